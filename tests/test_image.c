/*
 * test_image.c: the image container, format detection, atomic writes and
 * both encoders.  Encoded files are read back with the libraries' own
 * decoders (libpng's reader, OpenEXRCore's decoding pipeline), and the
 * expected values are computed here from the published formulas rather
 * than by calling the library's helpers, so a shared mistake cannot hide.
 */
#include "test.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <openexr.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- helpers ---------------------------------------------------------- */

/* The sRGB transfer curve of IEC 61966-2-1, written out independently. */
static double ref_srgb(double v)
{
    if (isnan(v) || v <= 0.0)
        return 0.0;
    if (v >= 1.0)
        return 1.0;
    if (v <= 0.0031308)
        return 12.92 * v;
    return 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

static unsigned ref_code(double linear, unsigned max)
{
    return (unsigned)floor(ref_srgb(linear) * max + 0.5);
}

/* An image whose samples cover the interesting ranges: the linear toe of
 * the sRGB curve, mid greys, values above 1 and below 0, and a smooth
 * ramp, all different per channel. */
static lr_image *make_image(int w, int h, int with_depth)
{
    static const float specials[] = {0.0f,  1.0f,  0.5f,   0.18f,
                                     2.0f,  -0.5f, 0.001f, 0.0031308f,
                                     0.01f, 0.75f, 100.0f, 1e-6f};
    const size_t n_specials = sizeof specials / sizeof specials[0];
    lr_image *img = NULL;
    lr_error err;
    assert_int_equal(lr_image_create(w, h, with_depth, &img, &err), LR_OK);
    float *rgb = lr_image_rgb_mut(img);
    size_t n = (size_t)w * (size_t)h * 3;
    for (size_t i = 0; i < n; i++) {
        if (i < n_specials)
            rgb[i] = specials[i];
        else
            rgb[i] = (float)((double)(i * 7919 % 1000) / 997.0 * 1.3 - 0.05);
    }
    if (with_depth) {
        float *z = lr_image_depth_mut(img);
        for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
            z[i] = (i % 5 == 0) ? LR_DEPTH_NONE : 0.25f + (float)i * 0.125f;
    }
    return img;
}

/* ---- PNG reading (libpng's classic API) ------------------------------- */

typedef struct mem_reader {
    const unsigned char *data;
    size_t len, pos;
} mem_reader;

static void png_mem_read(png_structp png, png_bytep out, png_size_t n)
{
    mem_reader *r = png_get_io_ptr(png);
    if (n > r->len - r->pos)
        png_error(png, "read past the end of the PNG");
    memcpy(out, r->data + r->pos, n);
    r->pos += n;
}

typedef struct decoded_png {
    png_uint_32 width, height;
    int bit_depth, color_type;
    int has_srgb, srgb_intent;
    unsigned *samples; /* width * height * 3 code values */
} decoded_png;

/* Decodes without any transform, so 16-bit samples arrive big-endian and
 * no gamma conversion happens.  Returns 0 on success. */
static int decode_png(const void *buf, size_t len, decoded_png *out)
{
    memset(out, 0, sizeof *out);
    mem_reader *rd = calloc(1, sizeof *rd);
    assert_non_null(rd);
    rd->data = buf;
    rd->len = len;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL,
                                             NULL);
    assert_non_null(png);
    png_infop info = png_create_info_struct(png);
    assert_non_null(info);
    /* `row` changes after setjmp and is freed after a longjmp, so it must
     * be volatile. */
    unsigned char *volatile row = NULL;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        free(row);
        free(out->samples);
        out->samples = NULL;
        free(rd);
        return -1;
    }
    png_set_read_fn(png, rd, png_mem_read);
    png_read_info(png, info);
    out->width = png_get_image_width(png, info);
    out->height = png_get_image_height(png, info);
    out->bit_depth = png_get_bit_depth(png, info);
    out->color_type = png_get_color_type(png, info);
    out->has_srgb = png_get_sRGB(png, info, &out->srgb_intent) != 0;
    size_t rowbytes = png_get_rowbytes(png, info);
    row = malloc(rowbytes);
    out->samples = calloc((size_t)out->width * out->height * 3,
                          sizeof *out->samples);
    assert_non_null(row);
    assert_non_null(out->samples);
    for (png_uint_32 y = 0; y < out->height; y++) {
        png_read_row(png, row, NULL);
        for (size_t i = 0; i < (size_t)out->width * 3; i++) {
            unsigned v = out->bit_depth == 16
                             ? ((unsigned)row[2 * i] << 8) | row[2 * i + 1]
                             : row[i];
            out->samples[(size_t)y * out->width * 3 + i] = v;
        }
    }
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    free(row);
    free(rd);
    return 0;
}

/* ---- EXR reading (OpenEXRCore's decoding pipeline) -------------------- */

#define MAX_CH 8

typedef struct decoded_exr {
    int width, height;
    int n_channels;
    char names[MAX_CH][16];         /* in the file's order */
    exr_pixel_type_t types[MAX_CH]; /* as stored in the file */
    float *planes[MAX_CH];          /* width * height floats each */
    exr_compression_t compression;
    int has_chroma;
    exr_attr_chromaticities_t chroma;
    exr_attr_box2i_t data_window, display_window;
    int spp;                    /* samplesPerPixel, -1 if absent */
    char seed[32], camera[512]; /* lensraySeed, lensrayCamera or "" */
} decoded_exr;

static int64_t exr_mem_read(exr_const_context_t ctxt, void *user, void *buffer,
                            uint64_t sz, uint64_t offset,
                            exr_stream_error_func_ptr_t error_cb)
{
    mem_reader *r = user;
    if (offset > r->len) {
        error_cb(ctxt, EXR_ERR_READ_IO, "read past the end of the EXR");
        return -1;
    }
    uint64_t n = r->len - offset < sz ? r->len - offset : sz;
    memcpy(buffer, r->data + offset, (size_t)n);
    return (int64_t)n;
}

static int64_t exr_mem_size(exr_const_context_t ctxt, void *user)
{
    (void)ctxt;
    return (int64_t)((mem_reader *)user)->len;
}

static void free_exr(decoded_exr *d)
{
    for (int c = 0; c < MAX_CH; c++)
        free(d->planes[c]);
    memset(d, 0, sizeof *d);
}

