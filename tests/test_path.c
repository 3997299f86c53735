/*
 * test_path.c: the path integrator against closed forms, not against its
 * own output:
 *   - the white furnace: a diffuse sphere of albedo 1 under a uniform sky
 *     of radiance L is L everywhere;
 *   - a closed box of albedo a whose walls emit Le: with max_depth n the
 *     camera sees Le (1 + a + ... + a^(n+1)) (every bounce stays inside);
 *   - a diffuse plane under a uniform sky: albedo x L;
 *   - a plane under an environment map: (albedo / pi) x the map's
 *     cosine-weighted integral over the upper hemisphere, by quadrature
 *     of the map as documented (exercises the map's mapping, lookup,
 *     sampling density and MIS);
 *   - a floor under a lamp far from the origin: a sphere, pi Le (r/d)^2
 *     cos; the same tessellated, Lambert's formula per triangle;
 *   - a small emitter through the thin lens: its blur is the circle of
 *     confusion, C = 2 r |1/Z - 1/s| f_px;
 *   - GGX: the visible-normal density integrates to 1 (Heitz 2014's weak
 *     white furnace), and sampled rough lobes agree with their evaluated
 *     albedo (quadrature of f cos);
 *   - every Embree ISA gives the same picture (and none aborts on a
 *     masked-off lane);
 *   - bad input names its field and file.
 */
#include "test.h"
#include "box_scene.h"
#include "integrator/bsdf.h"
#include "integrator/path.h"
#include "sampling/sampler.h"
#include "accel/trace.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Mean and largest relative deviation from `want` over every value of
 * channel 0..2 of img inside the pixel rectangle [x0, x1) x [y0, y1). */
static void deviation(const lr_image *img, int x0, int y0, int x1, int y1,
                      double want, double *mean_rel, double *max_rel)
{
    const float *p = lr_image_rgb(img);
    int w = lr_image_width(img);
    double sum = 0.0, mx = 0.0;
    size_t n = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            for (int c = 0; c < 3; c++) {
                double v = p[3 * (y * w + x) + c];
                sum += v;
                mx = fmax(mx, fabs(v - want) / want);
                n++;
            }
    *mean_rel = (sum / n - want) / want;
    *max_rel = mx;
}

static void expect(const lr_image *img, int x0, int y0, int x1, int y1,
                   double want, double tol_mean, double tol_pixel,
                   const char *what)
{
    double mean_rel, max_rel;
    deviation(img, x0, y0, x1, y1, want, &mean_rel, &max_rel);
    print_message("  %-40s want %.6g: mean %+.4f%%, worst pixel %.3f%%\n", what,
                  want, 100 * mean_rel, 100 * max_rel);
    if (!(fabs(mean_rel) <= tol_mean) || !(max_rel <= tol_pixel))
        fail_msg("%s: mean off by %.4f%% (allowed %.3f%%), worst pixel "
                 "%.3f%% (allowed %.2f%%)",
                 what, 100 * mean_rel, 100 * tol_mean, 100 * max_rel,
                 100 * tol_pixel);
}

/* ---- white furnace ---------------------------------------------------- */

/* The sphere fills the middle of the frame; the corners see the sky. */
static void test_white_furnace(void **state)
{
    (void)state;
    const char *json =
        "{\"render\": {\"width\": 12, \"height\": 12, \"spp\": 4096,"
        "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 8},"
        " \"camera\": {\"position\": [0, 0, 4], \"look_at\": [0, 0, 0],"
        "  \"fov\": 20},"
        " \"background\": 0.5,"
        " \"materials\": {\"w\": {\"diffuse\": 1}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],"
        "  \"radius\": 1, \"material\": \"w\"}]}";
    lr_image *img = lr_test_render_json(json, "white furnace");
    expect(img, 0, 0, 12, 12, 0.5, 1e-3, 1e-2, "white furnace, albedo 1");
    lr_image_free(img);
}

/* Glass of ior 1, rough or smooth, under a white sky: equal indices are
 * no interface, so the sphere is invisible (1 everywhere).  The rough
 * lobe's half vector wo + eta wi was zero for every refraction, and the
 * sphere rendered 0.26 (a glTF ior of 0, read as 1, too). */
static void test_ior_one_is_invisible(void **state)
{
    (void)state;
    const char *json =
        "{\"render\": {\"width\": 12, \"height\": 12, \"spp\": 64,"
        "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 64},"
        " \"camera\": {\"position\": [0, 0, 4], \"look_at\": [0, 0, 0],"
        "  \"fov\": 20},"
        " \"background\": 1,"
        " \"materials\": {\"g\": {\"transmit\": 1, \"ior\": 1, \"roughness\": "
        "0.3}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],"
        "  \"radius\": 1, \"material\": \"g\"}]}";
    lr_image *img = lr_test_render_json(json, "rough glass of ior 1");
    expect(img, 0, 0, 12, 12, 1.0, 1e-6, 1e-6, "rough glass, ior 1");
    lr_image_free(img);
}

/* ---- the emitting box ------------------------------------------------- */

/* Six inward-facing walls of the cube [-1, 1]^3 (the camera inside), of
 * albedo a and emission Le. */
static void box_scene(char *buf, size_t n, double a, int depth, int spp)
{
    static const char *const walls[6] = {"[0, -1, 0], \"normal\": [0, 1, 0]",
                                         "[0, 1, 0], \"normal\": [0, -1, 0]",
                                         "[-1, 0, 0], \"normal\": [1, 0, 0]",
                                         "[1, 0, 0], \"normal\": [-1, 0, 0]",
                                         "[0, 0, -1], \"normal\": [0, 0, 1]",
                                         "[0, 0, 1], \"normal\": [0, 0, -1]"};
    int k = snprintf(buf, n,
                     "{\"render\": {\"width\": 8, \"height\": 8, \"spp\": %d,"
                     "  \"integrator\": \"path\", \"adaptive\": false,"
                     "  \"max_depth\": %d},"
                     " \"camera\": {\"position\": [0.1, 0.2, 0.3],"
                     "  \"look_at\": [1, 0.5, -1], \"fov\": 90},"
                     " \"materials\": {\"w\": {\"diffuse\": %g,"
                     "  \"emission\": 1}},"
                     " \"objects\": [",
                     spp, depth, a);
    for (int i = 0; i < 6; i++)
        k += snprintf(buf + k, n - (size_t)k,
                      "%s{\"type\": \"plane\", \"point\": %s, \"size\": 2,"
                      " \"material\": \"w\"}",
                      i ? ", " : "", walls[i]);
    snprintf(buf + k, n - (size_t)k, "]}");
}

static void test_emitting_box(void **state)
{
    (void)state;
    const int depths[] = {0, 1, 3, 6, 64};
    for (int i = 0; i < 5; i++) {
        char json[2048], what[64];
        box_scene(json, sizeof json, 0.5, depths[i], 4096);
        lr_image *img = lr_test_render_json(json, "emitting box");
        /* Le (1 - a^(n+2)) / (1 - a): the geometric sum. */
        double want = (1.0 - pow(0.5, depths[i] + 2)) / 0.5;
        snprintf(what, sizeof what, "box, albedo 0.5, max_depth %d", depths[i]);
        expect(img, 0, 0, 8, 8, want, 2e-3, 3e-2, what);
        lr_image_free(img);
    }
}

/* ---- a plane under the sky -------------------------------------------- */

