/*
 * light_footprint.c: where a small light's paths through a real lens
 * start (light_trace.h: lr__lt_footprint), for the light side's plan
 * (light_trace_plan.c).
 */
#include "integrator/light_trace.h"

#include "camera/camera.h"
#include "camera/camera_lens.h"

#include <math.h>
#include <stdlib.h>

/* The offsets of an n x n grid over the square of half-width `half`
 * about (cx, cy), inside the disk of radius rho that lens_point draws
 * on, whose rays from light l's centre land on the film: into at[],
 * their count returned. */
static int footprint_grid(const lr__cam *c, const lr__lt_light *l, double rho,
                          double cx, double cy, double half, int n,
                          double (*at)[2])
{
    const lr__camera_model *m = c->model;
    double cell = 2.0 * half / n;
    int k = 0;
    for (int iy = 0; iy < n; iy++)
        for (int ix = 0; ix < n; ix++) {
            double ox = cx + (ix + 0.5) * cell - half;
            double oy = cy + (iy + 0.5) * cell - half;
            if (ox * ox + oy * oy > rho * rho)
                continue;
            lr__v3 P = m->lens_at(c, ox, oy), dv = v3_sub(l->center, P);
            double len = sqrt(v3_dot(dv, dv)), fx, fy;
            if (!(len > l->radius))
                continue;
            if (!(m->film(c, ox, oy, v3_scale(dv, 1.0 / len), &fx, &fy) >
                  0.0) ||
                !lr__cam_on_film(c, fx, fy))
                continue;
            at[k][0] = ox, at[k][1] = oy, k++;
        }
    return k;
}

/* Whether the direction to p lies within the frame's field of view, by
 * its angle from the axis against the frame's corner's paraxial angle
 * widened by a quarter (a real lens's barrel distortion images beyond
 * the paraxial frame; fisheyes, which image far beyond, have no light
 * side): the 256 x 256 search below is for a light the camera sees
 * through a small pupil, and lights out of view (night-lens.json's 16
 * beyond the frame's edges) had each cost it 65536 traces, 20 ms a
 * light, outside any time limit (an independent check: 720 lights, 15 s
 * before a 2-s limit took hold). */
static int in_view(const lr__cam *c, lr__v3 p)
{
    lr__v3 d = v3_sub(p, c->origin);
    double z = v3_dot(d, c->forward);
    double x = v3_dot(d, c->right), y = v3_dot(d, c->up);
    double corner = atan(sqrt(c->half_w * c->half_w + c->half_h * c->half_h));
    return atan2(sqrt(x * x + y * y), z) <= fmin(1.25 * corner, 0.499 * M_PI);
}

/* Light l's footprint (light_trace.h: fp_x, fp_y, fp_r): of a 64 x 64
 * grid over the disk lens_point draws on, the offsets whose rays from
 * the light's centre land on the film, in a disk
 * about their mean, widened by two cells and by the light's angular
 * radius over the front's.  The front is wide and a stopped-down lens's
 * pupil small: a light path drawn over the whole front reached the film
 * 1 time in 65 at f/16 (the double Gauss), 1 in 250 wide open for the
 * Nikkor Z 14-30 at 14 mm, so a small light's image was empty at 1024
 * spp; the footprint's half of the paths land.  Where fewer than 4
 * offsets land the grid is refined: 16 x 16 over the 3 x 3 cells about
 * those that did (the cells shrink 8 times), or, where none did, the
 * light is in view and the entrance pupil is under two cells wide, 256 x
 * 256 over the whole disk and then that window again.  The pupil of the
 * Zoom-Nikkor 25 mm at f/22, or the Nikkor Z 14-30 at f/16, is smaller
 * than two cells of the 64 x 64 grid: none of its points landed, no
 * footprint was made, and 0 of 386 paths landed at 256 spp (an
 * independent check).  Left at 0 where still fewer than 4 land (the
 * whole front then) or the disk would cover half the front anyway.  A
 * proposal only: the whole front's half keeps every lens point drawable,
 * so a footprint that misses rays costs noise, never light.  0 when out
 * of memory. */
int lr__lt_footprint(const lr__cam *c, lr__lt_light *l)
{
    const lr__camera_model *m = c->model;
    enum { N = 64, FINE = 256 };
    l->fp_r = 0.0;
    if (m->ghost_disk == NULL || m->lens_at == NULL || m->film == NULL)
        return 1;
    double rho = m->ghost_disk(c), cell = 2.0 * rho / N;
    if (!(rho > 0.0))
        return 1;
    double(*at)[2] = malloc((size_t)FINE * FINE * sizeof *at);
    if (at == NULL)
        return 0;
    /* First 16 x 16: where the rays that land span 1.6 rho across, the 64
     * x 64 grid's disk (a cell finer, within a coarse cell of them) would
     * reach past sqrt(1/2) rho and the footprint would not be made: wide
     * open, it was 3000 traces a light for nothing (720 lights through
     * the double Gauss at f/2: 14 s of planning). */
    int n = footprint_grid(c, l, rho, 0.0, 0.0, rho, 16, at);
    double x0 = rho, x1 = -rho, y0 = rho, y1 = -rho;
    for (int k = 0; k < n; k++) {
        x0 = fmin(x0, at[k][0]), x1 = fmax(x1, at[k][0]);
        y0 = fmin(y0, at[k][1]), y1 = fmax(y1, at[k][1]);
    }
    int seen = in_view(c, l->center);
    if ((n > 0 && (x1 - x0 >= 1.6 * rho || y1 - y0 >= 1.6 * rho)) ||
        (n == 0 && !seen)) {
        /* (None landing of a light out of view: its image is off the
         * frame, and a finer grid would find none either.) */
        free(at);
        return 1;
    }
    n = footprint_grid(c, l, rho, 0.0, 0.0, rho, N, at);
    /* (A pupil of two cells or more, the grid would have found: its
     * light lands nowhere.) */
    if (n == 0 && seen && lr__lens_pupil_radius(c) < 2.0 * cell) {
        cell = 2.0 * rho / FINE;
        n = footprint_grid(c, l, rho, 0.0, 0.0, rho, FINE, at);
    }
    if (n > 0 && n < 4) {
        double wx = 0.0, wy = 0.0;
        for (int k = 0; k < n; k++)
            wx += at[k][0] / n, wy += at[k][1] / n;
        n = footprint_grid(c, l, rho, wx, wy, 1.5 * cell, 16, at);
        cell *= 3.0 / 16.0;
    }
    if (n >= 4) {
        double mx = 0.0, my = 0.0;
        for (int k = 0; k < n; k++)
            mx += at[k][0], my += at[k][1];
        mx /= n, my /= n;
        double r2 = 0.0;
        for (int k = 0; k < n; k++) {
            double dx = at[k][0] - mx, dy = at[k][1] - my;
            r2 = fmax(r2, dx * dx + dy * dy);
        }
        lr__v3 dv = v3_sub(l->center, c->origin);
        double ang = l->radius / sqrt(fmax(v3_dot(dv, dv), 1e-300));
        double r = sqrt(r2) + 2.0 * cell + 2.0 * rho * fmin(ang, 1.0);
        if (r * r < 0.5 * rho * rho)
            l->fp_x = mx, l->fp_y = my, l->fp_r = r;
    }
    free(at);
    return 1;
}
