/*
 * render.c: the render loop: tiles handed out to a pool of threads, the
 * samples of each pixel accumulated in order by one thread (so the result
 * does not depend on the thread count or tile size), progress and
 * cancellation between tiles, and the statistics.  What to simulate where
 * is the plan's (plan.c), how many samples adaptive.c's, what a sample is
 * sample.c's.
 */
#include "render/adaptive.h"
#include "render/autofocus.h"
#include "camera/camera.h"
#include "render/film.h"
#include "integrator/ghost_trace.h"
#include "integrator/integrator.h"
#include "render/pilots.h"
#include "render/plan.h"
#include "render/sample.h"
#include "sampling/sampler.h"
#include "render/splat.h"
#include "util/fp_mode.h"

#include <math.h>
#include <pmmintrin.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <xmmintrin.h>

/* One render: what its threads share. */
typedef struct render {
    const lr_render_settings *set;
    lr__cam cam;
    lr__sampler sampler;
    lr__shot shot;
    lr__plan plan;
    lr__splat *splat;  /* the plan's splat mode: its units replace tiles */
    lr__pilots pilots; /* adaptive sampling's pilots shared between tiles */
    lr__lt_film light; /* the light side's splats (plan.lt), if any */
    atomic_ullong next_light;
    lr_image *img;
    int x0, y0, x1, y1; /* the region rendered, in frame pixels */
    int tiles_x, tiles_y;
    atomic_int next_tile;
    atomic_int cancelled;
    pthread_mutex_t progress_lock;
    uint64_t pixels_done; /* camera tiles' pixels finished */
    uint64_t light_done;  /* light units finished, of n_light */
    uint64_t n_light;
    double light_share; /* of the render's work (progress_share) */
    uint64_t shown;     /* the last `done` given to the callback */
} render;

typedef struct worker {
    render *r;
    int index;  /* 0 .. threads - 1 */
    double cpu; /* CPU seconds of this thread in worker_main */
    lr__sample_counts counts;
    uint64_t pixels, samples, dropped, lens_pixels, chroma_pixels;
    uint64_t light_landed, ghost_landed;
    lr__block_scratch scratch;
} worker;

static void sample_cb(void *ctx, int x, int y, int first, int last,
                      lr__pixel *acc)
{
    worker *w = ctx;
    lr__sample_pixel(&w->r->shot, lr__plan_at(&w->r->plan, x, y), x, y, first,
                     last, acc, &w->counts);
}

static void sample_n_cb(void *ctx, int n, const lr__span *spans)
{
    worker *w = ctx;
    lr__sample_pixels(&w->r->shot, &w->r->plan, n, spans, &w->counts);
}

/* Writes a finished pixel (and its Z) into the image, and counts it. */
static void store_cb(void *ctx, int x, int y, const lr__pixel *acc)
{
    worker *w = ctx;
    render *r = w->r;
    w->pixels++;
    w->samples += acc->n;
    w->dropped += acc->dropped;
    size_t out = (size_t)(y - r->y0) * (size_t)r->img->width +
                 (size_t)(x - r->x0);
    lr__pixel_resolve(acc, &r->img->rgb[3 * out]);
    if (r->img->depth != NULL)
        r->img->depth[out] = lr__sample_depth(&r->shot, x, y, &w->counts);
    const lr__block_plan *bp = lr__plan_at(&r->plan, x, y);
    w->lens_pixels += bp->lens;
    w->chroma_pixels += bp->chroma;
}

static void render_tile(worker *w, int x0, int y0, int x1, int y1)
{
    lr__block_io io = {sample_cb, sample_n_cb, store_cb, w};
    for (int y = y0; y < y1; y += LR__BLOCK_MAX)
        for (int x = x0; x < x1; x += LR__BLOCK_MAX)
            lr__adaptive_block(w->r->set, &w->r->plan, x, y,
                               x + LR__BLOCK_MAX < x1 ? x + LR__BLOCK_MAX : x1,
                               y + LR__BLOCK_MAX < y1 ? y + LR__BLOCK_MAX : y1,
                               &w->scratch, &w->r->pilots, &io);
}

