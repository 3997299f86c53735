/*
 * obj_face.c: an OBJ file's faces: each corner's v/vt/vn indices read and
 * checked (1-based, or negative from the end of the list so far), and the
 * polygon fan-triangulated, keeping per-corner normals while every corner
 * has one.
 */
#include "scene/obj.h"

#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Parses the integer at *pp, which must lie before `end`.  Returns 0 on
 * success, -1 when there is no integer there and -2 when it does not fit
 * a long.  The explicit first-character test matters: strtol would skip
 * whitespace and happily read the next token. */
static int parse_int(const char **pp, const char *end, long *out)
{
    const char *p = *pp;
    if (p >= end)
        return -1;
    if (!((*p >= '0' && *p <= '9') || *p == '-' || *p == '+'))
        return -1;
    char *stop = NULL;
    errno = 0;
    long x = strtol(p, &stop, 10);
    if (stop == p || stop > end)
        return -1;
    if (errno == ERANGE)
        return -2;
    *out = x;
    *pp = stop;
    return 0;
}

static const char *plural(size_t n, const char *one, const char *many)
{
    return n == 1 ? one : many;
}

/* Turns an OBJ index (1-based, or negative counting back from the end of
 * the list so far) into a 0-based position, or reports it.  `kind` is
 * "" for vertices, "normal " or "texture " for the others. */
static lr_status resolve_index(parser *ps, long i, size_t count,
                               const char *kind, const char *one,
                               const char *many, size_t *out)
{
    if (i == 0)
        return lr__obj_fail_at(
            ps, LR_ERR_INVALID,
            "face %sindex 0 out of range (OBJ indices start at 1; "
            "the file has %zu %s so far)",
            kind, count, plural(count, one, many));
    if (i > 0) {
        if ((unsigned long)i <= count) {
            *out = (size_t)i - 1;
            return LR_OK;
        }
    } else {
        /* -(i + 1) cannot overflow even for LONG_MIN. */
        unsigned long back = (unsigned long)(-(i + 1)) + 1u;
        if (back <= count) {
            *out = count - back;
            return LR_OK;
        }
    }
    return lr__obj_fail_at(
        ps, LR_ERR_INVALID,
        "face %sindex %ld out of range (the file has %zu %s so far)", kind, i,
        count, plural(count, one, many));
}

/* Parses one corner: v, v/vt, v//vn or v/vt/vn. */
static lr_status parse_corner(parser *ps, const char *tok, size_t len,
                              corner *c)
{
    const char *end = tok + len;
    const char *p = tok;
    long iv = 0, it = 0, in = 0;
    int have_vt = 0;
    c->has_vn = 0;
    c->has_vt = 0;

    int r = parse_int(&p, end, &iv);
    if (r == 0 && p < end) {
        if (*p != '/') {
            r = -1;
        } else {
            p++;
            if (p < end && *p != '/') {
                r = parse_int(&p, end, &it);
                have_vt = 1;
            }
            if (r == 0 && p < end) {
                if (*p != '/') {
                    r = -1;
                } else {
                    p++;
                    r = parse_int(&p, end, &in);
                    c->has_vn = 1;
                }
            } else if (r == 0 && !have_vt) {
                /* "1/" names a texture coordinate and then gives none. */
                r = -1;
            }
        }
        if (r == 0 && p != end)
            r = -1;
    }
    if (r == -2)
        return lr__obj_fail_at(ps, LR_ERR_INVALID,
                               "face index in '%s' out of range",
                               lr__obj_quote(tok, len).s);
    if (r != 0)
        return lr__obj_fail_at(
            ps, LR_ERR_INVALID,
            "bad face corner '%s' (expected v, v/vt, v//vn or "
            "v/vt/vn with integer indices)",
            lr__obj_quote(tok, len).s);

    lr_status st = resolve_index(ps, iv, ps->n_v, "", "vertex", "vertices",
                                 &c->v);
    if (st != LR_OK)
        return st;
    if (have_vt) {
        st = resolve_index(ps, it, ps->n_vt, "texture ", "texture coordinate",
                           "texture coordinates", &c->vt);
        if (st != LR_OK)
            return st;
        c->has_vt = 1;
    }
    if (c->has_vn) {
        st = resolve_index(ps, in, ps->n_vn, "normal ", "normal", "normals",
                           &c->vn);
        if (st != LR_OK)
            return st;
    }
    return LR_OK;
}

