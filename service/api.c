/*
 * api.c: what a job body means.  Turns the JSON of POST /v1/render and
 * POST /v1/jobs into a validated lrd_job_spec:
 *
 *   {"scene": "cornell" | {inline scene},
 *    "camera": {...overrides...}, "render": {...overrides...},
 *    "output": {"format": "png" | "exr", "bit_depth": 8 | 16,
 *               "half": bool, "depth": bool}}
 *
 * The camera and render keys go through lr_camera_apply_json and
 * lr_render_settings_apply_json on top of the scene's own defaults
 * (lr_scene_camera, lr_scene_settings), so the daemon accepts exactly the
 * keys the scene format does, including ones the library adds later.
 * Also builds the scene listing of GET /v1/scenes.
 */
#include "lensrayd.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void lrd_job_spec_clear(lrd_job_spec *spec)
{
    lrd_scene_release(spec->scene);
    spec->scene = NULL;
}

int lrd_api_check_depth(const char *body, size_t len, long max_depth,
                        lrd_err *e)
{
    /* A linear scan that only tracks strings and brackets, so that a body
     * of a million '[' never reaches cJSON's recursive parser. */
    long depth = 0;
    int in_string = 0, escaped = 0;
    for (size_t i = 0; i < len; i++) {
        char c = body[i];
        if (in_string) {
            if (escaped)
                escaped = 0;
            else if (c == '\\')
                escaped = 1;
            else if (c == '"')
                in_string = 0;
        } else if (c == '"') {
            in_string = 1;
        } else if (c == '{' || c == '[') {
            if (++depth > max_depth)
                return lrd_fail(e, 400, "too_deep", NULL,
                                "the JSON body nests deeper than %ld levels "
                                "(at byte %zu; --max-json-depth)",
                                max_depth, i);
        } else if (c == '}' || c == ']') {
            depth--;
        }
    }
    return 0;
}

/* The offset of the first byte of `s` (len bytes) that does not start a
 * valid UTF-8 sequence (RFC 3629: shortest form, no surrogates, at most
 * U+10FFFF), or len if all of it is valid. */
static size_t utf8_invalid_at(const char *s, size_t len)
{
    const unsigned char *p = (const unsigned char *)s;
    size_t i = 0;
    while (i < len) {
        unsigned c = p[i];
        size_t n;
        unsigned min, cp;
        if (c < 0x80) {
            i++;
            continue;
        }
        if (c >= 0xC2 && c <= 0xDF)
            n = 1, min = 0x80;
        else if (c >= 0xE0 && c <= 0xEF)
            n = 2, min = 0x800;
        else if (c >= 0xF0 && c <= 0xF4)
            n = 3, min = 0x10000;
        else
            return i;
        if (i + n >= len)
            return i;
        cp = c & (0x3Fu >> n);
        for (size_t k = 1; k <= n; k++) {
            if ((p[i + k] & 0xC0) != 0x80)
                return i;
            cp = (cp << 6) | (p[i + k] & 0x3Fu);
        }
        if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF))
            return i;
        i += n + 1;
    }
    return len;
}

/* Checks an object's keys against a list and for duplicates; `prefix`
 * names the object in the path ("" for the top level). */
static int check_keys(const cJSON *obj, const char *prefix,
                      const char *const *allowed, lrd_err *e)
{
    for (const cJSON *c = obj->child; c != NULL; c = c->next) {
        const char *k = c->string ? c->string : "";
        char path[300];
        if (prefix[0] != '\0')
            snprintf(path, sizeof path, "%s.%s", prefix, k);
        else
            snprintf(path, sizeof path, "%s", k);
        lrd_utf8_trim(path);
        int ok = 0;
        for (size_t i = 0; allowed[i] != NULL; i++)
            if (strcmp(k, allowed[i]) == 0)
                ok = 1;
        if (!ok) {
            char list[256] = "";
            size_t used = 0;
            for (size_t i = 0; allowed[i] != NULL && used < sizeof list; i++)
                used += (size_t)snprintf(list + used, sizeof list - used,
                                         "%s%s", i ? ", " : "", allowed[i]);
            return lrd_fail(e, 422, "invalid_value", path,
                            "%s: unknown key \"%s\" (expected one of: %s)",
                            path, k, list);
        }
        for (const cJSON *d = c->next; d != NULL; d = d->next)
            if (d->string != NULL && strcmp(d->string, k) == 0)
                return lrd_fail(e, 422, "invalid_value", path,
                                "%s: duplicate key \"%s\"", path, k);
    }
    return 0;
}

