/*
 * test_sampler.c: the samplers' defining properties, checked directly:
 * grid = cell centres, jittered = one point per cell, Sobol = (0,m,2)-net
 * for every power-of-two prefix, all = pure functions in [0, 1).
 */
#include "test.h"
#include "sampling/sampler.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void test_permute_is_bijection(void **state)
{
    (void)state;
    const uint32_t sizes[] = {1, 2, 3, 7, 16, 17, 100, 1000};
    for (size_t k = 0; k < 8; k++) {
        uint32_t n = sizes[k];
        unsigned char *seen = calloc(n, 1);
        assert_non_null(seen);
        for (uint32_t i = 0; i < n; i++) {
            uint32_t p = lr__permute(i, n, 0x1234567u + k);
            assert_true(p < n);
            assert_false(seen[p]);
            seen[p] = 1;
        }
        free(seen);
    }
}

static void test_values_in_unit_interval_and_pure(void **state)
{
    (void)state;
    for (int kind = 0; kind <= LR_SAMPLER_SOBOL; kind++) {
        lr__sampler s;
        lr__sampler_init(&s, (lr_sampler_kind)kind, 7, 37);
        for (uint64_t px = 0; px < 50; px++)
            for (uint32_t i = 0; i < 37; i++)
                for (uint32_t d = 0; d < LR__DIM_COUNT; d += 2) {
                    double a[2], b[2];
                    lr__sample_2d(&s, px, i, d, a);
                    lr__sample_2d(&s, px, i, d, b);
                    assert_true(a[0] >= 0 && a[0] < 1 && a[1] >= 0 && a[1] < 1);
                    assert_true(a[0] == b[0] && a[1] == b[1]);
                    double c = lr__sample_1d(&s, px, i, d);
                    assert_true(c >= 0 && c < 1);
                }
    }
}

static int cmp_pt(const void *a, const void *b)
{
    const double *p = a, *q = b;
    if (p[0] != q[0])
        return p[0] < q[0] ? -1 : 1;
    return (p[1] > q[1]) - (p[1] < q[1]);
}

/* The grid sampler uses exactly the cell centres of a k x k grid, in a
 * per-pixel order: the paper's unjittered sampling. */
static void test_grid_is_cell_centres(void **state)
{
    (void)state;
    lr__sampler s;
    lr__sampler_init(&s, LR_SAMPLER_GRID, 3, 16);
    double want[16][2], got[16][2];
    for (int i = 0; i < 16; i++) {
        want[i][0] = (i % 4 + 0.5) / 4;
        want[i][1] = (i / 4 + 0.5) / 4;
    }
    qsort(want, 16, sizeof want[0], cmp_pt);
    double first[2] = {0, 0};
    int differs = 0;
    for (uint64_t px = 0; px < 20; px++) {
        for (uint32_t i = 0; i < 16; i++)
            lr__sample_2d(&s, px, i, LR__DIM_LENS, got[i]);
        if (px == 0)
            memcpy(first, got[0], sizeof first);
        else if (got[0][0] != first[0] || got[0][1] != first[1])
            differs = 1;
        qsort(got, 16, sizeof got[0], cmp_pt);
        assert_memory_equal(want, got, sizeof want);
    }
    /* The order is shuffled per pixel (so pixel and lens positions are
     * not locked together), while the set stays the grid. */
    assert_true(differs);
}

static void test_jittered_one_per_cell(void **state)
{
    (void)state;
    const int spps[] = {16, 64, 12};
    for (int k = 0; k < 3; k++) {
        lr__sampler s;
        lr__sampler_init(&s, LR_SAMPLER_JITTERED, 11, spps[k]);
        int nx = (int)s.nx, ny = (int)s.ny;
        for (uint64_t px = 0; px < 10; px++) {
            int count[64] = {0};
            for (uint32_t i = 0; i < (uint32_t)spps[k]; i++) {
                double u[2];
                lr__sample_2d(&s, px, i, LR__DIM_PIXEL, u);
                int cx = (int)(u[0] * nx), cy = (int)(u[1] * ny);
                count[cy * nx + cx]++;
            }
            for (int c = 0; c < nx * ny; c++)
                assert_true(count[c] <= 1);
            /* 1-D strata too. */
            int c1[64] = {0};
            for (uint32_t i = 0; i < (uint32_t)spps[k]; i++)
                c1[(int)(lr__sample_1d(&s, px, i, LR__DIM_WAVELENGTH) *
                         spps[k])]++;
            for (int c = 0; c < spps[k]; c++)
                assert_int_equal(c1[c], 1);
        }
    }
}

/* A (t,m,2)-net: for every a in 0..m-t, the 2^a x 2^(m-t-a) elementary
 * boxes each hold exactly 2^t of the first 2^m points. */
