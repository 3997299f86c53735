/*
 * test_shared_rules.c: the rules the CLI and the daemon take from the
 * library rather than keep themselves: the format table (format.c), the
 * output object (output.c), stats as JSON (stats.c), the camera and
 * settings written back as JSON (settings_json.c), the cameras from
 * lr_camera_new, the camera models' and the integrators' registries
 * (camera.c, integrator.c), the scene's
 * description, and a job parsed once (job.c).
 */
#include "test.h"
#include "camera/camera.h"
#include "integrator/integrator.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- formats ---------------------------------------------------------- */

static void test_format_table(void **state)
{
    (void)state;
    int n = 0;
    for (lr_format f = 0; lr_format_name(f) != NULL; f++, n++) {
        lr_format back = (lr_format)-1;
        assert_int_equal(
            lr_format_from_name(lr_format_name(f), NULL, &back, NULL), LR_OK);
        assert_int_equal(back, f);
        /* The extension is the name with a dot, and names a file. */
        char file[32];
        snprintf(file, sizeof file, "x%s", lr_format_extension(f));
        assert_int_equal(lr_format_from_path(file, &back, NULL), LR_OK);
        assert_int_equal(back, f);
        assert_non_null(strstr(lr_format_mime(f), "image/"));
    }
    assert_int_equal(n, 2);
    assert_string_equal(lr_format_mime(LR_FORMAT_PNG), "image/png");
    assert_string_equal(lr_format_mime(LR_FORMAT_EXR), "image/x-exr");
    assert_int_equal(lr_format_has_depth(LR_FORMAT_EXR), 1);
    assert_int_equal(lr_format_has_depth(LR_FORMAT_PNG), 0);
    /* A value past the table is no format, never "exr". */
    assert_null(lr_format_name((lr_format)7));
    assert_null(lr_format_mime((lr_format)-1));

    lr_error err;
    lr_format f;
    assert_int_equal(lr_format_from_name("gif", "output.format", &f, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "output.format");
    assert_non_null(strstr(err.message, "\"png\""));
    assert_non_null(strstr(err.message, "\"exr\""));
    assert_int_equal(lr_format_from_name(NULL, NULL, &f, &err), LR_ERR_INVALID);
    assert_string_equal(err.path, "format");
}

/* ---- the output object ------------------------------------------------ */

static lr_status output(const char *json, lr_output *o, lr_error *err)
{
    lr_output_default(o);
    return lr_output_apply_json(o, json, strlen(json), err);
}

static void test_output_json(void **state)
{
    (void)state;
    lr_output o;
    lr_error err;
    assert_int_equal(output("{}", &o, &err), LR_OK);
    assert_int_equal(o.format, LR_FORMAT_PNG);
    assert_int_equal(o.depth, 0);
    assert_int_equal(o.options.exr_depth, 0);
    assert_int_equal(output("{\"format\": \"exr\", \"half\": true, "
                            "\"depth\": true}",
                            &o, &err),
                     LR_OK);
    assert_int_equal(o.format, LR_FORMAT_EXR);
    assert_int_equal(o.options.exr_half, 1);
    assert_int_equal(o.depth, 1);
    assert_int_equal(o.depth_given, 1);
    assert_int_equal(o.options.exr_depth, 1);
    assert_int_equal(output("{\"bit_depth\": 16}", &o, &err), LR_OK);
    assert_int_equal(o.options.png_16bit, 1);
    assert_int_equal(o.options.exr_compression, LR_EXR_ZIP);
    static const char *const comps[] = {"zip", "none", "zips", "rle", "piz"};
    for (int c = 0; c < 5; c++) {
        char json[96];
        snprintf(json, sizeof json,
                 "{\"format\": \"exr\", \"compression\": \"%s\"}", comps[c]);
        assert_int_equal(output(json, &o, &err), LR_OK);
        assert_int_equal(o.options.exr_compression, c);
        assert_string_equal(lr_exr_compression_name(o.options.exr_compression),
                            comps[c]);
    }

    /* Options that do not apply are refused, naming the field. */
    static const struct {
        const char *json, *path;
    } bad[] = {
        {"{\"format\": \"gif\"}", "output.format"},
        {"{\"format\": 3}", "output.format"},
        {"{\"half\": true}", "output.half"},
        {"{\"depth\": true}", "output.depth"},
        {"{\"depth\": false}", "output.depth"},
        {"{\"format\": \"exr\", \"bit_depth\": 16}", "output.bit_depth"},
        {"{\"bit_depth\": 12}", "output.bit_depth"},
        {"{\"format\": \"exr\", \"half\": 1}", "output.half"},
        {"{\"quality\": 9}", "output.quality"},
        {"{\"compression\": \"zip\"}", "output.compression"},
        {"{\"format\": \"exr\", \"compression\": \"lzw\"}",
         "output.compression"},
        {"{\"format\": \"exr\", \"compression\": 2}", "output.compression"},
        {"[]", "output"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        lr_output before;
        lr_output_default(&before);
        o = before;
        memset(&err, 0, sizeof err);
        if (lr_output_apply_json(&o, bad[i].json, strlen(bad[i].json), &err) !=
            LR_ERR_INVALID)
            fail_msg("%s was accepted", bad[i].json);
        assert_string_equal(err.path, bad[i].path);
        assert_memory_equal(&o, &before, sizeof o);
    }
}

/* ---- stats ------------------------------------------------------------ */

static void test_stats_json(void **state)
{
    (void)state;
    lr_render_stats st;
    memset(&st, 0, sizeof st);
    st.seconds = 0.5;
    st.cpu_seconds = 0.75;
    st.pixels = 100;
    st.samples = 400;
    st.rays = 1000;
    st.threads = 2;
    st.lens_pixels = 25;
    st.full_samples = 1600;
    st.camera_rays = 450;
    st.full_camera_rays = 1600;
    lr_render_settings rs;
    lr_render_settings_default(&rs);
    char *j = lr_render_stats_json(&st, &rs, NULL);
    assert_non_null(j);
    /* What bench/ and the accuracy study read, in the spelling they use. */
    static const char *const want[] = {
        "{\"seconds\": 0.500000, \"cpu_seconds\": 0.750000",
        "\"width\": 640, \"height\": 480, \"spp\": 16",
        "\"threads\": 2",
        "\"samples\": 400",
        "\"rays\": 1000",
        "\"samples_per_second\": 800",
        "\"rays_per_second\": 2000",
        "\"nan_samples\": 0",
        ", \"plan\": {\"enabled\": true",
        "\"lens_pixels\": 0.2500",
        "\"full_samples\": 1600",
        "\"camera_rays\": 450",
        "\"full_camera_rays\": 1600",
        "\"lens_blocked\": 0",
        "\"light_paths\": 0",
        "\"light_landed\": 0",
        "\"ghost_landed\": 0",
        "\"ghost_flux\": 0}}"};
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
        if (strstr(j, want[i]) == NULL)
            fail_msg("%s lacks %s", j, want[i]);
    assert_null(strstr(j, "primitives"));
    lr_free(j);
    /* Without settings, their members are left out; a zero time divides
     * nothing by zero. */
    st.seconds = 0;
    st.pixels = 0;
    j = lr_render_stats_json(&st, NULL, NULL);
    assert_non_null(j);
    assert_null(strstr(j, "width"));
    assert_null(strstr(j, "enabled"));
    assert_null(strstr(j, "nan\""));
    assert_null(strstr(j, "inf"));
    lr_free(j);
    assert_null(lr_render_stats_json(NULL, NULL, NULL));
}

/* ---- settings back to JSON ---------------------------------------------- */

/* camera -> JSON -> camera (on the defaults) -> JSON must be a fixed
 * point, and the camera must come back field for field. */
static void camera_round_trip(const lr_camera *cam)
{
    char *a = lr_camera_json(cam);
    assert_non_null(a);
    lr_camera back;
    lr_camera_default(&back);
    lr_error err;
    if (lr_camera_apply_json(&back, a, strlen(a), &err) != LR_OK)
        fail_msg("%s does not read back: %s", a, err.message);
    char *b = lr_camera_json(&back);
    assert_non_null(b);
    assert_string_equal(a, b);
    assert_int_equal(back.model, cam->model);
    assert_memory_equal(back.position, cam->position, sizeof cam->position);
    assert_memory_equal(back.look_at, cam->look_at, sizeof cam->look_at);
    assert_true(back.fov == cam->fov);
    if (cam->model != LR_CAMERA_PINHOLE) {
        assert_int_equal(back.chromatic.mode, cam->chromatic.mode);
        assert_int_equal(back.chromatic.glass, cam->chromatic.glass);
        assert_int_equal(back.focus_on[0], cam->focus_on[0]);
    }
    lr_free(a);
    lr_free(b);
}

static void test_camera_json(void **state)
{
    (void)state;
    lr_camera c;
    lr_camera_default(&c);
    camera_round_trip(&c);
    c.model = LR_CAMERA_THINLENS;
    c.position[0] = 0.1; /* not exact in binary: must still come back */
    c.fov = 33.3;
    c.aperture_radius = 0.25;
    c.f_number = 2.8;
    c.focal_length_mm = 50;
    c.aperture_shape = LR_APERTURE_POLYGON;
    c.aperture_blades = 7;
    c.aperture_rotation = 12.5;
    c.aperture_ratio = 1.5;
    c.focus_on[0] = 3;
    c.focus_on[1] = 4;
    c.chromatic.mode = LR_CHROMATIC_SPECTRAL;
    c.chromatic.focal_model = LR_FOCAL_LENSMAKER;
    c.chromatic.glass = LR_GLASS_ABBE;
    c.chromatic.abbe_nd = 1.6;
    c.chromatic.abbe_vd = 40;
    c.chromatic.amplify = 20;
    c.chromatic.wavelengths = 12;
    camera_round_trip(&c);
    /* The last bit too: cJSON's %.15g wrote 0.30000000000000004 as 0.3
     * and 1.0000000000000002 as 1. */
    c.position[0] = 0.30000000000000004;
    c.position[1] = 1.0000000000000002;
    c.fov = nextafter(40.0, 41.0);
    camera_round_trip(&c);
    for (int g = LR_GLASS_BK7; g <= LR_GLASS_FUSED_SILICA; g++) {
        c.chromatic.glass = (lr_glass)g;
        camera_round_trip(&c);
    }
    c.model = LR_CAMERA_BRACKET;
    c.chromatic.mode = LR_CHROMATIC_RGB;
    c.image_plane_distance = 2;
    c.focal_length = 7;
    c.aperture = 0.1;
    camera_round_trip(&c);
}

static void test_render_settings_json(void **state)
{
    (void)state;
    lr_render_settings s;
    lr_render_settings_default(&s);
    for (int k = 0; k < 4; k++) {
        if (k == 3) {
            /* 2^53 - 1, the largest seed the JSON takes: it came back
             * 2^53 - 2 (cJSON's %.15g), and --remote rendered another
             * picture than the local render. */
            s.seed = 9007199254740991ull;
            s.adaptive_threshold = 0.1 + 0.2;
        } else if (k == 1) {
            s.sampler = LR_SAMPLER_GRID;
            s.seed = 12345678901ull;
            s.region[0] = 1, s.region[1] = 2, s.region[2] = 30,
            s.region[3] = 40;
            s.adaptive = 0;
            s.plan = 0;
            s.want_depth = 1;
        } else if (k == 2) {
            s.adaptive = 1;
            s.adaptive_threshold = 0.05;
            s.adaptive_min_spp = 8;
            s.sampler = LR_SAMPLER_JITTERED;
        }
        char *a = lr_render_settings_json(&s);
        assert_non_null(a);
        lr_render_settings back;
        lr_render_settings_default(&back);
        lr_error err;
        if (lr_render_settings_apply_json(&back, a, strlen(a), &err) != LR_OK)
            fail_msg("%s does not read back: %s", a, err.message);
        assert_memory_equal(&back, &s, sizeof s);
        lr_free(a);
    }
    /* Past 2^53 the JSON cannot carry the seed: 2^53 + 1 was written as
     * 2^53 (another image) and 2^64 - 1 as 1.8446744073709552e+19, which
     * apply_json refuses.  The struct's check refuses them too. */
    lr_error err;
    s.seed = (1ull << 53) + 1;
    assert_int_equal(lr_render_settings_validate(&s, &err), LR_ERR_INVALID);
    assert_string_equal(err.path, "render.seed");
    s.seed = UINT64_MAX;
    assert_int_equal(lr_render_settings_validate(&s, &err), LR_ERR_INVALID);
    s.seed = 1ull << 53;
    assert_int_equal(lr_render_settings_validate(&s, &err), LR_OK);
}

/* A camera from lr_camera_new (the bindings' camera, python/) is the
 * default camera, for every model; lr_camera_free(NULL) does nothing. */
static void test_camera_new(void **state)
{
    (void)state;
    lr_camera *heap = lr_camera_new();
    assert_non_null(heap);
    lr_camera local;
    lr_camera_default(&local);
    for (int m = 0; lr__camera_models[m] != NULL; m++) {
        heap->model = local.model = (lr_camera_model)m;
        char *a = lr_camera_json(heap), *b = lr_camera_json(&local);
        assert_string_equal(a, b);
        lr_free(a);
        lr_free(b);
    }
    lr_camera_free(heap);
    lr_camera_free(NULL);
}

/* The camera models' registry (camera.c) is the one list, and the public
 * API shows it whole: the daemon's GET /v1/options asks lr_camera_json to
 * write each lr_camera_model value in turn (service/inspect.c), and the
 * tests of the spec and the page compare their names with that list and
 * with the "must be one of" sentence checked here.  Each row's name
 * parses to its id and is written back as that name; a value no row has
 * is written "unknown"; a bad name's error lists the rows in order. */
static void test_camera_model_registry(void **state)
{
    (void)state;
    int n = 0, seen = 0;
    char list[256] = "";
    lr_camera cam;
    lr_error err;
    for (; lr__camera_models[n] != NULL; n++) {
        const lr__camera_model *m = lr__camera_models[n];
        assert_ptr_equal(lr__camera_model_named(m->name), m);
        assert_ptr_equal(lr__camera_model_of((lr_camera_model)n), m);
        assert_int_equal((int)lr__camera_model_id(m), n);
        snprintf(list + strlen(list), sizeof list - strlen(list), "%s\"%s\"",
                 n ? ", " : "", m->name);
        char json[128];
        snprintf(json, sizeof json, "{\"model\": \"%s\"}", m->name);
        /* A model may need more keys (the real lens its lens), but its
         * name is never the one refused. */
        lr_camera_default(&cam);
        if (lr_camera_apply_json(&cam, json, strlen(json), &err) == LR_OK)
            assert_int_equal((int)cam.model, n);
        else
            assert_string_not_equal(err.path, "camera.model");
    }
    assert_true(n >= 4);
    /* The models after "lens" keep their parameters in blocks of
     * lr_camera.model_params: every block fits, one after another, and no
     * two models' parameters share a key name (each is read once, by its
     * own model's block). */
    int end = 0;
    for (int m = 0; m < n; m++) {
        assert_int_equal(lr__camera_param_base(lr__camera_models[m]), end);
        for (const lr__camera_key *k = lr__camera_models[m]->keys;
             k->name != NULL; k++) {
            if (k->type != LR__KEY_PARAM)
                continue;
            assert_true(m > (int)LR_CAMERA_LENS);
            end++;
            for (int o = 0; o < n; o++)
                for (const lr__camera_key *q = lr__camera_models[o]->keys;
                     q->name != NULL; q++)
                    if (q != k && strcmp(q->name, k->name) == 0)
                        fail_msg("model %s's parameter %s is also model %s's "
                                 "key",
                                 lr__camera_models[m]->name, k->name,
                                 lr__camera_models[o]->name);
        }
    }
    assert_true(end <= LR_CAMERA_MODEL_PARAMS);
    /* The values inspect.c tries (0..63): each is a row's, or unknown. */
    for (int id = 0; id < 64; id++) {
        lr_camera_default(&cam);
        cam.model = (lr_camera_model)id;
        char *w = lr_camera_json(&cam);
        const lr__camera_model *m = lr__camera_model_of(cam.model);
        char want[64];
        snprintf(want, sizeof want, "\"model\":\"%s\"",
                 m != NULL ? m->name : "unknown");
        assert_non_null(strstr(w, want));
        lr_free(w);
        seen += m != NULL;
    }
    assert_int_equal(seen, n);
    const char *bad = "{\"model\": \"fisheye\"}";
    lr_camera_default(&cam);
    assert_int_equal(lr_camera_apply_json(&cam, bad, strlen(bad), &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.model");
    char want[300];
    snprintf(want, sizeof want,
             "camera.model must be one of %s, got \"fisheye\"", list);
    assert_string_equal(err.message, want);
}

/* The integrator registry (integrator.c) is the one list: each row's
 * name parses to its kind, is written back as that name, renders with
 * that row, and the first kind past the table is refused by the parser's
 * list and by the check alike. */
static void test_integrator_registry(void **state)
{
    (void)state;
    int n = 0;
    char list[256] = "";
    for (; lr__integrators[n] != NULL; n++) {
        const char *name = lr__integrators[n]->name;
        assert_ptr_equal(lr__integrator_for((lr_integrator_kind)n),
                         lr__integrators[n]);
        snprintf(list + strlen(list), sizeof list - strlen(list), "%s\"%s\"",
                 n ? ", " : "", name);
        char json[128];
        snprintf(json, sizeof json, "{\"integrator\": \"%s\"}", name);
        lr_render_settings s;
        lr_render_settings_default(&s);
        lr_error err;
        assert_int_equal(
            lr_render_settings_apply_json(&s, json, strlen(json), &err), LR_OK);
        assert_int_equal((int)s.integrator, n);
        char *back = lr_render_settings_json(&s);
        snprintf(json, sizeof json, "\"integrator\":\"%s\"", name);
        assert_non_null(strstr(back, json));
        lr_free(back);
    }
    assert_true(n >= 2 && n <= LR__MAX_INTEGRATORS);
    assert_null(lr__integrator_for((lr_integrator_kind)n));
    lr_render_settings s;
    lr_render_settings_default(&s);
    s.integrator = (lr_integrator_kind)n;
    lr_error err;
    assert_int_equal(lr_render_settings_validate(&s, &err), LR_ERR_INVALID);
    assert_string_equal(err.path, "render.integrator");
    char *w = lr_render_settings_json(&s);
    assert_non_null(strstr(w, "\"integrator\":\"unknown\""));
    lr_free(w);
    const char *bad = "{\"integrator\": \"bidir\"}";
    lr_render_settings_default(&s);
    assert_int_equal(lr_render_settings_apply_json(&s, bad, strlen(bad), &err),
                     LR_ERR_INVALID);
    char want[300];
    snprintf(want, sizeof want,
             "render.integrator must be one of %s, got \"bidir\"", list);
    assert_string_equal(err.message, want);
}

static void test_scene_description(void **state)
{
    (void)state;
    static const char with[] =
        "{\"description\": \"a \\u00e9 scene\", \"objects\": []}";
    lr_scene *s = NULL;
    assert_int_equal(
        lr_scene_load_json(with, strlen(with), NULL, NULL, 0, &s, NULL), LR_OK);
    assert_string_equal(lr_scene_description(s), "a \xc3\xa9 scene");
    lr_scene_free(s);
    assert_int_equal(lr_scene_load_json("{}", 2, NULL, NULL, 0, &s, NULL),
                     LR_OK);
    assert_string_equal(lr_scene_description(s), "");
    lr_scene_free(s);
}

/* ---- jobs ------------------------------------------------------------- */

static lr_status parse(const char *json, lr_job **job, lr_error *err)
{
    memset(err, 0, sizeof *err);
    return lr_job_parse(json, strlen(json), 64, job, err);
}

static void test_job_parse_errors(void **state)
{
    (void)state;
    static const struct {
        const char *json;
        lr_status status;
        const char *path; /* NULL: not checked */
    } cases[] = {
        {"", LR_ERR_SYNTAX, ""},
        {"{\"scene\": \"a\",", LR_ERR_SYNTAX, NULL},
        {"{\"scene\": \"a\"} x", LR_ERR_SYNTAX, NULL},
        {"{\"scene\": \"\xff\"}", LR_ERR_SYNTAX, NULL},
        {"[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["
         "[[[]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]"
         "]]]",
         LR_ERR_LIMIT, ""},
        {"[1]", LR_ERR_INVALID, ""},
        {"{}", LR_ERR_INVALID, "scene"},
        {"{\"scene\": 3}", LR_ERR_INVALID, "scene"},
        {"{\"scene\": \"a\", \"scene\": \"b\"}", LR_ERR_INVALID, "scene"},
        {"{\"scene\": \"a\", \"colour\": 1}", LR_ERR_INVALID, "colour"},
        {"{\"scene\": \"a\", \"camera\": 1}", LR_ERR_INVALID, "camera"},
        {"{\"scene\": \"a\", \"output\": []}", LR_ERR_INVALID, "output"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        lr_job *job = (lr_job *)1;
        lr_error err;
        lr_status st = parse(cases[i].json, &job, &err);
        if (st != cases[i].status)
            fail_msg("%s: status %d (%s), want %d", cases[i].json, st,
                     err.message, cases[i].status);
        assert_null(job);
        assert_int_equal(err.status, st);
        assert_true(err.message[0] != '\0');
        if (cases[i].path != NULL)
            assert_string_equal(err.path, cases[i].path);
    }
    /* Brackets inside strings are not nesting; a lower limit holds. */
    lr_job *job = NULL;
    lr_error err;
    /* A job's object that is not one says what it is. */
    assert_int_equal(
        parse("{\"scene\": \"a\", \"output\": \"png\"}", &job, &err),
        LR_ERR_INVALID);
    assert_string_equal(err.message,
                        "output must be an object, got the string \"png\"");
    assert_int_equal(parse("{\"scene\": \"[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["
                           "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\"}",
                           &job, &err),
                     LR_OK);
    assert_string_equal(lr_job_scene_name(job), "[[[[[[[[[[[[[[[[[[[[[[[[[[["
                                                "[[[[[[[[[[[[[[[[[[[[[[[[[["
                                                "[[[[[[[[[[[[[[[[[[[");
    lr_job_free(job);
    assert_int_equal(
        lr_job_parse("{\"scene\": {\"a\": [[1]]}}", 22, 2, &job, &err),
        LR_ERR_LIMIT);
    lr_job_free(NULL);
}

static void test_job_scene_and_meshes(void **state)
{
    (void)state;
    lr_job *job = NULL;
    lr_error err;
    assert_int_equal(parse("{\"scene\": {\"objects\": [{\"type\": \"sphere\"},"
                           " {\"type\": \"mesh\", \"file\": \"m/a.obj\"}, "
                           "{\"file\": \"\"}, {\"file\": \"b.obj\"}]}}",
                           &job, &err),
                     LR_OK);
    assert_null(lr_job_scene_name(job));
    size_t len = 0;
    const char *text = lr_job_scene_json(job, &len);
    assert_non_null(text);
    assert_int_equal(len, strlen(text));
    assert_non_null(strstr(text, "\"m/a.obj\""));
    const char *file, *field;
    assert_int_equal(lr_job_mesh_file(job, 0, &file, &field), 1);
    assert_string_equal(file, "m/a.obj");
    assert_string_equal(field, "scene.objects[1].file");
    assert_int_equal(lr_job_mesh_file(job, 1, &file, &field), 1);
    assert_string_equal(file, "b.obj");
    assert_string_equal(field, "scene.objects[3].file");
    assert_int_equal(lr_job_mesh_file(job, 2, &file, &field), 0);
    lr_job_free(job);
    /* The environment map is a file the scene reads too. */
    assert_int_equal(parse("{\"scene\": {\"environment\": {\"file\": "
                           "\"sky.exr\"}}}",
                           &job, &err),
                     LR_OK);
    assert_int_equal(lr_job_mesh_file(job, 0, &file, &field), 1);
    assert_string_equal(file, "sky.exr");
    assert_string_equal(field, "scene.environment.file");
    assert_int_equal(lr_job_mesh_file(job, 1, &file, &field), 0);
    lr_job_free(job);
}

/* Every key that names a file is listed, wherever it stands (a
 * material's texture too), and camera.lens, a plain name too (it is the
 * file of that name beside the scene when there is one: lensrayd read a
 * link out of its scenes directory that way). */
static void test_job_files_every_key(void **state)
{
    (void)state;
    lr_job *job = NULL;
    lr_error err;
    static const char hex[] = "sha256:0123456789abcdef0123456789abcdef"
                              "0123456789abcdef0123456789abcdef";
    char json[1024];
    snprintf(json, sizeof json,
             "{\"scene\": {\"camera\": {\"model\": \"lens\", \"lens\": \"%s\"},"
             " \"materials\": {\"m\": {\"diffuse_texture\": \"t.png\"}},"
             " \"environment\": {\"file\": \"%s\"}}}",
             hex, hex);
    assert_int_equal(parse(json, &job, &err), LR_OK);
    const char *file, *field;
    assert_int_equal(lr_job_mesh_file(job, 0, &file, &field), 1);
    assert_string_equal(file, hex);
    assert_string_equal(field, "scene.camera.lens");
    assert_int_equal(lr_job_mesh_file(job, 1, &file, &field), 1);
    assert_string_equal(file, "t.png");
    assert_string_equal(field, "scene.materials.m.diffuse_texture");
    assert_int_equal(lr_job_mesh_file(job, 2, &file, &field), 1);
    assert_string_equal(field, "scene.environment.file");
    assert_int_equal(lr_job_mesh_file(job, 3, &file, &field), 0);
    lr_job_free(job);
    assert_int_equal(parse("{\"scene\": {\"camera\": {\"lens\": "
                           "\"double-gauss-50\"}}}",
                           &job, &err),
                     LR_OK);
    assert_int_equal(lr_job_mesh_file(job, 0, &file, &field), 1);
    assert_string_equal(file, "double-gauss-50");
    assert_string_equal(field, "scene.camera.lens");
    assert_int_equal(lr_job_mesh_file(job, 1, &file, &field), 0);
    lr_job_free(job);
    /* The job's own camera's lens asset, first, beside a named scene too
     * (lensrayd checks it as it does the scene's). */
    snprintf(json, sizeof json,
             "{\"scene\": \"tiny\", \"camera\": {\"lens\": \"%s\"}}", hex);
    assert_int_equal(parse(json, &job, &err), LR_OK);
    assert_int_equal(lr_job_mesh_file(job, 0, &file, &field), 1);
    assert_string_equal(file, hex);
    assert_string_equal(field, "camera.lens");
    assert_int_equal(lr_job_mesh_file(job, 1, &file, &field), 0);
    lr_job_free(job);
    assert_true(lr_scene_file_key("file"));
    assert_true(lr_scene_file_key("roughness_texture"));
    assert_false(lr_scene_file_key("lens"));
    assert_false(lr_scene_file_key("material"));
}

/* "sha256:HEX" is found in the assets directory for every file key (a
 * mesh and a lens here), and refused, naming the field, without one,
 * when the asset is missing, or when the name is not a hash. */
static void test_asset_references(void **state)
{
    (void)state;
    char dir[] = "/tmp/lensray-assets-XXXXXX";
    assert_non_null(mkdtemp(dir));
    /* A quad stored under a made-up hash: the loader trusts the name
     * (the daemon checks it when the asset is PUT). */
    static const char quad[] = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                               "f 1 2 3\nf 1 3 4\n";
    static const char h1[] = "1111111111111111111111111111111111111111111111"
                             "111111111111111111";
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, h1);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(quad, f);
    fclose(f);
    char scene[512];
    snprintf(scene, sizeof scene,
             "{\"objects\": [{\"type\": \"mesh\", \"file\": \"sha256:%s\"}]}",
             h1);
    lr_scene *sc = NULL;
    lr_error err;
    unsetenv("LENSRAY_ASSETS_DIR");
    assert_int_equal(lr_assets_dir_set(NULL, &err), LR_OK);
    assert_int_equal(
        lr_scene_load_json(scene, strlen(scene), ".", NULL, 0, &sc, &err),
        LR_ERR_INVALID);
    assert_string_equal(err.path, "objects[0].file");
    assert_non_null(strstr(err.message, "no assets directory"));
    assert_int_equal(lr_assets_dir_set(dir, &err), LR_OK);
    assert_int_equal(
        lr_scene_load_json(scene, strlen(scene), ".", NULL, 0, &sc, &err),
        LR_OK);
    lr_scene_free(sc);
    /* The asset's own messages name it by its reference, not the path. */
    scene[strlen(scene) - 5] = '2';
    assert_int_equal(
        lr_scene_load_json(scene, strlen(scene), ".", NULL, 0, &sc, &err),
        LR_ERR_INVALID);
    assert_string_equal(err.path, "objects[0].file");
    assert_non_null(strstr(err.message, "there is no asset sha256:"));
    assert_null(strstr(err.message, dir));
    const char *bad = "{\"objects\": [{\"type\": \"mesh\", \"file\": "
                      "\"sha256:ABC\"}]}";
    assert_int_equal(
        lr_scene_load_json(bad, strlen(bad), ".", NULL, 0, &sc, &err),
        LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "64 lowercase hex digits"));
    /* Lens assets: each form (lensray JSON, Zemax, pbrt) is read from
     * the bytes, since the name says nothing. */
    static const char *const lenses[] = {"lenses/double-gauss-50.json",
                                         "tests/data/lenses/cooke-triplet.zmx",
                                         "tests/data/lenses/dgauss.50mm.dat"};
    for (size_t k = 0; k < 3; k++) {
        char hex[65];
        snprintf(hex, sizeof hex, "%064zu", k + 7);
        snprintf(path, sizeof path, "%s/%s", dir, hex);
        FILE *in = fopen(lenses[k], "rb"), *out = fopen(path, "wb");
        assert_non_null(in);
        assert_non_null(out);
        char buf[4096];
        for (size_t n = fread(buf, 1, sizeof buf, in); n > 0;
             n = fread(buf, 1, sizeof buf, in))
            assert_int_equal(fwrite(buf, 1, n, out), n);
        fclose(in);
        fclose(out);
        snprintf(scene, sizeof scene,
                 "{\"camera\": {\"model\": \"lens\", \"lens\": \"sha256:%s\"}}",
                 hex);
        if (lr_scene_load_json(scene, strlen(scene), ".", NULL, 0, &sc, &err) !=
            LR_OK)
            fail_msg("%s as an asset: %s", lenses[k], err.message);
        lr_camera cam;
        lr_scene_camera(sc, &cam);
        assert_non_null(cam.lens);
        lr_scene_free(sc);
        unlink(path);
    }
    assert_int_equal(lr_assets_dir_set(NULL, &err), LR_OK);
    snprintf(path, sizeof path, "%s/%s", dir, h1);
    unlink(path);
    rmdir(dir);
}

/* Applies a job on top of the defaults with the scene's depth `scene_z`;
 * returns the status, the error path in err. */
static lr_status apply(const char *json, int scene_z, lr_render_settings *s,
                       lr_output *o, lr_error *err)
{
    lr_job *job = NULL;
    assert_int_equal(parse(json, &job, err), LR_OK);
    lr_camera cam;
    lr_camera_default(&cam);
    lr_render_settings_default(s);
    s->want_depth = scene_z;
    lr_output_default(o);
    lr_status st = lr_job_apply(job, &cam, s, o, err);
    lr_job_free(job);
    return st;
}

static void test_job_apply_depth(void **state)
{
    (void)state;
    lr_render_settings s;
    lr_output o;
    lr_error err;
    /* The job's render.depth with PNG is refused like output.depth. */
    assert_int_equal(apply("{\"scene\": \"a\", \"render\": {\"depth\": true}}",
                           0, &s, &o, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "render.depth");
    assert_int_equal(apply("{\"scene\": \"a\", \"output\": {\"depth\": true}}",
                           0, &s, &o, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "output.depth");
    /* A scene's own depth is a default that PNG leaves out. */
    assert_int_equal(apply("{\"scene\": \"a\"}", 1, &s, &o, &err), LR_OK);
    assert_int_equal(s.want_depth, 0);
    assert_int_equal(o.options.exr_depth, 0);
    /* With EXR: the scene's default, the job's render.depth, and
     * output.depth deciding over both. */
    const char *exr = "{\"scene\": \"a\", \"output\": {\"format\": \"exr\"}}";
    assert_int_equal(apply(exr, 1, &s, &o, &err), LR_OK);
    assert_int_equal(s.want_depth, 1);
    assert_int_equal(o.options.exr_depth, 1);
    assert_int_equal(apply(exr, 0, &s, &o, &err), LR_OK);
    assert_int_equal(s.want_depth, 0);
    assert_int_equal(apply("{\"scene\": \"a\", \"render\": {\"depth\": true}, "
                           "\"output\": {\"format\": \"exr\"}}",
                           0, &s, &o, &err),
                     LR_OK);
    assert_int_equal(s.want_depth, 1);
    assert_int_equal(apply("{\"scene\": \"a\", \"render\": {\"depth\": true}, "
                           "\"output\": {\"format\": \"exr\", \"depth\": "
                           "false}}",
                           1, &s, &o, &err),
                     LR_OK);
    assert_int_equal(s.want_depth, 0);
    assert_int_equal(o.options.exr_depth, 0);
    /* Errors name the job's field. */
    assert_int_equal(apply("{\"scene\": \"a\", \"camera\": {\"fov\": 500}}", 0,
                           &s, &o, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.fov");
    assert_int_equal(apply("{\"scene\": \"a\", \"render\": {\"region\": "
                           "[0, 0, 9999, 1]}}",
                           0, &s, &o, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "render.region");
}

/* NULL where the header allows nothing else gives the defaults, 0, ""
 * or an error, never a crash (an independent check found nine calls
 * that dereferenced it): reliability.md's "every public call checks its
 * input". */
static void test_null_arguments(void **state)
{
    (void)state;
    lr_camera_default(NULL);
    lr_render_settings_default(NULL);
    lr_progress_store(NULL, 1, 2);
    lr_camera cam, dcam;
    lr_camera_default(&dcam);
    memset(&cam, 0x5a, sizeof cam);
    lr_scene_camera(NULL, &cam);
    assert_memory_equal(&cam, &dcam, sizeof cam);
    lr_scene_camera(NULL, NULL);
    lr_render_settings rs, drs;
    lr_render_settings_default(&drs);
    memset(&rs, 0x5a, sizeof rs);
    lr_scene_settings(NULL, &rs);
    assert_memory_equal(&rs, &drs, sizeof rs);
    lr_scene_settings(NULL, NULL);
    assert_int_equal(lr_scene_primitive_count(NULL), 0);
    assert_string_equal(lr_scene_description(NULL), "");
    const char *json = "{\"objects\": []}";
    const char *ov[2] = {"render.spp=4", NULL};
    lr_scene *sc = (lr_scene *)&cam;
    lr_error err;
    assert_int_equal(
        lr_scene_load_json(json, strlen(json), NULL, NULL, 2, &sc, &err),
        LR_ERR_INVALID);
    assert_null(sc);
    assert_int_equal(
        lr_scene_load_json(json, strlen(json), NULL, ov, 2, &sc, &err),
        LR_ERR_INVALID);
    assert_string_equal(err.message, "override 1 of 2 is NULL");
    char path[512];
    lr_test_write_text("null-ov.json", json, path, sizeof path);
    assert_int_equal(lr_scene_load_file(path, ov, 2, &sc, &err),
                     LR_ERR_INVALID);
    assert_int_equal(lr_scene_read_settings(path, NULL, 1, &cam, &rs, &err),
                     LR_ERR_INVALID);
    assert_int_equal(lr_scene_load_file(path, ov, 1, &sc, &err), LR_OK);
    assert_int_equal(lr_scene_primitive_count(sc), 0);
    lr_scene_free(sc);
}

static const struct CMUnitTest tests[] = {
    cmocka_unit_test(test_format_table),
    cmocka_unit_test(test_output_json),
    cmocka_unit_test(test_stats_json),
    cmocka_unit_test(test_camera_json),
    cmocka_unit_test(test_render_settings_json),
    cmocka_unit_test(test_camera_new),
    cmocka_unit_test(test_camera_model_registry),
    cmocka_unit_test(test_integrator_registry),
    cmocka_unit_test(test_scene_description),
    cmocka_unit_test(test_null_arguments),
    cmocka_unit_test(test_job_parse_errors),
    cmocka_unit_test(test_job_scene_and_meshes),
    cmocka_unit_test(test_job_files_every_key),
    cmocka_unit_test(test_asset_references),
    cmocka_unit_test(test_job_apply_depth),
};
LR_TEST_GROUP(shared_rules, tests)
