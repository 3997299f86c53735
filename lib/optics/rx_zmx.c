/*
 * rx_zmx.c: Zemax (OpticStudio) sequential .zmx files.  Read: UNIT,
 * MODE, NAME, NOTE and GCAT (which maker's glass a shared name is) at
 * the top; per surface (the indented lines after "SURF k") TYPE STANDARD
 * or EVENASPH, CURV, CONI, PARM (the even asphere's r^2 ... r^16 terms),
 * DISZ, GLAS, DIAM (a semi-diameter), CLAP (a circular aperture: the
 * smaller of it and DIAM), STOP.  SURF 0 is the object (at infinity
 * here) and the last SURF the image.  Per-surface lines that only draw
 * or annotate (COMM, HIDE, SLAB, MEMA, POPS, COAT, FLAP, ...) are
 * ignored; any other per-surface line changes the optics in a way
 * lensray does not model, and is an error that names its line.  Zemax writes UTF-16 files as often as ASCII ones;
 * both are read.
 */
#include "optics/prescription.h"
#include "json/json_util.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_MM 1e6

/* Lines of a surface that draw, annotate or set solves on values that
 * are given anyway: ignored. */
static const char *const cosmetic[] = {
    "COMM", "HIDE", "SLAB", "MEMA", "POPS", "COAT", "FLAP", "VPAR", "VCON",
    "VDSZ", "VCRV", "PPAR", "PZUP", "MAZH", "XDAT", "CMMP", "OEMA", "ISNH",
    "TCE", "BLNK", "FIMP",
    /* The surface's unique ID, "SSID n": bookkeeping that OpticStudio
     * 2023 and later writes on every surface (VERS 231205 files). */
    "SSID",
    /* The mirror substrate's drawing (MIRR type thickness): written on
     * every surface by every OpticStudio since the 1990s; a mirror
     * itself is GLAS MIRROR. */
    "MIRR", NULL};

static int in(const char *w, const char *const *list)
{
    for (int i = 0; list[i]; i++)
        if (strcmp(w, list[i]) == 0)
            return 1;
    return 0;
}

/* The text as 8-bit characters: UTF-16LE (with its byte order mark)
 * as UTF-8, anything else copied.  Names and notes may hold characters
 * beyond ASCII (Thorlabs' files: "NAME \u00d8=2.65mm ..."); keywords and
 * numbers are ASCII either way.  A lone surrogate becomes U+FFFD.  NULL
 * when out of memory. */
static char *narrow(const char *text, size_t len, size_t *out_len)
{
    const unsigned char *u = (const unsigned char *)text;
    int utf16 = len >= 2 && u[0] == 0xFF && u[1] == 0xFE;
    size_t n = utf16 ? (len - 2) / 2 : len;
    /* At most 3 bytes of UTF-8 per UTF-16 unit (a pair: 4 for 2). */
    char *s = malloc(utf16 ? 3 * n + 1 : n + 1);
    if (s == NULL)
        return NULL;
    if (!utf16) {
        /* UTF-8's byte order mark is no part of the first keyword. */
        if (n >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0) {
            text += 3;
            n -= 3;
        }
        memcpy(s, text, n);
        s[n] = '\0';
        *out_len = n;
        return s;
    }
    size_t o = 0;
    for (size_t i = 0; i < n; i++) {
        unsigned long c = u[2 + 2 * i] | (unsigned)u[3 + 2 * i] << 8;
        if (c >= 0xD800 && c <= 0xDBFF && i + 1 < n) {
            unsigned long lo = u[4 + 2 * i] | (unsigned)u[5 + 2 * i] << 8;
            if (lo >= 0xDC00 && lo <= 0xDFFF) {
                c = 0x10000 + ((c - 0xD800) << 10) + (lo - 0xDC00);
                i++;
            }
        }
        if (c >= 0xD800 && c <= 0xDFFF)
            c = 0xFFFD;
        if (c < 0x80)
            s[o++] = (char)c;
        else if (c < 0x800) {
            s[o++] = (char)(0xC0 | c >> 6);
            s[o++] = (char)(0x80 | (c & 0x3F));
        } else if (c < 0x10000) {
            s[o++] = (char)(0xE0 | c >> 12);
            s[o++] = (char)(0x80 | (c >> 6 & 0x3F));
            s[o++] = (char)(0x80 | (c & 0x3F));
        } else {
            s[o++] = (char)(0xF0 | c >> 18);
            s[o++] = (char)(0x80 | (c >> 12 & 0x3F));
            s[o++] = (char)(0x80 | (c >> 6 & 0x3F));
            s[o++] = (char)(0x80 | (c & 0x3F));
        }
    }
    s[o] = '\0';
    *out_len = o;
    return s;
}

