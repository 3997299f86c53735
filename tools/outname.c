/*
 * outname.c: a batch's output file names (outname.h).  The pattern is
 * parsed here by hand rather than given to snprintf, so that a name with
 * a stray conversion (%s, %n) can never reach a format string.
 */
#include "outname.h"

#include <stdio.h>
#include <string.h>

/* At p (just after a '%'): the width of a %d or %0Nd, -1 for none, or -2
 * when it is no such conversion; *len gets the characters it spans. */
static int conversion(const char *p, size_t *len)
{
    if (p[0] == 'd') {
        *len = 1;
        return -1;
    }
    if (p[0] == '0' && p[1] >= '1' && p[1] <= '9' && p[2] == 'd') {
        *len = 3;
        return p[1] - '0';
    }
    return -2;
}

int outname_check(const char *pattern)
{
    int numbers = 0;
    for (const char *p = pattern; (p = strchr(p, '%')) != NULL;) {
        if (p[1] == '%') {
            p += 2;
            continue;
        }
        size_t len;
        if (conversion(p + 1, &len) == -2)
            return -1;
        numbers++;
        p += 1 + len;
    }
    return numbers == 0 ? 0 : numbers == 1 ? 1 : -1;
}

int outname_frame(const char *pattern, int number, char *out, size_t size)
{
    size_t o = 0;
    for (const char *p = pattern; *p != '\0'; p++) {
        char piece[32] = {*p, '\0'};
        if (*p == '%' && p[1] == '%') {
            p++;
        } else if (*p == '%') {
            size_t len;
            int width = conversion(p + 1, &len);
            snprintf(piece, sizeof piece, "%0*d", width < 0 ? 1 : width,
                     number);
            p += len;
        }
        size_t n = strlen(piece);
        if (o + n >= size)
            return -1;
        memcpy(out + o, piece, n);
        o += n;
    }
    out[o] = '\0';
    return 0;
}
