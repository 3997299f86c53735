/*
 * test_light_trace.c: light traced through the lens (lib/integrator/light_trace.c).
 * Against independent truth: the film integral of a light's image in
 * closed form (the camera's importance integrated over the lens and the
 * sphere's solid angle), and the camera's own estimator of the same
 * image (render.light = false, every sample traced, many samples).  Also
 * what the plan sends to the light side, and that splats keep the
 * renderer's determinism (threads, tiles, regions give the same bytes).
 */
#include "test.h"

#include "film_integral.h"

#include "camera/camera.h"
#include "render/plan.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Three lights behind the focus of a thin lens, each on its own part of
 * a black frame; their discs are about 12, 15 and 20 pixels across. */
static const char *discs_scene =
    "{\"render\": {\"width\": 96, \"height\": 64, \"seed\": 5},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
    "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.6,"
    "  \"focus_distance\": 10},"
    " \"materials\": {\"a\": {\"emission\": [300, 200, 100]},"
    "   \"b\": {\"emission\": [60, 90, 400]}},"
    " \"objects\": ["
    "  {\"type\": \"sphere\", \"center\": [-10, 4, -30], \"radius\": 0.15, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [2, -5, -40], \"radius\": 0.2, "
    "\"material\": \"b\"},"
    "  {\"type\": \"sphere\", \"center\": [14, 6, -50], \"radius\": 0.25, "
    "\"material\": \"a\"}]}";

static double sum_box(const lr_image *img, int x0, int y0, int x1, int y1,
                      int c)
{
    double s = 0.0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            s += img->rgb[3 * ((size_t)y * img->width + x) + c];
    return s;
}

/* Each box's sum (x0, y0, x1, y1), every channel, of the light side's
 * image li within tol[k] of the camera's ci. */
static void boxes_agree(const lr_image *li, const lr_image *ci,
                        const int boxes[][4], const double *tol, int n,
                        const char *what)
{
    for (int k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) {
            const int *b = boxes[k];
            double x = sum_box(li, b[0], b[1], b[2], b[3], c);
            double y = sum_box(ci, b[0], b[1], b[2], b[3], c);
            if (c == 0)
                print_message("%s %d: light side %.6g, camera %.6g (%.4f)\n",
                              what, k, x, y, x / y);
            if (!(fabs(x / y - 1.0) < tol[k]))
                fail_msg("%s %d channel %d: light side %.6g, camera %.6g", what,
                         k, c, x, y);
        }
}

/* discs_scene's lights (their emission per channel) and a box holding
 * each one's disc. */
static const double disc_c[3][3] = {{-10, 4, -30}, {2, -5, -40}, {14, 6, -50}};
static const double disc_r[3] = {0.15, 0.2, 0.25};
static const double disc_L[3][3] = {
    {300, 200, 100}, {60, 90, 400}, {300, 200, 100}};
static const int disc_boxes[3][4] = {
    {0, 0, 40, 32}, {30, 32, 70, 64}, {60, 0, 96, 32}};

/* Each of discs_scene's lights' energy in img, channels 0 .. n_ch - 1,
 * within 0.5% of the closed form through a lens at the eye of radius
 * R[ch] (a square of half side R[ch] when square). */
static void discs_match_closed_form_ch(const lr_image *img, const double *R,
                                       int square, int n_ch, const char *what)
{
    double fpx = 0.5 * 64 / tan(20.0 * M_PI / 180.0);
    for (int k = 0; k < 3; k++)
        for (int ch = 0; ch < n_ch; ch++) {
            double want = film_integral_of(
                v3(0, 0, 10), v3(0, 0, -1), R[ch], square,
                v3(disc_c[k][0], disc_c[k][1], disc_c[k][2]), disc_r[k],
                disc_L[k][ch], fpx);
            const int *b = disc_boxes[k];
            double got = sum_box(img, b[0], b[1], b[2], b[3], ch);
            print_message("%s light %d channel %d: film integral %.6g, "
                          "closed form %.6g (%.5f)\n",
                          what, k, ch, got, want, got / want);
            if (!(fabs(got / want - 1.0) < 0.005))
                fail_msg("%s light %d channel %d: its image holds %.6g, the "
                         "closed form %.6g",
                         what, k, ch, got, want);
        }
}

/* The same with one lens for every channel. */
static void discs_match_closed_form(const lr_image *img, double R, int square,
                                    int n_ch, const char *what)
{
    const double Rs[3] = {R, R, R};
    discs_match_closed_form_ch(img, Rs, square, n_ch, what);
}

/* Each light's energy on the film, light-traced at 64 spp, against the
 * closed form: within 0.5% (the light paths' noise is about 0.1%). */
static void test_disc_energy_closed_form(void **state)
{
    (void)state;
    const char *sets[] = {"render.spp=64"};
    lr_render_stats st;
    lr_image *img = lr_test_render(discs_scene, sets, 1, &st);
    assert_int_equal(st.light_lights, 3);
    discs_match_closed_form(img, 0.6, 0, 1, "thin lens");
    lr_test_check_finite(img, &st, "discs");
    lr_image_free(img);
}

/* The bracket (image plane 1 in front of the eye, focal plane 9 beyond,
 * a square of side 1): its rays from film point D and square offset off
 * all pass e + (1 + di / f) off, so each light's film integral is the
 * closed form for a square lens of half side 0.5 (1 + 1/9) at the eye,
 * within 0.5% from the light side.  A ball nearer than the image plane,
 * across light 0's rays, is behind every camera ray's start: it must
 * not shadow the light side either.  The camera alone (every sample
 * traced) agrees within its noise. */
static void test_bracket_light_side(void **state)
{
    (void)state;
    char scene[2048];
    size_t len = strlen(discs_scene);
    snprintf(scene, sizeof scene,
             "%.*s, {\"type\": \"sphere\", \"center\": [-0.12, 0.048, "
             "9.52], \"radius\": 0.1, \"material\": \"k\"}]}",
             (int)len - 2, discs_scene);
    const char *cam[] = {
        "camera.model=bracket",           "camera.aperture=1",
        "camera.focal_length=9",          "camera.image_plane_distance=1",
        "materials.k={\"diffuse\": 0.5}", "render.spp=64"};
    lr_render_stats st;
    lr_image *img = lr_test_render(scene, cam, 6, &st);
    assert_int_equal(st.light_lights, 3);
    discs_match_closed_form(img, 0.5 * (1.0 + 1.0 / 9.0), 1, 1, "bracket");
    const char *csets[] = {"camera.model=bracket",
                           "camera.aperture=1",
                           "camera.focal_length=9",
                           "camera.image_plane_distance=1",
                           "materials.k={\"diffuse\": 0.5}",
                           "render.spp=4096",
                           "render.light=false",
                           "render.plan=false",
                           "render.adaptive=false"};
    lr_image *ci = lr_test_render(scene, csets, 9, NULL);
    const double tol[3] = {0.03, 0.03, 0.03};
    boxes_agree(img, ci, disc_boxes, tol, 3, "bracket disc");
    lr_image_free(img);
    lr_image_free(ci);
}

static double rms_radius(const lr_image *img, const int *b, int ch);

/* The bracket with rgb colours that focus apart (the paper's camera
 * and its chromatic aberration): channel k's rays cross at e + (1 + di
 * w_k) off, so each light path is traced once a channel from its own
 * lens point.  Each light's energy in each channel equals the closed
 * form for a square lens of half side 0.5 (1 + di w_k) within 0.5%; the
 * camera alone (2048 spp) agrees within its noise, and the discs' sizes
 * differ by channel as the camera's do. */
