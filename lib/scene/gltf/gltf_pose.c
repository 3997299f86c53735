/*
 * gltf_pose.c: meshes posed for assimp (gltf_assimp.c): a node whose mesh
 * has morph targets at non-zero weights, or a skin, gets a mesh of its own
 * in the reduced document whose POSITION and NORMAL are morphed and
 * skinned here, into the extra buffer (gltf_extra.h).  assimp never sees
 * the targets nor the skins.
 */
#include "scene/gltf/gltf_extra.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int lr__gltf_skinned(const lr__gltf_doc *d, int i)
{
    const cJSON *node = d->node_at[i];
    return item(node, "mesh") != NULL && item(node, "skin") != NULL;
}

/* A node's pose for posed(): its mesh's morph weights, and its skin's
 * joint matrices (each joint node's world transform times its inverse
 * bind matrix, spec 3.7.3.3). */
typedef struct pose {
    const cJSON *weights; /* non-zero morph weights, or NULL */
    lr__xform *joint;     /* one per joint, or NULL without a skin */
} pose;

/* Adds morph target displacements at weights w to the floats f of
 * attribute attr of primitive pr (spec 3.7.2.2: the base plus the
 * weighted sum of the targets'). */
static void morph(const lr__gltf_doc *d, const cJSON *pr, const char *attr,
                  const cJSON *w, float *f)
{
    int nt;
    const cJSON *ts = lr__gltf_array(pr, "targets", &nt);
    const cJSON *wk = w->child;
    for (const cJSON *t = ts ? ts->child : NULL; t && wk;
         t = t->next, wk = wk->next) {
        const cJSON *ta = item(t, attr);
        if (ta == NULL || wk->valuedouble == 0)
            continue;
        size_t stride, cs;
        long long count;
        const unsigned char *q = lr__gltf_accessor_at(
            d, (long long)ta->valuedouble, &stride, &count, &cs);
        for (size_t i = 0; i < 3 * (size_t)count; i++) {
            float dv;
            memcpy(&dv, q + i / 3 * stride + i % 3 * sizeof(float), sizeof dv);
            f[i] = (float)(f[i] + wk->valuedouble * dv);
        }
    }
}

/* An accessor of joint indices or weights, found once. */
typedef struct vec4_at {
    const unsigned char *p;
    size_t stride, cs;
    int is_float, normalized;
} vec4_at;

static vec4_at vec4_of(const lr__gltf_doc *d, const cJSON *acc)
{
    vec4_at v;
    long long count, k = (long long)acc->valuedouble;
    v.p = lr__gltf_accessor_at(d, k, &v.stride, &count, &v.cs);
    int n;
    const cJSON *a = cJSON_GetArrayItem(
        lr__gltf_array(d->root, "accessors", &n), (int)k);
    v.is_float = cJSON_GetNumberValue(item(a, "componentType")) == 5126;
    v.normalized = cJSON_IsTrue(item(a, "normalized"));
    return v;
}

/* Component c of element e: joint indices as they are, normalized
 * weights scaled to [0, 1] (spec 3.11). */
static double vec4_get(const vec4_at *v, size_t e, int c)
{
    const unsigned char *q = v->p + e * v->stride + (size_t)c * v->cs;
    if (v->is_float) {
        float f;
        memcpy(&f, q, sizeof f);
        return f;
    }
    double x = v->cs == 1 ? q[0] : (double)(q[0] | q[1] << 8);
    return v->normalized ? x / (v->cs == 1 ? 255 : 65535) : x;
}

/* The skinning matrix of vertex v (spec 3.7.3.3): the sum over its
 * JOINTS_n / WEIGHTS_n (n sets in j, w) of weight x joint matrix. */
static lr__xform skin_matrix(const vec4_at *j, const vec4_at *w, int n,
                             const lr__xform *joint, size_t v)
{
    lr__xform sum;
    memset(&sum, 0, sizeof sum);
    for (int set = 0; set < n; set++)
        for (int c = 0; c < 4; c++) {
            double wt = vec4_get(&w[set], v, c);
            const lr__xform *m = &joint[(int)vec4_get(&j[set], v, c)];
            for (int r = 0; wt != 0 && r < 3; r++)
                for (int k = 0; k < 4; k++)
                    sum.m[r][k] += wt * m->m[r][k];
        }
    return sum;
}

