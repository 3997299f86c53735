/*
 * test_plan.c: effect planning and adaptive sampling.  The planner may
 * skip work only where it cannot matter: on scenes built to fool a naive
 * planner, a planned render's error against a converged reference is no
 * worse than 1.1x the full simulation's at the same samples per pixel.
 * Adaptive sampling must keep regions and thread counts bit-identical.
 */
#include "test.h"

#include "render/adaptive.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* A blurred foreground sphere whose blur spills over a sharp, textured
 * background (strips at the focus distance), under a sky: a planner that
 * looked only at each pixel's own depth would call the background sharp
 * and cut the sphere's halo off. */
static const char *foreground_scene =
    "{\"render\": {\"width\": 64, \"height\": 48, \"max_depth\": 0},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 0],"
    "  \"look_at\": [0, 0, -1], \"fov\": 30, \"aperture_radius\": 0.12,"
    "  \"focus_distance\": 10},"
    " \"background\": [0.3, 0.4, 0.6],"
    " \"materials\": {\"w\": {\"diffuse\": 0.9}, \"k\": {\"diffuse\": 0.05},"
    "   \"r\": {\"diffuse\": [0.9, 0.2, 0.1]}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [-1.5, -0.6, -10], \"normal\": [0, 0, "
    "1],"
    "   \"size\": [1, 1.6], \"material\": \"w\"},"
    "  {\"type\": \"plane\", \"point\": [0, -0.6, -10], \"normal\": [0, 0, 1],"
    "   \"size\": [1, 1.6], \"material\": \"k\"},"
    "  {\"type\": \"plane\", \"point\": [1.5, -0.6, -10], \"normal\": [0, 0, "
    "1],"
    "   \"size\": [1, 1.6], \"material\": \"w\"},"
    "  {\"type\": \"sphere\", \"center\": [0.3, 0.25, -2.5], \"radius\": 0.25,"
    "   \"material\": \"r\"}]}";

/* A sharp white sphere in focus on black, with strong chromatic
 * aberration: only its rim shows colour. */
static const char *rim_scene =
    "{\"render\": {\"width\": 64, \"height\": 48, \"max_depth\": 0},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 0],"
    "  \"look_at\": [0, 0, -1], \"fov\": 20, \"aperture_radius\": 0.05,"
    "  \"focus_distance\": 4, \"focal_length_mm\": 50,"
    "  \"chromatic\": {\"mode\": \"rgb\", \"amplify\": 3}},"
    " \"materials\": {\"w\": {\"diffuse\": 1}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
    " \"objects\": [{\"type\": \"sphere\", \"center\": [0.1, 0, -4],"
    "   \"radius\": 0.3, \"material\": \"w\"}]}";

static void guarantee(const char *scene, const char *what)
{
    lr_image *im[3];
    lr_render_stats sf, sp;
    lr_test_plan_renders(scene, 2048, 64, im, &sf, &sp);
    lr_image *ref = im[0], *full = im[1], *plan = im[2];
    double ef = lr_test_rmse(full, ref), ep = lr_test_rmse(plan, ref);
    print_message("%s: RMSE full %.5f, planned %.5f (%.3fx); lens on %.0f%% "
                  "of pixels, colours split on %.0f%%, camera rays %llu of "
                  "%llu\n",
                  what, ef, ep, ep / ef, 100.0 * sp.lens_pixels / sp.pixels,
                  100.0 * sp.chroma_pixels / sp.pixels,
                  (unsigned long long)sp.camera_rays,
                  (unsigned long long)sp.full_camera_rays);
    if (!(ep <= 1.1 * ef))
        fail_msg("%s: planned error %g is more than 1.1x the full "
                 "simulation's %g",
                 what, ep, ef);
    /* The full simulation really simulates everything. */
    assert_int_equal(sf.lens_pixels, sf.pixels);
    lr_image_free(ref);
    lr_image_free(full);
    lr_image_free(plan);
}

static void test_blurred_foreground_over_sharp_background(void **state)
{
    (void)state;
    guarantee(foreground_scene, "blurred foreground");
}

