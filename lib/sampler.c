/*
 * sampler.c: sample values as pure functions of (pixel, sample, dim, seed).
 *
 * - random: a hash of all four.
 * - grid: the centres of an nx x ny grid of cells (the paper's unjittered
 *   sampling); which cell a sample index gets is shuffled per pixel and
 *   per dimension pair, so that pixel and lens positions are not
 *   correlated, but every pixel uses the same set of cells.
 * - jittered: the same cells with a random offset inside each.
 * - sobol: the first two dimensions of Sobol's (0,2)-sequence for each
 *   dimension pair, Owen-scrambled with Burley's hash-based nested uniform
 *   scrambling and with the sample index shuffled the same way
 *   ("Practical Hash-based Owen Scrambling", JCGT 9(4), 2020).  Every
 *   power-of-two prefix of a pixel's samples is a (0,m,2)-net.
 */
#include "sampler.h"

#include <math.h>

void lr__sampler_init(lr__sampler *s, lr_sampler_kind kind, uint64_t seed,
                      int spp)
{
    s->kind = kind;
    s->seed = seed;
    s->spp = spp > 0 ? (uint32_t)spp : 1;
    /* The most square grid with at least spp cells. */
    uint32_t nx = (uint32_t)ceil(sqrt((double)s->spp));
    s->nx = nx;
    s->ny = (s->spp + nx - 1) / nx;
}

/* SplitMix64's output function (Steele, Lea & Flood 2014): a bijection on
 * 64-bit words with full avalanche. */
uint64_t lr__mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static uint64_t hash4(uint64_t seed, uint64_t pixel, uint64_t sample,
                      uint64_t dim)
{
    uint64_t h = lr__mix64(seed + 0x9e3779b97f4a7c15ull);
    h = lr__mix64(h ^ pixel);
    h = lr__mix64(h ^ (sample << 16) ^ dim);
    return h;
}

/* The top 53 bits as a double in [0, 1). */
static double to_unit(uint64_t h) { return (double)(h >> 11) * 0x1p-53; }

uint32_t lr__permute(uint32_t i, uint32_t l, uint32_t p)
{
    uint32_t w = l - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    /* Cycle-walking: a bijection on [0, w] applied until it lands in
     * [0, l). */
    do {
        i ^= p;
        i *= 0xe170893du;
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i *= 0x0929eb3fu;
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i *= 1u | p >> 27;
        i *= 0x6935fa69u;
        i ^= (i & w) >> 11;
        i *= 0x74dcb303u;
        i ^= (i & w) >> 2;
        i *= 0x9e501cc3u;
        i ^= (i & w) >> 2;
        i *= 0xc860a3dfu;
        i &= w;
        i ^= i >> 5;
    } while (i >= l);
    return (i + p) % l;
}

/* ---- Sobol ------------------------------------------------------------ */

static uint32_t reverse_bits(uint32_t x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* Sobol's second dimension, as a 32-bit binary fraction: its generator
 * matrix is Pascal's triangle mod 2 (Kollig & Keller 2002). */
static uint32_t sobol2(uint32_t i)
{
    uint32_t r = 0;
    for (uint32_t v = 1u << 31; i != 0; i >>= 1, v ^= v >> 1)
        if (i & 1u)
            r ^= v;
    return r;
}

/* Laine & Karras' permutation with Burley's constants: output bit k
 * depends only on input bits 0..k, so applied to bit-reversed values it
 * is a nested uniform (Owen) scramble. */
static uint32_t lk_permute(uint32_t x, uint32_t seed)
{
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

static uint32_t owen(uint32_t x, uint32_t seed)
{
    return reverse_bits(lk_permute(reverse_bits(x), seed));
}

static void sobol_2d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                     uint32_t dim, double out[2])
{
    uint64_t h = hash4(s->seed, pixel, 0xffffffffu, dim);
    uint32_t idx = owen(sample, (uint32_t)h);
    uint32_t x = owen(reverse_bits(idx), (uint32_t)(h >> 32));
    uint32_t y = owen(sobol2(idx), (uint32_t)lr__mix64(h));
    out[0] = x * 0x1p-32;
    out[1] = y * 0x1p-32;
}

/* ---- the public face -------------------------------------------------- */

double lr__sample_1d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                     uint32_t dim)
{
    switch (s->kind) {
    case LR_SAMPLER_GRID:
    case LR_SAMPLER_JITTERED: {
        uint32_t key = (uint32_t)hash4(s->seed, pixel, 0xfffffffeu, dim);
        uint32_t cell = lr__permute(sample % s->spp, s->spp, key);
        double off = s->kind == LR_SAMPLER_GRID
                         ? 0.5
                         : to_unit(hash4(s->seed, pixel, sample, dim));
        return (cell + off) / s->spp;
    }
    case LR_SAMPLER_SOBOL: {
        uint64_t h = hash4(s->seed, pixel, 0xffffffffu, dim);
        uint32_t idx = owen(sample, (uint32_t)h);
        return owen(reverse_bits(idx), (uint32_t)(h >> 32)) * 0x1p-32;
    }
    case LR_SAMPLER_RANDOM:
    default:
        return to_unit(hash4(s->seed, pixel, sample, dim));
    }
}

void lr__sample_2d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                   uint32_t dim, double out[2])
{
    switch (s->kind) {
    case LR_SAMPLER_GRID:
    case LR_SAMPLER_JITTERED: {
        uint32_t cells = s->nx * s->ny;
        uint32_t key = (uint32_t)hash4(s->seed, pixel, 0xfffffffeu, dim);
        uint32_t c = lr__permute(sample % s->spp, cells, key);
        double ox = 0.5, oy = 0.5;
        if (s->kind == LR_SAMPLER_JITTERED) {
            ox = to_unit(hash4(s->seed, pixel, sample, dim));
            oy = to_unit(hash4(s->seed, pixel, sample, dim + 1));
        }
        out[0] = ((c % s->nx) + ox) / s->nx;
        out[1] = ((c / s->nx) + oy) / s->ny;
        return;
    }
    case LR_SAMPLER_SOBOL:
        sobol_2d(s, pixel, sample, dim, out);
        return;
    case LR_SAMPLER_RANDOM:
    default:
        out[0] = to_unit(hash4(s->seed, pixel, sample, dim));
        out[1] = to_unit(hash4(s->seed, pixel, sample, dim + 1));
        return;
    }
}
