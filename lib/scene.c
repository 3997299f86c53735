/*
 * scene.c: the scene's Embree side: building geometry, committing, and
 * tracing single rays (closest hit and occlusion), plus the infinite
 * planes that Embree cannot hold and that are intersected analytically;
 * and the scene's destructor and accessors.
 */
#include "scene.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Embree reports errors through a callback; keep the last message per
 * device so that the failing call can put it in the lr_error. */
static _Thread_local char embree_msg[256];

static void on_embree_error(void *user, enum RTCError code, const char *str)
{
    (void)user;
    snprintf(embree_msg, sizeof embree_msg, "Embree error %d: %s", (int)code,
             str ? str : "(no message)");
}

static lr_status embree_fail(lr_error *err, const char *what)
{
    return lr__fail(err, LR_ERR_EMBREE, NULL, "%s failed: %s", what,
                    embree_msg[0] ? embree_msg : "unknown Embree error");
}

lr_status lr__scene_begin(lr_scene *s, lr_error *err)
{
    embree_msg[0] = '\0';
    s->device = rtcNewDevice(NULL);
    if (s->device == NULL)
        return embree_fail(err, "creating the Embree device");
    rtcSetDeviceErrorFunction(s->device, on_embree_error, NULL);
    s->rtc = rtcNewScene(s->device);
    if (s->rtc == NULL)
        return embree_fail(err, "creating the Embree scene");
    /* Robust traversal: no missed hits at shared triangle edges, which
     * matters for watertight meshes seen through a lens. */
    rtcSetSceneFlags(s->rtc, RTC_SCENE_FLAG_ROBUST);
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
                                  int material, lr_error *err)
{
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
    return LR_OK;
}

lr_status lr__scene_add_sphere(lr_scene *s, lr__v3 center, double radius,
                               int material, lr_error *err)
{
    RTCGeometry geom =
        rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
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

lr_status lr__scene_commit(lr_scene *s, lr_error *err)
{
    for (size_t i = 0; i < s->n_geoms; i++) {
        lr__geom *g = &s->geoms[i];
        const lr__material *m = &s->materials[g->material];
        g->plain = g->kind == LR__GEOM_TRIANGLES && s->n_planes == 0 &&
                   !(v3_maxc(m->specular) > 0.0) &&
                   !(v3_maxc(m->reflect) > 0.0) &&
                   !(v3_maxc(m->transmit) > 0.0) &&
                   v3_maxc(m->diffuse) > 0.0;
    }
    embree_msg[0] = '\0';
    rtcCommitScene(s->rtc);
    if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE)
        return embree_fail(err, "building the Embree scene");
    return LR_OK;
}

/* ---- tracing ---------------------------------------------------------- */

static void embree_ray(struct RTCRay *r, lr__v3 org, lr__v3 dir, double tfar)
{
    r->org_x = (float)org.x;
    r->org_y = (float)org.y;
    r->org_z = (float)org.z;
    r->tnear = 0.0f;
    r->dir_x = (float)dir.x;
    r->dir_y = (float)dir.y;
    r->dir_z = (float)dir.z;
    r->time = 0.0f;
    r->tfar = tfar < FLT_MAX ? (float)tfar : FLT_MAX;
    r->mask = 0xFFFFFFFFu;
    r->id = 0;
    r->flags = 0;
}

/* The nearest infinite plane hit with t in (0, tfar), or -1. */
static long plane_hit(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
                      double *t_out)
{
    long best = -1;
    double best_t = tfar;
    for (size_t i = 0; i < s->n_planes; i++) {
        const lr__geom *pl = &s->planes[i];
        double den = v3_dot(dir, pl->normal);
        if (den == 0.0)
            continue;
        double t = v3_dot(v3_sub(pl->center, org), pl->normal) / den;
        if (t > 0.0 && t < best_t) {
            best_t = t;
            best = (long)i;
        }
    }
    *t_out = best_t;
    return best;
}

static void finish_hit(lr__hit *h, lr__v3 org, lr__v3 dir, double t,
                       lr__v3 ng_outward, lr__v3 ns_outward, int material)
{
    h->t = t;
    h->p = v3_madd(org, dir, t);
    h->material = material;
    ng_outward = v3_norm(ng_outward);
    ns_outward = v3_norm(ns_outward);
    h->entering = v3_dot(dir, ng_outward) < 0.0;
    h->ng = h->entering ? ng_outward : v3_neg(ng_outward);
    h->ns = h->entering ? ns_outward : v3_neg(ns_outward);
    /* An interpolated normal may point below the surface near silhouettes;
     * fall back to the geometric normal there rather than shade a
     * surface from behind. */
    if (v3_dot(h->ns, h->ng) <= 0.0 || !v3_finite(h->ns))
        h->ns = h->ng;
    /* Float rounding in Embree's t and in the hit position scales with
     * the coordinates involved: 2^-17 of them is ~64 float ulps. */
    double mag = v3_maxabs(h->p) + t * v3_len(dir);
    h->eps = (1.0 + mag) * 0x1p-17;
}

