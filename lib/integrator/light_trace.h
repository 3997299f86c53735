/*
 * light_trace.h: light traced through the lens (issue 27).  A small light
 * far out of focus spreads over a disc of film, yet a camera ray finds it
 * only through the small part of the aperture that looks at it, so the
 * disc stays speckled for thousands of samples.  From the light's side
 * every sample lands: a point on the light, a point on the aperture, and
 * the film point follows from the lens (camera.h's lens_point and film).
 *
 * Lights: spheres and meshes of emitting triangles, their emission
 * textured or not, and the environment map's sun: the cone of directions around
 * its brightest texel that holds its bright texels (lr__envmap_sun), seen
 * as a sphere at infinity.  For the sun the split below is by direction:
 * camera rays that escape within the cone add none of the map's radiance
 * (lr__lt_sun), and a light path is a direction uniform in the cone from
 * a lens point, landing if the camera ray along it escapes.
 *
 * Why the sum is unbiased: the plan picks lights whose image is small
 * against their blur (lr__lt_plan).  For a picked light, the radiance it
 * sends straight into the lens (the camera ray's first hit) is shared
 * between the two sides by multiple importance sampling (Veach 1997,
 * section 9.2): a path of lens point P and direction d counts w_cam(d)
 * of its light where the camera finds it and w_light(d) = 1 - w_cam(d)
 * where the light side does (lr__lt_direct_w and splat_landing), and
 * every other path of that light (on surfaces, in mirrors, through
 * glass) stays the camera's.  Any such pair of weights that sums to 1
 * path by path gives an unbiased sum of two unbiased estimators (Veach's
 * theorem 9.1; light tracing is unbiased by his section 10.2).  The
 * weights are the balance heuristic with his cutoff (integrator.h): the
 * camera's density of d per pixel sample is its importance fpx^2 /
 * cos^3 (lr__offset_lens_film) times spp samples, the light side's its
 * cone's density seen from the eye times the light's paths (from P it
 * differs by the aperture over the distance, which changes only how
 * well, never whether, the weights sum to 1).  The ratio rho of the two
 * is at least about 2 for a picked light and in the hundreds for a far
 * defocused one, where the cutoff gives the light side every path and
 * the camera none: exactly a split, and the same bytes.  In a dark
 * block (plan.h) no camera ray is traced, so the light side's weight is
 * 1 there.  A real lens's camera samples carry weights whose density
 * is not known in closed form: its lights keep the split (the light
 * side takes them all).  Other lights, and every light of a model
 * without a light side, stay with the camera.
 *
 * Sparkles (glints): a small light k (a sphere or a mesh, its emission
 * textured or not) seen in a flat rough metal surface G
 * (a planar triangle mesh whose one lobe is GGX's conductor) behind the
 * focus is a defocused disc too, and the camera's light sample at G
 * finds it only from the few lens points whose mirror direction meets
 * it.  For a pair (G, k) the plan picks, the paths camera -> G -> k
 * (the camera ray's first hit on G, then k straight from there) are the
 * light side's: a point y on k, a lens point P, and a point x of G drawn
 * around the mirror point of P and y (light_trace.c, glint_path).
 * Camera paths whose first hit is on G add none of k's light at G,
 * neither by the light sample nor by the BSDF's ray meeting k (path.c);
 * every other path stays the camera's.  The same disjoint split, so the
 * same argument.  The path integrator only (Whitted's rough lobes are
 * mirrors).
 *
 * Determinism: a light path is a pure function of (light, path index,
 * seed), and splats add as fixed-point integers, whose sum does not
 * depend on the order: any thread count, tile size or region gives the
 * same bytes, and a region keeps exactly the splats that land inside it.
 */
#ifndef LR_LIGHT_TRACE_H
#define LR_LIGHT_TRACE_H

#include "camera/camera.h"
#include "integrator/integrator.h"
#include "integrator/light_paths.h"
#include "sampling/sampler.h"
#include "scene/scene.h"

#include <math.h>
#include <stdint.h>

/* One light traced from its side: a sphere of the scene, or a mesh of
 * emitting triangles. */
