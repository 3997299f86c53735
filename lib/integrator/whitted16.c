/*
 * whitted16.c: the Whitted integrator (whitted.c) for a packet of sixteen
 * camera rays.  Lanes that hit a purely Lambertian triangle take vector
 * loops, which compute exactly what whitted.c's scalar code computes,
 * operation for operation, so that a pixel's bits do not depend on the
 * path its ray took (tests/test_shade.c compares the two with
 * lr__whitted_scalar_only); the other lanes are shaded one by one by
 * whitted.c's code.
 */
#include "scene/light.h"
#include "integrator/whitted.h"

#include <float.h>
#include <emmintrin.h>
#include <math.h>
#include <string.h>

/* light_ray_setup for a Lambertian material of albedo k, all lanes at
 * once: fills the shadow packet's rays, ok[i] (-1 where a shadow ray is
 * needed, in lanes where ok[i] was -1 before), the contribution f E cos
 * (fr, fg, fb) and the shadow rays in double (ro, rd, rt), as
 * light_ray_setup gives them, for the infinite planes.  Returns the
 * number of lanes that need a shadow ray (counted here, from registers:
 * read back from ok[], it waited for the stores). */
static inline __attribute__((always_inline)) int
light_rays16_body(const lr__light *restrict lt, const lr__hits16 *restrict h,
                  const double k[restrict 3][16], int *restrict ok,
                  struct RTCRay16 *restrict r, double fr[restrict 16],
                  double fg[restrict 16], double fb[restrict 16],
                  double ro[restrict 3][16], double rd[restrict 3][16],
                  double rt[restrict 16], const int keep)
{
    const int point = lt->kind == LR__LIGHT_POINT;
    const double lpx = lt->position.x, lpy = lt->position.y,
                 lpz = lt->position.z;
    const double ldx = -lt->direction.x, ldy = -lt->direction.y,
                 ldz = -lt->direction.z;
    const double Pr = lt->power.x, Pg = lt->power.y, Pb = lt->power.z;
    const double inv_pi = 1.0 / M_PI;
    /* lr__spot_falloff, spelled out for the lanes (1 for a plain point
     * light, so that its bits are the same as before spots existed). */
    const int spot = lt->spot;
    const double sdx = lt->direction.x, sdy = lt->direction.y,
                 sdz = lt->direction.z;
    const double cs = lt->cone_scale, co = lt->cone_offset;
    int lit_[16];
    /* The shadow rays in double: into the caller's arrays when it keeps
     * them (keep: the infinite planes test them), else into locals the
     * compiler keeps in registers or drops. */
    struct {
        double o[3][16], d[3][16], t[16];
    } S;
    for (int i = 0; i < 16; i++) {
        double tox = lpx - h->px[i], toy = lpy - h->py[i], toz = lpz - h->pz[i];
        double d2 = tox * tox + toy * toy + toz * toz;
        double dist = sqrt(d2);
        double id = 1.0 / dist;
        double lx = point ? tox * id : ldx;
        double ly = point ? toy * id : ldy;
        double lz = point ? toz * id : ldz;
        double a = -(lx * sdx + ly * sdy + lz * sdz) * cs + co;
        a = a < 0.0 ? 0.0 : a > 1.0 ? 1.0 : a;
        double id2 = (spot ? a * a : 1.0) / d2;
        double Er = point ? Pr * id2 : Pr;
        double Eg = point ? Pg * id2 : Pg;
        double Eb = point ? Pb * id2 : Pb;
        double cos_t = h->sx[i] * lx + h->sy[i] * ly + h->sz[i] * lz;
        double cos_g = lx * h->gx[i] + ly * h->gy[i] + lz * h->gz[i];
        /* The scalar code's tests, NaN behaviour included. */
        int lit = (!point | (d2 > 0.0)) & !(cos_t <= 0.0) &
                  !(h->gx[i] * lx + h->gy[i] * ly + h->gz[i] * lz <= 0.0);
        /* lr__offset_origin */
        double side = cos_g >= 0.0 ? 1.0 : -1.0;
        double se = side * h->eps[i];
        double orx = h->px[i] + h->gx[i] * se;
        double ory = h->py[i] + h->gy[i] * se;
        double orz = h->pz[i] + h->gz[i] * se;
        double qx = lpx - orx, qy = lpy - ory, qz = lpz - orz;
        double tfar = point ? sqrt(qx * qx + qy * qy + qz * qz) : INFINITY;
        fr[i] = ((k[0][i] * inv_pi) * Er) * cos_t;
        fg[i] = ((k[1][i] * inv_pi) * Eg) * cos_t;
        fb[i] = ((k[2][i] * inv_pi) * Eb) * cos_t;
        lit_[i] = lit;
        S.o[0][i] = orx, S.o[1][i] = ory, S.o[2][i] = orz;
        S.d[0][i] = lx, S.d[1][i] = ly, S.d[2][i] = lz;
        S.t[i] = tfar;
    }
    /* (Apart: the vectoriser takes loops of one element width more
     * readily.) */
    int count = 0;
    for (int i = 0; i < 16; i++) {
        int need = (ok[i] != 0) & lit_[i];
        count += need;
        ok[i] = -need;
        r->org_x[i] = (float)S.o[0][i];
        r->org_y[i] = (float)S.o[1][i];
        r->org_z[i] = (float)S.o[2][i];
        r->tnear[i] = 0.0f;
        r->dir_x[i] = (float)S.d[0][i];
        r->dir_y[i] = (float)S.d[1][i];
        r->dir_z[i] = (float)S.d[2][i];
        r->time[i] = 0.0f;
        r->tfar[i] = S.t[i] < FLT_MAX ? (float)S.t[i] : FLT_MAX;
        if (keep) {
            ro[0][i] = S.o[0][i], ro[1][i] = S.o[1][i], ro[2][i] = S.o[2][i];
            rd[0][i] = S.d[0][i], rd[1][i] = S.d[1][i], rd[2][i] = S.d[2][i];
            rt[i] = S.t[i];
        }
        r->mask[i] = 0xFFFFFFFFu;
        r->id[i] = 0;
        r->flags[i] = 0;
    }
    return count;
}

