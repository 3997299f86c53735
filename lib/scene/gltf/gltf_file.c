/*
 * gltf_file.c: the bytes of a glTF document (gltf_doc.h): the files it
 * names (URIs unescaped and confined, data: URIs decoded from base64,
 * each read once) and the GLB container (spec 4.4); gltf_check.c checks
 * what they hold.
 */
#include "scene/gltf/gltf_doc.h"
#include "json/json_util.h"

#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- external files ----------------------------------------------------- */

static int hex_value(int c)
{
    return c >= '0' && c <= '9'   ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
}

/* A URI reference spells a byte that may not stand in it as %XX (RFC
 * 3986, 2.1): exporters write a file "My Wood.png" as "My%20Wood.png".
 * Decoded into out (at least strlen(u) + 1 bytes); escapes of "/", "\"
 * and NUL are refused rather than decoded, since they would spell a
 * path other than the one the checks below read.  Returns what is
 * wrong, or NULL. */
static const char *unescape_uri(const char *u, char *out)
{
    size_t k = 0;
    for (const char *p = u; *p; p++) {
        if (*p != '%') {
            out[k++] = *p;
            continue;
        }
        int hi = hex_value((unsigned char)p[1]);
        int lo = hi < 0 ? -1 : hex_value((unsigned char)p[2]);
        if (lo < 0)
            return "has a \"%\" that is not an escape %XX";
        int c = 16 * hi + lo;
        if (c == '/' || c == '\\' || c == 0)
            return "escapes a slash, a backslash or a NUL byte";
        out[k++] = (char)c;
        p += 2;
    }
    out[k] = '\0';
    return NULL;
}

/* Whether the URI reference u, as written (escapes not decoded), is an
 * absolute URI: a colon in its first segment, which a relative path
 * reference may not have (RFC 3986, 4.2; a colon there is spelled %3A).
 * A colon after the first "/" is part of a file name ("sub/t:1.bin"). */
static int names_scheme(const char *u)
{
    size_t first = strcspn(u, "/");
    const char *colon = strchr(u, ':');
    return colon != NULL && (size_t)(colon - u) < first;
}

/* A relative path below the glTF's directory, percent escapes decoded:
 * no absolute path, no ".." segment, no backslash (which could spell
 * either), no control characters. */
static const char *bad_uri(const char *u)
{
    if (u[0] == '\0')
        return "is empty";
    if (u[0] == '/')
        return "is an absolute path";
    if (strchr(u, '\\') != NULL)
        return "has a backslash";
    for (const char *p = u; *p; p++)
        if ((unsigned char)*p < 0x20)
            return "has a control character";
    for (const char *p = u; p != NULL; p = strchr(p, '/')) {
        if (*p == '/')
            p++;
        if (p[0] == '.' && p[1] == '.' && (p[2] == '/' || p[2] == '\0'))
            return "has a \"..\" segment";
    }
    return NULL;
}

static int b64_value(int c)
{
    if (c >= 'A' && c <= 'Z')
        return c - 'A';
    if (c >= 'a' && c <= 'z')
        return c - 'a' + 26;
    if (c >= '0' && c <= '9')
        return c - '0' + 52;
    return c == '+' ? 62 : c == '/' ? 63 : -1;
}

/* Decodes the base64 data: URI `u` (RFC 2397, RFC 4648 section 4). */
static lr_status decode_data_uri(const lr__gltf_doc *d, const char *path,
                                 const char *u, unsigned char **out, size_t *n,
                                 lr_error *err)
{
    const char *comma = strchr(u, ',');
    if (comma == NULL || comma - u < 12 ||
        strncmp(comma - 7, ";base64", 7) != 0)
        return lr__gltf_fail(d, err,
                             "%s.uri: a data: URI must be base64 "
                             "(\"data:...;base64,...\")",
                             path);
    const char *s = comma + 1;
    size_t len = strlen(s);
    unsigned char *buf = malloc(len / 4 * 3 + 3);
    if (buf == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    size_t k = 0, i;
    unsigned acc = 0;
    int bits = 0;
    for (i = 0; i < len && s[i] != '='; i++) {
        int v = b64_value((unsigned char)s[i]);
        if (v < 0) {
            free(buf);
            return lr__gltf_fail(d, err,
                                 "%s.uri: byte %zu of the base64 "
                                 "data is not base64",
                                 path, i);
        }
        acc = (acc << 6) | (unsigned)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            buf[k++] = (unsigned char)(acc >> bits);
        }
    }
    *out = buf;
    *n = k;
    return LR_OK;
}

/* Reads the file `uri` (relative to the glTF's directory `dir`) into a
 * new blob. */
