/*
 * lens_light.c: the real lens seen from the light side: a point on a disk
 * before the front element, traced toward the sensor, gives the film
 * point and the camera's importance there (camera.h: lens_point, film);
 * and the ghosts, the same trace with two reflections (ghost_paths,
 * ghost_film).  Part of the lens model (camera_lens.h).
 */
#include "camera/camera_lens.h"
#include "optics/ghost.h"
#include "optics/lens.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* ---- the light side (camera.h: lr__lens_point, film) --------------------------
 *
 * The camera's measurement: a pixel's value is inv_E0 / A_pix times the
 * integral over its sensor area and the rear plane of L cos^4 / Z^2, that
 * is of L cos(theta) dA dw at the sensor (cos^4 / Z^2 dA_q = cos dw from
 * the sensor point): the ray bundle's etendue.  A lens conserves etendue
 * (n^2 cos dA dw, air on both sides), so the same integral over the rays
 * entering the front of the lens, in cos(theta_o) dA_o dw_o on a plane
 * across the axis, gives the pixel (Kolb et al. 1995, section 4; Veach
 * 1997, section 5.7 on the invariance of etendue).  The light side draws
 * the plane's point uniformly over a disk in front of the first element
 * (density 1 / A) and a direction, traces the ray toward the image, and
 * the sensor point it reaches is the film point; its weight is inv_E0
 * cos(theta_o) A / A_pix per unit solid angle.  A ray the camera could
 * not have drawn (outside the pupil bounds its film point samples) counts
 * for nothing, as for the camera. */

/* The first surface's semi-aperture a and its sag at a (a when the
 * surface is a hemisphere or more). */
static void front_rim(const lr_lens *L, double *a, double *sag)
{
    const lr__surface *s0 = &L->rx.s[0];
    *a = s0->semi_aperture, *sag = 0.0;
    if (s0->radius != 0.0 && fabs(s0->radius) > *a)
        *sag = fabs(s0->radius) - sqrt(s0->radius * s0->radius - *a * *a);
    else if (s0->radius != 0.0)
        *sag = *a;
}

/* Whether any point of a 32 x 32 grid over the disk of radius rho on the
 * first vertex's plane sends a ray of slope s (along +x) through the
 * lens, toward the image. */
static int any_through(const lr_lens *L, const double *n, double s, double rho)
{
    double len = sqrt(1.0 + s * s);
    double d0[3] = {s / len, 0.0, 1.0 / len};
    double back = (L->rx.s[0].semi_aperture + 1.0) / d0[2];
    for (int iy = 0; iy < 32; iy++)
        for (int ix = 0; ix < 32; ix++) {
            double ox = rho * ((ix + 0.5) / 16.0 - 1.0);
            double oy = rho * ((iy + 0.5) / 16.0 - 1.0);
            if (ox * ox + oy * oy > rho * rho)
                continue;
            double o[3] = {ox - back * d0[0], oy, L->z[0] - back * d0[2]};
            double d[3] = {d0[0], d0[1], d0[2]};
            if (lr__rx_trace_n(&L->rx, L->z, n, 1.0, 1, o, d))
                return 1;
        }
    return 0;
}

double lr__lens_front_slope(const lr_lens *L)
{
    if (__atomic_load_n(&L->front_slope_set, __ATOMIC_ACQUIRE))
        return L->front_slope;
    lr_lens *M = (lr_lens *)L; /* the bound is mutable, under L->mu */
    pthread_mutex_lock(&M->mu);
    if (!M->front_slope_set) {
        double n[LR__RX_MAX_SURFACES], a, sag, clear = 4.0;
        lr__rx_indices(&L->rx, LR__NM_d, n);
        front_rim(L, &a, &sag);
        /* A ray of slope s crosses the vertex's plane within sag s of
         * where it meets the first surface (inside a). */
        int found = 0;
        for (double s = 4.0; s > 1e-3 && !found; s *= 0.95) {
            found = any_through(L, n, s, a + sag * s);
            clear = found ? clear : s;
        }
        M->front_slope = found ? fmin(1.5 * clear + 0.1, 4.0) : 4.0;
        __atomic_store_n(&M->front_slope_set, 1, __ATOMIC_RELEASE);
    }
    pthread_mutex_unlock(&M->mu);
    return L->front_slope;
}

