/*
 * scene_json.c: JSON -> lr_scene.  Every value is validated here and every
 * error names its JSON path ("objects[3].radius must be > 0, got -2").
 * Unknown and duplicate keys are errors, so a typo never goes unnoticed.
 */
#include "apply_json.h"
#include "json_util.h"
#include "scene.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The largest scene file we read: far beyond any hand-written scene. */
#define MAX_SCENE_BYTES (64u << 20)

/* A 3x4 affine transform, row-major: p' = M p + t. */
typedef struct xform {
    double m[3][4];
} xform;

static xform xform_identity(void)
{
    xform x = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
    return x;
}

/* a * b: apply b first, then a. */
static xform xform_mul(const xform *a, const xform *b)
{
    xform r;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++) {
            double v = j == 3 ? a->m[i][3] : 0.0;
            for (int k = 0; k < 3; k++)
                v += a->m[i][k] * b->m[k][j];
            r.m[i][j] = v;
        }
    return r;
}

static lr__v3 xform_point(const xform *x, lr__v3 p)
{
    return v3(x->m[0][0] * p.x + x->m[0][1] * p.y + x->m[0][2] * p.z + x->m[0][3],
              x->m[1][0] * p.x + x->m[1][1] * p.y + x->m[1][2] * p.z + x->m[1][3],
              x->m[2][0] * p.x + x->m[2][1] * p.y + x->m[2][2] * p.z + x->m[2][3]);
}

/* Normals transform by the inverse transpose; the cofactor matrix is the
 * inverse transpose times the determinant, which is fine for a direction
 * that is normalised afterwards (and flips correctly for mirroring). */
static lr__v3 xform_normal(const xform *x, lr__v3 n)
{
    const double(*m)[4] = x->m;
    double c[3][3] = {
        {m[1][1] * m[2][2] - m[1][2] * m[2][1],
         m[1][2] * m[2][0] - m[1][0] * m[2][2],
         m[1][0] * m[2][1] - m[1][1] * m[2][0]},
        {m[0][2] * m[2][1] - m[0][1] * m[2][2],
         m[0][0] * m[2][2] - m[0][2] * m[2][0],
         m[0][1] * m[2][0] - m[0][0] * m[2][1]},
        {m[0][1] * m[1][2] - m[0][2] * m[1][1],
         m[0][2] * m[1][0] - m[0][0] * m[1][2],
         m[0][0] * m[1][1] - m[0][1] * m[1][0]}};
    return v3_norm(v3(c[0][0] * n.x + c[0][1] * n.y + c[0][2] * n.z,
                      c[1][0] * n.x + c[1][1] * n.y + c[1][2] * n.z,
                      c[2][0] * n.x + c[2][1] * n.y + c[2][2] * n.z));
}

static double xform_det(const xform *x)
{
    const double(*m)[4] = x->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* For spheres: the transform must scale all directions alike.  Returns
 * the scale factor, or -1 if it does not. */
static double xform_uniform_scale(const xform *x)
{
    double len[3];
    for (int j = 0; j < 3; j++)
        len[j] = sqrt(x->m[0][j] * x->m[0][j] + x->m[1][j] * x->m[1][j] +
                      x->m[2][j] * x->m[2][j]);
    for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++) {
            double dot = x->m[0][a] * x->m[0][b] + x->m[1][a] * x->m[1][b] +
                         x->m[2][a] * x->m[2][b];
            if (fabs(dot) > 1e-9 * len[a] * len[b])
                return -1;
        }
    if (fabs(len[0] - len[1]) > 1e-9 * len[0] ||
        fabs(len[0] - len[2]) > 1e-9 * len[0])
        return -1;
    return len[0];
}