static void test_bracket_rgb_light_side(void **state)
{
    (void)state;
    const char *sets[] = {"camera.model=bracket",
                          "camera.aperture=1",
                          "camera.focal_length=9",
                          "camera.image_plane_distance=1",
                          "camera.chromatic.mode=rgb",
                          "camera.chromatic.amplify=20",
                          "render.spp=64",
                          "render.light=false",
                          "render.plan=false",
                          "render.adaptive=false"};
    lr_render_stats st;
    lr_image *img = lr_test_render(discs_scene, sets, 7, &st);
    assert_int_equal(st.light_lights, 3);
    lr_scene *sc = lr_test_load(discs_scene, sets, 7);
    lr_camera cam;
    lr_scene_camera(sc, &cam);
    lr__cam c;
    lr__cam_init(&c, &cam, 96, 64);
    lr_scene_free(sc);
    double R[3];
    for (int k = 0; k < 3; k++)
        R[k] = 0.5 * (1.0 + c.base_di * c.w_rgb[k]);
    print_message("bracket rgb: lens half sides %.5f %.5f %.5f\n", R[0], R[1],
                  R[2]);
    assert_true(fabs(R[0] - R[2]) > 1e-3);
    discs_match_closed_form_ch(img, R, 1, 3, "bracket rgb");
    const char *csets[] = {
        "camera.model=bracket",      "camera.aperture=1",
        "camera.focal_length=9",     "camera.image_plane_distance=1",
        "camera.chromatic.mode=rgb", "camera.chromatic.amplify=20",
        "render.spp=2048",           "render.light=false",
        "render.plan=false",         "render.adaptive=false"};
    lr_image *ci = lr_test_render(discs_scene, csets, 10, NULL);
    /* The camera's noise (seed 5, as test_spectral_light_side's: light
     * 0's disc 6% low at 4096 spp). */
    const double tol[3] = {0.1, 0.1, 0.1};
    boxes_agree(img, ci, disc_boxes, tol, 3, "bracket rgb disc");
    for (int k = 0; k < 3; k++)
        for (int ch = 0; ch < 3; ch += 2) {
            double a = rms_radius(img, disc_boxes[k], ch);
            double b = rms_radius(ci, disc_boxes[k], ch);
            print_message("bracket rgb disc %d channel %d: rms radius %.4f, "
                          "camera %.4f\n",
                          k, ch, a, b);
            assert_true(fabs(a / b - 1.0) < 0.04);
        }
    lr_image_free(img);
    lr_image_free(ci);
}

/* Colours that focus apart (rgb mode, the dispersion amplified 2x): each
 * channel lands at its own focus (red and blue discs wider than green's
 * here), and each light's image still holds, in every channel, the
 * closed form's energy (which does not depend on the focus) within 0.5%;
 * the camera alone agrees within its noise. */
static void test_rgb_light_side(void **state)
{
    (void)state;
    const char *lsets[] = {"camera.focal_length_mm=50",
                           "camera.chromatic.mode=rgb",
                           "camera.chromatic.amplify=2", "render.spp=64"};
    lr_render_stats st;
    lr_image *img = lr_test_render(discs_scene, lsets, 4, &st);
    assert_int_equal(st.light_lights, 3);
    discs_match_closed_form(img, 0.6, 0, 3, "rgb");
    const char *csets[] = {
        "camera.focal_length_mm=50",  "camera.chromatic.mode=rgb",
        "camera.chromatic.amplify=2", "render.spp=4096",
        "render.light=false",         "render.plan=false",
        "render.adaptive=false"};
    lr_image *ci = lr_test_render(discs_scene, csets, 7, NULL);
    /* The camera's own noise here: seeds 1, 2, 3 and 5 put light 0's blue
     * at 36.7, 36.3, 35.9 and 34.1 (closed form 35.4). */
    const double tol[3] = {0.06, 0.06, 0.06};
    boxes_agree(img, ci, disc_boxes, tol, 3, "rgb disc");
    lr_image_free(img);
    lr_image_free(ci);
}

/* The rms radius of channel ch of the image in box b about its
 * centroid, in pixels: a disc's size, for comparing shapes. */
static double rms_radius(const lr_image *img, const int *b, int ch)
{
    double s = 0.0, sx = 0.0, sy = 0.0, sxx = 0.0;
    for (int y = b[1]; y < b[3]; y++)
        for (int x = b[0]; x < b[2]; x++) {
            double v = img->rgb[3 * ((size_t)y * img->width + x) + ch];
            s += v, sx += v * x, sy += v * y;
            sxx += v * ((double)x * x + (double)y * y);
        }
    double mx = sx / s, my = sy / s;
    return sqrt(sxx / s - mx * mx - my * my);
}

/* Spectral mode (the glass's own dispersion, a 100 mm lens): each light
 * path lands at camera.chromatic.wavelengths wavelengths, each at its own
 * focus with its weights.  Each light's image holds, in every channel,
 * the closed form's energy (the normalised matching functions integrate
 * to 1, and the energy does not depend on the focus) within 0.5% (5e-4
 * seen); and has the camera's shape: the camera alone (every sample
 * traced) gives each disc's channels the same rms radius within 4% (2%
 * seen), where red's and blue's differ from green's by over 20% (30 to
 * 60%).  The camera's energies agree within its noise (up to 6% at 1024
 * spp: the rgb test's measurements). */
static void test_spectral_light_side(void **state)
{
    (void)state;
    const char *lsets[] = {"camera.focal_length_mm=100",
                           "camera.chromatic.mode=spectral",
                           "camera.chromatic.amplify=1", "render.spp=64"};
    lr_render_stats st;
    lr_image *img = lr_test_render(discs_scene, lsets, 4, &st);
    assert_int_equal(st.light_lights, 3);
    discs_match_closed_form(img, 0.6, 0, 3, "spectral");
    lr_test_check_finite(img, &st, "spectral discs");
    const char *csets[] = {
        "camera.focal_length_mm=100", "camera.chromatic.mode=spectral",
        "camera.chromatic.amplify=1", "render.spp=1024",
        "render.light=false",         "render.plan=false",
        "render.adaptive=false"};
    lr_render_stats sc;
    lr_image *ci = lr_test_render(discs_scene, csets, 7, &sc);
    assert_int_equal(sc.light_lights, 0);
    const double tol[3] = {0.08, 0.08, 0.08};
    boxes_agree(img, ci, disc_boxes, tol, 3, "spectral disc");
    for (int k = 0; k < 3; k++) {
        double g = rms_radius(ci, disc_boxes[k], 1);
        for (int ch = 0; ch < 3; ch++) {
            double a = rms_radius(img, disc_boxes[k], ch);
            double b = rms_radius(ci, disc_boxes[k], ch);
            print_message("spectral disc %d channel %d: rms radius %.4f, "
                          "camera %.4f, camera's green %.4f\n",
                          k, ch, a, b, g);
            if (!(fabs(a / b - 1.0) < 0.04))
                fail_msg("spectral disc %d channel %d: rms radius %.4f, the "
                         "camera's %.4f",
                         k, ch, a, b);
            if (ch != 1 && !(fabs(b / g - 1.0) > 0.2))
                fail_msg("spectral disc %d channel %d: as wide as green "
                         "(%.4f, %.4f): the check cannot see the colours",
                         k, ch, b, g);
        }
    }
    lr_image_free(img);
    lr_image_free(ci);
}

/* A sky of 0.05 and a sun of 3 x 3 texels of 2000 at u = 0.03, v = 0.45
 * (a little above the horizon, towards -z) on a 256 x 128 map. */
static double sun_sky(int x, int y)
{
    return x >= 6 && x <= 8 && y >= 56 && y <= 58 ? 2000.0 : 0.05;
}

/* Stripes of 1 and 0.1 a texel wide, for an emission texture. */
static double stripes(int x, int y)
{
    (void)y;
    return x % 8 < 4 ? 1.0 : 0.1;
}

/* A sphere light with an emission texture (stripes: the largest value
 * 1, the mean 0.55), far behind the focus: the light side traces it and
 * looks the texture up where each path meets it; the camera alone
 * (every sample traced, 8192 spp) agrees on the disc's energy within
 * its noise (seeds 1 to 4 at 4096 spp: 224.4 to 229.6, the light side
 * 225.6 to 226.1; the texture's largest value would be 80% over) and on
 * its size. */
