/*
 * splat.c: spectral splatting (splat.h).
 *
 * The integral.  Channel c of pixel P (the unit square: film.c's box
 * filter) is
 *
 *     I_c(P) = int_P dx int dh p(h) int dl w_c(l) L_c(r_l(x, h))
 *
 * with p the density of the lens samples, w_c the normalised matching
 * function (wavelength.h: int w_c = 1) and r_l(x, h) the ray at
 * wavelength l through film point x and lens point h.
 *
 * A colour's focus change is a film shift.  The thin lens's ray at focus
 * power P_d + t through film point x + t v(h) is its ray at P_d (the d
 * line) through x, with v(h) = R fpx (h_x, -h_y) pixels (camera.c,
 * lr__offset_lens_shift16: the direction D - off w of camera.h's form is
 * unchanged when D gains t off and w gains t).  With t(l) = P(l) - P_d,
 *
 *     L(r_l(x, h)) = L_d(x - t(l) v(h), h),
 *
 * L_d being the radiance of the d-line ray.
 *
 * One film offset and lens point for every pixel.  Sample k of every
 * pixel P goes through film point P + d_k and lens point h_k, the same
 * (d_k, h_k) for all pixels: a 4-D sequence of the sampler's own, under
 * an identity no pixel has (a scrambled Sobol net over the samples).
 * Then each wavelength l of sample k of P is the d-line ray through
 * P + d_k - t(l) v_k, and that film point lies in exactly one pixel Q,
 * whose own sample k is the d-line ray through Q + d_k, at the same
 * offset in its pixel: Q = P - D with D = floor(d_k + t(l) v_k).  The
 * one is taken for the other:
 *
 *     Q + d_k = P - t v_k + frac(d_k + t v_k),
 *
 * and as d_k is uniform over the unit square given h_k (each point of a
 * scrambled net is; the grid sampler's fixed cell centres are its own
 * approximation here as everywhere), so is frac(d_k + t v_k) (a translation
 * modulo 1): Q + d_k is uniform over the square P - t v_k, as
 * P + d_k - t v_k is, and the two rays' radiance has the same mean.  So
 *
 *     I_k(P) = int dl w(l) L_d(P - D(l) + d_k, h_k)
 *
 * is unbiased for I(P): every wavelength of every pixel's sample reuses
 * a ray traced once per pixel, with no ray traced per wavelength.
 * Along the spectrum D(l) is constant between the values of t where
 * d_k + t v_k crosses a pixel's side, so with
 *
 *     G_c(s) = int dl w_c(l) [t(l) <= s]      (t monotonic in l)
 *
 * the integral is exactly a sum over those pieces [a, b] of t:
 *
 *     I_k(P) = L_k(P) + sum_pieces (G_c(b) - G_c(a)) (L_k(P - D) - L_k(P))
 *
 * written about L_k(P), the pixel's own ray (D = 0 at t = 0): the pieces'
 * weights sum to 1, and on an area of one radiance every term but the
 * first is exactly 0, so a grey card has no colour noise however far the
 * colours spread.  The wavelengths cost about twenty multiply-adds a
 * pixel and sample on accuracy-chroma; camera.chromatic.wavelengths
 * plays no part.
 *
 * G is made once per render from the tables spectral.c samples
 * (wavelength.h: w and P at whole nanometres, linear between; the mass
 * of a linear w along a linear t in each nanometre, exactly), at GRID + 1
 * values of s and linear between, scaled to end at exactly 1.  The
 * weights are then exact for matching functions whose mass in each cell
 * of s is the tables' and spread evenly in s across it (on
 * accuracy-chroma's SF11 a cell spans at most 0.37 nm, at 780 nm).
 *
 * What sharing costs.  A pixel's samples are still a scrambled net over
 * its area and the lens, so its error is what it would be with a net of
 * its own; but neighbours' errors are alike (at low spp an out-of-focus
 * edge shows as spp sharp copies rather than as grain).
 *
 * The order.  The rays of a group of 16 samples are traced for every
 * origin (the region, and as far around it as the longest shift, the
 * margin: the pixel P - D may lie outside the region or the frame) and
 * kept (phase A, by bands of 16 rows aligned to the frame), then each
 * pixel of the region adds its samples' sums in sample order (phase B).
 * Every value is a pure function of the pixel and the sample, so neither
 * the thread count nor the region changes a bit.
 */
