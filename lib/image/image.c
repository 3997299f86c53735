/*
 * image.c: the lr_image container, output options, encoding dispatch,
 * atomic file writes and the sRGB transfer curve (format names and
 * extensions: format.c).  The encoders themselves live in image_exr.c
 * and image_png.c.
 */
#include "util/internal.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* ---- the image container --------------------------------------------- */

lr_status lr_image_create(int width, int height, int with_depth, lr_image **out,
                          lr_error *err)
{
    if (out == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_image_create: the output pointer is NULL");
    *out = NULL;
    if (width <= 0 || height <= 0)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "image size %d x %d is invalid: width and height "
                        "must be positive",
                        width, height);

    /* Both factors are positive ints, so the pixel count is computed in
     * size_t and every multiplication is checked before it is made. */
    size_t pixels = (size_t)width;
    if (pixels > SIZE_MAX / (size_t)height ||
        pixels * (size_t)height > SIZE_MAX / (3 * sizeof(float)))
        return lr__fail(err, LR_ERR_LIMIT, NULL,
                        "image size %d x %d is too large: its pixels do not "
                        "fit in this machine's address space",
                        width, height);
    pixels *= (size_t)height;

    lr_image *img = calloc(1, sizeof *img);
    if (img == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "out of memory allocating a %d x %d image", width,
                        height);
    img->width = width;
    img->height = height;
    img->rgb = calloc(pixels * 3, sizeof(float));
    if (with_depth && img->rgb != NULL)
        img->depth = calloc(pixels, sizeof(float));
    if (img->rgb == NULL || (with_depth && img->depth == NULL)) {
        lr_image_free(img);
        return lr__fail(err, LR_ERR_NOMEM, NULL,
                        "out of memory allocating a %d x %d image", width,
                        height);
    }
    *out = img;
    return LR_OK;
}

int lr_image_width(const lr_image *img)
{
    return img ? img->width : 0;
}

int lr_image_height(const lr_image *img)
{
    return img ? img->height : 0;
}

const float *lr_image_rgb(const lr_image *img)
{
    return img ? img->rgb : NULL;
}

const float *lr_image_depth(const lr_image *img)
{
    return img ? img->depth : NULL;
}

float *lr_image_rgb_mut(lr_image *img)
{
    return img ? img->rgb : NULL;
}

float *lr_image_depth_mut(lr_image *img)
{
    return img ? img->depth : NULL;
}

void lr_image_free(lr_image *img)
{
    if (img == NULL)
        return;
    free(img->rgb);
    free(img->depth);
    free(img->camera);
    free(img);
}

