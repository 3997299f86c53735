/*
 * scene_file.h: a scene's file references, resolved in one place.
 *
 * Every key of the scene format that names a file (an OBJ mesh, the
 * environment map, a lens prescription, and any later one such as a
 * texture or a glTF file) turns its string into a path to open through
 * lr__scene_file, and is listed in lr__scene_file_key, so that
 *   - "sha256:HEX" (a content-addressed asset, docs/api.md "Assets")
 *     works for every key at once, and
 *   - lr_job_mesh_file, which a daemon uses to confine an inline scene's
 *     files, sees every key at once.
 */
#ifndef LR_SCENE_FILE_H
#define LR_SCENE_FILE_H

#include "util/internal.h"

/* Whether a member named `key` of a scene object holds a file reference
 * (a string).  camera.lens is the one key that may also hold a name
 * (a shipped lens); lr_job_mesh_file treats it apart. */
int lr__scene_file_key(const char *key);

/* Whether `ref` is an asset reference: "sha256:" and 64 lowercase hex
 * digits, nothing more. */
int lr__scene_file_is_asset(const char *ref);

/* The path to open for the file reference `ref` read at JSON path
 * `field`: an asset "sha256:HEX" is the file HEX in the assets directory
 * (lr_assets_dir_set, else $LENSRAY_ASSETS_DIR); an absolute path is
 * itself; anything else is relative to base_dir (NULL or "": the
 * current directory).  Writes at most `cap` bytes to `out`.  Errors,
 * naming `field` and never the assets directory: LR_ERR_INVALID (a
 * "sha256:" string that is not 64 lowercase hex digits; no assets
 * directory; no such asset), LR_ERR_LIMIT (path too long). */
lr_status lr__scene_file(const char *ref, const char *base_dir,
                         const char *field, char *out, size_t cap,
                         lr_error *err);

#endif
