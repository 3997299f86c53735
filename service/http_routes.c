/*
 * http_routes.c: the route table (http.h) and the checks that need only
 * a request's headers: shutdown, the Host (without a token), the token,
 * the route, the method, the content type and a declared length over the
 * route's limit; then the route's handler, once the body is complete.
 */
#include "http.h"

#include <arpa/inet.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

/* ---- early checks -------------------------------------------------------- */

static int token_ok(struct MHD_Connection *c)
{
    if (lrd_cfg.token == NULL)
        return 1;
    const char *h = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                MHD_HTTP_HEADER_AUTHORIZATION);
    if (h == NULL)
        return 0;
    while (*h == ' ')
        h++;
    if (strncasecmp(h, "Bearer ", 7) != 0)
        return 0;
    h += 7;
    while (*h == ' ')
        h++;
    size_t n = strlen(h);
    while (n > 0 && (h[n - 1] == ' ' || h[n - 1] == '\t'))
        n--;
    return lrd_secret_equal(h, n, lrd_cfg.token, strlen(lrd_cfg.token));
}

/* Whether `name` (n bytes) is one of --allow-host's names (lowercase,
 * comma-separated), case aside. */
static int allowed_name(const char *name, size_t n)
{
    const char *p = lrd_cfg.allow_host;
    while (*p != '\0') {
        size_t len = strcspn(p, ",");
        if (len == n && strncasecmp(p, name, n) == 0)
            return 1;
        p += len;
        if (*p == ',')
            p++;
    }
    return 0;
}

/* Without a token, whether the request's Host header names this server
 * in a way a web page cannot choose: an IP address literal (IPv4, or IPv6
 * in brackets), localhost, or a name of --allow-host, with any port.  A
 * page that rebinds its own name to 127.0.0.1 (DNS rebinding) is
 * same-origin with the daemon, but its requests still say its name.  No
 * Host at all (HTTP/1.0; MHD refuses HTTP/1.1 without one) is no
 * browser's.  With a token, the token guards and any Host goes. */
static int host_ok(struct MHD_Connection *c, const char **host)
{
    *host = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                        MHD_HTTP_HEADER_HOST);
    if (lrd_cfg.token != NULL || *host == NULL || (*host)[0] == '\0')
        return 1;
    const char *h = *host, *end;
    char addr[64];
    size_t n;
    if (h[0] == '[') {
        end = strchr(h, ']');
        if (end == NULL)
            return 0;
        n = (size_t)(end - h - 1);
        if (n == 0 || n >= sizeof addr)
            return 0;
        memcpy(addr, h + 1, n);
        addr[n] = '\0';
        struct in6_addr a6;
        if (inet_pton(AF_INET6, addr, &a6) != 1)
            return 0;
        end++;
    } else {
        n = strcspn(h, ":");
        end = h + n;
        struct in_addr a4;
        int ip = 0;
        if (n > 0 && n < sizeof addr) {
            memcpy(addr, h, n);
            addr[n] = '\0';
            ip = inet_pton(AF_INET, addr, &a4) == 1;
        }
        /* A name may end in the root's dot ("localhost."): the same name. */
        size_t m = n > 0 && h[n - 1] == '.' ? n - 1 : n;
        if (!ip && !(m == 9 && strncasecmp(h, "localhost", 9) == 0) &&
            !(m > 0 && allowed_name(h, m)))
            return 0;
    }
    /* Then nothing, or a port. */
    if (*end == '\0')
        return 1;
    return *end == ':' && end[1] != '\0' &&
           strspn(end + 1, "0123456789") == strlen(end + 1);
}

static int json_content_type(struct MHD_Connection *c)
{
    const char *ct = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                 MHD_HTTP_HEADER_CONTENT_TYPE);
    if (ct == NULL)
        return 0;
    while (*ct == ' ')
        ct++;
    static const char want[] = "application/json";
    if (strncasecmp(ct, want, sizeof want - 1) != 0)
        return 0;
    char next = ct[sizeof want - 1];
    return next == '\0' || next == ';' || next == ' ' || next == '\t';
}

static const route routes[] = {
    {"GET", "/healthz", lrd_do_health, 1, 0},
    {"GET", "/metrics", lrd_do_metrics, 0, 0},
    {"GET", "/v1/scenes", lrd_do_scenes, 0, 0},
    {"GET", "/v1/lenses", lrd_do_lenses, 0, 0},
    {"POST", "/v1/render", lrd_do_render, 0, 1},
    {"POST", "/v1/jobs", lrd_do_submit, 0, 1},
    {"GET", "/v1/jobs/{id}", lrd_do_job, 0, 0},
    {"DELETE", "/v1/jobs/{id}", lrd_do_job_delete, 0, 0},
    {"GET", "/v1/jobs/{id}/image", lrd_do_job_image, 0, 0},
    {"GET", "/v1/jobs/{id}/plan", lrd_do_job_plan, 0, 0},
    {"GET", "/v1/options", lrd_do_options, 0, 0},
    {"GET", "/", lrd_do_ui, 1, 0},
    {"GET", "/ui/page.js", lrd_do_ui, 1, 0},
    {"GET", "/ui/page.css", lrd_do_ui, 1, 0},
    {"GET", "/v1/jobs", lrd_do_jobs_list, 0, 0},
    {"PUT", "/v1/assets/{hash}", lrd_do_asset_put, 0, 2},
    {"GET", "/v1/assets/{hash}", lrd_do_asset_get, 0, 0},
};
#define N_ROUTES (sizeof routes / sizeof routes[0])

/* The largest body the route takes. */
uint64_t lrd_body_limit(const req *r)
{
    return r->route != NULL && r->route->body == 2 ? lrd_cfg.max_asset
                                                   : lrd_cfg.max_body;
}

