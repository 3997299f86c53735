/*
 * bsdf.c: materials for the path integrator (bsdf.h).
 */
#include "integrator/bsdf.h"
#include "integrator/integrator.h"

#include <math.h>

enum { DIFFUSE, PHONG, CONDUCTOR, DIELECTRIC };

/* Lobes whose roughness is below this are treated as smooth (delta): a
 * GGX lobe that narrow only adds noise. */
#define LR__MIN_ROUGHNESS 1e-3

void lr__bsdf_init(lr__bsdf *f, const lr__material *m, const lr__hit *h)
{
    f->m = m;
    f->n = h->ns;
    /* An orthonormal basis from one vector (Duff et al. 2017). */
    lr__v3 n = f->n;
    double sign = copysign(1.0, n.z);
    double a = -1.0 / (sign + n.z), b = n.x * n.y * a;
    f->t = v3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f->b = v3(b, sign + n.y * n.y * a, -n.y);
    f->eta = h->entering ? m->ior : 1.0 / m->ior;
    double w[4] = {v3_maxc(m->diffuse), v3_maxc(m->specular),
                   v3_maxc(m->reflect), v3_maxc(m->transmit)};
    double sum = 0.0;
    for (int i = 0; i < 4; i++)
        sum += w[i] = w[i] > 0.0 ? w[i] : 0.0;
    double inv = sum > 0.0 ? 1.0 / sum : 0.0;
    for (int i = 0; i < 4; i++)
        f->p[i] = w[i] * inv;
}

static int rough(const lr__bsdf *f)
{
    return f->m->roughness >= LR__MIN_ROUGHNESS;
}

/* The dielectric lobe as GGX: rough, and an interface at all.  With ior
 * 1 (allowed; a glTF ior of 0 is read as 1) a refraction is -wo, whose
 * half vector wo + eta wi is zero: the rough lobe lost the transmitted
 * light (a rough ior-1 sphere under a white sky rendered 0.26 where it
 * is invisible).  Equal indices are no interface: the smooth lobe, which
 * passes the ray straight on. */
static int rough_dielectric(const lr__bsdf *f)
{
    return rough(f) && f->eta != 1.0;
}

int lr__bsdf_has_smooth_lobes(const lr__bsdf *f)
{
    return f->p[DIFFUSE] > 0.0 || f->p[PHONG] > 0.0 ||
           (f->p[CONDUCTOR] > 0.0 && rough(f)) ||
           (f->p[DIELECTRIC] > 0.0 && rough_dielectric(f));
}

static lr__v3 to_local(const lr__bsdf *f, lr__v3 v)
{
    return v3(v3_dot(v, f->t), v3_dot(v, f->b), v3_dot(v, f->n));
}

static lr__v3 to_world(const lr__bsdf *f, lr__v3 v)
{
    return v3_add(v3_add(v3_scale(f->t, v.x), v3_scale(f->b, v.y)),
                  v3_scale(f->n, v.z));
}

/* ---- GGX -------------------------------------------------------------- */

double lr__ggx_d(double cos_m, double alpha)
{
    if (cos_m <= 0.0)
        return 0.0;
    double a2 = alpha * alpha, c2 = cos_m * cos_m;
    double k = c2 * (a2 - 1.0) + 1.0;
    return a2 / (M_PI * k * k);
}

double lr__ggx_g1(double cos_v, double vm, double alpha)
{
    /* No shadowing term for a facet seen from behind (Walter 2007, eq. 7
     * with its chi+ factor). */
    if (vm * cos_v <= 0.0)
        return 0.0;
    double c2 = cos_v * cos_v;
    double tan2 = (1.0 - c2) / c2;
    return 2.0 / (1.0 + sqrt(1.0 + alpha * alpha * tan2));
}

lr__v3 lr__ggx_sample_vn(lr__v3 v, double alpha, const double u[2])
{
    lr__v3 vh = v3_norm(v3(alpha * v.x, alpha * v.y, v.z));
    double lensq = vh.x * vh.x + vh.y * vh.y;
    lr__v3 t1 = lensq > 0.0 ? v3_scale(v3(-vh.y, vh.x, 0.0), 1.0 / sqrt(lensq))
                            : v3(1.0, 0.0, 0.0);
    lr__v3 t2 = v3_cross(vh, t1);
    double r = sqrt(u[0]), sp, cp;
    lr__sincos_2pi(u[1], &sp, &cp);
    double p1 = r * cp, p2 = r * sp;
    double s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(fmax(0.0, 1.0 - p1 * p1)) + s * p2;
    lr__v3 nh = v3_add(v3_add(v3_scale(t1, p1), v3_scale(t2, p2)),
                       v3_scale(vh, sqrt(fmax(0.0, 1.0 - p1 * p1 - p2 * p2))));
    return v3_norm(v3(alpha * nh.x, alpha * nh.y, fmax(1e-12, nh.z)));
}

