/*
 * render.c: the render loop: tiles handed out to a pool of threads, the
 * pixel samples of each pixel accumulated in order by one thread (so the
 * result does not depend on the thread count or tile size), progress and
 * cancellation between tiles.
 */
#include "camera.h"
#include "film.h"
#include "sampler.h"
#include "shade.h"
#include "plan.h"
#include "spectrum.h"
#include "trace16.h"

#include <math.h>
#include <pmmintrin.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <xmmintrin.h>


void lr_render_settings_default(lr_render_settings *s)
{
    memset(s, 0, sizeof *s);
    s->width = 640;
    s->height = 480;
    s->spp = 16;
    s->sampler = LR_SAMPLER_SOBOL;
    s->seed = 0;
    s->max_depth = 8;
    s->threads = 0;
    s->tile_size = 32;
    s->want_depth = 0;
    s->plan = 1;
    s->adaptive = 1;
    s->adaptive_threshold = 0.01;
    s->adaptive_min_spp = 4;
}

lr_status lr_render_settings_validate(const lr_render_settings *s,
                                      lr_error *err)
{
    if (s == NULL)
        return lr__fail(err, LR_ERR_INVALID, "render", "settings are NULL");
    if (s->width < 1 || s->width > LR__MAX_DIM)
        return lr__fail(err, LR_ERR_INVALID, "render.width",
                        "render.width must be between 1 and %d, got %d",
                        LR__MAX_DIM, s->width);
    if (s->height < 1 || s->height > LR__MAX_DIM)
        return lr__fail(err, LR_ERR_INVALID, "render.height",
                        "render.height must be between 1 and %d, got %d",
                        LR__MAX_DIM, s->height);
    if ((uint64_t)s->width * (uint64_t)s->height > LR__MAX_PIXELS)
        return lr__fail(err, LR_ERR_INVALID, "render.width",
                        "render.width x render.height is %llu pixels, more "
                        "than the limit of %llu",
                        (unsigned long long)s->width * (unsigned)s->height,
                        (unsigned long long)LR__MAX_PIXELS);
    if (s->spp < 1 || s->spp > LR__MAX_SPP)
        return lr__fail(err, LR_ERR_INVALID, "render.spp",
                        "render.spp must be between 1 and %d, got %d",
                        LR__MAX_SPP, s->spp);
    if ((int)s->sampler < 0 || s->sampler > LR_SAMPLER_SOBOL)
        return lr__fail(err, LR_ERR_INVALID, "render.sampler",
                        "render.sampler is not a known sampler (%d)",
                        (int)s->sampler);
    if (s->max_depth < 0 || s->max_depth > LR__MAX_DEPTH)
        return lr__fail(err, LR_ERR_INVALID, "render.max_depth",
                        "render.max_depth must be between 0 and %d, got %d",
                        LR__MAX_DEPTH, s->max_depth);
    if (s->threads < 0 || s->threads > LR__MAX_THREADS)
        return lr__fail(err, LR_ERR_INVALID, "render.threads",
                        "render.threads must be between 0 (all cores) and "
                        "%d, got %d",
                        LR__MAX_THREADS, s->threads);
    if (!(s->adaptive_threshold > 0.0 && s->adaptive_threshold <= 1.0))
        return lr__fail(err, LR_ERR_INVALID, "render.adaptive.threshold",
                        "render.adaptive.threshold must be in (0, 1], got %g",
                        s->adaptive_threshold);
    if (s->adaptive_min_spp < 1 || s->adaptive_min_spp > LR__MAX_SPP)
        return lr__fail(err, LR_ERR_INVALID, "render.adaptive.min_spp",
                        "render.adaptive.min_spp must be between 1 and %d, "
                        "got %d",
                        LR__MAX_SPP, s->adaptive_min_spp);
    const int *r = s->region;
    if ((r[0] | r[1] | r[2] | r[3]) != 0 &&
        !(r[0] >= 0 && r[1] >= 0 && r[2] > r[0] && r[3] > r[1] &&
          r[2] <= s->width && r[3] <= s->height))
        return lr__fail(err, LR_ERR_INVALID, "render.region",
                        "render.region [%d, %d, %d, %d] must satisfy 0 <= x0 "
                        "< x1 <= width (%d) and 0 <= y0 < y1 <= height (%d)",
                        r[0], r[1], r[2], r[3], s->width, s->height);
    if (s->tile_size < 1 || s->tile_size > LR__MAX_TILE)
        return lr__fail(err, LR_ERR_INVALID, "render.tile_size",
                        "render.tile_size must be between 1 and %d, got %d",
                        LR__MAX_TILE, s->tile_size);
    return LR_OK;
}

