/*
 * lens_info.c: lr_lens_describe, a lens's first-order data (paraxial.c)
 * and its real chief rays (rx_trace.c) as one JSON object, for
 * `lensray lens` and the daemon's GET /v1/lenses.
 */
#include "optics/prescription.h"
#include "json/json_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAX_ANGLES 64

/* The lens with its apertures opened to the surfaces' edges: the chief
 * ray of a field is the ray through the stop's centre whether or not an
 * element's rim would block it (as optical design programs trace it). */
static void unvignetted(const lr__rx *rx, lr__rx *out)
{
    *out = *rx;
    for (int i = 0; i < out->n; i++) {
        lr__surface *s = &out->s[i];
        double c = s->radius != 0 ? 1.0 / s->radius : 0.0;
        double q = (1.0 + s->conic) * c * c;
        /* The conic's sag is defined while (1 + k) c^2 h^2 < 1. */
        s->semi_aperture = q > 0 ? (1.0 - 1e-9) / sqrt(q) : 1e6;
        if (s->semi_aperture > 1e6)
            s->semi_aperture = 1e6;
    }
}

/* Where the chief rays start: in front of the first surface by more than
 * its size, judged on the lens as given (`rx`), not on the opened copy
 * (a flat front surface opens to 1e6 mm, and its rays would start 1 km
 * away and aim in metre steps). */
static double start_z(const lr__rx *rx)
{
    double z0 = -(2.0 * fmax(fabs(rx->s[0].radius), rx->s[0].semi_aperture) +
                  10.0);
    return z0 < -1e6 ? -1e6 : z0;
}

/* Starts a ray at field angle `deg` that crosses the first vertex's plane
 * at height y0, from z0 (start_z). */
static void start(double z0, double deg, double y0, double o[3], double d[3])
{
    double t = deg * M_PI / 180.0;
    o[0] = 0;
    o[1] = y0 + tan(t) * z0;
    o[2] = z0;
    d[0] = 0;
    d[1] = sin(t);
    d[2] = cos(t);
}

/* The height at which the ray of (deg, y0) crosses the stop's plane, at
 * wavelength nm; `front` is the lens cut before its stop.  0: lost. */
static int at_stop(const lr__rx *front, double z0, double deg, double y0,
                   double nm, double *y)
{
    double o[3], d[3], z[LR__RX_MAX_SURFACES + 1];
    start(z0, deg, y0, o, d);
    if (front->n == 0) {
        *y = y0;
        return 1;
    }
    lr__rx_layout(front, z);
    if (!lr__rx_trace(front, z, nm, 1.0, 1, o, d) || !(d[2] > 0))
        return 0;
    *y = o[1] + (z[front->n] - o[2]) / d[2] * d[1];
    return isfinite(*y);
}

/* The y0 at which the ray of field angle `deg` crosses the stop's centre
 * at wavelength nm, by the secant method from `guess`.  0: not found. */
static int aim(const lr__rx *front, double z0, double deg, double nm,
               double guess, double step, double *y0)
{
    double a = guess, fa, b = guess + step, fb;
    if (!at_stop(front, z0, deg, a, nm, &fa) ||
        !at_stop(front, z0, deg, b, nm, &fb))
        return 0;
    for (int it = 0; it < 60 && fabs(fa) > 1e-14; it++) {
        if (fb == fa)
            break;
        double c = b - fb * (b - a) / (fb - fa), fc;
        /* A step that loses the ray is halved back toward b. */
        int tries = 0;
        while (!(isfinite(c) && at_stop(front, z0, deg, c, nm, &fc)) &&
               tries++ < 40)
            c = isfinite(c) ? 0.5 * (b + c) : b + step;
        if (tries > 40)
            return 0;
        a = b;
        fa = fb;
        b = c;
        fb = fc;
        if (fabs(fb) < fabs(fa)) {
            double t = a;
            a = b;
            b = t;
            t = fa;
            fa = fb;
            fb = t;
        }
    }
    *y0 = a;
    /* 0.1 nm at the stop: far below what any use of the height sees, and
     * above the rounding noise of an iterated surface intersection. */
    return fabs(fa) < 1e-7;
}

/* The aim at field angle dk from the answer *y0 at dp: first from *y0
 * moved along the paraxial entrance pupil's line, then from *y0 itself,
 * then (the guess lost: near 90 degrees tan grows faster than the real
 * pupil moves) through the middle angle, halving down to 1/1000 degree.
 * 1 and *y0 updated, or 0. */
static int advance(const lr__rx *front, double z0, double dp, double dk,
                   double nm, double enp, double step, double *y0)
{
    double guess = *y0 - (tan(dk * M_PI / 180) - tan(dp * M_PI / 180)) *
                             (isfinite(enp) ? enp : 0);
    double y;
    if (aim(front, z0, dk, nm, guess, step, &y) ||
        aim(front, z0, dk, nm, *y0, step, &y)) {
        *y0 = y;
        return 1;
    }
    if (!(fabs(dk - dp) > 1e-3))
        return 0;
    double mid = 0.5 * (dp + dk), ym = *y0;
    if (!advance(front, z0, dp, mid, nm, enp, step, &ym) ||
        !advance(front, z0, mid, dk, nm, enp, step, &ym))
        return 0;
    *y0 = ym;
    return 1;
}