/* light_rays16_body with the rays in double kept (for the infinite
 * planes), and without: radiance16_n's batches never have planes. */
__attribute__((target_clones("avx512f", "avx2", "default"))) static int
light_rays16(const lr__light *restrict lt, const lr__hits16 *restrict h,
             const double k[restrict 3][16], int *restrict ok,
             struct RTCRay16 *restrict r, double fr[restrict 16],
             double fg[restrict 16], double fb[restrict 16],
             double ro[restrict 3][16], double rd[restrict 3][16],
             double rt[restrict 16])
{
    return light_rays16_body(lt, h, k, ok, r, fr, fg, fb, ro, rd, rt, 1);
}

__attribute__((target_clones("avx512f", "avx2", "default"))) static int
light_rays16_f(const lr__light *restrict lt, const lr__hits16 *restrict h,
               const double k[restrict 3][16], int *restrict ok,
               struct RTCRay16 *restrict r, double fr[restrict 16],
               double fg[restrict 16], double fb[restrict 16])
{
    return light_rays16_body(lt, h, k, ok, r, fr, fg, fb, NULL, NULL, NULL, 0);
}


int lr__whitted_scalar_only = 0;

/* The vector path takes a lane whose camera ray hit a triangle of a
 * purely Lambertian material with no infinite plane in front of it (the
 * planes, which Embree does not hold, are tested in double as
 * lr__hit_complete tests them): its hit is completed (lr__hits16), its
 * shadow rays set up (light_rays16) and its light added in vector loops;
 * the planes are tested for its shadow rays as lr__occluded tests them.
 * Other lanes go through lr__hit_complete and whitted.c's shading. */
