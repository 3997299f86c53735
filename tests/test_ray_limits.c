/*
 * test_ray_limits.c: numbers at the edge of what Embree can trace.  Embree
 * aborts the process on a ray it finds invalid (a component beyond about
 * 1.8e18, or not finite), so the library must refuse such input or keep
 * such rays from it: 1e308 and its neighbours (and the smallest numbers) in
 * every numeric field for every camera model, a camera or lens far beyond
 * the JSON limit through the C API, a camera 1e15 up grazing an infinite
 * plane, and geometry that a transform carries beyond 1e15.  Renders that
 * could abort run in a child process (render_in_child), so that a crash
 * fails the test instead of ending the runner.  Each test guards a fixed
 * bug ("Fixed bug, guarded here") and fails if it comes back.
 */
#include "test.h"

#include <fcntl.h>
#include <math.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

/* Camera edits a child can apply (JSON cannot express these values
 * since numbers are limited to 1e15). */
static void cam_far(lr_camera *c)
{
    c->position[0] = 1e19;
}

static void cam_far_lens(lr_camera *c)
{
    c->model = LR_CAMERA_THINLENS;
    c->aperture_radius = 1e19;
}

static void (*const cam_fns[])(lr_camera *) = {NULL, cam_far, cam_far_lens};

/* The child's side of render_in_child: load, edit the camera, render a
 * 3 x 2 crop of the frame's centre, check it, and exit with the verdict
 * (0 fine or a clean error naming a field, 3 non-finite pixels, 4 an
 * error that names no field). */
static int child_render(const char *json, const char *const *sets,
                        size_t n_sets, const char *base_dir, int cam_fn)
{
    lr_scene *s = NULL;
    lr_error err;
    memset(&err, 0, sizeof err);
    if (lr_scene_load_json(json, strlen(json), base_dir, sets, n_sets, &s,
                           &err) != LR_OK)
        return err.path[0] && strstr(err.message, err.path) ? 0 : 4;
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    if (cam_fn > 0)
        cam_fns[cam_fn](&cam);
    int cx = rs.width / 2, cy = rs.height / 2;
    rs.region[0] = cx;
    rs.region[1] = cy;
    rs.region[2] = cx + 3 < rs.width ? cx + 3 : rs.width;
    rs.region[3] = cy + 2 < rs.height ? cy + 2 : rs.height;
    rs.spp = 2;
    rs.threads = 1;
    lr_image *img = NULL;
    if (lr_render(s, &cam, &rs, &img, NULL, &err) != LR_OK)
        return err.path[0] && strstr(err.message, err.path) ? 0 : 4;
    const float *p = lr_image_rgb(img);
    for (size_t k = 0; k < lr_test_n_values(img); k++)
        if (!isfinite(p[k]))
            return 3;
    return 0;
}

/* The unit binary re-executed as a child: LENSRAY_RAY_LIMITS_CHILD names a
 * file of "CAMFN\nBASEDIR\nNSETS\nSET...\nJSON".  Runs before main, in a
 * fresh process (a fork of the multi-threaded runner could inherit
 * locks held by Embree's or TBB's threads and hang). */
__attribute__((constructor)) static void ray_limits_child(void)
{
    const char *file = getenv("LENSRAY_RAY_LIMITS_CHILD");
    if (file == NULL || *file == '\0')
        return;
    FILE *f = fopen(file, "rb");
    if (f == NULL)
        _exit(90);
    static char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    char *line[16];
    char *p = buf;
    for (int k = 0; k < 3; k++) {
        line[k] = p;
        p = strchr(p, '\n');
        if (p == NULL)
            _exit(91);
        *p++ = '\0';
    }
    int cam_fn = (int)strtol(line[0], NULL, 10);
    size_t n_sets = (size_t)strtoul(line[2], NULL, 10);
    const char *sets[8];
    for (size_t k = 0; k < n_sets && k < 8; k++) {
        sets[k] = p;
        p = strchr(p, '\n');
        if (p == NULL)
            _exit(92);
        *p++ = '\0';
    }
    _exit(child_render(p, sets, n_sets, line[1], cam_fn));
}

/* Loads and renders in a child process, so that an abort inside Embree
 * (which asserts on rays it considers invalid) cannot take the test
 * runner down.  `cam_fn` indexes cam_fns.  Returns the child's verdict
 * (see child_render), or 100 + the signal number when it died. */
