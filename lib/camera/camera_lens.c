/*
 * camera_lens.c: a real lens, traced surface by surface at the ray's
 * wavelength (Kolb, Mitchell & Hanrahan 1995, "A realistic camera model
 * for computer graphics"; pbrt-v4's RealisticCamera for the exit-pupil
 * bounds).
 *
 * Frames.  The prescription's coordinates (prescription.h) have the
 * object toward -z; the camera looks along `forward`, so lens x = right,
 * lens y = up, lens z = -forward, and the sensor's centre, at lens z =
 * z_sensor, is the camera's `position`.  A lens forms an inverted image,
 * so film point (fx, fy) is sensor point (-x, -y) of the upright one: the
 * picture comes out the right way up, as a camera's does.
 *
 * A camera ray starts at a sensor point p, aims at a point q of the disk
 * that bounds the exit pupil for p's distance from the axis (on the
 * plane of the rear vertex, z_rear), and is traced toward the object;
 * it is lost where an element, the stop or total internal reflection
 * stops it.  Radiometry: the irradiance at p is E = int L cos^4(theta) /
 * Z^2 dA over the rear plane (Z = z_sensor - z_rear; Kolb et al. eq. 3),
 * so a sample drawn uniformly from the disk of area A weighs A cos^4 / Z^2,
 * divided by E for a white scene at the centre of the sensor: the
 * centre of a uniform scene renders at its radiance at every f-number,
 * as with the thin lens, and the corners darken by the lens's own
 * vignetting and cos^4.
 *
 * Focus (unit focusing): the whole lens moves by y from its infinity
 * position so that the plane at distance D from the sensor is sharp at
 * the d line.  With F, F' the focal points and f the focal length,
 * Newton's equation x x' = f^2 (x = object to F, x' = F' to image) with
 * x' = y and x = D - (z_F' - z_F) - y gives y^2 - (D - L) y + f^2 = 0,
 * L = z_F' - z_F: y = ((D - L) - sqrt((D - L)^2 - 4 f^2)) / 2, which needs
 * D >= L + 2f (the nearest focus).  The prescription's last thickness is
 * the infinity position (its designer's best focus), y is added to it.
 *
 * The model's other parts (camera_lens.h): the scalar and double rays
 * (`ray`, `rays_n`, `chief`) in lens_rays.c, the exit-pupil bounds in
 * lens_pupil.c, the light side and the ghosts in lens_light.c.
 */
#include "camera/camera_lens.h"
#include "optics/ghost.h"
#include "optics/lens.h"
#include "optics/lens_load.h"
#include "sampling/spectrum.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define AT(field) offsetof(lr_camera, field)

/* Indexed by lr_lens_coating. */
static const char *const coatings[] = {"prescription", "none", "mgf2", NULL};

_Static_assert(sizeof(lr_lens_coating) == sizeof(int),
               "LR__KEY_ENUM fields are stored as int");

static const lr__camera_key keys[] = {
    {"lens", LR__KEY_CUSTOM, AT(lens), NULL, 0, 0, 0.0},
    {"sensor_width_mm", LR__KEY_NUMBER, AT(sensor_width_mm), NULL, 0, 0, 0.0},
    {"scene_unit_mm", LR__KEY_NUMBER, AT(scene_unit_mm), NULL, 0, 0, 0.0},
    {"focus_distance", LR__KEY_NUMBER, AT(focus_distance), NULL, 0, 0, 0.0},
    {"f_number", LR__KEY_NUMBER, AT(f_number), NULL, 0, 0, 0.0},
    {"coating", LR__KEY_ENUM, AT(coating), coatings, 0, 0, 0.0},
    /* "auto", true or false: camera_json.c reads it, json_write.c writes
     * it (only when not "auto"). */
    {"ghosts", LR__KEY_CUSTOM, AT(ghosts), NULL, 0, 0, 0.0},
    {NULL, 0, 0, NULL, 0, 0, 0.0},
};

#define BAD(path, ...) lr__fail(err, LR_ERR_INVALID, path, __VA_ARGS__)

/* The wavelengths of the rgb mode's channels: near the peaks of the
 * linear-sRGB colour-matching functions (spectrum.c). */
