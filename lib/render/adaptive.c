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
#include "render/adaptive.h"
#include "render/pilots.h"
#include "render/plan.h"

#include <math.h>

#define PACKET_PILOT 16

/* The threshold when none is given: 3 / spp.  Cycles likewise derives
 * its noise threshold from the sample count when it is left at 0
 * (Blender 2.83 onwards: "automatic setting based on number of AA
 * samples"); the form here is ours.  A threshold falling as 1 / spp
 * tightens faster than the N^-1/2 at which a pixel's standard error
 * falls, so a pixel stops early only where its error is already below
 * what the full budget buys, and the bar keeps moving with the budget.
 * The factor 3 comes from measurement (make accuracy, docs/accuracy.md,
 * and tests/test_plan.c's blurred foreground): with 1 / spp hardly
 * anything stopped early on the defocused scene; with 10 / spp the
 * error at 16 to 64 spp was up to 9x the full simulation's.  No floor:
 * a larger spp always asks for less error. */
#define AUTO_THRESHOLD 3.0

double lr__adaptive_threshold(const lr_render_settings *set)
{
    if (set->adaptive_threshold > 0.0)
        return set->adaptive_threshold;
    double t = AUTO_THRESHOLD / (double)set->spp;
    return t < 1.0 ? t : 1.0;
}

/* The minimum when none is given: the power of two at or above
 * sqrt(spp), at least a packet of 16.  It grows with spp so that thin
 * features the pilot missed are found (the widest sliver n Sobol samples
 * can miss is 1/n of the pixel: lr__edge_samples_needed), while a flat
 * pixel's sqrt(spp) samples are a vanishing share of the budget; a
 * power of two keeps Sobol's prefix a (0, k, 2)-net.  At least 16
 * because the first packet costs the same whatever its lanes (the speed
 * issue measured 0.48 us per pixel's first packet), so a smaller pilot
 * saves little and judges the spread worse.  (Cycles too picks its
 * minimum automatically when it is 0.) */
int lr__adaptive_min(const lr_render_settings *set)
{
    if (set->adaptive_min_spp > 0)
        return set->adaptive_min_spp;
    int m = PACKET_PILOT;
    while ((double)m * m < (double)set->spp)
        m *= 2;
    return m;
}

int lr__adaptive_pilot(const lr_render_settings *set, int lens)
{
    int lo = lr__adaptive_min(set), spp = set->spp;
    if (!set->adaptive || lo >= spp)
        return spp;
    if (lens && lo < PACKET_PILOT)
        lo = PACKET_PILOT;
    return lo < spp ? lo : spp;
}

/* The squared scale an error is measured against, per channel: relMSE's
 * r^2 + 0.01 (Rousselle, Knaus and Zwicker 2011, the measure of
 * docs/accuracy.md), so that near-black pixels do not ask for endless
 * samples to pin down nothing. */
static double scale2(double mean)
{
    return mean * mean + 0.01;
}

/* A need in samples as a count in [lo, hi] (lo where it is 0 or NaN). */
static int need_in(double need, int lo, int hi)
{
    if (!(need > 0.0))
        return lo;
    if (!(need < (double)hi))
        return hi;
    int k = (int)ceil(need);
    return k < lo ? lo : k;
}

int lr__pixel_samples_needed(const lr__pixel *p, double threshold, int lo,
                             int hi)
{
    /* One sample says nothing about the spread: judge again after two. */
    if (p->n < 2)
        return 2 < hi ? 2 : hi;
    double n = (double)p->n, need = 0.0;
    /* Per channel, the standard error sqrt(var / N) relative to the
     * scale must reach the threshold: N = var / (threshold^2 scale^2).
     * Colour noise (a spectral render's) can leave luminance steady, so
     * every channel is judged, not their luminance. */
    for (int c = 0; c < 3; c++) {
        double mean = p->sum[c] / n;
        double var = (p->sum2[c] / n - mean * mean) * n / (n - 1.0);
        double k = var / (threshold * threshold * scale2(mean));
        if (k > need)
            need = k;
    }
    return need_in(need, lo, hi);
}

