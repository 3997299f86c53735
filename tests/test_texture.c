/*
 * test_texture.c: image textures (lib/scene/texture.c, texture_png.c,
 * texture_jpeg.c): decoding against images written here by independent
 * writers (PNG chunks built byte by byte with zlib, JPEG through
 * libjpeg's compressor, EXR through the library's own encoder whose
 * floats are exact), sRGB against the IEC 61966-2-1 formula and published
 * values, bilinear lookup and wrapping, and hostile files: every prefix
 * of a valid file, garbage, huge dimensions.
 */
#include "test.h"
#include "scene/texture.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <jpeglib.h>
#include <openexr.h>

/* ---- an independent PNG writer (PNG specification, ISO/IEC 15948) ---- */

typedef struct bytes {
    unsigned char *p;
    size_t n, cap;
} bytes;

static void put(bytes *b, const void *data, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 64;
        b->p = realloc(b->p, b->cap);
        assert_non_null(b->p);
    }
    memcpy(b->p + b->n, data, n);
    b->n += n;
}

static void put32(bytes *b, uint32_t v)
{
    unsigned char c[4] = {v >> 24, v >> 16, v >> 8, v};
    put(b, c, 4);
}

/* length, type, data, CRC-32 of type + data */
static void chunk(bytes *b, const char *type, const void *data, size_t n)
{
    put32(b, (uint32_t)n);
    put(b, type, 4);
    put(b, data, n);
    uLong crc = crc32(0L, (const Bytef *)type, 4);
    crc = crc32(crc, data, (uInt)n);
    put32(b, (uint32_t)crc);
}

/* A PNG of w x h with colour type `type` and bit depth `depth` from the
 * raw scanlines (filter byte 0 is added here); plte/trns may be NULL. */
static bytes png_file(uint32_t w, uint32_t h, int depth, int type,
                      const unsigned char *raw, size_t row_bytes,
                      const unsigned char *plte, size_t n_plte,
                      const unsigned char *trns, size_t n_trns)
{
    bytes b = {0};
    put(&b, "\x89PNG\r\n\x1a\n", 8);
    unsigned char ihdr[13];
    for (int i = 0; i < 4; i++) {
        ihdr[i] = (unsigned char)(w >> (24 - 8 * i));
        ihdr[4 + i] = (unsigned char)(h >> (24 - 8 * i));
    }
    ihdr[8] = (unsigned char)depth, ihdr[9] = (unsigned char)type;
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    chunk(&b, "IHDR", ihdr, 13);
    if (plte)
        chunk(&b, "PLTE", plte, n_plte);
    if (trns)
        chunk(&b, "tRNS", trns, n_trns);
    size_t n = (row_bytes + 1) * h;
    unsigned char *filt = malloc(n);
    for (uint32_t y = 0; y < h; y++) {
        filt[y * (row_bytes + 1)] = 0;
        memcpy(filt + y * (row_bytes + 1) + 1, raw + y * row_bytes, row_bytes);
    }
    uLongf zn = compressBound(n);
    unsigned char *z = malloc(zn);
    assert_int_equal(compress(z, &zn, filt, n), Z_OK);
    chunk(&b, "IDAT", z, zn);
    chunk(&b, "IEND", "", 0);
    free(filt);
    free(z);
    return b;
}

static lr__texture *load_mem(const bytes *b, int srgb)
{
    lr_error err;
    lr__texture *t = lr__texture_load_memory(b->p, b->n, "t.png", srgb, &err);
    if (t == NULL)
        fail_msg("%s", err.message);
    return t;
}