static void test_textured_light_side(void **state)
{
    (void)state;
    lr_test_write_map("stripes.exr", stripes, 64, 32);
    const char *scene =
        "{\"render\": {\"width\": 64, \"height\": 48, \"seed\": 4},"
        " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
        "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.6,"
        "  \"focus_distance\": 10},"
        " \"materials\": {\"t\": {\"emission\": [300, 200, 100],"
        "   \"emission_texture\": \"stripes.exr\"}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [1, 0.5, -30],"
        "   \"radius\": 0.4, \"material\": \"t\"}]}";
    /* The part of the frame around the disc. */
    const char *region = "render.region=[24,15,44,33]";
    const char *lsets[] = {"render.spp=256", region};
    lr_render_stats st;
    lr_image *li = lr_test_render(scene, lsets, 2, &st);
    assert_int_equal(st.light_lights, 1);
    lr_test_check_finite(li, &st, "textured light");
    const char *csets[] = {"render.spp=8192", "render.light=false",
                           "render.plan=false", "render.adaptive=false",
                           region};
    lr_image *ci = lr_test_render(scene, csets, 5, NULL);
    const int box[1][4] = {{0, 0, 20, 18}};
    const double tol[1] = {0.03};
    boxes_agree(li, ci, box, tol, 1, "textured light");
    double a = rms_radius(li, box[0], 0), b = rms_radius(ci, box[0], 0);
    print_message("textured light: rms radius %.4f, camera %.4f\n", a, b);
    assert_true(fabs(a / b - 1.0) < 0.02);
    lr_image_free(li);
    lr_image_free(ci);
}

/* sun_sky's map (sun-sky.exr) seen through a thin lens focused at 1 m:
 * the sun's disc about 40 pixels across, a ball in front of part of it. */
static const char *sun_scene =
    "{\"render\": {\"width\": 96, \"height\": 64, \"seed\": 2},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 0],"
    "  \"look_at\": [0.185, 0.156, -0.97], \"fov\": 40,"
    "  \"aperture_radius\": 0.25, \"focus_distance\": 1},"
    " \"environment\": {\"file\": \"sun-sky.exr\"},"
    " \"materials\": {\"b\": {\"diffuse\": 0.5}},"
    " \"objects\": [{\"type\": \"sphere\", \"center\": [0.9, 0.6, -6],"
    "   \"radius\": 0.5, \"material\": \"b\"}]}";

/* The environment's sun seen directly through a thin lens focused at 1,
 * a disc about 40 pixels across, a ball in front of part of it: with
 * the defaults the light side traces the sun (and camera rays that
 * escape within its cone add none of the map), with both integrators;
 * the sun's box holds what the camera alone finds (every sample traced,
 * 2048 spp), within its noise, and has its size. */
static void test_env_sun_light_side(void **state)
{
    (void)state;
    lr_test_write_map("sun-sky.exr", sun_sky, 256, 128);
    const char *scene = sun_scene;
    const char *integrators[2] = {"render.integrator=path",
                                  "render.integrator=whitted"};
    /* The part of the frame that holds the disc (a farm part's pixels
     * are the full frame's: test_light_deterministic). */
    const char *region = "render.region=[24,8,72,56]";
    for (int k = 0; k < 2; k++) {
        const char *lsets[] = {integrators[k], "render.spp=64", region};
        lr_render_stats st;
        lr_image *li = lr_test_render(scene, lsets, 3, &st);
        assert_int_equal(st.light_lights, 1);
        lr_test_check_finite(li, &st, "sun");
        const char *csets[] = {integrators[k],          "render.spp=2048",
                               "render.light=false",    "render.plan=false",
                               "render.adaptive=false", region};
        lr_render_stats sc;
        lr_image *ci = lr_test_render(scene, csets, 6, &sc);
        assert_int_equal(sc.light_lights, 0);
        const int boxes[1][4] = {{0, 0, 48, 48}};
        const double tol[1] = {0.02};
        boxes_agree(li, ci, boxes, tol, 1, integrators[k]);
        /* The same disc, bitten by the ball: its size. */
        double a = rms_radius(li, boxes[0], 0), b = rms_radius(ci, boxes[0], 0);
        print_message("%s: the sun's rms radius %.4f, camera %.4f\n",
                      integrators[k], a, b);
        assert_true(fabs(a / b - 1.0) < 0.01);
        lr_image_free(li);
        lr_image_free(ci);
    }
}

/* The light side and the camera agree: the camera alone (light off,
 * every sample traced, 8192 spp) and the light side (64 spp) give each
 * light's disc the same energy within the camera's noise (about 0.7%
 * here), and the same image within it. */
/* A sphere light across the bracket's image plane (di = 1; the sphere
 * spans depths 0.95 to 1.05): the camera's rays that start inside it
 * see its inside, which emits nothing, and the light side must splat
 * only what the camera sees.  It splatted the inside too: 77 times the
 * camera's total at this place, 60% more one radius farther. */
static void test_bracket_light_across_plane(void **state)
{
    (void)state;
    const char *scene =
        "{\"camera\": {\"model\": \"bracket\", \"fov\": 40, "
        "\"image_plane_distance\": 1, \"focal_length\": 3, \"aperture\": "
        "0.5}, \"render\": {\"width\": 60, \"height\": 60}, "
        "\"background\": 0, \"materials\": {\"e\": {\"emission\": 100}}, "
        "\"objects\": [{\"type\": \"sphere\", \"center\": [0.1, 0, -1], "
        "\"radius\": 0.05, \"material\": \"e\"}]}";
    const char *lsets[] = {"render.spp=64"};
    const char *csets[] = {"render.spp=1024", "render.light=false"};
    lr_render_stats st;
    lr_image *li = lr_test_render(scene, lsets, 1, &st);
    assert_int_equal(st.light_lights, 1);
    lr_image *ci = lr_test_render(scene, csets, 2, NULL);
    double sl = 0.0, sc = 0.0;
    for (size_t i = 0; i < lr_test_n_values(ci); i++)
        sl += li->rgb[i], sc += ci->rgb[i];
    print_message("across the plane: light side %.4g, camera %.4g\n", sl, sc);
    assert_true(sc > 0.0 && fabs(sl / sc - 1.0) < 0.1);
    lr_image_free(li);
    lr_image_free(ci);
}

/* A dim light's disc beside a light 1e8 times brighter, out of the
 * region: the film's fixed point is scaled by the brightest light, and
 * the dim light's splats (some 1e-12 of it) rounded to 0: its disc was
 * black (at 1e6, black from 16384 spp, 0.4% short at 64).  Its energy
 * must be what it is beside a light as dim as itself. */
static void test_dim_light_beside_bright(void **state)
{
    (void)state;
    const char *scene =
        "{\"camera\": {\"model\": \"thinlens\", \"fov\": 40, "
        "\"focus_distance\": 4, \"aperture_radius\": 0.25}, \"render\": "
        "{\"width\": 200, \"height\": 200, \"spp\": 256, \"region\": [70, "
        "70, 130, 130]}, \"background\": 0, \"materials\": {\"dim\": "
        "{\"emission\": 1}, \"bright\": {\"emission\": 1e8}}, "
        "\"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -10], "
        "\"radius\": 0.02, \"material\": \"dim\"}, {\"type\": \"sphere\", "
        "\"center\": [2.5, 2.5, -10], \"radius\": 0.02, \"material\": "
        "\"bright\"}]}";
    const char *dim[] = {"materials.bright={\"emission\": 1}"};
    lr_render_stats st;
    lr_image *a = lr_test_render(scene, NULL, 0, &st);
    assert_int_equal(st.light_lights, 1);
    lr_image *b = lr_test_render(scene, dim, 1, NULL);
    double sa = 0.0, sb = 0.0;
    for (size_t i = 0; i < lr_test_n_values(a); i++)
        sa += a->rgb[i], sb += b->rgb[i];
    print_message("dim disc: %.6g beside 1e8, %.6g beside 1\n", sa, sb);
    assert_true(sb > 0.0 && fabs(sa / sb - 1.0) < 1e-4);
    lr_image_free(a);
    lr_image_free(b);
}

