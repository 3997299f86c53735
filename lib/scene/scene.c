/*
 * scene.c: the scene's Embree side: building geometry and committing it;
 * the scene's destructor and accessors.  Tracing is in trace.c.
 */
#include "scene/scene.h"
#include "scene/envmap.h"
#include "scene/light.h"

#include <float.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Embree reports errors through a callback; keep the last message per
 * device so that the failing call can put it in the lr_error. */
static _Thread_local char embree_msg[256];
static _Thread_local enum RTCError embree_code;

static void on_embree_error(void *user, enum RTCError code, const char *str)
{
    (void)user;
    embree_code = code;
    snprintf(embree_msg, sizeof embree_msg, "Embree error %d: %s", (int)code,
             str ? str : "(no message)");
}

/* Embree's failure; out of memory is LR_ERR_NOMEM like any allocation
 * that fails (code: rtcGetDeviceError's, or RTC_ERROR_NONE for the one
 * the callback saw on this thread). */
static lr_status embree_fail_code(lr_error *err, const char *what,
                                  enum RTCError code)
{
    if (code == RTC_ERROR_NONE)
        code = embree_code;
    return lr__fail(
        err, code == RTC_ERROR_OUT_OF_MEMORY ? LR_ERR_NOMEM : LR_ERR_EMBREE,
        NULL, "%s failed: %s", what,
        embree_msg[0] ? embree_msg : "unknown Embree error");
}

static lr_status embree_fail(lr_error *err, const char *what)
{
    return embree_fail_code(err, what, RTC_ERROR_NONE);
}

const char *lr__embree_config = NULL;

enum RTCSceneFlags lr__scene_flags(const lr_scene *s)
{
    return s->not_robust ? RTC_SCENE_FLAG_NONE : RTC_SCENE_FLAG_ROBUST;
}

lr_status lr__scene_begin(lr_scene *s, lr_error *err)
{
    embree_msg[0] = '\0';
    embree_code = RTC_ERROR_NONE;
    const char *env = getenv("LENSRAY_EMBREE_CONFIG");
    const char *config = lr__embree_config != NULL ? lr__embree_config : env;
    s->device = rtcNewDevice(config);
    if (s->device == NULL && config == env)
        return lr__fail(err, LR_ERR_EMBREE, NULL,
                        "creating the Embree device with "
                        "LENSRAY_EMBREE_CONFIG=\"%s\" failed: %s",
                        env,
                        embree_msg[0] ? embree_msg : "unknown Embree error");
    if (s->device == NULL)
        return embree_fail(err, "creating the Embree device");
    rtcSetDeviceErrorFunction(s->device, on_embree_error, NULL);
    s->rtc = rtcNewScene(s->device);
    if (s->rtc == NULL)
        return embree_fail(err, "creating the Embree scene");
    /* Robust traversal ("avoids optimizations that reduce arithmetic
     * accuracy", for rays through the edges of neighbouring primitives,
     * rtcSetSceneFlags(3)) unless the scene's "accel" turns it off: it
     * costs about 12% of a bench render (docs/scene-format.md), and
     * Mitsuba 3 leaves it off by default. */
    rtcSetSceneFlags(s->rtc, lr__scene_flags(s));
    rtcSetSceneBuildQuality(s->rtc, RTC_BUILD_QUALITY_HIGH);
    return LR_OK;
}

