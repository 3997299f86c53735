/*
 * test_coating.c: surface reflectance (lib/optics/coating.c) against
 * formulas written here that share no code with it: Fresnel's equations
 * in their sine and tangent forms (Born & Wolf, section 1.5.2), the
 * single-layer sum of multiple reflections (Airy's formula; Hecht,
 * Optics, section 9.7; Macleod, section 2.5), the quarter-wave and
 * half-wave rules, and energy conservation; then the prescription key
 * "coating" and its errors.
 */
#include "test.h"
#include "optics/coating.h"
#include "optics/ghost.h"
#include "json/json_util.h"
#include "optics/lens_load.h"
#include "optics/prescription.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Fresnel amplitude coefficients by the angles themselves: r_s =
 * -sin(i - t) / sin(i + t), r_p = tan(i - t) / tan(i + t); at normal
 * incidence the limit (n1 - n2) / (n1 + n2). */
static void fresnel_angles(double n1, double n2, double i, double *rs,
                           double *rp)
{
    if (i == 0.0) {
        *rs = (n1 - n2) / (n1 + n2);
        *rp = -*rs;
        return;
    }
    double t = asin(n1 * sin(i) / n2);
    *rs = -sin(i - t) / sin(i + t);
    *rp = tan(i - t) / tan(i + t);
}

/* One layer (index n1, thickness d) between n0 and n2, one polarisation
 * from its two interfaces' amplitudes r01 and r12 and the layer's phase
 * thickness delta (Airy): R = (r01^2 + r12^2 + 2 r01 r12 cos 2 delta) /
 * (1 + r01^2 r12^2 + 2 r01 r12 cos 2 delta). */
static double airy(double r01, double r12, double delta)
{
    double c = cos(2.0 * delta);
    return (r01 * r01 + r12 * r12 + 2.0 * r01 * r12 * c) /
           (1.0 + r01 * r01 * r12 * r12 + 2.0 * r01 * r12 * c);
}

/* A single layer's unpolarised reflectance at angle i (radians, in n0). */
static double one_layer(double n0, double n1, double n2, double d_nm, double i,
                        double nm)
{
    double a[2], b[2];
    double t1 = asin(n0 * sin(i) / n1);
    fresnel_angles(n0, n1, i, &a[0], &a[1]);
    fresnel_angles(n1, n2, t1, &b[0], &b[1]);
    double delta = 2.0 * M_PI * n1 * d_nm * cos(t1) / nm;
    return 0.5 * (airy(a[0], b[0], delta) + airy(a[1], b[1], delta));
}

static double nbk7(double nm)
{
    lr__glass g;
    assert_int_equal(lr__glass_named("N-BK7", &g, NULL, 0), 0);
    return lr__glass_n(&g, nm);
}

static void test_bare_fresnel(void **state)
{
    (void)state;
    const double ns[] = {1.45, 1.5168, 1.7, 1.9};
    for (int k = 0; k < 4; k++) {
        double n = ns[k], want = ((1 - n) / (1 + n)) * ((1 - n) / (1 + n));
        double R, T;
        lr__stack_rt(1.0, n, NULL, NULL, 0, 1.0, 550, &R, &T);
        assert_true(fabs(lr__fresnel_r(1.0, n, 1.0) - want) < 1e-15);
        assert_true(fabs(lr__fresnel_r(n, 1.0, 1.0) - want) < 1e-15);
        assert_true(fabs(R - want) < 1e-14);
        /* Every angle below grazing, from air and (below the critical
         * angle) from the glass: the matrix code with no layers and the
         * direct formula against the sine and tangent forms. */
        for (double deg = 0; deg < 89.5; deg += 1.0) {
            double i = deg * M_PI / 180, rs, rp;
            for (int dir = 0; dir < 2; dir++) {
                double n1 = dir ? n : 1.0, n2 = dir ? 1.0 : n;
                if (n1 * sin(i) >= n2)
                    continue;
                fresnel_angles(n1, n2, i, &rs, &rp);
                double w = 0.5 * (rs * rs + rp * rp);
                lr__stack_rt(n1, n2, NULL, NULL, 0, cos(i), 550, &R, &T);
                assert_true(fabs(lr__fresnel_r(n1, n2, cos(i)) - w) < 1e-13);
                assert_true(fabs(R - w) < 1e-13);
                assert_true(fabs(R + T - 1.0) < 1e-13);
            }
        }
        /* At Brewster's angle p is not reflected: R = R_s / 2. */
        double b = atan(n), rs, rp;
        fresnel_angles(1.0, n, b, &rs, &rp);
        assert_true(fabs(rp) < 1e-15);
        assert_true(fabs(lr__fresnel_r(1.0, n, cos(b)) - 0.5 * rs * rs) <
                    1e-15);
    }
}

