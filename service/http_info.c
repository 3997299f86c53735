/*
 * http_info.c: the handlers that are not about one job (http.h): health,
 * metrics, the scenes, lenses and options, the page's files, and
 * content-addressed assets.
 */
#include "http.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum MHD_Result lrd_do_health(struct MHD_Connection *c, req *r)
{
    lrd_jobs_stats js;
    lrd_jobs_stats_get(&js);
    char *json = malloc(200);
    if (json == NULL)
        return MHD_NO;
    /* token_required lets the page ask for the token before its first
     * call rather than after a 401. */
    snprintf(json, 200,
             "{\"status\":\"ok\",\"version\":\"%s\",\"workers\":%ld,"
             "\"running\":%ld,\"queue_depth\":%ld,\"token_required\":%s}",
             LRD_VERSION, lrd_cfg.workers, js.running, js.queue_depth,
             lrd_cfg.token != NULL ? "true" : "false");
    return lrd_send_json(c, r, 200, json, NULL);
}

enum MHD_Result lrd_do_metrics(struct MHD_Connection *c, req *r)
{
    size_t len = 0;
    char *text = lrd_metrics_text(&len);
    return lrd_send_text(c, r, 200, "text/plain; version=0.0.4; charset=utf-8",
                         text, len, NULL);
}

enum MHD_Result lrd_do_scenes(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    char *json = lrd_api_scenes_json(&e);
    if (json == NULL)
        return lrd_send_error(c, r, &e, NULL);
    return lrd_send_json(c, r, 200, json, NULL);
}

/* The shipped lenses (lenses/) with their first-order data and real chief
 * rays at 0, 10 and 20 degrees, at the d line (lr_lenses_describe). */
enum MHD_Result lrd_do_lenses(struct MHD_Connection *c, req *r)
{
    static const double angles[] = {0, 10, 20};
    lr_error le;
    char *json = NULL;
    if (lr_lenses_describe(angles, 3, 587.5618, &json, &le) != LR_OK) {
        lrd_err e;
        lrd_fail_lr(&e, &le, NULL, NULL);
        return lrd_send_error(c, r, &e, NULL);
    }
    return lrd_send_json(c, r, 200, json, NULL);
}

enum MHD_Result lrd_do_options(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    char *json = lrd_options_json(&e);
    if (json == NULL)
        return lrd_send_error(c, r, &e, NULL);
    return lrd_send_json(c, r, 200, json, NULL);
}


/* The page's files (ui.c).  They are open: the page must load before it
 * can ask for the token, and it holds no secret.  The policy keeps it to
 * its own files and this server, as it is written to be. */
enum MHD_Result lrd_do_ui(struct MHD_Connection *c, req *r)
{
    /* The route matched the path exactly, so the log's copy is it. */
    const lrd_ui_file *f = lrd_ui_find(r->path);
    if (f == NULL) {
        lrd_err e;
        lrd_fail(&e, 404, "not_found", NULL,
                 "there is no route %s %s (the page is off: --no-ui)",
                 r->method, r->path);
        return lrd_send_error(c, r, &e, NULL);
    }
    struct MHD_Response *resp = MHD_create_response_from_buffer(
        f->len, (void *)f->data, MHD_RESPMEM_PERSISTENT);
    const char *hdrs[] = {
        "Content-Security-Policy",
        "default-src 'none'; script-src 'self'; style-src 'self'; "
        "img-src 'self' blob: data:; connect-src 'self'; "
        "frame-ancestors 'none'",
        "X-Content-Type-Options", "nosniff", NULL};
    return lrd_send_response(c, r, 200, resp, f->len, f->content_type, hdrs);
}


/* The asset's name: the last segment of the path (the route's {hash}). */
static const char *asset_hex(const req *r)
{
    const char *slash = strrchr(r->path, '/');
    return slash ? slash + 1 : r->path;
}

/* PUT /v1/assets/{sha256}: 201 when stored now, 200 when it was there. */
enum MHD_Result lrd_do_asset_put(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    int created = 0;
    if (lrd_asset_put(asset_hex(r), r->body ? r->body : "", r->len, &created,
                      &e) != 0)
        return lrd_send_error(c, r, &e, NULL);
    char *json = NULL;
    if (asprintf(&json, "{\"sha256\":\"%s\",\"bytes\":%zu,\"created\":%s}",
                 asset_hex(r), r->len, created ? "true" : "false") < 0)
        return MHD_NO;
    return lrd_send_json(c, r, created ? 201 : 200, json, NULL);
}

/* GET (and HEAD) /v1/assets/{sha256}: whether the asset is here. */
enum MHD_Result lrd_do_asset_get(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    uint64_t size = 0;
    if (lrd_asset_stat(asset_hex(r), &size, &e) != 0)
        return lrd_send_error(c, r, &e, NULL);
    char *json = NULL;
    if (asprintf(&json, "{\"sha256\":\"%s\",\"bytes\":%llu}", asset_hex(r),
                 (unsigned long long)size) < 0)
        return MHD_NO;
    return lrd_send_json(c, r, 200, json, NULL);
}