static lr_status parse_transform(const cJSON *list, const char *path,
                                 xform *out, lr_error *err)
{
    static const char *const keys_rot[] = {"axis", "degrees", NULL};
    char p[LR__PATH_MAX], q[LR__PATH_MAX];
    lr_status st;
    *out = xform_identity();
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
        xform x = xform_identity();
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
            double th = deg * M_PI / 180.0, c = cos(th), s = sin(th),
                   t = 1 - c;
            double m[3][3] = {
                {t * a.x * a.x + c, t * a.x * a.y - s * a.z,
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
        *out = xform_mul(&x, out);
    }
    return LR_OK;
}

/* ---- materials -------------------------------------------------------- */

static lr_status parse_materials(lr_scene *s, const cJSON *mats,
                                 lr_error *err)
{
    static const char *const keys[] = {"diffuse", "specular", "shininess",
                                       "reflect", "transmit", "ior", NULL};
    char p[LR__PATH_MAX];
    lr_status st;
    size_t n = 1; /* slot 0 is the default material */
    if (mats != NULL && !cJSON_IsObject(mats))
        return lr__fail(err, LR_ERR_INVALID, "materials",
                        "materials must be an object of named materials");
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
        if (!cJSON_IsObject(m))
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s must be an object", p);
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
        char q[LR__PATH_MAX];
        if (mt->shininess < 0 || mt->shininess > 1e6) {
            lr__path_key(q, p, "shininess");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be between 0 and 1e6, got %g", q,
                            mt->shininess);
        }
        if (mt->ior < 1.0 || mt->ior > 10.0) {
            lr__path_key(q, p, "ior");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be between 1 and 10, got %g", q,
                            mt->ior);
        }
    }
    return LR_OK;
}

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

/* ---- lights ----------------------------------------------------------- */

static lr_status parse_lights(lr_scene *s, const cJSON *lights,
                              lr_error *err)
{
    static const char *const keys_point[] = {"type", "position",
                                             "intensity", NULL};
    static const char *const keys_dir[] = {"type", "direction", "irradiance",
                                           NULL};
    static const char *const keys_amb[] = {"type", "radiance", NULL};
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
        if (!cJSON_IsObject(l))
            return lr__fail(err, LR_ERR_INVALID, p, "%s must be an object",
                            p);
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
        } else if (strcmp(type, "ambient") == 0) {
            lr__v3 r = v3(0, 0, 0);
            LR_TRY(lr__json_check_keys(l, p, keys_amb, err));
            LR_TRY(lr__json_rgb(l, "radiance", p, 1, &r, err));
            s->ambient = v3_add(s->ambient, r);
        } else {
            char q[LR__PATH_MAX];
            lr__path_key(q, p, "type");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be \"point\", \"directional\" or "
                            "\"ambient\", got \"%s\"",
                            q, type);
        }
    }
    return LR_OK;
}

/* ---- objects ---------------------------------------------------------- */

/* Area-weighted vertex normals, expanded to corners. */
static float *smooth_normals(const lr__mesh *m)
{
    double *acc = calloc(m->n_vertices * 3, sizeof *acc);
    float *out = malloc(m->n_triangles * 9 * sizeof *out);
    if (acc == NULL || out == NULL) {
        free(acc);
        free(out);
        return NULL;
    }
    for (size_t t = 0; t < m->n_triangles; t++) {
        const unsigned *ix = &m->indices[3 * t];
        lr__v3 a = v3(m->vertices[3 * ix[0]], m->vertices[3 * ix[0] + 1],
                      m->vertices[3 * ix[0] + 2]);
        lr__v3 b = v3(m->vertices[3 * ix[1]], m->vertices[3 * ix[1] + 1],
                      m->vertices[3 * ix[1] + 2]);
        lr__v3 c = v3(m->vertices[3 * ix[2]], m->vertices[3 * ix[2] + 1],
                      m->vertices[3 * ix[2] + 2]);
        /* The cross product's length is twice the area: the weight. */
        lr__v3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
        for (int k = 0; k < 3; k++) {
            acc[3 * ix[k]] += n.x;
            acc[3 * ix[k] + 1] += n.y;
            acc[3 * ix[k] + 2] += n.z;
        }
    }
    for (size_t t = 0; t < m->n_triangles; t++)
        for (int k = 0; k < 3; k++) {
            unsigned v = m->indices[3 * t + k];
            lr__v3 n = v3_norm(v3(acc[3 * v], acc[3 * v + 1], acc[3 * v + 2]));
            out[9 * t + 3 * k] = (float)n.x;
            out[9 * t + 3 * k + 1] = (float)n.y;
            out[9 * t + 3 * k + 2] = (float)n.z;
        }
    free(acc);
    return out;
}

static char *join_path(const char *dir, const char *file)
{
    size_t n = strlen(file) + (dir ? strlen(dir) : 0) + 2;
    char *out = malloc(n);
    if (out == NULL)
        return NULL;
    if (file[0] == '/' || dir == NULL || dir[0] == '\0')
        snprintf(out, n, "%s", file);
    else
        snprintf(out, n, "%s/%s", dir, file);
    return out;
}