lr_status lr__gltf_read_blob(lr__gltf_doc *d, const char *dir, const char *path,
                             const char *uri, lr__gltf_blob **out,
                             lr_error *err)
{
    const lr__gltf_blob *seen = lr__gltf_blob_find(d, uri);
    if (seen != NULL) {
        *out = (lr__gltf_blob *)seen;
        return LR_OK;
    }
    int is_data = strncmp(uri, "data:", 5) == 0;
    char *file = is_data ? NULL : malloc(strlen(uri) + 1);
    if (!is_data && file == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    const char *why = is_data             ? NULL
                      : names_scheme(uri) ? "names a URI scheme (only data: "
                                            "URIs and relative paths are read)"
                                          : unescape_uri(uri, file);
    if (!is_data && why == NULL)
        why = bad_uri(file);
    if (why != NULL) {
        free(file);
        return lr__gltf_fail(d, err, "%s.uri \"%.80s\" %s", path, uri, why);
    }
    lr__gltf_blob *b = realloc(d->blobs, (d->n_blobs + 1) * sizeof *b);
    if (b == NULL) {
        free(file);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    d->blobs = b;
    b = &d->blobs[d->n_blobs];
    memset(b, 0, sizeof *b);
    if (is_data) {
        LR_TRY(decode_data_uri(d, path, uri, &b->data, &b->n, err));
    } else {
        size_t plen = strlen(dir) + strlen(file) + 2;
        char *full = malloc(plen);
        if (full == NULL) {
            free(file);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
        snprintf(full, plen, "%s/%s", dir, file);
        /* A symbolic link must not lead out of the directory either.
         * Into buffers of our own: realpath's own allocation, when it
         * failed, skipped the check (a file it cannot resolve is not
         * there, and lr__read_file says so below). */
        char rdir[PATH_MAX], rfile[PATH_MAX];
        int out = realpath(dir, rdir) != NULL &&
                  realpath(full, rfile) != NULL &&
                  (strncmp(rfile, rdir, strlen(rdir)) != 0 ||
                   (rfile[strlen(rdir)] != '/' && strcmp(rdir, "/") != 0));
        if (out) {
            free(full);
            free(file);
            return lr__gltf_fail(d, err,
                                 "%s.uri \"%.80s\" leads out of the "
                                 "glTF's directory (a symbolic link)",
                                 path, uri);
        }
        char *data = NULL;
        size_t n = 0;
        lr_error e2;
        /* The name as messages quote it: a uri's bytes need not be UTF-8
         * (a fuzzed file's were not), and messages must be. */
        char shown[256];
        lr__utf8_escape(file, shown, sizeof shown);
        lr_status st = lr__read_file(full, shown, NULL, LR__GLTF_MAX_BYTES,
                                     "files a glTF names", NULL, &data, &n,
                                     &e2);
        free(full);
        free(file);
        if (st != LR_OK) {
            if (st == LR_ERR_NOMEM)
                return lr__fail(err, st, NULL, "out of memory");
            return lr__fail(err, st, d->fp, "%s: %s: %s.uri: %s", d->fp,
                            d->shown, path, e2.message);
        }
        b->data = (unsigned char *)data;
        b->n = n;
    }
    b->uri = strdup(uri);
    if (b->uri == NULL) {
        free(b->data);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    d->n_blobs++;
    *out = b;
    return LR_OK;
}

/* ---- the container -------------------------------------------------------- */

uint32_t lr__gltf_le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

/* The GLB header and chunks (spec 4.4): the JSON chunk's text in *json. */
lr_status lr__gltf_read_glb(lr__gltf_doc *d, const char **json, size_t *n,
                            lr_error *err)
{
    const unsigned char *b = d->bytes;
    if (d->n_bytes < 20)
        return lr__gltf_fail(d, err,
                             "a GLB file needs a 12-byte header "
                             "and a chunk; this one has %zu bytes",
                             d->n_bytes);
    if (lr__gltf_le32(b + 4) != 2)
        return lr__gltf_fail(d, err, "GLB version %u (only 2 is read)",
                             (unsigned)lr__gltf_le32(b + 4));
    size_t total = lr__gltf_le32(b + 8);
    if (total > d->n_bytes || total < 20)
        return lr__gltf_fail(d, err,
                             "the GLB header says %zu bytes, the "
                             "file has %zu (truncated?)",
                             total, d->n_bytes);
    size_t jlen = lr__gltf_le32(b + 12);
    if (memcmp(b + 16, "JSON", 4) != 0)
        return lr__gltf_fail(d, err, "the first GLB chunk must be JSON");
    if (jlen > total - 20)
        return lr__gltf_fail(d, err,
                             "the GLB JSON chunk of %zu bytes runs "
                             "past the file's end (truncated?)",
                             jlen);
    *json = (const char *)b + 20;
    *n = jlen;
    size_t at = 20 + jlen;
    if (at + 8 <= total) {
        size_t blen = lr__gltf_le32(b + at);
        if (memcmp(b + at + 4, "BIN\0", 4) != 0)
            return lr__gltf_fail(d, err, "the second GLB chunk must be BIN");
        if (blen > total - at - 8)
            return lr__gltf_fail(d, err,
                                 "the GLB BIN chunk of %zu bytes "
                                 "runs past the file's end (truncated?)",
                                 blen);
        d->bin = b + at + 8;
        d->n_bin = blen;
    }
    return LR_OK;
}