static int vector_lane(const lr_scene *s, const struct RTCRayHit16 *rh, int i)
{
    unsigned g = rh->hit.geomID[i];
    if (g == RTC_INVALID_GEOMETRY_ID || !s->geoms[g].lambert_triangles)
        return 0;
    if (s->n_planes == 0)
        return 1;
    const struct RTCRay16 *r = &rh->ray;
    return !lr__planes_block(s, v3(r->org_x[i], r->org_y[i], r->org_z[i]),
                             v3(r->dir_x[i], r->dir_y[i], r->dir_z[i]),
                             (double)r->tfar[i]);
}

/* What the vector path keeps between packets: its lanes' hits and
 * albedos (see lr__hits16 for why these are not cleared per packet). */
typedef struct scratch16 {
    lr__hits16 h;
    double k[3][16];
} scratch16;

/* Each thread's scratch, zeroed when the thread starts; a thread renders
 * one packet at a time. */
static _Thread_local scratch16 tls_scratch;

/* Its address, taken once per packet by a call.  In position-independent
 * code each use of a thread-local variable is a call to __tls_get_addr,
 * which may clobber every vector register, and the compiler repeated that
 * call inside radiance16's lane loop, spilling registers around it (a
 * quarter of radiance16's time on the bench scene). */
__attribute__((noinline)) static scratch16 *thread_scratch(void)
{
    return &tls_scratch;
}

/* A vector lane's light, kept per channel (v[0..2][i]): ambient x
 * albedo to start with, then each light's contribution added where its
 * shadow ray got through, in the order of the lights, as the scalar code
 * adds them.  Lanes without a shadow ray keep their value. */
static void vector_start16(const lr_scene *s, const double k[3][16],
                           double v[restrict 3][16])
{
    for (int c = 0; c < 3; c++) {
        double a = c == 0 ? s->ambient.x : c == 1 ? s->ambient.y : s->ambient.z;
        for (int i = 0; i < 16; i++)
            v[c][i] = a * k[c][i];
    }
}

/* take ? a : b, as bits under a mask: for that written as a condition
 * GCC makes a branch in each lane of the loops below (mispredicted along
 * shadow edges and silhouettes), even with both loads made beforehand. */
static inline double blend(int take, double a, double b)
{
    uint64_t m = (uint64_t)0 - (uint64_t)(take != 0), x, y;
    memcpy(&x, &a, sizeof x);
    memcpy(&y, &b, sizeof y);
    x = (x & m) | (y & ~m);
    memcpy(&a, &x, sizeof a);
    return a;
}

/* The sum made in every lane and kept where lit (blend). */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
vector_add16(const int *restrict valid, const struct RTCRay16 *restrict shadow,
             const double fr[restrict 16], const double fg[restrict 16],
             const double fb[restrict 16], double v[restrict 3][16])
{
    const double *f[3] = {fr, fg, fb};
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < 16; i++) {
            /* Embree marks an occluded ray by setting tfar to -inf. */
            int lit = (valid[i] != 0) & (shadow->tfar[i] >= 0.0f);
            v[c][i] = blend(lit, v[c][i] + f[c][i], v[c][i]);
        }
}

/* Lane i's camera ray missed and no infinite plane can meet it: the
 * sky, as lr__hit_complete's miss gives it, less the light side's sun
 * (lt, the camera's rays'). */
static inline lr__v3 sky16(const lr_scene *s, const lr__lt_view *lt,
                           const struct RTCRay16 *r, int i)
{
    if (s->env == NULL)
        return s->background;
    lr__v3 d = v3_norm(v3(r->dir_x[i], r->dir_y[i], r->dir_z[i]));
    return lr__lt_weigh(lr__env_radiance(s, d), lr__lt_sun_w(lt, d));
}

/* Vector lane i's hit into sc->h and its albedo into sc->k: a textured
 * albedo looked up where lr__hit_complete would (the same barycentrics,
 * the same formula). */
