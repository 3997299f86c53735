/*
 * jobs.c: the job table, the queue and the worker pool.
 *
 * Every job, synchronous or not, goes through one FIFO queue to a fixed
 * pool of worker threads, so HTTP threads never render and a slow or
 * vanished client never holds a worker: a worker only writes the encoded
 * image into the job and moves on.
 *
 * Ownership and locking: one mutex, jobs.mu, guards the table, the queue,
 * every job's mutable fields and every job's reference count.  A job is
 * referenced by the table while it is listed, by the worker running it and
 * by each HTTP request holding it; it is freed by whoever drops the last
 * reference, always after unlocking (freeing releases a scene, which takes
 * the scene cache's lock).  The job's spec (scene, camera, settings,
 * output) is immutable once queued and is read without the lock.
 *
 * Retention: asynchronous jobs stay in the table when finished, until
 * lrd_cfg.job_ttl seconds have passed or lrd_cfg.max_finished newer
 * finished jobs (or lrd_cfg.max_retained image bytes) push them out.
 * Synchronous jobs leave the table as soon as they finish: their image
 * goes to the waiting response and nowhere else.
 */
#include "lensrayd.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* The departed jobs remembered for GET /v1/jobs?after= (49 bytes each):
 * ten times --max-finished-jobs' default leave. */
#define LRD_GONE_KEPT 1024

struct lrd_blob {
    atomic_int refs;
    void *data; /* from lr_image_encode: released with lr_free */
    size_t len;
};

struct lrd_job {
    char id[33];
    char key[LRD_KEY_MAX + 1];   /* Idempotency-Key, or "" */
    unsigned char body_hash[32]; /* SHA-256 of the request, with a key */
    int refs;
    int in_table;
    int sync;
    lrd_state state;
    lrd_cancel_reason cancel_reason;
    /* Polled by lr_render between tiles; written under jobs.mu. */
    volatile int cancel;
    lrd_job_spec spec; /* owns a scene reference */
    double created_wall, started_wall, finished_wall;
    double created, started, finished; /* monotonic */
    double encode_seconds;
    uint64_t done_px, total_px;
    lrd_blob *image;
    lr_render_stats stats;
    lrd_err err;
    uint64_t seq;                /* 1, 2, ... in the order of the table */
    struct lrd_job *prev, *next; /* the table, oldest first */
    struct lrd_job *qnext;       /* the queue, or the free chain */
};

static struct {
    pthread_mutex_t mu;
    pthread_cond_t work_cv; /* a job was queued, or stop was set */
    pthread_cond_t done_cv; /* some job finished */
    lrd_job *head, *tail;
    lrd_job *qhead, *qtail;
    long queued, running;
    long in_state[LRD_N_STATES];
    uint64_t finished[LRD_N_STATES];
    uint64_t rays, samples, pixels, rejected_full;
    double render_seconds;
    double avg_job_seconds; /* for Retry-After */
    pthread_t *threads;
    long n_threads;
    int stop, shutting_down;
    uint64_t last_seq;
    /* The ids and places of the jobs that left the table last, so that a
     * listing paged `after` a job that expired meanwhile goes on from its
     * place rather than ending (GET /v1/jobs). */
    struct {
        char id[33];
        uint64_t seq;
    } gone[LRD_GONE_KEPT];
    uint64_t n_gone;
} jobs = {.mu = PTHREAD_MUTEX_INITIALIZER};

const char *lrd_state_name(lrd_state s)
{
    static const char *const names[] = {"queued", "running", "done", "failed",
                                        "cancelled"};
    return (unsigned)s < LRD_N_STATES ? names[s] : "unknown";
}

/* ---- blobs --------------------------------------------------------------- */

const void *lrd_blob_data(const lrd_blob *b)
{
    return b->data;
}
size_t lrd_blob_len(const lrd_blob *b)
{
    return b->len;
}

lrd_blob *lrd_blob_ref(lrd_blob *b)
{
    atomic_fetch_add(&b->refs, 1);
    return b;
}

void lrd_blob_release(lrd_blob *b)
{
    if (b != NULL && atomic_fetch_sub(&b->refs, 1) == 1) {
        lr_free(b->data);
        free(b);
    }
}

/* ---- the table ----------------------------------------------------------- */

