/*
 * autofocus.c: camera.focus_on, above the camera models: the scene's
 * first hit through a pixel gives the depth, and the model's focus_at
 * (camera.h) sets its focus there.
 */
#include "render/autofocus.h"

#include "camera/camera.h"

#include <math.h>
#include <stdio.h>

lr_status lr__autofocus(const lr_scene *scene, lr_camera *cam, int width,
                        int height, lr_error *err)
{
    const lr__camera_model *model = lr__camera_model_of(cam->model);
    if (cam->focus_on[0] < 0 || model->focus_at == NULL)
        return LR_OK;
    int x = cam->focus_on[0], y = cam->focus_on[1];
    if (x >= width || y >= height)
        return lr__fail(err, LR_ERR_INVALID, "camera.focus_on",
                        "camera.focus_on [%d, %d] is outside the %d x %d "
                        "image",
                        x, y, width, height);
    lr__cam c;
    lr__cam_init(&c, cam, width, height);
    lr__v3 org, dir;
    lr__cam_ray(&c, x + 0.5, y + 0.5, &org, &dir);
    lr__hit h;
    if (!lr__trace(scene, org, dir, INFINITY, &h))
        return lr__fail(err, LR_ERR_INVALID, "camera.focus_on",
                        "camera.focus_on: the ray through pixel [%d, %d] hits "
                        "nothing to focus on",
                        x, y);
    /* Depth along the view axis from the camera's position (a real
     * lens's chief ray starts at its front element, not there; for the
     * other models the second term is exactly 0). */
    double z = h.t * v3_dot(dir, c.forward) +
               v3_dot(v3_sub(org, c.origin), c.forward);
    lr_status st = model->focus_at(cam, z, err);
    if (st == LR_OK) {
        cam->focus_on[0] = cam->focus_on[1] = -1;
        st = lr_camera_validate(cam, err);
    }
    if (st == LR_OK || err == NULL)
        return st;
    /* The field the user set, not the focus_distance it made (the
     * message named camera.focus_distance, never given). */
    char why[sizeof err->message];
    snprintf(why, sizeof why, "%s", err->message);
    return lr__fail(err, st, "camera.focus_on",
                    "camera.focus_on [%d, %d]: the surface there, %g from "
                    "the camera, cannot be focused on: %s",
                    x, y, z, why);
}