typedef struct lr__lt_light {
    /* Index in scene->geoms; for LR__LT_PATHS, its part; for LR__LT_SUN,
     * the number of geometries (its sampler key). */
    int geom;
    /* -1: the light seen directly; LR__LT_PATHS: a part of the `light`
     * integrator's paths (light_paths.h; L is then the film's scale);
     * LR__LT_SUN: the environment's sun seen directly (center its cone's
     * unit axis, area 1 - cos of its half-angle, L the map's largest
     * value: the film's scale); else a glint: the light seen in the flat
     * rough metal geometry surf, whose plane holds plane_p with unit
     * normal plane_n (any side), GGX alpha `alpha`. */
    int surf;
    lr__v3 plane_p, plane_n;
    double alpha;
    lr__v3 center; /* the sphere, or a sphere around the mesh */
    double radius;
    /* A mesh: its triangles are scene->emitters[first_tri ..
     * first_tri + n_tri), drawn by area through cdf (n_tri, owned, the
     * last 1) from a total of `area`; n_tri = 0 for a sphere.  A ghost
     * light: its ghost paths' choice (`ghosts` of them) follows in cdf,
     * from cdf + n_tri (ghost_trace.c). */
    long first_tri;
    size_t n_tri;
    double *cdf;
    double area;
    /* Its radiance; with an emission texture (textured), the largest the
     * texture gives, and each path looks its emission up where it meets
     * the light, as the camera does. */
    lr__v3 L;
    int textured;
    /* Seen directly (surf -1) or the sun: its MIS coefficient kappa
     * (integrator.h's lr__lt_rho); 0: no mix, the light side takes every
     * path. */
    double mis;
    int ghosts; /* LR__LT_GHOST: the lens's ghost paths */
    /* LR__LT_GHOST drawn as meshes (ghost_grid.c): grid x grid
     * directions, all of them task grid_first of the light side's mesh
     * tasks (after its path units); 0: drawn by paths. */
    int grid;
    uint64_t grid_first;
    /* A ghost light: the solid angle it fills from the eye, and its
     * mean radiance there (a textured one's texels' mean). */
    double omega;
    lr__v3 Lmean;
    /* Seen directly through a real lens: the disk of front offsets
     * (centre fp_x, fp_y, radius fp_r, in lens_point's units) whose rays
     * from the light's centre land on the film (light_trace_plan.c), half
     * its lens points drawn there and half over the whole front
     * (light_trace.c); fp_r 0: all over the front. */
    double fp_x, fp_y, fp_r;
    uint64_t paths; /* light paths traced for it */
    uint64_t first; /* index of its first path among all */
} lr__lt_light;

typedef struct lr__lt {
    int n;
    lr__lt_light *lights;
    /* The brightest radiance of the frame's lights, kept when a region
     * drops some (lr__lt_keep), so that the film's fixed-point scale is
     * the whole frame's; 0 until then. */
    double lmax_frame;
    uint64_t paths;      /* all lights' */
    uint64_t grid_tasks; /* ghost lights drawn as meshes, a task each */
    /* Per geometry of the scene, flags: LR__LT_DIRECT where its direct
     * emission is the light side's (camera rays that meet it first add
     * none); LR__LT_GLINT_SURF on a glint surface, LR__LT_GLINT_LIGHT on
     * a light whose glints in those surfaces are the light side's (every
     * such pair is traced). */
    unsigned char *direct;
    /* Per geometry, the MIS coefficient of a light seen directly (its
     * light's mis), 0 elsewhere: owned, the view's. */
    double *mis;
    /* What camera rays leave to this light side (lr__sample_id.lt):
     * direct, mis, and the sun's cone. */
    lr__lt_view view;
    /* With a mixing light (mis > 0): per block of the frame (dark_block
     * pixels square, dark_bw across), 1 where the plan made it dark
     * (plan.h): no camera ray is traced there, so the light side keeps
     * all of its landings there.  Set by the plan; NULL: no block dark.
     * Owned. */
    unsigned char *dark;
    int dark_bw, dark_block;
    uint64_t seed;
    /* The `light` integrator's paths (their parts are the lights with
     * surf LR__LT_PATHS), or NULL.  Owned. */
    lr__lp *lp;
    uint64_t lp_paths; /* all its parts' */
    int ghost_lights;  /* lights with surf LR__LT_GHOST (the last ones) */
    double ghost_main; /* their main images' totals on axis, every channel */
    /* Spectral mode with colours that focus apart: the wavelengths'
     * table (lr__cam_land), owned; else NULL. */
    lr__wl_table *wl;
} lr__lt;

#define LR__LT_PATHS (-2)
#define LR__LT_SUN (-3)
/* A source's ghosts (ghost_trace.h): geom, center, radius and L the
 * sphere's or mesh's (a mesh's cdf its triangles' then its ghost paths',
 * one array), or for the environment's sun geom the number of
 * geometries, center, area and L as LR__LT_SUN's. */
#define LR__LT_GHOST (-4)
/* The most paths of one part (a sampler "pixel" counts its samples in 32
 * bits). */
