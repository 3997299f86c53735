/*
 * fuzz_lens.c: the three lens prescription readers (lensray JSON, pbrt-v4
 * lens files, Zemax .zmx), each given every input, then lr__rx_check on
 * what they accept, then first-order data and a few real rays through
 * what passes.  One target for the three (so that one 20-second session
 * covers them, and a seed of any form feeds all).
 *
 * Promises checked: no crash, no leak, no undefined behaviour; a rejected
 * input gets a known status and a non-empty UTF-8 message that names its
 * field (JSON) or "FILE:LINE" / "FILE:" (pbrt, Zemax); an accepted lens
 * that passes lr__rx_check has 1 to 64 surfaces, one stop, positive
 * semi-apertures and a finite positive focal length at three
 * wavelengths, every ray that lr__rx_trace lets through leaves with
 * a finite origin and a unit direction, every surface reflects between
 * 0 and 1, and a ray through a ghost path lands at a finite point with a
 * weight between 0 and 1.
 */
#include "fuzz.h"

#include "optics/prescription.h"
#include "optics/ghost.h"
#include "json/json_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Every surface's reflectance (its coating as read) lies in [0, 1], and
 * a ray through each of the first ghost paths that reaches the sensor
 * lands at a finite point with a weight in [0, 1]. */
static int ghosts(const char *what, const lr__rx *rx, const double *z)
{
    double n_after[LR__RX_MAX_SURFACES];
    lr__rx_indices(rx, LR__NM_d, n_after);
    for (int i = 0; i < rx->n; i++)
        for (int c = 0; c < 3; c++) {
            double R = lr__rx_surface_r(rx, n_after, i, c & 1, 1.0 - 0.45 * c,
                                        LR__NM_d, NULL);
            if (!(R >= 0.0 && R <= 1.0))
                return lr_fuzz_report("%s: surface %d reflects %g", what, i, R);
        }
    static lr__ghost paths[LR__GHOST_MAX];
    int np = lr__ghost_paths(rx, paths);
    for (int p = 0; p < np && p < 24; p++) {
        double o[3] = {0, 0.3 * rx->s[0].semi_aperture, z[0] - 1.0};
        double d[3] = {0, 0, 1}, hit[2], w;
        if (lr__ghost_trace(rx, z, LR__NM_d, 1.0, NULL, paths[p], z[rx->n], o,
                            d, hit, &w) &&
            (!isfinite(hit[0] + hit[1]) || !(w >= 0.0 && w <= 1.0)))
            return lr_fuzz_report("%s: ghost (%d, %d) landed at (%g, %g) "
                                  "with weight %g",
                                  what, paths[p].j, paths[p].i, hit[0], hit[1],
                                  w);
    }
    return 0;
}

static int accepted(const char *what, const lr__rx *rx)
{
    if (rx->n < 1 || rx->n > LR__RX_MAX_SURFACES || rx->stop < 0 ||
        rx->stop >= rx->n || !rx->s[rx->stop].stop)
        return lr_fuzz_report("%s: accepted %d surfaces, stop %d", what, rx->n,
                              rx->stop);
    for (int i = 0; i < rx->n; i++)
        if (!(rx->s[i].semi_aperture > 0) || !isfinite(rx->s[i].thickness))
            return lr_fuzz_report("%s: surface %d accepted with "
                                  "semi-aperture %g",
                                  what, i, rx->s[i].semi_aperture);
    const double nms[] = {LR__NM_F, LR__NM_d, LR__NM_C};
    for (int k = 0; k < 3; k++) {
        lr__paraxial p;
        lr_error err;
        lr_status st = lr__rx_paraxial(rx, nms[k], &p, &err);
        /* A lens checked at the d line may still be afocal at another
         * wavelength: then an error, never a non-finite number. */
        if (st != LR_OK) {
            if (lr_fuzz_check_error(what, st, &err))
                return 1;
            continue;
        }
        if (!isfinite(p.efl) || !isfinite(p.bfl) || !isfinite(p.ffl) ||
            (k == 1 && !(p.efl > 0)))
            return lr_fuzz_report("%s: efl %g bfl %g ffl %g at %g nm", what,
                                  p.efl, p.bfl, p.ffl, nms[k]);
    }
    double z[LR__RX_MAX_SURFACES + 1];
    lr__rx_layout(rx, z);
    for (int r = 0; r < 9; r++) {
        double a = rx->s[0].semi_aperture * (r % 3 - 1) * 0.7;
        double o[3] = {0, a, z[0] - 1.0 - fabs(a)};
        double d[3] = {0, 0.05 * (r / 3 - 1), 1};
        double len = sqrt(d[1] * d[1] + d[2] * d[2]);
        d[1] /= len;
        d[2] /= len;
        if (lr__rx_trace(rx, z, nms[r % 3], 1.0, 1, o, d)) {
            double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (!isfinite(o[0] + o[1] + o[2]) || !(fabs(dl - 1) < 1e-9))
                return lr_fuzz_report("%s: a traced ray left at (%g, %g, "
                                      "%g), |d| = %g",
                                      what, o[0], o[1], o[2], dl);
        }
    }
    return ghosts(what, rx, z);
}

/* A reader's verdict: an error that is well formed (and, for the text
 * forms, names the file), or a lens that passes the promises above. */
static int verdict(const char *what, lr_status st, const lr__rx *rx,
                   lr_error *err, int names_file)
{
    if (st == LR_OK) {
        st = lr__rx_check(rx, "", err);
        return st == LR_OK ? accepted(what, rx)
                           : lr_fuzz_check_error(what, st, err);
    }
    if (lr_fuzz_check_error(what, st, err))
        return 1;
    if (names_file && st != LR_ERR_NOMEM &&
        strncmp(err->message, "in.", 3) != 0)
        return lr_fuzz_report("%s: the message does not name the file: %s",
                              what, err->message);
    return 0;
}

int lr_fuzz_lens(const uint8_t *data, size_t size)
{
    lr__rx *rx = malloc(sizeof *rx);
    if (rx == NULL)
        return 0;
    lr_error err;
    int bad = 0;
    cJSON *o = NULL;
    lr_status st = lr__json_parse((const char *)data, size, "in.json",
                                  "camera.lens", &o, &err);
    if (st == LR_OK) {
        st = lr__rx_from_json(o, "camera.lens", rx, &err);
        if (st == LR_OK)
            st = lr__rx_check(rx, "camera.lens", &err);
        bad = st == LR_OK ? accepted("json", rx)
                          : lr_fuzz_check_error("json", st, &err);
        cJSON_Delete(o);
    } else
        bad = lr_fuzz_check_error("json text", st, &err);
    if (!bad) {
        memset(&err, 0, sizeof err);
        st = lr__rx_from_pbrt((const char *)data, size, "in.dat", rx, &err);
        bad = verdict("pbrt", st, rx, &err, 1);
    }
    if (!bad) {
        memset(&err, 0, sizeof err);
        st = lr__rx_from_zmx((const char *)data, size, "in.zmx", rx, &err);
        bad = verdict("zmx", st, rx, &err, 1);
    }
    free(rx);
    return bad;
}

LR_FUZZ_MAIN(lr_fuzz_lens)
