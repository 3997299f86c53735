/*
 * test_optics.c: what the lens models share, against optics, not against
 * our own output: zero aperture is the pinhole, the focal plane is sharp,
 * chromatic focus by channel and by wavelength, energy conservation, the
 * glass catalogue and the colour matching functions.  Blur sizes are
 * measured as second moments (point_scene.h).  One model's own tests are
 * in test_camera_<name>.c.
 */
#include "test.h"
#include "camera/camera.h"
#include "optics/lens.h"
#include "optics/prescription.h"
#include "sampling/spectrum.h"

/* Last: its W and FOV are macros. */
#include "point_scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* ---- the focal plane ------------------------------------------------ */

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
    /* The thin lens's "SF11" is the catalogue's N-SF11 (as the paper's
     * reference names it), not the catalogue's SF11 (V_d 25.76), and
     * camera.chromatic.glass takes "N-SF11" for it. */
    lr__glass nsf11, sf11;
    assert_int_equal(lr__glass_named("N-SF11", &nsf11, NULL, 0), 0);
    assert_int_equal(lr__glass_named("SF11", &sf11, NULL, 0), 0);
    for (double nm = 380; nm <= 780; nm += 100) {
        double n = lr__glass_index(LR_GLASS_SF11, 0, 0, nm);
        assert_true(fabs(n - lr__glass_n(&nsf11, nm)) < 1e-12);
    }
    /* (the two share n_d; at 380 nm 1.8607 against 1.8603) */
    assert_true(fabs(lr__glass_index(LR_GLASS_SF11, 0, 0, 380) -
                     lr__glass_n(&sf11, 380)) > 2e-4);
    lr_scene *sc = lr_test_load_json(
        "{\"camera\": {\"model\": \"thinlens\", \"focal_length_mm\": 50, "
        "\"chromatic\": {\"mode\": "
        "\"spectral\", \"glass\": \"N-SF11\"}}}");
    lr_camera cam;
    lr_scene_camera(sc, &cam);
    assert_int_equal(cam.chromatic.glass, LR_GLASS_SF11);
    lr_scene_free(sc);
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
    cmocka_unit_test(test_focal_plane_sharp),
    cmocka_unit_test(test_chromatic_focus_rgb),
    cmocka_unit_test(test_chromatic_spectral_order),
    cmocka_unit_test(test_spectral_white_is_white),
    cmocka_unit_test(test_energy_conserved),
    cmocka_unit_test(test_glass_catalogue),
    cmocka_unit_test(test_colour_matching),
};
LR_TEST_GROUP(optics, optics_tests)
