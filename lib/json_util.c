/*
 * json_util.c: typed, path-naming access to cJSON values.
 */
#include "json_util.h"

#include <errno.h>
#include <math.h>
#include <stdatomic.h>
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

/* Every key and string of a parsed document must be UTF-8 (RFC 8259);
 * cJSON passes any bytes through. */
static lr_status check_utf8(const cJSON *v, const char *path, lr_error *err)
{
    char p[LR__PATH_MAX];
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
        LR_TRY(check_utf8(c, p, err));
    }
    return LR_OK;
}

void lr__json_describe(const cJSON *v, char *out, size_t n)
{
    if (v == NULL)
        snprintf(out, n, "nothing");
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
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be a finite number, got %g", p,
                        v->valuedouble);
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

/* ---- what cJSON would accept ------------------------------------------
 * cJSON returns NULL both for text that is not JSON and when one of its
 * allocations fails, and does not say which.  When it returns NULL, this
 * scan, which allocates nothing, decides: text that cJSON's grammar
 * accepts failed for lack of memory.  It follows cJSON 1.7's parser
 * (parse_value, parse_string, utf16_literal_to_utf8, parse_number,
 * parse_array, parse_object, buffer_skip_whitespace, skip_utf8_bom) step
 * by step, quirks included: any byte up to 32 is white space, "\uZZZZ"
 * reads as U+0000, lone surrogates are refused.  Where cJSON versions
 * differ (numbers over 63 characters: cut at 63 before 1.7.18, whole
 * since and in Debian's 1.7.15 since its fix of CVE-2023-26819), the
 * cJSON in use is asked once (cjson_long_numbers).  The fuzz targets
 * check that the scan and cJSON agree on every input they try.
 *
 * Why not cJSON_InitHooks with an allocator that records failures: the
 * hooks are one global setting of the process, shared with the
 * application (lensrayd, tests/oom and any program that links both use
 * cJSON themselves), not safe to change while another thread parses, and
 * replacing an application's hooks would free its blocks with the wrong
 * allocator.  This scan needs no global state and works whatever hooks
 * are installed. */
typedef struct json_scan {
    const unsigned char *s;
    size_t len, off, depth;
} json_scan;

static int scan_can(const json_scan *b, size_t i) { return b->off + i < b->len; }

static void scan_ws(json_scan *b)
{
    if (!scan_can(b, 0))
        return;
    while (scan_can(b, 0) && b->s[b->off] <= 32)
        b->off++;
    if (b->off == b->len)
        b->off--;
}

/* parse_hex4: 0 for any digit that is not hexadecimal. */
static unsigned scan_hex4(const unsigned char *p)
{
    unsigned h = 0;
    for (int i = 0; i < 4; i++) {
        unsigned c = p[i], d;
        if (c >= '0' && c <= '9')
            d = c - '0';
        else if (c >= 'A' && c <= 'F')
            d = c - 'A' + 10;
        else if (c >= 'a' && c <= 'f')
            d = c - 'a' + 10;
        else
            return 0;
        h = (h << 4) | d;
    }
    return h;
}

/* Length of the \u escape (6 or 12) at p, before `end`; 0 if refused. */
static size_t scan_utf16(const unsigned char *p, const unsigned char *end)
{
    if (end - p < 6)
        return 0;
    unsigned first = scan_hex4(p + 2);
    if (first >= 0xDC00 && first <= 0xDFFF)
        return 0;
    if (first < 0xD800 || first > 0xDBFF)
        return 6;
    const unsigned char *q = p + 6;
    if (end - q < 6 || q[0] != '\\' || q[1] != 'u')
        return 0;
    unsigned second = scan_hex4(q + 2);
    return second >= 0xDC00 && second <= 0xDFFF ? 12 : 0;
}

static int scan_string(json_scan *b)
{
    if (!scan_can(b, 0) || b->s[b->off] != '"')
        return 0;
    const unsigned char *start = b->s + b->off + 1, *end = start;
    while ((size_t)(end - b->s) < b->len && *end != '"') {
        if (*end == '\\') {
            if ((size_t)(end + 1 - b->s) >= b->len)
                return 0;
            end++;
        }
        end++;
    }
    if ((size_t)(end - b->s) >= b->len || *end != '"')
        return 0;
    for (const unsigned char *p = start; p < end;) {
        if (*p != '\\') {
            p++;
            continue;
        }
        size_t n = 2;
        switch (p[1]) {
        case 'b': case 'f': case 'n': case 'r': case 't':
        case '"': case '\\': case '/':
            break;
        case 'u':
            n = scan_utf16(p, end);
            if (n == 0)
                return 0;
            break;
        default:
            return 0;
        }
        p += n;
    }
    b->off = (size_t)(end - b->s) + 1;
    return 1;
}

static int scan_digit(unsigned char c) { return c >= '0' && c <= '9'; }