#include "render/splat.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define BAND 16   /* rows a unit */
#define GROUP 16  /* samples a group: one packet of each origin */
#define GRID 4096 /* cells of s in the table of G */

/* The sampler identity of the shared film offsets and lens points: no
 * pixel has it (pixels are numbered y W + x, or with bit 63 set outside
 * the frame). */
#define SHARED_ID (UINT64_C(1) << 62)

struct lr__splat {
    const lr__shot *sh;
    lr_image *img;
    int spp, margin;
    int x0, y0, x1, y1;   /* the region */
    int ox0, oy0, ow, oh; /* the origins: [ox0, ox0 + ow) x [oy0, oy0 + oh) */
    int a0, n_a;          /* phase A's first band (rows 16 a0 ...), count */
    int b0, n_b;          /* phase B's */
    int n_groups;
    struct piece *pieces; /* per worker: GROUP x max_pieces */
    int max_pieces;
    lr__pixel_sampler shared; /* the film offsets and lens points */
    double t_lo, t_hi, inv_dt;
    double G[GRID + 1][3];
    float *L; /* phase A's radiance of the group being summed: a plane
                     of the origins per sample and channel */
    size_t origins;
    double *sums; /* per region pixel, 3 */
    double *rows; /* per worker: a row of the region, 3 planes */
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int *a_done, *b_done; /* per group: units finished in each phase */
};

/* The focus power at the tables' nodes, as lr__shot_init tabulates it,
 * less the reference's: t at 380 + j nm.  0 if not finite or not
 * monotonic. */
static int shift_nodes(const lr__cam *c, double t[LR__WL_NODES])
{
    int up = 1, down = 1;
    for (int j = 0; j < LR__WL_NODES; j++) {
        t[j] = (double)(float)lr__cam_power_at(c, 380.0 + j) - c->w;
        if (!isfinite(t[j]))
            return 0;
        if (j > 0) {
            up &= t[j] >= t[j - 1];
            down &= t[j] <= t[j - 1];
        }
    }
    return up || down;
}

/* The margin: the longest film shift in pixels, rounded up, plus one; 0
 * when splatting does not apply. */
static int margin_of(const lr__cam *c)
{
    if (!c->chroma_active || c->chroma.mode != LR_CHROMATIC_SPECTRAL ||
        !c->chroma.splat || c->model->shift16 == NULL)
        return 0;
    double t[LR__WL_NODES], tmax = 0.0;
    if (!shift_nodes(c, t))
        return 0;
    for (int j = 0; j < LR__WL_NODES; j++)
        tmax = fmax(tmax, fabs(t[j]));
    /* The lens point's reach (the bound's R covers the shape and the
     * anamorphic stretch) times the pixels per unit on the film. */
    lr__lens_bound b;
    c->model->bound(c, &b);
    double px = tmax * b.R * c->height / (2.0 * c->half_h);
    if (!(px <= LR__SPLAT_MAX_MARGIN - 2))
        return 0;
    int M = (int)ceil(px) + 1;
    /* The rays of a group of the whole frame and its margin are kept (a
     * crop keeps fewer, but must choose as the frame does). */
    double kept = (c->width + 2.0 * M) * (c->height + 2.0 * M) * GROUP * 3 *
                  sizeof(float);
    return kept <= LR__SPLAT_MAX_BYTES ? M : 0;
}

int lr__splat_applies(const lr__cam *c)
{
    return margin_of(c) > 0;
}

/* G_c(s) at the grid: each nanometre's mass of its linear w over the part
 * [0, f] where t <= s is a f + (b - a) f^2 / 2 when t rises through it
 * (the rest of it when t falls); 0 below its range of t, all of it
 * above. */
