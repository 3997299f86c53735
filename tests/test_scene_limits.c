/*
 * test_scene_limits.c: lr_scene_limits_set, what one scene may hold.
 * Small files make large scenes: an OBJ file named by many objects, a
 * glTF mesh drawn by many nodes, a PNG that declares many pixels in a
 * few bytes.  Each is counted as it is placed or before it is decoded,
 * and the load fails with LR_ERR_LIMIT naming the field that went over.
 * No limit (0, the default) loads them all.
 */
#include "test.h"

#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static int no_limits(void **state)
{
    (void)state;
    lr_scene_limits_set(0, 0);
    return 0;
}

/* A scene of n objects that each name mesh FILE (two triangles). */
static char *mesh_scene(const char *file, int n)
{
    size_t cap = 256 + (size_t)n * 64;
    char *json = malloc(cap);
    assert_non_null(json);
    size_t k = (size_t)snprintf(json, cap, "{\"objects\": [");
    for (int i = 0; i < n; i++)
        k += (size_t)snprintf(json + k, cap - k,
                              "%s{\"type\": \"mesh\", \"file\": \"%s\"}",
                              i ? ", " : "", file);
    snprintf(json + k, cap - k, "]}");
    return json;
}

static lr_status load(const char *json, lr_error *err)
{
    lr_scene *s = NULL;
    memset(err, 0, sizeof *err);
    lr_status st = lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                      NULL, 0, &s, err);
    assert_true((st == LR_OK) == (s != NULL));
    lr_scene_free(s);
    return st;
}

static void test_triangles_of_repeated_obj(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_text("limit-quad.obj",
                       "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", path,
                       sizeof path);
    char *json = mesh_scene("limit-quad.obj", 10);
    lr_error err;
    /* No limit: 20 triangles. */
    assert_int_equal(load(json, &err), LR_OK);
    /* 15: objects[0..6] hold 14, objects[7] would make 16. */
    lr_scene_limits_set(15, 0);
    assert_int_equal(load(json, &err), LR_ERR_LIMIT);
    assert_string_equal(err.path, "objects[7].file");
    assert_string_equal(err.message,
                        "objects[7].file: the scene would hold more than 15 "
                        "triangles, the limit set by lr_scene_limits_set");
    /* Exactly the limit fits. */
    lr_scene_limits_set(20, 0);
    assert_int_equal(load(json, &err), LR_OK);
    /* Inline triangles and rectangles count too. */
    lr_scene_limits_set(2, 0);
    const char *tris =
        "{\"objects\": [{\"type\": \"plane\", \"normal\": [0, 0, 1], "
        "\"size\": 1}, {\"type\": \"triangle\", \"vertices\": [[0, 0, 0], "
        "[1, 0, 0], [0, 1, 0]]}]}";
    assert_int_equal(load(tris, &err), LR_ERR_LIMIT);
    assert_string_equal(err.path, "objects[1]");
    lr_scene_limits_set(0, 0);
    free(json);
}

static void test_triangles_of_gltf_nodes(void **state)
{
    (void)state;
    const char *src = getenv("LENSRAY_SOURCE_DIR");
    char cmd[1024], path[512];
    snprintf(cmd, sizeof cmd, "python3 %s/tests/gltf_writer.py tri %s/%s",
             src && *src ? src : ".", lr_test_tmpdir(), "limit-tri.gltf");
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/limit-tri.gltf", lr_test_tmpdir());
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    static char text[1 << 16];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = '\0';
    cJSON *root = cJSON_Parse(text);
    assert_non_null(root);
    /* 30 more nodes drawing mesh 0 (one triangle), in the scene. */
    cJSON *nodes = cJSON_GetObjectItemCaseSensitive(root, "nodes");
    cJSON *scene0 = cJSON_GetArrayItem(
        cJSON_GetObjectItemCaseSensitive(root, "scenes"), 0);
    cJSON *roots = cJSON_GetObjectItemCaseSensitive(scene0, "nodes");
    for (int i = 0; i < 30; i++) {
        cJSON *node = cJSON_CreateObject();
        cJSON_AddNumberToObject(node, "mesh", 0);
        cJSON *t = cJSON_AddArrayToObject(node, "translation");
        cJSON_AddItemToArray(t, cJSON_CreateNumber(i));
        cJSON_AddItemToArray(t, cJSON_CreateNumber(0));
        cJSON_AddItemToArray(t, cJSON_CreateNumber(0));
        cJSON_AddItemToArray(roots,
                             cJSON_CreateNumber(cJSON_GetArraySize(nodes)));
        cJSON_AddItemToArray(nodes, node);
    }
    char *out = cJSON_Print(root);
    lr_test_write_text("limit-many.gltf", out, path, sizeof path);
    free(out);
    cJSON_Delete(root);
    const char *json = "{\"objects\": [{\"type\": \"sphere\", \"center\": "
                       "[0, 0, -9], \"radius\": 1}, {\"type\": \"gltf\", "
                       "\"file\": \"limit-many.gltf\"}]}";
    lr_error err;
    assert_int_equal(load(json, &err), LR_OK);
    lr_scene_limits_set(10, 0);
    assert_int_equal(load(json, &err), LR_ERR_LIMIT);
    assert_string_equal(err.path, "objects[1].file");
    assert_non_null(strstr(err.message, "objects[1].file"));
    assert_non_null(strstr(err.message, "more than 10 triangles, the limit "
                                        "set by lr_scene_limits_set"));
    lr_scene_limits_set(31, 0);
    assert_int_equal(load(json, &err), LR_OK);
    lr_scene_limits_set(0, 0);
}

