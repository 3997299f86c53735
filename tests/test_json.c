/*
 * test_json.c: telling cJSON's syntax errors from its allocation failures
 * (lr__json_cjson_accepts in lib/json_util.c).
 *
 * The scan must accept exactly what the installed cJSON parses (checked
 * on hand-picked quirks and on random JSON-like text), and a parse that
 * fails inside cJSON for lack of memory must come back as LR_ERR_NOMEM,
 * for a scene and for an override, while a real syntax error stays
 * LR_ERR_INVALID and a value that is not JSON stays a string.
 */
#include "test.h"
#include "json_util.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* cJSON's verdict and the scan's, for both ways the library parses. */
static void check_agrees(const char *t, size_t len)
{
    const char *end = NULL;
    cJSON *a = cJSON_ParseWithLengthOpts(t, len, &end, 0);
    int scan = lr__json_cjson_accepts(t, len, 0);
    if ((a != NULL) != scan)
        fail_msg("length parse of \"%.*s\" (%zu bytes): cJSON %s, scan %s",
                 (int)len, t, len, a ? "accepts" : "refuses",
                 scan ? "accepts" : "refuses");
    cJSON_Delete(a);
    if (memchr(t, '\0', len) != NULL)
        return;
    char *z = strndup(t, len);
    assert_non_null(z);
    cJSON *b = cJSON_ParseWithOpts(z, NULL, 1);
    scan = lr__json_cjson_accepts(z, len + 1, 1);
    if ((b != NULL) != scan)
        fail_msg("terminated parse of \"%s\": cJSON %s, scan %s", z,
                 b ? "accepts" : "refuses", scan ? "accepts" : "refuses");
    cJSON_Delete(b);
    free(z);
}

