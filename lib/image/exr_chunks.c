/*
 * exr_chunks.c: the EXR encoder's pixels (exr_chunks.h), for image_exr.c:
 * float samples to half, non-finite samples replaced, each chunk's rows
 * staged as planes (or read from the image where they need no change),
 * and the chunks compressed on several threads and written in file
 * order.
 */
#include "image/exr_chunks.h"
#include "image/exr_zip.h"

#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- sample conversion ------------------------------------------------ */

/* IEEE 754 binary32 to binary16 with round-to-nearest-even, done on the
 * bits so the result does not depend on the FPU rounding mode.  The
 * argument must be finite; magnitudes that would round to infinity are
 * clamped to the largest half, 65504. */
static uint16_t float_to_half(float f)
{
    uint32_t x;
    memcpy(&x, &f, sizeof x);
    uint16_t sign = (uint16_t)((x >> 16) & 0x8000u);
    uint32_t a = x & 0x7fffffffu;

    /* 65520 (0x477ff000) is halfway between 65504 and 2^16; ties go to
     * the even neighbour, 2^16, which as a half is infinity. */
    if (a >= 0x477ff000u)
        return (uint16_t)(sign | 0x7bffu);

    /* Normal halves: at least 2^-14 (0x38800000).  Rebias the exponent
     * from 127 to 15 and drop 13 mantissa bits, rounding; a carry out of
     * the mantissa correctly bumps the exponent. */
    if (a >= 0x38800000u) {
        uint32_t h = (a - 0x38000000u) >> 13;
        uint32_t rem = a & 0x1fffu;
        if (rem > 0x1000u || (rem == 0x1000u && (h & 1u)))
            h++;
        return (uint16_t)(sign | h);
    }

    /* At most 2^-25, half of the smallest subnormal, rounds to zero (the
     * tie goes to the even zero). */
    if (a <= 0x33000000u)
        return sign;

    /* Subnormal halves count units of 2^-24.  The float here is normal
     * with a biased exponent e in [102, 112], so its value in those units
     * is the 24-bit significand shifted right by 126 - e, in [14, 24]. */
    uint32_t e = a >> 23;
    uint32_t m = (a & 0x7fffffu) | 0x800000u;
    uint32_t shift = 126u - e;
    uint32_t h = m >> shift;
    uint32_t rem = m & ((1u << shift) - 1u);
    uint32_t halfway = 1u << (shift - 1u);
    if (rem > halfway || (rem == halfway && (h & 1u)))
        h++;
    /* A carry to 0x400 is the smallest normal half, which is right. */
    return (uint16_t)(sign | h);
}

static float finite_or(float v, float fallback)
{
    return isfinite(v) ? v : fallback;
}

/* ---- the pixels --------------------------------------------------------- */

const char *const lr__exr_channel_names[CH_COUNT] = {"R", "G", "B", "Z"};


/* Fills the planar staging buffer for scanlines [y0, y0 + lines): one
 * plane of spc * width samples per channel, in the channel's output type.
 * Each plane has room for 4-byte samples, halves use half of it. */
static void stage_chunk(const lr_image *img, int want_z, int half, int y0,
                        int lines, size_t plane_bytes, unsigned char *stage)
{
    size_t w = (size_t)img->width;
    for (int c = 0; c < CH_COUNT; c++) {
        if (c == CH_Z && !want_z)
            continue;
        unsigned char *plane = stage + (size_t)c * plane_bytes;
        for (int ly = 0; ly < lines; ly++) {
            size_t row = (size_t)(y0 + ly) * w;
            for (size_t x = 0; x < w; x++) {
                size_t i = (size_t)ly * w + x;
                if (c == CH_Z) {
                    float z = finite_or(img->depth[row + x], LR_DEPTH_NONE);
                    memcpy(plane + 4 * i, &z, 4);
                } else {
                    float v = finite_or(img->rgb[3 * (row + x) + (size_t)c],
                                        0.0f);
                    if (half) {
                        uint16_t h = float_to_half(v);
                        memcpy(plane + 2 * i, &h, 2);
                    } else {
                        memcpy(plane + 4 * i, &v, 4);
                    }
                }
            }
        }
    }
}

