/*
 * http.c: the HTTP side of lensrayd on libmicrohttpd (MHD).
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
 * headers, come shutdown (503), the token (401), the route (404), the
 * method (405), the content type (415) and a declared Content-Length over
 * the limit (413), so a refused request never uploads its body.  Bodies
 * are collected up to --max-body; the JSON is only looked at when it is
 * complete.
 */
#include "lensrayd.h"

#include <microhttpd.h>

#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <poll.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <unistd.h>

typedef struct req req;
typedef struct route route;

/* One request, owned by MHD's context pointer. */
struct req {
    double t0;
    char method[16];
    char path[200];   /* for the log, escaped */
    const route *route; /* NULL until the early checks found one */
    char job_id[33];  /* from the URL or of the job created, for the log */
    char *body;       /* malloc'ed; NUL-terminated */
    size_t len, cap;
    int too_large;    /* the body outgrew --max-body; the rest is dropped */
    uint64_t dropped;
    int answered;     /* a response was queued on the first call */
    int status;       /* of the response queued, for the log */
    uint64_t bytes;   /* body bytes of that response */
};

static struct {
    struct MHD_Daemon *d;
    MHD_socket quiesced_fd;
    atomic_long in_flight;
    atomic_int shutting_down;
} http = {.quiesced_fd = MHD_INVALID_SOCKET};

/* Set by a connection thread just before it returns MHD_NO on purpose
 * (its client left), so that the logger drops MHD's "internal error"
 * message for that close; MHD logs it from the same thread. */
static _Thread_local int closing_on_purpose;

/* MHD's own messages (bind failures, resource limits) go to stderr with
 * the daemon's prefix. */
static void mhd_log(void *cls, const char *fmt, va_list ap)
{
    (void)cls;
    if (closing_on_purpose) {
        closing_on_purpose = 0;
        return;
    }
    char msg[512];
    vsnprintf(msg, sizeof msg, fmt, ap);
    size_t n = strlen(msg);
    while (n > 0 && msg[n - 1] == '\n')
        msg[--n] = '\0';
    fprintf(stderr, "lensrayd: libmicrohttpd: %s\n", msg);
}

int lrd_shutting_down(void) { return atomic_load(&http.shutting_down); }
long lrd_http_in_flight(void) { return atomic_load(&http.in_flight); }

/* ---- responses ----------------------------------------------------------- */

/* Extra headers as name/value pairs, ended by NULL. */
static enum MHD_Result queue(struct MHD_Connection *c, req *r, int status,
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
static enum MHD_Result send_text(struct MHD_Connection *c, req *r,
                                 int status, const char *ctype, char *body,
                                 size_t len, const char *const *hdrs)
{
    if (body == NULL)
        return MHD_NO;
    struct MHD_Response *resp =
        MHD_create_response_from_buffer(len, body, MHD_RESPMEM_MUST_FREE);
    if (resp == NULL) {
        free(body);
        return MHD_NO;
    }
    return queue(c, r, status, resp, len, ctype, hdrs);
}

static enum MHD_Result send_json(struct MHD_Connection *c, req *r,
                                 int status, char *json,
                                 const char *const *hdrs)
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
    return send_text(c, r, status, "application/json", nl, len + 1, hdrs);
}

static enum MHD_Result send_error(struct MHD_Connection *c, req *r,
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
    return send_json(c, r, status, lrd_err_json(e), hdrs);
}

static void release_blob(void *cls)
{
    lrd_blob_release(cls);
}

/* Sends an encoded image; takes over the blob reference. */
static enum MHD_Result send_image(struct MHD_Connection *c, req *r,
                                  lrd_blob *img, lr_format fmt,
                                  const lr_render_stats *st)
{
    struct MHD_Response *resp =
        MHD_create_response_from_buffer_with_free_callback_cls(
            lrd_blob_len(img), (void *)lrd_blob_data(img), release_blob,
            img);
    if (resp == NULL) {
        lrd_blob_release(img);
        return MHD_NO;
    }
    char secs[32], rays[24], samples[24], disp[96], plan[160];
    snprintf(secs, sizeof secs, "%.6f", st->seconds);
    snprintf(rays, sizeof rays, "%llu", (unsigned long long)st->rays);
    snprintf(samples, sizeof samples, "%llu",
             (unsigned long long)st->samples);
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
    const char *hdrs[] = {"X-Lensray-Render-Seconds", secs,
                          "X-Lensray-Rays",           rays,
                          "X-Lensray-Samples",        samples,
                          "X-Lensray-Plan",           plan,
                          "Content-Disposition",      disp,
                          NULL};
    return queue(c, r, 200, resp, lrd_blob_len(img), lr_format_mime(fmt),
                 hdrs);
}

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

