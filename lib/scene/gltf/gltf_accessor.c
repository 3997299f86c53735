/*
 * gltf_accessor.c: a glTF document's binary data checked (gltf_doc.h;
 * spec 3.6): buffers, bufferViews and accessors in bounds, sparse
 * accessors and accessors without a view made dense copies, an
 * attribute's component type and type, and where an accessor's elements
 * lie.  gltf_check.c checks the rest of the document.
 */
#include "scene/gltf/gltf_doc.h"
#include "json/json_util.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


lr_status lr__gltf_check_buffers(lr__gltf_doc *d, const char *dir,
                                 lr_error *err)
{
    int n;
    const cJSON *a = lr__gltf_array(d->root, "buffers", &n);
    d->buffers = calloc(n ? (size_t)n : 1, sizeof *d->buffers);
    if (d->buffers == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    d->n_buffers = (size_t)n;
    int i = 0;
    char p[64];
    for (const cJSON *b = a ? a->child : NULL; b; b = b->next, i++) {
        snprintf(p, sizeof p, "buffers[%d]", i);
        long long len;
        LR_TRY(lr__gltf_get_uint(d, b, p, "byteLength", 0, -1, &len, err));
        if (len < 1 || len > LR__GLTF_MAX_BYTES)
            return lr__gltf_fail(d, err,
                                 "%s.byteLength must be between 1 "
                                 "and %u",
                                 p, LR__GLTF_MAX_BYTES);
        const cJSON *uri = cJSON_GetObjectItemCaseSensitive(b, "uri");
        if (uri != NULL && !cJSON_IsString(uri))
            return lr__gltf_fail(d, err, "%s.uri must be a string", p);
        const unsigned char *data;
        size_t have;
        if (uri == NULL) {
            if (i != 0 || d->bin == NULL)
                return lr__gltf_fail(d, err,
                                     "%s has no uri (only a GLB's "
                                     "first buffer, its BIN chunk, may "
                                     "have none)",
                                     p);
            data = d->bin;
            have = d->n_bin;
        } else {
            lr__gltf_blob *bl;
            LR_TRY(lr__gltf_read_blob(d, dir, p, uri->valuestring, &bl, err));
            data = bl->data;
            have = bl->n;
        }
        if ((size_t)len > have)
            return lr__gltf_fail(d, err,
                                 "%s.byteLength is %lld but its data "
                                 "has %zu bytes",
                                 p, len, have);
        d->buffers[i].data = data;
        d->buffers[i].n = (size_t)len;
    }
    return LR_OK;
}

lr_status lr__gltf_check_views(lr__gltf_doc *d, lr_error *err)
{
    int n;
    const cJSON *a = lr__gltf_array(d->root, "bufferViews", &n);
    int i = 0;
    char p[64];
    for (const cJSON *v = a ? a->child : NULL; v; v = v->next, i++) {
        snprintf(p, sizeof p, "bufferViews[%d]", i);
        long long b, off, len, stride;
        LR_TRY(
            lr__gltf_get_index(d, v, p, "buffer", (int)d->n_buffers, &b, err));
        LR_TRY(lr__gltf_get_uint(d, v, p, "byteOffset", 0, 0, &off, err));
        LR_TRY(lr__gltf_get_uint(d, v, p, "byteLength", 0, -1, &len, err));
        LR_TRY(lr__gltf_get_uint(d, v, p, "byteStride", 0, 0, &stride, err));
        if (b < 0 || len < 1)
            return lr__gltf_fail(d, err,
                                 "%s needs a buffer and a "
                                 "byteLength >= 1",
                                 p);
        if ((unsigned long long)off + (unsigned long long)len > d->buffers[b].n)
            return lr__gltf_fail(d, err,
                                 "%s: bytes %lld to %lld are "
                                 "beyond buffers[%lld]'s %zu",
                                 p, off, off + len, b, d->buffers[b].n);
        if (stride != 0 && (stride < 4 || stride > 252 || stride % 4 != 0))
            return lr__gltf_fail(d, err,
                                 "%s.byteStride must be a multiple "
                                 "of 4 from 4 to 252, got %lld",
                                 p, stride);
    }
    return LR_OK;
}

static int component_size(long long t)
{
    switch (t) {
    case 5120:
    case 5121:
        return 1;
    case 5122:
    case 5123:
        return 2;
    case 5125:
    case 5126:
        return 4;
    default:
        return 0;
    }
}

static int type_count(const char *t)
{
    static const char *const names[] = {"SCALAR", "VEC2", "VEC3", "VEC4",
                                        "MAT2",   "MAT3", "MAT4"};
    static const int counts[] = {1, 2, 3, 4, 4, 9, 16};
    for (int i = 0; i < 7; i++)
        if (strcmp(t, names[i]) == 0)
            return counts[i];
    return 0;
}

/* bufferViews[v] and accessors[i], from the tables once they are made
 * (a cJSON array is a list: a look-up by index walks it). */
static const cJSON *view_of(const lr__gltf_doc *d, long long v)
{
    int n;
    if (d->view_at != NULL)
        return v >= 0 && v < d->n_views ? d->view_at[v] : NULL;
    return cJSON_GetArrayItem(lr__gltf_array(d->root, "bufferViews", &n),
                              (int)v);
}

static const cJSON *accessor_of(const lr__gltf_doc *d, long long i)
{
    int n;
    if (d->acc_at != NULL)
        return i >= 0 && i < (long long)d->n_accessors ? d->acc_at[i] : NULL;
    return cJSON_GetArrayItem(lr__gltf_array(d->root, "accessors", &n), (int)i);
}

/* Where view v's bytes start in its buffer (lr__gltf_check_views has put them
 * there) and how many it has. */
static const unsigned char *view_bytes(const lr__gltf_doc *d, long long v,
                                       long long *len)
{
    const cJSON *view = view_of(d, v);
    const cJSON *off = cJSON_GetObjectItemCaseSensitive(view, "byteOffset");
    long long b = (long long)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(view, "buffer"));
    *len = (long long)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(view, "byteLength"));
    return d->buffers[b].data + (size_t)(off ? off->valuedouble : 0);
}

