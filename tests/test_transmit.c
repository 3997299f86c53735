/*
 * test_transmit.c: every surface's 1 - R on a real lens's main path
 * (lib/optics/transmit.c, issue 29): the camera's tables against the
 * coating formula, a plate's transmittance worked by hand, and the
 * exposure normalisation that keeps a uniform scene's centre at its
 * radiance whatever the coating.
 */
#include "test.h"
#include "camera/camera.h"
#include "optics/coating.h"
#include "optics/ghost.h"
#include "optics/lens_load.h"
#include "optics/transmit.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* One plate of index 1.5, 5 mm thick, bare: a ray at angle theta keeps
 * (1 - R(theta))^2 with R by Fresnel's sine and tangent forms (Hecht,
 * Optics, 4.6: r_s = -sin(i - t) / sin(i + t), r_p = tan(i - t) /
 * tan(i + t)), written here; the same either way through the plate; and
 * the table's value within 2e-4 of it. */
static void test_plate(void **state)
{
    (void)state;
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    rx.n = 2;
    rx.s[0] = lr_test_flat(5.0, 1.5, 1e4);
    rx.s[1] = lr_test_flat(10.0, 1.0, 1e4);
    rx.s[0].coating.kind = rx.s[1].coating.kind = LR__COAT_NONE;
    double z[LR__RX_MAX_SURFACES + 1], n[LR__RX_MAX_SURFACES];
    lr__rx_layout(&rx, z);
    lr__rx_indices(&rx, 550.0, n);
    lr__ttab tab;
    lr__ttab_fill(&tab, &rx, n, 550.0, NULL);
    double worst = 0.0;
    for (int k = 0; k <= 16; k++) {
        double th = k * (M_PI / 2.0 - 0.05) / 16.0;
        double R;
        if (k == 0) {
            R = (0.5 / 2.5) * (0.5 / 2.5);
        } else {
            double tt = asin(sin(th) / 1.5);
            double rs = -sin(th - tt) / sin(th + tt);
            double rp = tan(th - tt) / tan(th + tt);
            R = 0.5 * (rs * rs + rp * rp);
        }
        double want = (1.0 - R) * (1.0 - R);
        for (int way = 0; way < 2; way++) {
            double o[3] = {0.0, 0.0, way ? 20.0 : -1.0};
            double d[3] = {sin(th), 0.0, way ? -cos(th) : cos(th)};
            double o2[3] = {o[0], o[1], o[2]}, d2[3] = {d[0], d[1], d[2]};
            double T = -1.0, Tt = -1.0;
            assert_true(lr__rx_trace_t(&rx, z, n, 1.0, !way, NULL, 550.0, NULL,
                                       o, d, &T));
            assert_true(lr__rx_trace_t(&rx, z, n, 1.0, !way, &tab, 550.0, NULL,
                                       o2, d2, &Tt));
            assert_true(fabs(T - want) < 1e-12);
            worst = fmax(worst, fabs(Tt - want));
        }
    }
    print_message("plate: table against Fresnel, worst %.2e\n", worst);
    assert_true(worst < 2e-4);
}

/* Every surface of the shipped lenses, bare, MgF2 and as prescribed, at
 * three wavelengths: the table against 1 - R from the stack formula
 * (coating.c), both ways through the surface at matching angles (Snell),
 * over the angles that transmit. */
