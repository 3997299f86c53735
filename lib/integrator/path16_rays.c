/*
 * path16_rays.c: the path integrator's rays and hashed random numbers
 * for a packet's sixteen paths at once (path.h), from the arrays that
 * hold them (lr__paths16): the later bounces' hashed numbers, the
 * shadow and continuation rays packed for few_triangles.c and
 * spheres.c, or as Embree's packets, and the light of the unblocked
 * shadow rays.  Each is what path.c's lane-by-lane code gave, to the bit
 * (tests/test_path16.c checks them against it).
 */
#include "integrator/path.h"
#include "sampling/sampler.h"

#include <float.h>
#include <math.h>

/* x y mod 2^64 from 32-bit halves: AVX2 and AVX-512F multiply 32 x 32
 * -> 64 bits in vectors, not 64 x 64 (that is AVX-512DQ's, which GCC's
 * target_clones cannot name alone), so GCC vectorises this form. */
static inline uint64_t mul64(uint64_t x, uint64_t y)
{
    uint64_t xl = (uint32_t)x, xh = x >> 32, yl = (uint32_t)y, yh = y >> 32;
    return xl * yl + ((xh * yl + xl * yh) << 32);
}

/* sampler.c's lr__mix64 (splitmix64's finaliser), the same values:
 * with the 64-bit multiply, and from halves (mul64). */
static inline uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static inline uint64_t mix64_halves(uint64_t z)
{
    z = mul64(z ^ (z >> 30), 0xbf58476d1ce4e5b9ull);
    z = mul64(z ^ (z >> 27), 0x94d049bb133111ebull);
    return z ^ (z >> 31);
}

/* x < 2^52 as a double, exactly: its bits under 2^52's exponent, less
 * 2^52 (no 64-bit integer conversion before AVX-512DQ). */
static inline double small_to_double(uint64_t x)
{
    union {
        uint64_t u;
        double d;
    } b = {.u = x | 0x4330000000000000ull};
    return b.d - 0x1p52;
}

/* The live lanes' numbers, packed (as hashes of a lane each, there is
 * nothing to gain from computing the others).  `wide`: the form for
 * AVX-512 vectors, the 64-bit products and conversions from 32-bit
 * halves; else the plain one, which stays scalar (with four lanes to an
 * AVX2 vector the halves cost more than scalar code, by callgrind). */
static inline __attribute__((always_inline)) void
hashed_lanes(const uint64_t *restrict key, int m, uint32_t dim, int dims,
             double (*restrict h)[16], const int wide)
{
    for (int j = 0; j < dims; j++) {
        uint64_t c = (uint64_t)(dim + (uint32_t)j) * 0x9e3779b97f4a7c15ull;
        for (int i = 0; i < m; i++) {
            /* (double)(h >> 11) * 2^-53 as path.c's scalar code had it:
             * h >> 11 < 2^53 is hi 2^32 + lo, each part exact as a
             * double, and so is their sum. */
            if (wide) {
                uint64_t x = mix64_halves(key[i] ^ c) >> 11;
                double d = small_to_double(x >> 32) * 0x1p32 +
                           small_to_double(x & 0xffffffffull);
                h[j][i] = d * 0x1p-53;
            } else {
                h[j][i] = (double)(mix64(key[i] ^ c) >> 11) * 0x1p-53;
            }
        }
    }
}

__attribute__((target("avx512f"))) static void
hashed_avx512(const uint64_t *restrict key, int m, uint32_t dim, int dims,
              double (*restrict h)[16])
{
    hashed_lanes(key, m, dim, dims, h, 1);
}

static void hashed(const uint64_t *restrict key, int m, uint32_t dim, int dims,
                   double (*restrict h)[16])
{
    if (__builtin_cpu_supports("avx512f"))
        hashed_avx512(key, m, dim, dims, h);
    else
        hashed_lanes(key, m, dim, dims, h, 0);
}

void lr__path16_hashed(const uint64_t key[16], const double alive[16],
                       uint32_t dim, int dims, double u[LR__PATH_DIMS][16])
{
    int lane[16];
    uint64_t k[16] = {0};
    double h[LR__PATH_DIMS - 1][16];
    int m = lr__path16_lanes_of(alive, lane);
    for (int c = 0; c < m; c++)
        k[c] = key[lane[c]];
    hashed(k, m, dim, dims, h);
    for (int j = 0; j < dims; j++)
        for (int c = 0; c < m; c++)
            u[j][lane[c]] = h[j][c];
}

/* Entries c0..m-1 of P with tnear 0, but a ray Embree could not take
 * (lr__embree_can_trace) meets nothing, as lr__shadow_ray16 makes it.  In a loop of
 * its own over the packed entries, which GCC vectorises. */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
quiet(lr__rays_packed *P, int c0, int m)
{
    const double lim = LR__EMBREE_MAX_COORD;
    for (int c = c0; c < m; c++) {
        int ok = (fabs(P->ox[c]) <= lim) & (fabs(P->oy[c]) <= lim) &
                 (fabs(P->oz[c]) <= lim) & (fabs(P->dx[c]) <= lim) &
                 (fabs(P->dy[c]) <= lim) & (fabs(P->dz[c]) <= lim);
        P->ox[c] = ok ? P->ox[c] : 0.0, P->oy[c] = ok ? P->oy[c] : 0.0;
        P->oz[c] = ok ? P->oz[c] : 0.0;
        P->dx[c] = ok ? P->dx[c] : 0.0, P->dy[c] = ok ? P->dy[c] : 0.0;
        P->dz[c] = ok ? P->dz[c] : 1.0;
        P->tn[c] = ok ? 0.0 : 1.0;
        P->tf[c] = ok ? P->tf[c] : 0.0;
    }
}

