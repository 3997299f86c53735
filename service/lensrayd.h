/*
 * lensrayd.h: the internal interface between the parts of the lensrayd
 * render daemon.  Not installed; nothing outside service/ includes it.
 *
 * The daemon is a thin client of the public lensray.h API:
 *
 *   main.c         flags and environment, signals, startup and shutdown
 *   http_*.c       the HTTP side on libmicrohttpd (http.h): lifecycle,
 *                  transport, the route table, responses, handlers
 *   api.c          job body -> validated job spec (through lr_job_*);
 *                  mesh-path confinement; the scene listing
 *   jobs.c         job table, queue, worker pool, retention, cancellation
 *   scene_cache.c  loaded scenes shared by name and by content hash
 *   metrics.c      counters and the Prometheus text exposition
 *   util.c         errors as JSON, clocks, ids, size parsing
 *   sha256.c       SHA-256 (OpenSSL), for cache keys and the token comparison
 *   inspect.c      what the page shows: models and names, a job's resolved
 *                  camera, a job's plan
 *   ui.c           the page (service/ui/, embedded at build time)
 *
 * Threads: libmicrohttpd runs one thread per connection; renders run on
 * the worker pool of jobs.c and never on an HTTP thread.  Every module
 * guards its own state with its own mutex; the only nesting is jobs ->
 * scene cache (a job frees its scene reference), never the other way.
 */
#ifndef LENSRAYD_H
#define LENSRAYD_H

#include "lensray.h"

#include <stddef.h>
#include <stdint.h>

#include <cjson/cJSON.h>

#define LRD_VERSION "0.1.0"

/* Scene files larger than this are refused; the library has the same
 * limit for the files it reads itself. */
#define LRD_MAX_SCENE_FILE ((size_t)64 << 20)

/* ------------------------------------------------------------------------
 * Configuration (main.c fills it once, before any thread starts; after
 * that it is read-only and shared by every thread).
 * ---------------------------------------------------------------------- */

typedef struct lrd_config {
    char bind[64];             /* address to listen on */
    long port;                 /* 0 = an ephemeral port, printed at startup */
    char scenes_dir[4096];     /* absolute, symlinks resolved */
    char assets_dir[4096];     /* absolute, or "" for no asset store */
    uint64_t max_asset;        /* bytes of one asset (PUT /v1/assets) */
    char id_prefix[9];         /* the start of every job id: a balancer
                                 routes a job's requests on it */
    long workers;              /* render worker threads */
    long queue;                /* jobs that may wait beyond the workers */
    char *token;               /* NULL = no authentication; owned */
    char allow_host[1024];     /* without a token, the names besides IP
                                 literals and localhost that a request's
                                 Host may give: "a,b", lowercase, "" for
                                 none (against DNS rebinding) */
    uint64_t max_body;         /* request body bytes */
    uint64_t max_pixels;       /* pixels per output image */
    uint64_t max_samples;      /* pixels x spp per job */
    double max_render_seconds; /* wall time per render, then "timeout" */
    uint64_t max_output;       /* encoded image bytes */
    long max_json_depth;       /* nesting of a request body */
    long max_connections;      /* open connections, all clients */
    long max_per_ip;           /* open connections from one address */
    uint64_t conn_memory;      /* libmicrohttpd memory per connection */
    long conn_timeout;         /* seconds of silence before a close */
    double job_ttl;            /* seconds a finished job is kept */
    long max_finished;         /* finished jobs kept */
    uint64_t max_retained;     /* image bytes kept by finished jobs */
    long scene_cache;          /* loaded scenes kept */
    uint64_t max_scene_triangles; /* triangles one scene may hold (0: any) */
    uint64_t max_scene_texels;    /* texels of one scene's images (0: any) */
    double shutdown_grace;        /* seconds running jobs get at shutdown */
    long no_ui;                   /* 1: GET / and the page's files are 404 */
} lrd_config;

