/*
 * texture.c: textures (texture.h): loading by magic bytes, OpenEXR
 * textures (through exr_read.c, the reader the environment map uses),
 * the sRGB decoding and the bilinear lookup.
 */
#include "scene/texture.h"
#include "image/exr_read.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

double lr__srgb_decode(double c)
{
    /* IEC 61966-2-1:1999, section 5.2 (the inverse of lr__srgb_encode). */
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

void lr__texture_table8(float table[256], int srgb)
{
    for (int k = 0; k < 256; k++)
        table[k] = (float)(srgb ? lr__srgb_decode(k / 255.0) : k / 255.0);
}

lr_status lr__texture_check_size(long long w, long long h, const char *name,
                                 lr_error *err)
{
    if (w < 1 || h < 1 || w > LR__TEX_MAX_DIM || h > LR__TEX_MAX_DIM ||
        (unsigned long long)w * (unsigned long long)h > LR__TEX_MAX_TEXELS)
        return lr__fail(err, LR_ERR_LIMIT, NULL,
                        "%s is %lld x %lld pixels; a texture must be 1 to %d "
                        "on each side and at most %zu pixels",
                        name, w, h, LR__TEX_MAX_DIM, LR__TEX_MAX_TEXELS);
    /* And within what the scene loading it may still hold. */
    if ((uint64_t)w * (uint64_t)h > lr__texel_room()) {
        char what[400];
        snprintf(what, sizeof what, "%s is %lld x %lld pixels", name, w, h);
        return lr__texel_room_check((uint64_t)w * (uint64_t)h, what, err);
    }
    return LR_OK;
}

void lr__texture_free(lr__texture *t)
{
    if (t == NULL)
        return;
    free(t->rgba);
    free(t);
}

/* An OpenEXR texture: R, G, B (or Y, grey) and A if present; every value
 * finite and >= 0. */
lr_status lr__exr_read_room(const void *data, size_t n, const char *name,
                            const char *blame, const char *what, int max_dim,
                            size_t max_texels, lr__exr_planes *px,
                            lr_error *err)
{
    uint64_t room = lr__texel_room();
    size_t most = room < max_texels ? (size_t)room : max_texels;
    /* (At least one texel asked for: room 0 refuses it below.) */
    lr_status st = lr__exr_read(data, n, name, blame, what, max_dim,
                                most ? most : 1, px, err);
    int over = st == LR_ERR_LIMIT && most < max_texels;
    if (st == LR_OK && (uint64_t)px->w * (uint64_t)px->h > room) {
        lr__exr_planes_free(px);
        over = 1;
    }
    if (!over)
        return st;
    lr__texel_room_check(UINT64_MAX, name, err);
    if (err != NULL && blame != NULL)
        snprintf(err->path, sizeof err->path, "%s", blame);
    return LR_ERR_LIMIT;
}

static lr_status texture_exr(const void *data, size_t n, const char *name,
                             lr__texture *t, lr_error *err)
{
    lr__exr_planes px;
    lr_status st = lr__exr_read_room(data, n, name, NULL, "a texture",
                                     LR__TEX_MAX_DIM, LR__TEX_MAX_TEXELS, &px,
                                     err);
    if (st != LR_OK)
        return st;
    /* (lr__exr_read has refused sizes beyond lr__texture_check_size's.) */
    int rgb = px.plane[LR__EXR_R] && px.plane[LR__EXR_G] && px.plane[LR__EXR_B];
    if (!rgb && px.plane[LR__EXR_Y] == NULL)
        st = lr__fail(err, LR_ERR_INVALID, NULL,
                      "%s needs channels R, G and B, or Y", name);
    size_t count = (size_t)px.w * (size_t)px.h;
    if (st == LR_OK) {
        t->w = px.w, t->h = px.h;
        t->rgba = malloc(4 * count * sizeof(float));
        if (t->rgba == NULL)
            st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    for (size_t i = 0; st == LR_OK && i < count; i++)
        for (int c = 0; c < 4; c++) {
            const float *pl = c == 3 ? px.plane[LR__EXR_A]
                              : rgb  ? px.plane[c]
                                     : px.plane[LR__EXR_Y];
            float v = pl != NULL ? pl[i] : 1.0f;
            if (!isfinite(v) || v < 0.0f) {
                st = lr__fail(err, LR_ERR_INVALID, NULL,
                              "%s: pixel (%lld, %lld) channel %c is %g; a "
                              "texture's values must be finite and >= 0",
                              name, px.x0 + (long long)(i % (size_t)px.w),
                              px.y0 + (long long)(i / (size_t)px.w), "RGBA"[c],
                              (double)v);
                break;
            }
            t->rgba[4 * i + (size_t)c] = v;
        }
    lr__exr_planes_free(&px);
    return st;
}

lr__texture *lr__texture_load_memory(const void *data, size_t n,
                                     const char *name, int srgb, lr_error *err)
{
    if (name == NULL)
        name = "(texture)";
    if (data == NULL && n > 0) {
        lr__fail(err, LR_ERR_INVALID, NULL, "%s: no data", name);
        return NULL;
    }
    lr__texture *t = calloc(1, sizeof *t);
    if (t == NULL) {
        lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        return NULL;
    }
    const unsigned char *b = data;
    lr_status st;
    if (n >= 8 && memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0)
        st = lr__texture_png(data, n, name, srgb, t, err);
    else if (n >= 3 && memcmp(b, "\xff\xd8\xff", 3) == 0)
        st = lr__texture_jpeg(data, n, name, srgb, t, err);
    else if (lr__exr_magic(data, n))
        st = texture_exr(data, n, name, t, err);
    else
        st = lr__fail(err, LR_ERR_INVALID, NULL,
                      "%s is not a PNG, JPEG or OpenEXR image (by its first "
                      "bytes)",
                      name);
    if (st != LR_OK) {
        lr__texture_free(t);
        return NULL;
    }
    size_t count = (size_t)t->w * (size_t)t->h;
    for (int c = 0; c < 4; c++) {
        double sum = 0.0, hi = 0.0;
        for (size_t i = 0; i < count; i++) {
            double v = t->rgba[4 * i + (size_t)c];
            sum += v;
            hi = v > hi ? v : hi;
        }
        t->mean[c] = sum / (double)count;
        t->max[c] = hi;
    }
    return t;
}

lr__texture *lr__texture_load_named(const char *path, const char *shown,
                                    int srgb, lr_error *err)
{
    if (path == NULL) {
        lr__fail(err, LR_ERR_INVALID, NULL, "lr__texture_load: NULL path");
        return NULL;
    }
    if (shown == NULL)
        shown = path;
    char *buf = NULL;
    size_t len = 0;
    if (lr__read_file(path, shown, NULL, LR__TEX_MAX_BYTES, "textures", NULL,
                      &buf, &len, err) != LR_OK)
        return NULL;
    lr__texture *t = lr__texture_load_memory(buf, len, shown, srgb, err);
    free(buf);
    return t;
}

lr__texture *lr__texture_load(const char *path, int srgb, lr_error *err)
{
    return lr__texture_load_named(path, path, srgb, err);
}

/* Texel coordinate x (texel centres at integers) wrapped into [0, n):
 * the two texels either side and the weight of the second. */
static void wrap(double x, int n, int *i0, int *i1, double *f)
{
    if (!isfinite(x))
        x = 0.0;
    double fl = floor(x);
    *f = x - fl;
    /* fmod of an integral double is exact. */
    double m = fmod(fl, (double)n);
    if (m < 0.0)
        m += n;
    int i = (int)m;
    if (i >= n || i < 0)
        i = 0;
    *i0 = i;
    *i1 = i + 1 == n ? 0 : i + 1;
}

void lr__texture_lookup(const lr__texture *t, double u, double v, float rgba[4])
{
    /* Texel (i, j) (j counted down from the top row) has its centre at
     * u = (i + 0.5) / w, v = 1 - (j + 0.5) / h. */
    int x0, x1, y0, y1;
    double fx, fy;
    wrap(u * t->w - 0.5, t->w, &x0, &x1, &fx);
    wrap((1.0 - v) * t->h - 0.5, t->h, &y0, &y1, &fy);
    const float *a = &t->rgba[4 * ((size_t)y0 * (size_t)t->w + (size_t)x0)];
    const float *b = &t->rgba[4 * ((size_t)y0 * (size_t)t->w + (size_t)x1)];
    const float *c = &t->rgba[4 * ((size_t)y1 * (size_t)t->w + (size_t)x0)];
    const float *d = &t->rgba[4 * ((size_t)y1 * (size_t)t->w + (size_t)x1)];
    for (int k = 0; k < 4; k++)
        rgba[k] = (float)((1.0 - fy) * ((1.0 - fx) * a[k] + fx * b[k]) +
                          fy * ((1.0 - fx) * c[k] + fx * d[k]));
}