static void job_free(lrd_job *j)
{
    lrd_job_spec_clear(&j->spec);
    lrd_blob_release(j->image);
    free(j);
}

static void free_chain(lrd_job *j)
{
    while (j != NULL) {
        lrd_job *next = j->qnext;
        job_free(j);
        j = next;
    }
}

/* Called with jobs.mu held: takes `j` out of the table and drops the
 * table's reference; a job whose last reference that was is pushed on
 * *chain for the caller to free after unlocking. */
static void unlink_locked(lrd_job *j, lrd_job **chain)
{
    if (!j->in_table)
        return;
    if (j->prev != NULL)
        j->prev->next = j->next;
    else
        jobs.head = j->next;
    if (j->next != NULL)
        j->next->prev = j->prev;
    else
        jobs.tail = j->prev;
    j->prev = j->next = NULL;
    j->in_table = 0;
    jobs.in_state[j->state]--;
    size_t g = (size_t)(jobs.n_gone++ % LRD_GONE_KEPT);
    memcpy(jobs.gone[g].id, j->id, sizeof j->id);
    jobs.gone[g].seq = j->seq;
    if (--j->refs == 0) {
        j->qnext = *chain;
        *chain = j;
    }
}

static void set_state_locked(lrd_job *j, lrd_state s)
{
    if (j->in_table) {
        jobs.in_state[j->state]--;
        jobs.in_state[s]++;
    }
    j->state = s;
    /* Waiters on any change (GET /v1/jobs/{id}?wait=) re-check. */
    pthread_cond_broadcast(&jobs.done_cv);
}

/* Called with jobs.mu held: drops finished asynchronous jobs that are too
 * old, too many or hold too many image bytes. */
static void prune_locked(lrd_job **chain)
{
    double now = lrd_monotonic();
    long n_finished = 0;
    uint64_t bytes = 0;
    for (lrd_job *j = jobs.head; j != NULL;) {
        lrd_job *next = j->next;
        if (j->state >= LRD_DONE) {
            if (now - j->finished > lrd_cfg.job_ttl) {
                unlink_locked(j, chain);
            } else {
                n_finished++;
                bytes += j->image ? j->image->len : 0;
            }
        }
        j = next;
    }
    /* The newest finished job is kept whatever its size, so that a big
     * result can always be fetched once. */
    while (n_finished > lrd_cfg.max_finished ||
           (bytes > lrd_cfg.max_retained && n_finished > 1)) {
        lrd_job *oldest = NULL;
        for (lrd_job *j = jobs.head; j != NULL; j = j->next)
            if (j->state >= LRD_DONE &&
                (oldest == NULL || j->finished < oldest->finished))
                oldest = j;
        if (oldest == NULL)
            break;
        n_finished--;
        bytes -= oldest->image ? oldest->image->len : 0;
        unlink_locked(oldest, chain);
    }
}

/* Called with jobs.mu held: the job reached a final state. */
static void finish_locked(lrd_job *j, lrd_state s, lrd_job **chain)
{
    set_state_locked(j, s);
    j->finished = lrd_monotonic();
    j->finished_wall = lrd_wall();
    jobs.finished[s]++;
    if (s == LRD_DONE) {
        jobs.rays += j->stats.rays;
        jobs.samples += j->stats.samples;
        jobs.pixels += j->stats.pixels;
    }
    /* A synchronous job with an Idempotency-Key stays, so that a retry
     * of its request gets its image rather than a second render. */
    if (j->sync && j->key[0] == '\0')
        unlink_locked(j, chain);
    pthread_cond_broadcast(&jobs.done_cv);
}

static void cancel_error_locked(lrd_job *j, lrd_job **chain)
{
    switch (j->cancel_reason) {
    case LRD_CANCEL_TIMEOUT:
        lrd_fail(&j->err, 504, "timeout", NULL,
                 "the render took longer than the limit of %g seconds "
                 "(--max-render-seconds)",
                 lrd_cfg.max_render_seconds);
        finish_locked(j, LRD_FAILED, chain);
        return;
    case LRD_CANCEL_SHUTDOWN:
        lrd_fail(&j->err, 503, "shutting_down", NULL,
                 "the job was cancelled because the server is shutting "
                 "down");
        j->err.retry_after = 1;
        break;
    case LRD_CANCEL_DISCONNECT:
        lrd_fail(&j->err, 499, "client_disconnected", NULL,
                 "the client of the synchronous render disconnected");
        break;
    case LRD_CANCEL_USER:
    case LRD_CANCEL_NONE:
    default:
        lrd_fail(&j->err, 409, "cancelled", NULL,
                 "the job was cancelled by DELETE /v1/jobs/%s", j->id);
        break;
    }
    finish_locked(j, LRD_CANCELLED, chain);
}

