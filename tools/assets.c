/*
 * assets.c: a scene's files sent once as content-addressed assets
 * (assets.h).  The scene is read with cJSON, whose printer writes each
 * number so that it reads back to the same double (%1.15g, or %1.17g when
 * that does not), so the rewritten scene renders the same pixels.
 */
#include "assets.h"
#include "remote.h"

#include "lensray.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <openssl/evp.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

enum { EXIT_SCENE = 3, EXIT_IO = 4 };

unsigned char *read_whole_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return NULL;
    unsigned char *buf = NULL;
    size_t cap = 0;
    *len = 0;
    for (;;) {
        if (*len == cap) {
            cap = cap ? 2 * cap : 65536;
            unsigned char *grown = realloc(buf, cap);
            if (grown == NULL) {
                free(buf);
                fclose(f);
                errno = ENOMEM;
                return NULL;
            }
            buf = grown;
        }
        size_t got = fread(buf + *len, 1, cap - *len, f);
        *len += got;
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
    return buf;
}

static void sha256_hex(const void *data, size_t len, char out[65])
{
    static const char hex[] = "0123456789abcdef";
    unsigned char sum[32];
    unsigned int n = 0;
    if (EVP_Digest(data, len, sum, &n, EVP_sha256(), NULL) != 1)
        memset(sum, 0, sizeof sum);
    for (int i = 0; i < 32; i++) {
        out[2 * i] = hex[sum[i] >> 4];
        out[2 * i + 1] = hex[sum[i] & 15];
    }
    out[64] = '\0';
}

typedef struct answer {
    char text[512]; /* the start of the body, for messages */
    size_t len;
} answer;

static size_t keep_start(char *data, size_t size, size_t n, void *user)
{
    answer *a = user;
    size_t add = size * n, room = sizeof a->text - 1 - a->len;
    memcpy(a->text + a->len, data, add < room ? add : room);
    a->len += add < room ? add : room;
    a->text[a->len] = '\0';
    return add;
}

/* One request about asset `hex`: HEAD (data NULL) or PUT.  Returns the
 * HTTP status, or -1 with the transport's reason in a->text. */
static long request(const char *url, const char *token, const char *hex,
                    const unsigned char *data, size_t len, answer *a)
{
    char endpoint[2200], auth[1024];
    size_t ul = strlen(url);
    snprintf(endpoint, sizeof endpoint, "%.*s/v1/assets/%s",
             (int)(ul > 0 && url[ul - 1] == '/' ? ul - 1 : ul), url, hex);
    CURL *h = curl_easy_init();
    if (h == NULL) {
        snprintf(a->text, sizeof a->text, "out of memory");
        return -1;
    }
    struct curl_slist *hdrs = curl_slist_append(
        NULL, "Content-Type: application/octet-stream");
    if (token != NULL) {
        snprintf(auth, sizeof auth, "Authorization: Bearer %s", token);
        hdrs = curl_slist_append(hdrs, auth);
    }
    a->len = 0;
    a->text[0] = '\0';
    curl_easy_setopt(h, CURLOPT_URL, endpoint);
    curl_easy_setopt(h, CURLOPT_HTTPHEADER, hdrs);
    curl_easy_setopt(h, CURLOPT_WRITEFUNCTION, keep_start);
    curl_easy_setopt(h, CURLOPT_WRITEDATA, a);
    curl_easy_setopt(h, CURLOPT_CONNECTTIMEOUT, 10L);
    curl_easy_setopt(h, CURLOPT_NOSIGNAL, 1L);
    if (data == NULL) {
        curl_easy_setopt(h, CURLOPT_NOBODY, 1L);
    } else {
        curl_easy_setopt(h, CURLOPT_CUSTOMREQUEST, "PUT");
        curl_easy_setopt(h, CURLOPT_POSTFIELDS, (const char *)data);
        curl_easy_setopt(h, CURLOPT_POSTFIELDSIZE_LARGE, (curl_off_t)len);
    }
    CURLcode res = curl_easy_perform(h);
    long status = -1;
    if (res == CURLE_OK)
        curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &status);
    else
        snprintf(a->text, sizeof a->text, "%s", curl_easy_strerror(res));
    curl_slist_free_all(hdrs);
    curl_easy_cleanup(h);
    return status;
}

