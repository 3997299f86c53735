/*
 * ghost_film.c: a ghost's light into the film (ghost_trace.h): a
 * splat's unbiased rounding to the film's integers (lr__gt_splat), and
 * a polygon's coverage of the pixels (lr__gt_acc_edge) for the meshes
 * (ghost_grid.c).
 */
#include "integrator/ghost_trace.h"

#include <math.h>

/* Adds v (>= 0) to pixel (ix, iy) of f, if the region holds it, as
 * lr__lt_splat does but rounded at random, down or up by u (uniform in
 * [0, 1)), which is unbiased: a coated ghost's splats are a few of the
 * film's units (2^-40 of its brightest light), where rounding to the
 * nearest unit lost or gained up to 6% of the colour test's ghost
 * (test_ghost_render.c at 8192 spp, seeds 5, 7 and 9).  Returns the
 * units added. */
int64_t lr__gt_splat(lr__lt_film *f, int ix, int iy, lr__v3 v, double u)
{
    if (ix < f->x0 || ix >= f->x1 || iy < f->y0 || iy >= f->y1)
        return 0;
    size_t k = 3 * ((size_t)(iy - f->y0) * (size_t)(f->x1 - f->x0) +
                    (size_t)(ix - f->x0));
    double c[3] = {v.x, v.y, v.z};
    int64_t sum = 0;
    for (int j = 0; j < 3; j++) {
        /* floor(fmin(x, 2^52) + u) where that is > 0, without the calls
         * the baseline x86-64 makes for floor and fmin: a NaN takes
         * 2^52 as fmin gives it, and y >= 1 truncates to its floor. */
        double x = c[j] * f->scale;
        double y = (x < 0x1p52 ? x : 0x1p52) + u;
        if (!(y >= 1.0))
            continue;
        int64_t q = (int64_t)y;
        lr__lt_film_add(f->sum, f->sum_hi, k + (size_t)j, (double)q);
        sum += q;
    }
    return sum;
}

/* fmin and fmax for the film's numbers, never NaN: the baseline x86-64
 * calls those. */
static inline double lo(double a, double b)
{
    return a < b ? a : b;
}

static inline double hi(double a, double b)
{
    return a > b ? a : b;
}

/* Adds the segment (x0, y0)-(x1, y1), 0 <= x <= W, to the rows [0, H)
 * of the accumulation buffer a (stride S >= W + 2) with weight w: each
 * pixel of a row gets w times the part of it right of the segment, in
 * differences along the row (summed by gg_flush).  The signed-area
 * accumulation of font rasterisers (R. Levien, font-rs, 2016; the same
 * as libart's): a row's share of the segment, dy, goes to the pixels
 * it crosses by the area of each pixel's part to its right, and the
 * pixels past it get all of dy through the running sum, so a closed
 * polygon's edges leave each pixel the area it covers, in time
 * proportional to its edges' length, not its area. */
static void acc_line(double *a, int S, int H, double x0, double y0, double x1,
                     double y1, double w)
{
    double dir = 1.0;
    if (y0 > y1) {
        double t = x0;
        x0 = x1, x1 = t, t = y0, y0 = y1, y1 = t, dir = -1.0;
    }
    double ys = hi(y0, 0.0), ye = lo(y1, (double)H);
    if (!(ys < ye))
        return;
    double dxdy = (x1 - x0) / (y1 - y0);
    double x = x0 + (ys - y0) * dxdy;
    for (int iy = (int)ys; iy < ye; iy++) {
        double dy = lo(iy + 1.0, ye) - hi((double)iy, ys);
        double xn = x + dxdy * dy, d = dy * dir * w;
        double *row = a + (size_t)iy * (size_t)S;
        double xa = lo(x, xn), xb = hi(x, xn);
        /* ceil(xb) for xb >= 0 (lr__gt_acc_edge's clip): a call where the
         * baseline x86-64 has no rounding instruction. */
        int ia = (int)xa, ib = (int)xb;
        ib += ib < xb;
        if (ib <= ia + 1) {
            /* Within one pixel: its part right of the segment's mean. */
            double xm = 0.5 * (x + xn) - ia;
            row[ia] += d * (1.0 - xm);
            row[ia + 1] += d * xm;
        } else {
            /* x uniform over [xa, xb] along the row: the first pixel's
             * part right of it a0, the last's left of it am, s per
             * pixel between. */
            double s = 1.0 / (xb - xa), fa = xa - ia, fb = xb - (ib - 1);
            double a0 = 0.5 * s * (1.0 - fa) * (1.0 - fa);
            double am = 0.5 * s * fb * fb;
            row[ia] += d * a0;
            if (ib == ia + 2) {
                row[ia + 1] += d * (1.0 - a0 - am);
            } else {
                double a1 = s * (1.5 - fa);
                row[ia + 1] += d * (a1 - a0);
                for (int k = ia + 2; k < ib - 1; k++)
                    row[k] += d * s;
                row[ib - 1] += d * (1.0 - a1 - (ib - ia - 3) * s - am);
            }
            row[ib] += d * am;
        }
        x = xn;
    }
}

/* acc_line for any segment: its parts left of x = 0 and right of x = W
 * moved onto those lines (a part left of the buffer covers every pixel
 * of its rows, one right of it none). */
void lr__gt_acc_edge(double *a, int S, int W, int H, double x0, double y0,
                     double x1, double y1, double w)
{
    double t[4] = {0.0, 1.0, 1.0, 1.0};
    int n = 1;
    for (int e = 0; e < 2; e++) {
        double at = e == 0 ? 0.0 : (double)W, u = (at - x0) / (x1 - x0);
        if (u > 0.0 && u < 1.0)
            t[n++] = u;
    }
    if (n == 3 && t[2] < t[1]) {
        double s = t[1];
        t[1] = t[2], t[2] = s;
    }
    t[n] = 1.0;
    for (int k = 0; k < n; k++) {
        double xa = x0 + t[k] * (x1 - x0), xb = x0 + t[k + 1] * (x1 - x0);
        double ya = y0 + t[k] * (y1 - y0), yb = y0 + t[k + 1] * (y1 - y0);
        xa = lo(hi(xa, 0.0), (double)W), xb = lo(hi(xb, 0.0), (double)W);
        acc_line(a, S, H, xa, ya, xb, yb, w);
    }
}
