/*
 * test_spectral.c: spectral mode's estimator (lib/render/spectral.c) against
 * colour science computed here: the CIE 1931 functions (the Wyman,
 * Sloan & Shirley 2013 fit, typed from the paper), the sRGB matrix
 * (IEC 61966-2-1), N-BK7's Sellmeier coefficients (Schott) and the thin
 * lens's blur, integrated by quadrature.  Nothing expected here comes
 * from the code under test.
 */
#include "camera/camera.h"
#include "render/plan.h"
#include "test.h"
#include "sampling/wavelength.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ---- the independent model ---------------------------------------------- */

static double lobe(double x, double mu, double s1, double s2)
{
    double t = (x - mu) / (x < mu ? s1 : s2);
    return exp(-0.5 * t * t);
}

/* Linear-sRGB matching functions at nm. */
static void cmf(double nm, double out[3])
{
    double X = 1.056 * lobe(nm, 599.8, 37.9, 31.0) +
               0.362 * lobe(nm, 442.0, 16.0, 26.7) -
               0.065 * lobe(nm, 501.1, 20.4, 26.2);
    double Y = 0.821 * lobe(nm, 568.8, 46.9, 40.5) +
               0.286 * lobe(nm, 530.9, 16.3, 31.1);
    double Z = 1.217 * lobe(nm, 437.0, 11.8, 36.0) +
               0.681 * lobe(nm, 459.0, 26.0, 13.8);
    out[0] = 3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z;
    out[1] = -0.9692660 * X + 1.8760108 * Y + 0.0415560 * Z;
    out[2] = 0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z;
}

static double bk7(double nm)
{
    const double B[3] = {1.03961212, 0.231792344, 1.01046945};
    const double C[3] = {0.00600069867, 0.0200179144, 103.560653};
    double L2 = nm * nm * 1e-6, n2 = 1;
    for (int i = 0; i < 3; i++)
        n2 += B[i] * L2 / (L2 - C[i]);
    return sqrt(n2);
}

/* The scene: a white bar (film columns a..b at the frame's centre row)
 * on black, at the depth the d line focuses, seen through a thin lens of
 * N-BK7 with its dispersion amplified AMP times (lensmaker's model). */
#define IW 48
#define IH 16
#define FOV 10.0
#define R 0.05 /* aperture radius, m */
#define F 0.05 /* focal length, m */
#define S 2.0  /* focus and bar depth, m */
#define AMP 3.0
#define BAR 0.02 /* bar half width, m */

/* Blur radius in pixels at nm: R |1/S - w| f_px, where w is the depth in
 * focus's reciprocal, 1/F_c - 1/v, with v the image distance at the d
 * line and F_c = F (n_d - 1) / (n - 1). */
static double blur_px(double nm)
{
    double nd = bk7(587.5618);
    double n = nd + AMP * (bk7(nm) - nd);
    double Fc = F * (nd - 1) / (n - 1);
    double v = 1 / (1 / F - 1 / S);
    double w = 1 / Fc - 1 / v;
    double fpx = IH / (2 * tan(FOV * M_PI / 360));
    return R * fabs(1 / S - w) * fpx;
}

/* The part of a disk of radius r (about the origin) beyond the line at
 * signed distance -d, i.e. {x > -d}: circular segment area / disk area. */
static double beyond(double d, double r)
{
    if (r < 1e-9)
        return d > 0 ? 1 : 0;
    double t = d / r;
    if (t >= 1)
        return 1;
    if (t <= -1)
        return 0;
    return 0.5 + (t * sqrt(1 - t * t) + asin(t)) / M_PI;
}

/* Expected value of channel c in column i: the film box over the pixel
 * (x by 16-point midpoints) and the normalised matching functions over
 * 380..780 nm (0.5 nm midpoints) of the fraction of the blur disk on the
 * bar. */
