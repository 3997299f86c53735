/*
 * output.c: what to encode, from a job's "output" object: the format by
 * name (format.c's table), bit depth, half floats, the Z channel and the
 * EXR compression.
 * Options that do not apply to the chosen format are refused rather than
 * ignored, so a client never gets an image other than the one it asked
 * for.
 */
#include "json/apply_json.h"
#include "json/json_util.h"

#include <string.h>

void lr_output_default(lr_output *o)
{
    if (o == NULL)
        return;
    memset(o, 0, sizeof *o);
    o->format = LR_FORMAT_PNG;
    lr_output_options_default(&o->options);
    o->options.exr_depth = 0;
}

lr_status lr__output_apply_cjson(lr_output *o, const cJSON *obj, lr_error *err)
{
    static const char *const keys[] = {"format", "bit_depth",   "half",
                                       "depth",  "compression", NULL};
    const char *path = "output";
    if (obj == NULL)
        return LR_OK;
    LR_TRY(lr__json_object(obj, path, " like {\"format\": \"png\"}", err));
    LR_TRY(lr__json_check_keys(obj, path, keys, err));
    lr_output t = *o;
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(obj, "format");
    if (fmt != NULL)
        LR_TRY(
            lr_format_from_name(cJSON_IsString(fmt) ? fmt->valuestring : NULL,
                                "output.format", &t.format, err));
    const char *name = lr_format_name(t.format);
    int png = t.format == LR_FORMAT_PNG, exr = t.format == LR_FORMAT_EXR;
    const cJSON *bd = cJSON_GetObjectItemCaseSensitive(obj, "bit_depth");
    if (bd != NULL) {
        if (!png)
            return lr__fail(err, LR_ERR_INVALID, "output.bit_depth",
                            "output.bit_depth applies to png only, not %s",
                            name);
        if (!cJSON_IsNumber(bd) ||
            (bd->valuedouble != 8 && bd->valuedouble != 16))
            return lr__fail(err, LR_ERR_INVALID, "output.bit_depth",
                            "output.bit_depth must be 8 or 16");
        t.options.png_16bit = bd->valuedouble == 16;
    }
    if (cJSON_GetObjectItemCaseSensitive(obj, "half") != NULL) {
        if (!exr)
            return lr__fail(err, LR_ERR_INVALID, "output.half",
                            "output.half applies to exr only, not %s", name);
        LR_TRY(lr__json_bool(obj, "half", path, 0, &t.options.exr_half, err));
    }
    const cJSON *comp = cJSON_GetObjectItemCaseSensitive(obj, "compression");
    if (comp != NULL) {
        if (!exr)
            return lr__fail(err, LR_ERR_INVALID, "output.compression",
                            "output.compression applies to exr only, not %s",
                            name);
        LR_TRY(lr_exr_compression_from_name(
            cJSON_IsString(comp) ? comp->valuestring : NULL,
            "output.compression", &t.options.exr_compression, err));
    }
    if (cJSON_GetObjectItemCaseSensitive(obj, "depth") != NULL) {
        if (!lr_format_has_depth(t.format))
            return lr__fail(err, LR_ERR_INVALID, "output.depth",
                            "output.depth: %s has no depth channel (use "
                            "\"format\": \"exr\")",
                            name);
        LR_TRY(lr__json_bool(obj, "depth", path, 0, &t.depth, err));
        t.depth_given = 1;
    }
    t.options.exr_depth = t.depth;
    *o = t;
    return LR_OK;
}

lr_status lr_output_apply_json(lr_output *o, const char *json, size_t len,
                               lr_error *err)
{
    if (o == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_output_apply_json: NULL argument");
    cJSON *root = NULL;
    LR_TRY(
        lr__json_parse(json ? json : "", len, "output", "output", &root, err));
    lr_status st = lr__output_apply_cjson(o, root, err);
    cJSON_Delete(root);
    return st;
}
