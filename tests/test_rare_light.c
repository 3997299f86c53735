/*
 * test_rare_light.c: adaptive sampling cannot lose rare light (issue 27).
 * Each scene is built to fool a rule that believes a pixel's pilot: light
 * that each pixel reaches through a small part of its domain (a small
 * light far out of focus, a light smaller than a pixel, a light reflected
 * by a mirror or a glossy metal out of focus).  With the defaults, the
 * image's mean must stay within 1% of the full simulation's (the same
 * seed, plan and adaptive sampling off) at every spp from 64; the rule
 * that believed its pilot kept 5% to 60% of such light.  And the plan's
 * bound on rare light (lr__plan_unseen) must cover every pixel where a
 * converged render finds any light of those sources.
 */
#include "test.h"

#include "render/adaptive.h"
#include "camera/camera.h"
#include "render/plan.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Seven small bright lights far behind the focus of a thin lens, on
 * black: discs about 11 pixels across. */
static const char *night_scene =
    "{\"render\": {\"width\": 96, \"height\": 64},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
    "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.8,"
    "  \"focus_distance\": 10},"
    " \"materials\": {\"a\": {\"emission\": [300, 200, 100]},"
    "   \"b\": {\"emission\": [60, 90, 400]}},"
    " \"objects\": ["
    "  {\"type\": \"sphere\", \"center\": [-14, 6, -40], \"radius\": 0.04, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [-5, -7, -50], \"radius\": 0.05, "
    "\"material\": \"b\"},"
    "  {\"type\": \"sphere\", \"center\": [3, 5, -35], \"radius\": 0.03, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [12, -3, -45], \"radius\": 0.05, "
    "\"material\": \"b\"},"
    "  {\"type\": \"sphere\", \"center\": [20, 9, -60], \"radius\": 0.06, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [-22, -9, -55], \"radius\": 0.05, "
    "\"material\": \"b\"},"
    "  {\"type\": \"sphere\", \"center\": [0, 0, -30], \"radius\": 0.02, "
    "\"material\": \"a\"}]}";

/* Lights smaller than a pixel, in focus, seen by a pinhole: each pixel
 * sample finds one with a probability of about 1%. */
static const char *speck_scene =
    "{\"render\": {\"width\": 64, \"height\": 48},"
    " \"camera\": {\"model\": \"pinhole\", \"position\": [0, 0, 10],"
    "  \"look_at\": [0, 0, 0], \"fov\": 40},"
    " \"background\": 0.02,"
    " \"materials\": {\"a\": {\"emission\": 5000}},"
    " \"objects\": ["
    "  {\"type\": \"sphere\", \"center\": [-1, 1, 0], \"radius\": 0.004, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [1.3, -0.4, 0], \"radius\": 0.004, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [0.2, 0.7, 0], \"radius\": 0.004, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [-2, -1.2, 0], \"radius\": 0.004, "
    "\"material\": \"a\"}]}";

/* A small light seen only in a mirror ball, the ball far out of focus:
 * the light's reflection is a glint that each pixel's lens samples
 * rarely find.  `metal` replaces the mirror with a rough metal plane for
 * the path tracer (sparkles). */
static const char *glint_scene =
    "{\"render\": {\"width\": 80, \"height\": 60},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
    "  \"look_at\": [0, 0, 0], \"fov\": 30, \"aperture_radius\": 0.3,"
    "  \"focus_distance\": 4},"
    " \"materials\": {\"m\": {\"reflect\": 0.9},"
    "   \"l\": {\"emission\": 2000}},"
    " \"objects\": ["
    "  {\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1.5, "
    "\"material\": \"m\"},"
    "  {\"type\": \"sphere\", \"center\": [4, 3, 8], \"radius\": 0.03, "
    "\"material\": \"l\"},"
    "  {\"type\": \"sphere\", \"center\": [-3, 4, 6], \"radius\": 0.03, "
    "\"material\": \"l\"}]}";