/* Inline scenes may only use mesh files inside the scenes directory: no
 * absolute paths, no ".." components, and no symbolic link that resolves
 * outside it.  A missing file is reported here too, so that the error does
 * not show the server's directory layout. */
static int check_mesh_paths(const cJSON *scene, lrd_err *e)
{
    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(scene, "objects");
    if (!cJSON_IsArray(objs))
        return 0; /* the library reports the type error */
    int i = 0;
    for (const cJSON *o = objs->child; o != NULL; o = o->next, i++) {
        const cJSON *f = cJSON_GetObjectItemCaseSensitive(o, "file");
        if (!cJSON_IsString(f) || f->valuestring[0] == '\0')
            continue;
        const char *file = f->valuestring;
        char path[64];
        snprintf(path, sizeof path, "scene.objects[%d].file", i);
        if (file[0] == '/')
            return lrd_fail(e, 422, "forbidden_path", path,
                            "%s must be a path relative to the scenes "
                            "directory, not an absolute path",
                            path);
        for (const char *p = file; *p != '\0';) {
            const char *slash = strchr(p, '/');
            size_t n = slash ? (size_t)(slash - p) : strlen(p);
            if (n == 2 && p[0] == '.' && p[1] == '.')
                return lrd_fail(e, 422, "forbidden_path", path,
                                "%s must stay inside the scenes directory: "
                                "\"..\" is not allowed",
                                path);
            p += n;
            if (*p == '/')
                p++;
        }
        char joined[PATH_MAX + 64];
        snprintf(joined, sizeof joined, "%s/%s", lrd_cfg.scenes_dir, file);
        char resolved[PATH_MAX];
        if (realpath(joined, resolved) == NULL)
            return lrd_fail(e, 422, "invalid_value", path,
                            "%s: there is no mesh file \"%s\" in the scenes "
                            "directory",
                            path, file);
        size_t dl = strlen(lrd_cfg.scenes_dir);
        if (strncmp(resolved, lrd_cfg.scenes_dir, dl) != 0 ||
            resolved[dl] != '/')
            return lrd_fail(e, 422, "forbidden_path", path,
                            "%s must stay inside the scenes directory (it "
                            "leads outside through a symbolic link)",
                            path);
    }
    return 0;
}

static int parse_output(const cJSON *o, lrd_job_spec *spec, lrd_err *e)
{
    static const char *const keys[] = {"format", "bit_depth", "half",
                                       "depth", NULL};
    spec->format = LR_FORMAT_PNG;
    lr_output_options_default(&spec->out);
    int depth = spec->rs.want_depth;
    if (o == NULL) {
        spec->rs.want_depth = 0;
        return 0;
    }
    if (!cJSON_IsObject(o))
        return lrd_fail(e, 422, "invalid_value", "output",
                        "output must be an object like {\"format\": "
                        "\"png\"}");
    if (check_keys(o, "output", keys, e) != 0)
        return -1;
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(o, "format");
    if (fmt != NULL) {
        if (cJSON_IsString(fmt) && strcmp(fmt->valuestring, "png") == 0)
            spec->format = LR_FORMAT_PNG;
        else if (cJSON_IsString(fmt) && strcmp(fmt->valuestring, "exr") == 0)
            spec->format = LR_FORMAT_EXR;
        else
            return lrd_fail(e, 422, "invalid_value", "output.format",
                            "output.format must be \"png\" or \"exr\"");
    }
    int png = spec->format == LR_FORMAT_PNG;
    const cJSON *bd = cJSON_GetObjectItemCaseSensitive(o, "bit_depth");
    if (bd != NULL) {
        if (!png)
            return lrd_fail(e, 422, "invalid_value", "output.bit_depth",
                            "output.bit_depth applies to png only");
        if (!cJSON_IsNumber(bd) ||
            (bd->valuedouble != 8 && bd->valuedouble != 16))
            return lrd_fail(e, 422, "invalid_value", "output.bit_depth",
                            "output.bit_depth must be 8 or 16");
        spec->out.png_16bit = bd->valuedouble == 16;
    }
    const cJSON *half = cJSON_GetObjectItemCaseSensitive(o, "half");
    if (half != NULL) {
        if (png)
            return lrd_fail(e, 422, "invalid_value", "output.half",
                            "output.half applies to exr only");
        if (!cJSON_IsBool(half))
            return lrd_fail(e, 422, "invalid_value", "output.half",
                            "output.half must be true or false");
        spec->out.exr_half = cJSON_IsTrue(half);
    }
    const cJSON *dp = cJSON_GetObjectItemCaseSensitive(o, "depth");
    if (dp != NULL) {
        if (png)
            return lrd_fail(e, 422, "invalid_value", "output.depth",
                            "output.depth applies to exr only (png has no "
                            "depth channel)");
        if (!cJSON_IsBool(dp))
            return lrd_fail(e, 422, "invalid_value", "output.depth",
                            "output.depth must be true or false");
        depth = cJSON_IsTrue(dp);
    }
    /* A Z channel is rendered only when it is written. */
    spec->rs.want_depth = png ? 0 : depth;
    spec->out.exr_depth = spec->rs.want_depth;
    return 0;
}

