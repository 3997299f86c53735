/*
 * camera_json.h: the scene format's "camera" object, read into an
 * lr_camera (camera_json.c).
 */
#ifndef LR_CAMERA_JSON_H
#define LR_CAMERA_JSON_H

#include "internal.h"

#include <cjson/cJSON.h>

/* Applies the keys of the "camera" object `c` on top of *cam and
 * validates the result; NULL (no camera object) leaves *cam as it is.
 * On error *cam may be partly written: callers work on a copy. */
lr_status lr__camera_from_json(const cJSON *c, lr_camera *cam,
                               lr_error *err);

#endif
