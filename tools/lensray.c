/*
 * lensray: the command-line tool.  A thin client of lensray.h:
 *
 *   lensray render SCENE.json|SCENE.glb|SCENE.gltf... -o OUT.exr|OUT.png|OUT-%04d.exr
 *                  [--set PATH=VALUE]...
 *                  [--stats] [--half] [--compression NAME] [--png16]
 *                  [--depth] [--quiet]
 *                  [--remote URL [--parts N] [--parallel K] [--retries R]
 *                   [--timeout S] [--token-file F]]
 *   lensray version
 *   lensray --help
 *
 * Exit codes: 0 ok, 2 usage, 3 bad scene, 4 I/O, 130 interrupted.
 *
 * Here: the commands and their arguments; `render` runs in
 * render_run.c (render_job.h).
 */
#include "lensray.h"
#include "outname.h"
#include "render_job.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

static const char usage_text[] =
    "usage: lensray render SCENE.json|SCENE.glb... -o OUT.exr|OUT.png "
    "[options]\n"
    "       lensray lens FILE|NAME [--field-angles A,B,...] [--wavelength NM]\n"
    "                   [--ghosts [--coating prescription|none|mgf2]]\n"
    "       lensray lens --list\n"
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
    "                      the plan and the peak memory (peak_rss_kib);\n"
    "                      with several scenes, a line a frame written,\n"
    "                      its number first (\"frame\")\n"
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
    "  --timeout S         seconds a part may wait without a byte from the\n"
    "                      daemon before it is sent again (default 660)\n"
    "  --token-file F      the daemons' bearer token, first line of F\n"
    "\n"
    "lens: prints a lens's first-order data and real chief rays as one JSON\n"
    "object (docs/lenses.md); FILE is a .json, .zmx or pbrt .dat lens, NAME\n"
    "a shipped lens (lenses/)\n"
    "  --field-angles A,B  field angles in degrees, object at infinity\n"
    "  --wavelength NM     primary wavelength (default 587.5618, the d line)\n"
    "  --ghosts            each ghost path's flux for a distant point on the\n"
    "                      axis (or at the one field angle given)\n"
    "  --coating NAME      with --ghosts: every surface bare (none) or MgF2\n"
    "  --list              every shipped lens: its NAME, a tab, its title\n"
    "\n"
    "an option's value may also follow it after '=': --output=out.png\n"
    "\n"
    "exit status: 0 ok, 2 usage, 3 bad scene or lens, 4 I/O error,\n"
    "130 interrupted\n";

static void on_signal(int sig)
{
    cancel_flag = 1;
    /* A second Ctrl-C ends the process at once: the first stops the
     * render and the file's write at their next check, which a slow disk
     * may make long, and it had been the only way out. */
    signal(sig, SIG_DFL);
}

/* rc, or EXIT_IO if standard output could not be written: a full disk
 * under `lensray lens ... > f.json` or `--stats > f` had exited 0 with
 * the JSON cut short. */
static int stdout_checked(int rc)
{
    errno = 0;
    if (fflush(stdout) == 0 && !ferror(stdout))
        return rc;
    fprintf(stderr, "lensray: cannot write the standard output%s%s\n",
            errno ? ": " : "", errno ? strerror(errno) : "");
    return rc == EXIT_OK ? EXIT_IO : rc;
}

static int usage_error(const char *fmt, const char *arg)
{
    fprintf(stderr, "lensray: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\nTry 'lensray --help'.\n");
    return EXIT_USAGE;
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
                   strcmp(a, "--retries") == 0 || strcmp(a, "--timeout") == 0) {
            int *dst = strcmp(a, "--parts") == 0      ? &r->ro.parts
                       : strcmp(a, "--parallel") == 0 ? &r->ro.parallel
                       : strcmp(a, "--timeout") == 0  ? &r->ro.timeout
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
    /* libcurl's parse, at once: a comma list of daemons was taken as one
     * URL and tried 68 times in 3.8 s before "bad/illegal format". */
    if (r->ro.url != NULL) {
        CURLU *u = curl_url();
        CURLUcode uc = u != NULL ? curl_url_set(u, CURLUPART_URL, r->ro.url, 0)
                                 : CURLUE_OUT_OF_MEMORY;
        curl_url_cleanup(u);
        if (uc != CURLUE_OK) {
            char m[1024];
            snprintf(m, sizeof m,
                     "--remote '%.900s' is not a URL (%s); several daemons "
                     "go behind one balancer (docs/deploy.md)",
                     r->ro.url, curl_url_strerror(uc));
            return usage_error("%s", m);
        }
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
        char out_path[4096];
        frame_out(r, i, out_path, sizeof out_path);
        /* As the file will be written (a directory, where a link leads,
         * a file system that refuses), not access(2)'s guess, which
         * passes a directory and anything for root. */
        if (lr_image_write_check(out_path, &err) != LR_OK) {
            fprintf(stderr, "lensray: %s\n", err.message);
            return EXIT_IO;
        }
    }

    return EXIT_OK;
}

