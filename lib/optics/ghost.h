/*
 * ghost.h: light reflected twice inside a lens (issue 29's ghosts),
 * traced through the real surfaces.  The renderer lands them through
 * the lens camera's ghost_film (camera_lens.c, ghost_trace.c).
 *
 * A ghost path (j, i), i < j: light from the object refracts through
 * surfaces 0 .. j-1, reflects at surface j back toward the object,
 * refracts back through j-1 .. i+1, reflects at surface i toward the
 * image again and refracts through i+1 .. n-1 to the sensor.  N surfaces
 * give N(N-1)/2 paths (Hullin et al., "Physically-based real-time lens
 * flare rendering", SIGGRAPH 2011, section 3).  Light reflected four or
 * more times carries a product of four reflectances, some 1e-5 of it
 * with coated glass, and is left out here.
 *
 * Every crossing is clipped by the surface's semi-aperture (the stop's
 * scaled by stop_scale), whichever way the ray travels, and a ray that
 * would be totally internally reflected where it should refract is lost.
 * Its throughput is the product of the reflectance R at the two
 * reflections and the transmittance 1 - R at every other crossing, each
 * at the ray's own angle of incidence and wavelength, under the
 * surface's coating (coating.h).
 */
#ifndef LR_GHOST_H
#define LR_GHOST_H

#include "optics/prescription.h"
#include "optics/transmit.h"

/* A ghost path: reflect at surface j, then at surface i < j.  j < 0: the
 * main image (no reflection; the same weights: 1 - R at every surface). */
typedef struct lr__ghost {
    int j, i;
} lr__ghost;

#define LR__GHOST_MAX (LR__RX_MAX_SURFACES * (LR__RX_MAX_SURFACES - 1) / 2)

/* Every ghost path of `rx`, N(N-1)/2 of them, ordered by j then i:
 * fills out (room for LR__GHOST_MAX) and returns how many. */
int lr__ghost_paths(const lr__rx *rx, lr__ghost *out);

/* 1 when g is air: LR__GLASS_AIR, or a constant index of exactly 1 (a
 * pbrt file's, or {"nd": 1}). */
int lr__glass_is_air(const lr__glass *g);

/* 1 when surface i has air on one side and glass on the other (where a
 * coating goes). */
int lr__rx_glass_air(const lr__rx *rx, int i);

/* The reflectance of surface i for light crossing it toward the image
 * (toward_image = 1) or toward the object, at `cos_i` and `nm`;
 * n_after as lr__rx_indices fills it.  The coating is the surface's own,
 * or *override for every glass-air surface when override is not NULL
 * (the camera key issue 29 asks for). */
double lr__rx_surface_r(const lr__rx *rx, const double *n_after, int i,
                        int toward_image, double cos_i, double nm,
                        const lr__coating *override);

/* One crossing of a ghost path: surface i, the way the ray goes
 * (toward the image: fwd 1), and whether it reflects there. */
typedef struct lr__ghost_xing {
    int i, fwd, mirror;
} lr__ghost_xing;

/* Path g's crossings in the order a ray makes them (g.j < 0: the main
 * path) into x (room for 3 LR__RX_MAX_SURFACES); returns how many, or
 * -1 when g is not a path of rx.  The one order both traces follow
 * (ghost.c, ghost16.c). */
int lr__ghost_crossings(const lr__rx *rx, lr__ghost g, lr__ghost_xing *x);

/* Traces one ray through ghost path g at wavelength nm: o (before the
 * first surface) and d (unit, d[2] > 0) in lens coordinates.  Returns 1
 * when it reaches the plane z = sensor_z (lr__rx_layout's z[rx->n] for
 * the designer's infinity focus), with hit[0], hit[1] where it lands and
 * *weight its throughput; 0 when it is lost (missed or blocked surface,
 * total internal reflection, travelling away from the sensor). */
int lr__ghost_trace(const lr__rx *rx, const double *z, double nm,
                    double stop_scale, const lr__coating *override, lr__ghost g,
                    double sensor_z, const double o[3], const double d[3],
                    double hit[2], double *weight);

/* lr__ghost_trace with the indices at nm given (n_after, as
 * lr__rx_indices fills it) and R from `tab` (lr__ttab_r, filled at those
 * indices and nm under *override) when not NULL, else exactly at nm.
 * `clip` (not NULL): the ray counts only when it lands inside |x| <
 * clip[0], |y| < clip[1] (the frame, mm), and only such a ray's
 * reflectances are looked up.  A camera's ghost rays come here. */
