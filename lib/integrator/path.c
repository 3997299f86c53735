/*
 * path.c: the path integrator: unidirectional path tracing with
 * next-event estimation and multiple importance sampling (Veach 1997,
 * chapter 9; the power heuristic, beta = 2), as pbrt-v3's PathIntegrator
 * (section 14.5) and Mitsuba 3's `path`.
 *
 * At every surface a path takes one light sample (light.c) and one BSDF
 * sample (bsdf.c); light reached either way is weighted by the power
 * heuristic of the two densities, so area lights and the environment are
 * found both ways, delta lights (point, directional) and delta lobes
 * (mirror, smooth glass) one way only, unweighted.  Emission is one-sided
 * (the front: outward for spheres, counter-clockwise for triangles).
 * Ambient light keeps Whitted's meaning: albedo x La added, unshadowed,
 * at every surface the path meets.
 *
 * Depth: render.max_depth counts bounces after the first hit, as for
 * Whitted: 0 is direct light only; Mitsuba's max_depth is this + 2.
 * From the fifth surface on, Russian roulette ends a path with
 * probability 1 - min(0.95, max throughput) (throughput taken without
 * the 1/eta^2 of glass, as pbrt-v4 does, so that light inside glass is
 * not cut short).  That start is Mitsuba 3's default (rr_depth 5, its
 * depth counting surfaces from 1), so both trace the same paths; started
 * at the third surface, the Cornell box's relative MSE at equal spp was
 * 43% higher for 19% fewer rays (bench/path, docs/path-tracing.md).
 *
 * Random numbers: every decision is a pure function of (pixel, sample,
 * dimension, seed), dimensions 6 + 8 k .. 6 + 8 k + 6 for the k-th
 * surface (see bounce_numbers), so a path is a pure function of its
 * sample.
 *
 * Packets: the sixteen samples of a camera packet (one pixel's) go
 * through their bounces together, kept as arrays (path16.c): each
 * bounce's shadow rays are traced as one packet (rtcOccluded16) and the
 * continuation rays as another (rtcIntersect16), or in a scene of a few
 * primitives both in one pass; lanes on Lambertian surfaces are shaded
 * in path16.c's vector loops, the others here one by one (trace_paths).
 */
#include "integrator/bsdf.h"
#include "integrator/integrator.h"
#include "scene/light.h"
#include "integrator/path.h"

#include <math.h>

#define DIM_FIRST 6
#define DIMS_PER_BOUNCE LR__PATH_DIMS
#define RR_FROM LR__PATH_RR_FROM

#define mis lr__path_mis

/* A path's random numbers.  The first SOBOL_BOUNCES surfaces draw from
 * the render's sampler (stratified where the sampler is: that is where
 * it pays), through the pixel's pairs prepared once per packet
 * (sampler.h: no hashing per number); the later ones from a hash of
 * (seed, pixel, sample, dimension).  Three surfaces rather than one
 * lowered the Cornell box's relative MSE at equal spp by 6%; the
 * prepared pairs made them cheaper than one had been. */
#define SOBOL_BOUNCES 3
#define DIM_SOBOL_END (DIM_FIRST + DIMS_PER_BOUNCE * SOBOL_BOUNCES)
#define SOBOL_PAIRS (DIMS_PER_BOUNCE / 2 * SOBOL_BOUNCES)

/* The numbers of bounce `depth` of lanes 0..n-1 that are alive, all at
 * once: u[j][i] is dimension DIM_FIRST + DIMS_PER_BOUNCE depth + j of
 * lane i's sample (first + i).  The Sobol pairs are computed for all
 * sixteen lanes in one vectorised loop (lr__pixel_pairs_get16), the
 * hashed ones likewise (lr__path16_hashed); either way a lane's numbers
 * are those of its sample alone. */
