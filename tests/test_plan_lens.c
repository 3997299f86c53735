/*
 * test_plan_lens.c: the plan through a real lens (docs/plan-lens.md):
 * where it skips the lens or the colours, the planned image keeps the
 * full simulation's light, channel by channel, against a render of the
 * same scene in full (the blur bound itself: test_lens_blur.c).
 */
#include "test.h"

#include <math.h>
#include <stdio.h>

/* A scene of sky and one object through the double Gauss (camera keys
 * `camera`, objects `objects`), rendered in full and planned, adaptive
 * sampling off: *full, *plan and the plan's statistics. */
static void lens_plan_pair(const char *camera, const char *objects, int w,
                           int h, int spp, lr_image **full, lr_image **plan,
                           lr_render_stats *st)
{
    char json[2048];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": %d,"
             "  \"adaptive\": false, \"max_depth\": 0},"
             " \"camera\": {\"model\": \"lens\", \"lens\": \"double-gauss-50\","
             "  %s},"
             " \"background\": [0.5, 0.6, 0.8],"
             " \"materials\": {\"w\": {\"diffuse\": 0.8}},"
             " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
             " \"objects\": [%s]}",
             w, h, spp, camera, objects);
    const char *full_sets[] = {"render.plan=false"};
    *full = lr_test_render(json, full_sets, 1, NULL);
    *plan = lr_test_render(json, NULL, 0, st);
}

/* The planned image's mean per channel within 0.3% of the full
 * simulation's (n pixels); frees both. */
