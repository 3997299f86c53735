/*
 * point_scene.h: the point-light scene the lens models' blur tests render
 * (test_optics.c, test_camera_thinlens.c, test_camera_bracket.c) and the
 * second moments they measure it by.  The blur kernel's second moment is
 * E(defocused) - E(pinhole) (see ../shared/optics-reference.md), compared
 * with each model's blur computed from its formula.  Include it after
 * the library's headers: W and FOV are macros.
 */
#ifndef LR_TEST_POINT_SCENE_H
#define LR_TEST_POINT_SCENE_H

#include "test.h"

#include <stddef.h>

#define W 161
#define FOV 20.0

typedef struct moments {
    double sum, cx, cy, m2; /* total, centroid, polar second moment */
} moments;

/* Focal length in pixels: H / (2 tan(fov / 2)). */
double f_px(void);

/* A small white sphere (angular radius 0.004 rad, ~1.8 px) at depth z on
 * black, lit by a uniform ambient light so it renders as a flat disk. */
void point_scene(char *buf, size_t n, double z, int spp, const char *sampler);

/* The total, centroid and polar second moment of channel ch. */
moments measure(const lr_image *img, int ch);

/* The blur diameter implied by a measured second moment, for a kernel
 * whose second moment is k * D^2 (disk: 1/8; square of side D: 1/6). */
double diameter(double m2_blur, double k);

/* Fails unless got is within rel * want of want; prints both. */
void check_close(double got, double want, double rel, const char *what,
                 double z);

/* The depths the blur tests put the point at (the focus is elsewhere). */
extern const double depths[4];

#endif
