/*
 * test_optics.c: the lens models against optics, not against our own
 * output.  Blur sizes are measured as second moments (the blur kernel's
 * second moment is E(defocused) - E(pinhole), see
 * ../shared/optics-reference.md) and compared with the thin-lens circle
 * of confusion and the bracket model's geometry, both computed here from
 * their formulas.
 */
#include "test.h"
#include "camera.h"
#include "lens.h"
#include "spectrum.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define W 161
#define FOV 20.0

/* Focal length in pixels: H / (2 tan(fov / 2)). */
static double f_px(void)
{
    return W / (2.0 * tan(FOV * M_PI / 360.0));
}

/* A small white sphere (angular radius 0.004 rad, ~1.8 px) at depth z on
 * black, lit by a uniform ambient light so it renders as a flat disk. */
static void point_scene(char *buf, size_t n, double z, int spp,
                        const char *sampler)
{
    snprintf(buf, n,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": %d,"
             "  \"sampler\": \"%s\", \"max_depth\": 0, \"adaptive\": false},"
             " \"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
             "  \"fov\": %g},"
             " \"materials\": {\"w\": {\"diffuse\": 1}},"
             " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, %.17g],"
             "  \"radius\": %.17g, \"material\": \"w\"}]}",
             W, W, spp, sampler, FOV, -z, 0.004 * z);
}

typedef struct moments {
    double sum, cx, cy, m2; /* total, centroid, polar second moment */
} moments;

static moments measure(const lr_image *img, int ch)
{
    const float *p = lr_image_rgb(img);
    int w = lr_image_width(img), h = lr_image_height(img);
    moments m = {0, 0, 0, 0};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = p[3 * (y * w + x) + ch];
            m.sum += v;
            m.cx += v * (x + 0.5);
            m.cy += v * (y + 0.5);
        }
    m.cx /= m.sum;
    m.cy /= m.sum;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = p[3 * (y * w + x) + ch];
            double dx = x + 0.5 - m.cx, dy = y + 0.5 - m.cy;
            m.m2 += v * (dx * dx + dy * dy);
        }
    m.m2 /= m.sum;
    return m;
}

/* Polar second moment of a regular n-gon of circumradius R about its
 * centre, from its fan of triangles (0, a, b):
 * J / A = (|a|^2 + |b|^2 + a.b) / 6 for each. */
static double polygon_m2(int n, double R)
{
    return R * R * (2.0 + cos(2.0 * M_PI / n)) / 6.0;
}

/* The blur diameter implied by a measured second moment, for a kernel
 * whose second moment is k * D^2 (disk: 1/8; square of side D: 1/6). */
static double diameter(double m2_blur, double k)
{
    return m2_blur > 0 ? sqrt(m2_blur / k) : 0.0;
}

static void check_close(double got, double want, double rel, const char *what,
                        double z)
{
    print_message("  %-28s depth %6.3f: measured %7.3f px, expected %7.3f px "
                  "(%+.2f%%)\n",
                  what, z, got, want, 100.0 * (got - want) / want);
    if (!(fabs(got - want) <= rel * want))
        fail_msg("%s at depth %g: measured %.4g px, expected %.4g px "
                 "(%.1f%% off, allowed %.0f%%)",
                 what, z, got, want, 100.0 * (got - want) / want, rel * 100);
}

/* ---- identities ------------------------------------------------------- */

/* A lens of zero aperture is a pinhole, bit for bit, for every sampler
 * and with chromatic aberration switched on. */
