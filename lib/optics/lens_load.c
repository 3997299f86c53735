/*
 * lens_load.c: lr_lens_load and camera.lens, with the process-wide table
 * of interned lenses (lens_load.h).
 */
#include "optics/lens_load.h"
#include "json/json_util.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static pthread_mutex_t table_mu = PTHREAD_MUTEX_INITIALIZER;
static lr_lens *table[LR_MAX_LENSES];
static int n_table;

/* ---- first-order data ---------------------------------------------------- */

/* Rays of height h = 1e-6 of the first surface's semi-aperture stay
 * within 1e-12 of the paraxial limit (aberrations grow as h^2). */
static int first_order(lr_lens *L)
{
    const lr__rx *rx = &L->rx;
    double n_after[LR__RX_MAX_SURFACES];
    lr__rx_indices(rx, LR__NM_d, n_after);
    double h = 1e-6 * rx->s[0].semi_aperture;
    double o[3] = {0, h, -1.0}, d[3] = {0, 0, 1};
    if (!lr__rx_trace_n(rx, L->z, n_after, 1.0, 1, o, d) || d[1] == 0.0)
        return 0;
    double u = d[1] / d[2];
    L->first.efl = -h / u;
    L->first.z_Fp = o[2] - o[1] / u;
    /* From the image side, parallel, toward the object. */
    double hb = 1e-6 * rx->s[rx->n - 1].semi_aperture;
    double ob[3] = {0, hb, L->z[rx->n] + 1.0}, db[3] = {0, 0, -1};
    if (!lr__rx_trace_n(rx, L->z, n_after, 1.0, 0, ob, db) || db[1] == 0.0)
        return 0;
    double ub = db[1] / db[2];
    L->first.z_F = ob[2] - ob[1] / ub;
    if (!(L->first.efl > 0.0) || !isfinite(L->first.efl) ||
        !isfinite(L->first.z_F) || !isfinite(L->first.z_Fp))
        return 0;
    /* The entrance pupil's radius: the highest axial parallel ray that
     * gets through, by bisection (rays below it pass). */
    double lo = 0.0, hi = rx->s[0].semi_aperture;
    for (int it = 0; it < 50; it++) {
        double mid = 0.5 * (lo + hi);
        double om[3] = {0, mid, -1.0}, dm[3] = {0, 0, 1};
        if (lr__rx_trace_n(rx, L->z, n_after, 1.0, 1, om, dm))
            lo = mid;
        else
            hi = mid;
    }
    L->first.enp_radius = lo;
    return lo > 0.0;
}

/* ---- interning ----------------------------------------------------------- */

static int glass_equal(const lr__glass *a, const lr__glass *b)
{
    if (a->kind != b->kind || strcmp(a->name, b->name) != 0)
        return 0;
    for (int i = 0; i < 3; i++)
        if (a->B[i] != b->B[i] || a->C[i] != b->C[i])
            return 0;
    for (int i = 0; i < 6; i++)
        if (a->A[i] != b->A[i])
            return 0;
    return a->nd == b->nd && a->vd == b->vd;
}

static int coating_equal(const lr__coating *a, const lr__coating *b)
{
    if (a->kind != b->kind || a->n != b->n)
        return 0;
    for (int i = 0; i < a->n; i++)
        if (a->layer[i].film != b->layer[i].film ||
            a->layer[i].thickness_nm != b->layer[i].thickness_nm)
            return 0;
    return 1;
}

static int rx_equal(const lr__rx *a, const lr__rx *b)
{
    if (a->n != b->n || a->stop != b->stop || strcmp(a->name, b->name) != 0)
        return 0;
    for (int i = 0; i < a->n; i++) {
        const lr__surface *p = &a->s[i], *q = &b->s[i];
        if (p->radius != q->radius || p->thickness != q->thickness ||
            p->semi_aperture != q->semi_aperture || p->conic != q->conic ||
            p->stop != q->stop || !glass_equal(&p->after, &q->after))
            return 0;
        for (int j = 0; j < LR__RX_MAX_ASPH; j++)
            if (p->asph[j] != q->asph[j])
                return 0;
        if (!coating_equal(&p->coating, &q->coating))
            return 0;
    }
    return 1;
}

static int str_equal(const char *a, const char *b)
{
    return (a == NULL && b == NULL) ||
           (a != NULL && b != NULL && strcmp(a, b) == 0);
}

/* The interned lens equal to (rx, ref, json), made if new.  Takes
 * ownership of ref and json. */
