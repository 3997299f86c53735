/*
 * scene_limits.c: what one scene may hold (lr_scene_limits_set in
 * lensray.h): triangles, counted as each mesh is placed (every reference
 * of an OBJ file, every glTF node that draws a mesh), and texels of
 * textures and the environment map, checked from an image's declared
 * size before it is decoded (scene.h).
 */
#include "scene/scene.h"

#include <stdatomic.h>
#include <stdint.h>

static _Atomic uint64_t limit_triangles, limit_texels;

/* The texture being decoded on this thread may have at most `room`
 * texels (lr__texel_room_*); UINT64_MAX: no scene limit. */
static _Thread_local uint64_t texel_room = UINT64_MAX, texel_limit;

void lr_scene_limits_set(uint64_t max_triangles, uint64_t max_texels)
{
    atomic_store(&limit_triangles, max_triangles);
    atomic_store(&limit_texels, max_texels);
}

lr_status lr__scene_limit_triangles(const lr_scene *s, uint64_t n,
                                    const char *field, lr_error *err)
{
    uint64_t max = atomic_load(&limit_triangles);
    if (max == 0 ||
        (s->limit_triangles <= max && n <= max - s->limit_triangles))
        return LR_OK;
    if (field == NULL || field[0] == '\0')
        return lr__fail(err, LR_ERR_LIMIT, NULL,
                        "the scene would hold more than %llu triangles, the "
                        "limit set by lr_scene_limits_set",
                        (unsigned long long)max);
    return lr__fail(err, LR_ERR_LIMIT, field,
                    "%s: the scene would hold more than %llu triangles, the "
                    "limit set by lr_scene_limits_set",
                    field, (unsigned long long)max);
}

void lr__texel_room_begin(const lr_scene *s)
{
    uint64_t max = atomic_load(&limit_texels);
    texel_limit = max;
    texel_room = max == 0                 ? UINT64_MAX
                 : s->limit_texels >= max ? 0
                                          : max - s->limit_texels;
}

void lr__texel_room_end(void)
{
    texel_room = UINT64_MAX;
}

uint64_t lr__texel_room(void)
{
    return texel_room;
}

lr_status lr__texel_room_check(uint64_t n, const char *name, lr_error *err)
{
    if (n <= texel_room)
        return LR_OK;
    return lr__fail(err, LR_ERR_LIMIT, NULL,
                    "%s: the scene would hold more than %llu texels, the "
                    "limit set by lr_scene_limits_set",
                    name, (unsigned long long)texel_limit);
}