/* ---- handlers ------------------------------------------------------------ */

/* True if the peer has closed its side of the connection. */
static int client_gone(int fd)
{
    if (fd < 0)
        return 0;
    struct pollfd p = {.fd = fd, .events = POLLIN | POLLRDHUP};
    if (poll(&p, 1, 0) <= 0)
        return 0;
    if (p.revents & (POLLRDHUP | POLLHUP | POLLERR | POLLNVAL))
        return 1;
    if (p.revents & POLLIN) {
        /* Readable: either a pipelined request (still there) or EOF. */
        char b;
        ssize_t n = recv(fd, &b, 1, MSG_PEEK | MSG_DONTWAIT);
        return n == 0;
    }
    return 0;
}

/* The request's Idempotency-Key into key[]: "" without one.  0, or -1
 * with *e (422) for a key that is empty, too long or not printable ASCII
 * without spaces. */
static int idempotency_key(struct MHD_Connection *c, char key[LRD_KEY_MAX + 1],
                           lrd_err *e)
{
    const char *k = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                "Idempotency-Key");
    key[0] = '\0';
    if (k == NULL)
        return 0;
    size_t n = strlen(k);
    int ok = n > 0 && n <= LRD_KEY_MAX;
    for (size_t i = 0; ok && i < n; i++)
        ok = k[i] > ' ' && k[i] < 127;
    if (!ok)
        return lrd_fail(e, 422, "invalid_value", NULL,
                        "the Idempotency-Key header must be 1 to %d "
                        "printable ASCII characters without spaces",
                        LRD_KEY_MAX);
    memcpy(key, k, n + 1);
    return 0;
}

/* Parses the body and queues its job, or finds the job an earlier
 * request with the same Idempotency-Key made.  NULL after an error
 * answer was queued in *result. */
static lrd_job *submit(struct MHD_Connection *c, req *r, int sync,
                       int *existing, enum MHD_Result *result)
{
    lrd_err e;
    char key[LRD_KEY_MAX + 1];
    unsigned char hash[32];
    lrd_job_spec spec;
    lrd_job *job = NULL;
    if (idempotency_key(c, key, &e) != 0 ||
        lrd_api_parse_job(r->body, r->len, &spec, &e) != 0) {
        *result = send_error(c, r, &e, NULL);
        return NULL;
    }
    lrd_sha256(r->body ? r->body : "", r->len, hash);
    if (lrd_jobs_submit(&spec, sync, key, hash, &job, existing, &e) != 0) {
        *result = send_error(c, r, &e, NULL);
        return NULL;
    }
    snprintf(r->job_id, sizeof r->job_id, "%s", lrd_job_id(job));
    return job;
}

static enum MHD_Result do_render(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    int existing = 0;
    lrd_job *job = submit(c, r, 1, &existing, &result);
    if (job == NULL)
        return result;
    snprintf(r->job_id, sizeof r->job_id, "%s", lrd_job_id(job));

    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD);
    int fd = ci != NULL ? ci->connect_fd : -1;
    /* No idle timeout while the render runs: the client is waiting, not
     * idle.  Setting the timeout again afterwards restarts its clock (MHD
     * documents this when the previous value was zero), so the render's
     * duration can never count as idleness and close the connection
     * before the image goes out, whatever MHD's version measures. */
    MHD_set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT, 0u);
    while (!lrd_job_wait(job, 0.1)) {
        if (client_gone(fd)) {
            /* A render with an Idempotency-Key goes on for the retry
             * that will come; the others stop. */
            if (!lrd_job_keyed(job))
                lrd_job_cancel(job, LRD_CANCEL_DISCONNECT);
            lrd_job_release(job);
            r->status = 499;
            closing_on_purpose = 1;
            return MHD_NO; /* closes the connection */
        }
    }
    MHD_set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT,
                              (unsigned)lrd_cfg.conn_timeout);
    lrd_job_result res;
    lrd_job_result_get(job, &res);
    lrd_job_release(job);
    if (res.state == LRD_DONE && res.image != NULL)
        return send_image(c, r, res.image, res.format, &res.stats);
    lrd_blob_release(res.image);
    return send_error(c, r, &res.err, NULL);
}

static enum MHD_Result do_submit(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    int existing = 0;
    lrd_job *job = submit(c, r, 0, &existing, &result);
    if (job == NULL)
        return result;
    lrd_job_release(job);
    char href[48];
    snprintf(href, sizeof href, "/v1/jobs/%s", r->job_id);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", r->job_id);
    cJSON_AddStringToObject(o, "status", "queued");
    cJSON_AddStringToObject(o, "href", href);
    char *json = lrd_json_print(o);
    cJSON_Delete(o);
    /* A retry gets the first answer again, and is told so. */
    const char *hdrs[] = {MHD_HTTP_HEADER_LOCATION, href,
                          existing ? "Idempotent-Replayed" : NULL, "true",
                          NULL};
    return send_json(c, r, 202, json, hdrs);
}

