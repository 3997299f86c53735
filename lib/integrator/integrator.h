/*
 * integrator.h: the integrator interface.  An integrator computes the
 * radiance arriving along camera rays, one ray at a time or a packet of
 * sixteen; it decides itself which lanes of a packet its vector code can
 * take and which go one by one.  The render loop (sample.c) knows only
 * this table.
 *
 * Implementations: whitted.c and whitted16.c (direct light with hard
 * shadows, mirrors and glass: the classic ray tracer) and path.c and
 * path16.c (path tracing), listed in integrator.c's registry and chosen
 * by render.integrator through lr__integrator_for.
 */
#ifndef LR_INTEGRATOR_H
#define LR_INTEGRATOR_H

#include "sampling/sampler.h"
#include "accel/trace.h"

#include <stdint.h>

/* What the light side estimates of what camera rays see first
 * (light_trace.h), so that camera rays add none of it: per scene geometry
 * the LR__LT_* flags below, and the environment's sun, a cone of
 * directions: a camera ray that escapes within it (dot(dir, sun_dir) >=
 * sun_cos; sun_cos > 1: no sun) adds none of the environment's radiance
 * (its other light, and every later bounce's, as ever). */
typedef struct lr__lt_view {
    const unsigned char *geom;
    lr__v3 sun_dir;
    double sun_cos;
    /* Multiple importance sampling of what a light of the light side
     * sends straight into the lens (light_trace.h): per geometry (NULL:
     * none) and for the sun, kappa >= 0 with the strategies' density
     * ratio rho = kappa cos^3 of the camera ray's angle to `forward`
     * (lr__lt_rho); 0: the light side takes it all. */
    const double *mis;
    double sun_mis;
    lr__v3 forward;
} lr__lt_view;

/* Which camera sample a ray belongs to: an integrator that makes random
 * decisions draws them from `sampler` for (pixel, sample, its own
 * dimensions >= LR__DIM_COUNT), so they stay a pure function of the
 * sample.  In a packet, lane i is sample `sample + i`. */
typedef struct lr__sample_id {
    const lr__sampler *sampler;
    uint64_t pixel;
    uint32_t sample;
    /* The light side's part of the camera ray's first hit or escape;
     * NULL: none. */
    const lr__lt_view *lt;
} lr__sample_id;

/* lr__lt_view.geom's flags (light_trace.h's lr__lt.direct). */
#define LR__LT_DIRECT 1
#define LR__LT_GLINT_SURF 2
#define LR__LT_GLINT_LIGHT 4

/* Whether geometry `geom` has flag `flag` in lt: LR__LT_DIRECT, whether
 * the emission of the camera ray's first hit on it is the light side's;
 * LR__LT_GLINT_SURF and LR__LT_GLINT_LIGHT, whether light from the
 * second straight off the first (the camera ray's first hit) is. */
static inline int lr__lt_flag(const lr__lt_view *lt, long geom, int flag)
{
    return lt != NULL && geom >= 0 && (lt->geom[geom] & flag);
}

static inline int lr__lt_direct(const lr__lt_view *lt, long geom)
{
    return lr__lt_flag(lt, geom, LR__LT_DIRECT);
}

/* Veach's cutoff heuristic (1997, section 9.2.3, alpha = 1 / this): where
 * the light side's density is this many times the camera's, the camera
 * takes none of the light, so a light far from the cutoff everywhere
 * renders exactly as under a plain split. */
#define LR__LT_MIS_CUT 10.0

/* The two strategies' density ratio for a light of coefficient kappa
 * met along dir (any length): the light side's paths times their
 * direction's density over spp times the camera's, fpx^2 / cos^3
 * (lr__offset_lens_film).  0 where there is no such mix. */
static inline double lr__lt_rho(double kappa, lr__v3 forward, lr__v3 dir)
{
    if (!(kappa > 0.0))
        return 0.0;
    double cz = v3_dot(dir, forward) / v3_len(dir);
    return cz > 0.0 ? kappa * cz * cz * cz : 0.0;
}

/* The balance heuristic's weights of the two, cut off as above: the
 * camera's 1 / (1 + rho), the light side's rho / (1 + rho); with rho 0
 * (no mix) or past the cutoff, all the light side's. */
static inline double lr__lt_cam_weight(double rho)
{
    return rho > 0.0 && rho < LR__LT_MIS_CUT ? 1.0 / (1.0 + rho) : 0.0;
}

static inline double lr__lt_light_weight(double rho)
{
    return rho > 0.0 && rho < LR__LT_MIS_CUT ? rho / (1.0 + rho) : 1.0;
}

/* How much of the emission of geometry geom, met first by a camera ray
 * along dir, the camera adds: 1 for a light the light side does not
 * carry, else its weight. */
static inline double lr__lt_direct_w(const lr__lt_view *lt, long geom,
                                     lr__v3 dir)
{
    if (!lr__lt_direct(lt, geom))
        return 1.0;
    return lt->mis != NULL
               ? lr__lt_cam_weight(lr__lt_rho(lt->mis[geom], lt->forward, dir))
               : 0.0;
}

/* L times a camera weight w: exactly L where w is 1, and 0 where it is
 * 0 (so that lights without a mix render as they did). */
static inline lr__v3 lr__lt_weigh(lr__v3 L, double w)
{
    return w == 1.0 ? L : w == 0.0 ? v3(0, 0, 0) : v3_scale(L, w);
}

/* Whether the environment's radiance along unit dir, seen by a camera ray
 * escaping, is the light side's (its sun). */
