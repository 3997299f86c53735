/*
 * film.c: accumulation of samples into pixels.
 */
#include "render/film.h"

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
    double s0 = p->sum[0], s1 = p->sum[1], s2 = p->sum[2];
    double q0 = p->sum2[0], q1 = p->sum2[1], q2 = p->sum2[2];
    for (int i = 0; i < n; i++) {
        if (!v3_finite(L[i])) {
            p->dropped++;
            continue;
        }
        s0 += L[i].x;
        s1 += L[i].y;
        s2 += L[i].z;
        q0 += L[i].x * L[i].x;
        q1 += L[i].y * L[i].y;
        q2 += L[i].z * L[i].z;
    }
    p->n += (uint64_t)n;
    p->sum[0] = s0, p->sum[1] = s1, p->sum[2] = s2;
    p->sum2[0] = q0, p->sum2[1] = q1, p->sum2[2] = q2;
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__pixel_add16(lr__pixel *p, const double L[3][16], int n, int squares)
{
    /* One finiteness test for the packet, over all sixteen lanes at once
     * (isfinite(x) is |x| <= DBL_MAX, NaN failing), instead of a test and
     * a branch per sample. */
    int bad = 0;
    for (int i = 0; i < 16; i++)
        bad |= (i < n) &
               !((fabs(L[0][i]) <= DBL_MAX) & (fabs(L[1][i]) <= DBL_MAX) &
                 (fabs(L[2][i]) <= DBL_MAX));
    if (bad) {
        /* Rare: lr__pixel_add_n's loop, sample by sample. */
        lr__v3 A[16];
        double q[3] = {p->sum2[0], p->sum2[1], p->sum2[2]};
        for (int i = 0; i < n; i++)
            A[i] = v3(L[0][i], L[1][i], L[2][i]);
        lr__pixel_add_n(p, A, n);
        if (!squares)
            p->sum2[0] = q[0], p->sum2[1] = q[1], p->sum2[2] = q[2];
        return;
    }
    /* The sums stay a chain of additions in sample order: the same
     * roundings as lr__pixel_add_n. */
    double s0 = p->sum[0], s1 = p->sum[1], s2 = p->sum[2];
    if (squares) {
        double q0 = p->sum2[0], q1 = p->sum2[1], q2 = p->sum2[2];
        for (int i = 0; i < n; i++) {
            s0 += L[0][i];
            s1 += L[1][i];
            s2 += L[2][i];
            q0 += L[0][i] * L[0][i];
            q1 += L[1][i] * L[1][i];
            q2 += L[2][i] * L[2][i];
        }
        p->sum2[0] = q0, p->sum2[1] = q1, p->sum2[2] = q2;
    } else {
        for (int i = 0; i < n; i++) {
            s0 += L[0][i];
            s1 += L[1][i];
            s2 += L[2][i];
        }
    }
    p->sum[0] = s0, p->sum[1] = s1, p->sum[2] = s2;
    p->n += (uint64_t)n;
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
