/*
 * lens_blur.c: the planner's bound for a real lens (camera.h,
 * lr__lens_blur; the proof and its measurements: docs/plan-lens.md).
 *
 * Every ray leaving the front of the lens is a straight line.  In the
 * lens's frame, with zeta the depth in front of the sensor (mm) and x =
 * 1 / zeta, a ray's lateral point at depth zeta is p + zeta s (s its
 * slope, p where it would cross the sensor's plane), so on the "image
 * plane at distance 1" it is at s + p x: affine in x.  So is the chief
 * ray's, and so is the chief ray's derivative along the film, J(x) =
 * J_s + J_p x (radially, from a neighbouring chief ray; tangentially,
 * the chief ray's point over the film radius, by symmetry).  A sample's
 * distance from the chief ray's point in film mm is then
 *
 *     delta(x) = ((s - s0) + (p - p0) x) / (J_s + J_p x)
 *
 * per component: a Moebius function of x, monotone wherever J has no
 * zero.  So on any interval of x where J keeps its sign, |delta| is
 * largest at an end; and at an end x_e inside a cell [x_j, x_j+1] of
 * the table's grid, |delta(x_e)| is at most its larger value at the
 * cell's ends.  The table stores, at each grid point, the largest
 * |delta| over the traced rays; the bound over a depth range is the
 * table's largest at the four grid points around its two ends, with no
 * assumption on how the spot varies in between (near focus it falls to
 * a waist and grows again: nonmonotone, which the argument allows).
 * The grid's x_max is chosen so that J has no zero on [0, x_max].
 *
 * What is sampled, and what the margin covers: the pupil (a grid and
 * its rim), the colours (the camera's), the film radius (the pupil
 * table's radii; a block takes the largest over the radii around those
 * it spans) and the linearised film map (J over a fraction
 * of a pixel).  test_lens_blur.c samples the real spot at random film
 * points, depths and pupil points on every shipped and test lens and
 * checks it against the bound.
 */
#include "camera/lens_blur.h"
#include "optics/lens_load.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#define G 32 /* pupil grid side, for the spot */
/* (the chief ray's weight: LR__CHIEF_GW, lens_chief.c) */
#define RIM 64    /* points on the pupil bounds' rim */
#define MAX_COL 6 /* the reference and up to 5 wavelengths */
/* fmax without its NaN rules (the table's values are finite), which
 * GCC inlines. */
#define MAX(a, b) ((a) > (b) ? (a) : (b))

/* A ray out of the front: point on the image plane s + p x. */
typedef struct line {
    double sx, sy, px, py;
} line;

/* Traces the ray from sensor point (r, 0) toward rear-plane point (a, b)
 * with indices n; its line, and its transmittance when tab is given.
 * 0 when the lens stops it or it does not leave forward. */
static int trace_line(const lr__cam *c, const double *n, const lr__ttab *tab,
                      double r, double a, double b, line *l, double *T,
                      double *cos4)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double dz = lc->z_rear - lc->z_sensor;
    double o[3] = {r, 0.0, lc->z_sensor}, d[3] = {a - r, b, dz};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        d[k] /= len;
    if (cos4 != NULL) {
        double ct = -d[2];
        *cos4 = ct * ct * ct * ct;
    }
    int ok = tab != NULL
                 ? lr__rx_trace_t(&L->rx, L->z, n, lc->stop_scale, 0, tab,
                                  c->nm_ref, lc->coat, o, d, T)
                 : lr__rx_trace_n(&L->rx, L->z, n, lc->stop_scale, 0, o, d);
    if (!ok || !(d[2] < -1e-6))
        return 0;
    double zeta0 = lc->z_sensor - o[2];
    l->sx = d[0] / -d[2];
    l->sy = d[1] / -d[2];
    l->px = o[0] - zeta0 * l->sx;
    l->py = o[1] - zeta0 * l->sy;
    return 1;
}