static void expected_column(int i, double out[3])
{
    double fpx = IH / (2 * tan(FOV * M_PI / 360));
    double a = IW / 2.0 - BAR / S * fpx, b = IW / 2.0 + BAR / S * fpx;
    double num[3] = {0, 0, 0}, den[3] = {0, 0, 0};
    for (int k = 0; k < 800; k++) {
        double nm = 380 + (k + 0.5) * 0.5, Wc[3];
        cmf(nm, Wc);
        double r = blur_px(nm), v = 0;
        for (int j = 0; j < 16; j++) {
            double x = i + (j + 0.5) / 16;
            v += (beyond(x - a, r) - beyond(x - b, r)) / 16;
        }
        for (int c = 0; c < 3; c++) {
            num[c] += Wc[c] * v;
            den[c] += Wc[c];
        }
    }
    for (int c = 0; c < 3; c++)
        out[c] = num[c] / den[c];
}

static void bar_scene(char *buf, size_t n, int spp, const char *extra)
{
    snprintf(
        buf, n,
        "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": %d,"
        "  \"max_depth\": 0, \"adaptive\": false%s},"
        " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 0],"
        "  \"look_at\": [0, 0, -1], \"fov\": %g, \"focus_distance\": %g,"
        "  \"focal_length_mm\": %g, \"aperture_radius\": %g,"
        "  \"chromatic\": {\"mode\": \"spectral\", \"glass\": \"N-BK7\","
        "   \"focal_model\": \"lensmaker\", \"amplify\": %g}},"
        " \"materials\": {\"w\": {\"diffuse\": 1}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, %g],"
        "  \"normal\": [0, 0, 1], \"size\": [%g, 10], \"material\": \"w\"}]}",
        IW, IH, spp, extra, FOV, S, F * 1000, R, AMP, -S, 2 * BAR);
}

/* Whether the plan of the scene `json` (with `sets`) traces it by
 * spectral splatting (splat.c). */
static int plan_splats(const char *json, const char *const *sets, size_t n_sets)
{
    lr__cam c;
    lr__plan p;
    lr_scene *s = lr_test_plan(json, sets, n_sets, &c, &p, NULL);
    int splat = p.splat;
    lr__plan_free(&p);
    lr_scene_free(s);
    return splat;
}

/* ---- tests ------------------------------------------------------------- */

/* The mean colour of each column of a defocused, dispersed white bar
 * against the CIE integral of its blurred profile.  Splatting gives every
 * pixel of a render the same film offsets and lens points (splat.c), so
 * the rows of a column (the bar is the same in every row) are one
 * estimate; renders with SEEDS seeds are independent ones: their spread
 * gives the standard error, and each column's mean must lie within 4 of
 * them (plus 2e-3 for the renderer's 1 nm tables and float rays) of the
 * integral. */
#define SEEDS 12
static void test_white_bar_matches_cie_integral(void **state)
{
    (void)state;
    /* The blur must really vary with the wavelength for this to test
     * anything: 7.5 px at 400 nm, 0 at the d line, 1.2 at 650. */
    assert_true(blur_px(400) > 5.0 && blur_px(650) < 2.0);
    char json[4096];
    const char *samplers[] = {"sobol", "random"};
    for (int sm = 0; sm < 2; sm++) {
        static double col[SEEDS][IW][3];
        for (int k = 0; k < SEEDS; k++) {
            char extra[96];
            snprintf(extra, sizeof extra, ", \"sampler\": \"%s\", \"seed\": %d",
                     samplers[sm], k + 1);
            bar_scene(json, sizeof json, 64, extra);
            assert_true(plan_splats(json, NULL, 0));
            lr_image *img = lr_test_render(json, NULL, 0, NULL);
            const float *p = lr_image_rgb(img);
            for (int i = 0; i < IW; i++)
                for (int c = 0; c < 3; c++) {
                    double s = 0;
                    for (int y = 0; y < IH; y++)
                        s += p[3 * (y * IW + i) + c];
                    col[k][i][c] = s / IH;
                }
            lr_image_free(img);
        }
        int coloured = 0;
        for (int i = 0; i < IW; i++) {
            double e[3];
            expected_column(i, e);
            coloured += fabs(e[2] - e[0]) > 0.05;
            for (int c = 0; c < 3; c++) {
                double s = 0, s2 = 0;
                for (int k = 0; k < SEEDS; k++) {
                    s += col[k][i][c];
                    s2 += col[k][i][c] * col[k][i][c];
                }
                double mean = s / SEEDS;
                double se = sqrt(fmax(s2 / SEEDS - mean * mean, 0) /
                                 (SEEDS - 1));
                if (fabs(mean - e[c]) > 4 * se + 2e-3)
                    fail_msg("%s: column %d channel %d: %g, the CIE integral "
                             "%g (standard error %g)",
                             samplers[sm], i, c, mean, e[c], se);
            }
        }
        /* The fringes are there (the bar is not just white). */
        assert_true(coloured >= 4);
    }
}

