/*
 * ghost.c: ghost paths, and rays traced through them (ghost.h).
 */
#include "optics/ghost.h"

#include <math.h>

int lr__ghost_paths(const lr__rx *rx, lr__ghost *out)
{
    int k = 0;
    for (int j = 1; j < rx->n; j++)
        for (int i = 0; i < j; i++)
            out[k++] = (lr__ghost){j, i};
    return k;
}

int lr__glass_is_air(const lr__glass *g)
{
    return g->kind == LR__GLASS_AIR ||
           (g->kind == LR__GLASS_CONSTANT && g->nd == 1.0);
}

int lr__rx_glass_air(const lr__rx *rx, int i)
{
    static const lr__glass air = {.kind = LR__GLASS_AIR, .nd = 1.0};
    const lr__glass *before = i > 0 ? &rx->s[i - 1].after : &air;
    return lr__glass_is_air(before) != lr__glass_is_air(&rx->s[i].after);
}

double lr__rx_surface_r(const lr__rx *rx, const double *n_after, int i,
                        int toward_image, double cos_i, double nm,
                        const lr__coating *override)
{
    double before = i > 0 ? n_after[i - 1] : 1.0, after = n_after[i];
    const lr__coating *c = override != NULL ? override : &rx->s[i].coating;
    return toward_image ? lr__coated_r(c, lr__rx_glass_air(rx, i), before,
                                       after, cos_i, nm)
                        : lr__coated_r(c, lr__rx_glass_air(rx, i), after,
                                       before, cos_i, nm);
}

/* A ray on its way through the lens, and its cosine of incidence at
 * each crossing (lr__ghost_crossings' order), so that the weights come
 * after the geometry (a ray the lens stops, or that lands outside the
 * frame, never pays for a reflectance). */
typedef struct walk {
    const lr__rx *rx;
    const double *z, *n_after;
    double stop_scale;
    double o[3], d[3];
    double *rel; /* not NULL: past the apertures too, the largest ratio */
    int n;
    double cos_i[3 * LR__RX_MAX_SURFACES];
} walk;

/* Surface i, travelling toward the image (fwd = 1) or back: reflect
 * (mirror = 1) or refract.  0: lost. */
static int cross(walk *r, int i, int fwd, int mirror)
{
    double p[3], nrm[3], rel = 0.0;
    if (r->rel != NULL
            ? !lr__rx_meet_rel(r->rx, r->z, r->stop_scale, i, r->o, r->d, p,
                               nrm, &rel)
            : !lr__rx_meet(r->rx, r->z, r->stop_scale, i, r->o, r->d, p, nrm))
        return 0;
    if (r->rel != NULL)
        *r->rel = fmax(*r->rel, rel);
    /* The surface must lie ahead: a ray that a reflection turned the
     * wrong way would otherwise meet a surface behind it.  (Zero
     * thicknesses put two surfaces at one vertex: hence the 1e-9 mm.) */
    double ahead = 0.0;
    for (int a = 0; a < 3; a++)
        ahead += (p[a] - r->o[a]) * r->d[a];
    if (ahead < -1e-9)
        return 0;
    for (int a = 0; a < 3; a++)
        r->o[a] = p[a];
    double dn = r->d[0] * nrm[0] + r->d[1] * nrm[1] + r->d[2] * nrm[2];
    r->cos_i[r->n++] = fabs(dn);
    if (mirror) {
        /* d' = d - 2 (d . n) n: the law of reflection. */
        for (int a = 0; a < 3; a++)
            r->d[a] -= 2.0 * dn * nrm[a];
        return 1;
    }
    double before = i > 0 ? r->n_after[i - 1] : 1.0, after = r->n_after[i];
    return fwd ? lr__rx_refract(r->d, nrm, before, after)
               : lr__rx_refract(r->d, nrm, after, before);
}

