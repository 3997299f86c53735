/*
 * few_triangles.c: the path integrator's packets against a scene's
 * triangles when it has only a few (scene.h: lr__few_triangles; trace.h), every
 * shape tested for eight packed lanes at once in vectorised loops, in
 * double.  A shape is a triangle, or the parallelogram of two triangles
 * of a mesh that make one (a rectangle object's two), tested once.
 *
 * Why: on the Cornell box of bench/path (12 triangles, 2 spheres met in
 * spheres.c) Embree took 32% of a path's CPU time, about 100 ns a ray
 * (perf, one thread): per call it walks its BVH and its packet logic for
 * a handful of primitives.  Six parallelogram tests, eight lanes to an
 * AVX-512 instruction, cost a few ns a ray.  Past a few dozen triangles
 * a BVH wins, so scenes with more keep Embree.
 *
 * What a hit reports is what Embree reports and lr__hit_complete reads:
 * geometry and primitive IDs, t (as float in tfar) and the barycentrics
 * (u, v) of corners b and c (Embree's convention: p = (1 - u - v) a + u b
 * + v c).  Embree works in float, this in double, so t and (u, v) differ
 * from Embree's in the last float bits, and rays within that rounding
 * of an edge may take the other triangle (tests/test_path.c:
 * test_few_triangles_match_embree).
 */
#include "accel/trace.h"

#include <math.h>

int lr__few_triangles_enabled = 1;

/* Which of (x, s1, s2) corner v is: 0, 1 or 2. */
static unsigned char which(unsigned v, unsigned x, unsigned s1)
{
    return v == x ? 0 : v == s1 ? 1 : 2;
}

/* Shape j: corner x, edges to s1 and s2 (float corners, in double). */
static void shape_set(lr__few_triangles *T, int j, const float *x,
                      const float *s1, const float *s2)
{
    T->ax[j] = x[0], T->ay[j] = x[1], T->az[j] = x[2];
    T->e1x[j] = (double)s1[0] - x[0];
    T->e1y[j] = (double)s1[1] - x[1];
    T->e1z[j] = (double)s1[2] - x[2];
    T->e2x[j] = (double)s2[0] - x[0];
    T->e2y[j] = (double)s2[1] - x[1];
    T->e2z[j] = (double)s2[2] - x[2];
    T->nx[j] = T->e1y[j] * T->e2z[j] - T->e1z[j] * T->e2y[j];
    T->ny[j] = T->e1z[j] * T->e2x[j] - T->e1x[j] * T->e2z[j];
    T->nz[j] = T->e1x[j] * T->e2y[j] - T->e1y[j] * T->e2x[j];
}

/* If triangles ia and ib (index triples) share two corners s1, s2 and
 * their others x, y make a parallelogram (x + y = s1 + s2 in float, to
 * within 1e-6 of the corners' size), sets x, y, s1, s2 and returns 1. */
static int parallelogram(const float *V, const unsigned *ia, const unsigned *ib,
                         unsigned q[4])
{
    for (int k = 0; k < 3; k++) {
        unsigned x = ia[k], s1 = ia[(k + 1) % 3], s2 = ia[(k + 2) % 3];
        for (int j = 0; j < 3; j++) {
            unsigned y = ib[j], b1 = ib[(j + 1) % 3], b2 = ib[(j + 2) % 3];
            if (!((b1 == s1 && b2 == s2) || (b1 == s2 && b2 == s1)) || y == x)
                continue;
            double size = 1.0, err = 0.0;
            for (int c = 0; c < 3; c++) {
                double d = (double)V[3 * x + c] + V[3 * y + c] - V[3 * s1 + c] -
                           V[3 * s2 + c];
                err = fmax(err, fabs(d));
                size = fmax(size, fabs((double)V[3 * s1 + c]) +
                                      fabs((double)V[3 * s2 + c]));
            }
            if (err > 1e-6 * size)
                return 0;
            q[0] = x, q[1] = y, q[2] = s1, q[3] = s2;
            return 1;
        }
    }
    return 0;
}

