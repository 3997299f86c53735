/*
 * plan_rare.c: where a camera sample may carry rare light
 * (lr__plan_unseen: emitters and glossy geometry that the plan's
 * adaptive sampling must not starve), and which of the light side's
 * lights a region of the frame can hold (plan_parts.h).
 */
#include "render/plan_parts.h"
#include "render/adaptive.h"
#include "scene/envmap.h"
#include "integrator/integrator.h"
#include "sampling/sampler.h"
#include "render/splat.h"
#include "scene/texture.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

/* ---- rare light (lr__plan_unseen) --------------------------------------- */

/* A source of rare light: the camera-space bounds of emissive or
 * non-Lambertian geometry, or an infinite plane, and the largest channel
 * of the radiance it can show. */
typedef struct rare_src {
    box b;
    const lr__geom *plane; /* an infinite plane, else NULL */
    double L;
} rare_src;

struct lr__rare {
    lens L;
    int everywhere; /* no bound: every pixel may reach every source */
    double L_all;   /* the largest L of any source */
    double su, sv, half_w, half_h;
    int bw;
    /* Per block: a bound on the environment map's radiance along its
     * pixels' rays (0 without a map). */
    double *env;
    int *first; /* per block b, its sources are idx[first[b] .. first[b+1]) */
    int *idx;
    rare_src *src;
    size_t n;
};

void lr__plan_rare_free(struct lr__rare *r)
{
    if (r == NULL)
        return;
    free(r->first);
    free(r->env);
    free(r->idx);
    free(r->src);
    free(r);
}

/* The largest channel of the radiance material m emits (its texture's
 * largest texel included): 0 for a material that does not emit. */
static double emission_max(const lr__material *m)
{
    double e = fmax(m->emission.x, fmax(m->emission.y, m->emission.z));
    if (e > 0.0 && m->emission_tex != NULL) {
        const double *t = m->emission_tex->max;
        e = fmax(m->emission.x * t[0],
                 fmax(m->emission.y * t[1], m->emission.z * t[2]));
    }
    return e > 0.0 ? e : 0.0;
}

/* Whether m has a lobe other than a Lambertian one (Phong, mirror,
 * glass, or a glTF metal split), which can show an emitter at up to its
 * radiance where a pilot's few directions miss it. */
static int shows_emitters(const lr__material *m)
{
    lr__v3 a = m->specular, b = m->reflect, c = m->transmit;
    return m->pbr_split || fmax(a.x, fmax(a.y, a.z)) > 0.0 ||
           fmax(b.x, fmax(b.y, b.z)) > 0.0 || fmax(c.x, fmax(c.y, c.z)) > 0.0;
}

static int src_reached(const lens *L, const rare_src *r, double u0, double u1,
                       double v0, double v1)
{
    if (r->plane != NULL)
        return lr__plan_plane_reached(L, r->plane, u0, u1, v0, v1);
    return lr__plan_box_reached(L, &r->b, u0, u1, v0, v1);
}

/* Appends a source; 0 when out of memory. */
static int src_add(struct lr__rare *r, size_t *cap, const rare_src *x)
{
    if (r->n == *cap) {
        size_t nc = *cap ? 2 * *cap : 64;
        rare_src *g = realloc(r->src, nc * sizeof *g);
        if (g == NULL)
            return 0;
        r->src = g;
        *cap = nc;
    }
    r->src[r->n++] = *x;
    return 1;
}

