/*
 * json_parse.c: JSON text to cJSON trees, checked for what cJSON lets
 * through: nesting (before cJSON recurses), \u0000 in strings, invalid
 * UTF-8, numbers too large for a double; with out-of-memory told apart
 * from a syntax error.  lr__json_parse for documents, and the --set
 * overrides (lr__json_apply_override), whose values parse the same way.
 */
#include "json/json_util.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The next number at or after offset *at (outside strings) of JSON text
 * that cJSON accepted: its start, its length in *n, and *at moved past
 * it; NULL when there is none.  Outside strings, a number is a run of
 * [0-9+-.eE] that starts with '-' or a digit (cJSON's own scan). */
static const char *next_number(const char *text, size_t len, size_t *at,
                               size_t *n)
{
    int in_str = 0;
    for (size_t i = *at; i < len; i++) {
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
            *n = j - i;
            *at = j;
            return text + i;
        }
    }
    *at = len;
    return NULL;
}

/* The k-th number (from 0) of JSON text that cJSON accepted, and its
 * length in *n; NULL if there is none. */
static const char *nth_number(const char *text, size_t len, size_t k, size_t *n)
{
    size_t at = 0;
    const char *p = next_number(text, len, &at, n);
    while (p != NULL && k > 0) {
        p = next_number(text, len, &at, n);
        k--;
    }
    return p;
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
static lr_status check_values(const cJSON *v, const char *path, value_walk *w,
                              lr_error *err)
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
                lr__utf8_escape(k, shown, sizeof shown);
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

size_t lr__json_depth_at(const char *s, size_t len, int max)
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
            if (++depth > max)
                return i;
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
    return len;
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

/* Whether the n bytes at s are a number as RFC 8259 (section 6) writes
 * one: -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?. */
static int rfc_number(const char *s, size_t n)
{
    size_t i = 0;
#define DIGIT(k) ((k) < n && s[k] >= '0' && s[k] <= '9')
    if (i < n && s[i] == '-')
        i++;
    if (i < n && s[i] == '0')
        i++;
    else if (DIGIT(i))
        while (DIGIT(i))
            i++;
    else
        return 0;
    if (i < n && s[i] == '.') {
        if (!DIGIT(i + 1))
            return 0;
        for (i++; DIGIT(i); i++)
            ;
    }
    if (i < n && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        if (i < n && (s[i] == '+' || s[i] == '-'))
            i++;
        if (!DIGIT(i))
            return 0;
        while (DIGIT(i))
            i++;
    }
#undef DIGIT
    return i == n;
}

/* The offset of the first number outside strings that RFC 8259 does not
 * allow, or len.  cJSON reads a number with strtod, which also takes a
 * leading zero ("016", which other readers take for octal or refuse) and
 * a point without digits after it ("2.", "1.e3").  Called on text cJSON
 * accepted. */
static size_t bad_number_at(const char *s, size_t len)
{
    size_t at = 0, n = 0;
    for (const char *p = next_number(s, len, &at, &n); p != NULL;
         p = next_number(s, len, &at, &n))
        if (!rfc_number(p, n))
            return (size_t)(p - s);
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

static void cjson_free(void *p)
{
    free(p);
}

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
    if (lr__json_depth_at(text, len, LR_MAX_JSON_DEPTH) < len)
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: JSON nested deeper than %d levels", what,
                        LR_MAX_JSON_DEPTH);
    if (memchr(text, '\0', len) != NULL)
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: JSON text contains a NUL byte", what);
    /* "invalid JSON at line 1, column 1" would send the reader looking
     * for a bad character in a file that has none. */
    size_t first = 0;
    while (first < len && (text[first] == ' ' || text[first] == '\t' ||
                           text[first] == '\n' || text[first] == '\r'))
        first++;
    if (first == len)
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: empty (%s), not a JSON value", what,
                        len ? "only white space" : "0 bytes");
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
                        "%s: invalid JSON at line %zu, column %zu", what, line,
                        col);
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
    off = bad_number_at(text, len);
    if (off < len) {
        cJSON_Delete(root);
        line_col(text, off, &line, &col);
        return lr__fail(err, LR_ERR_INVALID, "",
                        "%s: invalid JSON at line %zu, column %zu: not a "
                        "JSON number (RFC 8259: no leading zeros, digits "
                        "after a decimal point)",
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
    /* "016" is not JSON either (bad_number_at), so it is a string too. */
    if (value != NULL && bad_number_at(text, strlen(text)) < strlen(text)) {
        cJSON_Delete(value);
        value = NULL;
    }
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
                    return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
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
