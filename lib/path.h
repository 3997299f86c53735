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
int lr__path16_geom_ok(const lr_scene *s, unsigned g);

/* The bounce of the lanes i with take[i] set, all at once: each did
 * hit a triangle that lr__path16_geom_ok accepts (rh: Embree's answer
 * for the ray from hit_org[.][i] along hit_dir[.][i]), at a depth <=
 * max_depth, in a scene that lr__path16_scene_ok accepts.  Does what
 * path.c's bounce does for such a hit, operation for operation (so each
 * lane's result is the same to the bit): ambient light, the light
 * sample (P[i].shadow, s_*), the BSDF sample and roulette (P[i].beta,
 * org, dir, prev_*); alive[i] says whether the path goes on.  u[j][i]
 * is the lane's j-th number of this bounce. */
void lr__path16_lambert(const lr_scene *s, int depth, const int take[16],
                        const double hit_org[3][16],
                        const double hit_dir[3][16],
                        const struct RTCRayHit16 *rh,
                        const double u[LR__PATH_DIMS][16],
                        lr__path_lane P[16], int alive[16]);

/* 0 turns path16.c off (path.c shades every lane alone): for the test
 * that the two agree to the bit. */
extern int lr__path16_enabled;

#endif
