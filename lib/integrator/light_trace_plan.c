/*
 * light_trace_plan.c: the light side's plan (light_trace.h): which
 * lights it takes and how many paths each gets, the weights joining it
 * to the camera (MIS), and the glints and the sun it traces.  The paths
 * themselves and their film are light_trace.c's.
 */
#include "integrator/light_trace.h"

#include "integrator/ghost_trace.h"

#include "integrator/bsdf.h"
#include "integrator/integrator.h"
#include "scene/envmap.h"
#include "scene/light.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Sampler "pixels" of the light paths: past any frame's pixel index. */
#define LT_PIXEL_BASE ((uint64_t)1 << 48)


void lr__lt_keep(lr__lt *lt, const unsigned char *keep)
{
    /* The scale of the film's fixed-point sums follows the brightest
     * light (lr__lt_film_init): the frame's, not the region's, or a farm
     * part's pixels differed from the whole frame's by an ulp. */
    if (!(lt->lmax_frame > 0.0))
        for (int k = 0; k < lt->n; k++)
            lt->lmax_frame = fmax(lt->lmax_frame, v3_maxc(lt->lights[k].L));
    int n = 0;
    lt->paths = 0, lt->grid_tasks = 0;
    for (int k = 0; k < lt->n; k++) {
        if (!keep[k]) {
            free(lt->lights[k].cdf);
            continue;
        }
        lr__lt_light l = lt->lights[k];
        l.first = lt->paths;
        lt->paths += l.paths;
        l.grid_first = lt->grid_tasks;
        lt->grid_tasks += l.grid > 0;
        lt->lights[n++] = l;
    }
    lt->n = n;
}

void lr__lt_free(lr__lt *lt)
{
    if (lt == NULL)
        return;
    for (int k = 0; k < lt->n; k++)
        free(lt->lights[k].cdf);
    free(lt->lights);
    free(lt->direct);
    free(lt->mis);
    free(lt->dark);
    lr__lp_free(lt->lp);
    free(lt->wl);
    free(lt);
}

/* The largest disc, in frames' areas, whose paths a light's count
 * follows (paths_for). */
#define LR__LT_MAX_FRAMES 64.0

/* The light-side candidate: a sphere emitting untextured radiance that
 * is small against its blur.  Its image on the film: radius rho (pixels)
 * sharp, blurred over a circle of diameter C (plan.c's bound), about
 * D = C + 2 rho + 1 pixels across (the last pixel for the pixel's own
 * footprint); a camera sample of a pixel there finds it with a chance of
 * about (2 rho / D)^2.  Returns the paths it gets (0: the camera keeps
 * it). */
static uint64_t paths_for(const lr__cam *c, const lr__lens_bound *lb,
                          int estimate, lr__v3 center, double r, int spp,
                          int force)
{
    lr__v3 d = v3_sub(center, c->origin);
    double z = v3_dot(d, c->forward);
    /* Near or behind the eye, the projection below means nothing. */
    if (!(z > 2.0 * r) || !(r > 0.0))
        return 0;
    double fpx = 0.5 * c->height / c->half_h;
    double rho = fpx * r / sqrt(z * z - r * r);
    double blur = 0.0;
    for (int k = 0; k < lb->n_w; k++)
        blur = fmax(blur, fmax(fabs(1.0 / (z - r) - lb->ws[k]),
                               fabs(1.0 / (z + r) - lb->ws[k])));
    double C = 2.0 * lb->R * fpx * blur;
    double D = C + 2.0 * rho + 1.0;
    if (!force && !((2.0 * rho / D) * (2.0 * rho / D) < LR__LT_HIT_RATE))
        return 0;
    /* Wholly outside the frame: nothing of it lands.  Where the lens is
     * only estimated (a real lens: distortion, no bound), a light that
     * seems outside still goes to the light side, with few paths: left
     * to the camera, it would be a source of rare light everywhere
     * (plan.c's rare-light bound has no bound to confine it) and every
     * pixel would take every sample. */
    double sx = v3_dot(d, c->right) / z, sy = v3_dot(d, c->up) / z;
    double fx = (sx / c->half_w + 1.0) * 0.5 * c->width;
    double fy = (1.0 - sy / c->half_h) * 0.5 * c->height;
    if (fx + D < 0.0 || fx - D > c->width || fy + D < 0.0 || fy - D > c->height)
        return estimate || force ? 256 : 0;
    /* The paths spread over the light's disc, D across; where the disc is
     * far larger than the frame almost all of them land outside it, and
     * their number grew with the disc's area without bound (a thin lens
     * focused at 1e-6 traced billions of paths for a 48 x 32 frame, for
     * minutes).  Past LR__LT_MAX_FRAMES frames' area the count stays
     * there: each path's weight divides by the count traced, so the
     * estimate stays unbiased and only its noise grows. */
    double area = 0.25 * M_PI * D * D;
    double most = LR__LT_MAX_FRAMES * (double)c->width * (double)c->height;
    double n = ceil((double)spp * (area < most ? area : most) * LR__LT_DENSITY);
    if (n < 16.0)
        n = 16.0;
    return n < 4294967295.0 ? (uint64_t)n : 4294967295u;
}

