/*
 * spheres.c: the path integrator's rays in a scene with a few spheres
 * (trace.h: lr__spheres_build, lr__paths_intersect16,
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
#include "accel/trace.h"

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
    rtcSetSceneFlags(s->rtc_few, lr__scene_flags(s));
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
    enum RTCError code = rtcGetDeviceError(s->device);
    if (code == RTC_ERROR_OUT_OF_MEMORY)
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "out of memory building the Embree scene without "
                        "spheres");
    if (code != RTC_ERROR_NONE)
        return lr__fail(err, LR_ERR_EMBREE, NULL,
                        "building the Embree scene without spheres");
    return LR_OK;
}

/* Entries m .. m8 - 1: rays that meet nothing. */
static void pad(lr__rays_packed *P)
{
    P->m8 = (P->m + 7) & ~7;
    for (int c = P->m; c < P->m8; c++) {
        P->ox[c] = P->oy[c] = P->oz[c] = 0.0;
        P->dx[c] = P->dy[c] = 0.0;
        P->dz[c] = 1.0;
        P->tn[c] = 1.0;
        P->tf[c] = 0.0;
    }
}

/* Packs the lanes with valid[i] set (lr__rays_packed).  The lane list
 * is made without a branch per lane (which mispredicted often enough to
 * cost 5% of the Cornell box's CPU time), then the rays gathered. */
static void pack(const int *valid, const struct RTCRay16 *r, lr__rays_packed *P)
{
    int m = 0;
    for (int i = 0; i < 16; i++) {
        P->lane[m] = i;
        m += valid[i] != 0;
    }
    for (int c = 0; c < m; c++) {
        int i = P->lane[c];
        P->ox[c] = r->org_x[i], P->oy[c] = r->org_y[i], P->oz[c] = r->org_z[i];
        P->dx[c] = r->dir_x[i], P->dy[c] = r->dir_y[i], P->dz[c] = r->dir_z[i];
        P->tn[c] = r->tnear[i];
        P->tf[c] = r->tfar[i];
    }
    P->m = m;
    pad(P);
}

/* Each entry's nearest sphere hit with t in (tn, tf): tf[c] becomes its
 * t and sph[c] the sphere's index (else tf stays and sph is -1).  The
 * quadratic as trace.c's sphere refinement solves it (q = -(b + sign(b)
 * sqrt(disc)), the roots q / a and c / q), but with c = |o - c|^2 - r^2
 * rather than (l - r)(l + r), l = |o - c|: a square root less, and
 * lr__hit_complete solves the chosen sphere's t again in that careful
 * form anyway.  Eight entries at a time in loops that GCC vectorises
 * (-fno-trapping-math in the Makefile lets it compute every entry's
 * square roots and quotients, and select): one sphere test per lane in
 * turn had cost 11% of the Cornell box's CPU time.  An entry with a
 * negative discriminant or a zero direction computes NaN or infinite
 * roots that the selects refuse. */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
spheres_packed(const lr_scene *s, lr__rays_packed *P, double sph[LR__PACKED])
{
    for (int c0 = 0; c0 < P->m8; c0 += 8) {
        for (int i = c0; i < c0 + 8; i++)
            sph[i] = -1.0;
        for (size_t j = 0; j < s->n_few; j++) {
            const lr__few_sphere *f = &s->few[j];
            double cx = f->cx, cy = f->cy, cz = f->cz, r2 = f->r * f->r;
            for (int i = c0; i < c0 + 8; i++) {
                double dx = P->dx[i], dy = P->dy[i], dz = P->dz[i];
                double ocx = P->ox[i] - cx, ocy = P->oy[i] - cy,
                       ocz = P->oz[i] - cz;
                double a = dx * dx + dy * dy + dz * dz;
                double b = ocx * dx + ocy * dy + ocz * dz;
                double c = ocx * ocx + ocy * ocy + ocz * ocz - r2;
                double disc = b * b - a * c;
                int ok = (disc >= 0.0) & (a > 0.0);
                double sq = sqrt(disc > 0.0 ? disc : 0.0);
                double q = -(b + (b < 0.0 ? -sq : sq));
                double r1 = q / a;
                double r2 = q != 0.0 ? c / (q != 0.0 ? q : 1.0) : r1;
                double lo = r1 < r2 ? r1 : r2, hi = r1 < r2 ? r2 : r1;
                double tf = P->tf[i], tn = P->tn[i];
                int lo_in = (lo > tn) & (lo < tf);
                int hi_in = (hi > tn) & (hi < tf);
                double t = lo_in ? lo : hi;
                int hit = ok & (lo_in | hi_in);
                P->tf[i] = hit ? t : tf;
                sph[i] = hit ? (double)j : sph[i];
            }
        }
    }
}

/* Entry c's hit, a sphere (sph[c] >= 0) or else a triangle (tri[c] >=
 * 0), written into its lane of rh as rtcIntersect16 writes it; 0 if it
 * has neither (rh untouched). */
