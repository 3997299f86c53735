/*
 * mesh.h: triangle geometry the scene loader builds from more than the
 * JSON gives: an OBJ file's mesh placed in the scene, and a finite
 * plane's rectangle.
 */
#ifndef LR_MESH_H
#define LR_MESH_H

#include "scene/scene.h"
#include "util/transform.h"

/* Reads the OBJ file `file` and adds its triangles to `s`, placed by `x`
 * (a mirroring x keeps the front side outside).  Normals: the file's are
 * used unless smooth is 0 (flat shading); when the file has none, smooth
 * 1 computes area-weighted vertex normals; smooth -1 means not given.
 * `fp` is the JSON path of the field that named the file: errors start
 * with it and name it.  Messages name the file as `shown` (as the scene
 * wrote it, relative to its directory: the daemon's scenes directory
 * must not show in its answers). */
lr_status lr__scene_add_obj(lr_scene *s, const char *file, const char *shown,
                            const char *fp, int smooth, const lr__xform *x,
                            int material, lr_error *err);

/* Adds a w x h rectangle centred on `pt` in the plane of unit normal `n`,
 * placed by `x`, as two triangles.  Its first side runs along the world
 * x axis projected onto the plane (the z axis when |n.x| > 0.9).  `blame`
 * is the field named when a corner lands beyond the scene's limit. */
lr_status lr__scene_add_rect(lr_scene *s, lr__v3 pt, lr__v3 n, double w,
                             double h, const lr__xform *x, int material,
                             const char *blame, lr_error *err);

#endif
