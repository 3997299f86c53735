/*
 * scene.h: the loaded scene as the renderer sees it.  Built by
 * scene_load.c (validation) and scene.c (Embree), read-only afterwards.
 */
#ifndef LR_SCENE_H
#define LR_SCENE_H

#include "internal.h"
#include "vec.h"

#include "texture.h"

#include <embree3/rtcore.h>
#include <stdatomic.h>

/* An affine map of texture coordinates (lensray's: v up), applied before
 * a lookup: u' = m[0] u + m[1] v + m[2], v' = m[3] u + m[4] v + m[5];
 * `on` 0 is the identity.  glTF's KHR_texture_transform (gltf.c). */
typedef struct lr__uv_xf {
    int on;
    double m[6];
} lr__uv_xf;

typedef struct lr__material {
    char *name;       /* owned */
    lr__v3 diffuse;   /* Lambertian albedo: BRDF = diffuse / pi */
    lr__v3 specular;  /* normalised Phong weight */
    double shininess; /* Phong exponent */
    lr__v3 reflect;   /* perfect mirror weight */
    lr__v3 transmit;  /* dielectric weight (refraction + its Fresnel) */
    double ior;       /* index of refraction inside the object */
    lr__v3 emission;  /* radiance leaving the front side (area light) */
    /* GGX alpha of the mirror and glass lobes (0: smooth).  Rough
     * lobes are the path integrator's; Whitted treats them as smooth. */
    double roughness;
    /* Textures (texture.h) multiply the factors above, as glTF's factors
     * do: diffuse x the texture's RGB, emission x RGB, roughness (an
     * alpha) x r^2 where r, the roughness_channel (0 = R; glTF packs
     * roughness in G = 1), is a perceptual roughness as in glTF.  NULL:
     * none.  Not owned: the scene owns them (lr_scene.textures). */
    lr__texture *diffuse_tex, *emission_tex, *roughness_tex;
    int roughness_channel;
    /* A glTF metallic-roughness material whose textures vary its metal
     * (gltf.c): when pbr_split, lr__material_textures splits the base
     * colour b = base x base_tex's RGB by the metallic m = metal x
     * metal_tex's B (glTF packs metalness in B) point by point:
     * reflect = m b, diffuse = (1 - m)(1 - trans) b, transmit =
     * (1 - m) trans b (the glTF 2.0 specification, appendix B).  The
     * factors above hold the untextured split.  Textures not owned. */
    int pbr_split;
    lr__v3 base;
    double metal, trans;
    lr__texture *base_tex, *metal_tex;
    /* The coordinates of each slot's lookups: the colour (diffuse_tex or
     * base_tex), the emission, and roughness_tex and metal_tex (glTF
     * packs both in one texture). */
    lr__uv_xf xf_colour, xf_emission, xf_rough;
    /* A tangent-space normal map (glTF's normalTexture, linear RGB:
     * n = 2 c - 1, x and y times normal_scale), on triangle meshes with
     * texture coordinates; it bends the shading normal (trace.c). */
    lr__texture *normal_tex;
    double normal_scale;
    lr__uv_xf xf_normal;
    /* The texture files as the scene JSON wrote them, for the writer
     * (json_write.c); NULL when none.  Owned. */
    char *diffuse_file, *emission_file, *roughness_file;
} lr__material;

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

/* envmap.c, for the planner's rare-light bound: a bound on the largest
 * channel of the radiance the map shows in any direction within angle
 * `alpha` (radians) of unit direction `axis`, never below a lookup there
 * (conservative: whole runs of texels, and whole rows near a pole); and
 * the map's largest value anywhere. */
double lr__envmap_max_in_cone(const lr__envmap *e, lr__v3 axis, double alpha);
double lr__envmap_max(const lr__envmap *e);
/* envmap.c, for the light side (light_trace.c): the map's sun, a cone
 * (unit axis *dir, cos of its half-angle *cos_a) holding every texel
 * within LR__ENV_SUN_MAX of the brightest whose luminance is at least
 * 1 / LR__ENV_SUN_RATIO of its, with a margin of the bilinear lookup's
 * spread; 0 when that cone would be wider than LR__ENV_SUN_MAX (no small
 * bright source to speak of).  Found when the map is loaded. */
