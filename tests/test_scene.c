/*
 * test_scene.c: the JSON scene loader.  Every error path must name its
 * field; valid scenes must load with the values they give.
 */
#include "test.h"
#include "scene/scene.h"

#include <stdio.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>

static lr_status load(const char *json, lr_scene **out, lr_error *err)
{
    memset(err, 0, sizeof *err);
    return lr_scene_load_json(json, strlen(json), lr_test_tmpdir(), NULL, 0,
                              out, err);
}

/* A scene with one JSON fragment spliced in at top level. */
#define BASE_OBJS                                                             \
    "\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,-5], \"radius\": " \
    "1}]"

typedef struct bad_case {
    const char *json;
    lr_status status;
    const char *path;    /* expected err.path */
    const char *message; /* substring of err.message, or NULL */
} bad_case;

static const bad_case bad_cases[] = {
    {"{", LR_ERR_INVALID, "", "line 1"},
    {"{\"camera\": {}}\n  x", LR_ERR_INVALID, "", "unexpected text"},
    {"[1, 2]", LR_ERR_INVALID, "", "JSON object"},
    {"{\"accel\": true}", LR_ERR_INVALID, "accel", "must be an object"},
    /* Every "must be an object" says what it got: --set x={a:1}, whose
     * quotes a shell ate, is the string "{a:1}", not a missing object. */
    {"{\"accel\": true}", LR_ERR_INVALID, "accel", "true|false}, got true"},
    {"{\"camera\": {\"chromatic\": \"{mode:rgb}\"}}", LR_ERR_INVALID,
     "camera.chromatic", "must be an object, got the string \"{mode:rgb}\""},
    {"{\"camera\": {\"chromatic\": {\"abbe\": [1.5, 60]}}}", LR_ERR_INVALID,
     "camera.chromatic.abbe", "64.17}, got an array of 2"},
    {"{\"camera\": 3}", LR_ERR_INVALID, "camera", "must be an object, got 3"},
    {"{\"render\": \"{spp:4}\"}", LR_ERR_INVALID, "render",
     "got the string \"{spp:4}\""},
    {"{\"materials\": []}", LR_ERR_INVALID, "materials", "got an array of 0"},
    {"{\"materials\": {\"m\": 0.5}}", LR_ERR_INVALID, "materials.m",
     "must be an object, got 0.5"},
    {"{\"lights\": [null]}", LR_ERR_INVALID, "lights[0]", "got null"},
    {"{\"objects\": [\"sphere\"]}", LR_ERR_INVALID, "objects[0]",
     "got the string \"sphere\""},
    {"{\"environment\": \"sky.exr\"}", LR_ERR_INVALID, "environment",
     "got the string \"sky.exr\""},
    {"{\"accel\": {\"robust\": 1}}", LR_ERR_INVALID, "accel.robust",
     "true or false"},
    {"{\"accel\": {\"fast\": true}}", LR_ERR_INVALID, "accel.fast",
     "unknown key"},
    {"{\"camra\": {}}", LR_ERR_INVALID, "camra", "unknown key"},
    {"{\"camera\": {\"fvo\": 30}}", LR_ERR_INVALID, "camera.fvo",
     "unknown key \"fvo\""},
    {"{\"camera\": {\"fov\": 30, \"fov\": 40}}", LR_ERR_INVALID, "camera.fov",
     "duplicate"},
    {"{\"camera\": {\"fov\": 0}}", LR_ERR_INVALID, "camera.fov", "got 0"},
    {"{\"camera\": {\"fov\": 180}}", LR_ERR_INVALID, "camera.fov", NULL},
    {"{\"camera\": {\"fov\": \"wide\"}}", LR_ERR_INVALID, "camera.fov",
     "must be a number"},
    {"{\"camera\": {\"fov\": 1e999}}", LR_ERR_INVALID, "camera.fov", "finite"},
    {"{\"camera\": {\"position\": [1, 2]}}", LR_ERR_INVALID, "camera.position",
     "3 numbers"},
    {"{\"camera\": {\"position\": [1, \"a\", 2]}}", LR_ERR_INVALID,
     "camera.position[1]", NULL},
    {"{\"camera\": {\"model\": \"fisheye\"}}", LR_ERR_INVALID, "camera.model",
     "fisheye"},
    {"{\"camera\": {\"position\": [0,0,-1]}}", LR_ERR_INVALID, "camera.look_at",
     NULL},
    {"{\"camera\": {\"up\": [0,0,2]}}", LR_ERR_INVALID, "camera.up",
     "parallel"},
    {"{\"camera\": {\"up\": [0,0,0]}}", LR_ERR_INVALID, "camera.up", NULL},
    {"{\"render\": {\"width\": 0}}", LR_ERR_INVALID, "render.width", "got 0"},
    {"{\"render\": {\"width\": 1.5}}", LR_ERR_INVALID, "render.width",
     "whole number"},
    {"{\"render\": {\"height\": 70000}}", LR_ERR_INVALID, "render.height",
     NULL},
    {"{\"render\": {\"width\": 65536, \"height\": 65536}}", LR_ERR_INVALID,
     "render.width", "pixels"},
    {"{\"render\": {\"spp\": 0}}", LR_ERR_INVALID, "render.spp", NULL},
    {"{\"render\": {\"sampler\": \"magic\"}}", LR_ERR_INVALID, "render.sampler",
     "magic"},
    {"{\"render\": {\"max_depth\": 100}}", LR_ERR_INVALID, "render.max_depth",
     NULL},
    {"{\"render\": {\"seed\": -1}}", LR_ERR_INVALID, "render.seed", NULL},
    {"{\"render\": {\"threads\": -1}}", LR_ERR_INVALID, "render.threads", NULL},
    {"{\"render\": {\"tile_size\": 0}}", LR_ERR_INVALID, "render.tile_size",
     NULL},
    {"{\"render\": {\"depth\": 1}}", LR_ERR_INVALID, "render.depth",
     "true or false"},
    {"{\"render\": {\"spp\": 4, \"sp\": 4}}", LR_ERR_INVALID, "render.sp",
     "unknown key"},
    {"{\"background\": -1}", LR_ERR_INVALID, "background", "negative"},
    {"{\"background\": [1, 1]}", LR_ERR_INVALID, "background", NULL},
    {"{\"materials\": []}", LR_ERR_INVALID, "materials", NULL},
    {"{\"materials\": {\"m\": {\"difuse\": 1}}}", LR_ERR_INVALID,
     "materials.m.difuse", "unknown key"},
    {"{\"materials\": {\"m\": {\"diffuse\": [1, -1, 0]}}}", LR_ERR_INVALID,
     "materials.m.diffuse", "negative"},
    {"{\"materials\": {\"m\": {\"ior\": 0.5}}}", LR_ERR_INVALID,
     "materials.m.ior", NULL},
    {"{\"materials\": {\"m\": {\"shininess\": -1}}}", LR_ERR_INVALID,
     "materials.m.shininess", NULL},
    {"{\"materials\": {\"m\": {}, \"m\": {}}}", LR_ERR_INVALID, "materials.m",
     "duplicate"},
    {"{\"materials\": {\"m\": 3}}", LR_ERR_INVALID, "materials.m", "object"},
    {"{\"lights\": {}}", LR_ERR_INVALID, "lights", "array"},
    {"{\"lights\": [{\"type\": \"area\"}]}", LR_ERR_INVALID, "lights[0].type",
     "area"},
    {"{\"lights\": [{\"position\": [0,0,0]}]}", LR_ERR_INVALID,
     "lights[0].type", "required"},
    {"{\"lights\": [{\"type\": \"point\", \"position\": [0,0,0]}]}",
     LR_ERR_INVALID, "lights[0].intensity", "required"},
    {"{\"lights\": [{\"type\": \"point\", \"position\": [0,0,0], "
     "\"intensity\": 1, \"radius\": 2}]}",
     LR_ERR_INVALID, "lights[0].radius", "unknown key"},
    {"{\"lights\": [{\"type\": \"directional\", \"direction\": [0,0,0], "
     "\"irradiance\": 1}]}",
     LR_ERR_INVALID, "lights[0].direction", "zero"},
    {"{\"lights\": [{\"type\": \"ambient\", \"radiance\": -0.5}]}",
     LR_ERR_INVALID, "lights[0].radiance", NULL},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "-2}]}",
     LR_ERR_INVALID, "objects[0].radius",
     "objects[0].radius must be > 0, got -2"},
    {"{\"objects\": [{\"center\": [0,0,0], \"radius\": 1}]}", LR_ERR_INVALID,
     "objects[0].type", "required"},
    {"{\"objects\": [{\"type\": \"cube\"}]}", LR_ERR_INVALID, "objects[0].type",
     "cube"},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"normal\": [0,1,0]}]}",
     LR_ERR_INVALID, "objects[0].normal", "unknown key"},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0]}]}",
     LR_ERR_INVALID, "objects[0].radius", "required"},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1}, {\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 1, "
     "\"material\": \"nope\"}]}",
     LR_ERR_INVALID, "objects[1].material", "nope"},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"shear\": 1}]}]}",
     LR_ERR_INVALID, "objects[0].transform[0].shear", "unknown transform"},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"scale\": [1, 2, 1]}]}]}",
     LR_ERR_INVALID, "objects[0].transform", "uniformly"},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"scale\": 0}]}]}",
     LR_ERR_INVALID, "objects[0].transform[0].scale", NULL},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"rotate\": {\"axis\": [0,0,0], \"degrees\": 3}}]}]}",
     LR_ERR_INVALID, "objects[0].transform[0].rotate.axis", NULL},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"rotate\": {\"axis\": [0,1,0]}}]}]}",
     LR_ERR_INVALID, "objects[0].transform[0].rotate.degrees", "required"},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": {\"scale\": 2}}]}",
     LR_ERR_INVALID, "objects[0].transform", "array"},
    {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0,0,0]}]}",
     LR_ERR_INVALID, "objects[0].normal", "zero"},
    {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0,1,0], \"size\": "
     "-1}]}",
     LR_ERR_INVALID, "objects[0].size", NULL},
    {"{\"objects\": [{\"type\": \"triangle\", \"vertices\": "
     "[[0,0,0],[1,0,0]]}]}",
     LR_ERR_INVALID, "objects[0].vertices", NULL},
    {"{\"objects\": [{\"type\": \"triangle\", \"vertices\": "
     "[[0,0,0],[1,0,0],[0,1]]}]}",
     LR_ERR_INVALID, "objects[0].vertices[2]", NULL},
    {"{\"objects\": [{\"type\": \"mesh\"}]}", LR_ERR_INVALID, "objects[0].file",
     "required"},
    {"{\"objects\": [{\"type\": \"mesh\", \"file\": \"no-such-file.obj\"}]}",
     LR_ERR_IO, "objects[0].file", "no-such-file.obj"},
    {"{\"objects\": [{\"type\": \"mesh\", \"file\": \"x.obj\", \"smooth\": "
     "\"yes\"}]}",
     LR_ERR_INVALID, "objects[0].smooth", NULL},
    {"{\"objects\": 5}", LR_ERR_INVALID, "objects", "array"},
};

