/*
 * light.c: light sampling for the path integrator (light.h): the list of
 * area lights, the pick of one light, sampling a point on a triangle (by
 * area) or a sphere (by the solid angle it subtends), and the densities
 * of those choices for multiple importance sampling.  The environment's
 * own sampling is envmap.c.
 */
#include "scene/light.h"
#include "scene/envmap.h"

#include <math.h>
#include <stdlib.h>

static void tri_corners(const lr_scene *s, unsigned g, unsigned prim,
                        lr__v3 v[3])
{
    const lr__geom *G = &s->geoms[g];
    const unsigned *ix = &G->indices[3 * (size_t)prim];
    for (int c = 0; c < 3; c++) {
        const float *p = &G->vertices[3 * (size_t)ix[c]];
        v[c] = v3(p[0], p[1], p[2]);
    }
}

/* The luminance an emitter's power is taken from: the emission's, times
 * its texture's mean (per channel) where it has one.  Only the choice
 * among emitters uses it (their density, which MIS and next-event
 * estimation share), so the estimate stays unbiased; a texture that
 * varies much over one mesh makes that mesh's triangles chosen by area
 * alone, not by their own texels. */
static double emitter_luminance(const lr__material *m)
{
    const lr__texture *t = m->emission_tex;
    if (t == NULL)
        return lr__luminance(m->emission);
    return lr__luminance(v3(m->emission.x * t->mean[0],
                            m->emission.y * t->mean[1],
                            m->emission.z * t->mean[2]));
}

/* The emitters' power (pi x total: a Lambertian emitter of radiance L
 * and area A sends pi A L), their power-weighted centroid and a radius
 * about it holding every emitter (corners, spheres' extents). */
static void emitters_extent(lr_scene *s, double total)
{
    lr__v3 c = v3(0, 0, 0);
    double wsum = 0.0;
    for (size_t i = 0; i < s->n_emitters; i++) {
        const lr__emitter *e = &s->emitters[i];
        const lr__geom *G = &s->geoms[e->geom];
        double w = e->area * emitter_luminance(&s->materials[G->material]);
        lr__v3 x = G->kind == LR__GEOM_TRIANGLES
                       ? v3_add(e->a, v3_scale(v3_add(e->e1, e->e2), 1.0 / 3))
                       : G->center;
        c = v3_madd(c, x, w);
        wsum += w;
    }
    c = wsum > 0.0 ? v3_scale(c, 1.0 / wsum) : c;
    double r = 0.0;
    for (size_t i = 0; i < s->n_emitters; i++) {
        const lr__emitter *e = &s->emitters[i];
        const lr__geom *G = &s->geoms[e->geom];
        if (G->kind == LR__GEOM_TRIANGLES) {
            r = fmax(r, v3_len(v3_sub(e->a, c)));
            r = fmax(r, v3_len(v3_sub(v3_add(e->a, e->e1), c)));
            r = fmax(r, v3_len(v3_sub(v3_add(e->a, e->e2), c)));
        } else {
            r = fmax(r, v3_len(v3_sub(G->center, c)) + G->radius);
        }
    }
    s->emit_power = M_PI * total;
    s->emit_centre = c;
    s->emit_radius = r;
}

int lr__scene_emits(const lr_scene *s)
{
    for (size_t g = 0; g < s->n_geoms; g++)
        if (emitter_luminance(&s->materials[s->geoms[g].material]) > 0.0)
            return 1;
    return 0;
}