/* The joint matrices of skin sk under the nodes' transforms `world`
 * (a new array, or NULL on no memory). */
static lr__xform *joint_matrices(const lr__gltf_doc *d, const cJSON *sk,
                                 const lr__xform *world)
{
    int nj;
    const cJSON *joints = lr__gltf_array(sk, "joints", &nj);
    const cJSON *ibm = item(sk, "inverseBindMatrices");
    lr__xform *out = malloc((size_t)nj * sizeof *out);
    size_t stride = 0, cs;
    long long count;
    const unsigned char *m = ibm ? lr__gltf_accessor_at(
                                       d, (long long)ibm->valuedouble, &stride,
                                       &count, &cs)
                                 : NULL;
    int i = 0;
    for (const cJSON *j = joints->child; out && j; j = j->next, i++) {
        lr__xform b = lr__xform_identity();
        /* A column-major MAT4: row r, column k is element 4 k + r. */
        for (int r = 0; m && r < 3; r++)
            for (int k = 0; k < 4; k++) {
                float f;
                memcpy(&f, m + (size_t)i * stride + (size_t)(4 * k + r) * 4,
                       sizeof f);
                b.m[r][k] = f;
            }
        out[i] = lr__xform_mul(&world[(int)j->valuedouble], &b);
    }
    return out;
}

/* Attribute `attr` (POSITION or NORMAL, VEC3 floats: gltf_check.c) of
 * the document's primitive `pr` in the node's pose: morphed, then skinned
 * into the glTF's world (a normal by the inverse transpose, unit length
 * again), as floats in the extra buffer; the new accessor's index in r,
 * -2 when the pose does not move it, -1 on no memory. */
static int posed(const lr__gltf_doc *d, const cJSON *pr, const char *attr,
                 const pose *ps, cJSON *r, lr__gltf_extra *u)
{
    const cJSON *base = item(item(pr, "attributes"), attr);
    int nt, moved = ps->joint != NULL;
    const cJSON *ts = lr__gltf_array(pr, "targets", &nt);
    for (const cJSON *t = ts ? ts->child : NULL; t; t = t->next)
        moved |= ps->weights != NULL && item(t, attr) != NULL;
    if (base == NULL || !moved)
        return -2;
    size_t stride, cs, at;
    long long count;
    const unsigned char *src = lr__gltf_accessor_at(
        d, (long long)base->valuedouble, &stride, &count, &cs);
    if (!lr__gltf_extra_grow(u, (size_t)count * 3 * sizeof(float), &at))
        return -1;
    float *f = (float *)(u->data + at);
    for (size_t i = 0; i < (size_t)count; i++)
        memcpy(f + 3 * i, src + i * stride, 3 * sizeof(float));
    if (ps->weights != NULL)
        morph(d, pr, attr, ps->weights, f);
    /* At most 8 sets of 4 joints each (gltf_check.c keeps them below
     * the skin's count). */
    vec4_at js[8], ws[8];
    int sets = 0;
    const cJSON *ats = item(pr, "attributes");
    for (; ps->joint != NULL && sets < 8; sets++) {
        char jn[24], wn[24];
        snprintf(jn, sizeof jn, "JOINTS_%d", sets);
        snprintf(wn, sizeof wn, "WEIGHTS_%d", sets);
        if (item(ats, jn) == NULL || item(ats, wn) == NULL)
            break;
        js[sets] = vec4_of(d, item(ats, jn));
        ws[sets] = vec4_of(d, item(ats, wn));
    }
    int normal = attr[0] == 'N';
    for (size_t i = 0; i < (size_t)count; i++) {
        lr__v3 p = v3(f[3 * i], f[3 * i + 1], f[3 * i + 2]);
        if (ps->joint != NULL) {
            lr__xform m = skin_matrix(js, ws, sets, ps->joint, i);
            p = normal ? lr__xform_normal(&m, p) : lr__xform_point(&m, p);
        } else if (normal && v3_len(p) > 0) {
            p = v3_norm(p);
        }
        /* Kept within a float's range: a vertex thrown beyond 1e15 is
         * refused when placed (gltf.c), naming the limit. */
        f[3 * i] = (float)fmax(-1e30, fmin(1e30, p.x));
        f[3 * i + 1] = (float)fmax(-1e30, fmin(1e30, p.y));
        f[3 * i + 2] = (float)fmax(-1e30, fmin(1e30, p.z));
    }
    return lr__gltf_extra_accessor(r, u, -1, at,
                                   (size_t)count * 3 * sizeof(float), 5126,
                                   (double)count, "VEC3", 0);
}

