/*
 * test_scene_validation.c: the scene loader refuses bad values in every
 * field of the format, each with an error that names the field: a value of
 * every JSON type a field does not accept, NaN and infinity however spelled
 * and numbers that overflow a double, duplicate keys at every level,
 * missing required keys and out-of-range values.  The table of fields is
 * lr_test_fields (tests/helpers.c), shared with test_ray_limits.c.
 */
#include "test.h"

#include <stdio.h>
#include <string.h>

/* A value of every JSON type in every field: the types a field does not
 * accept fail with an error that names the field. */
static void test_every_type_error(void **state)
{
    (void)state;
    static const struct {
        int type;
        const char *text;
    } values[] = {{LR_TEST_NUM, "3"},         {LR_TEST_NUM, "-0.5"},
                  {LR_TEST_STR, "\"x\""},     {LR_TEST_STR, "\"\""},
                  {LR_TEST_BOOL, "true"},     {LR_TEST_BOOL, "false"},
                  {LR_TEST_NULL, "null"},     {LR_TEST_ARR, "[]"},
                  {LR_TEST_ARR, "[1, 2]"},    {LR_TEST_OBJ, "{}"},
                  {LR_TEST_OBJ, "{\"k\": 1}"}};
    size_t tried = 0;
    for (size_t i = 0; i < lr_test_n_fields; i++)
        for (size_t v = 0; v < sizeof values / sizeof values[0]; v++) {
            if (lr_test_fields[i].accepts & values[v].type)
                continue;
            char json[1024], what[512];
            lr_test_field_json(i, values[v].text, json, sizeof json);
            snprintf(what, sizeof what, "%s = %s", lr_test_fields[i].path,
                     values[v].text);
            lr_test_expect_invalid(json, strlen(json), lr_test_fields[i].path,
                                   what);
            tried++;
        }
    print_message("type errors: %zu cases\n", tried);
}

/* NaN and infinity however spelled: JSON has no such literals, so the
 * spellings are syntax errors (with a line and column), and overflowing
 * numbers are errors naming the field. */
static void test_nan_inf_spellings(void **state)
{
    (void)state;
    static const char *const syntax[] = {"NaN",
                                         "nan",
                                         "-nan",
                                         "+nan",
                                         "NAN",
                                         "Infinity",
                                         "-Infinity",
                                         "+Infinity",
                                         "infinity",
                                         "inf",
                                         "-inf",
                                         "+inf",
                                         "INF",
                                         "Inf",
                                         "1.#INF",
                                         "1.#QNAN",
                                         "0x7ff0000000000000",
                                         "1e",
                                         "--1",
                                         "nan(0x1)",
                                         "\"\\u0000\"",
                                         "0/0"};
    static const char *const overflow[] = {
        "1e999",
        "-1e999",
        "1e400",
        "-1E+309",
        "1e308000",
        "1797693134862315807937289714053034150799341327100378269361737789804449"
        "6829276475094664901797758720709633028641669288791094655554785194040263"
        "0657488671505820681908902000708383676273854845817711531764475730270069"
        "8555713669596228429148198608349364752927190741684443655107043427115596"
        "99508093042880177904174497792"};
    size_t tried = 0;
    for (size_t i = 0; i < lr_test_n_fields; i++) {
        if (!(lr_test_fields[i].accepts & LR_TEST_NUM))
            continue;
        for (size_t k = 0; k < sizeof syntax / sizeof syntax[0]; k++) {
            char json[1024], what[256];
            lr_test_field_json(i, syntax[k], json, sizeof json);
            snprintf(what, sizeof what, "%s = %s", lr_test_fields[i].path,
                     syntax[k]);
            /* Syntax errors have no field path but a line and column;
             * "\u0000" is a string, so a type error or the NUL refusal. */
            lr_test_expect_invalid(json, strlen(json), NULL, what);
            tried++;
        }
        for (size_t k = 0; k < sizeof overflow / sizeof overflow[0]; k++) {
            char json[2048], what[256];
            lr_test_field_json(i, overflow[k], json, sizeof json);
            snprintf(what, sizeof what, "%s = %.20s", lr_test_fields[i].path,
                     overflow[k]);
            lr_test_expect_invalid(json, strlen(json), lr_test_fields[i].path,
                                   what);
            tried++;
        }
    }
    /* In arrays too: a colour component, a vertex coordinate. */
    lr_test_expect_invalid("{\"background\": [0, 1e999, 0]}", 29, "background",
                           "background[1] = 1e999");
    print_message("NaN/Inf spellings: %zu cases\n", tried + 1);
}

