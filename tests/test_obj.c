/*
 * test_obj.c: the OBJ reader (lib/scene/obj.c).  Each test writes a small OBJ
 * file into the run's scratch directory and loads it, so the tests cover
 * the real file path including reading, not just the parser.
 */
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

/* Loads text that must parse; the caller frees the mesh. */
static void load_ok(const char *name, const char *text, lr__mesh *m)
{
    char path[512];
    lr_test_write_text(name, text, path, sizeof path);
    lr_error err;
    memset(&err, 0, sizeof err);
    lr_status st = lr__obj_load(path, "objects[0].file", m, &err);
    if (st != LR_OK)
        fail_msg("%s: %s", name, err.message);
}

/* Loads bytes that must fail with `status` and a message containing
 * `needle` (typically "name.obj:LINE:").  Also checks that the mesh is
 * left empty, so a caller that frees it anyway is safe. */
static void load_fail_bytes(const char *name, const char *data, size_t len,
                            lr_status status, const char *needle)
{
    char path[512];
    lr_test_write_file(name, data, len, path, sizeof path);
    lr_error err;
    memset(&err, 0, sizeof err);
    lr__mesh m;
    memset(&m, 0xab, sizeof m);
    lr_status st = lr__obj_load(path, "objects[1].file", &m, &err);
    assert_int_equal(st, status);
    assert_int_equal(err.status, status);
    assert_string_equal(err.path, "objects[1].file");
    if (strstr(err.message, needle) == NULL)
        fail_msg("message '%s' lacks '%s'", err.message, needle);
    /* Messages start with the path as given. */
    assert_memory_equal(err.message, path, strlen(path));
    assert_null(m.vertices);
    assert_null(m.indices);
    assert_null(m.normals);
    assert_int_equal(m.n_vertices, 0);
    assert_int_equal(m.n_triangles, 0);
    lr__mesh_free(&m);
}

static void load_fail(const char *name, const char *text, const char *needle)
{
    load_fail_bytes(name, text, strlen(text), LR_ERR_INVALID, needle);
}

static void assert_vec3(const float *v, double x, double y, double z)
{
    assert_true(fabs(v[0] - x) < 1e-6);
    assert_true(fabs(v[1] - y) < 1e-6);
    assert_true(fabs(v[2] - z) < 1e-6);
}

static void assert_tri(const lr__mesh *m, size_t t, unsigned a, unsigned b,
                       unsigned c)
{
    assert_true(t < m->n_triangles);
    assert_int_equal(m->indices[3 * t + 0], a);
    assert_int_equal(m->indices[3 * t + 1], b);
    assert_int_equal(m->indices[3 * t + 2], c);
}

static void test_triangle(void **state)
{
    (void)state;
    lr__mesh m;
    load_ok("tri.obj",
            "# one triangle\n"
            "v 0 0 0\n"
            "v 1.5 0 -2\n"
            "v 0 1e1 0.25\n"
            "f 1 2 3\n",
            &m);
    assert_int_equal(m.n_vertices, 3);
    assert_int_equal(m.n_triangles, 1);
    assert_vec3(&m.vertices[0], 0, 0, 0);
    assert_vec3(&m.vertices[3], 1.5, 0, -2);
    assert_vec3(&m.vertices[6], 0, 10, 0.25);
    assert_tri(&m, 0, 0, 1, 2);
    assert_null(m.normals);
    lr__mesh_free(&m);
    assert_null(m.vertices);
    lr__mesh_free(&m);
    lr__mesh_free(NULL);
}

static void test_quad_and_polygon_fan(void **state)
{
    (void)state;
    lr__mesh m;
    load_ok("quad.obj",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\n"
            "f 1 2 3 4\n"
            "f 1 2 3 5 4\n",
            &m);
    assert_int_equal(m.n_vertices, 5);
    /* 4 corners give 2 triangles, 5 give 3, all fanned around corner 1. */
    assert_int_equal(m.n_triangles, 5);
    assert_tri(&m, 0, 0, 1, 2);
    assert_tri(&m, 1, 0, 2, 3);
    assert_tri(&m, 2, 0, 1, 2);
    assert_tri(&m, 3, 0, 2, 4);
    assert_tri(&m, 4, 0, 4, 3);
    lr__mesh_free(&m);
}