/* Splits the line into at most 16 words (in place). */
static int words(char *line, char **w)
{
    int n = 0;
    char *p = line;
    while (*p && n < 16) {
        while (*p && isspace((unsigned char)*p))
            p++;
        if (!*p)
            break;
        w[n++] = p;
        while (*p && !isspace((unsigned char)*p))
            p++;
        if (*p)
            *p++ = '\0';
    }
    return n;
}

/* The text of a NAME or NOTE line from `from` (a word of words()) to the
 * line's end `eol`, whole: words() splits at most 16 words and writes NULs
 * between them, which become spaces again.  Trailing blanks dropped, cut
 * to `size` bytes on a character's boundary. */
static void rest_of_line(char *from, const char *eol, char *raw, size_t size)
{
    for (char *c = from; c < eol; c++)
        if (*c == '\0')
            *c = ' ';
    size_t r = (size_t)(eol - from);
    while (r > 0 && isspace((unsigned char)from[r - 1]))
        r--;
    if (r >= size)
        r = size - 1;
    memcpy(raw, from, r);
    raw[r] = '\0';
    lr__trim_partial_utf8(raw, size, (int)r + 1);
}

/* OpticStudio cuts a long note into NOTE lines of this many characters,
 * mid-word if need be: Thorlabs' AC254-100-A (VERS 120928) ends a line
 * with "TECHSUPPORT@THORL" and the next is "ABS.COM", and Zemax's sample
 * "Double Gauss Experimental Arrangement" (VERS 190513) splits "usi" /
 * "ng" likewise; both lines hold 200 characters after "NOTE 0 ". */
#define NOTE_LINE_CHARS 200

/* The characters (UTF-8 sequences) of a line's text [text, eol); `cr`:
 * the line ended in a carriage return (which words() has since made a
 * NUL), not counted. */
static size_t note_chars(const char *text, const char *eol, int cr)
{
    size_t n = 0;
    if (cr && eol > text)
        eol--;
    for (const char *c = text; c < eol; c++)
        n += ((unsigned char)*c & 0xC0) != 0x80;
    return n;
}

static int number(const char *w, double *x)
{
    if (w == NULL)
        return -1;
    if (strcasecmp(w, "INFINITY") == 0) {
        *x = INFINITY;
        return 0;
    }
    /* Decimal only, as Zemax writes numbers. */
    return lr__rx_decimal(w, x);
}

/* A word of the file, quoted in a message: at most 40 bytes, escaped
 * where it is not UTF-8. */
static const char *quote(const char *w, char *buf, size_t cap)
{
    char raw[41];
    snprintf(raw, sizeof raw, "%s", w ? w : "");
    lr__trim_partial_utf8(raw, sizeof raw, (int)strlen(w ? w : "") + 1);
    lr__utf8_escape(raw, buf, cap);
    return buf;
}

typedef struct zsurf {
    double curv, disz, diam, coni, parm[9], clap;
    int stop, has_diam, has_clap, line, glas_line, evenasph;
    lr__glass glass;
} zsurf;

#define BAD(...) lr__fail(r->err, LR_ERR_INVALID, NULL, __VA_ARGS__)

/* The reader's state as it walks the file's lines. */
typedef struct zread {
    const char *shown; /* the file, as messages name it */
    lr_error *err;
    lr__rx *rx;
    zsurf *zs;      /* LR__RX_MAX_SURFACES + 2: object, surfaces, image */
    int nz;         /* SURF entries so far */
    int cur;        /* the surface the indented lines belong to; -1 */
    int line;       /* the line being read, from 1 */
    int note_full;  /* the last system line was a full NOTE line */
    double unit;    /* millimetres per lens unit */
    char gcat[256]; /* the GCAT line's catalogues */
} zread;

/* One line, split: its words, the line's end (a NUL now) and whether it
 * ended in a carriage return. */