lr_status lr__emitters_build(lr_scene *s, lr_error *err)
{
    size_t n = 0;
    for (size_t g = 0; g < s->n_geoms; g++) {
        lr__geom *G = &s->geoms[g];
        G->emitter = -1;
        if (!(emitter_luminance(&s->materials[G->material]) > 0.0))
            continue;
        G->emitter = (long)n;
        n += G->kind == LR__GEOM_TRIANGLES ? G->n_triangles : 1;
    }
    if (n == 0)
        return LR_OK;
    s->emitters = malloc(n * sizeof *s->emitters);
    s->emitter_cdf = malloc(n * sizeof *s->emitter_cdf);
    if (s->emitters == NULL || s->emitter_cdf == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    double total = 0.0;
    size_t k = 0;
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *G = &s->geoms[g];
        if (G->emitter < 0)
            continue;
        double lum = emitter_luminance(&s->materials[G->material]);
        size_t m = G->kind == LR__GEOM_TRIANGLES ? G->n_triangles : 1;
        for (size_t i = 0; i < m; i++, k++) {
            lr__emitter *e = &s->emitters[k];
            *e = (lr__emitter){.geom = (unsigned)g, .prim = (unsigned)i};
            if (G->kind == LR__GEOM_TRIANGLES) {
                lr__v3 v[3];
                tri_corners(s, (unsigned)g, (unsigned)i, v);
                e->a = v[0];
                e->e1 = v3_sub(v[1], v[0]);
                e->e2 = v3_sub(v[2], v[0]);
                lr__v3 c = v3_cross(e->e1, e->e2);
                e->area = 0.5 * v3_len(c);
                e->n = v3_norm(c);
            } else {
                e->area = 4.0 * M_PI * G->radius * G->radius;
            }
            double area = e->area;
            total += area * lum;
            s->emitter_cdf[k] = total;
        }
    }
    s->n_emitters = n;
    for (size_t i = 0; i < n; i++)
        s->emitter_cdf[i] = total > 0.0 ? s->emitter_cdf[i] / total
                                        : (double)(i + 1) / (double)n;
    emitters_extent(s, total);
    return LR_OK;
}

/* The share of a pick that goes uniformly to the choices (light.h). */
#define DEFENSIVE 0.1

/* What point light lt gives p, as an irradiance estimate: its
 * intensity's luminance (times a spot's falloff) over the squared
 * distance; a directional light's irradiance. */
static double delta_weight(const lr__light *lt, lr__v3 p)
{
    double lum = lr__luminance(lt->power);
    if (lt->kind != LR__LIGHT_POINT)
        return lum;
    lr__v3 to = v3_sub(lt->position, p);
    double d2 = v3_dot(to, to);
    if (!(d2 > 0.0))
        return lum;
    return lum * lr__spot_falloff(lt, v3_scale(to, 1.0 / sqrt(d2))) / d2;
}

/* Mixes weights w[0..n) (each >= 0) into probabilities: (1 - DEFENSIVE)
 * w / sum + DEFENSIVE / n, or 1 / n each when the sum is not a positive
 * finite number.  Present choices only: n counts them. */
static void mix(double *w, int n)
{
    double sum = 0.0;
    for (int i = 0; i < n; i++)
        sum += w[i];
    int ok = sum > 0.0 && isfinite(sum);
    for (int i = 0; i < n; i++)
        w[i] = ok ? (1.0 - DEFENSIVE) * (w[i] / sum) + DEFENSIVE / n : 1.0 / n;
}

/* Whether light samples go to the environment.  Not to a constant
 * colour (no map) when the scene has other lights: its radiance is the
 * same from every direction, so the BSDF's sample, which every bounce
 * traces anyway, already follows what it brings (f cos, up to
 * visibility; for a Lambertian surface exactly), and a light sample of
 * it (uniform over the sphere, half of it below the surface) would only
 * take picks from the lamps.  Its light is then found by the BSDF's
 * rays alone, weighted 1 (its light density is 0: lr__light_pdf_env),
 * unbiased as before.  On Blender's default scene (a point light and a
 * grey world, bench/blender_cycles.py) relMSE at 16 spp went from 8.9e-4
 * to 2.6e-4 and a sample got cheaper (0.71 -> 0.57 CPU s); the floor of
 * test_light_pick.c from rms 0.0673 to 0.0468.  A constant world alone
 * keeps its light samples: a bounce would otherwise trace no light
 * sample at all. */
static int env_sampled(const lr_scene *s)
{
    if (!lr__env_is_light(s))
        return 0;
    return s->env != NULL || (s->n_emitters == 0 && s->n_lights == 0);
}

/* The probabilities of picking each kind at p: pk[0] area lights, pk[1]
 * the environment, pk[2] point and directional lights (0 for a kind the
 * scene lacks).  Each kind is weighed by the irradiance it could bring
 * to p, taking surfaces to face it: the area lights' power over pi
 * (d^2 + r^2) (d from their centroid, r their radius: a point inside
 * them is not infinitely favoured), pi times the environment's mean
 * luminance, and the point lights' delta_weight summed.  A scene with a
 * single kind picks it with probability 1, as it always did.  Returns
 * the number of kinds. */
