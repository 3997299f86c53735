/*
 * adaptive.h: adaptive sampling's policy: how many samples a pixel takes
 * first (its pilot), when it has enough, and in what rounds it goes on;
 * and the loop that applies it to a block of pixels.  What a sample is
 * (the camera, the integrator) is the caller's: this file sees only the
 * film's running sums.
 */
#ifndef LR_ADAPTIVE_H
#define LR_ADAPTIVE_H

#include "render/film.h"
#include "util/internal.h"

struct lr__plan;
struct lr__pilots;

/* The threshold and the minimum that a render uses: the settings' own
 * when given (> 0), otherwise derived from spp so that a larger budget
 * always buys less error (adaptive.c says how). */
double lr__adaptive_threshold(const lr_render_settings *set);
int lr__adaptive_min(const lr_render_settings *set);

/* The pilot: samples every pixel takes before it is judged: the minimum
 * (lr__adaptive_min), or, where the lens is sampled, at least a packet's
 * worth (16, the width of the packet path).  Where the lens blurs, almost
 * every pixel goes on (lens noise is everywhere), and a pixel that goes
 * on after its pilot traces another, partly filled packet, which costs
 * about as much as three or four samples more; a few samples of a
 * blurred (or, with chromatic aberration, spectral) integrand also judge
 * its spread poorly.  Where nothing is blurred only edges go on.  At
 * most spp; spp itself when sampling is not adaptive. */
int lr__adaptive_pilot(const lr_render_settings *set, int lens);

/* How many samples in all the pixel needs for a relative standard error
 * of `threshold` in its luminance, judged from the samples it has, at
 * least `lo` and at most `hi` (2 when it has fewer than two). */
int lr__pixel_samples_needed(const lr__pixel *p, double threshold, int lo,
                             int hi);

/* How many samples in all the pixel needs, at least `lo` and at most
 * `hi`, so that light of radiance up to `unseen` (lr__plan_unseen) that
 * its samples may have missed errs by at most `threshold`, relative to
 * its scale: 0 when unseen is 0 (adaptive.c gives the rule of three this
 * rests on). */
int lr__rare_samples_needed(const lr__pixel *p, double unseen, double threshold,
                            int lo, int hi);

/* How many samples in all a pixel needs, at most `hi`, so that a sliver
 * of its area that all its samples missed, next to an edge of relative
 * contrast `contrast`, errs by at most `threshold`: contrast / threshold
 * (0 when that is no more than `have`). */
int lr__edge_samples_needed(double contrast, double threshold, int have,
                            int hi);

/* Adaptive sampling's schedule: a pixel that has `have` samples (>= 1)
 * and wants `want` > have goes on to have * 2^k, the first such count
 * that reaches `want`, at most `hi`.  From a pilot of min_spp samples
 * the counts are min_spp * 2^k (powers of two, the prefixes that Sobol
 * stratifies best, when min_spp is one) and spp. */
int lr__adaptive_next(int have, int want, int hi);

/* How the block loop reaches the caller: `sample` adds samples first ..
 * last-1 of pixel (x, y) to *acc in order; `sample_n` (NULL: `sample`
 * span by span) does that for n spans at once, each as `sample` would
 * alone; `store` takes a finished pixel. */
typedef struct lr__block_io {
    void (*sample)(void *ctx, int x, int y, int first, int last,
                   lr__pixel *acc);
    void (*sample_n)(void *ctx, int n, const lr__span *spans);
    void (*store)(void *ctx, int x, int y, const lr__pixel *acc);
    void *ctx;
} lr__block_io;

/* What the neighbours' contrast test reads of a pixel's pilot, made once
 * per pixel rather than once per neighbour that reads it: per channel
 * the mean and the square root of its error scale (adaptive.c). */
typedef struct lr__pilot_view {
    double mean[3];
    double root[3];
} lr__pilot_view;

/* How many spans lr__adaptive_block hands to sample_n at most (1 to 16,
 * the default): for tests, which check that a batch changes no bit. */
extern int lr__adaptive_batch;

/* The largest block lr__adaptive_block takes, and the scratch it needs:
 * (LR__BLOCK_MAX + 2)^2 pixels (a one-pixel apron). */
#define LR__BLOCK_MAX 64
#define LR__BLOCK_APRON ((LR__BLOCK_MAX + 2) * (LR__BLOCK_MAX + 2))

typedef struct lr__block_scratch {
    lr__pixel acc[LR__BLOCK_APRON]; /* every pixel's pilot */
    int need[LR__BLOCK_APRON];      /* its need; 0: not sampled */
    lr__pilot_view view[LR__BLOCK_APRON];
    /* Per pixel of the block: its samples after the pilot's rounds, how
     * many it has, wants, and will have after the round under way. */
    lr__pixel round[LR__BLOCK_MAX * LR__BLOCK_MAX];
    int have[LR__BLOCK_MAX * LR__BLOCK_MAX];
    int want[LR__BLOCK_MAX * LR__BLOCK_MAX];
    int next[LR__BLOCK_MAX * LR__BLOCK_MAX];
} lr__block_scratch;

/* Renders pixels [x0, x1) x [y0, y1) (at most LR__BLOCK_MAX a side) of a
 * frame planned by `plan`, every pixel stored once, in row order, after
 * all of the block's samples.  The pilots on the block's borders and in
 * its apron are shared with the neighbouring blocks through `share`
 * (pilots.h; NULL: each block traces its own), which must then have been
 * set up with the block grid this block belongs to. */
void lr__adaptive_block(const lr_render_settings *set,
                        const struct lr__plan *plan, int x0, int y0, int x1,
                        int y1, lr__block_scratch *scratch,
                        struct lr__pilots *share, const lr__block_io *io);

/* A pixel's view (a mean of NaN per channel when it has no samples). */
void lr__pilot_view_make(const lr__pixel *p, lr__pilot_view *v);

/* How much two pixels' means differ, relative to the larger: per channel
 * |ma - mb| / sqrt(max(ma^2, mb^2) + 0.01), the largest of the three
 * (0 when either has no samples). */
double lr__pilot_contrast(const lr__pilot_view *a, const lr__pilot_view *b);

#endif
