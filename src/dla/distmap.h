/*
 * distmap.h - a coarse distance map of the cluster for far distance queries.
 *
 * Dense grids of cubic cells over the box [-half, half)^dim, which holds
 * every particle with a margin. Each cell keeps v = the chessboard
 * (Chebyshev) distance, in cells, from it to the nearest cell holding a
 * particle centre, capped (v = cap means "at least cap"). So every particle
 * lies outside the block of cells within v - 1 of the query's cell, and the
 * distance from the query point to the outside of that block is a lower
 * bound on its distance to the cluster: a load or two and a few compares
 * instead of a tree search. Two levels (below): fine cells of at least one
 * leaf, 4-bit values; coarse cells 4 times larger, byte values. A bound is
 * used only where v >= 2, so it is never below one fine cell (> D + eps),
 * and near the cluster the tree search decides.
 *
 * Updates: a particle in a cell that was not yet occupied sets it to 0 and a
 * pass over the shells of cells around it lowers the cells whose distance
 * drops (each cell only ever decreases). A particle that lands too near
 * the grid's edge makes a larger grid (old values copied, new cells filled
 * by a two-pass chessboard transform; in 2D while no other thread reads,
 * the fine level grows in place by mremap, so a growing grid does not hold
 * two fine levels at once). Everything is derived from the particle positions alone:
 * distmap_rebuild makes it from a tree (after a checkpoint load), with the
 * same cell values as the incrementally built map wherever both reach.
 *
 * Concurrency (PDLA). Readers never lock: the grid pointer and the cells are
 * C11 atomics (release stores, acquire loads). The writer (serialised by the
 * engine's node mutex) updates the map BEFORE the particle is published in
 * the tree, so a reader that already sees a lowered cell gets a smaller
 * (conservative) bound, and one that sees a stale cell answers for the
 * cluster as it was a moment before, exactly like a tree search that misses
 * a particle appended meanwhile (the WALK_OVERLAP re-check path). The 2D
 * leaf bits follow the same rule: a tile is zeroed before its id is stored
 * (release) in the grid's tile ids, and a bit is set (release) before the
 * particle is published; a tile never moves and is freed only with the map.
 * A new grid names the old grid's tiles before it is published, and new
 * tiles are made in the current grid only, so a reader that caches bits
 * keys them by the tree's count, read (acquire) before the grid: a bit set
 * for a particle published by then is in the grid it then reads. A spot
 * the insertion re-check then turns down leaves its cells marked: a fine
 * cell at 0 then has no leaf behind it, which search_block2 allows for, and
 * the bounds around it are merely smaller than they could be. A grid
 * replaced while workers run is kept (retired) until distmap_free or
 * distmap_quiesce, as a reader may still hold it.
 */
#ifndef PDLA_SRC_DISTMAP_H
#define PDLA_SRC_DISTMAP_H
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "tree.h"

/* Two levels: fine cells of 2^bits units hold 4-bit values (capped at 15),
 * coarse cells of 2^(bits + 2) units hold bytes (capped at 255), so far
 * walkers get long jumps and the fine level costs half a byte a cell. */
#define DISTMAP_FINE_CAP 15u
#define DISTMAP_COARSE_CAP 255u
#define DISTMAP_COARSE_SHIFT 2

/* Fine cell side 2^bits units: one leaf, so the fine cells are the leaves
 * (search_block2 relies on it), and more than D + eps (<= 192 units). When
 * the fine level would outgrow its memory budget, max(512 KiB, 0.04 bytes
 * per particle), the grid's fine cells coarsen (2, 4, ... leaves;
 * search_block2 then defers to the tree). A 2D cluster passes 512 KiB at
 * leaf cells near 1.5e6 particles. 2D grids made while no other thread
 * reads (the serial phase) get DISTMAP_SERIAL_2D_FACTOR times the
 * per-particle budget, 0.2 bytes/particle, for the fine level alone: there
 * it grows in place (no second copy while a grid grows), and half chunks
 * (tree.h) took the 2D tree from 3.96 to 3.6 bytes/particle. That keeps
 * 2-leaf cells to 1e7 (2D 1e7: -6 to -10% time in paired runs, peak RSS
 * 3.8 bytes/particle; runs/bench-serial/issue12-half20-2026-11-29.md).
 * While workers run, the map keeps the smaller budget: replaced grids are
 * kept until no reader holds them. */
