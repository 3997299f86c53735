/*
 * unit_main.c: runs every registered cmocka group, or only the groups
 * named on the command line, and ends with
 * "unit: N passed, N failed, N skipped".  A skipped test is counted as
 * skipped, never as passed; every skip here is an environment skip
 * (lr_test_skip_env in test.h), each printed with its reason.
 */
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_GROUPS 64

static struct {
    const char *name;
    const struct CMUnitTest *tests;
    size_t n;
} groups[MAX_GROUPS];
static size_t n_groups;

/* Skips so far; cmocka's runner returns only the failures. */
static size_t n_skipped;

void lr_test_register(const char *name, const struct CMUnitTest *tests,
                      size_t n)
{
    if (n_groups == MAX_GROUPS) {
        fprintf(stderr, "unit: too many test groups\n");
        exit(2);
    }
    groups[n_groups].name = name;
    groups[n_groups].tests = tests;
    groups[n_groups].n = n;
    n_groups++;
}

const char *lr_test_tmpdir(void)
{
    static char dir[256];
    if (dir[0] == '\0') {
        const char *base = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/lensray-unit-XXXXXX",
                 base && *base ? base : "/tmp");
        if (mkdtemp(dir) == NULL) {
            perror("mkdtemp");
            exit(2);
        }
    }
    return dir;
}

lr_image *lr_test_render(const char *json, const char *const *sets,
                         size_t n_sets, lr_render_stats *stats)
{
    lr_scene *s = NULL;
    lr_error err;
    if (lr_scene_load_json(json, strlen(json), NULL, sets, n_sets, &s, &err) !=
        LR_OK)
        fail_msg("scene: %s", err.message);
    lr_camera cam;
    lr_render_settings rs;
    lr_scene_camera(s, &cam);
    lr_scene_settings(s, &rs);
    lr_image *img = NULL;
    if (lr_render(s, &cam, &rs, &img, stats, &err) != LR_OK)
        fail_msg("render: %s", err.message);
    lr_scene_free(s);
    return img;
}

double lr_test_rmse(const lr_image *a, const lr_image *b)
{
    int n = lr_image_width(a) * lr_image_height(a) * 3;
    double e = 0;
    for (int i = 0; i < n; i++) {
        double d = lr_image_rgb(a)[i] - lr_image_rgb(b)[i];
        e += d * d;
    }
    return sqrt(e / n);
}

void lr_test_skip_env_at(const char *reason, const char *file, int line)
{
    print_message("SKIP (environment): %s\n", reason);
    n_skipped++;
    _skip(file, line);
}

static int wanted(const char *name, int argc, char **argv)
{
    if (argc < 2)
        return 1;
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], name) == 0)
            return 1;
    return 0;
}

int main(int argc, char **argv)
{
    size_t total = 0, failed = 0;
    for (size_t g = 0; g < n_groups; g++) {
        if (!wanted(groups[g].name, argc, argv))
            continue;
        int f = _cmocka_run_group_tests(groups[g].name, groups[g].tests,
                                        groups[g].n, NULL, NULL);
        total += groups[g].n;
        failed += (size_t)f;
    }
    printf("unit: %zu passed, %zu failed, %zu skipped\n",
           total - failed - n_skipped, failed, n_skipped);
    return failed ? 1 : 0;
}