static int kind_probs(const lr_scene *s, lr__v3 p, double pk[3])
{
    int has[3] = {s->n_emitters > 0, env_sampled(s), s->n_lights > 0};
    int nk = has[0] + has[1] + has[2];
    pk[0] = pk[1] = pk[2] = 0.0;
    if (nk <= 1) {
        for (int k = 0; k < 3; k++)
            pk[k] = has[k];
        return nk;
    }
    double w[3];
    int n = 0;
    if (has[0]) {
        lr__v3 d = v3_sub(s->emit_centre, p);
        w[n++] = s->emit_power /
                 (M_PI * (v3_dot(d, d) + s->emit_radius * s->emit_radius));
    }
    if (has[1])
        w[n++] = M_PI * (s->env != NULL ? s->env->mean_lum
                                        : lr__luminance(s->background));
    if (has[2]) {
        double sum = 0.0;
        for (size_t i = 0; i < s->n_lights; i++)
            sum += delta_weight(&s->lights[i], p);
        w[n++] = sum;
    }
    mix(w, n);
    n = 0;
    for (int k = 0; k < 3; k++)
        if (has[k])
            pk[k] = w[n++];
    return nk;
}

/* The point or directional light u picks at p (u rescaled into [0, 1)
 * by the caller), with the pick's probability *q. */
static size_t delta_pick(const lr_scene *s, lr__v3 p, double u, double *q)
{
    size_t n = s->n_lights;
    *q = 1.0;
    if (n == 1)
        return 0;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++)
        sum += delta_weight(&s->lights[i], p);
    int ok = sum > 0.0 && isfinite(sum);
    double acc = 0.0;
    for (size_t i = 0; i < n; i++) {
        double w = delta_weight(&s->lights[i], p);
        *q = ok ? (1.0 - DEFENSIVE) * (w / sum) + DEFENSIVE / (double)n
                : 1.0 / (double)n;
        acc += *q;
        if (u < acc)
            return i;
    }
    return n - 1; /* (rounding: *q is the last light's) */
}

/* Probability that the power pick chooses emitter i. */
static double emitter_prob(const lr_scene *s, size_t i)
{
    return s->emitter_cdf[i] - (i > 0 ? s->emitter_cdf[i - 1] : 0.0);
}

