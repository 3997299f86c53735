/*
 * test.h: shared by the C unit tests (cmocka).  Each tests/test_*.c file
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
#include "internal.h"

void lr_test_register(const char *name, const struct CMUnitTest *tests,
                      size_t n);

#define LR_TEST_GROUP(name, array)                                         \
    __attribute__((constructor)) static void lr_test_reg_##name(void)      \
    {                                                                      \
        lr_test_register(#name, array, sizeof(array) / sizeof(array[0]));  \
    }

/* Loads a scene from JSON text with `sets` overrides, renders it with its
 * own camera and settings, and returns the image (failing the test on
 * any error); stats may be NULL. */
lr_image *lr_test_render(const char *json, const char *const *sets,
                         size_t n_sets, lr_render_stats *stats);

/* Root-mean-square difference of two images of the same size. */
double lr_test_rmse(const lr_image *a, const lr_image *b);

/* Directory for scratch files of this test run (created on first use). */
const char *lr_test_tmpdir(void);

/* Ends the current test as skipped because of its environment: prints
 * "SKIP (environment): REASON" and counts the skip in unit_main.c's
 * summary line, where a skip is never counted as a pass.  Does not
 * return. */
void lr_test_skip_env_at(const char *reason, const char *file, int line);
#define lr_test_skip_env(reason)                                           \
    lr_test_skip_env_at((reason), __FILE__, __LINE__)

#undef skip
#define skip()                                                             \
    _Static_assert(0, "use lr_test_skip_env(\"reason\") for a skip that "   \
                      "the environment forces; a bug's test fails instead")

#endif
