/*
 * spheres.c: the path integrator's rays in a scene with a few spheres
 * (scene.h: lr__spheres_build, lr__paths_intersect16,
 * lr__paths_occluded16).  Embree's sphere primitive cost the Cornell box
 * of bench/path 40 to 60 ns a ray, a third of all Embree's time there
 * (a bare Embree program, 12 triangles with and without the two
 * spheres); the same spheres solved here in double, lane by lane, cost a
 * few ns each.  So when a scene has at most LR__FEW_SPHERES spheres, a
 * second Embree scene holds everything else (the same geometries,
 * attached by their IDs, so the BVH is built twice but the meshes are
 * shared) and the spheres are met here; with more, Embree's own scene
 * (and its sphere BVH) is used.  Only scenes whose own render settings
 * name the path integrator get the second scene (Whitted renders never
 * pay for it); a path render of another scene (render.integrator set
 * for one job) takes Embree's scene, slower and the same.
 *
 * What a hit reports is what lr__hit_complete needs: the geometry ID,
 * and t, which it solves again in double near the given value
 * (trace.c), so a sphere hit found here completes as one from Embree.
 * Rays that quiet lanes disabled (tnear 1 > tfar 0) meet nothing.
 */
#include "scene.h"

#include <math.h>

int lr__few_spheres_enabled = 1;

lr_status lr__spheres_build(lr_scene *s, lr_error *err)
{
    if (!lr__few_spheres_enabled ||
        s->settings.integrator != LR_INTEGRATOR_PATH)
        return LR_OK;
    size_t n = 0;
    for (size_t g = 0; g < s->n_geoms; g++)
        n += s->geoms[g].kind == LR__GEOM_SPHERE;
    if (n > LR__FEW_SPHERES)
        return LR_OK;
    if (lr__few_triangles_build(s)) {
        /* No Embree scene: the triangles in few_triangles.c, the spheres
         * here. */
        for (size_t g = 0; g < s->n_geoms; g++) {
            const lr__geom *G = &s->geoms[g];
            if (G->kind != LR__GEOM_SPHERE)
                continue;
            lr__few_sphere *f = &s->few[s->n_few++];
            f->cx = G->center.x, f->cy = G->center.y, f->cz = G->center.z;
            f->r = G->radius;
            f->id = (unsigned)g;
        }
        return LR_OK;
    }
    if (n == 0)
        return LR_OK;
    s->rtc_few = rtcNewScene(s->device);
    if (s->rtc_few == NULL)
        return lr__fail(err, LR_ERR_EMBREE, NULL,
                        "creating the Embree scene without spheres");
    /* As the main scene (scene.c). */
    rtcSetSceneFlags(s->rtc_few, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(s->rtc_few, RTC_BUILD_QUALITY_HIGH);
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *G = &s->geoms[g];
        if (G->kind == LR__GEOM_SPHERE) {
            lr__few_sphere *f = &s->few[s->n_few++];
            f->cx = G->center.x, f->cy = G->center.y, f->cz = G->center.z;
            f->r = G->radius;
            f->id = (unsigned)g;
            continue;
        }
        rtcAttachGeometryByID(s->rtc_few, rtcGetGeometry(s->rtc, (unsigned)g),
                              (unsigned)g);
    }
    rtcCommitScene(s->rtc_few);
    if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE)
        return lr__fail(err, LR_ERR_EMBREE, NULL,
                        "building the Embree scene without spheres");
    return LR_OK;
}

/* The nearest root of |o + t d - c| = r in (tnear, tfar), or tfar: the
 * cancellation-free quadratic of trace.c's sphere refinement. */
