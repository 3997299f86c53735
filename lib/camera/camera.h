/*
 * camera.h: the camera-model interface.  A camera turns a film position, a
 * lens sample and a focus power into a ray; it knows nothing of how pixels
 * are stored (it sees continuous film coordinates) and nothing of samplers
 * (it is handed numbers).
 *
 * Each model is one file (camera_pinhole.c, camera_thinlens.c,
 * camera_bracket.c) that fills one lr__camera_model table, listed in
 * camera.c's registry by its JSON name.  Nothing outside those files asks
 * which model a camera is: the render loop, the planner, autofocus, the
 * packet path and the JSON loader go through the table, and an unknown
 * model is an error.
 *
 * The three models so far share one form (the "offset lens", drawn in
 * camera.c for 1 and 16 rays).  Let D be the chief ray through the film
 * point from the eye e, scaled to unit length along the view axis.  A
 * lens offset `off` (in the lens plane spanned by right and up) gives the
 * ray
 *
 *     origin    = base + off
 *     direction = normalise(D - off * w)
 *
 * which passes through the point of D at axial distance 1/w from `base`'s
 * plane: the focal point.  The thin lens has base = e and w = 1 /
 * focus_distance (Kolb, Mitchell & Hanrahan 1995; pbrt's
 * PerspectiveCamera).  The bracket has base = the pixel's point on the
 * image plane, X = e + D di, and w = 1 / f, so its rays pass through the
 * paper's focal point p = e + (di + f) dp / di d (Lee 2007, Kuang & Lee
 * 2018).  The pinhole has no lens.  Chromatic aberration changes only w,
 * per channel or per wavelength; w may be 0 (focus at infinity) or
 * negative.
 */
#ifndef LR_CAMERA_H
#define LR_CAMERA_H

#include "util/internal.h"
#include "optics/ghost.h"
#include "optics/lens_load.h"
#include "optics/prescription.h"
#include "optics/transmit.h"
#include "util/vec.h"
#include "sampling/wavelength.h"

#include <embree3/rtcore.h>
#include <math.h>

typedef struct lr__cam lr__cam;

/* One key of the scene format's "camera" object: read by camera_json.c
 * into the lr_camera field at `offset`, and written back by it, by type.
 * The keys every camera takes are camera_json.c's; each model lists its
 * own in its table below.  A model registered after "lens" keeps its
 * parameters out of lr_camera's named fields: its keys are LR__KEY_PARAM,
 * numbers in its own block of lr_camera.model_params (lr__camera_param). */
typedef enum lr__key_type {
    LR__KEY_NUMBER, /* double */
    LR__KEY_INT,    /* int: a whole number in [min, max] */
    LR__KEY_VEC3,   /* double[3] */
    LR__KEY_ENUM,   /* an enum (int): one of `names`, stored as its index */
    LR__KEY_CUSTOM, /* read and written by camera_json.c's own code */
    LR__KEY_PARAM   /* double: the `offset`-th number of the model's block,
                       `def` by default, in [min, max] */
} lr__key_type;

typedef struct lr__camera_key {
    const char *name;
    lr__key_type type;
    size_t offset;            /* of the field in lr_camera */
    const char *const *names; /* LR__KEY_ENUM: indexed by value, NULL-ended */
    long long min, max;       /* LR__KEY_INT, LR__KEY_PARAM */
    double def;               /* LR__KEY_PARAM: the default */
} lr__camera_key;

/* The planner's view of a camera: a thin lens of radius R at the eye
 * (R: the aperture's farthest point from its axis), such that a ray of
 * focus power w through any film point strays from the pinhole ray, at
 * depth Z along the view axis, by at most R |1/Z - w| on the image plane
 * at distance 1.  Its circle of confusion at depth Z is then at most
 * 2 R |1/Z - w| pixels x fpx, the bound plan.c works from over a depth
 * range (at most three powers: the reference and the colours' extremes). */
typedef struct lr__lens_bound {
    double R;
    int n_w;      /* 1, or 3 when the colours focus apart */
    double ws[3]; /* focus powers at the eye: reference first */
} lr__lens_bound;

/* One camera model.  Every function receives a camera that passed
 * lr_camera_validate. */
