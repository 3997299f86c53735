/*
 * plan.h: effect planning.  Before a render, for every 16 x 16 block of
 * the frame (aligned to the frame, so crops and tilings plan alike), a
 * conservative bound on the depths that the block's lens rays can reach
 * gives a bound on its circle of confusion: where it is under a quarter
 * pixel the block traces pinhole rays, and where the colours' circles of
 * confusion differ by less than that it traces one ray for all colours.
 */
#ifndef LR_PLAN_H
#define LR_PLAN_H

#include "camera.h"
#include "scene.h"

#define LR__PLAN_BLOCK 16     /* pixels per block side */
#define LR__PLAN_BLUR_PX 0.25 /* blur below this is not simulated */

typedef struct lr__block_plan {
    unsigned char lens;   /* sample the lens */
    unsigned char chroma; /* trace each colour / wavelength */
} lr__block_plan;

typedef struct lr__plan {
    int bw, bh;             /* blocks across and down the frame */
    lr__block_plan *blocks; /* bw * bh, owned */
} lr__plan;

/* Plans the blocks covering [x0, x1) x [y0, y1) of the frame (the others
 * are left planned as "simulate everything").  `enabled` = 0 plans every
 * block as the full simulation.  Returns LR_ERR_NOMEM on failure. */
lr_status lr__plan_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                         int x0, int y0, int x1, int y1, int enabled,
                         lr_error *err);
void lr__plan_free(lr__plan *p);

static inline const lr__block_plan *lr__plan_at(const lr__plan *p, int x,
                                                int y)
{
    return &p->blocks[(y / LR__PLAN_BLOCK) * p->bw + x / LR__PLAN_BLOCK];
}

#endif