#ifndef DISTMAP_SERIAL_2D_FACTOR
#define DISTMAP_SERIAL_2D_FACTOR 5
#endif
#define DISTMAP_BITS TREE_LEAF_BITS
/* The budget macros may be set at build time (-D) to force coarsened
 * cells at small N, for measurements (callgrind at 1e5) only. */
#ifndef DISTMAP_BUDGET_MIN
#define DISTMAP_BUDGET_MIN ((size_t)1 << 19)
#endif
#ifndef DISTMAP_BUDGET_PER_PARTICLE
#define DISTMAP_BUDGET_PER_PARTICLE 0.04
#endif
/* 2D leaf bits. Once the 2D fine cells coarsen, the map also keeps one bit
 * per leaf (256 units), set when a particle lands in it, so the walk near
 * the cluster keeps the resolution of leaf cells (search_block2: the 3 x 3
 * leaf block, and beyond it the Euclidean distance to the nearest marked
 * leaf within the words of 8 x 8 leaves around the walker, which reach at
 * least DISTMAP_LEAF_REACH leaves). Bits live in tiles of 32 x 32 leaves (16
 * words, 128 bytes), made only where a particle lands, from a pool of
 * segments that never move (2^DISTMAP_TSEG_SHIFT tiles each); each grid
 * holds the tile ids over its area (4 bytes per tile slot). They cost about
 * 0.035 bytes/particle in 2D (2D DLA: ~300 marked leaves a tile); the fine
 * level then gets a share of the budget only (it serves the bound beyond the
 * bits' reach). One bit per 2 x 2 leaves (a third of the tiles) was measured
 * slower: more jumps and more tree look-ups
 * (runs/bench-serial/issue12-map12-2026-11-25.md). */
#define DISTMAP_LEAFBIT_SHIFT TREE_LEAF_BITS /* one bit a leaf */
#define DISTMAP_TILE_SHIFT 5        /* tile side 2^5 leaves */
#define DISTMAP_TILE_WORDS 16       /* 4 x 4 words of 8 x 8 leaves */
#define DISTMAP_TSEG_SHIFT 10       /* tiles per pool segment: 2^10 (128 KiB) */
/* Segments: 2^28 tiles, 32 GiB of tiles at most, more than a cluster of
 * 2^32 particles marks at any resolution (about 340 particles a tile at
 * resolution 128, 3600 at 32); the table is mmap'd, so only the pages of
 * the segments in use become resident. Running out disables the map (a
 * grid without bits would be needed, as readers trust a missing tile). */
#define DISTMAP_TSEG_MAX ((size_t)1 << 18)
/* Tiles that lie wholly within DISTMAP_LEAF_INTERIOR of the farthest
 * particle's distance from the seed when a grid grows are dropped from the
 * new grid and reused (serial phases only: no other reader may hold them):
 * their slot then reads "unknown" (DISTMAP_TILE_UNKNOWN), and queries there
 * use the tree. The interior within 0.35 holds about 0.35^1.71 = 17% of
 * the leaves; at 2D 1e7 dropping it cost no measurable time, while 0.6
 * (42%) gave back half the speed-up: walkers do reach deep into the
 * fjords. */
#ifndef DISTMAP_LEAF_INTERIOR
#define DISTMAP_LEAF_INTERIOR 0.35
#endif
#define DISTMAP_TILE_UNKNOWN UINT32_MAX
/* A multiple of 8, at most 24. 16 (5 x 5 words) saved 5% of the jumps but
 * cost 30% more instructions at forced-coarse 2D 1e5 (the rows' refills). */
#ifndef DISTMAP_LEAF_REACH
#define DISTMAP_LEAF_REACH 8
#endif
#ifndef DISTMAP_LEAF_FINE_SHARE
#define DISTMAP_LEAF_FINE_SHARE 6   /* the fine level's share of the budget: 1/6 (not serial) */
#endif
/* 3D: the target is 6 bytes/particle at 1e6 and the tree takes ~4.8 in
 * peak RSS. Measured at 3D 1e6 (VmHWM difference to 1e4, seed 1): budget
 * 2.0 -> 6.18 B/p, 22.4 s; 1.5 -> 5.83 B/p, 22.9 s; 1.0 -> 4.69 B/p, 26.1 s. */