static void test_light_and_camera_agree(void **state)
{
    (void)state;
    const char *lsets[] = {"render.spp=64"};
    const char *csets[] = {"render.spp=8192", "render.light=false",
                           "render.plan=false", "render.adaptive=false"};
    lr_render_stats sc;
    lr_image *li = lr_test_render(discs_scene, lsets, 1, NULL);
    lr_image *ci = lr_test_render(discs_scene, csets, 4, &sc);
    assert_int_equal(sc.light_lights, 0);
    const int boxes[3][4] = {{0, 0, 40, 32}, {30, 32, 70, 64}, {60, 0, 96, 32}};
    const double tol[3] = {0.025, 0.025, 0.025};
    boxes_agree(li, ci, boxes, tol, 3, "disc");
    /* Pixel by pixel: the two differ by the camera's noise only. */
    double rmse = lr_test_rmse(li, ci), mean = 0.0;
    for (size_t i = 0; i < lr_test_n_values(ci); i++)
        mean += ci->rgb[i] / (double)lr_test_n_values(ci);
    print_message("image: RMSE %.4g against a mean of %.4g\n", rmse, mean);
    lr_image_free(li);
    lr_image_free(ci);
}

/* A point of light smaller than a pixel, in focus, through a pinhole: the
 * light side finds it in every sample; its image's film integral is
 * L fpx^2 times the solid angle over cos^3 (R = 0 in the closed form). */
static void test_pinhole_speck(void **state)
{
    (void)state;
    const char *scene =
        "{\"render\": {\"width\": 64, \"height\": 48, \"spp\": 64},"
        " \"camera\": {\"model\": \"pinhole\", \"position\": [0, 0, 10],"
        "  \"look_at\": [0, 0, 0], \"fov\": 40},"
        " \"materials\": {\"a\": {\"emission\": 5000}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [1.3, -0.4, 0],"
        "   \"radius\": 0.004, \"material\": \"a\"}]}";
    lr_render_stats st;
    lr_image *img = lr_test_render(scene, NULL, 0, &st);
    assert_int_equal(st.light_lights, 1);
    double fpx = 0.5 * 48 / tan(20.0 * M_PI / 180.0);
    double want = film_integral(v3(0, 0, 10), v3(0, 0, -1), 0.0,
                                v3(1.3, -0.4, 0), 0.004, 5000, fpx);
    double got = sum_box(img, 0, 0, 64, 48, 0);
    print_message("speck: %.6g, closed form %.6g (%.6f)\n", got, want,
                  got / want);
    assert_true(fabs(got / want - 1.0) < 1e-3);
    lr_image_free(img);
}

/* Splats keep determinism: one thread and two with odd tiles give the
 * same bytes, and a region's pixels are the full frame's (spheres and
 * the environment's sun). */
static void test_light_deterministic(void **state)
{
    (void)state;
    const char *a_sets[] = {"render.spp=32", "render.threads=1"};
    const char *b_sets[] = {"render.spp=32", "render.threads=2",
                            "render.tile_size=7"};
    const char *c_sets[] = {"render.spp=32", "render.threads=2",
                            "render.region=[17,9,80,51]"};
    lr_image *a = lr_test_render(discs_scene, a_sets, 2, NULL);
    lr_image *b = lr_test_render(discs_scene, b_sets, 3, NULL);
    lr_image *c = lr_test_render(discs_scene, c_sets, 3, NULL);
    lr_test_assert_same_bytes(a, b, "1 thread against 2 with 7-pixel tiles");
    assert_int_equal(c->width, 63);
    assert_int_equal(c->height, 42);
    lr_test_assert_region_is_frame(a, c, 17, 9, "region");
    /* A corner holds one light's disc: a farm part there traces that
     * light alone, and its pixels are still the full frame's. */
    const char *d_sets[] = {"render.spp=32", "render.region=[0,0,30,30]"};
    lr_render_stats sd, sa;
    lr_image *d = lr_test_render(discs_scene, d_sets, 2, &sd);
    lr_image_free(lr_test_render(discs_scene, a_sets, 2, &sa));
    print_message("corner region: %llu of %llu lights, %llu of %llu paths\n",
                  (unsigned long long)sd.light_lights,
                  (unsigned long long)sa.light_lights,
                  (unsigned long long)sd.light_paths,
                  (unsigned long long)sa.light_paths);
    assert_int_equal(sd.light_lights, 1);
    assert_true(sd.light_landed > 0);
    lr_test_assert_region_is_frame(a, d, 0, 0, "corner");
    lr_image_free(a);
    lr_image_free(b);
    lr_image_free(c);
    lr_image_free(d);
    /* A part that drops the brightest lights keeps the frame's
     * fixed-point scale (set by the brightest light): through
     * scenes/night.json (radiances 60 to 400) the lower half traced 12 of
     * 24 lights and 42 of its values were an ulp off (an independent
     * check). */
    const char *n_full[] = {"render.width=64", "render.height=48",
                            "render.spp=4"};
    const char *n_part[] = {"render.width=64", "render.height=48",
                            "render.spp=4", "render.region=[0,24,64,48]"};
    lr_image *nf = NULL, *np = NULL;
    for (int k = 0; k < 2; k++) {
        lr_scene *sc = NULL;
        lr_error err;
        assert_int_equal(lr_scene_load_file("scenes/night.json",
                                            k ? n_part : n_full, k ? 4 : 3, &sc,
                                            &err),
                         LR_OK);
        lr_camera cam;
        lr_render_settings rs;
        lr_scene_camera(sc, &cam);
        lr_scene_settings(sc, &rs);
        *(k ? &np : &nf) = lr_test_render_with(sc, &cam, &rs, "night");
        lr_scene_free(sc);
    }
    lr_test_assert_region_is_frame(nf, np, 0, 24, "night's lower half");
    lr_image_free(nf);
    lr_image_free(np);
    /* The environment's sun likewise. */
    lr_test_write_map("sun-sky.exr", sun_sky, 256, 128);
    lr_render_stats ss;
    a = lr_test_render(sun_scene, a_sets, 2, &ss);
    assert_int_equal(ss.light_lights, 1);
    c = lr_test_render(sun_scene, c_sets, 3, NULL);
    lr_test_assert_region_is_frame(a, c, 17, 9, "the sun's region");
    lr_image_free(a);
    lr_image_free(c);
}

/* What the plan sends to the light side: small lights far from focus
 * and lights smaller than a pixel; not a light whose image is large and
 * sharp, nor anything with render.light off, colours that focus apart,
 * or a model without a light side. */
static uint64_t lights_traced(const char *scene, const char *const *sets,
                              size_t n)
{
    lr_render_stats st;
    lr_image *img = lr_test_render(scene, sets, n, &st);
    lr_image_free(img);
    return st.light_lights;
}

static void test_plan_chooses_lights(void **state)
{
    (void)state;
    const char *base[] = {"render.spp=16"};
    assert_int_equal(lights_traced(discs_scene, base, 1), 3);
    const char *off[] = {"render.spp=16", "render.light=false"};
    assert_int_equal(lights_traced(discs_scene, off, 2), 0);
    /* In focus, these lights are smaller than a pixel: still rare. */
    const char *sharp[] = {"render.spp=16", "camera.aperture_radius=0.001"};
    assert_int_equal(lights_traced(discs_scene, sharp, 2), 3);
    const char *rgb[] = {"render.spp=16", "camera.focal_length_mm=50",
                         "camera.chromatic.mode=rgb"};
    assert_int_equal(lights_traced(discs_scene, rgb, 3), 3);
    const char *spectral[] = {"render.spp=16", "camera.focal_length_mm=50",
                              "camera.chromatic.mode=spectral"};
    assert_int_equal(lights_traced(discs_scene, spectral, 3), 3);
    const char *bracket[] = {"render.spp=16", "camera.model=bracket",
                             "camera.aperture=1", "camera.focal_length=9",
                             "camera.image_plane_distance=1"};
    assert_int_equal(lights_traced(discs_scene, bracket, 5), 3);
    /* A big light near focus stays with the camera. */
    const char *big =
        "{\"render\": {\"width\": 64, \"height\": 48, \"spp\": 16},"
        " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
        "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.05,"
        "  \"focus_distance\": 10},"
        " \"materials\": {\"a\": {\"emission\": 5}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],"
        "   \"radius\": 1, \"material\": \"a\"}]}";
    assert_int_equal(lights_traced(big, NULL, 0), 0);
}

