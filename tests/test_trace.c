/*
 * test_trace.c: ray intersection of every primitive against analytic
 * answers, including transforms, rays from inside and grazing misses.
 */
#include "test.h"
#include "accel/trace.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static lr_scene *scene_of(const char *objects)
{
    char json[4096];
    snprintf(json, sizeof json, "{\"objects\": %s}", objects);
    lr_scene *s = NULL;
    lr_error err;
    lr_status st = lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                      NULL, 0, &s, &err);
    if (st != LR_OK)
        fail_msg("scene did not load: %s", err.message);
    return s;
}

#define assert_near(a, b, tol)                                          \
    do {                                                                \
        double a_ = (a), b_ = (b);                                      \
        if (!(fabs(a_ - b_) <= (tol)))                                  \
            fail_msg("%s = %.12g, expected %.12g (tol %g)", #a, a_, b_, \
                     (double)(tol));                                    \
    } while (0)

static void test_sphere(void **state)
{
    (void)state;
    lr_scene *s = scene_of("[{\"type\": \"sphere\", \"center\": [0, 0, -5],"
                           " \"radius\": 1}]");
    lr__hit h;
    /* Straight on: t = 5 - 1, normal towards the ray. */
    assert_true(lr__trace(s, v3(0, 0, 0), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 4.0, 1e-5);
    assert_near(h.ng.z, 1.0, 1e-9);
    assert_true(h.entering);
    /* Off-centre by 0.6: t = 5 - sqrt(1 - 0.36) = 4.2. */
    assert_true(lr__trace(s, v3(0.6, 0, 0), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 4.2, 1e-5);
    assert_near(h.ng.x, 0.6, 1e-5);
    assert_near(h.ng.z, 0.8, 1e-5);
    /* A ray passing 1.001 from the centre misses. */
    assert_false(lr__trace(s, v3(1.001, 0, 0), v3(0, 0, -1), INFINITY, &h));
    /* tfar limits the search. */
    assert_false(lr__trace(s, v3(0, 0, 0), v3(0, 0, -1), 3.9, &h));
    /* From the centre: the far side at t = 1, seen from inside. */
    assert_true(lr__trace(s, v3(0, 0, -5), v3(1, 0, 0), INFINITY, &h));
    assert_near(h.t, 1.0, 1e-5);
    assert_false(h.entering);
    assert_near(h.ng.x, -1.0, 1e-9); /* faces the ray's origin */
    /* Behind the ray: nothing. */
    assert_false(lr__trace(s, v3(0, 0, 0), v3(0, 0, 1), INFINITY, &h));
    lr_scene_free(s);
}

static void test_infinite_plane(void **state)
{
    (void)state;
    lr_scene *s = scene_of("[{\"type\": \"plane\", \"point\": [0, -1, 0],"
                           " \"normal\": [0, 2, 0]}]");
    lr__hit h;
    lr__v3 d = v3_norm(v3(0, -1, -1));
    assert_true(lr__trace(s, v3(0, 0, 0), d, INFINITY, &h));
    assert_near(h.t, sqrt(2.0), 1e-12);
    assert_near(h.p.y, -1.0, 1e-12);
    assert_near(h.ng.y, 1.0, 1e-12);
    assert_true(h.entering);
    /* Far away along a shallow ray: still exact (no float BVH). */
    d = v3_norm(v3(0, -1, -1000));
    assert_true(lr__trace(s, v3(0, 0, 0), d, INFINITY, &h));
    assert_near(h.p.z, -1000.0, 1e-9);
    /* From below: the plane is two-sided. */
    assert_true(lr__trace(s, v3(0, -2, 0), v3(0, 1, 0), INFINITY, &h));
    assert_near(h.t, 1.0, 1e-12);
    assert_false(h.entering);
    assert_near(h.ng.y, -1.0, 1e-12);
    /* Parallel: no hit. */
    assert_false(lr__trace(s, v3(0, 0, 0), v3(1, 0, 0), INFINITY, &h));
    assert_true(lr__occluded(s, v3(0, 0, 0), v3(0, -1, 0), 2.0));
    assert_false(lr__occluded(s, v3(0, 0, 0), v3(0, -1, 0), 0.5));
    lr_scene_free(s);
}

static void test_finite_plane(void **state)
{
    (void)state;
    /* A 4 x 2 rectangle in the plane y = 0 centred at the origin: its
     * first side runs along x. */
    lr_scene *s = scene_of("[{\"type\": \"plane\", \"point\": [0, 0, 0],"
                           " \"normal\": [0, 1, 0], \"size\": [4, 2]}]");
    lr__hit h;
    assert_true(lr__trace(s, v3(1.9, 1, 0.9), v3(0, -1, 0), INFINITY, &h));
    assert_near(h.t, 1.0, 1e-6);
    assert_true(h.entering);
    assert_near(h.ng.y, 1.0, 1e-9);
    assert_false(lr__trace(s, v3(2.1, 1, 0), v3(0, -1, 0), INFINITY, &h));
    assert_false(lr__trace(s, v3(0, 1, 1.1), v3(0, -1, 0), INFINITY, &h));
    assert_int_equal(lr_scene_primitive_count(s), 2);
    lr_scene_free(s);
}

static void test_triangle_and_transforms(void **state)
{
    (void)state;
    /* CCW seen from +z: the front faces +z. */
    lr_scene *s = scene_of(
        "[{\"type\": \"triangle\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0]]}]");
    lr__hit h;
    assert_true(lr__trace(s, v3(0.25, 0.25, 3), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 3.0, 1e-6);
    assert_true(h.entering);
    assert_near(h.ng.z, 1.0, 1e-9);
    assert_true(lr__trace(s, v3(0.25, 0.25, -3), v3(0, 0, 1), INFINITY, &h));
    assert_false(h.entering);
    assert_false(lr__trace(s, v3(0.6, 0.6, 3), v3(0, 0, -1), INFINITY, &h));
    lr_scene_free(s);

    /* Rotate 90 degrees about +y (x -> -z), then translate by (0, 0, -5):
     * the front now faces +x and the triangle spans z in [-6, -5]. */
    s = scene_of("[{\"type\": \"triangle\", \"vertices\": [[0,0,0],[1,0,0],"
                 "[0,1,0]], \"transform\": [{\"rotate\": {\"axis\": [0,1,0],"
                 " \"degrees\": 90}}, {\"translate\": [0, 0, -5]}]}]");
    assert_true(lr__trace(s, v3(4, 0.25, -5.25), v3(-1, 0, 0), INFINITY, &h));
    assert_near(h.t, 4.0, 1e-5);
    assert_true(h.entering);
    assert_near(h.ng.x, 1.0, 1e-6);
    assert_false(lr__trace(s, v3(4, 0.25, -4.75), v3(-1, 0, 0), INFINITY, &h));
    lr_scene_free(s);

    /* A mirroring scale keeps the front side on the outside. */
    s = scene_of("[{\"type\": \"triangle\", \"vertices\": [[0,0,0],[1,0,0],"
                 "[0,1,0]], \"transform\": [{\"scale\": [-1, 1, 1]}]}]");
    assert_true(lr__trace(s, v3(-0.25, 0.25, 3), v3(0, 0, -1), INFINITY, &h));
    assert_true(h.entering);
    lr_scene_free(s);

    /* Sphere under uniform scale and translation. */
    s = scene_of(
        "[{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 1,"
        " \"transform\": [{\"scale\": 2}, {\"translate\": [0,0,-10]}]}]");
    assert_true(lr__trace(s, v3(0, 0, 0), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 8.0, 1e-5);
    lr_scene_free(s);
}

/* A mirroring transform keeps normals on the image of their side (the
 * inverse transpose, whose sign the cofactor matrix flips): an infinite
 * plane's front is the mirror image of its front, and a mesh's file
 * normals stay in front of their faces, so that they are kept (smooth
 * shading) and come out as the mirror images of the unmirrored mesh's
 * at mirrored points. */
static void test_mirror_keeps_normals(void **state)
{
    (void)state;
    lr_scene *s = scene_of("[{\"type\": \"plane\", \"point\": [0, -1, 0],"
                           " \"normal\": [0, 1, 0], \"transform\":"
                           " [{\"scale\": [-1, 1, 1]}]}]");
    lr__hit h;
    assert_true(lr__trace(s, v3(0, 0, 0), v3(0, -1, 0), INFINITY, &h));
    assert_true(h.entering);
    assert_near(h.ng.y, 1.0, 1e-12);
    lr_scene_free(s);

    char path[512];
    lr_test_write_text("tilted.obj",
                       "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                       "vn 0.3 0 1\nvn -0.3 0 1\nvn 0 0.3 1\nvn 0 -0.3 1\n"
                       "f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n",
                       path, sizeof path);
    lr_scene *a = scene_of("[{\"type\": \"mesh\", \"file\": \"tilted.obj\"}]");
    lr_scene *b = scene_of("[{\"type\": \"mesh\", \"file\": \"tilted.obj\","
                           " \"transform\": [{\"scale\": [-1, 1, 1]}]}]");
    static const double at[3][2] = {{0.5, -0.2}, {-0.6, 0.3}, {0.1, 0.7}};
    for (int i = 0; i < 3; i++) {
        lr__hit ha, hb;
        double x = at[i][0], y = at[i][1];
        assert_true(lr__trace(a, v3(x, y, 3), v3(0, 0, -1), INFINITY, &ha));
        assert_true(lr__trace(b, v3(-x, y, 3), v3(0, 0, -1), INFINITY, &hb));
        assert_true(ha.entering && hb.entering);
        /* Smooth, not the flat normal the mirrored mesh had fallen to. */
        if (!(fabs(ha.ns.x) + fabs(ha.ns.y) > 0.01))
            fail_msg("(%g, %g): the unmirrored normal is flat", x, y);
        assert_near(hb.ns.x, -ha.ns.x, 1e-6);
        assert_near(hb.ns.y, ha.ns.y, 1e-6);
        assert_near(hb.ns.z, ha.ns.z, 1e-6);
    }
    lr_scene_free(a);
    lr_scene_free(b);
}

/* A plane scaled by 1e-300 across itself is the same plane: the
 * cofactors, products of two scales, underflowed to a zero normal (the
 * floor vanished from the picture).  Mirrored too, and tilted where two
 * scales are tiny: the normal (1, 1, 1) under scale (1e-300, 1e-300, 1)
 * is M^-T n, along (1, 1, 1e-300). */
static void test_tiny_scale_keeps_normals(void **state)
{
    (void)state;
    static const char *const scales[] = {
        "[1e-300, 1, 1e-300]", "[-1e-300, 1, 1e-300]", "[1e-300, 1, 1]"};
    for (int k = 0; k < 3; k++) {
        char objs[256];
        snprintf(objs, sizeof objs,
                 "[{\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": "
                 "[0, 1, 0], \"transform\": [{\"scale\": %s}]}]",
                 scales[k]);
        lr_scene *s = scene_of(objs);
        lr__hit h;
        assert_true(lr__trace(s, v3(0, 0, 0), v3(0, -1, 0), INFINITY, &h));
        assert_true(h.entering);
        assert_near(h.ng.y, 1.0, 1e-12);
        assert_near(h.t, 1.0, 1e-12);
        lr_scene_free(s);
    }
    lr_scene *s = scene_of("[{\"type\": \"plane\", \"point\": [0, 0, 0], "
                           "\"normal\": [1, 1, 1], \"transform\": "
                           "[{\"scale\": [1e-300, 1e-300, 1]}]}]");
    lr__hit h;
    assert_true(lr__trace(s, v3(1, 1, 0), v3(-1, -1, 0), INFINITY, &h));
    assert_near(h.ng.x, sqrt(0.5), 1e-12);
    assert_near(h.ng.y, sqrt(0.5), 1e-12);
    assert_near(h.ng.z, 0.0, 1e-12);
    lr_scene_free(s);
}

static void test_closest_of_many(void **state)
{
    (void)state;
    /* A plane behind a sphere behind a triangle: the nearest wins, and
     * an infinite plane in front of Embree geometry wins too. */
    lr_scene *s = scene_of(
        "[{\"type\": \"plane\", \"point\": [0,0,-20], \"normal\": [0,0,1]},"
        " {\"type\": \"sphere\", \"center\": [0,0,-10], \"radius\": 1},"
        " {\"type\": \"triangle\", \"vertices\": "
        "[[-1,-1,-5],[1,-1,-5],[0,1,-5]]}]");
    lr__hit h;
    assert_true(lr__trace(s, v3(0, 0, 0), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 5.0, 1e-6);
    assert_true(lr__trace(s, v3(0, 0, -6), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 3.0, 1e-5);
    assert_true(lr__trace(s, v3(0, 0, -12), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 8.0, 1e-9);
    lr_scene_free(s);
}

static void test_offset_escapes_surface(void **state)
{
    (void)state;
    /* Rays leaving a hit point never hit the surface they start on, at
     * the origin or far from it. */
    const double offsets[] = {0.0, 1e3, 1e5};
    for (size_t k = 0; k < 3; k++) {
        double o = offsets[k];
        char objs[256];
        snprintf(objs, sizeof objs,
                 "[{\"type\": \"sphere\", \"center\": [%g, 0, -5],"
                 " \"radius\": 1}]",
                 o);
        lr_scene *s = scene_of(objs);
        int self_hits = 0;
        for (int i = 0; i < 200; i++) {
            double a = 0.05 + 0.9 * i / 200.0;
            lr__v3 org = v3(o + a - 0.5, 0.3 * a, 0);
            lr__hit h;
            if (!lr__trace(s, org, v3_norm(v3(0, 0, -1)), INFINITY, &h))
                continue;
            /* Leave along the reflection: must escape the convex sphere. */
            lr__v3 d = v3(0, 0, -1);
            lr__v3 r = v3_madd(d, h.ng, -2 * v3_dot(d, h.ng));
            lr__hit h2;
            if (lr__trace(s, lr__offset_origin(&h, r), r, INFINITY, &h2))
                self_hits++;
            /* Light above the surface is not occluded by it. */
            if (lr__occluded(s, lr__offset_origin(&h, h.ng), h.ng, 100.0))
                self_hits++;
        }
        if (self_hits != 0)
            fail_msg("offset %g: %d self-intersections", o, self_hits);
        lr_scene_free(s);
    }
}

/* Rays Embree would abort the process on (a component beyond 1.8e18 or
 * not finite) arise in valid scenes: a camera 1e15 up, looking just
 * below the horizon, meets an infinite plane 1e19 away, and the shadow
 * and reflected rays start there.  lr__trace and lr__occluded must not
 * give them to Embree: a miss of Embree's geometry (the planes still
 * count), each counted. */
static void test_rays_beyond_embree(void **state)
{
    (void)state;
    assert_true(lr__embree_can_trace(v3(1.8e18, -1.8e18, 0), v3(0, 0, 1)));
    assert_false(lr__embree_can_trace(v3(1.9e18, 0, 0), v3(0, 0, 1)));
    assert_false(lr__embree_can_trace(v3(0, 0, 0), v3(0, -2e18, 1)));
    assert_false(lr__embree_can_trace(v3(0, NAN, 0), v3(0, 0, 1)));
    assert_false(lr__embree_can_trace(v3(0, 0, 0), v3(INFINITY, 0, 1)));

    lr_scene *s = scene_of("[{\"type\": \"sphere\", \"center\": [0, 0, -5],"
                           " \"radius\": 1}, {\"type\": \"plane\","
                           " \"point\": [0, 0, 0], \"normal\": [0, 1, 0]}]");
    lr__hit h;
    /* The far hit, from numbers within the scene's limits. */
    lr__v3 cam = v3(0, 1e15, 0);
    lr__v3 dir = v3_norm(v3(0, -1e-4, -1));
    assert_true(lr__trace(s, cam, dir, INFINITY, &h));
    assert_true(fabs(h.p.z) > 5e18);
    assert_false(lr__embree_can_trace(lr__offset_origin(&h, h.ng), h.ng));
    assert_int_equal(lr__scene_skipped_rays(s), 0);

    /* From there: straight back at the sphere, a miss (Embree skipped);
     * down, the plane is still hit, in double; up, nothing occludes. */
    lr__v3 far = v3(0, 1, -1e19);
    assert_false(lr__trace(s, far, v3(0, 0, 1), INFINITY, &h));
    assert_int_equal(lr__scene_skipped_rays(s), 1);
    assert_true(lr__trace(s, far, v3_norm(v3(0, -1, 1)), INFINITY, &h));
    assert_near(h.t, sqrt(2.0), 1e-9);
    assert_int_equal(lr__scene_skipped_rays(s), 2);
    assert_false(lr__occluded(s, far, v3(0, 1, 0), 1e3));
    assert_int_equal(lr__scene_skipped_rays(s), 3);
    /* Blocked by the plane: found before Embree is asked, not counted. */
    assert_true(lr__occluded(s, far, v3_norm(v3(0, -1, 1)), 1e3));
    assert_int_equal(lr__scene_skipped_rays(s), 3);
    /* Not finite: a miss. */
    assert_false(lr__trace(s, v3(0, 0, 0), v3(NAN, 0, -1), INFINITY, &h));
    assert_false(lr__occluded(s, v3(0, INFINITY, 0), v3(0, 0, -1), 1e3));
    assert_int_equal(lr__scene_skipped_rays(s), 5);
    /* Ordinary rays are traced as before and not counted. */
    assert_true(lr__trace(s, v3(0, 0.5, 0), v3(0, 0, -1), INFINITY, &h));
    assert_near(h.t, 5.0 - sqrt(0.75), 1e-5);
    assert_true(lr__occluded(s, v3(0, 0.5, 0), v3(0, 0, -1), 1e3));
    assert_int_equal(lr__scene_skipped_rays(s), 5);
    lr_scene_free(s);
}

static const struct CMUnitTest trace_tests[] = {
    cmocka_unit_test(test_rays_beyond_embree),
    cmocka_unit_test(test_sphere),
    cmocka_unit_test(test_infinite_plane),
    cmocka_unit_test(test_finite_plane),
    cmocka_unit_test(test_triangle_and_transforms),
    cmocka_unit_test(test_mirror_keeps_normals),
    cmocka_unit_test(test_tiny_scale_keeps_normals),
    cmocka_unit_test(test_closest_of_many),
    cmocka_unit_test(test_offset_escapes_surface),
};
LR_TEST_GROUP(trace, trace_tests)
