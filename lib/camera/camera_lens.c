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
#include "camera/camera.h"
#include "optics/ghost.h"
#include "optics/lens.h"
#include "optics/lens_load.h"

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
    {"lens", LR__KEY_CUSTOM, AT(lens), NULL, 0, 0},
    {"sensor_width_mm", LR__KEY_NUMBER, AT(sensor_width_mm), NULL, 0, 0},
    {"scene_unit_mm", LR__KEY_NUMBER, AT(scene_unit_mm), NULL, 0, 0},
    {"focus_distance", LR__KEY_NUMBER, AT(focus_distance), NULL, 0, 0},
    {"f_number", LR__KEY_NUMBER, AT(f_number), NULL, 0, 0},
    {"coating", LR__KEY_ENUM, AT(coating), coatings, 0, 0},
    /* "auto", true or false: camera_json.c reads it, json_write.c writes
     * it (only when not "auto"). */
    {"ghosts", LR__KEY_CUSTOM, AT(ghosts), NULL, 0, 0},
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
    lr_status st = lr__cam_check_length("camera.sensor_width_mm",
                                        cam->sensor_width_mm, 0, 0, err);
    if (st != LR_OK)
        return st;
    st = lr__cam_check_length("camera.scene_unit_mm", cam->scene_unit_mm, 0, 0,
                              err);
    if (st != LR_OK)
        return st;
    if (!active)
        return LR_OK;
    if (cam->lens == NULL)
        return BAD("camera.lens",
                   "camera.lens must name a lens for the \"lens\" model");
    /* The exit-pupil search (pupil_point) resolves stops down to about
     * 1/400 of the rear element: f/128 on every shipped lens. */
    if (cam->f_number > 128.0)
        return BAD("camera.f_number",
                   "camera.f_number must be at most 128 for a real lens, "
                   "got %g",
                   cam->f_number);
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

/* ---- exit-pupil bounds ----------------------------------------------------- */

#define G_COARSE 24
#define G_FINE 128

typedef struct pupil_job {
    const lr__cam *c;
    const double *nsets[4];
    int n_sets;
} pupil_job;

/* Which of up to 16 rear-plane points (x, y) rays from sensor point
 * (r, 0) get through with any of the index sets: ok[i]; cos4[i] gets
 * cos^4 of each ray's angle to the axis. */
static void passes16(const pupil_job *j, double r, int m, const double *x,
                     const double *y, int *ok, double *cos4)
{
    const lr__lens_cam *lc = &j->c->lens;
    const lr_lens *L = lc->L;
    double o[3][16], d[3][16], dz = lc->z_rear - lc->z_sensor;
    int alive[16];
    for (int i = 0; i < 16; i++)
        ok[i] = 0;
    for (int k = 0; k < j->n_sets; k++) {
        for (int i = 0; i < 16; i++) {
            int l = i < m ? i : 0;
            double dx = x[l] - r, dy = y[l];
            double len = sqrt(dx * dx + dy * dy + dz * dz);
            double ct = -dz / len;
            cos4[i] = ct * ct * ct * ct;
            o[0][i] = r, o[1][i] = 0.0, o[2][i] = lc->z_sensor;
            d[0][i] = dx / len, d[1][i] = dy / len, d[2][i] = dz / len;
            alive[i] = i < m;
        }
        lr__rx_trace16(&L->rx, L->z, j->nsets[k], lc->stop_scale, o, d, alive);
        for (int i = 0; i < m; i++)
            ok[i] |= alive[i];
    }
}

/* Calls fn on every point of a g x g grid over [x0, x1] x [y0, y1] (cell
 * centres) that rays from film radius r pass, 16 points at a time. */
typedef void (*grid_fn)(void *ctx, double x, double y, double cos4);
static void grid_pass(const pupil_job *j, double r, double x0, double y0,
                      double cw, double ch, int g, grid_fn fn, void *ctx)
{
    double x[16], y[16], c4[16];
    int ok[16], m = 0;
    for (int iy = 0; iy < g; iy++)
        for (int ix = 0; ix < g; ix++) {
            x[m] = x0 + (ix + 0.5) * cw, y[m] = y0 + (iy + 0.5) * ch;
            if (++m < 16 && !(iy == g - 1 && ix == g - 1))
                continue;
            passes16(j, r, m, x, y, ok, c4);
            for (int i = 0; i < m; i++)
                if (ok[i])
                    fn(ctx, x[i], y[i], c4[i]);
            m = 0;
        }
}

