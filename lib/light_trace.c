/*
 * light_trace.c: light traced through the lens (light_trace.h).
 *
 * A light path of light k: a point on the aperture from lens sample
 * (u0, u1), uniform by area as the camera's rays take it; a direction
 * from there into the cone the sphere subtends, uniform by solid angle
 * from (u2, u3) (pbrt-v4's Sphere::Sample from a reference point); the
 * ray traced along it must meet the light first, on its emitting side.
 * Then the camera ray that leaves that lens point along that direction is
 * the one the film point (fx, fy) = film(lens point, direction) takes,
 * and the pixel under it gets
 *
 *     L x W / (pdf_dir x N_k)
 *
 * where W = fpx^2 / cos^3 theta is the camera's importance per unit solid
 * angle and lens measure (camera.c, lr__offset_lens_film), pdf_dir =
 * 1 / (2 pi (1 - cos alpha)) the cone's density and N_k the light's
 * paths: the pixel's value is the lens average of the radiance over the
 * pixel, an integral over lens points and directions of L x W, and the
 * aperture's density cancels the lens average's.
 */
#include "light_trace.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Sampler "pixels" of the light paths: past any frame's pixel index. */
#define LT_PIXEL_BASE ((uint64_t)1 << 48)

void lr__lt_keep(lr__lt *lt, const unsigned char *keep)
{
    int n = 0;
    lt->paths = 0;
    for (int k = 0; k < lt->n; k++) {
        if (!keep[k]) {
            free(lt->lights[k].cdf);
            continue;
        }
        lr__lt_light l = lt->lights[k];
        l.first = lt->paths;
        lt->paths += l.paths;
        lt->lights[n++] = l;
    }
    lt->n = n;
}

void lr__lt_free(lr__lt *lt)
{
    if (lt == NULL)
        return;
    for (int k = 0; k < lt->n; k++)
        free(lt->lights[k].cdf);
    free(lt->lights);
    free(lt->direct);
    free(lt);
}

/* The light-side candidate: a sphere emitting untextured radiance that
 * is small against its blur.  Its image on the film: radius rho (pixels)
 * sharp, blurred over a circle of diameter C (plan.c's bound), about
 * D = C + 2 rho + 1 pixels across (the last pixel for the pixel's own
 * footprint); a camera sample of a pixel there finds it with a chance of
 * about (2 rho / D)^2.  Returns the paths it gets (0: the camera keeps
 * it). */
static uint64_t paths_for(const lr__cam *c, const lr__lens_bound *lb,
                          int estimate, lr__v3 center, double r, int spp)
{
    lr__v3 d = v3_sub(center, c->origin);
    double z = v3_dot(d, c->forward);
    /* Near or behind the eye, the projection below means nothing. */
    if (!(z > 2.0 * r) || !(r > 0.0))
        return 0;
    double fpx = 0.5 * c->height / c->half_h;
    double rho = fpx * r / sqrt(z * z - r * r);
    double blur = 0.0;
    for (int k = 0; k < lb->n_w; k++)
        blur = fmax(blur, fmax(fabs(1.0 / (z - r) - lb->ws[k]),
                               fabs(1.0 / (z + r) - lb->ws[k])));
    double C = 2.0 * lb->R * fpx * blur;
    double D = C + 2.0 * rho + 1.0;
    if (!((2.0 * rho / D) * (2.0 * rho / D) < LR__LT_HIT_RATE))
        return 0;
    /* Wholly outside the frame: nothing of it lands.  Where the lens is
     * only estimated (a real lens: distortion, no bound), a light that
     * seems outside still goes to the light side, with few paths: left
     * to the camera, it would be a source of rare light everywhere
     * (plan.c's rare-light bound has no bound to confine it) and every
     * pixel would take every sample. */
    double sx = v3_dot(d, c->right) / z, sy = v3_dot(d, c->up) / z;
    double fx = (sx / c->half_w + 1.0) * 0.5 * c->width;
    double fy = (1.0 - sy / c->half_h) * 0.5 * c->height;
    if (fx + D < 0.0 || fx - D > c->width || fy + D < 0.0 ||
        fy - D > c->height)
        return estimate ? 256 : 0;
    double n = ceil((double)spp * 0.25 * M_PI * D * D * LR__LT_DENSITY);
    if (n < 16.0)
        n = 16.0;
    return n < 4294967295.0 ? (uint64_t)n : 4294967295u;
}

