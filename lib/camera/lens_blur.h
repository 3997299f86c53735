/*
 * lens_blur.h: the real lens's blur table, inside (camera.h has what the
 * plan asks of it): lens_blur.c builds it, lens_bound.c answers the
 * plan's questions from it.  Private to those two files.
 */
#ifndef LR_LENS_BLUR_H
#define LR_LENS_BLUR_H

#include "camera/camera_lens.h"

#define NR LR__PUPIL_N /* film radii: the pupil table's */
#define NX 256         /* cells of inverse depth */
/* The bound's margin over the sampled table (docs/plan-lens.md measures
 * how much of it the real spot uses). */
#define MARGIN 1.25
#define MARGIN_MM 2e-4
#define MAX_SLOPE 3.0 /* tan 72 degrees */

struct lr__lens_blur {
    double key[10];
    double x_max; /* 1/mm: the grid's inverse depths are [0, x_max] */
    double reach; /* mm: the largest |p| of any traced ray */
    int ok[NR + 1];
    /* Per interval [k, k + 1] of radii: 1 where the chief weight's
     * interpolation holds at its middle (weights_hold). */
    unsigned char w_ok[NR];
    /* Per film radius, the traced rays' slopes: radial in [slo, shi],
     * tangential within +-sta. */
    double slo[NR + 1], shi[NR + 1], sta[NR + 1];
    float chief_w[NR + 1];
    /* Per film radius, each channel's share: its pupil mean weight over
     * the reference's (lens_shares.c; 1 without colours), for the packet
     * rays that stand for every colour. */
    float share[NR + 1][3];
    /* Spot and colour spread, radial and tangential, film mm. */
    float sr[NR + 1][NX + 1], st[NR + 1][NX + 1];
    float cr[NR + 1][NX + 1], ct[NR + 1][NX + 1];
    /* The skipped blocks' chief rays (lens_chief.c). */
    lr__lens_chief chief;
};

#endif
