/*
 * load.c: the public scene loaders (lensray.h): a scene loaded and
 * committed by the scene layer (scene_load.c), then readied for the
 * integrators (lr__integrators_prepare), so that a loaded scene renders
 * with any of them and renders share it read-only.  The render layer
 * reads a scene's "render" object for the scene layer
 * (lr__settings_from_json, passed down as its lr__render_reader): the
 * settings name integrators, which the scene layer does not know.
 */
#include "integrator/integrator.h"
#include "render/settings_json.h"
#include "scene/scene_load.h"
#include "util/fp_mode.h"

static lr_status prepared(lr_status st, lr_scene **out, lr_error *err)
{
    if (st != LR_OK)
        return st;
    st = lr__integrators_prepare(*out, err);
    if (st != LR_OK) {
        lr_scene_free(*out);
        *out = NULL;
    }
    return st;
}

/* LR_ERR_INVALID if the list of n overrides, or one of them, is NULL
 * (they were read through, a crash). */
static lr_status overrides_bad(const char *const *ov, size_t n, lr_error *err)
{
    for (size_t i = 0; i < n; i++)
        if (ov == NULL || ov[i] == NULL)
            return lr__fail(err, LR_ERR_INVALID, NULL,
                            "override %zu of %zu is NULL", i, n);
    return LR_OK;
}

lr_status lr_scene_load_json(const char *json, size_t len, const char *base_dir,
                             const char *const *overrides, size_t n_overrides,
                             lr_scene **out, lr_error *err)
{
    if (out != NULL)
        *out = NULL;
    LR_TRY(overrides_bad(overrides, n_overrides, err));
    unsigned fp = lr__fp_enter();
    lr_status st = prepared(
        lr__scene_load_json(json, len, base_dir, overrides, n_overrides,
                            lr__settings_from_json, out, err),
        out, err);
    lr__fp_leave(fp);
    return st;
}

lr_status lr_scene_load_file(const char *path, const char *const *overrides,
                             size_t n_overrides, lr_scene **out, lr_error *err)
{
    if (out != NULL)
        *out = NULL;
    LR_TRY(overrides_bad(overrides, n_overrides, err));
    unsigned fp = lr__fp_enter();
    lr_status st = prepared(lr__scene_load_file(path, overrides, n_overrides,
                                                lr__settings_from_json, out,
                                                err),
                            out, err);
    lr__fp_leave(fp);
    return st;
}

lr_status lr_scene_read_settings(const char *path, const char *const *overrides,
                                 size_t n_overrides, lr_camera *cam,
                                 lr_render_settings *rs, lr_error *err)
{
    LR_TRY(overrides_bad(overrides, n_overrides, err));
    return lr__scene_read_settings(path, overrides, n_overrides,
                                   lr__settings_from_json, cam, rs, err);
}
