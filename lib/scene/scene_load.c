/*
 * scene_load.c: the scene format's top level -> lr_scene: materials,
 * lights, environment, objects (scene_objects.c; with camera_json.c,
 * settings_json.c, transform.c and mesh.c for the parts they hold), from
 * JSON text or a file.  Every
 * value is validated and every error names its JSON path
 * ("objects[3].radius must be > 0, got -2").  Unknown and duplicate keys
 * are errors, so a typo never goes unnoticed.
 */
#include "camera/camera_json.h"
#include "scene/envmap.h"
#include "scene/gltf/gltf.h"
#include "json/json_util.h"
#include "scene/material_json.h"
#include "scene/scene.h"
#include "scene/scene_load.h"
#include "util/scene_file.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The largest scene file we read: far beyond any hand-written scene. */
#define MAX_SCENE_BYTES (64u << 20)

/* ---- materials -------------------------------------------------------- */

static lr_status parse_materials(lr_scene *s, const cJSON *mats,
                                 const char *base_dir, lr_error *err)
{
    static const char *const keys[] = {"diffuse",
                                       "specular",
                                       "shininess",
                                       "reflect",
                                       "transmit",
                                       "ior",
                                       "emission",
                                       "roughness",
                                       "diffuse_texture",
                                       "emission_texture",
                                       "roughness_texture",
                                       "roughness_channel",
                                       NULL};
    char p[LR__PATH_MAX];
    lr_status st;
    size_t n = 1; /* slot 0 is the default material */
    if (mats != NULL)
        LR_TRY(lr__json_object(mats, "materials", " of named materials", err));
    if (mats != NULL)
        n += (size_t)cJSON_GetArraySize(mats);
    s->materials = calloc(n, sizeof *s->materials);
    if (s->materials == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");

    /* Objects without a material are a matte grey. */
    lr__material *def = &s->materials[0];
    def->name = strdup("(default)");
    if (def->name == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    def->diffuse = v3(0.8, 0.8, 0.8);
    def->ior = 1.5;
    s->n_materials = 1;
    if (mats == NULL)
        return LR_OK;

    /* Any name is allowed; only duplicates are errors. */
    for (const cJSON *m = mats->child; m; m = m->next) {
        lr__path_key(p, "materials", m->string);
        for (const cJSON *d = m->next; d; d = d->next)
            if (strcmp(d->string, m->string) == 0)
                return lr__fail(err, LR_ERR_INVALID, p,
                                "%s: duplicate material name", p);
        LR_TRY(lr__json_object(m, p, "", err));
        st = lr__json_check_keys(m, p, keys, err);
        if (st != LR_OK)
            return st;
        lr__material *mt = &s->materials[s->n_materials];
        mt->name = strdup(m->string);
        if (mt->name == NULL)
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        s->n_materials++;
        mt->ior = 1.5;
        LR_TRY(lr__json_rgb(m, "diffuse", p, 0, &mt->diffuse, err));
        LR_TRY(lr__json_rgb(m, "specular", p, 0, &mt->specular, err));
        LR_TRY(lr__json_number(m, "shininess", p, 0, &mt->shininess, err));
        LR_TRY(lr__json_rgb(m, "reflect", p, 0, &mt->reflect, err));
        LR_TRY(lr__json_rgb(m, "transmit", p, 0, &mt->transmit, err));
        LR_TRY(lr__json_number(m, "ior", p, 0, &mt->ior, err));
        LR_TRY(lr__json_rgb(m, "emission", p, 0, &mt->emission, err));
        LR_TRY(lr__json_number(m, "roughness", p, 0, &mt->roughness, err));
        int given =
            (cJSON_HasObjectItem(m, "diffuse") ? LR__GIVEN_DIFFUSE : 0) |
            (cJSON_HasObjectItem(m, "emission") ? LR__GIVEN_EMISSION : 0) |
            (cJSON_HasObjectItem(m, "roughness") ? LR__GIVEN_ROUGHNESS : 0);
        LR_TRY(lr__material_textures_json(s, mt, m, p, base_dir, given, err));
        char q[LR__PATH_MAX];
        if (!(mt->roughness >= 0.0 && mt->roughness <= 1.0)) {
            lr__path_key(q, p, "roughness");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be between 0 and 1, got %g", q,
                            mt->roughness);
        }
        if (mt->shininess < 0 || mt->shininess > 1e6) {
            lr__path_key(q, p, "shininess");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be between 0 and 1e6, got %g", q,
                            mt->shininess);
        }
        if (mt->ior < 1.0 || mt->ior > 10.0) {
            lr__path_key(q, p, "ior");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be between 1 and 10, got %g", q, mt->ior);
        }
    }
    return LR_OK;
}

