/*
 * path16.c: the path integrator's sixteen paths of a packet kept as
 * arrays (path.h: lr__paths16), and the bounce of the lanes that hit an
 * untextured Lambertian surface (a flat triangle or a sphere) in a
 * scene lit by a few emitting triangles or spheres, or by one point
 * light: the hit, ambient light, the
 * light sample, the cosine-weighted BSDF sample and roulette, in
 * structure-of-arrays loops over the lanes that GCC vectorises (double,
 * as path.c).  (A bounce's rays and hashed numbers: path16_rays.c.)
 *
 * Every operation is the one path.c's scalar code does (trace.c's
 * lr__hit_complete and finish_hit, bsdf.c, light.c, path.c's bounce and
 * next_event), in the same order and without FMA contraction
 * (-ffp-contract=off), so each lane's result is the scalar result to
 * the bit (test_path.c renders both ways and compares bytes).  Where the
 * scalar code returns early, these loops compute on and mask the
 * result; lanes not taken compute on whatever they hold and keep their
 * state (each store selects).
 */
#include "integrator/path.h"
#include "integrator/bsdf.h"
#include "scene/light.h"

#include <float.h>
#include <math.h>
#include <string.h>

int lr__path16_enabled = 1;

#define MAX_EMITTERS LR__PATH16_EMITTERS
/* A bounce with this many live lanes or fewer shades them alone
 * (path.c), the same bytes: past roulette's start (the fifth surface) a
 * packet of the sphere-lit box of bench/path at max depth 64 has 1.35
 * live lanes on average, and lambert16 costs about the same for one
 * lane as for sixteen.  The box: 3.53 -> 3.39 CPU s at 256 spp, its
 * max-depth-6 twin lit by a rectangle 2.67 -> 2.64 (medians of 7
 * interleaved runs, one thread; 1 and 3 gave less). */
#define FEW_LIVE 2

/* One point light (not a spot), no emitters, no map (path.h). */
static int point_lit(const lr_scene *s)
{
    return s->n_lights == 1 && s->n_emitters == 0 && s->env == NULL &&
           s->lights[0].kind == LR__LIGHT_POINT && !s->lights[0].spot;
}

int lr__path16_scene_ok(const lr_scene *s)
{
    if (!lr__path16_enabled || s->n_planes > 0)
        return 0;
    if (point_lit(s))
        return 1;
    if (s->n_lights > 0 || s->env != NULL || s->n_emitters == 0 ||
        s->n_emitters > MAX_EMITTERS)
        return 0;
    for (size_t i = 0; i < s->n_emitters; i++) {
        const lr__geom *g = &s->geoms[s->emitters[i].geom];
        if ((g->kind != LR__GEOM_TRIANGLES && g->kind != LR__GEOM_SPHERE) ||
            lr__material_textured(&s->materials[g->material]))
            return 0;
    }
    return 1;
}

/* v3_maxc's comparisons. */
static inline double maxc3(double x, double y, double z)
{
    double m = x;
    m = y > m ? y : m;
    return z > m ? z : m;
}

static void emitters_get(const lr_scene *s, emitters16 *E)
{
    E->point = point_lit(s);
    if (E->point) {
        memset(E, 0, sizeof *E); /* (lanes16 loads [0] and [1]) */
        E->point = 1;
        const lr__light *lt = &s->lights[0];
        E->px = lt->position.x, E->py = lt->position.y;
        E->pz = lt->position.z;
        E->ir = lt->power.x, E->ig = lt->power.y, E->ib = lt->power.z;
        return;
    }
    /* (Past n, at least to 2, the last repeated: lambert16 reads [1].) */
    size_t n = s->n_emitters;
    for (size_t i = 0; i < n || i < 2; i++) {
        size_t k = i < n ? i : n - 1;
        const lr__emitter *e = &s->emitters[k];
        /* emitter_find's binary search gives the first index whose cdf
         * exceeds u, or the last: the count of the cdfs before the last
         * that do not exceed u (the cdf never decreases). */
        E->cdf[i] = i + 1 < n ? s->emitter_cdf[i] : INFINITY;
        /* emitter_prob */
        E->prob[i] = s->emitter_cdf[k] - (k > 0 ? s->emitter_cdf[k - 1] : 0.0);
        E->ax[i] = e->a.x, E->ay[i] = e->a.y, E->az[i] = e->a.z;
        E->e1x[i] = e->e1.x, E->e1y[i] = e->e1.y, E->e1z[i] = e->e1.z;
        E->e2x[i] = e->e2.x, E->e2y[i] = e->e2.y, E->e2z[i] = e->e2.z;
        E->nx[i] = e->n.x, E->ny[i] = e->n.y, E->nz[i] = e->n.z;
        E->area[i] = e->area;
        lr__v3 le = s->materials[s->geoms[e->geom].material].emission;
        E->lr[i] = le.x, E->lg[i] = le.y, E->lb[i] = le.z;
        const lr__geom *G = &s->geoms[e->geom];
        E->cx[i] = G->center.x, E->cy[i] = G->center.y;
        E->cz[i] = G->center.z, E->rad[i] = G->radius;
        E->is_sphere[i] = G->kind == LR__GEOM_SPHERE;
    }
    E->n = (int)n;
    int spheres = 0;
    for (size_t i = 0; i < n; i++)
        spheres += E->is_sphere[i] != 0.0;
    E->sphere = spheres == 0 ? 0 : spheres == (int)n ? 1 : 2;
}

