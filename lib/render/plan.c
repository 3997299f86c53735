/*
 * plan.c: where the lens and the colours need simulating (see plan.h).
 *
 * Camera space: z along the view axis, u = x / z and v = y / z on the
 * image plane at distance 1 (pixel (px, py) is at u = (2 px / W - 1)
 * half_w, v = (1 - 2 py / H) half_h).  Every lens model here is a lens of
 * radius R at the eye focused at 1/w (the bracket is one: its rays all
 * pass through e + off (1 + di / f), a square lens focused at di + f).
 * A point at depth Z seen through the lens lands within R |1/Z - w| (in
 * u, v units) of where the pinhole sees it, and blurs over a circle of
 * C(Z) = 2 R |1/Z - w| f_px pixels (f_px = H / (2 half_h)).
 *
 * So a block's lens rays can only reach geometry within its rectangle
 * grown by R |1/Z - w| at that geometry's depth (box_reached says it in
 * camera space, which also copes with geometry beside or behind the eye).  Geometry is bounded by boxes (spheres; triangles in chunks of
 * 64, and big triangles, like a ground quad's, cut into pieces until
 * each piece's depth extent is small against its distance, so that a
 * ground plane does not make every block "near"); infinite planes
 * exactly, since 1/Z is linear in (u, v) on a plane.
 * The block's blur is then at most C at the ends of its depth range.
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


/* From what the blur bounds allow to what each block does. */
static void finish(lr__plan *p, const lr__cam *c, const lr_render_settings *set)
{
    for (int i = 0; i < p->bw * p->bh; i++) {
        lr__block_plan *bp = &p->blocks[i];
        bp->lens = c->has_lens && bp->lens && !bp->dark;
        bp->chroma = c->chroma_active && bp->lens && bp->chroma;
        bp->path = bp->chroma ? LR__PATH_COLOURS : LR__PATH_PACKET;
        bp->pilot = bp->dark ? 1 : lr__adaptive_pilot(set, bp->lens);
    }
}

static lr_status plan_blur(lr__plan *p, const lr_scene *s, const lr__cam *c,
                           const lr__lens_blur *lb, int dither, int rough,
                           double blur_px, const unsigned char *dark, int x0,
                           int y0, int x1, int y1, lr_error *err);
static unsigned char *dark_geoms(const lr_scene *s, const lr__lt *lt, int *all);

/* The light side's copy of the dark blocks, which it needs when one of
 * its lights mixes with the camera (light_trace.h): in a dark block it
 * keeps all of that light.  0: out of memory. */
static int lt_dark(lr__plan *p)
{
    lr__lt *lt = p->lt;
    int mixes = 0, any_dark = 0, n = p->bw * p->bh;
    for (int k = 0; k < lt->n; k++)
        mixes |= lt->lights[k].mis > 0.0;
    for (int i = 0; i < n; i++)
        any_dark |= p->blocks[i].dark;
    if (!mixes || !any_dark)
        return 1;
    lt->dark = malloc((size_t)n);
    if (lt->dark == NULL)
        return 0;
    for (int i = 0; i < n; i++)
        lt->dark[i] = p->blocks[i].dark;
    lt->dark_bw = p->bw;
    lt->dark_block = LR__PLAN_BLOCK;
    return 1;
}

