/*
 * camera.h: turns a film position into a ray.  The camera knows nothing
 * of how pixels are stored; it sees continuous film coordinates.
 */
#ifndef LR_CAMERA_H
#define LR_CAMERA_H

#include "internal.h"
#include "vec.h"

/* A camera prepared for one render: an orthonormal frame and the image
 * plane's extent. */
typedef struct lr__cam {
    lr_camera_model model;
    lr__v3 origin;
    lr__v3 forward, right, up; /* unit, right-handed */
    double half_h;             /* tan(fov/2): image plane half height at 1 */
    double half_w;             /* half_h * width / height */
    double width, height;      /* film size in pixels */
} lr__cam;

/* Prepares `c`; `cam` must have passed lr_camera_validate. */
void lr__cam_init(lr__cam *c, const lr_camera *cam, int width, int height);

/* The primary ray through film point (fx, fy), in pixels from the image's
 * top-left corner (pixel (x, y) covers [x, x+1) x [y, y+1)).  `dir` is
 * unit length. */
void lr__cam_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                 lr__v3 *dir);

#endif
