/*
 * test_lens_blur.c: the planner's bound for a real lens (lens_blur.c)
 * against the real spot, measured here by the camera's own rays and an
 * inverse of its chief-ray map found by Newton's method (not the
 * table's linearised map): on every shipped lens and the test lenses
 * (fisheye, zoom, retrofocus), on and off axis, at random depth ranges
 * on both sides of the focus and across it.  Also the chief rays' weight
 * against the mean of the sampled lens's, and where the rays go against
 * lr__lens_blur_reach.  The chief-ray table (lens_chief.c) against the
 * chief ray traced in double at the film radius itself, and the packet
 * rays of a skipped block against the model's own chief ray.
 */
#include "test.h"
#include "camera/camera.h"
#include "camera/camera_lens.h"
#include "optics/lens_load.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define W 160
#define H 100

static lr_scene *lens_cam(const char *lens, const char *extra, lr_camera *cam,
                          lr__cam *c)
{
    char json[4096], path[2048], cwd[1024];
    if (lens[0] == '@') {
        /* A test lens: a file, by its full path (scenes load from the
         * tests' own directory). */
        assert_non_null(getcwd(cwd, sizeof cwd));
        snprintf(path, sizeof path, "\"%s/%s\"", cwd, lens + 1);
        lens = path;
    }
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": 1,"
             "  \"max_depth\": 0, \"adaptive\": false},"
             " \"camera\": {\"model\": \"lens\", \"lens\": %s,"
             "  \"position\": [0, 0, 0], \"look_at\": [0, 0, -1] %s},"
             " \"materials\": {\"w\": {\"diffuse\": 1}},"
             " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -50],"
             "  \"radius\": 1}]}",
             W, H, lens, extra);
    lr_scene *s = lr_test_load_json(json);
    lr_scene_camera(s, cam);
    lr__cam_init(c, cam, W, H);
    return s;
}

static double rnd(unsigned *st)
{
    *st = *st * 1664525u + 1013904223u;
    return (*st >> 8) * (1.0 / 16777216.0);
}

/* Where the ray org + t dir meets depth Z (along the view axis from the
 * sensor): camera-space x, y.  0 when it does not go there. */
static int at_depth(const lr__cam *c, lr__v3 org, lr__v3 dir, double Z,
                    double *x, double *y)
{
    double dz = v3_dot(dir, c->forward);
    if (!(dz > 1e-9))
        return 0;
    double t = (Z - v3_dot(v3_sub(org, c->origin), c->forward)) / dz;
    lr__v3 p = v3_sub(v3_madd(org, dir, t), c->origin);
    *x = v3_dot(p, c->right);
    *y = v3_dot(p, c->up);
    return 1;
}

/* The film point whose chief ray meets depth Z at (x, y): Newton's method
 * from (fx, fy) with a differenced Jacobian.  0 when it does not
 * converge (to 1e-6 of a pixel in the point's units). */
static int film_of(const lr__cam *c, double Z, double x, double y, double *fx,
                   double *fy)
{
    for (int it = 0; it < 30; it++) {
        double p[3][2];
        for (int k = 0; k < 3; k++) {
            lr__v3 o, d;
            double h = 1e-3;
            c->model->chief(c, *fx + (k == 1 ? h : 0), *fy + (k == 2 ? h : 0),
                            &o, &d);
            if (!at_depth(c, o, d, Z, &p[k][0], &p[k][1]))
                return 0;
            if (k > 0)
                for (int a = 0; a < 2; a++)
                    p[k][a] = (p[k][a] - p[0][a]) / h;
        }
        double ex = x - p[0][0], ey = y - p[0][1];
        double det = p[1][0] * p[2][1] - p[2][0] * p[1][1];
        if (!(fabs(det) > 0.0))
            return 0;
        double dx = (ex * p[2][1] - ey * p[2][0]) / det;
        double dy = (p[1][0] * ey - p[1][1] * ex) / det;
        *fx += dx, *fy += dy;
        if (hypot(dx, dy) < 1e-7)
            return 1;
    }
    return 0;
}

typedef struct tally {
    int checked, bounded;
    double worst_spot, worst_col; /* real / bound */
} tally;

