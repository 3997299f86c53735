/*
 * sample.c: the samples of one pixel (sample.h).
 */
#include "render/sample.h"
#include "render/spectral.h"

#include <math.h>

uint64_t lr__colour_rays(const lr__cam *c)
{
    if (!c->chroma_active)
        return 1;
    /* Spectral: the wavelengths and the reference ray (spectral.c). */
    return c->chroma.mode == LR_CHROMATIC_RGB
               ? 3
               : (uint64_t)c->chroma.wavelengths + 1;
}

/* rgb samples first..last of a pixel: each sample's three channels
 * traced with its own focus through the same film point and lens point
 * (the paper).  The camera's rays for up to 16 samples are made at once,
 * channel by channel (a real lens traces their glass in vectors: the
 * same rays), then the radiance sample by sample, channel by channel. */
static void rgb_samples(const lr__shot *sh, const lr__pixel_sampler *ps,
                        uint64_t pixel, int x, int y, int first, int last,
                        lr__pixel *acc, lr__sample_counts *cnt)
{
    const lr__cam *c = sh->cam;
    for (int s0 = first; s0 < last; s0 += 16) {
        int n = last - s0 < 16 ? last - s0 : 16;
        double fx[16], fy[16], u[16][2], wt[3][16];
        lr__v3 org[3][16], dir[3][16];
        for (int i = 0; i < n; i++) {
            double v[4];
            lr__pixel_sampler_get(ps, (uint32_t)(s0 + i), v);
            fx[i] = x + v[0], fy[i] = y + v[1];
            u[i][0] = v[2], u[i][1] = v[3];
        }
        for (int ch = 0; ch < 3; ch++) {
            double w[16], nm[16];
            for (int i = 0; i < n; i++)
                w[i] = c->w_rgb[ch], nm[i] = c->lens.nm_rgb[ch];
            lr__cam_lens_rays(c, n, fx, fy, (const double(*)[2])u, w, nm,
                              org[ch], dir[ch], wt[ch]);
        }
        for (int i = 0; i < n; i++) {
            const lr__sample_id id = {sh->sampler, pixel, (uint32_t)(s0 + i),
                                      sh->lt};
            cnt->camera_rays += 3;
            double L[3];
            for (int ch = 0; ch < 3; ch++) {
                lr__v3 Li = lr__weighted_radiance(sh, org[ch][i], dir[ch][i],
                                                  wt[ch][i], &id, cnt);
                L[ch] = ch == 0 ? Li.x : ch == 1 ? Li.y : Li.z;
            }
            lr__pixel_add(acc, v3(L[0], L[1], L[2]));
        }
    }
}

/* Samples of pixels sixteen at a time: one packet of camera rays from
 * the camera model, radiance for all of it from the integrator.  Packets
 * never mix pixels: which rays share a packet then never depends on the
 * tile size or region, so neither can the result (Embree may break exact
 * ties between primitives differently for differently composed
 * packets).
 *
 * The rays of up to PACKETS_AHEAD packets, of one span or of several,
 * are made before any of them is traced.  A packet's sample values and
 * rays are a chain of long-latency steps (Owen scrambling's integer
 * multiplies, the aperture map's division, a square root and a division
 * per direction; through a real lens, two square roots and a division per
 * surface) with little work beside it; the packets' chains do not depend
 * on each other, so made one after another the processor overlaps them
 * (on the bench scene the rays cost a third less than made one packet at
 * a time; through the double Gauss a call of one packet took 0.39 us
 * more than its share of a call of four).  Each packet's values are the
 * ones it would have alone (camera.h's rays16_n, integrator.h's
 * radiance16_n), and each span's packets are added to its pixel in
 * order. */
#define PACKETS_AHEAD 4

