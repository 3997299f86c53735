/*
 * test_ghost_mesh.c: a small source's ghosts drawn as meshes
 * (lib/integrator/ghost_grid.c) against the same ghosts traced as light
 * paths (ghost_trace.c's lr__gt_path, unbiased), two estimators that
 * share only the lens's trace; and the meshes' convergence as their
 * cells and directions grow.  A sphere 5 degrees off axis, 100 m out,
 * through the shipped double Gauss, bare.
 */
#include "test.h"
#include "integrator/ghost_trace.h"

#include <math.h>
#include <stdio.h>

#define W 64
#define SCENE                                                                \
    "{\"render\": {\"width\": 64, \"height\": 64, \"spp\": 1024, "           \
    "\"seed\": 1, \"adaptive\": false},"                                     \
    " \"camera\": {\"model\": \"lens\", \"lens\": \"double-gauss-50\","      \
    "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"                    \
    "  \"sensor_width_mm\": 36, \"focus_distance\": 1000,"                   \
    "  \"coating\": \"none\", \"ghosts\": true},"                            \
    " \"background\": 0,"                                                    \
    " \"materials\": {\"l\": {\"emission\": [4e6, 4e6, 4e6]}},"              \
    " \"objects\": [{\"type\": \"sphere\", \"center\": [8.7488663525924, 0," \
    " -100], \"radius\": 0.1, \"material\": \"l\"}]}"

/* The ghosts alone (ghosts on less off, channel 0), their sum, centroid
 * and rms radius in pixels. */
typedef struct ghosts {
    double v[W * W];
    double sum, cx, cy, rms;
} ghosts;

/* The scene's ghosts with the sphere's radius set by `radius` (a --set
 * line). */
static void render_ghosts_r(const char *seed, const char *radius, ghosts *g,
                            lr_render_stats *st)
{
    const char *on[] = {"camera.ghosts=true", seed, radius};
    const char *off[] = {"camera.ghosts=false", seed, radius};
    lr_image *a = lr_test_render(SCENE, on, 3, st);
    lr_test_check_finite(a, st, "ghosts on");
    lr_image *b = lr_test_render(SCENE, off, 3, NULL);
    double s0 = 0.0, sx = 0.0, sy = 0.0, srr = 0.0;
    for (int k = 0; k < W * W; k++) {
        double v = (double)a->rgb[3 * k] - (double)b->rgb[3 * k];
        double x = k % W + 0.5, y = k / W + 0.5;
        g->v[k] = v;
        s0 += v, sx += v * x, sy += v * y, srr += v * (x * x + y * y);
    }
    g->sum = s0, g->cx = sx / s0, g->cy = sy / s0;
    g->rms = sqrt(srr / s0 - g->cx * g->cx - g->cy * g->cy);
    lr_image_free(a);
    lr_image_free(b);
}

static void render_ghosts(const char *seed, ghosts *g, lr_render_stats *st)
{
    render_ghosts_r(seed, "objects[0].radius=0.1", g, st);
}

/* The squared difference of a and b summed over blocks of bs x bs
 * pixels (the ghosts' shape above the paths' noise). */
static double block_d2(const ghosts *a, const ghosts *b, int bs)
{
    double d2 = 0.0;
    for (int by = 0; by < W / bs; by++)
        for (int bx = 0; bx < W / bs; bx++) {
            double d = 0.0;
            for (int k = 0; k < bs * bs; k++) {
                int i = (by * bs + k / bs) * W + bx * bs + k % bs;
                d += a->v[i] - b->v[i];
            }
            d2 += d * d;
        }
    return d2;
}

/* The mean squared error of a against b relative to b's peak squared. */
static double rel_err(const ghosts *a, const ghosts *b)
{
    double peak = 0.0, e = 0.0;
    for (int k = 0; k < W * W; k++) {
        peak = fmax(peak, b->v[k]);
        e += (a->v[k] - b->v[k]) * (a->v[k] - b->v[k]);
    }
    return e / (W * W) / (peak * peak);
}

/* The mesh render agrees with the paths' at seed 1 as closely as the paths' at seeds 1 and 2 agree with each other (in
 * 4 x 4 blocks), and in energy, centroid and rms radius.  A mesh that
 * lost its edges, a direction's weight, or the disk's normalisation
 * fails it. */
