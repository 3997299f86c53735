/*
 * rx_trace16f.c: packets of rays through a prescription in float, for
 * the packet camera (prescription.h, lr__rx_trace16f).  (GCC's
 * approximate reciprocal square roots, under -ffast-math's options, were
 * measured no faster here: 66 against 67 ns a ray through the double
 * Gauss.)  Each surface's step is a chain of two square roots and a
 * division a lane, and each surface waits for the one before: a single
 * packet left the processor waiting on that chain, so the camera hands
 * over up to four packets, whose vectors are independent and overlap.
 */
#include "optics/prescription.h"
#include "optics/transmit.h"

#include <immintrin.h>
#include <math.h>
#include <string.h>

/* The packet camera's version: lr__rx_trace16's loop in float, one
 * AVX-512 vector for each packet's sixteen lanes (Embree traces floats
 * anyway; a lens's millimetres keep 1e-6 mm in float).  Two square roots and a
 * division per surface are saved by identities, not approximations: on a
 * sphere (k = 0) the quadric's half-gradient (-cx, -cy, 1 - cz) has
 * length^2 = c (c (x^2 + y^2 + z^2) - 2z) + 1 = 1, so it is the unit
 * normal as it stands; and the vector form of Snell's law maps a unit
 * direction to a unit direction, so the direction is normalised once, by
 * the caller, not after every surface.  Aspheric surfaces go through
 * lr__rx_asph16, in double. */
/* A surface's transmittance from the directions before (d0) and after
 * (d1) a refraction toward the object, for the aspheric surfaces traced
 * in double (lr__rx_asph16): the normal is parallel to n1 d0 - n2 d1 (the
 * vector form of Snell's law), so cos^2 in the incident medium is
 * (d0 . v)^2 / |v|^2. */
static double aspheric_t(const lr__ttab *tab, int i, const double *n_after,
                         const double *d0, const double *d1)
{
    double n1 = n_after[i], n2 = i > 0 ? n_after[i - 1] : 1.0;
    if (n1 == n2)
        return 1.0;
    double v[3], dv = 0.0, vv = 0.0;
    for (int a = 0; a < 3; a++) {
        v[a] = n1 * d0[a] - n2 * d1[a];
        dv += d0[a] * v[a];
        vv += v[a] * v[a];
    }
    double c = vv > 0.0 ? fabs(dv) / sqrt(vv) : 1.0;
    return lr__ttab_at(tab, i, n1, c);
}

/* An aspheric surface on every lane: in double, sixteen lanes at a time,
 * by lr__rx_asph16 (Newton's method), each lane's transmittance by
 * aspheric_t. */
static void aspheric16(const lr__rx *rx, const double *z, const double *n_after,
                       double stop_scale, int i, int lanes,
                       float (*o)[LR__RX_LANES], float (*d)[LR__RX_LANES],
                       int *alive, const lr__ttab *tab, float *T)
{
    double n1[16], n2[16];
    for (int l = 0; l < 16; l++)
        n1[l] = n_after[i], n2[l] = i > 0 ? n_after[i - 1] : 1.0;
    for (int b = 0; b < lanes; b += 16) {
        double od[3][16], dd[3][16], d0[3][16];
        int live[16];
        for (int l = 0; l < 16; l++) {
            for (int a = 0; a < 3; a++)
                od[a][l] = o[a][b + l], dd[a][l] = d0[a][l] = d[a][b + l];
            live[l] = alive[b + l];
        }
        lr__rx_asph16(rx, z, n1, n2, stop_scale, i, od, dd, live, NULL);
        for (int l = 0; l < 16; l++) {
            if (!alive[b + l])
                continue;
            alive[b + l] = live[l];
            if (!live[l])
                continue;
            if (tab != NULL) {
                double a0[3] = {d0[0][l], d0[1][l], d0[2][l]};
                double a1[3] = {dd[0][l], dd[1][l], dd[2][l]};
                T[b + l] *= (float)aspheric_t(tab, i, n_after, a0, a1);
            }
            for (int a = 0; a < 3; a++)
                o[a][b + l] = (float)od[a][l], d[a][b + l] = (float)dd[a][l];
        }
    }
}

int lr__rx_trace_isa = 0;

/* T[l] *= the table row's T at the cosine cosv[l] on the ray's side, for
 * `lanes` lanes (a multiple of 8): the sine invariant's n1^2 (1 - cos^2)
 * into the cosine on the lower-index side (transmit.h), its fourth root
 * into the row, linear interpolation (with the row's differences, dt,
 * computed once in float: the same values).  A lane lost on the way has
 * a meaningless cosine (NaN or infinite); its index is kept inside the
 * row and its weight is read by nobody.  Portable C, AVX2 and AVX-512:
 * the same operations in the same order, the same bits. */