/* Film points, depth ranges and lens samples at random: each sample's
 * landing point against the chief ray's (spot) and each colour's against
 * the reference's through the same lens point (colour). */
static void check_lens(const char *lens, const char *extra, tally *t)
{
    lr_camera cam;
    lr__cam c;
    lr_scene *s = lens_cam(lens, extra, &cam, &c);
    const lr__lens_blur *b = lr__lens_blur_get(&c);
    assert_non_null(b);
    assert_ptr_equal(c.lens.blur, b);
    /* The cache gives the same table to the next camera. */
    lr__cam c2;
    lr__cam_init(&c2, &cam, W, H);
    assert_ptr_equal(lr__lens_blur_get(&c2), b);
    double nms[10];
    int ncol = 0;
    nms[ncol++] = c.nm_ref;
    if (c.chroma_active && c.chroma.mode == LR_CHROMATIC_RGB)
        for (int k = 0; k < 3; k++)
            nms[ncol++] = c.lens.nm_rgb[k];
    else if (c.chroma_active)
        for (int k = 0; k < 3; k++)
            nms[ncol++] = 380.0 + 200.0 * k;
    unsigned st = 12345u;
    double F = cam.focus_distance;
    for (int trial = 0; trial < 100; trial++) {
        /* A 16-pixel block; every fourth on the axis. */
        double bx0 = trial % 4 == 0 ? W / 2 - 8 : floor(rnd(&st) * (W - 16));
        double by0 = trial % 4 == 0 ? H / 2 - 8 : floor(rnd(&st) * (H - 16));
        /* Depths: on either side of the focus, or across it, or out to
         * infinity. */
        double z0 = F * (0.3 + 2.0 * rnd(&st)), z1 = z0 * (1.0 + rnd(&st));
        if (trial % 3 == 0)
            z0 = F * (0.7 + 0.3 * rnd(&st)), z1 = F * (1.0 + 0.5 * rnd(&st));
        if (trial % 5 == 0)
            z1 = INFINITY;
        double spot, col;
        if (!lr__lens_blur_bound(&c, b, bx0, by0, bx0 + 16, by0 + 16, z0, z1,
                                 &spot, &col))
            continue;
        t->bounded++;
        for (int k = 0; k < 40; k++) {
            double fx = bx0 + 16 * rnd(&st), fy = by0 + 16 * rnd(&st);
            double Z = isfinite(z1) ? z0 + (z1 - z0) * rnd(&st)
                                    : z0 / fmax(1e-3, rnd(&st));
            double u[2] = {rnd(&st), rnd(&st)};
            double X0 = 0, Y0 = 0;
            for (int ci = 0; ci < ncol; ci++) {
                lr__v3 o, d;
                double wt = lr__cam_lens_ray(&c, fx, fy, u, c.w, nms[ci], &o,
                                             &d);
                double x, y, gx = fx, gy = fy;
                if (!(wt > 0.0) || !at_depth(&c, o, d, Z, &x, &y) ||
                    !film_of(&c, Z, x, y, &gx, &gy))
                    break;
                double off = hypot(gx - fx, gy - fy);
                /* The bound is a diameter: twice the farthest offset. */
                t->worst_spot = fmax(t->worst_spot, 2.0 * off / spot);
                if (ci == 0) {
                    X0 = gx, Y0 = gy;
                } else {
                    double sep = hypot(gx - X0, gy - Y0);
                    t->worst_col = fmax(t->worst_col, 2.0 * sep / col);
                }
                t->checked++;
            }
        }
    }
    lr_scene_free(s);
}

