/*
 * test_ghost.c: two-reflection ghost paths (lib/optics/ghost.c).  Flat
 * plates, where a ghost's place follows from geometry worked by hand
 * (each extra pass through a slab of thickness t at angle theta shifts a
 * ray sideways by t tan(theta)) and its weight from the reflectances at
 * the crossings; the stop clipping a ghost; and the shipped double
 * Gauss's brightest ghosts, a first number for issue 29's "auto".
 */
#include "test.h"
#include "optics/coating.h"
#include "optics/ghost.h"
#include "optics/lens_load.h"
#include "optics/prescription.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const lr__coating bare = {.kind = LR__COAT_NONE};

typedef struct landing {
    int ok;
    double x, y, w;
} landing;

static landing trace(const lr__rx *rx, const lr__coating *coat, lr__ghost g,
                     const double o[3], const double d[3])
{
    double z[LR__RX_MAX_SURFACES + 1], hit[2];
    landing l = {0, 0, 0, 0};
    lr__rx_layout(rx, z);
    l.ok = lr__ghost_trace(rx, z, 550, 1.0, coat, g, z[rx->n], o, d, hit, &l.w);
    l.x = hit[0];
    l.y = hit[1];
    return l;
}

/* A unit direction at polar angle theta from the axis, azimuth phi. */
static void direction(double theta, double phi, double d[3])
{
    d[0] = sin(theta) * cos(phi);
    d[1] = sin(theta) * sin(phi);
    d[2] = cos(theta);
}

static void test_paths(void **state)
{
    (void)state;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 12;
    static lr__ghost g[LR__GHOST_MAX];
    int n = lr__ghost_paths(&rx, g);
    assert_int_equal(n, 12 * 11 / 2);
    for (int k = 0; k < n; k++) {
        assert_true(g[k].i >= 0 && g[k].i < g[k].j && g[k].j < 12);
        for (int m = 0; m < k; m++)
            assert_false(g[m].i == g[k].i && g[m].j == g[k].j);
    }
    rx.n = LR__RX_MAX_SURFACES;
    assert_int_equal(lr__ghost_paths(&rx, g), LR__GHOST_MAX);
}

/* One plate of index 1.5 and thickness 5 mm, in air. */
static void test_plate(void **state)
{
    (void)state;
    const double t = 5.0, n = 1.5, theta = 25 * M_PI / 180, phi = 0.6;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 2;
    rx.stop = -1;
    rx.s[0] = lr_test_flat(t, n, 50);
    rx.s[1] = lr_test_flat(20, 1.0, 50);
    double o[3] = {-3, 0.5, -2}, d[3];
    direction(theta, phi, d);
    lr__coating mgf2 = {0};
    for (int c = 0; c < 2; c++) {
        const lr__coating *coat = c ? &mgf2 : &bare;
        landing m = trace(&rx, coat, (lr__ghost){-1, -1}, o, d);
        landing g = trace(&rx, coat, (lr__ghost){1, 0}, o, d);
        assert_true(m.ok && g.ok);
        /* The ghost crosses the plate twice more, each time shifted by
         * t tan(theta_glass) along the ray's azimuth. */
        double tg = asin(sin(theta) / n);
        double shift = 2 * t * tan(tg);
        assert_true(fabs(g.x - m.x - shift * cos(phi)) < 1e-12);
        assert_true(fabs(g.y - m.y - shift * sin(phi)) < 1e-12);
        /* Four crossings, each at theta outside or theta_glass inside,
         * which reflect alike (a lossless interface): R from outside. */
        double R = lr__coated_r(coat, 1, 1.0, n, cos(theta), 550);
        print_message("plate, %s: R %.6f, main %.6f, ghost %.3e, shift "
                      "%.4f mm\n",
                      c ? "MgF2" : "bare", R, m.w, g.w, shift);
        assert_true(fabs(m.w - (1 - R) * (1 - R)) < 1e-14);
        assert_true(fabs(g.w - (1 - R) * (1 - R) * R * R) < 1e-14);
    }
}