/* Whether rows [y0, y0 + lines) of the image's float samples go into
 * the file as they are (no half to convert to, nothing non-finite to
 * replace): then the pipeline reads them from the image itself, without
 * the staging copy, a chunk's worth of memory and a pass less a thread. */
static int rows_as_they_are(const lr_image *img, int want_z, int half, int y0,
                            int lines)
{
    if (half)
        return 0;
    size_t w = (size_t)img->width, a = (size_t)y0 * w;
    size_t b = (size_t)(y0 + lines) * w;
    int ok = 1;
    for (size_t i = 3 * a; i < 3 * b; i++)
        ok &= isfinite(img->rgb[i]) != 0;
    if (want_z)
        for (size_t i = a; i < b; i++)
            ok &= isfinite(img->depth[i]) != 0;
    return ok;
}

/* CH_R ... CH_Z for a channel's name, -1 for none.  The pipeline lists
 * channels in the file's order, which OpenEXR sorts by name (B, G, R,
 * Z), not the order they were added in, so they are matched by name. */
static int channel_index(const char *name)
{
    for (int k = 0; k < CH_COUNT; k++)
        if (strcmp(name, lr__exr_channel_names[k]) == 0)
            return k;
    return -1;
}

/* Points the pipeline's channels straight at the image's rows from y0
 * (rows_as_they_are said they need no change). */
static exr_result_t bind_image(exr_encode_pipeline_t *enc, const lr_image *img,
                               int y0)
{
    size_t row = (size_t)y0 * (size_t)img->width;
    for (int i = 0; i < enc->channel_count; i++) {
        exr_coding_channel_info_t *ch = &enc->channels[i];
        int c = channel_index(ch->channel_name);
        if (c < 0)
            return EXR_ERR_INVALID_ARGUMENT;
        int stride = c == CH_Z ? 4 : 12;
        ch->user_bytes_per_element = 4;
        ch->user_data_type = (uint16_t)EXR_PIXEL_FLOAT;
        ch->user_pixel_stride = stride;
        ch->user_line_stride = stride * img->width;
        ch->encode_from_ptr = c == CH_Z ? (const uint8_t *)(img->depth + row)
                                        : (const uint8_t *)(img->rgb + 3 * row +
                                                            (size_t)c);
    }
    return EXR_ERR_SUCCESS;
}

/* Points the pipeline's channels at their staging planes. */
static exr_result_t bind_channels(exr_encode_pipeline_t *enc, int half,
                                  size_t plane_bytes, unsigned char *stage,
                                  int width)
{
    for (int i = 0; i < enc->channel_count; i++) {
        exr_coding_channel_info_t *ch = &enc->channels[i];
        int c = channel_index(ch->channel_name);
        if (c < 0)
            return EXR_ERR_INVALID_ARGUMENT;
        int bytes = (c != CH_Z && half) ? 2 : 4;
        ch->user_bytes_per_element = (int16_t)bytes;
        ch->user_data_type = (uint16_t)(bytes == 2 ? EXR_PIXEL_HALF
                                                   : EXR_PIXEL_FLOAT);
        ch->user_pixel_stride = bytes;
        ch->user_line_stride = bytes * width;
        ch->encode_from_ptr = stage + (size_t)c * plane_bytes;
    }
    return EXR_ERR_SUCCESS;
}

/* ---- the chunks, compressed in parallel ------------------------------- */

/* Compressing is nearly all of an EXR's encoding time (ZIP: about 80 ms
 * for a 640 x 480 RGBZ frame, 8% of a 64-spp render of the bench scene,
 * and the whole of the farm client's time after the last part arrives).
 * Each chunk compresses on its own (OpenEXRCore's encode pipeline is
 * "meant to be used by separate threads ... accessing the same context
 * concurrently", openexr_encode.h), so threads compress a batch of chunks
 * into their own buffers, and the batch is then written in file order:
 * the bytes are the same as one thread writing each chunk as it goes,
 * which is what one thread does.  Batches keep what is held in memory to
 * a few chunks a thread, so that a file written to `fd` still never costs
 * its size in memory. */