typedef struct zline {
    char *w[16];
    int k;
    char *eol;
    int cr;
} zline;

/* "SURF k": the next surface starts; k must be its number. */
static lr_status surf_card(zread *r, const zline *l)
{
    char q[200];
    double x;
    if (l->k < 2 || number(l->w[1], &x) != 0 || x != r->nz)
        return BAD("%s:%d: SURF %s out of order (expected SURF %d)", r->shown,
                   r->line, quote(l->k > 1 ? l->w[1] : "", q, sizeof q), r->nz);
    if (r->nz == LR__RX_MAX_SURFACES + 2)
        return lr__fail(r->err, LR_ERR_LIMIT, NULL,
                        "%s:%d: more than %d surfaces", r->shown, r->line,
                        LR__RX_MAX_SURFACES);
    r->cur = r->nz++;
    r->zs[r->cur].line = r->line;
    r->zs[r->cur].glass.kind = LR__GLASS_AIR;
    r->zs[r->cur].glass.nd = 1;
    return LR_OK;
}

/* "UNIT MM|CM|IN|METER ...": the lens units. */
static lr_status unit_card(zread *r, const zline *l)
{
    char q[200];
    const char *u = l->w[1];
    if (strcasecmp(u, "MM") == 0)
        r->unit = 1;
    else if (strcasecmp(u, "CM") == 0)
        r->unit = 10;
    else if (strcasecmp(u, "IN") == 0)
        r->unit = 25.4;
    else if (strcasecmp(u, "METER") == 0 || strcasecmp(u, "M") == 0)
        r->unit = 1000;
    else
        return BAD("%s:%d: UNIT %s: lens units must be MM, CM, IN or METER",
                   r->shown, r->line, quote(u, q, sizeof q));
    return LR_OK;
}

/* "NOTE n text": the notes, joined, are the source.  `cont`: the line
 * before was a full NOTE line, which this one continues. */
static void note_card(zread *r, const zline *l, int cont)
{
    lr__rx *rx = r->rx;
    const char *eol = l->eol;
    int cr = l->cr;
    size_t o = strlen(rx->source);
    char raw[sizeof rx->source], esc[sizeof rx->source];
    /* The text after "NOTE n ", its blanks included. */
    char *text = l->w[1] + strlen(l->w[1]) + 1;
    r->note_full = note_chars(text, eol, cr) == NOTE_LINE_CHARS;
    rest_of_line(cont ? text : l->w[2], eol, raw, sizeof raw);
    /* A full line's trailing blank is the space between its last word
     * and the next line's first. */
    size_t n = strlen(raw);
    if (r->note_full && eol - cr > text &&
        (eol[-1 - cr] == ' ' || eol[-1 - cr] == '\0') && n + 2 < sizeof raw) {
        raw[n] = ' ';
        raw[n + 1] = '\0';
    }
    lr__utf8_escape(raw, esc, sizeof esc);
    if (o + 2 < sizeof rx->source) {
        snprintf(rx->source + o, sizeof rx->source - o, "%s%s",
                 o && !cont ? " " : "", esc);
        lr__trim_partial_utf8(rx->source, sizeof rx->source,
                              (int)strlen(rx->source) + 1);
    }
}

/* A line of the system (not indented under a SURF): only the units and
 * the mode change what the surfaces mean; the name, the notes and the
 * glass catalogues are read too, the rest passed over. */
static lr_status system_line(zread *r, const zline *l)
{
    char q[200];
    char *const *w = l->w;
    int k = l->k;
    int was_full = r->note_full;
    r->note_full = 0;
    if (strcmp(w[0], "MODE") == 0 && (k < 2 || strcasecmp(w[1], "SEQ") != 0))
        return BAD("%s:%d: MODE %s: only sequential files (MODE SEQ) are "
                   "read",
                   r->shown, r->line, quote(k > 1 ? w[1] : "", q, sizeof q));
    if (strcmp(w[0], "UNIT") == 0 && k >= 2)
        return unit_card(r, l);
    if (strcmp(w[0], "NOTE") == 0 && k >= 3) {
        note_card(r, l, was_full);
    } else if (strcmp(w[0], "GCAT") == 0 && k >= 2) {
        /* "GCAT SCHOTT OHARA ...": the catalogues whose glasses the GLAS
         * lines name, in the order Zemax searches them; it settles a
         * name two makers use (F2). */
        rest_of_line(w[1], l->eol, r->gcat, sizeof r->gcat);
    } else if (strcmp(w[0], "NAME") == 0 && k >= 2 && !r->rx->name[0]) {
        lr__rx *rx = r->rx;
        char raw[sizeof rx->name];
        rest_of_line(w[1], l->eol, raw, sizeof raw);
        lr__utf8_escape(raw, rx->name, sizeof rx->name);
        lr__trim_partial_utf8(rx->name, sizeof rx->name,
                              (int)strlen(rx->name) + 1);
    }
    return LR_OK;
}

