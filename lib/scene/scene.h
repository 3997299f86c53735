/*
 * scene.h: the loaded scene as the renderer sees it: its materials
 * (material.h), lights, geometry and Embree scene.  Built by
 * scene_load.c (validation) and scene.c (Embree), read-only afterwards;
 * ray queries on it are lib/accel/trace.h's.
 */
#ifndef LR_SCENE_H
#define LR_SCENE_H

#include "util/internal.h"
#include "util/vec.h"

#include "scene/material.h"

#include <embree3/rtcore.h>
#include <stdatomic.h>


/* One emitting primitive: a triangle of an emissive mesh or an emissive
 * sphere (light.c). */
typedef struct lr__emitter {
    unsigned geom; /* in scene->geoms */
    unsigned prim; /* triangle index; 0 for a sphere */
    double area;
    /* A triangle's corner a, edges b - a and c - a, and unit normal
     * (counter-clockwise front), kept in double so that sampling does
     * not read and convert the mesh again for every light sample. */
    lr__v3 a, e1, e2, n;
} lr__emitter;

typedef struct lr__envmap lr__envmap; /* envmap.c */

typedef enum lr__light_kind {
    LR__LIGHT_POINT,
    LR__LIGHT_DIRECTIONAL
} lr__light_kind;

typedef struct lr__light {
    lr__light_kind kind;
    lr__v3 position;  /* point */
    lr__v3 direction; /* directional, spot: unit, the way the light travels
                         (a spot's cone axis) */
    lr__v3 power;     /* point: intensity W/sr (a spot's on its axis);
                         directional: irradiance */
    /* A spot light is a point light whose intensity falls to 0 between
     * two cones about `direction` (lr__spot_falloff). */
    int spot;
    double cone_scale, cone_offset;
} lr__light;

/* The share of a point light's intensity sent towards a point that sees
 * it in unit direction l: 1, or for a spot with inner and outer cone
 * half-angles ci, co, a = (cos t - cos co) / (cos ci - cos co) clamped to
 * [0, 1], squared, where t is the angle off the axis (the falloff of
 * glTF's KHR_lights_punctual: scale = 1 / (cos ci - cos co), offset =
 * -cos co x scale). */
static inline double lr__spot_falloff(const lr__light *lt, lr__v3 l)
{
    if (!lt->spot)
        return 1.0;
    double cd = -(l.x * lt->direction.x + l.y * lt->direction.y +
                  l.z * lt->direction.z);
    double a = cd * lt->cone_scale + lt->cone_offset;
    a = a < 0.0 ? 0.0 : a > 1.0 ? 1.0 : a;
    return a * a;
}

/* Makes *lt a spot: axis `dir` (non-zero; normalised here) and cone
 * half-angles inner < outer in radians, 0 <= inner, outer <= pi/2. */
void lr__spot_set(lr__light *lt, lr__v3 dir, double inner, double outer);

typedef enum lr__geom_kind {
    LR__GEOM_TRIANGLES,
    LR__GEOM_SPHERE,
    LR__GEOM_PLANE /* infinite: traced analytically beside Embree */
} lr__geom_kind;

/* One object of the scene.  For Embree geometries, the index in
 * scene->geoms is the Embree geometry ID. */
typedef struct lr__geom {
    lr__geom_kind kind;
    int material; /* index into scene->materials */
    /* Triangles: per-corner unit shading normals (9 per triangle), or
     * NULL for flat shading.  Owned. */
    float *corner_normals;
    /* Triangles: per-corner texture coordinates (6 per triangle: u, v of
     * corners a, b, c), or NULL when the mesh has none.  Owned.  A loader
     * sets it right after lr__scene_add_triangles, on
     * s->geoms[s->n_geoms - 1]. */
    float *corner_uv;
    /* Triangles with a normal-mapped material and corner_uv: each
     * triangle's tangent and bitangent (6 floats: dP/du and dP/dv from
     * its corners' positions and uvs), or NULL.  Set by lr__scene_commit.
     * Owned. */
    float *tangents;
    size_t n_triangles;
    /* Spheres (also mirrored in Embree) and infinite planes. */
    lr__v3 center;
    double radius;
    lr__v3 normal; /* plane */
    /* Set by lr__scene_commit: a triangle mesh whose material is a
     * Lambertian lobe with some albedo and nothing else (no Phong lobe,
     * mirror or glass): a fact the integrator's vector path asks per
     * lane. */
    int lambert_triangles;
    /* Set with lambert_triangles: each triangle's unit geometric normal
     * (b - a) x (c - a) / |...|, in double from the float corners, as
     * lr__hit_complete computes it (3 per triangle; owned), and the
     * material's albedo.  The vector path reads them per lane instead of
     * the index, three corners and a material: one cache line and no
     * chain of dependent loads. */
    double *face_ng;
    lr__v3 albedo;
    /* Set with lambert_triangles: the albedo comes from a texture (the
     * material's diffuse_tex), read here rather than through the
     * material, one dependent load less per lane. */
    int albedo_textured;
    /* Emissive geometry: the index in scene->emitters of its first
     * primitive (triangle i is emitters[emitter + i]); -1 if none. */
    long emitter;
    /* Triangles: Embree's copies of the vertices and indices, valid for
     * the scene's lifetime (not owned). */
    const float *vertices;
    const unsigned *indices;
    /* A triangle mesh of more than LR__GEOM_FEW triangles: the world
     * bounds of each chunk of LR__GEOM_CHUNK of them, lo x, y, z then hi
     * x, y, z, for the planner (made at commit: they depend only on the
     * scene, and computing them once, not per render, spares each part
     * of a split frame).  Owned; NULL otherwise. */
    double *chunk_bounds;
} lr__geom;

