/*
 * test_convergence.c: sampling error against a high-sample reference.
 * Error must fall as samples grow, faster for the stratified samplers
 * than for random ones; and the grid sampler's error must show the
 * periodic structure the paper describes, which jittering removes.
 */
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A defocused scene with edges: a lit sphere in front of the focal plane
 * casting a shadow on a ground plane, through a thin lens. */
static const char *dof_scene =
    "{\"render\": {\"width\": 32, \"height\": 24, \"max_depth\": 0,"
    "  \"plan\": false, \"adaptive\": false},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 1, 4],"
    "  \"look_at\": [0, 0.6, 0], \"fov\": 30, \"aperture_radius\": 0.6,"
    "  \"focus_distance\": 6},"
    " \"background\": [0.6, 0.7, 0.9],"
    " \"materials\": {\"r\": {\"diffuse\": [0.8, 0.2, 0.1]}},"
    " \"lights\": [{\"type\": \"point\", \"position\": [3, 6, 4],"
    "   \"intensity\": 60}],"
    " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0]},"
    "   {\"type\": \"sphere\", \"center\": [0.3, 0.6, 0.5], \"radius\": 0.6,"
    "    \"material\": \"r\"}]}";

/* Least-squares slope of log(err) against log(spp). */
static double slope(const double *spp, const double *err, int n)
{
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int i = 0; i < n; i++) {
        double x = log(spp[i]), y = log(err[i]);
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

static void test_error_falls_faster_when_stratified(void **state)
{
    (void)state;
    const char *ref_sets[] = {"render.spp=16384", "render.sampler=sobol",
                              "render.seed=99"};
    lr_image *ref = lr_test_render(dof_scene, ref_sets, 3, NULL);
    const char *samplers[] = {"random", "jittered", "sobol"};
    const double spps[] = {4, 16, 64, 256};
    double slopes[3];
    for (int k = 0; k < 3; k++) {
        double err[4];
        for (int i = 0; i < 4; i++) {
            /* Average the squared error over a few seeds: one seed's error
             * is itself a random number. */
            double e2 = 0;
            for (int seed = 1; seed <= 3; seed++) {
                char a[64], b[64], c[64];
                snprintf(a, sizeof a, "render.spp=%d", (int)spps[i]);
                snprintf(b, sizeof b, "render.sampler=%s", samplers[k]);
                snprintf(c, sizeof c, "render.seed=%d", seed);
                const char *sets[] = {a, b, c};
                lr_image *img = lr_test_render(dof_scene, sets, 3, NULL);
                double e = lr_test_rmse(img, ref);
                e2 += e * e / 3;
                lr_image_free(img);
            }
            err[i] = sqrt(e2);
            if (i > 0 && !(err[i] < err[i - 1]))
                fail_msg("%s: error %g at %g spp is not below %g at %g spp",
                         samplers[k], err[i], spps[i], err[i - 1], spps[i - 1]);
        }
        slopes[k] = slope(spps, err, 4);
        print_message(
            "%s: RMSE %.4g %.4g %.4g %.4g at 4..256 spp, slope %.3f\n",
            samplers[k], err[0], err[1], err[2], err[3], slopes[k]);
    }
    /* Random converges as N^-0.5; stratification and Owen-scrambled Sobol
     * do better on a scene with edges (about N^-0.75, Mitchell 1996). */
    assert_true(slopes[0] > -0.6 && slopes[0] < -0.4);
    assert_true(slopes[1] < slopes[0] - 0.1);
    assert_true(slopes[2] < slopes[0] - 0.1);
    lr_image_free(ref);
}

/* The paper's grid artifact.  A point light's blur through a grid of
 * k x k lens samples is k x k copies of the point on a lattice, so the
 * error against the true (smooth) blur has a strong Fourier peak at the
 * lattice frequency; jittered samples spread that error into noise. */
static const char *point_scene =
    "{\"render\": {\"width\": 96, \"height\": 96, \"max_depth\": 0,"
    "  \"plan\": false, \"adaptive\": false},"
    " \"camera\": {\"model\": \"bracket\", \"image_plane_distance\": 1,"
    "  \"focal_length\": 5, \"aperture\": 0.5, \"fov\": 20},"
    " \"materials\": {\"w\": {\"diffuse\": 1}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
    " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -2.5],"
    "   \"radius\": 0.008, \"material\": \"w\"}]}";

/* Power of the row-summed error profile at `freq` cycles per pixel,
 * relative to the mean power over all frequencies. */
static double peak_ratio(const lr_image *img, const lr_image *ref, double freq)
{
    int w = lr_image_width(img), h = lr_image_height(img);
    double prof[96];
    for (int x = 0; x < w; x++) {
        prof[x] = 0;
        for (int y = 0; y < h; y++)
            prof[x] += lr_image_rgb(img)[3 * (y * w + x) + 1] -
                       lr_image_rgb(ref)[3 * (y * w + x) + 1];
    }
    double at = 0, mean = 0;
    for (int k = 1; k < w / 2; k++) {
        double re = 0, im = 0;
        for (int x = 0; x < w; x++) {
            re += prof[x] * cos(2 * M_PI * k * x / w);
            im += prof[x] * sin(2 * M_PI * k * x / w);
        }
        double p = re * re + im * im;
        mean += p / (w / 2 - 1);
        if (fabs((double)k / w - freq) < 0.5 / w)
            at = p;
    }
    return at / mean;
}

static void test_grid_artifacts_and_jitter(void **state)
{
    (void)state;
    const char *ref_sets[] = {"render.spp=4096", "render.sampler=sobol"};
    lr_image *ref = lr_test_render(point_scene, ref_sets, 2, NULL);
    const char *grid_sets[] = {"render.spp=16", "render.sampler=grid"};
    const char *jit_sets[] = {"render.spp=16", "render.sampler=jittered"};
    lr_image *grid = lr_test_render(point_scene, grid_sets, 2, NULL);
    lr_image *jit = lr_test_render(point_scene, jit_sets, 2, NULL);
    /* Blur side S = a |1 - (Z - di) / f| f_px / Z; 4 x 4 lens samples put
     * copies S / 4 apart: frequency 4 / S cycles per pixel. */
    double fpx = 96 / (2 * tan(10 * M_PI / 180));
    double S = 0.5 * fabs(1 - 1.5 / 5) * fpx / 2.5;
    double f0 = 4.0 / S;
    double pg = peak_ratio(grid, ref, f0), pj = peak_ratio(jit, ref, f0);
    print_message("lattice frequency %.3f /px: grid peak %.1f x mean, "
                  "jittered %.1f x mean\n",
                  f0, pg, pj);
    assert_true(pg > 5.0);
    assert_true(pj < 3.0);
    assert_true(lr_test_rmse(jit, ref) < lr_test_rmse(grid, ref));
    lr_image_free(ref);
    lr_image_free(grid);
    lr_image_free(jit);
}

static const struct CMUnitTest convergence_tests[] = {
    cmocka_unit_test(test_error_falls_faster_when_stratified),
    cmocka_unit_test(test_grid_artifacts_and_jitter),
};
LR_TEST_GROUP(convergence, convergence_tests)