/* The signed area of mesh m's triangle t in the xy plane. */
static double tri_area(const lr__mesh *m, size_t t)
{
    const float *a = &m->vertices[3 * m->indices[3 * t]];
    const float *b = &m->vertices[3 * m->indices[3 * t + 1]];
    const float *c = &m->vertices[3 * m->indices[3 * t + 2]];
    return 0.5 * (((double)b[0] - a[0]) * ((double)c[1] - a[1]) -
                  ((double)b[1] - a[1]) * ((double)c[0] - a[0]));
}

/* A concave polygon is cut into triangles inside it: each counter-
 * clockwise as the face (positive area), together its area.  A fan about
 * corner 1 of this L (area 3) covered 3.25, its notch filled, whichever
 * corner came first in the L's other orders; and as the L turned round,
 * a comb (area 7), each written from every corner. */
static void test_concave_polygon(void **state)
{
    (void)state;
    static const double L[][2] = {{1, -1}, {1, 0},  {0, 0},
                                  {0, 1},  {-1, 1}, {-1, -1}};
    static const double comb[][2] = {{-1.5, -1.5}, {1.5, -1.5}, {1.5, 1.5},
                                     {1, 1.5},     {1, -0.5},   {0.5, -0.5},
                                     {0.5, 1.5},   {0, 1.5},    {0, -0.5},
                                     {-0.5, -0.5}, {-0.5, 1.5}, {-1.5, 1.5}};
    const struct {
        const double (*p)[2];
        size_t n;
        double area;
    } polys[] = {{L, 6, 3.0}, {comb, 12, 7.0}};
    for (size_t k = 0; k < 2; k++)
        for (size_t r = 0; r < polys[k].n; r++) {
            char text[1024];
            size_t len = 0, n = polys[k].n;
            for (size_t i = 0; i < n; i++)
                len += (size_t)snprintf(
                    text + len, sizeof text - len, "v %g %g 0\n",
                    polys[k].p[(i + r) % n][0], polys[k].p[(i + r) % n][1]);
            len += (size_t)snprintf(text + len, sizeof text - len, "f");
            for (size_t i = 0; i < n; i++)
                len += (size_t)snprintf(text + len, sizeof text - len, " %zu",
                                        i + 1);
            snprintf(text + len, sizeof text - len, "\n");
            lr__mesh m;
            load_ok("concave.obj", text, &m);
            assert_int_equal(m.n_triangles, n - 2);
            double sum = 0.0;
            for (size_t t = 0; t < m.n_triangles; t++) {
                double a = tri_area(&m, t);
                if (!(a >= 0.0))
                    fail_msg("polygon %zu from corner %zu: triangle %zu is "
                             "clockwise (%g)",
                             k, r, t, a);
                sum += a;
            }
            if (fabs(sum - polys[k].area) > 1e-9)
                fail_msg("polygon %zu from corner %zu: triangles cover %g, "
                         "the polygon %g",
                         k, r, sum, polys[k].area);
            lr__mesh_free(&m);
        }
}

/* A vertex beyond 1e15 after the transform: the message names the file
 * and which "v" line (it named neither). */
static void test_vertex_out_of_range_named(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_text("far.obj", "v 0 0 0\nv 1 0 0\nv 0 1e20 0\nf 1 2 3\n",
                       path, sizeof path);
    const char *json =
        "{\"objects\": [{\"type\": \"mesh\", \"file\": \"far.obj\"}]}";
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                        NULL, 0, &s, &err),
                     LR_ERR_INVALID);
    if (strstr(err.message, "objects[0].file: far.obj: vertex 3 (the 3rd "
                            "\"v\" line) reaches 1e+20") == NULL)
        fail_msg("%s", err.message);
}

