/*
 * inspect.c: what lr_render decides before it traces, asked for alone:
 * the autofocus (camera.c's lr__cam_autofocus) and the plan (plan.c).
 * Both run the same steps, in the same order, as lr_render does, so what
 * they report is what a render of the same camera and settings works
 * from.
 */
#include "render/autofocus.h"
#include "camera/camera.h"
#include "json/json_util.h"
#include "render/plan.h"
#include "util/fp_mode.h"

#include <stdlib.h>
#include <string.h>

/* The public block size is the planner's. */
_Static_assert(LR_PLAN_BLOCK == LR__PLAN_BLOCK, "LR_PLAN_BLOCK");

lr_status lr_camera_autofocus(const lr_scene *scene, lr_camera *cam, int width,
                              int height, lr_error *err)
{
    if (scene == NULL || cam == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_camera_autofocus: NULL scene or camera");
    if (width < 1 || height < 1)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_camera_autofocus: the frame is %d x %d", width,
                        height);
    LR_TRY(lr_camera_validate(cam, err));
    lr_camera c = *cam;
    LR_TRY(lr__autofocus(scene, &c, width, height, err));
    *cam = c;
    return LR_OK;
}

static lr_status plan_map_in_mode(const lr_scene *scene, const lr_camera *cam,
                                  const lr_render_settings *set,
                                  unsigned char **cells, int *columns,
                                  int *rows, lr_error *err);

lr_status lr_render_plan_map(const lr_scene *scene, const lr_camera *cam,
                             const lr_render_settings *set,
                             unsigned char **cells, int *columns, int *rows,
                             lr_error *err)
{
    /* lr_render's plan, in its floating-point mode (fp_mode.h). */
    unsigned fp = lr__fp_enter();
    lr_status st = plan_map_in_mode(scene, cam, set, cells, columns, rows, err);
    lr__fp_leave(fp);
    return st;
}

static lr_status plan_map_in_mode(const lr_scene *scene, const lr_camera *cam,
                                  const lr_render_settings *set,
                                  unsigned char **cells, int *columns,
                                  int *rows, lr_error *err)
{
    if (scene == NULL || cam == NULL || set == NULL || cells == NULL ||
        columns == NULL || rows == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_render_plan_map: NULL argument");
    *cells = NULL;
    LR_TRY(lr_camera_validate(cam, err));
    LR_TRY(lr_render_settings_validate(set, err));
    lr_camera used = *cam;
    LR_TRY(lr__autofocus(scene, &used, set->width, set->height, err));
    int x0 = 0, y0 = 0, x1 = set->width, y1 = set->height;
    if ((set->region[0] | set->region[1] | set->region[2] | set->region[3]))
        x0 = set->region[0], y0 = set->region[1], x1 = set->region[2],
        y1 = set->region[3];
    lr__cam c;
    lr__cam_init(&c, &used, set->width, set->height);
    lr__plan p;
    LR_TRY(lr__plan_build(&p, scene, &c, set, x0, y0, x1, y1, err));
    size_t n = (size_t)p.bw * (size_t)p.bh;
    unsigned char *out = malloc(n);
    if (out == NULL) {
        lr__plan_free(&p);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    for (size_t i = 0; i < n; i++)
        out[i] = (unsigned char)((p.blocks[i].lens ? LR_PLAN_LENS : 0) |
                                 (p.blocks[i].chroma ? LR_PLAN_CHROMA : 0));
    *cells = out;
    *columns = p.bw;
    *rows = p.bh;
    lr__plan_free(&p);
    return LR_OK;
}
