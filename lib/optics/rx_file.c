/*
 * rx_file.c: a lens prescription from a file: finding it (the scene's
 * directory, then the shipped lenses) and reading it in the form its
 * name says.
 */
#include "optics/prescription.h"
#include "optics/lens_load.h"
#include "json/json_util.h"
#include "util/scene_file.h"

#include <dirent.h>
#include <locale.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#ifndef LR_LENS_DIR
#define LR_LENS_DIR "lenses"
#endif
#ifndef LR_LENS_INSTALL_DIR
#define LR_LENS_INSTALL_DIR "/usr/local/share/lensray/lenses"
#endif

/* A lens file is small; 1 MiB leaves a hundredfold margin. */
#define MAX_LENS_BYTES (1u << 20)

static const char *const exts[] = {".json", ".zmx", ".dat", ".txt", NULL};

int lr__rx_decimal(const char *word, double *x)
{
    if (word == NULL || word[0] == '\0' ||
        word[strspn(word, "0123456789+-.eE")] != '\0')
        return -1;
    /* strtod follows LC_NUMERIC, which a host program (Python after
     * locale.setlocale) may have set to a locale whose decimal point is a
     * comma, and then "70.97" would end at the point.  Should the C
     * locale not be had (out of memory), the process's is the best left. */
    locale_t c = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    char *end;
    *x = c != (locale_t)0 ? strtod_l(word, &end, c) : strtod(word, &end);
    if (c != (locale_t)0)
        freelocale(c);
    return end != word && *end == '\0' ? 0 : -1;
}

static int is_file(const char *p)
{
    struct stat sb;
    return stat(p, &sb) == 0 && S_ISREG(sb.st_mode);
}

static int is_dir(const char *p)
{
    struct stat sb;
    return stat(p, &sb) == 0 && S_ISDIR(sb.st_mode);
}

/* $LENSRAY_LENS_DIR, else the source tree's lenses/, else where `make
 * install` put them: an installed lensrayd whose build tree is gone still
 * has the shipped lenses. */
static const char *lens_dir(void)
{
    const char *d = getenv("LENSRAY_LENS_DIR");
    if (d != NULL && d[0])
        return d;
    return is_dir(LR_LENS_DIR) || !is_dir(LR_LENS_INSTALL_DIR)
               ? LR_LENS_DIR
               : LR_LENS_INSTALL_DIR;
}

static int cmp(const void *a, const void *b)
{
    return strcmp((const char *)a, (const char *)b);
}

int lr__rx_shipped(char (*names)[64], int max)
{
    int n = 0;
    DIR *d = opendir(lens_dir());
    if (d == NULL)
        return 0;
    while (n < max) {
        const struct dirent *e = readdir(d);
        if (e == NULL)
            break;
        const char *dot = strrchr(e->d_name, '.');
        if (dot == NULL || e->d_name[0] == '.')
            continue;
        for (int k = 0; exts[k]; k++)
            if (strcasecmp(dot, exts[k]) == 0 &&
                (size_t)(dot - e->d_name) < sizeof names[0]) {
                snprintf(names[n], sizeof names[0], "%.*s",
                         (int)(dot - e->d_name), e->d_name);
                n++;
                break;
            }
    }
    closedir(d);
    qsort(names, (size_t)n, sizeof names[0], cmp);
    return n;
}

/* "a, b, c": the shipped lenses' names, for an error message.  Those that
 * do not fit are counted ("a, b and 7 more"), not cut off mid-name: two
 * dozen names of source, focal length and f-number are longer than an
 * lr_error's message. */
static void shipped(char *out, size_t cap)
{
    char names[64][64];
    int n = lr__rx_shipped(names, 64);
    /* Room kept for " and 64 more". */
    const size_t tail = 16;
    size_t o = 0;
    int i = 0;
    out[0] = '\0';
    for (; i < n; i++) {
        size_t w = strlen(names[i]) + (i ? 2 : 0);
        if (o + w + (i + 1 < n ? tail : 0) >= cap)
            break;
        o += (size_t)snprintf(out + o, cap - o, "%s%s", i ? ", " : "",
                              names[i]);
    }
    if (i < n)
        snprintf(out + o, cap - o, " and %d more", n - i);
    if (n == 0)
        snprintf(out, cap, "none (in %s)", lens_dir());
}

/* `name` as a file beside `base_dir` ("": the working directory) into
 * `out`: 1 if it is a file, 0 if not, -1 if the path does not fit.
 * *dir says whether it is a directory, which is told apart from a missing
 * file in the error. */
static int beside(const char *name, const char *base_dir, char *out, size_t cap,
                  int *dir)
{
    int w;
    if (name[0] == '/' || base_dir[0] == '\0')
        w = snprintf(out, cap, "%s", name);
    else
        w = snprintf(out, cap, "%s/%s", base_dir, name);
    if (w < 0 || (size_t)w >= cap)
        return -1;
    *dir = is_dir(out);
    return is_file(out);
}

/* A shipped lens: a plain name, with or without its extension. */
static int shipped_file(const char *name, char *out, size_t cap)
{
    if (strchr(name, '/') != NULL)
        return 0;
    int w = snprintf(out, cap, "%s/%s", lens_dir(), name);
    if (w > 0 && (size_t)w < cap && is_file(out))
        return 1;
    for (int k = 0; exts[k]; k++) {
        w = snprintf(out, cap, "%s/%s%s", lens_dir(), name, exts[k]);
        if (w > 0 && (size_t)w < cap && is_file(out))
            return 1;
    }
    return 0;
}