/* The formula, written out here: IEC 61966-2-1 section 5.2. */
static double srgb_ref(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

static void texel(const lr__texture *t, int x, int y, float out[4])
{
    memcpy(out, &t->rgba[4 * ((size_t)y * (size_t)t->w + (size_t)x)],
           4 * sizeof(float));
}

static void srgb_decode_values(void **state)
{
    (void)state;
    /* Published values of the sRGB decode (e.g. the W3C CSS Color 4
     * conversion code, same formula): code 0, 10 (linear segment: 10 /
     * 255 / 12.92), 128 and 255. */
    assert_true(lr__srgb_decode(0.0) == 0.0);
    assert_true(fabs(lr__srgb_decode(10 / 255.0) - 0.0030352698) < 1e-9);
    assert_true(fabs(lr__srgb_decode(128 / 255.0) - 0.2158605001) < 1e-9);
    assert_true(lr__srgb_decode(1.0) == 1.0);
    /* Both sides of the 0.04045 break (code 10 = 0.0392, 11 = 0.0431). */
    for (int k = 0; k < 256; k++)
        assert_true(lr__srgb_decode(k / 255.0) == srgb_ref(k / 255.0));
    float table[256];
    lr__texture_table8(table, 1);
    for (int k = 0; k < 256; k += 17)
        assert_true(table[k] == (float)srgb_ref(k / 255.0));
    lr__texture_table8(table, 0);
    for (int k = 0; k < 256; k += 17)
        assert_true(table[k] == (float)(k / 255.0));
}

static void png_8bit_layouts(void **state)
{
    (void)state;
    /* 3 x 2 RGB, 8-bit. */
    const unsigned char rgb[18] = {0,   10,  20, 30, 40, 50, 60,  70,  80,
                                   255, 128, 1,  2,  3,  4,  200, 100, 0};
    bytes b = png_file(3, 2, 8, 2, rgb, 9, NULL, 0, NULL, 0);
    for (int srgb = 0; srgb < 2; srgb++) {
        lr__texture *t = load_mem(&b, srgb);
        assert_int_equal(t->w, 3);
        assert_int_equal(t->h, 2);
        for (int i = 0; i < 6; i++)
            for (int c = 0; c < 3; c++) {
                double x = rgb[3 * i + c] / 255.0;
                assert_true(t->rgba[4 * i + c] ==
                            (float)(srgb ? srgb_ref(x) : x));
            }
        assert_true(t->rgba[3] == 1.0f);
        lr__texture_free(t);
    }
    free(b.p);

    /* Grey + alpha: alpha is never decoded. */
    const unsigned char ga[4] = {128, 64, 255, 0};
    b = png_file(2, 1, 8, 4, ga, 4, NULL, 0, NULL, 0);
    lr__texture *t = load_mem(&b, 1);
    float v[4];
    texel(t, 0, 0, v);
    assert_true(v[0] == (float)srgb_ref(128 / 255.0) && v[1] == v[0] &&
                v[2] == v[0]);
    assert_true(v[3] == 64 / 255.0f);
    texel(t, 1, 0, v);
    assert_true(v[0] == 1.0f && v[3] == 0.0f);
    lr__texture_free(t);
    free(b.p);

    /* RGBA. */
    const unsigned char rgba[4] = {1, 2, 3, 4};
    b = png_file(1, 1, 8, 6, rgba, 4, NULL, 0, NULL, 0);
    t = load_mem(&b, 0);
    assert_true(t->rgba[0] == 1 / 255.0f && t->rgba[2] == 3 / 255.0f &&
                t->rgba[3] == 4 / 255.0f);
    lr__texture_free(t);
    free(b.p);

    /* Palette with transparency: indices 1, 0 (4-bit). */
    const unsigned char plte[6] = {10, 20, 30, 200, 150, 100};
    const unsigned char trns[1] = {51};
    const unsigned char idx[1] = {0x10};
    b = png_file(2, 1, 4, 3, idx, 1, plte, 6, trns, 1);
    t = load_mem(&b, 0);
    texel(t, 0, 0, v);
    assert_true(v[0] == 200 / 255.0f && v[1] == 150 / 255.0f &&
                v[2] == 100 / 255.0f && v[3] == 1.0f);
    texel(t, 1, 0, v);
    assert_true(v[0] == 10 / 255.0f && v[3] == 51 / 255.0f);
    lr__texture_free(t);
    free(b.p);

    /* 1-bit grey: 0b10100000 -> 1, 0, 1. */
    const unsigned char bits[1] = {0xa0};
    b = png_file(3, 1, 1, 0, bits, 1, NULL, 0, NULL, 0);
    t = load_mem(&b, 1);
    assert_true(t->rgba[0] == 1.0f && t->rgba[4] == 0.0f && t->rgba[8] == 1.0f);
    lr__texture_free(t);
    free(b.p);
}

static void png_16bit(void **state)
{
    (void)state;
    /* 2 x 1 RGB 16-bit, big-endian samples. */
    const uint16_t vals[6] = {0, 1, 32768, 65535, 12345, 54321};
    unsigned char raw[12];
    for (int i = 0; i < 6; i++)
        raw[2 * i] = vals[i] >> 8, raw[2 * i + 1] = vals[i] & 0xff;
    bytes b = png_file(2, 1, 16, 2, raw, 12, NULL, 0, NULL, 0);
    for (int srgb = 0; srgb < 2; srgb++) {
        lr__texture *t = load_mem(&b, srgb);
        for (int i = 0; i < 2; i++)
            for (int c = 0; c < 3; c++) {
                double x = vals[3 * i + c] / 65535.0;
                assert_true(t->rgba[4 * i + c] ==
                            (float)(srgb ? srgb_ref(x) : x));
            }
        lr__texture_free(t);
    }
    free(b.p);
}

/* ---- JPEG through libjpeg's compressor ------------------------------- */

static bytes jpeg_file(int w, int h, int comps, const unsigned char *px)
{
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    unsigned char *out = NULL;
    unsigned long n = 0;
    jpeg_mem_dest(&c, &out, &n);
    c.image_width = (JDIMENSION)w;
    c.image_height = (JDIMENSION)h;
    c.input_components = comps;
    c.in_color_space = comps == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, 100, TRUE);
    jpeg_start_compress(&c, TRUE);
    while (c.next_scanline < c.image_height) {
        JSAMPROW r = (JSAMPROW)(px + (size_t)c.next_scanline * w * comps);
        jpeg_write_scanlines(&c, &r, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    bytes b = {0};
    put(&b, out, n);
    free(out);
    return b;
}

static void jpeg_levels(void **state)
{
    (void)state;
    /* Flat grey 200 and a flat colour, 16 x 16: quality 100 keeps each
     * within 1/255 of the level written. */
    unsigned char grey[256], col[768];
    memset(grey, 200, sizeof grey);
    for (int i = 0; i < 256; i++)
        col[3 * i] = 40, col[3 * i + 1] = 120, col[3 * i + 2] = 220;
    bytes b = jpeg_file(16, 16, 1, grey);
    lr__texture *t = load_mem(&b, 0);
    assert_int_equal(t->w, 16);
    for (int i = 0; i < 256; i++)
        for (int c = 0; c < 3; c++)
            assert_true(fabs(t->rgba[4 * i + c] - 200 / 255.0) <=
                        1.0 / 255 + 1e-7);
    lr__texture_free(t);
    free(b.p);
    b = jpeg_file(16, 16, 3, col);
    t = load_mem(&b, 1);
    static const int want[3] = {40, 120, 220};
    for (int i = 0; i < 256; i++)
        for (int c = 0; c < 3; c++) {
            /* Decoded from sRGB: the level within 1/255 before decoding. */
            double lo = (float)srgb_ref((want[c] - 1) / 255.0),
                   hi = (float)srgb_ref((want[c] + 1) / 255.0);
            if (!(t->rgba[4 * i + c] >= lo && t->rgba[4 * i + c] <= hi))
                fail_msg("texel %d channel %d: %.6f, level %d decodes to "
                         "%.6f",
                         i, c, (double)t->rgba[4 * i + c], want[c],
                         srgb_ref(want[c] / 255.0));
        }
    assert_true(t->rgba[3] == 1.0f);
    lr__texture_free(t);
    free(b.p);
}

/* ---- EXR through the library's encoder -------------------------------- */

static void ramp(int x, int y, float rgb[3])
{
    rgb[0] = (float)x, rgb[1] = (float)y, rgb[2] = (float)(x * 10 + y);
}

static void exr_exact(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_exr("ramp.exr", 4, 2, ramp, path, sizeof path);
    lr_error err;
    lr__texture *t = lr__texture_load(path, 1, &err);
    if (t == NULL)
        fail_msg("%s", err.message);
    assert_int_equal(t->w, 4);
    assert_int_equal(t->h, 2);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 4; x++) {
            float v[4], r[3];
            texel(t, x, y, v);
            ramp(x, y, r);
            assert_true(v[0] == r[0] && v[1] == r[1] && v[2] == r[2]);
            assert_true(v[3] == 1.0f);
        }
    /* Mean of R: (0 + 1 + 2 + 3) / 4. */
    assert_true(t->mean[0] == 1.5);
    lr__texture_free(t);
}

static void bilinear_and_wrap(void **state)
{
    (void)state;
    char path[512];
    lr_test_write_exr("ramp2.exr", 4, 2, ramp, path, sizeof path);
    lr_error err;
    lr__texture *t = lr__texture_load(path, 0, &err);
    assert_non_null(t);
    float v[4];
    /* Texel centres: u = (x + 0.5) / 4, v = 1 - (y + 0.5) / 2 (v = 0 is
     * the bottom row). */
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 4; x++) {
            float r[3];
            ramp(x, y, r);
            for (int k = -2; k <= 2; k++) {
                /* Repeat wrapping: whole periods change nothing. */
                lr__texture_lookup(t, (x + 0.5) / 4 + k, 1 - (y + 0.5) / 2 - k,
                                   v);
                assert_true(v[0] == r[0] && v[1] == r[1] && v[2] == r[2]);
            }
        }
    /* Midway between texels (1, 0) and (2, 0): the mean. */
    lr__texture_lookup(t, 0.5, 0.75, v);
    assert_true(v[0] == 1.5f && v[1] == 0.0f && v[2] == 15.0f);
    /* Midway between rows 0 and 1 (v = 0.5) at column 3. */
    lr__texture_lookup(t, 0.875, 0.5, v);
    assert_true(v[0] == 3.0f && v[1] == 0.5f && v[2] == 30.5f);
    /* Across the wrap: u = 0 lies midway between columns 3 and 0. */
    lr__texture_lookup(t, 0.0, 0.75, v);
    assert_true(v[0] == 1.5f);
    /* Non-finite coordinates give a texel, not garbage. */
    lr__texture_lookup(t, NAN, INFINITY, v);
    assert_true(isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]));
    lr__texture_free(t);
}

