/*
 * tree.h - the memory-compact bucket quadtree (2D) / octree (3D) that holds
 * the cluster.
 *
 * Geometry. Positions are integers (units). Leaves are aligned boxes of
 * 256 units per side, so a particle inside a leaf is stored as one byte per
 * coordinate relative to the leaf's low corner. A node at level L is an
 * aligned box of side 256 << L; leaves are level 0. The root, at level
 * root_level >= 1, is the box [-S/2, S/2)^dim with S = 256 << root_level,
 * centred on the seed; it grows by one level (doubling S) whenever a
 * particle lands outside it. Child k of a node holds the half-boxes with
 * bit a of k set where coordinate a is in the upper half.
 *
 * Memory. Three pools of fixed-size records linked by 32-bit indices
 * (0 is null): inner nodes (2^dim child indices), chunks (10 particles of
 * dim bytes, stored as x[10] y[10] (z[10]) so a leaf scan vectorises, plus
 * one 32-bit link: 24 bytes in 2D, 36 in 3D) and, in 2D only, half chunks
 * (5 particles; two share a 32-byte record laid out like a chunk with two
 * links, so a half is read with a chunk's strides and vector loads).
 * A leaf is just its list of chunks: a level-1 node's child index is the
 * leaf's first chunk. Every chunk but the last is full; the last one's
 * link, having no next chunk to name, holds its own particle count
 * (1..10), and chunk indices 1..10 are never handed out so the two cannot
 * be confused. A half's index has bit 31 set (TREE_HALF_BIT) over
 * 2 x record + side. No leaf record, no count field: a 2D particle costs
 * 2.4 bytes in a full chunk.
 *
 * Why halves: a leaf holds ~13 particles in 2D (~23 in 3D), so a last
 * chunk of 10 slots left half empty cost 0.94 of the tree's 3.96
 * bytes/particle at 2D 1e6. Serially, a leaf starts with a half; a full
 * last chunk is followed by a half; a half that overflows is copied, with
 * the new particle, into a chunk that takes its place, and the half goes
 * to a free list. So a serially grown leaf is full chunks and one half or
 * chunk at the end (2D 1e6: 3.34 -> 2.98 bytes/particle in chunks). While
 * workers read, nothing moves (a reader may be inside the half): a full
 * half is followed by a chunk, and new leaves and new last chunks are
 * chunks, as before halves (leaves grown as half, chunk, half, ... would
 * cost 3.5 bytes/particle). A half moved out as the leaf's first chunk
 * changes the leaf's head: head_moves counts that, and caches of heads
 * check it. Free halves are zero (link 0) and reused lowest index first (a
 * min-heap), so the layout depends only on which are free: a checkpoint
 * that stores the pools gives the resumed run the same layout.
 *
 * Why 2D only: halves cost time where chains mix them with chunks (the
 * record's address and link depend on the half bit, a branch the
 * predictor misses: 2D 1e6 about +5% CPU in simultaneous pairs, 3D 1e6
 * +4%), and 3D meets its memory target without them (5.4-5.6
 * bytes/particle at 1e6 and 1e7 against 6.0), while 2D needs them for its
 * 4.0 at 1e7 (runs/bench-serial/issue12-half20-2026-11-29.md).
 *
 * Pools grow by whole segments that never move, so a record's address is
 * stable for the life of the tree (lock-free readers need that) and growth
 * never copies.
 *
 * Concurrency (PDLA). Readers never lock. Everything a writer publishes is a
 * C11 atomic stored with release and loaded with acquire: child indices,
 * chunk links (and with them the fill counts), the root (index and level in
 * one word) and the particle count. A record is fully written before the
 * index that makes it reachable is published, and a reader uses only the
 * particle slots below the count it acquired. 3D reads nothing else (vector
 * loads of whole records only where tree_vector_ok), so no byte is read
 * while it is written. 2D vector loads read whole records everywhere: slots
 * are stored as relaxed atomic bytes (leaf_append) and, where a record may
 * be written, read as relaxed atomic words (search.c chunk_min2_shared),
 * and the lanes past the count are masked. Writers serialise among
 * themselves (engine.c's mutexes).
 */
#ifndef PDLA_SRC_TREE_H
#define PDLA_SRC_TREE_H
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <string.h>

#define TREE_LEAF_BITS 8
#define TREE_LEAF_SIDE (1 << TREE_LEAF_BITS)
#define TREE_CHUNK_CAP 10
#define TREE_HALF_CAP 5
#define TREE_HALF_BIT 0x80000000u
/* The root never grows past this level: side 2^31 covers every coordinate
 * allowed by PDLA_MAX_CLUSTER_RADIUS_UNITS with room to spare. */
