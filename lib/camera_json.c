/*
 * camera_json.c: the scene format's "camera" object -> lr_camera, and
 * lr_camera_apply_json.  Every key the camera takes is one row of
 * camera_keys[] below: its name, how it is read, the lr_camera field it
 * fills and the models that read it, so that a model's keys can move to
 * that model's own file as a block of rows.
 */
#include "camera_json.h"
#include "json_util.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

/* ---- camera.chromatic ------------------------------------------------- */

static lr_status parse_chromatic(const cJSON *c, lr_camera *cam,
                                 lr_error *err)
{
    static const char *const keys[] = {"mode",     "focal_model", "ior",
                                       "glass",    "abbe",        "amplify",
                                       "wavelengths", NULL};
    static const char *const modes[] = {"off", "rgb", "spectral", NULL};
    static const char *const models[] = {"paper", "lensmaker", NULL};
    /* Indexed by lr_glass; "N-BK7" is accepted as Schott's full name. */
    static const char *const glasses[] = {"BK7", "F2", "SF11",
                                          "fused_silica", NULL};
    static const char *const abbe_keys[] = {"n_d", "V_d", NULL};
    const char *path = "camera.chromatic";
    lr_chromatic *ch = &cam->chromatic;
    if (!cJSON_IsObject(c))
        return lr__fail(err, LR_ERR_INVALID, path,
                        "%s must be an object", path);
    LR_TRY(lr__json_check_keys(c, path, keys, err));
    int mode = (int)ch->mode, model = (int)ch->focal_model;
    LR_TRY(lr__json_enum(c, "mode", path, modes, &mode, err));
    LR_TRY(lr__json_enum(c, "focal_model", path, models, &model, err));
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
        if (cJSON_IsString(g) && strcmp(g->valuestring, "N-BK7") == 0) {
            ch->glass = LR_GLASS_BK7;
        } else {
            int gi = (int)ch->glass;
            LR_TRY(lr__json_enum(c, "glass", path, glasses, &gi, err));
            ch->glass = (lr_glass)gi;
        }
    }
    if (abbe != NULL) {
        const char *ap = "camera.chromatic.abbe";
        if (!cJSON_IsObject(abbe))
            return lr__fail(err, LR_ERR_INVALID, ap,
                            "%s must be an object {\"n_d\": 1.5168, "
                            "\"V_d\": 64.17}",
                            ap);
        LR_TRY(lr__json_check_keys(abbe, ap, abbe_keys, err));
        LR_TRY(lr__json_number(abbe, "n_d", ap, 1, &ch->abbe_nd, err));
        LR_TRY(lr__json_number(abbe, "V_d", ap, 1, &ch->abbe_vd, err));
        ch->glass = LR_GLASS_ABBE;
    }
    LR_TRY(lr__json_number(c, "amplify", path, 0, &ch->amplify, err));
    long long nw = ch->wavelengths;
    LR_TRY(lr__json_int(c, "wavelengths", path, 0, 1, 64, &nw, err));
    ch->wavelengths = (int)nw;
    return LR_OK;
}

/* ---- camera.focus_on -------------------------------------------------- */

/* A pixel [x, y] to autofocus on, or null for none. */
static lr_status parse_focus_on(const cJSON *fo, lr_camera *cam,
                                lr_error *err)
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
                            "camera.focus_on[%d] must be a whole pixel "
                            "index >= 0, got %g",
                            i, v);
        cam->focus_on[i] = (int)v;
    }
    return LR_OK;
}

/* ---- the key table ---------------------------------------------------- */

typedef enum key_type {
    KEY_NUMBER, /* double: a number within +-LR__MAX_NUMBER */
    KEY_INT,    /* int: a whole number in [min, max] */
    KEY_VEC3,   /* double[3]: three such numbers */
    KEY_ENUM,   /* an enum: one of `names`, stored as its index */
    KEY_OBJECT  /* anything else: read by `parse` */
} key_type;

/* Which models read a key (the others accept it and ignore it). */
#define M_PINHOLE (1u << LR_CAMERA_PINHOLE)
#define M_THINLENS (1u << LR_CAMERA_THINLENS)
#define M_BRACKET (1u << LR_CAMERA_BRACKET)
#define M_ALL (M_PINHOLE | M_THINLENS | M_BRACKET)

typedef struct camera_key {
    const char *name;
    key_type type;
    size_t offset;   /* of the field in lr_camera */
    unsigned models; /* M_* bits */
    const char *const *names; /* KEY_ENUM: indexed by the enum's value */
    long long min, max;       /* KEY_INT */
    lr_status (*parse)(const cJSON *v, lr_camera *cam, lr_error *err);
} camera_key;

/* Indexed by lr_camera_model and lr_aperture_shape. */
static const char *const model_names[] = {"pinhole", "thinlens", "bracket",
                                          NULL};
static const char *const shape_names[] = {"disk", "square", "polygon", NULL};

_Static_assert(sizeof(lr_camera_model) == sizeof(int) &&
                   sizeof(lr_aperture_shape) == sizeof(int),
               "KEY_ENUM fields are stored as int");

#define AT(field) offsetof(lr_camera, field)