/* What an OBJ says and the mesh does not use is a warning naming the
 * file and line: usemtl (the object's one material is used), a face
 * without normals in a file that has them, or without texture
 * coordinates (all of the file's are dropped); each went unsaid. */
static void test_unused_statements_warned(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_text("mixed.obj",
                       "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                       "vn 0 0 1\nvt 0 0\nusemtl red\nf 1/1/1 2/1/1 3/1/1\n"
                       "usemtl blue\nf 2 4 3\n",
                       path, sizeof path);
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"mesh\", \"file\": \"mixed.obj\"}]}");
    const char *w = lr_scene_warnings(s);
    if (strstr(w, "objects[0].file: mixed.obj: its 2 usemtl lines are "
                  "ignored") == NULL ||
        strstr(w, "mixed.obj:11: a face without normals") == NULL ||
        strstr(w, "mixed.obj:11: a face without texture coordinates") == NULL)
        fail_msg("warnings: \"%s\"", w);
    lr_scene_free(s);
    /* A file without normals or texture coordinates at all says nothing. */
    lr_test_write_text("plain.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                       path, sizeof path);
    s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"mesh\", \"file\": \"plain.obj\"}]}");
    assert_string_equal(lr_scene_warnings(s), "");
    lr_scene_free(s);
}

/* lr_scene_files_changed: unchanged after the caller's chdir (the file
 * was logged by its relative path, "gone" from elsewhere), changed after
 * an edit. */
static void test_files_changed(void **state)
{
    (void)state;
    char path[512], cwd[1024];
    lr_test_write_text("fc.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", path,
                       sizeof path);
    assert_non_null(getcwd(cwd, sizeof cwd));
    assert_int_equal(chdir(lr_test_tmpdir()), 0);
    const char *json =
        "{\"objects\": [{\"type\": \"mesh\", \"file\": \"fc.obj\"}]}";
    lr_scene *s = NULL;
    lr_error err;
    lr_status st = lr_scene_load_json(json, strlen(json), NULL, NULL, 0, &s,
                                      &err);
    assert_int_equal(chdir(cwd), 0);
    assert_int_equal(st, LR_OK);
    assert_int_equal(lr_scene_files_changed(s), 0);
    lr_test_write_text("fc.obj", "v 0 0 0\nv 20 0 0\nv 0 1 0\nf 1 2 3\n", path,
                       sizeof path);
    assert_int_equal(lr_scene_files_changed(s), 1);
    lr_scene_free(s);
    /* A link switched to another file is a change (realpath logged the
     * link's old target, unchanged). */
    char a[600], b[600], link[600];
    lr_test_write_text("fa.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", a,
                       sizeof a);
    lr_test_write_text("fb.obj", "v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n", b,
                       sizeof b);
    snprintf(link, sizeof link, "%s/fl.obj", lr_test_tmpdir());
    unlink(link);
    assert_int_equal(symlink("fa.obj", link), 0);
    s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"mesh\", \"file\": \"fl.obj\"}]}");
    assert_int_equal(lr_scene_files_changed(s), 0);
    unlink(link);
    assert_int_equal(symlink("fb.obj", link), 0);
    assert_int_equal(lr_scene_files_changed(s), 1);
    lr_scene_free(s);
}

static void test_negative_indices(void **state)
{
    (void)state;
    lr__mesh m;
    /* Negative indices count back from the vertices read so far, so the
     * same "-3 -2 -1" means different vertices at different lines. */
    load_ok("neg.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
            "f -3 -2 -1\n"
            "v 0 0 1\n"
            "f -3 -2 -1\n"
            "f -4 2 -1\n",
            &m);
    assert_int_equal(m.n_triangles, 3);
    assert_tri(&m, 0, 0, 1, 2);
    assert_tri(&m, 1, 1, 2, 3);
    assert_tri(&m, 2, 0, 1, 3);
    lr__mesh_free(&m);
}