/* The bytes of accessor copies (zero-filled or sparse) allowed in all: a
 * tiny file must not make lensray allocate gigabytes, yet a mesh's
 * sparse morph targets stay within the budget of the buffers' size. */
static size_t dense_budget(const lr__gltf_doc *d)
{
    size_t n = 16u << 20;
    for (size_t i = 0; i < d->n_buffers; i++)
        n += 4 * d->buffers[i].n;
    return n;
}

/* A sparse accessor's indices or values (spec 3.6.2.3, "accessor.sparse"):
 * `n` elements of `size` bytes at the bufferView and byteOffset of
 * sparse.KEY, which must lie within that view; the view must not be
 * strided. */
static lr_status sparse_part(const lr__gltf_doc *d, const cJSON *sp,
                             const char *p, const char *key, long long n,
                             long long size, const unsigned char **out,
                             lr_error *err)
{
    char q[96];
    snprintf(q, sizeof q, "%s.sparse.%s", p, key);
    const cJSON *o = cJSON_GetObjectItemCaseSensitive(sp, key);
    int nv;
    lr__gltf_array(d->root, "bufferViews", &nv);
    long long v, off, len;
    if (!cJSON_IsObject(o))
        return lr__gltf_fail(d, err, "%s must be an object", q);
    LR_TRY(lr__gltf_get_index(d, o, q, "bufferView", nv, &v, err));
    LR_TRY(lr__gltf_get_uint(d, o, q, "byteOffset", 0, 0, &off, err));
    if (v < 0)
        return lr__gltf_fail(d, err, "%s.bufferView is required", q);
    const cJSON *view = view_of(d, v);
    if (cJSON_GetObjectItemCaseSensitive(view, "byteStride") != NULL)
        return lr__gltf_fail(d, err,
                             "%s: bufferViews[%lld] has a "
                             "byteStride, which sparse data must not have",
                             q, v);
    const unsigned char *base = view_bytes(d, v, &len);
    if ((unsigned long long)off +
            (unsigned long long)n * (unsigned long long)size >
        (unsigned long long)len)
        return lr__gltf_fail(d, err,
                             "%s: %lld elements of %lld bytes from "
                             "byte %lld run past bufferViews[%lld]'s %lld",
                             q, n, size, off, v, len);
    *out = base + off;
    return LR_OK;
}

unsigned long lr__gltf_read_uint(const unsigned char *q, size_t cs)
{
    return cs == 1   ? q[0]
           : cs == 2 ? (unsigned long)(q[0] | q[1] << 8)
                     : (unsigned long)lr__gltf_le32(q);
}

/* Writes accessor x's sparse values over its `count` elements of `elem`
 * bytes in `dense` (spec 3.6.2.3): indices strictly increasing and below
 * count. */
