/*
 * metrics.c: counters and the /metrics document in the Prometheus text
 * exposition format (version 0.0.4).  Request counts live here; job and
 * scene-cache figures are read from their modules when scraped.
 */
#include "lensrayd.h"

#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Requests answered, by HTTP status (100..599). */
static atomic_ullong requests[600];
/* Monotonic start time, written by lrd_metrics_start before any other
 * thread exists and only read afterwards. */
static double started_at;

void lrd_metrics_request(int status)
{
    if (status >= 100 && status < 600)
        atomic_fetch_add(&requests[status], 1);
}

/* A growing text buffer; `failed` sticks after an allocation failure. */
typedef struct sbuf {
    char *p;
    size_t len, cap;
    int failed;
} sbuf;

static void put(sbuf *b, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static void put(sbuf *b, const char *fmt, ...)
{
    if (b->failed)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(b->p + b->len, b->cap - b->len, fmt, ap);
        va_end(ap);
        if (n < 0) {
            b->failed = 1;
            return;
        }
        if ((size_t)n < b->cap - b->len) {
            b->len += (size_t)n;
            return;
        }
        size_t cap = 2 * b->cap + (size_t)n + 1;
        char *grown = realloc(b->p, cap);
        if (grown == NULL) {
            b->failed = 1;
            return;
        }
        b->p = grown;
        b->cap = cap;
    }
}

static void head(sbuf *b, const char *name, const char *type, const char *help)
{
    put(b, "# HELP %s %s\n# TYPE %s %s\n", name, help, name, type);
}

char *lrd_metrics_text(size_t *len)
{
    sbuf b = {malloc(4096), 0, 4096, 0};
    if (b.p == NULL)
        return NULL;
    b.p[0] = '\0';

    head(&b, "lensrayd_http_requests_total", "counter",
         "HTTP requests answered, by status code.");
    for (int s = 100; s < 600; s++) {
        unsigned long long n = atomic_load(&requests[s]);
        if (n > 0)
            put(&b, "lensrayd_http_requests_total{code=\"%d\"} %llu\n", s, n);
    }

    lrd_jobs_stats js;
    lrd_jobs_stats_get(&js);
    head(&b, "lensrayd_jobs", "gauge",
         "Jobs in the job table now, by state (finished synchronous jobs "
         "leave the table at once).");
    for (int s = 0; s < LRD_N_STATES; s++)
        put(&b, "lensrayd_jobs{state=\"%s\"} %ld\n",
            lrd_state_name((lrd_state)s), js.in_state[s]);
    head(&b, "lensrayd_jobs_finished_total", "counter",
         "Jobs that reached a final state, by that state.");
    for (int s = LRD_DONE; s < LRD_N_STATES; s++)
        put(&b, "lensrayd_jobs_finished_total{state=\"%s\"} %llu\n",
            lrd_state_name((lrd_state)s), (unsigned long long)js.finished[s]);
    head(&b, "lensrayd_jobs_rejected_total", "counter",
         "Jobs refused with 429 because the queue was full.");
    put(&b, "lensrayd_jobs_rejected_total %llu\n",
        (unsigned long long)js.rejected_full);
    head(&b, "lensrayd_queue_depth", "gauge", "Jobs waiting for a worker.");
    put(&b, "lensrayd_queue_depth %ld\n", js.queue_depth);
    head(&b, "lensrayd_queue_capacity", "gauge",
         "Jobs that may wait for a worker (--queue).");
    put(&b, "lensrayd_queue_capacity %ld\n", lrd_cfg.queue);
    head(&b, "lensrayd_workers", "gauge", "Render worker threads.");
    put(&b, "lensrayd_workers %ld\n", lrd_cfg.workers);
    head(&b, "lensrayd_workers_busy", "gauge", "Workers rendering now.");
    put(&b, "lensrayd_workers_busy %ld\n", js.running);
    head(&b, "lensrayd_rays_traced_total", "counter",
         "Rays traced by finished renders: camera, shadow and secondary.");
    put(&b, "lensrayd_rays_traced_total %llu\n", (unsigned long long)js.rays);
    head(&b, "lensrayd_samples_total", "counter",
         "Camera samples of finished renders.");
    put(&b, "lensrayd_samples_total %llu\n", (unsigned long long)js.samples);
    head(&b, "lensrayd_pixels_total", "counter", "Pixels of finished renders.");
    put(&b, "lensrayd_pixels_total %llu\n", (unsigned long long)js.pixels);
    head(&b, "lensrayd_render_seconds_total", "counter",
         "Seconds workers spent on jobs (rendering and encoding, including "
         "renders that failed or were cancelled).");
    put(&b, "lensrayd_render_seconds_total %.6f\n", js.render_seconds);
    head(&b, "lensrayd_retained_image_bytes", "gauge",
         "Bytes of finished images kept for GET /v1/jobs/{id}/image.");
    put(&b, "lensrayd_retained_image_bytes %llu\n",
        (unsigned long long)js.retained_bytes);

    lrd_scene_stats ss;
    lrd_scenes_stats(&ss);
    head(&b, "lensrayd_scene_cache_entries", "gauge", "Scenes loaded now.");
    put(&b, "lensrayd_scene_cache_entries %ld\n", ss.entries);
    head(&b, "lensrayd_scene_cache_hits_total", "counter",
         "Scene lookups served without loading.");
    put(&b, "lensrayd_scene_cache_hits_total %llu\n",
        (unsigned long long)ss.hits);
    head(&b, "lensrayd_scene_cache_misses_total", "counter",
         "Scene lookups that loaded (or failed to load) a scene.");
    put(&b, "lensrayd_scene_cache_misses_total %llu\n",
        (unsigned long long)ss.misses);
    head(&b, "lensrayd_scene_cache_evictions_total", "counter",
         "Scenes dropped from the cache to make room.");
    put(&b, "lensrayd_scene_cache_evictions_total %llu\n",
        (unsigned long long)ss.evictions);

    head(&b, "lensrayd_in_flight_requests", "gauge",
         "HTTP requests being handled or sent.");
    put(&b, "lensrayd_in_flight_requests %ld\n", lrd_http_in_flight());
    head(&b, "lensrayd_shutting_down", "gauge",
         "1 once a SIGTERM or SIGINT has started the shutdown.");
    put(&b, "lensrayd_shutting_down %d\n", lrd_shutting_down() ? 1 : 0);
    head(&b, "lensrayd_uptime_seconds", "gauge",
         "Seconds since the daemon started.");
    put(&b, "lensrayd_uptime_seconds %.3f\n", lrd_monotonic() - started_at);
    head(&b, "lensrayd_build_info", "gauge",
         "Versions of the daemon and the library.");
    put(&b, "lensrayd_build_info{version=\"%s\",lensray=\"%s\"} 1\n",
        LRD_VERSION, lr_version());

    if (b.failed) {
        free(b.p);
        return NULL;
    }
    *len = b.len;
    return b.p;
}

void lrd_metrics_start(void)
{
    started_at = lrd_monotonic();
}
