/*
 * remote.c: a frame as region parts on lensrayd daemons (remote.h).
 *
 * The frame (or the scene's own render.region) is cut into bands of rows,
 * the parts.  Parts run o->parallel at a time through one libcurl multi
 * handle; each answer, a float32 EXR, is placed straight into the frame
 * (exr_crop.c).  Because every pixel's samples depend only on (pixel,
 * sample, dimension, seed), a part's pixels are those of the whole
 * render (docs/architecture.md, "Rules that keep pixels the same"), so
 * the stitched floats, written by the same encoder, are the local
 * render's file.
 */
#include "remote.h"

#include "assets.h"
#include "exr_crop.h"

#include <curl/curl.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

enum { EXIT_OK = 0, EXIT_SCENE = 3, EXIT_IO = 4, EXIT_INTERRUPTED = 130 };

enum part_state { PART_WAITING, PART_RUNNING, PART_DONE };

typedef struct part {
    int index;
    int region[4];         /* [x0, y0, x1, y1) in the frame */
    enum part_state state;
    int attempts;
    double not_before;     /* a retried part waits until then */
    char *body;            /* the job, JSON */
    unsigned char *answer; /* the answer's body as it arrives */
    size_t len, cap;
    int too_big;           /* the answer outgrew its buffer's limit */
    CURL *easy;
    struct curl_slist *headers;
} part;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A part's image is at most w x h x 4 channels of float plus headers;
 * an answer far beyond that is not an image of this part. */
static size_t answer_limit(const part *p)
{
    size_t w = (size_t)(p->region[2] - p->region[0]);
    size_t h = (size_t)(p->region[3] - p->region[1]);
    return w * h * 16 * 2 + (1 << 20);
}

static size_t on_data(char *data, size_t size, size_t n, void *user)
{
    part *p = user;
    size_t add = size * n;
    if (p->len + add > answer_limit(p)) {
        p->too_big = 1;
        return 0;
    }
    if (p->len + add > p->cap) {
        size_t cap = p->cap ? p->cap : 65536;
        while (cap < p->len + add)
            cap *= 2;
        unsigned char *grown = realloc(p->answer, cap);
        if (grown == NULL)
            return 0;
        p->answer = grown;
        p->cap = cap;
    }
    memcpy(p->answer + p->len, data, add);
    p->len += add;
    return add;
}

/* The job of part p: the scene inline, the camera and the settings as
 * the local render would use them, the part's region, a float EXR.
 * Returns a malloc'ed string, or NULL when out of memory. */
static char *part_body(const char *scene, size_t len, const char *cam_json,
                       const lr_render_settings *rs, const int region[4])
{
    lr_render_settings s = *rs;
    memcpy(s.region, region, sizeof s.region);
    char *rs_json = lr_render_settings_json(&s);
    if (rs_json == NULL)
        return NULL;
    char output[64];
    snprintf(output, sizeof output, "{\"format\": \"exr\", \"depth\": %s}",
             rs->want_depth ? "true" : "false");
    size_t n = len + strlen(cam_json) + strlen(rs_json) + strlen(output) + 64;
    char *body = malloc(n);
    if (body != NULL)
        snprintf(body, n,
                 "{\"scene\": %.*s,\n\"camera\": %s,\n\"render\": %s,\n"
                 "\"output\": %s}",
                 (int)len, scene, cam_json, rs_json, output);
    lr_free(rs_json);
    return body;
}

static int start_part(CURLM *multi, part *p, const remote_options *o,
                      const char *endpoint)
{
    p->len = 0;
    p->too_big = 0;
    p->easy = curl_easy_init();
    if (p->easy == NULL)
        return -1;
    p->headers = curl_slist_append(NULL, "Content-Type: application/json");
    if (o->token != NULL) {
        char auth[1024];
        snprintf(auth, sizeof auth, "Authorization: Bearer %s", o->token);
        p->headers = curl_slist_append(p->headers, auth);
    }
    curl_easy_setopt(p->easy, CURLOPT_URL, endpoint);
    curl_easy_setopt(p->easy, CURLOPT_HTTPHEADER, p->headers);
    curl_easy_setopt(p->easy, CURLOPT_POSTFIELDS, p->body);
    curl_easy_setopt(p->easy, CURLOPT_WRITEFUNCTION, on_data);
    curl_easy_setopt(p->easy, CURLOPT_WRITEDATA, p);
    curl_easy_setopt(p->easy, CURLOPT_PRIVATE, p);
    curl_easy_setopt(p->easy, CURLOPT_CONNECTTIMEOUT, 10L);
    curl_easy_setopt(p->easy, CURLOPT_NOSIGNAL, 1L);
    p->state = PART_RUNNING;
    p->attempts++;
    return curl_multi_add_handle(multi, p->easy) == CURLM_OK ? 0 : -1;
}

