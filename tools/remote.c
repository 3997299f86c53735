/*
 * remote.c: frames as region parts on lensrayd daemons (remote.h).
 *
 * Each frame (or the scene's own render.region) is cut into bands of
 * rows, the parts.  The parts of all frames form one queue, sent in frame
 * order o->parallel at a time through one libcurl multi handle, so the
 * daemons never wait for a frame's last part before the next frame
 * starts; a frame's image exists from its first part to its last.  A
 * frame is read (its scene loaded, its files hashed and uploaded) only
 * when the queue runs short of parts to send, so the first part of a
 * long batch leaves after one frame's reading, not all of them.  Each
 * answer, a float32 EXR, is placed straight into its frame (exr_crop.c).  Because every pixel's samples depend only on (pixel,
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

/* The longest wait for a part that a daemon's Retry-After can ask, in
 * seconds (the daemon's own bound is an hour). */
#define REMOTE_MAX_WAIT 300.0
/* How many times a part is sent again to daemons whose queues are full
 * (429) before it fails: those answers do not count as --retries'
 * attempts (a healthy but busy daemon is not a failure), but a farm full
 * for this long (at least 200 waits of 0.25 to 4 s, more where the
 * daemons' Retry-After asks) is not coming back. */
#define REMOTE_MAX_BUSY 200

enum part_state { PART_WAITING, PART_RUNNING, PART_DONE };

