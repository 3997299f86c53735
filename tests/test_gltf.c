/*
 * test_gltf.c: glTF 2.0 scenes (lib/gltf*.c, docs/gltf.md) against truth
 * computed here: a mesh under node transforms renders as the same
 * triangle moved by this file's own matrices and written as OBJ (bit for
 * bit); the glTF camera's rays (yfov, aspect ratio, node rotation) hit
 * the floor where this file's projection says; a point light's
 * irradiance is I cos(theta) / d^2; metallic 1 is our mirror and base
 * colour our albedo; normals move by the inverse transpose; hostile files
 * get errors that name the field.  The files come from
 * tests/gltf_writer.py (python3, a build dependency).
 */
#include "test.h"
#include "integrator/integrator.h"
#include "scene/scene.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define PI 3.14159265358979323846

/* Writes scene NAME of tests/gltf_writer.py to FILE in the scratch
 * directory. */
static void make(const char *name, const char *file)
{
    const char *src = getenv("LENSRAY_SOURCE_DIR");
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "python3 %s/tests/gltf_writer.py %s %s/%s",
             src && *src ? src : ".", name, lr_test_tmpdir(), file);
    assert_int_equal(system(cmd), 0);
}

/* Renders with the scene's own camera and settings (finite, checked). */
static lr_image *render(lr_scene *s)
{
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    return lr_test_render_with(s, &cam, &rs, "glTF scene");
}

/* The JSON of glTF file FILE in the test directory, parsed. */
static cJSON *read_json(const char *file)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", lr_test_tmpdir(), file);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    static char text[1 << 16];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = '\0';
    cJSON *root = cJSON_Parse(text);
    assert_non_null(root);
    return root;
}

/* Writes root as FILE in the test directory and frees it. */
static void write_json(const char *file, cJSON *root)
{
    char path[512];
    char *out = cJSON_Print(root);
    lr_test_write_text(file, out, path, sizeof path);
    free(out);
    cJSON_Delete(root);
}

/* Loading glTF file FILE as a scene's object fails with `status`, and
 * the message names the field and the file and holds `text`. */
static void expect_file_error(const char *file, lr_status status,
                              const char *text)
{
    char json[256];
    snprintf(json, sizeof json,
             "{\"objects\": [{\"type\": \"gltf\", \"file\": \"%s\"}]}", file);
    lr_scene *s = NULL;
    lr_error err;
    lr_status st = lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                      NULL, 0, &s, &err);
    assert_null(s);
    if (st != status || strstr(err.message, text) == NULL ||
        strstr(err.message, "objects[0].file") == NULL ||
        strstr(err.message, file) == NULL)
        fail_msg("%s: status %d, message \"%s\", want \"%s\"", file, st,
                 err.message, text);
}

/* ---- transforms ----------------------------------------------------------- */

/* tri: the triangle (0,0,0), (1,0,0), (0,1,0) in a child node (T, R =
 * 45 degrees about z, S = (1.5, 0.75, 1)) of a node whose matrix rotates
 * about y (cos 0.8, sin -0.6) and translates by (0.5, 0.25, -1). */
static void tri_world(const double v[3], double out[3])
{
    double c = cos(PI / 4), s = sin(PI / 4);
    double p[3] = {1.5 * v[0], 0.75 * v[1], v[2]};
    double q[3] = {c * p[0] - s * p[1] + 0.25, s * p[0] + c * p[1] - 0.5,
                   p[2] + 0.125};
    /* The matrix's columns are where the axes go: x -> (0.8, 0, 0.6),
     * z -> (-0.6, 0, 0.8). */
    out[0] = 0.8 * q[0] - 0.6 * q[2] + 0.5;
    out[1] = q[1] + 0.25;
    out[2] = 0.6 * q[0] + 0.8 * q[2] - 1;
}

static void test_transform_matches_obj(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    char obj[512] = "";
    static const double tri[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    for (int i = 0; i < 3; i++) {
        double w[3];
        tri_world(tri[i], w);
        size_t n = strlen(obj);
        snprintf(obj + n, sizeof obj - n, "v %.9g %.9g %.9g\n", (float)w[0],
                 (float)w[1], (float)w[2]);
    }
    strcat(obj, "f 1 2 3\n");
    char path[512];
    lr_test_write_text("tri.obj", obj, path, sizeof path);
    static const char *const integrators[] = {"whitted", "path"};
    for (int k = 0; k < 2; k++) {
        char json[1024];
        const char *fmt =
            "{\"camera\": {\"position\": [0.6, 0.3, 3], \"look_at\": [0.6, "
            "0.3, -1], \"fov\": 50},"
            " \"render\": {\"width\": 48, \"height\": 32, \"spp\": 4, "
            "\"integrator\": \"%s\"}, \"background\": [0.2, 0.3, 0.4],"
            " \"lights\": [{\"type\": \"point\", \"position\": [1, 2, 3], "
            "\"intensity\": 10}],"
            " \"materials\": {\"m\": {\"diffuse\": [0.8, 0.4, 0.2], "
            "\"roughness\": 1}},"
            " \"objects\": [%s]}";
        snprintf(json, sizeof json, fmt, integrators[k],
                 "{\"type\": \"gltf\", \"file\": \"tri.gltf\"}");
        lr_scene *a = lr_test_load_json(json);
        snprintf(json, sizeof json, fmt, integrators[k],
                 "{\"type\": \"mesh\", \"file\": \"tri.obj\", \"material\": "
                 "\"m\"}");
        lr_scene *b = lr_test_load_json(json);
        for (int i = 0; i < 9; i++)
            if (a->geoms[0].vertices[i] != b->geoms[0].vertices[i])
                fail_msg("vertex value %d: glTF %.9g, OBJ %.9g", i,
                         (double)a->geoms[0].vertices[i],
                         (double)b->geoms[0].vertices[i]);
        lr_image *ia = render(a), *ib = render(b);
        const float *pa = lr_image_rgb(ia);
        /* The triangle is in the picture, not only the background. */
        int lit = 0;
        for (int i = 0; i < 48 * 32; i++)
            lit += pa[3 * i] != 0.2f;
        assert_true(lit > 50);
        lr_test_assert_same_bytes(ia, ib, "glTF against OBJ");
        lr_image_free(ia);
        lr_image_free(ib);
        lr_scene_free(a);
        lr_scene_free(b);
    }
}

static void test_normals_inverse_transpose(void **state)
{
    (void)state;
    make("normals", "normals.glb");
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"normals.glb\"}]}");
    assert_int_equal(s->n_geoms, 1);
    const float *n = s->geoms[0].corner_normals;
    assert_non_null(n);
    /* Scale (2, 1, 1): the inverse transpose scales x by 1/2. */
    double want[3] = {0.3, 0, 0.8}, len = sqrt(0.09 + 0.64);
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < 3; k++)
            assert_true(fabs(n[3 * c + k] - want[k] / len) < 1e-6);
    lr_scene_free(s);
}

/* ---- camera and light ------------------------------------------------------ */

/* camera-light: the camera at (0, 3, 4) pitched down by atan(3/4), yfov
 * 0.7, aspect 1.5; a floor y = 0 of albedo 0.5; 20 cd at (0, 2, 0). */
static lr_scene *camera_light_scene(void)
{
    make("camera-light", "camera-light.glb");
    return lr_test_load_json(
        "{\"render\": {\"width\": 60, \"spp\": 1, \"sampler\": \"grid\","
        " \"depth\": true}, \"objects\": [{\"type\": \"gltf\", "
        "\"file\": \"camera-light.glb\", \"camera\": true}]}");
}

/* The unit direction through the centre of pixel (x, y) of a w x h image,
 * from the projection: the view basis of the camera's node. */
static void pixel_dir(int x, int y, int w, int h, double d[3], double fwd[3])
{
    double a = atan2(3, 4); /* pitch down */
    double t = tan(0.35), asp = (double)w / h;
    double sx = (2 * (x + 0.5) / w - 1) * t * asp;
    double sy = (1 - 2 * (y + 0.5) / h) * t;
    /* Camera axes: right (1,0,0), up (0, cos a, -sin a), back (0, sin a,
     * cos a); the ray is right sx + up sy - back. */
    double v[3] = {sx, sy * cos(a) - sin(a), -sy * sin(a) - cos(a)};
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; k++)
        d[k] = v[k] / len;
    fwd[0] = 0, fwd[1] = -sin(a), fwd[2] = -cos(a);
}

/* lr_scene_read_settings takes a glTF camera from the file, as the whole
 * load does: the scene JSON placing the file with "camera": true (the
 * height from its aspect) and the .glb file alone. */
