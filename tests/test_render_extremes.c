/*
 * test_render_extremes.c: every camera and render setting at the ends of
 * its range: focus distance 1e-4 .. 1e6 (focus plane at the lens and behind
 * everything), aperture 0 .. far larger than the scene, fov 0.01 .. 179.999
 * degrees, images 1x1, 1x4096 and 4096x1, spp 1 and 65536.  Each render is
 * checked for finite pixels and depths and for no NaN sample dropped on the
 * way (lr_test_render_json), and where the picture is known, for that
 * picture.  Images are tiny and sample counts low (except where 65536 spp is
 * the point), so the group runs in seconds.
 */
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Thin lens focused from 1e-4 (at the lens) to 1e6 (far behind every
 * object), with every aperture shape and chromatic aberration on; and the
 * bracket's focal length and image plane over the same range. */
static void test_focus_distance_extremes(void **state)
{
    (void)state;
    const double focus[] = {1e-4, 1e-2, 0.5, 7, 1e3, 1e6};
    const char *models[] = {
        "\"model\": \"thinlens\", \"aperture_radius\": 0.3",
        "\"model\": \"thinlens\", \"aperture_radius\": 0.3,"
        " \"aperture_shape\": \"polygon\", \"aperture_blades\": 5,"
        " \"aperture_ratio\": 0.01",
        "\"model\": \"thinlens\", \"f_number\": 1.4, \"focal_length_mm\": 0.05,"
        " \"chromatic\": {\"mode\": \"rgb\", \"amplify\": 50}",
        "\"model\": \"thinlens\", \"aperture_radius\": 0.3,"
        " \"focal_length_mm\": 0.05, \"chromatic\": {\"mode\": \"spectral\","
        " \"focal_model\": \"lensmaker\", \"wavelengths\": 5}"};
    for (size_t m = 0; m < 4; m++)
        for (size_t i = 0; i < 6; i++) {
            char cam[512], json[4096], what[128];
            snprintf(cam, sizeof cam, "%s, %s, \"focus_distance\": %g",
                     LR_TEST_CAM_BASE, models[m], focus[i]);
            lr_test_busy_scene(json, sizeof json, cam,
                               "\"width\": 12, \"height\": 8, \"spp\": 4, "
                               "\"depth\": true");
            snprintf(what, sizeof what, "thin lens %zu, focus %g", m, focus[i]);
            lr_image_free(lr_test_render_json(json, what));
        }
    /* The bracket: image plane from 1e-4 to 1e3, focal length beyond it
     * from 1e-4 to 1e6. */
    const double di[] = {1e-4, 0.5, 1e3};
    for (size_t a = 0; a < 3; a++)
        for (size_t i = 0; i < 6; i++) {
            char cam[512], json[4096], what[128];
            snprintf(cam, sizeof cam,
                     "%s, \"model\": \"bracket\", \"aperture\": 0.2,"
                     " \"image_plane_distance\": %g, \"focal_length\": %g,"
                     " \"chromatic\": {\"mode\": \"rgb\"}",
                     LR_TEST_CAM_BASE, di[a], focus[i]);
            lr_test_busy_scene(json, sizeof json, cam,
                               "\"width\": 12, \"height\": 8, \"spp\": 4");
            snprintf(what, sizeof what, "bracket di %g, f %g", di[a], focus[i]);
            lr_image_free(lr_test_render_json(json, what));
        }
}

/* Apertures from 0 to a million times the scene.  Zero is the pinhole
 * exactly; a huge aperture blurs everything but stays finite, and since
 * every ray still ends on the scene or the background, no pixel can be
 * brighter than the brightest thing a pinhole sees from anywhere, which a
 * generous bound checks. */