static void bounce_numbers(const lr__pixel_pairs *pairs, const uint64_t key[16],
                           const double alive[16], int n, uint32_t first,
                           int depth, double u[DIMS_PER_BOUNCE][16])
{
    uint32_t dim = DIM_FIRST + DIMS_PER_BOUNCE * (uint32_t)depth;
    if (dim < DIM_SOBOL_END) {
        /* Dimension 6 (roulette's) only where roulette is played, and 7
         * never: a bounce before RR_FROM takes three pairs, not four
         * (the Sobol pairs were 9% of the Cornell box's CPU time). */
        uint32_t end = depth + 1 >= RR_FROM ? DIMS_PER_BOUNCE
                                            : DIMS_PER_BOUNCE - 2;
        for (uint32_t j = 0; j < end; j += 2)
            lr__pixel_pairs_get16(pairs, first, n, dim + j,
                                  (double(*)[16])u[j]);
        return;
    }
    /* (Again dimension 6 only where roulette is played.) */
    lr__path16_hashed(
        key, alive, dim,
        depth + 1 >= RR_FROM ? DIMS_PER_BOUNCE - 1 : DIMS_PER_BOUNCE - 2, u);
}

typedef lr__path_lane lane;

/* Light sampled from hit h towards a light: the lane's shadow ray and
 * its weighted contribution f cos Le w / pdf, to count if the ray is
 * clear; 0 if there is nothing to trace. */
/* glints: the lt flags where the hit is a glint surface of the light
 * side (its lights' light from here is the light side's), else NULL. */
static int next_event(const lr_scene *s, const lr__hit *h, const lr__bsdf *f,
                      lr__v3 wo, const double v[DIMS_PER_BOUNCE],
                      const lr__lt_view *glints, lane *p)
{
    lr__light_sample ls;
    if (!lr__light_sample_from(s, h->p, v[4], v, &ls) ||
        (lr__lt_flag(glints, ls.geom, LR__LT_GLINT_LIGHT) &&
         lr__lt_glint_core(wo, ls.dir, h->ng, f->m->roughness)))
        return 0;
    /* Light from behind the geometric surface arrives only through a
     * transmitting lobe, which evaluates it. */
    double bpdf;
    lr__v3 fv = lr__bsdf_eval(f, wo, ls.dir, &bpdf);
    double cos_i = fabs(v3_dot(ls.dir, h->ns));
    lr__v3 c = v3_scale(v3_mul(fv, ls.L), cos_i / ls.pdf);
    if (!(v3_maxc(c) > 0.0))
        return 0;
    if (!ls.delta)
        c = v3_scale(c, mis(ls.pdf, bpdf));
    p->s_c = v3_mul(p->beta, c);
    p->s_org = lr__offset_origin(h, ls.dir);
    p->s_dir = ls.dir;
    p->s_tfar = INFINITY;
    if (isfinite(ls.dist)) {
        /* Stop short of the light's own surface (relative, as Mitsuba's
         * shadow epsilon).  The origin is moved off the surface by an
         * offset that grows with the coordinates, and a ray that keeps
         * the direction sampled from h->p runs parallel to the sampled
         * one: it met a lamp before the sampled point (a sphere near its
         * silhouette, a tessellated lamp's next triangle), and a floor
         * lit by a lamp 200 units from the origin got 56% (sphere) or
         * 58% (48 x 24 mesh) of its light.  So the ray is aimed from the
         * moved origin at the sampled point, as Mitsuba's spawn_ray_to
         * does, and stops where it enters a sphere lamp if that comes
         * first.  Sphere lamps keep the parallel ray: stopped at its own
         * entry, it measured closer to the closed form (1.0000 and
         * 0.9957 of it 200 and 2000 units out, against 0.9996 and 0.979
         * aimed; test_path.c, test_sphere_lamp_irradiance and
         * test_mesh_lamp_irradiance).  A sphere lamp's entry is found
         * from the origin as Embree's float ray will hold it: 10^4 units
         * out the origin's rounding (5e-4) passed the stop's margin
         * (1e-4 of the distance), the lamp shadowed itself, and the floor
         * got 0.904 of its light (0.619 at 10^5). */
        int sphere = lr__light_is_sphere(s, &ls);
        if (sphere)
            p->s_org = v3((float)p->s_org.x, (float)p->s_org.y,
                          (float)p->s_org.z);
        lr__v3 q = v3_madd(h->p, ls.dir, ls.dist);
        lr__v3 e = v3_sub(q, p->s_org);
        double len = sqrt(e.x * e.x + e.y * e.y + e.z * e.z);
        if (!sphere)
            p->s_dir = v3(e.x / len, e.y / len, e.z / len);
        p->s_tfar = lr__light_reach(s, &ls, p->s_org, p->s_dir, len) *
                    (1.0 - 1e-4);
    }
    return 1;
}

/* The lane's surface (or escape, hit == 0) at bounce `depth`: light
 * found there, its light sample (p->shadow) and the next ray.  Returns 1
 * if the path goes on. */