/* State shared by the render threads. */
typedef struct job {
    const lr_scene *scene;
    const lr_render_settings *set;
    lr__cam cam;
    lr__sampler sampler;
    lr_image *img;
    lr__v3 mean_cmf;    /* mean of the sRGB matching functions, 380-780 nm */
    lr__plan plan;
    int x0, y0, x1, y1; /* the region rendered, in frame pixels */
    int tiles_x, tiles_y;
    atomic_int next_tile;
    atomic_int cancelled;
    pthread_mutex_t progress_lock;
    uint64_t pixels_done;
} job;

/* Tiles are worked in sub-blocks of at most SUB x SUB pixels, plus a
 * one-pixel apron for adaptive sampling's neighbourhoods. */
#define SUB 64
#define SUBA (SUB + 2)

typedef struct worker {
    job *job;
    double cpu; /* CPU seconds of this thread in worker_main */
    uint64_t rays, samples, dropped;
    uint64_t camera_rays, lens_pixels, chroma_pixels;
    lr__pixel acc[SUBA * SUBA];
    int need[SUBA * SUBA];
} worker;

/* One camera sample: radiance through film point (fx, fy) and lens
 * sample u, with whatever chromatic treatment the camera asks for. */
static void camera_sample(worker *w, uint64_t pixel, uint32_t s, double fx,
                          double fy, const double u[2], lr__pixel *acc)
{
    job *j = w->job;
    const lr__cam *c = &j->cam;
    int depth = j->set->max_depth;
    lr__v3 org, dir;
    if (c->chroma.mode == LR_CHROMATIC_RGB) {
        w->camera_rays += 3;
        /* The paper: each channel traced with its own focus, through the
         * same film point and lens point. */
        double L[3];
        for (int ch = 0; ch < 3; ch++) {
            lr__cam_lens_ray(c, fx, fy, u, c->w_rgb[ch], &org, &dir);
            lr__v3 Li = lr__radiance(j->scene, org, dir, 0, depth, &w->rays);
            L[ch] = ch == 0 ? Li.x : ch == 1 ? Li.y : Li.z;
        }
        lr__pixel_add(acc, v3(L[0], L[1], L[2]));
        return;
    }
    /* Spectral: N wavelengths stratified over the visible range with one
     * random offset per sample, each weighted by the linear-sRGB
     * colour-matching functions W(lambda).  With five or more the weights
     * are normalised by their own sum in this sample (W's sums then stay
     * within a factor of 2 of each other for any offset): a uniform white
     * scene stays exactly white and each wavelength's light is conserved.
     * With fewer, the sum could approach zero, so the exact mean of W over
     * the range normalises instead (unbiased, white only on average). */
    int n = c->chroma.wavelengths;
    w->camera_rays += (uint64_t)n;
    double off = lr__sample_1d(&j->sampler, pixel, s, LR__DIM_WAVELENGTH);
    lr__v3 num = v3(0, 0, 0), den = v3(0, 0, 0);
    for (int k = 0; k < n; k++) {
        double nm = LR__LAMBDA_MIN +
                    (LR__LAMBDA_MAX - LR__LAMBDA_MIN) * (k + off) / n;
        double W[3];
        lr__srgb_cmf(nm, W);
        lr__cam_lens_ray(c, fx, fy, u, lr__cam_power_at(c, nm), &org, &dir);
        lr__v3 Li = lr__radiance(j->scene, org, dir, 0, depth, &w->rays);
        num = v3_add(num, v3(W[0] * Li.x, W[1] * Li.y, W[2] * Li.z));
        den = v3_add(den, v3(W[0], W[1], W[2]));
    }
    if (n < 5)
        den = v3_scale(j->mean_cmf, n);
    lr__pixel_add(acc, v3(num.x / den.x, num.y / den.y, num.z / den.z));
}

