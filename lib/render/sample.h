/*
 * sample.h: the samples of one pixel.  Numbers from the sampler, rays
 * from the camera model, radiance from the integrator, added to the
 * film in sample order, the way the plan says: a packet of 16 samples at
 * a time with one focus, or with the colours split: one sample at a time
 * with a ray per colour (rgb), or spectral.c's samples (spectral).  Also
 * the Z channel's ray.
 */
#ifndef LR_SAMPLE_H
#define LR_SAMPLE_H

#include "camera/camera.h"
#include "render/film.h"
#include "integrator/integrator.h"
#include "render/plan.h"
#include "sampling/sampler.h"
#include "sampling/wavelength.h"

/* What every sample of a render shares; read-only while it runs. */
typedef struct lr__shot {
    const lr_scene *scene;
    const lr__cam *cam;
    const lr__sampler *sampler;
    const lr__integrator *integrator;
    int width; /* of the full frame, for pixel indices */
    int max_depth;
    /* 1: nobody reads the film's sums of squares (adaptive sampling is
     * off), so the packet path does not keep them.  0, the default,
     * keeps them. */
    int no_squares;
    /* Spectral mode: where wavelengths are drawn, their weights and the
     * camera's focus power (lr__cam_power_at) at each (wavelength.h). */
    lr__wl_table wl;
    /* The light side's part of camera rays' first hits and escapes
     * (lr__sample_id.lt); NULL: none. */
    const lr__lt_view *lt;
} lr__shot;

/* Prepares `sh` (wl) for the other fields the caller has set. */
void lr__shot_init(lr__shot *sh);

/* Counts a thread keeps. */
typedef struct lr__sample_counts {
    uint64_t rays;         /* every ray traced */
    uint64_t camera_rays;  /* camera rays (one per colour where split) */
    uint64_t lens_blocked; /* of those, stopped by a real lens */
} lr__sample_counts;

/* A camera ray's radiance times its weight wt, counted; 0 (not traced)
 * where wt is 0, a ray the lens stopped (the one-ray-a-colour paths:
 * sample.c's rgb samples, spectral.c's). */
static inline lr__v3 lr__weighted_radiance(const lr__shot *sh, lr__v3 org,
                                           lr__v3 dir, double wt,
                                           const lr__sample_id *id,
                                           lr__sample_counts *cnt)
{
    cnt->lens_blocked += wt == 0.0;
    if (wt == 0.0)
        return v3(0, 0, 0);
    return v3_scale(sh->integrator->radiance(sh->scene, sh->max_depth, org, dir,
                                             id, &cnt->rays),
                    wt);
}

/* Adds samples first .. last-1 of pixel (x, y) to *acc, in order, as the
 * block's plan `bp` says. */
void lr__sample_pixel(const lr__shot *sh, const lr__block_plan *bp, int x,
                      int y, int first, int last, lr__pixel *acc,
                      lr__sample_counts *n);

/* lr__sample_pixel for n spans, each as it would be alone (the same
 * samples, added in the same order, to the same bits): consecutive spans
 * on the packet path with the same use of the lens share calls to the
 * camera and the integrator, so that the glass's and the integrator's
 * long chains of one pixel's packet overlap another's (a pixel of 16
 * samples is a single packet).  Packets never mix pixels. */
void lr__sample_pixels(const lr__shot *sh, const lr__plan *plan, int n,
                       const lr__span *sp, lr__sample_counts *cnt);

/* Z: the distance along the view axis of the first hit of the pinhole
 * ray through the centre of pixel (x, y), or LR_DEPTH_NONE. */
float lr__sample_depth(const lr__shot *sh, int x, int y, lr__sample_counts *n);

/* Camera rays one sample takes where the colours are split (1 when they
 * never are): for the full simulation's count in the statistics. */
uint64_t lr__colour_rays(const lr__cam *c);

/* The film (fx, fy) and lens (lu, lv) coordinates of samples s0 ..
 * s0 + n - 1 of pixel (x, y), one lane each: the film position summed in
 * double, as the scalar path does, then rounded once.  Lanes n to 15 get
 * the pixel's centre and the lens's.  The packet paths
 * of sample.c and spectral.c both fill their lanes with it. */
static inline void lr__packet_coords(const lr__pixel_sampler *ps, int x, int y,
                                     uint32_t s0, int n, float fx[16],
                                     float fy[16], float lu[16], float lv[16])
{
    float u[4][16];
    lr__pixel_sampler_get16(ps, s0, n, u);
    if (n == 16) {
        /* A full packet, the common case, in a loop of known length:
         * for n lanes the compiler copies lu and lv by `rep movs`,
         * whose start-up alone cost a third of packet_samples. */
        for (int i = 0; i < 16; i++) {
            fx[i] = (float)(x + (double)u[0][i]);
            fy[i] = (float)(y + (double)u[1][i]);
            lu[i] = u[2][i];
            lv[i] = u[3][i];
        }
        return;
    }
    for (int i = 0; i < n; i++) {
        fx[i] = (float)(x + (double)u[0][i]);
        fy[i] = (float)(y + (double)u[1][i]);
        lu[i] = u[2][i];
        lv[i] = u[3][i];
    }
    /* The lanes past n: any ray the camera makes of them is masked off,
     * but Embree's AVX2 code checks masked lanes for NaN. */
    for (int i = n; i < 16; i++)
        fx[i] = (float)x + 0.5f, fy[i] = (float)y + 0.5f, lu[i] = lv[i] = 0.5f;
}

#endif
