/*
 * prescription.h: a real lens as a list of surfaces (a "prescription"),
 * its glasses, its readers, and the rays traced through it.
 *
 * Coordinates are the optical designer's: millimetres, the optical axis
 * is z, the first surface's vertex is at z = 0 and light from the object
 * travels toward +z.  Surface i's vertex is at z_i = sum of the
 * thicknesses before it.  A radius is positive when the centre of
 * curvature lies toward +z (the image), as in Zemax, Code V, pbrt-v4's
 * lens files and every patent.
 *
 * Ownership: an lr__rx is a plain value (fixed arrays, no pointers), so
 * it is copied with `=` and freed with nothing.
 *
 * Who writes what:
 *   glass.c             the catalogue, lr__glass_n, nearest names
 *   rx_json.c           lensray's JSON form
 *   rx_pbrt.c           pbrt-v4's lens files
 *   rx_zmx.c            Zemax sequential .zmx files
 *   rx_check.c          lr__rx_check (geometry that can be built)
 *   paraxial.c          first-order data by a y-nu trace
 *   rx_trace.c          real rays, surface by surface
 *   coating.c           what each surface reflects (coating.h)
 *   ghost.c             rays reflected twice inside the lens (ghost.h)
 *   ghost_flux.c        a distant point's ghosts against its image
 *   transmit.c          what each surface passes on the main path (1 - R)
 */
#ifndef LR_PRESCRIPTION_H
#define LR_PRESCRIPTION_H

#include "util/internal.h"
#include "optics/coating.h"

#include <math.h>

/* At most this many surfaces in one prescription (the largest published
 * camera lenses have about 40). */
#define LR__RX_MAX_SURFACES 64
/* Even aspheric terms: A4 r^4 + A6 r^6 + ... + A18 r^18. */
#define LR__RX_MAX_ASPH 8

/* Wavelengths of the Fraunhofer lines, nm (Schott's catalogue). */
#define LR__NM_d 587.5618
#define LR__NM_F 486.1327
#define LR__NM_C 656.2725

/* ---- glass (glass.c) --------------------------------------------------- */

typedef enum lr__glass_kind {
    LR__GLASS_AIR,       /* n = 1 at every wavelength */
    LR__GLASS_SELLMEIER, /* n^2 - 1 = sum B_i l^2 / (l^2 - C_i), l in um */
    LR__GLASS_ABBE,      /* from nd and vd alone (see glass.c) */
    LR__GLASS_CONSTANT,  /* nd at every wavelength (pbrt-v4's files) */
    LR__GLASS_LAURENT,   /* HOYA's power series: n^2 = A0 + A1 l^2 +
                          * A2 l^-2 + A3 l^-4 + A4 l^-6 + A5 l^-8, l in um */
    LR__GLASS_POWER      /* HIKARI's: n^2 = A0 + A1 l^2 + A2 l^4 + A3 l^-2
                          * + A4 l^-4 + ... + A8 l^-12, l in um */
} lr__glass_kind;

typedef struct lr__glass {
    lr__glass_kind kind;
    char name[32];     /* the catalogue name, or "" when given by numbers */
    const char *maker; /* the catalogue's maker ("SCHOTT"), or NULL */
    double B[3], C[3]; /* SELLMEIER; C in um^2 */
    double A[9];       /* LAURENT: A0..A5; POWER: A0..A8 */
    double nd, vd;     /* ABBE and CONSTANT (vd unused there) */
} lr__glass;

/* One row of the catalogue (lib/optics/glass_table.h), as its maker gives it. */
typedef struct lr__glass_row {
    const char *name, *maker;
    lr__glass_kind kind; /* SELLMEIER, LAURENT or POWER */
    double c[9];         /* as the kind reads them (tools/glass-catalogue.py) */
    double nd, vd;       /* as the maker states them (the unit tests' truth) */
} lr__glass_row;

