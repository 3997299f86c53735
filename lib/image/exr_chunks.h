/*
 * exr_chunks.h: the EXR encoder's pixels (exr_chunks.c) for image_exr.c,
 * which makes the file's context, header and stream: the channels, and
 * every chunk staged, converted and compressed, on several threads for a
 * large image.
 */
#ifndef LR_EXR_CHUNKS_H
#define LR_EXR_CHUNKS_H

#include "util/internal.h"

#include <openexr.h>

#include <stddef.h>

enum { CH_R, CH_G, CH_B, CH_Z, CH_COUNT };

/* The channels' names in the file, by CH_R ... CH_Z. */
extern const char *const lr__exr_channel_names[CH_COUNT];

/* Compresses and writes every chunk of the image into the context's
 * part, whose header is written: spc scanlines a chunk, plane_bytes a
 * channel's staging plane, zip: ZIP or ZIPS through exr_zip.c. */
exr_result_t lr__exr_encode_chunks(exr_context_t ctxt, int part,
                                   const lr_image *img, int want_z, int half,
                                   int spc, size_t plane_bytes, int zip);

#endif
