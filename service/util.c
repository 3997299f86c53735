/*
 * util.c: error responses, clocks, job ids and number parsing shared by
 * the daemon's modules.
 */
#include "lensrayd.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

/* A message cut to fit its buffer may end inside a UTF-8 character;
 * drop that partial character so that the JSON error stays valid. */
void lrd_utf8_trim(char *s)
{
    size_t len = strlen(s), i = len;
    /* Back over continuation bytes to the start of the last character. */
    while (i > 0 && ((unsigned char)s[i - 1] & 0xC0) == 0x80 && len - i < 3)
        i--;
    if (i == 0)
        return;
    unsigned c = (unsigned char)s[i - 1];
    size_t need = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC0 ? 2 : 1;
    if (c >= 0x80 && len - (i - 1) < need)
        s[i - 1] = '\0';
}

/* Every byte of s that does not belong to a well-formed UTF-8 sequence
 * (RFC 3629: no overlong forms, surrogates or code points past U+10FFFF)
 * becomes '?': an error that echoed a request's bytes (a query's %ff)
 * made JSON that no UTF-8 decoder reads. */
static void utf8_clean(char *str)
{
    unsigned char *s = (unsigned char *)str;
    for (size_t i = 0; s[i] != '\0';) {
        unsigned c = s[i];
        size_t n = c < 0x80                 ? 1
                   : c >= 0xC2 && c <= 0xDF ? 2
                   : c >= 0xE0 && c <= 0xEF ? 3
                   : c >= 0xF0 && c <= 0xF4 ? 4
                                            : 0;
        int ok = n > 0;
        for (size_t k = 1; ok && k < n; k++)
            ok = (s[i + k] & 0xC0) == 0x80;
        /* The second byte's range where the first allows less (RFC 3629
         * section 4). */
        if (ok && n >= 3) {
            unsigned d = s[i + 1];
            ok = !(c == 0xE0 && d < 0xA0) && !(c == 0xED && d > 0x9F) &&
                 !(c == 0xF0 && d < 0x90) && !(c == 0xF4 && d > 0x8F);
        }
        if (!ok) {
            s[i++] = '?';
            continue;
        }
        i += n;
    }
}

int lrd_fail(lrd_err *e, int http, const char *code, const char *path,
             const char *fmt, ...)
{
    if (e == NULL)
        return -1;
    e->http = http;
    e->retry_after = 0;
    snprintf(e->code, sizeof e->code, "%s", code);
    snprintf(e->path, sizeof e->path, "%s", path ? path : "");
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(e->message, sizeof e->message, fmt, ap);
    va_end(ap);
    lrd_utf8_trim(e->path);
    lrd_utf8_trim(e->message);
    utf8_clean(e->path);
    utf8_clean(e->message);
    return -1;
}