/* CPU time of the calling thread. */
static double thread_cpu_seconds(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0)
        return 0.0;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Whether the render is cancelled, by the caller's flag (read
 * atomically, so that a flag set by another thread with
 * __atomic_store_n, or a plain store from a signal handler, is a
 * race-free handshake) or already by another worker. */
static int stopped(render *j)
{
    const volatile int *flag = j->set->cancel;
    if (flag != NULL && __atomic_load_n(flag, __ATOMIC_RELAXED))
        atomic_store(&j->cancelled, 1);
    return atomic_load(&j->cancelled);
}

/* The light side's share of the render's work, for progress: its units'
 * paths against the camera's samples in the blocks where it traces any
 * (a dark block traces none; the light integrator's camera only looks
 * for what is seen directly, a sample a pixel).  An estimate: a path
 * and a camera sample cost about alike. */
static double progress_share(const render *j)
{
    const lr__lt *lt = j->plan.lt;
    if (lt == NULL || j->n_light == 0)
        return 0.0;
    const lr_render_settings *set = j->set;
    double per = set->integrator == LR_INTEGRATOR_LIGHT ? 1.0 : set->spp;
    double cam = 0.0;
    /* The plan's own dark blocks (the light side keeps a copy only where
     * a light mixes: night.json's camera had been priced at every
     * sample, and progress said 0.89 at 0.02 s of 4.9), block by block:
     * each the part of it inside the region. */
    const int B = LR__PLAN_BLOCK;
    for (int y = j->y0; y < j->y1; y = (y / B + 1) * B) {
        int h = ((y / B + 1) * B < j->y1 ? (y / B + 1) * B : j->y1) - y;
        for (int x = j->x0; x < j->x1; x = (x / B + 1) * B) {
            int w = ((x / B + 1) * B < j->x1 ? (x / B + 1) * B : j->x1) - x;
            cam += lr__plan_at(&j->plan, x, y)->dark ? 0.0 : per * w * h;
        }
    }
    double light = (double)j->n_light * LR__LT_CHUNK;
    return light / (light + cam);
}

/* Adds a finished tile's pixels or light units and tells the caller's
 * callback: `done` is the pixels' count weighted by the work done of
 * both sides (the tiles' (1 - share), the light units' share), so that
 * it reaches `total` when the light side ends, not with the last tile
 * (a light-integrator render said 100% at 0.002 s of 8.4).  Called after
 * every tile, and for light units when `done` grows by a thousandth;
 * the last call is done == total. */
static void progress(render *j, uint64_t pixels, uint64_t light)
{
    const lr_render_settings *set = j->set;
    uint64_t total = (uint64_t)(j->x1 - j->x0) * (uint64_t)(j->y1 - j->y0);
    pthread_mutex_lock(&j->progress_lock);
    j->pixels_done += pixels;
    j->light_done += light;
    uint64_t v = total;
    if (j->pixels_done < total || j->light_done < j->n_light) {
        double f = (1.0 - j->light_share) * (double)j->pixels_done /
                   (double)total;
        if (j->n_light > 0)
            f += j->light_share * (double)j->light_done / (double)j->n_light;
        v = (uint64_t)(f * (double)total);
        v = v < total ? v : total - 1;
    }
    uint64_t step = light > 0 ? total / 1000 + 1 : 1;
    if (set->progress != NULL && v > j->shown &&
        (v - j->shown >= step || v == total)) {
        j->shown = v;
        set->progress(set->progress_user, v, total);
    }
    pthread_mutex_unlock(&j->progress_lock);
}

