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
 * So a block's lens rays can only reach geometry whose pinhole projection
 * meets the block's rectangle grown by R |1/Z - w| at that geometry's
 * depth.  Geometry is bounded by boxes (spheres; triangles in chunks of
 * 64); infinite planes exactly, since 1/Z is linear in (u, v) on a plane.
 * The block's blur is then at most C at the ends of its depth range.
 */
#include "plan.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CHUNK 64       /* triangles per bounding box */
#define NEAR 1e-6      /* depths below this count as "at the eye" */

typedef struct box {
    double z0, z1; /* depth range */
    double u0, u1, v0, v1; /* projected extent (when z0 > NEAR) */
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

static void box_from_points(const lens *L, const lr__v3 *pts, size_t n,
                            box *b)
{
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX},
           hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    for (size_t i = 0; i < n; i++) {
        double c[3] = {pts[i].x, pts[i].y, pts[i].z};
        for (int k = 0; k < 3; k++) {
            if (c[k] < lo[k])
                lo[k] = c[k];
            if (c[k] > hi[k])
                hi[k] = c[k];
        }
    }
    /* The eight corners of the world box, in camera space. */
    b->z0 = DBL_MAX, b->z1 = -DBL_MAX;
    b->u0 = b->v0 = DBL_MAX, b->u1 = b->v1 = -DBL_MAX;
    double cx[8], cy[8], cz[8];
    for (int k = 0; k < 8; k++) {
        lr__v3 p = v3(k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1],
                      k & 4 ? hi[2] : lo[2]);
        to_cam(L, p, &cx[k], &cy[k], &cz[k]);
        if (cz[k] < b->z0)
            b->z0 = cz[k];
        if (cz[k] > b->z1)
            b->z1 = cz[k];
    }
    if (b->z0 > NEAR)
        for (int k = 0; k < 8; k++) {
            double u = cx[k] / cz[k], v = cy[k] / cz[k];
            if (u < b->u0)
                b->u0 = u;
            if (u > b->u1)
                b->u1 = u;
            if (v < b->v0)
                b->v0 = v;
            if (v > b->v1)
                b->v1 = v;
        }
}

/* How far (in u, v) lens rays stray from the pinhole at depths in
 * [z0, z1]: R |1/Z - w| is largest at an end. */
static double spread(const lens *L, double z0, double z1)
{
    double a = fabs(1.0 / z0 - L->w);
    double b = isfinite(z1) ? fabs(1.0 / z1 - L->w) : fabs(L->w);
    return L->R * (a > b ? a : b);
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

lr_status lr__plan_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                         int x0, int y0, int x1, int y1, int enabled,
                         lr_error *err)
{
    p->bw = ((int)c->width + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->bh = ((int)c->height + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->blocks = malloc((size_t)p->bw * (size_t)p->bh * sizeof *p->blocks);
    if (p->blocks == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < p->bw * p->bh; i++)
        p->blocks[i] = (lr__block_plan){1, 1};
    if (!enabled || !c->has_lens)
        return LR_OK;

    lens L;
    /* The aperture's farthest point from its centre. */
    double reach = c->shape == LR_APERTURE_SQUARE ? sqrt(2.0) : 1.0;
    double ratio = c->ratio > 1.0 ? c->ratio : 1.0;
    L.R = c->radius * reach * ratio;
    L.w = c->w;
    if (c->model == LR_CAMERA_BRACKET) {
        /* The equivalent lens at the eye: radius grows by 1 + di/f, focus
         * at di + f. */
        L.R *= 1.0 + c->di * c->w;
        L.w = 1.0 / (c->di + 1.0 / c->w);
    }
    L.fpx = c->height / (2.0 * c->half_h);
    L.e = c->origin;
    L.fwd = c->forward;
    L.right = c->right;
    L.up = c->up;
    L.n_w = 1;
    L.ws[0] = L.w;
    if (c->chroma_active) {
        /* Other colours differ from the reference only in focus power;
         * for the bracket, convert like the reference. */
        double w1, w2;
        if (c->chroma.mode == LR_CHROMATIC_RGB) {
            w1 = c->w_rgb[0];
            w2 = c->w_rgb[2];
        } else {
            w1 = lr__cam_power_at(c, 380.0);
            w2 = lr__cam_power_at(c, 780.0);
        }
        if (c->model == LR_CAMERA_BRACKET) {
            w1 = 1.0 / (c->di + 1.0 / w1);
            w2 = 1.0 / (c->di + 1.0 / w2);
        }
        L.ws[1] = w1;
        L.ws[2] = w2;
        L.n_w = 3;
    }

    /* Bounding boxes of the geometry in camera space. */
    size_t n_boxes = 0, cap = 0;
    for (size_t g = 0; g < s->n_geoms; g++)
        cap += s->geoms[g].kind == LR__GEOM_TRIANGLES
                   ? (s->geoms[g].n_triangles + CHUNK - 1) / CHUNK
                   : 1;
    box *boxes = malloc((cap ? cap : 1) * sizeof *boxes);
    if (boxes == NULL) {
        lr__plan_free(p);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *geo = &s->geoms[g];
        if (geo->kind == LR__GEOM_SPHERE) {
            lr__v3 pts[2] = {v3_sub(geo->center, v3(geo->radius, geo->radius,
                                                    geo->radius)),
                             v3_add(geo->center, v3(geo->radius, geo->radius,
                                                    geo->radius))};
            box_from_points(&L, pts, 2, &boxes[n_boxes++]);
            continue;
        }
        for (size_t t0 = 0; t0 < geo->n_triangles; t0 += CHUNK) {
            lr__v3 pts[3 * CHUNK];
            size_t n = 0;
            for (size_t t = t0; t < geo->n_triangles && t < t0 + CHUNK; t++)
                for (int k = 0; k < 3; k++) {
                    const float *v = &geo->vertices[3 * geo->indices[3 * t + k]];
                    pts[n++] = v3(v[0], v[1], v[2]);
                }
            box_from_points(&L, pts, n, &boxes[n_boxes++]);
        }
    }

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
                if (b->z1 <= NEAR)
                    continue; /* wholly behind the eye */
                if (b->z0 <= NEAR) {
                    /* Reaches the eye's plane: assume the worst. */
                    zmin = NEAR;
                    if (b->z1 > zmax)
                        zmax = b->z1;
                    continue;
                }
                double g = spread(&L, b->z0, b->z1) + 1e-9;
                if (b->u1 < u0 - g || b->u0 > u1 + g || b->v1 < v0 - g ||
                    b->v0 > v1 + g)
                    continue;
                if (b->z0 < zmin)
                    zmin = b->z0;
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
            bp->lens = blur >= LR__PLAN_BLUR_PX;
            bp->chroma = L.n_w > 1 &&
                         chroma_spread(&L, x_lo, x_hi) >= LR__PLAN_BLUR_PX;
        }
    free(boxes);
    return LR_OK;
}

void lr__plan_free(lr__plan *p)
{
    free(p->blocks);
    p->blocks = NULL;
}
