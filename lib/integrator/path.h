/*
 * path.h: what the path integrator's two files share: a packet's sixteen
 * paths between bounces, as arrays (lr__paths16) and one lane of them as
 * a struct (lr__path_lane, which path.c shades alone), and the work on
 * all sixteen at once: the bounce on Lambertian surfaces (path16.c), the
 * rays' packing and the hashed numbers (path16_rays.c).
 */
#ifndef LR_PATH_H
#define LR_PATH_H

#include "accel/trace.h"

#define LR__PATH_DIMS 8 /* random numbers per bounce (7 used) */
#define LR__PATH_RR_FROM 5

/* One path of a packet, between bounces (path.c's scalar bounce). */
typedef struct lr__path_lane {
    lr__v3 L, beta;
    lr__v3 org, dir;  /* the ray traced next (dir unit) */
    lr__v3 prev_p;    /* where dir was sampled */
    double prev_pdf;  /* its BSDF density (solid angle) */
    int prev_delta;   /* 1 if from a delta lobe or the camera */
    double eta_scale; /* product of eta^2 crossed, for roulette */
    /* This bounce's light sample: c is added if the shadow ray from
     * s_org along s_dir is clear up to s_tfar. */
    int shadow;
    lr__v3 s_org, s_dir, s_c;
    double s_tfar;
} lr__path_lane;

/* The lanes with mask[i] set, in order, in lane[0..m-1]; returns m.
 * Without a branch per lane (a lane list made with one had cost 5% of
 * the Cornell box's CPU time in mispredictions). */
static inline int lr__path16_lanes_of(const double mask[16], int lane[16])
{
    int m = 0;
    for (int i = 0; i < 16; i++) {
        lane[m] = i;
        m += mask[i] != 0.0;
    }
    return m;
}

/* The power heuristic's weight of density a against b (Veach 1997,
 * section 9.2.4, beta = 2). */