int lr__envmap_sun(const lr__envmap *e, lr__v3 *dir, double *cos_a);
#define LR__ENV_SUN_MAX 0.25
#define LR__ENV_SUN_RATIO 64.0

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
    lr__v3 background; /* radiance of escaping rays */
    /* The "environment" map (NULL: the uniform background), and where it
     * came from, for the JSON writer. */
    lr__envmap *env;
    /* Area lights, chosen in proportion to power (cdf[i] = sum of the
     * first i + 1 powers / total); light.c. */
    lr__emitter *emitters;
    double *emitter_cdf;
    size_t n_emitters;
    size_t n_primitives;
    double extent; /* largest coordinate magnitude in the scene */
    lr_camera camera;
    lr_render_settings settings;
    char *description; /* the scene's "description", "" if none */
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
};

/* Sets *slot (a cache field of a scene that renders may share) to c if
 * it is still NULL, atomically, and returns what it holds then: c, or
 * the cache another render set first (the caller then frees c). */
lr__scene_cache *lr__scene_cache_set(lr__scene_cache *const *slot,
                                     lr__scene_cache *c);

/* ---- scene.c: Embree side --------------------------------------------- */

/* Creates the device and an empty Embree scene in `s` (zeroed before but
 * for s->not_robust). */
lr_status lr__scene_begin(lr_scene *s, lr_error *err);
/* The flags both of s's Embree scenes are built with. */
enum RTCSceneFlags lr__scene_flags(const lr_scene *s);
/* Adds a triangle mesh; copies the arrays.  `corner_normals` (9 per
 * triangle) is taken over by the scene (freed with it) and may be NULL. */
lr_status lr__scene_add_triangles(lr_scene *s, const float *vertices,
                                  size_t n_vertices, const unsigned *indices,
                                  size_t n_triangles, float *corner_normals,
                                  int material, lr_error *err);
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
/* Commits the Embree scene: no more geometry after this.  Builds the
 * emitter list (lr__emitters_build). */
lr_status lr__scene_commit(lr_scene *s, lr_error *err);
/* The configuration string scenes give rtcNewDevice (NULL: the
 * environment's LENSRAY_EMBREE_CONFIG, and without it Embree's defaults,
 * the best code for this CPU).  The tests set it to run Embree's code
 * for other CPUs ("isa=avx2", "isa=sse4.2"); tools/isa-matrix.sh sets
 * the variable. */
extern const char *lr__embree_config;

/* ---- tracing (trace.c) ------------------------------------------------ */

typedef struct lr__hit {
    double t;
    lr__v3 p;     /* hit position */
    lr__v3 ng;    /* unit geometric normal, facing the ray's origin */
    lr__v3 ns;    /* unit shading normal, same side as ng */
    int entering; /* 1 if the ray hit the outside (front) surface */
    int material;
    double eps;    /* how far to push a new ray's origin off p */
    long geom;     /* Embree geometry ID; -1 for an infinite plane */
    unsigned prim; /* triangle index in it */
    /* Texture coordinates (lr__triangle_uv, lr__sphere_uv), computed
     * only where the material has a texture; has_uv 0 otherwise, on an
     * infinite plane and on a mesh without them. */
    int has_uv;
    double uv[2];
} lr__hit;

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

/* A sphere's texture coordinates at unit outward normal n, a lat-long
 * map wrapped like a globe: the image's centre column faces +z, u grows
 * towards +x, its top row is the +y pole:
 * u = 1/2 + atan2(n.x, n.z) / (2 pi), v = 1 - acos(n.y) / pi. */
void lr__sphere_uv(lr__v3 n, double uv[2]);

/* The shading normal of triangle `prim` of g (a mesh with tangents) bent
 * by its material's normal map at uv: ns_front is the unit shading normal
 * on the front side.  Returns the unit bent normal on the front side, or
 * ns_front where the map says nothing usable (material.c). */
lr__v3 lr__normal_mapped(const lr__geom *g, const lr__material *m,
                         unsigned prim, const double uv[2], lr__v3 ns_front);

