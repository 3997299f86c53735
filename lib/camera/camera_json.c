/*
 * camera_json.c: the scene format's "camera" object -> lr_camera, and
 * lr_camera_apply_json.  Every key is one row of a table (lr__camera_key):
 * the keys every camera takes and the lens keys here, each model's own in
 * that model's file (camera_*.c).
 */
#include "json/apply_json.h"
#include "camera/camera.h"
#include "camera/camera_json.h"
#include "optics/lens_load.h"
#include "json/json_util.h"

#include <math.h>
#include <stdio.h>
#include <stddef.h>
#include <string.h>

/* ---- camera.chromatic ------------------------------------------------- */

static lr_status parse_chromatic(const cJSON *c, lr_camera *cam, lr_error *err)
{
    static const char *const keys[] = {"mode",        "focal_model", "ior",
                                       "glass",       "abbe",        "amplify",
                                       "wavelengths", "splat",       NULL};
    static const char *const abbe_keys[] = {"n_d", "V_d", NULL};
    const char *path = "camera.chromatic";
    lr_chromatic *ch = &cam->chromatic;
    LR_TRY(lr__json_object(c, path, "", err));
    LR_TRY(lr__json_check_keys(c, path, keys, err));
    int mode = (int)ch->mode, model = (int)ch->focal_model;
    LR_TRY(lr__json_enum(c, "mode", path, lr__chroma_mode_names, &mode, err));
    LR_TRY(lr__json_enum(c, "focal_model", path, lr__focal_model_names, &model,
                         err));
    ch->mode = (lr_chromatic_mode)mode;
    ch->focal_model = (lr_focal_model)model;
    lr__v3 ior = v3a(ch->ior);
    LR_TRY(lr__json_vec3(c, "ior", path, 0, &ior, err));
    ch->ior[0] = ior.x, ch->ior[1] = ior.y, ch->ior[2] = ior.z;
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(c, "glass");
    const cJSON *abbe = cJSON_GetObjectItemCaseSensitive(c, "abbe");
    if (g != NULL && abbe != NULL)
        return lr__fail(err, LR_ERR_INVALID, "camera.chromatic",
                        "camera.chromatic: give either glass or abbe, not "
                        "both");
    if (g != NULL) {
        /* "N-BK7" and "N-SF11" are accepted as Schott's full names (the
         * coefficients of "SF11" are N-SF11's, lens.c). */
        if (cJSON_IsString(g) && strcmp(g->valuestring, "N-BK7") == 0) {
            ch->glass = LR_GLASS_BK7;
        } else if (cJSON_IsString(g) && strcmp(g->valuestring, "N-SF11") == 0) {
            ch->glass = LR_GLASS_SF11;
        } else {
            int gi = (int)ch->glass;
            LR_TRY(lr__json_enum(c, "glass", path, lr__glass_names, &gi, err));
            ch->glass = (lr_glass)gi;
        }
    }
    if (abbe != NULL) {
        const char *ap = "camera.chromatic.abbe";
        LR_TRY(lr__json_object(abbe, ap, " {\"n_d\": 1.5168, \"V_d\": 64.17}",
                               err));
        LR_TRY(lr__json_check_keys(abbe, ap, abbe_keys, err));
        LR_TRY(lr__json_number(abbe, "n_d", ap, 1, &ch->abbe_nd, err));
        LR_TRY(lr__json_number(abbe, "V_d", ap, 1, &ch->abbe_vd, err));
        ch->glass = LR_GLASS_ABBE;
    }
    LR_TRY(lr__json_number(c, "amplify", path, 0, &ch->amplify, err));
    long long nw = ch->wavelengths;
    LR_TRY(lr__json_int(c, "wavelengths", path, 0, 1, 64, &nw, err));
    ch->wavelengths = (int)nw;
    LR_TRY(lr__json_bool(c, "splat", path, 0, &ch->splat, err));
    return LR_OK;
}

/* ---- camera.focus_on -------------------------------------------------- */

