/*
 * trace16.c: camera samples in 16-wide packets (see trace16.h).
 */
#include "trace16.h"
#include "lens.h"
#include "shade.h"

#include <math.h>
#include <string.h>

#define LANES 16

typedef struct packet {
    struct RTCRayHit16 rh __attribute__((aligned(64)));
    struct RTCRay16 shadow __attribute__((aligned(64)));
    int valid[LANES] __attribute__((aligned(64)));
    int n;
    int slot[LANES];        /* which accumulator each lane adds to */
    lr__v3 org[LANES], dir[LANES];
} packet;

static void flush(const lr__trace16 *t, packet *p, lr__pixel *acc,
                  uint64_t *rays)
{
    const lr_scene *s = t->scene;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int i = 0; i < LANES; i++)
        p->valid[i] = i < p->n ? -1 : 0;
    rtcIntersect16(p->valid, s->rtc, &ctx, &p->rh);
    *rays += (uint64_t)p->n;

    lr__hit hit[LANES];
    int has_hit[LANES];
    lr__v3 L[LANES];
    for (int i = 0; i < p->n; i++) {
        has_hit[i] = lr__hit_complete(
            s, p->org[i], p->dir[i], INFINITY, p->rh.hit.geomID[i],
            p->rh.hit.primID[i], p->rh.hit.u[i], p->rh.hit.v[i],
            p->rh.ray.tfar[i], &hit[i]);
        L[i] = has_hit[i] ? lr__ambient(s, &hit[i]) : s->background;
    }

    /* One packet of shadow rays per light. */
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    for (size_t k = 0; k < s->n_lights; k++) {
        lr__light_ray lr[LANES];
        int any = 0;
        for (int i = 0; i < LANES; i++) {
            p->valid[i] = 0;
            if (i < p->n && has_hit[i] &&
                lr__light_ray_setup(s, &hit[i], v3_neg(p->dir[i]), k,
                                    &lr[i])) {
                p->valid[i] = -1;
                lr__shadow_ray16(&p->shadow, i, lr[i].org, lr[i].dir,
                                 lr[i].tfar);
                any++;
            }
        }
        if (!any)
            continue;
        rtcOccluded16(p->valid, s->rtc, &ctx, &p->shadow);
        *rays += (uint64_t)any;
        for (int i = 0; i < p->n; i++)
            /* Embree marks an occluded ray by setting tfar to -inf. */
            if (p->valid[i] && p->shadow.tfar[i] >= 0.0f &&
                !lr__planes_block(s, lr[i].org, lr[i].dir, lr[i].tfar))
                L[i] = v3_add(L[i], lr[i].f_E_cos);
    }

    for (int i = 0; i < p->n; i++) {
        if (has_hit[i] && t->max_depth > 0)
            L[i] = v3_add(L[i], lr__secondary(s, &hit[i], p->dir[i], 0,
                                              t->max_depth, rays));
        lr__pixel_add(&acc[p->slot[i]], L[i]);
    }
    p->n = 0;
}

/* Camera rays for lanes 0..n-1 from their film points (fx, fy) and lens
 * samples (lu, lv), in single precision, lane by lane in loops the
 * compiler can vectorise; the same geometry as lr__cam_lens_ray (see
 * camera.h), computed in floats since Embree traces floats anyway.  The
 * rays are written straight into the packet, and copied to p->org and
 * p->dir so that hits are completed on exactly the ray that was traced. */
/* Built for AVX2 and for any x86-64, chosen at load time (the float
 * arithmetic is the same in both, lane by lane: no FMA contraction, as
 * -ffp-contract=off in the Makefile keeps it). */