#define DISTMAP_BUDGET_PER_PARTICLE_3D 1.5

/* 3D: distmap_bound's near answer is used from this many diameters
 * (distmap.near_min = this x resolution): in the prototype, 3, 4 and 5
 * diameters took 14.1, 14.1 and 14.0 s at 3D 1e6 (two alternated rounds
 * each; 15.1 s without), the same within the noise
 * (runs/bench-serial/issue12-near22-2026-11-30.md). */
#define DISTMAP_NEAR_MIN_DIAMETERS 4

typedef struct distmap_level {
    _Atomic uint8_t *cell;        /* width^dim cells, x fastest; fine: two per byte */
    uint32_t width;               /* cells per axis */
    int bits;                     /* cell side 2^bits units */
    int nibble;                   /* 4-bit cells (the fine level) */
    unsigned cap;
    size_t bytes;                 /* of the cell array */
} distmap_level;

typedef struct distmap_grid {
    int64_t half;                 /* covers [-half, half)^dim units, whole coarse cells */
    distmap_level lv[2];          /* 0 fine, 1 coarse */
    size_t bytes;                 /* of both levels' cells and the tile ids */
    /* 2D with coarsened fine cells: the id of the leaf-bit tile over each
     * 32 x 32 leaves of the grid (tw x tw, x fastest; 0: no particle there
     * yet). NULL otherwise (no leaf bits: the fine cells are the leaves,
     * or 3D). */
    _Atomic uint32_t *tix;
    uint32_t tw;                  /* 2 toff */
    int64_t toff;                 /* slot of the tile at absolute tile coordinate 0 */
    uint64_t retired_at;          /* the map's epoch when it was replaced */
    struct distmap_grid *retired; /* older grids a reader may still hold */
} distmap_grid;

typedef struct distmap {
    /* Read by walkers on every jump near the cluster; each group on its own
     * cache line (PDLA_CACHE_PAD), as the writer's fields change with every
     * particle and `leaves` with every new leaf. */
    _Atomic(distmap_grid *) grid; /* NULL: no map (readers use the tree) */
    _Atomic uint64_t epoch;       /* grids replaced while readers ran, so far */
    PDLA_CACHE_PAD(pad_grid_);
    _Atomic uint64_t leaves;      /* fine cells marked occupied so far (= leaves) */
    PDLA_CACHE_PAD(pad_leaves_);
    /* The writer's (under the engine's node mutex while workers run); dim
     * and margin are fixed at init, so readers may read them too. */
    int dim;
    int bits;                     /* fine cell side 2^bits units, >= TREE_LEAF_BITS */
    int64_t margin;               /* units the grid keeps beyond every particle */
    int disabled;                 /* set for good when a grid cannot be made */
    uint64_t particles;           /* cluster size at the last grid change (budget) */
    size_t budget_min;            /* the fine level may use max(budget_min, */
    double budget_per_particle;   /*   budget_per_particle x particles) bytes */
    distmap_grid *old;            /* retired grids, newest first */
    size_t retired_bytes;         /* their cells */
    size_t bytes;                 /* bytes of the current grid */
    /* The leaf-bit tiles (2D, coarsened): segments of 2^DISTMAP_TSEG_SHIFT
     * tiles, each DISTMAP_TILE_WORDS words; tile id i (>= 1) is word
     * (i & mask) * 16 of segment i >> shift. A segment pointer is written
     * before any id in it is published (release), so readers that found
     * the id read it without further ordering. */
    _Atomic uint64_t **tseg;      /* DISTMAP_TSEG_MAX pointers, NULL until used */
    uint32_t ntiles;              /* tiles handed out, plus the unused id 0 */
    uint32_t tfree;               /* dropped tiles to reuse (linked by word 0), 0: none */
    uint32_t nfree;
    double leaf_interior;         /* DISTMAP_LEAF_INTERIOR (tests may change it) */
    /* 3D: distmap_bound's near answer (within one fine cell of an occupied
     * one), used only when it is at least this many units; 0: never (2D,
     * and distmap_init's default). Fixed before any reader runs. */
    int64_t near_min;
    PDLA_CACHE_PAD(pad_end_);
} distmap;

/* margin_units: how far beyond the farthest particle queries are expected
 * (the birth circle); points beyond the grid fall back to the tree. */
