/*
 * test_obj_hostile.c: the OBJ reader (lib/scene/obj.c) on hostile files: indices
 * that overflow, malformed corners and numbers, non-finite and too large
 * values, binary files, an enormous face, a million-digit index, a device
 * that streams forever, a missing file and a directory.  Each error names
 * the file and line (test_obj.c covers well-formed files and the common
 * errors).
 */
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* Fails with "FILE:LINE: " (LINE as given) and `needle`. */
static void obj_fails_at(const char *name, const void *data, size_t len,
                         int line, const char *needle)
{
    char path[512], want[600];
    lr_test_write_file(name, data, len, path, sizeof path);
    lr__mesh m;
    lr_error err;
    memset(&err, 0, sizeof err);
    lr_status st = lr__obj_load(path, "objects[0].file", &m, &err);
    snprintf(want, sizeof want, "%s:%d: ", path, line);
    if (st == LR_OK || strncmp(err.message, want, strlen(want)) != 0 ||
        (needle && strstr(err.message, needle) == NULL))
        fail_msg("%s: status %d, message \"%s\", want \"%s%s\"", name, (int)st,
                 err.message, want, needle ? needle : "");
    assert_null(m.vertices);
}

static void test_obj_hostile(void **state)
{
    (void)state;
    const char *tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    char buf[4096];
#define OBJ(name, body, line, needle)                       \
    do {                                                    \
        snprintf(buf, sizeof buf, "%s%s", tri, body);       \
        obj_fails_at(name, buf, strlen(buf), line, needle); \
    } while (0)
    OBJ("idx-uint.obj", "f 1 2 4294967297\n", 4, "out of range");
    OBJ("idx-long-min.obj", "f 1 2 -9223372036854775808\n", 4, "out of range");
    OBJ("idx-long-under.obj", "f 1 2 -9223372036854775809\n", 4,
        "out of range");
    OBJ("idx-zero-vn.obj", "vn 0 0 1\nf 1//0 2//1 3//1\n", 5, "index 0");
    OBJ("idx-plus.obj", "f +1 2 0\n", 4, "index 0");
    OBJ("idx-space.obj", "f 1 2 3/ 1\n", 4, "bad face corner");
    OBJ("idx-empty-vt.obj", "f 1/ 2 3\n", 4, "bad face corner");
    OBJ("idx-triple-slash.obj", "f 1/// 2 3\n", 4, "bad face corner");
    OBJ("idx-hex.obj", "f 0x1 2 3\n", 4, "bad face corner");
    OBJ("num-hex.obj", "v 0x10 0 0\n", 4, NULL);
    OBJ("num-comma.obj", "v 0,5 0 0\n", 4, "bad number");
    OBJ("num-nan-paren.obj", "v nan(123) 0 0\n", 4, "non-finite");
    OBJ("num-infinity.obj", "v 0 0 Infinity\n", 4, "non-finite");
    OBJ("num-flt-max.obj", "v 3.4028236e38 0 0\n", 4, "too large for a float");
    OBJ("vn-tiny.obj", "vn 1e-320 0 0\nf 1//1 2//1 3//1\n", 4, NULL);
    OBJ("f-one.obj", "f 1\n", 4, "at least 3 corners");
    OBJ("f-bare.obj", "f\n", 4, "at least 3 corners");
    OBJ("cont-eof.obj", "f 1 2 \\", 4,
        "line continuation '\\' at the end of the file");
    OBJ("later-line.obj", "\n\n\n# comment\n\nf 1 2 9\n", 9, "out of range");
    /* Bytes beyond ASCII in a quoted token are shown as \xNN, so the
     * message stays valid UTF-8 (found by fuzz_obj). */
    OBJ("non-ascii.obj", "v 1e\xff\xc3 0 0\n", 4, "bad number '1e\\xff\\xc3'");
    OBJ("non-ascii-corner.obj", "f 1 2 \xe2\x82\n", 4,
        "bad face corner '\\xe2\\x82'");
#undef OBJ
    /* Binary garbage: bytes of an ELF header, a PNG signature. */
    static const char elf[] = "\x7f"
                              "ELF\x02\x01\x01\0\0\0\0\0\0\0\0\0";
    obj_fails_at("elf.obj", elf, sizeof elf - 1, 1, "not a text OBJ file");
    static const char png[] = "\x89PNG\r\n\x1a\n\0\0\0\rIHDR";
    obj_fails_at("png.obj", png, sizeof png - 1, 2, "not a text OBJ file");
    /* An enormous face: 200000 corners fan into 199998 triangles. */
    size_t cap = 16u << 20, n = 0;
    char *big = malloc(cap);
    assert_non_null(big);
    n += (size_t)snprintf(big, cap, "%s", tri);
    n += (size_t)snprintf(big + n, cap - n, "f");
    for (int i = 0; i < 200000; i++)
        n += (size_t)snprintf(big + n, cap - n, " %d", 1 + i % 3);
    big[n++] = '\n';
    char path[512];
    lr_test_write_file("enormous-face.obj", big, n, path, sizeof path);
    lr__mesh m;
    lr_error err;
    assert_int_equal(lr__obj_load(path, NULL, &m, &err), LR_OK);
    assert_int_equal(m.n_triangles, 199998);
    lr__mesh_free(&m);
    /* Concave faces: a star of 8192 corners is ear-clipped into 8190
     * triangles; one of 8193 is refused, naming the limit (a star of
     * 100000 corners, 5 MB, had taken 30 s to load). */
    for (int k = 0; k < 2; k++) {
        int corners = 8192 + k;
        n = 0;
        for (int i = 0; i < corners; i++) {
            double a = 2.0 * M_PI * i / corners, r = i % 2 ? 0.5 : 1.0;
            n += (size_t)snprintf(big + n, cap - n, "v %.9f %.9f 0\n",
                                  r * cos(a), r * sin(a));
        }
        n += (size_t)snprintf(big + n, cap - n, "f");
        for (int i = 0; i < corners; i++)
            n += (size_t)snprintf(big + n, cap - n, " %d", i + 1);
        big[n++] = '\n';
        if (k == 0) {
            lr_test_write_file("star.obj", big, n, path, sizeof path);
            assert_int_equal(lr__obj_load(path, NULL, &m, &err), LR_OK);
            assert_int_equal(m.n_triangles, 8190);
            lr__mesh_free(&m);
        } else {
            obj_fails_at("star-big.obj", big, n, corners + 1,
                         "a concave face of 8193 corners; at most 8192");
        }
    }
    /* A self-crossing face of 8192 random corners: ear clipping found
     * few ears and walked the ring for each cut (15 s alone, and a file
     * may hold many).  The file's steps are budgeted (about 2 s): past
     * them, a named limit. */
    n = 0;
    unsigned long long lcg = 5;
    for (int i = 0; i < 8192; i++) {
        double xy[2];
        for (int a = 0; a < 2; a++) {
            lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
            xy[a] = (double)(lcg >> 11) * 0x1p-53;
        }
        n += (size_t)snprintf(big + n, cap - n, "v %.9f %.9f 0\n", xy[0],
                              xy[1]);
    }
    n += (size_t)snprintf(big + n, cap - n, "f");
    for (int i = 0; i < 8192; i++)
        n += (size_t)snprintf(big + n, cap - n, " %d", i + 1);
    big[n++] = '\n';
    obj_fails_at("tangle.obj", big, n, 8193,
                 "the file's concave faces take too long to triangulate");
    /* A million-digit index. */
    n = (size_t)snprintf(big, cap, "%sf 1 2 ", tri);
    memset(big + n, '7', 1000000);
    n += 1000000;
    big[n++] = '\n';
    obj_fails_at("long-index.obj", big, n, 4, "out of range");
    free(big);
    /* A missing file and a directory: I/O errors naming the file. */
    snprintf(path, sizeof path, "%s/no-such.obj", lr_test_tmpdir());
    assert_int_equal(lr__obj_load(path, "objects[0].file", &m, &err),
                     LR_ERR_IO);
    assert_non_null(strstr(err.message, "no-such.obj"));
}

