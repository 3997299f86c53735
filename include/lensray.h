/*
 * lensray.h: the whole public API of liblensray.
 *
 * liblensray renders JSON scenes with Intel Embree 3 and writes the result
 * as OpenEXR or PNG.  The flow is:
 *
 *     lr_scene_load_file()  -> lr_scene       (immutable, shareable)
 *     lr_scene_camera()     -> lr_camera      (plain struct, yours to edit)
 *     lr_scene_settings()   -> lr_render_settings
 *     lr_render()           -> lr_image       (+ lr_render_stats)
 *     lr_image_write()      -> file, or lr_image_encode() -> memory
 *
 * Conventions that hold for every function here:
 *   - Functions that can fail return an lr_status (LR_OK == 0, errors are
 *     negative) and, when the caller passes a non-NULL lr_error, fill it
 *     with a sentence and, for input errors, the JSON path of the field.
 *   - Whoever allocates frees, through the matching lr_*_free function;
 *     every lr_*_free(NULL) is a harmless no-op.
 *   - A loaded lr_scene is read-only: any number of threads may render
 *     from one scene at once, with different cameras and settings.
 *   - Rendering is deterministic: the same scene, camera and settings give
 *     the same bytes for any thread count and tile size.
 */
#ifndef LENSRAY_H
#define LENSRAY_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Marks the exported functions; everything else in the library is hidden. */
#if defined(__GNUC__)
#define LR_API __attribute__((visibility("default")))
#else
#define LR_API
#endif

#define LR_VERSION_MAJOR 0
#define LR_VERSION_MINOR 1
#define LR_VERSION_PATCH 0

/* The library's version as "MAJOR.MINOR.PATCH"; a static string. */
LR_API const char *lr_version(void);

/* ------------------------------------------------------------------------
 * Errors
 * ---------------------------------------------------------------------- */

typedef enum lr_status {
    LR_OK = 0,
    LR_ERR_INVALID = -1,   /* bad input: JSON, scene value, OBJ, argument */
    LR_ERR_IO = -2,        /* a file could not be read or written */
    LR_ERR_NOMEM = -3,     /* an allocation failed */
    LR_ERR_EMBREE = -4,    /* Embree reported an error */
    LR_ERR_CANCELLED = -5, /* the render was cancelled via its flag */
    LR_ERR_LIMIT = -6,     /* a size limit was exceeded */
    LR_ERR_SYNTAX = -7     /* text that is not JSON at all (only
                              lr_job_parse tells this from LR_ERR_INVALID) */
} lr_status;

/* Filled by failing calls.  `path` is the JSON path of the offending field
 * ("objects[3].radius") or "" when the error is not about one field;
 * `message` is a whole sentence that already includes the path. */
typedef struct lr_error {
    lr_status status;
    char path[256];
    char message[768];
} lr_error;

/* A short static name for a status, e.g. "invalid" or "io". */
LR_API const char *lr_status_name(lr_status status);

/* ------------------------------------------------------------------------
 * Camera
 * ---------------------------------------------------------------------- */

typedef enum lr_camera_model {
    LR_CAMERA_PINHOLE = 0,  /* ideal pinhole: everything sharp */
    LR_CAMERA_THINLENS = 1, /* physical thin lens (pbrt, Mitsuba, Blender) */
    LR_CAMERA_BRACKET = 2,  /* the paper's square "bracket" method */
    LR_CAMERA_LENS = 3      /* a real lens, traced surface by surface */
    /* Values from 4 on are the models registered after these, in the
     * registry's order (4: "orthographic"); they have no name here, so
     * that adding a model changes nothing in this header.  Choose any
     * model by name: lr_camera_apply_json(cam, "{\"model\": ...}"). */
} lr_camera_model;

/* Room in lr_camera for the parameters of the models registered after
 * LR_CAMERA_LENS (lr_camera.model_params). */
#define LR_CAMERA_MODEL_PARAMS 32

/* A real lens prescription, loaded by lr_lens_load (or by a scene whose
 * camera names one).  Loaded lenses are immutable, shared and never
 * freed: they live as long as the process (one per distinct name and
 * prescription: "double-gauss-50", "double-gauss-50.json" and its
 * absolute path are three; at most LR_MAX_LENSES, past which loading a
 * new one is LR_ERR_LIMIT), so an lr_camera that points to one can be
 * copied freely. */
typedef struct lr_lens lr_lens;
#define LR_MAX_LENSES 256

typedef enum lr_aperture_shape {
    LR_APERTURE_DISK = 0,   /* circle of radius aperture_radius */
    LR_APERTURE_SQUARE = 1, /* half side aperture_radius */
    LR_APERTURE_POLYGON = 2 /* regular polygon inscribed in the circle */
} lr_aperture_shape;

/* A real lens's coatings (camera.coating): each surface's own, as its
 * prescription gives it (the default: one quarter-wave MgF2 layer on
 * every glass-air surface unless the prescription says otherwise), or
 * one kind for every glass-air surface, overriding the prescription. */
typedef enum lr_lens_coating {
    LR_COATING_PRESCRIPTION = 0, /* "prescription" (the default) */
    LR_COATING_NONE = 1,         /* "none": bare glass everywhere */
    LR_COATING_MGF2 = 2          /* "mgf2": quarter-wave MgF2 everywhere */
} lr_lens_coating;

/* A real lens's ghosts (camera.ghosts): light reflected twice inside the
 * lens, traced from bright sources (docs/lenses.md). */
typedef enum lr_ghosts {
    LR_GHOSTS_AUTO = 0, /* "auto" (the default): only for sources whose
                           ghosts would show */
    LR_GHOSTS_ON = 1,   /* true: every source */
    LR_GHOSTS_OFF = 2   /* false: none */
} lr_ghosts;

typedef enum lr_chromatic_mode {
    LR_CHROMATIC_OFF = 0,     /* one focus for all light (costs nothing) */
    LR_CHROMATIC_RGB = 1,     /* the paper: R, G, B each with its focus */
    LR_CHROMATIC_SPECTRAL = 2 /* wavelength samples through a dispersion
                                 curve, to sRGB via CIE 1931 */
} lr_chromatic_mode;

