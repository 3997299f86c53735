/*
 * format.c: the table of image formats: names, MIME types, extensions and
 * what each can hold.  Everything that names a format (file extensions,
 * a job's output.format, the daemon's Content-Type, the encoder to call)
 * asks this table, so a new format is one new row here and one encoder.
 */
#include "util/internal.h"

#include <stdio.h>
#include <string.h>
#include <strings.h>

typedef struct format_info {
    const char *name;      /* in JSON and messages */
    const char *mime;      /* Content-Type */
    const char *extension; /* with the dot, matched in any case */
    int has_depth;         /* can hold a Z channel */
    lr__encoder encode;    /* image_<name>.c */
} format_info;

/* Indexed by lr_format. */
static const format_info formats[] = {
    [LR_FORMAT_EXR] = {"exr", "image/x-exr", ".exr", 1, lr__encode_exr},
    [LR_FORMAT_PNG] = {"png", "image/png", ".png", 0, lr__encode_png},
};
#define N_FORMATS (sizeof formats / sizeof formats[0])

static const format_info *info(lr_format fmt)
{
    return (unsigned)fmt < N_FORMATS ? &formats[fmt] : NULL;
}

const char *lr_format_name(lr_format fmt)
{
    return info(fmt) ? info(fmt)->name : NULL;
}

const char *lr_format_mime(lr_format fmt)
{
    return info(fmt) ? info(fmt)->mime : NULL;
}

const char *lr_format_extension(lr_format fmt)
{
    return info(fmt) ? info(fmt)->extension : NULL;
}

int lr_format_has_depth(lr_format fmt)
{
    return info(fmt) ? info(fmt)->has_depth : 0;
}

lr__encoder lr__format_encoder(lr_format fmt)
{
    return info(fmt) ? info(fmt)->encode : NULL;
}

/* name(0), ..., name(n - 1) joined as "a, b or c", each in quotes when
 * `quoted`. */
static void join_names(char *out, size_t cap, size_t n,
                       const char *(*name)(size_t), int quoted)
{
    size_t used = 0;
    out[0] = '\0';
    for (size_t i = 0; i < n && used < cap; i++) {
        const char *sep = i == 0 ? "" : i + 1 == n ? " or " : ", ";
        int k = snprintf(out + used, cap - used, quoted ? "%s\"%s\"" : "%s%s",
                         sep, name(i));
        if (k < 0)
            break;
        used += (size_t)k;
    }
}

static const char *format_name(size_t i)
{
    return formats[i].name;
}
static const char *format_ext(size_t i)
{
    return formats[i].extension;
}

/* "\"exr\" or \"png\"" (quoted = 1) or ".exr or .png" (quoted = 0). */
static void list_names(char *out, size_t cap, int quoted)
{
    join_names(out, cap, N_FORMATS, quoted ? format_name : format_ext, quoted);
}

lr_status lr_format_from_name(const char *name, const char *field,
                              lr_format *fmt, lr_error *err)
{
    const char *f = field ? field : "format";
    if (fmt == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_format_from_name: the format pointer is NULL");
    for (size_t i = 0; name != NULL && i < N_FORMATS; i++)
        if (strcmp(name, formats[i].name) == 0) {
            *fmt = (lr_format)i;
            return LR_OK;
        }
    char names[128];
    list_names(names, sizeof names, 1);
    return lr__fail(err, LR_ERR_INVALID, f, "%s must be %s", f, names);
}

/* In lr_exr_compression's order. */
static const char *const exr_compressions[] = {"zip", "none", "zips", "rle",
                                               "piz"};
enum {
    N_EXR_COMPRESSIONS = sizeof exr_compressions / sizeof *exr_compressions
};

static const char *compression_name(size_t i)
{
    return exr_compressions[i];
}

const char *lr_exr_compression_name(lr_exr_compression c)
{
    return (unsigned)c < N_EXR_COMPRESSIONS ? exr_compressions[c] : NULL;
}

lr_status lr_exr_compression_from_name(const char *name, const char *field,
                                       lr_exr_compression *c, lr_error *err)
{
    const char *f = field ? field : "compression";
    if (c == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_exr_compression_from_name: the pointer is NULL");
    for (size_t i = 0; name != NULL && i < N_EXR_COMPRESSIONS; i++)
        if (strcmp(name, exr_compressions[i]) == 0) {
            *c = (lr_exr_compression)i;
            return LR_OK;
        }
    char names[96];
    join_names(names, sizeof names, N_EXR_COMPRESSIONS, compression_name, 1);
    return lr__fail(err, LR_ERR_INVALID, f, "%s must be %s", f, names);
}

lr_status lr_format_from_path(const char *path, lr_format *fmt, lr_error *err)
{
    if (path == NULL || fmt == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_format_from_path: path and format pointer must "
                        "not be NULL");

    /* Only a dot in the last path component starts an extension, so that
     * "out.d/image" is not mistaken for an image with extension
     * "d/image". */
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *dot = strrchr(base, '.');
    for (size_t i = 0; dot != NULL && i < N_FORMATS; i++)
        if (strcasecmp(dot, formats[i].extension) == 0) {
            *fmt = (lr_format)i;
            return LR_OK;
        }
    char names[128];
    list_names(names, sizeof names, 0);
    return lr__fail(err, LR_ERR_INVALID, NULL,
                    "cannot tell the image format of '%s': the file name "
                    "must end in %s (any case)",
                    path, names);
}