/* The weights a node draws its mesh's morph targets at: its own, else
 * its mesh's (spec 3.7.2.2), or NULL when they are all zero. */
static const cJSON *node_weights(const cJSON *node, const cJSON *mesh)
{
    const cJSON *w = item(node, "weights");
    if (w == NULL)
        w = item(mesh, "weights");
    for (const cJSON *c = w ? w->child : NULL; c; c = c->next)
        if (c->valuedouble != 0)
            return w;
    return NULL;
}

/* Appends to r's meshes a copy of its meshes[m] (the document's `mesh`)
 * whose POSITION and NORMAL are posed by ps.  0 on no memory. */
static int pose_mesh(const lr__gltf_doc *d, const pose *ps, const cJSON *mesh,
                     int m, cJSON *r, lr__gltf_extra *u)
{
    cJSON *rmeshes = cJSON_GetObjectItemCaseSensitive(r, "meshes");
    cJSON *copy = cJSON_Duplicate(cJSON_GetArrayItem(rmeshes, m), 1);
    if (copy == NULL || !cJSON_AddItemToArray(rmeshes, copy)) {
        cJSON_Delete(copy);
        return 0;
    }
    /* The copy lacks the primitives that are not drawn. */
    cJSON *cp = item(copy, "primitives")->child;
    for (const cJSON *pr = item(mesh, "primitives")->child; pr && cp;
         pr = pr->next) {
        if (!drawn(pr))
            continue;
        static const char *const attrs[] = {"POSITION", "NORMAL"};
        for (int k = 0; k < 2; k++) {
            int a = posed(d, pr, attrs[k], ps, r, u);
            cJSON *at = cJSON_GetObjectItemCaseSensitive(cp, "attributes");
            if (a == -1 || (a >= 0 && !cJSON_ReplaceItemInObjectCaseSensitive(
                                          at, attrs[k], cJSON_CreateNumber(a))))
                return 0;
        }
        cp = cp->next;
    }
    return 1;
}

/* Each node whose mesh is morphed (targets at non-zero default weights)
 * or skinned gets, in the reduced copy r, a mesh of its own whose
 * POSITION and NORMAL are posed (posed()); assimp is never given the
 * targets nor the skins.  A still image then shows what glTF viewers show
 * before any animation: the targets at the file's weights (spec 3.7.2.2)
 * and the skin at its joints' own transforms (3.7.3.3). */
int lr__gltf_pose_meshes(const lr__gltf_doc *d, const lr__xform *world,
                         cJSON *r, lr__gltf_extra *u)
{
    int nn, ns;
    const cJSON *nodes = lr__gltf_array(d->root, "nodes", &nn);
    const cJSON *skins = lr__gltf_array(d->root, "skins", &ns);
    cJSON *rmeshes = cJSON_GetObjectItemCaseSensitive(r, "meshes");
    cJSON *rnodes = cJSON_GetObjectItemCaseSensitive(r, "nodes");
    /* r's nodes in step with d's (r is a copy: the same order). */
    cJSON *rn = rnodes ? rnodes->child : NULL;
    for (const cJSON *n = nodes ? nodes->child : NULL; n;
         n = n->next, rn = rn ? rn->next : NULL) {
        const cJSON *mi = item(n, "mesh");
        if (mi == NULL)
            continue;
        int m = (int)mi->valuedouble;
        const cJSON *mesh = d->mesh_at[m];
        const cJSON *sk = item(n, "skin");
        pose ps = {node_weights(n, mesh), NULL};
        if (ps.weights == NULL && sk == NULL)
            continue;
        if (sk != NULL) {
            ps.joint = joint_matrices(
                d, cJSON_GetArrayItem(skins, (int)sk->valuedouble), world);
            if (ps.joint == NULL)
                return 0;
        }
        int ok = pose_mesh(d, &ps, mesh, m, r, u) &&
                 cJSON_ReplaceItemInObjectCaseSensitive(
                     rn, "mesh",
                     cJSON_CreateNumber(cJSON_GetArraySize(rmeshes) - 1));
        free(ps.joint);
        if (!ok)
            return 0;
    }
    return 1;
}
