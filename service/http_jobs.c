/*
 * http_jobs.c: the job handlers (http.h): POST /v1/render (waits for the
 * image, cancelling when the client leaves), POST /v1/jobs, and a job's
 * status, deletion, image and plan; GET /v1/jobs lists them.
 */
#include "http.h"

#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>

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
        *result = lrd_send_error(c, r, &e, NULL);
        return NULL;
    }
    lrd_sha256(r->body ? r->body : "", r->len, hash);
    if (lrd_jobs_submit(&spec, sync, key, hash, &job, existing, &e) != 0) {
        *result = lrd_send_error(c, r, &e, NULL);
        return NULL;
    }
    snprintf(r->job_id, sizeof r->job_id, "%s", lrd_job_id(job));
    return job;
}

enum MHD_Result lrd_do_render(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    int existing = 0;
    lrd_job *job = submit(c, r, 1, &existing, &result);
    if (job == NULL)
        return result;
    snprintf(r->job_id, sizeof r->job_id, "%s", lrd_job_id(job));

    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(
        c, MHD_CONNECTION_INFO_CONNECTION_FD);
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
            lrd_http_closing_on_purpose = 1;
            return MHD_NO; /* closes the connection */
        }
    }
    MHD_set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT,
                              (unsigned)lrd_cfg.conn_timeout);
    lrd_job_result res;
    lrd_job_result_get(job, &res);
    lrd_job_release(job);
    if (res.state == LRD_DONE && res.image != NULL)
        return lrd_send_image(c, r, res.image, res.format, &res.stats);
    lrd_blob_release(res.image);
    return lrd_send_error(c, r, &res.err, NULL);
}

enum MHD_Result lrd_do_submit(struct MHD_Connection *c, req *r)
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
    return lrd_send_json(c, r, 202, json, hdrs);
}

static lrd_job *find_or_404(struct MHD_Connection *c, req *r,
                            enum MHD_Result *result)
{
    lrd_job *j = lrd_is_job_id(r->job_id) ? lrd_jobs_find(r->job_id) : NULL;
    if (j == NULL) {
        lrd_err e;
        /* (The count and byte limits drop the oldest finished jobs
         * sooner: the time alone misled.) */
        lrd_fail(&e, 404, "job_not_found", NULL,
                 "there is no job \"%s\" (finished jobs are kept for up to "
                 "%g seconds, the oldest dropped sooner beyond %ld jobs or "
                 "--max-retained-bytes)",
                 r->job_id, lrd_cfg.job_ttl, lrd_cfg.max_finished);
        r->job_id[0] = '\0';
        *result = lrd_send_error(c, r, &e, NULL);
    }
    return j;
}

enum MHD_Result lrd_do_job(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    lrd_err e;
    long wait = -1;
    static const char *const known[] = {"wait"};
    /* ?wait=SECONDS: answer when the status changes (or after that long),
     * so that a client follows a job without polling. */
    if (lrd_check_query(c, known, 1, "wait", &e) != 0 ||
        lrd_query_long(c, "wait", 0, 60, &wait, &e) != 0) {
        r->job_id[0] = '\0';
        return lrd_send_error(c, r, &e, NULL);
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
    return lrd_send_json(c, r, 200, json, NULL);
}

enum MHD_Result lrd_do_job_delete(struct MHD_Connection *c, req *r)
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
        return lrd_send_json(c, r, 200, json, NULL);
    }
    /* A running render stops at its next tile; waiting a moment lets the
     * answer say "cancelled" rather than "running". */
    int status = 200;
    if (lrd_job_cancel(j, LRD_CANCEL_USER) == LRD_RUNNING &&
        !lrd_job_wait(j, 5.0))
        status = 202;
    char *json = lrd_job_status_json(j);
    lrd_job_release(j);
    return lrd_send_json(c, r, status, json, NULL);
}

