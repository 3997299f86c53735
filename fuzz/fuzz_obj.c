/*
 * fuzz_obj.c: the OBJ reader (lr__obj_load), and every mesh it accepts
 * put into a scene and rendered.
 *
 * The input is handed over as a file (an anonymous memfd opened through
 * /proc/self/fd), so the real reading path runs.  Promises checked: a
 * rejected file gets "FILE:LINE: what" with a line that exists; an
 * accepted mesh has triangles, finite vertices, in-range indices and unit
 * normals (when it has normals); the scene built from it (smooth normals
 * computed, so zero-area triangles are exercised) renders 2 x 2 finite
 * pixels looking at the mesh.
 */
#include "fuzz.h"

#include "util/internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

/* The input as a file; returns the fd (the caller closes it) and its
 * path in `path`, or -1. */
static int as_file(const uint8_t *data, size_t size, char *path, size_t cap)
{
    int fd = memfd_create("lensray-fuzz.obj", 0);
    if (fd < 0)
        return -1;
    size_t done = 0;
    while (done < size) {
        ssize_t n = write(fd, data + done, size - done);
        if (n <= 0) {
            close(fd);
            return -1;
        }
        done += (size_t)n;
    }
    snprintf(path, cap, "/proc/self/fd/%d", fd);
    return fd;
}

static size_t count_lines(const uint8_t *data, size_t size)
{
    size_t n = 1;
    for (size_t i = 0; i < size; i++)
        if (data[i] == '\n')
            n++;
    return n;
}

static int check_mesh(const lr__mesh *m)
{
    if (m->n_triangles == 0 || m->indices == NULL || m->vertices == NULL)
        return lr_fuzz_report("obj: accepted a mesh with no triangles");
    for (size_t i = 0; i < 3 * m->n_vertices; i++)
        if (!isfinite(m->vertices[i]))
            return lr_fuzz_report("obj: vertex value %zu is %g", i,
                                  (double)m->vertices[i]);
    for (size_t i = 0; i < 3 * m->n_triangles; i++)
        if (m->indices[i] >= m->n_vertices)
            return lr_fuzz_report("obj: index %u of %zu vertices",
                                  m->indices[i], m->n_vertices);
    if (m->normals != NULL)
        for (size_t c = 0; c < 3 * m->n_triangles; c++) {
            const float *n = &m->normals[3 * c];
            double len = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] +
                              (double)n[2] * n[2]);
            if (!(fabs(len - 1.0) < 1e-3))
                return lr_fuzz_report("obj: corner normal %zu has length "
                                      "%g",
                                      c, len);
        }
    return 0;
}

/* Puts the mesh file into a scene with the camera looking at it, and
 * renders the centre of the frame. */
