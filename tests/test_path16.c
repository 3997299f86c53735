/*
 * test_path16.c: the sixteen paths as arrays (path16.c, path16_rays.c)
 * against the code they stand in for, each checked against an
 * independent answer:
 *   - the vector bounce against path.c's lane-by-lane bounce, to the
 *     byte, where test_path.c's Cornell box does not reach: more than two
 *     emitters (the picked emitter copied lane by lane), and every
 *     primitive in Embree (packets filled by lr__path16_shadows16 and
 *     lr__path16_rays16);
 *   - those packets against trace.c's lr__shadow_ray16 and
 *     lr__ray16_quiet_lanes, lane by lane, rays Embree could not take
 *     and lanes without a ray among them;
 *   - the packed rays against lr__embree_can_trace;
 *   - the hashed numbers against sampler.c's lr__mix64.
 */
#include "test.h"
#include "integrator/path.h"
#include "sampling/sampler.h"
#include "accel/trace.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The Cornell box of bench/path with two rectangle lights (4 emitting
 * triangles), small. */
static const char *const two_lights_json =
    "{\"render\": {\"width\": 20, \"height\": 16, \"spp\": 16,"
    "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 8,"
    "  \"plan\": false, \"threads\": 2},"
    " \"camera\": {\"position\": [0, 5, 16], \"look_at\": [0, 5, 0],"
    "  \"fov\": 40},"
    " \"materials\": {\"w\": {\"diffuse\": 0.75},"
    "  \"r\": {\"diffuse\": [0.65, 0.08, 0.06]},"
    "  \"m\": {\"reflect\": 0.9, \"roughness\": 0.25},"
    "  \"e\": {\"diffuse\": 0, \"emission\": 30},"
    "  \"f\": {\"diffuse\": 0, \"emission\": [2, 4, 8]}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": 0.05}],"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [0, 0, -5], \"normal\": [0, 1, 0],"
    "   \"size\": 10, \"material\": \"w\"},"
    "  {\"type\": \"plane\", \"point\": [0, 10, -5], \"normal\": [0, -1, 0],"
    "   \"size\": 10, \"material\": \"w\"},"
    "  {\"type\": \"plane\", \"point\": [0, 5, -10], \"normal\": [0, 0, 1],"
    "   \"size\": 10, \"material\": \"w\"},"
    "  {\"type\": \"plane\", \"point\": [-5, 5, -5], \"normal\": [1, 0, 0],"
    "   \"size\": 10, \"material\": \"r\"},"
    "  {\"type\": \"plane\", \"point\": [5, 5, -5], \"normal\": [-1, 0, 0],"
    "   \"size\": 10, \"material\": \"w\"},"
    "  {\"type\": \"plane\", \"point\": [0, 9.99, -5],"
    "   \"normal\": [0, -1, 0], \"size\": 3, \"material\": \"e\"},"
    "  {\"type\": \"plane\", \"point\": [4.99, 5, -6],"
    "   \"normal\": [-1, 0, 0], \"size\": 2, \"material\": \"f\"},"
    "  {\"type\": \"sphere\", \"center\": [-2, 2, -6.5], \"radius\": 2,"
    "   \"material\": \"w\"},"
    "  {\"type\": \"sphere\", \"center\": [2.2, 1.8, -3],"
    "   \"radius\": 1.8, \"material\": \"m\"}]}";

/* Blender's default scene in small (docs/blender.md): one point light
 * under a grey world, Lambertian boxes, floor and spheres, a rough metal
 * sphere (shaded alone), ambient light, at f/2.8 (a thin lens). */
