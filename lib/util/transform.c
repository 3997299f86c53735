/*
 * transform.c: the scene format's transforms: the affine algebra that
 * places objects (points, normals, mirroring, uniform scale), the JSON
 * list of translate / rotate / scale steps, and the check that placed
 * geometry stays within the scene's number limit.
 */
#include "transform.h"
#include "json_util.h"

#include <math.h>
#include <string.h>

lr__xform lr__xform_identity(void)
{
    lr__xform x = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
    return x;
}

lr__xform lr__xform_mul(const lr__xform *a, const lr__xform *b)
{
    lr__xform r;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++) {
            double v = j == 3 ? a->m[i][3] : 0.0;
            for (int k = 0; k < 3; k++)
                v += a->m[i][k] * b->m[k][j];
            r.m[i][j] = v;
        }
    return r;
}

lr__v3 lr__xform_point(const lr__xform *x, lr__v3 p)
{
    return v3(
        x->m[0][0] * p.x + x->m[0][1] * p.y + x->m[0][2] * p.z + x->m[0][3],
        x->m[1][0] * p.x + x->m[1][1] * p.y + x->m[1][2] * p.z + x->m[1][3],
        x->m[2][0] * p.x + x->m[2][1] * p.y + x->m[2][2] * p.z + x->m[2][3]);
}

/* Normals transform by the inverse transpose.  The cofactor matrix is
 * the inverse transpose times the determinant: normalised, the same
 * direction where the determinant is positive, the opposite one where x
 * mirrors.  So its sign is taken off: with it, a mirrored infinite
 * plane's front turned to the other side and a mirrored mesh's file
 * normals pointed behind their faces, which dropped them (flat shading;
 * tests/test_trace.c, test_mirror_keeps_normals). */
lr__v3 lr__xform_normal(const lr__xform *x, lr__v3 n)
{
    const double(*m)[4] = x->m;
    double c[3][3] = {{m[1][1] * m[2][2] - m[1][2] * m[2][1],
                       m[1][2] * m[2][0] - m[1][0] * m[2][2],
                       m[1][0] * m[2][1] - m[1][1] * m[2][0]},
                      {m[0][2] * m[2][1] - m[0][1] * m[2][2],
                       m[0][0] * m[2][2] - m[0][2] * m[2][0],
                       m[0][1] * m[2][0] - m[0][0] * m[2][1]},
                      {m[0][1] * m[1][2] - m[0][2] * m[1][1],
                       m[0][2] * m[1][0] - m[0][0] * m[1][2],
                       m[0][0] * m[1][1] - m[0][1] * m[1][0]}};
    double sign = lr__xform_det(x) < 0.0 ? -1.0 : 1.0;
    return v3_scale(v3_norm(v3(c[0][0] * n.x + c[0][1] * n.y + c[0][2] * n.z,
                               c[1][0] * n.x + c[1][1] * n.y + c[1][2] * n.z,
                               c[2][0] * n.x + c[2][1] * n.y + c[2][2] * n.z)),
                    sign);
}

double lr__xform_det(const lr__xform *x)
{
    const double(*m)[4] = x->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* For spheres: the transform must scale all directions alike.  Returns
 * the scale factor, or -1 if it does not. */
double lr__xform_uniform_scale(const lr__xform *x)
{
    double len[3];
    for (int j = 0; j < 3; j++)
        len[j] = sqrt(x->m[0][j] * x->m[0][j] + x->m[1][j] * x->m[1][j] +
                      x->m[2][j] * x->m[2][j]);
    for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++) {
            double dot = x->m[0][a] * x->m[0][b] + x->m[1][a] * x->m[1][b] +
                         x->m[2][a] * x->m[2][b];
            if (fabs(dot) > 1e-9 * len[a] * len[b])
                return -1;
        }
    if (fabs(len[0] - len[1]) > 1e-9 * len[0] ||
        fabs(len[0] - len[2]) > 1e-9 * len[0])
        return -1;
    return len[0];
}