static double sphere_t(const lr__few_sphere *f, double ox, double oy,
                       double oz, double dx, double dy, double dz,
                       double tnear, double tfar)
{
    double ocx = ox - f->cx, ocy = oy - f->cy, ocz = oz - f->cz;
    double a = dx * dx + dy * dy + dz * dz;
    double b = ocx * dx + ocy * dy + ocz * dz;
    double l = sqrt(ocx * ocx + ocy * ocy + ocz * ocz);
    double c = (l - f->r) * (l + f->r);
    double disc = b * b - a * c;
    if (!(disc >= 0.0) || !(a > 0.0))
        return tfar;
    double q = -(b + copysign(sqrt(disc), b));
    double r1 = q / a, r2 = q != 0.0 ? c / q : r1;
    double lo = fmin(r1, r2), hi = fmax(r1, r2);
    if (lo > tnear && lo < tfar)
        return lo;
    if (hi > tnear && hi < tfar)
        return hi;
    return tfar;
}

void lr__paths_intersect16(const lr_scene *s, const int *valid,
                           struct RTCIntersectContext *ctx,
                           struct RTCRayHit16 *rh)
{
    double tri_t[16];
    if (s->few_tris.n > 0) {
        lr__few_triangles_intersect16(&s->few_tris, valid, rh, tri_t);
    } else if (s->rtc_few == NULL) {
        rtcIntersect16(valid, s->rtc, ctx, rh);
        return;
    } else {
        rtcIntersect16(valid, s->rtc_few, ctx, rh);
    }
    const struct RTCRay16 *r = &rh->ray;
    for (int i = 0; i < 16; i++) {
        if (!valid[i])
            continue;
        double tfar = s->few_tris.n > 0 ? tri_t[i] : r->tfar[i];
        double tnear = r->tnear[i];
        long best = -1;
        for (size_t j = 0; j < s->n_few; j++) {
            double t = sphere_t(&s->few[j], r->org_x[i], r->org_y[i],
                                r->org_z[i], r->dir_x[i], r->dir_y[i],
                                r->dir_z[i], tnear, tfar);
            if (t < tfar) {
                tfar = t;
                best = (long)j;
            }
        }
        if (best < 0)
            continue;
        rh->ray.tfar[i] = (float)tfar;
        rh->hit.geomID[i] = s->few[best].id;
        rh->hit.primID[i] = 0;
        rh->hit.u[i] = rh->hit.v[i] = 0.0f;
        rh->hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
}

void lr__paths_occluded16(const lr_scene *s, const int *valid,
                          struct RTCIntersectContext *ctx,
                          struct RTCRay16 *r)
{
    if (s->rtc_few == NULL && s->few_tris.n == 0) {
        rtcOccluded16(valid, s->rtc, ctx, r);
        return;
    }
    /* The spheres first: a ray they block needs no Embree. */
    int rest[16] __attribute__((aligned(64)));
    int any = 0;
    for (int i = 0; i < 16; i++) {
        rest[i] = valid[i];
        if (!valid[i])
            continue;
        double tfar = r->tfar[i], tnear = r->tnear[i];
        for (size_t j = 0; j < s->n_few && rest[i]; j++)
            if (sphere_t(&s->few[j], r->org_x[i], r->org_y[i], r->org_z[i],
                         r->dir_x[i], r->dir_y[i], r->dir_z[i], tnear,
                         tfar) < tfar) {
                /* Embree's mark of an occluded ray. */
                r->tfar[i] = -INFINITY;
                rest[i] = 0;
            }
        any |= rest[i];
    }
    if (!any)
        return;
    if (s->few_tris.n > 0)
        lr__few_triangles_occluded16(&s->few_tris, rest, r);
    else
        rtcOccluded16(rest, s->rtc_few, ctx, r);
}

void lr__paths_camera16(const lr_scene *s, struct RTCRayHit16 *rh, int n,
                        uint64_t *rays)
{
    if (s->few_tris.n == 0) {
        lr__intersect16(s, rh, n, rays);
        return;
    }
    int valid[16] __attribute__((aligned(64)));
    for (int i = 0; i < 16; i++)
        valid[i] = i < n ? -1 : 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    lr__paths_intersect16(s, valid, &ctx, rh);
    *rays += (uint64_t)n;
}