/* ---- the workers --------------------------------------------------------- */

/* Raises the flag lr_render polls.  The library takes a plain
 * `const volatile int *`, so its reads are not atomic; the store at least
 * is, and happens under jobs.mu like every other write to the job. */
static void set_cancel(lrd_job *j)
{
    __atomic_store_n(&j->cancel, 1, __ATOMIC_SEQ_CST);
}

/* Called by lr_render after each tile, serialised by the library.  It is
 * also where the time limit is enforced: the library polls the cancel
 * flag between tiles, so checking the clock after each tile stops an
 * overlong render as early as any watchdog could. */
static void on_progress(void *user, uint64_t done, uint64_t total)
{
    lrd_job *j = user;
    pthread_mutex_lock(&jobs.mu);
    j->done_px = done;
    j->total_px = total;
    if (!j->cancel && lrd_cfg.max_render_seconds > 0 &&
        lrd_monotonic() - j->started > lrd_cfg.max_render_seconds) {
        j->cancel_reason = LRD_CANCEL_TIMEOUT;
        set_cancel(j);
    }
    pthread_mutex_unlock(&jobs.mu);
}

/* What run() produced, published into the job under the lock. */
typedef struct run_result {
    lrd_blob *image;
    lr_render_stats stats;
    double encode_seconds;
    lrd_err err;
} run_result;

/* Renders and encodes one job, outside the lock.  It writes only to *out:
 * readers such as /metrics and the status document look at the job's
 * fields at any time, so the worker copies the result in under the lock. */
static lrd_state run(lrd_job *j, run_result *out)
{
    const lrd_job_spec *sp = &j->spec;
    memset(out, 0, sizeof *out);
    lr_render_settings rs = sp->rs;
    rs.progress = on_progress;
    rs.progress_user = j;
    rs.cancel = &j->cancel;
    lr_image *img = NULL;
    lr_error le;
    lr_status st = lr_render(lrd_scene_get(sp->scene), &sp->cam, &rs, &img,
                             &out->stats, &le);
    if (st == LR_ERR_CANCELLED)
        return LRD_CANCELLED;
    if (st != LR_OK) {
        lrd_fail_lr(&out->err, &le, NULL, 0);
        return LRD_FAILED;
    }
    double t0 = lrd_monotonic();
    void *buf = NULL;
    size_t len = 0;
    st = lr_image_encode(img, sp->out.format, &sp->out.options, &buf, &len,
                         &le);
    lr_image_free(img);
    out->encode_seconds = lrd_monotonic() - t0;
    if (st != LR_OK) {
        lrd_fail_lr(&out->err, &le, "output", 0);
        return LRD_FAILED;
    }
    if (len > lrd_cfg.max_output) {
        lr_free(buf);
        lrd_fail(&out->err, 413, "image_too_large", "output",
                 "the encoded image is %zu bytes, more than the limit of "
                 "%llu (--max-output-bytes)",
                 len, (unsigned long long)lrd_cfg.max_output);
        return LRD_FAILED;
    }
    lrd_blob *b = malloc(sizeof *b);
    if (b == NULL) {
        lr_free(buf);
        lrd_fail(&out->err, 503, "out_of_memory", NULL, "out of memory");
        return LRD_FAILED;
    }
    atomic_init(&b->refs, 1);
    b->data = buf;
    b->len = len;
    out->image = b;
    return LRD_DONE;
}

