/*
 * fuzz_scene.c: the scene loader (lr_scene_load_json), and a tiny render
 * of every scene it accepts.
 *
 * Promises checked: no crash, no leak, no undefined behaviour; no scene
 * is refused for lack of memory (no allocation fails here, so that would
 * be the loader taking a syntax error for one); a
 * rejected scene gets a known status and a message naming its field; an
 * accepted scene renders (a 2 x 2 crop at the frame's centre, at most 2
 * samples and 3 bounces, one thread) to finite pixels and depths, or
 * fails cleanly (autofocus that hits nothing).
 *
 * Mesh paths resolve against fuzz/meshes (LENSRAY_FUZZ_MESHES overrides),
 * which holds a few small OBJ files.  Inputs that name a mesh by an
 * absolute path or with ".." are skipped: they would make the fuzzer read
 * arbitrary files of the machine (/dev/zero is read up to the 1 GiB limit
 * before being rejected), which tests the file system, not the parser.
 */
#include "fuzz.h"

#include "lensray.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *mesh_dir(void)
{
    const char *d = getenv("LENSRAY_FUZZ_MESHES");
    return d && *d ? d : "fuzz/meshes";
}

/* 1 if the scene names a mesh file outside the mesh directory. */
static int names_outside_file(const uint8_t *data, size_t size)
{
    cJSON *root = cJSON_ParseWithLength((const char *)data, size);
    if (root == NULL)
        return 0; /* the loader rejects it before reading any file */
    int bad = 0;
    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(root, "objects");
    if (cJSON_IsArray(objs)) {
        for (const cJSON *o = objs->child; o != NULL; o = o->next) {
            /* Any member named "file", wherever the loader may look. */
            for (const cJSON *m = o->child; m != NULL; m = m->next) {
                if (!cJSON_IsString(m))
                    continue;
                const char *f = m->valuestring;
                if (f[0] == '/' || strstr(f, "..") != NULL)
                    bad = 1;
            }
        }
    }
    cJSON_Delete(root);
    return bad;
}

static int min_int(int a, int b)
{
    return a < b ? a : b;
}

int lr_fuzz_scene(const uint8_t *data, size_t size)
{
    if (names_outside_file(data, size))
        return 0;
    lr_scene *scene = (lr_scene *)(uintptr_t)1;
    lr_error err;
    memset(&err, 0x5a, sizeof err);
    lr_status st = lr_scene_load_json((const char *)data, size, mesh_dir(),
                                      NULL, 0, &scene, &err);
    if (st != LR_OK) {
        if (scene != NULL)
            return lr_fuzz_report("scene: failed (%d) but *out is not NULL",
                                  (int)st);
        if (st == LR_ERR_NOMEM)
            return lr_fuzz_report("scene: out of memory, though no "
                                  "allocation failed: %s",
                                  err.message);
        return lr_fuzz_check_error("scene", st, &err);
    }
    if (scene == NULL)
        return lr_fuzz_report("scene: LR_OK with a NULL scene");

    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(scene, &cam);
    lr_scene_settings(scene, &rs);
    int rc = 0;
    if (lr_camera_validate(&cam, &err) != LR_OK)
        rc = lr_fuzz_report("scene: accepted a camera that does not "
                            "validate: %s",
                            err.message);
    else if (lr_render_settings_validate(&rs, &err) != LR_OK)
        rc = lr_fuzz_report("scene: accepted settings that do not "
                            "validate: %s",
                            err.message);
    if (rc != 0) {
        lr_scene_free(scene);
        return rc;
    }

    /* A few pixels at the centre of the frame, cheaply: the geometry of
     * the full frame is kept (so the camera is exactly the scene's). */
    int cx = rs.width / 2, cy = rs.height / 2;
    rs.region[0] = cx;
    rs.region[1] = cy;
    rs.region[2] = min_int(cx + 2, rs.width);
    rs.region[3] = min_int(cy + 2, rs.height);
    rs.spp = min_int(rs.spp, 2);
    rs.max_depth = min_int(rs.max_depth, 3);
    rs.threads = 1;
    if (cam.chromatic.wavelengths > 8)
        cam.chromatic.wavelengths = 8;
    lr_image *img = NULL;
    lr_render_stats stats;
    st = lr_render(scene, &cam, &rs, &img, &stats, &err);
    if (st != LR_OK) {
        if (img != NULL)
            rc = lr_fuzz_report("render: failed (%d) with an image", (int)st);
        else
            rc = lr_fuzz_check_error("render", st, &err);
    } else {
        int w = lr_image_width(img), h = lr_image_height(img);
        const float *rgb = lr_image_rgb(img);
        const float *z = lr_image_depth(img);
        if (w != rs.region[2] - rs.region[0] ||
            h != rs.region[3] - rs.region[1])
            rc = lr_fuzz_report("render: image is %d x %d for a region of "
                                "%d x %d",
                                w, h, rs.region[2] - rs.region[0],
                                rs.region[3] - rs.region[1]);
        for (int i = 0; rc == 0 && i < 3 * w * h; i++)
            if (!isfinite(rgb[i]))
                rc = lr_fuzz_report("render: pixel value %d is %g", i,
                                    (double)rgb[i]);
        for (int i = 0; rc == 0 && z != NULL && i < w * h; i++)
            if (!isfinite(z[i]) || z[i] < 0)
                rc = lr_fuzz_report("render: depth %d is %g", i, (double)z[i]);
        if (rc == 0 && (rs.want_depth != 0) != (z != NULL))
            rc = lr_fuzz_report("render: depth channel %s",
                                z ? "unasked" : "missing");
        lr_image_free(img);
    }
    lr_scene_free(scene);
    return rc;
}

LR_FUZZ_MAIN(lr_fuzz_scene)