/* The tangents of lr__geom (6 floats per triangle), or NULL when out of
 * memory (material.c). */
float *lr__triangle_tangents(const lr__geom *g);

/* ---- materials at a hit (material.c) ---------------------------------- */

/* Whether a material has any texture. */
static inline int lr__material_textured(const lr__material *m)
{
    return m->diffuse_tex != NULL || m->emission_tex != NULL ||
           m->roughness_tex != NULL || m->base_tex != NULL ||
           m->metal_tex != NULL || m->normal_tex != NULL;
}

/* *tmp = m with its textures applied at uv; returns tmp (material.c). */
const lr__material *lr__material_textures(const lr__material *m,
                                          const double uv[2],
                                          lr__material *tmp);

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
static inline const lr__material *
lr__hit_material(const lr_scene *s, const lr__hit *h, lr__material *tmp)
{
    return lr__material_at(s, h->material, h->has_uv, h->uv, tmp);
}

/* Closest hit along org + t dir with t in (0, tfar); dir need not be unit
 * length but t is in its units.  Returns 1 on a hit. */
int lr__trace(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
              lr__hit *hit);
/* Which geometry lr__trace's hit would be on, without completing the
 * hit: its index, -1 for an infinite plane, -2 for none. */
long lr__trace_geom(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar);
/* 1 if anything blocks org + t dir for t in (0, tfar). */
int lr__occluded(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar);
/* The closest hits of lanes 0..n-1 of a packet of camera rays (Embree's
 * answer in rh, coherent), counted in *rays. */
void lr__intersect16(const lr_scene *s, struct RTCRayHit16 *rh, int n,
                     uint64_t *rays);

/* The path integrator's packets (spheres.c): rtcIntersect16 and
 * rtcOccluded16 on the scene, the spheres met in double when it has a
 * few; the same answers (a sphere hit's t is solved again by
 * lr__hit_complete).  lr__spheres_build, at commit, makes the scene
 * without spheres. */
lr_status lr__spheres_build(lr_scene *s, lr_error *err);
/* 0: scenes loaded from now on keep Embree's spheres (for tests). */
extern int lr__few_spheres_enabled;
/* The camera rays of a packet of n lanes (lr__intersect16, or in a scene
 * of a few primitives lr__paths_intersect16: the same hits as
 * continuation rays find). */
void lr__paths_camera16(const lr_scene *s, struct RTCRayHit16 *rh, int n,
                        uint64_t *rays);

/* few_triangles.c.  Fills s->few_tris and returns 1 if the scene's
 * Embree geometries are spheres and 1 to LR__FEW_TRIANGLES triangles
 * (and lr__few_triangles_enabled); else leaves few_tris.n 0 and returns
 * 0.  At commit, by lr__spheres_build. */
int lr__few_triangles_build(lr_scene *s);
/* 0: scenes loaded from now on leave their triangles to Embree (tests). */
extern int lr__few_triangles_enabled;
/* Rays packed to the front, in double (spheres.c and path16.c fill
 * it): entry c is packet lane lane[c]'s ray, c < m; entries m .. m8 - 1
 * (m8: m rounded up to a multiple of 8, the lane loops' step) hold rays
 * that meet nothing (tnear 1, tfar 0).  The lane loops then cost what
 * the live lanes need: on the Cornell box a continuation packet had 10.6
 * live lanes of 16 on average, a shadow packet 7.4.  A bounce's shadow
 * and continuation rays go in one (lr__paths_trace_packed), so up to
 * 32. */
#define LR__PACKED 32
typedef struct lr__rays_packed {
    int m, m8;
    int lane[LR__PACKED];
    double ox[LR__PACKED], oy[LR__PACKED], oz[LR__PACKED];
    double dx[LR__PACKED], dy[LR__PACKED], dz[LR__PACKED];
    double tn[LR__PACKED], tf[LR__PACKED];
} lr__rays_packed;
/* Whether the scene's path packets skip Embree altogether (few_tris
 * holds its triangles), so that lr__paths_occluded_packed serves it. */
static inline int lr__paths_packed(const lr_scene *s)
{
    return s->few_tris.n > 0;
}
/* occ[c] = 1 if P's entry c meets a sphere or triangle at t in (tnear,
 * tfar), else 0, in a scene lr__paths_packed accepts. */
