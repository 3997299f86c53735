/*
 * pilots.h: adaptive sampling's pilots shared between blocks.  A block
 * reads the pilots of a one-pixel apron around it (adaptive.c); inside
 * the region those are pilots of the neighbouring blocks' own pixels, so
 * each was traced twice (at 32-pixel tiles 7.4% of a render's rays
 * through a real lens).  Here a pilot on a block's border is traced once,
 * by the first block in the render's order that needs it (its owner, or a
 * neighbour that reads it as apron), and the others wait for it and copy
 * it.  A pilot is the same samples whoever traces it, so the pixels do
 * not change; the rays counted are each pilot's once, so the statistics
 * do not depend on the thread count or tile size.
 *
 * Why waiting cannot deadlock: blocks are numbered in the order the
 * render hands them out (tiles in order, a tile's blocks in render.c's
 * order), a block waits only for blocks numbered before it, and a block,
 * once handed out, is rendered to its end.
 *
 * Memory: a slot (72 bytes) per pixel on a block's first or last row or
 * column, about 9 bytes a pixel of the region at 32-pixel tiles.
 *
 * Owned by the render (render.c), shared by its threads.
 */
#ifndef LR_PILOTS_H
#define LR_PILOTS_H

#include "render/film.h"
#include "util/internal.h"

#include <stdatomic.h>

struct lr__plan;

typedef struct lr__pilot_slot {
    atomic_int ready; /* 1 once acc holds the pilot */
    lr__pixel acc;
} lr__pilot_slot;

typedef struct lr__pilots {
    const struct lr__plan *plan;
    int spp;
    int x0, y0, x1, y1;        /* the region, tiled from (x0, y0) */
    int tile, tiles_x, blocks; /* tile size; tiles a row; blocks a tile side */
    int *col, *row;            /* a border column's or row's index, else -1 */
    int ncol, nrow;
    lr__pilot_slot *slot; /* ncol x height, then nrow x width */
} lr__pilots;

/* Sets up sharing for the region [x0, x1) x [y0, y1) in tiles of `tile`
 * pixels (render.c's), or leaves *p empty (every call below then says
 * "trace it yourself") when adaptive sampling reads no apron.  Returns 0
 * when out of memory. */
int lr__pilots_init(lr__pilots *p, const lr_render_settings *set,
                    const struct lr__plan *plan, int x0, int y0, int x1, int y1,
                    int tile);
void lr__pilots_free(lr__pilots *p);

/* For pixel (x, y), needed by the block whose first pixel is (bx, by):
 * LR__PILOT_TRACE (trace it; *slot is -1), LR__PILOT_GIVE (trace it, then
 * lr__pilots_give) or LR__PILOT_TAKE (lr__pilots_take). */
enum { LR__PILOT_TRACE, LR__PILOT_GIVE, LR__PILOT_TAKE };
int lr__pilots_role(const lr__pilots *p, int x, int y, int bx, int by,
                    int *slot);
void lr__pilots_give(lr__pilots *p, int slot, const lr__pixel *acc);
/* Waits until the slot is given, then copies it. */
void lr__pilots_take(lr__pilots *p, int slot, lr__pixel *acc);

#endif
