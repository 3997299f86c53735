/*
 * ghost_trace.c: a real lens's ghosts from the light side
 * (ghost_trace.h).
 */
#include "integrator/ghost_trace.h"

#include "scene/envmap.h"
#include "scene/light.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The solid angle a sphere fills from camera c's eye; -1 when the eye
 * is inside the sphere or the sphere lies behind it. */
static double solid_angle(const lr__cam *c, lr__v3 center, double radius)
{
    lr__v3 d = v3_sub(center, c->origin);
    double dist2 = v3_dot(d, d), r2 = radius * radius;
    if (!(dist2 > r2) || !(v3_dot(d, c->forward) > -radius))
        return -1.0;
    double sin2 = r2 / dist2;
    return 2.0 * M_PI * sin2 / (1.0 + sqrt(1.0 - sin2));
}

/* The sum over n paths' estimates est of flux_g / sqrt(land_g), each
 * term into w[g] (w not NULL). */
static double est_weights(const lr__ghost_est *est, int n, double *w)
{
    double sum = 0.0;
    for (int g = 0; g < n; g++) {
        double x = est[g].land > 0.0 && est[g].flux > 0.0
                       ? est[g].flux / sqrt(est[g].land)
                       : 0.0;
        if (w != NULL)
            w[g] = x;
        sum += x;
    }
    return sum;
}

/* Per ghost path g of a light, after the paths' cdf (GUIDE doubles a
 * path): the box of lens offsets x0, y0, x1, y1 its paths draw from (x0
 * >= x1: none, the disk alone), the weight p_disk / p_mix of a lens
 * point inside it, and for a light drawn as meshes the cells across its
 * mesh and 1 when it takes every direction of the light (0: the centre
 * alone, lr__gt_mesh); after the last path's, the disk's squared
 * radius. */
#define GUIDE 7
static double *guides(const lr__lt_light *l)
{
    return l->cdf + l->n_tri + l->ghosts;
}

const double *lr__gt_box(const lr__lt_light *l, int g)
{
    return guides(l) + GUIDE * g;
}

/* Light l's guides (guides), seen along unit w0 (its centre's direction
 * from the eye), and its own estimate of each path there (own).  A grid
 * of GRID x GRID lens offsets over the front disk, each traced through
 * each ghost path at the reference wavelength (ghost_film): a path's
 * box holds the offsets that land in the frame, widened by 1.5 cells
 * (a ghost's footprint on the disk is a pupil's image, a disc or a
 * lens, which the cells' centres find to within a cell), and its paths
 * draw LR__GT_DISK of their lens points from the whole disk, the rest
 * from the box: unbiased whatever the grid misses (the disk's share
 * covers it), up to 1 / LR__GT_DISK times the landings where it finds
 * them all.  own[g]: the landings' importance times the cell's area
 * (the path's flux, up to a factor common to every path), and the share
 * of the box's lens points that land. */
#define GRID 16
/* Where the main beam reaches fewer than MAIN_FEW of GRID's offsets (a
 * stopped-down lens's sliver, which GRID stepped over: docs/lenses.md),
 * a ghost landing on fewer than FEW of its guide's offsets (paths' or
 * meshes') is looked for on a grid doubled until the main beam reaches
 * MAIN_FEW (<= FINE). */
#define MAIN_FEW 16
#define FEW 4
#define FINE 128

/* Offsets of an n x n grid over the disk whose main path lands. */
static int main_cells(const lr__cam *c, lr__v3 w0, int n, double rho)
{
    int main = 0;
    double h = 2.0 * rho / n;
    for (int q = 0; q < n * n; q++) {
        double x = (q / n + 0.5) * h - rho, y = (q % n + 0.5) * h - rho, fx, fy;
        main += x * x + y * y <= rho * rho &&
                c->model->film(c, x, y, w0, &fx, &fy) > 0.0 &&
                lr__cam_on_film(c, fx, fy);
    }
    return main;
}

