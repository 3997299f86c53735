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
#include "scene/gltf/gltf_doc.h"
#include "json/json_util.h"

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

const cJSON **lr__gltf_table(const cJSON *o, const char *key, int n)
{
    int na;
    const cJSON *a = lr__gltf_array(o, key, &na);
    const cJSON **t = malloc((n > 0 ? (size_t)n : 1) * sizeof *t);
    int i = 0;
    for (const cJSON *x = a ? a->child : NULL; t != NULL && x && i < n;
         x = x->next)
        t[i++] = x;
    return t;
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
    free(d->node_at);
    free(d->mesh_at);
    free(d->acc_at);
    free(d->view_at);
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

/* Default morph weights, o.weights (a mesh's or a node's): one finite
 * number per morph target when present (spec 3.7.2.2). */
lr_status lr__gltf_check_weights(const lr__gltf_doc *d, const cJSON *o,
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
        LR_TRY(lr__gltf_check_weights(d, m, p, targets, err));
    }
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
    if (st != LR_OK) {
        /* Starting with the field, as a mesh file's error does (it began
         * "nothere.gltf: cannot open"). */
        lr__fail_under(err, fp);
        return st;
    }
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
        st = lr__gltf_check_nodes(d, err);
    if (st == LR_OK)
        st = check_images(d, dir, err);
    if (st != LR_OK)
        lr__gltf_doc_free(d);
    return st;
}