static const char *sparkle_scene =
    "{\"render\": {\"width\": 80, \"height\": 60, \"integrator\": \"path\","
    "  \"max_depth\": 3},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 1, 6],"
    "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.15,"
    "  \"focus_distance\": 2},"
    " \"materials\": {\"g\": {\"reflect\": 0.9, \"roughness\": 0.05},"
    "   \"l\": {\"emission\": 3000}},"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": [0, 1, 0],"
    "   \"size\": [20, 20], \"material\": \"g\"},"
    "  {\"type\": \"sphere\", \"center\": [-1, 1.5, -8], \"radius\": 0.03, "
    "\"material\": \"l\"},"
    "  {\"type\": \"sphere\", \"center\": [1.5, 0.8, -6], \"radius\": 0.03, "
    "\"material\": \"l\"},"
    "  {\"type\": \"sphere\", \"center\": [0.3, 2.5, -12], \"radius\": 0.03, "
    "\"material\": \"l\"}]}";

static double image_mean(const lr_image *img)
{
    double sum = 0.0;
    size_t n = lr_test_n_values(img);
    for (size_t i = 0; i < n; i++)
        sum += img->rgb[i];
    return sum / (double)n;
}

/* The defaults' mean against the full simulation's at `spp`, both with
 * render.light = `light` (off: the adaptive rule alone must keep the
 * light the camera finds; on: lights the plan traces from the light
 * side leave the camera). */
static double default_over_full(const char *scene, int spp, int light,
                                const char *what)
{
    char s[64];
    snprintf(s, sizeof s, "render.spp=%d", spp);
    const char *l = light ? "render.light=true" : "render.light=false";
    const char *def_sets[] = {s, l};
    const char *full_sets[] = {s, l, "render.plan=false",
                               "render.adaptive=false"};
    lr_render_stats sd;
    lr_image *def = lr_test_render(scene, def_sets, 2, &sd);
    lr_image *full = lr_test_render(scene, full_sets, 4, NULL);
    double md = image_mean(def), mf = image_mean(full);
    print_message("%s, light side %s, at %d spp: mean %.6g, full "
                  "simulation %.6g (%.4f); %.1f%% of the full samples\n",
                  what, light ? "on" : "off", spp, md, mf, md / mf,
                  100.0 * (double)sd.samples / (double)sd.full_samples);
    lr_image_free(def);
    lr_image_free(full);
    assert_true(mf > 0.0);
    return md / mf;
}

static void keeps_light(const char *scene, const char *what)
{
    static const int spps[] = {64, 256, 1024};
    for (int light = 0; light < 2; light++)
        for (size_t k = 0; k < sizeof spps / sizeof *spps; k++) {
            double r = default_over_full(scene, spps[k], light, what);
            if (!(fabs(r - 1.0) <= 0.01))
                fail_msg("%s at %d spp: the defaults' mean is %.4f of the "
                         "full simulation's (rare light lost or added)",
                         what, spps[k], r);
        }
}

static void test_night_lights_keep_their_light(void **state)
{
    (void)state;
    keeps_light(night_scene, "night lights");
}

static void test_specks_keep_their_light(void **state)
{
    (void)state;
    keeps_light(speck_scene, "sub-pixel lights");
}

static void test_glints_keep_their_light(void **state)
{
    (void)state;
    keeps_light(glint_scene, "mirror glints");
}

static void test_sparkles_keep_their_light(void **state)
{
    (void)state;
    keeps_light(sparkle_scene, "rough-metal sparkles");
}

/* A sun in an environment map: one texel of a 1024 x 512 map (0.006 rad
 * across) at 10^5 over a dim sky, far out of focus of a thin lens
 * focused at 3 units: a disc about 16 pixels across that each pixel's
 * lens samples rarely find. */
