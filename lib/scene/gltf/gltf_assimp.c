/*
 * gltf_assimp.c: the meshes of a checked glTF document (gltf_check.c)
 * decoded by libassimp.  assimp is given only what it must decode, the
 * geometry: a glTF that this file prints from the checked tree with
 * nothing but asset, scenes, nodes (renamed "n<index>", so that its nodes
 * map back to the document's), meshes, accessors, bufferViews, buffers
 * (renamed "lr-buffer-<index>.bin") and materials reduced to names
 * ("m<index>").  It reads files only through the aiFileIO below, which
 * serves that text and the checked buffers from memory and nothing else:
 * assimp never opens a file of its own, never sees a GLB container,
 * base64, an image, a camera, a light, an animation or a skin.
 *
 * Texture coordinates stored as normalized unsigned bytes or shorts
 * (glTF 2.0, 3.7.2.1) are decoded here into floats, c / 255 or
 * c / 65535, and given to assimp as float accessors in one more buffer:
 * assimp 5.2 copies such an accessor's raw bytes into its floats, which
 * textured a quad with a few texels of garbage.  Sparse and zero-filled
 * accessors (3.6.2.3) reach assimp the same way, as plain accessors over
 * the copies gltf_check.c made of them.  Meshes that are morphed or
 * skinned reach it posed (gltf_pose.c), through the same extra buffer
 * (gltf_extra.h).
 */
#include "scene/gltf/gltf_doc.h"
#include "scene/gltf/gltf_extra.h"
#include "json/json_util.h"

#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAIN_NAME "lensray.gltf"

/* ---- the document assimp reads ------------------------------------------ */

/* Copies the members `keys` of o into a new object (NULL on no memory). */
static cJSON *pick(const cJSON *o, const char *const *keys)
{
    cJSON *out = cJSON_CreateObject();
    for (int k = 0; out != NULL && keys[k]; k++) {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, keys[k]);
        if (v == NULL)
            continue;
        cJSON *c = cJSON_Duplicate(v, 1);
        if (c == NULL || !cJSON_AddItemToObject(out, keys[k], c)) {
            cJSON_Delete(c);
            cJSON_Delete(out);
            return NULL;
        }
    }
    return out;
}

/* Each element of root[key] reduced to `keys`, renamed by `rename`
 * ("n%d") when given; 0 on no memory. */
static int copy_array(cJSON *dst, const cJSON *root, const char *key,
                      const char *const *keys, const char *rename)
{
    int n;
    const cJSON *a = lr__gltf_array(root, key, &n);
    if (a == NULL)
        return 1;
    cJSON *out = cJSON_AddArrayToObject(dst, key);
    if (out == NULL)
        return 0;
    int i = 0;
    for (const cJSON *e = a->child; e; e = e->next, i++) {
        cJSON *c = pick(e, keys);
        if (c == NULL || !cJSON_AddItemToArray(out, c)) {
            cJSON_Delete(c);
            return 0;
        }
        char name[32];
        if (rename != NULL) {
            snprintf(name, sizeof name, rename, i);
            if (cJSON_AddStringToObject(c, "name", name) == NULL)
                return 0;
        }
    }
    return 1;
}

/* Room for `n` more bytes after padding to 4 (a float's alignment, which
 * glTF asks of every accessor); the offset where they go in *at, or 0 on
 * no memory. */
int lr__gltf_extra_grow(lr__gltf_extra *u, size_t n, size_t *at)
{
    size_t start = (u->n + 3) & ~(size_t)3;
    if (start + n > u->cap) {
        size_t cap = 2 * (start + n);
        unsigned char *p = realloc(u->data, cap);
        if (p == NULL)
            return 0;
        u->data = p, u->cap = cap;
    }
    memset(u->data + u->n, 0, start - u->n);
    *at = start;
    u->n = start + n;
    return 1;
}

/* A new bufferView of the extra buffer over bytes [at, at + n) in the
 * reduced copy r, and an accessor of it (`count` elements of `type`, of
 * componentType ct, normalized or not) replacing accessors[k], or
 * appended when k < 0.  Its index, or -1 on no memory. */
