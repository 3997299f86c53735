/*
 * exr_crop.c: an EXR crop from memory into its place in a frame
 * (exr_crop.h), with the OpenEXRCore C API.  The reading follows
 * OpenEXRCore's own decoding example: one decode pipeline per scanline
 * chunk, each channel decoded straight into the frame as float.
 */
#include "exr_crop.h"

#include <openexr.h>

#include <math.h>
#include <stdlib.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

typedef struct mem_stream {
    const unsigned char *data;
    size_t len;
} mem_stream;

static int64_t mem_read(exr_const_context_t ctxt, void *user, void *buffer,
                        uint64_t sz, uint64_t offset,
                        exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb;
    const mem_stream *m = user;
    if (offset >= m->len)
        return 0;
    uint64_t n = m->len - offset < sz ? m->len - offset : sz;
    memcpy(buffer, m->data + offset, n);
    return (int64_t)n;
}

static int64_t mem_size(exr_const_context_t ctxt, void *user)
{
    (void)ctxt;
    return (int64_t)((const mem_stream *)user)->len;
}

/* OpenEXRCore prints its errors on stderr by default; the caller reports
 * one sentence of its own instead. */
static void quiet(exr_const_context_t ctxt, exr_result_t code, const char *m)
{
    (void)ctxt;
    (void)code;
    (void)m;
}

/* The frame's channel that an EXR channel goes to: 0-2 for R, G, B, 3 for
 * Z, -1 for none. */
static int channel_index(const char *name)
{
    static const char *const names[4] = {"R", "G", "B", "Z"};
    for (int k = 0; k < 4; k++)
        if (strcmp(name, names[k]) == 0)
            return k;
    return -1;
}

int exr_crop_place(const void *buf, size_t len, lr_image *dst, int x0, int y0,
                   int fx, int fy, int w, int h, char *msg, size_t msg_size)
{
    mem_stream m = {buf, len};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = &m;
    init.read_fn = mem_read;
    init.size_fn = mem_size;
    init.error_handler_fn = quiet;
    exr_context_t ctxt = NULL;
    if (exr_start_read(&ctxt, "part", &init) != EXR_ERR_SUCCESS) {
        snprintf(msg, msg_size, "the answer is not an OpenEXR image");
        exr_finish(&ctxt);
        return -1;
    }
    int rc = -1;
    int want_z = lr_image_depth(dst) != NULL;
    int dst_w = lr_image_width(dst);
    float *rgb = lr_image_rgb_mut(dst);
    float *z = lr_image_depth_mut(dst);
    /* One staging row per channel: the chunk is decoded into planes of
     * the crop's width, then checked and copied into the frame. */
    float *plane[4] = {NULL, NULL, NULL, NULL};
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    int32_t spc = 0;
    if (exr_get_storage(ctxt, 0, &storage) != EXR_ERR_SUCCESS ||
        storage != EXR_STORAGE_SCANLINE ||
        exr_get_data_window(ctxt, 0, &dw) != EXR_ERR_SUCCESS ||
        exr_get_channels(ctxt, 0, &chl) != EXR_ERR_SUCCESS ||
        exr_get_scanlines_per_chunk(ctxt, 0, &spc) != EXR_ERR_SUCCESS ||
        spc <= 0) {
        snprintf(msg, msg_size, "the image is not a scanline OpenEXR");
        goto done;
    }
    int cw = dw.max.x - dw.min.x + 1, ch = dw.max.y - dw.min.y + 1;
    if (cw != w || ch != h) {
        snprintf(msg, msg_size, "the image is %d x %d, not the part's %d x %d",
                 cw, ch, w, h);
        goto done;
    }
    if (dw.min.x != fx || dw.min.y != fy) {
        snprintf(msg, msg_size,
                 "the image's data window starts at %d, %d, "
                 "not at the part's %d, %d",
                 dw.min.x, dw.min.y, fx, fy);
        goto done;
    }
    int found[4] = {0, 0, 0, 0};
    for (int i = 0; i < chl->num_channels; i++) {
        int k = channel_index(chl->entries[i].name.str);
        if (k >= 0)
            found[k] = 1;
    }
    if (!found[0] || !found[1] || !found[2] || (want_z && !found[3])) {
        snprintf(msg, msg_size, "the image lacks channel %s",
                 !found[0]   ? "R"
                 : !found[1] ? "G"
                 : !found[2] ? "B"
                             : "Z");
        goto done;
    }
    for (int k = 0; k < 4; k++) {
        plane[k] = calloc((size_t)w * (size_t)spc, sizeof(float));
        if (plane[k] == NULL) {
            snprintf(msg, msg_size, "out of memory");
            goto done;
        }
    }
    for (int y = dw.min.y; y <= dw.max.y; y += spc) {
        exr_chunk_info_t ci;
        exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
        if (exr_read_scanline_chunk_info(ctxt, 0, y, &ci) != EXR_ERR_SUCCESS ||
            exr_decoding_initialize(ctxt, 0, &ci, &dec) != EXR_ERR_SUCCESS) {
            snprintf(msg, msg_size, "the image's line %d cannot be read",
                     y - dw.min.y);
            goto done;
        }
        for (int i = 0; i < dec.channel_count; i++) {
            exr_coding_channel_info_t *c = &dec.channels[i];
            int k = channel_index(c->channel_name);
            if (k < 0 || (k == 3 && !want_z)) {
                c->decode_to_ptr = NULL;
                continue;
            }
            c->decode_to_ptr = (uint8_t *)plane[k];
            c->user_bytes_per_element = 4;
            c->user_data_type = EXR_PIXEL_FLOAT;
            c->user_pixel_stride = 4;
            c->user_line_stride = 4 * w;
        }
        int ok = exr_decoding_choose_default_routines(ctxt, 0, &dec) ==
                     EXR_ERR_SUCCESS &&
                 exr_decoding_run(ctxt, 0, &dec) == EXR_ERR_SUCCESS;
        exr_decoding_destroy(ctxt, &dec);
        if (!ok) {
            snprintf(msg, msg_size, "the image's line %d cannot be decoded",
                     y - dw.min.y);
            goto done;
        }
        for (int r = 0; r < ci.height; r++) {
            size_t row = (size_t)(y0 + ci.start_y - dw.min.y + r);
            for (int x = 0; x < w; x++) {
                size_t s = (size_t)r * (size_t)w + (size_t)x;
                size_t d = row * (size_t)dst_w + (size_t)(x0 + x);
                for (int k = 0; k < (want_z ? 4 : 3); k++)
                    if (!isfinite(plane[k][s])) {
                        snprintf(msg, msg_size,
                                 "the image has a NaN or "
                                 "infinite value at %d, %d",
                                 x, ci.start_y - dw.min.y + r);
                        goto done;
                    }
                for (int k = 0; k < 3; k++)
                    rgb[d * 3 + (size_t)k] = plane[k][s];
                if (want_z)
                    z[d] = plane[3][s];
            }
        }
    }
    rc = 0;
done:
    for (int k = 0; k < 4; k++)
        free(plane[k]);
    exr_finish(&ctxt);
    return rc;
}
