/*
 * gltf.c: a glTF 2.0 file into the scene (gltf.h): checked (gltf_check.c),
 * its meshes decoded by libassimp (gltf_assimp.c) and placed by the node
 * transforms (gltf_nodes.c), its materials mapped to lensray's here.
 *
 * Material mapping (glTF 2.0 spec, appendix B "BRDF implementation"; the
 * table is in docs/gltf.md).  With base colour b, metallic m, perceptual
 * roughness r and transmission t:
 *   reflect  = m b            (a conductor: a mirror tinted by b)
 *   diffuse  = (1 - m)(1 - t) b
 *   transmit = (1 - m) t b    (KHR_materials_transmission; ior from
 *                              KHR_materials_ior, default 1.5)
 *   roughness (GGX alpha) = r^2  (the spec's alpha = roughness^2)
 *   emission = emissiveFactor x KHR_materials_emissive_strength
 * The dielectric's 4 % specular layer (F0 = 0.04) is left out: lensray's
 * diffuse lobe has no Fresnel coat to put it on.
 * Textures (texture.h) multiply the factors, as in glTF: baseColorTexture
 * the base colour b (sRGB), emissiveTexture the emission (sRGB), and the
 * metallicRoughnessTexture's G the perceptual roughness and its B the
 * metallic m (linear; lensray squares the roughness).  The split above
 * is then made at each point (material.h, pbr_split).
 */
#include "scene/gltf/gltf_doc.h"
#include "json/json_util.h"
#include "scene/texture.h"

#include <assimp/scene.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void lr__gltf_warn(lr_scene *s, const lr__gltf_doc *d, const char *fmt, ...)
{
    char what[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    lr__scene_warn(s, "%s: %s", d->shown, what);
}

/* ---- materials ------------------------------------------------------------ */

/* A factor in [0, hi] (absent: dflt). */
static lr_status factor(const lr__gltf_doc *d, const cJSON *o, const char *p,
                        const char *key, double hi, double dflt, double *out,
                        lr_error *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    *out = dflt;
    if (v == NULL)
        return LR_OK;
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0 && v->valuedouble <= hi))
        return lr__gltf_fail(d, err, "%s.%s must be a number from 0 to %g", p,
                             key, hi);
    *out = v->valuedouble;
    return LR_OK;
}

static lr_status colour(const lr__gltf_doc *d, const cJSON *o, const char *p,
                        const char *key, int n, double *out, lr_error *err)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, key);
    if (a == NULL)
        return LR_OK;
    int ok = cJSON_IsArray(a) && cJSON_GetArraySize(a) == n;
    for (int i = 0; ok && i < n; i++) {
        const cJSON *v = cJSON_GetArrayItem(a, i);
        ok = cJSON_IsNumber(v) && v->valuedouble >= 0 && v->valuedouble <= 1;
        out[i] = ok ? v->valuedouble : 0;
    }
    if (!ok)
        return lr__gltf_fail(d, err, "%s.%s must be %d numbers from 0 to 1", p,
                             key, n);
    return LR_OK;
}

/* `n` numbers of magnitude at most 1e6 at o.key (absent: left as they
 * are). */
static lr_status numbers(const lr__gltf_doc *d, const cJSON *o, const char *p,
                         const char *key, int n, double *out, lr_error *err)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, key);
    if (a == NULL)
        return LR_OK;
    int ok = n == 1 ? cJSON_IsNumber(a)
                    : cJSON_IsArray(a) && cJSON_GetArraySize(a) == n;
    for (int i = 0; ok && i < n; i++) {
        const cJSON *v = n == 1 ? a : cJSON_GetArrayItem(a, i);
        ok = cJSON_IsNumber(v) && fabs(v->valuedouble) <= 1e6;
        out[i] = ok ? v->valuedouble : 0;
    }
    if (!ok)
        return lr__gltf_fail(d, err, "%s.%s must be %s from -1e6 to 1e6", p,
                             key, n == 1 ? "a number" : "2 numbers");
    return LR_OK;
}

