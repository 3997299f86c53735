/*
 * coating.c: reflectance of bare and coated lens surfaces (coating.h has
 * the formulas and their sources).
 */
#include "optics/coating.h"

#include <complex.h>
#include <math.h>
#include <string.h>
#include <strings.h>

const char *const lr__film_names[LR__FILM_COUNT] = {"MgF2", "SiO2", "Al2O3",
                                                    "ZrO2", "TiO2"};
const char lr__film_list[] = "MgF2, SiO2, Al2O3, ZrO2, TiO2";

int lr__film_find(const char *name)
{
    for (int f = 0; f < LR__FILM_COUNT; f++)
        if (strcasecmp(name, lr__film_names[f]) == 0)
            return f;
    return -1;
}

/* n^2 - 1 = sum B_i l^2 / (l^2 - C_i^2), l in um (C_i in um, squared
 * here, as the sources print them). */
static double sellmeier(const double *B, const double *C, double nm)
{
    double l2 = nm * nm * 1e-6, n2 = 1.0;
    for (int i = 0; i < 3; i++)
        n2 += B[i] * l2 / (l2 - C[i] * C[i]);
    return sqrt(n2);
}

/* The formulas are the bulk materials' (the refractiveindex.info
 * database carries each); evaporated films are somewhat less dense and
 * their indices lower, by about 0.01 for MgF2 and up to 0.3 for TiO2,
 * depending on how they were deposited (Macleod, chapter 9). */
double lr__film_n(lr__film f, double nm)
{
    /* MgF2, ordinary ray: M. J. Dodge, "Refractive properties of
     * magnesium fluoride", Appl. Opt. 23, 1980 (1984); 1.3785 at 550 nm,
     * 1.3777 at 589.3 nm. */
    static const double mgf2_B[3] = {0.48755108, 0.39875031, 2.3120353};
    static const double mgf2_C[3] = {0.04338408, 0.09461442, 23.793604};
    /* Fused silica: I. H. Malitson, "Interspecimen comparison of the
     * refractive index of fused silica", JOSA 55, 1205 (1965); 1.4584 at
     * 589.3 nm. */
    static const double sio2_B[3] = {0.6961663, 0.4079426, 0.8974794};
    static const double sio2_C[3] = {0.0684043, 0.1162414, 9.896161};
    /* Sapphire, ordinary ray: I. H. Malitson and M. J. Dodge, "Refractive
     * index and birefringence of synthetic sapphire", JOSA 62, 1405
     * (1972); 1.7681 at 589.3 nm. */
    static const double al2o3_B[3] = {1.4313493, 0.65054713, 5.3414021};
    static const double al2o3_C[3] = {0.0726631, 0.1193242, 18.028251};
    /* Cubic (yttria-stabilised) zirconia: D. L. Wood and K. Nassau,
     * "Refractive index of cubic zirconia stabilized with yttria", Appl.
     * Opt. 21, 2978 (1982); 2.1585 at 589.3 nm. */
    static const double zro2_B[3] = {1.347091, 2.117788, 9.452943};
    static const double zro2_C[3] = {0.062543, 0.166739, 24.320570};
    switch (f) {
    case LR__FILM_MGF2:
        return sellmeier(mgf2_B, mgf2_C, nm);
    case LR__FILM_SIO2:
        return sellmeier(sio2_B, sio2_C, nm);
    case LR__FILM_AL2O3:
        return sellmeier(al2o3_B, al2o3_C, nm);
    case LR__FILM_ZRO2:
        return sellmeier(zro2_B, zro2_C, nm);
    case LR__FILM_TIO2: {
        /* Rutile, ordinary ray: J. R. DeVore, "Refractive indices of
         * rutile and sphalerite", JOSA 41, 416 (1951):
         * n^2 = 5.913 + 0.2441 / (l^2 - 0.0803); 2.6129 at 589.3 nm. */
        double l2 = nm * nm * 1e-6;
        return sqrt(5.913 + 0.2441 / (l2 - 0.0803));
    }
    default:
        return 1.0;
    }
}

int lr__coating_layers(const lr__coating *c, lr__layer *out)
{
    switch (c->kind) {
    case LR__COAT_MGF2:
        out[0].film = LR__FILM_MGF2;
        out[0].thickness_nm = LR__COAT_DESIGN_NM /
                              (4.0 *
                               lr__film_n(LR__FILM_MGF2, LR__COAT_DESIGN_NM));
        return 1;
    case LR__COAT_LAYERS:
        memcpy(out, c->layer, (size_t)c->n * sizeof *out);
        return c->n;
    default:
        return 0;
    }
}

