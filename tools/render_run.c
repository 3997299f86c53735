/*
 * render_run.c: `lensray render` once its arguments are read (lensray.c):
 * each scene loaded with its overrides, rendered here with a progress bar
 * or on daemons with --remote (remote.c), and its image written; --stats
 * lines.  The render_job is read only.
 */
#include "render_job.h"
#include "assets.h"
#include "outname.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

volatile int cancel_flag;

/* The progress bar: redrawn at most ten times a second on a terminal. */
typedef struct progress {
    double start, last;
} progress;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void on_progress(void *user, uint64_t done, uint64_t total)
{
    progress *p = user;
    double t = now();
    if (done < total && t - p->last < 0.1)
        return;
    p->last = t;
    double f = total ? (double)done / (double)total : 1.0;
    int width = 40, filled = (int)(f * width);
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[width] = '\0';
    double elapsed = t - p->start;
    double eta = f > 0 ? elapsed * (1.0 - f) / f : 0.0;
    fprintf(stderr, "\r[%s] %5.1f%%  %.1fs elapsed, %.1fs left ", bar,
            100.0 * f, elapsed, eta);
    if (done >= total)
        fputc('\n', stderr);
    fflush(stderr);
}

/* This process's peak resident set size so far in KiB (VmHWM, which
 * starts afresh at exec, unlike getrusage's maxrss), or -1 if unknown. */
static long peak_rss_kib(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (f == NULL)
        return -1;
    char line[256];
    long kib = -1;
    while (fgets(line, sizeof line, f) != NULL)
        if (sscanf(line, "VmHWM: %ld kB", &kib) == 1)
            break;
    fclose(f);
    return kib;
}

/* The directory part of `path` ("." for a bare name, "/" at the root). */
void dir_of(const char *path, char *dir, size_t size)
{
    snprintf(dir, size, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash == NULL)
        snprintf(dir, size, ".");
    else if (slash == dir)
        dir[1] = '\0';
    else
        *slash = '\0';
}

static int exit_for(lr_status st)
{
    switch (st) {
    case LR_OK:
        return EXIT_OK;
    case LR_ERR_IO:
        return EXIT_IO;
    case LR_ERR_CANCELLED:
        return EXIT_INTERRUPTED;
    default:
        return EXIT_SCENE;
    }
}

/* Writes the image; the exit status. */
static int write_image(const lr_image *img, const char *path,
                       const lr_output_options *oo)
{
    lr_error err;
    /* Ctrl-C while the file is written keeps the file as it was. */
    lr_status st = lr_image_write_cancellable(img, path, oo, &cancel_flag,
                                              &err);
    if (st == LR_OK)
        return EXIT_OK;
    fprintf(stderr, "lensray: %s\n", err.message);
    return exit_for(st) == EXIT_SCENE ? EXIT_IO : exit_for(st);
}

/* The output file of frame i (from 0): the pattern with its number and
 * its "%%" read, also in a name without a number (where "%%" had stayed
 * two characters); a name with a % that is no pattern (one scene's
 * "100%.png") as it is. */
void frame_out(const render_job *r, int i, char *out, size_t size)
{
    if (outname_check(r->out) < 0 ||
        outname_frame(r->out, i + 1, out, size) != 0)
        snprintf(out, size, "%s", r->out);
}

/* The render's wishes that the output cannot hold, and --depth: applied
 * to the settings the scene gave, as both loaders below use them. */
static void fit_output(const render_job *r, lr_render_settings *rs,
                       const char *out_path)
{
    if (r->want_depth)
        rs->want_depth = 1;
    if (rs->want_depth && !lr_format_has_depth(r->fmt)) {
        /* The scene asks for Z but the output cannot hold it: say so
         * rather than drop it silently, and skip the work. */
        fprintf(stderr,
                "lensray: warning: render.depth is set but %s has no "
                "Z channel; write an .exr to keep it\n",
                out_path);
        rs->want_depth = 0;
    }
}

/* The scene at `path` with the --set overrides; its camera and settings
 * as this render uses them.  0, or an exit status, printed. */
static int load_scene(const render_job *r, const char *path, lr_scene **scene,
                      lr_camera *cam, lr_render_settings *rs,
                      const char *out_path)
{
    lr_error err;
    lr_status st = lr_scene_load_file(path, r->sets, r->n_sets, scene, &err);
    if (st != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        return exit_for(st);
    }
    /* What the loader ignored (glTF features), one line each. */
    for (const char *w = lr_scene_warnings(*scene); *w;) {
        const char *nl = strchr(w, '\n');
        int len = nl ? (int)(nl - w) : (int)strlen(w);
        fprintf(stderr, "lensray: warning: %.*s\n", len, w);
        w += len + (nl != NULL);
    }
    lr_scene_camera(*scene, cam);
    lr_scene_settings(*scene, rs);
    fit_output(r, rs, out_path);
    return EXIT_OK;
}

