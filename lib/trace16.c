/*
 * trace16.c: camera samples in 16-wide packets (see trace16.h).
 */
#include "trace16.h"
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

void lr__trace16_row(const lr__trace16 *t, int y, int x0, int x1,
                     lr__pixel *acc, uint64_t *rays)
{
    packet p;
    p.n = 0;
    for (int x = x0; x < x1; x++) {
        lr__pixel_sampler ps;
        uint64_t pixel = (uint64_t)y * (uint64_t)t->width + (uint64_t)x;
        lr__pixel_sampler_init(&ps, t->sampler, pixel);
        lr__pixel_reset(&acc[x - x0]);
        for (int s = 0; s < t->spp; s++) {
            double u[4];
            lr__pixel_sampler_get(&ps, (uint32_t)s, u);
            int i = p.n;
            lr__cam_lens_ray(t->cam, x + u[0], y + u[1], u + 2, t->cam->w,
                             &p.org[i], &p.dir[i]);
            lr__embree_ray16(&p.rh, i, p.org[i], p.dir[i], INFINITY);
            p.slot[i] = x - x0;
            if (++p.n == LANES)
                flush(t, &p, acc, rays);
        }
        /* Packets never mix pixels: which rays share a packet then never
         * depends on the tile size or region, so neither can the result
         * (Embree may break exact ties between primitives differently
         * for differently composed packets). */
        if (p.n > 0)
            flush(t, &p, acc, rays);
    }
}
