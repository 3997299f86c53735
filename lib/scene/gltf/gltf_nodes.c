/*
 * gltf_nodes.c: what a glTF's node hierarchy places, read from the checked
 * JSON in double precision: the nodes' world transforms, the camera and
 * KHR_lights_punctual's lights (docs/gltf.md has the mapping and the
 * units).
 */
#include "scene/gltf/gltf_doc.h"
#include "json/json_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

static double num(const cJSON *a, int i)
{
    return cJSON_GetArrayItem(a, i)->valuedouble;
}

/* A node's own transform (spec 3.5.2). */
static lr__xform local(const cJSON *node)
{
    lr__xform x = lr__xform_identity();
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(node, "matrix");
    if (m != NULL) {
        /* Column-major: element (row r, column c) is m[4 c + r]. */
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++)
                x.m[r][c] = num(m, 4 * c + r);
        return x;
    }
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(node, "translation");
    const cJSON *q = cJSON_GetObjectItemCaseSensitive(node, "rotation");
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(node, "scale");
    double qx = 0, qy = 0, qz = 0, qw = 1;
    if (q != NULL) {
        qx = num(q, 0), qy = num(q, 1), qz = num(q, 2), qw = num(q, 3);
        double len = sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
        if (len > 0)
            qx /= len, qy /= len, qz /= len, qw /= len;
        else
            qw = 1;
    }
    /* The rotation matrix of a unit quaternion (Shoemake 1985). */
    double R[3][3] = {{1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw),
                       2 * (qx * qz + qy * qw)},
                      {2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz),
                       2 * (qy * qz - qx * qw)},
                      {2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw),
                       1 - 2 * (qx * qx + qy * qy)}};
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++)
            x.m[r][c] = R[r][c] * (s ? num(s, c) : 1.0);
        x.m[r][3] = t ? num(t, r) : 0.0;
    }
    return x;
}

/* World transforms of node i's tree under `parent`; `mark` into active
 * (1: in the displayed scene). */
static void walk(const lr__gltf_doc *d, int i, const lr__xform *parent,
                 lr__xform *world, unsigned char *active, int mark)
{
    const cJSON *node = d->node_at[i];
    lr__xform l = local(node);
    world[i] = lr__xform_mul(parent, &l);
    active[i] = (unsigned char)mark;
    int n;
    const cJSON *ch = lr__gltf_array(node, "children", &n);
    for (const cJSON *c = ch ? ch->child : NULL; c; c = c->next)
        walk(d, (int)c->valuedouble, &world[i], world, active, mark);
}

lr_status lr__gltf_world(const lr__gltf_doc *d, lr__xform **world,
                         unsigned char **active, lr_error *err)
{
    size_t n = d->n_nodes > 0 ? (size_t)d->n_nodes : 1;
    *world = malloc(n * sizeof **world);
    *active = calloc(n, 1);
    unsigned char *child = calloc(n, 1);
    if (*world == NULL || *active == NULL || child == NULL) {
        free(*world);
        free(*active);
        free(child);
        *world = NULL;
        *active = NULL;
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    for (size_t i = 0; i < n; i++)
        (*world)[i] = lr__xform_identity();
    int nn, ns;
    const cJSON *nodes = lr__gltf_array(d->root, "nodes", &nn);
    const cJSON *scenes = lr__gltf_array(d->root, "scenes", &ns);
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(d->root, "scene");
    const cJSON *scene = cJSON_GetArrayItem(scenes,
                                            sc ? (int)sc->valuedouble : 0);
    int nr;
    const cJSON *roots = lr__gltf_array(scene, "nodes", &nr);
    lr__xform id = lr__xform_identity();
    /* check_nodes made the graph a forest at most LR__GLTF_MAX_DEPTH
     * deep, so the walk ends, and its recursion with it. */
    for (const cJSON *r = roots ? roots->child : NULL; r; r = r->next)
        walk(d, (int)r->valuedouble, &id, *world, *active, 1);
    /* The trees outside the displayed scene get their transforms too: a
     * skin's joints need not be in it (spec 3.7.3). */
    for (const cJSON *o = nodes ? nodes->child : NULL; o; o = o->next) {
        int k;
        const cJSON *ch = lr__gltf_array(o, "children", &k);
        for (const cJSON *c = ch ? ch->child : NULL; c; c = c->next)
            child[(int)c->valuedouble] = 1;
    }
    for (int i = 0; i < nn; i++)
        if (!child[i] && !(*active)[i])
            walk(d, i, &id, *world, *active, 0);
    free(child);
    return LR_OK;
}

/* ---- lights --------------------------------------------------------------- */

/* An optional number member in [lo, hi]. */
static lr_status get_num(const lr__gltf_doc *d, const cJSON *o, const char *p,
                         const char *key, double lo, double hi, double *out,
                         lr_error *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (v == NULL)
        return LR_OK;
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= lo && v->valuedouble <= hi))
        return lr__gltf_fail(d, err, "%s.%s must be a number from %g to %g", p,
                             key, lo, hi);
    *out = v->valuedouble;
    return LR_OK;
}