/* Path g's box and estimate from an n x n grid: how many offsets land. */
static int guide_path(const lr__cam *c, lr__lt_light *l, lr__v3 w0, int g,
                      int n, double rho, lr__ghost_est *own)
{
    double *gd = guides(l);
    double h = n > 0 ? 2.0 * rho / n : 0.0;
    double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
    double flux = 0.0;
    int land = 0;
    /* LR__GHOST_LANES offsets at a time (ghost_film_n: ghost_film's bits). */
    double ox[LR__GHOST_LANES], oy[LR__GHOST_LANES];
    lr__v3 ws[LR__GHOST_LANES];
    int u = 0;
    for (int q = 0; q <= n * n; q++) {
        if (q < n * n) {
            int i = q / n, j = q % n;
            double x = (i + 0.5) * h - rho, y = (j + 0.5) * h - rho;
            if (x * x + y * y > rho * rho)
                continue;
            ox[u] = x, oy[u] = y, ws[u++] = w0;
            if (u < LR__GHOST_LANES)
                continue;
        }
        double W[LR__GHOST_LANES], fx[LR__GHOST_LANES], fy[LR__GHOST_LANES];
        c->model->ghost_film_n(c, g, -1, u, ox, oy, ws, NULL, fx, fy, W);
        for (int a = 0; a < u; a++) {
            if (!(W[a] > 0.0) || !lr__cam_on_film(c, fx[a], fy[a]))
                continue;
            land++, flux += W[a];
            x0 = fmin(x0, ox[a]), x1 = fmax(x1, ox[a]);
            y0 = fmin(y0, oy[a]), y1 = fmax(y1, oy[a]);
        }
        u = 0;
    }
    double *b = gd + GUIDE * g;
    own[g] = (lr__ghost_est){0.0, 1.0, 0.0};
    b[0] = b[2] = 0.0, b[4] = 1.0;
    if (land == 0)
        return 0;
    b[0] = fmax(-rho, x0 - 1.5 * h), b[1] = fmax(-rho, y0 - 1.5 * h);
    b[2] = fmin(rho, x1 + 1.5 * h), b[3] = fmin(rho, y1 + 1.5 * h);
    double A = (b[2] - b[0]) * (b[3] - b[1]);
    b[4] = 1.0 / (LR__GT_DISK + (1.0 - LR__GT_DISK) * M_PI * rho * rho / A);
    own[g] = (lr__ghost_est){flux * h * h, 1.0, fmin(1.0, land * h * h / A)};
    return land;
}

static void ghost_guide(const lr__cam *c, lr__lt_light *l, lr__v3 w0,
                        lr__ghost_est *own)
{
    double rho = c->model->ghost_disk(c);
    double *gd = guides(l);
    gd[GUIDE * l->ghosts] = rho * rho;
    int fine = 0;
    if (main_cells(c, w0, GRID, rho) < MAIN_FEW)
        for (fine = 2 * GRID;
             fine < FINE && main_cells(c, w0, fine, rho) < MAIN_FEW;)
            fine *= 2;
    for (int g = 0; g < l->ghosts; g++) {
        /* A light drawn as meshes: LR__GT_GUIDE_MESH, none for a ghost
         * of no light (mesh_sizes). */
        int n = l->grid == 0               ? GRID
                : gd[GUIDE * g + 5] == 0.0 ? 0
                                           : LR__GT_GUIDE_MESH;
        if (guide_path(c, l, w0, g, n, rho, own) < FEW && fine > n && n > 0)
            guide_path(c, l, w0, g, fine, rho, own);
    }
}

/* The cumulative choice of n ghost paths from their estimates est
 * (ghost_choice). */
static void choice_cdf(double *cdf, const lr__ghost_est *est, int n)
{
    double sum = est_weights(est, n, cdf), acc = 0.0;
    for (int g = 0; g < n; g++) {
        double p = sum > 0.0 ? (1.0 - LR__GT_UNIFORM) * cdf[g] / sum +
                                   LR__GT_UNIFORM / n
                             : 1.0 / n;
        acc += p;
        cdf[g] = acc;
    }
    cdf[n - 1] = 1.0;
}

