/*
 * assets.c: a scene's mesh files sent once as content-addressed assets
 * (assets.h).  The scene is read with cJSON, whose printer writes each
 * number so that it reads back to the same double (%1.15g, or %1.17g when
 * that does not), so the rewritten scene renders the same pixels.
 */
#include "assets.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <openssl/evp.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

int assets_send(const char *url, const char *token, const char *scene,
                size_t len, const char *dir, char **out, size_t *out_len,
                assets_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    *out = NULL;
    cJSON *root = cJSON_ParseWithLength(scene, len);
    if (root == NULL) {
        fprintf(stderr, "lensray: the scene is not JSON\n");
        return EXIT_SCENE;
    }
    int rc = EXIT_IO, store = 1;
    const cJSON *objects = cJSON_GetObjectItemCaseSensitive(root, "objects");
    int n = cJSON_IsArray(objects) ? cJSON_GetArraySize(objects) : 0;
    for (int i = 0; i < n && store; i++) {
        cJSON *file = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetArrayItem(objects, i), "file");
        if (!cJSON_IsString(file) || strncmp(file->valuestring, "sha256:", 7) == 0)
            continue;
        stats->files++;
        char path[4096];
        if (file->valuestring[0] == '/')
            snprintf(path, sizeof path, "%s", file->valuestring);
        else
            snprintf(path, sizeof path, "%s/%s", dir, file->valuestring);
        size_t flen = 0;
        unsigned char *data = read_whole_file(path, &flen);
        if (data == NULL) {
            fprintf(stderr, "lensray: objects[%d].file: %s: %s\n", i, path,
                    strerror(errno));
            rc = EXIT_SCENE;
            goto done;
        }
        char hex[65];
        sha256_hex(data, flen, hex);
        answer a;
        long status = request(url, token, hex, NULL, 0, &a);
        /* A HEAD answer has no body, so a daemon without an asset store
         * is told apart by the PUT's answer (404 no_asset_store). */
        if (status == 404) {
            status = request(url, token, hex, data, flen, &a);
            if (status == 404 && strstr(a.text, "no_asset_store") != NULL) {
                store = 0;
            } else if (status == 201 || status == 200) {
                stats->uploaded++;
            } else {
                fprintf(stderr, "lensray: objects[%d].file: sending %s as "
                                "asset sha256:%s failed: %s%s\n",
                        i, path, hex, status < 0 ? "" : "HTTP ",
                        status < 0 ? a.text : a.text[0] ? a.text : "?");
                free(data);
                goto done;
            }
        } else if (status != 200) {
            fprintf(stderr, "lensray: asking %s for asset sha256:%s failed: "
                            "%s (HTTP %ld)\n", url, hex, a.text, status);
            free(data);
            goto done;
        }
        free(data);
        if (store) {
            char ref[80];
            snprintf(ref, sizeof ref, "sha256:%s", hex);
            if (cJSON_SetValuestring(file, ref) == NULL) {
                fprintf(stderr, "lensray: out of memory\n");
                goto done;
            }
        }
    }
    if (!store || stats->files == 0) {
        *out = malloc(len + 1);
        if (*out == NULL) {
            fprintf(stderr, "lensray: out of memory\n");
            goto done;
        }
        memcpy(*out, scene, len);
        (*out)[len] = '\0';
        *out_len = len;
    } else {
        *out = cJSON_PrintUnformatted(root);
        if (*out == NULL) {
            fprintf(stderr, "lensray: out of memory\n");
            goto done;
        }
        *out_len = strlen(*out);
    }
    rc = 0;
done:
    cJSON_Delete(root);
    return rc;
}
