/*
 * scene_load.h: the scene loaders of the scene layer (scene_load.c), and
 * the scene format's parts that scene_load.c reads through files of their
 * own: the objects and their transforms (scene_objects.c).
 */
#ifndef LR_SCENE_LOAD_H
#define LR_SCENE_LOAD_H

#include "scene/scene.h"
#include "util/transform.h"

#include <cjson/cJSON.h>

/* scene_objects.c: reads a JSON list of steps ([{"translate": [x, y, z]},
 * {"rotate": {"axis": [x, y, z], "degrees": d}}, {"scale": s or
 * [x, y, z]}]) at `path`; the first step listed acts first. */
lr_status lr__xform_parse(const cJSON *list, const char *path, lr__xform *out,
                          lr_error *err);

/* The "objects" array (NULL: none) into s, after its materials; files
 * found from base_dir; height_given: render.height was set (a glTF
 * camera then keeps it).  Errors name objects[i]. */
lr_status lr__scene_parse_objects(lr_scene *s, const cJSON *objs,
                                  const char *base_dir, int height_given,
                                  lr_error *err);

/* The reader of a scene's "render" object into *rs (NULL object: *rs
 * as it is): the render layer's lr__settings_from_json, handed down by
 * the public loaders (load.c), so that the scene layer reads the settings
 * without knowing the integrators and samplers they name. */
typedef lr_status (*lr__render_reader)(const cJSON *r, lr_render_settings *rs,
                                       lr_error *err);

/* lr_scene_load_json, lr_scene_load_file and lr_scene_read_settings
 * (lensray.h), the first two up to the committed scene
 * (lr__scene_commit), not yet prepared for the integrators: the public
 * ones (load.c) add lr__integrators_prepare.  Enough to read a scene's
 * camera, settings and objects. */
lr_status lr__scene_load_json(const char *json, size_t len,
                              const char *base_dir,
                              const char *const *overrides, size_t n_overrides,
                              lr__render_reader rd, lr_scene **out,
                              lr_error *err);
lr_status lr__scene_load_file(const char *path, const char *const *overrides,
                              size_t n_overrides, lr__render_reader rd,
                              lr_scene **out, lr_error *err);
lr_status lr__scene_read_settings(const char *path,
                                  const char *const *overrides,
                                  size_t n_overrides, lr__render_reader rd,
                                  lr_camera *cam, lr_render_settings *rs,
                                  lr_error *err);

#endif