static int render_in_child(const char *json, const char *const *sets,
                           size_t n_sets, int cam_fn)
{
    char file[512];
    snprintf(file, sizeof file, "%s/child-render.txt", lr_test_tmpdir());
    FILE *f = fopen(file, "wb");
    assert_non_null(f);
    fprintf(f, "%d\n%s\n%zu\n", cam_fn, lr_test_tmpdir(), n_sets);
    for (size_t k = 0; k < n_sets; k++)
        fprintf(f, "%s\n", sets[k]);
    fputs(json, f);
    assert_int_equal(fclose(f), 0);
    char env_child[600];
    snprintf(env_child, sizeof env_child, "LENSRAY_RAY_LIMITS_CHILD=%s", file);
    /* The child's environment: ours, plus the request; quiet, since
     * Embree prints its assertion and ASan its report. */
    extern char **environ;
    size_t n_env = 0;
    while (environ[n_env] != NULL)
        n_env++;
    char **env = calloc(n_env + 2, sizeof *env);
    assert_non_null(env);
    for (size_t k = 0; k < n_env; k++)
        env[k] = environ[k];
    env[n_env] = env_child;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    char exe[] = "/proc/self/exe";
    char *argv[] = {exe, NULL};
    pid_t pid;
    int rc = posix_spawn(&pid, exe, &fa, NULL, argv, env);
    posix_spawn_file_actions_destroy(&fa);
    free(env);
    assert_int_equal(rc, 0);
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    if (WIFSIGNALED(status))
        return 100 + WTERMSIG(status);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 99;
}

/* 1e308 and its neighbours (and the smallest numbers, for the fields
 * that divide by them) in every numeric field, for every camera model:
 * either a clean error naming the field, or a scene that renders to
 * finite pixels.  JSON numbers beyond 1e15 are refused since this test
 * was written (json_util.c); small positive ones are not, and some of
 * those crash the renderer.
 *
 * Fixed bug, guarded here: a ray whose origin or direction Embree finds
 * invalid (a component beyond about 1.8e18, or not finite) makes Embree
 * abort the process in an assertion (bvh_intersector*.cpp: ray.valid()),
 * because lib/accel/trace.c (lr__trace, lr__occluded) and lib/integrator/whitted.c hand
 * rays to Embree unchecked and lib/camera/camera.c accepts lenses that produce
 * them: camera.focus_distance 1e-308 (thin lens: the direction
 * d - off cos w overflows), camera.f_number 4e-324 (radius
 * f / (2 N) is infinite), camera.focal_length 1e-308 (bracket).  Each
 * crashing case is printed and the test then fails. */