/* ---- hostile input ---------------------------------------------------- */

/* Every prefix of `b` (and b with its tail cut short) must fail with an
 * error naming the file, never crash; the whole file must load. */
static void all_prefixes_fail(const bytes *b, const char *name)
{
    lr_error err;
    for (size_t n = 0; n < b->n; n++) {
        memset(&err, 0, sizeof err);
        lr__texture *t = lr__texture_load_memory(b->p, n, name, 1, &err);
        if (t != NULL) {
            /* A PNG may end before IEND's CRC only if libpng never needs
             * it; everything else must fail. */
            lr__texture_free(t);
            if (n + 12 < b->n)
                fail_msg("%s: a prefix of %zu of %zu bytes loaded", name, n,
                         b->n);
            continue;
        }
        if (strstr(err.message, name) == NULL)
            fail_msg("%s: message '%s' does not name the file", name,
                     err.message);
    }
    lr__texture *t = lr__texture_load_memory(b->p, b->n, name, 1, &err);
    assert_non_null(t);
    lr__texture_free(t);
}

static void truncated_files(void **state)
{
    (void)state;
    unsigned char raw[48];
    for (int i = 0; i < 48; i++)
        raw[i] = (unsigned char)(i * 5);
    bytes b = png_file(4, 4, 8, 2, raw, 12, NULL, 0, NULL, 0);
    all_prefixes_fail(&b, "cut.png");
    free(b.p);
    unsigned char grey[64];
    for (int i = 0; i < 64; i++)
        grey[i] = (unsigned char)(i * 3);
    b = jpeg_file(8, 8, 1, grey);
    all_prefixes_fail(&b, "cut.jpg");
    free(b.p);
    char path[512];
    lr_test_write_exr("cut.exr", 4, 2, ramp, path, sizeof path);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    b = (bytes){0};
    unsigned char buf[4096];
    for (size_t k = fread(buf, 1, sizeof buf, f); k > 0;
         k = fread(buf, 1, sizeof buf, f))
        put(&b, buf, k);
    fclose(f);
    all_prefixes_fail(&b, "cut.exr");
    free(b.p);
}