static void test_plane_under_sky(void **state)
{
    (void)state;
    const char *json =
        "{\"render\": {\"width\": 16, \"height\": 8, \"spp\": 1024,"
        "  \"integrator\": \"path\", \"adaptive\": false},"
        " \"camera\": {\"position\": [0, 1, 0], \"look_at\": [0, 0, -1],"
        "  \"fov\": 30},"
        " \"background\": [2, 1, 0.5],"
        " \"materials\": {\"g\": {\"diffuse\": 0.3}},"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 0],"
        "  \"normal\": [0, 1, 0], \"material\": \"g\"}]}";
    lr_image *img = lr_test_render_json(json, "plane under sky");
    /* Channel by channel: albedo x L. */
    const float *p = lr_image_rgb(img);
    const double L[3] = {2, 1, 0.5};
    double worst = 0.0;
    for (int i = 0; i < 16 * 8; i++)
        for (int c = 0; c < 3; c++)
            worst = fmax(worst, fabs(p[3 * i + c] - 0.3 * L[c]) / (0.3 * L[c]));
    print_message("  plane under a uniform sky: worst pixel %.4f%% off "
                  "albedo x L\n",
                  100 * worst);
    if (!(worst <= 1e-2))
        fail_msg("plane under a uniform sky: a pixel is %.3f%% off albedo x L",
                 100 * worst);
    lr_image_free(img);
}

/* ---- a plane under an environment map --------------------------------- */

#define ENV_W 32
#define ENV_H 16

/* The map: 1 everywhere, 40 in a patch above the horizon. */
static double env_value(int x, int y)
{
    return (x >= 5 && x < 9 && y >= 3 && y < 6) ? 40.0 : 1.0;
}

/* The irradiance on a plane facing +y under a W x H map of values
 * value(x, y) (grey), as documented (texels at u = (x + 0.5) / W and
 * v = y / (H - 1), as Mitsuba 3 places them, bilinear between them,
 * wrapping in u; v = theta / pi from +y): the lookup integrated with
 * cos(theta) over the upper hemisphere by the midpoint rule. */
static double irradiance_up(double (*value)(int x, int y), int W, int H)
{
    double E = 0.0;
    const int NT = 1024, NP = 2048;
    for (int i = 0; i < NT; i++) {
        double th = (M_PI / 2) * (i + 0.5) / NT;
        double y = th / M_PI * (H - 1);
        int y0 = (int)floor(y);
        double ty = y - y0;
        int ya = y0 < 0 ? 0 : y0, yb = y0 + 1 >= H ? H - 1 : y0 + 1;
        double row = 0.0;
        for (int j = 0; j < NP; j++) {
            double x = (j + 0.5) / NP * W - 0.5;
            int x0 = (int)floor(x);
            double tx = x - x0;
            int xa = (x0 + W) % W, xb = (x0 + 1) % W;
            row += (1 - ty) * ((1 - tx) * value(xa, ya) + tx * value(xb, ya)) +
                   ty * ((1 - tx) * value(xa, yb) + tx * value(xb, yb));
        }
        E += row / NP * 2 * M_PI * cos(th) * sin(th) * (M_PI / 2) / NT;
    }
    return E;
}

static void test_plane_under_envmap(void **state)
{
    (void)state;
    lr_test_write_map("env.exr", env_value, ENV_W, ENV_H);
    double E = irradiance_up(env_value, ENV_W, ENV_H);
    double want = 0.5 / M_PI * E;
    const char *json =
        "{\"render\": {\"width\": 8, \"height\": 8, \"spp\": 2048,"
        "  \"integrator\": \"path\", \"adaptive\": false},"
        " \"camera\": {\"position\": [0, 1, 0], \"look_at\": [0, 0, 0.01],"
        "  \"fov\": 20},"
        " \"environment\": {\"file\": \"env.exr\"},"
        " \"materials\": {\"g\": {\"diffuse\": 0.5}},"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 0],"
        "  \"normal\": [0, 1, 0], \"material\": \"g\"}]}";
    lr_image *img = lr_test_render_json(json, "plane under envmap");
    expect(img, 0, 0, 8, 8, want, 3e-3, 3e-2, "plane under an environment map");
    lr_image_free(img);

    /* Turned by 90 degrees about +y, the patch moves but the plane's
     * irradiance does not. */
    const char *sets[] = {"environment.rotation_deg=90",
                          "environment.intensity=2"};
    img = lr_test_render_sets(json, sets, 2, "rotated envmap");
    expect(img, 0, 0, 8, 8, 2 * want, 3e-3, 3e-2,
           "the same map turned 90 degrees, x 2");
    lr_image_free(img);
}

/* Sets both windows of the EXR file `path` to [0, w-1] x [0, h-1] (its
 * pixel data stays a 2 x 1 image's: the header alone claims the size). */
static void claim_size(const char *path, int w, int h)
{
    FILE *f = fopen(path, "r+b");
    assert_non_null(f);
    unsigned char buf[4096];
    size_t n = fread(buf, 1, sizeof buf, f);
    const char *names[2] = {"dataWindow", "displayWindow"};
    for (int k = 0; k < 2; k++) {
        size_t len = strlen(names[k]) + 1;
        size_t at = 0;
        while (at + len + 6 + 4 + 16 <= n &&
               (memcmp(buf + at, names[k], len) != 0 ||
                memcmp(buf + at + len, "box2i", 6) != 0))
            at++;
        assert_true(at + len + 6 + 4 + 16 <= n);
        int32_t box[4] = {0, 0, w - 1, h - 1}; /* little-endian host */
        memcpy(buf + at + len + 6 + 4, box, sizeof box);
    }
    rewind(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
}

static double one_value(int x, int y)
{
    (void)x, (void)y;
    return 1.0;
}

/* An environment map whose header claims 16384 x 16384 is refused from
 * the header, naming the file: decoded, with its sampling tables, it
 * would take 6 GB (a small file could ask a daemon for that); a lat-long
 * map 16384 x 8192 is within the cap (its error, here, is the data's). */
static void test_envmap_too_many_texels(void **state)
{
    (void)state;
    char path[1024];
    snprintf(path, sizeof path, "%s/huge.exr", lr_test_tmpdir());
    const char *json = "{\"environment\": {\"file\": \"huge.exr\"}, "
                       "\"objects\": []}";
    for (int k = 0; k < 2; k++) {
        lr_test_write_map("huge.exr", one_value, 2, 1);
        claim_size(path, 16384, k == 0 ? 16384 : 8192);
        lr_scene *sc = NULL;
        lr_error err;
        memset(&err, 0, sizeof err);
        assert_int_not_equal(lr_scene_load_json(json, strlen(json),
                                                lr_test_tmpdir(), NULL, 0, &sc,
                                                &err),
                             LR_OK);
        assert_non_null(strstr(err.message, "huge.exr"));
        if (k == 0)
            assert_non_null(strstr(err.message, "16384 x 16384 pixels; an "
                                                "environment map may have "
                                                "at most 134217728"));
        else
            assert_null(strstr(err.message, "at most"));
    }
}

/* A sun of one texel, 40000 times its sky, over a plane: the light
 * that lookup spreads from the sun texel into its neighbours' cells must
 * be sampled too, or BSDF samples find it with little density and the
 * pixels settle slowly (at 512 spp the pixels' rms error was 7.7% and
 * the mean 0.6% low when cells were weighted by their own texel; 1.6%
 * and 0.03% now). */
static double sun_value(int x, int y)
{
    return x == 20 && y == 3 ? 2000.0 : 0.05;
}

static void test_envmap_one_texel_sun(void **state)
{
    (void)state;
    lr_test_write_map("sun.exr", sun_value, ENV_W, ENV_H);
    double want = 0.5 / M_PI * irradiance_up(sun_value, ENV_W, ENV_H);
    const char *json =
        "{\"render\": {\"width\": 8, \"height\": 8, \"spp\": 512,"
        "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 0},"
        " \"camera\": {\"position\": [0, 1, 0], \"look_at\": [0, 0, 0.01],"
        "  \"fov\": 20},"
        " \"environment\": {\"file\": \"sun.exr\"},"
        " \"materials\": {\"g\": {\"diffuse\": 0.5}},"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 0],"
        "  \"normal\": [0, 1, 0], \"material\": \"g\"}]}";
    lr_image *img = lr_test_render_json(json, "one-texel sun");
    /* The root mean square of the pixels' relative errors: noise, which
     * the sampling is about, more steadily than the worst pixel. */
    const float *p = lr_image_rgb(img);
    double sum = 0.0, sq = 0.0;
    for (int i = 0; i < 8 * 8 * 3; i++) {
        sum += p[i] / want - 1.0;
        sq += (p[i] / want - 1.0) * (p[i] / want - 1.0);
    }
    double mean = sum / (8 * 8 * 3), rms = sqrt(sq / (8 * 8 * 3));
    print_message("  plane under a one-texel sun: want %.6g, mean %+.3f%%, "
                  "rms %.3f%%\n",
                  want, 100 * mean, 100 * rms);
    if (!(fabs(mean) <= 3e-3) || !(rms <= 3.5e-2))
        fail_msg("plane under a one-texel sun: mean %+.3f%%, rms %.3f%% "
                 "(allowed 0.3%%, 3.5%%)",
                 100 * mean, 100 * rms);
    lr_image_free(img);
}

