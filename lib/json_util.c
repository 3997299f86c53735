/*
 * json_util.c: typed, path-naming access to cJSON values.
 */
#include "json_util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Deeper nesting than any scene needs; checked before cJSON recurses. */
#define MAX_NESTING 64

void lr__path_key(char out[LR__PATH_MAX], const char *parent,
                  const char *key)
{
    int w;
    if (parent == NULL || parent[0] == '\0')
        w = snprintf(out, LR__PATH_MAX, "%s", key);
    else
        w = snprintf(out, LR__PATH_MAX, "%s.%s", parent, key);
    /* A path longer than LR__PATH_MAX is cut, never inside a character
     * (keys may be any text). */
    lr__trim_partial_utf8(out, LR__PATH_MAX, w);
}

void lr__path_index(char out[LR__PATH_MAX], const char *parent, size_t i)
{
    lr__trim_partial_utf8(
        out, LR__PATH_MAX, snprintf(out, LR__PATH_MAX, "%s[%zu]", parent, i));
}

/* Length of the valid UTF-8 sequence starting at s (1 to 4), or 0 when
 * the bytes there are not one (RFC 3629: no overlong forms, no UTF-16
 * surrogates, nothing beyond U+10FFFF; a NUL ends the text). */
static size_t utf8_char(const unsigned char *s)
{
    unsigned c = s[0];
    size_t n;
    unsigned min;
    if (c < 0x80)
        return 1;
    if (c >= 0xC2 && c <= 0xDF)
        n = 1, min = 0x80;
    else if (c >= 0xE0 && c <= 0xEF)
        n = 2, min = 0x800;
    else if (c >= 0xF0 && c <= 0xF4)
        n = 3, min = 0x10000;
    else
        return 0;
    unsigned cp = c & (0x3Fu >> n);
    for (size_t i = 1; i <= n; i++) {
        if ((s[i] & 0xC0) != 0x80)
            return 0;
        cp = (cp << 6) | (s[i] & 0x3Fu);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF))
        return 0;
    return n + 1;
}

size_t lr__utf8_invalid_at(const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    size_t i = 0;
    while (p[i] != '\0') {
        size_t n = utf8_char(p + i);
        if (n == 0)
            return i;
        i += n;
    }
    return (size_t)-1;
}

int lr__utf8_prefix(const char *s, int max)
{
    const unsigned char *p = (const unsigned char *)s;
    int i = 0;
    while (i < max && p[i] != '\0') {
        size_t n = utf8_char(p + i);
        if (n == 0)
            n = 1; /* not UTF-8 anyway: count bytes */
        if (i + (int)n > max)
            break;
        i += (int)n;
    }
    return i;
}

/* `s` with every byte that is not part of valid UTF-8 written as \xNN,
 * so that a bad key can still be named in a path and a message. */
static void utf8_escape(const char *s, char *out, size_t cap)
{
    const unsigned char *p = (const unsigned char *)s;
    size_t o = 0;
    while (*p != '\0' && o + 5 < cap) {
        size_t n = utf8_char(p);
        if (n == 0) {
            o += (size_t)snprintf(out + o, cap - o, "\\x%02x", *p);
            p++;
        } else {
            if (o + n >= cap)
                break;
            memcpy(out + o, p, n);
            o += n;
            p += n;
        }
    }
    out[o] = '\0';
}

/* The k-th number (from 0) of JSON text that cJSON accepted, and its
 * length in *n; NULL if there is none.  Outside strings, a number is a
 * run of [0-9+-.eE] that starts with '-' or a digit. */
static const char *nth_number(const char *text, size_t len, size_t k,
                              size_t *n)
{
    int in_str = 0;
    for (size_t i = 0; i < len; i++) {
        char c = text[i];
        if (in_str) {
            if (c == '\\')
                i++;
            else if (c == '"')
                in_str = 0;
        } else if (c == '"') {
            in_str = 1;
        } else if (c == '-' || (c >= '0' && c <= '9')) {
            size_t j = i;
            while (j < len && text[j] != '\0' &&
                   strchr("0123456789+-.eE", text[j]) != NULL)
                j++;
            if (k == 0) {
                *n = j - i;
                return text + i;
            }
            k--;
            i = j - 1;
        }
    }
    return NULL;
}

/* A parsed document, walked by check_values. */
typedef struct value_walk {
    const char *text; /* what it was parsed from, len bytes */
    size_t len;
    size_t numbers; /* numbers passed so far, in document order */
} value_walk;

