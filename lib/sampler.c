/*
 * sampler.c: sample values as pure functions of (pixel, sample, dim, seed).
 *
 * - random: a hash of all four.
 * - grid: the centres of an nx x ny grid of cells (the paper's unjittered
 *   sampling); which cell a sample index gets is shuffled per pixel and
 *   per dimension pair, so that pixel and lens positions are not
 *   correlated, but (when spp fills the grid, nx * ny = spp) every pixel
 *   uses the same set of cells.
 * - jittered: the same cells with a random offset inside each.
 * - sobol: the first four dimensions of Sobol's sequence (direction
 *   numbers of Joe & Kuo 2008) serve the pixel and lens dimensions
 *   jointly, so that the 4-D (pixel x lens) integral of depth of field is
 *   stratified as a whole; further dimensions are padded with
 *   independently shuffled copies.  Everything is Owen-scrambled with
 *   Burley's hash-based nested uniform scrambling, and the sample index is
 *   shuffled the same way ("Practical Hash-based Owen Scrambling", JCGT
 *   9(4), 2020).  Every power-of-two prefix of a pixel's samples is a
 *   (0,m,2)-net in the lens dimensions and a (1,m,2)-net in the pixel
 *   dimensions.
 */
#include "sampler.h"

#include <math.h>
#include <pthread.h>

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

static uint8_t rev8[256]; /* bit-reversed bytes, filled by sobol_init */

static uint32_t reverse_bits(uint32_t x)
{
    return (uint32_t)rev8[x & 0xffu] << 24 |
           (uint32_t)rev8[(x >> 8) & 0xffu] << 16 |
           (uint32_t)rev8[(x >> 16) & 0xffu] << 8 | rev8[x >> 24];
}

/* Direction numbers of Sobol's first four dimensions as 32-bit binary
 * fractions, V[d][k] for bit k of the index.  Dimension 0 is van der
 * Corput's (the identity matrix); the others come from primitive
 * polynomials of degree s with coefficient bits a and initial numbers
 * m_1..m_s (Joe & Kuo, new-joe-kuo-6.21201, dimensions 2 to 4):
 *     x + 1:           s = 1, a = 0, m = 1
 *     x^2 + x + 1:     s = 2, a = 1, m = 1, 3
 *     x^3 + x + 1:     s = 3, a = 1, m = 1, 3, 1
 * extended by the recurrence of Bratley & Fox (Algorithm 659). */
static uint32_t sobol_v[4][32];
/* sobol_t[d][b][x]: the XOR of the direction numbers for the set bits of
 * byte value x at byte b of the index, so a point costs four lookups.
 * sobol_rt is the same for the bit-reversed index and gives the
 * bit-reversed point: Owen scrambling works on reversed bits, so the
 * fast path never needs to reverse the index or the point before it. */
static uint32_t sobol_t[4][4][256];
static uint32_t sobol_rt[4][4][256];
static pthread_once_t sobol_once = PTHREAD_ONCE_INIT;

static void sobol_init(void)
{
    static const struct {
        unsigned s, a, m[3];
    } poly[3] = {{1, 0, {1}}, {2, 1, {1, 3}}, {3, 1, {1, 3, 1}}};
    for (int k = 0; k < 32; k++)
        sobol_v[0][k] = 1u << (31 - k);
    for (int d = 1; d < 4; d++) {
        unsigned s = poly[d - 1].s, a = poly[d - 1].a;
        uint32_t m[32];
        for (unsigned k = 0; k < 32; k++) {
            if (k < s) {
                m[k] = poly[d - 1].m[k];
            } else {
                /* m_k = m_{k-s} ^ 2^s m_{k-s} ^ sum_i 2^i a_i m_{k-i} */
                uint32_t v = m[k - s] ^ (m[k - s] << s);
                for (unsigned i = 1; i < s; i++)
                    if ((a >> (s - 1 - i)) & 1u)
                        v ^= m[k - i] << i;
                m[k] = v;
            }
            /* v_k = m_k / 2^(k+1), as a 32-bit fraction. */
            sobol_v[d][k] = m[k] << (31 - k);
        }
    }
    for (uint32_t x = 0; x < 256; x++) {
        uint8_t r = 0;
        for (int k = 0; k < 8; k++)
            if (x & (1u << k))
                r |= (uint8_t)(0x80u >> k);
        rev8[x] = r;
    }
    for (int d = 0; d < 4; d++)
        for (int b = 0; b < 4; b++)
            for (uint32_t x = 0; x < 256; x++) {
                uint32_t r = 0, rr = 0;
                for (int k = 0; k < 8; k++)
                    if (x & (1u << k)) {
                        r ^= sobol_v[d][8 * b + k];
                        /* Bit 8b + k of a reversed index is bit
                         * 31 - 8b - k of the index. */
                        rr ^= reverse_bits(sobol_v[d][31 - 8 * b - k]);
                    }
                sobol_t[d][b][x] = r;
                sobol_rt[d][b][x] = rr;
            }
}

