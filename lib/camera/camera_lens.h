/*
 * camera_lens.h: the real lens model's parts, shared by its three files
 * and lens_blur.c.  Owned by the lens model; nothing outside lib/camera/
 * includes it but its tests (other layers reach a model through camera.h's table).
 *
 *   camera_lens.c   keys, validation, setup, camera rays, the registration
 *   lens_pupil.c    the exit-pupil bounds (pbrt-v4's RealisticCamera)
 *   lens_light.c    the light side and the ghosts (camera.h: lens_point,
 *                   film, ghost_paths, ghost_film)
 *
 * Frames and radiometry: the top of camera_lens.c.
 */
#ifndef LR_CAMERA_LENS_H
#define LR_CAMERA_LENS_H

#include "camera/camera.h"
#include "optics/lens_load.h"

#include <math.h>

/* Fills c->lens's exit-pupil table for the colours the render traces (0
 * one, 1 rgb, 2 the visible range), from the lens's cache when it has it
 * (lens_pupil.c). */
void lr__lens_pupils(lr__cam *c, int colours);

/* Which of m (at most 16) rear-plane points (x[i], y[i]) the rays from
 * sensor point (r, 0) get through with any of the n_sets (at most 4)
 * index sets: ok[i]; cos4[i] gets cos^4 of each ray's angle to the axis
 * (lens_pupil.c). */
void lr__pupil_passes16(const lr__cam *c, const double *const *nsets,
                        int n_sets, double r, int m, const double *x,
                        const double *y, int *ok, double *cos4);

/* Where the exit-pupil search's grids (cells of `step` over [-S, S]^2 on
 * the rear plane) miss every ray from film radius r: a box about the
 * pupil, {x0, x1, y0, y1}, and a cell for the fine grid's margin, from the
 * ray through the stop's centre (lens_pupil_seed.c).  0 when that ray is
 * stopped too. */
int lr__pupil_seed(const lr__cam *c, const double *const *nsets, int n_sets,
                   double r, double S, double step, double box[4],
                   double *cell);

/* The step after the grid search (lens_pupil.c): bounds *P of film radius
 * r, found on a grid of cell `cell`, replaced by the pupil's edge traced
 * by bisection for each of the n_sets (at most 4) index sets, where the
 * edge's premises hold (lens_pupil.c says which).  The exhaustive search
 * of tests/test_camera_lens.c ends with it too. */
void lr__pupil_refine(const lr__cam *c, const double *const *nsets, int n_sets,
                      double r, double cell, lr__pupil *P);

/* The light side (lens_light.c): the model table's lens_point, film,
 * film_rgb, film_wl, thin_equiv, light_ok and lens_at. */
lr__v3 lr__lens_at(const lr__cam *c, double ox, double oy);
lr__v3 lr__lens_point(const lr__cam *c, const double u[2], double *ox,
                      double *oy);
double lr__lens_film(const lr__cam *c, double ox, double oy, lr__v3 w,
                     double *fx, double *fy);
double lr__lens_film_rgb(const lr__cam *c, int k, double ox, double oy,
                         lr__v3 w, double *fx, double *fy);
double lr__lens_film_wl(const lr__cam *c, double w, double nm, double ox,
                        double oy, lr__v3 d, double *fx, double *fy);
void lr__lens_thin_equiv(const lr__cam *c, lr__lens_bound *b);
int lr__lens_light_ok(const lr__cam *c);

/* The ghosts (lens_light.c): the model table's ghost_paths, ghost_film,
 * ghost_film_n and ghost_disk. */
int lr__lens_ghost_paths(const lr__cam *c, double *peak, double *k,
                         lr__ghost_est *est);
double lr__lens_ghost_film(const lr__cam *c, int g, int k, double ox, double oy,
                           lr__v3 w, double *rel, double *fx, double *fy);
void lr__lens_ghost_film_n(const lr__cam *c, int g, int k, int n,
                           const double *ox, const double *oy, const lr__v3 *w,
                           double *rel, double *fx, double *fy, double *W);
double lr__lens_ghost_disk(const lr__cam *c);
/* The entrance pupil's paraxial radius at the camera's f-number, in the
 * same millimetres (light_footprint.c: whether a finer search can find
 * a pupil the coarse grid stepped over). */
double lr__lens_pupil_radius(const lr__cam *c);

/* The chief ray out of the front by film radius (lens_chief.c), for the
 * packet rays of the blocks whose plan skips the lens: nodes every
 * 1/LR__CHIEF_SUB of the pupil table's intervals, interpolated linearly,
 * each interval checked when made (within LR__CHIEF_TOL_PX of a pixel
 * of an LR__CHIEF_FRAME_PX-pixel-wide frame of the traced ray: its
 * `exact`; test_lens_blur.c measures it).  Kept in the blur table
 * (lens_blur.c), made with it. */