int lr__few_triangles_build(lr_scene *s)
{
    lr__few_triangles *T = &s->few_tris;
    T->n = 0;
    T->n_shapes = 0;
    if (!lr__few_triangles_enabled)
        return 0;
    size_t n = 0;
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *G = &s->geoms[g];
        if (G->kind == LR__GEOM_TRIANGLES)
            n += G->n_triangles;
        else if (G->kind != LR__GEOM_SPHERE)
            return 0;
    }
    if (n == 0 || n > LR__FEW_TRIANGLES)
        return 0;
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *G = &s->geoms[g];
        if (G->kind != LR__GEOM_TRIANGLES)
            continue;
        const float *V = G->vertices;
        for (size_t t = 0; t < G->n_triangles; t++) {
            const unsigned *ia = &G->indices[3 * t];
            int j = T->n_shapes++;
            int k = (int)T->n++;
            T->geom[k] = (unsigned)g;
            T->prim[k] = (unsigned)t;
            T->first[j] = k;
            T->second[j] = -1;
            T->quad[j] = 0.0;
            unsigned q[4];
            if (t + 1 < G->n_triangles && parallelogram(V, ia, ia + 3, q)) {
                /* Triangles t and t + 1 as one shape. */
                const unsigned *ib = ia + 3;
                shape_set(T, j, &V[3 * (size_t)q[0]], &V[3 * (size_t)q[2]],
                          &V[3 * (size_t)q[3]]);
                T->corner_b[k] = which(ia[1], q[0], q[2]);
                T->corner_c[k] = which(ia[2], q[0], q[2]);
                int k2 = (int)T->n++;
                T->geom[k2] = (unsigned)g;
                T->prim[k2] = (unsigned)t + 1;
                T->corner_b[k2] = which(ib[1], q[1], q[2]);
                T->corner_c[k2] = which(ib[2], q[1], q[2]);
                T->second[j] = k2;
                T->quad[j] = 1.0;
                t++;
                continue;
            }
            shape_set(T, j, &V[3 * (size_t)ia[0]], &V[3 * (size_t)ia[1]],
                      &V[3 * (size_t)ia[2]]);
            T->corner_b[k] = 1;
            T->corner_c[k] = 2;
        }
    }
    return 1;
}

/* Entry i's ray against shape k (Moller & Trumbore 1997, "Fast,
 * minimum storage ray-triangle intersection", with the triangle's normal
 * n = e1 x e2 precomputed: with T = o - a and C = T x d, det = -d.n,
 * u det = e2.C, v det = -e1.C, t det = T.n, by the triple products'
 * rotation; 33 operations where the textbook's order takes 41), without
 * its divisions: with D = |det| and the signs of u det, v det, t det
 * turned by det's, u = U / D, v = V / D, t = N / D, and a hit is 0 <= U,
 * V, U + V <= D, tnear D < N and N / D nearer than the best so far,
 * bn / bd (D, bd > 0: N bd < bn D).  One division per entry at the end
 * instead of one per triangle: vdivpd is slow, and the intersection's
 * CPU time fell by about a half.  A parallelogram's test is the same
 * with U, V <= D instead of U + V <= D (its s, t in [0, 1]); the two
 * triangles of each of the Cornell box's rectangles tested as one shape
 * cost 1.09x less CPU overall (min of 4 runs each).  A ray in the
 * shape's plane (D = 0)
 * passes every test only if N > 0 and N 1 < bn 0, which cannot be.  The
 * tests are combined with & so that GCC vectorises the loop
 * (-fno-trapping-math in the Makefile lets it compute them all). */