/* Density of the visible normal m seen from wo (local). */
static double vn_pdf(lr__v3 wo, lr__v3 m, double alpha)
{
    double om = v3_dot(wo, m);
    return lr__ggx_g1(wo.z, om, alpha) * fmax(om, 0.0) * lr__ggx_d(m.z, alpha) /
           wo.z;
}

/* Fresnel of the dielectric for wo . m = c, eta = far / near. */
static double fresnel(double c, double eta)
{
    return c >= 0.0 ? lr__fresnel_dielectric(c, 1.0 / eta)
                    : lr__fresnel_dielectric(-c, eta);
}

/* The rough conductor: f and its lobe density (local wo, wi). */
static lr__v3 conductor_eval(const lr__bsdf *f, lr__v3 wo, lr__v3 wi,
                             double *pdf)
{
    *pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0)
        return v3(0, 0, 0);
    double a = f->m->roughness;
    lr__v3 m = v3_norm(v3_add(wo, wi));
    double D = lr__ggx_d(m.z, a);
    double G = lr__ggx_g1(wo.z, v3_dot(wo, m), a) *
               lr__ggx_g1(wi.z, v3_dot(wi, m), a);
    *pdf = vn_pdf(wo, m, a) / (4.0 * v3_dot(wi, m));
    return v3_scale(f->m->reflect, D * G / (4.0 * wo.z * wi.z));
}

/* The rough dielectric (Walter 2007; Mitsuba 3's roughdielectric). */
static lr__v3 dielectric_eval(const lr__bsdf *f, lr__v3 wo, lr__v3 wi,
                              double *pdf)
{
    *pdf = 0.0;
    if (wo.z <= 0.0 || wi.z == 0.0)
        return v3(0, 0, 0);
    double a = f->m->roughness, eta = f->eta;
    int refl = wi.z > 0.0;
    lr__v3 m = v3_norm(v3_add(wo, v3_scale(wi, refl ? 1.0 : eta)));
    if (m.z < 0.0)
        m = v3_neg(m);
    double om = v3_dot(wo, m), im = v3_dot(wi, m);
    /* Both directions must see the facet from their own side. */
    if (om <= 0.0 || im * wi.z <= 0.0)
        return v3(0, 0, 0);
    double D = lr__ggx_d(m.z, a);
    double F = fresnel(om, eta);
    double G = lr__ggx_g1(wo.z, om, a) * lr__ggx_g1(wi.z, im, a);
    double pv = vn_pdf(wo, m, a);
    if (refl) {
        *pdf = pv * F / (4.0 * im);
        return v3_scale(f->m->transmit, F * D * G / (4.0 * wo.z * wi.z));
    }
    double den = om + eta * im;
    den *= den;
    if (!(den > 0.0))
        return v3(0, 0, 0);
    *pdf = pv * (1.0 - F) * eta * eta * fabs(im) / den;
    /* Radiance mode: Walter's eta^2 cancels against the 1/eta^2 of
     * radiance crossing the interface. */
    double v = (1.0 - F) * D * G * fabs(om * im) / (wo.z * den);
    return v3_scale(f->m->transmit, v / fabs(wi.z));
}

/* lr__bsdf_eval for local wo and wi. */
static lr__v3 eval_local(const lr__bsdf *f, lr__v3 wo, lr__v3 wi, double *pdf)
{
    lr__v3 val = v3(0, 0, 0);
    double p = 0.0;
    if (wi.z > 0.0 && wo.z > 0.0) {
        if (f->p[DIFFUSE] > 0.0) {
            val = v3_madd(val, f->m->diffuse, 1.0 / M_PI);
            p += f->p[DIFFUSE] * wi.z / M_PI;
        }
        if (f->p[PHONG] > 0.0) {
            /* Normalised Phong (Lafortune & Willems 1994); its sampling
             * density is (n + 1) / (2 pi) cos^n. */
            double ns = f->m->shininess;
            lr__v3 r = v3(-wo.x, -wo.y, wo.z);
            double ca = v3_dot(r, wi);
            if (ca > 0.0) {
                double cn = pow(ca, ns);
                val = v3_madd(val, f->m->specular,
                              (ns + 2.0) / (2.0 * M_PI) * cn);
                p += f->p[PHONG] * (ns + 1.0) / (2.0 * M_PI) * cn;
            }
        }
    }
    if (rough(f)) {
        double q;
        if (f->p[CONDUCTOR] > 0.0) {
            val = v3_add(val, conductor_eval(f, wo, wi, &q));
            p += f->p[CONDUCTOR] * q;
        }
        if (f->p[DIELECTRIC] > 0.0 && rough_dielectric(f)) {
            val = v3_add(val, dielectric_eval(f, wo, wi, &q));
            p += f->p[DIELECTRIC] * q;
        }
    }
    *pdf = p;
    return val;
}

