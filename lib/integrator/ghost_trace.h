/*
 * ghost_trace.h: a real lens's ghosts, traced from the light side (issue
 * 29).  Light that a bright source sends into the lens is reflected at
 * one glass surface j, back at an earlier surface i and reaches the
 * sensor: a ghost (ghost.h; Hullin et al., "Physically-based real-time
 * lens flare rendering", SIGGRAPH 2011).  The camera never traces these
 * paths, so the light side's estimate is the whole of their light and is
 * purely added: no split with the camera to keep consistent, and the
 * main image is the same with ghosts on or off.
 *
 * A ghost light (lr__lt_light with surf LR__LT_GHOST) is an emitter seen
 * directly: a sphere light, a mesh of emitting triangles (either with an
 * emission texture or without), or the environment map's sun
 * (lr__envmap_sun's cone, as light_trace.h's LR__LT_SUN).  It is drawn
 * one of two ways, chosen by the plan (ghost_trace.c: ghost_paths):
 *
 * As meshes (ghost_grid.c, lr__gt_grid), for a source at most
 * LR__GT_DIRS pixels wide whose paths would cost more rays: per ghost
 * path a grid of rays over the lens, each cell's light spread over the
 * pixels it lands on.  Deterministic, converging as the cells shrink.
 *
 * As paths: each draws a lens point and a direction as light_trace.c's
 * paths do (into the sphere's cone; to a point uniform by area on the
 * mesh, density dist^2 / (A cos) at the lens point, the emission
 * one-sided; uniform in the sun's cone, the map's radiance looked up
 * along it), checks that the camera ray along it meets the sphere
 * first, or the mesh's very triangle from its front, or for the sun
 * escapes the scene (the light must reach the front of the lens), and
 * lands that one ray through one ghost path g of the lens (camera.h:
 * ghost_film), drawn with probability p_g: half by the paths' fluxes
 * over the square root of their landing shares on axis (ghost_trace.c:
 * ghost_choice), half uniform (so that a path the on-axis estimate
 * misses, bright off axis, still has 1 / (2 n)).  The pixel under the
 * landing gets L x W_g / (pdf_dir x p_g x N), W_g the ghost's
 * importance: unbiased for the sum over every path.  Same determinism
 * as every light path: a pure function of (light, path index, seed),
 * fixed-point splats.  The environment outside the sun's cone is not a
 * source.
 */
#ifndef LR_GHOST_TRACE_H
#define LR_GHOST_TRACE_H

#include "integrator/light_trace.h"

/* camera.ghosts "auto": a source gets ghosts when its brightest ghost,
 * spread evenly over its area on the film, would add at least this much
 * to a pixel: 1% of display white (1.0), 2.5 of 256 levels of a linear
 * 8-bit image, visible over a dark ground; fainter ghosts are lost under
 * the main image's noise at usual sample counts.  The estimate (the
 * camera's ghost_paths peak times the source's main-image total L Omega
 * k, k from ghost_paths) is on axis, at the reference wavelength and the
 * camera's stop.  L Omega, the radiance times the solid angle the source
 * fills from the eye (the largest channel): a sphere's cone; a mesh's
 * triangles that face the eye and lie ahead of it, each triangle's exact
 * solid angle (ghost_trace.c: mesh_omega); the sun's cone times the
 * map's mean over it (a 64 x 64 midpoint rule), i.e. its irradiance. */
#define LR__GT_AUTO 0.01

/* The ghost lights' paths follow their ghosts' brightness, not the
 * frame's size (ghost_trace.c: ghost_choice, ghost_paths): enough that
 * the ghosts' rms error over the frame's pixels, estimated from the
 * camera's on-axis fluxes, is LR__GT_SIGMA / sqrt(render.spp) of
 * display white (1/512 at 64 spp), each light's share by its ghosts'
 * brightness; LR__GT_UNIFORM of a light's paths are drawn uniformly over
 * the ghost paths.  At least LR__GT_MIN paths a light; all the lights'
 * together at most LR__GT_CAP of the frame's pixels times render.spp
 * (then the ghosts are noisier than LR__GT_SIGMA, the price bounded). */
#define LR__GT_SIGMA (1.0 / 64.0)
#define LR__GT_UNIFORM 0.5
#define LR__GT_MIN 256
#define LR__GT_CAP (1.0 / 8.0)

/* The share of a ghost path's lens points drawn from the whole front
 * disk; the rest from the box where the path lands the light's centre
 * (ghost_trace.c: ghost_guide), which makes up to 1 / LR__GT_DISK times
 * the landings. */
#define LR__GT_DISK 0.1
/* A light's lens points are guided only when its paths are at least this
 * many times the guide's grid of rays (ghost_trace.c: some 11000 through
 * the double Gauss's 55 ghost paths), so that the grid costs at most a
 * fifth of what the paths do (a ray through the lens on the grid costs
 * about what a path that lands costs). */
#define LR__GT_GUIDE 4.0

/* A ghost light is drawn as meshes (ghost_grid.c: a grid of rays over
 * the lens a ghost path, each cell's light spread over where it lands)
 * when it is at most LR__GT_DIRS pixels across as the eye sees it: then
 * n x n directions, n its diameter in pixels rounded up (each direction
 * a sharp copy of every ghost, a pixel apart where the ghost's scale is
 * the main image's).  A larger source (a window, a lamp close by) keeps
 * the paths, whose noise does not grow with its size.  LR__GT_CELLS:
 * the cells across the box a ghost path lands from (ghost_guide);
 * LR__GT_DEPTH: how many times a cell on the ghost's edge splits in
 * four. */