static void test_aperture_extremes(void **state)
{
    (void)state;
    char json[4096];
    lr_test_busy_scene(json, sizeof json, LR_TEST_CAM_BASE ", \"fov\": 50",
                       "\"width\": 16, \"height\": 10, \"spp\": 4");
    lr_image *pin = lr_test_render_json(json, "pinhole");
    const double radii[] = {0, 1e-9, 1e-3, 10, 1e3, 1e6};
    for (size_t i = 0; i < 6; i++) {
        char set1[64], what[64];
        snprintf(set1, sizeof set1, "camera.aperture_radius=%g", radii[i]);
        const char *sets[] = {"camera.model=thinlens", set1,
                              "camera.focus_distance=7"};
        snprintf(what, sizeof what, "aperture %g", radii[i]);
        lr_image *img = lr_test_render_sets(json, sets, 3, what);
        if (radii[i] == 0)
            lr_test_assert_same_bytes(pin, img, "aperture 0 vs pinhole");
        const float *p = lr_image_rgb(img);
        for (size_t k = 0; k < lr_test_n_values(img); k++)
            if (!(p[k] >= 0 && p[k] < 50))
                fail_msg("%s: value %g out of range", what, (double)p[k]);
        lr_image_free(img);
    }
    /* The bracket too. */
    const char *bsets[] = {"camera.model=bracket", "camera.aperture=1e6"};
    lr_image_free(lr_test_render_sets(json, bsets, 2, "bracket aperture 1e6"));
    lr_image_free(pin);
}

/* fov from 0.01 to 179.999 degrees.  At 0.01 degrees every pixel of a
 * 5 x 5 image looks at the same point of a sphere (the frame is 0.001
 * units wide there), so they agree to within the shading gradient. */
static void test_fov_extremes(void **state)
{
    (void)state;
    const double fovs[] = {0.01, 0.1, 1, 90, 170, 179, 179.999};
    for (size_t i = 0; i < 7; i++) {
        char json[1024], what[64];
        snprintf(
            json, sizeof json,
            "{\"camera\": {\"position\": [0, 0, 5], \"look_at\": [0, 0, 0],"
            "  \"fov\": %.17g},"
            " \"render\": {\"width\": 5, \"height\": 5, \"spp\": 2,"
            "  \"depth\": true},"
            " \"background\": 0.3,"
            " \"lights\": [{\"type\": \"point\", \"position\": [2, 3, 6],"
            "   \"intensity\": 40}],"
            " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],"
            "   \"radius\": 1}]}",
            fovs[i]);
        snprintf(what, sizeof what, "fov %g", fovs[i]);
        lr_image *img = lr_test_render_json(json, what);
        const float *p = lr_image_rgb(img);
        if (fovs[i] <= 0.01)
            for (int k = 0; k < 25; k++)
                if (fabs(p[3 * k] - p[3 * 12]) > 1e-3 * p[3 * 12])
                    fail_msg("fov 0.01: pixel %d is %g, centre %g", k,
                             (double)p[3 * k], (double)p[3 * 12]);
        /* The centre pixel sees the sphere (depth 4) at any fov. */
        assert_true(fabs(lr_image_depth(img)[12] - 4.0) < 1e-3);
        lr_image_free(img);
    }
    /* The thin lens and the bracket at the extremes. */
    const char *sets[][2] = {
        {"camera.model=thinlens", "camera.aperture_radius=0.5"},
        {"camera.model=bracket", "camera.aperture=0.5"}};
    for (size_t m = 0; m < 2; m++)
        for (size_t i = 0; i < 7; i += 6) {
            char json[1024], fov[64];
            lr_test_busy_scene(json, sizeof json, LR_TEST_CAM_BASE,
                               "\"width\": 6, \"height\": 4, \"spp\": 2");
            snprintf(fov, sizeof fov, "camera.fov=%.17g", fovs[i]);
            const char *all[] = {sets[m][0], sets[m][1], fov};
            lr_image_free(lr_test_render_sets(json, all, 3, fov));
        }
}

/* 1x1, 1x4096 and 4096x1.  A constant background gives exactly the
 * constant; a left-right symmetric scene sampled at pixel centres (grid,
 * 1 spp) gives a mirror-symmetric row even when the horizontal field of
 * view is almost 180 degrees; the tall column likewise top-bottom is not
 * symmetric (a floor), but every pixel is finite and the column is a
 * monotone sweep from sky to floor. */
