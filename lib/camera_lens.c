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
 */
#include "camera.h"
#include "lens.h"
#include "lens_load.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define AT(field) offsetof(lr_camera, field)

static const lr__camera_key keys[] = {
    {"lens", LR__KEY_CUSTOM, AT(lens), NULL, 0, 0},
    {"sensor_width_mm", LR__KEY_NUMBER, AT(sensor_width_mm), NULL, 0, 0},
    {"scene_unit_mm", LR__KEY_NUMBER, AT(scene_unit_mm), NULL, 0, 0},
    {"focus_distance", LR__KEY_NUMBER, AT(focus_distance), NULL, 0, 0},
    {"f_number", LR__KEY_NUMBER, AT(f_number), NULL, 0, 0},
    {NULL, 0, 0, NULL, 0, 0},
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
    lr_status st;
    if ((st = lr__cam_check_length("camera.sensor_width_mm",
                                   cam->sensor_width_mm, 0, 0, err)) != LR_OK ||
        (st = lr__cam_check_length("camera.scene_unit_mm", cam->scene_unit_mm,
                                   0, 0, err)) != LR_OK)
        return st;
    if (!active)
        return LR_OK;
    if (cam->lens == NULL)
        return BAD("camera.lens",
                   "camera.lens must name a lens for the \"lens\" model");
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
static void indices(const lr__cam *c, double nm, double *n)
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

/* ---- exit-pupil bounds ----------------------------------------------------- */

#define G_COARSE 24
#define G_FINE 96

typedef struct pupil_job {
    const lr__cam *c;
    const double *nsets[4];
    int n_sets;
} pupil_job;

/* Traces from sensor point (r, 0) to rear-plane point (x, y) with every
 * index set; 1 if any gets through.  *cos4 gets cos^4 of the first. */
static int passes(const pupil_job *j, double r, double x, double y,
                  double *cos4)
{
    const lr__lens_cam *lc = &j->c->lens;
    const lr_lens *L = lc->L;
    double dx = x - r, dy = y, dz = lc->z_rear - lc->z_sensor;
    double len = sqrt(dx * dx + dy * dy + dz * dz);
    double ct = -dz / len;
    *cos4 = ct * ct * ct * ct;
    for (int k = 0; k < j->n_sets; k++) {
        double o[3] = {r, 0, lc->z_sensor}, d[3] = {dx / len, dy / len,
                                                    dz / len};
        if (lr__rx_trace_n(&L->rx, L->z, j->nsets[k], lc->stop_scale, 0, o,
                           d))
            return 1;
    }
    return 0;
}

/* The bound of interval [ra, rb] of film radii: a disk centred at
 * (*cx, 0) of radius *rad.  For ra = 0 also E0 (on-axis irradiance
 * integral, white scene). */
static void pupil_interval(const pupil_job *j, double ra, double rb,
                           double *cx, double *rad, double *E0)
{
    const lr__lens_cam *lc = &j->c->lens;
    const lr_lens *L = lc->L;
    double S = 1.5 * L->rx.s[L->rx.n - 1].semi_aperture;
    double film[2] = {ra, rb};
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    double cell = 2.0 * S / G_COARSE, c4;
    for (int f = 0; f < 2; f++)
        for (int iy = 0; iy < G_COARSE; iy++)
            for (int ix = 0; ix < G_COARSE; ix++) {
                double x = -S + (ix + 0.5) * cell, y = -S + (iy + 0.5) * cell;
                if (passes(j, film[f], x, y, &c4)) {
                    x0 = fmin(x0, x), x1 = fmax(x1, x);
                    y0 = fmin(y0, y), y1 = fmax(y1, y);
                }
            }
    *cx = 0.0, *rad = 0.0;
    if (E0 != NULL)
        *E0 = 0.0;
    if (!(x0 <= x1))
        return; /* nothing gets through */
    x0 -= cell, x1 += cell, y0 -= cell, y1 += cell;
    double cxw = (x1 - x0) / G_FINE, cyw = (y1 - y0) / G_FINE;
    double fx0 = INFINITY, fx1 = -INFINITY;
    /* Two passes over the fine grid: the centre from the extent, then
     * the radius about it.  The grid points that pass are kept. */
    double *pts = malloc(sizeof *pts * 2 * G_FINE * G_FINE * 2);
    int np = 0;
    double e0 = 0.0, Z = lc->z_sensor - lc->z_rear;
    for (int f = 0; f < 2; f++)
        for (int iy = 0; iy < G_FINE; iy++)
            for (int ix = 0; ix < G_FINE; ix++) {
                double x = x0 + (ix + 0.5) * cxw, y = y0 + (iy + 0.5) * cyw;
                if (!passes(j, film[f], x, y, &c4))
                    continue;
                fx0 = fmin(fx0, x), fx1 = fmax(fx1, x);
                if (pts != NULL) {
                    pts[2 * np] = x, pts[2 * np + 1] = y;
                    np++;
                }
                if (f == 0 && E0 != NULL)
                    e0 += c4 / (Z * Z);
            }
    if (E0 != NULL)
        *E0 = e0 * cxw * cyw;
    if (!(fx0 <= fx1)) { /* too thin for the fine grid: the coarse box */
        *cx = 0.5 * (x0 + x1);
        *rad = 0.5 * hypot(x1 - x0, y1 - y0);
        free(pts);
        return;
    }
    *cx = 0.5 * (fx0 + fx1);
    double m = 0.0;
    if (pts != NULL) {
        for (int i = 0; i < np; i++)
            m = fmax(m, hypot(pts[2 * i] - *cx, pts[2 * i + 1]));
    } else {
        m = 0.5 * hypot(x1 - x0, y1 - y0);
    }
    free(pts);
    /* A grid point's cell reaches half a diagonal beyond it; the pupil
     * also moves between the interval's ends: one and a half cells. */
    *rad = m + 1.5 * fmax(cxw, cyw);
}

/* Fills c->lens's pupil table, from the lens's cache when it has it. */
static void pupils(lr__cam *c, int colours)
{
    lr__lens_cam *lc = &c->lens;
    lr_lens *L = (lr_lens *)lc->L; /* the cache is mutable, under L->mu */
    double key[5] = {lc->z_sensor, lc->stop_scale, lc->pupil_rmax,
                     colours + 10.0 * c->chroma.amplify, lc->z_rear};
    pthread_mutex_lock(&L->mu);
    for (int i = 0; i < L->n_pupils; i++) {
        const lr__pupil_entry *e = &L->pupils[i];
        if (memcmp(e->key, key, sizeof key) == 0) {
            for (int k = 0; k < LR__PUPIL_N; k++)
                lc->pupil_c[k] = e->c[k], lc->pupil_r[k] = e->r[k];
            lc->inv_E0 = e->inv_E0;
            pthread_mutex_unlock(&L->mu);
            return;
        }
    }
    pthread_mutex_unlock(&L->mu);

    /* Every colour the render traces must fit in the bounds. */
    double n_lo[LR__RX_MAX_SURFACES], n_hi[LR__RX_MAX_SURFACES];
    pupil_job j = {c, {lc->n_ref}, 1};
    if (colours == 1) {
        for (int k = 0; k < 3; k++)
            j.nsets[j.n_sets++] = lc->n_rgb[k];
    } else if (colours == 2) {
        indices(c, 380.0, n_lo);
        indices(c, 780.0, n_hi);
        j.nsets[j.n_sets++] = n_lo;
        j.nsets[j.n_sets++] = n_hi;
    }
    double E0 = 0.0;
    for (int k = 0; k < LR__PUPIL_N; k++) {
        double ra = lc->pupil_rmax * k / LR__PUPIL_N;
        double rb = lc->pupil_rmax * (k + 1) / LR__PUPIL_N;
        pupil_interval(&j, ra, rb, &lc->pupil_c[k], &lc->pupil_r[k],
                       k == 0 ? &E0 : NULL);
    }
    lc->inv_E0 = E0 > 0.0 ? 1.0 / E0 : 0.0;

    pthread_mutex_lock(&L->mu);
    lr__pupil_entry *e = &L->pupils[L->next_pupil];
    memcpy(e->key, key, sizeof key);
    for (int k = 0; k < LR__PUPIL_N; k++)
        e->c[k] = lc->pupil_c[k], e->r[k] = lc->pupil_r[k];
    e->inv_E0 = lc->inv_E0;
    e->n = LR__PUPIL_N;
    L->next_pupil = (L->next_pupil + 1) % LR__PUPIL_CACHE;
    if (L->n_pupils < LR__PUPIL_CACHE)
        L->n_pupils++;
    pthread_mutex_unlock(&L->mu);
}

/* ---- setup ------------------------------------------------------------------ */

static void setup(lr__cam *c, const lr_camera *cam)
{
    lr__lens_cam *lc = &c->lens;
    const lr_lens *L = cam->lens;
    lc->L = L;
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
    lc->z_rear = L->z[L->rx.n - 1];

    /* The frame's field of view, for whoever reads it: the sensor seen
     * from the rear principal point. */
    c->half_h = 0.5 * lc->sensor_h / (f + y);
    c->half_w = 0.5 * lc->sensor_w / (f + y);

    lr__rx_indices(&L->rx, c->nm_ref, lc->n_ref);
    for (int k = 0; k < 3; k++) {
        lc->nm_rgb[k] = rgb_nm[k];
        indices(c, rgb_nm[k], lc->n_rgb[k]);
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
    pupils(c, colours);
}

/* ---- rays ----------------------------------------------------------------------- */

/* The sensor point of film point (fx, fy), in mm (top of file). */
static void sensor_at(const lr__lens_cam *lc, const lr__cam *c, double fx,
                      double fy, double *x, double *y)
{
    *x = (0.5 - fx / c->width) * lc->sensor_w;
    *y = (fy / c->height - 0.5) * lc->sensor_h;
}

/* From lens coordinates (mm, about the sensor's centre) to the scene. */
static void to_world(const lr__cam *c, const double o[3], const double d[3],
                     lr__v3 *org, lr__v3 *dir)
{
    const lr__lens_cam *lc = &c->lens;
    double zo = o[2] - lc->z_sensor;
    lr__v3 p = v3_madd(v3_madd(v3_scale(c->right, o[0]), c->up, o[1]),
                       c->forward, -zo);
    *org = v3_madd(c->origin, p, lc->mm);
    *dir = v3_norm(v3_madd(v3_madd(v3_scale(c->right, d[0]), c->up, d[1]),
                           c->forward, -d[2]));
}

static double lens_ray(const lr__cam *c, double fx, double fy,
                       const double u[2], double w, double nm, lr__v3 *org,
                       lr__v3 *dir)
{
    (void)w;
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double nbuf[LR__RX_MAX_SURFACES];
    const double *n = lc->n_ref;
    if (nm != c->nm_ref) {
        n = NULL;
        for (int k = 0; k < 3; k++)
            if (nm == lc->nm_rgb[k])
                n = lc->n_rgb[k];
        if (n == NULL) {
            indices(c, nm, nbuf);
            n = nbuf;
        }
    }
    double xs, ys;
    sensor_at(lc, c, fx, fy, &xs, &ys);
    double r = hypot(xs, ys);
    int k = (int)(r / lc->pupil_rmax * LR__PUPIL_N);
    if (k >= LR__PUPIL_N)
        k = LR__PUPIL_N - 1;
    double ex = r > 0.0 ? xs / r : 1.0, ey = r > 0.0 ? ys / r : 0.0;
    double lx, ly;
    lr__aperture_sample(LR_APERTURE_DISK, 0, 0.0, 1.0, u, &lx, &ly);
    double rad = lc->pupil_r[k], cx = lc->pupil_c[k];
    double qx = ex * cx + rad * lx, qy = ey * cx + rad * ly;
    double dz = lc->z_rear - lc->z_sensor;
    double o[3] = {xs, ys, lc->z_sensor}, d[3] = {qx - xs, qy - ys, dz};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; a++)
        d[a] /= len;
    double ct = -d[2];
    if (rad > 0.0 &&
        lr__rx_trace_n(&L->rx, L->z, n, lc->stop_scale, 0, o, d)) {
        to_world(c, o, d, org, dir);
        return M_PI * rad * rad * ct * ct * ct * ct / (dz * dz) * lc->inv_E0;
    }
    *org = c->origin;
    *dir = c->forward;
    return 0.0;
}

static void lens_rays16(const lr__cam *c, int use_lens, int n,
                        const float *fx, const float *fy, const float *lu,
                        const float *lv, struct RTCRayHit16 *rh, float *wt)
{
    (void)use_lens; /* a real lens is always sampled */
    struct RTCRay16 *r = &rh->ray;
    for (int i = 0; i < 16; i++) {
        int k = i < n ? i : 0;
        double u[2] = {lu[k], lv[k]};
        lr__v3 org, dir;
        wt[i] = (float)lens_ray(c, fx[k], fy[k], u, c->w, c->nm_ref, &org,
                                &dir);
        r->org_x[i] = (float)org.x;
        r->org_y[i] = (float)org.y;
        r->org_z[i] = (float)org.z;
        r->dir_x[i] = (float)dir.x;
        r->dir_y[i] = (float)dir.y;
        r->dir_z[i] = (float)dir.z;
        r->tnear[i] = 0.0f;
        r->time[i] = 0.0f;
        r->tfar[i] = INFINITY;
        r->mask[i] = 0xFFFFFFFFu;
        r->id[i] = 0;
        r->flags[i] = 0;
        rh->hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        rh->hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
}

/* The ray from the film point through the middle of its exit-pupil
 * bound (the stop's centre, near enough, for depth and autofocus); the
 * frame's pinhole ray where that is blocked. */
static void lens_chief(const lr__cam *c, double fx, double fy, lr__v3 *org,
                       lr__v3 *dir)
{
    const lr__lens_cam *lc = &c->lens;
    double xs, ys;
    sensor_at(lc, c, fx, fy, &xs, &ys);
    double r = hypot(xs, ys);
    int k = (int)(r / lc->pupil_rmax * LR__PUPIL_N);
    if (k >= LR__PUPIL_N)
        k = LR__PUPIL_N - 1;
    double ex = r > 0.0 ? xs / r : 1.0, ey = r > 0.0 ? ys / r : 0.0;
    double q[2] = {ex * lc->pupil_c[k], ey * lc->pupil_c[k]};
    double o[3] = {xs, ys, lc->z_sensor};
    double d[3] = {q[0] - xs, q[1] - ys, lc->z_rear - lc->z_sensor};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; a++)
        d[a] /= len;
    if (lc->pupil_r[k] > 0.0 &&
        lr__rx_trace_n(&lc->L->rx, lc->L->z, lc->n_ref, lc->stop_scale, 0,
                       o, d)) {
        to_world(c, o, d, org, dir);
        return;
    }
    *org = c->origin;
    *dir = v3_norm(v3_madd(v3_madd(c->forward, c->right,
                                   (2.0 * fx / c->width - 1.0) * c->half_w),
                           c->up, (1.0 - 2.0 * fy / c->height) * c->half_h));
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
    .id = LR_CAMERA_LENS,
    .keys = keys,
    .lens = 1,
    .validate = validate,
    .setup = setup,
    .ray = lens_ray,
    .rays16 = lens_rays16,
    .chief = lens_chief,
    .focus_at = focus_at,
    .bound = NULL,
};