static void ttab_apply_c(int lanes, const float *cosv, float n1s, float tk,
                         const float *trow, const float *tdt, float *T)
{
    /* Copies: read through pointers that might alias T, the lookups kept
     * GCC from vectorising the loop at all (scalar, it was a third of
     * the lens's time). */
    float row[LR__T_N], dt[LR__T_N];
    memcpy(row, trow, sizeof row);
    memcpy(dt, tdt, sizeof dt);
    for (int l = 0; l < lanes; l++) {
        float ci = cosv[l];
        float c2 = 1.0f - n1s * (1.0f - ci * ci) * tk;
        float x = sqrtf(sqrtf(c2 > 0.0f ? c2 : 0.0f)) * (float)LR__T_N;
        int j = x < (float)LR__T_N ? (int)x : LR__T_N - 1;
        j = j < LR__T_N - 1 ? j : LR__T_N - 1;
        float fr = x - (float)j;
        T[l] *= row[j] + fr * dt[j];
    }
}

/* The AVX2 version.  Its gathers (two per eight lanes) bound it on AMD's
 * Zen 3, and most crossings are within 50 degrees of the normal, where
 * the index is in the row's last sixteen entries: eight lanes that all
 * are take them from registers by permutes instead. */
__attribute__((target("avx2"))) static void
ttab_apply_avx2(int lanes, const float *cosv, float n1s, float tk,
                const float *row, const float *dt, float *T)
{
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    const __m256 vn1s = _mm256_set1_ps(n1s), vtk = _mm256_set1_ps(tk);
    const __m256 vn = _mm256_set1_ps((float)LR__T_N);
    const __m256i last = _mm256_set1_epi32(LR__T_N - 1);
    const __m256i k48 = _mm256_set1_epi32(LR__T_N - 16);
    const __m256i k55 = _mm256_set1_epi32(LR__T_N - 9);
    const __m256 r6 = _mm256_loadu_ps(row + LR__T_N - 16);
    const __m256 r7 = _mm256_loadu_ps(row + LR__T_N - 8);
    const __m256 d6 = _mm256_loadu_ps(dt + LR__T_N - 16);
    const __m256 d7 = _mm256_loadu_ps(dt + LR__T_N - 8);
    /* Two passes, the square roots in the first (as surface16's). */
    float xs[LR__RX_LANES] __attribute__((aligned(32)));
    for (int l = 0; l < lanes; l += 8) {
        __m256 ci = _mm256_loadu_ps(cosv + l);
        __m256 s = _mm256_mul_ps(vn1s,
                                 _mm256_sub_ps(one, _mm256_mul_ps(ci, ci)));
        __m256 c2 = _mm256_sub_ps(one, _mm256_mul_ps(s, vtk));
        /* c2 > 0 ? c2 : 0 (NaN: 0). */
        c2 = _mm256_and_ps(_mm256_cmp_ps(c2, zero, _CMP_GT_OQ), c2);
        _mm256_store_ps(xs + l,
                        _mm256_mul_ps(_mm256_sqrt_ps(_mm256_sqrt_ps(c2)), vn));
    }
    for (int l = 0; l < lanes; l += 8) {
        __m256 x = _mm256_load_ps(xs + l);
        /* x < N ? (int)x : N - 1, then at most N - 1. */
        __m256i j = _mm256_cvttps_epi32(x);
        j = _mm256_blendv_epi8(
            last, j, _mm256_castps_si256(_mm256_cmp_ps(x, vn, _CMP_LT_OQ)));
        j = _mm256_min_epi32(j, last);
        __m256 fr = _mm256_sub_ps(x, _mm256_cvtepi32_ps(j));
        __m256 a, b;
        if (_mm256_testz_si256(_mm256_cmpgt_epi32(k48, j),
                               _mm256_cmpgt_epi32(k48, j))) {
            /* Every index in the last sixteen: the permutes read its
             * low three bits. */
            __m256 hi = _mm256_castsi256_ps(_mm256_cmpgt_epi32(j, k55));
            a = _mm256_blendv_ps(_mm256_permutevar8x32_ps(r6, j),
                                 _mm256_permutevar8x32_ps(r7, j), hi);
            b = _mm256_blendv_ps(_mm256_permutevar8x32_ps(d6, j),
                                 _mm256_permutevar8x32_ps(d7, j), hi);
        } else {
            a = _mm256_i32gather_ps(row, j, 4);
            b = _mm256_i32gather_ps(dt, j, 4);
        }
        __m256 t = _mm256_add_ps(a, _mm256_mul_ps(fr, b));
        _mm256_storeu_ps(T + l, _mm256_mul_ps(_mm256_loadu_ps(T + l), t));
    }
}

