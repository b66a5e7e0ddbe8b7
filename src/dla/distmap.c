/*
 * distmap.c - the two-level chessboard distance map (see distmap.h): grid
 * growth, incremental updates shell by shell, rebuild from a tree.
 */
#define _GNU_SOURCE /* mremap */
#include "distmap.h"

#include <math.h>
#include <string.h>
#include <stdlib.h>
#include <sys/mman.h>

/* Grids beyond this many fine cells are not made: the map disables itself. */
#define DISTMAP_MAX_CELLS (UINT64_C(1) << 33)

static void level_free(distmap_level *L)
{
    if (L->cell) munmap((void *)L->cell, L->bytes);
    L->cell = NULL;
}

static size_t tix_bytes(const distmap_grid *g)
{
    return (size_t)g->tw * g->tw * sizeof *g->tix;
}

static void grid_free(distmap_grid *g)
{
    if (!g) return;
    for (int l = 0; l < 2; l++) level_free(&g->lv[l]);
    if (g->tix) munmap((void *)g->tix, tix_bytes(g));
    free(g);
}

/* ---- leaf-bit tiles (2D, coarsened fine cells) ------------------------ */

#define TSEG_TILES ((size_t)1 << DISTMAP_TSEG_SHIFT)
#define TSEG_BYTES (TSEG_TILES * DISTMAP_TILE_WORDS * sizeof(uint64_t))

size_t distmap_tile_bytes(const distmap *m)
{
    if (!m->tseg) return 0;
    /* The segment table is mmap'd: only its first entries are touched. */
    return (size_t)(m->ntiles - 1 - m->nfree) * DISTMAP_TILE_WORDS * sizeof(uint64_t);
}

static void tiles_free(distmap *m)
{
    if (!m->tseg) return;
    for (size_t i = 0; i < DISTMAP_TSEG_MAX && m->tseg[i]; i++) munmap((void *)m->tseg[i], TSEG_BYTES);
    munmap((void *)m->tseg, DISTMAP_TSEG_MAX * sizeof *m->tseg);
    m->tseg = NULL;
    m->ntiles = 1;
    m->tfree = 0;
    m->nfree = 0;
}

static _Atomic uint64_t *tile_at(const distmap *m, uint32_t id)
{
    return m->tseg[id >> DISTMAP_TSEG_SHIFT] + (size_t)(id & (TSEG_TILES - 1)) * DISTMAP_TILE_WORDS;
}

/* A new zeroed tile (a dropped one when there is one): its id, or 0 when
 * out of memory or ids. */
static uint32_t tile_new(distmap *m)
{
    if (m->tfree) {
        const uint32_t id = m->tfree;
        _Atomic uint64_t *tile = tile_at(m, id);
        m->tfree = (uint32_t)atomic_load_explicit(&tile[0], memory_order_relaxed);
        m->nfree--;
        for (int w = 0; w < DISTMAP_TILE_WORDS; w++) atomic_init(&tile[w], 0);
        return id;
    }
    const uint32_t id = m->ntiles;
    const size_t seg = id >> DISTMAP_TSEG_SHIFT;
    if (seg >= DISTMAP_TSEG_MAX) return 0;
    /* The segment table from mmap too: only its first page becomes resident. */
    if (!m->tseg && !(m->tseg = tree_mmap(DISTMAP_TSEG_MAX * sizeof *m->tseg))) return 0;
    if (!m->tseg[seg] && !(m->tseg[seg] = tree_mmap(TSEG_BYTES))) return 0;
    m->ntiles++;
    return id;
}

/* Set the bit of the leaf at absolute leaf coordinates (lx, ly) in grid g
 * (which has tile ids and covers it), making its tile if needed. Returns 1
 * if the bit was new, 0 if it was set already, -1 out of memory. The tile
 * is zero before its id is published, and the bit is stored with release,
 * so a reader that sees either sees a valid word. */
static int leafbit_set(distmap *m, distmap_grid *g, int64_t lx, int64_t ly)
{
    const size_t slot = (size_t)((ly >> DISTMAP_TILE_SHIFT) + g->toff) * g->tw +
                        (size_t)((lx >> DISTMAP_TILE_SHIFT) + g->toff);
    uint32_t id = atomic_load_explicit(&g->tix[slot], memory_order_relaxed);
    if (id == DISTMAP_TILE_UNKNOWN) return 0; /* dropped: its bits are not kept */
    if (!id) {
        if (!(id = tile_new(m))) return -1;
        atomic_store_explicit(&g->tix[slot], id, memory_order_release);
    }
    _Atomic uint64_t *tile = tile_at(m, id);
    _Atomic uint64_t *word = &tile[((ly >> 3) & 3) * 4 + ((lx >> 3) & 3)];
    const uint64_t bit = UINT64_C(1) << ((ly & 7) * 8 + (lx & 7));
    const uint64_t w = atomic_load_explicit(word, memory_order_relaxed);
    if (w & bit) return 0;
    atomic_store_explicit(word, w | bit, memory_order_release);
    return 1;
}