static lr_status apply_sparse(const lr__gltf_doc *d, const cJSON *x,
                              const char *p, long long count, long long elem,
                              unsigned char *dense, lr_error *err)
{
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(x, "sparse");
    long long n, ict;
    if (!cJSON_IsObject(sp))
        return lr__gltf_fail(d, err, "%s.sparse must be an object", p);
    char q[96];
    snprintf(q, sizeof q, "%s.sparse", p);
    LR_TRY(lr__gltf_get_uint(d, sp, q, "count", 0, -1, &n, err));
    if (n < 1 || n > count)
        return lr__gltf_fail(d, err,
                             "%s.count must be from 1 to the "
                             "accessor's count, %lld",
                             q, count);
    char qi[112];
    snprintf(qi, sizeof qi, "%s.indices", q);
    const cJSON *ind = cJSON_GetObjectItemCaseSensitive(sp, "indices");
    if (!cJSON_IsObject(ind))
        return lr__gltf_fail(d, err, "%s must be an object", qi);
    LR_TRY(lr__gltf_get_uint(d, ind, qi, "componentType", 0, 0, &ict, err));
    if (ict != 5121 && ict != 5123 && ict != 5125)
        return lr__gltf_fail(d, err,
                             "%s.componentType must be 5121, 5123 "
                             "or 5125",
                             qi);
    size_t isz = (size_t)component_size(ict);
    const unsigned char *idx, *val;
    LR_TRY(sparse_part(d, sp, p, "indices", n, (long long)isz, &idx, err));
    LR_TRY(sparse_part(d, sp, p, "values", n, elem, &val, err));
    long long last = -1;
    for (long long i = 0; i < n; i++) {
        unsigned long at = lr__gltf_read_uint(idx + (size_t)i * isz, isz);
        if ((long long)at <= last || (long long)at >= count)
            return lr__gltf_fail(d, err,
                                 "%s.indices: element %lld is %lu; "
                                 "they must increase and stay below %lld",
                                 q, i, at, count);
        last = (long long)at;
        memcpy(dense + (size_t)at * (size_t)elem,
               val + (size_t)i * (size_t)elem, (size_t)elem);
    }
    return LR_OK;
}

/* The primitive compressed with KHR_draco_mesh_compression that names
 * accessor i, as "meshes[m].primitives[p]" in out; 0 if there is none. */
static int draco_user(const lr__gltf_doc *d, int i, char *out, size_t n)
{
    int nm, np;
    const cJSON *meshes = lr__gltf_array(d->root, "meshes", &nm);
    int m = 0;
    for (const cJSON *me = meshes ? meshes->child : NULL; me;
         me = me->next, m++) {
        const cJSON *prims = lr__gltf_array(me, "primitives", &np);
        int k = 0;
        for (const cJSON *pr = prims ? prims->child : NULL; pr;
             pr = pr->next, k++) {
            if (!lr__gltf_member(pr, "extensions",
                                 "KHR_draco_mesh_compression"))
                continue;
            const cJSON *at = cJSON_GetObjectItemCaseSensitive(pr,
                                                               "attributes");
            const cJSON *ix = cJSON_GetObjectItemCaseSensitive(pr, "indices");
            int uses = cJSON_IsNumber(ix) && ix->valuedouble == i;
            for (const cJSON *c = cJSON_IsObject(at) ? at->child : NULL; c;
                 c = c->next)
                uses |= cJSON_IsNumber(c) && c->valuedouble == i;
            if (uses) {
                snprintf(out, n, "meshes[%d].primitives[%d]", m, k);
                return 1;
            }
        }
    }
    return 0;
}

/* An accessor without a bufferView is zeros (spec 3.6.2.1), unless an
 * extension that lensray does not read fills it: Draco's decoded
 * vertices would otherwise be drawn as a heap of zeros. */
static lr_status check_viewless(const lr__gltf_doc *d, const cJSON *x, int i,
                                const char *p, lr_error *err)
{
    char who[64];
    if (draco_user(d, i, who, sizeof who))
        return lr__gltf_fail(d, err,
                             "%s has no bufferView: %s is "
                             "compressed with KHR_draco_mesh_compression, "
                             "which lensray does not decode",
                             p, who);
    if (cJSON_GetObjectItemCaseSensitive(x, "byteOffset") != NULL)
        return lr__gltf_fail(d, err,
                             "%s has a byteOffset but no "
                             "bufferView",
                             p);
    return LR_OK;
}

/* Accessor x's elements copied out tightly packed into a new block
 * (*dense): its bufferView's, or zeros without one, with the sparse
 * values written over them.  The copies of a file share dense_budget. */