static lrd_job *find_or_404(struct MHD_Connection *c, req *r,
                            enum MHD_Result *result)
{
    lrd_job *j = lrd_is_job_id(r->job_id) ? lrd_jobs_find(r->job_id) : NULL;
    if (j == NULL) {
        lrd_err e;
        lrd_fail(&e, 404, "job_not_found", NULL,
                 "there is no job \"%s\" (finished jobs are kept for %g "
                 "seconds)",
                 r->job_id, lrd_cfg.job_ttl);
        r->job_id[0] = '\0';
        *result = send_error(c, r, &e, NULL);
    }
    return j;
}

/* A whole number in [lo, hi] from query argument `name`; *out keeps its
 * value when the argument is absent.  0, or -1 with *e (422). */
static int query_long(struct MHD_Connection *c, const char *name, long lo,
                      long hi, long *out, lrd_err *e)
{
    const char *v = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND,
                                                name);
    uint64_t n = 0;
    if (v == NULL)
        return 0;
    if (lrd_parse_u64(v, 0, &n) != 0 || n < (uint64_t)lo || n > (uint64_t)hi)
        return lrd_fail(e, 422, "invalid_value", name,
                        "%s must be a whole number from %ld to %ld, got "
                        "\"%.40s\"", name, lo, hi, v);
    *out = (long)n;
    return 0;
}

/* The first query parameter a route does not know, or one that came
 * twice (?status=done&status=failed would list done jobs only, as if the
 * second were not there). */
typedef struct query_check {
    const char *const *known;
    size_t n_known;
    unsigned seen;  /* a bit per known parameter */
    int twice;      /* the bad one came twice, rather than being unknown */
    char bad[64];
} query_check;

static enum MHD_Result check_arg(void *cls, enum MHD_ValueKind kind,
                                 const char *key, const char *value)
{
    (void)kind;
    (void)value;
    query_check *q = cls;
    if (q->bad[0] != '\0')
        return MHD_YES;
    for (size_t i = 0; i < q->n_known; i++)
        if (key != NULL && strcmp(key, q->known[i]) == 0) {
            q->twice = (q->seen >> i) & 1u;
            q->seen |= 1u << i;
            if (q->twice)
                snprintf(q->bad, sizeof q->bad, "%s", key);
            return MHD_YES;
        }
    snprintf(q->bad, sizeof q->bad, "%s", key != NULL && key[0] ? key : "(empty)");
    return MHD_YES;
}

/* Refuses (422) a query parameter that is not one of `known` (`list`
 * names them for the message), or one given twice, rather than ignoring
 * it: a misspelt filter would list everything, a misspelt ?wait would
 * answer at once.  0, or -1 with *e filled. */
static int check_query(struct MHD_Connection *c, const char *const *known,
                       size_t n_known, const char *list, lrd_err *e)
{
    query_check q = {known, n_known, 0, 0, ""};
    MHD_get_connection_values(c, MHD_GET_ARGUMENT_KIND, check_arg, &q);
    if (q.twice)
        return lrd_fail(e, 422, "invalid_value", q.bad,
                        "the query parameter \"%s\" is given twice; give it "
                        "once", q.bad);
    if (q.bad[0] != '\0')
        return lrd_fail(e, 422, "invalid_value", NULL,
                        "unknown query parameter \"%s\" (expected %s)", q.bad,
                        list);
    return 0;
}

static enum MHD_Result do_job(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    lrd_err e;
    long wait = -1;
    static const char *const known[] = {"wait"};
    /* ?wait=SECONDS: answer when the status changes (or after that long),
     * so that a client follows a job without polling. */
    if (check_query(c, known, 1, "wait", &e) != 0 ||
        query_long(c, "wait", 0, 60, &wait, &e) != 0) {
        r->job_id[0] = '\0';
        return send_error(c, r, &e, NULL);
    }
    lrd_job *j = find_or_404(c, r, &result);
    if (j == NULL)
        return result;
    lrd_job_result now;
    lrd_job_result_get(j, &now);
    lrd_blob_release(now.image);
    /* A finished job changes no more: answer at once. */
    if (wait > 0 && now.state < LRD_DONE) {
        MHD_set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT, 0u);
        lrd_job_wait_change(j, now.state, (double)wait);
        MHD_set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT,
                                  (unsigned)lrd_cfg.conn_timeout);
    }
    char *json = lrd_job_status_json(j);
    lrd_job_release(j);
    return send_json(c, r, 200, json, NULL);
}