/* Light l's choice of ghost paths (cumulative, after a mesh's triangles'
 * in l->cdf: one array, freed as one, with its guides after it) from the
 * n paths' estimates est (choice_cdf), and its weight in the budget: M
 * times the sum of flux_g / sqrt(land_g) on axis, M its main image's
 * total on axis (L's largest channel L Omega k, camera_model.ghost_paths'
 * k).
 *
 * Ghost g's light, M flux_g, lands in K_g = N p_g land_g splats of a
 * light's N paths, each M flux_g / K_g; over its px_g pixels their
 * counts are Poisson, so the squared error summed over its pixels is
 * (M flux_g)^2 / (N p_g land_g).  Summed over the ghosts that is least
 * with p_g proportional to flux_g / sqrt(land_g), and then (M sum_g
 * flux_g / sqrt(land_g))^2 / N: the weight squared over N.  Each path
 * is drawn with (1 - LR__GT_UNIFORM) of that share plus LR__GT_UNIFORM
 * / n, so that a ghost the estimate misses (off axis other ghosts lead)
 * still gets some.  The camera's estimates are on axis; a guided light
 * takes its own where it is seen (ghost_guide_lights).  -1: out of
 * memory. */
static double ghost_choice(const lr__cam *c, lr__lt_light *l,
                           const lr__ghost_est *est, int n, double M)
{
    size_t size = l->n_tri + (size_t)n * (1 + GUIDE) + 1;
    double *all = realloc(l->cdf, size * sizeof *all);
    if (all == NULL)
        return -1.0;
    l->cdf = all;
    choice_cdf(all + l->n_tri, est, n);
    /* No guide yet (ghost_guide_lights): the whole disk. */
    double *gd = guides(l), rho = c->model->ghost_disk(c);
    for (int g = 0; g < n; g++)
        gd[GUIDE * g] = gd[GUIDE * g + 2] = 0.0;
    gd[GUIDE * n] = rho * rho;
    return M * est_weights(est, n, NULL);
}

/* A light drawn as meshes: each ghost path's cells and directions
 * (guides), by its mean on the film m = M flux / px (the camera's
 * estimate on axis, M the light's main-image total): a mesh's error
 * falls as its cells squared inside a ghost and as its cells at the
 * edge, and what matters is that error against the pixels' brightness,
 * so a ghost from LR__GT_LIT of white on gets lr__gt_cells and a
 * fainter one lr__gt_cells (m / LR__GT_LIT)^(1/4), at least
 * LR__GT_CELLS_MIN; the light's every direction only for ghosts from
 * LR__GT_EVERY LR__GT_LIT on (a faint ghost's softened edge is lost
 * under the brighter ones).  The exponent and the levels are measured,
 * not derived (ghost_trace.h).  No estimate (all 0): every ghost at
 * full size. */
static void mesh_sizes(lr__lt_light *l, const lr__ghost_est *est, double M)
{
    double *gd = guides(l), sum = 0.0;
    for (int g = 0; g < l->ghosts; g++)
        sum += est[g].flux;
    for (int g = 0; g < l->ghosts; g++) {
        double m = sum > 0.0 ? M * est[g].flux / est[g].px : INFINITY;
        double n = lr__gt_cells * sqrt(sqrt(fmin(1.0, m / LR__GT_LIT)));
        gd[GUIDE * g + 5] = fmax(LR__GT_CELLS_MIN, ceil(n));
        gd[GUIDE * g + 6] = m >= LR__GT_LIT * LR__GT_EVERY;
        /* Rays that land but carry nothing: a reflection at a surface
         * with the same index on both sides (the stop), no ghost at any
         * place or wavelength. */
        if (est[g].flux == 0.0 && est[g].land > 0.0)
            gd[GUIDE * g + 5] = 0.0;
    }
}

/* Guides the ghost lights first .. lt->n - 1 (ghost_guide) whose paths
 * are at least LR__GT_GUIDE times the grid's rays, and draws their
 * paths' choice from their own estimates (where any path lands on the
 * grid).  own: room for the paths' estimates. */
static void ghost_guide_lights(lr__lt *lt, int first, const lr_scene *s,
                               const lr__cam *c, lr__ghost_est *own)
{
    for (int k = first; k < lt->n; k++) {
        lr__lt_light *l = &lt->lights[k];
        double rays = (double)l->ghosts * GRID * GRID * M_PI / 4.0;
        if (l->grid == 0 && !((double)l->paths >= LR__GT_GUIDE * rays))
            continue;
        lr__v3 w0 = l->geom == (int)s->n_geoms
                        ? l->center
                        : v3_norm(v3_sub(l->center, c->origin));
        ghost_guide(c, l, w0, own);
        if (est_weights(own, l->ghosts, NULL) > 0.0)
            choice_cdf(l->cdf + l->n_tri, own, l->ghosts);
    }
}