typedef struct extent {
    double x0, x1, y0, y1; /* of the points that pass */
    double *pts;           /* and the points, when kept */
    int np, cap;
    double e0; /* sum of cos^4 (for E0) */
} extent;

static void grow(void *ctx, double x, double y, double cos4)
{
    extent *e = ctx;
    e->x0 = fmin(e->x0, x), e->x1 = fmax(e->x1, x);
    e->y0 = fmin(e->y0, y), e->y1 = fmax(e->y1, y);
    e->e0 += cos4;
    if (e->pts != NULL && e->np < e->cap) {
        e->pts[2 * e->np] = x, e->pts[2 * e->np + 1] = y;
        e->np++;
    }
}

/* ---- the fine grid, traced only where its answer needs it ---------------
 *
 * The bounds depend on the fine grid's passing points only through their
 * extremes: the least and greatest x and y, and the greatest distance from
 * the centre of the x extent.  Each extreme is found by tracing points from
 * the outside in, in batches of 16, until one passes: every point beyond
 * it has been traced and failed, so it is the extreme the whole grid
 * would give, bit for bit (each point's ray is a pure function of the
 * point; lr__rx_trace16's lanes are independent).  Points inside the
 * pupil, the bulk of the grid, are never traced.  Only the on-axis entry,
 * whose E0 sums every passing point, traces them all. */

enum { ST_UNKNOWN = 0, ST_PASS = 1, ST_FAIL = 2, ST_QUEUED = 3 };

typedef struct fine_grid {
    const pupil_job *j;
    double r, x0, y0, cw, ch;
    unsigned char st[G_FINE * G_FINE]; /* row-major: iy * G_FINE + ix */
    int queue[16], nq;
} fine_grid;

/* The grid's point coordinates, as grid_pass makes them. */
static double fine_x(const fine_grid *f, int ix)
{
    return f->x0 + (ix + 0.5) * f->cw;
}

static double fine_y(const fine_grid *f, int iy)
{
    return f->y0 + (iy + 0.5) * f->ch;
}

static void fine_flush(fine_grid *f)
{
    if (f->nq == 0)
        return;
    double x[16], y[16], c4[16];
    int ok[16];
    for (int i = 0; i < f->nq; i++) {
        x[i] = fine_x(f, f->queue[i] % G_FINE);
        y[i] = fine_y(f, f->queue[i] / G_FINE);
    }
    passes16(f->j, f->r, f->nq, x, y, ok, c4);
    for (int i = 0; i < f->nq; i++)
        f->st[f->queue[i]] = ok[i] ? ST_PASS : ST_FAIL;
    f->nq = 0;
}

/* Queues point k for tracing if its status is unknown (the queue must
 * have room). */
static void fine_push(fine_grid *f, int k)
{
    if (f->st[k] != ST_UNKNOWN)
        return;
    f->st[k] = ST_QUEUED;
    f->queue[f->nq++] = k;
}

/* fine_push, tracing the queue when it is full. */
static void fine_want(fine_grid *f, int k)
{
    fine_push(f, k);
    if (f->nq == 16)
        fine_flush(f);
}

/* Traces line `i` (a column when col, else a row) over [a, b] of the
 * other index; returns whether any of its points passes. */
static int fine_line(fine_grid *f, int col, int i, int a, int b)
{
    for (int t = a; t <= b; t++)
        fine_want(f, col ? t * G_FINE + i : i * G_FINE + t);
    fine_flush(f);
    for (int t = a; t <= b; t++)
        if (f->st[col ? t * G_FINE + i : i * G_FINE + t] == ST_PASS)
            return 1;
    return 0;
}

typedef struct fine_cand {
    double dist;
    int k;
} fine_cand;

static int by_dist_desc(const void *pa, const void *pb)
{
    const fine_cand *a = pa, *b = pb;
    return (a->dist < b->dist) - (a->dist > b->dist);
}

