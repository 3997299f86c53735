/*
 * ceiling.c: the bare-Embree ceiling for `make bench`.
 *
 * Loads the benchmark scene's geometry by itself (scenes/bench.json: three
 * translated copies of scenes/meshes/bunny.obj and a 200 x 200 ground
 * square; nothing from lib/ is used), pre-generates the thin-lens camera
 * rays of W x H x spp samples, and times Embree's traversal alone:
 *
 *   camera  rays: rtcIntersect16 (and rtcIntersect8, rtcIntersect1M,
 *                 rtcIntersect1 for comparison), coherent context;
 *   shadow  rays: from each camera hit whose (viewer-side) geometric normal
 *                 faces the point light, towards the light, with
 *                 rtcOccluded16 / 8 / 1M / 1.
 *
 * No shading, no sampling and no film: only the calls into Embree are
 * timed, on 1 and on N threads (pthreads; threads take chunks of packets
 * from a shared counter).  The ray layouts are filled before each timed
 * pass and are not part of the time.
 *
 * Output: a human-readable table, and one line per (api, threads) that
 * starts with "RESULT" and holds key=value pairs for bench/run.sh.
 *
 * Usage: ceiling [--obj scenes/meshes/bunny.obj] [--width 640]
 *                [--height 480] [--spp 16] [--threads N] [--repeat 3]
 *                [--api all|16|8|1M|1] [--order all|block|pixel] [--robust]
 *
 * Packet orders: "block", a 4 x 4 pixel block at one sample index per
 * packet; "pixel", 16 consecutive samples of one pixel per packet (both go
 * through the image in 4 x 4 blocks).  The ceiling printed last (CEILING
 * lines) is the fastest camera pass plus the fastest shadow pass over every
 * API and order, per thread count.  Each pass is also timed in CPU time
 * (CLOCK_PROCESS_CPUTIME_ID): *_cpu figures, "samples per CPU second times
 * threads", estimate the rate on a machine that others are not using.
 *
 * Build: cc -std=c11 -O2 -o ceiling bench/ceiling.c -lembree3 -lpthread -lm
 */
#define _GNU_SOURCE
#include <embree3/rtcore.h>

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <pmmintrin.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <xmmintrin.h>

/* ---- the scene: keep in step with scenes/bench.json ------------------- */
static const float CAM_POS[3] = {0.0f, 4.0f, 30.0f};
static const float CAM_LOOK[3] = {0.0f, 4.0f, 0.0f};
static const float CAM_UP[3] = {0.0f, 1.0f, 0.0f};
static const double CAM_FOV = 40.0; /* vertical, degrees */
static const double LENS_RADIUS = 0.5;
static const double FOCUS_DIST = 30.0;
static const float LIGHT_POS[3] = {10.0f, 30.0f, 30.0f};
static const float BUNNY_OFFSETS[3][3] = {{-9, 0, 0}, {0, 0, -15}, {9, 0, -30}};
static const float GROUND_HALF = 100.0f;

#define PACKET 16
#define CHUNK 32 /* packets a thread takes at a time */
static int g_order = 0;
static const char *order_name[2] = {"block", "pixel"};

/* ---- small helpers ------------------------------------------------------ */
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU time of the whole process (all threads): a figure that other
 * processes competing for the cores do not inflate. */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void die(const char *msg)
{
    fprintf(stderr, "ceiling: %s\n", msg);
    exit(1);
}

static void *xalloc(size_t n)
{
    void *p = NULL;
    if (posix_memalign(&p, 64, n ? n : 64) != 0 || !p)
        die("out of memory");
    memset(p, 0, n);
    return p;
}