typedef enum lr_focal_model {
    LR_FOCAL_PAPER = 0,    /* f_c = f_g * n_g / n_c (the paper) */
    LR_FOCAL_LENSMAKER = 1 /* f(lambda) proportional to 1 / (n(lambda) - 1) */
} lr_focal_model;

typedef enum lr_glass {
    LR_GLASS_BK7 = 0,  /* Schott N-BK7 (Sellmeier) */
    LR_GLASS_F2 = 1,   /* Schott F2 */
    LR_GLASS_SF11 = 2, /* Schott N-SF11 (optics-reference.md's "SF11") */
    LR_GLASS_FUSED_SILICA = 3,
    LR_GLASS_ABBE = 4 /* n_d and V_d, the glTF Abbe-number model */
} lr_glass;

/* Axial chromatic aberration.  In rgb mode `ior` gives the red, green and
 * blue indices (green is the reference, focused as the camera says); in
 * spectral mode the index follows `glass` (or abbe_nd/abbe_vd) and the d
 * line (587.56 nm) is the reference.  `amplify` scales each index's
 * difference from the reference, to exaggerate the effect as the paper
 * does (1 = true glass, 0 = no aberration). */
typedef struct lr_chromatic {
    lr_chromatic_mode mode;     /* default LR_CHROMATIC_OFF */
    lr_focal_model focal_model; /* default LR_FOCAL_PAPER */
    double ior[3];              /* default 1.50917, 1.51534, 1.51690 */
    lr_glass glass;             /* default LR_GLASS_BK7 */
    double abbe_nd, abbe_vd;    /* for LR_GLASS_ABBE; default 1.5168, 64.17 */
    double amplify;             /* default 1 */
    int wavelengths;            /* spectral mode: wavelengths per camera
                                sample (besides the reference ray); 8 */
    int splat;                  /* spectral mode through the thin lens: 1
                                (default) credits each traced ray to every
                                pixel its colours' focus shifts it into,
                                with the samples' film offsets and lens
                                points shared by all pixels; 0 traces each
                                pixel's own wavelengths (docs/lens-models.md
                                4.4) */
} lr_chromatic;

/* A camera: a plain struct, so copy and edit it freely.  Directions need
 * not be normalised; `up` must not be parallel to look_at - position.
 * Which fields matter depends on `model`; the others are ignored. */
typedef struct lr_camera {
    lr_camera_model model;
    double position[3]; /* eye; default (0, 0, 0) */
    double look_at[3];  /* default (0, 0, -1) */
    double up[3];       /* default (0, 1, 0) */
    double fov;         /* vertical field of view in degrees, (0, 180); 40 */

    /* Thin lens.  The lens sits at `position`; the plane in focus is
     * perpendicular to the view axis at `focus_distance`.  The aperture is
     * `aperture_radius` in scene units, or, when f_number > 0, the radius
     * focal_length_mm / 1000 / (2 f_number): scene units are metres then. */
    double focus_distance;  /* > 0; default 10 */
    double aperture_radius; /* >= 0; default 0 (a pinhole) */
    double f_number;        /* 0 = use aperture_radius (default) */
    double focal_length_mm; /* lens focal length; 0 = unknown (default) */
    lr_aperture_shape aperture_shape; /* default LR_APERTURE_DISK */
    int aperture_blades;              /* polygon sides, 3..64; default 6 */
    double aperture_rotation; /* degrees, counter-clockwise; default 0 */
    double aperture_ratio;    /* width / height, anamorphic; default 1 */
    /* Autofocus: when focus_on[0] >= 0, the first hit of the pinhole ray
     * through pixel (focus_on[0], focus_on[1]) sets the focus (the thin
     * lens's focus_distance, the bracket's focal_length).  Default -1. */
    int focus_on[2];

    /* Bracket (the paper).  The image plane is `image_plane_distance` (di)
     * in front of the eye; the focal plane `focal_length` (f) beyond it.
     * Rays start in a square of side `aperture` around the pixel on the
     * image plane and pass through the pixel's focal point. */
    double image_plane_distance; /* > 0; default 1 */
    double focal_length;         /* > 0; default 9 */
    double aperture;             /* >= 0; default 0 */

    lr_chromatic chromatic;

    /* Real lens ("lens").  `position` is the sensor's centre; the lens
     * sits in front of it along the view axis, and unit focusing moves it
     * so that the plane `focus_distance` (scene units, from the sensor)
     * is sharp at the primary wavelength.  f_number > 0 closes the stop
     * to that f-number at infinity (clamped to the lens's widest); 0 is
     * fully open.  fov is unused: the lens and the sensor set the view. */
    const lr_lens *lens;    /* NULL until a lens is given */
    double sensor_width_mm; /* default 36; the height follows the image */
    double scene_unit_mm;   /* millimetres per scene unit; default 1000 */
    /* Every surface transmits 1 - R of the light (its reflectance R under
     * its coating), on every path; `coating` overrides the
     * prescription's coatings.  Default LR_COATING_PRESCRIPTION. */
    lr_lens_coating coating;
    lr_ghosts ghosts; /* default LR_GHOSTS_AUTO */

    /* The parameters of every model registered after LR_CAMERA_LENS,
     * each model's in a block of its own, laid out by its key table: they
     * are not API.  Set and read them by key, through
     * lr_camera_apply_json and lr_camera_json (docs/scene-format.md
     * section 6 lists each model's keys and defaults). */
    double model_params[LR_CAMERA_MODEL_PARAMS];
} lr_camera;

/* Loads the lens `lens`: a prescription file (lensray JSON, pbrt-v4's
 * .dat, Zemax .zmx) relative to `base_dir` (NULL: the working
 * directory), or a shipped lens by name ("double-gauss-50").  *out is
 * shared and never freed (see lr_lens), NULL on error.  Errors name the
 * file, line, surface and field: LR_ERR_INVALID, LR_ERR_IO,
 * LR_ERR_LIMIT (LR_MAX_LENSES), LR_ERR_NOMEM. */
LR_API lr_status lr_lens_load(const char *lens, const char *base_dir,
                              const lr_lens **out, lr_error *err);
