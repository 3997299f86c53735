/*
 * test_light_mis.c: the light side and the camera joined by multiple
 * importance sampling (light_trace.h, integrator.h's lr__lt_rho).  Two
 * lights a little out of focus and a few pixels wide, whose strategies'
 * density ratio is about 4 (the camera's weight about 0.18), and one far
 * out of focus and sub-pixel, past the cutoff (the camera's weight 0).
 * Against independent truth: each light's energy on the film in closed
 * form (film_integral.h), with every block traced by both sides, with
 * dark blocks where the light side must keep everything, and over a lit
 * background with adaptive sampling, whose pixels must not stop before
 * they have seen the camera's share.
 */
#include "test.h"

#include "camera/camera.h"
#include "film_integral.h"
#include "render/plan.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Lights 0 and 1 mix, light 2 does not; the %s: top-level members
 * (or none), more objects (or none). */
static const char *mis_scene_fmt =
    "{\"render\": {\"width\": 96, \"height\": 64, \"seed\": 9}%s,"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
    "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.6,"
    "  \"focus_distance\": 10},"
    " \"materials\": {\"a\": {\"emission\": [300, 200, 100]},"
    "   \"b\": {\"emission\": [60, 90, 400]},"
    "   \"g\": {\"diffuse\": [0, 0.8, 0]}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": [1, 1, 1]}],"
    " \"objects\": ["
    "  {\"type\": \"sphere\", \"center\": [-10, 4, -30], \"radius\": 1.0, "
    "\"material\": \"a\"},"
    "  {\"type\": \"sphere\", \"center\": [2, -5, -40], \"radius\": 1.2, "
    "\"material\": \"b\"},"
    "  {\"type\": \"sphere\", \"center\": [14, 6, -50], \"radius\": 0.25, "
    "\"material\": \"a\"}%s]}";

static const double mis_c[3][3] = {{-10, 4, -30}, {2, -5, -40}, {14, 6, -50}};
static const double mis_r[3] = {1.0, 1.2, 0.25};
static const double mis_L[3] = {300, 60, 300}; /* red */
static const int mis_box[3][4] = {
    {0, 0, 44, 32}, {30, 30, 72, 64}, {60, 0, 96, 32}};

/* A green ball beside light 0, at its depth (mis_scene's objects). */
static const char *green_ball =
    ", {\"type\": \"sphere\", \"center\": [-2, 4, -30], \"radius\": 1.0, "
    "\"material\": \"g\"}";

static void mis_scene(char *buf, size_t n, const char *top, const char *objects)
{
    snprintf(buf, n, mis_scene_fmt, top, objects);
}

static double box_red(const lr_image *img, const int *b)
{
    double s = 0.0;
    for (int y = b[1]; y < b[3]; y++)
        for (int x = b[0]; x < b[2]; x++)
            s += img->rgb[3 * ((size_t)y * img->width + x)];
    return s;
}

/* Light k's closed-form film integral at radiance L (fpx for 64 rows
 * and a 40-degree field), through a lens at the eye of radius R (a
 * square of half side R when square). */
static double closed_form_of(int k, double L, double R, int square)
{
    double fpx = 0.5 * 64 / tan(20.0 * M_PI / 180.0);
    return film_integral_of(v3(0, 0, 10), v3(0, 0, -1), R, square,
                            v3(mis_c[k][0], mis_c[k][1], mis_c[k][2]), mis_r[k],
                            L, fpx);
}

static double closed_form(int k, double L)
{
    return closed_form_of(k, L, 0.6, 0);
}

/* Each light k < n's red sum over its box within tol of want[k]. */
static void boxes_match(const lr_image *img, const double *want, int n,
                        double tol, const char *what)
{
    for (int k = 0; k < n; k++) {
        double got = box_red(img, mis_box[k]);
        print_message("%s light %d: %.6g, closed form %.6g (%.4f)\n", what, k,
                      got, want[k], got / want[k]);
        if (!(fabs(got / want[k] - 1.0) < tol))
            fail_msg("%s light %d: its box holds %.6g, the closed form %.6g",
                     what, k, got, want[k]);
    }
}

