/*
 * helpers.c: what the unit tests share (declared in test.h): scratch
 * files, loading and rendering scenes with the checks every render must
 * pass, comparing images, a busy test scene, the check of an input
 * error, and the table of the scene format's fields.
 */
#include "test.h"
#include "camera/camera.h"
#include "json/json_util.h"
#include "render/plan.h"
#include "optics/prescription.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

const char *lr_test_tmpdir(void)
{
    static char dir[256];
    if (dir[0] == '\0') {
        const char *base = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/lensray-unit-XXXXXX",
                 base && *base ? base : "/tmp");
        if (mkdtemp(dir) == NULL) {
            perror("mkdtemp");
            exit(2);
        }
    }
    return dir;
}

lr__surface lr_test_flat(double t, double n, double semi)
{
    lr__surface s;
    memset(&s, 0, sizeof s);
    s.thickness = t;
    s.semi_aperture = semi;
    s.after.kind = n == 1.0 ? LR__GLASS_AIR : LR__GLASS_CONSTANT;
    s.after.nd = n;
    return s;
}

lr_image *lr_test_render(const char *json, const char *const *sets,
                         size_t n_sets, lr_render_stats *stats)
{
    lr_scene *s = lr_test_load(json, sets, n_sets);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    lr_image *img = NULL;
    lr_error err;
    if (lr_render(s, &cam, &rs, &img, stats, &err) != LR_OK)
        fail_msg("render: %s", err.message);
    lr_scene_free(s);
    return img;
}

void lr_test_plan_renders(const char *scene, int ref_spp, int spp,
                          lr_image **out, lr_render_stats *sf,
                          lr_render_stats *sp)
{
    char rs[32], ss[32];
    snprintf(rs, sizeof rs, "render.spp=%d", ref_spp);
    snprintf(ss, sizeof ss, "render.spp=%d", spp);
    const char *ref_sets[] = {rs, "render.plan=false", "render.adaptive=false",
                              "render.seed=77"};
    const char *full_sets[] = {ss, "render.plan=false",
                               "render.adaptive=false"};
    const char *plan_sets[] = {ss, "render.plan=true", "render.adaptive=false"};
    out[0] = lr_test_render(scene, ref_sets, 4, NULL);
    out[1] = lr_test_render(scene, full_sets, 3, sf);
    out[2] = lr_test_render(scene, plan_sets, 3, sp);
}

double lr_test_rmse(const lr_image *a, const lr_image *b)
{
    int n = lr_image_width(a) * lr_image_height(a) * 3;
    double e = 0;
    for (int i = 0; i < n; i++) {
        double d = lr_image_rgb(a)[i] - lr_image_rgb(b)[i];
        e += d * d;
    }
    return sqrt(e / n);
}

lr_scene *lr_test_load(const char *json, const char *const *sets, size_t n_sets)
{
    lr_scene *s = NULL;
    lr_error err;
    memset(&err, 0, sizeof err);
    if (lr_scene_load_json(json, strlen(json), lr_test_tmpdir(), sets, n_sets,
                           &s, &err) != LR_OK)
        fail_msg("scene did not load: %s\n  %s", err.message, json);
    return s;
}

lr_scene *lr_test_load_json(const char *json)
{
    return lr_test_load(json, NULL, 0);
}

/* Every value finite (depth too); no sample was dropped as NaN or Inf,
 * since a dropped sample is a numerical failure the film merely hides. */
void lr_test_check_finite(const lr_image *img, const lr_render_stats *st,
                          const char *what)
{
    int n = lr_image_width(img) * lr_image_height(img);
    const float *rgb = lr_image_rgb(img);
    for (int i = 0; i < 3 * n; i++)
        if (!isfinite(rgb[i]))
            fail_msg("%s: pixel value %d is %g", what, i, (double)rgb[i]);
    const float *z = lr_image_depth(img);
    for (int i = 0; z != NULL && i < n; i++)
        if (!isfinite(z[i]) || z[i] < 0)
            fail_msg("%s: depth %d is %g", what, i, (double)z[i]);
    if (st != NULL && st->nan_samples != 0)
        fail_msg("%s: %llu samples were NaN or Inf and dropped", what,
                 (unsigned long long)st->nan_samples);
}