/* Rare light.  A pilot that saw nothing of a light tells nothing of a
 * light that only a small part of the pixel's domain (lens, pixel area,
 * lobe) reaches: a sphere light far out of focus is seen through about
 * 0.1% of the lens in each pixel of its disc, so most pixels' pilots
 * miss it, judge themselves converged at black, and the disc keeps a
 * fraction of its light (issue 27 measured 40% to 62%).  What the samples
 * do bound is how likely an unseen event is: after n samples without it,
 * an event of probability p went unseen with probability (1 - p)^n <=
 * e^-pn, under 5% once p >= 3 / n: the "rule of three" (Hanley & Lippman-
 * Hand 1983, JAMA 249:1743).  Such an event carries at most `unseen` (the
 * plan's bound on the radiance the pixel's rays can reach) where the
 * pixel's mean m is, so it moves the mean by at most 3 (unseen - m) / n.
 * Requiring that within the threshold, relative to the scale the noise
 * is judged against, gives n >= 3 (unseen - m) / (threshold sqrt(m^2 +
 * 0.01)) per channel.  With the automatic threshold 3 / spp this is spp
 * wherever a light much brighter than the pixel may be rare: such pixels
 * take the full simulation, as they must until the light side carries
 * these lights (issue 27); pixels whose rays cannot reach an emitter, and
 * every pixel of a scene without one, are judged as before. */
int lr__rare_samples_needed(const lr__pixel *p, double unseen, double threshold,
                            int lo, int hi)
{
    if (!(unseen > 0.0))
        return 0;
    double n = p->n > 0 ? (double)p->n : 1.0, need = 0.0;
    for (int c = 0; c < 3; c++) {
        double mean = p->sum[c] / n;
        double k = 3.0 * (unseen - mean) / (threshold * sqrt(scale2(mean)));
        if (k > need)
            need = k;
    }
    return need_in(need, lo, hi);
}

/* fmax as glibc has it (the non-NaN one), inline: a call per channel
 * and neighbour was a measurable share of the rule's cost. */
static inline double max_number(double a, double b)
{
    if (isnan(a))
        return b;
    if (isnan(b))
        return a;
    return a > b ? a : b;
}

void lr__pilot_view_make(const lr__pixel *p, lr__pilot_view *v)
{
    for (int i = 0; i < 3; i++) {
        /* No samples: a NaN mean makes every contrast with it NaN, which
         * lr__pilot_contrast ignores, so it is 0. */
        double m = p->n ? p->sum[i] / (double)p->n : NAN;
        v->mean[i] = m;
        v->root[i] = sqrt(scale2(m));
    }
}

/* The relative contrast of two pilots: per channel |ma - mb| over the
 * square root of the larger scale, the largest of the three.  sqrt is
 * correctly rounded, so monotonic: the root of the larger scale is the
 * larger root, taken from the views without a square root per pair. */
static inline double contrast(const lr__pilot_view *a, const lr__pilot_view *b)
{
    double c = 0.0;
    for (int i = 0; i < 3; i++) {
        double d = fabs(a->mean[i] - b->mean[i]) /
                   max_number(a->root[i], b->root[i]);
        if (d > c)
            c = d;
    }
    return c;
}

double lr__pilot_contrast(const lr__pilot_view *a, const lr__pilot_view *b)
{
    return contrast(a, b);
}

/* Can contrast(a, b) exceed `bound`?  0 only when it cannot: in some
 * channel |ma - mb| > bound x root, a product instead of a division.
 * NaN differences (ignored by contrast) say no too. */
static inline int may_exceed(const lr__pilot_view *a, const lr__pilot_view *b,
                             double bound)
{
    for (int i = 0; i < 3; i++)
        if (fabs(a->mean[i] - b->mean[i]) >
            bound * max_number(a->root[i], b->root[i]))
            return 1;
    return 0;
}

/* A sliver of the pixel that all n samples missed, next to a neighbour
 * of relative contrast c, errs by its width times c.  The first n = 2^k
 * Sobol points fall one in each of n strips 1/n wide along either axis
 * (a (0, k, 2)-net: Niederreiter 1992, Theorem 4.10, and Owen's
 * scrambling keeps it), so the sliver is at most 1/n wide and the error
 * at most c / n: n = c / threshold samples bound it by the threshold.
 * (For the shuffled strata of grid and jittered prefixes the bound holds
 * on average, not for every pixel.) */