/* Light l's meshes' cost in rays through the lens, nch colours: the
 * guide's grid for every ghost path that carries light, and each mesh's
 * corners over (about) half its box, times its directions. */
static double mesh_cost(const lr__lt_light *l, int nch)
{
    const double *gd = guides(l);
    double sum = 0.0, K = (double)l->grid * l->grid;
    for (int g = 0; g < l->ghosts; g++) {
        double n = gd[GUIDE * g + 5];
        if (n > 0.0)
            sum += LR__GT_GUIDE_MESH * LR__GT_GUIDE_MESH * M_PI / 4.0 +
                   0.5 * (n + 1.0) * (n + 1.0) * nch *
                       (gd[GUIDE * g + 6] != 0.0 ? K : 1.0);
    }
    return sum;
}

/* The ghost lights' paths, lights first .. lt->n - 1 with budget weights
 * a[] (ghost_choice): the squared error over the frame's P pixels,
 * sum_l a_l^2 / ((1 - LR__GT_UNIFORM) N_l), is least for a total of
 * paths with N_l proportional to a_l, and reaches LR__GT_SIGMA^2 / spp
 * per pixel with N_l = a_l sum_k a_k / ((1 - LR__GT_UNIFORM) P
 * LR__GT_SIGMA^2 / spp).  A light that can be drawn as meshes is, when
 * those N_l paths (each traced in every colour) cost more than its
 * meshes (mesh_cost), whose error is far below the paths' at that cost
 * (docs/lenses.md); else it keeps N_l paths, all the path lights
 * together at most LR__GT_CAP spp P (scaled down alike), each at least
 * LR__GT_MIN. */
static void ghost_paths(lr__lt *lt, int first, const double *a,
                        const lr__cam *c, int spp)
{
    double P = c->width * c->height, sum = 0.0;
    for (int k = first; k < lt->n; k++)
        sum += a[k - first];
    double per = sum * spp /
                 ((1.0 - LR__GT_UNIFORM) * P * LR__GT_SIGMA * LR__GT_SIGMA);
    int nch = c->chroma.mode == LR_CHROMATIC_OFF ? 1 : 3;
    double rest = 0.0;
    for (int k = first; k < lt->n; k++) {
        lr__lt_light *l = &lt->lights[k];
        if (l->grid > 0 && !(a[k - first] * per * nch > mesh_cost(l, nch)))
            l->grid = 0;
        rest += l->grid > 0 ? 0.0 : a[k - first];
    }
    double cap = LR__GT_CAP * spp * P;
    if (per * rest > cap)
        per = cap / rest;
    for (int k = first; k < lt->n; k++) {
        lr__lt_light *l = &lt->lights[k];
        double want = ceil(a[k - first] * per);
        l->paths = l->grid > 0                        ? 0
                   : !(want > (double)LR__GT_MIN)     ? LR__GT_MIN
                   : want < (double)(LR__LT_PART - 1) ? (uint64_t)want
                                                      : LR__LT_PART - 1;
        l->first = lt->paths;
        lt->paths += l->paths;
        l->grid_first = lt->grid_tasks;
        lt->grid_tasks += l->grid > 0;
    }
}

/* The plan's ghost sources as it picks them: the lens's ghost paths
 * (asked once, at the first emitter: a scene without one pays nothing),
 * and the budget weights of the lights picked so far. */
typedef struct gt_pick {
    const lr_scene *s;
    const lr__cam *c;
    lr__lt **ltp;
    int n_ghost; /* -1: not asked yet */
    double peak, k;
    lr__ghost_est est[LR__RX_MAX_SURFACES * LR__RX_MAX_SURFACES / 2];
    lr__ghost_est own[LR__RX_MAX_SURFACES * LR__RX_MAX_SURFACES / 2];
    double *a; /* room for every geometry and the sun */
    int first;
} gt_pick;

/* Adds source *src (geom, center, radius, L and, for a mesh, its
 * triangles' cdf, which it then owns) as a ghost light if camera.ghosts
 * asks for it: omega the solid angle it fills from the eye (< 0: behind
 * the eye, or around it) and Lbar its mean radiance there, so that its
 * main image's total on axis is omega Lbar k (ghost_paths' k).  "true"
 * (peak infinite): every source in front of the lens; "auto": those
 * whose brightest ghost reaches LR__GT_AUTO.  0: out of memory (src's
 * cdf freed). */
