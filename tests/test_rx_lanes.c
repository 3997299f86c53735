/*
 * test_rx_lanes.c: the packet trace's lanes (lr__rx_trace16, and its
 * aspheric surfaces' lr__rx_asph16) against the scalar trace, one ray at
 * a time, bit for bit, as prescription.h promises: the exit-pupil
 * tables, the blur table and the chief rays are traced in packets and
 * stand for the scalar code's results.  Rays from the image plane to
 * points scattered over 0.3 or 1.3 times the rear element, so that some pass,
 * some are stopped by an aperture and some miss an asphere's reach.  And
 * the lens camera's rays_n (its glass by lr__rx_trace16_nl, rgb and spectral
 * mode's samples) against its ray one sample at a time.
 */
#include "test.h"
#include "camera/camera.h"
#include "camera/camera_lens.h"
#include "optics/prescription.h"
#include "scene/scene.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

static uint64_t rng = 88172645463325252ull;

static double uniform(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17; /* xorshift64 */
    return (double)(rng >> 11) / 9007199254740992.0;
}

static void load(const char *name, lr__rx *rx)
{
    char path[4096];
    lr_error err;
    assert_int_equal(lr__rx_find(name, NULL, path, sizeof path, &err), LR_OK);
    assert_int_equal(lr__rx_load_file(path, name, NULL, rx, &err), LR_OK);
}

/* Sixteen rays from the image plane z[n] at heights up to h toward the
 * rear surface's plane, within `spread` of its semi-aperture. */
static void packet(const lr__rx *rx, const double *z, double h, double spread,
                   double (*o)[16], double (*d)[16])
{
    int rear = rx->n - 1;
    double a = spread * rx->s[rear].semi_aperture;
    for (int l = 0; l < 16; l++) {
        double x = h * uniform(), y = 0.2 * h * (uniform() - 0.5);
        double tx = a * (2 * uniform() - 1), ty = a * (2 * uniform() - 1);
        double dx = tx - x, dy = ty - y, dz = z[rear] - z[rx->n];
        double len = sqrt(dx * dx + dy * dy + dz * dz);
        o[0][l] = x, o[1][l] = y, o[2][l] = z[rx->n];
        d[0][l] = dx / len, d[1][l] = dy / len, d[2][l] = dz / len;
    }
}

typedef struct counts {
    long pass, lost, asph_pass, asph_lost;
} counts;

/* Whole traces: lr__rx_trace16 against lr__rx_trace_n lane by lane. */
static void whole(const lr__rx *rx, const double *z, const double *n,
                  double scale, double h, double spread, counts *k)
{
    double o[3][16], d[3][16];
    int alive[16];
    packet(rx, z, h, spread, o, d);
    double o0[3][16], d0[3][16];
    memcpy(o0, o, sizeof o), memcpy(d0, d, sizeof d);
    for (int l = 0; l < 16; l++)
        alive[l] = 1;
    lr__rx_trace16(rx, z, n, scale, o, d, alive);
    for (int l = 0; l < 16; l++) {
        double so[3] = {o0[0][l], o0[1][l], o0[2][l]};
        double sd[3] = {d0[0][l], d0[1][l], d0[2][l]};
        int ok = lr__rx_trace_n(rx, z, n, scale, 0, so, sd);
        assert_int_equal(alive[l], ok);
        k->pass += ok, k->lost += !ok;
        if (!ok)
            continue;
        for (int a = 0; a < 3; a++) {
            assert_memory_equal(&o[a][l], &so[a], sizeof(double));
            assert_memory_equal(&d[a][l], &sd[a], sizeof(double));
        }
    }
}

/* Each aspheric surface's step alone: the rays that reach it (traced
 * one by one), through lr__rx_asph16 and lr__rx_trace_surface. */
static void steps(const lr__rx *rx, const double *z, const double *n,
                  double scale, double h, double spread, counts *k)
{
    for (int i = rx->n - 1; i >= 0; i--) {
        if (!lr__rx_aspheric(&rx->s[i]))
            continue;
        double o[3][16], d[3][16];
        int alive[16];
        packet(rx, z, h, spread, o, d);
        for (int l = 0; l < 16; l++) {
            double so[3] = {o[0][l], o[1][l], o[2][l]};
            double sd[3] = {d[0][l], d[1][l], d[2][l]};
            alive[l] = 1;
            for (int j = rx->n - 1; j > i && alive[l]; j--)
                alive[l] = lr__rx_trace_surface(rx, z, n, scale, j, 0, so, sd);
            for (int a = 0; a < 3; a++)
                o[a][l] = so[a], d[a][l] = sd[a];
        }
        int before[16];
        memcpy(before, alive, sizeof alive);
        double o0[3][16], d0[3][16];
        memcpy(o0, o, sizeof o), memcpy(d0, d, sizeof d);
        double n1[16], n2[16];
        for (int l = 0; l < 16; l++)
            n1[l] = n[i], n2[l] = i > 0 ? n[i - 1] : 1.0;
        lr__rx_asph16(rx, z, n1, n2, scale, i, o, d, alive, NULL);
        for (int l = 0; l < 16; l++) {
            if (!before[l]) {
                /* A lane already lost stays lost and untouched. */
                assert_int_equal(alive[l], 0);
                for (int a = 0; a < 3; a++) {
                    assert_memory_equal(&o[a][l], &o0[a][l], sizeof(double));
                    assert_memory_equal(&d[a][l], &d0[a][l], sizeof(double));
                }
                continue;
            }
            double so[3] = {o0[0][l], o0[1][l], o0[2][l]};
            double sd[3] = {d0[0][l], d0[1][l], d0[2][l]};
            int ok = lr__rx_trace_surface(rx, z, n, scale, i, 0, so, sd);
            assert_int_equal(alive[l], ok);
            k->asph_pass += ok, k->asph_lost += !ok;
            if (!ok)
                continue;
            for (int a = 0; a < 3; a++) {
                assert_memory_equal(&o[a][l], &so[a], sizeof(double));
                assert_memory_equal(&d[a][l], &sd[a], sizeof(double));
            }
        }
    }
}