static void *worker_main(void *arg)
{
    (void)arg;
    pthread_mutex_lock(&jobs.mu);
    for (;;) {
        while (!jobs.stop && jobs.qhead == NULL)
            pthread_cond_wait(&jobs.work_cv, &jobs.mu);
        if (jobs.qhead == NULL)
            break; /* stopping, and nothing left */
        lrd_job *j = jobs.qhead;
        jobs.qhead = j->qnext;
        if (jobs.qhead == NULL)
            jobs.qtail = NULL;
        j->qnext = NULL;
        jobs.queued--;
        jobs.running++;
        j->refs++; /* the worker's */
        set_state_locked(j, LRD_RUNNING);
        j->started = lrd_monotonic();
        j->started_wall = lrd_wall();
        pthread_mutex_unlock(&jobs.mu);

        run_result out;
        lrd_state result = run(j, &out);

        lrd_job *chain = NULL;
        pthread_mutex_lock(&jobs.mu);
        jobs.running--;
        j->image = out.image;
        j->stats = out.stats;
        j->encode_seconds = out.encode_seconds;
        if (result == LRD_FAILED)
            j->err = out.err;
        double took = lrd_monotonic() - j->started;
        jobs.render_seconds += took;
        if (result == LRD_DONE) {
            jobs.avg_job_seconds = jobs.avg_job_seconds > 0
                                       ? 0.8 * jobs.avg_job_seconds + 0.2 * took
                                       : took;
            finish_locked(j, LRD_DONE, &chain);
        } else if (result == LRD_CANCELLED) {
            cancel_error_locked(j, &chain);
        } else {
            finish_locked(j, LRD_FAILED, &chain);
        }
        prune_locked(&chain);
        if (--j->refs == 0) {
            j->qnext = chain;
            chain = j;
        }
        pthread_mutex_unlock(&jobs.mu);
        free_chain(chain);
        pthread_mutex_lock(&jobs.mu);
    }
    pthread_mutex_unlock(&jobs.mu);
    return NULL;
}

int lrd_jobs_start(void)
{
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&jobs.work_cv, NULL);
    pthread_cond_init(&jobs.done_cv, &ca);
    pthread_condattr_destroy(&ca);
    jobs.threads = calloc((size_t)lrd_cfg.workers, sizeof *jobs.threads);
    if (jobs.threads == NULL)
        return -1;
    for (long i = 0; i < lrd_cfg.workers; i++) {
        if (pthread_create(&jobs.threads[i], NULL, worker_main, NULL) != 0) {
            fprintf(stderr, "lensrayd: cannot start worker thread %ld\n",
                    i + 1);
            lrd_jobs_stop();
            return -1;
        }
        jobs.n_threads++;
    }
    return 0;
}

/* ---- the API ------------------------------------------------------------- */

/* Called with jobs.mu held: the job in the table made with `key`, or
 * NULL. */
static lrd_job *keyed_locked(const char *key)
{
    for (lrd_job *j = jobs.head; j != NULL; j = j->next)
        if (strcmp(j->key, key) == 0)
            return j;
    return NULL;
}

