/*
 * lens.h: the optics behind the lens models: aperture shapes, glass
 * dispersion, and how a refractive index moves the focus.  Nothing here
 * knows about rays or pixels.
 */
#ifndef LR_LENS_H
#define LR_LENS_H

#include "util/internal.h"

#include <math.h>

/* Maps u in [0, 1)^2 to a point of the aperture in units of its radius,
 * uniformly by area and keeping stratification (neighbouring u stay
 * neighbours): the disk by Shirley & Chiu's concentric mapping, the
 * square by scaling, a regular polygon by choosing a triangle fan sector
 * with u[0] and sampling it with a sqrt-warped u[1].  The result is then
 * rotated by `rotation` (radians) and x is scaled by `ratio`. */
void lr__aperture_sample(lr_aperture_shape shape, int blades, double rotation,
                         double ratio, const double u[2], double *x, double *y);

/* lr__aperture_sample for the lanes 0..n-1 of a packet, in float; all
 * 16 lanes of lx, ly are written.  The disk without rotation has a
 * branch-free version of its own (sin and cos to 2e-9, ample for rays
 * traced in float), so its points differ from lr__aperture_sample's in
 * the last float bits; the other shapes round lr__aperture_sample's.
 * (Inline, so that it is compiled into each of the packet camera's
 * vector versions.) */
static inline void lr__aperture_sample16(lr_aperture_shape shape, int blades,
                                         double rotation, double ratio, int n,
                                         const float *lu, const float *lv,
                                         float *lx, float *ly)
{
    if (shape == LR_APERTURE_DISK && rotation == 0.0) {
        /* Shirley & Chiu's concentric map, branch-free; sin and cos of
         * t in [-pi/4, pi/4] by Taylor series (error < 2e-9). */
        const float fr = (float)ratio;
        for (int i = 0; i < 16; i++) {
            float a = 2.0f * lu[i] - 1.0f, b = 2.0f * lv[i] - 1.0f;
            /* Selects instead of branches, so the loop vectorises.
             * They give the bits of the blends m x + (1 - m) y (m = 1
             * when |a| > |b|) this loop had: a and b are never -0 (x - x
             * is +0), and the one that is picked is nonzero unless both
             * are +0, so adding the other times 0 changes nothing. */
            int m = fabsf(a) > fabsf(b);
            float rr = m ? a : b;
            float num = m ? b : a;
            /* rr = 0 only when a = b = 0, and then num = 0 too. */
            float den = rr + (float)(rr == 0.0f);
            float t = 0.78539816f * num / den;
            float t2 = t * t;
            float sn = t * (1.0f + t2 * (-1.0f / 6 +
                                         t2 * (1.0f / 120 +
                                               t2 * (-1.0f / 5040 +
                                                     t2 * (1.0f / 362880)))));
            float cs = 1.0f + t2 * (-0.5f +
                                    t2 * (1.0f / 24 +
                                          t2 * (-1.0f / 720 +
                                                t2 * (1.0f / 40320 -
                                                      t2 * (1.0f / 3628800)))));
            /* cs > 0; sn is -0 when num is +0 and den < 0, and the
             * blend's (+0) + sn made that +0: so does sn + 0. */
            lx[i] = rr * (m ? cs : sn + 0.0f) * fr;
            ly[i] = rr * (m ? sn + 0.0f : cs);
        }
        return;
    }
    for (int i = 0; i < 16; i++) {
        double x = 0.0, y = 0.0;
        if (i < n) {
            double u[2] = {lu[i], lv[i]};
            lr__aperture_sample(shape, blades, rotation, ratio, u, &x, &y);
        }
        lx[i] = (float)x;
        ly[i] = (float)y;
    }
}

/* Index of refraction of a glass at `nm` nanometres: Sellmeier for the
 * catalogue glasses, the Abbe-number model of glTF's
 * KHR_materials_dispersion for LR_GLASS_ABBE (nd, vd). */
double lr__glass_index(lr_glass glass, double nd, double vd, double nm);

#define LR__LAMBDA_D 587.5618 /* nm: the helium d line */
#define LR__LAMBDA_F 486.1327 /* nm: hydrogen F */
#define LR__LAMBDA_C 656.2725 /* nm: hydrogen C */

/* How a lens's optical power (1 / focal length) scales when the index
 * changes from the reference n_ref to n: n / n_ref for the paper's
 * f_c = f_g n_g / n_c, (n - 1) / (n_ref - 1) for the lensmaker's equation
 * 1/f = (n - 1)(1/R1 - 1/R2).  Working with power rather than focal
 * length means no division by n - 1, which may approach 0 when an index
 * difference is amplified. */
double lr__power_scale(lr_focal_model model, double n_ref, double n);

#endif
