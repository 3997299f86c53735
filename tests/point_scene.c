/*
 * point_scene.c: the point-light scene and its second moments, shared by
 * the blur tests of the lens models (point_scene.h).
 */
#include "point_scene.h"

#include <math.h>
#include <stdio.h>

/* Focal length in pixels: H / (2 tan(fov / 2)). */
double f_px(void)
{
    return W / (2.0 * tan(FOV * M_PI / 360.0));
}

/* A small white sphere (angular radius 0.004 rad, ~1.8 px) at depth z on
 * black, lit by a uniform ambient light so it renders as a flat disk. */
void point_scene(char *buf, size_t n, double z, int spp, const char *sampler)
{
    snprintf(buf, n,
             "{\"render\": {\"width\": %d, \"height\": %d, \"spp\": %d,"
             "  \"sampler\": \"%s\", \"max_depth\": 0, \"adaptive\": false},"
             " \"camera\": {\"position\": [0, 0, 0], \"look_at\": [0, 0, -1],"
             "  \"fov\": %g},"
             " \"materials\": {\"w\": {\"diffuse\": 1}},"
             " \"lights\": [{\"type\": \"ambient\", \"radiance\": 1}],"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, %.17g],"
             "  \"radius\": %.17g, \"material\": \"w\"}]}",
             W, W, spp, sampler, FOV, -z, 0.004 * z);
}

moments measure(const lr_image *img, int ch)
{
    const float *p = lr_image_rgb(img);
    int w = lr_image_width(img), h = lr_image_height(img);
    moments m = {0, 0, 0, 0};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = p[3 * (y * w + x) + ch];
            m.sum += v;
            m.cx += v * (x + 0.5);
            m.cy += v * (y + 0.5);
        }
    m.cx /= m.sum;
    m.cy /= m.sum;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = p[3 * (y * w + x) + ch];
            double dx = x + 0.5 - m.cx, dy = y + 0.5 - m.cy;
            m.m2 += v * (dx * dx + dy * dy);
        }
    m.m2 /= m.sum;
    return m;
}

/* The blur diameter implied by a measured second moment, for a kernel
 * whose second moment is k * D^2 (disk: 1/8; square of side D: 1/6). */
double diameter(double m2_blur, double k)
{
    return m2_blur > 0 ? sqrt(m2_blur / k) : 0.0;
}

void check_close(double got, double want, double rel, const char *what,
                 double z)
{
    print_message("  %-28s depth %6.3f: measured %7.3f px, expected %7.3f px "
                  "(%+.2f%%)\n",
                  what, z, got, want, 100.0 * (got - want) / want);
    if (!(fabs(got - want) <= rel * want))
        fail_msg("%s at depth %g: measured %.4g px, expected %.4g px "
                 "(%.1f%% off, allowed %.0f%%)",
                 what, z, got, want, 100.0 * (got - want) / want, rel * 100);
}

const double depths[4] = {2.5, 4.0, 9.0, 20.0};
