/*
 * test_determinism.c: the same input gives the same bytes for any thread
 * count and tile size, with a lens, chromatic aberration, every sampler and
 * the depth channel; and a crop is the same pixels as the full frame.
 */
#include "test.h"

#include <stdio.h>
#include <string.h>

/* Same input, same bytes, for any thread count and tile size, with lens,
 * spectral aberration, every sampler and the depth channel, and for a
 * crop. */
static void test_determinism(void **state)
{
    (void)state;
    const char *samplers[] = {"sobol", "jittered", "random", "grid"};
    for (size_t k = 0; k < 4; k++) {
        char cam[512], render[256], json[4096];
        snprintf(cam, sizeof cam,
                 LR_TEST_CAM_BASE
                 ", \"model\": \"thinlens\", \"aperture_radius\": 0.2,"
                 " \"focus_distance\": 6, \"focal_length_mm\": 50,"
                 " \"chromatic\": {\"mode\": \"%s\", \"amplify\": 20}",
                 k % 2 ? "rgb" : "spectral");
        snprintf(render, sizeof render,
                 "\"width\": 23, \"height\": 17, \"spp\": 3, \"depth\": true,"
                 " \"sampler\": \"%s\", \"seed\": %zu",
                 samplers[k], 11 * k);
        lr_test_busy_scene(json, sizeof json, cam, render);
        lr_scene *s = lr_test_load_json(json);
        lr_camera c;
        lr_render_settings rs;
        lr_scene_camera(s, &c);
        lr_scene_settings(s, &rs);
        rs.threads = 1;
        rs.tile_size = 4096;
        lr_image *ref = lr_test_render_with(s, &c, &rs, "reference");
        const int cfg[][2] = {{2, 1}, {3, 5}, {0, 16}, {7, 3}, {2, 4096}};
        for (size_t i = 0; i < 5; i++) {
            rs.threads = cfg[i][0];
            rs.tile_size = cfg[i][1];
            lr_image *img = lr_test_render_with(s, &c, &rs, "threads/tiles");
            lr_test_assert_same_bytes(ref, img, "threads/tiles");
            assert_memory_equal(lr_image_depth(ref), lr_image_depth(img),
                                23 * 17 * sizeof(float));
            lr_image_free(img);
        }
        /* A crop is the same pixels. */
        rs.region[0] = 5, rs.region[1] = 3, rs.region[2] = 19,
        rs.region[3] = 11;
        lr_image *crop = lr_test_render_with(s, &c, &rs, "crop");
        for (int y = 3; y < 11; y++)
            assert_memory_equal(&lr_image_rgb(crop)[3 * (y - 3) * 14],
                                &lr_image_rgb(ref)[3 * (y * 23 + 5)],
                                14 * 3 * sizeof(float));
        lr_image_free(crop);
        lr_image_free(ref);
        lr_scene_free(s);
    }
}

static const struct CMUnitTest determinism_tests[] = {
    cmocka_unit_test(test_determinism),
};

LR_TEST_GROUP(determinism, determinism_tests)