/* One scene rendered here into out_path; the exit status. */
/* Whether every value of img is 0. */
static int all_black(const lr_image *img)
{
    const float *v = lr_image_rgb(img);
    size_t n = 3 * (size_t)lr_image_width(img) * (size_t)lr_image_height(img);
    for (size_t i = 0; i < n; i++)
        if (v[i] != 0.0f)
            return 0;
    return 1;
}

static int render_local(const render_job *r, int frame, const char *out_path)
{
    const char *scene_path = r->scenes[frame];
    lr_scene *scene = NULL;
    lr_camera cam;
    lr_render_settings rs;
    int rc = load_scene(r, scene_path, &scene, &cam, &rs, out_path);
    if (rc != EXIT_OK)
        return rc;
    progress prog = {now(), 0.0};
    if (!r->quiet && isatty(STDERR_FILENO)) {
        rs.progress = on_progress;
        rs.progress_user = &prog;
    }
    rs.cancel = &cancel_flag;
    lr_image *img = NULL;
    lr_render_stats rst;
    memset(&rst, 0, sizeof rst);
    lr_error err;
    lr_status st = lr_render(scene, &cam, &rs, &img, &rst, &err);
    if (st != LR_OK) {
        /* End the progress bar's line first, if there is one. */
        fprintf(stderr, "%slensray: %s\n", rs.progress ? "\n" : "",
                err.message);
        lr_scene_free(scene);
        return exit_for(st);
    }
    rc = write_image(img, out_path, &r->oo);
    if (rc == EXIT_OK && r->stats) {
        /* The library's stats JSON, with this process's peak memory (which
         * only the CLI can know) as the first member. */
        char *json = lr_render_stats_json(&rst, &rs, scene);
        if (json == NULL) {
            fprintf(stderr, "lensray: out of memory\n");
            rc = EXIT_IO;
        } else {
            /* A batch's lines name their frames (from 1): a frame that
             * fails prints none. */
            if (r->n_scenes > 1)
                printf("{\"frame\": %d, ", frame + 1);
            else
                printf("{");
            printf("\"peak_rss_kib\": %ld, %s\n", peak_rss_kib(), json + 1);
        }
        lr_free(json);
    }
    if (rst.nan_samples > 0)
        fprintf(stderr,
                "lensray: warning: %llu samples were NaN or "
                "infinite and were dropped\n",
                (unsigned long long)rst.nan_samples);
    /* A real lens that stops every ray makes a black picture that is
     * right (its image circle misses the film) but rarely meant.  Only
     * when it is black: the plan traces rays only where it samples the
     * lens, which may all lie beyond the circle's edge while the light
     * side lights the picture (it warned on a lit picture). */
    if (rst.camera_rays > 0 && rst.lens_blocked >= rst.camera_rays &&
        all_black(img))
        fprintf(stderr,
                "lensray: warning: the lens stopped every camera ray, so the "
                "picture is black: its image circle misses the film (see "
                "camera.sensor_width_mm and render.region)\n");
    /* The light integrator, or the light side's lights, with paths
     * traced and none landing: a black picture (or black bokeh) that the
     * camera alone would have lit, at this spp; rarely meant (a sensor a
     * millimetre wide, a tiny field of view, a light only a mirror
     * shows). */
    if (rst.light_paths > 0 && rst.light_landed == 0 && all_black(img))
        fprintf(stderr,
                "lensray: warning: none of the %llu light paths reached the "
                "film, so the picture is black; more samples (render.spp), "
                "or the path integrator (render.integrator), may show "
                "it\n",
                (unsigned long long)rst.light_paths);
    lr_image_free(img);
    lr_scene_free(scene);
    return rc;
}

/* A name that lr_scene_load_file reads as glTF, when its bytes are: its
 * extension, in any case, as the library tests it. */
static int is_gltf_name(const char *path)
{
    size_t n = strlen(path);
    return (n >= 5 && strcasecmp(path + n - 5, ".gltf") == 0) ||
           (n >= 4 && strcasecmp(path + n - 4, ".glb") == 0);
}

/* remote_render's callbacks' state: the job, and each frame's directory
 * (the scenes' relative files are found there). */
typedef struct remote_io {
    const render_job *r;
    char (*dirs)[4096];
} remote_io;

/* remote_render's load: scene k read here for its camera and settings, and
 * its text as the daemons take it: a glTF file goes as the scene the
 * library made for it, the file itself as an asset. */
