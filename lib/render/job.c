/*
 * job.c: a render job as one JSON document (lensray.h, "Jobs"):
 *
 *   {"scene": "NAME" | {inline scene}, "camera": {...}, "render": {...},
 *    "output": {...}}
 *
 * The text is parsed once, here, into a cJSON tree that the job keeps;
 * the caller loads the scene (it owns the scenes directory and any cache)
 * and lr_job_apply then applies the camera, render and output members
 * from the same tree through the parsers the scene format uses
 * (apply_json.h), so a job accepts exactly the keys a scene file does and
 * nothing is printed back to text to be parsed again.  The one text made
 * here is an inline scene's compact form, which is both what the scene
 * loader reads and the key a cache can hash.
 */
#include "json/apply_json.h"
#include "json/json_util.h"
#include "util/scene_file.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct mesh_ref {
    const char *file;         /* into the tree */
    char field[LR__PATH_MAX]; /* "scene.objects[12].file" */
} mesh_ref;

struct lr_job {
    cJSON *root;
    const char *scene_name; /* into the tree, or NULL */
    char *scene_json;       /* compact text of an inline scene, or NULL */
    size_t scene_len;
    mesh_ref *meshes;
    size_t n_meshes, cap_meshes;
};

void lr_job_free(lr_job *job)
{
    if (job == NULL)
        return;
    cJSON_Delete(job->root);
    free(job->scene_json);
    free(job->meshes);
    free(job);
}

static lr_status add_file(lr_job *job, const cJSON *f, const char *field,
                          lr_error *err)
{
    if (!cJSON_IsString(f) || f->valuestring[0] == '\0')
        return LR_OK;
    if (job->n_meshes == job->cap_meshes) {
        size_t cap = job->cap_meshes ? 2 * job->cap_meshes : 8;
        mesh_ref *grown = realloc(job->meshes, cap * sizeof *grown);
        if (grown == NULL)
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        job->meshes = grown;
        job->cap_meshes = cap;
    }
    mesh_ref *m = &job->meshes[job->n_meshes++];
    m->file = f->valuestring;
    snprintf(m->field, sizeof m->field, "%s", field);
    return LR_OK;
}

/* Records every file an inline scene reads: each string under a key that
 * names a file (lr__scene_file_key: objects[i].file, environment.file,
 * textures, ...), wherever it stands, and camera.lens, whatever it is: a
 * path, an asset, or a plain name, which is the file of that name beside
 * the scene when there is one (through whatever link: lensrayd read a
 * link out of its scenes directory that way) and else a shipped lens.
 * Type errors are the scene loader's to report. */
static lr_status collect_files(lr_job *job, const cJSON *node, const char *path,
                               int depth, lr_error *err)
{
    size_t i = 0;
    for (const cJSON *c = node->child; c != NULL; c = c->next, i++) {
        char p[LR__PATH_MAX];
        if (cJSON_IsArray(node))
            lr__path_index(p, path, i);
        else
            lr__path_key(p, path, c->string);
        if (cJSON_IsString(c) && c->string != NULL) {
            int lens = depth == 1 && strcmp(c->string, "lens") == 0 &&
                       strcmp(path, "scene.camera") == 0;
            if (lens || lr__scene_file_key(c->string))
                LR_TRY(add_file(job, c, p, err));
        } else if (cJSON_IsObject(c) || cJSON_IsArray(c)) {
            LR_TRY(collect_files(job, c, p, depth + 1, err));
        }
    }
    return LR_OK;
}

/* Checks the top level's shape; fills the scene members of `job`. */
static lr_status check_shape(lr_job *job, lr_error *err)
{
    static const char *const keys[] = {"scene", "camera", "render", "output",
                                       NULL};
    static const char *const objects[] = {"camera", "render", "output", NULL};
    const cJSON *root = job->root;
    if (!cJSON_IsObject(root))
        return lr__fail(err, LR_ERR_INVALID, "",
                        "a job must be a JSON object: {\"scene\": ..., "
                        "\"camera\": {...}, \"render\": {...}, "
                        "\"output\": {...}}");
    LR_TRY(lr__json_check_keys(root, "", keys, err));
    for (size_t i = 0; objects[i] != NULL; i++) {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, objects[i]);
        if (v != NULL)
            LR_TRY(lr__json_object(v, objects[i], "", err));
    }
    /* The job's own camera.lens when it is an asset (a path is refused
     * there: lr_camera_apply_json), first, whatever the scene. */
    const cJSON *lens = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(root, "camera"), "lens");
    if (cJSON_IsString(lens) && strncmp(lens->valuestring, "sha256:", 7) == 0)
        LR_TRY(add_file(job, lens, "camera.lens", err));
    const cJSON *scene = cJSON_GetObjectItemCaseSensitive(root, "scene");
    if (cJSON_IsString(scene)) {
        job->scene_name = scene->valuestring;
        return LR_OK;
    }
    if (!cJSON_IsObject(scene))
        return lr__fail(err, LR_ERR_INVALID, "scene",
                        scene == NULL
                            ? "scene is required: the name of a scene or an "
                              "inline scene object"
                            : "scene must be the name of a scene or an "
                              "inline scene object");
    job->scene_json = cJSON_PrintUnformatted(scene);
    if (job->scene_json == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    job->scene_len = strlen(job->scene_json);
    return collect_files(job, scene, "scene", 0, err);
}