/* The lens's name as given to lr_lens_load or in the scene, or "" for
 * an inline prescription; a string owned by the lens. */
LR_API const char *lr_lens_name(const lr_lens *lens);

/* Fills `cam` with the defaults documented above. */
LR_API void lr_camera_default(lr_camera *cam);

/* Checks a camera; LR_ERR_INVALID names the bad field ("camera.fov"). */
LR_API lr_status lr_camera_validate(const lr_camera *cam, lr_error *err);

/* A camera of its own on the heap, with the defaults: for bindings
 * (Python's ctypes) that pass cameras to the library without knowing the
 * struct's layout, and set them only through lr_scene_camera,
 * lr_camera_apply_json and lr_camera_json, so that a field added to
 * lr_camera changes nothing in them.  Free it with lr_camera_free.  NULL
 * when out of memory. */
LR_API lr_camera *lr_camera_new(void);
/* Frees a camera from lr_camera_new.  NULL is a no-op. */
LR_API void lr_camera_free(lr_camera *cam);

/* ------------------------------------------------------------------------
 * Render settings
 * ---------------------------------------------------------------------- */

/* How sample values are drawn, for the pixel, lens and wavelength
 * dimensions alike.  Each value is a pure function of (pixel, sample
 * index, dimension, seed). */
typedef enum lr_sampler_kind {
    LR_SAMPLER_RANDOM = 0,   /* independent uniform numbers */
    LR_SAMPLER_GRID = 1,     /* cell centres: the paper's unjittered grid */
    LR_SAMPLER_JITTERED = 2, /* stratified, random offset in each cell */
    LR_SAMPLER_SOBOL = 3     /* Owen-scrambled Sobol (progressive) */
} lr_sampler_kind;

/* How radiance is computed along camera rays (render.integrator). */
typedef enum lr_integrator_kind {
    /* Direct light with hard shadows, mirror and glass rays: the classic
     * ray tracer (the default; scenes that name none keep their pixels). */
    LR_INTEGRATOR_WHITTED = 0,
    /* Unidirectional path tracing with next-event estimation and multiple
     * importance sampling: area lights (emission), environment light,
     * rough metal and glass, indirect light. */
    LR_INTEGRATOR_PATH = 1,
    /* Light tracing: every path from the lights, each vertex joined to
     * the lens (Mitsuba 3's ptracer); camera rays estimate nothing.  The
     * path tracer's image but for what is seen in smooth mirrors and glass
     * (docs/bokeh.md). */
    LR_INTEGRATOR_LIGHT = 2
} lr_integrator_kind;

/* Called from render threads, serialised by the library, after each tile
 * and as the light side's paths run (light tracing, bokeh's light paths):
 * `done` of `total` is the render's work done, counted in pixels, the
 * camera's tiles and the light side each weighted by its estimated share
 * of the work.  `done` only grows; the last call has done == total ==
 * the pixels rendered.  Must not call back into lr_render. */
typedef void (*lr_progress_fn)(void *user, uint64_t done, uint64_t total);

/* A ready-made lr_progress_fn for callers that poll rather than be called:
 * `user` points to a uint64_t[2] that receives done and total, each with
 * an atomic store, so that another thread can read them (with atomic
 * loads) while the render runs.  Language bindings use it to draw a
 * progress bar without running their own code on the render threads. */
LR_API void lr_progress_store(void *user, uint64_t done, uint64_t total);

typedef struct lr_render_settings {
    int width;               /* pixels; default 640 */
    int height;              /* pixels; default 480 */
    int spp;                 /* samples per pixel; default 16 */
    lr_sampler_kind sampler; /* default LR_SAMPLER_SOBOL */
    uint64_t seed; /* default 0; at most 2^53 (JSON's exact integers) */
    /* Bounces after the first hit: mirror/glass rays (whitted), any
     * scattering (path; Mitsuba's max_depth is this + 2); default 8 */
    int max_depth;
    int threads;    /* 0 = all cores (default) */
    int tile_size;  /* pixels per tile side; default 32 */
    int want_depth; /* also produce a Z channel; default 0 */
    /* Crop [x0, y0, x1, y1): render only these pixels of the full
     * width x height frame; the image is (x1-x0) x (y1-y0) and its pixels
     * are bit-identical to the same pixels of the full render.  All zero
     * (the default) means the whole frame. */
    int region[4];
    /* Effect planning: per tile, skip lens sampling where no geometry the
     * tile's lens rays can reach is blurred by more than a quarter pixel,
     * and trace one ray for all colours where the colours' circles of
     * confusion differ by less than that (with LR_SAMPLER_GRID and
     * adaptive sampling on, the lens is sampled wherever a tile can reach
     * geometry: only its blur dithers the grid's fixed positions).  Default 1; 0 = always
     * simulate everything. */
    int plan;
    /* Adaptive sampling: every pixel first takes a pilot of
     * adaptive_min_spp samples (at least 16 where the plan samples the
     * lens: blurred pixels nearly all need more, and a second packet of
     * rays costs more than the samples a small pilot saves); from their
     * spread it needs enough samples (up to spp) for a relative standard
     * error of adaptive_threshold in each colour channel (relative to
     * sqrt(mean^2 + 0.01)), and goes on to the largest need in its 3 x 3
     * neighbourhood, so that neighbours of unconverged pixels keep going,
     * and to contrast / threshold samples where its pilot's mean differs
     * from a neighbour's by that relative contrast (an edge along the
     * pixel grid can cut a sliver that the pilot missed); then it goes on
     * in rounds that at least double its count (min_spp x 2^k, or spp),
     * judging its need again from all its samples after each.  0 for
     * either (the default) derives it from spp, so that more samples
     * always buy less error: threshold 3 / spp, min_spp the power of two
     * at or above sqrt(spp), at least 16 (spp itself up to 16: no
     * adaptive sampling there).  Default 1; 0 = spp everywhere.  Counts
     * depend only on a pixel's neighbourhood, so regions and thread
     * counts still give the same bytes, and a pixel that stops at n
     * samples has the full render's first n. */
    int adaptive;
    double adaptive_threshold; /* default 0: 3 / spp */
    int adaptive_min_spp;      /* default 0: max(16, sqrt(spp)) (capped at
                                  spp) */
    lr_progress_fn progress;   /* optional; NULL by default */
    void *progress_user;
    /* Optional cancellation flag, polled (with an atomic load) between
     * tiles: when it becomes non-zero the render stops and returns
     * LR_ERR_CANCELLED with no image (the stats, if asked for, are still
     * filled).  Set it from another thread with an atomic store
     * (__atomic_store_n), or from a signal handler. */
    const volatile int *cancel;
    lr_integrator_kind integrator; /* default LR_INTEGRATOR_WHITTED */
    /* Light tracing through the lens: 1 (the default), the plan sends
     * small lights far out of focus (or smaller than a pixel) to the
     * light side, where every sample lands in their disc (docs/bokeh.md);
     * 0, every light is found by camera rays alone. */
    int light;
} lr_render_settings;

