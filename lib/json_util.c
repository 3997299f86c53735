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
    if (parent == NULL || parent[0] == '\0')
        snprintf(out, LR__PATH_MAX, "%s", key);
    else
        snprintf(out, LR__PATH_MAX, "%s.%s", parent, key);
}

void lr__path_index(char out[LR__PATH_MAX], const char *parent, size_t i)
{
    snprintf(out, LR__PATH_MAX, "%s[%zu]", parent, i);
}

void lr__json_describe(const cJSON *v, char *out, size_t n)
{
    if (v == NULL)
        snprintf(out, n, "nothing");
    else if (cJSON_IsNumber(v))
        snprintf(out, n, "%.17g", v->valuedouble);
    else if (cJSON_IsString(v))
        snprintf(out, n, "the string \"%.40s%s\"", v->valuestring,
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

lr_status lr__json_number(const cJSON *obj, const char *key,
                          const char *path, int required, double *out,
                          lr_error *err)
{
    char p[LR__PATH_MAX];
    lr__path_key(p, path, key);
    const cJSON *v = member(obj, key);
    if (v == NULL)
        return required ? lr__fail(err, LR_ERR_INVALID, p,
                                   "%s is required", p)
                        : LR_OK;
    if (!cJSON_IsNumber(v))
        return type_error(p, "a number", v, err);
    if (!isfinite(v->valuedouble))
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be a finite number, got %g", p,
                        v->valuedouble);
    *out = v->valuedouble;
    return LR_OK;
}

lr_status lr__json_int(const cJSON *obj, const char *key, const char *path,
                       int required, long long min, long long max,
                       long long *out, lr_error *err)
{
    char p[LR__PATH_MAX];
    lr__path_key(p, path, key);
    double d = 0;
    const cJSON *v = member(obj, key);
    if (v == NULL)
        return required ? lr__fail(err, LR_ERR_INVALID, p,
                                   "%s is required", p)
                        : LR_OK;
    lr_status st = lr__json_number(obj, key, path, 1, &d, err);
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
    lr__path_key(p, path, key);
    const cJSON *v = member(obj, key);
    if (v == NULL)
        return required ? lr__fail(err, LR_ERR_INVALID, p,
                                   "%s is required", p)
                        : LR_OK;
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
    lr__path_key(p, path, key);
    const cJSON *v = member(obj, key);
    if (v == NULL)
        return required ? lr__fail(err, LR_ERR_INVALID, p,
                                   "%s is required", p)
                        : LR_OK;
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
    return lr__fail(err, LR_ERR_INVALID, p, "%s must be one of %s, got \"%.60s\"",
                    p, list, v);
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
        if (!isfinite(c->valuedouble))
            return lr__fail(err, LR_ERR_INVALID, pi,
                            "%s must be a finite number, got %g", pi,
                            c->valuedouble);
        out[i] = c->valuedouble;
    }
    return LR_OK;
}

lr_status lr__json_vec3(const cJSON *obj, const char *key, const char *path,
                        int required, lr__v3 *out, lr_error *err)
{
    char p[LR__PATH_MAX];
    lr__path_key(p, path, key);
    const cJSON *v = member(obj, key);
    if (v == NULL)
        return required ? lr__fail(err, LR_ERR_INVALID, p,
                                   "%s is required", p)
                        : LR_OK;
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
    lr__path_key(p, path, key);
    const cJSON *v = member(obj, key);
    if (v == NULL)
        return required ? lr__fail(err, LR_ERR_INVALID, p,
                                   "%s is required", p)
                        : LR_OK;
    double a[3];
    if (cJSON_IsNumber(v)) {
        if (!isfinite(v->valuedouble))
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s must be a finite number, got %g", p,
                            v->valuedouble);
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

lr_status lr__json_parse(const char *text, size_t len, const char *what,
                         cJSON **out, lr_error *err)
{
    *out = NULL;
    if (too_deep(text, len))
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: JSON nested deeper than %d levels", what,
                        MAX_NESTING);
    if (memchr(text, '\0', len) != NULL)
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: JSON text contains a NUL byte", what);
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (root == NULL) {
        /* cJSON reports where it stopped; turn that into line:column. */
        const char *at = end ? end : cJSON_GetErrorPtr();
        size_t off = at && at >= text && at <= text + len ? (size_t)(at - text)
                                                           : 0;
        size_t line = 1, col = 1;
        for (size_t i = 0; i < off; i++) {
            if (text[i] == '\n') {
                line++;
                col = 1;
            } else {
                col++;
            }
        }
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
    *out = root;
    return LR_OK;
}

/* ---- overrides -------------------------------------------------------- */

lr_status lr__json_apply_override(cJSON *root, const char *assignment,
                                  lr_error *err)
{
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
                if (child != NULL)
                    cJSON_ReplaceItemInObjectCaseSensitive(node, key, value);
                else
                    cJSON_AddItemToObject(node, key, value);
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
