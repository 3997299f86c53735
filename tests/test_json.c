/*
 * test_json.c: parsing JSON text (lr__json_parse and overrides, in
 * lib/json/json_util.c): syntax errors stay syntax errors, a value that is not
 * JSON is a string, and a number too large for a double (1e400) is
 * refused as written, naming its field, in a scene, an override and
 * lr_camera_apply_json alike.
 *
 * That an allocation failure inside cJSON comes back as LR_ERR_NOMEM is
 * tested by tests/oom, which fails every allocation cJSON makes for the
 * library through the library's own cJSON hooks (a test that installed
 * hooks of its own would replace them).
 */
#include "test.h"
#include "camera/camera_json.h"
#include "json/json_util.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char scene_json[] =
    "{\"description\": \"caf\\u00e9\", \"camera\": {\"position\": [0, 1, 5], "
    "\"look_at\": [0, 0, 0], \"fov\": 40, \"model\": \"thinlens\"}, "
    "\"render\": {\"width\": 8, \"height\": 8}, \"materials\": {\"m\": "
    "{\"diffuse\": 0.5}}, \"objects\": [{\"type\": \"sphere\", "
    "\"center\": [0, 0, 0], \"radius\": 1, \"material\": \"m\"}]}";

/* A syntax error is INVALID with a line, an override that is not JSON a
 * string. */
static void test_syntax_errors_stay_invalid(void **state)
{
    (void)state;
    lr_scene *s = NULL;
    lr_error err;
    const char bad[] = "{\"camera\": {\"fov\": 40,}}";
    assert_int_equal(
        lr_scene_load_json(bad, strlen(bad), NULL, NULL, 0, &s, &err),
        LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "invalid JSON at line 1"));
    /* A value that is not JSON is a string, so a bad number names it. */
    const char *sets[] = {"camera.fov=40deg"};
    assert_int_equal(lr_scene_load_json(scene_json, strlen(scene_json), NULL,
                                        sets, 1, &s, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "the string \"40deg\""));
    const char *name[] = {"camera.model=pinhole"};
    assert_int_equal(lr_scene_load_json(scene_json, strlen(scene_json), NULL,
                                        name, 1, &s, &err),
                     LR_OK);
    lr_scene_free(s);
}

/* An empty scene file, or one of white space only, says so: it was
 * "invalid JSON at line 1, column 1", which points at a character that
 * is not there.  (The daemon's empty job has its own message, job.c.) */
static void test_empty_text_says_empty(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_file("blank.json", " \n\t\n", 4, path, sizeof path);
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_file(path, NULL, 0, &s, &err),
                     LR_ERR_INVALID);
    /* Gone at once: the shared temporary directory serves as another
     * group's lens directory. */
    remove(path);
    assert_non_null(strstr(err.message, "blank.json: empty (only white "
                                        "space), not a JSON value"));
    assert_int_equal(lr_scene_load_json("", 0, NULL, NULL, 0, &s, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "empty (0 bytes)"));
}

/* RFC 8259's number grammar: cJSON reads numbers with strtod, which also
 * takes a leading zero ("016", octal in other readers) and a bare point
 * ("2.", "1.e3"); those are syntax errors at their line and column, and
 * the numbers JSON allows still load. */
static void test_numbers_follow_rfc8259(void **state)
{
    (void)state;
    static const char *const bad[] = {"016",  "-016",  "00",  "2.",
                                      "1.e3", "-0.e1", "01.5"};
    static const char *const good[] = {"0",    "-0",      "0.5", "1e2",
                                       "1E+2", "-1.5e-3", "30",  "0e0"};
    char text[128];
    lr_scene *s = NULL;
    lr_error err;
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        snprintf(text, sizeof text,
                 "{\"render\": {\"seed\": 1},\n"
                 "\"camera\": {\"fov\": %s}}",
                 bad[i]);
        assert_int_equal(
            lr_scene_load_json(text, strlen(text), NULL, NULL, 0, &s, &err),
            LR_ERR_INVALID);
        if (strstr(err.message, "not a JSON number") == NULL ||
            strstr(err.message, "line 2, column 19") == NULL)
            fail_msg("%s: %s", bad[i], err.message);
    }
    for (size_t i = 0; i < sizeof good / sizeof *good; i++) {
        snprintf(text, sizeof text,
                 "{\"description\": \"016 in a "
                 "string\", \"render\": {\"seed\": %s}}",
                 good[i]);
        lr_status st = lr_scene_load_json(text, strlen(text), NULL, NULL, 0, &s,
                                          &err);
        /* -1.5e-3 and 1e2 load or fail on the seed's range, never on
         * the syntax. */
        if (st != LR_OK && strstr(err.message, "render.seed") == NULL)
            fail_msg("%s: %s", good[i], err.message);
        if (st == LR_OK)
            lr_scene_free(s);
    }
    /* An override's value that is not JSON is a string, as "40deg" is. */
    const char *sets[] = {"camera.fov=016"};
    assert_int_equal(lr_scene_load_json(scene_json, strlen(scene_json), NULL,
                                        sets, 1, &s, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "the string \"016\""));
}

