/*
 * sampler.h: the numbers behind every random decision.  A sample value is
 * a pure function of (pixel, sample index, dimension, seed), so any pixel
 * sample can be replayed alone and output does not depend on threads,
 * tiles or regions.  The sampler knows nothing of lenses or films: the
 * caller names dimensions, and 2-D requests use dimensions dim, dim + 1.
 */
#ifndef LR_SAMPLER_H
#define LR_SAMPLER_H

#include "util/internal.h"

#include <stdint.h>

typedef struct lr__sampler {
    lr_sampler_kind kind;
    uint64_t seed;
    uint32_t spp;
    uint32_t nx, ny; /* strata of 2-D grid/jittered: nx * ny >= spp */
} lr__sampler;

/* The dimensions the renderer uses. */
enum {
    LR__DIM_PIXEL = 0,      /* 2-D: position inside the pixel */
    LR__DIM_LENS = 2,       /* 2-D: position on the aperture */
    LR__DIM_WAVELENGTH = 4, /* 1-D: the sample's wavelength (spectral) */
    LR__DIM_COUNT = 5
};

void lr__sampler_init(lr__sampler *s, lr_sampler_kind kind, uint64_t seed,
                      int spp);

/* 1 when every pixel's samples take the same positions in the pixel
 * (the grid sampler's cell centres), so that nothing varies between
 * pixels but what the lens and the scene add. */
int lr__sampler_fixed_positions(lr_sampler_kind kind);

/* A number in [0, 1) for (pixel, sample, dim). */
double lr__sample_1d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                     uint32_t dim);
/* A point in [0, 1)^2 for dimensions dim and dim + 1, stratified jointly
 * (grid, jittered, sobol) so that the spp points of one pixel cover the
 * square evenly. */
void lr__sample_2d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                   uint32_t dim, double out[2]);

/* The pixel (out[0..1]) and lens (out[2..3]) dimensions of one sample at
 * once: the same values as two lr__sample_2d calls, computed faster. */
void lr__sample_pixel_lens(const lr__sampler *s, uint64_t pixel,
                           uint32_t sample, double out[4]);

/* The same values as lr__sample_pixel_lens for one pixel's samples, with
 * the per-pixel hashing done once: prepare with lr__pixel_sampler_init,
 * then ask for each sample. */
typedef struct lr__pixel_sampler {
    const lr__sampler *s;
    uint64_t pixel;
    uint32_t shuffle;     /* sobol: the index shuffle's seed */
    uint32_t scramble[4]; /* sobol: each dimension's scramble seed */
} lr__pixel_sampler;

void lr__pixel_sampler_init(lr__pixel_sampler *ps, const lr__sampler *s,
                            uint64_t pixel);
void lr__pixel_sampler_get(const lr__pixel_sampler *ps, uint32_t sample,
                           double out[4]);
/* Samples first .. first+n-1 (n <= 16) at once, the same values as n
 * calls of lr__pixel_sampler_get, as floats: out[d][i] is dimension d of
 * sample first + i.  Lanes n..15 are written with unspecified values. */
void lr__pixel_sampler_get16(const lr__pixel_sampler *ps, uint32_t first, int n,
                             float out[4][16]);

/* Padding dimensions (4 and up) in pairs for one pixel, with the
 * per-pixel hashing done once: for the sobol sampler, pair (dim, dim + 1),
 * dim even, is Sobol's first two dimensions under a shuffle and scrambles
 * of its own, and lr__pixel_pairs_get gives exactly lr__sample_2d's
 * values at a fraction of the cost (no hashing per value).  Other
 * samplers, and dimensions outside the prepared range, go to
 * lr__sample_2d.  The path integrator asks for several such pairs per
 * bounce of every sample of a pixel. */
#define LR__PAIRS_MAX 16
typedef struct lr__pixel_pairs {
    const lr__sampler *s;
    uint64_t pixel;
    uint32_t first; /* the first pair's (even) dimension */
    uint32_t n;     /* pairs prepared */
    uint32_t shuffle[LR__PAIRS_MAX];
    uint32_t scramble[LR__PAIRS_MAX][2];
} lr__pixel_pairs;

/* Prepares pairs first, first + 2, ... (n of them, at most
 * LR__PAIRS_MAX; first even and >= LR__DIM_COUNT - 1). */
void lr__pixel_pairs_init(lr__pixel_pairs *pp, const lr__sampler *s,
                          uint64_t pixel, uint32_t first, uint32_t n);
/* lr__sample_2d(s, pixel, sample, dim, out) for the prepared pixel. */
void lr__pixel_pairs_get(const lr__pixel_pairs *pp, uint32_t sample,
                         uint32_t dim, double out[2]);
/* lr__pixel_pairs_get for samples first .. first + n - 1 (n <= 16) at
 * once (dim even): out[j][i] is dimension dim + j of sample first + i;
 * lanes n..15 get unspecified values. */
void lr__pixel_pairs_get16(const lr__pixel_pairs *pp, uint32_t first, int n,
                           uint32_t dim, double out[2][16]);
/* lr__sample_1d(s, pixel, sample, dim) for the prepared pixel (any dim:
 * one coordinate of its pair). */
double lr__pixel_pairs_get1(const lr__pixel_pairs *pp, uint32_t sample,
                            uint32_t dim);

/* Dimension 4 of a sample (LR__DIM_WAVELENGTH), stratified jointly with
 * the pixel and lens dimensions where the sampler can: for sobol, the
 * fifth dimension of the same 5-D Sobol point (so a pixel's samples
 * spread over pixel, lens and wavelength together); for the others,
 * lr__sample_1d's value. */
double lr__pixel_sampler_dim4(const lr__pixel_sampler *ps, uint32_t sample);

/* The 64-bit mixing function behind the hashes (SplitMix64's finaliser). */
uint64_t lr__mix64(uint64_t z);

/* A pseudo-random permutation of [0, n): the image of i, for key `key`
 * (Kensler, "Correlated Multi-Jittered Sampling", 2013). */
uint32_t lr__permute(uint32_t i, uint32_t n, uint32_t key);

/* For tests: which version of lr__pixel_sampler_get16's Sobol path
 * runs: 0 = the best the CPU has (the default), 1 = portable C, 2 = AVX2,
 * 3 = AVX-512 (setting one the CPU lacks is the caller's fault). */
extern int lr__sampler_isa;

#endif