/* A ghost path's estimate on axis (camera_model.ghost_paths): its flux
 * over the main image's, its area on the film in pixels (at least 1),
 * and the share of the rays entering the front of the lens that land
 * on the film through it. */
typedef struct lr__ghost_est {
    double flux, px, land;
} lr__ghost_est;

typedef struct lr__camera_model {
    const char *name; /* in JSON: "camera": {"model": name} */
    /* The model's own keys of the camera object, ending with a NULL name;
     * every model's keys are accepted whatever the model (so that --set
     * camera.model=... works on any scene), and written back only for
     * the model in use. */
    const lr__camera_key *keys;
    /* 1 when the model reads camera.focus_on and camera.chromatic (it has
     * a lens to focus and colours to split). */
    int lens;
    /* Checks the model's own fields of `cam`.  It runs for every model
     * whatever cam->model says (`active` = 0 then), so that a bad value
     * never waits silently for the day someone switches models; checks
     * that matter only when the model is in use look at `active`. */
    lr_status (*validate)(const lr_camera *cam, int active, lr_error *err);
    /* Fills the model's part of `c` (lr__cam_init has set the frame):
     * has_lens, radius, shape, ..., w, and the chromatic focus line
     * w(n) = w_base + w_slope scale(n). */
    void (*setup)(lr__cam *c, const lr_camera *cam);
    /* The ray through film point (fx, fy), lens sample u in [0, 1)^2, for
     * light of focus power w (the offset-lens models) and wavelength nm
     * (models that trace glass); unit direction.  Without a lens, the
     * pinhole ray.  Returns the ray's weight: 1 for the offset-lens
     * models; for a real lens, the radiometric weight of the sample
     * (0: the lens blocked it; the ray is then harmless but meaningless). */
    double (*ray)(const lr__cam *c, double fx, double fy, const double u[2],
                  double w, double nm, lr__v3 *org, lr__v3 *dir);
    /* `ray` for 1 <= n <= 16 samples, sample i at power w[i] and wavelength
     * nm[i]: the same rays and weights, bit for bit, as n calls of `ray`
     * (a real lens traces their glass in vectors); NULL: `ray` one by one
     * (lr__cam_lens_rays). */
    void (*rays_n)(const lr__cam *c, int n, const double *fx, const double *fy,
                   const double (*u)[2], const double *w, const double *nm,
                   lr__v3 *org, lr__v3 *dir, double *wt);
    /* Camera rays for lanes 0..n-1 of a packet (all 16 lanes are written;
     * those from n on are copies nobody traces), in float, at focus power
     * c->w and wavelength c->nm_ref; through the lens only if use_lens.
     * Models whose rays have weights (c->weighted) write them to wt[];
     * the others leave wt alone. */
    void (*rays16)(const lr__cam *c, int use_lens, int n, const float *fx,
                   const float *fy, const float *lu, const float *lv,
                   struct RTCRayHit16 *rh, float *wt);
    /* rays16 for np packets at once (np <= 4), packet p's lanes
     * 0..ns[p]-1 from row p of each array; the same rays as np calls of
     * rays16.  NULL for models whose packets gain nothing from company
     * (a real lens's glass is a long chain a packet: camera_lens.c). */
    void (*rays16_n)(const lr__cam *c, int use_lens, int np, const int *ns,
                     const float (*fx)[16], const float (*fy)[16],
                     const float (*lu)[16], const float (*lv)[16],
                     struct RTCRayHit16 *rh, float (*wt)[16]);
    /* Where the plan traces one ray at c->nm_ref for every colour (a
     * packet block of a camera with colours, rgb or spectral): per channel,
     * the factor on each of lanes 0..n-1's weights that gives that
     * channel's share of the light (a real lens's glass and coating
     * pass each its own: lens_blur.c's shares); NULL for models whose
     * channels share one weight. */
    void (*colour_w16)(const lr__cam *c, int n, const float *fx,
                       const float *fy, float (*k)[16]);
    /* Spectral mode: rays16 through the lens with a focus power of each
     * lane's own, w[i] (lanes at different wavelengths); NULL when the
     * model has none, and its spectral samples take `ray` one by one. */
    void (*rays16_w)(const lr__cam *c, int n, const float *fx, const float *fy,
                     const float *lu, const float *lv, const float *w,
                     struct RTCRayHit16 *rh, float *wt);
    /* Spectral splatting (splat.c): for lanes 0..n-1's lens samples, the
     * film shift (sx[i], sy[i]) in pixels per unit of focus power such
     * that the ray at power c->w + t through film point (fx + t sx,
     * fy + t sy) is the ray at power c->w through (fx, fy): a change of
     * focus is a film shift proportional to the lens point.  NULL when
     * the model has no such shift (the bracket, whose lens point moves
     * with the power, and the real lens): its spectral samples are traced
     * pixel by pixel. */
    void (*shift16)(const lr__cam *c, int n, const float *lu, const float *lv,
                    float *sx, float *sy);
    /* The chief ray through film point (fx, fy), for depth, autofocus and
     * the planner; NULL: the frame's pinhole ray (lr__cam_ray). */
    void (*chief)(const lr__cam *c, double fx, double fy, lr__v3 *org,
                  lr__v3 *dir);
    /* Autofocus: sets the model's focus so that depth `z` (along the view
     * axis from the eye) is sharp, or says why it cannot.  NULL: the model
     * has no focus (camera.focus_on is then ignored). */
    lr_status (*focus_at)(lr_camera *cam, double z, lr_error *err);
    /* The planner's bound (see lr__lens_bound), for a camera with a lens;
     * NULL when the model has no safe bound: the lens is then sampled
     * everywhere. */
    void (*bound)(const lr__cam *c, lr__lens_bound *b);
    /* The light side (light_trace.c): the camera seen from the scene.
     * `lens_point` is the point of the aperture that lens sample u gives
     * the camera's own rays (uniform by area over the aperture: so the
     * light side's density of it is the camera's), with its lens-plane
     * offset (ox, oy) (scene units along right and up).  `film` is where
     * on the film (fx, fy, in pixels) the camera ray leaving lens offset
     * (ox, oy) along unit direction d starts, and returns the ray's
     * importance per unit solid angle, over lens_point's density relative
     * to the camera's own lens measure: radiance L along d adds L x that
     * per unit solid angle to the pixel (fpx^2 / cos^3 for the offset
     * lens, camera.c; for the real lens, camera_lens.c); 0 when no camera
     * ray goes along d.  NULL: the model has no light side, and its
     * lights are all traced from the camera.  (For the real lens the
     * offset is in the lens's own frame, mm; the bracket's lens point is
     * where all its rays of one square offset cross, behind their start
     * on the image plane: film_near.) */
    lr__v3 (*lens_point)(const lr__cam *c, const double u[2], double *ox,
                         double *oy);
    double (*film)(const lr__cam *c, double ox, double oy, lr__v3 d, double *fx,
                   double *fy);
    /* In rgb mode with colours that focus apart: `film` for channel k
     * (0 red, 1 green, 2 blue) at its own focus.  NULL: such a camera's
     * lights stay with the camera (the bracket, whose lens point moves
     * with the focus). */
    double (*film_rgb)(const lr__cam *c, int k, double ox, double oy, lr__v3 d,
                       double *fx, double *fy);
    /* In spectral mode with colours that focus apart: `film` for light of
     * wavelength nm (nm), whose focus power is w (the camera's rays at nm
     * take both: lr__cam_lens_ray).  NULL: such a camera's lights stay
     * with the camera. */
    double (*film_wl)(const lr__cam *c, double w, double nm, double ox,
                      double oy, lr__v3 d, double *fx, double *fy);
    /* For a model whose lens point moves with the focus power (the
     * bracket's, e + (1 + di w) off): lens_point for light whose focus
     * power is w.  Its colours are then traced one by one from their own
     * lens points (lr__cam_colour_point).  NULL: lens_point serves every
     * colour. */
    lr__v3 (*lens_point_w)(const lr__cam *c, double w, const double u[2],
                           double *ox, double *oy);
    /* For a model whose rays start past their lens point (the bracket's
     * start on its image plane): how far along unit d from the lens
     * point the camera ray starts.  NULL: at the lens point. */
    double (*film_near)(const lr__cam *c, lr__v3 d);
    /* For a model with a light side but no planner's bound (the real
     * lens): a thin lens at the eye that estimates the size of a light's
     * disc (light_trace_plan.c's choice of lights, not a bound). */
    void (*thin_equiv)(const lr__cam *c, lr__lens_bound *b);
    /* Whether the light side may run for this camera (its lens points
     * cover every ray the camera can take); NULL: whenever lens_point
     * and film are there. */
    int (*light_ok)(const lr__cam *c);
    /* Ghosts (issue 29, ghost_trace.c): light reflected twice inside the
     * lens.  `ghost_paths` is how many ghost paths the camera's lens has
     * (camera.ghosts false or no lens: 0), and sets *peak (true:
     * infinity, every source passes; "auto":) to the largest
     * over them of the ghost's mean film value per unit of the main
     * image's total (lr__ghost_fluxes' flux on axis over its area in
     * pixels), *k to the main image's total on axis per unit of
     * radiance and of the source's solid angle (in pixels of display
     * white, 0 when it could not be estimated), and est[g] (room for
     * LR__RX_MAX_SURFACES^2 / 2) to what it estimates of each path on
     * axis (all 0 when it could not);
     * `ghost_film` is `film` for light that follows path g
     * (0 .. ghost_paths - 1) instead of the main path, at the reference
     * wavelength (k = -1) or rgb channel k's (0 red, 1 green, 2 blue):
     * where it lands and its importance, 0 when it is lost (rel NULL:
     * also when it lands outside the frame; else past the apertures too,
     * *rel as lr__ghost_trace_rel sets it, for a mesh's corners,
     * ghost_grid.c).  NULL: the model has no ghosts.  ghost_paths returns -1 when out of memory. */
    /* A real lens's planner's bound (lens_blur.c: the spot and the
     * colours' spread over a film region and a depth range, from traced
     * bundles), made on first use and shared; NULL when the model has
     * none (then `bound`, or none at all) or it cannot be made. */
    const struct lr__lens_blur *(*blur)(const lr__cam *c);
    int (*ghost_paths)(const lr__cam *c, double *peak, double *k,
                       lr__ghost_est *est);
    double (*ghost_film)(const lr__cam *c, int g, int k, double ox, double oy,
                         lr__v3 d, double *rel, double *fx, double *fy);
    /* ghost_film for n <= LR__GHOST_LANES lens offsets (ox[l], oy[l]) and
     * directions w[l] at once, through one path g at one wavelength k:
     * W[l] its value, and fx[l], fy[l], rel[l] as ghost_film sets them,
     * bit for bit (a mesh's rows of corners, a guide's grid).  NULL
     * with ghost_film. */
    void (*ghost_film_n)(const lr__cam *c, int g, int k, int n,
                         const double *ox, const double *oy, const lr__v3 *w,
                         double *rel, double *fx, double *fy, double *W);
    /* The disk lens_point draws on (its radius, in the units of its
     * offsets), and the point lens_point gives for offset (ox, oy) on
     * it: for ghost paths that draw their own lens points
     * (ghost_trace.c).  NULL with ghost_film. */
    double (*ghost_disk)(const lr__cam *c);
    lr__v3 (*lens_at)(const lr__cam *c, double ox, double oy);
} lr__camera_model;