/* Fills `s` with the defaults documented above. */
LR_API void lr_render_settings_default(lr_render_settings *s);

/* Checks settings; LR_ERR_INVALID names the field ("render.spp"). */
LR_API lr_status lr_render_settings_validate(const lr_render_settings *s,
                                             lr_error *err);

/* ------------------------------------------------------------------------
 * Camera and settings from JSON
 * ---------------------------------------------------------------------- */

/* Applies the keys of a JSON object (`len` bytes of text, e.g. the
 * "camera" or "render" object of a job) on top of *cam or *s: keys it
 * leaves out keep their current values.  The keys and rules are those of
 * the scene format's "camera" and "render" objects, and errors name the
 * field as "camera.fov" / "render.spp".  On error *cam / *s is unchanged.
 * Errors: LR_ERR_INVALID, LR_ERR_NOMEM; for the camera also LR_ERR_IO
 * and LR_ERR_LIMIT from loading its lens (lr_lens_load). */
LR_API lr_status lr_camera_apply_json(lr_camera *cam, const char *json,
                                      size_t len, lr_error *err);
LR_API lr_status lr_render_settings_apply_json(lr_render_settings *s,
                                               const char *json, size_t len,
                                               lr_error *err);

/* ------------------------------------------------------------------------
 * Scenes
 * ---------------------------------------------------------------------- */

typedef struct lr_scene lr_scene;

/* Loads a scene from a JSON file (format: docs/scene-format.md), or a
 * glTF 2.0 file (a name ending in .gltf or .glb whose first bytes are
 * those of one: the scene of docs/gltf.md, "A glTF file alone").  Mesh
 * paths are relative to the file's directory.  `overrides` is an array of
 * `n_overrides` strings "dotted.path=value" applied to the JSON before it
 * is validated (value parsed as JSON, else taken as a string), e.g.
 * "camera.fov=30" or "objects[2].radius=0.5"; pass NULL, 0 for none.
 * On success *out owns a new scene: free it with lr_scene_free.
 * Errors: LR_ERR_IO (file), LR_ERR_INVALID (JSON, value, OBJ; the path
 * names the field), LR_ERR_LIMIT (a size limit: a file or image too large,
 * or more than lr_scene_limits_set allows), LR_ERR_NOMEM (also Embree
 * out of memory), LR_ERR_EMBREE. */
LR_API lr_status lr_scene_load_file(const char *path,
                                    const char *const *overrides,
                                    size_t n_overrides, lr_scene **out,
                                    lr_error *err);

/* The same from JSON text of `len` bytes (need not be NUL-terminated).
 * `base_dir` resolves relative mesh paths; NULL means the current
 * directory.  The text is not referenced after the call. */
LR_API lr_status lr_scene_load_json(const char *json, size_t len,
                                    const char *base_dir,
                                    const char *const *overrides,
                                    size_t n_overrides, lr_scene **out,
                                    lr_error *err);

/* The camera and render settings of the scene file at `path` with the
 * overrides, as lr_scene_load_file then lr_scene_camera and
 * lr_scene_settings give them, without loading the rest: for a client
 * that renders the scene elsewhere (lensray --remote) and needs only to
 * cut the frame.  The top-level keys, the description, the camera (with
 * its lens file) and the render settings are checked; materials, lights and objects are not
 * read, so their errors come from whoever loads the scene.  A glTF file,
 * or a scene that takes the camera of a glTF file it places, is loaded
 * whole, since the camera comes from that file.  Errors: those of
 * lr_scene_load_file. */
LR_API lr_status lr_scene_read_settings(const char *path,
                                        const char *const *overrides,
                                        size_t n_overrides, lr_camera *cam,
                                        lr_render_settings *rs, lr_error *err);

/* For a scene `s` that lr_scene_load_file loaded from the glTF file
 * `path`: the scene JSON that renders the same, for a client that sends
 * the scene elsewhere (lensray --remote): the file (by its name, relative
 * to its directory) as a {"type": "gltf", "camera": true} object, the
 * path tracer, and the background the loader chose (docs/gltf.md).
 * Malloc'ed text to release with lr_free; NULL when `path` is not a glTF
 * file or memory ran out. */
LR_API char *lr_gltf_scene_json(const char *path, const lr_scene *s);

/* Sets the process's assets directory: where a scene's file reference
 * "sha256:HEX" (any key that names a file: objects[].file,
 * environment.file, camera.lens, ...) is found, as the file named HEX,
 * the SHA-256 of its bytes (docs/api.md, "Assets").  NULL or "" unsets
 * it; then $LENSRAY_ASSETS_DIR is used when set, else such references
 * are refused (LR_ERR_INVALID naming the field).  Call it before loading
 * scenes; the path is copied.  Errors: LR_ERR_LIMIT (path too long). */
LR_API lr_status lr_assets_dir_set(const char *dir, lr_error *err);

/* Sets, for the process, the most one scene may hold: `max_triangles`
 * triangles (every placed copy counts: an OBJ file named by 1000 objects
 * is 1000 times its triangles, a glTF mesh drawn by many nodes as often
 * as it is drawn) and `max_texels` texels of its textures and
 * environment map together (each image as declared, checked before it
 * is decoded; a file used twice with the same colour space is loaded,
 * and counted, once).  0 means no limit, the default.  A scene loaded
 * later that would hold more fails with LR_ERR_LIMIT; the path names the
 * field that added the excess (objects[412].file,
 * materials.wood.diffuse_texture, environment.file) and the message
 * says "the limit set by lr_scene_limits_set".  Scenes already loaded
 * are not affected.  For a server that loads scenes from clients
 * (lensrayd's --max-scene-triangles, --max-scene-texels). */
