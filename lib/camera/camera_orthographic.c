/*
 * camera_orthographic.c: a parallel projection.  Every ray leaves the
 * plane through the eye across the view axis, along the axis: objects keep
 * their size at any distance, as in a technical drawing (pbrt-v4's and
 * Mitsuba 3's `orthographic`).  The view is `view_height` scene units
 * tall and as wide as the image's aspect makes it; `fov` plays no part.
 * Everything is sharp: no lens, no focus, no colours.
 *
 * A model registered after "lens": its parameter lives in its block of
 * lr_camera.model_params (camera.h, LR__KEY_PARAM), not in a field of
 * lr_camera, and its state in lr__cam.own.  It has no planner's bound
 * (the planner's is for rays from the eye), so the plan samples it as it
 * would a lens without one, and no light side.
 */
#include "camera/camera.h"

#include <math.h>

enum { VIEW_HEIGHT }; /* its keys, in model_params order */

static const lr__camera_key keys[] = {
    /* scene units; 1e9 keeps x / view_height and its float rays finite */
    {"view_height", LR__KEY_PARAM, VIEW_HEIGHT, NULL, 0, 0, 2.0},
    {NULL, 0, 0, NULL, 0, 0, 0.0},
};

extern const lr__camera_model lr__camera_orthographic;

static double view_height(const lr_camera *cam)
{
    return lr__camera_param(cam, &lr__camera_orthographic, &keys[VIEW_HEIGHT]);
}

static lr_status validate(const lr_camera *cam, int active, lr_error *err)
{
    (void)active;
    double h = view_height(cam);
    if (!(h > 0.0 && h <= 1e9))
        return lr__fail(err, LR_ERR_INVALID, "camera.view_height",
                        "camera.view_height must be > 0 and at most 1e9 "
                        "(scene units), got %g",
                        h);
    return LR_OK;
}

/* own[0], own[1]: the view's half width and half height, scene units. */
static void setup(lr__cam *c, const lr_camera *cam)
{
    c->has_lens = 0;
    c->w_slope = c->w;
    c->own[1] = 0.5 * view_height(cam);
    c->own[0] = c->own[1] * c->width / c->height;
}

/* Film point (fx, fy) -> the ray's start: the eye moved across the axis
 * by the film point's place in the view. */
static double ray(const lr__cam *c, double fx, double fy, const double u[2],
                  double w, double nm, lr__v3 *org, lr__v3 *dir)
{
    (void)u, (void)w, (void)nm;
    double sx = (2.0 * fx / c->width - 1.0) * c->own[0];
    double sy = (1.0 - 2.0 * fy / c->height) * c->own[1];
    *org = v3_madd(v3_madd(c->origin, c->right, sx), c->up, sy);
    *dir = c->forward;
    return 1.0;
}

static void chief(const lr__cam *c, double fx, double fy, lr__v3 *org,
                  lr__v3 *dir)
{
    ray(c, fx, fy, NULL, 0.0, 0.0, org, dir);
}

static void rays16(const lr__cam *c, int use_lens, int n, const float *fx,
                   const float *fy, const float *lu, const float *lv,
                   struct RTCRayHit16 *rh, float *wt)
{
    (void)use_lens, (void)n, (void)lu, (void)lv, (void)wt;
    for (int i = 0; i < 16; i++) {
        lr__v3 o, d;
        ray(c, fx[i], fy[i], NULL, 0.0, 0.0, &o, &d);
        rh->ray.org_x[i] = (float)o.x;
        rh->ray.org_y[i] = (float)o.y;
        rh->ray.org_z[i] = (float)o.z;
        rh->ray.dir_x[i] = (float)d.x;
        rh->ray.dir_y[i] = (float)d.y;
        rh->ray.dir_z[i] = (float)d.z;
        lr__ray16_open(rh, i);
    }
}

const lr__camera_model lr__camera_orthographic = {
    .name = "orthographic",
    .keys = keys,
    .lens = 0,
    .validate = validate,
    .setup = setup,
    .ray = ray,
    .rays16 = rays16,
    .chief = chief,
};
