/*
 * test_texture_scene.c: textures in scenes: OBJ `vt` (lib/scene/obj.c,
 * obj_face.c), the material keys and their errors (material_json.c),
 * the identity "a constant texture of value c = the colour c" under both
 * integrators, the vector lanes against the scalar code on a textured
 * mesh, a checkerboard seen through a pinhole landing where the
 * projection says, and the daemon's list of files to confine (job.c).
 */
#include "test.h"
#include "integrator/integrator.h"
#include "scene/light.h"
#include "accel/trace.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* An EXR in the scratch directory (lr_test_write_exr). */
static void write_exr(const char *name, int w, int h,
                      void (*f)(int x, int y, float rgb[3]))
{
    char path[512];
    lr_test_write_exr(name, w, h, f, path, sizeof path);
}

static void constant(int x, int y, float rgb[3])
{
    (void)x, (void)y;
    rgb[0] = 0.5f, rgb[1] = 0.25f, rgb[2] = 0.75f;
}

/* R: a checkerboard of 8 x 8 texels, white where x + y is even; G: x / 8;
 * B: y / 8 (row 0 at the top). */
static void checker(int x, int y, float rgb[3])
{
    rgb[0] = (x + y) % 2 == 0 ? 1.0f : 0.0f;
    rgb[1] = x / 8.0f;
    rgb[2] = y / 8.0f;
}

static lr_status load_status(const char *json, lr_error *err)
{
    lr_scene *s = NULL;
    memset(err, 0, sizeof *err);
    lr_status st = lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                      NULL, 0, &s, err);
    lr_scene_free(s);
    return st;
}

/* ---- OBJ texture coordinates ----------------------------------------- */