/* The disk the light side draws on: on the first vertex's plane, as wide
 * as the first element's semi-aperture plus its sag there times the
 * steepest slope a ray through the lens can have (a convex or concave
 * front's rays cross the vertex plane beyond the semi-aperture by the sag
 * times the ray's slope; lr__lens_front_slope). */
static double front_disk(const lr__lens_cam *lc)
{
    double a, sag;
    front_rim(lc->L, &a, &sag);
    return a + lr__lens_front_slope(lc->L) * sag;
}

lr__v3 lr__lens_at(const lr__cam *c, double ox, double oy)
{
    double o[3] = {ox, oy, c->lens.L->z[0]}, d[3] = {0, 0, 1};
    lr__v3 org, dir;
    lr__lens_to_world(c, o, d, &org, &dir);
    return org;
}

lr__v3 lr__lens_point(const lr__cam *c, const double u[2], double *ox,
                      double *oy)
{
    double a, b, rho = front_disk(&c->lens);
    lr__aperture_sample(LR_APERTURE_DISK, 0, 0.0, 1.0, u, &a, &b);
    *ox = a * rho, *oy = b * rho;
    return lr__lens_at(c, *ox, *oy);
}

double lr__lens_ghost_disk(const lr__cam *c)
{
    return front_disk(&c->lens);
}

double lr__lens_pupil_radius(const lr__cam *c)
{
    return c->lens.L->first.enp_radius * c->lens.stop_scale;
}

static double lens_film_n(const lr__cam *c, const double *n, double nm,
                          double ox, double oy, lr__v3 w, double *fx,
                          double *fy);

double lr__lens_film(const lr__cam *c, double ox, double oy, lr__v3 w,
                     double *fx, double *fy)
{
    return lens_film_n(c, c->lens.n_ref, c->nm_ref, ox, oy, w, fx, fy);
}

/* rgb mode: channel k at its wavelength (nm_rgb), as the camera traces
 * it; the pupil bounds hold every channel (pupils). */
double lr__lens_film_rgb(const lr__cam *c, int k, double ox, double oy,
                         lr__v3 w, double *fx, double *fy)
{
    return lens_film_n(c, c->lens.n_rgb[k], c->lens.nm_rgb[k], ox, oy, w, fx,
                       fy);
}

/* Spectral mode: at wavelength nm, as lens_ray traces it (the focus
 * power w plays no part in a traced lens). */
double lr__lens_film_wl(const lr__cam *c, double w, double nm, double ox,
                        double oy, lr__v3 d, double *fx, double *fy)
{
    (void)w;
    double n[LR__RX_MAX_SURFACES];
    lr__lens_indices(c, nm, n);
    return lens_film_n(c, n, nm, ox, oy, d, fx, fy);
}

/* lr__lens_film with the surfaces' indices n at wavelength nm (the
 * surfaces' reflectance, where no table holds n: lr__lens_ttab_for). */