/* Plate A (n 1.5, 3 mm), an air gap of 7 mm, plate B (n 1.8, 4 mm): the
 * ghost (2, 1) bounces in the gap, the ghost (3, 0) across both plates
 * and the gap. */
static void test_two_plates(void **state)
{
    (void)state;
    const double tA = 3, nA = 1.5, g = 7, tB = 4, nB = 1.8;
    const double theta = 18 * M_PI / 180, phi = -2.0;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 4;
    rx.stop = -1;
    rx.s[0] = lr_test_flat(tA, nA, 50);
    rx.s[1] = lr_test_flat(g, 1.0, 50);
    rx.s[2] = lr_test_flat(tB, nB, 50);
    rx.s[3] = lr_test_flat(30, 1.0, 50);
    double o[3] = {1, 2, -1}, d[3];
    direction(theta, phi, d);
    double thA = asin(sin(theta) / nA), thB = asin(sin(theta) / nB);
    double RA = lr__fresnel_r(1.0, nA, cos(theta));
    double RB = lr__fresnel_r(1.0, nB, cos(theta));
    double TA = 1 - RA, TB = 1 - RB;
    landing m = trace(&rx, &bare, (lr__ghost){-1, -1}, o, d);
    landing g21 = trace(&rx, &bare, (lr__ghost){2, 1}, o, d);
    landing g30 = trace(&rx, &bare, (lr__ghost){3, 0}, o, d);
    assert_true(m.ok && g21.ok && g30.ok);
    double s21 = 2 * g * tan(theta);
    double s30 = 2 * (tA * tan(thA) + g * tan(theta) + tB * tan(thB));
    assert_true(fabs(g21.x - m.x - s21 * cos(phi)) < 1e-12);
    assert_true(fabs(g21.y - m.y - s21 * sin(phi)) < 1e-12);
    assert_true(fabs(g30.x - m.x - s30 * cos(phi)) < 1e-12);
    assert_true(fabs(g30.y - m.y - s30 * sin(phi)) < 1e-12);
    /* (2, 1): in through 0 and 1, reflect at 2, reflect at 1 (from the
     * gap), on through 2 and 3.  (3, 0): in through 0, 1, 2, reflect at
     * 3, back through 2 and 1, reflect at 0, on through 1, 2, 3. */
    assert_true(fabs(m.w - TA * TA * TB * TB) < 1e-14);
    assert_true(fabs(g21.w - TA * TA * RB * RA * TB * TB) < 1e-15);
    assert_true(fabs(g30.w - RA * RB * pow(TA * TB, 4)) < 1e-15);
    print_message("two plates: ghost (2,1) %.3e at %.4f mm, (3,0) %.3e at "
                  "%.4f mm\n",
                  g21.w, s21, g30.w, s30);
    /* A path that reflects at an air-air surface carries nothing; a
     * path that is not one (i >= j) is refused. */
    rx.s[1] = lr_test_flat(g / 2, 1.0, 50);
    memmove(&rx.s[2], &rx.s[1], 3 * sizeof rx.s[0]);
    rx.n = 5;
    landing z = trace(&rx, &bare, (lr__ghost){2, 1}, o, d);
    assert_true(z.ok && z.w == 0.0);
    assert_false(trace(&rx, &bare, (lr__ghost){1, 2}, o, d).ok);
    assert_false(trace(&rx, &bare, (lr__ghost){5, 1}, o, d).ok);
}

/* A stop in the gap between two plates: the ghost (3, 1) crosses it
 * three times, farther out each time; the main ray once, at its centre. */
