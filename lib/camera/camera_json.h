/*
 * camera_json.h: the scene format's "camera" object, read into an
 * lr_camera (camera_json.c).
 */
#ifndef LR_CAMERA_JSON_H
#define LR_CAMERA_JSON_H

#include "util/internal.h"

#include <cjson/cJSON.h>

/* Applies the keys of the "camera" object `c` on top of *cam and
 * validates the result; NULL (no camera object) leaves *cam as it is.
 * A lens file (camera.lens) is found relative to base_dir, the scene's
 * directory; NULL allows only shipped lens names (lens_load.h).
 * On error *cam may be partly written: callers work on a copy. */
lr_status lr__camera_from_json(const cJSON *c, lr_camera *cam,
                               const char *base_dir, lr_error *err);

#endif