/* The scalar code's material test for a Lambertian surface (scene.c's
 * lambert_triangles), untextured. */
static int lambertian(const lr__material *m)
{
    return !(v3_maxc(m->specular) > 0.0) && !(v3_maxc(m->reflect) > 0.0) &&
           !(v3_maxc(m->transmit) > 0.0) && v3_maxc(m->diffuse) > 0.0 &&
           !(v3_maxc(m->emission) > 0.0) && !lr__material_textured(m);
}

enum { ALONE = 1, FLAT = 2, SPHERE = 3 };

/* How the vector bounce takes a hit on geometry G: FLAT (an untextured
 * Lambertian flat triangle), SPHERE (an untextured Lambertian sphere),
 * or ALONE (path.c's scalar bounce). */
static int kind_of(const lr_scene *s, const lr__geom *G)
{
    const lr__material *m = &s->materials[G->material];
    if (G->lambert_triangles)
        return G->corner_normals != NULL || G->albedo_textured ||
                       lr__material_textured(m)
                   ? ALONE
                   : FLAT;
    return G->kind == LR__GEOM_SPHERE && lambertian(m) ? SPHERE : ALONE;
}

/* Lane i's hit on a sphere (kind SPHERE) into H: lr__hit_complete's
 * sphere, t solved again in double near the intersector's, then the
 * normal from the centre. */
static void sphere_hit(const lr__geom *G, lr__path16 *w, int depth, int i,
                       const struct RTCRayHit16 *rh)
{
    lr__hits16p *H = &w->H;
    const lr__paths16 *S = &w->S;
    lr__v3 org = v3(S->ox[i], S->oy[i], S->oz[i]);
    lr__v3 dir = depth == 0 ? v3(w->cdx[i], w->cdy[i], w->cdz[i])
                            : v3(S->dx[i], S->dy[i], S->dz[i]);
    double t = lr__sphere_refine_t(G, org, dir, (double)rh->ray.tfar[i],
                                   INFINITY);
    lr__v3 n = v3_norm(v3_sub(v3_madd(org, dir, t), G->center));
    H->t[i] = t;
    H->nx[i] = n.x, H->ny[i] = n.y, H->nz[i] = n.z;
}

int lr__path16_sort(const lr_scene *s, lr__path16 *w, int depth, int max_depth,
                    int n, const struct RTCRayHit16 *rh, int alone[16])
{
    lr__paths16 *S = &w->S;
    lr__hits16p *H = &w->H;
    int vec = w->vec && depth <= max_depth, m = 0;
    (void)n; /* (lanes n..15 are never alive) */
    int live[16];
    int nl = lr__path16_lanes_of(S->alive, live);
    vec = vec && nl > FEW_LIVE;
    for (int i = 0; i < 16; i++) {
        S->shadow[i] = 0.0;
        H->take[i] = 0.0;
    }
    for (int c = 0; c < nl; c++) {
        int i = live[c];
        unsigned g = rh->hit.geomID[i];
        if (w->vec && g == RTC_INVALID_GEOMETRY_ID) {
            /* path.c's bounce for a path that leaves the scene, at any
             * depth: in a scene lr__path16_scene_ok accepts the
             * environment has no map (so no sun for the light side, whose
             * weight is 1) and no light samples (a black background, or
             * a uniform one beside lamps), so its radiance is the
             * background and its density 0. */
            double wt = S->pdelta[i] != 0.0 ? 1.0
                                            : lr__path_mis(S->ppdf[i], 0.0);
            lr__v3 L = v3(S->Lr[i], S->Lg[i], S->Lb[i]);
            lr__v3 beta = v3(S->br[i], S->bg[i], S->bb[i]);
            L = v3_add(L, v3_scale(v3_mul(beta, s->background), wt));
            S->Lr[i] = L.x, S->Lg[i] = L.y, S->Lb[i] = L.z;
            S->alive[i] = 0.0;
            continue;
        }
        int k = ALONE;
        if (vec) {
            /* A geometry's kind asked once per packet (the first 64). */
            const lr__geom *G = &s->geoms[g];
            if (g < LR__PATH16_KINDS) {
                k = w->kind[g];
                if (k == 0)
                    k = w->kind[g] = (unsigned char)kind_of(s, G);
            } else {
                k = kind_of(s, G);
            }
            if (k == FLAT) {
                const double *nn = &G->face_ng[3 * (size_t)rh->hit.primID[i]];
                H->t[i] = rh->ray.tfar[i];
                H->nx[i] = nn[0], H->ny[i] = nn[1], H->nz[i] = nn[2];
                H->ar[i] = G->albedo.x, H->ag[i] = G->albedo.y;
                H->ab[i] = G->albedo.z;
            } else if (k == SPHERE) {
                sphere_hit(G, w, depth, i, rh);
                lr__v3 a = s->materials[G->material].diffuse;
                H->ar[i] = a.x, H->ag[i] = a.y, H->ab[i] = a.z;
            }
        }
        H->take[i] = k != ALONE;
        alone[m] = i;
        m += k == ALONE;
    }
    return m;
}

