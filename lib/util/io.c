/*
 * io.c: reading a whole file into memory, with a size limit (scene files,
 * OBJ files).
 */
#include "util/internal.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Reading in a loop rather than trusting the size from fstat also copes
 * with pipes and with files that change while we read them. */
void lr__dir_of(const char *path, char *dir, size_t cap)
{
    snprintf(dir, cap, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash == NULL)
        snprintf(dir, cap, ".");
    else if (slash == dir)
        dir[1] = '\0';
    else
        *slash = '\0';
}

lr_status lr__read_file(const char *file, const char *shown,
                        const char *json_path, size_t max, const char *what,
                        int (*stop)(const char *chunk, size_t n), char **out,
                        size_t *out_len, lr_error *err)
{
    *out = NULL;
    *out_len = 0;
    FILE *f = fopen(file, "rb");
    if (f == NULL)
        return lr__fail(err, LR_ERR_IO, json_path, "%s: cannot open: %s", shown,
                        strerror(errno));

    /* Two bytes beyond the size: one for the terminating NUL and one so
     * that the first fread comes up short and shows the end of the file
     * without another round. */
    size_t cap = 65536;
    struct stat sb;
    if (fstat(fileno(f), &sb) == 0 && S_ISREG(sb.st_mode)) {
        if ((uintmax_t)sb.st_size > max) {
            fclose(f);
            return lr__fail(err, LR_ERR_LIMIT, json_path,
                            "%s: the file is larger than the %zu MiB limit "
                            "for %s",
                            shown, max >> 20, what);
        }
        cap = (size_t)sb.st_size + 2;
    }
    char *buf = malloc(cap);
    if (buf == NULL) {
        fclose(f);
        return lr__fail(err, LR_ERR_NOMEM, json_path,
                        "%s: out of memory reading the file", shown);
    }
    size_t len = 0;
    for (;;) {
        if (cap - len < 2) {
            size_t ncap = cap > max / 2 ? max + 2 : cap * 2;
            char *nbuf = realloc(buf, ncap);
            if (nbuf == NULL) {
                free(buf);
                fclose(f);
                return lr__fail(err, LR_ERR_NOMEM, json_path,
                                "%s: out of memory reading the file", shown);
            }
            buf = nbuf;
            cap = ncap;
        }
        size_t want = cap - len - 1;
        size_t got = fread(buf + len, 1, want, f);
        /* The caller's parser would stop here anyway (stop). */
        int stopped = stop != NULL && stop(buf + len, got);
        len += got;
        if (stopped)
            break;
        if (len > max) {
            free(buf);
            fclose(f);
            return lr__fail(err, LR_ERR_LIMIT, json_path,
                            "%s: the file is larger than the %zu MiB limit "
                            "for %s",
                            shown, max >> 20, what);
        }
        if (got < want) {
            if (ferror(f)) {
                int e = errno;
                free(buf);
                fclose(f);
                return lr__fail(err, LR_ERR_IO, json_path,
                                "%s: cannot read: %s", shown, strerror(e));
            }
            break;
        }
    }
    fclose(f);
    buf[len] = '\0';
    *out = buf;
    *out_len = len;
    return LR_OK;
}
