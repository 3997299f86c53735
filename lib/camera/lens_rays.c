/*
 * lens_rays.c: a real lens's camera rays in double (camera_lens.h): one
 * at a time (the model's `ray` and `chief`), and up to sixteen at once
 * with the same bits (`rays_n`: rgb and spectral mode's samples).  The
 * packet camera's float rays are camera_lens.c's.
 */
#include "camera/camera_lens.h"
#include "optics/ghost.h"
#include "optics/lens.h"

#include <math.h>
#include <string.h>

/* The first half of a camera ray: the sensor point, the point aimed at
 * in the smaller of the film radius's two bounds (a disk by the
 * concentric map, or a rectangle: both uniform by area), the unit
 * direction, and the sample's weight before the lens has its say (0: the
 * bounds are empty). */
static double lens_start(const lr__cam *c, double fx, double fy,
                         const double u[2], double o[3], double d[3])
{
    const lr__lens_cam *lc = &c->lens;
    lr__lens_sensor sp = lr__lens_sensor_at(c, fx, fy);
    double xs = sp.x, ys = sp.y, ex = sp.ex, ey = sp.ey;
    lr__pupil P = lr__lens_pupil_at(lc, sp.r);
    double a, b, area;
    double disk = M_PI * P.rad * P.rad, rect = 4.0 * P.hx * P.hy;
    if (disk <= rect) {
        lr__aperture_sample(LR_APERTURE_DISK, 0, 0.0, 1.0, u, &a, &b);
        a *= P.rad, b *= P.rad, area = disk;
    } else {
        a = (2.0 * u[0] - 1.0) * P.hx, b = (2.0 * u[1] - 1.0) * P.hy;
        area = rect;
    }
    a += P.cx;
    /* (a, b) along and across the radial direction. */
    double qx = ex * a - ey * b, qy = ey * a + ex * b;
    double dz = lc->z_rear - lc->z_sensor;
    o[0] = xs, o[1] = ys, o[2] = lc->z_sensor;
    d[0] = qx - xs, d[1] = qy - ys, d[2] = dz;
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        d[k] /= len;
    double ct = -d[2];
    return area * ct * ct * ct * ct / (dz * dz) * lc->inv_E0;
}

/* The camera's indices at nm (its reference's or a channel's), or NULL
 * for another wavelength. */
static const double *camera_n(const lr__cam *c, double nm)
{
    const lr__lens_cam *lc = &c->lens;
    if (nm == c->nm_ref)
        return lc->n_ref;
    const double *n = NULL;
    for (int k = 0; k < 3; k++)
        if (nm == lc->nm_rgb[k])
            n = lc->n_rgb[k];
    return n;
}

double lr__lens_ray(const lr__cam *c, double fx, double fy, const double u[2],
                    double w, double nm, lr__v3 *org, lr__v3 *dir)
{
    (void)w;
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double nbuf[LR__RX_MAX_SURFACES];
    const double *n = camera_n(c, nm);
    if (n == NULL) {
        lr__lens_indices(c, nm, nbuf);
        n = nbuf;
    }
    double o[3], d[3], T = 0.0;
    double wt = lens_start(c, fx, fy, u, o, d);
    if (wt > 0.0 &&
        lr__rx_trace_t(&L->rx, L->z, n, lc->stop_scale, 0,
                       lr__lens_ttab_for(lc, n), nm, lc->coat, o, d, &T)) {
        lr__lens_to_world(c, o, d, org, dir);
        return wt * T;
    }
    *org = c->origin;
    *dir = c->forward;
    return 0.0;
}

/* The model's rays_n: lr__lens_ray's rays, their glass traced sixteen at a
 * time in double by lr__rx_trace16_nl (each lane at its wavelength's
 * indices), then each lane's transmittance as lr__rx_trace_t takes it,
 * surface by surface in its order: from the table of a wavelength the
 * camera holds one for, else from the coating's formula at the lane's
 * own (spectral mode's). */
void lr__lens_rays_n(const lr__cam *c, int n, const double *fx,
                     const double *fy, const double (*u)[2], const double *w,
                     const double *nm, lr__v3 *org, lr__v3 *dir, double *wt)
{
    (void)w;
    if (n <= 0)
        return;
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    const lr__rx *rx = &L->rx;
    double nbuf[16][LR__RX_MAX_SURFACES], nl[LR__RX_MAX_SURFACES][16];
    double cosv[LR__RX_MAX_SURFACES][16], o[3][16], d[3][16], w0[16];
    const double *ns[16];
    int alive[16];
    for (int i = 0; i < 16; i++) {
        /* Lanes from n on are lost from the start; lane 0's indices
         * keep their arithmetic finite. */
        double oi[3] = {0.0, 0.0, 0.0}, di[3] = {0.0, 0.0, -1.0};
        ns[i] = i < n ? camera_n(c, nm[i]) : ns[0];
        if (ns[i] == NULL) {
            lr__lens_indices(c, nm[i], nbuf[i]);
            ns[i] = nbuf[i];
        }
        for (int s = 0; s < rx->n; s++)
            nl[s][i] = ns[i][s];
        w0[i] = i < n ? lens_start(c, fx[i], fy[i], u[i], oi, di) : 0.0;
        alive[i] = w0[i] > 0.0;
        for (int a = 0; a < 3; a++)
            o[a][i] = oi[a], d[a][i] = di[a];
    }
    lr__rx_trace16_nl(rx, L->z, (const double(*)[16])nl, lc->stop_scale, o, d,
                      alive, cosv);
    for (int i = 0; i < n; i++) {
        if (!alive[i]) {
            org[i] = c->origin, dir[i] = c->forward, wt[i] = 0.0;
            continue;
        }
        /* lr__rx_trace_t's product, in its order. */
        const lr__ttab *tab = lr__lens_ttab_for(lc, ns[i]);
        double T = 1.0;
        for (int step = 0; step < rx->n; step++) {
            int s = rx->n - 1 - step;
            T *= lr__rx_crossing_t(rx, ns[i], s, 0, tab, nm[i], lc->coat,
                                   cosv[s][i]);
        }
        double oi[3] = {o[0][i], o[1][i], o[2][i]};
        double di[3] = {d[0][i], d[1][i], d[2][i]};
        lr__lens_to_world(c, oi, di, &org[i], &dir[i]);
        wt[i] = w0[i] * T;
    }
}

/* The ray from the film point through the middle of its exit-pupil
 * bounds (the stop's centre, near enough, for depth and autofocus); the
 * frame's pinhole ray where that is blocked. */
void lr__lens_chief_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                        lr__v3 *dir)
{
    const lr__lens_cam *lc = &c->lens;
    lr__lens_sensor sp = lr__lens_sensor_at(c, fx, fy);
    double xs = sp.x, ys = sp.y, ex = sp.ex, ey = sp.ey;
    lr__pupil P = lr__lens_pupil_at(lc, sp.r);
    double o[3] = {xs, ys, lc->z_sensor};
    double d[3] = {ex * P.cx - xs, ey * P.cx - ys, lc->z_rear - lc->z_sensor};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; a++)
        d[a] /= len;
    if (P.rad > 0.0 && lr__rx_trace_n(&lc->L->rx, lc->L->z, lc->n_ref,
                                      lc->stop_scale, 0, o, d)) {
        lr__lens_to_world(c, o, d, org, dir);
        return;
    }
    *org = c->origin;
    *dir = v3_norm(v3_madd(
        v3_madd(c->forward, c->right, (2.0 * fx / c->width - 1.0) * c->half_w),
        c->up, (1.0 - 2.0 * fy / c->height) * c->half_h));
}