static int pick(gt_pick *p, lr__lt_light *src, double omega, lr__v3 Lbar)
{
    const lr__cam *c = p->c;
    if (p->n_ghost < 0) {
        p->n_ghost = c->model->ghost_paths(c, &p->peak, &p->k, p->est);
        if (p->n_ghost < 0)
            goto nomem;
    }
    double M = omega * p->k * v3_maxc(Lbar);
    if (p->n_ghost == 0 || !(omega >= 0.0) ||
        !(isinf(p->peak) || p->peak * M >= LR__GT_AUTO)) {
        free(src->cdf);
        return 1;
    }
    lr__lt *lt = *p->ltp;
    if (lt == NULL) {
        lt = lr__lt_new(p->s);
        *p->ltp = lt;
        if (lt == NULL)
            goto nomem;
    }
    if (p->a == NULL) {
        p->a = malloc((p->s->n_geoms + 1) * sizeof *p->a);
        if (p->a == NULL)
            goto nomem;
        p->first = lt->n;
    }
    lr__lt_light *grown = realloc(lt->lights, (lt->n + 1) * sizeof *grown);
    if (grown == NULL)
        goto nomem;
    lt->lights = grown;
    lr__lt_light *l = &lt->lights[lt->n++];
    *l = *src;
    l->surf = LR__LT_GHOST;
    l->ghosts = p->n_ghost;
    l->omega = omega, l->Lmean = Lbar;
    /* Its diameter in pixels at the frame's centre, as a disc of solid
     * angle omega: meshes up to LR__GT_DIRS (ghost_trace.h). */
    double diam = 2.0 * sqrt(omega / M_PI) / (2.0 * c->half_h / c->height);
    l->grid = diam <= LR__GT_DIRS * lr__gt_dir_px
                  ? (int)fmax(1.0, ceil(diam / lr__gt_dir_px))
                  : 0;
    lt->ghost_lights++;
    lt->ghost_main += omega * p->k * (Lbar.x + Lbar.y + Lbar.z);
    if ((p->a[lt->n - 1 - p->first] = ghost_choice(c, l, p->est, p->n_ghost,
                                                   M)) < 0.0)
        return 0;
    if (l->grid > 0)
        mesh_sizes(l, p->est, M);
    return 1;
nomem:
    free(src->cdf);
    return 0;
}

/* The solid angle mesh g's emitting triangles fill from the eye: each
 * triangle whose front faces the eye and whose centre is ahead of it,
 * by Van Oosterom and Strackee's formula (IEEE Trans. Biomed. Eng. 30,
 * 1983): tan(Omega / 2) = |a . (b x c)| / (abc + (a . b) c + (a . c) b
 * + (b . c) a), a, b, c the corners from the eye, of lengths a, b, c.
 * Overlapping triangles (a closed mesh's back) are left out by facing,
 * so a convex mesh counts its silhouette once; -1 when none counts. */
static double mesh_omega(const lr_scene *s, const lr__cam *c, const lr__geom *g)
{
    double sum = -1.0;
    for (size_t t = 0; t < g->n_triangles; t++) {
        const lr__emitter *e = &s->emitters[g->emitter + (long)t];
        lr__v3 a = v3_sub(e->a, c->origin);
        lr__v3 b = v3_add(a, e->e1), d = v3_add(a, e->e2);
        lr__v3 mid = v3_add(a, v3_scale(v3_add(e->e1, e->e2), 1.0 / 3.0));
        if (!(v3_dot(a, e->n) < 0.0) || !(v3_dot(mid, c->forward) > 0.0))
            continue;
        double la = v3_len(a), lb = v3_len(b), ld = v3_len(d);
        double num = fabs(v3_dot(a, v3_cross(b, d)));
        double den = la * lb * ld + v3_dot(a, b) * ld + v3_dot(a, d) * lb +
                     v3_dot(b, d) * la;
        double om = 2.0 * atan2(num, den);
        if (isfinite(om))
            sum = fmax(sum, 0.0) + om;
    }
    return sum;
}