static void *worker_main(void *arg)
{
    worker *w = arg;
    render *j = w->r;
    const lr_render_settings *set = j->set;
    /* Denormals only slow traversal down; Embree recommends FTZ/DAZ. */
    double cpu0 = thread_cpu_seconds();
    unsigned csr = _mm_getcsr();
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    int n_tiles = j->splat != NULL ? lr__splat_units(j->splat)
                                   : j->tiles_x * j->tiles_y;
    for (;;) {
        if (stopped(j))
            break;
        int t = atomic_fetch_add(&j->next_tile, 1);
        if (t >= n_tiles)
            break;
        uint64_t done;
        if (j->splat != NULL) {
            done = lr__splat_unit(j->splat, t, w->index, &w->counts,
                                  &w->dropped);
        } else {
            int ts = set->tile_size;
            int x0 = j->x0 + (t % j->tiles_x) * ts;
            int y0 = j->y0 + (t / j->tiles_x) * ts;
            int x1 = x0 + ts < j->x1 ? x0 + ts : j->x1;
            int y1 = y0 + ts < j->y1 ? y0 + ts : j->y1;
            render_tile(w, x0, y0, x1, y1);
            done = (uint64_t)(x1 - x0) * (uint64_t)(y1 - y0);
        }
        progress(j, done, 0);
    }
    /* The light side, once every camera tile is taken: units of light
     * paths, in any order (their splats add as integers). */
    const lr__lt *lt = j->plan.lt;
    uint64_t n_light = lt != NULL ? lr__lt_units(lt) : 0;
    for (;;) {
        if (stopped(j))
            break;
        uint64_t u = atomic_fetch_add(&j->next_light, 1);
        if (u >= n_light)
            break;
        lr__lt_unit(lt, j->shot.scene, &j->cam, u, &j->light, &w->counts.rays,
                    &w->light_landed, &w->ghost_landed);
        progress(j, 0, 1);
    }
    _mm_setcsr(csr);
    w->cpu = thread_cpu_seconds() - cpu0;
    return NULL;
}

/* Runs n workers on j's tiles and light units and returns how many ran:
 * the calling thread is worker 0, and if a thread cannot be started the
 * others simply take more tiles. */
