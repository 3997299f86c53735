/*
 * ghost16.c: sixteen rays at once through one ghost path (ghost.h:
 * lr__ghost_trace16), for a mesh's corners and a guide's grid, which
 * trace many rays through the same path (ghost_grid.c).
 *
 * The scalar trace (ghost.c) in loops over the lanes that the compiler
 * vectorises (target_clones picks AVX-512, AVX2 or plain x86-64 at load
 * time), as rx_trace.c's lr__rx_trace16 does for the main path: the
 * same operations in the same order, in double, with selects for its
 * early returns, so each lane gets the scalar trace's bits
 * (test_ghost.c compares them).  A path that crosses an aspheric
 * surface (Newton's method, a loop of its own length per ray) goes lane
 * by lane through the scalar code.
 */
#include "optics/ghost.h"

#include <math.h>

#define LN LR__GHOST_LANES

/* Lane by lane through the scalar trace (an aspheric surface on the
 * path). */
static void scalar_lanes(const lr__rx *rx, const double *z,
                         const double *n_after, const lr__ttab *tab, double nm,
                         double stop_scale, const lr__coating *override,
                         lr__ghost g, double sensor_z, const double *clip,
                         const double (*o)[LN], const double (*d)[LN],
                         double (*hit)[LN], double *weight, double *rel,
                         int *alive)
{
    for (int l = 0; l < LN; l++) {
        if (!alive[l])
            continue;
        double ol[3] = {o[0][l], o[1][l], o[2][l]};
        double dl[3] = {d[0][l], d[1][l], d[2][l]}, h[2], w = 0.0, r = 0.0;
        alive[l] = lr__ghost_trace_rel(rx, z, n_after, tab, nm, stop_scale,
                                       override, g, sensor_z, clip, ol, dl, h,
                                       &w, rel != NULL ? &r : NULL);
        if (alive[l]) {
            hit[0][l] = h[0], hit[1][l] = h[1], weight[l] = w;
            if (rel != NULL)
                rel[l] = r;
        }
    }
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__ghost_trace16(const lr__rx *rx, const double *z, const double *n_after,
                  const lr__ttab *tab, double nm, double stop_scale,
                  const lr__coating *override, lr__ghost g, double sensor_z,
                  const double *clip, const double (*o)[LN],
                  const double (*d)[LN], double (*hit)[LN], double *weight,
                  double *rel, int *alive)
{
    lr__ghost_xing x[3 * LR__RX_MAX_SURFACES];
    int m = lr__ghost_crossings(rx, g, x), asph = 0;
    for (int k = 0; k < m; k++)
        asph |= lr__rx_aspheric(&rx->s[x[k].i]);
    if (m < 0) {
        for (int l = 0; l < LN; l++)
            alive[l] = 0;
        return;
    }
    if (asph || tab == NULL) {
        scalar_lanes(rx, z, n_after, tab, nm, stop_scale, override, g, sensor_z,
                     clip, o, d, hit, weight, rel, alive);
        return;
    }
    /* Each lane's cosine at each crossing, for the weights after the
     * geometry (as ghost.c's walk keeps them), and the rays in arrays of
     * this function's own, which nothing else can alias (else the
     * compiler gives up on the loops' dependences). */
    double cosi[3 * LR__RX_MAX_SURFACES][LN];
    double rmax[LN], O[3][LN], D[3][LN];
    int al[LN];
    for (int l = 0; l < LN; l++) {
        rmax[l] = 0.0, al[l] = alive[l];
        for (int a = 0; a < 3; a++)
            O[a][l] = o[a][l], D[a][l] = d[a][l];
    }
    for (int k = 0; k < m; k++) {
        /* Once every lane is lost (a guide's rays outside a ghost's
         * footprint), the rest would change nothing. */
        int any = 0;
        for (int l = 0; l < LN; l++)
            any |= al[l];
        if (!any)
            break;
        int i = x[k].i, fwd = x[k].fwd, mirror = x[k].mirror;
        const lr__surface *s = &rx->s[i];
        const double c = s->radius != 0.0 ? 1.0 / s->radius : 0.0;
        const double k1 = 1.0 + s->conic;
        const double lim = s->semi_aperture *
                           (i == rx->stop ? stop_scale : 1.0);
        const double lim2 = lim * lim, zi = z[i];
        const double before = i > 0 ? n_after[i - 1] : 1.0, after = n_after[i];
        const double n1 = fwd ? before : after, n2 = fwd ? after : before;
        const int bend = !mirror && n1 != n2;
        const double eta = n1 / n2;
        const int relm = rel != NULL;
        for (int l = 0; l < LN; l++) {
            /* lr__rx_meet (rx_trace.c: intersect, normal_at). */
            double gx0 = O[0][l], gy0 = O[1][l], gz0 = O[2][l];
            double ox = gx0, oy = gy0, oz = gz0 - zi;
            double dx = D[0][l], dy = D[1][l], dz = D[2][l];
            double pt[3], nv[3];
            int ok = lr__rx_lane_meet(c, k1, ox, oy, oz, dx, dy, dz, pt, nv);
            double px = pt[0], py = pt[1], pz = pt[2];
            double nx = nv[0], ny = nv[1], nz = nv[2];
            double r2 = px * px + py * py;
            /* rel mode: past the apertures, their largest ratio. */
            double rl = lim > 0.0 ? sqrt(r2) / (lim > 0.0 ? lim : 1.0)
                                  : INFINITY;
            /* fmax (ghost.c), which the vectoriser does not take: the
             * same where neither is a NaN (dead lanes' are not kept). */
            rmax[l] = relm && (al[l] & ok) && rl > rmax[l] ? rl : rmax[l];
            ok &= relm || !(r2 > lim2);
            pz += zi;
            /* ghost.c: cross. */
            double ahead = (px - gx0) * dx + (py - gy0) * dy + (pz - gz0) * dz;
            ok &= !(ahead < -1e-9);
            double dn = dx * nx + dy * ny + dz * nz;
            cosi[k][l] = fabs(dn);
            /* A reflection (d - 2 (d . n) n) or lr__rx_refract, from n1
             * into n2, both computed and one taken. */
            double rx_ = dx - 2.0 * dn * nx, ry = dy - 2.0 * dn * ny,
                   rz = dz - 2.0 * dn * nz;
            double ev[3];
            ok &= lr__rx_lane_refract(eta, nv, dx, dy, dz, ev) || !bend;
            double ex = ev[0], ey = ev[1], ez = ev[2];
            int live = al[l] & ok;
            al[l] = live;
            O[0][l] = live ? px : gx0;
            O[1][l] = live ? py : gy0;
            O[2][l] = live ? pz : gz0;
            /* (Selects on lane-varying conditions: the vectoriser does
             * not take one on mirror or bend alone.) */
            int refl = live && mirror, bent = live && bend;
            D[0][l] = refl ? rx_ : bent ? ex : dx;
            D[1][l] = refl ? ry : bent ? ey : dy;
            D[2][l] = refl ? rz : bent ? ez : dz;
        }
    }
    for (int l = 0; l < LN; l++) {
        double dz = D[2][l];
        int ok = al[l] & (dz > 0.0);
        double t = (sensor_z - O[2][l]) / (ok ? dz : 1.0);
        double hx = O[0][l] + t * D[0][l], hy = O[1][l] + t * D[1][l];
        if (clip != NULL)
            ok &= fabs(hx) < clip[0] && fabs(hy) < clip[1];
        al[l] = alive[l] = ok;
        hit[0][l] = hx, hit[1][l] = hy;
        if (rel != NULL)
            rel[l] = rmax[l];
    }
    /* The weights (ghost.c): R at the two reflections, 1 - R at every
     * other crossing, in the scalar trace's order, for the lanes that
     * landed: a lane at a time (the table's lookups would be gathers,
     * which GCC's generic tuning does not emit). */
    for (int l = 0; l < LN; l++) {
        if (!al[l])
            continue;
        double w = 1.0;
        for (int k = 0; k < m; k++) {
            int i = x[k].i;
            double before = i > 0 ? n_after[i - 1] : 1.0, after = n_after[i];
            double R = before == after
                           ? 0.0
                           : lr__ttab_r(tab, i, x[k].fwd ? before : after,
                                        cosi[k][l]);
            w *= x[k].mirror ? R : 1.0 - R;
        }
        weight[l] = w;
    }
}
