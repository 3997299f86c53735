/*
 * json_write.c: a camera and render settings written back as JSON in
 * the scene format, the inverse of lr_camera_apply_json (camera_json.c)
 * and lr_render_settings_apply_json (settings_json.c), for clients that show
 * what a scene loaded (the daemon's scene listing) or pass settings on.
 * The unit tests read every value back through the parsers, so the names
 * here cannot drift from theirs.
 */
#include "camera/camera.h"
#include "integrator/integrator.h"
#include "json/json_util.h"
#include "optics/lens_load.h"

#include <cjson/cJSON.h>

#include <locale.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The enums are named by json_util.c's tables, as the parsers name them;
 * the integrator by its registry (integrator.c). */

/* names[i] of a NULL-ended table, or "unknown". */
static const char *name_of(const char *const *names, int i)
{
    for (int k = 0; names[k] != NULL; k++)
        if (k == i)
            return names[k];
    return "unknown";
}
#define NAME(table, i) name_of(table, (int)(i))

/* Adds and remembers failure: every cJSON_Add* returns NULL when out of
 * memory, and one check at the end covers them all. */
typedef struct jb {
    cJSON *o;
    int failed;
} jb;

static pthread_once_t c_once = PTHREAD_ONCE_INIT;
static locale_t c_numeric;

static void make_c_numeric(void)
{
    c_numeric = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
}

/* v as the shortest of %.15g to %.17g that reads back as v: cJSON
 * prints %.15g when that reads back within its epsilon, which dropped
 * the last bits (a seed of 2^53 - 1 came back 2^53 - 2, and --remote's
 * parts rendered another picture than the local render).  In the C
 * locale whatever the caller's (a decimal comma wrote "fov":39,6, which
 * is no JSON; obj.c and rx_file.c read numbers so). */
static cJSON *exact(double v)
{
    pthread_once(&c_once, make_c_numeric);
    if (!isfinite(v) || c_numeric == (locale_t)0)
        return cJSON_CreateNumber(v);
    locale_t was = uselocale(c_numeric);
    char t[40];
    for (int p = 15; p <= 17; p++) {
        snprintf(t, sizeof t, "%.*g", p, v);
        if (strtod(t, NULL) == v)
            break;
    }
    uselocale(was);
    return cJSON_CreateRaw(t);
}

static void num(jb *b, const char *k, double v)
{
    cJSON *n = exact(v);
    if (n == NULL || !cJSON_AddItemToObject(b->o, k, n)) {
        cJSON_Delete(n);
        b->failed = 1;
    }
}

static void str(jb *b, const char *k, const char *v)
{
    if (cJSON_AddStringToObject(b->o, k, v) == NULL)
        b->failed = 1;
}

static void boolean(jb *b, const char *k, int v)
{
    if (cJSON_AddBoolToObject(b->o, k, v) == NULL)
        b->failed = 1;
}

static void vec(jb *b, const char *k, const double *v, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a != NULL && i < n; i++) {
        cJSON *x = exact(v[i]);
        if (x == NULL || !cJSON_AddItemToArray(a, x)) {
            cJSON_Delete(x);
            cJSON_Delete(a);
            a = NULL;
        }
    }
    if (a == NULL || !cJSON_AddItemToObject(b->o, k, a)) {
        cJSON_Delete(a);
        b->failed = 1;
    }
}

static void child(jb *b, const char *k, jb *c)
{
    c->o = cJSON_AddObjectToObject(b->o, k);
    c->failed = c->o == NULL;
}

/* Prints and frees the object; NULL when anything failed. */
static char *finish(jb *b)
{
    char *text = b->failed ? NULL : cJSON_PrintUnformatted(b->o);
    cJSON_Delete(b->o);
    return text;
}

static void chromatic_json(jb *b, const lr_chromatic *ch)
{
    jb c;
    child(b, "chromatic", &c);
    if (c.failed) {
        b->failed = 1;
        return;
    }
    str(&c, "mode", NAME(lr__chroma_mode_names, ch->mode));
    str(&c, "focal_model", NAME(lr__focal_model_names, ch->focal_model));
    vec(&c, "ior", ch->ior, 3);
    if (ch->glass == LR_GLASS_ABBE) {
        jb a;
        child(&c, "abbe", &a);
        if (!a.failed) {
            num(&a, "n_d", ch->abbe_nd);
            num(&a, "V_d", ch->abbe_vd);
        }
        c.failed |= a.failed;
    } else {
        str(&c, "glass", NAME(lr__glass_names, ch->glass));
    }
    num(&c, "amplify", ch->amplify);
    num(&c, "wavelengths", ch->wavelengths);
    boolean(&c, "splat", ch->splat);
    b->failed |= c.failed;
}