int lr__gltf_extra_accessor(cJSON *r, const lr__gltf_extra *u, int k, size_t at,
                            size_t n, double ct, double count, const char *type,
                            int normalized)
{
    cJSON *views = cJSON_GetObjectItemCaseSensitive(r, "bufferViews");
    if (views == NULL)
        views = cJSON_AddArrayToObject(r, "bufferViews");
    cJSON *accs = cJSON_GetObjectItemCaseSensitive(r, "accessors");
    cJSON *view = cJSON_CreateObject();
    if (views == NULL || accs == NULL || view == NULL ||
        !cJSON_AddItemToArray(views, view)) {
        cJSON_Delete(view);
        return -1;
    }
    cJSON *fa = cJSON_CreateObject();
    int ok = fa != NULL &&
             cJSON_AddNumberToObject(view, "buffer", (double)u->index) &&
             cJSON_AddNumberToObject(view, "byteOffset", (double)at) &&
             cJSON_AddNumberToObject(view, "byteLength", (double)n) &&
             cJSON_AddNumberToObject(fa, "bufferView",
                                     cJSON_GetArraySize(views) - 1) &&
             cJSON_AddNumberToObject(fa, "componentType", ct) &&
             cJSON_AddNumberToObject(fa, "count", count) &&
             cJSON_AddStringToObject(fa, "type", type) &&
             (!normalized || cJSON_AddTrueToObject(fa, "normalized"));
    if (ok && k < 0) {
        ok = cJSON_AddItemToArray(accs, fa);
        k = cJSON_GetArraySize(accs) - 1;
    } else if (ok) {
        ok = cJSON_ReplaceItemInArray(accs, k, fa);
    }
    if (!ok)
        cJSON_Delete(fa);
    return ok ? k : -1;
}

/* The floats of integer TEXCOORD accessor k of the document
 * (componentType 5121 or 5123, VEC2, checked by gltf_check.c) appended
 * to u; where they start in *at.  0 on no memory. */
static int decode_uv(const lr__gltf_doc *d, int k, lr__gltf_extra *u,
                     size_t *at)
{
    size_t stride, cs;
    long long count;
    const unsigned char *base = lr__gltf_accessor_at(d, k, &stride, &count,
                                                     &cs);
    if (!lr__gltf_extra_grow(u, (size_t)count * 2 * sizeof(float), at))
        return 0;
    float *f = (float *)(u->data + *at);
    for (size_t i = 0; i < (size_t)count; i++)
        for (size_t c = 0; c < 2; c++) {
            const unsigned char *q = base + i * stride + c * cs;
            f[2 * i + c] = cs == 1 ? q[0] / 255.0f
                                   : (float)(q[0] | q[1] << 8) / 65535.0f;
        }
    return 1;
}

/* Every integer TEXCOORD accessor of the reduced copy r made a float one
 * over the extra buffer (its floats decoded into u). */
static int float_uvs(const lr__gltf_doc *d, cJSON *r, lr__gltf_extra *u)
{
    cJSON *accs = cJSON_GetObjectItemCaseSensitive(r, "accessors");
    const cJSON *meshes = item(r, "meshes");
    for (const cJSON *m = meshes ? meshes->child : NULL; m; m = m->next)
        for (const cJSON *p = item(m, "primitives")->child; p; p = p->next)
            for (const cJSON *at = item(p, "attributes")->child; at;
                 at = at->next) {
                if (strncmp(at->string, "TEXCOORD_", 9) != 0)
                    continue;
                int k = (int)at->valuedouble;
                cJSON *a = cJSON_GetArrayItem(accs, k);
                double ct = cJSON_GetNumberValue(item(a, "componentType"));
                if (ct != 5121 && ct != 5123)
                    continue; /* floats, or made floats already */
                size_t first;
                double count = cJSON_GetNumberValue(item(a, "count"));
                if (!decode_uv(d, k, u, &first) ||
                    lr__gltf_extra_accessor(r, u, k, first, 8 * (size_t)count,
                                            5126, count, "VEC2", 0) < 0)
                    return 0;
            }
    return 1;
}

/* Every accessor that gltf_check.c copied out (zero-filled or sparse)
 * given to assimp as a plain accessor over its copy in the extra buffer:
 * assimp then reads neither kind itself, and what it reads is the
 * checked copy. */
static int dense_accessors(const lr__gltf_doc *d, cJSON *r, lr__gltf_extra *u)
{
    const cJSON *accs = item(r, "accessors");
    for (size_t k = 0; k < d->n_accessors; k++) {
        if (d->dense[k] == NULL)
            continue;
        size_t stride, cs, at;
        long long count;
        const unsigned char *src = lr__gltf_accessor_at(d, (long long)k,
                                                        &stride, &count, &cs);
        size_t n = stride * (size_t)count;
        if (!lr__gltf_extra_grow(u, n, &at))
            return 0;
        memcpy(u->data + at, src, n);
        const cJSON *a = cJSON_GetArrayItem(accs, (int)k);
        char type[8];
        snprintf(type, sizeof type, "%s", item(a, "type")->valuestring);
        if (lr__gltf_extra_accessor(
                r, u, (int)k, at, n,
                cJSON_GetNumberValue(item(a, "componentType")), (double)count,
                type, cJSON_IsTrue(item(a, "normalized"))) < 0)
            return 0;
    }
    return 1;
}

