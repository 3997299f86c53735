/*
 * plan_boxes.c: the planner's view of the scene (plan_parts.h): the
 * camera-space boxes around its geometry, where a block's lens rays can
 * reach (plan.c's top comment derives the bound), and the scene's cache
 * that keeps the boxes for the next plan with the same camera.
 */
#include "render/plan_parts.h"
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

static void to_cam(const lens *L, lr__v3 p, double *x, double *y, double *z)
{
    lr__v3 r = v3_sub(p, L->e);
    *x = v3_dot(r, L->right);
    *y = v3_dot(r, L->up);
    *z = v3_dot(r, L->fwd);
}

/* The world-space bounds of n points: lo[3], hi[3]. */

/* The camera-space box around the world box [lo, hi]. */
void lr__plan_box_from_bounds(const lens *L, const double lo[3],
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

void lr__plan_box_from_points(const lens *L, const lr__v3 *pts, size_t n,
                              box *b)
{
    double lo[3], hi[3];
    v3_bounds(pts, n, lo, hi);
    lr__plan_box_from_bounds(L, lo, hi, b);
}


/* Can a lens ray of the block [u0, u1] x [v0, v1] reach box b?  At depth
 * z the block's lens rays cover the lateral interval
 * [z u0 - R |1 - z w|, z u1 + R |1 - z w|] (and likewise in y): the
 * pinhole's footprint widened by where off-centre lens points look.  The
 * upper end is convex in z and the lower end concave, so over the box's
 * depths their extremes are at its ends. */
int lr__plan_box_reached(const lens *L, const box *b, double u0, double u1,
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
    lr__plan_box_from_points(L, pts, 3, &bx);
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
double lr__plan_spread(const lens *L, double z0, double z1)
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
int lr__plan_plane_range(const lens *L, const lr__geom *pl, double u0,
                         double u1, double v0, double v1, double *z0,
                         double *z1)
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
double lr__plan_chroma_spread(const lens *L, double x0, double x1)
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

/* ---- the boxes, kept for the next plan with the same camera ------------- */

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
boxset *lr__plan_get_boxes(const lr_scene *s, const lens *L)
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

void lr__plan_put_boxes(const lr_scene *s, boxset *b)
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
void lr__plan_make_lens(const lr__cam *c, lens *L)
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
        lr__plan_box_from_bounds(L, wb, wb + 3, &(*boxes)[*n]);
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

/* Does the infinite plane pl meet the lens rays of [u0, u1] x [v0, v1]?
 * As plan_blur grows a block for a plane: the rectangle widened by the
 * spread at the depths the plane has there, twice. */
int lr__plan_plane_reached(const lens *L, const lr__geom *pl, double u0,
                           double u1, double v0, double v1)
{
    double z0, z1;
    if (!lr__plan_plane_range(L, pl, u0, u1, v0, v1, &z0, &z1)) {
        /* Not seen by the pinhole rays: the lens's spread at the plane's
         * far end still may reach it (a plane seen edge-on). */
        z0 = NEAR, z1 = INFINITY;
    }
    for (int it = 0; it < 2; it++) {
        double g = lr__plan_spread(L, z0, z1) * 1.01 + 1e-9;
        if (!isfinite(g))
            return 1;
        if (!lr__plan_plane_range(L, pl, u0 - g, u1 + g, v0 - g, v1 + g, &z0,
                                  &z1))
            return 0;
    }
    return 1;
}

/* Geometry g of the scene, counting its infinite planes after its
 * geometries (as rare_build walks them). */
const lr__geom *lr__plan_geom_or_plane(const lr_scene *s, size_t g)
{
    return g < s->n_geoms ? &s->geoms[g] : &s->planes[g - s->n_geoms];
}
