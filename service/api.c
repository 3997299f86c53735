/*
 * api.c: what a job body means.  Turns the JSON of POST /v1/render and
 * POST /v1/jobs into a validated lrd_job_spec, and builds the scene
 * listing of GET /v1/scenes.
 *
 * The library reads the job (lr_job_parse: the text is parsed once, its
 * shape, nesting and UTF-8 checked there) and applies its camera, render
 * and output members on top of the scene's own values (lr_job_apply,
 * which validates each once), so the daemon accepts exactly the keys the
 * scene format does, including ones the library adds later.  What stays
 * here is the server's own policy: where scenes come from (the cache),
 * which mesh files an inline scene may reach, and the size limits.
 */
#include "lensrayd.h"

#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

void lrd_job_spec_clear(lrd_job_spec *spec)
{
    lrd_scene_release(spec->scene);
    spec->scene = NULL;
}

/* Whether `resolved` (absolute, symlinks resolved) lies strictly inside
 * the scenes directory (itself absolute and resolved, so "/" is the only
 * form that ends in a slash). */
static int inside_scenes_dir(const char *resolved)
{
    const char *dir = lrd_cfg.scenes_dir;
    size_t dl = strlen(dir);
    if (dl > 0 && dir[dl - 1] == '/')
        dl--;
    return strncmp(resolved, dir, dl) == 0 && resolved[dl] == '/' &&
           resolved[dl + 1] != '\0';
}

/* Whether the deepest directory of `joined` (the scenes directory, '/', a
 * relative path) that exists resolves outside the scenes directory: a
 * file that is not there through a link out ("etc/nope" with etc -> /etc)
 * is as forbidden as one that is, so that the answer tells nothing of
 * what exists outside. */
static int parent_outside(const char *joined)
{
    char buf[PATH_MAX + 64], res[PATH_MAX];
    snprintf(buf, sizeof buf, "%s", joined);
    size_t base = strlen(lrd_cfg.scenes_dir);
    for (char *slash;
         (slash = strrchr(buf, '/')) != NULL && (size_t)(slash - buf) > base;) {
        *slash = '\0';
        if (realpath(buf, res) != NULL)
            return strcmp(res, lrd_cfg.scenes_dir) != 0 &&
                   !inside_scenes_dir(res);
    }
    return 0;
}

/* Inline scenes may only use mesh files inside the scenes directory: no
 * absolute paths, no ".." components, and no symbolic link that resolves
 * outside it.  A missing file, or one that is not a regular file (a
 * directory, the scenes directory itself), is reported here too, so that
 * the error does not show the server's directory layout. */
static int check_mesh_path(const char *file, const char *field, lrd_err *e)
{
    if (file[0] == '/')
        return lrd_fail(e, 422, "forbidden_path", field,
                        "%s must be a path relative to the scenes "
                        "directory, not an absolute path",
                        field);
    for (const char *p = file; *p != '\0';) {
        const char *slash = strchr(p, '/');
        size_t n = slash ? (size_t)(slash - p) : strlen(p);
        if (n == 2 && p[0] == '.' && p[1] == '.')
            return lrd_fail(e, 422, "forbidden_path", field,
                            "%s must stay inside the scenes directory: "
                            "\"..\" is not allowed",
                            field);
        p += n;
        if (*p == '/')
            p++;
    }
    char joined[PATH_MAX + 64];
    snprintf(joined, sizeof joined, "%s/%s", lrd_cfg.scenes_dir, file);
    char resolved[PATH_MAX];
    struct stat st;
    int there = realpath(joined, resolved) != NULL && stat(resolved, &st) == 0;
    /* Whether a path through a link out exists, and what it is, was told
     * by the message ("no file", "a directory", forbidden): anything that
     * leads outside is forbidden, there or not.  The scenes directory
     * itself ("." ) is inside for this, and a directory below. */
    if (there ? strcmp(resolved, lrd_cfg.scenes_dir) != 0 &&
                    !inside_scenes_dir(resolved)
              : parent_outside(joined))
        return lrd_fail(e, 422, "forbidden_path", field,
                        "%s must stay inside the scenes directory (it "
                        "leads outside through a symbolic link)",
                        field);
    if (!there)
        return lrd_fail(e, 422, "invalid_value", field,
                        "%s: there is no file \"%s\" in the scenes "
                        "directory",
                        field, file);
    if (!S_ISREG(st.st_mode))
        return lrd_fail(e, 422, "invalid_value", field,
                        "%s: \"%s\" is a directory, not a file", field, file);
    return 0;
}

