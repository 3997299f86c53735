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
 * From the fourth surface on, Russian roulette ends a path with
 * probability 1 - min(0.95, max throughput) (throughput taken without
 * the 1/eta^2 of glass, as pbrt-v4 does, so that light inside glass is
 * not cut short).
 *
 * Random numbers: every decision is a pure function of (pixel, sample,
 * dimension, seed), dimensions 6 + 8 k .. 6 + 8 k + 6 for the k-th
 * surface (see rnd1), so a path is a pure function of its sample.
 *
 * Camera rays: a packet of sixteen is traced together (rtcIntersect16);
 * each lane then goes on alone, since bounced rays are incoherent.
 */
#include "bsdf.h"
#include "integrator.h"
#include "light.h"

#include <math.h>

#define DIM_FIRST 6
#define DIMS_PER_BOUNCE 8
#define RR_FROM 3

static double mis(double a, double b)
{
    a *= a, b *= b;
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

/* A path's random numbers.  The first surface draws from the render's
 * sampler (stratified where the sampler is: that is where it pays), the
 * later ones from a hash of (seed, pixel, sample, dimension), a quarter
 * of the cost of a scrambled Sobol dimension (the sampler was 22% of a
 * Cornell box render). */
typedef struct rng {
    const lr__sample_id *id;
    uint64_t key; /* hash of (seed, pixel, sample) */
} rng;

static double rnd1(const rng *r, uint32_t dim)
{
    if (dim < DIM_FIRST + DIMS_PER_BOUNCE)
        return lr__sample_1d(r->id->sampler, r->id->pixel, r->id->sample,
                             dim);
    uint64_t h = lr__mix64(r->key ^ ((uint64_t)dim * 0x9e3779b97f4a7c15ull));
    return (double)(h >> 11) * 0x1p-53;
}

static void rnd2(const rng *r, uint32_t dim, double u[2])
{
    if (dim < DIM_FIRST + DIMS_PER_BOUNCE) {
        lr__sample_2d(r->id->sampler, r->id->pixel, r->id->sample, dim, u);
        return;
    }
    u[0] = rnd1(r, dim);
    u[1] = rnd1(r, dim + 1);
}

/* Light sampled from hit h towards a light, weighted: f cos Le w / pdf,
 * or 0 if blocked. */
static lr__v3 next_event(const lr_scene *s, const lr__hit *h,
                         const lr__bsdf *f, lr__v3 wo,
                         const rng *id, uint32_t dim, uint64_t *rays)
{
    double u[2];
    rnd2(id, dim, u);
    lr__light_sample ls;
    if (!lr__light_sample_from(s, h->p, rnd1(id, dim + 4), u, &ls))
        return v3(0, 0, 0);
    /* Light from behind the geometric surface arrives only through a
     * transmitting lobe, which evaluates it. */
    double bpdf;
    lr__v3 fv = lr__bsdf_eval(f, wo, ls.dir, &bpdf);
    double cos_i = fabs(v3_dot(ls.dir, h->ns));
    lr__v3 c = v3_scale(v3_mul(fv, ls.L), cos_i / ls.pdf);
    if (!(v3_maxc(c) > 0.0))
        return v3(0, 0, 0);
    if (!ls.delta)
        c = v3_scale(c, mis(ls.pdf, bpdf));
    lr__v3 org = lr__offset_origin(h, ls.dir);
    double tfar = INFINITY;
    if (isfinite(ls.dist)) {
        /* Stop short of the light's own surface (relative, as Mitsuba's
         * shadow epsilon). */
        lr__v3 q = v3_madd(h->p, ls.dir, ls.dist);
        tfar = v3_len(v3_sub(q, org)) * (1.0 - 1e-4);
    }
    (*rays)++;
    if (lr__occluded(s, org, ls.dir, tfar))
        return v3(0, 0, 0);
    return c;
}

/* The path from org along dir; if first is not NULL, the camera ray's
 * hit is already known (*first, valid when first_ok). */
static lr__v3 path(const lr_scene *s, int max_depth, lr__v3 org, lr__v3 dir,
                   const lr__sample_id *id, const lr__hit *first,
                   int first_ok, uint64_t *rays)
{
    lr__v3 L = v3(0, 0, 0), beta = v3(1, 1, 1);
    double eta_scale = 1.0; /* product of eta^2 crossed, for roulette */
    double prev_pdf = 0.0;
    int prev_delta = 1; /* the camera ray: nothing to weigh against */
    lr__v3 prev_p = org;
    dir = v3_norm(dir);
    const rng r = {id, lr__mix64(lr__mix64(id->sampler->seed ^
                                           lr__mix64(id->pixel)) ^
                                 id->sample)};
    for (int depth = 0;; depth++) {
        lr__hit h;
        int hit;
        if (depth == 0 && first != NULL) {
            hit = first_ok;
            if (hit)
                h = *first;
        } else {
            (*rays)++;
            hit = lr__trace(s, org, dir, INFINITY, &h);
        }
        if (!hit) {
            lr__v3 Le = lr__env_radiance(s, dir);
            double w = prev_delta ? 1.0
                                  : mis(prev_pdf, lr__light_pdf_env(s, dir));
            L = v3_add(L, v3_scale(v3_mul(beta, Le), w));
            break;
        }
        lr__material mt;
        const lr__material *m = lr__hit_material(s, &h, &mt);
        if (h.entering && v3_maxc(m->emission) > 0.0) {
            double w = 1.0;
            if (!prev_delta && h.geom >= 0)
                w = mis(prev_pdf, lr__light_pdf_area(s, prev_p, h.p, h.ng,
                                                     (unsigned)h.geom,
                                                     h.prim));
            L = v3_add(L, v3_scale(v3_mul(beta, m->emission), w));
        }
        if (depth > max_depth)
            break;
        lr__v3 wo = v3_neg(dir);
        L = v3_add(L, v3_mul(beta, v3_mul(m->diffuse, s->ambient)));
        lr__bsdf f;
        lr__bsdf_init(&f, m, &h);
        uint32_t dim = DIM_FIRST + DIMS_PER_BOUNCE * (uint32_t)depth;
        if (lr__bsdf_has_smooth_lobes(&f))
            L = v3_add(L, v3_mul(beta, next_event(s, &h, &f, wo, &r, dim,
                                                  rays)));
        double u[2];
        rnd2(&r, dim + 2, u);
        lr__v3 wi, weight;
        double pdf;
        int delta;
        if (!lr__bsdf_sample(&f, wo, rnd1(&r, dim + 5), u, &wi, &weight,
                             &pdf, &delta))
            break;
        /* A sampled direction must leave on the side the lobe says: in
         * front of the geometric surface for reflection, behind it for
         * transmission (shading normals can disagree). */
        int through = v3_dot(wi, h.ns) < 0.0;
        if ((v3_dot(wi, h.ng) < 0.0) != through)
            break;
        if (through && v3_maxc(m->transmit) > 0.0)
            eta_scale *= f.eta * f.eta;
        beta = v3_mul(beta, weight);
        prev_pdf = pdf;
        prev_delta = delta;
        prev_p = h.p;
        org = lr__offset_origin(&h, wi);
        dir = wi;
        if (depth + 1 >= RR_FROM) {
            double q = fmin(0.95, v3_maxc(beta) * eta_scale);
            if (!(rnd1(&r, dim + 6) < q))
                break;
            beta = v3_scale(beta, 1.0 / q);
        }
        if (!v3_finite(beta))
            break;
    }
    return L;
}

static lr__v3 radiance1(const lr_scene *s, int max_depth, lr__v3 org,
                        lr__v3 dir, const lr__sample_id *id, uint64_t *rays)
{
    return path(s, max_depth, org, dir, id, NULL, 0, rays);
}

static void radiance16(const lr_scene *s, int max_depth,
                       struct RTCRayHit16 *rh, int n, const lr__sample_id *id,
                       lr__v3 L[16], uint64_t *rays)
{
    lr__intersect16(s, rh, n, rays);
    for (int i = 0; i < n; i++) {
        const struct RTCRay16 *r = &rh->ray;
        lr__v3 org = v3(r->org_x[i], r->org_y[i], r->org_z[i]);
        lr__v3 dir = v3(r->dir_x[i], r->dir_y[i], r->dir_z[i]);
        lr__hit h;
        int ok = lr__hit_complete(s, org, dir, INFINITY, rh->hit.geomID[i],
                                  rh->hit.primID[i], rh->hit.u[i],
                                  rh->hit.v[i], rh->ray.tfar[i], &h);
        lr__sample_id lane = *id;
        lane.sample = id->sample + (uint32_t)i;
        L[i] = path(s, max_depth, org, dir, &lane, &h, ok, rays);
    }
}

const lr__integrator lr__path_tracer = {
    .name = "path",
    .radiance = radiance1,
    .radiance16 = radiance16,
};
