/*
 * lens_bound.c: the plan's questions to a real lens's blur table
 * (camera.h; the table: lens_blur.c): the bound on a block's spot and
 * colour spread, where its rays reach, and the chief rays' weights.
 */
#include "camera/lens_blur.h"

#include <math.h>

const lr__lens_chief *lr__lens_blur_chief(const lr__lens_blur *b)
{
    return &b->chief;
}

float lr__lens_blur_chief_w(const lr__lens_blur *b, int k, float f)
{
    return b->chief_w[k] + f * (b->chief_w[k + 1] - b->chief_w[k]);
}

void lr__lens_blur_share(const lr__lens_blur *b, int k, float f, float s[3])
{
    for (int ch = 0; ch < 3; ch++)
        s[ch] = b->share[k][ch] + f * (b->share[k + 1][ch] - b->share[k][ch]);
}

/* The film rectangle in sensor mm (lens frame) and its radii's range. */
static void rect_mm(const lr__cam *c, double fx0, double fy0, double fx1,
                    double fy1, double *x, double *y, double *rlo, double *rhi)
{
    const lr__lens_cam *lc = &c->lens;
    x[0] = (0.5 - fx1 / c->width) * lc->sensor_w;
    x[1] = (0.5 - fx0 / c->width) * lc->sensor_w;
    y[0] = (fy0 / c->height - 0.5) * lc->sensor_h;
    y[1] = (fy1 / c->height - 0.5) * lc->sensor_h;
    double nx = fmax(x[0], fmin(0.0, x[1])), ny = fmax(y[0], fmin(0.0, y[1]));
    *rlo = hypot(nx, ny);
    *rhi = hypot(fmax(fabs(x[0]), fabs(x[1])), fmax(fabs(y[0]), fabs(y[1])));
}

/* The table's radii around those a rectangle spans. */
static void radii(const lr__cam *c, double rlo, double rhi, int *k0, int *k1)
{
    double s = NR / c->lens.pupil_rmax;
    *k0 = (int)floor(rlo * s);
    *k1 = (int)ceil(rhi * s);
    *k0 = *k0 < 0 ? 0 : *k0;
    *k1 = *k1 > NR ? NR : *k1;
}

/* Whether the table has a chief ray at radii k0 to k1 and its weight
 * holds between them (lr__lens_blur_chief_ok). */
static int radii_hold(const lr__lens_blur *b, int k0, int k1)
{
    for (int k = k0; k <= k1; k++)
        if (!b->ok[k] || (k < k1 && !b->w_ok[k]))
            return 0;
    return 1;
}

int lr__lens_blur_chief_ok(const lr__cam *c, const lr__lens_blur *b, double fx0,
                           double fy0, double fx1, double fy1)
{
    double x[2], y[2], rlo, rhi;
    rect_mm(c, fx0, fy0, fx1, fy1, x, y, &rlo, &rhi);
    int k0, k1;
    radii(c, rlo, rhi, &k0, &k1);
    return radii_hold(b, k0, k1);
}

int lr__lens_blur_bound(const lr__cam *c, const lr__lens_blur *b, double fx0,
                        double fy0, double fx1, double fy1, double z0,
                        double z1, double *spot, double *colour)
{
    const lr__lens_cam *lc = &c->lens;
    double x[2], y[2], rlo, rhi;
    rect_mm(c, fx0, fy0, fx1, fy1, x, y, &rlo, &rhi);
    /* Inverse depths in 1/mm (depths are scene units: mm of them). */
    double xa = isfinite(z1) ? lc->mm / z1 : 0.0, xb = lc->mm / z0;
    if (!(z0 > 0.0) || !(xb <= b->x_max))
        return 0;
    /* The grid points either side of each end (grid_x's inverse). */
    double ja = NX * sqrt(xa / b->x_max), jb = NX * sqrt(xb / b->x_max);
    int js[4] = {(int)floor(ja), (int)ceil(ja), (int)floor(jb), (int)ceil(jb)};
    int k0, k1;
    radii(c, rlo, rhi, &k0, &k1);
    double s = 0.0, col = 0.0;
    if (!radii_hold(b, k0, k1))
        return 0;
    for (int k = k0; k <= k1; k++) {
        double sr = 0.0, st = 0.0, cr = 0.0, ct = 0.0;
        for (int i = 0; i < 4; i++) {
            int j = js[i] < 0 ? 0 : js[i] > NX ? NX : js[i];
            sr = fmax(sr, b->sr[k][j]), st = fmax(st, b->st[k][j]);
            cr = fmax(cr, b->cr[k][j]), ct = fmax(ct, b->ct[k][j]);
        }
        s = fmax(s, hypot(sr, st));
        col = fmax(col, hypot(cr, ct));
    }
    double px_mm = c->width / lc->sensor_w;
    /* A spot is a diameter: twice the farthest point from the chief. */
    *spot = 2.0 * (s * MARGIN + MARGIN_MM) * px_mm;
    *colour = 2.0 * (col * MARGIN + MARGIN_MM) * px_mm;
    return 1;
}

