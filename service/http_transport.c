/*
 * http_transport.c: one request on its connection (http.h), from MHD's
 * first call of the access handler to the request-completed callback:
 * its state made, the early checks run, the body collected up to its
 * route's limit (and a body that comes too slowly cut), the handler
 * dispatched; then one log line, the metrics, and its state freed.
 */
#include "http.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

_Thread_local int lrd_http_closing_on_purpose;

static atomic_long in_flight;

long lrd_http_in_flight(void)
{
    return atomic_load(&in_flight);
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

enum MHD_Result lrd_http_on_request(void *cls, struct MHD_Connection *c,
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
        atomic_fetch_add(&in_flight, 1);
        r->t0 = lrd_monotonic();
        snprintf(r->method, sizeof r->method, "%s", method);
        log_path(r->path, sizeof r->path, url);
        enum MHD_Result result = MHD_YES;
        if (lrd_route_early(c, r, url, &result))
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
            lrd_http_closing_on_purpose = 1;
            return MHD_NO;
        }
        if (r->too_large || !r->route->body) {
            /* Dropped, but not forever: a client that keeps streaming
             * long after the limit loses its connection. */
            r->dropped += n;
            return r->dropped > 4 * lrd_body_limit(r) + (1u << 20) ? MHD_NO
                                                                   : MHD_YES;
        }
        if (r->len + n > lrd_body_limit(r)) {
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
            if (cap > lrd_body_limit(r) + 1)
                cap = lrd_body_limit(r) + 1;
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
    return lrd_route_dispatch(c, r);
}

void lrd_http_on_completed(void *cls, struct MHD_Connection *c, void **con_cls,
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
    int n = snprintf(line, sizeof line, "lensrayd: %s %s %d %llu %.1fms %s%s\n",
                     r->method, r->path, status, (unsigned long long)r->bytes,
                     ms, r->job_id[0] ? r->job_id : "-",
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
    atomic_fetch_sub(&in_flight, 1);
}
