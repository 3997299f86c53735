/*
 * light_trace.c: light traced through the lens (light_trace.h).
 *
 * A light path of light k: a point on the aperture from lens sample
 * (u0, u1), uniform by area as the camera's rays take it; a direction
 * from there into the cone the sphere subtends, uniform by solid angle
 * from (u2, u3) (pbrt-v4's Sphere::Sample from a reference point); the
 * ray traced along it must meet the light first, on its emitting side.
 * Then the camera ray that leaves that lens point along that direction is
 * the one the film point (fx, fy) = film(lens point, direction) takes,
 * and the pixel under it gets
 *
 *     L x W / (pdf_dir x N_k)
 *
 * where W = fpx^2 / cos^3 theta is the camera's importance per unit solid
 * angle and lens measure (camera.c, lr__offset_lens_film), pdf_dir =
 * 1 / (2 pi (1 - cos alpha)) the cone's density and N_k the light's
 * paths: the pixel's value is the lens average of the radiance over the
 * pixel, an integral over lens points and directions of L x W, and the
 * aperture's density cancels the lens average's.
 *
 * A glint path (light k seen in flat rough metal G, light_trace.h): a
 * point y on the sphere, uniform by area; a lens point P as above; then
 * the point x of G where the half vector h = a + b of the unit vectors
 * a (x to P) and b (x to y) has a drawn tangential part g.  That g is
 * minus the gradient of phi(x) = |x - P| + |x - y| over the plane,
 * which is strictly convex, so each g names one x: the minimiser of
 * phi(x) + g . x (glint_solve, Newton's method), and x has the area
 * density q(g) det(Hessian of phi) there (a change of variables).  g
 * is drawn as h0 s, s from GGX's own slope density
 *
 *     P22(s) = 1 / (pi alpha^2 (1 + |s|^2 / alpha^2)^2)
 *
 * (Walter et al. 2007's D in slope space; radius alpha sqrt(u / (1 - u))
 * inverts its radial CDF u = r^2 / (alpha^2 + r^2)), h0 = 2 cos theta*
 * the half vector's normal part at the mirror point x*, so that near x*
 * the density follows the lobe.  The estimator is unbiased whatever the
 * guess's error, which only costs variance; paths outside the glint's
 * core are the camera's (lr__lt_glint_core).  The pixel under the
 * camera ray from P to x gets
 *
 *     L f(x) (cos_x' cos_y / |x - y|^2) W / (pdf_w pdf_y N_k)
 *
 * with f the BSDF at x (cos_x' at its shading normal), cos_y at y,
 * pdf_y = 1 / (4 pi r^2), and pdf_w = p_A(x) |x - P|^2 / cos_x the
 * solid-angle density at P of the direction to x (Veach 1997, 8.2.2: a
 * path's area and solid-angle measures).
 */
#include "integrator/light_trace.h"

#include "integrator/ghost_trace.h"

#include "integrator/bsdf.h"
#include "integrator/integrator.h"
#include "scene/envmap.h"
#include "scene/light.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Sampler "pixels" of the light paths: past any frame's pixel index. */
#define LT_PIXEL_BASE ((uint64_t)1 << 48)

uint64_t lr__lt_units(const lr__lt *lt)
{
    return (lt->paths + LR__LT_CHUNK - 1) / LR__LT_CHUNK + lt->grid_tasks;
}

