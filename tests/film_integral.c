/*
 * film_integral.c: the closed form of film_integral.h.
 */
#include "film_integral.h"

#include <math.h>

double film_integral(lr__v3 eye, lr__v3 fwd, double R, lr__v3 c, double r,
                     double L, double fpx)
{
    return film_integral_of(eye, fwd, R, 0, c, r, L, fpx);
}

double film_integral_of(lr__v3 eye, lr__v3 fwd, double R, int square, lr__v3 c,
                        double r, double L, double fpx)
{
    lr__v3 right = v3_norm(v3_cross(fwd, v3(0, 1, 0)));
    lr__v3 up = v3_cross(right, fwd);
    const int NR = 40, NA = 64, NT = 40, NP = 64;
    double total = 0.0, wsum = 0.0;
    for (int i = 0; i < NR; i++)
        for (int j = 0; j < NA; j++) {
            double rr = R * sqrt((i + 0.5) / NR),
                   ph = 2 * M_PI * (j + 0.5) / NA;
            double lx = rr * cos(ph), ly = rr * sin(ph);
            if (square)
                lx = R * (2.0 * (i + 0.5) / NR - 1.0),
                ly = R * (2.0 * (j + 0.5) / NA - 1.0);
            lr__v3 P = v3_add(eye,
                              v3_add(v3_scale(right, lx), v3_scale(up, ly)));
            lr__v3 d = v3_sub(c, P);
            double dist = sqrt(v3_dot(d, d));
            lr__v3 a = v3_scale(d, 1.0 / dist);
            double sin2 = r * r / (dist * dist);
            double omc = sin2 / (1.0 + sqrt(1.0 - sin2));
            lr__v3 t1 = v3_norm(
                v3_cross(a, fabs(a.x) < 0.9 ? v3(1, 0, 0) : v3(0, 1, 0)));
            lr__v3 t2 = v3_cross(a, t1);
            double cone = 0.0;
            for (int k = 0; k < NT; k++)
                for (int m = 0; m < NP; m++) {
                    double t = omc * (k + 0.5) / NT;
                    double ct = 1.0 - t, st = sqrt(t * (2.0 - t));
                    double p = 2 * M_PI * (m + 0.5) / NP;
                    lr__v3 w = v3_add(v3_scale(a, ct),
                                      v3_add(v3_scale(t1, st * cos(p)),
                                             v3_scale(t2, st * sin(p))));
                    double cz = v3_dot(w, fwd);
                    cone += 1.0 / (cz * cz * cz);
                }
            /* Each cell of the cone has solid angle 2 pi omc / (NT NP). */
            total += cone * 2 * M_PI * omc / (NT * NP);
            wsum += 1.0;
        }
    return L * fpx * fpx * total / wsum;
}

double tri_film_integral(double R, lr__v3 a, lr__v3 b, lr__v3 c, double L,
                         double fpx)
{
    lr__v3 eye = v3(0, 0, 10), fwd = v3(0, 0, -1);
    lr__v3 e1 = v3_sub(b, a), e2 = v3_sub(c, a);
    lr__v3 nc = v3_cross(e1, e2);
    double area = 0.5 * sqrt(v3_dot(nc, nc));
    lr__v3 n = v3_norm(nc);
    const int NR = 24, NA = 48, NT = 48;
    double total = 0.0;
    for (int i = 0; i < NR; i++)
        for (int j = 0; j < NA; j++) {
            double rr = R * sqrt((i + 0.5) / NR),
                   ph = 2 * M_PI * (j + 0.5) / NA;
            lr__v3 P = v3_add(eye, v3(rr * cos(ph), rr * sin(ph), 0));
            double sum = 0.0;
            for (int k = 0; k < NT; k++)
                for (int m = 0; m < NT; m++) {
                    double u0 = (k + 0.5) / NT, u1 = (m + 0.5) / NT;
                    double sq = sqrt(u0);
                    lr__v3 y = v3_add(a, v3_add(v3_scale(e1, sq * (1 - u1)),
                                                v3_scale(e2, sq * u1)));
                    lr__v3 d = v3_sub(y, P);
                    double r2 = v3_dot(d, d), r = sqrt(r2);
                    lr__v3 w = v3_scale(d, 1.0 / r);
                    double cy = -v3_dot(w, n), cz = v3_dot(w, fwd);
                    if (cy > 0.0)
                        sum += cy / (r2 * cz * cz * cz);
                }
            total += sum * area / (NT * NT);
        }
    return L * fpx * fpx * total / (NR * NA);
}
