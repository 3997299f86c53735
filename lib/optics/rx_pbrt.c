/*
 * rx_pbrt.c: pbrt-v4's lens files (the realistic camera's "lensfile"):
 * one surface a line, from the object side, as
 *     radius  thickness  index  aperture-diameter  [abbe]
 * in millimetres, '#' starting a comment.  Conventions as pbrt-v4 reads
 * them (src/pbrt/cameras.cpp, RealisticCamera): the thickness is to the
 * next surface, the index is of the medium after the surface (0 or 1:
 * air), a radius of 0 is the aperture stop, and a positive radius has
 * its centre of curvature toward the image.  pbrt has no dispersion; a
 * fifth column, lensray's addition, gives the Abbe number vd.  The last
 * thickness, 0 in pbrt's files (pbrt places the film by focusing), is
 * then taken as the paraxial back focal length at the d line.  Older
 * tables whose second column is the distance from the surface before
 * (0 on the first row) are refused with a message that says so.
 */
#include "optics/prescription.h"
#include "json/json_util.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_MM 1e6

#define NOT_A_NUMBER (-1)
#define OUT_OF_RANGE (-2)

/* Parses the numbers of the NUL-free line [p, end) into v (room for
 * `max`); returns how many the line has (more than `max` when it has
 * too many), or NOT_A_NUMBER or OUT_OF_RANGE with *bad at the offending
 * word.  A number is decimal, as pbrt writes them: strtod's hexadecimal,
 * "inf" and "nan" are not. */
static int numbers(const char *p, const char *end, double *v, int max,
                   const char **bad)
{
    int n = 0;
    char word[64];
    while (p < end) {
        while (p < end && isspace((unsigned char)*p))
            p++;
        if (p >= end)
            break;
        const char *w = p;
        while (p < end && !isspace((unsigned char)*p))
            p++;
        *bad = w;
        size_t len = (size_t)(p - w);
        if (len >= sizeof word)
            return NOT_A_NUMBER;
        memcpy(word, w, len);
        word[len] = '\0';
        double x;
        if (lr__rx_decimal(word, &x) != 0)
            return NOT_A_NUMBER;
        if (!isfinite(x) || fabs(x) > MAX_MM)
            return OUT_OF_RANGE;
        if (n < max)
            v[n] = x;
        n++;
    }
    return n;
}