/* The registry (camera.c, one line a model): the model called `name`,
 * or the one whose id (its value of lr_camera.model: its place in the
 * registry) is `id`; NULL when there is none. */
const lr__camera_model *lr__camera_model_named(const char *name);
const lr__camera_model *lr__camera_model_of(lr_camera_model id);
lr_camera_model lr__camera_model_id(const lr__camera_model *m);
/* The models, in registry order, ending with NULL: for listing names in
 * error messages and docs. */
extern const lr__camera_model *const lr__camera_models[];

/* Where model m's LR__KEY_PARAM keys live: its block starts at this
 * index of lr_camera.model_params (the models before it in the registry
 * hold the ones before; every model's block fits: test_camera_registry),
 * and key k's value is lr__camera_param(cam, m, k). */
int lr__camera_param_base(const lr__camera_model *m);
double lr__camera_param(const lr_camera *cam, const lr__camera_model *m,
                        const lr__camera_key *k);

/* A real lens prepared for one film (camera_lens.c): where the sensor
 * sits, the stop's scale, the indices at the fixed wavelengths, and the
 * exit-pupil bounds at LR__PUPIL_N + 1 film radii from 0 to the corner. */
typedef struct lr__lens_cam {
    const struct lr_lens *L;
    double mm;                         /* scene units per millimetre */
    double sensor_w, sensor_h;         /* mm */
    double z_sensor, z_rear;           /* lens coordinates (prescription.h) */
    double stop_scale;                 /* f_number's scale of the stop */
    double nm_rgb[3];                  /* rgb mode: the channels' wavelengths */
    double n_ref[LR__RX_MAX_SURFACES]; /* indices at c->nm_ref */
    double n_rgb[3][LR__RX_MAX_SURFACES]; /* and at nm_rgb */
    double pupil_rmax; /* film radius of the table's last entry */
    /* Film radius past which no ray passes: where the sensor dwarfs the
     * image circle, the table is drawn over the circle alone (setup in
     * camera_lens.c) and the film beyond is stopped; INFINITY else. */
    double r_cut;
    lr__pupil pupil[LR__PUPIL_N + 1];
    /* Per interval k, what lr__lens_pupil_at adds to the larger of its
     * two entries' sizes (lens_pupil.c's pupil_growth); cx unused. */
    lr__pupil pupil_grow[LR__PUPIL_N];
    /* Per interval k of film radii, the bounds pupil_at gives there
     * (camera_lens.c), in float for the packet path: the centre at the
     * interval's start and its change across it, radius, half sides. */
    float band_cx[LR__PUPIL_N], band_dcx[LR__PUPIL_N];
    float band_rad[LR__PUPIL_N], band_hx[LR__PUPIL_N], band_hy[LR__PUPIL_N];
    double inv_E0; /* 1 / the on-axis irradiance integral */
    /* Every crossing's 1 - R (transmit.h): the camera key's coating
     * (NULL: the prescription's), and the tables at nm_ref and, in rgb
     * mode with colours (t_rgb_ok), at nm_rgb. */
    const lr__coating *coat;
    /* camera.ghosts (lr_ghosts), and the lens's ghost paths (ghost.h:
     * {j, i} pairs, at most LR__RX_MAX_SURFACES^2 / 2). */
    int ghosts, n_ghost;
    int t_rgb_ok;
    lr__ttab t_ref, t_rgb[3];
    /* Ghosts in rgb and spectral mode (ghosts not false): the indices at
     * nm_rgb without chromatic.amplify (a ghost follows the glass's own
     * dispersion) and their tables. */
    double g_n[3][LR__RX_MAX_SURFACES];
    lr__ttab g_tab[3];
    /* The planner's blur table once a plan has asked for it
     * (lr__lens_blur_get; read and written atomically): where the plan
     * skips the lens, the packet rays are chief rays weighted by its
     * mean weight of the pupil. */
    const struct lr__lens_blur *blur;
} lr__lens_cam;