int lr__edge_samples_needed(double contrast, double threshold, int have, int hi)
{
    double need = contrast / threshold;
    if (!(need > (double)have))
        return 0;
    return need < (double)hi ? (int)ceil(need) : hi;
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

/* Resets *a; in a dark block (plan.h), to the one sample of 0 that every
 * camera sample there would be, traced or not, and returns 1. */
static int dark_pixel(const lr__plan *plan, int x, int y, lr__pixel *a)
{
    lr__pixel_reset(a);
    if (!lr__plan_at(plan, x, y)->dark)
        return 0;
    a->n = 1;
    return 1;
}

/* Spans gathered for the caller's sample_n (adaptive.h): a pixel of 16
 * samples is one packet, and the packets of several pixels in one call
 * overlap each other's long chains.  slot[k] >= 0: a pilot to give
 * (pilots.h) once it is traced. */
#define BATCH 16
int lr__adaptive_batch = BATCH;
typedef struct batch {
    const lr__block_io *io;
    lr__pilots *share;
    int n;
    lr__span s[BATCH];
    int slot[BATCH];
} batch;

static void batch_flush(batch *b)
{
    const lr__block_io *io = b->io;
    if (b->n == 0)
        return;
    if (io->sample_n != NULL)
        io->sample_n(io->ctx, b->n, b->s);
    else
        for (int k = 0; k < b->n; k++)
            io->sample(io->ctx, b->s[k].x, b->s[k].y, b->s[k].first,
                       b->s[k].last, b->s[k].acc);
    for (int k = 0; k < b->n; k++)
        if (b->slot[k] >= 0)
            lr__pilots_give(b->share, b->slot[k], b->s[k].acc);
    b->n = 0;
}

static void batch_add(batch *b, int x, int y, int first, int last,
                      lr__pixel *acc, int slot)
{
    b->s[b->n] = (lr__span){x, y, first, last, acc};
    b->slot[b->n++] = slot;
    if (b->n >= BATCH || b->n >= lr__adaptive_batch)
        batch_flush(b);
}

/* Every pixel of the block with all spp samples (sampling not adaptive),
 * in batches, then stored in row order. */
static void block_whole(const lr__plan *plan, int spp, int x0, int y0, int x1,
                        int y1, lr__pixel *acc, const lr__block_io *io)
{
    batch b = {.io = io, .share = NULL, .n = 0};
    int w = x1 - x0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            lr__pixel *a = &acc[(y - y0) * w + (x - x0)];
            if (!dark_pixel(plan, x, y, a))
                batch_add(&b, x, y, 0, spp, a, -1);
        }
    batch_flush(&b);
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            io->store(io->ctx, x, y, &acc[(y - y0) * w + (x - x0)]);
}

/* A pixel's want after its pilot: the largest need in its neighbourhood,
 * and enough samples to bound an edge that its pilot and a neighbour's
 * disagree on.  i: its index in the apron's arrays; (ax0, ay0, ax1,
 * ay1): the apron. */
static int pilot_want(const int *need, const lr__pilot_view *view, int i, int x,
                      int y, int ax0, int ay0, int ax1, int ay1, double thr,
                      int have, int spp)
{
    int aw = ax1 - ax0;
    /* need[i] is the pixel's own need, judged from its pilot;
     * neighbours of unconverged pixels keep going. */
    int want = need[i];
    int nx0 = x > ax0 ? x - 1 : x, nx1 = x + 1 < ax1 ? x + 1 : x;
    int ny0 = y > ay0 ? y - 1 : y, ny1 = y + 1 < ay1 ? y + 1 : y;
    for (int ny = ny0; ny <= ny1; ny++)
        for (int nx = nx0; nx <= nx1; nx++) {
            int k = (ny - ay0) * aw + (nx - ax0);
            if (need[k] > want)
                want = need[k];
        }
    /* An edge along the pixel grid can slip between a few samples: a
     * pixel whose pilot differs from a neighbour's takes the samples
     * that bound the error of a sliver it missed
     * (lr__edge_samples_needed, which grows with the contrast, so the
     * largest decides).  That adds samples only where contrast / thr >
     * want, so a pair whose contrast is surely below want x thr (with a
     * margin of 1e-9 that covers the few roundings on either side) needs
     * no division.  A bound so small that the product could underflow
     * checks nothing. */
    double bound = (double)want * thr * (1.0 - 1e-9);
    if (!(bound > 1e-200))
        bound = 0.0;
    double cmax = 0.0;
    for (int ny = ny0; ny <= ny1; ny++)
        for (int nx = nx0; nx <= nx1; nx++) {
            int k = (ny - ay0) * aw + (nx - ax0);
            if (need[k] > 0 && k != i &&
                may_exceed(&view[i], &view[k], bound)) {
                double c = contrast(&view[i], &view[k]);
                if (c > cmax)
                    cmax = c;
            }
        }
    int e = lr__edge_samples_needed(cmax, thr, have, spp);
    return e > want ? e : want;
}

