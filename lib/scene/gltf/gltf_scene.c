/*
 * gltf_scene.c: a glTF file alone as a scene (`lensray render x.glb`):
 * the file placed by a scene that lensray writes for it (gltf.h), and
 * that scene's text for a client that sends it on (lr_gltf_scene_json).
 */
#include "scene/gltf/gltf.h"
#include "scene/light.h"
#include "scene/scene_load.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static int ends_with(const char *s, const char *tail)
{
    size_t n = strlen(s), k = strlen(tail);
    return n >= k && strcasecmp(s + n - k, tail) == 0;
}

int lr__gltf_is_file(const char *path)
{
    if (!ends_with(path, ".gltf") && !ends_with(path, ".glb"))
        return 0;
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return 0;
    unsigned char b[64];
    size_t n = fread(b, 1, sizeof b, f);
    fclose(f);
    if (n >= 4 && memcmp(b, "glTF", 4) == 0)
        return 1;
    size_t i = n >= 3 && memcmp(b, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0;
    while (i < n &&
           (b[i] == ' ' || b[i] == '\t' || b[i] == '\r' || b[i] == '\n'))
        i++;
    return i < n && b[i] == '{';
}

/* The JSON of the scene around the file `name`, with a background when
 * `bg` is not NULL. */
static char *scene_text(const char *name, const lr__v3 *bg)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *render = cJSON_AddObjectToObject(root, "render");
    cJSON *objs = cJSON_AddArrayToObject(root, "objects");
    cJSON *o = cJSON_CreateObject();
    char *text = NULL;
    int ok = render && objs && o && cJSON_AddItemToArray(objs, o) &&
             cJSON_AddStringToObject(render, "integrator", "path") &&
             cJSON_AddStringToObject(o, "type", "gltf") &&
             cJSON_AddStringToObject(o, "file", name) &&
             cJSON_AddTrueToObject(o, "camera");
    if (ok && bg != NULL) {
        /* cJSON prints a double with enough digits to read it back. */
        const double c[3] = {bg->x, bg->y, bg->z};
        cJSON *a = cJSON_CreateDoubleArray(c, 3);
        ok = a != NULL && cJSON_AddItemToObject(root, "background", a);
        if (a != NULL && !ok)
            cJSON_Delete(a);
    }
    if (ok)
        text = cJSON_PrintUnformatted(root);
    else if (o != NULL && (objs == NULL || objs->child != o))
        cJSON_Delete(o);
    cJSON_Delete(root);
    return text;
}

static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

char *lr_gltf_scene_json(const char *path, const lr_scene *s)
{
    if (path == NULL || s == NULL || !lr__gltf_is_file(path))
        return NULL;
    return scene_text(base_name(path), &s->background);
}

lr_status lr__gltf_scene_load(const char *path, const char *const *overrides,
                              size_t n_overrides, lr__render_reader rd,
                              lr_scene **out, lr_error *err)
{
    char dir[4096];
    lr__dir_of(path, dir, sizeof dir);
    char *text = scene_text(base_name(path), NULL);
    if (text == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    lr_status st = lr__scene_load_json(text, strlen(text), dir, overrides,
                                       n_overrides, rd, out, err);
    free(text);
    /* The scene is lensray's, not the user's: its field is no help. */
    static const char field[] = "objects[0].file: ";
    if (st != LR_OK && err != NULL &&
        strncmp(err->message, field, sizeof field - 1) == 0) {
        memmove(err->message, err->message + sizeof field - 1,
                strlen(err->message) - (sizeof field - 1) + 1);
        err->path[0] = '\0';
    }
    if (st != LR_OK)
        return st;
    /* A file without lights of its own is lit by a uniform white sky,
     * unless an override says what the background is. */
    int set = 0;
    for (size_t i = 0; i < n_overrides; i++)
        set |= strncmp(overrides[i], "background", 10) == 0 ||
               strncmp(overrides[i], "environment", 11) == 0;
    if (!set && (*out)->n_lights == 0 && !lr__scene_emits(*out))
        (*out)->background = v3(1, 1, 1);
    return LR_OK;
}