lr_status lr__gltf_lights(lr_scene *s, const lr__gltf_doc *d,
                          const lr__xform *world, const unsigned char *active,
                          const lr__xform *place, lr_error *err)
{
    int nl, nn;
    const cJSON *lights = lr__gltf_array(
        lr__gltf_member(d->root, "extensions", "KHR_lights_punctual"), "lights",
        &nl);
    const cJSON *nodes = lr__gltf_array(d->root, "nodes", &nn);
    int i = 0;
    for (const cJSON *node = nodes ? nodes->child : NULL; node;
         node = node->next, i++) {
        const cJSON *ext = lr__gltf_member(node, "extensions",
                                           "KHR_lights_punctual");
        const cJSON *li = cJSON_GetObjectItemCaseSensitive(ext, "light");
        /* check_nodes made `light`, when present, an index of lights. */
        if (!active[i] || li == NULL)
            continue;
        int k = (int)li->valuedouble;
        const cJSON *l = cJSON_GetArrayItem(lights, k);
        char p[96];
        snprintf(p, sizeof p, "extensions.KHR_lights_punctual.lights[%d]", k);
        if (!cJSON_IsObject(l))
            return lr__gltf_fail(d, err, "%s must be an object", p);
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(l, "type");
        const char *t = cJSON_IsString(type) ? type->valuestring : "";
        int dir = strcmp(t, "directional") == 0;
        if (!dir && strcmp(t, "point") != 0 && strcmp(t, "spot") != 0)
            return lr__gltf_fail(d, err,
                                 "%s.type must be \"point\", "
                                 "\"spot\" or \"directional\"",
                                 p);
        double c[3] = {1, 1, 1}, intensity = 1;
        const cJSON *col = cJSON_GetObjectItemCaseSensitive(l, "color");
        if (col != NULL) {
            int ok = cJSON_IsArray(col) && cJSON_GetArraySize(col) == 3;
            for (int j = 0; ok && j < 3; j++) {
                const cJSON *v = cJSON_GetArrayItem(col, j);
                ok = cJSON_IsNumber(v) && v->valuedouble >= 0 &&
                     v->valuedouble <= 1e6;
                c[j] = ok ? v->valuedouble : 0;
            }
            if (!ok)
                return lr__gltf_fail(d, err,
                                     "%s.color must be 3 numbers "
                                     "from 0 to 1e6",
                                     p);
        }
        LR_TRY(get_num(d, l, p, "intensity", 0, 1e12, &intensity, err));
        if (cJSON_GetObjectItemCaseSensitive(l, "range") != NULL)
            lr__gltf_warn(s, d,
                          "%s.range is ignored (lights fall off as "
                          "1/d^2 without a cut-off)",
                          p);
        /* The spec's cone defaults: inner 0, outer pi/4, and 0 <= inner
         * < outer <= pi/2. */
        double inner = 0, outer = M_PI / 4;
        if (t[0] == 's') {
            const cJSON *sp = cJSON_GetObjectItemCaseSensitive(l, "spot");
            char q[112];
            snprintf(q, sizeof q, "%s.spot", p);
            if (sp != NULL && !cJSON_IsObject(sp))
                return lr__gltf_fail(d, err, "%s must be an object", q);
            LR_TRY(
                get_num(d, sp, q, "innerConeAngle", 0, M_PI / 2, &inner, err));
            LR_TRY(
                get_num(d, sp, q, "outerConeAngle", 0, M_PI / 2, &outer, err));
            if (!(outer > 0 && inner < outer))
                return lr__gltf_fail(d, err,
                                     "%s: innerConeAngle (%g) must "
                                     "be less than outerConeAngle (%g), "
                                     "which must be more than 0",
                                     q, inner, outer);
        }
        lr__xform m = lr__xform_mul(place, &world[i]);
        lr__light L;
        memset(&L, 0, sizeof L);
        /* glTF gives candela (point, spot) and lux (directional); taken
         * as W/sr and W/m^2 of lensray's RGB radiometry, unscaled, as
         * glTF viewers do (docs/gltf.md). */
        L.power = v3(c[0] * intensity, c[1] * intensity, c[2] * intensity);
        /* Directional and spot lights shine down their node's -z. */
        lr__v3 o = lr__xform_point(&m, v3(0, 0, 0));
        lr__v3 f = v3_sub(lr__xform_point(&m, v3(0, 0, -1)), o);
        if (t[0] != 'p' && !(v3_len(f) > 0))
            return lr__gltf_fail(d, err,
                                 "nodes[%d] squashes the "
                                 "direction of %s to nothing",
                                 i, p);
        if (dir) {
            L.kind = LR__LIGHT_DIRECTIONAL;
            L.direction = v3_norm(f);
        } else {
            L.kind = LR__LIGHT_POINT;
            L.position = o;
            LR_TRY(lr__check_extent(v3_maxabs(L.position), d->fp, err));
            if (t[0] == 's')
                lr__spot_set(&L, f, inner, outer);
        }
        lr__light *grown = realloc(s->lights,
                                   (s->n_lights + 1) * sizeof *grown);
        if (grown == NULL)
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        s->lights = grown;
        s->lights[s->n_lights++] = L;
    }
    return LR_OK;
}

