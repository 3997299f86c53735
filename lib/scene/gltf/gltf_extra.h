/*
 * gltf_extra.h: the reduced glTF that gltf_assimp.c gives assimp, as its
 * posing (gltf_pose.c) adds to it: the extra buffer of bytes beyond the
 * document's buffers, and accessors over it.  Only those two files
 * include it.
 */
#ifndef LR_GLTF_EXTRA_H
#define LR_GLTF_EXTRA_H

#include "scene/gltf/gltf_doc.h"

/* The bytes assimp gets beyond the document's buffers, in one more
 * buffer (`index`, one past the document's): floats for integer texture
 * coordinates and the dense copies of accessors (gltf_check.c). */
typedef struct lr__gltf_extra {
    unsigned char *data;
    size_t n, cap;
    size_t index;
} lr__gltf_extra;

/* Member k of o; NULL when o is NULL or has none. */
static inline const cJSON *item(const cJSON *o, const char *k)
{
    return cJSON_GetObjectItemCaseSensitive(o, k);
}

/* A primitive is drawn when it has POSITION (spec 3.7.2.1). */
static inline int drawn(const cJSON *prim)
{
    return item(item(prim, "attributes"), "POSITION") != NULL;
}

/* Room for `n` more bytes after padding to 4 (a float's alignment, which
 * glTF asks of every accessor); the offset where they go in *at, or 0 on
 * no memory. */
int lr__gltf_extra_grow(lr__gltf_extra *u, size_t n, size_t *at);

/* A new bufferView of the extra buffer over bytes [at, at + n) in the
 * reduced copy r, and an accessor of it replacing accessors[k], or
 * appended when k < 0.  Its index, or -1 on no memory. */
int lr__gltf_extra_accessor(cJSON *r, const lr__gltf_extra *u, int k, size_t at,
                            size_t n, double ct, double count, const char *type,
                            int normalized);

/* gltf_pose.c: each node whose mesh is morphed or skinned gets, in the
 * reduced copy r, a mesh of its own posed into the extra buffer.  0 on no
 * memory. */
int lr__gltf_pose_meshes(const lr__gltf_doc *d, const lr__xform *world,
                         cJSON *r, lr__gltf_extra *u);

#endif
