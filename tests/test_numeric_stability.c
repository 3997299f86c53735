/*
 * test_numeric_stability.c: ray-surface numerics where floating point is
 * hard: a scene offset by 1e5 and 1e7 against the same scene at the origin,
 * grazing rays, rays starting on a surface, total internal reflection, a
 * stack of glass that splits every ray (the work stays bounded), zero-area,
 * sliver and duplicate-vertex triangles, huge and tiny spheres, coincident
 * surfaces.  Each render is checked for finite pixels and depths and for no
 * NaN sample dropped (lr_test_render_json), and where the picture is known,
 * for that picture.  Tests that guard a fixed bug say so in their comment
 * ("Fixed bug, guarded here") and fail if it comes back.
 */
#include "test.h"
#include "accel/trace.h"
#include "integrator/integrator.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The busy scene, scaled by s and moved by (D, D, D), camera included.
 * Light intensity scales with s^2 so irradiance stays the same: the
 * picture is the same at every scale and offset up to rounding. */
static void offset_scene(char *out, size_t cap, double D, double s)
{
#define P3(x, y, z) D + (x)*s, D + (y)*s, D + (z)*s
    snprintf(
        out, cap,
        "{\"camera\": {\"position\": [%.17g, %.17g, %.17g],"
        "  \"look_at\": [%.17g, %.17g, %.17g]},"
        " \"render\": {\"width\": 64, \"height\": 40, \"spp\": 4,"
        "  \"max_depth\": 3},"
        " \"background\": 0.2,"
        " \"materials\": {\"red\": {\"diffuse\": [0.7, 0.1, 0.1],"
        "   \"specular\": 0.3, \"shininess\": 30},"
        "  \"mirror\": {\"reflect\": 0.8, \"diffuse\": 0.1},"
        "  \"floor\": {\"diffuse\": 0.6}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [%.17g, %.17g, "
        "%.17g],"
        "   \"intensity\": %.17g},"
        "  {\"type\": \"directional\", \"direction\": [-1, -2, -1],"
        "   \"irradiance\": 0.5},"
        "  {\"type\": \"ambient\", \"radiance\": 0.05}],"
        " \"objects\": ["
        "  {\"type\": \"plane\", \"point\": [%.17g, %.17g, %.17g],"
        "   \"normal\": [0, 1, 0], \"size\": %.17g, \"material\": \"floor\"},"
        "  {\"type\": \"sphere\", \"center\": [%.17g, %.17g, %.17g],"
        "   \"radius\": %.17g, \"material\": \"red\"},"
        "  {\"type\": \"sphere\", \"center\": [%.17g, %.17g, %.17g],"
        "   \"radius\": %.17g, \"material\": \"mirror\"},"
        "  {\"type\": \"triangle\", \"vertices\": [[%.17g, %.17g, %.17g],"
        "   [%.17g, %.17g, %.17g], [%.17g, %.17g, %.17g]]}]}",
        P3(0, 2, 8), P3(0, 0.8, 0), P3(3, 6, 4), 60 * s * s, P3(0, 0, 0),
        20 * s, P3(-1.2, 1, 0), s, P3(1.3, 0.7, 0.5), 0.7 * s, P3(0.2, 0, -2),
        P3(2, 0, -2), P3(1, 2, -2.5));
#undef P3
}

/* Renders the scene at (D, s) and at (0, s) and compares.  The tolerance:
 * at most 2% of the pixels may differ by more than 5% (silhouette pixels
 * whose geometry moved by float rounding, which is ulp(D) / s of the
 * object size: 8e-5 for 1e5 at s = 100, 1e-4 for 1e7 at s = 1e4), and the
 * mean relative difference must stay under 1%.  Acne (self-shadowing),
 * light leaking under objects or lost hits would each change far more. */
