/*
 * test_camera_lens.c: the "lens" camera model against optics computed
 * here: a thin singlet against the thin lens's circle of confusion, the
 * focus against the lens equation, a point's image against its real
 * chief ray, the red-blue split against the lateral colour, a white
 * scene against the radiometric normalisation, and its errors.
 */
#include "test.h"
#include "render/autofocus.h"
#include "camera/camera.h"
#include "camera/camera_lens.h"
#include "optics/ghost.h"
#include "optics/lens_load.h"
#include "scene/scene.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* A biconvex singlet of index 1.5, radii +-R and 0.01 mm thick (its edge
 * at the 0.7 mm semi-aperture is 0.005 mm thick): f = R by the
 * lensmaker's equation, the stop (radius a) right behind it, the last
 * thickness f (infinity focus).  Its spherical aberration is the only
 * difference from a thin lens that is left: relative to the circles
 * measured below it grows as a (4% at a = 4.5 mm, 1.3% at 1.5 mm), so
 * the stop is small. */
#define SINGLET_R 100.0
#define SINGLET_T 0.01
#define SINGLET_A 0.5
static const char singlet[] =
    "{\"name\": \"thin singlet\", \"surfaces\": ["
    " {\"radius\": 100, \"thickness\": 0.01, \"material\": {\"nd\": 1.5},"
    "  \"semi_aperture\": 0.7},"
    " {\"radius\": -100, \"thickness\": 0.000001, \"material\": \"air\","
    "  \"semi_aperture\": 0.7},"
    " {\"stop\": true, \"thickness\": 100, \"semi_aperture\": 0.5}]}";

/* The singlet's focal length: the thick lens's lensmaker's equation,
 * 1/f = (n - 1) (2/R + (n - 1) t / (n R^2)) for radii +R and -R. */
static double singlet_f(void)
{
    double n = 1.5, R = SINGLET_R, t = SINGLET_T;
    return 1.0 / ((n - 1.0) * (2.0 / R - (n - 1.0) * t / (n * R * R)));
}

/* A scene of one object with the lens camera at the origin looking down
 * -z; `objects` is the JSON of the objects array. */
static lr_scene *lens_scene(const char *lens, const char *camera_extra,
                            const char *objects, int w, int h, int spp)
{
    size_t n = strlen(lens) + strlen(camera_extra) + strlen(objects) + 1024;
    char *json = malloc(n);
    assert_non_null(json);
    snprintf(json, n,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": %d,"
             "  \"max_depth\": 0, \"adaptive\": false},"
             " \"camera\": {\"model\": \"lens\", \"lens\": %s,"
             "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1] %s},"
             " \"materials\": {\"w\": {\"diffuse\": 1}},"
             " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
             " \"objects\": %s}",
             w, h, spp, lens, camera_extra, objects);
    lr_scene *s = lr_test_load_json(json);
    free(json);
    return s;
}

/* The camera of a lens_scene (one sample per pixel) in *cam, prepared in
 * *c for its w x h film.  The caller frees the scene. */
static lr_scene *lens_cam(const char *lens, const char *camera_extra,
                          const char *objects, int w, int h, lr_camera *cam,
                          lr__cam *c)
{
    lr_scene *s = lens_scene(lens, camera_extra, objects, w, h, 1);
    lr_scene_camera(s, cam);
    lr__cam_init(c, cam, w, h);
    return s;
}

/* The singlet focused 2 m away with a sphere far behind: the set-up of
 * the footprint and lost-ray tests. */
#define SINGLET_AT_2M                                                       \
    singlet, ", \"focus_distance\": 2",                                     \
        "[{\"type\": \"sphere\", \"center\": [0, 0, -50], \"radius\": 1}]", \
        64, 64

/* Thin singlet: the footprint of the rays from the centre of the film on
 * a plane at distance Z from the sensor is a disk of radius
 * a |1 - s_Z / s_f| (s_f, s_Z: the focused and the measured plane's
 * distances from the lens), the thin lens's circle of confusion.  Its
 * radius is measured as sqrt(2) x the rms distance of the hits from their
 * mean (a uniform disk's second moment is r^2 / 2). */
static void test_thin_singlet_matches_thin_lens(void **state)
{
    (void)state;
    const double D = 2.0, f = singlet_f(); /* focus: 2 m from the sensor */
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam(SINGLET_AT_2M, &cam, &c);
    /* The lens equation with v + s_f = D (in mm). */
    double Dm = D * 1000.0;
    double v = 0.5 * (Dm - sqrt(Dm * Dm - 4.0 * Dm * f));
    double s_f = Dm - v;
    double worst = 0.0;
    for (int k = 0; k < 3; k++) {
        double Zm = (k == 0 ? 1.0 : k == 1 ? 4.0 : 10.0) * 1000.0;
        double s_Z = Zm - v;
        double want = SINGLET_A * fabs(1.0 - s_Z / s_f);
        double sx = 0, sy = 0, sxx = 0;
        int n = 0;
        for (int i = 0; i < 200; i++)
            for (int j = 0; j < 200; j++) {
                double u[2] = {(i + 0.5) / 200, (j + 0.5) / 200};
                lr__v3 o, d;
                double wt = lr__cam_lens_ray(&c, 32.0, 32.0, u, c.w, c.nm_ref,
                                             &o, &d);
                if (wt == 0.0)
                    continue;
                double t = (-Zm / 1000.0 - o.z) / d.z;
                double x = (o.x + t * d.x) * 1000, y = (o.y + t * d.y) * 1000;
                sx += x, sy += y, sxx += x * x + y * y;
                n++;
            }
        assert_true(n > 1000);
        double mx = sx / n, my = sy / n;
        double got = sqrt(2.0 * (sxx / n - mx * mx - my * my));
        print_message("singlet: footprint at %g m: %.5f mm, thin lens %.5f "
                      "mm (%.3f%%)\n",
                      Zm / 1000, got, want, 100 * (got / want - 1));
        worst = fmax(worst, fabs(got / want - 1.0));
    }
    assert_true(worst < 0.01);
    lr_scene_free(s);
}

/* The share of camera rays the lens stops, on axis at full aperture:
 * the exit-pupil bounds must waste few. */
static void test_few_rays_lost_on_axis(void **state)
{
    (void)state;
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam(SINGLET_AT_2M, &cam, &c);
    int lost = 0, n = 0;
    for (int i = 0; i < 100; i++)
        for (int j = 0; j < 100; j++, n++) {
            double u[2] = {(i + 0.5) / 100, (j + 0.5) / 100};
            lr__v3 o, d;
            lost += lr__cam_lens_ray(&c, 32, 32, u, c.w, c.nm_ref, &o, &d) ==
                    0.0;
        }
    print_message("singlet: %.1f%% of rays lost on axis\n", 100.0 * lost / n);
    assert_true(lost < 0.10 * n);
    lr_scene_free(s);
}

/* Autofocus: the sphere's front at 3 m from the sensor becomes the
 * focus distance. */