static void test_chromatic_rim(void **state)
{
    (void)state;
    guarantee(rim_scene, "chromatic rim");
}

/* A flat mirror on the focal plane facing the camera, and a sphere
 * behind the camera that only the mirror shows: its reflection is as
 * far behind the mirror as the sphere is in front, out of focus.  The
 * planner once took the mirror's depth for what its blocks show and drew
 * the reflection sharp (RMSE 5.5x the full simulation's here).  (Glass
 * behind which the blocks' rays go on is in their depths already: the
 * bound does not stop at what is hit first; its Fresnel reflection is a
 * mirror's.) */
static const char *mirror_scene =
    "{\"render\": {\"width\": 64, \"height\": 48, \"max_depth\": 2},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 0],"
    "  \"look_at\": [0, 0, -1], \"fov\": 30, \"aperture_radius\": 0.08,"
    "  \"focus_distance\": 4},"
    " \"background\": [0.3, 0.4, 0.6],"
    " \"materials\": {\"m\": {\"diffuse\": 0, \"reflect\": 0.9},"
    "   \"r\": {\"diffuse\": [0.9, 0.2, 0.1]}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [0, 0, -4], \"normal\": [0, 0, 1],"
    "   \"size\": [3, 3], \"material\": \"m\"},"
    "  {\"type\": \"sphere\", \"center\": [0.3, 0.1, 3], \"radius\": 0.5,"
    "   \"material\": \"r\"}]}";

static void test_mirror_shows_other_depths(void **state)
{
    (void)state;
    guarantee(mirror_scene, "mirror in focus");
}

/* But a lobe far wider than the angle the lens subtends hides the lens:
 * a rough metal card on the focal plane under the path tracer keeps the
 * plan (no lens sampled), the same card smooth, or under Whitted (which
 * traces mirrors smooth), samples it everywhere it is seen. */
static void test_rough_lobes_keep_the_plan(void **state)
{
    (void)state;
    const char *fmt =
        "{\"render\": {\"width\": 32, \"height\": 24, \"spp\": 4,"
        "  \"adaptive\": false, \"integrator\": \"%s\"},"
        " \"camera\": {\"model\": \"thinlens\", \"aperture_radius\": 0.01,"
        "  \"focus_distance\": 5, \"fov\": 20},"
        " \"materials\": {\"m\": {\"diffuse\": 0.2, \"reflect\": 0.7,"
        "  \"roughness\": %g}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, -5],"
        "  \"normal\": [0, 0, 1], \"size\": 4, \"material\": \"m\"}]}";
    struct {
        const char *integrator;
        double roughness;
        int lens_everywhere;
    } cases[] = {{"path", 0.3, 0}, {"path", 0.0, 1}, {"whitted", 0.3, 1}};
    for (int i = 0; i < 3; i++) {
        char json[1024];
        snprintf(json, sizeof json, fmt, cases[i].integrator,
                 cases[i].roughness);
        lr_render_stats st;
        lr_image *img = lr_test_render(json, NULL, 0, &st);
        if (cases[i].lens_everywhere)
            assert_int_equal(st.lens_pixels, st.pixels);
        else
            assert_int_equal(st.lens_pixels, 0);
        lr_image_free(img);
    }
}

/* Spectral aberration through SF11 glass: the violet halos of bars are
 * many pixels wider than the reference colour's blur, and reach blocks
 * that only the halos touch.  (The planner once bounded a block's reach
 * by the reference colour alone and cut these halos off.) */
