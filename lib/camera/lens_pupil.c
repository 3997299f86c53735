/*
 * lens_pupil.c: the real lens's exit-pupil bounds, one per film radius
 * (camera_lens.h).  For each of LR__PUPIL_N + 1 radii, the disk and the
 * rectangle on the rear plane that hold every ray from that sensor point
 * which gets through the lens (pbrt-v4's RealisticCamera bounds the exit
 * pupil the same way, by tracing a grid; Kolb et al. 1995, section 3.2).
 * Made once per lens, focus, stop, colours and coating, and kept in the
 * lens's cache (lens_load.h) so every job in the daemon shares them.
 */
#include "camera/camera_lens.h"
#include "optics/ghost.h"
#include "optics/lens.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

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
void lr__lens_pupils(lr__cam *c, int colours)
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
