/*
 * ghost_trace.c: a real lens's ghosts from the light side
 * (ghost_trace.h).
 */
#include "ghost_trace.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The solid angle a sphere fills from camera c's eye; -1 when the eye
 * is inside the sphere or the sphere lies behind it. */
static double solid_angle(const lr__cam *c, lr__v3 center, double radius)
{
    lr__v3 d = v3_sub(center, c->origin);
    double dist2 = v3_dot(d, d), r2 = radius * radius;
    if (!(dist2 > r2) || !(v3_dot(d, c->forward) > -radius))
        return -1.0;
    double sin2 = r2 / dist2;
    return 2.0 * M_PI * sin2 / (1.0 + sqrt(1.0 - sin2));
}

/* Light l's choice of ghost paths (l->cdf, cumulative) from the n
 * paths' estimates est, and its weight in the budget: M times the sum of
 * flux_g / sqrt(land_g), M its main image's total on axis (L's largest
 * channel L Omega k, camera_model.ghost_paths' k).
 *
 * Ghost g's light, M flux_g, lands in K_g = N p_g land_g splats of a
 * light's N paths, each M flux_g / K_g; over its px_g pixels their
 * counts are Poisson, so the squared error summed over its pixels is
 * (M flux_g)^2 / (N p_g land_g).  Summed over the ghosts that is least
 * with p_g proportional to flux_g / sqrt(land_g), and then (M sum_g
 * flux_g / sqrt(land_g))^2 / N: the weight squared over N.  Each path
 * is drawn with (1 - LR__GT_UNIFORM) of that share plus LR__GT_UNIFORM
 * / n, so that a ghost the on-axis estimate misses (off axis other
 * ghosts lead) still gets some.  -1: out of memory. */
static double ghost_choice(lr__lt_light *l, const lr__ghost_est *est, int n,
                           double M)
{
    if ((l->cdf = malloc((size_t)n * sizeof *l->cdf)) == NULL)
        return -1.0;
    double sum = 0.0;
    for (int g = 0; g < n; g++) {
        double w = est[g].land > 0.0 && est[g].flux > 0.0
                       ? est[g].flux / sqrt(est[g].land)
                       : 0.0;
        l->cdf[g] = w;
        sum += w;
    }
    double acc = 0.0;
    for (int g = 0; g < n; g++) {
        double p = sum > 0.0 ? (1.0 - LR__GT_UNIFORM) * l->cdf[g] / sum +
                                   LR__GT_UNIFORM / n
                             : 1.0 / n;
        acc += p;
        l->cdf[g] = acc;
    }
    l->cdf[n - 1] = 1.0;
    return M * sum;
}

/* The ghost lights' paths, lights first .. lt->n - 1 with budget weights
 * a[] (ghost_choice): the squared error over the frame's P pixels,
 * sum_l a_l^2 / ((1 - LR__GT_UNIFORM) N_l), is least for a total of
 * paths with N_l proportional to a_l, and reaches LR__GT_SIGMA^2 / spp
 * per pixel with N_l = a_l sum_k a_k / ((1 - LR__GT_UNIFORM) P
 * LR__GT_SIGMA^2 / spp); all of them at most LR__GT_CAP spp P (scaled
 * down alike), each at least LR__GT_MIN. */
static void ghost_paths(lr__lt *lt, int first, const double *a,
                        const lr__cam *c, int spp)
{
    double P = c->width * c->height, sum = 0.0;
    for (int k = first; k < lt->n; k++)
        sum += a[k - first];
    double per = sum * spp /
                 ((1.0 - LR__GT_UNIFORM) * P * LR__GT_SIGMA * LR__GT_SIGMA);
    double cap = LR__GT_CAP * spp * P;
    if (per * sum > cap)
        per = cap / sum;
    for (int k = first; k < lt->n; k++) {
        lr__lt_light *l = &lt->lights[k];
        double want = ceil(a[k - first] * per);
        l->paths = !(want > (double)LR__GT_MIN)       ? LR__GT_MIN
                   : want < (double)(LR__LT_PART - 1) ? (uint64_t)want
                                                      : LR__LT_PART - 1;
        l->first = lt->paths;
        lt->paths += l->paths;
    }
}