/* The emitter each lane's light sample picked: its fields (with more
 * than two emitters; lambert16). */
typedef struct picked16 {
    double ax[16], ay[16], az[16], e1x[16], e1y[16], e1z[16], e2x[16], e2y[16],
        e2z[16], nx[16], ny[16], nz[16], area[16], prob[16], lr[16], lg[16],
        lb[16];
} picked16;

/* Each lane's sample of a sphere lamp (sphere_samples), for lanes16:
 * what light.c's lr__light_sample_from returns, and the lamp. */
typedef struct sphere16 {
    double lx[16], ly[16], lz[16]; /* unit direction to the point */
    double d[16];                  /* its distance */
    double lpdf[16];               /* solid-angle density, pick included */
    double ok[16];                 /* 1.0 if a sample was made, else 0.0 */
    double is[16];                 /* 1.0 if the lamp picked is a sphere */
    double cx[16], cy[16], cz[16], rad[16];
    double lr[16], lg[16], lb[16];
} sphere16;

/* cos and sin of 2 pi u[1][i] for the taken lanes, by libm as light.c
 * takes them (a polynomial of our own would change the samples' bits),
 * outside the vector loop: GCC calls libm lane by lane anyway. */
static void sphere_angles(const double (*restrict u)[16],
                          const lr__hits16p *restrict H, double cph[16],
                          double sph[16])
{
    for (int i = 0; i < 16; i++) {
        cph[i] = sph[i] = 0.0;
        if (H->take[i] != 0.0) {
            double phi = 2.0 * M_PI * u[1][i];
            cph[i] = cos(phi);
            sph[i] = sin(phi);
        }
    }
}

/* The light sample of each lane on a sphere lamp: light.c's
 * sample_emitter for a sphere (uniform in the cone it subtends from
 * outside, pbrt-v3 section 14.2.2; by area from inside) and the checks
 * of lr__light_sample_from, operation for operation, both sides
 * computed and selected. */