static void test_table_matches_formula(void **state)
{
    (void)state;
    const char *lenses[] = {"double-gauss-50", "tessar-laikin-102mm-f4.5",
                            "wide-22"};
    const double nms[] = {450.0, 550.0, 650.0};
    double worst = 0.0, worst_78 = 0.0, worst_r = 0.0;
    for (size_t li = 0; li < sizeof lenses / sizeof *lenses; li++) {
        const lr_lens *L;
        if (lr_lens_load(lenses[li], NULL, &L, NULL) != LR_OK)
            fail_msg("lens %s not found", lenses[li]);
        for (int coat = 0; coat < 3; coat++)
            for (int w = 0; w < 3; w++) {
                const lr__coating *ov = lr__coating_override(coat);
                double n[LR__RX_MAX_SURFACES];
                lr__rx_indices(&L->rx, nms[w], n);
                lr__ttab tab;
                lr__ttab_fill(&tab, &L->rx, n, nms[w], ov);
                for (int i = 0; i < L->rx.n; i++) {
                    double nb = i > 0 ? n[i - 1] : 1.0, na = n[i];
                    double nmin = fmin(nb, na);
                    for (int k = 0; k < 200; k++) {
                        /* The sine invariant, up to grazing on the
                         * lower-index side (where T falls to 0). */
                        double s = nmin * sin(k * (M_PI / 2.0) / 200.0);
                        double cb = sqrt(1.0 - (s / nb) * (s / nb));
                        double ca = sqrt(1.0 - (s / na) * (s / na));
                        double Tb = 1.0 - lr__rx_surface_r(&L->rx, n, i, 1, cb,
                                                           nms[w], ov);
                        double Ta = 1.0 - lr__rx_surface_r(&L->rx, n, i, 0, ca,
                                                           nms[w], ov);
                        /* Stokes: a lossless interface passes the same
                         * share both ways. */
                        assert_true(fabs(Tb - Ta) < 1e-9);
                        double e = fmax(
                            fabs(lr__ttab_at(&tab, i, nb, cb) - Tb),
                            fabs(lr__ttab_at(&tab, i, na, ca) - Ta));
                        worst = fmax(worst, e);
                        /* Within 78 degrees of the normal on the
                         * lower-index side (c >= 0.2). */
                        if (s <= nmin * sqrt(1.0 - 0.04))
                            worst_78 = fmax(worst_78, e);
                        /* A ghost's R (lr__ttab_r), against R itself,
                         * where there is some (R > 1e-4) and up to 85
                         * degrees. */
                        if (1.0 - Tb > 1e-4 &&
                            s <= nmin * sin(85.0 * M_PI / 180.0))
                            worst_r = fmax(
                                worst_r, fmax(fabs(lr__ttab_r(&tab, i, nb, cb) /
                                                       (1.0 - Tb) -
                                                   1.0),
                                              fabs(lr__ttab_r(&tab, i, na, ca) /
                                                       (1.0 - Ta) -
                                                   1.0)));
                    }
                }
            }
    }
    print_message("tables against the formula: worst %.2e, within 78 "
                  "degrees %.2e\n",
                  worst, worst_78);
    print_message("ghosts' R from the tables: worst %.2e of R\n", worst_r);
    assert_true(worst < 1e-3);
    assert_true(worst_78 < 3e-4);
    assert_true(worst_r < 1e-3);
}

/* The mean weight of the camera's samples at film point (fx, fy). */
static double mean_weight(const lr__cam *c, double fx, double fy)
{
    const int M = 128;
    double sum = 0.0;
    uint64_t rng = 0x9E3779B97F4A7C15ull;
    for (int i = 0; i < M; i++)
        for (int j = 0; j < M; j++) {
            /* Jittered (cell centres count the pupil's edge with an error
             * of their own, test_lens_camera.c). */
            double r[2];
            for (int a = 0; a < 2; a++) {
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                r[a] = (rng >> 11) * 0x1p-53;
            }
            double u[2] = {(i + r[0]) / M, (j + r[1]) / M};
            lr__v3 org, dir;
            sum += lr__cam_lens_ray(c, fx, fy, u, c->w, c->nm_ref, &org, &dir);
        }
    return sum / (M * M);
}

/* The exposure normalisation: the centre of a uniform scene renders at
 * its radiance, bare, coated or as prescribed (within the 1% the lens
 * camera's sampling reaches at 128 x 128 samples); off axis the
 * coatings weigh the rays differently (test_lens_camera.c's
 * test_pupil_bounds_lose_no_light checks the falloff against an
 * integral with 1 - R computed ray by ray). */
/* At u = 0, grazing on the lower-index side (the critical angle on the
 * other), every stack reflects all: T = 0, where a coating's formula is
 * 0 / 0 for p light.  The table once held NaN there, and an aspheric
 * condenser's grazing camera rays weighed NaN (samples dropped).  Every
 * entry finite, T(0) = 0, and a ray at grazing gets next to nothing, on
 * three lenses under every coating. */
static void test_table_finite_at_grazing(void **state)
{
    (void)state;
    const char *lenses[] = {"double-gauss-50", "fisheye-10", "wide-22"};
    for (size_t li = 0; li < sizeof lenses / sizeof *lenses; li++) {
        const lr_lens *L;
        if (lr_lens_load(lenses[li], NULL, &L, NULL) != LR_OK)
            fail_msg("lens %s not found", lenses[li]);
        for (int coat = 0; coat < 3; coat++) {
            double n[LR__RX_MAX_SURFACES];
            lr__rx_indices(&L->rx, 550.0, n);
            lr__ttab tab;
            lr__ttab_fill(&tab, &L->rx, n, 550.0, lr__coating_override(coat));
            for (int i = 0; i < L->rx.n; i++) {
                if (tab.inv_nmin2[i] == 0.0f)
                    continue;
                for (int j = 0; j <= LR__T_N; j++)
                    assert_true(isfinite(tab.t[i][j]));
                assert_true(tab.t[i][0] == 0.0f);
                double nmin = fmin(i > 0 ? n[i - 1] : 1.0, n[i]);
                /* (float rounding leaves u a little above 0) */
                double T = lr__ttab_at(&tab, i, nmin, 0.0);
                assert_true(isfinite(T) && T < 0.2);
            }
        }
    }
}

