/*
 * material.c: a material's values at a point: its factors times its
 * textures (material.h), a glTF material's base colour split by its
 * metallic texture, and where a point of a sphere is in a texture.
 */
#include "scene/scene.h"

#include <math.h>
#include <stdlib.h>

void lr__sphere_uv(lr__v3 n, double uv[2])
{
    uv[0] = 0.5 + atan2(n.x, n.z) / (2.0 * M_PI);
    uv[1] = 1.0 - acos(fmax(-1.0, fmin(1.0, n.y))) / M_PI;
}

/* The texel of `t` at uv moved by `xf`. */
static void lookup(const lr__texture *t, const lr__uv_xf *xf,
                   const double uv[2], float c[4])
{
    if (!xf->on) {
        lr__texture_lookup(t, uv[0], uv[1], c);
        return;
    }
    const double *m = xf->m;
    lr__texture_lookup(t, m[0] * uv[0] + m[1] * uv[1] + m[2],
                       m[3] * uv[0] + m[4] * uv[1] + m[5], c);
}

static lr__v3 times_rgb(lr__v3 k, const lr__texture *t, const lr__uv_xf *xf,
                        const double uv[2])
{
    float c[4];
    lookup(t, xf, uv, c);
    return v3(k.x * c[0], k.y * c[1], k.z * c[2]);
}

const lr__material *lr__material_textures(const lr__material *m,
                                          const double uv[2], lr__material *tmp)
{
    *tmp = *m;
    if (m->pbr_split) {
        lr__v3 b = m->base_tex
                       ? times_rgb(m->base, m->base_tex, &m->xf_colour, uv)
                       : m->base;
        double metal = m->metal;
        if (m->metal_tex != NULL) {
            float c[4];
            lookup(m->metal_tex, &m->xf_rough, uv, c);
            metal *= fmin(1.0, fmax(0.0, c[2]));
        }
        tmp->reflect = v3_scale(b, metal);
        tmp->diffuse = v3_scale(b, (1 - metal) * (1 - m->trans));
        tmp->transmit = v3_scale(b, (1 - metal) * m->trans);
    }
    if (m->diffuse_tex != NULL)
        tmp->diffuse = times_rgb(m->diffuse, m->diffuse_tex, &m->xf_colour, uv);
    if (m->emission_tex != NULL)
        tmp->emission = times_rgb(m->emission, m->emission_tex, &m->xf_emission,
                                  uv);
    if (m->roughness_tex != NULL) {
        float c[4];
        lookup(m->roughness_tex, &m->xf_rough, uv, c);
        int k = m->roughness_channel >= 0 && m->roughness_channel < 4
                    ? m->roughness_channel
                    : 0;
        /* The texture holds perceptual roughness r, as glTF's does, and
         * `roughness` is a GGX alpha (glTF's alpha = r^2, Burley 2012 via
         * the glTF 2.0 specification, appendix B): alpha = roughness r^2,
         * so that a glTF factor f stored as f^2 gives (f r)^2. */
        double r = fmin(1.0, fmax(0.0, c[k]));
        tmp->roughness = m->roughness * (r * r);
    }
    return tmp;
}

/* dP/du and dP/dv of each triangle, solving the corners' edges against
 * their uv differences (Lengyel, "Computing Tangent Space Basis Vectors
 * for an Arbitrary Mesh", 2001): e1 = du1 T + dv1 B, e2 = du2 T + dv2 B.
 * A triangle whose uvs are degenerate gets zeros: no bending there. */
float *lr__triangle_tangents(const lr__geom *g)
{
    float *t = calloc(6 * (g->n_triangles ? g->n_triangles : 1), sizeof *t);
    if (t == NULL)
        return NULL;
    for (size_t k = 0; k < g->n_triangles; k++) {
        const unsigned *ix = &g->indices[3 * k];
        const float *a = &g->vertices[3 * (size_t)ix[0]];
        const float *b = &g->vertices[3 * (size_t)ix[1]];
        const float *c = &g->vertices[3 * (size_t)ix[2]];
        const float *uv = &g->corner_uv[6 * k];
        double du1 = uv[2] - uv[0], dv1 = uv[3] - uv[1];
        double du2 = uv[4] - uv[0], dv2 = uv[5] - uv[1];
        double det = du1 * dv2 - du2 * dv1;
        if (!(fabs(det) > 1e-20))
            continue;
        double r = 1.0 / det;
        for (int i = 0; i < 3; i++) {
            double e1 = (double)b[i] - a[i], e2 = (double)c[i] - a[i];
            t[6 * k + i] = (float)((e1 * dv2 - e2 * dv1) * r);
            t[6 * k + 3 + i] = (float)((e2 * du1 - e1 * du2) * r);
        }
    }
    return t;
}

lr__v3 lr__normal_mapped(const lr__geom *g, const lr__material *m,
                         unsigned prim, const double uv[2], lr__v3 ns_front)
{
    const float *tb = &g->tangents[6 * (size_t)prim];
    lr__v3 T = v3(tb[0], tb[1], tb[2]), B = v3(tb[3], tb[4], tb[5]);
    const lr__uv_xf *xf = &m->xf_normal;
    if (xf->on) {
        /* The frame of the map's own coordinates (glTF 2.0, 3.9.3: the
         * tangents of the normal texture's coordinates): (u', v') = M
         * (u, v) + o, so d/du' = (m4 d/du - m3 d/dv) / det and d/dv' =
         * (m0 d/dv - m1 d/du) / det.  A mirrored or turned map bent the
         * normal the wrong way. */
        double det = xf->m[0] * xf->m[4] - xf->m[1] * xf->m[3];
        if (!(det != 0.0))
            return ns_front;
        lr__v3 Tm = v3_scale(
            v3_sub(v3_scale(T, xf->m[4]), v3_scale(B, xf->m[3])), 1.0 / det);
        B = v3_scale(v3_sub(v3_scale(B, xf->m[0]), v3_scale(T, xf->m[1])),
                     1.0 / det);
        T = Tm;
    }
    /* Gram-Schmidt against the shading normal; B's side of N x T keeps
     * the map's handedness where the uvs are mirrored. */
    T = v3_sub(T, v3_scale(ns_front, v3_dot(ns_front, T)));
    double lt = v3_len(T);
    if (!(lt > 0.0))
        return ns_front;
    T = v3_scale(T, 1.0 / lt);
    lr__v3 Bo = v3_cross(ns_front, T);
    if (v3_dot(Bo, B) < 0.0)
        Bo = v3_neg(Bo);
    float c[4];
    lookup(m->normal_tex, &m->xf_normal, uv, c);
    /* glTF 2.0, 3.9.3: the texel's RGB is (n + 1) / 2 in tangent space,
     * +x along increasing u, +y along the bitangent (up the image: glTF's
     * decreasing v, lensray's increasing v), x and y scaled by `scale`. */
    double x = (2.0 * c[0] - 1.0) * m->normal_scale;
    double y = (2.0 * c[1] - 1.0) * m->normal_scale;
    double z = 2.0 * c[2] - 1.0;
    lr__v3 n = v3_add(v3_add(v3_scale(T, x), v3_scale(Bo, y)),
                      v3_scale(ns_front, z));
    double ln = v3_len(n);
    if (!(ln > 0.0) || !isfinite(ln))
        return ns_front;
    return v3_scale(n, 1.0 / ln);
}