/* Every key and string of a parsed document must be UTF-8 (RFC 8259);
 * cJSON passes any bytes through.  Every number must be finite: cJSON
 * reads a number too large for a double (1e400) as infinity, which is
 * refused here, as written, whatever field it is in. */
static lr_status check_values(const cJSON *v, const char *path,
                              value_walk *w, lr_error *err)
{
    char p[LR__PATH_MAX];
    if (cJSON_IsNumber(v)) {
        if (isfinite(v->valuedouble)) {
            w->numbers++;
            return LR_OK;
        }
        /* The tree and the text list their numbers in the same order. */
        size_t n = 0;
        const char *lit = nth_number(w->text, w->len, w->numbers, &n);
        if (lit == NULL) { /* not for text that cJSON accepted */
            lit = "";
            n = 0;
        }
        return lr__fail(err, LR_ERR_INVALID, path,
                        "%s: the number %.*s%s is out of range (larger "
                        "than any finite double, about 1.8e308)",
                        path[0] ? path : "the JSON value",
                        (int)(n > 40 ? 40 : n), lit, n > 40 ? "..." : "");
    }
    if (cJSON_IsString(v)) {
        size_t at = lr__utf8_invalid_at(v->valuestring);
        if (at != (size_t)-1)
            return lr__fail(err, LR_ERR_INVALID, path,
                            "%s: the string is not valid UTF-8 (byte 0x%02x "
                            "at offset %zu)",
                            path[0] ? path : "the JSON value",
                            (unsigned char)v->valuestring[at], at);
        return LR_OK;
    }
    size_t i = 0;
    for (const cJSON *c = v->child; c != NULL; c = c->next, i++) {
        if (cJSON_IsObject(v)) {
            const char *k = c->string ? c->string : "";
            size_t at = lr__utf8_invalid_at(k);
            if (at != (size_t)-1) {
                char shown[LR__PATH_MAX];
                utf8_escape(k, shown, sizeof shown);
                lr__path_key(p, path, shown);
                return lr__fail(err, LR_ERR_INVALID, p,
                                "%s: the key is not valid UTF-8 (byte 0x%02x "
                                "at offset %zu)",
                                p, (unsigned char)k[at], at);
            }
            lr__path_key(p, path, k);
        } else {
            lr__path_index(p, path, i);
        }
        LR_TRY(check_values(c, p, w, err));
    }
    return LR_OK;
}

void lr__json_describe(const cJSON *v, char *out, size_t n)
{
    if (v == NULL)
        snprintf(out, n, "nothing");
    else if (cJSON_IsNumber(v) && isinf(v->valuedouble))
        snprintf(out, n, "a number too large for a double");
    else if (cJSON_IsNumber(v))
        snprintf(out, n, "%.17g", v->valuedouble);
    else if (cJSON_IsString(v))
        snprintf(out, n, "the string \"%.*s%s\"",
                 lr__utf8_prefix(v->valuestring, 40), v->valuestring,
                 strlen(v->valuestring) > 40 ? "..." : "");
    else if (cJSON_IsBool(v))
        snprintf(out, n, "%s", cJSON_IsTrue(v) ? "true" : "false");
    else if (cJSON_IsNull(v))
        snprintf(out, n, "null");
    else if (cJSON_IsArray(v))
        snprintf(out, n, "an array of %d", cJSON_GetArraySize(v));
    else if (cJSON_IsObject(v))
        snprintf(out, n, "an object");
    else
        snprintf(out, n, "an invalid value");
}

static lr_status type_error(const char *path, const char *want,
                            const cJSON *got, lr_error *err)
{
    char desc[96];
    lr__json_describe(got, desc, sizeof desc);
    return lr__fail(err, LR_ERR_INVALID, path, "%s must be %s, got %s", path,
                    want, desc);
}

lr_status lr__json_check_keys(const cJSON *obj, const char *path,
                              const char *const *allowed, lr_error *err)
{
    char p[LR__PATH_MAX];
    for (const cJSON *c = obj->child; c != NULL; c = c->next) {
        const char *k = c->string ? c->string : "";
        int ok = 0;
        for (size_t i = 0; allowed[i] != NULL; i++)
            if (strcmp(k, allowed[i]) == 0)
                ok = 1;
        lr__path_key(p, path, k);
        if (!ok) {
            char list[512] = "";
            size_t used = 0;
            for (size_t i = 0; allowed[i] != NULL && used < sizeof list; i++)
                used += (size_t)snprintf(list + used, sizeof list - used,
                                         "%s%s", i ? ", " : "", allowed[i]);
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s: unknown key \"%s\" (expected one of: %s)", p,
                            k, list);
        }
        for (const cJSON *d = c->next; d != NULL; d = d->next)
            if (d->string && strcmp(d->string, k) == 0)
                return lr__fail(err, LR_ERR_INVALID, p,
                                "%s: duplicate key \"%s\"", p, k);
    }
    return LR_OK;
}