#define TREE_MAX_LEVEL 23

/* Padding that keeps fields written by inserting threads off the cache lines
 * walkers read on every query: with P workers, each insertion would
 * otherwise cost every other worker a cache miss per look-up (false sharing
 * grows with P). 64 bytes apart guarantees different lines without asking
 * the allocator for alignment (the engine comes from calloc). */
#define PDLA_CACHE_LINE 64
#define PDLA_CACHE_PAD(name) char name[PDLA_CACHE_LINE]

#define POOL_SEG_BITS 16
#define POOL_SEG_SIZE (1u << POOL_SEG_BITS)
#define POOL_MAX_SEGS (1u << (32 - POOL_SEG_BITS))

/* A growable array of fixed-size records addressed by 32-bit index. The
 * fields every look-up reads come first; the fill counts, written as records
 * are added, sit a cache line away. */
typedef struct tree_pool {
    uint8_t **seg;     /* POOL_MAX_SEGS segment pointers, NULL until used */
    uint32_t elem;     /* bytes per record */
    PDLA_CACHE_PAD(pad_);
    uint32_t count;    /* records in use, including the null record 0 */
    uint32_t nseg;     /* segments allocated */
    PDLA_CACHE_PAD(pad_end_);
} tree_pool;

/* The smallest r >= 0 with r^2 >= r2 (r2 < 2^62), exact: the truncated
 * double sqrt is a first guess never above it (rounding moves r2 by far
 * less than 2r), raised in integers. */
static inline int64_t tree_ceil_sqrt(uint64_t r2)
{
    int64_t r = (int64_t)sqrt((double)r2);
    while ((uint64_t)(r * r) < r2) r++;
    return r;
}

static inline void *pool_at(const tree_pool *p, uint32_t i)
{
    return p->seg[i >> POOL_SEG_BITS] + (size_t)(i & (POOL_SEG_SIZE - 1)) * p->elem;
}

typedef struct tree {
    /* Read on every query; root_word changes only when the root grows. */
    int dim;
    int nchild;          /* 2^dim */
    _Atomic uint64_t root_word; /* root level << 32 | root index in inner */
    uint32_t chunk_bytes;/* 24 (2D) or 36 (3D) */
    tree_pool inner;     /* uint32_t child[nchild] */
    tree_pool chunks;    /* uint8_t rel[dim][10], pad, uint32_t link */
    tree_pool halves;    /* uint8_t rel[dim][10], pad, uint32_t link[2] */
    uint32_t link_half;  /* offset of side 0's link in a half record */
    PDLA_CACHE_PAD(pad_);
    /* Written by every insertion. */
    _Atomic uint64_t count;     /* particles stored */
    uint64_t leaves;     /* leaves created */
    /* Serial writer only (never changes while workers run): */
    uint64_t head_moves; /* leaf heads replaced (a first half moved out) */
    uint32_t *hfree;     /* free half ids, a min-heap */
    uint32_t nfree, capfree;
    PDLA_CACHE_PAD(pad_end_);
} tree;

int tree_init(tree *t, int dim);
void tree_free(tree *t);

/* Insert a particle centre; grows the root as needed. Returns 0, or
 * -1 (out of memory / index space) or -2 (coordinate beyond the root limit).
 * Single writer and no reader (it may move a half chunk): tree_make_path
 * then tree_append(..., 0). While readers run, append with concurrent 1. */
int tree_insert(tree *t, const int64_t *p);

/* Where a particle at p goes: the level-1 node and the child slot of its leaf. */
typedef struct tree_slot {
    uint32_t node;
    uint32_t k;
    int64_t leaf_lo[3];
} tree_slot;

/* Create (and publish) the inner nodes from the root down to the level-1
 * node whose leaf will hold p, growing the root if p lies outside it.
 * Touches only the inner pool: the engine's node mutex guards it. */
int tree_make_path(tree *t, const int64_t *p, tree_slot *slot);

/* A node known to contain a point: where a walk down may start instead
 * of the root (a walker's cached search path, search_path_start). */
typedef struct tree_start {
    uint32_t node;               /* 0: none, start from the root */
    int level;
    int64_t lo[3];
} tree_start;

