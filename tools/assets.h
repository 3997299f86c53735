/*
 * assets.h: before a --remote render, the files a scene names (meshes,
 * the environment map, a lens file, textures: every key the library
 * reads a file from, lr_scene_file_key, and camera.lens when it is a
 * file) go to the daemons as content-addressed assets (PUT
 * /v1/assets/{sha256}, only those a HEAD says are missing), and the
 * scene sent names them as "sha256:HEX" (docs/api.md, Assets).
 */
#ifndef LENSRAY_ASSETS_H
#define LENSRAY_ASSETS_H

#include <stddef.h>

/* The whole file at `path` (*len bytes), malloc'ed (free with free()),
 * or NULL with errno set. */
unsigned char *read_whole_file(const char *path, size_t *len);

/* What one batch sends: the files it has hashed, whether the daemons keep
 * assets at all.  A file named by several frames is read, hashed and
 * asked about once. */
typedef struct assets_session assets_session;

/* A session for the daemons at url (bearer token or NULL), each request
 * tried again up to `retries` times where its failure can pass (as
 * --retries does for parts); NULL when out of memory.  Free with
 * assets_close (NULL is a no-op). */
assets_session *assets_open(const char *url, const char *token, int retries);
void assets_close(assets_session *s);

/* Distinct files the session's scenes named, and how many of them were
 * sent because the daemons lacked them. */
void assets_counts(const assets_session *s, int *files, int *uploaded);

/* The file of the session's asset "sha256:HEX" (hex: its 64 digits), or
 * NULL: for a daemon's message, which names assets by their hashes. */
const char *assets_file_of(const assets_session *s, const char *hex);

/* text with every "sha256:HEX" of the session's assets followed by
 * " (FILE)", into out (of cap bytes, cut there). */
void assets_name_files(const assets_session *s, const char *text, char *out,
                       size_t cap);

/* Reads the scene text scene[0 .. len), whose relative paths are relative
 * to `dir`, and the camera JSON `cam_json` (lr_camera_json), and for each
 * file either names: hashes it, asks the daemons whether they have that
 * asset and sends it if not.  *scene_out and *cam_out get the texts with
 * each file replaced by "sha256:HEX" (malloc'ed, NUL-terminated; free
 * them with free()), or copies when the daemons keep no assets (404
 * no_asset_store: their scenes directory must hold the files).  `what`
 * starts each message (the scene's path).  Returns 0, or the CLI's exit
 * status 3 (the scene or a file cannot be read) or 4 (the daemons
 * refused or could not be reached), with the reason printed. */
int assets_prepare(assets_session *s, const char *scene, size_t len,
                   const char *cam_json, const char *dir, const char *what,
                   char **scene_out, size_t *scene_out_len, char **cam_out);

#endif