static enum MHD_Result do_job_delete(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    lrd_job *j = find_or_404(c, r, &result);
    if (j == NULL)
        return result;
    lrd_job_result before;
    lrd_job_result_get(j, &before);
    lrd_blob_release(before.image);
    if (before.state >= LRD_DONE) {
        /* Deleting a finished job frees its image at once. */
        char *json = lrd_job_status_json(j);
        lrd_job_forget(j);
        lrd_job_release(j);
        return send_json(c, r, 200, json, NULL);
    }
    /* A running render stops at its next tile; waiting a moment lets the
     * answer say "cancelled" rather than "running". */
    int status = 200;
    if (lrd_job_cancel(j, LRD_CANCEL_USER) == LRD_RUNNING &&
        !lrd_job_wait(j, 5.0))
        status = 202;
    char *json = lrd_job_status_json(j);
    lrd_job_release(j);
    return send_json(c, r, status, json, NULL);
}

static enum MHD_Result do_job_image(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    lrd_job *j = find_or_404(c, r, &result);
    if (j == NULL)
        return result;
    lrd_job_result res;
    lrd_job_result_get(j, &res);
    lrd_job_release(j);
    if (res.state == LRD_DONE && res.image != NULL)
        return send_image(c, r, res.image, res.format, &res.stats);
    lrd_blob_release(res.image);
    lrd_err e;
    if (res.state == LRD_FAILED)
        lrd_fail(&e, 409, "job_failed", res.err.path,
                 "the job failed, so it has no image: %s", res.err.message);
    else if (res.state == LRD_CANCELLED)
        lrd_fail(&e, 409, "job_cancelled", NULL,
                 "the job was cancelled, so it has no image");
    else {
        lrd_fail(&e, 409, "not_ready",
                 NULL, "the job is %s; its image is not ready yet",
                 lrd_state_name(res.state));
        e.retry_after = 1;
    }
    return send_error(c, r, &e, NULL);
}

static enum MHD_Result do_health(struct MHD_Connection *c, req *r)
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
    return send_json(c, r, 200, json, NULL);
}

static enum MHD_Result do_metrics(struct MHD_Connection *c, req *r)
{
    size_t len = 0;
    char *text = lrd_metrics_text(&len);
    return send_text(c, r, 200, "text/plain; version=0.0.4; charset=utf-8",
                     text, len, NULL);
}

static enum MHD_Result do_scenes(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    char *json = lrd_api_scenes_json(&e);
    if (json == NULL)
        return send_error(c, r, &e, NULL);
    return send_json(c, r, 200, json, NULL);
}

/* The shipped lenses (lenses/) with their first-order data and real chief
 * rays at 0, 10 and 20 degrees, at the d line (lr_lenses_describe). */
static enum MHD_Result do_lenses(struct MHD_Connection *c, req *r)
{
    static const double angles[] = {0, 10, 20};
    lr_error le;
    char *json = NULL;
    if (lr_lenses_describe(angles, 3, 587.5618, &json, &le) != LR_OK) {
        lrd_err e;
        lrd_fail_lr(&e, &le, NULL, 0);
        return send_error(c, r, &e, NULL);
    }
    return send_json(c, r, 200, json, NULL);
}

static enum MHD_Result do_options(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    char *json = lrd_options_json(&e);
    if (json == NULL)
        return send_error(c, r, &e, NULL);
    return send_json(c, r, 200, json, NULL);
}

static enum MHD_Result do_job_plan(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    lrd_job *j = find_or_404(c, r, &result);
    if (j == NULL)
        return result;
    lrd_err e;
    char *json = lrd_job_plan_json(j, &e);
    lrd_job_release(j);
    if (json == NULL)
        return send_error(c, r, &e, NULL);
    return send_json(c, r, 200, json, NULL);
}

/* The page's files (ui.c).  They are open: the page must load before it
 * can ask for the token, and it holds no secret.  The policy keeps it to
 * its own files and this server, as it is written to be. */
static enum MHD_Result do_ui(struct MHD_Connection *c, req *r)
{
    /* The route matched the path exactly, so the log's copy is it. */
    const lrd_ui_file *f = lrd_ui_find(r->path);
    if (f == NULL) {
        lrd_err e;
        lrd_fail(&e, 404, "not_found", NULL,
                 "there is no route %s %s (the page is off: --no-ui)",
                 r->method, r->path);
        return send_error(c, r, &e, NULL);
    }
    struct MHD_Response *resp = MHD_create_response_from_buffer(
        f->len, (void *)f->data, MHD_RESPMEM_PERSISTENT);
    const char *hdrs[] = {
        "Content-Security-Policy",
        "default-src 'none'; script-src 'self'; style-src 'self'; "
        "img-src 'self' blob: data:; connect-src 'self'; "
        "frame-ancestors 'none'",
        "X-Content-Type-Options", "nosniff", NULL};
    return queue(c, r, 200, resp, f->len, f->content_type, hdrs);
}