/* Applies a "camera" or "render" member through the library. */
static int apply_member(const cJSON *v, lrd_job_spec *spec, int camera,
                        lrd_err *e)
{
    char *text = lrd_json_print(v);
    if (text == NULL)
        return lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
    lr_error le;
    lr_status st = camera ? lr_camera_apply_json(&spec->cam, text,
                                                 strlen(text), &le)
                          : lr_render_settings_apply_json(&spec->rs, text,
                                                          strlen(text), &le);
    free(text);
    if (st != LR_OK)
        return lrd_fail_lr(e, &le, NULL, 0);
    return 0;
}

static int check_limits(lrd_job_spec *spec, lrd_err *e)
{
    const lr_render_settings *rs = &spec->rs;
    int x0 = 0, y0 = 0, x1 = rs->width, y1 = rs->height;
    int cropped = (rs->region[0] | rs->region[1] | rs->region[2] |
                   rs->region[3]) != 0;
    if (cropped) {
        x0 = rs->region[0], y0 = rs->region[1];
        x1 = rs->region[2], y1 = rs->region[3];
    }
    spec->width = x1 - x0;
    spec->height = y1 - y0;
    uint64_t pixels = (uint64_t)spec->width * (uint64_t)spec->height;
    if (pixels > lrd_cfg.max_pixels)
        return lrd_fail(e, 413, "image_too_large",
                        cropped ? "render.region" : "render.width",
                        "the image would have %llu pixels (%d x %d), more "
                        "than the limit of %llu (--max-pixels); render it "
                        "in parts with render.region",
                        (unsigned long long)pixels, spec->width, spec->height,
                        (unsigned long long)lrd_cfg.max_pixels);
    spec->samples = pixels * (uint64_t)rs->spp;
    if (spec->samples > lrd_cfg.max_samples)
        return lrd_fail(e, 413, "too_many_samples", "render.spp",
                        "the job would take %llu samples (%llu pixels x "
                        "%d spp), more than the limit of %llu "
                        "(--max-samples)",
                        (unsigned long long)spec->samples,
                        (unsigned long long)pixels, rs->spp,
                        (unsigned long long)lrd_cfg.max_samples);
    return 0;
}

