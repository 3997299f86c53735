/*
 * trace.c: tracing against the scene: closest hit and occlusion for one
 * ray, Embree's answer turned into a hit (lr__hit_complete) for one ray
 * and, beside it, for the sixteen lanes of a packet (lr__hits16), and the
 * infinite planes that Embree cannot hold, intersected analytically in
 * double.
 */
#include "accel/trace.h"

#include <float.h>
#include <math.h>
#include <string.h>

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

static void finish_hit(lr__hit *h, double floor, lr__v3 org, lr__v3 dir,
                       double t, lr__v3 ng_outward, lr__v3 ns_outward,
                       int material)
{
    h->has_uv = 0;
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
     * the coordinates involved: 2^-17 of them is ~64 float ulps; floor,
     * the scene's eps_floor, for hits at the origin. */
    double mag = v3_maxabs(h->p) + t * v3_len(dir);
    h->eps = (floor + mag) * 0x1p-17;
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
 * counted (lr__scene_skipped_rays).
 * (The bound, LR__EMBREE_MAX_COORD, and the test, lr__embree_can_trace,
 * are in trace.h: inline, as the path integrator asks it per ray.) */

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

/* Embree's closest hit along org + t dir, t < tfar, in rh (geomID
 * RTC_INVALID_GEOMETRY_ID: none, or a ray Embree cannot take, counted). */
static void closest(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
                    struct RTCRayHit *rh)
{
    rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh->hit.primID = 0;
    rh->hit.u = rh->hit.v = 0.0f;
    rh->ray.tfar = 0.0f;
    if (!lr__embree_can_trace(org, dir)) {
        count_skipped(s);
        return;
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    embree_ray(&rh->ray, org, dir, tfar);
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s->rtc, &ctx, rh);
}

int lr__trace(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
              lr__hit *hit)
{
    struct RTCRayHit rh;
    closest(s, org, dir, tfar, &rh);
    return lr__hit_complete(s, org, dir, tfar, rh.hit.geomID, rh.hit.primID,
                            rh.hit.u, rh.hit.v, rh.ray.tfar, hit);
}

long lr__trace_geom(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar)
{
    struct RTCRayHit rh;
    closest(s, org, dir, tfar, &rh);
    unsigned geom = rh.hit.geomID;
    float t_hit = rh.ray.tfar;
    /* As lr__hit_complete decides between Embree's hit and a plane. */
    double t_embree = geom != RTC_INVALID_GEOMETRY_ID ? (double)t_hit : tfar;
    double t_plane;
    if (plane_hit(s, org, dir, t_embree, &t_plane) >= 0)
        return -1;
    return geom != RTC_INVALID_GEOMETRY_ID ? (long)geom : -2;
}

/* A packet lane whose ray Embree would abort on gets a harmless ray
 * that cannot hit anything instead (tnear 1 > tfar 0; Embree skips such
 * lanes): to the caller, a miss of Embree's geometry, as in lr__trace.
 * (The lane fillers do not see the scene, so these are not counted.) */
static int lane_disabled(lr__v3 *org, lr__v3 *dir, double *tfar, float *tnear)
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

int lr__hit_complete(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
                     unsigned geom_id, unsigned prim_id, float bu, float bv,
                     float t_hit, lr__hit *hit)
{
    double t_embree = geom_id != RTC_INVALID_GEOMETRY_ID ? (double)t_hit : tfar;
    double t_plane;
    long pl = plane_hit(s, org, dir, t_embree, &t_plane);
    if (pl >= 0) {
        const lr__geom *g = &s->planes[pl];
        finish_hit(hit, s->eps_floor, org, dir, t_plane, g->normal, g->normal,
                   g->material);
        hit->geom = -1;
        hit->prim = 0;
        return 1;
    }
    if (geom_id == RTC_INVALID_GEOMETRY_ID)
        return 0;
    hit->geom = (long)geom_id;
    hit->prim = prim_id;

    const lr__geom *g = &s->geoms[geom_id];
    if (g->kind == LR__GEOM_SPHERE) {
        /* t in double near Embree's float one, then the normal from the
         * centre. */
        double t = lr__sphere_refine_t(g, org, dir, t_embree, tfar);
        lr__v3 p = v3_madd(org, dir, t);
        lr__v3 n = v3_sub(p, g->center);
        finish_hit(hit, s->eps_floor, org, dir, t, n, n, g->material);
        if (lr__material_textured(&s->materials[g->material])) {
            hit->has_uv = 1;
            lr__sphere_uv(v3_norm(n), hit->uv);
        }
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
    finish_hit(hit, s->eps_floor, org, dir, t_embree, ng, ns, g->material);
    const lr__material *m = &s->materials[g->material];
    if (lr__material_textured(m))
        hit->has_uv = lr__triangle_uv(g, prim_id, bu, bv, hit->uv);
    if (m->normal_tex != NULL && hit->has_uv && g->tangents != NULL) {
        /* Bent on the front side, then turned to the ray's like ns; a
         * bend past the surface's horizon keeps the unbent normal, as
         * finish_hit does for interpolated ones. */
        lr__v3 front = hit->entering ? hit->ns : v3_neg(hit->ns);
        lr__v3 n = lr__normal_mapped(g, m, prim_id, hit->uv, front);
        n = hit->entering ? n : v3_neg(n);
        if (v3_dot(n, hit->ng) > 0.0)
            hit->ns = n;
    }
    return 1;
}

/* finish_hit, for all sixteen lanes. */
__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__hits16_complete(const struct RTCRayHit16 *rh, double floor, lr__hits16 *h)
{
    const struct RTCRay16 *r = &rh->ray;
    /* ns: the corner normals interpolated and normalised (v3_norm), or
     * in flat meshes ng (the scalar code normalises the same cross
     * product for both).  The square root and division queue for the
     * divider with the others of the packet path; a packet with no
     * smooth lane (the ground, a flat mesh) skips them. */
    double Nx[16], Ny[16], Nz[16];
    int any_smooth = 0;
    for (int i = 0; i < 16; i++)
        any_smooth |= h->smooth[i] != 0.0f;
    if (any_smooth)
        for (int i = 0; i < 16; i++) {
            double u = rh->hit.u[i], v = rh->hit.v[i], w = 1.0 - u - v;
            double nsx = w * h->n[0][i] + u * h->n[3][i] + v * h->n[6][i];
            double nsy = w * h->n[1][i] + u * h->n[4][i] + v * h->n[7][i];
            double nsz = w * h->n[2][i] + u * h->n[5][i] + v * h->n[8][i];
            double ls = sqrt(nsx * nsx + nsy * nsy + nsz * nsz);
            double is = 1.0 / ls;
            int oks = ls > 0;
            Nx[i] = oks ? nsx * is : nsx;
            Ny[i] = oks ? nsy * is : nsy;
            Nz[i] = oks ? nsz * is : nsz;
        }
    for (int i = 0; i < 16; i++) {
        /* ng: unit already (scene.c's face_normals). */
        double ngx = h->ng[0][i], ngy = h->ng[1][i], ngz = h->ng[2][i];
        int smooth = h->smooth[i] != 0.0f;
        double nsx = smooth ? Nx[i] : ngx;
        double nsy = smooth ? Ny[i] : ngy;
        double nsz = smooth ? Nz[i] : ngz;
        double t = r->tfar[i];
        double dx = r->dir_x[i], dy = r->dir_y[i], dz = r->dir_z[i];
        h->px[i] = (double)r->org_x[i] + dx * t;
        h->py[i] = (double)r->org_y[i] + dy * t;
        h->pz[i] = (double)r->org_z[i] + dz * t;
        int entering = dx * ngx + dy * ngy + dz * ngz < 0.0;
        ngx = entering ? ngx : -ngx;
        ngy = entering ? ngy : -ngy;
        ngz = entering ? ngz : -ngz;
        nsx = entering ? nsx : -nsx;
        nsy = entering ? nsy : -nsy;
        nsz = entering ? nsz : -nsz;
        /* (Bitwise & and |, not && and ||: no branches in the loop.) */
        int bad = (nsx * ngx + nsy * ngy + nsz * ngz <= 0.0) |
                  !((fabs(nsx) <= DBL_MAX) & (fabs(nsy) <= DBL_MAX) &
                    (fabs(nsz) <= DBL_MAX));
        h->sx[i] = bad ? ngx : nsx;
        h->sy[i] = bad ? ngy : nsy;
        h->sz[i] = bad ? ngz : nsz;
        h->gx[i] = ngx, h->gy[i] = ngy, h->gz[i] = ngz;
        /* v3_maxabs(p) + t |dir| */
        double m = fabs(h->px[i]);
        m = fabs(h->py[i]) > m ? fabs(h->py[i]) : m;
        m = fabs(h->pz[i]) > m ? fabs(h->pz[i]) : m;
        double dl = sqrt(dx * dx + dy * dy + dz * dz);
        h->eps[i] = (floor + (m + t * dl)) * 0x1p-17;
    }
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

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__ray16_quiet_lanes(struct RTCRay16 *r, const int *valid)
{
    for (int i = 0; i < 16; i++) {
        int off = valid[i] == 0;
        r->org_x[i] = off ? 0.0f : r->org_x[i];
        r->org_y[i] = off ? 0.0f : r->org_y[i];
        r->org_z[i] = off ? 0.0f : r->org_z[i];
        r->dir_x[i] = off ? 0.0f : r->dir_x[i];
        r->dir_y[i] = off ? 0.0f : r->dir_y[i];
        r->dir_z[i] = off ? 1.0f : r->dir_z[i];
        r->tnear[i] = off ? 1.0f : r->tnear[i];
        r->tfar[i] = off ? 0.0f : r->tfar[i];
    }
}

int lr__planes_block(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar)
{
    double t_plane;
    return plane_hit(s, org, dir, tfar, &t_plane) >= 0;
}

void lr__intersect16(const lr_scene *s, struct RTCRayHit16 *rh, int n,
                     uint64_t *rays)
{
    int valid[16] __attribute__((aligned(64)));
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int i = 0; i < 16; i++)
        valid[i] = i < n ? -1 : 0;
    rtcIntersect16(valid, s->rtc, &ctx, rh);
    *rays += (uint64_t)n;
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