/* A file the session has met: its path as read, its hash, and whether
 * the daemons have it now (then it is never asked about again). */
typedef struct known {
    char *path;
    char hex[65];
} known;

struct assets_session {
    const char *url, *token;
    int retries; /* further attempts of a request that failed for a
                    reason that can pass, as --retries gives parts */
    int store;   /* 0 once the daemons said they keep no assets */
    known *files;
    int n, cap, uploaded;
};

assets_session *assets_open(const char *url, const char *token, int retries)
{
    assets_session *s = calloc(1, sizeof *s);
    if (s != NULL) {
        s->url = url;
        s->token = token;
        s->retries = retries > 0 ? retries : 0;
        s->store = 1;
    }
    return s;
}

/* request() again, up to the session's retries, where the failure can
 * pass (no connection, 5xx, 408, 429: a daemon restarting, a balancer
 * with no live daemon for a moment), after 0.25 s, 0.5 s, ... 4 s as a
 * part waits (remote.c).  The parts survived such an outage and the
 * asset checks, one attempt each, failed the frame at once. */
static long request_retried(const assets_session *s, const char *hex,
                            const unsigned char *data, size_t len, answer *a)
{
    for (int attempt = 0;; attempt++) {
        long status = request(s->url, s->token, hex, data, len, a);
        if (!(status < 0 || remote_status_passes(status)) ||
            attempt >= s->retries)
            return status;
        double wait = remote_backoff(attempt + 1);
        char why[600];
        if (status < 0)
            snprintf(why, sizeof why, "%s", a->text);
        else
            snprintf(why, sizeof why, "HTTP %ld %s", status,
                     a->text[0] ? a->text : "(no answer text)");
        fprintf(stderr,
                "lensray: asset sha256:%.12s...: %s; trying again in %g s "
                "(attempt %d of %d)\n",
                hex, why, wait, attempt + 2, s->retries + 1);
        struct timespec ts = {(time_t)wait,
                              (long)((wait - (double)(time_t)wait) * 1e9)};
        nanosleep(&ts, NULL);
    }
}

void assets_close(assets_session *s)
{
    if (s == NULL)
        return;
    for (int i = 0; i < s->n; i++)
        free(s->files[i].path);
    free(s->files);
    free(s);
}

void assets_counts(const assets_session *s, int *files, int *uploaded)
{
    *files = s->n;
    *uploaded = s->uploaded;
}

const char *assets_file_of(const assets_session *s, const char *hex)
{
    for (int i = 0; s != NULL && i < s->n; i++)
        if (strncmp(s->files[i].hex, hex, 64) == 0)
            return s->files[i].path;
    return NULL;
}

void assets_name_files(const assets_session *s, const char *text, char *out,
                       size_t cap)
{
    size_t k = 0;
    if (cap == 0)
        return;
    for (const char *p = text; *p != '\0' && k + 1 < cap; p++) {
        out[k++] = *p;
        const char *file = NULL;
        if (p[0] == ':' && p - text >= 6 && strncmp(p - 6, "sha256", 6) == 0 &&
            strspn(p + 1, "0123456789abcdef") >= 64)
            file = assets_file_of(s, p + 1);
        if (file == NULL)
            continue;
        /* The hash, then the file. */
        for (int i = 1; i <= 64 && k + 1 < cap; i++)
            out[k++] = p[i];
        p += 64;
        int n = snprintf(out + k, cap - k, " (%s)", file);
        k = n < 0 ? k : k + (size_t)n < cap ? k + (size_t)n : cap - 1;
    }
    out[k] = '\0';
}

