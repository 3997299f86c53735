/*
 * http.h: the HTTP side of lensrayd on libmicrohttpd (MHD), as its files
 * share it.  Only service/http_*.c include it; the rest of the daemon
 * sees lrd_http_start, lrd_http_quiesce and lrd_http_stop (lensrayd.h).
 *
 *   http_server.c     lifecycle: the address, MHD started, quiesced and
 *                     stopped; MHD's own log messages
 *   http_transport.c  one request from its first call to its log line:
 *                     the body collected up to its limit, slow bodies cut
 *   http_routes.c     the route table; the checks that need only the
 *                     headers (shutdown, Host, token, route, method, content
 *                     type, declared length); dispatch to a handler
 *   http_respond.c    responses: JSON, text, errors, images
 *   http_query.c      query parameters: whole numbers, unknown or repeated
 *   http_jobs.c       the job handlers: render, submit, status, delete,
 *                     image, plan, list
 *   http_info.c       the other handlers: health, metrics, scenes, lenses,
 *                     options, the page, assets
 *
 * MHD runs one thread per connection (bounded by --max-connections and
 * --max-connections-per-ip), so a handler may block: POST /v1/render
 * queues its job on the worker pool and waits on the job's completion in
 * the connection's own thread, polling the socket meanwhile so that a
 * client that hangs up cancels its render.  Renders never run here.
 *
 * A request's state (struct req) lives in MHD's per-request context
 * pointer from the first call of the access handler to the
 * NOTIFY_COMPLETED callback, which logs the request and frees it.
 *
 * Checks happen as early as they can: on the first call, with only the
 * headers, come shutdown (503), without a token a Host that is no IP
 * address, localhost or --allow-host name (403), the token (401), the
 * route (404), the method (405), the content type (415) and a declared
 * Content-Length over the limit (413), so a refused request never uploads
 * its body.  Bodies are collected up to --max-body; the JSON is only
 * looked at when it is complete.
 */
#ifndef LENSRAYD_HTTP_H
#define LENSRAYD_HTTP_H

#include "lensrayd.h"

#include <microhttpd.h>

typedef struct req req;
typedef struct route route;

/* One request, owned by MHD's context pointer. */
struct req {
    double t0;
    char method[16];
    char path[200];     /* for the log, escaped */
    const route *route; /* NULL until the early checks found one */
    char job_id[33];    /* from the URL or of the job created, for the log */
    char *body;         /* malloc'ed; NUL-terminated */
    size_t len, cap;
    int too_large; /* the body outgrew --max-body; the rest is dropped */
    uint64_t dropped;
    int answered;   /* a response was queued on the first call */
    int status;     /* of the response queued, for the log */
    uint64_t bytes; /* body bytes of that response */
};

/* A handler answers a request whose route, token, content type and body
 * passed: it queues one response (lrd_send_*) and returns what that
 * returned, or MHD_NO to close the connection. */
typedef enum MHD_Result (*lrd_handler)(struct MHD_Connection *c, req *r);

/* A route: a method, a path pattern of literal segments and "{id}" (one
 * segment of 1 to 32 characters, of any shape: an id of the wrong shape is
 * still this route, and gets "no such job" rather than "no such route";
 * "{hash}" likewise, of 1 to 64 characters, read by the handler from the
 * path), and its handler.  GET routes also answer HEAD (MHD sends no body).
 * docs/openapi.yaml lists the same routes; tests/api checks them. */
struct route {
    const char *method;
    const char *pattern;
    lrd_handler handler;
    int open; /* served without the token (a load balancer's probe) */
    int body; /* takes a request body: 1 JSON, 2 any type up to
                 --max-asset-bytes */
};

/* Set by a connection thread just before it returns MHD_NO on purpose
 * (its client left), so that the logger drops MHD's "internal error"
 * message for that close; MHD logs it from the same thread
 * (http_transport.c). */
extern _Thread_local int lrd_http_closing_on_purpose;

