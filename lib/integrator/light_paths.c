/*
 * light_paths.c: the `light` integrator (light_paths.h).
 *
 * A path starts on a light picked in proportion to its power: a point y
 * of an area light (uniform by area over the light, density pdf_A) and a
 * direction w about its normal n, cosine-distributed, so that the flux
 * weight leaving is beta = Le cos / (pdf_A cos / pi) = pi Le / pdf_A; a
 * point light's position and a uniform direction (beta = I 4 pi); the
 * environment's or a directional light's light through a disk of radius
 * R across the scene's bounds, perpendicular to its direction (beta =
 * Le pi R^2 / pdf_dir, or E pi R^2).  Each pick's probability divides
 * beta too.
 *
 * Every vertex x the path meets, with the path's light arriving along
 * wp (unit, towards where it came from), joins a lens point P drawn as
 * the camera draws it.  The pixel the camera ray from P to x lands in
 * gets
 *
 *     beta f(wc, wp) (|ns.wp| / |ng.wp|) |ng.wc| / d^2 x W / N
 *
 * with wc the unit direction from x to P, d the distance, f the BSDF in
 * radiance's direction (light arriving along wp, leaving along wc), W
 * the camera's importance per unit solid angle at P (camera.h's `film`,
 * over the lens point's density) and N the paths.  The particles' flux
 * at x estimates the incident radiance's projected measure, so their
 * sum of f over the particles estimates radiance leaving along wc per
 * unit area, and |ng.wc| / d^2 turns area at x into solid angle at P;
 * the shading normal's ratio is Veach's correction (1997, section 5.3).
 * The light's own point joins the lens too (emission seen directly):
 * Le cos_y / d^2 x W / (pdf_A N), and for the environment Le W /
 * (pdf_dir N) along an escaping camera ray.
 *
 * The walk goes on by the BSDF's own sampling with wo = wp, whose weight
 * is f(wp, wi) |ns.wi| / pdf: light leaving along wi needs f(wi, wp),
 * which is the same for every lobe but refraction's, where radiance
 * mode's 1 / eta^2 is not the particles' (flux is not compressed with
 * the solid angle): the weight is multiplied by eta^2 there (pbrt-v4's
 * TransportMode::Importance), and by the shading normals' ratio
 * |ns.wp| |ng.wi| / (|ng.wp| |ns.wi|).
 *
 * A camera ray that meets x first is what makes the join count: the
 * trace from P along P -> x must meet the same geometry at the same
 * distance (1e-4 of it), the way the light side's direct paths ask for
 * the camera's own trace (light_trace.c).
 */
#include "integrator/light_paths.h"

#include "integrator/bsdf.h"
#include "integrator/integrator.h"
#include "scene/envmap.h"
#include "scene/light.h"
#include "integrator/path.h"
#include "json/json_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* Random dimensions of a path: the light (0 - 7), then each surface. */
#define DIM_PICK 0
#define DIM_POINT 2
#define DIM_DIR 4
#define DIM_LENS0 6
#define DIM_SURF 8
#define DIMS_PER_SURF 6

enum { KIND_AREA, KIND_ENV, KIND_DELTA, KINDS };

struct lr__lp {
    int max_depth;
    /* Spectral mode with colours that focus apart: the wavelengths'
     * table (light_trace.c's, not owned), placed by the path's dimension
     * after its last surface's; else NULL. */
    const lr__wl_table *wl;
    double p_kind[KINDS]; /* pick probabilities, summing to 1 */
    double *delta_cdf;    /* over s->lights by power; owned */
    lr__v3 C;             /* the disk's centre and radius (scene bounds) */
    double R;
};

void lr__lp_set_wl(lr__lp *lp, const lr__wl_table *wl)
{
    lp->wl = wl;
}

void lr__lp_free(lr__lp *lp)
{
    if (lp == NULL)
        return;
    free(lp->delta_cdf);
    free(lp);
}

/* The mean luminance of the environment over 256 directions of a
 * Fibonacci sphere: for the pick's share only. */
static double env_mean(const lr_scene *s)
{
    const int n = 256;
    double sum = 0.0, ga = M_PI * (3.0 - sqrt(5.0));
    for (int i = 0; i < n; i++) {
        double z = 1.0 - (2.0 * i + 1.0) / n, r = sqrt(1.0 - z * z);
        lr__v3 d = v3(r * cos(ga * i), r * sin(ga * i), z);
        sum += lr__luminance(lr__env_radiance(s, d));
    }
    return sum / n;
}