/* The extra buffer in r's buffers, when anything went into it. */
static int extra_declare(cJSON *r, const lr__gltf_extra *u)
{
    if (u->n == 0)
        return 1;
    char name[40];
    snprintf(name, sizeof name, "lr-buffer-%zu.bin", u->index);
    cJSON *bufs = cJSON_GetObjectItemCaseSensitive(r, "buffers");
    if (bufs == NULL)
        bufs = cJSON_AddArrayToObject(r, "buffers");
    cJSON *buf = cJSON_CreateObject();
    if (bufs == NULL || buf == NULL || !cJSON_AddItemToArray(bufs, buf)) {
        cJSON_Delete(buf);
        return 0;
    }
    return cJSON_AddNumberToObject(buf, "byteLength", (double)u->n) &&
           cJSON_AddStringToObject(buf, "uri", name);
}

static char *assimp_text(const lr__gltf_doc *d, const lr__xform *world,
                         lr__gltf_extra *u)
{
    static const char *const k_scene[] = {"nodes", NULL};
    static const char *const k_node[] = {
        "children", "mesh", "matrix", "translation", "rotation", "scale", NULL};
    static const char *const k_mesh[] = {"primitives", NULL};
    static const char *const k_acc[] = {
        "bufferView", "byteOffset", "componentType", "normalized", "count",
        "type",       NULL};
    static const char *const k_view[] = {"buffer", "byteOffset", "byteLength",
                                         "byteStride", NULL};
    static const char *const k_buf[] = {"byteLength", NULL};
    static const char *const k_none[] = {NULL};
    static const char *const k_prim[] = {"attributes", "indices", "material",
                                         "mode", NULL};
    cJSON *r = cJSON_CreateObject();
    int ok = r != NULL;
    cJSON *asset = ok ? cJSON_AddObjectToObject(r, "asset") : NULL;
    ok = ok && asset && cJSON_AddStringToObject(asset, "version", "2.0");
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(d->root, "scene");
    ok = ok &&
         (sc == NULL || cJSON_AddNumberToObject(r, "scene", sc->valuedouble));
    ok = ok && copy_array(r, d->root, "scenes", k_scene, NULL) &&
         copy_array(r, d->root, "nodes", k_node, "n%d") &&
         copy_array(r, d->root, "meshes", k_mesh, NULL) &&
         copy_array(r, d->root, "accessors", k_acc, NULL) &&
         copy_array(r, d->root, "bufferViews", k_view, NULL) &&
         copy_array(r, d->root, "buffers", k_buf, "lr-buffer-%d.bin") &&
         copy_array(r, d->root, "materials", k_none, "m%d");
    /* Primitives keep only their geometry, and those without POSITION
     * are left out (spec 3.7.2.1: not drawn); buffers are named by uri. */
    const cJSON *meshes = cJSON_GetObjectItemCaseSensitive(r, "meshes");
    for (cJSON *m = ok && meshes ? meshes->child : NULL; m && ok; m = m->next) {
        cJSON *prims = cJSON_GetObjectItemCaseSensitive(m, "primitives");
        for (cJSON *p = prims->child, *next; p && ok; p = next) {
            next = p->next;
            if (!drawn(p)) {
                cJSON_Delete(cJSON_DetachItemViaPointer(prims, p));
                continue;
            }
            cJSON *c = pick(p, k_prim);
            ok = c != NULL && cJSON_ReplaceItemViaPointer(prims, p, c);
        }
    }
    const cJSON *bufs = cJSON_GetObjectItemCaseSensitive(r, "buffers");
    for (cJSON *b = ok && bufs ? bufs->child : NULL; b && ok; b = b->next) {
        cJSON *name = cJSON_DetachItemFromObject(b, "name");
        ok = name && cJSON_AddItemToObject(b, "uri", name);
    }
    ok = ok && dense_accessors(d, r, u) && float_uvs(d, r, u) &&
         lr__gltf_pose_meshes(d, world, r, u) && extra_declare(r, u);
    /* A node whose mesh has nothing left to draw places none. */
    const cJSON *rnodes = cJSON_GetObjectItemCaseSensitive(r, "nodes");
    for (cJSON *n = ok && rnodes ? rnodes->child : NULL; n; n = n->next) {
        const cJSON *mi = cJSON_GetObjectItemCaseSensitive(n, "mesh");
        const cJSON *m = mi ? cJSON_GetArrayItem(meshes, (int)mi->valuedouble)
                            : NULL;
        int np;
        if (mi != NULL && (lr__gltf_array(m, "primitives", &np), np == 0))
            cJSON_DeleteItemFromObjectCaseSensitive(n, "mesh");
    }
    char *text = ok ? cJSON_PrintUnformatted(r) : NULL;
    cJSON_Delete(r);
    return text;
}

/* ---- files from memory ---------------------------------------------------- */