static void test_read_settings_gltf_camera(void **state)
{
    (void)state;
    make("camera-light", "camera-light.glb");
    /* The scene in a directory of its own: a .json in the shared
     * temporary directory would be listed as a lens by test_prescription's
     * LENSRAY_LENS_DIR check. */
    char dir[512], json[600], glb[512];
    snprintf(dir, sizeof dir, "%s/read-settings", lr_test_tmpdir());
    mkdir(dir, 0700);
    snprintf(json, sizeof json, "%s/camera-light.json", dir);
    snprintf(glb, sizeof glb, "%s/camera-light.glb", lr_test_tmpdir());
    FILE *f = fopen(json, "w");
    assert_non_null(f);
    fputs("{\"render\": {\"width\": 60}, \"objects\": [{\"type\": "
          "\"gltf\", \"file\": \"../camera-light.glb\", \"camera\": true}]}",
          f);
    fclose(f);
    const char *paths[] = {json, glb};
    for (int k = 0; k < 2; k++) {
        lr_scene *s = NULL;
        lr_error err;
        assert_int_equal(lr_scene_load_file(paths[k], NULL, 0, &s, &err),
                         LR_OK);
        lr_camera cam_full, cam;
        lr_render_settings rs_full, rs;
        lr_scene_camera(s, &cam_full);
        lr_scene_settings(s, &rs_full);
        lr_scene_free(s);
        assert_int_equal(
            lr_scene_read_settings(paths[k], NULL, 0, &cam, &rs, &err), LR_OK);
        assert_memory_equal(&cam, &cam_full, sizeof cam);
        assert_memory_equal(&rs, &rs_full, sizeof rs);
        if (k == 0)
            assert_int_equal(rs.height, 40); /* 60 / aspect 1.5 */
    }
}

/* Overrides of camera keys win over a glTF camera ("camera": true), as
 * --set does on any scene: the file's camera replaced them after they
 * were read, so --set camera.fov=20 and a thin lens set on the command
 * line were ignored, silently (an independent check).  Keys the
 * override leaves alone keep the file's values. */
static void test_overrides_win_over_gltf_camera(void **state)
{
    (void)state;
    make("camera-light", "camera-light.glb");
    const char *scene = "{\"render\": {\"width\": 60}, \"objects\": "
                        "[{\"type\": \"gltf\", \"file\": "
                        "\"camera-light.glb\", \"camera\": true}]}";
    const char *sets[] = {"camera.fov=20", "camera.model=thinlens",
                          "camera.aperture_radius=0.2",
                          "camera.focus_distance=1"};
    lr_scene *s = lr_test_load(scene, sets, 4);
    lr_camera cam;
    lr_scene_camera(s, &cam);
    assert_true(cam.fov == 20.0);
    assert_int_equal(cam.model, LR_CAMERA_THINLENS);
    assert_true(cam.aperture_radius == 0.2 && cam.focus_distance == 1.0);
    /* The view is still the file's: the camera at (0, 3, 4). */
    assert_true(fabs(cam.position[1] - 3.0) < 1e-9 &&
                fabs(cam.position[2] - 4.0) < 1e-9);
    lr_scene_free(s);
    /* Without overrides, the file's field of view (yfov 0.7 rad). */
    s = lr_test_load(scene, NULL, 0);
    lr_scene_camera(s, &cam);
    assert_true(fabs(cam.fov - 0.7 * 180 / PI) < 1e-9);
    lr_scene_free(s);
}

/* A camera aspect ratio that makes the image taller than 65536 rows is
 * an error naming the field; it was clamped to 65536 rows silently (an
 * independent check: aspectRatio 1e-6 made 160 x 65536 pixels).  With
 * render.height given the ratio is not used. */
static void test_camera_aspect_too_tall(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    cJSON *root = read_json("tri.gltf");
    cJSON *cams = cJSON_AddArrayToObject(root, "cameras");
    cJSON *cam = cJSON_CreateObject();
    cJSON_AddStringToObject(cam, "type", "perspective");
    cJSON *persp = cJSON_AddObjectToObject(cam, "perspective");
    cJSON_AddNumberToObject(persp, "yfov", 0.6);
    cJSON_AddNumberToObject(persp, "aspectRatio", 1e-6);
    cJSON_AddNumberToObject(persp, "znear", 0.1);
    cJSON_AddItemToArray(cams, cam);
    cJSON *node = cJSON_CreateObject();
    cJSON_AddNumberToObject(node, "camera", 0);
    cJSON_AddItemToArray(cJSON_GetObjectItemCaseSensitive(root, "nodes"), node);
    cJSON_AddItemToArray(
        cJSON_GetObjectItemCaseSensitive(
            cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(root, "scenes"),
                               0),
            "nodes"),
        cJSON_CreateNumber(2));
    write_json("tall.gltf", root);
    const char *json =
        "{\"render\": {\"width\": 160}, \"objects\": [{\"type\": "
        "\"gltf\", \"file\": \"tall.gltf\", \"camera\": true}]}";
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                        NULL, 0, &s, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "cameras[0].perspective.aspectRatio "
                                        "1e-06 makes the image 160 x "
                                        "160000000 pixels"));
    const char *h[] = {"render.height=90"};
    s = lr_test_load(json, h, 1);
    lr_render_settings rs;
    lr_scene_settings(s, &rs);
    assert_int_equal(rs.height, 90);
    lr_scene_free(s);
}

static void test_camera_projection(void **state)
{
    (void)state;
    lr_scene *s = camera_light_scene();
    lr_render_settings rs;
    lr_scene_settings(s, &rs);
    assert_int_equal(rs.width, 60);
    assert_int_equal(rs.height, 40); /* 60 / aspectRatio 1.5 */
    lr_image *img = render(s);
    const float *z = lr_image_depth(img);
    static const int px[][2] = {{0, 39}, {59, 39}, {30, 20}, {5, 12}, {44, 30}};
    for (int i = 0; i < 5; i++) {
        double d[3], f[3];
        pixel_dir(px[i][0], px[i][1], 60, 40, d, f);
        double t = 3 / -d[1]; /* to the floor y = 0 from y = 3 */
        double want = t * (d[0] * f[0] + d[1] * f[1] + d[2] * f[2]);
        double got = z[px[i][1] * 60 + px[i][0]];
        if (!(fabs(got - want) < 1e-4 * want))
            fail_msg("pixel (%d, %d): depth %.7g, projection says %.7g",
                     px[i][0], px[i][1], got, want);
    }
    lr_image_free(img);
    lr_scene_free(s);
}

static void test_point_light_irradiance(void **state)
{
    (void)state;
    lr_scene *s = camera_light_scene();
    lr_image *img = render(s);
    const float *rgb = lr_image_rgb(img);
    static const int px[][2] = {{30, 20}, {10, 35}, {50, 25}, {30, 5}};
    for (int i = 0; i < 4; i++) {
        double d[3], f[3];
        pixel_dir(px[i][0], px[i][1], 60, 40, d, f);
        double t = 3 / -d[1];
        double p[3] = {t * d[0], 0, 4 + t * d[2]};
        double r2 = p[0] * p[0] + 4 + p[2] * p[2];
        /* Lambertian radiance: albedo / pi x I cos(theta) / d^2, with
         * cos(theta) = 2 / d for the light 2 above the floor. */
        double want = 0.5 / PI * 20 * (2 / sqrt(r2)) / r2;
        double got = rgb[3 * (px[i][1] * 60 + px[i][0]) + 1];
        if (!(fabs(got - want) < 1e-4 * want))
            fail_msg("pixel (%d, %d): %.7g, I cos / d^2 says %.7g", px[i][0],
                     px[i][1], got, want);
    }
    lr_image_free(img);
    lr_scene_free(s);
}

/* A spot light: every floor pixel of the camera-light view against
 * albedo / pi x I cos / d^2 x the cone's falloff computed here from the
 * angle off the axis (KHR_lights_punctual: ((cos t - cos outer) / (cos
 * inner - cos outer)) clamped to [0, 1], squared), under Whitted's
 * vector and scalar paths and the path tracer.  The same light from a
 * glTF file (radians, the node's -z) and from scene JSON (degrees). */