/* Writes a finished pixel (and its Z) into the image. */
static void store_pixel(worker *w, int x, int y, const lr__pixel *acc)
{
    job *j = w->job;
    w->samples += acc->n;
    w->dropped += acc->dropped;
    size_t out = (size_t)(y - j->y0) * (size_t)j->img->width +
                 (size_t)(x - j->x0);
    lr__pixel_resolve(acc, &j->img->rgb[3 * out]);

    if (j->img->depth != NULL) {
        /* Z: distance along the view axis of the first hit of the ray
         * through the pixel centre. */
        lr__v3 org, dir;
        lr__hit h;
        lr__cam_ray(&j->cam, x + 0.5, y + 0.5, &org, &dir);
        w->rays++;
        float z = LR_DEPTH_NONE;
        if (lr__trace(j->scene, org, dir, INFINITY, &h)) {
            double d = h.t * v3_dot(dir, j->cam.forward);
            if (d < LR_DEPTH_NONE)
                z = (float)d;
        }
        j->img->depth[out] = z;
    }
}

/* Samples first .. last-1 of pixel (x, y) into *acc, simulating what the
 * plan says: through the lens or not, one ray or one per colour. */
static void sample_pixel(worker *w, int x, int y, int first, int last,
                         lr__pixel *acc)
{
    job *j = w->job;
    const lr__block_plan *bp = lr__plan_at(&j->plan, x, y);
    int use_lens = j->cam.has_lens && bp->lens;
    if (j->cam.chroma_active && use_lens && bp->chroma) {
        /* The scalar path: several rays per sample, one per focus. */
        uint64_t pixel = (uint64_t)y * (uint64_t)j->set->width + (uint64_t)x;
        lr__pixel_sampler ps;
        lr__pixel_sampler_init(&ps, &j->sampler, pixel);
        for (int s = first; s < last; s++) {
            double u[4];
            lr__pixel_sampler_get(&ps, (uint32_t)s, u);
            camera_sample(w, pixel, (uint32_t)s, x + u[0], y + u[1], u + 2,
                          acc);
        }
        return;
    }
    lr__trace16 t = {j->scene, &j->cam, &j->sampler, j->set->width,
                     j->set->spp, j->set->max_depth};
    lr__trace16_pixel(&t, x, y, first, last, use_lens, acc, &w->rays,
                      &w->camera_rays);
}

/* Plan statistics for a finished pixel. */
static void count_plan(worker *w, int x, int y)
{
    job *j = w->job;
    const lr__block_plan *bp = lr__plan_at(&j->plan, x, y);
    if (j->cam.has_lens && bp->lens) {
        w->lens_pixels++;
        if (j->cam.chroma_active && bp->chroma)
            w->chroma_pixels++;
    }
}

/* Adaptive sampling's pilot at pixel (x, y): min_spp samples, or, where
 * the plan samples the lens, at least a packet's worth (16, the width of
 * lr__trace16_pixel's packets).  Where the lens blurs, almost every pixel
 * goes on (lens noise is everywhere), and a pixel that goes on after its
 * pilot traces another, partly filled packet, which costs about as much
 * as three or four samples more; a few samples of a blurred (or, with
 * chromatic aberration, spectral) integrand also judge its spread
 * poorly.  Where nothing is blurred only edges go on.  The plan is
 * aligned to the frame, so this too is the same for any tile or region. */