int lrd_fail_lr(lrd_err *e, const lr_error *le, const char *prefix,
                const char *named_scene)
{
    char path[sizeof e->path];
    char msg[sizeof e->message];
    /* The library's message starts with its path ("objects[2].radius must
     * be > 0"); with a prefix the message names the full request path. */
    if (prefix != NULL && le->path[0] != '\0') {
        snprintf(path, sizeof path, "%s.%s", prefix, le->path);
        if (strncmp(le->message, le->path, strlen(le->path)) == 0)
            snprintf(msg, sizeof msg, "%s.%s", prefix, le->message);
        else
            snprintf(msg, sizeof msg, "%s: %s", prefix, le->message);
    } else if (prefix != NULL) {
        /* A message the library already heads with the prefix (the
         * loader's "scene: invalid JSON at ...") is not headed twice. */
        size_t pl = strlen(prefix);
        snprintf(path, sizeof path, "%s", prefix);
        if (strncmp(le->message, prefix, pl) == 0 && le->message[pl] == ':')
            snprintf(msg, sizeof msg, "%s", le->message);
        else
            snprintf(msg, sizeof msg, "%s: %s", prefix, le->message);
    } else {
        snprintf(path, sizeof path, "%s", le->path);
        snprintf(msg, sizeof msg, "%s", le->message);
    }
    switch (le->status) {
    case LR_ERR_INVALID:
        if (named_scene != NULL)
            return lrd_fail(e, 500, "scene_broken", path,
                            "the server's scene file %s is invalid: %s",
                            named_scene, msg);
        return lrd_fail(e, 422, "invalid_value", path, "%s", msg);
    case LR_ERR_IO:
        if (named_scene != NULL)
            return lrd_fail(e, 500, "scene_broken", path,
                            "the server's scene file %s cannot be read: %s",
                            named_scene, msg);
        return lrd_fail(e, 422, "invalid_value", path, "%s", msg);
    case LR_ERR_LIMIT: {
        /* The scene limits are the daemon's flags (lr_scene_limits_set in
         * main.c): the message names the flag rather than the call. */
        static const char lib[] = "the limit set by lr_scene_limits_set";
        char *at = strstr(msg, lib);
        if (at == NULL)
            return lrd_fail(e, 413, "too_large", path, "%s", msg);
        int texels = strstr(msg, " texels, the limit set by") != NULL;
        *at = '\0';
        return lrd_fail(e, 413, "scene_too_large", path,
                        "%sthe daemon's limit (--max-scene-%s)%s", msg,
                        texels ? "texels" : "triangles", at + sizeof lib - 1);
    }
    case LR_ERR_NOMEM:
        return lrd_fail(e, 503, "out_of_memory", path, "%s", msg);
    case LR_ERR_CANCELLED:
        return lrd_fail(e, 409, "cancelled", path, "%s", msg);
    case LR_ERR_EMBREE:
    case LR_OK:
    default:
        return lrd_fail(e, 500, "internal", path, "%s", msg);
    }
}

char *lrd_err_json(const lrd_err *e)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *inner = cJSON_AddObjectToObject(root, "error");
    if (inner == NULL) {
        cJSON_Delete(root);
        return NULL;
    }
    cJSON_AddStringToObject(inner, "code", e->code);
    cJSON_AddStringToObject(inner, "message", e->message);
    if (e->path[0] != '\0')
        cJSON_AddStringToObject(inner, "path", e->path);
    char *text = lrd_json_print(root);
    cJSON_Delete(root);
    return text;
}