static int write_hit(const lr_scene *s, const lr__rays_packed *P, int c,
                     const double *sph, const double *tri, const double *u,
                     const double *v, struct RTCRayHit16 *rh)
{
    int i = P->lane[c];
    if (sph[c] >= 0.0) {
        rh->hit.geomID[i] = s->few[(size_t)sph[c]].id;
        rh->hit.primID[i] = 0;
        rh->hit.u[i] = rh->hit.v[i] = 0.0f;
    } else if (tri[c] >= 0.0) {
        size_t k = (size_t)tri[c];
        rh->hit.geomID[i] = s->few_tris.geom[k];
        rh->hit.primID[i] = s->few_tris.prim[k];
        rh->hit.u[i] = (float)u[c];
        rh->hit.v[i] = (float)v[c];
    } else {
        return 0;
    }
    rh->ray.tfar[i] = (float)P->tf[c];
    rh->hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    return 1;
}

void lr__paths_intersect16(const lr_scene *s, const int *valid,
                           struct RTCIntersectContext *ctx,
                           struct RTCRayHit16 *rh)
{
    const lr__few_triangles *T = &s->few_tris;
    if (T->n == 0) {
        if (s->rtc_few == NULL) {
            rtcIntersect16(valid, s->rtc, ctx, rh);
            return;
        }
        rtcIntersect16(valid, s->rtc_few, ctx, rh);
    }
    lr__rays_packed P;
    double tri[LR__PACKED], u[LR__PACKED], v[LR__PACKED], sph[LR__PACKED];
    pack(valid, &rh->ray, &P);
    if (T->n > 0)
        lr__few_triangles_intersect(T, &P, 0, tri, u, v);
    spheres_packed(s, &P, sph);
    if (T->n == 0)
        for (int c = 0; c < P.m; c++)
            tri[c] = -1.0;
    /* Lanes that met neither keep Embree's answer, or none. */
    for (int c = 0; c < P.m; c++)
        write_hit(s, &P, c, sph, tri, u, v, rh);
}

void lr__paths_occluded16(const lr_scene *s, const int *valid,
                          struct RTCIntersectContext *ctx, struct RTCRay16 *r)
{
    const lr__few_triangles *T = &s->few_tris;
    if (s->rtc_few == NULL && T->n == 0) {
        rtcOccluded16(valid, s->rtc, ctx, r);
        return;
    }
    lr__rays_packed P;
    double sph[LR__PACKED], occ[LR__PACKED];
    pack(valid, r, &P);
    if (T->n > 0) {
        lr__paths_occluded_packed(s, &P, occ);
        for (int c = 0; c < P.m; c++)
            if (occ[c] != 0.0)
                r->tfar[P.lane[c]] = -INFINITY; /* Embree's mark */
        return;
    }
    spheres_packed(s, &P, sph);
    /* The spheres first: a ray they block needs no Embree. */
    int rest[16] __attribute__((aligned(64)));
    int any = 0;
    for (int i = 0; i < 16; i++)
        rest[i] = valid[i];
    for (int c = 0; c < P.m; c++)
        if (sph[c] >= 0.0) {
            r->tfar[P.lane[c]] = -INFINITY;
            rest[P.lane[c]] = 0;
        }
    for (int i = 0; i < 16; i++)
        any |= rest[i];
    if (any)
        rtcOccluded16(rest, s->rtc_few, ctx, r);
}

void lr__paths_trace_packed(const lr_scene *s, lr__rays_packed *P, int ns,
                            struct RTCRayHit16 *rh, double occ[LR__PACKED])
{
    /* A shadow ray is blocked if it has a nearest hit: the triangles'
     * first test of an entry is N 1 < tf D, the occlusion test's N < tf
     * D, and without a triangle hit tf stays (tf / 1) for the spheres.
     * One pass over the shapes for both kinds fills the eight-entry
     * groups better than one pass each (their padding). */
    const lr__few_triangles *T = &s->few_tris;
    double tri[LR__PACKED], u[LR__PACKED], v[LR__PACKED], sph[LR__PACKED];
    pad(P);
    lr__few_triangles_intersect(T, P, ns, tri, u, v);
    spheres_packed(s, P, sph);
    for (int c = 0; c < ns; c++)
        occ[c] = sph[c] >= 0.0 || tri[c] >= 0.0 ? 1.0 : 0.0;
    for (int c = ns; c < P->m; c++)
        if (!write_hit(s, P, c, sph, tri, u, v, rh)) {
            rh->hit.geomID[P->lane[c]] = RTC_INVALID_GEOMETRY_ID;
            rh->hit.instID[0][P->lane[c]] = RTC_INVALID_GEOMETRY_ID;
        }
}

void lr__paths_occluded_packed(const lr_scene *s, lr__rays_packed *P,
                               double occ[LR__PACKED])
{
    double sph[LR__PACKED];
    pad(P);
    spheres_packed(s, P, sph);
    lr__few_triangles_occluded(&s->few_tris, P, occ);
    for (int c = 0; c < P->m; c++)
        occ[c] = sph[c] >= 0.0 ? 1.0 : occ[c];
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