/* reverse_bits(sobol(reverse_bits(r), d)), from r's bytes. */
static uint32_t sobol_rev(uint32_t r, int d)
{
    return sobol_rt[d][0][r & 0xffu] ^ sobol_rt[d][1][(r >> 8) & 0xffu] ^
           sobol_rt[d][2][(r >> 16) & 0xffu] ^ sobol_rt[d][3][r >> 24];
}

static uint32_t sobol(uint32_t i, int d)
{
    return sobol_t[d][0][i & 0xffu] ^ sobol_t[d][1][(i >> 8) & 0xffu] ^
           sobol_t[d][2][(i >> 16) & 0xffu] ^ sobol_t[d][3][i >> 24];
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

/* A Sobol value's top 24 bits as a number in [0, 1): exact in float as
 * well as double, so the vectorised float path and the scalar double
 * path agree to the bit (24 bits resolve far finer than any pixel or
 * lens feature). */
static inline double sobol_unit(uint32_t v) { return (v >> 8) * 0x1p-24; }

static uint32_t owen(uint32_t x, uint32_t seed)
{
    return reverse_bits(lk_permute(reverse_bits(x), seed));
}

/* One Owen-scrambled Sobol coordinate.  Dimensions 0..3 share one index
 * shuffle (a 4-D sequence); from 4 on, each pair of dimensions reuses
 * Sobol's dimensions 0 and 1 with a shuffle of its own (padding). */
static double sobol_1d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                       uint32_t dim)
{
    /* The lens dimensions get Sobol's first two, which form a
     * (0,2)-sequence: the lens integral is what depth of field is about.
     * The pixel dimensions get the next two. */
    static const int map[4] = {2, 3, 0, 1};
    uint32_t block = dim < 4 ? 0 : dim / 2;
    int d = dim < 4 ? map[dim] : (int)(dim % 2);
    uint64_t shuffle = hash4(s->seed, pixel, 0xffffffffu, block);
    uint32_t idx = owen(sample, (uint32_t)shuffle);
    uint64_t scramble = hash4(s->seed, pixel, 0xfffffffdu, dim);
    return sobol_unit(owen(sobol(idx, d), (uint32_t)scramble));
}

/* Pixel and lens dimensions (0..3) in one go: one index shuffle for the
 * 4-D Sobol point.  The seeds depend on the pixel only. */
static void sobol_seeds(const lr__sampler *s, uint64_t pixel,
                        uint32_t *shuffle, uint32_t scramble[4])
{
    *shuffle = (uint32_t)hash4(s->seed, pixel, 0xffffffffu, 0);
    for (uint32_t dim = 0; dim < 4; dim++)
        scramble[dim] = (uint32_t)hash4(s->seed, pixel, 0xfffffffdu, dim);
}

static void sobol_4d_seeded(uint32_t shuffle, const uint32_t scramble[4],
                            uint32_t sample, double out[4])
{
    /* owen(x, s) = rev(lk(rev(x), s)), so with r = lk(rev(sample)) the
     * shuffled index is rev(r), and each coordinate is
     * rev(lk(rev(sobol(rev(r))))) = rev(lk(sobol_rev(r))). */
    static const int map[4] = {2, 3, 0, 1};
    uint32_t r = lk_permute(reverse_bits(sample), shuffle);
    for (int dim = 0; dim < 4; dim++)
        out[dim] = sobol_unit(
            reverse_bits(lk_permute(sobol_rev(r, map[dim]), scramble[dim])));
}