static lr_status push_geom(lr_scene *s, const lr__geom *g, unsigned id,
                           lr_error *err)
{
    if (id != s->n_geoms)
        return lr__fail(err, LR_ERR_EMBREE, NULL,
                        "Embree gave geometry ID %u, expected %zu", id,
                        s->n_geoms);
    lr__geom *grown = realloc(s->geoms, (s->n_geoms + 1) * sizeof *grown);
    if (grown == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    s->geoms = grown;
    s->geoms[s->n_geoms++] = *g;
    return LR_OK;
}

static void extend(lr_scene *s, double m)
{
    if (m > s->extent)
        s->extent = m;
}

lr_status lr__scene_add_triangles(lr_scene *s, const float *vertices,
                                  size_t n_vertices, const unsigned *indices,
                                  size_t n_triangles, float *corner_normals,
                                  int material, const char *field,
                                  lr_error *err)
{
    lr_status lim = lr__scene_limit_triangles(s, n_triangles, field, err);
    if (lim != LR_OK) {
        free(corner_normals);
        return lim;
    }
    RTCGeometry geom = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (geom == NULL) {
        free(corner_normals);
        return embree_fail(err, "creating a triangle mesh");
    }
    float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                        RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                        n_vertices);
    unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                           RTC_FORMAT_UINT3,
                                           3 * sizeof(unsigned), n_triangles);
    if (vb == NULL || ib == NULL) {
        rtcReleaseGeometry(geom);
        free(corner_normals);
        return embree_fail(err, "allocating a triangle mesh");
    }
    memcpy(vb, vertices, n_vertices * 3 * sizeof(float));
    memcpy(ib, indices, n_triangles * 3 * sizeof(unsigned));
    for (size_t i = 0; i < 3 * n_vertices; i++)
        extend(s, fabs((double)vertices[i]));
    rtcCommitGeometry(geom);
    unsigned id = rtcAttachGeometry(s->rtc, geom);
    rtcReleaseGeometry(geom);

    lr__geom g = {0};
    g.kind = LR__GEOM_TRIANGLES;
    g.material = material;
    g.corner_normals = corner_normals;
    g.n_triangles = n_triangles;
    g.vertices = vb;
    g.indices = ib;
    lr_status st = push_geom(s, &g, id, err);
    if (st != LR_OK) {
        free(corner_normals);
        return st;
    }
    s->n_primitives += n_triangles;
    s->limit_triangles += n_triangles;
    return LR_OK;
}

lr_status lr__scene_add_sphere(lr_scene *s, lr__v3 center, double radius,
                               int material, lr_error *err)
{
    RTCGeometry geom = rtcNewGeometry(s->device,
                                      RTC_GEOMETRY_TYPE_SPHERE_POINT);
    if (geom == NULL)
        return embree_fail(err, "creating a sphere");
    float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                        RTC_FORMAT_FLOAT4, 4 * sizeof(float),
                                        1);
    if (vb == NULL) {
        rtcReleaseGeometry(geom);
        return embree_fail(err, "allocating a sphere");
    }
    vb[0] = (float)center.x;
    vb[1] = (float)center.y;
    vb[2] = (float)center.z;
    vb[3] = (float)radius;
    extend(s, v3_maxabs(center) + radius);
    rtcCommitGeometry(geom);
    unsigned id = rtcAttachGeometry(s->rtc, geom);
    rtcReleaseGeometry(geom);

    lr__geom g = {0};
    g.kind = LR__GEOM_SPHERE;
    g.material = material;
    g.center = center;
    g.radius = radius;
    lr_status st = push_geom(s, &g, id, err);
    if (st == LR_OK)
        s->n_primitives++;
    return st;
}

