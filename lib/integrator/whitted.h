/*
 * whitted.h: what the Whitted integrator's two files share.  whitted.c
 * shades one hit at a time (direct light, hard shadows, mirrors and
 * glass); whitted16.c shades a packet of sixteen camera rays, taking the
 * lanes it can in vector loops and handing the others to whitted.c's
 * code, which must give the same bits either way.
 */
#ifndef LR_WHITTED_H
#define LR_WHITTED_H

#include "integrator/integrator.h"

#include <math.h>

/* One light as seen from a hit: the shadow ray to test and what arrives
 * if it is not blocked. */
typedef struct lr__light_ray {
    lr__v3 org, dir; /* shadow ray: offset origin, unit direction */
    double tfar;     /* to the light (infinite for directional lights) */
    lr__v3 f_E_cos;  /* BRDF x irradiance x cos(theta): the contribution */
} lr__light_ray;

/* The ambient term: albedo x ambient radiance.  (m: the hit's material
 * with its textures applied, lr__hit_material.) */
static inline lr__v3 lr__whitted_ambient(const lr_scene *s,
                                         const lr__material *m)
{
    return v3_mul(s->ambient, m->diffuse);
}

/* Emission seen at a hit: the front side of an emissive surface.  (Whitted
 * sees area lights but is not lit by them; the path integrator is.) */
static inline lr__v3 lr__whitted_emitted(const lr__material *m,
                                         const lr__hit *h)
{
    return h->entering ? m->emission : v3(0, 0, 0);
}

/* d mirrored about the unit normal n. */
static inline lr__v3 lr__whitted_mirror(lr__v3 d, lr__v3 n)
{
    return v3_madd(d, n, -2.0 * v3_dot(d, n));
}

/* The unshadowed contribution of light `i` at hit `h` seen from
 * direction wo; returns 0 when the light cannot contribute (behind the
 * surface, or the material reflects nothing), so no shadow ray is
 * needed.  The BRDF and the lights' irradiance: whitted.c's top comment.
 * (Inline: both files call it for every light at every hit,
 * and whitted16.c's vector loops must match it operation for
 * operation.) */
static inline int lr__light_ray_setup(const lr_scene *s, const lr__material *m,
                                      const lr__hit *h, lr__v3 wo, size_t i,
                                      lr__light_ray *out)
{
    int has_spec = v3_maxc(m->specular) > 0.0;
    if (!has_spec && !(v3_maxc(m->diffuse) > 0.0))
        return 0;
    const lr__light *lt = &s->lights[i];
    lr__v3 l, E;
    double dist;
    if (lt->kind == LR__LIGHT_POINT) {
        lr__v3 to = v3_sub(lt->position, h->p);
        double d2 = v3_dot(to, to);
        if (!(d2 > 0.0))
            return 0;
        dist = sqrt(d2);
        l = v3_scale(to, 1.0 / dist);
        E = v3_scale(lt->power, lr__spot_falloff(lt, l) / d2);
    } else {
        l = v3_neg(lt->direction);
        E = lt->power;
        dist = INFINITY;
    }
    double cos_t = v3_dot(h->ns, l);
    /* Light from behind the geometric surface never arrives, whatever the
     * interpolated normal says. */
    if (cos_t <= 0.0 || v3_dot(h->ng, l) <= 0.0)
        return 0;
    lr__v3 f = v3_scale(m->diffuse, 1.0 / M_PI);
    if (has_spec) {
        double ca = v3_dot(lr__whitted_mirror(v3_neg(l), h->ns), wo);
        if (ca > 0.0)
            f = v3_madd(f, m->specular,
                        (m->shininess + 2.0) / (2.0 * M_PI) *
                            pow(ca, m->shininess));
    }
    out->org = lr__offset_origin(h, l);
    out->dir = l;
    out->tfar = isfinite(dist) ? v3_len(v3_sub(lt->position, out->org)) : dist;
    out->f_E_cos = v3_scale(v3_mul(f, E), cos_t);
    return 1;
}

/* The mirror and refracted light at hit h of a ray along dir at bounce
 * `depth`, its branches traced while depth < max_depth and their weight
 * from the camera stays above whitted.c's LR__MIN_THROUGHPUT.
 * (whitted.c) */
lr__v3 lr__whitted_secondary(const lr_scene *s, const lr__material *m,
                             const lr__hit *h, lr__v3 dir, int depth,
                             int max_depth, double throughput, uint64_t *rays);

/* The integrator's radiance16 and radiance16_n (integrator.h).
 * (whitted16.c) */
void lr__whitted_radiance16(const lr_scene *s, int max_depth,
                            struct RTCRayHit16 *rh, int n,
                            const lr__sample_id *id, lr__v3 L[16],
                            uint64_t *rays);
void lr__whitted_radiance16_n(const lr_scene *s, int max_depth,
                              struct RTCRayHit16 *rh, const int *n, int count,
                              const lr__sample_id *id, double (*L)[3][16],
                              uint64_t *rays);

#endif
