/*
 * test_paraxial.c: lr__rx_paraxial against first-order optics computed
 * here another way: ray-transfer matrices on the real (not reduced)
 * angle, y' = y + t u and n' u' = n u - y (n' - n) / R (Hecht, Optics,
 * 5th ed., 6.2), with the pupils found by tracing a ray from the stop's
 * centre backwards and forwards and intersecting it with the axis; the
 * thick-lens formula for a singlet; and a patent's own back focus.
 */
#include "test.h"
#include "optics/prescription.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static double index_after(const lr__rx *rx, int i, double nm)
{
    return i < 0 ? 1.0 : lr__glass_n(&rx->s[i].after, nm);
}

/* Refraction at surface i on (y, u), light going toward +z. */
static void refract(const lr__rx *rx, int i, double nm, double *y, double *u)
{
    double n = index_after(rx, i - 1, nm), n2 = index_after(rx, i, nm);
    double c = rx->s[i].radius != 0 ? 1.0 / rx->s[i].radius : 0;
    *u = (n * *u - *y * (n2 - n) * c) / n2;
}

/* The same surface crossed backwards (toward -z): the inverse step. */
static void unrefract(const lr__rx *rx, int i, double nm, double *y, double *u)
{
    double n = index_after(rx, i - 1, nm), n2 = index_after(rx, i, nm);
    double c = rx->s[i].radius != 0 ? 1.0 / rx->s[i].radius : 0;
    *u = (n2 * *u + *y * (n2 - n) * c) / n;
}

typedef struct truth {
    double efl, bfl, ffl, enp_pos, enp_diam, exp_pos, exp_diam;
} truth;

static truth first_order(const lr__rx *rx, double nm)
{
    truth t;
    int n = rx->n, s = rx->stop;
    /* A ray parallel to the axis at height 1: focal length and back
     * focus from where it leaves. */
    double y = 1, u = 0;
    for (int i = 0; i < n; i++) {
        if (i > 0)
            y += rx->s[i - 1].thickness * u;
        refract(rx, i, nm, &y, &u);
    }
    t.efl = -1.0 / u;
    t.bfl = -y / u;
    /* A ray leaving parallel, traced backwards from the image side. */
    y = 1;
    u = 0;
    for (int i = n - 1; i >= 0; i--) {
        unrefract(rx, i, nm, &y, &u);
        if (i > 0)
            y -= rx->s[i - 1].thickness * u;
    }
    t.ffl = -y / u; /* it crosses the axis where y + u z = 0 */
    /* Entrance pupil: a ray from the stop's centre at a small angle,
     * backwards through the surfaces before the stop, into object
     * space; where it (extended) crosses the axis is the pupil, and the
     * marginal ray from the stop's rim gives its size. */
    double a = rx->s[s].semi_aperture;
    y = 0;
    u = 1e-3;
    double ym = a, um = 0;
    for (int i = s - 1; i >= 0; i--) {
        y -= rx->s[i].thickness * u;
        ym -= rx->s[i].thickness * um;
        unrefract(rx, i, nm, &y, &u);
        unrefract(rx, i, nm, &ym, &um);
    }
    t.enp_pos = -y / u;
    t.enp_diam = 2 * fabs(ym + um * t.enp_pos);
    /* Exit pupil: forwards from the stop (which refracts too). */
    y = 0;
    u = 1e-3;
    ym = a;
    um = 0;
    for (int i = s; i < n; i++) {
        if (i > s) {
            y += rx->s[i - 1].thickness * u;
            ym += rx->s[i - 1].thickness * um;
        }
        refract(rx, i, nm, &y, &u);
        refract(rx, i, nm, &ym, &um);
    }
    t.exp_pos = -y / u;
    t.exp_diam = 2 * fabs(ym + um * t.exp_pos);
    return t;
}

static void close_to(double got, double want, double scale, const char *what,
                     const char *lens)
{
    if (!(fabs(got - want) <= 1e-9 * scale))
        fail_msg("%s %s: %.12g, the matrices say %.12g", lens, what, got, want);
}

