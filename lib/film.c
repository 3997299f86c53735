/*
 * film.c: accumulation of samples into pixels.
 */
#include "film.h"

#include <float.h>
#include <math.h>

void lr__pixel_add(lr__pixel *p, lr__v3 L)
{
    p->n++;
    if (!v3_finite(L)) {
        p->dropped++;
        return;
    }
    p->sum[0] += L.x;
    p->sum[1] += L.y;
    p->sum[2] += L.z;
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