/* Decodes every channel to float (the library widens halves exactly). */
static void decode_exr(const void *buf, size_t len, decoded_exr *out)
{
    memset(out, 0, sizeof *out);
    mem_reader rd = {buf, len, 0};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = &rd;
    init.read_fn = exr_mem_read;
    init.size_fn = exr_mem_size;
    exr_context_t ctxt = NULL;
    assert_int_equal(exr_start_read(&ctxt, "<memory>", &init), EXR_ERR_SUCCESS);

    int parts = 0;
    assert_int_equal(exr_get_count(ctxt, &parts), EXR_ERR_SUCCESS);
    assert_int_equal(parts, 1);
    exr_storage_t storage;
    assert_int_equal(exr_get_storage(ctxt, 0, &storage), EXR_ERR_SUCCESS);
    assert_int_equal(storage, EXR_STORAGE_SCANLINE);
    assert_int_equal(exr_get_compression(ctxt, 0, &out->compression),
                     EXR_ERR_SUCCESS);
    out->has_chroma = exr_attr_get_chromaticities(ctxt, 0, "chromaticities",
                                                  &out->chroma) ==
                      EXR_ERR_SUCCESS;

    exr_attr_box2i_t dw;
    assert_int_equal(exr_get_data_window(ctxt, 0, &dw), EXR_ERR_SUCCESS);
    out->data_window = dw;
    assert_int_equal(exr_get_display_window(ctxt, 0, &out->display_window),
                     EXR_ERR_SUCCESS);
    int32_t spp = -1;
    const char *str = NULL;
    int32_t n = 0;
    out->spp = exr_attr_get_int(ctxt, 0, "samplesPerPixel", &spp) ==
                       EXR_ERR_SUCCESS
                   ? spp
                   : -1;
    if (exr_attr_get_string(ctxt, 0, "lensraySeed", &n, &str) ==
        EXR_ERR_SUCCESS)
        snprintf(out->seed, sizeof out->seed, "%.*s", (int)n, str);
    if (exr_attr_get_string(ctxt, 0, "lensrayCamera", &n, &str) ==
        EXR_ERR_SUCCESS)
        snprintf(out->camera, sizeof out->camera, "%.*s", (int)n, str);
    out->width = dw.max.x - dw.min.x + 1;
    out->height = dw.max.y - dw.min.y + 1;

    const exr_attr_chlist_t *chl = NULL;
    assert_int_equal(exr_get_channels(ctxt, 0, &chl), EXR_ERR_SUCCESS);
    assert_true(chl->num_channels <= MAX_CH);
    out->n_channels = chl->num_channels;
    for (int c = 0; c < chl->num_channels; c++) {
        snprintf(out->names[c], sizeof out->names[c], "%s",
                 chl->entries[c].name.str);
        out->types[c] = chl->entries[c].pixel_type;
        out->planes[c] = calloc((size_t)out->width * (size_t)out->height,
                                sizeof(float));
        assert_non_null(out->planes[c]);
    }

    int32_t spc = 0;
    assert_int_equal(exr_get_scanlines_per_chunk(ctxt, 0, &spc),
                     EXR_ERR_SUCCESS);
    for (int y = dw.min.y; y <= dw.max.y; y += spc) {
        exr_chunk_info_t ci;
        assert_int_equal(exr_read_scanline_chunk_info(ctxt, 0, y, &ci),
                         EXR_ERR_SUCCESS);
        exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
        assert_int_equal(exr_decoding_initialize(ctxt, 0, &ci, &dec),
                         EXR_ERR_SUCCESS);
        for (int i = 0; i < dec.channel_count; i++) {
            exr_coding_channel_info_t *ch = &dec.channels[i];
            int c = 0;
            while (c < out->n_channels &&
                   strcmp(out->names[c], ch->channel_name) != 0)
                c++;
            assert_true(c < out->n_channels);
            size_t first = (size_t)(ci.start_y - dw.min.y) * (size_t)out->width;
            ch->decode_to_ptr = (uint8_t *)(out->planes[c] + first);
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 4;
            ch->user_line_stride = 4 * out->width;
        }
        assert_int_equal(exr_decoding_choose_default_routines(ctxt, 0, &dec),
                         EXR_ERR_SUCCESS);
        assert_int_equal(exr_decoding_run(ctxt, 0, &dec), EXR_ERR_SUCCESS);
        assert_int_equal(exr_decoding_destroy(ctxt, &dec), EXR_ERR_SUCCESS);
    }
    assert_int_equal(exr_finish(&ctxt), EXR_ERR_SUCCESS);
}

static const float *exr_plane(const decoded_exr *d, const char *name)
{
    for (int c = 0; c < d->n_channels; c++)
        if (strcmp(d->names[c], name) == 0)
            return d->planes[c];
    return NULL;
}

static void encode_or_fail(const lr_image *img, lr_format fmt,
                           const lr_output_options *opts, void **buf,
                           size_t *len)
{
    lr_error err;
    memset(&err, 0, sizeof err);
    lr_status st = lr_image_encode(img, fmt, opts, buf, len, &err);
    if (st != LR_OK)
        fail_msg("lr_image_encode: %s", err.message);
    assert_non_null(*buf);
    assert_true(*len > 0);
}

/* ---- the container ---------------------------------------------------- */

static void test_create_rejects_bad_sizes(void **state)
{
    (void)state;
    static const int sizes[][2] = {{0, 5},  {5, 0},  {0, 0},
                                   {-1, 5}, {5, -3}, {INT_MIN, 1}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        lr_image *img = (lr_image *)&img; /* must be reset to NULL */
        lr_error err;
        memset(&err, 0, sizeof err);
        assert_int_equal(
            lr_image_create(sizes[i][0], sizes[i][1], 0, &img, &err),
            LR_ERR_INVALID);
        assert_null(img);
        assert_int_equal(err.status, LR_ERR_INVALID);
        assert_non_null(strstr(err.message, "positive"));
    }

    /* INT_MAX squared times 12 bytes exceeds a 64-bit address space, so
     * this must fail before trying to allocate. */
    lr_image *img = NULL;
    lr_error err;
    assert_int_equal(lr_image_create(INT_MAX, INT_MAX, 1, &img, &err),
                     LR_ERR_LIMIT);
    assert_null(img);
    assert_non_null(strstr(err.message, "too large"));

    assert_int_equal(lr_image_create(1, 1, 0, NULL, NULL), LR_ERR_INVALID);
}