/* 1 if the leaf's bit is set or not kept (distmap_add would set nothing). */
static int leafbit_get(const distmap *m, const distmap_grid *g, int64_t lx, int64_t ly)
{
    int unknown = 0;
    const uint64_t w = distmap_leaf_word(m, g, lx >> 3, ly >> 3, &unknown);
    return unknown || (int)((w >> ((ly & 7) * 8 + (lx & 7))) & 1);
}

int distmap_init(distmap *m, int dim, int bits, int64_t margin_units)
{
    m->dim = dim;
    m->bits = bits;
    m->margin = margin_units;
    m->disabled = 0;
    m->particles = 0;
    m->budget_min = DISTMAP_BUDGET_MIN;
    m->budget_per_particle = dim == 3 ? DISTMAP_BUDGET_PER_PARTICLE_3D : DISTMAP_BUDGET_PER_PARTICLE;
    atomic_init(&m->grid, NULL);
    atomic_init(&m->leaves, 0);
    atomic_init(&m->epoch, 0);
    m->retired_bytes = 0;
    m->old = NULL;
    m->bytes = 0;
    m->tseg = NULL;
    m->ntiles = 1;
    m->tfree = 0;
    m->nfree = 0;
    m->leaf_interior = DISTMAP_LEAF_INTERIOR;
    m->near_min = 0;
    return 0;
}

void distmap_quiesce(distmap *m)
{
    while (m->old) {
        distmap_grid *next = m->old->retired;
        grid_free(m->old);
        m->old = next;
    }
    m->retired_bytes = 0;
}

void distmap_reclaim(distmap *m, uint64_t oldest_seen)
{
    /* The list is newest first: cut it at the first grid a reader may still
     * hold, free everything older. */
    distmap_grid **link = &m->old;
    while (*link && (*link)->retired_at >= oldest_seen) link = &(*link)->retired;
    distmap_grid *g = *link;
    *link = NULL;
    while (g) {
        distmap_grid *next = g->retired;
        m->retired_bytes -= g->bytes;
        grid_free(g);
        g = next;
    }
}

void distmap_free(distmap *m)
{
    distmap_quiesce(m);
    grid_free(atomic_load_explicit(&m->grid, memory_order_relaxed));
    atomic_store_explicit(&m->grid, NULL, memory_order_relaxed);
    m->bytes = 0;
    tiles_free(m);
}

/* ---- one level's cells ---------------------------------------------- */

static inline size_t cell_index(const distmap_level *L, int64_t x, int64_t y, int64_t z)
{
    return ((size_t)z * L->width + (size_t)y) * L->width + (size_t)x;
}

static inline unsigned cell_get(const distmap_level *L, size_t i)
{
    if (!L->nibble) return atomic_load_explicit(&L->cell[i], memory_order_relaxed);
    return (atomic_load_explicit(&L->cell[i >> 1], memory_order_relaxed) >> ((i & 1) * 4)) & 15u;
}

/* Only the single writer stores, so a nibble's read-modify-write of its
 * byte cannot lose the other nibble; readers see either byte, both valid. */
static inline void cell_set(distmap_level *L, size_t i, unsigned v)
{
    if (!L->nibble) {
        atomic_store_explicit(&L->cell[i], (uint8_t)v, memory_order_release);
        return;
    }
    const unsigned sh = (unsigned)(i & 1) * 4;
    const unsigned b = atomic_load_explicit(&L->cell[i >> 1], memory_order_relaxed);
    atomic_store_explicit(&L->cell[i >> 1], (uint8_t)((b & ~(15u << sh)) | v << sh),
                          memory_order_release);
}

static uint64_t level_cells(const distmap_level *L, int dim)
{
    uint64_t n = (uint64_t)L->width * L->width;
    return dim == 3 ? n * L->width : n;
}

/* Replace the current grid by g (or by none); the old one is freed at once
 * when no reader can hold it, else kept until quiesce. */
static void publish(distmap *m, distmap_grid *g, int concurrent)
{
    distmap_grid *old = atomic_load_explicit(&m->grid, memory_order_relaxed);
    atomic_store_explicit(&m->grid, g, memory_order_release);
    m->bytes = g ? g->bytes : 0;
    if (!old) return;
    if (concurrent) {
        /* Retired at this epoch; readers that see a later one no longer
         * hold it (distmap_reclaim). */
        old->retired_at = atomic_load_explicit(&m->epoch, memory_order_relaxed);
        old->retired = m->old;
        m->old = old;
        m->retired_bytes += old->bytes;
        atomic_store_explicit(&m->epoch, old->retired_at + 1, memory_order_release);
    } else {
        grid_free(old);
    }
}