/* Index of the emitter whose cdf interval holds u. */
static size_t emitter_find(const lr_scene *s, double u)
{
    size_t lo = 0, hi = s->n_emitters - 1;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (s->emitter_cdf[mid] > u)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* Solid-angle density of a point sampled uniformly on an area A, seen
 * from distance d at cosine cos_l to its normal: d^2 / (A |cos_l|). */
static double area_to_solid(double area, double d2, double cos_l)
{
    double c = fabs(cos_l);
    return c > 0.0 && area > 0.0 ? d2 / (area * c) : 0.0;
}

/* 1 - cos(theta_max) of the cone a sphere of radius r at distance d
 * subtends, written as sin^2 / (1 + cos) so that it keeps its digits for
 * small, far spheres. */
static double cone_one_minus_cos(double r, double d)
{
    double sin2 = r * r / (d * d);
    double cos_max = sqrt(fmax(0.0, 1.0 - sin2));
    return sin2 / (1.0 + cos_max);
}

/* Samples emitter e from p: point q, its normal, the density, and its
 * texture coordinates (*has_uv 0 when none). */
static int sample_emitter(const lr_scene *s, const lr__emitter *e, lr__v3 p,
                          const double u[2], lr__v3 *q, lr__v3 *nq, double *pdf,
                          int *has_uv, double uv[2])
{
    const lr__geom *G = &s->geoms[e->geom];
    if (G->kind == LR__GEOM_TRIANGLES) {
        /* Uniform on the triangle: b0 = 1 - sqrt(u0), b1 = u1 sqrt(u0)
         * (pbrt-v3, section 13.6.3). */
        double su = sqrt(u[0]);
        double b1 = u[1] * su, b2 = su - b1;
        /* a + b1 (b - a) + b2 (c - a), with b0 = 1 - su. */
        *q = v3_add(e->a, v3_add(v3_scale(e->e1, b1), v3_scale(e->e2, b2)));
        /* Embree's barycentrics of q are (b1, b2). */
        *has_uv = lr__triangle_uv(G, e->prim, b1, b2, uv);
        *nq = e->n;
        lr__v3 to = v3_sub(*q, p);
        double d2 = v3_dot(to, to);
        *pdf = area_to_solid(e->area, d2, v3_dot(*nq, to) / sqrt(d2));
        return *pdf > 0.0;
    }
    *has_uv = 0;
    lr__v3 wc = v3_sub(G->center, p);
    double dc = v3_len(wc), r = G->radius;
    if (dc <= r * (1.0 + 1e-9)) {
        /* Inside (or on) the sphere: uniform by area (z = 1 - 2 u0). */
        double z = 1.0 - 2.0 * u[0], sr = sqrt(fmax(0.0, 1.0 - z * z));
        double phi = 2.0 * M_PI * u[1];
        *nq = v3(sr * cos(phi), sr * sin(phi), z);
        *q = v3_madd(G->center, *nq, r);
        lr__v3 to = v3_sub(*q, p);
        double d2 = v3_dot(to, to);
        *pdf = area_to_solid(e->area, d2,
                             v3_dot(*nq, v3_scale(to, 1.0 / sqrt(d2))));
        return *pdf > 0.0;
    }
    /* Outside: uniform in the cone the sphere subtends (pbrt-v3, section
     * 14.2.2), the point being where the sampled direction meets it. */
    wc = v3_scale(wc, 1.0 / dc);
    double omc = cone_one_minus_cos(r, dc);
    double cos_t = 1.0 - u[0] * omc;
    double sin_t = sqrt(fmax(0.0, 1.0 - cos_t * cos_t));
    double phi = 2.0 * M_PI * u[1];
    lr__v3 a = fabs(wc.x) > 0.9 ? v3(0, 1, 0) : v3(1, 0, 0);
    lr__v3 t1 = v3_norm(v3_cross(a, wc)), t2 = v3_cross(wc, t1);
    lr__v3 w = v3_add(
        v3_scale(wc, cos_t),
        v3_add(v3_scale(t1, sin_t * cos(phi)), v3_scale(t2, sin_t * sin(phi))));
    /* Nearest intersection of p + t w with the sphere. */
    double b = dc * cos_t;
    double t = b - sqrt(fmax(0.0, r * r - dc * dc * sin_t * sin_t));
    *q = v3_madd(p, w, t);
    *nq = v3_norm(v3_sub(*q, G->center));
    *pdf = omc > 0.0 ? 1.0 / (2.0 * M_PI * omc) : 0.0;
    return *pdf > 0.0;
}

int lr__light_sample_from(const lr_scene *s, lr__v3 p, double u_pick,
                          const double u[2], lr__light_sample *out)
{
    double pks[3];
    if (kind_probs(s, p, pks) == 0)
        return 0;
    out->geom = -1;
    /* The kind whose share of [0, 1) holds u_pick; the rest of u_pick,
     * rescaled, picks within the kind. */
    int k = 0, last = pks[2] > 0.0 ? 2 : pks[1] > 0.0 ? 1 : 0;
    double lo = 0.0;
    while (k < last && !(u_pick < lo + pks[k] && pks[k] > 0.0))
        lo += pks[k++];
    double pk = pks[k];
    double v = fmin((u_pick - lo) / pk, 0x1.fffffffffffffp-1);
    if (k == 0) {
        size_t i = emitter_find(s, v);
        const lr__emitter *e = &s->emitters[i];
        lr__v3 q, nq;
        double pdf, uv[2];
        int has_uv;
        if (!sample_emitter(s, e, p, u, &q, &nq, &pdf, &has_uv, uv))
            return 0;
        lr__v3 to = v3_sub(q, p);
        double d = v3_len(to);
        out->dir = v3_scale(to, 1.0 / d);
        /* One-sided: only the front (outward, counter-clockwise) side
         * emits. */
        if (!(v3_dot(out->dir, nq) < 0.0))
            return 0;
        out->dist = d;
        const lr__geom *G = &s->geoms[e->geom];
        if (G->kind == LR__GEOM_SPHERE &&
            lr__material_textured(&s->materials[G->material])) {
            has_uv = 1;
            lr__sphere_uv(nq, uv);
        }
        lr__material mt;
        out->L = lr__material_at(s, G->material, has_uv, uv, &mt)->emission;
        out->pdf = pk * emitter_prob(s, i) * pdf;
        out->delta = 0;
        out->geom = (int)e->geom;
        return out->pdf > 0.0;
    }
    if (k == 1) {
        double pdf;
        out->dir = lr__envmap_sample(s, u, &out->L, &pdf);
        out->dist = INFINITY;
        out->pdf = pk * pdf;
        out->delta = 0;
        return out->pdf > 0.0;
    }
    double q;
    const lr__light *lt = &s->lights[delta_pick(s, p, v, &q)];
    out->delta = 1;
    out->pdf = pk * q;
    if (lt->kind == LR__LIGHT_POINT) {
        lr__v3 to = v3_sub(lt->position, p);
        double d2 = v3_dot(to, to);
        if (!(d2 > 0.0))
            return 0;
        out->dist = sqrt(d2);
        out->dir = v3_scale(to, 1.0 / out->dist);
        out->L = v3_scale(lt->power, lr__spot_falloff(lt, out->dir) / d2);
    } else {
        out->dir = v3_neg(lt->direction);
        out->dist = INFINITY;
        out->L = lt->power;
    }
    return 1;
}

int lr__light_is_sphere(const lr_scene *s, const lr__light_sample *ls)
{
    return ls->geom >= 0 && s->geoms[ls->geom].kind == LR__GEOM_SPHERE;
}

double lr__light_reach(const lr_scene *s, const lr__light_sample *ls,
                       lr__v3 org, lr__v3 dir, double t)
{
    if (!lr__light_is_sphere(s, ls))
        return t;
    const lr__geom *G = &s->geoms[ls->geom];
    /* The nearer root of |org + x dir - centre| = r, when org is
     * outside. */
    lr__v3 oc = v3_sub(org, G->center);
    double b = v3_dot(oc, dir);
    double c = v3_dot(oc, oc) - G->radius * G->radius;
    double disc = b * b - c;
    if (c > 0.0 && disc >= 0.0) {
        double enter = -b - sqrt(disc);
        if (enter > 0.0 && enter < t)
            return enter;
    }
    return t;
}

double lr__light_pdf_area(const lr_scene *s, lr__v3 p, lr__v3 q, lr__v3 ng_q,
                          unsigned g, unsigned prim)
{
    double pks[3];
    kind_probs(s, p, pks);
    const lr__geom *G = &s->geoms[g];
    if (!(pks[0] > 0.0) || G->emitter < 0)
        return 0.0;
    size_t i = (size_t)G->emitter + prim;
    double pe = emitter_prob(s, i) * pks[0];
    lr__v3 to = v3_sub(q, p);
    double d2 = v3_dot(to, to);
    if (!(d2 > 0.0))
        return 0.0;
    double cos_l = v3_dot(ng_q, v3_scale(to, 1.0 / sqrt(d2)));
    if (G->kind == LR__GEOM_SPHERE) {
        double dc = v3_len(v3_sub(G->center, p));
        if (dc > G->radius * (1.0 + 1e-9)) {
            double omc = cone_one_minus_cos(G->radius, dc);
            return omc > 0.0 ? pe / (2.0 * M_PI * omc) : 0.0;
        }
    }
    return pe * area_to_solid(s->emitters[i].area, d2, cos_l);
}

double lr__light_pdf_env(const lr_scene *s, lr__v3 p, lr__v3 dir)
{
    double pks[3];
    kind_probs(s, p, pks);
    if (!(pks[1] > 0.0))
        return 0.0;
    return lr__envmap_pdf(s, dir) * pks[1];
}

void lr__spot_set(lr__light *lt, lr__v3 dir, double inner, double outer)
{
    lt->spot = 1;
    lt->direction = v3_norm(dir);
    double ci = cos(inner), co = cos(outer);
    /* The caller keeps inner < outer, so ci > co; a hair of room keeps a
     * hard-edged cone (inner = outer, refused upstream) finite anyway. */
    lt->cone_scale = 1.0 / fmax(ci - co, 1e-9);
    lt->cone_offset = -co * lt->cone_scale;
}