/* lt: the camera ray's light-side flags (lr__sample_id) at depth 0, else
 * NULL; glint: at depth 1, those flags when the first hit was a glint
 * surface (whose glint lights' emission met now is the light side's),
 * else NULL. */
static int bounce(const lr_scene *s, int max_depth, int depth, int hit,
                  const lr__hit *h, const double v[DIMS_PER_BOUNCE],
                  const lr__lt_view *lt, const lr__lt_view *glint, lane *p)
{
    p->shadow = 0;
    if (!hit) {
        /* (Escaping camera rays only: lt is NULL past the first hit.) */
        double sun_w = lr__lt_sun_w(lt, p->dir);
        if (sun_w == 0.0)
            return 0;
        lr__v3 Le = lr__lt_weigh(lr__env_radiance(s, p->dir), sun_w);
        double w = p->prev_delta ? 1.0
                                 : mis(p->prev_pdf,
                                       lr__light_pdf_env(s, p->prev_p, p->dir));
        p->L = v3_add(p->L, v3_scale(v3_mul(p->beta, Le), w));
        return 0;
    }
    lr__material mt;
    const lr__material *m = lr__hit_material(s, h, &mt);
    double direct_w = lr__lt_direct_w(lt, h->geom, p->dir);
    if (h->entering && v3_maxc(m->emission) > 0.0 && direct_w > 0.0 &&
        !lr__lt_flag(glint, h->geom, LR__LT_GLINT_LIGHT)) {
        double w = 1.0;
        if (!p->prev_delta && h->geom >= 0)
            w = mis(p->prev_pdf,
                    lr__light_pdf_area(s, p->prev_p, h->p, h->ng,
                                       (unsigned)h->geom, h->prim));
        lr__v3 Le = lr__lt_weigh(m->emission, direct_w);
        p->L = v3_add(p->L, v3_scale(v3_mul(p->beta, Le), w));
    }
    if (depth > max_depth)
        return 0;
    lr__v3 wo = v3_neg(p->dir);
    p->L = v3_add(p->L, v3_mul(p->beta, v3_mul(m->diffuse, s->ambient)));
    lr__bsdf f;
    lr__bsdf_init(&f, m, h);
    if (lr__bsdf_has_smooth_lobes(&f))
        p->shadow = next_event(
            s, h, &f, wo, v,
            lr__lt_flag(lt, h->geom, LR__LT_GLINT_SURF) ? lt : NULL, p);
    lr__v3 wi, weight;
    double pdf;
    int delta;
    if (!lr__bsdf_sample(&f, wo, v[5], v + 2, &wi, &weight, &pdf, &delta))
        return 0;
    /* A sampled direction must leave on the side the lobe says: in
     * front of the geometric surface for reflection, behind it for
     * transmission (shading normals can disagree). */
    int through = v3_dot(wi, h->ns) < 0.0;
    if ((v3_dot(wi, h->ng) < 0.0) != through)
        return 0;
    if (through && v3_maxc(m->transmit) > 0.0)
        p->eta_scale *= f.eta * f.eta;
    p->beta = v3_mul(p->beta, weight);
    p->prev_pdf = pdf;
    p->prev_delta = delta;
    p->prev_p = h->p;
    p->org = lr__offset_origin(h, wi);
    p->dir = wi;
    if (depth + 1 >= RR_FROM) {
        double q = fmin(0.95, v3_maxc(p->beta) * p->eta_scale);
        if (!(v[6] < q))
            return 0;
        p->beta = v3_scale(p->beta, 1.0 / q);
    }
    return v3_finite(p->beta);
}

/* Lane i of S as a lane struct, and back: for the lanes shaded alone. */
static void lane_get(const lr__paths16 *S, int i, lane *p)
{
    p->L = v3(S->Lr[i], S->Lg[i], S->Lb[i]);
    p->beta = v3(S->br[i], S->bg[i], S->bb[i]);
    p->org = v3(S->ox[i], S->oy[i], S->oz[i]);
    p->dir = v3(S->dx[i], S->dy[i], S->dz[i]);
    p->prev_p = v3(S->ppx[i], S->ppy[i], S->ppz[i]);
    p->prev_pdf = S->ppdf[i];
    p->prev_delta = S->pdelta[i] != 0.0;
    p->eta_scale = S->eta[i];
}

