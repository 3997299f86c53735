/*
 * test_shade.c: shading against closed-form radiometry, energy
 * conservation of mirrors and glass, and the render loop's guarantees
 * (determinism, exact accumulation, depth channel, cancellation).
 */
#include "test.h"
#include "render/film.h"
#include "integrator/integrator.h"


#include <math.h>
#include <stdio.h>
#include <string.h>

static void assert_rel(double got, double want, double tol, const char *what)
{
    if (!(fabs(got - want) <= tol * fabs(want)))
        fail_msg("%s: got %.12g, expected %.12g (relative tolerance %g)", what,
                 got, want, tol);
}

/* A lit Lambertian plane: L = albedo / pi * I cos(theta) / r^2. */
static void test_lambert_point_light(void **state)
{
    (void)state;
    const double a = 0.6, I = 50.0, hgt = 4.0;
    lr_scene *s = lr_test_load_json(
        "{\"materials\": {\"m\": {\"diffuse\": 0.6}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 4, 0],"
        "   \"intensity\": 50}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0],"
        "   \"material\": \"m\"}]}");
    const double xs[] = {0.0, 1.0, 3.0, 7.0, 20.0};
    for (size_t i = 0; i < 5; i++) {
        lr__v3 p = v3(xs[i], 0, -0.5 * xs[i]);
        lr__v3 eye = v3(0.3, 10, 5);
        uint64_t rays = 0;
        lr__v3 L = lr__radiance(s, eye, v3_norm(v3_sub(p, eye)), 0, 4, &rays);
        double r2 = p.x * p.x + hgt * hgt + p.z * p.z;
        double cos_t = hgt / sqrt(r2);
        double want = a / M_PI * I * cos_t / r2;
        assert_rel(L.x, want, 1e-9, "Lambert radiance");
        assert_rel(L.z, want, 1e-9, "Lambert radiance (blue)");
        assert_int_equal(rays, 2); /* camera ray + shadow ray */
    }
    lr_scene_free(s);
}

static void test_shadow_and_ambient(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(
        "{\"materials\": {\"m\": {\"diffuse\": 0.5}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 4, 0],"
        "   \"intensity\": 50}, {\"type\": \"ambient\", \"radiance\": 0.2}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0],"
        "   \"material\": \"m\"}, {\"type\": \"sphere\", \"center\": [0, 2, 0],"
        "   \"radius\": 0.5}]}");
    uint64_t rays = 0;
    /* Right under the sphere: only the ambient term, albedo * La. */
    lr__v3 L = lr__radiance(s, v3(0.05, 1, 3), v3_norm(v3(-0.05, -1, -3)), 0, 4,
                            &rays);
    assert_rel(L.y, 0.5 * 0.2, 1e-12, "shadowed radiance");
    lr_scene_free(s);
}

static void test_directional_light(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(
        "{\"materials\": {\"m\": {\"diffuse\": [0.2, 0.4, 0.8]}},"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [1, -2, 0],"
        "   \"irradiance\": 3}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0],"
        "   \"material\": \"m\"}]}");
    uint64_t rays = 0;
    lr__v3 L = lr__radiance(s, v3(0, 5, 5), v3_norm(v3(0, -1, -1)), 0, 4,
                            &rays);
    double cos_t = 2.0 / sqrt(5.0);
    assert_rel(L.x, 0.2 / M_PI * 3 * cos_t, 1e-12, "directional red");
    assert_rel(L.z, 0.8 / M_PI * 3 * cos_t, 1e-12, "directional blue");
    lr_scene_free(s);
}

/* Normalised Phong: ks (n + 2) / (2 pi) cos^n(alpha) E cos(theta). */
static void test_normalised_phong(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(
        "{\"materials\": {\"m\": {\"specular\": 0.5, \"shininess\": 20}},"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [1, -1, 0],"
        "   \"irradiance\": 2}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0],"
        "   \"material\": \"m\"}]}");
    uint64_t rays = 0;
    double ks = 0.5, n = 20, E = 2, cos_t = sqrt(0.5);
    /* Looking along the mirror direction: alpha = 0. */
    lr__v3 L = lr__radiance(s, v3(5, 5, 0), v3_norm(v3(-1, -1, 0)), 0, 4,
                            &rays);
    assert_rel(L.x, ks * (n + 2) / (2 * M_PI) * E * cos_t, 1e-12,
               "Phong at the mirror direction");
    /* Ten degrees off the mirror direction (in the plane of incidence). */
    double th = (45.0 + 10.0) * M_PI / 180.0;
    lr__v3 eye = v3(5 * sin(th), 5 * cos(th), 0);
    L = lr__radiance(s, eye, v3_norm(v3_neg(eye)), 0, 4, &rays);
    double want = ks * (n + 2) / (2 * M_PI) * pow(cos(10 * M_PI / 180), n) * E *
                  cos_t;
    assert_rel(L.x, want, 1e-9, "Phong 10 degrees off");
    lr_scene_free(s);
}

