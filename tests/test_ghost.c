/*
 * test_ghost.c: two-reflection ghost paths (lib/optics/ghost.c).  Flat
 * plates, where a ghost's place follows from geometry worked by hand
 * (each extra pass through a slab of thickness t at angle theta shifts a
 * ray sideways by t tan(theta)) and its weight from the reflectances at
 * the crossings; the stop clipping a ghost; and the shipped double
 * Gauss's brightest ghosts, a first number for issue 29's "auto".
 */
#include "test.h"
#include "coating.h"
#include "ghost.h"
#include "prescription.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* A flat surface followed by `t` mm of index n (1: air). */
static lr__surface flat(double t, double n, double semi)
{
    lr__surface s;
    memset(&s, 0, sizeof s);
    s.thickness = t;
    s.semi_aperture = semi;
    s.after.kind = n == 1.0 ? LR__GLASS_AIR : LR__GLASS_CONSTANT;
    s.after.nd = n;
    return s;
}

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
    rx.s[0] = flat(t, n, 50);
    rx.s[1] = flat(20, 1.0, 50);
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
    rx.s[0] = flat(tA, nA, 50);
    rx.s[1] = flat(g, 1.0, 50);
    rx.s[2] = flat(tB, nB, 50);
    rx.s[3] = flat(30, 1.0, 50);
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
    rx.s[1] = flat(g / 2, 1.0, 50);
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
    rx.s[0] = flat(2, 1.6, 50);
    rx.s[1] = flat(g1, 1.0, 50);
    rx.s[2] = flat(g2, 1.0, 1); /* the stop */
    rx.s[3] = flat(2, 1.7, 50);
    rx.s[4] = flat(30, 1.0, 50);
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
    rx.s[0] = flat(10, 1.6, 50);
    rx.s[1] = flat(20, 1.0, 50);
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

/* What dg_ghosts measures: the brightest ghost's flux over the main
 * image's, which path it is and its rms radius on the sensor (mm); the
 * sum over every ghost; the most concentrated ghost's mean irradiance
 * over a disc of its rms radius per unit of the main image's flux
 * (1/mm^2: times a pixel's area, its brightness against a point
 * source's image held in that pixel), and which it is. */
typedef struct ghost_stats {
    double best, rms, total, peak;
    lr__ghost which, peak_which;
} ghost_stats;

/* The flux of each ghost of `rx` relative to the main image, for a
 * distant point at `deg` off axis at `nm`, by rays on a grid over the
 * front element (each ray the same area of the beam), counted where
 * they land within a 36 x 24 mm sensor's half diagonal. */
static ghost_stats dg_ghosts(const lr__rx *rx, const lr__coating *coat,
                             double deg, double nm)
{
    static lr__ghost paths[LR__GHOST_MAX];
    int np = lr__ghost_paths(rx, paths);
    double z[LR__RX_MAX_SURFACES + 1];
    lr__rx_layout(rx, z);
    const int N = 61;
    const double a = rx->s[0].semi_aperture, half_diag = 21.63;
    double d[3];
    direction(deg * M_PI / 180, 0, d);
    double main = 0.0;
    ghost_stats st = {0, 0, 0, 0, {0, 0}, {0, 0}};
    for (int p = -1; p < np; p++) {
        lr__ghost g = p < 0 ? (lr__ghost){-1, -1} : paths[p];
        double sum = 0, sx = 0, sy = 0, sxx = 0;
        for (int u = 0; u < N; u++)
            for (int v = 0; v < N; v++) {
                double x = a * (2.0 * (u + 0.5) / N - 1);
                double y = a * (2.0 * (v + 0.5) / N - 1);
                if (x * x + y * y > a * a)
                    continue;
                double o[3] = {x - d[0] / d[2], y - d[1] / d[2], -1.0};
                double hit[2], w;
                if (!lr__ghost_trace(rx, z, nm, 1.0, coat, g, z[rx->n], o, d,
                                     hit, &w) ||
                    hypot(hit[0], hit[1]) > half_diag)
                    continue;
                sum += w;
                sx += w * hit[0];
                sy += w * hit[1];
                sxx += w * (hit[0] * hit[0] + hit[1] * hit[1]);
            }
        if (p < 0) {
            main = sum;
            continue;
        }
        if (sum == 0.0)
            continue;
        double ratio = sum / main, mx = sx / sum, my = sy / sum;
        double rms = sqrt(fmax(0.0, sxx / sum - mx * mx - my * my));
        st.total += ratio;
        if (ratio > st.best) {
            st.best = ratio;
            st.which = g;
            st.rms = rms;
        }
        /* A disc no smaller than a 10 um pixel. */
        double e = ratio / (M_PI * fmax(rms * rms, 1e-4));
        if (e > st.peak) {
            st.peak = e;
            st.peak_which = g;
        }
    }
    return st;
}

static void show(const char *what, double deg, double nm, ghost_stats s)
{
    print_message("  %-4s %2.0f deg %3.0f nm: brightest (%d,%d) %.3e of the "
                  "main flux, rms %.2f mm; all %.3e; most concentrated "
                  "(%d,%d) %.2e /mm^2\n",
                  what, deg, nm, s.which.j, s.which.i, s.best, s.rms, s.total,
                  s.peak_which.j, s.peak_which.i, s.peak);
}

static void test_double_gauss(void **state)
{
    (void)state;
    char path[4096];
    lr_error err;
    lr__rx rx;
    assert_int_equal(
        lr__rx_find("double-gauss-50", NULL, path, sizeof path, &err), LR_OK);
    assert_int_equal(lr__rx_load_file(path, "dg", NULL, &rx, &err), LR_OK);
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
    const double fields[2] = {0, 10};
    for (int f = 0; f < 2; f++) {
        ghost_stats b = dg_ghosts(&rx, &bare, fields[f], 550);
        ghost_stats c = dg_ghosts(&rx, &mgf2, fields[f], 550);
        show("bare", fields[f], 550, b);
        show("MgF2", fields[f], 550, c);
        /* Two reflections: at most about the largest R squared (the
         * angles inside the lens stay moderate, hence the margin); the
         * coating cuts each R by about 3 or more. */
        assert_true(b.best > 0 && b.best < 1.5 * rmax * rmax);
        assert_true(c.best > 0 && c.best < b.best / 4);
        assert_true(b.total >= b.best && c.total < b.total / 4);
    }
    /* The coated ghosts' colour: the layer is tuned to 550 nm, so blue
     * and red ghosts are brighter than green. */
    ghost_stats c450 = dg_ghosts(&rx, &mgf2, 0, 450);
    ghost_stats c650 = dg_ghosts(&rx, &mgf2, 0, 650);
    ghost_stats c550 = dg_ghosts(&rx, &mgf2, 0, 550);
    show("MgF2", 0, 450, c450);
    show("MgF2", 0, 650, c650);
    assert_true(c450.total > c550.total && c650.total > c550.total);
}

static const struct CMUnitTest ghost_tests[] = {
    cmocka_unit_test(test_paths),      cmocka_unit_test(test_plate),
    cmocka_unit_test(test_two_plates), cmocka_unit_test(test_stop_clips),
    cmocka_unit_test(test_tir_lost),   cmocka_unit_test(test_double_gauss),
};

LR_TEST_GROUP(ghost, ghost_tests)