static void test_zero_aperture_is_pinhole(void **state)
{
    (void)state;
    const char *samplers[] = {"random", "grid", "jittered", "sobol"};
    for (int k = 0; k < 4; k++) {
        char json[2048];
        point_scene(json, sizeof json, 4.0, 4, samplers[k]);
        /* Make it less trivial: a lit plane behind the sphere. */
        lr_image *pin = lr_test_render(json, NULL, 0, NULL);
        const char *thin[] = {
            "camera.model=thinlens", "camera.aperture_radius=0",
            "camera.focus_distance=2", "camera.focal_length_mm=50",
            "camera.chromatic={\"mode\": \"spectral\"}"};
        const char *bracket[] = {"camera.model=bracket", "camera.aperture=0",
                                 "camera.focal_length=3",
                                 "camera.chromatic={\"mode\": \"rgb\", "
                                 "\"amplify\": 10}"};
        /* The image plane beyond the sphere: without an aperture the
         * rays start at the eye and the sphere is seen (the packet rays
         * started on the image plane and missed it). */
        const char *far_plane[] = {"camera.model=bracket", "camera.aperture=0",
                                   "camera.image_plane_distance=6",
                                   "camera.focal_length=3"};
        lr_image *a = lr_test_render(json, thin, 5, NULL);
        lr_image *b = lr_test_render(json, bracket, 4, NULL);
        lr_image *c = lr_test_render(json, thin, 4, NULL);
        lr_image *d = lr_test_render(json, far_plane, 4, NULL);
        size_t bytes = (size_t)W * W * 3 * sizeof(float);
        assert_memory_equal(lr_image_rgb(pin), lr_image_rgb(a), bytes);
        assert_memory_equal(lr_image_rgb(pin), lr_image_rgb(b), bytes);
        assert_memory_equal(lr_image_rgb(pin), lr_image_rgb(c), bytes);
        assert_memory_equal(lr_image_rgb(pin), lr_image_rgb(d), bytes);
        lr_image_free(pin);
        lr_image_free(a);
        lr_image_free(b);
        lr_image_free(c);
        lr_image_free(d);
    }
}

/* ---- circle of confusion --------------------------------------------- */

static const double depths[] = {2.5, 4.0, 9.0, 20.0};

/* Thin lens: C = 2 r |1/Z - 1/s| f_px (pbrt, Mitsuba).  Disk kernel:
 * second moment C^2 / 8. */
static void test_thinlens_circle_of_confusion(void **state)
{
    (void)state;
    const double r = 0.2, s = 6.0;
    for (int i = 0; i < 4; i++) {
        double z = depths[i];
        char json[2048];
        point_scene(json, sizeof json, z, 128, "sobol");
        lr_image *pin = lr_test_render(json, NULL, 0, NULL);
        const char *sets[] = {"camera.model=thinlens",
                              "camera.aperture_radius=0.2",
                              "camera.focus_distance=6"};
        lr_image *blur = lr_test_render(json, sets, 3, NULL);
        moments m0 = measure(pin, 1), m1 = measure(blur, 1);
        double want = 2.0 * r * fabs(1.0 / z - 1.0 / s) * f_px();
        check_close(diameter(m1.m2 - m0.m2, 1.0 / 8.0), want, 0.05,
                    "thin-lens blur diameter", z);
        lr_image_free(pin);
        lr_image_free(blur);
    }
}

/* f-number: r = f / (2 N), in metres. */
static void test_f_number(void **state)
{
    (void)state;
    char json[2048];
    double z = 2.5, s = 6.0;
    point_scene(json, sizeof json, z, 128, "sobol");
    lr_image *pin = lr_test_render(json, NULL, 0, NULL);
    const char *sets[] = {"camera.model=thinlens", "camera.f_number=0.25",
                          "camera.focal_length_mm=100",
                          "camera.focus_distance=6"};
    lr_image *blur = lr_test_render(json, sets, 4, NULL);
    double r = 0.1 / (2 * 0.25);
    double want = 2.0 * r * fabs(1.0 / z - 1.0 / s) * f_px();
    check_close(diameter(measure(blur, 1).m2 - measure(pin, 1).m2, 0.125), want,
                0.05, "f-number blur diameter", z);
    lr_image_free(pin);
    lr_image_free(blur);
}

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

/* The blur takes the aperture's shape.  The defocused image should be the
 * pinhole image convolved with the aperture's shape scaled to the circle
 * of confusion.  Square, disk and hexagon kernels with the same second
 * moment are each convolved with the pinhole image; the render must be
 * much closer to its own shape's prediction than to the others'. */

