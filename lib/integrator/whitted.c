/*
 * whitted.c: the Whitted integrator: direct light, hard shadows,
 * reflection, refraction, for one camera ray (a packet of sixteen:
 * whitted16.c, whose lanes on diffuse triangles take a vector path
 * computing exactly what this file computes).
 *
 * BRDF: Lambertian diffuse (albedo / pi) plus normalised Phong specular,
 * specular * (n + 2) / (2 pi) * cos^n(alpha) with alpha the angle between
 * the mirrored light direction and the view direction (Lafortune &
 * Willems 1994), so that a scene gives the radiance a physically based
 * renderer computes.  Point lights: intensity I in W/sr, irradiance
 * I cos(theta) / r^2.  Directional lights: irradiance E on a surface
 * facing them, E cos(theta).  Ambient: uniform radiance La, reflected as
 * albedo * La without shadowing (the classic ray tracer's ambient term).
 *
 * Mirror and glass rays branch (a dielectric both reflects and refracts),
 * so a tree of them grows exponentially with max_depth: a stack of glass
 * plates would need ~1.6^depth rays per sample.  A branch whose weight,
 * multiplied down from the camera ray, falls below LR__MIN_THROUGHPUT is
 * therefore not traced: it could change the sample by less than that
 * fraction of the light it carries.
 */
#include "scene/light.h"
#include "integrator/whitted.h"

#include <math.h>

#define LR__MIN_THROUGHPUT 1e-4

double lr__fresnel_dielectric(double cos_i, double eta)
{
    double sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if (sin2_t >= 1.0)
        return 1.0;
    double cos_t = sqrt(1.0 - sin2_t);
    double rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    double rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

static lr__v3 direct(const lr_scene *s, const lr__material *m, const lr__hit *h,
                     lr__v3 wo, uint64_t *rays)
{
    lr__v3 L = lr__whitted_ambient(s, m);
    for (size_t i = 0; i < s->n_lights; i++) {
        lr__light_ray lr;
        if (!lr__light_ray_setup(s, m, h, wo, i, &lr))
            continue;
        (*rays)++;
        if (!lr__occluded(s, lr.org, lr.dir, lr.tfar))
            L = v3_add(L, lr.f_E_cos);
    }
    return L;
}

static lr__v3 radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                       int max_depth, double throughput, const lr__lt_view *lt,
                       uint64_t *rays);

lr__v3 lr__whitted_secondary(const lr_scene *s, const lr__material *m,
                             const lr__hit *h, lr__v3 dir, int depth,
                             int max_depth, double throughput, uint64_t *rays)
{
    lr__v3 L = v3(0, 0, 0);
    if (depth >= max_depth)
        return L;
    /* Mirror weight, plus the part of the dielectric that reflects. */
    lr__v3 w_refl = m->reflect;
    lr__v3 w_refr = v3(0, 0, 0);
    lr__v3 t_dir = v3(0, 0, 0);
    if (v3_maxc(m->transmit) > 0.0) {
        double eta = h->entering ? 1.0 / m->ior : m->ior;
        double cos_i = -v3_dot(dir, h->ns);
        if (cos_i < 0.0)
            cos_i = 0.0;
        double F = lr__fresnel_dielectric(cos_i, eta);
        w_refl = v3_madd(w_refl, m->transmit, F);
        if (F < 1.0) {
            /* Snell's law with the shading normal. */
            double cos_t = sqrt(1.0 - eta * eta * (1.0 - cos_i * cos_i));
            t_dir = v3_norm(v3_add(v3_scale(dir, eta),
                                   v3_scale(h->ns, eta * cos_i - cos_t)));
            /* Refraction must cross the geometric surface. */
            if (v3_dot(t_dir, h->ng) < 0.0)
                w_refr = v3_scale(m->transmit, 1.0 - F);
        }
    }
    double t_refl = throughput * v3_maxc(w_refl);
    if (t_refl >= LR__MIN_THROUGHPUT) {
        lr__v3 r = lr__whitted_mirror(dir, h->ns);
        if (v3_dot(r, h->ng) <= 0.0)
            r = lr__whitted_mirror(dir, h->ng);
        lr__v3 Li = radiance(s, lr__offset_origin(h, r), r, depth + 1,
                             max_depth, t_refl, NULL, rays);
        L = v3_add(L, v3_mul(w_refl, Li));
    }
    double t_refr = throughput * v3_maxc(w_refr);
    if (t_refr >= LR__MIN_THROUGHPUT) {
        lr__v3 Li = radiance(s, lr__offset_origin(h, t_dir), t_dir, depth + 1,
                             max_depth, t_refr, NULL, rays);
        L = v3_add(L, v3_mul(w_refr, Li));
    }
    return L;
}

/* lt: the camera ray's light-side geometry (lr__sample_id), NULL past
 * the first hit. */
static lr__v3 radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                       int max_depth, double throughput, const lr__lt_view *lt,
                       uint64_t *rays)
{
    lr__hit h;
    (*rays)++;
    if (!lr__trace(s, org, dir, INFINITY, &h))
        return lr__lt_weigh(lr__env_radiance(s, dir), lr__lt_sun_w(lt, dir));
    lr__material mt;
    const lr__material *m = lr__hit_material(s, &h, &mt);
    lr__v3 Le = lr__lt_weigh(lr__whitted_emitted(m, &h),
                             lr__lt_direct_w(lt, h.geom, dir));
    lr__v3 L = v3_add(Le, direct(s, m, &h, v3_neg(dir), rays));
    return v3_add(L, lr__whitted_secondary(s, m, &h, dir, depth, max_depth,
                                           throughput, rays));
}

lr__v3 lr__radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                    int max_depth, uint64_t *rays)
{
    return radiance(s, org, dir, depth, max_depth, 1.0, NULL, rays);
}

static lr__v3 radiance1(const lr_scene *s, int max_depth, lr__v3 org,
                        lr__v3 dir, const lr__sample_id *id, uint64_t *rays)
{
    return radiance(s, org, dir, 0, max_depth, 1.0, id->lt, rays);
}

const lr__integrator lr__whitted = {
    .name = "whitted",
    .radiance = radiance1,
    .radiance16 = lr__whitted_radiance16,
    .radiance16_n = lr__whitted_radiance16_n,
};
