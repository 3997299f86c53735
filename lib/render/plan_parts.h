/*
 * plan_parts.h: the planner's private parts, between plan.c (the plan of
 * blocks), plan_boxes.c (the camera-space boxes of the scene and their
 * cache) and plan_rare.c (rare light and the light side's regions).
 * Nothing outside lib/render/plan*.c includes it; the planner's interface
 * is plan.h.  Camera space, the lens's bound and why it holds: plan.c's
 * top comment.
 */
#ifndef LR_PLAN_PARTS_H
#define LR_PLAN_PARTS_H

#include "render/plan.h"

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

/* The camera-space boxes of a scene's geometry for one camera, shared by
 * the plans that use them (refs, under the cache's lock) and immutable. */
typedef struct boxset {
    int refs;
    lens key;
    size_t n;
    box *boxes;
} boxset;

/* ---- plan_boxes.c ---------------------------------------------------------- */

/* The planner's lens for camera c: its model's bound (lr__cam_bound), or
 * none (R = 0) for a camera without a lens or a real lens (plan_blur sets
 * its own). */
void lr__plan_make_lens(const lr__cam *c, lens *L);

/* The camera-space box around the world box [lo, hi], or around n
 * points. */
void lr__plan_box_from_bounds(const lens *L, const double lo[3],
                              const double hi[3], box *b);
void lr__plan_box_from_points(const lens *L, const lr__v3 *pts, size_t n,
                              box *b);

/* Whether a lens ray of the block [u0, u1] x [v0, v1] can reach box b,
 * or the infinite plane pl. */
int lr__plan_box_reached(const lens *L, const box *b, double u0, double u1,
                         double v0, double v1);
int lr__plan_plane_reached(const lens *L, const lr__geom *pl, double u0,
                           double u1, double v0, double v1);

/* The depth range [*z0, *z1] of plane pl over [u0, u1] x [v0, v1]; 0 if
 * it is not seen there. */
int lr__plan_plane_range(const lens *L, const lr__geom *pl, double u0,
                         double u1, double v0, double v1, double *z0,
                         double *z1);

/* How far lens rays of any colour stray from the pinhole over depths
 * [z0, z1], in (u, v); and the most the colours' blur diameters differ,
 * in pixels, over 1/Z in [x0, x1]. */
double lr__plan_spread(const lens *L, double z0, double z1);
double lr__plan_chroma_spread(const lens *L, double x0, double x1);

/* The boxes of scene s for camera L, from the scene's cache or made now
 * (a reference; NULL when out of memory), and the reference dropped. */
boxset *lr__plan_get_boxes(const lr_scene *s, const lens *L);
void lr__plan_put_boxes(const lr_scene *s, boxset *b);

/* Geometry g of the scene's geometries followed by its planes. */
const lr__geom *lr__plan_geom_or_plane(const lr_scene *s, size_t g);

/* ---- plan_rare.c ----------------------------------------------------------- */

/* p->rare for the region [x0, x1) x [y0, y1) (lr__plan_unseen), and its
 * freeing. */
lr_status lr__plan_rare_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                              int x0, int y0, int x1, int y1, lr_error *err);
void lr__plan_rare_free(struct lr__rare *r);

/* Keeps only the light side's lights that a lens ray of the region can
 * reach. */
lr_status lr__plan_lt_region(lr__lt *lt, const lr__cam *c, int x0, int y0,
                             int x1, int y1, lr_error *err);

#endif