lr_image *lr_test_render_with(const lr_scene *s, const lr_camera *cam,
                              const lr_render_settings *rs, const char *what)
{
    lr_image *img = NULL;
    lr_render_stats st;
    lr_error err;
    memset(&err, 0, sizeof err);
    if (lr_render(s, cam, rs, &img, &st, &err) != LR_OK)
        fail_msg("%s: render failed: %s", what, err.message);
    lr_test_check_finite(img, &st, what);
    return img;
}

/* Loads, renders with the scene's own camera and settings, checks. */
lr_image *lr_test_render_sets(const char *json, const char *const *sets,
                              size_t n_sets, const char *what)
{
    lr_scene *s = lr_test_load(json, sets, n_sets);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    lr_image *img = lr_test_render_with(s, &cam, &rs, what);
    lr_scene_free(s);
    return img;
}

lr_image *lr_test_render_json(const char *json, const char *what)
{
    return lr_test_render_sets(json, NULL, 0, what);
}

size_t lr_test_n_values(const lr_image *img)
{
    return 3u * (size_t)lr_image_width(img) * (size_t)lr_image_height(img);
}

void lr_test_assert_same_bytes(const lr_image *a, const lr_image *b,
                               const char *what)
{
    assert_int_equal(lr_image_width(a), lr_image_width(b));
    assert_int_equal(lr_image_height(a), lr_image_height(b));
    const float *pa = lr_image_rgb(a), *pb = lr_image_rgb(b);
    for (size_t i = 0; i < lr_test_n_values(a); i++)
        if (memcmp(&pa[i], &pb[i], sizeof(float)) != 0)
            fail_msg("%s: value %zu differs: %.9g vs %.9g", what, i,
                     (double)pa[i], (double)pb[i]);
}

lr_test_diff lr_test_compare(const lr_image *a, const lr_image *b)
{
    lr_test_diff d = {0, 0, 0};
    const float *pa = lr_image_rgb(a), *pb = lr_image_rgb(b);
    size_t n = lr_test_n_values(a);
    double sum_a = 0, sum_d = 0;
    size_t bad = 0;
    for (size_t p = 0; p < n / 3; p++) {
        int off = 0;
        for (int c = 0; c < 3; c++) {
            double x = pa[3 * p + c], y = pb[3 * p + c];
            double e = fabs(x - y);
            sum_a += fabs(x);
            sum_d += e;
            if (e > d.max_abs)
                d.max_abs = e;
            if (e > 0.05 * fabs(x) + 0.02)
                off = 1;
        }
        bad += (size_t)off;
    }
    d.mean_rel = sum_a > 0 ? sum_d / sum_a : sum_d;
    d.bad_frac = (double)bad / (double)(n / 3);
    return d;
}

/* A small lit scene used by many tests: a red sphere, a mirror sphere, a
 * glass sphere and a floor, under a point, a directional and an ambient
 * light.  `cam` and `render` are spliced in as JSON members. */
void lr_test_busy_scene(char *out, size_t cap, const char *cam,
                        const char *render)
{
    snprintf(out, cap,
             "{\"camera\": {%s}, \"render\": {%s},"
             " \"background\": [0.2, 0.25, 0.3],"
             " \"materials\": {\"red\": {\"diffuse\": [0.7, 0.1, 0.1],"
             "   \"specular\": 0.2, \"shininess\": 40},"
             "  \"mirror\": {\"reflect\": 0.8, \"diffuse\": 0.05},"
             "  \"glass\": {\"transmit\": 1, \"ior\": 1.5},"
             "  \"floor\": {\"diffuse\": 0.5}},"
             " \"lights\": [{\"type\": \"point\", \"position\": [3, 6, 4],"
             "   \"intensity\": 60},"
             "  {\"type\": \"directional\", \"direction\": [-1, -2, -1],"
             "   \"irradiance\": 0.5},"
             "  {\"type\": \"ambient\", \"radiance\": 0.05}],"
             " \"objects\": ["
             "  {\"type\": \"plane\", \"normal\": [0, 1, 0],"
             "   \"material\": \"floor\"},"
             "  {\"type\": \"sphere\", \"center\": [-1.2, 1, 0], \"radius\": 1,"
             "   \"material\": \"red\"},"
             "  {\"type\": \"sphere\", \"center\": [1.3, 0.7, 0.5],"
             "   \"radius\": 0.7, \"material\": \"mirror\"},"
             "  {\"type\": \"sphere\", \"center\": [0.2, 0.5, 2],"
             "   \"radius\": 0.5, \"material\": \"glass\"}]}",
             cam, render);
}

