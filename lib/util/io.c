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
#include <unistd.h>

/* The calling thread's log of files read (lr__file_log_begin), or NULL. */
static __thread lr__file_log *file_log;

void lr__file_log_begin(lr__file_log *log)
{
    memset(log, 0, sizeof *log);
    file_log = log;
}

void lr__file_log_end(void)
{
    file_log = NULL;
}

void lr__file_log_free(lr__file_log *log)
{
    for (size_t i = 0; i < log->n; i++)
        free(log->v[i].path);
    free(log->v);
    memset(log, 0, sizeof *log);
}

static lr__file_id id_of(const struct stat *sb)
{
    return (lr__file_id){NULL,
                         (unsigned long long)sb->st_dev,
                         (unsigned long long)sb->st_ino,
                         (unsigned long long)sb->st_size,
                         (long long)sb->st_mtim.tv_sec,
                         (long long)sb->st_mtim.tv_nsec};
}

static int same_id(const lr__file_id *a, const lr__file_id *b)
{
    return a->dev == b->dev && a->ino == b->ino && a->size == b->size &&
           a->mtime_s == b->mtime_s && a->mtime_ns == b->mtime_ns;
}

/* Adds `file` as sb found it to the thread's log, once.  0: out of
 * memory. */
static int log_file(const char *file, const struct stat *sb)
{
    lr__file_log *log = file_log;
    if (log == NULL)
        return 1;
    /* Absolute, so that a caller's chdir later does not make every
     * relative file "gone", but with its links kept (not realpath): a
     * link switched to another file ("ln -sfn v2 current") is a change.
     * As given if the directory is unknown. */
    char *abs = NULL;
    char cwd[4096];
    if (file[0] != '/' && getcwd(cwd, sizeof cwd) != NULL) {
        size_t n = strlen(cwd) + strlen(file) + 2;
        abs = malloc(n);
        if (abs == NULL)
            return 0;
        snprintf(abs, n, "%s/%s", cwd, file);
    }
    const char *key = abs != NULL ? abs : file;
    for (size_t i = 0; i < log->n; i++)
        if (strcmp(log->v[i].path, key) == 0) {
            free(abs);
            return 1;
        }
    if (log->n == log->cap) {
        size_t cap = log->cap ? 2 * log->cap : 8;
        lr__file_id *v = realloc(log->v, cap * sizeof *v);
        if (v == NULL) {
            free(abs);
            return 0;
        }
        log->v = v, log->cap = cap;
    }
    lr__file_id id = id_of(sb);
    id.path = abs != NULL ? abs : strdup(file);
    if (id.path == NULL)
        return 0;
    log->v[log->n++] = id;
    return 1;
}

int lr__file_log_changed(const lr__file_log *log)
{
    for (size_t i = 0; i < log->n; i++) {
        struct stat sb;
        lr__file_id now;
        if (stat(log->v[i].path, &sb) != 0)
            return 1;
        now = id_of(&sb);
        if (!same_id(&now, &log->v[i]))
            return 1;
    }
    return 0;
}

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

/* Reading in a loop rather than trusting the size from fstat also copes
 * with pipes and with files that change while we read them. */
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
        if (!log_file(file, &sb)) {
            fclose(f);
            return lr__fail(err, LR_ERR_NOMEM, json_path,
                            "%s: out of memory reading the file", shown);
        }
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
