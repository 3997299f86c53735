/*
 * envmap.h: the environment light: a latitude-longitude EXR image read
 * with OpenEXRCore, scaled by `intensity` and turned by `rotation_deg`
 * about +y, importance-sampled by luminance; or, without a map, the
 * uniform `background` radiance, sampled uniformly over the sphere.
 *
 * Directions map to the image as in Mitsuba 3's `envmap` emitter, so that
 * one file lights both renderers the same way: u = atan2(x, -z) / (2 pi)
 * (wrapped to [0, 1)), v = acos(y) / pi, +y up, looked up bilinearly
 * between texels placed as Mitsuba places them: column x at
 * u = (x + 1/2) / w, row y at v = y / (h - 1) (row 0 the +y pole, the
 * last row the -y pole).
 */
#ifndef LR_ENVMAP_H
#define LR_ENVMAP_H

#include "scene/light.h"

struct lr__envmap {
    int w, h;
    float *rgb;         /* w * h * 3, linear, finite, >= 0; owned */
    double *row_cdf;    /* h: rows' cumulative weights, last = 1 */
    double *col_cdf;    /* w * h: within each row, last = 1 */
    double *row_weight; /* h: each row's share of the total */
    double intensity;
    double rotation_deg;
    double cos_r, sin_r;
    char *file; /* as given in the scene; owned */
    /* Per row y and run of LR__ENV_RUN columns k, the largest channel of
     * the texels that a bilinear lookup inside the run's columns reads
     * (the run and one column each side), times intensity; and the map's
     * largest overall.  For lr__envmap_max_in_cone. */
    float *run_max; /* h * ceil(w / LR__ENV_RUN); owned */
    double max;
    /* The mean luminance over the sphere, intensity included (light.c's
     * pick among kinds of light). */
    double mean_lum;
    /* lr__envmap_sun's cone (sun_cos > 1: none). */
    lr__v3 sun_dir;
    double sun_cos;
};

#define LR__ENV_RUN 8

/* Reads `path` (the file named `file` in the scene, at JSON path
 * `blame`); LR_ERR_INVALID or LR_ERR_IO names the file and what is wrong
 * (not an EXR, no R, G, B channels, a pixel that is NaN, infinite or
 * negative, too large).  *out is the caller's, freed with
 * lr__envmap_free. */
lr_status lr__envmap_load(const char *path, const char *file, const char *blame,
                          double intensity, double rotation_deg,
                          lr__envmap **out, lr_error *err);
void lr__envmap_free(lr__envmap *e);

/* A direction towards the environment, sampled by luminance x the
 * latitude's solid angle (uniformly without a map), its radiance *L and
 * solid-angle density *pdf (0 when the sample is unusable). */
lr__v3 lr__envmap_sample(const lr_scene *s, const double u[2], lr__v3 *L,
                         double *pdf);
/* The density of lr__envmap_sample for direction dir. */
double lr__envmap_pdf(const lr_scene *s, lr__v3 dir);

/* envmap.c, for the planner's rare-light bound: a bound on the largest
 * channel of the radiance the map shows in any direction within angle
 * `alpha` (radians) of unit direction `axis`, never below a lookup there
 * (conservative: whole runs of texels, and whole rows near a pole); and
 * the map's largest value anywhere. */
double lr__envmap_max_in_cone(const lr__envmap *e, lr__v3 axis, double alpha);
double lr__envmap_max(const lr__envmap *e);
/* envmap.c, for the light side (light_trace.c): the map's sun, a cone
 * (unit axis *dir, cos of its half-angle *cos_a) holding every texel
 * within LR__ENV_SUN_MAX of the brightest whose luminance is at least
 * 1 / LR__ENV_SUN_RATIO of its, with a margin of the bilinear lookup's
 * spread; 0 when that cone would be wider than LR__ENV_SUN_MAX (no small
 * bright source to speak of).  Found when the map is loaded. */
int lr__envmap_sun(const lr__envmap *e, lr__v3 *dir, double *cos_a);
#define LR__ENV_SUN_MAX 0.25
#define LR__ENV_SUN_RATIO 64.0

#endif
