/*
 * obj_face.c: an OBJ file's faces: each corner's v/vt/vn indices read and
 * checked (1-based, or negative from the end of the list so far), and the
 * polygon triangulated (a fan when convex, else ear clipping), keeping
 * per-corner normals while every corner has one.
 */
#include "scene/obj.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
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
    ps->uvs_lost = ps->line;
    free(ps->cuv);
    ps->cuv = NULL;
    ps->cap_cuv = 0;
}

/* Stops collecting per-corner normals: once one corner lacks a normal the
 * mesh as a whole has none, so the memory can go right away. */
static void drop_normals(parser *ps)
{
    ps->all_normals = 0;
    ps->normals_lost = ps->line;
    free(ps->cn);
    ps->cn = NULL;
    ps->cap_cn = 0;
}

/* The polygon's corners c[0..n-1] in 2D: the plane across its Newell
 * normal's largest component, turned so that the polygon winds
 * counter-clockwise (xy: 2n numbers). */
static void project(const parser *ps, const corner *c, size_t n, double *xy)
{
    double N[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        const float *a = &ps->v[3 * c[i].v], *b = &ps->v[3 * c[(i + 1) % n].v];
        N[0] += ((double)a[1] - b[1]) * ((double)a[2] + b[2]);
        N[1] += ((double)a[2] - b[2]) * ((double)a[0] + b[0]);
        N[2] += ((double)a[0] - b[0]) * ((double)a[1] + b[1]);
    }
    int k = fabs(N[0]) > fabs(N[1]) ? (fabs(N[0]) > fabs(N[2]) ? 0 : 2)
                                    : (fabs(N[1]) > fabs(N[2]) ? 1 : 2);
    int u = (k + 1) % 3, w = (k + 2) % 3;
    double flip = N[k] < 0 ? -1.0 : 1.0;
    for (size_t i = 0; i < n; i++) {
        xy[2 * i] = ps->v[3 * c[i].v + u];
        xy[2 * i + 1] = flip * ps->v[3 * c[i].v + w];
    }
}

static double turn(const double *a, const double *b, const double *c)
{
    return (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
}

/* Whether p lies inside or on triangle abc (counter-clockwise). */
static int inside(const double *a, const double *b, const double *c,
                  const double *p)
{
    return turn(a, b, p) >= 0 && turn(b, c, p) >= 0 && turn(c, a, p) >= 0;
}

/* Ear clipping of the polygon xy (n corners, 2n numbers) into tri, with
 * live (n) for its scratch (Eberly, "Triangulation by Ear Clipping",
 * 2002).  Its steps count into ps->ear_steps: 1, or -2 once they pass
 * LR__OBJ_EAR_BUDGET. */
static int ear_clip(parser *ps, const double *xy, size_t n, size_t *live,
                    size_t *tri)
{
    size_t m = n, t = 0, i = 0, misses = 0;
    for (size_t k = 0; k < n; k++)
        live[k] = k;
    while (m > 3) {
        size_t a = live[(i + m - 1) % m], b = live[i % m],
               d = live[(i + 1) % m];
        const double *A = &xy[2 * a], *B = &xy[2 * b], *D = &xy[2 * d];
        int ear = turn(A, B, D) > 0;
        size_t k = 0;
        for (; k < m && ear; k++) {
            size_t q = live[k];
            if (q != a && q != b && q != d &&
                turn(&xy[2 * live[(k + m - 1) % m]], &xy[2 * q],
                     &xy[2 * live[(k + 1) % m]]) <= 0)
                ear = !inside(A, B, D, &xy[2 * q]);
        }
        ps->ear_steps += k + 1;
        if (ps->ear_steps > LR__OBJ_EAR_BUDGET)
            return -2;
        /* A self-crossing or degenerate rest has no ear: cut anyway. */
        if (ear || misses > m) {
            tri[3 * t] = a, tri[3 * t + 1] = b, tri[3 * t + 2] = d, t++;
            memmove(&live[i % m], &live[i % m + 1],
                    (m - i % m - 1) * sizeof *live);
            m--;
            misses = 0;
        } else {
            i++, misses++;
        }
        i %= m;
    }
    tri[3 * t] = live[0], tri[3 * t + 1] = live[1], tri[3 * t + 2] = live[2];
    return 1;
}

/* The polygon's n - 2 triangles as corner numbers, 3 each, into tri: a
 * fan about corner 0 when the polygon is convex (as it always was:
 * every convex polygon's triangles unchanged), else by ear clipping
 * (Eberly, "Triangulation by Ear Clipping", 2002): a fan of a concave
 * polygon covered area outside it (an L-shaped face filled its notch).
 * Each triangle keeps the polygon's winding.  0: out of memory; -1: a
 * concave polygon of more than LR__OBJ_MAX_EAR corners, which ear
 * clipping would take too long over (its time goes as the square of the
 * corners: a 100000-corner star, 5 MB, took 30 s to load); -2: the
 * file's concave faces past LR__OBJ_EAR_BUDGET steps in all. */
static int triangulate(parser *ps, const corner *c, size_t n, size_t *tri)
{
    /* On the stack for the usual few corners (an allocation a face cost
     * time in meshes of millions of quads). */
    double xy_small[2 * 16];
    size_t live_small[16];
    int heap = n > 16;
    double *xy = heap ? malloc(2 * n * sizeof *xy) : xy_small;
    size_t *live = heap ? malloc(n * sizeof *live) : live_small;
    int convex = 1, rc = 1;
    if (xy == NULL || live == NULL) {
        rc = 0;
    } else {
        if (n > 3) {
            project(ps, c, n, xy);
            for (size_t i = 0; i < n && convex; i++)
                convex = turn(&xy[2 * i], &xy[2 * ((i + 1) % n)],
                              &xy[2 * ((i + 2) % n)]) >= 0;
        }
        if (convex)
            for (size_t k = 1; k + 1 < n; k++)
                tri[3 * (k - 1)] = 0, tri[3 * (k - 1) + 1] = k,
                             tri[3 * (k - 1) + 2] = k + 1;
        else
            rc = n > LR__OBJ_MAX_EAR ? -1 : ear_clip(ps, xy, n, live, tri);
    }
    if (heap)
        free(xy), free(live);
    return rc;
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

    /* A polygon with n corners becomes n - 2 triangles (triangulate). */
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
    size_t order_small[3 * 14];
    size_t *order = add > 14 ? malloc(3 * add * sizeof *order) : order_small;
    int tr = order != NULL ? triangulate(ps, cs, n, order) : 0;
    if (tr <= 0) {
        if (order != order_small)
            free(order);
        if (tr == -1)
            return lr__obj_fail_at(
                ps, LR_ERR_LIMIT,
                "a concave face of %zu corners; at most %d are "
                "triangulated (the time goes as the square of the corners): "
                "split it into smaller faces",
                n, LR__OBJ_MAX_EAR);
        if (tr == -2)
            return lr__obj_fail_at(
                ps, LR_ERR_LIMIT,
                "the file's concave faces take too long to triangulate "
                "(over %llu steps of ear clipping, about 2 s; this face has "
                "%zu corners): split them into triangles or smaller faces",
                (unsigned long long)LR__OBJ_EAR_BUDGET, n);
        return lr__obj_nomem(ps);
    }
    for (size_t k = 0; k < add; k++) {
        const corner *tri[3] = {&cs[order[3 * k]], &cs[order[3 * k + 1]],
                                &cs[order[3 * k + 2]]};
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
    if (order != order_small)
        free(order);
    return LR_OK;
}
