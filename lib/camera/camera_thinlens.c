/*
 * camera_thinlens.c: the physical thin lens of pbrt, Mitsuba and Blender
 * (Kolb, Mitchell & Hanrahan 1995): a lens of radius aperture_radius (or
 * focal_length_mm / 2 f_number) at the eye, focused on the plane at
 * focus_distance.  Rays follow camera.h's offset-lens form with base = e
 * and w = 1 / focus_distance; the aperture is a disk, a square or a
 * regular polygon, rotated and stretched (anamorphic).
 *
 * Chromatic focus (sensor fixed at v behind the lens, 1/v = 1/F - 1/s):
 * the lens power P = 1/F becomes P(n) = P scale(n) (lens.h), so the plane
 * in focus has 1/s(n) = P(n) - 1/v = 1/s + P (scale(n) - 1): the line
 * w(n) = (w - P) + P scale(n).
 */
#include "camera/camera.h"

#include <math.h>
#include <stddef.h>

#define AT(field) offsetof(lr_camera, field)

/* Indexed by lr_aperture_shape. */
static const char *const shapes[] = {"disk", "square", "polygon", NULL};

static const lr__camera_key keys[] = {
    {"focus_distance", LR__KEY_NUMBER, AT(focus_distance), NULL, 0, 0, 0.0},
    {"aperture_radius", LR__KEY_NUMBER, AT(aperture_radius), NULL, 0, 0, 0.0},
    {"f_number", LR__KEY_NUMBER, AT(f_number), NULL, 0, 0, 0.0},
    {"focal_length_mm", LR__KEY_NUMBER, AT(focal_length_mm), NULL, 0, 0, 0.0},
    {"aperture_shape", LR__KEY_ENUM, AT(aperture_shape), shapes, 0, 0, 0.0},
    {"aperture_blades", LR__KEY_INT, AT(aperture_blades), NULL, 3, 64, 0.0},
    {"aperture_rotation", LR__KEY_NUMBER, AT(aperture_rotation), NULL, 0, 0,
     0.0},
    {"aperture_ratio", LR__KEY_NUMBER, AT(aperture_ratio), NULL, 0, 0, 0.0},
    {NULL, 0, 0, NULL, 0, 0, 0.0},
};

_Static_assert(sizeof(lr_aperture_shape) == sizeof(int),
               "LR__KEY_ENUM fields are stored as int");

#define BAD(path, ...) lr__fail(err, LR_ERR_INVALID, path, __VA_ARGS__)

static lr_status validate(const lr_camera *cam, int active, lr_error *err)
{
    lr_status st = lr__cam_check_length("camera.focus_distance",
                                        cam->focus_distance, 0, 1, err);
    if (st != LR_OK)
        return st;
    st = lr__cam_check_length("camera.aperture_radius", cam->aperture_radius, 1,
                              0, err);
    if (st != LR_OK)
        return st;
    st = lr__cam_check_length("camera.focal_length_mm", cam->focal_length_mm, 1,
                              0, err);
    if (st != LR_OK)
        return st;
    st = lr__cam_check_length("camera.f_number", cam->f_number, 1, 0, err);
    if (st != LR_OK)
        return st;
    if (cam->f_number > 0.0 && cam->f_number < 1e-3)
        return BAD("camera.f_number",
                   "camera.f_number must be 0 (unused) or at least 0.001, "
                   "got %g",
                   cam->f_number);
    /* Only in use: the lens model reads f_number without a focal length. */
    if (active && cam->f_number > 0.0 && !(cam->focal_length_mm > 0.0))
        return BAD("camera.focal_length_mm",
                   "camera.focal_length_mm must be set (> 0) when "
                   "camera.f_number is");
    if (cam->aperture_shape != LR_APERTURE_DISK &&
        cam->aperture_shape != LR_APERTURE_SQUARE &&
        cam->aperture_shape != LR_APERTURE_POLYGON)
        return BAD("camera.aperture_shape",
                   "camera.aperture_shape is not a known shape (%d)",
                   (int)cam->aperture_shape);
    if (cam->aperture_blades < 3 || cam->aperture_blades > 64)
        return BAD("camera.aperture_blades",
                   "camera.aperture_blades must be between 3 and 64, got %d",
                   cam->aperture_blades);
    if (!isfinite(cam->aperture_rotation))
        return BAD("camera.aperture_rotation",
                   "camera.aperture_rotation must be finite");
    if (!(cam->aperture_ratio >= 0.01 && cam->aperture_ratio <= 100.0))
        return BAD("camera.aperture_ratio",
                   "camera.aperture_ratio must be between 0.01 and 100, got %g",
                   cam->aperture_ratio);
    if (active && cam->chromatic.mode != LR_CHROMATIC_OFF) {
        /* The thin lens needs its focal length to know how far the sensor
         * sits behind it, which sets how each colour's focus moves. */
        if (!(cam->focal_length_mm > 0.0))
            return BAD("camera.focal_length_mm",
                       "camera.focal_length_mm must be set (> 0) for "
                       "chromatic aberration with the thin lens");
        if (!(cam->focus_distance * 1000.0 > cam->focal_length_mm))
            return BAD("camera.focus_distance",
                       "camera.focus_distance (%g m) must be beyond the focal "
                       "length (%g mm) to focus",
                       cam->focus_distance, cam->focal_length_mm);
    }
    return LR_OK;
}

static void setup(lr__cam *c, const lr_camera *cam)
{
    c->radius = cam->aperture_radius;
    if (cam->f_number > 0.0)
        c->radius = cam->focal_length_mm / 1000.0 / (2.0 * cam->f_number);
    c->shape = cam->aperture_shape;
    c->blades = cam->aperture_blades;
    c->rotation = cam->aperture_rotation * M_PI / 180.0;
    c->ratio = cam->aperture_ratio;
    c->w = 1.0 / cam->focus_distance;
    c->has_lens = c->radius > 0.0;
    /* The lens power 1/F, for the chromatic focus line (top of file). */
    double lens_power = 0.0;
    if (cam->focal_length_mm > 0.0)
        lens_power = 1000.0 / cam->focal_length_mm;
    c->w_base = c->w - lens_power;
    c->w_slope = lens_power;
}

static lr_status focus_at(lr_camera *cam, double z, lr_error *err)
{
    (void)err;
    cam->focus_distance = z;
    return LR_OK;
}

const lr__camera_model lr__camera_thinlens = {
    .name = "thinlens",
    .keys = keys,
    .lens = 1,
    .validate = validate,
    .setup = setup,
    .ray = lr__offset_lens_ray,
    .rays16 = lr__offset_lens_rays16,
    .rays16_w = lr__offset_lens_rays16_w,
    .shift16 = lr__offset_lens_shift16,
    .focus_at = focus_at,
    .bound = lr__offset_lens_bound,
    .lens_point = lr__offset_lens_point,
    .film = lr__offset_lens_film,
    .film_rgb = lr__offset_lens_film_rgb,
    .film_wl = lr__offset_lens_film_wl,
};