/* Coverage of pixel (x, y) (relative to the kernel centre) by a shape of
 * "radius" R: 0 square of half side R, 1 disk, 2 hexagon of circumradius
 * R with a vertex on +x; 8 x 8 supersamples. */
static double coverage(int shape, double R, int x, int y)
{
    int in = 0;
    for (int i = 0; i < 8; i++)
        for (int j = 0; j < 8; j++) {
            double px = x - 0.5 + (i + 0.5) / 8, py = y - 0.5 + (j + 0.5) / 8;
            int inside;
            if (shape == 0) {
                inside = fabs(px) <= R && fabs(py) <= R;
            } else if (shape == 1) {
                inside = px * px + py * py <= R * R;
            } else {
                /* Inside all six edges, at distance R cos(30) from the
                 * centre, with outward normals at 30 + 60 k degrees. */
                inside = 1;
                for (int k = 0; k < 6; k++) {
                    double a = M_PI / 6 + k * M_PI / 3;
                    if (px * cos(a) + py * sin(a) > R * cos(M_PI / 6))
                        inside = 0;
                }
            }
            in += inside;
        }
    return in / 64.0;
}

#define CROP 81 /* the region rendered around the centre */

static double shape_error(const lr_image *img, const lr_image *pin, int shape,
                          double R)
{
    /* Kernel, normalised to unit sum. */
    int K = (int)ceil(R) + 2;
    int side = 2 * K + 1;
    double *ker = calloc((size_t)side * side, sizeof *ker), ks = 0;
    for (int y = -K; y <= K; y++)
        for (int x = -K; x <= K; x++)
            ks += ker[(y + K) * side + x + K] = coverage(shape, R, x, y);
    const float *p = lr_image_rgb(pin), *q = lr_image_rgb(img);
    double err = 0, norm = 0;
    for (int y = 0; y < CROP; y++)
        for (int x = 0; x < CROP; x++) {
            double pred = 0;
            for (int v = -K; v <= K; v++)
                for (int u = -K; u <= K; u++) {
                    int sx = x - u, sy = y - v;
                    if (sx < 0 || sy < 0 || sx >= CROP || sy >= CROP)
                        continue;
                    pred += ker[(v + K) * side + u + K] *
                            p[3 * (sy * CROP + sx) + 1];
                }
            pred /= ks;
            double d = q[3 * (y * CROP + x) + 1] - pred;
            err += d * d;
            norm += pred * pred;
        }
    free(ker);
    return sqrt(err / norm);
}

static void test_aperture_shapes(void **state)
{
    (void)state;
    const double r = 0.2, s = 6.0, z = 2.5;
    const double scale = r * fabs(1.0 / z - 1.0 / s) * f_px(); /* px per r */
    char json[2048];
    point_scene(json, sizeof json, z, 1024, "sobol");
    const char *crop = "render.region=[40, 40, 121, 121]";
    lr_image *pin = lr_test_render(json, &crop, 1, NULL);
    double m0 = measure(pin, 1).m2;
    const char *shapes[3] = {"square", "disk", "polygon"};
    /* Kernel radii with equal second moments: square half side a has
     * m2 = 2 a^2 / 3, disk radius R has R^2 / 2, hexagon circumradius R
     * has polygon_m2(6, R). */
    double m2[3] = {2.0 * scale * scale / 3.0, scale * scale / 2.0,
                    polygon_m2(6, scale)};
    for (int k = 0; k < 3; k++) {
        char shape[64];
        snprintf(shape, sizeof shape, "camera.aperture_shape=%s", shapes[k]);
        const char *sets[] = {"camera.model=thinlens",
                              "camera.aperture_radius=0.2",
                              "camera.focus_distance=6",
                              "camera.aperture_blades=6",
                              shape,
                              crop};
        lr_image *img = lr_test_render(json, sets, 6, NULL);
        /* Size: the second moment of the kernel. */
        check_close(sqrt(measure(img, 1).m2 - m0), sqrt(m2[k]), 0.05, shapes[k],
                    z);
        /* Shape: compare with all three predictions at one common size
         * (that of this render's own second moment). */
        double target = measure(img, 1).m2 - m0, e[3];
        for (int t = 0; t < 3; t++) {
            double unit = t == 0 ? 2.0 / 3.0 : t == 1 ? 0.5 : polygon_m2(6, 1);
            e[t] = shape_error(img, pin, t, sqrt(target / unit));
        }
        for (int t = 0; t < 3; t++)
            if (t != k && !(e[k] < 0.8 * e[t]))
                fail_msg("%s aperture: relative error %.3f against its own "
                         "shape, %.3f against %s",
                         shapes[k], e[k], e[t], shapes[t]);
        lr_image_free(img);
    }
    lr_image_free(pin);
}