static inline void vector_gather(const lr_scene *s,
                                 const struct RTCRayHit16 *rh, int i,
                                 scratch16 *sc)
{
    lr__hits16_gather(s, rh, i, &sc->h);
    const lr__geom *G = &s->geoms[rh->hit.geomID[i]];
    lr__v3 kd = G->albedo;
    if (G->albedo_textured) {
        double uv[2];
        lr__material tmp;
        int has_uv = lr__triangle_uv(G, rh->hit.primID[i], rh->hit.u[i],
                                     rh->hit.v[i], uv);
        kd = lr__material_at(s, G->material, has_uv, uv, &tmp)->diffuse;
    }
    sc->k[0][i] = kd.x, sc->k[1][i] = kd.y, sc->k[2][i] = kd.z;
}

/* radiance16 for a packet whose camera rays have been traced. */
static void shade16(const lr_scene *restrict s, int max_depth,
                    struct RTCRayHit16 *restrict rh, int n,
                    const lr__lt_view *lt, lr__v3 L[restrict 16],
                    uint64_t *restrict rays)
{
    scratch16 *sc = thread_scratch();
    struct RTCRay16 shadow __attribute__((aligned(64)));
    /* For the shadow packets below. */
    int valid[16] __attribute__((aligned(64)));
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;

    /* Each lane is a vector lane, a scalar lane (hit completed by
     * lr__hit_complete, shaded by the scalar code) or a miss.  Only the
     * scalar lanes need the per-lane loops further down. */
    lr__hit hit[16];
    lr__material mt[16];
    const lr__material *m[16];
    lr__v3 org[16], dir[16];
    int has_hit[16], vec[16], n_vec = 0, n_scalar = 0;
    const int vector_ok = !lr__whitted_scalar_only;
    /* A miss with no infinite plane to meet: what lr__hit_complete would
     * say (a third of the bench scene's packets miss in every lane). */
    const int miss_is_sky = s->n_planes == 0;
    for (int i = 0; i < n; i++) {
        unsigned g = rh->hit.geomID[i];
        vec[i] = 0;
        has_hit[i] = 0;
        if (g == RTC_INVALID_GEOMETRY_ID && miss_is_sky) {
            L[i] = sky16(s, lt, &rh->ray, i);
            continue;
        }
        if (vector_ok && vector_lane(s, rh, i)) {
            vec[i] = -1;
            n_vec++;
            vector_gather(s, rh, i, sc);
            continue;
        }
        /* The scalar code works in double on the ray as traced. */
        n_scalar++;
        const struct RTCRay16 *r = &rh->ray;
        org[i] = v3(r->org_x[i], r->org_y[i], r->org_z[i]);
        dir[i] = v3(r->dir_x[i], r->dir_y[i], r->dir_z[i]);
        has_hit[i] = lr__hit_complete(s, org[i], dir[i], INFINITY, g,
                                      rh->hit.primID[i], rh->hit.u[i],
                                      rh->hit.v[i], rh->ray.tfar[i], &hit[i]);
        if (has_hit[i])
            m[i] = lr__hit_material(s, &hit[i], &mt[i]);
        L[i] = has_hit[i]
                   ? v3_add(
                         lr__lt_weigh(lr__whitted_emitted(m[i], &hit[i]),
                                      lr__lt_direct_w(lt, hit[i].geom, dir[i])),
                         lr__whitted_ambient(s, m[i]))
                   : lr__env_radiance(s, v3_norm(dir[i]));
    }
    if (n_vec == 0 && n_scalar == 0)
        return; /* every lane missed */
    for (int i = n; i < 16; i++)
        vec[i] = 0;
    double v[3][16] __attribute__((aligned(64)));
    if (n_vec) {
        lr__hits16_complete(rh, s->eps_floor, &sc->h);
        vector_start16(s, (const double(*)[16])sc->k, v);
    }

    /* One packet of shadow rays per light.  They are coherent too: they
     * leave the few surface points one pixel sees for one light (6%
     * faster on the bench scene than the incoherent flag). */
    for (size_t k = 0; k < s->n_lights; k++) {
        lr__light_ray lr[16];
        double fr[16], fg[16], fb[16], ro[3][16], rd[3][16], rt[16];
        int any = 0;
        for (int i = 0; i < 16; i++)
            valid[i] = vec[i];
        if (n_vec) {
            any = light_rays16(&s->lights[k], &sc->h,
                               (const double(*)[16])sc->k, valid, &shadow, fr,
                               fg, fb, ro, rd, rt);
        }
        for (int i = 0; i < n && n_scalar; i++) {
            if (vec[i] || !has_hit[i])
                continue;
            if (lr__light_ray_setup(s, m[i], &hit[i], v3_neg(dir[i]), k,
                                    &lr[i])) {
                valid[i] = -1;
                lr__shadow_ray16(&shadow, i, lr[i].org, lr[i].dir, lr[i].tfar);
                any++;
            }
        }
        if (!any)
            continue;
        /* The masked lanes hold what light_rays16 made of lanes without
         * a hit (NaN where the camera ray missed), or nothing at all. */
        lr__ray16_quiet_lanes(&shadow, valid);
        rtcOccluded16(valid, s->rtc, &ctx, &shadow);
        *rays += (uint64_t)any;
        if (n_vec && s->n_planes == 0) {
            vector_add16(valid, &shadow, fr, fg, fb, v);
            if (!n_scalar)
                continue;
        }
        for (int i = 0; i < n; i++) {
            /* Embree marks an occluded ray by setting tfar to -inf. */
            if (!valid[i] || !(shadow.tfar[i] >= 0.0f))
                continue;
            if (vec[i] && s->n_planes != 0 &&
                !lr__planes_block(s, v3(ro[0][i], ro[1][i], ro[2][i]),
                                  v3(rd[0][i], rd[1][i], rd[2][i]), rt[i])) {
                v[0][i] = v[0][i] + fr[i];
                v[1][i] = v[1][i] + fg[i];
                v[2][i] = v[2][i] + fb[i];
            } else if (!vec[i] &&
                       !lr__planes_block(s, lr[i].org, lr[i].dir, lr[i].tfar)) {
                L[i] = v3_add(L[i], lr[i].f_E_cos);
            }
        }
    }
    if (n_vec)
        for (int i = 0; i < n; i++)
            if (vec[i])
                L[i] = v3(v[0][i], v[1][i], v[2][i]);

    if (max_depth > 0 && n_scalar)
        for (int i = 0; i < n; i++)
            if (!vec[i] && has_hit[i])
                L[i] = v3_add(L[i],
                              lr__whitted_secondary(s, m[i], &hit[i], dir[i], 0,
                                                    max_depth, 1.0, rays));
}