static int load_frame(void *user, int k, remote_frame *f)
{
    const remote_io *io = user;
    const render_job *r = io->r;
    const char *path = r->scenes[k];
    f->scene_path = path;
    char out_path[4096];
    frame_out(r, k, out_path, sizeof out_path);
    char *text = NULL;
    size_t len = 0;
    if (is_gltf_name(path)) {
        /* The daemons take scene JSON: the scene the library makes of the
         * file, which goes as an asset. */
        lr_scene *scene = NULL;
        int rc = load_scene(r, path, &scene, &f->cam, &f->rs, out_path);
        if (rc != EXIT_OK)
            return rc;
        text = lr_gltf_scene_json(path, scene);
        lr_scene_free(scene);
        if (text != NULL)
            len = strlen(text);
    } else {
        /* Only the camera and settings: the meshes are the daemons' to
         * load (reading them here cost each frame their parsing and a BVH
         * built for nothing). */
        lr_error err;
        lr_status st = lr_scene_read_settings(path, r->sets, r->n_sets, &f->cam,
                                              &f->rs, &err);
        if (st != LR_OK) {
            fprintf(stderr, "lensray: %s\n", err.message);
            return exit_for(st);
        }
        fit_output(r, &f->rs, out_path);
    }
    if (text == NULL) {
        text = (char *)read_whole_file(path, &len);
        if (text == NULL) {
            fprintf(stderr, "lensray: %s: %s\n", path, strerror(errno));
            return EXIT_IO;
        }
    }
    dir_of(path, io->dirs[k], sizeof io->dirs[k]);
    f->scene_dir = io->dirs[k];
    f->scene = text;
    f->len = len;
    return EXIT_OK;
}

/* remote_render's done: frame k is stitched; writes it. */
static int write_frame(void *user, int k, lr_image *img)
{
    const remote_io *io = user;
    char out_path[4096];
    frame_out(io->r, k, out_path, sizeof out_path);
    int rc = write_image(img, out_path, &io->r->oo);
    lr_image_free(img);
    return rc;
}

/* --remote: every scene's frame on the daemons, as one batch of parts
 * (tools/remote.c), each scene read when the batch reaches it; a scene
 * that cannot be read fails alone.  The exit status: 0, or the first
 * failure's.  With --stats, one JSON line of what it took. */
int render_remote(const render_job *r)
{
    remote_io io = {r, calloc((size_t)r->n_scenes, sizeof *io.dirs)};
    if (io.dirs == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        return EXIT_IO;
    }
    remote_stats st;
    memset(&st, 0, sizeof st);
    int rc = remote_render(&r->ro, r->n_scenes, load_frame, write_frame, &io,
                           &st);
    /* Ctrl-C is no frame's failure; say which frames are there, as a
     * local batch does. */
    if (r->n_scenes > 1 && rc == EXIT_INTERRUPTED)
        fprintf(stderr, "lensray: interrupted: %d of %d frames written\n",
                st.frames, r->n_scenes);
    else if (r->n_scenes > 1 && rc != EXIT_OK)
        fprintf(stderr, "lensray: %d of %d frames written, %d failed\n",
                st.frames, r->n_scenes, r->n_scenes - st.frames);
    if (r->stats && rc != EXIT_INTERRUPTED)
        printf("{\"remote\": true, \"seconds\": %.3f, \"frames\": %d, "
               "\"failed\": %d, \"parts\": %d, \"requests\": %d, "
               "\"retries\": %d, \"assets\": %d, \"uploaded\": %d}\n",
               st.seconds, st.frames, r->n_scenes - st.frames, st.parts,
               st.attempts, st.retries, st.assets, st.uploaded);
    free(io.dirs);
    return rc;
}

/* Here, one scene after another; one that fails does not stop the
 * others, and the exit status is the first failure's. */
int render_frames_local(const render_job *r)
{
    int rc = EXIT_OK;
    int written = 0;
    for (int i = 0; i < r->n_scenes && !cancel_flag; i++) {
        char out_path[4096];
        frame_out(r, i, out_path, sizeof out_path);
        int frc = render_local(r, i, out_path);
        written += frc == EXIT_OK;
        if (frc != EXIT_OK && rc == EXIT_OK)
            rc = frc;
        if (frc != EXIT_OK && r->n_scenes > 1 && !cancel_flag)
            fprintf(stderr, "lensray: frame %d/%d (%s) failed\n", i + 1,
                    r->n_scenes, r->scenes[i]);
    }
    /* Ctrl-C is no frame's failure; say which frames are there. */
    if (cancel_flag) {
        rc = EXIT_INTERRUPTED;
        if (r->n_scenes > 1)
            fprintf(stderr, "lensray: interrupted: %d of %d frames written\n",
                    written, r->n_scenes);
        else if (written) /* (Ctrl-C as the file was renamed into place) */
            fprintf(stderr, "lensray: interrupted, but the frame was "
                            "written\n");
    } else if (r->n_scenes > 1 && rc != EXIT_OK)
        fprintf(stderr, "lensray: %d of %d frames written, %d failed\n",
                written, r->n_scenes, r->n_scenes - written);
    return rc;
}