int lrd_jobs_submit(lrd_job_spec *spec, int sync, const char *key,
                    const unsigned char body_hash[32], lrd_job **out,
                    int *existing, lrd_err *e)
{
    *out = NULL;
    *existing = 0;
    int keyed = key != NULL && key[0] != '\0';
    lrd_job *j = calloc(1, sizeof *j);
    if (j == NULL) {
        lrd_job_spec_clear(spec);
        return lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
    }
    if (lrd_random_id(j->id) != 0) {
        free(j);
        lrd_job_spec_clear(spec);
        return lrd_fail(e, 500, "internal", NULL,
                        "no random numbers for a job id");
    }
    /* The daemon's prefix names it in the id (--id-prefix). */
    memcpy(j->id, lrd_cfg.id_prefix, strlen(lrd_cfg.id_prefix));
    if (keyed) {
        snprintf(j->key, sizeof j->key, "%s", key);
        memcpy(j->body_hash, body_hash, 32);
    }
    j->spec = *spec;
    memset(spec, 0, sizeof *spec); /* the scene reference moved */
    j->sync = sync;
    j->created = lrd_monotonic();
    j->created_wall = lrd_wall();
    j->total_px = (uint64_t)j->spec.width * (uint64_t)j->spec.height;

    lrd_job *chain = NULL;
    pthread_mutex_lock(&jobs.mu);
    prune_locked(&chain);
    /* A request seen before gets its job, whatever its state.  The look-up
     * and the queueing below hold the lock together, so that two requests
     * with one key arriving at the same moment make one job, not two. */
    lrd_job *seen = keyed ? keyed_locked(key) : NULL;
    int rc = 0;
    if (seen != NULL && memcmp(seen->body_hash, body_hash, 32) != 0) {
        rc = lrd_fail(e, 422, "idempotency_key_reused", NULL,
                      "the Idempotency-Key \"%s\" was used for another "
                      "request; a key names one request",
                      key);
    } else if (seen != NULL) {
        seen->refs++;
        *out = seen;
        *existing = 1;
    } else if (jobs.shutting_down) {
        rc = lrd_fail(e, 503, "shutting_down", NULL,
                      "the server is shutting down");
        e->retry_after = 1;
    } else if (jobs.queued + jobs.running >= lrd_cfg.workers + lrd_cfg.queue) {
        jobs.rejected_full++;
        double wait = jobs.avg_job_seconds * (double)(jobs.queued + 1) /
                      (double)lrd_cfg.workers;
        int secs = (int)ceil(wait);
        secs = secs < 1 ? 1 : secs > 3600 ? 3600 : secs;
        rc = lrd_fail(e, 429, "queue_full", NULL,
                      "the queue is full: %ld jobs waiting and %ld running "
                      "(--queue %ld, --workers %ld); retry later",
                      jobs.queued, jobs.running, lrd_cfg.queue,
                      lrd_cfg.workers);
        e->retry_after = secs;
    } else {
        j->refs = 2; /* the table's and the caller's */
        j->in_table = 1;
        j->seq = ++jobs.last_seq;
        j->state = LRD_QUEUED;
        jobs.in_state[LRD_QUEUED]++;
        j->prev = jobs.tail;
        if (jobs.tail != NULL)
            jobs.tail->next = j;
        else
            jobs.head = j;
        jobs.tail = j;
        if (jobs.qtail != NULL)
            jobs.qtail->qnext = j;
        else
            jobs.qhead = j;
        jobs.qtail = j;
        jobs.queued++;
        pthread_cond_signal(&jobs.work_cv);
        prune_locked(&chain);
        *out = j;
    }
    pthread_mutex_unlock(&jobs.mu);
    free_chain(chain);
    /* Not queued (an error, or the earlier job returned): the new job and
     * its scene reference go, outside the lock. */
    if (*out != j)
        job_free(j);
    return rc;
}

lrd_job *lrd_jobs_find(const char *id)
{
    lrd_job *chain = NULL, *found = NULL;
    pthread_mutex_lock(&jobs.mu);
    prune_locked(&chain);
    for (lrd_job *j = jobs.head; j != NULL; j = j->next)
        if (strcmp(j->id, id) == 0) {
            j->refs++;
            found = j;
            break;
        }
    pthread_mutex_unlock(&jobs.mu);
    free_chain(chain);
    return found;
}

void lrd_job_release(lrd_job *j)
{
    if (j == NULL)
        return;
    pthread_mutex_lock(&jobs.mu);
    int last = --j->refs == 0;
    pthread_mutex_unlock(&jobs.mu);
    if (last)
        job_free(j);
}

const char *lrd_job_id(const lrd_job *j)
{
    return j->id;
}
const lrd_job_spec *lrd_job_spec_of(const lrd_job *j)
{
    return &j->spec;
}

/* The monotonic time `seconds` from now, for pthread_cond_timedwait. */
static struct timespec deadline(double seconds)
{
    struct timespec until;
    clock_gettime(CLOCK_MONOTONIC, &until);
    double whole = floor(seconds);
    until.tv_sec += (time_t)whole;
    until.tv_nsec += (long)((seconds - whole) * 1e9);
    if (until.tv_nsec >= 1000000000L) {
        until.tv_sec++;
        until.tv_nsec -= 1000000000L;
    }
    return until;
}

int lrd_job_wait(lrd_job *j, double seconds)
{
    struct timespec until = deadline(seconds);
    pthread_mutex_lock(&jobs.mu);
    while (j->state < LRD_DONE) {
        if (pthread_cond_timedwait(&jobs.done_cv, &jobs.mu, &until) != 0)
            break;
    }
    int finished = j->state >= LRD_DONE;
    pthread_mutex_unlock(&jobs.mu);
    return finished;
}

lrd_state lrd_job_wait_change(lrd_job *j, lrd_state from, double seconds)
{
    struct timespec until = deadline(seconds);
    pthread_mutex_lock(&jobs.mu);
    while (j->state == from && !jobs.shutting_down) {
        if (pthread_cond_timedwait(&jobs.done_cv, &jobs.mu, &until) != 0)
            break;
    }
    lrd_state now = j->state;
    pthread_mutex_unlock(&jobs.mu);
    return now;
}