int lrd_api_parse_job(const char *body, size_t len, lrd_job_spec *spec,
                      lrd_err *e)
{
    static const char *const keys[] = {"scene", "camera", "render", "output",
                                       NULL};
    memset(spec, 0, sizeof *spec);
    if (len == 0)
        return lrd_fail(e, 400, "malformed_json", NULL,
                        "the body is empty; it must be a JSON job object");
    if (lrd_api_check_depth(body, len, lrd_cfg.max_json_depth, e) != 0)
        return -1;
    /* JSON text is UTF-8 (RFC 8259), and error messages echo keys and
     * names back inside JSON: bytes that are not UTF-8 would make those
     * answers invalid JSON, so they are refused here, before parsing. */
    size_t bad = utf8_invalid_at(body, len);
    if (bad < len)
        return lrd_fail(e, 400, "malformed_json", NULL,
                        "the body is not valid UTF-8 (at byte %zu)", bad);
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(body, len, &end, 0);
    if (root == NULL) {
        size_t at = end != NULL && end >= body ? (size_t)(end - body) : 0;
        return lrd_fail(e, 400, "malformed_json", NULL,
                        "the body is not valid JSON (near byte %zu)", at);
    }
    for (const char *p = end; p != NULL && p < body + len; p++)
        if (*p != ' ' && *p != '\t' && *p != '\r' && *p != '\n') {
            cJSON_Delete(root);
            return lrd_fail(e, 400, "malformed_json", NULL,
                            "the body has text after its JSON value (at "
                            "byte %zu)",
                            (size_t)(p - body));
        }

    int rc = -1;
    if (!cJSON_IsObject(root)) {
        lrd_fail(e, 422, "invalid_value", NULL,
                 "the body must be a JSON object: {\"scene\": ..., "
                 "\"camera\": {...}, \"render\": {...}, \"output\": {...}}");
        goto out;
    }
    if (check_keys(root, "", keys, e) != 0)
        goto out;

    const cJSON *scene = cJSON_GetObjectItemCaseSensitive(root, "scene");
    if (cJSON_IsString(scene)) {
        spec->scene = lrd_scene_named(scene->valuestring, e);
        snprintf(spec->scene_name, sizeof spec->scene_name, "%s",
                 scene->valuestring);
    } else if (cJSON_IsObject(scene)) {
        if (check_mesh_paths(scene, e) != 0)
            goto out;
        char *text = lrd_json_print(scene);
        if (text == NULL) {
            lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
            goto out;
        }
        spec->scene = lrd_scene_inline(text, strlen(text), e);
        free(text);
    } else {
        lrd_fail(e, 422, "invalid_value", "scene",
                 scene == NULL ? "scene is required: the name of a scene "
                                 "(GET /v1/scenes) or an inline scene object"
                               : "scene must be the name of a scene or an "
                                 "inline scene object");
        goto out;
    }
    if (spec->scene == NULL)
        goto out;

    lr_scene_camera(lrd_scene_get(spec->scene), &spec->cam);
    lr_scene_settings(lrd_scene_get(spec->scene), &spec->rs);
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    if (cam != NULL && apply_member(cam, spec, 1, e) != 0)
        goto out;
    const cJSON *ren = cJSON_GetObjectItemCaseSensitive(root, "render");
    if (ren != NULL && apply_member(ren, spec, 0, e) != 0)
        goto out;
    if (parse_output(cJSON_GetObjectItemCaseSensitive(root, "output"), spec,
                     e) != 0)
        goto out;

    /* The scene and the overrides were each validated; the combination
     * (a region that fits the new size, say) is checked once more. */
    lr_error le;
    if (lr_camera_validate(&spec->cam, &le) != LR_OK ||
        lr_render_settings_validate(&spec->rs, &le) != LR_OK) {
        lrd_fail_lr(e, &le, NULL, 0);
        goto out;
    }
    if (check_limits(spec, e) != 0)
        goto out;
    rc = 0;
out:
    cJSON_Delete(root);
    if (rc != 0)
        lrd_job_spec_clear(spec);
    return rc;
}

/* ---- GET /v1/scenes ------------------------------------------------------ */

static void set_item(cJSON *obj, const char *key, cJSON *item)
{
    if (item == NULL)
        return;
    if (cJSON_GetObjectItemCaseSensitive(obj, key) != NULL)
        cJSON_ReplaceItemInObjectCaseSensitive(obj, key, item);
    else
        cJSON_AddItemToObject(obj, key, item);
}

/* A copy of the file's own object (so that keys this code does not know
 * about, which the library may add later, still show), with the values
 * the library actually loaded put over it. */
static cJSON *start_from(const cJSON *file_root, const char *key)
{
    const cJSON *raw = cJSON_GetObjectItemCaseSensitive(file_root, key);
    if (cJSON_IsObject(raw))
        return cJSON_Duplicate(raw, 1);
    return cJSON_CreateObject();
}

static cJSON *camera_json(const lr_camera *c, const cJSON *file_root)
{
    cJSON *o = start_from(file_root, "camera");
    if (o == NULL)
        return NULL;
    if (c->model == LR_CAMERA_PINHOLE)
        set_item(o, "model", cJSON_CreateString("pinhole"));
    set_item(o, "position", cJSON_CreateDoubleArray(c->position, 3));
    set_item(o, "look_at", cJSON_CreateDoubleArray(c->look_at, 3));
    set_item(o, "up", cJSON_CreateDoubleArray(c->up, 3));
    set_item(o, "fov", cJSON_CreateNumber(c->fov));
    return o;
}