/* A pixel [x, y] to autofocus on, or null for none. */
static lr_status parse_focus_on(const cJSON *fo, lr_camera *cam, lr_error *err)
{
    if (cJSON_IsNull(fo)) {
        cam->focus_on[0] = cam->focus_on[1] = -1;
        return LR_OK;
    }
    if (!cJSON_IsArray(fo) || cJSON_GetArraySize(fo) != 2 ||
        !cJSON_IsNumber(fo->child) || !cJSON_IsNumber(fo->child->next))
        return lr__fail(err, LR_ERR_INVALID, "camera.focus_on",
                        "camera.focus_on must be a pixel [x, y] (or null)");
    for (int i = 0; i < 2; i++) {
        double v = cJSON_GetArrayItem(fo, i)->valuedouble;
        if (!(v >= 0 && v <= 65535 && v == floor(v)))
            return lr__fail(err, LR_ERR_INVALID, "camera.focus_on",
                            "camera.focus_on[%d] must be a pixel index, a "
                            "whole number from 0 to 65535, got %g",
                            i, v);
        cam->focus_on[i] = (int)v;
    }
    return LR_OK;
}

/* ---- camera.ghosts ---------------------------------------------------- */

static lr_status parse_ghosts(const cJSON *v, lr_camera *cam, lr_error *err)
{
    if (cJSON_IsBool(v)) {
        cam->ghosts = cJSON_IsTrue(v) ? LR_GHOSTS_ON : LR_GHOSTS_OFF;
        return LR_OK;
    }
    if (cJSON_IsString(v) && strcmp(v->valuestring, "auto") == 0) {
        cam->ghosts = LR_GHOSTS_AUTO;
        return LR_OK;
    }
    char desc[96];
    lr__json_describe(v, desc, sizeof desc);
    return lr__fail(err, LR_ERR_INVALID, "camera.ghosts",
                    "camera.ghosts must be \"auto\", true or false, got %s",
                    desc);
}

/* ---- the key table ---------------------------------------------------- */

/* camera.model: a name in the registry of camera models (camera.c). */
static lr_status parse_model(const cJSON *c, lr_camera *cam, lr_error *err)
{
    const char *names[16];
    int n = 0;
    for (; lr__camera_models[n] != NULL && n < 15; n++)
        names[n] = lr__camera_models[n]->name;
    names[n] = NULL;
    int i = (int)cam->model < n ? (int)cam->model : -1;
    LR_TRY(lr__json_enum(c, "model", "camera", names, &i, err));
    if (i >= 0)
        cam->model = (lr_camera_model)i;
    return LR_OK;
}

#define AT(field) offsetof(lr_camera, field)

/* The keys every camera takes, before the models' own. */
static const lr__camera_key common_keys[] = {
    {"model", LR__KEY_CUSTOM, AT(model), NULL, 0, 0, 0.0},
    {"position", LR__KEY_VEC3, AT(position), NULL, 0, 0, 0.0},
    {"look_at", LR__KEY_VEC3, AT(look_at), NULL, 0, 0, 0.0},
    {"up", LR__KEY_VEC3, AT(up), NULL, 0, 0, 0.0},
    {"fov", LR__KEY_NUMBER, AT(fov), NULL, 0, 0, 0.0},
    {NULL, 0, 0, NULL, 0, 0, 0.0},
};

/* And after them, the keys of models with a lens (lr__camera_model.lens):
 * autofocus and chromatic aberration. */
static const lr__camera_key lens_keys[] = {
    {"focus_on", LR__KEY_CUSTOM, AT(focus_on), NULL, 0, 0, 0.0},
    {"chromatic", LR__KEY_CUSTOM, AT(chromatic), NULL, 0, 0, 0.0},
    {NULL, 0, 0, NULL, 0, 0, 0.0},
};

/* A model's LR__KEY_PARAM key: a number in [min, max] (both 0: any
 * finite number), in the model's block of cam->model_params. */
static lr_status read_param(const cJSON *c, const lr__camera_key *k,
                            const lr__camera_model *m, lr_camera *cam,
                            lr_error *err)
{
    int at = lr__camera_param_base(m) + (int)k->offset;
    if (at >= LR_CAMERA_MODEL_PARAMS)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "camera.%s: model %s's parameters do not fit in "
                        "LR_CAMERA_MODEL_PARAMS",
                        k->name, m->name);
    double v = cam->model_params[at];
    LR_TRY(lr__json_number(c, k->name, "camera", 0, &v, err));
    if ((k->min != 0 || k->max != 0) && !(v >= k->min && v <= k->max)) {
        char path[80];
        snprintf(path, sizeof path, "camera.%s", k->name);
        return lr__fail(err, LR_ERR_INVALID, path,
                        "camera.%s must be from %lld to %lld, got %g", k->name,
                        k->min, k->max, v);
    }
    cam->model_params[at] = v;
    return LR_OK;
}