/* The light a traced light throws on a surface stays the camera's: a
 * diffuse floor under a small defocused light, with both integrators
 * and the same camera samples (adaptive sampling off), has the same
 * bytes with the light side on and off wherever no camera ray can meet
 * the light (outside the disc's box: the light's pinhole image at about
 * (32, 15) and its blur of 11 pixels' radius). */
static void test_floor_light_unchanged(void **state)
{
    (void)state;
    const char *scene =
        "{\"render\": {\"width\": 64, \"height\": 48, \"spp\": 256,"
        "  \"max_depth\": 2},"
        " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 1, 10],"
        "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.5,"
        "  \"focus_distance\": 5},"
        " \"materials\": {\"a\": {\"emission\": 2000},"
        "   \"f\": {\"diffuse\": 0.5}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 1.5, -5],"
        "   \"radius\": 0.03, \"material\": \"a\"},"
        "  {\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": [0, 1, 0],"
        "   \"material\": \"f\"}]}";
    const char *integrators[] = {"render.integrator=whitted",
                                 "render.integrator=path"};
    for (int k = 0; k < 2; k++) {
        const char *on[] = {integrators[k], "render.adaptive=false"};
        const char *off[] = {integrators[k], "render.light=false",
                             "render.adaptive=false"};
        lr_render_stats s_on;
        lr_image *a = lr_test_render(scene, on, 2, &s_on);
        lr_image *b = lr_test_render(scene, off, 3, NULL);
        assert_int_equal(s_on.light_lights, 1);
        int same = 0, differ_in_disc = 0;
        for (int y = 0; y < 48; y++)
            for (int x = 0; x < 64; x++) {
                int disc = x >= 20 && x < 44 && y >= 3 && y < 27;
                size_t i = 3 * ((size_t)y * 64 + x);
                int eq = memcmp(&a->rgb[i], &b->rgb[i], 3 * sizeof(float)) == 0;
                if (!disc && !eq)
                    fail_msg("%s: pixel (%d, %d) outside the disc differs "
                             "with the light side on",
                             integrators[k], x, y);
                same += eq;
                differ_in_disc += disc && !eq;
            }
        print_message("%s: %d pixels the same, %d of the disc differ\n",
                      integrators[k], same, differ_in_disc);
        assert_true(differ_in_disc > 20);
        lr_image_free(a);
        lr_image_free(b);
    }
}

/* Through a real lens (the double Gauss wide open, focused at 0.6 m):
 * three lights 40 m away, one in the centre and two toward the corners
 * (cat's eyes), traced from the light side through the glass, against
 * the camera alone with every sample traced: each disc's energy within
 * 4% (the camera's noise here is about 1%), and the frame's mean within
 * 2%. */
static void test_real_lens_agrees_with_camera(void **state)
{
    (void)state;
    const char *scene =
        "{\"render\": {\"width\": 64, \"height\": 48, \"seed\": 3},"
        " \"camera\": {\"model\": \"lens\", \"lens\": \"double-gauss-50\","
        "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
        "  \"sensor_width_mm\": 36, \"focus_distance\": 0.6},"
        " \"materials\": {\"l\": {\"emission\": [200, 150, 100]}},"
        " \"objects\": ["
        "  {\"type\": \"sphere\", \"center\": [0, 0, -40], \"radius\": 0.8, "
        "\"material\": \"l\"},"
        "  {\"type\": \"sphere\", \"center\": [-11, 6, -40], \"radius\": 0.8, "
        "\"material\": \"l\"},"
        "  {\"type\": \"sphere\", \"center\": [11, -6, -40], \"radius\": 0.8, "
        "\"material\": \"l\"}]}";
    const char *lsets[] = {"render.spp=1024"};
    const char *csets[] = {"render.spp=2048", "render.light=false",
                           "render.plan=false", "render.adaptive=false"};
    lr_render_stats sl;
    lr_image *li = lr_test_render(scene, lsets, 1, &sl);
    lr_image *ci = lr_test_render(scene, csets, 4, NULL);
    assert_int_equal(sl.light_lights, 3);
    assert_true(sl.light_landed > 0);
    int boxes[3][4] = {{20, 12, 44, 36}, {0, 0, 20, 16}, {44, 32, 64, 48}};
    for (int k = 0; k < 3; k++) {
        double a = sum_box(li, boxes[k][0], boxes[k][1], boxes[k][2],
                           boxes[k][3], 0);
        double b = sum_box(ci, boxes[k][0], boxes[k][1], boxes[k][2],
                           boxes[k][3], 0);
        print_message("lens disc %d: light side %.6g, camera %.6g (%.4f)\n", k,
                      a, b, a / b);
        if (!(b > 0.0 && fabs(a / b - 1.0) < 0.04))
            fail_msg("lens disc %d: light side %.6g, camera %.6g", k, a, b);
    }
    double ma = sum_box(li, 0, 0, 64, 48, 0), mb = sum_box(ci, 0, 0, 64, 48, 0);
    print_message("lens frame: light side %.6g, camera %.6g (%.4f)\n", ma, mb,
                  ma / mb);
    assert_true(fabs(ma / mb - 1.0) < 0.02);
    lr_test_check_finite(li, &sl, "lens light side");
    lr_image_free(li);
    lr_image_free(ci);
}

/* A small light on the axis of a lens stopped down: its image's total
 * against the paraxial closed form L Omega (EFL / p)^2 pixels (the
 * exposure makes display white of the axis's irradiance, and the image
 * of a source filling solid angle Omega covers Omega (EFL / p)^2 pixels
 * of pitch p), within 4% at 1024 spp: the double Gauss (EFL 50.00748 mm
 * as ray-optics has it, make test-lenses) wide open and at f/16 and
 * f/22, and the Zoom-Nikkor 25-50 at 25.5 mm (25.49879 mm, the patent's
 * 25.5 and ray-optics' value) at f/22; and at f/16 a fair share of the
 * light paths land.  The paths were drawn over the whole front, of
 * which a stopped-down pupil takes a sliver: 6 of 432 landed at f/16
 * and the total was 1.33 times the closed form (0 at 256 spp).  The
 * Zoom-Nikkor's pupil at f/22 fell between the footprint's grid points:
 * 0 of 386 paths landed at 256 spp, an empty image. */