/* GET /v1/jobs?status=S&key=K&after=ID&limit=N: this daemon's jobs. */
static enum MHD_Result do_jobs_list(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    long limit = 100;
    int status = -1;
    /* An unknown parameter is refused, as an unknown key of a job is,
     * rather than ignored (a misspelt filter would list everything). */
    static const char *const known[] = {"status", "key", "after", "limit"};
    if (check_query(c, known, 4, "status, key, after, limit", &e) != 0)
        return send_error(c, r, &e, NULL);
    const char *s = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND,
                                                "status");
    if (s != NULL) {
        for (int i = 0; i < LRD_N_STATES; i++)
            if (strcmp(s, lrd_state_name((lrd_state)i)) == 0)
                status = i;
        if (status < 0) {
            lrd_fail(&e, 422, "invalid_value", "status",
                     "status must be one of queued, running, done, failed, "
                     "cancelled, got \"%.40s\"", s);
            return send_error(c, r, &e, NULL);
        }
    }
    if (query_long(c, "limit", 1, 1000, &limit, &e) != 0)
        return send_error(c, r, &e, NULL);
    const char *key = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND,
                                                  "key");
    const char *after = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND,
                                                    "after");
    if (after != NULL && !lrd_is_job_id(after)) {
        lrd_fail(&e, 422, "invalid_value", "after",
                 "after must be a job id (32 lowercase hex digits), got "
                 "\"%.40s\"", after);
        return send_error(c, r, &e, NULL);
    }
    size_t kn = key != NULL ? strlen(key) : 1;
    int key_ok = kn > 0 && kn <= LRD_KEY_MAX;
    for (size_t i = 0; key != NULL && key_ok && i < kn; i++)
        key_ok = key[i] > ' ' && key[i] < 127;
    if (!key_ok) {
        lrd_fail(&e, 422, "invalid_value", "key",
                 "key must be an Idempotency-Key: 1 to %d printable ASCII "
                 "characters without spaces", LRD_KEY_MAX);
        return send_error(c, r, &e, NULL);
    }
    int unknown_after = 0;
    char *json = lrd_jobs_list_json(status, key, after, limit, &unknown_after);
    if (json == NULL && unknown_after) {
        /* Not an empty page: that would tell a client paging through
         * that it has seen every job. */
        lrd_fail(&e, 404, "job_not_found", "after",
                 "after names no job this daemon has had lately (\"%s\"); "
                 "list from the start, without after", after);
        return send_error(c, r, &e, NULL);
    }
    if (json == NULL) {
        lrd_fail(&e, 503, "out_of_memory", NULL, "out of memory");
        return send_error(c, r, &e, NULL);
    }
    return send_json(c, r, 200, json, NULL);
}

/* The asset's name: the last segment of the path (the route's {hash}). */
static const char *asset_hex(const req *r)
{
    const char *slash = strrchr(r->path, '/');
    return slash ? slash + 1 : r->path;
}

/* PUT /v1/assets/{sha256}: 201 when stored now, 200 when it was there. */
static enum MHD_Result do_asset_put(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    int created = 0;
    if (lrd_asset_put(asset_hex(r), r->body ? r->body : "", r->len, &created,
                      &e) != 0)
        return send_error(c, r, &e, NULL);
    char *json = NULL;
    if (asprintf(&json, "{\"sha256\":\"%s\",\"bytes\":%zu,\"created\":%s}",
                 asset_hex(r), r->len, created ? "true" : "false") < 0)
        return MHD_NO;
    return send_json(c, r, created ? 201 : 200, json, NULL);
}

/* GET (and HEAD) /v1/assets/{sha256}: whether the asset is here. */
static enum MHD_Result do_asset_get(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    uint64_t size = 0;
    if (lrd_asset_stat(asset_hex(r), &size, &e) != 0)
        return send_error(c, r, &e, NULL);
    char *json = NULL;
    if (asprintf(&json, "{\"sha256\":\"%s\",\"bytes\":%llu}", asset_hex(r),
                 (unsigned long long)size) < 0)
        return MHD_NO;
    return send_json(c, r, 200, json, NULL);
}

/* ---- routes -------------------------------------------------------------- */

