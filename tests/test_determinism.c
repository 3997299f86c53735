/*
 * test_determinism.c: the same input gives the same bytes for any thread
 * count and tile size, with a lens, chromatic aberration, every sampler and
 * the depth channel; and a crop is the same pixels as the full frame.
 */
#include "test.h"
#include "render/adaptive.h"

#include <stdio.h>
#include <string.h>
#include <xmmintrin.h>

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

/* With planning and adaptive sampling on, any tile size gives the same
 * frame, and bands of rows (the parts of `lensray render --remote`) are
 * the full frame's rows, also at a band's edge, where adaptive sampling
 * reads the pilots of the row outside the band (which follow the plan of
 * blocks outside the band).  Pixel 3, 144 of this frame differed in the
 * band from 144 and with 16-pixel tiles while adaptive.c compared a
 * pilot with a neighbour's later rounds. */
static void test_bands_plan_adaptive(void **state)
{
    (void)state;
    const char *sets[] = {"render.width=160", "render.height=192",
                          "render.spp=8"};
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(
        lr_scene_load_file("scenes/spheres.json", sets, 3, &s, &err), LR_OK);
    lr_camera c;
    lr_render_settings rs;
    lr_scene_camera(s, &c);
    lr_scene_settings(s, &rs);
    assert_true(rs.plan && rs.adaptive);
    lr_image *full = lr_test_render_with(s, &c, &rs, "full frame");
    /* Tiles of 16 put tile edges where tiles of 32 have none. */
    rs.tile_size = 16;
    lr_image *tiled = lr_test_render_with(s, &c, &rs, "16-pixel tiles");
    lr_test_assert_same_bytes(full, tiled, "16-pixel tiles");
    lr_image_free(tiled);
    const int bands[][2] = {{0, 16}, {128, 144}, {144, 160}, {150, 192}};
    for (size_t b = 0; b < 4; b++) {
        int y0 = bands[b][0], y1 = bands[b][1];
        int region[4] = {0, y0, 160, y1};
        memcpy(rs.region, region, sizeof region);
        lr_image *band = lr_test_render_with(s, &c, &rs, "band");
        for (int y = y0; y < y1; y++)
            assert_memory_equal(&lr_image_rgb(band)[3 * (y - y0) * 160],
                                &lr_image_rgb(full)[3 * y * 160],
                                160 * 3 * sizeof(float));
        lr_image_free(band);
    }
    lr_image_free(full);
    lr_scene_free(s);
}

/* The same bytes whatever the caller's floating-point mode
 * (lib/util/fp_mode.h): a host that sets flush-to-zero, denormals-are-
 * zero and rounding toward zero (Blender's threads set the first two)
 * loads and renders a real lens with light paths and ghosts as a new
 * process does, and gets its own mode back.  Before the guard the lens's
 * set-up ran in the caller's mode (Blender's `blender -b` frame differed
 * from the CLI's in the last bit of 5 values). */
static void test_caller_fp_mode(void **state)
{
    (void)state;
    const char *sets[] = {"render.width=64", "render.height=40", "render.spp=4",
                          "camera.ghosts=true", "camera.coating=\"none\""};
    lr_image *img[2];
    for (int k = 0; k < 2; k++) {
        unsigned mine = _mm_getcsr();
        /* FTZ, DAZ, round toward zero. */
        unsigned host = k ? (mine | 0x8040u | 0x6000u) : mine;
        _mm_setcsr(host);
        lr_scene *s = NULL;
        lr_error err;
        lr_status st = lr_scene_load_file("scenes/night-lens.json", sets, 5, &s,
                                          &err);
        lr_camera c;
        lr_render_settings rs;
        if (st == LR_OK) {
            lr_scene_camera(s, &c);
            lr_scene_settings(s, &rs);
        }
        img[k] = st == LR_OK ? lr_test_render_with(s, &c, &rs, "mode") : NULL;
        unsigned after = _mm_getcsr();
        _mm_setcsr(mine);
        assert_int_equal(st, LR_OK);
        assert_int_equal(after, host);
        lr_scene_free(s);
    }
    lr_test_assert_same_bytes(img[0], img[1], "caller's FTZ/DAZ/rounding");
    lr_image_free(img[0]);
    lr_image_free(img[1]);
}

/* Adaptive sampling's pilots are traced once (lib/render/pilots.h): a
 * full frame's rays are the same for any tile size and thread count,
 * and so are its bytes.  Before pilots were shared, each block traced its
 * apron's pilots again, and the rays grew as the tiles shrank (spheres
 * at 64 spp: 7.7% more at 32-pixel tiles, 16% at 16).  Tiles of 4096
 * hold several of adaptive.c's 64-pixel blocks; tiles of 7 end blocks
 * off the plan's 16-pixel grid; a real lens at f/11 leaves the lens
 * unsampled in some blocks, whose pilots reach spp. */