/* The catalogue, lr__glass_rows rows in the makers' order (glass.c). */
extern const lr__glass_row lr__glass_catalogue[];
extern const size_t lr__glass_rows;

/* The refractive index of `g` at wavelength `nm`, in nanometres. */
double lr__glass_n(const lr__glass *g, double nm);

/* The catalogue glass called `name` (without regard to case or spaces:
 * "s-bsl 7" is S-BSL7; "air" is air), or "MAKER NAME" for that maker's
 * ("CDGM F2").  Where makers share a
 * name, the first maker named in `prefer` wins (a space-separated list,
 * as a Zemax file's GCAT line gives its catalogues; words that name no
 * maker are passed over; NULL: none), else the first in catalogue order
 * (SCHOTT, OHARA, HOYA, SUMITA, CDGM, HIKARI).  Zemax's names for fused
 * silica and calcium fluoride (F_SILICA, SILICA, CAF2) are SCHOTT's
 * LITHOSIL-Q and LITHOTEC-CAF2.  A six-digit glass code, "517642" or
 * "517.642", is a model glass (LR__GLASS_ABBE) of nd 1.517 and vd 64.2.
 * Returns 0 and fills *g, or -1 when
 * there is none; then `near` (if not NULL) gets up to three nearest
 * catalogue names, comma-separated, for the error message. */
int lr__glass_find(const char *name, const char *prefer, lr__glass *g,
                   char *near, size_t near_cap);

/* lr__glass_find without a preference. */
int lr__glass_named(const char *name, lr__glass *g, char *near,
                    size_t near_cap);

/* ---- the prescription -------------------------------------------------- */

typedef struct lr__surface {
    double radius;        /* mm; 0: flat */
    double thickness;     /* mm to the next surface's vertex (the last
                             surface: to the image plane at infinity focus) */
    double semi_aperture; /* mm: rays farther from the axis are blocked */
    double conic;         /* k: 0 sphere, -1 paraboloid */
    double asph[LR__RX_MAX_ASPH]; /* A4, A6, ...: sag += A_{2j+4} r^(2j+4) */
    int stop;                     /* 1: the aperture stop (f_number scales its
                             semi_aperture; it still refracts if curved) */
    lr__glass after;              /* the medium from this surface to the next */
    lr__coating coating; /* on a glass-air surface (zero: the default, one
                            quarter-wave MgF2 layer; see coating.h) */
} lr__surface;

typedef struct lr__rx {
    char name[128];
    char source[512]; /* where the numbers come from */
    int n;            /* surfaces used in s[] */
    int stop;         /* index of the stop surface */
    lr__surface s[LR__RX_MAX_SURFACES];
    /* Where each surface came from, for lr__rx_check's messages: its
     * line in a pbrt or Zemax file (0: a JSON lens, named by its path
     * "surfaces[i]"); zmx: 1 for a Zemax file, whose SURF i + 1 s[i] is. */
    int line[LR__RX_MAX_SURFACES];
    int zmx;
} lr__rx;

/* 1 when the surface has even aspheric terms (traced by Newton's method,
 * ray by ray). */
static inline int lr__rx_aspheric(const lr__surface *s)
{
    for (int j = 0; j < LR__RX_MAX_ASPH; j++)
        if (s->asph[j] != 0.0)
            return 1;
    return 0;
}

/* Where the ray o + t d (o relative to the vertex) meets the quadric of
 * curvature c and k1 = 1 + conic: rx_trace.c's intersect for one ray,
 * and one lane of the packet traces (lr__rx_trace16; ghost16.c;
 * rx_asph16.c), with selects for early returns so that a loop of lanes
 * vectorises.  0 on a miss (then t is not meaningful).
 *
 * A t^2 + 2 B t + C = 0; the root taken is the one that becomes -C / 2B
 * as the curvature goes to 0, i.e. the sheet through the vertex (not the
 * far side of a sphere).  A ray that starts beyond the centre of
 * curvature (a wide gap before a strongly curved surface) meets the far
 * sheet first: then the other root, -den / A, is the vertex sheet's
 * (where the quadric's gradient points toward +z).  A ray inside the
 * sphere whose chord has both ends on the vertex sheet (a ghost's ray
 * that a reflection turned back, leaving the sphere steeply): the root
 * taken may lie behind it, and the one ahead is where it meets the
 * surface (it was lost: ghost.c's cross; 1e-9 mm is cross()'s tolerance
 * for a start on the surface). */