/* "GLAS name ..." of surface z: a catalogue glass (searched in the GCAT
 * order), or a model glass; a mirror is an error. */
static lr_status glas_card(zread *r, zsurf *z, const zline *l)
{
    char q[200], q2[200], near[128];
    char *const *w = l->w;
    int k = l->k;
    z->glas_line = r->line;
    if (k < 2 || strcasecmp(w[1], "MIRROR") == 0)
        return BAD("%s:%d: GLAS %s: mirrors are not supported", r->shown,
                   r->line, quote(k > 1 ? w[1] : "", q, sizeof q));
    if (lr__glass_find(w[1], r->gcat, &z->glass, near, sizeof near) == 0)
        return LR_OK;
    /* A model glass: GLAS ___BLANK 1 0 nd vd ... (solve type 1; a pickup
     * of one, type 2, keeps the name).  A vd of 0 is Zemax's constant
     * index, as in ray-optics' reader (zemax/zmxread.py). */
    double flag, nd, vd;
    int model = k >= 6 && number(w[2], &flag) == 0 &&
                (flag == 1 || strcmp(w[1], "___BLANK") == 0);
    if (!model)
        return BAD("%s:%d: unknown glass \"%s\"; nearest: %s", r->shown,
                   r->line, quote(w[1], q, sizeof q), near);
    if (number(w[4], &nd) != 0 || number(w[5], &vd) != 0 || !(nd >= 1) ||
        !(nd <= 5) || !(vd == 0 || (vd >= 5 && vd <= 200)))
        return BAD("%s:%d: a model glass needs nd in [1, 5] and vd 0 (no "
                   "dispersion) or in [5, 200], got \"%s\" \"%s\"",
                   r->shown, r->line, quote(w[4], q, sizeof q),
                   quote(w[5], q2, sizeof q2));
    memset(&z->glass, 0, sizeof z->glass);
    z->glass.kind = vd == 0 ? LR__GLASS_CONSTANT : LR__GLASS_ABBE;
    z->glass.nd = nd;
    z->glass.vd = vd;
    return LR_OK;
}

/* "CLAP r_min r_max ...": a circular aperture; rays beyond r_max are
 * blocked, as by the semi-diameter; an annulus (r_min > 0) is not
 * modelled.  `x`: r_min, when `num_ok`. */
static lr_status clap_card(zread *r, zsurf *z, const zline *l, int num_ok,
                           double x)
{
    double rmax = 0;
    if (!num_ok || l->k < 3 || number(l->w[2], &rmax) != 0 || !isfinite(rmax) ||
        rmax <= 0 || rmax * r->unit > MAX_MM)
        return BAD("%s:%d: CLAP needs a minimum and a maximum radius > 0",
                   r->shown, r->line);
    if (x != 0)
        return BAD("%s:%d: CLAP with a minimum radius (an annular "
                   "aperture) is not supported",
                   r->shown, r->line);
    z->clap = rmax;
    z->has_clap = 1;
    return LR_OK;
}