/* One key of camera model m's table (camera.h), by its type. */
static void camera_key(jb *b, const lr__camera_key *k,
                       const lr__camera_model *m, const lr_camera *cam)
{
    const char *field = (const char *)cam + k->offset;
    switch (k->type) {
    case LR__KEY_PARAM:
        num(b, k->name, lr__camera_param(cam, m, k));
        break;
    case LR__KEY_NUMBER:
        num(b, k->name, *(const double *)field);
        break;
    case LR__KEY_INT:
        num(b, k->name, *(const int *)field);
        break;
    case LR__KEY_VEC3:
        vec(b, k->name, (const double *)field, 3);
        break;
    case LR__KEY_ENUM: {
        int v = *(const int *)field, n = 0;
        while (k->names[n] != NULL)
            n++;
        str(b, k->name, v >= 0 && v < n ? k->names[v] : "unknown");
        break;
    }
    case LR__KEY_CUSTOM:
        /* The lens model's prescription: its name, or the inline object;
         * the keys every model shares are written below. */
        if (strcmp(k->name, "lens") == 0 && cam->lens != NULL) {
            cJSON *v = lr__lens_to_json(cam->lens);
            if (v == NULL || !cJSON_AddItemToObject(b->o, "lens", v)) {
                cJSON_Delete(v);
                b->failed = 1;
            }
        }
        /* "auto", the default, is written as the key's absence. */
        if (strcmp(k->name, "ghosts") == 0 && cam->ghosts != LR_GHOSTS_AUTO)
            boolean(b, "ghosts", cam->ghosts == LR_GHOSTS_ON);
        break;
    }
}

char *lr_camera_json(const lr_camera *cam)
{
    if (cam == NULL)
        return NULL;
    const lr__camera_model *model = lr__camera_model_of(cam->model);
    jb b = {cJSON_CreateObject(), 0};
    if (b.o == NULL)
        return NULL;
    str(&b, "model", model != NULL ? model->name : "unknown");
    vec(&b, "position", cam->position, 3);
    vec(&b, "look_at", cam->look_at, 3);
    vec(&b, "up", cam->up, 3);
    num(&b, "fov", cam->fov);
    if (model != NULL)
        for (const lr__camera_key *k = model->keys; k->name != NULL; k++)
            camera_key(&b, k, model, cam);
    if (model != NULL && model->lens) {
        if (cam->focus_on[0] >= 0) {
            double at[2] = {cam->focus_on[0], cam->focus_on[1]};
            vec(&b, "focus_on", at, 2);
        }
        if (cam->chromatic.mode != LR_CHROMATIC_OFF)
            chromatic_json(&b, &cam->chromatic);
    }
    return finish(&b);
}

char *lr_render_settings_json(const lr_render_settings *s)
{
    if (s == NULL)
        return NULL;
    jb b = {cJSON_CreateObject(), 0};
    if (b.o == NULL)
        return NULL;
    num(&b, "width", s->width);
    num(&b, "height", s->height);
    num(&b, "spp", s->spp);
    str(&b, "sampler", NAME(lr__sampler_names, s->sampler));
    num(&b, "seed", (double)s->seed);
    const lr__integrator *in = lr__integrator_for(s->integrator);
    str(&b, "integrator", in != NULL ? in->name : "unknown");
    num(&b, "max_depth", s->max_depth);
    num(&b, "threads", s->threads);
    num(&b, "tile_size", s->tile_size);
    boolean(&b, "depth", s->want_depth);
    if (s->region[0] | s->region[1] | s->region[2] | s->region[3]) {
        double r[4] = {s->region[0], s->region[1], s->region[2], s->region[3]};
        vec(&b, "region", r, 4);
    }
    boolean(&b, "plan", s->plan);
    /* On, the default, is written as the key's absence (so that every
     * file written before the key existed reads back the same). */
    if (!s->light)
        boolean(&b, "light", s->light);
    if (s->adaptive &&
        (s->adaptive_threshold > 0.0 || s->adaptive_min_spp > 0)) {
        jb a;
        child(&b, "adaptive", &a);
        /* 0 (derived from spp) is written as the key's absence. */
        if (!a.failed && s->adaptive_threshold > 0.0)
            num(&a, "threshold", s->adaptive_threshold);
        if (!a.failed && s->adaptive_min_spp > 0)
            num(&a, "min_spp", s->adaptive_min_spp);
        b.failed |= a.failed;
    } else {
        boolean(&b, "adaptive", s->adaptive);
    }
    return finish(&b);
}