static void test_create_and_access(void **state)
{
    (void)state;
    lr_image *img = NULL;
    assert_int_equal(lr_image_create(4, 3, 1, &img, NULL), LR_OK);
    assert_int_equal(lr_image_width(img), 4);
    assert_int_equal(lr_image_height(img), 3);
    assert_ptr_equal(lr_image_rgb(img), lr_image_rgb_mut(img));
    assert_ptr_equal(lr_image_depth(img), lr_image_depth_mut(img));
    assert_non_null(lr_image_depth(img));
    for (int i = 0; i < 4 * 3 * 3; i++)
        assert_true(lr_image_rgb(img)[i] == 0.0f);
    lr_image_free(img);

    assert_int_equal(lr_image_create(2, 2, 0, &img, NULL), LR_OK);
    assert_null(lr_image_depth(img));
    assert_null(lr_image_depth_mut(img));
    lr_image_free(img);

    lr_image_free(NULL);
    lr_free(NULL);

    lr_output_options o = {7, 7, 7, LR_EXR_PIZ};
    lr_output_options_default(&o);
    assert_int_equal(o.exr_half, 0);
    assert_int_equal(o.exr_depth, 1);
    assert_int_equal(o.png_16bit, 0);
    assert_int_equal(o.exr_compression, LR_EXR_ZIP);
}

static void test_format_from_path(void **state)
{
    (void)state;
    static const struct {
        const char *path;
        lr_format fmt;
    } good[] = {{"a.exr", LR_FORMAT_EXR},     {"A.EXR", LR_FORMAT_EXR},
                {"dir/x.Exr", LR_FORMAT_EXR}, {"x.png", LR_FORMAT_PNG},
                {"X.PNG", LR_FORMAT_PNG},     {"a.b/c.d.pNg", LR_FORMAT_PNG}};
    for (size_t i = 0; i < sizeof good / sizeof good[0]; i++) {
        lr_format f = (lr_format)-1;
        assert_int_equal(lr_format_from_path(good[i].path, &f, NULL), LR_OK);
        assert_int_equal(f, good[i].fmt);
    }

    static const char *const bad[] = {"x.jpg",     "x",    "exr", "x.exr.bak",
                                      "dir.png/x", "x.pn", ""};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        lr_format f;
        lr_error err;
        memset(&err, 0, sizeof err);
        assert_int_equal(lr_format_from_path(bad[i], &f, &err), LR_ERR_INVALID);
        assert_int_equal(err.status, LR_ERR_INVALID);
        char quoted[64];
        snprintf(quoted, sizeof quoted, "'%s'", bad[i]);
        assert_non_null(strstr(err.message, quoted));
        assert_non_null(strstr(err.message, ".exr"));
        assert_non_null(strstr(err.message, ".png"));
    }
}

static void test_srgb_curve(void **state)
{
    (void)state;
    assert_true(lr__srgb_encode(0.0) == 0.0);
    assert_true(lr__srgb_encode(1.0) == 1.0);
    assert_true(lr__srgb_encode(2.0) == 1.0);
    assert_true(lr__srgb_encode(-1.0) == 0.0);
    assert_true(lr__srgb_encode(NAN) == 0.0);
    assert_true(lr__srgb_encode(INFINITY) == 1.0);
    assert_true(lr__srgb_encode(-INFINITY) == 0.0);
    /* Both pieces of the curve meet at the threshold to within 1e-7. */
    assert_float_equal(lr__srgb_encode(0.0031308), 0.04045, 1e-6);
    assert_float_equal(lr__srgb_encode(0.0031309), 0.04045, 1e-5);
    for (int i = 0; i <= 1000; i++) {
        double v = i / 1000.0;
        assert_float_equal(lr__srgb_encode(v), ref_srgb(v), 1e-12);
    }
}

/* ---- PNG --------------------------------------------------------------- */

static void check_png(int sixteen)
{
    const int w = 7, h = 5;
    lr_image *img = make_image(w, h, 1);
    lr_output_options opts;
    lr_output_options_default(&opts);
    opts.png_16bit = sixteen;
    void *buf = NULL;
    size_t len = 0;
    encode_or_fail(img, LR_FORMAT_PNG, &opts, &buf, &len);

    decoded_png d;
    assert_int_equal(decode_png(buf, len, &d), 0);
    assert_int_equal(d.width, w);
    assert_int_equal(d.height, h);
    assert_int_equal(d.bit_depth, sixteen ? 16 : 8);
    assert_int_equal(d.color_type, PNG_COLOR_TYPE_RGB);
    assert_true(d.has_srgb);
    assert_int_equal(d.srgb_intent, PNG_sRGB_INTENT_PERCEPTUAL);

    const unsigned max = sixteen ? 65535u : 255u;
    const float *rgb = lr_image_rgb(img);
    for (size_t i = 0; i < (size_t)w * h * 3; i++)
        assert_int_equal(d.samples[i], ref_code(rgb[i], max));

    /* Spot checks against hand-computed code values for the first
     * samples of make_image: 0, 1, 0.5, 0.18, 2 (clamped), -0.5
     * (clamped), 0.001 (linear toe: 12.92 * 0.001 * 255 = 3.29). */
    if (!sixteen) {
        static const unsigned want[] = {0, 255, 188, 118, 255, 0, 3};
        for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
            assert_int_equal(d.samples[i], want[i]);
    } else {
        assert_int_equal(d.samples[0], 0);
        assert_int_equal(d.samples[1], 65535);
        /* 1.055 * 0.5^(1/2.4) - 0.055 = 0.735357, * 65535 = 48191.6. */
        assert_int_equal(d.samples[2], 48192);
    }

    free(d.samples);
    lr_free(buf);
    lr_image_free(img);
}

static void test_png_8bit(void **state)
{
    (void)state;
    check_png(0);
}

static void test_png_16bit(void **state)
{
    (void)state;
    check_png(1);
}

static void test_png_nonfinite(void **state)
{
    (void)state;
    lr_image *img = NULL;
    assert_int_equal(lr_image_create(2, 1, 0, &img, NULL), LR_OK);
    float *rgb = lr_image_rgb_mut(img);
    rgb[0] = NAN;
    rgb[1] = INFINITY;
    rgb[2] = -INFINITY;
    rgb[3] = -NAN;
    rgb[4] = 0.5f;
    rgb[5] = NAN;
    void *buf = NULL;
    size_t len = 0;
    encode_or_fail(img, LR_FORMAT_PNG, NULL, &buf, &len);
    decoded_png d;
    assert_int_equal(decode_png(buf, len, &d), 0);
    /* NaN is black; infinities clamp like any out-of-range value. */
    static const unsigned want[] = {0, 255, 0, 0, 188, 0};
    for (int i = 0; i < 6; i++)
        assert_int_equal(d.samples[i], want[i]);
    free(d.samples);
    lr_free(buf);
    lr_image_free(img);
}