#define LR__LT_PART ((uint64_t)1 << 31)

/* Light paths a light gets per pixel of its image and camera sample per
 * pixel (render.spp): about spp / 2 splats in each pixel of its disc.
 * Where the camera finds nothing more (the lights' own discs), a light
 * path is cheaper than a camera sample: on scenes/night.json 0.125, 0.25
 * and 0.5 reached relMSE 1e-3 in 0.319, 0.318 and 0.277 CPU s (make
 * bench-bokeh, one run each, 2026-12-04). */
#define LR__LT_DENSITY 0.5

/* The largest share of a pixel's camera samples that may find a light
 * for it to stay with the camera: a light whose camera hit rate over its
 * image is below this goes to the light side. */
#define LR__LT_HIT_RATE 0.25

/* Chooses the lights to trace from the light side for camera `c` and
 * settings `set`: *out is NULL when there are none (render.light off, a
 * model without a light side, colours that focus apart where the model
 * cannot land them: lr__cam_lands_colours, no small light), else the
 * caller's, freed with lr__lt_free.  With the `light` integrator, every
 * path (light_paths.h): LR_ERR_INVALID names what the scene has that it
 * cannot trace.  LR_ERR_NOMEM. */
lr_status lr__lt_plan(const lr_scene *s, const lr__cam *c,
                      const lr_render_settings *set, lr__lt **out,
                      lr_error *err);
void lr__lt_free(lr__lt *lt);

/* The largest camera weight (integrator.h's lr__lt_cam_weight) of a
 * light of MIS coefficient kappa over camera c's frame (at its corners,
 * where cos is smallest): 0 for kappa 0. */
double lr__lt_cam_share_max(const lr__cam *c, double kappa);

/* Keeps the lights k with keep[k] (the plan's: those whose paths can
 * land in the region rendered); the others' direct emission stays the
 * light side's (the region's camera rays cannot meet them anyway).  A
 * light's paths do not depend on which others are kept. */
void lr__lt_keep(lr__lt *lt, const unsigned char *keep);

/* Splats under this many of the film's units go to its fine sum. */
#define LR__LT_FINE 4096.0

/* Adds q units, rounded to the nearest integer (a magnitude of at most
 * 2^80, 2^40 times the scale's light: 2^14 such splats a pixel fit in
 * the 96 bits; NaN adds nothing), to the 96-bit sum hi[k] 2^64 +
 * (uint64_t)lo[k], atomically: the low word's carry (or borrow) goes to
 * the high word.  Integer adds commute, so the sum is the same in any
 * order, whatever the threads (a float sum would not be). */
static inline void lr__lt_film_add(int64_t *lo, int32_t *hi, size_t k, double q)
{
    const double lim = 0x1p80;
    if (!(q == q))
        return;
    q = q < -lim ? -lim : q < lim ? q : lim;
    int64_t h = 0;
    uint64_t l;
    if (q > -0x1p63 && q < 0x1p63) {
        int64_t qi = (int64_t)llrint(q);
        l = (uint64_t)qi;
        h = qi < 0 ? -1 : 0;
    } else {
        /* floor(q / 2^64) and the rest, both exact in double. */
        double fh = floor(q * 0x1p-64);
        h = (int64_t)fh;
        l = (uint64_t)(q - fh * 0x1p64);
    }
    uint64_t old = __atomic_fetch_add((uint64_t *)&lo[k], l, __ATOMIC_RELAXED);
    h += old + l < old; /* the carry */
    if (h != 0)
        __atomic_fetch_add(&hi[k], (int32_t)h, __ATOMIC_RELAXED);
}

/* The sum hi 2^64 + (uint64_t)lo as a double, correctly rounded. */
static inline double lr__lt_film_value(int64_t lo, int32_t hi)
{
    /* (A multiplication: shifting a negative value is undefined.) */
    return (double)((__int128)hi * ((__int128)1 << 64) +
                    (__int128)(uint64_t)lo);
}

/* The light pass's film: fixed-point sums over region [x0, x1) x [y0, y1)
 * of the frame. */
