/*
 * scene_load.h: the scene format's parts that scene_load.c reads through
 * files of their own: the objects (scene_objects.c).
 */
#ifndef LR_SCENE_LOAD_H
#define LR_SCENE_LOAD_H

#include "scene.h"

/* The "objects" array (NULL: none) into s, after its materials; files
 * found from base_dir; height_given: render.height was set (a glTF
 * camera then keeps it).  Errors name objects[i]. */
lr_status lr__scene_parse_objects(lr_scene *s, const cJSON *objs,
                                  const char *base_dir, int height_given,
                                  lr_error *err);

#endif