static lr_status make_dense(lr__gltf_doc *d, const cJSON *x, const char *p,
                            long long v, long long off, long long stride,
                            long long count, long long elem, size_t *used,
                            unsigned char **dense, lr_error *err)
{
    unsigned long long bytes = (unsigned long long)count *
                               (unsigned long long)elem;
    if (bytes > dense_budget(d) - *used)
        return lr__gltf_fail(d, err,
                             "%s: %lld elements of %lld bytes to "
                             "fill in (zeros or sparse) are more than "
                             "lensray allows for this file (%zu bytes)",
                             p, count, elem, dense_budget(d));
    *dense = calloc((size_t)bytes, 1);
    if (*dense == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    *used += (size_t)bytes;
    if (v >= 0) {
        long long len;
        const unsigned char *base = view_bytes(d, v, &len) + off;
        for (long long i = 0; i < count; i++)
            memcpy(*dense + (size_t)(i * elem), base + (size_t)(i * stride),
                   (size_t)elem);
    }
    if (cJSON_GetObjectItemCaseSensitive(x, "sparse") != NULL)
        return apply_sparse(d, x, p, count, elem, *dense, err);
    return LR_OK;
}

/* Every accessor must lie within its bufferView (spec 3.6.2.4): the last
 * element ends at byteOffset + stride (count - 1) + element size.  One
 * without a bufferView, or with sparse values, is copied out (make_dense)
 * and read from the copy from then on. */
lr_status lr__gltf_check_accessors(lr__gltf_doc *d, lr_error *err)
{
    int n, nv;
    const cJSON *a = lr__gltf_array(d->root, "accessors", &n);
    lr__gltf_array(d->root, "bufferViews", &nv);
    d->dense = calloc(n ? (size_t)n : 1, sizeof *d->dense);
    d->acc_at = lr__gltf_table(d->root, "accessors", n);
    d->view_at = lr__gltf_table(d->root, "bufferViews", nv);
    d->n_views = nv;
    if (d->dense == NULL || d->acc_at == NULL || d->view_at == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    d->n_accessors = (size_t)n;
    size_t used = 0;
    int i = 0;
    char p[64];
    for (const cJSON *x = a ? a->child : NULL; x; x = x->next, i++) {
        snprintf(p, sizeof p, "accessors[%d]", i);
        long long v, off, ct, count, stride = 0, vlen = 0;
        LR_TRY(lr__gltf_get_index(d, x, p, "bufferView", nv, &v, err));
        if (v < 0)
            LR_TRY(check_viewless(d, x, i, p, err));
        LR_TRY(lr__gltf_get_uint(d, x, p, "byteOffset", 0, 0, &off, err));
        LR_TRY(lr__gltf_get_uint(d, x, p, "componentType", 0, 0, &ct, err));
        LR_TRY(lr__gltf_get_uint(d, x, p, "count", 0, 0, &count, err));
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(x, "type");
        int csize = component_size(ct);
        int k = cJSON_IsString(t) ? type_count(t->valuestring) : 0;
        if (csize == 0)
            return lr__gltf_fail(d, err,
                                 "%s.componentType %lld is not one "
                                 "of 5120, 5121, 5122, 5123, 5125, 5126",
                                 p, ct);
        if (k == 0)
            return lr__gltf_fail(d, err,
                                 "%s.type must be SCALAR, VEC2, "
                                 "VEC3, VEC4, MAT2, MAT3 or MAT4",
                                 p);
        if (count < 1)
            return lr__gltf_fail(d, err, "%s.count must be >= 1", p);
        if (off % csize != 0)
            return lr__gltf_fail(d, err,
                                 "%s.byteOffset %lld is not a "
                                 "multiple of its component size %d",
                                 p, off, csize);
        long long elem = (long long)k * csize;
        if (v >= 0) {
            const cJSON *view = view_of(d, v);
            LR_TRY(lr__gltf_get_uint(d, view, "bufferView", "byteStride", 0, 0,
                                     &stride, err));
            LR_TRY(lr__gltf_get_uint(d, view, "bufferView", "byteLength", 0, 0,
                                     &vlen, err));
            if (stride == 0)
                stride = elem;
            if (stride < elem)
                return lr__gltf_fail(d, err,
                                     "%s: elements of %lld bytes do "
                                     "not fit bufferViews[%lld].byteStride "
                                     "%lld",
                                     p, elem, v, stride);
            unsigned long long end = (unsigned long long)off +
                                     (unsigned long long)stride *
                                         (unsigned long long)(count - 1) +
                                     (unsigned long long)elem;
            if (end > (unsigned long long)vlen)
                return lr__gltf_fail(d, err,
                                     "%s: %lld elements reach byte "
                                     "%llu of bufferViews[%lld], which has "
                                     "%lld",
                                     p, count, end, v, vlen);
        }
        if (v < 0 || cJSON_GetObjectItemCaseSensitive(x, "sparse") != NULL)
            LR_TRY(make_dense(d, x, p, v, off, stride, count, elem, &used,
                              &d->dense[i], err));
    }
    return LR_OK;
}

/* The accessor's componentType and type must be what `attr` allows. */
lr_status lr__gltf_check_attribute(const lr__gltf_doc *d, const char *p,
                                   const char *attr, long long acc,
                                   long long *count, lr_error *err)
{
    const cJSON *a = accessor_of(d, acc);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(a, "type");
    double ct = cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(a, "componentType"));
    *count = (long long)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(a, "count"));
    const char *want = NULL;
    if (strcmp(attr, "POSITION") == 0 || strcmp(attr, "NORMAL") == 0)
        want = ct == 5126 && strcmp(t->valuestring, "VEC3") == 0
                   ? NULL
                   : "VEC3 of floats (5126)";
    else if (strncmp(attr, "TEXCOORD_", 9) == 0)
        /* Spec 3.7.2.1: floats, or unsigned bytes or shorts normalized
         * (gltf_assimp.c decodes those itself). */
        want = (ct == 5126 || ((ct == 5121 || ct == 5123) &&
                               cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(
                                   a, "normalized")))) &&
                       strcmp(t->valuestring, "VEC2") == 0
                   ? NULL
                   : "VEC2 of floats, or of unsigned bytes or shorts with "
                     "\"normalized\": true";
    else if (strncmp(attr, "JOINTS_", 7) == 0)
        /* Spec 3.7.3.3: joint indices as unsigned bytes or shorts. */
        want = (ct == 5121 || ct == 5123) && strcmp(t->valuestring, "VEC4") == 0
                   ? NULL
                   : "VEC4 of unsigned bytes or shorts";
    else if (strncmp(attr, "WEIGHTS_", 8) == 0)
        want = (ct == 5126 || ((ct == 5121 || ct == 5123) &&
                               cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(
                                   a, "normalized")))) &&
                       strcmp(t->valuestring, "VEC4") == 0
                   ? NULL
                   : "VEC4 of floats, or of unsigned bytes or shorts with "
                     "\"normalized\": true";
    else if (strcmp(attr, "indices") == 0)
        want = (ct == 5121 || ct == 5123 || ct == 5125) &&
                       strcmp(t->valuestring, "SCALAR") == 0
                   ? NULL
                   : "SCALAR of unsigned bytes, shorts or ints";
    /* A file that quantizes without requiring the extension (which the
     * extension forbids, yet exporters do) hears why its integers are
     * refused. */
    int quantized = 0, nu;
    const cJSON *used = lr__gltf_array(d->root, "extensionsUsed", &nu);
    for (const cJSON *e = used ? used->child : NULL; e; e = e->next)
        quantized |= cJSON_IsString(e) &&
                     strcmp(e->valuestring, "KHR_mesh_quantization") == 0;
    if (want != NULL)
        return lr__gltf_fail(d, err, "%s.%s: accessors[%lld] must be a %s%s", p,
                             attr, acc, want,
                             quantized ? " (KHR_mesh_quantization is not "
                                         "read by lensray)"
                                       : "");
    return LR_OK;
}

const unsigned char *lr__gltf_accessor_at(const lr__gltf_doc *d, long long acc,
                                          size_t *stride, long long *count,
                                          size_t *cs)
{
    const cJSON *a = accessor_of(d, acc);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(a, "type");
    *cs = (size_t)component_size((long long)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(a, "componentType")));
    *count = (long long)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(a, "count"));
    size_t elem = *cs * (size_t)type_count(t->valuestring);
    if (d->dense[acc] != NULL) {
        *stride = elem;
        return d->dense[acc];
    }
    long long vi = (long long)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(a, "bufferView"));
    const cJSON *v = view_of(d, vi);
    const cJSON *ao = cJSON_GetObjectItemCaseSensitive(a, "byteOffset");
    const cJSON *vs = cJSON_GetObjectItemCaseSensitive(v, "byteStride");
    long long len;
    *stride = vs ? (size_t)vs->valuedouble : elem;
    return view_bytes(d, vi, &len) + (size_t)(ao ? ao->valuedouble : 0);
}

/* The index accessor's values must name vertices that exist. */