static lr_test_diff offset_diff(double D, double s)
{
    char json[4096];
    offset_scene(json, sizeof json, 0, s);
    lr_image *ref = lr_test_render_json(json, "offset reference");
    offset_scene(json, sizeof json, D, s);
    lr_image *far = lr_test_render_json(json, "offset scene");
    lr_test_diff d = lr_test_compare(ref, far);
    lr_image_free(ref);
    lr_image_free(far);
    return d;
}

static void test_offset_1e5(void **state)
{
    (void)state;
    lr_test_diff d = offset_diff(1e5, 100);
    print_message("offset 1e5: %.2f%% of pixels off by > 5%%, mean relative "
                  "difference %.3g%%, max %.3g\n",
                  100 * d.bad_frac, 100 * d.mean_rel, d.max_abs);
    if (!(d.bad_frac <= 0.02 && d.mean_rel <= 0.01))
        fail_msg("offset 1e5 (scale 100): %.2f%% of pixels off by > 5%%, "
                 "mean relative difference %.3g%%, max %.3g",
                 100 * d.bad_frac, 100 * d.mean_rel, d.max_abs);
}

static void test_offset_1e7(void **state)
{
    (void)state;
    lr_test_diff d = offset_diff(1e7, 1e4);
    print_message("offset 1e7: %.2f%% of pixels off by > 5%%, mean relative "
                  "difference %.3g%%, max %.3g\n",
                  100 * d.bad_frac, 100 * d.mean_rel, d.max_abs);
    if (!(d.bad_frac <= 0.02 && d.mean_rel <= 0.01))
        fail_msg("offset 1e7 (scale 1e4): %.2f%% of pixels off by > 5%%, "
                 "mean relative difference %.3g%%, max %.3g",
                 100 * d.bad_frac, 100 * d.mean_rel, d.max_abs);
}

/* The busy scene a millionth of its size, against itself at size 1,
 * both integrators: the same picture up to rounding.  A new ray's origin
 * was pushed at least 7.6e-6 off its surface whatever the scene's size
 * (eps's floor of 1): at 1e-6 the whole scene, so shadows and the lit
 * sides of spheres were lost (5.4% of pixels off by 5%, up to 0.36,
 * whitted). */
static void test_scale_1e_minus_6(void **state)
{
    (void)state;
    static const char *const sets[][1] = {{"render.integrator=\"whitted\""},
                                          {"render.integrator=\"path\""}};
    for (int k = 0; k < 2; k++) {
        char json[4096];
        offset_scene(json, sizeof json, 0, 1);
        lr_image *ref = lr_test_render(json, sets[k], 1, NULL);
        offset_scene(json, sizeof json, 0, 1e-6);
        lr_image *tiny = lr_test_render(json, sets[k], 1, NULL);
        lr_test_diff d = lr_test_compare(ref, tiny);
        print_message("%s, scale 1e-6: %.2f%% of pixels off by > 5%%, mean "
                      "relative difference %.3g%%, max %.3g\n",
                      sets[k][0], 100 * d.bad_frac, 100 * d.mean_rel,
                      d.max_abs);
        if (!(d.bad_frac <= 0.02 && d.mean_rel <= 0.01))
            fail_msg("%s, scale 1e-6: %.2f%% of pixels off by > 5%%",
                     sets[k][0], 100 * d.bad_frac);
        lr_image_free(ref);
        lr_image_free(tiny);
    }
}

