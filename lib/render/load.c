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

lr_status lr_scene_load_json(const char *json, size_t len, const char *base_dir,
                             const char *const *overrides, size_t n_overrides,
                             lr_scene **out, lr_error *err)
{
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
    return lr__scene_read_settings(path, overrides, n_overrides,
                                   lr__settings_from_json, cam, rs, err);
}
