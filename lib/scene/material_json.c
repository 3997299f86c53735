/*
 * material_json.c: textures named by a material in the scene JSON
 * (material_json.h).  Colour textures (diffuse, emission) are sRGB-coded
 * where the format is 8- or 16-bit; roughness is data, kept linear.
 */
#include "scene/material_json.h"
#include "util/scene_file.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One texture key: loads its file (if present) into *tex, keeps the name
 * as written in *file. */
static lr_status one(lr_scene *s, const cJSON *m, const char *p,
                     const char *key, int srgb, const char *base_dir,
                     lr__texture **tex, char **file, int *present,
                     lr_error *err)
{
    const char *name = NULL;
    LR_TRY(lr__json_string(m, key, p, 0, &name, err));
    *present = name != NULL;
    if (name == NULL)
        return LR_OK;
    char q[LR__PATH_MAX];
    lr__path_key(q, p, key);
    if (name[0] == '\0')
        return lr__fail(err, LR_ERR_INVALID, q,
                        "%s must name an image file (PNG, JPEG or OpenEXR)", q);
    /* Through the one resolver of file keys, so "sha256:" assets work. */
    char full[4096];
    LR_TRY(lr__scene_file(name, base_dir, q, full, sizeof full, err));
    *file = strdup(name);
    if (*file == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    lr_error e;
    *tex = lr__scene_texture_named(s, full, name, srgb, &e);
    if (*tex == NULL)
        return lr__fail(err, e.status, q, "%s: %s", q, e.message);
    return LR_OK;
}

lr_status lr__material_textures_json(lr_scene *s, lr__material *mt,
                                     const cJSON *m, const char *p,
                                     const char *base_dir, int given,
                                     lr_error *err)
{
    int has_d = 0, has_e = 0, has_r = 0;
    LR_TRY(one(s, m, p, "diffuse_texture", 1, base_dir, &mt->diffuse_tex,
               &mt->diffuse_file, &has_d, err));
    LR_TRY(one(s, m, p, "emission_texture", 1, base_dir, &mt->emission_tex,
               &mt->emission_file, &has_e, err));
    LR_TRY(one(s, m, p, "roughness_texture", 0, base_dir, &mt->roughness_tex,
               &mt->roughness_file, &has_r, err));
    long long ch = 0;
    LR_TRY(lr__json_int(m, "roughness_channel", p, 0, 0, 3, &ch, err));
    mt->roughness_channel = (int)ch;
    /* A texture alone means the texture's values: factor 1, as in glTF. */
    if (has_d && !(given & LR__GIVEN_DIFFUSE))
        mt->diffuse = v3(1, 1, 1);
    if (has_e && !(given & LR__GIVEN_EMISSION))
        mt->emission = v3(1, 1, 1);
    if (has_r && !(given & LR__GIVEN_ROUGHNESS))
        mt->roughness = 1.0;
    return LR_OK;
}

const char *lr__material_texture_key(const lr__material *mt)
{
    return mt->diffuse_tex     ? "diffuse_texture"
           : mt->emission_tex  ? "emission_texture"
           : mt->roughness_tex ? "roughness_texture"
                               : NULL;
}

static lr_status no_uvs(const lr_scene *s, int material, const char *p,
                        const char *why, lr_error *err)
{
    const lr__material *mt = &s->materials[material];
    return lr__fail(err, LR_ERR_INVALID, p,
                    "%s: material \"%s\" sets %s, but %s has no texture "
                    "coordinates%s",
                    p, mt->name, lr__material_texture_key(mt), p, why);
}

lr_status lr__material_check_uvs(const lr_scene *s, size_t g0, size_t p0,
                                 const char *p, lr_error *err)
{
    for (size_t i = g0; i < s->n_geoms; i++) {
        const lr__geom *g = &s->geoms[i];
        if (g->kind == LR__GEOM_TRIANGLES && g->corner_uv == NULL &&
            lr__material_texture_key(&s->materials[g->material]) != NULL)
            return no_uvs(s, g->material, p,
                          " (a mesh needs `vt` on every face corner of its "
                          "OBJ file; a \"triangle\" has none)",
                          err);
    }
    for (size_t i = p0; i < s->n_planes; i++)
        if (lr__material_texture_key(&s->materials[s->planes[i].material]))
            return no_uvs(s, s->planes[i].material, p,
                          " (an infinite plane has none; give it a \"size\")",
                          err);
    return LR_OK;
}
