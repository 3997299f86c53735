/*
 * settings.c: render settings: their defaults and their checks (the
 * public lr_render_settings_default and lr_render_settings_validate).
 */
#include "integrator/integrator.h"
#include "json/json_util.h"

#include <string.h>

void lr_render_settings_default(lr_render_settings *s)
{
    if (s == NULL)
        return;
    memset(s, 0, sizeof *s);
    s->width = 640;
    s->height = 480;
    s->spp = 16;
    s->sampler = LR_SAMPLER_SOBOL;
    s->seed = 0;
    s->max_depth = 8;
    s->threads = 0;
    s->tile_size = 32;
    s->want_depth = 0;
    s->plan = 1;
    s->adaptive = 1;
    /* 0: derived from spp (adaptive.c). */
    s->adaptive_threshold = 0.0;
    s->adaptive_min_spp = 0;
    s->light = 1;
}

lr_status lr_render_settings_validate(const lr_render_settings *s,
                                      lr_error *err)
{
    if (s == NULL)
        return lr__fail(err, LR_ERR_INVALID, "render", "settings are NULL");
    if (s->width < 1 || s->width > LR__MAX_DIM)
        return lr__fail(err, LR_ERR_INVALID, "render.width",
                        "render.width must be between 1 and %d, got %d",
                        LR__MAX_DIM, s->width);
    if (s->height < 1 || s->height > LR__MAX_DIM)
        return lr__fail(err, LR_ERR_INVALID, "render.height",
                        "render.height must be between 1 and %d, got %d",
                        LR__MAX_DIM, s->height);
    if ((uint64_t)s->width * (uint64_t)s->height > LR__MAX_PIXELS)
        return lr__fail(err, LR_ERR_INVALID, "render.width",
                        "render.width x render.height is %llu pixels, more "
                        "than the limit of %llu",
                        (unsigned long long)s->width * (unsigned)s->height,
                        (unsigned long long)LR__MAX_PIXELS);
    if (s->spp < 1 || s->spp > LR__MAX_SPP)
        return lr__fail(err, LR_ERR_INVALID, "render.spp",
                        "render.spp must be between 1 and %d, got %d",
                        LR__MAX_SPP, s->spp);
    /* JSON carries integers exactly up to 2^53, and the settings' JSON
     * must give them back (lr_render_settings_json): a seed of 2^53 + 1
     * was written as 2^53, another image. */
    if (s->seed > ((uint64_t)1 << 53))
        return lr__fail(err, LR_ERR_INVALID, "render.seed",
                        "render.seed must be between 0 and %llu, got %llu",
                        1ull << 53, (unsigned long long)s->seed);
    if ((int)s->sampler < 0 || (int)s->sampler >= lr__sampler_count())
        return lr__fail(err, LR_ERR_INVALID, "render.sampler",
                        "render.sampler is not a known sampler (%d)",
                        (int)s->sampler);
    if (lr__integrator_for(s->integrator) == NULL)
        return lr__fail(err, LR_ERR_INVALID, "render.integrator",
                        "render.integrator is not a known integrator (%d)",
                        (int)s->integrator);
    if (s->max_depth < 0 || s->max_depth > LR__MAX_DEPTH)
        return lr__fail(err, LR_ERR_INVALID, "render.max_depth",
                        "render.max_depth must be between 0 and %d, got %d",
                        LR__MAX_DEPTH, s->max_depth);
    if (s->threads < 0 || s->threads > LR__MAX_THREADS)
        return lr__fail(err, LR_ERR_INVALID, "render.threads",
                        "render.threads must be between 0 (all cores) and "
                        "%d, got %d",
                        LR__MAX_THREADS, s->threads);
    if (!(s->adaptive_threshold >= 0.0 && s->adaptive_threshold <= 1.0))
        return lr__fail(err, LR_ERR_INVALID, "render.adaptive.threshold",
                        "render.adaptive.threshold must be 0 (from spp) or "
                        "in (0, 1], got %g",
                        s->adaptive_threshold);
    if (s->adaptive_min_spp < 0 || s->adaptive_min_spp > LR__MAX_SPP)
        return lr__fail(err, LR_ERR_INVALID, "render.adaptive.min_spp",
                        "render.adaptive.min_spp must be 0 (from spp) or "
                        "between 1 and %d, got %d",
                        LR__MAX_SPP, s->adaptive_min_spp);
    const int *r = s->region;
    if ((r[0] | r[1] | r[2] | r[3]) != 0 &&
        !(r[0] >= 0 && r[1] >= 0 && r[2] > r[0] && r[3] > r[1] &&
          r[2] <= s->width && r[3] <= s->height))
        return lr__fail(err, LR_ERR_INVALID, "render.region",
                        "render.region [%d, %d, %d, %d] must satisfy 0 <= x0 "
                        "< x1 <= width (%d) and 0 <= y0 < y1 <= height (%d)",
                        r[0], r[1], r[2], r[3], s->width, s->height);
    if (s->tile_size < 1 || s->tile_size > LR__MAX_TILE)
        return lr__fail(err, LR_ERR_INVALID, "render.tile_size",
                        "render.tile_size must be between 1 and %d, got %d",
                        LR__MAX_TILE, s->tile_size);
    return LR_OK;
}
