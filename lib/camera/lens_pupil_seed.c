/*
 * lens_pupil_seed.c: the exit-pupil search's start where its grids miss
 * the pupil (lens_pupil.c's pupil_point; camera_lens.h,
 * lr__pupil_seed).
 *
 * The rays from a sensor point reach the rear plane in a spot about (its
 * distance from the sensor) / (f-number) across.  Through US 8,879,901's
 * objective, whose rear surface is 3.2 mm from the sensor, that was 0.08
 * mm at f/38, under the finest coarse cell (0.06 mm): every grid point
 * missed, every ray was lost and the picture black.  The spot's centre is
 * where the ray through the stop's centre crosses the rear plane: found
 * on the radial line (the pupil is symmetric about it) by bisection on
 * the ray's height at the stop, the apertures ignored, and kept if its
 * ray gets through; the pupil's reach from it, by bisection too, sizes
 * the box the fine grid starts from.
 */
#include "camera/camera_lens.h"
#include "optics/lens.h"

#include <math.h>

/* Points tried on the radial line for the stop centre's ray. */
#define SEED_N 64

/* The signed x at which the ray from film radius r through rear-plane
 * point (x, 0) crosses the stop's plane at indices n, the apertures
 * ignored; 0 when the ray misses a surface or is reflected. */
static int stop_x(const lr__cam *c, const double *n, double r, double x,
                  double *sx)
{
    const lr__lens_cam *lc = &c->lens;
    const lr__rx *rx = &lc->L->rx;
    double dz = lc->z_rear - lc->z_sensor, dx = x - r;
    double len = sqrt(dx * dx + dz * dz);
    double o[3] = {r, 0.0, lc->z_sensor}, d[3] = {dx / len, 0.0, dz / len};
    for (int i = rx->n - 1; i >= rx->stop && i >= 0; i--) {
        double p[3], nrm[3], rel;
        if (!lr__rx_meet_rel(rx, lc->L->z, lc->stop_scale, i, o, d, p, nrm,
                             &rel))
            return 0;
        if (i == rx->stop) {
            *sx = p[0];
            return 1;
        }
        if (!lr__rx_refract(d, nrm, n[i], i > 0 ? n[i - 1] : 1.0))
            return 0;
        o[0] = p[0], o[1] = p[1], o[2] = p[2];
    }
    return 0;
}

/* Whether the ray from film radius r through rear-plane point (x, y)
 * gets through with any of the index sets. */
static int passes(const lr__cam *c, const double *const *nsets, int n_sets,
                  double r, double x, double y)
{
    double px[16] = {x}, py[16] = {y}, c4[16];
    int ok[16];
    lr__pupil_passes16(c, nsets, n_sets, r, 1, px, py, ok, c4);
    return ok[0];
}

/* A rear-plane point on the radial line within [-S, S] whose ray passes:
 * the stop centre's ray, by bisection between neighbours of SEED_N + 1
 * points whose stop crossings straddle the centre.  0 when there is none
 * or its ray is stopped. */
static int seed_point(const lr__cam *c, const double *const *nsets, int n_sets,
                      double r, double S, double *xs)
{
    double xa = 0.0, fa = 0.0;
    int have = 0;
    for (int k = 0; k <= SEED_N; k++) {
        double x = -S + 2.0 * S * k / SEED_N, fx;
        if (!stop_x(c, nsets[0], r, x, &fx)) {
            have = 0;
            continue;
        }
        if (have && (fa <= 0.0) != (fx <= 0.0)) {
            double lo = xa, hi = x, flo = fa;
            for (int it = 0; it < 60; it++) {
                double mid = 0.5 * (lo + hi), fm;
                if (!stop_x(c, nsets[0], r, mid, &fm))
                    break;
                if ((fm <= 0.0) == (flo <= 0.0))
                    lo = mid, flo = fm;
                else
                    hi = mid;
            }
            if (passes(c, nsets, n_sets, r, 0.5 * (lo + hi), 0.0)) {
                *xs = 0.5 * (lo + hi);
                return 1;
            }
        }
        xa = x, fa = fx, have = 1;
    }
    return 0;
}

/* The pupil's reach from (xs, 0) along +x, -x and +y, in e[0..2]: the
 * last passing distance, found by doubling from `step` while the far end
 * passes (at most 30 times), then 60 halvings; the three directions in
 * one packet. */
static void seed_reach(const lr__cam *c, const double *const *nsets, int n_sets,
                       double r, double xs, double step, double *e)
{
    static const double ux[3] = {1.0, -1.0, 0.0}, uy[3] = {0.0, 0.0, 1.0};
    double lo[3] = {0.0, 0.0, 0.0}, hi[3] = {step, step, step};
    double x[16] = {0}, y[16] = {0}, t[3], c4[16];
    int ok[16];
    for (int it = 0; it < 90; it++) {
        int grow = it < 30, any = 0;
        for (int k = 0; k < 3; k++) {
            t[k] = grow ? hi[k] : 0.5 * (lo[k] + hi[k]);
            x[k] = xs + t[k] * ux[k], y[k] = t[k] * uy[k];
        }
        lr__pupil_passes16(c, nsets, n_sets, r, 3, x, y, ok, c4);
        for (int k = 0; k < 3; k++) {
            if (ok[k])
                lo[k] = t[k], any = 1;
            else
                hi[k] = t[k];
            if (grow && ok[k])
                hi[k] = 2.0 * t[k];
        }
        if (grow && !any)
            it = 29; /* every far end fails: bisect */
    }
    for (int k = 0; k < 3; k++)
        e[k] = lo[k];
}

int lr__pupil_seed(const lr__cam *c, const double *const *nsets, int n_sets,
                   double r, double S, double step, double box[4], double *cell)
{
    double xs, e[3];
    if (n_sets < 1 || !seed_point(c, nsets, n_sets, r, S, &xs))
        return 0;
    seed_reach(c, nsets, n_sets, r, xs, step, e);
    box[0] = xs - e[1], box[1] = xs + e[0], box[2] = -e[2], box[3] = e[2];
    /* A quarter of the pupil's size each way (the fine grid grows the
     * box where that is too little). */
    double q = 0.25 * fmax(e[0] + e[1], 2.0 * e[2]);
    *cell = q > 0.0 ? q : 1e-6 * S;
    return 1;
}
