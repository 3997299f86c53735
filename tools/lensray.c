/*
 * lensray: the command-line tool.  A thin client of lensray.h:
 *
 *   lensray render SCENE.json|SCENE.glb|SCENE.gltf... -o OUT.exr|OUT.png|OUT-%04d.exr
 *                  [--set PATH=VALUE]...
 *                  [--stats] [--half] [--compression NAME] [--png16]
 *                  [--depth] [--quiet]
 *                  [--remote URL [--parts N] [--parallel K] [--retries R]
 *                   [--token-file F]]
 *   lensray version
 *   lensray --help
 *
 * Exit codes: 0 ok, 2 usage, 3 bad scene, 4 I/O, 130 interrupted.
 */
#include "lensray.h"
#include "assets.h"
#include "outname.h"
#include "remote.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

enum {
    EXIT_OK = 0,
    EXIT_USAGE = 2,
    EXIT_SCENE = 3,
    EXIT_IO = 4,
    EXIT_INTERRUPTED = 130
};

static const char usage_text[] =
    "usage: lensray render SCENE.json|SCENE.glb... -o OUT.exr|OUT.png "
    "[options]\n"
    "       lensray lens FILE|NAME [--field-angles A,B,...] [--wavelength NM]\n"
    "                   [--ghosts [--coating prescription|none|mgf2]]\n"
    "       lensray version\n"
    "       lensray --help\n"
    "\n"
    "render options:\n"
    "  -o, --output FILE   image to write; the format follows the extension\n"
    "                      (.exr: linear float, .png: 8-bit sRGB); with\n"
    "                      several scenes (frames), a name with a frame\n"
    "                      number, %d or %04d: the scene's place, from 1\n"
    "  --set PATH=VALUE    override a scene value by its JSON path, e.g.\n"
    "                      --set camera.fov=30 --set render.spp=64\n"
    "                      --set 'objects[1].radius=0.5' (VALUE is JSON,\n"
    "                      or a plain string); may be repeated\n"
    "  --stats             print a JSON line with time, rays, samples/s,\n"
    "                      the plan and the peak memory (peak_rss_kib)\n"
    "  --half              EXR: write RGB as half floats\n"
    "  --compression NAME  EXR: zip (default), none, zips, rle or piz\n"
    "  --png16             PNG: 16 bits per channel\n"
    "  --depth             also render the Z channel (written to EXR)\n"
    "  -q, --quiet         no progress bar\n"
    "\n"
    "rendering on daemons (docs/deploy.md):\n"
    "  --remote URL        render on lensrayd at URL (one daemon, or many\n"
    "                      behind a balancer) as region parts, stitched into\n"
    "                      the same pixels as a local render; the files the\n"
    "                      scene names are sent to daemons that lack them;\n"
    "                      several scenes are one queue of parts\n"
    "  --parts N           parts to cut the frame into (default 16)\n"
    "  --parallel K        parts sent at a time (default 4)\n"
    "  --retries R         further attempts of a failed part (default 4)\n"
    "  --token-file F      the daemons' bearer token, first line of F\n"
    "\n"
    "lens: prints a lens's first-order data and real chief rays as one JSON\n"
    "object (docs/lenses.md); FILE is a .json, .zmx or pbrt .dat lens, NAME\n"
    "a shipped lens (lenses/)\n"
    "  --field-angles A,B  field angles in degrees, object at infinity\n"
    "  --wavelength NM     primary wavelength (default 587.5618, the d line)\n"
    "  --ghosts            each ghost path's flux for a point on the axis\n"
    "  --coating NAME      with --ghosts: every surface bare (none) or MgF2\n"
    "\n"
    "an option's value may also follow it after '=': --output=out.png\n"
    "\n"
    "exit status: 0 ok, 2 usage, 3 bad scene or lens, 4 I/O error,\n"
    "130 interrupted\n";

static volatile int cancel_flag;

static void on_signal(int sig)
{
    (void)sig;
    cancel_flag = 1;
}

static int usage_error(const char *fmt, const char *arg)
{
    fprintf(stderr, "lensray: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\nTry 'lensray --help'.\n");
    return EXIT_USAGE;
}

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

/* A whole number in [lo, hi] from the whole of `s`: 0, or -1. */
static int parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

