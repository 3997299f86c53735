/*
 * shade.c: direct light, hard shadows, reflection, refraction.
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
#include "shade.h"

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

static lr__v3 mirror(lr__v3 d, lr__v3 n)
{
    return v3_madd(d, n, -2.0 * v3_dot(d, n));
}

lr__v3 lr__ambient(const lr_scene *s, const lr__hit *h)
{
    return v3_mul(s->ambient, s->materials[h->material].diffuse);
}

int lr__light_ray_setup(const lr_scene *s, const lr__hit *h, lr__v3 wo,
                        size_t i, lr__light_ray *out)
{
    const lr__material *m = &s->materials[h->material];
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
        E = v3_scale(lt->power, 1.0 / d2);
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
        double ca = v3_dot(mirror(v3_neg(l), h->ns), wo);
        if (ca > 0.0)
            f = v3_madd(f, m->specular, (m->shininess + 2.0) / (2.0 * M_PI) *
                                            pow(ca, m->shininess));
    }
    out->org = lr__offset_origin(h, l);
    out->dir = l;
    out->tfar = isfinite(dist) ? v3_len(v3_sub(lt->position, out->org)) : dist;
    out->f_E_cos = v3_scale(v3_mul(f, E), cos_t);
    return 1;
}

static lr__v3 direct(const lr_scene *s, const lr__hit *h, lr__v3 wo,
                     uint64_t *rays)
{
    lr__v3 L = lr__ambient(s, h);
    for (size_t i = 0; i < s->n_lights; i++) {
        lr__light_ray lr;
        if (!lr__light_ray_setup(s, h, wo, i, &lr))
            continue;
        (*rays)++;
        if (!lr__occluded(s, lr.org, lr.dir, lr.tfar))
            L = v3_add(L, lr.f_E_cos);
    }
    return L;
}

static lr__v3 radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                       int max_depth, double throughput, uint64_t *rays);

static lr__v3 secondary(const lr_scene *s, const lr__hit *h, lr__v3 dir,
                        int depth, int max_depth, double throughput,
                        uint64_t *rays)
{
    lr__v3 L = v3(0, 0, 0);
    if (depth >= max_depth)
        return L;
    const lr__material *m = &s->materials[h->material];
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
        lr__v3 r = mirror(dir, h->ns);
        if (v3_dot(r, h->ng) <= 0.0)
            r = mirror(dir, h->ng);
        lr__v3 Li = radiance(s, lr__offset_origin(h, r), r, depth + 1,
                             max_depth, t_refl, rays);
        L = v3_add(L, v3_mul(w_refl, Li));
    }
    double t_refr = throughput * v3_maxc(w_refr);
    if (t_refr >= LR__MIN_THROUGHPUT) {
        lr__v3 Li = radiance(s, lr__offset_origin(h, t_dir), t_dir,
                             depth + 1, max_depth, t_refr, rays);
        L = v3_add(L, v3_mul(w_refr, Li));
    }
    return L;
}

lr__v3 lr__secondary(const lr_scene *s, const lr__hit *h, lr__v3 dir,
                     int depth, int max_depth, uint64_t *rays)
{
    return secondary(s, h, dir, depth, max_depth, 1.0, rays);
}

static lr__v3 radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                       int max_depth, double throughput, uint64_t *rays)
{
    lr__hit h;
    (*rays)++;
    if (!lr__trace(s, org, dir, INFINITY, &h))
        return s->background;
    lr__v3 L = direct(s, &h, v3_neg(dir), rays);
    return v3_add(L, secondary(s, &h, dir, depth, max_depth, throughput,
                               rays));
}

lr__v3 lr__radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                    int max_depth, uint64_t *rays)
{
    return radiance(s, org, dir, depth, max_depth, 1.0, rays);
}