#define LR__GEOM_FEW 8
#define LR__GEOM_CHUNK 64

/* A cache that a higher layer keeps with a scene (the planner's boxes,
 * plan.c): made by its first user, which sets it once
 * (lr__scene_cache_set), and freed with the scene through its own
 * `free`; the user's struct begins with this one. */
typedef struct lr__scene_cache {
    void (*free)(struct lr__scene_cache *c);
} lr__scene_cache;

/* A sphere spheres.c meets itself (its geometry's center and radius). */
#define LR__FEW_SPHERES 8
typedef struct lr__few_sphere {
    double cx, cy, cz, r;
    unsigned id; /* its Embree geometry ID */
} lr__few_sphere;

/* A path-traced scene's triangles when it has no more than
 * LR__FEW_TRIANGLES (and nothing else but spheres), as shapes
 * (few_triangles.c): a triangle (x, s1, s2), or a parallelogram that
 * two triangles of a mesh (x, s1, s2) and (y, s1, s2) with x + y = s1 +
 * s2 make (a rectangle object's two).  Each shape's corner x, edges e1 =
 * s1 - x, e2 = s2 - x and normal e1 x e2 in double from Embree's float
 * corners; then per triangle its geometry and primitive IDs and where
 * its own corners b and c are among (x or y, s1, s2). */
#define LR__FEW_TRIANGLES 32
typedef struct lr__few_triangles {
    size_t n; /* triangles; 0: Embree meets them */
    int n_shapes;
    double ax[LR__FEW_TRIANGLES], ay[LR__FEW_TRIANGLES], az[LR__FEW_TRIANGLES];
    double e1x[LR__FEW_TRIANGLES], e1y[LR__FEW_TRIANGLES],
        e1z[LR__FEW_TRIANGLES];
    double e2x[LR__FEW_TRIANGLES], e2y[LR__FEW_TRIANGLES],
        e2z[LR__FEW_TRIANGLES];
    double nx[LR__FEW_TRIANGLES], ny[LR__FEW_TRIANGLES], nz[LR__FEW_TRIANGLES];
    double quad[LR__FEW_TRIANGLES]; /* 1: a parallelogram */
    int first[LR__FEW_TRIANGLES];   /* its triangle (x, s1, s2) */
    int second[LR__FEW_TRIANGLES];  /* (y, s1, s2), or -1 */
    unsigned geom[LR__FEW_TRIANGLES], prim[LR__FEW_TRIANGLES];
    unsigned char corner_b[LR__FEW_TRIANGLES], corner_c[LR__FEW_TRIANGLES];
} lr__few_triangles;