/* The film shift of splat.c is the thin lens's focus change: the ray at
 * power w + t through film point f + t shift (rays16_w, the packets'
 * spectral rays) is the ray at w through f (rays16), for lens points
 * across the aperture (polygonal and stretched too) and t of either
 * sign. */
static void test_thin_lens_shift_is_a_focus_change(void **state)
{
    (void)state;
    const char *shapes[] = {"\"disk\"", "\"polygon\", \"aperture_blades\": 5,"
                                        " \"aperture_ratio\": 1.7"};
    for (int k = 0; k < 2; k++) {
        char json[1024];
        snprintf(json, sizeof json,
                 "{\"camera\": {\"model\": \"thinlens\", \"fov\": 30,"
                 " \"focus_distance\": 2, \"focal_length_mm\": 50,"
                 " \"aperture_radius\": 0.05, \"aperture_shape\": %s,"
                 " \"chromatic\": {\"mode\": \"spectral\"}},"
                 " \"objects\": []}",
                 shapes[k]);
        lr_scene *sc = lr_test_load_json(json);
        lr_camera camera;
        lr_scene_camera(sc, &camera);
        lr__cam c;
        lr__cam_init(&c, &camera, IW, IH);
        assert_non_null(c.model->shift16);
        float fx[16], fy[16], lu[16], lv[16], sx[16], sy[16], wt[16];
        float gx[16], gy[16], w[16];
        for (int i = 0; i < 16; i++) {
            fx[i] = 3.25f + 2.5f * i;
            fy[i] = 1.5f + 0.75f * i;
            lu[i] = (i * 7 % 16 + 0.5f) / 16;
            lv[i] = (i * 11 % 16 + 0.5f) / 16;
        }
        c.model->shift16(&c, 16, lu, lv, sx, sy);
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            float t = sgn * 2.5f;
            for (int i = 0; i < 16; i++) {
                gx[i] = fx[i] + t * sx[i];
                gy[i] = fy[i] + t * sy[i];
                w[i] = (float)c.w + t;
            }
            struct RTCRayHit16 a __attribute__((aligned(64)));
            struct RTCRayHit16 b __attribute__((aligned(64)));
            c.model->rays16(&c, 1, 16, fx, fy, lu, lv, &a, wt);
            c.model->rays16_w(&c, 16, gx, gy, lu, lv, w, &b, wt);
            /* The film points move by pixels (a wrong sign or scale
             * would show). */
            float most = 0.0f;
            for (int i = 0; i < 16; i++)
                most = fmaxf(most, fmaxf(fabsf(t * sx[i]), fabsf(t * sy[i])));
            assert_true(most > 2.0f);
            for (int i = 0; i < 16; i++) {
                assert_float_equal(a.ray.org_x[i], b.ray.org_x[i], 1e-6);
                assert_float_equal(a.ray.org_y[i], b.ray.org_y[i], 1e-6);
                assert_float_equal(a.ray.dir_x[i], b.ray.dir_x[i], 1e-5);
                assert_float_equal(a.ray.dir_y[i], b.ray.dir_y[i], 1e-5);
                assert_float_equal(a.ray.dir_z[i], b.ray.dir_z[i], 1e-5);
            }
        }
        lr_scene_free(sc);
    }
}