/* Where the map's texels lie, seen directly: a map whose red is its row
 * index and whose green is its column index renders, through each
 * pixel's centre, red v (H - 1) and green u W - 1/2 (linear ramps, so
 * bilinear lookup is exact), v = acos(d.y) / pi and u = atan2(d.x, -d.z)
 * / (2 pi) of the pixel's direction d: texels where Mitsuba 3's envmap
 * puts them (its eval_spectrum), the first row at the +y pole.  Looking
 * up and towards +x (u about 1/4, away from the seam). */
static void test_envmap_texel_places(void **state)
{
    (void)state;
    enum { MW = 16, MH = 8, N = 24 };
    lr_image *map = NULL;
    assert_int_equal(lr_image_create(MW, MH, 0, &map, NULL), LR_OK);
    float *px = lr_image_rgb_mut(map);
    for (int y = 0; y < MH; y++)
        for (int x = 0; x < MW; x++) {
            px[3 * (y * MW + x)] = (float)y;
            px[3 * (y * MW + x) + 1] = (float)x;
            px[3 * (y * MW + x) + 2] = 0.0f;
        }
    char path[1024];
    snprintf(path, sizeof path, "%s/ramp.exr", lr_test_tmpdir());
    assert_int_equal(lr_image_write(map, path, NULL, NULL), LR_OK);
    lr_image_free(map);
    char json[512];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": 1,"
             "  \"sampler\": \"grid\"},"
             " \"camera\": {\"position\": [0, 0, 0], \"look_at\": [1, 1, 0],"
             "  \"fov\": 90},"
             " \"environment\": {\"file\": \"ramp.exr\"}}",
             N, N);
    lr_image *img = lr_test_render_json(json, "ramp map");
    const float *rgb = lr_image_rgb(img);
    /* The pinhole's frame (scene-format.md, 6): right = f x up, its up
     * = right x f; fov 90, so tan(fov / 2) = 1. */
    const double f[3] = {M_SQRT1_2, M_SQRT1_2, 0};
    const double r[3] = {0, 0, 1};
    const double up[3] = {-M_SQRT1_2, M_SQRT1_2, 0};
    double worst_r = 0.0, worst_g = 0.0;
    int n_g = 0;
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) {
            double X = 2.0 * (x + 0.5) / N - 1.0, Y = 1.0 - 2.0 * (y + 0.5) / N;
            double d[3];
            for (int k = 0; k < 3; k++)
                d[k] = f[k] + X * r[k] + Y * up[k];
            double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            double v = acos(d[1] / len) / M_PI;
            double u = atan2(d[0], -d[2]) / (2 * M_PI);
            u -= floor(u);
            double want_r = v * (MH - 1), want_g = u * MW - 0.5;
            worst_r = fmax(worst_r, fabs(rgb[3 * (y * N + x)] - want_r));
            if (want_g > 0.0 && want_g < MW - 1) {
                worst_g = fmax(worst_g,
                               fabs(rgb[3 * (y * N + x) + 1] - want_g));
                n_g++;
            }
        }
    print_message("  ramp map: row off by at most %.2g, column by %.2g "
                  "(%d pixels)\n",
                  worst_r, worst_g, n_g);
    if (!(worst_r < 2e-3) || !(worst_g < 2e-3) || n_g < N * N / 2)
        fail_msg("the map's texels are not where Mitsuba puts them: row off "
                 "by %.3g, column by %.3g",
                 worst_r, worst_g);
    lr_image_free(img);
}

/* Both integrators show the map where rays escape: a constant map of 0.7
 * renders 0.7 x intensity everywhere. */
static void test_envmap_seen_by_both(void **state)
{
    (void)state;
    lr_image *map = NULL;
    assert_int_equal(lr_image_create(8, 4, 0, &map, NULL), LR_OK);
    float *px = lr_image_rgb_mut(map);
    for (int i = 0; i < 8 * 4 * 3; i++)
        px[i] = 0.7f;
    char path[1024];
    snprintf(path, sizeof path, "%s/const.exr", lr_test_tmpdir());
    assert_int_equal(lr_image_write(map, path, NULL, NULL), LR_OK);
    lr_image_free(map);
    const char *json =
        "{\"render\": {\"width\": 8, \"height\": 8, \"spp\": 4},"
        " \"environment\": {\"file\": \"const.exr\", \"intensity\": 2},"
        " \"background\": 5}";
    const char *path_set[] = {"render.integrator=path"};
    lr_image *w = lr_test_render_json(json, "envmap, whitted");
    lr_image *p = lr_test_render_sets(json, path_set, 1, "envmap, path");
    expect(w, 0, 0, 8, 8, 1.4, 1e-6, 1e-6,
           "whitted sees the map (not background)");
    expect(p, 0, 0, 8, 8, 1.4, 1e-6, 1e-6,
           "path sees the map (not background)");
    lr_image_free(w);
    lr_image_free(p);
}

/* ---- bokeh of a small emitter ----------------------------------------- */

#define BW 161
#define BFOV 20.0

static void centroid_m2(const lr_image *img, double *m2)
{
    const float *p = lr_image_rgb(img);
    double sum = 0, cx = 0, cy = 0;
    for (int y = 0; y < BW; y++)
        for (int x = 0; x < BW; x++) {
            double v = p[3 * (y * BW + x)];
            sum += v, cx += v * (x + 0.5), cy += v * (y + 0.5);
        }
    cx /= sum, cy /= sum;
    double m = 0;
    for (int y = 0; y < BW; y++)
        for (int x = 0; x < BW; x++) {
            double v = p[3 * (y * BW + x)];
            m += v * ((x + 0.5 - cx) * (x + 0.5 - cx) +
                      (y + 0.5 - cy) * (y + 0.5 - cy));
        }
    *m2 = m / sum;
}

