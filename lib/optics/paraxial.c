/*
 * paraxial.c: a lens's first-order data by a y-nu trace (Smith, Modern
 * Optical Engineering, 4th ed., ch. 2.5; Kingslake & Johnson, Lens Design
 * Fundamentals, ch. 3), written as 2 x 2 ray-transfer matrices on
 * (y, nu) with nu = n u the reduced angle: refraction at a surface of
 * curvature c between indices n and n' is nu' = nu - y (n' - n) c, a gap
 * t in index n is y' = y + (t / n) nu.  Each matrix has determinant 1.
 * Object and image spaces are air.
 */
#include "optics/prescription.h"

#include <math.h>
#include <string.h>

typedef struct m2 {
    double a, b, c, d;
} m2;

static m2 mul(m2 x, m2 y) /* x after y */
{
    m2 r = {x.a * y.a + x.b * y.c, x.a * y.b + x.b * y.d, x.c * y.a + x.d * y.c,
            x.c * y.b + x.d * y.d};
    return r;
}

static double n_before(const lr__rx *rx, int i, double nm)
{
    return i == 0 ? 1.0 : lr__glass_n(&rx->s[i - 1].after, nm);
}

/* Refraction at surface i. */
static m2 refract(const lr__rx *rx, int i, double nm)
{
    const lr__surface *s = &rx->s[i];
    double c = s->radius != 0 ? 1.0 / s->radius : 0.0;
    double phi = (lr__glass_n(&s->after, nm) - n_before(rx, i, nm)) * c;
    m2 r = {1, 0, -phi, 1};
    return r;
}

/* The gap after surface i. */
static m2 gap(const lr__rx *rx, int i, double nm)
{
    m2 t = {1, rx->s[i].thickness / lr__glass_n(&rx->s[i].after, nm), 0, 1};
    return t;
}

/* Surfaces [from, to) with the gaps between them (not the last's). */
static m2 span(const lr__rx *rx, int from, int to, double nm)
{
    m2 m = {1, 0, 0, 1};
    for (int i = from; i < to; i++) {
        if (i > from)
            m = mul(gap(rx, i - 1, nm), m);
        m = mul(refract(rx, i, nm), m);
    }
    return m;
}

lr_status lr__rx_paraxial(const lr__rx *rx, double nm, lr__paraxial *p,
                          lr_error *err)
{
    memset(p, 0, sizeof *p);
    if (rx->n < 1 || rx->n > LR__RX_MAX_SURFACES || rx->stop < 0 ||
        rx->stop >= rx->n)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "a lens needs surfaces and a stop");
    m2 m = span(rx, 0, rx->n, nm);
    if (!(fabs(m.c) > 1e-12))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "the lens has no power (afocal): it forms no "
                        "image of an object at infinity");
    /* Parallel ray (1, 0) leaves as (a, c): f = -1/c, the focus a/(-c)
     * after the last vertex; the ray that leaves parallel enters as
     * (1, -c/d), crossing the axis d/c from the first vertex. */
    p->efl = -1.0 / m.c;
    p->bfl = -m.a / m.c;
    p->ffl = m.d / m.c;
    double a = rx->s[rx->stop].semi_aperture;
    /* Entrance pupil: the stop seen through the surfaces before it.  A
     * ray crossing the axis at z_E enters as (-nu z_E, nu) and reaches
     * the stop at nu (b - a z_E): the pupil is at z_E = b / a, magnified
     * by a. */
    m2 f = span(rx, 0, rx->stop, nm);
    if (rx->stop > 0)
        f = mul(gap(rx, rx->stop - 1, nm), f);
    p->enp_pos = fabs(f.a) > 1e-15 ? f.b / f.a : INFINITY;
    p->enp_diam = fabs(f.a) > 1e-15 ? 2.0 * a / fabs(f.a) : INFINITY;
    /* Exit pupil: the stop seen through itself and the surfaces after
     * it.  A ray from the stop's centre, (0, nu), leaves as (b nu, d nu)
     * and crosses the axis -b/d from the last vertex; the stop's image
     * there is magnified by det / d = 1 / d. */
    m2 b = span(rx, rx->stop, rx->n, nm);
    p->exp_pos = fabs(b.d) > 1e-15 ? -b.b / b.d : INFINITY;
    p->exp_diam = fabs(b.d) > 1e-15 ? 2.0 * a / fabs(b.d) : INFINITY;
    p->f_number = p->efl / p->enp_diam;
    double track = 0;
    for (int i = 0; i < rx->n; i++)
        track += rx->s[i].thickness;
    p->total_track = track;
    if (!isfinite(p->efl) || !isfinite(p->bfl) || !isfinite(p->ffl))
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "the lens's focal length is not finite");
    return LR_OK;
}

void lr__rx_zero_back_focus(lr__rx *rx)
{
    if (rx->n < 1 || rx->s[rx->n - 1].thickness != 0 || rx->stop < 0)
        return;
    lr__paraxial px;
    lr_error e2;
    if (lr__rx_paraxial(rx, LR__NM_d, &px, &e2) == LR_OK && isfinite(px.bfl) &&
        px.bfl > 0 && px.bfl < 1e6)
        rx->s[rx->n - 1].thickness = px.bfl;
}
