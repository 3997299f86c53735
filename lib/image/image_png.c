/*
 * image_png.c: encodes an lr_image as an sRGB PNG with libpng, in memory
 * or straight into a file.
 * The Z channel, if any, is not stored: PNG has no place for it.
 */
#include "util/internal.h"

#include <errno.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The growing output buffer plus what the error callback learnt, passed
 * to the libpng callbacks through their user pointers. */
typedef struct png_sink {
    int fd;                     /* >= 0: write to this file instead */
    int io_errno;               /* the errno of a failed write to fd */
    const volatile int *cancel; /* non-zero: writes to fd fail */
    unsigned char *data;
    size_t len, cap;
    int out_of_memory; /* set when the buffer could not grow */
    char message[256]; /* the last libpng error message */
} png_sink;

/* libpng calls this instead of printing to stderr.  It must not return,
 * so it records the message and jumps back to the setjmp in
 * lr__encode_png. */
static void sink_error(png_structp png, png_const_charp msg)
{
    png_sink *sink = png_get_error_ptr(png);
    /* sink_write's errors come with the message already in place: a copy
     * onto itself (snprintf of overlapping buffers) left it empty. */
    if (sink != NULL && msg != sink->message)
        snprintf(sink->message, sizeof sink->message, "%s",
                 msg ? msg : "unknown error");
    png_longjmp(png, 1);
}

/* Warnings do not stop encoding, and a library must not write to
 * stderr, so they are dropped. */
static void sink_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

static void sink_write(png_structp png, png_bytep data, png_size_t n)
{
    png_sink *sink = png_get_io_ptr(png);
    if (sink->fd >= 0) {
        if (sink->cancel != NULL && *sink->cancel) {
            sink->io_errno = ECANCELED;
            snprintf(sink->message, sizeof sink->message, "cancelled");
            png_error(png, sink->message);
        }
        while (n > 0) {
            ssize_t w = write(sink->fd, data, n);
            if (w < 0 && errno == EINTR)
                continue;
            if (w <= 0) {
                sink->io_errno = w < 0 ? errno : EIO;
                snprintf(sink->message, sizeof sink->message, "%s",
                         strerror(sink->io_errno));
                png_error(png, sink->message);
            }
            data += w;
            n -= (size_t)w;
        }
        return;
    }
    if (n > sink->cap - sink->len) {
        /* Doubling keeps the number of reallocations logarithmic in the
         * size of the file. */
        size_t cap = sink->cap ? sink->cap : 4096;
        while (cap - sink->len < n) {
            if (cap > ((size_t)-1) / 2) {
                sink->out_of_memory = 1;
                png_error(png, "the PNG does not fit in memory");
            }
            cap *= 2;
        }
        unsigned char *grown = realloc(sink->data, cap);
        if (grown == NULL) {
            sink->out_of_memory = 1;
            png_error(png, "out of memory growing the PNG buffer");
        }
        sink->data = grown;
        sink->cap = cap;
    }
    memcpy(sink->data + sink->len, data, n);
    sink->len += n;
}

static void sink_flush(png_structp png)
{
    (void)png;
}

/* Converts one row of linear RGB floats to sRGB code values, 8 or 16 bits
 * per channel; 16-bit samples are stored big-endian as PNG requires. */
static void convert_row(const float *src, int width, int sixteen,
                        unsigned char *dst)
{
    size_t n = (size_t)width * 3;
    for (size_t i = 0; i < n; i++) {
        double s = lr__srgb_encode(src[i]);
        if (sixteen) {
            unsigned v = (unsigned)(s * 65535.0 + 0.5);
            dst[2 * i] = (unsigned char)(v >> 8);
            dst[2 * i + 1] = (unsigned char)(v & 0xffu);
        } else {
            dst[i] = (unsigned char)(s * 255.0 + 0.5);
        }
    }
}

lr_status lr__encode_png(const lr_image *img, const lr_output_options *opts,
                         int fd, const volatile int *cancel, void **buf,
                         size_t *len, lr_error *err)
{
    *buf = NULL;
    *len = 0;

    const int sixteen = opts->png_16bit != 0;
    const size_t row_bytes = (size_t)img->width * 3 * (sixteen ? 2 : 1);

    /* The C standard leaves automatic variables that change between
     * setjmp and longjmp indeterminate afterwards.  The sink changes as
     * libpng writes, so it lives on the heap; the local pointers below
     * are all assigned before setjmp and never after, so they stay valid
     * after the jump without needing volatile. */
    png_sink *sink = calloc(1, sizeof *sink);
    unsigned char *row = malloc(row_bytes);
    if (sink == NULL || row == NULL) {
        free(sink);
        free(row);
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "out of memory encoding a PNG of width %d", img->width);
    }
    sink->fd = fd;
    sink->cancel = cancel;

    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, sink,
                                              sink_error, sink_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (info == NULL) {
        png_destroy_write_struct(&png, NULL);
        free(row);
        free(sink);
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "out of memory starting the PNG encoder");
    }

    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(row);
        lr_status st = sink->io_errno == ECANCELED ? LR_ERR_CANCELLED
                       : sink->out_of_memory       ? LR_ERR_NOMEM
                                                   : LR_ERR_IO;
        if (st == LR_ERR_CANCELLED)
            lr__fail(err, st, NULL, "writing the %d x %d PNG was cancelled",
                     img->width, img->height);
        else
            lr__fail(err, st, NULL, "cannot %s a %d x %d PNG: %s",
                     sink->io_errno ? "write" : "encode", img->width,
                     img->height, sink->message);
        free(sink->data);
        free(sink);
        return st;
    }

    png_set_write_fn(png, sink, sink_write, sink_flush);
    /* libpng's default limits (one million pixels a side) are meant for
     * untrusted input; when writing, lr_image_create has already
     * validated the size, so allow anything PNG itself can store. */
    png_set_user_limits(png, PNG_UINT_31_MAX, PNG_UINT_31_MAX);
    png_set_IHDR(png, info, (png_uint_32)img->width, (png_uint_32)img->height,
                 sixteen ? 16 : 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    /* The sRGB chunk (with the matching gAMA and cHRM for old readers)
     * tells viewers the samples use the sRGB curve we applied. */
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);

    for (int y = 0; y < img->height; y++) {
        convert_row(img->rgb + (size_t)y * (size_t)img->width * 3, img->width,
                    sixteen, row);
        png_write_row(png, row);
    }
    png_write_end(png, info);

    png_destroy_write_struct(&png, &info);
    free(row);
    *buf = sink->data;
    *len = sink->len;
    free(sink);
    return LR_OK;
}
