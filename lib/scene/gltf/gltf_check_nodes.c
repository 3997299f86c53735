/*
 * gltf_check_nodes.c: a glTF document's skins and nodes checked before
 * libassimp sees them (gltf_check.c checks the rest, in order): indices in
 * range, transforms of finite numbers, skins whose joints and inverse bind
 * matrices agree, skinned meshes' joint attributes, morph weights, the
 * node hierarchy.  Every error names the field.
 */
#include "scene/gltf/gltf_doc.h"
#include "json/json_util.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* An optional array of exactly n numbers of magnitude at most 1e15. */
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
                             "%s.%s must be an array of %d numbers of "
                             "magnitude at most 1e15",
                             path, key, n);
    return LR_OK;
}

/* The number of morph targets of meshes[m] (check_meshes made it the
 * same for every primitive). */
static int mesh_targets(const lr__gltf_doc *d, long long m)
{
    int np, nt;
    const cJSON *mesh = d->mesh_at[m];
    const cJSON *prims = lr__gltf_array(mesh, "primitives", &np);
    lr__gltf_array(prims ? prims->child : NULL, "targets", &nt);
    return nt;
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

/* No node is its own ancestor, and none lies deeper than
 * LR__GLTF_MAX_DEPTH below its root: the walks over the hierarchy (ours
 * and libassimp's) recurse once a level, and a chain of 15,000 nodes (600
 * KB of JSON) overflowed the stack, in the daemon too.  Each node's depth
 * once (up from it to the first node whose depth is known), so a chain is
 * linear where walking up from every node was quadratic. */
static lr_status check_depths(const lr__gltf_doc *d, const int *parent, int n,
                              lr_error *err)
{
    int *depth = malloc((n ? (size_t)n : 1) * sizeof *depth);
    if (depth == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int k = 0; k < n; k++)
        depth[k] = -1; /* unknown; -2: on the walk under way */
    lr_status st = LR_OK;
    for (int k = 0; k < n && st == LR_OK; k++) {
        /* Up to the first node known (or a root), marking the way. */
        int up = k;
        while (up >= 0 && depth[up] == -1) {
            depth[up] = -2;
            up = parent[up];
        }
        if (up >= 0 && depth[up] == -2) {
            st = lr__gltf_fail(d, err, "nodes[%d] is its own ancestor", up);
            break;
        }
        /* Down again: count the way (its length, then each depth). */
        int base = up >= 0 ? depth[up] : -1, len = 0;
        for (int v = k; v != up; v = parent[v])
            len++;
        for (int v = k, at = base + len; v != up; v = parent[v], at--)
            depth[v] = at;
        if (depth[k] > LR__GLTF_MAX_DEPTH)
            st = lr__gltf_fail(d, err,
                               "nodes[%d] lies %d levels below its root: at "
                               "most %d",
                               k, depth[k], LR__GLTF_MAX_DEPTH);
    }
    free(depth);
    return st;
}

/* The node graph must be a forest (spec 3.5.3): every node the child of
 * at most one parent, no cycle, scene roots without parents. */
lr_status lr__gltf_check_nodes(lr__gltf_doc *d, lr_error *err)
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
    d->node_at = lr__gltf_table(d->root, "nodes", n);
    d->mesh_at = lr__gltf_table(d->root, "meshes", nmesh);
    d->n_meshes = nmesh;
    if (d->node_at == NULL || d->mesh_at == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
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
            st = lr__gltf_check_weights(
                d, o, p, mesh < 0 ? 0 : mesh_targets(d, mesh), err);
        if (st != LR_OK)
            break;
        const cJSON *l = lr__gltf_member(o, "extensions",
                                         "KHR_lights_punctual");
        if (l != NULL) {
            /* The field by its whole path (it was named nodes[i].light). */
            char pl[128];
            snprintf(pl, sizeof pl, "%s.extensions.KHR_lights_punctual", p);
            st = lr__gltf_get_index(d, l, pl, "light", nlight, &x, err);
        }
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
    if (st == LR_OK)
        st = check_depths(d, parent, n, err);
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
