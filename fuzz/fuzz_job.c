/*
 * fuzz_job.c: the daemon's job parser (lrd_api_parse_job in
 * service/api.c), linked with the scene cache, the error helpers and
 * SHA-256 of service/ but without the HTTP server or the workers.
 *
 * service/main.c owns the configuration and main(), so this file defines
 * lrd_cfg itself with main.c's defaults; named scenes come from scenes/
 * (LENSRAY_FUZZ_SCENES overrides).  Promises checked: no crash, no leak;
 * an error has an HTTP status the API documents, a code and a message;
 * an accepted job has a valid camera and settings within the limits.
 */
#include "fuzz.h"

#include "../service/lensrayd.h"

#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

lrd_config lrd_cfg;

static void configure(void)
{
    lrd_config_defaults();
    const char *dir = getenv("LENSRAY_FUZZ_SCENES");
    char resolved[PATH_MAX];
    if (realpath(dir && *dir ? dir : "scenes", resolved) == NULL)
        snprintf(resolved, sizeof resolved, "/nonexistent");
    snprintf(lrd_cfg.scenes_dir, sizeof lrd_cfg.scenes_dir, "%s", resolved);
}

static pthread_once_t once = PTHREAD_ONCE_INIT;

static int known_http(int s)
{
    return s == 400 || s == 404 || s == 413 || s == 422 || s == 500 || s == 503;
}

int lr_fuzz_job(const uint8_t *data, size_t size)
{
    pthread_once(&once, configure);
    lrd_job_spec spec;
    lrd_err e;
    memset(&e, 0, sizeof e);
    int rc = lrd_api_parse_job((const char *)data, size, &spec, &e);
    if (rc != 0) {
        if (rc != -1)
            return lr_fuzz_report("job: returned %d", rc);
        if (spec.scene != NULL)
            return lr_fuzz_report("job: failed but kept a scene reference");
        if (!known_http(e.http) || e.code[0] == '\0' || e.message[0] == '\0')
            return lr_fuzz_report("job: error %d \"%s\": \"%s\"", e.http,
                                  e.code, e.message);
        /* The message and path go into a JSON response as they are
         * (non-UTF-8 bodies are refused, and text cut to fit a buffer
         * ends on a whole character: both found here, both fixed). */
        if (!lr_fuzz_valid_utf8(e.message) || !lr_fuzz_valid_utf8(e.path))
            return lr_fuzz_report("job: error %d is not valid UTF-8: %s",
                                  e.http, e.message);
        /* Named scenes of the repository are valid: a 500 here would be
         * a scene file the library rejects. */
        if (e.http == 500)
            return lr_fuzz_report("job: server error %s: %s", e.code,
                                  e.message);
        return 0;
    }
    lr_error le;
    int bad = 0;
    if (spec.scene == NULL)
        bad = lr_fuzz_report("job: accepted without a scene");
    else if (lr_camera_validate(&spec.cam, &le) != LR_OK)
        bad = lr_fuzz_report("job: invalid camera accepted: %s", le.message);
    else if (lr_render_settings_validate(&spec.rs, &le) != LR_OK)
        bad = lr_fuzz_report("job: invalid settings accepted: %s", le.message);
    else if ((uint64_t)spec.width * (uint64_t)spec.height >
                 lrd_cfg.max_pixels ||
             spec.samples > lrd_cfg.max_samples || spec.width < 1 ||
             spec.height < 1)
        bad = lr_fuzz_report("job: accepted %d x %d, %llu samples", spec.width,
                             spec.height, (unsigned long long)spec.samples);
    lrd_job_spec_clear(&spec);
    return bad;
}

LR_FUZZ_MAIN(lr_fuzz_job)
