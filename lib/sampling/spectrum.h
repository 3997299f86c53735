/*
 * spectrum.h: wavelengths and colour matching.
 */
#ifndef LR_SPECTRUM_H
#define LR_SPECTRUM_H

#define LR__LAMBDA_MIN 380.0 /* nm: the visible range sampled */
#define LR__LAMBDA_MAX 780.0

/* CIE 1931 2-degree colour-matching functions at `nm`, from the
 * multi-lobe piecewise Gaussian fit of Wyman, Sloan & Shirley, "Simple
 * Analytic Approximations to the CIE XYZ Color Matching Functions", JCGT
 * 2(2), 2013 (their equation 2). */
void lr__cie_xyz(double nm, double xyz[3]);

/* The linear-sRGB matching functions: the D65 XYZ -> linear sRGB matrix
 * (IEC 61966-2-1) applied to the CIE functions.  Can be negative. */
void lr__srgb_cmf(double nm, double rgb[3]);

#endif