static inline __attribute__((always_inline)) void
sphere_samples(const double (*restrict u)[16], const emitters16 *restrict E,
               const lr__hits16p *restrict H, const lr__paths16 *restrict S,
               const double *restrict pick, sphere16 *restrict Q)
{
    /* The picked lamp, lane by lane (as lambert16 copies triangles). */
    for (int i = 0; i < 16; i++) {
        int k = (int)pick[i];
        Q->cx[i] = E->cx[k], Q->cy[i] = E->cy[k], Q->cz[i] = E->cz[k];
        Q->rad[i] = E->rad[k], Q->lpdf[i] = E->prob[k];
        Q->lr[i] = E->lr[k], Q->lg[i] = E->lg[k], Q->lb[i] = E->lb[k];
        Q->d[i] = E->area[k]; /* (the area, until the loop below) */
        Q->is[i] = E->is_sphere[k];
    }
    double cph[16], sph[16];
    sphere_angles(u, H, cph, sph);
    for (int i = 0; i < 16; i++) {
        /* The hit point, as lanes16 computes it. */
        double t = H->t[i];
        double px = S->ox[i] + H->dx[i] * t, py = S->oy[i] + H->dy[i] * t,
               pz = S->oz[i] + H->dz[i] * t;
        double cx = Q->cx[i], cy = Q->cy[i], cz = Q->cz[i], r = Q->rad[i];
        double area = Q->d[i];
        double wcx = cx - px, wcy = cy - py, wcz = cz - pz;
        double dc = sqrt(wcx * wcx + wcy * wcy + wcz * wcz);
        int inside = dc <= r * (1.0 + 1e-9);
        double u0 = u[0][i];
        /* Inside: z = 1 - 2 u0, the point at the normal. */
        double z = 1.0 - 2.0 * u0, zz = 1.0 - z * z;
        double sr = sqrt(zz > 0.0 ? zz : 0.0);
        double inx = sr * cph[i], iny = sr * sph[i], inz = z;
        double iqx = cx + inx * r, iqy = cy + iny * r, iqz = cz + inz * r;
        double itx = iqx - px, ity = iqy - py, itz = iqz - pz;
        double id2 = itx * itx + ity * ity + itz * itz;
        double is = 1.0 / sqrt(id2);
        double icl = fabs(inx * (itx * is) + iny * (ity * is) +
                          inz * (itz * is));
        double ipdf = icl > 0.0 ? (area > 0.0 ? id2 / (area * icl) : 0.0) : 0.0;
        /* Outside: the cone about the direction to the centre. */
        double iw = 1.0 / dc;
        double wx = wcx * iw, wy = wcy * iw, wz = wcz * iw;
        double sin2 = r * r / (dc * dc), cm = 1.0 - sin2;
        double cos_max = sqrt(cm > 0.0 ? cm : 0.0);
        double omc = sin2 / (1.0 + cos_max);
        double cos_t = 1.0 - u0 * omc, st = 1.0 - cos_t * cos_t;
        double sin_t = sqrt(st > 0.0 ? st : 0.0);
        double ax = fabs(wx) > 0.9 ? 0.0 : 1.0;
        double ay = fabs(wx) > 0.9 ? 1.0 : 0.0, az = 0.0;
        double c1x = ay * wz - az * wy, c1y = az * wx - ax * wz,
               c1z = ax * wy - ay * wx;
        double l1 = sqrt(c1x * c1x + c1y * c1y + c1z * c1z), il1 = 1.0 / l1;
        double t1x = l1 > 0 ? c1x * il1 : c1x, t1y = l1 > 0 ? c1y * il1 : c1y,
               t1z = l1 > 0 ? c1z * il1 : c1z;
        double t2x = wy * t1z - wz * t1y, t2y = wz * t1x - wx * t1z,
               t2z = wx * t1y - wy * t1x;
        double sc = sin_t * cph[i], ss = sin_t * sph[i];
        double ux = wx * cos_t + (t1x * sc + t2x * ss);
        double uy = wy * cos_t + (t1y * sc + t2y * ss);
        double uz = wz * cos_t + (t1z * sc + t2z * ss);
        double b = dc * cos_t, h2 = r * r - dc * dc * sin_t * sin_t;
        double tq = b - sqrt(h2 > 0.0 ? h2 : 0.0);
        double oqx = px + ux * tq, oqy = py + uy * tq, oqz = pz + uz * tq;
        double opdf = omc > 0.0 ? 1.0 / (2.0 * M_PI * omc) : 0.0;
        /* The point, its normal (v3_norm) and density, by the side. */
        double qx = inside ? iqx : oqx, qy = inside ? iqy : oqy,
               qz = inside ? iqz : oqz;
        double mx = qx - cx, my = qy - cy, mz = qz - cz;
        double ml = sqrt(mx * mx + my * my + mz * mz), iml = 1.0 / ml;
        double onx = ml > 0 ? mx * iml : mx, ony = ml > 0 ? my * iml : my,
               onz = ml > 0 ? mz * iml : mz;
        double nx = inside ? inx : onx, ny = inside ? iny : ony,
               nz = inside ? inz : onz;
        double pdf = inside ? ipdf : opdf;
        /* lr__light_sample_from: the direction, one-sided emission, the
         * pick's probability (one kind of light: 1 / 1). */
        double tx = qx - px, ty = qy - py, tz = qz - pz;
        double d = sqrt(tx * tx + ty * ty + tz * tz), id = 1.0 / d;
        double lx = tx * id, ly = ty * id, lz = tz * id;
        double ok = pdf > 0.0 ? 1.0 : 0.0;
        ok = lx * nx + ly * ny + lz * nz < 0.0 ? ok : 0.0;
        double lpdf = 1.0 * Q->lpdf[i] * pdf;
        ok = lpdf > 0.0 ? ok : 0.0;
        Q->lx[i] = lx, Q->ly[i] = ly, Q->lz[i] = lz;
        Q->d[i] = d, Q->lpdf[i] = lpdf, Q->ok[i] = ok;
    }
}

/* lambert16's loop over the lanes; `two` and `sph` constant in each
 * call, so that GCC makes one loop for each (a select on it in one loop
 * kept the loop from vectorising).  sph: 0 if the lamps are triangles
 * (from E or K), 1 if spheres (their samples in Q), 2 if some of each
 * (both computed, and each lane's taken as Q->is says). */