static const char *const point_sky_json =
    "{\"render\": {\"width\": 24, \"height\": 16, \"spp\": 16,"
    "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 8,"
    "  \"plan\": false, \"threads\": 2},"
    " \"camera\": {\"model\": \"thinlens\", \"position\": [7, 5, 7],"
    "  \"look_at\": [0, 0, 0], \"fov\": 30, \"focus_distance\": 10,"
    "  \"focal_length_mm\": 50, \"f_number\": 2.8},"
    " \"background\": [0.2, 0.25, 0.3],"
    " \"materials\": {\"w\": {\"diffuse\": 0.5},"
    "  \"c\": {\"diffuse\": [0.6, 0.5, 0.4]},"
    "  \"m\": {\"reflect\": 0.9, \"roughness\": 0.3}},"
    " \"lights\": [{\"type\": \"point\", \"position\": [4, 6, -1],"
    "   \"intensity\": [80, 70, 60]},"
    "  {\"type\": \"ambient\", \"radiance\": 0.01}],"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": [0, 1, 0],"
    "   \"size\": 20, \"material\": \"w\"},"
    "  {\"type\": \"plane\", \"point\": [0, 1, 0], \"normal\": [0, 1, 0],"
    "   \"size\": 2, \"material\": \"c\"},"
    "  {\"type\": \"plane\", \"point\": [1, 0, 0], \"normal\": [1, 0, 0],"
    "   \"size\": 2, \"material\": \"c\"},"
    "  {\"type\": \"plane\", \"point\": [0, 0, 1], \"normal\": [0, 0, 1],"
    "   \"size\": 2, \"material\": \"c\"},"
    "  {\"type\": \"sphere\", \"center\": [2.2, -0.2, 1], \"radius\": 0.8,"
    "   \"material\": \"w\"},"
    "  {\"type\": \"sphere\", \"center\": [-1.5, -0.5, 2], \"radius\": 0.5,"
    "   \"material\": \"m\"}]}";

/* A scene both ways, path16.c on and off, the same bytes. */
static void same_both_ways_json(const char *json, const char *what)
{
    lr_image *a = lr_test_render_sets(json, NULL, 0, "path16 on");
    lr__path16_enabled = 0;
    lr_image *b = lr_test_render_sets(json, NULL, 0, "path16 off");
    lr__path16_enabled = 1;
    print_message("  %s\n", what);
    lr_test_assert_same_bytes(a, b, what);
    lr_image_free(a);
    lr_image_free(b);
}

static void same_both_ways(const char *what)
{
    lr_scene *s = lr_test_load_json(two_lights_json);
    /* (A scene path16.c takes, with its emitters copied lane by lane.) */
    assert_true(lr__path16_scene_ok(s));
    assert_int_equal(s->n_emitters, 4);
    lr_scene_free(s);
    same_both_ways_json(two_lights_json, what);
}

/* A point light under a grey world: the vector bounce's point-light
 * sample and its escapes to a lit background, against path.c's; a spot
 * light or a second light is path.c's alone. */
static void test_path16_point_light_and_sky(void **state)
{
    (void)state;
    lr_scene *s = lr_test_load_json(point_sky_json);
    assert_true(lr__path16_scene_ok(s));
    lr_scene_free(s);
    same_both_ways_json(point_sky_json, "a point light and a grey world");
    lr__few_triangles_enabled = 0;
    lr__few_spheres_enabled = 0;
    same_both_ways_json(point_sky_json,
                        "a point light and a grey world, Embree");
    lr__few_triangles_enabled = 1;
    lr__few_spheres_enabled = 1;
    const char *sets[] = {"lights[0].type=\"spot\"",
                          "lights[0].direction=[-4,-7,1]",
                          "lights[0].outer_angle=40"};
    lr_scene *spot = lr_test_load(point_sky_json, sets, 3);
    assert_false(lr__path16_scene_ok(spot));
    lr_scene_free(spot);
}

static void test_path16_many_emitters_and_embree(void **state)
{
    (void)state;
    same_both_ways("four emitters, a few primitives");
    /* Under a grey world (not light-sampled beside the emitters). */
    const char *grey[] = {"background=[0.2,0.25,0.3]"};
    lr_scene *s = lr_test_load(two_lights_json, grey, 1);
    assert_true(lr__path16_scene_ok(s));
    lr_scene_free(s);
    lr_image *a = lr_test_render_sets(two_lights_json, grey, 1, "on");
    lr__path16_enabled = 0;
    lr_image *b = lr_test_render_sets(two_lights_json, grey, 1, "off");
    lr__path16_enabled = 1;
    lr_test_assert_same_bytes(a, b, "four emitters under a grey world");
    lr_image_free(a);
    lr_image_free(b);
    /* Every primitive in Embree: the packets path16.c fills. */
    lr__few_triangles_enabled = 0;
    lr__few_spheres_enabled = 0;
    same_both_ways("four emitters, Embree");
    lr__few_triangles_enabled = 1;
    lr__few_spheres_enabled = 1;
}