static int is_net(double (*pts)[2], int m, int t)
{
    int n = 1 << m, cells = 1 << (m - t);
    int *count = calloc((size_t)cells, sizeof *count);
    int ok = 1;
    for (int a = 0; a <= m - t && ok; a++) {
        memset(count, 0, (size_t)cells * sizeof *count);
        int bx = 1 << a, by = 1 << (m - t - a);
        for (int i = 0; i < n; i++) {
            int cx = (int)(pts[i][0] * bx), cy = (int)(pts[i][1] * by);
            if (++count[cy * bx + cx] > (1 << t))
                ok = 0;
        }
    }
    free(count);
    return ok;
}

static void test_sobol_prefixes_are_nets(void **state)
{
    (void)state;
    lr__sampler s;
    lr__sampler_init(&s, LR_SAMPLER_SOBOL, 5, 256);
    static double pts[256][2];
    /* The lens gets Sobol's first two dimensions: a (0,2)-sequence.  The
     * pixel gets the third and fourth, a (t,2)-sequence with t = 2 (their
     * prefixes are (1,m,2)-nets from m = 5 on).  The padding dimensions
     * (4, 5) are again a (0,2)-sequence. */
    const uint32_t dims[3] = {LR__DIM_LENS, LR__DIM_PIXEL, 4};
    const int tval[3] = {0, 2, 0};
    for (uint64_t px = 0; px < 12; px++)
        for (int k = 0; k < 3; k++) {
            for (uint32_t i = 0; i < 256; i++)
                lr__sample_2d(&s, px * 7919, i, dims[k], pts[i]);
            for (int m = tval[k]; m <= 8; m++)
                if (!is_net(pts, m, m >= 5 && tval[k] ? 1 : tval[k]))
                    fail_msg("pixel %llu dims %u: first %d points are not a "
                             "(%d,%d,2)-net",
                             (unsigned long long)px, dims[k], 1 << m, tval[k],
                             m);
            /* Each coordinate alone is stratified: a (0,1)-sequence. */
            for (int m = 0; m <= 8; m++)
                for (int c = 0; c < 2; c++) {
                    int seen[256] = {0}, n = 1 << m;
                    for (int i = 0; i < n; i++)
                        seen[(int)(pts[i][c] * n)]++;
                    for (int b = 0; b < n; b++)
                        assert_int_equal(seen[b], 1);
                }
        }
    /* Different pixels get different (scrambled) points. */
    double a[2], b[2];
    lr__sample_2d(&s, 1, 0, 0, a);
    lr__sample_2d(&s, 2, 0, 0, b);
    assert_true(a[0] != b[0]);
}

/* Sobol's 1-D projection is stratified too: each power-of-two prefix
 * puts one point in each interval of that many. */
static void test_sobol_1d_stratified(void **state)
{
    (void)state;
    lr__sampler s;
    lr__sampler_init(&s, LR_SAMPLER_SOBOL, 9, 64);
    for (uint64_t px = 0; px < 10; px++)
        for (int m = 0; m <= 6; m++) {
            int n = 1 << m, seen[64] = {0};
            for (int i = 0; i < n; i++)
                seen[(int)(lr__sample_1d(&s, px, (uint32_t)i,
                                         LR__DIM_WAVELENGTH) *
                           n)]++;
            for (int c = 0; c < n; c++)
                assert_int_equal(seen[c], 1);
        }
}

/* Random: mean and variance of a uniform variable. */
static void test_random_moments(void **state)
{
    (void)state;
    lr__sampler s;
    lr__sampler_init(&s, LR_SAMPLER_RANDOM, 1, 1);
    double sum = 0, sum2 = 0;
    int n = 200000;
    for (int i = 0; i < n; i++) {
        double u = lr__sample_1d(&s, (uint64_t)i, 0, 3);
        sum += u;
        sum2 += u * u;
    }
    double mean = sum / n, var = sum2 / n - mean * mean;
    assert_true(fabs(mean - 0.5) < 0.005);
    assert_true(fabs(var - 1.0 / 12) < 0.002);
}

/* The fast 4-D call gives exactly the values of the per-pair calls. */
static void test_pixel_lens_matches_2d(void **state)
{
    (void)state;
    for (int kind = 0; kind <= LR_SAMPLER_SOBOL; kind++) {
        lr__sampler s;
        lr__sampler_init(&s, (lr_sampler_kind)kind, 3, 16);
        for (uint64_t px = 0; px < 40; px++)
            for (uint32_t i = 0; i < 16; i++) {
                double a[4], p[2], l[2];
                lr__sample_pixel_lens(&s, px, i, a);
                lr__sample_2d(&s, px, i, LR__DIM_PIXEL, p);
                lr__sample_2d(&s, px, i, LR__DIM_LENS, l);
                assert_true(a[0] == p[0] && a[1] == p[1] && a[2] == l[0] &&
                            a[3] == l[1]);
            }
    }
}

