/*
 * ghost_grid.c: a small source's ghosts drawn as meshes (ghost_trace.h:
 * lr__gt_grid), after Hullin et al., "Physically-based real-time lens
 * flare rendering" (SIGGRAPH 2011), section 4: a grid of rays over the
 * front of the lens is traced through one ghost path, each cell of the
 * grid lands on the sensor as a quadrilateral, and the light the cell
 * carries is spread evenly over it.
 *
 * For a direction d from a lens point, a ghost path g sends the pixel
 * (x, y) the lens integral
 *
 *     I(x, y) = 1 / (pi rho^2) int_disk L W_g(o) [film_g(o) in pixel] do,
 *
 * W_g the ghost's importance (camera.h: ghost_film; it holds the disk's
 * area pi rho^2 as a path's 1 / pdf).  Split the disk into triangles
 * (two a cell, cells of a grid over the box where the ghost lands,
 * ghost_guide): a triangle of lens area a whose corners carry L W_g
 * values v0, v1, v2 sends (v0 + v1 + v2) / 3 x a / (pi rho^2), spread
 * over the triangle its corners land on by the area each pixel shares
 * with it (an exact polygon clip).  This is the integral with L W_g
 * linear over each triangle and the film map affine over it: exact in
 * the limit of small cells, a few tenths of a percent off at the grid's
 * size where the ghost's shape is smooth.  Cells whose corners are
 * neither all landed nor all lost straddle the ghost's edge (the stop's
 * or an element's rim): they split in four, LR__GT_DEPTH times, and at
 * the finest level the triangles whose three corners land are drawn,
 * so the edge is found to 1 / 2^LR__GT_DEPTH of a cell.  A source with
 * an extent is its grid^2 stratified directions (the midpoints of
 * grid x grid strata of its direction sample: lr__gt_dir), each drawn
 * this way at 1 / grid^2 of the light.
 *
 * Unlike a path's splats these are not unbiased: the error is the
 * discretisation's, the same for every seed, and small against the
 * paths' noise at equal time (docs/lenses.md, "Coatings and ghosts").
 * Deterministic: a pure function of (light, direction, ghost path), and
 * the splats are integers whose sum does not depend on the order; each
 * pixel's rounding is a hash of the triangle and the pixel, so any
 * region or thread count gives the same bits.
 */
#include "integrator/ghost_trace.h"

#include "optics/lens.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int lr__gt_cells = LR__GT_CELLS, lr__gt_depth = LR__GT_DEPTH;
double lr__gt_dir_px = 1.0;

/* Channels a corner carries: the reference wavelength (chromatic.mode
 * off), or red, green and blue. */
#define NCH 3

/* A corner of the grid: where each channel lands (bit k of ok: it
 * does) and the value L W_g / pdf_dir it carries there (0 where the
 * source is hidden from the lens point). */
typedef struct gg_pt {
    unsigned ok;
    double fx[NCH], fy[NCH], rel[NCH];
    lr__v3 v[NCH];
} gg_pt;

/* A triangle on the film (pixels of the frame), and the light it
 * spreads evenly over itself. */
typedef struct gg_tri_t {
    double x[3], y[3];
    lr__v3 v;
} gg_tri_t;

/* Triangles held before they are drawn, and the pixels (times 3
 * channels) of a band's buffer: 1.2 and 1.5 MB a thread while it draws
 * a light's meshes (a quarter of each took the same time on the night
 * scene). */
#define LR__GT_TRIS 16384
#define LR__GT_BAND (1 << 16)
/* Corners traced together (gg_grid): a grid of 30 x 30 cells whole,
 * and at least two rows of the largest (the same corners, in more
 * calls, whatever the number: only the lanes' filling changes). */
#define LR__GT_PTS 1024
#define LR__GT_MIDS (5 * LR__GT_CELLS_MAX)
#define LR__GT_XY (LR__GT_PTS > LR__GT_MIDS ? LR__GT_PTS : LR__GT_MIDS)