static inline __attribute__((always_inline)) void
lanes16(lr__v3 amb, double ef, int rr, const double (*restrict u)[16],
        const emitters16 *restrict E, const lr__hits16p *restrict H,
        lr__paths16 *restrict S, const double *restrict pick,
        const picked16 *restrict K, const sphere16 *restrict Q, const int two,
        const int sph, const int pt)
{
    /* The first two emitters' fields, loaded here: loads under a select
     * in the loop kept GCC from vectorising it.  (E's entries past n
     * repeat the last, so [1] is there.) */
#define LOAD2(f) const double f##_0 = E->f[0], f##_1 = E->f[1]
    LOAD2(ax);
    LOAD2(ay);
    LOAD2(az);
    LOAD2(e1x);
    LOAD2(e1y);
    LOAD2(e1z);
    LOAD2(e2x);
    LOAD2(e2y);
    LOAD2(e2z);
    LOAD2(nx);
    LOAD2(ny);
    LOAD2(nz);
    LOAD2(area);
    LOAD2(prob);
    LOAD2(lr);
    LOAD2(lg);
    LOAD2(lb);
#undef LOAD2
#define EF(a, f) (two ? (pick[i] != 0.0 ? f##_1 : f##_0) : K->f[i])
    for (int i = 0; i < 16; i++) {
        int take = H->take[i] != 0.0;
        /* ---- the hit (trace.c's finish_hit, flat: ns = ng) ---- */
        double t = H->t[i];
        double dx = H->dx[i], dy = H->dy[i], dz = H->dz[i];
        double px = S->ox[i] + dx * t, py = S->oy[i] + dy * t,
               pz = S->oz[i] + dz * t;
        double gx = H->nx[i], gy = H->ny[i], gz = H->nz[i];
        int entering = dx * gx + dy * gy + dz * gz < 0.0;
        gx = entering ? gx : -gx;
        gy = entering ? gy : -gy;
        gz = entering ? gz : -gz;
        double m = fabs(px);
        m = fabs(py) > m ? fabs(py) : m;
        m = fabs(pz) > m ? fabs(pz) : m;
        double mag = m + t * sqrt(dx * dx + dy * dy + dz * dz);
        double eps = (ef + mag) * 0x1p-17; /* ef: the scene's eps_floor */

        /* ---- ambient (path.c's bounce) ---- */
        double ar = H->ar[i], ag = H->ag[i], ab = H->ab[i];
        double br = S->br[i], bg = S->bg[i], bb = S->bb[i];
        double Lr = S->Lr[i] + br * (ar * amb.x);
        double Lg = S->Lg[i] + bg * (ag * amb.y);
        double Lb = S->Lb[i] + bb * (ab * amb.z);

        /* ---- the frame and the lobe probability (lr__bsdf_init) ---- */
        double sign = copysign(1.0, gz);
        double fa = -1.0 / (sign + gz), fb = gx * gy * fa;
        double tx = 1.0 + sign * gx * gx * fa, ty = sign * fb, tz = -sign * gx;
        double bx = fb, by = sign + gy * gy * fa, bz = -gy;
        double w0 = maxc3(ar, ag, ab);
        double p0 = w0 * (1.0 / w0);
        double wox = -S->dx[i], woy = -S->dy[i], woz = -S->dz[i];
        double wol_z = wox * gx + woy * gy + woz * gz;

        /* ---- the light sample (light.c, path.c's next_event) ---- */
        double lx, ly, lz, d, lpdf, shadow, ler, leg, leb;
        int lamp = sph == 1 || (sph == 2 && Q->is[i] != 0.0);
        if (pt) {
            /* light.c's point light: the pick's probability 1 x 1, the
             * intensity over d^2 (no spot: falloff 1). */
            double tox = E->px - px, toy = E->py - py, toz = E->pz - pz;
            double d2 = tox * tox + toy * toy + toz * toz;
            shadow = d2 > 0.0 ? 1.0 : 0.0;
            d = sqrt(d2);
            double inv = 1.0 / d;
            lx = tox * inv, ly = toy * inv, lz = toz * inv;
            double fall = 1.0 / d2;
            ler = E->ir * fall, leg = E->ig * fall, leb = E->ib * fall;
            lpdf = 1.0 * 1.0;
        } else if (sph == 1) {
            lx = Q->lx[i], ly = Q->ly[i], lz = Q->lz[i];
            d = Q->d[i], lpdf = Q->lpdf[i], shadow = Q->ok[i];
            ler = Q->lr[i], leg = Q->lg[i], leb = Q->lb[i];
        } else {
            double su = sqrt(u[0][i]);
            double b1 = u[1][i] * su, b2 = su - b1;
            double qx = EF(ax, ax) + (EF(e1x, e1x) * b1 + EF(e2x, e2x) * b2);
            double qy = EF(ay, ay) + (EF(e1y, e1y) * b1 + EF(e2y, e2y) * b2);
            double qz = EF(az, az) + (EF(e1z, e1z) * b1 + EF(e2z, e2z) * b2);
            double enx = EF(enx_, nx), eny = EF(eny_, ny), enz = EF(enz_, nz);
            double tox = qx - px, toy = qy - py, toz = qz - pz;
            double d2 = tox * tox + toy * toy + toz * toz;
            double cl = fabs((enx * tox + eny * toy + enz * toz) / sqrt(d2));
            double area = EF(area_, area);
            /* (Conditions as 1.0 or 0.0 in doubles, selected rather than
         * combined as ints: GCC vectorises those selects.) */
            double spdf = cl > 0.0 ? (area > 0.0 ? d2 / (area * cl) : 0.0)
                                   : 0.0;
            shadow = spdf > 0.0 ? 1.0 : 0.0;
            d = sqrt(tox * tox + toy * toy + toz * toz);
            double inv = 1.0 / d;
            lx = tox * inv, ly = toy * inv, lz = toz * inv;
            shadow = lx * enx + ly * eny + lz * enz < 0.0 ? shadow : 0.0;
            lpdf = 1.0 * EF(prob, prob) * spdf;
            shadow = lpdf > 0.0 ? shadow : 0.0;
            ler = EF(ler, lr), leg = EF(leg, lg), leb = EF(leb, lb);
        }
        if (sph == 2) {
            lx = lamp ? Q->lx[i] : lx, ly = lamp ? Q->ly[i] : ly;
            lz = lamp ? Q->lz[i] : lz, d = lamp ? Q->d[i] : d;
            lpdf = lamp ? Q->lpdf[i] : lpdf, shadow = lamp ? Q->ok[i] : shadow;
            ler = lamp ? Q->lr[i] : ler, leg = lamp ? Q->lg[i] : leg;
            leb = lamp ? Q->lb[i] : leb;
        }
        /* lr__bsdf_eval: the diffuse lobe, both sides above. */
        double wil_z = lx * gx + ly * gy + lz * gz;
        double above = wil_z > 0.0 ? (wol_z > 0.0 ? 1.0 : 0.0) : 0.0;
        double fr = above != 0.0 ? 0.0 + ar * (1.0 / M_PI) : 0.0;
        double fg = above != 0.0 ? 0.0 + ag * (1.0 / M_PI) : 0.0;
        double fbb = above != 0.0 ? 0.0 + ab * (1.0 / M_PI) : 0.0;
        double bpdf = above != 0.0 ? 0.0 + p0 * wil_z / M_PI : 0.0;
        double cos_i = fabs(lx * gx + ly * gy + lz * gz);
        double ci = cos_i / lpdf;
        double cr = fr * ler * ci, cg = fg * leg * ci, cb = fbb * leb * ci;
        shadow = maxc3(cr, cg, cb) > 0.0 ? shadow : 0.0;
        double ma = lpdf * lpdf, mb = bpdf * bpdf;
        /* (A point light is a delta light: not weighted.) */
        double w = pt ? 1.0 : ma + mb > 0.0 ? ma / (ma + mb) : 0.0;
        cr = cr * w, cg = cg * w, cb = cb * w;
        double scr = br * cr, scg = bg * cg, scb = bb * cb;
        double side = lx * gx + ly * gy + lz * gz >= 0.0 ? 1.0 : -1.0;
        double sox = px + gx * (side * eps), soy = py + gy * (side * eps),
               soz = pz + gz * (side * eps);
        double stfar = 0.0, sdx = 0.0, sdy = 0.0, sdz = 0.0;
        if (sph != 1) {
            double ex = (px + lx * d) - sox, ey = (py + ly * d) - soy,
                   ez = (pz + lz * d) - soz;
            /* Aimed from the moved origin at the sampled point, as
             * path.c's next_event aims at a triangle's. */
            double elen = sqrt(ex * ex + ey * ey + ez * ez);
            stfar = isfinite(d) ? elen * (1.0 - 1e-4) : INFINITY;
            sdx = ex / elen, sdy = ey / elen, sdz = ez / elen;
        }
        if (sph) {
            /* path.c's next_event for a sphere lamp: the origin as
             * Embree's float ray holds it, the sampled direction kept,
             * stopped where the ray enters the lamp if that comes first
             * (lr__light_reach). */
            int fin = isfinite(d);
            double fx = fin ? (double)(float)sox : sox;
            double fy = fin ? (double)(float)soy : soy;
            double fz = fin ? (double)(float)soz : soz;
            double ex = (px + lx * d) - fx, ey = (py + ly * d) - fy,
                   ez = (pz + lz * d) - fz;
            double elen = sqrt(ex * ex + ey * ey + ez * ez);
            double ocx = fx - Q->cx[i], ocy = fy - Q->cy[i],
                   ocz = fz - Q->cz[i];
            double ob = ocx * lx + ocy * ly + ocz * lz;
            double oc = (ocx * ocx + ocy * ocy + ocz * ocz) -
                        Q->rad[i] * Q->rad[i];
            double disc = ob * ob - oc;
            double enter = -ob - sqrt(disc > 0.0 ? disc : 0.0);
            double reach = oc > 0.0 && disc >= 0.0 && enter > 0.0 &&
                                   enter < elen
                               ? enter
                               : elen;
            double sf = fin ? reach * (1.0 - 1e-4) : INFINITY;
            sox = lamp ? fx : sox, soy = lamp ? fy : soy;
            soz = lamp ? fz : soz, stfar = lamp ? sf : stfar;
            sdx = lamp ? lx : sdx, sdy = lamp ? ly : sdy;
            sdz = lamp ? lz : sdz;
        }

        /* ---- the BSDF sample (lr__bsdf_sample: the diffuse lobe) ---- */
        double alive = wol_z > 0.0 ? (u[5][i] < p0 ? 1.0 : 0.0) : 0.0;
        double u0 = u[2][i], r = sqrt(u0), sp, cp;
        lr__sincos_2pi(u[3][i], &sp, &cp);
        /* fmax(0.0, x) and fmin(0.95, x) as selects (the same values,
         * NaN included), which GCC vectorises. */
        double om = 1.0 - u0;
        double wlx = r * cp, wly = r * sp, wlz = sqrt(om > 0.0 ? om : 0.0);
        alive = wlz != 0.0 ? alive : 0.0;
        double wx = tx * wlx + bx * wly + gx * wlz;
        double wy = ty * wlx + by * wly + gy * wlz;
        double wz = tz * wlx + bz * wly + gz * wlz;
        double pdf = 0.0 + p0 * wlz / M_PI;
        alive = pdf > 0.0 ? alive : 0.0;
        double k2 = fabs(wlz) / pdf;
        double vr = (0.0 + ar * (1.0 / M_PI)) * k2;
        double vg = (0.0 + ag * (1.0 / M_PI)) * k2;
        double vb = (0.0 + ab * (1.0 / M_PI)) * k2;
        alive = maxc3(vr, vg, vb) > 0.0 ? alive : 0.0;
        /* (path.c's bounce checks that wi leaves on the same side of ng
         * as of ns: here ns = ng.) */
        double wn = wx * gx + wy * gy + wz * gz;
        br = br * vr, bg = bg * vg, bb = bb * vb;
        double side2 = wn >= 0.0 ? 1.0 : -1.0;
        double nox = px + gx * (side2 * eps);
        double noy = py + gy * (side2 * eps);
        double noz = pz + gz * (side2 * eps);
        /* Roulette (if rr), selected: a branch here kept GCC from
         * vectorising the loop. */
        double q = maxc3(br, bg, bb) * S->eta[i];
        q = q < 0.95 ? q : 0.95;
        alive = rr && !(u[6][i] < q) ? 0.0 : alive;
        double iq = 1.0 / q;
        br = rr ? br * iq : br, bg = rr ? bg * iq : bg, bb = rr ? bb * iq : bb;
        /* v3_finite */
        alive = fabs(br) <= DBL_MAX ? alive : 0.0;
        alive = fabs(bg) <= DBL_MAX ? alive : 0.0;
        alive = fabs(bb) <= DBL_MAX ? alive : 0.0;

        /* ---- the taken lanes' new state ---- */
#define SET(field, value) S->field[i] = take ? (value) : S->field[i]
        SET(Lr, Lr), SET(Lg, Lg), SET(Lb, Lb);
        SET(shadow, shadow);
        SET(sox, sox), SET(soy, soy), SET(soz, soz);
        SET(sdx, sdx), SET(sdy, sdy), SET(sdz, sdz);
        SET(scr, scr), SET(scg, scg), SET(scb, scb);
        SET(stfar, stfar);
        SET(br, br), SET(bg, bg), SET(bb, bb);
        SET(ppdf, pdf), SET(pdelta, 0.0);
        SET(ppx, px), SET(ppy, py), SET(ppz, pz);
        SET(ox, nox), SET(oy, noy), SET(oz, noz);
        SET(dx, wx), SET(dy, wy), SET(dz, wz);
        SET(alive, alive);
#undef SET
#undef EF
    }
}