/* A route: a method, a path pattern of literal segments and "{id}" (one
 * segment of 1 to 32 characters, of any shape: an id of the wrong shape is
 * still this route, and gets "no such job" rather than "no such route";
 * "{hash}" likewise, of 1 to 64 characters, read by the handler from the
 * path), and its handler.  GET routes also answer HEAD (MHD sends no body).
 * docs/openapi.yaml lists the same routes; tests/api checks them. */
struct route {
    const char *method;
    const char *pattern;
    enum MHD_Result (*handler)(struct MHD_Connection *c, req *r);
    int open; /* served without the token (a load balancer's probe) */
    int body; /* takes a request body: 1 JSON, 2 any type up to
                 --max-asset-bytes */
};

static const route routes[] = {
    {"GET", "/healthz", do_health, 1, 0},
    {"GET", "/metrics", do_metrics, 0, 0},
    {"GET", "/v1/scenes", do_scenes, 0, 0},
    {"GET", "/v1/lenses", do_lenses, 0, 0},
    {"POST", "/v1/render", do_render, 0, 1},
    {"POST", "/v1/jobs", do_submit, 0, 1},
    {"GET", "/v1/jobs/{id}", do_job, 0, 0},
    {"DELETE", "/v1/jobs/{id}", do_job_delete, 0, 0},
    {"GET", "/v1/jobs/{id}/image", do_job_image, 0, 0},
    {"GET", "/v1/jobs/{id}/plan", do_job_plan, 0, 0},
    {"GET", "/v1/options", do_options, 0, 0},
    {"GET", "/", do_ui, 1, 0},
    {"GET", "/ui/page.js", do_ui, 1, 0},
    {"GET", "/ui/page.css", do_ui, 1, 0},
    {"GET", "/v1/jobs", do_jobs_list, 0, 0},
    {"PUT", "/v1/assets/{hash}", do_asset_put, 0, 2},
    {"GET", "/v1/assets/{hash}", do_asset_get, 0, 0},
};
#define N_ROUTES (sizeof routes / sizeof routes[0])

/* The largest body the route takes. */
static uint64_t body_limit(const req *r)
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
static const route *find_route(const char *method, const char *url,
                               char id[33], int *known, int *open,
                               char *allow, size_t cap)
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
        int n = snprintf(allow + used, cap - used, "%s%s%s",
                         used ? ", " : "", routes[i].method,
                         strcmp(routes[i].method, "GET") == 0 ? ", HEAD"
                                                              : "");
        if (n > 0 && (size_t)n < cap - used)
            used += (size_t)n;
        if (found == NULL && method_is(&routes[i], method))
            found = &routes[i];
    }
    return found;
}

/* The checks that need only the headers.  Returns 1 when a response has
 * been queued (or the connection must close), 0 to go on. */
static int early(struct MHD_Connection *c, req *r, const char *url,
                 enum MHD_Result *result)
{
    lrd_err e;
    char allow[64], id[33] = "";
    int known = 0, open = 0;
    r->route = find_route(r->method, url, id, &known, &open, allow,
                          sizeof allow);
    if (known)
        snprintf(r->job_id, sizeof r->job_id, "%s", id);

    if (lrd_shutting_down()) {
        lrd_fail(&e, 503, "shutting_down", NULL,
                 "the server is shutting down");
        e.retry_after = 1;
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
            n > body_limit(r)) {
            lrd_fail(&e, 413, "body_too_large", NULL,
                     "the body is %llu bytes, more than the limit of %llu "
                     "(%s)",
                     (unsigned long long)n, (unsigned long long)body_limit(r),
                     r->route->body == 2 ? "--max-asset-bytes"
                                         : "--max-body");
        } else {
            return 0;
        }
    }
    /* Only an existing job's route names a job in the answer. */
    if (r->route == NULL || strstr(r->route->pattern, "{id}") == NULL)
        r->job_id[0] = '\0';
    r->answered = 1;
    *result = send_error(c, r, &e, e.http == 405 ? allow : NULL);
    return 1;
}

static enum MHD_Result dispatch(struct MHD_Connection *c, req *r)
{
    if (r->too_large) {
        lrd_err e;
        lrd_fail(&e, 413, "body_too_large", NULL,
                 "the body is more than the limit of %llu bytes (%s)",
                 (unsigned long long)body_limit(r),
                 r->route->body == 2 ? "--max-asset-bytes" : "--max-body");
        return send_error(c, r, &e, NULL);
    }
    return r->route->handler(c, r);
}

/* The slowest body kept, in bytes a second, averaged from
 * --connection-timeout seconds after the headers.  The idle timeout alone
 * let a client that sends a byte every few seconds hold its connection,
 * and its thread, for as long as its declared body lasts: hours, and 64
 * such clients from a few addresses leave no connection for anyone. */