/* A camera prepared for one film: the frame every model shares, then the
 * model's own part. */
#define LR__CAM_OWN 16

struct lr__cam {
    const lr__camera_model *model;
    lr__v3 origin;
    lr__v3 forward, right, up; /* unit, right-handed */
    double half_h;             /* tan(fov/2): image plane half height at 1 */
    double half_w;             /* half_h * width / height */
    double width, height;      /* film size in pixels (the full frame) */

    /* The offset-lens form (see above). */
    int has_lens;  /* 0: pinhole rays, whatever the model */
    double radius; /* lens radius; bracket half side */
    lr_aperture_shape shape;
    int blades;
    double rotation; /* radians */
    double ratio;
    double base_di; /* rays start at e + D base_di (bracket) */
    /* The frame and lens above rounded to float, for the packet rays
     * (lr__offset_lens_rays16): made once by lr__cam_init, not per
     * packet (two divisions and sixteen conversions a call). */
    struct {
        float sw, sh, hw, hh; /* 2 / width, 2 / height, half_w, half_h */
        float fw[3], rt[3], up[3], e[3];
        float rad, w, di;
    } f16;

    double w; /* focus power without aberration */
    /* Chromatic aberration: power as a function of the index n is
     * w(n) = w_base + w_slope * power_scale(n), see lr__cam_power_at. */
    lr_chromatic chroma;
    double n_ref; /* reference index (green, or n_d) */
    double w_base, w_slope;
    double w_rgb[3];   /* rgb mode: per channel */
    int chroma_active; /* 0 when every channel focuses alike */

