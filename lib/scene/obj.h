/*
 * obj.h: the OBJ reader's own parts, shared by obj.c (the file, its lines,
 * `v` and `vn`) and obj_face.c (`f`: corners, indices, triangulation).
 * Private to those two files; the reader's interface is lr__obj_load in
 * internal.h.
 */
#ifndef LR_OBJ_H
#define LR_OBJ_H

#include "util/internal.h"

#include <locale.h>
#include <stddef.h>
#include <stdint.h>

/* How much of an offending token an error message quotes. */
#define TOKEN_QUOTE_MAX 40

/* The most corners a concave face may have (convex ones: any number);
 * ear clipping's time goes as the square of the corners: 8192 take
 * about 0.15 s, 100000 took 30 s (obj_face.c). */
#define LR__OBJ_MAX_EAR 8192
/* And the most steps of ear clipping (corners tested against a candidate
 * ear) in one file, about 2 s: a self-crossing face of 8192 random
 * corners took 15 s alone, and a file can hold many (a reviewer's
 * measurement). */
#define LR__OBJ_EAR_BUDGET 200000000ull

/* A face corner after its indices were resolved to 0-based positions. */
typedef struct corner {
    size_t v;
    size_t vn;
    size_t vt;
    int has_vn;
    int has_vt;
} corner;

/* Everything the parser accumulates while it walks the file. */
typedef struct parser {
    const char *file;
    const char *json_path;
    lr_error *err;
    locale_t c_locale; /* numbers are always read with a '.' decimal point */
    size_t line;       /* the line being parsed, for messages */

    float *v; /* 3 per vertex */
    size_t n_v, cap_v;
    float *vn; /* 3 per normal, unit length */
    size_t n_vn, cap_vn;
    float *vt; /* 2 per texture coordinate */
    size_t n_vt, cap_vt;

    unsigned *idx; /* 3 per triangle */
    size_t n_tri, cap_idx;
    /* Ear clipping's steps so far in this file (LR__OBJ_EAR_BUDGET). */
    uint64_t ear_steps;
    float *cn; /* 9 per triangle while every corner so far had a normal */
    size_t cap_cn;
    int all_normals;
    float *cuv; /* 6 per triangle while every corner so far had a vt */
    size_t cap_cuv;
    int all_uvs;

    corner *corners; /* scratch for the face being parsed */
    size_t cap_corners;

    /* For the loader's warnings (lr__mesh): usemtl lines, and the lines
     * whose corner first lacked a normal, a texture coordinate. */
    size_t usemtl, normals_lost, uvs_lost;
} parser;


/* The first TOKEN_QUOTE_MAX bytes of a token for a message, with every
 * byte outside printable ASCII written as \xNN: a token is binary junk
 * when it has such bytes, and quoting them raw would make the message
 * invalid UTF-8 (lensrayd copies messages into JSON). */
typedef struct lr__obj_quoted {
    char s[4 * TOKEN_QUOTE_MAX + 1];
} lr__obj_quoted;

/* Grows an array so that it holds at least `need` elements of `elem`
 * bytes (see obj.c); NULL on overflow or failure, the old array intact. */
void *lr__obj_grow(void *p, size_t *cap, size_t need, size_t elem);
/* An input error at the current line, "FILE:LINE: what". */
__attribute__((format(printf, 3, 4))) lr_status
lr__obj_fail_at(parser *ps, lr_status status, const char *fmt, ...);
lr_status lr__obj_nomem(parser *ps);
/* The next token after *pp (advancing it), or NULL at the end of the
 * line; its length in *len. */
const char *lr__obj_next_token(const char **pp, size_t *len);
/* A token quoted for a message: printable ASCII, \xNN for the rest. */
lr__obj_quoted lr__obj_quote(const char *tok, size_t len);

/* obj_face.c: an `f` statement (after the keyword): its corners resolved
 * and fan-triangulated into ps->idx (and ps->cn). */
lr_status lr__obj_parse_face(parser *ps, const char *rest);

#endif