static lr_status intern(const lr__rx *rx, char *ref, char *json,
                        const char *path, const lr_lens **out, lr_error *err)
{
    pthread_mutex_lock(&table_mu);
    for (int i = 0; i < n_table; i++)
        if (str_equal(table[i]->ref, ref) && str_equal(table[i]->json, json) &&
            rx_equal(&table[i]->rx, rx)) {
            *out = table[i];
            pthread_mutex_unlock(&table_mu);
            free(ref);
            free(json);
            return LR_OK;
        }
    lr_status st = LR_OK;
    lr_lens *L = NULL;
    if (n_table == LR_MAX_LENSES) {
        st = lr__fail(err, LR_ERR_LIMIT, path,
                      "%s: this process has loaded %d distinct lenses, the "
                      "most it keeps",
                      path, LR_MAX_LENSES);
        goto done;
    }
    L = calloc(1, sizeof *L);
    if (L == NULL) {
        st = lr__fail(err, LR_ERR_NOMEM, path, "out of memory");
        goto done;
    }
    L->rx = *rx;
    lr__rx_layout(&L->rx, L->z);
    for (int i = 0; i < rx->n; i++)
        if (lr__glass_n(&rx->s[i].after, LR__NM_F) !=
            lr__glass_n(&rx->s[i].after, LR__NM_C))
            L->dispersive = 1;
    if (!first_order(L)) {
        st = lr__fail(err, LR_ERR_INVALID, path,
                      "%s: the lens forms no image (no positive focal "
                      "length, or no axial ray gets through)",
                      path);
        free(L);
        L = NULL;
        goto done;
    }
    pthread_mutex_init(&L->mu, NULL);
    L->ref = ref;
    L->json = json;
    ref = json = NULL;
    table[n_table++] = L;
    *out = L;
done:
    pthread_mutex_unlock(&table_mu);
    free(ref);
    free(json);
    return st;
}

/* ---- loading --------------------------------------------------------------- */

/* Starts the message with the field, as every scene error does and as a
 * mesh file's errors do ("camera.lens: my.json: surfaces[1]...", like
 * "objects[0].file: x.obj:12: ..."), and makes it the error's path. */
static lr_status name_field(lr_status st, const char *path, lr_error *err)
{
    if (err == NULL)
        return st;
    size_t n = strlen(path);
    if (strncmp(err->message, path, n) != 0 ||
        (err->message[n] != ':' && err->message[n] != ' ')) {
        char msg[sizeof err->message];
        snprintf(msg, sizeof msg, "%s: %s", path, err->message);
        lr__fail(err, st, path, "%s", msg);
    }
    snprintf(err->path, sizeof err->path, "%s", path);
    return st;
}

static lr_status load_named(const char *name, const char *base_dir,
                            const char *path, const lr_lens **out,
                            lr_error *err)
{
    char file[4096];
    lr_status st = base_dir != NULL
                       ? lr__rx_find(name, base_dir, file, sizeof file, err)
                       : lr__rx_find_shipped(name, file, sizeof file, err);
    if (st != LR_OK)
        return name_field(st, path, err);
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    st = lr__rx_load_file(file, name, path, &rx, err);
    if (st != LR_OK)
        return name_field(st, path, err);
    char *ref = strdup(name);
    if (ref == NULL)
        return lr__fail(err, LR_ERR_NOMEM, path, "out of memory");
    return intern(&rx, ref, NULL, path, out, err);
}

lr_status lr_lens_load(const char *lens, const char *base_dir,
                       const lr_lens **out, lr_error *err)
{
    if (out != NULL)
        *out = NULL; /* (as every constructor leaves it on error) */
    if (lens == NULL || out == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_lens_load: NULL argument");
    return load_named(lens, base_dir ? base_dir : ".", "lens", out, err);
}

const char *lr_lens_name(const lr_lens *lens)
{
    return lens != NULL && lens->ref != NULL ? lens->ref : "";
}

lr_status lr__lens_from_json(const cJSON *v, const char *path,
                             const char *base_dir, const lr_lens **out,
                             lr_error *err)
{
    if (cJSON_IsString(v)) {
        const char *name = v->valuestring;
        if (base_dir == NULL && strchr(name, '/') != NULL)
            return lr__fail(err, LR_ERR_INVALID, path,
                            "%s: here a lens must be a shipped lens's name "
                            "or an inline prescription, not a path (\"%s\")",
                            path, name);
        return load_named(name, base_dir, path, out, err);
    }
    if (!cJSON_IsObject(v))
        return lr__fail(err, LR_ERR_INVALID, path,
                        "%s must be a lens's name or file, or a "
                        "prescription object",
                        path);
    lr__rx rx;
    memset(&rx, 0, sizeof rx);
    LR_TRY(lr__rx_from_json(v, path, &rx, err));
    LR_TRY(lr__rx_check(&rx, path, err));
    char *json = cJSON_PrintUnformatted(v);
    if (json == NULL)
        return lr__fail(err, LR_ERR_NOMEM, path, "out of memory");
    return intern(&rx, NULL, json, path, out, err);
}

cJSON *lr__lens_to_json(const lr_lens *lens)
{
    if (lens->ref != NULL)
        return cJSON_CreateString(lens->ref);
    return cJSON_Parse(lens->json);
}
