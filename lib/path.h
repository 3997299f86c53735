/*
 * path.h: what the path integrator's two files share: a path between
 * bounces (path.c follows it lane by lane) and the bounce of sixteen
 * lanes at once on Lambertian triangles (path16.c).
 */
#ifndef LR_PATH_H
#define LR_PATH_H

#include "scene.h"

#define LR__PATH_DIMS 8 /* random numbers per bounce (7 used) */
#define LR__PATH_RR_FROM 5

/* One path of a packet, between bounces. */
typedef struct lr__path_lane {
    lr__v3 L, beta;
    lr__v3 org, dir;    /* the ray traced next (dir unit) */
    lr__v3 prev_p;      /* where dir was sampled */
    double prev_pdf;    /* its BSDF density (solid angle) */
    int prev_delta;     /* 1 if from a delta lobe or the camera */
    double eta_scale;   /* product of eta^2 crossed, for roulette */
    /* This bounce's light sample: c is added if the shadow ray from
     * s_org along s_dir is clear up to s_tfar. */
    int shadow;
    lr__v3 s_org, s_dir, s_c;
    double s_tfar;
} lr__path_lane;

/* Whether path16.c can take this scene's flat Lambertian triangles: no
 * infinite planes, and its only lights are at most 16 emitting
 * triangles without textures (no environment, point or directional
 * light).  Cheap: a few fields. */
int lr__path16_scene_ok(const lr_scene *s);

/* Whether a hit on geometry g (a valid Embree ID) can go to path16.c:
 * a flat triangle mesh whose material is Lambertian and untextured. */
static inline int lr__path16_geom_ok(const lr_scene *s, unsigned g)
{
    const lr__geom *G = &s->geoms[g];
    return G->lambert_triangles && G->corner_normals == NULL &&
           !lr__material_textured(&s->materials[G->material]);
}

#define LR__PATH16_EMITTERS 16

/* The emitters, by index: what light.c reads of each. */
typedef struct emitters16 {
    double cdf[LR__PATH16_EMITTERS]; /* +inf past the last but one */
    double prob[LR__PATH16_EMITTERS];
    double ax[LR__PATH16_EMITTERS], ay[LR__PATH16_EMITTERS], az[LR__PATH16_EMITTERS];
    double e1x[LR__PATH16_EMITTERS], e1y[LR__PATH16_EMITTERS], e1z[LR__PATH16_EMITTERS];
    double e2x[LR__PATH16_EMITTERS], e2y[LR__PATH16_EMITTERS], e2z[LR__PATH16_EMITTERS];
    double nx[LR__PATH16_EMITTERS], ny[LR__PATH16_EMITTERS], nz[LR__PATH16_EMITTERS];
    double area[LR__PATH16_EMITTERS];
    double lr[LR__PATH16_EMITTERS], lg[LR__PATH16_EMITTERS], lb[LR__PATH16_EMITTERS];
} emitters16;

/* The lanes' inputs and outputs, as arrays. */
typedef struct lanes16 {
    double ox[16], oy[16], oz[16];    /* the ray that hit */
    double dx[16], dy[16], dz[16];
    double wx[16], wy[16], wz[16];    /* the path's unit direction */
    double t[16];
    double nx[16], ny[16], nz[16];    /* face normal */
    double ar[16], ag[16], ab[16];    /* albedo */
    double br[16], bg[16], bb[16];    /* throughput */
    double Lr[16], Lg[16], Lb[16];
    double eta_scale[16];
    /* The emitter each lane's light sample picked (emitters16). */
    double ax[16], ay[16], az[16], e1x[16], e1y[16], e1z[16];
    double e2x[16], e2y[16], e2z[16], enx[16], eny[16], enz[16];
    double area[16], prob[16], ler[16], leg[16], leb[16];
    /* Results. */
    double shadow[16], alive[16];   /* 1 or 0 */
    double sox[16], soy[16], soz[16], sdx[16], sdy[16], sdz[16];
    double scr[16], scg[16], scb[16], stfar[16];
    double px[16], py[16], pz[16];
    double nox[16], noy[16], noz[16], ndx[16], ndy[16], ndz[16];
    double pdf[16];
} lanes16;

/* path16.c's working space for one packet's paths: the scene's
 * emitters as arrays, and the lanes'. */
typedef struct lr__path16 {
    emitters16 E;
    lanes16 l;
} lr__path16;

/* Prepares w for a packet (once, before its first bounce): its
 * emitters.  The lanes are the caller's to zero once (a thread's w
 * serves all its packets: zeroing its 9 KB per packet was 2.5% of the
 * Cornell box's CPU time). */
void lr__path16_begin(const lr_scene *s, lr__path16 *w);

/* The bounce of the lanes i with take[i] set, all at once: each did
 * hit a triangle that lr__path16_geom_ok accepts (rh: Embree's answer
 * for the ray from hit_org[.][i] along hit_dir[.][i]), at a depth <=
 * max_depth, in a scene that lr__path16_scene_ok accepts.  Does what
 * path.c's bounce does for such a hit, operation for operation (so each
 * lane's result is the same to the bit): ambient light, the light
 * sample (P[i].shadow, s_*), the BSDF sample and roulette (P[i].beta,
 * org, dir, prev_*); alive[i] says whether the path goes on.  u[j][i]
 * is the lane's j-th number of this bounce.  Lanes not taken keep in w
 * what they held (zeros, or an earlier bounce's or packet's): the
 * vector loop computes on them too, and nobody reads those results. */
void lr__path16_lambert(const lr_scene *s, lr__path16 *w, int depth,
                        const int take[16], const double hit_org[3][16],
                        const double hit_dir[3][16],
                        const struct RTCRayHit16 *rh,
                        const double u[LR__PATH_DIMS][16],
                        lr__path_lane P[16], int alive[16]);

/* 0 turns path16.c off (path.c shades every lane alone): for the test
 * that the two agree to the bit. */
extern int lr__path16_enabled;

#endif