int lr__ghost_crossings(const lr__rx *rx, lr__ghost g, lr__ghost_xing *x)
{
    int n = rx->n, m = 0, ghost = g.j >= 0;
    if (ghost && !(g.i >= 0 && g.i < g.j && g.j < n))
        return -1;
    /* Forward to j (or through everything), back from j - 1 to i, and
     * forward again from i + 1. */
    int first = ghost ? g.j : n;
    for (int k = 0; k < first; k++)
        x[m++] = (lr__ghost_xing){k, 1, 0};
    if (ghost) {
        x[m++] = (lr__ghost_xing){g.j, 1, 1};
        for (int k = g.j - 1; k > g.i; k--)
            x[m++] = (lr__ghost_xing){k, 0, 0};
        x[m++] = (lr__ghost_xing){g.i, 0, 1};
        for (int k = g.i + 1; k < n; k++)
            x[m++] = (lr__ghost_xing){k, 1, 0};
    }
    return m;
}

int lr__ghost_trace(const lr__rx *rx, const double *z, double nm,
                    double stop_scale, const lr__coating *override, lr__ghost g,
                    double sensor_z, const double o[3], const double d[3],
                    double hit[2], double *weight)
{
    double n_after[LR__RX_MAX_SURFACES];
    lr__rx_indices(rx, nm, n_after);
    return lr__ghost_trace_t(rx, z, n_after, NULL, nm, stop_scale, override, g,
                             sensor_z, NULL, o, d, hit, weight);
}

int lr__ghost_trace_t(const lr__rx *rx, const double *z, const double *n_after,
                      const lr__ttab *tab, double nm, double stop_scale,
                      const lr__coating *override, lr__ghost g, double sensor_z,
                      const double *clip, const double o[3], const double d[3],
                      double hit[2], double *weight)
{
    return lr__ghost_trace_rel(rx, z, n_after, tab, nm, stop_scale, override, g,
                               sensor_z, clip, o, d, hit, weight, NULL);
}

int lr__ghost_trace_rel(const lr__rx *rx, const double *z,
                        const double *n_after, const lr__ttab *tab, double nm,
                        double stop_scale, const lr__coating *override,
                        lr__ghost g, double sensor_z, const double *clip,
                        const double o[3], const double d[3], double hit[2],
                        double *weight, double *rel)
{
    walk r;
    r.rx = rx, r.z = z, r.n_after = n_after, r.stop_scale = stop_scale;
    r.n = 0, r.rel = rel;
    if (rel != NULL)
        *rel = 0.0;
    for (int a = 0; a < 3; a++) {
        r.o[a] = o[a];
        r.d[a] = d[a];
    }
    lr__ghost_xing x[3 * LR__RX_MAX_SURFACES];
    int m = lr__ghost_crossings(rx, g, x);
    if (m < 0)
        return 0;
    for (int k = 0; k < m; k++)
        if (!cross(&r, x[k].i, x[k].fwd, x[k].mirror))
            return 0;
    if (!(r.d[2] > 0.0))
        return 0;
    double t = (sensor_z - r.o[2]) / r.d[2];
    hit[0] = r.o[0] + t * r.d[0];
    hit[1] = r.o[1] + t * r.d[1];
    if (clip != NULL && !(fabs(hit[0]) < clip[0] && fabs(hit[1]) < clip[1]))
        return 0;
    /* The weights: R at the two reflections, 1 - R at every other
     * crossing, each at its own cosine. */
    double w = 1.0;
    for (int k = 0; k < r.n; k++) {
        int i = x[k].i, fwd = x[k].fwd;
        double before = i > 0 ? n_after[i - 1] : 1.0, after = n_after[i];
        double R;
        if (before == after)
            R = 0.0; /* no interface (a stop): nothing reflected */
        else if (tab != NULL)
            R = lr__ttab_r(tab, i, fwd ? before : after, r.cos_i[k]);
        else {
            R = lr__rx_surface_r(rx, n_after, i, fwd, r.cos_i[k], nm, override);
        }
        w *= x[k].mirror ? R : 1.0 - R;
    }
    *weight = w;
    return 1;
}