static void test_normals(void **state)
{
    (void)state;
    lr__mesh m;
    load_ok("normals.obj",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\n"
            "vn 0 0 2\n"
            "vn 3 4 0\n"
            "f 1//1 2//1 3//2\n"
            "f 1/1/2 3/3/1 4/2/-1\n",
            &m);
    assert_int_equal(m.n_triangles, 2);
    assert_non_null(m.normals);
    /* Normals are per corner and unit length. */
    assert_vec3(&m.normals[0], 0, 0, 1);
    assert_vec3(&m.normals[3], 0, 0, 1);
    assert_vec3(&m.normals[6], 0.6, 0.8, 0);
    assert_vec3(&m.normals[9], 0.6, 0.8, 0);
    assert_vec3(&m.normals[12], 0, 0, 1);
    assert_vec3(&m.normals[15], 0.6, 0.8, 0);
    assert_tri(&m, 1, 0, 2, 3);
    for (size_t k = 0; k < 3 * m.n_triangles; k++) {
        const float *n = &m.normals[3 * k];
        double len = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] +
                          (double)n[2] * n[2]);
        assert_true(fabs(len - 1.0) < 1e-6);
    }
    lr__mesh_free(&m);
}

static void test_quad_normals_follow_fan(void **state)
{
    (void)state;
    lr__mesh m;
    load_ok("quadn.obj",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
            "vn 1 0 0\nvn 0 1 0\nvn 0 0 1\nvn -1 0 0\n"
            "f 1//1 2//2 3//3 4//4\n",
            &m);
    assert_int_equal(m.n_triangles, 2);
    assert_non_null(m.normals);
    assert_vec3(&m.normals[0], 1, 0, 0);
    assert_vec3(&m.normals[3], 0, 1, 0);
    assert_vec3(&m.normals[6], 0, 0, 1);
    assert_vec3(&m.normals[9], 1, 0, 0);
    assert_vec3(&m.normals[12], 0, 0, 1);
    assert_vec3(&m.normals[15], -1, 0, 0);
    lr__mesh_free(&m);
}

static void test_mixed_normals_dropped(void **state)
{
    (void)state;
    lr__mesh m;
    load_ok("mixed.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n"
            "f 1//1 2//1 3//1\n"
            "f 1 2 3\n"
            "f 1//1 2//1 3//1\n",
            &m);
    assert_int_equal(m.n_triangles, 3);
    assert_null(m.normals);
    lr__mesh_free(&m);

    /* One corner without a normal is enough. */
    load_ok("mixed2.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n"
            "f 1//1 2//1 3\n",
            &m);
    assert_null(m.normals);
    lr__mesh_free(&m);
}

static void test_ignored_statements_and_syntax(void **state)
{
    (void)state;
    lr__mesh m;
    load_ok("misc.obj",
            "\xEF\xBB\xBF# exported by something\n"
            "mtllib scene.mtl\n"
            "o Thing\n"
            "g group1 group2\n"
            "s off\n"
            "usemtl red\n"
            "\n"
            "   \t  \n"
            "v\t0 0 0 1.0\n"
            "v 1 0 0 0.5 0.25 1 # vertex colours\n"
            "v   0  1  0   \n"
            "vt 0.5 0.5\n"
            "vp 0.1 0.2\n"
            "l 1 2\n"
            "p 3\n"
            "curv 0 1 1 2\n"
            "f 1 \\\n"
            "  2 3 # a face over two lines\n"
            "f 1 2 3 # comment with a backslash \\\n"
            "f +1 +2 +3\n",
            &m);
    assert_int_equal(m.n_vertices, 3);
    assert_int_equal(m.n_triangles, 3);
    assert_vec3(&m.vertices[3], 1, 0, 0);
    assert_tri(&m, 0, 0, 1, 2);
    assert_tri(&m, 2, 0, 1, 2);
    lr__mesh_free(&m);
}

