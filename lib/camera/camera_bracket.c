/*
 * camera_bracket.c: the paper's square "bracket" (Kuang & Lee 2018,
 * after Lee 2007).  The image plane is image_plane_distance (di) in front
 * of the eye and the focal plane focal_length (f) beyond it; rays start
 * in a square of side `aperture` around the pixel's point on the image
 * plane and pass through the pixel's focal point
 * p = e + (di + f) dp / di d.  In camera.h's offset-lens form: base =
 * e + D di, w = 1 / f, a square lens of half side aperture / 2.
 *
 * Chromatic focus: the paper scales f itself, f_c = f_g n_g / n_c (or
 * the lensmaker's f proportional to 1 / (n - 1)): w(n) = w scale(n).
 */
#include "camera/camera.h"

#include <math.h>
#include <stddef.h>

#define AT(field) offsetof(lr_camera, field)

static const lr__camera_key keys[] = {
    {"image_plane_distance", LR__KEY_NUMBER, AT(image_plane_distance), NULL, 0,
     0, 0.0},
    {"focal_length", LR__KEY_NUMBER, AT(focal_length), NULL, 0, 0, 0.0},
    {"aperture", LR__KEY_NUMBER, AT(aperture), NULL, 0, 0, 0.0},
    {NULL, 0, 0, NULL, 0, 0, 0.0},
};

#define BAD(path, ...) lr__fail(err, LR_ERR_INVALID, path, __VA_ARGS__)

static lr_status validate(const lr_camera *cam, int active, lr_error *err)
{
    (void)active;
    lr_status st = lr__cam_check_length("camera.image_plane_distance",
                                        cam->image_plane_distance, 0, 1, err);
    if (st != LR_OK)
        return st;
    st = lr__cam_check_length("camera.focal_length", cam->focal_length, 0, 1,
                              err);
    if (st != LR_OK)
        return st;
    return lr__cam_check_length("camera.aperture", cam->aperture, 1, 0, err);
}

static void setup(lr__cam *c, const lr_camera *cam)
{
    /* The bracket is a square of side `aperture`: half side below. */
    c->radius = 0.5 * cam->aperture;
    c->shape = LR_APERTURE_SQUARE;
    c->base_di = cam->image_plane_distance;
    c->w = 1.0 / cam->focal_length;
    c->has_lens = c->radius > 0.0;
    c->w_base = 0.0;
    c->w_slope = c->w;
}

static lr_status focus_at(lr_camera *cam, double z, lr_error *err)
{
    if (!(z > cam->image_plane_distance))
        return BAD("camera.focus_on",
                   "camera.focus_on: the hit at depth %g is not beyond the "
                   "image plane (%g)",
                   z, cam->image_plane_distance);
    cam->focal_length = z - cam->image_plane_distance;
    return LR_OK;
}

/* Its rays all pass through e + off (1 + di / f): a square lens at the
 * eye, its radius grown by 1 + di w, focused at di + f. */
static void bound(const lr__cam *c, lr__lens_bound *b)
{
    lr__offset_lens_bound(c, b);
    b->R *= 1.0 + c->base_di * c->w;
    b->ws[0] = 1.0 / (c->base_di + 1.0 / c->w);
}

/* The light side (camera.h).  A ray from film point D (axial component
 * 1) and square-lens offset off starts at e + di D + off and runs along
 * D - w off, so it passes e + s off, s = 1 + di w, whatever D: the lens
 * point, uniform over the square grown by s as off is over the square.
 * Seen from there it is an offset lens of power w / s (its focus at
 * di + f): D = d / d.z + (w / s) (s off), and the same importance per
 * solid angle as the thin lens's (the film-to-direction map at a fixed
 * lens point is the same).  The ray itself starts di / d.z along unit d
 * past the lens point, on the image plane. */
static double grow(const lr__cam *c, double w)
{
    return 1.0 + c->base_di * w;
}

/* With colours that focus apart, each colour's rays (power w) cross at
 * their own lens point e + (1 + di w) off: traced one by one
 * (lr__cam_colour_point). */
static lr__v3 lens_point_w(const lr__cam *c, double w, const double u[2],
                           double *ox, double *oy)
{
    lr__offset_lens_point(c, u, ox, oy);
    *ox *= grow(c, w);
    *oy *= grow(c, w);
    return v3_madd(v3_madd(c->origin, c->right, *ox), c->up, *oy);
}

static lr__v3 lens_point(const lr__cam *c, const double u[2], double *ox,
                         double *oy)
{
    return lens_point_w(c, c->w, u, ox, oy);
}

static double film(const lr__cam *c, double ox, double oy, lr__v3 d, double *fx,
                   double *fy)
{
    return lr__offset_lens_film_w(c, c->w / grow(c, c->w), ox, oy, d, fx, fy);
}

/* Colour k (rgb) or of power w (spectral), from its own lens point. */
static double film_rgb(const lr__cam *c, int k, double ox, double oy, lr__v3 d,
                       double *fx, double *fy)
{
    double w = c->w_rgb[k];
    return lr__offset_lens_film_w(c, w / grow(c, w), ox, oy, d, fx, fy);
}

static double film_wl(const lr__cam *c, double w, double nm, double ox,
                      double oy, lr__v3 d, double *fx, double *fy)
{
    (void)nm;
    return lr__offset_lens_film_w(c, w / grow(c, w), ox, oy, d, fx, fy);
}

static double film_near(const lr__cam *c, lr__v3 d)
{
    /* With no aperture the rays start at the eye, as the pinhole's (the
     * light side had started them on the image plane all the same, and
     * lost a light nearer than it). */
    return c->has_lens ? c->base_di / v3_dot(d, c->forward) : 0.0;
}

const lr__camera_model lr__camera_bracket = {
    .name = "bracket",
    .keys = keys,
    .lens = 1,
    .validate = validate,
    .setup = setup,
    .ray = lr__offset_lens_ray,
    .rays16 = lr__offset_lens_rays16,
    .rays16_w = lr__offset_lens_rays16_w,
    .focus_at = focus_at,
    .bound = bound,
    .lens_point = lens_point,
    .film = film,
    .film_rgb = film_rgb,
    .film_wl = film_wl,
    .lens_point_w = lens_point_w,
    .film_near = film_near,
};