double lrd_monotonic(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double lrd_wall(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void lrd_iso8601(double wall, char out[32])
{
    time_t secs = (time_t)floor(wall);
    int ms = (int)((wall - floor(wall)) * 1000.0);
    if (ms > 999)
        ms = 999;
    struct tm tm;
    gmtime_r(&secs, &tm);
    char base[24];
    strftime(base, sizeof base, "%Y-%m-%dT%H:%M:%S", &tm);
    snprintf(out, 32, "%s.%03dZ", base, ms);
}

int lrd_random_id(char out[33])
{
    unsigned char bytes[16];
    size_t got = 0;
    while (got < sizeof bytes) {
        ssize_t n = getrandom(bytes + got, sizeof bytes - got, 0);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        got += (size_t)n;
    }
    static const char hex[] = "0123456789abcdef";
    for (size_t i = 0; i < sizeof bytes; i++) {
        out[2 * i] = hex[bytes[i] >> 4];
        out[2 * i + 1] = hex[bytes[i] & 15];
    }
    out[32] = '\0';
    return 0;
}

int lrd_is_job_id(const char *s)
{
    size_t i = 0;
    for (; s[i] != '\0'; i++)
        if (!((s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f')))
            return 0;
    return i == 32;
}

int lrd_parse_u64(const char *s, int sizes, uint64_t *out)
{
    if (s == NULL || s[0] < '0' || s[0] > '9')
        return -1; /* strtoull would accept "-1" and " 1" */
    errno = 0;
    char *end = NULL;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno != 0 || end == s)
        return -1;
    unsigned shift = 0;
    if (sizes && *end != '\0') {
        switch (*end) {
        case 'k':
        case 'K':
            shift = 10;
            break;
        case 'm':
        case 'M':
            shift = 20;
            break;
        case 'g':
        case 'G':
            shift = 30;
            break;
        default:
            return -1;
        }
        end++;
        /* Allow "8M", "8MiB" and "8MB" alike: all binary. */
        if (strcmp(end, "iB") == 0 || strcmp(end, "B") == 0)
            end += strlen(end);
    }
    if (*end != '\0')
        return -1;
    if (shift > 0 && v > (UINT64_MAX >> shift))
        return -1;
    *out = (uint64_t)v << shift;
    return 0;
}

int lrd_parse_seconds(const char *s, double *out)
{
    if (s == NULL || !((s[0] >= '0' && s[0] <= '9') || s[0] == '.'))
        return -1;
    errno = 0;
    char *end = NULL;
    double v = strtod(s, &end);
    if (errno != 0 || end == s || *end != '\0' || !isfinite(v) || v < 0)
        return -1;
    *out = v;
    return 0;
}

char *lrd_json_print(const cJSON *v)
{
    return cJSON_PrintUnformatted(v);
}

char *lrd_read_file(const char *path, size_t max, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return NULL;
    char *buf = NULL;
    size_t used = 0, cap = 0;
    for (;;) {
        if (used == cap) {
            if (cap >= max) {
                free(buf);
                fclose(f);
                errno = EFBIG;
                return NULL;
            }
            cap = cap ? 2 * cap : 16384;
            char *grown = realloc(buf, cap + 1);
            if (grown == NULL) {
                free(buf);
                fclose(f);
                errno = ENOMEM;
                return NULL;
            }
            buf = grown;
        }
        size_t got = fread(buf + used, 1, cap - used, f);
        used += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        errno = EIO;
        return NULL;
    }
    buf[used] = '\0';
    *len = used;
    return buf;
}

/* The defaults of every setting, before flags and environment (shared
 * by main.c and the job fuzzer, so they cannot drift apart). */
void lrd_config_defaults(void)
{
    snprintf(lrd_cfg.bind, sizeof lrd_cfg.bind, "127.0.0.1");
    lrd_cfg.port = 8080;
    lrd_cfg.workers = 1;
    lrd_cfg.queue = 16;
    lrd_cfg.max_body = 8u << 20;
    lrd_cfg.max_asset = 64u << 20;
    lrd_cfg.max_pixels = 16777216; /* 16.8 MP: 4096 x 4096 */
    lrd_cfg.max_samples = 1ull << 33;
    lrd_cfg.max_render_seconds = 600;
    lrd_cfg.max_output = 512u << 20;
    lrd_cfg.max_json_depth = 64;
    lrd_cfg.max_connections = 64;
    /* Half of --max-connections: a client's closed connections count
     * until the server has reaped them, so one that reconnects at once
     * holds about twice what it has open (12 reconnecting threads lost
     * 5 to 30 of 120 requests at 16, none at 32). */
    lrd_cfg.max_per_ip = 32;
    lrd_cfg.conn_memory = 64u << 10;
    lrd_cfg.conn_timeout = 30;
    lrd_cfg.job_ttl = 600;
    /* About 100 bytes a triangle once built (Embree's copies and BVH,
     * normals, uvs): 16M is about 1.6 GB; 2^27 texels of float RGBA are
     * 2 GiB. */
    lrd_cfg.max_scene_triangles = 16000000;
    lrd_cfg.max_scene_texels = 1ull << 27;
    lrd_cfg.max_finished = 100;
    lrd_cfg.max_retained = 1ull << 30;
    lrd_cfg.scene_cache = 16;
    lrd_cfg.shutdown_grace = 10;
    lrd_cfg.no_ui = 0;
}