void lr__lens_blur_reach(const lr__cam *c, const lr__lens_blur *b, double fx0,
                         double fy0, double fx1, double fy1, double uv[4],
                         double *R)
{
    double x[2], y[2], rlo, rhi;
    rect_mm(c, fx0, fy0, fx1, fy1, x, y, &rlo, &rhi);
    int k0, k1;
    radii(c, rlo, rhi, &k0, &k1);
    double lo = INFINITY, hi = -INFINITY, ta = 0.0;
    for (int k = k0; k <= k1; k++) {
        if (!b->ok[k])
            continue;
        lo = fmin(lo, b->slo[k]), hi = fmax(hi, b->shi[k]);
        ta = fmax(ta, b->sta[k]);
    }
    *R = (b->reach * 1.1 + 1.0) * c->lens.mm;
    if (!(lo <= hi)) {
        /* No ray traced there passes: rays anywhere (none pass in fact,
         * but the bound says nothing). */
        uv[0] = uv[2] = -INFINITY, uv[1] = uv[3] = INFINITY;
        return;
    }
    double rho = hypot(fmax(fabs(lo), fabs(hi)), ta);
    if (rho > MAX_SLOPE) {
        /* Past 72 degrees slivers of the pupil pass at slopes the grid
         * misses (test_lens_blur.c found one at 88 degrees on the
         * 170-degree lens where the table said 83): no bound. */
        uv[0] = uv[2] = -INFINITY, uv[1] = uv[3] = INFINITY;
        return;
    }
    double grow = 0.01 * rho + 1e-3;
    /* The angles the rectangle spans about the axis: at its corners,
     * unless it holds the axis. */
    double pm = atan2(0.5 * (y[0] + y[1]), 0.5 * (x[0] + x[1])), dphi = 0.0;
    for (int i = 0; i < 4; i++) {
        double d = atan2(y[i >> 1], x[i & 1]) - pm;
        d = fabs(remainder(d, 2.0 * M_PI));
        dphi = fmax(dphi, d);
    }
    if (rlo <= 0.0 || dphi > 0.5 * M_PI) {
        uv[0] = uv[2] = -(rho + grow);
        uv[1] = uv[3] = rho + grow;
        return;
    }
    /* The slopes sr e_r + st e_t for e_r at angle pm: the rectangle of
     * [lo, hi] x [-ta, ta] turned by pm, grown by how far turning it by
     * up to dphi moves a point (dphi rho). */
    double cp = cos(pm), sp = sin(pm);
    uv[0] = uv[2] = INFINITY, uv[1] = uv[3] = -INFINITY;
    for (int i = 0; i < 4; i++) {
        double sr = i & 1 ? hi : lo, st = i & 2 ? ta : -ta;
        double u = cp * sr - sp * st, v = sp * sr + cp * st;
        uv[0] = fmin(uv[0], u), uv[1] = fmax(uv[1], u);
        uv[2] = fmin(uv[2], v), uv[3] = fmax(uv[3], v);
    }
    grow += dphi * rho;
    uv[0] -= grow, uv[2] -= grow, uv[1] += grow, uv[3] += grow;
}