static void disable(distmap *m, int concurrent)
{
    m->disabled = 1;
    publish(m, NULL, concurrent);
}

/* Two-pass chessboard distance transform in place: afterwards every cell is
 * min(its value, 1 + each neighbour's value, cap), the exact chessboard
 * distance to the zero cells when every value started as an upper bound. */
static void transform(distmap_level *L, int dim)
{
    const int64_t w = L->width;
    const int64_t nz = dim == 3 ? w : 1;
    for (int pass = 0; pass < 2; pass++) {
        const int64_t step = pass == 0 ? 1 : -1;
        for (int64_t z = pass == 0 ? 0 : nz - 1; z >= 0 && z < nz; z += step)
            for (int64_t y = pass == 0 ? 0 : w - 1; y >= 0 && y < w; y += step)
                for (int64_t x = pass == 0 ? 0 : w - 1; x >= 0 && x < w; x += step) {
                    const size_t i = cell_index(L, x, y, z);
                    unsigned v = cell_get(L, i);
                    if (v == 0) continue;
                    const unsigned v0 = v;
                    /* The neighbours already visited in this pass: those
                     * before (after) this cell in raster order. */
                    for (int64_t dz = dim == 3 ? -1 : 0; dz <= (dim == 3 ? 1 : 0); dz++)
                        for (int64_t dy = -1; dy <= 1; dy++)
                            for (int64_t dx = -1; dx <= 1; dx++) {
                                const int64_t off = (dz * w + dy) * w + dx;
                                if (off * step >= 0) continue;
                                const int64_t X = x + dx, Y = y + dy, Z = z + dz;
                                if (X < 0 || X >= w || Y < 0 || Y >= w || Z < 0 || Z >= nz)
                                    continue;
                                const unsigned u = cell_get(L, cell_index(L, X, Y, Z)) + 1u;
                                if (u < v) v = u;
                            }
                    if (v != v0) cell_set(L, i, v);
                }
    }
}

static int level_alloc(distmap_level *L, int dim, int bits, int nibble, unsigned cap, int64_t half)
{
    L->bits = bits;
    L->nibble = nibble;
    L->cap = cap;
    L->width = (uint32_t)((half << 1) >> bits);
    const uint64_t n = level_cells(L, dim);
    const size_t bytes = (size_t)(nibble ? (n + 1) / 2 : n);
    L->bytes = bytes;
    L->cell = tree_mmap(bytes);
    if (!L->cell) return -1;
    const uint8_t fill = (uint8_t)(nibble ? cap | cap << 4 : cap);
    for (size_t i = 0; i < bytes; i++) atomic_init(&L->cell[i], fill);
    return 0;
}

/* 2D, serial: the new fine level L (cells of 2^bits over [-half, half)^2)
 * grown in place from the old grid's fine level O, whose cells it places
 * at offset `off` (cells, a multiple of 4): the array is extended by
 * mremap (pages move, nothing is copied), rows move to their new places
 * from the top down (each row's new place is at or above its old one), and
 * the new cells get the cap. So a growing grid never holds two fine levels,
 * which made the map's peak twice its budget. O is left empty (its grid is
 * freed next). Returns 0, or -1 with O untouched (then allocate anew). */
/* ThreadSanitizer does not intercept mremap (google/sanitizers#1099): its
 * shadow keeps the old accesses of a moved range, and two engines in two
 * threads (an ensemble) that later map the same address read as a race.
 * Under TSan the level is made anew instead, as while workers run. */
#if defined(__SANITIZE_THREAD__)
#define DISTMAP_NO_MREMAP 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define DISTMAP_NO_MREMAP 1
#endif
#endif
#ifdef DISTMAP_NO_MREMAP
#define DISTMAP_IN_PLACE 0
#else
#define DISTMAP_IN_PLACE 1
#endif

static int level_grow_in_place2(distmap_level *L, int bits, int64_t half, distmap_level *O, int64_t off)
{
    if (!DISTMAP_IN_PLACE) return -1;
    L->bits = bits;
    L->nibble = 1;
    L->cap = DISTMAP_FINE_CAP;
    L->width = (uint32_t)((half << 1) >> bits);
    const size_t w = L->width, ow = O->width, len = ow / 2;
    if (w % 2 || ow % 2 || off % 2 || off < 0 || (size_t)off + ow > w) return -1;
    L->bytes = w * w / 2;
    void *p = mremap((void *)O->cell, O->bytes, L->bytes, MREMAP_MAYMOVE);
    if (p == MAP_FAILED) return -1;
    O->cell = NULL;
    L->cell = p;
    uint8_t *c = p;
    const uint8_t fill = (uint8_t)(DISTMAP_FINE_CAP | DISTMAP_FINE_CAP << 4);
    size_t end = L->bytes; /* the lowest byte already in its new place */
    for (size_t y = ow; y-- > 0;) {
        const size_t dst = ((y + (size_t)off) * w + (size_t)off) / 2, src = y * len;
        /* Between this row's new end and the next row's new start: new
         * cells, over old bytes of rows already moved (dst >= src). */
        memset(c + dst + len, fill, end - dst - len);
        memmove(c + dst, c + src, len);
        end = dst;
    }
    memset(c, fill, end);
    return 0;
}

