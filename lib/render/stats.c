/*
 * stats.c: lr_render_stats as JSON, once, so that the CLI's --stats line
 * and the daemon's job status show the same fields under the same names
 * (bench/ and the accuracy study read the CLI's).
 */
#include "util/internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The JSON is a few hundred bytes at most (every number is bounded), so
 * it is written into a fixed buffer and copied out; `used` past the end
 * means it did not fit, which the caller treats as a failure. */
typedef struct text {
    char buf[1024];
    size_t used;
} text;

static void put(text *t, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static void put(text *t, const char *fmt, ...)
{
    if (t->used >= sizeof t->buf)
        return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(t->buf + t->used, sizeof t->buf - t->used, fmt, ap);
    va_end(ap);
    t->used = n < 0 ? sizeof t->buf : t->used + (size_t)n;
}

char *lr_render_stats_json(const lr_render_stats *st,
                           const lr_render_settings *rs, const lr_scene *scene)
{
    if (st == NULL)
        return NULL;
    text b;
    b.used = 0;
    /* Rates per second of wall time; a render too short to time counts
     * as a nanosecond rather than dividing by zero. */
    double s = st->seconds > 0 ? st->seconds : 1e-9;
    double px = st->pixels ? (double)st->pixels : 1.0;
    put(&b, "{\"seconds\": %.6f, \"cpu_seconds\": %.6f", st->seconds,
        st->cpu_seconds);
    if (rs != NULL)
        put(&b, ", \"width\": %d, \"height\": %d, \"spp\": %d", rs->width,
            rs->height, rs->spp);
    put(&b,
        ", \"threads\": %d, \"pixels\": %llu, \"samples\": %llu, "
        "\"rays\": %llu, \"samples_per_second\": %.0f, "
        "\"rays_per_second\": %.0f, \"nan_samples\": %llu",
        st->threads, (unsigned long long)st->pixels,
        (unsigned long long)st->samples, (unsigned long long)st->rays,
        (double)st->samples / s, (double)st->rays / s,
        (unsigned long long)st->nan_samples);
    if (scene != NULL)
        put(&b, ", \"primitives\": %zu", lr_scene_primitive_count(scene));
    put(&b, ", \"plan\": {");
    if (rs != NULL)
        put(&b, "\"enabled\": %s, \"adaptive\": %s, ",
            rs->plan ? "true" : "false", rs->adaptive ? "true" : "false");
    put(&b,
        "\"lens_pixels\": %.4f, \"chroma_pixels\": %.4f, \"samples\": %llu, "
        "\"full_samples\": %llu, \"camera_rays\": %llu, "
        "\"full_camera_rays\": %llu, \"lens_blocked\": %llu, "
        "\"light_lights\": %llu, \"light_paths\": %llu, "
        "\"light_landed\": %llu, \"ghost_lights\": %llu, "
        "\"ghost_paths\": %llu, \"ghost_landed\": %llu, "
        "\"ghost_flux\": %.6g}}",
        (double)st->lens_pixels / px, (double)st->chroma_pixels / px,
        (unsigned long long)st->samples, (unsigned long long)st->full_samples,
        (unsigned long long)st->camera_rays,
        (unsigned long long)st->full_camera_rays,
        (unsigned long long)st->lens_blocked,
        (unsigned long long)st->light_lights,
        (unsigned long long)st->light_paths,
        (unsigned long long)st->light_landed,
        (unsigned long long)st->ghost_lights,
        (unsigned long long)st->ghost_paths,
        (unsigned long long)st->ghost_landed, st->ghost_flux);
    return b.used < sizeof b.buf ? strdup(b.buf) : NULL;
}
