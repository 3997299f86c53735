/*
 * transmit.c: every surface's 1 - R on a lens's main path (transmit.h).
 */
#include "optics/transmit.h"

#include "optics/ghost.h"

#include <math.h>
#include <string.h>

void lr__ttab_fill(lr__ttab *tab, const lr__rx *rx, const double *n_after,
                   double nm, const lr__coating *override)
{
    memset(tab, 0, sizeof *tab);
    for (int i = 0; i < rx->n; i++) {
        double before = i > 0 ? n_after[i - 1] : 1.0, after = n_after[i];
        if (before == after)
            continue;
        double nmin = fmin(before, after);
        tab->inv_nmin2[i] = (float)(1.0 / (nmin * nmin));
        /* u = 0: grazing on the lower-index side, the critical angle on
         * the other, where every stack reflects all (R = 1) but a
         * coating's formula is 0 / 0 for p light (its admittance n / cos
         * is infinite): the table held NaN there, and a condenser's
         * grazing rays weighed NaN (dropped samples). */
        tab->t[i][0] = 0.0f;
        for (int j = 1; j <= LR__T_N; j++) {
            /* The cosine c on the lower-index side (u = sqrt(c),
             * transmit.h); the cosine where the light comes from (toward
             * the image: before) by Snell's law. */
            double u = (double)j / LR__T_N, c = u * u;
            double s2 = nmin * nmin * (1.0 - c * c);
            double cb2 = 1.0 - s2 / (before * before);
            double cb = sqrt(cb2 > 0.0 ? cb2 : 0.0);
            double R = lr__rx_surface_r(rx, n_after, i, 1, cb, nm, override);
            tab->t[i][j] = (float)(1.0 - R);
        }
        for (int j = 0; j < LR__T_N; j++)
            tab->dt[i][j] = tab->t[i][j + 1] - tab->t[i][j];
    }
}

double lr__rx_crossing_t(const lr__rx *rx, const double *n_after, int i,
                         int toward_image, const lr__ttab *tab, double nm,
                         const lr__coating *override, double cos_in)
{
    double before = i > 0 ? n_after[i - 1] : 1.0, after = n_after[i];
    if (before == after)
        return 1.0;
    return tab != NULL
               ? lr__ttab_at(tab, i, toward_image ? before : after, cos_in)
               : 1.0 - lr__rx_surface_r(rx, n_after, i, toward_image, cos_in,
                                        nm, override);
}

int lr__rx_trace_t(const lr__rx *rx, const double *z, const double *n_after,
                   double stop_scale, int toward_image, const lr__ttab *tab,
                   double nm, const lr__coating *override, double o[3],
                   double d[3], double *T)
{
    int n = rx->n;
    double t = 1.0;
    for (int step = 0; step < n; step++) {
        int i = toward_image ? step : n - 1 - step;
        double p[3], nrm[3];
        if (!lr__rx_meet(rx, z, stop_scale, i, o, d, p, nrm))
            return 0;
        o[0] = p[0], o[1] = p[1], o[2] = p[2];
        double before = i > 0 ? n_after[i - 1] : 1.0, after = n_after[i];
        double n_in = toward_image ? before : after;
        double n_out = toward_image ? after : before;
        double ci = fabs(d[0] * nrm[0] + d[1] * nrm[1] + d[2] * nrm[2]);
        if (!lr__rx_refract(d, nrm, n_in, n_out))
            return 0;
        t *= lr__rx_crossing_t(rx, n_after, i, toward_image, tab, nm, override,
                               ci);
    }
    *T = t;
    return 1;
}

const lr__coating *lr__coating_override(int lens_coating)
{
    static const lr__coating none = {.kind = LR__COAT_NONE};
    static const lr__coating mgf2 = {.kind = LR__COAT_MGF2};
    switch (lens_coating) {
    case 1:
        return &none;
    case 2:
        return &mgf2;
    default:
        return NULL;
    }
}