/* One task: light l's meshes, a direction ud and a ghost path g at a
 * time. */
typedef struct gg_task {
    const lr_scene *s;
    const lr__cam *c;
    const lr__lt_light *l;
    lr__lt_film *f;
    int g, k0, nch;
    double ud[2];
    double norm; /* 1 / (pi rho^2 directions) */
    uint64_t key, flushes;
    uint64_t traced, landed, rays;
    gg_tri_t *tris; /* LR__GT_TRIS, n_tris held (gg_raster) */
    /* Every corner's light the source's colour times a number (one
     * wavelength): then gg_flush sums channel mono_ch alone and paints
     * mono_c (the colour over that channel) by it. */
    int mono, mono_ch;
    lr__v3 mono_c;
    int n_tris;
    double *band; /* LR__GT_BAND pixels x 3 channels (gg_flush) */
    /* gg_grid's corners (LR__GT_PTS), a row's splits' points (5
     * LR__GT_CELLS_MAX), and the coordinates and places of either. */
    gg_pt *pts, *mid, **pp;
    double *px, *py;
} gg_task;

/* Whether a mesh light reaches lens point P along w: the camera ray's
 * first hit is the light's geometry, from its front. */
static int mesh_reaches(const gg_task *t, lr__v3 P, lr__v3 w)
{
    lr__hit h;
    return lr__trace(t->s, lr__cam_ray_start(t->c, P, w), w, INFINITY, &h) &&
           h.geom == t->l->geom && h.entering;
}

/* The direction sample of a source's stratum midpoint u: the cone's
 * samples (lr__lt_in_cone) take 1 - cos theta and phi from ud[0] and
 * ud[1], so a grid of midpoints there would put 2 x 2 directions on one
 * line through the centre; the midpoint goes to the disc first by
 * Shirley and Chiu's concentric map (lr__aperture_sample), then to
 * (r^2, phi / 2 pi): the disc's area is the cone's solid angle. */
static void gg_direction(const double u[2], double ud[2])
{
    double x, y;
    lr__aperture_sample(LR_APERTURE_DISK, 0, 0.0, 1.0, u, &x, &y);
    double phi = atan2(y, x) / (2.0 * M_PI);
    ud[0] = fmin(x * x + y * y, 1.0);
    ud[1] = phi < 0.0 ? phi + 1.0 : phi;
}

/* Corners (ox[q], oy[q]) of task t, q < n, into *p[q]: where each
 * channel lands through the task's ghost path and what it carries there,
 * the lens traced LR__GHOST_LANES corners at a time (ghost_film_n). */