/* trace_line for m rays at once (lr__rx_trace16: the same rays), without
 * transmittance: lines l[i] and ok[i] for rear-plane points q[2i..]. */
static void trace_lines16(const lr__cam *c, const double *n, double r,
                          const double *q, int m, line *l, unsigned char *ok)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double dz = lc->z_rear - lc->z_sensor;
    for (int i0 = 0; i0 < m; i0 += 16) {
        double o[3][16], d[3][16];
        int alive[16];
        for (int i = 0; i < 16; i++) {
            int at = i0 + i < m ? i0 + i : i0;
            double dx = q[2 * at] - r, dy = q[2 * at + 1];
            double len = sqrt(dx * dx + dy * dy + dz * dz);
            o[0][i] = r, o[1][i] = 0.0, o[2][i] = lc->z_sensor;
            d[0][i] = dx / len, d[1][i] = dy / len, d[2][i] = dz / len;
            alive[i] = i0 + i < m;
        }
        lr__rx_trace16(&L->rx, L->z, n, lc->stop_scale, o, d, alive);
        for (int i = 0; i < 16 && i0 + i < m; i++) {
            line *li = &l[i0 + i];
            ok[i0 + i] = (unsigned char)(alive[i] && d[2][i] < -1e-6);
            if (!ok[i0 + i])
                continue;
            double zeta0 = lc->z_sensor - o[2][i];
            li->sx = d[0][i] / -d[2][i];
            li->sy = d[1][i] / -d[2][i];
            li->px = o[0][i] - zeta0 * li->sx;
            li->py = o[1][i] - zeta0 * li->sy;
        }
    }
}

/* The camera's colour set: 0 one wavelength, 1 rgb, 2 spectral. */
static int colour_set(const lr__cam *c)
{
    if (!c->chroma_active)
        return 0;
    return c->chroma.mode == LR_CHROMATIC_RGB ? 1 : 2;
}

/* The index sets traced: the reference first, then every colour the
 * camera traces (spectral: 380 to 780 nm every 100). */
static int index_sets(const lr__cam *c, double (*n)[LR__RX_MAX_SURFACES])
{
    const lr__lens_cam *lc = &c->lens;
    int m = 0, rx_n = lc->L->rx.n;
    memcpy(n[m++], lc->n_ref, sizeof(double) * (size_t)rx_n);
    if (colour_set(c) == 1)
        for (int k = 0; k < 3; k++)
            memcpy(n[m++], lc->n_rgb[k], sizeof(double) * (size_t)rx_n);
    else if (colour_set(c) == 2)
        for (double nm = 380.0; nm <= 780.0 + 1e-9; nm += 100.0)
            lr__lens_indices(c, nm, n[m++]);
    return m;
}

typedef struct ray_set {
    int nq, ncol;
    line *l;           /* [ncol][nq] */
    unsigned char *ok; /* [ncol][nq] */
} ray_set;

/* The sampling domain at film radius r (lens_start's: the disk or the
 * rectangle): its half sides about (cx, 0) and whether it is the disk. */
static int domain(const lr__pupil *P, double *hx, double *hy)
{
    double disk = M_PI * P->rad * P->rad, rect = 4.0 * P->hx * P->hy;
    int use_disk = disk <= rect;
    *hx = use_disk ? P->rad : P->hx, *hy = use_disk ? P->rad : P->hy;
    return use_disk;
}

/* Pupil points at film radius r: a G x G grid's cell centres over
 * [a0, a1] x [b0, b1] (offsets from (cx, 0)) inside the sampling domain,
 * then RIM points on the domain's rim.  Returns the number of grid
 * points (the rest are rim points); *q gets 2 doubles a point. */