__attribute__((target_clones("avx512f", "avx2", "default"))) static void
lambert16(lr__v3 amb, double ef, int rr, const double (*restrict u)[16],
          const emitters16 *restrict E, const lr__hits16p *restrict H,
          lr__paths16 *restrict S)
{
    /* light.c's pick: one kind of light (area), so u_pick * 1 - 0 picks
     * among the emitters: emitter_find's binary search gives the count
     * of the cdfs before the last that do not exceed u (they never
     * decrease). */
    double pick[16];
    for (int i = 0; i < 16; i++)
        pick[i] = 0.0;
    if (E->point) {
        lanes16(amb, ef, rr, u, E, H, S, pick, NULL, NULL, 0, 0, 1);
        return;
    }
    for (int j = 0; j + 1 < E->n; j++)
        for (int i = 0; i < 16; i++)
            pick[i] += E->cdf[j] <= u[4][i] * 1 - 0 ? 1.0 : 0.0;
    /* The picked emitter's fields: with one or two emitters (a
     * rectangle light) selected in the loop from the two; with more,
     * copied lane by lane first (a select per emitter in a loop of its
     * own kept GCC from vectorising, as did gathers in the loop). */
    picked16 K;
    sphere16 Q;
    if (E->sphere == 1) {
        sphere_samples(u, E, H, S, pick, &Q);
        lanes16(amb, ef, rr, u, E, H, S, pick, &K, &Q, 0, 1, 0);
        return;
    }
    if (E->n <= 2 && E->sphere == 0) {
        lanes16(amb, ef, rr, u, E, H, S, pick, &K, NULL, 1, 0, 0);
        return;
    }
    for (int i = 0; i < 16; i++) {
        int k = (int)pick[i];
        K.ax[i] = E->ax[k], K.ay[i] = E->ay[k], K.az[i] = E->az[k];
        K.e1x[i] = E->e1x[k], K.e1y[i] = E->e1y[k], K.e1z[i] = E->e1z[k];
        K.e2x[i] = E->e2x[k], K.e2y[i] = E->e2y[k], K.e2z[i] = E->e2z[k];
        K.nx[i] = E->nx[k], K.ny[i] = E->ny[k], K.nz[i] = E->nz[k];
        K.area[i] = E->area[k], K.prob[i] = E->prob[k];
        K.lr[i] = E->lr[k], K.lg[i] = E->lg[k], K.lb[i] = E->lb[k];
    }
    if (E->sphere == 2) {
        sphere_samples(u, E, H, S, pick, &Q);
        lanes16(amb, ef, rr, u, E, H, S, pick, &K, &Q, 0, 2, 0);
        return;
    }
    lanes16(amb, ef, rr, u, E, H, S, pick, &K, NULL, 0, 0, 0);
}

