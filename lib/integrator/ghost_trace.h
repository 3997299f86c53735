/*
 * ghost_trace.h: a real lens's ghosts, traced from the light side (issue
 * 29).  Light that a bright sphere sends into the lens is reflected at
 * one glass surface j, back at an earlier surface i and reaches the
 * sensor: a ghost (ghost.h; Hullin et al., "Physically-based real-time
 * lens flare rendering", SIGGRAPH 2011).  The camera never traces these
 * paths, so the light side's estimate is the whole of their light and is
 * purely added: no split with the camera to keep consistent, and the
 * main image is the same with ghosts on or off.
 *
 * A ghost light (lr__lt_light with surf LR__LT_GHOST) is a sphere light
 * seen directly; each of its paths draws a lens point and a direction
 * into the sphere's cone as light_trace.c's sphere paths do, checks that
 * the camera ray along it meets the sphere first (the light must reach
 * the front of the lens), and lands that one ray through one ghost path
 * g of the lens (camera.h: ghost_film), drawn with probability p_g: half
 * by the paths' fluxes over the square root of their landing shares on
 * axis (ghost_trace.c: ghost_choice), half uniform (so that a path the
 * on-axis estimate misses, bright off axis, still has 1 / (2 n)).  The
 * pixel under the landing gets L x W_g / (pdf_dir x p_g x N), W_g the
 * ghost's importance: unbiased for the sum over every path.  Same
 * determinism as every light path: a pure function of (light, path
 * index, seed), fixed-point splats.
 */
#ifndef LR_GHOST_TRACE_H
#define LR_GHOST_TRACE_H

#include "light_trace.h"

/* camera.ghosts "auto": a sphere light gets ghosts when its brightest
 * ghost, spread evenly over its area on the film, would add at least
 * this much to a pixel: 1% of display white (1.0), 2.5 of 256 levels of
 * a linear 8-bit image, visible over a dark ground; fainter ghosts are
 * lost under the main image's noise at usual sample counts.  The
 * estimate (the camera's ghost_paths peak times the sphere's main-image
 * total L Omega k, k from ghost_paths) is on axis, at the reference
 * wavelength and the camera's stop. */
#define LR__GT_AUTO 0.01

/* The ghost lights' paths follow their ghosts' brightness, not the
 * frame's size (ghost_trace.c: ghost_choice, ghost_paths): enough that
 * the ghosts' rms error over the frame's pixels, estimated from the
 * camera's on-axis fluxes, is LR__GT_SIGMA / sqrt(render.spp) of
 * display white (1/512 at 64 spp), each light's share by its ghosts'
 * brightness; LR__GT_UNIFORM of a light's paths are drawn uniformly over
 * the ghost paths.  At least LR__GT_MIN paths a light; all the lights'
 * together at most LR__GT_CAP of the frame's pixels times render.spp
 * (then the ghosts are noisier than LR__GT_SIGMA, the price bounded). */
#define LR__GT_SIGMA (1.0 / 64.0)
#define LR__GT_UNIFORM 0.5
#define LR__GT_MIN 256
#define LR__GT_CAP (1.0 / 8.0)

/* Adds to *ltp (made when NULL) a ghost light for every untextured
 * sphere light camera c's ghosts call for (camera.ghosts), spp camera
 * samples a pixel.  Returns 0 when out of memory. */
int lr__gt_plan(const lr_scene *s, const lr__cam *c, int spp, lr__lt **ltp);

/* What --stats reports as ghost_flux: the ghosts' light splatted into f
 * (every channel) over their sources' main images on axis
 * (lt->ghost_main), as `lensray lens --ghosts`'s total_flux is the
 * ghosts' flux over the main image's.  0 without ghost lights. */
double lr__gt_flux(const lr__lt *lt, const lr__lt_film *f);

/* One path of ghost light l from lens point P (offset ox, oy), its
 * direction from ud, its ghost path from ug (l->cdf); splats
 * into f, counting rays traced and the ghost
 * rays that landed (up to the lens's ghost paths, times 3 in colour). */
void lr__gt_path(const lr_scene *s, const lr__cam *c, const lr__lt_light *l,
                 lr__v3 P, double ox, double oy, const double *ud, double ug,
                 lr__lt_film *f, uint64_t *rays, uint64_t *landed);

#endif
