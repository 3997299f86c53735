/*
 * lens_chief.c: the chief ray out of the front of a real lens, tabled by
 * film radius (camera_lens.h, lr__lens_chief), for the blocks whose plan
 * skips the lens (lens_blur.c's bound: the spot under a quarter pixel).
 * There every sample is its film point's chief ray, the ray from the
 * sensor point toward the centre of its exit-pupil bounds (lens_chief,
 * chief_start16 in camera_lens.c); issue 30 found it traced through the
 * glass every sample, so a skipped block cost what a sampled one did.
 *
 * The lens is symmetric about its axis, so the chief ray of film radius
 * r in the direction e leaves the front at (rho e, z) with direction
 * (u e, w), all four functions of r alone, as is its transmittance T.
 * The pupil bounds' centre cx(r) is linear between the pupil table's
 * radii (lr__lens_pupil_at), so the ray is a smooth function of r
 * between them, kinked at them: the table's nodes split each of the
 * pupil table's intervals into LR__CHIEF_SUB, and the camera
 * interpolates linearly between the two nodes around its radius.
 * Linear interpolation's error is at most h^2 / 8 max |f''| on an
 * interval h; tests/test_lens_blur.c measures it against the chief ray
 * traced in double at the film radius itself, on every shipped lens, and
 * docs/plan-lens.md gives the worst: under 1e-4 of a pixel.
 *
 * Also the chief rays' weight's integral (lr__lens_chief_weight_sum, for
 * lens_blur.c): the pupil's mean sample weight, traced in packets.
 */
#include "camera/camera_lens.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The chief ray at film radius r, traced in double (lens_chief's ray in
 * the lens's frame, sensor point (r, 0)): its point and direction on
 * leaving the front and its transmittance.  0: the lens stops it. */
static int chief_at(const lr__cam *c, double r, double o[3], double d[3],
                    double *T)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    lr__pupil P = lr__lens_pupil_at(lc, r);
    if (!(P.rad > 0.0))
        return 0;
    o[0] = r, o[1] = 0.0, o[2] = lc->z_sensor;
    d[0] = P.cx - r, d[1] = 0.0, d[2] = lc->z_rear - lc->z_sensor;
    double len = sqrt(d[0] * d[0] + d[2] * d[2]);
    d[0] /= len, d[2] /= len;
    *T = 0.0;
    return lr__rx_trace_t(&L->rx, L->z, lc->n_ref, lc->stop_scale, 0,
                          &lc->t_ref, c->nm_ref, lc->coat, o, d, T) &&
           *T > 0.0 && d[2] < 0.0;
}

/* A ray of the radial plane as a line (lens_blur.c's): on the plane at
 * inverse depth x from the sensor its lateral point is s + p x. */
static void line_of(const lr__cam *c, double rho, double z, double u, double w,
                    double *s, double *p)
{
    *s = u / -w;
    *p = rho - (c->lens.z_sensor - z) * *s;
}

/* Whether interval i's interpolation is within tol_mm on the film of the
 * traced chief ray at a quarter, half and three quarters of the way (a
 * linear interpolant's error, g (1 - g) h^2 f''/2, is largest near the
 * middle: half the tolerance there leaves room for f'' to vary), at
 * every inverse depth in [0, x_max] (the distance over the film map's
 * derivative J is a Moebius function of x, largest at an end, as in
 * lens_blur.c; J here the nodes' secant, which must keep its sign), and
 * the transmittance within 1e-6. */
static int interval_exact(const lr__cam *c, const lr__lens_chief *t, int i,
                          double h, double x_max, double tol_mm)
{
    double s0, p0, s1, p1;
    line_of(c, t->rho_d[i], t->z_d[i], t->u_d[i], t->w_d[i], &s0, &p0);
    line_of(c, t->rho_d[i + 1], t->z_d[i + 1], t->u_d[i + 1], t->w_d[i + 1],
            &s1, &p1);
    double js = (s1 - s0) / h, jp = (p1 - p0) / h;
    double j0 = js, j1 = js + jp * x_max;
    if (!((j0 > 0.0 && j1 > 0.0) || (j0 < 0.0 && j1 < 0.0)))
        return 0;
    double r0 = c->lens.pupil_rmax * i / (LR__CHIEF_NODES - 1);
    for (int q = 1; q <= 3; q++) {
        double o[3], d[3], T, oi[3], di[3], Ti, s, p, si, pi;
        if (!chief_at(c, r0 + 0.25 * q * h, o, d, &T) ||
            !lr__lens_chief_eval(c, t, r0 + 0.25 * q * h, oi, di, &Ti))
            return 0;
        line_of(c, o[0], o[2], d[0], d[2], &s, &p);
        line_of(c, oi[0], oi[2], di[0], di[2], &si, &pi);
        for (int e = 0; e < 2; e++) {
            double x = e ? x_max : 0.0;
            double dl = fabs((si - s) + (pi - p) * x) / fabs(js + jp * x);
            if (!(dl <= 0.5 * tol_mm))
                return 0;
        }
        if (!(fabs(Ti - T) <= 1e-6 * T))
            return 0;
    }
    return 1;
}