lr_status lr__xform_parse(const cJSON *list, const char *path, lr__xform *out,
                          lr_error *err)
{
    static const char *const keys_rot[] = {"axis", "degrees", NULL};
    char p[LR__PATH_MAX], q[LR__PATH_MAX];
    lr_status st;
    *out = lr__xform_identity();
    if (!cJSON_IsArray(list)) {
        char d[96];
        lr__json_describe(list, d, sizeof d);
        return lr__fail(err, LR_ERR_INVALID, path,
                        "%s must be an array of steps, got %s", path, d);
    }
    size_t i = 0;
    for (const cJSON *step = list->child; step; step = step->next, i++) {
        lr__path_index(p, path, i);
        if (!cJSON_IsObject(step) || cJSON_GetArraySize(step) != 1)
            return lr__fail(err, LR_ERR_INVALID, p,
                            "%s must be an object with one key: translate, "
                            "rotate or scale",
                            p);
        lr__xform x = lr__xform_identity();
        const char *kind = step->child->string;
        if (strcmp(kind, "translate") == 0) {
            lr__v3 t;
            st = lr__json_vec3(step, "translate", p, 1, &t, err);
            if (st != LR_OK)
                return st;
            x.m[0][3] = t.x;
            x.m[1][3] = t.y;
            x.m[2][3] = t.z;
        } else if (strcmp(kind, "scale") == 0) {
            const cJSON *v = step->child;
            lr__v3 sc;
            lr__path_key(q, p, "scale");
            if (cJSON_IsNumber(v)) {
                double k = v->valuedouble;
                LR_TRY(lr__json_check_number(k, q, err));
                sc = v3(k, k, k);
            } else {
                st = lr__json_vec3(step, "scale", p, 1, &sc, err);
                if (st != LR_OK)
                    return st;
            }
            if (!v3_finite(sc) || sc.x == 0 || sc.y == 0 || sc.z == 0)
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must be finite and non-zero", q);
            x.m[0][0] = sc.x;
            x.m[1][1] = sc.y;
            x.m[2][2] = sc.z;
        } else if (strcmp(kind, "rotate") == 0) {
            const cJSON *r = step->child;
            lr__path_key(q, p, "rotate");
            if (!cJSON_IsObject(r))
                return lr__fail(err, LR_ERR_INVALID, q,
                                "%s must be an object {\"axis\": [x, y, z], "
                                "\"degrees\": d}",
                                q);
            st = lr__json_check_keys(r, q, keys_rot, err);
            if (st != LR_OK)
                return st;
            lr__v3 axis;
            double deg = 0;
            st = lr__json_vec3(r, "axis", q, 1, &axis, err);
            if (st == LR_OK)
                st = lr__json_number(r, "degrees", q, 1, &deg, err);
            if (st != LR_OK)
                return st;
            if (v3_len(axis) == 0.0) {
                lr__path_key(p, q, "axis");
                return lr__fail(err, LR_ERR_INVALID, p,
                                "%s must not be the zero vector", p);
            }
            /* Rodrigues' rotation formula, right-handed about the axis. */
            lr__v3 a = v3_norm(axis);
            double th = deg * M_PI / 180.0, c = cos(th), s = sin(th), t = 1 - c;
            double m[3][3] = {{t * a.x * a.x + c, t * a.x * a.y - s * a.z,
                               t * a.x * a.z + s * a.y},
                              {t * a.x * a.y + s * a.z, t * a.y * a.y + c,
                               t * a.y * a.z - s * a.x},
                              {t * a.x * a.z - s * a.y, t * a.y * a.z + s * a.x,
                               t * a.z * a.z + c}};
            for (int u = 0; u < 3; u++)
                for (int w = 0; w < 3; w++)
                    x.m[u][w] = m[u][w];
        } else {
            lr__path_key(q, p, kind);
            return lr__fail(err, LR_ERR_INVALID, q,
                            "%s: unknown transform step \"%s\" (expected "
                            "translate, rotate or scale)",
                            q, kind);
        }
        /* Steps apply in list order: the first one listed acts first. */
        *out = lr__xform_mul(&x, out);
    }
    return LR_OK;
}

/* Geometry, once transformed, must stay within LR__MAX_NUMBER of the
 * origin like every number of the file: beyond that Embree's float
 * rays stop being valid (an Embree assertion aborts the process). */
lr_status lr__check_extent(double m, const char *p, lr_error *err)
{
    if (!(m <= LR__MAX_NUMBER))
        return lr__fail(err, LR_ERR_INVALID, p,
                        "%s: the object reaches %g from the origin, beyond "
                        "the limit of 1e15",
                        p, m);
    return LR_OK;
}