static uint64_t fine_bytes(int dim, int64_t half, int bits)
{
    const uint64_t w = (uint64_t)((half << 1) >> bits);
    return (dim == 3 ? w * w * w : w * w) / 2;
}

/* A new grid that covers [-h, h)^dim (h rounded up to whole coarse cells),
 * filled from the old one (or with the caps) and completed by the
 * transform. The fine cells are the finest (>= m->bits, never finer than
 * the old grid's) whose level fits the memory budget; when they coarsen,
 * the new levels are made from the old fine level's occupied cells. */
/* Tile slots on each side of 0 over a grid of half side `half` (tiles are
 * aligned to absolute coordinates; half may be less than a tile). */
static int64_t tile_off(int64_t half)
{
    const int shift = DISTMAP_LEAFBIT_SHIFT + DISTMAP_TILE_SHIFT;
    return (half + ((int64_t)1 << shift) - 1) >> shift;
}

static uint32_t tile_width(int64_t half)
{
    return (uint32_t)(2 * tile_off(half));
}

/* Mark in g (which has tile ids) the leaves of the old grid's fine cells
 * that hold a particle (its cells are the leaves): the first coarsening. */
static int tiles_from_leaf_cells(distmap *m, distmap_grid *g, const distmap_grid *old)
{
    const distmap_level *O = &old->lv[0];
    const int64_t ow = O->width, off = old->half >> TREE_LEAF_BITS;
    for (int64_t y = 0; y < ow; y++)
        for (int64_t x = 0; x < ow; x++)
            if (cell_get(O, cell_index(O, x, y, 0)) == 0 &&
                leafbit_set(m, g, x - off, y - off) < 0)
                return -1;
    return 0;
}

/* The tile ids of a new coarsened 2D grid g: the old grid's tiles (they
 * stay where they are, in absolute leaf coordinates, so the new grid names
 * the same ones), or, at the first coarsening, new tiles for the leaves the
 * old grid's fine cells mark. Returns 0, or -1 out of memory. */
/* 1 if tile (tx, ty) (absolute tile coordinates) lies wholly within
 * distance rin of the seed. */
static int tile_inside(int64_t tx, int64_t ty, double rin)
{
    const int shift = DISTMAP_LEAFBIT_SHIFT + DISTMAP_TILE_SHIFT;
    const double s = (double)((int64_t)1 << shift);
    const double fx = fmax(fabs((double)tx * s), fabs((double)(tx + 1) * s));
    const double fy = fmax(fabs((double)ty * s), fabs((double)(ty + 1) * s));
    return fx * fx + fy * fy < rin * rin;
}

static int grid_tiles(distmap *m, distmap_grid *g, const distmap_grid *old, double rin)
{
    g->tw = tile_width(g->half);
    g->toff = tile_off(g->half);
    g->tix = tree_mmap(tix_bytes(g));
    if (!g->tix) {
        g->tw = 0;
        return -1;
    }
    g->bytes += tix_bytes(g);
    if (old && old->tix) {
        const int64_t d = g->toff - old->toff;
        for (size_t y = 0; y < old->tw; y++)
            for (size_t x = 0; x < old->tw; x++) {
                uint32_t id = atomic_load_explicit(&old->tix[y * old->tw + x], memory_order_relaxed);
                if (!id) continue;
                if (id != DISTMAP_TILE_UNKNOWN &&
                    tile_inside((int64_t)x - old->toff, (int64_t)y - old->toff, rin)) {
                    atomic_store_explicit(&tile_at(m, id)[0], m->tfree, memory_order_relaxed);
                    m->tfree = id;
                    m->nfree++;
                    id = DISTMAP_TILE_UNKNOWN;
                }
                atomic_init(&g->tix[(y + (size_t)d) * g->tw + x + (size_t)d], id);
            }
    } else if (old && old->lv[0].bits == TREE_LEAF_BITS) {
        return tiles_from_leaf_cells(m, g, old);
    }
    return 0;
}

