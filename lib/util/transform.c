/*
 * transform.c: the scene format's transforms: the affine algebra that
 * places objects (points, normals, mirroring, uniform scale) and the
 * check that placed geometry stays within the scene's number limit.  The
 * JSON list of translate / rotate / scale steps is read by
 * scene_objects.c (lr__xform_parse).
 */
#include "util/transform.h"

#include <math.h>
#include <string.h>

lr__xform lr__xform_identity(void)
{
    lr__xform x = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
    return x;
}

lr__xform lr__xform_mul(const lr__xform *a, const lr__xform *b)
{
    lr__xform r;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++) {
            double v = j == 3 ? a->m[i][3] : 0.0;
            for (int k = 0; k < 3; k++)
                v += a->m[i][k] * b->m[k][j];
            r.m[i][j] = v;
        }
    return r;
}

lr__v3 lr__xform_point(const lr__xform *x, lr__v3 p)
{
    return v3(
        x->m[0][0] * p.x + x->m[0][1] * p.y + x->m[0][2] * p.z + x->m[0][3],
        x->m[1][0] * p.x + x->m[1][1] * p.y + x->m[1][2] * p.z + x->m[1][3],
        x->m[2][0] * p.x + x->m[2][1] * p.y + x->m[2][2] * p.z + x->m[2][3]);
}

/* The cofactor matrix of m's 3 x 3 part times n, and the sign of its
 * determinant. */
static lr__v3 cofactor_times(const double (*m)[4], lr__v3 n, double *sign)
{
    double c[3][3] = {{m[1][1] * m[2][2] - m[1][2] * m[2][1],
                       m[1][2] * m[2][0] - m[1][0] * m[2][2],
                       m[1][0] * m[2][1] - m[1][1] * m[2][0]},
                      {m[0][2] * m[2][1] - m[0][1] * m[2][2],
                       m[0][0] * m[2][2] - m[0][2] * m[2][0],
                       m[0][1] * m[2][0] - m[0][0] * m[2][1]},
                      {m[0][1] * m[1][2] - m[0][2] * m[1][1],
                       m[0][2] * m[1][0] - m[0][0] * m[1][2],
                       m[0][0] * m[1][1] - m[0][1] * m[1][0]}};
    double det = m[0][0] * c[0][0] + m[0][1] * c[0][1] + m[0][2] * c[0][2];
    *sign = det < 0.0 ? -1.0 : 1.0;
    return v3(c[0][0] * n.x + c[0][1] * n.y + c[0][2] * n.z,
              c[1][0] * n.x + c[1][1] * n.y + c[1][2] * n.z,
              c[2][0] * n.x + c[2][1] * n.y + c[2][2] * n.z);
}

/* Normals transform by the inverse transpose.  The cofactor matrix is
 * the inverse transpose times the determinant: normalised, the same
 * direction where the determinant is positive, the opposite one where x
 * mirrors.  So its sign is taken off: with it, a mirrored infinite
 * plane's front turned to the other side and a mirrored mesh's file
 * normals pointed behind their faces, which dropped them (flat shading;
 * tests/test_trace.c, test_mirror_keeps_normals). */
lr__v3 lr__xform_normal(const lr__xform *x, lr__v3 n)
{
    double sign;
    lr__v3 v = cofactor_times(x->m, n, &sign);
    if (v3_len(v) > 1e-200 && v3_finite(v))
        return v3_scale(v3_norm(v), sign);
    /* Products of two tiny scales underflowed (a plane scaled by 1e-300
     * across itself lost its normal).  M = A D, D the columns' lengths,
     * A's columns unit: M^-T n = A^-T (D^-1 n), A's cofactors well
     * scaled, and D^-1 n scaled by D's least length (the direction is
     * all that counts). */
    double a[3][4], len[3];
    for (int j = 0; j < 3; j++) {
        len[j] = fmax(fabs(x->m[0][j]),
                      fmax(fabs(x->m[1][j]), fabs(x->m[2][j])));
        for (int i = 0; i < 3; i++)
            a[i][j] = len[j] > 0.0 ? x->m[i][j] / len[j] : 0.0;
    }
    double lo = INFINITY;
    for (int j = 0; j < 3; j++)
        lo = len[j] > 0.0 ? fmin(lo, len[j]) : lo;
    /* n / D times the least length: ratios at most 1, no overflow. */
    lr__v3 w = v3(len[0] > 0.0 ? n.x * (lo / len[0]) : 0.0,
                  len[1] > 0.0 ? n.y * (lo / len[1]) : 0.0,
                  len[2] > 0.0 ? n.z * (lo / len[2]) : 0.0);
    double big = v3_maxabs(w);
    if (big > 0.0)
        w = v3_scale(w, 1.0 / big); /* largest 1: its length cannot underflow */
    v = cofactor_times((const double(*)[4])a, w, &sign);
    return v3_scale(v3_norm(v), sign);
}

double lr__xform_det(const lr__xform *x)
{
    const double(*m)[4] = x->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* For spheres: the transform must scale all directions alike.  Returns
 * the scale factor, or -1 if it does not. */
double lr__xform_uniform_scale(const lr__xform *x)
{
    double len[3];
    for (int j = 0; j < 3; j++)
        len[j] = sqrt(x->m[0][j] * x->m[0][j] + x->m[1][j] * x->m[1][j] +
                      x->m[2][j] * x->m[2][j]);
    for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++) {
            double dot = x->m[0][a] * x->m[0][b] + x->m[1][a] * x->m[1][b] +
                         x->m[2][a] * x->m[2][b];
            if (fabs(dot) > 1e-9 * len[a] * len[b])
                return -1;
        }
    if (fabs(len[0] - len[1]) > 1e-9 * len[0] ||
        fabs(len[0] - len[2]) > 1e-9 * len[0])
        return -1;
    return len[0];
}

/* Geometry, once transformed, must stay within LR__MAX_NUMBER of the
 * origin like every number of the file: beyond that Embree's float
 * rays stop being valid (an Embree assertion aborts the process). */
lr_status lr__check_extent(double m, const char *p, lr_error *err)
{
    if (!(m <= LR__MAX_NUMBER))
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s: the object reaches %g from the origin, beyond "
                        "the limit of 1e15",
                        p, m);
    return LR_OK;
}
