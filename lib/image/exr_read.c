/*
 * exr_read.c: OpenEXR images from memory through OpenEXRCore
 * (exr_read.h).  The bytes are handed to the library through its custom
 * read and size callbacks, so a file and an embedded image take the same
 * path.
 */
#include "image/exr_read.h"
#include "json/json_util.h"

#include <openexr.h>
#include <stdlib.h>
#include <string.h>

typedef struct mem_stream {
    const unsigned char *data;
    size_t n;
} mem_stream;

static int64_t mem_read(exr_const_context_t ctxt, void *user, void *buffer,
                        uint64_t sz, uint64_t offset,
                        exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt, (void)error_cb;
    const mem_stream *m = user;
    if (offset >= m->n)
        return 0;
    uint64_t k = m->n - offset < sz ? m->n - offset : sz;
    memcpy(buffer, m->data + offset, (size_t)k);
    return (int64_t)k;
}

static int64_t mem_size(exr_const_context_t ctxt, void *user)
{
    (void)ctxt;
    return (int64_t)((const mem_stream *)user)->n;
}

/* OpenEXR prints its errors to stderr unless told otherwise; ours go in
 * the lr_error. */
static void quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt, (void)code, (void)msg;
}

int lr__exr_magic(const void *data, size_t n)
{
    return n >= 4 && memcmp(data, "\x76\x2f\x31\x01", 4) == 0;
}

void lr__exr_planes_free(lr__exr_planes *p)
{
    if (p == NULL)
        return;
    for (int c = 0; c < LR__EXR_NCH; c++) {
        free(p->plane[c]);
        p->plane[c] = NULL;
    }
}

static const char *const names[LR__EXR_NCH] = {"R", "G", "B", "A", "Y"};

static int channel_index(const char *name)
{
    for (int k = 0; k < LR__EXR_NCH; k++)
        if (strcmp(name, names[k]) == 0)
            return k;
    return -1;
}

/* The layouts OpenEXRCore 3.1 cannot read, or reads wrongly, refused
 * with a message that says why and how to save the file instead. */
static lr_status layout_refused(exr_context_t ctxt,
                                const exr_attr_chlist_t *chl, const char *shown,
                                const char *blame, lr_error *err)
{
    /* OpenEXRCore 3.1 (Debian 12) reads every compression but the DWA
     * ones, whose decoders exist only in the C++ library; say so rather
     * than fail on the first chunk. */
    exr_compression_t comp = EXR_COMPRESSION_NONE;
    if (exr_get_compression(ctxt, 0, &comp) == EXR_ERR_SUCCESS &&
        (comp == EXR_COMPRESSION_DWAA || comp == EXR_COMPRESSION_DWAB)) {
        return lr__fail(err, LR_ERR_INVALID, blame,
                        "%s is %s-compressed, which OpenEXRCore cannot "
                        "decode; save it with ZIP, PIZ or no compression",
                        shown, comp == EXR_COMPRESSION_DWAA ? "DWAA" : "DWAB");
    }
    /* OpenEXRCore 3.1 reads B44 and B44A files whose channels are not
     * all half wrong, without an error: rows shifted, channels mixed
     * (a float ramp read back up to 4.95 off; OpenEXR's C++ library and
     * Mitsuba read the same files right).  Refused like DWA. */
    int b44 = comp == EXR_COMPRESSION_B44 || comp == EXR_COMPRESSION_B44A;
    for (int i = 0; b44 && i < chl->num_channels; i++)
        if (chl->entries[i].pixel_type != EXR_PIXEL_HALF) {
            return lr__fail(err, LR_ERR_INVALID, blame,
                            "%s is %s-compressed with 32-bit channels, "
                            "which OpenEXRCore 3.1 decodes wrongly; save it "
                            "with ZIP, PIZ or no compression, or as half",
                            shown,
                            comp == EXR_COMPRESSION_B44 ? "B44" : "B44A");
        }
    /* Subsampled channels (luminance/chroma files: RY and BY at 2 x 2)
     * crashed OpenEXRCore 3.1's default unpacker, or shifted the full
     * channels' values, even when lensray reads none of them; refused,
     * whatever their name. */
    for (int i = 0; i < chl->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[i];
        if (e->x_sampling != 1 || e->y_sampling != 1) {
            /* (The name as valid UTF-8: a file's bytes are anything.) */
            char name[64];
            lr__utf8_escape(e->name.str, name, sizeof name);
            return lr__fail(err, LR_ERR_INVALID, blame,
                            "%s: channel %s is subsampled (%d x %d), which "
                            "lensray does not read; save the image with "
                            "every channel at full resolution (RGB, not "
                            "luminance/chroma)",
                            shown, name, e->x_sampling, e->y_sampling);
        }
    }
    return LR_OK;
}