/* The fine cells' side (bits) for a grid that covers [-h, h)^dim, never
 * finer than the old grid's: the finest whose level fits the memory budget;
 * *half_out: h rounded up to whole coarse cells of that size. serial: no
 * other thread reads (2D: the fine level grows in place, and gets the
 * larger serial budget, distmap.h). */
static int fine_bits(const distmap *m, const distmap_grid *old, int64_t h, int serial, int64_t *half_out)
{
    const int dim = m->dim;
    int fb = m->bits;
    if (old && old->lv[0].bits > fb) fb = old->lv[0].bits;
    const int serial2 = serial && dim == 2;
    const double per = m->budget_per_particle * (double)m->particles * (serial2 ? DISTMAP_SERIAL_2D_FACTOR : 1);
    const double budget = per > (double)m->budget_min ? per : (double)m->budget_min;
    int64_t half;
    for (;;) {
        const int64_t side = (int64_t)1 << (fb + DISTMAP_COARSE_SHIFT);
        half = (h + side - 1) / side * side;
        /* Coarsened 2D cells come with the leaf bits: the fine level
         * gets a share of the budget (distmap.h); serially, the whole of
         * the per-particle part. */
        double fine_budget = budget;
        if (dim == 2 && fb > TREE_LEAF_BITS) {
            fine_budget = (double)m->budget_min / DISTMAP_LEAF_FINE_SHARE;
            const double part = serial2 ? per : per / DISTMAP_LEAF_FINE_SHARE;
            if (part > fine_budget) fine_budget = part;
        }
        if ((double)fine_bytes(dim, half, fb) <= fine_budget || fb >= 24) break;
        fb++;
    }
    *half_out = half;
    return fb;
}

/* rin: tiles of the old grid wholly within it are dropped (0: none). */
/* 1 when a grid of half side `half` and fine cells of 2^fb units can be
 * made: whole coarse cells, width and cell count in range. */
static int shape_ok(const distmap *m, int64_t half, int fb)
{
    if (fb < m->bits || fb > 24 || half <= 0 || half % ((int64_t)1 << (fb + DISTMAP_COARSE_SHIFT)))
        return 0;
    const int64_t w = (half << 1) >> fb;
    if (w <= 0 || w >= (1 << 21)) return 0;
    uint64_t n = (uint64_t)w * (uint64_t)w;
    if (m->dim == 3) n *= (uint64_t)w;
    return n <= DISTMAP_MAX_CELLS;
}

/* steal: the old grid when no other thread reads it (its 2D fine level
 * may then be grown in place, level_grow_in_place2), else NULL. */
static distmap_grid *grid_make(distmap *m, const distmap_grid *old, int64_t h, double rin,
                               distmap_grid *steal)
{
    const int dim = m->dim;
    int64_t half;
    const int fb = fine_bits(m, old, h, steal != NULL || !old, &half);
    if (!shape_ok(m, half, fb)) return NULL;
    distmap_grid *g = calloc(1, sizeof *g);
    if (!g) return NULL;
    g->half = half;
    const int in_place = steal && steal == old && dim == 2 && old->lv[0].bits == fb &&
                         level_grow_in_place2(&g->lv[0], fb, half, &steal->lv[0], (half - old->half) >> fb) == 0;
    if ((!in_place && level_alloc(&g->lv[0], dim, fb, 1, DISTMAP_FINE_CAP, half)) ||
        level_alloc(&g->lv[1], dim, fb + DISTMAP_COARSE_SHIFT, 0, DISTMAP_COARSE_CAP, half)) {
        grid_free(g);
        return NULL;
    }
    g->bytes = g->lv[0].bytes + g->lv[1].bytes;
    if (dim == 2 && fb > TREE_LEAF_BITS && grid_tiles(m, g, old, rin)) {
        grid_free(g);
        return NULL;
    }
    if (!old) return g;
    if (old->lv[0].bits == fb) {
        for (int l = in_place; l < 2; l++) {
            distmap_level *L = &g->lv[l];
            const distmap_level *O = &old->lv[l];
            const int64_t off = (half - old->half) >> L->bits;
            const int64_t ow = O->width;
            for (int64_t z = 0; z < (dim == 3 ? ow : 1); z++)
                for (int64_t y = 0; y < ow; y++)
                    for (int64_t x = 0; x < ow; x++)
                        cell_set(L, cell_index(L, x + off, y + off, dim == 3 ? z + off : 0),
                                 cell_get(O, cell_index(O, x, y, z)));
        }
    } else {
        const distmap_level *O = &old->lv[0];
        const int64_t ow = O->width;
        for (int64_t z = 0; z < (dim == 3 ? ow : 1); z++)
            for (int64_t y = 0; y < ow; y++)
                for (int64_t x = 0; x < ow; x++) {
                    if (cell_get(O, cell_index(O, x, y, z)) != 0) continue;
                    const int64_t oc[3] = {x, y, z};
                    for (int l = 0; l < 2; l++) {
                        distmap_level *L = &g->lv[l];
                        int64_t c[3] = {0, 0, 0};
                        for (int a = 0; a < dim; a++)
                            c[a] = ((oc[a] << O->bits) - old->half + half) >> L->bits;
                        cell_set(L, cell_index(L, c[0], c[1], c[2]), 0);
                    }
                }
    }
    for (int l = 0; l < 2; l++) {
        /* The copied cells are exact already (every zero cell lies in the
         * old grid), and a new cell is more than margin / cell side cells
         * from every zero cell (each particle lies margin inside the old
         * grid): where that reaches the cap, the new cells' cap is exact
         * too and the transform would change nothing. At leaf cells that
         * is the fine level (margin >= 4096 units = 16 cells > 15), which
         * holds nearly all the cells. */
        if (old->lv[0].bits == fb && (m->margin >> g->lv[l].bits) + 1 >= (int64_t)g->lv[l].cap)
            continue;
        transform(&g->lv[l], dim);
    }
    return g;
}

