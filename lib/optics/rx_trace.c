/*
 * rx_trace.c: real rays through a prescription, surface by surface
 * (prescription.h).
 *
 * Each surface is a conic of revolution plus even aspheric terms, its
 * vertex at (0, 0, z_i):
 *
 *     sag(r) = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + sum A_j r^j
 *
 * (c = 1 / radius, k = conic).  Without aspheric terms the surface is the
 * quadric c (x^2 + y^2) + c (1 + k) z^2 - 2 z = 0, met in closed form;
 * with them, Newton's method on z - sag(r) starts from the quadric's
 * point (Spencer & Murty 1962, "General ray-tracing procedure", JOSA 52).
 * Refraction is the vector form of Snell's law (optics-reference.md).
 */
#include "optics/prescription.h"

#include <math.h>

void lr__rx_layout(const lr__rx *rx, double *z)
{
    z[0] = 0.0;
    for (int i = 0; i < rx->n; i++)
        z[i + 1] = z[i] + rx->s[i].thickness;
}

void lr__rx_indices(const lr__rx *rx, double nm, double *n_after)
{
    for (int i = 0; i < rx->n; i++)
        n_after[i] = lr__glass_n(&rx->s[i].after, nm);
}

/* d sag / d r at r (r > 0), and the sag, of surface s; 0 when r lies
 * beyond the conic's reach (1 - (1 + k) c^2 r^2 < 0). */
static int sag_at(const lr__surface *s, double r, double *sag, double *slope)
{
    double c = s->radius != 0.0 ? 1.0 / s->radius : 0.0;
    double q = 1.0 - (1.0 + s->conic) * c * c * r * r;
    if (q < 0.0)
        return 0;
    double sq = sqrt(q);
    *sag = c * r * r / (1.0 + sq);
    *slope = sq > 0.0 ? c * r / sq : INFINITY;
    double rp = r * r * r; /* r^3 */
    for (int j = 0; j < LR__RX_MAX_ASPH; j++) {
        double e = 4.0 + 2.0 * j; /* exponent */
        *sag += s->asph[j] * rp * r;
        *slope += s->asph[j] * e * rp;
        rp *= r * r;
    }
    return 1;
}

/* Where the ray o + t d (o relative to the vertex) meets surface s, of
 * curvature c = 1 / radius (0 when flat) and k1 = 1 + conic: sets the
 * point p.  0 on a miss.  The normal is normal_at's, apart so that a
 * ray outside the aperture costs no normal. */
static int intersect(const lr__surface *s, double c, double k1,
                     const double o[3], const double d[3], double p[3])
{
    /* The root on the vertex sheet, ahead of the ray: the packets'
     * lr__rx_lane_quadric, which says how, in the same operations. */
    double t;
    if (!lr__rx_lane_quadric(c, k1, o[0], o[1], o[2], d[0], d[1], d[2], &t))
        return 0;
    for (int a = 0; a < 3; a++)
        p[a] = o[a] + t * d[a];
    if (lr__rx_aspheric(s)) {
        /* Newton on F(t) = z(t) - sag(r(t)).  The height is sqrt(x^2 +
         * y^2), not hypot's: lr__rx_asph16 takes it so in vectors and
         * must give these bits (a millimetre-sized lens neither
         * overflows nor underflows it). */
        for (int it = 0; it < 30; it++) {
            double r = sqrt(p[0] * p[0] + p[1] * p[1]), sag, slope;
            if (!sag_at(s, r, &sag, &slope))
                return 0;
            double F = p[2] - sag;
            double gx = r > 0 ? -slope * p[0] / r : 0.0;
            double gy = r > 0 ? -slope * p[1] / r : 0.0;
            double dF = gx * d[0] + gy * d[1] + d[2];
            if (dF == 0.0 || !isfinite(dF))
                return 0;
            double dt = F / dF;
            t -= dt;
            for (int a = 0; a < 3; a++)
                p[a] = o[a] + t * d[a];
            if (fabs(dt) < 1e-13)
                break;
        }
    }
    return 1;
}

/* The unit normal nrm (pointing toward +z) of surface s at its point p.
 * 0 when there is none: past the conic's equator (the gradient turns
 * away from +z: the ray met the surface's far side) or beyond an
 * aspheric's reach. */
