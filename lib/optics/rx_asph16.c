/*
 * rx_asph16.c: sixteen rays at once through one aspheric surface, toward
 * the object (prescription.h, lr__rx_asph16).
 *
 * rx_trace.c's intersect, normal_at and lr__rx_refract in the same
 * operations and order, lane by lane, with selects for their early
 * returns: Newton's method on z - sag(r) from the quadric's point
 * (Spencer & Murty 1962) runs until every lane has converged or failed,
 * a lane that is done keeping its values, so each lane gets the scalar
 * code's bits.  The loops over the lanes vectorise (eight doubles a
 * vector under AVX-512).  Before, the packet traces sent aspheric
 * surfaces lane by lane through the scalar code, and a zoom with four
 * aspheres spent 70% of its set-up there (lr__lens_pupils, the chief-ray
 * weights).
 */
#include "optics/prescription.h"

#include <math.h>

/* rx_trace.c's sag_at for one lane: *ok = 0 where r lies beyond the
 * conic's reach (then sag and slope are not meaningful). */
static inline __attribute__((always_inline)) void
sag_lane(const double *asph, double c, double k1, double r, double *sag,
         double *slope, int *ok)
{
    double q = 1.0 - k1 * c * c * r * r;
    *ok = !(q < 0.0);
    double sq = sqrt(q < 0.0 ? 0.0 : q);
    double s = c * r * r / (1.0 + sq);
    double sl = c * r / (sq > 0.0 ? sq : 1.0);
    sl = sq > 0.0 ? sl : INFINITY;
    double rp = r * r * r; /* r^3 */
    for (int j = 0; j < LR__RX_MAX_ASPH; j++) {
        double e = 4.0 + 2.0 * j; /* exponent */
        s += asph[j] * rp * r;
        sl += asph[j] * e * rp;
        rp *= r * r;
    }
    *sag = s, *slope = sl;
}

/* The gradient's x and y parts of z - sag(r) at (x, y), r their height:
 * -slope x / r (0 on the axis). */
static inline __attribute__((always_inline)) double
grad_lane(double slope, double x, double r)
{
    double g = -slope * x / (r > 0.0 ? r : 1.0);
    return r > 0.0 ? g : 0.0;
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__rx_asph16(const lr__rx *rx, const double *z, const double *n1,
              const double *n2, double stop_scale, int i, double (*o)[16],
              double (*d)[16], int *alive, double *cosv)
{
    const lr__surface *s = &rx->s[i];
    const double c = s->radius != 0.0 ? 1.0 / s->radius : 0.0;
    const double k1 = 1.0 + s->conic;
    const double lim = s->semi_aperture * (i == rx->stop ? stop_scale : 1.0);
    const double lim2 = lim * lim, zi = z[i];
    double asph[LR__RX_MAX_ASPH];
    for (int j = 0; j < LR__RX_MAX_ASPH; j++)
        asph[j] = s->asph[j];
    double px[16], py[16], pz[16], tt[16];
    int ok[16], run[16], any = 0;
    /* The quadric's point: intersect's closed form. */
    for (int l = 0; l < 16; l++) {
        double ox = o[0][l], oy = o[1][l], oz = o[2][l] - zi;
        double dx = d[0][l], dy = d[1][l], dz = d[2][l];
        double t;
        int good = lr__rx_lane_quadric(c, k1, ox, oy, oz, dx, dy, dz, &t);
        tt[l] = t;
        px[l] = ox + t * dx, py[l] = oy + t * dy, pz[l] = oz + t * dz;
        ok[l] = alive[l] & good;
        run[l] = ok[l];
        any |= run[l];
    }
    /* Newton on F(t) = z(t) - sag(r(t)), at most 30 steps a lane, each
     * lane until its step is under 1e-13 mm. */
    for (int it = 0; it < 30 && any; it++) {
        any = 0;
        for (int l = 0; l < 16; l++) {
            double ox = o[0][l], oy = o[1][l], oz = o[2][l] - zi;
            double dx = d[0][l], dy = d[1][l], dz = d[2][l];
            double x = px[l], y = py[l];
            double r = sqrt(x * x + y * y), sag, slope;
            int good;
            sag_lane(asph, c, k1, r, &sag, &slope, &good);
            double F = pz[l] - sag;
            double gx = grad_lane(slope, x, r), gy = grad_lane(slope, y, r);
            double dF = gx * dx + gy * dy + dz;
            good &= (dF != 0.0) & isfinite(dF);
            double dt = F / (good ? dF : 1.0);
            double t = tt[l] - dt;
            int go = run[l] & good;
            ok[l] &= (run[l] == 0) | good;
            tt[l] = go ? t : tt[l];
            px[l] = go ? ox + t * dx : x;
            py[l] = go ? oy + t * dy : y;
            pz[l] = go ? oz + t * dz : pz[l];
            run[l] = go & !(fabs(dt) < 1e-13);
            any |= run[l];
        }
    }
    /* The normal (normal_at), the aperture, the refraction. */
    double eta[16], cl[16];
    int bend[16];
    lr__rx_lane_ratios(n1, n2, eta, bend);
    for (int l = 0; l < 16; l++) {
        double x = px[l], y = py[l];
        double r = sqrt(x * x + y * y), sag, slope;
        int good;
        sag_lane(asph, c, k1, r, &sag, &slope, &good);
        double gx = grad_lane(slope, x, r), gy = grad_lane(slope, y, r);
        double len = sqrt(gx * gx + gy * gy + 1.0 * 1.0);
        double m[3] = {gx / len, gy / len, 1.0 / len}, e[3];
        good &= !(x * x + y * y > lim2);
        double dx = d[0][l], dy = d[1][l], dz = d[2][l];
        cl[l] = fabs(dx * m[0] + dy * m[1] + dz * m[2]);
        good &= lr__rx_lane_refract(eta[l], m, dx, dy, dz, e) || !bend[l];
        int live = ok[l] & good;
        alive[l] = live;
        o[0][l] = live ? x : o[0][l];
        o[1][l] = live ? y : o[1][l];
        o[2][l] = live ? pz[l] + zi : o[2][l];
        d[0][l] = live && bend[l] ? e[0] : dx;
        d[1][l] = live && bend[l] ? e[1] : dy;
        d[2][l] = live && bend[l] ? e[2] : dz;
    }
    if (cosv != NULL)
        for (int l = 0; l < 16; l++)
            cosv[l] = cl[l];
}