/* A duplicate key at every level is an error naming it. */
static void test_duplicate_keys(void **state)
{
    (void)state;
    static const struct {
        const char *json, *path;
    } dups[] = {
        {"{\"camera\": {}, \"camera\": {}}", "camera"},
        {"{\"description\": \"a\", \"description\": \"b\"}", "description"},
        {"{\"objects\": [], \"objects\": []}", "objects"},
        {"{\"camera\": {\"fov\": 30, \"fov\": 30}}", "camera.fov"},
        {"{\"camera\": {\"focus_on\": null, \"focus_on\": [1, 1]}}",
         "camera.focus_on"},
        {"{\"camera\": {\"chromatic\": {\"mode\": \"rgb\", \"mode\": "
         "\"off\"}}}",
         "camera.chromatic.mode"},
        {"{\"camera\": {\"chromatic\": {\"abbe\": {\"n_d\": 1.5, \"V_d\": 50, "
         "\"V_d\": 40}}}}",
         "camera.chromatic.abbe.V_d"},
        {"{\"render\": {\"spp\": 1, \"spp\": 2}}", "render.spp"},
        {"{\"render\": {\"region\": [0,0,1,1], \"region\": [0,0,2,2]}}",
         "render.region"},
        {"{\"materials\": {\"m\": {}, \"m\": {}}}", "materials.m"},
        {"{\"materials\": {\"m\": {\"ior\": 1.5, \"ior\": 1.6}}}",
         "materials.m.ior"},
        {"{\"lights\": [{\"type\": \"ambient\", \"radiance\": 1, \"radiance\": "
         "2}]}",
         "lights[0].radiance"},
        {"{\"lights\": [{\"type\": \"ambient\", \"type\": \"point\", "
         "\"radiance\": 1}]}",
         "lights[0].type"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], "
         "\"radius\": 1, \"radius\": 2}]}",
         "objects[0].radius"},
        {"{\"objects\": [{\"type\": \"sphere\", \"type\": \"plane\", "
         "\"center\": [0,0,0], \"radius\": 1}]}",
         "objects[0].type"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], "
         "\"radius\": 1, \"transform\": [{\"scale\": 1, \"scale\": 2}]}]}",
         "objects[0].transform[0]"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], "
         "\"radius\": 1, \"transform\": [{\"rotate\": {\"axis\": [0,1,0], "
         "\"degrees\": 1, \"degrees\": 2}}]}]}",
         "objects[0].transform[0].rotate.degrees"},
        {"{\"objects\": [{\"type\": \"mesh\", \"file\": \"a.obj\", \"file\": "
         "\"b.obj\"}]}",
         "objects[0].file"},
    };
    for (size_t i = 0; i < sizeof dups / sizeof dups[0]; i++)
        lr_test_expect_invalid(dups[i].json, strlen(dups[i].json), dups[i].path,
                               dups[i].json);
    /* Through the camera and render objects of a job, too. */
    lr_camera cam;
    lr_camera_default(&cam);
    lr_error err;
    const char *cj = "{\"fov\": 30, \"fov\": 31}";
    assert_int_equal(lr_camera_apply_json(&cam, cj, strlen(cj), &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.fov");
    lr_render_settings rs;
    lr_render_settings_default(&rs);
    const char *rj = "{\"spp\": 3, \"spp\": 3}";
    assert_int_equal(lr_render_settings_apply_json(&rs, rj, strlen(rj), &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "render.spp");
}

/* Missing required keys and out-of-range values, a few of each kind the
 * loader checks (test_scene.c covers the common ones). */
static void test_missing_and_out_of_range(void **state)
{
    (void)state;
    static const struct {
        const char *json, *path;
    } cases[] = {
        {"{\"lights\": [{\"type\": \"directional\", \"direction\": [0,-1,0]}]}",
         "lights[0].irradiance"},
        {"{\"lights\": [{\"type\": \"directional\", \"irradiance\": 1}]}",
         "lights[0].direction"},
        {"{\"lights\": [{\"type\": \"ambient\"}]}", "lights[0].radiance"},
        {"{\"objects\": [{\"type\": \"plane\"}]}", "objects[0].normal"},
        {"{\"objects\": [{\"type\": \"triangle\"}]}", "objects[0].vertices"},
        {"{\"objects\": [{\"type\": \"sphere\", \"radius\": 1}]}",
         "objects[0].center"},
        {"{\"camera\": {\"chromatic\": {\"abbe\": {\"n_d\": 1.5}}}}",
         "camera.chromatic.abbe.V_d"},
        {"{\"camera\": {\"chromatic\": {\"abbe\": {\"V_d\": 50}}}}",
         "camera.chromatic.abbe.n_d"},
        {"{\"camera\": {\"fov\": -1e-300}}", "camera.fov"},
        {"{\"camera\": {\"focus_distance\": 0}}", "camera.focus_distance"},
        {"{\"camera\": {\"focus_distance\": -4e-324}}",
         "camera.focus_distance"},
        {"{\"camera\": {\"aperture_blades\": 65}}", "camera.aperture_blades"},
        {"{\"camera\": {\"aperture_blades\": 2.5}}", "camera.aperture_blades"},
        {"{\"camera\": {\"aperture_ratio\": 100.00001}}",
         "camera.aperture_ratio"},
        {"{\"camera\": {\"focus_on\": [-1, 0]}}", "camera.focus_on"},
        {"{\"camera\": {\"focus_on\": [65536, 0]}}", "camera.focus_on"},
        {"{\"camera\": {\"focus_on\": [1, 2, 3]}}", "camera.focus_on"},
        {"{\"camera\": {\"chromatic\": {\"ior\": [1, 1.5, 1.5]}}}",
         "camera.chromatic.ior"},
        {"{\"camera\": {\"chromatic\": {\"ior\": [1.5, 1.5, 4]}}}",
         "camera.chromatic.ior"},
        {"{\"camera\": {\"chromatic\": {\"amplify\": -1e-300}}}",
         "camera.chromatic.amplify"},
        {"{\"camera\": {\"chromatic\": {\"amplify\": 1000000.0001}}}",
         "camera.chromatic.amplify"},
        {"{\"camera\": {\"chromatic\": {\"wavelengths\": 0}}}",
         "camera.chromatic.wavelengths"},
        {"{\"camera\": {\"chromatic\": {\"wavelengths\": 65}}}",
         "camera.chromatic.wavelengths"},
        {"{\"camera\": {\"chromatic\": {\"abbe\": {\"n_d\": 4, \"V_d\": 50}}}}",
         "camera.chromatic.abbe.n_d"},
        {"{\"camera\": {\"chromatic\": {\"abbe\": {\"n_d\": 1.5, \"V_d\": "
         "0.5}}}}",
         "camera.chromatic.abbe.V_d"},
        {"{\"camera\": {\"model\": \"thinlens\", \"chromatic\": {\"mode\": "
         "\"rgb\"}}}",
         "camera.focal_length_mm"},
        {"{\"camera\": {\"model\": \"thinlens\", \"focal_length_mm\": 50, "
         "\"focus_distance\": 0.05, \"chromatic\": {\"mode\": \"rgb\"}}}",
         "camera.focus_distance"},
        {"{\"render\": {\"width\": 65537}}", "render.width"},
        {"{\"render\": {\"width\": 4294967297}}", "render.width"},
        {"{\"render\": {\"width\": -1}}", "render.width"},
        {"{\"render\": {\"spp\": 1048577}}", "render.spp"},
        {"{\"render\": {\"seed\": 9007199254740994}}", "render.seed"},
        {"{\"render\": {\"seed\": 1e300}}", "render.seed"},
        {"{\"render\": {\"threads\": 1025}}", "render.threads"},
        {"{\"render\": {\"tile_size\": 4097}}", "render.tile_size"},
        {"{\"render\": {\"max_depth\": -1}}", "render.max_depth"},
        {"{\"render\": {\"region\": [0, 0, 0, 0, 0]}}", "render.region"},
        {"{\"render\": {\"region\": [0, 0, 1e300, 1]}}", "render.region"},
        {"{\"render\": {\"region\": [0, 0, -1, 1]}}", "render.region"},
        {"{\"render\": {\"region\": [0, 0, 1.5, 1]}}", "render.region"},
        {"{\"render\": {\"width\": 10, \"region\": [5, 0, 5, 1]}}",
         "render.region"},
        {"{\"render\": {\"width\": 10, \"region\": [0, 0, 11, 1]}}",
         "render.region"},
        {"{\"materials\": {\"m\": {\"shininess\": 1000001}}}",
         "materials.m.shininess"},
        {"{\"materials\": {\"m\": {\"ior\": 10.000001}}}", "materials.m.ior"},
        {"{\"materials\": {\"m\": {\"ior\": 0.999999}}}", "materials.m.ior"},
        {"{\"materials\": {\"m\": {\"reflect\": [0, -4e-324, 0]}}}",
         "materials.m.reflect"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], "
         "\"radius\": 0}]}",
         "objects[0].radius"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], "
         "\"radius\": 1, \"transform\": [{\"scale\": [1, 1, 0]}]}]}",
         "objects[0].transform[0].scale"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], "
         "\"radius\": 1, \"transform\": [{\"scale\": [1, 1, -1]}, {\"scale\": "
         "[2, 1, 1]}]}]}",
         "objects[0].transform"},
        {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0,1,0], \"size\": "
         "[1, 0]}]}",
         "objects[0].size"},
        {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0,1,0], \"size\": "
         "[1, 2, 3]}]}",
         "objects[0].size"},
        {"{\"objects\": [{\"type\": \"plane\", \"normal\": [4e-324, 0, 0]}]}",
         "objects[0].normal"},
        /* Its film in floats lost it: a segfault, the daemon's too. */
        {"{\"camera\": {\"model\": \"lens\", \"lens\": \"petzval\", "
         "\"sensor_width_mm\": 1e-37}}",
         "camera.sensor_width_mm"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        lr_test_expect_invalid(cases[i].json, strlen(cases[i].json),
                               cases[i].path, cases[i].json);
    /* The message gives the range, at either end of it. */
    static const char *const focus_on[][2] = {
        {"{\"camera\": {\"focus_on\": [65536, 0]}}", "got 65536"},
        {"{\"camera\": {\"focus_on\": [0, -1]}}", "got -1"},
        {"{\"camera\": {\"focus_on\": [0, 2.5]}}", "got 2.5"}};
    for (size_t i = 0; i < 3; i++) {
        lr_scene *sc = NULL;
        lr_error err;
        assert_int_equal(lr_scene_load_json(focus_on[i][0],
                                            strlen(focus_on[i][0]), NULL, NULL,
                                            0, &sc, &err),
                         LR_ERR_INVALID);
        if (strstr(err.message, "a whole number from 0 to 65535") == NULL ||
            strstr(err.message, focus_on[i][1]) == NULL)
            fail_msg("%s: %s", focus_on[i][0], err.message);
    }
}