/* The environment's sun (lr__envmap_sun's cone, as light_trace.c's
 * LR__LT_SUN) as a ghost source: its mean radiance over the cone by a
 * 64 x 64 midpoint rule in the cone's equal-area coordinates
 * (lr__lt_in_cone), 4096 lookups; behind the eye, omega -1. */
static int pick_sun(gt_pick *p)
{
    const lr_scene *s = p->s;
    lr__v3 a;
    double cos_a;
    if (s->env == NULL || !lr__envmap_sun(s->env, &a, &cos_a))
        return 1;
    double sin_a = sqrt(fmax(0.0, 1.0 - cos_a * cos_a));
    lr__lt_light l;
    memset(&l, 0, sizeof l);
    l.geom = (int)s->n_geoms;
    l.center = a;
    l.area = sin_a * sin_a / (1.0 + cos_a); /* 1 - cos, as LR__LT_SUN's */
    double m = lr__envmap_max(s->env);
    l.L = v3(m, m, m); /* the film's scale, as LR__LT_SUN's */
    enum { Q = 64 };
    lr__v3 sum = v3(0, 0, 0);
    for (int i = 0; i < Q; i++)
        for (int j = 0; j < Q; j++) {
            double u[2] = {(i + 0.5) / Q, (j + 0.5) / Q};
            sum = v3_add(sum,
                         lr__env_radiance(s, lr__lt_in_cone(a, l.area, u)));
        }
    double omega = v3_dot(a, p->c->forward) > -sin_a ? 2.0 * M_PI * l.area
                                                     : -1.0;
    return pick(p, &l, omega, v3_scale(sum, 1.0 / (Q * Q)));
}

int lr__gt_plan(const lr_scene *s, const lr__cam *c, int spp, lr__lt **ltp)
{
    const lr__camera_model *m = c->model;
    if (m->ghost_paths == NULL || m->ghost_film == NULL ||
        m->ghost_film_n == NULL || m->ghost_disk == NULL || m->lens_at == NULL)
        return 1;
    gt_pick *p = calloc(1, sizeof *p);
    if (p == NULL)
        return 0;
    /* Its estimates' arrays are large (98 kB): on the heap, filled by
     * field. */
    p->s = s, p->c = c, p->ltp = ltp, p->n_ghost = -1, p->first = -1;
    int ok = 1;
    for (size_t g = 0; g < s->n_geoms && ok; g++) {
        const lr__geom *geo = &s->geoms[g];
        const lr__material *mt = &s->materials[geo->material];
        lr__lt_light l;
        memset(&l, 0, sizeof l);
        l.geom = (int)g;
        /* l.L the largest radiance the light gives (a textured one's
         * paths look their own up: lr__gt_reaches), and for the plan's
         * estimate of the ghosts and of the main image the texels'
         * mean. */
        lr__lt_light_emission(mt, &l);
        lr__v3 Lbar = mt->emission;
        if (mt->emission_tex != NULL) {
            const double *a = mt->emission_tex->mean;
            Lbar = v3(Lbar.x * a[0], Lbar.y * a[1], Lbar.z * a[2]);
        }
        if (!lr__lt_light_sphere(s, geo, &l.center, &l.radius))
            continue;
        if (geo->kind == LR__GEOM_SPHERE) {
            ok = pick(p, &l, solid_angle(c, geo->center, geo->radius), Lbar);
        } else {
            ok = lr__lt_mesh_cdf(s, geo, &l);
            if (!ok)
                break;
            ok = pick(p, &l, mesh_omega(s, c, geo), Lbar);
        }
    }
    if (ok)
        ok = pick_sun(p);
    if (ok && p->a != NULL) {
        ghost_paths(*ltp, p->first, p->a, c, spp);
        ghost_guide_lights(*ltp, p->first, s, c, p->own);
    }
    free(p->a);
    free(p);
    return ok;
}

/* Ghost light l's direction from lens point P, drawn from ud (as
 * light_trace.c's sphere, mesh and sun paths draw theirs), into *w,
 * with its radiance over its solid-angle density and, for a mesh, the
 * triangle drawn (*e).  0: no light that way. */
