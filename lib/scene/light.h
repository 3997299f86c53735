/*
 * light.h: every light as the path integrator sees it (light.c,
 * envmap.c): sampling a direction towards a light from a point, the
 * solid-angle density of that sampling for a direction found by the BSDF
 * (for multiple importance sampling), and the radiance of the
 * environment.
 *
 * One light sample first picks a kind among those the scene has (area
 * lights, the environment, point and directional lights), then a light
 * of that kind: an area light in proportion to its power (area x
 * luminance of its emission), a point or directional light by what it
 * gives the point.  Both picks weigh each choice by an estimate of the
 * irradiance it brings to the shading point (light.c's kind_probs),
 * mixed with the uniform pick (a tenth), so that no light that reaches
 * the point is ever left out and a poor estimate costs at most a factor
 * in variance (defensive importance sampling, Hesterberg 1995).  A
 * constant-colour environment (no map) is not among the kinds when the
 * scene has other lights: the BSDF's rays find it (light.c's
 * env_sampled), and lr__light_pdf_env is 0 for it.
 */
#ifndef LR_LIGHT_H
#define LR_LIGHT_H

#include "scene/scene.h"

typedef struct lr__light_sample {
    lr__v3 dir;  /* unit, from the shading point towards the light */
    double dist; /* to the sampled point; INFINITY for the environment
                   * and directional lights */
    lr__v3 L;    /* radiance arriving (area, environment) or, for a delta
                   * light, irradiance on a surface facing it */
    double pdf;  /* solid-angle density with the pick's probability; for
                   * a delta light the pick's probability alone */
    int delta;   /* point or directional: no MIS, no BSDF counterpart */
    int geom;    /* the emitting geometry (area lights), else -1 */
} lr__light_sample;

/* Samples a light seen from point p, with u_pick and u[2] in [0, 1).
 * Returns 0 when the scene has no light to sample or the sample carries
 * nothing (then *out is unspecified). */
int lr__light_sample_from(const lr_scene *s, lr__v3 p, double u_pick,
                          const double u[2], lr__light_sample *out);

/* How far a shadow ray from org along unit dir towards sample ls, whose
 * point is t away, may go before it meets the light itself: t, or less
 * where the ray enters a sphere lamp before the sampled point (near its
 * silhouette, seen from org rather than from where it was sampled). */
double lr__light_reach(const lr_scene *s, const lr__light_sample *ls,
                       lr__v3 org, lr__v3 dir, double t);

/* Whether sample ls is of a sphere lamp. */
int lr__light_is_sphere(const lr_scene *s, const lr__light_sample *ls);

/* The density lr__light_sample_from would have for reaching point q of
 * emitting geometry g (triangle prim) from p, along unit dir (p -> q),
 * where q's geometric normal is ng_q. */
double lr__light_pdf_area(const lr_scene *s, lr__v3 p, lr__v3 q, lr__v3 ng_q,
                          unsigned g, unsigned prim);
/* The same for a ray from p escaping along unit dir (the environment). */
double lr__light_pdf_env(const lr_scene *s, lr__v3 p, lr__v3 dir);

/* Whether the environment is a light (a map, or a non-black background). */
int lr__env_is_light(const lr_scene *s);
/* Radiance of the environment along unit dir: the map, or background. */
lr__v3 lr__env_radiance(const lr_scene *s, lr__v3 dir);

/* ---- light.c --------------------------------------------------------- */

/* Fills s->emitters and s->emitter_cdf from the geometry whose material
 * emits, and sets each geometry's `emitter` index; called by
 * lr__integrators_prepare (integrator.h). */
lr_status lr__emitters_build(lr_scene *s, lr_error *err);

/* 1 if some geometry of s emits: what lr__emitters_build would list. */
int lr__scene_emits(const lr_scene *s);

/* Luminance of linear sRGB (Rec. 709 weights, ITU-R BT.709). */
static inline double lr__luminance(lr__v3 c)
{
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

#endif