static void garbage_and_huge(void **state)
{
    (void)state;
    lr_error err;
    /* Not an image at all. */
    const char *txt = "hello, not an image";
    assert_null(lr__texture_load_memory(txt, strlen(txt), "x.png", 1, &err));
    assert_int_equal(err.status, LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "x.png is not a PNG, JPEG or OpenEXR"));
    /* Right magic, junk after it; flipped bytes in a valid PNG. */
    unsigned char junk[256];
    uint32_t r = 12345;
    for (int trial = 0; trial < 200; trial++) {
        memcpy(junk,
               trial % 3 == 0   ? "\x89PNG\r\n\x1a\n"
               : trial % 3 == 1 ? "\xff\xd8\xff\xe0\0\0\0\0"
                                : "\x76\x2f\x31\x01\2\0\0\0",
               8);
        for (int i = 8; i < 256; i++) {
            r = r * 1103515245u + 12345u;
            junk[i] = (unsigned char)(r >> 16);
        }
        lr__texture *t = lr__texture_load_memory(junk, sizeof junk, "junk", 1,
                                                 &err);
        lr__texture_free(t);
    }
    unsigned char raw[48] = {0};
    bytes b = png_file(4, 4, 8, 2, raw, 12, NULL, 0, NULL, 0);
    for (size_t i = 8; i < b.n; i++) {
        unsigned char keep = b.p[i];
        b.p[i] ^= 0x5a;
        lr__texture_free(
            lr__texture_load_memory(b.p, b.n, "flip.png", 1, &err));
        b.p[i] = keep;
    }
    free(b.p);

    /* Huge dimensions, declared in a valid header: refused before any
     * allocation of their size. */
    b = png_file(1, 1, 8, 0, raw, 1, NULL, 0, NULL, 0);
    const uint32_t big = 100000;
    for (int i = 0; i < 4; i++)
        b.p[16 + i] = (unsigned char)(big >> (24 - 8 * i)); /* width */
    uLong crc = crc32(0L, b.p + 12, 17);
    for (int i = 0; i < 4; i++)
        b.p[29 + i] = (unsigned char)(crc >> (24 - 8 * i));
    assert_null(lr__texture_load_memory(b.p, b.n, "wide.png", 1, &err));
    assert_non_null(strstr(err.message, "wide.png"));
    free(b.p);
    /* 20000 x 20000 (within libpng's own limit, beyond ours). */
    b = png_file(1, 1, 8, 0, raw, 1, NULL, 0, NULL, 0);
    for (int i = 0; i < 4; i++) {
        b.p[16 + i] = (unsigned char)(20000u >> (24 - 8 * i));
        b.p[20 + i] = (unsigned char)(20000u >> (24 - 8 * i));
    }
    crc = crc32(0L, b.p + 12, 17);
    for (int i = 0; i < 4; i++)
        b.p[29 + i] = (unsigned char)(crc >> (24 - 8 * i));
    assert_null(lr__texture_load_memory(b.p, b.n, "big.png", 1, &err));
    assert_int_equal(err.status, LR_ERR_LIMIT);
    assert_non_null(strstr(err.message, "big.png is 20000 x 20000 pixels"));
    free(b.p);
    /* A JPEG whose frame header says 65000 x 65000. */
    unsigned char grey[64] = {0};
    b = jpeg_file(8, 8, 1, grey);
    for (size_t i = 2; i + 9 < b.n; i++)
        if (b.p[i] == 0xff && b.p[i + 1] == 0xc0) {
            b.p[i + 5] = 0xfd, b.p[i + 6] = 0xe8; /* height 65000 */
            b.p[i + 7] = 0xfd, b.p[i + 8] = 0xe8; /* width */
            break;
        }
    assert_null(lr__texture_load_memory(b.p, b.n, "big.jpg", 1, &err));
    assert_int_equal(err.status, LR_ERR_LIMIT);
    assert_non_null(strstr(err.message, "big.jpg is 65000 x 65000 pixels"));
    free(b.p);
    /* An EXR one texel wider than the limit. */
    char path[512];
    lr_test_write_exr("wide.exr", LR__TEX_MAX_DIM + 1, 1, ramp, path,
                      sizeof path);
    assert_null(lr__texture_load(path, 0, &err));
    assert_non_null(strstr(err.message, "wide.exr is 16385 x 1 pixels"));
    assert_int_equal(err.status, LR_ERR_LIMIT); /* as PNG's (it was INVALID) */
    /* DWAA and DWAB, which Debian 12's OpenEXRCore cannot decode, are
     * named as such (the header's compression byte patched: the check
     * comes before any chunk is read). */
    lr_test_write_exr("dwa.exr", 4, 2, ramp, path, sizeof path);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    bytes e = {0};
    unsigned char buf[4096];
    for (size_t k = fread(buf, 1, sizeof buf, f); k > 0;
         k = fread(buf, 1, sizeof buf, f))
        put(&e, buf, k);
    fclose(f);
    static const char attr[] = "compression\0compression\0\1\0\0\0";
    size_t at = 0;
    while (at + sizeof attr <= e.n && memcmp(e.p + at, attr, sizeof attr - 1))
        at++;
    assert_true(at + sizeof attr <= e.n);
    /* And B44 and B44A with 32-bit channels (these are float), which
     * OpenEXRCore 3.1 decoded wrongly without an error. */
    static const char *const dwa[4] = {"B44-", "B44A", "DWAA", "DWAB"};
    for (int i = 0; i < 4; i++) {
        e.p[at + sizeof attr - 1] = (unsigned char)(6 + i);
        assert_null(lr__texture_load_memory(e.p, e.n, "dwa.exr", 0, &err));
        if (strstr(err.message, dwa[i]) == NULL ||
            strstr(err.message, "dwa.exr") == NULL)
            fail_msg("%s: %s", dwa[i], err.message);
    }
    free(e.p);
    /* A missing file names itself. */
    assert_null(lr__texture_load("/nonexistent/t.png", 1, &err));
    assert_int_equal(err.status, LR_ERR_IO);
    assert_non_null(strstr(err.message, "/nonexistent/t.png"));
}