/* Splatting credits a pixel from rays of pixels up to the longest film
 * shift away, outside a crop and the frame too: a crop is still the full
 * frame's pixels bit for bit, and one thread gives what two do.  40
 * samples: groups of 16, the last partial. */
static void test_splat_crop_and_threads_exact(void **state)
{
    (void)state;
    char json[4096];
    bar_scene(json, sizeof json, 40, ", \"threads\": 1");
    assert_true(plan_splats(json, NULL, 0));
    /* camera.chromatic.splat = false: each pixel's own wavelengths, a
     * different picture of the same scene. */
    const char *own[] = {"camera.chromatic.splat=false"};
    assert_false(plan_splats(json, own, 1));
    lr_image *full = lr_test_render(json, NULL, 0, NULL);
    lr_image *unsplat = lr_test_render(json, own, 1, NULL);
    assert_memory_not_equal(lr_image_rgb(full), lr_image_rgb(unsplat),
                            sizeof(float) * 3 * lr_image_width(full) *
                                lr_image_height(full));
    lr_image_free(unsplat);
    const char *two[] = {"render.threads=2"};
    lr_image *b = lr_test_render(json, two, 1, NULL);
    lr_test_assert_same_bytes(full, b, "splatting, 1 thread against 2");
    lr_image_free(b);
    const char *crop[] = {"render.region=[19, 3, 31, 12]", "render.threads=2"};
    lr_image *c = lr_test_render(json, crop, 2, NULL);
    const float *f = lr_image_rgb(full), *p = lr_image_rgb(c);
    for (int y = 3; y < 12; y++)
        assert_memory_equal(&p[3 * (y - 3) * 12], &f[3 * (y * IW + 19)],
                            12 * 3 * sizeof(float));
    lr_image_free(c);
    lr_image_free(full);
}

/* A grey card filling the frame: every wavelength's ray sees the
 * reference's grey, so spectral mode gives exactly the image without
 * colours (no colour noise, however spread the rays).  40 samples: three
 * packets, the later two (one partial) controlled by the first's
 * reference rays. */
static void test_grey_card_is_exact(void **state)
{
    (void)state;
    const char *json =
        "{\"render\": {\"width\": 24, \"height\": 16, \"spp\": 40,"
        "  \"max_depth\": 0, \"adaptive\": false, \"plan\": false},"
        " \"camera\": {\"model\": \"thinlens\", \"fov\": 10,"
        "  \"focus_distance\": 1, \"aperture_radius\": 0.05,"
        "  \"focal_length_mm\": 50,"
        "  \"look_at\": [0, 0, -1], \"position\": [0, 0, 0],"
        "  \"chromatic\": {\"mode\": \"spectral\", \"amplify\": 50,"
        "   \"wavelengths\": 3}},"
        " \"materials\": {\"g\": {\"diffuse\": 0.18}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 0, 1],"
        "  \"point\": [0, 0, -3], \"material\": \"g\"}]}";
    const char *off[] = {"camera.chromatic.mode=off"};
    assert_true(plan_splats(json, NULL, 0));
    lr_image *a = lr_test_render(json, NULL, 0, NULL);
    lr_image *b = lr_test_render(json, off, 1, NULL);
    lr_test_assert_same_bytes(a, b, "grey card, spectral against off");
    lr_image_free(a);
    lr_image_free(b);
}

/* Mean weights over u (stratified, 2^16 points) per channel, and the
 * density's integral over the range (0.1 nm steps). */
static void weight_means(const lr__wl_table *t, double sum[3], double *P)
{
    const int N = 1 << 16;
    sum[0] = sum[1] = sum[2] = 0;
    for (int i = 0; i < N; i++) {
        double w[3];
        double nm = lr__wl_sample(t, (i + 0.5) / N, w, NULL);
        assert_true(nm >= 380 && nm <= 780);
        for (int c = 0; c < 3; c++)
            sum[c] += w[c] / N;
    }
    *P = 0;
    for (int k = 0; k < 4000; k++)
        *P += lr__wl_pdf(t, 380 + (k + 0.5) * 0.1) * 0.1;
}