static lr_status add_mesh(lr_scene *s, const cJSON *o, const char *p,
                          const xform *x, int material, const char *base_dir,
                          lr_error *err)
{
    const char *file = NULL;
    int smooth = -1;
    lr_status st;
    LR_TRY(lr__json_string(o, "file", p, 1, &file, err));
    LR_TRY(lr__json_bool(o, "smooth", p, 0, &smooth, err));
    char fp[LR__PATH_MAX];
    lr__path_key(fp, p, "file");
    char *full = join_path(base_dir, file);
    if (full == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    lr__mesh m;
    memset(&m, 0, sizeof m);
    /* Messages name the file as the scene wrote it, relative to the
     * scene's directory: base_dir is the caller's business (the daemon's
     * scenes directory must not show in its answers). */
    st = lr__obj_load_named(full, file, fp, &m, err);
    free(full);
    if (st != LR_OK) {
        /* Prefix the OBJ error with the field that named the file. */
        if (err != NULL && strncmp(err->message, fp, strlen(fp)) != 0) {
            char msg[sizeof err->message];
            snprintf(msg, sizeof msg, "%s: %s", fp, err->message);
            snprintf(err->message, sizeof err->message, "%s", msg);
            snprintf(err->path, sizeof err->path, "%s", fp);
        }
        return st;
    }
    /* File normals are used unless smooth is false (flat shading); when
     * the file has none, smooth: true computes them. */
    float *normals = NULL;
    if (smooth != 0 && m.normals != NULL) {
        normals = m.normals;
        m.normals = NULL;
    } else if (smooth == 1) {
        normals = smooth_normals(&m);
        if (normals == NULL) {
            lr__mesh_free(&m);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
    }
    for (size_t v = 0; v < m.n_vertices; v++) {
        lr__v3 q = xform_point(x, v3(m.vertices[3 * v], m.vertices[3 * v + 1],
                                     m.vertices[3 * v + 2]));
        if (!(v3_maxabs(q) <= LR__MAX_NUMBER)) {
            free(normals);
            lr__mesh_free(&m);
            return lr__fail(err, LR_ERR_INVALID, fp,
                            "%s: vertex %zu reaches %g from the origin (after "
                            "the transform), beyond the limit of 1e15",
                            fp, v + 1, v3_maxabs(q));
        }
        m.vertices[3 * v] = (float)q.x;
        m.vertices[3 * v + 1] = (float)q.y;
        m.vertices[3 * v + 2] = (float)q.z;
    }
    if (normals != NULL)
        for (size_t c = 0; c < 3 * m.n_triangles; c++) {
            lr__v3 n = xform_normal(x, v3(normals[3 * c], normals[3 * c + 1],
                                          normals[3 * c + 2]));
            normals[3 * c] = (float)n.x;
            normals[3 * c + 1] = (float)n.y;
            normals[3 * c + 2] = (float)n.z;
        }
    /* A mirroring transform (negative determinant) turns CCW into CW, so
     * swap two corners to keep the front side outside. */
    if (xform_det(x) < 0)
        for (size_t t = 0; t < m.n_triangles; t++) {
            unsigned tmp = m.indices[3 * t + 1];
            m.indices[3 * t + 1] = m.indices[3 * t + 2];
            m.indices[3 * t + 2] = tmp;
            if (normals != NULL)
                for (int k = 0; k < 3; k++) {
                    float f = normals[9 * t + 3 + k];
                    normals[9 * t + 3 + k] = normals[9 * t + 6 + k];
                    normals[9 * t + 6 + k] = f;
                }
        }
    st = lr__scene_add_triangles(s, m.vertices, m.n_vertices, m.indices,
                                 m.n_triangles, normals, material, err);
    lr__mesh_free(&m);
    return st;
}

/* Geometry, once transformed, must stay within LR__MAX_NUMBER of the
 * origin like every number of the file: beyond that Embree's float
 * rays stop being valid (an Embree assertion aborts the process).  `m` is
 * the largest coordinate magnitude the object reaches; `p` the field to
 * blame. */
static lr_status check_extent(double m, const char *p, lr_error *err)
{
    if (!(m <= LR__MAX_NUMBER))
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s: the object reaches %g from the origin, beyond "
                        "the limit of 1e15",
                        p, m);
    return LR_OK;
}

static lr_status parse_object(lr_scene *s, const cJSON *o, const char *p,
                              const char *base_dir, lr_error *err)
{
    static const char *const keys_sphere[] = {"type", "material", "transform",
                                              "center", "radius", NULL};
    static const char *const keys_plane[] = {"type", "material", "transform",
                                             "point", "normal", "size", NULL};
    static const char *const keys_tri[] = {"type", "material", "transform",
                                           "vertices", NULL};
    static const char *const keys_mesh[] = {"type", "material", "transform",
                                            "file", "smooth", NULL};
    char q[LR__PATH_MAX];
    const char *type = NULL;
    if (!cJSON_IsObject(o))
        return lr__fail(err, LR_ERR_INVALID, p, "%s must be an object", p);
    LR_TRY(lr__json_string(o, "type", p, 1, &type, err));
    const char *const *keys = strcmp(type, "sphere") == 0     ? keys_sphere
                              : strcmp(type, "plane") == 0    ? keys_plane
                              : strcmp(type, "triangle") == 0 ? keys_tri
                              : strcmp(type, "mesh") == 0     ? keys_mesh
                                                              : NULL;
    if (keys == NULL) {
        lr__path_key(q, p, "type");
        return lr__fail(err, LR_ERR_INVALID, q,
                        "%s must be \"sphere\", \"plane\", \"triangle\" or "
                        "\"mesh\", got \"%s\"",
                        q, type);
    }
    LR_TRY(lr__json_check_keys(o, p, keys, err));
    int material = 0;
    LR_TRY(find_material(s, o, p, &material, err));
    xform x = xform_identity();
    const cJSON *tr = cJSON_GetObjectItemCaseSensitive(o, "transform");
    if (tr != NULL) {
        lr__path_key(q, p, "transform");
        LR_TRY(parse_transform(tr, q, &x, err));
    }

    if (keys == keys_sphere) {
        lr__v3 c;
        double r = 0;
        LR_TRY(lr__json_vec3(o, "center", p, 1, &c, err));
        LR_TRY(lr__json_number(o, "radius", p, 1, &r, err));
        if (!(r > 0)) {
            lr__path_key(q, p, "radius");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be > 0, got %g", q, r);
        }
        double k = xform_uniform_scale(&x);
        if (k < 0) {
            lr__path_key(q, p, "transform");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s: a sphere can only be scaled uniformly", q);
        }
        lr__v3 cw = xform_point(&x, c);
        lr__path_key(q, p, tr != NULL ? "transform" : "radius");
        LR_TRY(check_extent(v3_maxabs(cw) + r * k, q, err));
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
            lr__v3 pw = xform_point(&x, pt);
            lr__path_key(q, p, tr != NULL ? "transform" : "point");
            LR_TRY(check_extent(v3_maxabs(pw), q, err));
            return lr__scene_add_plane(s, pw, xform_normal(&x, n), material,
                                       err);
        }
        /* A finite plane: a rectangle centred on `point`, its first side
         * along the world x axis projected onto the plane (the z axis
         * when |normal.x| > 0.9), made of two triangles. */
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
        lr__v3 ax = fabs(n.x) > 0.9 ? v3(0, 0, 1) : v3(1, 0, 0);
        lr__v3 u = v3_norm(v3_madd(ax, n, -v3_dot(ax, n)));
        lr__v3 v = v3_cross(n, u);
        lr__v3 corner[4] = {
            v3_madd(v3_madd(pt, u, -w / 2), v, -h / 2),
            v3_madd(v3_madd(pt, u, w / 2), v, -h / 2),
            v3_madd(v3_madd(pt, u, w / 2), v, h / 2),
            v3_madd(v3_madd(pt, u, -w / 2), v, h / 2)};
        float verts[12];
        for (int i = 0; i < 4; i++) {
            lr__v3 c = xform_point(&x, corner[i]);
            lr__path_key(q, p, tr != NULL ? "transform" : "size");
            LR_TRY(check_extent(v3_maxabs(c), q, err));
            verts[3 * i] = (float)c.x;
            verts[3 * i + 1] = (float)c.y;
            verts[3 * i + 2] = (float)c.z;
        }
        unsigned idx[6] = {0, 1, 2, 0, 2, 3};
        if (xform_det(&x) < 0) {
            idx[1] = 2, idx[2] = 1, idx[4] = 3, idx[5] = 2;
        }
        return lr__scene_add_triangles(s, verts, 4, idx, 2, NULL, material,
                                       err);
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
            pt = xform_point(&x, v3a(a));
            if (tr != NULL) {
                lr__path_key(pi, p, "transform");
                LR_TRY(check_extent(v3_maxabs(pt), pi, err));
            }
            verts[3 * i] = (float)pt.x;
            verts[3 * i + 1] = (float)pt.y;
            verts[3 * i + 2] = (float)pt.z;
        }
        if (xform_det(&x) < 0)
            idx[1] = 2, idx[2] = 1;
        return lr__scene_add_triangles(s, verts, 3, idx, 1, NULL, material,
                                       err);
    }
    return add_mesh(s, o, p, &x, material, base_dir, err);
}

