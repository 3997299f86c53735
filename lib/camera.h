/*
 * camera.h: turns a film position, a lens sample and a focus into a ray.
 * The camera knows nothing of how pixels are stored (it sees continuous
 * film coordinates) and nothing of samplers (it is handed numbers).
 *
 * The pinhole, the thin lens and the paper's bracket share one form.  Let
 * d be the unit chief ray through the film point from the eye e, and
 * cos = d . forward.  A lens offset `off` (in the lens plane spanned by
 * right and up) gives the ray
 *
 *     origin    = base + off
 *     direction = normalise(d - off * cos * w)
 *
 * which passes through the point of d at axial distance 1/w from `base`'s
 * plane: the focal point.  The thin lens has base = e and w = 1 /
 * focus_distance (Kolb, Mitchell & Hanrahan 1995; pbrt's
 * PerspectiveCamera).  The bracket has base = the pixel's point on the
 * image plane, X = e + d di / cos, and w = 1 / f, so its rays pass through
 * the paper's focal point p = e + (di + f) dp / di d (Lee 2007, Kuang &
 * Lee 2018).  Chromatic aberration changes only w, per channel or per
 * wavelength; w may be 0 (focus at infinity) or negative.
 */
#ifndef LR_CAMERA_H
#define LR_CAMERA_H

#include "internal.h"
#include "vec.h"

typedef struct lr__cam {
    lr_camera_model model;
    lr__v3 origin;
    lr__v3 forward, right, up; /* unit, right-handed */
    double half_h;             /* tan(fov/2): image plane half height at 1 */
    double half_w;             /* half_h * width / height */
    double width, height;      /* film size in pixels (the full frame) */

    int has_lens;              /* 0: pinhole rays, whatever the model */
    double radius;             /* thin lens radius; bracket half side */
    lr_aperture_shape shape;
    int blades;
    double rotation;           /* radians */
    double ratio;
    double di;                 /* bracket: image plane distance */

    double w;                  /* focus power without aberration */
    /* Chromatic aberration: power as a function of the index n is
     * w(n) = w_base + w_slope * power_scale(n), see lr__cam_power. */
    lr_chromatic chroma;
    double n_ref;              /* reference index (green, or n_d) */
    double w_base, w_slope;
    double w_rgb[3];           /* rgb mode: per channel */
    int chroma_active;         /* 0 when every channel focuses alike */
} lr__cam;

/* Prepares `c` for a width x height film; `cam` must have passed
 * lr_camera_validate and its autofocus must have been resolved. */
void lr__cam_init(lr__cam *c, const lr_camera *cam, int width, int height);

/* The pinhole ray through film point (fx, fy), in pixels from the image's
 * top-left corner (pixel (x, y) covers [x, x+1) x [y, y+1)).  `dir` is
 * unit length. */
void lr__cam_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                 lr__v3 *dir);

/* The ray through film point (fx, fy) and lens sample u in [0, 1)^2 with
 * focus power w.  Without a lens it is exactly lr__cam_ray. */
void lr__cam_lens_ray(const lr__cam *c, double fx, double fy,
                      const double u[2], double w, lr__v3 *org, lr__v3 *dir);

/* Focus power for light of wavelength `nm` (spectral mode). */
double lr__cam_power_at(const lr__cam *c, double nm);

/* Distance (along the view axis, from the eye) of the plane in focus for
 * focus power w: for reports and tests. */
double lr__cam_focus_depth(const lr__cam *c, double w);

#endif