static void test_huge_numbers_everywhere(void **state)
{
    (void)state;
    static const char *const huge[] = {
        "1e308",  "-1e308",  "1.7976931348623157e308",
        "4e-324", "-4e-324", "1e-308",
        "1e15",   "-1e15",   "1e16"};
    static const char *const scene_objs =
        "objects=[{\"type\": \"sphere\", \"center\": [0, 0, -5], \"radius\": "
        "1},"
        " {\"type\": \"plane\", \"point\": [0, -1, 0], \"normal\": [0, 1, 0]}]";
    static const char *const scene_lights =
        "lights=[{\"type\": \"point\", \"position\": [1, 3, 0], \"intensity\": "
        "5}]";
    size_t tried = 0, accepted = 0, crashed = 0;
    for (size_t i = 0; i < lr_test_n_fields; i++) {
        if (!(lr_test_fields[i].accepts & LR_TEST_NUM))
            continue;
        int is_cam = strncmp(lr_test_fields[i].path, "camera.", 7) == 0;
        for (int model = 0; model < (is_cam ? 3 : 1); model++)
            for (size_t k = 0; k < sizeof huge / sizeof huge[0]; k++) {
                char json[1024], what[256];
                lr_test_field_json(i, huge[k], json, sizeof json);
                const char *sets[6];
                size_t n = 0;
                if (strstr(json, "\"objects\"") == NULL)
                    sets[n++] = scene_objs;
                if (strstr(json, "\"lights\"") == NULL)
                    sets[n++] = scene_lights;
                if (model == 1) {
                    sets[n++] = "camera.model=thinlens";
                    if (!strstr(lr_test_fields[i].path, "aperture_radius") &&
                        !strstr(lr_test_fields[i].path, "f_number"))
                        sets[n++] = "camera.aperture_radius=0.1";
                } else if (model == 2) {
                    sets[n++] = "camera.model=bracket";
                    if (strcmp(lr_test_fields[i].path, "camera.aperture") != 0)
                        sets[n++] = "camera.aperture=0.1";
                }
                snprintf(what, sizeof what, "%s = %s (%s)",
                         lr_test_fields[i].path, huge[k],
                         model == 0   ? "pinhole"
                         : model == 1 ? "thinlens"
                                      : "bracket");
                tried++;
                lr_scene *s = NULL;
                lr_error err;
                memset(&err, 0, sizeof err);
                lr_status st = lr_scene_load_json(
                    json, strlen(json), lr_test_tmpdir(), sets, n, &s, &err);
                if (st != LR_OK) {
                    /* Values above 1e15 must be refused, naming the field
                     * (or, for f_number, the focal length it needs). */
                    if (strncmp(err.path, lr_test_fields[i].path,
                                strlen(lr_test_fields[i].path)) != 0 &&
                        strcmp(lr_test_fields[i].path, "camera.f_number") != 0)
                        fail_msg("%s: error names \"%s\": %s", what, err.path,
                                 err.message);
                    if (strstr(err.message, err.path) == NULL)
                        fail_msg("%s: message \"%s\" does not name \"%s\"",
                                 what, err.message, err.path);
                    continue;
                }
                lr_scene_free(s);
                if (huge[k][0] != '-' && atof(huge[k]) > 1e15)
                    fail_msg("%s: a number beyond 1e15 was accepted", what);
                accepted++;
                int rc = render_in_child(json, sets, n, 0);
                if (rc >= 100) {
                    print_message("CRASH (signal %d): %s\n", rc - 100, what);
                    crashed++;
                } else if (rc != 0) {
                    fail_msg("%s: render %s", what,
                             rc == 3 ? "gave non-finite pixels"
                                     : "failed without naming a field");
                }
            }
    }
    print_message("huge numbers: %zu cases, %zu accepted, %zu crashed\n", tried,
                  accepted, crashed);
    if (crashed)
        fail_msg("huge numbers: %zu of %zu accepted cases crashed the "
                 "renderer (listed above)",
                 crashed, accepted);
}

/* Through the C API, where the JSON limit does not apply, a camera far
 * out or with a huge lens makes rays Embree rejects.
 *
 * Fixed bug, guarded here: Embree aborts the process (assertion
 * ray.valid() in bvh_intersector_hybrid.cpp) instead of lr_camera_validate
 * (lib/camera/camera.c) refusing the camera or lr__trace (lib/scene/scene.c) treating
 * the ray as a miss. */
static void test_embree_invalid_rays(void **state)
{
    (void)state;
    const char *json = "{\"render\": {\"width\": 4, \"height\": 4},"
                       " \"objects\": [{\"type\": \"sphere\","
                       " \"center\": [0, 0, -5], \"radius\": 1}]}";
    int a = render_in_child(json, NULL, 0, 1);
    int b = render_in_child(json, NULL, 0, 2);
    if (a >= 100 || b >= 100)
        fail_msg("camera.position [1e19, 0, 0]: %s; thin lens radius "
                 "1e19: %s",
                 a >= 100 ? "crash" : "ok", b >= 100 ? "crash" : "ok");
    assert_int_equal(a, 0);
    assert_int_equal(b, 0);
}

/* Fixed bug, guarded here: a camera 1e15 up (within the limits) looking
 * just below the horizon meets an infinite plane about 1e19 away; the
 * shadow rays (16-wide packets and single rays) and the mirror rays from
 * there had coordinates Embree asserts on, and the process aborted
 * (bvh_intersector_hybrid.cpp and bvh_intersector1.cpp: ray.valid()).
 * Every path: packets with lights, the scalar shading of a mirror
 * without lights, the scalar camera path of rgb chromatic aberration
 * through a thin lens, and the depth channel. */