static void gg_eval_n(gg_task *t, int n, const double *ox, const double *oy,
                      gg_pt **p)
{
    const lr__cam *c = t->c;
    /* A textured source, and the sun's cone of the map, at their mean
     * radiance: a few pixels across, a source's pattern is lost in every
     * ghost's blur, and a few directions' lookups would stand for the
     * whole of it (a sun of a few texels between them). */
    lr__v3 L = t->l->Lmean;
    for (int q0 = 0; q0 < n; q0 += LR__GHOST_LANES) {
        int m = n - q0 < LR__GHOST_LANES ? n - q0 : LR__GHOST_LANES;
        lr__v3 P[LR__GHOST_LANES], w[LR__GHOST_LANES];
        const lr__emitter *e[LR__GHOST_LANES];
        double inv_pdf[LR__GHOST_LANES];
        /* Lanes: the corners whose source is there, lane[u] the corner. */
        int lane[LR__GHOST_LANES], u = 0;
        for (int q = 0; q < m; q++) {
            gg_pt *pt = p[q0 + q];
            pt->ok = 0;
            for (int j = 0; j < NCH; j++)
                pt->v[j] = v3(0, 0, 0), pt->rel[j] = INFINITY;
            P[q] = c->model->lens_at(c, ox[q0 + q], oy[q0 + q]);
            if (t->l->n_tri > 0) {
                /* A mesh: a disc of its solid angle from the eye around
                 * its bounding sphere's centre, the direction ud's point
                 * of it (a point drawn on the mesh by area, as its paths
                 * draw one, would put a midpoint of ud on a triangle's
                 * corner).  A mesh with a hole there (a ring) loses what
                 * the disc's directions miss. */
                lr__v3 a = v3_norm(v3_sub(t->l->center, P[q]));
                w[q] = lr__lt_in_cone(a, t->l->omega / (2.0 * M_PI), t->ud);
                inv_pdf[q] = t->l->omega, e[q] = NULL;
            } else {
                inv_pdf[q] = lr__gt_dir(t->s, t->l, P[q], t->ud, &w[q], &e[q]);
            }
            if (inv_pdf[q] > 0.0 && v3_maxc(L) > 0.0)
                lane[u++] = q;
        }
        double lx[LR__GHOST_LANES], ly[LR__GHOST_LANES];
        lr__v3 lw[LR__GHOST_LANES];
        for (int a = 0; a < u; a++)
            lx[a] = ox[q0 + lane[a]], ly[a] = oy[q0 + lane[a]],
            lw[a] = w[lane[a]];
        for (int j = 0; j < t->nch; j++) {
            int k = t->k0 + j;
            double W[LR__GHOST_LANES], fx[LR__GHOST_LANES], fy[LR__GHOST_LANES],
                rel[LR__GHOST_LANES];
            c->model->ghost_film_n(c, t->g, k, u, lx, ly, lw, rel, fx, fy, W);
            for (int a = 0; a < u; a++) {
                gg_pt *pt = p[q0 + lane[a]];
                t->traced++;
                lr__v3 v = v3_scale(L, W[a] * inv_pdf[lane[a]]);
                if (k >= 0)
                    v = v3(k == 0 ? v.x : 0.0, k == 1 ? v.y : 0.0,
                           k == 2 ? v.z : 0.0);
                if (!(W[a] > 0.0) ||
                    !(isfinite(v.x) && isfinite(v.y) && isfinite(v.z)) ||
                    !(fabs(fx[a]) < 1e9 && fabs(fy[a]) < 1e9))
                    continue;
                pt->ok |= 1u << j;
                pt->v[j] = v;
                pt->rel[j] = rel[a], pt->fx[j] = fx[a], pt->fy[j] = fy[a];
                t->landed++;
            }
        }
        for (int a = 0; a < u; a++) {
            int q = lane[a];
            gg_pt *pt = p[q0 + q];
            if (pt->ok == 0)
                continue;
            t->rays++;
            double tex[3];
            int seen = t->l->n_tri > 0 ? mesh_reaches(t, P[q], w[q])
                                       : lr__gt_reaches(t->s, c, t->l, P[q],
                                                        w[q], e[q], tex);
            if (!seen)
                for (int j = 0; j < t->nch; j++)
                    pt->v[j] = v3(0, 0, 0);
        }
    }
}

/* Draws the task's triangles into the film (then none are held): band
 * by band of the region's rows under them, each row's pixels summed
 * along it from the left of the triangles' box in the frame (not the
 * region's: the same sums whatever the region), and the region's added
 * to f as integers, rounded by a hash of the task and the pixel
 * (lr__gt_splat: unbiased). */
