/*
 * spectral.h: the camera samples of spectral mode (camera.chromatic.mode
 * "spectral") where the plan splits the colours: which wavelengths each
 * sample traces, and how their radiance becomes linear sRGB.  Called by
 * sample.c; the estimator is described at the top of spectral.c, its
 * measurements in docs/spectral.md.
 */
#ifndef LR_SPECTRAL_H
#define LR_SPECTRAL_H

#include "render/sample.h"

/* Adds samples first .. last-1 of pixel (x, y) to *acc, sixteen at a time
 * (camera models with rays16_w). */
void lr__spectral_packets(const lr__shot *sh, int x, int y, int first, int last,
                          lr__pixel *acc, lr__sample_counts *cnt);

/* Adds samples first .. last-1 of pixel (x, y), which `ps` serves, a
 * ray per wavelength each (models without rays16_w: the real lens; its
 * camera rays made sixteen at a time by lr__cam_lens_rays). */
void lr__spectral_samples(const lr__shot *sh, const lr__pixel_sampler *ps,
                          int x, int y, int first, int last, lr__pixel *acc,
                          lr__sample_counts *cnt);

#endif