/* The plan gives lights 0 and 1 a mix (the camera's largest weight
 * between 0.1 and 0.33: the ratio rho at least the pick rule's 2 and
 * about 4 here), light 2 none; the view hands the camera the same
 * coefficients. */
static void test_mis_lights_mix(void **state)
{
    (void)state;
    char json[2048];
    mis_scene(json, sizeof json, "", "");
    lr__cam c;
    lr__plan p;
    lr_scene *s = lr_test_plan(json, NULL, 0, &c, &p, NULL);
    assert_non_null(p.lt);
    assert_int_equal(p.lt->n, 3);
    for (int k = 0; k < 3; k++) {
        const lr__lt_light *l = &p.lt->lights[k];
        double share = lr__lt_cam_share_max(&c, l->mis);
        print_message("light %d: kappa %.4g, camera's largest weight %.4f\n",
                      l->geom, l->mis, share);
        assert_true(p.lt->view.mis[l->geom] == l->mis);
        if (l->geom < 2)
            assert_true(share > 0.1 && share < 1.0 / 3.0);
        else
            assert_true(l->mis == 0.0 && share == 0.0);
    }
    lr__plan_free(&p);
    lr_scene_free(s);

    /* A real lens's camera samples carry weights (no density in closed
     * form): its lights keep the split, the same lights as above seen
     * through the double Gauss at f/2. */
    const char *lens_sets[] = {
        "camera.model=lens", "camera.lens=double-gauss-50",
        "camera.sensor_width_mm=36", "camera.focus_distance=0.3"};
    s = lr_test_plan(json, lens_sets, 4, &c, &p, NULL);
    assert_non_null(p.lt);
    assert_int_equal(p.lt->n, 3);
    for (int k = 0; k < p.lt->n; k++) {
        print_message("double Gauss: light %d traced from its side\n",
                      p.lt->lights[k].geom);
        assert_true(p.lt->lights[k].mis == 0.0);
    }
    lr__plan_free(&p);
    lr_scene_free(s);
}

/* The camera side's weight takes a camera sample's density per unit
 * solid angle to be fpx^2 / cos^3 (integrator.h's lr__lt_rho): every
 * model with a light side whose samples carry no weights must give
 * exactly that importance from its `film` (camera.h), wherever on the
 * lens the ray starts. */
static void test_mis_importance_is_density(void **state)
{
    (void)state;
    char json[2048];
    mis_scene(json, sizeof json, "", "");
    const char *models[][4] = {
        {"camera.model=pinhole"},
        {"camera.model=thinlens"},
        {"camera.model=bracket", "camera.aperture=1", "camera.focal_length=9",
         "camera.image_plane_distance=1"},
    };
    for (int m = 0; m < 3; m++) {
        size_t n = 0;
        while (n < 4 && models[m][n] != NULL)
            n++;
        lr_scene *s = lr_test_load(json, models[m], n);
        lr_camera cam;
        lr_scene_camera(s, &cam);
        lr_scene_free(s);
        lr__cam c;
        lr__cam_init(&c, &cam, 96, 64);
        assert_false(c.weighted);
        assert_non_null(c.model->film);
        double fpx = 0.5 * c.height / c.half_h;
        for (int i = 0; i < 50; i++) {
            double u[2] = {(i % 7 + 0.5) / 7.0, (i % 5 + 0.5) / 5.0};
            double ox, oy, fx, fy;
            c.model->lens_point(&c, u, &ox, &oy);
            lr__v3 d = v3_norm(
                v3_add(c.forward, v3_add(v3_scale(c.right, 0.05 * (i - 25)),
                                         v3_scale(c.up, 0.03 * (i % 11 - 5)))));
            double W = c.model->film(&c, ox, oy, d, &fx, &fy);
            double cz = v3_dot(d, c.forward);
            double want = fpx * fpx / (cz * cz * cz);
            if (!(fabs(W / want - 1.0) < 1e-12))
                fail_msg("%s: importance %.15g, fpx^2 / cos^3 %.15g",
                         models[m][0], W, want);
        }
    }
}

