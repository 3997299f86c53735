/*
 * test_chromatic_extremes.c: chromatic aberration at the ends of its
 * settings.  Equal indices and amplify 0 reduce to the monochrome render
 * byte for byte; nearly equal indices stay within rounding of it; huge
 * amplification, indices next to 1 under the lensmaker model and the ends
 * of the visible range stay finite, for the thin lens and the bracket.
 */
#include "test.h"
#include "optics/lens.h"
#include "sampling/spectrum.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const char *chroma_cam = LR_TEST_CAM_BASE
    ", \"model\": \"%s\", \"aperture_radius\": 0.3,"
    " \"aperture\": 0.3, \"focus_distance\": 6, \"focal_length_mm\": 50,"
    " \"chromatic\": {%s}";

static lr_image *chroma_render(const char *model, const char *chroma,
                               const char *what)
{
    char cam[1024], json[4096];
    snprintf(cam, sizeof cam, chroma_cam, model, chroma);
    lr_test_busy_scene(json, sizeof json, cam,
                       "\"width\": 16, \"height\": 10, \"spp\": 4");
    return lr_test_render_json(json, what);
}

/* Equal indices under rgb: every colour has the reference focus, so the
 * render is the monochrome one, byte for byte. */
static void test_chroma_equal_indices(void **state)
{
    (void)state;
    const char *models[] = {"thinlens", "bracket"};
    const char *fm[] = {"paper", "lensmaker"};
    for (size_t m = 0; m < 2; m++)
        for (size_t k = 0; k < 2; k++) {
            char ch[256];
            lr_image *mono = chroma_render(models[m], "\"mode\": \"off\"",
                                           "mono");
            snprintf(ch, sizeof ch,
                     "\"mode\": \"rgb\", \"focal_model\": \"%s\","
                     " \"ior\": [1.7, 1.7, 1.7]",
                     fm[k]);
            lr_image *rgb = chroma_render(models[m], ch, "rgb equal");
            lr_test_assert_same_bytes(mono, rgb, "rgb with equal indices");
            lr_image_free(rgb);
            lr_image_free(mono);
        }
}

/* amplify 0 switches the aberration off: rgb and spectral renders are the
 * monochrome render byte for byte. */
static void test_chroma_amplify_zero(void **state)
{
    (void)state;
    const char *models[] = {"bracket", "thinlens"};
    for (size_t m = 0; m < 2; m++) {
        lr_image *mono = chroma_render(models[m], "\"mode\": \"off\"", "mono");
        const char *modes[] = {
            "\"mode\": \"rgb\", \"amplify\": 0",
            "\"mode\": \"rgb\", \"amplify\": 0, \"focal_model\": \"lensmaker\"",
            "\"mode\": \"spectral\", \"amplify\": 0",
            "\"mode\": \"spectral\", \"amplify\": 0, \"glass\": \"SF11\","
            " \"focal_model\": \"lensmaker\""};
        for (size_t i = 0; i < 4; i++) {
            lr_image *img = chroma_render(models[m], modes[i], modes[i]);
            lr_test_assert_same_bytes(mono, img, modes[i]);
            lr_image_free(img);
        }
        lr_image_free(mono);
    }
}

/* Nearly equal indices: a focus shift far below a pixel, so the picture
 * is the monochrome one within rounding; huge amplification and indices
 * next to 1 under the lensmaker model stay finite (the model divides by
 * n_ref - 1, which validation keeps above 0). */