typedef struct part {
    int frame;     /* index into the frames */
    int index;     /* within its frame */
    int region[4]; /* [x0, y0, x1, y1) in the frame */
    enum part_state state;
    int attempts;
    int busy;              /* 429 answers so far (REMOTE_MAX_BUSY) */
    double not_before;     /* a retried part waits until then */
    char *body;            /* the job, JSON, while the part runs */
    unsigned char *answer; /* the answer's body as it arrives */
    size_t len, cap;
    int too_big; /* the answer outgrew its buffer's limit */
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
 * the local render would use them, the part's region, a float EXR without
 * compression.  A daemon's worker encodes a part before it takes the next
 * one, so ZIP's 5 ms for a 640 x 30 part left a core idle each time; the
 * raw floats (3.6x the bytes of ZIP on the bench scene, 4.9 MB for a
 * 640 x 480 frame with Z) cost less to send on a local network than to
 * compress (bench/README.md, the farm).
 * Returns a malloc'ed string, or NULL when out of memory. */
static char *part_body(const char *scene, size_t len, const char *cam_json,
                       const lr_render_settings *rs, const int region[4])
{
    lr_render_settings s = *rs;
    memcpy(s.region, region, sizeof s.region);
    char *rs_json = lr_render_settings_json(&s);
    if (rs_json == NULL)
        return NULL;
    char output[96];
    snprintf(output, sizeof output,
             "{\"format\": \"exr\", \"compression\": \"none\", "
             "\"depth\": %s}",
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
    /* A daemon that stops answering (frozen, its machine gone without a
     * reset) held the part for ever; a render sends nothing until it is
     * done, so the bound is a render's longest (--timeout). */
    curl_easy_setopt(p->easy, CURLOPT_LOW_SPEED_LIMIT, 1L);
    curl_easy_setopt(p->easy, CURLOPT_LOW_SPEED_TIME, (long)o->timeout);
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
    free(p->body);
    p->body = NULL;
}

/* A part that is over (placed, or its frame failed) gives its answer
 * back: the part's floats, 16 bytes a pixel, kept to the end of a long
 * batch of large frames would hold every frame's pixels a second time. */
static void drop_answer(part *p)
{
    free(p->answer);
    p->answer = NULL;
    p->len = p->cap = 0;
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

/* A frame of the batch as it is sent and stitched. */
typedef struct frame {
    char *scene; /* the text sent: files named by their hashes */
    size_t len;
    char *cam_json;  /* the camera sent */
    int box[4];      /* the frame's region: [x0, y0, x1, y1) */
    remote_frame in; /* as the caller's load filled it */
    part *parts;     /* its n_parts parts, from its reading on */
    int n_parts;
    int done_parts;
    int status;    /* nonzero once it failed: its exit status */
    lr_image *img; /* from its first part on, until handed over */
} frame;

typedef struct batch {
    const remote_options *o;
    int n;
    frame *frames;
    int read;    /* frames[0 .. read) have been read */
    int n_parts; /* parts of the frames read */
    remote_load load;
    void *user;
    assets_session *as;
    CURLM *multi;
    int running, left; /* parts in flight; parts read, not finished */
    int waiting;       /* parts read and not yet sent */
    int status;        /* the first failed frame's exit status */
    char endpoint[2048];
} batch;

/* "part 3/16" for one frame, "frame 2/5 part 3/16" in a batch. */
static void label(const batch *b, const part *p, char *out, size_t size)
{
    const frame *f = &b->frames[p->frame];
    if (b->n == 1)
        snprintf(out, size, "part %d/%d", p->index + 1, f->n_parts);
    else
        snprintf(out, size, "frame %d/%d part %d/%d", p->frame + 1, b->n,
                 p->index + 1, f->n_parts);
}

/* The frame fails with `status`: its running parts are stopped, its
 * waiting ones dropped, its image freed; the other frames go on. */
static void fail_frame(batch *b, int fi, int status)
{
    frame *f = &b->frames[fi];
    if (f->status != 0)
        return;
    f->status = status;
    if (b->status == 0)
        b->status = status;
    for (int i = 0; i < f->n_parts; i++) {
        part *p = &f->parts[i];
        if (p->state == PART_RUNNING) {
            end_part(b->multi, p);
            b->running--;
        }
        if (p->state == PART_WAITING)
            b->waiting--;
        if (p->state != PART_DONE)
            b->left--;
        p->state = PART_DONE;
        drop_answer(p);
    }
    lr_image_free(f->img);
    f->img = NULL;
    if (b->n > 1)
        fprintf(stderr,
                "lensray: frame %d/%d (%s) failed; the other frames "
                "go on\n",
                fi + 1, b->n,
                f->in.scene_path != NULL ? f->in.scene_path : "?");
}

/* The frame's image, made when its first part starts: the frame's
 * region, carrying its place when it is a crop, as lr_render's does.
 * 0, or -1 with the reason printed. */
static int frame_image(batch *b, int fi)
{
    frame *f = &b->frames[fi];
    const lr_render_settings *rs = &f->in.rs;
    lr_error err;
    if (f->img != NULL)
        return 0;
    if (lr_image_create(f->box[2] - f->box[0], f->box[3] - f->box[1],
                        rs->want_depth, &f->img, &err) != LR_OK ||
        ((f->box[0] != 0 || f->box[1] != 0 || f->box[2] != rs->width ||
          f->box[3] != rs->height) &&
         lr_image_set_frame(f->img, rs->width, rs->height, f->box[0], f->box[1],
                            &f->in.cam, rs, &err) != LR_OK)) {
        fprintf(stderr, "lensray: %s\n", err.message);
        return -1;
    }
    return 0;
}

/* Starts the waiting parts whose time has come, in order, up to
 * o->parallel in flight.  0, or -1 (out of memory, printed). */
static int start_parts(batch *b, remote_stats *stats)
{
    double t = now();
    for (int fi = 0; fi < b->read && b->running < b->o->parallel; fi++) {
        frame *f = &b->frames[fi];
        for (int i = 0; i < f->n_parts && b->running < b->o->parallel; i++) {
            part *p = &f->parts[i];
            if (p->state != PART_WAITING || p->not_before > t)
                continue;
            if (frame_image(b, fi) != 0) {
                fail_frame(b, fi, EXIT_IO);
                break;
            }
            p->body = part_body(f->scene, f->len, f->cam_json, &f->in.rs,
                                p->region);
            if (p->body == NULL ||
                start_part(b->multi, p, b->o, b->endpoint) != 0) {
                fprintf(stderr, "lensray: out of memory\n");
                return -1;
            }
            b->running++;
            b->waiting--;
            stats->attempts++;
        }
    }
    return 0;
}

/* One part's answer: placed, or sent again, or its frame failed. */
static void finish_part(batch *b, part *p, CURLcode res, remote_done done,
                        void *user, remote_stats *stats)
{
    const remote_options *o = b->o;
    frame *f = &b->frames[p->frame];
    long status = 0;
    curl_easy_getinfo(p->easy, CURLINFO_RESPONSE_CODE, &status);
    /* A daemon whose queue is full (429) or that is going down (503)
     * says in Retry-After when to come back (docs/api.md): its estimate
     * from its recent job times.  -1 when it says nothing. */
    curl_off_t asked = -1;
    if (res == CURLE_OK && (status == 429 || status == 503))
        curl_easy_getinfo(p->easy, CURLINFO_RETRY_AFTER, &asked);
    char why[512], name[64];
    label(b, p, name, sizeof name);
    int retry = 0;
    /* Connected, then silent past --timeout (not the connect's 10 s). */
    curl_off_t connected = 0;
    curl_easy_getinfo(p->easy, CURLINFO_CONNECT_TIME_T, &connected);
    if (res == CURLE_OPERATION_TIMEDOUT && !p->too_big && connected > 0) {
        snprintf(why, sizeof why,
                 "no answer from the daemon for %d s (--timeout)",
                 b->o->timeout);
        retry = 1;
    } else if (res != CURLE_OK) {
        snprintf(why, sizeof why, "%s",
                 p->too_big ? "the answer is larger than the part's image"
                            : curl_easy_strerror(res));
        retry = 1;
    } else if (status == 200) {
        int x0 = p->region[0] - f->box[0], y0 = p->region[1] - f->box[1];
        if (exr_crop_place(p->answer, p->len, f->img, x0, y0, p->region[0],
                           p->region[1], p->region[2] - p->region[0],
                           p->region[3] - p->region[1], why, sizeof why) != 0)
            retry = 1;
    } else {
        char text[400];
        answer_text(p, text, sizeof text);
        snprintf(why, sizeof why, "HTTP %ld: %s", status, text);
        /* 4xx is the request's fault and would come again; 408 and 429
         * (queue full) are the daemon's state. */
        retry = remote_status_passes(status);
        if (!retry) {
            /* The daemon names files by their assets' hashes: the file
             * after each (a corrupt texture was "sha256:7a66...569e"). */
            char named[sizeof why + 1024];
            assets_name_files(b->as, why, named, sizeof named);
            fprintf(stderr, "%slensray: %s refused: %s\n", o->quiet ? "" : "\n",
                    name, named);
            fail_frame(b, p->frame,
                       status == 401 || status == 403 ? EXIT_IO : EXIT_SCENE);
            return;
        }
    }
    end_part(b->multi, p);
    b->running--;
    if (!retry) {
        p->state = PART_DONE;
        drop_answer(p);
        b->left--;
        f->done_parts++;
        if (!o->quiet) {
            if (b->n == 1)
                fprintf(stderr,
                        "lensray: %s done (rows %d-%d), %d of %d "
                        "parts\n",
                        name, p->region[1], p->region[3] - 1, f->done_parts,
                        f->n_parts);
            else
                fprintf(stderr,
                        "lensray: %s done (rows %d-%d), %d of %d "
                        "frames\n",
                        name, p->region[1], p->region[3] - 1,
                        stats->frames + (f->done_parts == f->n_parts), b->n);
        }
        if (f->done_parts == f->n_parts) {
            lr_image *img = f->img;
            f->img = NULL;
            int rc = done(user, p->frame, img);
            if (rc != 0) {
                f->status = rc;
                if (b->status == 0)
                    b->status = rc;
            } else {
                stats->frames++;
            }
        }
        return;
    }
    /* A full queue (429) is the daemon's back-pressure, not a failure: it
     * spends no attempt.  With --queue 2, a part of 48 waiting to retry
     * lost its turn to the client's own next parts each time and spent
     * its five attempts in 4 s, and the frame was lost. */
    int busy = res == CURLE_OK && status == 429;
    if (busy) {
        p->attempts--;
        p->busy++;
    }
    if (p->attempts > o->retries || p->busy > REMOTE_MAX_BUSY) {
        fprintf(stderr, "lensray: %s failed %d times, the last: %s\n", name,
                p->attempts + p->busy, why);
        p->state = PART_DONE; /* not running: fail_frame leaves it */
        b->left--;
        fail_frame(b, p->frame, EXIT_IO);
        return;
    }
    stats->retries++;
    /* Wait a little longer each time (0.25 s, 0.5 s, ... up to 4 s), so
     * that a daemon that is restarting is not hammered; or as long as the
     * daemon asked, up to REMOTE_MAX_WAIT: retrying a full queue sooner
     * only spent the attempts (4 s in all by default) while a farm
     * busy with long jobs said to come back in a minute. */
    int nth = busy ? p->busy : p->attempts;
    double wait = remote_backoff(nth);
    int as_asked = asked > 0 && (double)asked > wait;
    if (as_asked)
        wait = (double)asked < REMOTE_MAX_WAIT ? (double)asked
                                               : REMOTE_MAX_WAIT;
    p->not_before = now() + wait;
    p->state = PART_WAITING;
    b->waiting++;
    if (!o->quiet && busy)
        fprintf(stderr,
                "lensray: %s: the daemon is busy (%s); sending it again in "
                "%.3g s%s\n",
                name, why, wait,
                as_asked ? ", as the daemon's Retry-After asks" : "");
    else if (!o->quiet)
        fprintf(stderr,
                "lensray: %s failed (%s); sending it again "
                "in %.3g s%s (attempt %d of %d)\n",
                name, why, wait,
                as_asked ? ", as the daemon's Retry-After asks" : "",
                p->attempts + 1, o->retries + 1);
}

/* Reads the next frame: the caller's load, then its text and camera as
 * sent (its files named by their hashes, uploaded where missing), and its
 * parts: bands of rows of its region.  A frame that cannot be read fails
 * alone (printed); -1 only when out of memory (printed). */
static int read_frame(batch *b)
{
    int fi = b->read++;
    frame *f = &b->frames[fi];
    remote_frame *in = &f->in;
    int rc = b->load(b->user, fi, in);
    if (rc != 0) {
        fail_frame(b, fi, rc);
        return 0;
    }
    const lr_render_settings *rs = &in->rs;
    int box[4] = {0, 0, rs->width, rs->height};
    if (rs->region[0] | rs->region[1] | rs->region[2] | rs->region[3])
        memcpy(box, rs->region, sizeof box);
    memcpy(f->box, box, sizeof box);
    char *cam_json = lr_camera_json(&in->cam);
    if (cam_json == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        return -1;
    }
    rc = assets_prepare(b->as, in->scene, in->len, cam_json, in->scene_dir,
                        in->scene_path, &f->scene, &f->len, &f->cam_json);
    lr_free(cam_json);
    /* What is sent is f->scene, its files named by their hashes. */
    free((char *)in->scene);
    in->scene = NULL;
    if (rc != 0) {
        fail_frame(b, fi, rc);
        return 0;
    }
    int rows = box[3] - box[1];
    int n_parts = b->o->parts < rows ? b->o->parts : rows;
    f->parts = calloc((size_t)(n_parts > 0 ? n_parts : 1), sizeof *f->parts);
    if (f->parts == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        return -1;
    }
    f->n_parts = n_parts;
    for (int i = 0; i < n_parts; i++) {
        part *p = &f->parts[i];
        p->frame = fi;
        p->index = i;
        /* Band i holds rows [rows * i / n, rows * (i + 1) / n). */
        p->region[0] = box[0];
        p->region[2] = box[2];
        p->region[1] = box[1] + (int)((long long)rows * i / n_parts);
        p->region[3] = box[1] + (int)((long long)rows * (i + 1) / n_parts);
    }
    b->n_parts += n_parts;
    b->left += n_parts;
    b->waiting += n_parts;
    return 0;
}

int remote_render(const remote_options *o, int n, remote_load load,
                  remote_done done, void *user, remote_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    double t0 = now();
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) {
        fprintf(stderr, "lensray: libcurl cannot start\n");
        return EXIT_IO;
    }
    batch b;
    memset(&b, 0, sizeof b);
    b.o = o;
    b.n = n;
    b.load = load;
    b.user = user;
    size_t ul = strlen(o->url);
    snprintf(b.endpoint, sizeof b.endpoint, "%.*s/v1/render",
             (int)(ul > 0 && o->url[ul - 1] == '/' ? ul - 1 : ul), o->url);
    int rc = EXIT_IO;
    b.as = assets_open(o->url, o->token, o->retries);
    b.frames = calloc((size_t)(n > 0 ? n : 1), sizeof *b.frames);
    b.multi = curl_multi_init();
    if (b.as == NULL || b.frames == NULL || b.multi == NULL) {
        fprintf(stderr, "lensray: out of memory\n");
        goto done;
    }
    while (b.left > 0 || b.read < n) {
        if (o->cancel != NULL && *o->cancel) {
            rc = EXIT_INTERRUPTED;
            goto done;
        }
        /* The next frame is read once fewer parts wait than can be in
         * flight, so that a daemon that frees up finds one to take. */
        int short_of_parts = b.read < n && b.waiting < o->parallel;
        if (short_of_parts && read_frame(&b) != 0)
            goto done;
        if (start_parts(&b, stats) != 0)
            goto done;
        int still = 0;
        curl_multi_perform(b.multi, &still);
        int queued, finished = 0;
        for (CURLMsg *msg = curl_multi_info_read(b.multi, &queued); msg != NULL;
             msg = curl_multi_info_read(b.multi, &queued)) {
            if (msg->msg != CURLMSG_DONE)
                continue;
            part *p = NULL;
            curl_easy_getinfo(msg->easy_handle, CURLINFO_PRIVATE, (char **)&p);
            /* A part of a frame that failed meanwhile is already ended. */
            if (p->state == PART_RUNNING) {
                finish_part(&b, p, msg->data.result, done, user, stats);
                finished++;
            }
        }
        /* A part just ended: send the next at once.  Waiting here for the
         * other parts' sockets first left a daemon's queue empty for up to
         * a whole part's render (or 50 ms with one part in flight), the
         * farm's splitting overhead (bench/README.md). */
        if (b.left > 0 && finished == 0 && !short_of_parts)
            curl_multi_poll(b.multi, NULL, 0, b.running > 0 ? 100 : 50, NULL);
    }
    rc = b.status;
done:
    for (int i = 0; b.frames != NULL && i < b.read; i++) {
        frame *f = &b.frames[i];
        for (int k = 0; k < f->n_parts; k++) {
            end_part(b.multi, &f->parts[k]);
            free(f->parts[k].answer);
        }
        if (f->status != 0)
            stats->failed++;
        free(f->parts);
        free(f->scene);
        free(f->cam_json);
        free((char *)f->in.scene);
        lr_image_free(f->img);
    }
    if (b.as != NULL)
        assets_counts(b.as, &stats->assets, &stats->uploaded);
    assets_close(b.as);
    free(b.frames);
    if (b.multi != NULL)
        curl_multi_cleanup(b.multi);
    stats->parts = b.n_parts;
    stats->seconds = now() - t0;
    curl_global_cleanup();
    return rc;
}