LR_API void lr_scene_limits_set(uint64_t max_triangles, uint64_t max_texels);

/* Whether a member named `key` of a scene object holds a file reference
 * (a string: a path relative to the scene's directory, an absolute path
 * or an asset "sha256:HEX"): "file" (objects, environment) and each
 * other key the loader reads a file from.  camera.lens is apart: it is
 * a file, a shipped lens's name or an inline prescription.  For clients
 * that send a scene elsewhere with its files (lensray render --remote). */
LR_API int lr_scene_file_key(const char *key);

/* Frees a scene.  No render may be using it.  NULL is a no-op. */
LR_API void lr_scene_free(lr_scene *scene);

/* The camera and render settings the scene file specified (defaults for
 * what it left out; all defaults for a NULL scene).  The scene keeps no
 * reference to them. */
LR_API void lr_scene_camera(const lr_scene *scene, lr_camera *cam);
LR_API void lr_scene_settings(const lr_scene *scene, lr_render_settings *s);

/* What loading read but ignored (parts of a glTF file lensray does not
 * render), one line each, "" when nothing was.  Owned by the scene. */
LR_API const char *lr_scene_warnings(const lr_scene *scene);

/* Counts, for reports: primitives (triangles + spheres + planes). */
LR_API size_t lr_scene_primitive_count(const lr_scene *scene);

/* The scene's "description" string, "" when it has none; valid until
 * lr_scene_free. */
LR_API const char *lr_scene_description(const lr_scene *scene);

/* Whether a file the scene was loaded from (its meshes, textures, glTF
 * files, environment map, lens file; not the scene's own JSON, which
 * the caller read) has changed or gone since, by device, inode, size and
 * modification time: for a caller that keeps loaded scenes, as lensrayd
 * does, to load it again. */
LR_API int lr_scene_files_changed(const lr_scene *scene);

/* The camera and render settings as JSON objects in the scene format
 * (docs/scene-format.md sections 6 and 7): every key that applies to the
 * camera's model, so that lr_camera_apply_json of the text on top of
 * lr_camera_default gives *cam back (and likewise for the settings;
 * progress and cancel are not JSON and are left out).  Returns compact
 * text of one line, malloc'ed: release it with lr_free.  NULL when out of
 * memory. */
LR_API char *lr_camera_json(const lr_camera *cam);
LR_API char *lr_render_settings_json(const lr_render_settings *s);

/* ------------------------------------------------------------------------
 * Rendering
 * ---------------------------------------------------------------------- */

typedef struct lr_image lr_image;

typedef struct lr_render_stats {
    double seconds;       /* wall time of the render */
    double cpu_seconds;   /* CPU time of the render's threads, together:
                              its work however busy the machine is */
    uint64_t pixels;      /* pixels rendered */
    uint64_t samples;     /* camera samples taken (pixels x spp without
                              adaptive sampling) */
    uint64_t rays;        /* all rays traced: camera, shadow, secondary */
    uint64_t nan_samples; /* samples dropped for being NaN or Inf */
    int threads;          /* threads used */
    /* The plan: what was simulated where, against the full simulation. */
    uint64_t lens_pixels;      /* pixels whose samples sampled the lens */
    uint64_t chroma_pixels;    /* pixels traced once per colour/wavelength */
    uint64_t camera_rays;      /* camera rays traced (apron pilots included) */
    uint64_t full_camera_rays; /* what plan = 0, adaptive = 0 would trace */
    uint64_t full_samples;     /* pixels x spp */
    uint64_t lens_blocked;     /* camera rays a real lens stopped */
    /* Light tracing through the lens (render.light): the lights the plan
     * sent to the light side, the light paths traced for them and those
     * that reached the film (inside the frame; a region keeps its own). */
    uint64_t light_lights;
    uint64_t light_paths;
    uint64_t light_landed;
    /* A real lens's ghosts (camera.ghosts, issue 29), left out of the
     * three above: the lights that got them, their light paths (for a
     * source drawn as meshes, its meshes' rays through the lens), and
     * the landings of those paths' ghost rays inside the frame (each
     * path lands through one ghost path of the lens, in each colour;
     * a mesh's corners that land). */
    uint64_t ghost_lights;
    uint64_t ghost_paths;
    uint64_t ghost_landed;
    /* The light the ghosts carried into the frame (a region: into the
     * region), every channel, over the main images their sources would
     * make on the axis (each the source's radiance times its solid
     * angle times the lens's main-path transmission over its front, in
     * pixels through the exposure normalisation; every channel, summed
     * over the ghost lights): for a source on the axis, the figure
     * `lensray lens --ghosts` gives as total_flux (counted there on the
     * frame's circumscribed circle).  0 without ghosts. */
    double ghost_flux;
} lr_render_stats;

/* Renders `scene` through `cam` with `settings`.  On success *out owns a
 * new image (free with lr_image_free) and, if `stats` is non-NULL, it is
 * filled (also when the render was cancelled).  The scene is only read.  Errors: LR_ERR_INVALID (camera or
 * settings; the path names the field), LR_ERR_NOMEM, LR_ERR_CANCELLED. */
LR_API lr_status lr_render(const lr_scene *scene, const lr_camera *cam,
                           const lr_render_settings *settings, lr_image **out,
                           lr_render_stats *stats, lr_error *err);