static void test_crlf(void **state)
{
    (void)state;
    lr__mesh m;
    load_ok("crlf.obj",
            "# windows\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nvn 0 0 1\r\n"
            "f 1//1 2//1 3//1\r\n",
            &m);
    assert_int_equal(m.n_vertices, 3);
    assert_int_equal(m.n_triangles, 1);
    assert_non_null(m.normals);
    assert_vec3(&m.vertices[3], 1, 0, 0);
    lr__mesh_free(&m);

    /* No newline at the end of the last line. */
    load_ok("noeol.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3", &m);
    assert_int_equal(m.n_triangles, 1);
    lr__mesh_free(&m);
}

static void test_missing_file(void **state)
{
    (void)state;
    char path[512];
    snprintf(path, sizeof path, "%s/does-not-exist.obj", lr_test_tmpdir());
    lr_error err;
    lr__mesh m;
    assert_int_equal(lr__obj_load(path, NULL, &m, &err), LR_ERR_IO);
    assert_int_equal(err.status, LR_ERR_IO);
    assert_string_equal(err.path, "");
    assert_non_null(strstr(err.message, "does-not-exist.obj"));
    assert_null(m.vertices);

    /* A directory cannot be read as a file either. */
    assert_int_equal(lr__obj_load(lr_test_tmpdir(), NULL, &m, &err), LR_ERR_IO);
    /* Without an lr_error the status alone comes back. */
    assert_int_equal(lr__obj_load(path, NULL, &m, NULL), LR_ERR_IO);
}

static void test_bad_indices(void **state)
{
    (void)state;
    load_fail("zero.obj", "v 0 0 0\nv 1 0 0\nf 0 1 2\n",
              "zero.obj:3: face index 0 out of range");
    load_fail("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n",
              "range.obj:4: face index 7 out of range (the file has 3 "
              "vertices so far)");
    /* Indices refer to what came before, not to later vertices. */
    load_fail("later.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n",
              "later.obj:3: face index 3 out of range (the file has 2 "
              "vertices so far)");
    load_fail("negrange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
              "negrange.obj:4: face index -4 out of range");
    load_fail("huge.obj",
              "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n",
              "huge.obj:4: face index");
    load_fail("nrange.obj",
              "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n"
              "f 1//1 2//1 3//2\n",
              "nrange.obj:5: face normal index 2 out of range (the file has "
              "1 normal so far)");
    load_fail("trange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n",
              "trange.obj:4: face texture index 1 out of range");
    load_fail("corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1/1/1\n",
              "corner.obj:4: bad face corner '3/1/1/1'");
    load_fail("corner2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
              "corner2.obj:4: bad face corner 'x'");
    load_fail("corner3.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3//\n",
              "corner3.obj:4: bad face corner");
    load_fail("corner4.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3.0\n",
              "corner4.obj:4: bad face corner");
}

