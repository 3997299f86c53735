/*
 * spectral.c: spectral camera samples (spectral.h).
 *
 * Each output channel c estimates L_c = int w_c(l) L_c(l) dl, the
 * radiance weighted by the normalised linear-sRGB matching functions
 * (wavelength.h).  A camera sample (film point, lens point) traces:
 *
 * 1. The reference ray, at the reference wavelength (the d line, focus
 *    power c->w).  Its radiance L_r is a control variate:
 *
 *        L_c = L_r,c + int w_c(l) (L_c(l) - L_r,c) dl
 *
 *    since the weights integrate to 1; the integral left is 0 wherever
 *    every wavelength's ray brings back the reference's radiance, so a
 *    flat area gets no colour noise even where its rays spread, and only
 *    the colour fringes are sampled.
 *
 *    The control need not be the sample's own: F below is
 *    (1 / m) sum_k w(l_k) L(l_k) - L_r c(v) with c(v) = (1 / m) sum_k
 *    w(l_k) - 1, whose mean over v is 0, so any L_r that does not depend
 *    on the sample's dimension 4 v keeps F unbiased (the sampler
 *    scrambles each dimension with a seed of its own, so the film and
 *    lens dimensions of every sample of the pixel are independent of v),
 *    and any L_r is exact on a flat area.  The packet path therefore
 *    traces the reference rays of a call's first packet only, and lane i
 *    of each later packet takes lane i's: at 64 and 128 spp, 8 to 10%
 *    fewer rays for 2 to 3% more relMSE on accuracy-chroma
 *    (docs/spectral.md).
 *
 * 2. m wavelengths (camera.chromatic.wavelengths), one in each stratum
 *    of the sampling space: l_k from u_k = (v + k) / m, k = 0 .. m-1,
 *    where v is the sample's dimension 4, stratified together with its
 *    pixel and lens position (lr__pixel_sampler_dim4), and lr__wl_sample
 *    turns u into a wavelength with the density of wavelength.h.  Each
 *    stratum has probability 1 / m, so (stratified sampling, one sample a
 *    stratum)
 *
 *        F = L_r + (1 / m) sum_k w(l_k) (L(l_k) - L_r)
 *
 *    is unbiased.  v itself, not frac(m v), offsets the strata: the
 *    pixel's samples then spread over lens and offset jointly, as Sobol's
 *    dimensions 2 to 4 do, where frac(m v) keeps only the low digits of
 *    dimension 4 (those the net leaves least stratified).  This is the
 *    hero wavelength with evenly rotated companions of Wilkie, Nawaz,
 *    Droske, Weidlich & Hanika, "Hero Wavelength Spectral Sampling" (EGSR
 *    2014), in the sample space, with the hero drawn from the first
 *    stratum.
 *
 * The m + 1 rays of a sample share its film and lens point; in packets,
 * each of the m + 1 is a packet of sixteen samples.  Where the plan finds
 * the colours' foci closer than it can see (plan.c), the reference ray
 * alone is traced (sample.c's packet path), which is the same estimate
 * with every wavelength's ray equal to it.
 */
#include "render/spectral.h"
#include "sampling/wavelength.h"

#include <math.h>

void lr__shot_init(lr__shot *sh)
{
    lr__cam_wl_table(sh->cam, &sh->wl);
}

/* Stratum k of m for a sample whose dimension 4 is v: (v + k) / m. */
static double stratum(double v, int k, int m)
{
    return (v + k) / m;
}

static lr__v3 weighted_diff(const double w[3], lr__v3 L, lr__v3 Lr)
{
    return v3(w[0] * (L.x - Lr.x), w[1] * (L.y - Lr.y), w[2] * (L.z - Lr.z));
}

/* The most camera rays lr__spectral_samples makes before tracing any
 * (each sample's m + 1, m <= 64). */
#define RAYS_AHEAD 128

