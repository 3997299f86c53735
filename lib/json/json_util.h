/*
 * json_util.h: typed, path-naming access to cJSON values, shared by the
 * scene loader and the override parser.  Every getter fills lr_error with
 * a sentence that starts with the JSON path of the field.
 */
#ifndef LR_JSON_UTIL_H
#define LR_JSON_UTIL_H

#include "util/internal.h"
#include "util/vec.h"

#include <cjson/cJSON.h>

#define LR__PATH_MAX 256

/* out = parent.key (or key when parent is empty). */
void lr__path_key(char out[LR__PATH_MAX], const char *parent, const char *key);
/* out = parent[i]. */
void lr__path_index(char out[LR__PATH_MAX], const char *parent, size_t i);

/* The offset of the first byte of `s` that is not part of valid UTF-8
 * (RFC 3629), or (size_t)-1 when all of it is. */
size_t lr__utf8_invalid_at(const char *s);
/* The length of the longest prefix of `s` of at most `max` bytes that
 * does not cut a UTF-8 character, for "%.*s" in messages. */
int lr__utf8_prefix(const char *s, int max);

/* Copies s into out (of capacity cap, NUL-terminated), with every byte
 * that is not part of valid UTF-8 written as \xHH, for quoting user text
 * in messages. */
void lr__utf8_escape(const char *s, char *out, size_t cap);

/* The JSON names of the public enums, indexed by value and ending with
 * NULL: one table each, for the parsers (camera_json.c, settings_json.c)
 * and the writer (json_write.c) alike (json_util.c).  The integrators'
 * names are their registry's (integrator.h). */
extern const char *const lr__sampler_names[]; /* lr_sampler_kind */
int lr__sampler_count(void);                  /* entries in lr__sampler_names */
extern const char *const lr__chroma_mode_names[]; /* lr_chromatic_mode */
extern const char *const lr__focal_model_names[]; /* lr_focal_model */
extern const char *const lr__glass_names[];       /* lr_glass, but ABBE */

/* json_parse.c: the offset where JSON text first nests deeper than `max`
 * brackets (outside strings), or len: a linear scan, so that hostile
 * input never reaches cJSON's recursive parser. */
size_t lr__json_depth_at(const char *s, size_t len, int max);

/* "a string", "an array", "the number 3.5", ... for error messages. */
void lr__json_describe(const cJSON *v, char *out, size_t n);

/* LR_OK when `v` is an object; else "PATH must be an object[HINT], got
 * the string \"...\"" (HINT, e.g. " like {\"format\": \"png\"}", may be
 * ""), so that a shell that ate the quotes of --set 'x={"a": 1}' shows. */
lr_status lr__json_object(const cJSON *v, const char *path, const char *hint,
                          lr_error *err);

/* Fails with an error naming the first key of `obj` that is not in the
 * NULL-terminated `allowed` list, or that appears twice. */
lr_status lr__json_check_keys(const cJSON *obj, const char *path,
                              const char *const *allowed, lr_error *err);

/* Fails unless x is finite and |x| <= LR__MAX_NUMBER; `p` names it. */
lr_status lr__json_check_number(double x, const char *p, lr_error *err);

/* Getters: `obj` is an object, `key` a member name, `path` the object's
 * path.  When the member is absent: required -> error, else LR_OK with
 * *out untouched (so callers preload defaults). */
/* A number: finite and within +-LR__MAX_NUMBER.  Integers (lr__json_int)
 * have only their own range. */
lr_status lr__json_number(const cJSON *obj, const char *key, const char *path,
                          int required, double *out, lr_error *err);
lr_status lr__json_int(const cJSON *obj, const char *key, const char *path,
                       int required, long long min, long long max,
                       long long *out, lr_error *err);
lr_status lr__json_bool(const cJSON *obj, const char *key, const char *path,
                        int required, int *out, lr_error *err);
/* *out points into the cJSON tree. */
lr_status lr__json_string(const cJSON *obj, const char *key, const char *path,
                          int required, const char **out, lr_error *err);
/* A string that must be one of the NULL-terminated `names`; *out is its
 * index.  The error lists the choices. */
lr_status lr__json_enum(const cJSON *obj, const char *key, const char *path,
                        const char *const *names, int *out, lr_error *err);

/* An array of three finite numbers. */
lr_status lr__json_vec3(const cJSON *obj, const char *key, const char *path,
                        int required, lr__v3 *out, lr_error *err);
/* A colour: one number (grey) or three; all finite and >= 0. */
lr_status lr__json_rgb(const cJSON *obj, const char *key, const char *path,
                       int required, lr__v3 *out, lr_error *err);

/* Parses JSON text of `len` bytes with a nesting limit; the error gives
 * the line and column.  Every key and string must be valid UTF-8 (the
 * error names the field) and none may contain \u0000.  `what` names the
 * text ("scene.json") in syntax errors; `path` is the JSON path of its
 * value ("" for a whole scene, "camera" for a camera object) in errors
 * about a value.  A number too large for a double (1e400) is an error
 * that quotes it.  LR_ERR_NOMEM when cJSON ran out of memory (told
 * apart from a syntax error by the library's cJSON hooks, json_util.c).
 * The caller deletes the result with cJSON_Delete. */
lr_status lr__json_parse(const char *text, size_t len, const char *what,
                         const char *path, cJSON **out, lr_error *err);

/* Applies one "dotted.path=value" override to a parsed document: value
 * is parsed as JSON when it is valid JSON, else taken as a string.  Path
 * segments are object keys or [index] into arrays ("objects[2].radius");
 * missing objects on the way are created, array indexes must exist. */
lr_status lr__json_apply_override(cJSON *root, const char *assignment,
                                  lr_error *err);

#endif