/* ---- lights ----------------------------------------------------------- */

static lr_status parse_lights(lr_scene *s, const cJSON *lights, lr_error *err)
{
    static const char *const keys_point[] = {"type", "position", "intensity",
                                             NULL};
    static const char *const keys_dir[] = {"type", "direction", "irradiance",
                                           NULL};
    static const char *const keys_amb[] = {"type", "radiance", NULL};
    static const char *const keys_spot[] = {
        "type",        "position",    "direction", "intensity",
        "inner_angle", "outer_angle", NULL};
    char p[LR__PATH_MAX];
    if (lights == NULL)
        return LR_OK;
    if (!cJSON_IsArray(lights))
        return lr__fail(err, LR_ERR_INVALID, "lights",
                        "lights must be an array");
    size_t n = (size_t)cJSON_GetArraySize(lights);
    s->lights = calloc(n ? n : 1, sizeof *s->lights);
    if (s->lights == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    size_t i = 0;
    for (const cJSON *l = lights->child; l; l = l->next, i++) {
        lr__path_index(p, "lights", i);
        LR_TRY(lr__json_object(l, p, "", err));
        const char *type = NULL;
        LR_TRY(lr__json_string(l, "type", p, 1, &type, err));
        if (strcmp(type, "point") == 0) {
            lr__light *L = &s->lights[s->n_lights];
            L->kind = LR__LIGHT_POINT;
            LR_TRY(lr__json_check_keys(l, p, keys_point, err));
            LR_TRY(lr__json_vec3(l, "position", p, 1, &L->position, err));
            LR_TRY(lr__json_rgb(l, "intensity", p, 1, &L->power, err));
            s->n_lights++;
        } else if (strcmp(type, "directional") == 0) {
            lr__light *L = &s->lights[s->n_lights];
            L->kind = LR__LIGHT_DIRECTIONAL;
            LR_TRY(lr__json_check_keys(l, p, keys_dir, err));
            LR_TRY(lr__json_vec3(l, "direction", p, 1, &L->direction, err));
            LR_TRY(lr__json_rgb(l, "irradiance", p, 1, &L->power, err));
            if (v3_len(L->direction) == 0.0) {
                char q[LR__PATH_MAX];
                lr__path_key(q, p, "direction");
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must not be the zero vector", q);
            }
            L->direction = v3_norm(L->direction);
            s->n_lights++;
        } else if (strcmp(type, "spot") == 0) {
            lr__light *L = &s->lights[s->n_lights];
            L->kind = LR__LIGHT_POINT;
            LR_TRY(lr__json_check_keys(l, p, keys_spot, err));
            LR_TRY(lr__json_vec3(l, "position", p, 1, &L->position, err));
            LR_TRY(lr__json_rgb(l, "intensity", p, 1, &L->power, err));
            lr__v3 dir = v3(0, -1, 0);
            LR_TRY(lr__json_vec3(l, "direction", p, 1, &dir, err));
            /* glTF's defaults (KHR_lights_punctual): 0 and 45 degrees. */
            double inner = 0, outer = 45;
            LR_TRY(lr__json_number(l, "inner_angle", p, 0, &inner, err));
            LR_TRY(lr__json_number(l, "outer_angle", p, 0, &outer, err));
            char q[LR__PATH_MAX];
            if (v3_len(dir) == 0.0) {
                lr__path_key(q, p, "direction");
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must not be the zero vector", q);
            }
            if (!(outer > 0 && outer <= 90)) {
                lr__path_key(q, p, "outer_angle");
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must be more than 0 and at most 90 "
                                "(degrees off the axis), got %g",
                                q, outer);
            }
            if (!(inner >= 0 && inner < outer)) {
                lr__path_key(q, p, "inner_angle");
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must be at least 0 and less than "
                                "outer_angle (%g), got %g",
                                q, outer, inner);
            }
            lr__spot_set(L, dir, inner * M_PI / 180, outer * M_PI / 180);
            s->n_lights++;
        } else if (strcmp(type, "ambient") == 0) {
            lr__v3 r = v3(0, 0, 0);
            LR_TRY(lr__json_check_keys(l, p, keys_amb, err));
            LR_TRY(lr__json_rgb(l, "radiance", p, 1, &r, err));
            s->ambient = v3_add(s->ambient, r);
            if (s->ambient_at < 0)
                s->ambient_at = (int)i;
        } else {
            char q[LR__PATH_MAX];
            lr__path_key(q, p, "type");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be \"point\", \"spot\", "
                            "\"directional\" or \"ambient\", got \"%s\"",
                            q, type);
        }
    }
    return LR_OK;
}

