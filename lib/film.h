/*
 * film.h: per-pixel accumulation.  Sums are kept in double, so that a
 * million samples of a constant average back to exactly that constant,
 * and samples that are NaN or infinite are dropped (counted as black) and
 * counted rather than poisoning the pixel.  Each channel keeps a weighted
 * sum and the sum of its weights: ordinary samples weigh 1; spectral
 * samples weigh by the colour-matching functions, so that the pixel is
 * a ratio estimate that keeps white exactly white.
 */
#ifndef LR_FILM_H
#define LR_FILM_H

#include "vec.h"

#include <stdint.h>

typedef struct lr__pixel {
    double sum[3];    /* sum of weight * radiance, per channel */
    double wsum[3];   /* sum of weights, per channel */
    uint64_t n;       /* samples added */
    uint64_t dropped; /* samples rejected as non-finite */
} lr__pixel;

static inline void lr__pixel_reset(lr__pixel *p)
{
    for (int c = 0; c < 3; c++)
        p->sum[c] = p->wsum[c] = 0.0;
    p->n = p->dropped = 0;
}

/* Adds one sample of weight 1 (a box filter over the pixel). */
void lr__pixel_add(lr__pixel *p, lr__v3 L);

/* Adds one sample as a weighted sum `num` = sum of w L and its weights
 * `den` = sum of w, per channel. */
void lr__pixel_add_weighted(lr__pixel *p, lr__v3 num, lr__v3 den);

/* The pixel's value, sum / wsum per channel, as three finite floats. */
void lr__pixel_resolve(const lr__pixel *p, float out[3]);

#endif