static const char *const lenses[] = {
    "\"biotar-de485798-100mm-f1.4\"",
    "\"double-gauss-50\"",
    "\"double-gauss-angenieux-us2701982-100mm-f1.1\"",
    "\"fisheye-10\"",
    "\"fisheye-minolta-us4256373-16mm-f2.8\"",
    "\"objective-us8879901-36mm-f2\"",
    "\"petzval-kodak-us2500046-100mm-f2.2\"",
    "\"petzval\"",
    "\"planar-rudolph-us583336-49mm-f4.5\"",
    "\"retrofocus-flektagon-de953471-35mm-f2.8\"",
    "\"retrofocus-nikon-us3583791-100mm-f2.8\"",
    "\"sonnar-us1975678-50mm-f1.5\"",
    "\"telephoto-250\"",
    "\"telephoto-laikin-127mm-f5.6\"",
    "\"tessar-laikin-102mm-f4.5\"",
    "\"wide-170deg-laikin-5mm-f1.8\"",
    "\"wide-22\"",
    "\"zoom-nikkor-us4189212-25mm-f4\"",
    "\"zoom-nikkor-us4189212-35mm-f4\"",
    "\"zoom-nikkor-us4189212-49mm-f4.4\"",
    "\"zoom-nikkor-z-14-30mm-f4-at-14mm\"",
    "\"zoom-nikon-jp53131852-200mm-f2.8\"",
    "\"zoom-nikon-jp53131852-80mm-f2.8\"",
    /* The test lenses: fisheye, zoom, retrofocus. */
    "@tests/data/lenses/minolta-fisheye-us4256373.json",
    "@tests/data/lenses/nikon-zoom-80-200-short.json",
    "@tests/data/lenses/flektagon-de953471.json",
};

/* The lenses a sweep below takes: every one, or under the sanitizers
 * (LR_TEST_SANITIZED) one of each kind: the double Gauss, a fisheye, the
 * zoom with four aspheres, and the three test lenses. */
static int swept(size_t i)
{
    const char *l = lenses[i];
    return !LR_TEST_SANITIZED || l[0] == '@' ||
           strstr(l, "\"double-gauss-50\"") != NULL ||
           strstr(l, "\"fisheye-10\"") != NULL || strstr(l, "z-14-30") != NULL;
}

/* Every lens, wide open and at f/8, focused at 3 m; then colours. */
static void test_spot_inside_bound(void **state)
{
    (void)state;
    const char *setups[] = {
        ", \"focus_distance\": 3",
        ", \"focus_distance\": 3, \"f_number\": 8",
        ", \"focus_distance\": 5, \"f_number\": 11,"
        " \"chromatic\": {\"mode\": \"rgb\"}",
        ", \"focus_distance\": 2, \"f_number\": 4,"
        " \"chromatic\": {\"mode\": \"spectral\"}",
    };
    double worst_s = 0.0, worst_c = 0.0;
    long total = 0;
    for (size_t i = 0; i < sizeof lenses / sizeof *lenses; i++)
        for (size_t k = 0; k < sizeof setups / sizeof *setups && swept(i);
             k++) {
            tally t = {0, 0, 0.0, 0.0};
            /* The test fisheye is scaled to f = 1 mm: a sensor to match
             * (on a 36 mm one its image is a dot in the middle). */
            char extra[256];
            snprintf(extra, sizeof extra, "%s%s", setups[k],
                     strstr(lenses[i], "us4256373.json") != NULL
                         ? ", \"sensor_width_mm\": 2.4"
                         : "");
            check_lens(lenses[i], extra, &t);
            print_message("%-60.60s %-24.24s %6d samples, %3d ranges: "
                          "spot %.3f, colour %.3f of the bound\n",
                          lenses[i], setups[k] + 2, t.checked, t.bounded,
                          t.worst_spot, t.worst_col);
            if (t.worst_spot > 1.0 || t.worst_col > 1.0)
                fail_msg("%s %s: the real spot is %.3f, the colours' spread "
                         "%.3f of the bound",
                         lenses[i], setups[k], t.worst_spot, t.worst_col);
            worst_s = fmax(worst_s, t.worst_spot);
            worst_c = fmax(worst_c, t.worst_col);
            /* Most ranges are bounded and sampled, unless the lens's
             * table reaches no nearer than these depths. */
            assert_true(t.checked > 300 || t.bounded == 0);
            total += t.checked;
        }
    print_message("worst: spot %.3f, colour %.3f of the bound (%ld samples)\n",
                  worst_s, worst_c, total);
    assert_true(total > (LR_TEST_SANITIZED ? 40000 : 200000));
}

/* The chief ray's weight (the plan's rays where it skips the lens) is
 * the mean weight of the sampled lens: on and off axis, against a
 * stratified 256 x 256 mean of the camera's own rays. */