static void packet_samples(const lr__shot *sh, int use_lens, int n_spans,
                           const lr__span *sp, lr__sample_counts *cnt)
{
    struct RTCRayHit16 rh[PACKETS_AHEAD] __attribute__((aligned(64)));
    float wt[PACKETS_AHEAD][16];
    float fx[PACKETS_AHEAD][16], fy[PACKETS_AHEAD][16];
    float lu[PACKETS_AHEAD][16], lv[PACKETS_AHEAD][16];
    lr__pixel_sampler ps;
    /* The next sample: s of span a (whose sampler ps is, once made). */
    int a = 0, s = n_spans > 0 ? sp[0].first : 0, made = -1;
    for (;;) {
        /* All the packets' sample values first, then all their rays:
         * each step's chains then overlap across the packets. */
        int n_packets = 0, ns[PACKETS_AHEAD], of[PACKETS_AHEAD],
            s0[PACKETS_AHEAD];
        uint64_t px[PACKETS_AHEAD];
        while (n_packets < PACKETS_AHEAD && a < n_spans) {
            const lr__span *q = &sp[a];
            if (s >= q->last) {
                if (++a < n_spans)
                    s = sp[a].first;
                continue;
            }
            uint64_t pixel = (uint64_t)q->y * (uint64_t)sh->width +
                             (uint64_t)q->x;
            if (made != a) {
                lr__pixel_sampler_init(&ps, sh->sampler, pixel);
                made = a;
            }
            int n = q->last - s < 16 ? q->last - s : 16;
            lr__packet_coords(&ps, q->x, q->y, (uint32_t)s, n, fx[n_packets],
                              fy[n_packets], lu[n_packets], lv[n_packets]);
            ns[n_packets] = n, of[n_packets] = a, s0[n_packets] = s;
            px[n_packets] = pixel;
            n_packets++;
            s += 16;
        }
        if (n_packets == 0)
            return;
        if (sh->cam->model->rays16_n != NULL)
            sh->cam->model->rays16_n(
                sh->cam, use_lens, n_packets, ns, (const float(*)[16])fx,
                (const float(*)[16])fy, (const float(*)[16])lu,
                (const float(*)[16])lv, rh, wt);
        else
            for (int p = 0; p < n_packets; p++)
                sh->cam->model->rays16(sh->cam, use_lens, ns[p], fx[p], fy[p],
                                       lu[p], lv[p], &rh[p], wt[p]);
        /* One ray for every colour where the camera has colours: each
         * channel's share of its weight (a real lens's glass). */
        float kc[PACKETS_AHEAD][3][16];
        int shares = sh->cam->chroma_active &&
                     sh->cam->model->colour_w16 != NULL;
        for (int p = 0; p < n_packets && shares; p++)
            sh->cam->model->colour_w16(sh->cam, ns[p], fx[p], fy[p], kc[p]);
        lr__sample_id id[PACKETS_AHEAD];
        for (int p = 0; p < n_packets; p++) {
            id[p] = (lr__sample_id){sh->sampler, px[p], (uint32_t)s0[p],
                                    sh->lt};
            cnt->camera_rays += (uint64_t)ns[p];
        }
        if (sh->integrator->radiance16_n != NULL) {
            /* Per channel, as the integrator's vector lanes keep it and
             * lr__pixel_add16 reads it: no sample is gathered into a
             * struct only to be taken apart again. */
            double L[PACKETS_AHEAD][3][16] __attribute__((aligned(64)));
            sh->integrator->radiance16_n(sh->scene, sh->max_depth, rh, ns,
                                         n_packets, id, L, &cnt->rays);
            for (int p = 0; p < n_packets; p++) {
                int n = ns[p];
                if (sh->cam->weighted)
                    for (int i = 0; i < n; i++) {
                        for (int c = 0; c < 3; c++)
                            L[p][c][i] = L[p][c][i] * (double)wt[p][i];
                        cnt->lens_blocked += wt[p][i] == 0.0f;
                    }
                for (int i = 0; i < n && shares; i++)
                    for (int c = 0; c < 3; c++)
                        L[p][c][i] = L[p][c][i] * (double)kc[p][c][i];
                lr__pixel_add16(sp[of[p]].acc, (const double(*)[16])L[p], n,
                                !sh->no_squares);
            }
            continue;
        }
        lr__v3 L[PACKETS_AHEAD][16];
        for (int p = 0; p < n_packets; p++)
            sh->integrator->radiance16(sh->scene, sh->max_depth, &rh[p], ns[p],
                                       &id[p], L[p], &cnt->rays);
        for (int p = 0; p < n_packets; p++) {
            int n = ns[p];
            if (sh->cam->weighted)
                for (int i = 0; i < n; i++) {
                    L[p][i] = v3_scale(L[p][i], wt[p][i]);
                    cnt->lens_blocked += wt[p][i] == 0.0f;
                }
            for (int i = 0; i < n && shares; i++)
                L[p][i] = v3(L[p][i].x * kc[p][0][i], L[p][i].y * kc[p][1][i],
                             L[p][i].z * kc[p][2][i]);
            lr__pixel_add_n(sp[of[p]].acc, L[p], n);
        }
    }
}