static void test_stop_clips(void **state)
{
    (void)state;
    const double g1 = 6, g2 = 4, theta = 12 * M_PI / 180;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 5;
    rx.s[0] = lr_test_flat(2, 1.6, 50);
    rx.s[1] = lr_test_flat(g1, 1.0, 50);
    rx.s[2] = lr_test_flat(g2, 1.0, 1); /* the stop */
    rx.s[3] = lr_test_flat(2, 1.7, 50);
    rx.s[4] = lr_test_flat(30, 1.0, 50);
    rx.stop = 2;
    double d[3], o[3];
    direction(theta, 0, d);
    /* Aim the main ray at the stop's centre: back from (0, 0, z_stop)
     * through the first plate. */
    double ta = asin(sin(theta) / 1.6);
    o[0] = -(g1 * tan(theta) + 2 * tan(ta) + 1 * tan(theta));
    o[1] = 0;
    o[2] = -1;
    /* The ghost meets the stop at 0, then 2 g2 tan(theta) on its way
     * back, then 2 (g1 + g2) tan(theta): a stop between the last two
     * passes the first and blocks the last. */
    double back = 2 * g2 * tan(theta), again = 2 * (g1 + g2) * tan(theta);
    lr__ghost gh = {3, 1};
    rx.s[2].semi_aperture = 0.5 * (back + again);
    assert_true(trace(&rx, &bare, (lr__ghost){-1, -1}, o, d).ok);
    assert_false(trace(&rx, &bare, gh, o, d).ok);
    /* ... and between the first two blocks it on the way back. */
    rx.s[2].semi_aperture = 0.5 * back;
    assert_true(trace(&rx, &bare, (lr__ghost){-1, -1}, o, d).ok);
    assert_false(trace(&rx, &bare, gh, o, d).ok);
    /* The ghost (4, 3) stays behind the stop: still there. */
    assert_true(trace(&rx, &bare, (lr__ghost){4, 3}, o, d).ok);
    /* Wider than the last pass: through. */
    rx.s[2].semi_aperture = 1.01 * again;
    assert_true(trace(&rx, &bare, gh, o, d).ok);
    /* So does an element's edge: plate A's back face narrower than
     * where the ghost comes back to it (back + g1 tan(theta)), wider
     * than where the main ray crosses it (-g1 tan(theta)). */
    rx.s[2].semi_aperture = 50;
    rx.s[1].semi_aperture = 0.99 * (back + g1 * tan(theta));
    assert_false(trace(&rx, &bare, gh, o, d).ok);
    assert_true(trace(&rx, &bare, (lr__ghost){-1, -1}, o, d).ok);
}

/* Total internal reflection where the path refracts: a plate whose back
 * face is a sphere of radius 12 mm, centre toward the object.  A ray
 * parallel to the axis at height h meets it at asin(h / 12) to the
 * normal; past asin(1 / 1.6) = 38.7 deg (h = 7.5 mm) it cannot leave
 * the glass. */
static void test_tir_lost(void **state)
{
    (void)state;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 2;
    rx.stop = -1;
    rx.s[0] = lr_test_flat(10, 1.6, 50);
    rx.s[1] = lr_test_flat(20, 1.0, 50);
    rx.s[1].radius = -12;
    double o[3] = {7.0, 0, -1}, d[3] = {0, 0, 1};
    landing m = trace(&rx, &bare, (lr__ghost){-1, -1}, o, d);
    assert_true(m.ok && m.w > 0.0);
    o[0] = 8.0;
    assert_false(trace(&rx, &bare, (lr__ghost){-1, -1}, o, d).ok);
    /* On the axis the main ray is square on everywhere: (1 - R)^2. */
    o[0] = 0.0;
    m = trace(&rx, &bare, (lr__ghost){-1, -1}, o, d);
    double R = lr__fresnel_r(1.0, 1.6, 1.0);
    assert_true(m.ok && fabs(m.w - (1 - R) * (1 - R)) < 1e-15);
}

/* A ray inside a sphere whose chord has both ends on the vertex sheet,
 * as a ghost's ray is after a reflection turns it back toward a surface
 * concave to it: it meets the surface ahead, at the sphere's positive
 * root |o + t d - C| = R worked here from the geometry.  The quadric's
 * root taken before was the one behind (t = -5.8 here), and ghost.c's
 * cross() dropped the ray: the Biotar's ghost (6,2) lost 36% of its
 * flux, against an independent tracer.  lr__rx_meet (the scalar walk)
 * and lr__rx_lane_meet (the packets') alike. */
