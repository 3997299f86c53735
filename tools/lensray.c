/*
 * lensray: the command-line tool.  A thin client of lensray.h:
 *
 *   lensray render SCENE.json|SCENE.glb|SCENE.gltf -o OUT.exr|OUT.png [--set PATH=VALUE]...
 *                  [--stats] [--half] [--png16] [--depth] [--quiet]
 *                  [--remote URL [--parts N] [--parallel K] [--retries R]
 *                   [--token-file F]]
 *   lensray version
 *   lensray --help
 *
 * Exit codes: 0 ok, 2 usage, 3 bad scene, 4 I/O, 130 interrupted.
 */
#include "lensray.h"
#include "assets.h"
#include "remote.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

enum { EXIT_OK = 0, EXIT_USAGE = 2, EXIT_SCENE = 3, EXIT_IO = 4,
       EXIT_INTERRUPTED = 130 };

static const char usage_text[] =
    "usage: lensray render SCENE.json|SCENE.glb -o OUT.exr|OUT.png [options]\n"
    "       lensray lens FILE|NAME [--field-angles A,B,...] [--wavelength NM]\n"
    "       lensray version\n"
    "       lensray --help\n"
    "\n"
    "render options:\n"
    "  -o, --output FILE   image to write; the format follows the extension\n"
    "                      (.exr: linear float, .png: 8-bit sRGB)\n"
    "  --set PATH=VALUE    override a scene value by its JSON path, e.g.\n"
    "                      --set camera.fov=30 --set render.spp=64\n"
    "                      --set 'objects[1].radius=0.5' (VALUE is JSON,\n"
    "                      or a plain string); may be repeated\n"
    "  --stats             print a JSON line with time, rays, samples/s,\n"
    "                      the plan and the peak memory (peak_rss_kib)\n"
    "  --half              EXR: write RGB as half floats\n"
    "  --png16             PNG: 16 bits per channel\n"
    "  --depth             also render the Z channel (written to EXR)\n"
    "  -q, --quiet         no progress bar\n"
    "\n"
    "rendering on daemons (docs/deploy.md):\n"
    "  --remote URL        render on lensrayd at URL (one daemon, or many\n"
    "                      behind a balancer) as region parts, stitched into\n"
    "                      the same pixels as a local render; the scene's\n"
    "                      meshes are read from the daemons' scenes directory\n"
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
    case LR_OK: return EXIT_OK;
    case LR_ERR_IO: return EXIT_IO;
    case LR_ERR_CANCELLED: return EXIT_INTERRUPTED;
    default: return EXIT_SCENE;
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

/* --remote: the frame on the daemons (tools/remote.c); the exit status.
 * With --stats, one JSON line of what it took. */
static int render_remote(const remote_options *ro, const char *scene_path,
                         const lr_camera *cam, const lr_render_settings *rs,
                         lr_image **img, int stats)
{
    size_t len;
    char *text = (char *)read_whole_file(scene_path, &len);
    if (text == NULL) {
        fprintf(stderr, "lensray: %s: %s\n", scene_path, strerror(errno));
        return EXIT_IO;
    }
    /* Mesh paths are relative to the scene file's directory. */
    char dir[4096];
    dir_of(scene_path, dir, sizeof dir);
    remote_options o = *ro;
    o.scene_dir = dir;
    remote_stats st;
    int rc = remote_render(&o, text, len, cam, rs, img, &st);
    free(text);
    if (rc == EXIT_OK && stats)
        printf("{\"remote\": true, \"seconds\": %.3f, \"parts\": %d, "
               "\"requests\": %d, \"retries\": %d, \"assets\": %d, "
               "\"uploaded\": %d}\n",
               st.seconds, st.parts, st.attempts, st.retries, st.assets,
               st.uploaded);
    return rc;
}

