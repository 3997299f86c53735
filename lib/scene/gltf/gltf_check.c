/*
 * gltf_check.c: a glTF document checked before libassimp sees it
 * (gltf_doc.h); its bytes are read by gltf_file.c, its binary data
 * checked by gltf_accessor.c.  assimp trusts much
 * of what a file says (an accessor's count, a child's index, a GLB
 * chunk's length), so everything it would
 * trust is checked here, against the glTF 2.0 specification (Khronos,
 * sections 3.6 "Binary data", 3.7 "Geometry", 4.4 "GLB file format"), and
 * every error names the field.  gltf.c then hands assimp a copy of the
 * JSON that this file printed, and files only through its own reader.
 */
#include "gltf_doc.h"
#include "json_util.h"

#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


lr_status lr__gltf_fail(const lr__gltf_doc *d, lr_error *err, const char *fmt,
                        ...)
{
    char what[600];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return lr__fail(err, LR_ERR_INVALID, d->fp, "%s: %s: %s", d->fp, d->shown,
                    what);
}

const cJSON *lr__gltf_array(const cJSON *o, const char *key, int *n)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, key);
    *n = cJSON_IsArray(a) ? cJSON_GetArraySize(a) : 0;
    return cJSON_IsArray(a) ? a : NULL;
}

const cJSON *lr__gltf_member(const cJSON *o, const char *k1, const char *k2)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, k1);
    const cJSON *b = cJSON_IsObject(a) ? cJSON_GetObjectItemCaseSensitive(a, k2)
                                       : NULL;
    return cJSON_IsObject(b) ? b : NULL;
}

const lr__gltf_blob *lr__gltf_blob_find(const lr__gltf_doc *d, const char *uri)
{
    for (size_t i = 0; i < d->n_blobs; i++)
        if (strcmp(d->blobs[i].uri, uri) == 0)
            return &d->blobs[i];
    return NULL;
}

void lr__gltf_doc_free(lr__gltf_doc *d)
{
    for (size_t i = 0; i < d->n_blobs; i++) {
        free(d->blobs[i].uri);
        free(d->blobs[i].data);
    }
    free(d->blobs);
    free(d->buffers);
    for (size_t i = 0; i < d->n_accessors; i++)
        free(d->dense[i]);
    free(d->dense);
    free(d->tex);
    cJSON_Delete(d->root);
    free(d->bytes);
    memset(d, 0, sizeof *d);
}

/* ---- small readers ------------------------------------------------------ */

/* "path.key", or "key" alone for a member of the document's root (path
 * ""), so that no message starts with a lone dot. */
static const char *dotted(const char *path, const char *key, char *buf,
                          size_t n)
{
    snprintf(buf, n, "%s%s%s", path, *path ? "." : "", key);
    return buf;
}

/* An optional non-negative integer member below `lim` (lim 0: no limit);
 * *out = dflt when absent. */
lr_status lr__gltf_get_uint(const lr__gltf_doc *d, const cJSON *o,
                            const char *path, const char *key, double lim,
                            long long dflt, long long *out, lr_error *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    *out = dflt;
    if (v == NULL)
        return LR_OK;
    double x = cJSON_IsNumber(v) ? v->valuedouble : -1;
    char f[200];
    if (!(x >= 0 && x == floor(x) && x <= 4e9 && (lim == 0 || x < lim))) {
        if (lim > 0)
            return lr__gltf_fail(d, err, "%s must be an index below %.0f",
                                 dotted(path, key, f, sizeof f), lim);
        return lr__gltf_fail(d, err, "%s must be a whole number >= 0",
                             dotted(path, key, f, sizeof f));
    }
    *out = (long long)x;
    return LR_OK;
}

