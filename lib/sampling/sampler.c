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
#include "sampling/sampler.h"

#include <immintrin.h>
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
static double to_unit(uint64_t h)
{
    return (double)(h >> 11) * 0x1p-53;
}

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

/* Direction numbers of Sobol's first five dimensions as 32-bit binary
 * fractions, V[d][k] for bit k of the index.  Dimension 0 is van der
 * Corput's (the identity matrix); the others come from primitive
 * polynomials of degree s with coefficient bits a and initial numbers
 * m_1..m_s (Joe & Kuo, new-joe-kuo-6.21201, dimensions 2 to 5):
 *     x + 1:           s = 1, a = 0, m = 1
 *     x^2 + x + 1:     s = 2, a = 1, m = 1, 3
 *     x^3 + x + 1:     s = 3, a = 1, m = 1, 3, 1
 *     x^3 + x^2 + 1:   s = 3, a = 2, m = 1, 1, 1   (the wavelength's)
 * extended by the recurrence of Bratley & Fox (Algorithm 659). */
static uint32_t sobol_v[5][32];
/* sobol_t[d][b][x]: the XOR of the direction numbers for the set bits of
 * byte value x at byte b of the index, so a point costs four lookups.
 * sobol_rt is the same for the bit-reversed index and gives the
 * bit-reversed point: Owen scrambling works on reversed bits, so the
 * fast path never needs to reverse the index or the point before it. */
static uint32_t sobol_t[5][4][256];
static uint32_t sobol_rt[5][4][256];
/* sobol_rt[d][3] rearranged for sixteen aligned samples (see
 * sobol16_avx512): sobol_rt16[d][lo][hi] = sobol_rt[d][3][lo + 16 hi]. */
static uint32_t sobol_rt16[4][16][16] __attribute__((aligned(64)));
static pthread_once_t sobol_once = PTHREAD_ONCE_INIT;

/* The best version of lr__pixel_sampler_get16's Sobol path this CPU
 * runs (see lr__sampler_isa), chosen once by sobol_init. */
static int sobol_isa;