static void end_part(CURLM *multi, part *p)
{
    if (p->easy != NULL) {
        curl_multi_remove_handle(multi, p->easy);
        curl_easy_cleanup(p->easy);
        p->easy = NULL;
    }
    curl_slist_free_all(p->headers);
    p->headers = NULL;
}

/* The daemon's error answer is JSON whose "message" names the field and
 * the limit (docs/api.md, section 5): that string when there is one (its
 * escapes left as they are), else the first line of the body (a proxy's
 * page), cut to fit. */
static void answer_text(const part *p, char *out, size_t size)
{
    size_t n = p->len < size - 1 ? p->len : size - 1;
    memcpy(out, p->answer ? (const char *)p->answer : "", n);
    out[n] = '\0';
    static const char key[] = "\"message\":\"";
    char *m = strstr(out, key);
    if (m != NULL) {
        char *s = m + sizeof key - 1, *e = s;
        while (*e != '\0' && !(*e == '"' && e[-1] != '\\'))
            e++;
        *e = '\0';
        memmove(out, s, (size_t)(e - s) + 1);
    }
    char *nl = strchr(out, '\n');
    if (nl != NULL)
        *nl = '\0';
}

int remote_render(const remote_options *o, const char *scene, size_t len,
                  const lr_camera *cam, const lr_render_settings *rs,
                  lr_image **out, remote_stats *stats)
{
    *out = NULL;
    memset(stats, 0, sizeof *stats);
    double t0 = now();
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) {
        fprintf(stderr, "lensray: libcurl cannot start\n");
        return EXIT_IO;
    }
    /* The frame to cut: the scene's own region, or the whole frame. */
    int box[4] = {0, 0, rs->width, rs->height};
    if (rs->region[0] | rs->region[1] | rs->region[2] | rs->region[3])
        memcpy(box, rs->region, sizeof box);
    int rows = box[3] - box[1];
    int n = o->parts < rows ? o->parts : rows;
    lr_error err;
    lr_image *img = NULL;
    if (lr_image_create(box[2] - box[0], rows, rs->want_depth, &img, &err) !=
        LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        return EXIT_IO;
    }
    /* A crop of the frame carries its place, as lr_render's does. */
    if ((box[0] != 0 || box[1] != 0 || box[2] != rs->width ||
         box[3] != rs->height) &&
        lr_image_set_frame(img, rs->width, rs->height, box[0], box[1], cam, rs,
                           &err) != LR_OK) {
        fprintf(stderr, "lensray: %s\n", err.message);
        lr_image_free(img);
        return EXIT_IO;
    }
    char endpoint[2048];
    size_t ul = strlen(o->url);
    snprintf(endpoint, sizeof endpoint, "%.*s/v1/render",
             (int)(ul > 0 && o->url[ul - 1] == '/' ? ul - 1 : ul), o->url);
    char *sent = NULL;
    size_t sent_len = 0;
    assets_stats as;
    int arc = assets_send(o->url, o->token, scene, len, o->scene_dir, &sent,
                          &sent_len, &as);
    stats->assets = as.files;
    stats->uploaded = as.uploaded;
    if (arc != 0) {
        lr_image_free(img);
        curl_global_cleanup();
        return arc;
    }
    scene = sent;
    len = sent_len;
    char *cam_json = lr_camera_json(cam);
    part *parts = calloc((size_t)n, sizeof *parts);
    CURLM *multi = curl_multi_init();
    int rc = EXIT_IO;
    if (cam_json == NULL || parts == NULL || multi == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        goto done;
    }
    for (int i = 0; i < n; i++) {
        part *p = &parts[i];
        p->index = i;
        /* Band i holds rows [rows * i / n, rows * (i + 1) / n). */
        p->region[0] = box[0];
        p->region[2] = box[2];
        p->region[1] = box[1] + (int)((long long)rows * i / n);
        p->region[3] = box[1] + (int)((long long)rows * (i + 1) / n);
        p->body = part_body(scene, len, cam_json, rs, p->region);
        if (p->body == NULL) {
            fprintf(stderr, "lensray: out of memory\n");
            goto done;
        }
    }
    int done = 0, running = 0;
    while (done < n) {
        if (o->cancel != NULL && *o->cancel) {
            rc = EXIT_INTERRUPTED;
            goto done;
        }
        double t = now();
        for (int i = 0; i < n && running < o->parallel; i++) {
            part *p = &parts[i];
            if (p->state != PART_WAITING || p->not_before > t)
                continue;
            if (start_part(multi, p, o, endpoint) != 0) {
                fprintf(stderr, "lensray: out of memory\n");
                goto done;
            }
            running++;
            stats->attempts++;
        }
        int still = 0;
        curl_multi_perform(multi, &still);
        CURLMsg *msg;
        int left;
        while ((msg = curl_multi_info_read(multi, &left)) != NULL) {
            if (msg->msg != CURLMSG_DONE)
                continue;
            part *p = NULL;
            curl_easy_getinfo(msg->easy_handle, CURLINFO_PRIVATE, (char **)&p);
            CURLcode res = msg->data.result;
            long status = 0;
            curl_easy_getinfo(p->easy, CURLINFO_RESPONSE_CODE, &status);
            char why[512];
            int retry = 0;
            if (res != CURLE_OK) {
                snprintf(why, sizeof why, "%s", p->too_big
                             ? "the answer is larger than the part's image"
                             : curl_easy_strerror(res));
                retry = 1;
            } else if (status == 200) {
                int x0 = p->region[0] - box[0], y0 = p->region[1] - box[1];
                if (exr_crop_place(p->answer, p->len, img, x0, y0,
                                   p->region[0], p->region[1],
                                   p->region[2] - p->region[0],
                                   p->region[3] - p->region[1], why,
                                   sizeof why) != 0)
                    retry = 1;
            } else {
                char text[400];
                answer_text(p, text, sizeof text);
                snprintf(why, sizeof why, "HTTP %ld: %s", status, text);
                /* 4xx is the request's fault and would come again; 408
                 * and 429 (queue full) are the daemon's state. */
                retry = status >= 500 || status == 408 || status == 429;
                if (!retry) {
                    fprintf(stderr, "%slensray: part %d/%d refused: %s\n",
                            o->quiet ? "" : "\n", p->index + 1, n, why);
                    rc = status == 401 || status == 403 ? EXIT_IO : EXIT_SCENE;
                    goto done;
                }
            }
            end_part(multi, p);
            running--;
            if (!retry) {
                p->state = PART_DONE;
                done++;
                if (!o->quiet)
                    fprintf(stderr, "lensray: part %d/%d done (rows %d-%d), "
                                    "%d of %d parts\n",
                            p->index + 1, n, p->region[1], p->region[3] - 1,
                            done, n);
                continue;
            }
            if (p->attempts > o->retries) {
                fprintf(stderr, "lensray: part %d/%d failed %d times, the "
                                "last: %s\n",
                        p->index + 1, n, p->attempts, why);
                goto done;
            }
            stats->retries++;
            /* Wait a little longer each time (0.25 s, 0.5 s, ... up to
             * 4 s), so that a daemon that is restarting is not hammered. */
            double wait = 0.25 * (double)(1 << (p->attempts < 5 ? p->attempts - 1 : 4));
            p->not_before = now() + wait;
            p->state = PART_WAITING;
            if (!o->quiet)
                fprintf(stderr, "lensray: part %d/%d failed (%s); sending "
                                "it again (attempt %d of %d)\n",
                        p->index + 1, n, why, p->attempts + 1, o->retries + 1);
        }
        if (done < n)
            curl_multi_poll(multi, NULL, 0, running > 0 ? 100 : 50, NULL);
    }
    rc = EXIT_OK;
    *out = img;
    img = NULL;
done:
    if (parts != NULL)
        for (int i = 0; i < n; i++) {
            end_part(multi, &parts[i]);
            free(parts[i].body);
            free(parts[i].answer);
        }
    free(parts);
    if (multi != NULL)
        curl_multi_cleanup(multi);
    lr_free(cam_json);
    free(sent);
    lr_image_free(img);
    stats->parts = n;
    stats->seconds = now() - t0;
    curl_global_cleanup();
    return rc;
}