/* An optional index into an array of n; -1 when absent. */
lr_status lr__gltf_get_index(const lr__gltf_doc *d, const cJSON *o,
                             const char *path, const char *key, int n,
                             long long *out, lr_error *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    *out = -1;
    if (v == NULL)
        return LR_OK;
    char f[200];
    if (n == 0)
        return lr__gltf_fail(d, err,
                             "%s refers to an element of an "
                             "empty or missing array",
                             dotted(path, key, f, sizeof f));
    return lr__gltf_get_uint(d, o, path, key, n, -1, out, err);
}

/* An optional array of exactly n finite numbers. */
static lr_status check_numbers(const lr__gltf_doc *d, const cJSON *o,
                               const char *path, const char *key, int n,
                               lr_error *err)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, key);
    if (a == NULL)
        return LR_OK;
    int ok = cJSON_IsArray(a) && cJSON_GetArraySize(a) == n;
    for (const cJSON *c = ok ? a->child : NULL; c; c = c->next)
        ok = ok && cJSON_IsNumber(c) && fabs(c->valuedouble) <= 1e15;
    if (!ok)
        return lr__gltf_fail(d, err,
                             "%s.%s must be an array of %d finite "
                             "numbers",
                             path, key, n);
    return LR_OK;
}

/* ---- the document ------------------------------------------------------- */

/* Extensions lensray reads or may ignore without changing the geometry;
 * a file that requires any other is refused. */
static const char *const known_ext[] = {"KHR_lights_punctual",
                                        "KHR_materials_emissive_strength",
                                        "KHR_materials_transmission",
                                        "KHR_materials_ior",
                                        "KHR_materials_specular",
                                        "KHR_materials_clearcoat",
                                        "KHR_materials_sheen",
                                        "KHR_materials_volume",
                                        "KHR_texture_transform",
                                        "KHR_materials_unlit",
                                        NULL};
static lr_status check_index_values(const lr__gltf_doc *d, const char *p,
                                    long long acc, long long n_vertices,
                                    lr_error *err)
{
    size_t stride, cs;
    long long count;
    const unsigned char *base = lr__gltf_accessor_at(d, acc, &stride, &count,
                                                     &cs);
    for (long long i = 0; i < count; i++) {
        const unsigned char *q = base + (size_t)i * stride;
        unsigned long x = lr__gltf_read_uint(q, cs);
        if ((long long)x >= n_vertices)
            return lr__gltf_fail(d, err,
                                 "%s.indices: index %lld is %lu, "
                                 "beyond the %lld vertices",
                                 p, i, x, n_vertices);
    }
    return LR_OK;
}

/* Every coordinate of a POSITION accessor (VEC3 of floats) must be a
 * finite number, so that the error names the accessor and the vertex
 * rather than the placed mesh. */
static lr_status check_positions(const lr__gltf_doc *d, const char *p,
                                 long long acc, lr_error *err)
{
    size_t stride, cs;
    long long count;
    static const char *const axis[3] = {"x", "y", "z"};
    const unsigned char *base = lr__gltf_accessor_at(d, acc, &stride, &count,
                                                     &cs);
    for (long long i = 0; i < count; i++)
        for (int k = 0; k < 3; k++) {
            uint32_t bits = lr__gltf_le32(base + (size_t)i * stride +
                                          4 * (size_t)k);
            float f;
            memcpy(&f, &bits, sizeof f);
            if (!isfinite(f))
                return lr__gltf_fail(d, err,
                                     "%s.POSITION: accessors[%lld] "
                                     "element %lld: %s is %g",
                                     p, acc, i, axis[k], (double)f);
        }
    return LR_OK;
}

/* A primitive's morph targets (spec 3.7.2.2): objects whose POSITION
 * and NORMAL are VEC3 floats (displacements, finite) of the primitive's
 * `nvert` vertices; their number in *n. */
