/*
 * camera.c: camera defaults, validation, and film point -> ray.
 */
#include "camera.h"

#include <math.h>

void lr_camera_default(lr_camera *cam)
{
    cam->model = LR_CAMERA_PINHOLE;
    cam->position[0] = cam->position[1] = cam->position[2] = 0.0;
    cam->look_at[0] = 0.0;
    cam->look_at[1] = 0.0;
    cam->look_at[2] = -1.0;
    cam->up[0] = 0.0;
    cam->up[1] = 1.0;
    cam->up[2] = 0.0;
    cam->fov = 40.0;
}

static int finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

lr_status lr_camera_validate(const lr_camera *cam, lr_error *err)
{
    if (cam == NULL)
        return lr__fail(err, LR_ERR_INVALID, "camera", "camera is NULL");
    if (cam->model != LR_CAMERA_PINHOLE)
        return lr__fail(err, LR_ERR_INVALID, "camera.model",
                        "camera.model is not a known model (%d)",
                        (int)cam->model);
    if (!finite3(cam->position))
        return lr__fail(err, LR_ERR_INVALID, "camera.position",
                        "camera.position must be finite");
    if (!finite3(cam->look_at))
        return lr__fail(err, LR_ERR_INVALID, "camera.look_at",
                        "camera.look_at must be finite");
    if (!finite3(cam->up))
        return lr__fail(err, LR_ERR_INVALID, "camera.up",
                        "camera.up must be finite");
    lr__v3 fwd = v3_sub(v3a(cam->look_at), v3a(cam->position));
    double flen = v3_len(fwd);
    if (!(flen > 0.0) || !isfinite(flen))
        return lr__fail(err, LR_ERR_INVALID, "camera.look_at",
                        "camera.look_at must differ from camera.position");
    lr__v3 up = v3a(cam->up);
    double ulen = v3_len(up);
    if (!(ulen > 0.0))
        return lr__fail(err, LR_ERR_INVALID, "camera.up",
                        "camera.up must not be the zero vector");
    /* sin of the angle between up and the view direction. */
    double s = v3_len(v3_cross(v3_scale(fwd, 1.0 / flen),
                               v3_scale(up, 1.0 / ulen)));
    if (!(s > 1e-9))
        return lr__fail(err, LR_ERR_INVALID, "camera.up",
                        "camera.up must not be parallel to the view "
                        "direction (look_at - position)");
    if (!(cam->fov > 0.0 && cam->fov < 180.0))
        return lr__fail(err, LR_ERR_INVALID, "camera.fov",
                        "camera.fov must be in (0, 180) degrees, got %g",
                        cam->fov);
    return LR_OK;
}

void lr__cam_init(lr__cam *c, const lr_camera *cam, int width, int height)
{
    c->model = cam->model;
    c->origin = v3a(cam->position);
    c->forward = v3_norm(v3_sub(v3a(cam->look_at), c->origin));
    c->right = v3_norm(v3_cross(c->forward, v3a(cam->up)));
    c->up = v3_cross(c->right, c->forward);
    c->half_h = tan(cam->fov * M_PI / 360.0);
    c->half_w = c->half_h * (double)width / (double)height;
    c->width = width;
    c->height = height;
}

void lr__cam_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                 lr__v3 *dir)
{
    /* Film to the image plane at distance 1: x right, y up. */
    double sx = (2.0 * fx / c->width - 1.0) * c->half_w;
    double sy = (1.0 - 2.0 * fy / c->height) * c->half_h;
    lr__v3 d = v3_madd(v3_madd(c->forward, c->right, sx), c->up, sy);
    *org = c->origin;
    *dir = v3_norm(d);
}