/* Rays that graze a plane and a sphere, and rays parallel to a plane. */
static void test_grazing_rays(void **state)
{
    (void)state;
    /* An eye 1e-6 above an infinite floor, looking along it: the lower
     * half of the frame sees the floor at grazing angles, the middle row
     * runs parallel to it. */
    const double heights[] = {1e-6, 0.0};
    for (size_t i = 0; i < 2; i++) {
        char json[1024];
        snprintf(
            json, sizeof json,
            "{\"camera\": {\"position\": [0, %g, 0],"
            "  \"look_at\": [0, %g, -1]},"
            " \"render\": {\"width\": 9, \"height\": 9, \"spp\": 2,"
            "  \"depth\": true, \"sampler\": \"grid\"},"
            " \"background\": 0.5,"
            " \"materials\": {\"m\": {\"diffuse\": 0.5, \"reflect\": 0.3}},"
            " \"lights\": [{\"type\": \"point\", \"position\": [0, 3, -4],"
            "   \"intensity\": 20}],"
            " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0],"
            "   \"material\": \"m\"}]}",
            heights[i], heights[i]);
        lr_image_free(lr_test_render_json(json, "grazing plane"));
    }
    /* Tangent rays of a sphere, through the tracer directly: hits just
     * inside the silhouette have finite t and unit normals; just outside,
     * none. */
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"sphere\","
        " \"center\": [1, 0, -5], \"radius\": 1}]}");
    /* The ray at x = e passes 1 - e from the centre: inside for e > 0. */
    const double offs[] = {-1e-3, -1e-5, -1e-7, 0, 1e-7, 1e-5, 1e-3};
    for (size_t i = 0; i < 7; i++) {
        lr__hit h;
        int hit = lr__trace(s, v3(offs[i], 0, 0), v3(0, 0, -1), INFINITY, &h);
        if (offs[i] < -1e-4)
            assert_false(hit);
        if (offs[i] > 1e-4)
            assert_true(hit);
        if (hit) {
            assert_true(isfinite(h.t) && h.t > 0);
            assert_true(fabs(v3_len(h.ng) - 1) < 1e-9);
            assert_true(fabs(v3_len(h.ns) - 1) < 1e-9);
            assert_true(isfinite(h.eps) && h.eps > 0);
        }
    }
    lr_scene_free(s);
    /* And rendered: a camera whose centre column grazes a glass sphere. */
    lr_image_free(lr_test_render_json(
        "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -1]},"
        " \"render\": {\"width\": 9, \"height\": 9, \"spp\": 4},"
        " \"background\": 0.5,"
        " \"materials\": {\"g\": {\"transmit\": 1, \"ior\": 1.5}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 3, 0],"
        "   \"intensity\": 20}],"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [1, 0, -5],"
        "   \"radius\": 1, \"material\": \"g\"}]}",
        "grazing glass sphere"));
}

/* A camera exactly on a surface: on a floor plane, on a sphere looking
 * in, and on a triangle. */
static void test_rays_starting_on_surfaces(void **state)
{
    (void)state;
    const char *cams[] = {
        "\"position\": [0, 0, 0], \"look_at\": [0, 0.2, -1]",
        "\"position\": [0, 0, -4], \"look_at\": [0, 0, -5]",
        "\"position\": [0.25, 0.25, -1], \"look_at\": [0, 0, -2]"};
    for (size_t i = 0; i < 3; i++) {
        char json[2048];
        snprintf(
            json, sizeof json,
            "{\"camera\": {%s, \"model\": \"thinlens\","
            "  \"aperture_radius\": 0.01, \"focus_distance\": 2},"
            " \"render\": {\"width\": 8, \"height\": 6, \"spp\": 4,"
            "  \"depth\": true},"
            " \"background\": 0.5,"
            " \"materials\": {\"g\": {\"transmit\": 0.7, \"reflect\": 0.2,"
            "   \"diffuse\": 0.1}},"
            " \"lights\": [{\"type\": \"point\", \"position\": [0, 3, 0],"
            "   \"intensity\": 20}, {\"type\": \"ambient\", \"radiance\": "
            "0.1}],"
            " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0],"
            "   \"material\": \"g\"},"
            "  {\"type\": \"sphere\", \"center\": [0, 0, -5], \"radius\": 1,"
            "   \"material\": \"g\"},"
            "  {\"type\": \"triangle\", \"vertices\": [[0, 0, -1], [1, 0, -1],"
            "   [0, 1, -1]], \"material\": \"g\"}]}",
            cams[i]);
        lr_image_free(lr_test_render_json(json, cams[i]));
    }
}