static int pupil_points(const lr__pupil *P, const double *box, double *q,
                        int *nq)
{
    double hx, hy;
    int use_disk = domain(P, &hx, &hy);
    int m = 0;
    for (int iy = 0; iy < G; iy++)
        for (int ix = 0; ix < G; ix++) {
            double a = box[0] + (ix + 0.5) / G * (box[1] - box[0]);
            double b = box[2] + (iy + 0.5) / G * (box[3] - box[2]);
            if (!lr__pupil_in_domain(P, use_disk, a, b))
                continue;
            q[2 * m] = P->cx + a, q[2 * m + 1] = b;
            m++;
        }
    int grid = m;
    for (int k = 0; k < RIM; k++) {
        double t = 2.0 * M_PI * k / RIM, a, b;
        if (use_disk) {
            a = P->rad * cos(t), b = P->rad * sin(t);
        } else {
            double ca = cos(t), sa = sin(t);
            double sc = fmin(fabs(ca) > 0 ? hx / fabs(ca) : INFINITY,
                             fabs(sa) > 0 ? hy / fabs(sa) : INFINITY);
            a = ca * sc, b = sa * sc;
        }
        q[2 * m] = P->cx + a, q[2 * m + 1] = b;
        m++;
    }
    *nq = m;
    return grid;
}

/* Where in the domain rays get through (at the reference or any colour):
 * the bounding box of a coarse grid's passing points grown by a coarse
 * cell, within the domain's; the fine grid is laid over it, so that a
 * lens stopped down (a pupil far smaller than its bounds) is still
 * sampled finely.  Offsets from (cx, 0); 0 when nothing passes. */
static int passing_box(const lr__cam *c, double (*nsets)[LR__RX_MAX_SURFACES],
                       int ncol, double r, const lr__pupil *P, double *box)
{
    enum { GC = 24 };
    double hx, hy, q[2 * GC * GC];
    int use_disk = domain(P, &hx, &hy), any = 0, m = 0;
    line l[GC * GC];
    unsigned char ok[GC * GC], pass[GC * GC];
    for (int iy = 0; iy < GC; iy++)
        for (int ix = 0; ix < GC; ix++) {
            double a = (2.0 * (ix + 0.5) / GC - 1.0) * hx;
            double b = (2.0 * (iy + 0.5) / GC - 1.0) * hy;
            if (lr__pupil_in_domain(P, use_disk, a, b))
                q[2 * m] = P->cx + a, q[2 * m + 1] = b, m++;
        }
    memset(pass, 0, sizeof pass);
    for (int k = 0; k < ncol; k++) {
        trace_lines16(c, nsets[k], r, q, m, l, ok);
        for (int i = 0; i < m; i++)
            pass[i] |= ok[i];
    }
    box[0] = box[2] = INFINITY, box[1] = box[3] = -INFINITY;
    for (int i = 0; i < m; i++) {
        if (!pass[i])
            continue;
        double a = q[2 * i] - P->cx, b = q[2 * i + 1];
        any = 1;
        box[0] = fmin(box[0], a), box[1] = fmax(box[1], a);
        box[2] = fmin(box[2], b), box[3] = fmax(box[3], b);
    }
    double ca = 2.0 * hx / GC, cb = 2.0 * hy / GC;
    box[0] = fmax(box[0] - ca, -hx), box[1] = fmin(box[1] + ca, hx);
    box[2] = fmax(box[2] - cb, -hy), box[3] = fmin(box[3] + cb, hy);
    return any;
}

/* The pupil's mean sample weight at film radius r over `box`, at the
 * reference wavelength (lr__lens_pupil_mean).  -1: out of memory. */
static double mean_weight(const lr__cam *c, double r, const lr__pupil *P,
                          const double *box)
{
    const lr__lens_cam *lc = &c->lens;
    double hx, hy;
    return lr__lens_pupil_mean(c, lc->n_ref, &lc->t_ref, r, P,
                               domain(P, &hx, &hy), box);
}