enum MHD_Result lrd_do_job_image(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    lrd_job *j = find_or_404(c, r, &result);
    if (j == NULL)
        return result;
    lrd_job_result res;
    lrd_job_result_get(j, &res);
    lrd_job_release(j);
    if (res.state == LRD_DONE && res.image != NULL)
        return lrd_send_image(c, r, res.image, res.format, &res.stats);
    lrd_blob_release(res.image);
    lrd_err e;
    if (res.state == LRD_FAILED)
        lrd_fail(&e, 409, "job_failed", res.err.path,
                 "the job failed, so it has no image: %s", res.err.message);
    else if (res.state == LRD_CANCELLED)
        lrd_fail(&e, 409, "job_cancelled", NULL,
                 "the job was cancelled, so it has no image");
    else {
        lrd_fail(&e, 409, "not_ready", NULL,
                 "the job is %s; its image is not ready yet",
                 lrd_state_name(res.state));
        e.retry_after = 1;
    }
    return lrd_send_error(c, r, &e, NULL);
}

enum MHD_Result lrd_do_job_plan(struct MHD_Connection *c, req *r)
{
    enum MHD_Result result = MHD_NO;
    lrd_job *j = find_or_404(c, r, &result);
    if (j == NULL)
        return result;
    lrd_err e;
    char *json = lrd_job_plan_json(j, &e);
    lrd_job_release(j);
    if (json == NULL)
        return lrd_send_error(c, r, &e, NULL);
    return lrd_send_json(c, r, 200, json, NULL);
}

/* GET /v1/jobs?status=S&key=K&after=ID&limit=N: this daemon's jobs. */
enum MHD_Result lrd_do_jobs_list(struct MHD_Connection *c, req *r)
{
    lrd_err e;
    long limit = 100;
    int status = -1;
    /* An unknown parameter is refused, as an unknown key of a job is,
     * rather than ignored (a misspelt filter would list everything). */
    static const char *const known[] = {"status", "key", "after", "limit"};
    if (lrd_check_query(c, known, 4, "status, key, after, limit", &e) != 0)
        return lrd_send_error(c, r, &e, NULL);
    const char *s = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND,
                                                "status");
    if (s != NULL) {
        for (int i = 0; i < LRD_N_STATES; i++)
            if (strcmp(s, lrd_state_name((lrd_state)i)) == 0)
                status = i;
        if (status < 0) {
            lrd_fail(&e, 422, "invalid_value", "status",
                     "status must be one of queued, running, done, failed, "
                     "cancelled, got \"%.40s\"",
                     s);
            return lrd_send_error(c, r, &e, NULL);
        }
    }
    if (lrd_query_long(c, "limit", 1, 1000, &limit, &e) != 0)
        return lrd_send_error(c, r, &e, NULL);
    const char *key = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND,
                                                  "key");
    const char *after = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND,
                                                    "after");
    if (after != NULL && !lrd_is_job_id(after)) {
        lrd_fail(&e, 422, "invalid_value", "after",
                 "after must be a job id (32 lowercase hex digits), got "
                 "\"%.40s\"",
                 after);
        return lrd_send_error(c, r, &e, NULL);
    }
    size_t kn = key != NULL ? strlen(key) : 1;
    int key_ok = kn > 0 && kn <= LRD_KEY_MAX;
    for (size_t i = 0; key != NULL && key_ok && i < kn; i++)
        key_ok = key[i] > ' ' && key[i] < 127;
    if (!key_ok) {
        lrd_fail(&e, 422, "invalid_value", "key",
                 "key must be an Idempotency-Key: 1 to %d printable ASCII "
                 "characters without spaces",
                 LRD_KEY_MAX);
        return lrd_send_error(c, r, &e, NULL);
    }
    int unknown_after = 0;
    char *json = lrd_jobs_list_json(status, key, after, limit, &unknown_after);
    if (json == NULL && unknown_after) {
        /* Not an empty page: that would tell a client paging through
         * that it has seen every job. */
        lrd_fail(&e, 404, "job_not_found", "after",
                 "after names no job this daemon has had lately (\"%s\"); "
                 "list from the start, without after",
                 after);
        return lrd_send_error(c, r, &e, NULL);
    }
    if (json == NULL) {
        lrd_fail(&e, 503, "out_of_memory", NULL, "out of memory");
        return lrd_send_error(c, r, &e, NULL);
    }
    return lrd_send_json(c, r, 200, json, NULL);
}