static void sobol_4d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                     double out[4])
{
    uint32_t shuffle, scramble[4];
    sobol_seeds(s, pixel, &shuffle, scramble);
    sobol_4d_seeded(shuffle, scramble, sample, out);
}

void lr__pixel_sampler_init(lr__pixel_sampler *ps, const lr__sampler *s,
                            uint64_t pixel)
{
    ps->s = s;
    ps->pixel = pixel;
    if (s->kind == LR_SAMPLER_SOBOL)
        sobol_seeds(s, pixel, &ps->shuffle, ps->scramble);
}

/* reverse_bits by shifts and masks, which vectorises across lanes. */
static inline uint32_t reverse_bits_swar(uint32_t x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* Built twice, for AVX2 (eight 32-bit multiplies at once) and for any
 * x86-64; the loader picks the version the CPU runs.  Both give the same
 * bits: the integer hashing is exact and the float conversion exact. */
__attribute__((target_clones("avx2", "default")))
void lr__pixel_sampler_get16(const lr__pixel_sampler *ps, uint32_t first,
                             int n, float out[4][16])
{
    if (ps->s->kind != LR_SAMPLER_SOBOL) {
        for (int i = 0; i < n; i++) {
            double u[4];
            lr__sample_pixel_lens(ps->s, ps->pixel, first + (uint32_t)i, u);
            for (int d = 0; d < 4; d++)
                out[d][i] = (float)u[d];
        }
        return;
    }
    /* sobol_4d_seeded, lane by lane in loops the compiler can vectorise
     * (only the table lookups stay scalar). */
    static const int map[4] = {2, 3, 0, 1};
    uint32_t r[16], v[16];
    if (n < 8) {
        /* A short run (adaptive sampling's pilot and first rounds): the
         * same arithmetic, for the lanes asked for only. */
        for (int i = 0; i < n; i++) {
            uint32_t ri = lk_permute(reverse_bits_swar(first + (uint32_t)i),
                                     ps->shuffle);
            for (int d = 0; d < 4; d++)
                out[d][i] = (float)(int32_t)(reverse_bits_swar(lk_permute(
                                sobol_rev(ri, map[d]), ps->scramble[d])) >>
                                             8) *
                            0x1p-24f;
        }
        return;
    }
    for (int i = 0; i < 16; i++)
        r[i] = lk_permute(reverse_bits_swar(first + (uint32_t)i),
                          ps->shuffle);
    for (int d = 0; d < 4; d++) {
        for (int i = 0; i < 16; i++)
            v[i] = sobol_rev(r[i], map[d]);
        uint32_t seed = ps->scramble[d];
        for (int i = 0; i < 16; i++)
            out[d][i] = (float)(int32_t)(reverse_bits_swar(
                            lk_permute(v[i], seed)) >> 8) *
                        0x1p-24f;
    }
}

void lr__pixel_sampler_get(const lr__pixel_sampler *ps, uint32_t sample,
                           double out[4])
{
    if (ps->s->kind == LR_SAMPLER_SOBOL)
        sobol_4d_seeded(ps->shuffle, ps->scramble, sample, out);
    else
        lr__sample_pixel_lens(ps->s, ps->pixel, sample, out);
}

/* ---- the public face -------------------------------------------------- */

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
    pthread_once(&sobol_once, sobol_init);
}


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
    case LR_SAMPLER_SOBOL:
        return sobol_1d(s, pixel, sample, dim);
    case LR_SAMPLER_RANDOM:
    default:
        return to_unit(hash4(s->seed, pixel, sample, dim));
    }
}

void lr__sample_pixel_lens(const lr__sampler *s, uint64_t pixel,
                           uint32_t sample, double out[4])
{
    if (s->kind == LR_SAMPLER_SOBOL) {
        sobol_4d(s, pixel, sample, out);
        return;
    }
    lr__sample_2d(s, pixel, sample, LR__DIM_PIXEL, out);
    lr__sample_2d(s, pixel, sample, LR__DIM_LENS, out + 2);
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
        out[0] = sobol_1d(s, pixel, sample, dim);
        out[1] = sobol_1d(s, pixel, sample, dim + 1);
        return;
    case LR_SAMPLER_RANDOM:
    default:
        out[0] = to_unit(hash4(s->seed, pixel, sample, dim));
        out[1] = to_unit(hash4(s->seed, pixel, sample, dim + 1));
        return;
    }
}