/* Loads `json` with `set` as its one override (or none) and expects an
 * error at `path` whose message holds each of `want` (NULL-ended). */
static void expect_error(const char *json, const char *set, const char *path,
                         const char *const *want)
{
    lr_scene *s = NULL;
    lr_error err;
    const char *sets[] = {set};
    lr_status st = lr_scene_load_json(json, strlen(json), NULL, sets,
                                      set ? 1 : 0, &s, &err);
    if (st != LR_ERR_INVALID)
        fail_msg("%s (%s): status %d, \"%s\"", json, set ? set : "", (int)st,
                 st == LR_OK ? "" : err.message);
    assert_null(s);
    assert_string_equal(err.path, path);
    for (size_t i = 0; want[i] != NULL; i++)
        if (strstr(err.message, want[i]) == NULL)
            fail_msg("%s: \"%s\" lacks \"%s\"", json, err.message, want[i]);
}

/* Issue 11: "fov": 1e400 said "camera.fov must be a number, got null"
 * through the daemon and "got inf" through the CLI; cJSON reads the
 * number as infinity.  Now the parse refuses it as written. */
static void test_overflow_quotes_the_number(void **state)
{
    (void)state;
    static const char *const fov[] = {"camera.fov: the number 1e400 is out "
                                      "of range",
                                      "finite", NULL};
    expect_error("{\"camera\": {\"fov\": 1e400}}", NULL, "camera.fov", fov);
    expect_error(scene_json, "camera.fov=1e400", "camera.fov", fov);
    /* In an array, negative, after strings that hold digits, quotes and
     * escapes, which are not numbers. */
    static const char *const pos[] = {"camera.position[1]: the number "
                                      "-1E+309 is out of range",
                                      NULL};
    expect_error("{\"description\": \"1e5 \\\"2\\\" -3\", \"camera\": "
                 "{\"fov\": 30, \"position\": [7, -1E+309, 0]}}",
                 NULL, "camera.position[1]", pos);
    expect_error(scene_json, "camera.position=[0, -1E+309, 5]",
                 "camera.position[1]", pos);
    /* In a field that wants no number, the range is still the problem. */
    static const char *const desc[] = {"description: the number 1e999 is "
                                       "out of range",
                                       NULL};
    expect_error("{\"description\": 1e999}", NULL, "description", desc);
    /* A long literal is cut, with "...". */
    char big[400];
    snprintf(big, sizeof big, "{\"render\": {\"width\": 1%0330d}}", 0);
    static const char *const width[] = {
        "render.width: the number "
        "1000000000000000000000000000000000000000"
        "... is out of range",
        NULL};
    expect_error(big, NULL, "render.width", width);

    /* lr_camera_apply_json names the field under "camera" too. */
    lr_camera cam;
    lr_camera_default(&cam);
    lr_error err;
    const char cj[] = "{\"fov\": 30, \"aperture_radius\": 1e400}";
    assert_int_equal(lr_camera_apply_json(&cam, cj, strlen(cj), &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.aperture_radius");
    assert_non_null(strstr(err.message, "1e400 is out of range"));
    assert_true(cam.fov == 40.0); /* unchanged */
}

/* A tree that did not come through lr__json_parse (a program's own
 * cJSON) may hold an infinity: the getters say what it is, never "null"
 * or "inf". */
static void test_infinity_in_a_tree(void **state)
{
    (void)state;
    cJSON *c = cJSON_CreateObject();
    assert_non_null(c);
    assert_non_null(cJSON_AddNumberToObject(c, "fov", INFINITY));
    lr_camera cam;
    lr_camera_default(&cam);
    lr_error err;
    assert_int_equal(lr__camera_from_json(c, &cam, NULL, &err), LR_ERR_INVALID);
    assert_string_equal(err.message, "camera.fov must be a finite number, "
                                     "got a number too large for a double");
    cJSON_DeleteItemFromObject(c, "fov");
    cJSON *pos = cJSON_AddArrayToObject(c, "position");
    assert_non_null(pos);
    cJSON_AddItemToArray(pos, cJSON_CreateNumber(0));
    cJSON_AddItemToArray(pos, cJSON_CreateNumber(-INFINITY));
    cJSON_AddItemToArray(pos, cJSON_CreateNumber(0));
    assert_int_equal(lr__camera_from_json(c, &cam, NULL, &err), LR_ERR_INVALID);
    assert_string_equal(err.message, "camera.position[1] must be a finite "
                                     "number, got a number too large for a "
                                     "double");
    cJSON_Delete(c);
}

static const struct CMUnitTest json_tests[] = {
    cmocka_unit_test(test_syntax_errors_stay_invalid),
    cmocka_unit_test(test_empty_text_says_empty),
    cmocka_unit_test(test_overflow_quotes_the_number),
    cmocka_unit_test(test_infinity_in_a_tree),
    cmocka_unit_test(test_numbers_follow_rfc8259),
};
LR_TEST_GROUP(json, json_tests)
