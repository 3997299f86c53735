/*
 * trace16.c: camera samples in 16-wide packets (see trace16.h).
 */
#include "trace16.h"
#include "shade.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define LANES 16

typedef struct packet {
    struct RTCRayHit16 rh __attribute__((aligned(64)));
    struct RTCRay16 shadow __attribute__((aligned(64)));
    int valid[LANES] __attribute__((aligned(64)));
    int n;
    /* The rays in double, filled in only for lanes the scalar code
     * shades. */
    lr__v3 org[LANES], dir[LANES];
} packet;

/* Test hook (trace16.h): 1 sends every lane down the scalar path. */
int lr__trace16_scalar_only = 0;

/* The hits of one packet in structure-of-arrays form, in double: what
 * lr__hit_complete and finish_hit (scene.c) compute for a triangle, lane
 * by lane in loops the compiler vectorises.  Every operation is the one
 * the scalar code does, in the same order, without FMA contraction
 * (-ffp-contract=off), so each lane's result is the scalar result to the
 * bit: the test suite renders scenes both ways and compares bytes. */
typedef struct soa_hits {
    float v[9][LANES];     /* the triangle's corners a, b, c (x, y, z) */
    float n[9][LANES];     /* corner normals, zero in flat meshes */
    float smooth[LANES];   /* 1 with corner normals */
    double k[3][LANES];    /* diffuse albedo */
    /* Results. */
    double px[LANES], py[LANES], pz[LANES];    /* hit position */
    double gx[LANES], gy[LANES], gz[LANES];    /* ng, facing the ray */
    double sx[LANES], sy[LANES], sz[LANES];    /* ns */
    double eps[LANES];
} soa_hits;

/* Gathers plain lane i's triangle (see lr__geom.plain) into h.  Lanes
 * that are not plain keep what they held (zeros, or an earlier packet's
 * triangle): the vector loops compute on them too, and nobody reads
 * those results. */
static void gather_lane(const lr_scene *s, const packet *p, int i,
                        soa_hits *h)
{
    const lr__geom *g = &s->geoms[p->rh.hit.geomID[i]];
    unsigned prim = p->rh.hit.primID[i];
    const unsigned *ix = &g->indices[3 * (size_t)prim];
    for (int c = 0; c < 3; c++) {
        const float *v = &g->vertices[3 * (size_t)ix[c]];
        h->v[3 * c][i] = v[0];
        h->v[3 * c + 1][i] = v[1];
        h->v[3 * c + 2][i] = v[2];
    }
    if (g->corner_normals != NULL) {
        const float *n = &g->corner_normals[9 * (size_t)prim];
        for (int k = 0; k < 9; k++)
            h->n[k][i] = n[k];
        h->smooth[i] = 1.0f;
    } else {
        for (int k = 0; k < 9; k++)
            h->n[k][i] = 0.0f;
        h->smooth[i] = 0.0f;
    }
    const lr__v3 kd = s->materials[g->material].diffuse;
    h->k[0][i] = kd.x, h->k[1][i] = kd.y, h->k[2][i] = kd.z;
}

/* finish_hit for all sixteen lanes (lanes that are not plain compute
 * garbage that nobody reads). */