/* Half side that holds p with the margin, with room to grow. */
static int64_t wanted_half(const distmap *m, const int64_t *p, int64_t at_least)
{
    int64_t r = 0;
    for (int a = 0; a < m->dim; a++) {
        const int64_t x = p[a] < 0 ? -p[a] : p[a];
        if (x > r) r = x;
    }
    int64_t h = (r + m->margin) + (r + m->margin) / 8 + 1;
    return h < at_least ? at_least : h;
}

static int covers(const distmap *m, const distmap_grid *g, const int64_t *p)
{
    for (int a = 0; a < m->dim; a++)
        if (p[a] - m->margin < -g->half || p[a] + m->margin >= g->half) return 0;
    return 1;
}

/* Mark the cell at level coordinates c occupied and lower the cells around
 * it to their chessboard distance r from it, shell by shell (the cells at
 * distance exactly r), while a shell changes. That gives every cell
 * min(old value, r), as a breadth-first pass from c would: the map was
 * exact, so 1-Lipschitz, and a cell at r whose value drops has a neighbour
 * at r - 1 (one step towards c on every axis) whose value dropped too. So
 * shell r is looked at only within one cell of the box of the cells that
 * changed on shell r - 1, and a shell where nothing drops ends it. A cell
 * looked at costs one load, where a breadth-first pass loads the 3^dim - 1
 * neighbours of every cell it lowers (and keeps a queue). */
static void count_leaf(distmap *m)
{
    atomic_store_explicit(&m->leaves, atomic_load_explicit(&m->leaves, memory_order_relaxed) + 1,
                          memory_order_release);
}

/* count: the level's cells are the leaves (m->leaves counts them). */
static void mark(distmap *m, distmap_level *L, const int64_t *c, int count)
{
    const int dim = m->dim;
    const int64_t w = L->width;
    const int64_t cc[3] = {c[0], c[1], dim == 3 ? c[2] : 0};
    const size_t i0 = cell_index(L, cc[0], cc[1], cc[2]);
    if (cell_get(L, i0) == 0) return;
    cell_set(L, i0, 0);
    if (count) count_leaf(m);
    /* The box of the cells changed on the last shell: [blo, bhi] per axis. */
    int64_t blo[3], bhi[3];
    for (int a = 0; a < 3; a++) blo[a] = bhi[a] = cc[a];
    for (int64_t r = 1; r < (int64_t)L->cap; r++) {
        int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, nlo[3], nhi[3];
        for (int a = 0; a < dim; a++) {
            lo[a] = blo[a] - 1 > cc[a] - r ? blo[a] - 1 : cc[a] - r;
            hi[a] = bhi[a] + 1 < cc[a] + r ? bhi[a] + 1 : cc[a] + r;
            if (lo[a] < 0) lo[a] = 0;
            if (hi[a] > w - 1) hi[a] = w - 1;
        }
        for (int a = 0; a < 3; a++) {
            nlo[a] = INT64_MAX;
            nhi[a] = INT64_MIN;
        }
        for (int64_t z = lo[2]; z <= hi[2]; z++) {
            const int zface = dim == 3 && (z == cc[2] - r || z == cc[2] + r);
            for (int64_t y = lo[1]; y <= hi[1]; y++) {
                const size_t row = cell_index(L, 0, y, z);
                const int face = zface || y == cc[1] - r || y == cc[1] + r;
                /* Off the faces only the two ends of the row are on the shell. */
                const int64_t step = face ? 1 : 2 * r;
                for (int64_t x = face ? lo[0] : cc[0] - r; x <= hi[0]; x += step) {
                    if (x < lo[0] || cell_get(L, row + (size_t)x) <= (unsigned)r) continue;
                    cell_set(L, row + (size_t)x, (unsigned)r);
                    const int64_t at[3] = {x, y, z};
                    for (int a = 0; a < 3; a++) {
                        if (at[a] < nlo[a]) nlo[a] = at[a];
                        if (at[a] > nhi[a]) nhi[a] = at[a];
                    }
                }
            }
        }
        if (nlo[0] == INT64_MAX) break;
        for (int a = 0; a < 3; a++) {
            blo[a] = nlo[a];
            bhi[a] = nhi[a];
        }
    }
}