/* The one configuration; defined in main.c. */
extern lrd_config lrd_cfg;

/* ------------------------------------------------------------------------
 * Errors (util.c): what an HTTP error response says.
 * ---------------------------------------------------------------------- */

typedef struct lrd_err {
    int http;           /* HTTP status, e.g. 422 */
    char code[48];      /* machine-readable, e.g. "invalid_value" */
    char path[300];     /* JSON path of the field, or "" */
    char message[1024]; /* a whole sentence */
    int retry_after;    /* seconds for Retry-After, 0 for none */
} lrd_err;

/* Fills *e.  `path` may be NULL.  Returns -1 so that callers can write
 * `return lrd_fail(...)`. */
int lrd_fail(lrd_err *e, int http, const char *code, const char *path,
             const char *fmt, ...) __attribute__((format(printf, 5, 6)));

/* Maps a library error to an HTTP error.  `prefix` ("scene" or NULL) is
 * put in front of the library's path, so that "objects[2].radius" of an
 * inline scene becomes "scene.objects[2].radius".  `named_scene`, the
 * file's name in the scenes directory ("night.json"), says the error is
 * in a server-side scene file, which is the server's fault; NULL
 * otherwise. */
int lrd_fail_lr(lrd_err *e, const lr_error *le, const char *prefix,
                const char *named_scene);

/* The body of an error response, {"error": {...}}; malloc'ed, or NULL
 * when out of memory. */
char *lrd_err_json(const lrd_err *e);

/* ------------------------------------------------------------------------
 * Small utilities (util.c)
 * ---------------------------------------------------------------------- */

double lrd_monotonic(void); /* seconds, CLOCK_MONOTONIC */
double lrd_wall(void);      /* seconds since the epoch */

/* "2025-01-31T12:34:56.789Z" into out[32]. */
void lrd_iso8601(double wall, char out[32]);

/* 32 lowercase hex digits from the kernel's random source into out[33].
 * Returns 0, or -1 if no randomness could be had. */
int lrd_random_id(char out[33]);

/* True if `s` is 32 lowercase hex digits. */
int lrd_is_job_id(const char *s);

/* Parses an unsigned integer with an optional binary suffix k, M, G
 * (when `sizes`), e.g. "8M".  Returns 0, or -1 on any junk or overflow. */
int lrd_parse_u64(const char *s, int sizes, uint64_t *out);

/* Parses a finite non-negative decimal number.  0 or -1. */
int lrd_parse_seconds(const char *s, double *out);

/* Reads a whole file of at most `max` bytes (more fails with EFBIG);
 * malloc'ed and NUL-terminated, or NULL with errno set. */
char *lrd_read_file(const char *path, size_t max, size_t *len);

/* Serialises a cJSON value with cJSON_PrintUnformatted; malloc'ed. */
char *lrd_json_print(const cJSON *v);

/* ------------------------------------------------------------------------
 * SHA-256 (sha256.c)
 * ---------------------------------------------------------------------- */

void lrd_sha256(const void *data, size_t len, unsigned char out[32]);

/* Constant-time equality of two byte strings of any lengths: both are
 * hashed first, so neither the content nor the length of the secret
 * leaks through the time taken. */
int lrd_secret_equal(const void *a, size_t alen, const void *b, size_t blen);

/* ------------------------------------------------------------------------
 * Scene cache (scene_cache.c)
 * ---------------------------------------------------------------------- */

/* A loaded scene with a reference count.  Holders may read the lr_scene
 * from any thread; it is freed when the cache has evicted it and the last
 * holder has released it. */
typedef struct lrd_scene lrd_scene;

int lrd_scenes_init(void);
void lrd_scenes_shutdown(void); /* frees every entry; no holders remain */

/* A scene of the scenes directory by name ([A-Za-z0-9_-]{1,64}, the file
 * DIR/NAME.json).  Returns a new reference, or NULL with *e filled (404
 * unknown scene, 422 bad name, 500 broken scene file). */