static void test_spectral_halos(void **state)
{
    (void)state;
    const char *json =
        "{\"render\": {\"width\": 96, \"height\": 64, \"max_depth\": 0},"
        " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 1.6, 0],"
        "  \"look_at\": [0, 1, -12], \"fov\": 20, \"focal_length_mm\": 50,"
        "  \"f_number\": 1.4, \"focus_distance\": 12,"
        "  \"chromatic\": {\"mode\": \"spectral\", \"glass\": \"SF11\","
        "   \"focal_model\": \"lensmaker\", \"wavelengths\": 8}},"
        " \"background\": 0.02,"
        " \"materials\": {\"w\": {\"diffuse\": 0.9}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1.5}],"
        " \"objects\": ["
        "  {\"type\": \"plane\", \"point\": [0, 2.0, -14], \"normal\": [0, 0, "
        "1],"
        "   \"size\": [3, 0.05], \"material\": \"w\"},"
        "  {\"type\": \"sphere\", \"center\": [0.6, 1, -12], \"radius\": 0.3,"
        "   \"material\": \"w\"}]}";
    guarantee(json, "spectral halos");
}

/* The planner does skip work where nothing is blurred: the sky, and a
 * scene whose only object sits on the focal plane far from the lens. */
static void test_plan_skips_what_it_can(void **state)
{
    (void)state;
    const char *sets[] = {"render.spp=16", "render.adaptive=false"};
    lr_render_stats st;
    lr_image *img = lr_test_render(foreground_scene, sets, 2, &st);
    assert_true(st.lens_pixels > 0 && st.lens_pixels < st.pixels);
    lr_image_free(img);
    /* A flat card exactly on the focal plane with a tiny aperture: no
     * block can blur by a quarter pixel, so no lens sampling at all, and
     * the image equals the pinhole's. */
    const char *card =
        "{\"render\": {\"width\": 32, \"height\": 24, \"spp\": 16,"
        "  \"adaptive\": false},"
        " \"camera\": {\"model\": \"thinlens\", \"aperture_radius\": 0.001,"
        "  \"focus_distance\": 5},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0.2, 0, -5],"
        "  \"normal\": [0, 0, 1], \"size\": 1}]}";
    lr_image *planned = lr_test_render(card, NULL, 0, &st);
    assert_int_equal(st.lens_pixels, 0);
    const char *pin_sets[] = {"camera.model=pinhole"};
    lr_image *pin = lr_test_render(card, pin_sets, 1, NULL);
    assert_memory_equal(lr_image_rgb(planned), lr_image_rgb(pin),
                        32 * 24 * 3 * sizeof(float));
    lr_image_free(planned);
    lr_image_free(pin);
}

/* Fine detail blurred just under a quarter pixel: dark stripes 0.6 px
 * wide every 1.37 px, 0.01 before a white wall, the thin lens focused
 * in front of them so that they blur 0.23 px.  At 64 spp the plan skips
 * the lens there (a blur under a quarter pixel); but a skipped blur is
 * a bias that more samples do not remove, and at 1024 spp the planned
 * image erred 8x as much as the full simulation.  The bound now
 * shrinks past 128 spp (plan.h: lr__plan_blur_px): at 1024 spp the
 * planned error is within 1.2x of the full simulation's. */
