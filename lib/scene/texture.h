/*
 * texture.h: image textures: PNG (texture_png.c), JPEG (texture_jpeg.c)
 * and OpenEXR (exr_read.c) files or bytes decoded into linear float RGBA,
 * looked up bilinearly with repeat wrapping (texture.c).
 *
 * Limits: at most LR__TEX_MAX_DIM texels on a side, LR__TEX_MAX_TEXELS
 * in all, LR__TEX_MAX_BYTES of file.  A truncated or hostile file is an
 * error that names it, never a crash.
 */
#ifndef LR_TEXTURE_H
#define LR_TEXTURE_H

#include "image/exr_read.h"
#include "util/internal.h"

#include <stdint.h>

#define LR__TEX_MAX_DIM 16384
#define LR__TEX_MAX_TEXELS ((size_t)1 << 26) /* 1 GiB of float RGBA */
#define LR__TEX_MAX_BYTES ((size_t)512 << 20)

typedef struct lr__texture
    lr__texture; /* width, height, linear float RGBA texels */

struct lr__texture {
    int w, h;
    float *rgba;    /* 4 * w * h, row 0 the image's top row; owned */
    double mean[4]; /* the texels' mean, per channel */
    double max[4];  /* and their largest value (no lookup exceeds it) */
};

/* Loads PNG, JPEG or EXR, chosen by the file's magic bytes (not its name).
 * srgb = 1: 8-bit colour images are decoded from sRGB to linear (albedo,
 * emission); srgb = 0: values kept as they are, /255 (roughness and other
 * data).  EXR is linear always.  Errors name the file and what is wrong. */
lr__texture *lr__texture_load(const char *path, int srgb, lr_error *err);
/* The same from bytes in memory (glTF .glb embedded images); `name` is
 * what errors call it. */
lr__texture *lr__texture_load_memory(const void *data, size_t n,
                                     const char *name, int srgb, lr_error *err);
void lr__texture_free(lr__texture *t);
/* Bilinear lookup with repeat wrapping.  (u, v) in OBJ/OpenGL convention:
 * v = 0 is the BOTTOM row of the image.  (glTF's v runs down: its loader
 * passes 1 - v.)  Returns RGBA (alpha 1 where the image has none). */
void lr__texture_lookup(const lr__texture *t, double u, double v,
                        float rgba[4]);

/* ---- beyond the agreed interface -------------------------------------- */

/* lr__texture_load with messages naming the file as `shown` (the path
 * the scene wrote, not the directory the daemon keeps its scenes in). */
lr__texture *lr__texture_load_named(const char *path, const char *shown,
                                    int srgb, lr_error *err);

/* The sRGB decoding function of IEC 61966-2-1 (section 5.2) for a code
 * value c in [0, 1]: c / 12.92 up to 0.04045, ((c + 0.055) / 1.055)^2.4
 * above. */
double lr__srgb_decode(double c);

/* The decoders (texture_png.c, texture_jpeg.c), for data whose magic
 * bytes said so: fill t->w, t->h, t->rgba or return an error naming
 * `name`.  16-bit PNG samples are /65535; with srgb, colour channels
 * (never alpha) go through lr__srgb_decode. */
lr_status lr__texture_png(const void *data, size_t n, const char *name,
                          int srgb, lr__texture *t, lr_error *err);
lr_status lr__texture_jpeg(const void *data, size_t n, const char *name,
                           int srgb, lr__texture *t, lr_error *err);
/* table[k] = k / 255, through lr__srgb_decode when srgb: 8-bit codes. */
void lr__texture_table8(float table[256], int srgb);
/* The texels the image being loaded on this thread may have: what its
 * scene may still hold under lr_scene_limits_set (lr__texel_room_begin,
 * scene.h), UINT64_MAX when none (scene_limits.c).  lr__texel_room_check
 * fails with LR_ERR_LIMIT, headed by `name`, when n is more. */
uint64_t lr__texel_room(void);
lr_status lr__texel_room_check(uint64_t n, const char *name, lr_error *err);
/* lr__exr_read (its arguments) within lr__texel_room too: no plane past
 * it is allocated (the header is refused), and an image past it is
 * lr__texel_room_check's LR_ERR_LIMIT, on `blame`'s path if not NULL. */
lr_status lr__exr_read_room(const void *data, size_t n, const char *name,
                            const char *blame, const char *what, int max_dim,
                            size_t max_texels, lr__exr_planes *px,
                            lr_error *err);

/* Checks a decoder's w x h against the limits (and lr__texel_room)
 * before it allocates. */
lr_status lr__texture_check_size(long long w, long long h, const char *name,
                                 lr_error *err);

#endif
