/*
 * material.c: a material's values at a point: its factors times its
 * textures (scene.h), a glTF material's base colour split by its
 * metallic texture, and where a point of a sphere is in a texture.
 */
#include "scene.h"

#include <math.h>

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
                                          const double uv[2],
                                          lr__material *tmp)
{
    *tmp = *m;
    if (m->pbr_split) {
        lr__v3 b = m->base_tex ? times_rgb(m->base, m->base_tex,
                                           &m->xf_colour, uv)
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
        tmp->diffuse = times_rgb(m->diffuse, m->diffuse_tex, &m->xf_colour,
                                 uv);
    if (m->emission_tex != NULL)
        tmp->emission = times_rgb(m->emission, m->emission_tex,
                                  &m->xf_emission, uv);
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