static void test_lanes_equal_scalar(void **state)
{
    (void)state;
    const char *lenses[] = {"zoom-nikkor-z-14-30mm-f4-at-14mm",
                            "tests/data/lenses/asphere-singlet.zmx",
                            "double-gauss-50", "fisheye-10"};
    for (size_t q = 0; q < sizeof lenses / sizeof lenses[0]; q++) {
        lr__rx rx;
        load(lenses[q], &rx);
        double z[LR__RX_MAX_SURFACES + 1], n[LR__RX_MAX_SURFACES];
        lr__rx_layout(&rx, z);
        counts k = {0, 0, 0, 0};
        for (int w = 0; w < 3; w++) {
            lr__rx_indices(&rx, 450.0 + 100.0 * w, n);
            for (int s = 0; s < 3; s++) {
                double scale = 1.0 / (1 << s); /* open, 1 and 2 stops down */
                for (int p = 0; p < 40; p++) {
                    double h = 0.6 * rx.s[rx.n - 1].semi_aperture * (p % 4);
                    double spread = p % 3 ? 0.3 : 1.3;
                    whole(&rx, z, n, scale, h, spread, &k);
                    steps(&rx, z, n, scale, h, spread, &k);
                }
            }
        }
        print_message("%s: %ld passed, %ld lost; at its aspheres %ld "
                      "passed, %ld lost\n",
                      lenses[q], k.pass, k.lost, k.asph_pass, k.asph_lost);
        /* Both outcomes, so that the selects of both are compared. */
        assert_true(k.pass > 100 && k.lost > 100);
        if (q < 2)
            assert_true(k.asph_pass > 100 && k.asph_lost > 10);
    }
}

/* rays_n's rays and weights against `ray`'s, bit for bit, wide open (so
 * that the corners vignette) and in rgb mode: at the reference
 * wavelength and each channel's (the glass in lanes, the transmittance
 * from their tables) and at one no table holds (ray by ray). */
static void check_rays_n(const char *lens)
{
    char json[1024];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": 300, \"height\": 200},"
             " \"camera\": {\"model\": \"lens\", \"lens\": \"%s\","
             "  \"f_number\": 0, \"focus_distance\": 3,"
             "  \"chromatic\": {\"mode\": \"rgb\"},"
             "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1]},"
             " \"objects\": []}",
             lens);
    lr_scene *sc = lr_test_load_json(json);
    lr_camera cam;
    lr__cam c;
    lr_scene_camera(sc, &cam);
    lr__cam_init(&c, &cam, 300, 200);
    assert_non_null(c.model->rays_n);
    const double nms[] = {c.nm_ref, c.lens.nm_rgb[0], c.lens.nm_rgb[1],
                          c.lens.nm_rgb[2], 500.0};
    long stopped = 0, passed = 0;
    /* k < 5: every lane at nms[k]; k = 5: each lane at its own, mixing
     * tabled wavelengths and others (spectral mode's). */
    for (int k = 0; k < 6; k++)
        for (int p = 0; p < 40; p++) {
            int n = p % 3 ? 16 : 7;
            double fx[16], fy[16], u[16][2], wt[16], w[16], nm[16];
            lr__v3 org[16], dir[16];
            for (int i = 0; i < n; i++) {
                fx[i] = 300 * uniform(), fy[i] = 200 * uniform();
                u[i][0] = uniform(), u[i][1] = uniform();
                w[i] = c.w;
                nm[i] = k < 5   ? nms[k]
                        : i % 4 ? 380.0 + 400.0 * uniform()
                                : nms[i / 4];
            }
            c.model->rays_n(&c, n, fx, fy, (const double(*)[2])u, w, nm, org,
                            dir, wt);
            for (int i = 0; i < n; i++) {
                lr__v3 o1, d1;
                double w1 = c.model->ray(&c, fx[i], fy[i], u[i], c.w, nm[i],
                                         &o1, &d1);
                assert_memory_equal(&wt[i], &w1, sizeof w1);
                assert_memory_equal(&org[i], &o1, sizeof o1);
                assert_memory_equal(&dir[i], &d1, sizeof d1);
                stopped += w1 == 0.0, passed += w1 != 0.0;
            }
        }
    print_message("%s: rays_n as ray: %ld passed, %ld stopped\n", lens, passed,
                  stopped);
    assert_true(passed > 1000 && stopped > 100);
    lr_scene_free(sc);
}

static void test_camera_rays_n_as_ray(void **state)
{
    (void)state;
    check_rays_n("double-gauss-50");
    check_rays_n("zoom-nikkor-z-14-30mm-f4-at-14mm");
}

static const struct CMUnitTest rx_lanes_tests[] = {
    cmocka_unit_test(test_lanes_equal_scalar),
    cmocka_unit_test(test_camera_rays_n_as_ray),
};

LR_TEST_GROUP(rx_lanes, rx_lanes_tests)