static void test_bad_numbers(void **state)
{
    (void)state;
    load_fail("num.obj", "v 0 0 0\nv 1 0 0\nv 1 x 2\nf 1 2 3\n",
              "num.obj:3: bad number 'x'");
    load_fail("num2.obj", "v 0 0 0\nv 1 0 0\nv 1 2 3z\nf 1 2 3\n",
              "num2.obj:3: bad number '3z'");
    /* Decimal only: strtod's hexadecimal is no OBJ number. */
    load_fail("hex.obj", "v 0 0 0\nv 1 0 0\nv 0x1 1 0\nf 1 2 3\n",
              "hex.obj:3: bad number '0x1'");
    load_fail("nan.obj", "v 0 0 0\nv 1 0 0\nv nan 0 0\nf 1 2 3\n",
              "nan.obj:3: non-finite");
    load_fail("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n",
              "inf.obj:3: non-finite");
    /* As old MSVC printed NaN and infinity: read as "1." and a comment,
     * a vertex at 1 and a normal (0, 0, 1). */
    load_fail("msnan.obj", "v 0 0 0\nv 1 0 0\nv 1 -1 1.#QNAN\nf 1 2 3\n",
              "msnan.obj:3: non-finite number '1.#QNAN'");
    load_fail("msind.obj", "v 0 0 0\nv 1 0 0\nv 1 -1 -1.#IND00 # c\nf 1 2 3\n",
              "msind.obj:3: non-finite number '-1.#IND00'");
    load_fail("msinf.obj",
              "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1.#INF\nf 1 2 3\n",
              "msinf.obj:4: non-finite number '1.#INF'");
    /* ... but a name and a comment after a number are what they were. */
    lr__mesh mm;
    load_ok("hashname.obj",
            "o Part2#lid\nv 0 0 0\nv 1 0 0\nv 0 1 0#apex\nf 1 2 3\n", &mm);
    assert_int_equal(mm.n_triangles, 1);
    assert_vec3(&mm.vertices[6], 0, 1, 0);
    lr__mesh_free(&mm);
    load_fail("over.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1e400\nf 1 2 3\n",
              "over.obj:3: number '1e400' in a 'v' line is too large");
    load_fail("flt.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1e39\nf 1 2 3\n",
              "flt.obj:3: number '1e39'");
    load_fail("short.obj", "v 0 0 0\nv 1 0 0\nv 0 1\nf 1 2 3\n",
              "short.obj:3: a 'v' line needs 3 numbers");
    load_fail("long.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0 1 1 1 1 1\nf 1 2 3\n",
              "long.obj:3: too many numbers");
    load_fail("vn0.obj", "v 0 0 0\nv 1 0 0\nvn 0 0 0\nf 1 2 3\n",
              "vn0.obj:3: zero-length normal");
    load_fail("vnnan.obj", "v 0 0 0\nv 1 0 0\nvn 0 nan 1\nf 1 2 3\n",
              "vnnan.obj:3: non-finite");
}

static void test_bad_structure(void **state)
{
    (void)state;
    load_fail("two.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n",
              "two.obj:3: a face needs at least 3 corners, this one has 2");
    load_fail("emptyface.obj", "v 0 0 0\nv 1 0 0\nf # nothing\n",
              "emptyface.obj:3: a face needs at least 3 corners");
    load_fail("nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
              "nofaces.obj:3: the file has no faces");
    load_fail("empty.obj", "", "empty.obj:1: the file has no faces");
    /* Binary data: a NUL byte on line 3. */
    static const char bin[] = "v 0 0 0\nv 1 0 0\n\x7f"
                              "ELF\x02\x01\x01\0\0\0\nf 1 2 3\n";
    load_fail_bytes("binary.obj", bin, sizeof bin - 1, LR_ERR_INVALID,
                    "binary.obj:3: not a text OBJ file");
    static const char bin2[] = "v 0 0 0\n\0";
    load_fail_bytes("nul.obj", bin2, sizeof bin2 - 1, LR_ERR_INVALID,
                    "nul.obj:2: not a text OBJ file");
    /* A continuation line moves the reported line to where the
     * statement began. */
    load_fail("cont.obj", "v 0 0 0\nv 1 0 0\nv 0 \\\n1 0\nf 1 2 \\\n 9\n",
              "cont.obj:5: face index 9 out of range");
    /* A continuation with no line after it is named as such, not taken
     * for a face corner '\', whether the file ends right after it,
     * after a newline, after CRLF, or it stands alone. */
    static const char *const cont_end[][2] = {
        {"f 1 2 3 \\", "contend1.obj:4: line continuation"},
        {"f 1 2 3 \\\n", "contend2.obj:4: line continuation"},
        {"f 1 2 3 \\\r\n", "contend3.obj:4: line continuation"},
        {"f 1 2 3\n\\", "contend4.obj:5: line continuation"},
    };
    for (size_t i = 0; i < sizeof cont_end / sizeof cont_end[0]; i++) {
        char name[32], text[128];
        snprintf(name, sizeof name, "contend%zu.obj", i + 1);
        snprintf(text, sizeof text, "v 0 0 0\nv 1 0 0\nv 0 1 0\n%s",
                 cont_end[i][0]);
        load_fail(name, text, cont_end[i][1]);
    }
    /* ... but in a comment a backslash is only text. */
    lr__mesh m;
    load_ok("contcomment.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # \\", &m);
    assert_int_equal(m.n_triangles, 1);
    lr__mesh_free(&m);
    /* CRLF keeps line numbers right. */
    load_fail("crlfbad.obj", "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 4\r\n",
              "crlfbad.obj:4: face index 4 out of range");
}