static void sun_texel(int x, int y, float rgb[3])
{
    /* Direction (0.1, 0.15, -1): u = atan2(0.1, 1) / 2 pi = 0.0158, v =
     * acos(0.148) / pi = 0.4527: column 15.7, row 231 (envmap.h). */
    int sun = x == 16 && y == 231;
    rgb[0] = rgb[1] = rgb[2] = sun ? 1e5f : 0.01f;
}

static void sun_scene(char *out, size_t cap)
{
    char path[4096];
    lr_test_write_exr("sun.exr", 1024, 512, sun_texel, path, sizeof path);
    snprintf(out, cap,
             "{\"render\": {\"width\": 80, \"height\": 60},"
             " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
             "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.3,"
             "  \"focus_distance\": 3},"
             " \"environment\": {\"file\": \"%s\"}}",
             path);
}

static void test_env_sun_keeps_its_light(void **state)
{
    (void)state;
    char scene[8192];
    sun_scene(scene, sizeof scene);
    keeps_light(scene, "a sun in the environment map");
}

/* The plan's bound covers the light: every pixel that a converged full
 * simulation finds lit (beyond the background) has lr__plan_unseen at
 * least the brightest channel it shows, where the sources are emitters
 * seen directly.  With the mirror and the metal it is at least the
 * light's emission wherever the reflection shows. */
static void check_cover(const char *scene, double floor, double most,
                        const char *what)
{
    lr_scene *s = lr_test_load(scene, NULL, 0);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    rs.spp = 4096;
    rs.plan = 0;
    rs.adaptive = 0;
    /* Every light the camera's (a light of the light side is no source
     * of rare light: test_light_side_lights_are_not_rare). */
    rs.light = 0;
    lr_image *full = lr_test_render_with(s, &cam, &rs, what);
    rs.adaptive = 1; /* the rare-light bound is made for adaptive sampling */
    lr__cam c;
    lr__cam_init(&c, &cam, rs.width, rs.height);
    lr__plan p;
    lr_error err;
    assert_int_equal(
        lr__plan_build(&p, s, &c, &rs, 0, 0, rs.width, rs.height, &err), LR_OK);
    assert_non_null(p.rare);
    int lit = 0, bounded = 0;
    for (int y = 0; y < rs.height; y++)
        for (int x = 0; x < rs.width; x++) {
            const float *v = &full->rgb[3 * ((size_t)y * rs.width + x)];
            double m = fmax(v[0], fmax(v[1], v[2]));
            double u = lr__plan_unseen(&p, x, y);
            bounded += u > floor;
            if (!(m > floor))
                continue;
            lit++;
            if (!(u >= m))
                fail_msg("%s: pixel (%d, %d) shows %g but the plan bounds "
                         "its rare light by %g",
                         what, x, y, m, u);
        }
    print_message("%s: %d lit pixels, %d pixels bounded, of %d\n", what, lit,
                  bounded, rs.width * rs.height);
    assert_true(lit > 0);
    /* It is a bound, not everything: the rest of the frame is left
     * alone.  (An environment map is bounded per 16 x 16 block over the
     * cone of the block's rays, lens spread included: wider.) */
    if (!(bounded <= most * rs.width * rs.height))
        fail_msg("%s: %d of %d pixels bounded", what, bounded,
                 rs.width * rs.height);
    lr__plan_free(&p);
    lr_image_free(full);
    lr_scene_free(s);
}

static void test_unseen_covers_the_light(void **state)
{
    (void)state;
    check_cover(night_scene, 0.0, 0.25, "night lights");
    check_cover(speck_scene, 0.02 + 1e-6, 0.01, "sub-pixel lights");
    char scene[8192];
    sun_scene(scene, sizeof scene);
    check_cover(scene, 0.01 + 1e-6, 0.7, "environment sun");
}

/* A light traced from the light side sends nothing straight into the
 * camera's rays, so it is no source of rare light for them: the night
 * lights' pixels are left to the rule that reads the pilot. */