static void same_channel_means(lr_image *full, lr_image *plan, int n)
{
    double mf[3] = {0, 0, 0}, mp[3] = {0, 0, 0};
    const float *f = lr_image_rgb(full), *q = lr_image_rgb(plan);
    for (int i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            mf[c] += f[3 * i + c], mp[c] += q[3 * i + c];
    for (int c = 0; c < 3; c++) {
        print_message("channel %d: planned / full mean %.5f\n", c,
                      mp[c] / mf[c]);
        if (!(fabs(mp[c] / mf[c] - 1.0) < 0.003))
            fail_msg("channel %d: planned mean %.6g, full %.6g", c, mp[c],
                     mf[c]);
    }
    lr_image_free(full);
    lr_image_free(plan);
}

/* A real lens tracing colours: the glass and its coating pass each
 * channel its own share, which the full simulation's ray per colour (or
 * wavelength) carries.  The plan traces one wavelength where the colours land within
 * a quarter pixel of each other, and chief rays where the lens need not
 * be sampled; with the reference wavelength's transmittance for every
 * channel, a wall in focus and the sky came out 1.0% too red and 1.8%
 * too blue against the full simulation (the double Gauss at f/11: a
 * bias, which no number of samples removes).  Each channel now carries
 * its share of the pupil's mean weight (colour_w16), and the plan still
 * skips the lens and the colours. */
static void test_real_lens_colours_keep_their_transmittance(void **state)
{
    (void)state;
    /* In focus at f/11 (chief rays); a wall at 3 m at f/4, blurred but
     * with its colours within a quarter pixel (packet rays through the
     * lens, one for every colour); the first in spectral mode, whose
     * shares integrate the matching functions (1.8% too red and 4.7%
     * too blue without them). */
    struct {
        const char *camera, *wall;
        int lens; /* 1: the lens sampled everywhere, else under half */
    } cases[] = {
        {"\"f_number\": 11, \"focus_distance\": 16,"
         " \"chromatic\": {\"mode\": \"rgb\"}",
         "{\"type\": \"plane\", \"point\": [0, -3, -16],"
         " \"normal\": [0, 0, 1], \"size\": [12, 6], \"material\": \"w\"}",
         0},
        {"\"f_number\": 4, \"focus_distance\": 16,"
         " \"chromatic\": {\"mode\": \"rgb\"}",
         "{\"type\": \"plane\", \"point\": [0, -3, -3],"
         " \"normal\": [0, 0, 1], \"size\": [12, 6], \"material\": \"w\"}",
         1},
        {"\"f_number\": 11, \"focus_distance\": 16,"
         " \"chromatic\": {\"mode\": \"spectral\"}",
         "{\"type\": \"plane\", \"point\": [0, -3, -16],"
         " \"normal\": [0, 0, 1], \"size\": [12, 6], \"material\": \"w\"}",
         0}};
    for (int k = 0; k < 3; k++) {
        lr_image *full, *plan;
        lr_render_stats st;
        lens_plan_pair(cases[k].camera, cases[k].wall, 64, 36, 16, &full, &plan,
                       &st);
        print_message("lens on %.0f%% of pixels, colours on %.0f%%\n",
                      100.0 * st.lens_pixels / st.pixels,
                      100.0 * st.chroma_pixels / st.pixels);
        if (cases[k].lens)
            assert_int_equal(st.lens_pixels, st.pixels);
        else
            assert_true(st.lens_pixels < st.pixels / 2);
        assert_true(st.chroma_pixels < st.pixels / 2);
        same_channel_means(full, plan, 64 * 36);
    }
}

/* The lens's caches of exit-pupil and blur tables are shared by every
 * job in a process.  Their keys once held the colour set and
 * chromatic.amplify as one number (colours + 10 amplify), so that after
 * a render without colours an rgb render at amplify 0.9 took its table:
 * its channels' shares all 1 and no colour spread, planned / full
 * 1.0099 / 0.9923 / 1.0281 (an independent review found it).  The
 * focus here is this test's own, so that no other test's tables are in
 * the cache. */
static void test_lens_caches_keep_colours_apart(void **state)
{
    (void)state;
    lr_image *full, *plan;
    const char *wall =
        "{\"type\": \"plane\", \"point\": [0, -3, -17],"
        " \"normal\": [0, 0, 1], \"size\": [12, 6], \"material\": \"w\"}";
    lens_plan_pair("\"f_number\": 11, \"focus_distance\": 17", wall, 32, 18, 1,
                   &full, &plan, NULL);
    lr_image_free(full);
    lr_image_free(plan);
    lens_plan_pair("\"f_number\": 11, \"focus_distance\": 17,"
                   " \"chromatic\": {\"mode\": \"rgb\", \"amplify\": 0.9}",
                   wall, 64, 36, 16, &full, &plan, NULL);
    same_channel_means(full, plan, 64 * 36);
}

/* Where a real lens with colours samples its lens but its table says
 * nothing of the colours, every colour is traced: blocks that see only
 * the sky at the edge of the image circle (the table's weights do not
 * hold there, nor do its shares), and a mirror in focus, which shows
 * depths the table was not asked about.  In both scenes every block
 * that samples the lens splits the colours. */
static void test_real_lens_colours_where_the_table_cannot_say(void **state)
{
    (void)state;
    const char *fmt =
        "{\"render\": {\"width\": 96, \"height\": 64, \"spp\": 1,"
        "  \"adaptive\": false, \"max_depth\": 1},"
        " \"camera\": {\"model\": \"lens\", \"lens\": \"double-gauss-50\","
        "  \"f_number\": 8, \"focus_distance\": 10, \"sensor_width_mm\": %d,"
        "  \"chromatic\": {\"mode\": \"rgb\"}},"
        " \"background\": [0.5, 0.6, 0.8],"
        " \"materials\": {\"m\": {\"%s\": 0.8}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -10],"
        "  \"radius\": 0.5, \"material\": \"m\"}]}";
    struct {
        int sensor;
        const char *material;
    } cases[] = {{70, "diffuse"}, {36, "reflect"}};
    for (int k = 0; k < 2; k++) {
        char json[1024];
        snprintf(json, sizeof json, fmt, cases[k].sensor, cases[k].material);
        lr_render_stats st;
        lr_image *img = lr_test_render(json, NULL, 0, &st);
        print_message("%d mm sensor, %s sphere: lens on %.0f%% of pixels, "
                      "colours on %.0f%%\n",
                      cases[k].sensor, cases[k].material,
                      100.0 * st.lens_pixels / st.pixels,
                      100.0 * st.chroma_pixels / st.pixels);
        assert_true(st.lens_pixels > 0 && st.lens_pixels < st.pixels);
        assert_int_equal(st.chroma_pixels, st.lens_pixels);
        lr_image_free(img);
    }
}

/* A sensor wider than the lens's image circle: at its edge the lens
 * cuts the pupil down to nothing within a fraction of a millimetre, and
 * a block there that sees only the sky once traced chief rays, whose
 * weight the table could not give (no chief ray past the edge; between
 * radii, a weight bent far from the straight line): a band of pixels at
 * 0 to 0.97 of the full simulation's (40 pixels under half of it here).
 * Such blocks now sample the lens. */
static void test_image_circle_edge(void **state)
{
    (void)state;
    lr_image *full, *plan;
    lr_render_stats st;
    lens_plan_pair("\"f_number\": 8, \"focus_distance\": 10,"
                   " \"sensor_width_mm\": 70",
                   "{\"type\": \"sphere\", \"center\": [0, 0, -10],"
                   " \"radius\": 0.5, \"material\": \"w\"}",
                   96, 64, 64, &full, &plan, &st);
    const float *f = lr_image_rgb(full), *q = lr_image_rgb(plan);
    double worst = INFINITY;
    for (int i = 0; i < 96 * 64; i++) {
        double a = f[3 * i] + f[3 * i + 1] + f[3 * i + 2];
        double b = q[3 * i] + q[3 * i + 1] + q[3 * i + 2];
        if (a > 0.05)
            worst = fmin(worst, b / a);
    }
    print_message("image circle's edge: planned / full, least over the "
                  "pixels %.4f; lens on %.0f%% of pixels\n",
                  worst, 100.0 * st.lens_pixels / st.pixels);
    /* Noise alone (the planned chief rays against the lens's 64
     * samples) stays within 1%; with the radii checked but not the
     * weight's bend between them, 0.915. */
    assert_true(worst > 0.96);
    /* And the plan still skips the lens somewhere. */
    assert_true(st.lens_pixels < st.pixels);
    lr_image_free(full);
    lr_image_free(plan);
}

static const struct CMUnitTest plan_lens_tests[] = {
    cmocka_unit_test(test_real_lens_colours_keep_their_transmittance),
    cmocka_unit_test(test_lens_caches_keep_colours_apart),
    cmocka_unit_test(test_real_lens_colours_where_the_table_cannot_say),
    cmocka_unit_test(test_image_circle_edge),
};
LR_TEST_GROUP(plan_lens, plan_lens_tests)
