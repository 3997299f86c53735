/*
 * film.h: per-pixel accumulation.  Sums are kept in double, so that a
 * million samples of a constant average back to exactly that constant,
 * and samples that are NaN or infinite are dropped (counted as black) and
 * counted rather than poisoning the pixel.
 */
#ifndef LR_FILM_H
#define LR_FILM_H

#include "util/vec.h"

#include <stdint.h>

typedef struct lr__pixel {
    double sum[3];    /* sum of radiance, per channel */
    double sum2[3];   /* sum of squares, per channel (adaptive sampling) */
    uint64_t n;       /* samples added, dropped ones included */
    uint64_t dropped; /* samples rejected as non-finite */
} lr__pixel;

/* Samples first .. last-1 of pixel (x, y), to be added to *acc: what
 * adaptive sampling asks of the sampler, one pixel's round at a time. */
typedef struct lr__span {
    int x, y, first, last;
    lr__pixel *acc;
} lr__span;

static inline void lr__pixel_reset(lr__pixel *p)
{
    p->sum[0] = p->sum[1] = p->sum[2] = 0.0;
    p->sum2[0] = p->sum2[1] = p->sum2[2] = 0.0;
    p->n = p->dropped = 0;
}

/* Adds one sample of weight 1 (a box filter over the pixel). */
void lr__pixel_add(lr__pixel *p, lr__v3 L);
/* lr__pixel_add of L[0], ..., L[n-1], in that order. */
void lr__pixel_add_n(lr__pixel *p, const lr__v3 *L, int n);
/* The same for a packet's samples kept per channel: sample i is
 * (L[0][i], L[1][i], L[2][i]), samples 0 .. n-1 (n <= 16) added in that
 * order, to the same bits as lr__pixel_add_n.  With squares 0 the sums of
 * squares are left as they are: for a caller whose pixels nobody judges
 * by their spread (adaptive sampling off). */
void lr__pixel_add16(lr__pixel *p, const double L[3][16], int n, int squares);

/* The pixel's value: the mean over all samples taken (a dropped sample
 * counts as black, which keeps the estimate unbiased when drops are
 * rare), as three finite floats. */
void lr__pixel_resolve(const lr__pixel *p, float out[3]);

#endif