static void lane_put(const lane *p, int alive, lr__paths16 *S, int i)
{
    S->Lr[i] = p->L.x, S->Lg[i] = p->L.y, S->Lb[i] = p->L.z;
    S->br[i] = p->beta.x, S->bg[i] = p->beta.y, S->bb[i] = p->beta.z;
    S->ox[i] = p->org.x, S->oy[i] = p->org.y, S->oz[i] = p->org.z;
    S->dx[i] = p->dir.x, S->dy[i] = p->dir.y, S->dz[i] = p->dir.z;
    S->ppx[i] = p->prev_p.x, S->ppy[i] = p->prev_p.y, S->ppz[i] = p->prev_p.z;
    S->ppdf[i] = p->prev_pdf;
    S->pdelta[i] = p->prev_delta;
    S->eta[i] = p->eta_scale;
    S->alive[i] = alive;
    S->shadow[i] = p->shadow;
    if (!p->shadow)
        return;
    S->sox[i] = p->s_org.x, S->soy[i] = p->s_org.y, S->soz[i] = p->s_org.z;
    S->sdx[i] = p->s_dir.x, S->sdy[i] = p->s_dir.y, S->sdz[i] = p->s_dir.z;
    S->scr[i] = p->s_c.x, S->scg[i] = p->s_c.y, S->scb[i] = p->s_c.z;
    S->stfar[i] = p->s_tfar;
}

/* The paths of lanes 0..n-1 (n >= 1) of a packet of camera rays that the
 * camera filled, all samples of one pixel: the camera rays are traced
 * together, then each bounce's shadow rays together and its
 * continuation rays together.  Bounced rays are incoherent, but in a
 * scene of a few primitives the cost of a ray is mostly the per-call
 * work, which a packet shares; a lane's result is what it would be
 * traced alone.  The paths stay as arrays (path16.c's lr__paths16)
 * throughout; lanes that path16.c's vector bounce does not take are
 * copied out, shaded alone (bounce) and copied back. */