/* As test_camera_thinlens.c's circle of confusion, with the sphere an
 * emitter on black lit by nothing else: what the path integrator sees
 * directly.
 * Disk kernel: second moment C^2 / 8. */
static void test_emitter_bokeh(void **state)
{
    (void)state;
    const double r = 0.2, s = 6.0, depths[] = {2.5, 20.0};
    double f_px = BW / (2.0 * tan(BFOV * M_PI / 360.0));
    for (int i = 0; i < 2; i++) {
        double z = depths[i];
        char json[2048];
        snprintf(
            json, sizeof json,
            "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": 128,"
            "  \"integrator\": \"path\", \"adaptive\": false},"
            " \"camera\": {\"position\": [0, 0, 0],"
            "  \"look_at\": [0, 0, -1], \"fov\": %g},"
            " \"materials\": {\"e\": {\"diffuse\": 0, \"emission\": 5}},"
            " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, %.17g],"
            "  \"radius\": %.17g, \"material\": \"e\"}]}",
            BW, BW, BFOV, -z, 0.004 * z);
        lr_image *pin = lr_test_render_json(json, "emitter, pinhole");
        const char *sets[] = {"camera.model=thinlens",
                              "camera.aperture_radius=0.2",
                              "camera.focus_distance=6"};
        lr_image *blur = lr_test_render_sets(json, sets, 3, "emitter bokeh");
        double m0, m1;
        centroid_m2(pin, &m0);
        centroid_m2(blur, &m1);
        double got = sqrt((m1 - m0) * 8.0);
        double want = 2.0 * r * fabs(1.0 / z - 1.0 / s) * f_px;
        print_message("  emitter bokeh at depth %5.1f: %.3f px, circle of "
                      "confusion %.3f px (%+.2f%%)\n",
                      z, got, want, 100 * (got - want) / want);
        if (!(fabs(got - want) <= 0.05 * want))
            fail_msg("emitter bokeh at depth %g: %.4g px, want %.4g px", z, got,
                     want);
        lr_image_free(pin);
        lr_image_free(blur);
    }
}

/* ---- a lamp over a floor ---------------------------------------------- */

/* Far from the origin, where a shadow ray's origin moves off the floor by
 * more than the relative shadow epsilon: the floor there once got 56%
 * (a sphere lamp) or 58% (a tessellated one) of its light 200 units out,
 * the lamp meeting its own shadow rays; and a sphere lamp 10^4 units out
 * 90%, its shadow rays' origins rounded to float past the margin. */
#define LAMP_LE 2.0
#define LAMP_R 0.5
static double lamp_at, lamp_c[3];

/* The floor's point under the camera, `at` units out along x and z, and
 * the lamp beside it. */
static void place_lamp(double at)
{
    lamp_at = at;
    lamp_c[0] = at + 1.2, lamp_c[1] = 1.2, lamp_c[2] = at;
}

/* Renders 8 x 8 pixels of a diffuse floor (albedo 0.5) at lamp_at, seen
 * from straight above, lit only by `lamp` (a JSON object of material
 * "l", emission LAMP_LE) out of the frame, and compares each pixel with
 * albedo / pi x LAMP_LE x irr(point) averaged over 8 x 8 points of it. */
static void floor_under_lamp(const char *lamp, double (*irr)(const double p[3]),
                             const char *what, double tol_pixel)
{
    enum { N = 8, SUB = 8 };
    const double o = lamp_at, fov = 20.0;
    char json[1024];
    snprintf(
        json, sizeof json,
        "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": 512,"
        "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 0},"
        " \"camera\": {\"position\": [%g, 1, %g], \"look_at\": [%g, 0, %g],"
        "  \"up\": [0, 0, -1], \"fov\": %g},"
        " \"materials\": {\"g\": {\"diffuse\": 0.5}, \"l\": {\"emission\": "
        "%g}},"
        " \"objects\": [{\"type\": \"plane\", \"point\": [%g, 0, %g],"
        "  \"normal\": [0, 1, 0], \"material\": \"g\"}, %s]}",
        N, N, o, o, o, o, fov, LAMP_LE, o, o, lamp);
    lr_image *img = lr_test_render_json(json, what);
    const float *px = lr_image_rgb(img);
    /* Looking down from height 1 with up -z: image right is +x, image
     * up is -z (scene-format.md, 6). */
    double t = tan(fov * M_PI / 360.0), mean_rel = 0.0, worst = 0.0;
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) {
            double want = 0.0;
            for (int j = 0; j < SUB; j++)
                for (int i = 0; i < SUB; i++) {
                    double X = (2.0 * (x + (i + 0.5) / SUB) / N - 1.0) * t;
                    double Y = (1.0 - 2.0 * (y + (j + 0.5) / SUB) / N) * t;
                    double p[3] = {o + X, 0.0, o - Y};
                    want += 0.5 / M_PI * LAMP_LE * irr(p) / (SUB * SUB);
                }
            for (int m = 0; m < 3; m++) {
                double rel = (px[3 * (y * N + x) + m] - want) / want;
                mean_rel += rel / (3 * N * N);
                worst = fmax(worst, fabs(rel));
            }
        }
    print_message("  floor under a %s %g units out: mean %+.4f%%, worst pixel "
                  "%.3f%%\n",
                  what, o, 100 * mean_rel, 100 * worst);
    if (!(fabs(mean_rel) <= 3e-3) || !(worst <= tol_pixel))
        fail_msg("floor under a %s: mean off by %.3f%%, worst pixel %.3f%% "
                 "(allowed 0.3%%, %.1f%%)",
                 what, 100 * mean_rel, 100 * worst, 100 * tol_pixel);
    lr_image_free(img);
}

/* An emitting sphere wholly above the point's horizon, of unit radiance:
 * E = pi (r / d)^2 cos(theta), d the distance to the centre, theta its
 * angle from the normal (the sphere's projected solid angle, Nusselt's
 * analogue). */
static double sphere_irradiance(const double p[3])
{
    double dx = lamp_c[0] - p[0], dy = lamp_c[1] - p[1], dz = lamp_c[2] - p[2];
    double d2 = dx * dx + dy * dy + dz * dz;
    return M_PI * LAMP_R * LAMP_R / d2 * dy / sqrt(d2);
}

static void test_sphere_lamp_irradiance(void **state)
{
    (void)state;
    static const double at[] = {200.0, 1e4};
    for (int k = 0; k < 2; k++) {
        char lamp[256];
        place_lamp(at[k]);
        snprintf(lamp, sizeof lamp,
                 "{\"type\": \"sphere\", \"center\": [%.17g, %.17g, %.17g],"
                 " \"radius\": %g, \"material\": \"l\"}",
                 lamp_c[0], lamp_c[1], lamp_c[2], LAMP_R);
        floor_under_lamp(lamp, sphere_irradiance, "sphere lamp", 1.5e-2);
    }
}

/* Irradiance at p (normal +y) from a triangle of radiance 1 facing p:
 * Lambert's polygon formula, E = 1/2 sum_i theta_i (n . g_i), theta_i the
 * angle its corners i and i + 1 subtend at p and g_i the unit normal of
 * their plane (Arvo 1994, "The irradiance Jacobian", eq. 1). */