/* The AVX-512 version: the whole row (64 entries, four registers) is
 * read by two two-register permutes and a blend on the index's bit 5,
 * for every lane, with no gathers (on an Intel Xeon the AVX2 version
 * was 13% of the lens's time on the bench scene). */
__attribute__((target("avx512f"))) static void
ttab_apply_avx512(int lanes, const float *cosv, float n1s, float tk,
                  const float *row, const float *dt, float *T)
{
    const __m512 one = _mm512_set1_ps(1.0f), zero = _mm512_setzero_ps();
    const __m512 vn1s = _mm512_set1_ps(n1s), vtk = _mm512_set1_ps(tk);
    const __m512 vn = _mm512_set1_ps((float)LR__T_N);
    const __m512i last = _mm512_set1_epi32(LR__T_N - 1);
    const __m512i k32 = _mm512_set1_epi32(32);
    __m512 r[4], d[4];
    for (int q = 0; q < 4; q++)
        r[q] = _mm512_loadu_ps(row + 16 * q),
        d[q] = _mm512_loadu_ps(dt + 16 * q);
    /* Two passes, the square roots in the first, so that the lanes'
     * chains overlap (as the AVX2 version's). */
    float xs[LR__RX_LANES] __attribute__((aligned(64)));
    for (int l = 0; l < lanes; l += 16) {
        __mmask16 m = lanes - l >= 16 ? 0xffff : 0x00ff;
        __m512 ci = _mm512_maskz_loadu_ps(m, cosv + l);
        __m512 s = _mm512_mul_ps(vn1s,
                                 _mm512_sub_ps(one, _mm512_mul_ps(ci, ci)));
        __m512 c2 = _mm512_sub_ps(one, _mm512_mul_ps(s, vtk));
        /* c2 > 0 ? c2 : 0 (NaN: 0). */
        c2 = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(c2, zero, _CMP_GT_OQ), c2);
        _mm512_store_ps(xs + l,
                        _mm512_mul_ps(_mm512_sqrt_ps(_mm512_sqrt_ps(c2)), vn));
    }
    for (int l = 0; l < lanes; l += 16) {
        __mmask16 m = lanes - l >= 16 ? 0xffff : 0x00ff;
        __m512 x = _mm512_load_ps(xs + l);
        /* x < N ? (int)x : N - 1, then at most N - 1. */
        __m512i j = _mm512_mask_mov_epi32(last,
                                          _mm512_cmp_ps_mask(x, vn, _CMP_LT_OQ),
                                          _mm512_cvttps_epi32(x));
        j = _mm512_min_epi32(j, last);
        __m512 fr = _mm512_sub_ps(x, _mm512_cvtepi32_ps(j));
        __mmask16 hi = _mm512_cmpge_epi32_mask(j, k32);
        __m512 a = _mm512_mask_blend_ps(hi,
                                        _mm512_permutex2var_ps(r[0], j, r[1]),
                                        _mm512_permutex2var_ps(r[2], j, r[3]));
        __m512 b = _mm512_mask_blend_ps(hi,
                                        _mm512_permutex2var_ps(d[0], j, d[1]),
                                        _mm512_permutex2var_ps(d[2], j, d[3]));
        __m512 t = _mm512_add_ps(a, _mm512_mul_ps(fr, b));
        _mm512_mask_storeu_ps(
            T + l, m, _mm512_mul_ps(_mm512_maskz_loadu_ps(m, T + l), t));
    }
}

static void ttab_apply(int lanes, const float *cosv, float n1s, float tk,
                       const float *row, const float *dt, float *T)
{
    int isa = lr__rx_trace_isa                    ? lr__rx_trace_isa
              : __builtin_cpu_supports("avx512f") ? 3
              : __builtin_cpu_supports("avx2")    ? 2
                                                  : 1;
    if (isa == 3)
        ttab_apply_avx512(lanes, cosv, n1s, tk, row, dt, T);
    else if (isa == 2)
        ttab_apply_avx2(lanes, cosv, n1s, tk, row, dt, T);
    else
        ttab_apply_c(lanes, cosv, n1s, tk, row, dt, T);
}