/* Total internal reflection: the Fresnel term is exactly 1 beyond the
 * critical angle and at grazing incidence, and never divides by zero; a
 * camera inside dense glass (ior 10, most rays reflect totally) sees a
 * finite picture no brighter than the background, since with no lights
 * and no diffuse part the reflected and refracted weights sum to at most
 * 1. */
static void test_total_internal_reflection(void **state)
{
    (void)state;
    /* Leaving glass of index 1.5: critical angle asin(1/1.5). */
    double crit = sqrt(1.0 - 1.0 / (1.5 * 1.5));
    assert_true(lr__fresnel_dielectric(crit * 0.999, 1.5) == 1.0);
    assert_true(lr__fresnel_dielectric(0.0, 1.5) == 1.0);
    assert_true(lr__fresnel_dielectric(0.0, 1.0) == 1.0);
    assert_true(lr__fresnel_dielectric(0.0, 1.0 / 1.5) == 1.0);
    assert_true(lr__fresnel_dielectric(1.0, 1.0) == 0.0);
    const double etas[] = {1e-3, 0.1, 1.0 / 1.5, 1.0, 1.5, 10.0};
    for (size_t i = 0; i < 6; i++)
        for (int k = 0; k <= 100; k++) {
            double F = lr__fresnel_dielectric(k / 100.0, etas[i]);
            if (!(F >= 0.0 && F <= 1.0))
                fail_msg("Fresnel(%g, %g) = %g", k / 100.0, etas[i], F);
        }
    lr_image *img = lr_test_render_json(
        "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0.3, 0.1, -1],"
        "  \"fov\": 120},"
        " \"render\": {\"width\": 12, \"height\": 8, \"spp\": 2,"
        "  \"max_depth\": 12},"
        " \"background\": 1,"
        " \"materials\": {\"g\": {\"transmit\": 1, \"ior\": 10}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],"
        "   \"radius\": 2, \"material\": \"g\"},"
        "  {\"type\": \"sphere\", \"center\": [0.5, 0, -0.5],"
        "   \"radius\": 0.3, \"material\": \"g\"}]}",
        "inside ior 10 glass");
    const float *p = lr_image_rgb(img);
    for (size_t k = 0; k < lr_test_n_values(img); k++)
        if (!(p[k] >= 0 && p[k] <= 1.0f + 1e-5f))
            fail_msg("inside glass: value %zu is %.9g, outside [0, 1]", k,
                     (double)p[k]);
    lr_image_free(img);
}

/* The work of one camera sample should stay bounded as bounces are
 * allowed: a stack of parallel glass planes splits every ray into a
 * reflected and a refracted one at each surface.
 *
 * Tracing both branches down to max_depth whatever their weight made the
 * rays of one sample grow as ~1.62^depth here (1217 at depth 12, 392833
 * at depth 24; ~1e13 at the allowed maximum of 64), so one pixel could
 * never finish.  lib/integrator/whitted.c now drops branches whose weight from the
 * camera falls below 1e-4. */
static void test_branching_bounded(void **state)
{
    (void)state;
    const char *json =
        "{\"camera\": {\"position\": [0, 0, 0], \"look_at\": [0.3, 0.2, -1]},"
        " \"render\": {\"width\": 1, \"height\": 1, \"spp\": 1,"
        "  \"max_depth\": 24},"
        " \"background\": 1,"
        " \"materials\": {\"g\": {\"transmit\": 0.9, \"reflect\": 0.1,"
        "  \"ior\": 1.5}},"
        " \"objects\": ["
        "  {\"type\": \"plane\", \"point\": [0, 0, -1], \"normal\": [0, 0, 1], "
        "\"material\": \"g\"},"
        "  {\"type\": \"plane\", \"point\": [0, 0, -2], \"normal\": [0, 0, 1], "
        "\"material\": \"g\"},"
        "  {\"type\": \"plane\", \"point\": [0, 0, -3], \"normal\": [0, 0, 1], "
        "\"material\": \"g\"},"
        "  {\"type\": \"plane\", \"point\": [0, 0, 1], \"normal\": [0, 0, 1], "
        "\"material\": \"g\"}]}";
    lr_scene *s = lr_test_load_json(json);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    lr_image *img = NULL;
    lr_render_stats st;
    assert_int_equal(lr_render(s, &cam, &rs, &img, &st, NULL), LR_OK);
    lr_test_check_finite(img, &st, "glass stack");
    lr_image_free(img);
    lr_scene_free(s);
    /* 24 bounces x 4 surfaces would be a generous linear budget. */
    if (st.rays > 10000) {
        fail_msg("glass stack: %llu rays for one sample at max_depth 24",
                 (unsigned long long)st.rays);
    }
}

