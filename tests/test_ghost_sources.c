/*
 * test_ghost_sources.c: ghosts of mesh lights and of the environment's
 * sun (lib/integrator/ghost_trace.c), issue 29's "emitters seen directly
 * are sources of ghosts".  test_ghost_render.c checks a sphere light's
 * ghosts against a sequential trace; here the other sources are checked
 * against a sphere: a small square emitter against a sphere of the same
 * power from the same place, and a sun in the environment map against a
 * sphere far out in its direction giving the same irradiance (computed
 * here from the map's texels, not by the library), both through the
 * shipped double Gauss, bare.  Then a sun just outside the frame, what
 * "auto" and false decide, and one-sided mesh emission.
 */
#include "test.h"
#include "camera/camera.h"
#include "integrator/ghost_trace.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The double Gauss, bare, at full aperture, focused far, on a 36 x 36 mm
 * square film; OBJ is the light (a sphere or a plane), emitting "l". */
#define HEAD                                                                \
    "{\"render\": {\"width\": 64, \"height\": 64, \"spp\": 256, \"seed\": " \
    "1, \"adaptive\": false},"                                              \
    " \"camera\": {\"model\": \"lens\", \"lens\": \"double-gauss-50\","     \
    "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"                   \
    "  \"sensor_width_mm\": 36, \"focus_distance\": 1000,"                  \
    "  \"coating\": \"none\", \"ghosts\": true},"
#define SCENE(obj)                                                   \
    HEAD " \"background\": 0,"                                       \
         " \"materials\": {\"l\": {\"emission\": [4e6, 4e6, 4e6]}}," \
         " \"objects\": [" obj "]}"

/* A sphere of radius 0.1 at 100 m, 5 degrees right of the axis; a
 * square of the same area facing the eye from there (side 0.1 sqrt(pi):
 * it sends the lens the same power, to 1e-6). */
#define AT "[8.7488663525924, 0, -100]"
#define SPHERE                                                    \
    "{\"type\": \"sphere\", \"center\": " AT ", \"radius\": 0.1," \
    " \"material\": \"l\"}"
#define SQUARE                                                      \
    "{\"type\": \"plane\", \"point\": " AT ", \"normal\": "         \
    "[-8.7488663525924, 0, 100], \"size\": 0.17724538509055160273," \
    " \"material\": \"l\"}"

/* The ghosts alone: a (ghosts on) less b (off), channel 0. */
typedef struct ghost_img {
    double v[64 * 64];
    double sum, cx, cy, rms; /* on the sensor, mm (test_ghost_render.c's) */
} ghost_img;

static void ghosts_alone(const lr_image *a, const lr_image *b, double side_mm,
                         ghost_img *g)
{
    int W = a->width, H = a->height;
    assert_true(W * H <= 64 * 64);
    double s0 = 0.0, sx = 0.0, sy = 0.0, srr = 0.0;
    for (int py = 0; py < H; py++)
        for (int px = 0; px < W; px++) {
            size_t k = 3 * ((size_t)py * (size_t)W + (size_t)px);
            double v = (double)a->rgb[k] - (double)b->rgb[k];
            double x = (0.5 - (px + 0.5) / W) * side_mm;
            double y = ((py + 0.5) / H - 0.5) * side_mm;
            g->v[py * W + px] = v;
            s0 += v, sx += v * x, sy += v * y, srr += v * (x * x + y * y);
        }
    g->sum = s0, g->cx = sx / s0, g->cy = sy / s0;
    g->rms = sqrt(srr / s0 - g->cx * g->cx - g->cy * g->cy);
}

/* Renders json with sets (sets[0] "camera.ghosts=true"), then with
 * ghosts false, into g; the "on" stats in *st, every pixel finite. */
static void render_ghosts(const char *json, const char **sets, size_t n,
                          lr_render_stats *st, ghost_img *g)
{
    lr_image *a = lr_test_render(json, sets, n, st);
    lr_test_check_finite(a, st, "ghosts on");
    sets[0] = "camera.ghosts=false";
    lr_image *b = lr_test_render(json, sets, n, NULL);
    sets[0] = "camera.ghosts=true";
    ghosts_alone(a, b, 36.0, g);
    lr_image_free(a);
    lr_image_free(b);
}