#define MT_TEST(T, k, ox, oy, oz, dx, dy, dz, tn, D, U, V, N, hit_ok)          \
    do {                                                                       \
        double tx = ox - T->ax[k], ty = oy - T->ay[k], tz = oz - T->az[k];     \
        double cx = ty * dz - tz * dy;                                         \
        double cy = tz * dx - tx * dz;                                         \
        double cz = tx * dy - ty * dx;                                         \
        double dn = dx * T->nx[k] + dy * T->ny[k] + dz * T->nz[k];             \
        double sg = dn > 0.0 ? -1.0 : 1.0; /* the sign of det = -dn */         \
        D = dn * -sg;                                                          \
        U = (T->e2x[k] * cx + T->e2y[k] * cy + T->e2z[k] * cz) * sg;           \
        V = (T->e1x[k] * cx + T->e1y[k] * cy + T->e1z[k] * cz) * -sg;          \
        N = (tx * T->nx[k] + ty * T->ny[k] + tz * T->nz[k]) * sg;              \
        hit_ok = (U >= 0.0) & (V >= 0.0) & (N > tn * D) &                      \
                 ((U + V <= D) | ((T->quad[k] != 0.0) & (U <= D) & (V <= D))); \
    } while (0)

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__few_triangles_intersect(const lr__few_triangles *T, lr__rays_packed *P,
                            int c0, double tri[LR__PACKED],
                            double u[LR__PACKED], double v[LR__PACKED])
{
    /* The best hit so far: t = bn / bd, and (s, t) = (bu, bv) / bd in
     * its shape's edges. */
    double bn[LR__PACKED], bd[LR__PACKED], bu[LR__PACKED], bv[LR__PACKED],
        best[LR__PACKED];
    int n = T->n_shapes;
    for (int c0 = 0; c0 < P->m8; c0 += 8) {
        for (int i = c0; i < c0 + 8; i++) {
            bn[i] = P->tf[i];
            bd[i] = 1.0;
            bu[i] = bv[i] = 0.0;
            best[i] = -1.0;
        }
        for (int k = 0; k < n; k++)
            for (int i = c0; i < c0 + 8; i++) {
                double D, U, V, N;
                int ok;
                MT_TEST(T, k, P->ox[i], P->oy[i], P->oz[i], P->dx[i], P->dy[i],
                        P->dz[i], P->tn[i], D, U, V, N, ok);
                int hit = ok & (N * bd[i] < bn[i] * D);
                bn[i] = hit ? N : bn[i];
                bd[i] = hit ? D : bd[i];
                bu[i] = hit ? U : bu[i];
                bv[i] = hit ? V : bv[i];
                best[i] = hit ? (double)k : best[i];
            }
        for (int i = c0; i < c0 + 8; i++)
            P->tf[i] = bn[i] / bd[i];
    }
    /* The triangle of the shape, and its barycentrics: in (x, s1, s2)
     * the weights are (1 - s - t, s, t); in (y, s1, s2), since y = s1 +
     * s2 - x, they are (s + t - 1, 1 - t, 1 - s). */
    for (int c = 0; c < c0; c++)
        tri[c] = best[c];
    for (int c = c0; c < P->m; c++) {
        tri[c] = -1.0;
        if (best[c] < 0.0)
            continue;
        int j = (int)best[c];
        double S = bu[c] / bd[c], Tt = bv[c] / bd[c], w[3];
        int k;
        if (bu[c] + bv[c] <= bd[c] || T->second[j] < 0) {
            k = T->first[j];
            w[0] = 1.0 - S - Tt, w[1] = S, w[2] = Tt;
        } else {
            k = T->second[j];
            w[0] = S + Tt - 1.0, w[1] = 1.0 - Tt, w[2] = 1.0 - S;
        }
        tri[c] = (double)k;
        u[c] = w[T->corner_b[k]];
        v[c] = w[T->corner_c[k]];
    }
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__few_triangles_occluded(const lr__few_triangles *T, const lr__rays_packed *P,
                           double occ[LR__PACKED])
{
    int n = T->n_shapes;
    for (int c0 = 0; c0 < P->m8; c0 += 8) {
        for (int i = c0; i < c0 + 8; i++)
            occ[i] = 0.0;
        for (int k = 0; k < n; k++)
            for (int i = c0; i < c0 + 8; i++) {
                double D, U, V, N;
                int ok;
                MT_TEST(T, k, P->ox[i], P->oy[i], P->oz[i], P->dx[i], P->dy[i],
                        P->dz[i], P->tn[i], D, U, V, N, ok);
                int hit = ok & (N < P->tf[i] * D);
                occ[i] = hit ? 1.0 : occ[i];
            }
    }
}