/* A random double in [-1, 1) from a counter. */
static double rnd(uint64_t *k)
{
    return (double)(lr__mix64(++*k) >> 11) * 0x1p-52 - 1.0;
}

/* Sixteen lanes of paths with random rays; lanes 3, 7 and 12 have
 * coordinates Embree could not take (too large, NaN, infinite). */
static void random_paths(lr__paths16 *S, uint64_t *k)
{
    memset(S, 0, sizeof *S);
    for (int i = 0; i < 16; i++) {
        S->ox[i] = 10 * rnd(k), S->oy[i] = 10 * rnd(k), S->oz[i] = rnd(k);
        S->dx[i] = rnd(k), S->dy[i] = rnd(k), S->dz[i] = rnd(k);
        S->sox[i] = rnd(k), S->soy[i] = rnd(k), S->soz[i] = 5 * rnd(k);
        S->sdx[i] = rnd(k), S->sdy[i] = rnd(k), S->sdz[i] = rnd(k);
        S->stfar[i] = i == 5 ? INFINITY : 20 * fabs(rnd(k));
        S->alive[i] = rnd(k) > -0.3;
        S->shadow[i] = rnd(k) > 0.0;
    }
    S->ox[3] = 1e30, S->sdy[3] = 1e30;
    S->dz[7] = NAN, S->soz[7] = NAN;
    S->oy[12] = -INFINITY, S->sox[12] = INFINITY;
    S->alive[3] = S->alive[7] = S->alive[12] = 1.0;
    S->shadow[3] = S->shadow[7] = S->shadow[12] = 1.0;
}

/* Lane i of a and b: the fields Embree reads of a ray, the same bytes. */
static void same_lane(const struct RTCRay16 *a, const struct RTCRay16 *b, int i)
{
    const float *fa[8] = {a->org_x, a->org_y, a->org_z, a->dir_x,
                          a->dir_y, a->dir_z, a->tnear, a->tfar};
    const float *fb[8] = {b->org_x, b->org_y, b->org_z, b->dir_x,
                          b->dir_y, b->dir_z, b->tnear, b->tfar};
    for (int f = 0; f < 8; f++)
        assert_memory_equal(&fa[f][i], &fb[f][i], sizeof(float));
}

static void test_path16_packets_as_trace_fills_them(void **state)
{
    (void)state;
    uint64_t k = 17;
    for (int round = 0; round < 200; round++) {
        lr__paths16 S;
        random_paths(&S, &k);
        struct RTCRayHit16 got, want;
        int valid[16], want_valid[16];
        memset(&got, 0x7f, sizeof got);
        memset(&want, 0x7f, sizeof want);
        /* Shadow rays. */
        int n = lr__path16_shadows16(&S, &got.ray, valid), m = 0;
        for (int i = 0; i < 16; i++) {
            want_valid[i] = S.shadow[i] != 0.0 ? -1 : 0;
            if (!want_valid[i])
                continue;
            lr__shadow_ray16(&want.ray, i, v3(S.sox[i], S.soy[i], S.soz[i]),
                             v3(S.sdx[i], S.sdy[i], S.sdz[i]), S.stfar[i]);
            m++;
        }
        lr__ray16_quiet_lanes(&want.ray, want_valid);
        assert_int_equal(n, m);
        assert_memory_equal(valid, want_valid, sizeof valid);
        for (int i = 0; i < 16; i++)
            same_lane(&got.ray, &want.ray, i);
        /* Continuation rays, their hits unset. */
        memset(&got, 0x7f, sizeof got);
        memset(&want, 0x7f, sizeof want);
        n = lr__path16_rays16(&S, &got, valid), m = 0;
        for (int i = 0; i < 16; i++) {
            want_valid[i] = S.alive[i] != 0.0 ? -1 : 0;
            if (!want_valid[i])
                continue;
            lr__shadow_ray16(&want.ray, i, v3(S.ox[i], S.oy[i], S.oz[i]),
                             v3(S.dx[i], S.dy[i], S.dz[i]), INFINITY);
            want.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
            want.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
            m++;
        }
        lr__ray16_quiet_lanes(&want.ray, want_valid);
        assert_int_equal(n, m);
        assert_memory_equal(valid, want_valid, sizeof valid);
        for (int i = 0; i < 16; i++) {
            same_lane(&got.ray, &want.ray, i);
            assert_int_equal(got.hit.geomID[i], want.hit.geomID[i]);
            assert_int_equal(got.hit.instID[0][i], want.hit.instID[0][i]);
        }
    }
}