/* tree_insert from `from` (a node that contains p, or none: then from
 * the root, growing it as needed): the same tree, without the descent's
 * upper levels (at 2D 1e7 the descent from the root, a random inner node
 * per level, was 2.7% of the run). */
int tree_insert_from(tree *t, const int64_t *p, const tree_start *from);

/* The same slot without creating anything: 1 if the nodes down to p's
 * level-1 node exist (then `slot` is what tree_make_path would give), else 0.
 * Reads only, so it needs no lock: most insertions land where the path
 * exists and skip the node mutex. A slot found under an older root stays
 * valid, as the root only grows by adding levels above it. */
int tree_find_slot(const tree *t, const int64_t *p, tree_slot *slot);

/* Append p to the leaf in `slot` (creating the leaf if it is new) and count
 * it. Touches only the chunk pools: the engine's bucket mutex guards them.
 * `concurrent`: readers may be inside the leaf, so nothing is moved or
 * freed (a full half is followed by a chunk, not copied). */
int tree_append(tree *t, const tree_slot *slot, const int64_t *p, int concurrent);

/* Bytes of the records in use (segments are allocated 2^16 records at a
 * time and touched as they fill, so resident memory follows this closely). */
size_t tree_bytes(const tree *t);

typedef struct tree_root {
    uint32_t node;
    int level; /* root side = 256 << level */
} tree_root;

static inline tree_root tree_root_get(const tree *t)
{
    const uint64_t w = atomic_load_explicit(&t->root_word, memory_order_acquire);
    const tree_root r = {(uint32_t)w, (int)(w >> 32)};
    return r;
}

static inline uint64_t tree_count(const tree *t)
{
    return atomic_load_explicit(&t->count, memory_order_acquire);
}

static inline const _Atomic uint32_t *tree_children(const tree *t, uint32_t node)
{
    return (const _Atomic uint32_t *)pool_at(&t->inner, node);
}

static inline uint32_t tree_child(const _Atomic uint32_t *children, uint32_t k)
{
    return atomic_load_explicit(&children[k], memory_order_acquire);
}
/* Chunk c's slots (x at [0..cap), y at [10..), z at [20..)): a chunk's
 * record, or a half's place in its record (side 1 at slot 5). */
static inline const uint8_t *tree_chunk_at(const tree *t, uint32_t c)
{
    if (c & TREE_HALF_BIT) {
        const uint32_t h = c & ~TREE_HALF_BIT;
        return (const uint8_t *)pool_at(&t->halves, h >> 1) + TREE_HALF_CAP * (h & 1);
    }
    return (const uint8_t *)pool_at(&t->chunks, c);
}
/* Bytes from chunk c's slots to its link. */
static inline uint32_t tree_link_offset(const tree *t, uint32_t c)
{
    return (c & TREE_HALF_BIT) ? t->link_half + 4 * (c & 1) - TREE_HALF_CAP * (c & 1)
                               : t->chunk_bytes - 4;
}
/* Chunk c's link (chunk: tree_chunk_at(c)): the next chunk's index, or
 * (<= TREE_CHUNK_CAP) the particle count of this last chunk. */
static inline uint32_t tree_chunk_link(const tree *t, uint32_t c, const uint8_t *chunk)
{
    return atomic_load_explicit((const _Atomic uint32_t *)(const void *)(chunk + tree_link_offset(t, c)),
                                memory_order_acquire);
}
/* Slots of chunk c. */
static inline uint32_t tree_cap(uint32_t c) { return (c & TREE_HALF_BIT) ? TREE_HALF_CAP : TREE_CHUNK_CAP; }
/* Particles in chunk c, given its link. */
static inline uint32_t tree_fill(uint32_t c, uint32_t link)
{
    return link <= TREE_CHUNK_CAP ? link : tree_cap(c);
}

/* Whether chunk c (with this link) may be read with plain vector loads,
 * which read every slot of its record: always serially; while workers
 * append, only a full chunk that links on (never written again). Not a
 * half: the record's other half may belong to a leaf being appended to.
 * (2D reads the others with atomic loads, search.c chunk_min2_shared.) */
static inline int tree_vector_ok(uint32_t c, uint32_t link, int concurrent)
{
    return !concurrent || (link > TREE_CHUNK_CAP && !(c & TREE_HALF_BIT));
}

/* The same three accessors for code instantiated per dimension: in 3D the
 * record sizes are constants (36-byte chunks, 8 children of 4 bytes) and
 * there are no halves, so an access is a shift and an add instead of a load,
 * a multiply and a test of the half bit. 2D code calls the general ones. */