lr__v3 lr__bsdf_eval(const lr__bsdf *f, lr__v3 wo_w, lr__v3 wi_w, double *pdf)
{
    return eval_local(f, to_local(f, wo_w), to_local(f, wi_w), pdf);
}

/* Refraction of wo through facet m, eta = far / near; 0 on total
 * internal reflection. */
static int refract(lr__v3 wo, lr__v3 m, double eta, lr__v3 *wt)
{
    double c = v3_dot(wo, m);
    double s2 = (1.0 - c * c) / (eta * eta);
    if (s2 >= 1.0)
        return 0;
    double ct = sqrt(1.0 - s2);
    *wt = v3_norm(v3_add(v3_scale(wo, -1.0 / eta), v3_scale(m, c / eta - ct)));
    return 1;
}

int lr__bsdf_sample(const lr__bsdf *f, lr__v3 wo_w, double u_lobe,
                    const double u[2], lr__v3 *wi_w, lr__v3 *weight,
                    double *pdf, int *delta)
{
    lr__v3 wo = to_local(f, wo_w), wi;
    if (wo.z <= 0.0)
        return 0;
    int lobe = 0;
    double acc = f->p[0];
    while (lobe < 3 && u_lobe >= acc)
        acc += f->p[++lobe];
    if (!(f->p[lobe] > 0.0))
        return 0;
    double a = f->m->roughness;
    int sampled_above = 1; /* the side the sampled lobe sends wi to */
    *delta = 0;
    switch (lobe) {
    case DIFFUSE: {
        /* Cosine-weighted (Malley's method, concentric disk: pbrt-v3
         * 13.6.3 uses the same density). */
        double r = sqrt(u[0]), sp, cp;
        lr__sincos_2pi(u[1], &sp, &cp);
        wi = v3(r * cp, r * sp, sqrt(fmax(0.0, 1.0 - u[0])));
        break;
    }
    case PHONG: {
        double ns = f->m->shininess;
        double ca = pow(u[0], 1.0 / (ns + 1.0));
        double sa = sqrt(fmax(0.0, 1.0 - ca * ca)), phi = 2.0 * M_PI * u[1];
        lr__v3 r = v3(-wo.x, -wo.y, wo.z);
        double sign = copysign(1.0, r.z);
        double aa = -1.0 / (sign + r.z), bb = r.x * r.y * aa;
        lr__v3 t = v3(1.0 + sign * r.x * r.x * aa, sign * bb, -sign * r.x);
        lr__v3 b = v3(bb, sign + r.y * r.y * aa, -r.y);
        wi = v3_add(
            v3_add(v3_scale(t, sa * cos(phi)), v3_scale(b, sa * sin(phi))),
            v3_scale(r, ca));
        break;
    }
    case CONDUCTOR:
        if (!rough(f)) {
            *wi_w = to_world(f, v3(-wo.x, -wo.y, wo.z));
            *weight = v3_scale(f->m->reflect, 1.0 / f->p[CONDUCTOR]);
            *pdf = 0.0;
            *delta = 1;
            return 1;
        }
        {
            lr__v3 m = lr__ggx_sample_vn(wo, a, u);
            wi = v3_sub(v3_scale(m, 2.0 * v3_dot(wo, m)), wo);
        }
        break;
    default: { /* DIELECTRIC */
        lr__v3 m = rough_dielectric(f) ? lr__ggx_sample_vn(wo, a, u)
                                       : v3(0, 0, 1);
        double F = fresnel(v3_dot(wo, m), f->eta);
        /* The Fresnel choice reuses the lobe number's unused part. */
        double lo = acc - f->p[DIELECTRIC];
        double uf = (u_lobe - lo) / f->p[DIELECTRIC];
        int refl = uf < F;
        sampled_above = refl;
        if (refl)
            wi = v3_sub(v3_scale(m, 2.0 * v3_dot(wo, m)), wo);
        else if (!refract(wo, m, f->eta, &wi))
            return 0;
        if (!rough_dielectric(f)) {
            *wi_w = to_world(f, wi);
            double k = refl ? 1.0 : 1.0 / (f->eta * f->eta);
            *weight = v3_scale(f->m->transmit, k / f->p[DIELECTRIC]);
            *pdf = 0.0;
            *delta = 1;
            return 1;
        }
        break;
    }
    }
    /* A reflection must stay above the surface and a refraction go below
     * it; a sample that does not (a facet seen at a grazing angle) is
     * lost, as in Mitsuba, and not counted as the other lobe. */
    if (wi.z == 0.0 || (wi.z > 0.0) != sampled_above)
        return 0;
    *wi_w = to_world(f, wi);
    lr__v3 val = eval_local(f, wo, wi, pdf);
    if (!(*pdf > 0.0))
        return 0;
    *weight = v3_scale(val, fabs(wi.z) / *pdf);
    return v3_maxc(*weight) > 0.0;
}
