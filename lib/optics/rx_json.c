/*
 * rx_json.c: lensray's JSON form of a prescription (docs/lenses.md):
 * {"name", "source", "notes", "surfaces": [{radius, thickness, material,
 * semi_aperture, conic, aspheric, stop, coating}, ...]}, surfaces from the object
 * side.  Every error names the surface and the field.
 */
#include "optics/prescription.h"
#include "optics/ghost.h"
#include "json/json_util.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Lengths beyond a kilometre are no camera lens; the bound keeps every
 * later sum finite. */
#define MAX_MM 1e6

static lr_status material(const cJSON *s, const char *sp, lr__glass *g,
                          lr_error *err)
{
    char p[LR__PATH_MAX];
    lr__path_key(p, sp, "material");
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(s, "material");
    memset(g, 0, sizeof *g);
    if (m == NULL) {
        g->kind = LR__GLASS_AIR;
        g->nd = 1.0;
        return LR_OK;
    }
    if (cJSON_IsString(m)) {
        char near[128], shown[96];
        if (lr__glass_named(m->valuestring, g, near, sizeof near) == 0)
            return LR_OK;
        lr__utf8_escape(m->valuestring, shown, sizeof shown);
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s: unknown glass \"%s\"; nearest: %s", p, shown,
                        near);
    }
    if (!cJSON_IsObject(m)) {
        char what[64];
        lr__json_describe(m, what, sizeof what);
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be \"air\", a catalogue glass name, "
                        "{\"nd\", \"vd\"} or {\"sellmeier\": [B1, B2, B3, "
                        "C1, C2, C3]}, got %s",
                        p, what);
    }
    static const char *const keys[] = {"nd", "vd", "sellmeier", "name", NULL};
    LR_TRY(lr__json_check_keys(m, p, keys, err));
    const cJSON *sell = cJSON_GetObjectItemCaseSensitive(m, "sellmeier");
    if (sell != NULL) {
        char q[LR__PATH_MAX];
        lr__path_key(q, p, "sellmeier");
        if (!cJSON_IsArray(sell) || cJSON_GetArraySize(sell) != 6)
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be an array of 6 numbers [B1, B2, B3, "
                            "C1, C2, C3] (C in um^2)",
                            q);
        double v[6];
        for (int i = 0; i < 6; i++) {
            const cJSON *x = cJSON_GetArrayItem(sell, i);
            if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble) ||
                fabs(x->valuedouble) > 1e6)
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s[%d] must be a finite number", q, i);
            v[i] = x->valuedouble;
        }
        g->kind = LR__GLASS_SELLMEIER;
        memcpy(g->B, v, sizeof g->B);
        memcpy(g->C, v + 3, sizeof g->C);
        g->nd = lr__glass_n(g, LR__NM_d);
        /* From 380 to 780 nm the index must be a real refractive index:
         * a pole of the formula there (l^2 = C_i) is a typing error,
         * found exactly (samples 10 nm apart let a pole between them
         * through, the index 1 or 2.3 beside it), the rest at every nm. */
        for (int i = 0; i < 3; i++)
            if (g->B[i] != 0.0 && g->C[i] >= 0.38 * 0.38 &&
                g->C[i] <= 0.78 * 0.78)
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s has a pole at %.1f nm (C%d = %g um^2): "
                                "no refractive index there",
                                q, 1e3 * sqrt(g->C[i]), i + 1, g->C[i]);
        for (double nm = 380; nm <= 780; nm += 1) {
            double n = lr__glass_n(g, nm);
            double l2 = nm * nm * 1e-6, n2 = 1;
            for (int i = 0; i < 3; i++)
                n2 += g->B[i] * l2 / (l2 - g->C[i]);
            if (!(n2 >= 1.0 && n2 <= 25.0) || !isfinite(n))
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s gives no refractive index between 1 and "
                                "5 at %g nm",
                                q, nm);
        }
        return LR_OK;
    }
    double nd = 0, vd = 0;
    LR_TRY(lr__json_number(m, "nd", p, 1, &nd, err));
    if (!(nd >= 1.0 && nd <= 5.0)) {
        char q[LR__PATH_MAX];
        lr__path_key(q, p, "nd");
        return lr__fail(err, LR_ERR_INVALID, q,
                        "%s must be between 1 and 5, got %g", q, nd);
    }
    g->nd = nd;
    g->kind = LR__GLASS_CONSTANT;
    if (cJSON_GetObjectItemCaseSensitive(m, "vd") != NULL) {
        LR_TRY(lr__json_number(m, "vd", p, 1, &vd, err));
        /* Optical glasses have 15 < vd < 100; 5 and 200 leave room. */
        if (!(vd >= 5.0 && vd <= 200.0)) {
            char q[LR__PATH_MAX];
            lr__path_key(q, p, "vd");
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s must be between 5 and 200, got %g", q, vd);
        }
        g->vd = vd;
        g->kind = nd > 1.0 ? LR__GLASS_ABBE : LR__GLASS_CONSTANT;
    }
    return LR_OK;
}