void lr__whitted_radiance16(const lr_scene *s, int max_depth,
                            struct RTCRayHit16 *rh, int n,
                            const lr__sample_id *id, lr__v3 L[16],
                            uint64_t *rays)
{
    /* Whitted's rays make no random decisions: of id it reads lt. */
    lr__intersect16(s, rh, n, rays);
    shade16(s, max_depth, rh, n, id->lt, L, rays);
}

/* Which of a packet's n lanes hit something: bit i for lane i.  The
 * loops over a packet's lanes below visit its hits by these bits: a test
 * per lane was a branch the processor mispredicted wherever hits and
 * misses mix (a silhouette, the horizon). */
static inline unsigned hit_mask(const struct RTCRayHit16 *rh, int n)
{
    /* Four lanes at a time in SSE2 (every x86-64 has it): as plain C,
     * sixteen compares and shifts. */
    const __m128i none = _mm_set1_epi32((int)RTC_INVALID_GEOMETRY_ID);
    unsigned miss = 0;
    for (int k = 0; k < 4; k++) {
        __m128i g = _mm_load_si128((const __m128i *)&rh->hit.geomID[4 * k]);
        miss |= (unsigned)_mm_movemask_ps(
                    _mm_castsi128_ps(_mm_cmpeq_epi32(g, none)))
                << (4 * k);
    }
    return ~miss & ((1u << n) - 1u);
}

/* A packet whose every lane is a miss (no infinite planes) or a vector
 * lane (`hits`: its hit_mask): shade16 would use none of its scalar
 * code. */
