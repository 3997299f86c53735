/*
 * adaptive.c: adaptive sampling (adaptive.h).  A pilot in the block and a
 * one-pixel apron around it (inside the frame, whatever the region) gives
 * each pixel a need; a pixel goes on to at least the largest need in its
 * 3 x 3 neighbourhood (neighbours of unconverged pixels keep going), then
 * in rounds that at least double its count, judging its own need again
 * from all its samples after each, until that need is met or it has spp.
 * A count depends only on the neighbourhood's pilots and the pixel's own
 * samples, all computed here, so tiles and regions agree; and a pixel's
 * first n samples are the full render's first n, so it is the full render
 * stopped at n.
 */
#include "adaptive.h"
#include "plan.h"

#include <math.h>

#define PACKET_PILOT 16

int lr__adaptive_pilot(const lr_render_settings *set, int lens)
{
    int lo = set->adaptive_min_spp, spp = set->spp;
    if (!set->adaptive || lo >= spp)
        return spp;
    if (lens && lo < PACKET_PILOT)
        lo = PACKET_PILOT;
    return lo < spp ? lo : spp;
}

int lr__pixel_samples_needed(const lr__pixel *p, double threshold, int lo,
                             int hi)
{
    /* One sample says nothing about the spread: judge again after two. */
    if (p->n < 2)
        return 2 < hi ? 2 : hi;
    double n = (double)p->n;
    double mean = lr__luminance(p->sum[0], p->sum[1], p->sum[2]) / n;
    double var = (p->sum_y2 / n - mean * mean) * n / (n - 1.0);
    if (!(var > 0.0))
        return lo;
    /* Standard error sqrt(var / N) relative to the mean, with a floor of
     * 0.02 on the mean so that near-black pixels do not ask for endless
     * samples to pin down nothing. */
    double ref = fabs(mean) + 0.02;
    double need = var / (threshold * threshold * ref * ref);
    if (!(need < (double)hi))
        return hi;
    int k = (int)ceil(need);
    return k < lo ? lo : k;
}

double lr__pixel_contrast(const lr__pixel *a, const lr__pixel *b)
{
    if (a->n == 0 || b->n == 0)
        return 0.0;
    double ma = lr__luminance(a->sum[0], a->sum[1], a->sum[2]) / (double)a->n;
    double mb = lr__luminance(b->sum[0], b->sum[1], b->sum[2]) / (double)b->n;
    return fabs(ma - mb) / (fmax(fabs(ma), fabs(mb)) + 0.02);
}

int lr__adaptive_next(int have, int want, int hi)
{
    long long next = 2LL * have;
    while (next < want)
        next *= 2;
    return next < hi ? (int)next : hi;
}

/* Does apron pixel (x, y) matter to the block [x0, x1) x [y0, y1): has it
 * a neighbour in the block whose pilot leaves it samples to decide on? */
static int apron_needed(const lr__plan *plan, int spp, int x, int y, int x0,
                        int y0, int x1, int y1)
{
    for (int ny = y - 1; ny <= y + 1; ny++)
        for (int nx = x - 1; nx <= x + 1; nx++)
            if (nx >= x0 && nx < x1 && ny >= y0 && ny < y1 &&
                lr__plan_at(plan, nx, ny)->pilot < spp)
                return 1;
    return 0;
}

void lr__adaptive_block(const lr_render_settings *set, const lr__plan *plan,
                        int x0, int y0, int x1, int y1, lr__pixel *acc,
                        int *need, const lr__block_io *io)
{
    int spp = set->spp;
    double thr = set->adaptive_threshold;
    if (!set->adaptive || set->adaptive_min_spp >= spp) {
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                lr__pixel *a = &acc[0];
                lr__pixel_reset(a);
                io->sample(io->ctx, x, y, 0, spp, a);
                io->store(io->ctx, x, y, a);
            }
        return;
    }
    int ax0 = x0 > 0 ? x0 - 1 : 0, ay0 = y0 > 0 ? y0 - 1 : 0;
    int ax1 = x1 < set->width ? x1 + 1 : x1;
    int ay1 = y1 < set->height ? y1 + 1 : y1;
    int aw = ax1 - ax0;
    for (int y = ay0; y < ay1; y++)
        for (int x = ax0; x < ax1; x++) {
            int i = (y - ay0) * aw + (x - ax0);
            int p = lr__plan_at(plan, x, y)->pilot;
            int inside = x >= x0 && x < x1 && y >= y0 && y < y1;
            need[i] = 0;
            if (!inside && !apron_needed(plan, spp, x, y, x0, y0, x1, y1))
                continue;
            lr__pixel_reset(&acc[i]);
            io->sample(io->ctx, x, y, 0, p, &acc[i]);
            need[i] = lr__pixel_samples_needed(&acc[i], thr, p, spp);
        }
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            lr__pixel *a = &acc[(y - ay0) * aw + (x - ax0)];
            int have = lr__plan_at(plan, x, y)->pilot;
            if (have >= spp) {
                /* The pilot was all of it (a blurred pixel at low spp). */
                io->store(io->ctx, x, y, a);
                continue;
            }
            int want = lr__pixel_samples_needed(a, thr, have, spp);
            for (int ny = y - 1; ny <= y + 1; ny++)
                for (int nx = x - 1; nx <= x + 1; nx++) {
                    if (nx < ax0 || nx >= ax1 || ny < ay0 || ny >= ay1)
                        continue;
                    int k = (ny - ay0) * aw + (nx - ax0);
                    if (need[k] > want)
                        want = need[k];
                    /* An edge along the pixel grid can slip between a
                     * few samples: a pixel whose pilot differs from a
                     * neighbour's by more than 10 x the threshold takes
                     * another round and judges again. */
                    if (need[k] > 0 && want <= have &&
                        lr__pixel_contrast(a, &acc[k]) > 10.0 * thr)
                        want = have + 1;
                }
            /* The rounds go into a copy: acc keeps every pixel's pilot,
             * so that the contrast test above compares pilots with
             * pilots, as in a tile or a crop where the neighbour is an
             * apron pixel that never goes on.  (Comparing with a
             * neighbour's later rounds made a crop's edge differ from
             * the full render.) */
            lr__pixel px = *a;
            while (want > have) {
                int next = lr__adaptive_next(have, want, spp);
                io->sample(io->ctx, x, y, have, next, &px);
                have = next;
                want = lr__pixel_samples_needed(&px, thr, have, spp);
            }
            io->store(io->ctx, x, y, &px);
        }
}