#define MIN_BODY_RATE 1024.0

static int body_too_slow(const req *r, size_t more)
{
    if (lrd_cfg.conn_timeout <= 0)
        return 0;
    double late = lrd_monotonic() - r->t0 - (double)lrd_cfg.conn_timeout;
    return late > 0 &&
           (double)(r->len + r->dropped + more) < late * MIN_BODY_RATE;
}

/* Copies a URL for the log with spaces, quotes and control characters
 * escaped, so that one request is always one parseable line. */
static void log_path(char *out, size_t n, const char *url)
{
    static const char hex[] = "0123456789ABCDEF";
    size_t o = 0;
    for (const unsigned char *p = (const unsigned char *)url;
         *p != '\0' && o + 4 < n; p++) {
        if (*p <= ' ' || *p >= 127 || *p == '"' || *p == '%') {
            out[o++] = '%';
            out[o++] = hex[*p >> 4];
            out[o++] = hex[*p & 15];
        } else {
            out[o++] = (char)*p;
        }
    }
    out[o] = '\0';
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c,
                                  const char *url, const char *method,
                                  const char *version,
                                  const char *upload_data,
                                  size_t *upload_data_size, void **con_cls)
{
    (void)cls;
    (void)version;
    req *r = *con_cls;
    if (r == NULL) {
        r = calloc(1, sizeof *r);
        if (r == NULL)
            return MHD_NO;
        *con_cls = r;
        atomic_fetch_add(&http.in_flight, 1);
        r->t0 = lrd_monotonic();
        snprintf(r->method, sizeof r->method, "%s", method);
        log_path(r->path, sizeof r->path, url);
        enum MHD_Result result = MHD_YES;
        if (early(c, r, url, &result))
            return result;
        return MHD_YES;
    }
    if (r->answered) {
        *upload_data_size = 0;
        return MHD_YES;
    }
    if (*upload_data_size > 0) {
        size_t n = *upload_data_size;
        *upload_data_size = 0;
        if (body_too_slow(r, n)) {
            /* Closed without an answer (the client is still sending);
             * the log says 408, as the status it earned. */
            r->status = 408;
            closing_on_purpose = 1;
            return MHD_NO;
        }
        if (r->too_large || !r->route->body) {
            /* Dropped, but not forever: a client that keeps streaming
             * long after the limit loses its connection. */
            r->dropped += n;
            return r->dropped > 4 * body_limit(r) + (1u << 20) ? MHD_NO
                                                               : MHD_YES;
        }
        if (r->len + n > body_limit(r)) {
            r->too_large = 1;
            free(r->body);
            r->body = NULL;
            r->len = r->cap = 0;
            r->dropped = n;
            return MHD_YES;
        }
        if (r->len + n + 1 > r->cap) {
            size_t cap = r->cap ? r->cap : 4096;
            while (cap < r->len + n + 1)
                cap *= 2;
            if (cap > body_limit(r) + 1)
                cap = body_limit(r) + 1;
            char *grown = realloc(r->body, cap);
            if (grown == NULL)
                return MHD_NO;
            r->body = grown;
            r->cap = cap;
        }
        memcpy(r->body + r->len, upload_data, n);
        r->len += n;
        r->body[r->len] = '\0';
        return MHD_YES;
    }
    return dispatch(c, r);
}

static void on_completed(void *cls, struct MHD_Connection *c, void **con_cls,
                         enum MHD_RequestTerminationCode toe)
{
    (void)cls;
    (void)c;
    req *r = *con_cls;
    if (r == NULL)
        return;
    *con_cls = NULL;
    /* A request that got no response was abandoned by its client (or cut
     * by the shutdown); it is logged as 499, as nginx does. */
    int status = r->status != 0 ? r->status : 499;
    double ms = (lrd_monotonic() - r->t0) * 1000.0;
    char line[512];
    int n = snprintf(line, sizeof line,
                     "lensrayd: %s %s %d %llu %.1fms %s%s\n", r->method,
                     r->path, status, (unsigned long long)r->bytes, ms,
                     r->job_id[0] ? r->job_id : "-",
                     toe == MHD_REQUEST_TERMINATED_COMPLETED_OK
                         ? ""
                         : " (connection closed early)");
    /* One write(2) per line keeps lines whole when threads log at once. */
    if (n > 0) {
        size_t len = (size_t)n < sizeof line ? (size_t)n : sizeof line - 1;
        ssize_t w = write(STDERR_FILENO, line, len);
        (void)w;
    }
    lrd_metrics_request(status);
    free(r->body);
    free(r);
    atomic_fetch_sub(&http.in_flight, 1);
}