static const double rgb_nm[3] = {610.0, 550.0, 465.0};

/* The nearest focus, in mm from the sensor (top of file). */
static double nearest_mm(const lr_lens *L)
{
    double Ld = L->first.z_Fp - L->first.z_F;
    return Ld + 2.0 * L->first.efl;
}

static lr_status validate(const lr_camera *cam, int active, lr_error *err)
{
    lr_status st = lr__cam_check_length("camera.sensor_width_mm",
                                        cam->sensor_width_mm, 0, 0, err);
    if (st != LR_OK)
        return st;
    /* The film's float arithmetic (film_band) loses a sensor narrower
     * than this; a nanometre is no camera's. */
    if (cam->sensor_width_mm < 1e-6)
        return BAD("camera.sensor_width_mm",
                   "camera.sensor_width_mm must be at least 1e-6, got %g",
                   cam->sensor_width_mm);
    st = lr__cam_check_length("camera.scene_unit_mm", cam->scene_unit_mm, 0, 0,
                              err);
    if (st != LR_OK)
        return st;
    /* As every other enum (a coating of 9 rendered, and was written
     * back "unknown", which the parser refuses). */
    if (cam->coating != LR_COATING_PRESCRIPTION &&
        cam->coating != LR_COATING_NONE && cam->coating != LR_COATING_MGF2)
        return BAD("camera.coating",
                   "camera.coating is not a known coating "
                   "(%d)",
                   (int)cam->coating);
    if (cam->ghosts != LR_GHOSTS_AUTO && cam->ghosts != LR_GHOSTS_ON &&
        cam->ghosts != LR_GHOSTS_OFF)
        return BAD("camera.ghosts", "camera.ghosts is not a known setting (%d)",
                   (int)cam->ghosts);
    if (!active)
        return LR_OK;
    if (cam->lens == NULL)
        return BAD("camera.lens",
                   "camera.lens must name a lens for the \"lens\" model");
    /* A bound of our choosing, checked: test_every_lens_closed_down
     * renders every shipped lens at f/128. */
    if (cam->f_number > 128.0)
        return BAD("camera.f_number",
                   "camera.f_number must be at most 128 for a real lens, "
                   "got %g",
                   cam->f_number);
    /* Dispersion amplified about the d line must leave every glass
     * denser than air at the wavelengths traced (rgb's 465 to 610 nm,
     * spectral's 380 to 780): past that the "glass" bends light the
     * wrong way, and a white scene rendered values up to 4e13 (an
     * independent check). */
    if (cam->chromatic.mode != LR_CHROMATIC_OFF &&
        cam->chromatic.amplify > 1.0) {
        const lr__rx *rx = &cam->lens->rx;
        double nd[LR__RX_MAX_SURFACES], nx[LR__RX_MAX_SURFACES],
            most = INFINITY;
        lr__rx_indices(rx, LR__NM_d, nd);
        int rgb = cam->chromatic.mode == LR_CHROMATIC_RGB;
        for (int e = 0; e < 2; e++) {
            double nm = rgb ? rgb_nm[e ? 0 : 2]
                        : e ? LR__LAMBDA_MAX
                            : LR__LAMBDA_MIN;
            lr__rx_indices(rx, nm, nx);
            for (int i = 0; i < rx->n; i++)
                if (nx[i] < nd[i] && nd[i] > 1.0)
                    most = fmin(most, (nd[i] - 1.0) / (nd[i] - nx[i]));
        }
        if (cam->chromatic.amplify >= most)
            return BAD("camera.chromatic.amplify",
                       "camera.chromatic.amplify %g makes a glass of this "
                       "lens less dense than air at the edge of the visible "
                       "range: below %.4g for this lens",
                       cam->chromatic.amplify, most);
    }
    double D = cam->focus_distance * cam->scene_unit_mm;
    double near = nearest_mm(cam->lens);
    if (!(D > near * (1.0 + 1e-9)))
        return BAD("camera.focus_distance",
                   "camera.focus_distance (%g, %g mm from the sensor) is "
                   "nearer than this lens focuses: at least %g mm",
                   cam->focus_distance, D, near);
    return LR_OK;
}

