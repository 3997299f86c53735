/*
 * transmit.h: the light a real lens passes on its main path (issue 29):
 * at every surface a ray crosses it keeps 1 - R, R the surface's
 * reflectance under its coating at the ray's angle and wavelength
 * (coating.h), ghosts on or off.  Energy is conserved: what a surface
 * reflects is what ghost.c's paths carry.
 *
 * Looking R up per ray is a complex 2x2 matrix product per layer and
 * polarisation (some 0.3 us a surface); the camera instead keeps, per
 * wavelength it traces at fixed indices, a table per surface of T = 1 -
 * R against the ray's direction, filled once per camera from the exact
 * formula.  The table's variable is the sine invariant of the crossing,
 * s = n_before sin(theta_before) = n_after sin(theta_after) (Snell's
 * law), which is the same whichever way the light goes, and a lossless
 * stack transmits the same fraction both ways at a given s (Stokes'
 * relations; Macleod, Thin-Film Optical Filters, section 2.5): one table
 * serves the camera's rays and the light side's.  It is indexed by the
 * cosine on the lower-index side, c = sqrt(1 - (s / n_min)^2) in [0, 1],
 * through u = sqrt(c) in LR__T_N equal steps, linear interpolation.
 * T falls to 0 linearly in c at grazing incidence, over a range of c
 * as narrow as the index contrast (a cemented surface's); in u it
 * falls as u^2, smoothly, and the steps are finest where it does
 * (test_transmit.c bounds the table's error against the formula).
 */
#ifndef LR_TRANSMIT_H
#define LR_TRANSMIT_H

#include "optics/prescription.h"

#include <math.h>

#define LR__T_N 64

typedef struct lr__ttab {
    /* Per surface: 1 / n_min^2, 0 where both sides have one index (no
     * interface: T = 1). */
    float inv_nmin2[LR__RX_MAX_SURFACES];
    float t[LR__RX_MAX_SURFACES][LR__T_N + 1];
    /* t[i][j + 1] - t[i][j] in float, for the packet trace
     * (rx_trace16f.c): the same value its lookups computed. */
    float dt[LR__RX_MAX_SURFACES][LR__T_N];
} lr__ttab;

/* Fills `tab` for `rx` at wavelength nm, n_after as lr__rx_indices
 * fills it (the camera's, amplified or not), under each surface's own
 * coating or *override (NULL: the prescription's). */
void lr__ttab_fill(lr__ttab *tab, const lr__rx *rx, const double *n_after,
                   double nm, const lr__coating *override);

/* The table's T at surface i for a ray crossing it from a medium of
 * index n_in at cosine cos_in (to the normal, in that medium). */
static inline double lr__ttab_at(const lr__ttab *tab, int i, double n_in,
                                 double cos_in)
{
    float k = tab->inv_nmin2[i];
    if (k == 0.0f)
        return 1.0;
    float s2 = (float)(n_in * n_in * (1.0 - cos_in * cos_in));
    float c2 = 1.0f - s2 * k;
    float u = sqrtf(sqrtf(c2 > 0.0f ? c2 : 0.0f));
    float x = u * (float)LR__T_N;
    int j = (int)x;
    j = j < LR__T_N - 1 ? j : LR__T_N - 1;
    float f = x - (float)j;
    return tab->t[i][j] + f * (tab->t[i][j + 1] - tab->t[i][j]);
}

/* The reflectance R = 1 - T of surface i from the same table, for a
 * ghost's reflections (ghost.h), where R itself (some 1% coated) must
 * be right to a small fraction of itself, not of 1: Catmull-Rom cubic
 * interpolation in u, its last step's missing point extrapolated by the
 * quadratic through the three before it.  Against the formula
 * (test_transmit.c: three shipped lenses, bare, MgF2 and as prescribed,
 * 450, 550 and 650 nm, both ways, up to 85 degrees where R > 1e-4): at
 * most 3.0e-4 of R; linear interpolation is off by up to 6.3e-3 of R
 * (the double Gauss at 465 nm). */
static inline double lr__ttab_r(const lr__ttab *tab, int i, double n_in,
                                double cos_in)
{
    double k = tab->inv_nmin2[i];
    if (k == 0.0)
        return 0.0;
    double c2 = 1.0 - n_in * n_in * (1.0 - cos_in * cos_in) * k;
    double x = sqrt(sqrt(c2 > 0.0 ? c2 : 0.0)) * LR__T_N;
    int j = (int)x;
    j = j < LR__T_N - 1 ? j : LR__T_N - 1;
    double f = x - j;
    const float *t = tab->t[i];
    double p1 = t[j], p2 = t[j + 1];
    double p0 = j > 0 ? t[j - 1] : 2.0 * p1 - p2;
    double p3 = j + 2 <= LR__T_N ? t[j + 2] : 3.0 * (p2 - p1) + p0;
    double T = p1 + 0.5 * f *
                        (p2 - p0 +
                         f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 +
                              f * (3.0 * (p1 - p2) + p3 - p0)));
    return fmin(1.0, fmax(0.0, 1.0 - T));
}

/* The factor a crossing of surface i at |cosine| cos_in (in the medium
 * the light comes from) puts on a ray's transmittance: 1 where the index
 * does not change, else 1 - R from `tab` or, without one, from the
 * formula at nm under *override (lr__rx_trace_t's, and the packet
 * traces' that take the cosines from lr__rx_trace16_nl). */
double lr__rx_crossing_t(const lr__rx *rx, const double *n_after, int i,
                         int toward_image, const lr__ttab *tab, double nm,
                         const lr__coating *override, double cos_in);

/* lr__rx_trace_n that also returns the product of every crossing's
 * transmittance in *T: from `tab` when not NULL, else exactly at nm
 * under *override (NULL: the prescription's coatings), for
 * wavelengths no table holds (spectral mode). */
int lr__rx_trace_t(const lr__rx *rx, const double *z, const double *n_after,
                   double stop_scale, int toward_image, const lr__ttab *tab,
                   double nm, const lr__coating *override, double o[3],
                   double d[3], double *T);

/* The camera key's coatings (lr_lens_coating): NULL for the
 * prescription's own, else a coating for every glass-air surface
 * (static storage). */
const lr__coating *lr__coating_override(int lens_coating);

#endif
