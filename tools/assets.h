/*
 * assets.h: before a --remote render, the scene's mesh files go to the
 * daemons as content-addressed assets (PUT /v1/assets/{sha256}, only
 * those a HEAD says are missing), and the scene sent names them as
 * "sha256:HEX" (docs/api.md, Assets).
 */
#ifndef LENSRAY_ASSETS_H
#define LENSRAY_ASSETS_H

#include <stddef.h>

typedef struct assets_stats {
    int files;    /* mesh files the scene names */
    int uploaded; /* of them, sent because the daemons lacked them */
} assets_stats;

/* Reads the scene text scene[0 .. len), whose relative mesh paths are
 * relative to `dir`, and for each objects[i].file: hashes the file, asks
 * url whether it has that asset and sends it if not.  *out gets the scene
 * text with each file replaced by "sha256:HEX" (malloc'ed, *out_len
 * bytes; free it with free()), or a copy of the text when the daemons
 * keep no assets (404 no_asset_store: their scenes directory must hold
 * the meshes).  Returns 0, or the CLI's exit status 3 (the scene or a
 * file cannot be read) or 4 (the daemons refused or could not be
 * reached), with the reason printed. */
/* The whole file at `path` (*len bytes), malloc'ed (free with free()),
 * or NULL with errno set. */
unsigned char *read_whole_file(const char *path, size_t *len);

int assets_send(const char *url, const char *token, const char *scene,
                size_t len, const char *dir, char **out, size_t *out_len,
                assets_stats *stats);

#endif
