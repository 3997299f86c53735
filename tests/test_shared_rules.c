/*
 * test_shared_rules.c: the rules the CLI and the daemon take from the
 * library rather than keep themselves: the format table (format.c), the
 * output object (output.c), stats as JSON (stats.c), the camera and
 * settings written back as JSON (settings_json.c), the scene's
 * description, and a job parsed once (job.c).
 */
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- formats ---------------------------------------------------------- */

static void test_format_table(void **state)
{
    (void)state;
    int n = 0;
    for (lr_format f = 0; lr_format_name(f) != NULL; f++, n++) {
        lr_format back = (lr_format)-1;
        assert_int_equal(lr_format_from_name(lr_format_name(f), NULL, &back,
                                             NULL),
                         LR_OK);
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
    assert_int_equal(lr_format_from_name(NULL, NULL, &f, &err),
                     LR_ERR_INVALID);
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
        {"[]", "output"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        lr_output before;
        lr_output_default(&before);
        o = before;
        memset(&err, 0, sizeof err);
        if (lr_output_apply_json(&o, bad[i].json, strlen(bad[i].json),
                                 &err) != LR_ERR_INVALID)
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
        "\"threads\": 2", "\"samples\": 400", "\"rays\": 1000",
        "\"samples_per_second\": 800", "\"rays_per_second\": 2000",
        "\"nan_samples\": 0", ", \"plan\": {\"enabled\": true",
        "\"lens_pixels\": 0.2500", "\"full_samples\": 1600",
        "\"camera_rays\": 450", "\"full_camera_rays\": 1600",
        "\"lens_blocked\": 0}}"};
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
    for (int k = 0; k < 3; k++) {
        if (k == 1) {
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
}

static void test_scene_description(void **state)
{
    (void)state;
    static const char with[] =
        "{\"description\": \"a \\u00e9 scene\", \"objects\": []}";
    lr_scene *s = NULL;
    assert_int_equal(lr_scene_load_json(with, strlen(with), NULL, NULL, 0,
                                        &s, NULL),
                     LR_OK);
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
    assert_int_equal(parse("{\"scene\": \"[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["
                           "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\"}",
                           &job, &err),
                     LR_OK);
    assert_string_equal(lr_job_scene_name(job), "[[[[[[[[[[[[[[[[[[[[[[[[[[["
                                                "[[[[[[[[[[[[[[[[[[[[[[[[[["
                                                "[[[[[[[[[[[[[[[[[[[");
    lr_job_free(job);
    assert_int_equal(lr_job_parse("{\"scene\": {\"a\": [[1]]}}", 22, 2, &job,
                                  &err),
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

static const struct CMUnitTest tests[] = {
    cmocka_unit_test(test_format_table),
    cmocka_unit_test(test_output_json),
    cmocka_unit_test(test_stats_json),
    cmocka_unit_test(test_camera_json),
    cmocka_unit_test(test_render_settings_json),
    cmocka_unit_test(test_scene_description),
    cmocka_unit_test(test_job_parse_errors),
    cmocka_unit_test(test_job_scene_and_meshes),
    cmocka_unit_test(test_job_apply_depth),
};
LR_TEST_GROUP(shared_rules, tests)