static void test_autofocus_on_a_pixel(void **state)
{
    (void)state;
    lr_scene *s = lens_scene(singlet,
                             ", \"focus_distance\": 10, \"focus_on\": [32, 32]",
                             "[{\"type\": \"sphere\", \"center\": [0, 0, -4],"
                             "  \"radius\": 1, \"material\": \"w\"}]",
                             64, 64, 1);
    lr_camera cam;
    lr_scene_camera(s, &cam);
    lr_error err;
    assert_int_equal(lr__autofocus(s, &cam, 64, 64, &err), LR_OK);
    print_message("autofocus: %.6f m (the sphere's front: 3 m)\n",
                  cam.focus_distance);
    assert_true(fabs(cam.focus_distance - 3.0) < 1e-3);
    lr_scene_free(s);
}

/* A white sphere around a lens camera, rendered n x n (n odd) at spp:
 * the centre pixel's value and the corner's. */
static void white_surround(const char *lens, const char *camera_extra, int n,
                           int spp, double *centre, double *corner)
{
    lr_scene *s = lens_scene(lens, camera_extra,
                             "[{\"type\": \"sphere\", \"center\": [0, 0, 0],"
                             "  \"radius\": 100, \"material\": \"w\"}]",
                             n, n, spp);
    lr_camera cam;
    lr_scene_camera(s, &cam);
    lr_render_settings rs;
    lr_scene_settings(s, &rs);
    lr_image *img = lr_test_render_with(s, &cam, &rs, "white surround");
    const float *p = lr_image_rgb(img);
    *centre = p[3 * (n / 2 * n + n / 2)];
    *corner = p[0];
    print_message("white surround: centre %.4f, corner %.4f\n", *centre,
                  *corner);
    lr_image_free(img);
    lr_scene_free(s);
}

/* A uniform white surround renders 1 at the centre of the film (the
 * normalisation), and darker, never brighter, at the corners. */
static void test_white_surround(void **state)
{
    (void)state;
    double centre, corner;
    white_surround(singlet, ", \"focus_distance\": 5", 33, 256, &centre,
                   &corner);
    assert_true(fabs(centre - 1.0) < 0.02);
    assert_true(corner < centre);
}

/* The same through a lens whose stop is its rear surface and ten times
 * larger than its glass, closed to f/128 (0.19 mm): the exit-pupil
 * search looked for it over the unscaled stop, missed it, and the picture
 * was black. */
static void test_white_surround_big_rear_stop(void **state)
{
    (void)state;
    double centre, corner;
    white_surround("{\"surfaces\": ["
                   " {\"radius\": 50, \"thickness\": 4, \"material\": "
                   "\"N-BK7\", \"semi_aperture\": 10},"
                   " {\"radius\": -50, \"thickness\": 1, \"material\": "
                   "\"air\", \"semi_aperture\": 10},"
                   " {\"stop\": true, \"thickness\": 45, "
                   "\"semi_aperture\": 100}]}",
                   ", \"focus_distance\": 5, \"f_number\": 128", 9, 64, &centre,
                   &corner);
    assert_true(fabs(centre - 1.0) < 0.02);
}

/* A white surround through the 22 mm wide angle (image circle some 26 mm
 * across the radius) on a 72 mm sensor and on a 3000 mm one: the light on
 * the film, the sum of the pixels times a pixel's area, is the same, since
 * the same rays reach the same film points.  The pupil table's 48 radii
 * spread over the 3000 mm sensor's half diagonal left the circle one
 * interval, and 1 - 1e-3 of the light was lost (at 1000 mm, 18%). */
static void test_sensor_dwarfs_circle(void **state)
{
    (void)state;
    const char *scene =
        "{\"camera\": {\"model\": \"lens\", \"lens\": \"wide-22\"}, "
        "\"background\": 1, \"render\": {\"width\": 32, \"height\": 32, "
        "\"spp\": 4096, \"plan\": false, \"adaptive\": false}}";
    double flux[2];
    const double sw[2] = {72.0, 3000.0};
    for (int k = 0; k < 2; k++) {
        char set[64];
        snprintf(set, sizeof set, "camera.sensor_width_mm=%g", sw[k]);
        const char *sets[] = {set};
        lr_image *img = lr_test_render(scene, sets, 1, NULL);
        double px = sw[k] / 32.0, sum = 0.0;
        for (size_t i = 1; i < lr_test_n_values(img); i += 3)
            sum += img->rgb[i];
        flux[k] = sum * px * px;
        lr_image_free(img);
    }
    print_message("film light: %.4g mm^2 on 72 mm, %.4g on 3000 mm\n", flux[0],
                  flux[1]);
    assert_true(flux[0] > 0.0 && fabs(flux[1] / flux[0] - 1.0) < 0.02);
}

/* Every shipped lens (lenses/, as lr__rx_shipped lists it) closed to
 * f/128, the most a real lens takes: a white surround renders 1 at the
 * centre.  Through US 8,879,901's objective, whose rear surface is 3.2
 * mm from the sensor, the rays' spot on the rear plane was under the
 * exit-pupil search's finest cell from f/38 on, and the picture black
 * (lens_pupil.c's pupil_seed).  Under the sanitizers one lens of each
 * kind, and the objective. */
static void test_every_lens_closed_down(void **state)
{
    (void)state;
    char names[64][64], lens[96];
    int n = lr__rx_shipped(names, 64), swept = 0;
    assert_true(n >= 20);
    for (int i = 0; i < n; i++) {
        const char *l = names[i];
        if (LR_TEST_SANITIZED && strcmp(l, "double-gauss-50") != 0 &&
            strcmp(l, "fisheye-10") != 0 && strcmp(l, "wide-22") != 0 &&
            strstr(l, "z-14-30") == NULL && strstr(l, "objective") == NULL)
            continue;
        snprintf(lens, sizeof lens, "\"%s\"", l);
        double centre, corner;
        print_message("%s at f/128: ", l);
        white_surround(lens, ", \"focus_distance\": 10, \"f_number\": 128", 9,
                       64, &centre, &corner);
        if (!(fabs(centre - 1.0) < 0.02))
            fail_msg("%s at f/128: the centre renders %g, not 1", l, centre);
        swept++;
    }
    assert_true(swept >= 5);
}

static void expect_error(const char *camera_extra, const char *path,
                         const char *words)
{
    char json[2048];
    snprintf(json, sizeof json,
             "{\"camera\": {\"model\": \"lens\" %s},"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -5],"
             " \"radius\": 1}]}",
             camera_extra);
    lr_scene *s = NULL;
    lr_error err;
    lr_status st = lr_scene_load_json(json, strlen(json), NULL, NULL, 0, &s,
                                      &err);
    print_message("error: %s\n", err.message);
    assert_int_equal(st, LR_ERR_INVALID);
    assert_string_equal(err.path, path);
    assert_non_null(strstr(err.message, words));
}

static void test_errors_name_the_field(void **state)
{
    (void)state;
    expect_error("", "camera.lens", "must name a lens");
    char buf[1024];
    snprintf(buf, sizeof buf, ", \"lens\": %s, \"focus_distance\": 0.3",
             singlet);
    expect_error(buf, "camera.focus_distance", "nearer than this lens");
    snprintf(buf, sizeof buf, ", \"lens\": %s, \"sensor_width_mm\": -1",
             singlet);
    expect_error(buf, "camera.sensor_width_mm", "must be > 0");
    expect_error(", \"lens\": 7", "camera.lens", "must be a lens");
    snprintf(buf, sizeof buf, ", \"lens\": %s, \"f_number\": 1000", singlet);
    expect_error(buf, "camera.f_number", "at most 128");
    /* Dispersion amplified until a glass is thinner than air at the edge
     * of the visible range: a white scene rendered up to 4e13 (an
     * independent check), now an error with the bound. */
    expect_error(", \"lens\": \"double-gauss-50\", \"focus_distance\": 5,"
                 " \"chromatic\": {\"mode\": \"spectral\", \"amplify\": 300}",
                 "camera.chromatic.amplify", "less dense than air");
}

