/*
 * fuzz_common.c: what the fuzz targets share: recording a broken promise
 * and checking an lr_error.
 */
#include "fuzz.h"

#include "lensray.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char last_failure[2048];

const char *lr_fuzz_last_failure(void)
{
    return last_failure;
}

int lr_fuzz_report(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(last_failure, sizeof last_failure, fmt, ap);
    va_end(ap);
    return 1;
}

/* Strict UTF-8 (RFC 3629): no overlong forms, no surrogates, nothing
 * beyond U+10FFFF.  Error messages quote user text, so a message that is
 * cut in the middle of a character would not be valid UTF-8 any more
 * (and lensrayd copies messages into JSON responses). */
int lr_fuzz_valid_utf8(const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    while (*p) {
        unsigned c = *p;
        int n;
        unsigned min;
        if (c < 0x80) {
            p++;
            continue;
        } else if (c >= 0xC2 && c <= 0xDF) {
            n = 1, min = 0x80;
        } else if (c >= 0xE0 && c <= 0xEF) {
            n = 2, min = 0x800;
        } else if (c >= 0xF0 && c <= 0xF4) {
            n = 3, min = 0x10000;
        } else {
            return 0;
        }
        unsigned cp = c & (0x3Fu >> n);
        for (int i = 1; i <= n; i++) {
            if ((p[i] & 0xC0) != 0x80)
                return 0;
            cp = (cp << 6) | (p[i] & 0x3Fu);
        }
        if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF))
            return 0;
        p += n + 1;
    }
    return 1;
}

int lr_fuzz_check_error(const char *what, int status,
                        const struct lr_error *err)
{
    if (status != LR_ERR_INVALID && status != LR_ERR_IO &&
        status != LR_ERR_NOMEM && status != LR_ERR_EMBREE &&
        status != LR_ERR_LIMIT)
        return lr_fuzz_report("%s: unexpected status %d", what, status);
    if (err->status != (lr_status)status)
        return lr_fuzz_report("%s: returned %d but err.status is %d", what,
                              status, (int)err->status);
    if (memchr(err->message, '\0', sizeof err->message) == NULL ||
        memchr(err->path, '\0', sizeof err->path) == NULL)
        return lr_fuzz_report("%s: unterminated error text", what);
    if (err->message[0] == '\0')
        return lr_fuzz_report("%s: status %d with an empty message", what,
                              status);
    if (!lr_fuzz_valid_utf8(err->message) || !lr_fuzz_valid_utf8(err->path))
        return lr_fuzz_report("%s: the error is not valid UTF-8: %s", what,
                              err->message);
    /* The message is a sentence that names the field it is about. */
    if (status == LR_ERR_INVALID && err->path[0] != '\0' &&
        strstr(err->message, err->path) == NULL)
        return lr_fuzz_report("%s: message \"%s\" does not name its path "
                              "\"%s\"",
                              what, err->message, err->path);
    return 0;
}
