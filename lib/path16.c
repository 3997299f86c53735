/*
 * path16.c: the path integrator's bounce for sixteen lanes at once, on
 * flat Lambertian triangles in a scene lit by a few emitting triangles
 * (path.h): the hit, ambient light, the light sample, the cosine-
 * weighted BSDF sample and roulette, in structure-of-arrays loops over
 * the lanes that GCC vectorises (double, as path.c).
 *
 * Every operation is the one path.c's scalar code does (trace.c's
 * finish_hit, bsdf.c, light.c, path.c's bounce and next_event), in the
 * same order and without FMA contraction (-ffp-contract=off), so each
 * lane's result is the scalar result to the bit (test_path.c renders
 * both ways and compares bytes).  Where the scalar code returns early,
 * these loops compute on and mask the result.  Lanes not taken compute
 * on whatever they hold; nobody reads those results.
 */
#include "path.h"
#include "bsdf.h"
#include "light.h"

#include <float.h>
#include <math.h>

int lr__path16_enabled = 1;

#define MAX_EMITTERS LR__PATH16_EMITTERS

int lr__path16_scene_ok(const lr_scene *s)
{
    if (!lr__path16_enabled || s->n_planes > 0 || s->n_lights > 0 ||
        lr__env_is_light(s) || s->n_emitters == 0 ||
        s->n_emitters > MAX_EMITTERS)
        return 0;
    for (size_t i = 0; i < s->n_emitters; i++) {
        const lr__geom *g = &s->geoms[s->emitters[i].geom];
        if (g->kind != LR__GEOM_TRIANGLES ||
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
    size_t n = s->n_emitters;
    for (size_t i = 0; i < MAX_EMITTERS; i++) {
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
    }
}

__attribute__((target_clones("avx512f", "avx2", "default")))
static void lambert16(lr__v3 amb, int rr,
                      const double (*restrict u)[16], lanes16 *restrict l)
{
    for (int i = 0; i < 16; i++) {
        /* ---- the hit (trace.c's finish_hit, flat: ns = ng) ---- */
        double t = l->t[i];
        double dx = l->dx[i], dy = l->dy[i], dz = l->dz[i];
        double px = l->ox[i] + dx * t, py = l->oy[i] + dy * t,
               pz = l->oz[i] + dz * t;
        double gx = l->nx[i], gy = l->ny[i], gz = l->nz[i];
        int entering = dx * gx + dy * gy + dz * gz < 0.0;
        gx = entering ? gx : -gx;
        gy = entering ? gy : -gy;
        gz = entering ? gz : -gz;
        double m = fabs(px);
        m = fabs(py) > m ? fabs(py) : m;
        m = fabs(pz) > m ? fabs(pz) : m;
        double mag = m + t * sqrt(dx * dx + dy * dy + dz * dz);
        double eps = (1.0 + mag) * 0x1p-17;

        /* ---- ambient (path.c's bounce) ---- */
        double ar = l->ar[i], ag = l->ag[i], ab = l->ab[i];
        double br = l->br[i], bg = l->bg[i], bb = l->bb[i];
        double Lr = l->Lr[i] + br * (ar * amb.x);
        double Lg = l->Lg[i] + bg * (ag * amb.y);
        double Lb = l->Lb[i] + bb * (ab * amb.z);

        /* ---- the frame and the lobe probability (lr__bsdf_init) ---- */
        double sign = copysign(1.0, gz);
        double fa = -1.0 / (sign + gz), fb = gx * gy * fa;
        double tx = 1.0 + sign * gx * gx * fa, ty = sign * fb, tz = -sign * gx;
        double bx = fb, by = sign + gy * gy * fa, bz = -gy;
        double w0 = maxc3(ar, ag, ab);
        double p0 = w0 * (1.0 / w0);
        double wox = -l->wx[i], woy = -l->wy[i], woz = -l->wz[i];
        double wol_z = wox * gx + woy * gy + woz * gz;

        /* ---- the light sample (light.c, path.c's next_event) ---- */
        double su = sqrt(u[0][i]);
        double b1 = u[1][i] * su, b2 = su - b1;
        double qx = l->ax[i] + (l->e1x[i] * b1 + l->e2x[i] * b2);
        double qy = l->ay[i] + (l->e1y[i] * b1 + l->e2y[i] * b2);
        double qz = l->az[i] + (l->e1z[i] * b1 + l->e2z[i] * b2);
        double enx = l->enx[i], eny = l->eny[i], enz = l->enz[i];
        double tox = qx - px, toy = qy - py, toz = qz - pz;
        double d2 = tox * tox + toy * toy + toz * toz;
        double cl = fabs((enx * tox + eny * toy + enz * toz) / sqrt(d2));
        double area = l->area[i];
        /* (Conditions as 1.0 or 0.0 in doubles, selected rather than
         * combined as ints: GCC vectorises those selects.) */
        double spdf = cl > 0.0 ? (area > 0.0 ? d2 / (area * cl) : 0.0) : 0.0;
        double shadow = spdf > 0.0 ? 1.0 : 0.0;
        double d = sqrt(tox * tox + toy * toy + toz * toz);
        double inv = 1.0 / d;
        double lx = tox * inv, ly = toy * inv, lz = toz * inv;
        shadow = lx * enx + ly * eny + lz * enz < 0.0 ? shadow : 0.0;
        double lpdf = 1.0 * l->prob[i] * spdf;
        shadow = lpdf > 0.0 ? shadow : 0.0;
        /* lr__bsdf_eval: the diffuse lobe, both sides above. */
        double wil_z = lx * gx + ly * gy + lz * gz;
        double above = wil_z > 0.0 ? (wol_z > 0.0 ? 1.0 : 0.0) : 0.0;
        double fr = above != 0.0 ? 0.0 + ar * (1.0 / M_PI) : 0.0;
        double fg = above != 0.0 ? 0.0 + ag * (1.0 / M_PI) : 0.0;
        double fbb = above != 0.0 ? 0.0 + ab * (1.0 / M_PI) : 0.0;
        double bpdf = above != 0.0 ? 0.0 + p0 * wil_z / M_PI : 0.0;
        double cos_i = fabs(lx * gx + ly * gy + lz * gz);
        double ci = cos_i / lpdf;
        double cr = fr * l->ler[i] * ci, cg = fg * l->leg[i] * ci,
               cb = fbb * l->leb[i] * ci;
        shadow = maxc3(cr, cg, cb) > 0.0 ? shadow : 0.0;
        double ma = lpdf * lpdf, mb = bpdf * bpdf;
        double w = ma + mb > 0.0 ? ma / (ma + mb) : 0.0;
        cr = cr * w, cg = cg * w, cb = cb * w;
        l->scr[i] = br * cr, l->scg[i] = bg * cg, l->scb[i] = bb * cb;
        double side = lx * gx + ly * gy + lz * gz >= 0.0 ? 1.0 : -1.0;
        double sox = px + gx * (side * eps), soy = py + gy * (side * eps),
               soz = pz + gz * (side * eps);
        l->sox[i] = sox, l->soy[i] = soy, l->soz[i] = soz;
        l->sdx[i] = lx, l->sdy[i] = ly, l->sdz[i] = lz;
        double ex = (px + lx * d) - sox, ey = (py + ly * d) - soy,
               ez = (pz + lz * d) - soz;
        l->stfar[i] = isfinite(d) ? sqrt(ex * ex + ey * ey + ez * ez) *
                                        (1.0 - 1e-4)
                                  : INFINITY;
        l->shadow[i] = shadow;

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
        l->nox[i] = px + gx * (side2 * eps);
        l->noy[i] = py + gy * (side2 * eps);
        l->noz[i] = pz + gz * (side2 * eps);
        l->ndx[i] = wx, l->ndy[i] = wy, l->ndz[i] = wz;
        if (rr) {
            double q = maxc3(br, bg, bb) * l->eta_scale[i];
            q = q < 0.95 ? q : 0.95;
            alive = u[6][i] < q ? alive : 0.0;
            double iq = 1.0 / q;
            br = br * iq, bg = bg * iq, bb = bb * iq;
        }
        /* v3_finite */
        alive = fabs(br) <= DBL_MAX ? alive : 0.0;
        alive = fabs(bg) <= DBL_MAX ? alive : 0.0;
        alive = fabs(bb) <= DBL_MAX ? alive : 0.0;
        l->alive[i] = alive;
        l->br[i] = br, l->bg[i] = bg, l->bb[i] = bb;
        l->Lr[i] = Lr, l->Lg[i] = Lg, l->Lb[i] = Lb;
        l->px[i] = px, l->py[i] = py, l->pz[i] = pz;
        l->pdf[i] = pdf;
    }
}

void lr__path16_begin(const lr_scene *s, lr__path16 *w)
{
    emitters_get(s, &w->E);
}

void lr__path16_lambert(const lr_scene *s, lr__path16 *w, int depth,
                        const int take[16], const double hit_org[3][16],
                        const double hit_dir[3][16],
                        const struct RTCRayHit16 *rh,
                        const double u[LR__PATH_DIMS][16],
                        lr__path_lane P[16], int alive[16])
{
    const emitters16 *E = &w->E;
    lanes16 *l = &w->l;
    for (int i = 0; i < 16; i++) {
        if (!take[i])
            continue;
        const lr__path_lane *p = &P[i];
        const lr__geom *g = &s->geoms[rh->hit.geomID[i]];
        const double *n = &g->face_ng[3 * (size_t)rh->hit.primID[i]];
        l->ox[i] = hit_org[0][i], l->oy[i] = hit_org[1][i], l->oz[i] = hit_org[2][i];
        l->dx[i] = hit_dir[0][i], l->dy[i] = hit_dir[1][i], l->dz[i] = hit_dir[2][i];
        l->wx[i] = p->dir.x, l->wy[i] = p->dir.y, l->wz[i] = p->dir.z;
        l->t[i] = rh->ray.tfar[i];
        l->nx[i] = n[0], l->ny[i] = n[1], l->nz[i] = n[2];
        lr__v3 a = s->materials[g->material].diffuse;
        l->ar[i] = a.x, l->ag[i] = a.y, l->ab[i] = a.z;
        l->br[i] = p->beta.x, l->bg[i] = p->beta.y, l->bb[i] = p->beta.z;
        l->Lr[i] = p->L.x, l->Lg[i] = p->L.y, l->Lb[i] = p->L.z;
        l->eta_scale[i] = p->eta_scale;
        /* light.c's pick: one kind of light (area), so u_pick * 1 - 0
         * picks among the emitters. */
        double upick = u[4][i] * 1 - 0;
        int k = 0;
        for (int j = 0; j < MAX_EMITTERS; j++)
            k += E->cdf[j] <= upick;
        l->ax[i] = E->ax[k], l->ay[i] = E->ay[k], l->az[i] = E->az[k];
        l->e1x[i] = E->e1x[k], l->e1y[i] = E->e1y[k], l->e1z[i] = E->e1z[k];
        l->e2x[i] = E->e2x[k], l->e2y[i] = E->e2y[k], l->e2z[i] = E->e2z[k];
        l->enx[i] = E->nx[k], l->eny[i] = E->ny[k], l->enz[i] = E->nz[k];
        l->area[i] = E->area[k], l->prob[i] = E->prob[k];
        l->ler[i] = E->lr[k], l->leg[i] = E->lg[k], l->leb[i] = E->lb[k];
    }
    lambert16(s->ambient, depth + 1 >= LR__PATH_RR_FROM, u, l);
    for (int i = 0; i < 16; i++) {
        if (!take[i])
            continue;
        lr__path_lane *p = &P[i];
        p->L = v3(l->Lr[i], l->Lg[i], l->Lb[i]);
        p->shadow = l->shadow[i] != 0.0;
        p->s_org = v3(l->sox[i], l->soy[i], l->soz[i]);
        p->s_dir = v3(l->sdx[i], l->sdy[i], l->sdz[i]);
        p->s_c = v3(l->scr[i], l->scg[i], l->scb[i]);
        p->s_tfar = l->stfar[i];
        p->beta = v3(l->br[i], l->bg[i], l->bb[i]);
        p->prev_pdf = l->pdf[i];
        p->prev_delta = 0;
        p->prev_p = v3(l->px[i], l->py[i], l->pz[i]);
        p->org = v3(l->nox[i], l->noy[i], l->noz[i]);
        p->dir = v3(l->ndx[i], l->ndy[i], l->ndz[i]);
        alive[i] = l->alive[i] != 0.0;
    }
}