/* The camera writes its lens back: an inline prescription as the same
 * object, and reading the JSON back gives the same (interned) lens. */
static void test_lens_written_back(void **state)
{
    (void)state;
    lr_scene *s = lens_scene(singlet, "", "[]", 8, 8, 1);
    lr_camera cam;
    lr_scene_camera(s, &cam);
    char *json = lr_camera_json(&cam);
    assert_non_null(json);
    assert_non_null(strstr(json, "\"model\":\"lens\""));
    assert_non_null(strstr(json, "thin singlet"));
    lr_camera again;
    lr_camera_default(&again);
    lr_error err;
    assert_int_equal(lr_camera_apply_json(&again, json, strlen(json), &err),
                     LR_OK);
    assert_ptr_equal(again.lens, cam.lens);
    lr_free(json);
    lr_scene_free(s);
}

/* A lens file's own errors start with the field that named it, as a mesh
 * file's do: they began with the file ("bad-lens.json: surfaces must
 * be..."), so the daemon's inline scenes showed "scene: bad-lens.json". */
static void test_lens_file_errors_start_with_the_field(void **state)
{
    (void)state;
    char path[512];
    static const char bad[] = "{\"name\": \"x\", \"surfaces\": []}";
    lr_test_write_file("bad-lens.json", bad, strlen(bad), path, sizeof path);
    static const char *const scenes[] = {
        "{\"camera\": {\"model\": \"lens\", \"lens\": \"bad-lens.json\"}}",
        "{\"camera\": {\"model\": \"lens\", \"lens\": \"no-lens.json\"}}"};
    for (int i = 0; i < 2; i++)
        lr_test_expect_invalid(scenes[i], strlen(scenes[i]), "camera.lens",
                               scenes[i]);
    lr_scene *sc = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json(scenes[0], strlen(scenes[0]),
                                        lr_test_tmpdir(), NULL, 0, &sc, &err),
                     LR_ERR_INVALID);
    remove(path);
    assert_string_equal(err.message, "camera.lens: bad-lens.json: surfaces "
                                     "must be a non-empty array of surfaces");
}

/* An override (a daemon job's camera, lr_camera_apply_json) has no scene
 * directory, so a plain name is a shipped lens only: a lens file in the
 * working directory, the server's, is neither opened nor told apart from
 * a missing one.  It was loaded (docs/scene-format.md: "in a daemon job or
 * an API override only shipped names, assets and inline objects"). */
static void test_override_opens_no_working_directory_file(void **state)
{
    (void)state;
    char old[4096];
    assert_non_null(getcwd(old, sizeof old));
    assert_int_equal(chdir(lr_test_tmpdir()), 0);
    FILE *f = fopen("cwd-lens.dat", "w");
    assert_non_null(f);
    fputs("0 1 0 10\n50 4 1.5168 20\n-50 47 1 20\n", f);
    fclose(f);
    lr_camera cam;
    lr_camera_default(&cam);
    lr_error err;
    const char *json = "{\"model\": \"lens\", \"lens\": \"cwd-lens.dat\"}";
    lr_status st = lr_camera_apply_json(&cam, json, strlen(json), &err);
    /* The file itself loads by its path (as lensray lens FILE does). */
    const lr_lens *L = NULL;
    lr_status by_path = lr_lens_load("cwd-lens.dat", NULL, &L, NULL);
    remove("cwd-lens.dat");
    assert_int_equal(chdir(old), 0);
    assert_int_equal(by_path, LR_OK);
    assert_int_equal(st, LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.lens");
    assert_non_null(strstr(err.message, "no shipped lens of that name"));
    assert_null(strstr(err.message, "no such file"));
    /* A failed load leaves *out NULL, as every constructor does (it was
     * left as it was). */
    L = (const lr_lens *)&cam;
    assert_int_not_equal(lr_lens_load("no-such-lens", NULL, &L, NULL), LR_OK);
    assert_null(L);
}

/* The exit-pupil bounds lose no light: at film points from the centre
 * to the corner, the mean weight of the camera's samples (its estimate of
 * the irradiance there, relative to the centre's) equals a brute-force
 * integral of T cos^4 / Z^2 over every rear-plane point whose ray gets
 * through: on a grid over three times the rear element, then a finer one
 * over where rays passed (plus two coarse cells).  A bound that clipped
 * the pupil would come out low by the share it clipped.  T is the
 * product of 1 - R over the crossings, R from the surfaces' coatings
 * computed here ray by ray (exact_t), not from the camera's tables. */
static int exact_t(const lr__cam *c, double o[3], double d[3], double *T)
{
    const lr__lens_cam *lc = &c->lens;
    const lr__rx *rx = &lc->L->rx;
    double t = 1.0;
    for (int i = rx->n - 1; i >= 0; i--) {
        double p[3], m[3];
        if (!lr__rx_meet(rx, lc->L->z, lc->stop_scale, i, o, d, p, m))
            return 0;
        double n1 = lc->n_ref[i], n2 = i > 0 ? lc->n_ref[i - 1] : 1.0;
        double ci = fabs(d[0] * m[0] + d[1] * m[1] + d[2] * m[2]);
        memcpy(o, p, sizeof p);
        if (!lr__rx_refract(d, m, n1, n2))
            return 0;
        t *= 1.0 -
             lr__rx_surface_r(rx, lc->n_ref, i, 0, ci, c->nm_ref, lc->coat);
    }
    *T = t;
    return 1;
}

static double brute_irradiance(const lr__cam *c, double xs, double ys)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double Z = lc->z_sensor - lc->z_rear;
    double S = 1.5 * L->rx.s[L->rx.n - 1].semi_aperture;
    double x0 = -S, y0 = -S, w = 2 * S, h = 2 * S, E = 0;
    int G0 = 80;
    for (int pass = 0; pass < 2; pass++) {
        int G = pass == 0 ? G0 : 300;
        double cw = w / G, ch = h / G;
        double bx0 = INFINITY, bx1 = -INFINITY, by0 = INFINITY, by1 = -INFINITY;
        E = 0;
        for (int iy = 0; iy < G; iy++)
            for (int ix = 0; ix < G; ix++) {
                double qx = x0 + (ix + 0.5) * cw, qy = y0 + (iy + 0.5) * ch;
                double d[3] = {qx - xs, qy - ys, -Z};
                double len = sqrt(d[0] * d[0] + d[1] * d[1] + Z * Z);
                for (int a = 0; a < 3; a++)
                    d[a] /= len;
                double o[3] = {xs, ys, lc->z_sensor}, ct = -d[2], T;
                if (!exact_t(c, o, d, &T))
                    continue;
                E += T * ct * ct * ct * ct / (Z * Z) * cw * ch;
                bx0 = fmin(bx0, qx), bx1 = fmax(bx1, qx);
                by0 = fmin(by0, qy), by1 = fmax(by1, qy);
            }
        if (!(bx0 <= bx1)) {
            /* A small stop's pupil between the points: a finer grid. */
            if (pass == 0 && G0 < 1280) {
                G0 *= 4;
                pass--;
                continue;
            }
            return 0;
        }
        x0 = bx0 - 2 * cw, y0 = by0 - 2 * ch;
        w = bx1 - bx0 + 4 * cw, h = by1 - by0 + 4 * ch;
    }
    return E;
}

