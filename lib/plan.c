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
#include "plan.h"
#include "adaptive.h"
#include "sampler.h"
#include "splat.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#define CHUNK 64       /* triangles per bounding box */
#define NEAR 1e-6      /* depths below this count as "at the eye" */

typedef struct box {
    double z0, z1;         /* depth range */
    double x0, x1, y0, y1; /* lateral range, camera space */
    size_t skip;           /* > 0: a cut triangle's whole box, followed by
                              the `skip` boxes of its pieces */
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
static void world_bounds(const lr__v3 *pts, size_t n, double lo[3],
                         double hi[3])
{
    lo[0] = lo[1] = lo[2] = DBL_MAX;
    hi[0] = hi[1] = hi[2] = -DBL_MAX;
    for (size_t i = 0; i < n; i++) {
        double c[3] = {pts[i].x, pts[i].y, pts[i].z};
        for (int k = 0; k < 3; k++) {
            if (c[k] < lo[k])
                lo[k] = c[k];
            if (c[k] > hi[k])
                hi[k] = c[k];
        }
    }
}

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

static void box_from_points(const lens *L, const lr__v3 *pts, size_t n,
                            box *b)
{
    double lo[3], hi[3];
    world_bounds(pts, n, lo, hi);
    box_from_bounds(L, lo, hi, b);
}

/* The points of triangles [t0, t0 + CHUNK) of g (fewer at the end):
 * their number. */
static size_t chunk_points(const lr__geom *g, size_t t0, lr__v3 *pts)
{
    size_t n = 0;
    for (size_t t = t0; t < g->n_triangles && t < t0 + CHUNK; t++)
        for (int k = 0; k < 3; k++) {
            const float *v = &g->vertices[3 * g->indices[3 * t + k]];
            pts[n++] = v3(v[0], v[1], v[2]);
        }
    return n;
}

lr_status lr__plan_chunk_bounds(lr__geom *g, lr_error *err)
{
    if (g->kind != LR__GEOM_TRIANGLES || g->n_triangles <= LR__PLAN_FEW)
        return LR_OK;
    size_t n_chunks = (g->n_triangles + CHUNK - 1) / CHUNK;
    g->chunk_bounds = malloc(n_chunks * 6 * sizeof *g->chunk_bounds);
    if (g->chunk_bounds == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (size_t c = 0; c < n_chunks; c++) {
        lr__v3 pts[3 * CHUNK];
        size_t n = chunk_points(g, c * CHUNK, pts);
        world_bounds(pts, n, &g->chunk_bounds[6 * c],
                     &g->chunk_bounds[6 * c + 3]);
    }
    return LR_OK;
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
static int plane_range(const lens *L, const lr__geom *pl, double u0,
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
static void finish(lr__plan *p, const lr__cam *c,
                   const lr_render_settings *set)
{
    for (int i = 0; i < p->bw * p->bh; i++) {
        lr__block_plan *bp = &p->blocks[i];
        bp->lens = c->has_lens && bp->lens;
        bp->chroma = c->chroma_active && bp->lens && bp->chroma;
        bp->path = bp->chroma ? LR__PATH_COLOURS : LR__PATH_PACKET;
        bp->pilot = lr__adaptive_pilot(set, bp->lens);
    }
}

static lr_status plan_blur(lr__plan *p, const lr_scene *s, const lr__cam *c,
                           int dither, int x0, int y0, int x1, int y1,
                           lr_error *err);

lr_status lr__plan_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                         const lr_render_settings *set, int x0, int y0,
                         int x1, int y1, lr_error *err)
{
    p->bw = ((int)c->width + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->bh = ((int)c->height + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->blocks = malloc((size_t)p->bw * (size_t)p->bh * sizeof *p->blocks);
    if (p->blocks == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < p->bw * p->bh; i++)
        p->blocks[i] = (lr__block_plan){1, 1, 0, 0};
    /* Splatting traces one ray a pixel and sample for the whole
     * spectrum, where spectral.c's packets trace one a wavelength
     * (docs/spectral.md measures both). */
    p->splat = lr__splat_applies(c);
    /* A model with no safe bound samples its lens everywhere. */
    if (set->plan && !p->splat && c->has_lens && c->model->bound != NULL) {
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
        int dither =
            set->adaptive && lr__sampler_fixed_positions(set->sampler);
        lr_status st = plan_blur(p, s, c, dither, gx0, gy0, gx1, gy1, err);
        if (st != LR_OK) {
            lr__plan_free(p);
            return st;
        }
    }
    finish(p, c, set);
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

struct lr__plan_cache {
    pthread_mutex_t lock;
    boxset *last;
};

struct lr__plan_cache *lr__plan_cache_new(void)
{
    struct lr__plan_cache *c = calloc(1, sizeof *c);
    if (c != NULL && pthread_mutex_init(&c->lock, NULL) != 0) {
        free(c);
        c = NULL;
    }
    return c;
}

static void boxset_unref(boxset *b)
{
    if (b != NULL && --b->refs == 0) {
        free(b->boxes);
        free(b);
    }
}

void lr__plan_cache_free(struct lr__plan_cache *c)
{
    if (c == NULL)
        return;
    boxset_unref(c->last);
    pthread_mutex_destroy(&c->lock);
    free(c);
}

/* Whether two cameras give the same boxes: every input of tri_boxes and
 * box_from_bounds, compared exactly. */
static int same_lens(const lens *a, const lens *b)
{
    if (a->R != b->R || a->w != b->w || a->fpx != b->fpx ||
        a->n_w != b->n_w)
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
    struct lr__plan_cache *c = s->plan_cache;
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
    struct lr__plan_cache *c = s->plan_cache;
    if (c != NULL)
        pthread_mutex_lock(&c->lock);
    boxset_unref(b);
    if (c != NULL)
        pthread_mutex_unlock(&c->lock);
}

/* Where no colour's blur can reach a quarter pixel, the block needs no
 * lens (unless `dither`: wherever it reaches anything); where the
 * colours' blurs differ by less, one ray for all. */
static lr_status plan_blur(lr__plan *p, const lr_scene *s, const lr__cam *c,
                           int dither, int x0, int y0, int x1, int y1,
                           lr_error *err)
{
    lens L;
    lr__lens_bound lb;
    lr__cam_bound(c, &lb);
    L.R = lb.R;
    L.w = lb.ws[0];
    L.fpx = c->height / (2.0 * c->half_h);
    L.e = c->origin;
    L.fwd = c->forward;
    L.right = c->right;
    L.up = c->up;
    L.n_w = lb.n_w;
    for (int k = 0; k < lb.n_w; k++)
        L.ws[k] = lb.ws[k];

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
            double zmin = INFINITY, zmax = 0.0;
            for (size_t i = 0; i < n_boxes; i++) {
                const box *b = &boxes[i];
                double z0 = b->z0 > NEAR ? b->z0 : NEAR;
                /* A box within the depths found so far cannot widen
                 * them, and one out of reach has no piece in reach
                 * (box_reached only grows with the box): skip it, and
                 * its pieces.  A cut triangle's box in reach only leads
                 * to its pieces. */
                if ((z0 >= zmin && b->z1 <= zmax) ||
                    !box_reached(&L, b, u0, u1, v0, v1)) {
                    i += b->skip;
                    continue;
                }
                if (b->skip > 0)
                    continue;
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
                    if (!plane_range(&L, &s->planes[i], u0 - g, u1 + g,
                                     v0 - g, v1 + g, &z0, &z1))
                        z0 = INFINITY, z1 = 0.0;
                }
                if (z0 < zmin)
                    zmin = z0;
                if (z1 > zmax)
                    zmax = z1;
            }
            lr__block_plan *bp = &p->blocks[by * p->bw + bx];
            if (!(zmin <= zmax)) {
                /* Nothing reachable: only the background, which no blur
                 * changes. */
                bp->lens = 0;
                bp->chroma = 0;
                continue;
            }
            double x_lo = isfinite(zmax) ? 1.0 / zmax : 0.0;
            double x_hi = 1.0 / zmin;
            /* The largest blur of any colour at either end. */
            double blur = 0.0;
            for (int k = 0; k < L.n_w; k++)
                blur = fmax(blur, 2.0 * L.R * L.fpx *
                                      fmax(fabs(x_lo - L.ws[k]),
                                           fabs(x_hi - L.ws[k])));
            bp->lens = dither || blur >= LR__PLAN_BLUR_PX;
            bp->chroma = L.n_w > 1 &&
                         chroma_spread(&L, x_lo, x_hi) >= LR__PLAN_BLUR_PX;
        }
    put_boxes(s, set);
    return LR_OK;
}

void lr__plan_free(lr__plan *p)
{
    free(p->blocks);
    p->blocks = NULL;
}

/* Bounding boxes of the geometry in camera space, for camera L: 1, or 0
 * when out of memory. */
static int make_boxes(const lr_scene *s, const lens *L, box **out,
                      size_t *out_n)
{
    size_t n_boxes = 0, cap = 0;
    box *boxes = NULL;
    int ok = 1;
    for (size_t g = 0; g < s->n_geoms && ok; g++) {
        const lr__geom *geo = &s->geoms[g];
        if (geo->kind == LR__GEOM_SPHERE) {
            lr__v3 r = v3(geo->radius, geo->radius, geo->radius);
            lr__v3 a = v3_sub(geo->center, r), b = v3_add(geo->center, r);
            /* A degenerate triangle across the box's diagonal has the
             * same bounding box, so it can go through tri_boxes. */
            ok = tri_boxes(L, a, b, b, 0, &boxes, &n_boxes, &cap);
            continue;
        }
        if (geo->n_triangles <= LR__PLAN_FEW) {
            /* Few, probably large triangles (a ground quad): cut them. */
            for (size_t t = 0; t < geo->n_triangles && ok; t++) {
                lr__v3 q[3];
                for (int k = 0; k < 3; k++) {
                    const float *v =
                        &geo->vertices[3 * geo->indices[3 * t + k]];
                    q[k] = v3(v[0], v[1], v[2]);
                }
                ok = tri_boxes(L, q[0], q[1], q[2], 7, &boxes, &n_boxes,
                               &cap);
            }
            continue;
        }
        /* Many triangles: a box per CHUNK of them, from the world bounds
         * lr__scene_commit kept (the same for every render, so a frame
         * cut into parts does not find them again for each part). */
        for (size_t t0 = 0; t0 < geo->n_triangles && ok; t0 += CHUNK) {
            if (n_boxes == cap) {
                size_t nc = cap ? 2 * cap : 256;
                box *gr = realloc(boxes, nc * sizeof *gr);
                if (gr == NULL) {
                    ok = 0;
                    break;
                }
                boxes = gr;
                cap = nc;
            }
            const double *wb = &geo->chunk_bounds[6 * (t0 / CHUNK)];
            box_from_bounds(L, wb, wb + 3, &boxes[n_boxes]);
            boxes[n_boxes++].skip = 0;
        }
    }
    if (!ok) {
        free(boxes);
        return 0;
    }
    *out = boxes;
    *out_n = n_boxes;
    return 1;
}