static double lens_film_n(const lr__cam *c, const double *n, double nm,
                          double ox, double oy, lr__v3 w, double *fx,
                          double *fy)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    /* The light comes in along -w; in the lens's frame (x right, y up,
     * z = -forward) it travels toward +z, the image. */
    double d[3] = {-v3_dot(w, c->right), -v3_dot(w, c->up),
                   v3_dot(w, c->forward)};
    if (!(d[2] > 0.0))
        return 0.0;
    double cos_o = d[2];
    /* Back along the line to before the first surface. */
    double back = (L->rx.s[0].semi_aperture + 1.0) / d[2];
    double o[3] = {ox - back * d[0], oy - back * d[1], L->z[0] - back * d[2]};
    double T = 0.0;
    if (!lr__rx_trace_t(&L->rx, L->z, n, lc->stop_scale, 1,
                        lr__lens_ttab_for(lc, n), nm, lc->coat, o, d, &T) ||
        !(d[2] > 0.0))
        return 0.0;
    double t = (lc->z_sensor - o[2]) / d[2];
    double xs = o[0] + t * d[0], ys = o[1] + t * d[1];
    *fx = (0.5 - xs / lc->sensor_w) * c->width;
    *fy = (ys / lc->sensor_h + 0.5) * c->height;
    /* Where the camera aims from this sensor point: the line's point on
     * the rear plane, inside the bounds it samples (lens_start). */
    lr__lens_sensor sp = lr__lens_sensor_at(c, *fx, *fy);
    lr__pupil P = lr__lens_pupil_at(lc, sp.r);
    double tq = (lc->z_rear - lc->z_sensor) / d[2];
    double qx = xs + tq * d[0], qy = ys + tq * d[1];
    double a = sp.ex * qx + sp.ey * qy - P.cx, b = -sp.ey * qx + sp.ex * qy;
    double disk = M_PI * P.rad * P.rad, rect = 4.0 * P.hx * P.hy;
    if (disk <= rect ? a * a + b * b > P.rad * P.rad
                     : fabs(a) > P.hx || fabs(b) > P.hy)
        return 0.0;
    double rho = front_disk(lc);
    double A_pix = lc->sensor_w * lc->sensor_h / (c->width * c->height);
    return lc->inv_E0 * cos_o * M_PI * rho * rho / A_pix * T;
}

/* ---- ghosts (camera.h: ghost_paths, ghost_film) ----------------------------
 *
 * A ghost's light enters the front of the lens as the main image's does,
 * so the same measurement holds: the pixel's value is inv_E0 / A_pix
 * times the sensor's irradiance integrated over the pixel, and the
 * ray's etendue cos(theta_o) dA_o dw_o at the front is what reaches
 * the sensor (etendue is conserved along a ray through refractions and
 * reflections alike: Kolb et al. 1995, section 4; Veach 1997, section
 * 5.7), carrying the ghost path's throughput (two reflectances R and
 * 1 - R at every other crossing, Hullin et al. 2011, section 3; ghost.h)
 * in place of the main path's.  So the importance is lens_film_n's
 * inv_E0 cos(theta_o) A / A_pix, times that throughput.  There is no
 * pupil-bound check: the camera never traces a ghost path, so no camera
 * estimator shares this light with the light side. */

/* Ghost g in lr__ghost_paths' order (by j, then i < j). */
static lr__ghost ghost_at(int g)
{
    int j = 1;
    while ((j + 1) * j / 2 <= g)
        j++;
    return (lr__ghost){j, g - j * (j - 1) / 2};
}