static void test_chroma_near_and_extreme(void **state)
{
    (void)state;
    const char *models[] = {"thinlens", "bracket"};
    for (size_t m = 0; m < 2; m++) {
        lr_image *mono = chroma_render(models[m], "\"mode\": \"off\"", "mono");
        lr_image *near = chroma_render(models[m],
                                       "\"mode\": \"rgb\", \"ior\": [1.5, "
                                       "1.5000000000001, 1.5000000000002]",
                                       "nearly equal");
        lr_test_diff d = lr_test_compare(mono, near);
        if (d.max_abs > 1e-4)
            fail_msg("%s: nearly equal indices differ from mono by %g",
                     models[m], d.max_abs);
        lr_image_free(near);
        lr_image_free(mono);
        const char *extreme[] = {
            "\"mode\": \"rgb\", \"amplify\": 1000000",
            "\"mode\": \"rgb\", \"amplify\": 1000000, \"focal_model\": "
            "\"lensmaker\"",
            "\"mode\": \"spectral\", \"amplify\": 1000000, \"wavelengths\": 64",
            "\"mode\": \"spectral\", \"amplify\": 1000000, \"focal_model\":"
            " \"lensmaker\", \"glass\": \"SF11\"",
            "\"mode\": \"rgb\", \"focal_model\": \"lensmaker\","
            " \"ior\": [1.0000000000000004, 1.0000000000000002, "
            "1.000000000000001]",
            "\"mode\": \"rgb\", \"focal_model\": \"lensmaker\", \"amplify\": "
            "1000000,"
            " \"ior\": [3.999999, 1.0000000000000002, 1.0000001]",
            "\"mode\": \"spectral\", \"focal_model\": \"lensmaker\","
            " \"abbe\": {\"n_d\": 1.0000000000000002, \"V_d\": 1}, "
            "\"amplify\": 1000000",
            "\"mode\": \"spectral\", \"abbe\": {\"n_d\": 3.999, \"V_d\": 1000},"
            " \"wavelengths\": 1",
            "\"mode\": \"spectral\", \"wavelengths\": 2, \"glass\": "
            "\"fused_silica\""};
        for (size_t i = 0; i < 9; i++) {
            char what[256];
            snprintf(what, sizeof what, "%s: %s", models[m], extreme[i]);
            lr_image_free(chroma_render(models[m], extreme[i], what));
        }
    }
}

/* The ends of the visible range, and a little beyond, through every
 * dispersion formula: finite indices above 1 and finite matching
 * functions.  Renders sample wavelengths up to the ends. */
static void test_wavelength_ends(void **state)
{
    (void)state;
    const double nms[] = {
        LR__LAMBDA_MIN,        LR__LAMBDA_MIN + 1e-9, 400, 700,
        LR__LAMBDA_MAX - 1e-9, LR__LAMBDA_MAX,        360, 830};
    for (size_t i = 0; i < 8; i++) {
        for (int g = LR_GLASS_BK7; g <= LR_GLASS_ABBE; g++) {
            double n = lr__glass_index((lr_glass)g, 1.5168, 64.17, nms[i]);
            if (!(isfinite(n) && n > 1.0 && n < 4.0))
                fail_msg("glass %d at %g nm: n = %g", g, nms[i], n);
            double lo = lr__glass_index((lr_glass)g, 1.0000001, 1.0, nms[i]);
            assert_true(isfinite(lo));
        }
        double rgb[3];
        lr__srgb_cmf(nms[i], rgb);
        assert_true(isfinite(rgb[0]) && isfinite(rgb[1]) && isfinite(rgb[2]));
        for (int fmod = 0; fmod < 2; fmod++) {
            double sc = lr__power_scale(
                (lr_focal_model)fmod, 1.0000000000000002,
                lr__glass_index(LR_GLASS_SF11, 0, 0, nms[i]));
            assert_true(isfinite(sc));
        }
    }
    /* One wavelength per sample: the sampled wavelength sweeps the whole
     * range over the samples, ends included. */
    lr_image_free(chroma_render("thinlens",
                                "\"mode\": \"spectral\", \"wavelengths\": 1,"
                                " \"glass\": \"SF11\", \"amplify\": 30",
                                "one wavelength"));
}

static const struct CMUnitTest chromatic_extremes_tests[] = {
    cmocka_unit_test(test_chroma_equal_indices),
    cmocka_unit_test(test_chroma_amplify_zero),
    cmocka_unit_test(test_chroma_near_and_extreme),
    cmocka_unit_test(test_wavelength_ends),
};

LR_TEST_GROUP(chromatic_extremes, chromatic_extremes_tests)
