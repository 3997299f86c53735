/*
 * remote.h: `lensray render --remote URL`: one frame rendered as region
 * parts on lensrayd daemons (one daemon, or many behind a balancer such
 * as the farm's nginx) and stitched into the image a local render gives,
 * bit for bit (docs/deploy.md says which settings that needs).
 */
#ifndef LENSRAY_REMOTE_H
#define LENSRAY_REMOTE_H

#include "lensray.h"

#include <stddef.h>

typedef struct remote_options {
    const char *url;       /* the daemon or balancer, "http://host:port" */
    const char *token;     /* bearer token, or NULL */
    int parts;             /* parts to cut the frame into (bands of rows) */
    int parallel;          /* parts in flight at once */
    int retries;           /* further attempts of a failed part */
    int quiet;             /* no progress lines */
    const volatile int *cancel; /* stops the render when non-zero */
    const char *scene_dir; /* the scene file's directory: its meshes */
} remote_options;

/* What remote_render did, for --stats. */
typedef struct remote_stats {
    double seconds;
    int parts;
    int attempts;          /* requests sent, retries included */
    int retries;
    int assets;            /* mesh files the scene names */
    int uploaded;          /* of them, sent because the daemons lacked them */
} remote_stats;

/* Renders the scene whose file text is scene[0 .. len) through `cam` with
 * `rs` (both as the local render would use them; rs->want_depth asks for
 * Z) as parts on o->url, and stitches them into *out, a new image that
 * the caller frees with lr_image_free.  First the scene's mesh files go
 * to the daemons as assets, those they lack (tools/assets.c).  Every
 * part is a POST /v1/render
 * of the scene inline with the camera and settings as JSON and
 * render.region set to the part, answered as a float32 EXR.  A part that
 * fails for a reason that can pass (no connection, 5xx, 429, a broken
 * image) is sent again, up to o->retries times; one the daemon refuses
 * (4xx) stops the render.  Returns the CLI's exit status: 0, 3 (the
 * daemon refused the scene: its message is printed), 4 (I/O: the
 * daemons could not be reached or kept failing), 130 (cancelled). */
int remote_render(const remote_options *o, const char *scene, size_t len,
                  const lr_camera *cam, const lr_render_settings *rs,
                  lr_image **out, remote_stats *stats);

#endif