static double triangle_irradiance(const double p[3], const double v[3][3])
{
    double u[3][3], E = 0.0;
    for (int i = 0; i < 3; i++) {
        double l = 0.0;
        for (int k = 0; k < 3; k++)
            u[i][k] = v[i][k] - p[k], l += u[i][k] * u[i][k];
        for (int k = 0; k < 3; k++)
            u[i][k] /= sqrt(l);
    }
    for (int i = 0; i < 3; i++) {
        const double *a = u[i], *b = u[(i + 1) % 3];
        double g[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                       a[0] * b[1] - a[1] * b[0]};
        double gl = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        E += acos(fmax(-1.0, fmin(1.0, c))) * g[1] / gl;
    }
    return 0.5 * fabs(E);
}

/* The sphere lamp tessellated: a 48 x 24 latitude-longitude mesh,
 * counter-clockwise outwards (the poles' slivers, which have no area,
 * left out). */
enum { LAMP_NU = 48, LAMP_NV = 24 };
static double lamp_vert[(LAMP_NV + 1) * LAMP_NU][3];
static int lamp_tri[2 * LAMP_NU * LAMP_NV][3], lamp_nt;

/* The triangles that face p, each by Lambert's formula: for a convex
 * lamp they tile its outline. */
static double mesh_irradiance(const double p[3])
{
    double E = 0.0;
    for (int q = 0; q < lamp_nt; q++) {
        double v[3][3], e1[3], e2[3];
        for (int c = 0; c < 3; c++)
            for (int m = 0; m < 3; m++)
                v[c][m] = lamp_vert[lamp_tri[q][c]][m];
        for (int m = 0; m < 3; m++)
            e1[m] = v[1][m] - v[0][m], e2[m] = v[2][m] - v[0][m];
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1],
                       e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        if ((p[0] - v[0][0]) * n[0] + (p[1] - v[0][1]) * n[1] +
                (p[2] - v[0][2]) * n[2] >
            0.0)
            E += triangle_irradiance(p, v);
    }
    return E;
}

static void test_mesh_lamp_irradiance(void **state)
{
    (void)state;
    place_lamp(200.0);
    for (int j = 0; j <= LAMP_NV; j++)
        for (int i = 0; i < LAMP_NU; i++) {
            double th = M_PI * j / LAMP_NV, ph = 2 * M_PI * i / LAMP_NU;
            double *v = lamp_vert[j * LAMP_NU + i];
            v[0] = lamp_c[0] + LAMP_R * sin(th) * cos(ph);
            v[1] = lamp_c[1] + LAMP_R * cos(th);
            v[2] = lamp_c[2] + LAMP_R * sin(th) * sin(ph);
        }
    lamp_nt = 0;
    for (int j = 0; j < LAMP_NV; j++)
        for (int i = 0; i < LAMP_NU; i++) {
            int a = j * LAMP_NU + i, b = j * LAMP_NU + (i + 1) % LAMP_NU;
            int d = b + LAMP_NU, e = a + LAMP_NU;
            if (j > 0) {
                int *t = lamp_tri[lamp_nt++];
                t[0] = a, t[1] = b, t[2] = d;
            }
            if (j < LAMP_NV - 1) {
                int *t = lamp_tri[lamp_nt++];
                t[0] = a, t[1] = d, t[2] = e;
            }
        }
    static char obj[1 << 18];
    size_t k = 0;
    for (int i = 0; i < (LAMP_NV + 1) * LAMP_NU; i++)
        k += (size_t)snprintf(obj + k, sizeof obj - k, "v %.17g %.17g %.17g\n",
                              lamp_vert[i][0], lamp_vert[i][1],
                              lamp_vert[i][2]);
    for (int q = 0; q < lamp_nt; q++)
        k += (size_t)snprintf(obj + k, sizeof obj - k, "f %d %d %d\n",
                              lamp_tri[q][0] + 1, lamp_tri[q][1] + 1,
                              lamp_tri[q][2] + 1);
    char path[512];
    lr_test_write_text("lamp.obj", obj, path, sizeof path);
    /* Triangles are sampled by area, noisier than the sphere's cone. */
    floor_under_lamp("{\"type\": \"mesh\", \"file\": \"lamp.obj\","
                     " \"material\": \"l\"}",
                     mesh_irradiance, "mesh lamp", 4e-2);
}

/* ---- determinism ------------------------------------------------------ */

/* Paths are pure functions of their sample: one thread or two, tiles of
 * 32 or 5, every sampler: the same bytes; and a region is the same
 * pixels of the full frame. */
static void test_path_is_deterministic(void **state)
{
    (void)state;
    const char *samplers[] = {"sobol", "random", "jittered", "grid"};
    for (int k = 0; k < 4; k++) {
        char json[2048], smp[64];
        box_scene(json, sizeof json, 0.7, 8, 16);
        snprintf(smp, sizeof smp, "render.sampler=%s", samplers[k]);
        const char *a[] = {smp, "render.threads=1"};
        const char *b[] = {smp, "render.threads=2", "render.tile_size=5"};
        lr_image *x = lr_test_render_sets(json, a, 2, "1 thread");
        lr_image *y = lr_test_render_sets(json, b, 3, "2 threads, tiles of 5");
        lr_test_assert_same_bytes(x, y, "path: threads and tiles");
        const char *c[] = {smp, "render.region=[2, 3, 7, 8]"};
        lr_image *z = lr_test_render_sets(json, c, 2, "region");
        const float *px = lr_image_rgb(x), *pz = lr_image_rgb(z);
        for (int yy = 3; yy < 8; yy++)
            assert_memory_equal(&px[3 * (yy * 8 + 2)], &pz[3 * ((yy - 3) * 5)],
                                5 * 3 * sizeof(float));
        lr_image_free(x);
        lr_image_free(y);
        lr_image_free(z);
    }
}

/* Embree's code for CPUs without AVX-512 checks the rays of masked-off
 * packet lanes and aborts on garbage (an assertion on tnear >= 0): the
 * path integrator's shadow, continuation and single-ray packets on each
 * ISA this CPU runs, with hits, misses, an area light and spp 20 (packets
 * of 16 and of 4).  Each must give finite pixels within 1% of the
 * default's mean (Embree's code for each ISA may round differently). */
/* Fills the stack below the caller with 0x7f bytes (floats of 3.4e38),
 * so that a packet lane left unset holds a ray Embree's checks refuse
 * (else what an unset lane holds depends on what ran before; NaN would
 * not do: Embree masks NaN lanes off before it checks). */
__attribute__((noinline)) static void poison_stack(void)
{
    volatile unsigned char junk[256 * 1024];
    for (size_t i = 0; i < sizeof junk; i++)
        junk[i] = 0x7f;
}

static void test_path_on_every_embree_isa(void **state)
{
    (void)state;
    int n_isa;
    const char *const *isa = lr_test_embree_isas(&n_isa);
    double mean[3];
    for (int k = 0; k < n_isa; k++) {
        lr__embree_config = isa[k];
        lr_scene *s = lr_test_load_json(cornell_json);
        lr__embree_config = NULL;
        lr_camera cam;
        lr_render_settings rs;
        lr_scene_camera(s, &cam);
        lr_scene_settings(s, &rs);
        poison_stack();
        lr_image *img = lr_test_render_with(s, &cam, &rs, "path, Embree ISA");
        lr_scene_free(s);
        mean[k] = lr_test_finite_mean(img, isa[k] ? isa[k] : "default");
        lr_image_free(img);
    }
    lr_test_isa_means_agree(mean, isa, n_isa);
}