    int chroma_fixed;  /* 1: setup has set chroma_active itself
                                  (colours from glass, not a focus line) */
    double nm_ref;     /* the wavelength traced without colours */
    int weighted;      /* 1: rays carry weights (a real lens) */
    lr__lens_cam lens; /* the "lens" model's part */
    /* The state of a model registered after "lens", laid out by its
     * setup (its own file), which nothing else reads. */
    double own[LR__CAM_OWN];
};

/* ---- the real lens's blur bound (lens_blur.c) ----------------------- */

/* A table per lens, focus, f-number and colour set (docs/plan-lens.md):
 * over the film radii of the exit-pupil table and a grid of inverse
 * depths, how far every traced ray of the pupil (every colour the camera
 * traces) lands from the reference colour's chief ray, and how far each
 * colour's ray lands from the reference colour's ray through the same
 * pupil point, both on the film in mm, radial and tangential apart. */
typedef struct lr__lens_blur lr__lens_blur;

/* The table for real-lens camera c, made now or found in its lens's
 * cache, and left in c->lens.blur; NULL when out of memory or the cache
 * is full (the plan then samples the lens everywhere). */
const lr__lens_blur *lr__lens_blur_get(const lr__cam *c);

/* Whether a block over the film rectangle [fx0, fx1] x [fy0, fy1]
 * (pixels) may trace chief rays for the lens at all: the table has a
 * chief ray at every radius it spans and its weight interpolates there
 * (lens_blur.c, weights_hold).  lr__lens_blur_bound checks it too; a
 * block that sees only the background, which no blur changes, needs
 * this alone. */