#define PACKET_PILOT 16
static int pilot_spp(const job *j, int x, int y)
{
    int lo = j->set->adaptive_min_spp, spp = j->set->spp;
    const lr__block_plan *bp = lr__plan_at(&j->plan, x, y);
    if (j->cam.has_lens && bp->lens && lo < PACKET_PILOT)
        lo = PACKET_PILOT;
    return lo < spp ? lo : spp;
}

/* Does apron pixel (x, y) matter to the block [x0, x1) x [y0, y1): has it
 * a neighbour in the block whose pilot leaves it samples to decide on? */
static int apron_needed(const job *j, int x, int y, int x0, int y0, int x1,
                        int y1)
{
    for (int ny = y - 1; ny <= y + 1; ny++)
        for (int nx = x - 1; nx <= x + 1; nx++)
            if (nx >= x0 && nx < x1 && ny >= y0 && ny < y1 &&
                pilot_spp(j, nx, ny) < j->set->spp)
                return 1;
    return 0;
}

/* One sub-block [x0, x1) x [y0, y1) of a tile. */
static void render_block(worker *w, int x0, int y0, int x1, int y1)
{
    job *j = w->job;
    const lr_render_settings *set = j->set;
    int spp = set->spp, lo = set->adaptive_min_spp;
    double thr = set->adaptive_threshold;
    if (!set->adaptive || lo >= spp) {
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                lr__pixel *a = &w->acc[0];
                lr__pixel_reset(a);
                sample_pixel(w, x, y, 0, spp, a);
                store_pixel(w, x, y, a);
                count_plan(w, x, y);
            }
        return;
    }
    /* Adaptive.  A pilot (pilot_spp) in the block and a one-pixel apron
     * around it (inside the frame, whatever the region) gives each pixel
     * a need; a pixel goes on to at least the largest need in its 3 x 3
     * neighbourhood (neighbours of unconverged pixels keep going), then
     * in rounds that at least double its count, judging its own need
     * again from all its samples after each, until that need is met or
     * it has spp.  A count depends only on the neighbourhood's pilots and
     * the pixel's own samples, all computed here, so tiles and regions
     * agree; and a pixel's first n samples are the full render's first
     * n, so it is the full render stopped at n. */
    int ax0 = x0 > 0 ? x0 - 1 : 0, ay0 = y0 > 0 ? y0 - 1 : 0;
    int ax1 = x1 < set->width ? x1 + 1 : x1;
    int ay1 = y1 < set->height ? y1 + 1 : y1;
    int aw = ax1 - ax0;
    for (int y = ay0; y < ay1; y++)
        for (int x = ax0; x < ax1; x++) {
            int i = (y - ay0) * aw + (x - ax0);
            int p = pilot_spp(j, x, y);
            int inside = x >= x0 && x < x1 && y >= y0 && y < y1;
            w->need[i] = 0;
            if (!inside && !apron_needed(j, x, y, x0, y0, x1, y1))
                continue;
            lr__pixel_reset(&w->acc[i]);
            sample_pixel(w, x, y, 0, p, &w->acc[i]);
            w->need[i] = lr__pixel_samples_needed(&w->acc[i], thr, p, spp);
        }
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            lr__pixel *a = &w->acc[(y - ay0) * aw + (x - ax0)];
            int have = pilot_spp(j, x, y);
            if (have >= spp) {
                /* The pilot was all of it (a blurred pixel at low spp). */
                store_pixel(w, x, y, a);
                count_plan(w, x, y);
                continue;
            }
            int want = lr__pixel_samples_needed(a, thr, have, spp);
            for (int ny = y - 1; ny <= y + 1; ny++)
                for (int nx = x - 1; nx <= x + 1; nx++) {
                    if (nx < ax0 || nx >= ax1 || ny < ay0 || ny >= ay1)
                        continue;
                    int k = (ny - ay0) * aw + (nx - ax0);
                    if (w->need[k] > want)
                        want = w->need[k];
                    /* An edge along the pixel grid can slip between a
                     * few samples: a pixel whose pilot differs from a
                     * neighbour's by more than 10 x the threshold takes
                     * another round and judges again. */
                    if (w->need[k] > 0 && want <= have &&
                        lr__pixel_contrast(a, &w->acc[k]) > 10.0 * thr)
                        want = have + 1;
                }
            while (want > have) {
                int next = lr__adaptive_next(have, want, spp);
                sample_pixel(w, x, y, have, next, a);
                have = next;
                want = lr__pixel_samples_needed(a, thr, have, spp);
            }
            store_pixel(w, x, y, a);
            count_plan(w, x, y);
        }
}