/* ---- EXR --------------------------------------------------------------- */

/* The decoded R, G, B and Z planes are the image's floats, bit for bit. */
static void assert_exr_is_image(const decoded_exr *d, const lr_image *img)
{
    const int w = lr_image_width(img), h = lr_image_height(img);
    const float *rgb = lr_image_rgb(img);
    const float *z = lr_image_depth(img);
    const float *R = exr_plane(d, "R"), *G = exr_plane(d, "G"),
                *B = exr_plane(d, "B"), *Z = exr_plane(d, "Z");
    for (size_t i = 0; i < (size_t)w * h; i++) {
        assert_memory_equal(&R[i], &rgb[3 * i + 0], sizeof(float));
        assert_memory_equal(&G[i], &rgb[3 * i + 1], sizeof(float));
        assert_memory_equal(&B[i], &rgb[3 * i + 2], sizeof(float));
        assert_memory_equal(&Z[i], &z[i], sizeof(float));
    }
}

static void test_exr_float(void **state)
{
    (void)state;
    /* 23 rows make one full 16-line ZIP chunk and one partial chunk. */
    const int w = 37, h = 23;
    lr_image *img = make_image(w, h, 1);
    lr_output_options opts;
    lr_output_options_default(&opts);
    void *buf = NULL;
    size_t len = 0;
    encode_or_fail(img, LR_FORMAT_EXR, &opts, &buf, &len);

    decoded_exr d;
    decode_exr(buf, len, &d);
    assert_int_equal(d.width, w);
    assert_int_equal(d.height, h);
    assert_int_equal(d.compression, EXR_COMPRESSION_ZIP);
    /* OpenEXR keeps channels sorted by name. */
    assert_int_equal(d.n_channels, 4);
    static const char *const names[] = {"B", "G", "R", "Z"};
    for (int c = 0; c < 4; c++) {
        assert_string_equal(d.names[c], names[c]);
        assert_int_equal(d.types[c], EXR_PIXEL_FLOAT);
    }
    assert_true(d.has_chroma);
    assert_float_equal(d.chroma.red_x, 0.64, 1e-6);
    assert_float_equal(d.chroma.white_y, 0.329, 1e-6);

    assert_exr_is_image(&d, img);
    free_exr(&d);
    lr_free(buf);
    lr_image_free(img);
}

/* Every lossless compression the output offers (output.compression)
 * writes that compression in the header and decodes to the same floats:
 * a 37 x 41 image with depth, 3 ZIP chunks and one partial. */
static void test_exr_compressions(void **state)
{
    (void)state;
    const int w = 37, h = 41;
    lr_image *img = make_image(w, h, 1);
    static const struct {
        lr_exr_compression ours;
        exr_compression_t file;
    } kinds[] = {{LR_EXR_ZIP, EXR_COMPRESSION_ZIP},
                 {LR_EXR_NONE, EXR_COMPRESSION_NONE},
                 {LR_EXR_ZIPS, EXR_COMPRESSION_ZIPS},
                 {LR_EXR_RLE, EXR_COMPRESSION_RLE},
                 {LR_EXR_PIZ, EXR_COMPRESSION_PIZ}};
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        lr_output_options opts;
        lr_output_options_default(&opts);
        opts.exr_compression = kinds[k].ours;
        void *buf = NULL;
        size_t len = 0;
        encode_or_fail(img, LR_FORMAT_EXR, &opts, &buf, &len);
        decoded_exr d;
        decode_exr(buf, len, &d);
        assert_int_equal(d.compression, kinds[k].file);
        assert_exr_is_image(&d, img);
        if (kinds[k].ours == LR_EXR_NONE)
            assert_true(len > (size_t)w * h * 16);
        free_exr(&d);
        lr_free(buf);
    }
    lr_image_free(img);
}

/* A chunk that deflate cannot shrink is stored raw, as OpenEXR expects
 * (exr_zip.h): floats of random bits (any exponent but Inf/NaN's) give
 * such chunks, and ZIP and ZIPS files of them still decode to the same
 * floats through OpenEXRCore's own reader, beside a ZIP chunk that does
 * shrink (the last rows are zeros). */
static void test_exr_zip_incompressible(void **state)
{
    (void)state;
    const int w = 29, h = 40;
    lr_image *img = NULL;
    lr_error err;
    assert_int_equal(lr_image_create(w, h, 1, &img, &err), LR_OK);
    float *rgb = lr_image_rgb_mut(img), *z = lr_image_depth_mut(img);
    uint64_t x = 0x9e3779b97f4a7c15ull;
    for (size_t i = 0; i < (size_t)w * h * 4; i++) {
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        uint32_t bits = (uint32_t)(x >> 32);
        uint32_t e = 1 + (uint32_t)((x >> 8) % 254);
        bits = (bits & 0x807fffffu) | (e << 23);
        float v;
        memcpy(&v, &bits, sizeof v);
        if (i >= (size_t)w * 32 * 4)
            v = 0.0f;
        if (i < (size_t)w * h * 3)
            rgb[i] = v;
        else
            z[i - (size_t)w * h * 3] = v;
    }
    static const lr_exr_compression kinds[] = {LR_EXR_ZIP, LR_EXR_ZIPS};
    for (size_t k = 0; k < 2; k++) {
        lr_output_options opts;
        lr_output_options_default(&opts);
        opts.exr_compression = kinds[k];
        void *buf = NULL;
        size_t len = 0;
        encode_or_fail(img, LR_FORMAT_EXR, &opts, &buf, &len);
        decoded_exr d;
        decode_exr(buf, len, &d);
        assert_exr_is_image(&d, img);
        /* Nearly raw: the random rows cannot be made smaller. */
        assert_true(len > (size_t)w * 32 * 16);
        free_exr(&d);
        lr_free(buf);
    }
    lr_image_free(img);
}

/* The image encoded as EXR on one thread, after checking that each of
 * the n thread counts gives the same bytes; the caller frees it. */
