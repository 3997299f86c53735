/*
 * scene_texture.c: the scene's textures: each file loaded once per
 * (path, srgb) and kept until the scene is freed (scene.h).
 */
#include "scene/scene.h"

#include <stdlib.h>
#include <string.h>

/* Appends t (and where it came from) to the scene's lists. */
static lr_status keep(lr_scene *s, lr__texture *t, const char *path, int srgb)
{
    size_t k = s->n_textures;
    lr__texture **tx = realloc(s->textures, (k + 1) * sizeof *tx);
    if (tx != NULL)
        s->textures = tx;
    char **px = tx ? realloc(s->texture_paths, (k + 1) * sizeof *px) : NULL;
    if (px != NULL)
        s->texture_paths = px;
    int *sx = px ? realloc(s->texture_srgb, (k + 1) * sizeof *sx) : NULL;
    if (sx != NULL)
        s->texture_srgb = sx;
    char *copy = path != NULL ? strdup(path) : NULL;
    if (sx == NULL || (path != NULL && copy == NULL)) {
        free(copy);
        lr__texture_free(t);
        return LR_ERR_NOMEM;
    }
    s->textures[k] = t;
    s->texture_paths[k] = copy;
    s->texture_srgb[k] = srgb;
    s->n_textures = k + 1;
    s->limit_texels += (uint64_t)t->w * (uint64_t)t->h;
    return LR_OK;
}

lr__texture *lr__scene_texture_named(lr_scene *s, const char *path,
                                     const char *shown, int srgb, lr_error *err)
{
    srgb = srgb != 0;
    for (size_t i = 0; i < s->n_textures; i++)
        if (s->texture_paths[i] != NULL && s->texture_srgb[i] == srgb &&
            strcmp(s->texture_paths[i], path) == 0)
            return s->textures[i];
    lr__texel_room_begin(s);
    lr__texture *t = lr__texture_load_named(path, shown, srgb, err);
    lr__texel_room_end();
    if (t == NULL)
        return NULL;
    if (keep(s, t, path, srgb) != LR_OK) {
        lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        return NULL;
    }
    return t;
}

lr__texture *lr__scene_texture(lr_scene *s, const char *path, int srgb,
                               lr_error *err)
{
    return lr__scene_texture_named(s, path, path, srgb, err);
}

lr_status lr__scene_texture_add(lr_scene *s, lr__texture *t)
{
    return keep(s, t, NULL, 0);
}
