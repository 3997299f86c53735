/*
 * shade.h: the Whitted-style integrator: radiance along a ray from direct
 * lighting with hard shadows, perfect mirrors and dielectrics.
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

/* Fresnel reflectance of a smooth dielectric for unpolarised light, cos_i
 * the cosine of the incidence angle (>= 0) and eta = n_incident /
 * n_transmitted.  Returns 1 for total internal reflection.  (Exact
 * formula, e.g. pbrt-v4 section 9.3.) */
double lr__fresnel_dielectric(double cos_i, double eta);

#endif
