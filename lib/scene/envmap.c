/*
 * envmap.c: the environment light (envmap.h).  Sampling is the
 * piecewise-constant 2-D distribution of pbrt-v3 (section 13.6.7, and
 * 14.2.4 for the map): a row by its marginal weight, then a column
 * within it, each texel's cell weighted by the mean luminance the lookup
 * gives over it x the solid angle of its latitudes, so that the density over the sphere is
 * p(u, v) / (2 pi^2 sin(theta)).  A texel's cell is centred where the
 * lookup puts the texel (envmap.h): columns [x, x + 1] / w, rows
 * [y - 1/2, y + 1/2] / (h - 1), the first and last rows half as tall.
 */
#include "scene/envmap.h"
#include "image/exr_read.h"
#include "scene/texture.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Larger maps are refused: 16k x 8k RGB float is 1.5 GB already, and
 * its sampling tables and the decoded file as much again.  A lat-long map
 * is twice as wide as high, so the texel cap keeps 16k x 8k and refuses
 * a square 16k map (6 GB at its peak: a small ZIP file could ask a
 * daemon for that). */
#define LR__ENV_MAX_DIM 16384
#define LR__ENV_MAX_TEXELS ((size_t)16384 * 8192)
/* The file is read whole first: 16k x 8k RGB half-float is 768 MB, in
 * float 1.5 GiB and a little (the largest map the texel cap allows,
 * which 1 GiB refused). */
#define LR__ENV_MAX_BYTES ((size_t)7 << 28)

void lr__envmap_free(lr__envmap *e)
{
    if (e == NULL)
        return;
    free(e->rgb);
    free(e->row_cdf);
    free(e->col_cdf);
    free(e->row_weight);
    free(e->run_max);
    free(e->file);
    free(e);
}

/* e->run_max and e->max (envmap.h). */
static lr_status build_run_max(lr__envmap *e, lr_error *err)
{
    int runs = (e->w + LR__ENV_RUN - 1) / LR__ENV_RUN;
    e->run_max = malloc((size_t)e->h * (size_t)runs * sizeof *e->run_max);
    if (e->run_max == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    e->max = 0.0;
    for (int y = 0; y < e->h; y++)
        for (int k = 0; k < runs; k++) {
            float m = 0.0f;
            for (int x = k * LR__ENV_RUN - 1; x <= (k + 1) * LR__ENV_RUN; x++) {
                int xi = ((x % e->w) + e->w) % e->w;
                const float *p =
                    &e->rgb[3 * ((size_t)y * (size_t)e->w + (size_t)xi)];
                m = fmaxf(m, fmaxf(p[0], fmaxf(p[1], p[2])));
            }
            e->run_max[(size_t)y * runs + k] = (float)(m * e->intensity);
            e->max = fmax(e->max, m * e->intensity);
        }
    return LR_OK;
}

/* Reads R, G, B of a single-part scanline EXR into e->rgb. */
static lr_status read_exr(lr__envmap *e, const char *path, const char *file,
                          const char *blame, lr_error *err)
{
    char shown[600];
    snprintf(shown, sizeof shown, "%s: %s", blame, file);
    char *buf = NULL;
    size_t len = 0;
    lr_status st = lr__read_file(path, shown, blame, LR__ENV_MAX_BYTES,
                                 "environment maps", NULL, &buf, &len, err);
    if (st != LR_OK)
        return st;
    lr__exr_planes px;
    /* Within what the scene may still hold (lr__texel_room, set by the
     * scene's loader): refused from the header, before the planes. */
    st = lr__exr_read_room(buf, len, shown, blame, "an environment map",
                           LR__ENV_MAX_DIM, LR__ENV_MAX_TEXELS, &px, err);
    free(buf);
    if (st != LR_OK)
        return st;
    static const char *const names[3] = {"R", "G", "B"};
    if (px.plane[LR__EXR_R] == NULL || px.plane[LR__EXR_G] == NULL ||
        px.plane[LR__EXR_B] == NULL) {
        st = lr__fail(err, LR_ERR_INVALID, blame,
                      "%s: %s needs channels R, G and B", blame, file);
        goto done;
    }
    e->w = px.w, e->h = px.h;
    size_t n = (size_t)px.w * (size_t)px.h;
    e->rgb = malloc(3 * n * sizeof(float));
    if (e->rgb == NULL) {
        st = lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        goto done;
    }
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            float v = px.plane[c][i];
            if (!isfinite(v) || v < 0.0f) {
                st = lr__fail(
                    err, LR_ERR_INVALID, blame,
                    "%s: %s: pixel (%lld, %lld) channel %s is %g; "
                    "radiance must be finite and >= 0",
                    blame, file, px.x0 + (long long)(i % (size_t)px.w),
                    px.y0 + (long long)(i / (size_t)px.w), names[c], (double)v);
                goto done;
            }
            e->rgb[3 * i + c] = v;
        }
done:
    lr__exr_planes_free(&px);
    return st;
}