/* In the order the keys are read, which decides which error comes first,
 * and listed in "unknown key" errors. */
static const camera_key camera_keys[] = {
    {"model", KEY_ENUM, AT(model), M_ALL, model_names, 0, 0, NULL},
    {"position", KEY_VEC3, AT(position), M_ALL, NULL, 0, 0, NULL},
    {"look_at", KEY_VEC3, AT(look_at), M_ALL, NULL, 0, 0, NULL},
    {"up", KEY_VEC3, AT(up), M_ALL, NULL, 0, 0, NULL},
    {"fov", KEY_NUMBER, AT(fov), M_ALL, NULL, 0, 0, NULL},
    /* thin lens */
    {"focus_distance", KEY_NUMBER, AT(focus_distance), M_THINLENS, NULL, 0, 0,
     NULL},
    {"aperture_radius", KEY_NUMBER, AT(aperture_radius), M_THINLENS, NULL, 0,
     0, NULL},
    {"f_number", KEY_NUMBER, AT(f_number), M_THINLENS, NULL, 0, 0, NULL},
    {"focal_length_mm", KEY_NUMBER, AT(focal_length_mm), M_THINLENS, NULL, 0,
     0, NULL},
    {"aperture_shape", KEY_ENUM, AT(aperture_shape), M_THINLENS, shape_names,
     0, 0, NULL},
    {"aperture_blades", KEY_INT, AT(aperture_blades), M_THINLENS, NULL, 3, 64,
     NULL},
    {"aperture_rotation", KEY_NUMBER, AT(aperture_rotation), M_THINLENS, NULL,
     0, 0, NULL},
    {"aperture_ratio", KEY_NUMBER, AT(aperture_ratio), M_THINLENS, NULL, 0, 0,
     NULL},
    /* autofocus sets the thin lens's focus_distance, the bracket's
     * focal_length */
    {"focus_on", KEY_OBJECT, AT(focus_on), M_THINLENS | M_BRACKET, NULL, 0, 0,
     parse_focus_on},
    /* bracket */
    {"image_plane_distance", KEY_NUMBER, AT(image_plane_distance), M_BRACKET,
     NULL, 0, 0, NULL},
    {"focal_length", KEY_NUMBER, AT(focal_length), M_BRACKET, NULL, 0, 0,
     NULL},
    {"aperture", KEY_NUMBER, AT(aperture), M_BRACKET, NULL, 0, 0, NULL},
    /* every model with a lens */
    {"chromatic", KEY_OBJECT, AT(chromatic), M_THINLENS | M_BRACKET, NULL, 0,
     0, parse_chromatic},
};

#define N_KEYS (sizeof camera_keys / sizeof camera_keys[0])

static lr_status read_key(const cJSON *c, const camera_key *k, lr_camera *cam,
                          lr_error *err)
{
    void *field = (char *)cam + k->offset;
    switch (k->type) {
    case KEY_NUMBER:
        return lr__json_number(c, k->name, "camera", 0, field, err);
    case KEY_INT: {
        int *f = field;
        long long v = *f;
        LR_TRY(lr__json_int(c, k->name, "camera", 0, k->min, k->max, &v,
                            err));
        *f = (int)v;
        return LR_OK;
    }
    case KEY_VEC3: {
        double *f = field;
        lr__v3 v = v3a(f);
        LR_TRY(lr__json_vec3(c, k->name, "camera", 0, &v, err));
        f[0] = v.x, f[1] = v.y, f[2] = v.z;
        return LR_OK;
    }
    case KEY_ENUM:
        return lr__json_enum(c, k->name, "camera", k->names, field, err);
    case KEY_OBJECT: {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(c, k->name);
        return v == NULL ? LR_OK : k->parse(v, cam, err);
    }
    }
    return lr__fail(err, LR_ERR_INVALID, NULL, "camera.%s: unknown key type",
                    k->name);
}

lr_status lr__camera_from_json(const cJSON *c, lr_camera *cam, lr_error *err)
{
    const char *names[N_KEYS + 1];
    if (c == NULL)
        return LR_OK;
    if (!cJSON_IsObject(c))
        return lr__fail(err, LR_ERR_INVALID, "camera",
                        "camera must be an object");
    for (size_t i = 0; i < N_KEYS; i++)
        names[i] = camera_keys[i].name;
    names[N_KEYS] = NULL;
    LR_TRY(lr__json_check_keys(c, "camera", names, err));
    for (size_t i = 0; i < N_KEYS; i++)
        LR_TRY(read_key(c, &camera_keys[i], cam, err));
    return lr_camera_validate(cam, err);
}

lr_status lr_camera_apply_json(lr_camera *cam, const char *json, size_t len,
                               lr_error *err)
{
    if (cam == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_camera_apply_json: NULL argument");
    cJSON *root = NULL;
    LR_TRY(lr__json_parse(json ? json : "", len, "camera", "camera",
                          &root, err));
    lr_camera tmp = *cam;
    lr_status st = lr__camera_from_json(root, &tmp, err);
    cJSON_Delete(root);
    if (st == LR_OK)
        *cam = tmp;
    return st;
}