int distmap_init(distmap *m, int dim, int bits, int64_t margin_units);
void distmap_free(distmap *m);

/* Account a particle centre at p (call before publishing it in the tree).
 * `particles`: the cluster's size counting p (sizes the memory budget).
 * `concurrent`: other threads may read the map now (old grids are kept).
 * Returns 0; on allocation failure the map disables itself (readers fall
 * back to the tree), which is not an error. */
int distmap_add(distmap *m, const int64_t *p, uint64_t particles, int concurrent);

/* 0 when distmap_add(p) would change nothing (p's cells are marked in a
 * grid that covers it), else 1. Reads only: workers call it without a lock
 * so that most particles skip the writer's mutex. */
int distmap_needs_add(const distmap *m, const int64_t *p);

/* Free grids retired while workers ran; only when no reader runs. */
void distmap_quiesce(distmap *m);

/* Reclamation while readers run (epochs). A reader holds a grid only inside
 * one query; between queries (a worker's walks) it publishes the epoch it
 * sees, distmap_epoch. Once every reader has published at least E, no
 * reader holds a grid retired before epoch E: distmap_reclaim(m, E) frees
 * those (the caller serialises it with the writer: the engine's node
 * mutex). Without it, a long parallel phase would keep every grid the map
 * ever outgrew (about 4.7 times the current one: 0.2 bytes/particle). */
static inline uint64_t distmap_epoch(const distmap *m)
{
    return atomic_load_explicit(&m->epoch, memory_order_acquire);
}
void distmap_reclaim(distmap *m, uint64_t oldest_seen);

/* Rebuild the whole map from the particles of a tree (e.g. after loading a
 * checkpoint): the cells hold the same values as the incrementally built
 * map wherever both grids reach. Returns 0 (or the map is disabled). */
int distmap_rebuild(distmap *m, const tree *t);

/* What a checkpoint keeps of the map, so that distmap_rebuild_as remakes
 * the grid the run had (the cells follow from the particles): without it a
 * rebuilt grid has another size and, once cells coarsen, other bounds, and
 * the resumed serial run's walk (not its law) departs from the unstopped
 * run's (2D past ~1.5e6 particles). half 0: no map (disabled). particles:
 * the cluster size the budget was last taken at. tw, unknown: 2D leaf
 * bits, which of the tw x tw tile slots were dropped as interior. */
typedef struct distmap_shape {
    int64_t half;
    int bits;
    uint64_t particles;
    uint32_t tw;
    uint8_t *unknown; /* tw * tw flags 0/1, malloc'd (distmap_shape_get) */
} distmap_shape;
/* Returns 0, or -1 when out of memory. */
int distmap_shape_get(const distmap *m, distmap_shape *s);
/* Rebuild to shape s. Returns 0 (or the map is disabled, out of memory),
 * or 1 when s is no shape this map can have for this tree (nothing done). */
int distmap_rebuild_as(distmap *m, const tree *t, const distmap_shape *s);

/* search_block2, the map-assisted search, is declared in search.h. */

/* Bytes of the leaf-bit tiles in use (0 when there are none). */
size_t distmap_tile_bytes(const distmap *m);

/* The word of 8 x 8 leaf bits whose leaves have absolute leaf coordinates
 * (wx * 8.., wy * 8..) (leaf coordinates: units >> DISTMAP_LEAFBIT_SHIFT; bit
 * (y & 7) * 8 + (x & 7)), from grid g, which must have tile ids. 0 when no
 * tile is there, or the word lies outside the grid (no particle lies
 * there); *unknown is set to 1 (else left) where the tile was dropped (the
 * bits there are not kept). Readers call it without a lock. */
static inline __attribute__((always_inline)) uint64_t distmap_leaf_word(const distmap *m,
                                                                        const distmap_grid *g,
                                                                        int64_t wx, int64_t wy,
                                                                        int *unknown)
{
    const int64_t tx = (wx >> 2) + g->toff, ty = (wy >> 2) + g->toff;
    if ((uint64_t)tx >= g->tw || (uint64_t)ty >= g->tw) return 0;
    const uint32_t id = atomic_load_explicit(&g->tix[(size_t)ty * g->tw + (size_t)tx],
                                             memory_order_acquire);
    if (!id) return 0;
    if (id == DISTMAP_TILE_UNKNOWN) {
        *unknown = 1;
        return 0;
    }
    const _Atomic uint64_t *tile =
        m->tseg[id >> DISTMAP_TSEG_SHIFT] + (size_t)(id & ((1u << DISTMAP_TSEG_SHIFT) - 1)) * DISTMAP_TILE_WORDS;
    return atomic_load_explicit(&tile[(wy & 3) * 4 + (wx & 3)], memory_order_acquire);
}