static void make_table(lr__splat *sp, const lr__wl_table *wl, double w_ref)
{
    double t[LR__WL_NODES];
    for (int j = 0; j < LR__WL_NODES; j++)
        t[j] = (double)wl->node[j][3] - w_ref;
    int rising = t[LR__WL_NODES - 1] >= t[0];
    sp->t_lo = rising ? t[0] : t[LR__WL_NODES - 1];
    sp->t_hi = rising ? t[LR__WL_NODES - 1] : t[0];
    double range = sp->t_hi - sp->t_lo;
    sp->inv_dt = range > 0.0 ? GRID / range : 0.0;
    double full[GRID + 2][3]; /* masses wholly below each grid point */
    memset(full, 0, sizeof full);
    memset(sp->G, 0, sizeof sp->G);
    for (int j = 0; j + 1 < LR__WL_NODES; j++) {
        double ta = t[j], tb = t[j + 1];
        const float *na = wl->node[j], *nb = wl->node[j + 1];
        double mass[3];
        for (int c = 0; c < 3; c++)
            mass[c] = 0.5 * ((double)na[c] + nb[c]);
        double lo = fmin(ta, tb), hi = fmax(ta, tb);
        /* Grid points k with s_k in [lo, hi) take a part; above, all. */
        int k0 = range > 0.0 ? (int)ceil((lo - sp->t_lo) * sp->inv_dt) : 0;
        int k1 = range > 0.0 ? (int)ceil((hi - sp->t_lo) * sp->inv_dt) : 0;
        k0 = k0 < 0 ? 0 : k0 > GRID + 1 ? GRID + 1 : k0;
        k1 = k1 < k0 ? k0 : k1 > GRID + 1 ? GRID + 1 : k1;
        for (int k = k0; k < k1 && k <= GRID; k++) {
            double sig = sp->t_lo + k / sp->inv_dt;
            double f = (sig - ta) / (tb - ta); /* ta != tb here */
            f = f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f;
            for (int c = 0; c < 3; c++) {
                double a = na[c], d = (double)nb[c] - na[c];
                double part = a * f + d * f * f / 2.0;
                sp->G[k][c] += tb >= ta ? part : mass[c] - part;
            }
        }
        for (int c = 0; c < 3; c++)
            full[k1][c] += mass[c];
    }
    double run[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k <= GRID; k++)
        for (int c = 0; c < 3; c++) {
            run[c] += full[k][c];
            sp->G[k][c] += run[c];
        }
    double total[3] = {sp->G[GRID][0], sp->G[GRID][1], sp->G[GRID][2]};
    for (int k = 0; k <= GRID; k++)
        for (int c = 0; c < 3; c++)
            sp->G[k][c] /= total[c];
    for (int c = 0; c < 3; c++) {
        sp->G[0][c] = 0.0;
        sp->G[GRID][c] = 1.0;
    }
}

static void G_at(const lr__splat *sp, double sig, double out[3])
{
    double x = (sig - sp->t_lo) * sp->inv_dt;
    int k = (int)x;
    k = k < 0 ? 0 : k > GRID - 1 ? GRID - 1 : k;
    double f = x - k;
    f = f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f;
    for (int c = 0; c < 3; c++)
        out[c] = sp->G[k][c] + f * (sp->G[k + 1][c] - sp->G[k][c]);
}

/* The pieces of sample (dx, dy) (the offset d in the pixel), v: the
 * pixel steps D = floor(d + t v) along t in [t_lo, t_hi] and the weight
 * G(b) - G(a) of each.  At most max pieces (2 margin + 3 suffice). */
typedef struct piece {
    int dx, dy;
    double w[3];
} piece;

static int pieces_of(const lr__splat *sp, double ox, double oy, double vx,
                     double vy, piece *out, int max)
{
    double s = sp->t_lo, s_end = sp->t_hi;
    int px = (int)floor(ox + s * vx), py = (int)floor(oy + s * vy);
    double nx = INFINITY, ny = INFINITY;
    int stx = vx > 0.0 ? 1 : -1, sty = vy > 0.0 ? 1 : -1;
    /* The t of the next side crossed in x and in y. */
    if (vx != 0.0)
        nx = ((vx > 0.0 ? px + 1 : px) - ox) / vx;
    if (vy != 0.0)
        ny = ((vy > 0.0 ? py + 1 : py) - oy) / vy;
    double Ga[3] = {0.0, 0.0, 0.0};
    int n = 0;
    for (;;) {
        int axis = nx < ny ? 0 : 1;
        double e = axis == 0 ? nx : ny;
        if (e >= s_end) {
            e = s_end;
            axis = 2;
        }
        if (e > s && n < max) {
            double Gb[3];
            G_at(sp, e, Gb);
            out[n].dx = px;
            out[n].dy = py;
            for (int c = 0; c < 3; c++)
                out[n].w[c] = Gb[c] - Ga[c];
            n++;
            Ga[0] = Gb[0], Ga[1] = Gb[1], Ga[2] = Gb[2];
            s = e;
        }
        if (axis == 2)
            break;
        if (axis == 0) {
            px += stx;
            nx = ((vx > 0.0 ? px + 1 : px) - ox) / vx;
        } else {
            py += sty;
            ny = ((vy > 0.0 ? py + 1 : py) - oy) / vy;
        }
    }
    return n;
}