static void *exr_same_on_threads(const lr_image *img,
                                 const lr_output_options *opts,
                                 const int *counts, size_t n, size_t *len)
{
    void *one = NULL;
    lr__exr_threads = 1;
    encode_or_fail(img, LR_FORMAT_EXR, opts, &one, len);
    for (size_t k = 0; k < n; k++) {
        lr__exr_threads = counts[k];
        void *buf = NULL;
        size_t blen = 0;
        encode_or_fail(img, LR_FORMAT_EXR, opts, &buf, &blen);
        assert_int_equal(blen, *len);
        assert_memory_equal(buf, one, blen);
        lr_free(buf);
    }
    lr__exr_threads = 0;
    return one;
}

/* The chunks are compressed on several threads and written in order
 * (exr_chunks.c): every thread count writes the same bytes, and they
 * decode to the image.  A crop placed at row 7 of its frame (chunks named
 * by their rows in the frame), 533 rows (34 chunks, the last partial),
 * with depth, in float and in half. */
static void test_exr_threads_same_bytes(void **state)
{
    (void)state;
    const int w = 61, h = 533;
    lr_image *img = make_image(w, h, 1);
    lr_camera cam;
    lr_camera_default(&cam);
    lr_render_settings rs;
    lr_render_settings_default(&rs);
    lr_error err;
    assert_int_equal(lr_image_set_frame(img, 80, 600, 5, 7, &cam, &rs, &err),
                     LR_OK);
    for (int half = 0; half <= 1; half++) {
        lr_output_options opts;
        lr_output_options_default(&opts);
        opts.exr_half = half;
        static const int counts[] = {2, 3, 8, 40};
        size_t one_len = 0;
        void *one = exr_same_on_threads(
            img, &opts, counts, sizeof counts / sizeof counts[0], &one_len);
        decoded_exr d;
        decode_exr(one, one_len, &d);
        assert_int_equal(d.data_window.min.y, 7);
        assert_int_equal(d.data_window.max.y, 7 + h - 1);
        const float *rgb = lr_image_rgb(img);
        const float *z = lr_image_depth(img);
        const float *R = exr_plane(&d, "R"), *Z = exr_plane(&d, "Z");
        for (size_t i = 0; i < (size_t)w * h; i++) {
            if (!half)
                assert_memory_equal(&R[i], &rgb[3 * i], sizeof(float));
            else
                assert_true(fabsf(R[i] - rgb[3 * i]) <=
                            fabsf(rgb[3 * i]) * 1e-3f + 1e-7f);
            assert_memory_equal(&Z[i], &z[i], sizeof(float));
        }
        free_exr(&d);
        lr_free(one);
    }
    lr_image_free(img);
}

/* A crop (lr_image_set_frame) is written where it sits: its data window
 * at its place inside a display window of the whole frame, as OpenEXR
 * defines the two windows, with how it was rendered; its pixels are the
 * image's.  A frame of its own keeps the two windows equal and has none
 * of the attributes.  A crop that does not fit its frame is refused. */
static void test_exr_crop_window(void **state)
{
    (void)state;
    const int w = 9, h = 20;
    lr_image *img = make_image(w, h, 0);
    lr_camera cam;
    lr_camera_default(&cam);
    lr_render_settings rs;
    lr_render_settings_default(&rs);
    rs.spp = 37;
    rs.seed = 18446744073709551615ull;
    lr_error err;
    assert_int_equal(lr_image_set_frame(img, 100, 50, 91, 31, &cam, &rs, &err),
                     LR_ERR_INVALID);
    assert_non_null(strstr(err.message, "does not fit"));
    lr_output_options opts;
    lr_output_options_default(&opts);
    void *buf = NULL;
    size_t len = 0;
    encode_or_fail(img, LR_FORMAT_EXR, &opts, &buf, &len);
    decoded_exr d;
    decode_exr(buf, len, &d);
    assert_int_equal(d.data_window.min.x, 0);
    assert_int_equal(d.display_window.max.x, w - 1);
    assert_int_equal(d.display_window.max.y, h - 1);
    assert_int_equal(d.spp, -1);
    assert_string_equal(d.camera, "");
    free_exr(&d);
    lr_free(buf);

    assert_int_equal(lr_image_set_frame(img, 100, 50, 91, 30, &cam, &rs, &err),
                     LR_OK);
    encode_or_fail(img, LR_FORMAT_EXR, &opts, &buf, &len);
    decode_exr(buf, len, &d);
    assert_int_equal(d.width, w);
    assert_int_equal(d.height, h);
    assert_int_equal(d.data_window.min.x, 91);
    assert_int_equal(d.data_window.min.y, 30);
    assert_int_equal(d.data_window.max.x, 99);
    assert_int_equal(d.data_window.max.y, 49);
    assert_int_equal(d.display_window.min.x, 0);
    assert_int_equal(d.display_window.min.y, 0);
    assert_int_equal(d.display_window.max.x, 99);
    assert_int_equal(d.display_window.max.y, 49);
    assert_int_equal(d.spp, 37);
    assert_string_equal(d.seed, "18446744073709551615");
    char *cam_json = lr_camera_json(&cam);
    assert_string_equal(d.camera, cam_json);
    lr_free(cam_json);
    const float *rgb = lr_image_rgb(img), *G = exr_plane(&d, "G");
    for (size_t i = 0; i < (size_t)w * h; i++)
        assert_memory_equal(&G[i], &rgb[3 * i + 1], sizeof(float));
    free_exr(&d);
    lr_free(buf);
    lr_image_free(img);
}

/* The largest error round-to-nearest allows for a half: half a unit in
 * the last place, 2^-11 relative for normals and 2^-25 absolute for
 * subnormals. */
static int within_half_precision(float got, float want)
{
    double tol = fmax(fabs((double)want) * ldexp(1.0, -11), ldexp(1.0, -25));
    return fabs((double)got - (double)want) <= tol;
}