int lr__lens_ghost_paths(const lr__cam *c, double *peak, double *k,
                         lr__ghost_est *est)
{
    const lr__lens_cam *lc = &c->lens;
    *peak = 0.0, *k = 0.0;
    if (lc->ghosts == LR_GHOSTS_OFF || lc->n_ghost == 0)
        return 0;
    for (int g = 0; g < lc->n_ghost; g++)
        est[g] = (lr__ghost_est){0.0, 1.0, 0.0};
    /* On axis at the reference wavelength and the camera's stop, a 12 x
     * 12 beam (some 9 ms for the double Gauss's 55 paths), counted on
     * the frame's circle: an estimate for the plan, not a bound. */
    lr__ghost_flux *gf = malloc(LR__GHOST_MAX * sizeof *gf);
    if (gf == NULL)
        return -1;
    double A_pix = lc->sensor_w * lc->sensor_h / (c->width * c->height);
    /* The main image of a distant source of radiance L filling a small
     * solid angle Omega on axis: L Omega times the main path's
     * transmission over the front, each ray worth lens_film_n's inv_E0
     * cos A / A_pix in pixels (cos = 1).  Its own 64 x 64 beam (some 2
     * ms): the stop's disc covers a few of the 12 x 12 beam's cells. */
    double area = lr__ghost_main_area(&lc->L->rx, lc->n_ref, &lc->t_ref,
                                      c->nm_ref, lc->stop_scale, lc->coat, 64);
    *k = lc->inv_E0 * area / A_pix;
    /* Where that beam is under six of the 12 x 12 beam's cells (stopped
     * down: at f/17 the double Gauss's missed every cell centre, no path
     * had an estimate, "auto" drew no ghost and true drew them from the
     * whole front, where none of 256 landed), a beam whose cells it
     * covers some 24 of, at most 128 a side. */
    double front = 2.0 * lc->L->rx.s[0].semi_aperture, cell = front / 12.0;
    int grid = 12;
    if (area < 6.0 * cell * cell)
        grid = (int)fmin(128.0, ceil(front * sqrt(24.0 / fmax(area, 1e-9))));
    double main = 0.0;
    int n = lr__ghost_fluxes_t(&lc->L->rx, lc->n_ref, &lc->t_ref, c->nm_ref,
                               lc->stop_scale, lc->coat, 0.0, grid,
                               lc->pupil_rmax, gf, &main);
    for (int j = 0; j < n; j++) {
        /* A uniform disc of radius r has rms radius r / sqrt 2: area
         * 2 pi rms^2. */
        double px = fmax(1.0, 2.0 * M_PI * gf[j].rms * gf[j].rms / A_pix);
        *peak = fmax(*peak, gf[j].flux / px);
        lr__ghost p = gf[j].path;
        est[p.j * (p.j - 1) / 2 + p.i] = (lr__ghost_est){gf[j].flux, px,
                                                         gf[j].landed};
    }
    free(gf);
    if (lc->ghosts == LR_GHOSTS_ON)
        *peak = INFINITY;
    return lc->n_ghost;
}

/* Channel k's wavelength, indices and reflectance table for a ghost:
 * the glass's own dispersion at nm (chromatic.amplify plays no part in
 * a ghost). */
static const lr__ttab *ghost_wl(const lr__cam *c, int k, double *nm,
                                const double **n_after)
{
    const lr__lens_cam *lc = &c->lens;
    int rgb = k >= 0 && k < 3 && c->chroma.mode != LR_CHROMATIC_OFF;
    *nm = rgb ? lc->nm_rgb[k] : c->nm_ref;
    *n_after = rgb ? lc->g_n[k] : lc->n_ref;
    return rgb ? &lc->g_tab[k] : &lc->t_ref;
}

/* The lens-space ray toward the front for offset (ox, oy) and world
 * direction w: o a millimetre before the first surface's rim, d unit;
 * returns d[2] (> 0 when it enters the lens). */
static double ghost_ray(const lr__cam *c, double ox, double oy, lr__v3 w,
                        double o[3], double d[3])
{
    const lr_lens *L = c->lens.L;
    d[0] = -v3_dot(w, c->right), d[1] = -v3_dot(w, c->up);
    d[2] = v3_dot(w, c->forward);
    double back = (L->rx.s[0].semi_aperture + 1.0) / d[2];
    o[0] = ox - back * d[0], o[1] = oy - back * d[1];
    o[2] = L->z[0] - back * d[2];
    return d[2];
}

/* A landed ghost ray's film point and value: hit on the sensor (mm),
 * T its throughput, cos_o its d[2] in front. */
static double ghost_land(const lr__cam *c, const double hit[2], double T,
                         double cos_o, double *fx, double *fy)
{
    const lr__lens_cam *lc = &c->lens;
    *fx = (0.5 - hit[0] / lc->sensor_w) * c->width;
    *fy = (hit[1] / lc->sensor_h + 0.5) * c->height;
    double rho = front_disk(lc);
    double A_pix = lc->sensor_w * lc->sensor_h / (c->width * c->height);
    return lc->inv_E0 * cos_o * M_PI * rho * rho / A_pix * T;
}