int lrd_job_keyed(const lrd_job *j)
{
    return j->key[0] != '\0';
}

/* Called with jobs.mu held: the place in the table of job `id`, listed
 * or departed lately; 0 when it is neither. */
static uint64_t seq_of_locked(const char *id)
{
    for (lrd_job *j = jobs.head; j != NULL; j = j->next)
        if (strcmp(j->id, id) == 0)
            return j->seq;
    uint64_t n = jobs.n_gone < LRD_GONE_KEPT ? jobs.n_gone : LRD_GONE_KEPT;
    for (uint64_t i = 0; i < n; i++)
        if (strcmp(jobs.gone[i].id, id) == 0)
            return jobs.gone[i].seq;
    return 0;
}

char *lrd_jobs_list_json(int status, const char *key, const char *after,
                         long limit, int *unknown_after)
{
    /* The ids of the page first, under the lock; then each status
     * document, as GET /v1/jobs/{id} builds it. */
    *unknown_after = 0;
    char(*ids)[33] = calloc((size_t)limit + 1, sizeof *ids);
    if (ids == NULL)
        return NULL;
    long n = 0;
    int more = 0;
    lrd_job *chain = NULL;
    pthread_mutex_lock(&jobs.mu);
    prune_locked(&chain);
    /* The page starts after the cursor's place, which the job keeps when
     * it leaves the table between two pages (expired, deleted). */
    uint64_t from = 0;
    if (after != NULL && after[0] != '\0') {
        from = seq_of_locked(after);
        *unknown_after = from == 0;
    }
    for (lrd_job *j = jobs.head; j != NULL && !*unknown_after; j = j->next) {
        if (j->seq <= from)
            continue;
        if ((status >= 0 && (int)j->state != status) ||
            (key != NULL && key[0] != '\0' && strcmp(j->key, key) != 0))
            continue;
        if (n == limit) {
            more = 1;
            break;
        }
        snprintf(ids[n++], sizeof ids[0], "%s", j->id);
    }
    pthread_mutex_unlock(&jobs.mu);
    free_chain(chain);
    if (*unknown_after) {
        free(ids);
        return NULL;
    }
    cJSON *o = cJSON_CreateObject();
    cJSON *arr = o ? cJSON_AddArrayToObject(o, "jobs") : NULL;
    for (long i = 0; arr != NULL && i < n; i++) {
        lrd_job *j = lrd_jobs_find(ids[i]);
        if (j == NULL)
            continue; /* dropped meanwhile */
        char *doc = lrd_job_status_json(j);
        lrd_job_release(j);
        cJSON *item = doc ? cJSON_Parse(doc) : NULL;
        free(doc);
        if (item != NULL)
            cJSON_AddItemToArray(arr, item);
    }
    if (o != NULL) {
        if (more && n > 0)
            cJSON_AddStringToObject(o, "next", ids[n - 1]);
        else
            cJSON_AddNullToObject(o, "next");
    }
    free(ids);
    char *text = o ? lrd_json_print(o) : NULL;
    cJSON_Delete(o);
    return text;
}

lrd_state lrd_job_cancel(lrd_job *j, lrd_cancel_reason why)
{
    lrd_job *chain = NULL;
    pthread_mutex_lock(&jobs.mu);
    if (j->state == LRD_QUEUED) {
        lrd_job **pp = &jobs.qhead;
        lrd_job *prev = NULL;
        while (*pp != NULL && *pp != j) {
            prev = *pp;
            pp = &(*pp)->qnext;
        }
        if (*pp == j) {
            *pp = j->qnext;
            if (jobs.qtail == j)
                jobs.qtail = prev;
            j->qnext = NULL;
            jobs.queued--;
        }
        j->cancel_reason = why;
        cancel_error_locked(j, &chain);
    } else if (j->state == LRD_RUNNING && !j->cancel) {
        j->cancel_reason = why;
        set_cancel(j);
    }
    lrd_state s = j->state;
    pthread_mutex_unlock(&jobs.mu);
    free_chain(chain);
    return s;
}