/* The light whose paths hold global path index i. */
static int light_of(const lr__lt *lt, uint64_t i)
{
    int lo = 0, hi = lt->n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (lt->lights[mid].first <= i)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

/* Adds v times each channel's importance at each place ld lands it,
 * and times the light side's MIS weight for the strategies' ratio rho
 * (integrator.h) except in a dark block, where the camera traces
 * nothing.  Counts a landing. */
static void splat_landing(lr__lt_film *f, const lr__landing *ld, lr__v3 v,
                          double rho, uint64_t *landed)
{
    if (!(isfinite(v.x) && isfinite(v.y) && isfinite(v.z)))
        return;
    (*landed)++;
    double w = lr__lt_light_weight(rho);
    for (int j = 0; j < ld->n; j++) {
        const double *W = ld->at[j].W;
        lr__v3 x = v3(v.x * W[0], v.y * W[1], v.z * W[2]);
        int ix = ld->at[j].ix, iy = ld->at[j].iy;
        if (w != 1.0 &&
            !(f->dark != NULL &&
              f->dark[(iy / f->dark_block) * f->dark_bw + ix / f->dark_block]))
            x = v3_scale(x, w);
        lr__lt_splat(f, ix, iy, x);
    }
}

/* A light path's colours: all from one lens point (j = -1), or colour j
 * alone from its own (lr__cam_colours_apart), with spectral mode's
 * wavelengths table wl and their placing uw. */
typedef struct lt_colour {
    const lr__wl_table *wl;
    double uw;
    int j;
    double lw; /* the lens point's density ratio (lens_point_of) */
} lt_colour;

/* Where radiance along w from lens offset (ox, oy) lands, for col. */
static int land(const lr__cam *c, const lt_colour *col, double ox, double oy,
                lr__v3 w, lr__landing *ld)
{
    int hit = col->j < 0 ? lr__cam_land(c, col->wl, col->uw, ox, oy, w, ld)
                         : lr__cam_land_colour(c, col->wl, col->uw, col->j, ox,
                                               oy, w, ld);
    if (hit && col->lw != 1.0)
        for (int k = 0; k < ld->n; k++)
            for (int ch = 0; ch < 3; ch++)
                ld->at[k].W[ch] *= col->lw;
    return hit;
}

/* Light l's lens point from lens sample u: lens_point's, or for a light
 * with a footprint on a real lens's front (light_trace.h) half the time
 * (u[0] < 1/2) lens_point's over the whole front disk of radius rho and
 * half uniform in the footprint's disk, *lw then lens_point's density
 * over the mixture's there (0 off the front), which the landing's
 * importance (lens_point's) is multiplied by. */
static lr__v3 lens_point_of(const lr__cam *c, const lr__lt_light *l,
                            const double u[2], double *ox, double *oy,
                            double *lw)
{
    *lw = 1.0;
    if (!(l->fp_r > 0.0))
        return c->model->lens_point(c, u, ox, oy);
    double rho = c->model->ghost_disk(c), v[2] = {2.0 * u[0], u[1]};
    /* The ratio inside the footprint (the whole front's density over the
     * mixture's); outside it, 2. */
    double in_fp = 1.0 / (0.5 + 0.5 * rho * rho / (l->fp_r * l->fp_r));
    if (v[0] < 1.0) {
        lr__v3 P = c->model->lens_point(c, v, ox, oy);
        double dx = *ox - l->fp_x, dy = *oy - l->fp_y;
        *lw = dx * dx + dy * dy <= l->fp_r * l->fp_r ? in_fp : 1.0 / 0.5;
        return P;
    }
    /* Uniform in the footprint's disk: radius sqrt(v0), angle 2 pi v1. */
    double r = l->fp_r * sqrt(v[0] - 1.0), sn, cs;
    lr__sincos_2pi(v[1], &sn, &cs);
    *ox = l->fp_x + r * cs, *oy = l->fp_y + r * sn;
    *lw = *ox * *ox + *oy * *oy > rho * rho ? 0.0 : in_fp;
    return c->model->lens_at(c, *ox, *oy);
}

lr__v3 lr__lt_emission_at(const lr_scene *s, const lr__lt_light *l,
                          const lr__hit *h)
{
    if (!l->textured)
        return l->L;
    lr__material mt;
    return lr__hit_material(s, h, &mt)->emission;
}

const lr__emitter *lr__lt_mesh_point(const lr_scene *s, const lr__lt_light *l,
                                     const double *u, lr__v3 *y)
{
    size_t lo = 0, hi = l->n_tri - 1;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (u[0] < l->cdf[mid])
            hi = mid;
        else
            lo = mid + 1;
    }
    double c0 = lo > 0 ? l->cdf[lo - 1] : 0.0, c1 = l->cdf[lo];
    double v0 = c1 > c0 ? (u[0] - c0) / (c1 - c0) : 0.5;
    v0 = fmin(fmax(v0, 0.0), 1.0);
    const lr__emitter *e = &s->emitters[l->first_tri + (long)lo];
    /* Uniform on the triangle: b0 = 1 - sqrt(v0), b1 = u1 sqrt(v0)
     * (pbrt-v4's SampleUniformTriangle, the square-root form). */
    double sq = sqrt(v0);
    *y = v3_add(e->a, v3_add(v3_scale(e->e1, sq * (1.0 - u[1])),
                             v3_scale(e->e2, sq * u[1])));
    return e;
}