/* Makes sure the daemons have the file at `path` (named at `field` of
 * `what`) and gives its hash in hex[65].  0; 1 when the daemons keep no
 * assets (the session remembers it); or an exit status, printed. */
static int ensure(assets_session *s, const char *path, const char *what,
                  const char *field, char hex[65])
{
    for (int i = 0; i < s->n; i++)
        if (strcmp(s->files[i].path, path) == 0) {
            memcpy(hex, s->files[i].hex, 65);
            return 0;
        }
    size_t flen = 0;
    unsigned char *data = read_whole_file(path, &flen);
    if (data == NULL) {
        fprintf(stderr, "lensray: %s: %s: %s: %s\n", what, field, path,
                strerror(errno));
        return EXIT_SCENE;
    }
    sha256_hex(data, flen, hex);
    answer a;
    int rc = EXIT_IO;
    long status = request_retried(s, hex, NULL, 0, &a);
    /* A HEAD answer has no body, so a daemon without an asset store
     * is told apart by the PUT's answer (404 no_asset_store). */
    if (status == 404) {
        status = request_retried(s, hex, data, flen, &a);
        if (status == 404 && strstr(a.text, "no_asset_store") != NULL) {
            s->store = 0;
            rc = 1;
            goto out;
        }
        if (status != 201 && status != 200) {
            fprintf(stderr,
                    "lensray: %s: %s: sending %s as asset sha256:%s "
                    "failed: %s%s\n",
                    what, field, path, hex, status < 0 ? "" : "HTTP ",
                    status < 0  ? a.text
                    : a.text[0] ? a.text
                                : "?");
            goto out;
        }
        s->uploaded++;
    } else if (status != 200) {
        /* A HEAD answer has no text: say what a 401 or 403 means (it
         * read "failed:  (HTTP 401)").  A daemon without a token answers
         * 403 to a Host it does not know (lensrayd --allow-host). */
        const char *why = a.text[0]       ? a.text
                          : status == 401 ? "the daemon wants a valid bearer "
                                            "token (--token-file)"
                          : status == 403
                              ? "the daemon refuses it (a token it wants, "
                                "--token-file, or, without one, a host name "
                                "it does not answer to: lensrayd "
                                "--allow-host)"
                              : "no answer text";
        if (status < 0)
            fprintf(stderr,
                    "lensray: %s: %s: asking %s for asset sha256:%s (%s) "
                    "failed: %s\n",
                    what, field, s->url, hex, path, why);
        else
            fprintf(stderr,
                    "lensray: %s: %s: asking %s for asset sha256:%s (%s) "
                    "failed: %s (HTTP %ld)\n",
                    what, field, s->url, hex, path, why, status);
        goto out;
    }
    if (s->n == s->cap) {
        int cap = s->cap ? 2 * s->cap : 8;
        known *grown = realloc(s->files, (size_t)cap * sizeof *grown);
        if (grown == NULL)
            goto oom;
        s->files = grown;
        s->cap = cap;
    }
    s->files[s->n].path = strdup(path);
    if (s->files[s->n].path == NULL)
        goto oom;
    memcpy(s->files[s->n].hex, hex, 65);
    s->n++;
    rc = 0;
    goto out;
oom:
    fprintf(stderr, "lensray: out of memory\n");
out:
    free(data);
    return rc;
}

/* `ref` relative to dir (or absolute), in out. */
static void joined(const char *dir, const char *ref, char *out, size_t size)
{
    if (ref[0] == '/')
        snprintf(out, size, "%s", ref);
    else
        snprintf(out, size, "%s/%s", dir, ref);
}

static int is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* Sends the file `node` names and makes it "sha256:HEX"; 0, 1 (no asset
 * store) or an exit status. */
static int send_ref(assets_session *s, cJSON *node, const char *dir,
                    const char *what, const char *field)
{
    char path[4096], hex[65], ref[80];
    joined(dir, node->valuestring, path, sizeof path);
    int rc = ensure(s, path, what, field, hex);
    if (rc != 0)
        return rc;
    snprintf(ref, sizeof ref, "sha256:%s", hex);
    if (cJSON_SetValuestring(node, ref) == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        return EXIT_IO;
    }
    return 0;
}

