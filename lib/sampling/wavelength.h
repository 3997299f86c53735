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
 * returns l and w.
 *
 * The density.  spectral.c subtracts the reference ray's radiance L_r
 * (the d line) from every wavelength's, so what is sampled is
 * w_c(l) (L_c(l) - L_r,c), which is 0 wherever the ray at l sees what the
 * reference ray sees.  The camera moves a wavelength's ray away from the
 * reference's only by its focus power P(l) (thin lens: a film shift of
 * (P(l) - P_ref) times the lens point), so near an edge the two rays see
 * different things with a probability proportional to |P(l) - P_ref|,
 * and E[(L(l) - L_r)^2] grows like it.  The variance of the estimate,
 * int w^2 E[(L - L_r)^2] / p, is least (Cauchy-Schwarz, summed over the
 * channels: Kahn & Marshall 1953) for
 *
 *     p(l) ~ |w(l)| sqrt(|P(l) - P_ref| / max |P - P_ref|),
 *
 * |w| being the length of the vector of the three normalised matching
 * functions.  The table mixes in 10% of p ~ |w| (a defensive mixture,
 * Hesterberg 1995) so that no weight exceeds 10 times what p ~ |w| gives
 * it (the edge model is only a model; near the d line it would give
 * wavelengths no density at all).  A camera without dispersion (P flat)
 * gets p ~ |w|, the least summed variance for a flat spectrum without
 * the control variate.  docs/spectral.md has the measurements.
 *
 * For speed, everything is tabulated once per render (lr__wl_table_init):
 * W at each whole nanometre and linear between (the integrals above are
 * those of that interpolant, so the weights stay exact for it: it differs
 * from the fit by under 1e-4 of its peak), the focus power likewise, and
 * the sampling as the inverse of p's cumulative distribution at 4096 + 1
 * values of u, linear between: u in cell i maps to [l_i, l_i+1]
 * uniformly, so p is 1 / (4096 (l_i+1 - l_i)) there, exactly the density
 * the weights use.
 */
#ifndef LR_WAVELENGTH_H
#define LR_WAVELENGTH_H

/* Whole nanometres from 380 to 780: the nodes of the tables. */
#define LR__WL_NODES 401
/* Cells of u in the inverse distribution. */
#define LR__WL_CELLS 4096

typedef struct lr__wl_table {
    /* At each whole nanometre: the three normalised matching functions
     * W_c / int W_c, and the camera's focus power. */
    float node[LR__WL_NODES][4];
    /* The inverse distribution at u = i / LR__WL_CELLS, in nm. */
    float lam[LR__WL_CELLS + 1];
} lr__wl_table;

/* Fills *t for a camera whose focus power at 380 + j nm is power[j]
 * (j < LR__WL_NODES) and at the d line p_ref.  power == NULL: no
 * dispersion (p ~ |w|).  Thread-safe; *t is read-only afterwards. */
void lr__wl_table_init(lr__wl_table *t, const float *power, double p_ref);

/* The wavelength (nm) for a number u in [0, 1), its weights w[3] (see
 * above) and the focus power there (*power, if not NULL). */
static inline double lr__wl_sample(const lr__wl_table *t, double u, double w[3],
                                   float *power)
{
    double x = u * LR__WL_CELLS;
    int i = (int)x;
    i = i < 0 ? 0 : i > LR__WL_CELLS - 1 ? LR__WL_CELLS - 1 : i;
    double l0 = t->lam[i], dl = (double)t->lam[i + 1] - l0;
    double nm = l0 + (x - i) * dl;
    /* 1 / p in the cell: LR__WL_CELLS dl. */
    double inv_p = LR__WL_CELLS * dl;
    double y = nm - 380.0;
    int j = (int)y;
    j = j < 0 ? 0 : j > LR__WL_NODES - 2 ? LR__WL_NODES - 2 : j;
    double f = y - j;
    const float *a = t->node[j], *b = t->node[j + 1];
    for (int c = 0; c < 3; c++)
        w[c] = (a[c] + f * ((double)b[c] - a[c])) * inv_p;
    if (power)
        *power = (float)(a[3] + f * ((double)b[3] - a[3]));
    return nm;
}

/* lr__wl_sample for sixteen lanes at once, in float, for the packet
 * path (vectorised; the AVX-512, AVX2 and portable versions give the same
 * bits): lane i draws from u[i] and gets weights w[c][i] and focus power
 * power[i].  Float keeps the weights exact for the density the lanes
 * were drawn with (the cell's width is the same float difference in
 * both); the wavelength itself is not returned, as the packets trace
 * with the power alone. */
void lr__wl_sample16(const lr__wl_table *restrict t, const float u[restrict 16],
                     float w[restrict 3][16], float power[restrict 16]);

/* The density (per nm) with which lr__wl_sample draws `nm`: 0 outside
 * 380 to 780 nm. */
double lr__wl_pdf(const lr__wl_table *t, double nm);

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