/* ---- the camera ----------------------------------------------------------- */

/* The node of the camera to use, or -1. */
static int find_camera(const lr__gltf_doc *d, const unsigned char *active,
                       const lr__gltf_options *o)
{
    int nn, nc;
    const cJSON *nodes = lr__gltf_array(d->root, "nodes", &nn);
    const cJSON *cams = lr__gltf_array(d->root, "cameras", &nc);
    int i = 0;
    for (const cJSON *n = nodes ? nodes->child : NULL; n; n = n->next, i++) {
        const cJSON *c = cJSON_GetObjectItemCaseSensitive(n, "camera");
        if (!active[i] || c == NULL)
            continue;
        if (o->camera == LR__GLTF_CAMERA_FIRST)
            return i;
        const cJSON *cn = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetArrayItem(cams, (int)c->valuedouble), "name");
        const cJSON *nn2 = cJSON_GetObjectItemCaseSensitive(n, "name");
        if ((cJSON_IsString(cn) &&
             strcmp(cn->valuestring, o->camera_name) == 0) ||
            (cJSON_IsString(nn2) &&
             strcmp(nn2->valuestring, o->camera_name) == 0))
            return i;
    }
    return -1;
}

/* A view of the box [lo, hi] from the front, a little above and to the
 * right, far enough for its bounding sphere to fit the vertical field of
 * view. */
static lr_status auto_frame(lr_scene *s, const lr__gltf_doc *d, lr__v3 lo,
                            lr__v3 hi, lr_error *err)
{
    if (!(lo.x <= hi.x))
        return lr__gltf_fail(d, err,
                             "it has no camera and no triangles "
                             "to frame (points and lines are not drawn)");
    lr_camera *c = &s->camera;
    lr__v3 mid = v3_scale(v3_add(lo, hi), 0.5);
    double r = 0.5 * v3_len(v3_sub(hi, lo));
    if (!(r > 0))
        r = 1;
    double dist = r / sin(0.5 * c->fov * PI / 180) * 1.05;
    lr__v3 eye = v3_madd(mid, v3_norm(v3(0.35, 0.3, 1)), dist);
    c->position[0] = eye.x, c->position[1] = eye.y, c->position[2] = eye.z;
    c->look_at[0] = mid.x, c->look_at[1] = mid.y, c->look_at[2] = mid.z;
    c->up[0] = 0, c->up[1] = 1, c->up[2] = 0;
    c->focus_distance = dist;
    return LR_OK;
}

