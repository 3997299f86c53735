/*
 * pilots.c: pilots shared between blocks (pilots.h).
 */
#include "render/pilots.h"
#include "render/adaptive.h"
#include "render/plan.h"

#include <immintrin.h>
#include <sched.h>
#include <stdlib.h>

/* The block (render.c's render_tile) holding coordinate v along one
 * axis: its first coordinate, and its number along the axis as (tile,
 * block within the tile). */
static void block_of(const lr__pilots *p, int v, int v0, int *first, int *tile,
                     int *sub)
{
    int t = (v - v0) / p->tile, o = (v - v0) - t * p->tile;
    *tile = t;
    *sub = o / LR__BLOCK_MAX;
    *first = v0 + t * p->tile + *sub * LR__BLOCK_MAX;
}

/* The block's place in the order the render takes them: tiles in row
 * order, and in a tile its blocks in row order. */
static long long block_key(const lr__pilots *p, int x, int y)
{
    int fx, fy, tx, ty, sx, sy;
    block_of(p, x, p->x0, &fx, &tx, &sx);
    block_of(p, y, p->y0, &fy, &ty, &sy);
    long long tile = (long long)ty * p->tiles_x + tx;
    return tile * p->blocks * p->blocks + (long long)sy * p->blocks + sx;
}

/* Index of a border line (a block's first or last column or row) for
 * each coordinate of [v0, v1), -1 elsewhere; the count. */
static int border_lines(const lr__pilots *p, int v0, int v1, int *idx)
{
    int n = 0;
    for (int v = v0; v < v1; v++) {
        int first, t, s;
        block_of(p, v, v0, &first, &t, &s);
        int end = first + LR__BLOCK_MAX;
        int tile_end = v0 + (t + 1) * p->tile;
        end = end < tile_end ? end : tile_end;
        end = end < v1 ? end : v1;
        idx[v - v0] = v == first || v == end - 1 ? n++ : -1;
    }
    return n;
}

int lr__pilots_init(lr__pilots *p, const lr_render_settings *set,
                    const lr__plan *plan, int x0, int y0, int x1, int y1,
                    int tile)
{
    *p = (lr__pilots){0};
    /* No apron is read (adaptive.c's lr__adaptive_block), or one block
     * covers the region. */
    if (!set->adaptive || lr__adaptive_min(set) >= set->spp ||
        (x1 - x0 <= LR__BLOCK_MAX && y1 - y0 <= LR__BLOCK_MAX &&
         x1 - x0 <= tile && y1 - y0 <= tile))
        return 1;
    int w = x1 - x0, h = y1 - y0;
    p->plan = plan, p->spp = set->spp;
    p->x0 = x0, p->y0 = y0, p->x1 = x1, p->y1 = y1;
    p->tile = tile;
    p->tiles_x = (w + tile - 1) / tile;
    p->blocks = (tile + LR__BLOCK_MAX - 1) / LR__BLOCK_MAX;
    p->col = malloc((size_t)w * sizeof *p->col);
    p->row = malloc((size_t)h * sizeof *p->row);
    if (p->col == NULL || p->row == NULL) {
        lr__pilots_free(p);
        return 0;
    }
    p->ncol = border_lines(p, x0, x1, p->col);
    p->nrow = border_lines(p, y0, y1, p->row);
    size_t n = (size_t)p->ncol * (size_t)h + (size_t)p->nrow * (size_t)w;
    /* calloc: every slot starts not ready (atomic_int's zero is 0). */
    p->slot = calloc(n, sizeof *p->slot);
    if (p->slot == NULL) {
        lr__pilots_free(p);
        return 0;
    }
    return 1;
}

void lr__pilots_free(lr__pilots *p)
{
    free(p->col);
    free(p->row);
    free(p->slot);
    *p = (lr__pilots){0};
}

int lr__pilots_role(const lr__pilots *p, int x, int y, int bx, int by,
                    int *slot)
{
    *slot = -1;
    if (p->slot == NULL || x < p->x0 || x >= p->x1 || y < p->y0 || y >= p->y1)
        return LR__PILOT_TRACE;
    int c = p->col[x - p->x0], r = p->row[y - p->y0];
    if (c < 0 && r < 0)
        return LR__PILOT_TRACE; /* only its own block reads it */
    /* Who reads it: its own block, and every neighbouring block with a
     * neighbour of the pixel whose pilot is not all of its samples
     * (adaptive.c's apron_needed).  The first of them traces it. */
    long long first = block_key(p, x, y);
    for (int ny = y - 1; ny <= y + 1; ny++)
        for (int nx = x - 1; nx <= x + 1; nx++) {
            if (nx < p->x0 || nx >= p->x1 || ny < p->y0 || ny >= p->y1 ||
                lr__plan_at(p->plan, nx, ny)->pilot >= p->spp)
                continue;
            long long k = block_key(p, nx, ny);
            if (k < first)
                first = k;
        }
    *slot = c >= 0
                ? c * (p->y1 - p->y0) + (y - p->y0)
                : p->ncol * (p->y1 - p->y0) + r * (p->x1 - p->x0) + (x - p->x0);
    return block_key(p, bx, by) == first ? LR__PILOT_GIVE : LR__PILOT_TAKE;
}

void lr__pilots_give(lr__pilots *p, int slot, const lr__pixel *acc)
{
    lr__pilot_slot *s = &p->slot[slot];
    s->acc = *acc;
    atomic_store_explicit(&s->ready, 1, memory_order_release);
}

void lr__pilots_take(lr__pilots *p, int slot, lr__pixel *acc)
{
    lr__pilot_slot *s = &p->slot[slot];
    /* The giver is a block handed out earlier, most often one tile back
     * and long past its pilots: the wait is short when there is one. */
    for (int spin = 0; !atomic_load_explicit(&s->ready, memory_order_acquire);
         spin++) {
        if (spin < 64)
            _mm_pause();
        else
            sched_yield();
    }
    *acc = s->acc;
}
