/*
 * image_exr.c: encodes an lr_image as a single-part scanline OpenEXR file
 * in memory, with the OpenEXRCore C API (no C++).
 *
 * Channels: R, G, B as float32 (or half with opts->exr_half) and Z as
 * float32 when the image has depth and opts->exr_depth is set; ZIP
 * compression unless opts->exr_compression says another; Rec.709 / sRGB
 * chromaticities, since the renderer's linear RGB uses those primaries.
 * Large images are compressed on several threads (exr_chunks.c: the
 * pixels staged, converted and compressed chunk by chunk; here the
 * stream, the header and its attributes).
 *
 * Non-finite samples are never written: a NaN or infinite R, G or B
 * becomes 0, and a NaN or infinite Z becomes LR_DEPTH_NONE, the value
 * that already means "nothing was hit here".  Images from lr_render are
 * always finite, but images built by callers through lr_image_rgb_mut
 * need not be, and NaN or Inf in an EXR poisons every filter and
 * compositing step downstream.  For the same reason half output clamps
 * magnitudes beyond the largest half (65504) instead of writing Inf.
 *
 * A crop (lr_image_set_frame) has its data window at its place inside a
 * display window of the whole frame, and says how it was rendered.
 */
#include "util/internal.h"
#include "image/exr_chunks.h"

#include <openexr.h>

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- the in-memory stream --------------------------------------------- */

/* The output buffer plus what the error handler learnt; it is the
 * context's user data. */
typedef struct exr_sink {
    int fd;                     /* >= 0: write to this file instead */
    int io_errno;               /* the errno of a failed write to fd */
    const volatile int *cancel; /* non-zero: writes to fd fail */
    unsigned char *data;
    size_t len, cap;
    int out_of_memory; /* set when the buffer could not grow */
    char message[256]; /* the library's first detailed error message */
} exr_sink;

/* OpenEXRCore reports details through this callback, by default on
 * stderr; a library must stay quiet, so the first message is kept for
 * the lr_error instead.  Later messages are usually consequences of the
 * first. */
static void sink_error_handler(exr_const_context_t ctxt, exr_result_t code,
                               const char *msg)
{
    (void)code;
    void *user = NULL;
    if (ctxt == NULL || exr_get_user_data(ctxt, &user) != EXR_ERR_SUCCESS ||
        user == NULL)
        return;
    exr_sink *sink = user;
    if (sink->message[0] == '\0')
        snprintf(sink->message, sizeof sink->message, "%s", msg ? msg : "");
}

/* The write callback has pwrite semantics: the library writes the header
 * and chunks in order, then goes back to fill in the chunk offset table,
 * so writes may land anywhere, and any gap is zero-filled. */
static int64_t sink_write(exr_const_context_t ctxt, void *user,
                          const void *buffer, uint64_t sz, uint64_t offset,
                          exr_stream_error_func_ptr_t error_cb)
{
    exr_sink *sink = user;
    /* Our own failures are recorded in the sink rather than reported
     * through error_cb: OpenEXRCore may call the error handler with the
     * context's lock held, and the handler's exr_get_user_data() would
     * then wait on that lock forever.  The caller maps out_of_memory to
     * LR_ERR_NOMEM. */
    (void)ctxt;
    (void)error_cb;
    if (sink->fd >= 0) {
        if (sink->cancel != NULL && *sink->cancel) {
            sink->io_errno = ECANCELED;
            return -1;
        }
        const unsigned char *p = buffer;
        uint64_t left = sz, at = offset;
        while (left > 0) {
            ssize_t n = pwrite(sink->fd, p, left, (off_t)at);
            if (n < 0 && errno == EINTR)
                continue;
            if (n <= 0) {
                sink->io_errno = n < 0 ? errno : EIO;
                return -1;
            }
            p += n;
            at += (uint64_t)n;
            left -= (uint64_t)n;
        }
        return (int64_t)sz;
    }
    if (offset > SIZE_MAX || sz > SIZE_MAX - offset) {
        sink->out_of_memory = 1;
        return -1;
    }
    size_t end = (size_t)offset + (size_t)sz;
    if (end > sink->cap) {
        /* Doubling keeps the number of reallocations logarithmic in the
         * size of the file. */
        size_t cap = sink->cap ? sink->cap : 4096;
        while (cap < end)
            cap = cap > SIZE_MAX / 2 ? end : cap * 2;
        unsigned char *grown = realloc(sink->data, cap);
        if (grown == NULL) {
            sink->out_of_memory = 1;
            return -1;
        }
        sink->data = grown;
        sink->cap = cap;
    }
    if ((size_t)offset > sink->len)
        memset(sink->data + sink->len, 0, (size_t)offset - sink->len);
    memcpy(sink->data + offset, buffer, (size_t)sz);
    if (end > sink->len)
        sink->len = end;
    return (int64_t)sz;
}