void lr__spectral_samples(const lr__shot *sh, const lr__pixel_sampler *ps,
                          int x, int y, int first, int last, lr__pixel *acc,
                          lr__sample_counts *cnt)
{
    /* Steps 1 and 2, each sample's reference ray first, then its m
     * wavelengths'. */
    const lr__cam *c = sh->cam;
    int m = c->chroma.wavelengths, per = m + 1;
    int batch = RAYS_AHEAD / per > 0 ? RAYS_AHEAD / per : 1;
    double fx[RAYS_AHEAD], fy[RAYS_AHEAD], u[RAYS_AHEAD][2], w[RAYS_AHEAD];
    double nm[RAYS_AHEAD], W[RAYS_AHEAD][3], wt[RAYS_AHEAD];
    lr__v3 org[RAYS_AHEAD], dir[RAYS_AHEAD];
    for (int s0 = first; s0 < last; s0 += batch) {
        int ns = last - s0 < batch ? last - s0 : batch, nr = ns * per;
        for (int j = 0; j < ns; j++) {
            uint32_t s = (uint32_t)(s0 + j);
            double v[4];
            lr__pixel_sampler_get(ps, s, v);
            double u4 = lr__pixel_sampler_dim4(ps, s);
            for (int k = 0; k < per; k++) {
                int r = j * per + k;
                fx[r] = x + v[0], fy[r] = y + v[1];
                u[r][0] = v[2], u[r][1] = v[3];
                w[r] = c->w, nm[r] = c->nm_ref;
                if (k > 0) {
                    float pw;
                    nm[r] = lr__wl_sample(&sh->wl, stratum(u4, k - 1, m), W[r],
                                          &pw);
                    w[r] = pw;
                }
            }
        }
        /* The camera's rays sixteen at a time (a real lens traces their
         * glass in vectors, lanes at different wavelengths together):
         * each the ray it is alone. */
        for (int r = 0; r < nr; r += 16)
            lr__cam_lens_rays(c, nr - r < 16 ? nr - r : 16, fx + r, fy + r,
                              (const double(*)[2])(u + r), w + r, nm + r,
                              org + r, dir + r, wt + r);
        for (int j = 0; j < ns; j++) {
            const lr__sample_id id = {sh->sampler, ps->pixel,
                                      (uint32_t)(s0 + j), sh->lt};
            const int r0 = j * per;
            cnt->camera_rays += (uint64_t)m + 1;
            lr__v3 Lr = lr__weighted_radiance(sh, org[r0], dir[r0], wt[r0], &id,
                                              cnt);
            lr__v3 sum = v3(0, 0, 0);
            for (int k = 0; k < m; k++) {
                int r = r0 + 1 + k;
                lr__v3 Li = lr__weighted_radiance(sh, org[r], dir[r], wt[r],
                                                  &id, cnt);
                sum = v3_add(sum, weighted_diff(W[r], Li, Lr));
            }
            lr__pixel_add(acc, v3_add(Lr, v3_scale(sum, 1.0 / m)));
        }
    }
}

void lr__spectral_packets(const lr__shot *sh, int x, int y, int first, int last,
                          lr__pixel *acc, lr__sample_counts *cnt)
{
    const lr__cam *c = sh->cam;
    struct RTCRayHit16 rh __attribute__((aligned(64)));
    float fx[16], fy[16], lu[16], lv[16], pw[16], lw[16];
    for (int i = 0; i < 16; i++) {
        fx[i] = fy[i] = lu[i] = lv[i] = 0.5f;
        pw[i] = (float)c->w;
    }
    lr__pixel_sampler ps;
    uint64_t pixel = (uint64_t)y * (uint64_t)sh->width + (uint64_t)x;
    lr__pixel_sampler_init(&ps, sh->sampler, pixel);
    int m = c->chroma.wavelengths;
    /* The first packet's reference radiance, the control of every packet
     * (see the top of the file); a first packet of fewer than 16 lanes is
     * the only one. */
    lr__v3 Lr[16];
    for (int s0 = first; s0 < last; s0 += 16) {
        int n = last - s0 < 16 ? last - s0 : 16;
        double u4[16];
        lr__packet_coords(&ps, x, y, (uint32_t)s0, n, fx, fy, lu, lv);
        for (int i = 0; i < n; i++)
            u4[i] = lr__pixel_sampler_dim4(&ps, (uint32_t)(s0 + i));
        const lr__sample_id id = {sh->sampler, pixel, (uint32_t)s0, sh->lt};
        lr__v3 sum[16], L[16];
        if (s0 == first) {
            c->model->rays16(c, 1, n, fx, fy, lu, lv, &rh, lw);
            sh->integrator->radiance16(sh->scene, sh->max_depth, &rh, n, &id,
                                       Lr, &cnt->rays);
            cnt->camera_rays += (uint64_t)n;
        }
        cnt->camera_rays += (uint64_t)n * (uint64_t)m;
        for (int i = 0; i < n; i++)
            sum[i] = v3(0, 0, 0);
        for (int k = 0; k < m; k++) {
            float uk[16], W[3][16];
            for (int i = 0; i < 16; i++)
                uk[i] = (float)stratum(i < n ? u4[i] : 0.0, k, m);
            lr__wl_sample16(&sh->wl, uk, W, pw);
            c->model->rays16_w(c, n, fx, fy, lu, lv, pw, &rh, lw);
            sh->integrator->radiance16(sh->scene, sh->max_depth, &rh, n, &id, L,
                                       &cnt->rays);
            for (int i = 0; i < n; i++) {
                double Wi[3] = {W[0][i], W[1][i], W[2][i]};
                sum[i] = v3_add(sum[i], weighted_diff(Wi, L[i], Lr[i]));
            }
        }
        for (int i = 0; i < n; i++)
            sum[i] = v3_add(Lr[i], v3_scale(sum[i], 1.0 / m));
        lr__pixel_add_n(acc, sum, n);
    }
}