static void test_chief_weight_is_mean(void **state)
{
    (void)state;
    const char *cases[][2] = {
        {"\"double-gauss-50\"", ", \"focus_distance\": 5, \"f_number\": 11"},
        {"\"double-gauss-50\"", ", \"focus_distance\": 2, \"f_number\": 2.8"},
        {"\"wide-22\"", ", \"focus_distance\": 10, \"f_number\": 8"},
        {"\"fisheye-10\"", ", \"focus_distance\": 3"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        lr_camera cam;
        lr__cam c;
        lr_scene *s = lens_cam(cases[i][0], cases[i][1], &cam, &c);
        assert_non_null(lr__lens_blur_get(&c));
        const double pts[3][2] = {
            {W / 2.0, H / 2.0}, {W * 0.8, H * 0.3}, {W - 2.0, H - 2.0}};
        for (int p = 0; p < 3; p++) {
            double sum = 0.0;
            const int n = 256;
            for (int a = 0; a < n; a++)
                for (int b = 0; b < n; b++) {
                    double u[2] = {(a + 0.5) / n, (b + 0.5) / n};
                    lr__v3 o, d;
                    sum += lr__cam_lens_ray(&c, pts[p][0], pts[p][1], u, c.w,
                                            c.nm_ref, &o, &d);
                }
            double mean = sum / (n * n);
            float fx[16], fy[16], lu[16] = {0}, lv[16] = {0}, wt[16];
            for (int k = 0; k < 16; k++)
                fx[k] = (float)pts[p][0], fy[k] = (float)pts[p][1];
            struct RTCRayHit16 rh __attribute__((aligned(64)));
            c.model->rays16(&c, 0, 16, fx, fy, lu, lv, &rh, wt);
            print_message("%s%s at (%g, %g): chief %.5f, mean %.5f\n",
                          cases[i][0], cases[i][1], pts[p][0], pts[p][1], wt[0],
                          mean);
            assert_true(fabs(wt[0] - mean) <= 0.01 * mean + 1e-6);
        }
        lr_scene_free(s);
    }
}

/* Every ray of a block meets depth Z within Z [u0, u1] x [v0, v1] grown
 * by R (the reach the plan finds geometry with). */
static void test_reach_holds_rays(void **state)
{
    (void)state;
    int checked = 0;
    for (size_t i = 0; i < sizeof lenses / sizeof *lenses; i++) {
        if (!swept(i))
            continue;
        lr_camera cam;
        lr__cam c;
        lr_scene *s = lens_cam(lenses[i], ", \"focus_distance\": 3", &cam, &c);
        const lr__lens_blur *b = lr__lens_blur_get(&c);
        assert_non_null(b);
        unsigned st = 777u;
        for (int trial = 0; trial < 40; trial++) {
            double bx0 = floor(rnd(&st) * (W - 16)),
                   by0 = floor(rnd(&st) * (H - 16));
            if (trial == 0)
                bx0 = W / 2 - 8, by0 = H / 2 - 8;
            double uv[4], R;
            lr__lens_blur_reach(&c, b, bx0, by0, bx0 + 16, by0 + 16, uv, &R);
            for (int k = 0; k < 200; k++) {
                double fx = bx0 + 16 * rnd(&st), fy = by0 + 16 * rnd(&st);
                double u[2] = {rnd(&st), rnd(&st)};
                lr__v3 o, d;
                if (!(lr__cam_lens_ray(&c, fx, fy, u, c.w, c.nm_ref, &o, &d) >
                      0.0))
                    continue;
                double Z = 0.5 + 100.0 * rnd(&st), x, y;
                if (!at_depth(&c, o, d, Z, &x, &y))
                    continue;
                if (!isfinite(uv[0] + uv[1] + uv[2] + uv[3]))
                    continue; /* no bound claimed */
                if (!(x >= Z * uv[0] - R && x <= Z * uv[1] + R &&
                      y >= Z * uv[2] - R && y <= Z * uv[3] + R))
                    fail_msg("%s: a ray of block (%g, %g) meets depth %g at "
                             "(%g, %g), outside %g [%g, %g] x [%g, %g] +- %g",
                             lenses[i], bx0, by0, Z, x, y, Z, uv[0], uv[1],
                             uv[2], uv[3], R);
                checked++;
            }
        }
        lr_scene_free(s);
    }
    assert_true(checked > 10000);
}

/* A scene built to fool the planner: a wall of sharp tiles in focus 8 m
 * away through the double Gauss at f/8, and a small sphere 0.5 m from
 * the camera blurred over it (3 pixels).  The plan skips the lens on the wall's
 * blocks and must keep it wherever the sphere's blur reaches: the
 * planned image's RMSE against a 512-spp full simulation stays within
 * 1.1x the full simulation's at the same samples, and it does skip. */
static const char *fool_scene =
    "{\"render\": {\"width\": 192, \"height\": 128, \"max_depth\": 0},"
    " \"camera\": {\"model\": \"lens\", \"lens\": \"double-gauss-50\","
    "  \"position\": [0, 0, 8], \"look_at\": [0, 0, 0],"
    "  \"sensor_width_mm\": 36, \"focus_distance\": 8, \"f_number\": 8},"
    " \"materials\": {\"w\": {\"diffuse\": 0.9}, \"k\": {\"diffuse\": 0.05},"
    "  \"r\": {\"diffuse\": [0.9, 0.1, 0.1]}},"
    " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
    " \"objects\": ["
    "  {\"type\": \"plane\", \"point\": [0, 0, 0], \"normal\": [0, 0, 1],"
    "   \"size\": [12, 8], \"material\": \"w\"},"
    "  {\"type\": \"plane\", \"point\": [-1.5, 0.5, 0.01], \"normal\": [0, 0, "
    "1],"
    "   \"size\": 0.7, \"material\": \"k\"},"
    "  {\"type\": \"plane\", \"point\": [1.2, -0.6, 0.01], \"normal\": [0, 0, "
    "1],"
    "   \"size\": 0.7, \"material\": \"k\"},"
    "  {\"type\": \"plane\", \"point\": [0, 0, 0.01], \"normal\": [0, 0, 1],"
    "   \"size\": [6, 0.05], \"material\": \"k\"},"
    "  {\"type\": \"sphere\", \"center\": [0.05, 0.03, 7.5], \"radius\": 0.03,"
    "   \"material\": \"r\"}]}";

/* RMSE of a against ref over the pixels within 3 of one where ref is
 * red (the foreground sphere's blurred image): where a plan that ignored
 * the foreground would err, too few pixels for the whole image's RMSE
 * to show it. */
static double red_rmse(const lr_image *a, const lr_image *ref, int *n)
{
    int w = lr_image_width(ref), h = lr_image_height(ref);
    const float *pa = lr_image_rgb(a), *pr = lr_image_rgb(ref);
    double sum = 0.0;
    *n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int near = 0;
            for (int dy = -3; dy <= 3 && !near; dy++)
                for (int dx = -3; dx <= 3 && !near; dx++) {
                    int X = x + dx, Y = y + dy;
                    if (X < 0 || Y < 0 || X >= w || Y >= h)
                        continue;
                    const float *q = &pr[3 * (Y * w + X)];
                    near = q[0] - q[1] > 0.05f;
                }
            if (!near)
                continue;
            for (int c = 0; c < 3; c++) {
                double d = pa[3 * (y * w + x) + c] - pr[3 * (y * w + x) + c];
                sum += d * d;
            }
            ++*n;
        }
    return *n > 0 ? sqrt(sum / (3.0 * *n)) : 0.0;
}

