/*
 * jobs.h: the insides of the job table (jobs.c), as its three files share
 * them: jobs.c (the table, the queue and the API), jobs_worker.c (the
 * worker pool) and jobs_json.c (the status and list documents).  Nothing
 * else in the daemon includes it; the rest sees lensrayd.h's lrd_job_*.
 *
 * Ownership and locking are jobs.c's header comment's: one mutex,
 * lrd_jobs.mu, guards the table, the queue, every job's mutable fields and
 * every job's reference count.
 */
#ifndef LRD_JOBS_H
#define LRD_JOBS_H

#include "lensrayd.h"

#include <pthread.h>
#include <stdatomic.h>

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
    /* Polled by lr_render between tiles; written under lrd_jobs.mu. */
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

struct lrd_jobs_table {
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
};


/* The one job table of the daemon (jobs.c). */
extern struct lrd_jobs_table lrd_jobs;

/* Frees a chain of jobs linked by qnext (after unlocking). */
void lrd_jobs_free_chain(lrd_job *j);

/* Called with lrd_jobs.mu held: drops finished asynchronous jobs that are
 * too old, too many or hold too many image bytes; jobs to free go on
 * *chain. */
void lrd_jobs_prune_locked(lrd_job **chain);

/* Called with lrd_jobs.mu held: the job's state, its count and waiters. */
void lrd_job_set_state_locked(lrd_job *j, lrd_state s);

/* Called with lrd_jobs.mu held: the job reached a final state. */
void lrd_job_finish_locked(lrd_job *j, lrd_state s, lrd_job **chain);

/* Called with lrd_jobs.mu held: a cancelled job's error, by its reason,
 * and its final state. */
void lrd_job_cancel_error_locked(lrd_job *j, lrd_job **chain);

/* Raises the flag lr_render polls (jobs_worker.c). */
void lrd_job_set_cancel(lrd_job *j);

#endif