static void render_tile(worker *w, int x0, int y0, int x1, int y1)
{
    for (int y = y0; y < y1; y += SUB)
        for (int x = x0; x < x1; x += SUB)
            render_block(w, x, y, x + SUB < x1 ? x + SUB : x1,
                         y + SUB < y1 ? y + SUB : y1);
}

/* CPU time of the calling thread. */
static double thread_cpu_seconds(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0)
        return 0.0;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void *worker_main(void *arg)
{
    worker *w = arg;
    job *j = w->job;
    const lr_render_settings *set = j->set;
    /* Denormals only slow traversal down; Embree recommends FTZ/DAZ. */
    double cpu0 = thread_cpu_seconds();
    unsigned csr = _mm_getcsr();
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    int n_tiles = j->tiles_x * j->tiles_y;
    for (;;) {
        /* An atomic read, so that a flag set by another thread (with
         * __atomic_store_n, or a plain store from a signal handler) is
         * a race-free handshake. */
        if (set->cancel != NULL &&
            __atomic_load_n(set->cancel, __ATOMIC_RELAXED)) {
            atomic_store(&j->cancelled, 1);
            break;
        }
        if (atomic_load(&j->cancelled))
            break;
        int t = atomic_fetch_add(&j->next_tile, 1);
        if (t >= n_tiles)
            break;
        int ts = set->tile_size;
        int x0 = j->x0 + (t % j->tiles_x) * ts;
        int y0 = j->y0 + (t / j->tiles_x) * ts;
        int x1 = x0 + ts < j->x1 ? x0 + ts : j->x1;
        int y1 = y0 + ts < j->y1 ? y0 + ts : j->y1;
        render_tile(w, x0, y0, x1, y1);
        pthread_mutex_lock(&j->progress_lock);
        j->pixels_done += (uint64_t)(x1 - x0) * (uint64_t)(y1 - y0);
        if (set->progress != NULL)
            set->progress(set->progress_user, j->pixels_done,
                          (uint64_t)(j->x1 - j->x0) *
                              (uint64_t)(j->y1 - j->y0));
        pthread_mutex_unlock(&j->progress_lock);
    }
    _mm_setcsr(csr);
    w->cpu = thread_cpu_seconds() - cpu0;
    return NULL;
}

/* The mean of the linear-sRGB matching functions over the sampled range,
 * by the midpoint rule at 0.25 nm (far finer than the functions vary). */