typedef struct lr__lt_film {
    int x0, y0, x1, y1;
    /* 3 per pixel, in units of 1 / scale: each the 96-bit integer
     * sum_hi 2^64 + (uint64_t)sum (lr__lt_film_add), so that no pixel's
     * sum wraps or is clipped however bright it is against the scale's
     * light (a lamp 0.5 m over a 20 km ground: the light's radiance
     * estimate I / R^2 over the scene was 4e8 times too low, splats
     * were clipped at 2^52 units and the sums wrapped negative). */
    int64_t *sum;
    int32_t *sum_hi;
    /* The splats under LR__LT_FINE units, 3 per pixel, in units of
     * 2^-24 / scale, as wide: a dim light's splats beside a light 1e8
     * times brighter round to 0 in sum's units. */
    int64_t *fine;
    int32_t *fine_hi;
    double scale;
    const unsigned char *dark; /* the light side's (lr__lt.dark) */
    int dark_bw, dark_block;
    /* The ghosts' splats inside the region, every channel, in the same
     * units (ghost_trace.c; --stats ghost_flux). */
    int64_t ghost_sum;
    /* Rays the ghosts' meshes traced through the lens (ghost_grid.c;
     * --stats ghost_paths). */
    uint64_t ghost_traced;
    /* Set when a ghost mesh's scratch could not be had: the render
     * fails as out of memory rather than lose its light. */
    int nomem;
} lr__lt_film;

lr_status lr__lt_film_init(lr__lt_film *f, const lr__lt *lt, int x0, int y0,
                           int x1, int y1, lr_error *err);
void lr__lt_film_free(lr__lt_film *f);

/* Paths per unit of work (render.c hands units to its threads): units of
 * paths, then one a ghost mesh task (lr__gt_grid). */
#define LR__LT_CHUNK 4096
uint64_t lr__lt_units(const lr__lt *lt);

/* An empty light side for scene s (room for a light a geometry and the
 * sun); NULL when out of memory. */
lr__lt *lr__lt_new(const lr_scene *s);

/* Whether geometry g is a light the light side can trace, a sphere or a
 * mesh of emitting triangles, and the sphere that bounds it. */
int lr__lt_light_sphere(const lr_scene *s, const lr__geom *g, lr__v3 *center,
                        double *radius);
/* Mesh light l's triangles (those of geometry g) and their cumulative
 * areas into l (first_tri, n_tri, cdf, area); 0 when out of memory. */
int lr__lt_mesh_cdf(const lr_scene *s, const lr__geom *g, lr__lt_light *l);

/* Light l's radiance l->L from material m, and l->textured: with an
 * emission texture, the largest the texture gives (each path then looks
 * its own up where it meets the light: lr__lt_emission_at). */
void lr__lt_light_emission(const lr__material *m, lr__lt_light *l);

/* Light l's footprint on a real lens's front, where half its paths
 * start (fp_x, fp_y, fp_r above; light_footprint.c): fp_r is left 0 for
 * other cameras, and where no small disk holds the rays that land.
 * Returns 0 when out of memory. */
int lr__lt_footprint(const lr__cam *c, lr__lt_light *l);

/* Light l's emission where a path meets it (h): l->L, or for a textured
 * light the texture looked up there, as the camera's hit does
 * (lr__hit_material). */
lr__v3 lr__lt_emission_at(const lr_scene *s, const lr__lt_light *l,
                          const lr__hit *h);
/* A point y uniform by area over mesh light l (density 1 / l->area) from
 * (u0, u1): its triangle by area through l->cdf, u0 rescaled reused for
 * the point (the usual trick for one more dimension).  Returns the
 * triangle. */
const lr__emitter *lr__lt_mesh_point(const lr_scene *s, const lr__lt_light *l,
                                     const double *u, lr__v3 *y);

/* Adds v to pixel (ix, iy) of f, if the region holds it (v may be
 * negative in spectral mode, whose weights are: wavelength.h). */
void lr__lt_splat(lr__lt_film *f, int ix, int iy, lr__v3 v);

/* A direction uniform in the cone about unit a whose half-angle has 1 -
 * cos = omc, from u (pbrt-v4's SampleUniformCone, with 1 - cos theta
 * drawn directly, without cancellation for tiny cones); density 1 /
 * (2 pi omc). */
lr__v3 lr__lt_in_cone(lr__v3 a, double omc, const double u[2]);

/* Traces unit u's light paths and adds their splats to f (from any
 * thread at once).  Counts the rays traced in *rays, the paths that
 * reached the film in *landed, and ghost rays that did in *ghosts. */
void lr__lt_unit(const lr__lt *lt, const lr_scene *s, const lr__cam *c,
                 uint64_t u, lr__lt_film *f, uint64_t *rays, uint64_t *landed,
                 uint64_t *ghosts);

/* Adds the light pass's pixels to the camera's: rgb is the region's
 * image, 3 floats a pixel. */
void lr__lt_film_resolve(const lr__lt_film *f, float *rgb);

#endif