static void test_fooling_scene_within_guarantee(void **state)
{
    (void)state;
    lr_image *im[3];
    lr_render_stats sf, sp;
    lr_test_plan_renders(fool_scene, 512, 32, im, &sf, &sp);
    lr_image *ref = im[0], *full = im[1], *plan = im[2];
    double ef = lr_test_rmse(full, ref), ep = lr_test_rmse(plan, ref);
    print_message("fooling scene: RMSE full %.5f, planned %.5f (%.3fx); lens "
                  "on %.0f%% of pixels\n",
                  ef, ep, ep / ef, 100.0 * sp.lens_pixels / sp.pixels);
    int nr;
    double rf = red_rmse(full, ref, &nr), rp = red_rmse(plan, ref, &nr);
    print_message("  around the blurred sphere (%d pixels): RMSE full %.5f, "
                  "planned %.5f (%.3fx)\n",
                  nr, rf, rp, rp / rf);
    assert_true(nr > 20);
    assert_true(ep <= 1.1 * ef);
    assert_true(rp <= 1.1 * rf);
    /* It does skip, and not everywhere. */
    assert_true(sp.lens_pixels < sp.pixels);
    assert_true(sp.lens_pixels > 0);
    assert_int_equal(sf.lens_pixels, sf.pixels);
    lr_image_free(ref);
    lr_image_free(full);
    lr_image_free(plan);
}

