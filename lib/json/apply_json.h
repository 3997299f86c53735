/*
 * apply_json.h: the public objects' JSON keys applied from an already
 * parsed cJSON value, for callers inside the library that hold a parsed
 * document (a job: job.c) and must not print it back to text to use the
 * public *_apply_json functions.  Same keys, rules and errors as those.
 */
#ifndef LR_APPLY_JSON_H
#define LR_APPLY_JSON_H

#include "util/internal.h"

#include <cjson/cJSON.h>

/* camera_json.c, settings_json.c: the "camera" and "render" objects, validated as a whole
 * after the keys are applied; on error *cam / *s is unchanged.  `obj`
 * NULL changes nothing (and validates nothing). */
lr_status lr__camera_apply_cjson(lr_camera *cam, const cJSON *obj,
                                 lr_error *err);
lr_status lr__render_apply_cjson(lr_render_settings *s, const cJSON *obj,
                                 lr_error *err);

/* output.c: the "output" object; on error *o is unchanged. */
lr_status lr__output_apply_cjson(lr_output *o, const cJSON *obj, lr_error *err);

#endif