/* The bounds for film radius r (lr__pupil), from a coarse grid over the
 * rear element and a fine one over what passed; for r = 0 also *E0, the
 * on-axis irradiance integral for a white scene.  The bounds reach one
 * fine cell beyond the outermost grid points that pass (the region's
 * edge lies within a cell of them); test_camera_lens.c checks that no
 * ray outside them gets through. */
static void pupil_point(const pupil_job *j, double r, lr__pupil *P, double *E0)
{
    const lr__lens_cam *lc = &j->c->lens;
    const lr_lens *L = lc->L;
    /* The rays cross the rear plane within the rear surface's aperture,
     * the stop's as scaled when the rear surface is the stop (a stop
     * larger than the glass, closed to f/128, was 1/500 of the grid's
     * box: every ray missed, a black picture). */
    int rear = L->rx.n - 1;
    double S = 1.5 * L->rx.s[rear].semi_aperture *
               (rear == L->rx.stop ? lc->stop_scale : 1.0);
    /* A stopped-down lens's pupil can fall between the coarse grid's
     * points (at f/22 the double Gauss's is 1.6 mm across, the cells
     * 1.25 mm): then finer grids, four and sixteen times. */
    double cell = 0;
    extent co = {INFINITY, -INFINITY, INFINITY, -INFINITY, NULL, 0, 0, 0};
    for (int g = G_COARSE; g <= 16 * G_COARSE && !(co.x0 <= co.x1); g *= 4) {
        cell = 2.0 * S / g;
        grid_pass(j, r, -S, -S, cell, cell, g, grow, &co);
    }
    *P = (lr__pupil){0, 0, 0, 0};
    if (E0 != NULL)
        *E0 = 0.0;
    if (!(co.x0 <= co.x1))
        return; /* nothing gets through */
    double x0 = co.x0 - cell, x1 = co.x1 + cell;
    double y0 = co.y0 - cell, y1 = co.y1 + cell;
    double cxw = (x1 - x0) / G_FINE, cyw = (y1 - y0) / G_FINE;
    fine_grid *f = malloc(sizeof *f);
    if (f == NULL) { /* out of memory: the coarse box, as when too thin */
        P->cx = 0.5 * (x0 + x1);
        P->hx = 0.5 * (x1 - x0), P->hy = fmax(y1, -y0);
        P->rad = hypot(P->hx, P->hy);
        return;
    }
    f->j = j, f->r = r, f->x0 = x0, f->y0 = y0, f->cw = cxw, f->ch = cyw;
    memset(f->st, ST_UNKNOWN, sizeof f->st);
    f->nq = 0;
    double Z = lc->z_sensor - lc->z_rear;
    if (E0 != NULL) {
        /* Every point, and the sum of cos^4 over those that pass in
         * grid_pass's order (passes16's cos^4, recomputed). */
        double dz = lc->z_rear - lc->z_sensor, e0 = 0.0;
        for (int k = 0; k < G_FINE * G_FINE; k++)
            fine_want(f, k);
        fine_flush(f);
        for (int k = 0; k < G_FINE * G_FINE; k++) {
            if (f->st[k] != ST_PASS)
                continue;
            double dx = fine_x(f, k % G_FINE) - r, dy = fine_y(f, k / G_FINE);
            double len = sqrt(dx * dx + dy * dy + dz * dz);
            double ct = -dz / len;
            /* And what the glass passes of it (1 - R at every crossing,
             * transmit.h), as the camera's rays are weighed: a uniform
             * scene's centre keeps its radiance, coated or not. */
            double o[3] = {r, 0.0, lc->z_sensor};
            double d[3] = {dx / len, dy / len, dz / len}, T = 0.0;
            if (!lr__rx_trace_t(&L->rx, L->z, lc->n_ref, lc->stop_scale, 0,
                                &lc->t_ref, j->c->nm_ref, lc->coat, o, d, &T))
                T = 0.0;
            e0 += ct * ct * ct * ct * T;
        }
        *E0 = e0 * cxw * cyw / (Z * Z);
    }
    double margin = fmax(cxw, cyw);
    /* The extremes, from the outside in. */
    int ix0 = 0, ix1 = G_FINE - 1, iy0 = 0, iy1 = G_FINE - 1;
    while (ix0 < G_FINE && !fine_line(f, 1, ix0, 0, G_FINE - 1))
        ix0++;
    if (ix0 == G_FINE) { /* too thin for the fine grid: the coarse box */
        P->cx = 0.5 * (x0 + x1);
        P->hx = 0.5 * (x1 - x0), P->hy = fmax(y1, -y0);
        P->rad = hypot(P->hx, P->hy);
        free(f);
        return;
    }
    while (!fine_line(f, 1, ix1, 0, G_FINE - 1))
        ix1--;
    while (!fine_line(f, 0, iy0, ix0, ix1))
        iy0++;
    while (!fine_line(f, 0, iy1, ix0, ix1))
        iy1--;
    double fx0 = fine_x(f, ix0), fx1 = fine_x(f, ix1);
    double fy0 = fine_y(f, iy0), fy1 = fine_y(f, iy1);
    P->cx = 0.5 * (fx0 + fx1);
    P->hx = 0.5 * (fx1 - fx0) + margin;
    P->hy = fmax(fy1, -fy0) + margin;
    /* The greatest distance from (cx, 0) of a passing point: the points
     * not known to fail, farthest first, traced until one passes.  The
     * passing points found so far bound it from below (mlow), and a point
     * whose squared distance is under mlow^2 (1 - 1e-9) is nearer than
     * mlow whatever hypot's rounding (under an ulp): only the ring
     * outside is sorted. */
    double mlow = 0.0;
    for (int iy = iy0; iy <= iy1; iy++)
        for (int ix = ix0; ix <= ix1; ix++)
            if (f->st[iy * G_FINE + ix] == ST_PASS)
                mlow = fmax(mlow, hypot(fine_x(f, ix) - P->cx, fine_y(f, iy)));
    double low2 = mlow * mlow * (1.0 - 1e-9);
    int nc = 0;
    fine_cand *cand = malloc(sizeof *cand * (size_t)(ix1 - ix0 + 1) *
                             (size_t)(iy1 - iy0 + 1));
    if (cand == NULL) { /* out of memory: the box's corner */
        P->rad = hypot(P->hx, P->hy);
        free(f);
        return;
    }
    for (int iy = iy0; iy <= iy1; iy++)
        for (int ix = ix0; ix <= ix1; ix++) {
            int k = iy * G_FINE + ix;
            double dx = fine_x(f, ix) - P->cx, dy = fine_y(f, iy);
            if (f->st[k] != ST_FAIL && !(dx * dx + dy * dy < low2))
                cand[nc++] = (fine_cand){hypot(dx, dy), k};
        }
    qsort(cand, (size_t)nc, sizeof *cand, by_dist_desc);
    double m = mlow;
    for (int i = 0; i < nc; i++) {
        if (f->st[cand[i].k] == ST_UNKNOWN) {
            for (int t = i; t < nc && f->nq < 16; t++)
                fine_push(f, cand[t].k);
            fine_flush(f);
        }
        if (f->st[cand[i].k] == ST_PASS) {
            m = fmax(m, cand[i].dist);
            break;
        }
    }
    free(cand);
    free(f);
    P->rad = m + margin;
}

