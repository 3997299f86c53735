/*
 * coating.h: how much light a lens surface reflects, per wavelength and
 * angle of incidence: bare (Fresnel) or under a stack of thin films.
 * The first piece of issue 29 (ghosts): the main image's 1 - R
 * (transmit.h) and the ghosts' R (ghost.h, rendered by ghost_trace.c).
 *
 * Unpolarised light: R = (R_s + R_p) / 2 throughout, since the light
 * reaching a camera lens is, to a first approximation, unpolarised, and
 * the two polarisations are reflected independently at a plane stack.
 *
 * Bare surface (Born & Wolf, Principles of Optics, section 1.5.2; Hecht,
 * Optics, section 4.6), from index n1 into n2, cos_i in n1, cos_t by
 * Snell's law n1 sin_i = n2 sin_t:
 *
 *     r_s = (n1 cos_i - n2 cos_t) / (n1 cos_i + n2 cos_t)
 *     r_p = (n2 cos_i - n1 cos_t) / (n2 cos_i + n1 cos_t)
 *     R   = (r_s^2 + r_p^2) / 2;  R = 1 when sin_t > 1 (total internal
 *                                 reflection)
 *
 * At normal incidence both give ((n1 - n2) / (n1 + n2))^2.
 *
 * A stack (Macleod, Thin-Film Optical Filters, 4th ed., chapter 2: the
 * characteristic matrix).  Layers r = 1..m between the incident medium
 * n0 and the substrate ns, each of index n_r and physical thickness d_r;
 * in each, cos(theta_r) = sqrt(1 - (n0 sin_i / n_r)^2) (complex beyond
 * the critical angle: an evanescent layer), its phase thickness
 * delta_r = 2 pi n_r d_r cos(theta_r) / lambda, and its tilted
 * admittance eta_r = n_r cos(theta_r) (s) or n_r / cos(theta_r) (p), in
 * units of free space's.  Then
 *
 *     [B]   m  [ cos delta_r          i sin delta_r / eta_r ] [ 1     ]
 *     [C] = II [ i eta_r sin delta_r  cos delta_r           ] [ eta_s ]
 *          r=1
 *
 *     Y = C / B,   r = (eta_0 - Y) / (eta_0 + Y),   R = |r|^2,
 *     T = 4 eta_0 Re(eta_s) / |eta_0 B + C|^2
 *
 * (the matrices' product in the order the light meets the layers).
 * With no layers it is the bare surface's formula.  Films here do not
 * absorb, so R + T = 1 (the tests check it, the two formulas being
 * independent of each other).
 *
 * The default coating of a glass-air surface is one quarter-wave layer
 * of MgF2 for 550 nm at normal incidence: d = 550 / (4 n_MgF2(550))
 * = 99.74 nm.  On N-BK7 it leaves about 1.3% at 550 nm where the bare
 * glass reflects 4.2%: ((n0 ns - nc^2) / (n0 ns + nc^2))^2 at the design
 * wavelength (Macleod, section 3.2.1).
 */
#ifndef LR_COATING_H
#define LR_COATING_H

/* ---- film materials ---------------------------------------------------- */

typedef enum lr__film {
    LR__FILM_MGF2,  /* magnesium fluoride */
    LR__FILM_SIO2,  /* silicon dioxide */
    LR__FILM_AL2O3, /* aluminium oxide */
    LR__FILM_ZRO2,  /* zirconium dioxide */
    LR__FILM_TIO2,  /* titanium dioxide */
    LR__FILM_COUNT
} lr__film;

/* The materials' names as a prescription gives them ("MgF2", ...), in
 * lr__film order, and a comma-separated list of them for messages. */
extern const char *const lr__film_names[LR__FILM_COUNT];
extern const char lr__film_list[];

/* The film named `name` (without regard to case), or -1. */
int lr__film_find(const char *name);

/* The index of film `f` at `nm` nanometres (sources in coating.c:
 * dispersion formulas of the crystals for MgF2, SiO2 and Al2O3, nominal
 * film indices for ZrO2 and TiO2). */
double lr__film_n(lr__film f, double nm);

/* ---- a surface's coating ---------------------------------------------- */

#define LR__COAT_MAX_LAYERS 8
/* The default layer's design wavelength (nm). */
#define LR__COAT_DESIGN_NM 550.0

typedef enum lr__coating_kind {
    LR__COAT_MGF2 = 0, /* the default: one quarter-wave MgF2 layer for
                          550 nm (a zeroed surface has it) */
    LR__COAT_NONE,     /* bare glass */
    LR__COAT_LAYERS    /* layer[0 .. n-1] */
} lr__coating_kind;

typedef struct lr__layer {
    lr__film film;
    double thickness_nm; /* physical thickness */
} lr__layer;

/* A coating sits on the glass of a glass-air surface; layer[0] touches
 * the glass, layer[n - 1] the air (the order of deposition). */
typedef struct lr__coating {
    lr__coating_kind kind;
    int n;
    lr__layer layer[LR__COAT_MAX_LAYERS];
} lr__coating;

/* The layers of coating `c`, layer[0] on the glass: fills `out` (room
 * for LR__COAT_MAX_LAYERS) and returns how many (0 for NONE). */
int lr__coating_layers(const lr__coating *c, lr__layer *out);

/* ---- reflectance -------------------------------------------------------- */

/* The stack's reflectance and transmittance, unpolarised, for light in
 * medium n0 meeting `m` layers (at most LR__COAT_MAX_LAYERS; index n[r],
 * thickness d_nm[r], r = 0 first met) on a substrate of index ns, at `cos_i` (in n0, in [0, 1])
 * and wavelength `nm`.  Sets *R and, if T is not NULL, *T.  Total
 * internal reflection in the substrate: R = 1, T = 0. */
void lr__stack_rt(double n0, double ns, const double *n, const double *d_nm,
                  int m, double cos_i, double nm, double *R, double *T);

/* The bare surface's reflectance by the Fresnel formulas above (not the
 * matrix code: the tests compare the two). */
double lr__fresnel_r(double n1, double n2, double cos_i);

/* The reflectance of an interface between index n_in (where the light
 * comes from) and n_out under coating `c` at `cos_i` and `nm`.  The
 * coating is on the denser side (the glass); where both indices are
 * equal there is no interface (R = 0).  `glass_air` is 0 for a surface
 * with glass on both sides (cemented) or air on both: those reflect as
 * bare (R = 0 for air on both), whatever c says. */
double lr__coated_r(const lr__coating *c, int glass_air, double n_in,
                    double n_out, double cos_i, double nm);

#endif