/* The value of cell (c) of a level whose L->nibble is `nibble` (a constant
 * where the level is known: the fine level is always 4-bit, the coarse one
 * always bytes, and the walker's look-up then has no branch on it). */
static inline __attribute__((always_inline)) unsigned distmap_level_value_k(const distmap_level *L,
                                                                            const int64_t *c,
                                                                            const int dim,
                                                                            const int nibble)
{
    size_t idx = 0;
    for (int a = dim - 1; a >= 0; a--) idx = idx * L->width + (size_t)c[a];
    if (!nibble) return atomic_load_explicit(&L->cell[idx], memory_order_acquire);
    const unsigned b = atomic_load_explicit(&L->cell[idx >> 1], memory_order_acquire);
    return (b >> ((idx & 1) * 4)) & 15u;
}

/* The value of cell (c) of a level, and the distance bound it gives. */
static inline __attribute__((always_inline)) unsigned distmap_level_value(const distmap_level *L,
                                                                          const int64_t *c,
                                                                          const int dim)
{
    return L->nibble ? distmap_level_value_k(L, c, dim, 1) : distmap_level_value_k(L, c, dim, 0);
}

/* Every particle is outside the cells within v - 1 of p's cell: the distance
 * from p to the outside of that block is (v - 1) cells plus the distance from
 * p to the outside of its own cell, min over axes of r + 1 and side - r
 * (r: p's offset in its cell; u = p + half, the grid coordinates, >= 0).
 * The second term does not depend on v. */
static inline __attribute__((always_inline)) int64_t distmap_cell_edge(const int64_t *u, int bits,
                                                                       const int dim)
{
    const int64_t side = (int64_t)1 << bits;
    int64_t best = side;
    for (int a = 0; a < dim; a++) {
        const int64_t r = u[a] & (side - 1), below = r + 1, above = side - r;
        if (below < best) best = below;
        if (above < best) best = above;
    }
    return best;
}

static inline __attribute__((always_inline)) int64_t distmap_block_bound(const int64_t *u, int bits,
                                                                         int64_t v, const int dim)
{
    return (v - 1) * ((int64_t)1 << bits) + distmap_cell_edge(u, bits, dim);
}

/* p outside grid g: every particle of g lies in [-half + margin, half -
 * margin) on every axis (distmap_add grows the grid before one would not),
 * so the largest gap from p to that box on one axis bounds its distance to
 * them (chessboard, never above the Euclidean), and it is at least the
 * margin. The grid is a square about the farthest particle's largest
 * coordinate, while the birth circle's radius is its Euclidean distance:
 * a cluster whose farthest arms lie off the axes leaves parts of the circle
 * outside the grid. Walkers there got no map bound, and in 2D after the
 * fine cells coarsen the leaf bits bounded them by at most ~8 leaves a jump
 * (runs/bench-serial/issue12-outside16-2026-11-29.md: 2D 1e8 seed 1 with
 * the Euclidean leaf bound took 143 jumps a particle, 7.3 returns). */
static inline __attribute__((always_inline)) int64_t distmap_outside_bound(const distmap *m,
                                                                           const distmap_grid *g,
                                                                           const int64_t *p,
                                                                           const int dim)
{
    const int64_t lo = m->margin - g->half, hi = g->half - m->margin - 1;
    int64_t b = 0;
    for (int a = 0; a < dim; a++) {
        const int64_t d = p[a] > hi ? p[a] - hi : p[a] < lo ? lo - p[a] : 0;
        if (d > b) b = d;
    }
    return b;
}