/* A mesh light's path from lens point P: a triangle by area and a point
 * y on it, uniform by area over the mesh (pdf 1 / A), from (u0, u1) (u0
 * picks the triangle and, rescaled, is reused: the usual trick for one
 * more dimension); the direction w from P to y has solid-angle density
 * dist^2 / (A cos) (cos at y).  The emission is one-sided (the
 * triangle's front, counter-clockwise): seen from behind, nothing.  The
 * camera ray along w must meet this very triangle first, from the front
 * (a mesh can hide its own triangles). */
static void mesh_path(const lr_scene *s, const lr__cam *c,
                      const lr__lt_light *l, lr__v3 P, double ox, double oy,
                      const double *u, const lt_colour *col, lr__lt_film *f,
                      uint64_t *rays, uint64_t *landed)
{
    lr__v3 y;
    const lr__emitter *e = lr__lt_mesh_point(s, l, u, &y);
    lr__v3 dv = v3_sub(y, P);
    double dist2 = v3_dot(dv, dv);
    if (!(dist2 > 0.0))
        return;
    double dist = sqrt(dist2);
    lr__v3 w = v3_scale(dv, 1.0 / dist);
    double cos_y = -v3_dot(w, e->n);
    if (!(cos_y > 0.0))
        return;
    lr__landing ld;
    if (!land(c, col, ox, oy, w, &ld))
        return;
    lr__hit h;
    (*rays)++;
    if (!lr__trace(s, lr__cam_ray_start(c, P, w), w, INFINITY, &h) ||
        h.geom != l->geom ||
        h.prim != (unsigned)(e - &s->emitters[l->first_tri]) || !h.entering)
        return;
    double pdf = dist2 / (l->area * cos_y);
    splat_landing(
        f, &ld,
        v3_scale(lr__lt_emission_at(s, l, &h), 1.0 / (pdf * (double)l->paths)),
        lr__lt_rho(l->mis, c->forward, w), landed);
}

/* The point X of the plane (2-D coordinates) where the half vector's
 * tangential part a_t + b_t is (gx, gy), for P and Y at heights hp, hy
 * over the plane at 2-D points P2, Y2.  a_t + b_t is minus the gradient
 * of phi(X) = |X - P| + |X - Y|, which is strictly convex (hp, hy > 0),
 * so X is the one minimiser of phi(X) + g . X, found by Newton's method
 * with backtracking; H gets phi's Hessian there (xx, xy, yy), whose
 * determinant is the map's Jacobian g -> X.  0 if it did not converge. */
static int glint_solve(const double P2[2], double hp, const double Y2[2],
                       double hy, double gx, double gy, double X[2],
                       double H[3])
{
    X[0] = X[1] = 0.0;
    for (int it = 0; it < 60; it++) {
        double ax = P2[0] - X[0], ay = P2[1] - X[1];
        double bx = Y2[0] - X[0], by = Y2[1] - X[1];
        double la = sqrt(ax * ax + ay * ay + hp * hp);
        double lb = sqrt(bx * bx + by * by + hy * hy);
        double cur = la + lb + gx * X[0] + gy * X[1];
        ax /= la, ay /= la, bx /= lb, by /= lb;
        H[0] = (1.0 - ax * ax) / la + (1.0 - bx * bx) / lb;
        H[1] = -ax * ay / la - bx * by / lb;
        H[2] = (1.0 - ay * ay) / la + (1.0 - by * by) / lb;
        double rx = gx - ax - bx, ry = gy - ay - by; /* the gradient */
        double scale = la + lb;
        if (rx * rx + ry * ry < 1e-20)
            return 1;
        double det = H[0] * H[2] - H[1] * H[1];
        if (!(det > 0.0))
            return 0;
        double sx = -(H[2] * rx - H[1] * ry) / det;
        double sy = -(H[0] * ry - H[1] * rx) / det;
        /* Backtracking: halve the step until phi + g . X decreases. */
        double t = 1.0;
        for (int k = 0; k < 60; k++, t *= 0.5) {
            double nx = X[0] + t * sx, ny = X[1] + t * sy;
            double pa = sqrt((P2[0] - nx) * (P2[0] - nx) +
                             (P2[1] - ny) * (P2[1] - ny) + hp * hp);
            double pb = sqrt((Y2[0] - nx) * (Y2[0] - nx) +
                             (Y2[1] - ny) * (Y2[1] - ny) + hy * hy);
            if (pa + pb + gx * nx + gy * ny <= cur + 1e-15 * scale)
                break;
        }
        X[0] += t * sx, X[1] += t * sy;
    }
    return 0;
}