static void test_grazing_plane_far_away(void **state)
{
    (void)state;
    const char *json =
        "{\"camera\": {\"position\": [0, 1e15, 0], \"look_at\": [0, "
        "999900000000000, -1e15], \"fov\": 0.001, \"focal_length_mm\": 50},"
        " \"render\": {\"width\": 6, \"height\": 4, \"max_depth\": 3},"
        " \"materials\": {\"m\": {\"diffuse\": 0.5, \"reflect\": 0.5}},"
        " \"lights\": [{\"type\": \"point\", \"position\": [0, 10, 0],"
        " \"intensity\": 5}, {\"type\": \"directional\", \"direction\":"
        " [0, -1, -1], \"irradiance\": 1}],"
        " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 0],"
        " \"normal\": [0, 1, 0], \"material\": \"m\"}, {\"type\":"
        " \"sphere\", \"center\": [0, 0, -5], \"radius\": 1}]}";
    static const char *const variants[][3] = {
        {NULL},
        {"lights=[]"},
        {"camera.model=thinlens", "camera.aperture_radius=0.1",
         "camera.chromatic.mode=rgb"},
        {"render.depth=true"},
    };
    for (size_t v = 0; v < sizeof variants / sizeof variants[0]; v++) {
        size_t n = 0;
        while (n < 3 && variants[v][n] != NULL)
            n++;
        int rc = render_in_child(json, variants[v], n, 0);
        if (rc != 0)
            fail_msg("variant %zu (%s): %s %d", v, n ? variants[v][0] : "as is",
                     rc >= 100 ? "died on signal" : "render verdict",
                     rc >= 100 ? rc - 100 : rc);
    }
}

/* Geometry that ends up beyond 1e15 from the origin once transformed
 * (each number within the limit) is refused too, naming the transform or
 * the mesh file: Embree cannot trace rays from such hit points. */
static void test_geometry_beyond_limit(void **state)
{
    (void)state;
    char path[512];
    const char *far = "v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n";
    lr_test_write_text("far.obj", far, path, sizeof path);
    const char *near = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    lr_test_write_text("near.obj", near, path, sizeof path);
    static const struct {
        const char *json, *path;
    } cases[] = {
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [1e15, 0, 0], "
         "\"radius\": 1}]}",
         "objects[0].radius"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], "
         "\"radius\": 1e10, \"transform\": [{\"scale\": 1e10}]}]}",
         "objects[0].transform"},
        {"{\"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], "
         "\"radius\": 1, \"transform\": [{\"translate\": [1e15, 0, 0]}, "
         "{\"translate\": [1e15, 0, 0]}]}]}",
         "objects[0].transform"},
        {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0], "
         "\"point\": [0, 1e8, 0], \"transform\": [{\"scale\": 1e8}]}]}",
         "objects[0].transform"},
        {"{\"objects\": [{\"type\": \"plane\", \"normal\": [0, 1, 0], "
         "\"size\": 1e15, \"point\": [1e15, 0, 0]}]}",
         "objects[0].size"},
        {"{\"objects\": [{\"type\": \"triangle\", \"vertices\": [[0,0,0], "
         "[1e9,0,0], [0,1,0]], \"transform\": [{\"scale\": [1e9, 1, 1]}]}]}",
         "objects[0].transform"},
        {"{\"objects\": [{\"type\": \"mesh\", \"file\": \"far.obj\"}]}",
         "objects[0].file"},
        {"{\"objects\": [{\"type\": \"mesh\", \"file\": \"near.obj\", "
         "\"transform\": [{\"scale\": 1e15}, {\"scale\": 10}]}]}",
         "objects[0].file"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        lr_test_expect_invalid(cases[i].json, strlen(cases[i].json),
                               cases[i].path, cases[i].json);
    /* Right at the limit is fine. */
    lr_scene_free(
        lr_test_load_json("{\"objects\": [{\"type\": \"sphere\","
                          " \"center\": [0, 0, 0], \"radius\": 1e15},"
                          " {\"type\": \"mesh\", \"file\": \"near.obj\","
                          " \"transform\": [{\"scale\": 1e15}]}]}"));
}

static const struct CMUnitTest ray_limits_tests[] = {
    cmocka_unit_test(test_huge_numbers_everywhere),
    cmocka_unit_test(test_embree_invalid_rays),
    cmocka_unit_test(test_grazing_plane_far_away),
    cmocka_unit_test(test_geometry_beyond_limit),
};

LR_TEST_GROUP(ray_limits, ray_limits_tests)
