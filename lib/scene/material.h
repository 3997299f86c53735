/*
 * material.h: a surface's material as the renderer reads it (material.c,
 * material_json.c): its lobes' weights, emission and textures, and the
 * texture lookups that turn a point's coordinates into its factors.
 */
#ifndef LR_MATERIAL_H
#define LR_MATERIAL_H

#include "util/internal.h"
#include "util/vec.h"

#include "scene/texture.h"

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

/* A sphere's texture coordinates at unit outward normal n, a lat-long
 * map wrapped like a globe: the image's centre column faces +z, u grows
 * towards +x, its top row is the +y pole:
 * u = 1/2 + atan2(n.x, n.z) / (2 pi), v = 1 - acos(n.y) / pi. */
void lr__sphere_uv(lr__v3 n, double uv[2]);

#endif