/* The latitudes [*lo, *hi] (as v) of row y's sampling cell. */
static void row_span(const lr__envmap *e, int y, double *lo, double *hi)
{
    if (e->h == 1) {
        *lo = 0.0, *hi = 1.0;
        return;
    }
    double s = 1.0 / (e->h - 1);
    *lo = fmax(0.0, (y - 0.5) * s);
    *hi = fmin(1.0, (y + 0.5) * s);
}

/* The row whose sampling cell holds latitude v. */
static int row_of(const lr__envmap *e, double v)
{
    int y = (int)floor(v * (e->h - 1) + 0.5);
    return y < 0 ? 0 : y >= e->h ? e->h - 1 : y;
}

static double texel_lum(const lr__envmap *e, int x, int y)
{
    x = (x % e->w + e->w) % e->w;
    y = y < 0 ? 0 : y >= e->h ? e->h - 1 : y;
    const float *p = &e->rgb[3 * ((size_t)y * (size_t)e->w + (size_t)x)];
    return lr__luminance(v3(p[0], p[1], p[2]));
}

/* The mean luminance the bilinear lookup gives over the sampling cell of
 * texel (x, y): the tent of each neighbour integrated over the cell,
 * 1/8, 3/4, 1/8 across a whole cell (half a texel each side), 3/4 and
 * 1/4 down a polar row's half cell.  Weighting a cell by its own texel
 * alone left the light that lookup spreads into the neighbours' cells
 * to BSDF samples: under a one-texel sun a floor's pixels were 7.7% rms
 * off at 512 spp, 1.6% so (test_envmap_one_texel_sun); a diffuse ball
 * on a floor under it, 44% rms from seed to seed at 64 spp, 5.7% so. */
static double cell_lum(const lr__envmap *e, int x, int y)
{
    double wy[3] = {0.125, 0.75, 0.125};
    if (e->h > 1 && y == 0)
        wy[0] = 0.0, wy[2] = 0.25;
    if (e->h > 1 && y == e->h - 1)
        wy[0] = 0.25, wy[2] = 0.0;
    static const double wx[3] = {0.125, 0.75, 0.125};
    double sum = 0.0;
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++)
            sum += wx[i + 1] * wy[j + 1] * texel_lum(e, x + i, y + j);
    return sum;
}

