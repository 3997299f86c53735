/*
 * settings_json.h: the scene format's "render" object, read into an
 * lr_render_settings (settings_json.c).
 */
#ifndef LR_SETTINGS_JSON_H
#define LR_SETTINGS_JSON_H

#include "util/internal.h"

#include <cjson/cJSON.h>

/* Applies the keys of the "render" object `r` on top of *rs and
 * validates the result; NULL (no render object) leaves *rs as it is.  On
 * error *rs may be partly written: callers work on a copy. */
lr_status lr__settings_from_json(const cJSON *r, lr_render_settings *rs,
                                 lr_error *err);

#endif