static int normal_at(const lr__surface *s, double c, double k1,
                     const double p[3], double nrm[3])
{
    /* The normal: the gradient of z - sag(r), or of the quadric. */
    double g[3];
    if (lr__rx_aspheric(s)) {
        double r = sqrt(p[0] * p[0] + p[1] * p[1]), sag, slope;
        if (!sag_at(s, r, &sag, &slope))
            return 0;
        g[0] = r > 0 ? -slope * p[0] / r : 0.0;
        g[1] = r > 0 ? -slope * p[1] / r : 0.0;
        g[2] = 1.0;
    } else {
        /* Half the gradient of c(x^2+y^2) + c k1 z^2 - 2z, negated so
         * that it points toward +z at the vertex. */
        g[0] = -c * p[0];
        g[1] = -c * p[1];
        g[2] = 1.0 - c * k1 * p[2];
        /* Past the conic's equator the gradient turns away from +z: the
         * ray met the surface's far side. */
        if (g[2] <= 0.0)
            return 0;
    }
    double len = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    for (int a = 0; a < 3; a++)
        nrm[a] = g[a] / len;
    return 1;
}

int lr__rx_refract(double d[3], const double nrm[3], double n1, double n2)
{
    if (n1 == n2)
        return 1;
    double m[3] = {nrm[0], nrm[1], nrm[2]};
    double cosi = -(m[0] * d[0] + m[1] * d[1] + m[2] * d[2]);
    if (cosi < 0.0) { /* the normal must face the incoming ray */
        for (int a = 0; a < 3; a++)
            m[a] = -m[a];
        cosi = -cosi;
    }
    double eta = n1 / n2;
    double k = 1.0 - eta * eta * (1.0 - cosi * cosi);
    if (k < 0.0)
        return 0;
    double f = eta * cosi - sqrt(k);
    double len = 0.0;
    for (int a = 0; a < 3; a++) {
        d[a] = eta * d[a] + f * m[a];
        len += d[a] * d[a];
    }
    len = sqrt(len);
    for (int a = 0; a < 3; a++)
        d[a] /= len;
    return 1;
}

/* Where the ray meets surface i, its normal there, its height squared
 * r2 and the surface's semi-aperture lim (the stop's scaled). */
static int meet(const lr__rx *rx, const double *z, double stop_scale, int i,
                const double o[3], const double d[3], double p[3],
                double nrm[3], double *r2, double *lim)
{
    const lr__surface *s = &rx->s[i];
    double ol[3] = {o[0], o[1], o[2] - z[i]};
    double c = s->radius != 0.0 ? 1.0 / s->radius : 0.0;
    double k1 = 1.0 + s->conic;
    if (!intersect(s, c, k1, ol, d, p) || !normal_at(s, c, k1, p, nrm))
        return 0;
    *lim = s->semi_aperture * (i == rx->stop ? stop_scale : 1.0);
    *r2 = p[0] * p[0] + p[1] * p[1];
    p[2] += z[i];
    return 1;
}

int lr__rx_meet(const lr__rx *rx, const double *z, double stop_scale, int i,
                const double o[3], const double d[3], double p[3],
                double nrm[3])
{
    double r2, lim;
    return meet(rx, z, stop_scale, i, o, d, p, nrm, &r2, &lim) &&
           !(r2 > lim * lim);
}

int lr__rx_meet_rel(const lr__rx *rx, const double *z, double stop_scale, int i,
                    const double o[3], const double d[3], double p[3],
                    double nrm[3], double *rel)
{
    double r2, lim;
    if (!meet(rx, z, stop_scale, i, o, d, p, nrm, &r2, &lim))
        return 0;
    *rel = lim > 0.0 ? sqrt(r2) / lim : INFINITY;
    return 1;
}

int lr__rx_trace_surface(const lr__rx *rx, const double *z,
                         const double *n_after, double stop_scale, int i,
                         int toward_image, double o[3], double d[3])
{
    double p[3], nrm[3];
    if (!lr__rx_meet(rx, z, stop_scale, i, o, d, p, nrm))
        return 0;
    o[0] = p[0];
    o[1] = p[1];
    o[2] = p[2];
    /* Media on either side of surface i. */
    double before = i > 0 ? n_after[i - 1] : 1.0;
    double after = n_after[i];
    return toward_image ? lr__rx_refract(d, nrm, before, after)
                        : lr__rx_refract(d, nrm, after, before);
}

int lr__rx_trace_n(const lr__rx *rx, const double *z, const double *n_after,
                   double stop_scale, int toward_image, double o[3],
                   double d[3])
{
    int n = rx->n;
    for (int step = 0; step < n; step++) {
        int i = toward_image ? step : n - 1 - step;
        if (!lr__rx_trace_surface(rx, z, n_after, stop_scale, i, toward_image,
                                  o, d))
            return 0;
    }
    return 1;
}