void lr__lens_chief_fill(const lr__cam *c, double x_max, lr__lens_chief *t)
{
    const lr__lens_cam *lc = &c->lens;
    unsigned char ok[LR__CHIEF_NODES];
    for (int i = 0; i < LR__CHIEF_NODES; i++) {
        /* The node's radius, on the pupil table's radii every
         * LR__CHIEF_SUB nodes. */
        double r = lc->pupil_rmax * i / (LR__CHIEF_NODES - 1);
        double o[3], d[3], T;
        ok[i] = (unsigned char)chief_at(c, r, o, d, &T);
        if (!ok[i])
            o[0] = o[2] = d[0] = d[2] = T = 0.0;
        t->rho_d[i] = o[0], t->z_d[i] = o[2];
        t->u_d[i] = d[0], t->w_d[i] = d[2], t->T_d[i] = T;
        t->rho[i] = (float)o[0], t->z[i] = (float)o[2];
        t->u[i] = (float)d[0], t->w[i] = (float)d[2], t->T[i] = (float)T;
        /* Until checked, every interval may be evaluated. */
        t->exact[i] = 1;
    }
    double h = lc->pupil_rmax / (LR__CHIEF_NODES - 1);
    double tol_mm = LR__CHIEF_TOL_PX * lc->sensor_w / LR__CHIEF_FRAME_PX;
    unsigned char ex[LR__CHIEF_NODES];
    t->n_exact = 0;
    for (int i = 0; i + 1 < LR__CHIEF_NODES; i++) {
        ex[i] = ok[i] && ok[i + 1] && interval_exact(c, t, i, h, x_max, tol_mm);
        t->n_exact += ex[i];
    }
    ex[LR__CHIEF_NODES - 1] = 0;
    memcpy(t->exact, ex, sizeof ex);
}

int lr__lens_chief_eval(const lr__cam *c, const lr__lens_chief *t, double r,
                        double o[3], double d[3], double *T)
{
    double s = r / c->lens.pupil_rmax * (LR__CHIEF_NODES - 1);
    int i = (int)s;
    i = i < 0 ? 0 : i > LR__CHIEF_NODES - 2 ? LR__CHIEF_NODES - 2 : i;
    double g = s - i;
    if (!t->exact[i])
        return 0;
    o[0] = t->rho_d[i] + g * (t->rho_d[i + 1] - t->rho_d[i]);
    o[1] = 0.0;
    o[2] = t->z_d[i] + g * (t->z_d[i + 1] - t->z_d[i]);
    d[0] = t->u_d[i] + g * (t->u_d[i + 1] - t->u_d[i]);
    d[1] = 0.0;
    d[2] = t->w_d[i] + g * (t->w_d[i + 1] - t->w_d[i]);
    *T = t->T_d[i] + g * (t->T_d[i + 1] - t->T_d[i]);
    return 1;
}

int lr__lens_chief_traced(const lr__cam *c, double r, double o[3], double d[3],
                          double *T)
{
    return chief_at(c, r, o, d, T);
}

/* ---- the chief rays' weight: the pupil's mean (lens_blur.c) ---------- */

/* cos^4 T of the rays from film radius r toward the rear-plane points
 * (q[2i], q[2i + 1]), i < m, and ok[i] whether the lens passes the ray
 * and it leaves forward (trace_line's rays and test), 64 at a time
 * through the packet camera's float trace and its transmittance table
 * (lr__rx_trace16f): the sum below was the table's largest cost in
 * trace_line's scalar double trace (0.1 s of 0.13 for the double Gauss),
 * and a float cos^4 T is far inside its 1/GW error. */