static void gg_flush(gg_task *t)
{
    lr__lt_film *f = t->f;
    int n = t->n_tris;
    t->n_tris = 0;
    uint64_t key = lr__mix64(t->key + t->flushes++);
    double bx0 = INFINITY, bx1 = -INFINITY, by0 = INFINITY, by1 = -INFINITY;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double x = t->tris[i].x[k], y = t->tris[i].y[k];
            bx0 = x < bx0 ? x : bx0, bx1 = x > bx1 ? x : bx1;
            by0 = y < by0 ? y : by0, by1 = y > by1 ? y : by1;
        }
    /* The columns [x0, x1) of the frame the triangles touch, and the
     * rows [y0, y1) of the region. */
    int x0 = (int)fmax(0.0, floor(bx0));
    int x1 = (int)fmin(t->c->width, floor(bx1) + 1.0);
    int y0 = (int)fmax(f->y0, floor(by0)),
        y1 = (int)fmin(f->y1, floor(by1) + 1.0);
    if (n == 0 || x0 >= x1 || y0 >= y1)
        return;
    /* One plane when every triangle's light is the source's colour
     * times a number (t->mono: its channel m's), else three. */
    int planes = t->mono ? 1 : 3, m = t->mono_ch;
    int W = x1 - x0, S = W + 2;
    int B = (int)fmax(1.0, fmin(y1 - y0, (double)LR__GT_BAND / S));
    double *a = t->band;
    int64_t units = 0;
    for (int b0 = y0; b0 < y1; b0 += B) {
        int H = b0 + B < y1 ? B : y1 - b0;
        size_t P = (size_t)S * (size_t)H;
        memset(a, 0, (size_t)planes * P * sizeof *a);
        for (int i = 0; i < n; i++) {
            const gg_tri_t *tr = &t->tris[i];
            double ylo = tr->y[0], yhi = tr->y[0];
            for (int k = 1; k < 3; k++) {
                ylo = tr->y[k] < ylo ? tr->y[k] : ylo;
                yhi = tr->y[k] > yhi ? tr->y[k] : yhi;
            }
            if (yhi <= b0 || ylo >= b0 + H)
                continue;
            double ch[3] = {tr->v.x, tr->v.y, tr->v.z};
            if (t->mono)
                ch[0] = ch[m];
            /* Coverage is positive for a triangle whose signed area
             * (y down) is negative, so w takes that sign.  One of no
             * area (a fold's edge) is a point at its centroid. */
            double ar = (tr->x[1] - tr->x[0]) * (tr->y[2] - tr->y[0]) -
                        (tr->x[2] - tr->x[0]) * (tr->y[1] - tr->y[0]);
            if (!(fabs(ar) > 1e-12)) {
                double cx = (tr->x[0] + tr->x[1] + tr->x[2]) / 3.0 - x0;
                double cy = (tr->y[0] + tr->y[1] + tr->y[2]) / 3.0 - b0;
                if (!(cx >= 0.0 && cx < W && cy >= 0.0 && cy < H))
                    continue;
                size_t o = (size_t)cy * (size_t)S + (size_t)cx;
                for (int c = 0; c < planes; c++)
                    a[c * P + o] += ch[c], a[c * P + o + 1] -= ch[c];
                continue;
            }
            double inv = (ar < 0.0 ? 2.0 : -2.0) / fabs(ar);
            for (int c = 0; c < planes; c++) {
                if (ch[c] == 0.0)
                    continue;
                for (int e = 0; e < 3; e++) {
                    int e1 = (e + 1) % 3;
                    lr__gt_acc_edge(a + c * P, S, W, H, tr->x[e] - x0,
                                    tr->y[e] - b0, tr->x[e1] - x0,
                                    tr->y[e1] - b0, ch[c] * inv);
                }
            }
        }
        for (int r = 0; r < H; r++) {
            double acc[3] = {0.0, 0.0, 0.0};
            for (int i = 0; i < W; i++) {
                size_t o = (size_t)r * (size_t)S + (size_t)i;
                for (int c = 0; c < planes; c++)
                    acc[c] += a[c * P + o];
                if (!(acc[0] > 0.0 || acc[1] > 0.0 || acc[2] > 0.0))
                    continue;
                lr__v3 v = t->mono ? v3_scale(t->mono_c, acc[0])
                                   : v3(acc[0] > 0.0 ? acc[0] : 0.0,
                                        acc[1] > 0.0 ? acc[1] : 0.0,
                                        acc[2] > 0.0 ? acc[2] : 0.0);
                int px = x0 + i, py = b0 + r;
                if (px < f->x0 || px >= f->x1)
                    continue;
                uint64_t h = lr__mix64(
                    key ^ ((uint64_t)(uint32_t)py << 32 | (uint32_t)px));
                units += lr__gt_splat(f, px, py, v,
                                      (double)(h >> 11) * 0x1.0p-53);
            }
        }
    }
    /* One atomic add a flush: a pixel's each, on the one counter every
     * thread adds to, was a quarter of the flush's time. */
    __atomic_fetch_add(&f->ghost_sum, units, __ATOMIC_RELAXED);
}

