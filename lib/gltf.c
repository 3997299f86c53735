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
 */
#include "gltf_doc.h"
#include "json_util.h"

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
        return lr__gltf_fail(d, err, "%s.%s must be a number from 0 to %g",
                             p, key, hi);
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
        return lr__gltf_fail(d, err, "%s.%s must be %d numbers from 0 to 1",
                             p, key, n);
    return LR_OK;
}

/* Warns once per material about each part lensray ignores. */
static void warn_ignored(lr_scene *s, const lr__gltf_doc *d, const cJSON *m,
                         const char *p)
{
    static const char *const slots[] = {"normalTexture", "occlusionTexture",
                                        NULL};
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
            lr__gltf_warn(s, d, "%s.extensions.%.60s is ignored", p,
                          e->string);
}

/* The glTF material `m` (NULL: the spec's default material, 3.9.6) as
 * lensray's, appended to s->materials. */
static lr_status add_material(lr_scene *s, const lr__gltf_doc *d,
                              const cJSON *m, int index, lr_error *err)
{
    char p[48];
    snprintf(p, sizeof p, "materials[%d]", index);
    double base[4] = {1, 1, 1, 1}, emissive[3] = {0, 0, 0};
    double metal = 1, rough = 1, strength = 1, trans = 0, ior = 1.5;
    const cJSON *pbr = cJSON_GetObjectItemCaseSensitive(m, "pbrMetallicRoughness");
    char q[80];
    snprintf(q, sizeof q, "%s.pbrMetallicRoughness", p);
    LR_TRY(colour(d, pbr, q, "baseColorFactor", 4, base, err));
    LR_TRY(factor(d, pbr, q, "metallicFactor", 1, 1, &metal, err));
    LR_TRY(factor(d, pbr, q, "roughnessFactor", 1, 1, &rough, err));
    LR_TRY(colour(d, m, p, "emissiveFactor", 3, emissive, err));
    snprintf(q, sizeof q, "%s.extensions.KHR_materials_emissive_strength", p);
    LR_TRY(factor(d, lr__gltf_member(m, "extensions",
                                     "KHR_materials_emissive_strength"),
                  q, "emissiveStrength", 1e9, 1, &strength, err));
    snprintf(q, sizeof q, "%s.extensions.KHR_materials_transmission", p);
    LR_TRY(factor(d, lr__gltf_member(m, "extensions",
                                     "KHR_materials_transmission"),
                  q, "transmissionFactor", 1, 0, &trans, err));
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
    return LR_OK;
}

/* ---- meshes --------------------------------------------------------------- */

typedef struct placer {
    lr_scene *s;
    const lr__gltf_doc *d;
    const struct aiScene *sc;
    const lr__xform *world;
    const lr__gltf_options *o;
    int first_material;  /* lensray index of materials[0] */
    int default_material;/* lensray index of the spec's default, or -1 */
    lr__v3 lo, hi;       /* box of the placed vertices */
    size_t skipped;      /* points and lines */
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
    int material;
    LR_TRY(material_of(pl, am->mMaterialIndex, &material, err));
    size_t nv = am->mNumVertices, nt = 0;
    float *v = malloc(nv * 3 * sizeof *v);
    unsigned *idx = malloc((size_t)am->mNumFaces * 3 * sizeof *idx);
    float *cn = am->mNormals ? malloc((size_t)am->mNumFaces * 9 * sizeof *cn)
                             : NULL;
    if (v == NULL || idx == NULL || (am->mNormals && cn == NULL)) {
        free(v), free(idx), free(cn);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    for (size_t i = 0; i < nv; i++) {
        const struct aiVector3D *q = &am->mVertices[i];
        lr__v3 w = lr__xform_point(x, v3(q->x, q->y, q->z));
        if (!(v3_maxabs(w) <= LR__MAX_NUMBER)) {
            free(v), free(idx), free(cn);
            return lr__gltf_fail(pl->d, err, "a vertex reaches %g from the "
                                 "origin after the transforms, beyond the "
                                 "limit of 1e15", v3_maxabs(w));
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
                                     err);
    else
        free(cn);
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
            return lr__gltf_fail(pl->d, err, "libassimp returned a node "
                                 "\"%.40s\" the file does not have",
                                 n->mName.data);
        lr__xform x = lr__xform_mul(&pl->o->place, &pl->world[i]);
        for (unsigned k = 0; k < n->mNumMeshes; k++)
            if (n->mMeshes[k] < pl->sc->mNumMeshes)
                LR_TRY(add_mesh(pl, pl->sc->mMeshes[n->mMeshes[k]], &x,
                                err));
    }
    for (unsigned c = 0; c < n->mNumChildren; c++)
        LR_TRY(place_node(pl, n->mChildren[c], err));
    return LR_OK;
}

/* Warnings for the parts of the file nothing reads. */
static void warn_unread(lr_scene *s, const lr__gltf_doc *d)
{
    static const char *const top[] = {"animations", "skins", NULL};
    for (int k = 0; top[k]; k++)
        if (cJSON_GetObjectItemCaseSensitive(d->root, top[k]))
            lr__gltf_warn(s, d, "%s are ignored", top[k]);
    int nm;
    const cJSON *meshes = lr__gltf_array(d->root, "meshes", &nm);
    int i = 0;
    for (const cJSON *m = meshes ? meshes->child : NULL; m; m = m->next, i++)
        for (const cJSON *p = cJSON_GetObjectItemCaseSensitive(m,
                                                               "primitives")
                                  ->child;
             p; p = p->next)
            if (cJSON_GetObjectItemCaseSensitive(p, "targets"))
                lr__gltf_warn(s, d, "meshes[%d]: morph targets are ignored",
                              i);
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
    placer pl = {s, &d, NULL, world, o, (int)s->n_materials, -1,
                 v3(INFINITY, INFINITY, INFINITY),
                 v3(-INFINITY, -INFINITY, -INFINITY), 0};
    int nm;
    const cJSON *mats = lr__gltf_array(d.root, "materials", &nm);
    int i = 0;
    for (const cJSON *m = mats ? mats->child : NULL; m && st == LR_OK;
         m = m->next, i++)
        st = add_material(s, &d, m, i, err);
    if (st == LR_OK)
        st = lr__gltf_import(&d, &sc, err);
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