struct lr_scene {
    RTCDevice device;
    RTCScene rtc;
    /* With 1 to LR__FEW_SPHERES spheres: Embree's scene of everything
     * else, and the spheres (spheres.c); else NULL and 0.  NULL too when
     * few_tris holds every triangle: then no Embree scene is asked. */
    RTCScene rtc_few;
    /* "accel": {"robust": false}: both Embree scenes built without
     * RTC_SCENE_FLAG_ROBUST (zero, the default, builds them robust). */
    int not_robust;
    lr__few_sphere few[LR__FEW_SPHERES];
    size_t n_few;
    lr__few_triangles few_tris;
    lr__material *materials;
    size_t n_materials;
    lr__light *lights;
    size_t n_lights;
    lr__geom *geoms; /* Embree geometries, by geometry ID */
    size_t n_geoms;
    /* Set by lr__scene_commit: every one of geoms has lambert_triangles
     * (then a hit's geometry needs no look-up to know it). */
    int all_lambert;
    lr__geom *planes; /* infinite planes */
    size_t n_planes;
    lr__v3 ambient;    /* sum of ambient lights' radiance */
    int ambient_at;    /* lights[] index of the first ambient light, or -1 */
    int camera_gltf;   /* the camera came from a glTF ("camera": true) */
    lr__v3 background; /* radiance of escaping rays */
    /* The "environment" map (NULL: the uniform background), and where it
     * came from, for the JSON writer. */
    lr__envmap *env;
    /* Area lights, chosen in proportion to power (cdf[i] = sum of the
     * first i + 1 powers / total); light.c. */
    lr__emitter *emitters;
    double *emitter_cdf;
    size_t n_emitters;
    /* The area lights together, for the pick among kinds of light
     * (light.c): their power pi x sum(area x luminance), its centroid,
     * and the radius about it that holds every emitter. */
    double emit_power;
    lr__v3 emit_centre;
    double emit_radius;
    size_t n_primitives;
    double extent; /* largest coordinate magnitude in the scene */
    /* The least push of a new ray's origin off a surface, in units of
     * 2^-17 (lr__hit's eps = (eps_floor + magnitude) 2^-17): 1, or the
     * scene's size when it is smaller (lr__scene_commit), so that a
     * scene a millionth of a unit across is not pushed through. */
    double eps_floor;
    lr_camera camera;
    lr_render_settings settings;
    char *description;  /* the scene's "description", "" if none */
    lr__file_log files; /* what it was loaded from (lr_scene_files_changed) */
    /* Every texture the materials use, each loaded once; owned. */
    lr__texture **textures;
    size_t n_textures;
    /* For lr__scene_texture: where each texture came from (owned path
     * and srgb flag; NULL path for one made in memory). */
    char **texture_paths;
    int *texture_srgb;
    /* What the loaders read but ignored, one line each ("" if nothing;
     * NULL until the first), for lr_scene_warnings. */
    char *warnings;
    /* Rays lr__trace and lr__occluded did not give Embree (see
     * lr__embree_can_trace), over the scene's life; with plan_cache, what
     * changes while renders share the scene. */
    atomic_ullong skipped_rays;
    /* The planner's camera-space boxes for the last camera it planned
     * (plan.c), behind their own lock: the parts of a split frame share
     * one camera, so only the first part finds them.  NULL until the
     * first plan; set once, atomically (lr__scene_cache_set). */
    lr__scene_cache *plan_cache;
    /* What the scene holds against lr_scene_limits_set (scene_limits.c):
     * triangles placed, and texels of its textures and environment map. */
    uint64_t limit_triangles, limit_texels;
};

/* Sets *slot (a cache field of a scene that renders may share) to c if
 * it is still NULL, atomically, and returns what it holds then: c, or
 * the cache another render set first (the caller then frees c). */
lr__scene_cache *lr__scene_cache_set(lr__scene_cache *const *slot,
                                     lr__scene_cache *c);

/* ---- scene_limits.c: what one scene may hold ------------------------- */

/* LR_OK when n more triangles fit in s under lr_scene_limits_set, else
 * LR_ERR_LIMIT naming `field` (for a loader to ask before it builds the
 * arrays; lr__scene_add_triangles asks again and counts them). */
lr_status lr__scene_limit_triangles(const lr_scene *s, uint64_t n,
                                    const char *field, lr_error *err);
/* Between begin and end, on this thread, the texels a texture or
 * environment map being loaded for s may have (lr__texel_room:
 * UINT64_MAX when there is no limit): the decoders check an image's
 * declared size with lr__texel_room_check before they allocate
 * (LR_ERR_LIMIT, the message headed by `name`; both in texture.h).
 * s->limit_texels counts what was kept (scene_texture.c, scene_load.c). */
void lr__texel_room_begin(const lr_scene *s);
void lr__texel_room_end(void);

/* ---- scene.c: Embree side --------------------------------------------- */

/* Creates the device and an empty Embree scene in `s` (zeroed before but
 * for s->not_robust). */