static lr__v3 mean_cmf(void)
{
    double sum[3] = {0, 0, 0};
    int n = (int)((LR__LAMBDA_MAX - LR__LAMBDA_MIN) * 4);
    for (int i = 0; i < n; i++) {
        double W[3];
        lr__srgb_cmf(LR__LAMBDA_MIN + (i + 0.5) * 0.25, W);
        for (int c = 0; c < 3; c++)
            sum[c] += W[c];
    }
    return v3(sum[0] / n, sum[1] / n, sum[2] / n);
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

lr_status lr_render(const lr_scene *scene, const lr_camera *cam,
                    const lr_render_settings *set, lr_image **out,
                    lr_render_stats *stats, lr_error *err)
{
    if (scene == NULL || out == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_render: NULL scene or output");
    *out = NULL;
    lr_status st = lr_camera_validate(cam, err);
    if (st != LR_OK)
        return st;
    st = lr_render_settings_validate(set, err);
    if (st != LR_OK)
        return st;

    lr_camera cam_used = *cam;
    st = lr__cam_autofocus(scene, &cam_used, set->width, set->height, err);
    if (st != LR_OK)
        return st;

    job j;
    memset(&j, 0, sizeof j);
    j.x0 = 0, j.y0 = 0, j.x1 = set->width, j.y1 = set->height;
    if ((set->region[0] | set->region[1] | set->region[2] | set->region[3]))
        j.x0 = set->region[0], j.y0 = set->region[1],
        j.x1 = set->region[2], j.y1 = set->region[3];

    double t0 = now_seconds(), cpu0 = thread_cpu_seconds();
    lr_image *img = NULL;
    st = lr_image_create(j.x1 - j.x0, j.y1 - j.y0, set->want_depth, &img,
                         err);
    if (st != LR_OK)
        return st;

    j.scene = scene;
    j.set = set;
    j.img = img;
    lr__cam_init(&j.cam, &cam_used, set->width, set->height);
    j.mean_cmf = mean_cmf();
    st = lr__plan_build(&j.plan, scene, &j.cam, j.x0, j.y0, j.x1, j.y1,
                        set->plan, err);
    if (st != LR_OK) {
        lr_image_free(img);
        return st;
    }
    lr__sampler_init(&j.sampler, set->sampler, set->seed, set->spp);
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
    if (n > j.tiles_x * j.tiles_y)
        n = j.tiles_x * j.tiles_y;
    worker *ws = calloc((size_t)n, sizeof *ws);
    pthread_t *tids = calloc((size_t)n, sizeof *tids);
    if (ws == NULL || tids == NULL) {
        free(ws);
        free(tids);
        lr_image_free(img);
        lr__plan_free(&j.plan);
        pthread_mutex_destroy(&j.progress_lock);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    /* The calling thread is worker 0; if a thread cannot be started the
     * others simply take more tiles. */
    int started = 1;
    for (int i = 0; i < n; i++)
        ws[i].job = &j;
    for (int i = 1; i < n; i++) {
        if (pthread_create(&tids[i], NULL, worker_main, &ws[i]) != 0)
            break;
        started++;
    }
    worker_main(&ws[0]);
    for (int i = 1; i < started; i++)
        pthread_join(tids[i], NULL);
    /* The calling thread's share: the plan and the set-up as well as its
     * tiles (the other workers' time is all tiles). */
    ws[0].cpu = thread_cpu_seconds() - cpu0;
    pthread_mutex_destroy(&j.progress_lock);

    lr_render_stats sum;
    memset(&sum, 0, sizeof sum);
    for (int i = 0; i < started; i++) {
        sum.rays += ws[i].rays;
        sum.camera_rays += ws[i].camera_rays;
        sum.lens_pixels += ws[i].lens_pixels;
        sum.chroma_pixels += ws[i].chroma_pixels;
        sum.samples += ws[i].samples;
        sum.cpu_seconds += ws[i].cpu;
        sum.nan_samples += ws[i].dropped;
    }
    free(ws);
    free(tids);
    sum.threads = started;
    sum.pixels = (uint64_t)(j.x1 - j.x0) * (uint64_t)(j.y1 - j.y0);
    sum.full_samples = sum.pixels * (uint64_t)set->spp;
    uint64_t per_sample = 1;
    if (j.cam.chroma_active)
        per_sample = j.cam.chroma.mode == LR_CHROMATIC_RGB
                         ? 3
                         : (uint64_t)j.cam.chroma.wavelengths;
    sum.full_camera_rays = sum.full_samples * per_sample;
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
    *out = img;
    return LR_OK;
}