lrd_scene *lrd_scene_named(const char *name, lrd_err *e);

/* An inline scene: `text` is its JSON (len bytes), mesh paths relative to
 * the scenes directory.  The caller has already checked the paths.
 * Returns a new reference, or NULL with *e filled (422 invalid). */
lrd_scene *lrd_scene_inline(const char *text, size_t len, lrd_err *e);

/* A second reference to the same scene. */
lrd_scene *lrd_scene_ref(lrd_scene *s);
void lrd_scene_release(lrd_scene *s); /* NULL is a no-op */
const lr_scene *lrd_scene_get(const lrd_scene *s);

typedef struct lrd_scene_stats {
    uint64_t hits, misses, loads_failed, evictions;
    long entries;
} lrd_scene_stats;
void lrd_scenes_stats(lrd_scene_stats *out);

/* ------------------------------------------------------------------------
 * Job specs (api.c): a request body turned into everything a render needs.
 * ---------------------------------------------------------------------- */

typedef struct lrd_job_spec {
    lrd_scene *scene;    /* a reference owned by the spec */
    char scene_name[72]; /* "" for an inline scene */
    lr_camera cam;
    lr_render_settings rs; /* progress/cancel are set by the worker */
    lr_output out;         /* format and encoder options */
    int width, height;     /* of the output image (the region's size) */
    uint64_t samples;      /* width x height x spp */
} lrd_job_spec;

/* Parses and validates a job body.  On success *spec owns a scene
 * reference (release it with lrd_job_spec_clear, or hand it to
 * lrd_jobs_submit).  Returns 0, or -1 with *e filled. */
int lrd_api_parse_job(const char *body, size_t len, lrd_job_spec *spec,
                      lrd_err *e);
void lrd_job_spec_clear(lrd_job_spec *spec);

/* ------------------------------------------------------------------------
 * Assets (assets.c): files named by the SHA-256 of their bytes in
 * --assets DIR, which inline scenes name as "sha256:HEX".
 * ---------------------------------------------------------------------- */

/* Whether `hex` is an asset name: 64 lowercase hex digits. */
int lrd_asset_name_ok(const char *hex);

/* Stores len bytes as asset `hex` unless it is there already (*created
 * says which).  0, or -1 with *e: 404 no store, 422 a bad name or bytes
 * whose SHA-256 is not `hex` (nothing stored), 507 the disk failed. */
int lrd_asset_put(const char *hex, const void *data, size_t len, int *created,
                  lrd_err *e);

/* Whether asset `hex` is there, and its size.  0, or -1 with *e (404). */
int lrd_asset_stat(const char *hex, uint64_t *size, lrd_err *e);

/* Checks a file "sha256:HEX" of an inline scene (or the job's scene
 * itself) at `field`: 0, or -1 with a 422 that names the field and the
 * asset the server lacks. */
int lrd_asset_check_ref(const char *file, const char *field, lrd_err *e);

/* GET /v1/scenes as a JSON document; malloc'ed, or NULL with *e. */
char *lrd_api_scenes_json(lrd_err *e);

/* Sets lrd_cfg to the documented defaults (util.c). */
void lrd_config_defaults(void);

/* Drops a partial UTF-8 character left at the end of `s` by a cut to
 * fit a buffer (util.c). */
void lrd_utf8_trim(char *s);

/* ------------------------------------------------------------------------
 * Jobs (jobs.c)
 * ---------------------------------------------------------------------- */

typedef enum lrd_state {
    LRD_QUEUED = 0,
    LRD_RUNNING,
    LRD_DONE,
    LRD_FAILED,
    LRD_CANCELLED,
    LRD_N_STATES
} lrd_state;

const char *lrd_state_name(lrd_state s);