static void check_spot(lr_scene *s, double inner, double outer,
                       const char *what)
{
    int seen[3] = {0, 0, 0}; /* inside the inner cone, between, outside */
    for (int pass = 0; pass < 3; pass++) {
        lr__whitted_scalar_only = pass == 1;
        lr_camera cam;
        lr_render_settings rs;
        lr_scene_camera(s, &cam);
        lr_scene_settings(s, &rs);
        if (pass == 2)
            rs.integrator = LR_INTEGRATOR_PATH;
        lr_image *img = lr_test_render_with(s, &cam, &rs, what);
        lr__whitted_scalar_only = 0;
        const float *rgb = lr_image_rgb(img);
        for (int y = 0; y < 40; y++)
            for (int x = 0; x < 60; x++) {
                double d[3], f[3];
                pixel_dir(x, y, 60, 40, d, f);
                double t = 3 / -d[1];
                double p[3] = {t * d[0], 0, 4 + t * d[2]};
                if (!(d[1] < 0) || fabs(p[0]) > 3.9 || fabs(p[2]) > 3.9)
                    continue;
                double r2 = p[0] * p[0] + 4 + p[2] * p[2];
                double c = 2 / sqrt(r2); /* cos off the axis = cos theta */
                double a = (c - cos(outer)) / (cos(inner) - cos(outer));
                a = a < 0 ? 0 : a > 1 ? 1 : a;
                seen[a >= 1 ? 0 : a > 0 ? 1 : 2]++;
                double want = 0.5 / PI * 20 * a * a * c / r2;
                double got = rgb[3 * (y * 60 + x) + 1];
                if (!(fabs(got - want) <= 1e-4 * want + 1e-7))
                    fail_msg("%s, pass %d, pixel (%d, %d): %.7g, the cone "
                             "says %.7g",
                             what, pass, x, y, got, want);
            }
        lr_image_free(img);
    }
    for (int k = 0; k < 3; k++)
        assert_true(seen[k] > 0);
}

static void test_spot_light(void **state)
{
    (void)state;
    make("spot-light", "spot-light.glb");
    lr_scene *s = lr_test_load_json(
        "{\"render\": {\"width\": 60, \"spp\": 1, \"sampler\": \"grid\"},"
        " \"objects\": [{\"type\": \"gltf\", \"file\": \"spot-light.glb\","
        " \"camera\": true}]}");
    assert_null(strstr(lr_scene_warnings(s), "spot"));
    check_spot(s, 0.3, 0.6, "glTF spot");
    lr_scene_free(s);
    /* The floor and camera of camera-light.glb without its point light,
     * under a JSON spot: degrees, a direction that need not be unit. */
    make("camera-floor", "camera-floor.glb");
    s = lr_test_load_json(
        "{\"render\": {\"width\": 60, \"spp\": 1, \"sampler\": \"grid\"},"
        " \"lights\": [{\"type\": \"spot\", \"position\": [0, 2, 0],"
        " \"direction\": [0, -3, 0], \"intensity\": 20,"
        " \"inner_angle\": 10, \"outer_angle\": 50}],"
        " \"objects\": [{\"type\": \"gltf\", \"file\": \"camera-floor.glb\","
        " \"camera\": true}]}");
    check_spot(s, 10 * PI / 180, 50 * PI / 180, "JSON spot");
    lr_scene_free(s);
    static const struct {
        const char *light, *path;
    } bad[] = {
        {"\"inner_angle\": 50, \"outer_angle\": 50", "lights[0].inner_angle"},
        {"\"inner_angle\": -1", "lights[0].inner_angle"},
        {"\"outer_angle\": 0", "lights[0].outer_angle"},
        {"\"outer_angle\": 91", "lights[0].outer_angle"},
        {"\"direction\": [0, 0, 0]", "lights[0].direction"},
        {"\"irradiance\": 1", "lights[0].irradiance"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char json[512];
        snprintf(json, sizeof json,
                 "{\"lights\": [{\"type\": \"spot\", \"position\": [0, 2, 0],"
                 " \"intensity\": 1, %s%s}]}",
                 bad[i].light,
                 strstr(bad[i].light, "direction")
                     ? ""
                     : ", \"direction\": [0, -1, 0]");
        lr_test_expect_invalid(json, strlen(json), bad[i].path, NULL);
    }
}

/* ---- materials ------------------------------------------------------------- */

static void test_materials(void **state)
{
    (void)state;
    make("materials", "materials.gltf");
    /* Panels at x = -1.5 (metallic 1, roughness 0, base 0.9) and 1.5
     * (metallic 0, base (0.2, 0.6, 0.4)), facing +z; the light falls
     * straight on them, the camera looks straight at them. */
    lr_scene *s = lr_test_load_json(
        "{\"camera\": {\"position\": [0, 0, 10], \"look_at\": [0, 0, 0], "
        "\"fov\": 30}, \"render\": {\"width\": 40, \"height\": 20, \"spp\": 1,"
        " \"sampler\": \"grid\"}, \"background\": [0.2, 0.3, 0.4],"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [0, 0, -1],"
        " \"irradiance\": 2}],"
        " \"objects\": [{\"type\": \"gltf\", \"file\": \"materials.gltf\"}]}");
    lr_image *img = render(s);
    const float *rgb = lr_image_rgb(img);
    /* Pixel centres over each panel (10 units away, 30 degrees: the
     * panels span about 7 pixels each side of x = 20 +- 8). */
    const float *mirror = &rgb[3 * (10 * 40 + 12)];
    const float *matte = &rgb[3 * (10 * 40 + 27)];
    static const double bg[3] = {0.2, 0.3, 0.4}, alb[3] = {0.2, 0.6, 0.4};
    for (int k = 0; k < 3; k++) {
        /* A perfect mirror of reflectance 0.9 shows 0.9 x the sky. */
        assert_true(fabs(mirror[k] - 0.9 * bg[k]) < 1e-6);
        /* Lambert: albedo / pi x irradiance. */
        assert_true(fabs(matte[k] - alb[k] / PI * 2) < 1e-6);
    }
    lr_image_free(img);
    lr_scene_free(s);
}

/* The mapping table of docs/gltf.md, value by value. */
static void test_material_mapping(void **state)
{
    (void)state;
    make("mapping", "mapping.gltf");
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"mapping.gltf\"}]}");
    assert_int_equal(s->n_geoms, 2);
    const lr__material *m = &s->materials[s->geoms[0].material];
    const lr__material *def = &s->materials[s->geoms[1].material];
    static const double b[3] = {0.9, 0.8, 0.7}, e[3] = {0.5, 0.25, 1};
    double mc[3] = {m->reflect.x, m->reflect.y, m->reflect.z};
    double dc[3] = {m->diffuse.x, m->diffuse.y, m->diffuse.z};
    double tc[3] = {m->transmit.x, m->transmit.y, m->transmit.z};
    double ec[3] = {m->emission.x, m->emission.y, m->emission.z};
    for (int k = 0; k < 3; k++) {
        assert_true(fabs(mc[k] - 0.25 * b[k]) < 1e-12);       /* m b */
        assert_true(fabs(dc[k] - 0.75 * 0.5 * b[k]) < 1e-12); /* (1-m)(1-t) b */
        assert_true(fabs(tc[k] - 0.75 * 0.5 * b[k]) < 1e-12); /* (1-m) t b */
        assert_true(fabs(ec[k] - 4 * e[k]) < 1e-12);          /* x strength */
    }
    assert_true(fabs(m->roughness - 0.36) < 1e-12); /* r^2 */
    assert_true(fabs(m->ior - 1.33) < 1e-12);
    assert_true(m->specular.x == 0 && m->shininess == 0);
    /* The spec's default material: base 1, metallic 1, roughness 1. */
    assert_true(def->reflect.x == 1 && def->reflect.y == 1 &&
                def->diffuse.x == 0 && def->roughness == 1);
    lr_scene_free(s);
}

/* The quads of scene "textured" (gltf_writer.py) in FILE: each texel
 * where its UVs put it. */