/* A sphere around an emitting mesh (its triangles' corners' box). */
static int mesh_sphere(const lr_scene *s, const lr__geom *g, lr__v3 *center,
                       double *radius)
{
    if (g->n_triangles == 0)
        return 0;
    lr__v3 lo = v3(INFINITY, INFINITY, INFINITY),
           hi = v3(-INFINITY, -INFINITY, -INFINITY);
    for (size_t t = 0; t < g->n_triangles; t++) {
        const lr__emitter *e = &s->emitters[g->emitter + (long)t];
        lr__v3 p[3] = {e->a, v3_add(e->a, e->e1), v3_add(e->a, e->e2)};
        for (int k = 0; k < 3; k++) {
            lo = v3(fmin(lo.x, p[k].x), fmin(lo.y, p[k].y), fmin(lo.z, p[k].z));
            hi = v3(fmax(hi.x, p[k].x), fmax(hi.y, p[k].y), fmax(hi.z, p[k].z));
        }
    }
    *center = v3_scale(v3_add(lo, hi), 0.5);
    *radius = 0.5 * sqrt(v3_dot(v3_sub(hi, lo), v3_sub(hi, lo)));
    return *radius > 0.0;
}

int lr__lt_mesh_cdf(const lr_scene *s, const lr__geom *g, lr__lt_light *l)
{
    l->first_tri = g->emitter;
    l->n_tri = g->n_triangles;
    l->cdf = malloc(l->n_tri * sizeof *l->cdf);
    if (l->cdf == NULL)
        return 0;
    double sum = 0.0;
    for (size_t t = 0; t < l->n_tri; t++) {
        sum += s->emitters[l->first_tri + (long)t].area;
        l->cdf[t] = sum;
    }
    for (size_t t = 0; t < l->n_tri; t++)
        l->cdf[t] /= sum;
    l->cdf[l->n_tri - 1] = 1.0;
    l->area = sum;
    return 1;
}

int lr__lt_light_sphere(const lr_scene *s, const lr__geom *g, lr__v3 *center,
                        double *radius)
{
    if (!(v3_maxc(s->materials[g->material].emission) > 0.0))
        return 0;
    if (g->kind == LR__GEOM_SPHERE) {
        *center = g->center;
        *radius = g->radius;
        return 1;
    }
    return g->kind == LR__GEOM_TRIANGLES && g->emitter >= 0 &&
           mesh_sphere(s, g, center, radius);
}

void lr__lt_light_emission(const lr__material *m, lr__lt_light *l)
{
    l->L = m->emission;
    if (m->emission_tex != NULL) {
        const double *t = m->emission_tex->max;
        l->L = v3(l->L.x * t[0], l->L.y * t[1], l->L.z * t[2]);
        l->textured = 1;
    }
}

/* An empty light side for scene s with room for n lights; NULL when out
 * of memory. */