/* ---- lifecycle ----------------------------------------------------------- */

const char *lrd_http_resolve(const char *bind, struct sockaddr_storage *sa,
                             int *v6)
{
    struct addrinfo hints, *ai = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE;
    int gai = getaddrinfo(bind, NULL, &hints, &ai);
    if (gai != 0 || ai == NULL)
        return gai != 0 ? gai_strerror(gai) : "no address";
    memset(sa, 0, sizeof *sa);
    memcpy(sa, ai->ai_addr, ai->ai_addrlen);
    *v6 = ai->ai_family == AF_INET6;
    freeaddrinfo(ai);
    return NULL;
}

int lrd_http_start(void)
{
    struct sockaddr_storage sa;
    int v6 = 0;
    /* main.c resolved it already, so this fails only if the name's
     * address went away in between. */
    const char *why = lrd_http_resolve(lrd_cfg.bind, &sa, &v6);
    if (why != NULL) {
        fprintf(stderr, "lensrayd: cannot use --bind %s: %s\n", lrd_cfg.bind,
                why);
        return -1;
    }
    if (v6)
        ((struct sockaddr_in6 *)&sa)->sin6_port = htons((uint16_t)lrd_cfg.port);
    else
        ((struct sockaddr_in *)&sa)->sin_port = htons((uint16_t)lrd_cfg.port);

    unsigned flags = MHD_USE_THREAD_PER_CONNECTION |
                     MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_ITC |
                     MHD_USE_ERROR_LOG | (v6 ? MHD_USE_IPv6 : 0);
    http.d = MHD_start_daemon(
        flags, (uint16_t)lrd_cfg.port, NULL, NULL, on_request, NULL,
        MHD_OPTION_EXTERNAL_LOGGER, mhd_log, NULL,
        MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&sa,
        MHD_OPTION_CONNECTION_LIMIT, (unsigned)lrd_cfg.max_connections,
        MHD_OPTION_PER_IP_CONNECTION_LIMIT, (unsigned)lrd_cfg.max_per_ip,
        MHD_OPTION_CONNECTION_MEMORY_LIMIT, (size_t)lrd_cfg.conn_memory,
        MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)lrd_cfg.conn_timeout,
        MHD_OPTION_NOTIFY_COMPLETED, on_completed, NULL,
        MHD_OPTION_LISTENING_ADDRESS_REUSE, 1u, MHD_OPTION_END);
    if (http.d == NULL) {
        fprintf(stderr, "lensrayd: cannot listen on %s port %ld (in use, or "
                        "not an address of this host?)\n",
                lrd_cfg.bind, lrd_cfg.port);
        return -1;
    }
    const union MHD_DaemonInfo *di =
        MHD_get_daemon_info(http.d, MHD_DAEMON_INFO_BIND_PORT);
    unsigned port = di != NULL ? di->port : (unsigned)lrd_cfg.port;
    char host[INET6_ADDRSTRLEN] = "";
    if (v6)
        inet_ntop(AF_INET6, &((struct sockaddr_in6 *)&sa)->sin6_addr, host,
                  sizeof host);
    else
        inet_ntop(AF_INET, &((struct sockaddr_in *)&sa)->sin_addr, host,
                  sizeof host);
    fprintf(stderr,
            "lensrayd: listening on http://%s%s%s:%u (scenes %s, %ld "
            "worker%s)\n",
            v6 ? "[" : "", host, v6 ? "]" : "", port, lrd_cfg.scenes_dir,
            lrd_cfg.workers, lrd_cfg.workers == 1 ? "" : "s");
    return 0;
}

void lrd_http_quiesce(void)
{
    atomic_store(&http.shutting_down, 1);
    if (http.d != NULL)
        http.quiesced_fd = MHD_quiesce_daemon(http.d);
    /* MHD no longer accepts, but the socket still listens, so new clients
     * would wait in the kernel's backlog until the end.  shutdown(2) makes
     * them be refused at once (a load balancer moves on) while the
     * descriptor stays valid until MHD_stop_daemon, as MHD requires. */
    if (http.quiesced_fd != MHD_INVALID_SOCKET)
        shutdown(http.quiesced_fd, SHUT_RDWR);
}

void lrd_http_stop(void)
{
    if (http.d != NULL)
        MHD_stop_daemon(http.d);
    http.d = NULL;
    /* The listening socket is ours to close once MHD has stopped. */
    if (http.quiesced_fd != MHD_INVALID_SOCKET)
        close(http.quiesced_fd);
    http.quiesced_fd = MHD_INVALID_SOCKET;
}
