/*
 * fuzz.h: the entry points of the fuzz targets, shared by the libFuzzer
 * builds (make fuzz) and the corpus replay of the unit tests
 * (tests/test_fuzz_replay.c), which links the same code without libFuzzer.
 *
 * Each entry point feeds one input to a parser and checks what the issue
 * promises about bad input: it never crashes (the sanitizers watch that),
 * every error has a known status and a non-empty message that names its
 * field, and whatever is accepted is usable (a scene renders finite
 * pixels, a mesh has finite vertices and in-range indices, a job spec is
 * within the daemon's limits).  A broken promise returns non-zero after
 * lr_fuzz_report() recorded what happened; the libFuzzer wrapper then
 * aborts so that the input is saved as a crash.
 */
#ifndef LR_FUZZ_H
#define LR_FUZZ_H

#include <stddef.h>
#include <stdint.h>

int lr_fuzz_scene(const uint8_t *data, size_t size);
int lr_fuzz_obj(const uint8_t *data, size_t size);
int lr_fuzz_job(const uint8_t *data, size_t size);
int lr_fuzz_lens(const uint8_t *data, size_t size);
int lr_fuzz_gltf(const uint8_t *data, size_t size);
int lr_fuzz_texture(const uint8_t *data, size_t size);

/* The last broken promise, as a sentence ("" when none). */
const char *lr_fuzz_last_failure(void);

/* 1 if s is strict UTF-8 (RFC 3629). */
int lr_fuzz_valid_utf8(const char *s);

/* Records a broken promise (printf-style) and returns 1. */
int lr_fuzz_report(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Checks an lr_error after a failed call: a known status, a message, and
 * the field's path inside the message when there is one.  Returns 0 or
 * the lr_fuzz_report() result. */
struct lr_error;
int lr_fuzz_check_error(const char *what, int status,
                        const struct lr_error *err);

#ifdef LR_FUZZ_LIBFUZZER
#include <stdio.h>
#include <stdlib.h>
#define LR_FUZZ_MAIN(fn)                                           \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);  \
    int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)   \
    {                                                              \
        if (fn(data, size) != 0) {                                 \
            fprintf(stderr, "fuzz: %s\n", lr_fuzz_last_failure()); \
            abort();                                               \
        }                                                          \
        return 0;                                                  \
    }
#else
#define LR_FUZZ_MAIN(fn)
#endif

#endif