/* Why scene s with settings set cannot be traced from its lights alone:
 * an error naming the field, or LR_OK. */
static lr_status check_scene(const lr_scene *s, const lr__cam *c,
                             const lr_render_settings *set, lr_error *err)
{
    const char *me = "render.integrator \"light\"";
    if (!set->light)
        return lr__fail(err, LR_ERR_INVALID, "render.light",
                        "render.light: false contradicts %s, which traces "
                        "every path from the lights",
                        me);
    const lr__camera_model *m = c->model;
    if (m->lens_point == NULL || m->film == NULL)
        return lr__fail(err, LR_ERR_INVALID, "camera.model",
                        "camera.model: \"%s\" has no light side, which %s "
                        "needs (use thinlens, bracket, pinhole or lens)",
                        m->name, me);
    if (m->light_ok != NULL && !m->light_ok(c))
        return lr__fail(err, LR_ERR_INVALID, "camera.lens",
                        "camera.lens: this lens passes rays steeper than its "
                        "light side holds (a fisheye or extreme wide angle), "
                        "which %s needs",
                        me);
    /* (Colours traced one by one from their own lens points, the
     * bracket's, would need a walk per colour.) */
    if (!lr__cam_lands_colours(c) || lr__cam_colours_apart(c) > 0)
        return lr__fail(err, LR_ERR_INVALID, "camera.chromatic",
                        "camera.chromatic: %s lands colours that focus "
                        "apart through the thin lens and real lenses, not "
                        "through the bracket (whose lens point moves with "
                        "the focus)",
                        me);
    if (v3_maxc(s->ambient) > 0.0) {
        char q[32];
        snprintf(q, sizeof q, "lights[%d]", s->ambient_at);
        return lr__fail(err, LR_ERR_INVALID, q,
                        "%s: an ambient light is emitted by nothing, so %s "
                        "cannot trace it",
                        q, me);
    }
    for (size_t g = 0; g < s->n_geoms + s->n_planes; g++) {
        const lr__geom *geo = g < s->n_geoms ? &s->geoms[g]
                                             : &s->planes[g - s->n_geoms];
        const lr__material *mt = &s->materials[geo->material];
        if (mt->emission_tex != NULL) {
            char q[LR__PATH_MAX];
            snprintf(q, sizeof q, "materials.%s", mt->name);
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s: textured emission is not traced from the "
                            "lights yet (%s)",
                            q, me);
        }
        if (g >= s->n_geoms && v3_maxc(mt->emission) > 0.0)
            return lr__fail(err, LR_ERR_INVALID, "objects",
                            "objects: an emitting infinite plane (material "
                            "\"%s\") has no point for %s to start a path "
                            "from (use a mesh)",
                            mt->name, me);
    }
    /* The field is the far light's (it said "objects", for a background
     * the user may not know lights the scene). */
    char far[32] = "";
    if (lr__env_is_light(s))
        snprintf(far, sizeof far, "%s",
                 s->env != NULL ? "environment" : "background");
    for (size_t i = 0; i < s->n_lights && !far[0]; i++)
        if (s->lights[i].kind == LR__LIGHT_DIRECTIONAL)
            snprintf(far, sizeof far, "lights[%zu]", i);
    if (far[0] && s->n_planes > 0)
        return lr__fail(err, LR_ERR_INVALID, far,
                        "%s: with %s, light from %s starts its paths on a "
                        "disk across the scene's bounds, which cannot cover "
                        "the scene's infinite plane (use a mesh for the "
                        "plane%s)",
                        far, me,
                        far[0] == 'l' ? "a directional light"
                                      : "the environment or background",
                        far[0] == 'b' ? ", or a black background" : "");
    return LR_OK;
}