int lr__gt_plan(const lr_scene *s, const lr__cam *c, int spp, lr__lt **ltp)
{
    const lr__camera_model *m = c->model;
    if (m->ghost_paths == NULL || m->ghost_film == NULL)
        return 1;
    double peak = 0.0, k = 0.0;
    lr__ghost_est est[LR__RX_MAX_SURFACES * LR__RX_MAX_SURFACES / 2];
    int n_ghost = -1, first = -1;
    double *a = NULL;
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *geo = &s->geoms[g];
        const lr__material *mt = &s->materials[geo->material];
        if (geo->kind != LR__GEOM_SPHERE || mt->emission_tex != NULL ||
            !(v3_maxc(mt->emission) > 0.0))
            continue;
        /* The lens's ghosts, once, and only for a scene with a sphere
         * light (a scene without one pays nothing). */
        if (n_ghost < 0 && (n_ghost = m->ghost_paths(c, &peak, &k, est)) < 0)
            goto nomem;
        /* "true" (peak infinite): every light in front of the lens;
         * "auto": those whose brightest ghost reaches LR__GT_AUTO. */
        double omega = solid_angle(c, geo->center, geo->radius);
        double M = omega * k * v3_maxc(mt->emission);
        if (n_ghost == 0 || !(omega >= 0.0) ||
            !(isinf(peak) || peak * M >= LR__GT_AUTO))
            continue;
        lr__lt *lt = *ltp;
        if (lt == NULL && (*ltp = lt = lr__lt_new(s)) == NULL)
            goto nomem;
        if (a == NULL) {
            if ((a = malloc(s->n_geoms * sizeof *a)) == NULL)
                goto nomem;
            first = lt->n;
        }
        lr__lt_light *grown = realloc(lt->lights, (lt->n + 1) * sizeof *grown);
        if (grown == NULL)
            goto nomem;
        lt->lights = grown;
        lr__lt_light *l = &lt->lights[lt->n++];
        memset(l, 0, sizeof *l);
        l->geom = (int)g;
        l->surf = LR__LT_GHOST;
        l->center = geo->center;
        l->radius = geo->radius;
        l->L = mt->emission;
        l->ghosts = n_ghost;
        lt->ghost_lights++;
        lt->ghost_main += omega * k * (l->L.x + l->L.y + l->L.z);
        if (!((a[lt->n - 1 - first] = ghost_choice(l, est, n_ghost, M)) >= 0.0))
            goto nomem;
    }
    if (a != NULL)
        ghost_paths(*ltp, first, a, c, spp);
    free(a);
    return 1;
nomem:
    free(a);
    return 0;
}

void lr__gt_path(const lr_scene *s, const lr__cam *c, const lr__lt_light *l,
                 lr__v3 P, double ox, double oy, const double *ud, double ug,
                 lr__lt_film *f, uint64_t *rays, uint64_t *landed)
{
    /* The direction as light_trace.c's sphere_path draws it. */
    lr__v3 dv = v3_sub(l->center, P);
    double dist2 = v3_dot(dv, dv), r2 = l->radius * l->radius;
    if (!(dist2 > r2))
        return;
    double dist = sqrt(dist2);
    double sin2 = r2 / dist2, omc = sin2 / (1.0 + sqrt(1.0 - sin2));
    lr__v3 w = lr__lt_in_cone(v3_scale(dv, 1.0 / dist), omc, ud);
    /* The ghost path: the first g whose cumulative probability passes
     * ug (binary search). */
    int lo = 0, hi = l->ghosts - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (l->cdf[mid] > ug)
            hi = mid;
        else
            lo = mid + 1;
    }
    int g = lo;
    double p_g = l->cdf[g] - (g > 0 ? l->cdf[g - 1] : 0.0);
    if (!(p_g > 0.0))
        return;
    lr__v3 v = v3_scale(l->L, 2.0 * M_PI * omc / ((double)l->paths * p_g));
    /* chromatic.mode off: every channel at the reference wavelength (a
     * grey ghost, as the main image is traced); rgb and spectral: each
     * channel at its own wavelength, so that a coating's colour shows
     * (spectral mode: the rgb channels' wavelengths, not its spectra).
     * The lens first: most ghost rays are stopped in it or land outside
     * the frame, and those need no trace through the scene. */
    int k0 = c->chroma.mode == LR_CHROMATIC_OFF ? -1 : 0;
    int k1 = k0 < 0 ? 0 : 3, n = 0, px[3], py[3];
    lr__v3 e[3];
    for (int k = k0; k < k1; k++) {
        double fx, fy;
        double W = c->model->ghost_film(c, g, k, ox, oy, w, &fx, &fy);
        if (!(W > 0.0) ||
            !(fx >= 0.0 && fx < c->width && fy >= 0.0 && fy < c->height))
            continue;
        lr__v3 ek = v3_scale(v, W);
        if (k >= 0)
            ek = v3(k == 0 ? ek.x : 0.0, k == 1 ? ek.y : 0.0,
                    k == 2 ? ek.z : 0.0);
        if (!(isfinite(ek.x) && isfinite(ek.y) && isfinite(ek.z)))
            continue;
        px[n] = (int)fx, py[n] = (int)fy, e[n++] = ek;
    }
    if (n == 0)
        return;
    /* The sphere's light must reach the front of the lens: the camera
     * ray along w (the same trace as the camera's) meets it first. */
    (*rays)++;
    if (lr__trace_geom(s, lr__cam_ray_start(c, P, w), w, INFINITY) != l->geom)
        return;
    for (int k = 0; k < n; k++) {
        lr__lt_splat(f, px[k], py[k], e[k]);
        (*landed)++;
        /* The flux --stats reports, in the film's integer units (the
         * same for any threads or tiles).  A ghost's pixel stays under
         * its source's radiance times the two reflectances, so the sum
         * over a frame stays far inside the 2^23 times the brightest
         * light that an int64 holds at that scale. */
        if (px[k] >= f->x0 && px[k] < f->x1 && py[k] >= f->y0 &&
            py[k] < f->y1) {
            double q = (e[k].x + e[k].y + e[k].z) * f->scale;
            __atomic_fetch_add(&f->ghost_sum,
                               (int64_t)llrint(fmin(q, ldexp(1.0, 52))),
                               __ATOMIC_RELAXED);
        }
    }
}

double lr__gt_flux(const lr__lt *lt, const lr__lt_film *f)
{
    return lt->ghost_main > 0.0
               ? (double)f->ghost_sum / f->scale / lt->ghost_main
               : 0.0;
}
