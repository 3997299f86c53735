/*
 * scene_objects.c: the scene format's "objects" -> lr_scene (for
 * scene_load.c, scene_load.h): spheres, triangles, planes, OBJ meshes and
 * glTF files, each with its material by name and its transform.  Every
 * value is validated and every error names its JSON path.
 */
#include "scene/gltf/gltf.h"
#include "json/json_util.h"
#include "scene/material_json.h"
#include "scene/mesh.h"
#include "scene/scene.h"
#include "util/scene_file.h"
#include "scene/scene_load.h"
#include "util/transform.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- transforms -------------------------------------------------------- */

lr_status lr__xform_parse(const cJSON *list, const char *path, lr__xform *out,
                          lr_error *err)
{
    static const char *const keys_rot[] = {"axis", "degrees", NULL};
    char p[LR__PATH_MAX], q[LR__PATH_MAX];
    lr_status st;
    *out = lr__xform_identity();
    if (!cJSON_IsArray(list)) {
        char d[96];
        lr__json_describe(list, d, sizeof d);
        return lr__fail(err, LR_ERR_INVALID, path,
                        "%s must be an array of steps, got %s", path, d);
    }
    size_t i = 0;
    for (const cJSON *step = list->child; step; step = step->next, i++) {
        lr__path_index(p, path, i);
        if (!cJSON_IsObject(step) || cJSON_GetArraySize(step) != 1)
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s must be an object with one key: translate, "
                            "rotate or scale",
                            p);
        lr__xform x = lr__xform_identity();
        const char *kind = step->child->string;
        if (strcmp(kind, "translate") == 0) {
            lr__v3 t;
            st = lr__json_vec3(step, "translate", p, 1, &t, err);
            if (st != LR_OK)
                return st;
            x.m[0][3] = t.x;
            x.m[1][3] = t.y;
            x.m[2][3] = t.z;
        } else if (strcmp(kind, "scale") == 0) {
            const cJSON *v = step->child;
            lr__v3 sc;
            lr__path_key(q, p, "scale");
            if (cJSON_IsNumber(v)) {
                double k = v->valuedouble;
                LR_TRY(lr__json_check_number(k, q, err));
                sc = v3(k, k, k);
            } else {
                st = lr__json_vec3(step, "scale", p, 1, &sc, err);
                if (st != LR_OK)
                    return st;
            }
            if (!v3_finite(sc) || sc.x == 0 || sc.y == 0 || sc.z == 0)
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must be finite and non-zero", q);
            x.m[0][0] = sc.x;
            x.m[1][1] = sc.y;
            x.m[2][2] = sc.z;
        } else if (strcmp(kind, "rotate") == 0) {
            const cJSON *r = step->child;
            lr__path_key(q, p, "rotate");
            if (!cJSON_IsObject(r))
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must be an object {\"axis\": [x, y, z], "
                                "\"degrees\": d}",
                                q);
            st = lr__json_check_keys(r, q, keys_rot, err);
            if (st != LR_OK)
                return st;
            lr__v3 axis;
            double deg = 0;
            st = lr__json_vec3(r, "axis", q, 1, &axis, err);
            if (st == LR_OK)
                st = lr__json_number(r, "degrees", q, 1, &deg, err);
            if (st != LR_OK)
                return st;
            if (v3_len(axis) == 0.0) {
                lr__path_key(p, q, "axis");
                return lr__fail(err, LR_ERR_INVALID, p,
                                "%s must not be the zero vector", p);
            }
            /* Rodrigues' rotation formula, right-handed about the axis. */
            lr__v3 a = v3_norm(axis);
            double th = deg * M_PI / 180.0, c = cos(th), s = sin(th), t = 1 - c;
            double m[3][3] = {{t * a.x * a.x + c, t * a.x * a.y - s * a.z,
                               t * a.x * a.z + s * a.y},
                              {t * a.x * a.y + s * a.z, t * a.y * a.y + c,
                               t * a.y * a.z - s * a.x},
                              {t * a.x * a.z - s * a.y, t * a.y * a.z + s * a.x,
                               t * a.z * a.z + c}};
            for (int u = 0; u < 3; u++)
                for (int w = 0; w < 3; w++)
                    x.m[u][w] = m[u][w];
        } else {
            lr__path_key(q, p, kind);
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s: unknown transform step \"%s\" (expected "
                            "translate, rotate or scale)",
                            q, kind);
        }
        /* Steps apply in list order: the first one listed acts first. */
        *out = lr__xform_mul(&x, out);
    }
    return LR_OK;
}

/* ---- objects ---------------------------------------------------------- */

static lr_status find_material(const lr_scene *s, const cJSON *obj,
                               const char *path, int *out, lr_error *err)
{
    const char *name = NULL;
    lr_status st = lr__json_string(obj, "material", path, 0, &name, err);
    if (st != LR_OK)
        return st;
    *out = 0;
    if (name == NULL)
        return LR_OK;
    for (size_t i = 1; i < s->n_materials; i++)
        if (strcmp(s->materials[i].name, name) == 0) {
            *out = (int)i;
            return LR_OK;
        }
    char p[LR__PATH_MAX];
    lr__path_key(p, path, "material");
    return lr__fail(err, LR_ERR_INVALID, p,
                    "%s: no material named \"%s\" in materials", p, name);
}