/* The scene rendered with path16.c's vector bounce and without it (every
 * lane shaded alone in path.c): the same bytes. */
static void same_with_path16_off(const char *json, const char *const *sets,
                                 int n_sets, const char *what)
{
    lr_image *a = lr_test_render_sets(json, sets, n_sets, "path16 on");
    lr__path16_enabled = 0;
    lr_image *b = lr_test_render_sets(json, sets, n_sets, "path16 off");
    lr__path16_enabled = 1;
    lr_test_assert_same_bytes(a, b, what);
    lr_image_free(a);
    lr_image_free(b);
}

/* path16.c's sixteen-lane bounce on Lambertian triangles gives what the
 * lane-by-lane code gives, to the byte: the Cornell box (walls and light
 * triangles, a diffuse and a metal sphere: both routes in one packet),
 * with ambient light added, and past roulette's start. */
static void test_path16_matches_scalar(void **state)
{
    (void)state;
    const char *sets[] = {"render.spp=32", "render.max_depth=12",
                          "render.threads=2"};
    char amb[4096];
    /* An ambient light too (added at every surface). */
    int k = snprintf(amb, sizeof amb, "%s", cornell_json);
    assert_true(k > 2 && (size_t)k < sizeof amb - 80);
    snprintf(amb + k - 1, sizeof amb - (size_t)k + 1,
             ", \"lights\": [{\"type\": \"ambient\", \"radiance\": 0.05}]}");
    const char *jsons[2] = {cornell_json, amb};
    for (int j = 0; j < 2; j++) {
        /* (A scene path16.c takes: else this compares nothing.) */
        lr_scene *s = lr_test_load_json(jsons[j]);
        assert_true(lr__path16_scene_ok(s));
        lr_scene_free(s);
        same_with_path16_off(jsons[j], sets, 3, "path16 against lane by lane");
    }
}

/* The same box lit by two sphere lamps: a small one under the ceiling,
 * and a large one sunk into the floor by the back wall, so that floor
 * points inside it sample it by area (light.c's other branch); max
 * depth 64, as issue 30's full-length paths. */
static const char *const sphere_lamps_json =
    "{\"render\": {\"width\": 24, \"height\": 16, \"spp\": 32,"
    "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 64,"
    "  \"plan\": false, \"threads\": 2}," BOX_CAMERA
    " \"materials\": {\"w\": {\"diffuse\": 0.75},"
    "  \"m\": {\"reflect\": 0.9, \"roughness\": 0.25},"
    "  \"e\": {\"diffuse\": 0, \"emission\": 30},"
    "  \"f\": {\"diffuse\": 0, \"emission\": [2, 1, 0.5]}},"
    " \"objects\": [" BOX_WALLS
    "  {\"type\": \"sphere\", \"center\": [0, 8.6, -5], \"radius\": 0.8,"
    "   \"material\": \"e\"},"
    "  {\"type\": \"sphere\", \"center\": [3, 0, -8], \"radius\": 1.5,"
    "   \"material\": \"f\"}," BOX_SPHERES;

/* path16.c's bounce with sphere lamps (light.c's cone and area samples
 * of a sphere, redone in its loops) gives the lane-by-lane bytes, with a
 * few primitives and with every primitive in Embree; and with the
 * rectangle lamp too (its two triangles and the spheres: each lane's
 * sample of the kind it picked). */
static void test_path16_sphere_lamps_match_scalar(void **state)
{
    (void)state;
    char mixed[4096];
    const char *rect = "  {\"type\": \"plane\", \"point\": [0, 9.99, -5],"
                       "   \"normal\": [0, -1, 0], \"size\": 3,"
                       "   \"material\": \"e\"},";
    const char *at = strstr(sphere_lamps_json, "\"objects\": [");
    assert_non_null(at);
    int k = (int)(at - sphere_lamps_json) + (int)strlen("\"objects\": [");
    snprintf(mixed, sizeof mixed, "%.*s%s%s", k, sphere_lamps_json, rect,
             sphere_lamps_json + k);
    const char *jsons[2] = {sphere_lamps_json, mixed};
    for (int j = 0; j < 2; j++) {
        lr_scene *s = lr_test_load_json(jsons[j]);
        assert_true(lr__path16_scene_ok(s));
        assert_int_equal(s->n_emitters, j == 0 ? 2 : 4);
        lr_scene_free(s);
        for (int embree = 0; embree < 2; embree++) {
            lr__few_triangles_enabled = !embree;
            lr__few_spheres_enabled = !embree;
            same_with_path16_off(jsons[j], NULL, 0, "sphere lamps");
        }
    }
    lr__few_triangles_enabled = 1;
    lr__few_spheres_enabled = 1;
}

/* spheres.c's spheres, met in double beside Embree's scene without
 * them, give the picture Embree's spheres give: lr__hit_complete solves
 * a sphere hit's t again either way, so only rays within float rounding
 * of a silhouette may go the other way.  The Cornell box at 32 spp, max
 * depth 12: at least 99% of the values the same to the bit, and the
 * image means within 0.1%. */
static void test_few_spheres_match_embree(void **state)
{
    (void)state;
    const char *sets[] = {"render.spp=32", "render.max_depth=12"};
    /* The triangles in Embree either way (few_triangles.c has its own
     * test below). */
    lr__few_triangles_enabled = 0;
    lr_scene *s = lr_test_load_json(cornell_json);
    assert_int_equal(s->n_few, 2);
    lr_scene_free(s);
    lr_image *a = lr_test_render_sets(cornell_json, sets, 2, "few spheres");
    lr__few_spheres_enabled = 0;
    s = lr_test_load_json(cornell_json);
    assert_null(s->rtc_few);
    lr_scene_free(s);
    lr_image *b = lr_test_render_sets(cornell_json, sets, 2,
                                      "Embree's spheres");
    lr__few_spheres_enabled = 1;
    lr__few_triangles_enabled = 1;
    const float *pa = lr_image_rgb(a), *pb = lr_image_rgb(b);
    size_t n = lr_test_n_values(a), same = 0;
    double ma = 0, mb = 0;
    for (size_t i = 0; i < n; i++) {
        same += pa[i] == pb[i];
        ma += pa[i];
        mb += pb[i];
    }
    print_message("  %zu of %zu values the same, means %.6g and %.6g\n", same,
                  n, ma / n, mb / n);
    assert_true(same >= n - n / 100);
    assert_true(ma > 0 && fabs(ma - mb) <= 1e-3 * ma);
    lr_image_free(a);
    lr_image_free(b);
}

/* few_triangles.c (through lr__paths_intersect16 and _occluded16, which
 * pack the live lanes) against Embree on the Cornell box's 12 triangles
 * and two more (the box without its spheres, so that Embree's scene
 * holds just them):
 * 2,500 packets of 16 rays from inside the box and from the camera's
 * side, in every direction, every fifth packet with a third of its lanes
 * off (which must stay untouched).  Embree is the independent answer:
 * the same triangle, t within 1e-5 x (t + 10) and (u, v) within 1e-5,
 * except for rays within float rounding of an edge (at most 0.1% may
 * differ); the same occlusion for shadow rays stopping short of or past
 * Embree's hit by 1%.  Then the pictures with and without it: means
 * within 0.1% (the paths differ in the last float bits). */