/* The squared difference of two ghost images over blocks of b x b
 * pixels (the blocks' sums: a ghost's shape at a coarser scale than its
 * noise). */
static double block_d2(const ghost_img *a, const ghost_img *b, int bs)
{
    double d2 = 0.0;
    for (int by = 0; by < 64 / bs; by++)
        for (int bx = 0; bx < 64 / bs; bx++) {
            double d = 0.0;
            for (int y = 0; y < bs; y++)
                for (int x = 0; x < bs; x++) {
                    int k = (by * bs + y) * 64 + bx * bs + x;
                    d += a->v[k] - b->v[k];
                }
            d2 += d * d;
        }
    return d2;
}

/* Fails unless ghost image x agrees with s1 as two renders of the same
 * ghosts with different seeds (s1, s2) do: energy within 2% and that
 * seed-to-seed difference, centroids within 0.5 mm, rms radii within
 * 3%, and the squared difference of bs x bs blocks under twice the
 * seeds', or (the ghosts drawn as meshes, the same for every seed)
 * under 1e-4 of the energy squared: every block within 1% of it. */
static void same_ghosts(const ghost_img *x, const ghost_img *s1,
                        const ghost_img *s2, int bs, const char *what)
{
    double seeds = fabs(s2->sum / s1->sum - 1.0);
    double d_x = block_d2(x, s1, bs), d_s = block_d2(s2, s1, bs);
    print_message("%s: energy %.6g, sphere %.6g (%.4f; seed to seed %.4f); "
                  "centroid (%.3f, %.3f) mm, sphere (%.3f, %.3f); rms %.3f "
                  "mm, sphere %.3f (%.4f); %d-pixel blocks' d2 %.4g, seeds' "
                  "%.4g\n",
                  what, x->sum, s1->sum, x->sum / s1->sum, s2->sum / s1->sum,
                  x->cx, x->cy, s1->cx, s1->cy, x->rms, s1->rms,
                  x->rms / s1->rms, bs, d_x, d_s);
    assert_true(s1->sum > 0.0);
    assert_true(fabs(x->sum / s1->sum - 1.0) < 0.02 + seeds);
    assert_true(hypot(x->cx - s1->cx, x->cy - s1->cy) < 0.5);
    assert_true(fabs(x->rms / s1->rms - 1.0) < 0.03);
    assert_true(d_x < fmax(2.0 * d_s, 1e-4 * s1->sum * s1->sum));
}

/* The sphere of ssets (ssets[1] its seed) at seeds 1 and 2, and the
 * source of json and xsets at seed 3 (with the sphere's own seed the two
 * sources' paths draw the same numbers, and agree far better than noise
 * allows): one ghost light, the same budget (the same power: within its
 * rounding), the same ghosts (same_ghosts), and --stats ghost_flux
 * alike, each over its own main image's estimate; bs: same_ghosts'. */
static void against_sphere(const char **ssets, size_t ns, const char *json,
                           const char **xsets, size_t nx, int bs,
                           const char *what)
{
    lr_render_stats st_s, st_s2, st_x;
    static ghost_img s1, s2, x;
    ssets[1] = "render.seed=1";
    render_ghosts(SCENE(SPHERE), ssets, ns, &st_s, &s1);
    ssets[1] = "render.seed=2";
    render_ghosts(SCENE(SPHERE), ssets, ns, &st_s2, &s2);
    xsets[1] = "render.seed=3";
    render_ghosts(json, xsets, nx, &st_x, &x);
    assert_int_equal(st_x.ghost_lights, 1);
    print_message("%s: ghost paths %llu, sphere %llu; ghost_flux %.6g, "
                  "sphere %.6g\n",
                  what, (unsigned long long)st_x.ghost_paths,
                  (unsigned long long)st_s.ghost_paths, st_x.ghost_flux,
                  st_s.ghost_flux);
    /* The same budget: as many paths (to their rounding), or as meshes
     * (the same cells, but as many directions as each is pixels wide)
     * within 4x. */
    double ratio = (double)st_x.ghost_paths / (double)st_s.ghost_paths;
    assert_true(fabs(ratio - 1.0) < 1e-3 || (ratio > 0.25 && ratio < 4.0));
    same_ghosts(&x, &s1, &s2, bs, what);
    assert_true(fabs(st_x.ghost_flux / st_s.ghost_flux - 1.0) <
                0.02 + fabs(st_s2.ghost_flux / st_s.ghost_flux - 1.0));
}