/* The chief-ray table's errors (lens_chief.c) are in pixels of this
 * frame's width. */
#define PX_WIDE LR__CHIEF_FRAME_PX

/* A ray in the lens's radial plane as a line (lens_blur.c's): on the
 * plane at inverse depth x (1/mm from the sensor) its lateral point is
 * s + p x. */
static void line_of(const lr__cam *c, const double *o, const double *d,
                    double *s, double *p)
{
    *s = d[0] / -d[2];
    *p = o[0] - (c->lens.z_sensor - o[2]) * *s;
}

/* The inverse depths the plan may use the table at: [0, xm], xm the
 * blur table's start (twice the front vertex's distance), halved while
 * the film map's derivative J changes sign (as lens_blur.c's x_max). */
static double x_near(const lr__cam *c, double js, double jp)
{
    double xm = 1.0 / (2.0 * (c->lens.z_sensor - c->lens.L->z[0]));
    while (!((js > 0.0) == (js + jp * xm > 0.0)))
        xm *= 0.5;
    return xm;
}

/* The largest film distance, in pixels of a PX_WIDE frame, between two
 * rays from film radius r, over x in [0, xm] (a Moebius function of x:
 * largest at an end, lens_blur.c), J the traced chief ray's derivative
 * over r at r. */
static double film_px(const lr__cam *c, double r, const double *o1,
                      const double *d1, const double *o2, const double *d2,
                      double *xm)
{
    double s1, p1, s2, p2, sa, pa, sb, pb, oa[3], da[3], ob[3], db[3], T;
    double h = 1e-4;
    line_of(c, o1, d1, &s1, &p1);
    line_of(c, o2, d2, &s2, &p2);
    /* J by a difference inside r's interval of the pupil table (its
     * centre is kinked at the table's radii). */
    double a = r, b = r + h;
    if (floor(b / c->lens.pupil_rmax * LR__PUPIL_N) !=
        floor(a / c->lens.pupil_rmax * LR__PUPIL_N))
        a = r - h, b = r;
    if (!lr__lens_chief_traced(c, a, oa, da, &T) ||
        !lr__lens_chief_traced(c, b, ob, db, &T))
        return -1.0;
    line_of(c, oa, da, &sa, &pa);
    line_of(c, ob, db, &sb, &pb);
    double js = (sb - sa) / h, jp = (pb - pa) / h;
    *xm = x_near(c, js, jp);
    double px = PX_WIDE / c->lens.sensor_w, worst = 0.0;
    for (int e = 0; e < 2; e++) {
        double x = e ? *xm : 0.0;
        double dl = fabs((s2 - s1) + (p2 - p1) * x) / fabs(js + jp * x);
        worst = fmax(worst, dl * px);
    }
    return worst;
}

static const char *const chief_setups[] = {
    ", \"focus_distance\": 3",
    ", \"focus_distance\": 10, \"f_number\": 8",
};

static void extra_for(const char *lens, const char *setup, char *extra,
                      size_t n)
{
    /* The test fisheye is scaled to f = 1 mm: a sensor to match. */
    snprintf(extra, n, "%s%s", setup,
             strstr(lens, "us4256373.json") != NULL
                 ? ", \"sensor_width_mm\": 2.4"
                 : "");
}

/* The table's interpolated ray and transmittance against the chief ray
 * traced at the same radius, 16 radii in each of the table's intervals
 * at random: within 1e-4 of a pixel at every depth the plan uses it at,
 * the transmittance within 1e-5; and the table holds a node wherever the
 * chief ray passes there. */
