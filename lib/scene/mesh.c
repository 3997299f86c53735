/*
 * mesh.c: triangle geometry the scene loader builds beyond what the JSON
 * spells out: an OBJ file's mesh placed in the scene (transformed, its
 * normals kept, dropped or computed, its winding kept outward under a
 * mirroring transform), and a finite plane tessellated as a rectangle of
 * two triangles.
 */
#include "scene/mesh.h"
#include "json/json_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Area-weighted vertex normals, expanded to corners. */
static float *smooth_normals(const lr__mesh *m)
{
    double *acc = calloc(m->n_vertices * 3, sizeof *acc);
    float *out = malloc(m->n_triangles * 9 * sizeof *out);
    if (acc == NULL || out == NULL) {
        free(acc);
        free(out);
        return NULL;
    }
    for (size_t t = 0; t < m->n_triangles; t++) {
        const unsigned *ix = &m->indices[3 * t];
        lr__v3 a = v3(m->vertices[3 * ix[0]], m->vertices[3 * ix[0] + 1],
                      m->vertices[3 * ix[0] + 2]);
        lr__v3 b = v3(m->vertices[3 * ix[1]], m->vertices[3 * ix[1] + 1],
                      m->vertices[3 * ix[1] + 2]);
        lr__v3 c = v3(m->vertices[3 * ix[2]], m->vertices[3 * ix[2] + 1],
                      m->vertices[3 * ix[2] + 2]);
        /* The cross product's length is twice the area: the weight. */
        lr__v3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
        for (int k = 0; k < 3; k++) {
            acc[3 * ix[k]] += n.x;
            acc[3 * ix[k] + 1] += n.y;
            acc[3 * ix[k] + 2] += n.z;
        }
    }
    for (size_t t = 0; t < m->n_triangles; t++)
        for (int k = 0; k < 3; k++) {
            unsigned v = m->indices[3 * t + k];
            lr__v3 n = v3_norm(v3(acc[3 * v], acc[3 * v + 1], acc[3 * v + 2]));
            out[9 * t + 3 * k] = (float)n.x;
            out[9 * t + 3 * k + 1] = (float)n.y;
            out[9 * t + 3 * k + 2] = (float)n.z;
        }
    free(acc);
    return out;
}

/* "st", "nd", "rd" or "th" after n. */
static const char *ordinal(size_t n)
{
    if (n % 100 >= 11 && n % 100 <= 13)
        return "th";
    return n % 10 == 1 ? "st" : n % 10 == 2 ? "nd" : n % 10 == 3 ? "rd" : "th";
}

lr_status lr__scene_add_obj(lr_scene *s, const char *file, const char *shown,
                            const char *fp, int smooth, const lr__xform *x,
                            int material, lr_error *err)
{
    lr__mesh m;
    memset(&m, 0, sizeof m);
    lr_status st = lr__obj_load_named(file, shown, fp, &m, err);
    if (st != LR_OK) {
        lr__fail_under(err, fp);
        return st;
    }
    /* Each reference of the file places its triangles again: over the
     * scene's limit, stop before the copies (lr__scene_add_triangles
     * checks as well). */
    st = lr__scene_limit_triangles(s, m.n_triangles, fp, err);
    if (st != LR_OK) {
        lr__mesh_free(&m);
        return st;
    }
    /* What the file says and the mesh does not use, said (silently the
     * object rendered in one material, or flat). */
    if (m.usemtl_lines > 0)
        lr__scene_warn(s,
                       "%s: %s: its %zu usemtl line%s ignored: the object's "
                       "material is used for the whole mesh",
                       fp, shown, m.usemtl_lines,
                       m.usemtl_lines == 1 ? " is" : "s are");
    if (m.normals_lost_line > 0)
        lr__scene_warn(s,
                       "%s: %s:%zu: a face without normals (v or v/vt "
                       "corners): the file's normals are not used (smooth: "
                       "true computes them)",
                       fp, shown, m.normals_lost_line);
    if (m.uvs_lost_line > 0)
        lr__scene_warn(s,
                       "%s: %s:%zu: a face without texture coordinates: the "
                       "file's texture coordinates are not used",
                       fp, shown, m.uvs_lost_line);
    /* File normals are used unless smooth is false (flat shading); when
     * the file has none, smooth: true computes them. */
    float *normals = NULL;
    if (smooth != 0 && m.normals != NULL) {
        normals = m.normals;
        m.normals = NULL;
    } else if (smooth == 1) {
        normals = smooth_normals(&m);
        if (normals == NULL) {
            lr__mesh_free(&m);
            return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
        }
    }
    for (size_t v = 0; v < m.n_vertices; v++) {
        lr__v3 q = lr__xform_point(x,
                                   v3(m.vertices[3 * v], m.vertices[3 * v + 1],
                                      m.vertices[3 * v + 2]));
        if (!(v3_maxabs(q) <= LR__MAX_NUMBER)) {
            free(normals);
            lr__mesh_free(&m);
            return lr__fail(err, LR_ERR_INVALID, fp,
                            "%s: %s: vertex %zu (the %zu%s \"v\" line) "
                            "reaches %g from the origin (after the "
                            "transform), beyond the limit of 1e15",
                            fp, shown, v + 1, v + 1, ordinal(v + 1),
                            v3_maxabs(q));
        }
        m.vertices[3 * v] = (float)q.x;
        m.vertices[3 * v + 1] = (float)q.y;
        m.vertices[3 * v + 2] = (float)q.z;
    }
    if (normals != NULL)
        for (size_t c = 0; c < 3 * m.n_triangles; c++) {
            lr__v3 n = lr__xform_normal(
                x, v3(normals[3 * c], normals[3 * c + 1], normals[3 * c + 2]));
            normals[3 * c] = (float)n.x;
            normals[3 * c + 1] = (float)n.y;
            normals[3 * c + 2] = (float)n.z;
        }
    /* A mirroring transform (negative determinant) turns CCW into CW, so
     * swap two corners to keep the front side outside. */
    if (lr__xform_det(x) < 0)
        for (size_t t = 0; t < m.n_triangles; t++) {
            unsigned tmp = m.indices[3 * t + 1];
            m.indices[3 * t + 1] = m.indices[3 * t + 2];
            m.indices[3 * t + 2] = tmp;
            if (normals != NULL)
                for (int k = 0; k < 3; k++) {
                    float f = normals[9 * t + 3 + k];
                    normals[9 * t + 3 + k] = normals[9 * t + 6 + k];
                    normals[9 * t + 6 + k] = f;
                }
            if (m.uvs != NULL)
                for (int k = 0; k < 2; k++) {
                    float f = m.uvs[6 * t + 2 + k];
                    m.uvs[6 * t + 2 + k] = m.uvs[6 * t + 4 + k];
                    m.uvs[6 * t + 4 + k] = f;
                }
        }
    st = lr__scene_add_triangles(s, m.vertices, m.n_vertices, m.indices,
                                 m.n_triangles, normals, material, fp, err);
    if (st == LR_OK) {
        s->geoms[s->n_geoms - 1].corner_uv = m.uvs;
        m.uvs = NULL;
    }
    lr__mesh_free(&m);
    return st;
}