/* One surface of the quadric family (not aspheric, not a flat surface
 * between equal media), on every lane, in five passes over all the
 * lanes (16 known lanes, a vector, at a time): the quadratic, its
 * discriminant's square root, the root, the normal and refracted
 * cosine, the refracted direction.  Each pass is a short chain of
 * long-latency steps (square roots, a division); run over all the
 * packets' vectors one after another, the processor overlaps their
 * chains (a single pass a packet for the whole surface took 57 ns a ray
 * through the double Gauss at f/2.8 with the transmittance, four passes
 * over all the lanes 46, ttab_apply's two passes 43, five here 42).
 * Always inlined, with `sphere` a constant at each call: a sphere's
 * unit normal needs no square root and division (top of file), and a
 * loop that selected between both forms computed both.  The far root's
 * division (a start beyond the centre of curvature) is taken only when
 * a lane needs it: the root's pass keeps the near root and marks those
 * lanes, and the values are the ones the select of both would give, bit
 * for bit. */
static inline __attribute__((always_inline)) void
surface16(int lanes, float c, float k1, float lim2, float zi, float eta,
          int bend, int sphere, float (*o)[LR__RX_LANES],
          float (*d)[LR__RX_LANES], int *alive, float *cosv)
{
    float tt[LR__RX_LANES], dd[LR__RX_LANES], aa[LR__RX_LANES];
    float bb[LR__RX_LANES], cc[LR__RX_LANES], ds[LR__RX_LANES];
    int ok0[LR__RX_LANES], far[LR__RX_LANES], any = 0;
    for (int b = 0; b < lanes; b += 16) {
        for (int i = b; i < b + 16; i++) {
            int l = i;
            float ox = o[0][l], oy = o[1][l], oz = o[2][l] - zi;
            float dx = d[0][l], dy = d[1][l], dz = d[2][l];
            /* On a sphere k1 = 1 and |d| = 1 (top of file): A = c. */
            float A = sphere ? c : c * (dx * dx + dy * dy + k1 * dz * dz);
            float B = sphere ? c * (ox * dx + oy * dy + oz * dz) - dz
                             : c * (ox * dx + oy * dy + k1 * oz * dz) - dz;
            float C = sphere
                          ? c * (ox * ox + oy * oy + oz * oz) - 2.0f * oz
                          : c * (ox * ox + oy * oy + k1 * oz * oz) - 2.0f * oz;
            float disc = B * B - A * C;
            aa[i] = A, bb[i] = B, cc[i] = C, ds[i] = disc;
        }
    }
    for (int b = 0; b < lanes; b += 16) {
        for (int i = b; i < b + 16; i++) {
            float B = bb[i], disc = ds[i];
            dd[i] = B + copysignf(sqrtf(disc >= 0.0f ? disc : 0.0f), B);
        }
    }
    for (int b = 0; b < lanes; b += 16) {
        for (int i = b; i < b + 16; i++) {
            float oz = o[2][i] - zi, dz = d[2][i];
            float A = aa[i], C = cc[i], disc = ds[i], den = dd[i];
            float t = -C / (den != 0.0f ? den : 1.0f);
            /* A start beyond the centre of curvature: the other root (as
             * in rx_trace.c's intersect), -den / A, below. */
            int f = A != 0.0f && !(1.0f - c * k1 * (oz + t * dz) > 0.0f);
            tt[i] = t, far[i] = f;
            ok0[i] = (disc >= 0.0f) & (den != 0.0f);
            any |= f;
        }
    }
    if (any)
        for (int b = 0; b < lanes; b += 16)
            for (int i = b; i < b + 16; i++)
                tt[i] = far[i] ? -dd[i] / (aa[i] != 0.0f ? aa[i] : 1.0f)
                               : tt[i];
    /* The refraction, the square root in a pass of its own. */
    float mxa[LR__RX_LANES], mya[LR__RX_LANES], mza[LR__RX_LANES];
    float ka[LR__RX_LANES];
    for (int b = 0; b < lanes; b += 16) {
        for (int i = b; i < b + 16; i++) {
            int l = i;
            float ox = o[0][l], oy = o[1][l], oz0 = o[2][l], oz = oz0 - zi;
            float dx = d[0][l], dy = d[1][l], dz = d[2][l];
            float t = tt[i];
            int ok = ok0[i];
            ok &= isfinite(t);
            float px = ox + t * dx, py = oy + t * dy, pz = oz + t * dz;
            float gx = -c * px, gy = -c * py, gz = 1.0f - c * k1 * pz;
            ok &= gz > 0.0f;
            float inv = sphere ? 1.0f
                               : 1.0f / sqrtf(gx * gx + gy * gy + gz * gz);
            float mx = gx * inv, my = gy * inv, mz = gz * inv;
            ok &= !(px * px + py * py > lim2);
            float cosi = -(mx * dx + my * dy + mz * dz);
            float sg = cosi < 0.0f ? -1.0f : 1.0f;
            mx *= sg, my *= sg, mz *= sg, cosi *= sg;
            float k = 1.0f - eta * eta * (1.0f - cosi * cosi);
            ok &= !bend || k >= 0.0f;
            int live = alive[l] & ok;
            alive[l] = live;
            cosv[l] = cosi;
            mxa[l] = mx, mya[l] = my, mza[l] = mz, ka[l] = k;
            /* Every lane stored, the old value where it stays: a
             * conditional store became a masked one (vmaskmovps, slow
             * on AMD's processors). */
            o[0][l] = live ? px : ox;
            o[1][l] = live ? py : oy;
            o[2][l] = live ? pz + zi : oz0;
        }
    }
    if (!bend)
        return;
    for (int b = 0; b < lanes; b += 16) {
        for (int i = b; i < b + 16; i++) {
            int l = i;
            float dx = d[0][l], dy = d[1][l], dz = d[2][l];
            float cosi = cosv[l], k = ka[l];
            float mx = mxa[l], my = mya[l], mz = mza[l];
            float fq = eta * cosi - sqrtf(k >= 0.0f ? k : 0.0f);
            float ex = eta * dx + fq * mx, ey = eta * dy + fq * my,
                  ez = eta * dz + fq * mz;
            int live = alive[l];
            d[0][l] = live ? ex : dx;
            d[1][l] = live ? ey : dy;
            d[2][l] = live ? ez : dz;
        }
    }
}