/* A sphere around an emitting mesh (its triangles' corners' box). */
static int mesh_sphere(const lr_scene *s, const lr__geom *g, lr__v3 *center,
                       double *radius)
{
    if (g->n_triangles == 0)
        return 0;
    lr__v3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY,
                                                         -INFINITY);
    for (size_t t = 0; t < g->n_triangles; t++) {
        const lr__emitter *e = &s->emitters[g->emitter + (long)t];
        lr__v3 p[3] = {e->a, v3_add(e->a, e->e1), v3_add(e->a, e->e2)};
        for (int k = 0; k < 3; k++) {
            lo = v3(fmin(lo.x, p[k].x), fmin(lo.y, p[k].y), fmin(lo.z, p[k].z));
            hi = v3(fmax(hi.x, p[k].x), fmax(hi.y, p[k].y), fmax(hi.z, p[k].z));
        }
    }
    *center = v3_scale(v3_add(lo, hi), 0.5);
    *radius = 0.5 * sqrt(v3_dot(v3_sub(hi, lo), v3_sub(hi, lo)));
    return *radius > 0.0;
}

/* The mesh light's triangles and their cumulative areas; 0 when out of
 * memory. */
static int mesh_cdf(const lr_scene *s, const lr__geom *g, lr__lt_light *l)
{
    l->first_tri = g->emitter;
    l->n_tri = g->n_triangles;
    l->cdf = malloc(l->n_tri * sizeof *l->cdf);
    if (l->cdf == NULL)
        return 0;
    double sum = 0.0;
    for (size_t t = 0; t < l->n_tri; t++) {
        sum += s->emitters[l->first_tri + (long)t].area;
        l->cdf[t] = sum;
    }
    for (size_t t = 0; t < l->n_tri; t++)
        l->cdf[t] /= sum;
    l->cdf[l->n_tri - 1] = 1.0;
    l->area = sum;
    return 1;
}

lr_status lr__lt_plan(const lr_scene *s, const lr__cam *c,
                      const lr_render_settings *set, lr__lt **out,
                      lr_error *err)
{
    *out = NULL;
    const lr__camera_model *m = c->model;
    if (!set->light || m->lens_point == NULL || m->film == NULL ||
        c->chroma_active || (m->bound == NULL && m->thin_equiv == NULL))
        return LR_OK;
    lr__lens_bound lb = {0.0, 1, {0.0, 0.0, 0.0}};
    if (m->bound == NULL)
        m->thin_equiv(c, &lb);
    else if (c->has_lens)
        lr__cam_bound(c, &lb);
    lr__lt *lt = NULL;
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *geo = &s->geoms[g];
        const lr__material *mt = &s->materials[geo->material];
        if (mt->emission_tex != NULL || !(v3_maxc(mt->emission) > 0.0))
            continue;
        lr__v3 center = geo->center;
        double radius = geo->radius;
        if (geo->kind != LR__GEOM_SPHERE &&
            (geo->kind != LR__GEOM_TRIANGLES || geo->emitter < 0 ||
             !mesh_sphere(s, geo, &center, &radius)))
            continue;
        uint64_t n = paths_for(c, &lb, m->bound == NULL, center, radius,
                               set->spp);
        if (n == 0)
            continue;
        if (lt == NULL) {
            lt = calloc(1, sizeof *lt);
            if (lt == NULL ||
                (lt->direct = calloc(s->n_geoms, 1)) == NULL ||
                (lt->lights = malloc(s->n_geoms * sizeof *lt->lights)) ==
                    NULL) {
                lr__lt_free(lt);
                return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
            }
        }
        lr__lt_light *l = &lt->lights[lt->n];
        memset(l, 0, sizeof *l);
        l->geom = (int)g;
        l->center = center;
        l->radius = radius;
        if (geo->kind == LR__GEOM_TRIANGLES &&
            !mesh_cdf(s, geo, l)) {
            lr__lt_free(lt);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
        lt->n++;
        l->L = mt->emission;
        l->paths = n;
        l->first = lt->paths;
        lt->paths += n;
        lt->direct[g] = 1;
    }
    if (lt != NULL)
        lt->seed = set->seed;
    *out = lt;
    return LR_OK;
}