int lrd_job_forget(lrd_job *j)
{
    lrd_job *chain = NULL;
    int rc = 0;
    pthread_mutex_lock(&jobs.mu);
    if (j->state < LRD_DONE)
        rc = -1;
    else
        unlink_locked(j, &chain);
    pthread_mutex_unlock(&jobs.mu);
    free_chain(chain);
    return rc;
}

void lrd_job_result_get(lrd_job *j, lrd_job_result *out)
{
    memset(out, 0, sizeof *out);
    pthread_mutex_lock(&jobs.mu);
    out->state = j->state;
    out->format = j->spec.out.format;
    out->cancel_reason = j->cancel_reason;
    if (j->state >= LRD_DONE) {
        out->stats = j->stats;
        out->err = j->err;
        if (j->image != NULL)
            out->image = lrd_blob_ref(j->image);
    }
    pthread_mutex_unlock(&jobs.mu);
}

static void add_time(cJSON *o, const char *key, double wall, int set)
{
    if (!set) {
        cJSON_AddNullToObject(o, key);
        return;
    }
    char iso[32];
    lrd_iso8601(wall, iso);
    cJSON_AddStringToObject(o, key, iso);
}

/* Rounds to microseconds so that the JSON stays short. */
static double us(double seconds)
{
    return round(seconds * 1e6) / 1e6;
}

char *lrd_job_status_json(lrd_job *j)
{
    /* Copy what is needed under the lock, build the JSON without it. */
    pthread_mutex_lock(&jobs.mu);
    lrd_job c = *j;
    size_t image_len = j->image ? j->image->len : 0;
    int has_image = j->image != NULL;
    double now = lrd_monotonic();
    pthread_mutex_unlock(&jobs.mu);

    cJSON *o = cJSON_CreateObject();
    if (o == NULL)
        return NULL;
    cJSON_AddStringToObject(o, "id", c.id);
    cJSON_AddStringToObject(o, "status", lrd_state_name(c.state));
    if (c.key[0] != '\0')
        cJSON_AddStringToObject(o, "idempotency_key", c.key);
    double progress = c.state == LRD_DONE ? 1.0
                      : c.total_px > 0 ? (double)c.done_px / (double)c.total_px
                                       : 0.0;
    cJSON_AddNumberToObject(o, "progress", round(progress * 1e4) / 1e4);
    if (c.spec.scene_name[0] != '\0')
        cJSON_AddStringToObject(o, "scene", c.spec.scene_name);
    else
        cJSON_AddStringToObject(o, "scene", "(inline)");
    cJSON_AddNumberToObject(o, "width", c.spec.width);
    cJSON_AddNumberToObject(o, "height", c.spec.height);
    cJSON_AddNumberToObject(o, "spp", c.spec.rs.spp);
    cJSON_AddStringToObject(o, "format", lr_format_name(c.spec.out.format));
    /* The camera the render uses, its autofocus resolved (one ray): what
     * a click on the page focused on.  The spec is immutable and the
     * caller's reference keeps its scene. */
    char *cam = lrd_spec_camera_json(&j->spec);
    if (cam == NULL || cJSON_AddRawToObject(o, "camera", cam) == NULL) {
        lr_free(cam);
        cJSON_Delete(o);
        return NULL;
    }
    lr_free(cam);
    /* A job cancelled in the queue never started: started is 0. */
    int ran = c.started > 0;
    add_time(o, "created_at", c.created_wall, 1);
    add_time(o, "started_at", c.started_wall, ran);
    add_time(o, "finished_at", c.finished_wall, c.state >= LRD_DONE);

    cJSON *t = cJSON_AddObjectToObject(o, "timings");
    if (t != NULL) {
        double ended = c.state >= LRD_DONE ? c.finished : now;
        double left_queue = ran ? c.started : ended;
        cJSON_AddNumberToObject(t, "queued_seconds",
                                us(left_queue - c.created));
        cJSON_AddNumberToObject(t, "render_seconds",
                                !ran ? 0.0
                                : c.state == LRD_DONE
                                    ? us(c.stats.seconds)
                                    : us(ended - c.started - c.encode_seconds));
        cJSON_AddNumberToObject(t, "encode_seconds", us(c.encode_seconds));
        cJSON_AddNumberToObject(t, "total_seconds", us(ended - c.created));
    }
    if (c.state == LRD_DONE) {
        /* The library's stats JSON, the same as the CLI's --stats. */
        char *stats = lr_render_stats_json(&c.stats, &c.spec.rs,
                                           lrd_scene_get(c.spec.scene));
        if (stats == NULL || cJSON_AddRawToObject(o, "stats", stats) == NULL) {
            lr_free(stats);
            cJSON_Delete(o);
            return NULL;
        }
        lr_free(stats);
        if (has_image) {
            cJSON *im = cJSON_AddObjectToObject(o, "image");
            char href[64];
            snprintf(href, sizeof href, "/v1/jobs/%s/image", c.id);
            if (im != NULL) {
                cJSON_AddStringToObject(im, "href", href);
                cJSON_AddStringToObject(im, "content_type",
                                        lr_format_mime(c.spec.out.format));
                cJSON_AddNumberToObject(im, "bytes", (double)image_len);
            }
        }
    }
    if (c.state == LRD_FAILED || c.state == LRD_CANCELLED) {
        cJSON *er = cJSON_AddObjectToObject(o, "error");
        if (er != NULL) {
            cJSON_AddStringToObject(er, "code", c.err.code);
            cJSON_AddStringToObject(er, "message", c.err.message);
            if (c.err.path[0] != '\0')
                cJSON_AddStringToObject(er, "path", c.err.path);
        }
    }
    char *text = lrd_json_print(o);
    cJSON_Delete(o);
    return text;
}

