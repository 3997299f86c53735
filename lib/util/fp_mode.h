/*
 * fp_mode.h: the floating-point mode lensray computes in, whatever its
 * caller's.  A host program may set the SSE unit's flush-to-zero and
 * denormals-are-zero bits (Blender's threads do), another rounding mode
 * or unmasked exceptions: a render set up under them differed from the
 * CLI's in the last bit of a few pixels (blender/tests/
 * test_blender_binary.py, 2 runs in 9).  The public entry points that
 * compute (lr_scene_load_*, lr_render, lr_render_plan_map) take the
 * default mode for the call, as a new process has it, and give the
 * caller's back; the render's workers then set FTZ and DAZ themselves,
 * as Embree recommends (render.c), whatever the caller had.
 */
#ifndef LR_FP_MODE_H
#define LR_FP_MODE_H

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>

/* MXCSR as a new process has it: every exception masked, round to
 * nearest, FTZ and DAZ off.  Returns the caller's, for lr__fp_leave. */
static inline unsigned lr__fp_enter(void)
{
    unsigned csr = _mm_getcsr();
    _mm_setcsr(0x1f80u);
    return csr;
}

static inline void lr__fp_leave(unsigned csr)
{
    _mm_setcsr(csr);
}
#else
static inline unsigned lr__fp_enter(void)
{
    return 0;
}

static inline void lr__fp_leave(unsigned csr)
{
    (void)csr;
}
#endif

#endif
