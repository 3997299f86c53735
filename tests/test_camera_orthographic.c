/*
 * test_camera_orthographic.c: the orthographic camera
 * (lib/camera/camera_orthographic.c) against the parallel projection's
 * geometry, and its key in the model's own parameter block.
 */
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define SIDE 128

/* A sphere of radius r at (x, y, -z), lit evenly (ambient 1, albedo 1,
 * no bounces: a covered pixel reads 1), seen by an orthographic camera
 * at the origin looking down -z with a view vh tall. */
static lr_image *sphere(double x, double y, double z, double r, double vh,
                        int depth)
{
    char json[1024], set[64];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": 64,"
             "  \"max_depth\": 0, \"adaptive\": false, \"depth\": %s},"
             " \"camera\": {\"model\": \"orthographic\", \"position\": [0, 0, "
             "0], \"look_at\": [0, 0, -1]},"
             " \"materials\": {\"w\": {\"diffuse\": 1}},"
             " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [%.17g, %.17g, "
             "%.17g], \"radius\": %.17g, \"material\": \"w\"}]}",
             SIDE, SIDE, depth ? "true" : "false", x, y, -z, r);
    snprintf(set, sizeof set, "camera.view_height=%.17g", vh);
    const char *sets[] = {set};
    return lr_test_render(json, sets, 1, NULL);
}

/* Covered area (pixels) and its centroid. */
static void coverage(const lr_image *img, double *area, double *cx, double *cy)
{
    const float *p = lr_image_rgb(img);
    *area = *cx = *cy = 0.0;
    for (int y = 0; y < SIDE; y++)
        for (int x = 0; x < SIDE; x++) {
            double v = p[3 * (y * SIDE + x) + 1];
            *area += v, *cx += v * (x + 0.5), *cy += v * (y + 0.5);
        }
    *cx /= *area, *cy /= *area;
}

/* A parallel projection keeps size and place at any distance: a sphere of
 * radius r shows as a disc of radius r SIDE / vh pixels, centred where its
 * centre's (x, y) falls in the view, at depth 3 and at depth 300 alike. */
static void test_ortho_size_and_place(void **state)
{
    (void)state;
    const double r = 0.5, vh = 4.0, x = 1.0, y = 0.5;
    double want = M_PI * pow(r * SIDE / vh, 2.0);
    double wx = (x / vh + 0.5) * SIDE, wy = (0.5 - y / vh) * SIDE;
    double zs[2] = {3.0, 300.0};
    for (int i = 0; i < 2; i++) {
        lr_image *img = sphere(x, y, zs[i], r, vh, 0);
        double a, cx, cy;
        coverage(img, &a, &cx, &cy);
        printf("depth %g: area %.1f (want %.1f), centroid (%.3f, %.3f) "
               "(want (%.3f, %.3f))\n",
               zs[i], a, want, cx, cy, wx, wy);
        assert_true(fabs(a - want) < 0.01 * want);
        assert_true(fabs(cx - wx) < 0.05 && fabs(cy - wy) < 0.05);
        lr_image_free(img);
    }
}

/* Every ray runs along the view axis from the eye's plane: the depth at
 * the disc's centre is the distance to the sphere's near pole, z - r. */
static void test_ortho_depth(void **state)
{
    (void)state;
    lr_image *img = sphere(0.0, 0.0, 7.0, 1.0, 4.0, 1);
    const float *d = lr_image_depth(img);
    assert_non_null(d);
    double got = d[(SIDE / 2) * SIDE + SIDE / 2];
    printf("depth at the centre %.6f (want about %.6f)\n", got, 6.0);
    /* The pixel's centre is 1/64 of the view off the axis: the sphere's
     * surface there is within 1e-3 of the pole's depth. */
    assert_true(fabs(got - 6.0) < 2e-3);
    lr_image_free(img);
}

/* view_height lives in the model's block (lr_camera.model_params), not in
 * a named field: it has its default, reads and writes back by name, and a
 * bad value is refused with the key's name. */
static void test_ortho_key(void **state)
{
    (void)state;
    lr_camera *cam = lr_camera_new();
    lr_error err;
    const char *set = "{\"model\": \"orthographic\"}";
    assert_int_equal(lr_camera_apply_json(cam, set, strlen(set), &err), LR_OK);
    char *j = lr_camera_json(cam);
    assert_non_null(strstr(j, "\"view_height\":2"));
    lr_free(j);
    set = "{\"view_height\": 12.5}";
    assert_int_equal(lr_camera_apply_json(cam, set, strlen(set), &err), LR_OK);
    j = lr_camera_json(cam);
    assert_non_null(strstr(j, "\"view_height\":12.5"));
    assert_non_null(strstr(j, "\"model\":\"orthographic\""));
    lr_free(j);
    const char *bad[] = {"{\"view_height\": 0}", "{\"view_height\": -3}",
                         "{\"view_height\": \"wide\"}"};
    for (int i = 0; i < 3; i++) {
        assert_int_equal(
            lr_camera_apply_json(cam, bad[i], strlen(bad[i]), &err),
            LR_ERR_INVALID);
        assert_non_null(strstr(err.message, "view_height"));
    }
    /* A refused value leaves the camera as it was. */
    j = lr_camera_json(cam);
    assert_non_null(strstr(j, "\"view_height\":12.5"));
    lr_free(j);
    lr_camera_free(cam);
}

static const struct CMUnitTest camera_orthographic_tests[] = {
    cmocka_unit_test(test_ortho_size_and_place),
    cmocka_unit_test(test_ortho_depth),
    cmocka_unit_test(test_ortho_key),
};

LR_TEST_GROUP(camera_orthographic, camera_orthographic_tests)
