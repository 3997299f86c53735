/*
 * camera.c: camera defaults, validation, and film point -> ray for the
 * pinhole, thin-lens and bracket models (see camera.h for the geometry).
 */
#include "camera.h"
#include "lens.h"

#include <math.h>

void lr_camera_default(lr_camera *cam)
{
    *cam = (lr_camera){0};
    cam->model = LR_CAMERA_PINHOLE;
    cam->look_at[2] = -1.0;
    cam->up[1] = 1.0;
    cam->fov = 40.0;
    cam->focus_distance = 10.0;
    cam->aperture_radius = 0.0;
    cam->f_number = 0.0;
    cam->focal_length_mm = 0.0;
    cam->aperture_shape = LR_APERTURE_DISK;
    cam->aperture_blades = 6;
    cam->aperture_rotation = 0.0;
    cam->aperture_ratio = 1.0;
    cam->focus_on[0] = cam->focus_on[1] = -1;
    cam->image_plane_distance = 1.0;
    cam->focal_length = 9.0;
    cam->aperture = 0.0;
    cam->chromatic.mode = LR_CHROMATIC_OFF;
    cam->chromatic.focal_model = LR_FOCAL_PAPER;
    /* The paper's indices for red, green and blue light in glass. */
    cam->chromatic.ior[0] = 1.50917;
    cam->chromatic.ior[1] = 1.51534;
    cam->chromatic.ior[2] = 1.51690;
    cam->chromatic.glass = LR_GLASS_BK7;
    cam->chromatic.abbe_nd = 1.5168;
    cam->chromatic.abbe_vd = 64.17;
    cam->chromatic.amplify = 1.0;
    cam->chromatic.wavelengths = 8;
}

/* Finite and within +-1e15, the scene format's limit for any number:
 * beyond it Embree is given rays it cannot trace (and aborts). */
#define LR__MAX_COORD 1e15

static int ok1(double x) { return isfinite(x) && fabs(x) <= LR__MAX_COORD; }

static int finite3(const double v[3])
{
    return ok1(v[0]) && ok1(v[1]) && ok1(v[2]);
}

#define BAD(path, ...) lr__fail(err, LR_ERR_INVALID, path, __VA_ARGS__)

/* Every field is checked whatever the model, so that a bad value never
 * waits silently for the day someone switches models. */
static lr_status validate_lens(const lr_camera *cam, lr_error *err)
{
    if (!(cam->focus_distance > 0.0 && isfinite(cam->focus_distance)))
        return BAD("camera.focus_distance",
                   "camera.focus_distance must be > 0, got %g",
                   cam->focus_distance);
    if (!(cam->aperture_radius >= 0.0 && isfinite(cam->aperture_radius)))
        return BAD("camera.aperture_radius",
                   "camera.aperture_radius must be >= 0, got %g",
                   cam->aperture_radius);
    if (!(cam->focal_length_mm >= 0.0 && isfinite(cam->focal_length_mm)))
        return BAD("camera.focal_length_mm",
                   "camera.focal_length_mm must be >= 0, got %g",
                   cam->focal_length_mm);
    if (!(cam->f_number >= 0.0 && isfinite(cam->f_number)))
        return BAD("camera.f_number", "camera.f_number must be >= 0, got %g",
                   cam->f_number);
    if (cam->f_number > 0.0 && !(cam->focal_length_mm > 0.0))
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
    if (!(cam->image_plane_distance > 0.0 &&
          isfinite(cam->image_plane_distance)))
        return BAD("camera.image_plane_distance",
                   "camera.image_plane_distance must be > 0, got %g",
                   cam->image_plane_distance);
    if (!(cam->focal_length > 0.0 && isfinite(cam->focal_length)))
        return BAD("camera.focal_length",
                   "camera.focal_length must be > 0, got %g",
                   cam->focal_length);
    if (!(cam->aperture >= 0.0 && isfinite(cam->aperture)))
        return BAD("camera.aperture", "camera.aperture must be >= 0, got %g",
                   cam->aperture);
    if ((cam->focus_on[0] < 0) != (cam->focus_on[1] < 0))
        return BAD("camera.focus_on",
                   "camera.focus_on must be a pixel [x, y] with x, y >= 0");
    return LR_OK;
}