static void against_paths(const char *radius)
{
    static ghosts m, p1, p2;
    lr_render_stats sm, sp;
    render_ghosts_r("render.seed=1", radius, &m, &sm);
    double keep = lr__gt_dir_px;
    lr__gt_dir_px = 1e-12; /* every source wider than that: paths */
    render_ghosts_r("render.seed=1", radius, &p1, &sp);
    render_ghosts_r("render.seed=2", radius, &p2, NULL);
    lr__gt_dir_px = keep;
    double seeds = fabs(p2.sum / p1.sum - 1.0);
    double d_m = block_d2(&m, &p1, 4), d_s = block_d2(&p2, &p1, 4);
    print_message("mesh against paths (%s): %llu rays against %llu paths; "
                  "energy "
                  "%.4f of the paths' (seed to seed %.4f); centroid (%.3f, "
                  "%.3f) px, paths (%.3f, %.3f); rms %.4f of the paths'; "
                  "4-pixel blocks' d2 %.4g, seeds' %.4g\n",
                  radius, (unsigned long long)sm.ghost_paths,
                  (unsigned long long)sp.ghost_paths, m.sum / p1.sum, seeds,
                  m.cx, m.cy, p1.cx, p1.cy, m.rms / p1.rms, d_m, d_s);
    assert_true(sm.ghost_lights == 1 && sp.ghost_lights == 1);
    assert_true(p1.sum > 0.0);
    assert_true(fabs(m.sum / p1.sum - 1.0) < 0.02 + 2.0 * seeds);
    assert_true(hypot(m.cx - p1.cx, m.cy - p1.cy) < 0.2);
    assert_true(fabs(m.rms / p1.rms - 1.0) < 0.02);
    assert_true(d_m < 2.0 * d_s);
}

/* Meshes against paths: a source 0.2 px wide (one direction), and one
 * 3.7 px wide (4 x 4 directions, each a copy of every ghost a pixel
 * apart: they must cover the source's disc, not a line across it). */
static void test_mesh_against_paths(void **state)
{
    (void)state;
    against_paths("objects[0].radius=0.1");
    against_paths("objects[0].radius=2");
}

/* Convergence: against a mesh of 64 cells, 3 x 3 directions a pixel
 * and two splits at edges, the default's error is under 1e-4 of the
 * peak squared and under that of a mesh of 8 cells with no split, whose
 * energy is further off too. */
static void test_mesh_converges(void **state)
{
    (void)state;
    static ghosts fine, def, coarse;
    int cells = lr__gt_cells, depth = lr__gt_depth;
    double dir = lr__gt_dir_px;
    lr__gt_cells = 64, lr__gt_depth = 2, lr__gt_dir_px = 1.0 / 3.0;
    render_ghosts("render.seed=1", &fine, NULL);
    lr__gt_cells = cells, lr__gt_depth = depth, lr__gt_dir_px = dir;
    render_ghosts("render.seed=1", &def, NULL);
    lr__gt_cells = 8, lr__gt_depth = 0;
    render_ghosts("render.seed=1", &coarse, NULL);
    lr__gt_cells = cells, lr__gt_depth = depth;
    double e_def = rel_err(&def, &fine), e_coarse = rel_err(&coarse, &fine);
    print_message("mesh convergence: error over the peak^2 %.3g (default), "
                  "%.3g (8 cells); energy %.4f, %.4f of the fine mesh's\n",
                  e_def, e_coarse, def.sum / fine.sum, coarse.sum / fine.sum);
    assert_true(e_def < 1e-4);
    assert_true(e_def < e_coarse);
    assert_true(fabs(def.sum / fine.sum - 1.0) < 0.01);
    assert_true(fabs(def.sum / fine.sum - 1.0) <
                fabs(coarse.sum / fine.sum - 1.0));
}

/* A round source on the axis makes round ghosts: a source 1.5 px wide
 * (2 x 2 directions), its ghosts' second moments across and along the
 * frame within 1e-4 of each other (0 to 5 digits).  Directions on a line
 * through the source's centre (the cone's own (1 - cos, phi) grid of
 * midpoints, phi 90 and 270 degrees) stretch every ghost along that
 * line: 4.6e-4 apart. */
static void test_round_source_round_ghosts(void **state)
{
    (void)state;
    const char *sets[] = {"camera.ghosts=true", "objects[0].radius=0.8",
                          "objects[0].center=[0, 0, -100]"};
    lr_image *a = lr_test_render(SCENE, sets, 3, NULL);
    sets[0] = "camera.ghosts=false";
    lr_image *b = lr_test_render(SCENE, sets, 3, NULL);
    double s0 = 0.0, sx = 0.0, sy = 0.0, sxx = 0.0, syy = 0.0;
    for (int k = 0; k < W * W; k++) {
        double v = (double)a->rgb[3 * k] - (double)b->rgb[3 * k];
        double x = k % W + 0.5 - W / 2, y = k / W + 0.5 - W / 2;
        s0 += v, sx += v * x, sy += v * y, sxx += v * x * x, syy += v * y * y;
    }
    double vx = sxx / s0 - (sx / s0) * (sx / s0);
    double vy = syy / s0 - (sy / s0) * (sy / s0);
    print_message("round source on the axis: ghosts' variance across %.4f "
                  "px^2, along %.4f (%.5f apart)\n",
                  vx, vy, fabs(vx - vy) / (vx + vy));
    assert_true(s0 > 0.0);
    assert_true(fabs(vx - vy) / (vx + vy) < 1e-4);
    lr_image_free(a);
    lr_image_free(b);
}

static const struct CMUnitTest ghost_mesh_tests[] = {
    cmocka_unit_test(test_round_source_round_ghosts),
    cmocka_unit_test(test_mesh_against_paths),
    cmocka_unit_test(test_mesh_converges),
};

LR_TEST_GROUP(ghost_mesh, ghost_mesh_tests)