/* Sampler identities for the rays' own random numbers (an integrator's):
 * a frame pixel keeps its own (y W + x, as the other paths), an origin
 * outside the frame gets one with the top bit set. */
static uint64_t origin_id(const lr__splat *sp, int x, int y)
{
    int W = sp->sh->width, H = (int)sp->sh->cam->height;
    if (x >= 0 && y >= 0 && x < W && y < H)
        return (uint64_t)y * (uint64_t)W + (uint64_t)x;
    return (UINT64_C(1) << 63) | ((uint64_t)(uint32_t)y << 31) |
           (uint64_t)((uint32_t)x & 0x7fffffffu);
}

static int floor_div(int a, int b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

int lr__splat_units(const lr__splat *sp)
{
    return sp->n_groups * (sp->n_a + sp->n_b);
}

static void splat_free_parts(lr__splat *sp)
{
    free(sp->L);
    free(sp->rows);
    free(sp->sums);
    free(sp->a_done);
    free(sp->b_done);
    free(sp->pieces);
}

lr_status lr__splat_new(const lr__shot *sh, int spp, int x0, int y0, int x1,
                        int y1, int workers, lr_image *img, lr__splat **out,
                        lr_error *err)
{
    *out = NULL;
    lr__splat *sp = calloc(1, sizeof *sp);
    if (sp == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    const lr__cam *c = sh->cam;
    sp->sh = sh;
    sp->img = img;
    sp->spp = spp;
    sp->margin = margin_of(c);
    int M = sp->margin;
    sp->x0 = x0, sp->y0 = y0, sp->x1 = x1, sp->y1 = y1;
    sp->ox0 = x0 - M, sp->oy0 = y0 - M;
    sp->ow = x1 - x0 + 2 * M, sp->oh = y1 - y0 + 2 * M;
    sp->a0 = floor_div(y0 - M, BAND);
    sp->n_a = floor_div(y1 + M - 1, BAND) - sp->a0 + 1;
    sp->b0 = floor_div(y0, BAND);
    sp->n_b = floor_div(y1 - 1, BAND) - sp->b0 + 1;
    sp->n_groups = (spp + GROUP - 1) / GROUP;
    size_t origins = (size_t)sp->ow * (size_t)sp->oh;
    size_t px = (size_t)(x1 - x0) * (size_t)(y1 - y0);
    sp->origins = origins;
    sp->L = malloc(origins * GROUP * 3 * sizeof(float));
    sp->rows = malloc((size_t)workers * 3 * (size_t)(x1 - x0) *
                      sizeof *sp->rows);
    sp->sums = calloc(3 * px, sizeof *sp->sums);
    sp->a_done = calloc((size_t)sp->n_groups, sizeof *sp->a_done);
    sp->b_done = calloc((size_t)sp->n_groups, sizeof *sp->b_done);
    /* D steps at most 2 M times in x and y over the spectrum. */
    sp->max_pieces = 4 * M + 4;
    sp->pieces = malloc((size_t)workers * GROUP * (size_t)sp->max_pieces *
                        sizeof *sp->pieces);
    if (sp->L == NULL || sp->rows == NULL || sp->sums == NULL ||
        sp->a_done == NULL || sp->b_done == NULL || sp->pieces == NULL) {
        splat_free_parts(sp);
        free(sp);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    lr__pixel_sampler_init(&sp->shared, sh->sampler, SHARED_ID);
    make_table(sp, &sh->wl, (float)c->w);
    pthread_mutex_init(&sp->lock, NULL);
    pthread_cond_init(&sp->cond, NULL);
    *out = sp;
    return LR_OK;
}

/* Channel c of sample i of the group (the planes are the origins' rows,
 * so that a pixel's neighbours along a row are neighbours in memory). */
static float *L_plane(const lr__splat *sp, int i, int c)
{
    return sp->L + (size_t)(3 * i + c) * sp->origins;
}

static size_t origin_at(const lr__splat *sp, int x, int y)
{
    return (size_t)(y - sp->oy0) * (size_t)sp->ow + (size_t)(x - sp->ox0);
}

/* The shared offsets and lens points of group g (lanes n..15 harmless). */
static void group_coords(const lr__splat *sp, int g, int n, float dx[16],
                         float dy[16], float lu[16], float lv[16])
{
    for (int i = 0; i < 16; i++)
        dx[i] = dy[i] = lu[i] = lv[i] = 0.5f;
    lr__packet_coords(&sp->shared, 0, 0, (uint32_t)(g * GROUP), n, dx, dy, lu,
                      lv);
}

/* Phase A: group g's rays of the origins in rows [r0, r1), kept. */
static void phase_a(lr__splat *sp, int g, int r0, int r1,
                    lr__sample_counts *cnt, uint64_t *dropped)
{
    const lr__shot *sh = sp->sh;
    const lr__cam *c = sh->cam;
    int s0 = g * GROUP, n = sp->spp - s0 < GROUP ? sp->spp - s0 : GROUP;
    struct RTCRayHit16 rh __attribute__((aligned(64)));
    float dx[16], dy[16], lu[16], lv[16], fx[16], fy[16], wt[16];
    group_coords(sp, g, n, dx, dy, lu, lv);
    for (int y = r0; y < r1; y++)
        for (int x = sp->ox0; x < sp->ox0 + sp->ow; x++) {
            /* The film point summed in double and rounded once, as
             * lr__packet_coords does. */
            for (int i = 0; i < 16; i++) {
                fx[i] = (float)(x + (double)dx[i]);
                fy[i] = (float)(y + (double)dy[i]);
            }
            c->model->rays16(c, 1, n, fx, fy, lu, lv, &rh, wt);
            lr__v3 L[16];
            uint64_t id = origin_id(sp, x, y);
            const lr__sample_id sid = {sh->sampler, id, (uint32_t)s0, sh->lt};
            sh->integrator->radiance16(sh->scene, sh->max_depth, &rh, n, &sid,
                                       L, &cnt->rays);
            cnt->camera_rays += (uint64_t)n;
            size_t at = origin_at(sp, x, y);
            for (int i = 0; i < n; i++) {
                /* A non-finite radiance counts as black (film.c's rule). */
                if (!isfinite(L[i].x) || !isfinite(L[i].y) ||
                    !isfinite(L[i].z)) {
                    L[i] = v3(0, 0, 0);
                    ++*dropped;
                }
                L_plane(sp, i, 0)[at] = (float)L[i].x;
                L_plane(sp, i, 1)[at] = (float)L[i].y;
                L_plane(sp, i, 2)[at] = (float)L[i].z;
            }
        }
}

/* Phase B: group g's samples of the region's pixels in rows [r0, r1). */
static void phase_b(lr__splat *sp, int g, int r0, int r1, int worker)
{
    const lr__cam *c = sp->sh->cam;
    const int M = sp->margin, W = sp->x1 - sp->x0;
    int s0 = g * GROUP, n = sp->spp - s0 < GROUP ? sp->spp - s0 : GROUP;
    float dx[16], dy[16], lu[16], lv[16], vx[16], vy[16];
    group_coords(sp, g, n, dx, dy, lu, lv);
    c->model->shift16(c, n, lu, lv, vx, vy);
    /* Each sample's pieces: the same for every pixel. */
    const int maxp = sp->max_pieces;
    piece *pcs = sp->pieces + (size_t)worker * GROUP * (size_t)maxp;
    int np[GROUP];
    for (int i = 0; i < n; i++) {
        piece *pc_i = pcs + (size_t)i * maxp;
        np[i] = pieces_of(sp, dx[i], dy[i], vx[i], vy[i], pc_i, maxp);
        /* D = floor(d + t v) is within the margin by its choice; a piece
         * beyond it (never) would read outside the origins. */
        for (int p = 0; p < np[i]; p++)
            if (abs(pc_i[p].dx) > M || abs(pc_i[p].dy) > M)
                pc_i[p] = (piece){0, 0, {0.0, 0.0, 0.0}};
    }
    /* Row by row, sample by sample, piece by piece: each pixel's own
     * additions in the order the estimate is written, L_k(P) first; the
     * loops over a row run along memory. */
    double *row = sp->rows + (size_t)worker * 3 * (size_t)W;
    for (int y = r0; y < r1; y++) {
        double *sum = &sp->sums[3 * (size_t)(y - sp->y0) * (size_t)W];
        size_t at = origin_at(sp, sp->x0, y);
        for (int i = 0; i < n; i++) {
            for (int ch = 0; ch < 3; ch++) {
                const float *own = L_plane(sp, i, ch) + at;
                double *acc = row + (size_t)ch * W;
                for (int x = 0; x < W; x++)
                    acc[x] = own[x];
                for (int p = 0; p < np[i]; p++) {
                    const piece *q = &pcs[(size_t)i * maxp + p];
                    const float *o = own - ((ptrdiff_t)q->dy * sp->ow + q->dx);
                    double w = q->w[ch];
                    for (int x = 0; x < W; x++)
                        acc[x] += w * ((double)o[x] - own[x]);
                }
            }
            for (int x = 0; x < W; x++)
                for (int ch = 0; ch < 3; ch++)
                    sum[3 * x + ch] += row[(size_t)ch * W + x];
        }
    }
}

static void wait_count(lr__splat *sp, const int *count, int at_least)
{
    pthread_mutex_lock(&sp->lock);
    while (*count < at_least)
        pthread_cond_wait(&sp->cond, &sp->lock);
    pthread_mutex_unlock(&sp->lock);
}

static void count_one(lr__splat *sp, int *count)
{
    pthread_mutex_lock(&sp->lock);
    ++*count;
    pthread_cond_broadcast(&sp->cond);
    pthread_mutex_unlock(&sp->lock);
}

uint64_t lr__splat_unit(lr__splat *sp, int u, int worker,
                        lr__sample_counts *cnt, uint64_t *dropped)
{
    int per_group = sp->n_a + sp->n_b;
    int g = u / per_group, r = u % per_group;
    if (r < sp->n_a) {
        /* Group g's rays go where group g - 1's were: wait until those
         * are read. */
        if (g >= 1)
            wait_count(sp, &sp->b_done[g - 1], sp->n_b);
        int r0 = BAND * (sp->a0 + r), r1 = r0 + BAND;
        r0 = r0 > sp->oy0 ? r0 : sp->oy0;
        r1 = r1 < sp->oy0 + sp->oh ? r1 : sp->oy0 + sp->oh;
        phase_a(sp, g, r0, r1, cnt, dropped);
        count_one(sp, &sp->a_done[g]);
        return 0;
    }
    /* Every ray of the group within the margin is read; and the pixels'
     * sums take the groups in order. */
    wait_count(sp, &sp->a_done[g], sp->n_a);
    if (g >= 1)
        wait_count(sp, &sp->b_done[g - 1], sp->n_b);
    int b = r - sp->n_a;
    int r0 = BAND * (sp->b0 + b), r1 = r0 + BAND;
    r0 = r0 > sp->y0 ? r0 : sp->y0;
    r1 = r1 < sp->y1 ? r1 : sp->y1;
    phase_b(sp, g, r0, r1, worker);
    if (g == sp->n_groups - 1 && sp->img->depth != NULL) {
        int W = sp->x1 - sp->x0;
        for (int y = r0; y < r1; y++)
            for (int x = sp->x0; x < sp->x1; x++)
                sp->img->depth[(size_t)(y - sp->y0) * W + (x - sp->x0)] =
                    lr__sample_depth(sp->sh, x, y, cnt);
    }
    count_one(sp, &sp->b_done[g]);
    /* Progress: the band's pixels, a share per group. */
    uint64_t rows = (uint64_t)(r1 - r0) * (uint64_t)(sp->x1 - sp->x0);
    return rows * (uint64_t)(g + 1) / (uint64_t)sp->n_groups -
           rows * (uint64_t)g / (uint64_t)sp->n_groups;
}

void lr__splat_resolve(const lr__splat *sp)
{
    size_t px = (size_t)(sp->x1 - sp->x0) * (size_t)(sp->y1 - sp->y0);
    for (size_t i = 0; i < 3 * px; i++) {
        double v = sp->sums[i] / sp->spp;
        /* Never NaN or Inf in an image (film.c's clamp). */
        if (isnan(v))
            v = 0.0;
        v = v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v;
        sp->img->rgb[i] = (float)v;
    }
}

void lr__splat_free(lr__splat *sp)
{
    if (sp == NULL)
        return;
    pthread_mutex_destroy(&sp->lock);
    pthread_cond_destroy(&sp->cond);
    splat_free_parts(sp);
    free(sp);
}