int lr__lens_blur_chief_ok(const lr__cam *c, const lr__lens_blur *b, double fx0,
                           double fy0, double fx1, double fy1);

/* Over the film rectangle [fx0, fx1] x [fy0, fy1] (pixels) and the depths
 * [z0, z1] from the sensor along the view axis (z1 may be infinite): a
 * bound in pixels on the spot (*spot: how far a sample of the lens, of
 * any colour, lands from the chief ray's point) and on the colours'
 * spread (*colour: how far apart two colours through the same lens
 * point land).  Returns 0 (no bound) when the depths come nearer than
 * the table reaches or a chief ray there is blocked. */
int lr__lens_blur_bound(const lr__cam *c, const lr__lens_blur *b, double fx0,
                        double fy0, double fx1, double fy1, double z0,
                        double z1, double *spot, double *colour);

/* Where the rays of that film rectangle go: at depth Z from the sensor,
 * within Z [u0, u1] x [v0, v1] grown by *R on every side (camera space,
 * scene units: u along right, v along up), uv = {u0, u1, v0, v1}. */
void lr__lens_blur_reach(const lr__cam *c, const lr__lens_blur *b, double fx0,
                         double fy0, double fx1, double fy1, double uv[4],
                         double *R);

/* The chief ray's weight (the pupil's mean sample weight over the chief
 * ray's transmittance), for the packet rays, in interval k of the pupil
 * table's film radii at f in [0, 1] along it. */
float lr__lens_blur_chief_w(const lr__lens_blur *b, int k, float f);
/* Each channel's share of the pupil's mean sample weight, over the
 * reference's (s[3]; 1 without colours: lens_shares.c), at the same
 * place. */
void lr__lens_blur_share(const lr__lens_blur *b, int k, float f, float s[3]);

/* camera_lens.c's indices at wavelength nm (chromatic.amplify applied),
 * for lens_blur.c and the lens model's files. */
void lr__lens_indices(const lr__cam *c, double nm, double *n);

/* Prepares `c` for a width x height film; `cam` must have passed
 * lr_camera_validate and its autofocus must have been resolved. */
void lr__cam_init(lr__cam *c, const lr_camera *cam, int width, int height);

