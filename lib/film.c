/*
 * film.c: accumulation of samples into pixels.
 */
#include "film.h"

#include <float.h>
#include <math.h>

void lr__pixel_add(lr__pixel *p, lr__v3 L)
{
    lr__pixel_add_n(p, &L, 1);
}

void lr__pixel_add_n(lr__pixel *p, const lr__v3 *L, int n)
{
    /* Non-finite samples are counted and dropped; the sums are kept in
     * registers, in sample order. */
    double s0 = p->sum[0], s1 = p->sum[1], s2 = p->sum[2], sy = p->sum_y2;
    for (int i = 0; i < n; i++) {
        if (!v3_finite(L[i])) {
            p->dropped++;
            continue;
        }
        s0 += L[i].x;
        s1 += L[i].y;
        s2 += L[i].z;
        double y = lr__luminance(L[i].x, L[i].y, L[i].z);
        sy += y * y;
    }
    p->n += (uint64_t)n;
    p->sum[0] = s0, p->sum[1] = s1, p->sum[2] = s2, p->sum_y2 = sy;
}

void lr__pixel_resolve(const lr__pixel *p, float out[3])
{
    for (int c = 0; c < 3; c++) {
        double v = p->n ? p->sum[c] / (double)p->n : 0.0;
        /* Finite doubles can still overflow float: clamp, never write
         * Inf (or NaN) into an image. */
        if (isnan(v))
            v = 0.0;
        if (v > FLT_MAX)
            v = FLT_MAX;
        if (v < -FLT_MAX)
            v = -FLT_MAX;
        out[c] = (float)v;
    }
}
