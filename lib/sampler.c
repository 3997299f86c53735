/*
 * sampler.c: sample values as pure functions of (pixel, sample, dim, seed).
 */
#include "sampler.h"

void lr__sampler_init(lr__sampler *s, lr_sampler_kind kind, uint64_t seed,
                      int spp)
{
    s->kind = kind;
    s->seed = seed;
    s->spp = spp;
}

/* SplitMix64's output function (Steele, Lea & Flood 2014): a bijection on
 * 64-bit words with full avalanche. */
uint64_t lr__mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static uint64_t hash4(uint64_t seed, uint64_t pixel, uint32_t sample,
                      uint32_t dim)
{
    uint64_t h = lr__mix64(seed + 0x9e3779b97f4a7c15ull);
    h = lr__mix64(h ^ pixel);
    h = lr__mix64(h ^ (((uint64_t)sample << 32) | dim));
    return h;
}

/* The top 53 bits as a double in [0, 1). */
static double to_unit(uint64_t h) { return (double)(h >> 11) * 0x1p-53; }

double lr__sample_1d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                     uint32_t dim)
{
    switch (s->kind) {
    case LR_SAMPLER_RANDOM:
        break;
    }
    return to_unit(hash4(s->seed, pixel, sample, dim));
}

void lr__sample_2d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                   uint32_t dim, double out[2])
{
    out[0] = lr__sample_1d(s, pixel, sample, dim);
    out[1] = lr__sample_1d(s, pixel, sample, dim + 1);
}