static void test_every_error_names_its_field(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        const bad_case *c = &bad_cases[i];
        lr_scene *s = (lr_scene *)0x1;
        lr_error err;
        lr_status st = load(c->json, &s, &err);
        if (st != c->status || strcmp(err.path, c->path) != 0 ||
            (c->message && strstr(err.message, c->message) == NULL) ||
            s != NULL)
            fail_msg("case %zu: %s\n  got status %d path \"%s\" message "
                     "\"%s\"\n  want status %d path \"%s\" message ~ \"%s\"",
                     i, c->json, (int)st, err.path, err.message, (int)c->status,
                     c->path, c->message ? c->message : "");
        /* The message is a sentence that names the field itself. */
        if (c->path[0] != '\0' && c->status == LR_ERR_INVALID &&
            strstr(err.message, c->path) == NULL)
            fail_msg("case %zu: message \"%s\" does not name \"%s\"", i,
                     err.message, c->path);
    }
}

static void test_valid_scene_values(void **state)
{
    (void)state;
    const char *json =
        "{\"description\": \"x\","
        " \"camera\": {\"model\": \"pinhole\", \"position\": [1,2,3],"
        "  \"look_at\": [1,2,0], \"up\": [0,1,0], \"fov\": 55},"
        " \"render\": {\"width\": 33, \"height\": 17, \"spp\": 3,"
        "  \"sampler\": \"random\", \"seed\": 9, \"max_depth\": 2,"
        "  \"threads\": 1, \"tile_size\": 8, \"depth\": true},"
        " \"background\": [0.1, 0.2, 0.3],"
        " \"materials\": {\"a\": {\"diffuse\": 0.5, \"ior\": 1.33}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 0.25},"
        "   {\"type\": \"ambient\", \"radiance\": [0.25, 0, 0]},"
        "   {\"type\": \"point\", \"position\": [0,5,0], \"intensity\": 10}],"
        " " BASE_OBJS "}";
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(load(json, &s, &err), LR_OK);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    assert_true(cam.position[2] == 3.0 && cam.fov == 55.0);
    assert_int_equal(rs.width, 33);
    assert_int_equal(rs.height, 17);
    assert_int_equal(rs.spp, 3);
    assert_int_equal(rs.seed, 9);
    assert_int_equal(rs.max_depth, 2);
    assert_int_equal(rs.threads, 1);
    assert_int_equal(rs.tile_size, 8);
    assert_int_equal(rs.want_depth, 1);
    assert_true(s->background.z == 0.3);
    /* Ambient lights add up; the point light is the only light. */
    assert_true(s->ambient.x == 0.5 && s->ambient.y == 0.25);
    assert_int_equal(s->n_lights, 1);
    assert_int_equal(s->n_materials, 2);
    assert_true(s->materials[1].ior == 1.33);
    assert_int_equal(lr_scene_primitive_count(s), 1);
    lr_scene_free(s);
}