static lr_status check_targets(const lr__gltf_doc *d, const cJSON *pr,
                               const char *p, long long nvert, int *n,
                               lr_error *err)
{
    int nacc;
    lr__gltf_array(d->root, "accessors", &nacc);
    const cJSON *ts = lr__gltf_array(pr, "targets", n);
    if (ts == NULL && cJSON_GetObjectItemCaseSensitive(pr, "targets"))
        return lr__gltf_fail(d, err, "%s.targets must be an array", p);
    int k = 0;
    char q[160];
    for (const cJSON *t = ts ? ts->child : NULL; t; t = t->next, k++) {
        snprintf(q, sizeof q, "%s.targets[%d]", p, k);
        if (!cJSON_IsObject(t))
            return lr__gltf_fail(d, err, "%s must be an object", q);
        for (const cJSON *c = t->child; c; c = c->next) {
            long long x, cnt;
            LR_TRY(lr__gltf_get_index(d, t, q, c->string, nacc, &x, err));
            LR_TRY(lr__gltf_check_attribute(d, q, c->string, x, &cnt, err));
            if (cnt != nvert)
                return lr__gltf_fail(d, err,
                                     "%s.%s has %lld elements, "
                                     "POSITION %lld",
                                     q, c->string, cnt, nvert);
            if (strcmp(c->string, "POSITION") == 0)
                LR_TRY(check_positions(d, q, x, err));
        }
    }
    return LR_OK;
}

/* The number of morph targets of meshes[m] (check_meshes made it the
 * same for every primitive). */
static int mesh_targets(const lr__gltf_doc *d, long long m)
{
    int n, np, nt;
    const cJSON *mesh = cJSON_GetArrayItem(
        lr__gltf_array(d->root, "meshes", &n), (int)m);
    const cJSON *prims = lr__gltf_array(mesh, "primitives", &np);
    lr__gltf_array(prims ? prims->child : NULL, "targets", &nt);
    return nt;
}

/* Default morph weights, o.weights (a mesh's or a node's): one finite
 * number per morph target when present (spec 3.7.2.2). */
static lr_status check_weights(const lr__gltf_doc *d, const cJSON *o,
                               const char *p, int targets, lr_error *err)
{
    const cJSON *w = cJSON_GetObjectItemCaseSensitive(o, "weights");
    if (w == NULL)
        return LR_OK;
    int ok = cJSON_IsArray(w) && cJSON_GetArraySize(w) == targets;
    for (const cJSON *c = ok ? w->child : NULL; c; c = c->next)
        ok = ok && cJSON_IsNumber(c) && fabs(c->valuedouble) <= 1e6;
    if (!ok)
        return lr__gltf_fail(d, err,
                             "%s.weights must be %d numbers from "
                             "-1e6 to 1e6, one per morph target",
                             p, targets);
    return LR_OK;
}

