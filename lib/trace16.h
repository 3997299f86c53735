/*
 * trace16.h: camera samples traced sixteen at a time.  The samples of a
 * pixel are packed into 16-wide Embree packets (the lens samples of one
 * pixel are coherent: they all pass near one focal point), their
 * shadow rays likewise, and each lane is shaded exactly as lr__radiance
 * would shade it.  Used whenever every colour shares one focus.
 */
#ifndef LR_TRACE16_H
#define LR_TRACE16_H

#include "camera.h"
#include "film.h"
#include "sampler.h"
#include "scene.h"

typedef struct lr__trace16 {
    const lr_scene *scene;
    const lr__cam *cam;
    const lr__sampler *sampler;
    int width;     /* of the full frame, for pixel indices */
    int spp;
    int max_depth;
} lr__trace16;

/* Traces samples first .. last-1 of pixel (x, y), adding them in sample
 * order to *acc; through the lens if use_lens, else as pinhole rays.
 * Counts all rays into *rays and the camera rays into *camera_rays. */
void lr__trace16_pixel(const lr__trace16 *t, int x, int y, int first,
                       int last, int use_lens, lr__pixel *acc,
                       uint64_t *rays, uint64_t *camera_rays);

/* For tests: when nonzero, every lane is completed and shaded by the
 * scalar code of scene.c and shade.c instead of the vector path, whose
 * results must match it bit for bit.  Not thread-safe to change during a
 * render. */
extern int lr__trace16_scalar_only;

#endif