static const cJSON *member(const cJSON *obj, const char *key)
{
    return cJSON_GetObjectItemCaseSensitive(obj, key);
}

lr_status lr__json_check_number(double x, const char *p, lr_error *err)
{
    /* (A tree from lr__json_parse has no infinity: cJSON's reading of a
     * number too large for a double is refused there, as written.) */
    if (isinf(x))
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be a finite number, got a number too large "
                        "for a double", p);
    if (!isfinite(x))
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be a finite number, got %g", p, x);
    if (fabs(x) > LR__MAX_NUMBER)
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be between -1e15 and 1e15, got %g", p, x);
    return LR_OK;
}

/* Looks obj.key up and writes its path to p.  A missing key is an error
 * when required; otherwise LR_OK with *v = NULL. */
static lr_status find(const cJSON *obj, const char *key, const char *path,
                      int required, char p[LR__PATH_MAX], const cJSON **v,
                      lr_error *err)
{
    lr__path_key(p, path, key);
    *v = member(obj, key);
    if (*v == NULL && required)
        return lr__fail(err, LR_ERR_INVALID, p, "%s is required", p);
    return LR_OK;
}

/* The number at obj.key; `limit` applies LR__MAX_NUMBER (integers have
 * their own ranges instead). */
static lr_status get_number(const cJSON *obj, const char *key,
                            const char *path, int required, int limit,
                            double *out, lr_error *err)
{
    char p[LR__PATH_MAX];
    const cJSON *v;
    LR_TRY(find(obj, key, path, required, p, &v, err));
    if (v == NULL)
        return LR_OK;
    if (!cJSON_IsNumber(v))
        return type_error(p, "a number", v, err);
    if (!isfinite(v->valuedouble))
        return type_error(p, "a finite number", v, err);
    if (limit)
        LR_TRY(lr__json_check_number(v->valuedouble, p, err));
    *out = v->valuedouble;
    return LR_OK;
}

lr_status lr__json_number(const cJSON *obj, const char *key,
                          const char *path, int required, double *out,
                          lr_error *err)
{
    return get_number(obj, key, path, required, 1, out, err);
}

lr_status lr__json_int(const cJSON *obj, const char *key, const char *path,
                       int required, long long min, long long max,
                       long long *out, lr_error *err)
{
    char p[LR__PATH_MAX];
    double d = 0;
    const cJSON *v;
    LR_TRY(find(obj, key, path, required, p, &v, err));
    if (v == NULL)
        return LR_OK;
    lr_status st = get_number(obj, key, path, 1, 0, &d, err);
    if (st != LR_OK)
        return st;
    if (d != floor(d))
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be a whole number, got %.17g", p, d);
    if (d < (double)min || d > (double)max)
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be between %lld and %lld, got %.17g", p,
                        min, max, d);
    *out = (long long)d;
    return LR_OK;
}

lr_status lr__json_bool(const cJSON *obj, const char *key, const char *path,
                        int required, int *out, lr_error *err)
{
    char p[LR__PATH_MAX];
    const cJSON *v;
    LR_TRY(find(obj, key, path, required, p, &v, err));
    if (v == NULL)
        return LR_OK;
    if (!cJSON_IsBool(v))
        return type_error(p, "true or false", v, err);
    *out = cJSON_IsTrue(v);
    return LR_OK;
}

lr_status lr__json_string(const cJSON *obj, const char *key,
                          const char *path, int required, const char **out,
                          lr_error *err)
{
    char p[LR__PATH_MAX];
    const cJSON *v;
    LR_TRY(find(obj, key, path, required, p, &v, err));
    if (v == NULL)
        return LR_OK;
    if (!cJSON_IsString(v))
        return type_error(p, "a string", v, err);
    *out = v->valuestring;
    return LR_OK;
}

