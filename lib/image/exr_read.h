/*
 * exr_read.h: the one OpenEXR reader (OpenEXRCore): the R, G, B, A and Y
 * channels of a single-part scanline image, as float planes, from bytes
 * in memory.  The environment map (envmap.c) and textures (texture.c)
 * both read through it.
 */
#ifndef LR_EXR_READ_H
#define LR_EXR_READ_H

#include "util/internal.h"

enum { LR__EXR_R, LR__EXR_G, LR__EXR_B, LR__EXR_A, LR__EXR_Y, LR__EXR_NCH };

typedef struct lr__exr_planes {
    int w, h;
    /* The data window's first pixel, in the file's own coordinates (for
     * messages that name a pixel). */
    int x0, y0;
    /* plane[c]: w * h floats, row 0 at the top, or NULL when the image
     * has no channel named "R", "G", "B", "A" or "Y" (in that order);
     * owned, freed by lr__exr_planes_free. */
    float *plane[LR__EXR_NCH];
} lr__exr_planes;

/* Decodes the n bytes at data.  Messages begin with `shown` (e.g.
 * "environment.file: sky.exr") and say what is wrong: not OpenEXR, not
 * scanline, larger than max_dim on a side ("`what` must be 1 to max_dim
 * on each side") or than max_texels in all (both checked from the header,
 * before anything is decoded), more than one part, a subsampled channel,
 * a bad or undecodable chunk; err->path is
 * `blame` (may be NULL).  Other channels are ignored.  On error *out
 * holds nothing. */
lr_status lr__exr_read(const void *data, size_t n, const char *shown,
                       const char *blame, const char *what, int max_dim,
                       size_t max_texels, lr__exr_planes *out, lr_error *err);
void lr__exr_planes_free(lr__exr_planes *p);

/* The first four bytes of every OpenEXR file (its magic number). */
int lr__exr_magic(const void *data, size_t n);

#endif
