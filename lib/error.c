/*
 * error.c: filling lr_error, status names, the version string.
 */
#include "internal.h"

#include <stdio.h>
#include <string.h>

lr_status lr__fail(lr_error *err, lr_status status, const char *path,
                   const char *fmt, ...)
{
    if (err == NULL)
        return status;
    err->status = status;
    snprintf(err->path, sizeof err->path, "%s", path ? path : "");
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
    return status;
}

const char *lr_status_name(lr_status status)
{
    switch (status) {
    case LR_OK: return "ok";
    case LR_ERR_INVALID: return "invalid";
    case LR_ERR_IO: return "io";
    case LR_ERR_NOMEM: return "nomem";
    case LR_ERR_EMBREE: return "embree";
    case LR_ERR_CANCELLED: return "cancelled";
    case LR_ERR_LIMIT: return "limit";
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
