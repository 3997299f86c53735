/*
 * outname.h: the output file of each frame of a batch (`lensray render
 * A.json B.json ... -o out-%04d.exr`): the pattern's one printf-style
 * number, %d or %0Nd, becomes the frame's number, its place among the
 * scene arguments counted from 1; %% is a '%'.
 */
#ifndef LENSRAY_OUTNAME_H
#define LENSRAY_OUTNAME_H

#include <stddef.h>

/* Whether `pattern` holds a frame number (exactly one %d or %0Nd, N
 * from 1 to 9, and no other '%' than %%): 1; 0 when it holds no '%'
 * but %%; -1 otherwise (a second number, another conversion).  The CLI
 * takes a name that is not 1 as a plain file name, for one scene. */
int outname_check(const char *pattern);

/* The name of frame `number` by `pattern` (for which outname_check
 * said 1).  0, or -1 when it does not fit `size`. */
int outname_frame(const char *pattern, int number, char *out, size_t size);

#endif