/* The sources of geometry g that shows radiance up to Lg. */
static int geom_sources(struct lr__rare *r, size_t *cap, const lr__geom *g,
                        double Lg)
{
    rare_src x = {.plane = NULL, .L = Lg};
    if (g->kind == LR__GEOM_SPHERE) {
        double lo[3] = {g->center.x - g->radius, g->center.y - g->radius,
                        g->center.z - g->radius};
        double hi[3] = {g->center.x + g->radius, g->center.y + g->radius,
                        g->center.z + g->radius};
        lr__plan_box_from_bounds(&r->L, lo, hi, &x.b);
        return src_add(r, cap, &x);
    }
    if (g->chunk_bounds != NULL) {
        for (size_t t0 = 0; t0 < g->n_triangles; t0 += CHUNK) {
            const double *wb = &g->chunk_bounds[6 * (t0 / CHUNK)];
            lr__plan_box_from_bounds(&r->L, wb, wb + 3, &x.b);
            if (!src_add(r, cap, &x))
                return 0;
        }
        return 1;
    }
    for (size_t t = 0; t < g->n_triangles; t++) {
        lr__v3 q[3];
        for (int k = 0; k < 3; k++) {
            const float *v = &g->vertices[3 * g->indices[3 * t + k]];
            q[k] = v3(v[0], v[1], v[2]);
        }
        lr__plan_box_from_points(&r->L, q, 3, &x.b);
        if (!src_add(r, cap, &x))
            return 0;
    }
    return 1;
}

/* The rectangle of pixels [px0, px1) x [py0, py1) on the image plane. */
static void pixel_rect(const struct lr__rare *r, double px0, double py0,
                       double px1, double py1, double *u0, double *u1,
                       double *v0, double *v1)
{
    *u0 = px0 * r->su - r->half_w;
    *u1 = px1 * r->su - r->half_w;
    *v0 = r->half_h - py1 * r->sv;
    *v1 = r->half_h - py0 * r->sv;
}

/* The environment map's bound over the directions of the lens rays of
 * pixels [u0, u1] x [v0, v1]: an offset-lens ray has direction D - off w
 * (camera.h), so its point on the image plane lies within the rectangle
 * grown by R |w| for every colour's w; the cone about the rectangle's
 * centre through its farthest corner holds them all. */
static double env_bound(const struct lr__rare *r, const lr__envmap *e,
                        double u0, double u1, double v0, double v1)
{
    const lens *L = &r->L;
    double g = 0.0;
    for (int k = 0; k < L->n_w; k++)
        g = fmax(g, L->R * fabs(L->ws[k]));
    g = g * (1.0 + 1e-9) + 1e-12;
    u0 -= g, u1 += g, v0 -= g, v1 += g;
    lr__v3 axis = v3_norm(v3(0.5 * (u0 + u1), 0.5 * (v0 + v1), 1.0));
    double cmin = 1.0;
    for (int k = 0; k < 4; k++) {
        lr__v3 q = v3_norm(v3(k & 1 ? u1 : u0, k & 2 ? v1 : v0, 1.0));
        cmin = fmin(cmin, v3_dot(q, axis));
    }
    double alpha = acos(fmax(-1.0, fmin(1.0, cmin))) * (1.0 + 1e-9) + 1e-9;
    lr__v3 world = v3_add(
        v3_add(v3_scale(L->fwd, axis.z), v3_scale(L->right, axis.x)),
        v3_scale(L->up, axis.y));
    return lr__envmap_max_in_cone(e, v3_norm(world), alpha);
}

/* The most a surface that shows emitters (geometry or plane g) shows:
 * everything, or L_glint on a glint surface of the light side. */
static double shown(const lr__lt_view *fl, size_t g, int is_plane,
                    double L_emit, double L_glint)
{
    return !is_plane && lr__lt_flag(fl, (long)g, LR__LT_GLINT_SURF) ? L_glint
                                                                    : L_emit;
}

/* The most of geometry or plane g's emission that a camera ray meeting
 * it first adds: all, or a light side's light's largest camera weight. */
static double cam_share(const lr__lt_view *fl, const lr__cam *c, size_t g,
                        int is_plane)
{
    if (is_plane || !lr__lt_direct(fl, (long)g))
        return 1.0;
    return lr__lt_cam_share_max(c, fl->mis[g]);
}