/* KHR_texture_transform of a textureInfo at `p` as lensray's map.  The
 * extension maps glTF's coordinates (v down the image) by translation x
 * rotation x scale, the rotation as every implementation turns it (the
 * Khronos sample viewer, three.js, Babylon, Cesium, Blender's importer;
 * the spec's GLSL listing, read column by column, turns it the other way,
 * glTF issue #1563, and lensray had followed the listing):
 *   u' = cos r sx u + sin r sy v + ox,  v' = -sin r sx u + cos r sy v + oy;
 * lensray's v is 1 - glTF's on both sides, which the constants absorb. */
static lr_status uv_transform(const lr__gltf_doc *d, const cJSON *ext,
                              const char *p, lr__uv_xf *xf, lr_error *err)
{
    char q[160];
    snprintf(q, sizeof q, "%s.extensions.KHR_texture_transform", p);
    if (!cJSON_IsObject(ext))
        return lr__gltf_fail(d, err, "%s must be an object", q);
    double off[2] = {0, 0}, sc[2] = {1, 1}, rot = 0;
    LR_TRY(numbers(d, ext, q, "offset", 2, off, err));
    LR_TRY(numbers(d, ext, q, "scale", 2, sc, err));
    LR_TRY(numbers(d, ext, q, "rotation", 1, &rot, err));
    double c = cos(rot), s = sin(rot);
    double a = c * sc[0], b = s * sc[1], e = -s * sc[0], f = c * sc[1];
    /* With v = 1 - w (w glTF's): u' = a u + b (1 - v) + ox, and
     * v' = 1 - (e u + f (1 - v) + oy). */
    xf->on = 1;
    xf->m[0] = a, xf->m[1] = -b, xf->m[2] = b + off[0];
    xf->m[3] = -e, xf->m[4] = f, xf->m[5] = 1 - f - off[1];
    return LR_OK;
}

/* Warns once per material about each part lensray ignores. */
static void warn_ignored(lr_scene *s, const lr__gltf_doc *d, const cJSON *m,
                         const char *p)
{
    static const char *const slots[] = {"occlusionTexture", NULL};
    for (int k = 0; slots[k]; k++)
        if (cJSON_GetObjectItemCaseSensitive(m, slots[k]))
            lr__gltf_warn(s, d, "%s.%s is ignored", p, slots[k]);
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(m, "alphaMode");
    if (cJSON_IsString(mode) && strcmp(mode->valuestring, "OPAQUE") != 0)
        lr__gltf_warn(s, d, "%s.alphaMode %.20s is ignored (rendered opaque)",
                      p, mode->valuestring);
    const cJSON *ext = cJSON_GetObjectItemCaseSensitive(m, "extensions");
    for (const cJSON *e = cJSON_IsObject(ext) ? ext->child : NULL; e;
         e = e->next)
        if (strcmp(e->string, "KHR_materials_emissive_strength") != 0 &&
            strcmp(e->string, "KHR_materials_transmission") != 0 &&
            strcmp(e->string, "KHR_materials_ior") != 0)
            lr__gltf_warn(s, d, "%s.extensions.%.60s is ignored", p, e->string);
}

/* The bytes of images[i]: a file or data: URI (read by gltf_check.c), or
 * a bufferView. */
static int image_bytes(const lr__gltf_doc *d, int i, const unsigned char **b,
                       size_t *n)
{
    int ni, nv;
    const cJSON *im = cJSON_GetArrayItem(lr__gltf_array(d->root, "images", &ni),
                                         i);
    const cJSON *uri = cJSON_GetObjectItemCaseSensitive(im, "uri");
    if (cJSON_IsString(uri)) {
        const lr__gltf_blob *bl = lr__gltf_blob_find(d, uri->valuestring);
        if (bl == NULL)
            return 0;
        *b = bl->data;
        *n = bl->n;
        return 1;
    }
    const cJSON *v = cJSON_GetArrayItem(
        lr__gltf_array(d->root, "bufferViews", &nv),
        (int)cJSON_GetNumberValue(
            cJSON_GetObjectItemCaseSensitive(im, "bufferView")));
    const cJSON *off = cJSON_GetObjectItemCaseSensitive(v, "byteOffset");
    size_t buf = (size_t)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(v, "buffer"));
    *b = d->buffers[buf].data + (size_t)(off ? off->valuedouble : 0);
    *n = (size_t)cJSON_GetNumberValue(
        cJSON_GetObjectItemCaseSensitive(v, "byteLength"));
    return 1;
}

