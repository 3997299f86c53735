/*
 * shade.h: the Whitted-style integrator: radiance along a ray from direct
 * lighting with hard shadows, perfect mirrors and dielectrics.  Its parts
 * are exposed so that the packet tracer (trace16.c) can batch the shadow
 * rays of sixteen hits and still shade each exactly as lr__radiance does.
 */
#ifndef LR_SHADE_H
#define LR_SHADE_H

#include "scene.h"

#include <stdint.h>

/* Radiance arriving at `org` from direction -dir (dir unit length).
 * `depth` is the number of bounces already taken; mirror and refraction
 * rays are traced while depth < max_depth.  Adds every ray traced to
 * *rays. */
lr__v3 lr__radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                    int max_depth, uint64_t *rays);

/* One light as seen from a hit: the shadow ray to test and what arrives
 * if it is not blocked. */
typedef struct lr__light_ray {
    lr__v3 org, dir; /* shadow ray: offset origin, unit direction */
    double tfar;     /* to the light (infinite for directional lights) */
    lr__v3 f_E_cos;  /* BRDF x irradiance x cos(theta): the contribution */
} lr__light_ray;

/* The unshadowed contribution of light `i` at hit `h` seen from
 * direction wo; returns 0 when the light cannot contribute (behind the
 * surface, or the material reflects nothing), so no shadow ray is
 * needed. */
int lr__light_ray_setup(const lr_scene *s, const lr__hit *h, lr__v3 wo,
                        size_t i, lr__light_ray *out);

/* The ambient term: albedo x ambient radiance. */
lr__v3 lr__ambient(const lr_scene *s, const lr__hit *h);

/* Radiance from the mirror and refraction rays leaving hit `h` (reached
 * by a ray along `dir` after `depth` bounces); zero when the material has
 * neither or depth >= max_depth. */
lr__v3 lr__secondary(const lr_scene *s, const lr__hit *h, lr__v3 dir,
                     int depth, int max_depth, uint64_t *rays);

/* Fresnel reflectance of a smooth dielectric for unpolarised light, cos_i
 * the cosine of the incidence angle (>= 0) and eta = n_incident /
 * n_transmitted.  Returns 1 for total internal reflection.  (Exact
 * formula, e.g. pbrt-v4 section 9.3.) */
double lr__fresnel_dielectric(double cos_i, double eta);

#endif
