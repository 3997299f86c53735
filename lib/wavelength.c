/*
 * wavelength.c: importance sampling of the visible range (wavelength.h).
 */
#include "wavelength.h"
#include "spectrum.h"

#include <math.h>
#include <pthread.h>

#define BINS 400 /* 1 nm each, 380 to 780 nm: p is constant in each */
#define CELLS 4096 /* of u: the inverse distribution's table */

static float cmf[3][LR__WL_NODES]; /* W_c / int W_c at whole nm */
static double lam[CELLS + 1];      /* the inverse distribution at i/CELLS */
static double cell_w[CELLS];       /* CELLS (l_i+1 - l_i): 1 / p in cell i */
static pthread_once_t table_once = PTHREAD_ONCE_INIT;

static void table_init(void)
{
    /* W at the nodes; int of its interpolant by the trapezoid rule. */
    double W[LR__WL_NODES][3], sum[3] = {0, 0, 0};
    for (int j = 0; j < LR__WL_NODES; j++) {
        lr__srgb_cmf(LR__LAMBDA_MIN + j, W[j]);
        for (int c = 0; c < 3; c++)
            sum[c] += W[j][c] * (j == 0 || j == LR__WL_NODES - 1 ? 0.5 : 1);
    }
    for (int j = 0; j < LR__WL_NODES; j++)
        for (int c = 0; c < 3; c++)
            cmf[c][j] = (float)(W[j][c] / sum[c]);
    /* p per bin: the norm of the normalised functions at its centre
     * (from the float table, as the weights will read them). */
    double pdf[BINS], cdf[BINS + 1], total = 0.0;
    for (int j = 0; j < BINS; j++) {
        double s = 0.0;
        for (int c = 0; c < 3; c++) {
            double v = lr__wl_lerp(cmf[c], LR__LAMBDA_MIN + j + 0.5);
            s += v * v;
        }
        pdf[j] = sqrt(s);
        total += pdf[j];
    }
    cdf[0] = 0.0;
    for (int j = 0; j < BINS; j++)
        cdf[j + 1] = cdf[j] + pdf[j] / total;
    /* The inverse of the piecewise linear cdf at u = i / CELLS. */
    int j = 0;
    for (int i = 0; i <= CELLS; i++) {
        double u = (double)i / CELLS;
        while (j < BINS - 1 && cdf[j + 1] <= u)
            j++;
        double t = (u - cdf[j]) / (cdf[j + 1] - cdf[j]);
        lam[i] = LR__LAMBDA_MIN + j + (t < 1.0 ? t : 1.0);
    }
    lam[0] = LR__LAMBDA_MIN;
    lam[CELLS] = LR__LAMBDA_MAX;
    for (int i = 0; i < CELLS; i++)
        cell_w[i] = CELLS * (lam[i + 1] - lam[i]);
}

void lr__wl_init(void) { pthread_once(&table_once, table_init); }

double lr__wl_pdf(double nm)
{
    pthread_once(&table_once, table_init);
    if (!(nm >= LR__LAMBDA_MIN && nm < LR__LAMBDA_MAX))
        return 0.0;
    int lo = 0, hi = CELLS; /* the cell with lam[lo] <= nm < lam[lo + 1] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (lam[mid] <= nm)
            lo = mid;
        else
            hi = mid;
    }
    return 1.0 / cell_w[lo];
}

double lr__wl_sample(double u, double w[3])
{
    double x = u * CELLS;
    int i = (int)x;
    i = i < 0 ? 0 : i > CELLS - 1 ? CELLS - 1 : i;
    double nm = lam[i] + (x - i) * (lam[i + 1] - lam[i]);
    for (int c = 0; c < 3; c++)
        w[c] = lr__wl_lerp(cmf[c], nm) * cell_w[i];
    return nm;
}