static void test_stopped_down_lens_light(void **state)
{
    (void)state;
    static const struct {
        const char *lens, *fn;
        double efl;
    } cases[4] = {
        {"double-gauss-50", "camera.f_number=2", 50.00748},
        {"double-gauss-50", "camera.f_number=16", 50.00748},
        {"double-gauss-50", "camera.f_number=22", 50.00748},
        {"zoom-nikkor-us4189212-25mm-f4", "camera.f_number=22", 25.49879},
    };
    double sin2 = 0.04 / 1e6;
    double omega = 2.0 * M_PI * sin2 / (1.0 + sqrt(1.0 - sin2));
    for (int k = 0; k < 4; k++) {
        char scene[1024];
        snprintf(scene, sizeof scene,
                 "{\"render\": {\"width\": 64, \"height\": 48, \"seed\": 3,"
                 "  \"adaptive\": false},"
                 " \"camera\": {\"model\": \"lens\", \"lens\": \"%s\","
                 "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
                 "  \"sensor_width_mm\": 36, \"focus_distance\": 1e6,"
                 "  \"coating\": \"none\", \"ghosts\": false,"
                 "  \"chromatic\": {\"mode\": \"off\"}},"
                 " \"background\": 0,"
                 " \"materials\": {\"l\": {\"emission\": 1e6}},"
                 " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, "
                 "-1000], \"radius\": 0.2, \"material\": \"l\"}]}",
                 cases[k].lens);
        double want = 1e6 * omega * pow(cases[k].efl / (36.0 / 64.0), 2.0);
        const char *sets[] = {"render.spp=1024", cases[k].fn};
        lr_render_stats st;
        lr_image *img = lr_test_render(scene, sets, 2, &st);
        double got = sum_box(img, 0, 0, 64, 48, 1);
        print_message("%s %s: total %.6g, closed form %.6g (%.4f); %llu of "
                      "%llu paths landed\n",
                      cases[k].lens, cases[k].fn, got, want, got / want,
                      (unsigned long long)st.light_landed,
                      (unsigned long long)st.light_paths);
        assert_int_equal(st.light_lights, 1);
        if (!(fabs(got / want - 1.0) < 0.04))
            fail_msg("%s %s: the light's image holds %.6g, the closed form "
                     "%.6g",
                     cases[k].lens, cases[k].fn, got, want);
        if (k == 1)
            assert_true(st.light_landed * 6 > st.light_paths);
        if (k == 3)
            assert_true(st.light_landed * 20 > st.light_paths);
        lr_test_check_finite(img, &st, "stopped down");
        lr_image_free(img);
    }
}

/* A lens whose first surface is flat (the stop in front of a singlet;
 * a plano-convex lens the flat side forward) meets every ray inside that
 * surface's semi-aperture at any slope, so it has a light side; it had
 * been refused as if it were a fisheye.  A lamp far out of focus: the
 * light side's total within 3% of the camera's own (every sample traced,
 * 2048 spp; its noise here about 1%). */
static void test_flat_front_light_side(void **state)
{
    (void)state;
    const char *lenses[2] = {
        "{\"surfaces\": [{\"stop\": true, \"thickness\": 5, "
        "\"semi_aperture\": 8}, {\"radius\": 51.7, \"thickness\": 6, "
        "\"material\": {\"nd\": 1.5168}, \"semi_aperture\": 12}, "
        "{\"radius\": -51.7, \"thickness\": 0, \"material\": \"air\", "
        "\"semi_aperture\": 12}]}",
        "{\"surfaces\": [{\"radius\": 0, \"thickness\": 6, \"material\": "
        "{\"nd\": 1.5168}, \"semi_aperture\": 12}, {\"radius\": -26, "
        "\"thickness\": 3, \"material\": \"air\", \"semi_aperture\": 12}, "
        "{\"stop\": true, \"thickness\": 0, \"semi_aperture\": 8}]}"};
    for (int k = 0; k < 2; k++) {
        char scene[2048];
        snprintf(scene, sizeof scene,
                 "{\"camera\": {\"model\": \"lens\", \"lens\": %s,"
                 " \"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
                 " \"sensor_width_mm\": 36, \"focus_distance\": 3},"
                 " \"render\": {\"width\": 48, \"height\": 32, \"seed\": 2},"
                 " \"background\": 0,"
                 " \"materials\": {\"l\": {\"emission\": 100}},"
                 " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, "
                 "-0.5], \"radius\": 0.005, \"material\": \"l\"}]}",
                 lenses[k]);
        const char *lsets[] = {"render.spp=256"};
        const char *csets[] = {"render.spp=2048", "render.light=false",
                               "render.plan=false", "render.adaptive=false"};
        lr_render_stats sl;
        lr_image *li = lr_test_render(scene, lsets, 1, &sl);
        lr_image *ci = lr_test_render(scene, csets, 4, NULL);
        double a = sum_box(li, 0, 0, 48, 32, 0),
               b = sum_box(ci, 0, 0, 48, 32, 0);
        print_message("flat front %d: %llu light side lights; light side "
                      "%.6g, camera %.6g (%.4f)\n",
                      k, (unsigned long long)sl.light_lights, a, b, a / b);
        assert_int_equal(sl.light_lights, 1);
        assert_true(b > 0.0 && fabs(a / b - 1.0) < 0.03);
        lr_test_check_finite(li, &sl, "flat front");
        lr_image_free(li);
        lr_image_free(ci);
    }
}

/* Mesh lights: a quad of two triangles (an OBJ mesh, so that the light
 * side draws its triangles by area) tilted toward the camera, and a lone
 * triangle, far behind the focus: each one's energy on the film from the
 * light side at 256 spp against the closed form, within 0.5%. */
static void test_mesh_lights_closed_form(void **state)
{
    (void)state;
    char obj[4096];
    lr_test_write_text("quad.obj",
                       "v -10.15 3.9 -30.03\nv -9.85 3.9 -30.03\n"
                       "v -9.85 4.1 -29.97\nv -10.15 4.1 -29.97\n"
                       "f 1 2 3\nf 1 3 4\n",
                       obj, sizeof obj);
    char scene[8192];
    snprintf(scene, sizeof scene,
             "{\"render\": {\"width\": 96, \"height\": 64, \"seed\": 5},"
             " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
             "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.6,"
             "  \"focus_distance\": 10},"
             " \"materials\": {\"a\": {\"emission\": [300, 200, 100]}},"
             " \"objects\": ["
             "  {\"type\": \"mesh\", \"file\": \"%s\", \"material\": \"a\"},"
             "  {\"type\": \"triangle\", \"vertices\": [[2, -5, -40], [2.4, "
             "-5, -40],"
             "   [2.2, -4.6, -40]], \"material\": \"a\"}]}",
             obj);
    const char *lsets[] = {"render.spp=256"};
    lr_render_stats sl;
    lr_image *li = lr_test_render(scene, lsets, 1, &sl);
    assert_int_equal(sl.light_lights, 2);
    double fpx = 0.5 * 64 / tan(20.0 * M_PI / 180.0);
    lr__v3 q[4] = {v3(-10.15, 3.9, -30.03), v3(-9.85, 3.9, -30.03),
                   v3(-9.85, 4.1, -29.97), v3(-10.15, 4.1, -29.97)};
    double want[2] = {tri_film_integral(0.6, q[0], q[1], q[2], 300, fpx) +
                          tri_film_integral(0.6, q[0], q[2], q[3], 300, fpx),
                      tri_film_integral(0.6, v3(2, -5, -40), v3(2.4, -5, -40),
                                        v3(2.2, -4.6, -40), 300, fpx)};
    int boxes[2][4] = {{0, 0, 40, 32}, {30, 32, 70, 64}};
    const char *names[] = {"quad mesh", "triangle"};
    for (int k = 0; k < 2; k++) {
        double got = sum_box(li, boxes[k][0], boxes[k][1], boxes[k][2],
                             boxes[k][3], 0);
        print_message("%s: light side %.6g, closed form %.6g (%.5f)\n",
                      names[k], got, want[k], got / want[k]);
        if (!(fabs(got / want[k] - 1.0) < 0.005))
            fail_msg("%s: light side %.6g, closed form %.6g", names[k], got,
                     want[k]);
    }
    lr_image_free(li);
}

/* Sparkles: two small lights above the frame, seen in a rough metal
 * plane (GGX alpha 0.05) far behind the focus: each glint is a
 * defocused disc 20 to 30 pixels across. */
static const char *glint_scene =
    "{\"render\": {\"width\": 48, \"height\": 36, \"integrator\": \"path\","
    "  \"max_depth\": 1, \"seed\": 3},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 2, 2],"
    "  \"look_at\": [0, 0, -1], \"fov\": 30, \"aperture_radius\": 0.1,"
    "  \"focus_distance\": 0.6},"
    " \"materials\": {\"g\": {\"reflect\": [0.9, 0.8, 0.6], \"roughness\": "
    "0.05},"
    "   \"l\": {\"emission\": 3000}},"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [0, 0, -2], \"normal\": [0, 1, 0],"
    "   \"size\": [8, 8], \"material\": \"g\"},"
    "  {\"type\": \"sphere\", \"center\": [-0.6, 1.2, -3.5], \"radius\": 0.02, "
    "\"material\": \"l\"},"
    "  {\"type\": \"sphere\", \"center\": [0.7, 0.9, -4], \"radius\": 0.02, "
    "\"material\": \"l\"}]}";

