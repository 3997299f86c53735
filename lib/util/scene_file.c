/*
 * scene_file.c: a scene's file references made paths (scene_file.h), and
 * the process's assets directory (lr_assets_dir_set in lensray.h).
 */
#include "util/scene_file.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* The keys that name files.  A new file key is added here and read
 * through lr__scene_file; nothing else needs to know about it.  The
 * texture keys are the materials' (docs/scene-format.md). */
static const char *const file_keys[] = {
    "file", "diffuse_texture", "emission_texture", "roughness_texture", NULL};

int lr_scene_file_key(const char *key)
{
    return key != NULL && lr__scene_file_key(key);
}

int lr__scene_file_key(const char *key)
{
    for (size_t i = 0; file_keys[i] != NULL; i++)
        if (strcmp(key, file_keys[i]) == 0)
            return 1;
    return 0;
}

int lr__scene_file_is_asset(const char *ref)
{
    if (strncmp(ref, "sha256:", 7) != 0)
        return 0;
    size_t n = 0;
    for (const char *p = ref + 7; *p != '\0'; p++, n++)
        if (!((*p >= '0' && *p <= '9') || (*p >= 'a' && *p <= 'f')))
            return 0;
    return n == 64;
}

/* Set once at start-up, before any scene loads; the mutex only keeps a
 * late change from tearing a path being read. */
static pthread_mutex_t dir_lock = PTHREAD_MUTEX_INITIALIZER;
static char assets_dir[4096];

lr_status lr_assets_dir_set(const char *dir, lr_error *err)
{
    if (dir != NULL && strlen(dir) >= sizeof assets_dir)
        return lr__fail(err, LR_ERR_LIMIT, NULL,
                        "the assets directory's path is longer than %zu "
                        "bytes",
                        sizeof assets_dir - 1);
    pthread_mutex_lock(&dir_lock);
    snprintf(assets_dir, sizeof assets_dir, "%s", dir ? dir : "");
    pthread_mutex_unlock(&dir_lock);
    return LR_OK;
}

lr_status lr__scene_file(const char *ref, const char *base_dir,
                         const char *field, char *out, size_t cap,
                         lr_error *err)
{
    const char *f = field ? field : "file";
    int w;
    if (strncmp(ref, "sha256:", 7) == 0) {
        if (!lr__scene_file_is_asset(ref))
            return lr__fail(err, LR_ERR_INVALID, field,
                            "%s: an asset is named \"sha256:\" and the "
                            "SHA-256 of its bytes as 64 lowercase hex "
                            "digits, got \"%.80s\"",
                            f, ref);
        char dir[sizeof assets_dir];
        pthread_mutex_lock(&dir_lock);
        snprintf(dir, sizeof dir, "%s", assets_dir);
        pthread_mutex_unlock(&dir_lock);
        if (dir[0] == '\0') {
            const char *env = getenv("LENSRAY_ASSETS_DIR");
            snprintf(dir, sizeof dir, "%s", env ? env : "");
        }
        if (dir[0] == '\0')
            return lr__fail(err, LR_ERR_INVALID, field,
                            "%s names the asset %s, but there is no assets "
                            "directory (LENSRAY_ASSETS_DIR, lensrayd "
                            "--assets)",
                            f, ref);
        w = snprintf(out, cap, "%s/%s", dir, ref + 7);
        struct stat st;
        if (w >= 0 && (size_t)w < cap &&
            (stat(out, &st) != 0 || !S_ISREG(st.st_mode)))
            return lr__fail(err, LR_ERR_INVALID, field,
                            "%s: there is no asset %s in the assets "
                            "directory",
                            f, ref);
    } else if (ref[0] == '/' || base_dir == NULL || base_dir[0] == '\0') {
        w = snprintf(out, cap, "%s", ref);
    } else {
        w = snprintf(out, cap, "%s/%s", base_dir, ref);
    }
    if (w < 0 || (size_t)w >= cap)
        return lr__fail(err, LR_ERR_LIMIT, field, "%s: the path is too long",
                        f);
    return LR_OK;
}
