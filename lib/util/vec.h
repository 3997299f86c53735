/*
 * vec.h: small 3-vector helpers in double precision, all static inline.
 * The renderer computes in double and hands Embree floats.
 */
#ifndef LR_VEC_H
#define LR_VEC_H

#include <float.h>
#include <math.h>
#include <stddef.h>

typedef struct lr__v3 {
    double x, y, z;
} lr__v3;

static inline lr__v3 v3(double x, double y, double z)
{
    lr__v3 r = {x, y, z};
    return r;
}
static inline lr__v3 v3a(const double a[3])
{
    return v3(a[0], a[1], a[2]);
}
static inline lr__v3 v3_add(lr__v3 a, lr__v3 b)
{
    return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline lr__v3 v3_sub(lr__v3 a, lr__v3 b)
{
    return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline lr__v3 v3_mul(lr__v3 a, lr__v3 b)
{
    return v3(a.x * b.x, a.y * b.y, a.z * b.z);
}
static inline lr__v3 v3_scale(lr__v3 a, double s)
{
    return v3(a.x * s, a.y * s, a.z * s);
}
static inline lr__v3 v3_madd(lr__v3 a, lr__v3 b, double s)
{
    return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
static inline double v3_dot(lr__v3 a, lr__v3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline lr__v3 v3_cross(lr__v3 a, lr__v3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z,
              a.x * b.y - a.y * b.x);
}
static inline double v3_len(lr__v3 a)
{
    return sqrt(v3_dot(a, a));
}
static inline lr__v3 v3_norm(lr__v3 a)
{
    double l = v3_len(a);
    return l > 0 ? v3_scale(a, 1.0 / l) : a;
}
static inline lr__v3 v3_neg(lr__v3 a)
{
    return v3(-a.x, -a.y, -a.z);
}
static inline double v3_maxabs(lr__v3 a)
{
    double m = fabs(a.x);
    if (fabs(a.y) > m)
        m = fabs(a.y);
    if (fabs(a.z) > m)
        m = fabs(a.z);
    return m;
}
static inline double v3_maxc(lr__v3 a)
{
    double m = a.x;
    if (a.y > m)
        m = a.y;
    if (a.z > m)
        m = a.z;
    return m;
}
static inline int v3_finite(lr__v3 a)
{
    return isfinite(a.x) && isfinite(a.y) && isfinite(a.z);
}
/* Two unit vectors completing unit a to a right-handed orthonormal frame
 * (Duff et al. 2017, "Building an orthonormal basis, revisited"). */
static inline void v3_frame(lr__v3 a, lr__v3 *t1, lr__v3 *t2)
{
    double sign = copysign(1.0, a.z);
    double p = -1.0 / (sign + a.z), q = a.x * a.y * p;
    *t1 = v3(1.0 + sign * a.x * a.x * p, sign * q, -sign * a.x);
    *t2 = v3(q, sign + a.y * a.y * p, -a.y);
}

/* The bounds lo, hi (per axis, x y z) of points pts[0 .. n-1]; for
 * n = 0, lo above hi. */
static inline void v3_bounds(const lr__v3 *pts, size_t n, double lo[3],
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

#endif