/* The glints from the light side (their cores; the camera keeps the
 * tails and everything else) against the camera alone, every sample
 * traced: the same energy in each quarter of the frame and in the
 * whole, within the camera's noise (2048 spp: about 1% in a quarter).
 * Counting a glint twice (the camera not leaving the light side's part)
 * or a wrong density (the Jacobian of the mirror-point map) would be
 * tens of percent. */
/* The glints of scene from the light side against the camera alone,
 * as test_glints_agree_with_camera says: each quarter of the frame
 * within quarter_tol, the whole within 1.5%; `what` names it. */
static void glints_agree(const char *scene, double quarter_tol,
                         const char *what)
{
    const char *lsets[] = {"render.spp=128"};
    const char *csets[] = {"render.spp=2048", "render.light=false",
                           "render.plan=false", "render.adaptive=false"};
    lr_render_stats sl, sc;
    lr_image *li = lr_test_render(scene, lsets, 1, &sl);
    lr_image *ci = lr_test_render(scene, csets, 4, &sc);
    assert_int_equal(sc.light_lights, 0);
    print_message("%s: %llu light entries, %llu paths, %llu landed\n", what,
                  (unsigned long long)sl.light_lights,
                  (unsigned long long)sl.light_paths,
                  (unsigned long long)sl.light_landed);
    assert_true(sl.light_lights >= 2);
    const int boxes[5][4] = {{0, 0, 24, 18},
                             {24, 0, 48, 18},
                             {0, 18, 24, 36},
                             {24, 18, 48, 36},
                             {0, 0, 48, 36}};
    const double q = quarter_tol, tol[5] = {q, q, q, q, 0.015};
    boxes_agree(li, ci, boxes, tol, 5, what);
    lr_image_free(li);
    lr_image_free(ci);
}

static void test_glints_agree_with_camera(void **state)
{
    (void)state;
    glints_agree(glint_scene, 0.03, "sphere lights");
}

/* The same with a triangle light (facing the plane: the camera sees its
 * back, which emits nothing, and its glint) and a sphere light with an
 * emission texture (stripes), whose glint paths look the emission up
 * where they meet it.  The dimmest quarter holds about 4% of the frame:
 * over render.seed 3, 4 and 5 the two sides differed there by +0.1%,
 * -4.5% and +0.4% (the camera's values spread 4%), elsewhere by at most
 * 2.3%, the whole by at most 0.6%: each quarter within 6%.  Not
 * looking the emission up (its mean is 0.55 of its largest) put the
 * textured glint's quarter 61% high and the frame 28%. */
static void test_glints_mesh_and_textured(void **state)
{
    (void)state;
    lr_test_write_map("glint-stripes.exr", stripes, 64, 32);
    const char *scene =
        "{\"render\": {\"width\": 48, \"height\": 36, \"integrator\": \"path\","
        "  \"max_depth\": 1, \"seed\": 3},"
        " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 2, 2],"
        "  \"look_at\": [0, 0, -1], \"fov\": 30, \"aperture_radius\": 0.1,"
        "  \"focus_distance\": 0.6},"
        " \"materials\": {\"g\": {\"reflect\": [0.9, 0.8, 0.6], \"roughness\": "
        "0.05},"
        "   \"l\": {\"emission\": 3000},"
        "   \"t\": {\"emission\": 3000, \"emission_texture\": "
        "\"glint-stripes.exr\"}},"
        " \"objects\": ["
        "  {\"type\": \"plane\", \"point\": [0, 0, -2], \"normal\": [0, 1, 0],"
        "   \"size\": [8, 8], \"material\": \"g\"},"
        "  {\"type\": \"triangle\", \"vertices\": [[-0.63, 1.2, -3.52],"
        "   [-0.57, 1.2, -3.52], [-0.6, 1.2, -3.46]], \"material\": \"l\"},"
        "  {\"type\": \"sphere\", \"center\": [0.7, 0.9, -4], \"radius\": "
        "0.02, "
        "\"material\": \"t\"}]}";
    glints_agree(scene, 0.06, "triangle and textured lights");
}

/* Glints keep determinism too, and go to the light side only where the
 * scene calls for it: the path tracer, a flat rough conductor, small
 * lights. */
static void test_glints_deterministic_and_planned(void **state)
{
    (void)state;
    const char *a_sets[] = {"render.spp=16", "render.threads=1"};
    const char *b_sets[] = {"render.spp=16", "render.threads=2",
                            "render.tile_size=7"};
    const char *c_sets[] = {"render.spp=16", "render.region=[5,7,40,30]"};
    lr_render_stats st;
    lr_image *a = lr_test_render(glint_scene, a_sets, 2, &st);
    lr_image *b = lr_test_render(glint_scene, b_sets, 3, NULL);
    lr_image *c = lr_test_render(glint_scene, c_sets, 2, NULL);
    lr_test_assert_same_bytes(a, b,
                              "glints: 1 thread against 2, 7-pixel tiles");
    lr_test_assert_region_is_frame(a, c, 5, 7, "glint region");
    uint64_t with = st.light_lights;
    const char *whitted[] = {"render.spp=16", "render.integrator=whitted"};
    const char *matte[] = {"render.spp=16", "materials.g.roughness=0",
                           "materials.g.diffuse=0.5"};
    const char *broad[] = {"render.spp=16", "materials.g.roughness=0.5"};
    uint64_t w = lights_traced(glint_scene, whitted, 2);
    print_message("light entries: %llu (glints); whitted %llu, matte %llu, "
                  "alpha 0.5 %llu\n",
                  (unsigned long long)with, (unsigned long long)w,
                  (unsigned long long)lights_traced(glint_scene, matte, 3),
                  (unsigned long long)lights_traced(glint_scene, broad, 2));
    assert_int_equal(with, w + 2);
    assert_int_equal(lights_traced(glint_scene, matte, 3), w);
    assert_int_equal(lights_traced(glint_scene, broad, 2), w);
    lr_image_free(a);
    lr_image_free(b);
    lr_image_free(c);
}

/* A lens whose front disk cannot be bounded below the slope of 4 that
 * the light side once assumed (test_camera_lens.c's
 * test_front_disk_covers finds rays through these three lenses steeper
 * than that) keeps its lights with the camera: light paths drawn from
 * that disk would miss light the camera sees.  The double Gauss, bounded,
 * keeps its light side. */
static void test_unbounded_lenses_keep_lights(void **state)
{
    (void)state;
    const char *lenses[] = {"double-gauss-50", "fisheye-10",
                            "fisheye-minolta-us4256373-16mm-f2.8",
                            "wide-170deg-laikin-5mm-f1.8"};
    for (int i = 0; i < 4; i++) {
        char scene[1024];
        snprintf(
            scene, sizeof scene,
            "{\"render\": {\"width\": 32, \"height\": 24, \"spp\": 4},"
            " \"camera\": {\"model\": \"lens\", \"lens\": \"%s\","
            "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
            "  \"focus_distance\": 0.6},"
            " \"materials\": {\"l\": {\"emission\": 500}},"
            " \"objects\": [{\"type\": \"sphere\", \"center\": [0.5, 0.3, -40],"
            "   \"radius\": 0.05, \"material\": \"l\"}]}",
            lenses[i]);
        uint64_t n = lights_traced(scene, NULL, 0);
        print_message("%s: %llu lights from the light side\n", lenses[i],
                      (unsigned long long)n);
        if (i == 0)
            assert_int_equal(n, 1);
        else
            assert_int_equal(n, 0);
        /* Ghosts asked for by name through such a lens: an error naming
         * camera.ghosts (it rendered none without a word). */
        const char *on[] = {"camera.ghosts=true"};
        lr_scene *sc = lr_test_load(scene, on, 1);
        lr_camera cam;
        lr_render_settings rs;
        lr_scene_camera(sc, &cam);
        lr_scene_settings(sc, &rs);
        lr_image *img = NULL;
        lr_error err;
        lr_status st = lr_render(sc, &cam, &rs, &img, NULL, &err);
        if (i == 0) {
            assert_int_equal(st, LR_OK);
        } else {
            assert_int_equal(st, LR_ERR_INVALID);
            assert_string_equal(err.path, "camera.ghosts");
        }
        lr_image_free(img);
        lr_scene_free(sc);
    }
}