int lr__rx_trace(const lr__rx *rx, const double *z, double nm,
                 double stop_scale, int toward_image, double o[3], double d[3])
{
    double n_after[LR__RX_MAX_SURFACES];
    lr__rx_indices(rx, nm, n_after);
    return lr__rx_trace_n(rx, z, n_after, stop_scale, toward_image, o, d);
}

/* ---- sixteen rays at once -------------------------------------------------- */

/* The same trace for lanes where alive[i] is 1, in loops over the lanes
 * that the compiler vectorises (target_clones picks AVX-512, AVX2 or
 * plain x86-64 at load time): the same operations in the same order as
 * the scalar code, in double, with selects for its early returns, so each
 * lane gets the scalar trace's bits.  Aspheric surfaces (Newton's method,
 * a loop of its own length per ray) go to lr__rx_asph16, which gives
 * them too.  Each lane has its own indices (nl, lr__rx_trace16_nl); with
 * cosv, the cosine at each surface before the refraction. */
__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__rx_trace16_nl(const lr__rx *rx, const double *z, const double (*nl)[16],
                  double stop_scale, double (*o)[16], double (*d)[16],
                  int *alive, double (*cosv)[16])
{
    int n = rx->n;
    double air[16], cl[16];
    for (int l = 0; l < 16; l++)
        air[l] = 1.0;
    for (int step = 0; step < n; step++) {
        /* Once every lane is lost, the rest would change nothing. */
        int any = 0;
        for (int l = 0; l < 16; l++)
            any |= alive[l];
        if (!any)
            return;
        int i = n - 1 - step;
        const lr__surface *s = &rx->s[i];
        const double *n1 = nl[i], *n2 = i > 0 ? nl[i - 1] : air;
        if (lr__rx_aspheric(s)) {
            lr__rx_asph16(rx, z, n1, n2, stop_scale, i, o, d, alive, cl);
        } else {
            const double c = s->radius != 0.0 ? 1.0 / s->radius : 0.0;
            const double k1 = 1.0 + s->conic;
            const double lim = s->semi_aperture *
                               (i == rx->stop ? stop_scale : 1.0);
            const double lim2 = lim * lim, zi = z[i];
            double eta[16];
            int bend[16];
            lr__rx_lane_ratios(n1, n2, eta, bend);
            for (int l = 0; l < 16; l++) {
                double ox = o[0][l], oy = o[1][l], oz = o[2][l] - zi;
                double dx = d[0][l], dy = d[1][l], dz = d[2][l];
                double pt[3], m[3], e[3];
                int ok = lr__rx_lane_meet(c, k1, ox, oy, oz, dx, dy, dz, pt, m);
                double px = pt[0], py = pt[1], pz = pt[2];
                ok &= !(px * px + py * py > lim2);
                cl[l] = fabs(dx * m[0] + dy * m[1] + dz * m[2]);
                /* Refraction (lr__rx_refract above, from n1 into n2). */
                ok &= lr__rx_lane_refract(eta[l], m, dx, dy, dz, e) || !bend[l];
                double ex = e[0], ey = e[1], ez = e[2];
                int live = alive[l] & ok;
                alive[l] = live;
                o[0][l] = live ? px : o[0][l];
                o[1][l] = live ? py : o[1][l];
                o[2][l] = live ? pz + zi : o[2][l];
                d[0][l] = live && bend[l] ? ex : dx;
                d[1][l] = live && bend[l] ? ey : dy;
                d[2][l] = live && bend[l] ? ez : dz;
            }
        }
        if (cosv != NULL)
            for (int l = 0; l < 16; l++)
                cosv[i][l] = cl[l];
    }
}

/* Every lane at the indices n_after. */
static void same_indices(const lr__rx *rx, const double *n_after,
                         double (*nl)[16])
{
    for (int i = 0; i < rx->n; i++)
        for (int l = 0; l < 16; l++)
            nl[i][l] = n_after[i];
}

void lr__rx_trace16(const lr__rx *rx, const double *z, const double *n_after,
                    double stop_scale, double (*o)[16], double (*d)[16],
                    int *alive)
{
    double nl[LR__RX_MAX_SURFACES][16];
    same_indices(rx, n_after, nl);
    lr__rx_trace16_nl(rx, z, (const double(*)[16])nl, stop_scale, o, d, alive,
                      NULL);
}