/* The texture of the textureInfo `info` (materials[..].SLOT), decoded
 * once per image and colour space and kept by the scene; *out NULL when
 * the slot is empty or its texture has no image. */
static lr_status slot_texture(lr_scene *s, lr__gltf_doc *d, const cJSON *info,
                              const char *p, int srgb, lr__texture **out,
                              lr__uv_xf *xf, lr_error *err)
{
    *out = NULL;
    memset(xf, 0, sizeof *xf);
    if (!cJSON_IsObject(info))
        return LR_OK;
    int nt;
    const cJSON *tex = cJSON_GetArrayItem(
        lr__gltf_array(d->root, "textures", &nt),
        (int)cJSON_GetNumberValue(
            cJSON_GetObjectItemCaseSensitive(info, "index")));
    const cJSON *src = cJSON_GetObjectItemCaseSensitive(tex, "source");
    if (src == NULL) {
        /* KTX2 (KHR_texture_basisu), WebP or DDS without a fallback: the
         * image is only in an extension, which the warning names. */
        const cJSON *ext = cJSON_GetObjectItemCaseSensitive(tex, "extensions");
        const cJSON *e = cJSON_IsObject(ext) ? ext->child : NULL;
        lr__gltf_warn(s, d,
                      "%s: its texture has no source image%s%.60s%s: "
                      "ignored",
                      p, e ? ", only one in " : "", e ? e->string : "",
                      e ? ", which lensray does not read" : "");
        return LR_OK;
    }
    const cJSON *tc = cJSON_GetObjectItemCaseSensitive(info, "texCoord");
    if (tc != NULL && cJSON_GetNumberValue(tc) != 0)
        lr__gltf_warn(s, d, "%s.texCoord: only TEXCOORD_0 is read", p);
    const cJSON *ext = lr__gltf_member(info, "extensions",
                                       "KHR_texture_transform");
    if (ext != NULL) {
        LR_TRY(uv_transform(d, ext, p, xf, err));
        const cJSON *etc = cJSON_GetObjectItemCaseSensitive(ext, "texCoord");
        if (etc != NULL && cJSON_GetNumberValue(etc) != 0)
            lr__gltf_warn(s, d,
                          "%s.extensions.KHR_texture_transform."
                          "texCoord: only TEXCOORD_0 is read",
                          p);
    }
    int ns;
    const cJSON *si = cJSON_GetObjectItemCaseSensitive(tex, "sampler");
    const cJSON *smp = si == NULL
                           ? NULL
                           : cJSON_GetArrayItem(
                                 lr__gltf_array(d->root, "samplers", &ns),
                                 (int)si->valuedouble);
    static const char *const wraps[] = {"wrapS", "wrapT"};
    for (int k = 0; smp && k < 2; k++) {
        const cJSON *w = cJSON_GetObjectItemCaseSensitive(smp, wraps[k]);
        if (w != NULL && cJSON_GetNumberValue(w) != 10497)
            lr__gltf_warn(s, d,
                          "%s: the sampler's %s is ignored (textures "
                          "repeat)",
                          p, wraps[k]);
    }
    /* Lookup is always bilinear: texels meant to stay sharp (pixel art)
     * come out blended. */
    const cJSON *mag = cJSON_GetObjectItemCaseSensitive(smp, "magFilter");
    if (mag != NULL && cJSON_GetNumberValue(mag) == 9728)
        lr__gltf_warn(s, d,
                      "%s: the sampler's magFilter NEAREST is ignored "
                      "(textures are filtered bilinearly)",
                      p);
    int image = (int)src->valuedouble;
    for (size_t i = 0; i < d->n_tex; i++)
        if (d->tex[i].image == image && d->tex[i].srgb == srgb) {
            *out = d->tex[i].t;
            return LR_OK;
        }
    const unsigned char *bytes = NULL;
    size_t n = 0;
    char name[300];
    snprintf(name, sizeof name, "%s: images[%d]", d->shown, image);
    if (!image_bytes(d, image, &bytes, &n))
        return lr__gltf_fail(d, err, "images[%d] has no data", image);
    lr_error e2;
    lr__texel_room_begin(s);
    lr__texture *t = lr__texture_load_memory(bytes, n, name, srgb, &e2);
    lr__texel_room_end();
    if (t == NULL) {
        if (e2.status == LR_ERR_NOMEM)
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        return lr__fail(err, e2.status, d->fp, "%s: %s (for %s)", d->fp,
                        e2.message, p);
    }
    struct lr__gltf_tex *grown = realloc(d->tex,
                                         (d->n_tex + 1) * sizeof *grown);
    if (grown == NULL) {
        lr__texture_free(t);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    d->tex = grown;
    LR_TRY(lr__scene_texture_add(s, t));
    d->tex[d->n_tex].image = image;
    d->tex[d->n_tex].srgb = srgb;
    d->tex[d->n_tex++].t = t;
    *out = t;
    return LR_OK;
}

/* The glTF material `m` (NULL: the spec's default material, 3.9.6) as
 * lensray's, appended to s->materials. */
static lr_status add_material(lr_scene *s, lr__gltf_doc *d, const cJSON *m,
                              int index, lr_error *err)
{
    char p[48];
    snprintf(p, sizeof p, "materials[%d]", index);
    double base[4] = {1, 1, 1, 1}, emissive[3] = {0, 0, 0};
    double metal = 1, rough = 1, strength = 1, trans = 0, ior = 1.5;
    const cJSON *pbr = cJSON_GetObjectItemCaseSensitive(m,
                                                        "pbrMetallicRoughness");
    char q[80];
    snprintf(q, sizeof q, "%s.pbrMetallicRoughness", p);
    LR_TRY(colour(d, pbr, q, "baseColorFactor", 4, base, err));
    LR_TRY(factor(d, pbr, q, "metallicFactor", 1, 1, &metal, err));
    LR_TRY(factor(d, pbr, q, "roughnessFactor", 1, 1, &rough, err));
    LR_TRY(colour(d, m, p, "emissiveFactor", 3, emissive, err));
    snprintf(q, sizeof q, "%s.extensions.KHR_materials_emissive_strength", p);
    LR_TRY(factor(
        d, lr__gltf_member(m, "extensions", "KHR_materials_emissive_strength"),
        q, "emissiveStrength", 1e9, 1, &strength, err));
    snprintf(q, sizeof q, "%s.extensions.KHR_materials_transmission", p);
    LR_TRY(factor(
        d, lr__gltf_member(m, "extensions", "KHR_materials_transmission"), q,
        "transmissionFactor", 1, 0, &trans, err));
    snprintf(q, sizeof q, "%s.extensions.KHR_materials_ior", p);
    LR_TRY(factor(d, lr__gltf_member(m, "extensions", "KHR_materials_ior"), q,
                  "ior", 10, 1.5, &ior, err));
    /* KHR_materials_ior allows 0 to mean "a perfect mirror"; lensray's
     * glass needs ior >= 1. */
    if (ior < 1)
        ior = 1;
    if (m != NULL)
        warn_ignored(s, d, m, p);

    lr__material *grown = realloc(s->materials,
                                  (s->n_materials + 1) * sizeof *grown);
    if (grown == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    s->materials = grown;
    lr__material *mt = &s->materials[s->n_materials];
    memset(mt, 0, sizeof *mt);
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(m, "name");
    char nm[200];
    snprintf(nm, sizeof nm, "%s:%s", d->shown,
             cJSON_IsString(name) ? name->valuestring
             : m != NULL          ? p
                                  : "(default)");
    mt->name = strdup(nm);
    if (mt->name == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    s->n_materials++;
    lr__v3 b = v3(base[0], base[1], base[2]);
    mt->reflect = v3_scale(b, metal);
    mt->diffuse = v3_scale(b, (1 - metal) * (1 - trans));
    mt->transmit = v3_scale(b, (1 - metal) * trans);
    mt->ior = ior;
    mt->roughness = rough * rough;
    mt->emission = v3_scale(v3(emissive[0], emissive[1], emissive[2]),
                            strength);
    /* The textures: slots of this material, decoded (or found) now.  The
     * material is filled in after all of them. */
    lr__texture *base_tex, *emission_tex, *rough_tex, *normal_tex;
    lr__uv_xf xf_colour, xf_emission, xf_rough, xf_normal;
    snprintf(q, sizeof q, "%s.pbrMetallicRoughness.baseColorTexture", p);
    LR_TRY(slot_texture(
        s, d, cJSON_GetObjectItemCaseSensitive(pbr, "baseColorTexture"), q, 1,
        &base_tex, &xf_colour, err));
    snprintf(q, sizeof q, "%s.emissiveTexture", p);
    LR_TRY(slot_texture(s, d,
                        cJSON_GetObjectItemCaseSensitive(m, "emissiveTexture"),
                        q, 1, &emission_tex, &xf_emission, err));
    snprintf(q, sizeof q, "%s.pbrMetallicRoughness.metallicRoughnessTexture",
             p);
    LR_TRY(slot_texture(
        s, d, cJSON_GetObjectItemCaseSensitive(pbr, "metallicRoughnessTexture"),
        q, 0, &rough_tex, &xf_rough, err));
    snprintf(q, sizeof q, "%s.normalTexture", p);
    const cJSON *nt = cJSON_GetObjectItemCaseSensitive(m, "normalTexture");
    LR_TRY(slot_texture(s, d, nt, q, 0, &normal_tex, &xf_normal, err));
    double nscale = 1;
    if (normal_tex != NULL)
        LR_TRY(numbers(d, nt, q, "scale", 1, &nscale, err));
    mt = &s->materials[s->n_materials - 1];
    mt->emission_tex = emission_tex;
    mt->xf_emission = xf_emission;
    mt->roughness_tex = rough_tex;
    mt->roughness_channel = 1;
    mt->xf_rough = xf_rough;
    mt->xf_colour = xf_colour;
    mt->normal_tex = normal_tex;
    mt->normal_scale = nscale;
    mt->xf_normal = xf_normal;
    /* Where metal can vary or be tinted by a texture, the lobes are split
     * point by point (lr__material_textures); without metal, the base
     * colour texture is the diffuse albedo's, as before. */
    if (metal > 0 && (base_tex != NULL || rough_tex != NULL)) {
        mt->pbr_split = 1;
        mt->base = b;
        mt->metal = metal;
        mt->trans = trans;
        mt->base_tex = base_tex;
        mt->metal_tex = rough_tex;
    } else {
        mt->diffuse_tex = base_tex;
    }
    return LR_OK;
}

/* ---- meshes --------------------------------------------------------------- */

typedef struct placer {
    lr_scene *s;
    lr__gltf_doc *d;
    const struct aiScene *sc;
    const lr__xform *world;
    const lr__gltf_options *o;
    int first_material;   /* lensray index of materials[0] */
    int default_material; /* lensray index of the spec's default, or -1 */
    lr__v3 lo, hi;        /* box of the placed vertices */
    size_t skipped;       /* points and lines */
} placer;

static lr_status material_of(placer *pl, unsigned ai, int *out, lr_error *err)
{
    const struct aiMaterial *m = ai < pl->sc->mNumMaterials
                                     ? pl->sc->mMaterials[ai]
                                     : NULL;
    for (unsigned k = 0; m != NULL && k < m->mNumProperties; k++) {
        const struct aiMaterialProperty *pr = m->mProperties[k];
        /* "?mat.name" is an aiString: a 32-bit length, then the text. */
        if (strcmp(pr->mKey.data, "?mat.name") == 0 && pr->mDataLength > 5 &&
            pr->mData[4] == 'm') {
            long i = strtol(pr->mData + 5, NULL, 10);
            int nm;
            lr__gltf_array(pl->d->root, "materials", &nm);
            if (i >= 0 && i < nm) {
                *out = pl->first_material + (int)i;
                return LR_OK;
            }
        }
    }
    if (pl->default_material < 0) {
        LR_TRY(add_material(pl->s, pl->d, NULL, -1, err));
        pl->default_material = (int)pl->s->n_materials - 1;
    }
    *out = pl->default_material;
    return LR_OK;
}

static lr_status add_mesh(placer *pl, const struct aiMesh *am,
                          const lr__xform *x, lr_error *err)
{
    if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) ||
        am->mNumVertices == 0) {
        pl->skipped++;
        return LR_OK;
    }
    /* Every node that draws the mesh places its triangles again: over
     * the scene's limit, stop before the copies (at most mNumFaces). */
    LR_TRY(lr__scene_limit_triangles(pl->s, am->mNumFaces, pl->d->fp, err));
    int material;
    LR_TRY(material_of(pl, am->mMaterialIndex, &material, err));
    size_t nv = am->mNumVertices, nt = 0;
    float *v = malloc(nv * 3 * sizeof *v);
    unsigned *idx = malloc((size_t)am->mNumFaces * 3 * sizeof *idx);
    float *cn = am->mNormals ? malloc((size_t)am->mNumFaces * 9 * sizeof *cn)
                             : NULL;
    /* UVs: TEXCOORD_0, which assimp has already turned to v = 0 at the
     * image's bottom (texture.h's convention); a textured material on a
     * primitive without them samples the texel at (0, 0). */
    const lr__material *mt = &pl->s->materials[material];
    int textured = lr__material_textured(mt);
    const struct aiVector3D *tc = am->mTextureCoords[0];
    float *uv = tc || textured ? calloc((size_t)am->mNumFaces * 6, sizeof *uv)
                               : NULL;
    if (v == NULL || idx == NULL || (am->mNormals && cn == NULL) ||
        ((tc || textured) && uv == NULL)) {
        free(v), free(idx), free(cn), free(uv);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    if (textured && tc == NULL)
        lr__gltf_warn(pl->s, pl->d,
                      "material %s is textured but a mesh "
                      "using it has no TEXCOORD_0: its texels at (0, 0) are "
                      "used",
                      mt->name);
    for (size_t i = 0; i < nv; i++) {
        const struct aiVector3D *q = &am->mVertices[i];
        lr__v3 w = lr__xform_point(x, v3(q->x, q->y, q->z));
        if (!(v3_maxabs(w) <= LR__MAX_NUMBER)) {
            free(v), free(idx), free(cn), free(uv);
            return lr__gltf_fail(pl->d, err,
                                 "a vertex reaches %g from the "
                                 "origin after the transforms, beyond the "
                                 "limit of 1e15",
                                 v3_maxabs(w));
        }
        v[3 * i] = (float)w.x, v[3 * i + 1] = (float)w.y;
        v[3 * i + 2] = (float)w.z;
        pl->lo = v3(fmin(pl->lo.x, w.x), fmin(pl->lo.y, w.y),
                    fmin(pl->lo.z, w.z));
        pl->hi = v3(fmax(pl->hi.x, w.x), fmax(pl->hi.y, w.y),
                    fmax(pl->hi.z, w.z));
    }
    /* A mirroring transform turns counter-clockwise into clockwise:
     * swap two corners to keep the front side outside (as mesh.c). */
    int flip = lr__xform_det(x) < 0;
    for (unsigned f = 0; f < am->mNumFaces; f++) {
        const struct aiFace *fc = &am->mFaces[f];
        if (fc->mNumIndices != 3)
            continue;
        unsigned c[3] = {fc->mIndices[0], fc->mIndices[flip ? 2 : 1],
                         fc->mIndices[flip ? 1 : 2]};
        if (c[0] >= nv || c[1] >= nv || c[2] >= nv)
            continue; /* cannot happen after gltf_check.c; never trusted */
        for (int k = 0; k < 3; k++) {
            idx[3 * nt + (size_t)k] = c[k];
            if (tc != NULL) {
                uv[6 * nt + 2 * (size_t)k] = tc[c[k]].x;
                uv[6 * nt + 2 * (size_t)k + 1] = tc[c[k]].y;
            }
            if (cn == NULL)
                continue;
            const struct aiVector3D *n = &am->mNormals[c[k]];
            lr__v3 w = lr__xform_normal(x, v3(n->x, n->y, n->z));
            /* A zero or broken normal: the face's own, flat shading. */
            if (!v3_finite(w) || !(v3_len(w) > 0.5))
                w = v3(0, 0, 0);
            cn[9 * nt + 3 * (size_t)k] = (float)w.x;
            cn[9 * nt + 3 * (size_t)k + 1] = (float)w.y;
            cn[9 * nt + 3 * (size_t)k + 2] = (float)w.z;
        }
        nt++;
    }
    /* Normals that were zero make the whole mesh flat. */
    for (size_t i = 0; cn != NULL && i < 9 * nt; i += 3)
        if (cn[i] == 0 && cn[i + 1] == 0 && cn[i + 2] == 0) {
            free(cn);
            cn = NULL;
        }
    lr_status st = LR_OK;
    if (nt > 0)
        st = lr__scene_add_triangles(pl->s, v, nv, idx, nt, cn, material,
                                     pl->d->fp, err);
    else
        free(cn);
    /* The scene takes the UVs over once the mesh is in. */
    if (nt > 0 && st == LR_OK)
        pl->s->geoms[pl->s->n_geoms - 1].corner_uv = uv;
    else
        free(uv);
    free(v);
    free(idx);
    return st;
}

static lr_status place_node(placer *pl, const struct aiNode *n, lr_error *err)
{
    /* Only the nodes gltf_assimp.c named "n<index>" carry meshes. */
    if (n->mNumMeshes > 0) {
        char *end = NULL;
        long i = n->mName.data[0] == 'n' ? strtol(n->mName.data + 1, &end, 10)
                                         : -1;
        if (end == NULL || *end != '\0' || i < 0 || i >= pl->d->n_nodes)
            return lr__gltf_fail(pl->d, err,
                                 "libassimp returned a node "
                                 "\"%.40s\" the file does not have",
                                 n->mName.data);
        /* A skinned mesh comes already in the glTF's world
         * (lr__gltf_skinned). */
        lr__xform id = lr__xform_identity();
        lr__xform x = lr__xform_mul(
            &pl->o->place,
            lr__gltf_skinned(pl->d, (int)i) ? &id : &pl->world[i]);
        for (unsigned k = 0; k < n->mNumMeshes; k++)
            if (n->mMeshes[k] < pl->sc->mNumMeshes)
                LR_TRY(add_mesh(pl, pl->sc->mMeshes[n->mMeshes[k]], &x, err));
    }
    for (unsigned c = 0; c < n->mNumChildren; c++)
        LR_TRY(place_node(pl, n->mChildren[c], err));
    return LR_OK;
}

/* Warnings for the parts of the file nothing reads.  Morph targets and
 * skins are read (drawn at the default weights and at the joints' own
 * transforms, gltf_assimp.c); their animation is one of the
 * animations. */
static void warn_unread(lr_scene *s, const lr__gltf_doc *d)
{
    static const char *const top[] = {"animations", NULL};
    for (int k = 0; top[k]; k++)
        if (cJSON_GetObjectItemCaseSensitive(d->root, top[k]))
            lr__gltf_warn(s, d, "%s are ignored", top[k]);
    /* Attributes nothing reads, a warning a kind: the first place and
     * how many primitives have it (a file may have thousands). */
    static const char *const kinds[] = {"COLOR_", "TANGENT"};
    static const char *const why[] = {
        "vertex colours: the material's base colour alone is used",
        "tangents come from each triangle's UVs"};
    char first[2][96] = {"", ""};
    int count[2] = {0, 0}, nm, np;
    const cJSON *meshes = lr__gltf_array(d->root, "meshes", &nm);
    int i = 0;
    for (const cJSON *m = meshes ? meshes->child : NULL; m; m = m->next, i++) {
        const cJSON *prims = lr__gltf_array(m, "primitives", &np);
        int j = 0;
        for (const cJSON *p = prims ? prims->child : NULL; p;
             p = p->next, j++) {
            const cJSON *at = cJSON_GetObjectItemCaseSensitive(p, "attributes");
            if (!cJSON_GetObjectItemCaseSensitive(at, "POSITION"))
                lr__gltf_warn(s, d,
                              "meshes[%d].primitives[%d] has no "
                              "POSITION: not drawn (spec 3.7.2.1)",
                              i, j);
            for (int k = 0; k < 2; k++)
                for (const cJSON *a = cJSON_IsObject(at) ? at->child : NULL; a;
                     a = a->next)
                    if (a->string != NULL &&
                        strncmp(a->string, kinds[k], strlen(kinds[k])) == 0) {
                        if (count[k]++ == 0)
                            snprintf(first[k], sizeof first[k],
                                     "meshes[%d].primitives[%d].attributes."
                                     "%.20s",
                                     i, j, a->string);
                        break;
                    }
        }
    }
    for (int k = 0; k < 2; k++)
        if (count[k] > 0)
            lr__gltf_warn(s, d, "%s is ignored (%s)%s%.0d%s", first[k], why[k],
                          count[k] > 1 ? "; so are those of " : "",
                          count[k] > 1 ? count[k] - 1 : 0,
                          count[k] > 1 ? " more primitives" : "");
}

lr_status lr__scene_add_gltf(lr_scene *s, const char *file, const char *shown,
                             const char *fp, const lr__gltf_options *o,
                             lr_error *err)
{
    lr__gltf_doc d;
    LR_TRY(lr__gltf_doc_load(file, shown, fp, &d, err));
    const struct aiScene *sc = NULL;
    lr__xform *world = NULL;
    unsigned char *active = NULL;
    lr_status st = lr__gltf_world(&d, &world, &active, err);
    placer pl = {s,
                 &d,
                 NULL,
                 world,
                 o,
                 (int)s->n_materials,
                 -1,
                 v3(INFINITY, INFINITY, INFINITY),
                 v3(-INFINITY, -INFINITY, -INFINITY),
                 0};
    int nm;
    const cJSON *mats = lr__gltf_array(d.root, "materials", &nm);
    int i = 0;
    for (const cJSON *m = mats ? mats->child : NULL; m && st == LR_OK;
         m = m->next, i++)
        st = add_material(s, &d, m, i, err);
    if (st == LR_OK)
        st = lr__gltf_import(&d, world, &sc, err);
    pl.sc = sc;
    if (st == LR_OK && sc->mRootNode != NULL)
        st = place_node(&pl, sc->mRootNode, err);
    if (st == LR_OK)
        st = lr__gltf_lights(s, &d, world, active, &o->place, err);
    if (st == LR_OK)
        st = lr__gltf_camera(s, &d, world, active, o, pl.lo, pl.hi, err);
    if (st == LR_OK && pl.skipped > 0)
        lr__gltf_warn(s, &d, "%zu meshes of points or lines are ignored",
                      pl.skipped);
    if (st == LR_OK)
        warn_unread(s, &d);
    lr__gltf_release(sc);
    free(world);
    free(active);
    lr__gltf_doc_free(&d);
    return st;
}
