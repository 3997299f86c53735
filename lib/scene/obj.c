/*
 * obj.c: reading triangle meshes from Wavefront OBJ files.
 *
 * The whole file is read into memory first and then split into lines in
 * place, so a line is a NUL-terminated string that strtod and strtol can
 * work on without ever running into the next line.  Only geometry is kept:
 * `v` positions, `vn` normals, `vt` texture coordinates and `f` faces;
 * everything else an exporter may write (groups, materials, lines,
 * points) is skipped, because the renderer has no use for it.  Faces (`f`) are
 * obj_face.c's; the parser's state is in obj.h.
 */
#include "scene/obj.h"

#include <errno.h>
#include <float.h>
#include <limits.h>
#include <locale.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The largest OBJ file we agree to read.  Real scenes are far smaller;
 * the cap keeps a wrong path (a disk image, /dev/zero) from eating all
 * memory before the parser gets a chance to reject it. */
#define OBJ_MAX_BYTES ((size_t)1 << 30)

/* Grows an array so that it holds at least `need` elements of `elem`
 * bytes, doubling the capacity so that appending stays linear overall.
 * Returns the (possibly moved) array, or NULL when the size would
 * overflow or realloc fails; the old array is then still valid, which is
 * what lets the caller free everything on the error path. */
void *lr__obj_grow(void *p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return p;
    size_t n = *cap ? *cap : 64;
    while (n < need) {
        if (n > SIZE_MAX / 2)
            return NULL;
        n *= 2;
    }
    if (n > SIZE_MAX / elem)
        return NULL;
    void *q = realloc(p, n * elem);
    if (q == NULL)
        return NULL;
    *cap = n;
    return q;
}

static void parser_free(parser *ps)
{
    free(ps->v);
    free(ps->vn);
    free(ps->vt);
    free(ps->idx);
    free(ps->cn);
    free(ps->cuv);
    free(ps->corners);
    ps->v = ps->vn = ps->cn = ps->vt = ps->cuv = NULL;
    ps->idx = NULL;
    ps->corners = NULL;
}

/* Reports an input error at the current line.  Every parse message has
 * the "FILE:LINE: " prefix that editors and compilers use, so a user can
 * jump straight to the culprit. */