/* Fills c->lens's pupil table, from the lens's cache when it has it. */
static void pupils(lr__cam *c, int colours)
{
    lr__lens_cam *lc = &c->lens;
    lr_lens *L = (lr_lens *)lc->L; /* the cache is mutable, under L->mu */
    double key[6] = {
        lc->z_sensor,   lc->stop_scale,
        lc->pupil_rmax, colours + 10.0 * c->chroma.amplify,
        lc->z_rear,     lc->coat == NULL ? -1.0 : (double)lc->coat->kind};
    pthread_mutex_lock(&L->mu);
    for (int i = 0; i < L->n_pupils; i++) {
        const lr__pupil_entry *e = &L->pupils[i];
        if (memcmp(e->key, key, sizeof key) == 0) {
            memcpy(lc->pupil, e->p, sizeof lc->pupil);
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
        lr__lens_indices(c, 380.0, n_lo);
        lr__lens_indices(c, 780.0, n_hi);
        j.nsets[j.n_sets++] = n_lo;
        j.nsets[j.n_sets++] = n_hi;
    }
    double E0 = 0.0;
    for (int k = 0; k <= LR__PUPIL_N; k++)
        pupil_point(&j, lc->pupil_rmax * k / LR__PUPIL_N, &lc->pupil[k],
                    k == 0 ? &E0 : NULL);
    lc->inv_E0 = E0 > 0.0 ? 1.0 / E0 : 0.0;

    pthread_mutex_lock(&L->mu);
    lr__pupil_entry *e = &L->pupils[L->next_pupil];
    memcpy(e->key, key, sizeof key);
    memcpy(e->p, lc->pupil, sizeof lc->pupil);
    e->inv_E0 = lc->inv_E0;
    L->next_pupil = (L->next_pupil + 1) % LR__PUPIL_CACHE;
    if (L->n_pupils < LR__PUPIL_CACHE)
        L->n_pupils++;
    pthread_mutex_unlock(&L->mu);
}

static lr__pupil pupil_at(const lr__lens_cam *lc, double r);

lr__pupil lr__lens_pupil_at(const lr__lens_cam *lc, double r)
{
    return pupil_at(lc, r);
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
    pupils(c, colours);
    for (int k = 0; k < LR__PUPIL_N; k++) {
        lr__pupil a = pupil_at(lc, lc->pupil_rmax * k / LR__PUPIL_N);
        lc->band_cx[k] = (float)a.cx;
        lc->band_dcx[k] = (float)(lc->pupil[k + 1].cx - lc->pupil[k].cx);
        lc->band_rad[k] = (float)a.rad;
        lc->band_hx[k] = (float)a.hx;
        lc->band_hy[k] = (float)a.hy;
    }
}

/* ---- rays ----------------------------------------------------------------------- */

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

/* Film point (fx, fy) on the sensor, in mm (top of file), with its
 * distance from the axis and the unit vector of its radial direction. */
typedef struct sensor_pt {
    double x, y, r, ex, ey;
} sensor_pt;

static sensor_pt sensor_at(const lr__cam *c, double fx, double fy)
{
    const lr__lens_cam *lc = &c->lens;
    sensor_pt p;
    p.x = (0.5 - fx / c->width) * lc->sensor_w;
    p.y = (fy / c->height - 0.5) * lc->sensor_h;
    p.r = hypot(p.x, p.y);
    p.ex = p.r > 0.0 ? p.x / p.r : 1.0;
    p.ey = p.r > 0.0 ? p.y / p.r : 0.0;
    return p;
}

/* The bounds at film radius r, between the table's two neighbouring
 * entries a and b: centred in proportion, as large as the larger of the
 * two plus half the distance their centres move.  Sizes interpolated in
 * proportion fall short where an element starts to cut the pupil (it
 * shrinks fast there): a white scene came out 3.5% dark in rings. */
static lr__pupil pupil_at(const lr__lens_cam *lc, double r)
{
    double t = r / lc->pupil_rmax * LR__PUPIL_N;
    int k = (int)t;
    k = k < LR__PUPIL_N - 1 ? k : LR__PUPIL_N - 1;
    double f = t - k;
    const lr__pupil *a = &lc->pupil[k], *b = &lc->pupil[k + 1];
    double move = 0.5 * fabs(b->cx - a->cx);
    return (lr__pupil){a->cx + f * (b->cx - a->cx), fmax(a->rad, b->rad) + move,
                       fmax(a->hx, b->hx) + move, fmax(a->hy, b->hy)};
}

/* The first half of a camera ray: the sensor point, the point aimed at
 * in the smaller of the film radius's two bounds (a disk by the
 * concentric map, or a rectangle: both uniform by area), the unit
 * direction, and the sample's weight before the lens has its say (0: the
 * bounds are empty). */
static double lens_start(const lr__cam *c, double fx, double fy,
                         const double u[2], double o[3], double d[3])
{
    const lr__lens_cam *lc = &c->lens;
    sensor_pt sp = sensor_at(c, fx, fy);
    double xs = sp.x, ys = sp.y, ex = sp.ex, ey = sp.ey;
    lr__pupil P = pupil_at(lc, sp.r);
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

/* The transmittance table for the indices n (one of the camera's sets),
 * or NULL for indices at another wavelength (then R is computed at the
 * ray's own). */
static const lr__ttab *ttab_for(const lr__lens_cam *lc, const double *n)
{
    if (n == lc->n_ref)
        return &lc->t_ref;
    for (int k = 0; k < 3; k++)
        if (n == lc->n_rgb[k] && lc->t_rgb_ok)
            return &lc->t_rgb[k];
    return NULL;
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
            lr__lens_indices(c, nm, nbuf);
            n = nbuf;
        }
    }
    double o[3], d[3], T = 0.0;
    double wt = lens_start(c, fx, fy, u, o, d);
    if (wt > 0.0 && lr__rx_trace_t(&L->rx, L->z, n, lc->stop_scale, 0,
                                   ttab_for(lc, n), nm, lc->coat, o, d, &T)) {
        to_world(c, o, d, org, dir);
        return wt * T;
    }
    *org = c->origin;
    *dir = c->forward;
    return 0.0;
}

