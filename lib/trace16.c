/*
 * trace16.c: camera samples in 16-wide packets (see trace16.h).
 */
#include "trace16.h"
#include "lens.h"
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
    int slot[LANES];        /* which accumulator each lane adds to */
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
    double ox[LANES], oy[LANES], oz[LANES];    /* ray origin */
    double dx[LANES], dy[LANES], dz[LANES];    /* ray direction */
    double t[LANES], bu[LANES], bv[LANES];
    double ax[LANES], ay[LANES], az[LANES];    /* the triangle's corners */
    double bx[LANES], by[LANES], bz[LANES];
    double cx[LANES], cy[LANES], cz[LANES];
    double n[9][LANES];                        /* corner normals */
    double smooth[LANES];                      /* 1 with corner normals */
    double kr[LANES], kg[LANES], kb[LANES];    /* diffuse albedo */
    /* Results. */
    double px[LANES], py[LANES], pz[LANES];    /* hit position */
    double gx[LANES], gy[LANES], gz[LANES];    /* ng, facing the ray */
    double sx[LANES], sy[LANES], sz[LANES];    /* ns */
    double eps[LANES];
} soa_hits;

/* Is the lane's hit one the vector path shades: a triangle of a purely
 * diffuse material (no Phong lobe, which needs pow, and no mirror or
 * glass rays)?  Infinite planes are tested per ray beside Embree, so a
 * scene with any sends every lane to the scalar path. */
static int plain_lane(const lr_scene *s, unsigned geom_id, int *material)
{
    if (geom_id == RTC_INVALID_GEOMETRY_ID || s->n_planes != 0)
        return 0;
    const lr__geom *g = &s->geoms[geom_id];
    if (g->kind != LR__GEOM_TRIANGLES)
        return 0;
    const lr__material *m = &s->materials[g->material];
    if (v3_maxc(m->specular) > 0.0 || v3_maxc(m->reflect) > 0.0 ||
        v3_maxc(m->transmit) > 0.0 || !(v3_maxc(m->diffuse) > 0.0))
        return 0;
    *material = g->material;
    return 1;
}

/* Gathers lane i's triangle into h (scalar: every lane its own mesh). */
static void gather_lane(const lr_scene *s, const packet *p, int i,
                        soa_hits *h)
{
    const lr__geom *g = &s->geoms[p->rh.hit.geomID[i]];
    unsigned prim = p->rh.hit.primID[i];
    const unsigned *ix = &g->indices[3 * (size_t)prim];
    const float *a = &g->vertices[3 * (size_t)ix[0]];
    const float *b = &g->vertices[3 * (size_t)ix[1]];
    const float *c = &g->vertices[3 * (size_t)ix[2]];
    h->ox[i] = p->org[i].x, h->oy[i] = p->org[i].y, h->oz[i] = p->org[i].z;
    h->dx[i] = p->dir[i].x, h->dy[i] = p->dir[i].y, h->dz[i] = p->dir[i].z;
    h->t[i] = p->rh.ray.tfar[i];
    h->bu[i] = p->rh.hit.u[i];
    h->bv[i] = p->rh.hit.v[i];
    h->ax[i] = a[0], h->ay[i] = a[1], h->az[i] = a[2];
    h->bx[i] = b[0], h->by[i] = b[1], h->bz[i] = b[2];
    h->cx[i] = c[0], h->cy[i] = c[1], h->cz[i] = c[2];
    if (g->corner_normals != NULL) {
        const float *n = &g->corner_normals[9 * (size_t)prim];
        for (int k = 0; k < 9; k++)
            h->n[k][i] = n[k];
        h->smooth[i] = 1.0;
    } else {
        for (int k = 0; k < 9; k++)
            h->n[k][i] = 0.0;
        h->smooth[i] = 0.0;
    }
    const lr__v3 kd = s->materials[g->material].diffuse;
    h->kr[i] = kd.x, h->kg[i] = kd.y, h->kb[i] = kd.z;
}

/* Zeros in lane i, which is not plain: the vector loops compute on it
 * too, and their results there are never read. */
static void gather_lane_blank(soa_hits *h, int i)
{
    h->ox[i] = h->oy[i] = h->oz[i] = 0.0;
    h->dx[i] = h->dy[i] = h->dz[i] = 0.0;
    h->t[i] = h->bu[i] = h->bv[i] = 0.0;
    h->ax[i] = h->ay[i] = h->az[i] = 0.0;
    h->bx[i] = h->by[i] = h->bz[i] = 0.0;
    h->cx[i] = h->cy[i] = h->cz[i] = 0.0;
    for (int k = 0; k < 9; k++)
        h->n[k][i] = 0.0;
    h->smooth[i] = 0.0;
    h->kr[i] = h->kg[i] = h->kb[i] = 0.0;
}