static lr__lt *lt_new_n(const lr_scene *s, size_t n)
{
    lr__lt *lt = calloc(1, sizeof *lt);
    /* Each made only when the one before was (lt's fields start NULL). */
    if (lt != NULL)
        lt->direct = calloc(s->n_geoms + 1, 1);
    if (lt != NULL && lt->direct != NULL)
        lt->mis = calloc(s->n_geoms + 1, sizeof *lt->mis);
    if (lt != NULL && lt->mis != NULL)
        lt->lights = malloc((n + 1) * sizeof *lt->lights);
    if (lt == NULL || lt->lights == NULL) {
        lr__lt_free(lt);
        return NULL;
    }
    lt->view = (lr__lt_view){.geom = lt->direct,
                             .sun_dir = v3(0, 0, 0),
                             .sun_cos = 2.0,
                             .mis = lt->mis};
    return lt;
}

lr__lt *lr__lt_new(const lr_scene *s)
{
    return lt_new_n(s, s->n_geoms);
}

/* The MIS coefficient kappa (integrator.h's lr__lt_rho) of a light with
 * n paths whose directions' density seen from the eye is q: n q over
 * spp fpx^2, the camera's density on the axis.  0 (no mix) where rho
 * passes the cutoff for every camera ray of the frame (its smallest
 * cos, at a corner, gives the smallest rho), and for a model whose
 * camera samples carry weights (a real lens: light_trace.h). */
static double mis_kappa(const lr__cam *c, uint64_t n, double q, int spp)
{
    if (c->weighted || !(q > 0.0) || spp <= 0)
        return 0.0;
    double fpx = 0.5 * c->height / c->half_h;
    double kappa = (double)n * q / ((double)spp * fpx * fpx);
    return lr__lt_cam_share_max(c, kappa) > 0.0 ? kappa : 0.0;
}

double lr__lt_cam_share_max(const lr__cam *c, double kappa)
{
    double cz = 1.0 / sqrt(1.0 + c->half_w * c->half_w + c->half_h * c->half_h);
    return lr__lt_cam_weight(kappa * cz * cz * cz);
}

/* The density of a direction uniform in the cone a sphere (center,
 * radius) fills seen from p: 1 / (2 pi (1 - cos alpha)); 0 from inside. */
static double cone_density(lr__v3 p, lr__v3 center, double radius)
{
    lr__v3 dv = v3_sub(center, p);
    double dist2 = v3_dot(dv, dv), r2 = radius * radius;
    if (!(dist2 > r2))
        return 0.0;
    double sin2 = r2 / dist2;
    return 1.0 / (2.0 * M_PI * sin2 / (1.0 + sqrt(1.0 - sin2)));
}

/* The roughest GGX alpha whose glints go to the light side: past it a
 * glint is a broad highlight, which camera rays find well. */
#define GLINT_ALPHA_MAX 0.3

/* Whether geometry g is a glint surface: a flat, flat-shaded triangle
 * mesh whose material's one lobe is an untextured rough conductor.  Its
 * plane (a point, the unit normal) and bounds go to *pp, *pn, *lo, *hi. */
