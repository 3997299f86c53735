/*
 * trace.h: ray queries on a committed scene (trace.c, spheres.c,
 * few_triangles.c): the closest hit and occlusion of single rays and
 * 16-wide packets, the path integrator's packed rays, and the hit record
 * every integrator shades.
 */
#ifndef LR_TRACE_H
#define LR_TRACE_H

#include "scene/scene.h"

typedef struct lr__hit {
    double t;
    lr__v3 p;     /* hit position */
    lr__v3 ng;    /* unit geometric normal, facing the ray's origin */
    lr__v3 ns;    /* unit shading normal, same side as ng */
    int entering; /* 1 if the ray hit the outside (front) surface */
    int material;
    double eps;    /* how far to push a new ray's origin off p */
    long geom;     /* Embree geometry ID; -1 for an infinite plane */
    unsigned prim; /* triangle index in it */
    /* Texture coordinates (lr__triangle_uv, lr__sphere_uv), computed
     * only where the material has a texture; has_uv 0 otherwise, on an
     * infinite plane and on a mesh without them. */
    int has_uv;
    double uv[2];
} lr__hit;

/* The material at a hit: lr__material_at at its texture coordinates. */
static inline const lr__material *
lr__hit_material(const lr_scene *s, const lr__hit *h, lr__material *tmp)
{
    return lr__material_at(s, h->material, h->has_uv, h->uv, tmp);
}

/* Closest hit along org + t dir with t in (0, tfar); dir need not be unit
 * length but t is in its units.  Returns 1 on a hit. */
int lr__trace(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
              lr__hit *hit);
/* Which geometry lr__trace's hit would be on, without completing the
 * hit: its index, -1 for an infinite plane, -2 for none. */
long lr__trace_geom(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar);
/* 1 if anything blocks org + t dir for t in (0, tfar). */
int lr__occluded(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar);
/* The closest hits of lanes 0..n-1 of a packet of camera rays (Embree's
 * answer in rh, coherent), counted in *rays. */
void lr__intersect16(const lr_scene *s, struct RTCRayHit16 *rh, int n,
                     uint64_t *rays);

/* The path integrator's packets (spheres.c): rtcIntersect16 and
 * rtcOccluded16 on the scene, the spheres met in double when it has a
 * few; the same answers (a sphere hit's t is solved again by
 * lr__hit_complete).  lr__spheres_build, the path integrator's prepare
 * step, makes the scene without spheres. */
lr_status lr__spheres_build(lr_scene *s, lr_error *err);
/* 0: scenes loaded from now on keep Embree's spheres (for tests). */
extern int lr__few_spheres_enabled;
/* The camera rays of a packet of n lanes (lr__intersect16, or in a scene
 * of a few primitives lr__paths_intersect16: the same hits as
 * continuation rays find). */
void lr__paths_camera16(const lr_scene *s, struct RTCRayHit16 *rh, int n,
                        uint64_t *rays);

/* few_triangles.c.  Fills s->few_tris and returns 1 if the scene's
 * Embree geometries are spheres and 1 to LR__FEW_TRIANGLES triangles
 * (and lr__few_triangles_enabled); else leaves few_tris.n 0 and returns
 * 0.  Called by lr__spheres_build. */
int lr__few_triangles_build(lr_scene *s);
/* 0: scenes loaded from now on leave their triangles to Embree (tests). */
extern int lr__few_triangles_enabled;
/* Rays packed to the front, in double (spheres.c and path16.c fill
 * it): entry c is packet lane lane[c]'s ray, c < m; entries m .. m8 - 1
 * (m8: m rounded up to a multiple of 8, the lane loops' step) hold rays
 * that meet nothing (tnear 1, tfar 0).  The lane loops then cost what
 * the live lanes need: on the Cornell box a continuation packet had 10.6
 * live lanes of 16 on average, a shadow packet 7.4.  A bounce's shadow
 * and continuation rays go in one (lr__paths_trace_packed), so up to
 * 32. */
#define LR__PACKED 32
typedef struct lr__rays_packed {
    int m, m8;
    int lane[LR__PACKED];
    double ox[LR__PACKED], oy[LR__PACKED], oz[LR__PACKED];
    double dx[LR__PACKED], dy[LR__PACKED], dz[LR__PACKED];
    double tn[LR__PACKED], tf[LR__PACKED];
} lr__rays_packed;
/* Whether the scene's path packets skip Embree altogether (few_tris
 * holds its triangles), so that lr__paths_occluded_packed serves it. */