/* Holds a triangle of the film with light v, drawing the held ones
 * first when there is no room.  Which triangles are held, and so where
 * a flush falls, depends on the frame alone, never on the region: a
 * pixel's sum is then the same whatever the region (gg_flush). */
static void gg_raster(gg_task *t, const double *x, const double *y, lr__v3 v)
{
    double FW = t->c->width, FH = t->c->height;
    /* A triangle wholly beside the frame adds nothing to it. */
    if ((x[0] < 0.0 && x[1] < 0.0 && x[2] < 0.0) ||
        (x[0] >= FW && x[1] >= FW && x[2] >= FW) ||
        (y[0] < 0.0 && y[1] < 0.0 && y[2] < 0.0) ||
        (y[0] >= FH && y[1] >= FH && y[2] >= FH))
        return;
    if (t->n_tris == LR__GT_TRIS)
        gg_flush(t);
    gg_tri_t *tr = &t->tris[t->n_tris++];
    for (int k = 0; k < 3; k++)
        tr->x[k] = x[k], tr->y[k] = y[k];
    tr->v = v;
}

/* Channel j's triangle of corners a, b, c, of lens area `area`: the part
 * of it inside every aperture, where rel interpolated linearly over it
 * is at most 1 (Hullin et al. 2011, section 4.2: the corners' rel, not
 * a finer grid, finds the edge), clipped in its own coordinates (u, v)
 * so that a triangle folded flat on the film still keeps its share. */
static void gg_tri(gg_task *t, int j, const gg_pt *a, const gg_pt *b,
                   const gg_pt *c, double area)
{
    lr__v3 v = v3_scale(v3_add(a->v[j], v3_add(b->v[j], c->v[j])),
                        area * t->norm / 3.0);
    if (!(v3_maxc(v) > 0.0))
        return;
    double x[3] = {a->fx[j], b->fx[j], c->fx[j]};
    double y[3] = {a->fy[j], b->fy[j], c->fy[j]};
    double f[3] = {1.0 - a->rel[j], 1.0 - b->rel[j], 1.0 - c->rel[j]};
    if (f[0] >= 0.0 && f[1] >= 0.0 && f[2] >= 0.0) {
        gg_raster(t, x, y, v);
        return;
    }
    /* (u, v) of the corners (0, 0), (1, 0), (0, 1), clipped to f >= 0
     * (at most four corners), then a fan of triangles, each with its
     * share of the light by its area in (u, v) (twice: the whole's is
     * 1/2). */
    static const double U[3] = {0, 1, 0}, V[3] = {0, 0, 1};
    double pu[4], pv[4];
    int m = 0;
    for (int i = 0; i < 3; i++) {
        int k = (i + 1) % 3;
        if (f[i] >= 0.0)
            pu[m] = U[i], pv[m++] = V[i];
        if ((f[i] >= 0.0) != (f[k] >= 0.0)) {
            double s = f[i] / (f[i] - f[k]);
            pu[m] = U[i] + s * (U[k] - U[i]),
            pv[m++] = V[i] + s * (V[k] - V[i]);
        }
    }
    for (int i = 1; i + 1 < m; i++) {
        double tu[3] = {pu[0], pu[i], pu[i + 1]},
               tv[3] = {pv[0], pv[i], pv[i + 1]};
        double share = fabs((tu[1] - tu[0]) * (tv[2] - tv[0]) -
                            (tu[2] - tu[0]) * (tv[1] - tv[0]));
        double sx[3], sy[3];
        for (int k = 0; k < 3; k++) {
            sx[k] = x[0] + tu[k] * (x[1] - x[0]) + tv[k] * (x[2] - x[0]);
            sy[k] = y[0] + tu[k] * (y[1] - y[0]) + tv[k] * (y[2] - y[0]);
        }
        if (share > 0.0)
            gg_raster(t, sx, sy, v3_scale(v, share));
    }
}

