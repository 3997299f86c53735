/*
 * test_fuzz_replay.c: replays the fuzzing corpora.  Every file of
 * tests/corpus/{scene,obj,lens,gltf,texture,job}/ (cases the fuzzers
 * found, and hand-written hostile inputs) and of fuzz/seeds/ likewise goes through the same
 * entry points as the libFuzzer targets (fuzz/fuzz_*.c), built here
 * without libFuzzer.  Each input must keep the promises those entry
 * points check (no crash, a clean error naming its field, finite renders
 * of what is accepted); under `make test-sanitize` ASan and UBSan watch
 * them too.  Paths are relative to the repository root, where `make
 * test` runs (LENSRAY_SOURCE_DIR overrides).
 */
#include "test.h"
#include "../fuzz/fuzz.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Weak so that a build without service/ still links: the job corpus is
 * then skipped, as an environment skip (the build left the daemon out). */
int lr_fuzz_job(const uint8_t *data, size_t size) __attribute__((weak));

static const char *source_dir(void)
{
    const char *d = getenv("LENSRAY_SOURCE_DIR");
    return d && *d ? d : ".";
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

static unsigned char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return NULL;
    size_t cap = 4096, n = 0;
    unsigned char *buf = malloc(cap);
    for (;;) {
        if (buf == NULL)
            break;
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (n < cap)
            break;
        unsigned char *grown = realloc(buf, cap * 2);
        if (grown == NULL) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = grown;
        cap *= 2;
    }
    fclose(f);
    *len = n;
    return buf;
}

/* Feeds every regular file of DIR to fn; returns how many. */
static size_t replay_dir(const char *dir, int (*fn)(const uint8_t *, size_t))
{
    DIR *d = opendir(dir);
    if (d == NULL)
        return 0;
    char **names = NULL;
    size_t n = 0, cap = 0;
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        if (e->d_name[0] == '.')
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            names = realloc(names, cap * sizeof *names);
            assert_non_null(names);
        }
        names[n] = strdup(e->d_name);
        assert_non_null(names[n]);
        n++;
    }
    closedir(d);
    qsort(names, n, sizeof *names, by_name);
    /* A failure is reported after everything is freed (cmocka's failure
     * does not return), so that the sanitizer run reports no leak. */
    char failure[2600] = "";
    for (size_t i = 0; i < n && failure[0] == '\0'; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        size_t len = 0;
        unsigned char *data = read_all(path, &len);
        if (data == NULL) {
            snprintf(failure, sizeof failure, "cannot read %s", path);
            break;
        }
        /* Every file must pass, the cases of fixed bugs included: a bug
         * that comes back fails the test. */
        int rc = fn(data, len);
        free(data);
        if (rc != 0) {
            snprintf(failure, sizeof failure, "%s: %s", path,
                     lr_fuzz_last_failure());
        }
    }
    for (size_t i = 0; i < n; i++)
        free(names[i]);
    free(names);
    if (failure[0] != '\0')
        fail_msg("%s", failure);
    return n;
}

static void replay(const char *kind, int (*fn)(const uint8_t *, size_t))
{
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/tests/corpus/%s", source_dir(), kind);
    size_t found = replay_dir(dir, fn);
    snprintf(dir, sizeof dir, "%s/fuzz/seeds/%s", source_dir(), kind);
    size_t seeds = replay_dir(dir, fn);
    /* An empty replay would pass silently if the tests ran from the
     * wrong directory. */
    if (found + seeds == 0)
        fail_msg("no %s corpus under %s (run from the repository root or "
                 "set LENSRAY_SOURCE_DIR)",
                 kind, source_dir());
    print_message("corpus %s: %zu found cases, %zu seeds\n", kind, found,
                  seeds);
}

static void test_scene_corpus(void **state)
{
    (void)state;
    replay("scene", lr_fuzz_scene);
}

static void test_obj_corpus(void **state)
{
    (void)state;
    replay("obj", lr_fuzz_obj);
}

static void test_lens_corpus(void **state)
{
    (void)state;
    replay("lens", lr_fuzz_lens);
}

static void test_gltf_corpus(void **state)
{
    (void)state;
    replay("gltf", lr_fuzz_gltf);
}

static void test_texture_corpus(void **state)
{
    (void)state;
    replay("texture", lr_fuzz_texture);
}

static void test_job_corpus(void **state)
{
    (void)state;
    if (lr_fuzz_job == NULL)
        lr_test_skip_env("this build has no service/, so no job parser");
    replay("job", lr_fuzz_job);
}

static const struct CMUnitTest fuzz_replay_tests[] = {
    cmocka_unit_test(test_scene_corpus),   cmocka_unit_test(test_obj_corpus),
    cmocka_unit_test(test_lens_corpus),    cmocka_unit_test(test_gltf_corpus),
    cmocka_unit_test(test_texture_corpus), cmocka_unit_test(test_job_corpus),
};

LR_TEST_GROUP(fuzz_replay, fuzz_replay_tests)
