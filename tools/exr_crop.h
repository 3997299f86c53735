/*
 * exr_crop.h: places an OpenEXR crop, held in memory, into a larger
 * image: the reading half of `lensray render --remote` (tools/remote.c),
 * which gets each part of a frame from a daemon as a float EXR.
 */
#ifndef LENSRAY_EXR_CROP_H
#define LENSRAY_EXR_CROP_H

#include "lensray.h"

#include <stddef.h>

/* Decodes the single-part scanline EXR in buf[0 .. len), a crop whose
 * data window must be exactly the w x h pixels at fx, fy of its frame
 * (lr_image_set_frame), and copies its R, G, B (and Z, when `dst` has a
 * Z channel) into `dst` at x0, y0.  Values are copied bit for bit; a NaN
 * or infinite one is an error, never written.  Returns 0; or -1 with the
 * reason in msg (a sentence, at most msg_size bytes), and dst partly
 * written. */
int exr_crop_place(const void *buf, size_t len, lr_image *dst, int x0, int y0,
                   int fx, int fy, int w, int h, char *msg, size_t msg_size);

#endif
