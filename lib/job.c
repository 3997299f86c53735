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
#include "apply_json.h"
#include "json_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct mesh_ref {
    const char *file; /* into the tree */
    /* "scene.objects[12].file", "scene.materials.NAME.diffuse_texture" */
    char field[LR__PATH_MAX];
} mesh_ref;

struct lr_job {
    cJSON *root;
    const char *scene_name;   /* into the tree, or NULL */
    char *scene_json;         /* compact text of an inline scene, or NULL */
    size_t scene_len;
    mesh_ref *meshes;
    size_t n_meshes;
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

static void add_file(lr_job *job, const cJSON *f, const char *field)
{
    if (!cJSON_IsString(f) || f->valuestring[0] == '\0')
        return;
    mesh_ref *m = &job->meshes[job->n_meshes++];
    m->file = f->valuestring;
    snprintf(m->field, sizeof m->field, "%s", field);
}

/* A material's keys that name files (material_json.c). */
static const char *const texture_keys[] = {
    "diffuse_texture", "emission_texture", "roughness_texture"};
#define N_TEXTURE_KEYS (sizeof texture_keys / sizeof *texture_keys)

/* Records the files an inline scene reads: objects[i].file strings,
 * environment.file, camera.lens when it is a path (a name without a
 * '/' is a file in the scenes directory or a shipped lens: both safe),
 * and the materials' textures. */
static lr_status collect_meshes(lr_job *job, const cJSON *scene,
                                lr_error *err)
{
    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(scene, "objects");
    const cJSON *env = cJSON_GetObjectItemCaseSensitive(scene, "environment");
    const cJSON *lens = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(scene, "camera"), "lens");
    int lens_path = cJSON_IsString(lens) && strchr(lens->valuestring, '/');
    const cJSON *mats = cJSON_GetObjectItemCaseSensitive(scene, "materials");
    size_t n = cJSON_IsArray(objs) ? (size_t)cJSON_GetArraySize(objs) : 0;
    size_t n_mats =
        cJSON_IsObject(mats) ? (size_t)cJSON_GetArraySize(mats) : 0;
    /* Type errors are the scene loader's to report. */
    if (n == 0 && n_mats == 0 && !cJSON_IsObject(env) && !lens_path)
        return LR_OK;
    job->meshes = calloc(n + 2 + N_TEXTURE_KEYS * n_mats, sizeof *job->meshes);
    if (job->meshes == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    size_t i = 0;
    char field[48];
    for (const cJSON *o = n ? objs->child : NULL; o != NULL; o = o->next, i++) {
        snprintf(field, sizeof field, "scene.objects[%zu].file", i);
        add_file(job, cJSON_GetObjectItemCaseSensitive(o, "file"), field);
    }
    if (cJSON_IsObject(env))
        add_file(job, cJSON_GetObjectItemCaseSensitive(env, "file"),
                 "scene.environment.file");
    if (lens_path)
        add_file(job, lens, "scene.camera.lens");
    for (const cJSON *m = n_mats ? mats->child : NULL; m != NULL; m = m->next)
        for (size_t k = 0; k < N_TEXTURE_KEYS; k++) {
            /* (The field names the material as the loader's paths do.) */
            char mp[LR__PATH_MAX], tf[LR__PATH_MAX];
            lr__path_key(mp, "scene.materials", m->string);
            lr__path_key(tf, mp, texture_keys[k]);
            add_file(job, cJSON_GetObjectItemCaseSensitive(m, texture_keys[k]),
                     tf);
        }
    return LR_OK;
}

/* Checks the top level's shape; fills the scene members of `job`. */
static lr_status check_shape(lr_job *job, lr_error *err)
{
    static const char *const keys[] = {"scene", "camera", "render",
                                       "output", NULL};
    static const char *const objects[] = {"camera", "render", "output",
                                          NULL};
    const cJSON *root = job->root;
    if (!cJSON_IsObject(root))
        return lr__fail(err, LR_ERR_INVALID, "",
                        "a job must be a JSON object: {\"scene\": ..., "
                        "\"camera\": {...}, \"render\": {...}, "
                        "\"output\": {...}}");
    LR_TRY(lr__json_check_keys(root, "", keys, err));
    for (size_t i = 0; objects[i] != NULL; i++) {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, objects[i]);
        if (v != NULL && !cJSON_IsObject(v))
            return lr__fail(err, LR_ERR_INVALID, objects[i],
                            "%s must be an object", objects[i]);
    }
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
    return collect_meshes(job, scene, err);
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

lr_status lr_job_apply(const lr_job *job, lr_camera *cam,
                       lr_render_settings *s, lr_output *out, lr_error *err)
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