lr_status lr__scene_begin(lr_scene *s, lr_error *err);
/* The flags both of s's Embree scenes are built with. */
enum RTCSceneFlags lr__scene_flags(const lr_scene *s);
/* Adds a triangle mesh; copies the arrays.  `corner_normals` (9 per
 * triangle) is taken over by the scene (freed with it) and may be NULL.
 * The triangles count against lr_scene_limits_set: beyond it,
 * LR_ERR_LIMIT naming `field` (the JSON path that placed the mesh; NULL
 * or "" for none) and nothing added. */
lr_status lr__scene_add_triangles(lr_scene *s, const float *vertices,
                                  size_t n_vertices, const unsigned *indices,
                                  size_t n_triangles, float *corner_normals,
                                  int material, const char *field,
                                  lr_error *err);
lr_status lr__scene_add_sphere(lr_scene *s, lr__v3 center, double radius,
                               int material, lr_error *err);
lr_status lr__scene_add_plane(lr_scene *s, lr__v3 point, lr__v3 normal,
                              int material, lr_error *err);
/* A texture for the scene's materials: the file at `path` decoded with
 * `srgb` (lr__texture_load), loaded once per (path, srgb) and kept by
 * the scene (freed with it).  NULL with err filled on error. */
lr__texture *lr__scene_texture(lr_scene *s, const char *path, int srgb,
                               lr_error *err);
/* The same with messages naming the file as `shown`. */
lr__texture *lr__scene_texture_named(lr_scene *s, const char *path,
                                     const char *shown, int srgb,
                                     lr_error *err);
/* Takes over a texture made in memory: freed with the scene.  Returns
 * LR_OK, or LR_ERR_NOMEM when it could not be recorded (then it is freed
 * at once, and the caller reports the error). */
lr_status lr__scene_texture_add(lr_scene *s, lr__texture *t);

/* Appends a line to s->warnings (dropped when out of memory: a warning
 * never fails a load). */
void lr__scene_warn(lr_scene *s, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* Commits the Embree scene: no more geometry after this.  What the
 * integrators sample and trace beyond it (the emitter list, the path
 * tracer's sphere scene) they build in their own prepare step
 * (lr__integrators_prepare, integrator.h). */
lr_status lr__scene_commit(lr_scene *s, lr_error *err);
/* The configuration string scenes give rtcNewDevice (NULL: the
 * environment's LENSRAY_EMBREE_CONFIG, and without it Embree's defaults,
 * the best code for this CPU).  The tests set it to run Embree's code
 * for other CPUs ("isa=avx2", "isa=sse4.2"); tools/isa-matrix.sh sets
 * the variable. */
extern const char *lr__embree_config;

/* The texture coordinates of triangle `prim` of g at Embree's
 * barycentrics (bu, bv) (the point (1 - bu - bv) a + bu b + bv c): the
 * corners' uv interpolated alike.  Returns 0 when g has none.  The one
 * formula for the scalar hit, the packet lanes and sampled light points,
 * so that all three see the same texel. */
static inline int lr__triangle_uv(const lr__geom *g, unsigned prim, double bu,
                                  double bv, double uv[2])
{
    if (g->corner_uv == NULL)
        return 0;
    const float *t = &g->corner_uv[6 * (size_t)prim];
    double w = 1.0 - bu - bv;
    uv[0] = w * t[0] + bu * t[2] + bv * t[4];
    uv[1] = w * t[1] + bu * t[3] + bv * t[5];
    return 1;
}


/* The shading normal of triangle `prim` of g (a mesh with tangents) bent
 * by its material's normal map at uv: ns_front is the unit shading normal
 * on the front side.  Returns the unit bent normal on the front side, or
 * ns_front where the map says nothing usable (material.c). */
lr__v3 lr__normal_mapped(const lr__geom *g, const lr__material *m,
                         unsigned prim, const double uv[2], lr__v3 ns_front);

/* The tangents of lr__geom (6 floats per triangle), or NULL when out of
 * memory (material.c). */
float *lr__triangle_tangents(const lr__geom *g);

/* Material `material` at texture coordinates uv: the scene's own record
 * when it has no texture (or has_uv is 0: the factors alone), else *tmp
 * filled with the factors times the textures.  Valid while the scene and
 * *tmp are.  (Inline: every hit asks, and untextured scenes must not pay
 * a call for it.) */
static inline const lr__material *lr__material_at(const lr_scene *s,
                                                  int material, int has_uv,
                                                  const double uv[2],
                                                  lr__material *tmp)
{
    const lr__material *m = &s->materials[material];
    if (!has_uv || !lr__material_textured(m))
        return m;
    return lr__material_textures(m, uv, tmp);
}

#endif