/* A lens that is a file beside the scene (not a shipped lens's name nor
 * an inline prescription) is sent like any file. */
static int send_lens(assets_session *s, cJSON *camera, const char *dir,
                     const char *what, const char *field)
{
    cJSON *lens = cJSON_GetObjectItemCaseSensitive(camera, "lens");
    char path[4096];
    if (!cJSON_IsString(lens) || strncmp(lens->valuestring, "sha256:", 7) == 0)
        return 0;
    joined(dir, lens->valuestring, path, sizeof path);
    return is_file(path) ? send_ref(s, lens, dir, what, field) : 0;
}

/* Every string under a file key, wherever it stands in the scene (the
 * library's rule, lr_scene_file_key), with its JSON path for messages. */
static int send_files(assets_session *s, cJSON *node, const char *path,
                      const char *dir, const char *what)
{
    int i = 0;
    for (cJSON *c = node->child; c != NULL && s->store; c = c->next, i++) {
        char p[512];
        if (cJSON_IsArray(node))
            snprintf(p, sizeof p, "%s[%d]", path, i);
        else
            snprintf(p, sizeof p, "%s%s%s", path, path[0] ? "." : "",
                     c->string);
        int rc = 0;
        if (cJSON_IsString(c) && c->string != NULL &&
            lr_scene_file_key(c->string) && c->valuestring[0] != '\0' &&
            strncmp(c->valuestring, "sha256:", 7) != 0)
            rc = send_ref(s, c, dir, what, p);
        else if (cJSON_IsObject(c) || cJSON_IsArray(c))
            rc = send_files(s, c, p, dir, what);
        if (rc != 0)
            return rc;
    }
    return 0;
}

static char *copy_text(const char *text, size_t len)
{
    char *out = malloc(len + 1);
    if (out != NULL) {
        memcpy(out, text, len);
        out[len] = '\0';
    }
    return out;
}

int assets_prepare(assets_session *s, const char *scene, size_t len,
                   const char *cam_json, const char *dir, const char *what,
                   char **scene_out, size_t *scene_out_len, char **cam_out)
{
    *scene_out = NULL;
    *cam_out = NULL;
    cJSON *root = cJSON_ParseWithLength(scene, len);
    cJSON *cam = cJSON_Parse(cam_json);
    int rc = EXIT_IO;
    if (root == NULL) {
        fprintf(stderr, "lensray: %s: the scene is not JSON\n", what);
        rc = EXIT_SCENE;
        goto done;
    }
    if (cam == NULL)
        goto oom;
    rc = 0;
    if (s->store)
        rc = send_files(s, root, "", dir, what);
    if (rc == 0 && s->store)
        rc = send_lens(s, cJSON_GetObjectItemCaseSensitive(root, "camera"), dir,
                       what, "camera.lens");
    if (rc == 0 && s->store)
        rc = send_lens(s, cam, dir, what, "camera.lens");
    if (rc > 1)
        goto done;
    if (!s->store) {
        /* The daemons read the files from their scenes directory. */
        *scene_out = copy_text(scene, len);
        *cam_out = copy_text(cam_json, strlen(cam_json));
        *scene_out_len = len;
    } else {
        *scene_out = cJSON_PrintUnformatted(root);
        *cam_out = cJSON_PrintUnformatted(cam);
        *scene_out_len = *scene_out ? strlen(*scene_out) : 0;
    }
    rc = 0;
    if (*scene_out != NULL && *cam_out != NULL)
        goto done;
oom:
    fprintf(stderr, "lensray: out of memory\n");
    rc = EXIT_IO;
    free(*scene_out);
    free(*cam_out);
    *scene_out = *cam_out = NULL;
done:
    cJSON_Delete(root);
    cJSON_Delete(cam);
    return rc;
}
