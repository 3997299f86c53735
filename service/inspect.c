/*
 * inspect.c: what the page (service/ui/) shows beside a picture, through
 * the public API only: the camera models and the names a job may use
 * (GET /v1/options), the camera a job renders with once its autofocus is
 * resolved (the job status's "camera"), and the plan of a job's render
 * (GET /v1/jobs/{id}/plan).
 *
 * The models are found by asking the library to write a default camera
 * of each lr_camera_model value in turn (lr_camera_json names a value it
 * does not know "unknown"), so a model added to the library appears here
 * with its keys and their defaults and nothing in the daemon changes.
 * The samplers, integrators and chromatic modes are found the same way.
 */
#include "lensrayd.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* lr_camera_model values tried; the enum has 3 today. */
#define MAX_ENUM 64

/* The "model" (or another string member) of a JSON text written by the
 * library; NULL when it is "unknown" or absent.  Returns the parsed tree
 * in *tree (free it with cJSON_Delete). */
static const char *known_name(const char *json, const char *key, cJSON **tree)
{
    *tree = json != NULL ? cJSON_Parse(json) : NULL;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(*tree, key);
    if (!cJSON_IsString(v) || strcmp(v->valuestring, "unknown") == 0)
        return NULL;
    return v->valuestring;
}

/* One model: its name, its keys with their defaults, and whether it
 * reads focus_on and chromatic (asked by setting both: the library
 * writes them only for a model with a lens). */
static cJSON *model_item(int id)
{
    lr_camera cam;
    lr_camera_default(&cam);
    cam.model = (lr_camera_model)id;
    char *plain = lr_camera_json(&cam);
    cJSON *defaults = NULL;
    const char *name = known_name(plain, "model", &defaults);
    lr_free(plain);
    if (name == NULL) {
        cJSON_Delete(defaults);
        return NULL;
    }
    cam.focus_on[0] = cam.focus_on[1] = 0;
    cam.chromatic.mode = LR_CHROMATIC_RGB;
    char *lens = lr_camera_json(&cam);
    cJSON *lt = lens != NULL ? cJSON_Parse(lens) : NULL;
    lr_free(lens);
    cJSON *item = cJSON_CreateObject();
    if (item == NULL) {
        cJSON_Delete(lt);
        cJSON_Delete(defaults);
        return NULL;
    }
    cJSON_AddStringToObject(item, "name", name);
    cJSON_AddBoolToObject(item, "autofocus",
                          cJSON_GetObjectItemCaseSensitive(lt, "focus_on") !=
                              NULL);
    cJSON_AddBoolToObject(item, "chromatic",
                          cJSON_GetObjectItemCaseSensitive(lt, "chromatic") !=
                              NULL);
    cJSON_Delete(lt);
    cJSON_AddItemToObject(item, "defaults", defaults);
    return item;
}

static void set_sampler(lr_render_settings *rs, int k)
{
    rs->sampler = (lr_sampler_kind)k;
}

static void set_integrator(lr_render_settings *rs, int k)
{
    rs->integrator = (lr_integrator_kind)k;
}

/* Adds to `list` the names the library writes for render.`key` when
 * `set` gives it each value in turn (NULL list: nothing). */
static void setting_names(cJSON *list, const char *key,
                          void (*set)(lr_render_settings *, int))
{
    lr_render_settings rs;
    lr_render_settings_default(&rs);
    for (int k = 0; k < MAX_ENUM && list != NULL; k++) {
        set(&rs, k);
        char *json = lr_render_settings_json(&rs);
        cJSON *t = NULL;
        const char *name = known_name(json, key, &t);
        if (name != NULL)
            cJSON_AddItemToArray(list, cJSON_CreateString(name));
        cJSON_Delete(t);
        lr_free(json);
    }
}

