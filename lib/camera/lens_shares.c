/*
 * lens_shares.c: each colour's share of a real lens's pupil mean weight
 * (camera_lens.h, lr__lens_shares), for the blur table (lens_blur.c),
 * whose packet and chief rays carry one wavelength for every channel.
 *
 * Spectral mode's integral takes the mean traced at nodes 50 nm apart,
 * cubic between them (the Lagrange cubic through the four nodes nearest
 * each interval), against the matching functions at every nanometre
 * (lr__srgb_cmf, which bend on a scale of 20 nm).  The mean changes
 * smoothly with wavelength, by some 15% over the visible range on a
 * coated lens (every surface's reflectance has its minimum near 550 nm):
 * linear interpolation's error, h^2 / 8 max |m''|, would be some 2e-3
 * of it at these nodes, the cubic's, O(h^4 m''''), under 1e-4
 * (test_real_lens_colours_keep_their_transmittance measures the
 * result against the full simulation).
 */
#include "camera/camera_lens.h"
#include "sampling/spectrum.h"

#include <stdlib.h>
#include <string.h>

#define STEP ((LR__LAMBDA_MAX - LR__LAMBDA_MIN) / (LR__SHARE_NODES - 1))

/* Spectral weights: w[c][k] = int W_c(l) L_k(l) dl / int W_c(l) dl at
 * whole nanometres (the ends counted half, the trapezoid rule), L_k the
 * interpolant's basis function at node k: in the interval [i, i + 1]
 * the Lagrange basis of the nodes j0 .. j0 + 3, j0 = i - 1 clamped to
 * the table. */
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
        int i = (int)t;
        i = i < LR__SHARE_NODES - 1 ? i : LR__SHARE_NODES - 2;
        int j0 = i - 1 < 0 ? 0 : i - 1;
        j0 = j0 > LR__SHARE_NODES - 4 ? LR__SHARE_NODES - 4 : j0;
        for (int a = 0; a < 4; a++) {
            double L = 1.0;
            for (int b = 0; b < 4; b++)
                if (b != a)
                    L *= (t - (j0 + b)) / (double)(a - b);
            for (int c = 0; c < 3; c++)
                s->w[c][j0 + a] += h * W[c] * L;
        }
        for (int c = 0; c < 3; c++)
            sum[c] += h * W[c];
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