static void test_defaults(void **state)
{
    (void)state;
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(load("{}", &s, &err), LR_OK);
    lr_camera cam, def;
    lr_render_settings rs, rdef;
    lr_scene_camera(s, &cam);
    lr_camera_default(&def);
    assert_memory_equal(&cam, &def, sizeof cam);
    lr_scene_settings(s, &rs);
    lr_render_settings_default(&rdef);
    assert_memory_equal(&rs, &rdef, sizeof rs);
    assert_int_equal(rdef.width, 640);
    assert_int_equal(rdef.height, 480);
    assert_int_equal(rdef.spp, 16);
    /* Embree's traversal is robust unless the scene says otherwise. */
    assert_int_equal(rtcGetSceneFlags(s->rtc), RTC_SCENE_FLAG_ROBUST);
    lr_scene_free(s);
    lr_scene_free(NULL); /* a harmless no-op */
}

/* "accel": {"robust": false} reaches both Embree scenes (the path
 * integrator's second one exists with 1 to 8 spheres). */
static void test_accel_robust(void **state)
{
    (void)state;
    static const char *const json[] = {
        "{\"accel\": {\"robust\": false}, \"render\": {\"integrator\": "
        "\"path\"}, " BASE_OBJS "}",
        "{\"accel\": {\"robust\": true}, \"render\": {\"integrator\": "
        "\"path\"}, " BASE_OBJS "}",
    };
    for (int k = 0; k < 2; k++) {
        lr_scene *s = NULL;
        lr_error err;
        assert_int_equal(load(json[k], &s, &err), LR_OK);
        enum RTCSceneFlags want = k == 0 ? RTC_SCENE_FLAG_NONE
                                         : RTC_SCENE_FLAG_ROBUST;
        assert_int_equal(rtcGetSceneFlags(s->rtc), want);
        assert_non_null(s->rtc_few);
        assert_int_equal(rtcGetSceneFlags(s->rtc_few), want);
        lr_scene_free(s);
    }
}

