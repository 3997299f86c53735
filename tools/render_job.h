/*
 * render_job.h: `lensray render` between its two files: lensray.c reads
 * and checks the arguments into a render_job, render_run.c renders it
 * (here, or on daemons with --remote) and writes the images.
 */
#ifndef LENSRAY_RENDER_JOB_H
#define LENSRAY_RENDER_JOB_H

#include "lensray.h"
#include "remote.h"

#include <stddef.h>

/* The exit statuses of the tool (lensray.c's usage text lists them). */
enum {
    EXIT_OK = 0,
    EXIT_USAGE = 2,
    EXIT_SCENE = 3,
    EXIT_IO = 4,
    EXIT_INTERRUPTED = 130
};


/* What `lensray render` was asked, once its arguments are read. */
typedef struct render_job {
    const char **scenes; /* the scene files, in order */
    int n_scenes;
    const char *out; /* the output, or a pattern with a frame number */
    int numbered;    /* out holds a frame number (outname.h) */
    const char **sets;
    size_t n_sets;
    int stats, quiet, want_depth;
    lr_output_options oo;
    const char *compression; /* --compression NAME, or NULL */
    lr_format fmt;
    remote_options ro;
} render_job;

/* Raised by SIGINT and SIGTERM (lensray.c); lr_render and --remote poll
 * it. */
extern volatile int cancel_flag;

/* The directory part of `path` ("." for a bare name, "/" at the root). */
void dir_of(const char *path, char *dir, size_t size);

/* The output file of frame i (from 0). */
void frame_out(const render_job *r, int i, char *out, size_t size);

/* Here, one scene after another; one that fails does not stop the
 * others, and the exit status is the first failure's. */
int render_frames_local(const render_job *r);

/* --remote: every scene's frame on the daemons, as one batch of parts;
 * the exit status: 0, or the first failure's. */
int render_remote(const render_job *r);

#endif