static inline double lr__path_mis(double a, double b)
{
    a *= a, b *= b;
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

/* Whether path16.c's vector bounce can take this scene's Lambertian
 * hits: no infinite planes, no environment map, and its only lights
 * either at most 16 emitting triangles or spheres without textures (no
 * point or directional light), or one point light (not a spot).  A
 * uniform background beside them is fine: light.c leaves it to the
 * BSDF's rays, so a bounce's light sample is the lamps'.  Cheap: a few
 * fields. */
int lr__path16_scene_ok(const lr_scene *s);

#define LR__PATH16_EMITTERS 16
#define LR__PATH16_KINDS 64

/* The emitters, by index: what light.c reads of each. */
typedef struct emitters16 {
    double cdf[LR__PATH16_EMITTERS]; /* +inf past the last but one */
    double prob[LR__PATH16_EMITTERS];
    double ax[LR__PATH16_EMITTERS], ay[LR__PATH16_EMITTERS],
        az[LR__PATH16_EMITTERS];
    double e1x[LR__PATH16_EMITTERS], e1y[LR__PATH16_EMITTERS],
        e1z[LR__PATH16_EMITTERS];
    double e2x[LR__PATH16_EMITTERS], e2y[LR__PATH16_EMITTERS],
        e2z[LR__PATH16_EMITTERS];
    double nx[LR__PATH16_EMITTERS], ny[LR__PATH16_EMITTERS],
        nz[LR__PATH16_EMITTERS];
    double area[LR__PATH16_EMITTERS];
    double lr[LR__PATH16_EMITTERS], lg[LR__PATH16_EMITTERS],
        lb[LR__PATH16_EMITTERS];
    /* Sphere lamps: centre and radius (the fields above that describe a
     * triangle are unset). */
    double cx[LR__PATH16_EMITTERS], cy[LR__PATH16_EMITTERS],
        cz[LR__PATH16_EMITTERS], rad[LR__PATH16_EMITTERS];
    double is_sphere[LR__PATH16_EMITTERS]; /* 1.0 or 0.0 (a triangle) */
    int n;                                 /* how many */
    int sphere; /* 0: every emitter a triangle; 1: every one a sphere; 2:
                 * some of each */
    /* 1 if the scene's one light is a point light (n is then 0): its
     * position and intensity. */
    int point;
    double px, py, pz, ir, ig, ib;
} emitters16;

/* The sixteen paths of a packet between bounces, as arrays: lane i's
 * lr__path_lane is element i of each (path.c copies a lane out to shade
 * it alone and back).  Kept as arrays through the whole bounce so that
 * the vector bounce, the packing of rays and the sums read and write
 * them in place: gathering lanes into arrays and scattering them back
 * per bounce had been a fifth of the Cornell box's CPU time. */
typedef struct lr__paths16 {
    double Lr[16], Lg[16], Lb[16];
    double br[16], bg[16], bb[16];    /* throughput */
    double ox[16], oy[16], oz[16];    /* the ray traced next */
    double dx[16], dy[16], dz[16];    /* (unit) */
    double ppx[16], ppy[16], ppz[16]; /* prev_p */
    double ppdf[16], pdelta[16];      /* prev_pdf, prev_delta (1 or 0) */
    double eta[16];                   /* eta_scale */
    double alive[16];                 /* 1 or 0 */
    /* This bounce's light sample (shadow 1 or 0). */
    double shadow[16];
    double sox[16], soy[16], soz[16], sdx[16], sdy[16], sdz[16];
    double scr[16], scg[16], scb[16], stfar[16];
} lr__paths16;

/* A bounce's hits that path16.c shades (take 1), as arrays. */
typedef struct lr__hits16p {
    double take[16];
    double t[16];
    double nx[16], ny[16], nz[16]; /* unit geometric normal */
    double ar[16], ag[16], ab[16]; /* albedo */
    double dx[16], dy[16], dz[16]; /* the ray's direction */
} lr__hits16p;

/* path16.c's working space for one packet's paths (one per thread): the
 * scene's emitters, the paths, this bounce's hits, and the camera rays'
 * directions as the camera made them (the first hit is completed with
 * those). */
typedef struct lr__path16 {
    emitters16 E;
    lr__paths16 S;
    lr__hits16p H;
    double cdx[16], cdy[16], cdz[16];
    int vec; /* lr__path16_scene_ok */
    /* How the vector bounce takes geometry g < LR__PATH16_KINDS, found
     * at its first hit in the packet (0: not yet). */
    unsigned char kind[LR__PATH16_KINDS];
} lr__path16;

/* Starts w on a packet of camera rays (lanes 0..n-1 of rh, which the
 * camera filled): the paths' state, and (if vec) the emitters. */
void lr__path16_begin(const lr_scene *s, lr__path16 *w,
                      const struct RTCRayHit16 *rh, int n);

/* Sorts the live lanes of 0..n-1 at bounce `depth` (rh: the answer for
 * the rays w->S holds, or at depth 0 the camera's): those the vector
 * bounce takes (an untextured Lambertian flat triangle or sphere, at a
 * depth <= max_depth, in a scene lr__path16_scene_ok accepts, when more
 * than two lanes are live) get
 * w->H.take and their hit in w->H; in such a scene a lane whose ray
 * left it is done here (its background light added); the others are
 * listed in alone[], in order, their count returned.  Clears every
 * lane's S.shadow. */
int lr__path16_sort(const lr_scene *s, lr__path16 *w, int depth, int max_depth,
                    int n, const struct RTCRayHit16 *rh, int alone[16]);

/* The bounce of the lanes with w->H.take[i] set, all at once, at a
 * depth <= max_depth: what path.c's bounce does for such a hit,
 * operation for operation (so each lane's result is the same to the
 * bit): ambient light, the light sample (S.shadow, s*), the BSDF sample
 * and roulette (S.b*, o*, d*, pp*, alive).  u[j][i] is lane i's j-th
 * number of this bounce.  Other lanes keep what they hold. */
void lr__path16_lambert(const lr_scene *s, lr__path16 *w, int depth,
                        const double u[LR__PATH_DIMS][16]);

/* The hashed numbers u[j][i], j < dims, of dimension dim + j for the
 * keys of the lanes with alive[i] set (path.c's bounce_numbers); the
 * other lanes' u keep what they hold. */
void lr__path16_hashed(const uint64_t key[16], const double alive[16],
                       uint32_t dim, int dims, double u[LR__PATH_DIMS][16]);

/* The lanes with a light sample to test (S.shadow), packed into P's
 * first entries in lane order (P->m set); returns how many.  The bounds
 * are checked by lr__path16_pack_rays, which must follow. */
int lr__path16_pack_shadows(const lr__paths16 *S, lr__rays_packed *P);

/* The live lanes' next rays (S.o*, S.d*; tfar infinite), added to P
 * after its P->m entries; returns how many.  Every entry that Embree
 * could not take (lr__embree_can_trace) then meets nothing, as
 * lr__shadow_ray16 makes it. */
int lr__path16_pack_rays(const lr__paths16 *S, lr__rays_packed *P);

/* The shadow rays (S.shadow) into r, and the live lanes' next rays
 * (S.alive) into rh's rays (their hits' geomID and instID unset), as
 * lr__shadow_ray16 fills a lane and lr__ray16_quiet_lanes quiets the
 * others, all sixteen lanes at once; valid[i] -1 for a ray, else 0.
 * Return how many rays. */
int lr__path16_shadows16(const lr__paths16 *S, struct RTCRay16 *r,
                         int valid[16]);
int lr__path16_rays16(const lr__paths16 *S, struct RTCRayHit16 *rh,
                      int valid[16]);

/* L += s_c for packed shadow entry c < ns with occ[c] == 0. */
void lr__path16_unoccluded(lr__paths16 *S, const lr__rays_packed *P, int ns,
                           const double occ[LR__PACKED]);

/* 0 turns path16.c off (path.c shades every lane alone): for the test
 * that the two agree to the bit. */
extern int lr__path16_enabled;

#endif