/* 1 if the cJSON in use reads a number of any length, 0 if it reads 63
 * characters at most (or is not known to read more: a failed allocation
 * looks the same, so only the answer 1 is kept).  A number cut at 63
 * leaves characters that no JSON can follow it with, inside an array or
 * an object, so what the cut accepts, the whole reading accepts too:
 * when in doubt, the scan cuts. */
static atomic_int long_numbers = -1;

static int cjson_long_numbers(void)
{
    if (atomic_load(&long_numbers) == 1)
        return 1;
    static const char probe[] =
        "[0000000000000000000000000000000000000000000000000000000000000000]";
    cJSON *v = cJSON_ParseWithLength(probe, sizeof probe - 1);
    if (v == NULL)
        return 0;
    cJSON_Delete(v);
    atomic_store(&long_numbers, 1);
    return 1;
}

/* parse_number: the run of [0-9+-eE.] goes to strtod, which takes the
 * longest prefix that is a decimal number; nothing taken is an error. */
static int scan_number(json_scan *b)
{
    const unsigned char *s = b->s + b->off;
    size_t n = 0;
    while (scan_can(b, n) && s[n] != '\0' &&
           strchr("0123456789+-eE.", s[n]) != NULL)
        n++;
    if (n > 63 && !cjson_long_numbers())
        n = 63;
    size_t i = 0, digits = 0;
    if (i < n && (s[i] == '+' || s[i] == '-'))
        i++;
    for (; i < n && scan_digit(s[i]); i++)
        digits++;
    if (i < n && s[i] == '.')
        for (i++; i < n && scan_digit(s[i]); i++)
            digits++;
    if (digits == 0)
        return 0;
    if (i < n && (s[i] == 'e' || s[i] == 'E')) {
        size_t j = i + 1;
        if (j < n && (s[j] == '+' || s[j] == '-'))
            j++;
        if (j < n && scan_digit(s[j])) {
            while (j < n && scan_digit(s[j]))
                j++;
            i = j;
        }
    }
    b->off += i;
    return 1;
}

static int scan_value(json_scan *b);

/* parse_array and parse_object: `close` is ']' or '}'. */
static int scan_container(json_scan *b, unsigned char close)
{
    if (b->depth >= CJSON_NESTING_LIMIT)
        return 0;
    b->depth++;
    b->off++;
    scan_ws(b);
    if (!scan_can(b, 0) || b->s[b->off] != close) {
        if (!scan_can(b, 0))
            return 0;
        b->off--;
        do {
            b->off++;
            scan_ws(b);
            if (close == '}') {
                if (!scan_string(b))
                    return 0;
                scan_ws(b);
                if (!scan_can(b, 0) || b->s[b->off] != ':')
                    return 0;
                b->off++;
                scan_ws(b);
            }
            if (!scan_value(b))
                return 0;
            scan_ws(b);
        } while (scan_can(b, 0) && b->s[b->off] == ',');
        if (!scan_can(b, 0) || b->s[b->off] != close)
            return 0;
    }
    b->depth--;
    b->off++;
    return 1;
}

static int scan_literal(json_scan *b, const char *word)
{
    size_t n = strlen(word);
    if (b->off + n > b->len || memcmp(b->s + b->off, word, n) != 0)
        return 0;
    b->off += n;
    return 1;
}

static int scan_value(json_scan *b)
{
    if (scan_literal(b, "null") || scan_literal(b, "false") ||
        scan_literal(b, "true"))
        return 1;
    if (!scan_can(b, 0))
        return 0;
    unsigned char c = b->s[b->off];
    if (c == '"')
        return scan_string(b);
    if (c == '-' || scan_digit(c))
        return scan_number(b);
    if (c == '[')
        return scan_container(b, ']');
    if (c == '{')
        return scan_container(b, '}');
    return 0;
}

int lr__json_cjson_accepts(const char *text, size_t len,
                           int require_null_terminated)
{
    if (text == NULL || len == 0)
        return 0;
    json_scan b = {(const unsigned char *)text, len, 0, 0};
    if (len > 4 && memcmp(text, "\xEF\xBB\xBF", 3) == 0)
        b.off = 3;
    scan_ws(&b);
    if (!scan_value(&b))
        return 0;
    if (require_null_terminated) {
        scan_ws(&b);
        if (b.off >= len || text[b.off] != '\0')
            return 0;
    }
    return 1;
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
                         cJSON **out, lr_error *err)
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
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (root == NULL && lr__json_cjson_accepts(text, len, 0))
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
    lr_status st = check_utf8(root, "", err);
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
    cJSON *value = cJSON_ParseWithOpts(text, NULL, 1);
    if (value != NULL && nul_escape_at(text, strlen(text)) < strlen(text)) {
        cJSON_Delete(value);
        return lr__fail(err, LR_ERR_INVALID, path,
                        "override %s: \\u0000 (a NUL character) is not "
                        "allowed in a string",
                        path);
    }
    if (value == NULL && lr__json_cjson_accepts(text, strlen(text) + 1, 1))
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "override %s: out of memory parsing its value", path);
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