#define TREE_CHUNK_BYTES3 36u
#define TREE_INNER_BYTES3 32u
static inline const _Atomic uint32_t *tree_children_d(const tree *t, uint32_t node, const int dim)
{
    if (dim != 3) return tree_children(t, node);
    return (const _Atomic uint32_t *)(const void *)(t->inner.seg[node >> POOL_SEG_BITS] +
                                                    (size_t)(node & (POOL_SEG_SIZE - 1)) *
                                                        TREE_INNER_BYTES3);
}
static inline const uint8_t *tree_chunk_at_d(const tree *t, uint32_t c, const int dim)
{
    if (dim != 3) return tree_chunk_at(t, c);
    /* 3D trees have no halves (tree_init): no half bit to test. */
    return t->chunks.seg[c >> POOL_SEG_BITS] + (size_t)(c & (POOL_SEG_SIZE - 1)) * TREE_CHUNK_BYTES3;
}
static inline uint32_t tree_chunk_link_d(const tree *t, uint32_t c, const uint8_t *chunk, const int dim)
{
    if (dim != 3) return tree_chunk_link(t, c, chunk);
    return atomic_load_explicit((const _Atomic uint32_t *)(const void *)(chunk + TREE_CHUNK_BYTES3 - 4),
                                memory_order_acquire);
}
/* Particles in chunk c, given its link; in 3D every non-last chunk is full. */
static inline uint32_t tree_fill_d(uint32_t c, uint32_t link, const int dim)
{
    if (dim == 3) return link <= TREE_CHUNK_CAP ? link : TREE_CHUNK_CAP;
    return tree_fill(c, link);
}

/* Half side of a root box of this level: the root is [-h, h)^dim. */
static inline int64_t tree_root_half(int root_level)
{
    return (int64_t)TREE_LEAF_SIDE << (root_level - 1);
}

/* Visit every stored particle; fn gets the absolute coordinates. Stops and
 * returns fn's value when it is non-zero. */
typedef int (*tree_visit_fn)(const int64_t *p, void *user);
int tree_visit(const tree *t, tree_visit_fn fn, void *user);

/* The leaf (its first chunk) whose box contains p (0 if none), and its low corner. */
uint32_t tree_find_leaf(const tree *t, const int64_t *p, int64_t *leaf_lo);

/* What a verifying walk of a tree finds: particles, leaves, and the exact
 * sums the gyration state must reproduce. */
typedef struct tree_verify_sums {
    uint64_t count, leaves, r2max;
    __extension__ __int128 s1[3];
    __extension__ unsigned __int128 s2;
} tree_verify_sums;
enum { TREE_VERIFY_ENOMEM = -2 }; /* = PDLA_ENOMEM */
/* Walk a tree read from untrusted storage (a checkpoint): every node and
 * chunk index in range and reached exactly once, no chunk unreached or
 * empty, no fill above its chunk's capacity, every half no leaf holds zero
 * (free), every particle within the coordinate limit. Returns 0 with *bad
 * NULL (or a short static reason) and the sums, or TREE_VERIFY_ENOMEM. */
int tree_verify(const tree *t, tree_verify_sums *sums, const char **bad);

/* After tree_verify passed (or tree_compact): the free list is the halves
 * no leaf holds (tree_verify requires them zero). Returns 0, or -1 when out
 * of memory. */
int tree_free_rebuild(tree *t);

/* Zeroed memory straight from mmap (NULL when none; munmap it), for large
 * arrays that come and go beside the tree: freeing a large malloc block
 * raises glibc's mmap threshold, after which the pools' segments would come
 * from the heap and be zeroed (made resident) whole by calloc. */
void *tree_mmap(size_t bytes);

/* Renumber the inner nodes and the chunks in visiting order (depth first,
 * children in index order, a leaf's chunks in list order), so that a leaf's
 * chunks lie one after another and nearby leaves near each other: a search
 * around a point then touches fewer cache lines and pages (3D 1e6 and 1e7
 * 6-10% less CPU, runs/bench-serial/issue12-compact17-2026-11-29.md). Every particle
 * keeps its leaf and slot, so visits and searches answer the same, in the
 * same order. Pools keep their sizes; 4 bytes a record are borrowed while it
 * runs. Serial only: no reader may run, and indices cached before
 * (search_state) are stale after. Returns 0, or -1 when out of memory (the
 * tree unchanged). */
int tree_compact(tree *t);

/* The distance search over the tree (search.c) is declared in search.h. */
#endif