lr_status lr__obj_fail_at(parser *ps, lr_status status, const char *fmt, ...)
{
    char what[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return lr__fail(ps->err, status, ps->json_path, "%s:%zu: %s", ps->file,
                    ps->line, what);
}

lr_status lr__obj_nomem(parser *ps)
{
    return lr__obj_fail_at(ps, LR_ERR_NOMEM,
                           "out of memory while reading the mesh");
}

/* Whitespace between tokens.  A stray '\r' counts too, so CRLF files and
 * files with odd line endings mid-way parse like plain ones. */
static int is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* Control bytes that never occur in a text OBJ file.  Finding one means
 * the path points at something binary, which must not pass as "a file
 * with no faces" or, worse, as a few accidental statements. */
static int is_binary_byte(unsigned char c)
{
    return (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\v' &&
            c != '\f') ||
           c == 0x7f;
}

/* Reading a file stops at the first chunk with a binary byte: the parser
 * reports it (with its line) before it could reach anything after it, so
 * there is no need to read on, and a device that streams bytes forever
 * (/dev/zero, /dev/urandom) is rejected at once instead of after the
 * 1 GiB limit. */
static int stop_at_binary(const char *chunk, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (is_binary_byte((unsigned char)chunk[i]))
            return 1;
    return 0;
}

/* Finds the next token after *pp; returns its start and sets *len, or
 * returns NULL at the end of the line.  Advances *pp past the token. */
const char *lr__obj_next_token(const char **pp, size_t *len)
{
    const char *p = *pp;
    while (is_blank(*p))
        p++;
    if (*p == '\0') {
        *pp = p;
        return NULL;
    }
    const char *start = p;
    while (*p != '\0' && !is_blank(*p))
        p++;
    *len = (size_t)(p - start);
    *pp = p;
    return start;
}

lr__obj_quoted lr__obj_quote(const char *tok, size_t len)
{
    lr__obj_quoted q;
    size_t o = 0;
    for (size_t i = 0; i < len && i < TOKEN_QUOTE_MAX; i++) {
        unsigned char c = (unsigned char)tok[i];
        if (c >= 0x20 && c < 0x7f)
            q.s[o++] = (char)c;
        else
            o += (size_t)snprintf(q.s + o, sizeof q.s - o, "\\x%02x", c);
    }
    q.s[o] = '\0';
    return q;
}

/* Parses one whole token as a finite number that fits a float.  `what`
 * names the statement for the message. */
static lr_status parse_number(parser *ps, const char *tok, size_t len,
                              const char *what, double *out)
{
    char *end = NULL;
    errno = 0;
    /* OBJ numbers are decimal; strtod also reads hexadecimal ("0x1"),
     * which no exporter writes, so it is as bad as "1z". */
    int hex = 0;
    for (size_t i = 0; i + 1 < len; i++)
        if (tok[i] == '0' && (tok[i + 1] == 'x' || tok[i + 1] == 'X'))
            hex = 1;
    double x = strtod_l(tok, &end, ps->c_locale);
    if (hex || end == tok || end != tok + len)
        return lr__obj_fail_at(ps, LR_ERR_INVALID,
                               "bad number '%s' in a '%s' line",
                               lr__obj_quote(tok, len).s, what);
    /* ERANGE on underflow gives a tiny but usable value; on overflow the
     * number was written finite and is merely too large. */
    if (!isfinite(x) && errno != ERANGE)
        return lr__obj_fail_at(ps, LR_ERR_INVALID,
                               "non-finite number '%s' in a '%s' line",
                               lr__obj_quote(tok, len).s, what);
    if (!isfinite(x) || fabs(x) > FLT_MAX)
        return lr__obj_fail_at(
            ps, LR_ERR_INVALID,
            "number '%s' in a '%s' line is too large for a float",
            lr__obj_quote(tok, len).s, what);
    *out = x;
    return LR_OK;
}

/* Reads between `min` and `max` numbers from the rest of the line. */
static lr_status parse_numbers(parser *ps, const char *rest, const char *what,
                               size_t min, size_t max, double *vals,
                               size_t *count)
{
    size_t n = 0;
    size_t len = 0;
    const char *tok = lr__obj_next_token(&rest, &len);
    while (tok != NULL) {
        if (n == max)
            return lr__obj_fail_at(
                ps, LR_ERR_INVALID,
                "too many numbers in a '%s' line (at most %zu)", what, max);
        lr_status st = parse_number(ps, tok, len, what, &vals[n]);
        if (st != LR_OK)
            return st;
        n++;
        tok = lr__obj_next_token(&rest, &len);
    }
    if (n < min)
        return lr__obj_fail_at(
            ps, LR_ERR_INVALID,
            "a '%s' line needs %zu numbers, this one has %zu", what, min, n);
    *count = n;
    return LR_OK;
}

static lr_status parse_vertex(parser *ps, const char *rest)
{
    /* x y z, then optionally w (rational curves; meaningless for a
     * triangle mesh) or r g b (the vertex colours MeshLab and others
     * write).  Only x y z are kept, but all must be valid numbers. */
    double vals[7];
    size_t n = 0;
    lr_status st = parse_numbers(ps, rest, "v", 3, 7, vals, &n);
    if (st != LR_OK)
        return st;
    /* Faces store vertex indices as unsigned, so more vertices than that
     * could not be referenced. */
    if (ps->n_v >= UINT_MAX)
        return lr__obj_fail_at(ps, LR_ERR_LIMIT, "more than %u vertices",
                               UINT_MAX);
    float *v = lr__obj_grow(ps->v, &ps->cap_v, 3 * (ps->n_v + 1), sizeof *v);
    if (v == NULL)
        return lr__obj_nomem(ps);
    ps->v = v;
    for (int i = 0; i < 3; i++)
        v[3 * ps->n_v + (size_t)i] = (float)vals[i];
    ps->n_v++;
    return LR_OK;
}

static lr_status parse_normal(parser *ps, const char *rest)
{
    double vals[3];
    size_t n = 0;
    lr_status st = parse_numbers(ps, rest, "vn", 3, 3, vals, &n);
    if (st != LR_OK)
        return st;
    /* Each component is at most FLT_MAX, so the squares cannot overflow
     * a double. */
    double len = sqrt(vals[0] * vals[0] + vals[1] * vals[1] +
                      vals[2] * vals[2]);
    if (!(len > 0.0))
        return lr__obj_fail_at(ps, LR_ERR_INVALID,
                               "zero-length normal; a 'vn' needs a direction");
    if (ps->n_vn > SIZE_MAX / 3 - 1)
        return lr__obj_fail_at(ps, LR_ERR_LIMIT, "too many normals");
    float *vn = lr__obj_grow(ps->vn, &ps->cap_vn, 3 * (ps->n_vn + 1),
                             sizeof *vn);
    if (vn == NULL)
        return lr__obj_nomem(ps);
    ps->vn = vn;
    for (int i = 0; i < 3; i++)
        vn[3 * ps->n_vn + (size_t)i] = (float)(vals[i] / len);
    ps->n_vn++;
    return LR_OK;
}

/* vt u [v [w]]: a texture coordinate; v defaults to 0 and w (3-D
 * textures) is checked and dropped. */
static lr_status parse_texcoord(parser *ps, const char *rest)
{
    double vals[3] = {0, 0, 0};
    size_t n = 0;
    lr_status st = parse_numbers(ps, rest, "vt", 1, 3, vals, &n);
    if (st != LR_OK)
        return st;
    if (ps->n_vt > SIZE_MAX / 2 - 1)
        return lr__obj_fail_at(ps, LR_ERR_LIMIT,
                               "too many texture coordinates");
    float *vt = lr__obj_grow(ps->vt, &ps->cap_vt, 2 * (ps->n_vt + 1),
                             sizeof *vt);
    if (vt == NULL)
        return lr__obj_nomem(ps);
    ps->vt = vt;
    vt[2 * ps->n_vt] = (float)vals[0];
    vt[2 * ps->n_vt + 1] = (float)vals[1];
    ps->n_vt++;
    return LR_OK;
}

/* Parses one logical line, already NUL-terminated. */
static lr_status parse_line(parser *ps, char *s)
{
    char *hash = strchr(s, '#');
    if (hash != NULL)
        *hash = '\0';
    const char *rest = s;
    size_t len = 0;
    const char *kw = lr__obj_next_token(&rest, &len);
    if (kw == NULL)
        return LR_OK;
    /* "1.#QNAN", "-1.#IND00", "1.#INF": NaN and infinity as old MSVC
     * printed them, read as "1." and a comment (a vertex at 1).  Only in
     * the number lines, and only those spellings: "o Part2#lid" and
     * "v 0 1 0#apex" are a name and a comment.  (hash > kw: the keyword
     * came before it.) */
    int numbers = kw[0] == 'v' &&
                  (len == 1 || (len == 2 && (kw[1] == 'n' || kw[1] == 't')));
    if (numbers && hash != NULL &&
        ((hash[-1] >= '0' && hash[-1] <= '9') || hash[-1] == '.') &&
        (strncmp(hash + 1, "QNAN", 4) == 0 ||
         strncmp(hash + 1, "SNAN", 4) == 0 ||
         strncmp(hash + 1, "IND", 3) == 0 ||
         strncmp(hash + 1, "INF", 3) == 0)) {
        *hash = '#'; /* the token whole, for the message */
        char *t = hash;
        while (t > s && t[-1] != ' ' && t[-1] != '\t')
            t--;
        size_t n = strcspn(t, " \t");
        return lr__obj_fail_at(ps, LR_ERR_INVALID,
                               "non-finite number '%s' (NaN or infinity as "
                               "old MSVC wrote them)",
                               lr__obj_quote(t, n).s);
    }
    if (len == 1 && kw[0] == 'v')
        return parse_vertex(ps, rest);
    if (len == 2 && kw[0] == 'v' && kw[1] == 'n')
        return parse_normal(ps, rest);
    if (len == 1 && kw[0] == 'f')
        return lr__obj_parse_face(ps, rest);
    if (len == 2 && kw[0] == 'v' && kw[1] == 't')
        return parse_texcoord(ps, rest);
    if (len == 6 && memcmp(kw, "usemtl", 6) == 0)
        ps->usemtl++;
    /* o, g, s, usemtl, mtllib, l, p and anything unknown carry nothing a
     * triangle mesh needs. */
    return LR_OK;
}

/* Splits the buffer into logical lines in place and parses each.  A line
 * ending in a backslash (outside a comment) continues on the next one;
 * messages then name the line where the statement began.  A backslash
 * with no line after it, on the last line or before the final newline,
 * is an error of its own (it would otherwise be read as part of the
 * statement: "bad face corner '\'"). */
static const char continuation_at_end[] =
    "line continuation '\\' at the end of the file: no line follows it";

static lr_status parse_buffer(parser *ps, char *buf, size_t len,
                              size_t *last_line)
{
    char *p = buf;
    char *end = buf + len;
    size_t line = 1;
    /* Noted now because splitting overwrites the newlines. */
    int ends_with_newline = len > 0 && buf[len - 1] == '\n';
    /* A UTF-8 byte order mark, as some Windows tools write, is no
     * statement. */
    if (len >= 3 && memcmp(p, "\xEF\xBB\xBF", 3) == 0)
        p += 3;
    while (p < end) {
        char *s = p;
        char *q = p;
        size_t start_line = line;
        int in_comment = 0;
        while (q < end) {
            unsigned char c = (unsigned char)*q;
            if (c == '\n') {
                char *b = q;
                if (b > s && b[-1] == '\r')
                    b--;
                if (!in_comment && b > s && b[-1] == '\\') {
                    if (q + 1 == end) {
                        ps->line = line;
                        return lr__obj_fail_at(ps, LR_ERR_INVALID, "%s",
                                               continuation_at_end);
                    }
                    for (char *t = b - 1; t <= q; t++)
                        *t = ' ';
                    line++;
                    q++;
                    continue;
                }
                break;
            }
            if (c == '#') {
                in_comment = 1;
            } else if (is_binary_byte(c)) {
                ps->line = line;
                return lr__obj_fail_at(
                    ps, LR_ERR_INVALID,
                    "not a text OBJ file (byte 0x%02x at offset "
                    "%zu)",
                    c, (size_t)(q - buf));
            }
            q++;
        }
        if (q == end && !in_comment) {
            char *b = q;
            if (b > s && b[-1] == '\r')
                b--;
            if (b > s && b[-1] == '\\') {
                ps->line = line;
                return lr__obj_fail_at(ps, LR_ERR_INVALID, "%s",
                                       continuation_at_end);
            }
        }
        char *next = q < end ? q + 1 : end;
        int had_newline = q < end;
        /* The buffer has one spare byte past `len`, so this is safe at the
         * end too. */
        *q = '\0';
        ps->line = start_line;
        lr_status st = parse_line(ps, s);
        if (st != LR_OK)
            return st;
        if (had_newline)
            line++;
        p = next;
    }
    /* The last line that had content: a final newline starts no line. */
    *last_line = (ends_with_newline && line > 1) ? line - 1 : line;
    return LR_OK;
}

lr_status lr__obj_load(const char *file, const char *json_path, lr__mesh *out,
                       lr_error *err)
{
    return lr__obj_load_named(file, file, json_path, out, err);
}

lr_status lr__obj_load_named(const char *file, const char *shown,
                             const char *json_path, lr__mesh *out,
                             lr_error *err)
{
    if (out != NULL)
        memset(out, 0, sizeof *out);
    if (file == NULL || out == NULL)
        return lr__fail(err, LR_ERR_INVALID, json_path,
                        "lr__obj_load: file and out must not be NULL");
    if (shown == NULL)
        shown = file;

    char *buf = NULL;
    size_t len = 0;
    lr_status st = lr__read_file(file, shown, json_path, OBJ_MAX_BYTES,
                                 "OBJ files", stop_at_binary, &buf, &len, err);
    if (st != LR_OK)
        return st;

    parser ps;
    memset(&ps, 0, sizeof ps);
    ps.file = shown;
    ps.json_path = json_path;
    ps.err = err;
    ps.all_normals = 1;
    ps.all_uvs = 1;
    /* strtod follows LC_NUMERIC, which a host program may have set to a
     * locale with a decimal comma; OBJ numbers always use a point. */
    ps.c_locale = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    if (ps.c_locale == (locale_t)0) {
        free(buf);
        return lr__fail(err, LR_ERR_NOMEM, json_path,
                        "%s: out of memory setting up the number parser",
                        shown);
    }

    size_t last_line = 1;
    st = parse_buffer(&ps, buf, len, &last_line);
    free(buf);
    freelocale(ps.c_locale);
    if (st == LR_OK && ps.n_tri == 0) {
        ps.line = last_line;
        st = lr__obj_fail_at(&ps, LR_ERR_INVALID,
                             "the file has no faces ('f' lines), so there is "
                             "nothing to render");
    }
    if (st != LR_OK) {
        parser_free(&ps);
        return st;
    }

    out->n_vertices = ps.n_v;
    out->vertices = ps.v;
    out->n_triangles = ps.n_tri;
    out->indices = ps.idx;
    out->normals = ps.all_normals ? ps.cn : NULL;
    if (!ps.all_normals)
        free(ps.cn);
    out->uvs = ps.all_uvs ? ps.cuv : NULL;
    if (!ps.all_uvs)
        free(ps.cuv);
    out->usemtl_lines = ps.usemtl;
    out->normals_lost_line = ps.n_vn > 0 ? ps.normals_lost : 0;
    out->uvs_lost_line = ps.n_vt > 0 ? ps.uvs_lost : 0;
    free(ps.vn);
    free(ps.vt);
    free(ps.corners);
    return LR_OK;
}

void lr__mesh_free(lr__mesh *m)
{
    if (m == NULL)
        return;
    free(m->vertices);
    free(m->indices);
    free(m->normals);
    free(m->uvs);
    memset(m, 0, sizeof *m);
}