int distmap_needs_add(const distmap *m, const int64_t *p)
{
    const distmap_grid *g = atomic_load_explicit(&m->grid, memory_order_acquire);
    if (!g || !covers(m, g, p)) return 1;
    for (int l = 0; l < 2; l++) {
        int64_t c[3] = {0, 0, 0};
        for (int a = 0; a < m->dim; a++) c[a] = (p[a] + g->half) >> g->lv[l].bits;
        if (distmap_level_value(&g->lv[l], c, m->dim) != 0) return 1;
    }
    if (g->tix && !leafbit_get(m, g, p[0] >> DISTMAP_LEAFBIT_SHIFT, p[1] >> DISTMAP_LEAFBIT_SHIFT)) return 1;
    return 0;
}

int distmap_add(distmap *m, const int64_t *p, uint64_t particles, int concurrent)
{
    if (m->disabled) return 0;
    distmap_grid *g = atomic_load_explicit(&m->grid, memory_order_relaxed);
    if (!g || !covers(m, g, p)) {
        /* Stored only here, where it sizes the new grid's budget: a write
         * per particle would move this cache line between inserting
         * threads. */
        m->particles = particles;
        /* Interior tiles are dropped only while no other thread reads. */
        double r = 0;
        for (int a = 0; a < m->dim; a++) r += (double)p[a] * (double)p[a];
        const double rin = concurrent ? 0.0 : m->leaf_interior * sqrt(r);
        distmap_grid *ng = grid_make(m, g, wanted_half(m, p, g ? g->half : 0), rin, concurrent ? NULL : g);
        if (!ng) {
            disable(m, concurrent);
            return 0;
        }
        publish(m, ng, concurrent);
        g = ng;
    }
    /* The leaf bit first: a reader that sees the cells lowered may look
     * for the leaf. */
    if (g->tix) {
        const int set = leafbit_set(m, g, p[0] >> DISTMAP_LEAFBIT_SHIFT, p[1] >> DISTMAP_LEAFBIT_SHIFT);
        if (set < 0) {
            disable(m, concurrent);
            return 0;
        }
        if (set) count_leaf(m);
    }
    for (int l = 0; l < 2; l++) {
        int64_t c[3] = {0, 0, 0};
        for (int a = 0; a < m->dim; a++) c[a] = (p[a] + g->half) >> g->lv[l].bits;
        mark(m, &g->lv[l], c, l == 0 && !g->tix);
    }
    return 0;
}

typedef struct rebuild_ctx {
    distmap *m;
    distmap_grid *g;
    int64_t r;      /* the largest |coordinate| */
    int64_t lo, hi; /* the smallest and the largest coordinate */
} rebuild_ctx;

static int max_coord(const int64_t *p, void *user)
{
    rebuild_ctx *b = user;
    for (int a = 0; a < b->m->dim; a++) {
        const int64_t x = p[a] < 0 ? -p[a] : p[a];
        if (x > b->r) b->r = x;
        if (p[a] < b->lo) b->lo = p[a];
        if (p[a] > b->hi) b->hi = p[a];
    }
    return 0;
}

static int zero_cells(const int64_t *p, void *user)
{
    rebuild_ctx *b = user;
    for (int l = 0; l < 2; l++) {
        distmap_level *L = &b->g->lv[l];
        int64_t c[3] = {0, 0, 0};
        for (int a = 0; a < b->m->dim; a++) c[a] = (p[a] + b->g->half) >> L->bits;
        cell_set(L, cell_index(L, c[0], c[1], c[2]), 0);
    }
    if (b->g->tix &&
        leafbit_set(b->m, b->g, p[0] >> DISTMAP_LEAFBIT_SHIFT, p[1] >> DISTMAP_LEAFBIT_SHIFT) < 0)
        return -1;
    return 0;
}

/* Forget the map before a rebuild; 0 when the tree is empty (then the
 * map stays empty). */
