/*
 * plan.c: where the lens and the colours need simulating (see plan.h).
 *
 * Camera space: z along the view axis, u = x / z and v = y / z on the
 * image plane at distance 1 (pixel (px, py) is at u = (2 px / W - 1)
 * half_w, v = (1 - 2 py / H) half_h).  Every lens model here is a lens of
 * radius R at the eye focused at 1/w (the bracket is one: its rays all
 * pass through e + off (1 + di / f), a square lens focused at di + f).
 * A point at depth Z seen through the lens lands within R |1/Z - w| (in
 * u, v units) of where the pinhole sees it, and blurs over a circle of
 * C(Z) = 2 R |1/Z - w| f_px pixels (f_px = H / (2 half_h)).
 *
 * So a block's lens rays can only reach geometry within its rectangle
 * grown by R |1/Z - w| at that geometry's depth (box_reached says it in
 * camera space, which also copes with geometry beside or behind the eye).  Geometry is bounded by boxes (spheres; triangles in chunks of
 * 64, and big triangles, like a ground quad's, cut into pieces until
 * each piece's depth extent is small against its distance, so that a
 * ground plane does not make every block "near"); infinite planes
 * exactly, since 1/Z is linear in (u, v) on a plane.
 * The block's blur is then at most C at the ends of its depth range.
 */
#include "render/plan.h"
#include "render/adaptive.h"
#include "scene/envmap.h"
#include "integrator/integrator.h"
#include "sampling/sampler.h"
#include "render/splat.h"
#include "scene/texture.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#define CHUNK LR__GEOM_CHUNK /* triangles per bounding box */
#define NEAR 1e-6            /* depths below this count as "at the eye" */

typedef struct box {
    double z0, z1;         /* depth range */
    double x0, x1, y0, y1; /* lateral range, camera space */
    size_t skip;           /* > 0: a cut triangle's whole box, followed by
                              the `skip` boxes of its pieces */
    size_t geom;           /* the geometry it bounds (scene->geoms) */
} box;

typedef struct lens {
    double R, w, fpx;
    lr__v3 e, fwd, right, up;
    /* The colours' focus powers: the reference and the extremes. */
    int n_w;
    double ws[3];
} lens;

static void to_cam(const lens *L, lr__v3 p, double *x, double *y, double *z)
{
    lr__v3 r = v3_sub(p, L->e);
    *x = v3_dot(r, L->right);
    *y = v3_dot(r, L->up);
    *z = v3_dot(r, L->fwd);
}

/* The world-space bounds of n points: lo[3], hi[3]. */

/* The camera-space box around the world box [lo, hi]. */
static void box_from_bounds(const lens *L, const double lo[3],
                            const double hi[3], box *b)
{
    /* The camera-space box around the eight corners of the world box. */
    b->z0 = b->x0 = b->y0 = DBL_MAX;
    b->z1 = b->x1 = b->y1 = -DBL_MAX;
    for (int k = 0; k < 8; k++) {
        lr__v3 p = v3(k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1],
                      k & 4 ? hi[2] : lo[2]);
        double x, y, z;
        to_cam(L, p, &x, &y, &z);
        b->x0 = fmin(b->x0, x);
        b->x1 = fmax(b->x1, x);
        b->y0 = fmin(b->y0, y);
        b->y1 = fmax(b->y1, y);
        b->z0 = fmin(b->z0, z);
        b->z1 = fmax(b->z1, z);
    }
}

static void box_from_points(const lens *L, const lr__v3 *pts, size_t n, box *b)
{
    double lo[3], hi[3];
    v3_bounds(pts, n, lo, hi);
    box_from_bounds(L, lo, hi, b);
}


/* Can a lens ray of the block [u0, u1] x [v0, v1] reach box b?  At depth
 * z the block's lens rays cover the lateral interval
 * [z u0 - R |1 - z w|, z u1 + R |1 - z w|] (and likewise in y): the
 * pinhole's footprint widened by where off-centre lens points look.  The
 * upper end is convex in z and the lower end concave, so over the box's
 * depths their extremes are at its ends. */
static int box_reached(const lens *L, const box *b, double u0, double u1,
                       double v0, double v1)
{
    double za = b->z0 > 0.0 ? b->z0 : 0.0, zb = b->z1;
    if (zb <= 0.0)
        return 0;
    /* Every colour's rays: each focuses at its own 1/w. */
    double ga = 0.0, gb = 0.0;
    for (int k = 0; k < L->n_w; k++) {
        ga = fmax(ga, L->R * fabs(1.0 - za * L->ws[k]));
        gb = fmax(gb, L->R * fabs(1.0 - zb * L->ws[k]));
    }
    double xr = fmax(za * u1 + ga, zb * u1 + gb);
    double xl = fmin(za * u0 - ga, zb * u0 - gb);
    double yr = fmax(za * v1 + ga, zb * v1 + gb);
    double yl = fmin(za * v0 - ga, zb * v0 - gb);
    return b->x0 <= xr && b->x1 >= xl && b->y0 <= yr && b->y1 >= yl;
}

/* Boxes for triangle (a, b, c), cut in four at its edge midpoints while a
 * piece reaches across more than a quarter of its distance in depth (at
 * most `depth` times).  Appends to *boxes, growing it as needed; returns
 * 0 on allocation failure. */
static int tri_boxes(const lens *L, lr__v3 a, lr__v3 b, lr__v3 c, int depth,
                     box **boxes, size_t *n, size_t *cap)
{
    lr__v3 pts[3] = {a, b, c};
    box bx;
    box_from_points(L, pts, 3, &bx);
    bx.skip = 0;
    double dist = fmax(fabs(bx.z0), fabs(bx.z1));
    int cut = depth > 0 && bx.z1 - bx.z0 > 0.25 * dist;
    if (*n == *cap) {
        size_t nc = *cap ? 2 * *cap : 256;
        box *g = realloc(*boxes, nc * sizeof *g);
        if (g == NULL)
            return 0;
        *boxes = g;
        *cap = nc;
    }
    size_t at = (*n)++;
    (*boxes)[at] = bx;
    if (cut) {
        /* The whole triangle's box stays in front of its pieces' (each
         * inside it), so that a block that cannot reach it, or whose
         * depths it cannot widen, skips them all. */
        lr__v3 ab = v3_scale(v3_add(a, b), 0.5);
        lr__v3 bc = v3_scale(v3_add(b, c), 0.5);
        lr__v3 ca = v3_scale(v3_add(c, a), 0.5);
        if (!(tri_boxes(L, a, ab, ca, depth - 1, boxes, n, cap) &&
              tri_boxes(L, ab, b, bc, depth - 1, boxes, n, cap) &&
              tri_boxes(L, ca, bc, c, depth - 1, boxes, n, cap) &&
              tri_boxes(L, ab, bc, ca, depth - 1, boxes, n, cap)))
            return 0;
        (*boxes)[at].skip = *n - at - 1;
    }
    return 1;
}