/* finish_hit for all sixteen lanes (lanes that are not plain compute
 * garbage that nobody reads). */
__attribute__((target_clones("avx2", "default")))
static void complete_hits(soa_hits *h)
{
    for (int i = 0; i < LANES; i++) {
        /* ng = (b - a) x (c - a) */
        double e1x = h->bx[i] - h->ax[i], e1y = h->by[i] - h->ay[i],
               e1z = h->bz[i] - h->az[i];
        double e2x = h->cx[i] - h->ax[i], e2y = h->cy[i] - h->ay[i],
               e2z = h->cz[i] - h->az[i];
        double ngx = e1y * e2z - e1z * e2y;
        double ngy = e1z * e2x - e1x * e2z;
        double ngz = e1x * e2y - e1y * e2x;
        /* ns: the corner normals interpolated, or ng. */
        double u = h->bu[i], v = h->bv[i], w = 1.0 - u - v;
        double nsx = w * h->n[0][i] + u * h->n[3][i] + v * h->n[6][i];
        double nsy = w * h->n[1][i] + u * h->n[4][i] + v * h->n[7][i];
        double nsz = w * h->n[2][i] + u * h->n[5][i] + v * h->n[8][i];
        int smooth = h->smooth[i] != 0.0;
        nsx = smooth ? nsx : ngx;
        nsy = smooth ? nsy : ngy;
        nsz = smooth ? nsz : ngz;
        double t = h->t[i];
        h->px[i] = h->ox[i] + h->dx[i] * t;
        h->py[i] = h->oy[i] + h->dy[i] * t;
        h->pz[i] = h->oz[i] + h->dz[i] * t;
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
        int entering = h->dx[i] * ngx + h->dy[i] * ngy + h->dz[i] * ngz < 0.0;
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
        double dl = sqrt(h->dx[i] * h->dx[i] + h->dy[i] * h->dy[i] +
                         h->dz[i] * h->dz[i]);
        h->eps[i] = (1.0 + (m + t * dl)) * 0x1p-17;
    }
}

/* lr__light_ray_setup for a diffuse material, all lanes at once: fills
 * the shadow packet's rays, ok[i] (-1 where a shadow ray is needed, in
 * lanes where ok[i] was -1 before) and the contribution f E cos. */
__attribute__((target_clones("avx2", "default")))
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
        fr[i] = ((h->kr[i] * inv_pi) * Er) * cos_t;
        fg[i] = ((h->kg[i] * inv_pi) * Eg) * cos_t;
        fb[i] = ((h->kb[i] * inv_pi) * Eb) * cos_t;
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

    /* Each lane is plain (the vector path), scalar (hit completed by
     * lr__hit_complete and shaded by shade.c) or a miss. */
    soa_hits sh;
    lr__hit hit[LANES];
    int has_hit[LANES], plain[LANES], n_plain = 0;
    lr__v3 L[LANES];
    for (int i = 0; i < LANES; i++) {
        int mat;
        plain[i] = 0;
        has_hit[i] = 0;
        if (i >= p->n)
            continue;
        if (!lr__trace16_scalar_only &&
            plain_lane(s, p->rh.hit.geomID[i], &mat)) {
            plain[i] = -1;
            has_hit[i] = 1;
            n_plain++;
            gather_lane(s, p, i, &sh);
            L[i] = v3_mul(s->ambient, s->materials[mat].diffuse);
            continue;
        }
        has_hit[i] = lr__hit_complete(
            s, p->org[i], p->dir[i], INFINITY, p->rh.hit.geomID[i],
            p->rh.hit.primID[i], p->rh.hit.u[i], p->rh.hit.v[i],
            p->rh.ray.tfar[i], &hit[i]);
        L[i] = has_hit[i] ? lr__ambient(s, &hit[i]) : s->background;
    }
    if (n_plain) {
        /* Lanes that are not plain hold whatever was there; give them
         * harmless values so the vector loops see no signalling junk. */
        for (int i = 0; i < LANES; i++)
            if (!plain[i])
                gather_lane_blank(&sh, i);
        complete_hits(&sh);
    }

    /* One packet of shadow rays per light. */
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    for (size_t k = 0; k < s->n_lights; k++) {
        lr__light_ray lr[LANES];
        double fr[LANES], fg[LANES], fb[LANES];
        int any = 0;
        if (n_plain) {
            for (int i = 0; i < LANES; i++)
                p->valid[i] = plain[i];
            light_rays(&s->lights[k], &sh, p->valid, &p->shadow, fr, fg,
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

    for (int i = 0; i < p->n; i++) {
        if (!plain[i] && has_hit[i] && t->max_depth > 0)
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