lr_status lr__rx_from_pbrt(const char *text, size_t len, const char *shown,
                           lr__rx *rx, lr_error *err)
{
    memset(rx, 0, sizeof *rx);
    rx->stop = -1;
    int line = 0, n = 0, named = 0;
    size_t src = 0;
    const char *p = text, *end = text + len;
    /* A UTF-8 byte order mark, as Windows editors write one, is not text
     * (the first line would be no comment and no number); obj.c skips
     * it likewise. */
    if (len >= 3 && memcmp(p, "\xEF\xBB\xBF", 3) == 0)
        p += 3;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (eol == NULL)
            eol = end;
        line++;
        const char *hash = memchr(p, '#', (size_t)(eol - p));
        const char *stop_at = hash != NULL ? hash : eol;
        if (memchr(p, '\0', (size_t)(eol - p)) != NULL)
            return lr__fail(err, LR_ERR_INVALID, NULL,
                            "%s:%d: a NUL byte in the text", shown, line);
        if (hash != NULL) {
            /* Comments: the first names the lens, all are its source
             * (bytes that are not UTF-8 written as \xHH). */
            const char *c = hash + 1;
            while (c < eol && (*c == ' ' || *c == '\t' || *c == '#'))
                c++;
            const char *ce = eol;
            while (ce > c && isspace((unsigned char)ce[-1]))
                ce--;
            char raw[160], esc[160];
            size_t k = (size_t)(ce - c) < sizeof raw - 1 ? (size_t)(ce - c)
                                                         : sizeof raw - 1;
            memcpy(raw, c, k);
            raw[k] = '\0';
            lr__utf8_escape(raw, esc, sizeof esc);
            if (k > 0 && !named) {
                snprintf(rx->name, sizeof rx->name, "%s", esc);
                lr__trim_partial_utf8(rx->name, sizeof rx->name,
                                      (int)strlen(esc) + 1);
                named = 1;
            }
            if (k > 0 && src + 2 < sizeof rx->source) {
                int w = snprintf(rx->source + src, sizeof rx->source - src,
                                 "%s%s", src ? "; " : "", esc);
                src = w < 0 ? src : src + (size_t)w;
                if (src >= sizeof rx->source)
                    src = sizeof rx->source - 1;
                lr__trim_partial_utf8(rx->source, sizeof rx->source,
                                      (int)src + 1);
            }
        }
        double v[5];
        const char *bad = p;
        int k = numbers(p, stop_at, v, 5, &bad);
        if (k < 0) {
            /* The word as text: bounded by the line, escaped. */
            char raw[48], esc[200];
            size_t m = 0;
            while (bad + m < stop_at && m < sizeof raw - 1 &&
                   !isspace((unsigned char)bad[m]))
                m++;
            memcpy(raw, bad, m);
            raw[m] = '\0';
            lr__utf8_escape(raw, esc, sizeof esc);
            if (k == OUT_OF_RANGE)
                return lr__fail(err, LR_ERR_INVALID, NULL,
                                "%s:%d: \"%s\" is out of range (a number of "
                                "a lens file is within +-%g mm)",
                                shown, line, esc, MAX_MM);
            return lr__fail(err, LR_ERR_INVALID, NULL,
                            "%s:%d: \"%s\" is not a number (a line is: "
                            "radius thickness index aperture-diameter "
                            "[abbe], in mm)",
                            shown, line, esc);
        }
        p = eol < end ? eol + 1 : end;
        if (k == 0)
            continue;
        if (k < 4 || k > 5)
            return lr__fail(err, LR_ERR_INVALID, NULL,
                            "%s:%d: %d numbers; a line is: radius thickness "
                            "index aperture-diameter [abbe]",
                            shown, line, k);
        if (n == LR__RX_MAX_SURFACES)
            return lr__fail(err, LR_ERR_LIMIT, NULL,
                            "%s:%d: more than %d surfaces", shown, line,
                            LR__RX_MAX_SURFACES);
        lr__surface *s = &rx->s[n];
        memset(s, 0, sizeof *s);
        rx->line[n] = line;
        s->radius = v[0];
        s->thickness = v[1];
        s->semi_aperture = v[3] / 2;
        if (v[1] < 0)
            return lr__fail(err, LR_ERR_INVALID, NULL,
                            "%s:%d: thickness must be >= 0, got %g", shown,
                            line, v[1]);
        if (!(v[3] > 0))
            return lr__fail(err, LR_ERR_INVALID, NULL,
                            "%s:%d: aperture diameter must be > 0, got %g",
                            shown, line, v[3]);
        if (v[2] != 0 && !(v[2] >= 1 && v[2] <= 5))
            return lr__fail(err, LR_ERR_INVALID, NULL,
                            "%s:%d: index must be 0 (air), or between 1 "
                            "and 5, got %g",
                            shown, line, v[2]);
        if (v[0] == 0) {
            if (rx->stop >= 0)
                return lr__fail(err, LR_ERR_INVALID, NULL,
                                "%s:%d: a second stop (radius 0); the "
                                "first is surface %d",
                                shown, line, rx->stop);
            rx->stop = n;
            s->stop = 1;
        }
        s->after.nd = v[2] > 1 ? v[2] : 1.0;
        s->after.kind = v[2] > 1 ? LR__GLASS_CONSTANT : LR__GLASS_AIR;
        if (k == 5 && v[4] != 0) {
            if (!(v[4] >= 5 && v[4] <= 200) || !(v[2] > 1))
                return lr__fail(err, LR_ERR_INVALID, NULL,
                                "%s:%d: an Abbe number must be between 5 "
                                "and 200, on a glass (index > 1); got %g",
                                shown, line, v[4]);
            s->after.kind = LR__GLASS_ABBE;
            s->after.vd = v[4];
        }
        n++;
    }
    if (n == 0)
        return lr__fail(err, LR_ERR_INVALID, NULL, "%s: no surfaces", shown);
    /* A glass surface 0 mm before the next: the older tables whose second
     * column is each surface's distance from the one before ("axpos", 0
     * on the first row, and no distance to the film), as pbrt-v4-scenes'
     * unscaled dgauss.dat, wide.dat, fisheye.dat and telephoto.dat still
     * are.  Read as thicknesses they make a lens whose surfaces cross
     * somewhere further on, a message that does not name the cause. */
    if (n > 1 && !rx->s[0].stop && rx->s[0].thickness == 0)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "%s:%d: the first surface is 0 mm before the next: "
                        "the second column is the thickness to the next "
                        "surface (pbrt-v4's convention), not the distance "
                        "from the one before (an older table's \"axpos\", "
                        "0 on the first row): move that column up a row",
                        shown, rx->line[0]);
    rx->n = n;
    lr__rx_zero_back_focus(rx);
    return LR_OK;
}