static int all_vector(const lr_scene *s, const struct RTCRayHit16 *rh,
                      unsigned hits)
{
    if (lr__whitted_scalar_only || s->n_planes != 0)
        return 0;
    if (s->all_lambert)
        return 1;
    for (; hits; hits &= hits - 1) {
        unsigned g = rh->hit.geomID[__builtin_ctz(hits)];
        if (!s->geoms[g].lambert_triangles)
            return 0;
    }
    return 1;
}

/* A batch packet's result: L[c][i] = v[c][i] in its vector lanes
 * (vec[i] != 0), sky[c][i] in the others (lanes past the packet's n
 * included: the film ignores them).  In whole vectors, as the film reads
 * them: written lane by lane, the film's vector loads would wait for the
 * stores to retire, and as plain C with a condition per lane GCC made a
 * branch of each. */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
lanes_out16(const int *restrict vec, const double v[restrict 3][16],
            const double sky[restrict 3][16], double L[restrict 3][16])
{
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < 16; i++)
            L[c][i] = blend(vec[i], v[c][i], sky[c][i]);
}

/* Asks for the triangle data vector_gather will read for a packet's
 * hits (its unit normal, its corner normals): a pixel's first packets
 * meet triangles whose data is not in the cache yet, and the load then
 * waited in vector_gather.  Called a packet late, while Embree traces
 * the next one. */
static inline void prefetch_lanes(const lr_scene *s,
                                  const struct RTCRayHit16 *rh, unsigned hits)
{
    for (; hits; hits &= hits - 1) {
        int i = __builtin_ctz(hits);
        const lr__geom *G = &s->geoms[rh->hit.geomID[i]];
        if (!G->lambert_triangles)
            continue;
        size_t prim = rh->hit.primID[i];
        __builtin_prefetch(&G->face_ng[3 * prim]);
        if (G->corner_normals != NULL) {
            /* 36 bytes: they may straddle two cache lines. */
            __builtin_prefetch(&G->corner_normals[9 * prim]);
            __builtin_prefetch(&G->corner_normals[9 * prim + 8]);
        }
    }
}

/* What such a packet keeps between the steps of radiance16_n. */
typedef struct batch16 {
    scratch16 sc; /* its lanes' hits and albedos, as shade16's */
    double v[3][16];
    double sky[3][16]; /* the misses' sky, with an environment map */
    double fr[16], fg[16], fb[16];
    int vec[16], valid[16];
    int n_vec, any;
    struct RTCRay16 shadow __attribute__((aligned(64)));
} batch16;

#define LR__BATCH_MAX 8
static _Thread_local batch16 tls_batch[LR__BATCH_MAX];

/* (A call, as for thread_scratch.) */
__attribute__((noinline)) static batch16 *thread_batch(void)
{
    return tls_batch;
}

/* Every packet's camera rays traced before any packet is shaded, and the
 * packets with vector lanes only shaded step by step together: all their
 * hits completed and shadow rays made, then all their shadow packets
 * traced, then their light added.  So one packet's arithmetic (its square
 * roots and divisions queue for the one divider) overlaps another's
 * gathers, and Embree's results, written by masked stores that a load
 * right after waits for, are read a packet later.  Each packet's rays,
 * Embree calls and arithmetic are the ones shade16 gives it alone. */
