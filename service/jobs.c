/*
 * jobs.c: the job table, the queue and the worker pool: the table and
 * the API here, the workers in jobs_worker.c, the status and list
 * documents in jobs_json.c, sharing jobs.h.
 *
 * Every job, synchronous or not, goes through one FIFO queue to a fixed
 * pool of worker threads, so HTTP threads never render and a slow or
 * vanished client never holds a worker: a worker only writes the encoded
 * image into the job and moves on.
 *
 * Ownership and locking: one mutex, lrd_jobs.mu, guards the table, the queue,
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
#include "jobs.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

struct lrd_jobs_table lrd_jobs = {.mu = PTHREAD_MUTEX_INITIALIZER};

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

void lrd_jobs_free_chain(lrd_job *j)
{
    while (j != NULL) {
        lrd_job *next = j->qnext;
        job_free(j);
        j = next;
    }
}

/* Called with lrd_jobs.mu held: takes `j` out of the table and drops the
 * table's reference; a job whose last reference that was is pushed on
 * *chain for the caller to free after unlocking. */
static void unlink_locked(lrd_job *j, lrd_job **chain)
{
    if (!j->in_table)
        return;
    if (j->prev != NULL)
        j->prev->next = j->next;
    else
        lrd_jobs.head = j->next;
    if (j->next != NULL)
        j->next->prev = j->prev;
    else
        lrd_jobs.tail = j->prev;
    j->prev = j->next = NULL;
    j->in_table = 0;
    lrd_jobs.in_state[j->state]--;
    size_t g = (size_t)(lrd_jobs.n_gone++ % LRD_GONE_KEPT);
    memcpy(lrd_jobs.gone[g].id, j->id, sizeof j->id);
    lrd_jobs.gone[g].seq = j->seq;
    if (--j->refs == 0) {
        j->qnext = *chain;
        *chain = j;
    }
}

void lrd_job_set_state_locked(lrd_job *j, lrd_state s)
{
    if (j->in_table) {
        lrd_jobs.in_state[j->state]--;
        lrd_jobs.in_state[s]++;
    }
    j->state = s;
    /* Waiters on any change (GET /v1/jobs/{id}?wait=) re-check. */
    pthread_cond_broadcast(&lrd_jobs.done_cv);
}

/* Called with lrd_jobs.mu held: drops finished asynchronous jobs that are too
 * old, too many or hold too many image bytes. */