/* Embree asserts, aborting the process, on a ray with a component of its
 * origin or direction beyond FLT_LARGE (1.844e18) or not finite
 * (RayK::valid() in its BVH intersectors).  Valid scenes make such rays:
 * a ray grazing an infinite plane (traced here in double) meets it at
 * t up to about 1e15 / |cos|, 1e19 and far more, and the shadow and
 * secondary rays start there.  Everything Embree holds lies within 1e15
 * of the origin (the scene's limits), so such a ray is not given to
 * Embree: it misses Embree's geometry (a point light that far away gives
 * nothing measurable anyway), still meets the infinite planes, and is
 * counted (lr__scene_skipped_rays). */
#define EMBREE_MAX_COORD 1.8e18

int lr__embree_can_trace(lr__v3 org, lr__v3 dir)
{
    /* Written so that NaN fails. */
    return fabs(org.x) <= EMBREE_MAX_COORD && fabs(org.y) <= EMBREE_MAX_COORD &&
           fabs(org.z) <= EMBREE_MAX_COORD && fabs(dir.x) <= EMBREE_MAX_COORD &&
           fabs(dir.y) <= EMBREE_MAX_COORD && fabs(dir.z) <= EMBREE_MAX_COORD;
}

static void count_skipped(const lr_scene *s)
{
    /* The scene is shared by the render's threads, and only this counter
     * of it changes while they trace (it is never const-defined: scenes
     * come from calloc). */
    atomic_fetch_add_explicit(&((lr_scene *)s)->skipped_rays, 1,
                              memory_order_relaxed);
}

unsigned long long lr__scene_skipped_rays(const lr_scene *s)
{
    return atomic_load_explicit(&((lr_scene *)s)->skipped_rays,
                                memory_order_relaxed);
}

int lr__trace(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
              lr__hit *hit)
{
    if (!lr__embree_can_trace(org, dir)) {
        count_skipped(s);
        return lr__hit_complete(s, org, dir, tfar, RTC_INVALID_GEOMETRY_ID,
                                0, 0.0f, 0.0f, 0.0f, hit);
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    embree_ray(&rh.ray, org, dir, tfar);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s->rtc, &ctx, &rh);
    return lr__hit_complete(s, org, dir, tfar, rh.hit.geomID, rh.hit.primID,
                            rh.hit.u, rh.hit.v, rh.ray.tfar, hit);
}

/* A packet lane whose ray Embree would abort on gets a harmless ray
 * that cannot hit anything instead (tnear 1 > tfar 0; Embree skips such
 * lanes): to the caller, a miss of Embree's geometry, as in lr__trace.
 * (The lane fillers do not see the scene, so these are not counted.) */
static int lane_disabled(lr__v3 *org, lr__v3 *dir, double *tfar,
                         float *tnear)
{
    *tnear = 0.0f;
    if (lr__embree_can_trace(*org, *dir))
        return 0;
    *org = v3(0, 0, 0);
    *dir = v3(0, 0, 1);
    *tfar = 0.0;
    *tnear = 1.0f;
    return 1;
}

void lr__embree_ray16(struct RTCRayHit16 *rh, int lane, lr__v3 org,
                      lr__v3 dir, double tfar)
{
    float tnear;
    lane_disabled(&org, &dir, &tfar, &tnear);
    rh->ray.org_x[lane] = (float)org.x;
    rh->ray.org_y[lane] = (float)org.y;
    rh->ray.org_z[lane] = (float)org.z;
    rh->ray.tnear[lane] = tnear;
    rh->ray.dir_x[lane] = (float)dir.x;
    rh->ray.dir_y[lane] = (float)dir.y;
    rh->ray.dir_z[lane] = (float)dir.z;
    rh->ray.time[lane] = 0.0f;
    rh->ray.tfar[lane] = tfar < FLT_MAX ? (float)tfar : FLT_MAX;
    rh->ray.mask[lane] = 0xFFFFFFFFu;
    rh->ray.id[lane] = 0;
    rh->ray.flags[lane] = 0;
    rh->hit.geomID[lane] = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0][lane] = RTC_INVALID_GEOMETRY_ID;
}