static void test_exr_half(void **state)
{
    (void)state;
    const int w = 19, h = 17;
    lr_image *img = make_image(w, h, 1);

    /* Exact cases, in the first pixels: ties to even, clamping instead of
     * infinity, and the subnormal range. */
    static const float in[][2] = {
        {1.0f + 0x1p-11f, 1.0f},                       /* tie, to even */
        {1.0f + 3 * 0x1p-11f, 1.0f + 0x1p-9f},         /* tie, up to even */
        {1.0f + 0x1p-11f + 0x1p-20f, 1.0f + 0x1p-10f}, /* above tie */
        {65504.0f, 65504.0f},
        {65519.0f, 65504.0f}, /* rounds down */
        {65520.0f, 65504.0f}, /* would be Inf */
        {1e6f, 65504.0f},
        {-1e30f, -65504.0f},
        {0x1p-14f, 0x1p-14f},            /* smallest normal */
        {0x1p-24f, 0x1p-24f},            /* smallest subnormal */
        {3 * 0x1p-25f, 0x1p-23f},        /* tie, to even */
        {5 * 0x1p-25f, 0x1p-23f},        /* tie, to even */
        {0x1p-25f, 0.0f},                /* tie, to zero */
        {0x1p-25f + 0x1p-35f, 0x1p-24f}, /* above tie */
        {1e-10f, 0.0f},
        {-0x1p-24f, -0x1p-24f},
        {0x1.ffcp-15f, 0x1p-14f}, /* rounds up into the normals */
        {0.1f, 0.0999755859375f},
    };
    const size_t n_in = sizeof in / sizeof in[0];
    float *rgb = lr_image_rgb_mut(img);
    for (size_t i = 0; i < n_in; i++)
        rgb[i] = in[i][0];

    lr_output_options opts;
    lr_output_options_default(&opts);
    opts.exr_half = 1;
    void *buf = NULL;
    size_t len = 0;
    encode_or_fail(img, LR_FORMAT_EXR, &opts, &buf, &len);

    decoded_exr d;
    decode_exr(buf, len, &d);
    assert_int_equal(d.width, w);
    assert_int_equal(d.height, h);
    assert_int_equal(d.n_channels, 4);
    static const char *const names[] = {"B", "G", "R", "Z"};
    for (int c = 0; c < 4; c++)
        assert_string_equal(d.names[c], names[c]);
    assert_int_equal(d.types[0], EXR_PIXEL_HALF);
    assert_int_equal(d.types[1], EXR_PIXEL_HALF);
    assert_int_equal(d.types[2], EXR_PIXEL_HALF);
    assert_int_equal(d.types[3], EXR_PIXEL_FLOAT); /* Z stays float32 */

    const float *planes[3] = {exr_plane(&d, "R"), exr_plane(&d, "G"),
                              exr_plane(&d, "B")};
    for (size_t i = 0; i < n_in; i++) {
        float got = planes[i % 3][i / 3];
        if (got != in[i][1])
            fail_msg("half of %a: got %a, want %a", (double)in[i][0],
                     (double)got, (double)in[i][1]);
    }
    for (size_t i = n_in; i < (size_t)w * h * 3; i++) {
        float got = planes[i % 3][i / 3];
        if (!within_half_precision(got, rgb[i]))
            fail_msg("half of %a: got %a", (double)rgb[i], (double)got);
    }
    const float *z = lr_image_depth(img), *Z = exr_plane(&d, "Z");
    for (size_t i = 0; i < (size_t)w * h; i++)
        assert_memory_equal(&Z[i], &z[i], sizeof(float));

    free_exr(&d);
    lr_free(buf);
    lr_image_free(img);
}

static void expect_exr_channels(const lr_image *img,
                                const lr_output_options *opts, int want_z)
{
    void *buf = NULL;
    size_t len = 0;
    encode_or_fail(img, LR_FORMAT_EXR, opts, &buf, &len);
    decoded_exr d;
    decode_exr(buf, len, &d);
    assert_int_equal(d.n_channels, want_z ? 4 : 3);
    assert_non_null(exr_plane(&d, "R"));
    assert_non_null(exr_plane(&d, "G"));
    assert_non_null(exr_plane(&d, "B"));
    if (want_z)
        assert_non_null(exr_plane(&d, "Z"));
    else
        assert_null(exr_plane(&d, "Z"));
    for (int c = 0; c < 3; c++)
        assert_int_equal(d.types[c], opts && opts->exr_half ? EXR_PIXEL_HALF
                                                            : EXR_PIXEL_FLOAT);
    free_exr(&d);
    lr_free(buf);
}

static void test_exr_depth_option(void **state)
{
    (void)state;
    lr_image *with_z = make_image(3, 2, 1);
    lr_image *no_z = make_image(3, 2, 0);
    lr_output_options opts;

    /* NULL options are the defaults: float RGB plus Z when there is one. */
    expect_exr_channels(with_z, NULL, 1);
    expect_exr_channels(no_z, NULL, 0);

    lr_output_options_default(&opts);
    opts.exr_depth = 0;
    expect_exr_channels(with_z, &opts, 0);
    opts.exr_half = 1;
    expect_exr_channels(with_z, &opts, 0);
    opts.exr_depth = 1;
    expect_exr_channels(no_z, &opts, 0);
    expect_exr_channels(with_z, &opts, 1);

    lr_image_free(with_z);
    lr_image_free(no_z);
}

static void test_exr_nonfinite(void **state)
{
    (void)state;
    const int w = 3, h = 2;
    lr_image *img = make_image(w, h, 1);
    float *rgb = lr_image_rgb_mut(img);
    float *z = lr_image_depth_mut(img);
    rgb[0] = NAN;
    rgb[1] = INFINITY;
    rgb[2] = -INFINITY;
    rgb[4] = -NAN;
    z[0] = NAN;
    z[1] = INFINITY;
    z[2] = -INFINITY;

    for (int half = 0; half <= 1; half++) {
        lr_output_options opts;
        lr_output_options_default(&opts);
        opts.exr_half = half;
        void *buf = NULL;
        size_t len = 0;
        encode_or_fail(img, LR_FORMAT_EXR, &opts, &buf, &len);
        decoded_exr d;
        decode_exr(buf, len, &d);
        for (int c = 0; c < d.n_channels; c++)
            for (int i = 0; i < w * h; i++)
                assert_true(isfinite(d.planes[c][i]));
        /* The encoder writes 0 for non-finite colour and LR_DEPTH_NONE
         * for non-finite depth. */
        const float *R = exr_plane(&d, "R"), *G = exr_plane(&d, "G"),
                    *B = exr_plane(&d, "B"), *Z = exr_plane(&d, "Z");
        assert_true(R[0] == 0.0f && G[0] == 0.0f && B[0] == 0.0f);
        assert_true(G[1] == 0.0f);
        assert_true(Z[0] == LR_DEPTH_NONE && Z[1] == LR_DEPTH_NONE &&
                    Z[2] == LR_DEPTH_NONE);
        assert_true(Z[3] == z[3]);
        free_exr(&d);
        lr_free(buf);
    }
    lr_image_free(img);
}