/* The pinhole ray through film point (fx, fy), in pixels from the image's
 * top-left corner (pixel (x, y) covers [x, x+1) x [y, y+1)).  `dir` is
 * unit length.  Every model's chief ray. */
void lr__cam_ray(const lr__cam *c, double fx, double fy, lr__v3 *org,
                 lr__v3 *dir);

/* The model's ray through film point (fx, fy) and lens sample u with
 * focus power w.  Without a lens it is exactly lr__cam_ray. */
static inline double lr__cam_lens_ray(const lr__cam *c, double fx, double fy,
                                      const double u[2], double w, double nm,
                                      lr__v3 *org, lr__v3 *dir)
{
    return c->model->ray(c, fx, fy, u, w, nm, org, dir);
}

/* lr__cam_lens_ray for n <= 16 samples at once (the model's rays_n, or
 * `ray` one by one): the same values. */
static inline void lr__cam_lens_rays(const lr__cam *c, int n, const double *fx,
                                     const double *fy, const double (*u)[2],
                                     const double *w, const double *nm,
                                     lr__v3 *org, lr__v3 *dir, double *wt)
{
    if (c->model->rays_n != NULL) {
        c->model->rays_n(c, n, fx, fy, u, w, nm, org, dir, wt);
        return;
    }
    for (int i = 0; i < n; i++)
        wt[i] = c->model->ray(c, fx[i], fy[i], u[i], w[i], nm[i], &org[i],
                              &dir[i]);
}

/* Focus power for light of wavelength `nm` (spectral mode). */
double lr__cam_power_at(const lr__cam *c, double nm);

/* The planner's bound for `c` (see lr__lens_bound): the model's, with the
 * colours' powers added when chromatic aberration is active. */
void lr__cam_bound(const lr__cam *c, lr__lens_bound *b);

/* ---- the offset-lens form, for the model files ----------------------- */

/* Scalar and 16-wide rays of the offset-lens form: origin
 * e + D base_di + off, direction D - off w (see the top of this file). */
double lr__offset_lens_ray(const lr__cam *c, double fx, double fy,
                           const double u[2], double w, double nm, lr__v3 *org,
                           lr__v3 *dir);
void lr__offset_lens_rays16(const lr__cam *c, int use_lens, int n,
                            const float *fx, const float *fy, const float *lu,
                            const float *lv, struct RTCRayHit16 *rh, float *wt);
void lr__offset_lens_rays16_w(const lr__cam *c, int n, const float *fx,
                              const float *fy, const float *lu, const float *lv,
                              const float *w, struct RTCRayHit16 *rh,
                              float *wt);
/* shift16 of the offset-lens form with base_di = 0 (the thin lens). */
void lr__offset_lens_shift16(const lr__cam *c, int n, const float *lu,
                             const float *lv, float *sx, float *sy);
/* lens_point and film of the offset-lens form with base_di = 0 (the
 * thin lens and the pinhole, whose lens point is the eye). */
lr__v3 lr__offset_lens_point(const lr__cam *c, const double u[2], double *ox,
                             double *oy);
double lr__offset_lens_film(const lr__cam *c, double ox, double oy, lr__v3 d,
                            double *fx, double *fy);
/* lr__offset_lens_film for rgb channel k's focus power (w_rgb[k]). */
double lr__offset_lens_film_rgb(const lr__cam *c, int k, double ox, double oy,
                                lr__v3 d, double *fx, double *fy);
/* lr__offset_lens_film for a lens of focus power w (the bracket's, seen
 * from its lens points, differs from c->w). */
double lr__offset_lens_film_w(const lr__cam *c, double w, double ox, double oy,
                              lr__v3 d, double *fx, double *fy);
/* film_wl of the offset-lens form: lr__offset_lens_film_w at power w (the
 * wavelength acts only through it). */
double lr__offset_lens_film_wl(const lr__cam *c, double w, double nm, double ox,
                               double oy, lr__v3 d, double *fx, double *fy);

/* Where radiance arriving at a lens point along unit d lands on the
 * film (the light side's splat): n places, place j pixel (ix, iy), where
 * radiance L adds L_c W[c] to channel c (times the path's weight).  One
 * place with W the same in every channel; or, with colours that focus
 * apart, in rgb mode one place a channel (W zero in the others), and in
 * spectral mode one place a wavelength (chroma.wavelengths of them) with
 * W[c] the importance times the wavelength's weight w_c / m (may be
 * negative: wavelength.h).  Places that miss the film are left out. */