static void put_chunk(unsigned char **p, const char *type,
                      const unsigned char *data, size_t n)
{
    unsigned char *q = *p;
    q[0] = (unsigned char)(n >> 24), q[1] = (unsigned char)(n >> 16);
    q[2] = (unsigned char)(n >> 8), q[3] = (unsigned char)n;
    memcpy(q + 4, type, 4);
    if (n > 0)
        memcpy(q + 8, data, n);
    uLong crc = crc32(0L, q + 4, (uInt)(4 + n));
    q[8 + n] = (unsigned char)(crc >> 24),
          q[9 + n] = (unsigned char)(crc >> 16);
    q[10 + n] = (unsigned char)(crc >> 8), q[11 + n] = (unsigned char)crc;
    *p = q + 12 + n;
}

/* A grey 8-bit PNG of W x H black pixels: a few KB that declare W x H. */
static void write_black_png(const char *name, int w, int h, char *path,
                            size_t cap)
{
    size_t raw_n = (size_t)(w + 1) * (size_t)h;
    unsigned char *raw = calloc(raw_n, 1);
    uLongf z_n = compressBound((uLong)raw_n);
    unsigned char *z = malloc(z_n);
    assert_true(raw != NULL && z != NULL);
    assert_int_equal(compress2(z, &z_n, raw, (uLong)raw_n, 9), Z_OK);
    unsigned char *png = malloc(z_n + 64), *p = png;
    assert_non_null(png);
    memcpy(p, "\x89PNG\r\n\x1a\n", 8);
    p += 8;
    unsigned char ihdr[13] = {(unsigned char)(w >> 24),
                              (unsigned char)(w >> 16),
                              (unsigned char)(w >> 8),
                              (unsigned char)w,
                              (unsigned char)(h >> 24),
                              (unsigned char)(h >> 16),
                              (unsigned char)(h >> 8),
                              (unsigned char)h,
                              8,
                              0,
                              0,
                              0,
                              0};
    put_chunk(&p, "IHDR", ihdr, sizeof ihdr);
    put_chunk(&p, "IDAT", z, z_n);
    put_chunk(&p, "IEND", NULL, 0);
    lr_test_write_file(name, png, (size_t)(p - png), path, cap);
    free(raw);
    free(z);
    free(png);
}

static double one(int x, int y)
{
    (void)x, (void)y;
    return 1.0;
}

static void test_texels(void **state)
{
    (void)state;
    char path[512];
    write_black_png("limit-big.png", 2048, 2048, path, sizeof path);
    /* The same file as an sRGB colour and as linear data: decoded, and
     * kept, twice. */
    const char *json =
        "{\"materials\": {\"a\": {\"diffuse_texture\": \"limit-big.png\"}, "
        "\"b\": {\"roughness_texture\": \"limit-big.png\"}}, "
        "\"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -3], "
        "\"radius\": 1, \"material\": \"a\"}]}";
    lr_error err;
    assert_int_equal(load(json, &err), LR_OK);
    lr_scene_limits_set(0, 1u << 20);
    assert_int_equal(load(json, &err), LR_ERR_LIMIT);
    assert_string_equal(err.path, "materials.a.diffuse_texture");
    assert_non_null(strstr(err.message, "materials.a.diffuse_texture: "));
    assert_non_null(strstr(err.message,
                           "is 2048 x 2048 pixels: the scene would hold more "
                           "than 1048576 texels, the limit set by "
                           "lr_scene_limits_set"));
    lr_scene_limits_set(0, 2048 * 2048);
    assert_int_equal(load(json, &err), LR_ERR_LIMIT);
    assert_string_equal(err.path, "materials.b.roughness_texture");
    lr_scene_limits_set(0, 2 * 2048 * 2048);
    assert_int_equal(load(json, &err), LR_OK);
    /* The environment map counts with them. */
    lr_test_write_map("limit-env.exr", one, 64, 32);
    const char *env = "{\"environment\": {\"file\": \"limit-env.exr\"}}";
    lr_scene_limits_set(0, 64 * 32 - 1);
    assert_int_equal(load(env, &err), LR_ERR_LIMIT);
    assert_string_equal(err.path, "environment.file");
    assert_non_null(strstr(err.message, "more than 2047 texels"));
    lr_scene_limits_set(0, 64 * 32);
    assert_int_equal(load(env, &err), LR_OK);
    lr_scene_limits_set(0, 0);
}

static const struct CMUnitTest scene_limits_tests[] = {
    cmocka_unit_test_teardown(test_triangles_of_repeated_obj, no_limits),
    cmocka_unit_test_teardown(test_triangles_of_gltf_nodes, no_limits),
    cmocka_unit_test_teardown(test_texels, no_limits),
};

LR_TEST_GROUP(scene_limits, scene_limits_tests)