static void sobol_init(void)
{
    sobol_isa = __builtin_cpu_supports("avx512bw") ? 3
                : __builtin_cpu_supports("avx2")   ? 2
                                                   : 1;
    static const struct {
        unsigned s, a, m[3];
    } poly[4] = {
        {1, 0, {1}}, {2, 1, {1, 3}}, {3, 1, {1, 3, 1}}, {3, 2, {1, 1, 1}}};
    for (int k = 0; k < 32; k++)
        sobol_v[0][k] = 1u << (31 - k);
    for (int d = 1; d < 5; d++) {
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
    for (int d = 0; d < 5; d++)
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
    for (int d = 0; d < 4; d++)
        for (int lo = 0; lo < 16; lo++)
            for (int hi = 0; hi < 16; hi++)
                sobol_rt16[d][lo][hi] = sobol_rt[d][3][lo + 16 * hi];
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
static inline double sobol_unit(uint32_t v)
{
    return (v >> 8) * 0x1p-24;
}

static uint32_t owen(uint32_t x, uint32_t seed)
{
    return reverse_bits(lk_permute(reverse_bits(x), seed));
}

/* Which of Sobol's dimensions each sample dimension (pixel x, y, lens
 * u, v) takes: the lens gets Sobol's first two, which form a
 * (0,2)-sequence, since the lens integral is what depth of field is
 * about; the pixel gets the next two. */
static const int sobol_dim[4] = {2, 3, 0, 1};

/* One Owen-scrambled Sobol coordinate.  Dimensions 0..3 share one index
 * shuffle (a 4-D sequence); from 4 on, each pair of dimensions reuses
 * Sobol's dimensions 0 and 1 with a shuffle of its own (padding). */
static double sobol_1d(const lr__sampler *s, uint64_t pixel, uint32_t sample,
                       uint32_t dim)
{
    uint32_t block = dim < 4 ? 0 : dim / 2;
    int d = dim < 4 ? sobol_dim[dim] : (int)(dim % 2);
    uint64_t shuffle = hash4(s->seed, pixel, 0xffffffffu, block);
    uint32_t idx = owen(sample, (uint32_t)shuffle);
    uint64_t scramble = hash4(s->seed, pixel, 0xfffffffdu, dim);
    return sobol_unit(owen(sobol(idx, d), (uint32_t)scramble));
}

void lr__pixel_pairs_init(lr__pixel_pairs *pp, const lr__sampler *s,
                          uint64_t pixel, uint32_t first, uint32_t n)
{
    pp->s = s;
    pp->pixel = pixel;
    pp->first = first;
    pp->n = 0;
    /* Only the padding pairs have a shuffle of their own. */
    if (s->kind != LR_SAMPLER_SOBOL || first < 4 || (first & 1u))
        return;
    pp->n = n < LR__PAIRS_MAX ? n : LR__PAIRS_MAX;
    for (uint32_t k = 0; k < pp->n; k++) {
        uint32_t dim = first + 2 * k;
        /* sobol_1d's seeds for dim and dim + 1. */
        pp->shuffle[k] = (uint32_t)hash4(s->seed, pixel, 0xffffffffu, dim / 2);
        for (uint32_t j = 0; j < 2; j++)
            pp->scramble[k][j] = (uint32_t)hash4(s->seed, pixel, 0xfffffffdu,
                                                 dim + j);
    }
}

void lr__pixel_pairs_get(const lr__pixel_pairs *pp, uint32_t sample,
                         uint32_t dim, double out[2])
{
    uint32_t k = (dim - pp->first) / 2;
    if (dim < pp->first || k >= pp->n || (dim & 1u)) {
        lr__sample_2d(pp->s, pp->pixel, sample, dim, out);
        return;
    }
    /* As sobol_4d_seeded: r = lk(rev(sample)) is the reversed shuffled
     * index, and each coordinate rev(lk(sobol_rev(r, d))). */
    uint32_t r = lk_permute(reverse_bits(sample), pp->shuffle[k]);
    for (int d = 0; d < 2; d++)
        out[d] = sobol_unit(
            reverse_bits(lk_permute(sobol_rev(r, d), pp->scramble[k][d])));
}

double lr__pixel_pairs_get1(const lr__pixel_pairs *pp, uint32_t sample,
                            uint32_t dim)
{
    uint32_t k = (dim - pp->first) / 2, d = dim & 1u;
    if (dim < pp->first || k >= pp->n)
        return lr__sample_1d(pp->s, pp->pixel, sample, dim);
    uint32_t r = lk_permute(reverse_bits(sample), pp->shuffle[k]);
    return sobol_unit(
        reverse_bits(lk_permute(sobol_rev(r, (int)d), pp->scramble[k][d])));
}

/* reverse_bits without its table, so that a loop of it vectorises. */
static inline uint32_t reverse_bits_arith(uint32_t x)
{
    x = __builtin_bswap32(x);
    x = (x >> 4 & 0x0f0f0f0fu) | (x & 0x0f0f0f0fu) << 4;
    x = (x >> 2 & 0x33333333u) | (x & 0x33333333u) << 2;
    return (x >> 1 & 0x55555555u) | (x & 0x55555555u) << 1;
}

/* lr__pixel_pairs_get for n (<= 16) consecutive samples, as a loop over
 * the lanes that GCC vectorises (gathers for the Sobol table): the
 * integer steps are the same, so each lane's values are the same bits.
 * Only the n lanes asked: at 4 spp a packet holds 4 samples, and all
 * sixteen had made this loop 12% of a render's CPU time (Blender's
 * default scene, bench/blender_cycles.py). */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
pairs16_sobol(const lr__pixel_pairs *pp, uint32_t k, uint32_t first, uint32_t n,
              double out[2][16])
{
    uint32_t shuffle = pp->shuffle[k], s0 = pp->scramble[k][0],
             s1 = pp->scramble[k][1];
    for (uint32_t i = 0; i < n; i++) {
        uint32_t r = lk_permute(reverse_bits_arith(first + i), shuffle);
        /* Sobol's dimension 0 is van der Corput's: sobol_rev(r, 0) = r
         * reversed. */
        uint32_t v0 = reverse_bits_arith(r);
        uint32_t v1 = sobol_rt[1][0][r & 0xffu] ^
                      sobol_rt[1][1][(r >> 8) & 0xffu] ^
                      sobol_rt[1][2][(r >> 16) & 0xffu] ^
                      sobol_rt[1][3][r >> 24];
        out[0][i] = sobol_unit(reverse_bits_arith(lk_permute(v0, s0)));
        out[1][i] = sobol_unit(reverse_bits_arith(lk_permute(v1, s1)));
    }
}

void lr__pixel_pairs_get16(const lr__pixel_pairs *pp, uint32_t first, int n,
                           uint32_t dim, double out[2][16])
{
    uint32_t k = (dim - pp->first) / 2;
    if (dim < pp->first || k >= pp->n || (dim & 1u)) {
        for (uint32_t i = 0; i < (uint32_t)n; i++) {
            double u[2];
            lr__sample_2d(pp->s, pp->pixel, first + i, dim, u);
            out[0][i] = u[0];
            out[1][i] = u[1];
        }
        return;
    }
    pairs16_sobol(pp, k, first, (uint32_t)n, out);
}

/* Pixel and lens dimensions (0..3) in one go: one index shuffle for the
 * 4-D Sobol point.  The seeds depend on the pixel only. */
static void sobol_seeds(const lr__sampler *s, uint64_t pixel, uint32_t *shuffle,
                        uint32_t scramble[4])
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
    uint32_t r = lk_permute(reverse_bits(sample), shuffle);
    for (int dim = 0; dim < 4; dim++)
        out[dim] = sobol_unit(reverse_bits(
            lk_permute(sobol_rev(r, sobol_dim[dim]), scramble[dim])));
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

int lr__sampler_isa = 0;

/* The Sobol path of lr__pixel_sampler_get16 in AVX2, eight lanes at a
 * time: table lookups as gathers, bit reversal as byte shuffles. */
__attribute__((target("avx2"))) static __m256i rev_bits8(__m256i x)
{
    /* Reverse the bytes of each lane, then the bits of each byte by a
     * nibble table. */
    const __m256i bswap = _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8,
                                           15, 14, 13, 12, 3, 2, 1, 0, 7, 6, 5,
                                           4, 11, 10, 9, 8, 15, 14, 13, 12);
    const __m256i nib = _mm256_setr_epi8(
        0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd, 0x3, 0xb,
        0x7, 0xf, 0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd,
        0x3, 0xb, 0x7, 0xf);
    const __m256i lo4 = _mm256_set1_epi8(0x0f);
    x = _mm256_shuffle_epi8(x, bswap);
    __m256i lo = _mm256_shuffle_epi8(nib, _mm256_and_si256(x, lo4));
    __m256i hi = _mm256_shuffle_epi8(
        nib, _mm256_and_si256(_mm256_srli_epi16(x, 4), lo4));
    return _mm256_or_si256(_mm256_slli_epi16(lo, 4), hi);
}

__attribute__((target("avx2"))) static __m256i lk_permute8(__m256i x,
                                                           uint32_t seed)
{
    x = _mm256_add_epi32(x, _mm256_set1_epi32((int)seed));
    x = _mm256_xor_si256(
        x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0x6c50b47cu)));
    x = _mm256_xor_si256(
        x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0xb82f1e52u)));
    x = _mm256_xor_si256(
        x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0xc7afe638u)));
    x = _mm256_xor_si256(
        x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0x8d22f6e6u)));
    return x;
}