/* The sampling density and the weights agree: the weights' mean over u is
 * each normalised function's integral, 1, and the density integrates to
 * 1 over the range, without dispersion (p ~ |w|) and with (p also ~
 * sqrt(|P(l) - P_ref|), mixed with 10% of p ~ |w|). */
static void test_wavelength_weights_integrate_to_one(void **state)
{
    (void)state;
    static lr__wl_table flat, disp;
    float power[LR__WL_NODES];
    /* A Cauchy-like dispersion: power falls with wavelength, equal to the
     * reference (1) at the d line. */
    for (int j = 0; j < LR__WL_NODES; j++) {
        double l = (380.0 + j) / 1000.0;
        power[j] = (float)(1 +
                           0.01 * (1 / (l * l) - 1 / (0.5875618 * 0.5875618)));
    }
    lr__wl_table_init(&flat, NULL, 1.0);
    lr__wl_table_init(&disp, power, 1.0);
    const lr__wl_table *tabs[2] = {&flat, &disp};
    for (int k = 0; k < 2; k++) {
        double sum[3], P;
        weight_means(tabs[k], sum, &P);
        for (int c = 0; c < 3; c++)
            if (fabs(sum[c] - 1) > 1e-4)
                fail_msg("table %d, channel %d: mean weight %.6f", k, c,
                         sum[c]);
        assert_true(fabs(P - 1) < 1e-3);
        /* More samples where the matching functions are large. */
        assert_true(lr__wl_pdf(tabs[k], 550) > 5 * lr__wl_pdf(tabs[k], 770));
    }
    /* The packets' float version draws the same: weights and power as the
     * scalar's (float rounding), and weights that average to 1 too. */
    double sum16[3] = {0, 0, 0};
    const int N16 = 1 << 12;
    for (int i0 = 0; i0 < N16; i0 += 16) {
        float u[16], w16[3][16], p16[16];
        for (int i = 0; i < 16; i++)
            u[i] = (float)((i0 + i + 0.5) / N16);
        lr__wl_sample16(&disp, u, w16, p16);
        for (int i = 0; i < 16; i++) {
            double ws[3];
            float ps;
            lr__wl_sample(&disp, u[i], ws, &ps);
            assert_true(fabs(p16[i] - ps) < 1e-6);
            for (int c = 0; c < 3; c++) {
                if (fabs(w16[c][i] - ws[c]) > 1e-5 * (1 + fabs(ws[c])))
                    fail_msg("u %g channel %d: float %g, double %g", u[i], c,
                             w16[c][i], ws[c]);
                sum16[c] += w16[c][i] / N16;
            }
        }
    }
    for (int c = 0; c < 3; c++)
        if (fabs(sum16[c] - 1) > 1e-3)
            fail_msg("float weights, channel %d: mean %.6f", c, sum16[c]);
    /* The power the table gives back is the camera's. */
    double w[3];
    float pw;
    double nm = lr__wl_sample(&disp, 0.3, w, &pw);
    assert_true(fabs(pw - lr__wl_lerp(power, nm)) < 1e-6);
    /* With dispersion, the wavelengths far from the d line gain density
     * against those near it (the edge factor), and the density near the
     * d line keeps at least the defensive 10% of p ~ |w|'s. */
    double near = lr__wl_pdf(&disp, 588) / lr__wl_pdf(&flat, 588);
    double far = lr__wl_pdf(&disp, 430) / lr__wl_pdf(&flat, 430);
    assert_true(far > 2 * near);
    assert_true(near > 0.1);
}

static const struct CMUnitTest spectral_tests[] = {
    cmocka_unit_test(test_white_bar_matches_cie_integral),
    cmocka_unit_test(test_grey_card_is_exact),
    cmocka_unit_test(test_thin_lens_shift_is_a_focus_change),
    cmocka_unit_test(test_splat_crop_and_threads_exact),
    cmocka_unit_test(test_wavelength_weights_integrate_to_one),
};
LR_TEST_GROUP(spectral, spectral_tests)