lr_status lr__plan_rare_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                              int x0, int y0, int x1, int y1, lr_error *err)
{
    /* The scene's largest emission: what a non-Lambertian lobe may show.
     * A map's sun is a light as small and as bright as any.  (A uniform
     * background is the same in every direction: nothing to miss.)
     * And what a glint surface of the light side shows its first hits:
     * its glint lights' light straight from it is the light side's
     * (light_trace.h), so every other emitter's, and everything if
     * another surface may show those lights in turn. */
    const lr__lt_view *fl = p->lt != NULL ? &p->lt->view : NULL;
    double L_env = s->env != NULL ? lr__envmap_max(s->env) : 0.0;
    double L_emit = L_env, L_glint = L_env;
    int n_show = 0;
    for (size_t g = 0; g < s->n_geoms + s->n_planes; g++) {
        int is_plane = g >= s->n_geoms;
        const lr__material *m =
            &s->materials[lr__plan_geom_or_plane(s, g)->material];
        L_emit = fmax(L_emit, emission_max(m));
        if (is_plane || !lr__lt_flag(fl, (long)g, LR__LT_GLINT_LIGHT))
            L_glint = fmax(L_glint, emission_max(m));
        n_show += shows_emitters(m);
    }
    if (!(L_emit > 0.0))
        return LR_OK;
    /* A second such surface (another glint surface too) may show them
     * after the first (depth 1 on). */
    if (n_show > 1)
        L_glint = L_emit;
    struct lr__rare *r = calloc(1, sizeof *r);
    if (r == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    /* What the camera's rays may find: every source's, less the direct
     * emission of lights the light side carries (light_trace.h). */
    double L_cam = L_env;
    for (size_t g = 0; g < s->n_geoms + s->n_planes; g++) {
        int is_plane = g >= s->n_geoms;
        const lr__geom *geo = lr__plan_geom_or_plane(s, g);
        const lr__material *m = &s->materials[geo->material];
        L_cam = fmax(L_cam, cam_share(fl, c, g, is_plane) * emission_max(m));
        if (shows_emitters(m))
            L_cam = fmax(L_cam, shown(fl, g, is_plane, L_emit, L_glint));
    }
    r->L_all = L_cam;
    if (c->model->bound == NULL) {
        /* No bound on where the camera's rays go (a real lens's, or rays
         * that do not leave the eye, as an orthographic camera's):
         * anywhere. */
        r->everywhere = 1;
        p->rare = r;
        return LR_OK;
    }
    lr__plan_make_lens(c, &r->L);
    r->su = 2.0 * c->half_w / c->width;
    r->sv = 2.0 * c->half_h / c->height;
    r->half_w = c->half_w;
    r->half_h = c->half_h;
    r->bw = p->bw;
    size_t cap = 0;
    int ok = 1;
    for (size_t g = 0; g < s->n_geoms + s->n_planes && ok; g++) {
        int is_plane = g >= s->n_geoms;
        const lr__geom *geo = lr__plan_geom_or_plane(s, g);
        const lr__material *m = &s->materials[geo->material];
        /* A light of the light side: camera rays see its emission first
         * only by their MIS weight, most often 0 (light_trace.h), and
         * through other surfaces. */
        double Le = cam_share(fl, c, g, is_plane) * emission_max(m);
        double Lg = fmax(Le, shows_emitters(m)
                                 ? shown(fl, g, is_plane, L_emit, L_glint)
                                 : 0.0);
        if (!(Lg > 0.0))
            continue;
        if (is_plane) {
            rare_src x = {.plane = geo, .L = Lg};
            ok = src_add(r, &cap, &x);
        } else {
            ok = geom_sources(r, &cap, geo, Lg);
        }
    }
    /* Per block of the region and its apron (adaptive.c reads the
     * apron's pixels too), the sources its pixels may reach. */
    int gx0 = x0 > 0 ? x0 - 1 : 0, gy0 = y0 > 0 ? y0 - 1 : 0;
    int gx1 = x1 < (int)c->width ? x1 + 1 : x1;
    int gy1 = y1 < (int)c->height ? y1 + 1 : y1;
    int bx0 = gx0 / LR__PLAN_BLOCK, by0 = gy0 / LR__PLAN_BLOCK;
    int bx1 = (gx1 - 1) / LR__PLAN_BLOCK, by1 = (gy1 - 1) / LR__PLAN_BLOCK;
    size_t nb = (size_t)p->bw * (size_t)p->bh, n_idx = 0, idx_cap = 0;
    r->first = ok ? calloc(nb + 1, sizeof *r->first) : NULL;
    ok = r->first != NULL;
    if (ok && s->env != NULL) {
        r->env = calloc(nb, sizeof *r->env);
        ok = r->env != NULL;
    }
    for (size_t b = 0; b < nb && ok; b++) {
        r->first[b] = (int)n_idx;
        int bx = (int)(b % (size_t)p->bw), by = (int)(b / (size_t)p->bw);
        if (bx < bx0 || bx > bx1 || by < by0 || by > by1)
            continue;
        double u0, u1, v0, v1;
        pixel_rect(r, bx * LR__PLAN_BLOCK, by * LR__PLAN_BLOCK,
                   (bx + 1) * LR__PLAN_BLOCK, (by + 1) * LR__PLAN_BLOCK, &u0,
                   &u1, &v0, &v1);
        if (r->env != NULL)
            r->env[b] = env_bound(r, s->env, u0, u1, v0, v1);
        for (size_t i = 0; i < r->n && ok; i++) {
            if (!src_reached(&r->L, &r->src[i], u0, u1, v0, v1))
                continue;
            if (n_idx == idx_cap) {
                size_t nc = idx_cap ? 2 * idx_cap : 256;
                int *gi = realloc(r->idx, nc * sizeof *gi);
                if (gi == NULL) {
                    ok = 0;
                    break;
                }
                r->idx = gi;
                idx_cap = nc;
            }
            r->idx[n_idx++] = (int)i;
        }
    }
    if (!ok) {
        lr__plan_rare_free(r);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    r->first[nb] = (int)n_idx;
    p->rare = r;
    return LR_OK;
}

double lr__plan_unseen(const lr__plan *p, int x, int y)
{
    const struct lr__rare *r = p->rare;
    if (r == NULL)
        return 0.0;
    if (r->everywhere)
        return r->L_all;
    int b = (y / LR__PLAN_BLOCK) * r->bw + x / LR__PLAN_BLOCK;
    double u0, u1, v0, v1, best = r->env != NULL ? r->env[b] : 0.0;
    pixel_rect(r, x, y, x + 1, y + 1, &u0, &u1, &v0, &v1);
    for (int k = r->first[b]; k < r->first[b + 1]; k++) {
        const rare_src *src = &r->src[r->idx[k]];
        if (src->L > best && src_reached(&r->L, src, u0, u1, v0, v1))
            best = src->L;
    }
    return best;
}

/* ---- the light side's lights, per region --------------------------------- */

/* A light path lands where a camera ray of that pixel meets the light,
 * so a light that no lens ray of the region [x0, x1) x [y0, y1) can
 * reach (box_reached, the planner's bound) lands nothing there: a farm
 * part traces only the lights whose discs it holds.  A model without a
 * planner's bound keeps them all. */
lr_status lr__plan_lt_region(lr__lt *lt, const lr__cam *c, int x0, int y0,
                             int x1, int y1, lr_error *err)
{
    if (c->model->bound == NULL ||
        (x0 == 0 && y0 == 0 && x1 == (int)c->width && y1 == (int)c->height))
        return LR_OK;
    lens L;
    lr__plan_make_lens(c, &L);
    double su = 2.0 * c->half_w / c->width, sv = 2.0 * c->half_h / c->height;
    double u0 = x0 * su - c->half_w, u1 = x1 * su - c->half_w;
    double v0 = c->half_h - y1 * sv, v1 = c->half_h - y0 * sv;
    unsigned char *keep = malloc((size_t)lt->n + 1);
    if (keep == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int k = 0; k < lt->n; k++) {
        const lr__lt_light *l = &lt->lights[k];
        double r = l->radius;
        double lo[3] = {l->center.x - r, l->center.y - r, l->center.z - r};
        double hi[3] = {l->center.x + r, l->center.y + r, l->center.z + r};
        box b;
        lr__plan_box_from_bounds(&L, lo, hi, &b);
        /* A glint may land wherever its surface is seen, a light path
         * anywhere: kept. */
        keep[k] = (unsigned char)(l->surf != -1 ||
                                  lr__plan_box_reached(&L, &b, u0, u1, v0, v1));
    }
    lr__lt_keep(lt, keep);
    free(keep);
    return LR_OK;
}