static lr_status check_meshes(lr__gltf_doc *d, lr_error *err)
{
    int n, nacc, nmat;
    const cJSON *a = lr__gltf_array(d->root, "meshes", &n);
    lr__gltf_array(d->root, "accessors", &nacc);
    lr__gltf_array(d->root, "materials", &nmat);
    int i = 0;
    char p[96];
    for (const cJSON *m = a ? a->child : NULL; m; m = m->next, i++) {
        int np;
        const cJSON *prims = lr__gltf_array(m, "primitives", &np);
        if (np == 0)
            return lr__gltf_fail(d, err,
                                 "meshes[%d].primitives must be a "
                                 "non-empty array",
                                 i);
        int j = 0, targets = 0;
        for (const cJSON *pr = prims->child; pr; pr = pr->next, j++) {
            snprintf(p, sizeof p, "meshes[%d].primitives[%d]", i, j);
            const cJSON *at = cJSON_GetObjectItemCaseSensitive(pr,
                                                               "attributes");
            if (!cJSON_IsObject(at) || at->child == NULL)
                return lr__gltf_fail(d, err,
                                     "%s.attributes must be a "
                                     "non-empty object",
                                     p);
            /* POSITION may be missing (spec 3.7.2.1: such a primitive is
             * not drawn; gltf_assimp.c leaves it out). */
            const cJSON *pos = cJSON_GetObjectItemCaseSensitive(at, "POSITION");
            const char *first = pos ? "POSITION" : at->child->string;
            long long nvert = -1, cnt, x, mode;
            char q[128];
            snprintf(q, sizeof q, "%s.attributes", p);
            if (pos != NULL) {
                LR_TRY(lr__gltf_get_index(d, at, q, "POSITION", nacc, &x, err));
                LR_TRY(
                    lr__gltf_check_attribute(d, q, "POSITION", x, &nvert, err));
                LR_TRY(check_positions(d, q, x, err));
            }
            for (const cJSON *c = at->child; c; c = c->next) {
                LR_TRY(lr__gltf_get_index(d, at, q, c->string, nacc, &x, err));
                LR_TRY(lr__gltf_check_attribute(d, q, c->string, x, &cnt, err));
                if (nvert < 0)
                    nvert = cnt;
                if (cnt != nvert)
                    return lr__gltf_fail(d, err,
                                         "%s.%s has %lld elements, "
                                         "%s %lld",
                                         q, c->string, cnt, first, nvert);
            }
            LR_TRY(lr__gltf_get_index(d, pr, p, "indices", nacc, &x, err));
            if (x >= 0) {
                LR_TRY(lr__gltf_check_attribute(d, p, "indices", x, &cnt, err));
                LR_TRY(check_index_values(d, p, x, nvert, err));
            }
            LR_TRY(lr__gltf_get_index(d, pr, p, "material", nmat, &x, err));
            LR_TRY(lr__gltf_get_uint(d, pr, p, "mode", 7, 4, &mode, err));
            int nt;
            LR_TRY(check_targets(d, pr, p, nvert, &nt, err));
            if (j == 0)
                targets = nt;
            else if (nt != targets)
                return lr__gltf_fail(d, err,
                                     "%s has %d morph targets, "
                                     "primitives[0] %d (the spec asks for "
                                     "the same number)",
                                     p, nt, targets);
        }
        snprintf(p, sizeof p, "meshes[%d]", i);
        LR_TRY(check_weights(d, m, p, targets, err));
    }
    return LR_OK;
}

/* Skins (spec 3.7.3): joints, a non-empty array of node indices, and
 * inverseBindMatrices, MAT4 floats (finite numbers), at least one per
 * joint. */
static lr_status check_skins(const lr__gltf_doc *d, lr_error *err)
{
    int ns, nacc, nn;
    const cJSON *skins = lr__gltf_array(d->root, "skins", &ns);
    lr__gltf_array(d->root, "accessors", &nacc);
    lr__gltf_array(d->root, "nodes", &nn);
    int i = 0;
    char p[64];
    for (const cJSON *sk = skins ? skins->child : NULL; sk;
         sk = sk->next, i++) {
        snprintf(p, sizeof p, "skins[%d]", i);
        int nj;
        const cJSON *joints = lr__gltf_array(sk, "joints", &nj);
        int ok = nj > 0;
        for (const cJSON *j = ok ? joints->child : NULL; j; j = j->next)
            ok = ok && cJSON_IsNumber(j) && j->valuedouble >= 0 &&
                 j->valuedouble < nn && j->valuedouble == floor(j->valuedouble);
        if (!ok)
            return lr__gltf_fail(d, err,
                                 "%s.joints must be a non-empty "
                                 "array of indices below %d",
                                 p, nn);
        long long x, sk_node;
        LR_TRY(lr__gltf_get_index(d, sk, p, "skeleton", nn, &sk_node, err));
        LR_TRY(
            lr__gltf_get_index(d, sk, p, "inverseBindMatrices", nacc, &x, err));
        if (x < 0)
            continue;
        const cJSON *a = cJSON_GetArrayItem(
            lr__gltf_array(d->root, "accessors", &nacc), (int)x);
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(a, "type");
        size_t stride, cs;
        long long count;
        const unsigned char *m = lr__gltf_accessor_at(d, x, &stride, &count,
                                                      &cs);
        if (cJSON_GetNumberValue(
                cJSON_GetObjectItemCaseSensitive(a, "componentType")) != 5126 ||
            strcmp(t->valuestring, "MAT4") != 0 || count < nj)
            return lr__gltf_fail(d, err,
                                 "%s.inverseBindMatrices: "
                                 "accessors[%lld] must be %d or more MAT4 "
                                 "of floats",
                                 p, x, nj);
        for (long long e = 0; e < count * 16; e++) {
            float f;
            memcpy(&f, m + (size_t)(e / 16) * stride + (size_t)(e % 16) * 4,
                   sizeof f);
            /* Only finite: a joint no vertex weighs may hold anything
             * (tinygltf's unassigned-skeleton.gltf has 1.2e18); a used
             * one that throws a vertex too far is refused when placed. */
            if (!isfinite(f))
                return lr__gltf_fail(d, err,
                                     "%s.inverseBindMatrices: "
                                     "accessors[%lld] holds %g",
                                     p, x, (double)f);
        }
    }
    return LR_OK;
}