static void check_textured(const char *file)
{
    /* 81 x 41 pixels, 10 to a unit at the quads (10 units away): pixel
     * (i, j) looks at x = (i - 40) / 10, y = (20 - j) / 10, so that pixel
     * centres fall on the texel centres, half a unit in from each corner:
     * x = -2, -1 (base colour quad), 1, 2 (emissive), y = +-0.5. */
    char json[1024];
    snprintf(json, sizeof json,
             "{\"camera\": {\"position\": [0, 0, 10], \"look_at\": [0, 0, 0],"
             " \"fov\": %.17g}, \"render\": {\"width\": 81, \"height\": 41,"
             " \"spp\": 1, \"sampler\": \"grid\"},"
             " \"lights\": [{\"type\": \"directional\", \"direction\": [0, 0,"
             " -1], \"irradiance\": %.17g}],"
             " \"objects\": [{\"type\": \"gltf\", \"file\": \"%s\"}]}",
             2 * atan(0.205) * 180 / PI, PI, file);
    lr_scene *s = lr_test_load_json(json);
    lr_image *img = render(s);
    const float *rgb = lr_image_rgb(img);
    /* Red top left, green top right, blue bottom left, white bottom
     * right: glTF's UV (0, 0) is the image's top left. */
    static const double want[4][3] = {
        {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    static const int at[2][4][2] = {{{20, 15}, {30, 15}, {20, 25}, {30, 25}},
                                    {{50, 15}, {60, 15}, {50, 25}, {60, 25}}};
    for (int quad = 0; quad < 2; quad++)
        for (int k = 0; k < 4; k++) {
            int x = at[quad][k][0], y = at[quad][k][1];
            const float *px = &rgb[3 * (y * 81 + x)];
            /* Base colour: albedo / pi x pi; emission: the texel. */
            for (int c = 0; c < 3; c++)
                if (!(fabs(px[c] - want[k][c]) < 1e-3))
                    fail_msg("%s: %s quad, pixel (%d, %d): (%g, %g, %g), "
                             "want texel %d",
                             file, quad ? "emissive" : "base", x, y,
                             (double)px[0], (double)px[1], (double)px[2], k);
        }
    lr_image_free(img);
    lr_scene_free(s);
}

/* Texture coordinates as floats, or as normalized unsigned bytes or
 * shorts (glTF 2.0, 3.7.2.1), which assimp 5.2 read as raw bytes; ones
 * not normalized are not glTF, and an error names them. */
static void test_textures(void **state)
{
    (void)state;
    make("textured", "textured.glb");
    check_textured("textured.glb");
    make("textured-u8", "textured-u8.glb");
    check_textured("textured-u8.glb");
    make("textured-u16", "textured-u16.gltf");
    check_textured("textured-u16.gltf");
    /* What the sampler asks for and lensray does not do is a warning:
     * clamping, mirroring, a nearest-texel magnification. */
    make("textured", "sampled.gltf");
    cJSON *root = read_json("sampled.gltf");
    cJSON_ReplaceItemInObject(root, "samplers",
                              cJSON_Parse("[{\"wrapS\": 33071, \"wrapT\": "
                                          "33648, \"magFilter\": 9728}]"));
    write_json("sampled.gltf", root);
    lr_scene *sc = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"sampled.gltf\"}]}");
    const char *w = lr_scene_warnings(sc);
    if (!strstr(w, "baseColorTexture: the sampler's wrapS is ignored") ||
        !strstr(w, "baseColorTexture: the sampler's wrapT is ignored") ||
        !strstr(w, "baseColorTexture: the sampler's magFilter NEAREST is "
                   "ignored"))
        fail_msg("sampler warnings: \"%s\"", w);
    lr_scene_free(sc);
    make("textured-u8-raw", "textured-raw.glb");
    expect_file_error("textured-raw.glb", LR_ERR_INVALID,
                      "textured-raw.glb: meshes[0].primitives[0].attributes."
                      "TEXCOORD_0: accessors[2] must be a VEC2 of floats, or "
                      "of unsigned bytes or shorts with \"normalized\": true");
}

/* The metallic texture's B scales metallicFactor and splits the textured
 * base colour b point by point (glTF 2.0, appendix B): reflect = m b,
 * diffuse = (1 - m) b.  Checked at the four texel centres (texel (x, y)
 * from the image's top left is at u = (x + 0.5) / 2, v = 1 - (y + 0.5) /
 * 2 in lensray's lookup), with metallicFactor 0.5: m = 0.5 B / 255. */
static void test_metal_texture(void **state)
{
    (void)state;
    make("metal-texture", "metal.glb");
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"metal.glb\"}]}");
    const lr__material *m = &s->materials[s->geoms[0].material];
    /* A hit on it computes its texture coordinates (trace.c). */
    assert_true(lr__material_textured(m));
    static const double base[2][2][3] = {{{1, 0, 0}, {1, 1, 1}},
                                         {{1, 1, 1}, {0, 1, 0}}};
    static const double metal[2][2] = {{1, 0}, {0.4, 1}}; /* B / 255 */
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 2; x++) {
            double uv[2] = {(x + 0.5) / 2, 1 - (y + 0.5) / 2};
            lr__material tmp;
            const lr__material *at = lr__material_textures(m, uv, &tmp);
            double mm = 0.5 * metal[y][x];
            const double *b = base[y][x];
            double got[2][3] = {{at->reflect.x, at->reflect.y, at->reflect.z},
                                {at->diffuse.x, at->diffuse.y, at->diffuse.z}};
            for (int c = 0; c < 3; c++) {
                if (!(fabs(got[0][c] - mm * b[c]) < 1e-6 &&
                      fabs(got[1][c] - (1 - mm) * b[c]) < 1e-6))
                    fail_msg("texel (%d, %d) channel %d: reflect %g diffuse "
                             "%g, want %g and %g",
                             x, y, c, got[0][c], got[1][c], mm * b[c],
                             (1 - mm) * b[c]);
            }
            assert_true(at->transmit.x == 0 && at->transmit.y == 0);
            assert_true(fabs(at->roughness - 1) < 1e-6);
        }
    lr_scene_free(s);
    /* Rendered: Whitted's mirror sends each pixel to the white
     * background behind the camera, and nothing lights the diffuse part,
     * so a texel centre's pixel is m b; again without the metallic
     * texture (m = 0.5 everywhere), where only the base colour is
     * textured.  41 x 41 pixels, 10 to a unit at the quad: texel (x, y)
     * at pixel (15 + 10 x, 15 + 10 y). */
    make("metal-base-texture", "metal-base.glb");
    for (int k = 0; k < 2; k++) {
        char json[512];
        snprintf(
            json, sizeof json,
            "{\"camera\": {\"position\": [0, 0, 10], \"look_at\": [0, 0, 0],"
            " \"fov\": %.17g}, \"render\": {\"width\": 41, \"height\": 41,"
            " \"spp\": 1, \"sampler\": \"grid\"}, \"background\": 1,"
            " \"objects\": [{\"type\": \"gltf\", \"file\": \"%s\"}]}",
            2 * atan(0.205) * 180 / PI, k ? "metal-base.glb" : "metal.glb");
        s = lr_test_load_json(json);
        lr_image *img = render(s);
        const float *rgb = lr_image_rgb(img);
        for (int y = 0; y < 2; y++)
            for (int x = 0; x < 2; x++)
                for (int c = 0; c < 3; c++) {
                    double mm = 0.5 * (k ? 1 : metal[y][x]);
                    double want = mm * base[y][x][c];
                    double got =
                        rgb[3 * ((15 + 10 * y) * 41 + 15 + 10 * x) + c];
                    if (!(fabs(got - want) < 1e-4))
                        fail_msg("%s: rendered texel (%d, %d) channel %d: %g, "
                                 "want m b = %g",
                                 k ? "base only" : "metal", x, y, c, got, want);
                }
        lr_image_free(img);
        lr_scene_free(s);
    }
}

/* KHR_texture_transform: for each texel centre (x + 0.5, y + 0.5) / 2
 * (plus a whole repeat, to check wrapping), this test inverts the
 * extension's map (translation x rotation x scale: g' = R S g + o, R =
 * [[cos, sin], [-sin, cos]] as the Khronos sample viewer, three.js and
 * Cesium turn it; glTF issue #1563: the spec's GLSL listing, read column
 * by column, has the transpose, which lensray had followed and an
 * independent check caught) to find the glTF coordinates g that land
 * there, turns them into lensray's (v = 1 - glTF's), and expects that
 * texel's colour. */
static void test_texture_transform(void **state)
{
    (void)state;
    make("texture-transform", "tt.glb");
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"tt.glb\"}]}");
    assert_null(strstr(lr_scene_warnings(s), "KHR_texture_transform"));
    const lr__material *m = &s->materials[s->geoms[0].material];
    static const double cols[2][2][3] = {{{1, 0, 0}, {0, 1, 0}},
                                         {{0, 0, 1}, {1, 1, 1}}};
    const double ox = 0.25, oy = 0.1, r = 0.3, sx = 1.5, sy = -0.7;
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 2; x++) {
            double gx = (x + 0.5) / 2 + 1 - ox, gy = (y + 0.5) / 2 - 1 - oy;
            /* S^-1 R^-1 (g' - o); R^-1 is R of -r. */
            double px = (cos(r) * gx - sin(r) * gy) / sx;
            double py = (sin(r) * gx + cos(r) * gy) / sy;
            double uv[2] = {px, 1 - py};
            lr__material tmp;
            const lr__material *at = lr__material_textures(m, uv, &tmp);
            double got[3] = {at->diffuse.x, at->diffuse.y, at->diffuse.z};
            for (int c = 0; c < 3; c++)
                if (!(fabs(got[c] - cols[y][x][c]) < 1e-4))
                    fail_msg("texel (%d, %d): (%g, %g, %g)", x, y, got[0],
                             got[1], got[2]);
        }
    lr_scene_free(s);
}

/* The normal-map tests' light, unit, and their scene: glTF `file` (its
 * 2 x 2 quad facing +z) seen 41 x 41 from 10 away, one grid sample a
 * pixel, under a directional light of irradiance 2 along -bump_lt. */
static const double bump_lt[3] = {0.5, 0.4, 0.7681145747868608};