__attribute__((target_clones("avx512f", "avx2", "default")))
static void complete_hits(const packet *p, soa_hits *h)
{
    const struct RTCRay16 *r = &p->rh.ray;
    for (int i = 0; i < LANES; i++) {
        /* ng = (b - a) x (c - a), in double as scene.c does it. */
        double ax = h->v[0][i], ay = h->v[1][i], az = h->v[2][i];
        double e1x = (double)h->v[3][i] - ax, e1y = (double)h->v[4][i] - ay,
               e1z = (double)h->v[5][i] - az;
        double e2x = (double)h->v[6][i] - ax, e2y = (double)h->v[7][i] - ay,
               e2z = (double)h->v[8][i] - az;
        double ngx = e1y * e2z - e1z * e2y;
        double ngy = e1z * e2x - e1x * e2z;
        double ngz = e1x * e2y - e1y * e2x;
        /* ns: the corner normals interpolated, or ng. */
        double u = p->rh.hit.u[i], v = p->rh.hit.v[i], w = 1.0 - u - v;
        double nsx = w * h->n[0][i] + u * h->n[3][i] + v * h->n[6][i];
        double nsy = w * h->n[1][i] + u * h->n[4][i] + v * h->n[7][i];
        double nsz = w * h->n[2][i] + u * h->n[5][i] + v * h->n[8][i];
        int smooth = h->smooth[i] != 0.0f;
        nsx = smooth ? nsx : ngx;
        nsy = smooth ? nsy : ngy;
        nsz = smooth ? nsz : ngz;
        double t = r->tfar[i];
        double dx = r->dir_x[i], dy = r->dir_y[i], dz = r->dir_z[i];
        h->px[i] = (double)r->org_x[i] + dx * t;
        h->py[i] = (double)r->org_y[i] + dy * t;
        h->pz[i] = (double)r->org_z[i] + dz * t;
        /* v3_norm, twice. */
        double lg = sqrt(ngx * ngx + ngy * ngy + ngz * ngz);
        double ig = 1.0 / lg;
        int okg = lg > 0;
        ngx = okg ? ngx * ig : ngx;
        ngy = okg ? ngy * ig : ngy;
        ngz = okg ? ngz * ig : ngz;
        double ls = sqrt(nsx * nsx + nsy * nsy + nsz * nsz);
        double is = 1.0 / ls;
        int oks = ls > 0;
        nsx = oks ? nsx * is : nsx;
        nsy = oks ? nsy * is : nsy;
        nsz = oks ? nsz * is : nsz;
        int entering = dx * ngx + dy * ngy + dz * ngz < 0.0;
        ngx = entering ? ngx : -ngx;
        ngy = entering ? ngy : -ngy;
        ngz = entering ? ngz : -ngz;
        nsx = entering ? nsx : -nsx;
        nsy = entering ? nsy : -nsy;
        nsz = entering ? nsz : -nsz;
        /* (Bitwise & and |, not && and ||: no branches in the loop.) */
        int bad = (nsx * ngx + nsy * ngy + nsz * ngz <= 0.0) |
                  !((fabs(nsx) <= DBL_MAX) & (fabs(nsy) <= DBL_MAX) &
                    (fabs(nsz) <= DBL_MAX));
        h->sx[i] = bad ? ngx : nsx;
        h->sy[i] = bad ? ngy : nsy;
        h->sz[i] = bad ? ngz : nsz;
        h->gx[i] = ngx, h->gy[i] = ngy, h->gz[i] = ngz;
        /* v3_maxabs(p) + t |dir| */
        double m = fabs(h->px[i]);
        m = fabs(h->py[i]) > m ? fabs(h->py[i]) : m;
        m = fabs(h->pz[i]) > m ? fabs(h->pz[i]) : m;
        double dl = sqrt(dx * dx + dy * dy + dz * dz);
        h->eps[i] = (1.0 + (m + t * dl)) * 0x1p-17;
    }
}

/* lr__light_ray_setup for a diffuse material, all lanes at once: fills
 * the shadow packet's rays, ok[i] (-1 where a shadow ray is needed, in
 * lanes where ok[i] was -1 before) and the contribution f E cos. */
