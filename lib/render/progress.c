/* progress.c: lr_progress_store, the polling form of the progress
 * callback (include/lensray.h). */
#include "lensray.h"

void lr_progress_store(void *user, uint64_t done, uint64_t total)
{
    uint64_t *out = user;
    if (out == NULL)
        return;
    /* Total first, so that a reader that sees a done count also sees the
     * total it belongs to (release pairs with the reader's acquire). */
    __atomic_store_n(&out[1], total, __ATOMIC_RELEASE);
    __atomic_store_n(&out[0], done, __ATOMIC_RELEASE);
}