static int glint_surface(const lr_scene *s, const lr__geom *g, lr__v3 *pp,
                         lr__v3 *pn, lr__v3 *lo, lr__v3 *hi)
{
    const lr__material *m = &s->materials[g->material];
    if (g->kind != LR__GEOM_TRIANGLES || g->n_triangles == 0 ||
        g->corner_normals != NULL || v3_maxc(m->diffuse) > 0.0 ||
        v3_maxc(m->specular) > 0.0 || v3_maxc(m->transmit) > 0.0 ||
        v3_maxc(m->emission) > 0.0 || !(v3_maxc(m->reflect) > 0.0) ||
        !(m->roughness >= 1e-3 && m->roughness <= GLINT_ALPHA_MAX) ||
        m->diffuse_tex != NULL || m->emission_tex != NULL ||
        m->roughness_tex != NULL || m->normal_tex != NULL || m->pbr_split)
        return 0;
    const float *V = g->vertices;
    const unsigned *I = g->indices;
    lr__v3 n = v3(0, 0, 0),
           p0 = v3(V[3 * I[0]], V[3 * I[0] + 1], V[3 * I[0] + 2]);
    *lo = *hi = p0;
    /* The normal: the largest triangle's (its rounding the least). */
    double best = 0.0;
    for (size_t t = 0; t < g->n_triangles; t++) {
        lr__v3 q[3];
        for (int k = 0; k < 3; k++) {
            const float *f = &V[3 * (size_t)I[3 * t + (size_t)k]];
            q[k] = v3(f[0], f[1], f[2]);
            *lo = v3(fmin(lo->x, q[k].x), fmin(lo->y, q[k].y),
                     fmin(lo->z, q[k].z));
            *hi = v3(fmax(hi->x, q[k].x), fmax(hi->y, q[k].y),
                     fmax(hi->z, q[k].z));
        }
        lr__v3 c = v3_cross(v3_sub(q[1], q[0]), v3_sub(q[2], q[0]));
        double l = sqrt(v3_dot(c, c));
        if (l > best)
            best = l, n = v3_scale(c, 1.0 / l);
    }
    if (!(best > 0.0))
        return 0;
    /* Every corner on the plane, to the floats' rounding. */
    lr__v3 ext = v3_sub(*hi, *lo);
    double tol = 1e-6 * (sqrt(v3_dot(ext, ext)) + fabs(p0.x) + fabs(p0.y) +
                         fabs(p0.z));
    for (size_t i = 0; i < 3 * g->n_triangles; i++) {
        const float *f = &V[3 * (size_t)I[i]];
        if (fabs(v3_dot(v3_sub(v3(f[0], f[1], f[2]), p0), n)) > tol)
            return 0;
    }
    *pp = p0;
    *pn = n;
    return 1;
}

/* Paths for light geometry `light` (a sphere) seen in glint surface g
 * (plane pp, pn, bounds lo..hi, alpha): its glint as a light of the
 * direct kind, the sphere's mirror image widened by the roughness
 * (slopes of alpha turn the reflected ray by 2 alpha: from the camera,
 * an image widened by 2 alpha times the light's distance to the mirror
 * point).  0: the camera keeps it (unless force). */
static uint64_t glint_paths(const lr__cam *c, const lr__lens_bound *lb,
                            int estimate, lr__v3 center, double radius,
                            lr__v3 pp, lr__v3 pn, lr__v3 lo, lr__v3 hi,
                            double alpha, int spp, int force)
{
    double dc = v3_dot(v3_sub(center, pp), pn);
    double dcam = v3_dot(v3_sub(c->origin, pp), pn);
    if (!(fabs(dc) > radius) || !(dc * dcam > 0.0))
        return 0;
    lr__v3 image = v3_madd(center, pn, -2.0 * dc);
    lr__v3 x0 = v3_add(c->origin,
                       v3_scale(v3_sub(image, c->origin), dcam / (dcam + dc)));
    lr__v3 b = v3_sub(center, x0);
    double lb_ = sqrt(v3_dot(b, b));
    /* The mirror point seen from the eye, on the surface or near it. */
    double margin = 8.0 * alpha * lb_ + radius;
    if (x0.x < lo.x - margin || x0.x > hi.x + margin || x0.y < lo.y - margin ||
        x0.y > hi.y + margin || x0.z < lo.z - margin || x0.z > hi.z + margin)
        return force ? 16 : 0;
    /* Twice the direct rule's paths, 1 a pixel of the glint's image and
     * sample: on scenes/sparkles.json 0.25, 0.5 and 1 were measured,
     * and 1 reached a given error soonest (half the sphere's points
     * face away from the mirror). */
    uint64_t n = paths_for(c, lb, estimate, image, radius + 2.0 * alpha * lb_,
                           spp, force);
    if (force && n < 16)
        n = 16;
    return n < 2147483647u ? 2 * n : 4294967295u;
}

/* Adds the glint pairs (glint surface, sphere light) to *ltp: every pair
 * of a surface and a light that some picked pair holds (the camera's
 * flags are per geometry, light_trace.h).  0 when out of memory. */