#define LR__CHIEF_SUB 64
#define LR__CHIEF_NODES (LR__PUPIL_N * LR__CHIEF_SUB + 1)
#define LR__CHIEF_TOL_PX 1e-4
#define LR__CHIEF_FRAME_PX 8192.0
typedef struct lr__lens_chief {
    /* At each node, in the radial plane of the lens's frame: the point
     * (rho, z) and direction (u, w) on leaving the front, and the
     * transmittance, in double (for the check) and float (the camera's
     * packets). */
    double rho_d[LR__CHIEF_NODES], z_d[LR__CHIEF_NODES];
    double u_d[LR__CHIEF_NODES], w_d[LR__CHIEF_NODES], T_d[LR__CHIEF_NODES];
    float rho[LR__CHIEF_NODES], z[LR__CHIEF_NODES];
    float u[LR__CHIEF_NODES], w[LR__CHIEF_NODES], T[LR__CHIEF_NODES];
    /* Per interval [node i, node i + 1]: 1 when both nodes pass and the
     * interpolation is within the tolerance inside it; 0 sends the
     * packet through the glass. */
    unsigned char exact[LR__CHIEF_NODES];
    int n_exact; /* intervals exact */
} lr__lens_chief;

/* Fills the table; x_max (1/mm) the nearest inverse depth the plan uses
 * it at (the blur table's). */
void lr__lens_chief_fill(const lr__cam *c, double x_max, lr__lens_chief *t);
/* The table's ray at film radius r mm, interpolated in double from the
 * double nodes: 0 where r's interval is not exact. */
int lr__lens_chief_eval(const lr__cam *c, const lr__lens_chief *t, double r,
                        double o[3], double d[3], double *T);
/* The chief ray at film radius r traced through the glass in double,
 * which the table holds at its nodes (for the tests). */
int lr__lens_chief_traced(const lr__cam *c, double r, double o[3], double d[3],
                          double *T);
/* The integral of cos^4 T over where rays from film radius r pass, over
 * the pupil bounds P's sampling domain (the disk when use_disk) within
 * box (offsets from (cx, 0): a0, a1, b0, b1), on an LR__CHIEF_GW grid
 * (lens_blur.c's chief weight), traced with indices n and T from `tab`
 * (the table of those indices); -1 when out of memory. */
#define LR__CHIEF_GW 96
double lr__lens_chief_weight_sum(const lr__cam *c, const double *n,
                                 const lr__ttab *tab, double r,
                                 const lr__pupil *P, int use_disk,
                                 const double *box);
/* The mean of lens_start's weight (area cos^4 / Z^2 / E0, times T) over
 * that domain and box: the weight sum over Z^2 E0 (the area cancels);
 * -1 when out of memory. */
double lr__lens_pupil_mean(const lr__cam *c, const double *n,
                           const lr__ttab *tab, double r, const lr__pupil *P,
                           int use_disk, const double *box);

/* ---- the colours' shares of that mean (lens_shares.c) ---------------- */

/* Where one ray at the reference wavelength stands for every colour
 * (the plan's packet and chief rays), each output channel takes its
 * share of the light: its own mean weight over the reference's.  In rgb
 * mode a channel's mean is traced at its wavelength; in spectral mode
 * the mean is traced at LR__SHARE_NODES wavelengths 50 nm apart, taken
 * as cubic between them, and integrated against the channel's
 * normalised matching function (spectral.c's estimate: int w_c(l)
 * L_c(l) dl, with L_c(l) the reference ray's radiance times the weight
 * at l). */
#define LR__SHARE_NODES 9
typedef struct lr__lens_shares {
    int n; /* wavelengths traced */
    double idx[LR__SHARE_NODES][LR__RX_MAX_SURFACES];
    lr__ttab *tab; /* [n], owned when own_tab */
    int own_tab;
    double w[3][LR__SHARE_NODES]; /* channel c's weight of each mean */
} lr__lens_shares;

/* The shares' wavelengths for camera c: NULL without colours (or out of
 * memory: then no shares, and the caller's plan samples in full). */
lr__lens_shares *lr__lens_shares_new(const lr__cam *c);
void lr__lens_shares_free(lr__lens_shares *s);
/* Each channel's share at film radius r (share[3]) given the reference's
 * mean there (lr__lens_pupil_mean's arguments); 0 when out of memory. */
int lr__lens_shares_at(const lr__cam *c, const lr__lens_shares *s, double r,
                       const lr__pupil *P, int use_disk, const double *box,
                       double mean_ref, double share[3]);
