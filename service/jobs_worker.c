/*
 * jobs_worker.c: the worker pool of the job table (jobs.h): each worker
 * takes the oldest queued job, renders and encodes it outside the lock,
 * and publishes the result into the job under lrd_jobs.mu.  HTTP threads
 * never render.
 */
#include "jobs.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- the workers --------------------------------------------------------- */

/* Raises the flag lr_render polls.  The library takes a plain
 * `const volatile int *`, so its reads are not atomic; the store at least
 * is, and happens under lrd_jobs.mu like every other write to the job. */
void lrd_job_set_cancel(lrd_job *j)
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
    pthread_mutex_lock(&lrd_jobs.mu);
    j->done_px = done;
    j->total_px = total;
    if (!j->cancel && lrd_cfg.max_render_seconds > 0 &&
        lrd_monotonic() - j->started > lrd_cfg.max_render_seconds) {
        j->cancel_reason = LRD_CANCEL_TIMEOUT;
        lrd_job_set_cancel(j);
    }
    pthread_mutex_unlock(&lrd_jobs.mu);
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
/* "scene" when a render's error names a part of a scene the job sent
 * (inline or as an asset), which api.md's paths carry under "scene."
 * (lights[1], materials.glow); else NULL.  (camera and render may come
 * from the scene or from the job's own fields: left as they are.) */
static const char *scene_part(const lrd_job_spec *sp, const char *path)
{
    static const char *const parts[] = {"lights",      "materials",  "objects",
                                        "environment", "background", NULL};
    if (sp->scene_name[0] != '\0' && strncmp(sp->scene_name, "sha256:", 7))
        return NULL; /* a scene of the server's */
    for (int k = 0; parts[k] != NULL; k++) {
        size_t n = strlen(parts[k]);
        if (strncmp(path, parts[k], n) == 0 &&
            (path[n] == '\0' || path[n] == '[' || path[n] == '.'))
            return "scene";
    }
    return NULL;
}

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
        lrd_fail_lr(&out->err, &le, scene_part(sp, le.path), NULL);
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
        lrd_fail_lr(&out->err, &le, "output", NULL);
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
    pthread_mutex_lock(&lrd_jobs.mu);
    for (;;) {
        while (!lrd_jobs.stop && lrd_jobs.qhead == NULL)
            pthread_cond_wait(&lrd_jobs.work_cv, &lrd_jobs.mu);
        if (lrd_jobs.qhead == NULL)
            break; /* stopping, and nothing left */
        lrd_job *j = lrd_jobs.qhead;
        lrd_jobs.qhead = j->qnext;
        if (lrd_jobs.qhead == NULL)
            lrd_jobs.qtail = NULL;
        j->qnext = NULL;
        lrd_jobs.queued--;
        lrd_jobs.running++;
        j->refs++; /* the worker's */
        lrd_job_set_state_locked(j, LRD_RUNNING);
        j->started = lrd_monotonic();
        j->started_wall = lrd_wall();
        pthread_mutex_unlock(&lrd_jobs.mu);

        run_result out;
        lrd_state result = run(j, &out);

        lrd_job *chain = NULL;
        pthread_mutex_lock(&lrd_jobs.mu);
        lrd_jobs.running--;
        j->image = out.image;
        j->stats = out.stats;
        j->encode_seconds = out.encode_seconds;
        if (result == LRD_FAILED)
            j->err = out.err;
        double took = lrd_monotonic() - j->started;
        lrd_jobs.render_seconds += took;
        if (result == LRD_DONE) {
            lrd_jobs.avg_job_seconds = lrd_jobs.avg_job_seconds > 0
                                           ? 0.8 * lrd_jobs.avg_job_seconds +
                                                 0.2 * took
                                           : took;
            lrd_job_finish_locked(j, LRD_DONE, &chain);
        } else if (result == LRD_CANCELLED) {
            lrd_job_cancel_error_locked(j, &chain);
        } else {
            lrd_job_finish_locked(j, LRD_FAILED, &chain);
        }
        lrd_jobs_prune_locked(&chain);
        if (--j->refs == 0) {
            j->qnext = chain;
            chain = j;
        }
        pthread_mutex_unlock(&lrd_jobs.mu);
        lrd_jobs_free_chain(chain);
        pthread_mutex_lock(&lrd_jobs.mu);
    }
    pthread_mutex_unlock(&lrd_jobs.mu);
    return NULL;
}

int lrd_jobs_start(void)
{
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&lrd_jobs.work_cv, NULL);
    pthread_cond_init(&lrd_jobs.done_cv, &ca);
    pthread_condattr_destroy(&ca);
    lrd_jobs.threads = calloc((size_t)lrd_cfg.workers,
                              sizeof *lrd_jobs.threads);
    if (lrd_jobs.threads == NULL)
        return -1;
    for (long i = 0; i < lrd_cfg.workers; i++) {
        if (pthread_create(&lrd_jobs.threads[i], NULL, worker_main, NULL) !=
            0) {
            fprintf(stderr, "lensrayd: cannot start worker thread %ld\n",
                    i + 1);
            lrd_jobs_stop();
            return -1;
        }
        lrd_jobs.n_threads++;
    }
    return 0;
}