static inline int lr__rx_lane_quadric(double c, double k1, double ox, double oy,
                                      double oz, double dx, double dy,
                                      double dz, double *t_out)
{
    double A = c * (dx * dx + dy * dy + k1 * dz * dz);
    double B = c * (ox * dx + oy * dy + k1 * oz * dz) - dz;
    double C = c * (ox * ox + oy * oy + k1 * oz * oz) - 2.0 * oz;
    double disc = B * B - A * C;
    int ok = disc >= 0.0;
    double den = B + copysign(sqrt(ok ? disc : 0.0), B);
    ok &= den != 0.0;
    double t = -C / (den != 0.0 ? den : 1.0);
    double t1 = t, t2 = -den / (A != 0.0 ? A : 1.0);
    t = A != 0.0 && !(1.0 - c * k1 * (oz + t * dz) > 0.0) ? t2 : t;
    /* The root ahead where the one taken lies behind, both on the vertex
     * sheet. */
    double u = t == t1 ? t2 : t1;
    t = A != 0.0 && t < -1e-9 && u > 0.0 && 1.0 - c * k1 * (oz + u * dz) > 0.0
            ? u
            : t;
    ok &= isfinite(t);
    *t_out = t;
    return ok;
}

/* The point p there and the unit normal n, by intersect and normal_at
 * (as lr__rx_lane_quadric).  0 where those would fail (then p and n are
 * not meaningful). */
static inline int lr__rx_lane_meet(double c, double k1, double ox, double oy,
                                   double oz, double dx, double dy, double dz,
                                   double p[3], double n[3])
{
    double t;
    int ok = lr__rx_lane_quadric(c, k1, ox, oy, oz, dx, dy, dz, &t);
    p[0] = ox + t * dx, p[1] = oy + t * dy, p[2] = oz + t * dz;
    double gx = -c * p[0], gy = -c * p[1], gz = 1.0 - c * k1 * p[2];
    ok &= gz > 0.0;
    double len = sqrt(gx * gx + gy * gy + gz * gz);
    n[0] = gx / len, n[1] = gy / len, n[2] = gz / len;
    return ok;
}

/* The packet traces' index ratios eta[l] = n1[l] / n2[l] and which lanes
 * bend (n1 != n2): one division for all sixteen where the lanes share
 * their indices (the same quotient as each lane's). */
static inline void lr__rx_lane_ratios(const double *n1, const double *n2,
                                      double *eta, int *bend)
{
    int same = 1;
    for (int l = 1; l < 16; l++)
        same &= (n1[l] == n1[0]) & (n2[l] == n2[0]);
    if (same) {
        double q = n1[0] / n2[0];
        for (int l = 0; l < 16; l++)
            eta[l] = q;
    } else {
        for (int l = 0; l < 16; l++)
            eta[l] = n1[l] / n2[l];
    }
    for (int l = 0; l < 16; l++)
        bend[l] = n1[l] != n2[l];
}

/* lr__rx_refract's operations for one lane (as lr__rx_lane_meet): unit
 * d through the surface of unit normal n at the index ratio eta = n1 /
 * n2, into e.  0 on total internal reflection (then e is not
 * meaningful). */