/* The first line of `path`, trailing whitespace dropped, as lensrayd
 * reads its --token-file.  0, or -1 with the reason printed. */
static int read_token(const char *path, char *out, size_t size)
{
    FILE *f = fopen(path, "r");
    if (f == NULL || fgets(out, (int)size, f) == NULL) {
        fprintf(stderr, "lensray: --token-file %s: %s\n", path,
                f == NULL ? strerror(errno) : "the file is empty");
        if (f != NULL)
            fclose(f);
        return -1;
    }
    fclose(f);
    size_t n = strlen(out);
    while (n > 0 && (out[n - 1] == '\n' || out[n - 1] == '\r' ||
                     out[n - 1] == ' ' || out[n - 1] == '\t'))
        out[--n] = '\0';
    return 0;
}

/* The directory part of `path` ("." for a bare name, "/" at the root). */
static void dir_of(const char *path, char *dir, size_t size)
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
    lr_status st = lr_image_write(img, path, oo, &err);
    if (st == LR_OK)
        return EXIT_OK;
    fprintf(stderr, "lensray: %s\n", err.message);
    return exit_for(st) == EXIT_SCENE ? EXIT_IO : exit_for(st);
}

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

/* The output file of frame i (from 0). */
static void frame_out(const render_job *r, int i, char *out, size_t size)
{
    if (!r->numbered || outname_frame(r->out, i + 1, out, size) != 0)
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
static int render_local(const render_job *r, const char *scene_path,
                        const char *out_path)
{
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
            printf("{\"peak_rss_kib\": %ld, %s\n", peak_rss_kib(), json + 1);
        }
        lr_free(json);
    }
    if (rst.nan_samples > 0)
        fprintf(stderr,
                "lensray: warning: %llu samples were NaN or "
                "infinite and were dropped\n",
                (unsigned long long)rst.nan_samples);
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
static int render_remote(const render_job *r)
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

/* render's arguments into *r; the token file and the last remote-only
 * flag into *token_file and *remote_flag.  EXIT_OK or a usage error. */
static int render_parse_args(render_job *r, int argc, char **argv,
                             const char **token_file, const char **remote_flag)
{
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-o") == 0 || strcmp(a, "--output") == 0) {
            if (i + 1 >= argc) {
                return usage_error("%s needs a file name", a);
            }
            /* The first would be dropped unwritten. */
            if (r->out != NULL) {
                char both[8192];
                snprintf(both, sizeof both, "('%s', then '%s')", r->out,
                         argv[i + 1]);
                return usage_error("-o given twice %s; a render writes one "
                                   "file, or one a frame with %%d",
                                   both);
            }
            r->out = argv[++i];
        } else if (strcmp(a, "--set") == 0) {
            if (i + 1 >= argc) {
                return usage_error("%s needs PATH=VALUE", a);
            }
            r->sets[r->n_sets++] = argv[++i];
        } else if (strcmp(a, "--stats") == 0) {
            r->stats = 1;
        } else if (strcmp(a, "--half") == 0) {
            r->oo.exr_half = 1;
        } else if (strcmp(a, "--compression") == 0) {
            if (i + 1 >= argc) {
                return usage_error("%s needs a name", a);
            }
            r->compression = argv[++i];
        } else if (strcmp(a, "--png16") == 0) {
            r->oo.png_16bit = 1;
        } else if (strcmp(a, "--depth") == 0) {
            r->want_depth = 1;
        } else if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            r->quiet = 1;
        } else if (strcmp(a, "--remote") == 0 ||
                   strcmp(a, "--token-file") == 0) {
            if (i + 1 >= argc) {
                return usage_error("%s needs a value", a);
            }
            if (a[2] == 'r')
                r->ro.url = argv[++i];
            else
                *token_file = argv[++i];
        } else if (strcmp(a, "--parts") == 0 || strcmp(a, "--parallel") == 0 ||
                   strcmp(a, "--retries") == 0) {
            int *dst = strcmp(a, "--parts") == 0      ? &r->ro.parts
                       : strcmp(a, "--parallel") == 0 ? &r->ro.parallel
                                                      : &r->ro.retries;
            int lo = dst == &r->ro.retries ? 0 : 1;
            if (i + 1 >= argc || parse_int(argv[i + 1], lo, 100000, dst) != 0) {
                char what[64];
                snprintf(what, sizeof what,
                         "%s needs a whole number from %d "
                         "to 100000",
                         a, lo);
                return usage_error("%s", what);
            }
            i++;
            *remote_flag = a;
        } else if (a[0] == '-' && a[1] != '\0') {
            return usage_error("unknown option '%s'", a);
        } else {
            r->scenes[r->n_scenes++] = a;
        }
    }
    return EXIT_OK;
}

