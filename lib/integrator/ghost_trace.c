/*
 * ghost_trace.c: a real lens's ghosts from the light side
 * (ghost_trace.h).
 */
#include "ghost_trace.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Whether sphere geometry g's ghosts are called for: "true" (peak
 * infinite) every one in front of the lens; "auto" those whose main
 * image's total, L Omega / Omega_pix (Omega the solid angle the sphere
 * fills from the eye, Omega_pix a central pixel's), times the peak
 * reaches LR__GT_AUTO. */
static int wants_ghosts(const lr__cam *c, const lr__geom *g, lr__v3 L,
                        double peak)
{
    lr__v3 d = v3_sub(g->center, c->origin);
    double dist2 = v3_dot(d, d), r2 = g->radius * g->radius;
    if (!(dist2 > r2) || !(v3_dot(d, c->forward) > -g->radius))
        return 0;
    if (isinf(peak))
        return 1;
    double sin2 = r2 / dist2;
    double omega = 2.0 * M_PI * sin2 / (1.0 + sqrt(1.0 - sin2));
    double omega_pix = (2.0 * c->half_w / c->width) *
                       (2.0 * c->half_h / c->height);
    return peak * v3_maxc(L) * omega / omega_pix >= LR__GT_AUTO;
}

/* lt's ghost_cdf for n paths of fluxes flux: p_g = (flux_g / sum + 1 /
 * n) / 2 (uniform alone when no flux was estimated).  0: out of
 * memory. */
static int ghost_cdf(lr__lt *lt, const double *flux, int n)
{
    if (lt->ghost_cdf != NULL)
        return 1;
    if ((lt->ghost_cdf = malloc((size_t)n * sizeof *lt->ghost_cdf)) == NULL)
        return 0;
    double sum = 0.0, acc = 0.0;
    for (int g = 0; g < n; g++)
        sum += flux[g];
    for (int g = 0; g < n; g++) {
        double p = sum > 0.0 ? 0.5 * (flux[g] / sum + 1.0 / n) : 1.0 / n;
        acc += p;
        lt->ghost_cdf[g] = acc;
    }
    lt->ghost_cdf[n - 1] = 1.0;
    return 1;
}

int lr__gt_plan(const lr_scene *s, const lr__cam *c, int spp, lr__lt **ltp)
{
    const lr__camera_model *m = c->model;
    if (m->ghost_paths == NULL || m->ghost_film == NULL)
        return 1;
    double peak = 0.0, flux[LR__RX_MAX_SURFACES * LR__RX_MAX_SURFACES / 2];
    int n_ghost = -1;
    double want = ceil((double)spp * c->width * c->height * LR__GT_DENSITY);
    uint64_t n = want < (double)LR__GT_MIN    ? LR__GT_MIN
                 : want < (double)LR__LT_PART ? (uint64_t)want
                                              : LR__LT_PART - 1;
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *geo = &s->geoms[g];
        const lr__material *mt = &s->materials[geo->material];
        if (geo->kind != LR__GEOM_SPHERE || mt->emission_tex != NULL ||
            !(v3_maxc(mt->emission) > 0.0))
            continue;
        /* The lens's ghosts, once, and only for a scene with a sphere
         * light (a scene without one pays nothing). */
        if (n_ghost < 0)
            n_ghost = m->ghost_paths(c, &peak, flux);
        if (n_ghost == 0 || !wants_ghosts(c, geo, mt->emission, peak))
            continue;
        lr__lt *lt = *ltp;
        if ((lt == NULL && (*ltp = lt = lr__lt_new(s)) == NULL) ||
            !ghost_cdf(lt, flux, n_ghost))
            return 0;
        lr__lt_light *grown = realloc(lt->lights, (lt->n + 1) * sizeof *grown);
        if (grown == NULL)
            return 0;
        lt->lights = grown;
        lr__lt_light *l = &lt->lights[lt->n++];
        memset(l, 0, sizeof *l);
        l->geom = (int)g;
        l->surf = LR__LT_GHOST;
        l->center = geo->center;
        l->radius = geo->radius;
        l->L = mt->emission;
        l->ghosts = n_ghost;
        l->paths = n;
        l->first = lt->paths;
        lt->paths += n;
        lt->ghost_lights++;
    }
    return 1;
}

void lr__gt_path(const lr__lt *lt, const lr_scene *s, const lr__cam *c,
                 const lr__lt_light *l, lr__v3 P, double ox, double oy,
                 const double *ud, double ug, lr__lt_film *f, uint64_t *rays,
                 uint64_t *landed)
{
    /* The direction as light_trace.c's sphere_path draws it. */
    lr__v3 dv = v3_sub(l->center, P);
    double dist2 = v3_dot(dv, dv), r2 = l->radius * l->radius;
    if (!(dist2 > r2))
        return;
    double dist = sqrt(dist2);
    double sin2 = r2 / dist2, omc = sin2 / (1.0 + sqrt(1.0 - sin2));
    lr__v3 w = lr__lt_in_cone(v3_scale(dv, 1.0 / dist), omc, ud);
    /* The sphere's light must reach the front of the lens: the camera
     * ray along w (the same trace as the camera's) meets it first. */
    (*rays)++;
    if (lr__trace_geom(s, lr__cam_ray_start(c, P, w), w, INFINITY) != l->geom)
        return;
    /* The ghost path: the first g whose cumulative probability passes
     * ug (binary search). */
    int lo = 0, hi = l->ghosts - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (lt->ghost_cdf[mid] > ug)
            hi = mid;
        else
            lo = mid + 1;
    }
    int g = lo;
    double p_g = lt->ghost_cdf[g] - (g > 0 ? lt->ghost_cdf[g - 1] : 0.0);
    if (!(p_g > 0.0))
        return;
    lr__v3 v = v3_scale(l->L, 2.0 * M_PI * omc / ((double)l->paths * p_g));
    /* chromatic.mode off: every channel at the reference wavelength (a
     * grey ghost, as the main image is traced); rgb and spectral: each
     * channel at its own wavelength, so that a coating's colour shows
     * (spectral mode: the rgb channels' wavelengths, not its spectra). */
    int k0 = c->chroma.mode == LR_CHROMATIC_OFF ? -1 : 0;
    int k1 = k0 < 0 ? 0 : 3;
    for (int k = k0; k < k1; k++) {
        double fx, fy;
        double W = c->model->ghost_film(c, g, k, ox, oy, w, &fx, &fy);
        if (!(W > 0.0) ||
            !(fx >= 0.0 && fx < c->width && fy >= 0.0 && fy < c->height))
            continue;
        lr__v3 e = v3_scale(v, W);
        if (k >= 0)
            e = v3(k == 0 ? e.x : 0.0, k == 1 ? e.y : 0.0, k == 2 ? e.z : 0.0);
        if (!(isfinite(e.x) && isfinite(e.y) && isfinite(e.z)))
            continue;
        lr__lt_splat(f, (int)fx, (int)fy, e);
        (*landed)++;
    }
}