static inline int lr__rx_lane_refract(double eta, const double n[3], double dx,
                                      double dy, double dz, double e[3])
{
    double cosi = -(n[0] * dx + n[1] * dy + n[2] * dz);
    double mx = cosi < 0.0 ? -n[0] : n[0], my = cosi < 0.0 ? -n[1] : n[1];
    double mz = cosi < 0.0 ? -n[2] : n[2];
    cosi = cosi < 0.0 ? -cosi : cosi;
    double k = 1.0 - eta * eta * (1.0 - cosi * cosi);
    double f = eta * cosi - sqrt(k >= 0.0 ? k : 0.0);
    double ex = eta * dx + f * mx, ey = eta * dy + f * my,
           ez = eta * dz + f * mz;
    double el = sqrt(ex * ex + ey * ey + ez * ez);
    e[0] = ex / el, e[1] = ey / el, e[2] = ez / el;
    return k >= 0.0;
}

/* ---- readers (rx_json.c, rx_pbrt.c, rx_zmx.c) --------------------------- */

struct cJSON;
/* lensray's JSON form, from a parsed object.  Error paths start with
 * `path` ("camera.lens" for an inline lens, "" for a lens file) and name
 * the surface and field: "camera.lens.surfaces[3].material". */
lr_status lr__rx_from_json(const struct cJSON *o, const char *path, lr__rx *rx,
                           lr_error *err);
/* pbrt-v4's lens file text, and a Zemax .zmx file's text.  Messages name
 * the file as `shown` and the line: "double-gauss.dat:7: ...". */
lr_status lr__rx_from_pbrt(const char *text, size_t len, const char *shown,
                           lr__rx *rx, lr_error *err);
lr_status lr__rx_from_zmx(const char *text, size_t len, const char *shown,
                          lr__rx *rx, lr_error *err);
/* The text readers' numbers: 0 and *x when the whole NUL-terminated
 * `word` is a decimal number ([0-9+-.eE] only: not strtod's hexadecimal,
 * "inf" or "nan"), read in the C locale whatever LC_NUMERIC the host
 * program set; -1 otherwise. */
int lr__rx_decimal(const char *word, double *x);
/* Reads a file in whichever form its name says (.json, .dat or .txt for
 * pbrt, .zmx), then checks it with lr__rx_check.  `shown` names the file
 * in messages, `json_path` is the error path (may be NULL). */
lr_status lr__rx_load_file(const char *file, const char *shown,
                           const char *json_path, lr__rx *rx, lr_error *err);

/* Resolves a camera's "lens" name to a file: `name` relative to
 * `base_dir` (the scene's directory; NULL or "": the working directory)
 * if that file exists, else a shipped lens in the lens directory
 * ($LENSRAY_LENS_DIR, else the repository's lenses/ compiled in as
 * LR_LENS_DIR) named with or without its extension (.json, .zmx, .dat).
 * Fills `out` (capacity `cap`) with the path to open.  LR_ERR_INVALID
 * when there is none, with a message that lists the shipped names;
 * LR_ERR_LIMIT when the path does not fit. */
lr_status lr__rx_find(const char *name, const char *base_dir, char *out,
                      size_t cap, lr_error *err);

/* lr__rx_find and lr__rx_load_file together: *out is a malloc'ed
 * prescription (free it with free()) on LR_OK, NULL otherwise
 * (lens_info.c; lr_lens_describe and lr_lens_ghosts). */
lr_status lr__rx_load_named(const char *lens, const char *base_dir,
                            lr__rx **out, lr_error *err);
/* The arguments of lr_lens_describe and lr_lens_ghosts_at: n_angles
 * field angles (each within +-90 degrees, exclusive) and a wavelength in
 * [300, 2000] nm; errors name "field_angles" or "wavelength"
 * (lens_info.c). */
lr_status lr__lens_check_args(const double *field_angles_deg, int n_angles,
                              double nm, lr_error *err);
/* Prints `o` compactly into *json (malloc'ed, for lr_free) and deletes
 * it; LR_ERR_NOMEM when o is NULL or printing fails (lens_info.c). */