static void test_total_internal_reflection(void **state)
{
    (void)state;
    double n = 1.5, crit = asin(1.0 / n);
    lr__coating mgf2 = {0};
    for (double deg = 42.0; deg < 90.0; deg += 4.0) {
        double c = cos(deg * M_PI / 180);
        assert_true(deg * M_PI / 180 > crit);
        assert_true(lr__fresnel_r(n, 1.0, c) == 1.0);
        assert_true(lr__coated_r(&mgf2, 1, n, 1.0, c, 550) == 1.0);
    }
    /* Just below the critical angle the reflection is partial, and
     * rises toward 1. */
    double below = lr__fresnel_r(n, 1.0, cos(crit - 1e-3));
    assert_true(below < 1.0 && below > 0.5);
}

static void test_quarter_wave(void **state)
{
    (void)state;
    /* The default layer on N-BK7 at its design wavelength: the minimum
     * ((n0 ns - nc^2) / (n0 ns + nc^2))^2. */
    lr__coating mgf2 = {0};
    double ns = nbk7(550), nc = lr__film_n(LR__FILM_MGF2, 550);
    double want = (ns - nc * nc) / (ns + nc * nc);
    want *= want;
    double got = lr__coated_r(&mgf2, 1, 1.0, ns, 1.0, 550);
    print_message("MgF2 quarter wave on N-BK7 at 550 nm: R %.6f (bare "
                  "%.6f); nc %.5f, layer %.3f nm\n",
                  got, lr__fresnel_r(1.0, ns, 1.0), nc, 550 / (4 * nc));
    assert_true(fabs(got - want) < 1e-12);
    assert_true(fabs(nc - 1.3785) < 1e-4); /* Dodge 1984, at 550 nm */
    /* Issue 29's target: the thin-film formula's value at 450, 550 and
     * 650 nm within 1e-4 (here Airy's sum), and at oblique incidence,
     * from the air and from the glass. */
    const double nms[] = {450, 550, 650};
    for (int k = 0; k < 3; k++) {
        double nm = nms[k], n_s = nbk7(nm), n_c = lr__film_n(LR__FILM_MGF2, nm);
        double d = 550 / (4 * lr__film_n(LR__FILM_MGF2, 550));
        for (double deg = 0; deg <= 60; deg += 15) {
            double i = deg * M_PI / 180;
            double a = one_layer(1.0, n_c, n_s, d, i, nm);
            double b = lr__coated_r(&mgf2, 1, 1.0, n_s, cos(i), nm);
            print_message("  %3.0f nm %2.0f deg: R %.6f, Airy %.6f\n", nm, deg,
                          b, a);
            assert_true(fabs(a - b) < 1e-12);
            /* From inside the glass at the refracted angle: the same
             * (a lossless stack reflects alike from either side). */
            double ti = asin(sin(i) / n_s);
            double c = lr__coated_r(&mgf2, 1, n_s, 1.0, cos(ti), nm);
            assert_true(fabs(c - a) < 1e-12);
        }
    }
    /* Off the design wavelength the layer reflects more: purple-tinted
     * reflections, blue and red above green. */
    assert_true(lr__coated_r(&mgf2, 1, 1.0, nbk7(450), 1.0, 450) > got);
    assert_true(lr__coated_r(&mgf2, 1, 1.0, nbk7(650), 1.0, 650) > got);
}

static void test_thin_layers(void **state)
{
    (void)state;
    double ns = 1.62, n[1], d[1], R, bare;
    /* A layer of no thickness is not there, at any angle. */
    n[0] = lr__film_n(LR__FILM_TIO2, 500);
    d[0] = 0.0;
    for (double deg = 0; deg < 85; deg += 5) {
        double c = cos(deg * M_PI / 180);
        lr__stack_rt(1.0, ns, n, d, 1, c, 500, &R, NULL);
        assert_true(fabs(R - lr__fresnel_r(1.0, ns, c)) < 1e-14);
    }
    /* A half-wave layer is "absent" at its design wavelength at normal
     * incidence, and not elsewhere. */
    for (int f = 0; f < LR__FILM_COUNT; f++) {
        n[0] = lr__film_n((lr__film)f, 600);
        d[0] = 600 / (2 * n[0]);
        bare = lr__fresnel_r(1.0, ns, 1.0);
        lr__stack_rt(1.0, ns, n, d, 1, 1.0, 600, &R, NULL);
        assert_true(fabs(R - bare) < 1e-14);
        lr__stack_rt(1.0, ns, n, d, 1, 1.0, 450, &R, NULL);
        assert_true(fabs(R - bare) > 1e-4);
    }
}