static void check_irradiance(const char *lens, double f_number, int points)
{
    char extra[128];
    snprintf(extra, sizeof extra, ", \"focus_distance\": 10, \"f_number\": %g",
             f_number);
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam(lens, extra, "[]", 300, 200, &cam, &c);
    const lr__lens_cam *lc = &c.lens;
    double E0 = brute_irradiance(&c, 0, 0), worst = 0;
    for (int k = 0; k < points; k++) {
        /* Along the diagonal, from the centre to the corner. */
        double t = k / (points - 1.0) * 0.98;
        double fx = 150 + 150 * t, fy = 100 + 100 * t;
        double xs = (0.5 - fx / 300) * lc->sensor_w;
        double ys = (fy / 200 - 0.5) * lc->sensor_h;
        double want = brute_irradiance(&c, xs, ys) / E0, sum = 0;
        /* Jittered: cell centres would count the pupil's edge with a
         * systematic error of its own (1.5% here). */
        const int M = 128;
        uint64_t rng = 0x9E3779B97F4A7C15ull + (uint64_t)k;
        for (int i = 0; i < M; i++)
            for (int j = 0; j < M; j++) {
                double r1 = ((rng = rng * 6364136223846793005ull +
                                    1442695040888963407ull) >>
                             11) *
                            0x1p-53;
                double r2 = ((rng = rng * 6364136223846793005ull +
                                    1442695040888963407ull) >>
                             11) *
                            0x1p-53;
                double u[2] = {(i + r1) / M, (j + r2) / M};
                lr__v3 org, dir;
                sum += lr__cam_lens_ray(&c, fx, fy, u, c.w, c.nm_ref, &org,
                                        &dir);
            }
        assert_true(want >= 0 && want < 2); /* finite: the pupil found */
        double got = sum / (M * M);
        /* And the packet camera's own float code, sixteen at a time. */
        double sum16 = 0;
        for (int i = 0; i < M * M; i += 16) {
            float fx16[16], fy16[16], lu[16], lv[16], wt[16];
            for (int l = 0; l < 16; l++) {
                int q = i + l;
                double r1 = ((rng = rng * 6364136223846793005ull +
                                    1442695040888963407ull) >>
                             11) *
                            0x1p-53;
                double r2 = ((rng = rng * 6364136223846793005ull +
                                    1442695040888963407ull) >>
                             11) *
                            0x1p-53;
                fx16[l] = (float)fx, fy16[l] = (float)fy;
                lu[l] = (float)((q % M + r1) / M);
                lv[l] = (float)((q / M + r2) / M);
            }
            struct RTCRayHit16 rh;
            c.model->rays16(&c, 1, 16, fx16, fy16, lu, lv, &rh, wt);
            for (int l = 0; l < 16; l++)
                sum16 += wt[l];
        }
        double got16 = sum16 / (M * M);
        if (points <= 5 || fabs(got / want - 1) > 0.005 ||
            fabs(got16 / want - 1) > 0.005)
            print_message("%s f/%g, film %.3f of the way to the corner: "
                          "camera %.5f (packets %.5f), integral %.5f\n",
                          lr_lens_name(lc->L), f_number, t, got, got16, want);
        if (want > 0.01)
            worst = fmax(worst,
                         fmax(fabs(got / want - 1), fabs(got16 / want - 1)));
    }
    assert_true(worst < 0.01);
    lr_scene_free(s);
}

/* The packet camera's rays for several packets at once (rays16_n: the
 * packets go through the glass together) are, bit for bit, the rays of
 * each packet alone (rays16), short packets and stopped lanes included;
 * the double Gauss wide open, sample points across the frame and the
 * lens, some outside the pupil. */
static void test_packets_together_as_alone(void **state)
{
    (void)state;
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam("\"double-gauss-50\"", ", \"f_number\": 0", "[]",
                           300, 200, &cam, &c);
    assert_non_null(c.model->rays16_n);
    enum { NP = 6 }; /* more than rays16_n takes at once */
    float fx[NP][16], fy[NP][16], lu[NP][16], lv[NP][16];
    float wt[NP][16], wt1[16];
    int ns[NP] = {16, 16, 7, 16, 1, 16};
    uint64_t rng = 12345;
    for (int p = 0; p < NP; p++)
        for (int l = 0; l < 16; l++) {
            float r[4];
            for (int k = 0; k < 4; k++) {
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                r[k] = (float)((rng >> 40) * 0x1p-24);
            }
            fx[p][l] = 300 * r[0], fy[p][l] = 200 * r[1];
            lu[p][l] = r[2], lv[p][l] = r[3];
        }
    struct RTCRayHit16 rh[NP], rh1;
    memset(rh, 0, sizeof rh);
    c.model->rays16_n(&c, 1, NP, ns, (const float(*)[16])fx,
                      (const float(*)[16])fy, (const float(*)[16])lu,
                      (const float(*)[16])lv, rh, wt);
    int stopped = 0;
    for (int p = 0; p < NP; p++) {
        memset(&rh1, 0, sizeof rh1);
        c.model->rays16(&c, 1, ns[p], fx[p], fy[p], lu[p], lv[p], &rh1, wt1);
        for (int l = 0; l < ns[p]; l++) {
            assert_memory_equal(&wt[p][l], &wt1[l], sizeof(float));
            stopped += wt1[l] == 0.0f;
            const float *a[] = {rh[p].ray.org_x, rh[p].ray.org_y,
                                rh[p].ray.org_z, rh[p].ray.dir_x,
                                rh[p].ray.dir_y, rh[p].ray.dir_z,
                                rh[p].ray.tfar};
            const float *b[] = {rh1.ray.org_x, rh1.ray.org_y, rh1.ray.org_z,
                                rh1.ray.dir_x, rh1.ray.dir_y, rh1.ray.dir_z,
                                rh1.ray.tfar};
            for (int k = 0; k < 7; k++)
                assert_memory_equal(&a[k][l], &b[k][l], sizeof(float));
        }
    }
    /* Both kinds of lane were checked: wide open, the corners vignette. */
    assert_true(stopped > 0 && stopped < 60);
    lr_scene_free(s);
}

static void test_pupil_bounds_lose_no_light(void **state)
{
    (void)state;
    check_irradiance(singlet, 0, 5);
    check_irradiance("\"double-gauss-50\"", 0, 5);
    check_irradiance("\"double-gauss-50\"", 5.6, 5);
    /* Stopped down, the pupil is smaller than the bounds' first grid's
     * cells (it was missed: every ray lost, a black picture). */
    check_irradiance("\"double-gauss-50\"", 22, 3);
    check_irradiance("\"double-gauss-50\"", 128, 3);
    /* Finely, where elements start to cut the pupil one after another
     * (bounds interpolated in proportion lost 1-3.5% in rings there). */
    check_irradiance("\"wide-22\"", 8, 36);
}