static lr_status validate_chromatic(const lr_camera *cam, lr_error *err)
{
    const lr_chromatic *ch = &cam->chromatic;
    if (ch->mode != LR_CHROMATIC_OFF && ch->mode != LR_CHROMATIC_RGB &&
        ch->mode != LR_CHROMATIC_SPECTRAL)
        return BAD("camera.chromatic.mode",
                   "camera.chromatic.mode is not a known mode (%d)",
                   (int)ch->mode);
    if (ch->focal_model != LR_FOCAL_PAPER &&
        ch->focal_model != LR_FOCAL_LENSMAKER)
        return BAD("camera.chromatic.focal_model",
                   "camera.chromatic.focal_model is not a known model (%d)",
                   (int)ch->focal_model);
    static const char *const ior_path[3] = {"camera.chromatic.ior[0]",
                                            "camera.chromatic.ior[1]",
                                            "camera.chromatic.ior[2]"};
    for (int i = 0; i < 3; i++)
        if (!(ch->ior[i] > 1.0 && ch->ior[i] < 4.0))
            return BAD(ior_path[i],
                       "%s must be between 1 and 4 (exclusive), got %g",
                       ior_path[i], ch->ior[i]);
    if ((int)ch->glass < 0 || ch->glass > LR_GLASS_ABBE)
        return BAD("camera.chromatic.glass",
                   "camera.chromatic.glass is not a known glass (%d)",
                   (int)ch->glass);
    if (!(ch->abbe_nd > 1.0 && ch->abbe_nd < 4.0))
        return BAD("camera.chromatic.abbe.n_d",
                   "camera.chromatic.abbe.n_d must be between 1 and 4, got %g",
                   ch->abbe_nd);
    if (!(ch->abbe_vd >= 1.0 && ch->abbe_vd <= 1000.0))
        return BAD("camera.chromatic.abbe.V_d",
                   "camera.chromatic.abbe.V_d must be between 1 and 1000, "
                   "got %g",
                   ch->abbe_vd);
    if (!(ch->amplify >= 0.0 && ch->amplify <= 1e6))
        return BAD("camera.chromatic.amplify",
                   "camera.chromatic.amplify must be between 0 and 1e6, got %g",
                   ch->amplify);
    if (ch->wavelengths < 1 || ch->wavelengths > 64)
        return BAD("camera.chromatic.wavelengths",
                   "camera.chromatic.wavelengths must be between 1 and 64, "
                   "got %d",
                   ch->wavelengths);
    if (ch->mode != LR_CHROMATIC_OFF && cam->model == LR_CAMERA_THINLENS) {
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

lr_status lr_camera_validate(const lr_camera *cam, lr_error *err)
{
    if (cam == NULL)
        return BAD("camera", "camera is NULL");
    if (cam->model != LR_CAMERA_PINHOLE && cam->model != LR_CAMERA_THINLENS &&
        cam->model != LR_CAMERA_BRACKET)
        return BAD("camera.model", "camera.model is not a known model (%d)",
                   (int)cam->model);
    if (!finite3(cam->position))
        return BAD("camera.position",
                   "camera.position must be finite and within +-1e15");
    if (!finite3(cam->look_at))
        return BAD("camera.look_at",
                   "camera.look_at must be finite and within +-1e15");
    if (!finite3(cam->up))
        return BAD("camera.up", "camera.up must be finite and within +-1e15");
    /* Lengths in scene units obey the same limit. */
    const struct {
        const char *path;
        double v;
    } lengths[] = {{"camera.focus_distance", cam->focus_distance},
                   {"camera.aperture_radius", cam->aperture_radius},
                   {"camera.focal_length_mm", cam->focal_length_mm},
                   {"camera.f_number", cam->f_number},
                   {"camera.image_plane_distance", cam->image_plane_distance},
                   {"camera.focal_length", cam->focal_length},
                   {"camera.aperture", cam->aperture}};
    for (size_t i = 0; i < sizeof lengths / sizeof lengths[0]; i++)
        if (isfinite(lengths[i].v) && fabs(lengths[i].v) > LR__MAX_COORD)
            return BAD(lengths[i].path, "%s must be at most 1e15, got %g",
                       lengths[i].path, lengths[i].v);
    /* Distances that set a focus are divided into: below 1e-6 the focus
     * power, and with it the rays' directions, would overflow floats. */
    const struct {
        const char *path;
        double v;
    } foci[] = {{"camera.focus_distance", cam->focus_distance},
                {"camera.image_plane_distance", cam->image_plane_distance},
                {"camera.focal_length", cam->focal_length}};
    for (size_t i = 0; i < sizeof foci / sizeof foci[0]; i++)
        if (foci[i].v > 0.0 && foci[i].v < 1e-6)
            return BAD(foci[i].path, "%s must be at least 1e-6, got %g",
                       foci[i].path, foci[i].v);
    if (cam->f_number > 0.0 && cam->f_number < 1e-3)
        return BAD("camera.f_number",
                   "camera.f_number must be 0 (unused) or at least 0.001, "
                   "got %g",
                   cam->f_number);
    lr__v3 fwd = v3_sub(v3a(cam->look_at), v3a(cam->position));
    double flen = v3_len(fwd);
    if (!(flen > 0.0) || !isfinite(flen))
        return BAD("camera.look_at",
                   "camera.look_at must differ from camera.position");
    lr__v3 up = v3a(cam->up);
    double ulen = v3_len(up);
    if (!(ulen > 0.0) || !isfinite(ulen))
        return BAD("camera.up", "camera.up must not be the zero vector");
    /* sin of the angle between up and the view direction. */
    double s = v3_len(v3_cross(v3_scale(fwd, 1.0 / flen),
                               v3_scale(up, 1.0 / ulen)));
    if (!(s > 1e-9))
        return BAD("camera.up", "camera.up must not be parallel to the view "
                                "direction (look_at - position)");
    if (!(cam->fov > 0.0 && cam->fov < 180.0))
        return BAD("camera.fov", "camera.fov must be in (0, 180) degrees, got %g",
                   cam->fov);
    lr_status st = validate_lens(cam, err);
    if (st != LR_OK)
        return st;
    return validate_chromatic(cam, err);
}

void lr__cam_init(lr__cam *c, const lr_camera *cam, int width, int height)
{
    *c = (lr__cam){0};
    c->model = cam->model;
    c->origin = v3a(cam->position);
    c->forward = v3_norm(v3_sub(v3a(cam->look_at), c->origin));
    c->right = v3_norm(v3_cross(c->forward, v3a(cam->up)));
    c->up = v3_cross(c->right, c->forward);
    c->half_h = tan(cam->fov * M_PI / 360.0);
    c->half_w = c->half_h * (double)width / (double)height;
    c->width = width;
    c->height = height;
    c->ratio = 1.0;
    c->shape = LR_APERTURE_DISK;
    c->blades = 6;
    c->chroma = cam->chromatic;

    /* Optical power of the whole lens, for the thin lens's chromatic
     * focus: 1/F.  The bracket's "focal length" f is its own power. */
    double lens_power = 0.0;
    if (cam->model == LR_CAMERA_THINLENS) {
        c->radius = cam->aperture_radius;
        if (cam->f_number > 0.0)
            c->radius = cam->focal_length_mm / 1000.0 / (2.0 * cam->f_number);
        c->shape = cam->aperture_shape;
        c->blades = cam->aperture_blades;
        c->rotation = cam->aperture_rotation * M_PI / 180.0;
        c->ratio = cam->aperture_ratio;
        c->w = 1.0 / cam->focus_distance;
        if (cam->focal_length_mm > 0.0)
            lens_power = 1000.0 / cam->focal_length_mm;
    } else if (cam->model == LR_CAMERA_BRACKET) {
        /* The bracket is a square of side `aperture`: half side below. */
        c->radius = 0.5 * cam->aperture;
        c->shape = LR_APERTURE_SQUARE;
        c->di = cam->image_plane_distance;
        c->w = 1.0 / cam->focal_length;
    }
    c->has_lens = cam->model != LR_CAMERA_PINHOLE && c->radius > 0.0;

    /* Chromatic focus.  With the reference index the power is c->w.
     * Thin lens (sensor fixed at v, 1/v = 1/F - 1/s): the lens power
     * becomes P(n) = P scale(n), so the plane in focus has
     * 1/s(n) = P(n) - 1/v = 1/s + P (scale(n) - 1).
     * Bracket: the paper scales f itself: 1/f(n) = scale(n) / f. */
    if (cam->model == LR_CAMERA_THINLENS) {
        c->w_base = c->w - lens_power;
        c->w_slope = lens_power;
    } else {
        c->w_base = 0.0;
        c->w_slope = c->w;
    }
    const lr_chromatic *ch = &cam->chromatic;
    if (ch->mode == LR_CHROMATIC_RGB) {
        c->n_ref = ch->ior[1];
        for (int i = 0; i < 3; i++) {
            double n = c->n_ref + ch->amplify * (ch->ior[i] - c->n_ref);
            c->w_rgb[i] = c->w_base +
                          c->w_slope * lr__power_scale(ch->focal_model,
                                                       c->n_ref, n);
        }
        /* The green channel is the reference: exactly the camera's focus. */
        c->w_rgb[1] = c->w;
        c->chroma_active = c->has_lens && (c->w_rgb[0] != c->w_rgb[1] ||
                                           c->w_rgb[2] != c->w_rgb[1]);
    } else if (ch->mode == LR_CHROMATIC_SPECTRAL) {
        c->n_ref = lr__glass_index(ch->glass, ch->abbe_nd, ch->abbe_vd,
                                   LR__LAMBDA_D);
        c->chroma_active = c->has_lens && ch->amplify != 0.0;
    }
}

/* The chief ray's direction scaled so that its component along the view
 * axis is 1: the film point on the image plane at distance 1. */
static lr__v3 chief_ray(const lr__cam *c, double fx, double fy)
{
    /* Film to the image plane at distance 1: x right, y up. */
    double sx = (2.0 * fx / c->width - 1.0) * c->half_w;
    double sy = (1.0 - 2.0 * fy / c->height) * c->half_h;
    return v3_madd(v3_madd(c->forward, c->right, sx), c->up, sy);
}

void lr__cam_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                 lr__v3 *dir)
{
    *org = c->origin;
    *dir = v3_norm(chief_ray(c, fx, fy));
}

void lr__cam_lens_ray(const lr__cam *c, double fx, double fy,
                      const double u[2], double w, lr__v3 *org, lr__v3 *dir)
{
    /* D has axial component 1, so the point of the chief ray at axial
     * distance 1/w is e + D / w, and the ray from the lens point e + off
     * through it runs along D / w - off, i.e. D - off w (the cos factor
     * of camera.h's formula is folded into D's length). */
    lr__v3 D = chief_ray(c, fx, fy);
    if (!c->has_lens) {
        *org = c->origin;
        *dir = v3_norm(D);
        return;
    }
    double lx, ly;
    lr__aperture_sample(c->shape, c->blades, c->rotation, c->ratio, u, &lx,
                        &ly);
    lr__v3 off = v3_madd(v3_scale(c->right, lx * c->radius), c->up,
                         ly * c->radius);
    lr__v3 base = c->origin;
    if (c->model == LR_CAMERA_BRACKET)
        base = v3_madd(c->origin, D, c->di);
    *org = v3_add(base, off);
    *dir = v3_norm(v3_madd(D, off, -w));
}

double lr__cam_power_at(const lr__cam *c, double nm)
{
    const lr_chromatic *ch = &c->chroma;
    double n = lr__glass_index(ch->glass, ch->abbe_nd, ch->abbe_vd, nm);
    n = c->n_ref + ch->amplify * (n - c->n_ref);
    return c->w_base +
           c->w_slope * lr__power_scale(ch->focal_model, c->n_ref, n);
}

double lr__cam_focus_depth(const lr__cam *c, double w)
{
    double base = c->model == LR_CAMERA_BRACKET ? c->di : 0.0;
    return w > 0.0 ? base + 1.0 / w : INFINITY;
}