static void test_light_side_lights_are_not_rare(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load(night_scene, NULL, 0);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    rs.spp = 256;
    lr__cam c;
    lr__cam_init(&c, &cam, rs.width, rs.height);
    lr_error err;
    for (int light = 0; light < 2; light++) {
        rs.light = light;
        lr__plan p;
        assert_int_equal(
            lr__plan_build(&p, s, &c, &rs, 0, 0, rs.width, rs.height, &err),
            LR_OK);
        int bounded = 0;
        for (int y = 0; y < rs.height; y++)
            for (int x = 0; x < rs.width; x++)
                bounded += lr__plan_unseen(&p, x, y) > 0.0;
        if (light) {
            assert_non_null(p.lt);
            assert_int_equal(p.lt->n, 7);
            assert_int_equal(bounded, 0);
        } else {
            assert_null(p.lt);
            assert_true(bounded > 300);
        }
        lr__plan_free(&p);
    }
    lr_scene_free(s);
}

/* No emitter, no bound: such scenes are judged exactly as before. */
static void test_no_emitter_no_bound(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load(
        "{\"camera\": {\"model\": \"thinlens\", \"aperture_radius\": 0.2},"
        " \"materials\": {\"m\": {\"reflect\": 1}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 5, 5],"
        "  \"intensity\": 100}],"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -3],"
        "  \"radius\": 1, \"material\": \"m\"}]}",
        NULL, 0);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    rs.spp = 256;
    lr__cam c;
    lr__cam_init(&c, &cam, rs.width, rs.height);
    lr__plan p;
    lr_error err;
    assert_int_equal(
        lr__plan_build(&p, s, &c, &rs, 0, 0, rs.width, rs.height, &err), LR_OK);
    assert_null(p.rare);
    assert_true(lr__plan_unseen(&p, 3, 3) == 0.0);
    lr__plan_free(&p);
    lr_scene_free(s);
}

/* The rule of three's arithmetic: a pixel that saw black next to light
 * of 100 needs n >= 3 x 100 / (threshold x 0.1); one at the light's own
 * level needs nothing more; no bound, no need. */
static void test_rare_samples_needed(void **state)
{
    (void)state;
    lr__pixel p;
    lr__pixel_reset(&p);
    for (int i = 0; i < 64; i++)
        lr__pixel_add(&p, v3(0.0, 0.0, 0.0));
    assert_int_equal(lr__rare_samples_needed(&p, 0.0, 0.01, 64, 4096), 0);
    /* 3 x 100 / (0.01 x 0.1) = 300000 > hi. */
    assert_int_equal(lr__rare_samples_needed(&p, 100.0, 0.01, 64, 4096), 4096);
    /* 3 x 0.001 / (0.5 x 0.1) = 0.06: the pilot is enough. */
    assert_int_equal(lr__rare_samples_needed(&p, 0.001, 0.5, 64, 4096), 64);
    /* 3 x 0.05 / (0.01 x 0.1) = 150 (151 as the roundings fall). */
    int k = lr__rare_samples_needed(&p, 0.05, 0.01, 64, 4096);
    assert_in_range(k, 150, 151);
    lr__pixel_reset(&p);
    for (int i = 0; i < 64; i++)
        lr__pixel_add(&p, v3(100.0, 100.0, 100.0));
    assert_int_equal(lr__rare_samples_needed(&p, 100.0, 0.01, 64, 4096), 64);
}

static const struct CMUnitTest rare_tests[] = {
    cmocka_unit_test(test_night_lights_keep_their_light),
    cmocka_unit_test(test_specks_keep_their_light),
    cmocka_unit_test(test_glints_keep_their_light),
    cmocka_unit_test(test_sparkles_keep_their_light),
    cmocka_unit_test(test_env_sun_keeps_its_light),
    cmocka_unit_test(test_unseen_covers_the_light),
    cmocka_unit_test(test_light_side_lights_are_not_rare),
    cmocka_unit_test(test_no_emitter_no_bound),
    cmocka_unit_test(test_rare_samples_needed),
};
LR_TEST_GROUP(rare_light, rare_tests)