static lr_status length(const cJSON *s, const char *key, const char *sp,
                        double lo, double *out, lr_error *err)
{
    LR_TRY(lr__json_number(s, key, sp, 0, out, err));
    if (!(*out >= lo && fabs(*out) <= MAX_MM)) {
        char p[LR__PATH_MAX];
        lr__path_key(p, sp, key);
        /* The conic constant is a ratio; the others are lengths. */
        const char *unit = strcmp(key, "conic") == 0 ? "" : " mm";
        if (lo > -MAX_MM)
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s must be between %g and %g%s, got %g", p, lo,
                            MAX_MM, unit, *out);
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be within +-%g%s, got %g", p, MAX_MM, unit,
                        *out);
    }
    return LR_OK;
}

/* A thin film's thickness beyond 10 um is no coating layer (an
 * anti-reflection layer is about 100 nm). */
#define MAX_LAYER_NM 1e4

/* One layer of "coating.layers": {"material": NAME, "thickness_nm": d}. */
static lr_status layer(const cJSON *l, const char *lp, lr__layer *out,
                       lr_error *err)
{
    static const char *const keys[] = {"material", "thickness_nm", NULL};
    if (!cJSON_IsObject(l))
        return lr__fail(err, LR_ERR_INVALID, lp,
                        "%s must be an object {\"material\", "
                        "\"thickness_nm\"}",
                        lp);
    LR_TRY(lr__json_check_keys(l, lp, keys, err));
    const char *name = NULL;
    LR_TRY(lr__json_string(l, "material", lp, 1, &name, err));
    char p[LR__PATH_MAX];
    lr__path_key(p, lp, "material");
    int f = lr__film_find(name);
    if (f < 0) {
        char shown[96];
        lr__utf8_escape(name, shown, sizeof shown);
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s: unknown coating material \"%s\"; one of %s", p,
                        shown, lr__film_list);
    }
    out->film = (lr__film)f;
    LR_TRY(lr__json_number(l, "thickness_nm", lp, 1, &out->thickness_nm, err));
    if (!(out->thickness_nm > 0.0 && out->thickness_nm <= MAX_LAYER_NM)) {
        lr__path_key(p, lp, "thickness_nm");
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be > 0 and at most %g nm, got %g", p,
                        MAX_LAYER_NM, out->thickness_nm);
    }
    return LR_OK;
}

/* "coating": "none", "mgf2" or {"layers": [...]} (coating.h); absent:
 * the default.  Sets *given when the key is there. */
static lr_status coating(const cJSON *s, const char *sp, lr__coating *c,
                         int *given, lr_error *err)
{
    char p[LR__PATH_MAX];
    lr__path_key(p, sp, "coating");
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(s, "coating");
    memset(c, 0, sizeof *c);
    *given = v != NULL;
    if (v == NULL)
        return LR_OK;
    if (cJSON_IsString(v) && strcmp(v->valuestring, "none") == 0) {
        c->kind = LR__COAT_NONE;
        return LR_OK;
    }
    if (cJSON_IsString(v) && strcmp(v->valuestring, "mgf2") == 0)
        return LR_OK;
    if (!cJSON_IsObject(v)) {
        char what[64];
        lr__json_describe(v, what, sizeof what);
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s must be \"none\", \"mgf2\" or {\"layers\": "
                        "[{\"material\", \"thickness_nm\"}, ...]}, got %s",
                        p, what);
    }
    static const char *const keys[] = {"layers", NULL};
    LR_TRY(lr__json_check_keys(v, p, keys, err));
    char lp[LR__PATH_MAX];
    lr__path_key(lp, p, "layers");
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(v, "layers");
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) < 1 ||
        cJSON_GetArraySize(a) > LR__COAT_MAX_LAYERS)
        return lr__fail(err, LR_ERR_INVALID, lp,
                        "%s must be an array of 1 to %d layers, the first on "
                        "the glass",
                        lp, LR__COAT_MAX_LAYERS);
    c->kind = LR__COAT_LAYERS;
    c->n = cJSON_GetArraySize(a);
    for (int i = 0; i < c->n; i++) {
        char q[LR__PATH_MAX];
        lr__path_index(q, lp, (size_t)i);
        LR_TRY(layer(cJSON_GetArrayItem(a, i), q, &c->layer[i], err));
    }
    return LR_OK;
}