static void test_fresnel(void **state)
{
    (void)state;
    /* Normal incidence: ((n1 - n2) / (n1 + n2))^2 = 0.04 for glass. */
    assert_rel(lr__fresnel_dielectric(1.0, 1.0 / 1.5), 0.04, 1e-12,
               "normal incidence");
    assert_rel(lr__fresnel_dielectric(1.0, 1.5), 0.04, 1e-12,
               "normal incidence from inside");
    /* Beyond the critical angle asin(1/1.5) = 41.8 degrees: total. */
    assert_true(lr__fresnel_dielectric(cos(45 * M_PI / 180), 1.5) == 1.0);
    /* Grazing incidence reflects everything. */
    assert_rel(lr__fresnel_dielectric(0.0, 1.0 / 1.5), 1.0, 1e-12, "grazing");
    /* Brewster's angle atan(1.5): rp = 0, so F = rs^2 / 2. */
    double tb = atan(1.5), ct = cos(M_PI / 2 - tb);
    double rs = (cos(tb) - 1.5 * ct) / (cos(tb) + 1.5 * ct);
    assert_rel(lr__fresnel_dielectric(cos(tb), 1.0 / 1.5), 0.5 * rs * rs, 1e-9,
               "Brewster");
}

/* A lossless mirror or glass ball in a uniform environment must look
 * exactly like the environment: energy is neither made nor lost. */
static void test_energy_mirror_and_glass(void **state)
{
    (void)state;
    const char *mats[] = {"{\"reflect\": 1}", "{\"transmit\": 1, \"ior\": 1.5}",
                          "{\"transmit\": 1, \"ior\": 2.4}"};
    for (size_t k = 0; k < 3; k++) {
        char json[1024];
        snprintf(json, sizeof json,
                 "{\"background\": 0.7, \"materials\": {\"m\": %s},"
                 " \"objects\": [{\"type\": \"sphere\", \"center\": [0,0,-4],"
                 " \"radius\": 1, \"material\": \"m\"}]}",
                 mats[k]);
        lr_scene *s = lr_test_load_json(json);
        for (int i = 0; i < 50; i++) {
            double x = -0.99 + 1.98 * i / 49.0;
            uint64_t rays = 0;
            lr__v3 d = v3_norm(v3(x / 4.0, 0.1 * x / 4.0, -1));
            lr__v3 L = lr__radiance(s, v3(0, 0, 0), d, 0, 40, &rays);
            if (fabs(L.y - 0.7) > 1e-4)
                fail_msg("%s, ray %d: radiance %.9g, want 0.7", mats[k], i,
                         L.y);
        }
        lr_scene_free(s);
    }
}

static void test_film_drops_nan(void **state)
{
    (void)state;
    lr__pixel p;
    lr__pixel_reset(&p);
    lr__pixel_add(&p, v3(1, 2, 3));
    lr__pixel_add(&p, v3(NAN, 0, 0));
    lr__pixel_add(&p, v3(INFINITY, 0, 0));
    lr__pixel_add(&p, v3(1, 2, 3));
    float out[3];
    lr__pixel_resolve(&p, out);
    assert_int_equal(p.dropped, 2);
    assert_true(out[0] == 0.5f && out[1] == 1.0f && out[2] == 1.5f);
    /* Finite but larger than a float: clamped, never Inf. */
    lr__pixel_reset(&p);
    lr__pixel_add(&p, v3(1e300, -1e300, 0));
    lr__pixel_resolve(&p, out);
    assert_true(isfinite(out[0]) && isfinite(out[1]));
}