static void check(const char *name)
{
    char path[4096];
    lr_error err;
    lr__rx rx;
    if (lr__rx_find(name, NULL, path, sizeof path, &err) != LR_OK ||
        lr__rx_load_file(path, name, NULL, &rx, &err) != LR_OK)
        fail_msg("%s: %s", name, err.message);
    const double nms[] = {LR__NM_F, LR__NM_d, LR__NM_C, 450.0};
    for (int k = 0; k < 4; k++) {
        lr__paraxial p;
        assert_int_equal(lr__rx_paraxial(&rx, nms[k], &p, &err), LR_OK);
        truth t = first_order(&rx, nms[k]);
        double f = fabs(t.efl);
        close_to(p.efl, t.efl, f, "efl", name);
        close_to(p.bfl, t.bfl, f, "bfl", name);
        close_to(p.ffl, t.ffl, f, "ffl", name);
        close_to(p.enp_pos, t.enp_pos, f, "entrance pupil", name);
        close_to(p.enp_diam, t.enp_diam, f, "entrance pupil diameter", name);
        close_to(p.exp_pos, t.exp_pos, f, "exit pupil", name);
        close_to(p.exp_diam, t.exp_diam, f, "exit pupil diameter", name);
        close_to(p.f_number, t.efl / t.enp_diam, 1, "f-number", name);
        double track = 0;
        for (int i = 0; i < rx.n; i++)
            track += rx.s[i].thickness;
        close_to(p.total_track, track, f, "total track", name);
    }
}

static void test_against_matrices(void **state)
{
    (void)state;
    const char *lenses[] = {"double-gauss-50",
                            "wide-22",
                            "telephoto-250",
                            "fisheye-10",
                            "petzval",
                            "tests/data/lenses/cooke-triplet.zmx",
                            "tests/data/lenses/asphere-singlet.zmx",
                            "tests/data/lenses/dgauss.50mm.dat"};
    for (size_t i = 0; i < sizeof lenses / sizeof lenses[0]; i++)
        check(lenses[i]);
}

static void test_thick_lens(void **state)
{
    (void)state;
    /* A singlet behind a stop at its front vertex: 1/f = (n - 1) (1/R1 -
     * 1/R2 + (n - 1) d / (n R1 R2)), back focus f (1 - (n - 1) d /
     * (n R1)) (the thick-lens formulas, Hecht 6.2). */
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 2;
    rx.stop = 0;
    double R1 = 40, R2 = -60, d = 5, n = 1.6;
    rx.s[0] = (lr__surface){.radius = R1,
                            .thickness = d,
                            .semi_aperture = 8,
                            .stop = 1,
                            .after = {.kind = LR__GLASS_CONSTANT, .nd = n}};
    rx.s[1] = (lr__surface){.radius = R2,
                            .thickness = 30,
                            .semi_aperture = 8,
                            .after = {.kind = LR__GLASS_AIR, .nd = 1}};
    lr__paraxial p;
    lr_error err;
    assert_int_equal(lr__rx_paraxial(&rx, 550, &p, &err), LR_OK);
    double f = 1 / ((n - 1) * (1 / R1 - 1 / R2 + (n - 1) * d / (n * R1 * R2)));
    assert_true(fabs(p.efl - f) < 1e-12 * f);
    assert_true(fabs(p.bfl - f * (1 - (n - 1) * d / (n * R1))) < 1e-12 * f);
    assert_true(fabs(p.enp_pos) < 1e-15 && fabs(p.enp_diam - 16) < 1e-12);
    assert_true(fabs(p.f_number - f / 16) < 1e-12);
    /* A negative lens forms no image: an error, not a number. */
    rx.s[0].radius = -40;
    rx.s[1].radius = 60;
    assert_int_equal(lr__rx_check(&rx, "", &err), LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "forms no image"));
}

static void test_patent_back_focus(void **state)
{
    (void)state;
    /* Tronnier, US 2,673,491: back focus 0.71436 f, printed to 5 digits
     * for the patent's radii (which our lens rounds to pbrt's 3 decimals
     * at 50 mm, hence 5e-5). */
    char path[4096];
    lr_error err;
    lr__rx rx;
    lr__paraxial p;
    assert_int_equal(
        lr__rx_find("double-gauss-50", NULL, path, sizeof path, &err), LR_OK);
    assert_int_equal(lr__rx_load_file(path, "dg", NULL, &rx, &err), LR_OK);
    assert_int_equal(lr__rx_paraxial(&rx, LR__NM_d, &p, &err), LR_OK);
    print_message("double Gauss: f %.4f mm, back focus %.5f f (patent "
                  "0.71436), f/%.3f\n",
                  p.efl, p.bfl / p.efl, p.f_number);
    assert_true(fabs(p.bfl / p.efl - 0.71436) < 5e-5);
    assert_true(fabs(p.efl - 50) < 0.05);
}

static const struct CMUnitTest paraxial_tests[] = {
    cmocka_unit_test(test_against_matrices),
    cmocka_unit_test(test_thick_lens),
    cmocka_unit_test(test_patent_back_focus),
};

LR_TEST_GROUP(paraxial, paraxial_tests)