/* A glint path of l (light_trace.c's header) from lens point P: y on the
 * sphere from uy, the slope from us. */
static void glint_path(const lr_scene *s, const lr__cam *c,
                       const lr__lt_light *l, lr__v3 P, double ox, double oy,
                       const double uy[2], const double us[2],
                       const lt_colour *col, lr__lt_film *f, uint64_t *rays,
                       uint64_t *landed)
{
    /* y uniform by area on the sphere (pbrt-v4's SampleUniformSphere),
     * with its outward normal ny, or on the mesh, with its triangle's
     * front normal (the side that emits). */
    lr__v3 y, ny;
    const lr__emitter *e = NULL;
    double pdf_y;
    if (l->n_tri > 0) {
        e = lr__lt_mesh_point(s, l, uy, &y);
        ny = e->n;
        pdf_y = 1.0 / l->area;
    } else {
        double zy = 1.0 - 2.0 * uy[0], ry = sqrt(fmax(0.0, 1.0 - zy * zy));
        double phi = 2.0 * M_PI * uy[1];
        ny = v3(ry * cos(phi), ry * sin(phi), zy);
        y = v3_madd(l->center, ny, l->radius);
        pdf_y = 1.0 / (4.0 * M_PI * l->radius * l->radius);
    }
    /* P and y in front of the same side of the plane. */
    lr__v3 n = l->plane_n;
    double dP = v3_dot(v3_sub(P, l->plane_p), n);
    double dy = v3_dot(v3_sub(y, l->plane_p), n);
    if (dP < 0.0)
        n = v3_neg(n), dP = -dP, dy = -dy;
    if (!(dP > 0.0) || !(dy > 0.0))
        return;
    /* Plane coordinates around the mirror point x*, where the line from
     * P to y's mirror image meets the plane. */
    lr__v3 Pp = v3_madd(P, n, -dP), yp = v3_madd(y, n, -dy);
    lr__v3 xs = v3_add(Pp, v3_scale(v3_sub(yp, Pp), dP / (dP + dy)));
    lr__v3 t1, t2;
    v3_frame(n, &t1, &t2);
    lr__v3 pr = v3_sub(Pp, xs), yr = v3_sub(yp, xs);
    double P2[2] = {v3_dot(pr, t1), v3_dot(pr, t2)};
    double Y2[2] = {v3_dot(yr, t1), v3_dot(yr, t2)};
    /* The target g of the half vector's tangential part (unnormalised,
     * a_t + b_t): a slope from GGX's density times the half vector's
     * normal part at x*, h0 = 2 cos(theta*).  Where the normal part at
     * x is larger than h0 the true slope is smaller than drawn and the
     * lobe wider than this density: the wide tails are the camera's
     * (lr__lt_glint_core), and within the core the two differ little. */
    double al = l->alpha,
           h0 = 2.0 * (dP + dy) /
                sqrt((dP + dy) * (dP + dy) + (P2[0] - Y2[0]) * (P2[0] - Y2[0]) +
                     (P2[1] - Y2[1]) * (P2[1] - Y2[1]));
    double sn, cs;
    lr__sincos_2pi(us[1], &sn, &cs);
    /* Truncated where no core path can be: there the normal part is at
     * most 2, so |g| < 2 LR__LT_GLINT_CORE alpha (and |g| < 2 always).
     * In units of h0 alpha the truncated radius R keeps a share R^2 /
     * (1 + R^2) of the density, drawn from us[0] rescaled to it. */
    double R = fmin(2.0, 2.0 * LR__LT_GLINT_CORE * al) / (h0 * al);
    double keep = R * R / (1.0 + R * R), u0 = us[0] * keep;
    double rn = sqrt(u0 / (1.0 - u0)), rg = h0 * al * rn;
    double gx = rg * cs, gy = rg * sn;
    double q1 = 1.0 + rn * rn;
    double qg = 1.0 / (M_PI * al * al * h0 * h0 * q1 * q1 * keep);
    double X[2], H[3];
    if (!glint_solve(P2, dP, Y2, dy, gx, gy, X, H))
        return;
    lr__v3 x = v3_add(xs, v3_add(v3_scale(t1, X[0]), v3_scale(t2, X[1])));
    double pA = qg * (H[0] * H[2] - H[1] * H[1]);
    /* The camera ray from P to x. */
    lr__v3 dv = v3_sub(x, P);
    double dist2 = v3_dot(dv, dv);
    if (!(dist2 > 0.0))
        return;
    lr__v3 w = v3_scale(dv, 1.0 / sqrt(dist2));
    double cos_x = fabs(v3_dot(w, n));
    lr__landing ld;
    if (!(cos_x > 0.0) || !land(c, col, ox, oy, w, &ld))
        return;
    /* Light from y to x: from y's front, and in the glint's core (first
     * at the plane's normal, a hair wider, before a ray is spent; then
     * exactly as the camera asks it, at the hit's). */
    lr__v3 xy = v3_sub(y, x);
    double d2 = v3_dot(xy, xy);
    lr__v3 wi = v3_scale(xy, 1.0 / sqrt(d2));
    double cos_y = -v3_dot(wi, ny);
    if (!(cos_y > 0.0) ||
        !lr__lt_glint_core(v3_neg(w), wi, n, l->alpha * (1.0 + 1e-4)))
        return;
    lr__hit hx;
    (*rays)++;
    if (!lr__trace(s, lr__cam_ray_start(c, P, w), w, INFINITY, &hx) ||
        hx.geom != l->surf ||
        !lr__lt_glint_core(v3_neg(w), wi, hx.ng, l->alpha))
        return;
    lr__material mt;
    const lr__material *m = lr__hit_material(s, &hx, &mt);
    lr__bsdf bs;
    lr__bsdf_init(&bs, m, &hx);
    double bpdf;
    lr__v3 fv = lr__bsdf_eval(&bs, v3_neg(w), wi, &bpdf);
    if (!(v3_maxc(fv) > 0.0))
        return;
    /* x must see y itself: the light first, and for a mesh the very
     * triangle, from its front (a mesh can hide its own triangles). */
    (*rays)++;
    lr__v3 Le = l->L;
    if (e == NULL && !l->textured) {
        if (lr__trace_geom(s, lr__offset_origin(&hx, wi), wi, INFINITY) !=
            l->geom)
            return;
    } else {
        lr__hit hy;
        if (!lr__trace(s, lr__offset_origin(&hx, wi), wi, INFINITY, &hy) ||
            hy.geom != l->geom ||
            (e != NULL &&
             (hy.prim != (unsigned)(e - &s->emitters[l->first_tri]) ||
              !hy.entering)))
            return;
        Le = lr__lt_emission_at(s, l, &hy);
    }
    double pdf_w = pA * dist2 / cos_x;
    double g = fabs(v3_dot(wi, hx.ns)) * cos_y / d2;
    splat_landing(
        f, &ld,
        v3_scale(v3_mul(Le, fv), g / (pdf_w * pdf_y * (double)l->paths)), 0.0,
        landed);
}