/* The paths of lanes 0..n-1 at their camera rays (as float, from r),
 * the others done; one vectorised loop (the unit directions' square
 * roots and quotients were 1% of the Cornell box's CPU time lane by
 * lane). */
__attribute__((target_clones("avx512f", "avx2", "default"))) static void
paths_start(lr__path16 *restrict w, const struct RTCRay16 *restrict r, int n)
{
    lr__paths16 *S = &w->S;
    for (int i = 0; i < 16; i++) {
        int live = i < n;
        double ox = live ? r->org_x[i] : 0.0, oy = live ? r->org_y[i] : 0.0,
               oz = live ? r->org_z[i] : 0.0;
        double dx = live ? r->dir_x[i] : 0.0, dy = live ? r->dir_y[i] : 0.0,
               dz = live ? r->dir_z[i] : 1.0;
        w->cdx[i] = dx, w->cdy[i] = dy, w->cdz[i] = dz;
        /* v3_norm */
        double l = sqrt(dx * dx + dy * dy + dz * dz), il = 1.0 / l;
        S->dx[i] = l > 0 ? dx * il : dx;
        S->dy[i] = l > 0 ? dy * il : dy;
        S->dz[i] = l > 0 ? dz * il : dz;
        S->Lr[i] = S->Lg[i] = S->Lb[i] = 0.0;
        S->br[i] = S->bg[i] = S->bb[i] = 1.0;
        S->ox[i] = S->ppx[i] = ox;
        S->oy[i] = S->ppy[i] = oy;
        S->oz[i] = S->ppz[i] = oz;
        S->ppdf[i] = 0.0;
        S->pdelta[i] = 1.0; /* the camera ray: nothing to weigh against */
        S->eta[i] = 1.0;
        S->alive[i] = live;
        S->shadow[i] = 0.0;
        w->H.take[i] = 0.0;
    }
}