/* Stops collecting per-corner texture coordinates, as drop_normals. */
static void drop_uvs(parser *ps)
{
    ps->all_uvs = 0;
    free(ps->cuv);
    ps->cuv = NULL;
    ps->cap_cuv = 0;
}

/* Stops collecting per-corner normals: once one corner lacks a normal the
 * mesh as a whole has none, so the memory can go right away. */
static void drop_normals(parser *ps)
{
    ps->all_normals = 0;
    free(ps->cn);
    ps->cn = NULL;
    ps->cap_cn = 0;
}

lr_status lr__obj_parse_face(parser *ps, const char *rest)
{
    size_t n = 0;
    size_t len = 0;
    int face_normals = 1, face_uvs = 1;
    const char *tok = lr__obj_next_token(&rest, &len);
    while (tok != NULL) {
        if (n == SIZE_MAX / sizeof(corner))
            return lr__obj_fail_at(ps, LR_ERR_LIMIT,
                                   "too many corners in a face");
        corner *cs = lr__obj_grow(ps->corners, &ps->cap_corners, n + 1,
                                  sizeof *cs);
        if (cs == NULL)
            return lr__obj_nomem(ps);
        ps->corners = cs;
        lr_status st = parse_corner(ps, tok, len, &cs[n]);
        if (st != LR_OK)
            return st;
        if (!cs[n].has_vn)
            face_normals = 0;
        if (!cs[n].has_vt)
            face_uvs = 0;
        n++;
        tok = lr__obj_next_token(&rest, &len);
    }
    if (n < 3)
        return lr__obj_fail_at(
            ps, LR_ERR_INVALID,
            "a face needs at least 3 corners, this one has %zu", n);
    if (!face_normals && ps->all_normals)
        drop_normals(ps);
    if (!face_uvs && ps->all_uvs)
        drop_uvs(ps);

    /* A polygon with n corners becomes a fan of n - 2 triangles around
     * its first corner; fine for the convex polygons exporters write. */
    size_t add = n - 2;
    if (ps->n_tri > SIZE_MAX / 9 - add)
        return lr__obj_fail_at(ps, LR_ERR_LIMIT, "too many triangles");
    size_t tri_after = ps->n_tri + add;
    unsigned *idx = lr__obj_grow(ps->idx, &ps->cap_idx, 3 * tri_after,
                                 sizeof *idx);
    if (idx == NULL)
        return lr__obj_nomem(ps);
    ps->idx = idx;
    float *cn = NULL;
    if (ps->all_normals) {
        cn = lr__obj_grow(ps->cn, &ps->cap_cn, 9 * tri_after, sizeof *cn);
        if (cn == NULL)
            return lr__obj_nomem(ps);
        ps->cn = cn;
    }
    float *cuv = NULL;
    if (ps->all_uvs) {
        cuv = lr__obj_grow(ps->cuv, &ps->cap_cuv, 6 * tri_after, sizeof *cuv);
        if (cuv == NULL)
            return lr__obj_nomem(ps);
        ps->cuv = cuv;
    }

    const corner *cs = ps->corners;
    for (size_t k = 1; k + 1 < n; k++) {
        const corner *tri[3] = {&cs[0], &cs[k], &cs[k + 1]};
        for (int j = 0; j < 3; j++) {
            /* parse_vertex keeps the vertex count within unsigned. */
            idx[3 * ps->n_tri + (size_t)j] = (unsigned)tri[j]->v;
            if (cn != NULL)
                memcpy(&cn[9 * ps->n_tri + 3 * (size_t)j],
                       &ps->vn[3 * tri[j]->vn], 3 * sizeof *cn);
            if (cuv != NULL)
                memcpy(&cuv[6 * ps->n_tri + 2 * (size_t)j],
                       &ps->vt[2 * tri[j]->vt], 2 * sizeof *cuv);
        }
        ps->n_tri++;
    }
    return LR_OK;
}
