/*
 * plan.h: effect planning.  Before a render, for every 16 x 16 block of
 * the frame (aligned to the frame, so crops and tilings plan alike), a
 * conservative bound on the depths that the block's lens rays can reach
 * gives a bound on its circle of confusion: where it is under a quarter
 * pixel the block traces pinhole rays, and where the colours' circles of
 * confusion differ by less than that it traces one ray for all colours.
 * A real lens's bound is its blur table (lens_blur.c, docs/plan-lens.md):
 * the spot and the colours' spread over the block's film radii and that
 * depth range; where the spot is under a quarter pixel the block traces
 * chief rays.
 *
 * The plan is the one record of what to simulate: the render loop, the
 * sampling code, adaptive sampling and the statistics read it and decide
 * nothing of their own.
 */
#ifndef LR_PLAN_H
#define LR_PLAN_H

#include "camera/camera.h"
#include "integrator/light_trace.h"
#include "scene/scene.h"

#include <math.h>

#define LR__PLAN_BLOCK 16     /* pixels per block side */
#define LR__PLAN_BLUR_PX 0.25 /* blur below this is not simulated */
/* ... up to this many samples a pixel; past it the bound shrinks as
 * 1 / sqrt(spp) (lr__plan_blur_px). */
#define LR__PLAN_BLUR_SPP 128.0

/* The blur a block may skip at `spp` samples a pixel: LR__PLAN_BLUR_PX,
 * shrinking past LR__PLAN_BLUR_SPP.  A skipped blur is a bias that more
 * samples do not remove, and the full simulation's noise falls as 1 /
 * spp: on fine detail near the focus (stripes 0.6 px wide, blurred 0.23
 * px) the defaults' relMSE levelled off at 1.95e-4 while the full
 * simulation's fell to 2.4e-5 at 1024 spp (8x).  The skip's error went
 * as the blur squared there, so a bound as 1 / sqrt(spp) keeps it in step
 * with the noise. */
static inline double lr__plan_blur_px(int spp)
{
    return spp > LR__PLAN_BLUR_SPP
               ? LR__PLAN_BLUR_PX * sqrt(LR__PLAN_BLUR_SPP / (double)spp)
               : LR__PLAN_BLUR_PX;
}

/* How a block's samples are traced (sample.c). */
typedef enum lr__path {
    LR__PATH_PACKET = 0, /* 16 samples a packet, one focus for all colours */
    LR__PATH_COLOURS = 1 /* a sample at a time, a ray per colour/wavelength */
} lr__path;

typedef struct lr__block_plan {
    unsigned char lens;   /* sample the lens (0: pinhole rays) */
    unsigned char chroma; /* trace each colour / wavelength on its own */
    unsigned char path;   /* lr__path */
    int pilot;            /* samples every pixel takes before adaptive
                             sampling judges it (adaptive.c); spp when
                             sampling is not adaptive */
    /* 1: every camera sample of the block is exactly 0 (lr__plan_build
     * says when), so its pixels are 0 without tracing (adaptive.c
     * stores one sample of 0 a pixel), adaptive sampling or not. */
    unsigned char dark;
} lr__block_plan;

typedef struct lr__plan {
    /* 1: the whole render is traced by spectral splatting (splat.h:
     * spectral mode with a thin lens), which simulates every block in
     * full and takes spp samples in every pixel (no adaptive sampling);
     * the blocks below are then the full simulation's. */
    int splat;
    int bw, bh;             /* blocks across and down the frame */
    lr__block_plan *blocks; /* bw * bh, owned */
    /* Where a camera sample may carry rare light (lr__plan_unseen); NULL
     * when no sample can (no emitter in the scene, or adaptive sampling
     * off).  Owned. */
    struct lr__rare *rare;
    /* The lights traced from the light side (light_trace.h); NULL: none.
     * Owned. */
    lr__lt *lt;
} lr__plan;

/* Plans the blocks covering [x0, x1) x [y0, y1) of the frame and the
 * one-pixel apron around it that adaptive sampling reads (the others are
 * planned as the full simulation).  A block is dark when nothing its
 * lens rays can reach gives a camera path any light: the background is
 * black (no environment), and every geometry in reach has no lobe and
 * emits nothing the camera counts (none, or only light the light side
 * carries, lr__sample_id.lt).  A night sky of small lights traced from
 * their side is dark; so is the whole frame of a model without a
 * planner's bound when every geometry is.  set->plan = 0 plans every block
 * as the full simulation: the lens sampled wherever the camera has one,
 * the colours split wherever they focus apart.  Returns LR_ERR_NOMEM on
 * failure. */
lr_status lr__plan_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                         const lr_render_settings *set, int x0, int y0, int x1,
                         int y1, lr_error *err);
void lr__plan_free(lr__plan *p);

/* Rare light, for adaptive sampling (adaptive.c): the largest radiance
 * (per channel, the largest channel) that one camera sample of pixel
 * (x, y) could carry from an emitter that its lens and pixel rays may
 * reach through only a small part of their domain, so that a pilot can
 * miss it entirely (a small light far out of focus covers a disc tens of
 * pixels wide, yet each of its pixels sees it through 0.1% of the lens).
 * Sources: emissive geometry whose bounds the pixel's rays (pixel area
 * times aperture, every colour) can reach, and, since a mirror, glass or
 * glossy lobe can show any emitter at full radiance (reflected radiance
 * is at most the largest emitted: energy conservation), surfaces other
 * than Lambertian that they can reach, at the scene's largest emission.
 * An environment map is a source too, bounded over the directions of
 * the pixel's block's rays (a sun in the map is as small and bright as
 * any light).  A model without a thin-lens bound (the real lens) reaches
 * everything.  0: no emitter can be seen by rare samples here. */
double lr__plan_unseen(const lr__plan *p, int x, int y);

/* Meshes of at most this many triangles are planned triangle by triangle
 * (a ground quad); larger ones by the bounds of chunks of triangles
 * (lr__geom.chunk_bounds). */
#define LR__PLAN_FEW LR__GEOM_FEW

static inline const lr__block_plan *lr__plan_at(const lr__plan *p, int x, int y)
{
    return &p->blocks[(y / LR__PLAN_BLOCK) * p->bw + x / LR__PLAN_BLOCK];
}

#endif