static void test_overrides(void **state)
{
    (void)state;
    const char *json = "{\"camera\": {\"fov\": 30}, " BASE_OBJS "}";
    const char *sets[] = {"camera.fov=45", "render.spp=7",
                          "objects[0].radius=2.5", "render.sampler=random",
                          "background=[0.5,0.5,0.5]"};
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(
        lr_scene_load_json(json, strlen(json), NULL, sets, 5, &s, &err), LR_OK);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    assert_true(cam.fov == 45.0);
    assert_int_equal(rs.spp, 7);
    assert_true(s->geoms[0].radius == 2.5);
    assert_true(s->background.x == 0.5);
    lr_scene_free(s);

    /* Bad overrides fail with the override's path. */
    const char *bad[][2] = {
        {"objects[3].radius=1", "objects[3].radius"},
        {"camera.fov=500", "camera.fov"},
        {"camera.fov", ""},
        {"camera..fov=3", "camera..fov"},
        {"objects[x].radius=1", "objects[x].radius"},
        {"camera.fov.deg=3", "camera.fov.deg"},
        {"render.spp=\"many\"", "render.spp"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        s = (lr_scene *)0x1;
        memset(&err, 0, sizeof err);
        lr_status st = lr_scene_load_json(json, strlen(json), NULL, &bad[i][0],
                                          1, &s, &err);
        if (st != LR_ERR_INVALID || s != NULL ||
            strcmp(err.path, bad[i][1]) != 0)
            fail_msg("override %s: status %d path \"%s\" message \"%s\"",
                     bad[i][0], (int)st, err.path, err.message);
    }
}

/* lr_scene_read_settings gives what the whole load gives, byte for byte,
 * for every shipped scene with and without overrides; it does not read
 * the objects (a missing mesh is not its error); and its errors on the
 * parts it reads are the loader's. */
static void test_read_settings(void **state)
{
    (void)state;
    static const char *const scenes[] = {
        "spheres",         "cornell",  "bunny",          "bokeh",
        "chromatic",       "bench",    "accuracy-focus", "accuracy-defocus",
        "accuracy-chroma", "textured", "lens-bokeh",     "lens-chart"};
    static const char *const sets[] = {"camera.fov=33", "render.spp=7",
                                       "render.region=[1,2,30,40]"};
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; i++) {
        for (size_t n = 0; n <= 3; n += 3) {
            char path[256];
            snprintf(path, sizeof path, "scenes/%s.json", scenes[i]);
            lr_scene *s = NULL;
            lr_error err;
            lr_camera cam_full, cam;
            lr_render_settings rs_full, rs;
            memset(&cam_full, 0, sizeof cam_full);
            memset(&cam, 0xAB, sizeof cam);
            memset(&rs_full, 0, sizeof rs_full);
            memset(&rs, 0xAB, sizeof rs);
            if (lr_scene_load_file(path, sets, n, &s, &err) != LR_OK)
                fail_msg("%s: %s", path, err.message);
            lr_scene_camera(s, &cam_full);
            lr_scene_settings(s, &rs_full);
            lr_scene_free(s);
            if (lr_scene_read_settings(path, sets, n, &cam, &rs, &err) != LR_OK)
                fail_msg("%s: %s", path, err.message);
            assert_memory_equal(&cam, &cam_full, sizeof cam);
            assert_memory_equal(&rs, &rs_full, sizeof rs);
        }
    }
    /* A scene whose mesh is missing: its camera and settings still read. */
    /* In a directory of its own: a .json in the shared temporary
     * directory would be listed as a lens by test_prescription. */
    char dir[512], path[600];
    snprintf(dir, sizeof dir, "%s/read-settings", lr_test_tmpdir());
    mkdir(dir, 0700);
    snprintf(path, sizeof path, "%s/no-mesh.json", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("{\"render\": {\"width\": 33}, \"objects\": [{\"type\": \"mesh\", "
          "\"file\": \"absent.obj\"}]}",
          f);
    fclose(f);
    lr_camera cam;
    lr_render_settings rs;
    lr_error err;
    assert_int_equal(lr_scene_read_settings(path, NULL, 0, &cam, &rs, &err),
                     LR_OK);
    assert_int_equal(rs.width, 33);
    /* The errors of what it reads: the loader's, with the path named. */
    static const char *const bad[][2] = {
        {"{\"camra\": {}}", "camra"},
        {"{\"camera\": {\"fov\": 0}}", "camera.fov"},
        {"{\"render\": {\"spp\": 0}}", "render.spp"},
        {"{\"accel\": 2}", "accel"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        f = fopen(path, "w");
        assert_non_null(f);
        fputs(bad[i][0], f);
        fclose(f);
        lr_scene *s = NULL;
        lr_error full;
        lr_status want = lr_scene_load_file(path, NULL, 0, &s, &full);
        assert_int_not_equal(want, LR_OK);
        if (strcmp(bad[i][1], "accel") == 0) {
            /* accel is the objects' side: not read here. */
            assert_int_equal(
                lr_scene_read_settings(path, NULL, 0, &cam, &rs, &err), LR_OK);
            continue;
        }
        assert_int_equal(lr_scene_read_settings(path, NULL, 0, &cam, &rs, &err),
                         want);
        assert_string_equal(err.path, bad[i][1]);
        assert_string_equal(err.message, full.message);
    }
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("{\"camera\": ", f);
    fclose(f);
    assert_int_equal(lr_scene_read_settings(path, NULL, 0, &cam, &rs, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "no-mesh.json"));
    assert_int_equal(
        lr_scene_read_settings("/nonexistent/x.json", NULL, 0, &cam, &rs, &err),
        LR_ERR_IO);
}

static void test_load_file_errors(void **state)
{
    (void)state;
    lr_scene *s = NULL;
    lr_error err;
    char path[512];
    assert_int_equal(
        lr_scene_load_file("/nonexistent/scene.json", NULL, 0, &s, &err),
        LR_ERR_IO);
    assert_non_null(strstr(err.message, "/nonexistent/scene.json"));
    /* Syntax errors name the file and the line. */
    snprintf(path, sizeof path, "%s/broken.json", lr_test_tmpdir());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("{\n  \"camera\": {\n    \"fov\": 30,\n  }\n}\n", f);
    fclose(f);
    assert_int_equal(lr_scene_load_file(path, NULL, 0, &s, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, path));
    assert_non_null(strstr(err.message, "line 4"));
    assert_null(s);
}

static void test_mesh_relative_to_scene_file(void **state)
{
    (void)state;
    char dir[512], path[600];
    snprintf(dir, sizeof dir, "%s", lr_test_tmpdir());
    snprintf(path, sizeof path, "%s/tri.obj", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("v 0 0 -5\nv 1 0 -5\nv 0 1 -5\nv 1 1 -5\nf 1 2 4 3\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/mesh-scene.json", dir);
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("{\"objects\": [{\"type\": \"mesh\", \"file\": \"tri.obj\","
          " \"smooth\": true}]}",
          f);
    fclose(f);
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_file(path, NULL, 0, &s, &err), LR_OK);
    assert_int_equal(lr_scene_primitive_count(s), 2);
    /* smooth: true on a file without normals computes them: a flat quad's
     * are all its face normal, +z. */
    assert_non_null(s->geoms[0].corner_normals);
    for (int k = 0; k < 6; k++)
        assert_true(fabsf(s->geoms[0].corner_normals[3 * k + 2] - 1.0f) <
                    1e-6f);
    lr_scene_free(s);
}

static void test_apply_json(void **state)
{
    (void)state;
    lr_camera cam;
    lr_camera_default(&cam);
    lr_error err;
    const char *j = "{\"fov\": 25, \"position\": [1, 2, 3]}";
    assert_int_equal(lr_camera_apply_json(&cam, j, strlen(j), &err), LR_OK);
    assert_true(cam.fov == 25.0 && cam.position[1] == 2.0);
    assert_true(cam.look_at[2] == -1.0); /* untouched */
    lr_camera before = cam;
    j = "{\"fov\": -5}";
    assert_int_equal(lr_camera_apply_json(&cam, j, strlen(j), &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.fov");
    assert_memory_equal(&cam, &before, sizeof cam); /* unchanged on error */
    j = "[1]";
    assert_int_equal(lr_camera_apply_json(&cam, j, strlen(j), &err),
                     LR_ERR_INVALID);

    lr_render_settings rs;
    lr_render_settings_default(&rs);
    j = "{\"spp\": 5, \"width\": 10}";
    assert_int_equal(lr_render_settings_apply_json(&rs, j, strlen(j), &err),
                     LR_OK);
    assert_int_equal(rs.spp, 5);
    assert_int_equal(rs.width, 10);
    assert_int_equal(rs.height, 480);
    j = "{\"spp\": 5, \"colour\": 1}";
    assert_int_equal(lr_render_settings_apply_json(&rs, j, strlen(j), &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "render.colour");
}

static const struct CMUnitTest scene_tests[] = {
    cmocka_unit_test(test_apply_json),
    cmocka_unit_test(test_every_error_names_its_field),
    cmocka_unit_test(test_valid_scene_values),
    cmocka_unit_test(test_defaults),
    cmocka_unit_test(test_accel_robust),
    cmocka_unit_test(test_overrides),
    cmocka_unit_test(test_load_file_errors),
    cmocka_unit_test(test_read_settings),
    cmocka_unit_test(test_mesh_relative_to_scene_file),
};
LR_TEST_GROUP(scene, scene_tests)
