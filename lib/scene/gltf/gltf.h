/*
 * gltf.h: glTF 2.0 scenes (.gltf and .glb), read through libassimp
 * (docs/gltf.md): meshes under their nodes' transforms, metallic-roughness
 * materials mapped to lensray's, the glTF camera and KHR_lights_punctual.
 */
#ifndef LR_GLTF_H
#define LR_GLTF_H

#include "scene/scene.h"
#include "scene/scene_load.h"
#include "util/transform.h"

/* What the scene asks of the file's camera ("camera" in a "gltf" object). */
typedef enum lr__gltf_camera_use {
    LR__GLTF_CAMERA_NONE = 0,  /* the scene's own camera stays */
    LR__GLTF_CAMERA_FIRST = 1, /* the file's first camera, or an auto-framed
                                  view of the file's meshes if it has none */
    LR__GLTF_CAMERA_NAMED = 2  /* the camera called `camera_name` */
} lr__gltf_camera_use;

typedef struct lr__gltf_options {
    lr__xform place; /* the object's "transform" */
    lr__gltf_camera_use camera;
    const char *camera_name;
    /* 1 when the scene set render.height: the camera's aspectRatio then
     * does not change the image's height. */
    int height_given;
} lr__gltf_options;

/* Reads the glTF file `file` (JSON or binary, told apart by its first
 * bytes, not its name) and adds its meshes, materials and lights to `s`
 * (between lr__scene_begin and lr__scene_commit), placed by o->place, and
 * sets s->camera from it as o->camera says.  Files the glTF names
 * (buffers, images) must be relative paths below the file's directory,
 * without "..": anything else is an error.  Errors start with `fp` (the
 * JSON path of the field that named the file) and name the file as
 * `shown` and the glTF field at fault ("objects[0].file: a.glb:
 * accessors[2].count: ...").  Features that are read but ignored add a
 * line to the scene's warnings (lr_scene_warnings). */
lr_status lr__scene_add_gltf(lr_scene *s, const char *file, const char *shown,
                             const char *fp, const lr__gltf_options *o,
                             lr_error *err);

/* 1 if the file at `path` starts like a glTF file ("glTF" magic, or a
 * JSON object after optional white space and a byte-order mark) and its
 * name ends in .gltf or .glb; for `lensray render scene.glb`. */
int lr__gltf_is_file(const char *path);

/* Loads a glTF file as a whole scene (what `lensray render x.glb` does):
 * the scene {"render": {"integrator": "path"}, "objects": [{"type":
 * "gltf", "file": x, "camera": true}]}, with a uniform white sky as the
 * background when the file has no lights of its own (punctual or
 * emissive), then the overrides. */
lr_status lr__gltf_scene_load(const char *path, const char *const *overrides,
                              size_t n_overrides, lr__render_reader rd,
                              lr_scene **out, lr_error *err);

#endif