/* ---- the environment -------------------------------------------------- */

/* "accel": {"robust": true|false}: Embree's robust traversal, on unless
 * the scene turns it off (lr__scene_begin; docs/scene-format.md has what
 * each costs and changes). */
static lr_status parse_accel(lr_scene *s, const cJSON *a, lr_error *err)
{
    static const char *const keys[] = {"robust", NULL};
    if (a == NULL)
        return LR_OK;
    LR_TRY(lr__json_object(a, "accel", " {\"robust\": true|false}", err));
    LR_TRY(lr__json_check_keys(a, "accel", keys, err));
    int robust = 1;
    LR_TRY(lr__json_bool(a, "robust", "accel", 0, &robust, err));
    s->not_robust = !robust;
    return LR_OK;
}

/* "environment": {"file", "intensity", "rotation_deg"}: a lat-long EXR
 * (envmap.h) relative to the scene's directory. */
static lr_status parse_environment(lr_scene *s, const cJSON *e,
                                   const char *base_dir, lr_error *err)
{
    static const char *const keys[] = {"file", "intensity", "rotation_deg",
                                       NULL};
    const char *p = "environment";
    if (e == NULL)
        return LR_OK;
    LR_TRY(lr__json_object(e, p, " {\"file\", \"intensity\", \"rotation_deg\"}",
                           err));
    LR_TRY(lr__json_check_keys(e, p, keys, err));
    const char *file = NULL;
    double intensity = 1.0, rot = 0.0;
    LR_TRY(lr__json_string(e, "file", p, 1, &file, err));
    LR_TRY(lr__json_number(e, "intensity", p, 0, &intensity, err));
    LR_TRY(lr__json_number(e, "rotation_deg", p, 0, &rot, err));
    if (!(intensity >= 0.0 && intensity <= 1e12))
        return lr__fail(err, LR_ERR_INVALID, "environment.intensity",
                        "environment.intensity must be between 0 and 1e12, "
                        "got %g",
                        intensity);
    if (!(fabs(rot) <= 1e6))
        return lr__fail(err, LR_ERR_INVALID, "environment.rotation_deg",
                        "environment.rotation_deg must be between -1e6 and "
                        "1e6, got %g",
                        rot);
    char full[4096];
    LR_TRY(lr__scene_file(file, base_dir, "environment.file", full, sizeof full,
                          err));
    lr__texel_room_begin(s);
    lr_status st = lr__envmap_load(full, file, "environment.file", intensity,
                                   rot, &s->env, err);
    lr__texel_room_end();
    if (st == LR_OK)
        s->limit_texels += (uint64_t)s->env->w * (uint64_t)s->env->h;
    return st;
}

/* ---- the scene -------------------------------------------------------- */

/* A scene's head, as build() and lr_scene_read_settings read it, in the
 * order of docs/scene-format.md: the top-level keys, the description
 * (*desc points into root, NULL when there is none), the camera over its
 * defaults (its files relative to base_dir, NULL: ".") and the render
 * settings over theirs. */
static lr_status read_head(const cJSON *root, const char *base_dir,
                           lr__render_reader rd, const char **desc,
                           lr_camera *cam, lr_render_settings *rs,
                           lr_error *err)
{
    /* docs/scene-format.md, section 5. */
    static const char *const keys[] = {
        "description", "camera",  "render",      "background", "materials",
        "lights",      "objects", "environment", "accel",      NULL};
    if (!cJSON_IsObject(root))
        return lr__fail(err, LR_ERR_INVALID, "",
                        "a scene must be a JSON object");
    LR_TRY(lr__json_check_keys(root, "", keys, err));
    *desc = NULL;
    LR_TRY(lr__json_string(root, "description", "", 0, desc, err));
    lr_camera_default(cam);
    lr_render_settings_default(rs);
    LR_TRY(
        lr__camera_from_json(cJSON_GetObjectItemCaseSensitive(root, "camera"),
                             cam, base_dir ? base_dir : ".", err));
    return rd(cJSON_GetObjectItemCaseSensitive(root, "render"), rs, err);
}