lr_status lr__json_enum(const cJSON *obj, const char *key, const char *path,
                        const char *const *names, int *out, lr_error *err)
{
    const char *v = NULL;
    lr_status st = lr__json_string(obj, key, path, 0, &v, err);
    if (st != LR_OK || v == NULL)
        return st;
    char list[256] = "";
    size_t used = 0;
    for (int i = 0; names[i] != NULL; i++) {
        if (strcmp(v, names[i]) == 0) {
            *out = i;
            return LR_OK;
        }
        if (used < sizeof list)
            used += (size_t)snprintf(list + used, sizeof list - used,
                                     "%s\"%s\"", i ? ", " : "", names[i]);
    }
    char p[LR__PATH_MAX];
    lr__path_key(p, path, key);
    return lr__fail(err, LR_ERR_INVALID, p, "%s must be one of %s, got \"%.*s\"",
                    p, list, lr__utf8_prefix(v, 60), v);
}

static lr_status numbers(const cJSON *v, const char *p, double *out,
                         const char *want, lr_error *err)
{
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return type_error(p, want, v, err);
    int i = 0;
    for (const cJSON *c = v->child; c != NULL; c = c->next, i++) {
        char pi[LR__PATH_MAX];
        lr__path_index(pi, p, (size_t)i);
        if (!cJSON_IsNumber(c))
            return type_error(pi, "a number", c, err);
        LR_TRY(lr__json_check_number(c->valuedouble, pi, err));
        out[i] = c->valuedouble;
    }
    return LR_OK;
}

lr_status lr__json_vec3(const cJSON *obj, const char *key, const char *path,
                        int required, lr__v3 *out, lr_error *err)
{
    char p[LR__PATH_MAX];
    const cJSON *v;
    LR_TRY(find(obj, key, path, required, p, &v, err));
    if (v == NULL)
        return LR_OK;
    double a[3];
    lr_status st = numbers(v, p, a, "an array of 3 numbers", err);
    if (st == LR_OK)
        *out = v3a(a);
    return st;
}

lr_status lr__json_rgb(const cJSON *obj, const char *key, const char *path,
                       int required, lr__v3 *out, lr_error *err)
{
    char p[LR__PATH_MAX];
    const cJSON *v;
    LR_TRY(find(obj, key, path, required, p, &v, err));
    if (v == NULL)
        return LR_OK;
    double a[3];
    if (cJSON_IsNumber(v)) {
        LR_TRY(lr__json_check_number(v->valuedouble, p, err));
        a[0] = a[1] = a[2] = v->valuedouble;
    } else {
        lr_status st =
            numbers(v, p, a, "a number or an array of 3 numbers", err);
        if (st != LR_OK)
            return st;
    }
    for (int i = 0; i < 3; i++)
        if (a[i] < 0.0)
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s must not be negative, got %g", p, a[i]);
    *out = v3a(a);
    return LR_OK;
}

/* Counts bracket depth outside strings, so that hostile input cannot make
 * cJSON recurse deeply (cJSON has its own limit, but a clear message about
 * nesting is better than a generic syntax error). */