/* ---- the encoder ------------------------------------------------------ */

/* The primaries and white point of Rec. ITU-R BT.709, which sRGB shares. */
static const exr_attr_chromaticities_t rec709 = {
    0.6400f, 0.3300f, 0.3000f, 0.6000f, 0.1500f, 0.0600f, 0.3127f, 0.3290f};
/* A crop's place and making (lr_image_set_frame): the data window where
 * the crop sits inside a display window of the whole frame, the way
 * OpenEXR ("Technical Introduction", data and display windows) and pbrt-v4
 * write crops, and how it was rendered.  The seed is a string: EXR has no
 * 64-bit integer attribute.  No render time: the same job must keep giving
 * the same bytes (docs/api.md, "Determinism"). */
static exr_result_t set_crop_attrs(exr_context_t ctxt, int part,
                                   const lr_image *img)
{
    exr_attr_box2i_t display, data;
    display.min.x = 0, display.min.y = 0;
    display.max.x = img->frame_w - 1, display.max.y = img->frame_h - 1;
    data.min.x = img->x0, data.min.y = img->y0;
    data.max.x = img->x0 + img->width - 1;
    data.max.y = img->y0 + img->height - 1;
    char seed[24];
    snprintf(seed, sizeof seed, "%llu", (unsigned long long)img->seed);
    exr_result_t rv = exr_set_display_window(ctxt, part, &display);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_set_data_window(ctxt, part, &data);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_attr_set_int(ctxt, part, "samplesPerPixel", img->spp);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_attr_set_string(ctxt, part, "lensraySeed", seed);
    if (rv == EXR_ERR_SUCCESS && img->camera != NULL)
        rv = exr_attr_set_string(ctxt, part, "lensrayCamera", img->camera);
    return rv;
}

/* OpenEXRCore's code for the options' compression; ZIP for a value out
 * of range (lr_output_options_default's). */
static exr_compression_t exr_compression(const lr_output_options *opts)
{
    switch (opts->exr_compression) {
    case LR_EXR_NONE:
        return EXR_COMPRESSION_NONE;
    case LR_EXR_ZIPS:
        return EXR_COMPRESSION_ZIPS;
    case LR_EXR_RLE:
        return EXR_COMPRESSION_RLE;
    case LR_EXR_PIZ:
        return EXR_COMPRESSION_PIZ;
    case LR_EXR_ZIP:
    default:
        return EXR_COMPRESSION_ZIP;
    }
}