/* lr__pixel_add16 (a packet's samples per channel) gives the bits of
 * lr__pixel_add_n (one struct per sample), for every n, with non-finite
 * samples among them or not; without squares it leaves sum2 alone. */
static void test_film_add16_matches_add_n(void **state)
{
    (void)state;
    uint64_t z = 12345;
    for (int round = 0; round < 400; round++) {
        int n = 1 + round % 16;
        double L[3][16];
        lr__v3 A[16];
        for (int i = 0; i < 16; i++)
            for (int c = 0; c < 3; c++) {
                z = lr__mix64(z + 1);
                /* Values over many scales, so that the sums round. */
                double v = (double)(z >> 11) * 0x1p-53 *
                           ldexp(1.0, (int)(z % 40) - 20);
                if (round % 5 == 0 && (z >> 7) % 23 == 0)
                    v = (z >> 3) % 3 == 0   ? NAN
                        : (z >> 3) % 3 == 1 ? INFINITY
                                            : -INFINITY;
                L[c][i] = v;
            }
        for (int i = 0; i < 16; i++)
            A[i] = v3(L[0][i], L[1][i], L[2][i]);
        lr__pixel a, b, c;
        lr__pixel_reset(&a);
        a.sum[0] = 0.1, a.sum[1] = 1e-3, a.sum[2] = 7.0;
        a.sum2[0] = 0.3, a.sum2[1] = 2.0, a.sum2[2] = 1e-5;
        a.n = 3;
        b = a, c = a;
        lr__pixel_add_n(&a, A, n);
        lr__pixel_add16(&b, (const double(*)[16])L, n, 1);
        lr__pixel_add16(&c, (const double(*)[16])L, n, 0);
        if (memcmp(&a, &b, sizeof a) != 0)
            fail_msg("round %d (n %d): add16 differs from add_n", round, n);
        assert_memory_equal(a.sum, c.sum, sizeof a.sum);
        assert_true(c.sum2[0] == 0.3 && c.sum2[1] == 2.0 && c.sum2[2] == 1e-5);
        assert_true(c.n == a.n && c.dropped == a.dropped);
    }
}

static lr_image *render(const char *json, int threads, int tile,
                        lr_render_stats *stats)
{
    lr_scene *s = lr_test_load_json(json);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    if (threads >= 0)
        rs.threads = threads;
    if (tile > 0)
        rs.tile_size = tile;
    lr_image *img = NULL;
    lr_error err;
    if (lr_render(s, &cam, &rs, &img, stats, &err) != LR_OK)
        fail_msg("render failed: %s", err.message);
    lr_scene_free(s);
    return img;
}

/* A constant scene averages back to exactly the constant, even at a very
 * high sample count (sums are double). */
static void test_constant_scene_exact(void **state)
{
    (void)state;
    lr_render_stats st;
    lr_image *img = render("{\"background\": [0.3, 0.1, 0.7],"
                           " \"render\": {\"width\": 2, \"height\": 2,"
                           " \"spp\": 65536, \"adaptive\": false}}",
                           -1, 0, &st);
    const float *px = lr_image_rgb(img);
    for (int i = 0; i < 4; i++)
        assert_true(px[3 * i] == 0.3f && px[3 * i + 1] == 0.1f &&
                    px[3 * i + 2] == 0.7f);
    assert_int_equal(st.samples, 4 * 65536);
    assert_int_equal(st.rays, 4 * 65536);
    lr_image_free(img);
}

static const char *busy_scene =
    "{\"render\": {\"width\": 37, \"height\": 23, \"spp\": 3, \"depth\": true},"
    " \"camera\": {\"position\": [0, 1, 5], \"look_at\": [0, 0.5, 0]},"
    " \"background\": 0.2,"
    " \"materials\": {\"g\": {\"transmit\": 1}, \"r\": {\"reflect\": 0.5,"
    "   \"diffuse\": 0.3}},"
    " \"lights\": [{\"type\": \"point\", \"position\": [2, 5, 3],"
    "   \"intensity\": 40}],"
    " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0]},"
    "   {\"type\": \"sphere\", \"center\": [-0.6, 0.5, 0], \"radius\": 0.5,"
    "    \"material\": \"g\"},"
    "   {\"type\": \"sphere\", \"center\": [0.6, 0.5, -0.5], \"radius\": 0.5,"
    "    \"material\": \"r\"}]}";