__attribute__((target_clones("avx512f", "avx2", "default")))
static void light_rays(const lr__light *lt, const soa_hits *h, int *ok,
                       struct RTCRay16 *r, double fr[LANES],
                       double fg[LANES], double fb[LANES])
{
    const int point = lt->kind == LR__LIGHT_POINT;
    const double lpx = lt->position.x, lpy = lt->position.y,
                 lpz = lt->position.z;
    const double ldx = -lt->direction.x, ldy = -lt->direction.y,
                 ldz = -lt->direction.z;
    const double Pr = lt->power.x, Pg = lt->power.y, Pb = lt->power.z;
    const double inv_pi = 1.0 / M_PI;
    double ro[3][LANES], rd[3][LANES], rt[LANES];
    int lit_[LANES];
    for (int i = 0; i < LANES; i++) {
        double tox = lpx - h->px[i], toy = lpy - h->py[i],
               toz = lpz - h->pz[i];
        double d2 = tox * tox + toy * toy + toz * toz;
        double dist = sqrt(d2);
        double id = 1.0 / dist, id2 = 1.0 / d2;
        double lx = point ? tox * id : ldx;
        double ly = point ? toy * id : ldy;
        double lz = point ? toz * id : ldz;
        double Er = point ? Pr * id2 : Pr;
        double Eg = point ? Pg * id2 : Pg;
        double Eb = point ? Pb * id2 : Pb;
        double cos_t = h->sx[i] * lx + h->sy[i] * ly + h->sz[i] * lz;
        double cos_g = lx * h->gx[i] + ly * h->gy[i] + lz * h->gz[i];
        /* The scalar code's tests, NaN behaviour included. */
        int lit = (!point | (d2 > 0.0)) & !(cos_t <= 0.0) &
                  !(h->gx[i] * lx + h->gy[i] * ly + h->gz[i] * lz <= 0.0);
        /* lr__offset_origin */
        double side = cos_g >= 0.0 ? 1.0 : -1.0;
        double se = side * h->eps[i];
        double orx = h->px[i] + h->gx[i] * se;
        double ory = h->py[i] + h->gy[i] * se;
        double orz = h->pz[i] + h->gz[i] * se;
        double qx = lpx - orx, qy = lpy - ory, qz = lpz - orz;
        double tfar = point ? sqrt(qx * qx + qy * qy + qz * qz) : INFINITY;
        fr[i] = ((h->k[0][i] * inv_pi) * Er) * cos_t;
        fg[i] = ((h->k[1][i] * inv_pi) * Eg) * cos_t;
        fb[i] = ((h->k[2][i] * inv_pi) * Eb) * cos_t;
        lit_[i] = lit;
        ro[0][i] = orx, ro[1][i] = ory, ro[2][i] = orz;
        rd[0][i] = lx, rd[1][i] = ly, rd[2][i] = lz;
        rt[i] = tfar;
    }
    /* (Apart: the vectoriser takes loops of one element width more
     * readily.) */
    for (int i = 0; i < LANES; i++) {
        ok[i] = -((ok[i] != 0) & lit_[i]);
        r->org_x[i] = (float)ro[0][i];
        r->org_y[i] = (float)ro[1][i];
        r->org_z[i] = (float)ro[2][i];
        r->tnear[i] = 0.0f;
        r->dir_x[i] = (float)rd[0][i];
        r->dir_y[i] = (float)rd[1][i];
        r->dir_z[i] = (float)rd[2][i];
        r->time[i] = 0.0f;
        r->tfar[i] = rt[i] < FLT_MAX ? (float)rt[i] : FLT_MAX;
        r->mask[i] = 0xFFFFFFFFu;
        r->id[i] = 0;
        r->flags[i] = 0;
    }
}