/* A device that streams bytes forever (/dev/zero): the first line is
 * binary, so the reader stops there instead of reading up to the 1 GiB
 * size limit first. */
static void test_obj_endless_binary_stream(void **state)
{
    (void)state;
    if (access("/dev/zero", R_OK) != 0)
        lr_test_skip_env("/dev/zero cannot be read on this machine");
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    lr__mesh m;
    lr_error err;
    memset(&err, 0, sizeof err);
    lr_status st = lr__obj_load("/dev/zero", "objects[0].file", &m, &err);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double secs = (double)(t1.tv_sec - t0.tv_sec) +
                  1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    if (st != LR_ERR_INVALID ||
        strstr(err.message, "/dev/zero:1: not a text OBJ file") == NULL)
        fail_msg("/dev/zero: status %d after %.2f s: %s", (int)st, secs,
                 err.message);
}

/* Through the scene loader: OBJ errors carry the object's field path and
 * the file's line. */
static void test_obj_errors_through_scene(void **state)
{
    (void)state;
    char path[512];
    const char *body = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 0\n";
    lr_test_write_file("scene-bad.obj", body, strlen(body), path, sizeof path);
    const char *json =
        "{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0],"
        " \"radius\": 1}, {\"type\": \"mesh\","
        " \"file\": \"scene-bad.obj\"}]}";
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                        NULL, 0, &s, &err),
                     LR_ERR_INVALID);
    assert_string_equal(err.path, "objects[1].file");
    assert_non_null(strstr(err.message, "scene-bad.obj:5: face index 0"));
    assert_true(strncmp(err.message, "objects[1].file: ", 17) == 0);
}

static const struct CMUnitTest obj_hostile_tests[] = {
    cmocka_unit_test(test_obj_hostile),
    cmocka_unit_test(test_obj_endless_binary_stream),
    cmocka_unit_test(test_obj_errors_through_scene),
};

LR_TEST_GROUP(obj_hostile, obj_hostile_tests)