/* A skinned node's mesh (spec 3.7.3.3): every primitive has JOINTS_0 and
 * WEIGHTS_0, and every joint index names one of the skin's joints. */
static lr_status check_skinned(const lr__gltf_doc *d, const char *p,
                               long long mesh, long long skin, lr_error *err)
{
    int n, nj, np;
    const cJSON *sk = cJSON_GetArrayItem(lr__gltf_array(d->root, "skins", &n),
                                         (int)skin);
    lr__gltf_array(sk, "joints", &nj);
    const cJSON *m = cJSON_GetArrayItem(lr__gltf_array(d->root, "meshes", &n),
                                        (int)mesh);
    const cJSON *prims = lr__gltf_array(m, "primitives", &np);
    int k = 0;
    for (const cJSON *pr = prims->child; pr; pr = pr->next, k++) {
        const cJSON *at = cJSON_GetObjectItemCaseSensitive(pr, "attributes");
        if (!cJSON_GetObjectItemCaseSensitive(at, "JOINTS_0") ||
            !cJSON_GetObjectItemCaseSensitive(at, "WEIGHTS_0"))
            return lr__gltf_fail(d, err,
                                 "%s: meshes[%lld].primitives[%d] "
                                 "of a skinned node needs JOINTS_0 and "
                                 "WEIGHTS_0",
                                 p, mesh, k);
        for (const cJSON *c = at->child; c; c = c->next) {
            if (strncmp(c->string, "JOINTS_", 7) != 0)
                continue;
            size_t stride, cs;
            long long count;
            const unsigned char *q = lr__gltf_accessor_at(
                d, (long long)c->valuedouble, &stride, &count, &cs);
            for (long long e = 0; e < 4 * count; e++) {
                unsigned long j = lr__gltf_read_uint(
                    q + (size_t)(e / 4) * stride + (size_t)(e % 4) * cs, cs);
                if ((long long)j >= nj)
                    return lr__gltf_fail(d, err,
                                         "%s: meshes[%lld]."
                                         "primitives[%d].attributes.%s: "
                                         "joint %lu of a skin of %d joints",
                                         p, mesh, k, c->string, j, nj);
            }
        }
    }
    return LR_OK;
}

/* The node graph must be a forest (spec 3.5.3): every node the child of
 * at most one parent, no cycle, scene roots without parents. */