/* The statistics of a render as one line of JSON, the same wherever they
 * are shown (the CLI's --stats, the daemon's job status):
 *     {"seconds": 0.42, "cpu_seconds": 0.8, "width": 640, "height": 480,
 *      "spp": 16, "threads": 2, "pixels": ..., "samples": ..., "rays": ...,
 *      "samples_per_second": ..., "rays_per_second": ..., "nan_samples": 0,
 *      "primitives": ...,
 *      "plan": {"enabled": true, "adaptive": true, "lens_pixels": 0.31,
 *               "chroma_pixels": 0, "samples": ..., "full_samples": ...,
 *               "camera_rays": ..., "full_camera_rays": ...,
 *               "lens_blocked": ..., "light_lights": ..., "light_paths": ...,
 *               "light_landed": ..., "ghost_lights": ..., "ghost_paths": ...,
 *               "ghost_landed": ..., "ghost_flux": ...}}
 * lens_pixels and chroma_pixels are shares of the pixels (0 to 1); "plan"
 * is the last member.  `settings` (what the render ran with) gives width,
 * height, spp and plan.enabled/adaptive, and `scene` gives primitives;
 * either may be NULL, and then those members are left out.  Returns
 * malloc'ed text (release with lr_free), or NULL when out of memory. */
LR_API char *lr_render_stats_json(const lr_render_stats *stats,
                                  const lr_render_settings *settings,
                                  const lr_scene *scene);

/* What lr_render decides before it traces, for callers that show it (the
 * daemon's page: the focus a click chose, where the lens was simulated).
 *
 * lr_camera_autofocus resolves camera.focus_on as lr_render does for a
 * width x height frame: the model's focus (the thin lens's
 * focus_distance, the bracket's focal_length) is set from the first hit
 * of the pinhole ray through that pixel's centre, and focus_on is cleared.
 * Rendering the result gives the same bytes as rendering *cam unresolved.
 * No-op when focus_on is unset or the model has no focus.  Errors:
 * LR_ERR_INVALID (the camera, or focus_on outside the frame or on
 * nothing); on error *cam is unchanged. */
LR_API lr_status lr_camera_autofocus(const lr_scene *scene, lr_camera *cam,
                                     int width, int height, lr_error *err);

/* The plan of a render (render.plan): per block of LR_PLAN_BLOCK x
 * LR_PLAN_BLOCK pixels of the whole frame, row by row, whether the lens
 * was sampled (LR_PLAN_LENS) and each colour traced on its own
 * (LR_PLAN_CHROMA).  It is the record lr_render works from, built the same
 * way (autofocus first); blocks outside settings->region are planned as
 * the full simulation.  On success *cells is columns x rows bytes,
 * malloc'ed: release it with lr_free.  Errors: LR_ERR_INVALID (camera or
 * settings), LR_ERR_NOMEM. */
#define LR_PLAN_BLOCK 16
#define LR_PLAN_LENS 1
#define LR_PLAN_CHROMA 2
LR_API lr_status lr_render_plan_map(const lr_scene *scene, const lr_camera *cam,
                                    const lr_render_settings *settings,
                                    unsigned char **cells, int *columns,
                                    int *rows, lr_error *err);

/* ------------------------------------------------------------------------
 * Images
 * ---------------------------------------------------------------------- */

/* Channel layout of an image: linear RGB radiance, always finite; plus an
 * optional Z channel (distance along the view axis of the first hit of the
 * ray through the pixel centre; LR_DEPTH_NONE where it hits nothing). */
#define LR_DEPTH_NONE 1e10f

LR_API int lr_image_width(const lr_image *img);
LR_API int lr_image_height(const lr_image *img);
/* Pointer to width*height*3 floats, row-major from the top-left pixel,
 * valid until lr_image_free. */
LR_API const float *lr_image_rgb(const lr_image *img);
/* Pointer to width*height floats, or NULL when the image has no Z. */
LR_API const float *lr_image_depth(const lr_image *img);

/* A new black image, for callers that build images themselves. */
LR_API lr_status lr_image_create(int width, int height, int with_depth,
                                 lr_image **out, lr_error *err);
/* Writable pixel access for images made by lr_image_create. */
LR_API float *lr_image_rgb_mut(lr_image *img);
LR_API float *lr_image_depth_mut(lr_image *img);

LR_API void lr_image_free(lr_image *img);

/* Records that `img` is the crop of a frame_w x frame_h frame whose
 * top-left pixel is x0, y0, rendered through `cam` with `s` (its spp and
 * seed are kept, and the camera as lr_camera_json writes it).  An EXR of
 * the image then has its data window at x0, y0 inside a display window
 * of the whole frame, as OpenEXR intends for crops, and the attributes
 * samplesPerPixel (int), lensraySeed (string, decimal) and lensrayCamera
 * (string, JSON), so that a compositing tool places it without help.
 * lr_render does this for every crop (render.region); a caller that
 * assembles the same crop from parts does it to write the same file.
 * Errors: LR_ERR_INVALID (the image does not fit the frame there; the
 * image is unchanged), LR_ERR_NOMEM. */
LR_API lr_status lr_image_set_frame(lr_image *img, int frame_w, int frame_h,
                                    int x0, int y0, const lr_camera *cam,
                                    const lr_render_settings *s, lr_error *err);

/* Image formats.  Their names, MIME types, extensions and what they can
 * hold come from one table in the library (lib/image/format.c): clients ask it
 * rather than keeping their own lists. */
typedef enum lr_format { LR_FORMAT_EXR = 0, LR_FORMAT_PNG = 1 } lr_format;

/* The format's short name, as JSON and file names use it ("exr",
 * "png"); NULL for a value that is not a format, so that
 * `for (f = 0; lr_format_name(f) != NULL; f++)` visits every format.
 * Static strings. */
LR_API const char *lr_format_name(lr_format fmt);
/* Its MIME type ("image/x-exr", "image/png"); NULL if not a format. */
LR_API const char *lr_format_mime(lr_format fmt);
/* Its file extension with the dot (".exr", ".png"); NULL if not one. */
LR_API const char *lr_format_extension(lr_format fmt);
/* 1 if the format can hold a Z (depth) channel, else 0. */
LR_API int lr_format_has_depth(lr_format fmt);
/* The format with this name (exact, lower case).  LR_ERR_INVALID for any
 * other name, with a message that lists the names; `field` names the
 * JSON field in the message and path (NULL: "format"). */
LR_API lr_status lr_format_from_name(const char *name, const char *field,
                                     lr_format *fmt, lr_error *err);