/* How far (in u, v) lens rays of any colour stray from the pinhole at
 * depths in [z0, z1]: R |1/Z - w| is largest at an end. */
static double spread(const lens *L, double z0, double z1)
{
    double worst = 0.0;
    for (int k = 0; k < L->n_w; k++) {
        double a = fabs(1.0 / z0 - L->ws[k]);
        double b = isfinite(z1) ? fabs(1.0 / z1 - L->ws[k]) : fabs(L->ws[k]);
        worst = fmax(worst, fmax(a, b));
    }
    return L->R * worst;
}

/* The depth range of an infinite plane over the rectangle
 * [u0, u1] x [v0, v1]: 1/Z is linear there, so its extremes are at the
 * corners.  Returns 0 if the plane is not seen. */
static int plane_range(const lens *L, const lr__geom *pl, double u0, double u1,
                       double v0, double v1, double *z0, double *z1)
{
    double k = v3_dot(pl->normal, v3_sub(pl->center, L->e));
    double a = v3_dot(pl->normal, L->fwd), b = v3_dot(pl->normal, L->right),
           c = v3_dot(pl->normal, L->up);
    if (fabs(k) < 1e-12) {
        /* The eye is on the plane: it can be anywhere in depth. */
        *z0 = NEAR;
        *z1 = INFINITY;
        return 1;
    }
    double lo = DBL_MAX, hi = -DBL_MAX;
    for (int i = 0; i < 4; i++) {
        double u = i & 1 ? u1 : u0, v = i & 2 ? v1 : v0;
        double inv = (a + b * u + c * v) / k; /* 1/Z along that ray */
        if (inv < lo)
            lo = inv;
        if (inv > hi)
            hi = inv;
    }
    if (hi <= 0.0)
        return 0;
    *z0 = 1.0 / hi;
    *z1 = lo > 0.0 ? 1.0 / lo : INFINITY;
    return 1;
}

/* The most that the colours' blur diameters differ, in pixels, over
 * 1/Z in [x0, x1]: |C_c - C_ref| is piecewise linear in 1/Z with kinks
 * at the foci, so check the ends and the kinks. */
static double chroma_spread(const lens *L, double x0, double x1)
{
    double pts[5] = {x0, x1, L->ws[0], L->ws[1], L->ws[2]};
    double worst = 0.0;
    for (int k = 0; k < 2 + L->n_w; k++) {
        double x = pts[k];
        if (x < x0 || x > x1)
            continue;
        for (int c = 1; c < L->n_w; c++) {
            double d = fabs(fabs(x - L->ws[c]) - fabs(x - L->ws[0]));
            if (d > worst)
                worst = d;
        }
    }
    return 2.0 * L->R * L->fpx * worst;
}

/* From what the blur bounds allow to what each block does. */
static void finish(lr__plan *p, const lr__cam *c, const lr_render_settings *set)
{
    for (int i = 0; i < p->bw * p->bh; i++) {
        lr__block_plan *bp = &p->blocks[i];
        bp->lens = c->has_lens && bp->lens && !bp->dark;
        bp->chroma = c->chroma_active && bp->lens && bp->chroma;
        bp->path = bp->chroma ? LR__PATH_COLOURS : LR__PATH_PACKET;
        bp->pilot = bp->dark ? 1 : lr__adaptive_pilot(set, bp->lens);
    }
}

static lr_status plan_blur(lr__plan *p, const lr_scene *s, const lr__cam *c,
                           const lr__lens_blur *lb, int dither,
                           const unsigned char *dark, int x0, int y0, int x1,
                           int y1, lr_error *err);
static unsigned char *dark_geoms(const lr_scene *s, const lr__lt *lt, int *all);

/* The light side's copy of the dark blocks, which it needs when one of
 * its lights mixes with the camera (light_trace.h): in a dark block it
 * keeps all of that light.  0: out of memory. */
static int lt_dark(lr__plan *p)
{
    lr__lt *lt = p->lt;
    int mixes = 0, any_dark = 0, n = p->bw * p->bh;
    for (int k = 0; k < lt->n; k++)
        mixes |= lt->lights[k].mis > 0.0;
    for (int i = 0; i < n; i++)
        any_dark |= p->blocks[i].dark;
    if (!mixes || !any_dark)
        return 1;
    if ((lt->dark = malloc((size_t)n)) == NULL)
        return 0;
    for (int i = 0; i < n; i++)
        lt->dark[i] = p->blocks[i].dark;
    lt->dark_bw = p->bw;
    lt->dark_block = LR__PLAN_BLOCK;
    return 1;
}
static const lr__geom *geom_or_plane(const lr_scene *s, size_t g);
static int plane_reached(const lens *L, const lr__geom *pl, double u0,
                         double u1, double v0, double v1);
static lr_status lt_region(lr__lt *lt, const lr__cam *c, int x0, int y0, int x1,
                           int y1, lr_error *err);
static lr_status rare_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                            int x0, int y0, int x1, int y1, lr_error *err);