/* A lens named plainly in an inline scene is the file of that name in
 * the scenes directory when there is one (the library looks there
 * first), else a shipped lens: only the first is checked. */
static int shipped_lens_name(const char *file, const char *field)
{
    size_t n = strlen(field);
    if (n < 5 || strcmp(field + n - 5, ".lens") != 0 ||
        strchr(file, '/') != NULL || strncmp(file, "sha256:", 7) == 0)
        return 0;
    char joined[PATH_MAX + 64];
    struct stat st;
    snprintf(joined, sizeof joined, "%s/%s", lrd_cfg.scenes_dir, file);
    return lstat(joined, &st) != 0;
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

/* An inline scene (of a job, or read from a scene asset): its files are
 * checked first, each an asset the server has or a file inside the
 * scenes directory; the library finds both (lr_assets_dir_set).  NULL
 * with *e filled on error. */
static lrd_scene *inline_scene(const lr_job *job, lrd_err *e)
{
    const char *file, *field;
    for (size_t k = 0; lr_job_mesh_file(job, k, &file, &field); k++)
        if (!shipped_lens_name(file, field) &&
            (strncmp(file, "sha256:", 7) == 0
                 ? lrd_asset_check_ref(file, field, e)
                 : check_mesh_path(file, field, e)) != 0)
            return NULL;
    size_t len = 0;
    const char *text = lr_job_scene_json(job, &len);
    return lrd_scene_inline(text, len, e);
}

/* "scene": "sha256:HEX": a scene file sent as an asset, read as an
 * inline scene would be (its own files are assets or inside the scenes
 * directory, never beside it).  NULL with *e filled on error. */
static lrd_scene *asset_scene(const char *ref, lrd_err *e)
{
    if (lrd_asset_check_ref(ref, "scene", e) != 0)
        return NULL;
    char path[PATH_MAX + 80];
    snprintf(path, sizeof path, "%s/%s", lrd_cfg.assets_dir, ref + 7);
    size_t len = 0;
    char *text = lrd_read_file(path, LRD_MAX_SCENE_FILE, &len);
    /* {"scene": TEXT}: a job whose scene is the file, so that its files
     * are listed by the same rule as an inline scene's. */
    char *wrapped = text ? malloc(len + 16) : NULL;
    if (wrapped == NULL) {
        free(text);
        lrd_fail(e, 500, "scene_broken", "scene",
                 "scene: the asset %s cannot be read", ref);
        return NULL;
    }
    if (len == 0) {
        free(text);
        free(wrapped);
        lrd_fail(e, 422, "invalid_value", "scene",
                 "scene: the asset %s is not a scene: it is empty (0 bytes)",
                 ref);
        return NULL;
    }
    /* The text alone first: a syntax error's line and column (or a
     * nesting's byte), or text after the value, are then the asset's
     * own, not the wrapper's (which took the text after a scene object
     * for more of the job). */
    lr_job *job = NULL;
    lr_error le;
    lr_status st = lr_job_parse(text, len, (int)lrd_cfg.max_json_depth, &job,
                                &le);
    lr_job_free(job);
    job = NULL;
    if (st == LR_ERR_SYNTAX || st == LR_ERR_LIMIT) {
        free(text);
        free(wrapped);
        /* The parser heads its message with "job", which this is not. */
        const char *m = le.message;
        if (strncmp(m, "job: ", 5) == 0)
            m += 5;
        lrd_fail(e, 422, "invalid_value", "scene",
                 "scene: the asset %s is not a scene: %s", ref, m);
        return NULL;
    }
    int n = snprintf(wrapped, len + 16, "{\"scene\": %.*s\n}", (int)len, text);
    free(text);
    st = lr_job_parse(wrapped, (size_t)n, (int)lrd_cfg.max_json_depth, &job,
                      &le);
    free(wrapped);
    if (st == LR_OK && lr_job_scene_name(job) != NULL) {
        /* A JSON string: a name, not a scene; never followed further. */
        st = LR_ERR_INVALID;
        snprintf(le.message, sizeof le.message,
                 "it is a JSON string, not "
                 "a scene object");
    }
    if (st != LR_OK) {
        lr_job_free(job);
        lrd_fail(e, 422, "invalid_value", "scene",
                 "scene: the asset %s is "
                 "not a scene: %s",
                 ref, le.message);
        return NULL;
    }
    lrd_scene *s = inline_scene(job, e);
    lr_job_free(job);
    return s;
}

/* The job's scene: a named one from the cache, a scene asset, or an
 * inline one.  NULL with *e filled on error. */
static lrd_scene *job_scene(const lr_job *job, lrd_job_spec *spec, lrd_err *e)
{
    const char *name = lr_job_scene_name(job);
    if (name == NULL)
        return inline_scene(job, e);
    snprintf(spec->scene_name, sizeof spec->scene_name, "%s", name);
    if (strncmp(name, "sha256:", 7) == 0)
        return asset_scene(name, e);
    return lrd_scene_named(name, e);
}

int lrd_api_parse_job(const char *body, size_t len, lrd_job_spec *spec,
                      lrd_err *e)
{
    memset(spec, 0, sizeof *spec);
    lr_job *job = NULL;
    lr_error le;
    lr_status st = lr_job_parse(body, len, (int)lrd_cfg.max_json_depth, &job,
                                &le);
    /* Text that is JSON but not data (a number beyond a double, a
     * string that is not UTF-8) has the field's path: give it. */
    if (st == LR_ERR_SYNTAX)
        return lrd_fail(e, 400, "malformed_json",
                        le.path[0] != '\0' ? le.path : NULL, "%s", le.message);
    if (st == LR_ERR_LIMIT)
        return lrd_fail(e, 400, "too_deep", NULL, "%s (--max-json-depth)",
                        le.message);
    if (st != LR_OK)
        return lrd_fail_lr(e, &le, NULL, NULL);

    int rc = -1;
    /* The job's own lens asset (lr_job_mesh_file lists it first, as
     * "camera.lens"): a missing one is asset_not_found, as an inline
     * scene's is (it was invalid_value, from the lens loader). */
    const char *file, *field;
    for (size_t k = 0; lr_job_mesh_file(job, k, &file, &field); k++)
        if (strncmp(field, "scene", 5) != 0 &&
            lrd_asset_check_ref(file, field, e) != 0)
            goto out;
    spec->scene = job_scene(job, spec, e);
    if (spec->scene == NULL)
        goto out;
    lr_scene_camera(lrd_scene_get(spec->scene), &spec->cam);
    lr_scene_settings(lrd_scene_get(spec->scene), &spec->rs);
    lr_output_default(&spec->out);
    if (lr_job_apply(job, &spec->cam, &spec->rs, &spec->out, &le) != LR_OK) {
        lrd_fail_lr(e, &le, NULL, NULL);
        goto out;
    }
    if (check_limits(spec, e) != 0)
        goto out;
    rc = 0;
out:
    lr_job_free(job);
    if (rc != 0)
        lrd_job_spec_clear(spec);
    return rc;
}

/* ---- GET /v1/scenes ------------------------------------------------------ */

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
            fprintf(stderr, "lensrayd: scene %s is unavailable: %s\n", names[i],
                    se.message);
            free(names[i]);
            continue;
        }
        const lr_scene *sc = lrd_scene_get(s);
        lr_camera cam;
        lr_render_settings rs;
        lr_scene_camera(sc, &cam);
        lr_scene_settings(sc, &rs);
        char *cam_json = lr_camera_json(&cam);
        char *rs_json = lr_render_settings_json(&rs);
        cJSON *item = cam_json && rs_json ? cJSON_CreateObject() : NULL;
        if (item == NULL) {
            lr_free(cam_json);
            lr_free(rs_json);
            lrd_scene_release(s);
            for (size_t k = i; k < n; k++)
                free(names[k]);
            free(names);
            cJSON_Delete(root);
            lrd_fail(e, 503, "out_of_memory", NULL, "out of memory");
            return NULL;
        }
        cJSON_AddStringToObject(item, "name", names[i]);
        cJSON_AddStringToObject(item, "description", lr_scene_description(sc));
        /* The library's own JSON of what it loaded, embedded as it is. */
        cJSON_AddRawToObject(item, "camera", cam_json);
        cJSON_AddRawToObject(item, "render", rs_json);
        lr_free(cam_json);
        lr_free(rs_json);
        cJSON_AddNumberToObject(item, "primitives",
                                (double)lr_scene_primitive_count(sc));
        cJSON_AddItemToArray(arr, item);
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