/* Every block traced by both sides (render.plan off: no dark block): the
 * camera's share and the light side's add up to each light's closed
 * form, within 1.5% (the camera's share, about 18% of a light, is found
 * by about a tenth of its samples: about 0.35% noise at 256 spp), for
 * both integrators, colours that focus apart (rgb and spectral: the
 * weight is the same for every colour) and the bracket (its rays start
 * on the image plane, past their lens point).  Without the camera's
 * weight a light would lose its share (-18%); without the light side's
 * it would gain it. */
static void test_mis_closed_form(void **state)
{
    (void)state;
    char json[2048];
    mis_scene(json, sizeof json, "", "");
    static const struct {
        const char *what;
        const char *sets[4];
        double R;
        int square;
    } cases[] = {
        {"path", {"render.integrator=path"}, 0.6, 0},
        {"whitted", {"render.integrator=whitted"}, 0.6, 0},
        {"rgb",
         {"camera.focal_length_mm=50", "camera.chromatic.mode=rgb",
          "camera.chromatic.amplify=2"},
         0.6,
         0},
        {"spectral",
         {"camera.focal_length_mm=100", "camera.chromatic.mode=spectral",
          "camera.chromatic.amplify=1"},
         0.6,
         0},
        /* The bracket's rays of one square offset cross at e + (1 + di /
         * f) off: a square lens of half side 0.5 (1 + 1/9) at the eye. */
        {"bracket",
         {"camera.model=bracket", "camera.aperture=1", "camera.focal_length=9",
          "camera.image_plane_distance=1"},
         0.5 * (1.0 + 1.0 / 9.0),
         1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *sets[7] = {"render.spp=256", "render.plan=false",
                               "render.adaptive=false"};
        size_t n = 3;
        for (int j = 0; j < 4 && cases[i].sets[j] != NULL; j++)
            sets[n++] = cases[i].sets[j];
        lr_render_stats st;
        lr_image *img = lr_test_render(json, sets, n, &st);
        assert_int_equal(st.light_lights, 3);
        double want[3];
        for (int k = 0; k < 3; k++)
            want[k] = closed_form_of(k, mis_L[k], cases[i].R, cases[i].square);
        boxes_match(img, want, 3, 0.015, cases[i].what);
        lr_test_check_finite(img, &st, cases[i].what);
        lr_image_free(img);
    }
}

/* A triangle light two units wide at depth 50, a few pixels across and
 * about twice that blurred, mixes too (its weights from the sphere
 * around it): its energy within 1.5% of the closed form with every
 * block traced by both sides. */
static void test_mis_mesh_closed_form(void **state)
{
    (void)state;
    const char *json =
        "{\"render\": {\"width\": 96, \"height\": 64, \"seed\": 9},"
        " \"camera\": {\"model\": \"thinlens\", \"position\": [0, 0, 10],"
        "  \"look_at\": [0, 0, 0], \"fov\": 40, \"aperture_radius\": 0.6,"
        "  \"focus_distance\": 10},"
        " \"materials\": {\"a\": {\"emission\": [300, 200, 100]}},"
        " \"objects\": [{\"type\": \"triangle\", \"vertices\": [[2, -5, -40],"
        "   [4, -5, -40], [3, -3, -40]], \"material\": \"a\"}]}";
    lr__cam c;
    lr__plan p;
    lr_scene *s = lr_test_plan(json, NULL, 0, &c, &p, NULL);
    assert_non_null(p.lt);
    assert_int_equal(p.lt->n, 1);
    double share = lr__lt_cam_share_max(&c, p.lt->lights[0].mis);
    print_message("triangle: camera's largest weight %.4f\n", share);
    assert_true(share > 0.05);
    lr__plan_free(&p);
    lr_scene_free(s);
    const char *sets[] = {"render.spp=256", "render.plan=false",
                          "render.adaptive=false"};
    lr_image *img = lr_test_render(json, sets, 3, NULL);
    double fpx = 0.5 * 64 / tan(20.0 * M_PI / 180.0);
    double want = tri_film_integral(0.6, v3(2, -5, -40), v3(4, -5, -40),
                                    v3(3, -3, -40), 300, fpx);
    double got = 0.0;
    for (size_t i = 0; i < (size_t)img->width * img->height; i++)
        got += img->rgb[3 * i];
    print_message("triangle: %.6g, closed form %.6g (%.4f)\n", got, want,
                  got / want);
    assert_true(fabs(got / want - 1.0) < 0.015);
    lr_image_free(img);
}

/* A green ball beside light 0 (its red channel untouched: no red in its
 * colour, no red ambient off it) makes the blocks its lens rays reach
 * lit, and light 0's disc then straddles dark and lit blocks: in the
 * dark ones the camera traces nothing and the light side keeps all its
 * light, in the lit ones they share it.  Each light's red within 1.2%
 * of the closed form; light 1's blocks are all dark (the light side's
 * weight there is 1, or it would lose 18%). */
static void test_mis_dark_blocks(void **state)
{
    (void)state;
    char json[2048];
    mis_scene(json, sizeof json, "", green_ball);
    const char *sets[] = {"render.spp=256", "render.adaptive=false"};
    /* The plan: light 0's box holds both kinds of block. */
    lr__cam c;
    lr__plan p;
    lr_scene *s = lr_test_plan(json, sets, 2, &c, &p, NULL);
    assert_non_null(p.lt);
    assert_non_null(p.lt->dark);
    int dark = 0, lit = 0;
    for (int y = mis_box[0][1]; y < mis_box[0][3]; y += LR__PLAN_BLOCK)
        for (int x = mis_box[0][0]; x < mis_box[0][2]; x += LR__PLAN_BLOCK)
            if (lr__plan_at(&p, x, y)->dark)
                dark++;
            else
                lit++;
    print_message("light 0's blocks: %d dark, %d lit\n", dark, lit);
    assert_true(dark > 0 && lit > 0);
    lr__plan_free(&p);
    lr_scene_free(s);

    lr_render_stats st;
    lr_image *img = lr_test_render(json, sets, 2, &st);
    double want[2] = {closed_form(0, mis_L[0]), closed_form(1, mis_L[1])};
    boxes_match(img, want, 2, 0.012, "dark and lit blocks");
    lr_test_check_finite(img, &st, "mis dark");
    lr_image_free(img);
}

/* A grey background (every block lit) and the defaults, adaptive
 * sampling included, at 64 spp: a pixel that saw none of a light's
 * camera share in its pilot must not stop there (its neighbours' pilots
 * keep it going here; plan.c's rare-light bound, which counts the
 * camera's largest weight, is the guarantee).  Each box is the light's
 * closed form plus the background where the light does not cover it,
 * (box pixels - the light's film integral at radiance 1) times the
 * background: within 1.5%. */
static void test_mis_adaptive(void **state)
{
    (void)state;
    char json[2048];
    mis_scene(json, sizeof json, ", \"background\": [0.05, 0.05, 0.05]", "");
    const char *sets[] = {"render.spp=64"};
    lr_render_stats st;
    lr_image *img = lr_test_render(json, sets, 1, &st);
    double want[3];
    for (int k = 0; k < 3; k++) {
        const int *b = mis_box[k];
        double pix = (double)(b[2] - b[0]) * (b[3] - b[1]);
        want[k] = closed_form(k, mis_L[k]) + 0.05 * (pix - closed_form(k, 1.0));
    }
    boxes_match(img, want, 3, 0.015, "adaptive, lit background");
    assert_true(st.samples < st.full_samples);
    lr_image_free(img);
}

/* The weights keep determinism: with dark and lit blocks (the green
 * ball), one thread and two with 7-pixel tiles give the same bytes, and
 * a region's pixels (its edges off the blocks) are the full frame's. */
static void test_mis_deterministic(void **state)
{
    (void)state;
    char json[2048];
    mis_scene(json, sizeof json, "", green_ball);
    const char *a_sets[] = {"render.spp=32", "render.threads=1"};
    const char *b_sets[] = {"render.spp=32", "render.threads=2",
                            "render.tile_size=7"};
    const char *c_sets[] = {"render.spp=32", "render.threads=2",
                            "render.region=[17,9,80,51]"};
    lr_image *a = lr_test_render(json, a_sets, 2, NULL);
    lr_image *b = lr_test_render(json, b_sets, 3, NULL);
    lr_image *c = lr_test_render(json, c_sets, 3, NULL);
    lr_test_assert_same_bytes(a, b, "1 thread against 2 with 7-pixel tiles");
    lr_test_assert_region_is_frame(a, c, 17, 9, "region");
    lr_image_free(a);
    lr_image_free(b);
    lr_image_free(c);
}

/* A cancel is heeded while the light side is planned, between lights:
 * a scene of many small lights through a real lens spent seconds there
 * (each light's footprint), past lensrayd's DELETE, time limit and
 * shutdown (an independent check: a 2-s limit answered after 15 s).
 * With the flag already set the render stops before the plan has taken
 * a light: its stats count none (they counted every one). */
static void test_cancel_while_planning(void **state)
{
    (void)state;
    char json[16384];
    int k = snprintf(json, sizeof json,
                     "{\"camera\": {\"model\": \"lens\", \"lens\": "
                     "\"double-gauss-50\", \"position\": [0, 0, 0],"
                     " \"look_at\": [0, 0, -1], \"focus_distance\": 0.5},"
                     " \"render\": {\"width\": 32, \"height\": 24, "
                     "\"spp\": 1},"
                     " \"background\": 0,"
                     " \"materials\": {\"l\": {\"emission\": 50}},"
                     " \"objects\": [");
    for (int i = 0; i < 40; i++)
        k += snprintf(json + k, sizeof json - (size_t)k,
                      "%s{\"type\": \"sphere\", \"center\": [%g, %g, -20],"
                      " \"radius\": 0.05, \"material\": \"l\"}",
                      i ? ", " : "", -4.0 + 0.2 * i, 0.1 * (i % 7) - 0.3);
    snprintf(json + k, sizeof json - (size_t)k, "]}");
    lr_scene *s = lr_test_load_json(json);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    lr_render_stats st;
    lr_image *img = NULL;
    assert_int_equal(lr_render(s, &cam, &rs, &img, &st, NULL), LR_OK);
    assert_true(st.light_lights >= 20);
    lr_image_free(img);
    volatile int cancel = 1;
    rs.cancel = &cancel;
    lr_error err;
    assert_int_equal(lr_render(s, &cam, &rs, &img, &st, &err),
                     LR_ERR_CANCELLED);
    assert_null(img);
    assert_int_equal(st.light_lights, 0);
    assert_int_equal(st.rays, 0);
    lr_scene_free(s);
}

static const struct CMUnitTest light_mis_tests[] = {
    cmocka_unit_test(test_mis_lights_mix),
    cmocka_unit_test(test_mis_importance_is_density),
    cmocka_unit_test(test_mis_closed_form),
    cmocka_unit_test(test_mis_mesh_closed_form),
    cmocka_unit_test(test_mis_dark_blocks),
    cmocka_unit_test(test_mis_adaptive),
    cmocka_unit_test(test_mis_deterministic),
    cmocka_unit_test(test_cancel_while_planning),
};
LR_TEST_GROUP(light_mis, light_mis_tests)