/* A line indented under SURF r->cur: one card of the surface. */
static lr_status surface_line(zread *r, const zline *l)
{
    char q[200];
    char *const *w = l->w;
    int k = l->k;
    zsurf *z = &r->zs[r->cur];
    double x = 0;
    int num_ok = k >= 2 && number(w[1], &x) == 0;
    if (strcmp(w[0], "TYPE") == 0) {
        if (k < 2 ||
            (strcmp(w[1], "STANDARD") != 0 && strcmp(w[1], "EVENASPH") != 0))
            return BAD("%s:%d: surface type %s is not supported (STANDARD "
                       "and EVENASPH are)",
                       r->shown, r->line,
                       quote(k > 1 ? w[1] : "(none)", q, sizeof q));
        z->evenasph = strcmp(w[1], "EVENASPH") == 0;
    } else if (strcmp(w[0], "CURV") == 0) {
        if (!num_ok || !isfinite(x) || fabs(x) > 1e6)
            return BAD("%s:%d: CURV needs a finite curvature", r->shown,
                       r->line);
        z->curv = x;
    } else if (strcmp(w[0], "CONI") == 0) {
        if (!num_ok || !isfinite(x) || fabs(x) > 1e6)
            return BAD("%s:%d: CONI needs a finite conic constant", r->shown,
                       r->line);
        z->coni = x;
    } else if (strcmp(w[0], "DISZ") == 0) {
        if (!num_ok || (isfinite(x) && fabs(x) * r->unit > MAX_MM) ||
            (!isfinite(x) && r->cur != 0))
            return BAD("%s:%d: DISZ needs a finite thickness within 1 km",
                       r->shown, r->line);
        z->disz = x;
    } else if (strcmp(w[0], "DIAM") == 0) {
        if (!num_ok || !isfinite(x) || x < 0 || x * r->unit > MAX_MM)
            return BAD("%s:%d: DIAM needs a semi-diameter >= 0", r->shown,
                       r->line);
        z->diam = x;
        z->has_diam = 1;
    } else if (strcmp(w[0], "CLAP") == 0) {
        return clap_card(r, z, l, num_ok, x);
    } else if (strcmp(w[0], "OBDC") == 0) {
        /* The aperture's decentre: only none, "OBDC 0 0", is read. */
        double dy = 0;
        if (!num_ok || x != 0 ||
            (k >= 3 && (number(w[2], &dy) != 0 || dy != 0)))
            return BAD("%s:%d: OBDC: a decentred aperture is not supported",
                       r->shown, r->line);
    } else if (strcmp(w[0], "STOP") == 0) {
        z->stop = 1;
    } else if (strcmp(w[0], "PARM") == 0) {
        double v = 0;
        if (!num_ok || x != floor(x) || x < 0 || x > 8 || k < 3 ||
            number(w[2], &v) != 0 || !isfinite(v))
            return BAD("%s:%d: PARM needs an index 1 to 8 and a finite value",
                       r->shown, r->line);
        z->parm[(int)x] = v;
    } else if (strcmp(w[0], "GLAS") == 0) {
        return glas_card(r, z, l);
    } else if (!in(w[0], cosmetic)) {
        return BAD("%s:%d: %s changes the optics in a way lensray does not "
                   "model",
                   r->shown, r->line, quote(w[0], q, sizeof q));
    }
    return LR_OK;
}

/* Walks the text `s` (n8 bytes, NUL-terminated; cut into lines in place)
 * line by line: SURF lines, the system's lines, the surfaces' cards. */
static lr_status read_lines(zread *r, char *s, size_t n8)
{
    char *p = s, *end = s + n8;
    while (p < end) {
        zline l;
        l.eol = memchr(p, '\n', (size_t)(end - p));
        if (l.eol == NULL)
            l.eol = end;
        *l.eol = '\0';
        r->line++;
        if (memchr(p, '\0', (size_t)(l.eol - p)) != NULL)
            return BAD("%s:%d: a NUL byte in the text", r->shown, r->line);
        int indented = *p == ' ' || *p == '\t';
        l.cr = l.eol > p && l.eol[-1] == '\r';
        l.k = words(p, l.w);
        p = l.eol < end ? l.eol + 1 : end;
        if (l.k == 0)
            continue;
        for (char *c = l.w[0]; *c; c++)
            *c = (char)toupper((unsigned char)*c);
        if (!indented)
            r->cur = -1;
        lr_status st;
        if (strcmp(l.w[0], "SURF") == 0 && !indented)
            st = surf_card(r, &l);
        else if (r->cur < 0)
            st = system_line(r, &l);
        else
            st = surface_line(r, &l);
        if (st != LR_OK)
            return st;
    }
    return LR_OK;
}

/* Zemax's surface i (1 .. nz - 2) as lensray's s[i - 1], in millimetres;
 * the checks that need the whole surface. */