/* OpenEXR's lossless compressions (OpenEXR "Technical Introduction",
 * "Data Compression").  ZIP, the default, makes the smallest files of
 * rendered images; NONE costs a sixth of ZIP's time for about 3.5x the
 * bytes (a farm's parts on a local network: bench/README.md). */
typedef enum lr_exr_compression {
    LR_EXR_ZIP = 0, /* "zip": zlib over 16 scanlines */
    LR_EXR_NONE,    /* "none" */
    LR_EXR_ZIPS,    /* "zips": zlib per scanline */
    LR_EXR_RLE,     /* "rle": run lengths */
    LR_EXR_PIZ      /* "piz": wavelet and Huffman, for grainy images; any
                       other value is LR_ERR_INVALID when encoding */
} lr_exr_compression;

/* The name of an EXR compression ("zip"), and the compression of a name;
 * an unknown name is LR_ERR_INVALID naming `field` (default
 * "compression") and listing the names. */
LR_API const char *lr_exr_compression_name(lr_exr_compression c);
LR_API lr_status lr_exr_compression_from_name(const char *name,
                                              const char *field,
                                              lr_exr_compression *c,
                                              lr_error *err);

typedef struct lr_output_options {
    int exr_half;  /* EXR: RGB as half instead of float32; default 0 */
    int exr_depth; /* EXR: also write Z (if the image has it); default 1 */
    int png_16bit; /* PNG: 16 bits per channel; default 0 (8) */
    lr_exr_compression exr_compression; /* EXR; default LR_EXR_ZIP */
} lr_output_options;

LR_API void lr_output_options_default(lr_output_options *o);

/* What to encode: a format, its options, and whether the image carries a
 * Z channel.  This is the "output" object of a job (docs/api.md):
 *     {"format": "png" | "exr", "bit_depth": 8 | 16, "half": bool,
 *      "depth": bool, "compression": "zip" | "none" | "zips" | "rle" |
 *      "piz"}
 * Options that do not apply to the format are errors, not ignored. */
typedef struct lr_output {
    lr_format format;          /* default LR_FORMAT_PNG */
    lr_output_options options; /* exr_depth follows `depth` */
    int depth;                 /* render and write Z; default 0 */
    int depth_given;           /* 1 when the JSON said "depth" */
} lr_output;

/* Fills `o` with the defaults above. */
LR_API void lr_output_default(lr_output *o);

/* Applies the keys of an "output" JSON object (`len` bytes of text) on
 * top of *o.  Errors (LR_ERR_INVALID) name the field as "output.half";
 * on error *o is unchanged. */
LR_API lr_status lr_output_apply_json(lr_output *o, const char *json,
                                      size_t len, lr_error *err);

/* The format implied by a file name's extension (.exr, .png, any case);
 * LR_ERR_INVALID for anything else. */
LR_API lr_status lr_format_from_path(const char *path, lr_format *fmt,
                                     lr_error *err);

/* Encodes to memory.  On success *buf is a malloc'ed block of *len bytes
 * that the caller releases with lr_free.  PNG is sRGB-encoded (IEC
 * 61966-2-1 transfer curve) and clamped to [0, 1]; EXR is linear. */
LR_API lr_status lr_image_encode(const lr_image *img, lr_format fmt,
                                 const lr_output_options *opts, void **buf,
                                 size_t *len, lr_error *err);

/* Encodes and writes to `path`, the format chosen by its extension.  The
 * file is written to a temporary name beside it and renamed into place,
 * so a failed write never leaves a partial image under `path`.
 * `opts` may be NULL for the defaults. */
LR_API lr_status lr_image_write(const lr_image *img, const char *path,
                                const lr_output_options *opts, lr_error *err);

/* lr_image_write that stops when *cancel (may be NULL) becomes non-zero,
 * as lr_render_settings.cancel stops a render: at the encoder's next
 * write, or at the latest before the finished file is renamed into
 * place.  Then LR_ERR_CANCELLED, the temporary file removed and `path`
 * as it was. */
LR_API lr_status lr_image_write_cancellable(const lr_image *img,
                                            const char *path,
                                            const lr_output_options *opts,
                                            const volatile int *cancel,
                                            lr_error *err);

/* Whether lr_image_write could write `path` now, checked the way it
 * writes: the format by the extension, `path` (the file its symbolic
 * links lead to) not a directory, the temporary file beside it created
 * and removed, and the rename into place allowed (the name's length,
 * another user's file in a sticky directory).  For a caller to refuse a file name before a long
 * render rather than after it; LR_ERR_IO (or LR_ERR_INVALID for the
 * extension) with a message naming `path`. */
LR_API lr_status lr_image_write_check(const char *path, lr_error *err);

/* ------------------------------------------------------------------------
 * Jobs: a render request as one JSON document
 * ---------------------------------------------------------------------- */

/* A job is the JSON object that lensrayd takes (docs/api.md section 3):
 *     {"scene": "NAME" | {inline scene}, "camera": {...},
 *      "render": {...}, "output": {...}}
 * It is parsed once, by lr_job_parse; the caller then loads the scene it
 * names (the caller knows where scenes live and may cache them) and takes
 * the camera, settings and output from the same parse with lr_job_apply,
 * which validates them once.  Paths in errors are paths in the job
 * ("camera.fov", "output.half", "scene.objects[2].file"). */
typedef struct lr_job lr_job;

/* The deepest nesting of arrays and objects the library parses. */
#define LR_MAX_JSON_DEPTH 64

/* Parses `len` bytes of job text (need not be NUL-terminated; not
 * referenced after the call) and checks its shape: an object with the
 * keys above and no others, none twice, "scene" a string or an object,
 * "camera", "render" and "output" objects.  Nesting deeper than
 * `max_depth` (capped at LR_MAX_JSON_DEPTH; 0 or less means that cap)
 * is refused before parsing.
 * On success *out owns a new job: free it with lr_job_free.
 * Errors: LR_ERR_SYNTAX (empty, not UTF-8, not JSON, or text after the
 * value; the message gives the place), LR_ERR_LIMIT (too deep),
 * LR_ERR_INVALID (the shape; the path names the key), LR_ERR_NOMEM. */