static lr_status parse_objects(lr_scene *s, const cJSON *objs,
                               const char *base_dir, lr_error *err)
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
        lr_status st = parse_object(s, o, p, base_dir, err);
        if (st != LR_OK)
            return st;
    }
    return LR_OK;
}

/* ---- camera and render ------------------------------------------------ */

static lr_status parse_chromatic(const cJSON *c, lr_chromatic *ch,
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

static void set3(double out[3], lr__v3 v)
{
    out[0] = v.x;
    out[1] = v.y;
    out[2] = v.z;
}

static lr_status parse_camera(const cJSON *c, lr_camera *cam, lr_error *err)
{
    static const char *const keys[] = {
        "model", "position", "look_at", "up", "fov",
        /* thin lens */
        "focus_distance", "aperture_radius", "f_number", "focal_length_mm",
        "aperture_shape", "aperture_blades", "aperture_rotation",
        "aperture_ratio", "focus_on",
        /* bracket */
        "image_plane_distance", "focal_length", "aperture",
        "chromatic", NULL};
    static const char *const models[] = {"pinhole", "thinlens", "bracket",
                                         NULL};
    static const char *const shapes[] = {"disk", "square", "polygon", NULL};
    if (c == NULL)
        return LR_OK;
    if (!cJSON_IsObject(c))
        return lr__fail(err, LR_ERR_INVALID, "camera",
                        "camera must be an object");
    LR_TRY(lr__json_check_keys(c, "camera", keys, err));
    lr__v3 pos = v3a(cam->position), at = v3a(cam->look_at),
           up = v3a(cam->up);
    int model = (int)cam->model, shape = (int)cam->aperture_shape;
    long long blades = cam->aperture_blades;
    LR_TRY(lr__json_enum(c, "model", "camera", models, &model, err));
    LR_TRY(lr__json_vec3(c, "position", "camera", 0, &pos, err));
    LR_TRY(lr__json_vec3(c, "look_at", "camera", 0, &at, err));
    LR_TRY(lr__json_vec3(c, "up", "camera", 0, &up, err));
    LR_TRY(lr__json_number(c, "fov", "camera", 0, &cam->fov, err));
    LR_TRY(lr__json_number(c, "focus_distance", "camera", 0,
                           &cam->focus_distance, err));
    LR_TRY(lr__json_number(c, "aperture_radius", "camera", 0,
                           &cam->aperture_radius, err));
    LR_TRY(lr__json_number(c, "f_number", "camera", 0, &cam->f_number, err));
    LR_TRY(lr__json_number(c, "focal_length_mm", "camera", 0,
                           &cam->focal_length_mm, err));
    LR_TRY(lr__json_enum(c, "aperture_shape", "camera", shapes, &shape, err));
    LR_TRY(lr__json_int(c, "aperture_blades", "camera", 0, 3, 64, &blades,
                        err));
    LR_TRY(lr__json_number(c, "aperture_rotation", "camera", 0,
                           &cam->aperture_rotation, err));
    LR_TRY(lr__json_number(c, "aperture_ratio", "camera", 0,
                           &cam->aperture_ratio, err));
    LR_TRY(lr__json_number(c, "image_plane_distance", "camera", 0,
                           &cam->image_plane_distance, err));
    LR_TRY(lr__json_number(c, "focal_length", "camera", 0,
                           &cam->focal_length, err));
    LR_TRY(lr__json_number(c, "aperture", "camera", 0, &cam->aperture, err));
    const cJSON *fo = cJSON_GetObjectItemCaseSensitive(c, "focus_on");
    if (fo != NULL && cJSON_IsNull(fo)) {
        cam->focus_on[0] = cam->focus_on[1] = -1;
    } else if (fo != NULL) {
        if (!cJSON_IsArray(fo) || cJSON_GetArraySize(fo) != 2 ||
            !cJSON_IsNumber(fo->child) || !cJSON_IsNumber(fo->child->next))
            return lr__fail(err, LR_ERR_INVALID, "camera.focus_on",
                            "camera.focus_on must be a pixel [x, y] (or "
                            "null)");
        for (int i = 0; i < 2; i++) {
            double v = cJSON_GetArrayItem(fo, i)->valuedouble;
            if (!(v >= 0 && v <= 65535 && v == floor(v)))
                return lr__fail(err, LR_ERR_INVALID, "camera.focus_on",
                                "camera.focus_on[%d] must be a whole pixel "
                                "index >= 0, got %g",
                                i, v);
            cam->focus_on[i] = (int)v;
        }
    }
    const cJSON *ch = cJSON_GetObjectItemCaseSensitive(c, "chromatic");
    if (ch != NULL)
        LR_TRY(parse_chromatic(ch, &cam->chromatic, err));
    cam->model = (lr_camera_model)model;
    cam->aperture_shape = (lr_aperture_shape)shape;
    cam->aperture_blades = (int)blades;
    set3(cam->position, pos);
    set3(cam->look_at, at);
    set3(cam->up, up);
    return lr_camera_validate(cam, err);
}

static lr_status parse_render(const cJSON *r, lr_render_settings *rs,
                              lr_error *err)
{
    static const char *const keys[] = {"width",     "height",  "spp",
                                       "sampler",   "seed",    "max_depth",
                                       "threads",   "tile_size", "depth",
                                       "region",    "plan",    "adaptive",
                                       NULL};
    /* Indexed by lr_sampler_kind. */
    static const char *const samplers[] = {"random", "grid", "jittered",
                                           "sobol", NULL};
    if (r == NULL)
        return LR_OK;
    if (!cJSON_IsObject(r))
        return lr__fail(err, LR_ERR_INVALID, "render",
                        "render must be an object");
    LR_TRY(lr__json_check_keys(r, "render", keys, err));
    long long w = rs->width, h = rs->height, spp = rs->spp,
              depth = rs->max_depth, th = rs->threads, tile = rs->tile_size;
    long long seed = (long long)rs->seed;
    LR_TRY(lr__json_int(r, "width", "render", 0, 1, LR__MAX_DIM, &w, err));
    LR_TRY(lr__json_int(r, "height", "render", 0, 1, LR__MAX_DIM, &h, err));
    LR_TRY(lr__json_int(r, "spp", "render", 0, 1, LR__MAX_SPP, &spp, err));
    LR_TRY(lr__json_int(r, "max_depth", "render", 0, 0, LR__MAX_DEPTH, &depth,
                        err));
    LR_TRY(lr__json_int(r, "threads", "render", 0, 0, LR__MAX_THREADS, &th,
                        err));
    LR_TRY(lr__json_int(r, "tile_size", "render", 0, 1, LR__MAX_TILE, &tile,
                        err));
    LR_TRY(lr__json_int(r, "seed", "render", 0, 0, (1LL << 53), &seed, err));
    LR_TRY(lr__json_bool(r, "depth", "render", 0, &rs->want_depth, err));
    LR_TRY(lr__json_bool(r, "plan", "render", 0, &rs->plan, err));
    const cJSON *ad = cJSON_GetObjectItemCaseSensitive(r, "adaptive");
    if (ad != NULL && cJSON_IsBool(ad)) {
        rs->adaptive = cJSON_IsTrue(ad);
    } else if (ad != NULL) {
        static const char *const akeys[] = {"threshold", "min_spp", "max_spp",
                                            NULL};
        const char *ap = "render.adaptive";
        if (!cJSON_IsObject(ad))
            return lr__fail(err, LR_ERR_INVALID, ap,
                            "%s must be true, false or an object "
                            "{\"threshold\", \"min_spp\", \"max_spp\"}",
                            ap);
        LR_TRY(lr__json_check_keys(ad, ap, akeys, err));
        long long lo = rs->adaptive_min_spp, hi = -1;
        LR_TRY(lr__json_number(ad, "threshold", ap, 0,
                               &rs->adaptive_threshold, err));
        LR_TRY(lr__json_int(ad, "min_spp", ap, 0, 1, LR__MAX_SPP, &lo, err));
        LR_TRY(lr__json_int(ad, "max_spp", ap, 0, 1, LR__MAX_SPP, &hi, err));
        rs->adaptive = 1;
        rs->adaptive_min_spp = (int)lo;
        /* The maximum is render.spp itself; max_spp is its other name
         * here, and the two must agree when both are given. */
        if (hi > 0) {
            if (cJSON_GetObjectItemCaseSensitive(r, "spp") != NULL &&
                hi != spp)
                return lr__fail(err, LR_ERR_INVALID,
                                "render.adaptive.max_spp",
                                "render.adaptive.max_spp (%lld) and render.spp "
                                "(%lld) disagree; give one of them",
                                hi, spp);
            spp = hi;
        }
    }
    int kind = (int)rs->sampler;
    LR_TRY(lr__json_enum(r, "sampler", "render", samplers, &kind, err));
    rs->sampler = (lr_sampler_kind)kind;
    const cJSON *reg = cJSON_GetObjectItemCaseSensitive(r, "region");
    if (reg != NULL) {
        if (!cJSON_IsArray(reg) || cJSON_GetArraySize(reg) != 4)
            return lr__fail(err, LR_ERR_INVALID, "render.region",
                            "render.region must be [x0, y0, x1, y1]");
        int k = 0;
        for (const cJSON *c = reg->child; c; c = c->next, k++) {
            double d = c->valuedouble;
            if (!cJSON_IsNumber(c) || d != floor(d) || d < 0 || d > 65536)
                return lr__fail(err, LR_ERR_INVALID, "render.region",
                                "render.region[%d] must be a whole number "
                                "of pixels between 0 and 65536",
                                k);
            rs->region[k] = (int)d;
        }
    }
    rs->width = (int)w;
    rs->height = (int)h;
    rs->spp = (int)spp;
    rs->max_depth = (int)depth;
    rs->threads = (int)th;
    rs->tile_size = (int)tile;
    rs->seed = (uint64_t)seed;
    return lr_render_settings_validate(rs, err);
}

lr_status lr__camera_apply_cjson(lr_camera *cam, const cJSON *obj,
                                 lr_error *err)
{
    lr_camera tmp = *cam;
    lr_status st = parse_camera(obj, &tmp, err);
    if (st == LR_OK)
        *cam = tmp;
    return st;
}

lr_status lr__render_apply_cjson(lr_render_settings *s, const cJSON *obj,
                                 lr_error *err)
{
    lr_render_settings tmp = *s;
    lr_status st = parse_render(obj, &tmp, err);
    if (st == LR_OK)
        *s = tmp;
    return st;
}

lr_status lr_camera_apply_json(lr_camera *cam, const char *json, size_t len,
                               lr_error *err)
{
    if (cam == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_camera_apply_json: NULL argument");
    cJSON *root = NULL;
    LR_TRY(lr__json_parse(json ? json : "", len, "camera", &root, err));
    lr_status st = lr__camera_apply_cjson(cam, root, err);
    cJSON_Delete(root);
    return st;
}

lr_status lr_render_settings_apply_json(lr_render_settings *s,
                                        const char *json, size_t len,
                                        lr_error *err)
{
    if (s == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_render_settings_apply_json: NULL argument");
    cJSON *root = NULL;
    LR_TRY(lr__json_parse(json ? json : "", len, "render", &root, err));
    lr_status st = lr__render_apply_cjson(s, root, err);
    cJSON_Delete(root);
    return st;
}

/* ---- the scene -------------------------------------------------------- */

static lr_status build(lr_scene *s, const cJSON *root, const char *base_dir,
                       lr_error *err)
{
    static const char *const keys[] = {"description", "camera",  "render",
                                       "background",  "materials", "lights",
                                       "objects",     NULL};
    if (!cJSON_IsObject(root))
        return lr__fail(err, LR_ERR_INVALID, "",
                        "a scene must be a JSON object");
    LR_TRY(lr__json_check_keys(root, "", keys, err));
    const char *desc = NULL;
    LR_TRY(lr__json_string(root, "description", "", 0, &desc, err));
    s->description = strdup(desc ? desc : "");
    if (s->description == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    lr_camera_default(&s->camera);
    lr_render_settings_default(&s->settings);
    LR_TRY(parse_camera(cJSON_GetObjectItemCaseSensitive(root, "camera"), &s->camera, err));
    LR_TRY(parse_render(cJSON_GetObjectItemCaseSensitive(root, "render"), &s->settings, err));
    LR_TRY(lr__json_rgb(root, "background", "", 0, &s->background, err));
    LR_TRY(parse_materials( s, cJSON_GetObjectItemCaseSensitive(root, "materials"), err));
    LR_TRY(parse_lights(s, cJSON_GetObjectItemCaseSensitive(root, "lights"), err));
    LR_TRY(lr__scene_begin(s, err));
    LR_TRY(parse_objects(s, cJSON_GetObjectItemCaseSensitive(root, "objects"), base_dir, err));
    LR_TRY(lr__scene_commit(s, err));
    return LR_OK;
}

lr_status lr_scene_load_json(const char *json, size_t len,
                             const char *base_dir,
                             const char *const *overrides, size_t n_overrides,
                             lr_scene **out, lr_error *err)
{
    if (out == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_scene_load_json: NULL argument");
    *out = NULL;
    if (len > MAX_SCENE_BYTES)
        return lr__fail(err, LR_ERR_LIMIT, NULL,
                        "scene JSON is %zu bytes, more than the limit of %u",
                        len, MAX_SCENE_BYTES);
    cJSON *root = NULL;
    lr_status st = lr__json_parse(json ? json : "", len, "scene", &root, err);
    if (st != LR_OK)
        return st;
    for (size_t i = 0; i < n_overrides; i++) {
        st = lr__json_apply_override(root, overrides[i], err);
        if (st != LR_OK) {
            cJSON_Delete(root);
            return st;
        }
    }
    lr_scene *s = calloc(1, sizeof *s);
    if (s == NULL) {
        cJSON_Delete(root);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    st = build(s, root, base_dir, err);
    cJSON_Delete(root);
    if (st != LR_OK) {
        lr_scene_free(s);
        return st;
    }
    *out = s;
    return LR_OK;
}

lr_status lr_scene_load_file(const char *path, const char *const *overrides,
                             size_t n_overrides, lr_scene **out,
                             lr_error *err)
{
    if (path == NULL || out == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_scene_load_file: NULL argument");
    *out = NULL;
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return lr__fail(err, LR_ERR_IO, NULL, "cannot open %s: %s", path,
                        strerror(errno));
    char *buf = NULL;
    size_t len = 0, cap = 0;
    lr_status st = LR_OK;
    for (;;) {
        if (len == cap) {
            if (cap >= MAX_SCENE_BYTES) {
                st = lr__fail(err, LR_ERR_LIMIT, NULL,
                              "%s is larger than the limit of %u bytes", path,
                              MAX_SCENE_BYTES);
                break;
            }
            cap = cap ? 2 * cap : 65536;
            char *grown = realloc(buf, cap + 1);
            if (grown == NULL) {
                st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
                break;
            }
            buf = grown;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            if (ferror(f))
                st = lr__fail(err, LR_ERR_IO, NULL, "cannot read %s: %s",
                              path, strerror(errno));
            break;
        }
    }
    fclose(f);
    if (st != LR_OK) {
        free(buf);
        return st;
    }
    /* Mesh paths are relative to the scene file's directory. */
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash == NULL)
        snprintf(dir, sizeof dir, ".");
    else if (slash == dir)
        dir[1] = '\0';
    else
        *slash = '\0';
    st = lr_scene_load_json(buf ? buf : "", len, dir, overrides, n_overrides,
                            out, err);
    free(buf);
    /* Name the file in JSON syntax errors, which only say "scene". */
    if (st == LR_ERR_INVALID && err != NULL &&
        strncmp(err->message, "scene: ", 7) == 0) {
        char msg[sizeof err->message];
        snprintf(msg, sizeof msg, "%s: %s", path, err->message + 7);
        snprintf(err->message, sizeof err->message, "%s", msg);
    }
    return st;
}

void lr_scene_free(lr_scene *s)
{
    if (s == NULL)
        return;
    for (size_t i = 0; i < s->n_geoms; i++)
        free(s->geoms[i].corner_normals);
    free(s->geoms);
    free(s->planes);
    for (size_t i = 0; i < s->n_materials; i++)
        free(s->materials[i].name);
    free(s->materials);
    free(s->lights);
    free(s->description);
    if (s->rtc != NULL)
        rtcReleaseScene(s->rtc);
    if (s->device != NULL)
        rtcReleaseDevice(s->device);
    free(s);
}

void lr_scene_camera(const lr_scene *s, lr_camera *cam) { *cam = s->camera; }

void lr_scene_settings(const lr_scene *s, lr_render_settings *rs)
{
    *rs = s->settings;
}

size_t lr_scene_primitive_count(const lr_scene *s) { return s->n_primitives; }

const char *lr_scene_description(const lr_scene *s)
{
    return s->description ? s->description : "";
}
