/*
 * json_util.c: typed, path-naming access to cJSON values; JSON paths;
 * UTF-8 checks.  Parsing text into checked trees is json_parse.c.
 */
#include "json/json_util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


const char *const lr__sampler_names[] = {"random", "grid", "jittered", "sobol",
                                         NULL};
int lr__sampler_count(void)
{
    int n = 0;
    while (lr__sampler_names[n] != NULL)
        n++;
    return n;
}

const char *const lr__chroma_mode_names[] = {"off", "rgb", "spectral", NULL};
const char *const lr__focal_model_names[] = {"paper", "lensmaker", NULL};
const char *const lr__glass_names[] = {"BK7", "F2", "SF11", "fused_silica",
                                       NULL};

void lr__path_key(char out[LR__PATH_MAX], const char *parent, const char *key)
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
    lr__trim_partial_utf8(out, LR__PATH_MAX,
                          snprintf(out, LR__PATH_MAX, "%s[%zu]", parent, i));
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
void lr__utf8_escape(const char *s, char *out, size_t cap)
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

lr_status lr__json_object(const cJSON *v, const char *path, const char *hint,
                          lr_error *err)
{
    if (cJSON_IsObject(v))
        return LR_OK;
    char want[256];
    snprintf(want, sizeof want, "an object%s", hint);
    return type_error(path, want, v, err);
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
                        "for a double",
                        p);
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
static lr_status get_number(const cJSON *obj, const char *key, const char *path,
                            int required, int limit, double *out, lr_error *err)
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

lr_status lr__json_number(const cJSON *obj, const char *key, const char *path,
                          int required, double *out, lr_error *err)
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
                        "%s must be between %lld and %lld, got %.17g", p, min,
                        max, d);
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

lr_status lr__json_string(const cJSON *obj, const char *key, const char *path,
                          int required, const char **out, lr_error *err)
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
    return lr__fail(err, LR_ERR_INVALID, p,
                    "%s must be one of %s, got \"%.*s\"", p, list,
                    lr__utf8_prefix(v, 60), v);
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
        lr_status st = numbers(v, p, a, "a number or an array of 3 numbers",
                               err);
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