/* 3D: the bound from p's fine cell c (value v, p's offset r in it) and its
 * six face neighbours. Every particle is at least v' - 1 cells from
 * neighbour c' grown by one unit on each side (its chessboard value v'
 * says every occupied cell is v' cells away on some axis), and p is r_a
 * units from the grown box of the neighbour below it on axis a, side - 1 -
 * r_a from the one above: so v' - 1 cells less that is a bound too. Where
 * c is an occupied cell's neighbour (v = 1), c's own term is p's distance
 * to c's edge, as distmap_block_bound. The faces say most where p sits
 * near a face whose neighbour is farther from the cluster than c, which is
 * where c's own bound, from the nearest face, says least. Far from the
 * cluster that only saves cheap jumps; what pays is the near answer, which
 * replaces exact tree queries: 3D 1e6 3.3-3.5% less time (two seeds,
 * alternated), 3D 1e5 7.5%, 3D 1e4 1.3% more
 * (runs/bench-serial/issue12-near22-2026-11-30.md). 2D gains no time
 * (its near queries are cheaper): it keeps the plain bound. */
static inline __attribute__((always_inline)) int64_t distmap_faces3(const distmap_level *L,
                                                                    const int64_t *c,
                                                                    const int64_t *u, int64_t v)
{
    const int64_t side = (int64_t)1 << L->bits;
    int64_t b = distmap_block_bound(u, L->bits, v, 3);
    for (int a = 0; a < 3; a++) {
        const int64_t r = u[a] & (side - 1);
        int64_t n[3] = {c[0], c[1], c[2]};
        n[a] = c[a] - 1;
        const int64_t lo = ((int64_t)distmap_level_value_k(L, n, 3, 1) - 1) * side - r;
        n[a] = c[a] + 1;
        const int64_t hi = ((int64_t)distmap_level_value_k(L, n, 3, 1) - 1) * side - (side - 1 - r);
        const int64_t m = lo > hi ? lo : hi;
        if (m > b) b = m;
    }
    return b;
}

/* Lower bound (units) on the distance from p to every particle, or 0 when
 * the map has nothing useful: then the caller searches the tree. Within
 * one fine cell of an occupied cell that is 0, except in 3D where the
 * faces (distmap_faces3) give at least m->near_min. A non-zero bound is
 * at least one fine cell, or near_min, or the grid's margin when p lies
 * outside the grid. */
static inline __attribute__((always_inline)) int64_t distmap_bound(const distmap *m,
                                                                   const int64_t *p,
                                                                   const int dim)
{
    const distmap_grid *g = atomic_load_explicit(&m->grid, memory_order_acquire);
    if (!g) return 0;
    const uint64_t span = (uint64_t)g->half << 1;
    int64_t u[3], c[3];
    const int cb = g->lv[1].bits, fb = g->lv[0].bits;
    for (int a = 0; a < dim; a++) {
        u[a] = p[a] + g->half;
        if (__builtin_expect((uint64_t)u[a] >= span, 0)) return distmap_outside_bound(m, g, p, dim);
        c[a] = u[a] >> fb;
    }
    /* The fine cell first: near the cluster (half the look-ups) it is
     * within one cell of an occupied one, and then so is its coarse cell
     * (two fine cells at chessboard distance 1 lie in the same or adjacent
     * coarse cells), whose bound would be 0: the answer is 0 without the
     * coarse look-up. */
    const int64_t vf = distmap_level_value_k(&g->lv[0], c, dim, 1);
    /* The 3D faces read c's six neighbours: not on the grid's border. */
    int inner = dim == 3;
    for (int a = 0; a < dim; a++) inner &= c[a] >= 1 && c[a] < (int64_t)g->lv[0].width - 1;
    if (vf < 2) {
        if (!inner || vf == 0 || !m->near_min) return 0;
        const int64_t b = distmap_faces3(&g->lv[0], c, u, 1);
        return b >= m->near_min ? b : 0;
    }
    const int64_t cf[3] = {c[0], c[1], dim == 3 ? c[2] : 0};
    for (int a = 0; a < dim; a++) c[a] = u[a] >> cb;
    const int64_t vc = distmap_level_value_k(&g->lv[1], c, dim, 0);
    int64_t coarse = 0;
    if (vc >= 2) {
        coarse = distmap_block_bound(u, cb, vc, dim);
        if (vc >= 5) return coarse; /* beyond anything the fine level can say */
    }
    const int64_t fine = inner ? distmap_faces3(&g->lv[0], cf, u, vf) : distmap_block_bound(u, fb, vf, dim);
    return fine > coarse ? fine : coarse;
}
#endif