/* The blur table's chief-ray table (lens_blur.c). */
const lr__lens_chief *lr__lens_blur_chief(const lr__lens_blur *b);

/* ---- small helpers of the three files, inline ----------------------------- */

/* From lens coordinates (mm, about the sensor's centre) to the scene. */
static inline void lr__lens_to_world(const lr__cam *c, const double o[3],
                                     const double d[3], lr__v3 *org,
                                     lr__v3 *dir)
{
    const lr__lens_cam *lc = &c->lens;
    double zo = o[2] - lc->z_sensor;
    lr__v3 p = v3_madd(v3_madd(v3_scale(c->right, o[0]), c->up, o[1]),
                       c->forward, -zo);
    *org = v3_madd(c->origin, p, lc->mm);
    *dir = v3_norm(v3_madd(v3_madd(v3_scale(c->right, d[0]), c->up, d[1]),
                           c->forward, -d[2]));
}

/* Whether the point (a, b), offset from the pupil bounds' centre (cx, 0),
 * is in the sampling domain: the disk of radius rad when use_disk, else
 * the bounds' box, which the callers' grids span (lens_blur.c's pupil
 * points and lens_chief.c's weight grid). */
static inline int lr__pupil_in_domain(const lr__pupil *P, int use_disk,
                                      double a, double b)
{
    return !use_disk || a * a + b * b <= P->rad * P->rad;
}

/* Film point (fx, fy) on the sensor, in mm (top of file), with its
 * distance from the axis and the unit vector of its radial direction. */
typedef struct lr__lens_sensor {
    double x, y, r, ex, ey;
} lr__lens_sensor;

static inline lr__lens_sensor lr__lens_sensor_at(const lr__cam *c, double fx,
                                                 double fy)
{
    const lr__lens_cam *lc = &c->lens;
    lr__lens_sensor p;
    p.x = (0.5 - fx / c->width) * lc->sensor_w;
    p.y = (fy / c->height - 0.5) * lc->sensor_h;
    p.r = hypot(p.x, p.y);
    p.ex = p.r > 0.0 ? p.x / p.r : 1.0;
    p.ey = p.r > 0.0 ? p.y / p.r : 0.0;
    return p;
}

/* The bounds at film radius r, between the table's two neighbouring
 * entries a and b: centred in proportion, as large as the larger of the
 * two plus the interval's growth (lens_pupil.c: what the centre's and the
 * sizes' curvature can add between the entries).  Sizes interpolated in
 * proportion fall short where an element starts to cut the pupil (it
 * shrinks fast there): a white scene came out 3.5% dark in rings. */
static inline lr__pupil lr__lens_pupil_at(const lr__lens_cam *lc, double r)
{
    if (r > lc->r_cut)
        return (lr__pupil){0.0, 0.0, 0.0, 0.0};
    double t = r / lc->pupil_rmax * LR__PUPIL_N;
    int k = (int)t;
    k = k < LR__PUPIL_N - 1 ? k : LR__PUPIL_N - 1;
    double f = t - k;
    const lr__pupil *a = &lc->pupil[k], *b = &lc->pupil[k + 1];
    const lr__pupil *g = &lc->pupil_grow[k];
    return (lr__pupil){a->cx + f * (b->cx - a->cx),
                       fmax(a->rad, b->rad) + g->rad,
                       fmax(a->hx, b->hx) + g->hx, fmax(a->hy, b->hy) + g->hy};
}

/* The transmittance table for the indices n (one of the camera's sets),
 * or NULL for indices at another wavelength (then R is computed at the
 * ray's own). */
static inline const lr__ttab *lr__lens_ttab_for(const lr__lens_cam *lc,
                                                const double *n)
{
    if (n == lc->n_ref)
        return &lc->t_ref;
    for (int k = 0; k < 3; k++)
        if (n == lc->n_rgb[k] && lc->t_rgb_ok)
            return &lc->t_rgb[k];
    return NULL;
}

/* The model's rays in double (lens_rays.c): `ray` (a sample through the
 * glass at nm, weighted), `rays_n` (up to sixteen samples, each at its
 * own wavelength, with ray's bits) and `chief` (through the middle of
 * the exit-pupil bounds, for depth and autofocus). */
double lr__lens_ray(const lr__cam *c, double fx, double fy, const double u[2],
                    double w, double nm, lr__v3 *org, lr__v3 *dir);
void lr__lens_rays_n(const lr__cam *c, int n, const double *fx,
                     const double *fy, const double (*u)[2], const double *w,
                     const double *nm, lr__v3 *org, lr__v3 *dir, double *wt);
void lr__lens_chief_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                        lr__v3 *dir);

#endif