int lr__path16_pack_shadows(const lr__paths16 *S, lr__rays_packed *P)
{
    int m = lr__path16_lanes_of(S->shadow, P->lane);
    for (int c = 0; c < m; c++) {
        int i = P->lane[c];
        P->ox[c] = S->sox[i], P->oy[c] = S->soy[i], P->oz[c] = S->soz[i];
        P->dx[c] = S->sdx[i], P->dy[c] = S->sdy[i], P->dz[c] = S->sdz[i];
        P->tf[c] = S->stfar[i];
    }
    P->m = m;
    return m;
}

int lr__path16_pack_rays(const lr__paths16 *S, lr__rays_packed *P)
{
    int m0 = P->m;
    int m = lr__path16_lanes_of(S->alive, P->lane + m0);
    for (int c = m0; c < m0 + m; c++) {
        int i = P->lane[c];
        P->ox[c] = S->ox[i], P->oy[c] = S->oy[i], P->oz[c] = S->oz[i];
        P->dx[c] = S->dx[i], P->dy[c] = S->dy[i], P->dz[c] = S->dz[i];
        P->tf[c] = INFINITY;
    }
    P->m = m0 + m;
    /* (Both kinds' bounds checked here, in one call.) */
    quiet(P, 0, m0 + m);
    return m;
}

void lr__path16_unoccluded(lr__paths16 *S, const lr__rays_packed *P, int ns,
                           const double occ[LR__PACKED])
{
    for (int c = 0; c < ns; c++) {
        int i = P->lane[c];
        if (occ[c] == 0.0) {
            S->Lr[i] = S->Lr[i] + S->scr[i];
            S->Lg[i] = S->Lg[i] + S->scg[i];
            S->Lb[i] = S->Lb[i] + S->scb[i];
        }
    }
}

/* Lanes with on[i] set as lr__shadow_ray16 fills them (the ray from o
 * along d up to tf: in float, a ray Embree could not take made one that
 * meets nothing), the others as lr__ray16_quiet_lanes leaves them;
 * valid[i] -1 or 0.  Returns how many are on.  (Constant `next`: tf is
 * infinite.) */
static inline __attribute__((always_inline)) int
ray16_fill(const double *restrict ox, const double *restrict oy,
           const double *restrict oz, const double *restrict dx,
           const double *restrict dy, const double *restrict dz,
           const double *restrict tf, const double *restrict on_,
           struct RTCRay16 *restrict r, int *restrict valid, const int next)
{
    const double lim = LR__EMBREE_MAX_COORD;
    int count = 0;
    for (int i = 0; i < 16; i++) {
        int on = on_[i] != 0.0;
        double t = next ? INFINITY : tf[i];
        int ok = (fabs(ox[i]) <= lim) & (fabs(oy[i]) <= lim) &
                 (fabs(oz[i]) <= lim) & (fabs(dx[i]) <= lim) &
                 (fabs(dy[i]) <= lim) & (fabs(dz[i]) <= lim);
        int use = on & ok;
        r->org_x[i] = use ? (float)ox[i] : 0.0f;
        r->org_y[i] = use ? (float)oy[i] : 0.0f;
        r->org_z[i] = use ? (float)oz[i] : 0.0f;
        r->dir_x[i] = use ? (float)dx[i] : 0.0f;
        r->dir_y[i] = use ? (float)dy[i] : 0.0f;
        r->dir_z[i] = use ? (float)dz[i] : 1.0f;
        r->tnear[i] = use ? 0.0f : 1.0f;
        r->tfar[i] = use ? (t < FLT_MAX ? (float)t : FLT_MAX) : 0.0f;
        r->time[i] = 0.0f;
        r->mask[i] = 0xFFFFFFFFu;
        r->id[i] = 0;
        r->flags[i] = 0;
        valid[i] = on ? -1 : 0;
        count += on;
    }
    return count;
}

__attribute__((target_clones("avx512f", "avx2", "default"))) int
lr__path16_shadows16(const lr__paths16 *S, struct RTCRay16 *r, int valid[16])
{
    return ray16_fill(S->sox, S->soy, S->soz, S->sdx, S->sdy, S->sdz, S->stfar,
                      S->shadow, r, valid, 0);
}

__attribute__((target_clones("avx512f", "avx2", "default"))) int
lr__path16_rays16(const lr__paths16 *S, struct RTCRayHit16 *rh, int valid[16])
{
    int go = ray16_fill(S->ox, S->oy, S->oz, S->dx, S->dy, S->dz, NULL,
                        S->alive, &rh->ray, valid, 1);
    for (int i = 0; i < 16; i++) {
        unsigned none = RTC_INVALID_GEOMETRY_ID;
        rh->hit.geomID[i] = valid[i] ? none : rh->hit.geomID[i];
        rh->hit.instID[0][i] = valid[i] ? none : rh->hit.instID[0][i];
    }
    return go;
}