static void test_image_shapes(void **state)
{
    (void)state;
    lr_image *one = lr_test_render_json(
        "{\"render\": {\"width\": 1, \"height\": 1, \"spp\": 1},"
        " \"background\": [0.25, 0.5, 0.75]}",
        "1x1");
    assert_true(lr_image_rgb(one)[0] == 0.25f && lr_image_rgb(one)[1] == 0.5f &&
                lr_image_rgb(one)[2] == 0.75f);
    lr_image_free(one);

    const char *scene =
        "{\"camera\": {\"position\": [0, 1, 5], \"look_at\": [0, 1, 0],"
        "  \"fov\": %s},"
        " \"render\": {\"width\": %d, \"height\": %d, \"spp\": 1,"
        "  \"sampler\": \"grid\", \"depth\": true},"
        " \"background\": 0.4,"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 6, 2],"
        "   \"intensity\": 80}, {\"type\": \"ambient\", \"radiance\": 0.1}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0]},"
        "  {\"type\": \"sphere\", \"center\": [-2, 1, 0], \"radius\": 1},"
        "  {\"type\": \"sphere\", \"center\": [2, 1, 0], \"radius\": 1}]}";
    char json[2048];
    snprintf(json, sizeof json, scene, "40", 4096, 1);
    lr_image *row = lr_test_render_json(json, "4096x1");
    assert_int_equal(lr_image_width(row), 4096);
    assert_int_equal(lr_image_height(row), 1);
    const float *p = lr_image_rgb(row);
    for (int x = 0; x < 2048; x++)
        for (int c = 0; c < 3; c++) {
            double a = p[3 * x + c], b = p[3 * (4095 - x) + c];
            if (fabs(a - b) > 1e-4 * fabs(a) + 1e-6)
                fail_msg("4096x1 not symmetric at x = %d: %g vs %g", x, a, b);
        }
    lr_image_free(row);

    snprintf(json, sizeof json, scene, "120", 1, 4096);
    lr_image *col = lr_test_render_json(json, "1x4096");
    assert_int_equal(lr_image_width(col), 1);
    assert_int_equal(lr_image_height(col), 4096);
    /* The top row sees the sky, the bottom the floor in front. */
    assert_true(lr_image_rgb(col)[0] == 0.4f);
    assert_true(lr_image_depth(col)[4095] < 2.0f);
    lr_image_free(col);
}

/* spp 1, and 65536 on scenes whose every sample has the same value: the
 * average is exactly the constant, through a lens and with per-colour and
 * spectral tracing too (white light through glass-free optics). */
static void test_spp_extremes(void **state)
{
    (void)state;
    char json[4096];
    lr_test_busy_scene(json, sizeof json, LR_TEST_CAM_BASE,
                       "\"width\": 7, \"height\": 5, \"spp\": 1");
    lr_image_free(lr_test_render_json(json, "spp 1"));

    /* Inside a sphere lit only by ambient light: every ray, from any lens
     * point, sees diffuse x ambient. */
    const char *inside =
        "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
        "  \"model\": \"thinlens\", \"aperture_radius\": 0.5,"
        "  \"focus_distance\": 3, \"focal_length_mm\": 100, %s},"
        " \"render\": {\"width\": 2, \"height\": 1, \"spp\": 65536},"
        " \"materials\": {\"m\": {\"diffuse\": [0.3, 0.6, 0.9]}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 0.5}],"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],"
        "   \"radius\": 10, \"material\": \"m\"}]}";
    const char *chroma[] = {"\"aperture_shape\": \"disk\"",
                            "\"chromatic\": {\"mode\": \"rgb\"}",
                            "\"chromatic\": {\"mode\": \"spectral\"}"};
    for (size_t i = 0; i < 3; i++) {
        char j2[1024];
        snprintf(j2, sizeof j2, inside, chroma[i]);
        lr_image *img = lr_test_render_json(j2, chroma[i]);
        const float *p = lr_image_rgb(img);
        const float want[3] = {0.15f, 0.3f, 0.45f};
        for (int k = 0; k < 6; k++) {
            /* Exact for the monochrome and rgb paths; the spectral path
             * normalises each sample by its own weights, which may move
             * the last bit of a double but not of the float. */
            if (p[k] != want[k % 3])
                fail_msg("%s: 65536 spp of a constant gave %.9g, want %.9g",
                         chroma[i], (double)p[k], (double)want[k % 3]);
        }
        lr_image_free(img);
    }
}

static const struct CMUnitTest render_extremes_tests[] = {
    cmocka_unit_test(test_focus_distance_extremes),
    cmocka_unit_test(test_aperture_extremes),
    cmocka_unit_test(test_fov_extremes),
    cmocka_unit_test(test_image_shapes),
    cmocka_unit_test(test_spp_extremes),
};

LR_TEST_GROUP(render_extremes, render_extremes_tests)
