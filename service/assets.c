/*
 * assets.c: the content-addressed asset store (PUT and GET/HEAD
 * /v1/assets/{sha256}, and the checks of "sha256:HEX" files in inline
 * scenes; the library opens them, lr_assets_dir_set).
 *
 * An asset is a file named by the SHA-256 of its bytes, as 64 lowercase
 * hex digits, in --assets DIR.  Because the name is the content, a PUT
 * is idempotent, two daemons sharing DIR (NFS behind the farm's nginx)
 * can never disagree on a name, and a daemon needs no locking: a new
 * asset is written to a temporary file in DIR and renamed into place,
 * which POSIX makes atomic, so a reader sees the whole file or none.
 */
#include "lensrayd.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char hexdigits[] = "0123456789abcdef";

int lrd_asset_name_ok(const char *hex)
{
    size_t n = 0;
    for (; hex[n] != '\0'; n++)
        if (strchr(hexdigits, hex[n]) == NULL)
            return 0;
    return n == 64;
}

/* DIR/HEX. */
static void asset_path(const char *hex, char *out, size_t size)
{
    snprintf(out, size, "%s/%s", lrd_cfg.assets_dir, hex);
}

static int store_ready(lrd_err *e)
{
    if (lrd_cfg.assets_dir[0] == '\0')
        return lrd_fail(e, 404, "no_asset_store", NULL,
                        "this server keeps no assets (start lensrayd with "
                        "--assets DIR)");
    return 0;
}

static int name_ok(const char *hex, const char *field, lrd_err *e)
{
    if (!lrd_asset_name_ok(hex))
        return lrd_fail(e, 422, "invalid_value", field,
                        "%s%san asset is named by the SHA-256 of its bytes: "
                        "64 lowercase hex digits, got \"%.80s\"",
                        field ? field : "", field ? ": " : "", hex);
    return 0;
}

/* Whether asset `hex` is in the store (a regular file), and its size. */
static int asset_exists(const char *hex, uint64_t *size)
{
    char path[PATH_MAX + 80];
    asset_path(hex, path, sizeof path);
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return 0;
    *size = (uint64_t)st.st_size;
    return 1;
}

int lrd_asset_stat(const char *hex, uint64_t *size, lrd_err *e)
{
    if (store_ready(e) != 0 || name_ok(hex, NULL, e) != 0)
        return -1;
    if (!asset_exists(hex, size))
        return lrd_fail(e, 404, "asset_not_found", NULL,
                        "there is no asset sha256:%s here (send it with "
                        "PUT /v1/assets/%s)",
                        hex, hex);
    return 0;
}

int lrd_asset_put(const char *hex, const void *data, size_t len, int *created,
                  lrd_err *e)
{
    *created = 0;
    if (store_ready(e) != 0 || name_ok(hex, NULL, e) != 0)
        return -1;
    unsigned char sum[32];
    char got[65];
    lrd_sha256(data, len, sum);
    for (int i = 0; i < 32; i++) {
        got[2 * i] = hexdigits[sum[i] >> 4];
        got[2 * i + 1] = hexdigits[sum[i] & 15];
    }
    got[64] = '\0';
    if (strcmp(got, hex) != 0)
        return lrd_fail(e, 422, "asset_hash_mismatch", NULL,
                        "the body's SHA-256 is %s, not the %s the URL "
                        "names; the asset sha256:%s was not stored",
                        got, hex, hex);
    char path[PATH_MAX + 80], tmp[PATH_MAX + 120];
    asset_path(hex, path, sizeof path);
    uint64_t size;
    if (asset_exists(hex, &size))
        return 0; /* the same name is the same bytes: nothing to do */
    /* A temporary name of this upload's own: two uploads of one asset at
     * once (on this daemon or on another sharing DIR) each write their
     * whole file, and the second rename replaces the first's identical
     * bytes.  A name shared by them was truncated by one while the other
     * wrote, and renamed away from under the second (507 ENOENT). */
    snprintf(tmp, sizeof tmp, "%s/.tmp-%s-XXXXXX", lrd_cfg.assets_dir, hex);
    int fd = mkostemp(tmp, O_CLOEXEC);
    if (fd >= 0 && fchmod(fd, 0644) != 0) {
        close(fd);
        unlink(tmp);
        fd = -1;
    }
    if (fd < 0)
        return lrd_fail(e, 507, "asset_store_failed", NULL,
                        "the asset sha256:%s could not be stored: %s", hex,
                        strerror(errno));
    const char *p = data;
    size_t left = len;
    while (left > 0) {
        ssize_t w = write(fd, p, left);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            int err = errno;
            close(fd);
            unlink(tmp);
            return lrd_fail(e, 507, "asset_store_failed", NULL,
                            "the asset sha256:%s could not be stored: %s", hex,
                            strerror(err));
        }
        p += w;
        left -= (size_t)w;
    }
    /* On disk before it has its name: a crash leaves a temporary file,
     * never a short asset under a name that promises the whole. */
    if (fsync(fd) != 0 || close(fd) != 0 || rename(tmp, path) != 0) {
        int err = errno;
        unlink(tmp);
        return lrd_fail(e, 507, "asset_store_failed", NULL,
                        "the asset sha256:%s could not be stored: %s", hex,
                        strerror(err));
    }
    *created = 1;
    return 0;
}

int lrd_asset_check_ref(const char *file, const char *field, lrd_err *e)
{
    const char *hex = file + 7; /* after "sha256:" */
    if (store_ready(e) != 0)
        return lrd_fail(e, 422, "asset_not_found", field,
                        "%s names the asset %s, but this server keeps no "
                        "assets (--assets DIR)",
                        field, file);
    if (name_ok(hex, field, e) != 0)
        return -1;
    uint64_t size;
    if (!asset_exists(hex, &size))
        return lrd_fail(e, 422, "asset_not_found", field,
                        "%s: this server has no asset %s (send it first with "
                        "PUT /v1/assets/%s)",
                        field, file, hex);
    return 0;
}
