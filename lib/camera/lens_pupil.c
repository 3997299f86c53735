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

/* camera_lens.h. */
void lr__pupil_passes16(const lr__cam *c, const double *const *nsets,
                        int n_sets, double r, int m, const double *x,
                        const double *y, int *ok, double *cos4)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double o[3][16], d[3][16], dz = lc->z_rear - lc->z_sensor;
    int alive[16];
    for (int i = 0; i < 16; i++)
        ok[i] = 0;
    for (int k = 0; k < n_sets; k++) {
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
        lr__rx_trace16(&L->rx, L->z, nsets[k], lc->stop_scale, o, d, alive);
        for (int i = 0; i < m; i++)
            ok[i] |= alive[i];
    }
}

/* lr__pupil_passes16 (above) for the job's index sets. */
static void passes16(const pupil_job *j, double r, int m, const double *x,
                     const double *y, int *ok, double *cos4)
{
    lr__pupil_passes16(j->c, j->nsets, j->n_sets, r, m, x, y, ok, cos4);
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

/* ---- the bounds refined: the pupil's edge by bisection ----------------------
 *
 * The grid's bounds reach a fine cell past the outermost points that pass
 * (pupil_point): at f/11 the double Gauss's pupil is 3.3 mm across and a
 * cell 0.05 mm, so one ray in nine missed the pupil on the axis, and every
 * blurred pixel paid for it in noise (a lost ray weighs 0).  Here the
 * pupil's edge is found along PR_DIRS directions from the bounds' centre
 * (cx, 0), to PR_ITER halvings, and the pupil is bounded by the polygon
 * those edge points and their "apexes" make: for a convex region K and
 * points p[j] on its edge in angular order, the edge between p[j] and
 * p[j + 1] lies in the triangle of the chord and the two neighbouring
 * chords' extensions past p[j] and p[j + 1] (a supporting line cannot
 * cross a chord's extension inside K), so K lies inside the polygon of the
 * p[j] and the apexes q[j] where those extensions meet.  A lens's
 * pupil at one wavelength is an intersection of the apertures' images,
 * each nearly a disk: convex.  Each index set is refined alone (a union of
 * shifted disks is not convex) and the bounds are the largest.  Where a
 * premise fails (the centre does not pass, an edge lies beyond the grid's
 * bounds, two extensions do not meet), the grid's bounds stand.
 * tests/test_camera_lens.c checks every passing ray of dense grids at
 * radii between the table's entries inside the bounds pupil_at gives. */

#define PR_HALF 64            /* directions in the upper half plane */
#define PR_DIRS (2 * PR_HALF) /* the pupil is symmetric in y */
#define PR_ITER 20

/* The edge along the upper half's directions for one index set; 0 when a
 * premise fails. */
static int pupil_edges(const pupil_job *j1, double r, double cx, double hi,
                       double *ex, double *ey)
{
    double x[16], y[16], c4[16], lo[16], up[16], ca[16], sa[16];
    int ok[16];
    /* The centre must pass. */
    x[0] = cx, y[0] = 0.0;
    passes16(j1, r, 1, x, y, ok, c4);
    if (!ok[0])
        return 0;
    for (int b = 0; b < PR_HALF; b += 16) {
        for (int i = 0; i < 16; i++) {
            double th = M_PI * (b + i + 0.5) / PR_HALF;
            ca[i] = cos(th), sa[i] = sin(th);
            lo[i] = 0.0, up[i] = hi;
            x[i] = cx + hi * ca[i], y[i] = hi * sa[i];
        }
        /* The far end must fail. */
        passes16(j1, r, 16, x, y, ok, c4);
        for (int i = 0; i < 16; i++)
            if (ok[i])
                return 0;
        for (int it = 0; it < PR_ITER; it++) {
            double mid[16];
            for (int i = 0; i < 16; i++) {
                mid[i] = 0.5 * (lo[i] + up[i]);
                x[i] = cx + mid[i] * ca[i], y[i] = mid[i] * sa[i];
            }
            passes16(j1, r, 16, x, y, ok, c4);
            for (int i = 0; i < 16; i++) {
                if (ok[i])
                    lo[i] = mid[i];
                else
                    up[i] = mid[i];
            }
        }
        /* The failing end: on or just past the edge. */
        for (int i = 0; i < 16; i++)
            ex[b + i] = cx + up[i] * ca[i], ey[b + i] = up[i] * sa[i];
    }
    return 1;
}

/* The polygon of the edge points (ex, ey) (PR_DIRS of them, in angular
 * order) and their apexes, in (px, py); 0 when the edge points do not
 * turn left at every one (the pupil is not convex) or two extensions do
 * not meet ahead. */
static int pupil_polygon(const double *ex, const double *ey, double *px,
                         double *py)
{
    for (int j = 0; j < PR_DIRS; j++) {
        int a = (j + PR_DIRS - 1) % PR_DIRS, b = (j + 1) % PR_DIRS,
            c = (j + 2) % PR_DIRS;
        double turn = (ex[j] - ex[a]) * (ey[b] - ey[j]) -
                      (ey[j] - ey[a]) * (ex[b] - ex[j]);
        if (!(turn > 0.0))
            return 0;
        /* p[j] + s (p[j] - p[a]) = p[b] + t (p[b] - p[c]), s, t >= 0. */
        double dx = ex[j] - ex[a], dy = ey[j] - ey[a];
        double fx = ex[b] - ex[c], fy = ey[b] - ey[c];
        double gx = ex[b] - ex[j], gy = ey[b] - ey[j];
        double det = dx * -fy - dy * -fx;
        if (!(fabs(det) > 0.0))
            return 0;
        double s = (gx * -fy - gy * -fx) / det;
        double t = (dx * gy - dy * gx) / det;
        if (!(s >= 0.0 && t >= 0.0 && s <= 1.0 && t <= 1.0))
            return 0;
        px[2 * j] = ex[j], py[2 * j] = ey[j];
        px[2 * j + 1] = ex[j] + s * dx, py[2 * j + 1] = ey[j] + s * dy;
    }
    return 1;
}

/* Replaces the grid's bounds *P by the edge polygon's (above) when every
 * index set's premises hold; `cell` is the fine grid's cell. */
static void pupil_refine(const pupil_job *j, double r, double cell,
                         lr__pupil *P)
{
    if (!(P->rad > 0.0))
        return;
    double hi = P->rad + 2.0 * cell;
    double ex[PR_DIRS], ey[PR_DIRS], px[2 * PR_DIRS], py[2 * PR_DIRS];
    double x0 = INFINITY, x1 = -INFINITY, yh = 0.0;
    /* Every index set's polygon (pupil_job holds at most four sets). */
    double pts[4 * 2 * PR_DIRS][2];
    int np = 0;
    for (int k = 0; k < j->n_sets; k++) {
        pupil_job j1 = {j->c, {j->nsets[k]}, 1};
        if (!pupil_edges(&j1, r, P->cx, hi, ex, ey))
            return;
        /* The lower half mirrors the upper, in angular order. */
        for (int i = 0; i < PR_HALF; i++) {
            ex[PR_HALF + i] = ex[PR_HALF - 1 - i];
            ey[PR_HALF + i] = -ey[PR_HALF - 1 - i];
        }
        if (!pupil_polygon(ex, ey, px, py))
            return;
        for (int i = 0; i < 2 * PR_DIRS; i++) {
            x0 = fmin(x0, px[i]), x1 = fmax(x1, px[i]);
            yh = fmax(yh, fabs(py[i]));
            pts[np][0] = px[i], pts[np][1] = py[i];
            np++;
        }
    }
    /* The bisection's last step and rounding: a millionth of the size. */
    double margin = 1e-6 * hi;
    lr__pupil R;
    R.cx = 0.5 * (x0 + x1);
    R.hx = 0.5 * (x1 - x0) + margin;
    R.hy = yh + margin;
    double m = 0.0;
    for (int i = 0; i < np; i++)
        m = fmax(m, hypot(pts[i][0] - R.cx, pts[i][1]));
    R.rad = m + margin;
    /* The grid's outermost passing points (its bounds less their cell)
     * must be inside: a pupil that is not convex can hide its far side
     * from every direction's first crossing and still turn left. */
    double gx0 = P->cx - (P->hx - cell), gx1 = P->cx + (P->hx - cell);
    if (!(x0 <= gx0 && x1 >= gx1 && R.hy >= P->hy - cell &&
          R.rad + fabs(R.cx - P->cx) >= P->rad - cell))
        return;
    *P = R;
}

/* Where every coarse point missed: the box about the pupil the seed
 * search finds (lens_pupil_seed.c), if any, and its cell. */
static void seed_box(const pupil_job *j, double r, double S, extent *co,
                     double *cell)
{
    double box[4];
    if (lr__pupil_seed(j->c, j->nsets, j->n_sets, r, S, *cell, box, cell))
        co->x0 = box[0], co->x1 = box[1], co->y0 = box[2], co->y1 = box[3];
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
    if (!(co.x0 <= co.x1))
        seed_box(j, r, S, &co, &cell);
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
    /* The extremes, from the outside in.  A pupil that is a thin sliver
     * can pass at a coarse point or two and reach past the fine grid's
     * box (a zoom's corner: 3.5 mm tall, the box 2.4): where the points
     * that pass touch the box's edge, the box grows threefold, at most
     * three times. */
    int ix0, ix1, iy0, iy1;
    for (int grow = 0;; grow++) {
        f->j = j, f->r = r, f->x0 = x0, f->y0 = y0, f->cw = cxw, f->ch = cyw;
        memset(f->st, ST_UNKNOWN, sizeof f->st);
        f->nq = 0;
        ix0 = 0, ix1 = G_FINE - 1, iy0 = 0, iy1 = G_FINE - 1;
        while (ix0 < G_FINE && !fine_line(f, 1, ix0, 0, G_FINE - 1))
            ix0++;
        if (ix0 == G_FINE)
            break;
        while (!fine_line(f, 1, ix1, 0, G_FINE - 1))
            ix1--;
        while (!fine_line(f, 0, iy0, ix0, ix1))
            iy0++;
        while (!fine_line(f, 0, iy1, ix0, ix1))
            iy1--;
        if (grow == 3 ||
            (ix0 > 0 && ix1 < G_FINE - 1 && iy0 > 0 && iy1 < G_FINE - 1))
            break;
        double w = x1 - x0, h = y1 - y0;
        x0 -= w, x1 += w, y0 -= h, y1 += h;
        cxw = (x1 - x0) / G_FINE, cyw = (y1 - y0) / G_FINE;
    }
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
    if (ix0 == G_FINE) { /* too thin for the fine grid: the coarse box */
        P->cx = 0.5 * (x0 + x1);
        P->hx = 0.5 * (x1 - x0), P->hy = fmax(y1, -y0);
        P->rad = hypot(P->hx, P->hy);
        free(f);
        return;
    }
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
    pupil_refine(j, r, margin, P);
}

void lr__pupil_refine(const lr__cam *c, const double *const *nsets, int n_sets,
                      double r, double cell, lr__pupil *P)
{
    pupil_job j = {c, {NULL}, 0};
    for (int k = 0; k < n_sets && k < 4; k++)
        j.nsets[j.n_sets++] = nsets[k];
    pupil_refine(&j, r, cell, P);
}

/* ---- between the table's entries -----------------------------------------
 *
 * lr__lens_pupil_at centres the bounds in proportion between two entries
 * and takes the larger sizes.  Between them the true centre and sizes
 * bend away from that by at most h^2 / 8 max |f''| (linear
 * interpolation's error; at a kink, where an element starts to cut the
 * pupil, at most a quarter of the slope's jump times h), and the second
 * difference f[k-1] - 2 f[k] + f[k+1] is h^2 f'' (the slope's jump times
 * h at a kink).  So an interval grows by half the larger second
 * difference at its two ends, twice what the error can be, the centre's
 * added to rad and hx.  It replaced half the distance the centre moves
 * across the interval, which at f/11 made the double Gauss's bounds 4%
 * wider than its pupil on the axis.  Where an entry nearby is empty (no
 * ray passes), the old rule stands.  Entry -1 mirrors entry 1 (the table
 * is even in r: cx odd, the sizes even). */
static double pupil_field(const lr__pupil *p, int k, int field)
{
    double sign = k < 0 && field == 0 ? -1.0 : 1.0;
    const lr__pupil *e = &p[k < 0 ? -k : k];
    double v = field == 0   ? e->cx
               : field == 1 ? e->rad
               : field == 2 ? e->hx
                            : e->hy;
    return sign * v;
}

static double second_diff(const lr__pupil *p, int k, int field)
{
    return fabs(pupil_field(p, k - 1, field) - 2.0 * pupil_field(p, k, field) +
                pupil_field(p, k + 1, field));
}

static void pupil_growth(lr__lens_cam *lc)
{
    const lr__pupil *p = lc->pupil;
    for (int k = 0; k < LR__PUPIL_N; k++) {
        int lo = k > 0 ? k - 1 : 1, hi = k + 2 <= LR__PUPIL_N ? k + 2 : k + 1;
        int empty = 0;
        for (int i = lo; i <= hi; i++)
            empty |= !(p[i].rad > 0.0);
        empty |= !(p[k].rad > 0.0);
        lr__pupil *g = &lc->pupil_grow[k];
        if (empty) {
            double move = 0.5 * fabs(p[k + 1].cx - p[k].cx);
            *g = (lr__pupil){0.0, move, move, 0.0};
            continue;
        }
        /* Second differences at k and at k + 1 (where it has a right
         * neighbour), per field: cx, rad, hx, hy. */
        double d[4];
        for (int f = 0; f < 4; f++) {
            d[f] = second_diff(p, k, f);
            if (k + 2 <= LR__PUPIL_N)
                d[f] = fmax(d[f], second_diff(p, k + 1, f));
        }
        *g = (lr__pupil){0.0, 0.5 * (d[0] + d[1]), 0.5 * (d[0] + d[2]),
                         0.5 * d[3]};
    }
}

/* Fills c->lens's pupil table, from the lens's cache when it has it. */
void lr__lens_pupils(lr__cam *c, int colours)
{
    lr__lens_cam *lc = &c->lens;
    lr_lens *L = (lr_lens *)lc->L; /* the cache is mutable, under L->mu */
    /* The colour set and amplify apart: as one number (colours + 10
     * amplify) no colours at 1.0 and rgb at 0.9 were one key, and a
     * daemon's rgb job could take bounds traced for one colour. */
    double key[7] = {lc->z_sensor,
                     lc->stop_scale,
                     lc->pupil_rmax,
                     colours,
                     c->chroma.amplify,
                     lc->z_rear,
                     lc->coat == NULL ? -1.0 : (double)lc->coat->kind};
    pthread_mutex_lock(&L->mu);
    for (int i = 0; i < L->n_pupils; i++) {
        const lr__pupil_entry *e = &L->pupils[i];
        if (memcmp(e->key, key, sizeof key) == 0) {
            memcpy(lc->pupil, e->p, sizeof lc->pupil);
            lc->inv_E0 = e->inv_E0;
            pthread_mutex_unlock(&L->mu);
            pupil_growth(lc);
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
    pupil_growth(lc);

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
