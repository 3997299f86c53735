/*
 * error.c: filling lr_error, status names, the version string.
 */
#include "util/internal.h"

#include <stdio.h>
#include <string.h>

void lr__trim_partial_utf8(char *s, size_t cap, int wanted)
{
    if (wanted < 0 || (size_t)wanted < cap)
        return;
    size_t n = strlen(s);
    size_t i = n;
    /* Back up over continuation bytes to the last lead byte. */
    while (i > 0 && ((unsigned char)s[i - 1] & 0xC0) == 0x80 && n - i < 3)
        i--;
    if (i == 0)
        return;
    unsigned char lead = (unsigned char)s[i - 1];
    size_t need = lead >= 0xF0 ? 4 : lead >= 0xE0 ? 3 : lead >= 0xC0 ? 2 : 1;
    if (lead >= 0x80 && n - (i - 1) < need)
        s[i - 1] = '\0';
}

lr_status lr__fail(lr_error *err, lr_status status, const char *path,
                   const char *fmt, ...)
{
    if (err == NULL)
        return status;
    err->status = status;
    int w = snprintf(err->path, sizeof err->path, "%s", path ? path : "");
    lr__trim_partial_utf8(err->path, sizeof err->path, w);
    va_list ap;
    va_start(ap, fmt);
    w = vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
    lr__trim_partial_utf8(err->message, sizeof err->message, w);
    return status;
}

void lr__fail_under(lr_error *err, const char *field)
{
    if (err == NULL || field == NULL || field[0] == '\0')
        return;
    if (strncmp(err->message, field, strlen(field)) == 0)
        return;
    char msg[sizeof err->message];
    int w = snprintf(msg, sizeof msg, "%s: %s", field, err->message);
    lr__trim_partial_utf8(msg, sizeof msg, w);
    memcpy(err->message, msg, sizeof msg);
    snprintf(err->path, sizeof err->path, "%s", field);
}

const char *lr_status_name(lr_status status)
{
    switch (status) {
    case LR_OK:
        return "ok";
    case LR_ERR_INVALID:
        return "invalid";
    case LR_ERR_IO:
        return "io";
    case LR_ERR_NOMEM:
        return "nomem";
    case LR_ERR_EMBREE:
        return "embree";
    case LR_ERR_CANCELLED:
        return "cancelled";
    case LR_ERR_LIMIT:
        return "limit";
    case LR_ERR_SYNTAX:
        return "syntax";
    }
    return "unknown";
}

const char *lr_version(void)
{
#define LR_STR2(x) #x
#define LR_STR(x) LR_STR2(x)
    return LR_STR(LR_VERSION_MAJOR) "." LR_STR(LR_VERSION_MINOR) "." LR_STR(
        LR_VERSION_PATCH);
}