/* Zero-area, sliver and duplicate-vertex triangles, as objects and in a
 * mesh with computed smooth normals (where a zero-area triangle adds a
 * zero normal). */
static void test_degenerate_triangles(void **state)
{
    (void)state;
    char path[512];
    snprintf(path, sizeof path, "%s/degenerate.obj", lr_test_tmpdir());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 0\nv 0 1e-30 0\n"
          "v 1 1 0\nv 0 1 0\nv 1 1 0\n"
          "f 1 2 3\nf 1 4 2\nf 1 2 5\nf 6 6 6\nf 1 2 6\nf 1 6 7\n"
          "f 6 8 7\nf 2 6 8\n",
          f);
    assert_int_equal(fclose(f), 0);
    lr_image *img = lr_test_render_json(
        "{\"camera\": {\"position\": [0.5, 0.5, 2], \"look_at\": [0.5, 0.5, 0],"
        "  \"fov\": 60},"
        " \"render\": {\"width\": 16, \"height\": 16, \"spp\": 2,"
        "  \"depth\": true},"
        " \"background\": 0.1,"
        " \"materials\": {\"m\": {\"diffuse\": 0.5, \"specular\": 0.5,"
        "   \"shininess\": 10, \"transmit\": 0.3}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 1, 3],"
        "   \"intensity\": 10}],"
        " \"objects\": [{\"type\": \"mesh\", \"file\": \"degenerate.obj\","
        "   \"smooth\": true, \"material\": \"m\"},"
        "  {\"type\": \"triangle\", \"vertices\": [[0, 0, 0.1], [1, 0, 0.1],"
        "   [2, 0, 0.1]]},"
        "  {\"type\": \"triangle\", \"vertices\": [[0, 0, 0.2], [0, 0, 0.2],"
        "   [0, 0, 0.2]]},"
        "  {\"type\": \"triangle\", \"vertices\": [[0, 0, 0.3], [1, 0, 0.3],"
        "   [0.5, 1e-9, 0.3]]}]}",
        "degenerate triangles");
    /* The quad (two proper triangles) fills the centre of the frame. */
    const float *z = lr_image_depth(img);
    assert_true(fabs(z[8 * 16 + 8] - 2.0f) < 1e-4);
    lr_image_free(img);
}

/* A sphere of radius 1e-7 (far below a pixel) and one of radius 1e6 as a
 * floor: the huge sphere's top looks like a plane at that scale, so the
 * picture matches the same floor made as a plane (up to the curvature,
 * ~1e-5 units over the visible floor, and float rounding of its surface). */
