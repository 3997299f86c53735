/*
 * test_json_limits.c: the JSON reader's limits on hostile text: nesting
 * 10000 deep in every place is refused before any recursion, a 50 MB string
 * is quoted only in part and text beyond 64 MiB is refused, invalid UTF-8
 * in keys and strings at every level is an error naming the field (in a
 * message that is itself valid UTF-8), and so is "\u0000".  Overrides are
 * held to the same rules.
 */
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Nesting 10000 deep (in every place, balanced or not) is refused before
 * any recursion, with a message about nesting. */
static void test_deep_nesting(void **state)
{
    (void)state;
    enum { DEPTH = 10000 };
    static const char *const wraps[][2] = {
        {"{\"description\": ", "}"},
        {"{\"objects\": ", "}"},
        {"{\"camera\": {\"chromatic\": ", "}}"},
        {"", ""}};
    static const char open_close[][2] = {{'[', ']'}, {'{', '}'}};
    for (size_t w = 0; w < 4; w++)
        for (size_t k = 0; k < 2; k++)
            for (int balanced = 0; balanced < 2; balanced++) {
                size_t cap = 2 * DEPTH * 8 + 128, n = 0;
                char *buf = malloc(cap);
                assert_non_null(buf);
                n += (size_t)snprintf(buf + n, cap - n, "%s", wraps[w][0]);
                for (int d = 0; d < DEPTH; d++) {
                    if (k == 1)
                        n += (size_t)snprintf(buf + n, cap - n, "{\"a\":");
                    else
                        buf[n++] = open_close[k][0];
                }
                buf[n++] = '1';
                for (int d = 0; balanced && d < DEPTH; d++)
                    buf[n++] = open_close[k][1];
                n += (size_t)snprintf(buf + n, cap - n, "%s", wraps[w][1]);
                lr_scene *s = NULL;
                lr_error err;
                assert_int_equal(
                    lr_scene_load_json(buf, n, NULL, NULL, 0, &s, &err),
                    LR_ERR_INVALID);
                assert_non_null(strstr(err.message, "nested deeper"));
                /* The camera and render appliers share the parser. */
                lr_camera cam;
                lr_camera_default(&cam);
                assert_int_equal(lr_camera_apply_json(&cam, buf, n, &err),
                                 LR_ERR_INVALID);
                free(buf);
            }
    /* Exactly at the limit parses (and fails only on meaning). */
    char buf[512];
    size_t n = (size_t)snprintf(buf, sizeof buf, "{\"description\": ");
    for (int d = 0; d < 63; d++)
        buf[n++] = '[';
    for (int d = 0; d < 63; d++)
        buf[n++] = ']';
    buf[n++] = '}';
    lr_test_expect_invalid(buf, n, "description", "63 levels of arrays");
    /* An override cannot nest deeply either: a value too deep for cJSON
     * becomes a string, one that parses is checked like the file. */
    char *deep = malloc(3 * DEPTH);
    assert_non_null(deep);
    n = (size_t)snprintf(deep, 3 * DEPTH, "camera.chromatic=");
    for (int d = 0; d < 2000; d++)
        deep[n++] = '[';
    deep[n] = '\0';
    const char *sets[] = {deep};
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json("{}", 2, NULL, sets, 1, &s, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "camera.chromatic");
    free(deep);
}

/* A 50 MB string: fine as a description (ignored), an error quoting only
 * its start where it is a value or a key; the whole text beyond 64 MiB is
 * refused as too large. */
static void test_huge_string(void **state)
{
    (void)state;
    const size_t big = 50u << 20;
    char *buf = malloc(big + 256);
    assert_non_null(buf);
    static const char *const pre[] = {"{\"description\": \"",
                                      "{\"camera\": {\"model\": \"",
                                      "{\"render\": {\""};
    static const char *const post[] = {"\"}", "\"}}", "\": 1}}"};
    static const char *const path[] = {NULL, "camera.model", "render."};
    for (size_t k = 0; k < 3; k++) {
        size_t n = (size_t)sprintf(buf, "%s", pre[k]);
        /* Multi-byte characters, so that quoting a prefix could cut one. */
        for (size_t i = 0; i + 2 <= big; i += 2) {
            buf[n++] = (char)0xC3;
            buf[n++] = (char)0xA9;
        }
        n += (size_t)sprintf(buf + n, "%s", post[k]);
        lr_scene *s = NULL;
        lr_error err;
        memset(&err, 0, sizeof err);
        lr_status st = lr_scene_load_json(buf, n, NULL, NULL, 0, &s, &err);
        if (k == 0) {
            if (st != LR_OK)
                fail_msg("50 MB description: %s", err.message);
            lr_scene_free(s);
        } else {
            lr_test_expect_invalid(buf, n, path[k], "50 MB string");
            assert_true(strlen(err.message) < sizeof err.message);
        }
    }
    free(buf);
    /* Over the 64 MiB limit: refused before parsing. */
    size_t over = (64u << 20) + 1;
    buf = malloc(over);
    assert_non_null(buf);
    memset(buf, ' ', over);
    buf[0] = '{';
    buf[over - 1] = '}';
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json(buf, over, NULL, NULL, 0, &s, &err),
                     LR_ERR_LIMIT);
    free(buf);
}

