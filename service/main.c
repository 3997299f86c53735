/*
 * main.c: lensrayd's entry point: flags and environment, startup, and the
 * graceful shutdown on SIGTERM or SIGINT.
 *
 *   lensrayd [--port 8080] [--bind 127.0.0.1] [--scenes DIR] [--workers N]
 *            [--queue N] [--token-file F] [--allow-host NAME,...]
 *            [limits...]
 *
 * Every flag --some-name also reads the environment variable
 * LENSRAYD_SOME_NAME; a flag on the command line wins over the variable.
 * Exit status: 0 after a clean shutdown, 1 if the server could not start,
 * 2 for a bad flag or variable.
 */
#include "lensrayd.h"

#include <errno.h>
#include <limits.h>
#include <malloc.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

lrd_config lrd_cfg;

typedef enum opt_type {
    T_STR,  /* a string into a char array */
    T_LONG, /* a whole number */
    T_U64,  /* a whole number, or a byte size with k/M/G when `size` */
    T_SECS, /* seconds, fractions allowed */
    T_FLAG  /* on when given without a value; 0 or 1 with one */
} opt_type;

typedef struct opt {
    const char *name; /* without the leading "--" */
    opt_type type;
    void *ptr;
    size_t cap; /* T_STR: size of the array */
    int size;   /* T_U64: accept k/M/G suffixes */
    double min, max;
    const char *help;
} opt;

static char scenes_arg[4096] = "scenes";
static char token_file[4096] = "";
static char assets_arg[4096] = "";

#define U64(x) ((double)(x))
static const opt opts[] = {
    {"port", T_LONG, &lrd_cfg.port, 0, 0, 0, 65535,
     "TCP port; 0 picks a free one (printed at startup)"},
    {"bind", T_STR, lrd_cfg.bind, sizeof lrd_cfg.bind, 0, 0, 0,
     "address to listen on (IPv4 or IPv6)"},
    {"scenes", T_STR, scenes_arg, sizeof scenes_arg, 0, 0, 0,
     "directory of NAME.json scenes and their meshes"},
    {"workers", T_LONG, &lrd_cfg.workers, 0, 0, 1, 256,
     "render worker threads (jobs rendered at once)"},
    {"queue", T_LONG, &lrd_cfg.queue, 0, 0, 0, 100000,
     "jobs that may wait for a worker; more get 429"},
    {"assets", T_STR, assets_arg, sizeof assets_arg, 0, 0, 0,
     "directory of content-addressed assets (PUT /v1/assets/{sha256}); "
     "shared by the daemons behind one balancer; none by default"},
    {"max-asset-bytes", T_U64, &lrd_cfg.max_asset, 0, 1, 1, U64(1ull << 40),
     "largest asset in bytes (k/M/G suffixes)"},
    {"id-prefix", T_STR, lrd_cfg.id_prefix, sizeof lrd_cfg.id_prefix, 0, 0, 0,
     "1 to 8 lowercase hex digits that start every job id, so that a "
     "balancer sends a job's requests to this daemon"},
    {"token-file", T_STR, token_file, sizeof token_file, 0, 0, 0,
     "file holding a bearer token that every request but /healthz must "
     "send"},
    {"allow-host", T_STR, lrd_cfg.allow_host, sizeof lrd_cfg.allow_host, 0, 0,
     0,
     "without --token-file, host names (comma-separated, any port) that a "
     "request's Host header may give besides IP addresses and localhost; "
     "others get 403, against DNS rebinding"},
    {"max-body", T_U64, &lrd_cfg.max_body, 0, 1, 1, U64(1) * (1 << 30),
     "largest request body in bytes (k/M/G suffixes)"},
    {"max-pixels", T_U64, &lrd_cfg.max_pixels, 0, 0, 1, U64(1ull << 28),
     "most pixels in one image (of the region, for a crop)"},
    {"max-samples", T_U64, &lrd_cfg.max_samples, 0, 0, 1, U64(1ull << 50),
     "most samples (pixels x spp) in one job"},
    {"max-render-seconds", T_SECS, &lrd_cfg.max_render_seconds, 0, 0, 0, 1e7,
     "longest render; then it fails with \"timeout\" (0: no limit)"},
    {"max-output-bytes", T_U64, &lrd_cfg.max_output, 0, 1, 1, U64(1ull << 40),
     "largest encoded image in bytes"},
    {"max-json-depth", T_LONG, &lrd_cfg.max_json_depth, 0, 0, 1,
     LR_MAX_JSON_DEPTH, "deepest nesting of a request body"},
    {"max-connections", T_LONG, &lrd_cfg.max_connections, 0, 0, 1, 10000,
     "open connections, all clients together"},
    {"max-connections-per-ip", T_LONG, &lrd_cfg.max_per_ip, 0, 0, 0, 10000,
     "open connections from one address (0: no limit)"},
    {"connection-memory", T_U64, &lrd_cfg.conn_memory, 0, 1, 8192,
     U64(1) * (1 << 30), "memory per connection for headers and buffers"},
    {"connection-timeout", T_LONG, &lrd_cfg.conn_timeout, 0, 0, 0, 86400,
     "seconds an idle or stalled connection is kept (0: forever)"},
    {"job-ttl", T_SECS, &lrd_cfg.job_ttl, 0, 0, 0, 1e7,
     "seconds a finished job and its image are kept"},
    {"max-finished-jobs", T_LONG, &lrd_cfg.max_finished, 0, 0, 0, 1000000,
     "finished jobs kept (the oldest go first)"},
    {"max-retained-bytes", T_U64, &lrd_cfg.max_retained, 0, 1, 0,
     U64(1ull << 40), "image bytes kept by finished jobs"},
    {"scene-cache", T_LONG, &lrd_cfg.scene_cache, 0, 0, 1, 10000,
     "loaded scenes kept in memory"},
    {"max-scene-triangles", T_U64, &lrd_cfg.max_scene_triangles, 0, 0, 0,
     U64(1ull << 40),
     "most triangles one scene may hold, every placed copy of a mesh "
     "counted (0: no limit)"},
    {"max-scene-texels", T_U64, &lrd_cfg.max_scene_texels, 0, 0, 0,
     U64(1ull << 40),
     "most texels of one scene's textures and environment map (0: no "
     "limit)"},
    {"shutdown-grace", T_SECS, &lrd_cfg.shutdown_grace, 0, 0, 0, 86400,
     "seconds running jobs get to finish on SIGTERM before they are "
     "cancelled"},
    {"no-ui", T_FLAG, &lrd_cfg.no_ui, 0, 0, 0, 1,
     "do not serve the page at / (docs/page.md): 404 instead"},
};
#define N_OPTS (sizeof opts / sizeof opts[0])


