/*
 * test.h: shared by the C unit tests (cmocka); the helpers live in
 * helpers.c, the runner in unit_main.c.  Each tests/test_*.c file
 * defines an array of CMUnitTest and registers it with LR_TEST_GROUP; the
 * runner in unit_main.c runs every group (or those named on its command
 * line) and prints a summary line that tests/run.sh adds up.
 *
 * Skips: a test may skip only for a reason outside the code under test
 * (a device the machine lacks, a part the build left out), through
 * lr_test_skip_env with that reason.  A test for a bug never skips: it
 * fails while the bug is there.  cmocka's own skip() is hidden below, so
 * that a skip without a stated reason does not compile.
 */
#ifndef LR_TEST_H
#define LR_TEST_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "lensray.h"
#include "util/internal.h"
#include "optics/prescription.h"

void lr_test_register(const char *name, const struct CMUnitTest *tests,
                      size_t n);

#define LR_TEST_GROUP(name, array)                                        \
    __attribute__((constructor)) static void lr_test_reg_##name(void)     \
    {                                                                     \
        lr_test_register(#name, array, sizeof(array) / sizeof(array[0])); \
    }

/* Writes a W x H grey map of value(x, y) as the EXR file NAME in
 * lr_test_tmpdir() (environment maps). */
void lr_test_write_map(const char *name, double (*value)(int x, int y), int W,
                       int H);

/* Loads a scene from JSON text with `sets` overrides (relative files from
 * lr_test_tmpdir()), renders it with its own camera and settings, and
 * returns the image (failing the test on any error); stats may be
 * NULL. */
lr_image *lr_test_render(const char *json, const char *const *sets,
                         size_t n_sets, lr_render_stats *stats);

/* The planner's guarantee renders of `scene`: out[0] the full
 * simulation (render.plan and render.adaptive off) at ref_spp with seed
 * 77, the reference; out[1] the full simulation and out[2] the plan
 * alone (adaptive off) at spp, with their stats. */
void lr_test_plan_renders(const char *scene, int ref_spp, int spp,
                          lr_image **out, lr_render_stats *sf,
                          lr_render_stats *sp);

/* Root-mean-square difference of two images of the same size. */
double lr_test_rmse(const lr_image *a, const lr_image *b);

/* Directory for scratch files of this test run (created on first use). */
const char *lr_test_tmpdir(void);

/* A flat lens surface followed by `t` mm of index n (1: air), with
 * semi-aperture `semi`: the plates of test_ghost.c and test_transmit.c. */
lr__surface lr_test_flat(double t, double n, double semi);

/* The full frame's plan (plan.h) of a scene loaded as lr_test_load
 * does, with its own camera and settings: *c gets the prepared camera,
 * *p the plan (the caller frees it with lr__plan_free, then the scene
 * returned), *rs the settings if not NULL; fails the test if planning
 * fails. */
struct lr__cam;
struct lr__plan;
lr_scene *lr_test_plan(const char *json, const char *const *sets, size_t n_sets,
                       struct lr__cam *c, struct lr__plan *p,
                       lr_render_settings *rs);

/* Loads a scene from JSON text with `sets` overrides, relative files
 * from lr_test_tmpdir(); fails the test if it does not load.  The caller
 * frees the scene. */
lr_scene *lr_test_load(const char *json, const char *const *sets,
                       size_t n_sets);
lr_scene *lr_test_load_json(const char *json);

/* Fails the test unless every value of img (depth too) is finite and, when
 * st is given, no sample was dropped as NaN or Inf. */
void lr_test_check_finite(const lr_image *img, const lr_render_stats *st,
                          const char *what);

/* Renders and checks with lr_test_check_finite; `what` names the case in
 * a failure.  _sets and _json load the scene first (lr_test_load) and
 * render it with its own camera and settings.  The caller frees the
 * image. */
lr_image *lr_test_render_with(const lr_scene *s, const lr_camera *cam,
                              const lr_render_settings *rs, const char *what);
lr_image *lr_test_render_sets(const char *json, const char *const *sets,
                              size_t n_sets, const char *what);
lr_image *lr_test_render_json(const char *json, const char *what);

/* Number of colour values (3 per pixel) of img. */
size_t lr_test_n_values(const lr_image *img);

/* Embree configurations for a test of packets on every ISA: the
 * default (the best the CPU has), SSE4.2 (every x86-64 CPU Embree 3 runs
 * on) and, where the CPU has it, AVX2 (Embree refuses an ISA the CPU
 * lacks).  Their number in *n; NULL names the default. */
const char *const *lr_test_embree_isas(int *n);
/* The mean of img's colour values; fails the test (naming `what`) at a
 * value that is not finite. */
double lr_test_finite_mean(const lr_image *img, const char *what);
/* Fails unless mean[0] > 0.01 (lit) and each other mean[k] is within
 * 1% of it (Embree's code for each ISA may round differently). */
void lr_test_isa_means_agree(const double *mean, const char *const *isa, int n);

/* Fails unless a and b have the same size and the same bytes. */
void lr_test_assert_same_bytes(const lr_image *a, const lr_image *b,
                               const char *what);

/* Fails unless every pixel of crop (a render.region from (x0, y0)) has
 * the bytes of the full frame's pixel there. */
void lr_test_assert_region_is_frame(const lr_image *full, const lr_image *crop,
                                    int x0, int y0, const char *what);

/* How far apart two images of the same size are. */
typedef struct lr_test_diff {
    double mean_rel; /* mean |a - b| / mean |a| */
    double bad_frac; /* fraction of pixels off by more than 5% + 0.02 */
    double max_abs;
} lr_test_diff;
lr_test_diff lr_test_compare(const lr_image *a, const lr_image *b);

/* 1 in a build with AddressSanitizer (make test-sanitize, -O1), else 0.
 * A test whose cost is a sweep over data (every shipped lens in every
 * set-up) sweeps a representative part there, each kind of lens and
 * every set-up, and the whole in the build as made: the sanitizers
 * watch code paths, which the part covers, and under them those sweeps
 * were 8 of the suite's 13 minutes (the critical path of make test). */
/* (GCC defines __SANITIZE_ADDRESS__; clang answers __has_feature.) */
#if defined(__SANITIZE_ADDRESS__)
#define LR_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LR_TEST_SANITIZED 1
#endif
#endif
#ifndef LR_TEST_SANITIZED
#define LR_TEST_SANITIZED 0
#endif

/* A small lit scene: a red, a mirror and a glass sphere on a floor under
 * a point, a directional and an ambient light; `cam` and `render` are
 * JSON members spliced in.  LR_TEST_CAM_BASE is a camera that sees it. */
void lr_test_busy_scene(char *out, size_t cap, const char *cam,
                        const char *render);
#define LR_TEST_CAM_BASE "\"position\": [0, 1.5, 7], \"look_at\": [0, 0.8, 0]"

/* Fails unless loading the text fails with LR_ERR_INVALID or
 * LR_ERR_LIMIT, no scene, and a valid UTF-8 message that names the
 * error's path, which starts with `path` (when not NULL). */
void lr_test_expect_invalid(const char *json, size_t len, const char *path,
                            const char *what);

/* Writes len bytes to NAME in lr_test_tmpdir() and its path to `path`. */
void lr_test_write_file(const char *name, const void *data, size_t len,
                        char *path, size_t cap);
void lr_test_write_text(const char *name, const char *text, char *path,
                        size_t cap);
/* Writes a w x h EXR (the library's encoder: float R, G, B, stored
 * exactly) whose pixel (x, y), row 0 at the top, is f(x, y), into the
 * scratch directory under `name`; its path goes into `path`. */
void lr_test_write_exr(const char *name, int w, int h,
                       void (*f)(int x, int y, float rgb[3]), char *path,
                       size_t cap);

/* Every field of the scene format: a JSON template with %s where the
 * value goes (lr_test_field_json fills it in), the path of that value,
 * and the JSON types it accepts. */
enum {
    LR_TEST_NUM = 1,
    LR_TEST_STR = 2,
    LR_TEST_BOOL = 4,
    LR_TEST_NULL = 8,
    LR_TEST_ARR = 16,
    LR_TEST_OBJ = 32
};
typedef struct lr_test_field {
    const char *tmpl;
    const char *path;
    int accepts;
} lr_test_field;
extern const lr_test_field lr_test_fields[];
extern const size_t lr_test_n_fields;
void lr_test_field_json(size_t i, const char *value, char *out, size_t cap);

/* Ends the current test as skipped because of its environment: prints
 * "SKIP (environment): REASON" and counts the skip in unit_main.c's
 * summary line, where a skip is never counted as a pass.  Does not
 * return. */
void lr_test_skip_env_at(const char *reason, const char *file, int line);
#define lr_test_skip_env(reason) \
    lr_test_skip_env_at((reason), __FILE__, __LINE__)

#undef skip
#define skip()                                                            \
    _Static_assert(0, "use lr_test_skip_env(\"reason\") for a skip that " \
                      "the environment forces; a bug's test fails instead")

#endif