/* An OBJ mesh: the file is found relative to the scene's directory, or
 * among the assets (lr__scene_file). */
static lr_status add_mesh(lr_scene *s, const cJSON *o, const char *p,
                          const lr__xform *x, int material,
                          const char *base_dir, lr_error *err)
{
    const char *file = NULL;
    int smooth = -1;
    LR_TRY(lr__json_string(o, "file", p, 1, &file, err));
    LR_TRY(lr__json_bool(o, "smooth", p, 0, &smooth, err));
    char fp[LR__PATH_MAX];
    lr__path_key(fp, p, "file");
    char full[4096];
    LR_TRY(lr__scene_file(file, base_dir, fp, full, sizeof full, err));
    return lr__scene_add_obj(s, full, file, fp, smooth, x, material, err);
}

/* A glTF file: meshes, materials, lights and, with "camera", the camera
 * (gltf.h). */
static lr_status add_gltf(lr_scene *s, const cJSON *o, const char *p,
                          const lr__xform *x, const char *base_dir,
                          int height_given, lr_error *err)
{
    const char *file = NULL;
    char q[LR__PATH_MAX];
    LR_TRY(lr__json_string(o, "file", p, 1, &file, err));
    lr__gltf_options go = {*x, LR__GLTF_CAMERA_NONE, NULL, height_given};
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(o, "camera");
    if (cJSON_IsTrue(cam)) {
        go.camera = LR__GLTF_CAMERA_FIRST;
    } else if (cJSON_IsString(cam)) {
        go.camera = LR__GLTF_CAMERA_NAMED;
        go.camera_name = cam->valuestring;
    } else if (cam != NULL && !cJSON_IsFalse(cam)) {
        lr__path_key(q, p, "camera");
        return lr__fail(err, LR_ERR_INVALID, q,
                        "%s must be true, false or a camera's name", q);
    }
    lr__path_key(q, p, "file");
    /* Through the one resolver of file keys ("sha256:" assets too; a
     * .glb, or a .gltf whose buffers and images are data: URIs, works as
     * an asset, since an asset has no directory of neighbours). */
    char full[4096];
    LR_TRY(lr__scene_file(file, base_dir, q, full, sizeof full, err));
    return lr__scene_add_gltf(s, full, file, q, &go, err);
}