/* One film radius's rays, chief lines and weight.  0: no bound there. */
static int radius_rays(const lr__cam *c, double (*nsets)[LR__RX_MAX_SURFACES],
                       int ncol, double r, double h, ray_set *rs, line *chief,
                       line *jr, line *jt, float *chief_w, double *box,
                       double *mean)
{
    const lr__lens_cam *lc = &c->lens;
    lr__pupil P = lr__lens_pupil_at(lc, r);
    double hx, hy;
    domain(&P, &hx, &hy);
    if (!(hx * hy > 0.0) || !passing_box(c, nsets, ncol, r, &P, box))
        return 0;
    double q[2 * (G * G + RIM)];
    int nq, grid = pupil_points(&P, box, q, &nq);
    rs->nq = nq;
    rs->ncol = ncol;
    double T0;
    if (!trace_line(c, nsets[0], &lc->t_ref, r, P.cx, 0.0, chief, &T0, NULL) ||
        !(T0 > 0.0))
        return 0;
    /* The film map's derivative: radially from a neighbour's chief ray,
     * tangentially the chief ray over its radius (rotational symmetry). */
    line nb;
    lr__pupil Pn = lr__lens_pupil_at(lc, r + h);
    if (!trace_line(c, nsets[0], NULL, r + h, Pn.cx, 0.0, &nb, NULL, NULL))
        return 0;
    jr->sx = (nb.sx - chief->sx) / h, jr->px = (nb.px - chief->px) / h;
    if (r > 0.0)
        jt->sx = chief->sx / r, jt->px = chief->px / r;
    else
        *jt = *jr;
    for (int k = 0; k < ncol; k++)
        trace_lines16(c, nsets[k], r, q, nq, rs->l + k * nq, rs->ok + k * nq);
    (void)grid;
    *mean = mean_weight(c, r, &P, box);
    if (*mean < 0.0)
        return 0; /* out of memory: no bound here */
    /* Per unit of the chief ray's own T, which the trace multiplies in. */
    *chief_w = (float)(*mean / T0);
    return 1;
}

/* Where the lens cuts the pupil down fast (the edge of its image circle,
 * on a wider sensor) the mean weight bends between the table's radii and
 * a sliver may pass where the chief ray is stopped: skipped blocks there
 * were 0 to 0.97 of the full simulation (a 16 mm lens, 44 mm sensor).  So
 * each interval is checked at its middle: a skipped block's weight there
 * (interpolated chief weight times the chief ray's T) against the mean
 * traced there, within W_TOL; where not, the bound has no say. */
#define W_TOL 3e-3

static void weights_hold(const lr__cam *c, double (*nsets)[LR__RX_MAX_SURFACES],
                         int ncol, lr__lens_blur *t, double (*mid_box)[4],
                         double *mid_T0, double *mid_mean)
{
    const lr__lens_cam *lc = &c->lens;
    for (int k = 0; k < NR; k++) {
        t->w_ok[k] = 0;
        if (!t->ok[k] || !t->ok[k + 1])
            continue;
        double r = lc->pupil_rmax * (k + 0.5) / NR;
        lr__pupil P = lr__lens_pupil_at(lc, r);
        double hx, hy, *box = mid_box[k];
        domain(&P, &hx, &hy);
        line chief;
        if (!(hx * hy > 0.0) || !passing_box(c, nsets, ncol, r, &P, box) ||
            !trace_line(c, nsets[0], &lc->t_ref, r, P.cx, 0.0, &chief,
                        &mid_T0[k], NULL))
            continue;
        double mean = mid_mean[k] = mean_weight(c, r, &P, box);
        if (mean < 0.0)
            continue;
        double planned = lr__lens_blur_chief_w(t, k, 0.5f) * mid_T0[k];
        t->w_ok[k] = fabs(planned - mean) <= W_TOL * mean;
    }
}

/* Each colour's share (lens_shares.c) at the radii next to an interval
 * whose weight holds, the only ones a block tracing one ray for every
 * colour reads; then each such interval's colours checked at its middle
 * as weights_hold checks the reference.  The pupils' boxes and reference
 * means are radius_rays' and weights_hold's (box, mean; mid_box,
 * mid_mean, with the chief ray's T mid_T0).  A share costs a pupil mean
 * per colour (on an aspheric lens, whose rays solve for each such
 * surface lane by lane, some 10 ms a mean), so none is traced where no
 * block could use it.  0: out of memory. */