/* Objects on the focal plane stay sharp: across an edge lying in the
 * focal plane, at most one pixel (the one the edge passes through) is
 * between 10% and 90% of the way from dark to bright.  Returns that count
 * for the row-averaged profile of a vertical edge. */
static double edge_width(const lr_image *img)
{
    const float *p = lr_image_rgb(img);
    double prof[W];
    for (int x = 0; x < W; x++) {
        prof[x] = 0;
        for (int y = 40; y < W - 40; y++)
            prof[x] += p[3 * (y * W + x) + 1];
        prof[x] /= W - 80;
    }
    double lo = prof[0], hi = prof[W - 1];
    int n = 0;
    for (int x = 0; x < W; x++) {
        double t = (prof[x] - lo) / (hi - lo);
        if (t > 0.1 && t < 0.9)
            n++;
    }
    return n;
}

static void test_focal_plane_sharp(void **state)
{
    (void)state;
    /* A white square covering the right half of the view at depth 6. */
    char json[2048];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": 64},"
             " \"camera\": {\"fov\": %g},"
             " \"materials\": {\"w\": {\"diffuse\": 1}},"
             " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
             " \"objects\": [{\"type\": \"plane\", \"point\": [5, 0, -6],"
             "  \"normal\": [0, 0, 1], \"size\": 10, \"material\": \"w\"}]}",
             W, W, FOV);
    const char *sharp[] = {"camera.model=thinlens",
                           "camera.aperture_radius=0.2",
                           "camera.focus_distance=6"};
    const char *soft[] = {"camera.model=thinlens", "camera.aperture_radius=0.2",
                          "camera.focus_distance=4"};
    const char *paper[] = {"camera.model=bracket", "camera.aperture=0.2",
                           "camera.focal_length=5"};
    lr_image *a = lr_test_render(json, sharp, 3, NULL);
    lr_image *b = lr_test_render(json, soft, 3, NULL);
    lr_image *c = lr_test_render(json, paper, 3, NULL);
    double wa = edge_width(a), wb = edge_width(b), wc = edge_width(c);
    if (!(wa <= 1.0 && wc <= 1.0))
        fail_msg("edge on the focal plane is %.2f px (thin lens) and %.2f px "
                 "(bracket) wide",
                 wa, wc);
    /* The measure does see blur: focused at 4, the edge at 6 spreads over
     * most of its C = 2 r |1/6 - 1/4| f_px. */
    double C = 2 * 0.2 * (1.0 / 4 - 1.0 / 6) * f_px();
    if (!(wb > 0.5 * C))
        fail_msg("defocused edge only %.2f px wide (C = %.2f px)", wb, C);
    lr_image_free(a);
    lr_image_free(b);
    lr_image_free(c);
}

/* ---- chromatic aberration -------------------------------------------- */

/* The paper's indices, amplified twice, on a 50 mm thin lens focused at
 * 2 m: each channel's plane of best focus follows from the lens equation
 * with the channel's focal length (independently of the library). */
static double channel_focus(int model, double n_c, double F, double s)
{
    const double n_g = 1.51534;
    double v = 1.0 / (1.0 / F - 1.0 / s); /* the sensor, fixed by green */
    double Fc = model == 0 ? F * n_g / n_c : F * (n_g - 1.0) / (n_c - 1.0);
    return 1.0 / (1.0 / Fc - 1.0 / v);
}