__attribute__((target_clones("avx2", "default")))
static void make_camera_rays(const lr__cam *c, int use_lens, packet *p,
                             int n,
                        const float *fx, const float *fy, const float *lu,
                        const float *lv)
{
    const float sw = (float)(2.0 / c->width), sh = (float)(2.0 / c->height);
    const float hw = (float)c->half_w, hh = (float)c->half_h;
    const float fw[3] = {(float)c->forward.x, (float)c->forward.y,
                         (float)c->forward.z};
    const float rt[3] = {(float)c->right.x, (float)c->right.y,
                         (float)c->right.z};
    const float up[3] = {(float)c->up.x, (float)c->up.y, (float)c->up.z};
    const float e[3] = {(float)c->origin.x, (float)c->origin.y,
                        (float)c->origin.z};
    const float rad = (float)c->radius, w = (float)c->w;
    const float ratio = (float)c->ratio;
    const float di = c->model == LR_CAMERA_BRACKET ? (float)c->di : 0.0f;
    float lx[LANES], ly[LANES];
    struct RTCRay16 *r = &p->rh.ray;

    if (!c->has_lens || !use_lens) {
        for (int i = 0; i < LANES; i++)
            lx[i] = ly[i] = 0.0f;
    } else if (c->shape == LR_APERTURE_DISK && c->rotation == 0.0) {
        /* Shirley & Chiu's concentric map, branch-free; sin and cos of
         * t in [-pi/4, pi/4] by Taylor series (error < 2e-9). */
        for (int i = 0; i < LANES; i++) {
            float a = 2.0f * lu[i] - 1.0f, b = 2.0f * lv[i] - 1.0f;
            /* Blends instead of branches, so the loop vectorises:
             * m = 1 when |a| > |b|. */
            float m = (float)(fabsf(a) > fabsf(b));
            float rr = m * a + (1.0f - m) * b;
            float num = m * b + (1.0f - m) * a;
            /* rr = 0 only when a = b = 0, and then num = 0 too. */
            float den = rr + (float)(rr == 0.0f);
            float t = 0.78539816f * num / den;
            float t2 = t * t;
            float sn = t * (1.0f + t2 * (-1.0f / 6 + t2 * (1.0f / 120 +
                       t2 * (-1.0f / 5040 + t2 * (1.0f / 362880)))));
            float cs = 1.0f + t2 * (-0.5f + t2 * (1.0f / 24 + t2 *
                       (-1.0f / 720 + t2 * (1.0f / 40320 -
                        t2 * (1.0f / 3628800)))));
            lx[i] = rr * (m * cs + (1.0f - m) * sn) * ratio;
            ly[i] = rr * (m * sn + (1.0f - m) * cs);
        }
    } else {
        for (int i = 0; i < n; i++) {
            double u[2] = {lu[i], lv[i]}, x, y;
            lr__aperture_sample(c->shape, c->blades, c->rotation, c->ratio, u,
                                &x, &y);
            lx[i] = (float)x;
            ly[i] = (float)y;
        }
    }
    for (int i = 0; i < LANES; i++) {
        /* D: the chief ray scaled to axial length 1. */
        float sx = (fx[i] * sw - 1.0f) * hw, sy = (1.0f - fy[i] * sh) * hh;
        float dx = fw[0] + rt[0] * sx + up[0] * sy;
        float dy = fw[1] + rt[1] * sx + up[1] * sy;
        float dz = fw[2] + rt[2] * sx + up[2] * sy;
        float ox = rad * (rt[0] * lx[i] + up[0] * ly[i]);
        float oy = rad * (rt[1] * lx[i] + up[1] * ly[i]);
        float oz = rad * (rt[2] * lx[i] + up[2] * ly[i]);
        r->org_x[i] = e[0] + dx * di + ox;
        r->org_y[i] = e[1] + dy * di + oy;
        r->org_z[i] = e[2] + dz * di + oz;
        float vx = dx - ox * w, vy = dy - oy * w, vz = dz - oz * w;
        float inv = 1.0f / sqrtf(vx * vx + vy * vy + vz * vz);
        r->dir_x[i] = vx * inv;
        r->dir_y[i] = vy * inv;
        r->dir_z[i] = vz * inv;
        r->tnear[i] = 0.0f;
        r->time[i] = 0.0f;
        r->tfar[i] = INFINITY;
        r->mask[i] = 0xFFFFFFFFu;
        r->id[i] = 0;
        r->flags[i] = 0;
        p->rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        p->rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    for (int i = 0; i < n; i++) {
        p->org[i] = v3(r->org_x[i], r->org_y[i], r->org_z[i]);
        p->dir[i] = v3(r->dir_x[i], r->dir_y[i], r->dir_z[i]);
    }
}

void lr__trace16_pixel(const lr__trace16 *t, int x, int y, int first,
                       int last, int use_lens, lr__pixel *acc,
                       uint64_t *rays, uint64_t *camera_rays)
{
    packet p;
    float fx[LANES], fy[LANES], lu[LANES], lv[LANES];
    for (int i = 0; i < LANES; i++)
        fx[i] = fy[i] = lu[i] = lv[i] = 0.5f;
    lr__pixel_sampler ps;
    uint64_t pixel = (uint64_t)y * (uint64_t)t->width + (uint64_t)x;
    lr__pixel_sampler_init(&ps, t->sampler, pixel);
    /* Packets never mix pixels: which rays share a packet then never
     * depends on the tile size or region, so neither can the result
     * (Embree may break exact ties between primitives differently for
     * differently composed packets). */
    for (int s0 = first; s0 < last; s0 += LANES) {
        int n = last - s0 < LANES ? last - s0 : LANES;
        float u[4][16];
        lr__pixel_sampler_get16(&ps, (uint32_t)s0, n, u);
        for (int i = 0; i < n; i++) {
            /* In double, as the scalar path does, then rounded once. */
            fx[i] = (float)(x + (double)u[0][i]);
            fy[i] = (float)(y + (double)u[1][i]);
            lu[i] = u[2][i];
            lv[i] = u[3][i];
            p.slot[i] = 0;
        }
        make_camera_rays(t->cam, use_lens, &p, n, fx, fy, lu, lv);
        p.n = n;
        *camera_rays += (uint64_t)n;
        flush(t, &p, acc, rays);
    }
}