static inline int lr__paths_packed(const lr_scene *s)
{
    return s->few_tris.n > 0;
}
/* occ[c] = 1 if P's entry c meets a sphere or triangle at t in (tnear,
 * tfar), else 0, in a scene lr__paths_packed accepts. */
void lr__paths_occluded_packed(const lr_scene *s, lr__rays_packed *P,
                               double occ[LR__PACKED]);
/* A bounce's rays at once, in a scene lr__paths_packed accepts: entries
 * c < ns are shadow rays (occ[c] as lr__paths_occluded_packed gives
 * it), the others continuation rays, whose nearest hits are written into
 * rh's lanes as lr__paths_intersect16 writes them (geomID, primID, u, v,
 * tfar; geomID RTC_INVALID_GEOMETRY_ID for a miss; rh's rays neither
 * read nor written). */
void lr__paths_trace_packed(const lr_scene *s, lr__rays_packed *P, int ns,
                            struct RTCRayHit16 *rh, double occ[LR__PACKED]);
/* The nearest triangle of each entry with t in (tn, tf): tf[c] becomes
 * its t, tri[c] its index in T (geom, prim), u[c], v[c] its
 * barycentrics (Embree's convention); entries without a hit keep tf and
 * get tri -1.  Entries c < c0 (shadow rays) get only tri >= 0 for a hit
 * (the shape's index) and no barycentrics. */
void lr__few_triangles_intersect(const lr__few_triangles *T, lr__rays_packed *P,
                                 int c0, double tri[LR__PACKED],
                                 double u[LR__PACKED], double v[LR__PACKED]);
/* occ[c] = 1 if entry c meets a triangle at t in (tn, tf), else 0. */
void lr__few_triangles_occluded(const lr__few_triangles *T,
                                const lr__rays_packed *P,
                                double occ[LR__PACKED]);
void lr__paths_intersect16(const lr_scene *s, const int *valid,
                           struct RTCIntersectContext *ctx,
                           struct RTCRayHit16 *rh);
void lr__paths_occluded16(const lr_scene *s, const int *valid,
                          struct RTCIntersectContext *ctx, struct RTCRay16 *r);

/* Packets.  lr__shadow_ray16 fills one lane of a 16-wide packet exactly
 * as lr__occluded fills a single ray;
 * lr__hit_complete turns Embree's answer for one ray (geom_id
 * RTC_INVALID_GEOMETRY_ID when it found nothing) into the same hit
 * lr__trace returns, infinite planes included; lr__planes_block is the
 * infinite planes' part of lr__occluded. */
void lr__shadow_ray16(struct RTCRay16 *r, int lane, lr__v3 org, lr__v3 dir,
                      double tfar);
int lr__hit_complete(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
                     unsigned geom_id, unsigned prim_id, float bu, float bv,
                     float t_hit, lr__hit *hit);
/* Gives the lanes of r that valid masks off (valid[i] == 0) the harmless
 * ray lane_disabled gives (origin 0, direction +z, tnear 1 > tfar 0).
 * Call it before rtcOccluded16 on a packet whose masked lanes hold
 * anything: Embree's AVX2 code (on a CPU without AVX-512) checks those
 * lanes too, and a NaN there aborts the process ("Assertion
 * `all(valid, ray.valid())' failed" in occludedCoherent). */
void lr__ray16_quiet_lanes(struct RTCRay16 *r, const int *valid);
int lr__planes_block(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar);

/* The triangle hits of a packet in structure-of-arrays form, in double:
 * what lr__hit_complete computes for a triangle, lane by lane in loops the
 * compiler vectorises.  Every operation is the one the scalar code does,
 * in the same order, without FMA contraction (-ffp-contract=off), so each
 * lane's result is the scalar result to the bit (the test suite renders
 * scenes both ways and compares bytes).  Lanes that were not gathered
 * keep what they held (zeros, or an earlier packet's triangle): the
 * vector loops compute on them too, and nobody reads those results, so a
 * caller zeroes the struct once and then reuses it. */
