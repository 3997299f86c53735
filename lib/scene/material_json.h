/*
 * material_json.h: a material's texture keys in the scene JSON
 * ("diffuse_texture", "emission_texture", "roughness_texture",
 * "roughness_channel"), and the check that textured materials sit on
 * geometry with texture coordinates (material_json.c).
 */
#ifndef LR_MATERIAL_JSON_H
#define LR_MATERIAL_JSON_H

#include "json/json_util.h"
#include "scene/scene.h"

/* The texture keys of material object `m` (JSON path p) into mt, files
 * relative to base_dir (NULL: as written), loaded once each through
 * lr__scene_texture_named.  Call after the factors were read: a
 * textured factor the JSON left out (diffuse, emission, roughness;
 * `given` says which were present, LR__GIVEN_*) becomes 1.  Errors name
 * the key and the file. */
enum { LR__GIVEN_DIFFUSE = 1, LR__GIVEN_EMISSION = 2, LR__GIVEN_ROUGHNESS = 4 };
lr_status lr__material_textures_json(lr_scene *s, lr__material *mt,
                                     const cJSON *m, const char *p,
                                     const char *base_dir, int given,
                                     lr_error *err);

/* Whether a material has any texture; the name of its first one's key. */
const char *lr__material_texture_key(const lr__material *mt);

/* Checks the geometry objects[i] (JSON path p) added: geoms[g0..) and
 * planes[p0..) of s.  A textured material needs texture coordinates: an
 * infinite plane or a "triangle" has none, a mesh has them when its OBJ
 * file gives `vt` on every face corner. */
lr_status lr__material_check_uvs(const lr_scene *s, size_t g0, size_t p0,
                                 const char *p, lr_error *err);

#endif
