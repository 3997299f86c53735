/*
 * few_triangles.c: the path integrator's packets against a scene's
 * triangles when it has only a few (scene.h: lr__few_triangles), all of
 * them tested for all sixteen lanes in one vectorised loop, in double.
 *
 * Why: on the Cornell box of bench/path (12 triangles, 2 spheres met in
 * spheres.c) Embree took 32% of a path's CPU time, about 100 ns a ray
 * (perf, one thread): per call it walks its BVH and its packet logic for
 * a handful of primitives.  Twelve Moller-Trumbore tests, eight lanes to
 * an AVX-512 instruction, cost a few ns a ray.  Past a few dozen
 * triangles a BVH wins, so scenes with more keep Embree.
 *
 * What a hit reports is what Embree reports and lr__hit_complete reads:
 * geometry and primitive IDs, t (as float in tfar) and the barycentrics
 * (u, v) of corners b and c (Embree's convention: p = (1 - u - v) a + u b
 * + v c).  Embree works in float; this works in double on the packets'
 * float rays, so t and (u, v) differ from Embree's in the last float
 * bits, and rays within that rounding of an edge may take the other
 * triangle (tests/test_path.c: test_few_triangles_match_embree).
 */
#include "scene.h"

#include <math.h>

int lr__few_triangles_enabled = 1;

int lr__few_triangles_build(lr_scene *s)
{
    lr__few_triangles *T = &s->few_tris;
    T->n = 0;
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
        for (size_t t = 0; t < G->n_triangles; t++) {
            const unsigned *ix = &G->indices[3 * t];
            const float *a = &G->vertices[3 * (size_t)ix[0]];
            const float *b = &G->vertices[3 * (size_t)ix[1]];
            const float *c = &G->vertices[3 * (size_t)ix[2]];
            size_t k = T->n++;
            T->ax[k] = a[0], T->ay[k] = a[1], T->az[k] = a[2];
            T->e1x[k] = (double)b[0] - a[0];
            T->e1y[k] = (double)b[1] - a[1];
            T->e1z[k] = (double)b[2] - a[2];
            T->e2x[k] = (double)c[0] - a[0];
            T->e2y[k] = (double)c[1] - a[1];
            T->e2z[k] = (double)c[2] - a[2];
            T->nx[k] = T->e1y[k] * T->e2z[k] - T->e1z[k] * T->e2y[k];
            T->ny[k] = T->e1z[k] * T->e2x[k] - T->e1x[k] * T->e2z[k];
            T->nz[k] = T->e1x[k] * T->e2y[k] - T->e1y[k] * T->e2x[k];
            T->geom[k] = (unsigned)g;
            T->prim[k] = (unsigned)t;
        }
    }
    return 1;
}

/* Entry i's ray against triangle k (Moller & Trumbore 1997, "Fast,
 * minimum storage ray-triangle intersection", with the triangle's normal
 * n = e1 x e2 precomputed: with T = o - a and C = T x d, det = -d.n,
 * u det = e2.C, v det = -e1.C, t det = T.n, by the triple products'
 * rotation; 33 operations where the textbook's order takes 41), without
 * its divisions: with D = |det| and the signs of u det, v det, t det
 * turned by det's, u = U / D, v = V / D, t = N / D, and a hit is 0 <= U,
 * V, U + V <= D, tnear D < N and N / D nearer than the best so far,
 * bn / bd (D, bd > 0: N bd < bn D).  One division per entry at the end
 * instead of one per triangle: vdivpd is slow, and the intersection's
 * CPU time fell by about a half.  A ray in the triangle's plane (D = 0)
 * passes every test only if N > 0 and N 1 < bn 0, which cannot be.  The
 * tests are combined with & so that GCC vectorises the loop
 * (-fno-trapping-math in the Makefile lets it compute them all). */
#define MT_TEST(T, k, ox, oy, oz, dx, dy, dz, tn, D, U, V, N, hit_ok)       \
    do {                                                                    \
        double tx = ox - T->ax[k], ty = oy - T->ay[k], tz = oz - T->az[k];  \
        double cx = ty * dz - tz * dy;                                      \
        double cy = tz * dx - tx * dz;                                      \
        double cz = tx * dy - ty * dx;                                      \
        double dn = dx * T->nx[k] + dy * T->ny[k] + dz * T->nz[k];          \
        double sg = dn > 0.0 ? -1.0 : 1.0; /* the sign of det = -dn */      \
        D = dn * -sg;                                                       \
        U = (T->e2x[k] * cx + T->e2y[k] * cy + T->e2z[k] * cz) * sg;        \
        V = (T->e1x[k] * cx + T->e1y[k] * cy + T->e1z[k] * cz) * -sg;       \
        N = (tx * T->nx[k] + ty * T->ny[k] + tz * T->nz[k]) * sg;           \
        hit_ok = (U >= 0.0) & (V >= 0.0) & (U + V <= D) & (N > tn * D);     \
    } while (0)

__attribute__((target_clones("avx512f", "avx2", "default")))
void lr__few_triangles_intersect(const lr__few_triangles *T,
                                 lr__rays_packed *P, double tri[16],
                                 double u[16], double v[16])
{
    /* The best hit so far: t = bn / bd, u = bu / bd, v = bv / bd. */
    double bn[16], bd[16], bu[16], bv[16];
    int n = (int)T->n;
    for (int c0 = 0; c0 < P->m8; c0 += 8) {
        for (int i = c0; i < c0 + 8; i++) {
            bn[i] = P->tf[i];
            bd[i] = 1.0;
            bu[i] = bv[i] = 0.0;
            tri[i] = -1.0;
        }
        for (int k = 0; k < n; k++)
            for (int i = c0; i < c0 + 8; i++) {
                double D, U, V, N;
                int ok;
                MT_TEST(T, k, P->ox[i], P->oy[i], P->oz[i], P->dx[i],
                        P->dy[i], P->dz[i], P->tn[i], D, U, V, N, ok);
                int hit = ok & (N * bd[i] < bn[i] * D);
                bn[i] = hit ? N : bn[i];
                bd[i] = hit ? D : bd[i];
                bu[i] = hit ? U : bu[i];
                bv[i] = hit ? V : bv[i];
                tri[i] = hit ? (double)k : tri[i];
            }
        for (int i = c0; i < c0 + 8; i++) {
            double inv = 1.0 / bd[i];
            P->tf[i] = bn[i] * inv;
            u[i] = bu[i] * inv;
            v[i] = bv[i] * inv;
        }
    }
}

__attribute__((target_clones("avx512f", "avx2", "default")))
void lr__few_triangles_occluded(const lr__few_triangles *T,
                                const lr__rays_packed *P, double occ[16])
{
    int n = (int)T->n;
    for (int c0 = 0; c0 < P->m8; c0 += 8) {
        for (int i = c0; i < c0 + 8; i++)
            occ[i] = 0.0;
        for (int k = 0; k < n; k++)
            for (int i = c0; i < c0 + 8; i++) {
                double D, U, V, N;
                int ok;
                MT_TEST(T, k, P->ox[i], P->oy[i], P->oz[i], P->dx[i],
                        P->dy[i], P->dz[i], P->tn[i], D, U, V, N, ok);
                int hit = ok & (N < P->tf[i] * D);
                occ[i] = hit ? 1.0 : occ[i];
            }
    }
}