static void test_few_triangles_match_embree(void **state)
{
    (void)state;
    char box[4096];
    const char *cut = strstr(cornell_json, ",  {\"type\": \"sphere\"");
    assert_non_null(cut);
    /* And two lone triangles (shapes of their own, where the walls'
     * rectangles are parallelograms of two). */
    snprintf(box, sizeof box,
             "%.*s, {\"type\": \"triangle\", \"material\": \"w\","
             " \"vertices\": [[-3, 1, -8], [2, 2, -7], [0, 6, -5]]},"
             " {\"type\": \"triangle\", \"material\": \"w\","
             " \"vertices\": [[1, 7, -2], [4, 3, -9], [-2, 8, -6]]}]}",
             (int)(cut - cornell_json), cornell_json);
    lr_scene *s = lr_test_load_json(box);
    assert_int_equal(s->few_tris.n, 14);
    assert_int_equal(s->few_tris.n_shapes, 8);
    assert_null(s->rtc_few);
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    int valid[16] __attribute__((aligned(64)));
    uint64_t seed = 1;
    /* Every fifth packet has lanes off (packing skips them). */
    size_t rays = 0, hits = 0, differ = 0, occ_differ = 0;
    for (int p = 0; p < 2500; p++) {
        struct RTCRayHit16 a __attribute__((aligned(64)));
        struct RTCRayHit16 b __attribute__((aligned(64)));
        for (int i = 0; i < 16; i++) {
            double r[5];
            for (int j = 0; j < 5; j++)
                r[j] = (double)(lr__mix64(seed++) >> 11) * 0x1p-53;
            lr__v3 o = p % 4 == 0 ? v3(-6 + 12 * r[0], 12 * r[1], 1 + 15 * r[2])
                                  : v3(-4.9 + 9.8 * r[0], 0.1 + 9.8 * r[1],
                                       -9.9 + 9.8 * r[2]);
            double z = 1 - 2 * r[3], ph = 2 * M_PI * r[4];
            double sn = sqrt(fmax(0.0, 1 - z * z));
            lr__v3 d = v3(sn * cos(ph), sn * sin(ph), z);
            lr__shadow_ray16(&a.ray, i, o, d, INFINITY);
            a.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
            a.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
            valid[i] = p % 5 == 0 && i % 3 == 0 ? 0 : -1;
        }
        lr__ray16_quiet_lanes(&a.ray, valid);
        b = a;
        rtcIntersect16(valid, s->rtc, &ctx, &a);
        lr__paths_intersect16(s, valid, &ctx, &b);
        struct RTCRay16 sa __attribute__((aligned(64)));
        for (int i = 0; i < 16; i++) {
            if (!valid[i]) {
                /* Untouched. */
                assert_int_equal(b.hit.geomID[i], RTC_INVALID_GEOMETRY_ID);
                continue;
            }
            rays++;
            int ha = a.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID;
            int hb = b.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID;
            hits += ha;
            if (ha != hb || (ha && (a.hit.geomID[i] != b.hit.geomID[i] ||
                                    a.hit.primID[i] != b.hit.primID[i]))) {
                differ++;
                continue;
            }
            if (ha) {
                double ta = a.ray.tfar[i];
                /* Embree's float t errs by the coordinates' rounding
                 * (the box is 10 across), not t's. */
                assert_true(fabs(ta - b.ray.tfar[i]) <= 1e-5 * (ta + 10.0));
                assert_true(fabs(a.hit.u[i] - b.hit.u[i]) <= 1e-5);
                assert_true(fabs(a.hit.v[i] - b.hit.v[i]) <= 1e-5);
            }
        }
        /* Shadow rays ending 1% before or after Embree's hit (or at
         * 100 if it found none). */
        for (int i = 0; i < 16; i++) {
            double t = a.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID
                           ? a.ray.tfar[i] * (p % 2 ? 0.99 : 1.01)
                           : 100.0;
            lr__shadow_ray16(
                &sa, i, v3(b.ray.org_x[i], b.ray.org_y[i], b.ray.org_z[i]),
                v3(b.ray.dir_x[i], b.ray.dir_y[i], b.ray.dir_z[i]), t);
        }
        lr__ray16_quiet_lanes(&sa, valid);
        struct RTCRay16 sb = sa;
        rtcOccluded16(valid, s->rtc, &ctx, &sa);
        lr__paths_occluded16(s, valid, &ctx, &sb);
        for (int i = 0; i < 16; i++)
            occ_differ += valid[i] &&
                          (sa.tfar[i] < 0.0f) != (sb.tfar[i] < 0.0f);
    }
    lr_scene_free(s);
    print_message("  %zu rays, %zu hits; %zu hit another triangle, %zu "
                  "occlusions differ\n",
                  rays, hits, differ, occ_differ);
    assert_true(hits > rays / 2); /* (the box is open on the camera side) */
    assert_true(differ <= rays / 1000);
    assert_true(occ_differ <= rays / 1000);

    const char *sets[] = {"render.spp=32", "render.max_depth=12"};
    lr_image *x = lr_test_render_sets(cornell_json, sets, 2, "few triangles");
    lr__few_triangles_enabled = 0;
    s = lr_test_load_json(cornell_json);
    assert_int_equal(s->few_tris.n, 0);
    lr_scene_free(s);
    lr_image *y = lr_test_render_sets(cornell_json, sets, 2, "Embree's");
    lr__few_triangles_enabled = 1;
    double mx = lr_test_finite_mean(x, "few triangles");
    double my = lr_test_finite_mean(y, "Embree's triangles");
    print_message("  image means %.6g and %.6g\n", mx, my);
    assert_true(mx > 0 && fabs(mx - my) <= 1e-3 * mx);
    lr_image_free(x);
    lr_image_free(y);
}

/* ---- GGX -------------------------------------------------------------- */

/* Heitz 2014, eq. 13: int G1(v, m) max(0, v.m) D(m) dm = cos(theta_v): the
 * visible-normal density integrates to 1, by the midpoint rule over the
 * hemisphere of m. */
static void test_ggx_visible_normals_integrate_to_one(void **state)
{
    (void)state;
    const double alphas[] = {0.05, 0.3, 0.8};
    const double thetas[] = {0.0, 0.7, 1.4};
    for (int a = 0; a < 3; a++)
        for (int t = 0; t < 3; t++) {
            lr__v3 v = v3(sin(thetas[t]), 0, cos(thetas[t]));
            /* Midpoint rule in cos(theta_m), finer near the pole where
             * narrow lobes live. */
            const int NP = 100;
            double sum = 0.0;
            const double edges[3] = {0.0, 0.95, 1.0};
            const int steps[2] = {1000, 8000};
            for (int part = 0; part < 2; part++)
                for (int i = 0; i < steps[part]; i++) {
                    double dc = (edges[part + 1] - edges[part]) / steps[part];
                    double c = edges[part] + (i + 0.5) * dc;
                    double sn = sqrt(1 - c * c);
                    for (int j = 0; j < NP; j++) {
                        double ph = 2 * M_PI * (j + 0.5) / NP;
                        lr__v3 m = v3(sn * cos(ph), sn * sin(ph), c);
                        double vm = v3_dot(v, m);
                        sum += lr__ggx_g1(v.z, vm, alphas[a]) * fmax(vm, 0) *
                               lr__ggx_d(c, alphas[a]) * dc * 2 * M_PI / NP;
                    }
                }
            sum /= v.z;
            if (!(fabs(sum - 1.0) < 5e-3))
                fail_msg("GGX alpha %g, theta %g: visible normals integrate "
                         "to %.5f, not 1",
                         alphas[a], thetas[t], sum);
        }
}