static void set_ftz_daz(void)
{
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

static uint64_t splitmix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double rnd(uint64_t *s)
{
    return (double)(splitmix(s) >> 11) * (1.0 / 9007199254740992.0);
}

typedef struct {
    double x, y, z;
} v3;
static v3 V(double x, double y, double z)
{
    return (v3){x, y, z};
}
static v3 vf(const float *a)
{
    return V(a[0], a[1], a[2]);
}
static v3 add(v3 a, v3 b)
{
    return V(a.x + b.x, a.y + b.y, a.z + b.z);
}
static v3 sub(v3 a, v3 b)
{
    return V(a.x - b.x, a.y - b.y, a.z - b.z);
}
static v3 mul(v3 a, double s)
{
    return V(a.x * s, a.y * s, a.z * s);
}
static double dot(v3 a, v3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
static v3 cross(v3 a, v3 b)
{
    return V(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z,
             a.x * b.y - a.y * b.x);
}
static v3 norm(v3 a)
{
    return mul(a, 1.0 / sqrt(dot(a, a)));
}

/* ---- OBJ: v and f lines only -------------------------------------------- */
typedef struct {
    float *v;    /* xyz */
    unsigned *f; /* triangle corners, 0-based */
    size_t nv, nf, capv, capf;
} mesh;

static void load_obj(const char *path, mesh *m)
{
    FILE *fp = fopen(path, "r");
    if (!fp) {
        fprintf(stderr, "ceiling: cannot open %s (run `make bunny`)\n", path);
        exit(1);
    }
    memset(m, 0, sizeof *m);
    char line[4096];
    while (fgets(line, sizeof line, fp)) {
        if (line[0] == 'v' && line[1] == ' ') {
            if (m->nv == m->capv) {
                m->capv = m->capv ? 2 * m->capv : 4096;
                m->v = realloc(m->v, 3 * m->capv * sizeof(float));
                if (!m->v)
                    die("out of memory");
            }
            float *p = m->v + 3 * m->nv++;
            if (sscanf(line + 2, "%f %f %f", &p[0], &p[1], &p[2]) != 3)
                die("bad v line in the OBJ");
        } else if (line[0] == 'f' && line[1] == ' ') {
            long idx[64];
            int n = 0;
            char *s = line + 2;
            while (n < 64) {
                char *end;
                long i = strtol(s, &end, 10);
                if (end == s)
                    break;
                idx[n++] = i < 0 ? (long)m->nv + i : i - 1;
                s = end;
                while (*s && *s != ' ' && *s != '\t')
                    s++; /* skip /vt/vn */
            }
            if (n < 3)
                die("bad f line in the OBJ");
            for (int k = 1; k + 1 < n; k++) { /* fan */
                if (m->nf == m->capf) {
                    m->capf = m->capf ? 2 * m->capf : 8192;
                    m->f = realloc(m->f, 3 * m->capf * sizeof(unsigned));
                    if (!m->f)
                        die("out of memory");
                }
                unsigned *t = m->f + 3 * m->nf++;
                t[0] = (unsigned)idx[0];
                t[1] = (unsigned)idx[k];
                t[2] = (unsigned)idx[k + 1];
            }
        }
    }
    fclose(fp);
    for (size_t i = 0; i < 3 * m->nf; i++)
        if (m->f[i] >= m->nv)
            die("face index out of range in the OBJ");
}

static void add_triangles(RTCDevice dev, RTCScene scene, const float *v,
                          size_t nv, const unsigned *f, size_t nf,
                          const float off[3])
{
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb = rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0,
                                           RTC_FORMAT_UINT3,
                                           3 * sizeof(unsigned), nf);
    if (!vb || !ib)
        die("Embree buffer allocation failed");
    for (size_t i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++)
            vb[3 * i + k] = v[3 * i + k] + off[k];
    memcpy(ib, f, 3 * nf * sizeof(unsigned));
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
}

/* ---- rays ---------------------------------------------------------------- */
/* Camera rays, SoA per packet of 16, in trace order: for each 4 x 4 pixel
 * block (row-major over the image), spp packets (see g_order). */
typedef struct {
    float ox[PACKET], oy[PACKET], oz[PACKET];
    float dx[PACKET], dy[PACKET], dz[PACKET];
} raypk;

/* What a trace leaves behind: per ray, hit distance and geometric normal. */
typedef struct {
    float t[PACKET], nx[PACKET], ny[PACKET], nz[PACKET];
    int hit[PACKET];
} hitpk;

/* Shadow rays: origin, unnormalised direction to the light, tfar, valid. */
typedef struct {
    float ox[PACKET], oy[PACKET], oz[PACKET];
    float dx[PACKET], dy[PACKET], dz[PACKET];
    float tfar[PACKET];
    int valid[PACKET];
} shadowpk;

static void gen_camera(raypk *pk, int W, int H, int spp)
{
    v3 pos = vf(CAM_POS), fwd = norm(sub(vf(CAM_LOOK), pos));
    v3 right = norm(cross(fwd, vf(CAM_UP)));
    v3 up = cross(right, fwd);
    double half_h = tan(CAM_FOV * M_PI / 360.0);
    double half_w = half_h * W / H;
    size_t p = 0;
    for (int by = 0; by < H; by += 4)
        for (int bx = 0; bx < W; bx += 4)
            for (int s0 = 0; s0 < spp; s0++, p++)
                for (int l = 0; l < PACKET; l++) {
                    /* ORDER 0: a 4 x 4 pixel block at one sample index;
                     * ORDER 1: 16 consecutive samples of one pixel. */
                    int px, py, s;
                    if (g_order == 0) {
                        px = bx + (l & 3), py = by + (l >> 2), s = s0;
                    } else {
                        size_t q = ((size_t)s0 * 16 + (size_t)l);
                        int pix = (int)(q / (size_t)spp);
                        px = bx + (pix & 3), py = by + (pix >> 2);
                        s = (int)(q % (size_t)spp);
                    }
                    uint64_t st = ((uint64_t)py * (uint64_t)W + (uint64_t)px) *
                                      (uint64_t)spp +
                                  (uint64_t)s;
                    st = splitmix(&st);
                    double fx = px + rnd(&st), fy = py + rnd(&st);
                    double sx = (2.0 * fx / W - 1.0) * half_w;
                    double sy = (1.0 - 2.0 * fy / H) * half_h;
                    v3 d = norm(add(add(fwd, mul(right, sx)), mul(up, sy)));
                    /* uniform point on the disk of radius LENS_RADIUS */
                    double r = LENS_RADIUS * sqrt(rnd(&st));
                    double phi = 2.0 * M_PI * rnd(&st);
                    v3 off = add(mul(right, r * cos(phi)),
                                 mul(up, r * sin(phi)));
                    double cos_t = dot(d, fwd);
                    /* through the point of the plane in focus on the chief ray */
                    v3 dir = norm(sub(d, mul(off, cos_t / FOCUS_DIST)));
                    v3 org = add(pos, off);
                    pk[p].ox[l] = (float)org.x;
                    pk[p].oy[l] = (float)org.y;
                    pk[p].oz[l] = (float)org.z;
                    pk[p].dx[l] = (float)dir.x;
                    pk[p].dy[l] = (float)dir.y;
                    pk[p].dz[l] = (float)dir.z;
                }
}

static size_t gen_shadow(const raypk *cam, const hitpk *hits, shadowpk *sh,
                         size_t np, size_t *nhit)
{
    size_t n = 0, nh = 0;
    v3 light = vf(LIGHT_POS);
    for (size_t p = 0; p < np; p++)
        for (int l = 0; l < PACKET; l++) {
            sh[p].valid[l] = 0;
            sh[p].ox[l] = sh[p].oy[l] = sh[p].oz[l] = 0.0f;
            sh[p].dx[l] = sh[p].dy[l] = 0.0f;
            sh[p].dz[l] = 1.0f;
            sh[p].tfar[l] = 0.0f;
            if (!hits[p].hit[l])
                continue;
            nh++;
            v3 o = V(cam[p].ox[l], cam[p].oy[l], cam[p].oz[l]);
            v3 d = V(cam[p].dx[l], cam[p].dy[l], cam[p].dz[l]);
            v3 P = add(o, mul(d, hits[p].t[l]));
            v3 N = norm(V(hits[p].nx[l], hits[p].ny[l], hits[p].nz[l]));
            if (dot(N, d) > 0)
                N = mul(N, -1.0); /* the side the ray came from */
            v3 L = sub(light, P);
            if (dot(N, L) <= 0)
                continue; /* the light is behind the surface: no shadow ray */
            v3 so = add(P, mul(N, 1e-3 * (1.0 + fabs(hits[p].t[l]) * 1e-2)));
            v3 sd = sub(light, so);
            sh[p].ox[l] = (float)so.x;
            sh[p].oy[l] = (float)so.y;
            sh[p].oz[l] = (float)so.z;
            sh[p].dx[l] = (float)sd.x;
            sh[p].dy[l] = (float)sd.y;
            sh[p].dz[l] = (float)sd.z;
            sh[p].tfar[l] = 1.0f - 1e-4f; /* the light is at t = 1 */
            sh[p].valid[l] = -1;
            n++;
        }
    *nhit = nh;
    return n;
}

/* ---- the APIs --------------------------------------------------------- */
enum api { API_16, API_8, API_1M, API_1, API_COUNT };
static const char *api_name[API_COUNT] = {"rtcIntersect16", "rtcIntersect8",
                                          "rtcIntersect1M", "rtcIntersect1"};
static const char *occ_name[API_COUNT] = {"rtcOccluded16", "rtcOccluded8",
                                          "rtcOccluded1M", "rtcOccluded1"};
static const char *api_short[API_COUNT] = {"16", "8", "1M", "1"};

typedef struct {
    RTCScene scene;
    enum api api;
    size_t np;            /* packets of 16 rays */
    void *buf;            /* the API's layout, np * 16 rays */
    int shadow;           /* 0: intersect, 1: occluded */
    const shadowpk *sh;   /* for the valid masks */
    volatile size_t next; /* next chunk of packets */
    int threads;
} job;

static void fill_camera(job *j, const raypk *pk)
{
    size_t np = j->np;
    switch (j->api) {
    case API_16: {
        struct RTCRayHit16 *r = j->buf;
        for (size_t p = 0; p < np; p++)
            for (int l = 0; l < 16; l++) {
                r[p].ray.org_x[l] = pk[p].ox[l];
                r[p].ray.org_y[l] = pk[p].oy[l];
                r[p].ray.org_z[l] = pk[p].oz[l];
                r[p].ray.dir_x[l] = pk[p].dx[l];
                r[p].ray.dir_y[l] = pk[p].dy[l];
                r[p].ray.dir_z[l] = pk[p].dz[l];
                r[p].ray.tnear[l] = 0.0f;
                r[p].ray.tfar[l] = INFINITY;
                r[p].ray.time[l] = 0.0f;
                r[p].ray.mask[l] = ~0u;
                r[p].ray.id[l] = 0;
                r[p].ray.flags[l] = 0;
                r[p].hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
                r[p].hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
            }
        break;
    }
    case API_8: {
        struct RTCRayHit8 *r = j->buf;
        for (size_t p = 0; p < np; p++)
            for (int l = 0; l < 16; l++) {
                struct RTCRayHit8 *q = &r[2 * p + (l >> 3)];
                int k = l & 7;
                q->ray.org_x[k] = pk[p].ox[l];
                q->ray.org_y[k] = pk[p].oy[l];
                q->ray.org_z[k] = pk[p].oz[l];
                q->ray.dir_x[k] = pk[p].dx[l];
                q->ray.dir_y[k] = pk[p].dy[l];
                q->ray.dir_z[k] = pk[p].dz[l];
                q->ray.tnear[k] = 0.0f;
                q->ray.tfar[k] = INFINITY;
                q->ray.time[k] = 0.0f;
                q->ray.mask[k] = ~0u;
                q->ray.id[k] = 0;
                q->ray.flags[k] = 0;
                q->hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                q->hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
            }
        break;
    }
    case API_1M:
    case API_1: {
        struct RTCRayHit *r = j->buf;
        for (size_t p = 0; p < np; p++)
            for (int l = 0; l < 16; l++) {
                struct RTCRayHit *q = &r[16 * p + l];
                q->ray.org_x = pk[p].ox[l];
                q->ray.org_y = pk[p].oy[l];
                q->ray.org_z = pk[p].oz[l];
                q->ray.dir_x = pk[p].dx[l];
                q->ray.dir_y = pk[p].dy[l];
                q->ray.dir_z = pk[p].dz[l];
                q->ray.tnear = 0.0f;
                q->ray.tfar = INFINITY;
                q->ray.time = 0.0f;
                q->ray.mask = ~0u;
                q->ray.id = 0;
                q->ray.flags = 0;
                q->hit.geomID = RTC_INVALID_GEOMETRY_ID;
                q->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            }
        break;
    }
    default:
        break;
    }
}

static void read_hits(const job *j, hitpk *h)
{
    for (size_t p = 0; p < j->np; p++)
        for (int l = 0; l < 16; l++) {
            unsigned g;
            float t, nx, ny, nz;
            if (j->api == API_16) {
                const struct RTCRayHit16 *r =
                    (const struct RTCRayHit16 *)j->buf + p;
                g = r->hit.geomID[l];
                t = r->ray.tfar[l];
                nx = r->hit.Ng_x[l], ny = r->hit.Ng_y[l], nz = r->hit.Ng_z[l];
            } else if (j->api == API_8) {
                const struct RTCRayHit8 *r = (const struct RTCRayHit8 *)j->buf +
                                             2 * p + (l >> 3);
                int k = l & 7;
                g = r->hit.geomID[k];
                t = r->ray.tfar[k];
                nx = r->hit.Ng_x[k], ny = r->hit.Ng_y[k], nz = r->hit.Ng_z[k];
            } else {
                const struct RTCRayHit *r = (const struct RTCRayHit *)j->buf +
                                            16 * p + l;
                g = r->hit.geomID;
                t = r->ray.tfar;
                nx = r->hit.Ng_x, ny = r->hit.Ng_y, nz = r->hit.Ng_z;
            }
            h[p].hit[l] = g != RTC_INVALID_GEOMETRY_ID;
            h[p].t[l] = t;
            h[p].nx[l] = nx, h[p].ny[l] = ny, h[p].nz[l] = nz;
        }
}

/* For the 1M and 1 APIs the shadow rays are compacted (valid ones only);
 * returns how many there are. */
static size_t fill_shadow(job *j, const shadowpk *sh)
{
    size_t np = j->np, n = 0;
    switch (j->api) {
    case API_16: {
        struct RTCRay16 *r = j->buf;
        for (size_t p = 0; p < np; p++)
            for (int l = 0; l < 16; l++) {
                r[p].org_x[l] = sh[p].ox[l];
                r[p].org_y[l] = sh[p].oy[l];
                r[p].org_z[l] = sh[p].oz[l];
                r[p].dir_x[l] = sh[p].dx[l];
                r[p].dir_y[l] = sh[p].dy[l];
                r[p].dir_z[l] = sh[p].dz[l];
                r[p].tnear[l] = 0.0f;
                r[p].tfar[l] = sh[p].tfar[l];
                r[p].time[l] = 0.0f;
                r[p].mask[l] = ~0u;
                r[p].id[l] = 0;
                r[p].flags[l] = 0;
                n += sh[p].valid[l] != 0;
            }
        break;
    }
    case API_8: {
        struct RTCRay8 *r = j->buf;
        for (size_t p = 0; p < np; p++)
            for (int l = 0; l < 16; l++) {
                struct RTCRay8 *q = &r[2 * p + (l >> 3)];
                int k = l & 7;
                q->org_x[k] = sh[p].ox[l];
                q->org_y[k] = sh[p].oy[l];
                q->org_z[k] = sh[p].oz[l];
                q->dir_x[k] = sh[p].dx[l];
                q->dir_y[k] = sh[p].dy[l];
                q->dir_z[k] = sh[p].dz[l];
                q->tnear[k] = 0.0f;
                q->tfar[k] = sh[p].tfar[l];
                q->time[k] = 0.0f;
                q->mask[k] = ~0u;
                q->id[k] = 0;
                q->flags[k] = 0;
                n += sh[p].valid[l] != 0;
            }
        break;
    }
    default: {
        struct RTCRay *r = j->buf;
        for (size_t p = 0; p < np; p++)
            for (int l = 0; l < 16; l++) {
                if (!sh[p].valid[l])
                    continue;
                struct RTCRay *q = &r[n++];
                q->org_x = sh[p].ox[l];
                q->org_y = sh[p].oy[l];
                q->org_z = sh[p].oz[l];
                q->dir_x = sh[p].dx[l];
                q->dir_y = sh[p].dy[l];
                q->dir_z = sh[p].dz[l];
                q->tnear = 0.0f;
                q->tfar = sh[p].tfar[l];
                q->time = 0.0f;
                q->mask = ~0u;
                q->id = 0;
                q->flags = 0;
            }
        break;
    }
    }
    return n;
}

static size_t count_occluded(const job *j, size_t nshadow)
{
    size_t n = 0;
    if (j->api == API_16) {
        const struct RTCRay16 *r = j->buf;
        for (size_t p = 0; p < j->np; p++)
            for (int l = 0; l < 16; l++)
                n += j->sh[p].valid[l] && r[p].tfar[l] < 0.0f;
    } else if (j->api == API_8) {
        const struct RTCRay8 *r = j->buf;
        for (size_t p = 0; p < j->np; p++)
            for (int l = 0; l < 16; l++)
                n += j->sh[p].valid[l] &&
                     r[2 * p + (l >> 3)].tfar[l & 7] < 0.0f;
    } else {
        const struct RTCRay *r = j->buf;
        for (size_t i = 0; i < nshadow; i++)
            n += r[i].tfar < 0.0f;
    }
    return n;
}

static size_t job_items(const job *j, size_t nshadow)
{
    /* Work items the threads share: packets, or compacted single rays
     * counted in groups of 16 for the 1M/1 shadow pass. */
    if (j->shadow && (j->api == API_1M || j->api == API_1))
        return (nshadow + 15) / 16;
    return j->np;
}

typedef struct {
    job *j;
    size_t items; /* see job_items */
    size_t nrays; /* for the 1M/1 shadow pass: the compacted count */
} worker_arg;

static void *worker(void *arg)
{
    worker_arg *w = arg;
    job *j = w->j;
    set_ftz_daz();
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    static _Alignas(64) const int all16[16] = {-1, -1, -1, -1, -1, -1, -1, -1,
                                               -1, -1, -1, -1, -1, -1, -1, -1};
    for (;;) {
        size_t c = __atomic_fetch_add(&j->next, CHUNK, __ATOMIC_RELAXED);
        if (c >= w->items)
            break;
        size_t e = c + CHUNK < w->items ? c + CHUNK : w->items;
        if (!j->shadow) {
            switch (j->api) {
            case API_16:
                for (size_t p = c; p < e; p++)
                    rtcIntersect16(all16, j->scene, &ctx,
                                   (struct RTCRayHit16 *)j->buf + p);
                break;
            case API_8:
                for (size_t p = 2 * c; p < 2 * e; p++)
                    rtcIntersect8(all16, j->scene, &ctx,
                                  (struct RTCRayHit8 *)j->buf + p);
                break;
            case API_1M:
                rtcIntersect1M(
                    j->scene, &ctx, (struct RTCRayHit *)j->buf + 16 * c,
                    (unsigned)(16 * (e - c)), sizeof(struct RTCRayHit));
                break;
            case API_1:
                for (size_t i = 16 * c; i < 16 * e; i++)
                    rtcIntersect1(j->scene, &ctx,
                                  (struct RTCRayHit *)j->buf + i);
                break;
            default:
                break;
            }
        } else {
            switch (j->api) {
            case API_16:
                for (size_t p = c; p < e; p++)
                    rtcOccluded16(j->sh[p].valid, j->scene, &ctx,
                                  (struct RTCRay16 *)j->buf + p);
                break;
            case API_8:
                for (size_t p = 2 * c; p < 2 * e; p++)
                    rtcOccluded8(j->sh[p / 2].valid + 8 * (p & 1), j->scene,
                                 &ctx, (struct RTCRay8 *)j->buf + p);
                break;
            case API_1M: {
                size_t b = 16 * c, n = 16 * e < w->nrays ? 16 * e : w->nrays;
                rtcOccluded1M(j->scene, &ctx, (struct RTCRay *)j->buf + b,
                              (unsigned)(n - b), sizeof(struct RTCRay));
                break;
            }
            case API_1: {
                size_t n = 16 * e < w->nrays ? 16 * e : w->nrays;
                for (size_t i = 16 * c; i < n; i++)
                    rtcOccluded1(j->scene, &ctx, (struct RTCRay *)j->buf + i);
                break;
            }
            default:
                break;
            }
        }
    }
    return NULL;
}

static double run_threads(job *j, size_t items, size_t nrays, double *cpu)
{
    pthread_t tid[256];
    worker_arg w = {j, items, nrays};
    j->next = 0;
    double c0 = cpu_now();
    double t0 = now();
    for (int i = 0; i < j->threads; i++)
        if (pthread_create(&tid[i], NULL, worker, &w) != 0)
            die("pthread_create failed");
    for (int i = 0; i < j->threads; i++)
        pthread_join(tid[i], NULL);
    double t = now() - t0;
    if (cpu)
        *cpu = cpu_now() - c0;
    return t;
}

/* ---- main ---------------------------------------------------------------- */
/* The whole number after option `name`, or exit naming the option: atoi
 * took "12x" as 12 and "x" as 0. */
static int int_arg(const char *name, const char *v)
{
    char *end = NULL;
    errno = 0;
    long n = strtol(v, &end, 10);
    if (errno != 0 || end == v || *end != '\0' || n < INT_MIN || n > INT_MAX) {
        fprintf(stderr, "ceiling: %s takes a whole number, got \"%s\"\n", name,
                v);
        exit(2);
    }
    return (int)n;
}

int main(int argc, char **argv)
{
    const char *obj = "scenes/meshes/bunny.obj";
    int W = 640, H = 480, spp = 16, repeat = 5, robust = 0;
    int maxthreads = (int)sysconf(_SC_NPROCESSORS_ONLN);
    int api_only = -1, order_only = -1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--robust")) {
            robust = 1;
            continue;
        }
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            puts("usage: ceiling [--obj F] [--width W] [--height H] [--spp N] "
                 "[--threads N] [--repeat N] [--api all|16|8|1M|1] "
                 "[--order all|block|pixel] [--robust]");
            return 0;
        }
        if (!v)
            die("usage: ceiling [--obj F] [--width W] [--height H] [--spp N] "
                "[--threads N] [--repeat N] [--api all|16|8|1M|1] "
                "[--order all|block|pixel] [--robust]");
        if (!strcmp(a, "--obj"))
            obj = v;
        else if (!strcmp(a, "--width"))
            W = int_arg(a, v);
        else if (!strcmp(a, "--height"))
            H = int_arg(a, v);
        else if (!strcmp(a, "--spp"))
            spp = int_arg(a, v);
        else if (!strcmp(a, "--threads"))
            maxthreads = int_arg(a, v);
        else if (!strcmp(a, "--repeat"))
            repeat = int_arg(a, v);
        else if (!strcmp(a, "--order")) {
            order_only = !strcmp(v, "block") ? 0 : !strcmp(v, "pixel") ? 1 : -1;
            if (order_only < 0 && strcmp(v, "all"))
                die("--order: all, block or pixel");
        } else if (!strcmp(a, "--api")) {
            api_only = -1;
            for (int k = 0; k < API_COUNT; k++)
                if (!strcmp(v, api_short[k]))
                    api_only = k;
            if (api_only < 0 && strcmp(v, "all"))
                die("--api: all, 16, 8, 1M or 1");
        } else
            die("unknown option");
        i++;
    }
    if (W % 4 || H % 4 || W <= 0 || H <= 0 || spp <= 0 || repeat <= 0 ||
        maxthreads <= 0 || maxthreads > 256)
        die("width and height must be multiples of 4; spp, repeat, threads > "
            "0");
    set_ftz_daz();

    mesh m;
    load_obj(obj, &m);
    RTCDevice dev = rtcNewDevice(NULL);
    if (!dev)
        die("rtcNewDevice failed");
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(scene,
                     robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    for (int c = 0; c < 3; c++)
        add_triangles(dev, scene, m.v, m.nv, m.f, m.nf, BUNNY_OFFSETS[c]);
    const float G = GROUND_HALF;
    const float ground_v[12] = {-G, 0, -G, -G, 0, G, G, 0, G, G, 0, -G};
    const unsigned ground_f[6] = {0, 1, 2,
                                  0, 2, 3}; /* counter-clockwise from +y */
    const float zero[3] = {0, 0, 0};
    add_triangles(dev, scene, ground_v, 4, ground_f, 2, zero);
    double tb = now();
    rtcCommitScene(scene);
    tb = now() - tb;
    if (rtcGetDeviceError(dev) != RTC_ERROR_NONE)
        die("Embree scene build failed");

    size_t np = (size_t)W * H / 16 * spp, nrays = np * 16;
    printf(
        "ceiling: Embree %ld.%ld.%ld (native ray16 %s, ray8 %s, streams %s), "
        "%zu triangles, build %.0f ms (quality high%s)\n",
        (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_VERSION_MAJOR),
        (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_VERSION_MINOR),
        (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_VERSION_PATCH),
        rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED)
            ? "yes"
            : "no",
        rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED)
            ? "yes"
            : "no",
        rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_RAY_STREAM_SUPPORTED)
            ? "yes"
            : "no",
        3 * m.nf + 2, tb * 1e3, robust ? ", robust" : "");
    printf("ceiling: %d x %d x %d spp = %zu camera rays (thin lens r=%.2f, "
           "focus %.0f), "
           "best of %d, threads 1 and %d\n",
           W, H, spp, nrays, LENS_RADIUS, FOCUS_DIST, repeat, maxthreads);
    fflush(stdout);

    raypk *cam = xalloc(np * sizeof(raypk));
    hitpk *hits = xalloc(np * sizeof(hitpk));
    shadowpk *sh = xalloc(np * sizeof(shadowpk));
    size_t bufsize = np * sizeof(struct RTCRayHit16);
    if (np * 16 * sizeof(struct RTCRayHit) > bufsize)
        bufsize = np * 16 * sizeof(struct RTCRayHit);
    void *buf = xalloc(bufsize);

    int tcounts[2] = {1, maxthreads};
    int ntc = maxthreads > 1 ? 2 : 1;
    /* The ceiling: per thread count, the fastest camera pass and the
     * fastest shadow pass over every API and packet order. */
    double best_tc[2] = {1e30, 1e30}, best_ts[2] = {1e30, 1e30};
    double best_cc[2] = {1e30, 1e30}, best_cs[2] = {1e30, 1e30}; /* CPU time */
    int best_cam[2] = {0, 0},
        best_shd[2] = {0, 0}; /* order * API_COUNT + api */
    size_t ref_occluded = (size_t)-1, ref_shadow = 0;
    printf("%-22s %7s %11s %11s %11s %11s %11s %11s\n", "api, packet order",
           "threads", "cam ns/ray", "cam Mray/s", "shd ns/ray", "shd Mray/s",
           "ns/sample", "Msample/s");
    printf("%-22s %7s %11s %11s %11s %11s %11s %11s\n", "", "", "(per core)",
           "", "(per core)", "", "(per core)", "(cam+shd)");
    for (int order = 0; order < 2; order++) {
        if (order_only >= 0 && order != order_only)
            continue;
        g_order = order;
        gen_camera(cam, W, H, spp);
        for (int a = 0; a < API_COUNT; a++) {
            if (api_only >= 0 && a != api_only)
                continue;
            char name[40];
            snprintf(name, sizeof name, "%s/%s", api_name[a],
                     order_name[order]);
            job j = {.scene = scene,
                     .api = (enum api)a,
                     .np = np,
                     .buf = buf,
                     .sh = sh};
            for (int ti = 0; ti < ntc; ti++) {
                j.threads = tcounts[ti];
                double tc = 1e30, ts = 1e30, cc = 1e30, cs = 1e30, c;
                size_t nshadow = 0, nhit = 0, nocc = 0;
                /* The shadow rays come from this API's own hits. */
                j.shadow = 0;
                fill_camera(&j, cam);
                run_threads(&j, np, nrays, NULL);
                read_hits(&j, hits);
                nshadow = gen_shadow(cam, hits, sh, np, &nhit);
                for (int r = 0; r < repeat; r++) {
                    j.shadow = 0;
                    fill_camera(&j, cam);
                    double t = run_threads(&j, np, nrays, &c);
                    if (t < tc)
                        tc = t;
                    if (c < cc)
                        cc = c;
                    j.shadow = 1;
                    size_t n = fill_shadow(&j, sh);
                    t = run_threads(&j, job_items(&j, n), n, &c);
                    if (t < ts)
                        ts = t;
                    if (c < cs)
                        cs = c;
                    if (r == 0)
                        nocc = count_occluded(&j, n);
                }
                if (ref_occluded == (size_t)-1) {
                    ref_occluded = nocc;
                    ref_shadow = nshadow;
                    printf("ceiling: %zu of %zu camera rays hit (%.1f%%), %zu "
                           "shadow "
                           "rays, %zu of them occluded\n",
                           nhit, nrays, 100.0 * nhit / nrays, nshadow, nocc);
                } else if (labs((long)nocc - (long)ref_occluded) >
                               (long)(ref_occluded / 100 + 10) ||
                           labs((long)nshadow - (long)ref_shadow) >
                               (long)(ref_shadow / 100 + 10)) {
                    printf("ceiling: warning: %s finds %zu occluded of %zu "
                           "shadow rays, "
                           "the first pass found %zu of %zu\n",
                           name, nocc, nshadow, ref_occluded, ref_shadow);
                }
                int T = j.threads;
                double cam_ns = tc * T / nrays * 1e9;
                double shd_ns = nshadow ? ts * T / nshadow * 1e9 : 0.0;
                double smp_ns = (tc + ts) * T / nrays * 1e9;
                double msps = nrays / (tc + ts) / 1e6;
                printf("%-22s %7d %11.2f %11.1f %11.2f %11.1f %11.2f %11.1f\n",
                       name, T, cam_ns, nrays / tc / 1e6, shd_ns,
                       nshadow / ts / 1e6, smp_ns, msps);
                printf(
                    "RESULT api=%s order=%s threads=%d camera_rays=%zu "
                    "shadow_rays=%zu "
                    "camera_s=%.6f shadow_s=%.6f camera_ns_per_ray_core=%.3f "
                    "camera_mrays_s=%.3f shadow_ns_per_ray_core=%.3f "
                    "shadow_mrays_s=%.3f sample_ns_core=%.3f msamples_s=%.3f "
                    "camera_cpu_s=%.6f shadow_cpu_s=%.6f sample_ns_cpu=%.3f "
                    "msamples_s_cpu=%.3f\n",
                    api_short[a], order_name[order], T, nrays, nshadow, tc, ts,
                    cam_ns, nrays / tc / 1e6, shd_ns, nshadow / ts / 1e6,
                    smp_ns, msps, cc, cs, (cc + cs) / nrays * 1e9,
                    nrays / (cc + cs) * T / 1e6);
                fflush(stdout);
                if (tc < best_tc[ti])
                    best_tc[ti] = tc, best_cam[ti] = order * API_COUNT + a;
                if (ts < best_ts[ti])
                    best_ts[ti] = ts, best_shd[ti] = order * API_COUNT + a;
                if (cc < best_cc[ti])
                    best_cc[ti] = cc;
                if (cs < best_cs[ti])
                    best_cs[ti] = cs;
            }
        }
    }
    for (int ti = 0; ti < ntc; ti++) {
        int T = tcounts[ti];
        double tt = best_tc[ti] + best_ts[ti];
        printf(
            "CEILING threads=%d camera_api=%s/%s shadow_api=%s/%s "
            "camera_ns_per_ray_core=%.3f camera_mrays_s=%.3f "
            "shadow_ns_per_ray_core=%.3f sample_ns_core=%.3f msamples_s=%.3f "
            "sample_ns_cpu=%.3f msamples_s_cpu=%.3f\n",
            T, api_name[best_cam[ti] % API_COUNT],
            order_name[best_cam[ti] / API_COUNT],
            occ_name[best_shd[ti] % API_COUNT],
            order_name[best_shd[ti] / API_COUNT], best_tc[ti] * T / nrays * 1e9,
            nrays / best_tc[ti] / 1e6,
            ref_shadow ? best_ts[ti] * T / ref_shadow * 1e9 : 0.0,
            tt * T / nrays * 1e9, nrays / tt / 1e6,
            (best_cc[ti] + best_cs[ti]) / nrays * 1e9,
            nrays / (best_cc[ti] + best_cs[ti]) * T / 1e6);
    }

    free(buf);
    free(sh);
    free(hits);
    free(cam);
    free(m.v);
    free(m.f);
    rtcReleaseScene(scene);
    rtcReleaseDevice(dev);
    return 0;
}