__attribute__((target_clones("avx512f", "avx2", "default"))) void
lr__rx_trace16f(const lr__rx *rx, const double *z, const double *n_after,
                double stop_scale, int lanes, float (*o)[LR__RX_LANES],
                float (*d)[LR__RX_LANES], int *alive, const lr__ttab *tab,
                float *T)
{
    int n = rx->n;
    float cosv[LR__RX_LANES];
    for (int step = 0; step < n; step++) {
        int i = n - 1 - step;
        const lr__surface *s = &rx->s[i];
        if (lr__rx_aspheric(s)) {
            aspheric16(rx, z, n_after, stop_scale, i, lanes, o, d, alive, tab,
                       T);
            continue;
        }
        const float c = (float)(s->radius != 0.0 ? 1.0 / s->radius : 0.0);
        const float k1 = (float)(1.0 + s->conic);
        const double limd = s->semi_aperture *
                            (i == rx->stop ? stop_scale : 1.0);
        const float lim2 = (float)(limd * limd), zi = (float)z[i];
        const double n1 = n_after[i], n2 = i > 0 ? n_after[i - 1] : 1.0;
        const int bend = n1 != n2;
        const float eta = (float)(n1 / n2);
        const int sphere = s->conic == 0.0;
        /* The transmittance table's row (transmit.h), where there is an
         * interface and a table. */
        const int lose = tab != NULL && bend && tab->inv_nmin2[i] != 0.0f;
        const float tk = tab != NULL ? tab->inv_nmin2[i] : 0.0f;
        const float n1s = (float)(n1 * n1);
        if (c == 0.0f && !bend) {
            /* A flat surface between equal media (the stop): only where
             * the ray crosses its plane matters. */
            for (int b = 0; b < lanes; b += 16) {
                for (int l = b; l < b + 16; l++) {
                    float t = (zi - o[2][l]) / d[2][l];
                    float px = o[0][l] + t * d[0][l],
                          py = o[1][l] + t * d[1][l];
                    int live = alive[l] & isfinite(t) &
                               !(px * px + py * py > lim2);
                    alive[l] = live;
                    o[0][l] = live ? px : o[0][l];
                    o[1][l] = live ? py : o[1][l];
                    o[2][l] = live ? zi : o[2][l];
                }
            }
            continue;
        }
        if (sphere)
            surface16(lanes, c, k1, lim2, zi, eta, bend, 1, o, d, alive, cosv);
        else
            surface16(lanes, c, k1, lim2, zi, eta, bend, 0, o, d, alive, cosv);
        /* The transmittance in a loop of its own: its table lookups
         * (gathers) inside the loop above kept GCC from vectorising it,
         * and the lens's rays took twice as long. */
        if (lose)
            ttab_apply(lanes, cosv, n1s, tk, tab->t[i], tab->dt[i], T);
    }
}