lr_status lr__scene_add_rect(lr_scene *s, lr__v3 pt, lr__v3 n, double w,
                             double h, const lr__xform *x, int material,
                             const char *blame, lr_error *err)
{
    lr__v3 ax = fabs(n.x) > 0.9 ? v3(0, 0, 1) : v3(1, 0, 0);
    lr__v3 u = v3_norm(v3_madd(ax, n, -v3_dot(ax, n)));
    lr__v3 v = v3_cross(n, u);
    lr__v3 corner[4] = {v3_madd(v3_madd(pt, u, -w / 2), v, -h / 2),
                        v3_madd(v3_madd(pt, u, w / 2), v, -h / 2),
                        v3_madd(v3_madd(pt, u, w / 2), v, h / 2),
                        v3_madd(v3_madd(pt, u, -w / 2), v, h / 2)};
    float verts[12];
    for (int i = 0; i < 4; i++) {
        lr__v3 c = lr__xform_point(x, corner[i]);
        LR_TRY(lr__check_extent(v3_maxabs(c), blame, err));
        verts[3 * i] = (float)c.x;
        verts[3 * i + 1] = (float)c.y;
        verts[3 * i + 2] = (float)c.z;
    }
    unsigned idx[6] = {0, 1, 2, 0, 2, 3};
    if (lr__xform_det(x) < 0) {
        idx[1] = 2, idx[2] = 1, idx[4] = 3, idx[5] = 2;
    }
    /* Texture coordinates: (0, 0) at the first corner, u along the first
     * side, v along the second, (1, 1) at the opposite corner; turned
     * half round (u and v both from the far side) where v points down,
     * so that an image stands upright on a wall seen from the front (on
     * walls facing +x and -z it stood on its head).  The corners stay
     * where they were. */
    static const float corner_uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    int turn = v.y < -1e-9;
    float *uv = malloc(12 * sizeof *uv);
    if (uv == NULL)
        return lr__fail(err, LR_ERR_NOMEM, NULL, "out of memory");
    for (int k = 0; k < 6; k++) {
        uv[2 * k] = turn ? 1.0f - corner_uv[idx[k]][0] : corner_uv[idx[k]][0];
        uv[2 * k + 1] = turn ? 1.0f - corner_uv[idx[k]][1]
                             : corner_uv[idx[k]][1];
    }
    lr_status st = lr__scene_add_triangles(s, verts, 4, idx, 2, NULL, material,
                                           blame, err);
    if (st != LR_OK) {
        free(uv);
        return st;
    }
    s->geoms[s->n_geoms - 1].corner_uv = uv;
    return LR_OK;
}