static int colour_shares(const lr__cam *c, const lr__lens_shares *shares,
                         lr__lens_blur *t, double (*box)[4], const double *mean,
                         double (*mid_box)[4], const double *mid_T0,
                         const double *mid_mean)
{
    const lr__lens_cam *lc = &c->lens;
    double hx, hy, sh[3];
    for (int k = 0; k <= NR; k++) {
        if (!((k < NR && t->w_ok[k]) || (k > 0 && t->w_ok[k - 1])) ||
            !(mean[k] > 0.0))
            continue;
        double r = lc->pupil_rmax * k / NR;
        lr__pupil P = lr__lens_pupil_at(lc, r);
        if (!lr__lens_shares_at(c, shares, r, &P, domain(&P, &hx, &hy), box[k],
                                mean[k], sh))
            return 0;
        for (int ch = 0; ch < 3; ch++)
            t->share[k][ch] = (float)sh[ch];
    }
    for (int k = 0; k < NR; k++) {
        if (!t->w_ok[k])
            continue;
        double r = lc->pupil_rmax * (k + 0.5) / NR, m = mid_mean[k];
        lr__pupil P = lr__lens_pupil_at(lc, r);
        sh[0] = sh[1] = sh[2] = 1.0;
        if (m > 0.0 &&
            !lr__lens_shares_at(c, shares, r, &P, domain(&P, &hx, &hy),
                                mid_box[k], m, sh))
            return 0;
        double planned = lr__lens_blur_chief_w(t, k, 0.5f) * mid_T0[k];
        float ps[3];
        lr__lens_blur_share(t, k, 0.5f, ps);
        for (int ch = 0; ch < 3; ch++)
            t->w_ok[k] &= fabs(planned * ps[ch] - m * sh[ch]) <=
                          W_TOL * m * sh[ch];
    }
    return 1;
}

/* Whether the affine J_s + J_p x keeps its sign on [0, xm]. */
static int no_pole(const line *j, double xm)
{
    double a = j->sx, b = j->sx + j->px * xm;
    return (a > 0.0 && b > 0.0) || (a < 0.0 && b < 0.0);
}

/* The grid's inverse depths: x_max (j / NX)^2, finest near infinity
 * (x = 0), where most scenes put their focus (1/16 m is cell 28 of 256
 * for the double Gauss, cells 4.4e-6 / mm apart there). */
static double grid_x(const lr__lens_blur *t, int j)
{
    double f = (double)j / NX;
    return t->x_max * f * f;
}

/* The table's rows for film radius k from its rays: at every grid
 * point j the largest distance of a ray from the chief ray's point, and
 * of a colour from the reference's.  The loop runs over the rays outside
 * and the grid points inside, which the compiler vectorises (the other
 * way round, a reduction, it did not: the double Gauss's set-up at f/11,
 * pupil and blur tables, fell from 98.6 to 88.2 ms); each grid point
 * still takes its maximum over the rays in the same order, so the table
 * has the same bits. */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