static void test_plan_bias_shrinks_with_spp(void **state)
{
    (void)state;
    /* 48 x 32 at fov 40: fpx = 16 / tan 20 deg; a pixel at 6.15 is
     * 6.15 / fpx across; blur 2 R fpx |1 / 6.15 - 1 / 6| = 0.228 px. */
    const double fpx = 16.0 / tan(20.0 * M_PI / 180.0), px = 6.15 / fpx;
    const double R = 0.228 / (2.0 * fpx * (1.0 / 6.0 - 1.0 / 6.15));
    char scene[8192];
    int n = snprintf(
        scene, sizeof scene,
        "{\"camera\": {\"model\": \"thinlens\", \"fov\": 40,"
        " \"focus_distance\": 6, \"aperture_radius\": %.9g},"
        " \"render\": {\"width\": 48, \"height\": 32},"
        " \"materials\": {\"w\": {\"diffuse\": 0.8}, \"k\": {\"diffuse\": "
        "0.05}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, -6.16],"
        " \"normal\": [0, 0, 1], \"size\": [20, 20], \"material\": \"w\"}",
        R);
    for (double x = -3.4; x < 3.4; x += 1.37 * px)
        n += snprintf(scene + n, sizeof scene - (size_t)n,
                      ", {\"type\": \"plane\", \"point\": [%.9g, 0, -6.15],"
                      " \"normal\": [0, 0, 1], \"size\": [%.9g, 4],"
                      " \"material\": \"k\"}",
                      x, 0.6 * px);
    snprintf(scene + n, sizeof scene - (size_t)n, "]}");
    const char *ref_sets[] = {"render.spp=8192", "render.plan=false",
                              "render.adaptive=false", "render.seed=99"};
    const char *full_sets[] = {"render.spp=1024", "render.plan=false",
                               "render.adaptive=false"};
    const char *plan_sets[] = {"render.spp=1024", "render.adaptive=false"};
    const char *low_sets[] = {"render.spp=64", "render.adaptive=false"};
    lr_render_stats st;
    lr_image *low = lr_test_render(scene, low_sets, 2, &st);
    assert_int_equal(st.lens_pixels, 0); /* the quarter pixel at 64 spp */
    lr_image *ref = lr_test_render(scene, ref_sets, 4, NULL);
    lr_image *full = lr_test_render(scene, full_sets, 3, NULL);
    lr_image *plan = lr_test_render(scene, plan_sets, 2, &st);
    double ef = lr_test_rmse(full, ref), ep = lr_test_rmse(plan, ref);
    print_message("stripes at 1024 spp: RMSE full %.3g, planned %.3g "
                  "(%.2fx), lens on %.0f%% of the pixels\n",
                  ef, ep, ep / ef, 100.0 * st.lens_pixels / st.pixels);
    assert_true(ep * ep <= 1.2 * ef * ef);
    lr_image_free(low);
    lr_image_free(ref);
    lr_image_free(full);
    lr_image_free(plan);
}

/* Adaptive sampling spends samples where the noise is: a flat region
 * converges at the pilot, the blurred edges get more; and its choices
 * depend only on each pixel's neighbourhood, so crops and thread counts
 * give the same bytes. */
static void test_adaptive_deterministic(void **state)
{
    (void)state;
    const char *sets[] = {"render.spp=128", "render.threads=1",
                          "render.tile_size=64"};
    lr_render_stats st;
    lr_image *full = lr_test_render(foreground_scene, sets, 3, &st);
    assert_true(st.samples < st.full_samples);
    assert_true(st.samples > (uint64_t)16 * st.pixels);
    const char *sets2[] = {"render.spp=128", "render.threads=2",
                           "render.tile_size=5"};
    lr_image *other = lr_test_render(foreground_scene, sets2, 3, NULL);
    assert_memory_equal(lr_image_rgb(full), lr_image_rgb(other),
                        64 * 48 * 3 * sizeof(float));
    lr_image_free(other);
    const char *crop_sets[] = {"render.spp=128", "render.tile_size=7",
                               "render.region=[13, 9, 41, 30]"};
    lr_image *crop = lr_test_render(foreground_scene, crop_sets, 3, NULL);
    for (int y = 0; y < 21; y++)
        assert_memory_equal(lr_image_rgb(full) + 3 * ((y + 9) * 64 + 13),
                            lr_image_rgb(crop) + 3 * y * 28,
                            28 * 3 * sizeof(float));
    lr_image_free(crop);
    lr_image_free(full);
}

/* The schedule itself, on a pinhole view of two flat cards, light and
 * dark, meeting in a vertical edge down the middle of pixel column 12.
 * With nothing given, the minimum at 64 spp is 16 (a packet; the power
 * of two at or above sqrt(64) is less); with {"threshold": 0.01,
 * "min_spp": 4} it is 4, as asked.  Either way every pixel's pilot is that minimum, the edge's
 * pilot sees both sides (Sobol's first four pixel points are two on each
 * side of the pixel's middle), so that column and its neighbours on both
 * sides go on to spp, and every other pixel, whose neighbourhood is flat,
 * stops at the pilot.  Each pixel is the full render stopped at its
 * count, and with min_spp = spp adaptive sampling is the full render. */