static lr_status build(lr_scene *s, const cJSON *root, const char *base_dir,
                       lr__render_reader rd, lr_error *err)
{
    const char *desc;
    LR_TRY(read_head(root, base_dir, rd, &desc, &s->camera, &s->settings, err));
    s->description = strdup(desc ? desc : "");
    if (s->description == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    LR_TRY(lr__json_rgb(root, "background", "", 0, &s->background, err));
    LR_TRY(parse_environment(
        s, cJSON_GetObjectItemCaseSensitive(root, "environment"), base_dir,
        err));
    LR_TRY(parse_materials(
        s, cJSON_GetObjectItemCaseSensitive(root, "materials"), base_dir, err));
    LR_TRY(
        parse_lights(s, cJSON_GetObjectItemCaseSensitive(root, "lights"), err));
    LR_TRY(
        parse_accel(s, cJSON_GetObjectItemCaseSensitive(root, "accel"), err));
    LR_TRY(lr__scene_begin(s, err));
    /* A glTF camera's aspect ratio sets the height the scene left out. */
    int height_given = cJSON_GetObjectItemCaseSensitive(
                           cJSON_GetObjectItemCaseSensitive(root, "render"),
                           "height") != NULL;
    LR_TRY(lr__scene_parse_objects(
        s, cJSON_GetObjectItemCaseSensitive(root, "objects"), base_dir,
        height_given, err));
    LR_TRY(lr__scene_commit(s, err));
    return LR_OK;
}

/* The scene JSON of `len` bytes parsed, with the overrides applied: the
 * first step of both loaders below.  *root is the caller's to delete. */
static lr_status parse_scene(const char *json, size_t len,
                             const char *const *overrides, size_t n_overrides,
                             cJSON **root, lr_error *err)
{
    if (len > MAX_SCENE_BYTES)
        return lr__fail(err, LR_ERR_LIMIT, NULL,
                        "scene JSON is %zu bytes, more than the limit of %u",
                        len, MAX_SCENE_BYTES);
    *root = NULL;
    LR_TRY(lr__json_parse(json ? json : "", len, "scene", "", root, err));
    for (size_t i = 0; i < n_overrides; i++) {
        lr_status st = lr__json_apply_override(*root, overrides[i], err);
        if (st != LR_OK) {
            cJSON_Delete(*root);
            *root = NULL;
            return st;
        }
    }
    return LR_OK;
}

/* A glTF's camera ("camera": true) replaced the scene's view, field and
 * focus after the overrides had been read into the scene's camera: the
 * overrides of camera keys go on top again, so that --set camera.fov=20
 * wins over the file as on any scene (it was ignored, silently). */
static lr_status camera_overrides_again(lr_scene *s,
                                        const char *const *overrides, size_t n,
                                        const char *base_dir, lr_error *err)
{
    cJSON *tmp = cJSON_CreateObject();
    if (tmp == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    lr_status st = LR_OK;
    for (size_t i = 0; i < n && st == LR_OK; i++)
        if (strncmp(overrides[i], "camera.", 7) == 0 ||
            strncmp(overrides[i], "camera=", 7) == 0)
            st = lr__json_apply_override(tmp, overrides[i], err);
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(tmp, "camera");
    if (st == LR_OK && c != NULL) {
        lr_camera cam = s->camera;
        st = lr__camera_from_json(c, &cam, base_dir, err);
        if (st == LR_OK)
            s->camera = cam;
    }
    cJSON_Delete(tmp);
    return st;
}

lr_status lr__scene_load_json(const char *json, size_t len,
                              const char *base_dir,
                              const char *const *overrides, size_t n_overrides,
                              lr__render_reader rd, lr_scene **out,
                              lr_error *err)
{
    if (out == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_scene_load_json: NULL argument");
    *out = NULL;
    cJSON *root = NULL;
    LR_TRY(parse_scene(json, len, overrides, n_overrides, &root, err));
    lr_scene *s = calloc(1, sizeof *s);
    if (s == NULL) {
        cJSON_Delete(root);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    s->ambient_at = -1;
    /* Every file read from here on is one the scene was loaded from. */
    lr__file_log_begin(&s->files);
    lr_status st = build(s, root, base_dir, rd, err);
    cJSON_Delete(root);
    if (st == LR_OK && s->camera_gltf && n_overrides > 0)
        st = camera_overrides_again(s, overrides, n_overrides, base_dir, err);
    lr__file_log_end();
    if (st != LR_OK) {
        lr_scene_free(s);
        return st;
    }
    *out = s;
    return LR_OK;
}

/* Whether some object of the scene is a glTF file whose camera the scene
 * takes: that camera, and the height its aspect sets, come from the file. */
static int takes_gltf_camera(const cJSON *root)
{
    const cJSON *o;
    cJSON_ArrayForEach(o, cJSON_GetObjectItemCaseSensitive(root, "objects"))
    {
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(o, "type");
        const cJSON *c = cJSON_GetObjectItemCaseSensitive(o, "camera");
        if (cJSON_IsString(t) && strcmp(t->valuestring, "gltf") == 0 &&
            c != NULL && !cJSON_IsFalse(c))
            return 1;
    }
    return 0;
}

/* Names the file in JSON syntax errors, which only say "scene". */
static void name_file(const char *path, lr_status st, lr_error *err)
{
    if (st == LR_ERR_INVALID && err != NULL &&
        strncmp(err->message, "scene: ", 7) == 0) {
        char msg[sizeof err->message];
        snprintf(msg, sizeof msg, "%s: %s", path, err->message + 7);
        snprintf(err->message, sizeof err->message, "%s", msg);
    }
}

/* The whole scene loaded, for its camera and settings. */
static lr_status settings_of_loaded(const char *path,
                                    const char *const *overrides,
                                    size_t n_overrides, lr__render_reader rd,
                                    lr_camera *cam, lr_render_settings *rs,
                                    lr_error *err)
{
    lr_scene *s = NULL;
    LR_TRY(lr__scene_load_file(path, overrides, n_overrides, rd, &s, err));
    lr_scene_camera(s, cam);
    lr_scene_settings(s, rs);
    lr_scene_free(s);
    return LR_OK;
}

lr_status lr__scene_read_settings(const char *path,
                                  const char *const *overrides,
                                  size_t n_overrides, lr__render_reader rd,
                                  lr_camera *cam, lr_render_settings *rs,
                                  lr_error *err)
{
    if (path == NULL || cam == NULL || rs == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_scene_read_settings: NULL argument");
    if (lr__gltf_is_file(path))
        return settings_of_loaded(path, overrides, n_overrides, rd, cam, rs,
                                  err);
    char *buf = NULL;
    size_t len = 0;
    LR_TRY(lr__read_file(path, path, NULL, MAX_SCENE_BYTES, "scene files", NULL,
                         &buf, &len, err));
    cJSON *root = NULL;
    lr_status st = parse_scene(buf, len, overrides, n_overrides, &root, err);
    free(buf);
    if (st != LR_OK) {
        name_file(path, st, err);
        return st;
    }
    if (takes_gltf_camera(root)) {
        cJSON_Delete(root);
        return settings_of_loaded(path, overrides, n_overrides, rd, cam, rs,
                                  err);
    }
    char dir[4096];
    lr__dir_of(path, dir, sizeof dir);
    const char *desc;
    lr_camera c;
    lr_render_settings r;
    st = read_head(root, dir, rd, &desc, &c, &r, err);
    cJSON_Delete(root);
    if (st != LR_OK)
        return st;
    *cam = c;
    *rs = r;
    return LR_OK;
}

lr_status lr__scene_load_file(const char *path, const char *const *overrides,
                              size_t n_overrides, lr__render_reader rd,
                              lr_scene **out, lr_error *err)
{
    if (path == NULL || out == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_scene_load_file: NULL argument");
    *out = NULL;
    if (lr__gltf_is_file(path))
        return lr__gltf_scene_load(path, overrides, n_overrides, rd, out, err);
    char *buf = NULL;
    size_t len = 0;
    lr_status st = lr__read_file(path, path, NULL, MAX_SCENE_BYTES,
                                 "scene files", NULL, &buf, &len, err);
    if (st != LR_OK)
        return st;
    /* Mesh paths are relative to the scene file's directory. */
    char dir[4096];
    lr__dir_of(path, dir, sizeof dir);
    st = lr__scene_load_json(buf ? buf : "", len, dir, overrides, n_overrides,
                             rd, out, err);
    free(buf);
    name_file(path, st, err);
    return st;
}