static void test_energy(void **state)
{
    (void)state;
    /* A four-layer stack (the layers' thicknesses chosen arbitrarily):
     * R + T = 1 from either side, at every angle the substrate lets
     * through, and TIR inside it (evanescent layers included) still
     * conserves: R = 1, T = 0. */
    const lr__film films[4] = {LR__FILM_AL2O3, LR__FILM_ZRO2, LR__FILM_TIO2,
                               LR__FILM_MGF2};
    const double dn[4] = {81.0, 133.5, 17.2, 96.0};
    for (double nm = 400; nm <= 700; nm += 50) {
        double n[4], d[4];
        for (int r = 0; r < 4; r++) {
            n[r] = lr__film_n(films[r], nm);
            d[r] = dn[r];
        }
        for (double deg = 0; deg < 89; deg += 3) {
            double c = cos(deg * M_PI / 180), R, T;
            lr__stack_rt(1.0, 1.74, n, d, 4, c, nm, &R, &T);
            assert_true(R > 0.0 && R < 1.0);
            assert_true(fabs(R + T - 1.0) < 1e-12);
            lr__stack_rt(1.74, 1.0, n, d, 4, c, nm, &R, &T);
            if (1.74 * sin(deg * M_PI / 180) >= 1.0)
                assert_true(R == 1.0 && T == 0.0);
            else
                assert_true(fabs(R + T - 1.0) < 1e-12);
        }
    }
}

static void test_evanescent_layer(void **state)
{
    (void)state;
    /* Light in glass of 1.9 onto glass of 1.8 through a MgF2 layer:
     * past sin_i = n_MgF2 / 1.9 the wave in the layer is evanescent
     * (frustrated total reflection), yet the substrate passes it: R + T
     * = 1 still, R rising toward 1 as the layer thickens, and nothing
     * breaks at the layer's own critical angle. */
    double nl = lr__film_n(LR__FILM_MGF2, 550), R, T, last = 0.0;
    const double crit = asin(nl / 1.9);
    for (double deg = 0; deg < 71; deg += 2) {
        double i = deg * M_PI / 180, d = 120.0;
        lr__stack_rt(1.9, 1.8, &nl, &d, 1, cos(i), 550, &R, &T);
        assert_true(fabs(R + T - 1.0) < 1e-12);
    }
    for (double d = 50; d <= 800; d += 50) {
        lr__stack_rt(1.9, 1.8, &nl, &d, 1, cos(crit + 0.05), 550, &R, &T);
        assert_true(R > last && fabs(R + T - 1.0) < 1e-12);
        last = R;
    }
    assert_true(last > 0.99);
    double d = 100.0;
    lr__stack_rt(1.9, 1.8, &nl, &d, 1, sqrt(1 - (nl / 1.9) * (nl / 1.9)), 550,
                 &R, &T);
    assert_true(isfinite(R) && fabs(R + T - 1.0) < 1e-12);
}

static void test_layer_order(void **state)
{
    (void)state;
    /* layer[0] is on the glass: from the air, the light meets the last
     * layer first. */
    lr__coating c = {.kind = LR__COAT_LAYERS, .n = 2};
    c.layer[0] = (lr__layer){LR__FILM_TIO2, 60.0};
    c.layer[1] = (lr__layer){LR__FILM_MGF2, 100.0};
    double n[2] = {lr__film_n(LR__FILM_MGF2, 520),
                   lr__film_n(LR__FILM_TIO2, 520)};
    double d[2] = {100.0, 60.0}, R, Rswap;
    lr__stack_rt(1.0, 1.6, n, d, 2, 0.9, 520, &R, NULL);
    assert_true(fabs(lr__coated_r(&c, 1, 1.0, 1.6, 0.9, 520) - R) < 1e-15);
    double ns[2] = {n[1], n[0]}, ds[2] = {60.0, 100.0};
    lr__stack_rt(1.0, 1.6, ns, ds, 2, 0.9, 520, &Rswap, NULL);
    assert_true(fabs(R - Rswap) > 1e-3);
    /* A cemented or air-spaced surface (glass_air 0) is bare whatever
     * the coating says; no index step, no reflection. */
    assert_true(lr__coated_r(&c, 0, 1.5, 1.7, 1.0, 520) ==
                lr__fresnel_r(1.5, 1.7, 1.0));
    assert_true(lr__coated_r(&c, 0, 1.0, 1.0, 0.7, 520) == 0.0);
    lr__coating none = {.kind = LR__COAT_NONE};
    assert_true(lr__coated_r(&none, 1, 1.0, 1.6, 0.8, 520) ==
                lr__fresnel_r(1.0, 1.6, 0.8));
}