static lr_status check_nodes(lr__gltf_doc *d, lr_error *err)
{
    int n, nmesh, ncam, nlight, nsc, nskin;
    const cJSON *a = lr__gltf_array(d->root, "nodes", &n);
    lr__gltf_array(d->root, "meshes", &nmesh);
    lr__gltf_array(d->root, "skins", &nskin);
    LR_TRY(check_skins(d, err));
    lr__gltf_array(d->root, "cameras", &ncam);
    lr__gltf_array(
        lr__gltf_member(d->root, "extensions", "KHR_lights_punctual"), "lights",
        &nlight);
    d->n_nodes = n;
    int *parent = malloc((n ? (size_t)n : 1) * sizeof *parent);
    if (parent == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < n; i++)
        parent[i] = -1;
    lr_status st = LR_OK;
    char p[64];
    int i = 0;
    for (const cJSON *o = a ? a->child : NULL; o && st == LR_OK;
         o = o->next, i++) {
        snprintf(p, sizeof p, "nodes[%d]", i);
        long long x;
        if (!cJSON_IsObject(o)) {
            st = lr__gltf_fail(d, err, "%s must be an object", p);
            break;
        }
        long long mesh = -1, skin = -1;
        st = lr__gltf_get_index(d, o, p, "mesh", nmesh, &mesh, err);
        if (st == LR_OK)
            st = lr__gltf_get_index(d, o, p, "camera", ncam, &x, err);
        if (st == LR_OK)
            st = check_numbers(d, o, p, "matrix", 16, err);
        if (st == LR_OK)
            st = check_numbers(d, o, p, "translation", 3, err);
        if (st == LR_OK)
            st = check_numbers(d, o, p, "rotation", 4, err);
        if (st == LR_OK)
            st = check_numbers(d, o, p, "scale", 3, err);
        if (st == LR_OK)
            st = lr__gltf_get_index(d, o, p, "skin", nskin, &skin, err);
        if (st == LR_OK && skin >= 0 && mesh >= 0)
            st = check_skinned(d, p, mesh, skin, err);
        /* A node's weights override its mesh's (spec 3.7.2.2). */
        if (st == LR_OK &&
            cJSON_GetObjectItemCaseSensitive(o, "weights") != NULL)
            st = check_weights(d, o, p, mesh < 0 ? 0 : mesh_targets(d, mesh),
                               err);
        if (st != LR_OK)
            break;
        const cJSON *l = lr__gltf_member(o, "extensions",
                                         "KHR_lights_punctual");
        if (l != NULL)
            st = lr__gltf_get_index(d, l, p, "light", nlight, &x, err);
        if (st != LR_OK)
            break;
        int nc;
        const cJSON *ch = lr__gltf_array(o, "children", &nc);
        if (ch == NULL && cJSON_GetObjectItemCaseSensitive(o, "children")) {
            st = lr__gltf_fail(d, err, "%s.children must be an array", p);
            break;
        }
        for (const cJSON *c = ch ? ch->child : NULL; c; c = c->next) {
            double v = cJSON_IsNumber(c) ? c->valuedouble : -1;
            if (!(v >= 0 && v < n && v == floor(v))) {
                st = lr__gltf_fail(d, err,
                                   "%s.children must be indices "
                                   "below %d",
                                   p, n);
                break;
            }
            if (parent[(int)v] >= 0 || (int)v == i) {
                st = lr__gltf_fail(d, err,
                                   "nodes[%d] is the child of more "
                                   "than one node (or of itself)",
                                   (int)v);
                break;
            }
            parent[(int)v] = i;
        }
    }
    /* Without a second parent, a cycle is a walk up that never ends. */
    for (int k = 0; k < n && st == LR_OK; k++) {
        int up = k, steps = 0;
        while (up >= 0 && steps <= n) {
            up = parent[up];
            steps++;
        }
        if (up >= 0)
            st = lr__gltf_fail(d, err, "nodes[%d] is its own ancestor", k);
    }
    const cJSON *scenes = lr__gltf_array(d->root, "scenes", &nsc);
    int si = 0;
    for (const cJSON *s = scenes ? scenes->child : NULL; s && st == LR_OK;
         s = s->next, si++) {
        int nr;
        const cJSON *r = lr__gltf_array(s, "nodes", &nr);
        for (const cJSON *c = r ? r->child : NULL; c; c = c->next) {
            double v = cJSON_IsNumber(c) ? c->valuedouble : -1;
            if (!(v >= 0 && v < n && v == floor(v)) || parent[(int)v] >= 0) {
                st = lr__gltf_fail(d, err,
                                   "scenes[%d].nodes must be "
                                   "indices of root nodes",
                                   si);
                break;
            }
        }
    }
    free(parent);
    if (st != LR_OK)
        return st;
    long long sc;
    LR_TRY(lr__gltf_get_index(d, d->root, "", "scene", nsc, &sc, err));
    /* Without scenes a glTF is a library of parts that nothing places
     * (spec 3.5.1); assimp would say only "GLTF: No scene". */
    if (nsc == 0)
        return lr__gltf_fail(d, err, "it has no scenes: nothing to draw");
    return LR_OK;
}