/* Why a job was cancelled; decides the error it reports. */
typedef enum lrd_cancel_reason {
    LRD_CANCEL_NONE = 0,
    LRD_CANCEL_USER,       /* DELETE /v1/jobs/{id} */
    LRD_CANCEL_DISCONNECT, /* the client of a synchronous render left */
    LRD_CANCEL_TIMEOUT,    /* max_render_seconds exceeded */
    LRD_CANCEL_SHUTDOWN    /* the daemon is stopping */
} lrd_cancel_reason;

/* An encoded image shared between a job and the responses sending it. */
typedef struct lrd_blob lrd_blob;
const void *lrd_blob_data(const lrd_blob *b);
size_t lrd_blob_len(const lrd_blob *b);
lrd_blob *lrd_blob_ref(lrd_blob *b);
void lrd_blob_release(lrd_blob *b); /* NULL is a no-op */

typedef struct lrd_job lrd_job;

int lrd_jobs_start(void); /* starts the workers; 0 or -1 */

/* The longest Idempotency-Key: printable ASCII without spaces. */
#define LRD_KEY_MAX 64

/* Queues a job.  Takes over spec->scene (spec is cleared either way).
 * `sync` jobs belong to a waiting POST /v1/render and leave the table as
 * soon as they finish, unless they have a key.  With a `key` (an
 * Idempotency-Key; NULL or "" for none) and `body_hash` (the SHA-256 of
 * the request), a job already in the table with that key is returned
 * instead (*existing = 1) and nothing is queued.  On success *out is a
 * new reference to the job.  Errors: 422 idempotency_key_reused (the key
 * came with another request), 429 queue full (retry_after set), 503
 * shutting down. */
int lrd_jobs_submit(lrd_job_spec *spec, int sync, const char *key,
                    const unsigned char body_hash[32], lrd_job **out,
                    int *existing, lrd_err *e);

/* Whether the job came with an Idempotency-Key. */
int lrd_job_keyed(const lrd_job *j);

/* Waits up to `seconds` while the job is in state `from`; returns the
 * state then. */
lrd_state lrd_job_wait_change(lrd_job *j, lrd_state from, double seconds);

/* GET /v1/jobs: the status documents of the table's jobs, oldest first,
 * in state `status` (-1: any) and with Idempotency-Key `key` (NULL: any),
 * after the job `after` (NULL: from the first; a job that left the table
 * since is still placed, among the last 1024 that left), at most
 * `limit`, as {"jobs": [...], "next": ID or null}.  malloc'ed; NULL when
 * out of memory, or with *unknown_after set when `after` is no job this
 * daemon can place. */
char *lrd_jobs_list_json(int status, const char *key, const char *after,
                         long limit, int *unknown_after);

/* A new reference to the job with this id, or NULL. */
lrd_job *lrd_jobs_find(const char *id);
void lrd_job_release(lrd_job *j); /* NULL is a no-op */
const char *lrd_job_id(const lrd_job *j);

/* Waits up to `seconds` for the job to finish; 1 if it has. */
int lrd_job_wait(lrd_job *j, double seconds);

/* Asks the job to stop: a queued job is cancelled at once, a running one
 * within a tile.  Returns the state after the call. */
lrd_state lrd_job_cancel(lrd_job *j, lrd_cancel_reason why);

/* Removes a finished job from the table (DELETE of a finished job).
 * Returns 0, or -1 if it had not finished. */
int lrd_job_forget(lrd_job *j);

/* What a finished job produced.  *image is a new reference (or NULL). */
typedef struct lrd_job_result {
    lrd_state state;
    lrd_blob *image;
    lr_format format;
    lr_render_stats stats;
    lrd_err err; /* for FAILED and CANCELLED */
    lrd_cancel_reason cancel_reason;
} lrd_job_result;
void lrd_job_result_get(lrd_job *j, lrd_job_result *out);

/* The job's spec: immutable once queued, so read without a lock; valid
 * while the caller holds its reference to the job. */
const lrd_job_spec *lrd_job_spec_of(const lrd_job *j);

/* The job's status document (GET /v1/jobs/{id}); malloc'ed or NULL. */
char *lrd_job_status_json(lrd_job *j);

