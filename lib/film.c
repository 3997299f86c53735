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

int lr__pixel_samples_needed(const lr__pixel *p, double threshold, int lo,
                             int hi)
{
    /* One sample says nothing about the spread: judge again after two. */
    if (p->n < 2)
        return 2 < hi ? 2 : hi;
    double n = (double)p->n;
    double mean = lr__luminance(p->sum[0], p->sum[1], p->sum[2]) / n;
    double var = (p->sum_y2 / n - mean * mean) * n / (n - 1.0);
    if (!(var > 0.0))
        return lo;
    /* Standard error sqrt(var / N) relative to the mean, with a floor of
     * 0.02 on the mean so that near-black pixels do not ask for endless
     * samples to pin down nothing. */
    double ref = fabs(mean) + 0.02;
    double need = var / (threshold * threshold * ref * ref);
    if (!(need < (double)hi))
        return hi;
    int k = (int)ceil(need);
    return k < lo ? lo : k;
}

double lr__pixel_contrast(const lr__pixel *a, const lr__pixel *b)
{
    if (a->n == 0 || b->n == 0)
        return 0.0;
    double ma = lr__luminance(a->sum[0], a->sum[1], a->sum[2]) / (double)a->n;
    double mb = lr__luminance(b->sum[0], b->sum[1], b->sum[2]) / (double)b->n;
    return fabs(ma - mb) / (fmax(fabs(ma), fabs(mb)) + 0.02);
}

int lr__adaptive_next(int have, int want, int hi)
{
    long long next = 2LL * have;
    while (next < want)
        next *= 2;
    return next < hi ? (int)next : hi;
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