/* A 4 x 4 uncompressed OpenEXR file written by OpenEXRCore itself:
 * `parts` parts, each with float B, G, R (texel value 1, 2, 3) and, if
 * sub, a half channel `sub` sampled every 2 x 2 pixels (as RY and BY are
 * in a luminance/chroma file); if moved, its data window at (10, 20) and
 * its R -1 at the window's (1, 2). */
static void core_exr(const char *name, int parts, const char *sub, int moved,
                     char *path, size_t cap)
{
    int n = snprintf(path, cap, "%s/%s", lr_test_tmpdir(), name);
    assert_true(n > 0 && (size_t)n < cap);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t ctxt = NULL;
    assert_int_equal(
        exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY, &init),
        EXR_ERR_SUCCESS);
    static const char *const part_names[2] = {"first", "second"};
    for (int p = 0; p < parts; p++) {
        int part = 0;
        assert_int_equal(exr_add_part(ctxt, parts > 1 ? part_names[p] : NULL,
                                      EXR_STORAGE_SCANLINE, &part),
                         EXR_ERR_SUCCESS);
        assert_int_equal(exr_initialize_required_attr_simple(
                             ctxt, part, 4, 4, EXR_COMPRESSION_NONE),
                         EXR_ERR_SUCCESS);
        exr_attr_box2i_t dw;
        dw.min.x = 10, dw.min.y = 20, dw.max.x = 13, dw.max.y = 23;
        if (moved)
            assert_int_equal(exr_set_data_window(ctxt, part, &dw),
                             EXR_ERR_SUCCESS);
        for (int c = 0; c < 3; c++)
            assert_int_equal(exr_add_channel(ctxt, part, &"B\0G\0R"[2 * c],
                                             EXR_PIXEL_FLOAT,
                                             EXR_PERCEPTUALLY_LINEAR, 1, 1),
                             EXR_ERR_SUCCESS);
        if (sub != NULL)
            assert_int_equal(exr_add_channel(ctxt, part, sub, EXR_PIXEL_HALF,
                                             EXR_PERCEPTUALLY_LINEAR, 2, 2),
                             EXR_ERR_SUCCESS);
    }
    assert_int_equal(exr_write_header(ctxt), EXR_ERR_SUCCESS);
    float plane[3][4];
    uint16_t halves[2] = {0x3c00, 0x3c00}; /* 1.0 */
    for (int c = 0; c < 3; c++)
        for (int x = 0; x < 4; x++)
            plane[c][x] = (float)(3 - c);
    float minus[4] = {3.0f, -1.0f, 3.0f, 3.0f};
    for (int p = 0; p < parts; p++)
        for (int y = 0; y < 4; y++) {
            exr_chunk_info_t ci;
            exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
            assert_int_equal(exr_write_scanline_chunk_info(
                                 ctxt, p, y + (moved ? 20 : 0), &ci),
                             EXR_ERR_SUCCESS);
            assert_int_equal(exr_encoding_initialize(ctxt, p, &ci, &enc),
                             EXR_ERR_SUCCESS);
            for (int i = 0; i < enc.channel_count; i++) {
                exr_coding_channel_info_t *ch = &enc.channels[i];
                int half = ch->data_type == EXR_PIXEL_HALF;
                ch->encode_from_ptr = half ? (const uint8_t *)halves
                                      : moved && y == 2 && i == 2
                                          ? (const uint8_t *)minus
                                          : (const uint8_t *)plane[i];
                ch->user_pixel_stride = half ? 2 : 4;
                ch->user_line_stride = half ? 4 : 16;
                ch->user_bytes_per_element = half ? 2 : 4;
                ch->user_data_type = ch->data_type;
            }
            assert_int_equal(
                exr_encoding_choose_default_routines(ctxt, p, &enc),
                EXR_ERR_SUCCESS);
            assert_int_equal(exr_encoding_run(ctxt, p, &enc), EXR_ERR_SUCCESS);
            exr_encoding_destroy(ctxt, &enc);
        }
    assert_int_equal(exr_finish(&ctxt), EXR_ERR_SUCCESS);
}