static void test_pilots_traced_once(void **state)
{
    (void)state;
    const char *sets[] = {"render.width=150",
                          "render.height=90",
                          "render.spp=64",
                          "camera.model=\"lens\"",
                          "camera.lens=\"double-gauss-50\"",
                          "camera.f_number=11",
                          "camera.focus_distance=16"};
    for (int lens = 0; lens < 2; lens++) {
        lr_scene *s = NULL;
        lr_error err;
        assert_int_equal(lr_scene_load_file("scenes/spheres.json", sets,
                                            lens ? 7 : 3, &s, &err),
                         LR_OK);
        lr_camera c;
        lr_render_settings rs;
        lr_scene_camera(s, &c);
        lr_scene_settings(s, &rs);
        assert_true(rs.plan && rs.adaptive);
        const int cfg[][2] = {{1, 32}, {2, 32}, {2, 16}, {3, 7}, {2, 4096}};
        lr_image *ref = NULL;
        lr_render_stats st0;
        for (size_t i = 0; i < 5; i++) {
            rs.threads = cfg[i][0];
            rs.tile_size = cfg[i][1];
            lr_image *img = NULL;
            lr_render_stats st;
            assert_int_equal(lr_render(s, &c, &rs, &img, &st, &err), LR_OK);
            if (ref == NULL) {
                ref = img, st0 = st;
                continue;
            }
            lr_test_assert_same_bytes(ref, img, "threads/tiles");
            if (st.rays != st0.rays)
                fail_msg("%s: %d threads, %d-pixel tiles: %llu rays, with "
                         "1 thread and 32-pixel tiles %llu",
                         lens ? "lens" : "thin lens", cfg[i][0], cfg[i][1],
                         (unsigned long long)st.rays,
                         (unsigned long long)st0.rays);
            lr_image_free(img);
        }
        lr_image_free(ref);
        lr_scene_free(s);
    }
}

/* adaptive.c hands the sampler up to 16 pixels' spans at once, so that
 * the camera and the integrator overlap several pixels' packets; each
 * pixel must keep the bits it has traced alone (lr__adaptive_batch 1,
 * as before batches).  Through the double Gauss at f/11 the plan mixes
 * pixels that sample the lens with chief-ray pixels (spans the sampler
 * must not put in one call); at 16 spp every pixel takes all its samples
 * at once (adaptive.c's block_whole), at 64 in rounds; rgb mode's
 * samples take the path one pixel at a time; the pinhole has no rays16_n
 * hook; the path tracer draws its numbers from each packet's pixel and
 * sample index (lr__sample_id).  At 24 and 100 spp spans end inside a
 * packet (a packet filled across spans must not carry one span's
 * overshoot into the next: an independent review planted that and this
 * test alone did not see it). */
static void test_batches_change_no_bit(void **state)
{
    (void)state;
    const char *base[] = {
        "render.width=96",       "render.height=64",
        "camera.model=\"lens\"", "camera.lens=\"double-gauss-50\"",
        "camera.f_number=11",    "camera.focus_distance=16"};
    const char *extra[][2] = {
        {"render.spp=16", "render.threads=1"},
        {"render.spp=64", "render.threads=1"},
        {"render.spp=64", "camera.chromatic.mode=\"rgb\""},
        {"render.spp=64", "camera.model=\"pinhole\""},
        {"render.spp=32", "render.integrator=\"path\""},
        {"render.spp=24", "camera.f_number=4"},
        {"render.spp=100", "render.threads=1"}};
    for (size_t k = 0; k < sizeof extra / sizeof *extra; k++) {
        const char *sets[8];
        memcpy(sets, base, sizeof base);
        sets[6] = extra[k][0], sets[7] = extra[k][1];
        lr_scene *s = NULL;
        lr_error err;
        assert_int_equal(
            lr_scene_load_file("scenes/spheres.json", sets, 8, &s, &err),
            LR_OK);
        lr_camera c;
        lr_render_settings rs;
        lr_scene_camera(s, &c);
        lr_scene_settings(s, &rs);
        lr_image *img[2];
        lr_render_stats st[2];
        for (int b = 0; b < 2; b++) {
            lr__adaptive_batch = b ? 1 : 16;
            img[b] = NULL;
            assert_int_equal(lr_render(s, &c, &rs, &img[b], &st[b], &err),
                             LR_OK);
        }
        lr__adaptive_batch = 16;
        lr_test_assert_same_bytes(img[1], img[0], extra[k][0]);
        assert_int_equal(st[0].rays, st[1].rays);
        assert_int_equal(st[0].samples, st[1].samples);
        lr_image_free(img[0]);
        lr_image_free(img[1]);
        lr_scene_free(s);
    }
}

static const struct CMUnitTest determinism_tests[] = {
    cmocka_unit_test(test_batches_change_no_bit),
    cmocka_unit_test(test_pilots_traced_once),
    cmocka_unit_test(test_determinism),
    cmocka_unit_test(test_bands_plan_adaptive),
    cmocka_unit_test(test_caller_fp_mode),
};

LR_TEST_GROUP(determinism, determinism_tests)