static inline int lr__lt_sun(const lr__lt_view *lt, lr__v3 dir)
{
    return lt != NULL && v3_dot(dir, lt->sun_dir) >= lt->sun_cos;
}

/* How much of the environment's radiance along unit dir a camera ray
 * escaping adds: 1 outside the sun's cone, else its weight. */
static inline double lr__lt_sun_w(const lr__lt_view *lt, lr__v3 dir)
{
    if (!lr__lt_sun(lt, dir))
        return 1.0;
    return lr__lt_cam_weight(lr__lt_rho(lt->sun_mis, lt->forward, dir));
}

/* A glint's core: light from a glint light reflected at a glint surface
 * is the light side's only where the half vector of wo and wi (unit,
 * away from the surface) leans from the surface's normal n (on wo's
 * side) by a slope under LR__LT_GLINT_CORE alpha, which holds 80% of
 * GGX's normals (P(|slope| < k alpha) = k^2 / (1 + k^2)).  On a test
 * scene 2 reached a given error sooner than 1.5, 3 or 6.  The wide
 * tails, a dim haze over the whole surface that the camera's light
 * samples find in every pixel, stay the camera's.  Both sides ask this
 * one function of the same path, so the split is exact. */
#define LR__LT_GLINT_CORE 2.0
static inline int lr__lt_glint_core(lr__v3 wo, lr__v3 wi, lr__v3 n,
                                    double alpha)
{
    lr__v3 h = v3_add(wo, wi);
    double hn = v3_dot(h, n), k = LR__LT_GLINT_CORE * alpha;
    return hn > 0.0 && v3_dot(h, h) - hn * hn < k * k * hn * hn;
}

typedef struct lr__integrator {
    const char *name;
    /* 1: camera rays estimate nothing (the light side traces every path,
     * light_paths.h), so the plan makes every block dark. */
    int camera_dark;
    /* Radiance arriving at `org` from direction -dir (unit length) along
     * a camera ray; rays traced are added to *rays. */
    lr__v3 (*radiance)(const lr_scene *s, int max_depth, lr__v3 org, lr__v3 dir,
                       const lr__sample_id *id, uint64_t *rays);
    /* The same for lanes 0..n-1 (n >= 1) of a packet of camera rays that
     * the camera filled (not yet traced): L[i] for lane i, each exactly
     * what `radiance` gives for lane i's ray (as traced, in float). */
    void (*radiance16)(const lr_scene *s, int max_depth, struct RTCRayHit16 *rh,
                       int n, const lr__sample_id *id, lr__v3 L[16],
                       uint64_t *rays);
    /* Optional (NULL: radiance16 for each packet): radiance16 for
     * `count` packets at once, packet p with n[p] lanes, identity id[p]
     * and results L[p] per channel (L[p][c][i]: channel c of lane i),
     * each exactly what radiance16 gives it alone.
     * It lets an integrator trace every packet's camera rays before it
     * reads any of their hits: Embree writes a packet's hits with masked
     * stores, which a load right after must wait for. */
    void (*radiance16_n)(const lr_scene *s, int max_depth,
                         struct RTCRayHit16 *rh, const int *n, int count,
                         const lr__sample_id *id, double (*L)[3][16],
                         uint64_t *rays);
    /* Optional (NULL: nothing): builds what this integrator needs of a
     * committed scene beyond the scene's own data, once, when the scene
     * is loaded; renders share it read-only afterwards. */
    lr_status (*prepare)(lr_scene *s, lr_error *err);
} lr__integrator;

extern const lr__integrator lr__whitted;
extern const lr__integrator lr__path_tracer;
extern const lr__integrator lr__light_tracer;

/* ---- the registry (integrator.c) ---------------------------------------- */

/* The integrators, indexed by lr_integrator_kind, ending with NULL.  Each
 * row's `name` is its value of render.integrator. */
#define LR__MAX_INTEGRATORS 15
extern const lr__integrator *const lr__integrators[];

/* Readies a committed scene (lr__scene_commit) for rendering: the
 * emitters every integrator samples (lr__emitters_build), then each
 * registered integrator's prepare.  The public loaders (load.c) call it
 * once, before any render. */
lr_status lr__integrators_prepare(lr_scene *s, lr_error *err);
/* The integrator for render.integrator's value; NULL when `kind` is not
 * one (lr_render_settings_validate rejects it). */
const lr__integrator *lr__integrator_for(lr_integrator_kind kind);

/* The names in registry order, ending with NULL: for lr__json_enum. */
void lr__integrator_names(const char *names[LR__MAX_INTEGRATORS + 1]);

/* ---- the Whitted integrator's parts, for tests ----------------------- */

/* Radiance arriving at `org` from direction -dir (dir unit length) after
 * `depth` bounces; mirror and refraction rays are traced while depth <
 * max_depth.  Adds every ray traced to *rays. */
lr__v3 lr__radiance(const lr_scene *s, lr__v3 org, lr__v3 dir, int depth,
                    int max_depth, uint64_t *rays);

/* Fresnel reflectance of a smooth dielectric for unpolarised light, cos_i
 * the cosine of the incidence angle (>= 0) and eta = n_incident /
 * n_transmitted.  Returns 1 for total internal reflection.  (Exact
 * formula, e.g. pbrt-v4 section 9.3.) */
double lr__fresnel_dielectric(double cos_i, double eta);

/* For tests: when nonzero, radiance16 shades every lane with the scalar
 * code instead of its vector path, whose results must match it bit for
 * bit.  Not thread-safe to change during a render. */
extern int lr__whitted_scalar_only;

#endif