lr_status lr__encode_exr(const lr_image *img, const lr_output_options *opts,
                         int fd, const volatile int *cancel, void **buf,
                         size_t *len, lr_error *err)
{
    *buf = NULL;
    *len = 0;
    /* (An unknown value was written as ZIP without a word.) */
    if ((int)opts->exr_compression < (int)LR_EXR_ZIP ||
        (int)opts->exr_compression > (int)LR_EXR_PIZ)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "exr_compression is not a known compression (%d)",
                        (int)opts->exr_compression);

    const int half = opts->exr_half != 0;
    const int want_z = opts->exr_depth && img->depth != NULL;
    const exr_pixel_type_t rgb_type = half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;

    exr_sink *sink = calloc(1, sizeof *sink);
    if (sink == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "out of memory starting the EXR encoder");
    sink->fd = fd;
    sink->cancel = cancel;

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = sink_error_handler;
    init.user_data = sink;
    init.write_fn = sink_write;

    exr_context_t ctxt = NULL;
    const char *step = "start the encoder";
    int part = 0;
    int32_t spc = 0;
    size_t plane_bytes = 0;

    /* The name is only for messages: a custom write_fn does the I/O. */
    exr_result_t rv = exr_start_write(&ctxt, "<memory>",
                                      EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS)
        goto fail;

    step = "define the image";
    rv = exr_add_part(ctxt, NULL, EXR_STORAGE_SCANLINE, &part);
    if (rv != EXR_ERR_SUCCESS)
        goto fail;
    rv = exr_initialize_required_attr_simple(
        ctxt, part, img->width, img->height, exr_compression(opts));
    if (rv != EXR_ERR_SUCCESS)
        goto fail;
    /* Colour channels are perceptually logarithmic, depth is linear; the
     * hint only matters to lossy compressors. */
    for (int c = 0; c < CH_COUNT && rv == EXR_ERR_SUCCESS; c++) {
        if (c == CH_Z && !want_z)
            continue;
        rv = exr_add_channel(ctxt, part, lr__exr_channel_names[c],
                             c == CH_Z ? EXR_PIXEL_FLOAT : rgb_type,
                             c == CH_Z ? EXR_PERCEPTUALLY_LINEAR
                                       : EXR_PERCEPTUALLY_LOGARITHMIC,
                             1, 1);
    }
    if (rv != EXR_ERR_SUCCESS)
        goto fail;
    rv = exr_attr_set_chromaticities(ctxt, part, "chromaticities", &rec709);
    if (rv != EXR_ERR_SUCCESS)
        goto fail;
    if (img->frame_w > 0) {
        step = "describe the crop";
        rv = set_crop_attrs(ctxt, part, img);
        if (rv != EXR_ERR_SUCCESS)
            goto fail;
    }

    step = "write the header";
    rv = exr_write_header(ctxt);
    if (rv != EXR_ERR_SUCCESS)
        goto fail;

    rv = exr_get_scanlines_per_chunk(ctxt, part, &spc);
    if (rv != EXR_ERR_SUCCESS)
        goto fail;
    if (spc <= 0)
        spc = 1;

    /* One staging plane per channel per thread, each big enough for a
     * chunk of float32 samples.  lr_image_create bounds width * height *
     * 12 bytes, but a chunk can be taller than the image, so check again. */
    if ((size_t)img->width > SIZE_MAX / CH_COUNT / 4 / (size_t)spc) {
        exr_finish(&ctxt);
        free(sink);
        return lr__fail(err, LR_ERR_LIMIT, NULL,
                        "cannot encode a %d x %d EXR: a row is too wide",
                        img->width, img->height);
    }
    plane_bytes = (size_t)img->width * (size_t)spc * 4;

    step = "encode the pixels";
    exr_compression_t comp = exr_compression(opts);
    rv = lr__exr_encode_chunks(ctxt, part, img, want_z, half, spc, plane_bytes,
                               comp == EXR_COMPRESSION_ZIP ||
                                   comp == EXR_COMPRESSION_ZIPS);
    if (rv != EXR_ERR_SUCCESS)
        goto fail;

    step = "finish the file";
    /* exr_finish writes the chunk offset table, so it can fail too. */
    rv = exr_finish(&ctxt);
    if (rv != EXR_ERR_SUCCESS)
        goto fail;

    *buf = sink->data;
    *len = sink->len;
    free(sink);
    return LR_OK;

fail:
    if (rv == EXR_ERR_OUT_OF_MEMORY)
        sink->out_of_memory = 1;
    if (ctxt != NULL)
        exr_finish(&ctxt);
    {
        lr_status st = (sink->out_of_memory || rv == EXR_ERR_OUT_OF_MEMORY)
                           ? LR_ERR_NOMEM
                           : LR_ERR_IO;
        if (sink->io_errno == ECANCELED)
            lr__fail(err, LR_ERR_CANCELLED, NULL,
                     "writing the %d x %d EXR was cancelled", img->width,
                     img->height);
        else if (sink->io_errno != 0)
            lr__fail(err, LR_ERR_IO, NULL,
                     "cannot write a %d x %d EXR: failed to %s: %s", img->width,
                     img->height, step, strerror(sink->io_errno));
        else
            lr__fail(err, st, NULL,
                     "cannot encode a %d x %d EXR: failed to %s: %s%s%s%s",
                     img->width, img->height, step,
                     exr_get_default_error_message(rv),
                     sink->message[0] ? " (" : "", sink->message,
                     sink->message[0] ? ")" : "");
        st = sink->io_errno == ECANCELED ? LR_ERR_CANCELLED
             : sink->io_errno != 0       ? LR_ERR_IO
                                         : st;
        free(sink->data);
        free(sink);
        return st;
    }
}