/* Whether `url` matches `pattern`; an {id} segment goes to id[33]. */
static int match(const char *pattern, const char *url, char id[33])
{
    while (*pattern != '\0') {
        if (strncmp(pattern, "{hash}", 6) == 0) {
            size_t n = strcspn(url, "/");
            if (n == 0 || n > 64)
                return 0;
            pattern += 6;
            url += n;
        } else if (strncmp(pattern, "{id}", 4) == 0) {
            size_t n = strcspn(url, "/");
            if (n == 0 || n > 32)
                return 0;
            memcpy(id, url, n);
            id[n] = '\0';
            pattern += 4;
            url += n;
        } else if (*pattern++ != *url++) {
            return 0;
        }
    }
    return *url == '\0';
}

static int method_is(const route *rt, const char *method)
{
    return strcmp(rt->method, method) == 0 ||
           (strcmp(method, "HEAD") == 0 && strcmp(rt->method, "GET") == 0);
}

/* Finds the route of `method` and `url`.  Returns it, or NULL with *known
 * set when the path exists with other methods (listed in allow[], the
 * Allow header) and *open when that path needs no token. */
static const route *find_route(const char *method, const char *url, char id[33],
                               int *known, int *open, char *allow, size_t cap)
{
    const route *found = NULL;
    size_t used = 0;
    *known = *open = 0;
    allow[0] = '\0';
    for (size_t i = 0; i < N_ROUTES; i++) {
        if (!match(routes[i].pattern, url, id))
            continue;
        *known = 1;
        *open |= routes[i].open;
        int n = snprintf(allow + used, cap - used, "%s%s%s", used ? ", " : "",
                         routes[i].method,
                         strcmp(routes[i].method, "GET") == 0 ? ", HEAD" : "");
        if (n > 0 && (size_t)n < cap - used)
            used += (size_t)n;
        if (found == NULL && method_is(&routes[i], method))
            found = &routes[i];
    }
    return found;
}

/* The checks that need only the headers.  Returns 1 when a response has
 * been queued (or the connection must close), 0 to go on. */
int lrd_route_early(struct MHD_Connection *c, req *r, const char *url,
                    enum MHD_Result *result)
{
    lrd_err e;
    char allow[64], id[33] = "", shown[201];
    int known = 0, open = 0;
    const char *host = NULL;
    r->route = find_route(r->method, url, id, &known, &open, allow,
                          sizeof allow);
    if (known)
        snprintf(r->job_id, sizeof r->job_id, "%s", id);

    if (lrd_shutting_down()) {
        lrd_fail(&e, 503, "shutting_down", NULL, "the server is shutting down");
        e.retry_after = 1;
    } else if (strcmp(url, "/healthz") != 0 && !host_ok(c, &host)) {
        /* The Host as sent, up to 200 bytes, printable ASCII (a name is
         * punycode; a byte cut from UTF-8 would break the JSON). */
        size_t k = 0;
        for (; host[k] != '\0' && k + 1 < sizeof shown; k++)
            shown[k] = host[k] >= 0x20 && host[k] < 0x7f ? host[k] : '?';
        shown[k] = '\0';
        lrd_fail(&e, 403, "host_not_allowed", NULL,
                 "the Host '%s' is not allowed: without --token-file "
                 "this server answers only to requests for an IP address "
                 "or localhost (against DNS rebinding); start it with "
                 "--allow-host NAME for a name it is reached by, or with "
                 "--token-file",
                 shown);
    } else if (!open && !token_ok(c)) {
        lrd_fail(&e, 401, "unauthorized", NULL,
                 "this server needs the header 'Authorization: Bearer "
                 "TOKEN' with the right token");
    } else if (!known) {
        lrd_fail(&e, 404, "not_found", NULL, "there is no route %s %s",
                 r->method, r->path);
    } else if (r->route == NULL) {
        lrd_fail(&e, 405, "method_not_allowed", NULL,
                 "%s does not allow %s (allowed: %s)", r->path, r->method,
                 allow);
    } else if (r->route->body == 1 && !json_content_type(c)) {
        lrd_fail(&e, 415, "unsupported_media_type", NULL,
                 "the body must be sent with 'Content-Type: "
                 "application/json'");
    } else {
        const char *cl = MHD_lookup_connection_value(
            c, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
        uint64_t n = 0;
        if (cl != NULL && lrd_parse_u64(cl, 0, &n) == 0 &&
            n > lrd_body_limit(r)) {
            lrd_fail(&e, 413, "body_too_large", NULL,
                     "the body is %llu bytes, more than the limit of %llu "
                     "(%s)",
                     (unsigned long long)n,
                     (unsigned long long)lrd_body_limit(r),
                     r->route->body == 2 ? "--max-asset-bytes" : "--max-body");
        } else {
            return 0;
        }
    }
    /* Only an existing job's route names a job in the answer. */
    if (r->route == NULL || strstr(r->route->pattern, "{id}") == NULL)
        r->job_id[0] = '\0';
    r->answered = 1;
    *result = lrd_send_error(c, r, &e, e.http == 405 ? allow : NULL);
    return 1;
}

enum MHD_Result lrd_route_dispatch(struct MHD_Connection *c, req *r)
{
    if (r->too_large) {
        lrd_err e;
        lrd_fail(&e, 413, "body_too_large", NULL,
                 "the body is more than the limit of %llu bytes (%s)",
                 (unsigned long long)lrd_body_limit(r),
                 r->route->body == 2 ? "--max-asset-bytes" : "--max-body");
        return lrd_send_error(c, r, &e, NULL);
    }
    return r->route->handler(c, r);
}
