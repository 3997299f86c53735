/*
 * film_integral.h: the closed form of a sphere light's energy on the film
 * through a thin lens (or a square lens), which the light side's tests
 * (test_light_trace.c, test_light_mis.c) hold renders against.
 */
#ifndef LR_TEST_FILM_INTEGRAL_H
#define LR_TEST_FILM_INTEGRAL_H

#include "util/vec.h"

/* The film integral (sum over pixels) of a sphere light's image through
 * a thin lens, in closed form: a pixel is the mean over its area and the
 * lens of the radiance seen, and for one lens point P the film points
 * that see the sphere cover (in pixels^2) its solid angle times fpx^2 /
 * cos^3 (the film's area per solid angle at the lens, camera.c).  So the
 * sum is L fpx^2 E_P[ integral over the cone of 1 / cos^3 ], here by
 * quadrature: the lens disk in rings and the cone in rings about its
 * axis (midpoint rules, far finer than the tolerance).  A lens of radius
 * R at eye, looking along unit fwd (up is +y); a sphere at c of radius
 * r and radiance L; fpx the focal length in pixels. */
double film_integral(lr__v3 eye, lr__v3 fwd, double R, lr__v3 c, double r,
                     double L, double fpx);

/* The same for a square lens of half side R (square = 1): the lens in a
 * grid of cells rather than rings. */
double film_integral_of(lr__v3 eye, lr__v3 fwd, double R, int square, lr__v3 c,
                        double r, double L, double fpx);

/* The film integral of a triangle light's image, in closed form as for
 * the sphere (film_integral): for one lens point P the film points that
 * see a patch dA of the triangle cover fpx^2 / cos^3 (at P) times its
 * solid angle cos_y dA / r^2, so the sum is L fpx^2 E_P[ integral over
 * the triangle of cos_y / (r^2 cos^3) dA ], the triangle's front only;
 * by midpoint rules over the lens's rings and the triangle (uniform by
 * area through the square-root map).  The lens (radius R) at (0, 0, 10)
 * looks along -z. */
double tri_film_integral(double R, lr__v3 a, lr__v3 b, lr__v3 c, double L,
                         double fpx);

#endif