lr_status lr_image_set_frame(lr_image *img, int frame_w, int frame_h, int x0,
                             int y0, const lr_camera *cam,
                             const lr_render_settings *s, lr_error *err)
{
    if (img == NULL || cam == NULL || s == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_image_set_frame: a pointer is NULL");
    if (x0 < 0 || y0 < 0 || frame_w <= 0 || frame_h <= 0 ||
        img->width > frame_w - x0 || img->height > frame_h - y0)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "a %d x %d image at %d, %d does not fit a %d x %d "
                        "frame",
                        img->width, img->height, x0, y0, frame_w, frame_h);
    char *camera = lr_camera_json(cam);
    if (camera == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    free(img->camera);
    img->camera = camera;
    img->frame_w = frame_w, img->frame_h = frame_h;
    img->x0 = x0, img->y0 = y0;
    img->spp = s->spp;
    img->seed = s->seed;
    return LR_OK;
}

void lr_free(void *p)
{
    free(p);
}

/* ---- options and formats ---------------------------------------------- */

void lr_output_options_default(lr_output_options *o)
{
    if (o == NULL)
        return;
    o->exr_half = 0;
    o->exr_depth = 1;
    o->exr_compression = LR_EXR_ZIP;
    o->png_16bit = 0;
}

/* ---- encoding ---------------------------------------------------------- */

/* Encodes `img` as `fmt` with `opts` (NULL: the defaults), into the file
 * `fd` when fd >= 0, else into a malloc'ed buffer (see lr__encode_exr). */
static lr_status encode(const lr_image *img, lr_format fmt,
                        const lr_output_options *opts, int fd,
                        const volatile int *cancel, void **buf, size_t *len,
                        lr_error *err)
{
    lr_output_options defaults;
    if (opts == NULL) {
        lr_output_options_default(&defaults);
        opts = &defaults;
    }
    lr__encoder enc = lr__format_encoder(fmt);
    if (enc == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL, "unknown image format %d",
                        (int)fmt);
    return enc(img, opts, fd, cancel, buf, len, err);
}

lr_status lr_image_encode(const lr_image *img, lr_format fmt,
                          const lr_output_options *opts, void **buf,
                          size_t *len, lr_error *err)
{
    if (buf == NULL || len == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_image_encode: the output pointers are NULL");
    *buf = NULL;
    *len = 0;
    if (img == NULL || img->rgb == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_image_encode: there is no image to encode");
    return encode(img, fmt, opts, -1, NULL, buf, len, err);
}

/* ---- writing files ----------------------------------------------------- */

/* Distinguishes temporary names made by different threads of one process;
 * the process id and the clock tell processes apart. */
static atomic_uint tmp_counter;

/* Creates a new file "PATH.tmp.PID.N" beside `path` with O_EXCL, so that
 * an existing file is never reused, and with mode 0666 so the process's
 * umask decides the final permissions, as it would for a plain fopen()
 * (mkstemp would leave the image readable by its owner only).  On
 * success returns the descriptor and stores the malloc'ed name in
 * *tmp_name; on failure returns -1 with errno set. */
static int create_temp_beside(const char *path, char **tmp_name)
{
    size_t cap = strlen(path) + 64;
    char *name = malloc(cap);
    if (name == NULL) {
        errno = ENOMEM;
        return -1;
    }
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    /* A file name near NAME_MAX (255) has no room for the suffix (names
     * of 236 bytes and more were refused, "File name too long"): then a
     * short hidden name in the same directory. */
    const char *slash = strrchr(path, '/');
    size_t base = strlen(slash ? slash + 1 : path);
    int dir_len = slash ? (int)(slash - path + 1) : 0;
    for (int attempt = 0; attempt < 100; attempt++) {
        unsigned n = atomic_fetch_add(&tmp_counter, 1u);
        if (base + 48 > 255)
            snprintf(name, cap, "%.*s.lensray.tmp.%ld.%lx.%u", dir_len, path,
                     (long)getpid(), (unsigned long)ts.tv_nsec, n);
        else
            snprintf(name, cap, "%s.tmp.%ld.%lx.%u", path, (long)getpid(),
                     (unsigned long)ts.tv_nsec, n);
        int fd = open(name, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            *tmp_name = name;
            return fd;
        }
        if (errno != EEXIST)
            break;
    }
    int saved = errno;
    free(name);
    errno = saved;
    return -1;
}

static lr_status write_at(const lr_image *img, lr_format fmt,
                          const lr_output_options *opts, const char *path,
                          const char *dest, const volatile int *cancel,
                          lr_error *err);

/* The file a symbolic link `path` leads to, followed link by link (a
 * relative target from the link's directory) as open(2) would, to at most
 * 40 links; the file need not exist.  malloc'ed; NULL when out of memory.
 * The rename below replaces whatever name it is given, so writing to a
 * link replaced the link with a plain file and left its target as it was. */
static char *follow_links(const char *path)
{
    char *cur = strdup(path);
    for (int hop = 0; cur != NULL && hop < 40; hop++) {
        struct stat st;
        if (lstat(cur, &st) != 0 || !S_ISLNK(st.st_mode))
            return cur;
        char target[4096];
        ssize_t n = readlink(cur, target, sizeof target - 1);
        if (n <= 0)
            return cur;
        target[n] = '\0';
        const char *slash = strrchr(cur, '/');
        size_t dir = target[0] == '/' || slash == NULL
                         ? 0
                         : (size_t)(slash - cur) + 1;
        char *next = malloc(dir + (size_t)n + 1);
        if (next != NULL) {
            memcpy(next, cur, dir);
            memcpy(next + dir, target, (size_t)n + 1);
        }
        free(cur);
        cur = next;
    }
    return cur;
}

lr_status lr_image_write_cancellable(const lr_image *img, const char *path,
                                     const lr_output_options *opts,
                                     const volatile int *cancel, lr_error *err)
{
    if (path == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_image_write: the path is NULL");
    lr_format fmt;
    lr_status st = lr_format_from_path(path, &fmt, err);
    if (st != LR_OK)
        return st;

    if (img == NULL || img->rgb == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_image_write: there is no image to write");

    /* Encoded straight into a temporary file beside `path` (the file its
     * links lead to), so the file never costs its size in memory, then
     * renamed into place. */
    char *dest = follow_links(path);
    if (dest == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    st = write_at(img, fmt, opts, path, dest, cancel, err);
    free(dest);
    return st;
}

lr_status lr_image_write(const lr_image *img, const char *path,
                         const lr_output_options *opts, lr_error *err)
{
    return lr_image_write_cancellable(img, path, opts, NULL, err);
}

/* Why renaming a finished file onto `dest` would fail where creating the
 * temporary file beside it did not, or 0: a name longer than its
 * directory allows (the temporary file takes a short name then), or
 * another user's file in a sticky directory (as /tmp), which only its
 * owner, the directory's or root may replace (rename(2), EPERM).  Both
 * had been found after the render, and the picture lost. */
static int rename_refused(const char *dest)
{
    char dir[4096];
    const char *slash = strrchr(dest, '/');
    const char *base = slash ? slash + 1 : dest;
    lr__dir_of(dest, dir, sizeof dir);
    long max = pathconf(dir, _PC_NAME_MAX);
    if (max > 0 && strlen(base) > (size_t)max)
        return ENAMETOOLONG;
    struct stat ds, fs;
    uid_t me = geteuid();
    if (me != 0 && stat(dir, &ds) == 0 && (ds.st_mode & S_ISVTX) &&
        lstat(dest, &fs) == 0 && fs.st_uid != me && ds.st_uid != me)
        return EPERM;
    return 0;
}

lr_status lr_image_write_check(const char *path, lr_error *err)
{
    if (path == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_image_write_check: the path is NULL");
    lr_format fmt;
    LR_TRY(lr_format_from_path(path, &fmt, err));
    char *dest = follow_links(path), *tmp_name = NULL;
    if (dest == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    struct stat sb;
    int fd = -1;
    lr_status st = LR_OK;
    if (stat(dest, &sb) == 0 && S_ISDIR(sb.st_mode)) {
        st = lr__fail(err, LR_ERR_IO, NULL, "cannot write '%s': %s", path,
                      strerror(EISDIR));
    } else {
        fd = create_temp_beside(dest, &tmp_name);
        int e = errno, link = strcmp(dest, path) != 0;
        if (fd < 0)
            st = lr__fail(err, e == ENOMEM ? LR_ERR_NOMEM : LR_ERR_IO, NULL,
                          "cannot create a temporary file for '%s'%s%.200s%s: "
                          "%s",
                          path, link ? " (a link to '" : "", link ? dest : "",
                          link ? "')" : "", strerror(e));
    }
    if (fd >= 0) {
        close(fd);
        unlink(tmp_name);
        int e = rename_refused(dest);
        if (e != 0)
            st = lr__fail(err, LR_ERR_IO, NULL, "cannot write '%s': %s%s", path,
                          strerror(e),
                          e == EPERM ? " (another user's file in a sticky "
                                       "directory cannot be replaced)"
                                     : "");
    }
    free(tmp_name);
    free(dest);
    return st;
}

/* lr_image_write's file at `dest` (`path` as the caller named it, for
 * the messages). */
static lr_status write_at(const lr_image *img, lr_format fmt,
                          const lr_output_options *opts, const char *path,
                          const char *dest, const volatile int *cancel,
                          lr_error *err)
{
    lr_status st;
    char *tmp_name = NULL;
    int fd = create_temp_beside(dest, &tmp_name);
    if (fd < 0 && errno == ENOMEM && tmp_name == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    if (fd < 0) {
        int saved = errno;
        return lr__fail(err, LR_ERR_IO, NULL,
                        "cannot create a temporary file for '%s': %s", path,
                        strerror(saved));
    }
    /* A file replaced keeps its permission bits (as sed -i keeps them):
     * a 0664 image had become 0644, the umask's.  Best effort. */
    struct stat old;
    if (stat(dest, &old) == 0 && S_ISREG(old.st_mode))
        (void)fchmod(fd, old.st_mode & 0777);

    void *buf = NULL;
    size_t len = 0;
    st = encode(img, fmt, opts, fd, cancel, &buf, &len, err);
    if (st == LR_ERR_CANCELLED) /* (the encoder's message names no file) */
        lr__fail(err, st, NULL, "writing '%s' was cancelled; it is as it was",
                 path);
    if (st != LR_OK) {
        close(fd);
        unlink(tmp_name);
        free(tmp_name);
        return st;
    }

    const char *what = "flush";
    /* Flushing before the rename means a crash cannot leave a renamed
     * but empty or truncated file under `path`. */
    if (fsync(fd) != 0)
        goto io_error;
    {
        int rc = close(fd);
        fd = -1;
        if (rc != 0)
            goto io_error;
    }
    what = "rename the finished file to";
    /* The last moment a cancellation keeps the file as it was. */
    if (cancel != NULL && *cancel) {
        unlink(tmp_name);
        free(tmp_name);
        return lr__fail(err, LR_ERR_CANCELLED, NULL,
                        "writing '%s' was cancelled; it is as it was", path);
    }
    if (rename(tmp_name, dest) != 0)
        goto io_error;

    free(tmp_name);
    return LR_OK;

io_error:;
    int saved = errno;
    if (fd >= 0)
        close(fd);
    unlink(tmp_name);
    free(tmp_name);
    return lr__fail(err, LR_ERR_IO, NULL, "cannot %s '%s': %s", what, path,
                    strerror(saved));
}

/* ---- colour ------------------------------------------------------------ */

double lr__srgb_encode(double linear)
{
    /* The negated comparison also catches NaN, which maps to black. */
    if (!(linear > 0.0))
        return 0.0;
    if (linear >= 1.0)
        return 1.0;
    if (linear <= 0.0031308)
        return 12.92 * linear;
    return 1.055 * pow(linear, 1.0 / 2.4) - 0.055;
}