fill_row(lr__lens_blur *t, int k, const ray_set *rs, const line *ch,
         const line *jr, const line *jt)
{
    /* NP: the grid padded to whole vectors (GCC's cost model at -O2
     * vectorises no loop that needs a remainder); the points past NX
     * are computed and never read. */
    enum { NP = (NX + 1 + 7) / 8 * 8 };
    double x[NP], ir[NP], it[NP], c0x[NP], c0y[NP];
    double sr[NP], st[NP], cr[NP], ct[NP];
    for (int j = 0; j < NP; j++) {
        x[j] = grid_x(t, j);
        ir[j] = 1.0 / (jr->sx + jr->px * x[j]);
        it[j] = 1.0 / (jt->sx + jt->px * x[j]);
        c0x[j] = ch->sx + ch->px * x[j], c0y[j] = ch->sy + ch->py * x[j];
        sr[j] = st[j] = cr[j] = ct[j] = 0.0;
    }
    for (int c = 0; c < rs->ncol; c++)
        for (int i = 0; i < rs->nq; i++) {
            int at = c * rs->nq + i;
            if (!rs->ok[at])
                continue;
            const double lsx = rs->l[at].sx, lpx = rs->l[at].px;
            const double lsy = rs->l[at].sy, lpy = rs->l[at].py;
            for (int j = 0; j < NP; j++) {
                double X = lsx + lpx * x[j], Y = lsy + lpy * x[j];
                double a = fabs((X - c0x[j]) * ir[j]);
                double b = fabs((Y - c0y[j]) * it[j]);
                sr[j] = MAX(sr[j], a);
                st[j] = MAX(st[j], b);
            }
            if (c == 0 || !rs->ok[i])
                continue;
            const double rsx = rs->l[i].sx, rpx = rs->l[i].px;
            const double rsy = rs->l[i].sy, rpy = rs->l[i].py;
            for (int j = 0; j < NP; j++) {
                double X = lsx + lpx * x[j], Y = lsy + lpy * x[j];
                double X0 = rsx + rpx * x[j], Y0 = rsy + rpy * x[j];
                double a = fabs((X - X0) * ir[j]);
                double b = fabs((Y - Y0) * it[j]);
                cr[j] = MAX(cr[j], a);
                ct[j] = MAX(ct[j], b);
            }
        }
    for (int j = 0; j <= NX; j++) {
        t->sr[k][j] = (float)sr[j], t->st[k][j] = (float)st[j];
        t->cr[k][j] = (float)cr[j], t->ct[k][j] = (float)ct[j];
    }
}

static void slopes(lr__lens_blur *t, int k, const ray_set *rs)
{
    t->slo[k] = INFINITY, t->shi[k] = -INFINITY, t->sta[k] = 0.0;
    for (int i = 0; i < rs->ncol * rs->nq; i++) {
        if (!rs->ok[i])
            continue;
        const line *l = &rs->l[i];
        t->slo[k] = fmin(t->slo[k], l->sx);
        t->shi[k] = fmax(t->shi[k], l->sx);
        t->sta[k] = fmax(t->sta[k], fabs(l->sy));
        t->reach = fmax(t->reach, hypot(l->px, l->py));
    }
}

