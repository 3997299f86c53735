/*
 * jobs_json.c: the job table's documents (jobs.h): a job's status
 * (GET /v1/jobs/{id}) and the paged list (GET /v1/jobs).  Each copies what
 * it needs under lrd_jobs.mu and builds the JSON without it.
 */
#include "jobs.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Called with lrd_jobs.mu held: the place in the table of job `id`, listed
 * or departed lately; 0 when it is neither. */
static uint64_t seq_of_locked(const char *id)
{
    for (lrd_job *j = lrd_jobs.head; j != NULL; j = j->next)
        if (strcmp(j->id, id) == 0)
            return j->seq;
    uint64_t n = lrd_jobs.n_gone < LRD_GONE_KEPT ? lrd_jobs.n_gone
                                                 : LRD_GONE_KEPT;
    for (uint64_t i = 0; i < n; i++)
        if (strcmp(lrd_jobs.gone[i].id, id) == 0)
            return lrd_jobs.gone[i].seq;
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
    pthread_mutex_lock(&lrd_jobs.mu);
    lrd_jobs_prune_locked(&chain);
    /* The page starts after the cursor's place, which the job keeps when
     * it leaves the table between two pages (expired, deleted). */
    uint64_t from = 0;
    if (after != NULL && after[0] != '\0') {
        from = seq_of_locked(after);
        *unknown_after = from == 0;
    }
    for (lrd_job *j = lrd_jobs.head; j != NULL && !*unknown_after;
         j = j->next) {
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
    pthread_mutex_unlock(&lrd_jobs.mu);
    lrd_jobs_free_chain(chain);
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
    pthread_mutex_lock(&lrd_jobs.mu);
    lrd_job c = *j;
    size_t image_len = j->image ? j->image->len : 0;
    int has_image = j->image != NULL;
    double now = lrd_monotonic();
    pthread_mutex_unlock(&lrd_jobs.mu);

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
