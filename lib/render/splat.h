/*
 * splat.h: spectral splatting, the way spectral renders through a thin
 * lens are traced (the estimator and why it is unbiased are at the top of
 * splat.c; the measurements in docs/spectral.md).  A colour's focus
 * change is a film shift, so each wavelength of a pixel's sample reuses
 * the d-line ray of the pixel it shifts to: one ray a pixel and sample,
 * none a wavelength.
 *
 * A render goes by units, taken in increasing order (render.c's counter),
 * each of which may wait for earlier ones: for each group of 16 samples,
 * phase A traces the group's rays of bands of 16 rows (aligned to the
 * frame) of the region widened by the margin (rays from outside the
 * region and the frame land inside it), then phase B sums the group's
 * samples of bands of the region's rows.  Every value is a pure function
 * of the pixel and the sample, added in sample order, so neither the
 * thread count nor the region changes a bit.
 */
#ifndef LR_SPLAT_H
#define LR_SPLAT_H

#include "render/sample.h"

typedef struct lr__splat lr__splat;

/* Whether spectral splatting renders with camera `c` (prepared for its
 * frame): spectral mode with the colours apart, a model with shift16
 * (camera.h), a focus power finite and monotonic over 380 to 780 nm, and
 * a film shift of at most LR__SPLAT_MAX_MARGIN pixels. */
int lr__splat_applies(const lr__cam *c);

/* The largest film shift (pixels) splatting takes on, and the most
 * memory the rays of a group of 16 samples of the frame and its margin
 * may take (192 bytes a pixel: 0.75 GB for 1080p with the largest
 * margin; a 4K frame does not fit); beyond either, spectral.c's packets
 * trace the render. */
#define LR__SPLAT_MAX_MARGIN 256
#define LR__SPLAT_MAX_BYTES (1024.0 * 1024.0 * 1024.0)

/* Prepares a splatting render of [x0, x1) x [y0, y1) of the frame into
 * `img` (its size) with `spp` samples a pixel, for up to `workers`
 * threads; `sh` (initialised) and `img` must outlive it.  LR_ERR_NOMEM on
 * failure. */
lr_status lr__splat_new(const lr__shot *sh, int spp, int x0, int y0, int x1,
                        int y1, int workers, lr_image *img, lr__splat **out,
                        lr_error *err);

/* The number of units of the render. */
int lr__splat_units(const lr__splat *sp);

/* Renders unit u (0 <= u < lr__splat_units) with worker `worker`'s
 * scratch (worker < the `workers` given to lr__splat_new), once the
 * earlier units it needs are done (it waits for them; every unit taken
 * must be finished).  Counts rays in *cnt and non-finite radiance in
 * *dropped.  Returns the region pixels it advanced (for progress: they
 * add up to the region's pixels over all units). */
uint64_t lr__splat_unit(lr__splat *sp, int u, int worker,
                        lr__sample_counts *cnt, uint64_t *dropped);

/* Writes the image's colours from the sums (after every unit). */
void lr__splat_resolve(const lr__splat *sp);

/* Frees sp; NULL is a no-op. */
void lr__splat_free(lr__splat *sp);

#endif