/* Files OpenEXRCore 3.1 reads wrongly or crashes on are refused with a
 * message that says why: a subsampled channel (a luminance/chroma file,
 * or any extra channel: reading one crashed the CLI and the daemon, or
 * shifted R, G and B by up to 4.0), and a multi-part file (read as its
 * first part, silently).  The same file with full channels loads. */
static void exr_refused_layouts(void **state)
{
    (void)state;
    char path[512];
    lr_error err;
    core_exr("plain.exr", 1, NULL, 0, path, sizeof path);
    lr__texture *t = lr__texture_load(path, 0, &err);
    if (t == NULL)
        fail_msg("%s", err.message);
    assert_int_equal(t->w, 4);
    for (int c = 0; c < 3; c++)
        assert_true(t->rgba[4 * 5 + c] == (float)(c + 1));
    lr__texture_free(t);
    static const char *const subs[3] = {"A", "X", "RY"};
    for (int i = 0; i < 3; i++) {
        core_exr("sub.exr", 1, subs[i], 0, path, sizeof path);
        assert_null(lr__texture_load(path, 0, &err));
        assert_int_equal(err.status, LR_ERR_INVALID);
        if (strstr(err.message, "is subsampled (2 x 2)") == NULL ||
            strstr(err.message, subs[i]) == NULL)
            fail_msg("%s: %s", subs[i], err.message);
    }
    core_exr("parts.exr", 2, NULL, 0, path, sizeof path);
    assert_null(lr__texture_load(path, 0, &err));
    assert_int_equal(err.status, LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "has 2 parts"));
    /* lensray's own --half --depth output: half R, G, B and a float Z,
     * which it does not read.  OpenEXRCore 3.1 crashed on the mixed
     * types while Z was left out of the decode (the CLI and lensrayd
     * exited on SIGSEGV); it now loads, R, G, B as written. */
    lr_image *img = NULL;
    assert_int_equal(lr_image_create(4, 3, 1, &img, &err), LR_OK);
    float *rgb = lr_image_rgb_mut(img), *z = lr_image_depth_mut(img);
    for (int i = 0; i < 12; i++) {
        for (int c = 0; c < 3; c++)
            rgb[3 * i + c] = 0.25f * (float)(c + 1) + (float)i;
        z[i] = 1.0f + (float)i;
    }
    lr_output_options o;
    lr_output_options_default(&o);
    o.exr_half = 1, o.exr_depth = 1;
    int n = snprintf(path, sizeof path, "%s/halfz.exr", lr_test_tmpdir());
    assert_true(n > 0 && (size_t)n < sizeof path);
    assert_int_equal(lr_image_write(img, path, &o, &err), LR_OK);
    lr_image_free(img);
    t = lr__texture_load(path, 0, &err);
    if (t == NULL)
        fail_msg("%s", err.message);
    for (int i = 0; i < 12; i++)
        for (int c = 0; c < 3; c++)
            assert_true(t->rgba[4 * i + c] ==
                        0.25f * (float)(c + 1) + (float)i);
    lr__texture_free(t);
    /* A bad texel is named in the file's own coordinates, not the data
     * window's (it said (1, 2) for the file's (11, 22)). */
    core_exr("moved.exr", 1, NULL, 1, path, sizeof path);
    assert_null(lr__texture_load(path, 0, &err));
    if (strstr(err.message, "pixel (11, 22) channel R is -1") == NULL)
        fail_msg("%s", err.message);
}

static const struct CMUnitTest tests[] = {
    cmocka_unit_test(srgb_decode_values),  cmocka_unit_test(png_8bit_layouts),
    cmocka_unit_test(png_16bit),           cmocka_unit_test(jpeg_levels),
    cmocka_unit_test(exr_exact),           cmocka_unit_test(bilinear_and_wrap),
    cmocka_unit_test(truncated_files),     cmocka_unit_test(garbage_and_huge),
    cmocka_unit_test(exr_refused_layouts),
};

LR_TEST_GROUP(texture, tests)