/* The chief ray's height on the plane z_img, aimed at the stop's centre
 * at wavelength nm.  The aim is continued from the axis in steps of at
 * most 2 degrees (advance), because at wide angles (a fisheye's) the
 * real pupil moves far from the paraxial one and a guess from the
 * paraxial pupil alone misses the lens.  0: no such ray. */
static int chief(const lr__rx *rx, const lr__rx *open, const lr__rx *front,
                 double deg, double nm, double enp, double z_img, double *h)
{
    int steps = (int)ceil(fabs(deg) / 2.0);
    double z0 = start_z(rx);
    double y0 = 0, step = 1e-3 * (1.0 + rx->s[0].semi_aperture);
    if (steps < 1)
        steps = 1;
    for (int k = 1; k <= steps; k++)
        if (!advance(front, z0, deg * (k - 1) / steps, deg * k / steps, nm, enp,
                     step, &y0))
            return 0;
    double o[3], d[3], z[LR__RX_MAX_SURFACES + 1];
    start(z0, deg, y0, o, d);
    lr__rx_layout(open, z);
    if (!lr__rx_trace(open, z, nm, 1.0, 1, o, d) || !(d[2] > 0))
        return 0;
    *h = o[1] + (z_img - o[2]) / d[2] * d[1];
    return isfinite(*h);
}

static cJSON *pupil(cJSON *o, const char *key, double pos, double diam)
{
    cJSON *p = cJSON_AddObjectToObject(o, key);
    if (p != NULL) {
        cJSON_AddNumberToObject(p, "position_mm", pos);
        cJSON_AddNumberToObject(p, "diameter_mm", diam);
    }
    return p;
}

/* Numbers that are not finite (an afocal part, a pupil at infinity)
 * become null: JSON has no Inf. */
static void number(cJSON *o, const char *key, double v)
{
    if (isfinite(v))
        cJSON_AddNumberToObject(o, key, v);
    else
        cJSON_AddNullToObject(o, key);
}

