/*
 * texture_jpeg.c: JPEG textures through libjpeg-turbo (texture.h): grey
 * and colour (YCbCr, RGB) baseline and progressive images, 8 bits.  JPEG
 * colour is sRGB.  libjpeg's default error handler calls exit(); ours
 * jumps back here instead, and so do its warnings (a truncated or
 * corrupt file, which libjpeg would finish with grey, is an error).
 */
#include "scene/texture.h"

/* (jpeglib.h needs stdio.h first.) */
#include <stdio.h>
#include <jpeglib.h>
#include <setjmp.h>
#include <stdlib.h>

typedef struct jerr {
    struct jpeg_error_mgr mgr; /* first: libjpeg passes a pointer to it */
    jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
} jerr;

static void on_error(j_common_ptr cinfo)
{
    jerr *e = (jerr *)cinfo->err;
    (*cinfo->err->format_message)(cinfo, e->message);
    longjmp(e->jump, 1);
}

/* Level -1 is a warning about corrupt data; others are trace messages. */
static void on_message(j_common_ptr cinfo, int level)
{
    if (level < 0)
        on_error(cinfo);
}

lr_status lr__texture_jpeg(const void *data, size_t n, const char *name,
                           int srgb, lr__texture *t, lr_error *err)
{
    struct jpeg_decompress_struct cinfo;
    jerr e;
    unsigned char *volatile row = NULL;
    volatile lr_status st = LR_OK;
    cinfo.err = jpeg_std_error(&e.mgr);
    e.mgr.error_exit = on_error;
    e.mgr.emit_message = on_message;
    e.message[0] = '\0';
    if (setjmp(e.jump)) {
        if (st == LR_OK)
            st = lr__fail(err, LR_ERR_INVALID, NULL,
                          "%s: not a valid JPEG image: %s", name, e.message);
        goto done;
    }
    jpeg_create_decompress(&cinfo);
    /* libjpeg's memory manager stops at this many bytes of its own
     * buffers (progressive images keep every coefficient). */
    cinfo.mem->max_memory_to_use = 1024L << 20;
    jpeg_mem_src(&cinfo, data, (unsigned long)n);
    jpeg_read_header(&cinfo, TRUE);
    if (lr__texture_check_size(cinfo.image_width, cinfo.image_height, name,
                               err) != LR_OK) {
        st = LR_ERR_LIMIT;
        goto done;
    }
    if (cinfo.jpeg_color_space == JCS_CMYK ||
        cinfo.jpeg_color_space == JCS_YCCK) {
        st = lr__fail(err, LR_ERR_INVALID, NULL,
                      "%s: CMYK JPEG images are not supported; save it as "
                      "RGB",
                      name);
        goto done;
    }
    cinfo.out_color_space = cinfo.jpeg_color_space == JCS_GRAYSCALE
                                ? JCS_GRAYSCALE
                                : JCS_RGB;
    jpeg_start_decompress(&cinfo);
    size_t w = cinfo.output_width, h = cinfo.output_height;
    int ch = cinfo.output_components;
    t->rgba = malloc(w * h * 4 * sizeof(float));
    row = malloc(w * (size_t)ch);
    if (t->rgba == NULL || row == NULL) {
        st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        goto done;
    }
    t->w = (int)w, t->h = (int)h;
    float table[256];
    lr__texture_table8(table, srgb);
    while (cinfo.output_scanline < h) {
        size_t y = cinfo.output_scanline;
        JSAMPROW r = row;
        if (jpeg_read_scanlines(&cinfo, &r, 1) != 1) {
            snprintf(e.message, sizeof e.message, "the image data ends early");
            longjmp(e.jump, 1);
        }
        for (size_t x = 0; x < w; x++) {
            float *o = &t->rgba[4 * (y * w + x)];
            for (int c = 0; c < 3; c++)
                o[c] = table[row[x * (size_t)ch + (size_t)(ch == 1 ? 0 : c)]];
            o[3] = 1.0f;
        }
    }
    jpeg_finish_decompress(&cinfo);
done:
    jpeg_destroy_decompress(&cinfo);
    free(row);
    return st;
}