/* Indices after each surface at `nm`, the dispersion scaled by amplify
 * about the d line's indices. */
void lr__lens_indices(const lr__cam *c, double nm, double *n)
{
    const lr__rx *rx = &c->lens.L->rx;
    lr__rx_indices(rx, nm, n);
    double a = c->chroma.amplify;
    if (a != 1.0)
        for (int i = 0; i < rx->n; i++)
            n[i] = c->lens.n_ref[i] + a * (n[i] - c->lens.n_ref[i]);
}

/* The widest axial parallel ray that gets through with the stop scaled
 * by s, at the d line (bisection: rays below it pass). */
static double axial_reach(const lr_lens *L, const double *n, double s)
{
    double lo = 0.0, hi = L->rx.s[0].semi_aperture;
    for (int it = 0; it < 40; it++) {
        double mid = 0.5 * (lo + hi);
        double o[3] = {0, mid, -1.0}, d[3] = {0, 0, 1};
        if (lr__rx_trace_n(&L->rx, L->z, n, s, 1, o, d))
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* ---- setup ------------------------------------------------------------------ */

static void setup(lr__cam *c, const lr_camera *cam)
{
    lr__lens_cam *lc = &c->lens;
    const lr_lens *L = cam->lens;
    lc->L = L;
    lc->blur = NULL;
    c->has_lens = 1;
    c->weighted = 1;
    c->chroma_fixed = 1;
    lc->mm = 1.0 / cam->scene_unit_mm;
    lc->sensor_w = cam->sensor_width_mm;
    lc->sensor_h = cam->sensor_width_mm * c->height / c->width;
    lc->pupil_rmax = 0.5 * hypot(lc->sensor_w, lc->sensor_h);

    /* Focus (top of file). */
    double D = cam->focus_distance * cam->scene_unit_mm;
    double f = L->first.efl, Ld = L->first.z_Fp - L->first.z_F;
    double disc = (D - Ld) * (D - Ld) - 4.0 * f * f;
    double y = 0.5 * ((D - Ld) - sqrt(disc > 0.0 ? disc : 0.0));
    lc->z_sensor = L->z[L->rx.n] + y;
    /* The focus power for the light side's estimate (lens_thin_equiv);
     * the lens model's own rays do not read it. */
    c->w = 1.0 / cam->focus_distance;
    lc->z_rear = L->z[L->rx.n - 1];

    /* The frame's field of view, for whoever reads it: the sensor seen
     * from the rear principal point. */
    c->half_h = 0.5 * lc->sensor_h / (f + y);
    c->half_w = 0.5 * lc->sensor_w / (f + y);

    lr__rx_indices(&L->rx, c->nm_ref, lc->n_ref);
    for (int k = 0; k < 3; k++) {
        lc->nm_rgb[k] = rgb_nm[k];
        lr__lens_indices(c, rgb_nm[k], lc->n_rgb[k]);
    }

    /* The stop: closed until the widest axial ray is efl / (2 N) high. */
    lc->stop_scale = 1.0;
    if (cam->f_number > 0.0) {
        double want = f / (2.0 * cam->f_number);
        if (axial_reach(L, lc->n_ref, 1.0) > want) {
            double lo = 0.0, hi = 1.0;
            for (int it = 0; it < 40; it++) {
                double mid = 0.5 * (lo + hi);
                if (axial_reach(L, lc->n_ref, mid) > want)
                    hi = mid;
                else
                    lo = mid;
            }
            lc->stop_scale = hi;
        }
    }
    int colours = 0;
    c->chroma_active = 0;
    if (c->chroma.mode != LR_CHROMATIC_OFF && L->dispersive &&
        c->chroma.amplify != 0.0) {
        c->chroma_active = 1;
        colours = c->chroma.mode == LR_CHROMATIC_RGB ? 1 : 2;
    }
    /* What each surface passes (transmit.h), at the wavelengths the
     * camera traces with fixed indices. */
    lc->coat = lr__coating_override((int)cam->coating);
    lc->ghosts = (int)cam->ghosts;
    lc->n_ghost = L->rx.n * (L->rx.n - 1) / 2;
    lr__ttab_fill(&lc->t_ref, &L->rx, lc->n_ref, c->nm_ref, lc->coat);
    lc->t_rgb_ok = colours == 1;
    for (int k = 0; k < 3 && lc->t_rgb_ok; k++)
        lr__ttab_fill(&lc->t_rgb[k], &L->rx, lc->n_rgb[k], rgb_nm[k], lc->coat);
    if (lc->ghosts != LR_GHOSTS_OFF && c->chroma.mode != LR_CHROMATIC_OFF)
        for (int k = 0; k < 3; k++) {
            lr__rx_indices(&L->rx, rgb_nm[k], lc->g_n[k]);
            lr__ttab_fill(&lc->g_tab[k], &L->rx, lc->g_n[k], rgb_nm[k],
                          lc->coat);
        }
    lc->r_cut = INFINITY;
    lr__lens_pupils(c, colours);
    /* A sensor far larger than the lens's image circle: the table's radii,
     * spread over the sensor's half diagonal, left the circle an interval
     * or two, and its bounds were too coarse to hold the rays (a 3000 mm
     * sensor behind the 22 mm wide angle lost all but 1e-3 of its light,
     * and the CLI warned that the circle missed the film).  While the
     * light reaches no more than the table's first eighth, the table is
     * drawn again out to two entries past the last that passes light,
     * and the film beyond is stopped (the entries past it passed none).
     * (Not for less: a finer table at the circle's rim, where the pupil
     * changes fastest, held fewer of the 170-degree lens's rays.) */
    for (int it = 0; it < 4; it++) {
        int last = -1;
        for (int k = 0; k <= LR__PUPIL_N; k++)
            if (lc->pupil[k].rad > 0.0)
                last = k;
        if (last < 0 || last + 2 > LR__PUPIL_N / 8)
            break;
        lc->pupil_rmax = lc->pupil_rmax * (last + 2) / LR__PUPIL_N;
        lc->r_cut = lc->pupil_rmax;
        lr__lens_pupils(c, colours);
    }
    for (int k = 0; k < LR__PUPIL_N; k++) {
        lr__pupil a = lr__lens_pupil_at(lc, lc->pupil_rmax * k / LR__PUPIL_N);
        lc->band_cx[k] = (float)a.cx;
        lc->band_dcx[k] = (float)(lc->pupil[k + 1].cx - lc->pupil[k].cx);
        lc->band_rad[k] = (float)a.rad;
        lc->band_hx[k] = (float)a.hx;
        lc->band_hy[k] = (float)a.hy;
    }
}

/* ---- rays ----------------------------------------------------------------------- */

/* Film point (fx, fy) on the sensor (lr__lens_sensor_at's, in float: iw, ih the
 * frame's inverse size, sw, sh the sensor's) and its interval of the
 * pupil table (kr: intervals per mm): the interval, with the point's
 * radius r and its place f in [0, 1) along the interval. */
static inline __attribute__((always_inline)) int
film_band(float fx, float fy, float iw, float ih, float sw, float sh, float kr,
          float *xs, float *ys, float *r, float *f)
{
    *xs = (0.5f - fx * iw) * sw, *ys = (fy * ih - 0.5f) * sh;
    *r = sqrtf(*xs * *xs + *ys * *ys);
    /* Never outside the table, whatever the floats: a sensor of 1e-37
     * mm made t NaN, (int)t INT_MIN, and the read crashed the daemon. */
    float t = *r * kr;
    t = t >= 0.0f ? t : 0.0f;
    int k = t < (float)(LR__PUPIL_N - 1) ? (int)t : LR__PUPIL_N - 1;
    *f = t - (float)k;
    return k;
}

/* A packet's rays from the sensor to the rear element, for
 * lens_rays16_n: o, d in the lens's frame, the radiometric weight w, and
 * alive[i] = 0 where the pupil's bounds are empty or i >= n.  Loops over
 * 16 lanes into the caller's own arrays, which GCC vectorises (through
 * rows of a larger array it did not: 5% of a run became 18%). */
static inline __attribute__((always_inline)) void
lens_start16(const lr__cam *c, int n, const float *fx, const float *fy,
             const float *lu, const float *lv, float (*o)[16], float (*d)[16],
             float *w, int *alive)
{
    const lr__lens_cam *lc = &c->lens;
    float lx[16], ly[16];
    lr__aperture_sample16(LR_APERTURE_DISK, 0, 0.0, 1.0, n, lu, lv, lx, ly);
    const float iw = (float)(1.0 / c->width), ih = (float)(1.0 / c->height);
    const float sw = (float)lc->sensor_w, sh = (float)lc->sensor_h;
    const float kr = (float)(LR__PUPIL_N / lc->pupil_rmax);
    const float rcut = (float)lc->r_cut;
    const float zs = (float)lc->z_sensor,
                dz = (float)(lc->z_rear - lc->z_sensor);
    const float wk = (float)(1.0 /
                             ((lc->z_rear - lc->z_sensor) *
                              (lc->z_rear - lc->z_sensor)) *
                             lc->inv_E0);
    const float pi = (float)M_PI;
    for (int i = 0; i < 16; i++) {
        float xs, ys, r, f;
        int k = film_band(fx[i], fy[i], iw, ih, sw, sh, kr, &xs, &ys, &r, &f);
        /* lr__lens_pupil_at's bounds, from the interval's table. */
        float cx = lc->band_cx[k] + f * lc->band_dcx[k];
        float rad = lc->band_rad[k], hx = lc->band_hx[k], hy = lc->band_hy[k];
        float disk = pi * rad * rad, rect = 4.0f * hx * hy;
        int use_disk = disk <= rect;
        float a = use_disk ? rad * lx[i] : (2.0f * lu[i] - 1.0f) * hx;
        float b = use_disk ? rad * ly[i] : (2.0f * lv[i] - 1.0f) * hy;
        float area = use_disk ? disk : rect;
        a += cx;
        float ir = r > 0.0f ? 1.0f / r : 0.0f;
        float ex = r > 0.0f ? xs * ir : 1.0f, ey = ys * ir;
        float dx = ex * a - ey * b - xs, dy = ey * a + ex * b - ys;
        float inv = 1.0f / sqrtf(dx * dx + dy * dy + dz * dz);
        float ct = -dz * inv;
        o[0][i] = xs, o[1][i] = ys, o[2][i] = zs;
        d[0][i] = dx * inv, d[1][i] = dy * inv, d[2][i] = dz * inv;
        w[i] = wk * area * ct * ct * ct * ct;
        alive[i] = (i < n) & (area > 0.0f) & !(r > rcut);
    }
}

/* lens_start16 for a block whose plan skips the lens (lens_blur.c's
 * bound: the spot is under a quarter pixel): each lane's chief ray,
 * through the centre of its pupil bounds as lr__lens_chief_ray's, weighted by
 * the pupil's mean sample weight over the chief ray's transmittance,
 * which the glass multiplies back in (so a uniform scene renders as the
 * lens's mean: its vignetting, not noise). */
static inline __attribute__((always_inline)) void
chief_start16(const lr__cam *c, const lr__lens_blur *bl, int n, const float *fx,
              const float *fy, float (*o)[16], float (*d)[16], float *w,
              int *alive)
{
    const lr__lens_cam *lc = &c->lens;
    const float iw = (float)(1.0 / c->width), ih = (float)(1.0 / c->height);
    const float sw = (float)lc->sensor_w, sh = (float)lc->sensor_h;
    const float kr = (float)(LR__PUPIL_N / lc->pupil_rmax);
    const float rcut = (float)lc->r_cut;
    const float zs = (float)lc->z_sensor,
                dz = (float)(lc->z_rear - lc->z_sensor);
    for (int i = 0; i < 16; i++) {
        float xs, ys, r, f;
        int k = film_band(fx[i], fy[i], iw, ih, sw, sh, kr, &xs, &ys, &r, &f);
        float cx = lc->band_cx[k] + f * lc->band_dcx[k];
        float ir = r > 0.0f ? 1.0f / r : 0.0f;
        float ex = r > 0.0f ? xs * ir : 1.0f, ey = ys * ir;
        float dx = ex * cx - xs, dy = ey * cx - ys;
        float inv = 1.0f / sqrtf(dx * dx + dy * dy + dz * dz);
        o[0][i] = xs, o[1][i] = ys, o[2][i] = zs;
        d[0][i] = dx * inv, d[1][i] = dy * inv, d[2][i] = dz * inv;
        w[i] = lr__lens_blur_chief_w(bl, k, f);
        alive[i] = (i < n) & (w[i] > 0.0f) & !(r > rcut);
    }
}

/* chief_start16's rays out of the front, from the blur table's chief-ray
 * table (lens_chief.c) instead of the glass: at film radius r in the
 * direction e, the point (rho e, z) and direction (u e, w) interpolated
 * between the two nodes around r, the weight the mean sample weight over
 * T times the table's T.  Returns 0, and leaves the packet to the glass,
 * where a lane's chief ray counts (weight above 0) and its interval is
 * not exact (a node the lens stops, or the fit outside its tolerance:
 * lens_chief.c). */
static inline __attribute__((always_inline)) int
chief_table16(const lr__cam *c, const lr__lens_blur *bl, int n, const float *fx,
              const float *fy, float (*o)[16], float (*d)[16], float *w,
              int *alive)
{
    const lr__lens_cam *lc = &c->lens;
    const lr__lens_chief *t = lr__lens_blur_chief(bl);
    const float iw = (float)(1.0 / c->width), ih = (float)(1.0 / c->height);
    const float sw = (float)lc->sensor_w, sh = (float)lc->sensor_h;
    const float kr = (float)(LR__PUPIL_N / lc->pupil_rmax);
    const float rcut = (float)lc->r_cut;
    int bad = 0;
    for (int i = 0; i < 16; i++) {
        float xs, ys, r, f;
        int k = film_band(fx[i], fy[i], iw, ih, sw, sh, kr, &xs, &ys, &r, &f);
        float s = f * (float)LR__CHIEF_SUB;
        int j = (int)s;
        j = j < LR__CHIEF_SUB - 1 ? j : LR__CHIEF_SUB - 1;
        float g = s - (float)j;
        int a = k * LR__CHIEF_SUB + j;
        a = a > 0 ? a : 0; /* a lane past n may hold anything */
        float ir = r > 0.0f ? 1.0f / r : 0.0f;
        float ex = r > 0.0f ? xs * ir : 1.0f, ey = ys * ir;
        float rho = t->rho[a] + g * (t->rho[a + 1] - t->rho[a]);
        float u = t->u[a] + g * (t->u[a + 1] - t->u[a]);
        o[0][i] = rho * ex, o[1][i] = rho * ey;
        o[2][i] = t->z[a] + g * (t->z[a + 1] - t->z[a]);
        d[0][i] = u * ex, d[1][i] = u * ey;
        d[2][i] = t->w[a] + g * (t->w[a + 1] - t->w[a]);
        float cw = lr__lens_blur_chief_w(bl, k, f);
        w[i] = cw * (t->T[a] + g * (t->T[a + 1] - t->T[a]));
        int live = (i < n) & (cw > 0.0f) & !(r > rcut);
        bad |= live & !t->exact[a];
        alive[i] = live;
    }
    return !bad;
}

/* The packet's rays out of the front element (o, d from the glass) into
 * the scene, for Embree; wt[] their weights. */
static inline __attribute__((always_inline)) void
lens_finish16(const lr__cam *c, const float (*o)[16], const float (*d)[16],
              const float *w, const int *alive, struct RTCRayHit16 *rh,
              float *wt)
{
    const lr__lens_cam *lc = &c->lens;
    const float zs = (float)lc->z_sensor;
    const float R[3] = {(float)c->right.x, (float)c->right.y,
                        (float)c->right.z};
    const float U[3] = {(float)c->up.x, (float)c->up.y, (float)c->up.z};
    const float F[3] = {(float)c->forward.x, (float)c->forward.y,
                        (float)c->forward.z};
    const float E[3] = {(float)c->origin.x, (float)c->origin.y,
                        (float)c->origin.z};
    const float mm = (float)lc->mm;
    struct RTCRay16 *ray = &rh->ray;
    float *org[3] = {ray->org_x, ray->org_y, ray->org_z};
    float *dir[3] = {ray->dir_x, ray->dir_y, ray->dir_z};
    for (int a = 0; a < 3; a++)
        for (int i = 0; i < 16; i++) {
            float zo = o[2][i] - zs;
            float p = R[a] * o[0][i] + U[a] * o[1][i] - F[a] * zo;
            float v = R[a] * d[0][i] + U[a] * d[1][i] - F[a] * d[2][i];
            org[a][i] = alive[i] ? E[a] + p * mm : E[a];
            dir[a][i] = alive[i] ? v : F[a];
        }
    /* The glass left the directions unit up to rounding (rx_trace.c):
     * once here, exactly unit for the integrator. */
    for (int i = 0; i < 16; i++) {
        float inv = 1.0f / sqrtf(dir[0][i] * dir[0][i] + dir[1][i] * dir[1][i] +
                                 dir[2][i] * dir[2][i]);
        dir[0][i] *= inv, dir[1][i] *= inv, dir[2][i] *= inv;
    }
    for (int i = 0; i < 16; i++) {
        wt[i] = alive[i] ? w[i] : 0.0f;
        lr__ray16_open(rh, i);
        /* A ray the lens stopped is inactive for Embree (tnear > tfar):
         * not traced, it shades as a miss, weighted 0. */
        rh->ray.tfar[i] = alive[i] ? INFINITY : -INFINITY;
    }
}

/* Sixteen rays a packet at c->nm_ref, in float from end to end
 * (lens_rays.c's lens_start and lr__lens_ray's arithmetic lane by lane,
 * the disk from the packet aperture map, the glass from
 * lr__rx_trace16f): the same distribution as lr__lens_ray's, not the
 * same bits.  Up to four packets go
 * through the glass together (rx_trace16f.c says why); each lane's ray is
 * the one its packet would have alone. */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
lens_rays16_n(const lr__cam *c, int use_lens, int np, const int *ns,
              const float (*fx)[16], const float (*fy)[16],
              const float (*lu)[16], const float (*lv)[16],
              struct RTCRayHit16 *rh, float (*wt)[16])
{
    /* Without the lens (the plan's bound allows it), chief rays: from
     * the blur table's chief-ray table, or through the glass where an
     * interval of it is not exact. */
    const lr__lens_blur *bl = use_lens ? NULL
                                       : __atomic_load_n(&c->lens.blur,
                                                         __ATOMIC_ACQUIRE);
    enum { MAXP = LR__RX_LANES / 16 };
    if (np > MAXP) {
        lens_rays16_n(c, use_lens, MAXP, ns, fx, fy, lu, lv, rh, wt);
        lens_rays16_n(c, use_lens, np - MAXP, ns + MAXP, fx + MAXP, fy + MAXP,
                      lu + MAXP, lv + MAXP, rh + MAXP, wt + MAXP);
        return;
    }
    float o[3][LR__RX_LANES], d[3][LR__RX_LANES], w[LR__RX_LANES];
    int alive[LR__RX_LANES], at[MAXP], ng = 0;
    for (int p = 0; p < np; p++) {
        float o16[3][16], d16[3][16], w16[16];
        int alive16[16];
        if (bl != NULL &&
            chief_table16(c, bl, ns[p], fx[p], fy[p], o16, d16, w16, alive16)) {
            /* Out of the front already: no glass. */
            lens_finish16(c, (const float(*)[16])o16, (const float(*)[16])d16,
                          w16, alive16, &rh[p], wt[p]);
            continue;
        }
        /* The packets for the glass, packed in its lanes. */
        int q = ng++;
        at[q] = p;
        if (bl != NULL)
            chief_start16(c, bl, ns[p], fx[p], fy[p], o16, d16, w + 16 * q,
                          alive + 16 * q);
        else
            lens_start16(c, ns[p], fx[p], fy[p], lu[p], lv[p], o16, d16,
                         w + 16 * q, alive + 16 * q);
        for (int a = 0; a < 3; a++) {
            memcpy(&o[a][16 * q], o16[a], sizeof o16[a]);
            memcpy(&d[a][16 * q], d16[a], sizeof d16[a]);
        }
    }
    if (ng == 0)
        return;
    lr__rx_trace16f(&c->lens.L->rx, c->lens.L->z, c->lens.n_ref,
                    c->lens.stop_scale, 16 * ng, o, d, alive, &c->lens.t_ref,
                    w);
    for (int q = 0; q < ng; q++) {
        float o16[3][16], d16[3][16];
        for (int a = 0; a < 3; a++) {
            memcpy(o16[a], &o[a][16 * q], sizeof o16[a]);
            memcpy(d16[a], &d[a][16 * q], sizeof d16[a]);
        }
        lens_finish16(c, (const float(*)[16])o16, (const float(*)[16])d16,
                      w + 16 * q, alive + 16 * q, &rh[at[q]], wt[at[q]]);
    }
}

static void lens_rays16(const lr__cam *c, int use_lens, int n, const float *fx,
                        const float *fy, const float *lu, const float *lv,
                        struct RTCRayHit16 *rh, float *wt)
{
    lens_rays16_n(c, use_lens, 1, &n, (const float(*)[16])fx,
                  (const float(*)[16])fy, (const float(*)[16])lu,
                  (const float(*)[16])lv, rh, (float(*)[16])wt);
}

/* The model's colour_w16: at each lane's film radius, the blur table's
 * shares (the channels' pupil mean weights over the reference's, which
 * the packet's ray carries).  A share is a mean over the pupil, where a
 * ray of each colour would carry its own transmittance and vignetting:
 * the expected pixel is right wherever the light reaching the pupil is
 * uniform (in focus, or background: a chief-ray block's), and where a
 * lens block's light varies across the pupil the colours' T differ from
 * their mean by a small fraction of itself (docs/plan-lens.md). */
static void lens_colour_w16(const lr__cam *c, int n, const float *fx,
                            const float *fy, float (*k)[16])
{
    const lr__lens_cam *lc = &c->lens;
    const lr__lens_blur *bl = __atomic_load_n(&lc->blur, __ATOMIC_ACQUIRE);
    const float iw = (float)(1.0 / c->width), ih = (float)(1.0 / c->height);
    const float sw = (float)lc->sensor_w, sh = (float)lc->sensor_h;
    const float kr = (float)(LR__PUPIL_N / lc->pupil_rmax);
    for (int i = 0; i < 16; i++) {
        float xs, ys, r, f, s[3] = {1.0f, 1.0f, 1.0f};
        int b = film_band(fx[i], fy[i], iw, ih, sw, sh, kr, &xs, &ys, &r, &f);
        if (bl != NULL && i < n)
            lr__lens_blur_share(bl, b, f, s);
        k[0][i] = s[0], k[1][i] = s[1], k[2][i] = s[2];
    }
}

static lr_status focus_at(lr_camera *cam, double z, lr_error *err)
{
    if (cam->lens != NULL &&
        !(z * cam->scene_unit_mm > nearest_mm(cam->lens) * (1.0 + 1e-9)))
        return BAD("camera.focus_on",
                   "camera.focus_on: the point is %g mm from the sensor, "
                   "nearer than this lens focuses (at least %g mm)",
                   z * cam->scene_unit_mm, nearest_mm(cam->lens));
    cam->focus_distance = z;
    return LR_OK;
}

const lr__camera_model lr__camera_lens = {
    .name = "lens",
    .keys = keys,
    .lens = 1,
    .validate = validate,
    .setup = setup,
    .ray = lr__lens_ray,
    .rays_n = lr__lens_rays_n,
    .rays16 = lens_rays16,
    .rays16_n = lens_rays16_n,
    .colour_w16 = lens_colour_w16,
    .chief = lr__lens_chief_ray,
    .focus_at = focus_at,
    .bound = NULL,
    .lens_point = lr__lens_point,
    .film = lr__lens_film,
    .film_rgb = lr__lens_film_rgb,
    .film_wl = lr__lens_film_wl,
    .thin_equiv = lr__lens_thin_equiv,
    .light_ok = lr__lens_light_ok,
    .blur = lr__lens_blur_get,
    .ghost_paths = lr__lens_ghost_paths,
    .ghost_film = lr__lens_ghost_film,
    .ghost_film_n = lr__lens_ghost_film_n,
    .ghost_disk = lr__lens_ghost_disk,
    .lens_at = lr__lens_at,
};
