/*
 * lens_shares.c: each colour's share of a real lens's pupil mean weight
 * (camera_lens.h, lr__lens_shares), for the blur table (lens_blur.c),
 * whose packet and chief rays carry one wavelength for every channel.
 *
 * Spectral mode's integral is taken with the mean traced at nodes 25 nm
 * apart and linear between them: the mean's change with wavelength
 * (a coating's reflectance, the glass's dispersion moving the stop's
 * image) is smooth over the visible range, a few percent end to end,
 * so linear interpolation's h^2 / 8 max |m''| is some 1e-4 of it,
 * while the matching functions, which bend on a scale of 20 nm, are
 * taken at every nanometre (lr__srgb_cmf).
 */
#include "camera/camera_lens.h"
#include "sampling/spectrum.h"

#include <stdlib.h>
#include <string.h>

#define STEP ((LR__LAMBDA_MAX - LR__LAMBDA_MIN) / (LR__SHARE_NODES - 1))

/* Spectral weights: w[c][k] = int W_c(l) hat_k(l) dl / int W_c(l) dl at
 * whole nanometres (the ends counted half, the trapezoid rule), hat_k
 * the linear interpolant's basis function at node k. */
static void spectral_weights(lr__lens_shares *s)
{
    double sum[3] = {0.0, 0.0, 0.0};
    memset(s->w, 0, sizeof s->w);
    int last = (int)(LR__LAMBDA_MAX - LR__LAMBDA_MIN);
    for (int j = 0; j <= last; j++) {
        double nm = LR__LAMBDA_MIN + j, W[3];
        lr__srgb_cmf(nm, W);
        double h = j == 0 || j == last ? 0.5 : 1.0;
        double t = j / STEP;
        int k = (int)t;
        k = k < LR__SHARE_NODES - 1 ? k : LR__SHARE_NODES - 2;
        double f = t - k;
        for (int c = 0; c < 3; c++) {
            s->w[c][k] += h * W[c] * (1.0 - f);
            s->w[c][k + 1] += h * W[c] * f;
            sum[c] += h * W[c];
        }
    }
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < LR__SHARE_NODES; k++)
            s->w[c][k] /= sum[c];
}

lr__lens_shares *lr__lens_shares_new(const lr__cam *c)
{
    const lr__lens_cam *lc = &c->lens;
    if (!c->chroma_active)
        return NULL;
    lr__lens_shares *s = calloc(1, sizeof *s);
    if (s == NULL)
        return NULL;
    if (c->chroma.mode == LR_CHROMATIC_RGB) {
        /* The camera's own three (t_rgb_ok in rgb mode with colours). */
        s->n = 3;
        s->tab = (lr__ttab *)lc->t_rgb;
        for (int k = 0; k < 3; k++) {
            memcpy(s->idx[k], lc->n_rgb[k], sizeof s->idx[k]);
            s->w[k][k] = 1.0;
        }
        return s;
    }
    s->n = LR__SHARE_NODES;
    s->own_tab = 1;
    s->tab = malloc(sizeof(lr__ttab) * LR__SHARE_NODES);
    if (s->tab == NULL) {
        free(s);
        return NULL;
    }
    for (int k = 0; k < LR__SHARE_NODES; k++) {
        double nm = LR__LAMBDA_MIN + k * STEP;
        lr__lens_indices(c, nm, s->idx[k]);
        lr__ttab_fill(&s->tab[k], &lc->L->rx, s->idx[k], nm, lc->coat);
    }
    spectral_weights(s);
    return s;
}

void lr__lens_shares_free(lr__lens_shares *s)
{
    if (s != NULL && s->own_tab)
        free(s->tab);
    free(s);
}

int lr__lens_shares_at(const lr__cam *c, const lr__lens_shares *s, double r,
                       const lr__pupil *P, int use_disk, const double *box,
                       double mean_ref, double share[3])
{
    double acc[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < s->n; k++) {
        double m = lr__lens_pupil_mean(c, s->idx[k], &s->tab[k], r, P, use_disk,
                                       box);
        if (m < 0.0)
            return 0;
        for (int ch = 0; ch < 3; ch++)
            acc[ch] += s->w[ch][k] * m;
    }
    for (int ch = 0; ch < 3; ch++)
        share[ch] = acc[ch] / mean_ref;
    return 1;
}