lr__v3 lr__lt_in_cone(lr__v3 a, double omc, const double u[2])
{
    double t = u[0] * omc; /* 1 - cos theta */
    double cos_t = 1.0 - t, sin_t = sqrt(t * (2.0 - t));
    double phi = 2.0 * M_PI * u[1];
    lr__v3 t1, t2;
    v3_frame(a, &t1, &t2);
    lr__v3 w = v3_add(
        v3_scale(a, cos_t),
        v3_add(v3_scale(t1, sin_t * cos(phi)), v3_scale(t2, sin_t * sin(phi))));
    return v3_norm(w);
}

/* The environment's sun seen from lens point P: a direction w uniform in
 * its cone (the camera's rays that escape within the cone add none of
 * the environment there: lr__lt_sun), landing where the camera ray from
 * P along w starts, if that ray escapes: the map's radiance along w over
 * the cone's density. */
static void sun_path(const lr_scene *s, const lr__cam *c, const lr__lt_light *l,
                     lr__v3 P, double ox, double oy, const double *ud,
                     const lt_colour *col, lr__lt_film *f, uint64_t *rays,
                     uint64_t *landed)
{
    lr__v3 w = lr__lt_in_cone(l->center, l->area, ud);
    lr__landing ld;
    if (!land(c, col, ox, oy, w, &ld))
        return;
    (*rays)++;
    if (lr__trace_geom(s, lr__cam_ray_start(c, P, w), w, INFINITY) != -2)
        return;
    double pdf = 1.0 / (2.0 * M_PI * l->area);
    splat_landing(
        f, &ld,
        v3_scale(lr__env_radiance(s, w), 1.0 / (pdf * (double)l->paths)),
        lr__lt_rho(l->mis, c->forward, w), landed);
}