char *lrd_options_json(lrd_err *e)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *models = cJSON_AddArrayToObject(root, "camera_models");
    cJSON *samplers = cJSON_AddArrayToObject(root, "samplers");
    cJSON *integrators = cJSON_AddArrayToObject(root, "integrators");
    cJSON *modes = cJSON_AddArrayToObject(root, "chromatic_modes");
    for (int id = 0; id < MAX_ENUM && models != NULL; id++) {
        cJSON *m = model_item(id);
        if (m != NULL)
            cJSON_AddItemToArray(models, m);
    }
    setting_names(samplers, "sampler", set_sampler);
    setting_names(integrators, "integrator", set_integrator);
    /* Chromatic modes through a thin lens, which writes them; "off" is
     * not written at all, so it is the first name by definition. */
    if (modes != NULL)
        cJSON_AddItemToArray(modes, cJSON_CreateString("off"));
    lr_camera cam;
    lr_camera_default(&cam);
    cam.model = LR_CAMERA_THINLENS;
    for (int k = 1; k < MAX_ENUM && modes != NULL; k++) {
        cam.chromatic.mode = (lr_chromatic_mode)k;
        char *json = lr_camera_json(&cam);
        cJSON *t = json != NULL ? cJSON_Parse(json) : NULL;
        lr_free(json);
        const cJSON *mode = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(t, "chromatic"), "mode");
        if (cJSON_IsString(mode) && strcmp(mode->valuestring, "unknown") != 0)
            cJSON_AddItemToArray(modes, cJSON_CreateString(mode->valuestring));
        cJSON_Delete(t);
    }
    char *out = lrd_json_print(root);
    cJSON_Delete(root);
    if (out == NULL)
        lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
    return out;
}

char *lrd_spec_camera_json(const lrd_job_spec *spec)
{
    lr_camera cam = spec->cam;
    lr_error le;
    /* A focus_on that hits nothing stays as it was: the render itself
     * fails with that error, and the status says so. */
    (void)lr_camera_autofocus(lrd_scene_get(spec->scene), &cam, spec->rs.width,
                              spec->rs.height, &le);
    return lr_camera_json(&cam);
}

char *lrd_job_plan_json(lrd_job *j, lrd_err *e)
{
    const lrd_job_spec *spec = lrd_job_spec_of(j);
    unsigned char *cells = NULL;
    int cols = 0, rows = 0;
    lr_error le;
    if (lr_render_plan_map(lrd_scene_get(spec->scene), &spec->cam, &spec->rs,
                           &cells, &cols, &rows, &le) != LR_OK) {
        lrd_fail_lr(e, &le, NULL, NULL);
        return NULL;
    }
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", lrd_job_id(j));
    cJSON_AddBoolToObject(o, "enabled", spec->rs.plan != 0);
    cJSON_AddNumberToObject(o, "block", LR_PLAN_BLOCK);
    cJSON_AddNumberToObject(o, "width", spec->rs.width);
    cJSON_AddNumberToObject(o, "height", spec->rs.height);
    cJSON_AddNumberToObject(o, "columns", cols);
    cJSON_AddNumberToObject(o, "rows", rows);
    /* One string per row of blocks, one digit per block: LR_PLAN_LENS +
     * LR_PLAN_CHROMA, so '0' pinhole rays, '1' the lens sampled, '2' the
     * colours apart without the lens, '3' both. */
    cJSON *arr = cJSON_AddArrayToObject(o, "cells");
    char *line = malloc((size_t)cols + 1);
    for (int y = 0; y < rows && arr != NULL && line != NULL; y++) {
        for (int x = 0; x < cols; x++)
            line[x] = (char)('0' +
                             (cells[(size_t)y * (size_t)cols + (size_t)x] & 3));
        line[cols] = '\0';
        cJSON_AddItemToArray(arr, cJSON_CreateString(line));
    }
    free(line);
    lr_free(cells);
    char *out = lrd_json_print(o);
    cJSON_Delete(o);
    if (out == NULL)
        lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
    return out;
}