#define LR__LAND_MAX 64
typedef struct lr__landing {
    int n;
    struct {
        int ix, iy;
        double W[3];
    } at[LR__LAND_MAX];
} lr__landing;

/* Whether the light side can land camera c's colours: one focus for all,
 * rgb mode through a model with film_rgb, or spectral mode through one
 * with film_wl. */
int lr__cam_lands_colours(const lr__cam *c);

/* Fills *ld for the camera ray from lens offset (ox, oy) (lens_point's)
 * along unit d; returns whether anything lands inside the film.  In
 * spectral mode with colours that focus apart, wl is the wavelengths'
 * table (lr__cam_wl_table) and u_wl in [0, 1) places the m wavelengths,
 * one in each of the strata (u_wl + j) / m of the table's sampling space
 * (as spectral.c's camera samples); otherwise both are ignored. */
int lr__cam_land(const lr__cam *c, const lr__wl_table *wl, double u_wl,
                 double ox, double oy, lr__v3 d, lr__landing *ld);

/* Colours traced one by one (a model with lens_point_w and colours that
 * focus apart): how many (3 in rgb mode, chroma.wavelengths in spectral
 * mode); 0 when one lens point serves them all. */
int lr__cam_colours_apart(const lr__cam *c);

/* Colour j of lr__cam_colours_apart's: its lens point for lens sample u
 * (lens_point_w at its power; the wavelength placed as lr__cam_land
 * places wavelength j), and where radiance along d from it lands, that
 * colour alone (lr__cam_land's place j). */
lr__v3 lr__cam_colour_point(const lr__cam *c, const lr__wl_table *wl,
                            double u_wl, int j, const double u[2], double *ox,
                            double *oy);
int lr__cam_land_colour(const lr__cam *c, const lr__wl_table *wl, double u_wl,
                        int j, double ox, double oy, lr__v3 d, lr__landing *ld);

/* The table of spectral mode's wavelengths for camera c (wavelength.h):
 * the density and weights its camera samples and light paths draw
 * wavelengths with. */
void lr__cam_wl_table(const lr__cam *c, lr__wl_table *t);

/* Whether film point (fx, fy), in pixels, lies on c's film (the full
 * frame); NaN does not. */
static inline int lr__cam_on_film(const lr__cam *c, double fx, double fy)
{
    return fx >= 0.0 && fx < c->width && fy >= 0.0 && fy < c->height;
}

/* Where the camera ray from lens point P along unit d starts (the light
 * side traces from there, so that it sees what the camera's ray sees):
 * P, or past it by the model's film_near. */
static inline lr__v3 lr__cam_ray_start(const lr__cam *c, lr__v3 P, lr__v3 d)
{
    if (c->model->film_near == NULL)
        return P;
    return v3_madd(P, d, c->model->film_near(c, d));
}
/* The bound of an offset lens at the eye: R = the aperture's reach. */
void lr__offset_lens_bound(const lr__cam *c, lr__lens_bound *b);

/* The fields of packet lane i that every camera ray shares: from t = 0
 * to infinity, no time, all masks, nothing hit yet. */
static inline void lr__ray16_open(struct RTCRayHit16 *rh, int i)
{
    rh->ray.tnear[i] = 0.0f;
    rh->ray.time[i] = 0.0f;
    rh->ray.tfar[i] = INFINITY;
    rh->ray.mask[i] = 0xFFFFFFFFu;
    rh->ray.id[i] = 0;
    rh->ray.flags[i] = 0;
    rh->hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
}

/* Finite and within +-1e15, the scene format's limit for any number:
 * beyond it Embree is given rays it cannot trace (and aborts). */
#define LR__MAX_COORD 1e15

/* Shared checks for the model files: a length in scene units that must
 * be > 0 (or >= 0 when zero_ok), finite, at most 1e15, and, when it sets
 * a focus (divides), at least 1e-6. */
lr_status lr__cam_check_length(const char *path, double v, int zero_ok,
                               int is_focus, lr_error *err);

#endif