lr_status lr__plan_build(lr__plan *p, const lr_scene *s, const lr__cam *c,
                         const lr_render_settings *set, int x0, int y0, int x1,
                         int y1, lr_error *err)
{
    p->bw = ((int)c->width + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->bh = ((int)c->height + LR__PLAN_BLOCK - 1) / LR__PLAN_BLOCK;
    p->blocks = malloc((size_t)p->bw * (size_t)p->bh * sizeof *p->blocks);
    if (p->blocks == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < p->bw * p->bh; i++)
        p->blocks[i] = (lr__block_plan){1, 1, 0, 0, 0};
    p->rare = NULL;
    p->lt = NULL;
    /* Splatting traces one ray a pixel and sample for the whole
     * spectrum, where spectral.c's packets trace one a wavelength
     * (docs/spectral.md measures both). */
    const lr__integrator *in = lr__integrator_for(set->integrator);
    /* An integrator whose camera rays estimate nothing has every block
     * dark (below), which the splatting pass would not skip. */
    p->splat = lr__splat_applies(c) && !(in != NULL && in->camera_dark);
    /* The light side comes first: what it carries, the camera does not
     * see (dark blocks).  With spectral splatting too: a splatted camera
     * ray that meets a light side's light first adds none of its
     * emission at any wavelength, as every other camera ray. */
    {
        lr_status st = lr__lt_plan(s, c, set, &p->lt, err);
        if (st == LR_OK && p->lt != NULL)
            st = lr__plan_lt_region(p->lt, c, x0, y0, x1, y1, err);
        if (st != LR_OK) {
            lr__plan_free(p);
            return st;
        }
    }
    /* Per geometry then per plane: 1 where it gives camera paths no
     * light; NULL when nothing can be dark (a lit background, or no
     * plan). */
    unsigned char *dark = NULL;
    int all_dark = 0;
    if (set->plan && !p->splat && v3_maxc(s->background) <= 0.0 &&
        s->env == NULL) {
        dark = dark_geoms(s, p->lt, &all_dark);
        if (dark == NULL) {
            lr__plan_free(p);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
    }
    /* An integrator whose camera rays estimate nothing: all dark. */
    if (in != NULL && in->camera_dark) {
        for (int i = 0; i < p->bw * p->bh; i++)
            p->blocks[i].dark = 1;
    } else if (set->plan && !p->splat && c->has_lens &&
               (c->model->bound != NULL ||
                (c->model->blur != NULL && c->model->blur(c) != NULL))) {
        /* A model with no safe bound samples its lens everywhere; a real
         * lens's is its blur table (lens_blur.c).  A real lens that
         * traces colours passes each its own share of the light (1 to 3%
         * apart on the double Gauss at f/11), which one ray for all
         * colours carries by the table's shares (lens_shares.c,
         * colour_w16; test_real_lens_colours_keep_their_transmittance). */
        const lr__lens_blur *lb = c->model->bound == NULL ? c->model->blur(c)
                                                          : NULL;
        /* Adaptive sampling reads the pilots of a one-pixel apron around
         * the region (adaptive.c), and a pilot follows its block's plan:
         * the apron's blocks are planned too, or a crop's edge pixels
         * would differ from the full render's. */
        int gx0 = x0 > 0 ? x0 - 1 : 0, gy0 = y0 > 0 ? y0 - 1 : 0;
        int gx1 = x1 < (int)c->width ? x1 + 1 : x1;
        int gy1 = y1 < (int)c->height ? y1 + 1 : y1;
        /* With the grid sampler every pixel samples the same film
         * positions, and its error is structure (aliased edges) that
         * only the lens's blur, however small, dithers from pixel to
         * pixel: skipping a lens that blurs less than LR__PLAN_BLUR_PX
         * raised the in-focus scene's error 1.6x to 2.8x over the full
         * simulation's at 16 to 1024 spp (docs/accuracy.md).  The
         * default (planning with adaptive sampling) promises at most
         * 1.2x, so with adaptive sampling on the grid keeps its lens
         * wherever there is something to blur; planning alone stays as
         * it was, the fastest choice at its own error. */
        int dither = set->adaptive && lr__sampler_fixed_positions(set->sampler);
        /* Whitted's mirrors and glass are smooth; the other
         * integrators' are GGX lobes of their roughness (bsdf.c). */
        int rough = set->integrator != LR_INTEGRATOR_WHITTED;
        lr_status st = plan_blur(p, s, c, lb, dither, rough,
                                 lr__plan_blur_px(set->spp), dark, gx0, gy0,
                                 gx1, gy1, err);
        if (st != LR_OK) {
            free(dark);
            lr__plan_free(p);
            return st;
        }
    } else if (all_dark) {
        /* Without a bound (or a lens) every geometry is in reach of every
         * block. */
        for (int i = 0; i < p->bw * p->bh; i++)
            p->blocks[i].dark = 1;
    }
    free(dark);
    finish(p, c, set);
    if (p->lt != NULL && !lt_dark(p)) {
        lr__plan_free(p);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    /* Rare light matters only to a pixel that may stop early. */
    if (set->adaptive && !p->splat && lr__adaptive_min(set) < set->spp) {
        lr_status st = lr__plan_rare_build(p, s, c, x0, y0, x1, y1, err);
        if (st != LR_OK) {
            lr__plan_free(p);
            return st;
        }
    }
    return LR_OK;
}


/* Whether geometry with material m, whose flags on the light side are
 * `lt` (light_trace.h), gives camera paths no light: no lobe to scatter
 * with, and no emission the camera counts (the light side carries what
 * it emits straight into the lens). */
static int gives_camera_nothing(const lr__material *m, unsigned char lt)
{
    if (m->pbr_split || v3_maxc(m->diffuse) > 0.0 ||
        v3_maxc(m->specular) > 0.0 || v3_maxc(m->reflect) > 0.0 ||
        v3_maxc(m->transmit) > 0.0)
        return 0;
    return (lt & LR__LT_DIRECT) ||
           (m->emission_tex == NULL && !(v3_maxc(m->emission) > 0.0));
}

/* Per geometry, then per infinite plane, of scene s: 1 where it gives
 * camera paths no light (with light side lt, or NULL); *all = 1 when
 * every one does.  NULL when out of memory. */
static unsigned char *dark_geoms(const lr_scene *s, const lr__lt *lt, int *all)
{
    size_t n = s->n_geoms + s->n_planes;
    unsigned char *d = malloc(n + 1);
    if (d == NULL)
        return NULL;
    *all = 1;
    for (size_t g = 0; g < n; g++) {
        const lr__geom *geo = lr__plan_geom_or_plane(s, g);
        unsigned char f = lt != NULL && g < s->n_geoms ? lt->direct[g]
                                                       : (unsigned char)0;
        d[g] = (unsigned char)gives_camera_nothing(&s->materials[geo->material],
                                                   f);
        *all &= d[g];
    }
    return d;
}

/* ---- what mirrors, glass and glossy lobes show ------------------------------
 *
 * The bound above is on the depths of what a block's rays meet first.  A
 * mirror or glass there shows other geometry at other depths: a flat
 * mirror in focus shows what it faces as far behind the mirror as that
 * is in front of it, and out of focus (planning it as the mirror's depth
 * drew those reflections sharp: relMSE 4.1x the full simulation's on
 * a 640 x 360 mirror scene, RMSE 5.5x on test_plan.c's).  So a block that
 * reaches a mirror or glass is simulated in full.  A glossy lobe of
 * angular half-width w blurs what it shows over w itself; the lens adds
 * the angle its aperture subtends at the surface, at most 2 R / Z for
 * depths Z >= zmin, and where that is under a quarter of w it is hidden
 * in the lobe's own spread, as a blur under a quarter pixel is in the
 * pixel (LR__PLAN_BLUR_PX; LOBE_SHARE below). */
#define LOBE_SHARE 0.25

/* The narrowest angular half-width (radians) of the lobes of m that show
 * other geometry or lights; INFINITY for Lambertian alone.  A Phong
 * lobe's is its half maximum (cos^n theta = 1/2).  A mirror's or glass's
 * is 0 where the integrator traces them smooth (`rough` 0: Whitted's),
 * or a texture can bring its roughness to 0; else its GGX alpha (bsdf.c:
 * the microfacet density falls to half at a half-vector 0.64 alpha from
 * the normal, which turns the reflected ray twice as far). */
static double lobe_width(const lr__material *m, int rough)
{
    double w = INFINITY;
    if (v3_maxc(m->specular) > 0.0)
        w = m->shininess > 0.0 ? acos(pow(2.0, -1.0 / m->shininess))
                               : 0.5 * M_PI;
    if (m->pbr_split || v3_maxc(m->reflect) > 0.0 || v3_maxc(m->transmit) > 0.0)
        w = fmin(w, rough && m->roughness_tex == NULL ? m->roughness : 0.0);
    return w;
}

/* lobe_width per geometry, then per infinite plane; NULL when out of
 * memory. */
static double *lobe_widths(const lr_scene *s, int rough)
{
    size_t n = s->n_geoms + s->n_planes;
    double *w = malloc((n + 1) * sizeof *w);
    for (size_t g = 0; w != NULL && g < n; g++)
        w[g] = lobe_width(&s->materials[lr__plan_geom_or_plane(s, g)->material],
                          rough);
    return w;
}

/* Whether a block whose rays reach lobes as narrow as `lobe` at depths
 * from zmin must be simulated in full (above); R is the lens's radius. */
static int lobe_needs_lens(double lobe, double R, double zmin)
{
    if (!(lobe < INFINITY))
        return 0;
    return !(lobe > 0.0) || 2.0 * R / fmax(zmin, NEAR) >= LOBE_SHARE * lobe;
}

/* The infinite planes' part of a block's reach (plan_blur, rectangle
 * [u0, u1] x [v0, v1]): their depths into [*zmin, *zmax], and whether one
 * in reach gives light (*lit) and its lobes (*lobe), as the boxes'. */
static void planes_reach(const lr_scene *s, const lens *L,
                         const unsigned char *dark, const double *lobes,
                         double u0, double u1, double v0, double v1,
                         double *zmin, double *zmax, int *lit, double *lobe)
{
    for (size_t i = 0; i < s->n_planes; i++) {
        double z0, z1;
        if (!lr__plan_plane_range(L, &s->planes[i], u0, u1, v0, v1, &z0, &z1))
            z0 = INFINITY, z1 = 0.0;
        /* Grow the rectangle by the spread at those depths (twice,
         * since the growth can reveal nearer parts). */
        for (int it = 0; it < 2 && isfinite(z0); it++) {
            double g = lr__plan_spread(L, z0, z1) * 1.01 + 1e-9;
            if (!lr__plan_plane_range(L, &s->planes[i], u0 - g, u1 + g, v0 - g,
                                      v1 + g, &z0, &z1))
                z0 = INFINITY, z1 = 0.0;
        }
        /* plane_reached also finds a plane that only the lens's
         * spread reaches (beyond its horizon in the block). */
        if ((!*lit && !dark[s->n_geoms + i]) || lobes[s->n_geoms + i] < *lobe)
            if (lr__plan_plane_reached(L, &s->planes[i], u0, u1, v0, v1)) {
                *lit |= dark == NULL || !dark[s->n_geoms + i];
                *lobe = fmin(*lobe, lobes[s->n_geoms + i]);
            }
        if (z0 < *zmin)
            *zmin = z0;
        if (z1 > *zmax)
            *zmax = z1;
    }
}

/* Where no colour's blur can reach a quarter pixel, the block needs no
 * lens (unless `dither`: wherever it reaches anything); where the
 * colours' blurs differ by less, one ray for all. */
static lr_status plan_blur(lr__plan *p, const lr_scene *s, const lr__cam *c,
                           const lr__lens_blur *lb, int dither, int rough,
                           double blur_px, const unsigned char *dark, int x0,
                           int y0, int x1, int y1, lr_error *err)
{
    lens L;
    lr__plan_make_lens(c, &L);
    if (lb != NULL) {
        /* A real lens: its rays from a block lie, at depth Z, within Z
         * times the slopes lr__lens_blur_reach gives, grown by R (the
         * form of a lens of radius R focused at infinity). */
        double uv[4];
        lr__lens_blur_reach(c, lb, 0.0, 0.0, c->width, c->height, uv, &L.R);
        L.w = L.ws[0] = 0.0;
        L.n_w = 1;
    }

    double *lobes = lobe_widths(s, rough);
    boxset *set = lobes != NULL ? lr__plan_get_boxes(s, &L) : NULL;
    if (set == NULL) {
        free(lobes);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    const box *boxes = set->boxes;
    size_t n_boxes = set->n;

    int bx0 = x0 / LR__PLAN_BLOCK, by0 = y0 / LR__PLAN_BLOCK;
    int bx1 = (x1 - 1) / LR__PLAN_BLOCK, by1 = (y1 - 1) / LR__PLAN_BLOCK;
    double su = 2.0 * c->half_w / c->width, sv = 2.0 * c->half_h / c->height;
    for (int by = by0; by <= by1; by++)
        for (int bx = bx0; bx <= bx1; bx++) {
            int px0 = bx * LR__PLAN_BLOCK, py0 = by * LR__PLAN_BLOCK;
            int px1 = px0 + LR__PLAN_BLOCK, py1 = py0 + LR__PLAN_BLOCK;
            double u0 = px0 * su - c->half_w, u1 = px1 * su - c->half_w;
            double v0 = c->half_h - py1 * sv, v1 = c->half_h - py0 * sv;
            lr__block_plan *bp = &p->blocks[by * p->bw + bx];
            /* The block's film rectangle, in the frame. */
            double fx1 = fmin(px1, c->width), fy1 = fmin(py1, c->height);
            if (lb != NULL) {
                double uv[4], R;
                lr__lens_blur_reach(c, lb, px0, py0, fx1, fy1, uv, &R);
                if (!isfinite(uv[0] + uv[1] + uv[2] + uv[3])) {
                    /* No bound on where its rays go. */
                    *bp = (lr__block_plan){1, 1, 0, 0, 0};
                    continue;
                }
                u0 = uv[0], u1 = uv[1], v0 = uv[2], v1 = uv[3];
            }
            double zmin = INFINITY, zmax = 0.0, lobe = INFINITY;
            /* Whether anything in reach gives camera paths light (with
             * no `dark`, anything counts). */
            int lit = dark == NULL;
            for (size_t i = 0; i < n_boxes; i++) {
                const box *b = &boxes[i];
                double z0 = b->z0 > NEAR ? b->z0 : NEAR;
                int b_lit = dark == NULL || !dark[b->geom];
                /* A box within the depths found so far cannot widen
                 * them, and one out of reach has no piece in reach
                 * (box_reached only grows with the box): skip it, and
                 * its pieces, unless it may be the first lit one.  A cut
                 * triangle's box in reach only leads to its pieces. */
                if ((z0 >= zmin && b->z1 <= zmax && (lit || !b_lit) &&
                     lobes[b->geom] >= lobe) ||
                    !lr__plan_box_reached(&L, b, u0, u1, v0, v1)) {
                    i += b->skip;
                    continue;
                }
                if (b->skip > 0)
                    continue;
                lit |= b_lit;
                lobe = fmin(lobe, lobes[b->geom]);
                if (z0 < zmin)
                    zmin = z0;
                if (b->z1 > zmax)
                    zmax = b->z1;
            }
            planes_reach(s, &L, dark, lobes, u0, u1, v0, v1, &zmin, &zmax, &lit,
                         &lobe);
            bp->dark = !lit;
            /* An environment map is light at infinite depth that any
             * ray may escape to, and the lens blurs it like anything
             * else (a uniform background it cannot change). */
            if (s->env != NULL) {
                if (!(zmin <= zmax))
                    zmin = INFINITY;
                zmax = INFINITY;
            }
            if (!(zmin <= zmax)) {
                /* Nothing reachable: only the background, which no blur
                 * changes; but a real lens's chief rays stand for its
                 * pupil's weight only where its table has them. */
                bp->lens = lb != NULL &&
                           !lr__lens_blur_chief_ok(c, lb, px0, py0, fx1, fy1);
                /* Where the table's weights do not hold, neither do its
                 * colours' shares: a ray per colour. */
                bp->chroma = bp->lens;
                continue;
            }
            if (lobe_needs_lens(lobe, L.R, zmin)) {
                /* A mirror, glass or narrow lobe shows other depths: the
                 * lens, and the colours wherever they can focus apart at
                 * some depth (a thin lens's blur diameters differ by at
                 * most their focus powers' difference at any depth; a
                 * real lens's colours, which its table bounds only at
                 * the depths it sees, always). */
                bp->lens = 1;
                bp->chroma = lb != NULL ||
                             (L.n_w > 1 && lr__plan_chroma_spread(
                                               &L, 0.0, 1.0 / NEAR) >= blur_px);
                continue;
            }
            if (lb != NULL) {
                /* The real lens's spot and colour spread, from its table. */
                double spot, col;
                int ok = lr__lens_blur_bound(c, lb, px0, py0, fx1, fy1, zmin,
                                             zmax, &spot, &col);
                bp->lens = dither || !ok || spot >= blur_px;
                bp->chroma = !ok || col >= blur_px;
                continue;
            }
            double x_lo = isfinite(zmax) ? 1.0 / zmax : 0.0;
            double x_hi = 1.0 / zmin;
            /* The largest blur of any colour at either end. */
            double blur = 0.0;
            for (int k = 0; k < L.n_w; k++)
                blur = fmax(
                    blur, 2.0 * L.R * L.fpx *
                              fmax(fabs(x_lo - L.ws[k]), fabs(x_hi - L.ws[k])));
            bp->lens = dither || blur >= blur_px;
            bp->chroma = L.n_w > 1 &&
                         lr__plan_chroma_spread(&L, x_lo, x_hi) >= blur_px;
        }
    lr__plan_put_boxes(s, set);
    free(lobes);
    return LR_OK;
}


void lr__plan_free(lr__plan *p)
{
    free(p->blocks);
    p->blocks = NULL;
    lr__plan_rare_free(p->rare);
    p->rare = NULL;
    lr__lt_free(p->lt);
    p->lt = NULL;
}