void lrd_jobs_stats_get(lrd_jobs_stats *out)
{
    memset(out, 0, sizeof *out);
    pthread_mutex_lock(&jobs.mu);
    for (int s = 0; s < LRD_N_STATES; s++) {
        out->in_state[s] = jobs.in_state[s];
        out->finished[s] = jobs.finished[s];
    }
    out->queue_depth = jobs.queued;
    out->running = jobs.running;
    out->rays = jobs.rays;
    out->samples = jobs.samples;
    out->pixels = jobs.pixels;
    out->rejected_full = jobs.rejected_full;
    out->render_seconds = jobs.render_seconds;
    for (lrd_job *j = jobs.head; j != NULL; j = j->next)
        if (j->image != NULL)
            out->retained_bytes += j->image->len;
    pthread_mutex_unlock(&jobs.mu);
}

/* ---- shutdown ------------------------------------------------------------ */

void lrd_jobs_begin_shutdown(void)
{
    lrd_job *chain = NULL;
    pthread_mutex_lock(&jobs.mu);
    jobs.shutting_down = 1;
    while (jobs.qhead != NULL) {
        lrd_job *j = jobs.qhead;
        jobs.qhead = j->qnext;
        j->qnext = NULL;
        jobs.queued--;
        j->cancel_reason = LRD_CANCEL_SHUTDOWN;
        cancel_error_locked(j, &chain);
    }
    jobs.qtail = NULL;
    pthread_mutex_unlock(&jobs.mu);
    free_chain(chain);
}

long lrd_jobs_running(void)
{
    pthread_mutex_lock(&jobs.mu);
    long n = jobs.running;
    pthread_mutex_unlock(&jobs.mu);
    return n;
}

void lrd_jobs_cancel_running(lrd_cancel_reason why)
{
    pthread_mutex_lock(&jobs.mu);
    for (lrd_job *j = jobs.head; j != NULL; j = j->next)
        if (j->state == LRD_RUNNING && !j->cancel) {
            j->cancel_reason = why;
            set_cancel(j);
        }
    pthread_mutex_unlock(&jobs.mu);
}

void lrd_jobs_stop(void)
{
    pthread_mutex_lock(&jobs.mu);
    jobs.stop = 1;
    pthread_cond_broadcast(&jobs.work_cv);
    pthread_mutex_unlock(&jobs.mu);
    for (long i = 0; i < jobs.n_threads; i++)
        pthread_join(jobs.threads[i], NULL);
    jobs.n_threads = 0;
    free(jobs.threads);
    jobs.threads = NULL;
}

void lrd_jobs_free_all(void)
{
    lrd_job *chain = NULL;
    pthread_mutex_lock(&jobs.mu);
    while (jobs.head != NULL)
        unlink_locked(jobs.head, &chain);
    pthread_mutex_unlock(&jobs.mu);
    free_chain(chain);
}