static lr_scene *bump_scene(const char *file)
{
    char json[640];
    snprintf(json, sizeof json,
             "{\"camera\": {\"position\": [0, 0, 10], \"look_at\": [0, 0, 0],"
             " \"fov\": %.17g}, \"render\": {\"width\": 41, \"height\": 41,"
             " \"spp\": 1, \"sampler\": \"grid\"},"
             " \"lights\": [{\"type\": \"directional\", \"direction\":"
             " [%.17g, %.17g, %.17g], \"irradiance\": 2}],"
             " \"objects\": [{\"type\": \"gltf\", \"file\": \"%s\"}]}",
             2 * atan(0.205) * 180 / PI, -bump_lt[0], -bump_lt[1], -bump_lt[2],
             file);
    return lr_test_load_json(json);
}

/* A normal map bends the shading normal as glTF 2.0 (3.9.3) defines it:
 * n = normalize(T x + B y + N z) with (x, y, z) = 2 texel - 1, x and y
 * times normalTexture.scale, T along increasing u (+x on this quad), B
 * up the image (+y), N the quad's normal (+z).  Each texel centre's
 * Lambertian radiance under a directional light, albedo / pi E n.l,
 * computed here from the texel bytes, under Whitted's scalar path and
 * the path tracer (the map keeps the mesh off the vector paths). */
static void test_normal_map(void **state)
{
    (void)state;
    make("normal-map", "bumpy.glb");
    lr_scene *s = bump_scene("bumpy.glb");
    assert_null(strstr(lr_scene_warnings(s), "normalTexture"));
    static const int bytes[2][2][3] = {{{204, 128, 230}, {128, 204, 230}},
                                       {{128, 128, 255}, {60, 70, 230}}};
    for (int pass = 0; pass < 2; pass++) {
        lr_camera cam;
        lr_render_settings rs;
        lr_scene_camera(s, &cam);
        lr_scene_settings(s, &rs);
        if (pass)
            rs.integrator = LR_INTEGRATOR_PATH;
        lr_image *img = lr_test_render_with(s, &cam, &rs, "normal map");
        const float *rgb = lr_image_rgb(img);
        for (int y = 0; y < 2; y++)
            for (int x = 0; x < 2; x++) {
                const int *b = bytes[y][x];
                double n[3] = {(2 * b[0] / 255.0 - 1) * 0.8,
                               (2 * b[1] / 255.0 - 1) * 0.8,
                               2 * b[2] / 255.0 - 1};
                double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                double cosl = (n[0] * bump_lt[0] + n[1] * bump_lt[1] +
                               n[2] * bump_lt[2]) /
                              len;
                double want = 0.5 / PI * 2 * cosl;
                double got = rgb[3 * ((15 + 10 * y) * 41 + 15 + 10 * x)];
                if (!(fabs(got - want) < 1e-4 * want))
                    fail_msg("%s, texel (%d, %d): %.7g, the bent normal says "
                             "%.7g (unbent %.7g)",
                             pass ? "path" : "whitted", x, y, got, want,
                             0.5 / PI * 2 * bump_lt[2]);
            }
        lr_image_free(img);
    }
    lr_scene_free(s);
}

/* A normal map under KHR_texture_transform bends along the frame of its
 * own coordinates (glTF 2.0, 3.9.3): mirrored in u (scale [-1, 1]) the
 * tilt towards +u leans to -x on the quad; turned half round (rotation
 * pi) both tilts turn over.  The frame had been the untransformed
 * coordinates', and the normal leaned the wrong way (an independent
 * check).  Radiance albedo / pi E n.l at the quad's centre. */
static void test_normal_map_transformed(void **state)
{
    (void)state;
    const char *scenes[2] = {"normal-map-mirrored", "normal-map-turned"};
    const double sign[2][2] = {{-1, 1}, {-1, -1}};
    for (int k = 0; k < 2; k++) {
        make(scenes[k], "moved-bump.glb");
        lr_scene *s = bump_scene("moved-bump.glb");
        lr_image *img = render(s);
        double n[3] = {sign[k][0] * (2 * 204 / 255.0 - 1) * 0.8,
                       sign[k][1] * (2 * 160 / 255.0 - 1) * 0.8,
                       2 * 230 / 255.0 - 1};
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double want = 0.5 / PI * 2 *
                      (n[0] * bump_lt[0] + n[1] * bump_lt[1] +
                       n[2] * bump_lt[2]) /
                      len;
        double got = lr_image_rgb(img)[3 * (20 * 41 + 20)];
        if (!(fabs(got - want) < 1e-4 * want))
            fail_msg("%s: %.7g, the bent normal says %.7g", scenes[k], got,
                     want);
        lr_image_free(img);
        lr_scene_free(s);
    }
}

/* ---- hostile files ---------------------------------------------------------- */

/* The member "array.index.member" `key` of root, split into its object
 * and its member's name (in k). */
static cJSON *member_of(cJSON *root, const char *key, char k[128],
                        const char **name)
{
    snprintf(k, 128, "%s", key);
    char *dot1 = strchr(k, '.'), *dot2 = dot1 ? strchr(dot1 + 1, '.') : NULL;
    assert_non_null(dot2);
    *dot1 = *dot2 = '\0';
    cJSON *o = cJSON_GetArrayItem(cJSON_GetObjectItem(root, k),
                                  (int)strtol(dot1 + 1, NULL, 10));
    assert_non_null(o);
    *name = dot2 + 1;
    return o;
}

/* Writes glTF file SRC of the test directory as NAME with member `drop`
 * removed (unless NULL) and member `key` set to the JSON `value` (both
 * "array.index.member"), and expects loading it to fail with `status`,
 * naming `what`. */
static void expect_bad_edit(const char *src, const char *name, const char *drop,
                            const char *key, const char *value,
                            lr_status status, const char *what)
{
    cJSON *root = read_json(src);
    char k[128];
    const char *m;
    if (drop != NULL) {
        cJSON *o = member_of(root, drop, k, &m);
        cJSON_DeleteItemFromObject(o, m);
    }
    cJSON *o = member_of(root, key, k, &m);
    cJSON_DeleteItemFromObject(o, m);
    cJSON_AddItemToObject(o, m, cJSON_Parse(value));
    write_json(name, root);
    expect_file_error(name, status, what);
}

/* Writes tri.gltf with member `key` ("array.index.member") set to the
 * JSON `value` as NAME and expects loading it to fail with
 * `status`, naming `what`. */
static void expect_bad(const char *name, const char *key, const char *value,
                       lr_status status, const char *what)
{
    expect_bad_edit("tri.gltf", name, NULL, key, value, status, what);
}

/* Renders glTF FILE of the test directory 64 x 32 from (0, 0, 5) down
 * -z (fov 40) and checks the depth at four pixels, two on a quad left of
 * x = 0 and two right of it, against want(sx): sx is the pixel's ray
 * (sx, sy, -1) across, `left` says which quad. */
static void expect_depths(const char *file, double (*want)(double sx, int left))
{
    char json[400];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": 64, \"height\": 32, \"spp\": 1, "
             "\"depth\": true}, \"camera\": {\"position\": [0, 0, 5], "
             "\"look_at\": [0, 0, 0], \"fov\": 40}, \"objects\": "
             "[{\"type\": \"gltf\", \"file\": \"%s\"}]}",
             file);
    lr_scene *s = lr_test_load_json(json);
    lr_image *img = render(s);
    const float *z = lr_image_depth(img);
    double t = tan(20 * PI / 180);
    static const int px[][2] = {{20, 16}, {22, 13}, {43, 16}, {40, 18}};
    for (int i = 0; i < 4; i++) {
        double sx = (2 * (px[i][0] + 0.5) / 64 - 1) * t * 2;
        double w = want(sx, px[i][0] < 32);
        double got = z[px[i][1] * 64 + px[i][0]];
        if (!(fabs(got - w) < 1e-5 * w))
            fail_msg("%s: pixel (%d, %d): depth %.7g, the geometry says "
                     "%.7g",
                     file, px[i][0], px[i][1], got, w);
    }
    lr_image_free(img);
    lr_scene_free(s);
}

/* Scene "sparse": the first quad in z = x + 1.5, the second in
 * z = 0.25. */
static double sparse_depth(double sx, int left)
{
    return left ? 3.5 / (1 + sx) : 4.75;
}

/* Sparse accessors (spec 3.6.2.3), over a bufferView and over zeros:
 * scene "sparse" of gltf_writer.py, whose quads would be at z = 0 and a
 * heap of zeros without the sparse values. */
static void test_sparse_accessors(void **state)
{
    (void)state;
    make("sparse", "sparse.gltf");
    expect_depths("sparse.gltf", sparse_depth);
}

