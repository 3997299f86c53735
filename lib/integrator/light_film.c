/*
 * light_film.c: the light side's film (light_trace.h: lr__lt_film): its
 * fixed-point sums, the splats into them, and their sum with the camera's
 * image.  Integers, so that the light's paths add up to the same bits in
 * any order, on any number of threads.
 */
#include "integrator/light_trace.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>

lr_status lr__lt_film_init(lr__lt_film *f, const lr__lt *lt, int x0, int y0,
                           int x1, int y1, lr_error *err)
{
    f->x0 = x0, f->y0 = y0, f->x1 = x1, f->y1 = y1;
    f->ghost_sum = 0;
    f->ghost_traced = 0;
    f->nomem = 0;
    size_t n = 3 * (size_t)(x1 - x0) * (size_t)(y1 - y0);
    f->sum = calloc(n, sizeof *f->sum);
    f->fine = calloc(n, sizeof *f->fine);
    f->sum_hi = calloc(n, sizeof *f->sum_hi);
    f->fine_hi = calloc(n, sizeof *f->fine_hi);
    if (f->sum == NULL || f->fine == NULL || f->sum_hi == NULL ||
        f->fine_hi == NULL) {
        lr__lt_film_free(f);
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    }
    /* A pixel's value is a mean of radiance, about the brightest
     * light's in expectation; a scale of 2^40 over it resolves 1e-12 of
     * that light, and the sums' 96 bits leave 2^55 of headroom (an
     * estimate too low costs nothing else).  Between 1e-30 and FLT_MAX,
     * so that the scale is finite and not 0: an infinite estimate made
     * it 0 and the picture black. */
    double Lmax = lt->lmax_frame;
    for (int k = 0; k < lt->n; k++)
        Lmax = fmax(Lmax, v3_maxc(lt->lights[k].L));
    f->scale = ldexp(1.0, 40) / fmax(fmin(Lmax, FLT_MAX), 1e-30);
    f->dark = lt->dark;
    f->dark_bw = lt->dark_bw;
    f->dark_block = lt->dark_block;
    return LR_OK;
}

void lr__lt_film_free(lr__lt_film *f)
{
    free(f->sum);
    free(f->fine);
    free(f->sum_hi);
    free(f->fine_hi);
    f->sum = f->fine = NULL;
    f->sum_hi = f->fine_hi = NULL;
}

void lr__lt_splat(lr__lt_film *f, int ix, int iy, lr__v3 v)
{
    if (ix < f->x0 || ix >= f->x1 || iy < f->y0 || iy >= f->y1)
        return;
    size_t k = 3 * ((size_t)(iy - f->y0) * (size_t)(f->x1 - f->x0) +
                    (size_t)(ix - f->x0));
    double c[3] = {v.x, v.y, v.z};
    for (int j = 0; j < 3; j++) {
        double q = c[j] * f->scale;
        if (!(q != 0.0) || isnan(q))
            continue;
        /* A splat of under 2^12 units (4e-9 of the brightest light) goes
         * to the fine sum, 2^24 times finer: in sum's units it rounded
         * to a whole unit, and a dim light's splats beside a light 1e6
         * times brighter rounded to 0 at 16384 spp (its disc was lost). */
        if (fabs(q) < LR__LT_FINE)
            lr__lt_film_add(f->fine, f->fine_hi, k + (size_t)j, q * 0x1p24);
        else
            lr__lt_film_add(f->sum, f->sum_hi, k + (size_t)j, q);
    }
}

void lr__lt_film_resolve(const lr__lt_film *f, float *rgb)
{
    size_t n = 3 * (size_t)(f->x1 - f->x0) * (size_t)(f->y1 - f->y0);
    for (size_t k = 0; k < n; k++) {
        double sum = lr__lt_film_value(f->sum[k], f->sum_hi[k]);
        double fine = lr__lt_film_value(f->fine[k], f->fine_hi[k]);
        /* (At most FLT_MAX, as every pixel: a sum past it is a light
         * beyond the float range, not infinity.) */
        double v = fine != 0.0
                       ? (double)rgb[k] + (sum + fine * 0x1p-24) / f->scale
                   : sum != 0.0 ? (double)rgb[k] + sum / f->scale
                                : (double)rgb[k];
        rgb[k] = (float)(v < -FLT_MAX ? -FLT_MAX : v < FLT_MAX ? v : FLT_MAX);
    }
}