lr_status lr__lp_prepare(const lr_scene *s, const lr__cam *c,
                         const lr_render_settings *set, lr__lp **out,
                         double *lref, lr_error *err)
{
    *out = NULL;
    lr_status st = check_scene(s, c, set, err);
    if (st != LR_OK)
        return st;
    lr__lp *lp = calloc(1, sizeof *lp);
    if (lp != NULL)
        lp->delta_cdf = malloc((s->n_lights + 1) * sizeof(double));
    if (lp == NULL || lp->delta_cdf == NULL) {
        lr__lp_free(lp);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    lp->max_depth = set->max_depth;
    /* A sphere about the origin holding every coordinate, and the eye. */
    lp->C = v3(0, 0, 0);
    lp->R = fmax(s->extent * sqrt(3.0), sqrt(v3_dot(c->origin, c->origin))) *
                1.01 +
            1e-6;
    double disk = M_PI * lp->R * lp->R, L = 0.0, power[KINDS] = {0, 0, 0};
    for (size_t i = 0; i < s->n_emitters; i++) {
        const lr__emitter *e = &s->emitters[i];
        lr__v3 Le = s->materials[s->geoms[e->geom].material].emission;
        power[KIND_AREA] += M_PI * e->area * lr__luminance(Le);
        L = fmax(L, v3_maxc(Le));
    }
    if (lr__env_is_light(s)) {
        power[KIND_ENV] = env_mean(s) * 4.0 * M_PI * disk;
        L = fmax(L, s->env != NULL ? lr__envmap_max(s->env)
                                   : v3_maxc(s->background));
    }
    for (size_t i = 0; i < s->n_lights; i++) {
        const lr__light *lt = &s->lights[i];
        double p = lr__luminance(lt->power);
        p *= lt->kind == LR__LIGHT_POINT ? 4.0 * M_PI : disk;
        power[KIND_DELTA] += p;
        lp->delta_cdf[i] = power[KIND_DELTA];
        /* A point light's radiance on a surface R away, or a directional
         * light's on one facing it. */
        L = fmax(L, v3_maxc(lt->power) /
                        (lt->kind == LR__LIGHT_POINT ? lp->R * lp->R : 1.0));
    }
    for (size_t i = 0; i < s->n_lights; i++)
        lp->delta_cdf[i] /= power[KIND_DELTA];
    if (s->n_lights > 0)
        lp->delta_cdf[s->n_lights - 1] = 1.0;
    double total = power[0] + power[1] + power[2];
    for (int k = 0; k < KINDS; k++)
        lp->p_kind[k] = total > 0.0 ? power[k] / total : 0.0;
    *lref = L > 0.0 ? L : 1.0;
    *out = lp;
    return LR_OK;
}

static lr__v3 uniform_sphere(const double u[2])
{
    double z = 1.0 - 2.0 * u[0], r = sqrt(fmax(0.0, 1.0 - z * z));
    double sn, cs;
    lr__sincos_2pi(u[1], &sn, &cs);
    return v3(r * cs, r * sn, z);
}

/* A light path's state: where it starts, its direction and flux. */
typedef struct walk {
    const lr__lp *lp;
    const lr_scene *s;
    const lr__cam *c;
    const lr__sampler *smp;
    uint64_t key;
    uint32_t idx;
    double inv_n; /* 1 / the paths */
    double u_wl;  /* places the wavelengths (lr__cam_land) */
    lr__lp_splat_fn splat;
    void *film;
    uint64_t *rays, *landed;
} walk;

static void dims(const walk *w, uint32_t dim, double u[2])
{
    lr__sample_2d(w->smp, w->key, w->idx, dim, u);
}

/* The lens point of dimension `dim` and the camera ray from it towards
 * x: where it lands (0: nowhere).  *dir, *dist: from P to x. */
static int to_lens(const walk *w, uint32_t dim, lr__v3 x, lr__v3 *P,
                   lr__v3 *dir, double *dist, lr__landing *ld)
{
    double u[2], ox, oy;
    dims(w, dim, u);
    *P = w->c->model->lens_point(w->c, u, &ox, &oy);
    lr__v3 d = v3_sub(x, *P);
    *dist = sqrt(v3_dot(d, d));
    if (!(*dist > 0.0))
        return 0;
    *dir = v3_scale(d, 1.0 / *dist);
    return lr__cam_land(w->c, w->lp->wl, w->u_wl, ox, oy, *dir, ld);
}

/* A hit's geometric normal on the surface's outside (its front). */
static lr__v3 outward(const lr__hit *h)
{
    return h->entering ? h->ng : v3_neg(h->ng);
}

/* Whether the camera ray from P along dir meets geometry geom first, at
 * distance dist (to 1e-4 of it), on the sheet of the vertex whose
 * outward normal is out; the hit in *h.  (The sheet: near a sphere's
 * outline its near and far sheets lie within 1e-4 of each other, and a
 * light shut inside a grey sphere reached the camera through the inside
 * of its far wall, some 1e-5 of the light.) */
static int camera_meets(const walk *w, lr__v3 P, lr__v3 dir, double dist,
                        long geom, lr__v3 out, lr__hit *h)
{
    lr__v3 o = lr__cam_ray_start(w->c, P, dir);
    dist -= sqrt(v3_dot(v3_sub(o, P), v3_sub(o, P)));
    (*w->rays)++;
    return dist > 0.0 && lr__trace(w->s, o, dir, INFINITY, h) &&
           h->geom == geom && fabs(h->t - dist) <= 1e-4 * dist + 4.0 * h->eps &&
           !(v3_dot(outward(h), dir) * v3_dot(out, dir) < 0.0);
}

static void add(const walk *w, const lr__landing *ld, lr__v3 v)
{
    if (!(v3_maxc(v) > 0.0))
        return;
    w->splat(w->film, ld, v, w->landed);
}

/* The light's own point y (normal n, emission Le, area density pdf_A)
 * seen through the lens. */
static void join_emitter(const walk *w, lr__v3 y, lr__v3 n, lr__v3 Le,
                         double pdf_A, long geom)
{
    lr__v3 P, dir;
    double dist;
    lr__landing ld;
    if (!to_lens(w, DIM_LENS0, y, &P, &dir, &dist, &ld))
        return;
    double cos_y = -v3_dot(dir, n);
    lr__hit h;
    if (!(cos_y > 0.0) || !camera_meets(w, P, dir, dist, geom, n, &h) ||
        !h.entering)
        return;
    add(w, &ld, v3_scale(Le, cos_y / (dist * dist * pdf_A) * w->inv_n));
}

/* Vertex h of the path, its light arriving along wp with flux beta,
 * seen through the lens (dimension `dim` for the lens point). */
static void join_vertex(const walk *w, const lr__hit *h, const lr__bsdf *f,
                        lr__v3 wp, lr__v3 beta, uint32_t dim)
{
    lr__v3 P, dir;
    double dist;
    lr__landing ld;
    if (!to_lens(w, dim, h->p, &P, &dir, &dist, &ld))
        return;
    lr__v3 wc = v3_neg(dir);
    double pdf;
    lr__v3 fv;
    if (v3_dot(wc, h->ng) >= 0.0) {
        fv = lr__bsdf_eval(f, wc, wp, &pdf);
    } else {
        /* Through the surface: the BSDF's frame faces wo (bsdf.h), so
         * that its eta is the far side's over wo's: the hit seen from
         * the camera's side. */
        lr__hit hb = *h;
        hb.ng = v3_neg(h->ng);
        hb.ns = v3_neg(h->ns);
        hb.entering = !h->entering;
        lr__bsdf fb;
        lr__bsdf_init(&fb, f->m, &hb);
        fv = lr__bsdf_eval(&fb, wc, wp, &pdf);
    }
    double ngp = fabs(v3_dot(h->ng, wp));
    if (!(v3_maxc(fv) > 0.0) || !(ngp > 0.0))
        return;
    lr__hit hc;
    if (!camera_meets(w, P, dir, dist, h->geom, outward(h), &hc))
        return;
    double g = fabs(v3_dot(h->ns, wp)) / ngp * fabs(v3_dot(h->ng, wc)) /
               (dist * dist);
    add(w, &ld, v3_scale(v3_mul(beta, fv), g * w->inv_n));
}

/* The environment along unit d (radiance Le, drawn with density pdf_d)
 * seen through the lens: along the camera ray from a lens point in
 * direction d, if it escapes. */
static void join_env(const walk *w, lr__v3 d, lr__v3 Le, double pdf_d)
{
    double ul[2], ox, oy;
    dims(w, DIM_LENS0, ul);
    lr__v3 P = w->c->model->lens_point(w->c, ul, &ox, &oy);
    lr__landing ld;
    if (!lr__cam_land(w->c, w->lp->wl, w->u_wl, ox, oy, d, &ld))
        return;
    lr__hit h;
    (*w->rays)++;
    if (lr__trace(w->s, lr__cam_ray_start(w->c, P, d), d, INFINITY, &h))
        return;
    add(w, &ld, v3_scale(Le, 1.0 / pdf_d * w->inv_n));
}

/* Light arriving from unit direction d (irradiance E on a surface facing
 * it, over the pick's density): a path from a point of the disk of
 * radius R across the bounds, drawn uniformly from u, towards -d. */
static int start_disk(const walk *w, lr__v3 d, const double u[2], lr__v3 E,
                      lr__v3 *org, lr__v3 *dir, lr__v3 *beta)
{
    const lr__lp *lp = w->lp;
    lr__v3 t1, t2;
    v3_frame(d, &t1, &t2);
    double r = lp->R * sqrt(u[0]), sn, cs;
    lr__sincos_2pi(u[1], &sn, &cs);
    *org = v3_add(v3_madd(lp->C, d, lp->R),
                  v3_add(v3_scale(t1, r * cs), v3_scale(t2, r * sn)));
    *dir = v3_neg(d);
    *beta = v3_scale(E, M_PI * lp->R * lp->R);
    return v3_maxc(*beta) > 0.0;
}

/* Where the path starts: *org, *dir and its flux *beta (0: nothing). */
static int start(const walk *w, lr__v3 *org, lr__v3 *dir, lr__v3 *beta)
{
    const lr__lp *lp = w->lp;
    const lr_scene *s = w->s;
    double up[2], ux[2], ud[2];
    dims(w, DIM_PICK, up);
    dims(w, DIM_POINT, ux);
    dims(w, DIM_DIR, ud);
    double u = up[0], pa = lp->p_kind[KIND_AREA], pe = lp->p_kind[KIND_ENV];
    if (u < pa && s->n_emitters > 0) {
        /* An emitter by power, a point on it by area. */
        size_t lo = 0, hi = s->n_emitters - 1;
        while (lo < hi) {
            size_t mid = (lo + hi) / 2;
            if (s->emitter_cdf[mid] > up[1])
                hi = mid;
            else
                lo = mid + 1;
        }
        const lr__emitter *e = &s->emitters[lo];
        const lr__geom *g = &s->geoms[e->geom];
        double pe_i = s->emitter_cdf[lo] -
                      (lo > 0 ? s->emitter_cdf[lo - 1] : 0);
        lr__v3 y, n;
        if (g->kind == LR__GEOM_SPHERE) {
            n = uniform_sphere(ux);
            y = v3_madd(g->center, n, g->radius);
        } else {
            double sq = sqrt(ux[0]);
            y = v3_add(e->a, v3_add(v3_scale(e->e1, sq * (1.0 - ux[1])),
                                    v3_scale(e->e2, sq * ux[1])));
            n = e->n;
        }
        double pdf_A = pa * pe_i / e->area;
        lr__v3 Le = s->materials[g->material].emission;
        if (!(pdf_A > 0.0))
            return 0;
        join_emitter(w, y, n, Le, pdf_A, (long)e->geom);
        /* Cosine-distributed about n. */
        lr__v3 t1, t2;
        v3_frame(n, &t1, &t2);
        double r = sqrt(ud[0]), sn, cs;
        lr__sincos_2pi(ud[1], &sn, &cs);
        *dir = v3_norm(
            v3_add(v3_scale(n, sqrt(fmax(0.0, 1.0 - ud[0]))),
                   v3_add(v3_scale(t1, r * cs), v3_scale(t2, r * sn))));
        double mag = fmax(fabs(y.x), fmax(fabs(y.y), fabs(y.z)));
        *org = v3_madd(y, n, (s->eps_floor + mag) * 0x1p-17);
        *beta = v3_scale(Le, M_PI / pdf_A);
        return 1;
    }
    if (u < pa + pe) {
        /* The environment: towards direction d, through a disk across
         * the bounds; seen directly along an escaping camera ray.  A map
         * draws d by its own importance (lr__envmap_sample, as the path
         * tracer does): drawn uniformly, a one-texel sun was met by 4 to
         * 7 paths in 262144, and at 256 spp a sphere it lit came out
         * black or 1.26 times the path tracer's by the seed.  The
         * uniform background keeps the uniform draw. */
        double pdf_env = 1.0 / (4.0 * M_PI);
        lr__v3 d, Le;
        if (s->env != NULL)
            d = lr__envmap_sample(s, ux, &Le, &pdf_env);
        else
            d = uniform_sphere(ux);
        if (!(pdf_env > 0.0))
            return 0;
        Le = lr__env_radiance(s, d);
        double pdf_d = pe * pdf_env;
        join_env(w, d, Le, pdf_d);
        return start_disk(w, d, ud, v3_scale(Le, 1.0 / pdf_d), org, dir, beta);
    }
    /* A point or directional light by power. */
    if (s->n_lights == 0)
        return 0;
    size_t i = 0;
    while (i + 1 < s->n_lights && lp->delta_cdf[i] <= up[1])
        i++;
    const lr__light *lt = &s->lights[i];
    double p = lp->p_kind[KIND_DELTA] *
               (lp->delta_cdf[i] - (i > 0 ? lp->delta_cdf[i - 1] : 0.0));
    if (!(p > 0.0))
        return 0;
    if (lt->kind == LR__LIGHT_DIRECTIONAL)
        return start_disk(w, v3_neg(lt->direction), ud,
                          v3_scale(lt->power, 1.0 / p), org, dir, beta);
    *dir = uniform_sphere(ux);
    *org = lt->position;
    double fall = lr__spot_falloff(lt, v3_neg(*dir));
    *beta = v3_scale(lt->power, fall * 4.0 * M_PI / p);
    return fall > 0.0;
}

void lr__lp_path(const lr__lp *lp, const lr_scene *s, const lr__cam *c,
                 const lr__sampler *smp, uint64_t key, uint32_t idx,
                 double n_paths, lr__lp_splat_fn splat, void *film,
                 uint64_t *rays, uint64_t *landed)
{
    walk w = {lp,  s,     c,    smp,  key,   idx, 1.0 / n_paths,
              0.0, splat, film, rays, landed};
    if (lp->wl != NULL) {
        double u[2];
        dims(&w, DIM_SURF + DIMS_PER_SURF * (uint32_t)(lp->max_depth + 1), u);
        w.u_wl = u[0];
    }
    lr__v3 org, dir, beta;
    if (!start(&w, &org, &dir, &beta))
        return;
    double beta0 = v3_maxc(beta);
    for (int k = 0; k <= lp->max_depth; k++) {
        lr__hit h;
        (*rays)++;
        if (!lr__trace(s, org, dir, INFINITY, &h))
            return;
        lr__material mt;
        const lr__material *m = lr__hit_material(s, &h, &mt);
        lr__bsdf f;
        lr__bsdf_init(&f, m, &h);
        lr__v3 wp = v3_neg(dir);
        uint32_t dim = DIM_SURF + DIMS_PER_SURF * (uint32_t)k;
        if (lr__bsdf_has_smooth_lobes(&f))
            join_vertex(&w, &h, &f, wp, beta, dim);
        if (k == lp->max_depth)
            return;
        double ub[2], ur[2];
        dims(&w, dim + 2, ub);
        dims(&w, dim + 4, ur);
        lr__v3 wi, weight;
        double pdf;
        int delta;
        if (!lr__bsdf_sample(&f, wp, ur[0], ub, &wi, &weight, &pdf, &delta))
            return;
        /* As path.c: the side the lobe says, by the geometric normal. */
        int through = v3_dot(wi, h.ns) < 0.0;
        if ((v3_dot(wi, h.ng) < 0.0) != through)
            return;
        if (through && v3_maxc(m->transmit) > 0.0)
            weight = v3_scale(weight, f.eta * f.eta);
        double ngp = fabs(v3_dot(h.ng, wp)), nsi = fabs(v3_dot(h.ns, wi));
        if (!(ngp > 0.0) || !(nsi > 0.0))
            return;
        double corr = fabs(v3_dot(h.ns, wp)) * fabs(v3_dot(h.ng, wi)) /
                      (ngp * nsi);
        beta = v3_scale(v3_mul(beta, weight), corr);
        if (k + 1 >= LR__PATH_RR_FROM) {
            double q = fmin(0.95, v3_maxc(beta) / beta0);
            if (!(ur[1] < q))
                return;
            beta = v3_scale(beta, 1.0 / q);
        }
        if (!v3_finite(beta))
            return;
        org = lr__offset_origin(&h, wi);
        dir = wi;
    }
}

/* The camera's share: nothing (camera_dark keeps these from being
 * called in a render; they answer 0 to anyone who asks). */
static lr__v3 radiance1(const lr_scene *s, int max_depth, lr__v3 org,
                        lr__v3 dir, const lr__sample_id *id, uint64_t *rays)
{
    (void)s, (void)max_depth, (void)org, (void)dir, (void)id, (void)rays;
    return v3(0, 0, 0);
}

static void radiance16(const lr_scene *s, int max_depth, struct RTCRayHit16 *rh,
                       int n, const lr__sample_id *id, lr__v3 L[16],
                       uint64_t *rays)
{
    (void)s, (void)max_depth, (void)rh, (void)id, (void)rays;
    for (int i = 0; i < n; i++)
        L[i] = v3(0, 0, 0);
}

const lr__integrator lr__light_tracer = {
    .name = "light",
    .camera_dark = 1,
    .radiance = radiance1,
    .radiance16 = radiance16,
};