lr_status lr__gltf_camera(lr_scene *s, const lr__gltf_doc *d,
                          const lr__xform *world, const unsigned char *active,
                          const lr__gltf_options *o, lr__v3 lo, lr__v3 hi,
                          lr_error *err)
{
    if (o->camera == LR__GLTF_CAMERA_NONE)
        return LR_OK;
    int node = find_camera(d, active, o);
    if (node < 0 && o->camera == LR__GLTF_CAMERA_NAMED)
        return lr__gltf_fail(d, err,
                             "no camera (or camera node) is called "
                             "\"%.80s\"",
                             o->camera_name);
    lr_camera c = s->camera;
    if (node < 0) {
        LR_TRY(auto_frame(s, d, lo, hi, err));
        if (lr_camera_validate(&s->camera, err) == LR_OK)
            return LR_OK;
        /* A box of denormal size (a fuzzer's) frames at a focus distance
         * no camera takes: the error names the file. */
        char why[sizeof err->message];
        snprintf(why, sizeof why, "%s", err->message);
        return lr__gltf_fail(d, err,
                             "it has no camera, and the camera "
                             "framing its meshes (%g across) is refused: %s",
                             v3_len(v3_sub(hi, lo)), why);
    }
    int nn, nc;
    const cJSON *nd = cJSON_GetArrayItem(lr__gltf_array(d->root, "nodes", &nn),
                                         node);
    int k = (int)cJSON_GetObjectItemCaseSensitive(nd, "camera")->valuedouble;
    const cJSON *cam = cJSON_GetArrayItem(
        lr__gltf_array(d->root, "cameras", &nc), k);
    char p[64];
    snprintf(p, sizeof p, "cameras[%d]", k);
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(cam, "type");
    const cJSON *persp = cJSON_GetObjectItemCaseSensitive(cam, "perspective");
    if (!cJSON_IsString(type) || strcmp(type->valuestring, "perspective") ||
        !cJSON_IsObject(persp))
        return lr__gltf_fail(d, err,
                             "%s: only perspective cameras are "
                             "read (type \"perspective\" with a "
                             "\"perspective\" object)",
                             p);
    double yfov = -1, aspect = 0;
    snprintf(p, sizeof p, "cameras[%d].perspective", k);
    LR_TRY(get_num(d, persp, p, "yfov", 1e-9, PI - 1e-9, &yfov, err));
    LR_TRY(get_num(d, persp, p, "aspectRatio", 1e-6, 1e6, &aspect, err));
    if (yfov < 0)
        return lr__gltf_fail(d, err, "%s.yfov is required", p);
    lr__xform m = lr__xform_mul(&o->place, &world[node]);
    /* The camera looks down its node's -z with +y up (spec 3.10.1). */
    lr__v3 eye = lr__xform_point(&m, v3(0, 0, 0));
    lr__v3 fwd = v3_sub(lr__xform_point(&m, v3(0, 0, -1)), eye);
    lr__v3 up = v3_sub(lr__xform_point(&m, v3(0, 1, 0)), eye);
    if (!(v3_len(fwd) > 0) || !(v3_len(v3_cross(fwd, up)) > 0))
        return lr__gltf_fail(d, err,
                             "nodes[%d]'s transform squashes the "
                             "camera's view",
                             node);
    /* A mirroring transform (a negative scale) mirrors the spec's view
     * (its view matrix is the node's inverse), which a camera of
     * position, look_at and up cannot: say so rather than draw the
     * mirror image of it silently. */
    if (lr__xform_det(&m) < 0)
        lr__gltf_warn(s, d,
                      "nodes[%d] mirrors the camera (a negative "
                      "scale): the image is drawn unmirrored",
                      node);
    lr__v3 at = v3_add(eye, v3_norm(fwd));
    c.position[0] = eye.x, c.position[1] = eye.y, c.position[2] = eye.z;
    c.look_at[0] = at.x, c.look_at[1] = at.y, c.look_at[2] = at.z;
    c.up[0] = up.x, c.up[1] = up.y, c.up[2] = up.z;
    c.fov = yfov * 180 / PI;
    /* Focus and aperture: cameras[k].extras.lensray (docs/gltf.md). */
    const cJSON *ex = lr__gltf_member(cam, "extras", "lensray");
    snprintf(p, sizeof p, "cameras[%d].extras.lensray", k);
    double ap = c.aperture_radius, fn = c.f_number;
    LR_TRY(get_num(d, ex, p, "focus_distance", 1e-9, 1e15, &c.focus_distance,
                   err));
    LR_TRY(get_num(d, ex, p, "aperture_radius", 0, 1e15, &ap, err));
    LR_TRY(get_num(d, ex, p, "f_number", 0.1, 1e6, &fn, err));
    LR_TRY(get_num(d, ex, p, "focal_length_mm", 0.1, 1e6, &c.focal_length_mm,
                   err));
    if (ex != NULL && (ap != c.aperture_radius || fn != c.f_number)) {
        c.aperture_radius = ap;
        c.f_number = fn;
        /* Without a focal length, the one of a 24 mm tall (full-frame)
         * sensor with this vertical field of view. */
        if (c.focal_length_mm <= 0)
            c.focal_length_mm = 12.0 / tan(0.5 * yfov);
        if (c.model == LR_CAMERA_PINHOLE && (ap > 0 || fn > 0))
            c.model = LR_CAMERA_THINLENS;
    }
    if (aspect > 0 && !o->height_given) {
        double h = floor(s->settings.width / aspect + 0.5);
        /* Too tall an image is an error, not a silent 65536 rows (an
         * aspectRatio of 1e-6 made 160 x 65536 pixels). */
        if (h > LR__MAX_DIM)
            return lr__gltf_fail(d, err,
                                 "cameras[%d].perspective.aspectRatio %g "
                                 "makes the image %d x %.0f pixels, more "
                                 "than %d rows (set render.height)",
                                 k, aspect, s->settings.width, h, LR__MAX_DIM);
        s->settings.height = h < 1 ? 1 : (int)h;
    }
    LR_TRY(lr_camera_validate(&c, err));
    s->camera = c;
    s->camera_gltf = 1;
    return LR_OK;
}