/* Loads text that must fail with an error naming `path` (a prefix of the
 * error's path, so that "camera.position" accepts "camera.position[1]"),
 * in a message that names it too. */
void lr_test_expect_invalid(const char *json, size_t len, const char *path,
                            const char *what)
{
    lr_scene *s = (lr_scene *)0x1;
    lr_error err;
    memset(&err, 0, sizeof err);
    lr_status st = lr_scene_load_json(json, len, lr_test_tmpdir(), NULL, 0, &s,
                                      &err);
    if (st != LR_ERR_INVALID && st != LR_ERR_LIMIT)
        fail_msg("%s: status %d (want invalid or limit) for %.200s", what,
                 (int)st, json);
    if (s != NULL)
        fail_msg("%s: failed but returned a scene", what);
    if (err.message[0] == '\0')
        fail_msg("%s: empty message", what);
    if (path != NULL && strncmp(err.path, path, strlen(path)) != 0)
        fail_msg("%s: error path \"%s\", want \"%s\" (%s)", what, err.path,
                 path, err.message);
    if (err.path[0] != '\0' &&
        strncmp(err.message, err.path, strlen(err.path)) != 0)
        fail_msg("%s: message \"%s\" does not start with \"%s\"", what,
                 err.message, err.path);
    if (lr__utf8_invalid_at(err.message) != (size_t)-1 ||
        lr__utf8_invalid_at(err.path) != (size_t)-1)
        fail_msg("%s: error is not valid UTF-8", what);
}