typedef struct mem_file {
    struct aiFile f;
    const unsigned char *data;
    size_t n, at;
} mem_file;

typedef struct mem_fs {
    const lr__gltf_doc *d;
    const char *text;
    const lr__gltf_extra *uv;
} mem_fs;

static size_t mf_read(struct aiFile *f, char *buf, size_t size, size_t count)
{
    mem_file *m = (mem_file *)f;
    if (size == 0)
        return 0;
    size_t items = (m->n - m->at) / size;
    if (items > count)
        items = count;
    memcpy(buf, m->data + m->at, items * size);
    m->at += items * size;
    return items;
}

static size_t mf_write(struct aiFile *f, const char *b, size_t s, size_t c)
{
    (void)f, (void)b, (void)s, (void)c;
    return 0;
}

static size_t mf_tell(struct aiFile *f)
{
    return ((mem_file *)f)->at;
}
static size_t mf_size(struct aiFile *f)
{
    return ((mem_file *)f)->n;
}
static void mf_flush(struct aiFile *f)
{
    (void)f;
}

static enum aiReturn mf_seek(struct aiFile *f, size_t off, enum aiOrigin o)
{
    mem_file *m = (mem_file *)f;
    size_t to = o == aiOrigin_SET   ? off
                : o == aiOrigin_CUR ? m->at + off
                                    : m->n + off;
    if (to > m->n || (o == aiOrigin_CUR && to < m->at))
        return aiReturn_FAILURE;
    m->at = to;
    return aiReturn_SUCCESS;
}

static struct aiFile *fs_open(struct aiFileIO *io, const char *name,
                              const char *mode)
{
    const mem_fs *fs = (const mem_fs *)io->UserData;
    if (mode == NULL || mode[0] != 'r')
        return NULL;
    const char *base = strrchr(name, '/');
    base = base ? base + 1 : name;
    const unsigned char *data = NULL;
    size_t n = 0;
    char *end = NULL;
    unsigned long b = strncmp(base, "lr-buffer-", 10) == 0
                          ? strtoul(base + 10, &end, 10)
                          : 0;
    if (strcmp(base, MAIN_NAME) == 0) {
        data = (const unsigned char *)fs->text;
        n = strlen(fs->text);
    } else if (end != NULL && end > base + 10 && strcmp(end, ".bin") == 0 &&
               b < fs->d->n_buffers) {
        data = fs->d->buffers[b].data;
        n = fs->d->buffers[b].n;
    } else if (end != NULL && end > base + 10 && strcmp(end, ".bin") == 0 &&
               b == fs->uv->index && fs->uv->n > 0) {
        data = fs->uv->data;
        n = fs->uv->n;
    } else {
        return NULL;
    }
    mem_file *m = calloc(1, sizeof *m);
    if (m == NULL)
        return NULL;
    m->f.ReadProc = mf_read;
    m->f.WriteProc = mf_write;
    m->f.TellProc = mf_tell;
    m->f.FileSizeProc = mf_size;
    m->f.SeekProc = mf_seek;
    m->f.FlushProc = mf_flush;
    m->data = data;
    m->n = n;
    return &m->f;
}

static void fs_close(struct aiFileIO *io, struct aiFile *f)
{
    (void)io;
    free(f);
}

/* assimp keeps its last error in one global string. */
static pthread_mutex_t import_lock = PTHREAD_MUTEX_INITIALIZER;

lr_status lr__gltf_import(const lr__gltf_doc *d, const lr__xform *world,
                          const struct aiScene **out, lr_error *err)
{
    *out = NULL;
    lr__gltf_extra uv = {NULL, 0, 0, d->n_buffers};
    char *text = assimp_text(d, world, &uv);
    if (text == NULL) {
        free(uv.data);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    mem_fs fs = {d, text, &uv};
    struct aiFileIO io = {fs_open, fs_close, (aiUserData)&fs};
    pthread_mutex_lock(&import_lock);
    /* Triangulate: polygons' fans; SortByPType: points and lines apart
     * (gltf.c skips them); nothing that moves or merges vertices, so that
     * the triangles are the file's. */
    const struct aiScene *sc = aiImportFileEx(
        MAIN_NAME, aiProcess_Triangulate | aiProcess_SortByPType, &io);
    char why[300] = "";
    if (sc == NULL)
        snprintf(why, sizeof why, "%s", aiGetErrorString());
    pthread_mutex_unlock(&import_lock);
    free(text);
    free(uv.data);
    if (sc == NULL)
        return lr__gltf_fail(d, err, "libassimp could not read it: %s", why);
    *out = sc;
    return LR_OK;
}

void lr__gltf_release(const struct aiScene *sc)
{
    if (sc != NULL)
        aiReleaseImport(sc);
}