/* Film point (fx, fy) on the sensor (sensor_at's, in float: iw, ih the
 * frame's inverse size, sw, sh the sensor's) and its interval of the
 * pupil table (kr: intervals per mm): the interval, with the point's
 * radius r and its place f in [0, 1) along the interval. */
static inline __attribute__((always_inline)) int
film_band(float fx, float fy, float iw, float ih, float sw, float sh, float kr,
          float *xs, float *ys, float *r, float *f)
{
    *xs = (0.5f - fx * iw) * sw, *ys = (fy * ih - 0.5f) * sh;
    *r = sqrtf(*xs * *xs + *ys * *ys);
    float t = *r * kr;
    int k = (int)t;
    k = k < LR__PUPIL_N - 1 ? k : LR__PUPIL_N - 1;
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
        /* pupil_at's bounds, from the interval's table. */
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
        alive[i] = (i < n) & (area > 0.0f);
    }
}

/* lens_start16 for a block whose plan skips the lens (lens_blur.c's
 * bound: the spot is under a quarter pixel): each lane's chief ray,
 * through the centre of its pupil bounds as lens_chief's, weighted by
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
        alive[i] = (i < n) & (w[i] > 0.0f);
    }
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
 * (lens_start and lens_ray's arithmetic lane by lane, the disk from the
 * packet aperture map, the glass from lr__rx_trace16f): the same
 * distribution as lens_ray's, not the same bits.  Up to four packets go
 * through the glass together (rx_trace16f.c says why); each lane's ray is
 * the one its packet would have alone. */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