static int cmd_render(int argc, char **argv)
{
    const char *scene_path = NULL, *out_path = NULL;
    int stats = 0, quiet = 0, want_depth = 0;
    lr_output_options oo;
    lr_output_options_default(&oo);
    remote_options ro = {NULL, NULL, 16, 4, 4, 0, &cancel_flag, NULL};
    const char *token_file = NULL, *remote_flag = NULL;
    char token[512];
    const char **sets = calloc((size_t)argc, sizeof *sets);
    size_t n_sets = 0;
    if (sets == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        return EXIT_IO;
    }
    int rc = EXIT_OK;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-o") == 0 || strcmp(a, "--output") == 0) {
            if (i + 1 >= argc) {
                rc = usage_error("%s needs a file name", a);
                goto done;
            }
            out_path = argv[++i];
        } else if (strcmp(a, "--set") == 0) {
            if (i + 1 >= argc) {
                rc = usage_error("%s needs PATH=VALUE", a);
                goto done;
            }
            sets[n_sets++] = argv[++i];
        } else if (strncmp(a, "--set=", 6) == 0) {
            sets[n_sets++] = a + 6;
        } else if (strcmp(a, "--stats") == 0) {
            stats = 1;
        } else if (strcmp(a, "--half") == 0) {
            oo.exr_half = 1;
        } else if (strcmp(a, "--png16") == 0) {
            oo.png_16bit = 1;
        } else if (strcmp(a, "--depth") == 0) {
            want_depth = 1;
        } else if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
        } else if (strcmp(a, "--remote") == 0 ||
                   strcmp(a, "--token-file") == 0) {
            if (i + 1 >= argc) {
                rc = usage_error("%s needs a value", a);
                goto done;
            }
            if (a[2] == 'r')
                ro.url = argv[++i];
            else
                token_file = argv[++i];
        } else if (strcmp(a, "--parts") == 0 ||
                   strcmp(a, "--parallel") == 0 ||
                   strcmp(a, "--retries") == 0) {
            int *dst = strcmp(a, "--parts") == 0      ? &ro.parts
                       : strcmp(a, "--parallel") == 0 ? &ro.parallel
                                                      : &ro.retries;
            int lo = dst == &ro.retries ? 0 : 1;
            if (i + 1 >= argc || parse_int(argv[i + 1], lo, 100000, dst) != 0) {
                char what[64];
                snprintf(what, sizeof what, "%s needs a whole number from %d "
                         "to 100000", a, lo);
                rc = usage_error("%s", what);
                goto done;
            }
            i++;
            remote_flag = a;
        } else if (a[0] == '-' && a[1] != '\0') {
            rc = usage_error("unknown option '%s'", a);
            goto done;
        } else if (scene_path == NULL) {
            scene_path = a;
        } else {
            rc = usage_error("unexpected argument '%s'", a);
            goto done;
        }
    }
    if (scene_path == NULL) {
        rc = usage_error("%s", "render needs a scene file");
        goto done;
    }
    if (out_path == NULL) {
        rc = usage_error("%s", "render needs an output file: -o OUT.exr or "
                               "-o OUT.png");
        goto done;
    }
    for (size_t i = 0; i < n_sets; i++) {
        if (strchr(sets[i], '=') == NULL) {
            rc = usage_error("--set '%s' must look like PATH=VALUE", sets[i]);
            goto done;
        }
        /* The daemons get the scene file as it is, with the camera and
         * settings as this process reads them: other overrides would not
         * reach them. */
        if (ro.url != NULL && strncmp(sets[i], "camera.", 7) != 0 &&
            strncmp(sets[i], "render.", 7) != 0) {
            rc = usage_error("--set '%s': with --remote only camera.* and "
                             "render.* can be overridden", sets[i]);
            goto done;
        }
    }
    if (ro.url == NULL && (token_file != NULL || remote_flag != NULL)) {
        rc = usage_error("%s is for --remote",
                         token_file != NULL ? "--token-file" : remote_flag);
        goto done;
    }
    if (token_file != NULL) {
        if (read_token(token_file, token, sizeof token) != 0) {
            rc = EXIT_IO;
            goto done;
        }
        ro.token = token;
    }

    /* Check the output name before rendering, so that a long render is
     * never thrown away for want of a valid file name. */
    lr_error err;
    lr_format fmt;
    if (lr_format_from_path(out_path, &fmt, &err) != LR_OK) {
        rc = usage_error("%s", err.message);
        goto done;
    }
    /* The format's options by the library's rules (lr_output), so that
     * --half with a .png, say, is refused rather than ignored. */
    if (oo.exr_half || oo.png_16bit) {
        char spec[128];
        lr_output out;
        lr_output_default(&out);
        snprintf(spec, sizeof spec, "{\"format\": \"%s\"%s%s}",
                 lr_format_name(fmt), oo.exr_half ? ", \"half\": true" : "",
                 oo.png_16bit ? ", \"bit_depth\": 16" : "");
        if (lr_output_apply_json(&out, spec, strlen(spec), &err) != LR_OK) {
            char msg[sizeof err.message + 32];
            snprintf(msg, sizeof msg, "%s: %s",
                     strcmp(err.path, "output.half") == 0 ? "--half"
                                                          : "--png16",
                     err.message);
            rc = usage_error("%s", msg);
            goto done;
        }
    }
    if (want_depth && !lr_format_has_depth(fmt)) {
        rc = usage_error("--depth needs an output that can hold a Z "
                         "channel, such as .exr (%s has none)",
                         lr_format_name(fmt));
        goto done;
    }
    {
        char dir[4096];
        dir_of(out_path, dir, sizeof dir);
        if (access(dir, W_OK) != 0) {
            fprintf(stderr, "lensray: cannot write to %s: %s\n", dir,
                    strerror(errno));
            rc = EXIT_IO;
            goto done;
        }
    }

    lr_scene *scene = NULL;
    lr_status st = lr_scene_load_file(scene_path, sets, n_sets, &scene, &err);
    if (st != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        rc = exit_for(st);
        goto done;
    }
    /* What the loader ignored (glTF features), one line each. */
    for (const char *w = lr_scene_warnings(scene); *w;) {
        const char *nl = strchr(w, '\n');
        int len = nl ? (int)(nl - w) : (int)strlen(w);
        fprintf(stderr, "lensray: warning: %.*s\n", len, w);
        w += len + (nl != NULL);
    }
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(scene, &cam);
    lr_scene_settings(scene, &rs);
    if (want_depth)
        rs.want_depth = 1;
    if (rs.want_depth && !lr_format_has_depth(fmt)) {
        /* The scene asks for Z but the output cannot hold it: say so
         * rather than drop it silently, and skip the work. */
        fprintf(stderr, "lensray: warning: render.depth is set but %s has no "
                        "Z channel; write an .exr to keep it\n",
                out_path);
        rs.want_depth = 0;
    }
    progress prog = {now(), 0.0};
    if (!quiet && isatty(STDERR_FILENO)) {
        rs.progress = on_progress;
        rs.progress_user = &prog;
    }
    rs.cancel = &cancel_flag;
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);

    lr_image *img = NULL;
    lr_render_stats rst;
    memset(&rst, 0, sizeof rst);
    if (ro.url != NULL) {
        ro.quiet = quiet;
        rc = render_remote(&ro, scene_path, &cam, &rs, &img, stats);
        if (rc == EXIT_OK)
            rc = write_image(img, out_path, &oo);
        lr_image_free(img);
        lr_scene_free(scene);
        goto done;
    }
    st = lr_render(scene, &cam, &rs, &img, &rst, &err);
    if (st != LR_OK) {
        /* End the progress bar's line first, if there is one. */
        fprintf(stderr, "%slensray: %s\n", rs.progress ? "\n" : "",
                err.message);
        rc = exit_for(st);
        lr_scene_free(scene);
        goto done;
    }
    st = lr_image_write(img, out_path, &oo, &err);
    if (st != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        rc = exit_for(st) == EXIT_SCENE ? EXIT_IO : exit_for(st);
    } else if (stats) {
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
        fprintf(stderr, "lensray: warning: %llu samples were NaN or "
                        "infinite and were dropped\n",
                (unsigned long long)rst.nan_samples);
    lr_image_free(img);
    lr_scene_free(scene);
done:
    free(sets);
    return rc;
}