/* The rough lobes' albedo two ways: the mean of sampled weights
 * (f cos / pdf, from lr__bsdf_sample) and the quadrature of f cos over
 * the sphere (lr__bsdf_eval), which share no code but the formulas. */
static void test_ggx_sampling_matches_evaluation(void **state)
{
    (void)state;
    static const char *const mats[] = {
        "{\"reflect\": 1, \"roughness\": 0.3}",
        "{\"transmit\": 1, \"roughness\": 0.3, \"ior\": 1.5}",
        "{\"transmit\": 1, \"roughness\": 0.6, \"ior\": 1.33}"};
    for (int k = 0; k < 3; k++)
        for (int side = 0; side < 2; side++) {
            char json[512];
            snprintf(json, sizeof json,
                     "{\"materials\": {\"m\": %s}, \"objects\": [{\"type\":"
                     " \"sphere\", \"center\": [0, 0, 0], \"radius\": 1,"
                     " \"material\": \"m\"}]}",
                     mats[k]);
            lr_scene *s = lr_test_load_json(json);
            lr__hit h;
            /* From outside, then from inside the sphere. */
            lr__v3 org = side ? v3(0, 0, 0) : v3(0.3, 0.2, 3);
            lr__v3 dir = v3_norm(side ? v3(0.2, 0.1, 1) : v3(0, 0, -1));
            assert_true(lr__trace(s, org, dir, INFINITY, &h));
            lr__bsdf f;
            lr__bsdf_init(&f, &s->materials[h.material], &h);
            lr__v3 wo = v3_neg(dir);
            double mc = 0.0;
            const int N = 100000;
            for (int i = 0; i < N; i++) {
                /* A 2-D lattice for the normal, a third number for the
                 * lobe (the Fresnel choice). */
                double u[2] = {(i + 0.5) / N, fmod(i * 0.6180339887498949, 1)};
                double ul = fmod(i * 0.7548776662466927 + 0.1, 1);
                lr__v3 wi, wgt;
                double pdf;
                int delta;
                if (lr__bsdf_sample(&f, wo, ul, u, &wi, &wgt, &pdf, &delta))
                    mc += wgt.x;
            }
            mc /= N;
            double q = 0.0;
            const int NT = 1000, NP = 400;
            for (int i = 0; i < NT; i++) {
                double c = -1 + 2 * (i + 0.5) / NT, sn = sqrt(1 - c * c);
                for (int j = 0; j < NP; j++) {
                    double ph = 2 * M_PI * (j + 0.5) / NP;
                    lr__v3 loc = v3(sn * cos(ph), sn * sin(ph), c);
                    lr__v3 wi = v3_add(
                        v3_add(v3_scale(f.t, loc.x), v3_scale(f.b, loc.y)),
                        v3_scale(f.n, loc.z));
                    double pdf;
                    lr__v3 val = lr__bsdf_eval(&f, wo, wi, &pdf);
                    q += val.x * fabs(c) * (2.0 / NT) * (2 * M_PI / NP);
                }
            }
            print_message("  %s from %s: sampled albedo %.4f, quadrature "
                          "%.4f\n",
                          mats[k], side ? "inside" : "outside", mc, q);
            if (!(fabs(mc - q) <= 0.01 * q + 1e-3))
                fail_msg("%s from %s: sampled albedo %.5f, quadrature %.5f",
                         mats[k], side ? "inside" : "outside", mc, q);
            lr_scene_free(s);
        }
}

/* ---- bad input -------------------------------------------------------- */

static void test_bad_input(void **state)
{
    (void)state;
    const char *a = "{\"render\": {\"integrator\": \"bidir\"}}";
    lr_test_expect_invalid(a, strlen(a), "render.integrator", "integrator");
    const char *b = "{\"materials\": {\"m\": {\"roughness\": 2}}}";
    lr_test_expect_invalid(b, strlen(b), "materials.m.roughness",
                           "roughness > 1");
    const char *c = "{\"materials\": {\"m\": {\"emission\": -1}}}";
    lr_test_expect_invalid(c, strlen(c), "materials.m.emission",
                           "negative emission");
    const char *d = "{\"environment\": {\"intensity\": 1}}";
    lr_test_expect_invalid(d, strlen(d), "environment.file", "no file");
    /* A file that is not an EXR, and one that is missing: the message
     * names the file. */
    char path[1024];
    lr_test_write_text("not-an-exr.exr", "hello", path, sizeof path);
    const char *e = "{\"environment\": {\"file\": \"not-an-exr.exr\"}}";
    lr_test_expect_invalid(e, strlen(e), "environment.file", "not an EXR");
    lr_scene *s = NULL;
    lr_error err;
    const char *f = "{\"environment\": {\"file\": \"missing.exr\"}}";
    assert_int_equal(
        lr_scene_load_json(f, strlen(f), lr_test_tmpdir(), NULL, 0, &s, &err),
        LR_ERR_IO);
    assert_null(s);
    assert_non_null(strstr(err.message, "missing.exr"));
    /* A map with a negative pixel is refused, naming the pixel.  (NaN
     * cannot be made this way: our EXR writer never writes one.) */
    lr_image *map = NULL;
    assert_int_equal(lr_image_create(4, 2, 0, &map, NULL), LR_OK);
    lr_image_rgb_mut(map)[3 * 5 + 1] = -1.0f;
    snprintf(path, sizeof path, "%s/nan.exr", lr_test_tmpdir());
    assert_int_equal(lr_image_write(map, path, NULL, NULL), LR_OK);
    lr_image_free(map);
    const char *g = "{\"environment\": {\"file\": \"nan.exr\"}}";
    assert_int_equal(
        lr_scene_load_json(g, strlen(g), lr_test_tmpdir(), NULL, 0, &s, &err),
        LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "nan.exr"));
    assert_non_null(strstr(err.message, "(1, 1)"));
}

static const struct CMUnitTest tests[] = {
    cmocka_unit_test(test_white_furnace),
    cmocka_unit_test(test_ior_one_is_invisible),
    cmocka_unit_test(test_emitting_box),
    cmocka_unit_test(test_plane_under_sky),
    cmocka_unit_test(test_plane_under_envmap),
    cmocka_unit_test(test_envmap_seen_by_both),
    cmocka_unit_test(test_envmap_texel_places),
    cmocka_unit_test(test_envmap_one_texel_sun),
    cmocka_unit_test(test_envmap_too_many_texels),
    cmocka_unit_test(test_emitter_bokeh),
    cmocka_unit_test(test_sphere_lamp_irradiance),
    cmocka_unit_test(test_mesh_lamp_irradiance),
    cmocka_unit_test(test_path_is_deterministic),
    cmocka_unit_test(test_path_on_every_embree_isa),
    cmocka_unit_test(test_path16_matches_scalar),
    cmocka_unit_test(test_path16_sphere_lamps_match_scalar),
    cmocka_unit_test(test_few_spheres_match_embree),
    cmocka_unit_test(test_few_triangles_match_embree),
    cmocka_unit_test(test_ggx_visible_normals_integrate_to_one),
    cmocka_unit_test(test_ggx_sampling_matches_evaluation),
    cmocka_unit_test(test_bad_input),
};
LR_TEST_GROUP(path, tests)