/* Dark blocks (plan.h): the blocks of scene (with sets) whose camera
 * samples the plan knows to be 0; *total gets the blocks of the frame. */
static int dark_blocks(const char *scene, const char *const *sets, size_t n,
                       int *total)
{
    lr__cam c;
    lr__plan p;
    lr_scene *s = lr_test_plan(scene, sets, n, &c, &p, NULL);
    int d = 0;
    for (int i = 0; i < p.bw * p.bh; i++)
        d += p.blocks[i].dark;
    *total = p.bw * p.bh;
    lr__plan_free(&p);
    lr_scene_free(s);
    return d;
}

/* Lights on the light side against a black sky give camera rays nothing:
 * the plan marks their blocks dark and the camera traces no ray there,
 * and the image is the same bytes as with every camera sample traced
 * (render.plan off), through the thin lens and a real lens.  Whatever
 * gives camera paths light keeps its blocks: a lit background, a light
 * that also reflects, lights left to the camera (render.light off, or a
 * lens whose light side is off). */
static void test_dark_blocks(void **state)
{
    (void)state;
    const char *lens_scene =
        "{\"render\": {\"width\": 48, \"height\": 32, \"spp\": 16},"
        " \"camera\": {\"model\": \"lens\", \"lens\": \"double-gauss-50\","
        "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
        "  \"focus_distance\": 0.6},"
        " \"materials\": {\"l\": {\"emission\": 500}, \"k\": {}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0.5, 0.3, -40],"
        "   \"radius\": 0.05, \"material\": \"l\"},"
        "  {\"type\": \"sphere\", \"center\": [-2, 0, -30],"
        "   \"radius\": 1, \"material\": \"k\"}]}";
    const char *scenes[] = {discs_scene, lens_scene};
    for (int k = 0; k < 2; k++) {
        int total, d = dark_blocks(scenes[k], NULL, 0, &total);
        assert_int_equal(d, total);
        const char *on[] = {"render.spp=32"};
        const char *off[] = {"render.spp=32", "render.plan=false"};
        lr_render_stats son, soff;
        lr_image *a = lr_test_render(scenes[k], on, 1, &son);
        lr_image *b = lr_test_render(scenes[k], off, 2, &soff);
        print_message("scene %d: camera rays %llu planned, %llu not\n", k,
                      (unsigned long long)son.camera_rays,
                      (unsigned long long)soff.camera_rays);
        assert_true(son.light_landed > 0);
        assert_int_equal(son.camera_rays, 0);
        assert_true(soff.camera_rays > 0);
        lr_test_assert_same_bytes(a, b, "dark blocks against every sample");
        lr_image_free(a);
        lr_image_free(b);
    }
    int total, d;
    const char *grey[] = {"background=0.05"};
    assert_int_equal(dark_blocks(discs_scene, grey, 1, &total), 0);
    /* A black ball in front of the lights (no lobe, no emission). */
    char ball[2048];
    size_t len = strlen(discs_scene);
    snprintf(ball, sizeof ball,
             "%.*s, {\"type\": \"sphere\", \"center\": [0, 0, -20], "
             "\"radius\": 3, \"material\": \"k\"}]}",
             (int)len - 2, discs_scene);
    const char *black[] = {"materials.k={}"};
    d = dark_blocks(ball, black, 1, &total);
    assert_int_equal(d, total);
    const char *reflects[] = {"materials.a.diffuse=0.5"};
    const char *camera_lights[] = {"render.light=false"};
    const char *fisheye[] = {"camera.lens=fisheye-10"};
    int d1 = dark_blocks(discs_scene, reflects, 1, &total);
    int d2 = dark_blocks(discs_scene, camera_lights, 1, &total);
    int lens_total, d3 = dark_blocks(lens_scene, fisheye, 1, &lens_total);
    print_message("dark blocks: %d of %d with reflecting lights, %d with the "
                  "camera's lights; %d of %d through the fisheye\n",
                  d1, total, d2, d3, lens_total);
    /* The blocks that reach no light stay dark (nothing there at all). */
    assert_true(d1 > 0 && d1 < total);
    assert_true(d2 > 0 && d2 < d1);
    assert_int_equal(d3, 0);
}

/* A light blurred over far more than the frame (a thin lens focused
 * 1 cm from the eye, the light 8 m away) traces at most 64 frames' area
 * of paths: the count grew with the disc's area (2.4 million paths here,
 * and without end nearer: focused at 1e-6 the render ran for minutes),
 * almost none of them landing.  At 3 cm the disc is under the cap and
 * its count as before. */
static void test_huge_disc_paths_bounded(void **state)
{
    (void)state;
    const char *scene =
        "{\"camera\": {\"model\": \"thinlens\", \"fov\": 40,"
        "  \"aperture_radius\": 0.1, \"focus_distance\": 0.01},"
        " \"render\": {\"width\": 48, \"height\": 32, \"spp\": 8},"
        " \"materials\": {\"e\": {\"emission\": 3}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -8],"
        "  \"radius\": 0.1, \"material\": \"e\"}]}";
    lr_render_stats st;
    lr_image *img = lr_test_render(scene, NULL, 0, &st);
    print_message("focused at 1 cm: %llu light paths, %llu landed\n",
                  (unsigned long long)st.light_paths,
                  (unsigned long long)st.light_landed);
    assert_int_equal(st.light_lights, 1);
    /* spp x 64 frames x 0.5 paths a pixel. */
    assert_true(st.light_paths <= 8ull * 64 * 48 * 32 / 2);
    lr_image_free(img);
    const char *nearer[] = {"camera.focus_distance=0.03"};
    img = lr_test_render(scene, nearer, 1, &st);
    assert_true(st.light_paths > 200000 && st.light_landed > 1000);
    lr_image_free(img);
}

static const struct CMUnitTest light_tests[] = {
    cmocka_unit_test(test_bracket_light_across_plane),
    cmocka_unit_test(test_dim_light_beside_bright),
    cmocka_unit_test(test_unbounded_lenses_keep_lights),
    cmocka_unit_test(test_dark_blocks),
    cmocka_unit_test(test_huge_disc_paths_bounded),
    cmocka_unit_test(test_bracket_light_side),
    cmocka_unit_test(test_rgb_light_side),
    cmocka_unit_test(test_bracket_rgb_light_side),
    cmocka_unit_test(test_spectral_light_side),
    cmocka_unit_test(test_env_sun_light_side),
    cmocka_unit_test(test_textured_light_side),
    cmocka_unit_test(test_glints_agree_with_camera),
    cmocka_unit_test(test_glints_mesh_and_textured),
    cmocka_unit_test(test_glints_deterministic_and_planned),
    cmocka_unit_test(test_mesh_lights_closed_form),
    cmocka_unit_test(test_real_lens_agrees_with_camera),
    cmocka_unit_test(test_stopped_down_lens_light),
    cmocka_unit_test(test_flat_front_light_side),
    cmocka_unit_test(test_disc_energy_closed_form),
    cmocka_unit_test(test_light_and_camera_agree),
    cmocka_unit_test(test_pinhole_speck),
    cmocka_unit_test(test_light_deterministic),
    cmocka_unit_test(test_plan_chooses_lights),
    cmocka_unit_test(test_floor_light_unchanged),
};
LR_TEST_GROUP(light_trace, light_tests)