/* Every error's path is the field its sentence starts with, cross-field
 * rules included: scene-format.md once listed three of these as naming
 * another field (camera.chromatic.abbe, camera.chromatic.ior, and an
 * f_number sentence); the path is exact here, not a prefix. */
static void test_cross_field_errors_start_with_their_path(void **state)
{
    (void)state;
    static const char *const cases[][2] = {
        {"{\"camera\": {\"model\": \"thinlens\", \"f_number\": 2}}",
         "camera.focal_length_mm"},
        {"{\"camera\": {\"chromatic\": {\"glass\": \"F2\", "
         "\"abbe\": {\"n_d\": 1.5, \"V_d\": 40}}}}",
         "camera.chromatic"},
        {"{\"camera\": {\"chromatic\": {\"ior\": [1.5, 1, 1.5]}}}",
         "camera.chromatic.ior[1]"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        lr_scene *sc = NULL;
        lr_error err;
        assert_int_equal(lr_scene_load_json(cases[i][0], strlen(cases[i][0]),
                                            NULL, NULL, 0, &sc, &err),
                         LR_ERR_INVALID);
        assert_string_equal(err.path, cases[i][1]);
        lr_test_expect_invalid(cases[i][0], strlen(cases[i][0]), cases[i][1],
                               cases[i][0]);
    }
}

static const struct CMUnitTest scene_validation_tests[] = {
    cmocka_unit_test(test_every_type_error),
    cmocka_unit_test(test_nan_inf_spellings),
    cmocka_unit_test(test_duplicate_keys),
    cmocka_unit_test(test_missing_and_out_of_range),
    cmocka_unit_test(test_cross_field_errors_start_with_their_path),
};

LR_TEST_GROUP(scene_validation, scene_validation_tests)