static cJSON *render_json(const lr_render_settings *s,
                          const cJSON *file_root)
{
    cJSON *o = start_from(file_root, "render");
    if (o == NULL)
        return NULL;
    set_item(o, "width", cJSON_CreateNumber(s->width));
    set_item(o, "height", cJSON_CreateNumber(s->height));
    set_item(o, "spp", cJSON_CreateNumber(s->spp));
    set_item(o, "max_depth", cJSON_CreateNumber(s->max_depth));
    set_item(o, "seed", cJSON_CreateNumber((double)s->seed));
    return o;
}

static int name_cmp(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The stems of DIR/NAME.json with a valid NAME, sorted; malloc'ed. */
static char **list_names(size_t *n)
{
    *n = 0;
    DIR *d = opendir(lrd_cfg.scenes_dir);
    if (d == NULL)
        return NULL;
    char **names = NULL;
    size_t cap = 0;
    struct dirent *de;
    for (de = readdir(d); de != NULL; de = readdir(d)) {
        size_t l = strlen(de->d_name);
        if (l <= 5 || l > 64 + 5 || strcmp(de->d_name + l - 5, ".json") != 0)
            continue;
        int ok = 1;
        for (size_t i = 0; i < l - 5; i++) {
            char c = de->d_name[i];
            if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                  (c >= '0' && c <= '9') || c == '_' || c == '-'))
                ok = 0;
        }
        if (!ok)
            continue;
        if (*n == cap) {
            cap = cap ? 2 * cap : 16;
            char **grown = realloc(names, cap * sizeof *names);
            if (grown == NULL)
                break;
            names = grown;
        }
        names[*n] = strndup(de->d_name, l - 5);
        if (names[*n] == NULL)
            break;
        (*n)++;
    }
    closedir(d);
    if (*n > 0)
        qsort(names, *n, sizeof *names, name_cmp);
    return names;
}

char *lrd_api_scenes_json(lrd_err *e)
{
    size_t n = 0;
    char **names = list_names(&n);
    cJSON *root = cJSON_CreateObject();
    cJSON *arr = cJSON_AddArrayToObject(root, "scenes");
    if (arr == NULL) {
        cJSON_Delete(root);
        for (size_t i = 0; i < n; i++)
            free(names[i]);
        free(names);
        lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
        return NULL;
    }
    for (size_t i = 0; i < n; i++) {
        lrd_err se;
        lrd_scene *s = lrd_scene_named(names[i], &se);
        if (s == NULL) {
            /* A broken file is the operator's problem: it is logged and
             * left out rather than failing the whole listing. */
            fprintf(stderr, "lensrayd: scene %s is unavailable: %s\n",
                    names[i], se.message);
            free(names[i]);
            continue;
        }
        char path[PATH_MAX + 80];
        snprintf(path, sizeof path, "%s/%s.json", lrd_cfg.scenes_dir,
                 names[i]);
        size_t len = 0;
        char *text = lrd_read_file(path, LRD_MAX_SCENE_FILE, &len);
        cJSON *file_root = text ? cJSON_ParseWithLength(text, len) : NULL;
        free(text);
        lr_camera cam;
        lr_render_settings rs;
        lr_scene_camera(lrd_scene_get(s), &cam);
        lr_scene_settings(lrd_scene_get(s), &rs);
        cJSON *item = cJSON_CreateObject();
        cJSON_AddStringToObject(item, "name", names[i]);
        const cJSON *desc =
            cJSON_GetObjectItemCaseSensitive(file_root, "description");
        if (cJSON_IsString(desc))
            cJSON_AddStringToObject(item, "description", desc->valuestring);
        else
            cJSON_AddStringToObject(item, "description", "");
        cJSON_AddItemToObject(item, "camera", camera_json(&cam, file_root));
        cJSON_AddItemToObject(item, "render", render_json(&rs, file_root));
        cJSON_AddNumberToObject(
            item, "primitives",
            (double)lr_scene_primitive_count(lrd_scene_get(s)));
        cJSON_AddItemToArray(arr, item);
        cJSON_Delete(file_root);
        lrd_scene_release(s);
        free(names[i]);
    }
    free(names);
    char *out = lrd_json_print(root);
    cJSON_Delete(root);
    if (out == NULL)
        lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
    return out;
}