/* A square emitter and a sphere of equal power from the same place: the
 * same ghosts (the square's main image estimated from its exact solid
 * angle). */
static void test_mesh_ghosts_as_sphere(void **state)
{
    (void)state;
    const char *ssets[] = {"camera.ghosts=true", NULL};
    const char *xsets[] = {"camera.ghosts=true", NULL};
    against_sphere(ssets, 2, SCENE(SQUARE), xsets, 2, 8,
                   "square against sphere");
}

/* An emission texture whose left half is 3 and right half 1 (mean 2,
 * EXR: linear), on the square at half the plain square's emission: the
 * same power, so the same ghosts, and the same budget (the plan
 * estimates from the texels' mean).  Each path must look its radiance up
 * where it meets the square: the texture ignored gives half the ghosts'
 * light, its largest value everywhere 1.5 times. */
static double half_map(int x, int y)
{
    (void)y;
    return x < 8 ? 3.0 : 1.0;
}

#define TEXTURED_SQUARE                                            \
    HEAD " \"background\": 0,"                                     \
         " \"materials\": {\"l\": {\"emission\": [2e6, 2e6, 2e6]," \
         "  \"emission_texture\": \"ghost-half.exr\"}},"           \
         " \"objects\": [" SQUARE "]}"

static void test_textured_mesh_ghosts_as_sphere(void **state)
{
    (void)state;
    lr_test_write_map("ghost-half.exr", half_map, 16, 16);
    const char *ssets[] = {"camera.ghosts=true", NULL};
    const char *xsets[] = {"camera.ghosts=true", NULL};
    against_sphere(ssets, 2, TEXTURED_SQUARE, xsets, 2, 8,
                   "textured square against sphere");
}

/* The sun: one texel of SUN_V on a black 1024 x 512 map, column sun_x,
 * row SUN_Y (0.18 degrees above the horizon): the lookup spreads it
 * over 0.35 degrees each way. */
#define MAP_W 1024
#define MAP_H 512
#define SUN_Y 255
#define SUN_V 3e5
static int sun_x = 15;

static double sun_map(int x, int y)
{
    return x == sun_x && y == SUN_Y ? SUN_V : 0.0;
}

/* The map's sun's irradiance at normal incidence, the integral of its
 * radiance over solid angle: the lookup is bilinear between texels at u
 * = (x + 1/2) / w and v = y / (h - 1) (envmap.h), whose integral over u
 * and v is the trapezoid rule's, each texel weighted by 1 / w and 1 / (h
 * - 1), and dw = 2 pi du pi sin(pi v) dv (sin within 3e-4 of its value
 * at the texel across a lookup's footprint). */
static double sun_irradiance(void)
{
    return SUN_V * (2.0 * M_PI / MAP_W) * (M_PI / (MAP_H - 1)) *
           sin(M_PI * SUN_Y / (MAP_H - 1));
}

/* The direction of map texel (x + 1/2, y) (envmap.h: u = atan2(x, -z) /
 * (2 pi), v = acos(y) / pi). */
static void texel_dir(double x, double y, double d[3])
{
    double phi = 2.0 * M_PI * (x + 0.5) / MAP_W, th = M_PI * y / (MAP_H - 1);
    d[0] = sin(th) * sin(phi), d[1] = cos(th), d[2] = -sin(th) * cos(phi);
}

#define SUN_SCENE                                           \
    HEAD " \"environment\": {\"file\": \"ghost-sun.exr\"}," \
         " \"materials\": {}, \"objects\": []}"

/* The sun's ghosts against a sphere 1000 m out in its direction whose
 * radiance times solid angle is the sun's irradiance (sun_irradiance),
 * with the lookup's rms width (a disc of 5 mrad: the tent of 6.1 mrad
 * each way has 2.5 mrad rms along each axis): the same
 * ghosts (against_sphere; the sun's ghost_flux over the library's own
 * integral of the map over its cone). */