/* "max-body" -> "LENSRAYD_MAX_BODY". */
static void env_name(const char *name, char *out, size_t n)
{
    size_t o = (size_t)snprintf(out, n, "LENSRAYD_");
    for (const char *p = name; *p != '\0' && o + 1 < n; p++)
        out[o++] = *p == '-'
                       ? '_'
                       : (char)(*p >= 'a' && *p <= 'z' ? *p - 'a' + 'A' : *p);
    out[o] = '\0';
}

/* Where each option's value came from ("--scenes" or "LENSRAYD_SCENES"),
 * so that the checks after parsing name what the user wrote. */
static char given[N_OPTS][64];

static const char *given_as(const char *name)
{
    for (size_t i = 0; i < N_OPTS; i++)
        if (strcmp(opts[i].name, name) == 0) {
            if (given[i][0] == '\0')
                snprintf(given[i], sizeof given[i], "--%s", name);
            return given[i];
        }
    return name;
}

/* Sets one option from text; `from` names the source in messages. */
static int set_opt(const opt *o, const char *value, const char *from)
{
    snprintf(given[o - opts], sizeof given[0], "%s", from);
    switch (o->type) {
    case T_STR:
        if (strlen(value) >= o->cap) {
            fprintf(stderr, "lensrayd: %s is too long\n", from);
            return -1;
        }
        snprintf(o->ptr, o->cap, "%s", value);
        return 0;
    case T_LONG:
    case T_FLAG: {
        uint64_t v = 0;
        if (lrd_parse_u64(value, 0, &v) != 0 || (double)v < o->min ||
            (double)v > o->max) {
            fprintf(stderr,
                    "lensrayd: %s must be a whole number from %.0f to %.0f, "
                    "got '%s'\n",
                    from, o->min, o->max, value);
            return -1;
        }
        *(long *)o->ptr = (long)v;
        return 0;
    }
    case T_U64: {
        uint64_t v = 0;
        if (lrd_parse_u64(value, o->size, &v) != 0 || (double)v < o->min ||
            (double)v > o->max) {
            fprintf(stderr,
                    "lensrayd: %s must be a whole number from %.0f to %.0f%s, "
                    "got '%s'\n",
                    from, o->min, o->max,
                    o->size ? " (k, M and G suffixes allowed)" : "", value);
            return -1;
        }
        *(uint64_t *)o->ptr = v;
        return 0;
    }
    case T_SECS: {
        double v = 0;
        if (lrd_parse_seconds(value, &v) != 0 || v < o->min || v > o->max) {
            fprintf(stderr,
                    "lensrayd: %s must be a number of seconds from %g to %g, "
                    "got '%s'\n",
                    from, o->min, o->max, value);
            return -1;
        }
        *(double *)o->ptr = v;
        return 0;
    }
    }
    return -1;
}