static void test_chromatic_focus_rgb(void **state)
{
    (void)state;
    const double ior[3] = {1.50917, 1.51534, 1.51690};
    const double amp = 2.0, F = 0.05, s = 2.0, r = 0.05;
    for (int model = 0; model < 2; model++) {
        double sc[3];
        for (int c = 0; c < 3; c++)
            sc[c] = channel_focus(model, 1.51534 + amp * (ior[c] - 1.51534), F,
                                  s);
        /* Blue focuses nearest, red farthest. */
        assert_true(sc[2] < sc[1] && sc[1] < sc[0]);
        assert_true(fabs(sc[1] - s) < 1e-9);
        char chroma[160];
        snprintf(chroma, sizeof chroma,
                 "camera.chromatic={\"mode\": \"rgb\", \"amplify\": 2, "
                 "\"focal_model\": \"%s\"}",
                 model == 0 ? "paper" : "lensmaker");
        const char *sets[] = {
            "camera.model=thinlens", "camera.aperture_radius=0.05",
            "camera.focus_distance=2", "camera.focal_length_mm=50", chroma};
        /* Put the point where red, then where blue is in focus. */
        for (int at = 0; at < 3; at += 2) {
            double z = sc[at];
            char json[2048];
            point_scene(json, sizeof json, z, 128, "sobol");
            lr_image *pin = lr_test_render(json, NULL, 0, NULL);
            lr_image *img = lr_test_render(json, sets, 5, NULL);
            for (int c = 0; c < 3; c++) {
                double m2 = measure(img, c).m2 - measure(pin, c).m2;
                double want = 2 * r * fabs(1.0 / z - 1.0 / sc[c]) * f_px();
                if (c == at) {
                    /* In focus: no blur beyond the noise. */
                    if (!(m2 < 0.3))
                        fail_msg("model %d: channel %d at its focus %g m has "
                                 "blur moment %g px^2",
                                 model, c, z, m2);
                } else {
                    char what[64];
                    snprintf(what, sizeof what, "model %d channel %d", model,
                             c);
                    check_close(diameter(m2, 0.125), want, 0.05, what, z);
                }
            }
            lr_image_free(pin);
            lr_image_free(img);
        }
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

/* Spectral: short wavelengths focus nearer.  At the depth where 450 nm is
 * in focus the blue channel is the sharpest; at 650 nm's, the red. */
static void test_chromatic_spectral_order(void **state)
{
    (void)state;
    /* Focus depths of 450 and 650 nm for N-BK7 amplified 3x, lensmaker,
     * from the Sellmeier index computed here. */
    const double F = 0.05, s = 2.0, amp = 3.0;
    const double B[3] = {1.03961212, 0.231792344, 1.01046945};
    const double C[3] = {0.00600069867, 0.0200179144, 103.560653};
    double nl[3], lam[3] = {587.5618, 450, 650};
    for (int k = 0; k < 3; k++) {
        double L2 = lam[k] * lam[k] * 1e-6, n2 = 1;
        for (int i = 0; i < 3; i++)
            n2 += B[i] * L2 / (L2 - C[i]);
        nl[k] = sqrt(n2);
    }
    double v = 1 / (1 / F - 1 / s), z[2];
    for (int k = 1; k < 3; k++) {
        double n = nl[0] + amp * (nl[k] - nl[0]);
        double Fc = F * (nl[0] - 1) / (n - 1);
        z[k - 1] = 1 / (1 / Fc - 1 / v);
    }
    assert_true(z[0] < s && s < z[1]);
    const char *sets[] = {
        "camera.model=thinlens", "camera.aperture_radius=0.05",
        "camera.focus_distance=2", "camera.focal_length_mm=50",
        "camera.chromatic={\"mode\": \"spectral\", \"amplify\": 3,"
        " \"focal_model\": \"lensmaker\", \"glass\": \"N-BK7\","
        " \"wavelengths\": 8}"};
    for (int k = 0; k < 2; k++) {
        char json[2048];
        point_scene(json, sizeof json, z[k], 64, "sobol");
        lr_image *pin = lr_test_render(json, NULL, 0, NULL);
        lr_image *img = lr_test_render(json, sets, 5, NULL);
        double mr = measure(img, 0).m2 - measure(pin, 0).m2;
        double mb = measure(img, 2).m2 - measure(pin, 2).m2;
        if (k == 0 ? !(mb < mr) : !(mr < mb))
            fail_msg("at %s focus: red blur %g, blue blur %g px^2",
                     k == 0 ? "450 nm" : "650 nm", mr, mb);
        lr_image_free(pin);
        lr_image_free(img);
    }
}

/* White stays white: a uniform white world through a strongly
 * dispersive spectral lens is exactly white, with any number of
 * wavelengths per sample (every ray sees the reference ray's white, the
 * control variate of lib/render/spectral.c). */
static void test_spectral_white_is_white(void **state)
{
    (void)state;
    const char *json =
        "{\"render\": {\"width\": 16, \"height\": 12, \"spp\": 16},"
        " \"background\": 1}";
    const char *modes[] = {"camera.chromatic={\"mode\": \"spectral\", "
                           "\"amplify\": 20, \"wavelengths\": 5}",
                           "camera.chromatic={\"mode\": \"spectral\", "
                           "\"amplify\": 20, \"wavelengths\": 2}"};
    for (int k = 0; k < 2; k++) {
        const char *sets[] = {
            "camera.model=thinlens", "camera.aperture_radius=0.5",
            "camera.focus_distance=2", "camera.focal_length_mm=50", modes[k]};
        lr_image *img = lr_test_render(json, sets, 5, NULL);
        for (int i = 0; i < 16 * 12 * 3; i++)
            if (lr_image_rgb(img)[i] != 1.0f)
                fail_msg("%s: value %d is %g", modes[k], i,
                         lr_image_rgb(img)[i]);
        lr_image_free(img);
    }
}

/* Energy: defocus moves light around, it does not make or lose it.  Three
 * white spheres at different depths (placed so that none hides another
 * from any point of the lens: partial occlusion really does change the
 * total) keep their total light, per channel, under every lens model,
 * aperture shape and chromatic mode. */
static void test_energy_conserved(void **state)
{
    (void)state;
    char json[2048];
    snprintf(
        json, sizeof json,
        "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": 256,"
        "  \"adaptive\": false},"
        " \"camera\": {\"fov\": %g},"
        " \"materials\": {\"w\": {\"diffuse\": 1}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": ["
        "  {\"type\": \"sphere\", \"center\": [0, 0, -1.9], \"radius\": 0.04,"
        "   \"material\": \"w\"},"
        "  {\"type\": \"sphere\", \"center\": [0.25, 0.15, -3],"
        "   \"radius\": 0.05, \"material\": \"w\"},"
        "  {\"type\": \"sphere\", \"center\": [0.4, -0.3, -6],"
        "   \"radius\": 0.15, \"material\": \"w\"}]}",
        W, W, FOV);
    lr_image *pin = lr_test_render(json, NULL, 0, NULL);
    double ref = measure(pin, 1).sum;
    const char *thin = "camera.model=thinlens";
    const char *cases[][6] = {
        {thin, "camera.aperture_radius=0.08", "camera.focus_distance=3"},
        {thin, "camera.aperture_radius=0.08", "camera.focus_distance=3",
         "camera.aperture_shape=polygon", "camera.aperture_blades=5"},
        {"camera.model=bracket", "camera.aperture=0.1",
         "camera.focal_length=2"},
        {thin, "camera.aperture_radius=0.05", "camera.focus_distance=2",
         "camera.focal_length_mm=50",
         "camera.chromatic={\"mode\": \"rgb\", \"amplify\": 3}"},
        {thin, "camera.aperture_radius=0.05", "camera.focus_distance=2",
         "camera.focal_length_mm=50",
         "camera.chromatic={\"mode\": \"spectral\", \"amplify\": 3}"},
    };
    const size_t n_sets[] = {3, 5, 3, 5, 5};
    for (size_t k = 0; k < 5; k++) {
        lr_image *img = lr_test_render(json, cases[k], n_sets[k], NULL);
        for (int c = 0; c < 3; c++) {
            double got = measure(img, c).sum;
            if (fabs(got - ref) > 0.005 * ref)
                fail_msg("case %zu channel %d: total %g, pinhole %g", k, c, got,
                         ref);
        }
        lr_image_free(img);
    }
    lr_image_free(pin);
}

/* ---- glass and colour data ------------------------------------------- */

static void test_glass_catalogue(void **state)
{
    (void)state;
    /* n_d and V_d = (n_d - 1) / (n_F - n_C) from the catalogues. */
    const struct {
        lr_glass g;
        double nd, vd;
    } cat[] = {{LR_GLASS_BK7, 1.5168, 64.17},
               {LR_GLASS_F2, 1.62004, 36.37},
               {LR_GLASS_SF11, 1.78472, 25.68},
               {LR_GLASS_FUSED_SILICA, 1.4585, 67.82}};
    for (int i = 0; i < 4; i++) {
        double nd = lr__glass_index(cat[i].g, 0, 0, LR__LAMBDA_D);
        double nF = lr__glass_index(cat[i].g, 0, 0, LR__LAMBDA_F);
        double nC = lr__glass_index(cat[i].g, 0, 0, LR__LAMBDA_C);
        assert_true(fabs(nd - cat[i].nd) < 2e-4);
        assert_true(fabs((nd - 1) / (nF - nC) - cat[i].vd) < 0.1);
        /* Normal dispersion: the index falls with wavelength. */
        assert_true(lr__glass_index(cat[i].g, 0, 0, 400) >
                    lr__glass_index(cat[i].g, 0, 0, 700));
    }
    /* The Abbe model passes through n_d with Abbe number V_d. */
    double nd = lr__glass_index(LR_GLASS_ABBE, 1.6, 40, LR__LAMBDA_D);
    double nF = lr__glass_index(LR_GLASS_ABBE, 1.6, 40, LR__LAMBDA_F);
    double nC = lr__glass_index(LR_GLASS_ABBE, 1.6, 40, LR__LAMBDA_C);
    assert_true(fabs(nd - 1.6) < 1e-4);
    assert_true(fabs((nd - 1) / (nF - nC) - 40) < 0.05);
}

static void test_colour_matching(void **state)
{
    (void)state;
    /* Integrals of the CIE 1931 functions are equal (about 106.86 nm,
     * equal-energy white at x = y = 1/3); y peaks at ~555 nm with 1. */
    double I[3] = {0, 0, 0};
    for (double nm = 360; nm <= 830; nm += 0.5) {
        double xyz[3];
        lr__cie_xyz(nm, xyz);
        for (int i = 0; i < 3; i++)
            I[i] += 0.5 * xyz[i];
    }
    for (int i = 0; i < 3; i++)
        assert_true(fabs(I[i] - 106.86) < 0.02 * 106.86);
    double y555[3];
    lr__cie_xyz(555, y555);
    assert_true(fabs(y555[1] - 1.0) < 0.01);
    /* D65-relative sRGB: the red function is negative near 500 nm. */
    double rgb[3];
    lr__srgb_cmf(500, rgb);
    assert_true(rgb[0] < 0);
}

static const struct CMUnitTest optics_tests[] = {
    cmocka_unit_test(test_zero_aperture_is_pinhole),
    cmocka_unit_test(test_thinlens_circle_of_confusion),
    cmocka_unit_test(test_f_number),
    cmocka_unit_test(test_bracket_blur),
    cmocka_unit_test(test_aperture_shapes),
    cmocka_unit_test(test_focal_plane_sharp),
    cmocka_unit_test(test_chromatic_focus_rgb),
    cmocka_unit_test(test_chromatic_bracket_paper),
    cmocka_unit_test(test_chromatic_spectral_order),
    cmocka_unit_test(test_spectral_white_is_white),
    cmocka_unit_test(test_energy_conserved),
    cmocka_unit_test(test_glass_catalogue),
    cmocka_unit_test(test_colour_matching),
};
LR_TEST_GROUP(optics, optics_tests)
