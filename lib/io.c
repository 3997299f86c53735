/*
 * io.c: reading a whole file into memory, for the scene loader.
 */
#include "internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

lr_status lr__read_file(const char *path, size_t max, char **out,
                        size_t *out_len, lr_error *err)
{
    *out = NULL;
    *out_len = 0;
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return lr__fail(err, LR_ERR_IO, NULL, "cannot open %s: %s", path,
                        strerror(errno));
    char *buf = NULL;
    size_t len = 0, cap = 0;
    lr_status st = LR_OK;
    for (;;) {
        if (len == cap) {
            if (cap >= max) {
                st = lr__fail(err, LR_ERR_LIMIT, NULL,
                              "%s is larger than the limit of %zu bytes",
                              path, max);
                break;
            }
            cap = cap ? 2 * cap : 65536;
            /* One byte more for the terminating NUL. */
            char *grown = realloc(buf, cap + 1);
            if (grown == NULL) {
                st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
                break;
            }
            buf = grown;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            if (ferror(f))
                st = lr__fail(err, LR_ERR_IO, NULL, "cannot read %s: %s",
                              path, strerror(errno));
            break;
        }
    }
    fclose(f);
    if (st != LR_OK) {
        free(buf);
        return st;
    }
    if (buf != NULL)
        buf[len] = '\0';
    *out = buf;
    *out_len = len;
    return LR_OK;
}