lens_rays16_n(const lr__cam *c, int use_lens, int np, const int *ns,
              const float (*fx)[16], const float (*fy)[16],
              const float (*lu)[16], const float (*lv)[16],
              struct RTCRayHit16 *rh, float (*wt)[16])
{
    /* Without the lens (the plan's bound allows it), chief rays. */
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
    int alive[LR__RX_LANES];
    for (int p = 0; p < np; p++) {
        float o16[3][16], d16[3][16];
        if (bl != NULL)
            chief_start16(c, bl, ns[p], fx[p], fy[p], o16, d16, w + 16 * p,
                          alive + 16 * p);
        else
            lens_start16(c, ns[p], fx[p], fy[p], lu[p], lv[p], o16, d16,
                         w + 16 * p, alive + 16 * p);
        for (int a = 0; a < 3; a++) {
            memcpy(&o[a][16 * p], o16[a], sizeof o16[a]);
            memcpy(&d[a][16 * p], d16[a], sizeof d16[a]);
        }
    }
    lr__rx_trace16f(&c->lens.L->rx, c->lens.L->z, c->lens.n_ref,
                    c->lens.stop_scale, 16 * np, o, d, alive, &c->lens.t_ref,
                    w);
    for (int p = 0; p < np; p++) {
        float o16[3][16], d16[3][16];
        for (int a = 0; a < 3; a++) {
            memcpy(o16[a], &o[a][16 * p], sizeof o16[a]);
            memcpy(d16[a], &d[a][16 * p], sizeof d16[a]);
        }
        lens_finish16(c, (const float(*)[16])o16, (const float(*)[16])d16,
                      w + 16 * p, alive + 16 * p, &rh[p], wt[p]);
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

/* The ray from the film point through the middle of its exit-pupil
 * bounds (the stop's centre, near enough, for depth and autofocus); the
 * frame's pinhole ray where that is blocked. */
static void lens_chief(const lr__cam *c, double fx, double fy, lr__v3 *org,
                       lr__v3 *dir)
{
    const lr__lens_cam *lc = &c->lens;
    sensor_pt sp = sensor_at(c, fx, fy);
    double xs = sp.x, ys = sp.y, ex = sp.ex, ey = sp.ey;
    lr__pupil P = pupil_at(lc, sp.r);
    double o[3] = {xs, ys, lc->z_sensor};
    double d[3] = {ex * P.cx - xs, ey * P.cx - ys, lc->z_rear - lc->z_sensor};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; a++)
        d[a] /= len;
    if (P.rad > 0.0 && lr__rx_trace_n(&lc->L->rx, lc->L->z, lc->n_ref,
                                      lc->stop_scale, 0, o, d)) {
        to_world(c, o, d, org, dir);
        return;
    }
    *org = c->origin;
    *dir = v3_norm(v3_madd(
        v3_madd(c->forward, c->right, (2.0 * fx / c->width - 1.0) * c->half_w),
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

/* ---- the light side (camera.h: lens_point, film) --------------------------
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

static lr__v3 lens_at(const lr__cam *c, double ox, double oy)
{
    double o[3] = {ox, oy, c->lens.L->z[0]}, d[3] = {0, 0, 1};
    lr__v3 org, dir;
    to_world(c, o, d, &org, &dir);
    return org;
}

static lr__v3 lens_point(const lr__cam *c, const double u[2], double *ox,
                         double *oy)
{
    double a, b, rho = front_disk(&c->lens);
    lr__aperture_sample(LR_APERTURE_DISK, 0, 0.0, 1.0, u, &a, &b);
    *ox = a * rho, *oy = b * rho;
    return lens_at(c, *ox, *oy);
}

static double lens_ghost_disk(const lr__cam *c)
{
    return front_disk(&c->lens);
}

static double lens_film_n(const lr__cam *c, const double *n, double nm,
                          double ox, double oy, lr__v3 w, double *fx,
                          double *fy);

static double lens_film(const lr__cam *c, double ox, double oy, lr__v3 w,
                        double *fx, double *fy)
{
    return lens_film_n(c, c->lens.n_ref, c->nm_ref, ox, oy, w, fx, fy);
}

/* rgb mode: channel k at its wavelength (nm_rgb), as the camera traces
 * it; the pupil bounds hold every channel (pupils). */
static double lens_film_rgb(const lr__cam *c, int k, double ox, double oy,
                            lr__v3 w, double *fx, double *fy)
{
    return lens_film_n(c, c->lens.n_rgb[k], c->lens.nm_rgb[k], ox, oy, w, fx,
                       fy);
}

/* Spectral mode: at wavelength nm, as lens_ray traces it (the focus
 * power w plays no part in a traced lens). */
static double lens_film_wl(const lr__cam *c, double w, double nm, double ox,
                           double oy, lr__v3 d, double *fx, double *fy)
{
    (void)w;
    double n[LR__RX_MAX_SURFACES];
    lr__lens_indices(c, nm, n);
    return lens_film_n(c, n, nm, ox, oy, d, fx, fy);
}

/* lens_film with the surfaces' indices n at wavelength nm (the
 * surfaces' reflectance, where no table holds n: ttab_for). */
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
    if (!lr__rx_trace_t(&L->rx, L->z, n, lc->stop_scale, 1, ttab_for(lc, n), nm,
                        lc->coat, o, d, &T) ||
        !(d[2] > 0.0))
        return 0.0;
    double t = (lc->z_sensor - o[2]) / d[2];
    double xs = o[0] + t * d[0], ys = o[1] + t * d[1];
    *fx = (0.5 - xs / lc->sensor_w) * c->width;
    *fy = (ys / lc->sensor_h + 0.5) * c->height;
    /* Where the camera aims from this sensor point: the line's point on
     * the rear plane, inside the bounds it samples (lens_start). */
    sensor_pt sp = sensor_at(c, *fx, *fy);
    lr__pupil P = pupil_at(lc, sp.r);
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

static int lens_ghost_paths(const lr__cam *c, double *peak, double *k,
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
    double main = 0.0;
    int n = lr__ghost_fluxes_t(&lc->L->rx, lc->n_ref, &lc->t_ref, c->nm_ref,
                               lc->stop_scale, lc->coat, 0.0, 12,
                               lc->pupil_rmax, gf, &main);
    double A_pix = lc->sensor_w * lc->sensor_h / (c->width * c->height);
    /* The main image of a distant source of radiance L filling a small
     * solid angle Omega on axis: L Omega times the main path's
     * transmission over the front, each ray worth lens_film_n's inv_E0
     * cos A / A_pix in pixels (cos = 1).  Its own 64 x 64 beam (some 2
     * ms): the stop's disc covers a few of the 12 x 12 beam's cells. */
    *k = lc->inv_E0 *
         lr__ghost_main_area(&lc->L->rx, lc->n_ref, &lc->t_ref, c->nm_ref,
                             lc->stop_scale, lc->coat, 64) /
         A_pix;
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

static double lens_ghost_film(const lr__cam *c, int g, int k, double ox,
                              double oy, lr__v3 w, double *fx, double *fy)
{
    const lr__lens_cam *lc = &c->lens;
    /* The glass's own dispersion at nm (chromatic.amplify plays no part
     * in a ghost). */
    int rgb = k >= 0 && k < 3 && c->chroma.mode != LR_CHROMATIC_OFF;
    double nm = rgb ? lc->nm_rgb[k] : c->nm_ref;
    const double *n_after = rgb ? lc->g_n[k] : lc->n_ref;
    const lr__ttab *tab = rgb ? &lc->g_tab[k] : &lc->t_ref;
    const lr_lens *L = lc->L;
    double d[3] = {-v3_dot(w, c->right), -v3_dot(w, c->up),
                   v3_dot(w, c->forward)};
    if (!(d[2] > 0.0) || g < 0 || g >= lc->n_ghost)
        return 0.0;
    double cos_o = d[2];
    double back = (L->rx.s[0].semi_aperture + 1.0) / d[2];
    double o[3] = {ox - back * d[0], oy - back * d[1], L->z[0] - back * d[2]};
    double hit[2], T = 0.0;
    double clip[2] = {0.5 * lc->sensor_w, 0.5 * lc->sensor_h};
    if (!lr__ghost_trace_t(&L->rx, L->z, n_after, tab, nm, lc->stop_scale,
                           lc->coat, ghost_at(g), lc->z_sensor, clip, o, d, hit,
                           &T))
        return 0.0;
    *fx = (0.5 - hit[0] / lc->sensor_w) * c->width;
    *fy = (hit[1] / lc->sensor_h + 0.5) * c->height;
    double rho = front_disk(lc);
    double A_pix = lc->sensor_w * lc->sensor_h / (c->width * c->height);
    return lc->inv_E0 * cos_o * M_PI * rho * rho / A_pix * T;
}

/* The light side's plan (light_trace.c) sees the lens as a thin lens of
 * the entrance pupil's radius at the eye focused at the focus distance:
 * an estimate of how large a light's disc is, not a bound. */
static void lens_thin_equiv(const lr__cam *c, lr__lens_bound *b)
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
static int lens_light_ok(const lr__cam *c)
{
    return lr__lens_front_slope(c->lens.L) < 4.0;
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
    .rays16_n = lens_rays16_n,
    .chief = lens_chief,
    .focus_at = focus_at,
    .bound = NULL,
    .lens_point = lens_point,
    .film = lens_film,
    .film_rgb = lens_film_rgb,
    .film_wl = lens_film_wl,
    .thin_equiv = lens_thin_equiv,
    .light_ok = lens_light_ok,
    .blur = lr__lens_blur_get,
    .ghost_paths = lens_ghost_paths,
    .ghost_film = lens_ghost_film,
    .ghost_disk = lens_ghost_disk,
    .lens_at = lens_at,
};
