/*
 * internal.h: what the library's files share and the public header does
 * not show.  Internal non-static names carry the lr__ prefix.
 */
#ifndef LR_INTERNAL_H
#define LR_INTERNAL_H

#include "lensray.h"

#include <stdarg.h>
#include <stddef.h>

/* ---- errors (error.c) ------------------------------------------------- */

/* Fills `err` (if non-NULL) with `status`, `path` (may be NULL) and a
 * printf-style message, and returns `status`.  The message is written as
 * given: callers include the path in it where it helps the reader. */
lr_status lr__fail(lr_error *err, lr_status status, const char *path,
                   const char *fmt, ...) __attribute__((format(printf, 4, 5)));

/* The error of a file that scene field `field` names, under the field:
 * unless its message starts with the field already, "field: " goes in
 * front and its path becomes the field.  NULL err or an empty field:
 * unchanged. */
void lr__fail_under(lr_error *err, const char *field);

/* Returns from the calling function when `expr` (an lr_status) fails. */
#define LR_TRY(expr)                   \
    do {                               \
        lr_status lr_try_st_ = (expr); \
        if (lr_try_st_ != LR_OK)       \
            return lr_try_st_;         \
    } while (0)

/* When snprintf, which wanted `wanted` characters, cut `s` (of capacity
 * `cap`) short, the cut may have fallen inside a UTF-8 character
 * (messages and paths quote user text): drops the partial character so
 * that the text stays valid UTF-8. */
void lr__trim_partial_utf8(char *s, size_t cap, int wanted);

/* ---- files (io.c) ---------------------------------------------------- */

/* Reads the whole file `file` into *out, a malloc'ed buffer of *len bytes
 * plus a terminating NUL, which the caller frees.  Messages name the file
 * as `shown` ("FILE: cannot open: reason") and err->path is `json_path`
 * (may be NULL); `what` names the kind of file in the size-limit message
 * ("OBJ files").  When `stop` is given, reading ends after the first
 * chunk for which it returns nonzero (the caller's parser rejects the
 * file there anyway).  Errors: LR_ERR_IO (cannot open or read, with the
 * system's reason), LR_ERR_LIMIT (larger than `max` bytes),
 * LR_ERR_NOMEM; then *out is NULL. */
lr_status lr__read_file(const char *file, const char *shown,
                        const char *json_path, size_t max, const char *what,
                        int (*stop)(const char *chunk, size_t n), char **out,
                        size_t *out_len, lr_error *err);
/* The directory part of `path` into dir (capacity cap): "." for a bare
 * name, "/" for a file in the root. */
void lr__dir_of(const char *path, char *dir, size_t cap);

/* The files a scene was loaded from (its meshes, textures, glTF files,
 * environment map, lens file), each as lr__read_file found it: for
 * lr_scene_files_changed.  Recorded by lr__read_file into the calling
 * thread's log between lr__file_log_begin and lr__file_log_end. */
typedef struct lr__file_id {
    char *path;
    unsigned long long dev, ino, size;
    long long mtime_s, mtime_ns;
} lr__file_id;

typedef struct lr__file_log {
    lr__file_id *v; /* owned, n of them */
    size_t n, cap;
} lr__file_log;

void lr__file_log_begin(lr__file_log *log);
void lr__file_log_end(void);
/* Whether a file of the log differs from what was read, or is gone. */
int lr__file_log_changed(const lr__file_log *log);
void lr__file_log_free(lr__file_log *log);

/* ---- limits, shared by the JSON loader and the C API's validation ---- */

#define LR__MAX_DIM 65536           /* pixels per side */
#define LR__MAX_PIXELS (1ull << 28) /* pixels per image */
#define LR__MAX_SPP (1 << 20)       /* samples per pixel */
#define LR__MAX_DEPTH 64            /* bounces */
#define LR__MAX_THREADS 1024
#define LR__MAX_TILE 4096

/* The largest magnitude of any number in a scene: far beyond any real
 * scene, yet small enough that positions, sizes and colours stay well
 * inside float range (Embree works in float and rejects rays whose
 * origin lies beyond about 1.8e18) and their products stay finite. */
#define LR__MAX_NUMBER 1e15

/* ---- images (image.c) ------------------------------------------------- */

