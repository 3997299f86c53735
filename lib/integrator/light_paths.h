/*
 * light_paths.h: the `light` integrator (render.integrator "light"):
 * every path traced from the lights, each vertex joined to the lens, as
 * Mitsuba 3's `ptracer` does (Veach 1997, section 10.2: light tracing
 * with a camera connection).  Camera rays estimate nothing (every block
 * of the plan is dark), so it is the light side alone: with the camera
 * alone (render.light false) and the two combined (the defaults) it is a
 * third estimator of the same image, which is what it is for (tests
 * compare the three over the path tracer's scenes) beside renders whose
 * light is all caustics.
 *
 * What it cannot see: a path whose vertex next to the camera is a delta
 * lobe (a smooth mirror or glass seen directly, and what is seen in it),
 * since a connection needs the BSDF's value there; ambient light, which
 * no light emits; textured emission.  The last two are errors.  The
 * environment and directional lights send their light through a disk
 * across the scene's bounds, which cannot cover an infinite plane: with
 * such a light, an infinite plane is an error too.
 *
 * Depth: render.max_depth as the path integrator counts it: a path may
 * scatter at max_depth + 1 surfaces (0: direct light only).  Roulette
 * from the fifth surface, as path.c.
 *
 * Ownership: lr__lp_prepare's result belongs to the light side (lr__lt,
 * light_trace.h), which frees it with lr__lp_free.
 */
#ifndef LR_LIGHT_PATHS_H
#define LR_LIGHT_PATHS_H

#include "camera/camera.h"
#include "sampling/sampler.h"
#include "scene/scene.h"

typedef struct lr__lp lr__lp;

/* Light paths per pixel and sample (render.spp) of the frame. */
#define LR__LP_DENSITY 1.0

/* Prepares the light paths of scene s for camera c, or says why the
 * scene cannot be rendered from the lights alone (the field at fault in
 * the error).  *lref: a radiance the image's values are measured
 * against (its brightest light's), for the fixed-point film. */
lr_status lr__lp_prepare(const lr_scene *s, const lr__cam *c,
                         const lr_render_settings *set, lr__lp **out,
                         double *lref, lr_error *err);
void lr__lp_free(lr__lp *lp);
/* Spectral mode with colours that focus apart: the wavelengths' table
 * its paths land with (lr__cam_land), the caller's, kept while lp is
 * used; NULL (the default) otherwise. */
void lr__lp_set_wl(lr__lp *lp, const lr__wl_table *wl);

/* Where a path's vertex lands: adds rgb v times the importance where ld
 * lands it on the light side's film (light_trace.c), counting it in
 * *landed. */
typedef void (*lr__lp_splat_fn)(void *film, const lr__landing *ld, lr__v3 v,
                                uint64_t *landed);

/* Traces light path `idx` of the sampler's "pixel" `key`, one of
 * `n_paths` in all, and splats what its vertices send into the lens.
 * Counts rays in *rays and splats in *landed. */
void lr__lp_path(const lr__lp *lp, const lr_scene *s, const lr__cam *c,
                 const lr__sampler *smp, uint64_t key, uint32_t idx,
                 double n_paths, lr__lp_splat_fn splat, void *film,
                 uint64_t *rays, uint64_t *landed);

#endif