__attribute__((target("avx2"))) static void
sobol16_avx2(const lr__pixel_sampler *ps, uint32_t first, int n,
             float out[4][16])
{
    const __m256i ff = _mm256_set1_epi32(0xff);
    const __m256 unit = _mm256_set1_ps(0x1p-24f);
    /* (The second eight lanes only if asked: at 4 spp a packet holds 4
     * samples.) */
    for (int h = 0; h < n; h += 8) {
        __m256i idx = _mm256_add_epi32(
            _mm256_set1_epi32((int)(first + (uint32_t)h)),
            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        __m256i r = lk_permute8(rev_bits8(idx), ps->shuffle);
        __m256i b0 = _mm256_and_si256(r, ff);
        __m256i b1 = _mm256_and_si256(_mm256_srli_epi32(r, 8), ff);
        __m256i b2 = _mm256_and_si256(_mm256_srli_epi32(r, 16), ff);
        __m256i b3 = _mm256_srli_epi32(r, 24);
        for (int d = 0; d < 4; d++) {
            const uint32_t(*t)[256] = sobol_rt[sobol_dim[d]];
            __m256i v = _mm256_xor_si256(
                _mm256_xor_si256(
                    _mm256_i32gather_epi32((const int *)t[0], b0, 4),
                    _mm256_i32gather_epi32((const int *)t[1], b1, 4)),
                _mm256_xor_si256(
                    _mm256_i32gather_epi32((const int *)t[2], b2, 4),
                    _mm256_i32gather_epi32((const int *)t[3], b3, 4)));
            v = rev_bits8(lk_permute8(v, ps->scramble[d]));
            __m256 f = _mm256_cvtepi32_ps(_mm256_srli_epi32(v, 8));
            _mm256_storeu_ps(&out[d][h], _mm256_mul_ps(f, unit));
        }
    }
}

/* The same sixteen lanes at once in AVX-512 (AVX512BW for the byte
 * shuffles). */
__attribute__((target("avx512f,avx512bw"))) static __m512i rev_bits16(__m512i x)
{
    const __m512i bswap = _mm512_set4_epi32(0x0c0d0e0f, 0x08090a0b, 0x04050607,
                                            0x00010203);
    const __m512i nib = _mm512_set4_epi32(0x0f070b03, 0x0d050901, 0x0e060a02,
                                          0x0c040800);
    const __m512i lo4 = _mm512_set1_epi8(0x0f);
    x = _mm512_shuffle_epi8(x, bswap);
    __m512i lo = _mm512_shuffle_epi8(nib, _mm512_and_si512(x, lo4));
    __m512i hi = _mm512_shuffle_epi8(
        nib, _mm512_and_si512(_mm512_srli_epi16(x, 4), lo4));
    return _mm512_or_si512(_mm512_slli_epi16(lo, 4), hi);
}

__attribute__((target("avx512f,avx512bw"))) static __m512i
lk_permute16(__m512i x, uint32_t seed)
{
    x = _mm512_add_epi32(x, _mm512_set1_epi32((int)seed));
    x = _mm512_xor_si512(
        x, _mm512_mullo_epi32(x, _mm512_set1_epi32((int)0x6c50b47cu)));
    x = _mm512_xor_si512(
        x, _mm512_mullo_epi32(x, _mm512_set1_epi32((int)0xb82f1e52u)));
    x = _mm512_xor_si512(
        x, _mm512_mullo_epi32(x, _mm512_set1_epi32((int)0xc7afe638u)));
    x = _mm512_xor_si512(
        x, _mm512_mullo_epi32(x, _mm512_set1_epi32((int)0x8d22f6e6u)));
    return x;
}

__attribute__((target("avx512f,avx512bw"))) static void
sobol16_avx512(const lr__pixel_sampler *ps, uint32_t first, int n,
               float out[4][16])
{
    __m512i idx = _mm512_add_epi32(_mm512_set1_epi32((int)first),
                                   _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8,
                                                     9, 10, 11, 12, 13, 14,
                                                     15));
    __m512i r = lk_permute16(rev_bits16(idx), ps->shuffle);
    const __m512 unit = _mm512_set1_ps(0x1p-24f);
    if ((first & 15u) + (uint32_t)n <= 16) {
        /* Samples within one block 16q .. 16q + 15: their reversed
         * indices differ only in bits 28..31, and the shuffle's output
         * bits 0..27 depend only on its input bits 0..27, so the lanes'
         * r share bits 0..27: three of the four table lookups are
         * common, and the fourth picks one of sixteen entries by r's top
         * nibble: a permute of one row of sobol_rt16, no gathers.  (Lanes
         * past n may leave the block; their values are not asked for.) */
        uint32_t r0 = lk_permute(reverse_bits(first & ~15u), ps->shuffle);
        __m512i hi = _mm512_srli_epi32(r, 28);
        unsigned lo = (r0 >> 24) & 0xfu;
        for (int d = 0; d < 4; d++) {
            const uint32_t(*t)[256] = sobol_rt[sobol_dim[d]];
            uint32_t c = t[0][r0 & 0xffu] ^ t[1][(r0 >> 8) & 0xffu] ^
                         t[2][(r0 >> 16) & 0xffu];
            __m512i row = _mm512_load_si512(sobol_rt16[sobol_dim[d]][lo]);
            __m512i v = _mm512_xor_si512(_mm512_set1_epi32((int)c),
                                         _mm512_permutexvar_epi32(hi, row));
            v = rev_bits16(lk_permute16(v, ps->scramble[d]));
            __m512 f = _mm512_cvtepi32_ps(_mm512_srli_epi32(v, 8));
            _mm512_storeu_ps(out[d], _mm512_mul_ps(f, unit));
        }
        return;
    }
    const __m512i ff = _mm512_set1_epi32(0xff);
    __m512i b0 = _mm512_and_si512(r, ff);
    __m512i b1 = _mm512_and_si512(_mm512_srli_epi32(r, 8), ff);
    __m512i b2 = _mm512_and_si512(_mm512_srli_epi32(r, 16), ff);
    __m512i b3 = _mm512_srli_epi32(r, 24);
    for (int d = 0; d < 4; d++) {
        const uint32_t(*t)[256] = sobol_rt[sobol_dim[d]];
        __m512i v = _mm512_xor_si512(
            _mm512_xor_si512(_mm512_i32gather_epi32(b0, t[0], 4),
                             _mm512_i32gather_epi32(b1, t[1], 4)),
            _mm512_xor_si512(_mm512_i32gather_epi32(b2, t[2], 4),
                             _mm512_i32gather_epi32(b3, t[3], 4)));
        v = rev_bits16(lk_permute16(v, ps->scramble[d]));
        __m512 f = _mm512_cvtepi32_ps(_mm512_srli_epi32(v, 8));
        _mm512_storeu_ps(out[d], _mm512_mul_ps(f, unit));
    }
}