/* ---- transport (http_transport.c) ---------------------------------------- */

/* MHD's access handler and its NOTIFY_COMPLETED callback: the request's
 * state made, its body collected, it dispatched; then logged and freed. */
enum MHD_Result lrd_http_on_request(void *cls, struct MHD_Connection *c,
                                    const char *url, const char *method,
                                    const char *version,
                                    const char *upload_data,
                                    size_t *upload_data_size, void **con_cls);
void lrd_http_on_completed(void *cls, struct MHD_Connection *c, void **con_cls,
                           enum MHD_RequestTerminationCode toe);

/* ---- routes (http_routes.c) ---------------------------------------------- */

/* The checks that need only the headers; they set r->route.  Returns 1
 * when a response has been queued in *result (or the connection must
 * close), 0 to go on. */
int lrd_route_early(struct MHD_Connection *c, req *r, const char *url,
                    enum MHD_Result *result);
/* The route's handler on a complete body, or 413 for a body that
 * outgrew its limit. */
enum MHD_Result lrd_route_dispatch(struct MHD_Connection *c, req *r);
/* The largest body the request's route takes. */
uint64_t lrd_body_limit(const req *r);

/* ---- responses (http_respond.c) ------------------------------------------ */

/* Each queues one response on `c`, records its status and length in *r
 * for the log, and returns MHD's result (MHD_NO when out of memory).
 * `hdrs` are extra headers as name/value pairs, ended by NULL. */

/* Queues `resp` (taken over, NULL gives MHD_NO) with `ctype`. */
enum MHD_Result lrd_send_response(struct MHD_Connection *c, req *r, int status,
                                  struct MHD_Response *resp, size_t body_len,
                                  const char *ctype, const char *const *hdrs);
/* Sends `body` (malloc'ed, taken over; NULL gives MHD_NO). */
enum MHD_Result lrd_send_text(struct MHD_Connection *c, req *r, int status,
                              const char *ctype, char *body, size_t len,
                              const char *const *hdrs);
/* Sends `json` (malloc'ed, taken over; NULL gives MHD_NO) with a final
 * newline. */
enum MHD_Result lrd_send_json(struct MHD_Connection *c, req *r, int status,
                              char *json, const char *const *hdrs);
/* Sends *e as JSON with its status (499, "the client left", as 409),
 * Retry-After, WWW-Authenticate for a 401, and Allow when `allow` is
 * not NULL. */
enum MHD_Result lrd_send_error(struct MHD_Connection *c, req *r,
                               const lrd_err *e, const char *allow);
/* Sends an encoded image with the render's statistics as headers; takes
 * over the blob reference. */
enum MHD_Result lrd_send_image(struct MHD_Connection *c, req *r, lrd_blob *img,
                               lr_format fmt, const lr_render_stats *st);

/* ---- query parameters (http_query.c) ------------------------------------- */

/* A whole number in [lo, hi] from query argument `name`; *out keeps its
 * value when the argument is absent.  0, or -1 with *e (422). */
int lrd_query_long(struct MHD_Connection *c, const char *name, long lo, long hi,
                   long *out, lrd_err *e);
/* Refuses (422) a query parameter that is not one of `known` (`list`
 * names them for the message), or one given twice.  0, or -1 with *e. */
int lrd_check_query(struct MHD_Connection *c, const char *const *known,
                    size_t n_known, const char *list, lrd_err *e);

/* ---- handlers (http_jobs.c, http_info.c) --------------------------------- */

enum MHD_Result lrd_do_render(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_submit(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_job(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_job_delete(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_job_image(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_job_plan(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_jobs_list(struct MHD_Connection *c, req *r);

enum MHD_Result lrd_do_health(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_metrics(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_scenes(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_lenses(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_options(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_ui(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_asset_put(struct MHD_Connection *c, req *r);
enum MHD_Result lrd_do_asset_get(struct MHD_Connection *c, req *r);

#endif