static void test_scan_quirks(void **state)
{
    (void)state;
    static const char *const cases[] = {
        "", " ", "null", "nul", "true", "false", "fals", "truex", "0", "-",
        "-0", "01", "1.", ".5", "-.5", "+1", "1e", "1e+", "1e+5", "1E-2x",
        "1.5.5", "--1", "1-", "0x10", "1e5e5", "123abc", "[1e]",
        "1234567890123456789012345678901234567890123456789012345678901", /*61*/
        /* 63, 64 and 70 characters, alone and where a cut would show */
        "123456789012345678901234567890123456789012345678901234567890123",
        "1234567890123456789012345678901234567890123456789012345678901234",
        "[1234567890123456789012345678901234567890123456789012345678901234]",
        "[123456789012345678901234567890123456789012345678901234567890.1234]",
        "[-1.234567890123456789012345678901234567890123456789012345678901e+5]",
        "{\"a\": 1234567890123456789012345678901234567890123456789012345678901234567890}",
        "\"\"", "\"a", "\"a\\\"", "\"a\\\"\"", "\"\\\\\"", "\"\\x\"",
        "\"\\u0041\"", "\"\\u00zz\"", "\"\\uzzzz\"", "\"\\u12\"", "\"\\u\"",
        "\"\\ud800\"", "\"\\udc00\"", "\"\\ud800\\udc00\"",
        "\"\\ud800\\u0041\"", "\"\\ud800x\"", "\"\\ud83d\\ude00\"",
        "\"tab\there\"", "\"\x01\"", "\"\\/\\b\\f\\n\\r\\t\"",
        "[", "]", "[]", "[ ]", "[1,]", "[,1]", "[1 2]", "[1,2]", "[[]]",
        "[1", "[1,", "[\"a\"", "{", "{}", "{ }", "{\"a\"}", "{\"a\":}",
        "{\"a\":1,}", "{\"a\":1", "{\"a\" : 1 , \"b\" : [true]}", "{a:1}",
        "{\"a\":1 \"b\":2}", "{1:2}", "{\"a\":1}}", "[1]]", "1 2", "1,",
        "\x01 1 \x02", "\t\n\r 1 \t", "\xEF\xBB\xBF", "\xEF\xBB\xBF" "1",
        "\xEF\xBB\xBF" "12", "\xEF\xBB\xBF" " [1]", "\xEF\xBB" "1",
        " \xEF\xBB\xBF" "1", "\xC3\xA9", "\"\xC3\xA9\"", "[\"\xff\"]",
        "{\"\":\"\"}", "[null,true,false,-1.5e-3,\"x\",{},[]]",
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        check_agrees(cases[i], strlen(cases[i]));
    /* With NUL bytes inside (only the length parse sees them). */
    check_agrees("1\0", 2);
    check_agrees("[1\0]", 4);
    check_agrees("\"a\0\"", 4);
    check_agrees(" \0", 2);
}

/* Nesting: cJSON refuses deeper than CJSON_NESTING_LIMIT. */
static void test_scan_nesting(void **state)
{
    (void)state;
    for (int depth = CJSON_NESTING_LIMIT - 1; depth <= CJSON_NESTING_LIMIT + 1;
         depth++) {
        char *t = malloc(2 * (size_t)depth + 1);
        assert_non_null(t);
        for (int i = 0; i < depth; i++) {
            t[i] = '[';
            t[2 * depth - 1 - i] = ']';
        }
        t[2 * depth] = '\0';
        check_agrees(t, strlen(t));
        free(t);
    }
}

/* Random text from JSON's alphabet, mutated from valid documents, so
 * that both verdicts come up often. */
static void test_scan_random(void **state)
{
    (void)state;
    static const char *const seeds[] = {
        "{\"a\": [1, -2.5e3, true, null], \"b\": {\"c\": \"d\\u00e9\"}}",
        "[\"\\ud83d\\ude00\", 0.5, -0, 1E+2, {}, [], \"\\\\\\\"\"]",
        "{\"camera\": {\"fov\": 40, \"position\": [0, 1, 5]}}",
    };
    static const char alphabet[] = "{}[]\",:.-+eE0123456789\\ubfnrtdDa \t\n";
    unsigned long long x = 0x9E3779B97F4A7C15ull;
    char buf[128];
    int accepted = 0, refused = 0;
    for (int n = 0; n < 30000; n++) {
        const char *s = seeds[n % 3];
        size_t len = strlen(s);
        memcpy(buf, s, len);
        int edits = 1 + n % 4;
        for (int e = 0; e < edits; e++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            size_t at = (size_t)(x >> 8) % len;
            char c = alphabet[(x >> 40) % (sizeof alphabet - 1)];
            switch ((x >> 4) % 3) {
            case 0: /* replace */
                buf[at] = c;
                break;
            case 1: /* delete */
                memmove(buf + at, buf + at + 1, len - at - 1);
                len--;
                break;
            default: /* insert */
                if (len + 1 < sizeof buf) {
                    memmove(buf + at + 1, buf + at, len - at);
                    buf[at] = c;
                    len++;
                }
            }
        }
        buf[len] = '\0';
        check_agrees(buf, len);
        if (lr__json_cjson_accepts(buf, len, 0))
            accepted++;
        else
            refused++;
    }
    /* Both verdicts were exercised many times. */
    assert_true(accepted > 1000);
    assert_true(refused > 1000);
}

/* cJSON hooks that fail every allocation from number `fail_from` on. */
static long allocs, fail_from;

static void *failing_malloc(size_t n)
{
    if (++allocs >= fail_from)
        return NULL;
    return malloc(n);
}

static void use_failing_hooks(long from)
{
    allocs = 0;
    fail_from = from;
    cJSON_Hooks h = {failing_malloc, free};
    cJSON_InitHooks(&h);
}

static const char scene_json[] =
    "{\"description\": \"caf\\u00e9\", \"camera\": {\"position\": [0, 1, 5], "
    "\"look_at\": [0, 0, 0], \"fov\": 40, \"model\": \"thinlens\"}, "
    "\"render\": {\"width\": 8, \"height\": 8}, \"materials\": {\"m\": "
    "{\"diffuse\": 0.5}}, \"objects\": [{\"type\": \"sphere\", "
    "\"center\": [0, 0, 0], \"radius\": 1, \"material\": \"m\"}]}";

/* Every allocation point of a scene load with an override: out of memory
 * is LR_ERR_NOMEM, never a syntax error or a string where a number was. */
static void test_nomem_is_nomem(void **state)
{
    (void)state;
    const char *sets[] = {"camera.fov=35", "camera.focus_distance=5.5"};
    int nomem = 0;
    long from;
    for (from = 1; from < 10000; from++) {
        use_failing_hooks(from);
        lr_scene *s = NULL;
        lr_error err;
        lr_status st = lr_scene_load_json(scene_json, strlen(scene_json),
                                          NULL, sets, 2, &s, &err);
        cJSON_InitHooks(NULL);
        if (st == LR_OK) {
            lr_camera cam;
            lr_scene_camera(s, &cam);
            assert_true(cam.fov == 35.0);
            lr_scene_free(s);
            break;
        }
        if (st != LR_ERR_NOMEM)
            fail_msg("allocation %ld failing: status %d, \"%s\"", from,
                     (int)st, err.message);
        assert_null(s);
        assert_non_null(strstr(err.message, "out of memory"));
        nomem++;
    }
    /* Failures inside the parse of the scene and of each override were
     * all reached before the load succeeded. */
    assert_true(nomem > 20);
    assert_true(from < 10000);
}

/* Without a failing allocation the answers are as before. */
static void test_syntax_errors_stay_invalid(void **state)
{
    (void)state;
    lr_scene *s = NULL;
    lr_error err;
    const char bad[] = "{\"camera\": {\"fov\": 40,}}";
    assert_int_equal(lr_scene_load_json(bad, strlen(bad), NULL, NULL, 0, &s,
                                        &err),
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

static const struct CMUnitTest json_tests[] = {
    cmocka_unit_test(test_scan_quirks),
    cmocka_unit_test(test_scan_nesting),
    cmocka_unit_test(test_scan_random),
    cmocka_unit_test(test_nomem_is_nomem),
    cmocka_unit_test(test_syntax_errors_stay_invalid),
};
LR_TEST_GROUP(json, json_tests)