static void test_huge_and_tiny_spheres(void **state)
{
    (void)state;
    const char *fmt =
        "{\"camera\": {\"position\": [0, 1, 4], \"look_at\": [0, 0.5, 0]},"
        " \"render\": {\"width\": 32, \"height\": 20, \"spp\": 2,"
        "  \"sampler\": \"grid\"},"
        " \"background\": 0.3,"
        " \"lights\": [{\"type\": \"point\", \"position\": [1, 4, 2],"
        "   \"intensity\": 30}],"
        " \"objects\": [%s,"
        "  {\"type\": \"sphere\", \"center\": [0, 0.5, 0], \"radius\": 0.5},"
        "  {\"type\": \"sphere\", \"center\": [0.3, 1.5, 0], \"radius\": "
        "1e-7}]}";
    char json[2048];
    snprintf(json, sizeof json, fmt,
             "{\"type\": \"plane\", \"normal\": [0, 1, 0]}");
    lr_image *plane = lr_test_render_json(json, "plane floor");
    snprintf(
        json, sizeof json, fmt,
        "{\"type\": \"sphere\", \"center\": [0, -1e6, 0], \"radius\": 1e6}");
    lr_image *sphere = lr_test_render_json(json, "sphere floor");
    lr_test_diff d = lr_test_compare(plane, sphere);
    lr_image_free(plane);
    lr_image_free(sphere);
    if (!(d.bad_frac <= 0.03 && d.mean_rel <= 0.02)) {
        /* Fixed bug, guarded here: shadow acne on the huge sphere.  Embree
         * intersects spheres in float, and lr__trace (lib/scene/scene.c) takes
         * its t as is, so the hit point of a radius-1e6 sphere lies up to
         * ~0.1 units off the surface, while lr__offset_origin pushes
         * shadow rays off by only (1 + |p| + t) 2^-17 ~ 4e-5: about half
         * the floor's samples shadow themselves (34% of the pixels off,
         * many black).  Refining t in double for spheres would fix it. */
        fail_msg("radius-1e6 sphere vs plane: %.2f%% of pixels off by "
                 "> 5%%, mean relative difference %.3g%%",
                 100 * d.bad_frac, 100 * d.mean_rel);
    }
}

/* Coincident surfaces: two planes (one infinite, one finite) and two
 * spheres in the same place with different materials.  Whichever wins a
 * pixel, the pixel is one of the two shadings, never NaN or a mixture
 * beyond what the samples average to. */
static void test_coincident_surfaces(void **state)
{
    (void)state;
    lr_image *img = lr_test_render_json(
        "{\"camera\": {\"position\": [0, 2, 5], \"look_at\": [0, 0, 0]},"
        " \"render\": {\"width\": 16, \"height\": 10, \"spp\": 1,"
        "  \"sampler\": \"grid\"},"
        " \"background\": 0,"
        " \"materials\": {\"a\": {\"diffuse\": [1, 0, 0]},"
        "  \"b\": {\"diffuse\": [0, 0, 1]}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0],"
        "   \"material\": \"a\"},"
        "  {\"type\": \"plane\", \"normal\": [0, 1, 0], \"size\": 4,"
        "   \"material\": \"b\"},"
        "  {\"type\": \"sphere\", \"center\": [0, 1, 0], \"radius\": 0.5,"
        "   \"material\": \"a\"},"
        "  {\"type\": \"sphere\", \"center\": [0, 1, 0], \"radius\": 0.5,"
        "   \"material\": \"b\"}]}",
        "coincident");
    const float *p = lr_image_rgb(img);
    for (int k = 0; k < 16 * 10; k++) {
        float r = p[3 * k], g = p[3 * k + 1], b = p[3 * k + 2];
        int is_a = r == 1.0f && g == 0 && b == 0;
        int is_b = r == 0 && g == 0 && b == 1.0f;
        int is_bg = r == 0 && g == 0 && b == 0;
        if (!(is_a || is_b || is_bg))
            fail_msg("coincident: pixel %d is (%g, %g, %g)", k, (double)r,
                     (double)g, (double)b);
    }
    lr_image_free(img);
}

static const struct CMUnitTest numeric_stability_tests[] = {
    cmocka_unit_test(test_offset_1e5),
    cmocka_unit_test(test_offset_1e7),
    cmocka_unit_test(test_scale_1e_minus_6),
    cmocka_unit_test(test_grazing_rays),
    cmocka_unit_test(test_rays_starting_on_surfaces),
    cmocka_unit_test(test_total_internal_reflection),
    cmocka_unit_test(test_branching_bounded),
    cmocka_unit_test(test_degenerate_triangles),
    cmocka_unit_test(test_huge_and_tiny_spheres),
    cmocka_unit_test(test_coincident_surfaces),
};

LR_TEST_GROUP(numeric_stability, numeric_stability_tests)