static void test_table_within_1e4_px(void **state)
{
    (void)state;
    double worst = 0.0, worst_t = 0.0;
    long checked = 0;
    unsigned st = 7;
    for (size_t i = 0; i < sizeof lenses / sizeof *lenses; i++)
        for (size_t k = 0;
             k < sizeof chief_setups / sizeof *chief_setups && swept(i); k++) {
            char extra[256];
            extra_for(lenses[i], chief_setups[k], extra, sizeof extra);
            lr_camera cam;
            lr__cam c;
            lr_scene *s = lens_cam(lenses[i], extra, &cam, &c);
            const lr__lens_blur *b = lr__lens_blur_get(&c);
            assert_non_null(b);
            const lr__lens_chief *t = lr__lens_blur_chief(b);
            double lw = 0.0, lt = 0.0;
            int n = 0;

            for (int a = 0; a + 1 < LR__CHIEF_NODES; a++)
                for (int m = 0; m < 16; m++) {
                    double r = c.lens.pupil_rmax * (a + rnd(&st)) /
                               (LR__CHIEF_NODES - 1);
                    double o1[3], d1[3], T1, o2[3], d2[3], T2, xm;
                    int traced = lr__lens_chief_traced(&c, r, o1, d1, &T1);
                    int tab = lr__lens_chief_eval(&c, t, r, o2, d2, &T2);
                    if (!tab)
                        continue; /* the glass traces there */
                    /* Where both nodes pass, so does the ray between. */
                    assert_true(traced);
                    double e = film_px(&c, r, o1, d1, o2, d2, &xm);
                    if (e < 0.0)
                        continue;
                    lw = fmax(lw, e);
                    lt = fmax(lt, fabs(T2 - T1) / T1);
                    n++;
                }
            print_message("%-44.44s %-24.24s %4d of %d intervals exact; %6d "
                          "radii there: %.2e px, T %.1e\n",
                          lenses[i], chief_setups[k] + 2, t->n_exact,
                          LR__CHIEF_NODES - 1, n, lw, lt);
            /* The double Gauss, the bench's lens: nearly all. */
            if (strstr(lenses[i], "\"double-gauss-50\"") != NULL)
                assert_true(t->n_exact > 0.9 * (LR__CHIEF_NODES - 1));
            assert_true(n >= 8 * t->n_exact);
            worst = fmax(worst, lw), worst_t = fmax(worst_t, lt);
            checked += n;
            lr_scene_free(s);
        }
    print_message("worst: %.2e px of a %g-pixel frame, T %.1e relative, %ld "
                  "radii\n",
                  worst, PX_WIDE, worst_t, checked);
    assert_true(worst < 1e-4);
    assert_true(worst_t < 1e-5);
}

/* The camera's packet rays where the plan skips the lens (rays16 with
 * use_lens 0: the table, or the glass where an interval is not exact)
 * against the model's chief ray traced in double (lens_chief), at random film
 * points: the same rays up to float's rounding (what the glass's float
 * trace gave before the table), and weights within 1e-6 of the chief
 * weight times the traced transmittance (absolute: about 1 at the
 * centre). */