static void test_meet_ahead(void **state)
{
    (void)state;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 1;
    rx.stop = -1;
    rx.s[0] = lr_test_flat(10, 1.5, 50);
    rx.s[0].radius = 10.0;
    double z[2];
    lr__rx_layout(&rx, z);
    double o[3] = {0.0, 0.0, z[0] + 3.0}, d[3] = {1.0, 0.0, 0.2};
    double len = sqrt(d[0] * d[0] + d[2] * d[2]);
    d[0] /= len, d[2] /= len;
    /* Centre of curvature (0, 0, z0 + R): t = -b + sqrt(b^2 - (|o - C|^2 -
     * R^2)) with b = d . (o - C). */
    double oc[3] = {o[0], o[1], o[2] - (z[0] + 10.0)};
    double b = d[0] * oc[0] + d[1] * oc[1] + d[2] * oc[2];
    double cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - 100.0;
    double t = -b + sqrt(b * b - cc);
    assert_true(t > 0.0 && -b - sqrt(b * b - cc) < 0.0);
    double want[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
    assert_true(want[2] < z[0] + 10.0); /* on the vertex sheet */
    double p[3], nrm[3];
    assert_true(lr__rx_meet(&rx, z, 1.0, 0, o, d, p, nrm));
    for (int a = 0; a < 3; a++)
        assert_true(fabs(p[a] - want[a]) < 1e-12);
    double lp[3], ln[3];
    assert_true(lr__rx_lane_meet(0.1, 1.0, o[0], o[1], o[2] - z[0], d[0], d[1],
                                 d[2], lp, ln));
    for (int a = 0; a < 3; a++)
        assert_true(fabs(lp[a] + (a == 2 ? z[0] : 0.0) - want[a]) < 1e-12);
    /* A bare lens's ghosts at the lane step and the walk: the Biotar's
     * (6,2), whose rays cross surface 4 so, carries 3.110e-3 of the
     * beam, as an independent tracer (own intersections, Snell, Fresnel,
     * apertures; 61 x 61 beam) gives: it was 2.004e-3. */
    const lr_lens *L;
    assert_int_equal(lr_lens_load("biotar-de485798-100mm-f1.4", NULL, &L, NULL),
                     LR_OK);
    static lr__ghost_flux f[LR__GHOST_MAX];
    double main = 0.0;
    int n = lr__ghost_fluxes(&L->rx, &bare, 0.0, 587.5618, 61,
                             sqrt(18.0 * 18.0 + 12.0 * 12.0), f, &main);
    int found = 0;
    for (int k = 0; k < n; k++)
        if ((f[k].path.i == 6 && f[k].path.j == 2) ||
            (f[k].path.i == 2 && f[k].path.j == 6)) {
            found = 1;
            assert_true(fabs(f[k].flux / 3.110e-3 - 1.0) < 1e-3);
        }
    assert_true(found);
}

/* lr__ghost_fluxes on one flat plate behind a window in air (surface 0,
 * which bounds the beam and reflects nothing): every ray of the beam
 * arrives, so the ghost's flux over the main image's is R^2 (its rays
 * cross the plate's two faces twice more), and the ghost lies
 * 2 t tan(theta_glass) beyond the main image's centre, which lies at
 * L tan(theta) - t (tan(theta) - tan(theta_glass)) for an image plane L
 * behind the window. */
static void test_fluxes_plate(void **state)
{
    (void)state;
    const double t = 4.0, n = 1.6, L = 1.0 + 4.0 + 25.0;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 3;
    rx.stop = 0;
    rx.s[0] = lr_test_flat(1, 1.0, 10);
    rx.s[1] = lr_test_flat(t, n, 80);
    rx.s[2] = lr_test_flat(25, 1.0, 80);
    static lr__ghost_flux f[LR__GHOST_MAX];
    double main;
    const double fields[2] = {0, 20};
    for (int k = 0; k < 2; k++) {
        double th = fields[k] * M_PI / 180, tg = asin(sin(th) / n);
        assert_int_equal(
            lr__ghost_fluxes(&rx, &bare, fields[k], 550, 41, 0, f, &main), 3);
        double R = lr__fresnel_r(1.0, n, cos(th));
        assert_true(fabs(main - (1 - R) * (1 - R)) < 1e-12);
        assert_true(f[0].path.j == 2 && f[0].path.i == 1);
        assert_true(fabs(f[0].flux - R * R) < 1e-12);
        /* The paths reflecting at the window carry nothing. */
        assert_true(f[1].flux == 0.0 && f[2].flux == 0.0);
        double cx_main = L * tan(th) - t * (tan(th) - tan(tg));
        assert_true(fabs(f[0].cx - (cx_main + 2 * t * tan(tg))) < 1e-9);
        assert_true(fabs(f[0].cy) < 1e-12);
        /* The beam's footprint: a disc of the window's radius 10
         * (sampled on a grid), unchanged by flat faces. */
        assert_true(fabs(f[0].rms - 10 / sqrt(2)) < 0.1);
    }
    /* A sensor of 0.5 mm radius: on axis the ghost's rays land where the
     * main image's do, so both are cut alike and the ratio stays R^2.  A
     * beam at 80 degrees lands some 170 mm off axis: no main image on
     * the sensor, 0 returned. */
    assert_int_equal(lr__ghost_fluxes(&rx, &bare, 0, 550, 41, 0.5, f, &main),
                     3);
    double R0 = lr__fresnel_r(1.0, n, 1.0);
    assert_true(main > 0 && main < 0.01);
    assert_true(fabs(f[0].flux - R0 * R0) < 1e-12);
    assert_int_equal(lr__ghost_fluxes(&rx, &bare, 80, 550, 41, 0.5, f, &main),
                     0);
}

/* The shipped double Gauss (lenses/double-gauss-50.json). */
static void double_gauss(lr__rx *rx)
{
    char path[4096];
    lr_error err;
    assert_int_equal(
        lr__rx_find("double-gauss-50", NULL, path, sizeof path, &err), LR_OK);
    assert_int_equal(lr__rx_load_file(path, "dg", NULL, rx, &err), LR_OK);
}

/* The height on the plane z = zs of a paraxial ray entering parallel to
 * the axis at height 1 and following ghost g (j < 0: the main path), by
 * a y-nu trace written here: at each surface n' u' = n u - y c (n' - n),
 * between surfaces y += u dz, with u the slope dy/dz.  A reflection is
 * the same formula with n' = -n (u' = -u - 2 y c), and the ray then
 * travels toward -z in media of negative index until it reflects again
 * (the usual convention for mirrors, as Zemax writes them). */
static double paraxial_ghost(const lr__rx *rx, lr__ghost g, double nm,
                             double zs)
{
    double z[LR__RX_MAX_SURFACES + 1], na[LR__RX_MAX_SURFACES];
    lr__rx_layout(rx, z);
    lr__rx_indices(rx, nm, na);
    /* The sequence of (surface, action): 0 refract, 1 reflect. */
    int seq[3 * LR__RX_MAX_SURFACES][2], m = 0;
    int first = g.j >= 0 ? g.j : rx->n;
    for (int k = 0; k < first; k++)
        seq[m][0] = k, seq[m++][1] = 0;
    if (g.j >= 0) {
        seq[m][0] = g.j, seq[m++][1] = 1;
        for (int k = g.j - 1; k > g.i; k--)
            seq[m][0] = k, seq[m++][1] = 0;
        seq[m][0] = g.i, seq[m++][1] = 1;
        for (int k = g.i + 1; k < rx->n; k++)
            seq[m][0] = k, seq[m++][1] = 0;
    }
    double y = 1.0, u = 0.0, n = 1.0, at = z[0];
    int fwd = 1;
    for (int q = 0; q < m; q++) {
        int k = seq[q][0];
        y += u * (z[k] - at);
        at = z[k];
        double c = rx->s[k].radius != 0.0 ? 1.0 / rx->s[k].radius : 0.0;
        double n2;
        if (seq[q][1]) {
            n2 = -n;
            fwd = !fwd;
        } else {
            /* The medium beyond surface k, the way the ray goes. */
            double beyond = fwd ? na[k] : (k > 0 ? na[k - 1] : 1.0);
            n2 = fwd ? beyond : -beyond;
        }
        u = (n * u - y * c * (n2 - n)) / n2;
        n = n2;
    }
    return y + u * (zs - at);
}

/* Rays close to the axis through curved surfaces against that paraxial
 * trace: the main path and every ghost of the double Gauss, on two
 * sensor planes.  At h = 1e-3 mm the aberrations (relative h^2 and up)
 * are far below the bound. */
static void test_paraxial_ghosts(void **state)
{
    (void)state;
    lr__rx rx;
    double_gauss(&rx);
    static lr__ghost paths[LR__GHOST_MAX + 1];
    int np = lr__ghost_paths(&rx, paths + 1);
    paths[0] = (lr__ghost){-1, -1};
    double z[LR__RX_MAX_SURFACES + 1], worst = 0.0;
    lr__rx_layout(&rx, z);
    const double h = 1e-3;
    int checked = 0;
    for (int p = 0; p <= np; p++) {
        /* Two sensor planes: the designer's and 20 mm beyond. */
        for (int s = 0; s < 2; s++) {
            double zs = z[rx.n] + 20.0 * s;
            double o[3] = {h, 0, -1}, d[3] = {0, 0, 1}, hit[2], w;
            assert_true(lr__ghost_trace(&rx, z, 550, 1.0, &bare, paths[p], zs,
                                        o, d, hit, &w) ||
                        paths[p].j >= 0);
            double want = paraxial_ghost(&rx, paths[p], 550, zs);
            if (!lr__ghost_trace(&rx, z, 550, 1.0, &bare, paths[p], zs, o, d,
                                 hit, &w))
                continue;
            /* Relative to the paraxial height (a magnification of the
             * entering height), with a floor of 1. */
            double e = fabs(hit[0] / h - want) / fmax(1.0, fabs(want));
            worst = fmax(worst, e);
            checked++;
            assert_true(fabs(hit[1]) < 1e-15);
            if (e > 1e-6)
                print_message("  (%d,%d) at z %.1f: real %.6f, paraxial "
                              "%.6f\n",
                              paths[p].j, paths[p].i, zs, hit[0] / h, want);
            assert_true(e < 1e-6);
        }
    }
    print_message("double Gauss: %d landings of rays at 1 um against the "
                  "paraxial ghost trace, worst %.2e\n",
                  checked, worst);
    assert_true(checked >= 2 * np);
    /* The main path's paraxial height is 0 at the paraxial focus: the
     * designer's last thickness is the back focus to 0.004 mm. */
    assert_true(fabs(paraxial_ghost(&rx, paths[0], LR__NM_d, z[rx.n])) < 1e-3);
}

static void show(const char *what, double deg, double nm,
                 const lr__ghost_flux *f, int n)
{
    double all = 0.0, peak = 0.0;
    int at = 0;
    for (int k = 0; k < n; k++) {
        all += f[k].flux;
        /* Mean irradiance over a disc of its rms radius (no smaller than
         * a 10 um pixel), per unit of the main image's flux: times a
         * pixel's area, its brightness against a point source's image
         * held in that pixel. */
        double e = f[k].flux / (M_PI * fmax(f[k].rms * f[k].rms, 1e-4));
        if (e > peak) {
            peak = e;
            at = k;
        }
    }
    print_message("  %-4s %2.0f deg %3.0f nm: brightest (%d,%d) %.3e of the "
                  "main flux, rms %.2f mm; all %.3e; most concentrated "
                  "(%d,%d) %.2e /mm^2\n",
                  what, deg, nm, f[0].path.j, f[0].path.i, f[0].flux, f[0].rms,
                  all, f[at].path.j, f[at].path.i, peak);
}

/* The shipped double Gauss's ghosts, for a distant point, counted within
 * a 36 x 24 mm frame's half diagonal. */
static void test_double_gauss(void **state)
{
    (void)state;
    lr__rx rx;
    double_gauss(&rx);
    /* The largest bare reflectance of any of its surfaces, square on. */
    double n_after[LR__RX_MAX_SURFACES], rmax = 0;
    lr__rx_indices(&rx, 550, n_after);
    for (int i = 0; i < rx.n; i++)
        rmax = fmax(rmax,
                    lr__fresnel_r(i ? n_after[i - 1] : 1.0, n_after[i], 1.0));
    lr__coating mgf2 = {0};
    print_message("double Gauss 50 mm f/2, a distant point, full aperture "
                  "(bare R at most %.4f square on):\n",
                  rmax);
    static lr__ghost_flux b[LR__GHOST_MAX], c[LR__GHOST_MAX];
    double mb, mc;
    const int N = 61, paths = rx.n * (rx.n - 1) / 2;
    const double half_diag = 21.63, fields[2] = {0, 10};
    for (int f = 0; f < 2; f++) {
        assert_int_equal(
            lr__ghost_fluxes(&rx, &bare, fields[f], 550, N, half_diag, b, &mb),
            paths);
        assert_int_equal(
            lr__ghost_fluxes(&rx, &mgf2, fields[f], 550, N, half_diag, c, &mc),
            paths);
        show("bare", fields[f], 550, b, paths);
        show("MgF2", fields[f], 550, c, paths);
        /* Brightest first. */
        for (int k = 1; k < paths; k++)
            assert_true(b[k].flux <= b[k - 1].flux);
        /* The coating passes more of the main image. */
        assert_true(mc > mb);
        /* Two reflections: at most about the largest R squared (the
         * angles inside the lens stay moderate, hence the margin); the
         * coating cuts each R by about 3 or more. */
        assert_true(b[0].flux > 0 && b[0].flux < 1.5 * rmax * rmax);
        assert_true(c[0].flux > 0 && c[0].flux < b[0].flux / 4);
    }
    /* The coated ghosts' colour: the layer is tuned to 550 nm, so blue
     * and red ghosts are brighter than green. */
    const double nms[3] = {450, 550, 650};
    double all[3];
    for (int k = 0; k < 3; k++) {
        assert_int_equal(
            lr__ghost_fluxes(&rx, &mgf2, 0, nms[k], N, half_diag, c, &mc),
            paths);
        all[k] = 0;
        for (int p = 0; p < paths; p++)
            all[k] += c[p].flux;
        if (k != 1)
            show("MgF2", 0, nms[k], c, paths);
    }
    assert_true(all[0] > all[1] && all[2] > all[1]);
}

/* lr__ghost_trace16 against lr__ghost_trace_rel lane by lane, bit for
 * bit: every ghost path (and the main one) of lenses with spherical
 * surfaces, conics and an asphere (the scalar fallback), rays from a
 * disc before the front at up to 30 degrees (many lost: the cases where
 * lanes die at different crossings), some lanes left out, with and
 * without rel, a stop scaled down and a frame's clip, three batches of
 * each. */
static void test_trace16_bits(void **state)
{
    (void)state;
    const char *lenses[] = {"double-gauss-50", "wide-22", "fisheye-10",
                            "tests/data/lenses/asphere-singlet.zmx"};
    uint64_t seed = 12345, lanes = 0, landed = 0, relv = 0;
    for (size_t li = 0; li < sizeof lenses / sizeof *lenses; li++) {
        const lr_lens *L;
        if (lr_lens_load(lenses[li], NULL, &L, NULL) != LR_OK)
            fail_msg("lens %s not found", lenses[li]);
        const lr__rx *rx = &L->rx;
        double z[LR__RX_MAX_SURFACES + 1], n[LR__RX_MAX_SURFACES];
        lr__rx_layout(rx, z);
        lr__rx_indices(rx, 550.0, n);
        lr__ttab tab;
        lr__ttab_fill(&tab, rx, n, 550.0, NULL);
        static lr__ghost g[LR__GHOST_MAX + 1];
        int ng = lr__ghost_paths(rx, g);
        g[ng++] = (lr__ghost){-1, -1};
        double r0 = rx->s[0].semi_aperture, clip[2] = {12.0, 8.0};
        for (int k = 0; k < ng; k++)
            for (int mode = 0; mode < 9; mode++) {
                double o[3][LR__GHOST_LANES], d[3][LR__GHOST_LANES];
                double hit[2][LR__GHOST_LANES], w[LR__GHOST_LANES];
                double rel[LR__GHOST_LANES];
                int alive[LR__GHOST_LANES];
                double scale = mode % 3 == 2 ? 0.6 : 1.0;
                for (int l = 0; l < LR__GHOST_LANES; l++) {
                    double u[4];
                    for (int a = 0; a < 4; a++) {
                        seed = seed * 6364136223846793005ull +
                               1442695040888963407ull;
                        u[a] = (double)(seed >> 11) * 0x1.0p-53;
                    }
                    double dl[3], rr = 1.1 * r0 * sqrt(u[0]);
                    direction(u[2] * 30.0 * M_PI / 180.0, 2.0 * M_PI * u[3],
                              dl);
                    double back = (r0 + 1.0) / dl[2];
                    o[0][l] = rr * cos(2.0 * M_PI * u[1]) - back * dl[0];
                    o[1][l] = rr * sin(2.0 * M_PI * u[1]) - back * dl[1];
                    o[2][l] = z[0] - back * dl[2];
                    for (int a = 0; a < 3; a++)
                        d[a][l] = dl[a];
                    alive[l] = (l * 7 + k + mode) % 9 != 0;
                }
                double *rp = mode % 3 == 1 ? NULL : rel;
                const double *cp = mode % 3 == 1 ? clip : NULL;
                int was[LR__GHOST_LANES];
                memcpy(was, alive, sizeof was);
                lr__ghost_trace16(rx, z, n, &tab, 550.0, scale, NULL, g[k],
                                  z[rx->n], cp, (const double(*)[16])o,
                                  (const double(*)[16])d, hit, w, rp, alive);
                for (int l = 0; l < LR__GHOST_LANES; l++) {
                    if (!was[l]) {
                        assert_int_equal(alive[l], 0);
                        continue;
                    }
                    double ol[3] = {o[0][l], o[1][l], o[2][l]};
                    double dl[3] = {d[0][l], d[1][l], d[2][l]}, h[2], ws, rs;
                    int ok = lr__ghost_trace_rel(
                        rx, z, n, &tab, 550.0, scale, NULL, g[k], z[rx->n], cp,
                        ol, dl, h, &ws, rp != NULL ? &rs : NULL);
                    lanes++;
                    assert_int_equal(alive[l], ok);
                    if (!ok)
                        continue;
                    landed++;
                    assert_memory_equal(&hit[0][l], &h[0], sizeof h[0]);
                    assert_memory_equal(&hit[1][l], &h[1], sizeof h[1]);
                    assert_memory_equal(&w[l], &ws, sizeof ws);
                    if (rp != NULL) {
                        assert_memory_equal(&rel[l], &rs, sizeof rs);
                        relv += rs > 1.0;
                    }
                }
            }
    }
    print_message("trace16: %llu lanes, %llu landed, %llu past a rim\n",
                  (unsigned long long)lanes, (unsigned long long)landed,
                  (unsigned long long)relv);
    /* Enough of each kind to mean something. */
    assert_true(landed > 1000 && lanes - landed > 1000 && relv > 100);
}

static const struct CMUnitTest ghost_tests[] = {
    cmocka_unit_test(test_paths),           cmocka_unit_test(test_plate),
    cmocka_unit_test(test_two_plates),      cmocka_unit_test(test_stop_clips),
    cmocka_unit_test(test_tir_lost),        cmocka_unit_test(test_fluxes_plate),
    cmocka_unit_test(test_paraxial_ghosts), cmocka_unit_test(test_double_gauss),
    cmocka_unit_test(test_trace16_bits),    cmocka_unit_test(test_meet_ahead),
};

LR_TEST_GROUP(ghost, ghost_tests)