/* The same in portable C, lane by lane. */
static void sobol16_c(const lr__pixel_sampler *ps, uint32_t first, int n,
                      float out[4][16])
{
    for (int i = 0; i < n; i++) {
        uint32_t r = lk_permute(reverse_bits(first + (uint32_t)i), ps->shuffle);
        for (int d = 0; d < 4; d++)
            out[d][i] = (float)(reverse_bits(
                                    lk_permute(sobol_rev(r, sobol_dim[d]),
                                               ps->scramble[d])) >>
                                8) *
                        0x1p-24f;
    }
}

void lr__pixel_sampler_get16(const lr__pixel_sampler *ps, uint32_t first, int n,
                             float out[4][16])
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
    /* At least the n lanes asked (AVX-512 all sixteen, AVX2 eight at a
     * time): the extra ones are harmless.  The three versions give the
     * same bits (integer arithmetic, and an exact conversion to float). */
    int isa = lr__sampler_isa ? lr__sampler_isa : sobol_isa;
    if (isa == 3)
        sobol16_avx512(ps, first, n, out);
    else if (isa == 2)
        sobol16_avx2(ps, first, n, out);
    else
        sobol16_c(ps, first, n, out);
}

void lr__pixel_sampler_get(const lr__pixel_sampler *ps, uint32_t sample,
                           double out[4])
{
    if (ps->s->kind == LR_SAMPLER_SOBOL)
        sobol_4d_seeded(ps->shuffle, ps->scramble, sample, out);
    else
        lr__sample_pixel_lens(ps->s, ps->pixel, sample, out);
}

double lr__pixel_sampler_dim4(const lr__pixel_sampler *ps, uint32_t sample)
{
    const lr__sampler *s = ps->s;
    if (s->kind != LR_SAMPLER_SOBOL)
        return lr__sample_1d(s, ps->pixel, sample, 4);
    /* Sobol's fifth dimension under the index shuffle of the first four
     * (sobol_4d_seeded), with a scramble of its own. */
    uint32_t scramble = (uint32_t)hash4(s->seed, ps->pixel, 0xfffffffdu, 4);
    uint32_t r = lk_permute(reverse_bits(sample), ps->shuffle);
    return sobol_unit(reverse_bits(lk_permute(sobol_rev(r, 4), scramble)));
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

int lr__sampler_fixed_positions(lr_sampler_kind kind)
{
    return kind == LR_SAMPLER_GRID;
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