void lr__sample_pixel(const lr__shot *sh, const lr__block_plan *bp, int x,
                      int y, int first, int last, lr__pixel *acc,
                      lr__sample_counts *cnt)
{
    if (bp->path == LR__PATH_PACKET) {
        const lr__span one = {x, y, first, last, acc};
        packet_samples(sh, bp->lens, 1, &one, cnt);
        return;
    }
    if (sh->cam->chroma.mode == LR_CHROMATIC_SPECTRAL &&
        sh->cam->model->rays16_w != NULL) {
        lr__spectral_packets(sh, x, y, first, last, acc, cnt);
        return;
    }
    uint64_t pixel = (uint64_t)y * (uint64_t)sh->width + (uint64_t)x;
    lr__pixel_sampler ps;
    lr__pixel_sampler_init(&ps, sh->sampler, pixel);
    if (sh->cam->chroma.mode == LR_CHROMATIC_RGB) {
        rgb_samples(sh, &ps, pixel, x, y, first, last, acc, cnt);
        return;
    }
    lr__spectral_samples(sh, &ps, x, y, first, last, acc, cnt);
}

void lr__sample_pixels(const lr__shot *sh, const lr__plan *plan, int n,
                       const lr__span *sp, lr__sample_counts *cnt)
{
    for (int a = 0; a < n;) {
        const lr__block_plan *bp = lr__plan_at(plan, sp[a].x, sp[a].y);
        if (bp->path != LR__PATH_PACKET) {
            lr__sample_pixel(sh, bp, sp[a].x, sp[a].y, sp[a].first, sp[a].last,
                             sp[a].acc, cnt);
            a++;
            continue;
        }
        int b = a + 1;
        while (b < n) {
            const lr__block_plan *q = lr__plan_at(plan, sp[b].x, sp[b].y);
            if (q->path != LR__PATH_PACKET || q->lens != bp->lens)
                break;
            b++;
        }
        packet_samples(sh, bp->lens, b - a, sp + a, cnt);
        a = b;
    }
}

float lr__sample_depth(const lr__shot *sh, int x, int y, lr__sample_counts *cnt)
{
    lr__v3 org, dir;
    lr__hit h;
    lr__cam_ray(sh->cam, x + 0.5, y + 0.5, &org, &dir);
    cnt->rays++;
    float z = LR_DEPTH_NONE;
    if (lr__trace(sh->scene, org, dir, INFINITY, &h)) {
        /* From the camera's position along the view axis (the second
         * term is exactly 0 unless a real lens's chief ray starts at
         * its front element). */
        double d = h.t * v3_dot(dir, sh->cam->forward) +
                   v3_dot(v3_sub(org, sh->cam->origin), sh->cam->forward);
        if (d < LR_DEPTH_NONE)
            z = (float)d;
    }
    return z;
}