/* The prepared pairs (the path integrator's bounce dimensions) give
 * exactly lr__sample_2d's and lr__sample_1d's values, inside the
 * prepared range and outside it, for every sampler, at small and large
 * sample indices, one at a time and sixteen at once. */
static void test_pairs_match_2d(void **state)
{
    (void)state;
    for (int kind = 0; kind <= LR_SAMPLER_SOBOL; kind++) {
        lr__sampler s;
        lr__sampler_init(&s, (lr_sampler_kind)kind, 5, 64);
        for (uint64_t px = 0; px < 12; px++) {
            lr__pixel_pairs pp;
            lr__pixel_pairs_init(&pp, &s, px, 6, 4);
            for (uint32_t i = 0; i < 300; i += 7) {
                uint32_t smp = i * 1234567u;
                for (uint32_t dim = 4; dim < 20; dim++) {
                    double a[2], b[2];
                    if ((dim & 1u) == 0) {
                        lr__pixel_pairs_get(&pp, smp, dim, a);
                        lr__sample_2d(&s, px, smp, dim, b);
                        assert_true(a[0] == b[0] && a[1] == b[1]);
                    }
                    assert_true(lr__pixel_pairs_get1(&pp, smp, dim) ==
                                lr__sample_1d(&s, px, smp, dim));
                }
            }
            /* Sixteen samples at once (lr__pixel_pairs_get16), from
             * aligned and unaligned first samples, n = 16 and n = 5. */
            for (uint32_t f = 0; f < 5; f++) {
                uint32_t first = f * 987654321u;
                for (uint32_t dim = 4; dim < 20; dim += 2) {
                    double u[2][16];
                    int n = dim == 10 ? 5 : 16;
                    lr__pixel_pairs_get16(&pp, first, n, dim, u);
                    for (int i = 0; i < n; i++) {
                        double b[2];
                        lr__sample_2d(&s, px, first + (uint32_t)i, dim, b);
                        assert_true(u[0][i] == b[0] && u[1][i] == b[1]);
                    }
                }
            }
        }
    }
}

/* The sixteen-lane Sobol call, in every version this CPU can run, gives
 * exactly the values of the one-sample call rounded to float, at small
 * and at large sample indices (all four index bytes in play). */
static void test_get16_matches_get(void **state)
{
    (void)state;
    const int has[4] = {0, 1, __builtin_cpu_supports("avx2"),
                        __builtin_cpu_supports("avx512bw")};
    lr__sampler s;
    lr__sampler_init(&s, LR_SAMPLER_SOBOL, 11, 64);
    /* Aligned starts (multiples of 16, the fast path) and others. */
    static const uint32_t firsts[] = {
        0, 16,          4096, 0x00fffff0u, 0x7ffffff0u, 0xfffffff0u, 4,
        9, 0x12345677u, 8,    12,          5,           0xfffffffcu};
    int versions = 0;
    for (int isa = 1; isa <= 3; isa++) {
        if (!has[isa])
            continue;
        versions++;
        lr__sampler_isa = isa;
        for (uint64_t px = 0; px < 3000; px += 37) {
            lr__pixel_sampler ps;
            lr__pixel_sampler_init(&ps, &s, px * 7919u);
            for (size_t k = 0; k < sizeof firsts / sizeof *firsts; k++) {
                /* All sixteen lanes, and a short run inside a block
                 * (adaptive sampling's small rounds). */
                int n = k % 2 ? 16 : 4;
                float out[4][16];
                lr__pixel_sampler_get16(&ps, firsts[k], n, out);
                for (int i = 0; i < n; i++) {
                    double u[4];
                    lr__pixel_sampler_get(&ps, firsts[k] + (uint32_t)i, u);
                    for (int d = 0; d < 4; d++)
                        if ((float)u[d] != out[d][i]) {
                            lr__sampler_isa = 0;
                            fail_msg("isa %d pixel %llu sample %u dim %d: "
                                     "%.9g against %.9g",
                                     isa, (unsigned long long)px,
                                     firsts[k] + (uint32_t)i, d,
                                     (double)out[d][i], u[d]);
                        }
                }
            }
        }
    }
    lr__sampler_isa = 0;
    print_message("get16 checked in %d versions\n", versions);
    assert_true(versions >= 1);
}

static const struct CMUnitTest sampler_tests[] = {
    cmocka_unit_test(test_get16_matches_get),
    cmocka_unit_test(test_pixel_lens_matches_2d),
    cmocka_unit_test(test_pairs_match_2d),
    cmocka_unit_test(test_permute_is_bijection),
    cmocka_unit_test(test_values_in_unit_interval_and_pure),
    cmocka_unit_test(test_grid_is_cell_centres),
    cmocka_unit_test(test_jittered_one_per_cell),
    cmocka_unit_test(test_sobol_prefixes_are_nets),
    cmocka_unit_test(test_sobol_1d_stratified),
    cmocka_unit_test(test_random_moments),
};
LR_TEST_GROUP(sampler, sampler_tests)