static void test_packet_rays_are_chief_rays(void **state)
{
    (void)state;
    double worst[2] = {0.0, 0.0}, worst_w[2] = {0.0, 0.0};
    long lanes[2] = {0, 0};
    unsigned st = 11;
    for (size_t i = 0; i < sizeof lenses / sizeof *lenses; i++) {
        if (!swept(i))
            continue;
        char extra[256];
        extra_for(lenses[i], chief_setups[1], extra, sizeof extra);
        lr_camera cam;
        lr__cam c;
        lr_scene *s = lens_cam(lenses[i], extra, &cam, &c);
        const lr__lens_blur *b = lr__lens_blur_get(&c);
        assert_non_null(b);
        for (int p = 0; p < 64; p++) {
            float fx[16], fy[16], lu[16] = {0}, lv[16] = {0}, wt[16];
            for (int l = 0; l < 16; l++) {
                fx[l] = (float)(W * rnd(&st));
                fy[l] = (float)(H * rnd(&st));
            }
            struct RTCRayHit16 rh __attribute__((aligned(64)));
            c.model->rays16(&c, 0, 16, fx, fy, lu, lv, &rh, wt);
            /* Which way the packet went: the table unless a lane's
             * interval is not exact (1: the glass). */
            const lr__lens_chief *t = lr__lens_blur_chief(b);
            int glass = 0;
            for (int l = 0; l < 16; l++) {
                lr__lens_sensor sp = lr__lens_sensor_at(&c, fx[l], fy[l]);
                int a = (int)(sp.r / c.lens.pupil_rmax * (LR__CHIEF_NODES - 1));
                a = a < LR__CHIEF_NODES - 2 ? a : LR__CHIEF_NODES - 2;
                glass |= !t->exact[a];
            }
            for (int l = 0; l < 16; l++) {
                lr__lens_sensor sp = lr__lens_sensor_at(&c, fx[l], fy[l]);
                double o1[3], d1[3], T1, xm;
                /* Where the double trace stops the chief ray the
                 * table has no exact interval, and the packet went
                 * through the float glass, as before the table (whose
                 * rounding can let a grazing ray through). */
                if (!lr__lens_chief_traced(&c, sp.r, o1, d1, &T1))
                    continue;
                /* The packet's ray, back into the radial plane of the
                 * lens's frame. */
                lr__v3 org = {rh.ray.org_x[l], rh.ray.org_y[l],
                              rh.ray.org_z[l]};
                lr__v3 dir = {rh.ray.dir_x[l], rh.ray.dir_y[l],
                              rh.ray.dir_z[l]};
                lr__v3 q = v3_scale(v3_sub(org, c.origin), 1.0 / c.lens.mm);
                double o2[3] = {v3_dot(q, c.right) * sp.ex +
                                    v3_dot(q, c.up) * sp.ey,
                                0.0, c.lens.z_sensor - v3_dot(q, c.forward)};
                double d2[3] = {v3_dot(dir, c.right) * sp.ex +
                                    v3_dot(dir, c.up) * sp.ey,
                                0.0, -v3_dot(dir, c.forward)};
                double e = film_px(&c, sp.r, o1, d1, o2, d2, &xm);
                if (e < 0.0)
                    continue;
                int k = (int)(sp.r / c.lens.pupil_rmax * LR__PUPIL_N);
                k = k < LR__PUPIL_N - 1 ? k : LR__PUPIL_N - 1;
                double f = sp.r / c.lens.pupil_rmax * LR__PUPIL_N - k;
                double want = lr__lens_blur_chief_w(b, k, (float)f) * T1;
                worst[glass] = fmax(worst[glass], e);
                /* Absolute: the weights are about 1 at the centre (a
                 * relative error grows where they fall to 0). */
                worst_w[glass] = fmax(worst_w[glass], fabs(wt[l] - want));
                lanes[glass]++;
            }
        }
        lr_scene_free(s);
    }
    print_message("packet chief rays, px of a %g-pixel frame: from the "
                  "table %.2e, weight %.1e (%ld lanes); through the "
                  "glass %.2e, weight %.1e (%ld lanes)\n",
                  PX_WIDE, worst[0], worst_w[0], lanes[0], worst[1], worst_w[1],
                  lanes[1]);
    assert_true(lanes[0] > (LR_TEST_SANITIZED ? 1000 : 5000) &&
                lanes[1] > 1000);
    assert_true(worst[0] <= worst[1] && worst_w[0] <= worst_w[1]);
    assert_true(worst[0] < 2e-3);
    assert_true(worst_w[0] < 1e-6);
}

static const struct CMUnitTest lens_blur_tests[] = {
    cmocka_unit_test(test_fooling_scene_within_guarantee),
    cmocka_unit_test(test_chief_weight_is_mean),
    cmocka_unit_test(test_spot_inside_bound),
    cmocka_unit_test(test_reach_holds_rays),
    cmocka_unit_test(test_table_within_1e4_px),
    cmocka_unit_test(test_packet_rays_are_chief_rays),
};
LR_TEST_GROUP(lens_blur, lens_blur_tests)