/* Images (a file, a data: URI or a bufferView), textures and the texture
 * references of materials. */
static lr_status check_images(lr__gltf_doc *d, const char *dir, lr_error *err)
{
    int ni, nt, nv, nm, nsamp;
    const cJSON *imgs = lr__gltf_array(d->root, "images", &ni);
    const cJSON *texs = lr__gltf_array(d->root, "textures", &nt);
    const cJSON *mats = lr__gltf_array(d->root, "materials", &nm);
    lr__gltf_array(d->root, "bufferViews", &nv);
    lr__gltf_array(d->root, "samplers", &nsamp);
    char p[96];
    int i = 0;
    long long x;
    for (const cJSON *im = imgs ? imgs->child : NULL; im; im = im->next) {
        snprintf(p, sizeof p, "images[%d]", i++);
        const cJSON *uri = cJSON_GetObjectItemCaseSensitive(im, "uri");
        LR_TRY(lr__gltf_get_index(d, im, p, "bufferView", nv, &x, err));
        if (cJSON_IsString(uri)) {
            lr__gltf_blob *b;
            LR_TRY(lr__gltf_read_blob(d, dir, p, uri->valuestring, &b, err));
        } else if (x < 0) {
            return lr__gltf_fail(d, err, "%s needs a uri or a bufferView", p);
        }
    }
    i = 0;
    for (const cJSON *t = texs ? texs->child : NULL; t; t = t->next) {
        snprintf(p, sizeof p, "textures[%d]", i++);
        LR_TRY(lr__gltf_get_index(d, t, p, "source", ni, &x, err));
        LR_TRY(lr__gltf_get_index(d, t, p, "sampler", nsamp, &x, err));
    }
    static const char *const slots[][2] = {
        {"pbrMetallicRoughness", "baseColorTexture"},
        {"pbrMetallicRoughness", "metallicRoughnessTexture"},
        {NULL, "emissiveTexture"},
        {NULL, "normalTexture"},
        {NULL, "occlusionTexture"}};
    i = 0;
    for (const cJSON *m = mats ? mats->child : NULL; m; m = m->next, i++) {
        if (!cJSON_IsObject(m))
            return lr__gltf_fail(d, err, "materials[%d] must be an object", i);
        for (int k = 0; k < 5; k++) {
            const cJSON *o = slots[k][0]
                                 ? lr__gltf_member(m, slots[k][0], slots[k][1])
                                 : cJSON_GetObjectItemCaseSensitive(
                                       m, slots[k][1]);
            /* The slot's whole path: two of them sit inside
             * pbrMetallicRoughness. */
            snprintf(p, sizeof p, "materials[%d].%s%s%s", i,
                     slots[k][0] ? slots[k][0] : "", slots[k][0] ? "." : "",
                     slots[k][1]);
            if (o != NULL)
                LR_TRY(lr__gltf_get_index(d, o, p, "index", nt, &x, err));
            if (o != NULL && x < 0)
                return lr__gltf_fail(d, err, "%s.index is required", p);
        }
    }
    return LR_OK;
}