static lr_status read_key(const cJSON *c, const lr__camera_key *k,
                          const lr__camera_model *m, lr_camera *cam,
                          const char *base_dir, lr_error *err)
{
    void *field = (char *)cam + k->offset;
    switch (k->type) {
    case LR__KEY_PARAM:
        return read_param(c, k, m, cam, err);
    case LR__KEY_NUMBER:
        return lr__json_number(c, k->name, "camera", 0, field, err);
    case LR__KEY_INT: {
        int *f = field;
        long long v = *f;
        LR_TRY(lr__json_int(c, k->name, "camera", 0, k->min, k->max, &v, err));
        *f = (int)v;
        return LR_OK;
    }
    case LR__KEY_VEC3: {
        double *f = field;
        lr__v3 v = v3a(f);
        LR_TRY(lr__json_vec3(c, k->name, "camera", 0, &v, err));
        f[0] = v.x, f[1] = v.y, f[2] = v.z;
        return LR_OK;
    }
    case LR__KEY_ENUM:
        return lr__json_enum(c, k->name, "camera", k->names, field, err);
    case LR__KEY_CUSTOM: {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(c, k->name);
        if (v == NULL)
            return LR_OK;
        if (strcmp(k->name, "model") == 0)
            return parse_model(c, cam, err);
        if (strcmp(k->name, "focus_on") == 0)
            return parse_focus_on(v, cam, err);
        if (strcmp(k->name, "ghosts") == 0)
            return parse_ghosts(v, cam, err);
        if (strcmp(k->name, "lens") == 0)
            return lr__lens_from_json(v, "camera.lens", base_dir, &cam->lens,
                                      err);
        return parse_chromatic(v, cam, err);
    }
    }
    return lr__fail(err, LR_ERR_INVALID, NULL, "camera.%s: unknown key type",
                    k->name);
}

/* Every key, in the order they are read (which decides which error comes
 * first) and listed in "unknown key" errors: the common keys, each
 * model's in registry order, the lens keys; owner[i]: the model whose
 * table holds out[i] (NULL for the common and lens keys). */
#define MAX_KEYS 64
static size_t all_keys(const lr__camera_key **out,
                       const lr__camera_model **owner)
{
    size_t n = 0;
    for (const lr__camera_key *k = common_keys; k->name != NULL; k++)
        owner[n] = NULL, out[n++] = k;
    for (int m = 0; lr__camera_models[m] != NULL; m++)
        for (const lr__camera_key *k = lr__camera_models[m]->keys;
             k->name != NULL && n < MAX_KEYS - 3; k++) {
            /* Models may share a key (focus_distance): read it once. */
            size_t seen = 0;
            while (seen < n && strcmp(out[seen]->name, k->name) != 0)
                seen++;
            if (seen == n)
                owner[n] = lr__camera_models[m], out[n++] = k;
        }
    for (const lr__camera_key *k = lens_keys; k->name != NULL; k++)
        owner[n] = NULL, out[n++] = k;
    return n;
}

lr_status lr__camera_from_json(const cJSON *c, lr_camera *cam,
                               const char *base_dir, lr_error *err)
{
    const lr__camera_key *keys[MAX_KEYS];
    const lr__camera_model *owner[MAX_KEYS];
    const char *names[MAX_KEYS + 1];
    if (c == NULL)
        return LR_OK;
    LR_TRY(lr__json_object(c, "camera", "", err));
    size_t n = all_keys(keys, owner);
    for (size_t i = 0; i < n; i++)
        names[i] = keys[i]->name;
    names[n] = NULL;
    LR_TRY(lr__json_check_keys(c, "camera", names, err));
    for (size_t i = 0; i < n; i++)
        LR_TRY(read_key(c, keys[i], owner[i], cam, base_dir, err));
    return lr_camera_validate(cam, err);
}

lr_status lr_camera_apply_json(lr_camera *cam, const char *json, size_t len,
                               lr_error *err)
{
    if (cam == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_camera_apply_json: NULL argument");
    cJSON *root = NULL;
    LR_TRY(
        lr__json_parse(json ? json : "", len, "camera", "camera", &root, err));
    lr_status st = lr__camera_apply_cjson(cam, root, err);
    cJSON_Delete(root);
    return st;
}

lr_status lr__camera_apply_cjson(lr_camera *cam, const cJSON *obj,
                                 lr_error *err)
{
    lr_camera tmp = *cam;
    lr_status st = lr__camera_from_json(obj, &tmp, NULL, err);
    if (st == LR_OK)
        *cam = tmp;
    return st;
}