lr_status lr_job_parse(const char *json, size_t len, int max_depth,
                       lr_job **out, lr_error *err)
{
    if (out == NULL || (json == NULL && len > 0))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_job_parse: NULL argument");
    *out = NULL;
    if (len == 0)
        return lr__fail(err, LR_ERR_SYNTAX, "",
                        "the job is empty; it must be a JSON object");
    if (max_depth < 1 || max_depth > LR_MAX_JSON_DEPTH)
        max_depth = LR_MAX_JSON_DEPTH;
    size_t deep = lr__json_depth_at(json, len, max_depth);
    if (deep < len)
        return lr__fail(err, LR_ERR_LIMIT, "",
                        "the JSON nests deeper than %d levels (at byte %zu)",
                        max_depth, deep);
    lr_job *job = calloc(1, sizeof *job);
    if (job == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    /* Text that is not UTF-8 JSON, or has more after its value, is a
     * syntax error; the parser's message says where. */
    lr_status st = lr__json_parse(json, len, "job", "", &job->root, err);
    if (st == LR_ERR_INVALID && err != NULL)
        err->status = LR_ERR_SYNTAX;
    if (st == LR_ERR_INVALID)
        st = LR_ERR_SYNTAX;
    if (st == LR_OK)
        st = check_shape(job, err);
    if (st != LR_OK) {
        lr_job_free(job);
        return st;
    }
    *out = job;
    return LR_OK;
}

const char *lr_job_scene_name(const lr_job *job)
{
    return job ? job->scene_name : NULL;
}

const char *lr_job_scene_json(const lr_job *job, size_t *len)
{
    if (len != NULL)
        *len = job && job->scene_json ? job->scene_len : 0;
    return job ? job->scene_json : NULL;
}

int lr_job_mesh_file(const lr_job *job, size_t k, const char **file,
                     const char **field)
{
    if (job == NULL || k >= job->n_meshes)
        return 0;
    if (file != NULL)
        *file = job->meshes[k].file;
    if (field != NULL)
        *field = job->meshes[k].field;
    return 1;
}

lr_status lr_job_apply(const lr_job *job, lr_camera *cam, lr_render_settings *s,
                       lr_output *out, lr_error *err)
{
    if (job == NULL || cam == NULL || s == NULL || out == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_job_apply: NULL argument");
    const cJSON *root = job->root;
    const cJSON *render = cJSON_GetObjectItemCaseSensitive(root, "render");
    LR_TRY(lr__camera_apply_cjson(
        cam, cJSON_GetObjectItemCaseSensitive(root, "camera"), err));
    LR_TRY(lr__render_apply_cjson(s, render, err));
    LR_TRY(lr__output_apply_cjson(
        out, cJSON_GetObjectItemCaseSensitive(root, "output"), err));

    /* Depth: asked for by output.depth, else by the job's render.depth,
     * else by the scene.  A format without a Z channel refuses the job's
     * request (output.depth was refused by the output parser) and leaves
     * the scene's default out. */
    int has_z = lr_format_has_depth(out->format);
    int depth = s->want_depth && has_z;
    const cJSON *rd = cJSON_GetObjectItemCaseSensitive(render, "depth");
    if (out->depth_given) {
        depth = out->depth;
    } else if (cJSON_IsTrue(rd) && !has_z) {
        return lr__fail(err, LR_ERR_INVALID, "render.depth",
                        "render.depth: %s has no depth channel (use "
                        "\"output\": {\"format\": \"exr\"})",
                        lr_format_name(out->format));
    }
    s->want_depth = depth;
    out->depth = depth;
    out->options.exr_depth = depth;
    return LR_OK;
}