/* Chunks wide enough that a batch holds one a thread (exr_chunks.c's
 * BATCH_BYTES), finite ones read straight from the image and one with a
 * NaN and an infinite depth staged: the same bytes on 1, 2 and 3
 * threads, every finite sample exact, the bad ones replaced. */
static void test_exr_wide_mixed_chunks(void **state)
{
    (void)state;
    const int w = 5000, h = 100; /* 1.28 MB a ZIP chunk before deflate */
    lr_image *img = make_image(w, h, 1);
    float *rgb = lr_image_rgb_mut(img);
    float *z = lr_image_depth_mut(img);
    const size_t bad = (size_t)(3 * 16 + 5) * w + 17; /* in chunk 3 */
    rgb[3 * bad + 1] = NAN;
    z[bad + 1] = INFINITY;
    lr_output_options opts;
    lr_output_options_default(&opts);
    static const int counts[] = {2, 3};
    size_t one_len = 0;
    void *one = exr_same_on_threads(img, &opts, counts, 2, &one_len);
    decoded_exr d;
    decode_exr(one, one_len, &d);
    const float *G = exr_plane(&d, "G"), *Z = exr_plane(&d, "Z");
    assert_true(G[bad] == 0.0f && Z[bad + 1] == LR_DEPTH_NONE);
    rgb[3 * bad + 1] = 0.0f;
    z[bad + 1] = LR_DEPTH_NONE;
    assert_exr_is_image(&d, img);
    free_exr(&d);
    lr_free(one);
    lr_image_free(img);
}

static void test_encode_bad_arguments(void **state)
{
    (void)state;
    lr_image *img = make_image(2, 2, 0);
    void *buf = (void *)&buf;
    size_t len = 99;
    lr_error err;
    assert_int_equal(
        lr_image_encode(NULL, LR_FORMAT_PNG, NULL, &buf, &len, &err),
        LR_ERR_INVALID);
    assert_null(buf);
    assert_int_equal(len, 0);
    assert_int_equal(
        lr_image_encode(img, (lr_format)42, NULL, &buf, &len, &err),
        LR_ERR_INVALID);
    assert_null(buf);
    assert_int_equal(
        lr_image_encode(img, LR_FORMAT_PNG, NULL, NULL, &len, &err),
        LR_ERR_INVALID);
    /* An unknown EXR compression is refused (it was written as ZIP). */
    lr_output_options o;
    lr_output_options_default(&o);
    o.exr_compression = (lr_exr_compression)99;
    assert_int_equal(lr_image_encode(img, LR_FORMAT_EXR, &o, &buf, &len, &err),
                     LR_ERR_INVALID);
    assert_null(buf);
    assert_non_null(strstr(err.message, "exr_compression"));
    lr_image_free(img);
}

/* ---- writing files ---------------------------------------------------- */

/* A fresh directory under the run's scratch directory. */
static void scratch_dir(const char *name, char *out, size_t cap)
{
    snprintf(out, cap, "%s/%s", lr_test_tmpdir(), name);
    assert_int_equal(mkdir(out, 0777), 0);
}

static int compare_names(const void *a, const void *b)
{
    return strcmp(a, b);
}

/* The names in `dir`, sorted and joined with spaces, for comparisons. */
static void list_dir(const char *dir, char *out, size_t cap)
{
    char names[16][NAME_MAX + 1];
    int n = 0;
    DIR *d = opendir(dir);
    assert_non_null(d);
    for (struct dirent *e = readdir(d); e != NULL; e = readdir(d)) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        assert_true(n < 16);
        snprintf(names[n++], sizeof names[0], "%s", e->d_name);
    }
    closedir(d);
    qsort(names, (size_t)n, sizeof names[0], compare_names);
    out[0] = '\0';
    size_t used = 0;
    for (int i = 0; i < n; i++) {
        int k = snprintf(out + used, cap - used, "%s%s", i ? " " : "",
                         names[i]);
        assert_true(k >= 0 && (size_t)k < cap - used);
        used += (size_t)k;
    }
}

static void *read_whole_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fseek(f, 0, SEEK_END), 0);
    long n = ftell(f);
    assert_true(n >= 0);
    assert_int_equal(fseek(f, 0, SEEK_SET), 0);
    void *data = malloc((size_t)n + 1);
    assert_non_null(data);
    assert_int_equal(fread(data, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *len = (size_t)n;
    return data;
}

static void test_write_files(void **state)
{
    (void)state;
    char dir[512], path[600], listing[1024];
    scratch_dir("write-ok", dir, sizeof dir);
    lr_image *img = make_image(5, 4, 1);

    static const char *const files[] = {"out.png", "out.EXR"};
    static const lr_format fmts[] = {LR_FORMAT_PNG, LR_FORMAT_EXR};
    for (int k = 0; k < 2; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[k]);
        /* The second round replaces the file written by the first. */
        for (int round = 0; round < 2; round++) {
            lr_error err;
            memset(&err, 0, sizeof err);
            if (lr_image_write(img, path, NULL, &err) != LR_OK)
                fail_msg("lr_image_write: %s", err.message);
        }
        void *want = NULL;
        size_t want_len = 0;
        encode_or_fail(img, fmts[k], NULL, &want, &want_len);
        size_t got_len = 0;
        void *got = read_whole_file(path, &got_len);
        assert_int_equal(got_len, want_len);
        assert_memory_equal(got, want, want_len);
        free(got);
        lr_free(want);
    }
    /* Nothing but the two images: no temporary file was left behind. */
    list_dir(dir, listing, sizeof listing);
    assert_string_equal(listing, "out.EXR out.png");

    /* The file gets the permissions the umask allows, like fopen's. */
    mode_t mask = umask(022);
    umask(mask);
    struct stat st;
    snprintf(path, sizeof path, "%s/out.png", dir);
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0666 & ~mask);

    lr_image_free(img);
}