static void test_centre_keeps_radiance(void **state)
{
    (void)state;
    double centre[3], edge[3];
    for (int coat = 0; coat < 3; coat++) {
        const lr_lens *L;
        assert_int_equal(lr_lens_load("double-gauss-50", NULL, &L, NULL),
                         LR_OK);
        lr_camera cam;
        lr_camera_default(&cam);
        cam.model = LR_CAMERA_LENS;
        cam.lens = L;
        cam.coating = (lr_lens_coating)coat;
        lr__cam c;
        lr__cam_init(&c, &cam, 300, 200);
        centre[coat] = mean_weight(&c, 150.0, 100.0);
        edge[coat] = mean_weight(&c, 280.0, 180.0);
        print_message("coating %d: centre %.5f, near the corner %.5f\n", coat,
                      centre[coat], edge[coat]);
        assert_true(fabs(centre[coat] - 1.0) < 0.01);
    }
    /* The camera key reaches the rays: a quarter-wave layer's
     * reflectance rises faster with the angle than bare glass's (its
     * optical thickness shrinks as cos(theta) inside the film, moving
     * its minimum to shorter wavelengths), so the bare lens's corner
     * comes out brighter relative to its centre. */
    assert_true(edge[LR_COATING_NONE] / centre[LR_COATING_NONE] >
                edge[LR_COATING_MGF2] / centre[LR_COATING_MGF2] * 1.0005);
}

/* The packet trace's transmittance lookups (rx_trace16f.c) in every
 * version this CPU runs give the same rays and weights, bit for bit:
 * through the double Gauss (its crossings near the normal, where the
 * AVX2 version reads the row's last entries by permutes) and the
 * fisheye (steep crossings, where it gathers; AVX-512 permutes the
 * whole row), wide open, over the whole frame. */
static void test_packet_lookups_agree(void **state)
{
    (void)state;
    const char *lenses[] = {"double-gauss-50", "fisheye-10"};
    int versions = __builtin_cpu_supports("avx512f") ? 3
                   : __builtin_cpu_supports("avx2")  ? 2
                                                     : 1;
    enum { NP = 4, ROUNDS = 64 };
    for (int li = 0; li < 2; li++) {
        const lr_lens *L;
        assert_int_equal(lr_lens_load(lenses[li], NULL, &L, NULL), LR_OK);
        lr_camera cam;
        lr_camera_default(&cam);
        cam.model = LR_CAMERA_LENS;
        cam.lens = L;
        lr__cam c;
        lr__cam_init(&c, &cam, 300, 200);
        uint64_t rng = 7;
        int stopped = 0;
        for (int round = 0; round < ROUNDS; round++) {
            float fx[NP][16], fy[NP][16], lu[NP][16], lv[NP][16];
            int ns[NP] = {16, 16, 16, 16};
            for (int p = 0; p < NP; p++)
                for (int l = 0; l < 16; l++) {
                    float r[4];
                    for (int k = 0; k < 4; k++) {
                        rng = rng * 6364136223846793005ull +
                              1442695040888963407ull;
                        r[k] = (float)((rng >> 40) * 0x1p-24);
                    }
                    fx[p][l] = 300 * r[0], fy[p][l] = 200 * r[1];
                    lu[p][l] = r[2], lv[p][l] = r[3];
                }
            struct RTCRayHit16 rh[3][NP];
            float wt[3][NP][16];
            memset(rh, 0, sizeof rh);
            for (int v = 0; v < 3; v++) {
                lr__rx_trace_isa = v < versions ? v + 1 : 1;
                c.model->rays16_n(&c, 1, NP, ns, (const float(*)[16])fx,
                                  (const float(*)[16])fy,
                                  (const float(*)[16])lu,
                                  (const float(*)[16])lv, rh[v], wt[v]);
            }
            lr__rx_trace_isa = 0;
            for (int p = 0; p < NP; p++)
                for (int l = 0; l < 16; l++)
                    stopped += wt[0][p][l] == 0.0f;
            for (int v = 1; v < 3; v++) {
                assert_memory_equal(wt[0], wt[v], sizeof wt[0]);
                assert_memory_equal(rh[0], rh[v], sizeof rh[0]);
            }
        }
        /* Both kinds of lane were compared. */
        assert_true(stopped > 0 && stopped < ROUNDS * NP * 16);
    }
    if (versions < 3)
        print_message("%s not on this CPU: %s\n",
                      versions == 1 ? "AVX2" : "AVX-512",
                      versions == 1 ? "the portable lookups only"
                                    : "C and AVX2 compared");
}

static const struct CMUnitTest transmit_tests[] = {
    cmocka_unit_test(test_plate),
    cmocka_unit_test(test_table_matches_formula),
    cmocka_unit_test(test_table_finite_at_grazing),
    cmocka_unit_test(test_centre_keeps_radiance),
    cmocka_unit_test(test_packet_lookups_agree),
};

LR_TEST_GROUP(transmit, transmit_tests)