void lr__adaptive_block(const lr_render_settings *set, const lr__plan *plan,
                        int x0, int y0, int x1, int y1,
                        lr__block_scratch *scratch, lr__pilots *share,
                        const lr__block_io *io)
{
    int spp = set->spp;
    double thr = lr__adaptive_threshold(set);
    lr__pixel *acc = scratch->acc;
    int *need = scratch->need;
    lr__pilot_view *view = scratch->view;
    if (!set->adaptive || lr__adaptive_min(set) >= spp) {
        block_whole(plan, spp, x0, y0, x1, y1, acc, io);
        return;
    }
    int ax0 = x0 > 0 ? x0 - 1 : 0, ay0 = y0 > 0 ? y0 - 1 : 0;
    int ax1 = x1 < set->width ? x1 + 1 : x1;
    int ay1 = y1 < set->height ? y1 + 1 : y1;
    int aw = ax1 - ax0;
    /* The pilots this block traces, in batches, each given to the
     * blocks that share it once its batch is done; then the ones it
     * takes from others (a block waits only for blocks handed out before
     * it, which trace theirs first in the same way: pilots.h).  need[i]
     * is -1 for a pixel whose pilot matters here, until it is judged. */
    batch b = {.io = io, .share = share, .n = 0};
    for (int y = ay0; y < ay1; y++)
        for (int x = ax0; x < ax1; x++) {
            int i = (y - ay0) * aw + (x - ax0);
            int inside = x >= x0 && x < x1 && y >= y0 && y < y1;
            need[i] = 0;
            if (!inside && !apron_needed(plan, spp, x, y, x0, y0, x1, y1))
                continue;
            need[i] = -1;
            if (dark_pixel(plan, x, y, &acc[i]))
                continue;
            int slot, role = share != NULL
                                 ? lr__pilots_role(share, x, y, x0, y0, &slot)
                                 : LR__PILOT_TRACE;
            if (role != LR__PILOT_TAKE)
                batch_add(&b, x, y, 0, lr__plan_at(plan, x, y)->pilot, &acc[i],
                          role == LR__PILOT_GIVE ? slot : -1);
        }
    batch_flush(&b);
    for (int y = ay0; y < ay1; y++)
        for (int x = ax0; x < ax1; x++) {
            int i = (y - ay0) * aw + (x - ax0);
            if (need[i] == 0)
                continue;
            const lr__block_plan *bp = lr__plan_at(plan, x, y);
            int slot;
            if (!bp->dark && share != NULL &&
                lr__pilots_role(share, x, y, x0, y0, &slot) == LR__PILOT_TAKE)
                lr__pilots_take(share, slot, &acc[i]);
            int p = bp->pilot;
            need[i] = lr__pixel_samples_needed(&acc[i], thr, p, spp);
            int r = lr__rare_samples_needed(
                &acc[i], lr__plan_unseen(plan, x, y), thr, p, spp);
            if (r > need[i])
                need[i] = r;
            lr__pilot_view_make(&acc[i], &view[i]);
        }
    /* Each pixel's rounds go into a copy, round[j]: acc keeps every
     * pixel's pilot, so that the contrast test above compares pilots
     * with pilots, as in a tile or a crop where the neighbour is an apron
     * pixel that never goes on.  (Comparing with a neighbour's later
     * rounds made a crop's edge differ from the full render.)  The rounds
     * go in waves: every pixel that wants more takes its next round, in
     * batches, and then judges its need again from all its samples; a
     * pixel's rounds, and so its samples, are the ones it would take
     * alone. */
    int w = x1 - x0;
    lr__pixel *round = scratch->round;
    int *have = scratch->have, *want = scratch->want, *next = scratch->next;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            int i = (y - ay0) * aw + (x - ax0), j = (y - y0) * w + (x - x0);
            const lr__block_plan *bp = lr__plan_at(plan, x, y);
            round[j] = acc[i];
            have[j] = bp->pilot;
            want[j] = have[j] >= spp || bp->dark
                          ? 0 /* the pilot was all of it */
                          : pilot_want(need, view, i, x, y, ax0, ay0, ax1, ay1,
                                       thr, have[j], spp);
        }
    for (int more = 1; more;) {
        more = 0;
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                int j = (y - y0) * w + (x - x0);
                if (want[j] <= have[j])
                    continue;
                next[j] = lr__adaptive_next(have[j], want[j], spp);
                batch_add(&b, x, y, have[j], next[j], &round[j], -1);
                more = 1;
            }
        batch_flush(&b);
        for (int y = y0; y < y1 && more; y++)
            for (int x = x0; x < x1; x++) {
                int j = (y - y0) * w + (x - x0);
                if (want[j] <= have[j])
                    continue;
                have[j] = next[j];
                /* With all spp there is nothing left to judge. */
                if (have[j] >= spp)
                    continue;
                want[j] = lr__pixel_samples_needed(&round[j], thr, have[j],
                                                   spp);
                int r = lr__rare_samples_needed(
                    &round[j], lr__plan_unseen(plan, x, y), thr, have[j], spp);
                if (r > want[j])
                    want[j] = r;
            }
    }
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            io->store(io->ctx, x, y, &round[(y - y0) * w + (x - x0)]);
}
