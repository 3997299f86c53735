/*
 * exr_zip.h: OpenEXR's ZIP and ZIPS chunk compression done with
 * libdeflate, for image_exr.c's encoder.
 *
 * OpenEXRCore 3.1 (Debian 12) compresses a chunk with zlib at level 6:
 * 70% of the farm client's CPU and about 10% of a 64-spp 640 x 480
 * render went there.  libdeflate makes the same zlib stream format about
 * twice as fast (bench/README.md, "EXR output"); OpenEXR itself moved to
 * it in 3.2.  The chunk's bytes before deflate are OpenEXR's own
 * transform (its "Technical Introduction", ZIP compression): the bytes
 * split into even and odd positions, then each byte replaced by its
 * difference from the one before, plus 128.
 *
 * One lr__exr_zip per thread: it owns the deflate state and its buffers.
 */
#ifndef LR_EXR_ZIP_H
#define LR_EXR_ZIP_H

#include <stddef.h>

typedef struct lr__exr_zip lr__exr_zip;

/* NULL when out of memory. */
lr__exr_zip *lr__exr_zip_new(void);
void lr__exr_zip_free(lr__exr_zip *z);

/* Compresses the n packed bytes at `in` into a chunk.  *out is then z's
 * buffer (valid until the next call or lr__exr_zip_free), or `in` itself
 * when deflate would not make the chunk smaller: OpenEXR reads a chunk
 * whose size equals the unpacked size as stored, so such a chunk must be
 * written raw.  Returns 0, or -1 when out of memory. */
int lr__exr_zip_chunk(lr__exr_zip *z, const unsigned char *in, size_t n,
                      const unsigned char **out, size_t *out_len);

/* Hands the caller the buffer that the last lr__exr_zip_chunk returned
 * in *out, if it is z's own (the caller frees it; z makes a new one for
 * its next chunk), so that a chunk kept for later is not copied; NULL
 * when `out` is not z's buffer (the chunk was stored raw). */
unsigned char *lr__exr_zip_take(lr__exr_zip *z, const unsigned char *out);

#endif
