/*
 * rx_check.c: lr__rx_check, whether a prescription can be built and
 * forms an image.  Readers check their own syntax; this checks the
 * geometry, whatever the form the lens came in.
 */
#include "optics/prescription.h"
#include "json/json_util.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The surface's sag at height h (Zemax's even asphere: the conic term
 * c h^2 / (1 + sqrt(1 - (1 + k) c^2 h^2)) plus A4 h^4 + A6 h^6 + ...);
 * NaN where the conic is not defined. */
static double sag(const lr__surface *s, double h)
{
    double c = s->radius != 0 ? 1.0 / s->radius : 0.0;
    double q = 1.0 - (1.0 + s->conic) * c * c * h * h;
    if (q < 0)
        return NAN;
    double z = c * h * h / (1.0 + sqrt(q)), h2 = h * h, hp = h2 * h2;
    for (int j = 0; j < LR__RX_MAX_ASPH; j++, hp *= h2)
        z += s->asph[j] * hp;
    return z;
}

/* The path of an error about surface i: its JSON path `p` in a JSON
 * lens; a file's surface has none, so the caller's `path` (the field
 * that named the file, which lr__rx_load_file sets), and its message
 * names the surface as surface_name says. */
static const char *error_path(const lr__rx *rx, int i, const char *path,
                              const char *p)
{
    return rx->line[i] > 0 ? path : p;
}

/* How a message names surface i: by its JSON path `p` ("surfaces[3]")
 * for a JSON lens, by what its file calls it elsewhere: "SURF 4 (line
 * 120)" in a Zemax file (SURF 0 is the object: surfaces[3] is SURF 4),
 * "the surface on line 7" in a pbrt file. */
static const char *surface_name(const lr__rx *rx, int i, const char *p,
                                char *out, size_t cap)
{
    if (rx->line[i] <= 0)
        snprintf(out, cap, "%s", p);
    else if (rx->zmx)
        snprintf(out, cap, "SURF %d (line %d)", i + 1, rx->line[i]);
    else
        snprintf(out, cap, "the surface on line %d", rx->line[i]);
    return out;
}

lr_status lr__rx_check(const lr__rx *rx, const char *path, lr_error *err)
{
    char sp[LR__PATH_MAX], p[LR__PATH_MAX], nm[LR__PATH_MAX + 32],
        nm2[LR__PATH_MAX + 32];
    lr__path_key(sp, path, "surfaces");
    if (rx->n < 1 || rx->n > LR__RX_MAX_SURFACES)
        return lr__fail(err, LR_ERR_INVALID, sp,
                        "%s: %d surfaces; a lens has 1 to %d", sp, rx->n,
                        LR__RX_MAX_SURFACES);
    int stops = 0;
    for (int i = 0; i < rx->n; i++)
        stops += rx->s[i].stop != 0;
    /* In the file's own terms (a Zemax file has no "stop": true). */
    int file = rx->n >= 1 && rx->line[0] > 0;
    if (stops == 0 || rx->stop < 0 || rx->stop >= rx->n ||
        !rx->s[rx->stop].stop)
        return lr__fail(err, LR_ERR_INVALID, file ? path : sp,
                        "%s%sno aperture stop (%s)", file ? path : sp,
                        (file ? path : sp)[0] ? ": " : "",
                        !file     ? "mark one surface \"stop\": true"
                        : rx->zmx ? "give one SURF a STOP line"
                                  : "give it a row of radius 0");
    if (stops > 1)
        return lr__fail(err, LR_ERR_INVALID, sp, "%s: %d stops; a lens has one",
                        sp, stops);
    for (int i = 0; i < rx->n; i++) {
        const lr__surface *s = &rx->s[i];
        lr__path_index(p, sp, (size_t)i);
        surface_name(rx, i, p, nm, sizeof nm);
        /* "surfaces[3].semi_aperture", "SURF 4 (line 120): semi_aperture" */
        const char *dot = rx->line[i] > 0 ? ": " : ".";
        const char *ep = error_path(rx, i, path, p);
        if (!(s->semi_aperture > 0) || !isfinite(s->semi_aperture))
            return lr__fail(err, LR_ERR_INVALID, ep,
                            "%s%ssemi_aperture must be > 0, got %g", nm, dot,
                            s->semi_aperture);
        if (!(s->thickness >= 0) || !isfinite(s->thickness) ||
            !isfinite(s->radius) || !isfinite(s->conic))
            return lr__fail(err, LR_ERR_INVALID, ep,
                            "%s: radius, thickness and conic must be "
                            "finite, thickness >= 0",
                            nm);
        if (isnan(sag(s, s->semi_aperture)))
            return lr__fail(err, LR_ERR_INVALID, ep,
                            "%s%ssemi_aperture: %g mm is beyond the "
                            "surface's edge (radius %g, conic %g)",
                            nm, dot, s->semi_aperture, s->radius, s->conic);
        /* Every nm (50 apart let a pole through); a formula that has no
         * real index returns 1, so a glass's index is above 1. */
        int formula = s->after.kind != LR__GLASS_AIR &&
                      s->after.kind != LR__GLASS_CONSTANT;
        for (double wl = 380; wl <= 780; wl += 1) {
            double n = lr__glass_n(&s->after, wl);
            if (!(n >= 1.0 && n < 5.0) || (formula && n == 1.0))
                return lr__fail(err, LR_ERR_INVALID, ep,
                                "%s%smaterial: index %g at %g nm is not a "
                                "refractive index",
                                nm, dot, n, wl);
        }
    }
    /* Neighbours must not cut through each other within their common
     * aperture: z_i + sag_i(h) <= z_i + t_i + sag_{i+1}(h).  Sampled at
     * 65 heights; a touch (a cemented edge) is allowed. */
    for (int i = 0; i + 1 < rx->n; i++) {
        const lr__surface *a = &rx->s[i], *b = &rx->s[i + 1];
        double hmax = fmin(a->semi_aperture, b->semi_aperture);
        for (int k = 0; k <= 64; k++) {
            double h = hmax * k / 64.0;
            double g = a->thickness + sag(b, h) - sag(a, h);
            if (g < -1e-9 * (1.0 + a->thickness)) {
                lr__path_index(p, sp, (size_t)(i + 1));
                surface_name(rx, i + 1, p, nm, sizeof nm);
                char q[LR__PATH_MAX];
                lr__path_index(q, sp, (size_t)i);
                surface_name(rx, i, q, nm2, sizeof nm2);
                return lr__fail(
                    err, LR_ERR_INVALID, error_path(rx, i + 1, path, p),
                    "%s cuts through %s at %.4g mm from the "
                    "axis (they cross by %.4g mm; their "
                    "semi-apertures are %g and %g mm)",
                    nm, nm2, h, -g, a->semi_aperture, b->semi_aperture);
            }
        }
    }
    lr__paraxial px;
    lr_error e2;
    if (lr__rx_paraxial(rx, LR__NM_d, &px, &e2) != LR_OK || !(px.efl > 0))
        return lr__fail(err, LR_ERR_INVALID, sp,
                        "%s: the lens forms no image of a distant object "
                        "(focal length %g mm)",
                        sp, px.efl);
    return LR_OK;
}
