/*
 * settings_json.c: the scene format's "render" object ->
 * lr_render_settings (size, samples, sampler, seed, depth, threads,
 * tiles, region, planning, adaptive sampling, integrator), and
 * lr_render_settings_apply_json.
 */
#include "json/json_util.h"
#include "json/apply_json.h"
#include "integrator/integrator.h"
#include "render/settings_json.h"

#include <math.h>

lr_status lr__settings_from_json(const cJSON *r, lr_render_settings *rs,
                                 lr_error *err)
{
    static const char *const keys[] = {
        "width",     "height",   "spp",        "sampler", "seed",
        "max_depth", "threads",  "tile_size",  "depth",   "region",
        "plan",      "adaptive", "integrator", "light",   NULL};
    if (r == NULL)
        return LR_OK;
    LR_TRY(lr__json_object(r, "render", "", err));
    LR_TRY(lr__json_check_keys(r, "render", keys, err));
    long long w = rs->width, h = rs->height, spp = rs->spp,
              depth = rs->max_depth, th = rs->threads, tile = rs->tile_size;
    long long seed = (long long)rs->seed;
    LR_TRY(lr__json_int(r, "width", "render", 0, 1, LR__MAX_DIM, &w, err));
    LR_TRY(lr__json_int(r, "height", "render", 0, 1, LR__MAX_DIM, &h, err));
    LR_TRY(lr__json_int(r, "spp", "render", 0, 1, LR__MAX_SPP, &spp, err));
    LR_TRY(lr__json_int(r, "max_depth", "render", 0, 0, LR__MAX_DEPTH, &depth,
                        err));
    LR_TRY(
        lr__json_int(r, "threads", "render", 0, 0, LR__MAX_THREADS, &th, err));
    LR_TRY(
        lr__json_int(r, "tile_size", "render", 0, 1, LR__MAX_TILE, &tile, err));
    LR_TRY(lr__json_int(r, "seed", "render", 0, 0, (1LL << 53), &seed, err));
    LR_TRY(lr__json_bool(r, "depth", "render", 0, &rs->want_depth, err));
    LR_TRY(lr__json_bool(r, "plan", "render", 0, &rs->plan, err));
    LR_TRY(lr__json_bool(r, "light", "render", 0, &rs->light, err));
    const cJSON *ad = cJSON_GetObjectItemCaseSensitive(r, "adaptive");
    if (ad != NULL && cJSON_IsBool(ad)) {
        rs->adaptive = cJSON_IsTrue(ad);
    } else if (ad != NULL) {
        static const char *const akeys[] = {"threshold", "min_spp", "max_spp",
                                            NULL};
        const char *ap = "render.adaptive";
        if (!cJSON_IsObject(ad))
            return lr__fail(err, LR_ERR_INVALID, ap,
                            "%s must be true, false or an object "
                            "{\"threshold\", \"min_spp\", \"max_spp\"}",
                            ap);
        LR_TRY(lr__json_check_keys(ad, ap, akeys, err));
        long long lo = rs->adaptive_min_spp, hi = -1;
        LR_TRY(lr__json_number(ad, "threshold", ap, 0, &rs->adaptive_threshold,
                               err));
        LR_TRY(lr__json_int(ad, "min_spp", ap, 0, 0, LR__MAX_SPP, &lo, err));
        LR_TRY(lr__json_int(ad, "max_spp", ap, 0, 1, LR__MAX_SPP, &hi, err));
        rs->adaptive = 1;
        rs->adaptive_min_spp = (int)lo;
        /* The maximum is render.spp itself; max_spp is its other name
         * here, and the two must agree when both are given. */
        if (hi > 0) {
            if (cJSON_GetObjectItemCaseSensitive(r, "spp") != NULL && hi != spp)
                return lr__fail(err, LR_ERR_INVALID, "render.adaptive.max_spp",
                                "render.adaptive.max_spp (%lld) and render.spp "
                                "(%lld) disagree; give one of them",
                                hi, spp);
            spp = hi;
        }
    }
    int kind = (int)rs->sampler;
    LR_TRY(
        lr__json_enum(r, "sampler", "render", lr__sampler_names, &kind, err));
    rs->sampler = (lr_sampler_kind)kind;
    const char *integrators[LR__MAX_INTEGRATORS + 1];
    lr__integrator_names(integrators);
    int integ = (int)rs->integrator;
    LR_TRY(lr__json_enum(r, "integrator", "render", integrators, &integ, err));
    rs->integrator = (lr_integrator_kind)integ;
    const cJSON *reg = cJSON_GetObjectItemCaseSensitive(r, "region");
    if (reg != NULL) {
        if (!cJSON_IsArray(reg) || cJSON_GetArraySize(reg) != 4)
            return lr__fail(err, LR_ERR_INVALID, "render.region",
                            "render.region must be [x0, y0, x1, y1]");
        int k = 0;
        for (const cJSON *c = reg->child; c; c = c->next, k++) {
            double d = c->valuedouble;
            if (!cJSON_IsNumber(c) || d != floor(d) || d < 0 || d > 65536)
                return lr__fail(err, LR_ERR_INVALID, "render.region",
                                "render.region[%d] must be a whole number "
                                "of pixels between 0 and 65536",
                                k);
            rs->region[k] = (int)d;
        }
    }
    rs->width = (int)w;
    rs->height = (int)h;
    rs->spp = (int)spp;
    rs->max_depth = (int)depth;
    rs->threads = (int)th;
    rs->tile_size = (int)tile;
    rs->seed = (uint64_t)seed;
    return lr_render_settings_validate(rs, err);
}

lr_status lr_render_settings_apply_json(lr_render_settings *s, const char *json,
                                        size_t len, lr_error *err)
{
    if (s == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_render_settings_apply_json: NULL argument");
    cJSON *root = NULL;
    LR_TRY(
        lr__json_parse(json ? json : "", len, "render", "render", &root, err));
    lr_status st = lr__render_apply_cjson(s, root, err);
    cJSON_Delete(root);
    return st;
}

lr_status lr__render_apply_cjson(lr_render_settings *s, const cJSON *obj,
                                 lr_error *err)
{
    lr_render_settings tmp = *s;
    lr_status st = lr__settings_from_json(obj, &tmp, err);
    if (st == LR_OK)
        *s = tmp;
    return st;
}