double lr__lens_ghost_film(const lr__cam *c, int g, int k, double ox, double oy,
                           lr__v3 w, double *rel, double *fx, double *fy)
{
    const lr__lens_cam *lc = &c->lens;
    double nm, o[3], d[3], hit[2], T = 0.0;
    const double *n_after;
    const lr__ttab *tab = ghost_wl(c, k, &nm, &n_after);
    double cos_o = ghost_ray(c, ox, oy, w, o, d);
    if (!(cos_o > 0.0) || g < 0 || g >= lc->n_ghost)
        return 0.0;
    double frame[2] = {0.5 * lc->sensor_w, 0.5 * lc->sensor_h};
    if (!lr__ghost_trace_rel(&lc->L->rx, lc->L->z, n_after, tab, nm,
                             lc->stop_scale, lc->coat, ghost_at(g),
                             lc->z_sensor, rel == NULL ? frame : NULL, o, d,
                             hit, &T, rel))
        return 0.0;
    return ghost_land(c, hit, T, cos_o, fx, fy);
}

void lr__lens_ghost_film_n(const lr__cam *c, int g, int k, int n,
                           const double *ox, const double *oy, const lr__v3 *w,
                           double *rel, double *fx, double *fy, double *W)
{
    /* lr__lens_ghost_film's steps, lane by lane around one
     * lr__ghost_trace16 (the same bits). */
    const lr__lens_cam *lc = &c->lens;
    double nm;
    const double *n_after;
    const lr__ttab *tab = ghost_wl(c, k, &nm, &n_after);
    double o[3][LR__GHOST_LANES], d[3][LR__GHOST_LANES];
    double hit[2][LR__GHOST_LANES], T[LR__GHOST_LANES], cos_o[LR__GHOST_LANES];
    int alive[LR__GHOST_LANES];
    for (int l = 0; l < n; l++)
        W[l] = 0.0;
    if (n <= 0 || g < 0 || g >= lc->n_ghost)
        return;
    for (int l = 0; l < LR__GHOST_LANES; l++) {
        double ol[3] = {0.0, 0.0, 0.0}, dl[3] = {0.0, 0.0, 1.0};
        if (l < n)
            ghost_ray(c, ox[l], oy[l], w[l], ol, dl);
        alive[l] = l < n && dl[2] > 0.0;
        cos_o[l] = dl[2];
        for (int a = 0; a < 3; a++)
            o[a][l] = ol[a], d[a][l] = dl[a];
    }
    double frame[2] = {0.5 * lc->sensor_w, 0.5 * lc->sensor_h};
    lr__ghost_trace16(&lc->L->rx, lc->L->z, n_after, tab, nm, lc->stop_scale,
                      lc->coat, ghost_at(g), lc->z_sensor,
                      rel == NULL ? frame : NULL, (const double(*)[16])o,
                      (const double(*)[16])d, hit, T, rel, alive);
    for (int l = 0; l < n; l++)
        if (alive[l]) {
            double h[2] = {hit[0][l], hit[1][l]};
            W[l] = ghost_land(c, h, T[l], cos_o[l], &fx[l], &fy[l]);
        }
}

/* The light side's plan (light_trace.c) sees the lens as a thin lens of
 * the entrance pupil's radius at the eye focused at the focus distance:
 * an estimate of how large a light's disc is, not a bound. */
void lr__lens_thin_equiv(const lr__cam *c, lr__lens_bound *b)
{
    const lr__lens_cam *lc = &c->lens;
    b->R = lc->L->first.enp_radius * lc->stop_scale * lc->mm;
    b->n_w = 1;
    b->ws[0] = c->w;
}

/* The light side only where its disk holds every ray through the lens:
 * a front slope bound under the former fixed 4 (a search that found one).
 * Where it stays at 4 (fisheye-10, the Minolta fisheye, the 170-degree
 * wide angle: test_front_disk_covers found rays steeper than that get
 * through), light paths would miss light that camera rays see. */
int lr__lens_light_ok(const lr__cam *c)
{
    /* A flat first surface (a stop in front, a plano-convex lens) meets
     * every ray through the lens inside its semi-aperture, at any slope:
     * its front disk holds them all (front_disk: the sag is 0).  Such
     * lenses had been refused, and their small lights left to the camera
     * (17 to 66 times the relMSE, an independent check). */
    double a, sag;
    front_rim(c->lens.L, &a, &sag);
    return sag == 0.0 || lr__lens_front_slope(c->lens.L) < 4.0;
}