static lr__lens_blur *build(const lr__cam *c)
{
    const lr__lens_cam *lc = &c->lens;
    lr__lens_blur *t = calloc(1, sizeof *t);
    double(*nsets)[LR__RX_MAX_SURFACES] = malloc(MAX_COL * sizeof *nsets);
    int ncol = nsets != NULL ? index_sets(c, nsets) : 0;
    size_t per = (size_t)(G * G + RIM) * (size_t)ncol;
    ray_set *rs = malloc((NR + 1) * sizeof *rs);
    line *lines = malloc((NR + 1) * per * sizeof *lines);
    unsigned char *oks = malloc((NR + 1) * per);
    line ch[NR + 1], jr[NR + 1], jt[NR + 1];
    double box[NR + 1][4], mean[NR + 1], mid_box[NR][4], mid_T0[NR],
        mid_mean[NR];
    /* Each colour's share, where one ray stands for every colour. */
    lr__lens_shares *shares = lr__lens_shares_new(c);
    if (t == NULL || nsets == NULL || rs == NULL || lines == NULL ||
        oks == NULL || (c->chroma_active && shares == NULL)) {
        free(t);
        t = NULL;
        goto done;
    }
    double h = 1e-3 * lc->pupil_rmax / NR;
    for (int k = 0; k <= NR; k++) {
        double r = lc->pupil_rmax * k / NR;
        rs[k].l = lines + (size_t)k * per;
        rs[k].ok = oks + (size_t)k * per;
        t->share[k][0] = t->share[k][1] = t->share[k][2] = 1.0f;
        t->ok[k] = radius_rays(c, nsets, ncol, r, k < NR ? h : -h, &rs[k],
                               &ch[k], &jr[k], &jt[k], &t->chief_w[k], box[k],
                               &mean[k]);
        if (t->ok[k])
            slopes(t, k, &rs[k]);
    }
    /* The grid's nearest depth: twice the front vertex's distance from
     * the sensor, halved until no radius's film map has a zero there. */
    double zeta_front = lc->z_sensor - lc->L->z[0];
    t->x_max = 1.0 / (2.0 * fmax(zeta_front, 1.0));
    for (int it = 0; it < 40; it++) {
        int good = 1;
        for (int k = 0; k <= NR; k++)
            good &= !t->ok[k] ||
                    (no_pole(&jr[k], t->x_max) && no_pole(&jt[k], t->x_max));
        if (good)
            break;
        t->x_max *= 0.5;
    }
    for (int k = 0; k <= NR; k++)
        if (t->ok[k])
            fill_row(t, k, &rs[k], &ch[k], &jr[k], &jt[k]);
    weights_hold(c, nsets, ncol, t, mid_box, mid_T0, mid_mean);
    if (shares != NULL &&
        !colour_shares(c, shares, t, box, mean, mid_box, mid_T0, mid_mean)) {
        free(t);
        t = NULL;
        goto done;
    }
    lr__lens_chief_fill(c, t->x_max, &t->chief);
done:
    lr__lens_shares_free(shares);
    free(nsets);
    free(rs);
    free(lines);
    free(oks);
    return t;
}

static void make_key(const lr__cam *c, double *key)
{
    const lr__lens_cam *lc = &c->lens;
    /* The colour set and amplify apart (lens_pupil.c's key says why). */
    double k[10] = {lc->z_sensor,
                    lc->stop_scale,
                    lc->pupil_rmax,
                    colour_set(c),
                    c->chroma.amplify,
                    lc->z_rear,
                    lc->coat == NULL ? -1.0 : (double)lc->coat->kind,
                    c->nm_ref,
                    lc->sensor_w,
                    lc->inv_E0};
    memcpy(key, k, sizeof k);
}

const lr__lens_blur *lr__lens_blur_get(const lr__cam *c)
{
    lr_lens *L = (lr_lens *)c->lens.L; /* the cache is mutable, under mu */
    double key[10];
    make_key(c, key);
    lr__lens_blur *hit = NULL;
    pthread_mutex_lock(&L->mu);
    for (int i = 0; i < L->n_blur && hit == NULL; i++)
        if (memcmp(((lr__lens_blur *)L->blur[i])->key, key, sizeof key) == 0)
            hit = L->blur[i];
    pthread_mutex_unlock(&L->mu);
    if (hit == NULL) {
        lr__lens_blur *t = build(c);
        if (t == NULL)
            return NULL;
        memcpy(t->key, key, sizeof key);
        pthread_mutex_lock(&L->mu);
        /* Another job may have made it meanwhile: keep the first. */
        for (int i = 0; i < L->n_blur && hit == NULL; i++)
            if (memcmp(((lr__lens_blur *)L->blur[i])->key, key, sizeof key) ==
                0)
                hit = L->blur[i];
        if (hit == NULL && L->n_blur < LR__BLUR_CACHE) {
            L->blur[L->n_blur++] = t;
            hit = t;
            t = NULL;
        }
        pthread_mutex_unlock(&L->mu);
        /* The cache is full: no bound (the tables live as long as the
         * lens, and a camera must not point at one that does not). */
        free(t);
        if (hit == NULL)
            return NULL;
    }
    /* The camera is the caller's (render.c's job), prepared before the
     * plan; its packet rays read this when the plan skips the lens. */
    __atomic_store_n(&((lr__cam *)c)->lens.blur, hit, __ATOMIC_RELEASE);
    return hit;
}