static int plan_glints(const lr_scene *s, const lr__cam *c,
                       const lr__lens_bound *lb, int estimate, int spp,
                       lr__lt **ltp)
{
    size_t ng = s->n_geoms;
    unsigned char *ok = calloc(ng ? ng : 1, 1);
    lr__v3 *plane = malloc(4 * (ng ? ng : 1) * sizeof *plane);
    if (ok == NULL || plane == NULL) {
        free(ok);
        free(plane);
        return 0;
    }
    /* ok[g]: a glint surface; one some pair picked; a light some pair
     * picked. */
    enum { SURF = 1, SURF_PICKED = 2, LIGHT_PICKED = 4 };
    size_t n_surf = 0, n_light = 0;
    for (size_t g = 0; g < ng; g++)
        if (glint_surface(s, &s->geoms[g], &plane[4 * g], &plane[4 * g + 1],
                          &plane[4 * g + 2], &plane[4 * g + 3]))
            ok[g] = SURF;
    for (size_t l = 0; l < ng; l++) {
        lr__v3 lc;
        double lr_;
        if (!lr__lt_light_sphere(s, &s->geoms[l], &lc, &lr_))
            continue;
        for (size_t g = 0; g < ng; g++) {
            if (!(ok[g] & SURF))
                continue;
            const lr__v3 *P = &plane[4 * g];
            double a = s->materials[s->geoms[g].material].roughness;
            if (glint_paths(c, lb, estimate, lc, lr_, P[0], P[1], P[2], P[3], a,
                            spp, 0) > 0)
                ok[g] |= SURF_PICKED, ok[l] |= LIGHT_PICKED;
        }
    }
    for (size_t g = 0; g < ng; g++) {
        n_surf += (ok[g] & SURF_PICKED) != 0;
        n_light += (ok[g] & LIGHT_PICKED) != 0;
    }
    int good = 1;
    lr__lt *lt = *ltp;
    if (n_surf > 0 && lt == NULL) {
        lt = lr__lt_new(s);
        *ltp = lt;
        good = lt != NULL;
    }
    if (n_surf > 0 && good) {
        lr__lt_light *grown = realloc(lt->lights,
                                      (ng + n_surf * n_light) * sizeof *grown);
        good = grown != NULL;
        if (good)
            lt->lights = grown;
    }
    for (size_t g = 0; g < ng && good && n_surf > 0; g++) {
        if (!(ok[g] & SURF_PICKED))
            continue;
        lt->direct[g] |= LR__LT_GLINT_SURF;
        const lr__v3 *P = &plane[4 * g];
        double a = s->materials[s->geoms[g].material].roughness;
        for (size_t k = 0; k < ng && good; k++) {
            if (!(ok[k] & LIGHT_PICKED))
                continue;
            const lr__geom *L = &s->geoms[k];
            lt->direct[k] |= LR__LT_GLINT_LIGHT;
            lr__lt_light *l = &lt->lights[lt->n++];
            memset(l, 0, sizeof *l);
            l->geom = (int)k;
            l->surf = (int)g;
            l->plane_p = P[0];
            l->plane_n = P[1];
            l->alpha = a;
            lr__lt_light_sphere(s, L, &l->center, &l->radius);
            lr__lt_light_emission(&s->materials[L->material], l);
            if (L->kind == LR__GEOM_TRIANGLES && !lr__lt_mesh_cdf(s, L, l)) {
                good = 0;
                break;
            }
            l->paths = glint_paths(c, lb, estimate, l->center, l->radius, P[0],
                                   P[1], P[2], P[3], a, spp, 1);
            l->first = lt->paths;
            lt->paths += l->paths;
        }
    }
    free(ok);
    free(plane);
    return good;
}

/* The environment's sun (lr__envmap_sun) to *ltp, when it is small
 * against its blur: seen through the camera as a sphere far beyond
 * everything (its blur is the lens's at infinity).  0 when out of
 * memory. */
