/*
 * test_inspect.c: lr_camera_autofocus and lr_render_plan_map (inspect.c),
 * what the daemon's page shows.  The focus they report is checked against
 * geometry worked out by hand, the map against the render's own counts,
 * and a render of the resolved camera against one of focus_on.
 */
#include "test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A wall facing the camera at z = -8, in focus, with a blurred sphere in
 * front of its left half; 64 x 48, 30 degrees. */
static const char *wall_scene =
    "{\"render\": {\"width\": 64, \"height\": 48, \"spp\": 4, \"max_depth\": "
    "0},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 0],"
    "  \"look_at\": [0, 0, -1], \"fov\": 30, \"aperture_radius\": 0.2,"
    "  \"focus_distance\": 8},"
    " \"materials\": {\"w\": {\"diffuse\": 0.8}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [0, 0, -8], \"normal\": [0, 0, 1],"
    "   \"material\": \"w\"},"
    "  {\"type\": \"sphere\", \"center\": [-1, 0, -4], \"radius\": 0.5,"
    "   \"material\": \"w\"}]}";

static void test_autofocus_on_the_wall(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(wall_scene);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    /* The wall is perpendicular to the view axis: every pixel that sees
     * it sees it at view-axis depth 8. */
    cam.focus_distance = 3;
    cam.focus_on[0] = 60, cam.focus_on[1] = 40;
    lr_camera resolved = cam;
    lr_error err;
    assert_int_equal(lr_camera_autofocus(s, &resolved, 64, 48, &err), LR_OK);
    assert_true(fabs(resolved.focus_distance - 8.0) < 1e-9);
    assert_int_equal(resolved.focus_on[0], -1);
    /* Rendering the resolved camera is rendering focus_on. */
    lr_image *a = lr_test_render_with(s, &cam, &rs, "focus_on");
    lr_image *b = lr_test_render_with(s, &resolved, &rs, "resolved");
    lr_test_assert_same_bytes(a, b, "focus_on against its resolution");
    lr_image_free(a);
    lr_image_free(b);

    /* Outside the frame: an error naming the field, the camera as it was. */
    lr_camera out = cam;
    out.focus_on[0] = 64;
    assert_int_equal(lr_camera_autofocus(s, &out, 64, 48, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.focus_on");
    assert_int_equal(out.focus_on[0], 64);
    assert_true(out.focus_distance == cam.focus_distance);
    lr_scene_free(s);
}

static void test_plan_map_is_the_render_plan(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(wall_scene);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    unsigned char *cells = NULL;
    int cols = 0, rows = 0;
    lr_error err;
    assert_int_equal(
        lr_render_plan_map(s, &cam, &rs, &cells, &cols, &rows, &err), LR_OK);
    assert_int_equal(cols, 4);
    assert_int_equal(rows, 3);
    /* Its lens blocks hold exactly the pixels the render counts as
     * having sampled the lens. */
    uint64_t lens = 0;
    for (int i = 0; i < cols * rows; i++)
        lens += (cells[i] & LR_PLAN_LENS) ? 16 * 16 : 0;
    lr_free(cells);
    lr_image *img = NULL;
    lr_render_stats st;
    assert_int_equal(lr_render(s, &cam, &rs, &img, &st, &err), LR_OK);
    lr_image_free(img);
    print_message("plan map: %llu lens pixels; the render: %llu\n",
                  (unsigned long long)lens, (unsigned long long)st.lens_pixels);
    assert_true(lens == st.lens_pixels);
    assert_true(lens > 0 && lens < 64 * 48);

    /* Without planning every block is the full simulation; a pinhole has
     * no lens anywhere. */
    rs.plan = 0;
    assert_int_equal(
        lr_render_plan_map(s, &cam, &rs, &cells, &cols, &rows, &err), LR_OK);
    for (int i = 0; i < cols * rows; i++)
        assert_true(cells[i] & LR_PLAN_LENS);
    lr_free(cells);
    cam.model = LR_CAMERA_PINHOLE;
    rs.plan = 1;
    assert_int_equal(
        lr_render_plan_map(s, &cam, &rs, &cells, &cols, &rows, &err), LR_OK);
    for (int i = 0; i < cols * rows; i++)
        assert_int_equal(cells[i], 0);
    lr_free(cells);
    /* Bad settings are refused, naming the field. */
    rs.spp = 0;
    assert_int_equal(
        lr_render_plan_map(s, &cam, &rs, &cells, &cols, &rows, &err),
        LR_ERR_INVALID);
    assert_string_equal(err.path, "render.spp");
    lr_scene_free(s);
}

static const struct CMUnitTest inspect_tests[] = {
    cmocka_unit_test(test_autofocus_on_the_wall),
    cmocka_unit_test(test_plan_map_is_the_render_plan),
};
LR_TEST_GROUP(inspect, inspect_tests)