/* The exit-pupil table equals the exhaustive search's, bit for bit.
 * camera_lens.c traces the fine grid only from the outside in, until
 * each extreme is found; here every point of both grids is traced, one
 * ray at a time through lr__rx_trace_n (whose bits lr__rx_trace16's
 * lanes repeat), and the bounds are taken over all that pass: the search
 * as it was first written (issue 12).  Every shipped lens, open and
 * stopped down, near and far, and the colour sets of both chromatic
 * modes. */
typedef struct brute_box {
    double x0, x1, y0, y1, e0;
} brute_box;

static int brute_passes(const lr__cam *c, const double *const *ns, int nn,
                        double r, double x, double y, double *cos4)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double dz = lc->z_rear - lc->z_sensor;
    double dx = x - r, dy = y;
    double len = sqrt(dx * dx + dy * dy + dz * dz);
    double ct = -dz / len;
    /* E0 weighs each ray at the reference wavelength by what the glass
     * passes (camera_lens.c's pupil_point; its table, transmit.h). */
    double o0[3] = {r, 0.0, lc->z_sensor}, T = 0.0;
    double d0[3] = {dx / len, dy / len, dz / len};
    if (!lr__rx_trace_t(&L->rx, L->z, lc->n_ref, lc->stop_scale, 0, &lc->t_ref,
                        c->nm_ref, lc->coat, o0, d0, &T))
        T = 0.0;
    *cos4 = ct * ct * ct * ct * T;
    for (int k = 0; k < nn; k++) {
        double o[3] = {r, 0.0, lc->z_sensor};
        double d[3] = {dx / len, dy / len, dz / len};
        if (lr__rx_trace_n(&L->rx, L->z, ns[k], lc->stop_scale, 0, o, d))
            return 1;
    }
    return 0;
}

/* Every point of a g x g grid (cell centres) from (x0, y0): the box of
 * those that pass and their cos^4 summed in row order; with pts, also
 * the points (2 g^2 doubles), *np of them. */
static brute_box brute_grid(const lr__cam *c, const double *const *ns, int nn,
                            double r, double x0, double y0, double cw,
                            double ch, int g, double *pts, int *np)
{
    brute_box b = {INFINITY, -INFINITY, INFINITY, -INFINITY, 0};
    for (int iy = 0; iy < g; iy++)
        for (int ix = 0; ix < g; ix++) {
            double x = x0 + (ix + 0.5) * cw, y = y0 + (iy + 0.5) * ch, c4;
            if (!brute_passes(c, ns, nn, r, x, y, &c4))
                continue;
            b.x0 = fmin(b.x0, x), b.x1 = fmax(b.x1, x);
            b.y0 = fmin(b.y0, y), b.y1 = fmax(b.y1, y);
            b.e0 += c4;
            if (pts != NULL) {
                pts[2 * *np] = x, pts[2 * *np + 1] = y;
                (*np)++;
            }
        }
    return b;
}

static lr__pupil brute_pupil(const lr__cam *c, const double *const *ns, int nn,
                             double r, double *E0)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    int rear = L->rx.n - 1;
    double S = 1.5 * L->rx.s[rear].semi_aperture *
               (rear == L->rx.stop ? lc->stop_scale : 1.0);
    double cell = 0;
    brute_box co = {INFINITY, -INFINITY, 0, 0, 0};
    for (int g = 24; g <= 16 * 24 && !(co.x0 <= co.x1); g *= 4) {
        cell = 2.0 * S / g;
        co = brute_grid(c, ns, nn, r, -S, -S, cell, cell, g, NULL, NULL);
    }
    *E0 = 0.0;
    if (!(co.x0 <= co.x1))
        return (lr__pupil){0, 0, 0, 0};
    double x0 = co.x0 - cell, x1 = co.x1 + cell;
    double y0 = co.y0 - cell, y1 = co.y1 + cell;
    double cw = (x1 - x0) / 128, ch = (y1 - y0) / 128;
    double *pts = malloc(sizeof *pts * 2 * 128 * 128);
    assert_non_null(pts);
    int np = 0;
    brute_box fi;
    /* Points that pass on the fine grid's edge grow its box threefold,
     * at most three times. */
    for (int grow = 0;; grow++) {
        np = 0;
        fi = brute_grid(c, ns, nn, r, x0, y0, cw, ch, 128, pts, &np);
        if (!(fi.x0 <= fi.x1) || grow == 3 ||
            (fi.x0 != x0 + 0.5 * cw && fi.x1 != x0 + 127.5 * cw &&
             fi.y0 != y0 + 0.5 * ch && fi.y1 != y0 + 127.5 * ch))
            break;
        double w = x1 - x0, h = y1 - y0;
        x0 -= w, x1 += w, y0 -= h, y1 += h;
        cw = (x1 - x0) / 128, ch = (y1 - y0) / 128;
    }
    double Z = lc->z_sensor - lc->z_rear;
    *E0 = fi.e0 * cw * ch / (Z * Z);
    double margin = fmax(cw, ch);
    lr__pupil P;
    if (!(fi.x0 <= fi.x1)) {
        P.cx = 0.5 * (x0 + x1);
        P.hx = 0.5 * (x1 - x0), P.hy = fmax(y1, -y0);
        P.rad = hypot(P.hx, P.hy);
    } else {
        P.cx = 0.5 * (fi.x0 + fi.x1);
        P.hx = 0.5 * (fi.x1 - fi.x0) + margin;
        P.hy = fmax(fi.y1, -fi.y0) + margin;
        double m = 0.0;
        for (int i = 0; i < np; i++)
            m = fmax(m, hypot(pts[2 * i] - P.cx, pts[2 * i + 1]));
        P.rad = m + margin;
        /* And the bisection of the pupil's edge that follows the grids
         * (shared: test_pupil_bounds_hold_every_ray checks it). */
        lr__pupil_refine(c, ns, nn, r, margin, &P);
    }
    free(pts);
    return P;
}

/* The index sets the pupil table is built for: the reference, then the
 * three rgb sets or the spectrum's two ends.  lo and hi hold the ends. */
static int pupil_index_sets(const lr__cam *c, double *lo, double *hi,
                            const double **ns)
{
    const lr__lens_cam *lc = &c->lens;
    int nn = 0;
    ns[nn++] = lc->n_ref;
    if (c->chroma_active && c->chroma.mode == LR_CHROMATIC_RGB) {
        for (int k = 0; k < 3; k++)
            ns[nn++] = lc->n_rgb[k];
    } else if (c->chroma_active) {
        assert_true(c->chroma.amplify == 1.0);
        lr__rx_indices(&lc->L->rx, 380.0, lo);
        lr__rx_indices(&lc->L->rx, 780.0, hi);
        ns[nn++] = lo, ns[nn++] = hi;
    }
    return nn;
}

/* Radii k = 0, 1, every `step`-th and the last two are compared (every
 * one when step is 1). */