int lr__ghost_trace_t(const lr__rx *rx, const double *z, const double *n_after,
                      const lr__ttab *tab, double nm, double stop_scale,
                      const lr__coating *override, lr__ghost g, double sensor_z,
                      const double *clip, const double o[3], const double d[3],
                      double hit[2], double *weight);

/* lr__ghost_trace_t with rel not NULL: the apertures do not stop the
 * ray (where the surfaces' formulas still hold), and *rel gets the
 * largest ratio of its height at a surface to that surface's
 * semi-aperture (the stop's scaled), <= 1 when it passes all of them: a
 * mesh of such rays finds a ghost's edge between its corners (Hullin et
 * al. 2011, section 4.2; ghost_grid.c).  rel NULL: lr__ghost_trace_t. */
int lr__ghost_trace_rel(const lr__rx *rx, const double *z,
                        const double *n_after, const lr__ttab *tab, double nm,
                        double stop_scale, const lr__coating *override,
                        lr__ghost g, double sensor_z, const double *clip,
                        const double o[3], const double d[3], double hit[2],
                        double *weight, double *rel);

/* lr__ghost_trace_rel for LR__GHOST_LANES rays at once (ghost16.c): lane
 * l's ray o[.][l], d[.][l] when alive[l] is 1, which stays 1 when it
 * lands, with hit[.][l], weight[l] and (rel not NULL) rel[l] as the
 * scalar trace sets them, bit for bit.  Lanes with alive[l] 0 are left
 * out.  Sixteen: the compiler's vectors, eight doubles, twice over. */
#define LR__GHOST_LANES 16
void lr__ghost_trace16(const lr__rx *rx, const double *z, const double *n_after,
                       const lr__ttab *tab, double nm, double stop_scale,
                       const lr__coating *override, lr__ghost g,
                       double sensor_z, const double *clip,
                       const double (*o)[LR__GHOST_LANES],
                       const double (*d)[LR__GHOST_LANES],
                       double (*hit)[LR__GHOST_LANES], double *weight,
                       double *rel, int *alive);

/* ---- a distant point's ghosts (ghost_flux.c) ----------------------------- */

/* One ghost of a distant point: its flux on the sensor over the main
 * image's, where it falls (the flux-weighted centroid, mm), how widely
 * (the rms distance from that centroid, mm), and the share of the
 * beam's rays that land (whatever their weight). */
typedef struct lr__ghost_flux {
    lr__ghost path;
    double flux, cx, cy, rms, landed;
} lr__ghost_flux;

/* A distant point at `field_deg` off axis (in the x-z plane) at `nm`,
 * its beam sampled by grid x grid parallel rays over the first
 * surface's semi-aperture (each ray the same area of the beam), every
 * ray traced through the main path and every ghost path to the plane
 * z[rx->n], counted where it lands within `radius` mm of the axis (<= 0:
 * anywhere).  Fills out (room for LR__GHOST_MAX) with every ghost path,
 * brightest first, sets *main to the main image's flux in units of the
 * beam's (the fraction of the rays' energy reaching the sensor) and
 * returns how many; 0 when no ray of the main image arrives. */
int lr__ghost_fluxes(const lr__rx *rx, const lr__coating *override,
                     double field_deg, double nm, int grid, double radius,
                     lr__ghost_flux *out, double *main);

/* The same with the indices at nm given, R from `tab` when not NULL
 * (lr__ghost_trace_t) and the stop scaled by stop_scale: a camera's
 * estimate, some 3e-4 of each R off the formula where the formula's
 * exact one costs some 0.3 us a crossing. */
int lr__ghost_fluxes_t(const lr__rx *rx, const double *n_after,
                       const lr__ttab *tab, double nm, double stop_scale,
                       const lr__coating *override, double field_deg, int grid,
                       double radius, lr__ghost_flux *out, double *main);

/* The main path's transmission integrated over the front of the lens for
 * a beam along the axis, mm^2 (its rays' 1 - R products times the area
 * each stands for), grid x grid rays over the first surface's
 * semi-aperture, at nm with the indices, R's source and the stop as
 * lr__ghost_fluxes_t takes them: what a distant point on the axis
 * sends to the sensor per unit of the beam's irradiance. */
double lr__ghost_main_area(const lr__rx *rx, const double *n_after,
                           const lr__ttab *tab, double nm, double stop_scale,
                           const lr__coating *override, int grid);

#endif