LR_API lr_status lr_job_parse(const char *json, size_t len, int max_depth,
                              lr_job **out, lr_error *err);

/* Frees a job.  NULL is a no-op. */
LR_API void lr_job_free(lr_job *job);

/* The scene the job names: its name, or NULL for an inline scene. */
LR_API const char *lr_job_scene_name(const lr_job *job);

/* An inline scene as compact JSON text of *len bytes (for
 * lr_scene_load_json, and as a cache key: the same scene gives the same
 * text), or NULL for a named scene.  Valid until lr_job_free. */
LR_API const char *lr_job_scene_json(const lr_job *job, size_t *len);

/* The files a job's inline scene names, for a caller that confines them to a
 * directory: the k-th (from 0) file reference as written, in document
 * order: every string under a key that names a file (objects[i].file,
 * environment.file, a material's textures: all keys that the loader
 * resolves through the same function, so a new file key is listed here
 * too), and camera.lens (a path, an asset "sha256:HEX", or a plain
 * name: the file of that name in the scene's directory when there is
 * one, else a shipped lens, which the caller tells apart); and its path in the job ("scene.objects[3].file",
 * "scene.environment.file", "scene.camera.lens"); before them the
 * job's own camera.lens when it is an asset ("camera.lens"), whatever
 * the scene.  Returns 0 past the last one.  The strings are valid until
 * lr_job_free. */
LR_API int lr_job_mesh_file(const lr_job *job, size_t k, const char **file,
                            const char **field);

/* Applies the job's "camera", "render" and "output" objects on top of
 * *cam, *s and *out, which the caller has filled with the scene's own
 * values (lr_scene_camera, lr_scene_settings) and lr_output_default:
 * keys the job leaves out keep those values.  The camera and the settings
 * are validated once each, as a whole, after the job's keys are applied.
 * Depth: output.depth decides when given; otherwise the job's own
 * render.depth, then the scene's.  A job that asks for depth (either key
 * true) with a format without a Z channel is refused, naming the key; a
 * scene's own render.depth is a default that such a format leaves out.
 * On return s->want_depth and out->options.exr_depth say whether Z is
 * rendered and written.  Errors: LR_ERR_INVALID (the path names the
 * field), LR_ERR_NOMEM; on error the outputs are unspecified. */
LR_API lr_status lr_job_apply(const lr_job *job, lr_camera *cam,
                              lr_render_settings *s, lr_output *out,
                              lr_error *err);

/* ------------------------------------------------------------------------
 * Real lenses (issue 12; docs/lenses.md)
 * ---------------------------------------------------------------------- */

/* A lens prescription's first-order data and real chief rays, as one
 * JSON object: name, source, wavelength_nm, efl_mm, bfl_mm (from the
 * last surface), ffl_mm (from the first; negative: in front of it),
 * f_number, entrance_pupil and exit_pupil {position_mm (from the first
 * and the last surface), diameter_mm}, total_track_mm, and fields, one
 * per angle: angle_deg, image_height_mm (the real chief ray, aimed at
 * the stop's centre, at `nm` on the paraxial focal plane),
 * distortion_percent (against efl tan(angle)) and lateral_color_um (the
 * chief ray's height at 486.1 nm minus at 656.3 nm); a value that does
 * not exist (a ray that cannot pass) is null.  `lens` is a file relative
 * to `base_dir` (NULL: the working directory) or a shipped lens's name
 * (.json, .zmx or .dat, with or without the extension).  Angles are in
 * degrees, object at infinity, |angle| < 90, at most 64; `nm` in [300,
 * 2000] (587.5618 is the d line).  *json is malloc'ed text: release it
 * with lr_free.  Errors: LR_ERR_INVALID (no such lens, with the shipped
 * names; a bad prescription, naming its file and line or field; a bad
 * argument), LR_ERR_IO, LR_ERR_LIMIT, LR_ERR_NOMEM; then *json is NULL. */
LR_API lr_status lr_lens_describe(const char *lens, const char *base_dir,
                                  const double *field_angles_deg, int n_angles,
                                  double nm, char **json, lr_error *err);

/* The ghosts of a distant point on the axis through lens `lens` (found
 * as by lr_lens_describe) at `nm`, under each surface's own coating or
 * `coating` for all (issue 29; docs/lenses.md): a grid of 61 x 61
 * parallel rays over the front element, each traced through the main
 * path and every two-reflection path, counted where it lands within a
 * 36 x 24 mm frame.  JSON: name, wavelength_nm, coating, field_deg,
 * frame_radius_mm, main_transmission (the share of the beam's energy
 * the main image receives), ghost_paths, total_flux, and ghosts,
 * brightest first, each {surfaces: [j, i] (reflected at j, then at i),
 * flux (over the main image's), centroid_mm, rms_radius_mm}.  *json is
 * malloc'ed text: release it with lr_free.  Errors as lr_lens_describe,
 * and LR_ERR_INVALID for a wavelength outside [300, 2000] nm. */
LR_API lr_status lr_lens_ghosts(const char *lens, const char *base_dir,
                                double nm, lr_lens_coating coating, char **json,
                                lr_error *err);

/* lr_lens_ghosts for a distant point `field_deg` degrees off the axis
 * (in the x-z plane; its centroids then lie on the x axis): the same
 * JSON, field_deg as given; LR_ERR_INVALID (path "field_angles") unless
 * |field_deg| < 90. */
LR_API lr_status lr_lens_ghosts_at(const char *lens, const char *base_dir,
                                   double nm, double field_deg,
                                   lr_lens_coating coating, char **json,
                                   lr_error *err);

/* The same for every shipped lens, as {"lenses": [{"id": NAME, ...},
 * ...]} sorted by name (NAME is the file's name without extension).  A
 * shipped lens that fails to load is listed with an "error" message
 * instead of its data.  Ownership and errors as lr_lens_describe. */
LR_API lr_status lr_lenses_describe(const double *field_angles_deg,
                                    int n_angles, double nm, char **json,
                                    lr_error *err);

/* Releases memory the library handed out (encoded buffers).  NULL is a
 * no-op. */
LR_API void lr_free(void *p);

#ifdef __cplusplus
}
#endif
#endif /* LENSRAY_H */
