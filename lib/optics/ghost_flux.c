/*
 * ghost_flux.c: how bright each ghost of a distant point is against its
 * main image (ghost.h): the figure `lensray lens --ghosts` and issue
 * 29's "auto" threshold start from.
 */
#include "optics/ghost.h"

#include <math.h>
#include <stdlib.h>

/* Sums over one path's rays. */
typedef struct sums {
    double w, wx, wy, wrr;
    int hits;
} sums;

/* The indices and R's source for one wavelength (lr__ghost_trace_t). */
typedef struct optics {
    const double *n_after;
    const lr__ttab *tab;
    double nm, stop_scale;
    const lr__coating *override;
} optics;

static sums path_sums(const lr__rx *rx, const double *z, const optics *op,
                      lr__ghost g, const double d[3], int grid, double radius)
{
    sums s = {0, 0, 0, 0, 0};
    const double a = rx->s[0].semi_aperture;
    for (int u = 0; u < grid; u++)
        for (int v = 0; v < grid; v++) {
            /* Cell centres over the square around the front element;
             * those outside its circle would be blocked there anyway. */
            double x = a * (2.0 * (u + 0.5) / grid - 1.0);
            double y = a * (2.0 * (v + 0.5) / grid - 1.0);
            if (x * x + y * y > a * a)
                continue;
            /* Through (x, y) in the first vertex's plane, from 1 mm in
             * front of it. */
            double o[3] = {x - d[0] / d[2], y - d[1] / d[2], -1.0};
            double hit[2], w;
            if (!lr__ghost_trace_t(rx, z, op->n_after, op->tab, op->nm,
                                   op->stop_scale, op->override, g, z[rx->n],
                                   NULL, o, d, hit, &w))
                continue;
            if (radius > 0.0 && hypot(hit[0], hit[1]) > radius)
                continue;
            s.hits++;
            s.w += w;
            s.wx += w * hit[0];
            s.wy += w * hit[1];
            s.wrr += w * (hit[0] * hit[0] + hit[1] * hit[1]);
        }
    return s;
}

static int brighter_first(const void *a, const void *b)
{
    const lr__ghost_flux *p = a, *q = b;
    if (p->flux != q->flux)
        return p->flux < q->flux ? 1 : -1;
    /* Ties (often 0) in path order, so the order is the same on every
     * platform's qsort. */
    if (p->path.j != q->path.j)
        return p->path.j - q->path.j;
    return p->path.i - q->path.i;
}

int lr__ghost_fluxes_t(const lr__rx *rx, const double *n_after,
                       const lr__ttab *tab, double nm, double stop_scale,
                       const lr__coating *override, double field_deg, int grid,
                       double radius, lr__ghost_flux *out, double *main)
{
    optics op = {n_after, tab, nm, stop_scale, override};
    double z[LR__RX_MAX_SURFACES + 1];
    lr__rx_layout(rx, z);
    double t = field_deg * M_PI / 180.0;
    double d[3] = {sin(t), 0.0, cos(t)};
    /* The beam's rays each carry the same energy: the flux of a path is
     * the sum of its rays' weights, in units of one ray's. */
    sums m = path_sums(rx, z, &op, (lr__ghost){-1, -1}, d, grid, radius);
    int cells = 0;
    for (int u = 0; u < grid; u++)
        for (int v = 0; v < grid; v++) {
            double x = 2.0 * (u + 0.5) / grid - 1.0;
            double y = 2.0 * (v + 0.5) / grid - 1.0;
            cells += x * x + y * y <= 1.0;
        }
    *main = cells > 0 ? m.w / cells : 0.0;
    if (!(m.w > 0.0))
        return 0;
    lr__ghost paths[LR__GHOST_MAX];
    int n = lr__ghost_paths(rx, paths);
    for (int k = 0; k < n; k++) {
        sums s = path_sums(rx, z, &op, paths[k], d, grid, radius);
        lr__ghost_flux *f = &out[k];
        f->path = paths[k];
        f->flux = s.w / m.w;
        f->landed = cells > 0 ? (double)s.hits / cells : 0.0;
        f->cx = s.w > 0.0 ? s.wx / s.w : 0.0;
        f->cy = s.w > 0.0 ? s.wy / s.w : 0.0;
        f->rms = s.w > 0.0 ? sqrt(fmax(0.0, s.wrr / s.w - f->cx * f->cx -
                                                f->cy * f->cy))
                           : 0.0;
    }
    qsort(out, (size_t)n, sizeof *out, brighter_first);
    return n;
}

double lr__ghost_main_area(const lr__rx *rx, const double *n_after,
                           const lr__ttab *tab, double nm, double stop_scale,
                           const lr__coating *override, int grid)
{
    double z[LR__RX_MAX_SURFACES + 1];
    lr__rx_layout(rx, z);
    optics op = {n_after, tab, nm, stop_scale, override};
    static const double axis[3] = {0.0, 0.0, 1.0};
    sums m = path_sums(rx, z, &op, (lr__ghost){-1, -1}, axis, grid, 0.0);
    double cell = 2.0 * rx->s[0].semi_aperture / grid;
    return m.w * cell * cell;
}

int lr__ghost_fluxes(const lr__rx *rx, const lr__coating *override,
                     double field_deg, double nm, int grid, double radius,
                     lr__ghost_flux *out, double *main)
{
    double n_after[LR__RX_MAX_SURFACES];
    lr__rx_indices(rx, nm, n_after);
    return lr__ghost_fluxes_t(rx, n_after, NULL, nm, 1.0, override, field_deg,
                              grid, radius, out, main);
}