struct cJSON;
lr_status lr__json_print_owned(struct cJSON *o, char **json, lr_error *err);

/* The shipped lenses' names: the files in the lens directory (see
 * lr__rx_find) ending in .json, .zmx, .dat or .txt, without the
 * extension, sorted.  Fills at most `max` and returns how many. */
int lr__rx_shipped(char (*names)[64], int max);

/* Checks that `rx` can be built and forms an image: one stop, positive
 * semi-apertures, no two surfaces cutting through each other within
 * their apertures, a positive finite focal length.  Messages name the
 * surface ("surfaces[4]: ...") after `path`. */
lr_status lr__rx_check(const lr__rx *rx, const char *path, lr_error *err);

/* ---- first-order data (paraxial.c) --------------------------------------- */

typedef struct lr__paraxial {
    double efl, bfl, ffl;     /* mm; bfl from the last surface, ffl from the
                              first (negative: in front of it) */
    double f_number;          /* efl / entrance pupil diameter, object at
                              infinity, the stop as given */
    double enp_pos, enp_diam; /* entrance pupil, from the first surface */
    double exp_pos, exp_diam; /* exit pupil, from the last surface */
    double total_track;       /* first vertex to the image plane (the last
                              thickness included) */
} lr__paraxial;

/* A paraxial (y-nu) trace at wavelength `nm`. */
lr_status lr__rx_paraxial(const lr__rx *rx, double nm, lr__paraxial *p,
                          lr_error *err);

/* A last thickness of 0 (the image plane on the rear vertex, which no
 * lens is built for) becomes the paraxial back focal length at the d
 * line, as pbrt's lens files mean it; left 0 when there is no real image
 * within 1e6 mm (or no stop).  The JSON and pbrt readers call it. */
void lr__rx_zero_back_focus(lr__rx *rx);

/* ---- real rays (rx_trace.c) -------------------------------------------------- */

/* The vertices' z, and the image plane's (after the last thickness),
 * as laid out by lr__rx_layout: z[i] for surface i, z[rx->n] the image. */
void lr__rx_layout(const lr__rx *rx, double *z);

/* Traces one ray through every surface of `rx` at wavelength `nm`.
 * `o` and `d` (unit) are in lens coordinates; the ray starts in the
 * medium before surface 0 (toward_image = 1: from the object side, o
 * before the first vertex) or after the last surface (toward_image = 0:
 * from the image side, travelling toward -z).  `z` is lr__rx_layout's.
 * `stop_scale` scales the stop's semi-aperture (f-number; 1 as given).
 * On success returns 1 and replaces o, d with the ray leaving the last
 * surface crossed (d unit); returns 0 when the ray misses a surface, is
 * blocked by a semi-aperture or the stop, or is totally internally
 * reflected. */
int lr__rx_trace(const lr__rx *rx, const double *z, double nm,
                 double stop_scale, int toward_image, double o[3], double d[3]);

/* The same with the indices given: n_after[i] is the index of the medium
 * after surface i at the ray's wavelength (lr__rx_indices fills it), so
 * that a camera computes them once per wavelength, not once per ray. */
void lr__rx_indices(const lr__rx *rx, double nm, double *n_after);
int lr__rx_trace_n(const lr__rx *rx, const double *z, const double *n_after,
                   double stop_scale, int toward_image, double o[3],
                   double d[3]);

/* One step of lr__rx_trace_n: through surface i alone. */
int lr__rx_trace_surface(const lr__rx *rx, const double *z,
                         const double *n_after, double stop_scale, int i,
                         int toward_image, double o[3], double d[3]);

/* Where the ray o + t d (lens coordinates, d unit, travelling either
 * way) meets surface i: returns 1 and sets p (lens coordinates) and the
 * surface's unit normal nrm there (pointing toward +z) when the point
 * lies within the semi-aperture (the stop's scaled by stop_scale); 0
 * when the ray misses or is blocked.  The first half of
 * lr__rx_trace_surface, for traces that reflect (ghost.c). */
