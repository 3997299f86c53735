/*
 * unit_main.c: runs every registered cmocka group, or only the groups
 * named on the command line (`unit --list` names them; each is the file
 * test_NAME.c), and ends with
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
    if (argc == 2 && strcmp(argv[1], "--list") == 0) {
        for (size_t g = 0; g < n_groups; g++)
            printf("%s (%zu test%s)\n", groups[g].name, groups[g].n,
                   groups[g].n == 1 ? "" : "s");
        return 0;
    }
    /* A misspelt group would otherwise run nothing and pass. */
    for (int i = 1; i < argc; i++) {
        size_t g = 0;
        while (g < n_groups && strcmp(groups[g].name, argv[i]) != 0)
            g++;
        if (g == n_groups) {
            fprintf(stderr, "unit: no test group \"%s\" (--list lists them)\n",
                    argv[i]);
            return 2;
        }
    }
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