/* The arguments checked together (a scene, an output, numbered outputs
 * for several scenes, --set's shape, --remote's URL and flags); the
 * token read into token[cap].  EXIT_OK, a usage error or EXIT_IO. */
static int render_check_args(render_job *r, const char *token_file,
                             const char *remote_flag, char *token, size_t cap)
{
    if (r->n_scenes == 0) {
        return usage_error("%s", "render needs a scene file");
    }
    if (r->out == NULL) {
        return usage_error("%s", "render needs an output file: -o OUT.exr or "
                                 "-o OUT.png");
    }
    r->numbered = outname_check(r->out) == 1;
    if (r->n_scenes > 1 && !r->numbered) {
        return usage_error("-o '%s': several scenes need an output name with "
                           "one frame number, such as -o out-%%04d.exr",
                           r->out);
    }
    for (size_t i = 0; i < r->n_sets; i++) {
        if (strchr(r->sets[i], '=') == NULL) {
            return usage_error("--set '%s' must look like PATH=VALUE",
                               r->sets[i]);
        }
        /* The daemons get the scene file as it is, with the camera and
         * settings as this process reads them: other overrides would not
         * reach them. */
        if (r->ro.url != NULL && strncmp(r->sets[i], "camera.", 7) != 0 &&
            strncmp(r->sets[i], "render.", 7) != 0) {
            return usage_error("--set '%s': with --remote only camera.* and "
                               "render.* can be overridden",
                               r->sets[i]);
        }
    }
    if (r->ro.url == NULL && (token_file != NULL || remote_flag != NULL)) {
        return usage_error("%s is for --remote",
                           token_file != NULL ? "--token-file" : remote_flag);
    }
    /* A URL libcurl could not reach is tried --retries more times with
     * back-off; one that is not even a web address is said at once. */
    if (r->ro.url != NULL && strncasecmp(r->ro.url, "http://", 7) != 0 &&
        strncasecmp(r->ro.url, "https://", 8) != 0) {
        return usage_error("--remote '%s' must be an http:// or https:// URL",
                           r->ro.url);
    }
    if (token_file != NULL) {
        if (read_token(token_file, token, cap) != 0) {
            return EXIT_IO;
        }
        r->ro.token = token;
    }

    return EXIT_OK;
}

/* The output names and options checked before rendering, so that a long
 * render is never thrown away for want of a valid file name. */
static int render_check_outputs(render_job *r)
{
    lr_error err;
    if (lr_format_from_path(r->out, &r->fmt, &err) != LR_OK) {
        return usage_error("%s", err.message);
    }
    /* The format's options by the library's rules (lr_output), so that
     * --half with a .png, say, is refused rather than ignored. */
    if (r->oo.exr_half || r->oo.png_16bit || r->compression != NULL) {
        lr_output out;
        lr_output_default(&out);
        cJSON *spec = cJSON_CreateObject();
        char *text = NULL;
        if (spec != NULL) {
            cJSON_AddStringToObject(spec, "format", lr_format_name(r->fmt));
            if (r->oo.exr_half)
                cJSON_AddTrueToObject(spec, "half");
            if (r->oo.png_16bit)
                cJSON_AddNumberToObject(spec, "bit_depth", 16);
            if (r->compression != NULL)
                cJSON_AddStringToObject(spec, "compression", r->compression);
            text = cJSON_PrintUnformatted(spec);
            cJSON_Delete(spec);
        }
        if (text == NULL) {
            fprintf(stderr, "lensray: out of memory\n");
            return 1;
        }
        lr_status ost = lr_output_apply_json(&out, text, strlen(text), &err);
        cJSON_free(text);
        if (ost != LR_OK) {
            char msg[sizeof err.message + 32];
            snprintf(msg, sizeof msg, "%s: %s",
                     strcmp(err.path, "output.half") == 0 ? "--half"
                     : strcmp(err.path, "output.compression") == 0
                         ? "--compression"
                         : "--png16",
                     err.message);
            return usage_error("%s", msg);
        }
        /* Only the compression is new to r->oo; the flags set the rest. */
        r->oo.exr_compression = out.options.exr_compression;
    }
    if (r->want_depth && !lr_format_has_depth(r->fmt)) {
        return usage_error("--depth needs an output that can hold a Z "
                           "channel, such as .exr (%s has none)",
                           lr_format_name(r->fmt));
    }
    for (int i = 0; i < r->n_scenes; i++) {
        char out_path[4096], dir[4096];
        frame_out(r, i, out_path, sizeof out_path);
        dir_of(out_path, dir, sizeof dir);
        if (access(dir, W_OK) != 0) {
            fprintf(stderr, "lensray: cannot write to %s: %s\n", dir,
                    strerror(errno));
            return EXIT_IO;
        }
    }

    return EXIT_OK;
}