/* Sparse accessors that break the spec's rules (3.6.2.3), an accessor
 * without a bufferView too big to fill with zeros, and one that Draco
 * would fill (the error names the extension, not a missing view).
 * tri.gltf's accessors[0] is 3 VEC3 floats in bufferViews[0] (36 bytes),
 * its bufferViews[1] the 3 unsigned ints 0, 1, 2. */
static void test_sparse_hostile(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    static const char *const cases[][3] = {
        {"sp-count.gltf",
         "{\"count\": 4, \"indices\": {\"bufferView\": 1, "
         "\"componentType\": 5125}, \"values\": {\"bufferView\": 0}}",
         "accessors[0].sparse.count must be from 1 to the accessor's count"},
        {"sp-type.gltf",
         "{\"count\": 3, \"indices\": {\"bufferView\": 1, "
         "\"componentType\": 5126}, \"values\": {\"bufferView\": 0}}",
         "accessors[0].sparse.indices.componentType must be 5121"},
        {"sp-order.gltf",
         "{\"count\": 3, \"indices\": {\"bufferView\": 0, "
         "\"componentType\": 5125}, \"values\": {\"bufferView\": 0}}",
         "accessors[0].sparse.indices: element 1 is 0; they must increase"},
        {"sp-past.gltf",
         "{\"count\": 3, \"indices\": {\"bufferView\": 1, "
         "\"componentType\": 5125}, \"values\": {\"bufferView\": 0, "
         "\"byteOffset\": 24}}",
         "accessors[0].sparse.values: 3 elements of 12 bytes from byte 24 "
         "run past bufferViews[0]'s 36"},
        {"sp-none.gltf", "{\"count\": 3}",
         "accessors[0].sparse.indices must be an object"}};
    for (int i = 0; i < 5; i++)
        expect_bad(cases[i][0], "accessors.0.sparse", cases[i][1],
                   LR_ERR_INVALID, cases[i][2]);
    expect_bad_edit("tri.gltf", "zeros.gltf", "accessors.0.bufferView",
                    "accessors.0.count", "1000000000", LR_ERR_INVALID,
                    "accessors[0]: 1000000000 elements of 12 bytes to fill "
                    "in (zeros or sparse) are more than lensray allows");
    expect_bad_edit("tri.gltf", "draco.gltf", "accessors.0.bufferView",
                    "meshes.0.primitives",
                    "[{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, "
                    "\"extensions\": {\"KHR_draco_mesh_compression\": "
                    "{\"bufferView\": 0, \"attributes\": {\"POSITION\": 0}}}}]",
                    LR_ERR_INVALID,
                    "accessors[0] has no bufferView: meshes[0].primitives[0] "
                    "is compressed with KHR_draco_mesh_compression, which "
                    "lensray does not decode");
}

/* Scene "morph": the quad at x = -1 in z = 1.1 + 0.4 x, the one at
 * x = +1 in z = 0.25. */
static double morph_depth(double sx, int left)
{
    return left ? 3.9 / (1 + 0.4 * sx) : 4.75;
}

/* Morph targets at their default weights (spec 3.7.2.2): scene "morph"
 * of gltf_writer.py, the mesh's weights (0.5, 0.4) on the left, the
 * node's own (0.25, 0) on the right.  Without the targets both quads
 * would be at z = 0. */
static void test_morph_weights(void **state)
{
    (void)state;
    make("morph", "morph.gltf");
    expect_depths("morph.gltf", morph_depth);
    /* Weights and targets that break the spec's rules name the field. */
    expect_bad_edit("morph.gltf", "morph-w.gltf", NULL, "meshes.0.weights",
                    "[1]", LR_ERR_INVALID,
                    "meshes[0].weights must be 2 numbers from -1e6 to 1e6, "
                    "one per morph target");
    expect_bad_edit("morph.gltf", "morph-nw.gltf", NULL, "nodes.1.weights",
                    "[1, 2, 3]", LR_ERR_INVALID,
                    "nodes[1].weights must be 2 numbers");
    expect_bad_edit("morph.gltf", "morph-t.gltf", NULL, "meshes.0.primitives",
                    "[{\"attributes\": {\"POSITION\": 1}, \"indices\": 0, "
                    "\"targets\": [{\"POSITION\": 0}]}]",
                    LR_ERR_INVALID,
                    "meshes[0].primitives[0].targets[0].POSITION: "
                    "accessors[0] must be a VEC3 of floats");
}

/* A file of points alone has nothing to frame, and the error says why
 * rather than that it has no meshes (the glTF Asset Generator's
 * Mesh_PrimitiveMode_00, mode 0). */
static void test_points_only(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    cJSON *root = read_json("tri.gltf");
    cJSON *prim = cJSON_GetArrayItem(
        cJSON_GetObjectItem(
            cJSON_GetArrayItem(cJSON_GetObjectItem(root, "meshes"), 0),
            "primitives"),
        0);
    cJSON_AddNumberToObject(prim, "mode", 0);
    write_json("points.gltf", root);
    const char *json = "{\"objects\": [{\"type\": \"gltf\", \"file\": "
                       "\"points.gltf\", \"camera\": true}]}";
    lr_scene *s = NULL;
    lr_error err;
    assert_int_equal(lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                        NULL, 0, &s, &err),
                     LR_ERR_INVALID);
    if (strstr(err.message, "points.gltf: it has no camera and no "
                            "triangles to frame (points and lines are not "
                            "drawn)") == NULL)
        fail_msg("points alone: \"%s\"", err.message);
}

/* Skins at their joints' own transforms (spec 3.7.3.3): scene "skin"
 * of gltf_writer.py, whose skinned quad lies where sparse.gltf's first
 * does, z = x + 1.5 (joint 1's world transform times its inverse bind
 * matrix lifts two corners by 1), and whose plain quad lies in z = 0.25:
 * the depths of test_sparse_accessors.  Unskinned, the quad would be
 * drawn under its node's transform, 15 units away.  A joint index beyond
 * the skin's joints and a skin without joints name the field. */
static void test_skin(void **state)
{
    (void)state;
    make("skin", "skin.gltf");
    expect_depths("skin.gltf", sparse_depth);
    expect_bad_edit("skin.gltf", "skin-j.gltf", NULL, "skins.0.joints", "[0]",
                    LR_ERR_INVALID,
                    "nodes[2]: meshes[0].primitives[0].attributes.JOINTS_0: "
                    "joint 1 of a skin of 1 joints");
    expect_bad_edit("skin.gltf", "skin-e.gltf", NULL, "skins.0.joints", "[]",
                    LR_ERR_INVALID,
                    "skins[0].joints must be a non-empty array");
}

/* A camera node that mirrors (scale -1 in x) is warned about: lensray's
 * camera cannot show the mirror image the spec's view matrix makes; an
 * unmirrored one is not. */
static void test_mirrored_camera(void **state)
{
    (void)state;
    make("camera-floor", "camfloor.gltf");
    cJSON *root = read_json("camfloor.gltf");
    cJSON *nodes = cJSON_GetObjectItem(root, "nodes");
    for (cJSON *n = nodes->child; n; n = n->next)
        if (cJSON_GetObjectItem(n, "camera") != NULL)
            cJSON_AddItemToObject(n, "scale", cJSON_Parse("[-1, 1, 1]"));
    write_json("mirrorcam.gltf", root);
    static const char *const files[] = {"camfloor.gltf", "mirrorcam.gltf"};
    for (int k = 0; k < 2; k++) {
        char json[200];
        snprintf(json, sizeof json,
                 "{\"objects\": [{\"type\": \"gltf\", "
                 "\"file\": \"%s\", \"camera\": true}]}",
                 files[k]);
        lr_scene *s = lr_test_load_json(json);
        const char *w = strstr(lr_scene_warnings(s), "mirrors the camera");
        if ((w != NULL) != (k == 1))
            fail_msg("%s: warnings \"%s\"", files[k], lr_scene_warnings(s));
        lr_scene_free(s);
    }
}

/* A file that uses KHR_mesh_quantization without requiring it (the
 * glTF Validator's non_required.gltf): the refused integer positions'
 * error names the extension. */
static void test_quantized_unrequired(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    cJSON *root = read_json("tri.gltf");
    cJSON_AddItemToObject(root, "extensionsUsed",
                          cJSON_Parse("[\"KHR_mesh_quantization\"]"));
    cJSON *a = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "accessors"), 0);
    cJSON_ReplaceItemInObject(a, "componentType", cJSON_CreateNumber(5123));
    write_json("quant.gltf", root);
    expect_file_error("quant.gltf", LR_ERR_INVALID,
                      "quant.gltf: meshes[0].primitives[0].attributes."
                      "POSITION: accessors[0] must be a VEC3 of floats "
                      "(5126) (KHR_mesh_quantization is not read by "
                      "lensray)");
}

/* A texture whose image is only in an extension (KTX2 through
 * KHR_texture_basisu, without a PNG fallback) is ignored with a warning
 * that names the extension. */