static int rebuild_reset(distmap *m, const tree *t)
{
    distmap_grid *old = atomic_load_explicit(&m->grid, memory_order_relaxed);
    atomic_store_explicit(&m->grid, NULL, memory_order_relaxed);
    grid_free(old);
    distmap_quiesce(m);
    tiles_free(m);
    m->disabled = 0;
    m->bytes = 0;
    m->particles = tree_count(t);
    /* Cached views of the old map (search_block2) must look again. */
    atomic_store_explicit(&m->leaves, atomic_load_explicit(&m->leaves, memory_order_relaxed) + 1,
                          memory_order_release);
    return m->particles != 0;
}

/* Mark the tree's particles in g and publish it (or disable the map). */
static int rebuild_fill(distmap *m, const tree *t, distmap_grid *g)
{
    rebuild_ctx b = {m, g, 0, 0, 0};
    if (!g || tree_visit(t, zero_cells, &b)) {
        grid_free(g);
        m->disabled = 1;
        return 0;
    }
    for (int l = 0; l < 2; l++) transform(&g->lv[l], m->dim);
    publish(m, g, 0);
    return 0;
}

int distmap_rebuild(distmap *m, const tree *t)
{
    if (!rebuild_reset(m, t)) return 0;
    rebuild_ctx b = {m, NULL, 0, 0, 0};
    tree_visit(t, max_coord, &b);
    const int64_t p[3] = {b.r, b.r, b.r};
    return rebuild_fill(m, t, grid_make(m, NULL, wanted_half(m, p, 0), 0.0, NULL));
}

int distmap_shape_get(const distmap *m, distmap_shape *s)
{
    const distmap_grid *g = atomic_load_explicit(&m->grid, memory_order_acquire);
    memset(s, 0, sizeof *s);
    s->particles = m->particles;
    if (!g) return 0;
    s->half = g->half;
    s->bits = g->lv[0].bits;
    if (!g->tix) return 0;
    s->tw = g->tw;
    if (!(s->unknown = malloc((size_t)g->tw * g->tw))) return -1;
    for (size_t i = 0; i < (size_t)g->tw * g->tw; i++)
        s->unknown[i] = atomic_load_explicit(&g->tix[i], memory_order_relaxed) == DISTMAP_TILE_UNKNOWN;
    return 0;
}

int distmap_rebuild_as(distmap *m, const tree *t, const distmap_shape *s)
{
    if (s->half == 0) { /* the run had no map (disabled) */
        rebuild_reset(m, t);
        publish(m, NULL, 0);
        m->disabled = 1;
        m->particles = s->particles;
        return 0;
    }
    rebuild_ctx b = {m, NULL, 0, 0, 0};
    tree_visit(t, max_coord, &b);
    /* Every particle within the grid as covers() has it (the grid is
     * [-half, half): a coordinate of -(half - margin) is covered, and such
     * a run's checkpoints were refused while |x| + margin >= half was
     * asked). */
    const int inside = b.hi + m->margin < (int64_t)s->half && b.lo - m->margin >= -(int64_t)s->half;
    const int tiles = m->dim == 2 && s->bits > TREE_LEAF_BITS;
    /* No grid is made finer than its budget allows (fine_bits: the serial
     * one is the largest), so a forged shape cannot ask for more memory. */
    const double most = m->budget_per_particle * (double)s->particles * (m->dim == 2 ? DISTMAP_SERIAL_2D_FACTOR : 1);
    const double budget = most > (double)m->budget_min ? most : (double)m->budget_min;
    if (!shape_ok(m, s->half, s->bits) || !inside || s->particles == 0 ||
        s->particles > tree_count(t) || (uint32_t)(tiles ? tile_width(s->half) : 0) != s->tw ||
        (s->bits < 24 && (double)fine_bytes(m->dim, s->half, s->bits) > budget))
        return 1;
    for (size_t i = 0; i < (size_t)s->tw * s->tw; i++)
        if (s->unknown[i] > 1) return 1;
    if (!rebuild_reset(m, t)) return 1;
    m->particles = s->particles;
    distmap_grid *g = calloc(1, sizeof *g);
    if (g) {
        g->half = s->half;
        if (level_alloc(&g->lv[0], m->dim, s->bits, 1, DISTMAP_FINE_CAP, s->half) ||
            level_alloc(&g->lv[1], m->dim, s->bits + DISTMAP_COARSE_SHIFT, 0, DISTMAP_COARSE_CAP, s->half) ||
            (tiles && grid_tiles(m, g, NULL, 0.0))) {
            grid_free(g);
            g = NULL;
        } else {
            g->bytes += g->lv[0].bytes + g->lv[1].bytes;
            for (size_t i = 0; i < (size_t)s->tw * s->tw; i++)
                if (s->unknown[i]) atomic_store_explicit(&g->tix[i], DISTMAP_TILE_UNKNOWN, memory_order_relaxed);
        }
    }
    return rebuild_fill(m, t, g);
}