static int too_deep(const char *s, size_t len)
{
    int depth = 0, in_str = 0;
    for (size_t i = 0; i < len; i++) {
        char c = s[i];
        if (in_str) {
            if (c == '\\')
                i++;
            else if (c == '"')
                in_str = 0;
        } else if (c == '"') {
            in_str = 1;
        } else if (c == '[' || c == '{') {
            if (++depth > MAX_NESTING)
                return 1;
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
    return 0;
}

/* The offset of the first \u0000 escape inside a string, or len.  cJSON
 * decodes it to a NUL that silently ends the string ("pinhole\u0000x"
 * would read as "pinhole"), so such text is refused instead. */
static size_t nul_escape_at(const char *s, size_t len)
{
    int in_str = 0;
    for (size_t i = 0; i < len; i++) {
        char c = s[i];
        if (in_str) {
            if (c == '\\') {
                if (i + 5 < len && memcmp(s + i + 1, "u0000", 5) == 0)
                    return i;
                i++;
            } else if (c == '"') {
                in_str = 0;
            }
        } else if (c == '"') {
            in_str = 1;
        }
    }
    return len;
}

/* ---- cJSON's allocations ---------------------------------------------
 * cJSON returns NULL both for text that is not JSON and when one of its
 * allocations fails, and does not say which.  So the library gives cJSON
 * an allocator that is malloc, and that, when malloc fails, says so in a
 * flag of the calling thread: a parse that returns NULL with the flag set
 * ran out of memory; without it, the text is not JSON.
 *
 * The hooks are one setting for the whole process, which other code may
 * share (lensrayd uses cJSON too), so they are installed once, by a
 * constructor that runs when the library is loaded, before main and
 * before any thread could be parsing; and they are malloc and free
 * themselves, so other cJSON users in the process allocate as they did.
 * (cJSON then grows printed text by malloc and copy instead of realloc.)
 * The flag is thread-local, so parses on other threads cannot touch it.
 * A program that installs its own hooks after loading the library takes
 * cJSON's allocations over, and with them this knowledge: its allocation
 * failures during a parse then read as syntax errors. */
static _Thread_local int cjson_alloc_failed;

static void *cjson_malloc(size_t n)
{
    void *p = malloc(n);
    if (p == NULL)
        cjson_alloc_failed = 1;
    return p;
}

static void cjson_free(void *p) { free(p); }

__attribute__((constructor)) static void install_cjson_hooks(void)
{
    cJSON_Hooks h = {cjson_malloc, cjson_free};
    cJSON_InitHooks(&h);
}

/* cJSON_ParseWithLengthOpts that also says, when it returns NULL, whether
 * an allocation failed (*nomem = 1) rather than the text. */
static cJSON *parse(const char *text, size_t len, const char **end,
                    int require_null_terminated, int *nomem)
{
    cjson_alloc_failed = 0;
    cJSON *v = cJSON_ParseWithLengthOpts(text, len, end,
                                         require_null_terminated);
    *nomem = v == NULL && cjson_alloc_failed;
    return v;
}

/* 1-based line and column (in bytes) of offset `off`. */
static void line_col(const char *text, size_t off, size_t *line, size_t *col)
{
    *line = 1;
    *col = 1;
    for (size_t i = 0; i < off; i++) {
        if (text[i] == '\n') {
            (*line)++;
            *col = 1;
        } else {
            (*col)++;
        }
    }
}

lr_status lr__json_parse(const char *text, size_t len, const char *what,
                         const char *path, cJSON **out, lr_error *err)
{
    *out = NULL;
    size_t line, col;
    if (too_deep(text, len))
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: JSON nested deeper than %d levels", what,
                        MAX_NESTING);
    if (memchr(text, '\0', len) != NULL)
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: JSON text contains a NUL byte", what);
    const char *end = NULL;
    int nomem;
    cJSON *root = parse(text, len, &end, 0, &nomem);
    if (nomem)
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "%s: out of memory parsing the JSON text", what);
    if (root == NULL) {
        /* cJSON reports where it stopped; turn that into line:column. */
        const char *at = end ? end : cJSON_GetErrorPtr();
        size_t off = at && at >= text && at <= text + len ? (size_t)(at - text)
                                                           : 0;
        line_col(text, off, &line, &col);
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: invalid JSON at line %zu, column %zu", what,
                        line, col);
    }
    /* cJSON stops after the first value; anything but white space after
     * it means the text is not one JSON document. */
    size_t off = end ? (size_t)(end - text) : len;
    while (off < len && (text[off] == ' ' || text[off] == '\t' ||
                         text[off] == '\n' || text[off] == '\r'))
        off++;
    if (off < len) {
        cJSON_Delete(root);
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: unexpected text after the JSON value at byte %zu",
                        what, off);
    }
    off = nul_escape_at(text, len);
    if (off < len) {
        cJSON_Delete(root);
        line_col(text, off, &line, &col);
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: \\u0000 (a NUL character) is not allowed in a "
                        "string, at line %zu, column %zu",
                        what, line, col);
    }
    value_walk w = {text, len, 0};
    lr_status st = check_values(root, path, &w, err);
    if (st != LR_OK) {
        cJSON_Delete(root);
        return st;
    }
    *out = root;
    return LR_OK;
}

/* ---- overrides -------------------------------------------------------- */