static void test_texture_extension_only(void **state)
{
    (void)state;
    make("textured", "textured.gltf");
    cJSON *root = read_json("textured.gltf");
    cJSON *t = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "textures"), 0);
    cJSON_DeleteItemFromObject(t, "source");
    cJSON_AddItemToObject(
        t, "extensions",
        cJSON_Parse("{\"KHR_texture_basisu\": {\"source\": 0}}"));
    write_json("basisu.gltf", root);
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"basisu.gltf\"}]}");
    if (strstr(lr_scene_warnings(s), "its texture has no source image, "
                                     "only one in KHR_texture_basisu, which "
                                     "lensray does not read: ignored") == NULL)
        fail_msg("warnings: \"%s\"", lr_scene_warnings(s));
    lr_scene_free(s);
}

/* A primitive without POSITION is not drawn (spec 3.7.2.1), with a
 * warning, and the file's others are (the glTF Validator's
 * primitive_no_position.gltf was refused whole); a mesh left with nothing
 * to draw places nothing. */
/* A metallic material's textures on a primitive without TEXCOORD_0:
 * the texel at (0, 0) (red) with the warning, as for any textured
 * material; the base texture was dropped without a word (grey). */
static void test_metal_texture_without_uvs(void **state)
{
    (void)state;
    make("metal-no-uv", "metal-no-uv.gltf");
    lr_scene *s = lr_test_load_json(
        "{\"camera\": {\"position\": [0, 0, 3], \"look_at\": [0, 0, 0]},"
        " \"render\": {\"width\": 8, \"height\": 8, \"spp\": 16,"
        "  \"integrator\": \"path\"}, \"background\": 1,"
        " \"objects\": [{\"type\": \"gltf\", \"file\": "
        "\"metal-no-uv.gltf\"}]}");
    if (strstr(lr_scene_warnings(s), "has no TEXCOORD_0") == NULL)
        fail_msg("warnings: \"%s\"", lr_scene_warnings(s));
    lr_image *img = render(s);
    const float *p = &lr_image_rgb(img)[3 * (4 * 8 + 4)];
    if (!(p[0] > 0.3f && p[1] < 0.02f && p[2] < 0.02f))
        fail_msg("centre (%g, %g, %g), want the red texel", p[0], p[1], p[2]);
    lr_image_free(img);
    lr_scene_free(s);
}

static void test_no_position(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    static const char *const prims[] = {
        "[{\"attributes\": {\"NORMAL\": 0}}, {\"attributes\": "
        "{\"POSITION\": 0}, \"indices\": 1}]",
        "[{\"attributes\": {\"NORMAL\": 0}, \"indices\": 1}]"};
    for (int k = 0; k < 2; k++) {
        cJSON *root = read_json("tri.gltf");
        cJSON *m = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "meshes"), 0);
        cJSON_ReplaceItemInObject(m, "primitives", cJSON_Parse(prims[k]));
        write_json("nopos.gltf", root);
        lr_scene *s = lr_test_load_json(
            "{\"objects\": [{\"type\": \"gltf\", \"file\": \"nopos.gltf\"}]}");
        assert_int_equal(lr_scene_primitive_count(s), 1 - k);
        if (strstr(lr_scene_warnings(s), "meshes[0].primitives[0] has no "
                                         "POSITION: not drawn") == NULL)
            fail_msg("warnings: \"%s\"", lr_scene_warnings(s));
        lr_scene_free(s);
    }
}

/* Vertex colours and tangents are not read: each kind is one warning
 * naming its first place and how many more primitives have it (COLOR_0
 * rendered white without a word, and docs/gltf.md promised TANGENT's
 * warning). */
static void test_unread_attributes(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    cJSON *root = read_json("tri.gltf");
    cJSON *m = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "meshes"), 0);
    cJSON_ReplaceItemInObject(
        m, "primitives",
        cJSON_Parse("[{\"attributes\": {\"POSITION\": 0, \"TANGENT\": 0}, "
                    "\"indices\": 1}, {\"attributes\": {\"POSITION\": 0, "
                    "\"COLOR_0\": 0}, \"indices\": 1}, {\"attributes\": "
                    "{\"COLOR_0\": 0, \"COLOR_1\": 0, \"POSITION\": 0}, "
                    "\"indices\": 1}]"));
    write_json("colours.gltf", root);
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"colours.gltf\"}]}");
    const char *w = lr_scene_warnings(s);
    if (strstr(w, "meshes[0].primitives[1].attributes.COLOR_0 is ignored "
                  "(vertex colours: the material's base colour alone is "
                  "used); so are those of 1 more primitives") == NULL ||
        strstr(w, "meshes[0].primitives[0].attributes.TANGENT is ignored "
                  "(tangents come from each triangle's UVs)\n") == NULL)
        fail_msg("warnings: \"%s\"", w);
    lr_scene_free(s);
}

/* A member of the document's root is named alone ("scene", not
 * ".scene"): scene 5 of a file without scenes. */
static void test_root_member_error(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    cJSON *root = read_json("tri.gltf");
    cJSON_DeleteItemFromObject(root, "scenes");
    cJSON_DeleteItemFromObject(root, "scene");
    cJSON_AddNumberToObject(root, "scene", 5);
    write_json("noscenes.gltf", root);
    expect_file_error("noscenes.gltf", LR_ERR_INVALID,
                      "noscenes.gltf: scene refers to an element of an "
                      "empty or missing array");
}

/* A file without scenes (valid glTF: a library of parts) has nothing to
 * draw, and says so itself rather than through assimp's "GLTF: No
 * scene" (the glTF Validator's EXT_texture_webp samples). */
static void test_no_scenes(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    cJSON *root = read_json("tri.gltf");
    cJSON_DeleteItemFromObject(root, "scenes");
    cJSON_DeleteItemFromObject(root, "scene");
    write_json("sceneless.gltf", root);
    expect_file_error("sceneless.gltf", LR_ERR_INVALID,
                      "sceneless.gltf: it has no scenes: nothing to draw");
}

/* tri.gltf under a chain of `links` more nodes (its triangle then lies
 * links + 1 levels below the scene's root), written as FILE. */
static void write_chain(const char *file, int links)
{
    cJSON *root = read_json("tri.gltf");
    cJSON *nodes = cJSON_GetObjectItemCaseSensitive(root, "nodes");
    cJSON *scene = cJSON_GetArrayItem(
        cJSON_GetObjectItemCaseSensitive(root, "scenes"), 0);
    int n0 = cJSON_GetArraySize(nodes);
    for (int j = 0; j < links; j++) {
        cJSON *node = cJSON_CreateObject();
        cJSON *ch = cJSON_AddArrayToObject(node, "children");
        /* The last link holds the old root, nodes[1]. */
        cJSON_AddItemToArray(
            ch, cJSON_CreateNumber(j + 1 < links ? n0 + j + 1 : 1));
        cJSON_AddItemToArray(nodes, node);
    }
    cJSON *roots = cJSON_CreateArray();
    cJSON_AddItemToArray(roots, cJSON_CreateNumber(n0));
    cJSON_ReplaceItemInObjectCaseSensitive(scene, "nodes", roots);
    write_json(file, root);
}

/* A node hierarchy is at most LR__GLTF_MAX_DEPTH (1000) deep: the walks
 * over it recurse once a level, and a chain of 15,000 nodes overflowed
 * the stack (the CLI's, and a daemon's connection thread: any client
 * could take the daemon down).  1000 levels load; 1001 are an error
 * naming the node. */
static void test_deep_hierarchy(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    write_chain("deep1000.gltf", 999);
    lr_scene *s = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"deep1000.gltf\"}]}");
    assert_int_equal(lr_scene_primitive_count(s), 1);
    lr_scene_free(s);
    write_chain("deep1001.gltf", 1000);
    expect_file_error("deep1001.gltf", LR_ERR_INVALID,
                      "nodes[0] lies 1001 levels below its root: at most 1000");
    /* Far deeper: refused the same way, not a crash. */
    write_chain("deep20000.gltf", 20000);
    expect_file_error("deep20000.gltf", LR_ERR_INVALID, "at most 1000");
}