double lr__gt_dir(const lr_scene *s, const lr__lt_light *l, lr__v3 P,
                  const double *ud, lr__v3 *w, const lr__emitter **e)
{
    *e = NULL;
    if (l->n_tri > 0) {
        /* A point y uniform by area on the mesh: dist^2 / (A cos_y). */
        lr__v3 y;
        *e = lr__lt_mesh_point(s, l, ud, &y);
        lr__v3 dv = v3_sub(y, P);
        double dist2 = v3_dot(dv, dv);
        if (!(dist2 > 0.0))
            return 0.0;
        *w = v3_scale(dv, 1.0 / sqrt(dist2));
        double cos_y = -v3_dot(*w, (*e)->n);
        return cos_y > 0.0 ? l->area * cos_y / dist2 : 0.0;
    }
    if (l->geom == (int)s->n_geoms) {
        /* The sun: uniform in its cone, the map's radiance along w. */
        *w = lr__lt_in_cone(l->center, l->area, ud);
        return 2.0 * M_PI * l->area;
    }
    lr__v3 dv = v3_sub(l->center, P);
    double dist2 = v3_dot(dv, dv), r2 = l->radius * l->radius;
    if (!(dist2 > r2))
        return 0.0;
    double dist = sqrt(dist2);
    double sin2 = r2 / dist2, omc = sin2 / (1.0 + sqrt(1.0 - sin2));
    *w = lr__lt_in_cone(v3_scale(dv, 1.0 / dist), omc, ud);
    return 2.0 * M_PI * omc;
}

/* Whether the light along w from lens point P reaches the front of the
 * lens: the camera ray along w (the same trace as the camera's) meets
 * the sphere first, or the mesh's very triangle e from its front (a
 * mesh can hide its own triangles), or for the sun escapes.  For a
 * textured light, *k gets its radiance where the ray meets it over l->L
 * (the largest), per channel, as the camera's hit looks it up
 * (lr__hit_material); else 1. */
int lr__gt_reaches(const lr_scene *s, const lr__cam *c, const lr__lt_light *l,
                   lr__v3 P, lr__v3 w, const lr__emitter *e, double k[3])
{
    lr__v3 o = lr__cam_ray_start(c, P, w);
    k[0] = k[1] = k[2] = 1.0;
    if (e == NULL && !l->textured)
        return lr__trace_geom(s, o, w, INFINITY) ==
               (l->geom == (int)s->n_geoms ? -2 : l->geom);
    lr__hit h;
    if (!lr__trace(s, o, w, INFINITY, &h) || h.geom != l->geom ||
        (e != NULL &&
         (h.prim != (unsigned)(e - &s->emitters[l->first_tri]) || !h.entering)))
        return 0;
    if (l->textured) {
        lr__v3 Le = lr__lt_emission_at(s, l, &h);
        double Le3[3] = {Le.x, Le.y, Le.z}, Lm[3] = {l->L.x, l->L.y, l->L.z};
        for (int j = 0; j < 3; j++)
            k[j] = Lm[j] > 0.0 ? fmin(Le3[j] / Lm[j], 1.0) : 0.0;
    }
    return 1;
}


/* Ghost path g's lens point for light l from lens sample ul, the
 * component drawn by uc (ghost_guide's mixture): its offset (ox, oy) and
 * the weight p_disk / p_mix (0: none, a box point off the disk). */
static double ghost_lens(const lr__cam *c, const lr__lt_light *l, int g,
                         const double *ul, double uc, lr__v3 *P, double *ox,
                         double *oy)
{
    const double *b = guides(l) + GUIDE * g;
    if (!(b[0] < b[2])) {
        *P = c->model->lens_point(c, ul, ox, oy);
        return 1.0;
    }
    if (!(uc < LR__GT_DISK)) {
        *ox = b[0] + ul[0] * (b[2] - b[0]), *oy = b[1] + ul[1] * (b[3] - b[1]);
        if (!(*ox * *ox + *oy * *oy <= guides(l)[GUIDE * l->ghosts]))
            return 0.0;
        *P = c->model->lens_at(c, *ox, *oy);
        return b[4];
    }
    *P = c->model->lens_point(c, ul, ox, oy);
    return *ox >= b[0] && *ox <= b[2] && *oy >= b[1] && *oy <= b[3]
               ? b[4]
               : 1.0 / LR__GT_DISK;
}