/* The channels for which the cell with corners p splits (gg_cell), and
 * in *all, *part those whose four corners land, and whose some do. */
static unsigned gg_split(const gg_task *t, const gg_pt *p, unsigned mask,
                         int depth, unsigned *all, unsigned *part)
{
    *all = p[0].ok & p[1].ok & p[2].ok & p[3].ok & mask;
    /* Split only where a corner that lands passes the apertures (the
     * rays past a rim that the lens's formulas lose, a sphere missed or
     * a total reflection, lie outside the ghost), and where the ghost's
     * edge crosses the cell: rel is a largest of ratios, convex, so its
     * interpolation runs high between corners and would trim the edge
     * inward by a share of a cell. */
    unsigned inside = 0, outside = 0;
    for (int q = 0; q < 4; q++)
        for (int j = 0; j < t->nch; j++) {
            if ((p[q].ok >> j & 1) && p[q].rel[j] <= 1.0)
                inside |= 1u << j;
            else
                outside |= 1u << j;
        }
    *part = (p[0].ok | p[1].ok | p[2].ok | p[3].ok) & mask & ~*all & inside;
    return depth > 0 ? *part | (*all & inside & outside) : 0;
}

/* The five points a split adds to the cell of side h at (x0, y0): the
 * edges' midpoints counter-clockwise from the bottom's, then the
 * centre. */
static void gg_mids(double x0, double y0, double h, double *qx, double *qy)
{
    double m = 0.5 * h;
    const double ux[5] = {1, 2, 1, 0, 1}, uy[5] = {0, 1, 2, 1, 1};
    for (int k = 0; k < 5; k++)
        qx[k] = x0 + ux[k] * m, qy[k] = y0 + uy[k] * m;
}

/* The cell of side h at (x0, y0), corners p (counter-clockwise from
 * (x0, y0)), for the channels in mask: drawn as two triangles where all
 * four corners land, split in four where some do (depth more times),
 * and at the last level its triangles of three landed corners.  q: the
 * split's five points (gg_mids) when it splits and the caller has them
 * (gg_grid: a row's splits traced together), else NULL. */