static void test_deterministic_across_threads_and_tiles(void **state)
{
    (void)state;
    lr_image *ref = render(busy_scene, 1, 64, NULL);
    const int configs[][2] = {{2, 1}, {3, 5}, {2, 16}, {0, 7}};
    for (size_t i = 0; i < 4; i++) {
        lr_image *img = render(busy_scene, configs[i][0], configs[i][1], NULL);
        assert_memory_equal(lr_image_rgb(ref), lr_image_rgb(img),
                            37 * 23 * 3 * sizeof(float));
        assert_memory_equal(lr_image_depth(ref), lr_image_depth(img),
                            37 * 23 * sizeof(float));
        lr_image_free(img);
    }
    /* And a different seed gives a different image (the seed is used). */
    lr_scene *s = lr_test_load_json(busy_scene);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    rs.seed = 12345;
    lr_image *other = NULL;
    assert_int_equal(lr_render(s, &cam, &rs, &other, NULL, NULL), LR_OK);
    assert_true(memcmp(lr_image_rgb(ref), lr_image_rgb(other),
                       37 * 23 * 3 * sizeof(float)) != 0);
    for (int i = 0; i < 37 * 23 * 3; i++)
        assert_true(isfinite(lr_image_rgb(other)[i]));
    lr_image_free(other);
    lr_scene_free(s);
    lr_image_free(ref);
}

/* Z is the distance along the view axis: constant on a plane facing the
 * camera, LR_DEPTH_NONE where nothing is hit. */
static void test_depth_channel(void **state)
{
    (void)state;
    lr_image *img = render(
        "{\"render\": {\"width\": 9, \"height\": 7, \"spp\": 1,"
        "  \"depth\": true},"
        " \"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -1]},"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, -7],"
        "   \"normal\": [0, 0, 1], \"size\": [100, 0.5]}]}",
        -1, 0, NULL);
    const float *z = lr_image_depth(img);
    assert_non_null(z);
    /* The middle row sees the strip, the top row sees nothing. */
    for (int x = 0; x < 9; x++) {
        assert_true(fabsf(z[3 * 9 + x] - 7.0f) < 1e-4f);
        assert_true(z[x] == LR_DEPTH_NONE);
    }
    lr_image_free(img);
}

/* A region's pixels are bit-identical to the same pixels of the full
 * frame, so a large job can be split and stitched. */
static void test_region_matches_full_frame(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(busy_scene);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    lr_image *full = NULL, *crop = NULL;
    assert_int_equal(lr_render(s, &cam, &rs, &full, NULL, NULL), LR_OK);
    const int regions[][4] = {{5, 3, 20, 11}, {0, 0, 37, 23}, {36, 22, 37, 23}};
    for (size_t k = 0; k < 3; k++) {
        memcpy(rs.region, regions[k], sizeof rs.region);
        rs.tile_size = 4;
        lr_render_stats st;
        assert_int_equal(lr_render(s, &cam, &rs, &crop, &st, NULL), LR_OK);
        int w = regions[k][2] - regions[k][0],
            h = regions[k][3] - regions[k][1];
        assert_int_equal(lr_image_width(crop), w);
        assert_int_equal(lr_image_height(crop), h);
        assert_int_equal(st.pixels, (uint64_t)(w * h));
        for (int y = 0; y < h; y++) {
            const float *a = lr_image_rgb(full) +
                             3 * ((y + regions[k][1]) * 37 + regions[k][0]);
            const float *b = lr_image_rgb(crop) + 3 * y * w;
            assert_memory_equal(a, b, 3 * (size_t)w * sizeof(float));
            const float *za = lr_image_depth(full) + (y + regions[k][1]) * 37 +
                              regions[k][0];
            assert_memory_equal(za, lr_image_depth(crop) + y * w,
                                (size_t)w * sizeof(float));
        }
        lr_image_free(crop);
    }
    /* Regions outside the frame are rejected with the field's name. */
    const int bad[][4] = {{0, 0, 38, 23}, {5, 5, 5, 9}, {-1, 0, 3, 3}};
    for (size_t k = 0; k < 3; k++) {
        memcpy(rs.region, bad[k], sizeof rs.region);
        lr_error err;
        assert_int_equal(lr_render(s, &cam, &rs, &crop, NULL, &err),
                         LR_ERR_INVALID);
        assert_string_equal(err.path, "render.region");
    }
    lr_image_free(full);
    lr_scene_free(s);
}