static lr_status to_surface(zread *r, int i)
{
    zsurf *z = &r->zs[i];
    lr__rx *rx = r->rx;
    lr__surface *o = &rx->s[i - 1];
    double unit = r->unit;
    if (z->has_clap && (!z->has_diam || z->clap < z->diam)) {
        z->diam = z->clap;
        z->has_diam = 1;
    }
    if (!z->has_diam || z->diam <= 0)
        return BAD("%s:%d: SURF %d has no semi-diameter (DIAM)", r->shown,
                   z->line, i);
    /* PARM are the surface type's parameters: a STANDARD surface has
     * none, and Zemax and ray-optics pass over its PARM lines (one left
     * from an EVENASPH made STANDARD again). */
    if (!z->evenasph)
        memset(z->parm, 0, sizeof z->parm);
    if (z->parm[1] != 0)
        return BAD("%s:%d: SURF %d has an r^2 aspheric term (PARM 1), which "
                   "lensray does not model",
                   r->shown, z->line, i);
    if (z->disz < 0)
        return BAD("%s:%d: SURF %d: a negative thickness (DISZ %g)", r->shown,
                   z->line, i, z->disz);
    o->radius = z->curv != 0 ? unit / z->curv : 0;
    o->thickness = z->disz * unit;
    o->semi_aperture = z->diam * unit;
    o->conic = z->coni;
    /* PARM 2..8: r^4 ... r^16; in the lens's units, so A_k scales as
     * unit^(1-k). */
    for (int j = 2; j <= 8; j++)
        o->asph[j - 2] = z->parm[j] * pow(unit, 1 - 2 * j);
    o->after = z->glass;
    o->stop = z->stop;
    rx->line[i - 1] = z->line;
    if (z->stop) {
        if (rx->stop >= 0)
            return BAD("%s:%d: a second STOP", r->shown, z->line);
        rx->stop = i - 1;
    }
    return LR_OK;
}

/* The surfaces read into rx, and the checks on the object and image
 * surfaces, which are not lensray surfaces. */
static lr_status to_rx(zread *r)
{
    const zsurf *zs = r->zs;
    int nz = r->nz;
    if (nz < 3)
        return BAD("%s: %d SURF entries; a lens needs the object, at least "
                   "one surface and the image",
                   r->shown, nz);
    for (int i = 1; i < nz - 1; i++) {
        lr_status st = to_surface(r, i);
        if (st != LR_OK)
            return st;
    }
    if (zs[0].stop)
        return BAD("%s:%d: the stop is on the object surface", r->shown,
                   zs[0].line);
    /* SURF 0's GLAS is the object space's medium: Zemax and ray-optics
     * refract the light from it into the first surface (ray-optics' EFL
     * for tests/data/lenses/cooke-triplet.zmx with SURF 0 in a model
     * glass of index 1.333 is 56% off the lens's in air).  lensray's
     * lenses look out of air. */
    if (zs[0].glas_line > 0 &&
        fabs(lr__glass_n(&zs[0].glass, LR__NM_d) - 1.0) > 1e-9)
        return BAD("%s:%d: a GLAS on SURF 0 puts the object in a medium of "
                   "index %g; lensray traces from air (a lens in front of "
                   "water or glass is not supported)",
                   r->shown, zs[0].glas_line,
                   lr__glass_n(&zs[0].glass, LR__NM_d));
    if (zs[nz - 1].stop)
        return BAD("%s:%d: the stop is on the image surface", r->shown,
                   zs[nz - 1].line);
    r->rx->n = nz - 2;
    r->rx->zmx = 1;
    return LR_OK;
}

lr_status lr__rx_from_zmx(const char *text, size_t len, const char *shown,
                          lr__rx *rx, lr_error *err)
{
    memset(rx, 0, sizeof *rx);
    rx->stop = -1;
    size_t n8;
    char *s = narrow(text, len, &n8);
    if (s == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "%s: out of memory", shown);
    zsurf *zs = calloc(LR__RX_MAX_SURFACES + 2, sizeof *zs);
    if (zs == NULL) {
        free(s);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "%s: out of memory", shown);
    }
    zread r = {
        .shown = shown, .err = err, .rx = rx, .zs = zs, .cur = -1, .unit = 1.0};
    lr_status st = read_lines(&r, s, n8);
    if (st == LR_OK)
        st = to_rx(&r);
    free(zs);
    free(s);
    return st;
}