static void schedule(const char *json, const char *adaptive, int lo)
{
    char full_lo[32];
    snprintf(full_lo, sizeof full_lo, "render.spp=%d", lo);
    const char *lo_sets[] = {"render.adaptive=false", full_lo};
    const char *full64_sets[] = {"render.adaptive=false"};
    lr_image *flo = lr_test_render(json, lo_sets, 2, NULL);
    lr_image *full64 = lr_test_render(json, full64_sets, 1, NULL);
    lr_render_stats st;
    const char *ad_sets[] = {adaptive};
    lr_image *ad = lr_test_render(json, ad_sets, 1, &st);
    uint64_t expect = 0;
    for (int x = 0; x < 24; x++) {
        int n = x >= 11 && x <= 13 ? 64 : lo;
        char region[64];
        snprintf(region, sizeof region, "render.region=[%d, 0, %d, 6]", x,
                 x + 1);
        const char *col_sets[] = {adaptive, region};
        lr_render_stats cs;
        lr_image *col = lr_test_render(json, col_sets, 2, &cs);
        if (cs.samples != (uint64_t)6 * n)
            fail_msg("%s: column %d took %llu samples, not 6 x %d", adaptive, x,
                     (unsigned long long)cs.samples, n);
        expect += (uint64_t)6 * n;
        const lr_image *same = n == 64 ? full64 : flo;
        for (int y = 0; y < 6; y++)
            assert_memory_equal(lr_image_rgb(ad) + 3 * (y * 24 + x),
                                lr_image_rgb(same) + 3 * (y * 24 + x),
                                3 * sizeof(float));
        lr_image_free(col);
    }
    assert_int_equal(st.samples, expect);
    /* The edge is really there: column 12 is neither card's colour. */
    float e = lr_image_rgb(full64)[3 * 12];
    assert_true(e > 0.2f && e < 0.8f);
    lr_image_free(ad);
    lr_image_free(flo);
    lr_image_free(full64);
}

