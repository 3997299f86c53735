/*
 * http_respond.c: the daemon's responses (http.h): JSON, text, errors
 * as JSON with their headers, and encoded images with the render's
 * statistics; each recorded in the request for the log.
 */
#include "http.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Extra headers as name/value pairs, ended by NULL. */
enum MHD_Result lrd_send_response(struct MHD_Connection *c, req *r, int status,
                                  struct MHD_Response *resp, size_t body_len,
                                  const char *ctype, const char *const *hdrs)
{
    if (resp == NULL)
        return MHD_NO;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, ctype);
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    if (r->job_id[0] != '\0')
        MHD_add_response_header(resp, "X-Lensray-Job-Id", r->job_id);
    for (size_t i = 0; hdrs != NULL && hdrs[i] != NULL; i += 2)
        MHD_add_response_header(resp, hdrs[i], hdrs[i + 1]);
    /* While shutting down, no connection is kept for another request. */
    if (lrd_shutting_down())
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONNECTION, "close");
    enum MHD_Result ok = MHD_queue_response(c, (unsigned)status, resp);
    MHD_destroy_response(resp);
    r->status = status;
    r->bytes = strcmp(r->method, "HEAD") == 0 ? 0 : body_len;
    return ok;
}

/* Sends `body` (malloc'ed, taken over). */
enum MHD_Result lrd_send_text(struct MHD_Connection *c, req *r, int status,
                              const char *ctype, char *body, size_t len,
                              const char *const *hdrs)
{
    if (body == NULL)
        return MHD_NO;
    struct MHD_Response *resp = MHD_create_response_from_buffer(
        len, body, MHD_RESPMEM_MUST_FREE);
    if (resp == NULL) {
        free(body);
        return MHD_NO;
    }
    return lrd_send_response(c, r, status, resp, len, ctype, hdrs);
}

enum MHD_Result lrd_send_json(struct MHD_Connection *c, req *r, int status,
                              char *json, const char *const *hdrs)
{
    if (json == NULL)
        return MHD_NO;
    size_t len = strlen(json);
    /* A final newline keeps `curl` output tidy. */
    char *nl = realloc(json, len + 2);
    if (nl == NULL) {
        free(json);
        return MHD_NO;
    }
    nl[len] = '\n';
    nl[len + 1] = '\0';
    return lrd_send_text(c, r, status, "application/json", nl, len + 1, hdrs);
}

enum MHD_Result lrd_send_error(struct MHD_Connection *c, req *r,
                               const lrd_err *e, const char *allow)
{
    const char *hdrs[8];
    size_t n = 0;
    char retry[24];
    if (e->retry_after > 0) {
        snprintf(retry, sizeof retry, "%d", e->retry_after);
        hdrs[n++] = MHD_HTTP_HEADER_RETRY_AFTER;
        hdrs[n++] = retry;
    }
    if (e->http == 401) {
        hdrs[n++] = MHD_HTTP_HEADER_WWW_AUTHENTICATE;
        hdrs[n++] = "Bearer realm=\"lensrayd\"";
    }
    if (allow != NULL) {
        hdrs[n++] = MHD_HTTP_HEADER_ALLOW;
        hdrs[n++] = allow;
    }
    hdrs[n] = NULL;
    /* 499 is the log's name for "the client left"; it is never sent. */
    int status = e->http == 499 ? 409 : e->http;
    return lrd_send_json(c, r, status, lrd_err_json(e), hdrs);
}

static void release_blob(void *cls)
{
    lrd_blob_release(cls);
}

/* Sends an encoded image; takes over the blob reference. */
enum MHD_Result lrd_send_image(struct MHD_Connection *c, req *r, lrd_blob *img,
                               lr_format fmt, const lr_render_stats *st)
{
    struct MHD_Response *resp =
        MHD_create_response_from_buffer_with_free_callback_cls(
            lrd_blob_len(img), (void *)lrd_blob_data(img), release_blob, img);
    if (resp == NULL) {
        lrd_blob_release(img);
        return MHD_NO;
    }
    char secs[32], rays[24], samples[24], disp[96], plan[160];
    snprintf(secs, sizeof secs, "%.6f", st->seconds);
    snprintf(rays, sizeof rays, "%llu", (unsigned long long)st->rays);
    snprintf(samples, sizeof samples, "%llu", (unsigned long long)st->samples);
    double px = st->pixels ? (double)st->pixels : 1.0;
    snprintf(plan, sizeof plan,
             "lens_pixels=%.4f; chroma_pixels=%.4f; camera_rays=%llu; "
             "full_camera_rays=%llu; full_samples=%llu",
             (double)st->lens_pixels / px, (double)st->chroma_pixels / px,
             (unsigned long long)st->camera_rays,
             (unsigned long long)st->full_camera_rays,
             (unsigned long long)st->full_samples);
    snprintf(disp, sizeof disp, "inline; filename=\"%s%s\"", r->job_id,
             lr_format_extension(fmt));
    const char *hdrs[] = {"X-Lensray-Render-Seconds",
                          secs,
                          "X-Lensray-Rays",
                          rays,
                          "X-Lensray-Samples",
                          samples,
                          "X-Lensray-Plan",
                          plan,
                          "Content-Disposition",
                          disp,
                          NULL};
    return lrd_send_response(c, r, 200, resp, lrd_blob_len(img),
                             lr_format_mime(fmt), hdrs);
}