void lrd_jobs_prune_locked(lrd_job **chain)
{
    double now = lrd_monotonic();
    long n_finished = 0;
    uint64_t bytes = 0;
    for (lrd_job *j = lrd_jobs.head; j != NULL;) {
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
        for (lrd_job *j = lrd_jobs.head; j != NULL; j = j->next)
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

/* Called with lrd_jobs.mu held: the job reached a final state. */
void lrd_job_finish_locked(lrd_job *j, lrd_state s, lrd_job **chain)
{
    lrd_job_set_state_locked(j, s);
    j->finished = lrd_monotonic();
    j->finished_wall = lrd_wall();
    lrd_jobs.finished[s]++;
    if (s == LRD_DONE) {
        lrd_jobs.rays += j->stats.rays;
        lrd_jobs.samples += j->stats.samples;
        lrd_jobs.pixels += j->stats.pixels;
    }
    /* A synchronous job with an Idempotency-Key stays, so that a retry
     * of its request gets its image rather than a second render. */
    if (j->sync && j->key[0] == '\0')
        unlink_locked(j, chain);
    pthread_cond_broadcast(&lrd_jobs.done_cv);
}

void lrd_job_cancel_error_locked(lrd_job *j, lrd_job **chain)
{
    switch (j->cancel_reason) {
    case LRD_CANCEL_TIMEOUT:
        lrd_fail(&j->err, 504, "timeout", NULL,
                 "the render took longer than the limit of %g seconds "
                 "(--max-render-seconds)",
                 lrd_cfg.max_render_seconds);
        lrd_job_finish_locked(j, LRD_FAILED, chain);
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
    lrd_job_finish_locked(j, LRD_CANCELLED, chain);
}

/* ---- the API ------------------------------------------------------------- */

/* Called with lrd_jobs.mu held: the job in the table made with `key`, or
 * NULL. */
static lrd_job *keyed_locked(const char *key)
{
    for (lrd_job *j = lrd_jobs.head; j != NULL; j = j->next)
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
    pthread_mutex_lock(&lrd_jobs.mu);
    lrd_jobs_prune_locked(&chain);
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
    } else if (lrd_jobs.shutting_down) {
        rc = lrd_fail(e, 503, "shutting_down", NULL,
                      "the server is shutting down");
        e->retry_after = 1;
    } else if (lrd_jobs.queued + lrd_jobs.running >=
               lrd_cfg.workers + lrd_cfg.queue) {
        lrd_jobs.rejected_full++;
        /* A place in the queue frees when any running job ends: on
         * average a job's time over the workers.  (It was the time to
         * drain the whole queue: 12 s where a place freed in 3, and the
         * --remote client waited as asked while workers sat idle.) */
        double wait = lrd_jobs.avg_job_seconds / (double)lrd_cfg.workers;
        int secs = (int)ceil(wait);
        secs = secs < 1 ? 1 : secs > 3600 ? 3600 : secs;
        rc = lrd_fail(e, 429, "queue_full", NULL,
                      "the queue is full: %ld jobs waiting and %ld running "
                      "(--queue %ld, --workers %ld); retry later",
                      lrd_jobs.queued, lrd_jobs.running, lrd_cfg.queue,
                      lrd_cfg.workers);
        e->retry_after = secs;
    } else {
        j->refs = 2; /* the table's and the caller's */
        j->in_table = 1;
        j->seq = ++lrd_jobs.last_seq;
        j->state = LRD_QUEUED;
        lrd_jobs.in_state[LRD_QUEUED]++;
        j->prev = lrd_jobs.tail;
        if (lrd_jobs.tail != NULL)
            lrd_jobs.tail->next = j;
        else
            lrd_jobs.head = j;
        lrd_jobs.tail = j;
        if (lrd_jobs.qtail != NULL)
            lrd_jobs.qtail->qnext = j;
        else
            lrd_jobs.qhead = j;
        lrd_jobs.qtail = j;
        lrd_jobs.queued++;
        pthread_cond_signal(&lrd_jobs.work_cv);
        lrd_jobs_prune_locked(&chain);
        *out = j;
    }
    pthread_mutex_unlock(&lrd_jobs.mu);
    lrd_jobs_free_chain(chain);
    /* Not queued (an error, or the earlier job returned): the new job and
     * its scene reference go, outside the lock. */
    if (*out != j)
        job_free(j);
    return rc;
}

lrd_job *lrd_jobs_find(const char *id)
{
    lrd_job *chain = NULL, *found = NULL;
    pthread_mutex_lock(&lrd_jobs.mu);
    lrd_jobs_prune_locked(&chain);
    for (lrd_job *j = lrd_jobs.head; j != NULL; j = j->next)
        if (strcmp(j->id, id) == 0) {
            j->refs++;
            found = j;
            break;
        }
    pthread_mutex_unlock(&lrd_jobs.mu);
    lrd_jobs_free_chain(chain);
    return found;
}

void lrd_job_release(lrd_job *j)
{
    if (j == NULL)
        return;
    pthread_mutex_lock(&lrd_jobs.mu);
    int last = --j->refs == 0;
    pthread_mutex_unlock(&lrd_jobs.mu);
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
    pthread_mutex_lock(&lrd_jobs.mu);
    while (j->state < LRD_DONE) {
        if (pthread_cond_timedwait(&lrd_jobs.done_cv, &lrd_jobs.mu, &until) !=
            0)
            break;
    }
    int finished = j->state >= LRD_DONE;
    pthread_mutex_unlock(&lrd_jobs.mu);
    return finished;
}

lrd_state lrd_job_wait_change(lrd_job *j, lrd_state from, double seconds)
{
    struct timespec until = deadline(seconds);
    pthread_mutex_lock(&lrd_jobs.mu);
    while (j->state == from && !lrd_jobs.shutting_down) {
        if (pthread_cond_timedwait(&lrd_jobs.done_cv, &lrd_jobs.mu, &until) !=
            0)
            break;
    }
    lrd_state now = j->state;
    pthread_mutex_unlock(&lrd_jobs.mu);
    return now;
}

int lrd_job_keyed(const lrd_job *j)
{
    return j->key[0] != '\0';
}

lrd_state lrd_job_cancel(lrd_job *j, lrd_cancel_reason why)
{
    lrd_job *chain = NULL;
    pthread_mutex_lock(&lrd_jobs.mu);
    if (j->state == LRD_QUEUED) {
        lrd_job **pp = &lrd_jobs.qhead;
        lrd_job *prev = NULL;
        while (*pp != NULL && *pp != j) {
            prev = *pp;
            pp = &(*pp)->qnext;
        }
        if (*pp == j) {
            *pp = j->qnext;
            if (lrd_jobs.qtail == j)
                lrd_jobs.qtail = prev;
            j->qnext = NULL;
            lrd_jobs.queued--;
        }
        j->cancel_reason = why;
        lrd_job_cancel_error_locked(j, &chain);
    } else if (j->state == LRD_RUNNING && !j->cancel) {
        j->cancel_reason = why;
        lrd_job_set_cancel(j);
    }
    lrd_state s = j->state;
    pthread_mutex_unlock(&lrd_jobs.mu);
    lrd_jobs_free_chain(chain);
    return s;
}

int lrd_job_forget(lrd_job *j)
{
    lrd_job *chain = NULL;
    int rc = 0;
    pthread_mutex_lock(&lrd_jobs.mu);
    if (j->state < LRD_DONE)
        rc = -1;
    else
        unlink_locked(j, &chain);
    pthread_mutex_unlock(&lrd_jobs.mu);
    lrd_jobs_free_chain(chain);
    return rc;
}

void lrd_job_result_get(lrd_job *j, lrd_job_result *out)
{
    memset(out, 0, sizeof *out);
    pthread_mutex_lock(&lrd_jobs.mu);
    out->state = j->state;
    out->format = j->spec.out.format;
    out->cancel_reason = j->cancel_reason;
    if (j->state >= LRD_DONE) {
        out->stats = j->stats;
        out->err = j->err;
        if (j->image != NULL)
            out->image = lrd_blob_ref(j->image);
    }
    pthread_mutex_unlock(&lrd_jobs.mu);
}

void lrd_jobs_stats_get(lrd_jobs_stats *out)
{
    memset(out, 0, sizeof *out);
    pthread_mutex_lock(&lrd_jobs.mu);
    for (int s = 0; s < LRD_N_STATES; s++) {
        out->in_state[s] = lrd_jobs.in_state[s];
        out->finished[s] = lrd_jobs.finished[s];
    }
    out->queue_depth = lrd_jobs.queued;
    out->running = lrd_jobs.running;
    out->rays = lrd_jobs.rays;
    out->samples = lrd_jobs.samples;
    out->pixels = lrd_jobs.pixels;
    out->rejected_full = lrd_jobs.rejected_full;
    out->render_seconds = lrd_jobs.render_seconds;
    for (lrd_job *j = lrd_jobs.head; j != NULL; j = j->next)
        if (j->image != NULL)
            out->retained_bytes += j->image->len;
    pthread_mutex_unlock(&lrd_jobs.mu);
}

/* ---- shutdown ------------------------------------------------------------ */

void lrd_jobs_begin_shutdown(void)
{
    lrd_job *chain = NULL;
    pthread_mutex_lock(&lrd_jobs.mu);
    lrd_jobs.shutting_down = 1;
    while (lrd_jobs.qhead != NULL) {
        lrd_job *j = lrd_jobs.qhead;
        lrd_jobs.qhead = j->qnext;
        j->qnext = NULL;
        lrd_jobs.queued--;
        j->cancel_reason = LRD_CANCEL_SHUTDOWN;
        lrd_job_cancel_error_locked(j, &chain);
    }
    lrd_jobs.qtail = NULL;
    pthread_mutex_unlock(&lrd_jobs.mu);
    lrd_jobs_free_chain(chain);
}

long lrd_jobs_running(void)
{
    pthread_mutex_lock(&lrd_jobs.mu);
    long n = lrd_jobs.running;
    pthread_mutex_unlock(&lrd_jobs.mu);
    return n;
}

void lrd_jobs_enforce_time(void)
{
    if (!(lrd_cfg.max_render_seconds > 0))
        return;
    double now = lrd_monotonic();
    pthread_mutex_lock(&lrd_jobs.mu);
    for (lrd_job *j = lrd_jobs.head; j != NULL; j = j->next)
        if (j->state == LRD_RUNNING && !j->cancel &&
            now - j->started > lrd_cfg.max_render_seconds) {
            j->cancel_reason = LRD_CANCEL_TIMEOUT;
            lrd_job_set_cancel(j);
        }
    pthread_mutex_unlock(&lrd_jobs.mu);
}

void lrd_jobs_cancel_running(lrd_cancel_reason why)
{
    pthread_mutex_lock(&lrd_jobs.mu);
    for (lrd_job *j = lrd_jobs.head; j != NULL; j = j->next)
        if (j->state == LRD_RUNNING && !j->cancel) {
            j->cancel_reason = why;
            lrd_job_set_cancel(j);
        }
    pthread_mutex_unlock(&lrd_jobs.mu);
}

void lrd_jobs_stop(void)
{
    pthread_mutex_lock(&lrd_jobs.mu);
    lrd_jobs.stop = 1;
    pthread_cond_broadcast(&lrd_jobs.work_cv);
    pthread_mutex_unlock(&lrd_jobs.mu);
    for (long i = 0; i < lrd_jobs.n_threads; i++)
        pthread_join(lrd_jobs.threads[i], NULL);
    lrd_jobs.n_threads = 0;
    free(lrd_jobs.threads);
    lrd_jobs.threads = NULL;
}

void lrd_jobs_free_all(void)
{
    lrd_job *chain = NULL;
    pthread_mutex_lock(&lrd_jobs.mu);
    while (lrd_jobs.head != NULL)
        unlink_locked(lrd_jobs.head, &chain);
    pthread_mutex_unlock(&lrd_jobs.mu);
    lrd_jobs_free_chain(chain);
}