static void test_adaptive_schedule(void **state)
{
    (void)state;
    /* fov 20 at 24 x 6: half_w = 4 tan(10 deg); the middle of column 12
     * is 5 half_w / 24 to the right of the axis at depth 5. */
    double xe = 5.0 * 4.0 * tan(10.0 * M_PI / 180.0) / 24.0;
    char json[1024];
    snprintf(
        json, sizeof json,
        "{\"render\": {\"width\": 24, \"height\": 6, \"spp\": 64,"
        "  \"max_depth\": 0, \"threads\": 1},"
        " \"camera\": {\"model\": \"pinhole\", \"position\": [0, 0, 0],"
        "  \"look_at\": [0, 0, -1], \"fov\": 20},"
        " \"materials\": {\"w\": {\"diffuse\": 0.9},"
        "   \"k\": {\"diffuse\": 0.1}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": ["
        "  {\"type\": \"plane\", \"point\": [%.9f, 0, -5],"
        "   \"normal\": [0, 0, 1], \"size\": [8, 4], \"material\": \"w\"},"
        "  {\"type\": \"plane\", \"point\": [%.9f, 0, -5],"
        "   \"normal\": [0, 0, 1], \"size\": [8, 4], \"material\": \"k\"}]}",
        xe - 4.0, xe + 4.0);
    schedule(json, "render.adaptive=true", 16);
    schedule(json, "render.adaptive={\"threshold\": 0.01, \"min_spp\": 4}", 4);
    /* min_spp = spp: nothing to decide. */
    const char *eq_sets[] = {"render.adaptive={\"min_spp\": 64}"};
    const char *full64_sets[] = {"render.adaptive=false"};
    lr_image *full64 = lr_test_render(json, full64_sets, 1, NULL);
    lr_image *eq = lr_test_render(json, eq_sets, 1, NULL);
    assert_memory_equal(lr_image_rgb(eq), lr_image_rgb(full64),
                        24 * 6 * 3 * sizeof(float));
    lr_image_free(eq);
    lr_image_free(full64);
}

/* Adaptive sampling follows the budget: at 64 and at 256 spp its error
 * against a converged reference is within 1.1x (RMSE; 1.21x in MSE) of
 * the full simulation's at the same spp, so four times the samples cut
 * its error about as much as they cut the full simulation's.  (With the
 * fixed threshold of 0.01 that was the default before, the adaptive
 * render's error levelled off: docs/accuracy.md.) */
static void test_adaptive_error(void **state)
{
    (void)state;
    const char *ref_sets[] = {"render.spp=2048", "render.plan=false",
                              "render.adaptive=false", "render.seed=5"};
    lr_image *ref = lr_test_render(foreground_scene, ref_sets, 4, NULL);
    double ef[2], ea[2];
    for (int i = 0; i < 2; i++) {
        const char *spp = i == 0 ? "render.spp=64" : "render.spp=256";
        const char *full_sets[] = {spp, "render.adaptive=false"};
        const char *ad_sets[] = {spp};
        lr_render_stats st;
        lr_image *full = lr_test_render(foreground_scene, full_sets, 2, NULL);
        lr_image *ad = lr_test_render(foreground_scene, ad_sets, 1, &st);
        ef[i] = lr_test_rmse(full, ref);
        ea[i] = lr_test_rmse(ad, ref);
        print_message("%s: adaptive RMSE %.5f with %.1f%% of the samples "
                      "(full %.5f)\n",
                      spp, ea[i], 100.0 * st.samples / st.full_samples, ef[i]);
        if (!(ea[i] <= 1.1 * ef[i]))
            fail_msg("%s: adaptive RMSE %g is more than 1.1x the full "
                     "simulation's %g",
                     spp, ea[i], ef[i]);
        /* It does skip samples where the picture is flat. */
        assert_true(st.samples < st.full_samples);
        lr_image_free(full);
        lr_image_free(ad);
    }
    /* The fall from 64 to 256 spp, in MSE, at least 0.8 of the full
     * simulation's. */
    double fall_a = ea[0] * ea[0] / (ea[1] * ea[1]);
    double fall_f = ef[0] * ef[0] / (ef[1] * ef[1]);
    print_message("MSE falls %.2fx adaptive, %.2fx full\n", fall_a, fall_f);
    if (!(fall_a >= 0.8 * fall_f))
        fail_msg("4x the samples cut the adaptive MSE %.2fx, the full "
                 "simulation's %.2fx",
                 fall_a, fall_f);
    lr_image_free(ref);
}

/* The in-focus accuracy scene (make accuracy) at 80 x 60, with `sets`
 * after the size. */
static lr_image *render_focus(const char *const *sets, size_t n)
{
    const char *all[8] = {"render.width=80", "render.height=60"};
    for (size_t i = 0; i < n; i++)
        all[2 + i] = sets[i];
    lr_scene *s = NULL;
    lr_error err;
    if (lr_scene_load_file("scenes/accuracy-focus.json", all, 2 + n, &s,
                           &err) != LR_OK)
        fail_msg("scene: %s", err.message);
    lr_camera c;
    lr_render_settings rs;
    lr_scene_camera(s, &c);
    lr_scene_settings(s, &rs);
    lr_image *img = lr_test_render_with(s, &c, &rs, "accuracy-focus");
    lr_scene_free(s);
    return img;
}

/* docs/accuracy.md's relative MSE: (x - r)^2 / (r^2 + 0.01). */
static double relmse(const lr_image *x, const lr_image *r)
{
    int n = lr_image_width(r) * lr_image_height(r) * 3;
    double e = 0.0;
    for (int i = 0; i < n; i++) {
        double ri = lr_image_rgb(r)[i], d = lr_image_rgb(x)[i] - ri;
        e += d * d / (ri * ri + 0.01);
    }
    return e / n;
}

/* The grid sampler's default in focus: every pixel samples the same
 * cell centres, and only the lens's blur dithers them; where the
 * planner skipped the lens the default erred 2.3x as much as the full
 * simulation at 64 spp (relMSE), now about 1.1x.  Target (issue 17):
 * at most 1.2x. */
static void test_grid_default_in_focus(void **state)
{
    (void)state;
    const char *ref_sets[] = {"render.spp=1024", "render.plan=false",
                              "render.adaptive=false", "render.seed=5"};
    const char *full_sets[] = {"render.spp=64", "render.sampler=grid",
                               "render.plan=false", "render.adaptive=false"};
    const char *def_sets[] = {"render.spp=64", "render.sampler=grid"};
    lr_image *ref = render_focus(ref_sets, 4);
    lr_image *full = render_focus(full_sets, 4);
    lr_image *def = render_focus(def_sets, 2);
    double ef = relmse(full, ref), ed = relmse(def, ref);
    print_message("grid in focus, 64 spp: relMSE default %.3g, full %.3g "
                  "(%.2fx)\n",
                  ed, ef, ed / ef);
    if (!(ed <= 1.2 * ef))
        fail_msg("grid default relMSE %g is more than 1.2x the full "
                 "simulation's %g",
                 ed, ef);
    lr_image_free(ref);
    lr_image_free(full);
    lr_image_free(def);
}

/* The contrast test reads views made once per pixel (means, roots of
 * the scales); it must give, to the bit, the formula it replaced: per
 * channel |ma - mb| / sqrt(fmax(ma^2 + 0.01, mb^2 + 0.01)), the largest,
 * 0 without samples.  Pixels from ordinary to overflowing scales. */
static double reference_contrast(const lr__pixel *a, const lr__pixel *b)
{
    if (a->n == 0 || b->n == 0)
        return 0.0;
    double c = 0.0;
    for (int i = 0; i < 3; i++) {
        double ma = a->sum[i] / (double)a->n, mb = b->sum[i] / (double)b->n;
        double d = fabs(ma - mb) / sqrt(fmax(ma * ma + 0.01, mb * mb + 0.01));
        if (d > c)
            c = d;
    }
    return c;
}

static void test_pilot_contrast_exact(void **state)
{
    (void)state;
    static const double scales[] = {0.0, 1e-3, 0.3, 1.0, 7.0, 1e6, 1e200};
    static const unsigned ns[] = {0, 1, 2, 3, 16, 17, 1000};
    uint64_t rng = 0x9e3779b97f4a7c15ull;
    int checked = 0;
    for (int t = 0; t < 20000; t++) {
        lr__pixel px[2];
        for (int j = 0; j < 2; j++) {
            lr__pixel_reset(&px[j]);
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            px[j].n = ns[(rng >> 33) % 7];
            double s = scales[(rng >> 40) % 7];
            for (int c = 0; c < 3; c++) {
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                /* Often equal sums, so that equal roots meet too. */
                double u = (double)(rng >> 11) * 0x1p-53;
                px[j].sum[c] = t % 5 == 0 ? s : u * s * (double)px[j].n;
            }
        }
        lr__pilot_view va, vb;
        lr__pilot_view_make(&px[0], &va);
        lr__pilot_view_make(&px[1], &vb);
        double want = reference_contrast(&px[0], &px[1]);
        double got = lr__pilot_contrast(&va, &vb);
        if (memcmp(&want, &got, sizeof want) != 0)
            fail_msg("pilot %d: contrast %.17g, the formula gives %.17g", t,
                     got, want);
        checked += want > 0.0;
    }
    assert_true(checked > 1000);
}

static const struct CMUnitTest plan_tests[] = {
    cmocka_unit_test(test_blurred_foreground_over_sharp_background),
    cmocka_unit_test(test_chromatic_rim),
    cmocka_unit_test(test_spectral_halos),
    cmocka_unit_test(test_mirror_shows_other_depths),
    cmocka_unit_test(test_rough_lobes_keep_the_plan),
    cmocka_unit_test(test_plan_skips_what_it_can),
    cmocka_unit_test(test_plan_bias_shrinks_with_spp),
    cmocka_unit_test(test_adaptive_deterministic),
    cmocka_unit_test(test_adaptive_error),
    cmocka_unit_test(test_adaptive_schedule),
    cmocka_unit_test(test_pilot_contrast_exact),
    cmocka_unit_test(test_grid_default_in_focus),
};
LR_TEST_GROUP(plan, plan_tests)