/* ---- the prescription key ---------------------------------------------- */

static lr_status parse(const char *text, lr__rx *rx, lr_error *err)
{
    cJSON *o = NULL;
    lr_status st = lr__json_parse(text, strlen(text), "lens", "", &o, err);
    if (st == LR_OK)
        st = lr__rx_from_json(o, "", rx, err);
    cJSON_Delete(o);
    return st;
}

/* A singlet whose front surface (surfaces[1]) carries `coat`; the stop
 * (surfaces[0]) carries `stopcoat`. */
static lr_status singlet(const char *coat, const char *stopcoat, lr__rx *rx,
                         lr_error *err)
{
    char text[2048];
    snprintf(text, sizeof text,
             "{\"surfaces\": ["
             "{\"stop\": true, \"thickness\": 1, \"semi_aperture\": 5%s},"
             "{\"radius\": 50, \"thickness\": 4, \"material\": \"N-BK7\","
             " \"semi_aperture\": 10%s},"
             "{\"radius\": -50, \"thickness\": 48, \"material\": \"air\","
             " \"semi_aperture\": 10}]}",
             stopcoat, coat);
    return parse(text, rx, err);
}

static void expect_error(const char *coat, const char *stopcoat,
                         const char *path, const char *words)
{
    lr__rx rx;
    lr_error err;
    assert_int_equal(singlet(coat, stopcoat, &rx, &err), LR_ERR_INVALID);
    print_message("  %s\n", err.message);
    assert_string_equal(err.path, path);
    assert_non_null(strstr(err.message, path));
    assert_non_null(strstr(err.message, words));
}

static void test_json_key(void **state)
{
    (void)state;
    lr__rx rx;
    lr_error err;
    assert_int_equal(singlet("", "", &rx, &err), LR_OK);
    assert_int_equal(rx.s[1].coating.kind, LR__COAT_MGF2);
    assert_int_equal(rx.s[2].coating.kind, LR__COAT_MGF2);
    assert_true(lr__rx_glass_air(&rx, 1) && lr__rx_glass_air(&rx, 2));
    assert_false(lr__rx_glass_air(&rx, 0));
    assert_int_equal(singlet(", \"coating\": \"none\"", "", &rx, &err), LR_OK);
    assert_int_equal(rx.s[1].coating.kind, LR__COAT_NONE);
    assert_int_equal(singlet(", \"coating\": \"mgf2\"", "", &rx, &err), LR_OK);
    assert_int_equal(rx.s[1].coating.kind, LR__COAT_MGF2);
    assert_int_equal(
        singlet(", \"coating\": {\"layers\": [{\"material\": \"Al2O3\", "
                "\"thickness_nm\": 80}, {\"material\": \"zro2\", "
                "\"thickness_nm\": 130.5}, {\"material\": \"MgF2\", "
                "\"thickness_nm\": 99}]}",
                ", \"coating\": \"none\"", &rx, &err),
        LR_OK);
    assert_int_equal(rx.s[1].coating.kind, LR__COAT_LAYERS);
    assert_int_equal(rx.s[1].coating.n, 3);
    assert_int_equal(rx.s[1].coating.layer[1].film, LR__FILM_ZRO2);
    assert_true(rx.s[1].coating.layer[1].thickness_nm == 130.5);

    expect_error(", \"coating\": \"MgF2 \"", "", "surfaces[1].coating",
                 "must be \"none\", \"mgf2\" or");
    expect_error(", \"coating\": 3", "", "surfaces[1].coating", "got 3");
    expect_error(", \"coating\": {\"layer\": []}", "",
                 "surfaces[1].coating.layer", "unknown key");
    expect_error(", \"coating\": {\"layers\": []}", "",
                 "surfaces[1].coating.layers", "1 to 8 layers");
    expect_error(", \"coating\": {\"layers\": [{\"material\": \"MgF2\", "
                 "\"thickness_nm\": 0}]}",
                 "", "surfaces[1].coating.layers[0].thickness_nm",
                 "must be > 0");
    expect_error(", \"coating\": {\"layers\": [{\"material\": \"MgF2\", "
                 "\"thickness_nm\": 90}, {\"material\": \"MgF2\", "
                 "\"thickness_nm\": -5}]}",
                 "", "surfaces[1].coating.layers[1].thickness_nm", "got -5");
    expect_error(", \"coating\": {\"layers\": [{\"material\": \"ITO\", "
                 "\"thickness_nm\": 90}]}",
                 "", "surfaces[1].coating.layers[0].material",
                 "one of MgF2, SiO2, Al2O3, ZrO2, TiO2");
    expect_error(", \"coating\": {\"layers\": [{\"thickness_nm\": 90}]}", "",
                 "surfaces[1].coating.layers[0].material", "required");
    expect_error(", \"coating\": {\"layers\": [{\"material\": \"MgF2\", "
                 "\"thickness_nm\": 90, \"n\": 1.4}]}",
                 "", "surfaces[1].coating.layers[0].n", "unknown key");
    /* The stop sits in air on both sides. */
    expect_error("", ", \"coating\": \"mgf2\"", "surfaces[0].coating",
                 "air on both sides");
}