/* `lensray lens FILE|NAME [--field-angles A,B,...] [--wavelength NM]` */
static int cmd_lens(int argc, char **argv)
{
    const char *lens = NULL;
    double angles[64], nm = 587.5618;
    int n = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--field-angles") == 0 || strcmp(a, "--wavelength") == 0) {
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
            while (*v) {
                if (n == 64)
                    return usage_error("%s", "at most 64 field angles");
                angles[n++] = strtod(v, &end);
                if (end == v || (*end != ',' && *end != '\0'))
                    return usage_error("--field-angles '%s': want numbers "
                                       "separated by commas", argv[i]);
                v = *end == ',' ? end + 1 : end;
            }
        } else if (a[0] == '-' && a[1] != '\0')
            return usage_error("unknown option '%s'", a);
        else if (lens != NULL)
            return usage_error("unexpected argument '%s'", a);
        else
            lens = a;
    }
    if (lens == NULL)
        return usage_error("%s", "lens needs a lens file or a shipped lens's name");
    char *json = NULL;
    lr_error err;
    lr_status st = lr_lens_describe(lens, NULL, angles, n, nm, &json, &err);
    if (st != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        return st == LR_ERR_IO ? EXIT_IO : EXIT_SCENE;
    }
    puts(json);
    lr_free(json);
    return EXIT_OK;
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
    if (strcmp(cmd, "render") == 0)
        return cmd_render(argc - 2, argv + 2);
    if (strcmp(cmd, "lens") == 0)
        return cmd_lens(argc - 2, argv + 2);
    return usage_error("unknown command '%s'", cmd);
}