double lr__fresnel_r(double n1, double n2, double cos_i)
{
    double sin2_t = (n1 / n2) * (n1 / n2) * (1.0 - cos_i * cos_i);
    if (sin2_t >= 1.0)
        return 1.0;
    double cos_t = sqrt(1.0 - sin2_t);
    double rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    double rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

/* A layer's terms that both polarisations share: c^2, k, cos(delta) and
 * S, computed once for the two (the same values either way). */
typedef struct layer_terms {
    double c2, k;
    double complex cd, S;
} layer_terms;

static void layer_terms_at(double s0, double n, double d_nm, double nm,
                           layer_terms *t)
{
    double c2 = 1.0 - (s0 / n) * (s0 / n);
    double k = 2.0 * M_PI * n * d_nm / nm;
    double complex delta = k * csqrt(c2 + 0.0 * I);
    t->c2 = c2, t->k = k;
    t->cd = ccos(delta);
    t->S = delta == 0.0 ? 1.0 : csin(delta) / delta;
}

/* One polarisation: p = 0 (s) or 1 (p).  Sets *R and *T.
 *
 * In a layer, write delta = k c with k = 2 pi n d / lambda and c =
 * cos(theta_r) (imaginary where the wave is evanescent), and sin(delta)
 * = delta S with S = sin(delta) / delta.  Then the matrix's entries are
 *
 *     s:  sin(delta) / eta = k S / n,      eta sin(delta) = n k c^2 S
 *     p:  sin(delta) / eta = k c^2 S / n,  eta sin(delta) = n k S
 *
 * with c^2 = 1 - (n0 sin_i / n)^2 real, and cos(delta) and S even in
 * delta: no division by c (which is 0 at the layer's own critical
 * angle), and the square root's branch does not matter. */
static void one_pol(int p, double n0, double ns, const double *n,
                    const layer_terms *lt, int m, double cos_i, double cs,
                    double *R, double *T)
{
    double eta0 = p ? n0 / cos_i : n0 * cos_i;
    double etas = p ? ns / cs : ns * cs;
    /* [B; C] = M_1 M_2 ... M_m [1; eta_s], built from the substrate out:
     * each layer's matrix applied to the vector so far, last layer
     * first. */
    double complex B = 1.0, C = etas;
    for (int r = m - 1; r >= 0; r--) {
        double c2 = lt[r].c2, k = lt[r].k;
        double complex cd = lt[r].cd, S = lt[r].S;
        double complex m12 = p ? k * c2 * S / n[r] : k * S / n[r];
        double complex m21 = p ? n[r] * k * S : n[r] * k * c2 * S;
        double complex B2 = cd * B + I * m12 * C;
        double complex C2 = I * m21 * B + cd * C;
        B = B2;
        C = C2;
    }
    double complex Y = C / B;
    double complex r = (eta0 - Y) / (eta0 + Y);
    *R = creal(r * conj(r));
    double complex den = eta0 * B + C;
    *T = 4.0 * eta0 * etas / creal(den * conj(den));
}

void lr__stack_rt(double n0, double ns, const double *n, const double *d_nm,
                  int m, double cos_i, double nm, double *R, double *T)
{
    double sin2_s = (n0 / ns) * (n0 / ns) * (1.0 - cos_i * cos_i);
    if (sin2_s >= 1.0 || cos_i <= 0.0) {
        /* No wave travels on in the substrate (or grazing incidence,
         * where both polarisations reflect entirely). */
        *R = 1.0;
        if (T != NULL)
            *T = 0.0;
        return;
    }
    double s0 = n0 * sqrt(fmax(0.0, 1.0 - cos_i * cos_i));
    /* The substrate passes a wave (checked above): c_s > 0. */
    double cs = sqrt(1.0 - (s0 / ns) * (s0 / ns));
    layer_terms lt[LR__COAT_MAX_LAYERS];
    for (int r = 0; r < m; r++)
        layer_terms_at(s0, n[r], d_nm[r], nm, &lt[r]);
    double Rs, Ts, Rp, Tp;
    one_pol(0, n0, ns, n, lt, m, cos_i, cs, &Rs, &Ts);
    one_pol(1, n0, ns, n, lt, m, cos_i, cs, &Rp, &Tp);
    *R = 0.5 * (Rs + Rp);
    if (T != NULL)
        *T = 0.5 * (Ts + Tp);
}

double lr__coated_r(const lr__coating *c, int glass_air, double n_in,
                    double n_out, double cos_i, double nm)
{
    if (n_in == n_out)
        return 0.0;
    lr__layer layer[LR__COAT_MAX_LAYERS];
    int m = glass_air ? lr__coating_layers(c, layer) : 0;
    if (m == 0)
        return lr__fresnel_r(n_in, n_out, cos_i);
    /* The layers in the order the light meets them: from the air, the
     * last deposited first. */
    int from_air = n_in < n_out;
    double n[LR__COAT_MAX_LAYERS], d[LR__COAT_MAX_LAYERS];
    for (int r = 0; r < m; r++) {
        const lr__layer *L = &layer[from_air ? m - 1 - r : r];
        n[r] = lr__film_n(L->film, nm);
        d[r] = L->thickness_nm;
    }
    double R;
    lr__stack_rt(n_in, n_out, n, d, m, cos_i, nm, &R, NULL);
    return R;
}