static void check_pupil_table(const char *lens, const char *extra, int step)
{
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam(lens, extra, "[]", 160, 100, &cam, &c);
    const lr__lens_cam *lc = &c.lens;
    double lo[LR__RX_MAX_SURFACES], hi[LR__RX_MAX_SURFACES];
    const double *ns[4];
    int nn = pupil_index_sets(&c, lo, hi, ns);
    int empty = 0;
    for (int k = 0; k <= LR__PUPIL_N; k++) {
        if (k > 1 && k < LR__PUPIL_N - 1 && k % step != 0)
            continue;
        double E0;
        lr__pupil want = brute_pupil(&c, ns, nn,
                                     lc->pupil_rmax * k / LR__PUPIL_N, &E0);
        if (k == 0)
            assert_memory_equal(&lc->inv_E0,
                                &(double){E0 > 0.0 ? 1.0 / E0 : 0.0},
                                sizeof(double));
        empty += want.rad == 0.0;
        if (memcmp(&want, &lc->pupil[k], sizeof want) != 0)
            fail_msg("%s %s: film radius %d/%d: bounds (%.17g %.17g %.17g "
                     "%.17g), the exhaustive search's (%.17g %.17g %.17g "
                     "%.17g)",
                     lens, extra, k, LR__PUPIL_N, lc->pupil[k].cx,
                     lc->pupil[k].rad, lc->pupil[k].hx, lc->pupil[k].hy,
                     want.cx, want.rad, want.hx, want.hy);
    }
    assert_true(empty < LR__PUPIL_N); /* something was compared */
    lr_scene_free(s);
}

/* Every shipped lens (lenses/). */
static const char *const shipped_lenses[] = {
    "biotar-de485798-100mm-f1.4",
    "double-gauss-50",
    "double-gauss-angenieux-us2701982-100mm-f1.1",
    "fisheye-10",
    "fisheye-minolta-us4256373-16mm-f2.8",
    "objective-us8879901-36mm-f2",
    "petzval-kodak-us2500046-100mm-f2.2",
    "petzval",
    "planar-rudolph-us583336-49mm-f4.5",
    "retrofocus-flektagon-de953471-35mm-f2.8",
    "retrofocus-nikon-us3583791-100mm-f2.8",
    "sonnar-us1975678-50mm-f1.5",
    "telephoto-250",
    "telephoto-laikin-127mm-f5.6",
    "tessar-laikin-102mm-f4.5",
    "wide-170deg-laikin-5mm-f1.8",
    "wide-22",
    "zoom-nikkor-us4189212-25mm-f4",
    "zoom-nikkor-us4189212-35mm-f4",
    "zoom-nikkor-us4189212-49mm-f4.4",
    "zoom-nikkor-z-14-30mm-f4-at-14mm",
    "zoom-nikon-jp53131852-200mm-f2.8",
    "zoom-nikon-jp53131852-80mm-f2.8",
};

/* The shipped lenses a sweep takes: every one, or under the sanitizers
 * (LR_TEST_SANITIZED, test.h) one of each kind: the double Gauss, the
 * fisheyes, a wide angle and the zoom with four aspheres. */
static int shipped_swept(size_t i)
{
    const char *l = shipped_lenses[i];
    return !LR_TEST_SANITIZED || strcmp(l, "double-gauss-50") == 0 ||
           strstr(l, "fisheye") != NULL || strcmp(l, "wide-22") == 0 ||
           strstr(l, "z-14-30") != NULL;
}

static void test_pupil_table_exact(void **state)
{
    (void)state;
    char name[128];
    for (size_t i = 0; i < sizeof shipped_lenses / sizeof *shipped_lenses;
         i++) {
        if (!shipped_swept(i))
            continue;
        snprintf(name, sizeof name, "\"%s\"", shipped_lenses[i]);
        check_pupil_table(name, ", \"focus_distance\": 5", 8);
    }
    check_pupil_table("\"double-gauss-50\"",
                      ", \"focus_distance\": 1, \"f_number\": 2", 1);
    check_pupil_table("\"double-gauss-50\"",
                      ", \"focus_distance\": 0.6, \"f_number\": 2.8,"
                      " \"chromatic\": {\"mode\": \"rgb\"}",
                      4);
    check_pupil_table("\"wide-22\"",
                      ", \"focus_distance\": 10, \"f_number\": 8,"
                      " \"chromatic\": {\"mode\": \"spectral\"}",
                      4);
    /* Stopped down past the coarse grid's cells (its finer grids). */
    check_pupil_table("\"double-gauss-50\"",
                      ", \"focus_distance\": 10, \"f_number\": 64", 8);
    check_pupil_table(singlet, ", \"focus_distance\": 2000", 8);
}

/* The bounds that lr__lens_pupil_at gives hold every ray that gets
 * through, at film radii between the table's entries as well as on them:
 * points just outside the sampling domain's edge (a millionth, a
 * thousandth and a hundredth of its size out; 360 of each around a disk,
 * 90 a side of a box) and a coarse grid over three times the rear element
 * outside it are traced, through each index set the camera traces, and
 * none may pass.  The pupil is connected and holds the domain's centre,
 * so a part of it outside the domain crosses the edge.  `lost` gets the
 * share of the domain's jittered points on the axis that do not pass.
 * (The grid's bounds before the edge was bisected: 12% lost at f/11.) */
static void domain_point(const lr__pupil *P, int disk, int i, int n, double out,
                         double *a, double *b)
{
    if (disk) {
        double th = 2.0 * M_PI * (i + 0.5) / n, rr = P->rad * (1.0 + out);
        *a = P->cx + rr * cos(th), *b = rr * sin(th);
        return;
    }
    int side = i % 4;
    double t = (i / 4 + 0.5) / (n / 4) * 2.0 - 1.0;
    double hx = P->hx * (1.0 + out), hy = P->hy * (1.0 + out);
    *a = P->cx + (side < 2 ? (side == 0 ? -hx : hx) : t * hx);
    *b = side < 2 ? t * hy : (side == 2 ? -hy : hy);
}