static void obj_vt(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_text("uv.obj",
                       "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                       "vt 0 0\nvt 1 0\nvt 1 1 0.5\nvt 0.25\n"
                       "f 1/1 2/2 3/3 4/4\n",
                       path, sizeof path);
    lr__mesh m;
    lr_error err;
    assert_int_equal(lr__obj_load(path, "f", &m, &err), LR_OK);
    assert_int_equal(m.n_triangles, 2);
    assert_non_null(m.uvs);
    /* Fan: (1, 2, 3), (1, 3, 4). */
    static const float want[12] = {0, 0, 1, 0, 1, 1, 0, 0, 1, 1, 0.25f, 0};
    for (int k = 0; k < 12; k++)
        assert_true(m.uvs[k] == want[k]);
    lr__mesh_free(&m);

    /* One face without vt: the mesh has none. */
    lr_test_write_text("uv_part.obj",
                       "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\n"
                       "f 1/1 2/1 3/1\nf 1 2 3\n",
                       path, sizeof path);
    assert_int_equal(lr__obj_load(path, "f", &m, &err), LR_OK);
    assert_null(m.uvs);
    lr__mesh_free(&m);

    /* Bad and out-of-range vt, named by file and line. */
    static const struct {
        const char *text, *needle;
    } bad[] = {
        {"v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/2 2/1 3/1\n",
         "bad_vt.obj:5: face texture index 2 out of range (the file has 1 "
         "texture coordinate so far)"},
        {"v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/-2 2/1 3/1\n",
         "bad_vt.obj:5: face texture index -2 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1/1 2/1 3/1\nvt 0 0\n",
         "bad_vt.obj:4: face texture index 1 out of range (the file has 0 "
         "texture coordinates so far)"},
        {"v 0 0 0\nvt 0 nan\n", "bad_vt.obj:2: non-finite number 'nan' in a "
                                "'vt' line"},
        {"v 0 0 0\nvt\n", "bad_vt.obj:2: a 'vt' line needs 1 numbers"},
        {"v 0 0 0\nvt 1 2 3 4\n", "bad_vt.obj:2: too many numbers in a 'vt'"},
        {"v 0 0 0\nvt 1e39 0\n", "bad_vt.obj:2: number '1e39' in a 'vt' "
                                 "line is too large for a float"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        lr_test_write_text("bad_vt.obj", bad[i].text, path, sizeof path);
        assert_int_equal(lr__obj_load(path, "objects[0].file", &m, &err),
                         LR_ERR_INVALID);
        if (strstr(err.message, bad[i].needle) == NULL)
            fail_msg("'%s' lacks '%s'", err.message, bad[i].needle);
        assert_null(m.uvs);
    }
}

/* ---- scene keys and their errors -------------------------------------- */

static void material_errors(void **state)
{
    (void)state;
    write_exr("const.exr", 2, 2, constant);
    char path[512];
    lr_test_write_text("novt.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", path,
                       sizeof path);
    lr_test_write_text("notimage.png", "just text", path, sizeof path);
    static const struct {
        const char *json, *path, *needle;
    } cases[] = {
        {"{\"materials\": {\"t\": {\"diffuse_texture\": \"const.exr\"}},"
         " \"objects\": [{\"type\": \"triangle\", \"material\": \"t\","
         " \"vertices\": [[0,0,0],[1,0,0],[0,1,0]]}]}",
         "objects[0]",
         "objects[0]: material \"t\" sets diffuse_texture, "
         "but objects[0] has no texture coordinates"},
        {"{\"materials\": {\"t\": {\"emission_texture\": \"const.exr\"}},"
         " \"objects\": [{\"type\": \"plane\", \"material\": \"t\","
         " \"normal\": [0,1,0]}]}",
         "objects[0]", "an infinite plane has none"},
        {"{\"materials\": {\"t\": {\"roughness_texture\": \"const.exr\"}},"
         " \"objects\": [{\"type\": \"sphere\", \"radius\": 1,"
         " \"center\": [0,0,-3]}, {\"type\": \"mesh\", \"file\":"
         " \"novt.obj\", \"material\": \"t\"}]}",
         "objects[1]", "objects[1]: material \"t\" sets roughness_texture"},
        {"{\"materials\": {\"t\": {\"diffuse_texture\": \"missing.png\"}}}",
         "materials.t.diffuse_texture",
         "materials.t.diffuse_texture: missing.png: cannot open"},
        {"{\"materials\": {\"t\": {\"diffuse_texture\": \"notimage.png\"}}}",
         "materials.t.diffuse_texture",
         "materials.t.diffuse_texture: notimage.png is not a PNG, JPEG or "
         "OpenEXR image"},
        {"{\"materials\": {\"t\": {\"diffuse_texture\": \"\"}}}",
         "materials.t.diffuse_texture", "must name an image file"},
        {"{\"materials\": {\"t\": {\"roughness_channel\": 4}}}",
         "materials.t.roughness_channel", "roughness_channel"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        lr_error err;
        assert_int_not_equal(load_status(cases[i].json, &err), LR_OK);
        assert_string_equal(err.path, cases[i].path);
        if (strstr(err.message, cases[i].needle) == NULL)
            fail_msg("case %zu: '%s' lacks '%s'", i, err.message,
                     cases[i].needle);
    }
    /* Spheres and finite planes have coordinates; one file is loaded
     * once for the two materials that share it. */
    lr_scene *s = lr_test_load_json(
        "{\"materials\": {\"a\": {\"diffuse_texture\": \"const.exr\"},"
        " \"b\": {\"diffuse_texture\": \"const.exr\", \"diffuse\": 0.5}},"
        " \"objects\": [{\"type\": \"sphere\", \"radius\": 1, \"center\":"
        " [0,0,-3], \"material\": \"a\"}, {\"type\": \"plane\", \"normal\":"
        " [0,1,0], \"size\": 2, \"material\": \"b\"}]}");
    assert_int_equal(s->n_textures, 1);
    assert_ptr_equal(s->materials[1].diffuse_tex, s->materials[2].diffuse_tex);
    /* A texture without its factor means factor 1. */
    assert_true(s->materials[1].diffuse.x == 1.0);
    assert_true(s->materials[2].diffuse.x == 0.5);
    lr_scene_free(s);
}

/* ---- constant texture = colour, bit for bit --------------------------- */

/* A scene whose material "m" is given by `mat` (JSON members): a finite
 * plane, a sphere and an emissive quad, lit by a point light and an
 * ambient term. */
static lr_image *render_mat(const char *mat, const char *emit,
                            const char *integrator)
{
    char json[2048];
    snprintf(
        json, sizeof json,
        "{\"camera\": {\"position\": [0, 1.5, 4], \"look_at\": [0, 0.5, 0]},"
        " \"render\": {\"width\": 48, \"height\": 36, \"spp\": 4,"
        "  \"integrator\": \"%s\", \"max_depth\": 3},"
        " \"materials\": {\"m\": {%s}, \"e\": {%s}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [2, 4, 3],"
        "  \"intensity\": 20}, {\"type\": \"ambient\", \"radiance\": 0.1}],"
        " \"objects\": ["
        "  {\"type\": \"plane\", \"normal\": [0, 1, 0], \"size\": 6,"
        "   \"material\": \"m\"},"
        "  {\"type\": \"sphere\", \"center\": [0.5, 0.6, 0], \"radius\": 0.6,"
        "   \"material\": \"m\"},"
        "  {\"type\": \"plane\", \"point\": [-1, 1, -1], \"normal\":"
        "   [0.5, -0.3, 1], \"size\": 1, \"material\": \"e\"}]}",
        integrator, mat, emit);
    return lr_test_render_json(json, mat);
}

static void constant_texture_identity(void **state)
{
    (void)state;
    write_exr("c.exr", 2, 2, constant);
    static const char *const integrators[] = {"whitted", "path"};
    for (int k = 0; k < 2; k++) {
        lr_image *a = render_mat("\"diffuse\": [0.5, 0.25, 0.75]",
                                 "\"emission\": [0.5, 0.25, 0.75]",
                                 integrators[k]);
        lr_image *b = render_mat("\"diffuse_texture\": \"c.exr\"",
                                 "\"emission_texture\": \"c.exr\"",
                                 integrators[k]);
        lr_test_assert_same_bytes(a, b, integrators[k]);
        /* And the image is not black: the test could fail. */
        double sum = 0;
        for (size_t i = 0; i < lr_test_n_values(a); i++)
            sum += lr_image_rgb(a)[i];
        assert_true(sum > 1.0);
        lr_image_free(a);
        lr_image_free(b);
    }
    /* Roughness: a texture of r = 1 with factor alpha equals alpha. */
    lr_image *a = render_mat("\"reflect\": 0.8, \"roughness\": 0.3",
                             "\"emission\": 2", "path");
    lr_image *b = render_mat("\"reflect\": 0.8, \"roughness\": 0.3, "
                             "\"roughness_texture\": \"one.exr\"",
                             "\"emission\": 2", "path");
    lr_test_assert_same_bytes(a, b, "roughness");
    lr_image_free(a);
    lr_image_free(b);
}

static void one(int x, int y, float rgb[3])
{
    (void)x, (void)y;
    rgb[0] = rgb[1] = rgb[2] = 1.0f;
}

static int setup_one(void **state)
{
    (void)state;
    write_exr("one.exr", 1, 1, one);
    return 0;
}

/* ---- the vector lanes see the texture --------------------------------- */

static void vector_lanes_textured(void **state)
{
    (void)state;
    write_exr("checker.exr", 8, 8, checker);
    char path[512];
    /* A textured OBJ quad (Lambertian: the vector path takes it). */
    lr_test_write_text("quad_uv.obj",
                       "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                       "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                       "f 1/1 2/2 3/3 4/4\n",
                       path, sizeof path);
    const char *json =
        "{\"camera\": {\"position\": [0.3, 0.2, 3], \"look_at\": [0, 0, 0]},"
        " \"render\": {\"width\": 48, \"height\": 40, \"spp\": 4},"
        " \"materials\": {\"t\": {\"diffuse_texture\": \"checker.exr\"}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [1, 2, 3],"
        "  \"intensity\": 10}, {\"type\": \"ambient\", \"radiance\": 0.2}],"
        " \"objects\": [{\"type\": \"mesh\", \"file\": \"quad_uv.obj\","
        "  \"material\": \"t\"}]}";
    lr_scene *s = lr_test_load_json(json);
    assert_true(s->geoms[0].lambert_triangles);
    lr_scene_free(s);
    lr_image *img[2];
    for (int k = 0; k < 2; k++) {
        lr__whitted_scalar_only = k;
        img[k] = lr_test_render_json(json, "checker quad");
        lr__whitted_scalar_only = 0;
    }
    lr_test_assert_same_bytes(img[0], img[1], "vector vs scalar");
    /* Not flat: the checker shows (some pixel dark, some bright). */
    float lo = 1e9f, hi = 0;
    for (size_t i = 0; i < lr_test_n_values(img[0]); i += 3) {
        float r = lr_image_rgb(img[0])[i];
        lo = r < lo ? r : lo;
        hi = r > hi ? r : hi;
    }
    assert_true(hi > 10 * lo + 0.05f);
    lr_image_free(img[0]);
    lr_image_free(img[1]);
}

/* ---- a checkerboard through a pinhole --------------------------------- */

/* The quad [-1, 1]^2 at z = 0 facing +z (a finite plane: u along +x, v
 * along +y), seen from (0, 0, 3) with a 60 degree square view, lit only
 * by ambient radiance 1 (Whitted: pixel = albedo), one sample per pixel
 * at its centre (grid sampler).  For each pixel the test intersects the
 * centre ray with the quad itself, turns the hit into texel coordinates
 * and predicts the bilinear value from the texture's definition. */
static void checker_projection(void **state)
{
    (void)state;
    write_exr("checker2.exr", 8, 8, checker);
    const int W = 64;
    lr_image *img = lr_test_render_json(
        "{\"camera\": {\"position\": [0, 0, 3], \"look_at\": [0, 0, 0],"
        "  \"fov\": 60},"
        " \"render\": {\"width\": 64, \"height\": 64, \"spp\": 1,"
        "  \"sampler\": \"grid\", \"adaptive\": false},"
        " \"materials\": {\"t\": {\"diffuse_texture\": \"checker2.exr\"}},"
        " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"normal\": [0, 0, 1],"
        "  \"size\": 2, \"material\": \"t\"}]}",
        "checker");
    const float *px = lr_image_rgb(img);
    double tan_h = tan(30.0 * M_PI / 180.0);
    int checked = 0;
    double worst = 0;
    for (int py = 0; py < W; py++)
        for (int qx = 0; qx < W; qx++) {
            /* The pixel centre's ray: (xn tan, yn tan, -1) from z = 3. */
            double xn = (2.0 * (qx + 0.5) / W - 1.0) * tan_h;
            double yn = (1.0 - 2.0 * (py + 0.5) / W) * tan_h;
            double x = 3.0 * xn, y = 3.0 * yn;
            const float *p = &px[3 * (py * W + qx)];
            if (fabs(x) > 0.999 || fabs(y) > 0.999) {
                if (fabs(x) > 1.001 || fabs(y) > 1.001)
                    assert_true(p[0] == 0.0f && p[1] == 0.0f);
                continue;
            }
            double u = (x + 1) / 2, v = (y + 1) / 2;
            /* Texel coordinates: centres at integers, row 0 at the top. */
            double tx = u * 8 - 0.5, ty = (1 - v) * 8 - 0.5;
            /* Inside the texture, away from the wrap: G and B are the
             * linear ramps x / 8 and y / 8 interpolated. */
            if (tx < 0 || tx > 7 || ty < 0 || ty > 7)
                continue;
            int i0 = (int)floor(tx), j0 = (int)floor(ty);
            double fx = tx - i0, fy = ty - j0;
            double c00 = (i0 + j0) % 2 == 0 ? 1 : 0, c10 = 1 - c00;
            double red = (1 - fx) * (1 - fy) * c00 + fx * (1 - fy) * c10 +
                         (1 - fx) * fy * c10 + fx * fy * c00;
            double e = fmax(fabs(p[0] - red),
                            fmax(fabs(p[1] - tx / 8), fabs(p[2] - ty / 8)));
            worst = fmax(worst, e);
            if (e > 1e-4)
                fail_msg("pixel (%d, %d): (%g, %g, %g), predicted (%g, %g, "
                         "%g) at texel (%.3f, %.3f)",
                         qx, py, p[0], p[1], p[2], red, tx / 8, ty / 8, tx, ty);
            checked++;
        }
    assert_true(checked > 1000);
    print_message("checker: %d pixels predicted, worst difference %.2g\n",
                  checked, worst);
    lr_image_free(img);
}

/* ---- a light sample sees the texel a ray sees -------------------------- */

/* An emission texture varying in u and v on a quad and on a sphere: for
 * light samples spread over each, the radiance the sample carries equals
 * the emission a ray along the sampled direction finds at its hit. */
static void sampled_emission_matches_hit(void **state)
{
    (void)state;
    write_exr("emit.exr", 8, 8, checker);
    static const char *const objs[] = {
        "{\"type\": \"plane\", \"point\": [0.3, 2, -0.2], \"normal\":"
        " [0.1, -1, 0.2], \"size\": [2, 1.5], \"material\": \"e\"}",
        "{\"type\": \"sphere\", \"center\": [0.5, 3, -1], \"radius\": 0.8,"
        " \"material\": \"e\"}"};
    for (int k = 0; k < 2; k++) {
        char json[1024];
        snprintf(json, sizeof json,
                 "{\"materials\": {\"e\": {\"emission_texture\": "
                 "\"emit.exr\", \"emission\": [1, 2, 3]}},"
                 " \"objects\": [%s]}",
                 objs[k]);
        lr_scene *s = lr_test_load_json(json);
        int n = 0, varied = 0;
        double first = -1;
        for (int i = 0; i < 32; i++)
            for (int j = 0; j < 32; j++) {
                double u[2] = {(i + 0.37) / 32, (j + 0.61) / 32};
                lr__light_sample ls;
                if (!lr__light_sample_from(s, v3(0, 0, 0), 0.5, u, &ls))
                    continue;
                lr__hit h;
                assert_true(lr__trace(s, v3(0, 0, 0), ls.dir, INFINITY, &h));
                lr__material tmp;
                lr__v3 e = lr__hit_material(s, &h, &tmp)->emission;
                if (fabs(e.x - ls.L.x) > 1e-4 || fabs(e.y - ls.L.y) > 1e-4 ||
                    fabs(e.z - ls.L.z) > 1e-4)
                    fail_msg("%s: sample (%g, %g): light sample %g %g %g, "
                             "hit %g %g %g",
                             k ? "sphere" : "quad", u[0], u[1], ls.L.x, ls.L.y,
                             ls.L.z, e.x, e.y, e.z);
                if (first < 0)
                    first = e.x;
                varied |= fabs(e.x - first) > 0.1;
                n++;
            }
        assert_true(n > 200 && varied);
        lr_scene_free(s);
    }
}

/* ---- the daemon confines texture paths -------------------------------- */

static void job_lists_textures(void **state)
{
    (void)state;
    const char *body =
        "{\"scene\": {\"materials\": {\"a\": {\"diffuse_texture\": "
        "\"../x.png\"}, \"b\": {\"emission_texture\": \"/etc/passwd\","
        " \"roughness_texture\": \"r.png\"}},"
        " \"objects\": [{\"type\": \"mesh\", \"file\": \"m.obj\"}]}}";
    lr_job *job = NULL;
    lr_error err;
    assert_int_equal(lr_job_parse(body, strlen(body), 64, &job, &err), LR_OK);
    const char *file, *field;
    static const char *const want[][2] = {
        /* In document order (lr_job_mesh_file). */
        {"../x.png", "scene.materials.a.diffuse_texture"},
        {"/etc/passwd", "scene.materials.b.emission_texture"},
        {"r.png", "scene.materials.b.roughness_texture"},
        {"m.obj", "scene.objects[0].file"}};
    size_t k = 0;
    for (; lr_job_mesh_file(job, k, &file, &field); k++) {
        assert_true(k < 4);
        assert_string_equal(file, want[k][0]);
        assert_string_equal(field, want[k][1]);
    }
    assert_int_equal(k, 4);
    lr_job_free(job);
}

/* A 2 x 2 image: its top row (y 0) red, green; its bottom blue, white. */
static void corners(int x, int y, float rgb[3])
{
    static const float c[2][2][3] = {{{1, 0, 0}, {0, 1, 0}},
                                     {{0, 0, 1}, {1, 1, 1}}};
    memcpy(rgb, c[y][x], sizeof c[y][x]);
}

/* A finite plane's texture stands upright seen from the front, on walls
 * facing each way (facing +x and -z it stood on its head, turned half
 * round): a 2 x 2 image on a 2 x 2 wall through a 2 x 2 orthographic
 * view from in front of it, up +y, each pixel one texel (grid sampler:
 * pixel centres, texel centres). */
static void walls_upright(void **state)
{
    (void)state;
    write_exr("corners.exr", 2, 2, corners);
    static const int n[4][3] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}};
    for (int k = 0; k < 4; k++) {
        char json[1024];
        snprintf(json, sizeof json,
                 "{\"camera\": {\"model\": \"orthographic\", \"position\": "
                 "[%d, %d, %d], \"look_at\": [0, 0, 0], \"view_height\": 2},"
                 " \"render\": {\"width\": 2, \"height\": 2, \"spp\": 1,"
                 "  \"sampler\": \"grid\", \"adaptive\": false},"
                 " \"materials\": {\"t\": {\"diffuse_texture\": "
                 "\"corners.exr\"}},"
                 " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
                 " \"objects\": [{\"type\": \"plane\", \"normal\": [%d, %d, "
                 "%d], \"size\": 2, \"material\": \"t\"}]}",
                 5 * n[k][0], 5 * n[k][1], 5 * n[k][2], n[k][0], n[k][1],
                 n[k][2]);
        lr_image *img = lr_test_render_json(json, "wall");
        const float *p = lr_image_rgb(img);
        for (int i = 0; i < 4; i++) {
            float want[3];
            corners(i % 2, i / 2, want);
            for (int c = 0; c < 3; c++)
                if (fabsf(p[3 * i + c] - want[c]) > 1e-5f)
                    fail_msg("wall facing (%d, %d, %d): pixel %d channel %d "
                             "is %g, want %g",
                             n[k][0], n[k][1], n[k][2], i, c, p[3 * i + c],
                             want[c]);
        }
        lr_image_free(img);
    }
}

static const struct CMUnitTest tests[] = {
    cmocka_unit_test(obj_vt),
    cmocka_unit_test(material_errors),
    cmocka_unit_test_setup(constant_texture_identity, setup_one),
    cmocka_unit_test(vector_lanes_textured),
    cmocka_unit_test(checker_projection),
    cmocka_unit_test(walls_upright),
    cmocka_unit_test(sampled_emission_matches_hit),
    cmocka_unit_test(job_lists_textures),
};

LR_TEST_GROUP(texture_scene, tests)