#define LR__GT_DIRS 8
#define LR__GT_CELLS 24
#define LR__GT_DEPTH 1
/* A ghost's cells shrink with its brightness (ghost_trace.c:
 * mesh_sizes): full size from LR__GT_LIT of white on (a quarter of one
 * level of an 8-bit image: a fainter ghost still adds to a brighter
 * one's pixels), at
 * least LR__GT_CELLS_MIN; a ghost takes the light's every direction
 * from LR__GT_EVERY of LR__GT_LIT on.  The guide's grid that finds
 * where each lands on the lens is LR__GT_GUIDE_MESH across.  Chosen on
 * the bare double Gauss's night scene against a mesh of 48 cells and 9
 * directions and against 66 million paths: the least time for a relMSE
 * under 1e-3 against both (docs/lenses.md, "Ghosts drawn as meshes"). */
#define LR__GT_LIT (1.0 / 1024.0)
#define LR__GT_CELLS_MIN 8
#define LR__GT_EVERY 0.1
#define LR__GT_GUIDE_MESH 12
/* For tests of the meshes' convergence: the cells (at most
 * LR__GT_CELLS_MAX), the splits, and the directions' spacing in pixels
 * that ghost_grid.c and the plan use; LR__GT_CELLS, LR__GT_DEPTH and 1
 * unless a test sets them. */
#define LR__GT_CELLS_MAX 256
extern int lr__gt_cells, lr__gt_depth;
extern double lr__gt_dir_px;

/* Adds to *ltp (made when NULL) a ghost light for every untextured
 * sphere or mesh light, and the environment's sun, that camera c's
 * ghosts call for (camera.ghosts), spp camera samples a pixel.  Returns 0
 * when out of memory. */
int lr__gt_plan(const lr_scene *s, const lr__cam *c, int spp, lr__lt **ltp);

/* What --stats reports as ghost_flux: the ghosts' light splatted into f
 * (every channel) over their sources' main images on axis
 * (lt->ghost_main), as `lensray lens --ghosts`'s total_flux is the
 * ghosts' flux over the main image's.  0 without ghost lights. */
double lr__gt_flux(const lr__lt *lt, const lr__lt_film *f);

/* Which ghost path light l's path i (0 .. l->paths - 1) follows, and in
 * *j its place among that ghost path's paths: systematic sampling of the
 * choice (l's cdf) at (i + u) / paths, u in [0, 1) the light's own
 * offset, so that every ghost path takes its share of the paths to
 * within one, in one run of indices, and each path's choice is still
 * ghost path g with probability p_g (u uniform: unbiased).  The caller
 * then draws path i's numbers as sample *j of a sequence of the ghost
 * path's own (a stratified set over its lens points, where drawing the
 * choice at random scattered each ghost path's share over the light's
 * sequence). */
int lr__gt_which(const lr__lt_light *l, double u, uint64_t i, uint32_t *j);

/* One path of ghost light l along ghost path g (lr__gt_which): its lens
 * point from ul (ghost_trace.c: ghost_guide), its direction from ud, the
 * lens point's component (guide box or disk) from uc and its splats'
 * rounding from ur; splats into f, counting rays traced and the ghost
 * rays that landed (up to the lens's ghost paths, times 3 in colour). */
void lr__gt_path(const lr_scene *s, const lr__cam *c, const lr__lt_light *l,
                 int g, const double *ul, const double *ud, double uc,
                 double ur, lr__lt_film *f, uint64_t *rays, uint64_t *landed);

/* Task `task` (0 .. lt->grid_tasks - 1) of the ghost lights drawn as
 * meshes: one light's ghosts (ghost_grid.c), their splats into f; counts scene rays in *rays and the
 * grid's corners that landed in *landed, and its rays through the lens
 * in f->ghost_traced. */
void lr__gt_grid(const lr__lt *lt, const lr_scene *s, const lr__cam *c,
                 uint64_t task, lr__lt_film *f, uint64_t *rays,
                 uint64_t *landed);

/* ---- shared by ghost_trace.c and ghost_grid.c ---------------------------- */

/* The box of lens offsets {x0, y0, x1, y1} where ghost light l's path g
 * lands in the frame, found by the guide's grid (x0 >= x1: none, or no
 * guide); then [5] its mesh's cells across and [6] 1 when the mesh takes
 * every direction of the light, 0 its centre alone (a light drawn as
 * meshes). */
const double *lr__gt_box(const lr__lt_light *l, int g);

/* Ghost light l's direction from lens point P, drawn from ud, into *w,
 * with its radiance over its solid-angle density and, for a mesh, the
 * triangle drawn (*e).  0: no light that way. */
double lr__gt_dir(const lr_scene *s, const lr__lt_light *l, lr__v3 P,
                  const double *ud, lr__v3 *w, const lr__emitter **e);

/* Whether the light along w from lens point P reaches the front of the
 * lens, and in k a textured light's radiance there over l->L (else 1). */
int lr__gt_reaches(const lr_scene *s, const lr__cam *c, const lr__lt_light *l,
                   lr__v3 P, lr__v3 w, const lr__emitter *e, double k[3]);

/* Adds v (>= 0) to pixel (ix, iy) of f if the region holds it, rounded
 * down or up by u (uniform in [0, 1): unbiased); returns the units. */
int64_t lr__gt_splat(lr__lt_film *f, int ix, int iy, lr__v3 v, double u);

/* Adds w times the coverage right of the segment (x0, y0)-(x1, y1) to
 * the rows [0, H) of the buffer a (stride S >= W + 2, columns [0, W]),
 * in differences along each row: summed along the rows after a closed
 * polygon's every edge, each pixel holds w times the area of it the
 * polygon covers (signed by the polygon's orientation; ghost_film.c,
 * for gg_flush). */
void lr__gt_acc_edge(double *a, int S, int W, int H, double x0, double y0,
                     double x1, double y1, double w);

#endif