/* Each option's default as its flag would spell it ("8080", "64M",
 * "none"), taken before the environment and the command line apply. */
static char defaults[N_OPTS][32];

static void opt_text(const opt *o, char *out, size_t n)
{
    uint64_t v;
    switch (o->type) {
    case T_STR:
        snprintf(out, n, "%s", ((char *)o->ptr)[0] ? (char *)o->ptr : "none");
        return;
    case T_LONG:
        snprintf(out, n, "%ld", *(long *)o->ptr);
        return;
    case T_FLAG:
        snprintf(out, n, "%s", *(long *)o->ptr ? "on" : "off");
        return;
    case T_SECS:
        snprintf(out, n, "%g", *(double *)o->ptr);
        return;
    case T_U64:
        v = *(uint64_t *)o->ptr;
        if (o->size && v > 0 && v % (1u << 30) == 0)
            snprintf(out, n, "%lluG", (unsigned long long)(v >> 30));
        else if (o->size && v > 0 && v % (1u << 20) == 0)
            snprintf(out, n, "%lluM", (unsigned long long)(v >> 20));
        else if (o->size && v > 0 && v % (1u << 10) == 0)
            snprintf(out, n, "%lluk", (unsigned long long)(v >> 10));
        else
            snprintf(out, n, "%llu", (unsigned long long)v);
        return;
    }
}

static void usage(FILE *f)
{
    fprintf(f, "usage: lensrayd [options]\n\n"
               "The lensray HTTP render daemon (API: docs/api.md).\n\n"
               "options (each also read from the environment variable "
               "shown):\n");
    for (size_t i = 0; i < N_OPTS; i++) {
        char env[64];
        env_name(opts[i].name, env, sizeof env);
        fprintf(f, "  --%-24s %s\n  %-26s [%s; default %s]\n", opts[i].name,
                opts[i].help, "", env, defaults[i]);
    }
    fprintf(f, "  --help                     this text\n"
               "  --version                  print the version\n\n"
               "SIGTERM or SIGINT stops the server gracefully; a second one "
               "cancels running renders at once.\n");
}

static const opt *find_opt(const char *name, size_t len)
{
    for (size_t i = 0; i < N_OPTS; i++)
        if (strlen(opts[i].name) == len &&
            strncmp(opts[i].name, name, len) == 0)
            return &opts[i];
    return NULL;
}

/* --allow-host's list in place: names without spaces, a trailing dot or
 * capitals, joined by commas.  Returns 0, or -1 (said on stderr) for an
 * empty name or one with other characters than a host name has. */
static int normalize_hosts(char *list, const char *from)
{
    char out[sizeof lrd_cfg.allow_host];
    size_t o = 0;
    const char *p = list;
    if (list[0] == '\0')
        return 0;
    for (;;) {
        size_t n = strcspn(p, ",");
        const char *s = p, *e = p + n;
        while (s < e && (*s == ' ' || *s == '\t'))
            s++;
        while (e > s && (e[-1] == ' ' || e[-1] == '\t'))
            e--;
        if (e > s && e[-1] == '.')
            e--;
        if (e == s || (size_t)(e - s) > 253 ||
            strspn(s, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                      "0123456789.-_") < (size_t)(e - s)) {
            fprintf(stderr,
                    "lensrayd: %s must be host names separated by commas "
                    "(letters, digits, '.', '-', '_'; no port), got '%s'\n",
                    from, list);
            return -1;
        }
        if (o > 0)
            out[o++] = ',';
        for (; s < e; s++)
            out[o++] = (char)(*s >= 'A' && *s <= 'Z' ? *s - 'A' + 'a' : *s);
        if (p[n] == '\0')
            break;
        p += n + 1;
    }
    out[o] = '\0';
    memcpy(list, out, o + 1);
    return 0;
}

