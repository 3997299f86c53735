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
#include "prescription.h"

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

static int has_asph(const lr__surface *s)
{
    for (int j = 0; j < LR__RX_MAX_ASPH; j++)
        if (s->asph[j] != 0.0)
            return 1;
    return 0;
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

/* Where the ray o + t d (o relative to the vertex) meets surface s: sets
 * the point p and the unit normal nrm (pointing toward +z).  0 on a
 * miss. */
static int intersect(const lr__surface *s, const double o[3],
                     const double d[3], double p[3], double nrm[3])
{
    double c = s->radius != 0.0 ? 1.0 / s->radius : 0.0;
    double k1 = 1.0 + s->conic;
    /* A t^2 + 2 B t + C = 0; the root taken is the one that becomes
     * -C / 2B as the curvature goes to 0, i.e. the sheet through the
     * vertex (not the far side of a sphere). */
    double A = c * (d[0] * d[0] + d[1] * d[1] + k1 * d[2] * d[2]);
    double B = c * (o[0] * d[0] + o[1] * d[1] + k1 * o[2] * d[2]) - d[2];
    double C = c * (o[0] * o[0] + o[1] * o[1] + k1 * o[2] * o[2]) - 2.0 * o[2];
    double disc = B * B - A * C;
    if (disc < 0.0)
        return 0;
    double den = B + copysign(sqrt(disc), B);
    if (den == 0.0)
        return 0;
    double t = -C / den;
    if (!isfinite(t))
        return 0;
    for (int a = 0; a < 3; a++)
        p[a] = o[a] + t * d[a];
    int asph = has_asph(s);
    if (asph) {
        /* Newton on F(t) = z(t) - sag(r(t)). */
        for (int it = 0; it < 30; it++) {
            double r = hypot(p[0], p[1]), sag, slope;
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
    /* The normal: the gradient of z - sag(r), or of the quadric. */
    double g[3];
    if (asph) {
        double r = hypot(p[0], p[1]), sag, slope;
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

/* Refracts unit d at unit normal nrm from index n1 into n2; 0 on total
 * internal reflection. */
static int refract(double d[3], const double nrm[3], double n1, double n2)
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

int lr__rx_trace_n(const lr__rx *rx, const double *z, const double *n_after,
                   double stop_scale, int toward_image, double o[3],
                   double d[3])
{
    int n = rx->n;
    for (int step = 0; step < n; step++) {
        int i = toward_image ? step : n - 1 - step;
        const lr__surface *s = &rx->s[i];
        double ol[3] = {o[0], o[1], o[2] - z[i]}, p[3], nrm[3];
        if (!intersect(s, ol, d, p, nrm))
            return 0;
        double lim = s->semi_aperture * (i == rx->stop ? stop_scale : 1.0);
        if (p[0] * p[0] + p[1] * p[1] > lim * lim)
            return 0;
        o[0] = p[0];
        o[1] = p[1];
        o[2] = p[2] + z[i];
        /* Media on either side of surface i. */
        double before = i > 0 ? n_after[i - 1] : 1.0;
        double after = n_after[i];
        int ok = toward_image ? refract(d, nrm, before, after)
                              : refract(d, nrm, after, before);
        if (!ok)
            return 0;
    }
    return 1;
}

int lr__rx_trace(const lr__rx *rx, const double *z, double nm,
                 double stop_scale, int toward_image, double o[3],
                 double d[3])
{
    double n_after[LR__RX_MAX_SURFACES];
    lr__rx_indices(rx, nm, n_after);
    return lr__rx_trace_n(rx, z, n_after, stop_scale, toward_image, o, d);
}