static void test_hostile(void **state)
{
    (void)state;
    make("tri", "tri.gltf");
    expect_bad("count.gltf", "accessors.0.count", "1000000000", LR_ERR_INVALID,
               "accessors[0]");
    expect_bad("view.gltf", "accessors.1.bufferView", "99", LR_ERR_INVALID,
               "accessors[1].bufferView");
    expect_bad("offset.gltf", "bufferViews.0.byteOffset", "4000000000",
               LR_ERR_INVALID, "bufferViews[0]");
    expect_bad("missing.gltf", "buffers.0.uri", "\"missing.bin\"", LR_ERR_IO,
               "missing.bin");
    expect_bad("abs.gltf", "buffers.0.uri", "\"/etc/passwd\"", LR_ERR_INVALID,
               "absolute");
    expect_bad("dotdot.gltf", "buffers.0.uri", "\"a/../../x.bin\"",
               LR_ERR_INVALID, "\"..\"");
    expect_bad("scheme.gltf", "buffers.0.uri", "\"file:///etc/passwd\"",
               LR_ERR_INVALID, "scheme");
    expect_bad("scheme2.gltf", "buffers.0.uri", "\"t:1.bin\"", LR_ERR_INVALID,
               "scheme");
    /* A colon past the first segment, or escaped, is a file name's (RFC
     * 3986, 4.2): both were refused as a scheme. */
    expect_bad("colon.gltf", "buffers.0.uri", "\"sub/t:1.bin\"", LR_ERR_IO,
               "sub/t:1.bin: cannot open");
    expect_bad("colon2.gltf", "buffers.0.uri", "\"data%3Ax.bin\"", LR_ERR_IO,
               "data:x.bin: cannot open");
    /* Percent escapes are decoded (RFC 3986), then checked like the
     * rest; an escaped slash, backslash or NUL is refused. */
    expect_bad("dots.gltf", "buffers.0.uri", "\"%2e%2E/x.bin\"", LR_ERR_INVALID,
               "\"..\" segment");
    expect_bad("slash.gltf", "buffers.0.uri", "\"a%2Fb.bin\"", LR_ERR_INVALID,
               "escapes a slash");
    expect_bad("pct.gltf", "buffers.0.uri", "\"a%zz.bin\"", LR_ERR_INVALID,
               "not an escape");
    expect_bad("space.gltf", "buffers.0.uri", "\"no%20such.bin\"", LR_ERR_IO,
               "no such.bin: cannot open");
    make("tri-spaced", "spaced.gltf");
    lr_scene *sp = lr_test_load_json(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"spaced.gltf\"}]}");
    assert_int_equal(lr_scene_primitive_count(sp), 1);
    lr_scene_free(sp);
    /* A symbolic link beside the glTF that leads out of its directory. */
    char dir[512], link[600];
    snprintf(dir, sizeof dir, "%s/sub", lr_test_tmpdir());
    mkdir(dir, 0755);
    lr_test_write_text("outside.bin",
                       "0123456789012345678901234567890123"
                       "456789012345678",
                       link, sizeof link);
    snprintf(link, sizeof link, "%s/link.bin", dir);
    unlink(link);
    assert_int_equal(symlink("../outside.bin", link), 0);
    expect_bad("sub/link.gltf", "buffers.0.uri", "\"link.bin\"", LR_ERR_INVALID,
               "symbolic link");
    expect_bad("cycle.gltf", "nodes.0.children", "[1]", LR_ERR_INVALID,
               "nodes[");
    expect_bad("index.gltf", "meshes.0.primitives",
               "[{\"attributes\": {\"POSITION\": 0}, \"indices\": 0}]",
               LR_ERR_INVALID, "indices");
    expect_bad("range.gltf", "accessors.0.count", "2", LR_ERR_INVALID,
               "beyond the 2 vertices");
    expect_bad("matrix.gltf", "nodes.1.matrix", "[1, 2]", LR_ERR_INVALID,
               "nodes[1].matrix");
    /* The texture slots inside pbrMetallicRoughness are named by their
     * whole path. */
    expect_bad("slot.gltf", "materials.0.pbrMetallicRoughness",
               "{\"baseColorTexture\": {\"index\": 9}}", LR_ERR_INVALID,
               "materials[0].pbrMetallicRoughness.baseColorTexture.index");
    expect_bad("light.gltf", "nodes.1.extensions",
               "{\"KHR_lights_punctual\": {\"light\": 0}}", LR_ERR_INVALID,
               "nodes[1].extensions.KHR_lights_punctual.light refers to");
    /* A missing file: its error starts with the field (it started with
     * the file's name alone). */
    expect_file_error("nothere.gltf", LR_ERR_IO, "cannot open");
    /* 1e300 is finite; the bound is on the magnitude (the message said
     * "finite numbers"). */
    expect_bad("huge.gltf", "nodes.0.scale", "[1e300, 1, 1]", LR_ERR_INVALID,
               "nodes[0].scale must be an array of 3 numbers of magnitude "
               "at most 1e15");

    /* A vertex that is not a number: the accessor and the element. */
    make("tri-nan", "nan.glb");
    expect_file_error("nan.glb", LR_ERR_INVALID,
                      "objects[0].file: nan.glb: meshes[0]."
                      "primitives[0].attributes.POSITION: "
                      "accessors[0] element 1: y is nan");

    /* An image that is no image: the error names the file, the image
     * and the material slot that uses it. */
    make("textured", "textured.gltf");
    cJSON *troot = read_json("textured.gltf");
    cJSON *im = cJSON_GetArrayItem(cJSON_GetObjectItem(troot, "images"), 0);
    cJSON_DeleteItemFromObject(im, "bufferView");
    cJSON_DeleteItemFromObject(im, "mimeType");
    cJSON_AddStringToObject(im, "uri",
                            "data:image/png;base64,bm90IGFuIGltYWdl");
    write_json("badimage.gltf", troot);
    {
        const char *json = "{\"objects\": [{\"type\": \"gltf\", "
                           "\"file\": \"badimage.gltf\"}]}";
        lr_scene *s = NULL;
        lr_error err;
        assert_int_not_equal(lr_scene_load_json(json, strlen(json),
                                                lr_test_tmpdir(), NULL, 0, &s,
                                                &err),
                             LR_OK);
        assert_null(s);
        if (!strstr(err.message, "badimage.gltf: images[0]") ||
            !strstr(err.message, "baseColorTexture"))
            fail_msg("bad image: \"%s\"", err.message);
    }

    /* A GLB cut short anywhere is an error, never a crash. */
    make("tri", "tri.glb");
    char path[512];
    snprintf(path, sizeof path, "%s/tri.glb", lr_test_tmpdir());
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char glb[4096];
    size_t n = fread(glb, 1, sizeof glb, f);
    fclose(f);
    for (size_t cut = 0; cut < n; cut += 7) {
        lr_test_write_file("cut.glb", glb, cut, path, sizeof path);
        const char *json =
            "{\"objects\": [{\"type\": \"gltf\", \"file\": \"cut.glb\"}]}";
        lr_scene *s = NULL;
        lr_error err;
        lr_status st = lr_scene_load_json(json, strlen(json), lr_test_tmpdir(),
                                          NULL, 0, &s, &err);
        assert_null(s);
        assert_int_equal(st, LR_ERR_INVALID);
        assert_non_null(strstr(err.message, "cut.glb"));
    }
    lr_test_expect_invalid(
        "{\"objects\": [{\"type\": \"gltf\", \"file\": \"tri.glb\", "
        "\"material\": \"x\"}]}",
        strlen("{\"objects\": [{\"type\": \"gltf\", \"file\": "
               "\"tri.glb\", \"material\": \"x\"}]}"),
        "objects[0]", "material");
}

static const struct CMUnitTest tests[] = {
    cmocka_unit_test(test_transform_matches_obj),
    cmocka_unit_test(test_normals_inverse_transpose),
    cmocka_unit_test(test_camera_projection),
    cmocka_unit_test(test_read_settings_gltf_camera),
    cmocka_unit_test(test_point_light_irradiance),
    cmocka_unit_test(test_materials),
    cmocka_unit_test(test_material_mapping),
    cmocka_unit_test(test_textures),
    cmocka_unit_test(test_metal_texture),
    cmocka_unit_test(test_spot_light),
    cmocka_unit_test(test_texture_transform),
    cmocka_unit_test(test_normal_map),
    cmocka_unit_test(test_normal_map_transformed),
    cmocka_unit_test(test_hostile),
    cmocka_unit_test(test_deep_hierarchy),
    cmocka_unit_test(test_overrides_win_over_gltf_camera),
    cmocka_unit_test(test_camera_aspect_too_tall),
    cmocka_unit_test(test_root_member_error),
    cmocka_unit_test(test_sparse_accessors),
    cmocka_unit_test(test_sparse_hostile),
    cmocka_unit_test(test_morph_weights),
    cmocka_unit_test(test_points_only),
    cmocka_unit_test(test_skin),
    cmocka_unit_test(test_mirrored_camera),
    cmocka_unit_test(test_no_scenes),
    cmocka_unit_test(test_quantized_unrequired),
    cmocka_unit_test(test_texture_extension_only),
    cmocka_unit_test(test_no_position),
    cmocka_unit_test(test_metal_texture_without_uvs),
    cmocka_unit_test(test_unread_attributes),
};
LR_TEST_GROUP(gltf, tests)
