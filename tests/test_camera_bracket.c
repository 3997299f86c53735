/*
 * test_camera_bracket.c: the paper's bracket (lib/camera/camera_bracket.c)
 * against its geometry: the square blur's size, and each channel's focal
 * plane with the paper's chromatic focal lengths (point_scene.h).
 */
#include "test.h"
#include "point_scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The paper's bracket: a square of side
 * S = a |1 - (Z - di) / f| f_px / Z; second moment S^2 / 6. */
static void test_bracket_blur(void **state)
{
    (void)state;
    const double a = 0.2, di = 1.0, f = 5.0;
    for (int i = 0; i < 4; i++) {
        double z = depths[i];
        char json[2048];
        point_scene(json, sizeof json, z, 128, "sobol");
        lr_image *pin = lr_test_render(json, NULL, 0, NULL);
        const char *sets[] = {"camera.model=bracket", "camera.aperture=0.2",
                              "camera.image_plane_distance=1",
                              "camera.focal_length=5"};
        lr_image *blur = lr_test_render(json, sets, 4, NULL);
        double want = a * fabs(1.0 - (z - di) / f) * f_px() / z;
        check_close(
            diameter(measure(blur, 1).m2 - measure(pin, 1).m2, 1.0 / 6.0), want,
            0.05, "bracket blur side", z);
        lr_image_free(pin);
        lr_image_free(blur);
    }
}

/* The bracket with the paper's f_c = f_g n_g / n_c: each channel's focal
 * plane sits at di + f_c. */
static void test_chromatic_bracket_paper(void **state)
{
    (void)state;
    const double n_g = 1.51534, n_r = n_g + 50 * (1.50917 - n_g),
                 n_b = n_g + 50 * (1.51690 - n_g);
    const double di = 1, f = 5, a = 0.4;
    double fr = f * n_g / n_r, fb = f * n_g / n_b;
    assert_true(fb < f && f < fr); /* blue nearest */
    double z = di + fr;            /* red in focus here */
    char json[2048];
    point_scene(json, sizeof json, z, 128, "sobol");
    const char *sets[] = {
        "camera.model=bracket", "camera.aperture=0.4", "camera.focal_length=5",
        "camera.chromatic={\"mode\": \"rgb\", \"amplify\": 50}"};
    lr_image *pin = lr_test_render(json, NULL, 0, NULL);
    lr_image *img = lr_test_render(json, sets, 4, NULL);
    assert_true(measure(img, 0).m2 - measure(pin, 0).m2 < 0.3);
    const double fc[3] = {fr, f, fb};
    for (int c = 1; c < 3; c++) {
        double want = a * fabs(1.0 - (z - di) / fc[c]) * f_px() / z;
        check_close(
            diameter(measure(img, c).m2 - measure(pin, c).m2, 1.0 / 6.0), want,
            0.05, c == 1 ? "bracket green" : "bracket blue", z);
    }
    lr_image_free(pin);
    lr_image_free(img);
}

/* With aperture 0 the bracket is the pinhole, bit for bit, whatever
 * the image plane's distance: also for a light nearer than the plane,
 * which the light side (on by default; and the light integrator) traced
 * from the image plane and lost (an independent check: 0 against the
 * pinhole's 0.041). */
static void test_bracket_zero_aperture_is_pinhole(void **state)
{
    (void)state;
    const char *scene =
        "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
        "  \"fov\": 40},"
        " \"render\": {\"width\": 64, \"height\": 48, \"spp\": 16},"
        " \"background\": 0,"
        " \"materials\": {\"l\": {\"emission\": 100}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0.5, 0.2, "
        "-20], \"radius\": 0.02, \"material\": \"l\"}]}";
    const char *integrators[3] = {"render.integrator=whitted",
                                  "render.integrator=path",
                                  "render.integrator=light"};
    for (int k = 0; k < 3; k++) {
        const char *pin_sets[] = {integrators[k]};
        const char *br_sets[] = {integrators[k], "camera.model=bracket",
                                 "camera.aperture=0",
                                 "camera.image_plane_distance=30"};
        lr_image *pin = lr_test_render(scene, pin_sets, 1, NULL);
        lr_image *br = lr_test_render(scene, br_sets, 4, NULL);
        size_t n = 3 * (size_t)64 * 48;
        double sum = 0.0;
        for (size_t i = 0; i < n; i++)
            sum += pin->rgb[i];
        assert_true(sum > 0.0);
        if (memcmp(pin->rgb, br->rgb, n * sizeof(float)) != 0)
            fail_msg("%s: the bracket with aperture 0 is not the pinhole",
                     integrators[k]);
        lr_image_free(pin);
        lr_image_free(br);
    }
}

static const struct CMUnitTest camera_bracket_tests[] = {
    cmocka_unit_test(test_bracket_blur),
    cmocka_unit_test(test_chromatic_bracket_paper),
    cmocka_unit_test(test_bracket_zero_aperture_is_pinhole),
};

LR_TEST_GROUP(camera_bracket, camera_bracket_tests)
