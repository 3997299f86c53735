/*
 * camera_pinhole.c: the ideal pinhole.  Every ray leaves the eye through
 * its film point, so everything is sharp: no lens, no focus, no
 * chromatic aberration (whatever camera.chromatic says).
 */
#include "camera/camera.h"

static lr_status validate(const lr_camera *cam, int active, lr_error *err)
{
    (void)cam, (void)active, (void)err;
    return LR_OK; /* no fields of its own */
}

static void setup(lr__cam *c, const lr_camera *cam)
{
    (void)cam;
    c->has_lens = 0;
    c->w_slope = c->w; /* (0: nothing to shift) */
}

static void bound(const lr__cam *c, lr__lens_bound *b)
{
    (void)c;
    b->R = 0.0;
    b->n_w = 1;
    b->ws[0] = 0.0;
}

static const lr__camera_key keys[] = {{NULL, 0, 0, NULL, 0, 0, 0.0}};

const lr__camera_model lr__camera_pinhole = {
    .name = "pinhole",
    .keys = keys,
    .lens = 0,
    .validate = validate,
    .setup = setup,
    .ray = lr__offset_lens_ray,
    .rays16 = lr__offset_lens_rays16,
    .focus_at = NULL,
    .bound = bound,
    .lens_point = lr__offset_lens_point,
    .film = lr__offset_lens_film,
};