void lr__paths_occluded_packed(const lr_scene *s, lr__rays_packed *P,
                               double occ[LR__PACKED]);
/* A bounce's rays at once, in a scene lr__paths_packed accepts: entries
 * c < ns are shadow rays (occ[c] as lr__paths_occluded_packed gives
 * it), the others continuation rays, whose nearest hits are written into
 * rh's lanes as lr__paths_intersect16 writes them (geomID, primID, u, v,
 * tfar; geomID RTC_INVALID_GEOMETRY_ID for a miss; rh's rays neither
 * read nor written). */
void lr__paths_trace_packed(const lr_scene *s, lr__rays_packed *P, int ns,
                            struct RTCRayHit16 *rh, double occ[LR__PACKED]);
/* The nearest triangle of each entry with t in (tn, tf): tf[c] becomes
 * its t, tri[c] its index in T (geom, prim), u[c], v[c] its
 * barycentrics (Embree's convention); entries without a hit keep tf and
 * get tri -1.  Entries c < c0 (shadow rays) get only tri >= 0 for a hit
 * (the shape's index) and no barycentrics. */
void lr__few_triangles_intersect(const lr__few_triangles *T, lr__rays_packed *P,
                                 int c0, double tri[LR__PACKED],
                                 double u[LR__PACKED], double v[LR__PACKED]);
/* occ[c] = 1 if entry c meets a triangle at t in (tn, tf), else 0. */
void lr__few_triangles_occluded(const lr__few_triangles *T,
                                const lr__rays_packed *P,
                                double occ[LR__PACKED]);
void lr__paths_intersect16(const lr_scene *s, const int *valid,
                           struct RTCIntersectContext *ctx,
                           struct RTCRayHit16 *rh);
void lr__paths_occluded16(const lr_scene *s, const int *valid,
                          struct RTCIntersectContext *ctx, struct RTCRay16 *r);

/* Packets.  lr__shadow_ray16 fills one lane of a 16-wide packet exactly
 * as lr__occluded fills a single ray;
 * lr__hit_complete turns Embree's answer for one ray (geom_id
 * RTC_INVALID_GEOMETRY_ID when it found nothing) into the same hit
 * lr__trace returns, infinite planes included; lr__planes_block is the
 * infinite planes' part of lr__occluded. */
void lr__shadow_ray16(struct RTCRay16 *r, int lane, lr__v3 org, lr__v3 dir,
                      double tfar);
int lr__hit_complete(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar,
                     unsigned geom_id, unsigned prim_id, float bu, float bv,
                     float t_hit, lr__hit *hit);
/* Gives the lanes of r that valid masks off (valid[i] == 0) the harmless
 * ray lane_disabled gives (origin 0, direction +z, tnear 1 > tfar 0).
 * Call it before rtcOccluded16 on a packet whose masked lanes hold
 * anything: Embree's AVX2 code (on a CPU without AVX-512) checks those
 * lanes too, and a NaN there aborts the process ("Assertion
 * `all(valid, ray.valid())' failed" in occludedCoherent). */
void lr__ray16_quiet_lanes(struct RTCRay16 *r, const int *valid);
int lr__planes_block(const lr_scene *s, lr__v3 org, lr__v3 dir, double tfar);

/* The triangle hits of a packet in structure-of-arrays form, in double:
 * what lr__hit_complete computes for a triangle, lane by lane in loops the
 * compiler vectorises.  Every operation is the one the scalar code does,
 * in the same order, without FMA contraction (-ffp-contract=off), so each
 * lane's result is the scalar result to the bit (the test suite renders
 * scenes both ways and compares bytes).  Lanes that were not gathered
 * keep what they held (zeros, or an earlier packet's triangle): the
 * vector loops compute on them too, and nobody reads those results, so a
 * caller zeroes the struct once and then reuses it. */
typedef struct lr__hits16 {
    double ng[3][16]; /* the triangle's unit normal (lr__geom.face_ng) */
    float n[9][16];   /* corner normals (flat meshes: not written) */
    float smooth[16]; /* 1 with corner normals */
    /* Results. */
    double px[16], py[16], pz[16]; /* hit position */
    double gx[16], gy[16], gz[16]; /* ng, facing the ray */
    double sx[16], sy[16], sz[16]; /* ns */
    double eps[16];
} lr__hits16;