static void test_cemented_surface(void **state)
{
    (void)state;
    const char *text =
        "{\"surfaces\": ["
        "{\"stop\": true, \"thickness\": 1, \"semi_aperture\": 5},"
        "{\"radius\": 50, \"thickness\": 4, \"material\": \"N-BK7\","
        " \"semi_aperture\": 10},"
        "{\"radius\": -40, \"thickness\": 2, \"material\": \"F2\","
        " \"semi_aperture\": 10%s},"
        "{\"radius\": -150, \"thickness\": 48, \"material\": \"air\","
        " \"semi_aperture\": 10}]}";
    char buf[1024];
    lr__rx rx;
    lr_error err;
    snprintf(buf, sizeof buf, text, "");
    assert_int_equal(parse(buf, &rx, &err), LR_OK);
    assert_false(lr__rx_glass_air(&rx, 2));
    snprintf(buf, sizeof buf, text, ", \"coating\": \"none\"");
    assert_int_equal(parse(buf, &rx, &err), LR_OK);
    snprintf(buf, sizeof buf, text, ", \"coating\": \"mgf2\"");
    assert_int_equal(parse(buf, &rx, &err), LR_ERR_INVALID);
    print_message("  %s\n", err.message);
    assert_string_equal(err.path, "surfaces[2].coating");
    assert_non_null(strstr(err.message, "glass on both sides"));
}

/* An inline lens (camera.lens as an object) carries its coatings into
 * the loaded lens, and two that differ only there are two lenses. */
static void test_inline_lens(void **state)
{
    (void)state;
    const char *text = "{\"surfaces\": ["
                       "{\"stop\": true, \"thickness\": 1, "
                       "\"semi_aperture\": 5},"
                       "{\"radius\": 50, \"thickness\": 4, \"material\": "
                       "\"N-BK7\", \"semi_aperture\": 10%s},"
                       "{\"radius\": -50, \"thickness\": 48, "
                       "\"material\": \"air\", \"semi_aperture\": 10}]}";
    const char *coats[2] = {"", ", \"coating\": \"none\""};
    const lr_lens *L[2];
    for (int k = 0; k < 2; k++) {
        char buf[1024];
        cJSON *o = NULL;
        lr_error err;
        snprintf(buf, sizeof buf, text, coats[k]);
        assert_int_equal(lr__json_parse(buf, strlen(buf), "lens", "", &o, &err),
                         LR_OK);
        assert_int_equal(
            lr__lens_from_json(o, "camera.lens", NULL, &L[k], &err), LR_OK);
        cJSON_Delete(o);
    }
    assert_true(L[0] != L[1]);
    assert_int_equal(L[0]->rx.s[1].coating.kind, LR__COAT_MGF2);
    assert_int_equal(L[1]->rx.s[1].coating.kind, LR__COAT_NONE);
}

static const struct CMUnitTest coating_tests[] = {
    cmocka_unit_test(test_bare_fresnel),
    cmocka_unit_test(test_total_internal_reflection),
    cmocka_unit_test(test_quarter_wave),
    cmocka_unit_test(test_thin_layers),
    cmocka_unit_test(test_energy),
    cmocka_unit_test(test_evanescent_layer),
    cmocka_unit_test(test_layer_order),
    cmocka_unit_test(test_json_key),
    cmocka_unit_test(test_cemented_surface),
    cmocka_unit_test(test_inline_lens),
};

LR_TEST_GROUP(coating, coating_tests)