typedef struct exr_blob {
    unsigned char *data;
    size_t len;
} exr_blob;

typedef struct chunk_job {
    exr_context_t ctxt;
    int part;
    const lr_image *img;
    int want_z, half, spc;
    int first, end, step; /* chunks first, first + step, ... below end */
    size_t plane_bytes;
    /* The batch's compressed chunks, chunk k at blobs[k - base]; NULL:
     * each chunk is written as it is made (one thread). */
    exr_blob *blobs;
    int base;
    int chunk; /* the chunk being compressed */
    exr_result_t rv;
    int zip; /* ZIP or ZIPS: compress with exr_zip.c */
    /* The worker's own, kept from batch to batch (job_open, job_close):
     * the staging planes, the deflate state and the pipeline with its
     * buffers. */
    unsigned char *stage;
    lr__exr_zip *deflate;
    exr_encode_pipeline_t enc;
    int live; /* enc initialised */
} chunk_job;

/* The job's worker state; its rv says whether there was memory. */
static void job_open(chunk_job *job)
{
    job->stage = malloc(job->plane_bytes * CH_COUNT);
    job->deflate = job->zip ? lr__exr_zip_new() : NULL;
    job->enc = (exr_encode_pipeline_t)EXR_ENCODE_PIPELINE_INITIALIZER;
    job->live = 0;
    job->rv = job->stage == NULL || (job->zip && job->deflate == NULL)
                  ? EXR_ERR_OUT_OF_MEMORY
                  : EXR_ERR_SUCCESS;
}

static void job_close(chunk_job *job)
{
    if (job->live)
        exr_encoding_destroy(job->ctxt, &job->enc);
    job->live = 0;
    lr__exr_zip_free(job->deflate);
    job->deflate = NULL;
    free(job->stage);
    job->stage = NULL;
}

/* The pipeline's last step in a batch: keeps the compressed chunk for
 * writing in order later (the bytes the default step would write now). */
static exr_result_t keep_chunk(exr_encode_pipeline_t *enc)
{
    chunk_job *job = enc->encoding_user_data;
    exr_blob *b = &job->blobs[job->chunk - job->base];
    b->len = enc->compressed_bytes;
    /* A deflated chunk is exr_zip's buffer: taken over, not copied (one
     * chunk's bytes less held per thread). */
    b->data = job->zip ? lr__exr_zip_take(job->deflate, enc->compressed_buffer)
                       : NULL;
    if (b->data != NULL)
        return EXR_ERR_SUCCESS;
    b->data = malloc(enc->compressed_bytes ? enc->compressed_bytes : 1);
    if (b->data == NULL)
        return EXR_ERR_OUT_OF_MEMORY;
    memcpy(b->data, enc->compressed_buffer, enc->compressed_bytes);
    return EXR_ERR_SUCCESS;
}

/* The pipeline's compression step for ZIP and ZIPS (exr_zip.h says
 * why): the chunk in the job's own buffer, or the packed bytes when
 * deflate does not pay, as the pipeline expects. */
static exr_result_t zip_chunk(exr_encode_pipeline_t *enc)
{
    chunk_job *job = enc->encoding_user_data;
    const unsigned char *out;
    size_t len;
    if (lr__exr_zip_chunk(job->deflate, enc->packed_buffer, enc->packed_bytes,
                          &out, &len) != 0)
        return EXR_ERR_OUT_OF_MEMORY;
    enc->compressed_buffer = (void *)out;
    enc->compressed_bytes = len;
    enc->compressed_alloc_size = 0;
    return EXR_ERR_SUCCESS;
}

/* Compresses (and, without blobs, writes) the job's chunks, with the
 * worker state job_open made. */
