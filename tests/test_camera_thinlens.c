/*
 * test_camera_thinlens.c: the thin lens (lib/camera/camera_thinlens.c)
 * against optics: its circle of confusion, the f-number, and the blur's
 * aperture shapes, blur measured as second moments (point_scene.h).
 */
#include "test.h"
#include "point_scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Polar second moment of a regular n-gon of circumradius R about its
 * centre, from its fan of triangles (0, a, b):
 * J / A = (|a|^2 + |b|^2 + a.b) / 6 for each. */
static double polygon_m2(int n, double R)
{
    return R * R * (2.0 + cos(2.0 * M_PI / n)) / 6.0;
}

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

static const struct CMUnitTest camera_thinlens_tests[] = {
    cmocka_unit_test(test_thinlens_circle_of_confusion),
    cmocka_unit_test(test_f_number),
    cmocka_unit_test(test_aperture_shapes),
};

LR_TEST_GROUP(camera_thinlens, camera_thinlens_tests)