static void gg_cell(gg_task *t, double x0, double y0, double h, const gg_pt *p,
                    unsigned mask, int depth, const gg_pt *q)
{
    unsigned all, part, split = gg_split(t, p, mask, depth, &all, &part);
    for (int j = 0; j < t->nch; j++) {
        if ((all >> j & 1) && !(split >> j & 1)) {
            gg_tri(t, j, &p[0], &p[1], &p[2], 0.5 * h * h);
            gg_tri(t, j, &p[0], &p[2], &p[3], 0.5 * h * h);
        } else if ((part >> j & 1) && depth == 0) {
            /* Three landed corners make one triangle (the two of the
             * cell's that hold them). */
            for (int skip = 0; skip < 4; skip++) {
                const gg_pt *a = &p[(skip + 1) % 4], *b = &p[(skip + 2) % 4];
                const gg_pt *d = &p[(skip + 3) % 4];
                if (!(p[skip].ok >> j & 1) && (a->ok & b->ok & d->ok) >> j & 1)
                    gg_tri(t, j, a, b, d, 0.5 * h * h);
            }
        }
    }
    if (split == 0)
        return;
    double m = 0.5 * h;
    gg_pt own[5];
    if (q == NULL) {
        double qx[5], qy[5];
        gg_pt *qp[5] = {&own[0], &own[1], &own[2], &own[3], &own[4]};
        gg_mids(x0, y0, h, qx, qy);
        gg_eval_n(t, 5, qx, qy, qp);
        q = own;
    }
    gg_pt c0[4] = {p[0], q[0], q[4], q[3]}, c1[4] = {q[0], p[1], q[1], q[4]};
    gg_pt c2[4] = {q[4], q[1], p[2], q[2]}, c3[4] = {q[3], q[4], q[2], p[3]};
    gg_cell(t, x0, y0, m, c0, split, depth - 1, NULL);
    gg_cell(t, x0 + m, y0, m, c1, split, depth - 1, NULL);
    gg_cell(t, x0 + m, y0 + m, m, c2, split, depth - 1, NULL);
    gg_cell(t, x0, y0 + m, m, c3, split, depth - 1, NULL);
}

/* The box's grid.  Its corners are traced LR__GHOST_LANES at a time
 * (gg_eval_n), so they go in as many rows as t->pts holds (every row of
 * a grid up to 30 cells across), and a row of cells' splits in one go:
 * the same corners and the same triangles in the same order as a corner
 * at a time, with the lanes full. */
static void gg_grid(gg_task *t, const double *b)
{
    int N = (int)b[5];
    double hx = (b[2] - b[0]) / N, hy = (b[3] - b[1]) / N;
    /* Square cells (the triangles' lens areas are h^2 / 2): the box's
     * longer side in N cells, the shorter in as many as fit, centred. */
    double h = fmax(hx, hy);
    int nx = (int)ceil((b[2] - b[0]) / h - 1e-9);
    int ny = (int)ceil((b[3] - b[1]) / h - 1e-9);
    double bx = 0.5 * (b[0] + b[2]) - 0.5 * nx * h;
    double by = 0.5 * (b[1] + b[3]) - 0.5 * ny * h;
    int cols = nx + 1, rows = LR__GT_PTS / cols; /* >= 2 */
    unsigned mask = (1u << t->nch) - 1;
    gg_pt **pp = t->pp;
    double *px = t->px, *py = t->py;
    /* Corner rows r0 .. r0 + rows - 1 in t->pts, the first carried over
     * from the last chunk's last. */
    for (int r0 = 0; r0 < ny; r0 += rows - 1) {
        int first = r0 == 0 ? 0 : 1, n = 0;
        int last = r0 + rows - 1 < ny ? r0 + rows - 1 : ny;
        if (r0 > 0)
            memcpy(t->pts, t->pts + (size_t)(rows - 1) * cols,
                   (size_t)cols * sizeof *t->pts);
        for (int r = r0 + first; r <= last; r++)
            for (int i = 0; i < cols; i++, n++) {
                px[n] = bx + i * h, py[n] = by + r * h;
                pp[n] = &t->pts[(size_t)(r - r0) * cols + i];
            }
        gg_eval_n(t, n, px, py, pp);
        for (int r = r0; r < last; r++) {
            gg_pt *lo = t->pts + (size_t)(r - r0) * cols, *hi = lo + cols;
            /* The row's splits' points, five a splitting cell: cell i's
             * from t->mid[at[i]] (-1: it does not split). */
            int ns = 0, at[LR__GT_CELLS_MAX];
            for (int i = 0; i < nx; i++) {
                gg_pt p[4] = {lo[i], lo[i + 1], hi[i + 1], hi[i]};
                unsigned all, part;
                at[i] = -1;
                if (gg_split(t, p, mask, lr__gt_depth, &all, &part) == 0)
                    continue;
                gg_mids(bx + i * h, by + r * h, h, px + ns, py + ns);
                for (int k = 0; k < 5; k++)
                    pp[ns + k] = &t->mid[ns + k];
                at[i] = ns;
                ns += 5;
            }
            gg_eval_n(t, ns, px, py, pp);
            for (int i = 0; i < nx; i++) {
                gg_pt p[4] = {lo[i], lo[i + 1], hi[i + 1], hi[i]};
                gg_cell(t, bx + i * h, by + r * h, h, p, mask, lr__gt_depth,
                        at[i] >= 0 ? &t->mid[at[i]] : NULL);
            }
        }
    }
}