static lr_status check_top(lr__gltf_doc *d, lr_error *err)
{
    const cJSON *asset = cJSON_GetObjectItemCaseSensitive(d->root, "asset");
    const cJSON *ver = cJSON_GetObjectItemCaseSensitive(asset, "version");
    if (!cJSON_IsString(ver) || strncmp(ver->valuestring, "2.", 2) != 0)
        return lr__gltf_fail(d, err,
                             "asset.version must be \"2.0\" (glTF 1 "
                             "and others are not read)");
    int n;
    const cJSON *req = lr__gltf_array(d->root, "extensionsRequired", &n);
    for (const cJSON *e = req ? req->child : NULL; e; e = e->next) {
        int k = 0;
        while (cJSON_IsString(e) && known_ext[k] &&
               strcmp(known_ext[k], e->valuestring) != 0)
            k++;
        if (!cJSON_IsString(e) || known_ext[k] == NULL)
            return lr__gltf_fail(d, err,
                                 "extensionsRequired: %.60s is not "
                                 "read by lensray",
                                 cJSON_IsString(e) ? e->valuestring : "?");
    }
    /* Arrays the checks index must be arrays of objects when present. */
    static const char *const arrays[] = {
        "buffers", "bufferViews", "accessors", "meshes", "nodes",
        "scenes",  "materials",   "textures",  "images", "samplers",
        "cameras", "skins",       NULL};
    for (int k = 0; arrays[k]; k++) {
        const cJSON *a = cJSON_GetObjectItemCaseSensitive(d->root, arrays[k]);
        if (a == NULL)
            continue;
        if (!cJSON_IsArray(a))
            return lr__gltf_fail(d, err, "%s must be an array", arrays[k]);
        int i = 0;
        for (const cJSON *c = a->child; c; c = c->next, i++)
            if (!cJSON_IsObject(c))
                return lr__gltf_fail(d, err, "%s[%d] must be an object",
                                     arrays[k], i);
    }
    return LR_OK;
}

lr_status lr__gltf_doc_load(const char *file, const char *shown, const char *fp,
                            lr__gltf_doc *d, lr_error *err)
{
    memset(d, 0, sizeof *d);
    d->fp = fp;
    d->shown = shown;
    char *buf = NULL;
    lr_status st = lr__read_file(file, shown, fp, LR__GLTF_MAX_BYTES,
                                 "glTF files", NULL, &buf, &d->n_bytes, err);
    if (st != LR_OK)
        return st;
    d->bytes = (unsigned char *)buf;
    const char *json = buf;
    size_t n = d->n_bytes;
    d->glb = n >= 4 && memcmp(buf, "glTF", 4) == 0;
    if (d->glb)
        st = lr__gltf_read_glb(d, &json, &n, err);
    if (st == LR_OK) {
        lr_error e2;
        st = lr__json_parse(json ? json : "", n, shown, "", &d->root, &e2);
        if (st == LR_ERR_NOMEM)
            lr__fail(err, st, NULL, "out of memory");
        else if (st != LR_OK &&
                 strncmp(e2.message, shown, strlen(shown)) == 0 &&
                 e2.message[strlen(shown)] == ':')
            lr__fail(err, st, fp, "%s: %s", fp, e2.message);
        else if (st != LR_OK)
            lr__fail(err, st, fp, "%s: %s: %s", fp, shown, e2.message);
        else if (!cJSON_IsObject(d->root))
            st = lr__gltf_fail(d, err, "a glTF file must be a JSON object");
    }
    /* External files are relative to the glTF's directory. */
    char dir[4096];
    lr__dir_of(file, dir, sizeof dir);
    if (st == LR_OK)
        st = check_top(d, err);
    if (st == LR_OK)
        st = lr__gltf_check_buffers(d, dir, err);
    if (st == LR_OK)
        st = lr__gltf_check_views(d, err);
    if (st == LR_OK)
        st = lr__gltf_check_accessors(d, err);
    if (st == LR_OK)
        st = check_meshes(d, err);
    if (st == LR_OK)
        st = check_nodes(d, err);
    if (st == LR_OK)
        st = check_images(d, dir, err);
    if (st != LR_OK)
        lr__gltf_doc_free(d);
    return st;
}