static lr_status parse_object(lr_scene *s, const cJSON *o, const char *p,
                              const char *base_dir, int height_given,
                              lr_error *err)
{
    static const char *const keys_sphere[] = {"type",   "material", "transform",
                                              "center", "radius",   NULL};
    static const char *const keys_plane[] = {
        "type", "material", "transform", "point", "normal", "size", NULL};
    static const char *const keys_tri[] = {"type", "material", "transform",
                                           "vertices", NULL};
    static const char *const keys_mesh[] = {"type", "material", "transform",
                                            "file", "smooth",   NULL};
    static const char *const keys_gltf[] = {"type", "transform", "file",
                                            "camera", NULL};
    char q[LR__PATH_MAX];
    const char *type = NULL;
    LR_TRY(lr__json_object(o, p, "", err));
    LR_TRY(lr__json_string(o, "type", p, 1, &type, err));
    const char *const *keys = strcmp(type, "sphere") == 0     ? keys_sphere
                              : strcmp(type, "plane") == 0    ? keys_plane
                              : strcmp(type, "triangle") == 0 ? keys_tri
                              : strcmp(type, "mesh") == 0     ? keys_mesh
                              : strcmp(type, "gltf") == 0     ? keys_gltf
                                                              : NULL;
    if (keys == NULL) {
        lr__path_key(q, p, "type");
        return lr__fail(err, LR_ERR_INVALID, q,
                        "%s must be \"sphere\", \"plane\", \"triangle\", "
                        "\"mesh\" or \"gltf\", got \"%s\"",
                        q, type);
    }
    LR_TRY(lr__json_check_keys(o, p, keys, err));
    int material = 0;
    LR_TRY(find_material(s, o, p, &material, err));
    lr__xform x = lr__xform_identity();
    const cJSON *tr = cJSON_GetObjectItemCaseSensitive(o, "transform");
    if (tr != NULL) {
        lr__path_key(q, p, "transform");
        LR_TRY(lr__xform_parse(tr, q, &x, err));
    }

    if (keys == keys_sphere) {
        lr__v3 c;
        double r = 0;
        LR_TRY(lr__json_vec3(o, "center", p, 1, &c, err));
        LR_TRY(lr__json_number(o, "radius", p, 1, &r, err));
        if (!(r > 0)) {
            lr__path_key(q, p, "radius");
            return lr__fail(err, LR_ERR_INVALID, q, "%s must be > 0, got %g", q,
                            r);
        }
        double k = lr__xform_uniform_scale(&x);
        if (k < 0) {
            lr__path_key(q, p, "transform");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s: a sphere can only be scaled uniformly", q);
        }
        lr__v3 cw = lr__xform_point(&x, c);
        lr__path_key(q, p, tr != NULL ? "transform" : "radius");
        LR_TRY(lr__check_extent(v3_maxabs(cw) + r * k, q, err));
        return lr__scene_add_sphere(s, cw, r * k, material, err);
    }
    if (keys == keys_plane) {
        lr__v3 pt = v3(0, 0, 0), n;
        LR_TRY(lr__json_vec3(o, "point", p, 0, &pt, err));
        LR_TRY(lr__json_vec3(o, "normal", p, 1, &n, err));
        if (v3_len(n) == 0.0) {
            lr__path_key(q, p, "normal");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must not be the zero vector", q);
        }
        n = v3_norm(n);
        const cJSON *size = cJSON_GetObjectItemCaseSensitive(o, "size");
        if (size == NULL) {
            lr__v3 pw = lr__xform_point(&x, pt);
            lr__path_key(q, p, tr != NULL ? "transform" : "point");
            LR_TRY(lr__check_extent(v3_maxabs(pw), q, err));
            return lr__scene_add_plane(s, pw, lr__xform_normal(&x, n), material,
                                       err);
        }
        /* A finite plane: a rectangle centred on `point` (mesh.c). */
        double w, h;
        lr__path_key(q, p, "size");
        if (cJSON_IsNumber(size)) {
            w = h = size->valuedouble;
        } else if (cJSON_IsArray(size) && cJSON_GetArraySize(size) == 2 &&
                   cJSON_IsNumber(size->child) &&
                   cJSON_IsNumber(size->child->next)) {
            w = size->child->valuedouble;
            h = size->child->next->valuedouble;
        } else {
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be a number or [width, height]", q);
        }
        if (!(w > 0 && h > 0 && w <= LR__MAX_NUMBER && h <= LR__MAX_NUMBER))
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be finite, > 0 and at most 1e15, got "
                            "[%g, %g]",
                            q, w, h);
        lr__path_key(q, p, tr != NULL ? "transform" : "size");
        return lr__scene_add_rect(s, pt, n, w, h, &x, material, q, err);
    }
    if (keys == keys_tri) {
        const cJSON *vs = cJSON_GetObjectItemCaseSensitive(o, "vertices");
        lr__path_key(q, p, "vertices");
        if (!cJSON_IsArray(vs) || cJSON_GetArraySize(vs) != 3)
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be an array of 3 points", q);
        float verts[9];
        unsigned idx[3] = {0, 1, 2};
        int i = 0;
        for (const cJSON *v = vs->child; v; v = v->next, i++) {
            char pi[LR__PATH_MAX];
            lr__path_index(pi, q, (size_t)i);
            lr__v3 pt;
            double a[3];
            if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
                return lr__fail(err, LR_ERR_INVALID, pi,
                                "%s must be an array of 3 numbers", pi);
            int j = 0;
            for (const cJSON *c = v->child; c; c = c->next, j++) {
                if (!cJSON_IsNumber(c) || !isfinite(c->valuedouble) ||
                    fabs(c->valuedouble) > LR__MAX_NUMBER)
                    return lr__fail(err, LR_ERR_INVALID, pi,
                                    "%s[%d] must be a finite number between "
                                    "-1e15 and 1e15",
                                    pi, j);
                a[j] = c->valuedouble;
            }
            pt = lr__xform_point(&x, v3a(a));
            if (tr != NULL) {
                lr__path_key(pi, p, "transform");
                LR_TRY(lr__check_extent(v3_maxabs(pt), pi, err));
            }
            verts[3 * i] = (float)pt.x;
            verts[3 * i + 1] = (float)pt.y;
            verts[3 * i + 2] = (float)pt.z;
        }
        if (lr__xform_det(&x) < 0)
            idx[1] = 2, idx[2] = 1;
        return lr__scene_add_triangles(s, verts, 3, idx, 1, NULL, material, p,
                                       err);
    }
    if (keys == keys_gltf)
        return add_gltf(s, o, p, &x, base_dir, height_given, err);
    return add_mesh(s, o, p, &x, material, base_dir, err);
}

lr_status lr__scene_parse_objects(lr_scene *s, const cJSON *objs,
                                  const char *base_dir, int height_given,
                                  lr_error *err)
{
    char p[LR__PATH_MAX];
    if (objs == NULL)
        return LR_OK;
    if (!cJSON_IsArray(objs))
        return lr__fail(err, LR_ERR_INVALID, "objects",
                        "objects must be an array");
    size_t i = 0;
    for (const cJSON *o = objs->child; o; o = o->next, i++) {
        lr__path_index(p, "objects", i);
        size_t g0 = s->n_geoms, p0 = s->n_planes;
        lr_status st = parse_object(s, o, p, base_dir, height_given, err);
        if (st == LR_OK)
            st = lr__material_check_uvs(s, g0, p0, p, err);
        if (st != LR_OK)
            return st;
    }
    return LR_OK;
}
