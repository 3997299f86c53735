/*
 * bsdf.h: a material as the path integrator samples it: the sum of its
 * lobes (Lambertian diffuse, normalised Phong, mirror or rough conductor,
 * smooth or rough dielectric), evaluated, sampled and given a density, in
 * the frame of a hit's shading normal.  Whitted (whitted.c) shades the
 * same materials its own way.
 *
 * Rough lobes are GGX microfacets (Walter et al. 2007) with visible-normal
 * sampling (Heitz 2018), formulas as Mitsuba 3's roughconductor (material
 * "none": Fresnel factor 1 x reflect) and roughdielectric (radiance
 * mode, separable Smith shadowing), so that both renderers compute the
 * same thing.  Transmission scales radiance by 1 / eta^2 going in (and
 * eta^2 coming out), as radiance crossing an interface does (Veach 1997,
 * section 5.2), for smooth glass too.
 */
#ifndef LR_BSDF_H
#define LR_BSDF_H

#include "accel/trace.h"

#include <math.h>

typedef struct lr__bsdf {
    const lr__material *m;
    lr__v3 n, t, b; /* shading frame: n = hit's ns, facing wo */
    double eta;     /* n on the far side / n on wo's side */
    /* Lobe-pick probabilities: diffuse, Phong, mirror/conductor,
     * dielectric; summing to 1 (all 0 for a black material). */
    double p[4];
} lr__bsdf;

/* Prepares the BSDF of material m (the hit's, textures applied:
 * lr__hit_material) at hit h; f keeps m, which must outlive it. */
void lr__bsdf_init(lr__bsdf *f, const lr__material *m, const lr__hit *h);

/* Whether any lobe is not a delta (next-event estimation is worth it). */
int lr__bsdf_has_smooth_lobes(const lr__bsdf *f);

/* f(wo, wi) of the non-delta lobes and their mixture density for wi
 * (*pdf, solid angle); wo and wi unit, pointing away from the surface. */
lr__v3 lr__bsdf_eval(const lr__bsdf *f, lr__v3 wo, lr__v3 wi, double *pdf);

/* Samples wi for wo with u_lobe and u[2] in [0, 1): returns 0 if nothing
 * was sampled; else *wi, *weight = f cos / pdf (the throughput factor),
 * *pdf (the mixture density; 0 for a delta lobe) and *delta. */
int lr__bsdf_sample(const lr__bsdf *f, lr__v3 wo, double u_lobe,
                    const double u[2], lr__v3 *wi, lr__v3 *weight, double *pdf,
                    int *delta);

/* sin and cos of 2 pi u for u in [0, 1): the angle is brought to
 * [-pi/4, pi/4] around a multiple q of pi/2 and the Taylor series taken
 * to x^13 and x^14, whose next terms are below 2e-14 there (a quarter of
 * the time of libm's sincos, which was 5% of a Cornell box render).
 * Inline and without branches: path16.c's vector loop uses it too. */
static inline void lr__sincos_2pi(double u, double *sn, double *cs)
{
    int k = (int)(4.0 * u + 0.5);
    double x = 2.0 * M_PI * (u - 0.25 * k), x2 = x * x;
    double s = x *
               (1.0 +
                x2 * (-1.0 / 6 +
                      x2 * (1.0 / 120 +
                            x2 * (-1.0 / 5040 +
                                  x2 * (1.0 / 362880 +
                                        x2 * (-1.0 / 39916800 +
                                              x2 * (1.0 / 6227020800.0)))))));
    double c = 1.0 +
               x2 * (-0.5 +
                     x2 * (1.0 / 24 +
                           x2 * (-1.0 / 720 +
                                 x2 * (1.0 / 40320 +
                                       x2 * (-1.0 / 3628800 +
                                             x2 * (1.0 / 479001600.0 -
                                                   x2 / 87178291200.0))))));
    /* (sin, cos) of x + q pi / 2, chosen without branches (q is as
     * random as u). */
    *sn = (k & 2 ? -1.0 : 1.0) * (k & 1 ? c : s);
    *cs = ((k + 1) & 2 ? -1.0 : 1.0) * (k & 1 ? s : c);
}

/* ---- GGX, for tests ------------------------------------------------- */

/* D(m) for the normal's cosine cos_m and alpha. */
double lr__ggx_d(double cos_m, double alpha);
/* Smith G1 of direction v (cosine cos_v to the normal) with microfacet
 * normal m (v . m = vm). */
double lr__ggx_g1(double cos_v, double vm, double alpha);
/* A visible normal for local unit v (z up, v.z > 0), in the local frame
 * (Heitz 2018, "Sampling the GGX Distribution of Visible Normals"). */
lr__v3 lr__ggx_sample_vn(lr__v3 v, double alpha, const double u[2]);

#endif
