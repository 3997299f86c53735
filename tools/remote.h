/*
 * remote.h: `lensray render --remote URL`: frames rendered as region
 * parts on lensrayd daemons (one daemon, or many behind a balancer such
 * as the farm's nginx) and stitched into the images a local render gives,
 * bit for bit (docs/deploy.md says which settings that needs).  A batch
 * of frames is one queue of parts, so every daemon stays busy across the
 * frames' boundaries.
 */
#ifndef LENSRAY_REMOTE_H
#define LENSRAY_REMOTE_H

#include "lensray.h"

#include <stddef.h>

/* Whether a daemon's HTTP answer is a failure that can pass (its state,
 * not the request's fault): 5xx, 408, and a full queue's 429. */
static inline int remote_status_passes(long status)
{
    return status >= 500 || status == 408 || status == 429;
}

/* The wait before sending again after the nth failure (1, 2, ...):
 * 0.25 s, 0.5 s, ... up to 4 s. */
static inline double remote_backoff(int nth)
{
    return 0.25 * (double)(1 << (nth < 5 ? nth - 1 : 4));
}

typedef struct remote_options {
    const char *url;   /* the daemon or balancer, "http://host:port" */
    const char *token; /* bearer token, or NULL */
    int parts;         /* parts to cut each frame into (bands of rows) */
    int parallel;      /* parts in flight at once */
    int retries;       /* further attempts of a failed part */
    int quiet;         /* no progress lines */
    int timeout;       /* seconds a part may go without a byte from the
                          daemon before it counts as failed (--timeout) */
    const volatile int *cancel; /* stops the render when non-zero */
} remote_options;

/* One frame of a batch: the scene file's path, directory and text, and
 * the camera and settings as the local render would use them
 * (rs.want_depth asks for Z).  remote_render owns `scene` (malloc'ed) and
 * frees it; the paths are the caller's and must outlive the call. */
typedef struct remote_frame {
    const char *scene_path;
    const char *scene_dir; /* the directory its relative files are in */
    const char *scene;
    size_t len;
    lr_camera cam;
    lr_render_settings rs;
} remote_frame;

/* Fills *out (zeroed) with frame k, read when the batch reaches it;
 * returns 0, or an exit status (the reason printed) that fails that frame
 * alone.  scene_path should be set even on failure: the failure names it. */
typedef int (*remote_load)(void *user, int frame, remote_frame *out);

/* What remote_render did, for --stats. */
typedef struct remote_stats {
    double seconds;
    int frames;   /* frames finished and handed to `done` */
    int failed;   /* frames that failed */
    int parts;    /* parts of all frames */
    int attempts; /* requests sent, retries included */
    int retries;
    int assets;   /* distinct files the scenes name */
    int uploaded; /* of them, sent because the daemons lacked them */
} remote_stats;

/* Called once per frame that completes, in the order they complete, with
 * the stitched image (the callee owns it and frees it with
 * lr_image_free); returns 0, or an exit status that makes the frame
 * count as failed. */
typedef int (*remote_done)(void *user, int frame, lr_image *img);

/* Renders frames 0 .. n - 1 as parts on o->url.  Each frame is read
 * through `load` when the queue of parts to send runs shorter than
 * o->parallel (so a batch starts after one frame's reading, and reading
 * overlaps the daemons' work); then its scene's files go to the daemons
 * as assets, those they lack (tools/assets.c).  Every part
 * is a POST /v1/render of the scene inline with the camera and settings
 * as JSON and render.region set to the part, answered as a float32 EXR;
 * parts are sent in frame order, o->parallel at a time.  A part that
 * fails for a reason that can pass (no connection, 5xx, 429, a broken
 * image) is sent again, up to o->retries times; one the daemon refuses
 * (4xx), or one that keeps failing, fails its frame: the frame is
 * reported, its other parts are dropped, and the other frames go on.
 * Returns the CLI's exit status: 0 when every frame was handed to
 * `done`; otherwise that of the first frame that failed: 3 (the daemon
 * refused the scene: its message is printed), 4 (I/O: the daemons could
 * not be reached or kept failing); 130 when cancelled. */
int remote_render(const remote_options *o, int n, remote_load load,
                  remote_done done, void *user, remote_stats *stats);

#endif