static int run_workers(render *j, worker *ws, pthread_t *tids, int n)
{
    int started = 1;
    for (int i = 0; i < n; i++) {
        memset(&ws[i], 0, offsetof(worker, scratch));
        ws[i].r = j;
        ws[i].index = i;
    }
    for (int i = 1; i < n; i++) {
        if (pthread_create(&tids[i], NULL, worker_main, &ws[i]) != 0)
            break;
        started++;
    }
    worker_main(&ws[0]);
    for (int i = 1; i < started; i++)
        pthread_join(tids[i], NULL);
    return started;
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The workers' counts added up into *sum (zeroed first). */
static void sum_workers(const worker *ws, int started, lr_render_stats *sum)
{
    memset(sum, 0, sizeof *sum);
    for (int i = 0; i < started; i++) {
        sum->rays += ws[i].counts.rays;
        sum->camera_rays += ws[i].counts.camera_rays;
        sum->lens_blocked += ws[i].counts.lens_blocked;
        sum->pixels += ws[i].pixels;
        sum->lens_pixels += ws[i].lens_pixels;
        sum->chroma_pixels += ws[i].chroma_pixels;
        sum->samples += ws[i].samples;
        sum->cpu_seconds += ws[i].cpu;
        sum->nan_samples += ws[i].dropped;
        sum->light_landed += ws[i].light_landed;
        sum->ghost_landed += ws[i].ghost_landed;
    }
}

/* Once the workers are done: the splat units' pixels and the light
 * side's splats resolved into the image (unless cancelled) and freed,
 * and their counts, with what a full render takes, into *sum.  Returns 1
 * when the light side ran out of memory (its light is then missing). */
static int finish_sides(render *j, lr_image *img, lr_render_stats *sum)
{
    int nomem = 0;
    const lr_render_settings *set = j->set;
    /* The pixels stored, all of the region's unless cancelled (a
     * cancelled render's stats said the whole region). */
    uint64_t area = (uint64_t)(j->x1 - j->x0) * (uint64_t)(j->y1 - j->y0);
    if (!atomic_load(&j->cancelled))
        sum->pixels = area;
    if (j->splat != NULL) {
        /* Every pixel takes spp samples, the lens and the colours. */
        if (!atomic_load(&j->cancelled))
            lr__splat_resolve(j->splat);
        lr__splat_free(j->splat);
        sum->samples = sum->pixels * (uint64_t)set->spp;
        sum->lens_pixels = sum->chroma_pixels = sum->pixels;
    }
    sum->full_samples = area * (uint64_t)set->spp;
    sum->full_camera_rays = sum->full_samples * lr__colour_rays(&j->cam);
    if (j->plan.lt != NULL) {
        const lr__lt *lt = j->plan.lt;
        sum->ghost_lights = (uint64_t)lt->ghost_lights;
        for (int k = 0; k < lt->n; k++)
            if (lt->lights[k].surf == LR__LT_GHOST)
                sum->ghost_paths += lt->lights[k].paths;
        sum->light_lights = (uint64_t)lt->n - sum->ghost_lights;
        sum->light_paths = lt->paths - sum->ghost_paths;
        /* A ghost mesh's rays through the lens count as its paths. */
        sum->ghost_paths += j->light.ghost_traced;
        sum->ghost_flux = lr__gt_flux(lt, &j->light);
        nomem = j->light.nomem;
        if (!atomic_load(&j->cancelled))
            lr__lt_film_resolve(&j->light, img->rgb);
        lr__lt_film_free(&j->light);
    }
    return nomem;
}

static lr_status render_in_mode(const lr_scene *scene, const lr_camera *cam,
                                const lr_render_settings *set, lr_image **out,
                                lr_render_stats *stats, lr_error *err);

lr_status lr_render(const lr_scene *scene, const lr_camera *cam,
                    const lr_render_settings *set, lr_image **out,
                    lr_render_stats *stats, lr_error *err)
{
    /* The same bits whatever the caller's floating-point mode
     * (fp_mode.h). */
    unsigned fp = lr__fp_enter();
    lr_status st = render_in_mode(scene, cam, set, out, stats, err);
    lr__fp_leave(fp);
    return st;
}

static lr_status render_in_mode(const lr_scene *scene, const lr_camera *cam,
                                const lr_render_settings *set, lr_image **out,
                                lr_render_stats *stats, lr_error *err)
{
    if (scene == NULL || out == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_render: NULL scene or output");
    *out = NULL;
    if (stats != NULL) /* (zero if it ends before the workers start) */
        memset(stats, 0, sizeof *stats);
    lr_status st = lr_camera_validate(cam, err);
    if (st != LR_OK)
        return st;
    st = lr_render_settings_validate(set, err);
    if (st != LR_OK)
        return st;

    lr_camera cam_used = *cam;
    st = lr__autofocus(scene, &cam_used, set->width, set->height, err);
    if (st != LR_OK)
        return st;

    render j;
    memset(&j, 0, sizeof j);
    j.x0 = 0, j.y0 = 0, j.x1 = set->width, j.y1 = set->height;
    if ((set->region[0] | set->region[1] | set->region[2] | set->region[3]))
        j.x0 = set->region[0], j.y0 = set->region[1], j.x1 = set->region[2],
        j.y1 = set->region[3];

    double t0 = now_seconds(), cpu0 = thread_cpu_seconds();
    lr_image *img = NULL;
    st = lr_image_create(j.x1 - j.x0, j.y1 - j.y0, set->want_depth, &img, err);
    if (st != LR_OK)
        return st;

    /* A crop carries its place and its making into its file's header. */
    if (j.x0 != 0 || j.y0 != 0 || j.x1 != set->width || j.y1 != set->height) {
        st = lr_image_set_frame(img, set->width, set->height, j.x0, j.y0, cam,
                                set, err);
        if (st != LR_OK) {
            lr_image_free(img);
            return st;
        }
    }
    j.set = set;
    j.img = img;
    lr__cam_init(&j.cam, &cam_used, set->width, set->height);
    st = lr__plan_build(&j.plan, scene, &j.cam, set, j.x0, j.y0, j.x1, j.y1,
                        err);
    if (st != LR_OK) {
        lr_image_free(img);
        return st;
    }
    if (j.plan.lt != NULL) {
        st = lr__lt_film_init(&j.light, j.plan.lt, j.x0, j.y0, j.x1, j.y1, err);
        if (st != LR_OK) {
            lr__plan_free(&j.plan);
            lr_image_free(img);
            return st;
        }
    }
    atomic_init(&j.next_light, 0);
    j.n_light = j.plan.lt != NULL ? lr__lt_units(j.plan.lt) : 0;
    j.light_share = progress_share(&j);
    lr__sampler_init(&j.sampler, set->sampler, set->seed, set->spp);
    j.shot = (lr__shot){.scene = scene,
                        .cam = &j.cam,
                        .sampler = &j.sampler,
                        .integrator = lr__integrator_for(set->integrator),
                        .width = set->width,
                        .max_depth = set->max_depth,
                        .no_squares = !set->adaptive,
                        .lt = j.plan.lt != NULL ? &j.plan.lt->view : NULL};
    lr__shot_init(&j.shot);
    j.tiles_x = (j.x1 - j.x0 + set->tile_size - 1) / set->tile_size;
    j.tiles_y = (j.y1 - j.y0 + set->tile_size - 1) / set->tile_size;
    atomic_init(&j.next_tile, 0);
    atomic_init(&j.cancelled, 0);
    pthread_mutex_init(&j.progress_lock, NULL);

    int n = set->threads;
    if (n == 0) {
        long cores = sysconf(_SC_NPROCESSORS_ONLN);
        n = cores > 0 ? (int)cores : 1;
    }
    /* No more threads than tiles and light units: a light-integrator
     * render of one tile ran its light paths on one thread. */
    if ((uint64_t)n > (uint64_t)j.tiles_x * (uint64_t)j.tiles_y + j.n_light &&
        !j.plan.splat)
        n = j.tiles_x * j.tiles_y + (int)j.n_light;
    st = LR_OK;
    if (j.plan.splat) {
        st = lr__splat_new(&j.shot, set->spp, j.x0, j.y0, j.x1, j.y1, n, img,
                           &j.splat, err);
        if (st == LR_OK && n > lr__splat_units(j.splat))
            n = lr__splat_units(j.splat);
    }
    /* Each worker's block scratch (0.8 MB) needs no zeroing
     * (lr__adaptive_block sets what it reads): zeroing it was a tenth of
     * a farm part's fixed cost (perf, one-row parts). */
    if (st == LR_OK && !j.plan.splat &&
        !lr__pilots_init(&j.pilots, set, &j.plan, j.x0, j.y0, j.x1, j.y1,
                         set->tile_size))
        st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    worker *ws = st == LR_OK ? malloc((size_t)n * sizeof *ws) : NULL;
    pthread_t *tids = st == LR_OK ? calloc((size_t)n, sizeof *tids) : NULL;
    if (ws == NULL || tids == NULL) {
        free(ws);
        free(tids);
        lr__pilots_free(&j.pilots);
        lr__splat_free(j.splat);
        lr_image_free(img);
        lr__lt_film_free(&j.light);
        lr__plan_free(&j.plan);
        pthread_mutex_destroy(&j.progress_lock);
        return st != LR_OK ? st
                           : lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    int started = run_workers(&j, ws, tids, n);
    /* The calling thread's share: the plan and the set-up as well as its
     * tiles (the other workers' time is all tiles). */
    ws[0].cpu = thread_cpu_seconds() - cpu0;
    pthread_mutex_destroy(&j.progress_lock);
    lr__pilots_free(&j.pilots);

    lr_render_stats sum;
    sum_workers(ws, started, &sum);
    free(ws);
    free(tids);
    sum.threads = started;
    int nomem = finish_sides(&j, img, &sum);
    lr__plan_free(&j.plan);
    sum.seconds = now_seconds() - t0;
    /* The statistics say what was done even when the render was
     * cancelled, so that callers can account for the rays traced. */
    if (stats != NULL)
        *stats = sum;
    if (atomic_load(&j.cancelled)) {
        lr_image_free(img);
        return lr__fail(err, LR_ERR_CANCELLED, NULL, "render cancelled");
    }
    if (nomem) {
        lr_image_free(img);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    *out = img;
    return LR_OK;
}