void lr_test_write_file(const char *name, const void *data, size_t len,
                        char *path, size_t cap)
{
    int n = snprintf(path, cap, "%s/%s", lr_test_tmpdir(), name);
    assert_true(n > 0 && (size_t)n < cap);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

void lr_test_write_text(const char *name, const char *text, char *path,
                        size_t cap)
{
    lr_test_write_file(name, text, strlen(text), path, cap);
}

void lr_test_write_exr(const char *name, int w, int h,
                       void (*f)(int x, int y, float rgb[3]), char *path,
                       size_t cap)
{
    lr_image *img = NULL;
    lr_error err;
    assert_int_equal(lr_image_create(w, h, 0, &img, &err), LR_OK);
    float *px = lr_image_rgb_mut(img);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            f(x, y, &px[3 * ((size_t)y * w + x)]);
    int n = snprintf(path, cap, "%s/%s", lr_test_tmpdir(), name);
    assert_true(n > 0 && (size_t)n < cap);
    if (lr_image_write(img, path, NULL, &err) != LR_OK)
        fail_msg("%s", err.message);
    lr_image_free(img);
}

/* One line per field of the format: a JSON template with %s where the
 * value goes, the path of that value, and the JSON types it accepts. */
#define OBJ_S                                                      \
    "{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,-5], " \
    "\"radius\": 1, %s}]}"
const lr_test_field lr_test_fields[] = {
    {"{\"description\": %s}", "description", LR_TEST_STR},
    {"{\"camera\": %s}", "camera", LR_TEST_OBJ},
    {"{\"render\": %s}", "render", LR_TEST_OBJ},
    {"{\"background\": %s}", "background", LR_TEST_NUM | LR_TEST_ARR},
    {"{\"materials\": %s}", "materials", LR_TEST_OBJ},
    {"{\"lights\": %s}", "lights", LR_TEST_ARR},
    {"{\"objects\": %s}", "objects", LR_TEST_ARR},
    {"{\"camera\": {\"model\": %s}}", "camera.model", LR_TEST_STR},
    {"{\"camera\": {\"position\": %s}}", "camera.position", LR_TEST_ARR},
    {"{\"camera\": {\"look_at\": %s}}", "camera.look_at", LR_TEST_ARR},
    {"{\"camera\": {\"up\": %s}}", "camera.up", LR_TEST_ARR},
    {"{\"camera\": {\"fov\": %s}}", "camera.fov", LR_TEST_NUM},
    {"{\"camera\": {\"focus_distance\": %s}}", "camera.focus_distance",
     LR_TEST_NUM},
    {"{\"camera\": {\"aperture_radius\": %s}}", "camera.aperture_radius",
     LR_TEST_NUM},
    {"{\"camera\": {\"focal_length_mm\": 50, \"f_number\": %s}}",
     "camera.f_number", LR_TEST_NUM},
    {"{\"camera\": {\"focal_length_mm\": %s}}", "camera.focal_length_mm",
     LR_TEST_NUM},
    {"{\"camera\": {\"aperture_shape\": %s}}", "camera.aperture_shape",
     LR_TEST_STR},
    {"{\"camera\": {\"aperture_blades\": %s}}", "camera.aperture_blades",
     LR_TEST_NUM},
    {"{\"camera\": {\"aperture_rotation\": %s}}", "camera.aperture_rotation",
     LR_TEST_NUM},
    {"{\"camera\": {\"aperture_ratio\": %s}}", "camera.aperture_ratio",
     LR_TEST_NUM},
    {"{\"camera\": {\"focus_on\": %s}}", "camera.focus_on",
     LR_TEST_ARR | LR_TEST_NULL},
    {"{\"camera\": {\"image_plane_distance\": %s}}",
     "camera.image_plane_distance", LR_TEST_NUM},
    {"{\"camera\": {\"focal_length\": %s}}", "camera.focal_length",
     LR_TEST_NUM},
    {"{\"camera\": {\"aperture\": %s}}", "camera.aperture", LR_TEST_NUM},
    {"{\"camera\": {\"chromatic\": %s}}", "camera.chromatic", LR_TEST_OBJ},
    {"{\"camera\": {\"chromatic\": {\"mode\": %s}}}", "camera.chromatic.mode",
     LR_TEST_STR},
    {"{\"camera\": {\"chromatic\": {\"focal_model\": %s}}}",
     "camera.chromatic.focal_model", LR_TEST_STR},
    {"{\"camera\": {\"chromatic\": {\"ior\": %s}}}", "camera.chromatic.ior",
     LR_TEST_ARR},
    {"{\"camera\": {\"chromatic\": {\"glass\": %s}}}", "camera.chromatic.glass",
     LR_TEST_STR},
    {"{\"camera\": {\"chromatic\": {\"abbe\": %s}}}", "camera.chromatic.abbe",
     LR_TEST_OBJ},
    {"{\"camera\": {\"chromatic\": {\"abbe\": {\"n_d\": %s, \"V_d\": 50}}}}",
     "camera.chromatic.abbe.n_d", LR_TEST_NUM},
    {"{\"camera\": {\"chromatic\": {\"abbe\": {\"n_d\": 1.5, \"V_d\": %s}}}}",
     "camera.chromatic.abbe.V_d", LR_TEST_NUM},
    {"{\"camera\": {\"chromatic\": {\"amplify\": %s}}}",
     "camera.chromatic.amplify", LR_TEST_NUM},
    {"{\"camera\": {\"chromatic\": {\"wavelengths\": %s}}}",
     "camera.chromatic.wavelengths", LR_TEST_NUM},
    {"{\"camera\": {\"chromatic\": {\"splat\": %s}}}", "camera.chromatic.splat",
     LR_TEST_BOOL},
    {"{\"render\": {\"width\": %s}}", "render.width", LR_TEST_NUM},
    {"{\"render\": {\"height\": %s}}", "render.height", LR_TEST_NUM},
    {"{\"render\": {\"spp\": %s}}", "render.spp", LR_TEST_NUM},
    {"{\"render\": {\"sampler\": %s}}", "render.sampler", LR_TEST_STR},
    {"{\"render\": {\"integrator\": %s}}", "render.integrator", LR_TEST_STR},
    {"{\"render\": {\"seed\": %s}}", "render.seed", LR_TEST_NUM},
    {"{\"render\": {\"max_depth\": %s}}", "render.max_depth", LR_TEST_NUM},
    {"{\"render\": {\"threads\": %s}}", "render.threads", LR_TEST_NUM},
    {"{\"render\": {\"tile_size\": %s}}", "render.tile_size", LR_TEST_NUM},
    {"{\"render\": {\"depth\": %s}}", "render.depth", LR_TEST_BOOL},
    {"{\"accel\": {\"robust\": %s}}", "accel.robust", LR_TEST_BOOL},
    {"{\"render\": {\"region\": %s}}", "render.region", LR_TEST_ARR},
    {"{\"materials\": {\"m\": %s}}", "materials.m", LR_TEST_OBJ},
    {"{\"materials\": {\"m\": {\"diffuse\": %s}}}", "materials.m.diffuse",
     LR_TEST_NUM | LR_TEST_ARR},
    {"{\"materials\": {\"m\": {\"specular\": %s}}}", "materials.m.specular",
     LR_TEST_NUM | LR_TEST_ARR},
    {"{\"materials\": {\"m\": {\"shininess\": %s}}}", "materials.m.shininess",
     LR_TEST_NUM},
    {"{\"materials\": {\"m\": {\"reflect\": %s}}}", "materials.m.reflect",
     LR_TEST_NUM | LR_TEST_ARR},
    {"{\"materials\": {\"m\": {\"transmit\": %s}}}", "materials.m.transmit",
     LR_TEST_NUM | LR_TEST_ARR},
    {"{\"materials\": {\"m\": {\"ior\": %s}}}", "materials.m.ior", LR_TEST_NUM},
    {"{\"materials\": {\"m\": {\"emission\": %s}}}", "materials.m.emission",
     LR_TEST_NUM | LR_TEST_ARR},
    {"{\"materials\": {\"m\": {\"roughness\": %s}}}", "materials.m.roughness",
     LR_TEST_NUM},
    {"{\"materials\": {\"m\": {\"diffuse_texture\": %s}}}",
     "materials.m.diffuse_texture", LR_TEST_STR},
    {"{\"materials\": {\"m\": {\"emission_texture\": %s}}}",
     "materials.m.emission_texture", LR_TEST_STR},
    {"{\"materials\": {\"m\": {\"roughness_texture\": %s}}}",
     "materials.m.roughness_texture", LR_TEST_STR},
    {"{\"materials\": {\"m\": {\"roughness_channel\": %s}}}",
     "materials.m.roughness_channel", LR_TEST_NUM},
    {"{\"environment\": %s}", "environment", LR_TEST_OBJ},
    {"{\"environment\": {\"file\": %s}}", "environment.file", LR_TEST_STR},
    {"{\"lights\": [%s]}", "lights[0]", LR_TEST_OBJ},
    {"{\"lights\": [{\"type\": %s}]}", "lights[0].type", LR_TEST_STR},
    {"{\"lights\": [{\"type\": \"point\", \"intensity\": 1, \"position\": "
     "%s}]}",
     "lights[0].position", LR_TEST_ARR},
    {"{\"lights\": [{\"type\": \"point\", \"position\": [0,0,0], "
     "\"intensity\": %s}]}",
     "lights[0].intensity", LR_TEST_NUM | LR_TEST_ARR},
    {"{\"lights\": [{\"type\": \"directional\", \"irradiance\": 1, "
     "\"direction\": %s}]}",
     "lights[0].direction", LR_TEST_ARR},
    {"{\"lights\": [{\"type\": \"directional\", \"direction\": [0,-1,0], "
     "\"irradiance\": %s}]}",
     "lights[0].irradiance", LR_TEST_NUM | LR_TEST_ARR},
    {"{\"lights\": [{\"type\": \"ambient\", \"radiance\": %s}]}",
     "lights[0].radiance", LR_TEST_NUM | LR_TEST_ARR},
    {"{\"objects\": [%s]}", "objects[0]", LR_TEST_OBJ},
    {"{\"objects\": [{\"type\": %s}]}", "objects[0].type", LR_TEST_STR},
    {OBJ_S, "objects[0].material", LR_TEST_STR}, /* "material": %s, see below */
    {"{\"objects\": [{\"type\": \"sphere\", \"radius\": 1, \"center\": %s}]}",
     "objects[0].center", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "%s}]}",
     "objects[0].radius", LR_TEST_NUM},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": %s}]}",
     "objects[0].transform", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [%s]}]}",
     "objects[0].transform[0]", LR_TEST_OBJ},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"translate\": %s}]}]}",
     "objects[0].transform[0].translate", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"scale\": %s}]}]}",
     "objects[0].transform[0].scale", LR_TEST_NUM | LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"rotate\": %s}]}]}",
     "objects[0].transform[0].rotate", LR_TEST_OBJ},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"rotate\": {\"degrees\": 1, \"axis\": %s}}]}]}",
     "objects[0].transform[0].rotate.axis", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": "
     "1, \"transform\": [{\"rotate\": {\"axis\": [0,1,0], \"degrees\": "
     "%s}}]}]}",
     "objects[0].transform[0].rotate.degrees", LR_TEST_NUM},
    {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0,1,0], \"point\": "
     "%s}]}",
     "objects[0].point", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"plane\", \"normal\": %s}]}",
     "objects[0].normal", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0,1,0], \"size\": "
     "%s}]}",
     "objects[0].size", LR_TEST_NUM | LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"triangle\", \"vertices\": %s}]}",
     "objects[0].vertices", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"triangle\", \"vertices\": [[0,0,0], [1,0,0], "
     "%s]}]}",
     "objects[0].vertices[2]", LR_TEST_ARR},
    {"{\"objects\": [{\"type\": \"triangle\", \"vertices\": [[0,0,0], [1,0,0], "
     "[0, %s, 0]]}]}",
     "objects[0].vertices[2]", LR_TEST_NUM},
    {"{\"objects\": [{\"type\": \"mesh\", \"file\": %s}]}", "objects[0].file",
     LR_TEST_STR},
    {"{\"objects\": [{\"type\": \"mesh\", \"file\": \"x.obj\", \"smooth\": "
     "%s}]}",
     "objects[0].smooth", LR_TEST_BOOL},
};
const size_t lr_test_n_fields = sizeof lr_test_fields /
                                sizeof lr_test_fields[0];