/* lr__rx_find, and lr__rx_find_shipped when `base_dir` is NULL. */
static lr_status find(const char *name, const char *base_dir, char *out,
                      size_t cap, lr_error *err)
{
    char shown[96];
    lr__utf8_escape(name, shown, sizeof shown);
    if (name[0] == '\0')
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "a lens name must not be empty");
    /* An asset is found where every scene file is, or not at all. */
    if (strncmp(name, "sha256:", 7) == 0)
        return lr__scene_file(name, base_dir, NULL, out, cap, err);
    int dir = 0, found = 0;
    if (base_dir != NULL)
        found = beside(name, base_dir, out, cap, &dir);
    if (found < 0)
        return lr__fail(err, LR_ERR_LIMIT, NULL, "lens \"%s\": path too long",
                        shown);
    if (found || shipped_file(name, out, cap))
        return LR_OK;
    out[0] = '\0';
    if (dir)
        return lr__fail(err, LR_ERR_INVALID, NULL,
                        "lens \"%s\": is a directory, not a lens file", shown);
    char list[512];
    shipped(list, sizeof list);
    /* The directory is not named: a daemon's error must not show where
     * its scenes live. */
    return lr__fail(err, LR_ERR_INVALID, NULL,
                    "lens \"%s\": %sno shipped lens of that name; shipped "
                    "lenses: %s",
                    shown,
                    base_dir == NULL   ? ""
                    : base_dir[0] != 0 ? "no such file beside the scene, and "
                                       : "no such file, and ",
                    list);
}

lr_status lr__rx_find(const char *name, const char *base_dir, char *out,
                      size_t cap, lr_error *err)
{
    return find(name, base_dir ? base_dir : "", out, cap, err);
}

lr_status lr__rx_find_shipped(const char *name, char *out, size_t cap,
                              lr_error *err)
{
    return find(name, NULL, out, cap, err);
}

/* Puts "shown: " before a reader's message (JSON lens files name fields,
 * not the file). */
static void prefix(lr_error *err, const char *shown)
{
    if (err == NULL)
        return;
    char m[sizeof err->message];
    snprintf(m, sizeof m, "%s", err->message);
    int w = snprintf(err->message, sizeof err->message, "%s: %s", shown, m);
    lr__trim_partial_utf8(err->message, sizeof err->message, w);
}

/* The form of a lens file without its name: lensray JSON starts with
 * '{'; a Zemax file has a SURF line (and is often UTF-16, whose BOM or
 * zero bytes show it); the rest is read as pbrt-v4's table.  Returns an
 * index into exts. */
static int sniff(const char *text, size_t len)
{
    /* A UTF-8 byte order mark before the '{' (the readers skip it). */
    size_t i = len >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0;
    while (i < len && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r' ||
                       text[i] == '\n'))
        i++;
    if (i < len && text[i] == '{')
        return 0;
    if (len >= 2 && ((unsigned char)text[0] == 0xff ||
                     (unsigned char)text[0] == 0xfe || memchr(text, 0, len)))
        return 1;
    for (size_t k = 0; k + 5 <= len; k++)
        if ((k == 0 || text[k - 1] == '\n') &&
            memcmp(text + k, "SURF ", 5) == 0)
            return 1;
    return 2;
}

lr_status lr__rx_load_file(const char *file, const char *shown,
                           const char *json_path, lr__rx *rx, lr_error *err)
{
    const char *dot = strrchr(file, '.');
    int kind = -1;
    for (int k = 0; dot != NULL && exts[k]; k++)
        if (strcasecmp(dot, exts[k]) == 0)
            kind = k;
    /* An asset has no name but its hash: its form is read from it. */
    int asset = lr__scene_file_is_asset(shown);
    if (kind < 0 && !asset)
        return lr__fail(err, LR_ERR_INVALID, json_path,
                        "%s: a lens file must end in .json (lensray), .zmx "
                        "(Zemax) or .dat/.txt (pbrt-v4)",
                        shown);
    char *text = NULL;
    size_t len = 0;
    LR_TRY(lr__read_file(file, shown, json_path, MAX_LENS_BYTES, "lens files",
                         NULL, &text, &len, err));
    if (asset)
        kind = sniff(text, len);
    lr_status st;
    if (kind == 0) {
        cJSON *o = NULL;
        st = lr__json_parse(text, len, shown, "", &o, err);
        if (st == LR_OK) {
            st = lr__rx_from_json(o, "", rx, err);
            if (st != LR_OK)
                prefix(err, shown);
        }
        cJSON_Delete(o);
    } else if (kind == 1)
        st = lr__rx_from_zmx(text, len, shown, rx, err);
    else
        st = lr__rx_from_pbrt(text, len, shown, rx, err);
    free(text);
    if (st == LR_OK) {
        st = lr__rx_check(rx, "", err);
        if (st != LR_OK)
            prefix(err, shown);
    }
    if (st != LR_OK && err != NULL) {
        if (json_path != NULL)
            snprintf(err->path, sizeof err->path, "%s", json_path);
    }
    return st;
}