static lr_status describe_rx(const lr__rx *rx, const double *angles,
                             int n_angles, double nm, cJSON **out,
                             lr_error *err)
{
    lr__paraxial p;
    *out = NULL;
    LR_TRY(lr__rx_paraxial(rx, nm, &p, err));
    cJSON *o = cJSON_CreateObject();
    if (o == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    cJSON_AddStringToObject(o, "name", rx->name);
    cJSON_AddStringToObject(o, "source", rx->source);
    cJSON_AddNumberToObject(o, "wavelength_nm", nm);
    number(o, "efl_mm", p.efl);
    number(o, "bfl_mm", p.bfl);
    number(o, "ffl_mm", p.ffl);
    number(o, "f_number", p.f_number);
    pupil(o, "entrance_pupil", p.enp_pos, p.enp_diam);
    pupil(o, "exit_pupil", p.exp_pos, p.exp_diam);
    number(o, "total_track_mm", p.total_track);
    cJSON *fields = cJSON_AddArrayToObject(o, "fields");
    lr__rx *open = malloc(2 * sizeof *open);
    if (fields == NULL || open == NULL) {
        free(open);
        cJSON_Delete(o);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    lr__rx *front = open + 1;
    unvignetted(rx, open);
    *front = *open;
    front->n = rx->stop;
    double z[LR__RX_MAX_SURFACES + 1];
    lr__rx_layout(open, z);
    /* The paraxial focal plane at the primary wavelength. */
    double z_img = z[rx->n - 1] + p.bfl;
    for (int i = 0; i < n_angles; i++) {
        cJSON *f = cJSON_CreateObject();
        if (f == NULL || !cJSON_AddItemToArray(fields, f)) {
            cJSON_Delete(f);
            free(open);
            cJSON_Delete(o);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
        double deg = angles[i], h, hF, hC;
        cJSON_AddNumberToObject(f, "angle_deg", deg);
        double ideal = p.efl * tan(deg * M_PI / 180.0);
        if (chief(rx, open, front, deg, nm, p.enp_pos, z_img, &h)) {
            cJSON_AddNumberToObject(f, "image_height_mm", h);
            /* Distortion against the paraxial height f tan(theta). */
            if (fabs(ideal) > 0)
                cJSON_AddNumberToObject(f, "distortion_percent",
                                        100.0 * (h - ideal) / ideal);
            else
                cJSON_AddNumberToObject(f, "distortion_percent", 0);
        } else {
            cJSON_AddNullToObject(f, "image_height_mm");
            cJSON_AddNullToObject(f, "distortion_percent");
        }
        /* Lateral colour: each colour's own chief ray (through the stop's
         * centre at its wavelength), F minus C, on the same plane. */
        if (chief(rx, open, front, deg, LR__NM_F, p.enp_pos, z_img, &hF) &&
            chief(rx, open, front, deg, LR__NM_C, p.enp_pos, z_img, &hC))
            cJSON_AddNumberToObject(f, "lateral_color_um", 1000.0 * (hF - hC));
        else
            cJSON_AddNullToObject(f, "lateral_color_um");
    }
    free(open);
    *out = o;
    return LR_OK;
}

lr_status lr_lens_describe(const char *lens, const char *base_dir,
                           const double *field_angles_deg, int n_angles,
                           double nm, char **json, lr_error *err)
{
    if (json != NULL)
        *json = NULL;
    if (lens == NULL || json == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_lens_describe: a lens name and an output "
                        "pointer are required");
    LR_TRY(lr__lens_check_args(field_angles_deg, n_angles, nm, err));
    lr__rx *rx;
    LR_TRY(lr__rx_load_named(lens, base_dir, &rx, err));
    cJSON *o = NULL;
    lr_status st = describe_rx(rx, field_angles_deg, n_angles, nm, &o, err);
    free(rx);
    if (st != LR_OK)
        return st;
    return lr__json_print_owned(o, json, err);
}

lr_status lr__rx_load_named(const char *lens, const char *base_dir,
                            lr__rx **out, lr_error *err)
{
    char path[4096];
    *out = NULL;
    LR_TRY(lr__rx_find(lens, base_dir, path, sizeof path, err));
    lr__rx *rx = malloc(sizeof *rx);
    if (rx == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    lr_status st = lr__rx_load_file(path, lens, NULL, rx, err);
    if (st != LR_OK) {
        free(rx);
        return st;
    }
    *out = rx;
    return LR_OK;
}

lr_status lr__json_print_owned(cJSON *o, char **json, lr_error *err)
{
    *json = o != NULL ? cJSON_PrintUnformatted(o) : NULL;
    cJSON_Delete(o);
    if (*json == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    return LR_OK;
}

lr_status lr__lens_check_args(const double *field_angles_deg, int n_angles,
                              double nm, lr_error *err)
{
    if (n_angles < 0 || (n_angles > 0 && field_angles_deg == NULL))
        return lr__fail(err, LR_ERR_INVALID, "field_angles",
                        "field angles: a count >= 0 and the angles");
    if (n_angles > MAX_ANGLES)
        return lr__fail(err, LR_ERR_LIMIT, "field_angles",
                        "at most %d field angles, got %d", MAX_ANGLES,
                        n_angles);
    if (!(nm >= 300 && nm <= 2000))
        return lr__fail(err, LR_ERR_INVALID, "wavelength",
                        "the wavelength must be between 300 and 2000 nm, "
                        "got %g",
                        nm);
    for (int i = 0; i < n_angles; i++)
        if (!(fabs(field_angles_deg[i]) < 90))
            return lr__fail(err, LR_ERR_INVALID, "field_angles",
                            "field angle %g: must be within +-90 degrees "
                            "(exclusive)",
                            field_angles_deg[i]);
    return LR_OK;
}

lr_status lr_lenses_describe(const double *field_angles_deg, int n_angles,
                             double nm, char **json, lr_error *err)
{
    if (json == NULL)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lr_lenses_describe: an output pointer is required");
    *json = NULL;
    LR_TRY(lr__lens_check_args(field_angles_deg, n_angles, nm, err));
    char(*names)[64] = malloc(64 * sizeof *names);
    cJSON *o = cJSON_CreateObject();
    cJSON *arr = o != NULL ? cJSON_AddArrayToObject(o, "lenses") : NULL;
    if (names == NULL || arr == NULL) {
        free(names);
        cJSON_Delete(o);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    int n = lr__rx_shipped(names, 64);
    lr_status st = LR_OK;
    for (int i = 0; i < n && st == LR_OK; i++) {
        char *one = NULL;
        lr_error e1;
        cJSON *item = NULL;
        lr_status s1 = lr_lens_describe(names[i], NULL, field_angles_deg,
                                        n_angles, nm, &one, &e1);
        if (s1 == LR_OK) {
            item = cJSON_Parse(one);
            free(one);
        } else if (s1 == LR_ERR_NOMEM) {
            st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
            break;
        } else {
            item = cJSON_CreateObject();
            if (item != NULL)
                cJSON_AddStringToObject(item, "error", e1.message);
        }
        if (item == NULL) {
            st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
            break;
        }
        /* "id" first: the name a job's camera.lens may use. */
        cJSON *entry = cJSON_CreateObject();
        if (entry == NULL || !cJSON_AddStringToObject(entry, "id", names[i]) ||
            !cJSON_AddItemToArray(arr, entry)) {
            cJSON_Delete(entry);
            cJSON_Delete(item);
            st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
            break;
        }
        while (item->child != NULL) {
            cJSON *c = cJSON_DetachItemViaPointer(item, item->child);
            if (!cJSON_AddItemToObject(entry, c->string, c)) {
                cJSON_Delete(c);
                st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
                break;
            }
        }
        cJSON_Delete(item);
    }
    free(names);
    if (st == LR_OK) {
        *json = cJSON_PrintUnformatted(o);
        if (*json == NULL)
            st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    cJSON_Delete(o);
    return st;
}