static void trace_paths(const lr_scene *s, int max_depth,
                        struct RTCRayHit16 *rh, int n, const lr__sample_id *id,
                        lr__v3 L[16], uint64_t *rays)
{
    lr__paths_camera16(s, rh, n, rays);
    lr__pixel_pairs pairs;
    lr__pixel_pairs_init(&pairs, id->sampler, id->pixel, DIM_FIRST,
                         n > 1 ? SOBOL_PAIRS : 0);
    /* One per thread (9 KB: zeroing it per packet had cost 2.5% of the
     * Cornell box's CPU time). */
    static _Thread_local lr__path16 w16;
    lr__path16_begin(s, &w16, rh, n);
    lr__paths16 *S = &w16.S;
    uint64_t key[16]; /* hash of (seed, pixel, sample), for hashed numbers */
    uint64_t kp = lr__mix64(id->sampler->seed ^ lr__mix64(id->pixel));
    for (int i = 0; i < 16; i++)
        key[i] = lr__mix64(kp ^ (id->sample + (uint32_t)i));
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    int packed = lr__paths_packed(s);
    /* A bounce's numbers; lanes that are done keep their last ones (the
     * vector loops compute on every lane). */
    double U[DIMS_PER_BOUNCE][16] = {{0}};
    /* Lanes whose camera ray met a glint surface of the light side first
     * (only lanes shaded alone can: such a surface is rough metal). */
    unsigned char glint[16] = {0};
    for (int depth = 0;; depth++) {
        bounce_numbers(&pairs, key, S->alive, n, id->sample, depth, U);
        /* This bounce's surfaces, light samples and next rays: lanes on
         * untextured Lambertian surfaces together (path16.c), the
         * others alone; either way with the same result. */
        int alone[16];
        int m = lr__path16_sort(s, &w16, depth, max_depth, n, rh, alone);
        for (int c = 0; c < m; c++) {
            int i = alone[c];
            lane p;
            lane_get(S, i, &p);
            /* The camera ray's hit with the ray as the camera made it. */
            lr__v3 dir = depth == 0 ? v3(w16.cdx[i], w16.cdy[i], w16.cdz[i])
                                    : p.dir;
            lr__hit h;
            int hit = lr__hit_complete(
                s, p.org, dir, INFINITY, rh->hit.geomID[i], rh->hit.primID[i],
                rh->hit.u[i], rh->hit.v[i], rh->ray.tfar[i], &h);
            /* (Dimension 7 of a bounce is not used.) */
            double v[DIMS_PER_BOUNCE] = {0};
            for (int j = 0; j < DIMS_PER_BOUNCE - 1; j++)
                v[j] = U[j][i];
            int alive = bounce(s, max_depth, depth, hit, &h, v,
                               depth == 0 ? id->lt : NULL,
                               depth == 1 && glint[i] ? id->lt : NULL, &p);
            /* The BSDF's ray from a glint surface, if within the glint's
             * core: should it meet a glint light, the light side has it. */
            if (depth == 0)
                glint[i] =
                    (unsigned char)(alive &&
                                    lr__lt_flag(id->lt, h.geom,
                                                LR__LT_GLINT_SURF) &&
                                    lr__lt_glint_core(
                                        v3_neg(dir), p.dir, h.ng,
                                        s->materials[h.material].roughness));
            lane_put(&p, alive, S, i);
        }
        if (w16.vec)
            lr__path16_lambert(s, &w16, depth, (const double(*)[16])U);
        /* The shadow rays: those an infinite plane blocks are done. */
        for (int i = 0; i < n; i++)
            *rays += S->shadow[i] != 0.0;
        for (int i = 0; i < n && s->n_planes > 0; i++)
            if (S->shadow[i] != 0.0 &&
                lr__planes_block(s, v3(S->sox[i], S->soy[i], S->soz[i]),
                                 v3(S->sdx[i], S->sdy[i], S->sdz[i]),
                                 S->stfar[i]))
                S->shadow[i] = 0.0;
        if (packed) {
            /* The shadow rays and the continuation rays together,
             * straight to spheres.c and few_triangles.c in double, which
             * meet every primitive themselves (no float packet to fill
             * and unpack).  (What reads a hit reads the ray from S, and
             * t from rh.) */
            lr__rays_packed P;
            int ns = lr__path16_pack_shadows(S, &P);
            int go = lr__path16_pack_rays(S, &P);
            if (ns + go > 0) {
                double occ[LR__PACKED];
                lr__paths_trace_packed(s, &P, ns, rh, occ);
                lr__path16_unoccluded(S, &P, ns, occ);
            }
            if (!go)
                break;
            *rays += (uint64_t)go;
            continue;
        }
        /* Embree's code for CPUs without AVX-512 checks every lane's
         * ray, masked or not, and aborts on garbage: the lanes without a
         * ray are quieted. */
        struct RTCRay16 sh __attribute__((aligned(64)));
        int valid[16] __attribute__((aligned(64)));
        if (lr__path16_shadows16(S, &sh, valid)) {
            lr__paths_occluded16(s, valid, &ctx, &sh);
            /* Embree marks an occluded ray by setting tfar to -inf. */
            for (int i = 0; i < n; i++)
                if (valid[i] && sh.tfar[i] >= 0.0f) {
                    S->Lr[i] = S->Lr[i] + S->scr[i];
                    S->Lg[i] = S->Lg[i] + S->scg[i];
                    S->Lb[i] = S->Lb[i] + S->scb[i];
                }
        }
        int go = lr__path16_rays16(S, rh, valid);
        if (!go)
            break;
        lr__paths_intersect16(s, valid, &ctx, rh);
        *rays += (uint64_t)go;
    }
    for (int i = 0; i < n; i++)
        L[i] = v3(S->Lr[i], S->Lg[i], S->Lb[i]);
}

static lr__v3 radiance1(const lr_scene *s, int max_depth, lr__v3 org,
                        lr__v3 dir, const lr__sample_id *id, uint64_t *rays)
{
    /* A packet of one, so that a ray gives what it gives in a packet. */
    struct RTCRayHit16 rh __attribute__((aligned(64)));
    int valid[16] = {-1};
    lr__shadow_ray16(&rh.ray, 0, org, dir, INFINITY);
    lr__ray16_quiet_lanes(&rh.ray, valid);
    rh.hit.geomID[0] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][0] = RTC_INVALID_GEOMETRY_ID;
    lr__v3 L[16];
    trace_paths(s, max_depth, &rh, 1, id, L, rays);
    return L[0];
}

const lr__integrator lr__path_tracer = {
    .name = "path",
    .radiance = radiance1,
    .radiance16 = trace_paths,
    .prepare = lr__spheres_build,
};