lr_status lr__scene_add_plane(lr_scene *s, lr__v3 point, lr__v3 normal,
                              int material, lr_error *err)
{
    lr__geom *grown = realloc(s->planes, (s->n_planes + 1) * sizeof *grown);
    if (grown == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    s->planes = grown;
    lr__geom g = {0};
    g.kind = LR__GEOM_PLANE;
    g.material = material;
    g.center = point;
    g.normal = v3_norm(normal);
    s->planes[s->n_planes++] = g;
    s->n_primitives++;
    return LR_OK;
}

/* The unit geometric normals of a mesh's triangles, as lr__hit_complete
 * and finish_hit compute them (the same operations in the same order, so
 * the same bits): malloc'd, 3 per triangle; NULL when out of memory. */
static double *face_normals(const lr__geom *g)
{
    /* (At least one, so that NULL means out of memory.) */
    double *ng = malloc(3 * (g->n_triangles + 1) * sizeof *ng);
    if (ng == NULL)
        return NULL;
    for (size_t t = 0; t < g->n_triangles; t++) {
        const unsigned *ix = &g->indices[3 * t];
        const float *a = &g->vertices[3 * (size_t)ix[0]];
        const float *b = &g->vertices[3 * (size_t)ix[1]];
        const float *c = &g->vertices[3 * (size_t)ix[2]];
        lr__v3 va = v3(a[0], a[1], a[2]);
        lr__v3 n = v3_norm(v3_cross(v3_sub(v3(b[0], b[1], b[2]), va),
                                    v3_sub(v3(c[0], c[1], c[2]), va)));
        ng[3 * t] = n.x, ng[3 * t + 1] = n.y, ng[3 * t + 2] = n.z;
    }
    return ng;
}

/* lr__geom.chunk_bounds of g, if g is a mesh of more than LR__GEOM_FEW
 * triangles.  0: out of memory. */
static int chunk_bounds(lr__geom *g)
{
    if (g->kind != LR__GEOM_TRIANGLES || g->n_triangles <= LR__GEOM_FEW)
        return 1;
    size_t n_chunks = (g->n_triangles + LR__GEOM_CHUNK - 1) / LR__GEOM_CHUNK;
    g->chunk_bounds = malloc(n_chunks * 6 * sizeof *g->chunk_bounds);
    if (g->chunk_bounds == NULL)
        return 0;
    for (size_t c = 0; c < n_chunks; c++) {
        lr__v3 pts[3 * LR__GEOM_CHUNK];
        size_t n = 0;
        for (size_t t = c * LR__GEOM_CHUNK;
             t < g->n_triangles && t < (c + 1) * LR__GEOM_CHUNK; t++)
            for (int k = 0; k < 3; k++) {
                const float *v = &g->vertices[3 * g->indices[3 * t + k]];
                pts[n++] = v3(v[0], v[1], v[2]);
            }
        v3_bounds(pts, n, &g->chunk_bounds[6 * c], &g->chunk_bounds[6 * c + 3]);
    }
    return 1;
}

lr__scene_cache *lr__scene_cache_set(lr__scene_cache *const *slot,
                                     lr__scene_cache *c)
{
    lr__scene_cache *expected = NULL;
    /* The slot is the scene's one field that renders sharing it may set
     * (its owner's docs: scene.h); a const scene is otherwise read only. */
    lr__scene_cache **s = (lr__scene_cache **)slot;
    if (__atomic_compare_exchange_n(s, &expected, c, 0, __ATOMIC_ACQ_REL,
                                    __ATOMIC_ACQUIRE))
        return c;
    return expected;
}

lr_status lr__scene_commit(lr_scene *s, lr_error *err)
{
    s->all_lambert = 1;
    for (size_t i = 0; i < s->n_geoms; i++) {
        lr__geom *g = &s->geoms[i];
        const lr__material *m = &s->materials[g->material];
        g->lambert_triangles = g->kind == LR__GEOM_TRIANGLES &&
                               !(v3_maxc(m->specular) > 0.0) &&
                               !(v3_maxc(m->reflect) > 0.0) &&
                               !(v3_maxc(m->transmit) > 0.0) &&
                               v3_maxc(m->diffuse) > 0.0 &&
                               !(v3_maxc(m->emission) > 0.0) &&
                               m->normal_tex == NULL;
        s->all_lambert &= g->lambert_triangles;
        if (!chunk_bounds(g))
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        if (g->kind == LR__GEOM_TRIANGLES && m->normal_tex != NULL &&
            g->corner_uv != NULL && g->tangents == NULL) {
            g->tangents = lr__triangle_tangents(g);
            if (g->tangents == NULL)
                return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
        if (!g->lambert_triangles)
            continue;
        g->albedo = m->diffuse;
        g->albedo_textured = m->diffuse_tex != NULL;
        free(g->face_ng);
        g->face_ng = face_normals(g);
        if (g->face_ng == NULL)
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    /* The scene's size: its geometry's (extent), its planes' points and
     * its lights' positions; 1 for a scene at the origin alone. */
    double size = s->extent;
    for (size_t i = 0; i < s->n_planes; i++)
        size = fmax(size, v3_maxabs(s->planes[i].center));
    for (size_t i = 0; i < s->n_lights; i++)
        if (s->lights[i].kind == LR__LIGHT_POINT)
            size = fmax(size, v3_maxabs(s->lights[i].position));
    s->eps_floor = size > 0.0 && size < 1.0 ? size : 1.0;
    embree_msg[0] = '\0';
    embree_code = RTC_ERROR_NONE;
    rtcCommitScene(s->rtc);
    enum RTCError code = rtcGetDeviceError(s->device);
    if (code != RTC_ERROR_NONE)
        return embree_fail_code(err, "building the Embree scene", code);
    return LR_OK;
}

/* ---- the scene's life ------------------------------------------------ */

void lr_scene_free(lr_scene *s)
{
    if (s == NULL)
        return;
    lr__file_log_free(&s->files);
    for (size_t i = 0; i < s->n_geoms; i++) {
        free(s->geoms[i].corner_normals);
        free(s->geoms[i].corner_uv);
        free(s->geoms[i].tangents);
        free(s->geoms[i].chunk_bounds);
        free(s->geoms[i].face_ng);
    }
    free(s->geoms);
    free(s->planes);
    for (size_t i = 0; i < s->n_materials; i++) {
        free(s->materials[i].name);
        free(s->materials[i].diffuse_file);
        free(s->materials[i].emission_file);
        free(s->materials[i].roughness_file);
    }
    for (size_t i = 0; i < s->n_textures; i++) {
        lr__texture_free(s->textures[i]);
        free(s->texture_paths[i]);
    }
    free(s->textures);
    free(s->texture_paths);
    free(s->texture_srgb);
    free(s->materials);
    free(s->lights);
    free(s->emitters);
    free(s->emitter_cdf);
    lr__envmap_free(s->env);
    if (s->plan_cache != NULL)
        s->plan_cache->free(s->plan_cache);
    free(s->description);
    free(s->warnings);
    if (s->rtc_few != NULL)
        rtcReleaseScene(s->rtc_few);
    if (s->rtc != NULL)
        rtcReleaseScene(s->rtc);
    if (s->device != NULL)
        rtcReleaseDevice(s->device);
    free(s);
}

void lr__scene_warn(lr_scene *s, const char *fmt, ...)
{
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    size_t have = s->warnings ? strlen(s->warnings) : 0;
    /* A file with many ignored parts should not grow this without end. */
    if (have > 16384)
        return;
    char *w = realloc(s->warnings, have + strlen(line) + 2);
    if (w == NULL)
        return;
    snprintf(w + have, strlen(line) + 2, "%s\n", line);
    s->warnings = w;
}

const char *lr_scene_warnings(const lr_scene *s)
{
    return s != NULL && s->warnings != NULL ? s->warnings : "";
}

void lr_scene_camera(const lr_scene *s, lr_camera *cam)
{
    if (cam == NULL)
        return;
    if (s == NULL)
        lr_camera_default(cam);
    else
        *cam = s->camera;
}

void lr_scene_settings(const lr_scene *s, lr_render_settings *rs)
{
    if (rs == NULL)
        return;
    if (s == NULL)
        lr_render_settings_default(rs);
    else
        *rs = s->settings;
}

size_t lr_scene_primitive_count(const lr_scene *s)
{
    return s != NULL ? s->n_primitives : 0;
}

int lr_scene_files_changed(const lr_scene *s)
{
    return s != NULL && lr__file_log_changed(&s->files);
}

const char *lr_scene_description(const lr_scene *s)
{
    return s != NULL && s->description ? s->description : "";
}
