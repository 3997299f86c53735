/*
 * wavelength.c: importance sampling of the visible range (wavelength.h).
 */
#include "sampling/wavelength.h"
#include "sampling/spectrum.h"

#include <math.h>
#include <pthread.h>

#define BINS 400      /* 1 nm each, 380 to 780 nm: p is constant in each */
#define DEFENSIVE 0.1 /* the share of p ~ |w| in the mixture */

static float cmf[3][LR__WL_NODES]; /* W_c / int W_c at whole nm */
static pthread_once_t cmf_once = PTHREAD_ONCE_INIT;

static void cmf_init(void)
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
}

void lr__wl_table_init(lr__wl_table *t, const float *power, double p_ref)
{
    pthread_once(&cmf_once, cmf_init);
    for (int j = 0; j < LR__WL_NODES; j++) {
        for (int c = 0; c < 3; c++)
            t->node[j][c] = cmf[c][j];
        t->node[j][3] = power ? power[j] : (float)p_ref;
    }
    /* The focus change's largest size, for the edge factor. */
    double dmax = 0.0;
    for (int j = 0; power && j < LR__WL_NODES; j++)
        dmax = fmax(dmax, fabs(power[j] - p_ref));
    /* A power that is not finite anywhere (an extreme glass) says nothing
     * about edges: p ~ |w| then, and the rays report the rest. */
    if (!isfinite(dmax) || !isfinite(p_ref))
        dmax = 0.0;
    /* p per bin, at its centre (from the float tables, as the weights
     * will read them). */
    double pdf[BINS], cdf[BINS + 1], total = 0.0;
    for (int j = 0; j < BINS; j++) {
        double nm = LR__LAMBDA_MIN + j + 0.5, s = 0.0;
        for (int c = 0; c < 3; c++) {
            double v = lr__wl_lerp(cmf[c], nm);
            s += v * v;
        }
        double edge = 1.0;
        if (dmax > 0.0) {
            double d = fabs(lr__wl_lerp(power, nm) - p_ref) / dmax;
            edge = (1.0 - DEFENSIVE) * sqrt(d <= 1.0 ? d : 1.0) + DEFENSIVE;
        }
        pdf[j] = sqrt(s) * edge;
        total += pdf[j];
    }
    cdf[0] = 0.0;
    for (int j = 0; j < BINS; j++)
        cdf[j + 1] = cdf[j] + pdf[j] / total;
    /* The inverse of the piecewise linear cdf at u = i / CELLS. */
    int j = 0;
    for (int i = 0; i <= LR__WL_CELLS; i++) {
        double u = (double)i / LR__WL_CELLS;
        while (j < BINS - 1 && cdf[j + 1] <= u)
            j++;
        double f = (u - cdf[j]) / (cdf[j + 1] - cdf[j]);
        t->lam[i] = (float)(LR__LAMBDA_MIN + j + (f < 1.0 ? f : 1.0));
    }
    t->lam[0] = LR__LAMBDA_MIN;
    t->lam[LR__WL_CELLS] = LR__LAMBDA_MAX;
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__wl_sample16(const lr__wl_table *restrict t, const float u[restrict 16],
                float w[restrict 3][16], float power[restrict 16])
{
    const float *lam = t->lam, *node = &t->node[0][0];
    for (int i = 0; i < 16; i++) {
        float x = u[i] * LR__WL_CELLS;
        int k = (int)x;
        k = k < 0 ? 0 : k;
        k = k > LR__WL_CELLS - 1 ? LR__WL_CELLS - 1 : k;
        float l0 = lam[k], dl = lam[k + 1] - l0;
        float nm = l0 + (x - (float)k) * dl;
        float inv_p = LR__WL_CELLS * dl;
        float y = nm - 380.0f;
        int j = (int)y;
        j = j < 0 ? 0 : j;
        j = j > LR__WL_NODES - 2 ? LR__WL_NODES - 2 : j;
        float f = y - (float)j;
        int a = 4 * j, b = 4 * j + 4;
        w[0][i] = (node[a] + f * (node[b] - node[a])) * inv_p;
        w[1][i] = (node[a + 1] + f * (node[b + 1] - node[a + 1])) * inv_p;
        w[2][i] = (node[a + 2] + f * (node[b + 2] - node[a + 2])) * inv_p;
        power[i] = node[a + 3] + f * (node[b + 3] - node[a + 3]);
    }
}

double lr__wl_pdf(const lr__wl_table *t, double nm)
{
    if (!(nm >= LR__LAMBDA_MIN && nm < LR__LAMBDA_MAX))
        return 0.0;
    int lo = 0, hi = LR__WL_CELLS; /* the cell with lam[lo] <= nm < lam[lo+1] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (t->lam[mid] <= nm)
            lo = mid;
        else
            hi = mid;
    }
    return 1.0 / (LR__WL_CELLS * ((double)t->lam[lo + 1] - t->lam[lo]));
}