static int cmd_render(int argc, char **argv)
{
    render_job r;
    memset(&r, 0, sizeof r);
    lr_output_options_default(&r.oo);
    /* --timeout's default: the daemon's --max-render-seconds default
     * (600) and a minute. */
    r.ro = (remote_options){NULL, NULL, 16, 4, 4, 0, 660, &cancel_flag};
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

/* `lensray lens --list`: each shipped lens's name and title, a line each
 * (lr_lenses_describe's ids and names; the unknown-lens error lists only
 * as many names as its message holds). */
static int list_lenses(void)
{
    char *json = NULL;
    lr_error err;
    if (lr_lenses_describe(NULL, 0, 587.5618, &json, &err) != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        return err.status == LR_ERR_IO ? EXIT_IO : EXIT_SCENE;
    }
    cJSON *o = cJSON_Parse(json);
    lr_free(json);
    const cJSON *l = NULL;
    cJSON_ArrayForEach(l, cJSON_GetObjectItemCaseSensitive(o, "lenses"))
    {
        const cJSON *id = cJSON_GetObjectItemCaseSensitive(l, "id");
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(l, "name");
        if (cJSON_IsString(id))
            printf("%s\t%s\n", id->valuestring,
                   cJSON_IsString(name) ? name->valuestring : "");
    }
    int rc = o != NULL ? EXIT_OK : EXIT_SCENE;
    cJSON_Delete(o);
    return rc;
}

/* `lensray lens FILE|NAME [--field-angles A,B,...] [--wavelength NM]
 * [--ghosts [--coating NAME]]` or `lensray lens --list` */
static int cmd_lens(int argc, char **argv)
{
    if (argc == 1 && strcmp(argv[0], "--list") == 0)
        return list_lenses();
    const char *lens = NULL;
    double angles[64], nm = 587.5618;
    int n = 0, ghosts = 0, coating = -1;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--ghosts") == 0) {
            ghosts = 1;
            continue;
        }
        if (strcmp(a, "--list") == 0)
            return usage_error("%s", "--list takes no other arguments");
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
                /* The catalogue keeps no glass's fitted range: HIKARI's
                 * are 400 to 700 nm and 546 glasses' narrower than 380 to
                 * 780, beyond which their formulas are extrapolations
                 * (HIKARI BAF10 at 1600 nm 0.007 above SCHOTT N-BAF10). */
                if (!(nm >= 380 && nm <= 780) && nm >= 300 && nm <= 2000)
                    fprintf(stderr,
                            "lensray: warning: --wavelength %g: outside "
                            "380 to 780 nm a glass's formula may be used "
                            "beyond the range its maker fitted it over\n",
                            nm);
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
    if (ghosts && n > 1)
        return usage_error("%s", "--ghosts takes one field angle (the "
                                 "distant point's, in degrees)");
    char *json = NULL;
    lr_error err;
    lr_status st = ghosts ? lr_lens_ghosts_at(
                                lens, NULL, nm, n == 1 ? angles[0] : 0.0,
                                (lr_lens_coating)(coating < 0 ? 0 : coating),
                                &json, &err)
                          : lr_lens_describe(lens, NULL, angles, n, nm, &json,
                                             &err);
    if (st != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        /* A value given on the command line is a usage error (the
         * library names those by path), the lens's own a lens error. */
        if (strcmp(err.path, "wavelength") == 0 ||
            strcmp(err.path, "field_angles") == 0)
            return EXIT_USAGE;
        return st == LR_ERR_IO ? EXIT_IO : EXIT_SCENE;
    }
    puts(json);
    lr_free(json);
    return EXIT_OK;
}

/* The long options that take a value: "--name=VALUE" is read as
 * "--name VALUE", as getopt_long does and as --set= always was. */
static const char *const value_options[] = {"--output",
                                            "--set",
                                            "--compression",
                                            "--remote",
                                            "--token-file",
                                            "--parts",
                                            "--parallel",
                                            "--retries",
                                            "--timeout",
                                            "--field-angles",
                                            "--wavelength",
                                            "--coating",
                                            NULL};

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

static int run(int argc, char **argv)
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

int main(int argc, char **argv)
{
    return stdout_checked(run(argc, argv));
}