static void count_progress(void *user, uint64_t done, uint64_t total)
{
    uint64_t *last = user;
    assert_true(done <= total);
    assert_true(done > last[0]);
    last[0] = done;
    last[1] = total;
}

/* Cancels the render (user: the flag) once a quarter of the pixels
 * are done. */
static void cancel_at_quarter(void *user, uint64_t done, uint64_t total)
{
    if (4 * done >= total)
        __atomic_store_n((volatile int *)user, 1, __ATOMIC_RELAXED);
}

static void test_progress_and_cancel(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(busy_scene);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    rs.tile_size = 4;
    uint64_t seen[2] = {0, 0};
    rs.progress = count_progress;
    rs.progress_user = seen;
    lr_image *img = NULL;
    assert_int_equal(lr_render(s, &cam, &rs, &img, NULL, NULL), LR_OK);
    assert_int_equal(seen[0], 37 * 23);
    assert_int_equal(seen[1], 37 * 23);
    lr_image_free(img);

    volatile int cancel = 1;
    rs.progress = NULL;
    rs.cancel = &cancel;
    img = (lr_image *)0x1;
    lr_error err;
    lr_render_stats st;
    assert_int_equal(lr_render(s, &cam, &rs, &img, &st, &err),
                     LR_ERR_CANCELLED);
    assert_null(img);
    /* The stats count the pixels rendered (they said the whole frame),
     * as their samples do: none here, a quarter or more below. */
    assert_int_equal(st.pixels, 0);
    assert_int_equal(st.samples, 0);
    cancel = 0;
    rs.progress = cancel_at_quarter;
    rs.progress_user = (void *)&cancel;
    rs.adaptive = 0;
    assert_int_equal(lr_render(s, &cam, &rs, &img, &st, &err),
                     LR_ERR_CANCELLED);
    assert_true(4 * st.pixels >= 37 * 23 && st.pixels < 37 * 23);
    assert_int_equal(st.samples, st.pixels * (uint64_t)rs.spp);
    lr_scene_free(s);
}