struct lr_image {
    int width, height;
    float *rgb;   /* width*height*3, owned */
    float *depth; /* width*height or NULL, owned */
    /* A crop's place in its frame and how it was rendered, for the EXR
     * header (lr_image_set_frame); frame_w == 0: the image is a frame of
     * its own and the header says nothing more. */
    int frame_w, frame_h, x0, y0;
    int spp;
    uint64_t seed;
    char *camera; /* lr_camera_json text, owned, or NULL */
};

/* ---- encoders (image_exr.c, image_png.c) ------------------------------ */

/* Each encodes `img`: with fd < 0 to a malloc'ed buffer (*buf, *len)
 * that the caller frees with free(); with fd >= 0 straight into that
 * file (at offset 0 on, opened for writing and empty), so that a file
 * never costs its size in memory, and *buf stays NULL.  `opts` is never
 * NULL here.  On failure *buf is NULL and nothing leaks; a failed write
 * is LR_ERR_IO with the system's reason.  `cancel` (may be NULL), when
 * non-zero at a write to fd, stops the encoding: LR_ERR_CANCELLED. */
typedef lr_status (*lr__encoder)(const lr_image *img,
                                 const lr_output_options *opts, int fd,
                                 const volatile int *cancel, void **buf,
                                 size_t *len, lr_error *err);
lr_status lr__encode_exr(const lr_image *img, const lr_output_options *opts,
                         int fd, const volatile int *cancel, void **buf,
                         size_t *len, lr_error *err);
/* Threads that compress an EXR's chunks: 0 (the default) chooses by the
 * cores and the image's height (exr_chunks.c); tests set a count to check
 * that every count writes the same bytes.  Not for use while encoding. */
extern int lr__exr_threads;
lr_status lr__encode_png(const lr_image *img, const lr_output_options *opts,
                         int fd, const volatile int *cancel, void **buf,
                         size_t *len, lr_error *err);

/* sRGB transfer function (IEC 61966-2-1) of a linear value clamped to
 * [0, 1]; NaN maps to 0. */
double lr__srgb_encode(double linear);

/* The encoder of a format (format.c's table), or NULL for an unknown one. */
lr__encoder lr__format_encoder(lr_format fmt);

/* ---- OBJ meshes (obj.c) ----------------------------------------------- */

/* A triangle mesh as read from a Wavefront OBJ file.  Polygons are
 * triangulated (obj_face.c: a fan when convex, else ear clipping).
 * `normals` is NULL unless the file gave a `vn` for every
 * corner of every face; then normals[3*k..3*k+2] is the unit normal for
 * corner k (corner order matches `indices`), i.e. normals are per corner,
 * not per vertex, because OBJ indexes them independently. */
typedef struct lr__mesh {
    size_t n_vertices;
    float *vertices; /* 3 * n_vertices, owned */
    size_t n_triangles;
    unsigned *indices; /* 3 * n_triangles vertex indices, owned */
    float *normals;    /* 9 * n_triangles (per corner) or NULL, owned */
    /* 6 * n_triangles texture coordinates (u, v per corner) or NULL
     * unless every corner of every face named a `vt`; owned. */
    float *uvs;
    /* What was read and not used, for warnings: the usemtl lines, and
     * the line whose face first lacked a normal (a texture coordinate)
     * when the file had some (0: none). */
    size_t usemtl_lines, normals_lost_line, uvs_lost_line;
} lr__mesh;

/* Reads an OBJ file.  Understands `v`, `vn`, `vt` (u [v [w]]; v
 * defaults to 0, w is ignored), `f` (with v, v/vt, v//vn, v/vt/vn
 * corners, negative indices relative to the end of the list so far) and
 * ignores other statements (o, g, s, usemtl, mtllib, l, p, comments).  Errors are LR_ERR_IO for an unreadable file and
 * LR_ERR_INVALID with "FILE:LINE: what is wrong" for malformed input
 * (bad numbers, zero or out-of-range indices, faces with fewer than three
 * corners, no faces at all).  `json_path` (e.g. "objects[2].file") goes
 * into err->path.  On success the caller frees with lr__mesh_free. */
lr_status lr__obj_load(const char *file, const char *json_path, lr__mesh *out,
                       lr_error *err);
/* The same, with messages naming the file as `shown` (e.g. the path
 * the scene wrote, relative to its directory) rather than `file`, the
 * path opened. */
lr_status lr__obj_load_named(const char *file, const char *shown,
                             const char *json_path, lr__mesh *out,
                             lr_error *err);
void lr__mesh_free(lr__mesh *m);

#endif /* LR_INTERNAL_H */
