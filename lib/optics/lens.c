/*
 * lens.c: aperture sampling, glass dispersion, focal models.
 */
#include "optics/lens.h"

#include <math.h>

/* sin and cos of t in [-pi/4, pi/4] by their Taylor series to t^13 and
 * t^14: the first omitted terms are below 2e-13, far under the float
 * precision the rays are traced in, and much cheaper than libm. */
static void sincos_quarter(double t, double *s, double *c)
{
    double t2 = t * t;
    *s = t * (1 + t2 * (-1.0 / 6 +
                        t2 * (1.0 / 120 +
                              t2 * (-1.0 / 5040 +
                                    t2 * (1.0 / 362880 +
                                          t2 * (-1.0 / 39916800 +
                                                t2 * (1.0 / 6227020800.0)))))));
    *c = 1 +
         t2 * (-0.5 +
               t2 * (1.0 / 24 +
                     t2 * (-1.0 / 720 +
                           t2 * (1.0 / 40320 +
                                 t2 * (-1.0 / 3628800 +
                                       t2 * (1.0 / 479001600 +
                                             t2 * (-1.0 / 87178291200.0)))))));
}

static void concentric_disk(const double u[2], double *x, double *y)
{
    /* Shirley & Chiu, "A Low Distortion Map Between Disk and Square",
     * 1997: the square's concentric squares go to the disk's circles. */
    double a = 2.0 * u[0] - 1.0, b = 2.0 * u[1] - 1.0;
    if (a == 0.0 && b == 0.0) {
        *x = *y = 0.0;
        return;
    }
    double s, c;
    if (fabs(a) > fabs(b)) {
        /* phi = pi/4 b/a */
        sincos_quarter((M_PI / 4.0) * (b / a), &s, &c);
        *x = a * c;
        *y = a * s;
    } else {
        /* phi = pi/2 - pi/4 a/b: cos(phi) = sin(t), sin(phi) = cos(t) */
        sincos_quarter((M_PI / 4.0) * (a / b), &s, &c);
        *x = b * s;
        *y = b * c;
    }
}

static void polygon(int n, const double u[2], double *x, double *y)
{
    /* Sector k of the fan spans angles [2 pi k / n, 2 pi (k + 1) / n]. The
     * triangle (centre, v_k, v_k+1) is sampled uniformly by
     * p = sqrt(s) ((1 - t) v_k + t v_k+1): the edge at distance sqrt(s)
     * has length proportional to it, so area density is uniform.  t is
     * continuous across sector boundaries, which keeps strata compact. */
    double fk = u[0] * n;
    int k = (int)fk;
    if (k >= n)
        k = n - 1;
    double t = fk - k;
    double s = sqrt(u[1]);
    double a0 = 2.0 * M_PI * k / n, a1 = 2.0 * M_PI * (k + 1) / n;
    *x = s * ((1.0 - t) * cos(a0) + t * cos(a1));
    *y = s * ((1.0 - t) * sin(a0) + t * sin(a1));
}

void lr__aperture_sample(lr_aperture_shape shape, int blades, double rotation,
                         double ratio, const double u[2], double *x, double *y)
{
    double px, py;
    switch (shape) {
    case LR_APERTURE_SQUARE:
        px = 2.0 * u[0] - 1.0;
        py = 2.0 * u[1] - 1.0;
        break;
    case LR_APERTURE_POLYGON:
        polygon(blades, u, &px, &py);
        break;
    case LR_APERTURE_DISK:
    default:
        concentric_disk(u, &px, &py);
        break;
    }
    if (rotation != 0.0) {
        double c = cos(rotation), s = sin(rotation);
        double rx = c * px - s * py, ry = s * px + c * py;
        px = rx;
        py = ry;
    }
    *x = px * ratio;
    *y = py;
}

/* Sellmeier coefficients B1..B3, C1..C3 (um^2), from the Schott catalogue
 * (N-BK7, F2, and N-SF11 under the name SF11 as the reference gives it)
 * and Malitson 1965 (fused silica); see ../shared/optics-reference.md,
 * where they reproduce n_d and V_d. */
static const double sellmeier[4][6] = {
    {1.03961212, 0.231792344, 1.01046945, 0.00600069867, 0.0200179144,
     103.560653},
    {1.34533359, 0.209073176, 0.937357162, 0.00997743871, 0.0470450767,
     111.886764},
    {1.73759695, 0.313747346, 1.89878101, 0.013188707, 0.0623068142, 155.23629},
    {0.6961663, 0.4079426, 0.8974794, 0.00467914826, 0.0135120631, 97.9340025},
};

double lr__glass_index(lr_glass glass, double nd, double vd, double nm)
{
    if (glass == LR_GLASS_ABBE) {
        /* KHR_materials_dispersion: a Cauchy-like curve through n_d with
         * the slope that gives the Abbe number V_d. */
        return nd + (nd - 1.0) / vd * (523655.0 / (nm * nm) - 1.5168);
    }
    const double *c = sellmeier[glass];
    double L2 = (nm * 1e-3) * (nm * 1e-3);
    double n2 = 1.0 + c[0] * L2 / (L2 - c[3]) + c[1] * L2 / (L2 - c[4]) +
                c[2] * L2 / (L2 - c[5]);
    return sqrt(n2);
}

double lr__power_scale(lr_focal_model model, double n_ref, double n)
{
    if (model == LR_FOCAL_LENSMAKER)
        return (n - 1.0) / (n_ref - 1.0);
    return n / n_ref;
}