int lr__hit_complete(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
                     unsigned geom_id, unsigned prim_id, float bu, float bv,
                     float t_hit, lr__hit *hit)
{
    double t_embree = geom_id != RTC_INVALID_GEOMETRY_ID ? (double)t_hit
                                                         : tfar;
    double t_plane;
    long pl = plane_hit(s, org, dir, t_embree, &t_plane);
    if (pl >= 0) {
        const lr__geom *g = &s->planes[pl];
        finish_hit(hit, org, dir, t_plane, g->normal, g->normal, g->material);
        return 1;
    }
    if (geom_id == RTC_INVALID_GEOMETRY_ID)
        return 0;

    const lr__geom *g = &s->geoms[geom_id];
    if (g->kind == LR__GEOM_SPHERE) {
        /* Embree found the sphere in float, so on a big sphere its t can
         * be far off the surface (0.1 units on a radius of 1e6): solve the
         * quadratic again in double, in the cancellation-free form
         * (|oc| - r)(|oc| + r) and q = -(b + sign(b) sqrt(disc)), and keep
         * the root nearest Embree's.  Then the normal from the centre. */
        double t = t_embree;
        lr__v3 oc = v3_sub(org, g->center);
        double a = v3_dot(dir, dir), b = v3_dot(oc, dir);
        double l = v3_len(oc);
        double c = (l - g->radius) * (l + g->radius);
        double disc = b * b - a * c;
        if (disc >= 0.0 && a > 0.0) {
            double q = -(b + copysign(sqrt(disc), b));
            double r1 = q / a, r2 = q != 0.0 ? c / q : r1;
            double best = fabs(r1 - t) < fabs(r2 - t) ? r1 : r2;
            if (best > 0.0 && best < tfar)
                t = best;
        }
        lr__v3 p = v3_madd(org, dir, t);
        lr__v3 n = v3_sub(p, g->center);
        finish_hit(hit, org, dir, t, n, n, g->material);
        return 1;
    }
    /* Triangles: CCW winding (as OBJ) is the front side. */
    const unsigned *ix = &g->indices[3 * (size_t)prim_id];
    const float *a = &g->vertices[3 * (size_t)ix[0]];
    const float *b = &g->vertices[3 * (size_t)ix[1]];
    const float *c = &g->vertices[3 * (size_t)ix[2]];
    lr__v3 va = v3(a[0], a[1], a[2]);
    lr__v3 ng = v3_cross(v3_sub(v3(b[0], b[1], b[2]), va),
                         v3_sub(v3(c[0], c[1], c[2]), va));
    lr__v3 ns = ng;
    if (g->corner_normals != NULL) {
        const float *n = &g->corner_normals[9 * (size_t)prim_id];
        double u = bu, v = bv, w = 1.0 - u - v;
        ns = v3(w * n[0] + u * n[3] + v * n[6], w * n[1] + u * n[4] + v * n[7],
                w * n[2] + u * n[5] + v * n[8]);
    }
    finish_hit(hit, org, dir, t_embree, ng, ns, g->material);
    return 1;
}

void lr__shadow_ray16(struct RTCRay16 *r, int lane, lr__v3 org, lr__v3 dir,
                      double tfar)
{
    float tnear;
    lane_disabled(&org, &dir, &tfar, &tnear);
    r->org_x[lane] = (float)org.x;
    r->org_y[lane] = (float)org.y;
    r->org_z[lane] = (float)org.z;
    r->tnear[lane] = tnear;
    r->dir_x[lane] = (float)dir.x;
    r->dir_y[lane] = (float)dir.y;
    r->dir_z[lane] = (float)dir.z;
    r->time[lane] = 0.0f;
    r->tfar[lane] = tfar < FLT_MAX ? (float)tfar : FLT_MAX;
    r->mask[lane] = 0xFFFFFFFFu;
    r->id[lane] = 0;
    r->flags[lane] = 0;
}

int lr__planes_block(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar)
{
    double t_plane;
    return plane_hit(s, org, dir, tfar, &t_plane) >= 0;
}

int lr__occluded(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar)
{
    double t_plane;
    if (plane_hit(s, org, dir, tfar, &t_plane) >= 0)
        return 1;
    if (!lr__embree_can_trace(org, dir)) {
        count_skipped(s);
        return 0;
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    embree_ray(&r, org, dir, tfar);
    rtcOccluded1(s->rtc, &ctx, &r);
    /* Embree marks an occluded ray by setting tfar to -inf. */
    return r.tfar < 0.0f;
}

lr__v3 lr__offset_origin(const lr__hit *hit, lr__v3 dir)
{
    double side = v3_dot(dir, hit->ng) >= 0.0 ? 1.0 : -1.0;
    return v3_madd(hit->p, hit->ng, side * hit->eps);
}

/* ---- the scene's life ------------------------------------------------ */

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