static void *compress_chunks(void *arg)
{
    chunk_job *job = arg;
    const lr_image *img = job->img;
    int top = img->frame_w > 0 ? img->y0 : 0;
    exr_encode_pipeline_t *enc = &job->enc;
    exr_result_t rv = job->rv;
    for (int k = job->first; k < job->end && rv == EXR_ERR_SUCCESS;
         k += job->step) {
        /* Chunks are named by their first line in the data window's
         * coordinates: a crop's start at its row in the frame. */
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(job->ctxt, job->part,
                                           top + k * job->spc, &cinfo);
        if (rv != EXR_ERR_SUCCESS)
            break;
        int direct = rows_as_they_are(img, job->want_z, job->half,
                                      cinfo.start_y - top, cinfo.height);
        if (!direct)
            stage_chunk(img, job->want_z, job->half, cinfo.start_y - top,
                        cinfo.height, job->plane_bytes, job->stage);
        if (!job->live) {
            rv = exr_encoding_initialize(job->ctxt, job->part, &cinfo, enc);
            if (rv != EXR_ERR_SUCCESS)
                break;
            job->live = 1;
            rv = exr_encoding_choose_default_routines(job->ctxt, job->part,
                                                      enc);
        } else {
            /* Reusing the pipeline keeps its buffers; the update resets
             * the per-chunk channel heights, so bind again. */
            rv = exr_encoding_update(job->ctxt, job->part, &cinfo, enc);
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = direct ? bind_image(enc, img, cinfo.start_y - top)
                        : bind_channels(enc, job->half, job->plane_bytes,
                                        job->stage, img->width);
        if (rv != EXR_ERR_SUCCESS)
            break;
        enc->encoding_user_data = job;
        if (job->zip)
            enc->compress_fn = zip_chunk;
        if (job->blobs != NULL) {
            /* Not the default order check: lr__exr_encode_chunks writes the
             * batch in order once every worker is done. */
            enc->yield_until_ready_fn = NULL;
            enc->write_fn = keep_chunk;
        }
        job->chunk = k;
        rv = exr_encoding_run(job->ctxt, job->part, enc);
        /* zip_chunk's buffer is the job's (or the packed one): the
         * pipeline must not free or reuse it as its own. */
        if (job->zip) {
            enc->compressed_buffer = NULL;
            enc->compressed_alloc_size = 0;
        }
    }
    job->rv = rv;
    return NULL;
}

int lr__exr_threads = 0;

/* Threads for an image of `height` rows in chunks of `spc` rows of
 * `chunk_bytes` (before compression): the online cores, at most 8, and
 * none beyond the first for fewer than 8 chunks per thread (a farm's part
 * of 30 rows has 2 chunks: starting a thread would cost more than it
 * saves), nor for buffers beyond max(4 MiB, 2% of the pixels).  A thread
 * holds about four chunks' bytes (the packed chunk, its reordered copy,
 * the deflated one and the kept one), measured: 2.7 MiB a thread at
 * 3840 x 2160, which took a 4K render 5% over its film and scene (make
 * bench's memory target); its file then takes one core's time more to
 * write, about 0.3 s, a few percent of any 4K render. */
static int encode_threads(int height, int spc, size_t chunk_bytes,
                          size_t image_bytes)
{
    if (lr__exr_threads > 0)
        return lr__exr_threads;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    int chunks = (height + spc - 1) / spc;
    size_t room = image_bytes / 50 > ((size_t)4 << 20) ? image_bytes / 50
                                                       : (size_t)4 << 20;
    int t = cores < 1 ? 1 : cores > 8 ? 8 : (int)cores;
    while (t > 1 && (chunks < 8 * t || (size_t)t * 4 * chunk_bytes > room))
        t--;
    return t;
}

/* What a batch holds at most (its chunks' bytes before compression,
 * which noisy float pixels hardly shrink): a ZIP chunk of a 4K RGBZ
 * image is 16 rows of 3840 x 16 bytes, 983 KB, and 16 a thread made a
 * 3840 x 2160 file cost 15 MiB of peak memory on top of its film
 * (make bench's memory line); at 2 MiB it is lost in the noise, and a
 * 640-wide frame still compresses in a batch or two. */
#define BATCH_BYTES ((size_t)2 << 20)

/* Compresses and writes every chunk (of `plane_bytes` a channel before
 * compression): on this thread alone, or in batches of up to 16 chunks a
 * thread and BATCH_BYTES (at least one chunk a thread) on
 * encode_threads' threads (fewer if a thread cannot be started). */
exr_result_t lr__exr_encode_chunks(exr_context_t ctxt, int part,
                                   const lr_image *img, int want_z, int half,
                                   int spc, size_t plane_bytes, int zip)
{
    int n = (img->height + spc - 1) / spc;
    int top = img->frame_w > 0 ? img->y0 : 0;
    size_t channels = want_z ? CH_COUNT : CH_COUNT - 1;
    size_t chunk_bytes = plane_bytes * channels;
    int threads = encode_threads(img->height, spc, chunk_bytes,
                                 (size_t)img->width * (size_t)img->height *
                                     channels * 4);
    chunk_job one = {.ctxt = ctxt,
                     .part = part,
                     .img = img,
                     .want_z = want_z,
                     .half = half,
                     .spc = spc,
                     .first = 0,
                     .end = n,
                     .step = 1,
                     .plane_bytes = plane_bytes,
                     .rv = EXR_ERR_SUCCESS,
                     .zip = zip};
    if (threads <= 1) {
        job_open(&one);
        compress_chunks(&one);
        job_close(&one);
        return one.rv;
    }
    size_t fit = BATCH_BYTES / (chunk_bytes ? chunk_bytes : 1);
    int batch = fit < (size_t)threads        ? threads
                : fit > (size_t)16 * threads ? 16 * threads
                                             : (int)fit;
    exr_blob *blobs = calloc((size_t)batch, sizeof *blobs);
    chunk_job *jobs = calloc((size_t)threads, sizeof *jobs);
    pthread_t *tids = calloc((size_t)threads, sizeof *tids);
    exr_result_t rv = EXR_ERR_SUCCESS;
    if (blobs == NULL || jobs == NULL || tids == NULL)
        rv = EXR_ERR_OUT_OF_MEMORY;
    for (int t = 0; t < threads && rv == EXR_ERR_SUCCESS; t++) {
        jobs[t] = one;
        jobs[t].step = threads;
        jobs[t].blobs = blobs;
        job_open(&jobs[t]);
        rv = jobs[t].rv;
    }
    for (int b0 = 0; b0 < n && rv == EXR_ERR_SUCCESS; b0 += batch) {
        int end = b0 + batch < n ? b0 + batch : n;
        for (int t = 0; t < threads; t++) {
            jobs[t].first = b0 + t;
            jobs[t].end = end;
            jobs[t].base = b0;
        }
        /* Worker 0 is this thread; a thread that cannot start leaves its
         * chunks to this one, below. */
        int started = 0;
        for (int t = 1; t < threads; t++) {
            if (pthread_create(&tids[t], NULL, compress_chunks, &jobs[t]))
                break;
            started = t;
        }
        compress_chunks(&jobs[0]);
        for (int t = 1; t <= started; t++)
            pthread_join(tids[t], NULL);
        for (int t = started + 1; t < threads; t++)
            compress_chunks(&jobs[t]);
        for (int t = 0; t < threads && rv == EXR_ERR_SUCCESS; t++)
            rv = jobs[t].rv;
        for (int k = b0; k < end; k++) {
            exr_blob *bl = &blobs[k - b0];
            if (rv == EXR_ERR_SUCCESS)
                rv = exr_write_scanline_chunk(ctxt, part, top + k * spc,
                                              bl->data, bl->len);
            free(bl->data);
            bl->data = NULL;
        }
    }
    for (int t = 0; jobs != NULL && t < threads; t++)
        job_close(&jobs[t]);
    free(blobs);
    free(jobs);
    free(tids);
    return rv;
}