lr_status lr__plan_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                         const lr_render_settings *set, int x0, int y0, int x1,
                         int y1, lr_error *err)
{
    p->bw = ((int)c->width + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->bh = ((int)c->height + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->blocks = malloc((size_t)p->bw * (size_t)p->bh * sizeof *p->blocks);
    if (p->blocks == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < p->bw * p->bh; i++)
        p->blocks[i] = (lr__block_plan){1, 1, 0, 0, 0};
    p->rare = NULL;
    p->lt = NULL;
    /* Splatting traces one ray a pixel and sample for the whole
     * spectrum, where spectral.c's packets trace one a wavelength
     * (docs/spectral.md measures both). */
    const lr__integrator *in = lr__integrator_for(set->integrator);
    /* An integrator whose camera rays estimate nothing has every block
     * dark (below), which the splatting pass would not skip. */
    p->splat = lr__splat_applies(c) && !(in != NULL && in->camera_dark);
    /* The light side comes first: what it carries, the camera does not
     * see (dark blocks).  With spectral splatting too: a splatted camera
     * ray that meets a light side's light first adds none of its
     * emission at any wavelength, as every other camera ray. */
    {
        lr_status st = lr__lt_plan(s, c, set, &p->lt, err);
        if (st == LR_OK && p->lt != NULL)
            st = lt_region(p->lt, c, x0, y0, x1, y1, err);
        if (st != LR_OK) {
            lr__plan_free(p);
            return st;
        }
    }
    /* Per geometry then per plane: 1 where it gives camera paths no
     * light; NULL when nothing can be dark (a lit background, or no
     * plan). */
    unsigned char *dark = NULL;
    int all_dark = 0;
    if (set->plan && !p->splat && v3_maxc(s->background) <= 0.0 &&
        s->env == NULL) {
        dark = dark_geoms(s, p->lt, &all_dark);
        if (dark == NULL) {
            lr__plan_free(p);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
    }
    /* An integrator whose camera rays estimate nothing: all dark. */
    if (in != NULL && in->camera_dark) {
        for (int i = 0; i < p->bw * p->bh; i++)
            p->blocks[i].dark = 1;
    } else if (set->plan && !p->splat && c->has_lens &&
               (c->model->bound != NULL ||
                (c->model->blur != NULL && c->model->blur(c) != NULL))) {
        /* A model with no safe bound samples its lens everywhere; a real
         * lens's is its blur table (lens_blur.c). */
        const lr__lens_blur *lb = c->model->bound == NULL ? c->model->blur(c)
                                                          : NULL;
        /* Adaptive sampling reads the pilots of a one-pixel apron around
         * the region (adaptive.c), and a pilot follows its block's plan:
         * the apron's blocks are planned too, or a crop's edge pixels
         * would differ from the full render's. */
        int gx0 = x0 > 0 ? x0 - 1 : 0, gy0 = y0 > 0 ? y0 - 1 : 0;
        int gx1 = x1 < (int)c->width ? x1 + 1 : x1;
        int gy1 = y1 < (int)c->height ? y1 + 1 : y1;
        /* With the grid sampler every pixel samples the same film
         * positions, and its error is structure (aliased edges) that
         * only the lens's blur, however small, dithers from pixel to
         * pixel: skipping a lens that blurs less than LR__PLAN_BLUR_PX
         * raised the in-focus scene's error 1.6x to 2.8x over the full
         * simulation's at 16 to 1024 spp (docs/accuracy.md).  The
         * default (planning with adaptive sampling) promises at most
         * 1.2x, so with adaptive sampling on the grid keeps its lens
         * wherever there is something to blur; planning alone stays as
         * it was, the fastest choice at its own error. */
        int dither = set->adaptive && lr__sampler_fixed_positions(set->sampler);
        lr_status st = plan_blur(p, s, c, lb, dither, dark, gx0, gy0, gx1, gy1,
                                 err);
        if (st != LR_OK) {
            free(dark);
            lr__plan_free(p);
            return st;
        }
    } else if (all_dark) {
        /* Without a bound (or a lens) every geometry is in reach of every
         * block. */
        for (int i = 0; i < p->bw * p->bh; i++)
            p->blocks[i].dark = 1;
    }
    free(dark);
    finish(p, c, set);
    if (p->lt != NULL && !lt_dark(p)) {
        lr__plan_free(p);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    /* Rare light matters only to a pixel that may stop early. */
    if (set->adaptive && !p->splat && lr__adaptive_min(set) < set->spp) {
        lr_status st = rare_build(p, s, c, x0, y0, x1, y1, err);
        if (st != LR_OK) {
            lr__plan_free(p);
            return st;
        }
    }
    return LR_OK;
}

/* ---- the boxes, kept for the next plan with the same camera ------------- */

/* The camera-space boxes of a scene's geometry for one camera, shared by
 * the plans that use them (refs, under the cache's lock) and immutable. */
typedef struct boxset {
    int refs;
    lens key;
    size_t n;
    box *boxes;
} boxset;

/* The scene's cache (lr_scene.plan_cache), made by the first plan of
 * the scene and freed with it. */
typedef struct plan_cache {
    lr__scene_cache base; /* first: the scene frees it through base.free */
    pthread_mutex_t lock;
    boxset *last;
} plan_cache;

static void boxset_unref(boxset *b)
{
    if (b != NULL && --b->refs == 0) {
        free(b->boxes);
        free(b);
    }
}

static void cache_free(lr__scene_cache *base)
{
    plan_cache *c = (plan_cache *)base;
    boxset_unref(c->last);
    pthread_mutex_destroy(&c->lock);
    free(c);
}

/* Scene s's cache, made now if it has none; NULL when out of memory (a
 * plan then finds its boxes alone). */
static plan_cache *cache_of(const lr_scene *s)
{
    lr__scene_cache *have = __atomic_load_n(&s->plan_cache, __ATOMIC_ACQUIRE);
    if (have != NULL)
        return (plan_cache *)have;
    plan_cache *c = calloc(1, sizeof *c);
    if (c == NULL)
        return NULL;
    if (pthread_mutex_init(&c->lock, NULL) != 0) {
        free(c);
        return NULL;
    }
    c->base.free = cache_free;
    have = lr__scene_cache_set(&s->plan_cache, &c->base);
    if (have != &c->base)
        cache_free(&c->base);
    return (plan_cache *)have;
}

/* Whether two cameras give the same boxes: every input of tri_boxes and
 * box_from_bounds, compared exactly. */
static int same_lens(const lens *a, const lens *b)
{
    if (a->R != b->R || a->w != b->w || a->fpx != b->fpx || a->n_w != b->n_w)
        return 0;
    const lr__v3 *va[4] = {&a->e, &a->fwd, &a->right, &a->up};
    const lr__v3 *vb[4] = {&b->e, &b->fwd, &b->right, &b->up};
    for (int k = 0; k < 4; k++)
        if (va[k]->x != vb[k]->x || va[k]->y != vb[k]->y ||
            va[k]->z != vb[k]->z)
            return 0;
    for (int k = 0; k < a->n_w; k++)
        if (a->ws[k] != b->ws[k])
            return 0;
    return 1;
}

static int make_boxes(const lr_scene *s, const lens *L, box **out,
                      size_t *out_n);

/* The boxes for camera L: the cache's when it holds this camera's, else
 * made now and left in the cache for the next plan.  A reference the
 * caller drops with put_boxes; NULL when out of memory. */
static boxset *get_boxes(const lr_scene *s, const lens *L)
{
    plan_cache *c = cache_of(s);
    if (c != NULL) {
        pthread_mutex_lock(&c->lock);
        boxset *hit = c->last;
        if (hit != NULL && same_lens(&hit->key, L))
            hit->refs++;
        else
            hit = NULL;
        pthread_mutex_unlock(&c->lock);
        if (hit != NULL)
            return hit;
    }
    boxset *b = calloc(1, sizeof *b);
    if (b == NULL || !make_boxes(s, L, &b->boxes, &b->n)) {
        free(b);
        return NULL;
    }
    b->key = *L;
    b->refs = 1;
    if (c != NULL) {
        pthread_mutex_lock(&c->lock);
        boxset_unref(c->last);
        c->last = b;
        b->refs++;
        pthread_mutex_unlock(&c->lock);
    }
    return b;
}

static void put_boxes(const lr_scene *s, boxset *b)
{
    plan_cache *c = (plan_cache *)__atomic_load_n(&s->plan_cache,
                                                  __ATOMIC_ACQUIRE);
    if (c != NULL)
        pthread_mutex_lock(&c->lock);
    boxset_unref(b);
    if (c != NULL)
        pthread_mutex_unlock(&c->lock);
}

/* The planner's lens for camera c: its model's bound (lr__cam_bound), or
 * none (R = 0) for a camera without a lens or a real lens (plan_blur sets
 * its own). */
static void make_lens(const lr__cam *c, lens *L)
{
    lr__lens_bound lb = {0.0, 1, {0.0, 0.0, 0.0}};
    if (c->has_lens && c->model->bound != NULL)
        lr__cam_bound(c, &lb);
    L->R = lb.R;
    L->w = lb.ws[0];
    L->fpx = c->height / (2.0 * c->half_h);
    L->e = c->origin;
    L->fwd = c->forward;
    L->right = c->right;
    L->up = c->up;
    L->n_w = lb.n_w;
    for (int k = 0; k < lb.n_w; k++)
        L->ws[k] = lb.ws[k];
}

/* Whether geometry with material m, whose flags on the light side are
 * `lt` (light_trace.h), gives camera paths no light: no lobe to scatter
 * with, and no emission the camera counts (the light side carries what
 * it emits straight into the lens). */
static int gives_camera_nothing(const lr__material *m, unsigned char lt)
{
    if (m->pbr_split || v3_maxc(m->diffuse) > 0.0 ||
        v3_maxc(m->specular) > 0.0 || v3_maxc(m->reflect) > 0.0 ||
        v3_maxc(m->transmit) > 0.0)
        return 0;
    return (lt & LR__LT_DIRECT) ||
           (m->emission_tex == NULL && !(v3_maxc(m->emission) > 0.0));
}

/* Per geometry, then per infinite plane, of scene s: 1 where it gives
 * camera paths no light (with light side lt, or NULL); *all = 1 when
 * every one does.  NULL when out of memory. */
static unsigned char *dark_geoms(const lr_scene *s, const lr__lt *lt, int *all)
{
    size_t n = s->n_geoms + s->n_planes;
    unsigned char *d = malloc(n + 1);
    if (d == NULL)
        return NULL;
    *all = 1;
    for (size_t g = 0; g < n; g++) {
        const lr__geom *geo = geom_or_plane(s, g);
        unsigned char f = lt != NULL && g < s->n_geoms ? lt->direct[g]
                                                       : (unsigned char)0;
        d[g] = (unsigned char)gives_camera_nothing(&s->materials[geo->material],
                                                   f);
        *all &= d[g];
    }
    return d;
}

/* Where no colour's blur can reach a quarter pixel, the block needs no
 * lens (unless `dither`: wherever it reaches anything); where the
 * colours' blurs differ by less, one ray for all. */
static lr_status plan_blur(lr__plan *p, const lr_scene *s, const lr__cam *c,
                           const lr__lens_blur *lb, int dither,
                           const unsigned char *dark, int x0, int y0, int x1,
                           int y1, lr_error *err)
{
    lens L;
    make_lens(c, &L);
    if (lb != NULL) {
        /* A real lens: its rays from a block lie, at depth Z, within Z
         * times the slopes lr__lens_blur_reach gives, grown by R (the
         * form of a lens of radius R focused at infinity). */
        double uv[4];
        lr__lens_blur_reach(c, lb, 0.0, 0.0, c->width, c->height, uv, &L.R);
        L.w = L.ws[0] = 0.0;
        L.n_w = 1;
    }

    boxset *set = get_boxes(s, &L);
    if (set == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    const box *boxes = set->boxes;
    size_t n_boxes = set->n;

    int bx0 = x0 / LR__PLAN_BLOCK, by0 = y0 / LR__PLAN_BLOCK;
    int bx1 = (x1 - 1) / LR__PLAN_BLOCK, by1 = (y1 - 1) / LR__PLAN_BLOCK;
    double su = 2.0 * c->half_w / c->width, sv = 2.0 * c->half_h / c->height;
    for (int by = by0; by <= by1; by++)
        for (int bx = bx0; bx <= bx1; bx++) {
            int px0 = bx * LR__PLAN_BLOCK, py0 = by * LR__PLAN_BLOCK;
            int px1 = px0 + LR__PLAN_BLOCK, py1 = py0 + LR__PLAN_BLOCK;
            double u0 = px0 * su - c->half_w, u1 = px1 * su - c->half_w;
            double v0 = c->half_h - py1 * sv, v1 = c->half_h - py0 * sv;
            lr__block_plan *bp = &p->blocks[by * p->bw + bx];
            /* The block's film rectangle, in the frame. */
            double fx1 = fmin(px1, c->width), fy1 = fmin(py1, c->height);
            if (lb != NULL) {
                double uv[4], R;
                lr__lens_blur_reach(c, lb, px0, py0, fx1, fy1, uv, &R);
                if (!isfinite(uv[0] + uv[1] + uv[2] + uv[3])) {
                    /* No bound on where its rays go. */
                    *bp = (lr__block_plan){1, 1, 0, 0, 0};
                    continue;
                }
                u0 = uv[0], u1 = uv[1], v0 = uv[2], v1 = uv[3];
            }
            double zmin = INFINITY, zmax = 0.0;
            /* Whether anything in reach gives camera paths light (with
             * no `dark`, anything counts). */
            int lit = dark == NULL;
            for (size_t i = 0; i < n_boxes; i++) {
                const box *b = &boxes[i];
                double z0 = b->z0 > NEAR ? b->z0 : NEAR;
                int b_lit = dark == NULL || !dark[b->geom];
                /* A box within the depths found so far cannot widen
                 * them, and one out of reach has no piece in reach
                 * (box_reached only grows with the box): skip it, and
                 * its pieces, unless it may be the first lit one.  A cut
                 * triangle's box in reach only leads to its pieces. */
                if ((z0 >= zmin && b->z1 <= zmax && (lit || !b_lit)) ||
                    !box_reached(&L, b, u0, u1, v0, v1)) {
                    i += b->skip;
                    continue;
                }
                if (b->skip > 0)
                    continue;
                lit |= b_lit;
                if (z0 < zmin)
                    zmin = z0;
                if (b->z1 > zmax)
                    zmax = b->z1;
            }
            for (size_t i = 0; i < s->n_planes; i++) {
                double z0, z1;
                if (!plane_range(&L, &s->planes[i], u0, u1, v0, v1, &z0, &z1))
                    z0 = INFINITY, z1 = 0.0;
                /* Grow the rectangle by the spread at those depths (twice,
                 * since the growth can reveal nearer parts). */
                for (int it = 0; it < 2 && isfinite(z0); it++) {
                    double g = spread(&L, z0, z1) * 1.01 + 1e-9;
                    if (!plane_range(&L, &s->planes[i], u0 - g, u1 + g, v0 - g,
                                     v1 + g, &z0, &z1))
                        z0 = INFINITY, z1 = 0.0;
                }
                /* plane_reached also finds a plane that only the lens's
                 * spread reaches (beyond its horizon in the block). */
                if (!lit && !dark[s->n_geoms + i] &&
                    plane_reached(&L, &s->planes[i], u0, u1, v0, v1))
                    lit = 1;
                if (z0 < zmin)
                    zmin = z0;
                if (z1 > zmax)
                    zmax = z1;
            }
            bp->dark = !lit;
            /* An environment map is light at infinite depth that any
             * ray may escape to, and the lens blurs it like anything
             * else (a uniform background it cannot change). */
            if (s->env != NULL) {
                if (!(zmin <= zmax))
                    zmin = INFINITY;
                zmax = INFINITY;
            }
            if (!(zmin <= zmax)) {
                /* Nothing reachable: only the background, which no blur
                 * changes. */
                bp->lens = 0;
                bp->chroma = 0;
                continue;
            }
            if (lb != NULL) {
                /* The real lens's spot and colour spread, from its table. */
                double spot, col;
                int ok = lr__lens_blur_bound(c, lb, px0, py0, fx1, fy1, zmin,
                                             zmax, &spot, &col);
                bp->lens = dither || !ok || spot >= LR__PLAN_BLUR_PX;
                bp->chroma = !ok || col >= LR__PLAN_BLUR_PX;
                continue;
            }
            double x_lo = isfinite(zmax) ? 1.0 / zmax : 0.0;
            double x_hi = 1.0 / zmin;
            /* The largest blur of any colour at either end. */
            double blur = 0.0;
            for (int k = 0; k < L.n_w; k++)
                blur = fmax(
                    blur, 2.0 * L.R * L.fpx *
                              fmax(fabs(x_lo - L.ws[k]), fabs(x_hi - L.ws[k])));
            bp->lens = dither || blur >= LR__PLAN_BLUR_PX;
            bp->chroma = L.n_w > 1 &&
                         chroma_spread(&L, x_lo, x_hi) >= LR__PLAN_BLUR_PX;
        }
    put_boxes(s, set);
    return LR_OK;
}

static void rare_free(struct lr__rare *r);

void lr__plan_free(lr__plan *p)
{
    free(p->blocks);
    p->blocks = NULL;
    rare_free(p->rare);
    p->rare = NULL;
    lr__lt_free(p->lt);
    p->lt = NULL;
}

/* Appends geometry geo's boxes to *boxes (n, cap: its count and room):
 * 1, or 0 when out of memory. */
static int make_geom_boxes(const lens *L, const lr__geom *geo, box **boxes,
                           size_t *n, size_t *cap)
{
    if (geo->kind == LR__GEOM_SPHERE) {
        lr__v3 r = v3(geo->radius, geo->radius, geo->radius);
        lr__v3 a = v3_sub(geo->center, r), b = v3_add(geo->center, r);
        /* A degenerate triangle across the box's diagonal has the same
         * bounding box, so it can go through tri_boxes. */
        return tri_boxes(L, a, b, b, 0, boxes, n, cap);
    }
    if (geo->n_triangles <= LR__PLAN_FEW) {
        /* Few, probably large triangles (a ground quad): cut them. */
        for (size_t t = 0; t < geo->n_triangles; t++) {
            lr__v3 q[3];
            for (int k = 0; k < 3; k++) {
                const float *v = &geo->vertices[3 * geo->indices[3 * t + k]];
                q[k] = v3(v[0], v[1], v[2]);
            }
            if (!tri_boxes(L, q[0], q[1], q[2], 7, boxes, n, cap))
                return 0;
        }
        return 1;
    }
    /* Many triangles: a box per CHUNK of them, from the world bounds
     * lr__scene_commit kept (the same for every render, so a frame cut
     * into parts does not find them again for each part). */
    for (size_t t0 = 0; t0 < geo->n_triangles; t0 += CHUNK) {
        if (*n == *cap) {
            size_t nc = *cap ? 2 * *cap : 256;
            box *gr = realloc(*boxes, nc * sizeof *gr);
            if (gr == NULL)
                return 0;
            *boxes = gr;
            *cap = nc;
        }
        const double *wb = &geo->chunk_bounds[6 * (t0 / CHUNK)];
        box_from_bounds(L, wb, wb + 3, &(*boxes)[*n]);
        (*boxes)[(*n)++].skip = 0;
    }
    return 1;
}

/* Bounding boxes of the geometry in camera space, for camera L: 1, or 0
 * when out of memory. */
static int make_boxes(const lr_scene *s, const lens *L, box **out,
                      size_t *out_n)
{
    size_t n_boxes = 0, cap = 0;
    box *boxes = NULL;
    for (size_t g = 0; g < s->n_geoms; g++) {
        size_t first = n_boxes;
        if (!make_geom_boxes(L, &s->geoms[g], &boxes, &n_boxes, &cap)) {
            free(boxes);
            return 0;
        }
        for (size_t i = first; i < n_boxes; i++)
            boxes[i].geom = g;
    }
    *out = boxes;
    *out_n = n_boxes;
    return 1;
}

/* ---- rare light (lr__plan_unseen) --------------------------------------- */

/* A source of rare light: the camera-space bounds of emissive or
 * non-Lambertian geometry, or an infinite plane, and the largest channel
 * of the radiance it can show. */
typedef struct rare_src {
    box b;
    const lr__geom *plane; /* an infinite plane, else NULL */
    double L;
} rare_src;

struct lr__rare {
    lens L;
    int everywhere; /* no bound: every pixel may reach every source */
    double L_all;   /* the largest L of any source */
    double su, sv, half_w, half_h;
    int bw;
    /* Per block: a bound on the environment map's radiance along its
     * pixels' rays (0 without a map). */
    double *env;
    int *first; /* per block b, its sources are idx[first[b] .. first[b+1]) */
    int *idx;
    rare_src *src;
    size_t n;
};

static void rare_free(struct lr__rare *r)
{
    if (r == NULL)
        return;
    free(r->first);
    free(r->env);
    free(r->idx);
    free(r->src);
    free(r);
}

/* The largest channel of the radiance material m emits (its texture's
 * largest texel included): 0 for a material that does not emit. */
static double emission_max(const lr__material *m)
{
    double e = fmax(m->emission.x, fmax(m->emission.y, m->emission.z));
    if (e > 0.0 && m->emission_tex != NULL) {
        const double *t = m->emission_tex->max;
        e = fmax(m->emission.x * t[0],
                 fmax(m->emission.y * t[1], m->emission.z * t[2]));
    }
    return e > 0.0 ? e : 0.0;
}

/* Whether m has a lobe other than a Lambertian one (Phong, mirror,
 * glass, or a glTF metal split), which can show an emitter at up to its
 * radiance where a pilot's few directions miss it. */
static int shows_emitters(const lr__material *m)
{
    lr__v3 a = m->specular, b = m->reflect, c = m->transmit;
    return m->pbr_split || fmax(a.x, fmax(a.y, a.z)) > 0.0 ||
           fmax(b.x, fmax(b.y, b.z)) > 0.0 || fmax(c.x, fmax(c.y, c.z)) > 0.0;
}

/* Does the infinite plane pl meet the lens rays of [u0, u1] x [v0, v1]?
 * As plan_blur grows a block for a plane: the rectangle widened by the
 * spread at the depths the plane has there, twice. */
static int plane_reached(const lens *L, const lr__geom *pl, double u0,
                         double u1, double v0, double v1)
{
    double z0, z1;
    if (!plane_range(L, pl, u0, u1, v0, v1, &z0, &z1)) {
        /* Not seen by the pinhole rays: the lens's spread at the plane's
         * far end still may reach it (a plane seen edge-on). */
        z0 = NEAR, z1 = INFINITY;
    }
    for (int it = 0; it < 2; it++) {
        double g = spread(L, z0, z1) * 1.01 + 1e-9;
        if (!isfinite(g))
            return 1;
        if (!plane_range(L, pl, u0 - g, u1 + g, v0 - g, v1 + g, &z0, &z1))
            return 0;
    }
    return 1;
}

static int src_reached(const lens *L, const rare_src *r, double u0, double u1,
                       double v0, double v1)
{
    if (r->plane != NULL)
        return plane_reached(L, r->plane, u0, u1, v0, v1);
    return box_reached(L, &r->b, u0, u1, v0, v1);
}

/* Appends a source; 0 when out of memory. */
static int src_add(struct lr__rare *r, size_t *cap, const rare_src *x)
{
    if (r->n == *cap) {
        size_t nc = *cap ? 2 * *cap : 64;
        rare_src *g = realloc(r->src, nc * sizeof *g);
        if (g == NULL)
            return 0;
        r->src = g;
        *cap = nc;
    }
    r->src[r->n++] = *x;
    return 1;
}

/* The sources of geometry g that shows radiance up to Lg. */
static int geom_sources(struct lr__rare *r, size_t *cap, const lr__geom *g,
                        double Lg)
{
    rare_src x = {.plane = NULL, .L = Lg};
    if (g->kind == LR__GEOM_SPHERE) {
        double lo[3] = {g->center.x - g->radius, g->center.y - g->radius,
                        g->center.z - g->radius};
        double hi[3] = {g->center.x + g->radius, g->center.y + g->radius,
                        g->center.z + g->radius};
        box_from_bounds(&r->L, lo, hi, &x.b);
        return src_add(r, cap, &x);
    }
    if (g->chunk_bounds != NULL) {
        for (size_t t0 = 0; t0 < g->n_triangles; t0 += CHUNK) {
            const double *wb = &g->chunk_bounds[6 * (t0 / CHUNK)];
            box_from_bounds(&r->L, wb, wb + 3, &x.b);
            if (!src_add(r, cap, &x))
                return 0;
        }
        return 1;
    }
    for (size_t t = 0; t < g->n_triangles; t++) {
        lr__v3 q[3];
        for (int k = 0; k < 3; k++) {
            const float *v = &g->vertices[3 * g->indices[3 * t + k]];
            q[k] = v3(v[0], v[1], v[2]);
        }
        box_from_points(&r->L, q, 3, &x.b);
        if (!src_add(r, cap, &x))
            return 0;
    }
    return 1;
}

/* The rectangle of pixels [px0, px1) x [py0, py1) on the image plane. */
static void pixel_rect(const struct lr__rare *r, double px0, double py0,
                       double px1, double py1, double *u0, double *u1,
                       double *v0, double *v1)
{
    *u0 = px0 * r->su - r->half_w;
    *u1 = px1 * r->su - r->half_w;
    *v0 = r->half_h - py1 * r->sv;
    *v1 = r->half_h - py0 * r->sv;
}

/* The environment map's bound over the directions of the lens rays of
 * pixels [u0, u1] x [v0, v1]: an offset-lens ray has direction D - off w
 * (camera.h), so its point on the image plane lies within the rectangle
 * grown by R |w| for every colour's w; the cone about the rectangle's
 * centre through its farthest corner holds them all. */
static double env_bound(const struct lr__rare *r, const lr__envmap *e,
                        double u0, double u1, double v0, double v1)
{
    const lens *L = &r->L;
    double g = 0.0;
    for (int k = 0; k < L->n_w; k++)
        g = fmax(g, L->R * fabs(L->ws[k]));
    g = g * (1.0 + 1e-9) + 1e-12;
    u0 -= g, u1 += g, v0 -= g, v1 += g;
    lr__v3 axis = v3_norm(v3(0.5 * (u0 + u1), 0.5 * (v0 + v1), 1.0));
    double cmin = 1.0;
    for (int k = 0; k < 4; k++) {
        lr__v3 q = v3_norm(v3(k & 1 ? u1 : u0, k & 2 ? v1 : v0, 1.0));
        cmin = fmin(cmin, v3_dot(q, axis));
    }
    double alpha = acos(fmax(-1.0, fmin(1.0, cmin))) * (1.0 + 1e-9) + 1e-9;
    lr__v3 world = v3_add(
        v3_add(v3_scale(L->fwd, axis.z), v3_scale(L->right, axis.x)),
        v3_scale(L->up, axis.y));
    return lr__envmap_max_in_cone(e, v3_norm(world), alpha);
}

/* Geometry g of the scene, counting its infinite planes after its
 * geometries (as rare_build walks them). */
static const lr__geom *geom_or_plane(const lr_scene *s, size_t g)
{
    return g < s->n_geoms ? &s->geoms[g] : &s->planes[g - s->n_geoms];
}

/* The most a surface that shows emitters (geometry or plane g) shows:
 * everything, or L_glint on a glint surface of the light side. */
static double shown(const lr__lt_view *fl, size_t g, int is_plane,
                    double L_emit, double L_glint)
{
    return !is_plane && lr__lt_flag(fl, (long)g, LR__LT_GLINT_SURF) ? L_glint
                                                                    : L_emit;
}

/* The most of geometry or plane g's emission that a camera ray meeting
 * it first adds: all, or a light side's light's largest camera weight. */
static double cam_share(const lr__lt_view *fl, const lr__cam *c, size_t g,
                        int is_plane)
{
    if (is_plane || !lr__lt_direct(fl, (long)g))
        return 1.0;
    return lr__lt_cam_share_max(c, fl->mis[g]);
}

static lr_status rare_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                            int x0, int y0, int x1, int y1, lr_error *err)
{
    /* The scene's largest emission: what a non-Lambertian lobe may show.
     * A map's sun is a light as small and as bright as any.  (A uniform
     * background is the same in every direction: nothing to miss.)
     * And what a glint surface of the light side shows its first hits:
     * its glint lights' light straight from it is the light side's
     * (light_trace.h), so every other emitter's, and everything if
     * another surface may show those lights in turn. */
    const lr__lt_view *fl = p->lt != NULL ? &p->lt->view : NULL;
    double L_env = s->env != NULL ? lr__envmap_max(s->env) : 0.0;
    double L_emit = L_env, L_glint = L_env;
    int n_show = 0;
    for (size_t g = 0; g < s->n_geoms + s->n_planes; g++) {
        int is_plane = g >= s->n_geoms;
        const lr__material *m = &s->materials[geom_or_plane(s, g)->material];
        L_emit = fmax(L_emit, emission_max(m));
        if (is_plane || !lr__lt_flag(fl, (long)g, LR__LT_GLINT_LIGHT))
            L_glint = fmax(L_glint, emission_max(m));
        n_show += shows_emitters(m);
    }
    if (!(L_emit > 0.0))
        return LR_OK;
    /* A second such surface (another glint surface too) may show them
     * after the first (depth 1 on). */
    if (n_show > 1)
        L_glint = L_emit;
    struct lr__rare *r = calloc(1, sizeof *r);
    if (r == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    /* What the camera's rays may find: every source's, less the direct
     * emission of lights the light side carries (light_trace.h). */
    double L_cam = L_env;
    for (size_t g = 0; g < s->n_geoms + s->n_planes; g++) {
        int is_plane = g >= s->n_geoms;
        const lr__geom *geo = geom_or_plane(s, g);
        const lr__material *m = &s->materials[geo->material];
        L_cam = fmax(L_cam, cam_share(fl, c, g, is_plane) * emission_max(m));
        if (shows_emitters(m))
            L_cam = fmax(L_cam, shown(fl, g, is_plane, L_emit, L_glint));
    }
    r->L_all = L_cam;
    if (c->has_lens && c->model->bound == NULL) {
        /* No bound on where the lens's rays go: anywhere. */
        r->everywhere = 1;
        p->rare = r;
        return LR_OK;
    }
    make_lens(c, &r->L);
    r->su = 2.0 * c->half_w / c->width;
    r->sv = 2.0 * c->half_h / c->height;
    r->half_w = c->half_w;
    r->half_h = c->half_h;
    r->bw = p->bw;
    size_t cap = 0;
    int ok = 1;
    for (size_t g = 0; g < s->n_geoms + s->n_planes && ok; g++) {
        int is_plane = g >= s->n_geoms;
        const lr__geom *geo = geom_or_plane(s, g);
        const lr__material *m = &s->materials[geo->material];
        /* A light of the light side: camera rays see its emission first
         * only by their MIS weight, most often 0 (light_trace.h), and
         * through other surfaces. */
        double Le = cam_share(fl, c, g, is_plane) * emission_max(m);
        double Lg = fmax(Le, shows_emitters(m)
                                 ? shown(fl, g, is_plane, L_emit, L_glint)
                                 : 0.0);
        if (!(Lg > 0.0))
            continue;
        if (is_plane) {
            rare_src x = {.plane = geo, .L = Lg};
            ok = src_add(r, &cap, &x);
        } else {
            ok = geom_sources(r, &cap, geo, Lg);
        }
    }
    /* Per block of the region and its apron (adaptive.c reads the
     * apron's pixels too), the sources its pixels may reach. */
    int gx0 = x0 > 0 ? x0 - 1 : 0, gy0 = y0 > 0 ? y0 - 1 : 0;
    int gx1 = x1 < (int)c->width ? x1 + 1 : x1;
    int gy1 = y1 < (int)c->height ? y1 + 1 : y1;
    int bx0 = gx0 / LR__PLAN_BLOCK, by0 = gy0 / LR__PLAN_BLOCK;
    int bx1 = (gx1 - 1) / LR__PLAN_BLOCK, by1 = (gy1 - 1) / LR__PLAN_BLOCK;
    size_t nb = (size_t)p->bw * (size_t)p->bh, n_idx = 0, idx_cap = 0;
    r->first = ok ? calloc(nb + 1, sizeof *r->first) : NULL;
    ok = r->first != NULL;
    if (ok && s->env != NULL) {
        r->env = calloc(nb, sizeof *r->env);
        ok = r->env != NULL;
    }
    for (size_t b = 0; b < nb && ok; b++) {
        r->first[b] = (int)n_idx;
        int bx = (int)(b % (size_t)p->bw), by = (int)(b / (size_t)p->bw);
        if (bx < bx0 || bx > bx1 || by < by0 || by > by1)
            continue;
        double u0, u1, v0, v1;
        pixel_rect(r, bx * LR__PLAN_BLOCK, by * LR__PLAN_BLOCK,
                   (bx + 1) * LR__PLAN_BLOCK, (by + 1) * LR__PLAN_BLOCK, &u0,
                   &u1, &v0, &v1);
        if (r->env != NULL)
            r->env[b] = env_bound(r, s->env, u0, u1, v0, v1);
        for (size_t i = 0; i < r->n && ok; i++) {
            if (!src_reached(&r->L, &r->src[i], u0, u1, v0, v1))
                continue;
            if (n_idx == idx_cap) {
                size_t nc = idx_cap ? 2 * idx_cap : 256;
                int *gi = realloc(r->idx, nc * sizeof *gi);
                if (gi == NULL) {
                    ok = 0;
                    break;
                }
                r->idx = gi;
                idx_cap = nc;
            }
            r->idx[n_idx++] = (int)i;
        }
    }
    if (!ok) {
        rare_free(r);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    r->first[nb] = (int)n_idx;
    p->rare = r;
    return LR_OK;
}

double lr__plan_unseen(const lr__plan *p, int x, int y)
{
    const struct lr__rare *r = p->rare;
    if (r == NULL)
        return 0.0;
    if (r->everywhere)
        return r->L_all;
    int b = (y / LR__PLAN_BLOCK) * r->bw + x / LR__PLAN_BLOCK;
    double u0, u1, v0, v1, best = r->env != NULL ? r->env[b] : 0.0;
    pixel_rect(r, x, y, x + 1, y + 1, &u0, &u1, &v0, &v1);
    for (int k = r->first[b]; k < r->first[b + 1]; k++) {
        const rare_src *src = &r->src[r->idx[k]];
        if (src->L > best && src_reached(&r->L, src, u0, u1, v0, v1))
            best = src->L;
    }
    return best;
}

/* ---- the light side's lights, per region --------------------------------- */

/* A light path lands where a camera ray of that pixel meets the light,
 * so a light that no lens ray of the region [x0, x1) x [y0, y1) can
 * reach (box_reached, the planner's bound) lands nothing there: a farm
 * part traces only the lights whose discs it holds.  A model without a
 * planner's bound keeps them all. */
static lr_status lt_region(lr__lt *lt, const lr__cam *c, int x0, int y0, int x1,
                           int y1, lr_error *err)
{
    if (c->model->bound == NULL ||
        (x0 == 0 && y0 == 0 && x1 == (int)c->width && y1 == (int)c->height))
        return LR_OK;
    lens L;
    make_lens(c, &L);
    double su = 2.0 * c->half_w / c->width, sv = 2.0 * c->half_h / c->height;
    double u0 = x0 * su - c->half_w, u1 = x1 * su - c->half_w;
    double v0 = c->half_h - y1 * sv, v1 = c->half_h - y0 * sv;
    unsigned char *keep = malloc((size_t)lt->n + 1);
    if (keep == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int k = 0; k < lt->n; k++) {
        const lr__lt_light *l = &lt->lights[k];
        double r = l->radius;
        double lo[3] = {l->center.x - r, l->center.y - r, l->center.z - r};
        double hi[3] = {l->center.x + r, l->center.y + r, l->center.z + r};
        box b;
        box_from_bounds(&L, lo, hi, &b);
        /* A glint may land wherever its surface is seen, a light path
         * anywhere: kept. */
        keep[k] = (unsigned char)(l->surf != -1 ||
                                  box_reached(&L, &b, u0, u1, v0, v1));
    }
    lr__lt_keep(lt, keep);
    free(keep);
    return LR_OK;
}
