/*
 * transform.h: the affine transforms of the scene format's "transform"
 * lists (translate, rotate, scale), and the limit on how far placed
 * geometry may reach.
 */
#ifndef LR_TRANSFORM_H
#define LR_TRANSFORM_H

#include "util/internal.h"
#include "util/vec.h"

/* A 3x4 affine transform, row-major: p' = M p + t. */
typedef struct lr__xform {
    double m[3][4];
} lr__xform;

lr__xform lr__xform_identity(void);
/* a * b: apply b first, then a. */
lr__xform lr__xform_mul(const lr__xform *a, const lr__xform *b);
lr__v3 lr__xform_point(const lr__xform *x, lr__v3 p);
/* A unit normal moved by x: the inverse transpose, normalised (for a
 * mirroring x too, so it stays on the image of its side). */
lr__v3 lr__xform_normal(const lr__xform *x, lr__v3 n);
/* The determinant of the linear part: negative for a mirroring x. */
double lr__xform_det(const lr__xform *x);
/* For spheres: the scale factor when x scales all directions alike,
 * else -1. */
double lr__xform_uniform_scale(const lr__xform *x);

/* Fails unless `m`, the largest coordinate magnitude a placed object
 * reaches, is within LR__MAX_NUMBER; `p` is the field to blame. */
lr_status lr__check_extent(double m, const char *p, lr_error *err);

#endif