int lr__gt_which(const lr__lt_light *l, double u, uint64_t i, uint32_t *j)
{
    /* The first g whose cumulative probability passes t (binary
     * search). */
    const double *cdf = l->cdf + l->n_tri;
    double N = (double)l->paths, t = ((double)i + u) / N;
    int lo = 0, hi = l->ghosts - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (cdf[mid] > t)
            hi = mid;
        else
            lo = mid + 1;
    }
    /* g's first index: the least i' with (i' + u) / N >= cdf[g - 1]
     * (rounding may put it one off: then two of g's paths share a
     * sample, each still uniform). */
    double start = lo > 0 ? ceil(cdf[lo - 1] * N - u) : 0.0;
    *j = (double)i > start ? (uint32_t)((double)i - start) : 0;
    return lo;
}

void lr__gt_path(const lr_scene *s, const lr__cam *c, const lr__lt_light *l,
                 int g, const double *ul, const double *ud, double uc,
                 double ur, lr__lt_film *f, uint64_t *rays, uint64_t *landed)
{
    const double *cdf = l->cdf + l->n_tri;
    double c0 = g > 0 ? cdf[g - 1] : 0.0, p_g = cdf[g] - c0;
    if (!(p_g > 0.0))
        return;
    lr__v3 P, w;
    double ox, oy;
    double share = ghost_lens(c, l, g, ul, uc, &P, &ox, &oy);
    const lr__emitter *e;
    double inv_pdf = share > 0.0 ? lr__gt_dir(s, l, P, ud, &w, &e) : 0.0;
    if (!(inv_pdf > 0.0))
        return;
    /* The sun's radiance along w (the map's, looked up before the lens:
     * a dark part of its cone costs no trace). */
    lr__v3 L = l->L;
    if (l->geom == (int)s->n_geoms) {
        L = lr__env_radiance(s, w);
        if (!(v3_maxc(L) > 0.0))
            return;
    }
    lr__v3 v = v3_scale(L, inv_pdf * share / ((double)l->paths * p_g));
    /* chromatic.mode off: every channel at the reference wavelength (a
     * grey ghost, as the main image is traced); rgb and spectral: each
     * channel at its own wavelength, so that a coating's colour shows
     * (spectral mode: the rgb channels' wavelengths, not its spectra).
     * The lens first: most ghost rays are stopped in it or land outside
     * the frame, and those need no trace through the scene. */
    int k0 = c->chroma.mode == LR_CHROMATIC_OFF ? -1 : 0;
    int k1 = k0 < 0 ? 0 : 3, n = 0, px[3], py[3];
    lr__v3 ev[3];
    for (int k = k0; k < k1; k++) {
        double fx, fy;
        double W = c->model->ghost_film(c, g, k, ox, oy, w, NULL, &fx, &fy);
        if (!(W > 0.0) || !lr__cam_on_film(c, fx, fy))
            continue;
        lr__v3 ek = v3_scale(v, W);
        if (k >= 0)
            ek = v3(k == 0 ? ek.x : 0.0, k == 1 ? ek.y : 0.0,
                    k == 2 ? ek.z : 0.0);
        if (!(isfinite(ek.x) && isfinite(ek.y) && isfinite(ek.z)))
            continue;
        px[n] = (int)fx, py[n] = (int)fy, ev[n++] = ek;
    }
    if (n == 0)
        return;
    (*rays)++;
    double tex[3];
    if (!lr__gt_reaches(s, c, l, P, w, e, tex))
        return;
    for (int k = 0; k < n; k++) {
        ev[k] = v3(ev[k].x * tex[0], ev[k].y * tex[1], ev[k].z * tex[2]);
        (*landed)++;
        /* The flux --stats reports, in the film's integer units (the
         * same for any threads or tiles).  A ghost's pixel stays under
         * its source's radiance times the two reflectances, so the sum
         * over a frame stays far inside the 2^23 times the brightest
         * light that an int64 holds at that scale. */
        int64_t q = lr__gt_splat(f, px[k], py[k], ev[k], ur);
        __atomic_fetch_add(&f->ghost_sum, q, __ATOMIC_RELAXED);
    }
}

double lr__gt_flux(const lr__lt *lt, const lr__lt_film *f)
{
    return lt->ghost_main > 0.0
               ? (double)f->ghost_sum / f->scale / lt->ghost_main
               : 0.0;
}