void lr__gt_grid(const lr__lt *lt, const lr_scene *s, const lr__cam *c,
                 uint64_t task, lr__lt_film *f, uint64_t *rays,
                 uint64_t *landed)
{
    int k = lt->n - lt->ghost_lights;
    while (k < lt->n &&
           !(lt->lights[k].grid > 0 && lt->lights[k].grid_first == task))
        k++;
    if (k >= lt->n)
        return;
    const lr__lt_light *l = &lt->lights[k];
    gg_task t;
    memset(&t, 0, sizeof t);
    t.s = s, t.c = c, t.l = l, t.f = f;
    t.k0 = c->chroma.mode == LR_CHROMATIC_OFF ? -1 : 0;
    t.nch = t.k0 < 0 ? 1 : 3;
    lr__v3 Lc = l->Lmean;
    t.mono = t.nch == 1;
    double Lm = v3_maxc(Lc);
    t.mono_ch = Lc.x == Lm ? 0 : Lc.y == Lm ? 1 : 2;
    t.mono_c = Lm > 0.0 ? v3_scale(Lc, 1.0 / Lm) : v3(0, 0, 0);
    double rho = c->model->ghost_disk(c);
    t.key = lr__mix64(0x67686f7374ull ^ (uint64_t)l->geom);
    t.tris = malloc(LR__GT_TRIS * sizeof *t.tris);
    t.band = malloc(3 * (size_t)LR__GT_BAND * sizeof *t.band);
    t.pts = malloc(LR__GT_PTS * sizeof *t.pts);
    t.mid = malloc(LR__GT_MIDS * sizeof *t.mid);
    t.pp = malloc(LR__GT_XY * sizeof *t.pp);
    t.px = malloc(LR__GT_XY * sizeof *t.px);
    t.py = malloc(LR__GT_XY * sizeof *t.py);
    if (t.tris == NULL || t.band == NULL || t.pts == NULL || t.mid == NULL ||
        t.pp == NULL || t.px == NULL || t.py == NULL) {
        __atomic_store_n(&f->nomem, 1, __ATOMIC_RELAXED);
    } else {
        /* A ghost that takes the light's every direction draws each
         * stratum d's midpoint at 1 / grid^2 of the light; one that
         * takes its centre alone draws that, at all of it. */
        int K = l->grid * l->grid;
        for (int d = 0; d < K; d++)
            for (t.g = 0; t.g < l->ghosts; t.g++) {
                const double *b = lr__gt_box(l, t.g);
                int every = b[6] != 0.0;
                if (!(b[0] < b[2]) || (!every && d != 0))
                    continue;
                double u[2] = {every ? (d % l->grid + 0.5) / l->grid : 0.5,
                               every ? (d / l->grid + 0.5) / l->grid : 0.5};
                gg_direction(u, t.ud);
                t.norm = 1.0 / (M_PI * rho * rho * (every ? K : 1));
                gg_grid(&t, b);
            }
        gg_flush(&t);
    }
    free(t.tris);
    free(t.band);
    free(t.pts);
    free(t.mid);
    free(t.pp);
    free(t.px);
    free(t.py);
    *rays += t.rays;
    *landed += t.landed;
    __atomic_fetch_add(&f->ghost_traced, t.traced, __ATOMIC_RELAXED);
}