/* The sampling tables: rows by marginal weight, columns within rows. */
static lr_status build_cdf(lr__envmap *e, lr_error *err)
{
    int w = e->w, h = e->h;
    e->row_cdf = malloc((size_t)h * sizeof(double));
    e->row_weight = malloc((size_t)h * sizeof(double));
    e->col_cdf = malloc((size_t)w * (size_t)h * sizeof(double));
    if (e->row_cdf == NULL || e->row_weight == NULL || e->col_cdf == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    double total = 0.0;
    for (int y = 0; y < h; y++) {
        /* The cell's share of the sphere: the integral of sin(pi v) dv
         * over its latitudes. */
        double lo, hi;
        row_span(e, y, &lo, &hi);
        double sin_t = (cos(M_PI * lo) - cos(M_PI * hi)) / M_PI;
        double *cdf = &e->col_cdf[(size_t)y * (size_t)w];
        double row = 0.0;
        for (int x = 0; x < w; x++) {
            row += cell_lum(e, x, y) * sin_t;
            cdf[x] = row;
        }
        for (int x = 0; x < w; x++)
            cdf[x] = row > 0.0 ? cdf[x] / row : (x + 1.0) / w;
        e->row_weight[y] = row;
        total += row;
        e->row_cdf[y] = total;
    }
    /* The rows' sin_t sum to 2 / pi: total over that and w columns. */
    e->mean_lum = total * M_PI / (2.0 * w) * e->intensity;
    for (int y = 0; y < h; y++) {
        e->row_cdf[y] = total > 0.0 ? e->row_cdf[y] / total : (y + 1.0) / h;
        e->row_weight[y] = total > 0.0 ? e->row_weight[y] / total : 1.0 / h;
    }
    return LR_OK;
}

/* The world direction of map coordinates (u, v): to_uv's inverse (the
 * map's frame, then the rotation about +y, as lr__envmap_sample). */
static lr__v3 from_uv(const lr__envmap *e, double u, double v)
{
    double theta = v * M_PI, phi = u * 2.0 * M_PI, st = sin(theta);
    double lx = st * sin(phi), ly = cos(theta), lz = -st * cos(phi);
    return v3(e->cos_r * lx + e->sin_r * lz, ly,
              -e->sin_r * lx + e->cos_r * lz);
}

/* lr__envmap_sun's cone, from the texels' places (column x at u = (x +
 * 1/2) / w, row y at v = y / (h - 1): lookup).  The lookup spreads a
 * texel's light over the texels around it, so the cone reaches one and
 * a half texel spacings (of a row, or of a column at the equator, the
 * wider) past the bright texels' places. */
static void find_sun(lr__envmap *e)
{
    e->sun_cos = 2.0;
    double best = 0.0;
    int bx = 0, by = 0;
    for (int y = 0; y < e->h; y++)
        for (int x = 0; x < e->w; x++) {
            double l = texel_lum(e, x, y);
            if (l > best)
                best = l, bx = x, by = y;
        }
    if (!(best > 0.0) || e->h < 2)
        return;
    lr__v3 a = from_uv(e, (bx + 0.5) / e->w, (double)by / (e->h - 1));
    double reach = 0.0, cos_max = cos(LR__ENV_SUN_MAX);
    /* Only rows within LR__ENV_SUN_MAX of the sun's latitude can count. */
    int dy = (int)ceil(LR__ENV_SUN_MAX / M_PI * (e->h - 1));
    int y0 = by - dy < 0 ? 0 : by - dy,
        y1 = by + dy >= e->h ? e->h - 1 : by + dy;
    for (int y = y0; y <= y1; y++)
        for (int x = 0; x < e->w; x++) {
            if (!(texel_lum(e, x, y) * LR__ENV_SUN_RATIO >= best))
                continue;
            lr__v3 d = from_uv(e, (x + 0.5) / e->w, (double)y / (e->h - 1));
            double c = v3_dot(a, d);
            if (c >= cos_max)
                reach = fmax(reach, acos(fmin(1.0, c)));
        }
    reach += 1.5 * fmax(M_PI / (e->h - 1), 2.0 * M_PI / e->w);
    if (reach < LR__ENV_SUN_MAX) {
        e->sun_dir = a;
        e->sun_cos = cos(reach);
    }
}

int lr__envmap_sun(const lr__envmap *e, lr__v3 *dir, double *cos_a)
{
    *dir = e->sun_dir;
    *cos_a = e->sun_cos;
    return e->sun_cos <= 1.0;
}

lr_status lr__envmap_load(const char *path, const char *file, const char *blame,
                          double intensity, double rotation_deg,
                          lr__envmap **out, lr_error *err)
{
    *out = NULL;
    lr__envmap *e = calloc(1, sizeof *e);
    if (e != NULL)
        e->file = strdup(file);
    if (e == NULL || e->file == NULL) {
        free(e);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    e->intensity = intensity;
    e->rotation_deg = rotation_deg;
    e->cos_r = cos(rotation_deg * M_PI / 180.0);
    e->sin_r = sin(rotation_deg * M_PI / 180.0);
    /* OpenEXR's own message for a missing file says less than this. */
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        int e_no = errno;
        lr__envmap_free(e);
        return lr__fail(err, LR_ERR_IO, blame, "%s: %s: %s", blame, file,
                        strerror(e_no));
    }
    fclose(fp);
    lr_status st = read_exr(e, path, file, blame, err);
    if (st == LR_OK)
        st = build_cdf(e, err);
    if (st == LR_OK)
        st = build_run_max(e, err);
    if (st == LR_OK)
        find_sun(e);
    if (st != LR_OK) {
        lr__envmap_free(e);
        return st;
    }
    *out = e;
    return LR_OK;
}

/* Index of the first entry of cdf[0..n) greater than u. */
static int find(const double *cdf, int n, double u)
{
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (cdf[mid] > u)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* World direction -> the map's (u, v), undoing the rotation about +y. */
static void to_uv(const lr__envmap *e, lr__v3 d, double *u, double *v)
{
    double x = e->cos_r * d.x - e->sin_r * d.z;
    double z = e->sin_r * d.x + e->cos_r * d.z;
    double uu = atan2(x, -z) / (2.0 * M_PI);
    *u = uu - floor(uu);
    *v = acos(fmax(-1.0, fmin(1.0, d.y))) / M_PI;
}

/* The cone's latitudes are v in [v0, v1] (v = polar angle / pi); away
 * from the poles its longitudes are within asin(sin alpha / sin theta)
 * of the axis's (the widest a cone of half-angle alpha reaches from an
 * axis at polar angle theta).  A lookup at (u, v) reads rows floor and
 * ceil of v (h - 1) and the columns around u w - 1/2, which the runs'
 * maxima hold. */
double lr__envmap_max_in_cone(const lr__envmap *e, lr__v3 axis, double alpha)
{
    if (!(alpha < 0.5 * M_PI))
        return e->max;
    double u, v;
    to_uv(e, axis, &u, &v);
    double theta = v * M_PI;
    double t0 = theta - alpha, t1 = theta + alpha;
    int runs = (e->w + LR__ENV_RUN - 1) / LR__ENV_RUN;
    int k0 = 0, k1 = runs - 1;
    if (t0 > 0.0 && t1 < M_PI) {
        double dphi = asin(fmin(1.0, sin(alpha) / sin(theta)));
        /* Columns of u +- dphi / 2 pi, one more each side for rounding. */
        double c0 = (u - dphi / (2.0 * M_PI)) * e->w - 0.5;
        double c1 = (u + dphi / (2.0 * M_PI)) * e->w - 0.5;
        if (c1 - c0 < e->w - 2 * LR__ENV_RUN) {
            k0 = (int)floor((floor(c0) - 1.0) / LR__ENV_RUN);
            k1 = (int)floor((ceil(c1) + 1.0) / LR__ENV_RUN);
        }
    }
    int y0 = (int)floor(fmax(t0, 0.0) / M_PI * (e->h - 1)) - 1;
    int y1 = (int)ceil(fmin(t1, M_PI) / M_PI * (e->h - 1)) + 1;
    y0 = y0 < 0 ? 0 : y0;
    y1 = y1 >= e->h ? e->h - 1 : y1;
    double m = 0.0;
    for (int y = y0; y <= y1; y++)
        for (int k = k0; k <= k1; k++) {
            int ki = ((k % runs) + runs) % runs;
            m = fmax(m, e->run_max[(size_t)y * runs + ki]);
        }
    return m;
}

double lr__envmap_max(const lr__envmap *e)
{
    return e->max;
}

/* The sampling cell that holds (u, v). */
static void cell(const lr__envmap *e, double u, double v, int *ix, int *iy)
{
    int x = (int)(u * e->w);
    *ix = x < 0 ? 0 : x >= e->w ? e->w - 1 : x;
    *iy = row_of(e, v);
}

int lr__env_is_light(const lr_scene *s)
{
    return s->env != NULL || v3_maxc(s->background) > 0.0;
}

/* Bilinear between texels, wrapping in u and clamping in v, as Mitsuba
 * 3's envmap looks up its image (src/emitters/envmap.cpp,
 * eval_spectrum): column x at u = (x + 1/2) / w, row y at v = y / (h - 1),
 * so the first row is the +y pole and the last the -y pole (not
 * (y + 1/2) / h, which put a texel up to half a row from where Mitsuba
 * puts it).  Sampling stays piecewise constant: MIS needs only that both
 * strategies see the same radiance, not that the density follow it
 * exactly. */
static lr__v3 lookup(const lr__envmap *e, double u, double v)
{
    double x = u * e->w - 0.5, y = v * (e->h - 1);
    double fx = floor(x), fy = floor(y);
    double tx = x - fx, ty = y - fy;
    int x0 = (int)fx, y0 = (int)fy;
    lr__v3 acc = v3(0, 0, 0);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            int xi = ((x0 + i) % e->w + e->w) % e->w;
            int yj = y0 + j < 0 ? 0 : y0 + j >= e->h ? e->h - 1 : y0 + j;
            double wgt = (i ? tx : 1.0 - tx) * (j ? ty : 1.0 - ty);
            const float *p =
                &e->rgb[3 * ((size_t)yj * (size_t)e->w + (size_t)xi)];
            acc = v3_madd(acc, v3(p[0], p[1], p[2]), wgt);
        }
    return v3_scale(acc, e->intensity);
}

lr__v3 lr__env_radiance(const lr_scene *s, lr__v3 dir)
{
    const lr__envmap *e = s->env;
    if (e == NULL)
        return s->background;
    double u, v;
    to_uv(e, dir, &u, &v);
    return lookup(e, u, v);
}

lr__v3 lr__envmap_sample(const lr_scene *s, const double u[2], lr__v3 *L,
                         double *pdf)
{
    const lr__envmap *e = s->env;
    if (e == NULL) {
        /* Uniform over the sphere: z = 1 - 2 u0, pdf 1 / (4 pi). */
        double z = 1.0 - 2.0 * u[0], r = sqrt(fmax(0.0, 1.0 - z * z));
        double phi = 2.0 * M_PI * u[1];
        *L = s->background;
        *pdf = 1.0 / (4.0 * M_PI);
        return v3(r * cos(phi), r * sin(phi), z);
    }
    int y = find(e->row_cdf, e->h, u[0]);
    double r0 = y > 0 ? e->row_cdf[y - 1] : 0.0;
    double dv = (u[0] - r0) / fmax(e->row_cdf[y] - r0, 1e-300);
    const double *cdf = &e->col_cdf[(size_t)y * (size_t)e->w];
    int x = find(cdf, e->w, u[1]);
    double c0 = x > 0 ? cdf[x - 1] : 0.0;
    double du = (u[1] - c0) / fmax(cdf[x] - c0, 1e-300);
    double lo, hi;
    row_span(e, y, &lo, &hi);
    double uu = (x + fmin(fmax(du, 0.0), 1.0)) / e->w;
    double vv = lo + fmin(fmax(dv, 0.0), 1.0) * (hi - lo);
    double theta = vv * M_PI, phi = uu * 2.0 * M_PI;
    double st = sin(theta);
    /* The map's frame, then the rotation about +y. */
    double lx = st * sin(phi), ly = cos(theta), lz = -st * cos(phi);
    lr__v3 d = v3(e->cos_r * lx + e->sin_r * lz, ly,
                  -e->sin_r * lx + e->cos_r * lz);
    *L = lookup(e, uu, vv);
    double p_uv = e->row_weight[y] * (cdf[x] - c0) * e->w / (hi - lo);
    *pdf = st > 0.0 ? p_uv / (2.0 * M_PI * M_PI * st) : 0.0;
    return d;
}

double lr__envmap_pdf(const lr_scene *s, lr__v3 dir)
{
    const lr__envmap *e = s->env;
    if (e == NULL)
        return 1.0 / (4.0 * M_PI);
    double u, v;
    int x, y;
    to_uv(e, dir, &u, &v);
    cell(e, u, v, &x, &y);
    double lo, hi;
    row_span(e, y, &lo, &hi);
    const double *cdf = &e->col_cdf[(size_t)y * (size_t)e->w];
    double c0 = x > 0 ? cdf[x - 1] : 0.0;
    double p_uv = e->row_weight[y] * (cdf[x] - c0) * e->w / (hi - lo);
    double st = sin(v * M_PI);
    return st > 0.0 ? p_uv / (2.0 * M_PI * M_PI * st) : 0.0;
}