/* Packed entry c: lane i's ray from o along d up to tf, or (a ray Embree
 * could not take) one that meets nothing. */
static void packed_entry(const lr__rays_packed *P, int c, int i, lr__v3 o,
                         lr__v3 d, double tf)
{
    assert_int_equal(P->lane[c], i);
    double want[8] = {o.x, o.y, o.z, d.x, d.y, d.z, 0.0, tf};
    if (!lr__embree_can_trace(o, d)) {
        double none[8] = {0, 0, 0, 0, 0, 1, 1, 0};
        memcpy(want, none, sizeof want);
    }
    double got[8] = {P->ox[c], P->oy[c], P->oz[c], P->dx[c],
                     P->dy[c], P->dz[c], P->tn[c], P->tf[c]};
    assert_memory_equal(got, want, sizeof got);
}

static void test_path16_packed_rays(void **state)
{
    (void)state;
    uint64_t k = 99;
    for (int round = 0; round < 200; round++) {
        lr__paths16 S;
        random_paths(&S, &k);
        lr__rays_packed P;
        int ns = lr__path16_pack_shadows(&S, &P);
        int go = lr__path16_pack_rays(&S, &P);
        assert_int_equal(P.m, ns + go);
        int c = 0;
        for (int i = 0; i < 16; i++)
            if (S.shadow[i] != 0.0)
                packed_entry(&P, c++, i, v3(S.sox[i], S.soy[i], S.soz[i]),
                             v3(S.sdx[i], S.sdy[i], S.sdz[i]), S.stfar[i]);
        assert_int_equal(c, ns);
        for (int i = 0; i < 16; i++)
            if (S.alive[i] != 0.0)
                packed_entry(&P, c++, i, v3(S.ox[i], S.oy[i], S.oz[i]),
                             v3(S.dx[i], S.dy[i], S.dz[i]), INFINITY);
        assert_int_equal(c, ns + go);
    }
}

/* lr__path16_hashed against the scalar formula path.c had:
 * (double)(lr__mix64(key ^ (dim + j) phi) >> 11) 2^-53 for live lanes;
 * the others untouched. */
static void test_path16_hashed_numbers(void **state)
{
    (void)state;
    uint64_t k = 5;
    for (int round = 0; round < 500; round++) {
        uint64_t key[16];
        double alive[16], u[LR__PATH_DIMS][16];
        for (int i = 0; i < 16; i++) {
            key[i] = lr__mix64(++k);
            alive[i] = round % 7 == 0 ? i == round % 16 : rnd(&k) > 0.2;
            for (int j = 0; j < LR__PATH_DIMS; j++)
                u[j][i] = -1.0;
        }
        uint32_t dim = 30 + (uint32_t)round;
        int dims = LR__PATH_DIMS - 1 - round % 2;
        lr__path16_hashed(key, alive, dim, dims, u);
        for (int i = 0; i < 16; i++)
            for (int j = 0; j < LR__PATH_DIMS; j++) {
                double want = -1.0;
                if (alive[i] != 0.0 && j < dims) {
                    uint64_t h = lr__mix64(
                        key[i] ^ ((uint64_t)(dim + j) * 0x9e3779b97f4a7c15ull));
                    want = (double)(h >> 11) * 0x1p-53;
                }
                assert_memory_equal(&u[j][i], &want, sizeof want);
            }
    }
}

static const struct CMUnitTest tests[] = {
    cmocka_unit_test(test_path16_point_light_and_sky),
    cmocka_unit_test(test_path16_many_emitters_and_embree),
    cmocka_unit_test(test_path16_packets_as_trace_fills_them),
    cmocka_unit_test(test_path16_packed_rays),
    cmocka_unit_test(test_path16_hashed_numbers),
};
LR_TEST_GROUP(path16, tests)