static void test_write_failures(void **state)
{
    (void)state;
    char dir[512], path[600], listing[1024];
    scratch_dir("write-fail", dir, sizeof dir);
    lr_image *img = make_image(3, 3, 0);
    lr_error err;

    /* A missing directory: nothing can be created. */
    snprintf(path, sizeof path, "%s/no-such-dir/x.png", dir);
    memset(&err, 0, sizeof err);
    assert_int_equal(lr_image_write(img, path, NULL, &err), LR_ERR_IO);
    assert_int_equal(err.status, LR_ERR_IO);
    assert_non_null(strstr(err.message, path));
    assert_non_null(strstr(err.message, strerror(ENOENT)));
    assert_int_equal(access(path, F_OK), -1);

    /* The target is a directory: the temporary file is written, the
     * rename fails, and the temporary file must be removed again. */
    snprintf(path, sizeof path, "%s/taken.exr", dir);
    assert_int_equal(mkdir(path, 0777), 0);
    memset(&err, 0, sizeof err);
    assert_int_equal(lr_image_write(img, path, NULL, &err), LR_ERR_IO);
    assert_non_null(strstr(err.message, path));
    list_dir(dir, listing, sizeof listing);
    assert_string_equal(listing, "taken.exr");

    /* An unknown extension is an argument error, and writes nothing. */
    snprintf(path, sizeof path, "%s/x.tiff", dir);
    memset(&err, 0, sizeof err);
    assert_int_equal(lr_image_write(img, path, NULL, &err), LR_ERR_INVALID);
    assert_non_null(strstr(err.message, path));
    list_dir(dir, listing, sizeof listing);
    assert_string_equal(listing, "taken.exr");

    lr_image_free(img);
}

/* lr_image_write_cancellable: a raised flag stops the write with
 * LR_ERR_CANCELLED, the file there before untouched and no temporary
 * file left, for both formats; a flag at 0 writes.  (Ctrl-C while the
 * CLI wrote had replaced the file and exited 130, "no file is written".)
 * And lr_image_write_check refuses a name too long for the rename, which
 * the short temporary name had let through. */
static void test_write_cancelled(void **state)
{
    (void)state;
    char dir[512], path[600], listing[1024];
    scratch_dir("write-cancel", dir, sizeof dir);
    lr_image *img = make_image(40, 30, 0);
    lr_error err;
    const char *names[2] = {"a.exr", "a.png"};
    for (int k = 0; k < 2; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, names[k]);
        FILE *f = fopen(path, "w");
        assert_non_null(f);
        fputs("before", f);
        fclose(f);
        volatile int flag = 1;
        memset(&err, 0, sizeof err);
        assert_int_equal(
            lr_image_write_cancellable(img, path, NULL, &flag, &err),
            LR_ERR_CANCELLED);
        assert_non_null(strstr(err.message, path));
        char buf[16] = {0};
        f = fopen(path, "r");
        assert_non_null(f);
        assert_int_equal(fread(buf, 1, sizeof buf - 1, f), 6);
        fclose(f);
        assert_string_equal(buf, "before");
        flag = 0;
        assert_int_equal(
            lr_image_write_cancellable(img, path, NULL, &flag, &err), LR_OK);
        struct stat sb;
        assert_int_equal(stat(path, &sb), 0);
        assert_true(sb.st_size > 6);
    }
    list_dir(dir, listing, sizeof listing);
    assert_string_equal(listing, "a.exr a.png");

    char name[300];
    memset(name, 'x', 260);
    memcpy(name + 260, ".png", 5);
    snprintf(path, sizeof path, "%s/%s", dir, name);
    memset(&err, 0, sizeof err);
    assert_int_equal(lr_image_write_check(path, &err), LR_ERR_IO);
    assert_non_null(strstr(err.message, strerror(ENAMETOOLONG)));
    list_dir(dir, listing, sizeof listing);
    assert_string_equal(listing, "a.exr a.png");
    lr_image_free(img);
}

/* A path that is a symbolic link is written through, as open(2) would:
 * the link stays and its target gets the file, through a chain of links,
 * a relative target (from the link's directory) and a target that does
 * not exist yet.  The rename into place replaced the link with a plain
 * file (an independent check). */
static void test_write_through_links(void **state)
{
    (void)state;
    char dir[512], a[600], b[600], c[600], t[600];
    scratch_dir("write-links", dir, sizeof dir);
    snprintf(t, sizeof t, "%s/sub", dir);
    assert_int_equal(mkdir(t, 0777), 0);
    snprintf(a, sizeof a, "%s/a.png", dir);
    snprintf(b, sizeof b, "%s/b.png", dir);
    snprintf(c, sizeof c, "%s/sub/c.png", dir);
    assert_int_equal(symlink("b.png", a), 0);     /* a -> b (relative) */
    assert_int_equal(symlink("sub/c.png", b), 0); /* b -> sub/c, absent */
    lr_image *img = make_image(3, 3, 0);
    lr_error err;
    assert_int_equal(lr_image_write(img, a, NULL, &err), LR_OK);
    struct stat st;
    assert_int_equal(lstat(a, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_int_equal(lstat(b, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_int_equal(lstat(c, &st), 0);
    assert_true(S_ISREG(st.st_mode) && st.st_size > 0);
    /* Written again, the same: the link is not replaced. */
    assert_int_equal(lr_image_write(img, a, NULL, &err), LR_OK);
    assert_int_equal(lstat(a, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    lr_image_free(img);
}

static const struct CMUnitTest image_tests[] = {
    cmocka_unit_test(test_write_through_links),
    cmocka_unit_test(test_create_rejects_bad_sizes),
    cmocka_unit_test(test_create_and_access),
    cmocka_unit_test(test_format_from_path),
    cmocka_unit_test(test_srgb_curve),
    cmocka_unit_test(test_png_8bit),
    cmocka_unit_test(test_png_16bit),
    cmocka_unit_test(test_png_nonfinite),
    cmocka_unit_test(test_exr_float),
    cmocka_unit_test(test_exr_crop_window),
    cmocka_unit_test(test_exr_threads_same_bytes),
    cmocka_unit_test(test_exr_zip_incompressible),
    cmocka_unit_test(test_exr_compressions),
    cmocka_unit_test(test_exr_half),
    cmocka_unit_test(test_exr_depth_option),
    cmocka_unit_test(test_exr_nonfinite),
    cmocka_unit_test(test_exr_wide_mixed_chunks),
    cmocka_unit_test(test_encode_bad_arguments),
    cmocka_unit_test(test_write_files),
    cmocka_unit_test(test_write_failures),
    cmocka_unit_test(test_write_cancelled),
};

LR_TEST_GROUP(image, image_tests)