static void test_render_rejects_bad_arguments(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json("{}");
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    lr_image *img = NULL;
    lr_error err;
    rs.spp = 0;
    assert_int_equal(lr_render(s, &cam, &rs, &img, NULL, &err), LR_ERR_INVALID);
    assert_string_equal(err.path, "render.spp");
    lr_scene_settings(s, &rs);
    cam.fov = NAN;
    assert_int_equal(lr_render(s, &cam, &rs, &img, NULL, &err), LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.fov");
    assert_null(img);
    lr_scene_free(s);
    /* A real lens's coating and ghosts, checked as every other enum (9
     * rendered, and was written back as "unknown" and false). */
    s = lr_test_load_json(
        "{\"camera\": {\"model\": \"lens\", \"lens\": \"petzval\"}}");
    lr_scene_camera(s, &cam);
    cam.coating = (lr_lens_coating)9;
    assert_int_equal(lr_camera_validate(&cam, &err), LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.coating");
    lr_scene_camera(s, &cam);
    cam.ghosts = (lr_ghosts)9;
    assert_int_equal(lr_render(s, &cam, &rs, &img, NULL, &err), LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.ghosts");
    lr_scene_free(s);
}

/* The packet tracer shades plain lanes (diffuse triangles) with vector
 * code (whitted16.c) and every other lane with the scalar code of
 * whitted.c; the two must agree to the bit.  A scene with both kinds in
 * the same packets:
 * a smooth-shaded and a flat-shaded sphere mesh (plain), a glossy mesh, a
 * mirror sphere and a black mesh (scalar), a point and a directional
 * light and ambient light, through a thin lens; rendered both ways. */
/* Renders the vector-path scene (a mesh ball in four materials, a mirror
 * sphere, a ground) with `ground` as its last objects, through the vector
 * path and through the scalar code only, and compares every byte. */
static void vector_matches_scalar(const char *ground, double min_mean)
{
    char path[512];
    snprintf(path, sizeof path, "%s/vecball.obj", lr_test_tmpdir());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    const int nu = 24, nv = 12;
    for (int j = 0; j <= nv; j++)
        for (int i = 0; i < nu; i++) {
            double th = M_PI * j / nv, ph = 2 * M_PI * i / nu;
            fprintf(f, "v %.9f %.9f %.9f\n", sin(th) * cos(ph), cos(th),
                    sin(th) * sin(ph));
        }
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            int a = j * nu + i + 1, b = j * nu + (i + 1) % nu + 1;
            fprintf(f, "f %d %d %d\nf %d %d %d\n", a, b, b + nu, a, b + nu,
                    a + nu);
        }
    assert_int_equal(fclose(f), 0);
    char json[8192];
    int len = snprintf(
        json, sizeof json,
        "{\"camera\": {\"model\": \"thinlens\", \"position\": [0, 1.5, 6],"
        "  \"look_at\": [0, 0.5, 0], \"fov\": 50, \"aperture_radius\": 0.15,"
        "  \"focus_distance\": 6},"
        " \"render\": {\"width\": 48, \"height\": 36, \"spp\": 32,"
        "  \"max_depth\": 2, \"plan\": false, \"adaptive\": false},"
        " \"background\": [0.1, 0.2, 0.3],"
        " \"materials\": {\"clay\": {\"diffuse\": [0.7, 0.5, 0.3]},"
        "   \"grey\": {\"diffuse\": 0.5},"
        "   \"gloss\": {\"diffuse\": 0.3, \"specular\": 0.4, \"shininess\": "
        "20},"
        "   \"mirror\": {\"diffuse\": 0, \"reflect\": 0.8},"
        "   \"black\": {\"diffuse\": 0}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [3, 5, 4],"
        "   \"intensity\": 40},"
        "  {\"type\": \"directional\", \"direction\": [-1, -2, -0.5],"
        "   \"irradiance\": 0.7},"
        "  {\"type\": \"ambient\", \"radiance\": 0.05}],"
        " \"objects\": ["
        "  {\"type\": \"mesh\", \"file\": \"%s\", \"smooth\": true,"
        "   \"material\": \"clay\", \"transform\": [{\"translate\": [-1.2, 1, "
        "0]}]},"
        "  {\"type\": \"mesh\", \"file\": \"%s\", \"smooth\": true,"
        "   \"material\": \"gloss\", \"transform\": [{\"translate\": [1.2, 1, "
        "-1]}]},"
        "  {\"type\": \"mesh\", \"file\": \"%s\", \"material\": \"black\","
        "   \"transform\": [{\"scale\": 0.4}, {\"translate\": [0, 0.4, 2]}]},"
        "  {\"type\": \"mesh\", \"file\": \"%s\", \"material\": \"clay\","
        "   \"transform\": [{\"scale\": 0.5}, {\"translate\": [0, 0.5, "
        "-1.5]}]},"
        "  {\"type\": \"sphere\", \"center\": [0, 0.6, 0.5], \"radius\": 0.6,"
        "   \"material\": \"mirror\"},"
        "  %s]}",
        path, path, path, path, ground);
    assert_true(len > 0 && (size_t)len < sizeof json);
    lr_image *img[2];
    for (int k = 0; k < 2; k++) {
        lr__whitted_scalar_only = k;
        img[k] = render(json, -1, 0, NULL);
        lr__whitted_scalar_only = 0;
    }
    const float *a = lr_image_rgb(img[0]), *b = lr_image_rgb(img[1]);
    size_t n = 3u * 48u * 36u;
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        if (memcmp(&a[i], &b[i], sizeof(float)) != 0)
            fail_msg("value %zu: vector %.9g, scalar %.9g", i, (double)a[i],
                     (double)b[i]);
        sum += a[i];
    }
    /* Something was lit (a black or empty frame would prove nothing). */
    if (!(sum / (double)n > min_mean))
        fail_msg("mean %g, expected more than %g", sum / (double)n, min_mean);
    lr_image_free(img[0]);
    lr_image_free(img[1]);
}

static void test_vector_shading_matches_scalar(void **state)
{
    (void)state;
    vector_matches_scalar("{\"type\": \"plane\", \"point\": [0, 0, 0], "
                          "\"normal\": [0, 1, 0], \"size\": 20, "
                          "\"material\": \"grey\"}",
                          0.05);
}

/* Infinite planes are traced beside Embree: the vector path must see one
 * in front of a mesh hit (the tilted plane cuts the balls) and across a
 * shadow ray (the upright one stands between the balls and both lights)
 * exactly as the scalar code does. */
static void test_vector_shading_with_infinite_planes(void **state)
{
    (void)state;
    vector_matches_scalar("{\"type\": \"plane\", \"point\": [0, 0, 0], "
                          "\"normal\": [0, 1, 0], \"material\": \"grey\"},"
                          "{\"type\": \"plane\", \"point\": [0, 0.9, 0], "
                          "\"normal\": [0.3, 1, 0.5], \"material\": \"clay\"},"
                          "{\"type\": \"plane\", \"point\": [1.9, 0, 0], "
                          "\"normal\": [1, 0, 0.2], \"material\": \"grey\"}",
                          0.0);
}

/* The packet path through Embree's code for CPUs without AVX-512: that
 * code checks the rays of masked-off lanes too, and aborted the process
 * on the rays the vector path left in the shadow packet's lanes whose
 * camera ray missed (the bench scene crashed on every AVX2 machine).  A
 * mesh on a ground square under the sky, so that packets mix hits and
 * misses (without the ground it did not crash), and 20 samples, so that
 * the second packet has lanes past its end; each ISA's picture must be
 * finite and within 1% of the default's mean (Embree's code for each
 * ISA may round differently). */
static void test_packets_on_every_embree_isa(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_text("isa-tet.obj",
                       "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nv 0 1.5 0\n"
                       "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n",
                       path, sizeof path);
    char json[2048];
    int len = snprintf(
        json, sizeof json,
        "{\"camera\": {\"model\": \"thinlens\", \"position\": [0, 0.8, 4],"
        "  \"look_at\": [0, 0.6, 0], \"fov\": 40, \"aperture_radius\": 0.1,"
        "  \"focus_distance\": 4},"
        " \"render\": {\"width\": 24, \"height\": 16, \"spp\": 20,"
        "  \"plan\": false, \"adaptive\": false},"
        " \"materials\": {\"clay\": {\"diffuse\": [0.7, 0.5, 0.3]}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [2, 4, 3],"
        "   \"intensity\": 30}],"
        " \"objects\": [{\"type\": \"mesh\", \"file\": \"%s\","
        "   \"material\": \"clay\"},"
        "  {\"type\": \"plane\", \"point\": [0, 0, 0], \"normal\": [0, 1, 0],"
        "   \"size\": 20, \"material\": \"clay\"}]}",
        path);
    assert_true(len > 0 && (size_t)len < sizeof json);
    int n_isa;
    const char *const *isa = lr_test_embree_isas(&n_isa);
    double mean[3];
    for (int k = 0; k < n_isa; k++) {
        lr__embree_config = isa[k];
        lr_image *img = render(json, 1, 0, NULL);
        lr__embree_config = NULL;
        mean[k] = lr_test_finite_mean(img, isa[k] ? isa[k] : "default");
        lr_image_free(img);
    }
    /* Lit, and not everywhere (hits and misses in the same packets). */
    lr_test_isa_means_agree(mean, isa, n_isa);
}

static const struct CMUnitTest shade_tests[] = {
    cmocka_unit_test(test_packets_on_every_embree_isa),
    cmocka_unit_test(test_film_add16_matches_add_n),
    cmocka_unit_test(test_vector_shading_matches_scalar),
    cmocka_unit_test(test_vector_shading_with_infinite_planes),
    cmocka_unit_test(test_lambert_point_light),
    cmocka_unit_test(test_shadow_and_ambient),
    cmocka_unit_test(test_directional_light),
    cmocka_unit_test(test_normalised_phong),
    cmocka_unit_test(test_fresnel),
    cmocka_unit_test(test_energy_mirror_and_glass),
    cmocka_unit_test(test_film_drops_nan),
    cmocka_unit_test(test_constant_scene_exact),
    cmocka_unit_test(test_deterministic_across_threads_and_tiles),
    cmocka_unit_test(test_depth_channel),
    cmocka_unit_test(test_progress_and_cancel),
    cmocka_unit_test(test_region_matches_full_frame),
    cmocka_unit_test(test_render_rejects_bad_arguments),
};
LR_TEST_GROUP(shade, shade_tests)