static void flush(const lr__trace16 *t, packet *p, soa_hits *sh,
                  lr__pixel *acc, uint64_t *rays)
{
    const lr_scene *s = t->scene;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int i = 0; i < LANES; i++)
        p->valid[i] = i < p->n ? -1 : 0;
    rtcIntersect16(p->valid, s->rtc, &ctx, &p->rh);
    *rays += (uint64_t)p->n;

    /* Each lane is plain (the vector path), scalar (hit completed by
     * lr__hit_complete and shaded by shade.c) or a miss. */
    lr__hit hit[LANES];
    int has_hit[LANES], plain[LANES], n_plain = 0;
    lr__v3 L[LANES];
    for (int i = 0; i < LANES; i++) {
        unsigned g = p->rh.hit.geomID[i];
        plain[i] = i < p->n && g != RTC_INVALID_GEOMETRY_ID &&
                   s->geoms[g].plain && !lr__trace16_scalar_only ? -1 : 0;
        n_plain += plain[i] != 0;
        if (plain[i])
            gather_lane(s, p, i, sh);
        has_hit[i] = 0;
        if (i >= p->n)
            continue;
        if (plain[i]) {
            has_hit[i] = 1;
            L[i] = v3(s->ambient.x * sh->k[0][i], s->ambient.y * sh->k[1][i],
                      s->ambient.z * sh->k[2][i]);
            continue;
        }
        if (g == RTC_INVALID_GEOMETRY_ID && s->n_planes == 0) {
            L[i] = s->background;   /* what lr__hit_complete would say */
            continue;
        }
        /* The scalar code works in double on the ray as traced. */
        const struct RTCRay16 *r = &p->rh.ray;
        p->org[i] = v3(r->org_x[i], r->org_y[i], r->org_z[i]);
        p->dir[i] = v3(r->dir_x[i], r->dir_y[i], r->dir_z[i]);
        has_hit[i] = lr__hit_complete(
            s, p->org[i], p->dir[i], INFINITY, g, p->rh.hit.primID[i],
            p->rh.hit.u[i], p->rh.hit.v[i], p->rh.ray.tfar[i], &hit[i]);
        L[i] = has_hit[i] ? lr__ambient(s, &hit[i]) : s->background;
    }
    if (n_plain)
        complete_hits(p, sh);

    /* One packet of shadow rays per light.  They are coherent too: they
     * leave the few surface points one pixel sees for one light (6%
     * faster on the bench scene than the incoherent flag). */
    for (size_t k = 0; k < s->n_lights; k++) {
        lr__light_ray lr[LANES];
        double fr[LANES], fg[LANES], fb[LANES];
        int any = 0;
        if (n_plain) {
            for (int i = 0; i < LANES; i++)
                p->valid[i] = plain[i];
            light_rays(&s->lights[k], sh, p->valid, &p->shadow, fr, fg,
                       fb);
        } else {
            for (int i = 0; i < LANES; i++)
                p->valid[i] = 0;
        }
        for (int i = 0; i < LANES; i++) {
            if (plain[i]) {
                any += p->valid[i] != 0;
                continue;
            }
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
        for (int i = 0; i < p->n; i++) {
            /* Embree marks an occluded ray by setting tfar to -inf. */
            if (!p->valid[i] || !(p->shadow.tfar[i] >= 0.0f))
                continue;
            if (plain[i])
                L[i] = v3_add(L[i], v3(fr[i], fg[i], fb[i]));
            else if (!lr__planes_block(s, lr[i].org, lr[i].dir, lr[i].tfar))
                L[i] = v3_add(L[i], lr[i].f_E_cos);
        }
    }

    if (t->max_depth > 0)
        for (int i = 0; i < p->n; i++)
            if (!plain[i] && has_hit[i])
                L[i] = v3_add(L[i], lr__secondary(s, &hit[i], p->dir[i], 0,
                                                  t->max_depth, rays));
    lr__pixel_add_n(acc, L, p->n);
    p->n = 0;
}

void lr__trace16_pixel(const lr__trace16 *t, int x, int y, int first,
                       int last, int use_lens, lr__pixel *acc,
                       uint64_t *rays, uint64_t *camera_rays)
{
    packet p;
    soa_hits sh;
    memset(&sh, 0, sizeof sh);
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
        }
        t->cam->model->rays16(t->cam, use_lens, n, fx, fy, lu, lv, &p.rh);
        p.n = n;
        *camera_rays += (uint64_t)n;
        flush(t, &p, &sh, acc, rays);
    }
}