/* Returns 0 to go on, 1 to exit 0 (help, version), -1 to exit 2. */
static int configure(int argc, char **argv)
{
    lrd_config_defaults();
    for (size_t i = 0; i < N_OPTS; i++)
        opt_text(&opts[i], defaults[i], sizeof defaults[i]);
    for (size_t i = 0; i < N_OPTS; i++) {
        char env[64], from[96];
        env_name(opts[i].name, env, sizeof env);
        const char *v = getenv(env);
        snprintf(from, sizeof from, "%s", env);
        if (v != NULL && v[0] != '\0' && set_opt(&opts[i], v, from) != 0)
            return -1;
    }
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return 1;
        }
        if (strcmp(a, "--version") == 0) {
            printf("lensrayd %s (liblensray %s)\n", LRD_VERSION, lr_version());
            return 1;
        }
        if (strncmp(a, "--", 2) != 0) {
            fprintf(stderr,
                    "lensrayd: unexpected argument '%s'\nTry "
                    "'lensrayd --help'.\n",
                    a);
            return -1;
        }
        const char *name = a + 2;
        const char *eq = strchr(name, '=');
        size_t len = eq ? (size_t)(eq - name) : strlen(name);
        const opt *o = find_opt(name, len);
        if (o == NULL) {
            fprintf(stderr,
                    "lensrayd: unknown option '%s'\nTry 'lensrayd "
                    "--help'.\n",
                    a);
            return -1;
        }
        const char *value = eq ? eq + 1 : NULL;
        if (value == NULL && o->type == T_FLAG)
            value = "1";
        if (value == NULL) {
            if (i + 1 >= argc) {
                fprintf(stderr, "lensrayd: --%s needs a value\n", o->name);
                return -1;
            }
            value = argv[++i];
        }
        char from[96];
        snprintf(from, sizeof from, "--%s", o->name);
        if (set_opt(o, value, from) != 0)
            return -1;
    }

    /* A name that is no address is a bad value (exit 2), found before
     * the scenes are loaded rather than when the socket opens. */
    struct sockaddr_storage sa;
    int v6;
    const char *why = lrd_http_resolve(lrd_cfg.bind, &sa, &v6);
    if (why != NULL) {
        fprintf(stderr,
                "lensrayd: %s '%s' is not an address to listen on: "
                "%s\n",
                given_as("bind"), lrd_cfg.bind, why);
        return -1;
    }
    struct stat st;
    if (realpath(scenes_arg, lrd_cfg.scenes_dir) == NULL ||
        stat(lrd_cfg.scenes_dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "lensrayd: %s %s is not a directory\n",
                given_as("scenes"), scenes_arg);
        return -1;
    }
    if (strspn(lrd_cfg.id_prefix, "0123456789abcdef") !=
        strlen(lrd_cfg.id_prefix)) {
        fprintf(stderr,
                "lensrayd: %s must be 1 to 8 lowercase hex digits, "
                "got '%s'\n",
                given_as("id-prefix"), lrd_cfg.id_prefix);
        return -1;
    }
    if (assets_arg[0] != '\0' &&
        (realpath(assets_arg, lrd_cfg.assets_dir) == NULL ||
         stat(lrd_cfg.assets_dir, &st) != 0 || !S_ISDIR(st.st_mode) ||
         access(lrd_cfg.assets_dir, W_OK) != 0)) {
        fprintf(stderr,
                "lensrayd: %s %s is not a directory this "
                "process can write to\n",
                given_as("assets"), assets_arg);
        return -1;
    }
    /* The library finds "sha256:HEX" files of every kind there (and,
     * without --assets, nowhere: not in a directory the environment
     * happens to name). */
    if (lrd_cfg.assets_dir[0] == '\0')
        unsetenv("LENSRAY_ASSETS_DIR");
    lr_assets_dir_set(lrd_cfg.assets_dir, NULL);
    if (normalize_hosts(lrd_cfg.allow_host, given_as("allow-host")) != 0)
        return -1;
    lr_scene_limits_set(lrd_cfg.max_scene_triangles, lrd_cfg.max_scene_texels);
    if (token_file[0] != '\0') {
        size_t len = 0;
        char *t = lrd_read_file(token_file, 4096, &len);
        if (t == NULL) {
            fprintf(stderr, "lensrayd: cannot read %s %s: %s\n",
                    given_as("token-file"), token_file, strerror(errno));
            return -1;
        }
        /* The first line is the token, as the docs and the CLI's
         * --token-file say (a second line, a note, had made every
         * request 401), without the whitespace editors add. */
        const char *nl = memchr(t, '\n', len);
        if (nl != NULL)
            len = (size_t)(nl - t), t[len] = '\0';
        while (len > 0 && (t[len - 1] == '\n' || t[len - 1] == '\r' ||
                           t[len - 1] == ' ' || t[len - 1] == '\t'))
            t[--len] = '\0';
        if (len == 0 || strlen(t) != len) {
            fprintf(stderr,
                    "lensrayd: %s %s holds no token (or a NUL "
                    "byte)\n",
                    given_as("token-file"), token_file);
            free(t);
            return -1;
        }
        lrd_cfg.token = t;
    }
    return 0;
}