/* A sphere light's path from lens point P: a direction uniform in the
 * cone the sphere fills seen from P. */
static void sphere_path(const lr_scene *s, const lr__cam *c,
                        const lr__lt_light *l, lr__v3 P, double ox, double oy,
                        const double *ud, const lt_colour *col, lr__lt_film *f,
                        uint64_t *rays, uint64_t *landed)
{
    lr__v3 dv = v3_sub(l->center, P);
    double dist2 = v3_dot(dv, dv), r2 = l->radius * l->radius;
    if (!(dist2 > r2))
        return;
    double dist = sqrt(dist2);
    lr__v3 a = v3_scale(dv, 1.0 / dist);
    /* 1 - cos alpha = sin^2 / (1 + cos), without cancellation for the
     * tiny cones of far lights. */
    double sin2 = r2 / dist2, cos_a = sqrt(1.0 - sin2);
    double omc = sin2 / (1.0 + cos_a);
    lr__v3 w = lr__lt_in_cone(a, omc, ud);
    lr__landing ld;
    if (!land(c, col, ox, oy, w, &ld))
        return;
    /* The camera ray along w must meet this light first (from outside a
     * sphere, on its emitting side): exactly the rays whose emission the
     * camera side leaves out (light_trace.h).  The same trace as the
     * camera's keeps the two sides a partition: a shadow ray up to the
     * analytic hit, cheaper still, lost 1e-4 of the light (near the
     * cone's rim the traced sphere's own hit came before its margin). */
    (*rays)++;
    /* A camera ray that starts inside the sphere (the bracket's start on
     * its image plane, in a light that reaches across it) meets its
     * inside, which emits nothing: the same sphere, from inside, was
     * splatted here, up to 77 times the light the camera sees. */
    lr__v3 S = lr__cam_ray_start(c, P, w), sc = v3_sub(S, l->center);
    if (!(v3_dot(sc, sc) > r2))
        return;
    lr__v3 Le = l->L;
    if (!l->textured) {
        if (lr__trace_geom(s, S, w, INFINITY) != l->geom)
            return;
    } else {
        lr__hit h;
        if (!lr__trace(s, S, w, INFINITY, &h) || h.geom != l->geom)
            return;
        Le = lr__lt_emission_at(s, l, &h);
    }
    double pdf = 1.0 / (2.0 * M_PI * omc);
    splat_landing(f, &ld, v3_scale(Le, 1.0 / (pdf * (double)l->paths)),
                  lr__lt_rho(l->mis, c->forward, w), landed);
}

/* The sampler "pixel" of light l's paths: by its geometry's index (and a
 * glint's surface's), so that a region that leaves some lights out draws
 * the same numbers for the others. */
static uint64_t light_key(const lr__lt_light *l)
{
    if (l->surf == LR__LT_PATHS)
        return LT_PIXEL_BASE + ((uint64_t)1 << 46) + (uint64_t)l->geom;
    if (l->surf == LR__LT_GHOST)
        return LT_PIXEL_BASE + ((uint64_t)1 << 45) + (uint64_t)l->geom;
    return LT_PIXEL_BASE + (uint64_t)l->geom +
           (l->surf < 0 ? 0 : (uint64_t)(l->surf + 1) << 24);
}

/* Ghost path g's sequence of ghost light l (lr__gt_which): a "pixel" of
 * its own beside the light's (g < 2^13 < 2^45 / 2^32). */
static uint64_t ghost_key(const lr__lt_light *l, int g)
{
    return light_key(l) + ((uint64_t)(g + 1) << 32);
}

/* Ghost light l's offset for lr__gt_which, uniform in [0, 1) from the
 * render's seed and the light (0 for other lights: unused). */
static double ghost_u(const lr__lt *lt, const lr__lt_light *l)
{
    if (l->surf != LR__LT_GHOST)
        return 0.0;
    return (double)(lr__mix64(lt->seed ^ lr__mix64(light_key(l))) >> 11) *
           0x1.0p-53;
}

static void splat_cb(void *film, const lr__landing *ld, lr__v3 v,
                     uint64_t *landed)
{
    splat_landing(film, ld, v, 0.0, landed);
}