int lr__rx_meet(const lr__rx *rx, const double *z, double stop_scale, int i,
                const double o[3], const double d[3], double p[3],
                double nrm[3]);
/* lr__rx_meet past the semi-aperture too (where the surface's formula
 * still holds): *rel is the point's height over the semi-aperture (the
 * stop's scaled), <= 1 within it. */
int lr__rx_meet_rel(const lr__rx *rx, const double *z, double stop_scale, int i,
                    const double o[3], const double d[3], double p[3],
                    double nrm[3], double *rel);

/* Snell's law in vector form: refracts unit d at unit normal nrm (either
 * orientation) from index n1 into n2; 0 on total internal reflection
 * (d unchanged). */
int lr__rx_refract(double d[3], const double nrm[3], double n1, double n2);

/* Sixteen rays from the image side (toward_image = 0) at once: o[axis]
 * [lane] and d[axis][lane] as in lr__rx_trace_n, for the lanes whose
 * alive[] is 1; a lane the lens stops gets alive[] = 0 (its o and d are
 * then meaningless).  Each lane's result is lr__rx_trace_n's, bit for
 * bit. */
void lr__rx_trace16(const lr__rx *rx, const double *z, const double *n_after,
                    double stop_scale, double (*o)[16], double (*d)[16],
                    int *alive);

/* lr__rx_trace16's step through aspheric surface i (lr__rx_aspheric)
 * toward the object, lane l from index n1[l] (after the surface) into
 * n2[l] (before it): the lanes whose alive[] is 1 get
 * lr__rx_trace_surface's bits, a lane it stops alive[] = 0 (its o and d
 * unchanged); rx_asph16.c.  With cosv, also each lane's |cosine| to the
 * normal before refracting (lr__rx_trace_t's, for the transmittance). */
void lr__rx_asph16(const lr__rx *rx, const double *z, const double *n1,
                   const double *n2, double stop_scale, int i, double (*o)[16],
                   double (*d)[16], int *alive, double *cosv);

/* lr__rx_trace16 with indices of each lane's own: nl[i][l] is lane l's
 * index after surface i (lr__rx_indices at its wavelength).  With cosv,
 * cosv[i][l] gets the |cosine| at which lane l meets surface i, before
 * refracting, for every surface a lane that stays alive crosses (the
 * transmittance's: lr__rx_trace_t's).  Each lane's result is
 * lr__rx_trace_n's with its indices, bit for bit. */
void lr__rx_trace16_nl(const lr__rx *rx, const double *z,
                       const double (*nl)[16], double stop_scale,
                       double (*o)[16], double (*d)[16], int *alive,
                       double (*cosv)[16]);

/* The same in float, for the packet camera, on `lanes` rays (a multiple
 * of 16, at most LR__RX_LANES: up to four packets at once); o and d have
 * rows of LR__RX_LANES.  Close to lr__rx_trace16's rays (float
 * rounding), not equal to them; each lane's result is the same whatever
 * `lanes` and its place among them.  With a transmittance table `tab`
 * (transmit.h; NULL: none), T[lane] is multiplied by every crossing's
 * 1 - R. */
#define LR__RX_LANES 64
struct lr__ttab;
void lr__rx_trace16f(const lr__rx *rx, const double *z, const double *n_after,
                     double stop_scale, int lanes, float (*o)[LR__RX_LANES],
                     float (*d)[LR__RX_LANES], int *alive,
                     const struct lr__ttab *tab, float *T);

/* For tests: which version of lr__rx_trace16f's transmittance lookups
 * runs: 0 = the best the CPU has (the default), 1 = portable C, 2 = AVX2,
 * 3 = AVX-512 (setting one the CPU lacks is the caller's fault).  They
 * give the same bits. */
extern int lr__rx_trace_isa;

#endif