typedef struct lr__hits16 {
    double ng[3][16]; /* the triangle's unit normal (lr__geom.face_ng) */
    float n[9][16];   /* corner normals (flat meshes: not written) */
    float smooth[16]; /* 1 with corner normals */
    /* Results. */
    double px[16], py[16], pz[16]; /* hit position */
    double gx[16], gy[16], gz[16]; /* ng, facing the ray */
    double sx[16], sy[16], sz[16]; /* ns */
    double eps[16];
} lr__hits16;

/* Copies lane i's triangle (geometry rh->hit.geomID[i], a triangle mesh
 * with lambert_triangles set) into h.  (Inline: it runs for every lane of
 * every packet, and as a call it cost 8% of a render.) */
static inline void lr__hits16_gather(const lr_scene *s,
                                     const struct RTCRayHit16 *rh, int i,
                                     lr__hits16 *h)
{
    const lr__geom *g = &s->geoms[rh->hit.geomID[i]];
    unsigned prim = rh->hit.primID[i];
    const double *ng = &g->face_ng[3 * (size_t)prim];
    h->ng[0][i] = ng[0];
    h->ng[1][i] = ng[1];
    h->ng[2][i] = ng[2];
    if (g->corner_normals != NULL) {
        const float *n = &g->corner_normals[9 * (size_t)prim];
        for (int k = 0; k < 9; k++)
            h->n[k][i] = n[k];
        h->smooth[i] = 1.0f;
    } else {
        /* n keeps what it held: lr__hits16_complete takes ng in this
         * lane whatever it computes from n. */
        h->smooth[i] = 0.0f;
    }
}

/* Completes all sixteen lanes from the rays and hits in rh. */
void lr__hits16_complete(const struct RTCRayHit16 *rh, double floor,
                         lr__hits16 *h);

/* The origin for a ray leaving the hit point towards `dir`: pushed along
 * the geometric normal, on the side dir points to, by hit->eps, which
 * grows with the magnitude of the hit position and the ray's length
 * (float rounding grows with both), so the new ray cannot hit the surface
 * it starts on. */
lr__v3 lr__offset_origin(const lr__hit *hit, lr__v3 dir);

/* 1 if Embree accepts a ray with this origin and direction: every
 * component finite and within 1.8e18 (Embree aborts the process on
 * others).  lr__trace and lr__occluded check it and treat a ray that
 * fails as missing Embree's geometry (the infinite planes are still
 * tested), counting it in lr__scene_skipped_rays; callers that fill
 * packets (lr__shadow_ray16) must check it themselves. */
#define LR__EMBREE_MAX_COORD 1.8e18
static inline int lr__embree_can_trace(lr__v3 org, lr__v3 dir)
{
    /* Written so that NaN fails; & rather than && (no branch each). */
    const double m = LR__EMBREE_MAX_COORD;
    return (fabs(org.x) <= m) & (fabs(org.y) <= m) & (fabs(org.z) <= m) &
           (fabs(dir.x) <= m) & (fabs(dir.y) <= m) & (fabs(dir.z) <= m);
}
unsigned long long lr__scene_skipped_rays(const lr_scene *s);

/* A sphere's t along org + t dir, solved again in double near the
 * intersector's t: Embree finds spheres in float, so on a big sphere its
 * t can be far off the surface (0.1 units on a radius of 1e6).  The
 * quadratic in the cancellation-free form (|oc| - r)(|oc| + r) and
 * q = -(b + sign(b) sqrt(disc)); the root nearest t, if it lies in
 * (0, tmax); otherwise t itself.  lr__hit_complete and path16.c's vector
 * bounce both use it, so that their hits agree to the bit. */
static inline double lr__sphere_refine_t(const lr__geom *g, lr__v3 org,
                                         lr__v3 dir, double t, double tmax)
{
    lr__v3 oc = v3_sub(org, g->center);
    double a = v3_dot(dir, dir), b = v3_dot(oc, dir);
    double l = v3_len(oc);
    double c = (l - g->radius) * (l + g->radius);
    double disc = b * b - a * c;
    if (disc >= 0.0 && a > 0.0) {
        double q = -(b + copysign(sqrt(disc), b));
        double r1 = q / a, r2 = q != 0.0 ? c / q : r1;
        double best = fabs(r1 - t) < fabs(r2 - t) ? r1 : r2;
        if (best > 0.0 && best < tmax)
            t = best;
    }
    return t;
}

#endif
