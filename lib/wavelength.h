/*
 * wavelength.h: where spectral mode samples the visible range, and how a
 * wavelength sample becomes linear sRGB.
 *
 * Each output channel c of a spectral pixel is the normalised integral
 *
 *     L_c = int W_c(l) L_c(l) dl / int W_c(l) dl        (380 to 780 nm)
 *
 * with W the linear-sRGB matching functions (spectrum.h).  A wavelength l
 * drawn with density p(l) estimates it without bias as
 * w_c(l) L_c(l) with w_c(l) = W_c(l) / (p(l) int W_c): lr__wl_sample
 * returns l and w.  p is proportional to the norm of the three
 * normalised matching functions,
 *
 *     p(l) ~ sqrt(sum_c (W_c(l) / int W_c)^2),
 *
 * the density that minimises the summed variance of the three channels'
 * estimates of a flat spectrum (for an integrand f with vector values,
 * int |f|^2 / p over densities p is least for p ~ |f|, by Cauchy-Schwarz:
 * Kahn & Marshall 1953, and pbrt-v4's SampleVisibleWavelengths follows
 * the same idea with an analytic fit to luminance).  For the CIE 1931
 * functions of spectrum.c it has 0.51 of a uniform density's variance
 * (8.7 against 17.1, summed over channels).
 *
 * For speed (the functions are sums of exponentials, and the sampling was
 * 40% of a spectral render's time before), everything is tabulated: W at
 * each whole nanometre and linear between (the integrals above are then
 * those of that interpolant, so the weights stay exact for it: it differs
 * from the fit by under 1e-4 of its peak), and the sampling as the
 * inverse of p's cumulative distribution at 4096 + 1 values of u, linear
 * between: u in cell i maps to [l_i, l_i+1] uniformly, so p is
 * 1 / (4096 (l_i+1 - l_i)) there, exactly the density the weights use.
 */
#ifndef LR_WAVELENGTH_H
#define LR_WAVELENGTH_H

/* Makes the tables, once per process (thread-safe); before any
 * lr__wl_sample. */
void lr__wl_init(void);

/* The wavelength (nm) for a number u in [0, 1), and its weights w[3]
 * (see above); the density is p(l) = lr__wl_pdf(l). */
double lr__wl_sample(double u, double w[3]);

/* The density (per nm) with which lr__wl_sample draws `nm`: 0 outside
 * 380 to 780 nm. */
double lr__wl_pdf(double nm);

/* Whole nanometres from 380 to 780: the nodes of lr__wl_table tables. */
#define LR__WL_NODES 401

/* Linear interpolation in a table of f at the whole nanometres. */
static inline double lr__wl_lerp(const float *f, double nm)
{
    double x = nm - 380.0;
    int j = (int)x;
    j = j < 0 ? 0 : j > LR__WL_NODES - 2 ? LR__WL_NODES - 2 : j;
    double t = x - j;
    return f[j] + t * ((double)f[j + 1] - f[j]);
}

/* Wavelengths a spectral camera sample traces besides the reference when
 * the scene does not say (camera.chromatic.wavelengths).  bench/spectral.py
 * found 8 and 16 equally fast to relMSE 1e-3 (4 never gets there within
 * 128 spp), see docs/spectral.md; 8 costs half as much a sample. */
#define LR__WL_PER_SAMPLE 8

#endif
