/*
 * texture_png.c: PNG textures through libpng (texture.h): 1, 2, 4, 8 and
 * 16-bit grey, grey + alpha, RGB, RGBA and palette images (with tRNS
 * transparency), interlaced or not.  The colour channels are taken as
 * sRGB (glTF 2.0 says so of base colour and emissive images whatever
 * their chunks say; gAMA, cHRM and iCCP are not read).
 */
#include "scene/texture.h"

#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct png_src {
    const unsigned char *data;
    size_t n, at;
    char message[200]; /* libpng's last error */
} png_src;

static void src_read(png_structp png, png_bytep out, png_size_t k)
{
    png_src *src = png_get_io_ptr(png);
    if (k > src->n - src->at)
        png_error(png, "the file ends early (truncated)");
    memcpy(out, src->data + src->at, k);
    src->at += k;
}

/* libpng must not return from here nor print: record and jump. */
static void src_error(png_structp png, png_const_charp msg)
{
    png_src *src = png_get_error_ptr(png);
    snprintf(src->message, sizeof src->message, "%s",
             msg ? msg : "unknown error");
    png_longjmp(png, 1);
}

static void src_warning(png_structp png, png_const_charp msg)
{
    (void)png, (void)msg;
}

lr_status lr__texture_png(const void *data, size_t n, const char *name,
                          int srgb, lr__texture *t, lr_error *err)
{
    png_src src = {data, n, 0, ""};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &src,
                                             src_error, src_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (info == NULL) {
        png_destroy_read_struct(&png, NULL, NULL);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    /* Set before the jump point, read after a jump: volatile. */
    unsigned char *volatile pixels = NULL;
    png_bytep *volatile rows = NULL;
    volatile lr_status st = LR_OK;
    if (setjmp(png_jmpbuf(png))) {
        if (st == LR_OK)
            st = lr__fail(err, LR_ERR_INVALID, NULL,
                          "%s: not a valid PNG image: %s", name, src.message);
        goto done;
    }
    png_set_read_fn(png, &src, src_read);
    /* (libpng refuses sides beyond a million itself; ours are checked
     * below, before anything large is allocated.) */
    png_set_chunk_malloc_max(png, 64u << 20);
    png_read_info(png, info);
    png_uint_32 w = png_get_image_width(png, info);
    png_uint_32 h = png_get_image_height(png, info);
    if (lr__texture_check_size(w, h, name, err) != LR_OK) {
        st = LR_ERR_LIMIT;
        goto done;
    }
    int type = png_get_color_type(png, info);
    if (type == PNG_COLOR_TYPE_PALETTE)
        png_set_palette_to_rgb(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS))
        png_set_tRNS_to_alpha(png);
    if (png_get_bit_depth(png, info) < 8)
        png_set_expand_gray_1_2_4_to_8(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    int ch = png_get_channels(png, info);
    int depth = png_get_bit_depth(png, info);
    size_t rowbytes = png_get_rowbytes(png, info);
    if (ch < 1 || ch > 4 || (depth != 8 && depth != 16) ||
        rowbytes != (size_t)w * (size_t)ch * (size_t)(depth / 8)) {
        st = lr__fail(err, LR_ERR_INVALID, NULL,
                      "%s: unsupported PNG layout (%d channels of %d bits)",
                      name, ch, depth);
        goto done;
    }
    pixels = malloc(rowbytes * h);
    rows = malloc(h * sizeof *rows);
    t->rgba = malloc((size_t)w * h * 4 * sizeof(float));
    if (pixels == NULL || rows == NULL || t->rgba == NULL) {
        st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        goto done;
    }
    for (png_uint_32 y = 0; y < h; y++)
        rows[y] = pixels + (size_t)y * rowbytes;
    png_read_image(png, rows);
    png_read_end(png, NULL);

    t->w = (int)w, t->h = (int)h;
    float table[256];
    lr__texture_table8(table, srgb);
    /* Grey and grey + alpha: the grey is R, G and B; the alpha is
     * linear (never decoded). */
    int has_alpha = ch == 2 || ch == 4, colours = has_alpha ? ch - 1 : ch;
    for (size_t i = 0; i < (size_t)w * h; i++) {
        float v[4];
        for (int c = 0; c < ch; c++) {
            const unsigned char *p = pixels + (i * (size_t)ch + (size_t)c) *
                                                  (size_t)(depth / 8);
            int alpha = has_alpha && c == ch - 1;
            if (depth == 8)
                v[c] = alpha ? p[0] / 255.0f : table[p[0]];
            else {
                /* PNG stores 16-bit samples big-endian. */
                double x = ((unsigned)p[0] << 8 | p[1]) / 65535.0;
                v[c] = (float)(srgb && !alpha ? lr__srgb_decode(x) : x);
            }
        }
        float *o = &t->rgba[4 * i];
        for (int c = 0; c < 3; c++)
            o[c] = v[colours == 1 ? 0 : c];
        o[3] = has_alpha ? v[ch - 1] : 1.0f;
    }
done:
    png_destroy_read_struct(&png, &info, NULL);
    free(pixels);
    free(rows);
    return st;
}