/* Counts for /metrics and the shutdown. */
typedef struct lrd_jobs_stats {
    long in_state[LRD_N_STATES];     /* jobs in the table now */
    uint64_t finished[LRD_N_STATES]; /* ever finished, by final state */
    long queue_depth;                /* jobs waiting for a worker */
    long running;                    /* jobs on a worker now */
    uint64_t rays, samples, pixels, rejected_full;
    double render_seconds;
    uint64_t retained_bytes;
} lrd_jobs_stats;
void lrd_jobs_stats_get(lrd_jobs_stats *out);

/* Shutdown, in this order: refuse new jobs and cancel the queued ones;
 * (wait for the running ones); cancel the running ones; join the workers;
 * free the table. */
void lrd_jobs_begin_shutdown(void);
long lrd_jobs_running(void);
void lrd_jobs_cancel_running(lrd_cancel_reason why);
/* Cancels, as timed out, each running job past --max-render-seconds: the
 * main thread calls it four times a second, so that a render's set-up,
 * which reports no progress (where on_progress checks the clock), is
 * held to the limit too. */
void lrd_jobs_enforce_time(void);
void lrd_jobs_stop(void);
void lrd_jobs_free_all(void);

/* ------------------------------------------------------------------------
 * HTTP (http_server.c, http_transport.c; the rest in http.h)
 * ---------------------------------------------------------------------- */

struct sockaddr_storage;
/* The address --bind names (IPv4, IPv6 or a host name), into *sa and
 * *v6 (1 for IPv6).  NULL, or why it names none. */
const char *lrd_http_resolve(const char *bind, struct sockaddr_storage *sa,
                             int *v6);
/* Starts libmicrohttpd; prints the startup line.  0 or -1. */
int lrd_http_start(void);
/* Stops accepting connections; requests on open connections get 503. */
void lrd_http_quiesce(void);
/* Requests being handled or sent right now. */
long lrd_http_in_flight(void);
/* Closes every connection and joins the HTTP threads. */
void lrd_http_stop(void);
/* True once shutdown has begun. */
int lrd_shutting_down(void);

/* ------------------------------------------------------------------------
 * What the page shows (inspect.c) and the page itself (ui.c)
 * ---------------------------------------------------------------------- */

/* GET /v1/options: {"camera_models": [{"name", "autofocus", "chromatic",
 * "defaults"}], "samplers": [...], "chromatic_modes": [...]}, found by
 * asking the library; malloc'ed, or NULL with *e. */
char *lrd_options_json(lrd_err *e);

/* The camera a job renders with, its autofocus resolved (as lr_render
 * resolves it; unresolved when it fails): lr_camera_json text, release
 * with lr_free; NULL when out of memory. */
char *lrd_spec_camera_json(const lrd_job_spec *spec);

/* GET /v1/jobs/{id}/plan: the job's plan map (lr_render_plan_map) as
 * JSON; malloc'ed, or NULL with *e. */
char *lrd_job_plan_json(lrd_job *j, lrd_err *e);

/* A file of the page, generated from service/ui/ into ui_files.c. */
typedef struct lrd_ui_file {
    const char *path; /* the URL path: "/", "/ui/page.js" */
    const char *content_type;
    const unsigned char *data;
    size_t len;
} lrd_ui_file;
extern const lrd_ui_file lrd_ui_files[]; /* ended by a NULL path */

/* The page's file at `path`, or NULL (also for every path with --no-ui). */
const lrd_ui_file *lrd_ui_find(const char *path);

/* ------------------------------------------------------------------------
 * Metrics (metrics.c)
 * ---------------------------------------------------------------------- */

void lrd_metrics_start(void);         /* at startup, before threads */
void lrd_metrics_request(int status); /* one answered request */
/* The /metrics document; malloc'ed or NULL. */
char *lrd_metrics_text(size_t *len);

#endif /* LENSRAYD_H */