/* Here, one scene after another; one that fails does not stop the
 * others, and the exit status is the first failure's. */
static int render_frames_local(const render_job *r)
{
    int rc = EXIT_OK;
    int written = 0;
    for (int i = 0; i < r->n_scenes && !cancel_flag; i++) {
        char out_path[4096];
        frame_out(r, i, out_path, sizeof out_path);
        int frc = render_local(r, r->scenes[i], out_path);
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
    } else if (r->n_scenes > 1 && rc != EXIT_OK)
        fprintf(stderr, "lensray: %d of %d frames written, %d failed\n",
                written, r->n_scenes, r->n_scenes - written);
    return rc;
}

static int cmd_render(int argc, char **argv)
{
    render_job r;
    memset(&r, 0, sizeof r);
    lr_output_options_default(&r.oo);
    r.ro = (remote_options){NULL, NULL, 16, 4, 4, 0, &cancel_flag};
    const char *token_file = NULL, *remote_flag = NULL;
    char token[512];
    r.sets = calloc((size_t)argc + 1, sizeof *r.sets);
    r.scenes = calloc((size_t)argc + 1, sizeof *r.scenes);
    if (r.sets == NULL || r.scenes == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        free(r.sets);
        free(r.scenes);
        return EXIT_IO;
    }
    int rc = render_parse_args(&r, argc, argv, &token_file, &remote_flag);
    if (rc == EXIT_OK)
        rc = render_check_args(&r, token_file, remote_flag, token,
                               sizeof token);
    if (rc == EXIT_OK)
        rc = render_check_outputs(&r);
    if (rc == EXIT_OK) {
        signal(SIGINT, on_signal);
        signal(SIGTERM, on_signal);
        if (r.ro.url != NULL) {
            r.ro.quiet = r.quiet;
            rc = render_remote(&r);
        } else {
            rc = render_frames_local(&r);
        }
    }
    free(r.sets);
    free(r.scenes);
    return rc;
}

/* `lensray lens FILE|NAME [--field-angles A,B,...] [--wavelength NM]
 * [--ghosts [--coating NAME]]` */