void lr__lt_unit(const lr__lt *lt, const lr_scene *s, const lr__cam *c,
                 uint64_t u, lr__lt_film *f, uint64_t *rays, uint64_t *landed,
                 uint64_t *ghosts)
{
    uint64_t n_path = (lt->paths + LR__LT_CHUNK - 1) / LR__LT_CHUNK;
    if (u >= n_path) {
        lr__gt_grid(lt, s, c, u - n_path, f, rays, ghosts);
        return;
    }
    lr__sampler smp;
    lr__sampler_init(&smp, LR_SAMPLER_SOBOL, lt->seed, 1);
    uint64_t i0 = u * LR__LT_CHUNK, i1 = i0 + LR__LT_CHUNK;
    if (i1 > lt->paths)
        i1 = lt->paths;
    int k = light_of(lt, i0);
    /* A light's paths are the samples of a "pixel" of its own
     * (light_key): the pixel dimensions give the direction (a glint's
     * point on the light, and dimensions 4 and 5 its slope), the lens
     * dimensions (the sequence's best pair, as for camera rays) the lens
     * point. */
    lr__pixel_sampler ps;
    lr__pixel_sampler_init(&ps, &smp, light_key(&lt->lights[k]));
    int n_col = lr__cam_colours_apart(c);
    /* A ghost light's paths: those of each ghost path in one run of
     * indices (lr__gt_which), each run a sequence of its own (ghost_key),
     * from an offset u of the light's own. */
    int cur_g = -1;
    double gu = ghost_u(lt, &lt->lights[k]);
    for (uint64_t i = i0; i < i1; i++) {
        if (i >= lt->lights[k].first + lt->lights[k].paths) {
            while (i >= lt->lights[k].first + lt->lights[k].paths)
                k++;
            lr__pixel_sampler_init(&ps, &smp, light_key(&lt->lights[k]));
            cur_g = -1;
            gu = ghost_u(lt, &lt->lights[k]);
        }
        const lr__lt_light *l = &lt->lights[k];
        uint32_t idx = (uint32_t)(i - l->first);
        if (l->surf == LR__LT_PATHS) {
            lr__lp_path(lt->lp, s, c, &smp, light_key(l), idx,
                        (double)lt->lp_paths, splat_cb, f, rays, landed);
            continue;
        }
        double q[4], ox, oy;
        if (l->surf == LR__LT_GHOST) {
            uint32_t j;
            int g = lr__gt_which(l, gu, idx, &j);
            if (g != cur_g) {
                lr__pixel_sampler_init(&ps, &smp, ghost_key(l, g));
                cur_g = g;
            }
            double ug[2];
            lr__pixel_sampler_get(&ps, j, q);
            lr__sample_2d(&smp, ghost_key(l, g), j, 4, ug);
            lr__gt_path(s, c, l, g, q + 2, q, ug[0], ug[1], f, rays, ghosts);
            continue;
        }
        lr__pixel_sampler_get(&ps, idx, q);
        const double *ud = q, *ul = q + 2;
        /* Spectral mode: dimension 6 places the path's wavelengths. */
        double uw[2] = {0.0, 0.0};
        if (lt->wl != NULL)
            lr__sample_2d(&smp, light_key(l), idx, 6, uw);
        double us[2] = {0.0, 0.0};
        if (l->surf >= 0)
            lr__sample_2d(&smp, light_key(l), idx, 4, us);
        /* Every colour from the lens point, or (a lens point that moves
         * with the focus: the bracket's) each colour from its own, the
         * same numbers for each. */
        lt_colour col = {lt->wl, uw[0], -1, 1.0};
        for (int j = n_col > 0 ? 0 : -1; j < n_col; j++) {
            col.j = j;
            lr__v3 P = j < 0 ? lens_point_of(c, l, ul, &ox, &oy, &col.lw)
                             : lr__cam_colour_point(c, lt->wl, uw[0], j, ul,
                                                    &ox, &oy);
            if (col.lw == 0.0)
                continue;
            if (l->surf >= 0)
                glint_path(s, c, l, P, ox, oy, ud, us, &col, f, rays, landed);
            else if (l->n_tri > 0)
                mesh_path(s, c, l, P, ox, oy, ud, &col, f, rays, landed);
            else if (l->surf == LR__LT_SUN)
                sun_path(s, c, l, P, ox, oy, ud, &col, f, rays, landed);
            else
                sphere_path(s, c, l, P, ox, oy, ud, &col, f, rays, landed);
        }
    }
}
