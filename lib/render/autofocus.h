/*
 * autofocus.h: camera.focus_on (autofocus.c).  Above the camera models
 * (it traces the scene); a model gives focus_at (camera.h).
 */
#ifndef LR_AUTOFOCUS_H
#define LR_AUTOFOCUS_H

#include "accel/trace.h"

/* camera.focus_on: focuses *cam on the first hit of the pinhole ray
 * through that pixel of a width x height frame (the model's focus_at), and
 * clears focus_on.  No-op when focus_on is unset or the model has no focus.
 * Errors: LR_ERR_INVALID naming camera.focus_on. */
lr_status lr__autofocus(const lr_scene *scene, lr_camera *cam, int width,
                        int height, lr_error *err);

#endif