/* Fills `out` with the template of field i and `value` in place. */
void lr_test_field_json(size_t i, const char *value, char *out, size_t cap)
{
    if (strcmp(lr_test_fields[i].tmpl, OBJ_S) == 0) {
        char m[256];
        snprintf(m, sizeof m, "\"material\": %s", value);
        snprintf(out, cap, OBJ_S, m);
    } else {
        snprintf(out, cap, lr_test_fields[i].tmpl, value);
    }
}

const char *const *lr_test_embree_isas(int *n)
{
    static const char *const isa[3] = {NULL, "isa=sse4.2", "isa=avx2"};
    *n = __builtin_cpu_supports("avx2") ? 3 : 2;
    return isa;
}

double lr_test_finite_mean(const lr_image *img, const char *what)
{
    const float *px = lr_image_rgb(img);
    size_t n = lr_test_n_values(img);
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(px[i]))
            fail_msg("%s: value %zu is %g", what, i, (double)px[i]);
        sum += px[i];
    }
    return sum / (double)n;
}

void lr_test_isa_means_agree(const double *mean, const char *const *isa, int n)
{
    assert_true(mean[0] > 0.01);
    for (int k = 1; k < n; k++)
        if (!(fabs(mean[k] - mean[0]) <= 0.01 * mean[0]))
            fail_msg("%s: mean %.9g, default %.9g", isa[k], mean[k], mean[0]);
}