static void check_bounds_hold(const char *lens, const char *extra, int step,
                              double *lost)
{
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam(lens, extra, "[]", 160, 100, &cam, &c);
    const lr__lens_cam *lc = &c.lens;
    double lo[LR__RX_MAX_SURFACES], hi[LR__RX_MAX_SURFACES];
    const double *ns[4];
    int nn = pupil_index_sets(&c, lo, hi, ns);
    const lr_lens *L = lc->L;
    double S = 1.5 * L->rx.s[L->rx.n - 1].semi_aperture *
               (L->rx.n - 1 == L->rx.stop ? lc->stop_scale : 1.0);
    static const double outs[] = {1e-6, 1e-3, 1e-2};
    int bad = 0, tried = 0;
    double c4;
    for (int k = 0; k < LR__PUPIL_N; k++) {
        if (k % step != 0 && k != LR__PUPIL_N - 1)
            continue;
        for (int q = 0; q < 4; q++) {
            double r = lc->pupil_rmax * (k + q / 4.0 + 0.125) / LR__PUPIL_N;
            lr__pupil P = lr__lens_pupil_at(lc, r);
            if (!(P.rad > 0.0))
                continue;
            int disk = M_PI * P.rad * P.rad <= 4.0 * P.hx * P.hy;
            for (int o = 0; o < 3; o++)
                for (int i = 0; i < 360; i++, tried++) {
                    double a, b;
                    domain_point(&P, disk, i, 360, outs[o], &a, &b);
                    if (brute_passes(&c, ns, nn, r, a, b, &c4)) {
                        if (bad++ < 5)
                            print_message("%s%s: film radius %.4f mm: "
                                          "(%.5f, %.5f) passes outside "
                                          "the bounds (%.5f %.5f %.5f "
                                          "%.5f)\n",
                                          lens, extra, r, a, b, P.cx, P.rad,
                                          P.hx, P.hy);
                    }
                }
            for (int iy = 0; iy < 40; iy++)
                for (int ix = 0; ix < 40; ix++) {
                    double a = -S + (ix + 0.5) * S / 20,
                           b = -S + (iy + 0.5) * S / 20;
                    double da = a - P.cx;
                    int in = disk ? da * da + b * b <= P.rad * P.rad
                                  : fabs(da) <= P.hx && fabs(b) <= P.hy;
                    if (in)
                        continue;
                    tried++;
                    if (brute_passes(&c, ns, nn, r, a, b, &c4) && bad++ < 5)
                        print_message("%s%s: film radius %.4f mm: grid "
                                      "point (%.4f, %.4f) passes outside\n",
                                      lens, extra, r, a, b);
                }
        }
    }
    if (lost != NULL) {
        int n = 0, miss = 0;
        for (int i = 0; i < 64; i++)
            for (int j = 0; j < 64; j++, n++) {
                double u[2] = {(i + 0.37) / 64, (j + 0.61) / 64};
                lr__v3 o, d;
                miss += lr__cam_lens_ray(&c, 80, 50, u, c.w, c.nm_ref, &o,
                                         &d) == 0.0;
            }
        *lost = (double)miss / n;
    }
    assert_true(tried > 0);
    if (bad > 0)
        fail_msg("%s%s: %d of %d points outside the bounds pass", lens, extra,
                 bad, tried);
    lr_scene_free(s);
}

static void test_pupil_bounds_hold_every_ray(void **state)
{
    (void)state;
    char name[1200];
    for (size_t i = 0; i < sizeof shipped_lenses / sizeof *shipped_lenses;
         i++) {
        snprintf(name, sizeof name, "\"%s\"", shipped_lenses[i]);
        check_bounds_hold(name, ", \"focus_distance\": 5", 3, NULL);
    }
    static const char *const test_lenses[] = {
        "minolta-fisheye-us4256373.json", "nikon-zoom-80-200-short.json",
        "flektagon-de953471.json", "wide-170-laikin.json", "dgauss.50mm.dat"};
    for (size_t i = 0; i < sizeof test_lenses / sizeof *test_lenses; i++) {
        char cwd[1024];
        assert_non_null(getcwd(cwd, sizeof cwd));
        snprintf(name, sizeof name, "\"%s/tests/data/lenses/%s\"", cwd,
                 test_lenses[i]);
        /* The test fisheye is scaled to f = 1 mm: a sensor to match. */
        check_bounds_hold(
            name,
            strstr(name, "us4256373") != NULL
                ? ", \"focus_distance\": 3, \"sensor_width_mm\": 2.4"
                : ", \"focus_distance\": 3",
            3, NULL);
    }
    double lost;
    check_bounds_hold("\"double-gauss-50\"",
                      ", \"focus_distance\": 1, \"f_number\": 2", 1, NULL);
    check_bounds_hold("\"double-gauss-50\"",
                      ", \"focus_distance\": 0.6, \"f_number\": 2.8,"
                      " \"chromatic\": {\"mode\": \"rgb\"}",
                      2, NULL);
    check_bounds_hold("\"wide-22\"",
                      ", \"focus_distance\": 10, \"f_number\": 8,"
                      " \"chromatic\": {\"mode\": \"spectral\"}",
                      2, NULL);
    check_bounds_hold("\"double-gauss-50\"",
                      ", \"focus_distance\": 16, \"f_number\": 11", 1, &lost);
    print_message("double-gauss-50 f/11: %.2f%% of the rays on the axis "
                  "lost\n",
                  100 * lost);
    assert_true(lost < 0.02);
    check_bounds_hold("\"double-gauss-50\"",
                      ", \"focus_distance\": 10, \"f_number\": 64", 2, NULL);
}

/* The light side's lens points cover every ray that gets through: random
 * rays from the object side (any slope to 13, 85 degrees, and as many
 * within 1.3 times the bound, where a miss would be), on every shipped
 * lens and the singlet, cross the first vertex's plane inside the disk
 * camera_lens.c draws from (a + sag lr__lens_front_slope) whenever they
 * get through, stop open, at the d line and at 400 and 700 nm.  A lens
 * left at the former fixed bound, 4, is only reported: the fisheyes and
 * the 170-degree wide angle take steeper rays, which it misses. */
static void check_front_disk(const char *lens)
{
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam(lens, ", \"focus_distance\": 5", "[]", 16, 16, &cam,
                           &c);
    const lr_lens *L = c.lens.L;
    const lr__surface *s0 = &L->rx.s[0];
    double a = s0->semi_aperture, sag = a;
    if (s0->radius != 0.0 && fabs(s0->radius) > a)
        sag = fabs(s0->radius) - sqrt(s0->radius * s0->radius - a * a);
    else if (s0->radius == 0.0)
        sag = 0.0;
    double bound = lr__lens_front_slope(L), rho = a + sag * bound;
    assert_true(bound > 0.0 && bound < 40.0);
    uint64_t rng = 0x2545F4914F6CDD1Dull;
#define RND()                                                                \
    (((rng = rng * 6364136223846793005ull + 1442695040888963407ull) >> 11) * \
     0x1p-53)
    int through = 0, missed = 0;
    const double nms[3] = {LR__NM_d, 400.0, 700.0};
    for (int w = 0; w < 3; w++) {
        double n[LR__RX_MAX_SURFACES];
        lr__rx_indices(&L->rx, nms[w], n);
        for (int i = 0; i < 100000; i++) {
            double sl = (i & 1) ? 13.0 * RND()
                                : fmin(1.3 * bound, 13.0) * RND();
            double phi = 2.0 * M_PI * RND();
            double R = a + sag * sl, r = R * sqrt(RND()), t = 2 * M_PI * RND();
            double ox = r * cos(t), oy = r * sin(t);
            double len = sqrt(1.0 + sl * sl);
            double d[3] = {sl * cos(phi) / len, sl * sin(phi) / len, 1 / len};
            double back = (a + 1.0) / d[2];
            double o[3] = {ox - back * d[0], oy - back * d[1],
                           L->z[0] - back * d[2]};
            if (!lr__rx_trace_n(&L->rx, L->z, n, 1.0, 1, o, d))
                continue;
            through++;
            if (hypot(ox, oy) > rho && bound >= 4.0) {
                /* The former fixed bound, kept: its misses are known. */
                missed++;
                continue;
            }
            if (hypot(ox, oy) > rho)
                fail_msg("%s: a ray of slope %g through (%g, %g), %g mm "
                         "from the axis, gets through; the disk is %g mm "
                         "(slope bound %g)",
                         lens, sl, ox, oy, hypot(ox, oy), rho, bound);
        }
    }
#undef RND
    if (missed > 0)
        print_message("%s: slope bound 4 (the former one): %d of %d rays "
                      "through miss the disk\n",
                      lens, missed, through);
    assert_true(through > 100);
    lr_scene_free(s);
}