static int cmd_lens(int argc, char **argv)
{
    const char *lens = NULL;
    double angles[64], nm = 587.5618;
    int n = 0, ghosts = 0, coating = -1;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--ghosts") == 0) {
            ghosts = 1;
            continue;
        }
        if (strcmp(a, "--coating") == 0) {
            static const char *const names[] = {"prescription", "none", "mgf2"};
            if (i + 1 >= argc)
                return usage_error("%s needs a value", a);
            const char *v = argv[++i];
            for (int k = 0; k < 3; k++)
                if (strcmp(v, names[k]) == 0)
                    coating = k;
            if (coating < 0)
                return usage_error("--coating '%s': one of prescription, "
                                   "none, mgf2",
                                   v);
            continue;
        }
        if (strcmp(a, "--field-angles") == 0 ||
            strcmp(a, "--wavelength") == 0) {
            if (i + 1 >= argc)
                return usage_error("%s needs a value", a);
            const char *v = argv[++i];
            char *end;
            if (strcmp(a, "--wavelength") == 0) {
                nm = strtod(v, &end);
                if (end == v || *end != '\0')
                    return usage_error("--wavelength '%s' is not a number", v);
                continue;
            }
            n = 0;
            do {
                if (n == 64)
                    return usage_error("%s", "at most 64 field angles");
                angles[n++] = strtod(v, &end);
                /* Every comma is followed by a number: "1," and "" are
                 * refused, not read as "1" and as no angles. */
                if (end == v || (*end != ',' && *end != '\0'))
                    return usage_error("--field-angles '%s': want numbers "
                                       "separated by commas",
                                       argv[i]);
                v = *end == ',' ? end + 1 : end;
            } while (*end != '\0');
        } else if (a[0] == '-' && a[1] != '\0')
            return usage_error("unknown option '%s'", a);
        else if (lens != NULL)
            return usage_error("unexpected argument '%s'", a);
        else
            lens = a;
    }
    if (lens == NULL)
        return usage_error("%s",
                           "lens needs a lens file or a shipped lens's name");
    if (coating >= 0 && !ghosts)
        return usage_error("%s", "--coating goes with --ghosts");
    char *json = NULL;
    lr_error err;
    lr_status st = ghosts ? lr_lens_ghosts(
                                lens, NULL, nm,
                                (lr_lens_coating)(coating < 0 ? 0 : coating),
                                &json, &err)
                          : lr_lens_describe(lens, NULL, angles, n, nm, &json,
                                             &err);
    if (st != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        return st == LR_ERR_IO ? EXIT_IO : EXIT_SCENE;
    }
    puts(json);
    lr_free(json);
    return EXIT_OK;
}

/* The long options that take a value: "--name=VALUE" is read as
 * "--name VALUE", as getopt_long does and as --set= always was. */
static const char *const value_options[] = {
    "--output",       "--set",        "--compression", "--remote",
    "--token-file",   "--parts",      "--parallel",    "--retries",
    "--field-angles", "--wavelength", "--coating",     NULL};

/* argv with every "--name=VALUE" of value_options split in two; NULL when
 * out of memory.  The strings stay argv's (names: the table's). */
static char **split_long_options(int argc, char **argv, int *out_argc)
{
    char **out = calloc((size_t)argc * 2 + 1, sizeof *out);
    if (out == NULL)
        return NULL;
    int n = 0;
    for (int i = 0; i < argc; i++) {
        const char *eq = strncmp(argv[i], "--", 2) == 0 ? strchr(argv[i], '=')
                                                        : NULL;
        int k = 0;
        while (eq != NULL && value_options[k] != NULL &&
               (strlen(value_options[k]) != (size_t)(eq - argv[i]) ||
                strncmp(value_options[k], argv[i], (size_t)(eq - argv[i]))))
            k++;
        if (eq != NULL && value_options[k] != NULL) {
            out[n++] = (char *)value_options[k];
            out[n++] = (char *)eq + 1;
        } else {
            out[n++] = argv[i];
        }
    }
    *out_argc = n;
    return out;
}

static int run_command(const char *cmd, int argc, char **argv)
{
    int n;
    char **args = split_long_options(argc, argv, &n);
    if (args == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        return EXIT_IO;
    }
    int rc = strcmp(cmd, "render") == 0 ? cmd_render(n, args)
                                        : cmd_lens(n, args);
    free(args);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(usage_text, stderr);
        return EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 ||
        strcmp(cmd, "help") == 0) {
        fputs(usage_text, stdout);
        return EXIT_OK;
    }
    if (strcmp(cmd, "version") == 0 || strcmp(cmd, "--version") == 0) {
        printf("lensray %s\n", lr_version());
        return EXIT_OK;
    }
    /* "lensray render --help" asks for help, not for a scene named
     * "--help": help wins over whatever else is on the line. */
    if (strcmp(cmd, "render") == 0 || strcmp(cmd, "lens") == 0) {
        for (int i = 2; i < argc; i++) {
            if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
                fputs(usage_text, stdout);
                return EXIT_OK;
            }
        }
    }
    if (strcmp(cmd, "render") == 0 || strcmp(cmd, "lens") == 0)
        return run_command(cmd, argc - 2, argv + 2);
    return usage_error("unknown command '%s'", cmd);
}
