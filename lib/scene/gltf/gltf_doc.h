/*
 * gltf_doc.h: a glTF file read and checked before libassimp sees it
 * (gltf_check.c), shared by the glTF loader's files (gltf.c: meshes and
 * materials through assimp; gltf_nodes.c: node transforms, the camera and
 * the lights).  Private to them.
 */
#ifndef LR_GLTF_DOC_H
#define LR_GLTF_DOC_H

#include "scene/gltf/gltf.h"
#include "util/internal.h"

#include <cjson/cJSON.h>

/* One file the glTF names (a buffer or an image), read whole. */
typedef struct lr__gltf_blob {
    char *uri;           /* as the glTF wrote it; owned */
    unsigned char *data; /* owned */
    size_t n;
} lr__gltf_blob;

typedef struct lr__gltf_doc {
    const char *fp;       /* JSON path of the field naming the file */
    const char *shown;    /* the file's name in messages */
    int glb;              /* binary container */
    unsigned char *bytes; /* the whole file; owned */
    size_t n_bytes;
    const unsigned char *bin; /* GLB BIN chunk inside bytes, or NULL */
    size_t n_bin;
    cJSON *root;          /* the JSON document; owned */
    lr__gltf_blob *blobs; /* external files, owned */
    size_t n_blobs;
    /* Each buffer's bytes (in `bytes`, bin or a blob) and its
     * byteLength, checked to be no more than the data. */
    struct lr__gltf_buffer {
        const unsigned char *data;
        size_t n;
    } * buffers; /* owned */
    size_t n_buffers;
    /* Accessors copied out, tightly packed: those without a bufferView
     * (zeros) or with sparse values written over their view's (spec
     * 3.6.2.3); NULL for the rest, read in place.  Read them all
     * through lr__gltf_accessor_at. */
    unsigned char **dense; /* n_accessors pointers, each owned */
    size_t n_accessors;
    int n_nodes;
    /* nodes[i] and meshes[i] of root, n_nodes and n_meshes of them
     * (lr__gltf_check_nodes; a cJSON array is a list, and looking an
     * item up by index walks it: a file of 100,000 nodes took 13 s). */
    const cJSON **node_at, **mesh_at; /* owned */
    int n_meshes;
    /* accessors[i] and bufferViews[i] likewise (lr__gltf_check_accessors;
     * NULL before it). */
    const cJSON **acc_at, **view_at; /* owned */
    int n_views;
    /* Textures decoded so far, one per (image, srgb); the scene owns
     * the textures, this only finds them again. */
    struct lr__gltf_tex {
        int image, srgb;
        struct lr__texture *t;
    } * tex; /* owned */
    size_t n_tex;
} lr__gltf_doc;

/* Reads `file` and its external files and checks everything libassimp
 * would otherwise trust: the GLB container, the JSON's shape, every index
 * between arrays, every accessor within its bufferView within its buffer,
 * the node graph (a tree: no cycles, no node twice), paths of external
 * files.  On error the doc is freed. */
lr_status lr__gltf_doc_load(const char *file, const char *shown, const char *fp,
                            lr__gltf_doc *d, lr_error *err);
void lr__gltf_doc_free(lr__gltf_doc *d);

/* An input error about the file: "FP: SHOWN: what". */
__attribute__((format(printf, 3, 4))) lr_status
lr__gltf_fail(const lr__gltf_doc *d, lr_error *err, const char *fmt, ...);

/* Where accessor acc's elements lie (checked by lr__gltf_doc_load): the
 * first one, the stride between them, their count and their component
 * size; a dense copy (see lr__gltf_doc.dense) or in its bufferView. */
const unsigned char *lr__gltf_accessor_at(const lr__gltf_doc *d, long long acc,
                                          size_t *stride, long long *count,
                                          size_t *cs);

/* The bytes of external file `uri` (read by lr__gltf_doc_load), or NULL. */
const lr__gltf_blob *lr__gltf_blob_find(const lr__gltf_doc *d, const char *uri);

/* o[k1][k2] when both are objects, else NULL. */
const cJSON *lr__gltf_member(const cJSON *o, const char *k1, const char *k2);

/* A member that must be an array (or absent: NULL, n = 0). */
const cJSON *lr__gltf_array(const cJSON *o, const char *key, int *n);

/* The n items of o[key] (lr__gltf_array's, n its count) by index, in a
 * new array of at least one slot; NULL when out of memory.  A cJSON
 * array is a list, and a look-up by index walks it. */
const cJSON **lr__gltf_table(const cJSON *o, const char *key, int n);

/* ---- gltf_assimp.c ---- */

struct aiScene;
/* The document's meshes decoded by libassimp (gltf_assimp.c says what it
 * is given; `world`: the nodes' transforms, lr__gltf_world); its aiNodes
 * are named "n<node index>", its materials "m<material index>" (a
 * primitive without one gets assimp's default, which has no such name).
 * Release with lr__gltf_release. */