void lr__path16_begin(const lr_scene *s, lr__path16 *w,
                      const struct RTCRayHit16 *rh, int n)
{
    w->vec = lr__path16_scene_ok(s);
    if (w->vec)
        emitters_get(s, &w->E);
    memset(w->kind, 0, sizeof w->kind);
    paths_start(w, &rh->ray, n);
}

void lr__path16_lambert(const lr_scene *s, lr__path16 *w, int depth,
                        const double u[LR__PATH_DIMS][16])
{
    /* Nothing to do where no lane was taken (past max_depth, or only
     * lanes shaded alone live). */
    lr__hits16p *H = &w->H;
    double any = 0.0;
    for (int i = 0; i < 16; i++)
        any += H->take[i];
    if (any == 0.0)
        return;
    /* The ray that hit: at depth 0 the camera's, as it made it. */
    const lr__paths16 *S = &w->S;
    memcpy(H->dx, depth == 0 ? w->cdx : S->dx, sizeof H->dx);
    memcpy(H->dy, depth == 0 ? w->cdy : S->dy, sizeof H->dy);
    memcpy(H->dz, depth == 0 ? w->cdz : S->dz, sizeof H->dz);
    int rr = depth + 1 >= LR__PATH_RR_FROM;
    lambert16(s->ambient, s->eps_floor, rr, u, &w->E, H, &w->S);
}