static void test_front_disk_covers(void **state)
{
    (void)state;
    char name[128];
    for (size_t i = 0; i < sizeof shipped_lenses / sizeof *shipped_lenses;
         i++) {
        snprintf(name, sizeof name, "\"%s\"", shipped_lenses[i]);
        check_front_disk(name);
    }
    check_front_disk(singlet);
}

/* The real chief ray's image height (mm) of a field angle at `nm`, from
 * lr_lens_describe (the prescription's own analysis, which aims each
 * chief ray at the stop's centre from infinity; tests/lenses/compare.py
 * checks it against ray-optics). */
static double chief_height(const char *lens, double deg, double nm)
{
    char *json = NULL;
    lr_error err;
    assert_int_equal(lr_lens_describe(lens, NULL, &deg, 1, nm, &json, &err),
                     LR_OK);
    cJSON *root = cJSON_Parse(json);
    assert_non_null(root);
    const cJSON *f = cJSON_GetArrayItem(
        cJSON_GetObjectItemCaseSensitive(root, "fields"), 0);
    const cJSON *h = cJSON_GetObjectItemCaseSensitive(f, "image_height_mm");
    assert_true(cJSON_IsNumber(h));
    double v = h->valuedouble;
    cJSON_Delete(root);
    lr_free(json);
    return v;
}

/* Centroid (pixels, x) of channel ch of an image. */
static double centroid_x(const lr_image *img, int ch, double *total)
{
    const float *p = lr_image_rgb(img);
    int w = lr_image_width(img), h = lr_image_height(img);
    double sum = 0, sx = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = p[3 * (y * w + x) + ch];
            sum += v, sx += v * (x + 0.5);
        }
    *total = sum;
    return sx / sum;
}

/* Where a collimated beam from field angle `deg` (toward +x in the
 * scene, so toward -x in the lens) lands on the camera's sensor at `nm`:
 * the mean x of the rays, traced from the object side on a fine grid
 * over the first surface (equal power each), that get through.  This is
 * the other direction from the camera's rays (sensor to scene, sampled
 * in exit-pupil bounds, then through Embree), so it checks them. */
static double beam_centroid(const lr__cam *c, double deg, double nm)
{
    const lr_lens *L = c->lens.L;
    double n_after[LR__RX_MAX_SURFACES];
    lr__rx_indices(&L->rx, nm, n_after);
    double th = deg * M_PI / 180, S = L->rx.s[0].semi_aperture;
    double sx = 0;
    int n = 0;
    const int G = 400;
    for (int iy = 0; iy < G; iy++)
        for (int ix = 0; ix < G; ix++) {
            double o[3] = {-S + (ix + 0.5) * 2 * S / G,
                           -S + (iy + 0.5) * 2 * S / G, -1e-9};
            double d[3] = {-sin(th), 0, cos(th)};
            /* Back along the ray to just before the first vertex. */
            o[0] -= d[0] * 100, o[2] -= d[2] * 100;
            if (!lr__rx_trace_n(&L->rx, L->z, n_after, c->lens.stop_scale, 1, o,
                                d))
                continue;
            double t = (c->lens.z_sensor - o[2]) / d[2];
            sx += o[0] + t * d[0];
            n++;
        }
    assert_true(n > 100);
    return sx / n;
}

/* A small distant sphere's image, rendered through the lens, is centred
 * where the lens puts a beam from its direction (within 0.1 px), channel
 * by channel in rgb mode: so the colours' split is the lens's lateral
 * colour at the channels' wavelengths (610 and 465 nm).  The real chief
 * ray's height, from lr_lens_describe, is printed beside it (the beam's
 * centroid differs from it by the coma at f/8 and by the blue's focus
 * shift). */
static void test_point_image_where_the_lens_puts_it(void **state)
{
    (void)state;
    const char *lens = "fisheye-10";
    const double deg[] = {0.0, 30.0, 55.0};
    const int W = 241, H = 41;
    const double sensor = 24.0; /* mm: the fisheye's image circle */
    for (int k = 0; k < 3; k++) {
        double th = deg[k] * M_PI / 180;
        /* 1 km away at angle th to the right, half a pixel across. */
        char obj[256], extra[256];
        snprintf(obj, sizeof obj,
                 "[{\"type\": \"sphere\", \"center\": [%.17g, 0, %.17g],"
                 " \"radius\": 5, \"material\": \"w\"}]",
                 1000 * sin(th), -1000 * cos(th));
        snprintf(extra, sizeof extra,
                 ", \"focus_distance\": 1000, \"f_number\": 8,"
                 " \"sensor_width_mm\": %g,"
                 " \"chromatic\": {\"mode\": \"rgb\"}",
                 sensor);
        char quoted[64];
        snprintf(quoted, sizeof quoted, "\"%s\"", lens);
        lr_scene *s = lens_scene(quoted, extra, obj, W, H, 64);
        lr_camera cam;
        lr_scene_camera(s, &cam);
        lr_render_settings rs;
        lr_scene_settings(s, &rs);
        lr_image *img = lr_test_render_with(s, &cam, &rs, "beam centroid");
        lr__cam c;
        lr__cam_init(&c, &cam, W, H);
        double px = sensor / W, tot;
        double split[2];
        for (int ch = 0; ch < 3; ch += 2) {
            double nm = ch == 0 ? 610.0 : 465.0;
            /* The film's x grows to the right; the sensor's to the left
             * (the image is inverted, camera_lens.c). */
            double want = W / 2.0 - beam_centroid(&c, deg[k], nm) / px;
            double chief = W / 2.0 + chief_height(lens, deg[k], nm) / px;
            double got = centroid_x(img, ch, &tot);
            split[ch / 2] = got;
            print_message("%s %g deg, %g nm: image centroid %.3f px, beam "
                          "%.3f px (%+.3f), chief ray %.3f px\n",
                          lens, deg[k], nm, got, want, got - want, chief);
            assert_true(tot > 0);
            assert_true(fabs(got - want) < 0.1);
        }
        print_message("  red - blue: %.3f px\n", split[0] - split[1]);
        lr_image_free(img);
        lr_scene_free(s);
    }
}

static const struct CMUnitTest camera_lens_tests[] = {
    cmocka_unit_test(test_sensor_dwarfs_circle),
    cmocka_unit_test(test_thin_singlet_matches_thin_lens),
    cmocka_unit_test(test_few_rays_lost_on_axis),
    cmocka_unit_test(test_autofocus_on_a_pixel),
    cmocka_unit_test(test_white_surround),
    cmocka_unit_test(test_white_surround_big_rear_stop),
    cmocka_unit_test(test_every_lens_closed_down),
    cmocka_unit_test(test_errors_name_the_field),
    cmocka_unit_test(test_lens_written_back),
    cmocka_unit_test(test_override_opens_no_working_directory_file),
    cmocka_unit_test(test_lens_file_errors_start_with_the_field),
    cmocka_unit_test(test_pupil_bounds_lose_no_light),
    cmocka_unit_test(test_pupil_table_exact),
    cmocka_unit_test(test_pupil_bounds_hold_every_ray),
    cmocka_unit_test(test_front_disk_covers),
    cmocka_unit_test(test_packets_together_as_alone),
    cmocka_unit_test(test_point_image_where_the_lens_puts_it),
};

LR_TEST_GROUP(camera_lens, camera_lens_tests)