lr_status lr__gltf_import(const lr__gltf_doc *d, const lr__xform *world,
                          const struct aiScene **out, lr_error *err);

/* gltf_pose.c: 1 when nodes[i] has a mesh and a skin: assimp is then handed
 * its mesh already skinned into the glTF's world (the joints' world
 * transforms times their inverse bind matrices, spec 3.7.3.3), and it is
 * placed without the node's own transform, which a skinned mesh
 * ignores. */
int lr__gltf_skinned(const lr__gltf_doc *d, int i);
void lr__gltf_release(const struct aiScene *sc);

/* ---- gltf_nodes.c ---- */

/* Every node's world transform (node to the glTF's world, before the
 * object's placement), from its matrix or its translation, rotation and
 * scale (spec 3.5.2: M = T R S; a matrix is column-major), and which
 * nodes the displayed scene ("scene", else scenes[0], else none) holds
 * (nodes outside it get their transforms as well, for skins' joints).
 * Both arrays have d->n_nodes elements; the caller frees them. */
lr_status lr__gltf_world(const lr__gltf_doc *d, lr__xform **world,
                         unsigned char **active, lr_error *err);

/* KHR_lights_punctual's lights of the active nodes, into s->lights. */
lr_status lr__gltf_lights(lr_scene *s, const lr__gltf_doc *d,
                          const lr__xform *world, const unsigned char *active,
                          const lr__xform *place, lr_error *err);

/* The camera the options ask for, into s->camera (and the image height
 * from its aspect ratio); [lo, hi] is the box of the placed meshes, for
 * the auto-framed view when the file has no camera. */
lr_status lr__gltf_camera(lr_scene *s, const lr__gltf_doc *d,
                          const lr__xform *world, const unsigned char *active,
                          const lr__gltf_options *o, lr__v3 lo, lr__v3 hi,
                          lr_error *err);

/* Adds a line to the scene's warnings (scene.c keeps them). */
void lr__gltf_warn(lr_scene *s, const lr__gltf_doc *d, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* The largest glTF (or GLB) and the largest file it may name. */
#define LR__GLTF_MAX_BYTES (512u << 20)
/* The deepest node below its scene root (gltf_check_nodes.c). */
#define LR__GLTF_MAX_DEPTH 1000

/* gltf_file.c: reads the file `uri` (relative to the glTF's directory
 * `dir`; `path` names the field for errors) into a new blob of d's, or
 * finds the one read before. */
lr_status lr__gltf_read_blob(lr__gltf_doc *d, const char *dir, const char *path,
                             const char *uri, lr__gltf_blob **out,
                             lr_error *err);
/* gltf_file.c: the GLB header and chunks (spec 4.4) of d's bytes: the
 * JSON chunk's text in *json, *n bytes. */
lr_status lr__gltf_read_glb(lr__gltf_doc *d, const char **json, size_t *n,
                            lr_error *err);
/* A little-endian 32-bit number. */
uint32_t lr__gltf_le32(const unsigned char *p);

/* gltf_check.c: an optional non-negative integer member `key` of o below
 * `lim` (0: no limit), *out = dflt when absent; an optional index into an
 * array of n, -1 when absent.  Errors name path.key. */
lr_status lr__gltf_get_uint(const lr__gltf_doc *d, const cJSON *o,
                            const char *path, const char *key, double lim,
                            long long dflt, long long *out, lr_error *err);
lr_status lr__gltf_get_index(const lr__gltf_doc *d, const cJSON *o,
                             const char *path, const char *key, int n,
                             long long *out, lr_error *err);

/* gltf_check.c: default morph weights, o.weights (a mesh's or a node's):
 * one finite number per morph target when present (spec 3.7.2.2). */
lr_status lr__gltf_check_weights(const lr__gltf_doc *d, const cJSON *o,
                                 const char *p, int targets, lr_error *err);
/* gltf_check_nodes.c: the skins, then the nodes (after the meshes). */
lr_status lr__gltf_check_nodes(lr__gltf_doc *d, lr_error *err);

/* gltf_accessor.c: the buffers (their files read from `dir`), the
 * bufferViews and the accessors checked, in that order. */
lr_status lr__gltf_check_buffers(lr__gltf_doc *d, const char *dir,
                                 lr_error *err);
lr_status lr__gltf_check_views(lr__gltf_doc *d, lr_error *err);
lr_status lr__gltf_check_accessors(lr__gltf_doc *d, lr_error *err);
/* gltf_accessor.c: accessor `acc` of attribute `attr` (at path p) has a
 * componentType and type that `attr` allows; its count in *count. */
lr_status lr__gltf_check_attribute(const lr__gltf_doc *d, const char *p,
                                   const char *attr, long long acc,
                                   long long *count, lr_error *err);
/* An unsigned integer of cs bytes (1, 2 or 4), little-endian. */
unsigned long lr__gltf_read_uint(const unsigned char *q, size_t cs);

#endif