lr_status lr__json_apply_override(cJSON *root, const char *assignment,
                                  lr_error *err)
{
    size_t bad = lr__utf8_invalid_at(assignment);
    if (bad != (size_t)-1)
        return lr__fail(err, LR_ERR_INVALID, "",
                        "override: the text is not valid UTF-8 (byte 0x%02x "
                        "at offset %zu)",
                        (unsigned char)assignment[bad], bad);
    const char *eq = strchr(assignment, '=');
    if (eq == NULL || eq == assignment)
        return lr__fail(err, LR_ERR_INVALID, "",
                        "override \"%s\" must look like path=value, e.g. "
                        "camera.fov=30",
                        assignment);
    size_t plen = (size_t)(eq - assignment);
    if (plen >= LR__PATH_MAX)
        return lr__fail(err, LR_ERR_INVALID, "", "override path too long");
    char path[LR__PATH_MAX];
    memcpy(path, assignment, plen);
    path[plen] = '\0';
    const char *text = eq + 1;

    /* The whole value must be JSON to count as JSON: "30deg" is the
     * string "30deg", not the number 30. */
    int nomem;
    cJSON *value = parse(text, strlen(text) + 1, NULL, 1, &nomem);
    if (value != NULL && nul_escape_at(text, strlen(text)) < strlen(text)) {
        cJSON_Delete(value);
        return lr__fail(err, LR_ERR_INVALID, path,
                        "override %s: \\u0000 (a NUL character) is not "
                        "allowed in a string",
                        path);
    }
    if (nomem)
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "override %s: out of memory parsing its value", path);
    if (value != NULL) {
        value_walk w = {text, strlen(text), 0};
        lr_status st = check_values(value, path, &w, err);
        if (st != LR_OK) {
            cJSON_Delete(value);
            return st;
        }
    }
    if (value == NULL)
        value = cJSON_CreateString(text);
    if (value == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");

    /* Walk the path: segments separated by '.', each a key optionally
     * followed by [index] parts. */
    cJSON *node = root;
    char done[LR__PATH_MAX] = "";
    const char *s = path;
    while (*s) {
        char key[LR__PATH_MAX];
        size_t k = 0;
        while (*s && *s != '.' && *s != '[' && k + 1 < sizeof key)
            key[k++] = *s++;
        key[k] = '\0';
        if (k == 0 && *s != '[') {
            cJSON_Delete(value);
            return lr__fail(err, LR_ERR_INVALID, path,
                            "override path \"%s\" has an empty part", path);
        }
        if (k > 0) {
            char next[LR__PATH_MAX];
            lr__path_key(next, done, key);
            if (!cJSON_IsObject(node)) {
                cJSON_Delete(value);
                return lr__fail(err, LR_ERR_INVALID, path,
                                "override %s: %s is not an object", path,
                                done[0] ? done : "the scene");
            }
            int last = *s == '\0';
            cJSON *child = cJSON_GetObjectItemCaseSensitive(node, key);
            if (last) {
                /* Remove and add rather than replace: cJSON's replace
                 * does not check its copy of the key (a failed copy
                 * leaves a member without a name), while its add does.
                 * On failure the value is still ours to free. */
                if (child != NULL)
                    cJSON_DeleteItemFromObjectCaseSensitive(node, key);
                if (!cJSON_AddItemToObject(node, key, value)) {
                    cJSON_Delete(value);
                    return lr__fail(err, LR_ERR_NOMEM, NULL,
                                    "out of memory");
                }
                return LR_OK;
            }
            if (child == NULL) {
                child = cJSON_AddObjectToObject(node, key);
                if (child == NULL) {
                    cJSON_Delete(value);
                    return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
                }
            }
            node = child;
            snprintf(done, sizeof done, "%s", next);
        }
        while (*s == '[') {
            char *end = NULL;
            errno = 0;
            long idx = strtol(s + 1, &end, 10);
            if (end == s + 1 || *end != ']' || errno != 0 || idx < 0) {
                cJSON_Delete(value);
                return lr__fail(err, LR_ERR_INVALID, path,
                                "override path \"%s\": bad array index", path);
            }
            s = end + 1;
            if (!cJSON_IsArray(node) || idx >= cJSON_GetArraySize(node)) {
                cJSON_Delete(value);
                return lr__fail(err, LR_ERR_INVALID, path,
                                "override %s: %s has no element %ld", path,
                                done[0] ? done : "the scene", idx);
            }
            char next[LR__PATH_MAX];
            lr__path_index(next, done, (size_t)idx);
            snprintf(done, sizeof done, "%s", next);
            if (*s == '\0') {
                cJSON_ReplaceItemInArray(node, (int)idx, value);
                return LR_OK;
            }
            node = cJSON_GetArrayItem(node, (int)idx);
        }
        if (*s == '.')
            s++;
        else if (*s != '\0' && *s != '[') {
            cJSON_Delete(value);
            return lr__fail(err, LR_ERR_INVALID, path,
                            "override path \"%s\" is malformed", path);
        }
    }
    cJSON_Delete(value);
    return lr__fail(err, LR_ERR_INVALID, path,
                    "override path \"%s\" is malformed", path);
}