static int render_mesh(const char *path, const lr__mesh *m)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < m->n_vertices; v++)
        for (int k = 0; k < 3; k++) {
            double x = m->vertices[3 * v + (size_t)k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    double c[3], ext = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * lo[k] + 0.5 * hi[k];
        ext = hi[k] - lo[k] > ext ? hi[k] - lo[k] : ext;
    }
    if (!isfinite(ext))
        ext = 3e38;
    char json[2048];
    snprintf(json, sizeof json,
             "{\"camera\": {\"position\": [%.9g, %.9g, %.9g],"
             "  \"look_at\": [%.9g, %.9g, %.9g], \"up\": [0.1, 1, 0.2]},"
             " \"render\": {\"width\": 4, \"height\": 4, \"spp\": 2,"
             "  \"threads\": 1, \"depth\": true, \"region\": [1, 1, 3, 3]},"
             " \"materials\": {\"g\": {\"diffuse\": 0.5, \"specular\": 0.5,"
             "  \"shininess\": 20, \"transmit\": 0.5, \"reflect\": 0.2}},"
             " \"lights\": [{\"type\": \"point\", \"position\": [1, 2, 3],"
             "  \"intensity\": 10}, {\"type\": \"directional\","
             "  \"direction\": [0.3, -1, -0.2], \"irradiance\": 1},"
             "  {\"type\": \"ambient\", \"radiance\": 0.1}],"
             " \"objects\": [{\"type\": \"mesh\", \"file\": \"%s\","
             "  \"smooth\": true, \"material\": \"g\"}]}",
             c[0] + 0.3 * ext + 1, c[1] + 0.4 * ext + 1, c[2] + 2 * ext + 1,
             c[0], c[1], c[2], path);
    lr_scene *scene = NULL;
    lr_error err;
    lr_status st = lr_scene_load_json(json, strlen(json), NULL, NULL, 0, &scene,
                                      &err);
    if (st != LR_OK) {
        /* The camera itself may be unusable for a mesh at the float
         * limit; anything else must be a clean error. */
        return lr_fuzz_check_error("obj scene", st, &err);
    }
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(scene, &cam);
    lr_scene_settings(scene, &rs);
    lr_image *img = NULL;
    int rc = 0;
    st = lr_render(scene, &cam, &rs, &img, NULL, &err);
    if (st != LR_OK) {
        rc = lr_fuzz_check_error("obj render", st, &err);
    } else {
        const float *rgb = lr_image_rgb(img);
        const float *z = lr_image_depth(img);
        for (int i = 0; rc == 0 && i < 12; i++)
            if (!isfinite(rgb[i]))
                rc = lr_fuzz_report("obj render: pixel value %d is %g", i,
                                    (double)rgb[i]);
        for (int i = 0; rc == 0 && i < 4; i++)
            if (!isfinite(z[i]))
                rc = lr_fuzz_report("obj render: depth %d is %g", i,
                                    (double)z[i]);
        lr_image_free(img);
    }
    lr_scene_free(scene);
    return rc;
}

int lr_fuzz_obj(const uint8_t *data, size_t size)
{
    char path[64];
    int fd = as_file(data, size, path, sizeof path);
    if (fd < 0)
        return 0; /* no memfd: nothing to test */
    lr__mesh m;
    memset(&m, 0x5a, sizeof m);
    lr_error err;
    memset(&err, 0, sizeof err);
    lr_status st = lr__obj_load(path, "objects[0].file", &m, &err);
    int rc = 0;
    if (st != LR_OK) {
        /* The reader's messages start with the file, not the field (the
         * scene loader adds that); the field goes into err.path. */
        if (strcmp(err.path, "objects[0].file") != 0)
            rc = lr_fuzz_report("obj: error path \"%s\", not the field",
                                err.path);
        lr_error plain = err;
        plain.path[0] = '\0';
        if (rc == 0)
            rc = lr_fuzz_check_error("obj", st, &plain);
        if (rc == 0 && (m.vertices != NULL || m.indices != NULL ||
                        m.normals != NULL || m.n_triangles != 0))
            rc = lr_fuzz_report("obj: failed but left a mesh behind");
        /* Parse errors carry "FILE:LINE: " with a line of the file. */
        if (rc == 0 && st != LR_ERR_IO) {
            size_t plen = strlen(path);
            const char *msg = err.message;
            char *end = NULL;
            unsigned long line = 0;
            if (strncmp(msg, path, plen) != 0 || msg[plen] != ':')
                rc = lr_fuzz_report("obj: message lacks \"%s:\": %s", path,
                                    msg);
            else
                line = strtoul(msg + plen + 1, &end, 10);
            if (rc == 0 && (end == NULL || *end != ':' || line < 1 ||
                            line > count_lines(data, size)))
                rc = lr_fuzz_report("obj: no valid line number (file has "
                                    "%zu lines): %s",
                                    count_lines(data, size), msg);
        }
    } else {
        rc = check_mesh(&m);
        if (rc == 0)
            rc = render_mesh(path, &m);
        lr__mesh_free(&m);
    }
    close(fd);
    return rc;
}

LR_FUZZ_MAIN(lr_fuzz_obj)
