/*
 * fuzz_texture.c: the texture decoders (lr__texture_load_memory: PNG,
 * JPEG and OpenEXR, chosen by magic bytes), as a glTF file's embedded
 * images reach them.
 *
 * Promises checked: a rejected input gets a known status and a message
 * that names the image; an accepted one has a size within the limits,
 * every texel finite and >= 0 (at most 1 for 8- and 16-bit formats, and
 * for every alpha), and lookups anywhere, wrapped, give finite values.
 * The low bit of the first byte after the magic picks srgb, so both
 * decodings run.
 */
#include "fuzz.h"

#include "scene/texture.h"

#include <math.h>
#include <string.h>

int lr_fuzz_texture(const uint8_t *data, size_t size)
{
    static const char name[] = "fuzz-image";
    int srgb = size > 8 ? data[8] & 1 : 1;
    lr_error err;
    memset(&err, 0, sizeof err);
    lr__texture *t = lr__texture_load_memory(data, size, name, srgb, &err);
    if (t == NULL) {
        if (lr_fuzz_check_error("texture", err.status, &err) != 0)
            return 1;
        if (strstr(err.message, name) == NULL)
            return lr_fuzz_report("texture: message \"%s\" does not name "
                                  "the image",
                                  err.message);
        return 0;
    }
    int rc = 0;
    int exr = size >= 4 && memcmp(data, "\x76\x2f\x31\x01", 4) == 0;
    if (t->w < 1 || t->h < 1 || t->w > LR__TEX_MAX_DIM ||
        t->h > LR__TEX_MAX_DIM ||
        (size_t)t->w * (size_t)t->h > LR__TEX_MAX_TEXELS)
        rc = lr_fuzz_report("texture: accepted %d x %d", t->w, t->h);
    size_t n = 4 * (size_t)t->w * (size_t)t->h;
    for (size_t i = 0; rc == 0 && i < n; i++) {
        float v = t->rgba[i];
        if (!isfinite(v) || v < 0.0f || (!exr && v > 1.0f))
            rc = lr_fuzz_report("texture: texel value %zu is %g", i, (double)v);
    }
    static const double uv[][2] = {{0, 0},      {0.5, 0.5},  {1, 1},
                                   {-3.2, 7.9}, {1e9, -1e9}, {NAN, 0.3}};
    for (size_t k = 0; rc == 0 && k < sizeof uv / sizeof uv[0]; k++) {
        float c[4];
        lr__texture_lookup(t, uv[k][0], uv[k][1], c);
        for (int j = 0; j < 4; j++)
            if (!isfinite(c[j]))
                rc = lr_fuzz_report("texture: lookup (%g, %g) gave %g",
                                    uv[k][0], uv[k][1], (double)c[j]);
    }
    lr__texture_free(t);
    return rc;
}

LR_FUZZ_MAIN(lr_fuzz_texture)