lr_status lr__exr_read(const void *data, size_t n, const char *shown,
                       const char *blame, const char *what, int max_dim,
                       size_t max_texels, lr__exr_planes *out, lr_error *err)
{
    memset(out, 0, sizeof *out);
    mem_stream m = {data, n};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    init.user_data = &m;
    init.read_fn = mem_read;
    init.size_fn = mem_size;
    exr_context_t ctxt = NULL;
    if (!lr__exr_magic(data, n) ||
        exr_start_read(&ctxt, shown, &init) != EXR_ERR_SUCCESS) {
        exr_finish(&ctxt);
        return lr__fail(err, LR_ERR_INVALID, blame,
                        "%s cannot be read as OpenEXR", shown);
    }
    lr_status st = LR_OK;
    float *scratch = NULL;
    /* A multi-part file was read as its first part, silently (a grey
     * texture where the colour was in the second). */
    int parts = 0;
    if (exr_get_count(ctxt, &parts) != EXR_ERR_SUCCESS || parts != 1) {
        st = lr__fail(err, LR_ERR_INVALID, blame,
                      "%s has %d parts; lensray reads single-part OpenEXR "
                      "images (save the part you want on its own)",
                      shown, parts);
        goto done;
    }
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    int32_t spc = 0;
    if (exr_get_storage(ctxt, 0, &storage) != EXR_ERR_SUCCESS ||
        storage != EXR_STORAGE_SCANLINE ||
        exr_get_data_window(ctxt, 0, &dw) != EXR_ERR_SUCCESS ||
        exr_get_channels(ctxt, 0, &chl) != EXR_ERR_SUCCESS ||
        exr_get_scanlines_per_chunk(ctxt, 0, &spc) != EXR_ERR_SUCCESS ||
        spc < 1) {
        st = lr__fail(err, LR_ERR_INVALID, blame,
                      "%s is not a scanline OpenEXR image", shown);
        goto done;
    }
    st = layout_refused(ctxt, chl, shown, blame, err);
    if (st != LR_OK)
        goto done;
    long long w = (long long)dw.max.x - dw.min.x + 1;
    long long h = (long long)dw.max.y - dw.min.y + 1;
    if (w < 1 || h < 1 || w > max_dim || h > max_dim) {
        /* (Too large is a limit, as for PNG and JPEG.) */
        st = lr__fail(err, w < 1 || h < 1 ? LR_ERR_INVALID : LR_ERR_LIMIT,
                      blame,
                      "%s is %lld x %lld pixels; %s must be 1 to %d on "
                      "each side",
                      shown, w, h, what, max_dim);
        goto done;
    }
    if ((unsigned long long)(w * h) > (unsigned long long)max_texels) {
        st = lr__fail(err, LR_ERR_LIMIT, blame,
                      "%s is %lld x %lld pixels; %s may have at most %zu "
                      "pixels in all (decoded, it would take %lld MB)",
                      shown, w, h, what, max_texels, w * h * 12 / 1000000);
        goto done;
    }
    out->w = (int)w, out->h = (int)h;
    out->x0 = dw.min.x, out->y0 = dw.min.y;
    size_t npx = (size_t)w * (size_t)h;
    for (int i = 0; i < chl->num_channels; i++) {
        int c = channel_index(chl->entries[i].name.str);
        if (c < 0 || out->plane[c] != NULL)
            continue;
        out->plane[c] = calloc(npx, sizeof(float));
        if (out->plane[c] == NULL) {
            st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
            goto done;
        }
    }
    /* A chunk's lines of one channel, for the channels not read. */
    scratch = calloc((size_t)w * (size_t)spc, sizeof(float));
    if (scratch == NULL) {
        st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        goto done;
    }
    for (long long y = dw.min.y; y <= dw.max.y; y += spc) {
        exr_chunk_info_t ci;
        exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
        if (exr_read_scanline_chunk_info(ctxt, 0, (int)y, &ci) !=
                EXR_ERR_SUCCESS ||
            exr_decoding_initialize(ctxt, 0, &ci, &dec) != EXR_ERR_SUCCESS) {
            st = lr__fail(err, LR_ERR_INVALID, blame,
                          "%s: bad chunk at line %lld", shown, y);
            goto done;
        }
        size_t first = (size_t)(ci.start_y - dw.min.y) * (size_t)w;
        for (int i = 0; i < dec.channel_count; i++) {
            exr_coding_channel_info_t *ch = &dec.channels[i];
            int c = channel_index(ch->channel_name);
            if (ch->height < 1) {
                ch->decode_to_ptr = NULL;
                continue;
            }
            /* A channel not read is decoded into scratch all the same:
             * left out (NULL), OpenEXRCore 3.1's unpacker crashed on
             * files mixing half and float channels (lensray's own
             * --half --depth output, its Z float) when it was one. */
            ch->decode_to_ptr = c < 0 ? (uint8_t *)scratch
                                      : (uint8_t *)(out->plane[c] + first);
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 4;
            ch->user_line_stride = 4 * (int32_t)w;
        }
        int ok = exr_decoding_choose_default_routines(ctxt, 0, &dec) ==
                     EXR_ERR_SUCCESS &&
                 exr_decoding_run(ctxt, 0, &dec) == EXR_ERR_SUCCESS;
        exr_decoding_destroy(ctxt, &dec);
        if (!ok) {
            st = lr__fail(err, LR_ERR_INVALID, blame,
                          "%s: cannot decode line %lld", shown, y);
            goto done;
        }
    }
done:
    free(scratch);
    if (st != LR_OK)
        lr__exr_planes_free(out);
    exr_finish(&ctxt);
    return st;
}