static lr_status surface(const cJSON *s, const char *sp, lr__surface *out,
                         int *coated, lr_error *err)
{
    static const char *const keys[] = {
        "radius",   "thickness", "material", "semi_aperture", "conic",
        "aspheric", "stop",      "coating",  "comment",       NULL};
    if (!cJSON_IsObject(s))
        return lr__fail(err, LR_ERR_INVALID, sp, "%s must be an object", sp);
    LR_TRY(lr__json_check_keys(s, sp, keys, err));
    memset(out, 0, sizeof *out);
    LR_TRY(length(s, "radius", sp, -MAX_MM, &out->radius, err));
    if (cJSON_GetObjectItemCaseSensitive(s, "thickness") == NULL) {
        char p[LR__PATH_MAX];
        lr__path_key(p, sp, "thickness");
        return lr__fail(err, LR_ERR_INVALID, p, "%s is required", p);
    }
    LR_TRY(length(s, "thickness", sp, 0, &out->thickness, err));
    if (cJSON_GetObjectItemCaseSensitive(s, "semi_aperture") == NULL) {
        char p[LR__PATH_MAX];
        lr__path_key(p, sp, "semi_aperture");
        return lr__fail(err, LR_ERR_INVALID, p, "%s is required", p);
    }
    LR_TRY(length(s, "semi_aperture", sp, 0, &out->semi_aperture, err));
    LR_TRY(length(s, "conic", sp, -MAX_MM, &out->conic, err));
    int stop = 0;
    LR_TRY(lr__json_bool(s, "stop", sp, 0, &stop, err));
    out->stop = stop;
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(s, "aspheric");
    if (a != NULL) {
        char p[LR__PATH_MAX];
        lr__path_key(p, sp, "aspheric");
        if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) > LR__RX_MAX_ASPH)
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s must be an array of at most %d numbers "
                            "[A4, A6, ...]",
                            p, LR__RX_MAX_ASPH);
        for (int i = 0; i < cJSON_GetArraySize(a); i++) {
            const cJSON *x = cJSON_GetArrayItem(a, i);
            if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble) ||
                fabs(x->valuedouble) > 1e3)
                return lr__fail(err, LR_ERR_INVALID, p,
                                "%s[%d] must be a finite number within "
                                "+-1000",
                                p, i);
            out->asph[i] = x->valuedouble;
        }
    }
    if (!stop && cJSON_GetObjectItemCaseSensitive(s, "material") == NULL) {
        char p[LR__PATH_MAX];
        lr__path_key(p, sp, "material");
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s is required (\"air\" or a glass)", p);
    }
    int given = 0;
    LR_TRY(coating(s, sp, &out->coating, &given, err));
    *coated = given && out->coating.kind != LR__COAT_NONE;
    return material(s, sp, &out->after, err);
}

lr_status lr__rx_from_json(const cJSON *o, const char *path, lr__rx *rx,
                           lr_error *err)
{
    static const char *const keys[] = {"name", "source", "notes", "surfaces",
                                       NULL};
    if (path == NULL)
        path = "";
    memset(rx, 0, sizeof *rx);
    rx->stop = -1;
    if (!cJSON_IsObject(o))
        return lr__fail(err, LR_ERR_INVALID, path,
                        "%s%sa lens must be an object with \"surfaces\"", path,
                        path[0] ? ": " : "");
    LR_TRY(lr__json_check_keys(o, path, keys, err));
    const char *name = NULL, *source = NULL;
    LR_TRY(lr__json_string(o, "name", path, 0, &name, err));
    LR_TRY(lr__json_string(o, "source", path, 0, &source, err));
    if (name != NULL)
        snprintf(rx->name, sizeof rx->name, "%.*s",
                 lr__utf8_prefix(name, (int)sizeof rx->name - 1), name);
    if (source != NULL)
        snprintf(rx->source, sizeof rx->source, "%.*s",
                 lr__utf8_prefix(source, (int)sizeof rx->source - 1), source);
    char sp[LR__PATH_MAX];
    lr__path_key(sp, path, "surfaces");
    const cJSON *arr = cJSON_GetObjectItemCaseSensitive(o, "surfaces");
    if (!cJSON_IsArray(arr) || cJSON_GetArraySize(arr) < 1)
        return lr__fail(err, LR_ERR_INVALID, sp,
                        "%s must be a non-empty array of surfaces", sp);
    int n = cJSON_GetArraySize(arr);
    if (n > LR__RX_MAX_SURFACES)
        return lr__fail(err, LR_ERR_LIMIT, sp,
                        "%s has %d surfaces; at most %d are allowed", sp, n,
                        LR__RX_MAX_SURFACES);
    for (int i = 0; i < n; i++) {
        char p[LR__PATH_MAX];
        lr__path_index(p, sp, (size_t)i);
        int coated = 0;
        LR_TRY(surface(cJSON_GetArrayItem(arr, i), p, &rx->s[i], &coated, err));
        /* A coating goes between glass and air; a cemented surface or
         * one in air (a stop) has nowhere to put one. */
        if (coated && !lr__rx_glass_air(rx, i)) {
            char q[LR__PATH_MAX];
            lr__path_key(q, p, "coating");
            return lr__fail(
                err, LR_ERR_INVALID, q,
                "%s: only a surface between glass and air takes "
                "a coating (this one has %s on both sides); use "
                "\"none\" or leave it out",
                q, lr__glass_is_air(&rx->s[i].after) ? "air" : "glass");
        }
        if (rx->s[i].stop) {
            if (rx->stop >= 0)
                return lr__fail(err, LR_ERR_INVALID, p,
                                "%s.stop: a second stop (surfaces[%d] is "
                                "one already)",
                                p, rx->stop);
            rx->stop = i;
        }
    }
    rx->n = n;
    lr__rx_zero_back_focus(rx);
    return LR_OK;
}