static int plan_sun(const lr_scene *s, const lr__cam *c,
                    const lr__lens_bound *lb, int estimate, int spp,
                    lr__lt **ltp)
{
    lr__v3 a;
    double cos_a;
    if (s->env == NULL || !lr__envmap_sun(s->env, &a, &cos_a))
        return 1;
    double far = 1e9 * (1.0 + s->extent + v3_len(c->origin));
    double sin_a = sqrt(fmax(0.0, 1.0 - cos_a * cos_a));
    uint64_t n = paths_for(c, lb, estimate, v3_madd(c->origin, a, far),
                           far * sin_a, spp, 0);
    if (n == 0)
        return 1;
    lr__lt *lt = *ltp;
    if (lt == NULL) {
        lt = lr__lt_new(s);
        *ltp = lt;
        if (lt == NULL)
            return 0;
    }
    lr__lt_light *grown = realloc(lt->lights, (lt->n + 1) * sizeof *grown);
    if (grown == NULL)
        return 0;
    lt->lights = grown;
    lr__lt_light *l = &lt->lights[lt->n++];
    memset(l, 0, sizeof *l);
    l->geom = (int)s->n_geoms;
    l->surf = LR__LT_SUN;
    l->center = a;
    /* 1 - cos alpha = sin^2 / (1 + cos), as for the spheres. */
    l->area = sin_a * sin_a / (1.0 + cos_a);
    double m = lr__envmap_max(s->env);
    l->L = v3(m, m, m);
    l->paths = n;
    l->first = lt->paths;
    l->mis = mis_kappa(c, n, 1.0 / (2.0 * M_PI * l->area), spp);
    lt->paths += n;
    lt->view.sun_dir = a;
    lt->view.sun_cos = cos_a;
    lt->view.sun_mis = l->mis;
    return 1;
}

/* Spectral mode with colours that focus apart: lt's wavelengths' table
 * (lr__cam_land), shared with its light integrator's paths.  0: out of
 * memory. */
static int wl_table(lr__lt *lt, const lr__cam *c)
{
    if (!c->chroma_active || c->chroma.mode != LR_CHROMATIC_SPECTRAL)
        return 1;
    lt->wl = malloc(sizeof *lt->wl);
    if (lt->wl == NULL)
        return 0;
    lr__cam_wl_table(c, lt->wl);
    if (lt->lp != NULL)
        lr__lp_set_wl(lt->lp, lt->wl);
    return 1;
}

/* The `light` integrator's light side: every path, in parts of at most
 * LR__LT_PART, LR__LP_DENSITY a pixel and sample of the frame. */