static void test_sun_ghosts_as_sphere(void **state)
{
    (void)state;
    sun_x = 15; /* 5.4 degrees right of the axis */
    lr_test_write_map("ghost-sun.exr", sun_map, MAP_W, MAP_H);
    double d[3];
    texel_dir(sun_x, SUN_Y, d);
    const double R = 5.0, D = 1000.0;
    double sin2 = R * R / (D * D);
    double omega = 2.0 * M_PI * sin2 / (1.0 + sqrt(1.0 - sin2));
    double L = sun_irradiance() / omega;
    char center[128], emission[96];
    snprintf(center, sizeof center, "objects[0].center=[%.15g, %.15g, %.15g]",
             D * d[0], D * d[1], D * d[2]);
    snprintf(emission, sizeof emission,
             "materials.l.emission=[%.15g, %.15g, "
             "%.15g]",
             L, L, L);
    const char *ssets[] = {"camera.ghosts=true", NULL, center, emission,
                           "objects[0].radius=5"};
    const char *sun[] = {"camera.ghosts=true", NULL};
    against_sphere(ssets, 5, SUN_SCENE, sun, 2, 16, "sun against sphere");
}

/* A sun 25.1 degrees right of the axis, outside the frame (19.8
 * degrees to its edge): nothing of its main image in the frame, its ghosts in
 * it, their centroid inside and across from the sun (the ghosts lie on
 * the line from the source through the centre). */
static void test_sun_outside_frame(void **state)
{
    (void)state;
    sun_x = 71;
    lr_test_write_map("ghost-sun.exr", sun_map, MAP_W, MAP_H);
    const char *on[] = {"camera.ghosts=true"};
    const char *off[] = {"camera.ghosts=false"};
    lr_render_stats st;
    lr_image *a = lr_test_render(SUN_SCENE, on, 1, &st);
    lr_image *b = lr_test_render(SUN_SCENE, off, 1, NULL);
    lr_test_check_finite(a, &st, "sun outside the frame");
    ghost_img g;
    ghosts_alone(a, b, 36.0, &g);
    double main = 0.0;
    int lit = 0;
    for (int k = 0; k < 64 * 64; k++) {
        main += b->rgb[3 * k];
        lit += g.v[k] > 0.0;
    }
    print_message("sun outside the frame: main image %.6g, ghosts %.6g over "
                  "%d pixels, centroid (%.3f, %.3f) mm, ghost_flux %.6g\n",
                  main, g.sum, lit, g.cx, g.cy, st.ghost_flux);
    assert_true(main == 0.0);
    assert_int_equal(st.ghost_lights, 1);
    assert_true(g.sum > 0.0 && st.ghost_landed > 0 && lit > 64 * 64 / 8);
    /* The sun to the right (world +x) images to the left of the sensor
     * (x < 0, the lens inverts); its ghosts spread about the line through
     * the centre, their centroid within the frame. */
    assert_true(fabs(g.cx) < 18.0 && fabs(g.cy) < 18.0);
    lr_image_free(a);
    lr_image_free(b);
}

/* Ghosts false, and "auto" for sources below LR__GT_AUTO, give the same
 * bytes and trace no ghost path; a square and a sphere of equal power
 * pass "auto" alike, 3 times above its threshold (the camera's own peak
 * and k, the docs' rule), and fail it alike 3 times below; so does the
 * sun.  A square facing away from the eye emits nothing toward it: no
 * ghost light even with ghosts true. */