static void test_size_limit(void **state)
{
    (void)state;
    /* A sparse file just over 1 GiB: the size alone is rejected, so
     * nothing is read or allocated. */
    char path[512];
    lr_test_write_text("big.obj", "", path, sizeof path);
    assert_int_equal(truncate(path, ((off_t)1 << 30) + 1), 0);
    lr_error err;
    lr__mesh m;
    assert_int_equal(lr__obj_load(path, "objects[5].file", &m, &err),
                     LR_ERR_LIMIT);
    assert_non_null(strstr(err.message, "big.obj"));
    assert_string_equal(err.path, "objects[5].file");
    assert_int_equal(unlink(path), 0);
}

static void test_larger_mesh(void **state)
{
    (void)state;
    /* A grid big enough to make every array grow several times. */
    enum { N = 60 };
    char path[512];
    snprintf(path, sizeof path, "%s/grid.obj", lr_test_tmpdir());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (int y = 0; y <= N; y++)
        for (int x = 0; x <= N; x++)
            fprintf(f, "v %d %d 0\n", x, y);
    fprintf(f, "vn 0 0 1\n");
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) {
            int a = y * (N + 1) + x + 1;
            fprintf(f, "f %d//1 %d//1 %d//1 %d//1\n", a, a + 1, a + N + 2,
                    a + N + 1);
        }
    assert_int_equal(fclose(f), 0);
    lr__mesh m;
    lr_error err;
    assert_int_equal(lr__obj_load(path, NULL, &m, &err), LR_OK);
    assert_int_equal(m.n_vertices, (N + 1) * (N + 1));
    assert_int_equal(m.n_triangles, 2 * N * N);
    assert_non_null(m.normals);
    size_t last = m.n_triangles - 1;
    unsigned a = (unsigned)((N - 1) * (N + 1) + N - 1);
    assert_tri(&m, last, a, a + N + 2, a + N + 1);
    assert_vec3(&m.normals[9 * last + 6], 0, 0, 1);
    lr__mesh_free(&m);
}

static const struct CMUnitTest obj_tests[] = {
    cmocka_unit_test(test_triangle),
    cmocka_unit_test(test_quad_and_polygon_fan),
    cmocka_unit_test(test_concave_polygon),
    cmocka_unit_test(test_vertex_out_of_range_named),
    cmocka_unit_test(test_files_changed),
    cmocka_unit_test(test_unused_statements_warned),
    cmocka_unit_test(test_negative_indices),
    cmocka_unit_test(test_normals),
    cmocka_unit_test(test_quad_normals_follow_fan),
    cmocka_unit_test(test_mixed_normals_dropped),
    cmocka_unit_test(test_ignored_statements_and_syntax),
    cmocka_unit_test(test_crlf),
    cmocka_unit_test(test_missing_file),
    cmocka_unit_test(test_bad_indices),
    cmocka_unit_test(test_bad_numbers),
    cmocka_unit_test(test_bad_structure),
    cmocka_unit_test(test_size_limit),
    cmocka_unit_test(test_larger_mesh),
};

LR_TEST_GROUP(obj, obj_tests)