/* Copies lane i's triangle (geometry rh->hit.geomID[i], a triangle mesh
 * with lambert_triangles set) into h.  (Inline: it runs for every lane of
 * every packet, and as a call it cost 8% of a render.) */
static inline void lr__hits16_gather(const lr_scene *s,
                                     const struct RTCRayHit16 *rh, int i,
                                     lr__hits16 *h)
{
    const lr__geom *g = &s->geoms[rh->hit.geomID[i]];
    unsigned prim = rh->hit.primID[i];
    const double *ng = &g->face_ng[3 * (size_t)prim];
    h->ng[0][i] = ng[0];
    h->ng[1][i] = ng[1];
    h->ng[2][i] = ng[2];
    if (g->corner_normals != NULL) {
        const float *n = &g->corner_normals[9 * (size_t)prim];
        for (int k = 0; k < 9; k++)
            h->n[k][i] = n[k];
        h->smooth[i] = 1.0f;
    } else {
        /* n keeps what it held: lr__hits16_complete takes ng in this
         * lane whatever it computes from n. */
        h->smooth[i] = 0.0f;
    }
}

/* Completes all sixteen lanes from the rays and hits in rh. */
void lr__hits16_complete(const struct RTCRayHit16 *rh, lr__hits16 *h);

/* The origin for a ray leaving the hit point towards `dir`: pushed along
 * the geometric normal, on the side dir points to, by hit->eps, which
 * grows with the magnitude of the hit position and the ray's length
 * (float rounding grows with both), so the new ray cannot hit the surface
 * it starts on. */
lr__v3 lr__offset_origin(const lr__hit *hit, lr__v3 dir);

/* 1 if Embree accepts a ray with this origin and direction: every
 * component finite and within 1.8e18 (Embree aborts the process on
 * others).  lr__trace and lr__occluded check it and treat a ray that
 * fails as missing Embree's geometry (the infinite planes are still
 * tested), counting it in lr__scene_skipped_rays; callers that fill
 * packets (lr__shadow_ray16) must check it themselves. */
#define LR__EMBREE_MAX_COORD 1.8e18
static inline int lr__embree_can_trace(lr__v3 org, lr__v3 dir)
{
    /* Written so that NaN fails; & rather than && (no branch each). */
    const double m = LR__EMBREE_MAX_COORD;
    return (fabs(org.x) <= m) & (fabs(org.y) <= m) & (fabs(org.z) <= m) &
           (fabs(dir.x) <= m) & (fabs(dir.y) <= m) & (fabs(dir.z) <= m);
}
unsigned long long lr__scene_skipped_rays(const lr_scene *s);

/* A sphere's t along org + t dir, solved again in double near the
 * intersector's t: Embree finds spheres in float, so on a big sphere its
 * t can be far off the surface (0.1 units on a radius of 1e6).  The
 * quadratic in the cancellation-free form (|oc| - r)(|oc| + r) and
 * q = -(b + sign(b) sqrt(disc)); the root nearest t, if it lies in
 * (0, tmax); otherwise t itself.  lr__hit_complete and path16.c's vector
 * bounce both use it, so that their hits agree to the bit. */
static inline double lr__sphere_refine_t(const lr__geom *g, lr__v3 org,
                                         lr__v3 dir, double t, double tmax)
{
    lr__v3 oc = v3_sub(org, g->center);
    double a = v3_dot(dir, dir), b = v3_dot(oc, dir);
    double l = v3_len(oc);
    double c = (l - g->radius) * (l + g->radius);
    double disc = b * b - a * c;
    if (disc >= 0.0 && a > 0.0) {
        double q = -(b + copysign(sqrt(disc), b));
        double r1 = q / a, r2 = q != 0.0 ? c / q : r1;
        double best = fabs(r1 - t) < fabs(r2 - t) ? r1 : r2;
        if (best > 0.0 && best < tmax)
            t = best;
    }
    return t;
}

#endif
