/*
 * spectrum.c: CIE 1931 colour matching and XYZ -> linear sRGB.
 */
#include "sampling/spectrum.h"

#include <math.h>

/* A Gaussian lobe with different widths below and above its mean. */
static double lobe(double x, double mu, double s_lo, double s_hi)
{
    double t = (x - mu) / (x < mu ? s_lo : s_hi);
    return exp(-0.5 * t * t);
}

void lr__cie_xyz(double nm, double xyz[3])
{
    xyz[0] = 1.056 * lobe(nm, 599.8, 37.9, 31.0) +
             0.362 * lobe(nm, 442.0, 16.0, 26.7) -
             0.065 * lobe(nm, 501.1, 20.4, 26.2);
    xyz[1] = 0.821 * lobe(nm, 568.8, 46.9, 40.5) +
             0.286 * lobe(nm, 530.9, 16.3, 31.1);
    xyz[2] = 1.217 * lobe(nm, 437.0, 11.8, 36.0) +
             0.681 * lobe(nm, 459.0, 26.0, 13.8);
}

void lr__srgb_cmf(double nm, double rgb[3])
{
    /* XYZ to linear sRGB, D65 (IEC 61966-2-1:1999). */
    static const double M[3][3] = {{3.2404542, -1.5371385, -0.4985314},
                                   {-0.9692660, 1.8760108, 0.0415560},
                                   {0.0556434, -0.2040259, 1.0572252}};
    double xyz[3];
    lr__cie_xyz(nm, xyz);
    for (int i = 0; i < 3; i++)
        rgb[i] = M[i][0] * xyz[0] + M[i][1] * xyz[1] + M[i][2] * xyz[2];
}
