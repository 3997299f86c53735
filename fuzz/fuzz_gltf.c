/*
 * fuzz_gltf.c: the glTF loader (lib/gltf*.c, libassimp behind it): the
 * input as a .gltf or .glb file (told apart by its bytes) placed by a
 * scene with the file's camera, and rendered.
 *
 * Promises checked: a rejected file gets a clean error that names the
 * scene's field and the file; an accepted one renders 2 x 2 finite
 * pixels (path integrator, depth too) through its own camera or an
 * auto-framed one.  A crash or a leak inside libassimp counts as ours:
 * gltf_check.c is there to stop such input before assimp sees it.
 */
#include "fuzz.h"

#include "lensray.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The input goes to a file in a directory of its own (not a memfd under
 * /proc/self/fd, where a uri "0" would name standard input): the files
 * the glTF names are looked up there, and are not found. */
static const char *input_path(void)
{
    static char path[256];
    if (path[0] == '\0') {
        char dir[200];
        snprintf(dir, sizeof dir, "%s/lensray-fuzz-gltf-XXXXXX",
                 getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        if (mkdtemp(dir) == NULL)
            return NULL;
        snprintf(path, sizeof path, "%s/input", dir);
    }
    return path;
}

int lr_fuzz_gltf(const uint8_t *data, size_t size)
{
    const char *path = input_path();
    FILE *f = path ? fopen(path, "wb") : NULL;
    if (f == NULL)
        return 0; /* no scratch directory: nothing to test */
    size_t wrote = fwrite(data, 1, size, f);
    if (fclose(f) != 0 || wrote != size)
        return 0;
    char json[512];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": 4, \"height\": 4, \"spp\": 2, "
             "\"threads\": 1, \"depth\": true, \"region\": [1, 1, 3, 3], "
             "\"integrator\": \"path\", \"max_depth\": 3},"
             " \"background\": [0.5, 0.5, 0.5],"
             " \"objects\": [{\"type\": \"gltf\", \"file\": "
             "\"%s\", \"camera\": true}]}",
             path);
    lr_scene *scene = NULL;
    lr_error err;
    memset(&err, 0, sizeof err);
    int rc = 0;
    lr_status st = lr_scene_load_json(json, strlen(json), NULL, NULL, 0, &scene,
                                      &err);
    if (st != LR_OK) {
        rc = lr_fuzz_check_error("gltf", st, &err);
        if (rc == 0 && st != LR_ERR_NOMEM && strstr(err.message, path) == NULL)
            rc = lr_fuzz_report("gltf: the error does not name the file: %s",
                                err.message);
        if (rc == 0 && scene != NULL)
            rc = lr_fuzz_report("gltf: failed but returned a scene");
        return rc;
    }
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(scene, &cam);
    lr_scene_settings(scene, &rs);
    /* The file's aspect ratio may have changed the height; keep it tiny. */
    rs.height = 4;
    lr_image *img = NULL;
    st = lr_render(scene, &cam, &rs, &img, NULL, &err);
    if (st != LR_OK) {
        rc = lr_fuzz_check_error("gltf render", st, &err);
    } else {
        const float *rgb = lr_image_rgb(img);
        const float *z = lr_image_depth(img);
        for (int i = 0; rc == 0 && i < 12; i++)
            if (!isfinite(rgb[i]))
                rc = lr_fuzz_report("gltf render: pixel value %d is %g", i,
                                    (double)rgb[i]);
        for (int i = 0; rc == 0 && i < 4; i++)
            if (!isfinite(z[i]))
                rc = lr_fuzz_report("gltf render: depth %d is %g", i,
                                    (double)z[i]);
        lr_image_free(img);
    }
    lr_scene_free(scene);
    return rc;
}

LR_FUZZ_MAIN(lr_fuzz_gltf)