lr_status lr__lt_film_init(lr__lt_film *f, const lr__lt *lt, int x0, int y0,
                           int x1, int y1, lr_error *err)
{
    f->x0 = x0, f->y0 = y0, f->x1 = x1, f->y1 = y1;
    size_t n = 3 * (size_t)(x1 - x0) * (size_t)(y1 - y0);
    f->sum = calloc(n, sizeof *f->sum);
    if (f->sum == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    /* A pixel's value is a mean of radiance, at most the brightest
     * light's in expectation; a scale of 2^40 over it leaves 2^23 of
     * headroom in an int64 and resolves 1e-12 of that light. */
    double Lmax = 0.0;
    for (int k = 0; k < lt->n; k++)
        Lmax = fmax(Lmax, v3_maxc(lt->lights[k].L));
    f->scale = ldexp(1.0, 40) / (Lmax > 0.0 ? Lmax : 1.0);
    return LR_OK;
}

void lr__lt_film_free(lr__lt_film *f)
{
    free(f->sum);
    f->sum = NULL;
}

uint64_t lr__lt_units(const lr__lt *lt)
{
    return (lt->paths + LR__LT_CHUNK - 1) / LR__LT_CHUNK;
}

/* The light whose paths hold global path index i. */
static int light_of(const lr__lt *lt, uint64_t i)
{
    int lo = 0, hi = lt->n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (lt->lights[mid].first <= i)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

/* Two unit vectors completing unit a to an orthonormal frame (Duff et
 * al. 2017, "Building an orthonormal basis, revisited"). */
static void frame_of(lr__v3 a, lr__v3 *t1, lr__v3 *t2)
{
    double sign = copysign(1.0, a.z);
    double p = -1.0 / (sign + a.z), q = a.x * a.y * p;
    *t1 = v3(1.0 + sign * a.x * a.x * p, sign * q, -sign * a.x);
    *t2 = v3(q, sign + a.y * a.y * p, -a.y);
}

/* Adds v to pixel (ix, iy) of f, if the region holds it. */
static void splat(lr__lt_film *f, int ix, int iy, lr__v3 v)
{
    if (ix < f->x0 || ix >= f->x1 || iy < f->y0 || iy >= f->y1)
        return;
    size_t k = 3 * ((size_t)(iy - f->y0) * (size_t)(f->x1 - f->x0) +
                    (size_t)(ix - f->x0));
    const double cap = ldexp(1.0, 52);
    double c[3] = {v.x, v.y, v.z};
    for (int j = 0; j < 3; j++) {
        double q = c[j] * f->scale;
        if (!(q > 0.0))
            continue;
        int64_t qi = (int64_t)llrint(q < cap ? q : cap);
        __atomic_fetch_add(&f->sum[k + (size_t)j], qi, __ATOMIC_RELAXED);
    }
}

/* A mesh light's path from lens point P: a triangle by area and a point
 * y on it, uniform by area over the mesh (pdf 1 / A), from (u0, u1) (u0
 * picks the triangle and, rescaled, is reused: the usual trick for one
 * more dimension); the direction w from P to y has solid-angle density
 * dist^2 / (A cos) (cos at y).  The emission is one-sided (the
 * triangle's front, counter-clockwise): seen from behind, nothing.  The
 * camera ray along w must meet this very triangle first, from the front
 * (a mesh can hide its own triangles). */
static void mesh_path(const lr__lt *lt, const lr_scene *s, const lr__cam *c,
                      const lr__lt_light *l, lr__v3 P, double ox, double oy,
                      const double *u, lr__lt_film *f, uint64_t *rays,
                      uint64_t *landed)
{
    (void)lt;
    size_t lo = 0, hi = l->n_tri - 1;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (u[0] < l->cdf[mid])
            hi = mid;
        else
            lo = mid + 1;
    }
    double c0 = lo > 0 ? l->cdf[lo - 1] : 0.0, c1 = l->cdf[lo];
    double v0 = c1 > c0 ? (u[0] - c0) / (c1 - c0) : 0.5;
    v0 = fmin(fmax(v0, 0.0), 1.0);
    const lr__emitter *e = &s->emitters[l->first_tri + (long)lo];
    /* Uniform on the triangle: b0 = 1 - sqrt(v0), b1 = u1 sqrt(v0)
     * (pbrt-v4's SampleUniformTriangle, the square-root form). */
    double sq = sqrt(v0);
    lr__v3 y = v3_add(e->a, v3_add(v3_scale(e->e1, sq * (1.0 - u[1])),
                                   v3_scale(e->e2, sq * u[1])));
    lr__v3 dv = v3_sub(y, P);
    double dist2 = v3_dot(dv, dv);
    if (!(dist2 > 0.0))
        return;
    double dist = sqrt(dist2);
    lr__v3 w = v3_scale(dv, 1.0 / dist);
    double cos_y = -v3_dot(w, e->n);
    if (!(cos_y > 0.0))
        return;
    double fx, fy;
    double W = c->model->film(c, ox, oy, w, &fx, &fy);
    if (!(W > 0.0) || !(fx >= 0.0 && fx < c->width && fy >= 0.0 &&
                        fy < c->height))
        return;
    lr__hit h;
    (*rays)++;
    if (!lr__trace(s, P, w, INFINITY, &h) || h.geom != l->geom ||
        h.prim != (unsigned)(e - &s->emitters[l->first_tri]) ||
        !h.entering)
        return;
    double pdf = dist2 / (l->area * cos_y);
    lr__v3 v = v3_scale(l->L, W / (pdf * (double)l->paths));
    if (!(isfinite(v.x) && isfinite(v.y) && isfinite(v.z)))
        return;
    (*landed)++;
    splat(f, (int)fx, (int)fy, v);
}

void lr__lt_unit(const lr__lt *lt, const lr_scene *s, const lr__cam *c,
                 uint64_t u, lr__lt_film *f, uint64_t *rays,
                 uint64_t *landed)
{
    lr__sampler smp;
    lr__sampler_init(&smp, LR_SAMPLER_SOBOL, lt->seed, 1);
    uint64_t i0 = u * LR__LT_CHUNK, i1 = i0 + LR__LT_CHUNK;
    if (i1 > lt->paths)
        i1 = lt->paths;
    int k = light_of(lt, i0);
    /* A light's paths are the samples of a "pixel" of its own (by its
     * geometry's index, so that a region that leaves some lights out
     * draws the same numbers for the others): the pixel dimensions give
     * the direction, the lens dimensions (the sequence's best pair, as
     * for camera rays) the lens point. */
    lr__pixel_sampler ps;
    lr__pixel_sampler_init(&ps, &smp,
                           LT_PIXEL_BASE + (uint64_t)lt->lights[k].geom);
    for (uint64_t i = i0; i < i1; i++) {
        if (i >= lt->lights[k].first + lt->lights[k].paths) {
            while (i >= lt->lights[k].first + lt->lights[k].paths)
                k++;
            lr__pixel_sampler_init(&ps, &smp,
                                   LT_PIXEL_BASE +
                                       (uint64_t)lt->lights[k].geom);
        }
        const lr__lt_light *l = &lt->lights[k];
        uint32_t idx = (uint32_t)(i - l->first);
        double q[4], ox, oy;
        lr__pixel_sampler_get(&ps, idx, q);
        const double *ud = q, *ul = q + 2;
        lr__v3 P = c->model->lens_point(c, ul, &ox, &oy);
        if (l->n_tri > 0) {
            mesh_path(lt, s, c, l, P, ox, oy, ud, f, rays, landed);
            continue;
        }
        lr__v3 dv = v3_sub(l->center, P);
        double dist2 = v3_dot(dv, dv), r2 = l->radius * l->radius;
        if (!(dist2 > r2))
            continue;
        double dist = sqrt(dist2);
        lr__v3 a = v3_scale(dv, 1.0 / dist);
        /* 1 - cos alpha = sin^2 / (1 + cos), without cancellation for
         * the tiny cones of far lights. */
        double sin2 = r2 / dist2, cos_a = sqrt(1.0 - sin2);
        double omc = sin2 / (1.0 + cos_a);
        double t = ud[0] * omc; /* 1 - cos theta */
        double cos_t = 1.0 - t, sin_t = sqrt(t * (2.0 - t));
        double phi = 2.0 * M_PI * ud[1];
        lr__v3 t1, t2;
        frame_of(a, &t1, &t2);
        lr__v3 w = v3_add(v3_scale(a, cos_t),
                          v3_add(v3_scale(t1, sin_t * cos(phi)),
                                 v3_scale(t2, sin_t * sin(phi))));
        w = v3_norm(w);
        double fx, fy;
        double W = c->model->film(c, ox, oy, w, &fx, &fy);
        if (!(W > 0.0) || !(fx >= 0.0 && fx < c->width && fy >= 0.0 &&
                            fy < c->height))
            continue;
        /* The camera ray along w must meet this light first (from
         * outside a sphere, on its emitting side): exactly the rays whose
         * emission the camera side leaves out (light_trace.h).  The same
         * trace as the camera's keeps the two sides a partition: a shadow
         * ray up to the analytic hit, cheaper still, lost 1e-4 of the
         * light (near the cone's rim the traced sphere's own hit came
         * before its margin). */
        (*rays)++;
        if (lr__trace_geom(s, P, w, INFINITY) != l->geom)
            continue;
        double pdf = 1.0 / (2.0 * M_PI * omc);
        lr__v3 v = v3_scale(l->L, W / (pdf * (double)l->paths));
        if (!(isfinite(v.x) && isfinite(v.y) && isfinite(v.z)))
            continue;
        (*landed)++;
        splat(f, (int)fx, (int)fy, v);
    }
}

void lr__lt_film_resolve(const lr__lt_film *f, float *rgb)
{
    size_t n = 3 * (size_t)(f->x1 - f->x0) * (size_t)(f->y1 - f->y0);
    for (size_t k = 0; k < n; k++)
        if (f->sum[k] != 0)
            rgb[k] = (float)((double)rgb[k] + (double)f->sum[k] / f->scale);
}