/* Waits up to `seconds` for a signal of `set`; returns it, or 0. */
static int wait_signal(const sigset_t *set, double seconds)
{
    struct timespec ts;
    ts.tv_sec = (time_t)seconds;
    ts.tv_nsec = (long)((seconds - (double)ts.tv_sec) * 1e9);
    int sig = sigtimedwait(set, NULL, &ts);
    return sig > 0 ? sig : 0;
}

int main(int argc, char **argv)
{
    /* Request bodies and images of a few MiB are allocated and freed by
     * many connection threads; with glibc's default (dynamic) mmap
     * threshold they stay resident in per-thread arenas after being
     * freed, and RSS climbs in 8 MiB steps to several times what is in
     * use.  Blocks over 1 MiB go straight to mmap and back instead. */
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
    /* Setting that threshold also fixes glibc's trim threshold at 128 KiB,
     * so a render's blocks under 1 MiB (its workers' scratch, about 250
     * KiB a thread) were given back to the kernel when freed and faulted
     * in, zeroed, by the next render: 1.8 ms of a farm part's 1.9 ms of
     * daemon CPU went there (perf, 200 one-row parts).  Keeping up to
     * 32 MiB of free heap makes it 1.2 ms, for 0.8 MiB more RSS. */
    mallopt(M_TRIM_THRESHOLD, 32 << 20);
    int rc = configure(argc, argv);
    if (rc != 0) {
        free(lrd_cfg.token);
        return rc > 0 ? 0 : 2;
    }

    /* SIGTERM and SIGINT are blocked in every thread (threads inherit the
     * mask) and taken synchronously here with sigwait, so no handler runs
     * in the middle of a lock.  Writes to closed sockets must not kill
     * the process. */
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    pthread_sigmask(SIG_BLOCK, &set, NULL);
    signal(SIGPIPE, SIG_IGN);

    lrd_metrics_start();
    if (lrd_scenes_init() != 0 || lrd_jobs_start() != 0) {
        free(lrd_cfg.token);
        return 1;
    }
    if (lrd_http_start() != 0) {
        lrd_jobs_begin_shutdown();
        lrd_jobs_stop();
        lrd_jobs_free_all();
        lrd_scenes_shutdown();
        free(lrd_cfg.token);
        return 1;
    }

    int sig = 0;
    while (sig == 0) {
        sig = wait_signal(&set, 0.25);
        lrd_jobs_enforce_time();
    }

    /* Shutdown: stop accepting, refuse new work with 503, cancel what is
     * queued, give running renders the grace period, then cancel them; a
     * cancelled render ends at its next tile and produces no image, so
     * nothing partial is ever sent as if it were whole. */
    fprintf(stderr,
            "lensrayd: %s: shutting down (up to %gs for running "
            "jobs)\n",
            sig == SIGINT ? "SIGINT" : "SIGTERM", lrd_cfg.shutdown_grace);
    lrd_http_quiesce();
    lrd_jobs_begin_shutdown();
    double deadline = lrd_monotonic() + lrd_cfg.shutdown_grace;
    int again = 0;
    while (lrd_jobs_running() > 0 && lrd_monotonic() < deadline && !again) {
        again = wait_signal(&set, 0.05);
        lrd_jobs_enforce_time();
    }
    long left = lrd_jobs_running();
    if (left > 0) {
        fprintf(stderr, "lensrayd: cancelling %ld running job%s\n", left,
                left == 1 ? "" : "s");
        lrd_jobs_cancel_running(LRD_CANCEL_SHUTDOWN);
    }
    lrd_jobs_stop();
    /* Answers already being written (an image to a slow client, say) get
     * a few more seconds before their connections are closed. */
    double drain = lrd_monotonic() + 5.0;
    while (lrd_http_in_flight() > 0 && lrd_monotonic() < drain)
        wait_signal(&set, 0.02);
    lrd_http_stop();
    lrd_jobs_free_all();
    lrd_scenes_shutdown();
    free(lrd_cfg.token);
    fprintf(stderr, "lensrayd: stopped\n");
    return 0;
}