/* Invalid UTF-8 in strings and keys at every level: an error naming the
 * field (the bad bytes shown as \xNN in a key), with a message that is
 * itself valid UTF-8. */
static void test_invalid_utf8(void **state)
{
    (void)state;
    static const char *const bad[] = {"\xff",
                                      "\xfe\xff",
                                      "\xc0\x80",
                                      "\xc1\xbf",
                                      "\xe0\x80\x80",
                                      "\xed\xa0\x80",
                                      "\xed\xbf\xbf",
                                      "\xf4\x90\x80\x80",
                                      "\xf5\x80\x80\x80",
                                      "\xf8\x88\x80\x80\x80",
                                      "\x80",
                                      "\xbf",
                                      "\xe2\x82",
                                      "\xf0\x9f\x98",
                                      "a\xc3",
                                      "\xc3\x28"};
    static const struct {
        const char *tmpl, *path;
    } where[] = {
        {"{\"description\": \"%s\"}", "description"},
        {"{\"camera\": {\"model\": \"%s\"}}", "camera.model"},
        {"{\"camera\": {\"chromatic\": {\"glass\": \"x%s\"}}}",
         "camera.chromatic.glass"},
        {"{\"render\": {\"sampler\": \"%s\"}}", "render.sampler"},
        {"{\"materials\": {\"%s\": {}}}", "materials."},
        {"{\"materials\": {\"m\": {\"%s\": 1}}}", "materials.m."},
        {"{\"lights\": [{\"type\": \"%s\"}]}", "lights[0].type"},
        {"{\"objects\": [{\"type\": \"mesh\", \"file\": \"%s.obj\"}]}",
         "objects[0].file"},
        {"{\"objects\": [{\"type\": \"sphere\", \"material\": \"%s\"}]}",
         "objects[0].material"},
        {"{\"%s\": 1}", ""},
        {"{\"camera\": {\"%s\": 1}}", "camera."},
        {"{\"camera\": {\"chromatic\": {\"abbe\": {\"%s\": 1}}}}",
         "camera.chromatic.abbe."},
        {"{\"objects\": [{\"type\": \"sphere\", \"transform\": [{\"%s\": "
         "1}]}]}",
         "objects[0].transform[0]."},
        {"{\"description\": [\"ok\", {\"deep\": [\"%s\"]}]}",
         "description[1].deep[0]"},
    };
    size_t tried = 0;
    for (size_t w = 0; w < sizeof where / sizeof where[0]; w++)
        for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++) {
            char json[512], what[128];
            snprintf(json, sizeof json, where[w].tmpl, bad[b]);
            snprintf(what, sizeof what, "invalid UTF-8 #%zu in %s", b,
                     where[w].path);
            lr_test_expect_invalid(json, strlen(json), where[w].path, what);
            lr_scene *s = NULL;
            lr_error err;
            lr_scene_load_json(json, strlen(json), NULL, NULL, 0, &s, &err);
            assert_non_null(strstr(err.message, "not valid UTF-8"));
            tried++;
        }
    /* Valid UTF-8 of every length passes: 2, 3 and 4 bytes, escaped
     * surrogate pairs, U+FFFF and U+10FFFF. */
    const char *good =
        "{\"description\": \"\xc3\xa9\xe2\x82\xac\xf0\x9f\x98\x80"
        "\\ud83d\\ude00\xef\xbf\xbf\xf4\x8f\xbf\xbf\","
        " \"materials\": {\"\xc3\xa9t\xc3\xa9\": {}}}";
    lr_scene_free(lr_test_load_json(good));
    /* Overrides are checked the same way. */
    const char *sets[] = {"description=\xff"};
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json("{}", 2, NULL, sets, 1, &s, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "UTF-8"));
    /* And "\u0000", which cJSON would turn into a string cut short. */
    const char *nul = "{\"camera\": {\"model\": \"pinhole\\u0000junk\"}}";
    lr_test_expect_invalid(nul, strlen(nul), "", "\\u0000 in a string");
    const char *nulsets[] = {"camera.model=\"thinlens\\u0000x\""};
    assert_int_equal(lr_scene_load_json("{}", 2, NULL, nulsets, 1, &s, &err),
                     LR_ERR_INVALID);
    print_message("invalid UTF-8: %zu cases\n", tried);
}

static const struct CMUnitTest json_limits_tests[] = {
    cmocka_unit_test(test_deep_nesting),
    cmocka_unit_test(test_huge_string),
    cmocka_unit_test(test_invalid_utf8),
};

LR_TEST_GROUP(json_limits, json_limits_tests)