static lr_status plan_paths(const lr_scene *s, const lr__cam *c,
                            const lr_render_settings *set, lr__lt **out,
                            lr_error *err)
{
    lr__lp *lp;
    double lref;
    lr_status st = lr__lp_prepare(s, c, set, &lp, &lref, err);
    if (st != LR_OK)
        return st;
    double want = ceil((double)set->spp * c->width * c->height *
                       LR__LP_DENSITY);
    uint64_t total = want < 1e18 ? (uint64_t)want : (uint64_t)1e18;
    size_t parts = (size_t)((total + LR__LT_PART - 1) / LR__LT_PART);
    lr__lt *lt = lt_new_n(s, parts);
    if (lt == NULL) {
        lr__lp_free(lp);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    lt->lp = lp;
    for (size_t j = 0; j < parts; j++) {
        lr__lt_light *l = &lt->lights[lt->n++];
        memset(l, 0, sizeof *l);
        l->geom = (int)j;
        l->surf = LR__LT_PATHS;
        /* lr__lt_film_init's scale: 2^40 over this, 2^36 over lref (a
         * light path's splats are less bounded than a light's radiance:
         * headroom of 2^27 lref a pixel). */
        l->L = v3(16.0 * lref, 16.0 * lref, 16.0 * lref);
        l->paths = j + 1 < parts ? LR__LT_PART : total - j * LR__LT_PART;
        l->first = lt->paths;
        lt->paths += l->paths;
    }
    lt->lp_paths = lt->paths;
    lt->seed = set->seed;
    /* The lens's ghosts, as for the other integrators. */
    if (!lr__gt_plan(s, c, set->spp, &lt) || !wl_table(lt, c)) {
        lr__lt_free(lt);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    *out = lt;
    return LR_OK;
}

lr_status lr__lt_plan(const lr_scene *s, const lr__cam *c,
                      const lr_render_settings *set, lr__lt **out,
                      lr_error *err)
{
    *out = NULL;
    if (set->integrator == LR_INTEGRATOR_LIGHT)
        return plan_paths(s, c, set, out, err);
    const lr__camera_model *m = c->model;
    /* Ghosts asked for by name where the lens has no light side: none
     * would be drawn (they come from the light side alone). */
    if (set->light && m->light_ok != NULL && c->lens.ghosts == LR_GHOSTS_ON &&
        !m->light_ok(c))
        return lr__fail(err, LR_ERR_INVALID, "camera.ghosts",
                        "camera.ghosts: this lens passes rays steeper than "
                        "its light side holds (a fisheye or extreme wide "
                        "angle), and ghosts are traced from the light side: "
                        "it draws none (use \"auto\" or false)");
    if (!set->light || m->lens_point == NULL || m->film == NULL ||
        !lr__cam_lands_colours(c) ||
        (m->bound == NULL && m->thin_equiv == NULL) ||
        (m->light_ok != NULL && !m->light_ok(c)))
        return LR_OK;
    lr__lens_bound lb = {0.0, 1, {0.0, 0.0, 0.0}};
    if (m->bound == NULL)
        m->thin_equiv(c, &lb);
    else if (c->has_lens)
        lr__cam_bound(c, &lb);
    lr__lt *lt = NULL;
    for (size_t g = 0; g < s->n_geoms; g++) {
        const lr__geom *geo = &s->geoms[g];
        lr__v3 center;
        double radius;
        if (!lr__lt_light_sphere(s, geo, &center, &radius))
            continue;
        /* A scene of many lights takes a while here (a real lens's
         * footprints): a cancel (lensrayd's DELETE, time limit and
         * shutdown) is heeded between lights, not only between tiles. */
        if (set->cancel != NULL &&
            __atomic_load_n(set->cancel, __ATOMIC_RELAXED)) {
            lr__lt_free(lt);
            return lr__fail(err, LR_ERR_CANCELLED, NULL, "render cancelled");
        }
        uint64_t n = paths_for(c, &lb, m->bound == NULL, center, radius,
                               set->spp, 0);
        if (n == 0)
            continue;
        if (lt == NULL) {
            lt = lr__lt_new(s);
            if (lt == NULL)
                return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
        lr__lt_light *l = &lt->lights[lt->n];
        memset(l, 0, sizeof *l);
        l->geom = (int)g;
        l->surf = -1;
        l->center = center;
        l->radius = radius;
        if (geo->kind == LR__GEOM_TRIANGLES && !lr__lt_mesh_cdf(s, geo, l)) {
            lr__lt_free(lt);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
        lt->n++;
        lr__lt_light_emission(&s->materials[geo->material], l);
        if (!lr__lt_footprint(c, l)) {
            lr__lt_free(lt);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
        l->paths = n;
        l->first = lt->paths;
        lt->paths += n;
        lt->direct[g] |= LR__LT_DIRECT;
        l->mis = mis_kappa(c, n, cone_density(c->origin, center, radius),
                           set->spp);
        lt->mis[g] = l->mis;
    }
    if ((set->integrator == LR_INTEGRATOR_PATH &&
         !plan_glints(s, c, &lb, m->bound == NULL, set->spp, &lt)) ||
        !plan_sun(s, c, &lb, m->bound == NULL, set->spp, &lt) ||
        !lr__gt_plan(s, c, set->spp, &lt)) {
        lr__lt_free(lt);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    if (lt != NULL && !wl_table(lt, c)) {
        lr__lt_free(lt);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    if (lt != NULL) {
        lt->seed = set->seed;
        lt->view.forward = c->forward;
    }
    *out = lt;
    return LR_OK;
}