void lr__whitted_radiance16_n(const lr_scene *s, int max_depth,
                              struct RTCRayHit16 *rh, const int *n, int count,
                              const lr__sample_id *id, double (*L)[3][16],
                              uint64_t *rays)
{
    (void)id;
    if (count > LR__BATCH_MAX) {
        /* In batches of at most LR__BATCH_MAX: each packet's result is
         * its own whatever the batch. */
        lr__whitted_radiance16_n(s, max_depth, rh, n, LR__BATCH_MAX, id, L,
                                 rays);
        lr__whitted_radiance16_n(s, max_depth, rh + LR__BATCH_MAX,
                                 n + LR__BATCH_MAX, count - LR__BATCH_MAX,
                                 id + LR__BATCH_MAX, L + LR__BATCH_MAX, rays);
        return;
    }
    unsigned hits[LR__BATCH_MAX];
    for (int p = 0; p < count; p++) {
        lr__intersect16(s, &rh[p], n[p], rays);
        if (p > 0) {
            hits[p - 1] = hit_mask(&rh[p - 1], n[p - 1]);
            prefetch_lanes(s, &rh[p - 1], hits[p - 1]);
        }
    }
    hits[count - 1] = hit_mask(&rh[count - 1], n[count - 1]);
    prefetch_lanes(s, &rh[count - 1], hits[count - 1]);
    batch16 *B = thread_batch();
    int of[LR__BATCH_MAX], nb = 0;
    for (int p = 0; p < count; p++) {
        if (all_vector(s, &rh[p], hits[p])) {
            of[nb++] = p;
            continue;
        }
        lr__v3 Lp[16];
        shade16(s, max_depth, &rh[p], n[p], id[p].lt, Lp, rays);
        /* Lanes past n[p] hold 0: the film's test reads all sixteen. */
        for (int i = 0; i < 16; i++) {
            L[p][0][i] = i < n[p] ? Lp[i].x : 0.0;
            L[p][1][i] = i < n[p] ? Lp[i].y : 0.0;
            L[p][2][i] = i < n[p] ? Lp[i].z : 0.0;
        }
    }
    for (int b = 0; b < nb; b++) {
        int p = of[b];
        batch16 *bt = &B[b];
        const struct RTCRayHit16 *r = &rh[p];
        unsigned h = hits[p];
        bt->n_vec = __builtin_popcount(h);
        for (int i = 0; i < 16; i++)
            bt->vec[i] = -(int)((h >> i) & 1u);
        for (unsigned m = h; m; m &= m - 1)
            vector_gather(s, r, __builtin_ctz(m), &bt->sc);
        if (s->env != NULL)
            for (unsigned m = ~h & ((1u << n[p]) - 1u); m; m &= m - 1) {
                int i = __builtin_ctz(m);
                lr__v3 sky = sky16(s, id[p].lt, &r->ray, i);
                bt->sky[0][i] = sky.x, bt->sky[1][i] = sky.y,
                bt->sky[2][i] = sky.z;
            }
        if (bt->n_vec) {
            lr__hits16_complete(r, s->eps_floor, &bt->sc.h);
            vector_start16(s, (const double(*)[16])bt->sc.k, bt->v);
        }
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (size_t k = 0; k < s->n_lights; k++) {
        for (int b = 0; b < nb; b++) {
            batch16 *bt = &B[b];
            bt->any = 0;
            if (!bt->n_vec)
                continue;
            for (int i = 0; i < 16; i++)
                bt->valid[i] = bt->vec[i];
            bt->any = light_rays16_f(&s->lights[k], &bt->sc.h,
                                     (const double(*)[16])bt->sc.k, bt->valid,
                                     &bt->shadow, bt->fr, bt->fg, bt->fb);
            if (bt->any)
                lr__ray16_quiet_lanes(&bt->shadow, bt->valid);
        }
        for (int b = 0; b < nb; b++) {
            batch16 *bt = &B[b];
            if (!bt->any)
                continue;
            rtcOccluded16(bt->valid, s->rtc, &ctx, &bt->shadow);
            *rays += (uint64_t)bt->any;
        }
        for (int b = 0; b < nb; b++) {
            batch16 *bt = &B[b];
            if (bt->any)
                vector_add16(bt->valid, &bt->shadow, bt->fr, bt->fg, bt->fb,
                             bt->v);
        }
    }
    /* The misses' value without an environment map. */
    double bg[3][16] __attribute__((aligned(64)));
    for (int i = 0; i < 16; i++)
        bg[0][i] = s->background.x, bg[1][i] = s->background.y,
        bg[2][i] = s->background.z;
    for (int b = 0; b < nb; b++) {
        int p = of[b];
        batch16 *bt = &B[b];
        lanes_out16(bt->vec, (const double(*)[16])bt->v,
                    s->env != NULL ? (const double(*)[16])bt->sky
                                   : (const double(*)[16])bg,
                    L[p]);
    }
}