static void test_ghost_sources_auto(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(SCENE(SPHERE));
    lr_camera cam;
    lr_scene_camera(s, &cam);
    cam.ghosts = LR_GHOSTS_AUTO;
    lr__cam c;
    lr__cam_init(&c, &cam, 64, 64);
    static lr__ghost_est est[LR__RX_MAX_SURFACES * LR__RX_MAX_SURFACES / 2];
    double peak, k;
    assert_true(c.model->ghost_paths(&c, &peak, &k, est) > 0);
    lr_scene_free(s);
    /* The threshold radiance of the sphere (and so of the square). */
    double omega = M_PI * 1e-6; /* (0.1 / 100)^2 pi, to 1e-6 */
    double L_th = LR__GT_AUTO / (peak * omega * k);
    const char *objs[2] = {SCENE(SPHERE), SCENE(SQUARE)};
    for (int f = -1; f <= 1; f += 2) {
        char em[96];
        snprintf(em, sizeof em, "materials.l.emission=[%.15g, %.15g, %.15g]",
                 L_th * pow(3.0, f), L_th * pow(3.0, f), L_th * pow(3.0, f));
        for (int o = 0; o < 2; o++) {
            const char *on[] = {"camera.ghosts=\"auto\"", em};
            const char *off[] = {"camera.ghosts=false", em};
            lr_render_stats sa, sb;
            lr_image *a = lr_test_render(objs[o], on, 2, &sa);
            lr_image *b = lr_test_render(objs[o], off, 2, &sb);
            assert_int_equal(sa.ghost_lights, f > 0 ? 1 : 0);
            assert_int_equal(sb.ghost_lights, 0);
            assert_int_equal(sb.ghost_paths, 0);
            if (f < 0)
                lr_test_assert_same_bytes(a, b, "auto below the threshold");
            lr_image_free(a);
            lr_image_free(b);
        }
    }
    /* The sun below and above: its irradiance (sun_irradiance) is that
     * of the sphere at SUN_V, times SUN_V / E. */
    sun_x = 15;
    lr_test_write_map("ghost-sun.exr", sun_map, MAP_W, MAP_H);
    double scale = L_th * omega / sun_irradiance();
    for (int f = -1; f <= 1; f += 2) {
        char in[64];
        snprintf(in, sizeof in, "environment.intensity=%.15g",
                 scale * pow(3.0, f));
        const char *on[] = {"camera.ghosts=\"auto\"", in};
        const char *off[] = {"camera.ghosts=false", in};
        lr_render_stats sa, sb;
        lr_image *a = lr_test_render(SUN_SCENE, on, 2, &sa);
        lr_image *b = lr_test_render(SUN_SCENE, off, 2, &sb);
        assert_int_equal(sa.ghost_lights, f > 0 ? 1 : 0);
        assert_int_equal(sb.ghost_lights, 0);
        if (f < 0)
            lr_test_assert_same_bytes(a, b, "the sun, auto below");
        lr_image_free(a);
        lr_image_free(b);
    }
    /* The square turned away. */
    const char *away[] = {"camera.ghosts=true",
                          "objects[0].normal=[8.7488663525924, 0, -100]"};
    lr_render_stats st;
    lr_image_free(lr_test_render(SCENE(SQUARE), away, 2, &st));
    assert_int_equal(st.ghost_lights, 0);
}

/* Determinism with two ghost sources, a square and the sun: the same
 * bytes for one thread and two with 7-pixel tiles, and a region's pixels
 * are the full frame's. */
static void test_ghost_sources_deterministic(void **state)
{
    (void)state;
    sun_x = 15;
    lr_test_write_map("ghost-sun.exr", sun_map, MAP_W, MAP_H);
    const char *env = "environment={\"file\": \"ghost-sun.exr\"}";
    const char *a_sets[] = {env, "render.threads=1"};
    const char *b_sets[] = {env, "render.threads=2", "render.tile_size=7"};
    const char *c_sets[] = {env, "render.threads=2",
                            "render.region=[5,9,40,51]"};
    lr_render_stats st;
    lr_image *a = lr_test_render(SCENE(SQUARE), a_sets, 2, &st);
    lr_image *b = lr_test_render(SCENE(SQUARE), b_sets, 3, NULL);
    lr_image *c = lr_test_render(SCENE(SQUARE), c_sets, 3, NULL);
    assert_int_equal(st.ghost_lights, 2);
    lr_test_assert_same_bytes(a, b, "1 thread against 2 with 7-pixel tiles");
    lr_test_assert_region_is_frame(a, c, 5, 9, "the ghosts' region");
    lr_image_free(a);
    lr_image_free(b);
    lr_image_free(c);
}

static const struct CMUnitTest ghost_sources_tests[] = {
    cmocka_unit_test(test_mesh_ghosts_as_sphere),
    cmocka_unit_test(test_textured_mesh_ghosts_as_sphere),
    cmocka_unit_test(test_sun_ghosts_as_sphere),
    cmocka_unit_test(test_sun_outside_frame),
    cmocka_unit_test(test_ghost_sources_auto),
    cmocka_unit_test(test_ghost_sources_deterministic),
};

LR_TEST_GROUP(ghost_sources, ghost_sources_tests)