static void c4t_rays(const lr__cam *c, const double *n, const lr__ttab *tab,
                     double r, const double *q, int m, double *val,
                     unsigned char *ok)
{
    const lr__lens_cam *lc = &c->lens;
    const lr_lens *L = lc->L;
    double dz = lc->z_rear - lc->z_sensor;
    for (int i0 = 0; i0 < m; i0 += LR__RX_LANES) {
        float o[3][LR__RX_LANES], d[3][LR__RX_LANES], T[LR__RX_LANES];
        int alive[LR__RX_LANES];
        for (int i = 0; i < LR__RX_LANES; i++) {
            int at = i0 + i < m ? i0 + i : i0;
            double dx = q[2 * at] - r, dy = q[2 * at + 1];
            double len = sqrt(dx * dx + dy * dy + dz * dz);
            o[0][i] = (float)r, o[1][i] = 0.0f, o[2][i] = (float)lc->z_sensor;
            d[0][i] = (float)(dx / len), d[1][i] = (float)(dy / len);
            d[2][i] = (float)(dz / len);
            alive[i] = i0 + i < m;
            T[i] = 1.0f;
        }
        int lanes = m - i0 < LR__RX_LANES ? (m - i0 + 15) / 16 * 16
                                          : LR__RX_LANES;
        float ct[LR__RX_LANES];
        for (int i = 0; i < lanes; i++)
            ct[i] = -d[2][i];
        lr__rx_trace16f(&L->rx, L->z, n, lc->stop_scale, lanes, o, d, alive,
                        tab, T);
        for (int i = 0; i < lanes && i0 + i < m; i++) {
            double c4 = (double)ct[i] * ct[i] * ct[i] * ct[i];
            ok[i0 + i] = (unsigned char)(alive[i] && d[2][i] < -1e-6f);
            val[i0 + i] = ok[i0 + i] ? c4 * T[i] : 0.0;
        }
    }
}

/* The integral of cos^4 T over where rays from film radius r pass
 * (rear-plane mm^2), by the midpoint rule on a GW x GW grid over the
 * passing box.  Its edge cells carry its error, which falls about as
 * 1 / GW, GW = LR__CHIEF_GW (for the double Gauss at f/11: 0.66% at 48, 0.17% at 128):
 * cells of a GW / 4 grid whose neighbours all pass count their centre's
 * value, the others are cut into 4 x 4.  -1 when out of memory. */
double lr__lens_chief_weight_sum(const lr__cam *c, const double *n,
                                 const lr__ttab *tab, double r,
                                 const lr__pupil *P, int use_disk,
                                 const double *box)
{
    enum { GC = LR__CHIEF_GW / 4, NF = GC * GC * 16 };
    double v[GC + 2][GC + 2], q[2 * GC * GC], val[GC * GC];
    unsigned char ok[GC * GC];
    int at[GC * GC], m = 0;
    double cw = (box[1] - box[0]) / GC, chh = (box[3] - box[2]) / GC;
    /* v: cos^4 T at the coarse centres, -1 where no ray passes (a ring
     * of -1 around the grid). */
    for (int iy = 0; iy < GC + 2; iy++)
        for (int ix = 0; ix < GC + 2; ix++) {
            double a = box[0] + (ix - 0.5) * cw, b = box[2] + (iy - 0.5) * chh;
            v[iy][ix] = -1.0;
            if (ix > 0 && iy > 0 && ix <= GC && iy <= GC &&
                lr__pupil_in_domain(P, use_disk, a, b)) {
                q[2 * m] = P->cx + a, q[2 * m + 1] = b;
                at[m++] = iy * (GC + 2) + ix;
            }
        }
    c4t_rays(c, n, tab, r, q, m, val, ok);
    for (int i = 0; i < m; i++)
        if (ok[i])
            v[at[i] / (GC + 2)][at[i] % (GC + 2)] = val[i];
    double *fq = malloc(sizeof(double) * 3 * NF);
    unsigned char *fok = malloc(NF);
    if (fq == NULL || fok == NULL) {
        free(fq);
        free(fok);
        return -1.0;
    }
    double sum = 0.0, *fval = fq + 2 * NF;
    int nf = 0;
    for (int iy = 1; iy <= GC; iy++)
        for (int ix = 1; ix <= GC; ix++) {
            int inner = 1;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++)
                    inner &= v[iy + dy][ix + dx] >= 0.0;
            if (inner) {
                sum += v[iy][ix] * cw * chh;
                continue;
            }
            for (int sy = 0; sy < 4; sy++)
                for (int sx = 0; sx < 4; sx++) {
                    double a = box[0] + (ix - 1 + (sx + 0.5) / 4) * cw;
                    double b = box[2] + (iy - 1 + (sy + 0.5) / 4) * chh;
                    if (lr__pupil_in_domain(P, use_disk, a, b))
                        fq[2 * nf] = P->cx + a, fq[2 * nf + 1] = b, nf++;
                }
        }
    c4t_rays(c, n, tab, r, fq, nf, fval, fok);
    for (int i = 0; i < nf; i++)
        if (fok[i])
            sum += fval[i] * cw * chh / 16.0;
    free(fq);
    free(fok);
    return sum;
}

double lr__lens_pupil_mean(const lr__cam *c, const double *n,
                           const lr__ttab *tab, double r, const lr__pupil *P,
                           int use_disk, const double *box)
{
    const lr__lens_cam *lc = &c->lens;
    double wsum = lr__lens_chief_weight_sum(c, n, tab, r, P, use_disk, box);
    if (wsum < 0.0)
        return -1.0;
    double dz = lc->z_rear - lc->z_sensor;
    return wsum / (dz * dz) * lc->inv_E0;
}