void lr_test_write_map(const char *name, double (*value)(int x, int y), int W,
                       int H)
{
    lr_image *map = NULL;
    assert_int_equal(lr_image_create(W, H, 0, &map, NULL), LR_OK);
    float *px = lr_image_rgb_mut(map);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++)
                px[3 * (y * W + x) + c] = (float)value(x, y);
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", lr_test_tmpdir(), name);
    assert_int_equal(lr_image_write(map, path, NULL, NULL), LR_OK);
    lr_image_free(map);
}

/* Every pixel of crop (a render.region from (x0, y0)) has the bytes of
 * the full frame's pixel there. */
void lr_test_assert_region_is_frame(const lr_image *full, const lr_image *crop,
                                    int x0, int y0, const char *what)
{
    for (int y = 0; y < crop->height; y++)
        for (int x = 0; x < crop->width; x++)
            for (int k = 0; k < 3; k++) {
                float f = full->rgb[3 * ((size_t)(y + y0) * full->width +
                                         (size_t)(x + x0)) +
                                    k];
                float c = crop->rgb[3 * ((size_t)y * crop->width + x) + k];
                if (memcmp(&f, &c, sizeof f) != 0)
                    fail_msg("%s pixel (%d, %d): %g, full frame %g", what, x, y,
                             c, f);
            }
}

lr_scene *lr_test_plan(const char *json, const char *const *sets, size_t n_sets,
                       lr__cam *c, lr__plan *p, lr_render_settings *rs)
{
    lr_scene *s = lr_test_load(json, sets, n_sets);
    lr_camera cam;
    lr_render_settings set;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &set);
    lr__cam_init(c, &cam, set.width, set.height);
    lr_error err;
    assert_int_equal(
        lr__plan_build(p, s, c, &set, 0, 0, set.width, set.height, &err),
        LR_OK);
    if (rs != NULL)
        *rs = set;
    return s;
}
