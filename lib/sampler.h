/*
 * sampler.h: the numbers behind every random decision.  A sample value is
 * a pure function of (pixel, sample index, dimension, seed), so any pixel
 * sample can be replayed alone and output does not depend on threads,
 * tiles or regions.  The sampler knows nothing of lenses or films.
 */
#ifndef LR_SAMPLER_H
#define LR_SAMPLER_H

#include "internal.h"

#include <stdint.h>

typedef struct lr__sampler {
    lr_sampler_kind kind;
    uint64_t seed;
    int spp;
} lr__sampler;

/* Dimensions in use; later effects append theirs. */
enum { LR__DIM_PIXEL = 0 /* and 1 */, LR__DIM_COUNT = 2 };

void lr__sampler_init(lr__sampler *s, lr_sampler_kind kind, uint64_t seed,
                      int spp);

/* A number in [0, 1) for (pixel, sample, dim). */
double lr__sample_1d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                     uint32_t dim);
/* A point in [0, 1)^2 from dimensions dim and dim + 1. */
void lr__sample_2d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                   uint32_t dim, double out[2]);

/* The 64-bit mixing function behind the hashes (SplitMix64's finaliser). */
uint64_t lr__mix64(uint64_t z);

#endif
