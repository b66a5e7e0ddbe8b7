/*
 * tree.c - construction of the bucket quadtree/octree: segmented pools,
 * insertion with root growth, traversal. The distance search lives in
 * search.c; the layout is described in tree.h.
 */
#include "tree.h"

#include "pdla/pdla.h"

#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

static int pool_init(tree_pool *p, uint32_t elem)
{
    p->seg = calloc(POOL_MAX_SEGS, sizeof *p->seg);
    if (!p->seg) return -1;
    p->elem = elem;
    p->nseg = 0;
    p->count = 1; /* record 0 is the null index */
    p->seg[0] = calloc(POOL_SEG_SIZE, elem);
    if (!p->seg[0]) return -1;
    p->nseg = 1;
    return 0;
}

static void pool_free(tree_pool *p)
{
    if (p->seg)
        for (uint32_t s = 0; s < p->nseg; s++) free(p->seg[s]);
    free(p->seg);
    p->seg = NULL;
}

/* Record i's segment, allocated (zeroed) if it is not yet: 0, or -1 when
 * out of memory. */
static int pool_ensure(tree_pool *p, uint32_t i)
{
    const uint32_t s = i >> POOL_SEG_BITS;
    if (s < p->nseg) return 0;
    if (!(p->seg[s] = calloc(POOL_SEG_SIZE, p->elem))) return -1;
    p->nseg = s + 1;
    return 0;
}

/* A new zeroed record; 0 when the index space (indices below `limit`) or
 * memory is exhausted. */
static uint32_t pool_new_below(tree_pool *p, uint32_t limit)
{
    const uint32_t i = p->count;
    if (i >= limit || pool_ensure(p, i)) return 0;
    p->count = i + 1;
    return i;
}

static uint32_t pool_new(tree_pool *p) { return pool_new_below(p, UINT32_MAX); }

int tree_init(tree *t, int dim)
{
    memset(t, 0, sizeof *t);
    t->dim = dim;
    t->nchild = 1 << dim;
    /* 10 particles of dim bytes, padded so the 32-bit next index is aligned. */
    /* tree.h's 3D accessors assume these sizes. */
    _Static_assert((TREE_CHUNK_CAP * 3 + 3) / 4 * 4 + 4 == TREE_CHUNK_BYTES3, "3D chunk size");
    _Static_assert(sizeof(uint32_t) * 8 == TREE_INNER_BYTES3, "3D inner node size");
    t->chunk_bytes = (uint32_t)((TREE_CHUNK_CAP * dim + 3) / 4 * 4 + 4);
    /* A half record: the slots of a chunk, then two links. In 2D 4 bytes
     * of padding keep side 1's vector loads (16 bytes from slot 8 on, that
     * is byte 13) inside the record: 32 bytes. */
    t->link_half = dim == 2 ? 24 : 32; /* 3D makes none (tree.h) */
    if (pool_init(&t->inner, (uint32_t)(sizeof(uint32_t) * (size_t)t->nchild)) ||
        pool_init(&t->chunks, t->chunk_bytes) || (dim == 2 && pool_init(&t->halves, t->link_half + 8))) {
        tree_free(t);
        return -1;
    }
    t->chunks.count = TREE_CHUNK_CAP + 1; /* indices 1..10 would read as counts */
    t->halves.count = 0; /* half ids carry TREE_HALF_BIT: none is 0; 3D: no pool */
    const uint32_t root = pool_new(&t->inner);
    if (!root) {
        tree_free(t);
        return -1;
    }
    atomic_init(&t->root_word, (uint64_t)1 << 32 | root);
    atomic_init(&t->count, 0);
    return 0;
}

void tree_free(tree *t)
{
    pool_free(&t->inner);
    pool_free(&t->chunks);
    pool_free(&t->halves);
    free(t->hfree);
    t->hfree = NULL;
    t->nfree = t->capfree = 0;
}

size_t tree_bytes(const tree *t)
{
    return (size_t)t->inner.count * t->inner.elem + (size_t)t->chunks.count * t->chunks.elem +
           (size_t)t->halves.count * t->halves.elem + (size_t)t->capfree * sizeof *t->hfree;
}

/* ---- the free halves: a min-heap of ids ----------------------------------- */

/* Room for one more free id; -1 when out of memory. */
static int hfree_reserve(tree *t)
{
    if (t->nfree < t->capfree) return 0;
    const uint32_t cap = t->capfree ? t->capfree * 2 : 64;
    uint32_t *h = realloc(t->hfree, (size_t)cap * sizeof *h);
    if (!h) return -1;
    t->hfree = h;
    t->capfree = cap;
    return 0;
}

/* Push a free id (room reserved). */
static void hfree_push(tree *t, uint32_t id)
{
    uint32_t i = t->nfree++;
    while (i > 0 && t->hfree[(i - 1) / 2] > id) {
        t->hfree[i] = t->hfree[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    t->hfree[i] = id;
}

/* Pop the lowest free id (nfree > 0). */
static uint32_t hfree_pop(tree *t)
{
    const uint32_t top = t->hfree[0], last = t->hfree[--t->nfree];
    uint32_t i = 0;
    for (;;) {
        uint32_t k = 2 * i + 1;
        if (k >= t->nfree) break;
        if (k + 1 < t->nfree && t->hfree[k + 1] < t->hfree[k]) k++;
        if (t->hfree[k] >= last) break;
        t->hfree[i] = t->hfree[k];
        i = k;
    }
    if (t->nfree) t->hfree[i] = last;
    return top;
}

int tree_free_rebuild(tree *t)
{
    t->nfree = 0;
    for (uint64_t h = 0; h < 2 * (uint64_t)t->halves.count; h++) {
        const uint32_t c = TREE_HALF_BIT | (uint32_t)h;
        if (tree_chunk_link(t, c, tree_chunk_at(t, c))) continue;
        if (hfree_reserve(t)) return -1;
        t->hfree[t->nfree++] = c; /* ascending: already a heap */
    }
    return 0;
}

static _Atomic uint32_t *children_mut(tree *t, uint32_t node)
{
    return (_Atomic uint32_t *)pool_at(&t->inner, node);
}

/* Publish a child index: the record it names is complete before this. */
static void set_child(tree *t, uint32_t node, uint32_t k, uint32_t child)
{
    atomic_store_explicit(&children_mut(t, node)[k], child, memory_order_release);
}

/* Double the root's side: each old quadrant/octant q moves into a new
 * intermediate node at q, where it is the child nearest the origin
 * (index q with every bit flipped). Readers see either the old root or the
 * complete new one. */
static int tree_grow_root(tree *t)
{
    const tree_root old = tree_root_get(t);
    if (old.level >= TREE_MAX_LEVEL) return -2;
    const uint32_t new_root = pool_new(&t->inner);
    if (!new_root) return -1;
    const uint32_t mask = (uint32_t)t->nchild - 1;
    for (uint32_t q = 0; q <= mask; q++) {
        const uint32_t old_child = tree_child(tree_children(t, old.node), q);
        if (!old_child) continue;
        const uint32_t mid = pool_new(&t->inner);
        if (!mid) return -1;
        set_child(t, mid, q ^ mask, old_child);
        set_child(t, new_root, q, mid);
    }
    /* The old root record stays allocated but unreferenced: one record per
     * growth, at most TREE_MAX_LEVEL in a run. */
    atomic_store_explicit(&t->root_word, (uint64_t)(old.level + 1) << 32 | new_root,
                          memory_order_release);
    return 0;
}

static int inside_root(const tree *t, int root_level, const int64_t *p)
{
    const int64_t h = tree_root_half(root_level);
    for (int a = 0; a < t->dim; a++)
        if (p[a] < -h || p[a] >= h) return 0;
    return 1;
}

static uint8_t *chunk_mut(tree *t, uint32_t c) { return (uint8_t *)(uintptr_t)tree_chunk_at(t, c); }

static void chunk_set_link(tree *t, uint32_t c, uint32_t link)
{
    _Atomic uint32_t *at = (_Atomic uint32_t *)(void *)(chunk_mut(t, c) + tree_link_offset(t, c));
    atomic_store_explicit(at, link, memory_order_release);
}

/* A new zeroed half (its id, with TREE_HALF_BIT), the lowest free one or
 * side 0 of a new record (side 1 then goes to the free list); 0 when out
 * of memory or half ids. */
static uint32_t half_take(tree *t)
{
    if (t->nfree) return hfree_pop(t);
    tree_pool *p = &t->halves;
    const uint32_t r = p->count;
    if (r >= TREE_HALF_BIT / 2 || hfree_reserve(t) || pool_ensure(p, r)) return 0;
    p->count = r + 1;
    hfree_push(t, TREE_HALF_BIT | (2 * r + 1));
    return TREE_HALF_BIT | 2 * r;
}

/* A new chunk (half: a half chunk, 2D only) holding one particle; 0 when
 * out of memory. Not yet reachable, so its fill count needs no ordering
 * until the index is published. */
static uint32_t chunk_new(tree *t, const uint8_t *rel, int half)
{
    half = half && t->dim == 2;
    const uint32_t c = half ? half_take(t) : pool_new_below(&t->chunks, TREE_HALF_BIT);
    if (!c) return 0;
    uint8_t *chunk = chunk_mut(t, c);
    for (int a = 0; a < t->dim; a++) chunk[a * TREE_CHUNK_CAP] = rel[a];
    chunk_set_link(t, c, 1);
    return c;
}

/* Serial only: the full half h (the leaf's last chunk; prev the chunk
 * before it, 0 when h is the leaf's head in `slot`) and one particle more
 * move into a new chunk that takes h's place; h is cleared and freed.
 * Returns 0, 1 when there was no memory for the move (nothing changed), or
 * -1. */
static int half_move_out(tree *t, const tree_slot *slot, uint32_t prev, uint32_t h,
                         const uint8_t *rel)
{
    if (hfree_reserve(t)) return 1;
    const uint32_t c = pool_new_below(&t->chunks, TREE_HALF_BIT);
    if (!c) return 1;
    uint8_t *dst = chunk_mut(t, c), *src = chunk_mut(t, h);
    for (int a = 0; a < t->dim; a++) {
        memcpy(dst + a * TREE_CHUNK_CAP, src + a * TREE_CHUNK_CAP, TREE_HALF_CAP);
        dst[a * TREE_CHUNK_CAP + TREE_HALF_CAP] = rel[a];
    }
    chunk_set_link(t, c, TREE_HALF_CAP + 1);
    if (prev) {
        chunk_set_link(t, prev, c);
    } else {
        set_child(t, slot->node, slot->k, c);
        t->head_moves++;
    }
    for (int a = 0; a < t->dim; a++) memset(src + a * TREE_CHUNK_CAP, 0, TREE_HALF_CAP);
    chunk_set_link(t, h, 0);
    hfree_push(t, h);
    return 0;
}

/* Append a particle (relative to the leaf's low corner) to a leaf's chunks:
 * write the free slot, then publish the new count (or the new chunk). */
static int leaf_append(tree *t, const tree_slot *slot, uint32_t head, const uint8_t *rel,
                       int concurrent)
{
    uint32_t prev = 0, last = head, link;
    while ((link = tree_chunk_link(t, last, tree_chunk_at(t, last))) > TREE_CHUNK_CAP) {
        prev = last;
        last = link;
    }
    const int half = (last & TREE_HALF_BIT) != 0;
    if (link < tree_cap(last)) {
        /* Relaxed atomic bytes (plain stores on x86-64): 2D readers' vector
         * loads read the slots past the count, and the other half of a
         * half record, as atomics while workers append (search.c,
         * chunk_min2_shared); the count's release store publishes the slot. */
        uint8_t *chunk = chunk_mut(t, last);
        for (int a = 0; a < t->dim; a++)
            __atomic_store_n(&chunk[a * TREE_CHUNK_CAP + (int)link], rel[a], __ATOMIC_RELAXED);
        chunk_set_link(t, last, link + 1);
        return 0;
    }
    if (half && !concurrent) {
        const int rc = half_move_out(t, slot, prev, last, rel);
        if (rc <= 0) return rc;
    }
    /* Serially, after a full chunk a half. While workers read, always a
     * chunk: a half could not move out when full, and a leaf grown as
     * half, chunk, half, ... costs more than chunks alone (2D 1e6 leaves:
     * 3.5 against 3.34 bytes/particle). */
    const uint32_t c = chunk_new(t, rel, !half && !concurrent);
    if (!c) return -1;
    chunk_set_link(t, last, c);
    return 0;
}

/* Walk p's path from node `from` (the root, or a node below it; it must
 * contain p) down to its level-1 node. A missing node is made when
 * `maker` is the tree (the writer holding the node mutex); with maker NULL
 * the walk only reads and gives up there.
 * Returns 1 with the slot filled, 0 if a node is missing, -1 when out of
 * memory. */
static int walk_from(const tree *t, tree *maker, const tree_start *from, const int64_t *p,
                     tree_slot *slot)
{
    const int dim = t->dim;
    int64_t lo[3];
    for (int a = 0; a < dim; a++) lo[a] = from->lo[a];
    uint32_t node = from->node;
    for (int level = from->level;; level--) {
        const int64_t half = (int64_t)TREE_LEAF_SIDE << (level - 1);
        uint32_t k = 0;
        for (int a = 0; a < dim; a++)
            if (p[a] >= lo[a] + half) {
                k |= 1u << a;
                lo[a] += half;
            }
        if (level == 1) {
            slot->node = node;
            slot->k = k;
            for (int a = 0; a < dim; a++) slot->leaf_lo[a] = lo[a];
            return 1;
        }
        uint32_t child = tree_child(tree_children(t, node), k);
        if (!child) {
            if (!maker) return 0;
            child = pool_new(&maker->inner);
            if (!child) return -1;
            set_child(maker, node, k, child);
        }
        node = child;
    }
}

static int walk_to_slot(const tree *t, tree *maker, tree_root root, const int64_t *p,
                        tree_slot *slot)
{
    const tree_start from = {.node = root.node, .level = root.level,
                             .lo = {-tree_root_half(root.level), -tree_root_half(root.level),
                                    -tree_root_half(root.level)}};
    return walk_from(t, maker, &from, p, slot);
}

int tree_make_path(tree *t, const int64_t *p, tree_slot *slot)
{
    tree_root root = tree_root_get(t);
    while (!inside_root(t, root.level, p)) {
        const int rc = tree_grow_root(t);
        if (rc) return rc;
        root = tree_root_get(t);
    }
    return walk_to_slot(t, t, root, p, slot) == 1 ? 0 : -1;
}

int tree_find_slot(const tree *t, const int64_t *p, tree_slot *slot)
{
    const tree_root root = tree_root_get(t);
    if (!inside_root(t, root.level, p)) return 0;
    return walk_to_slot(t, NULL, root, p, slot) == 1;
}

int tree_append(tree *t, const tree_slot *slot, const int64_t *p, int concurrent)
{
    uint8_t rel[3];
    for (int a = 0; a < t->dim; a++) rel[a] = (uint8_t)(p[a] - slot->leaf_lo[a]);
    const uint32_t head = tree_child(tree_children(t, slot->node), slot->k);
    if (head) {
        if (leaf_append(t, slot, head, rel, concurrent)) return -1;
    } else {
        const uint32_t c = chunk_new(t, rel, !concurrent);
        if (!c) return -1;
        set_child(t, slot->node, slot->k, c);
        t->leaves++;
    }
    atomic_store_explicit(&t->count, atomic_load_explicit(&t->count, memory_order_relaxed) + 1,
                          memory_order_release);
    return 0;
}

int tree_insert(tree *t, const int64_t *p)
{
    tree_slot slot;
    const int rc = tree_make_path(t, p, &slot);
    return rc ? rc : tree_append(t, &slot, p, 0);
}

int tree_insert_from(tree *t, const int64_t *p, const tree_start *from)
{
    if (!from || !from->node || from->level < 1) return tree_insert(t, p);
    tree_slot slot;
    if (walk_from(t, t, from, p, &slot) != 1) return -1;
    return tree_append(t, &slot, p, 0);
}

uint32_t tree_find_leaf(const tree *t, const int64_t *p, int64_t *leaf_lo)
{
    const tree_root root = tree_root_get(t);
    if (!inside_root(t, root.level, p)) return 0;
    int64_t lo[3];
    for (int a = 0; a < t->dim; a++) lo[a] = -tree_root_half(root.level);
    uint32_t node = root.node;
    for (int level = root.level; level >= 1; level--) {
        const int64_t half = (int64_t)TREE_LEAF_SIDE << (level - 1);
        uint32_t k = 0;
        for (int a = 0; a < t->dim; a++)
            if (p[a] >= lo[a] + half) {
                k |= 1u << a;
                lo[a] += half;
            }
        node = tree_child(tree_children(t, node), k);
        if (!node) return 0;
    }
    for (int a = 0; a < t->dim; a++) leaf_lo[a] = lo[a];
    return node;
}

static int visit_leaf(const tree *t, uint32_t head, const int64_t *lo, tree_visit_fn fn,
                      void *user)
{
    int64_t p[3] = {0, 0, 0};
    for (uint32_t c = head;;) {
        const uint8_t *chunk = tree_chunk_at(t, c);
        const uint32_t link = tree_chunk_link(t, c, chunk);
        const uint32_t m = tree_fill(c, link);
        for (uint32_t j = 0; j < m; j++) {
            for (int a = 0; a < t->dim; a++) p[a] = lo[a] + chunk[a * TREE_CHUNK_CAP + (int)j];
            const int rc = fn(p, user);
            if (rc) return rc;
        }
        if (link <= TREE_CHUNK_CAP) return 0;
        c = link;
    }
}

static int visit_node(const tree *t, uint32_t node, int level, const int64_t *lo,
                      tree_visit_fn fn, void *user)
{
    const int64_t half = (int64_t)TREE_LEAF_SIDE << (level - 1);
    for (int k = 0; k < t->nchild; k++) {
        const uint32_t child = tree_child(tree_children(t, node), (uint32_t)k);
        if (!child) continue;
        int64_t clo[3];
        for (int a = 0; a < t->dim; a++) clo[a] = lo[a] + ((k >> a) & 1) * half;
        const int rc = level == 1 ? visit_leaf(t, child, clo, fn, user)
                                  : visit_node(t, child, level - 1, clo, fn, user);
        if (rc) return rc;
    }
    return 0;
}

int tree_visit(const tree *t, tree_visit_fn fn, void *user)
{
    const tree_root root = tree_root_get(t);
    int64_t lo[3];
    for (int a = 0; a < t->dim; a++) lo[a] = -tree_root_half(root.level);
    return visit_node(t, root.node, root.level, lo, fn, user);
}

/* ---- verification of a tree read from storage ---------------------------- */

/* The state of one verifying walk. */
typedef struct tree_check {
    const tree *t;
    uint64_t *inner_seen, *chunk_seen, *half_seen;
    tree_verify_sums sums;
    const char *bad;
} tree_check;

static int seen(uint64_t *bits, uint32_t i)
{
    const uint64_t m = UINT64_C(1) << (i & 63);
    if (bits[i >> 6] & m) return 1;
    bits[i >> 6] |= m;
    return 0;
}

static void check_leaf(tree_check *c, uint32_t head, const int64_t *lo)
{
    const tree *t = c->t;
    c->sums.leaves++;
    for (uint32_t ch = head;;) {
        const uint32_t h = ch & ~TREE_HALF_BIT;
        const int half = (ch & TREE_HALF_BIT) != 0;
        if (half && t->dim != 2) {
            c->bad = "a half chunk in a 3D tree";
            return;
        }
        if (half ? h >= 2 * (uint64_t)t->halves.count : ch <= TREE_CHUNK_CAP || ch >= t->chunks.count) {
            c->bad = "a chunk index out of range";
            return;
        }
        if (half ? seen(c->half_seen, h) : seen(c->chunk_seen, ch)) {
            c->bad = "a chunk listed twice";
            return;
        }
        const uint8_t *rec = tree_chunk_at(t, ch);
        const uint32_t link = tree_chunk_link(t, ch, rec);
        if (link == 0) {
            c->bad = "an empty chunk";
            return;
        }
        if (link <= TREE_CHUNK_CAP && link > tree_cap(ch)) {
            c->bad = "a chunk filled beyond its slots";
            return;
        }
        const uint32_t m = tree_fill(ch, link);
        for (uint32_t j = 0; j < m; j++) {
            uint64_t r2 = 0;
            for (int a = 0; a < t->dim; a++) {
                const int64_t x = lo[a] + rec[a * TREE_CHUNK_CAP + (int)j];
                if (x <= -PDLA_MAX_CLUSTER_RADIUS_UNITS || x >= PDLA_MAX_CLUSTER_RADIUS_UNITS) {
                    c->bad = "a particle beyond the coordinate limit";
                    return;
                }
                c->sums.s1[a] += x;
                r2 += (uint64_t)(x * x);
            }
            c->sums.s2 += r2;
            if (r2 > c->sums.r2max) c->sums.r2max = r2;
        }
        c->sums.count += m;
        if (link <= TREE_CHUNK_CAP) return;
        ch = link;
    }
}

static void check_node(tree_check *c, uint32_t node, int level, const int64_t *lo)
{
    const tree *t = c->t;
    if (c->bad) return;
    if (node == 0 || node >= t->inner.count) {
        c->bad = "a node index out of range";
        return;
    }
    if (seen(c->inner_seen, node)) {
        c->bad = "a node listed twice";
        return;
    }
    const uint32_t *ch = (const uint32_t *)pool_at(&t->inner, node);
    const int64_t half = (int64_t)TREE_LEAF_SIDE << (level - 1);
    for (int k = 0; k < t->nchild && !c->bad; k++) {
        if (!ch[k]) continue;
        int64_t clo[3] = {0, 0, 0};
        for (int a = 0; a < t->dim; a++) clo[a] = lo[a] + ((k >> a) & 1) * half;
        if (level == 1) check_leaf(c, ch[k], clo);
        else check_node(c, ch[k], level - 1, clo);
    }
}

/* A half with no particle and link 0 (free). */
static int half_is_clear(const tree *t, uint32_t c)
{
    const uint8_t *rec = tree_chunk_at(t, c);
    for (int a = 0; a < t->dim; a++)
        for (int j = 0; j < TREE_HALF_CAP; j++)
            if (rec[a * TREE_CHUNK_CAP + j]) return 0;
    return tree_chunk_link(t, c, rec) == 0;
}

int tree_verify(const tree *t, tree_verify_sums *sums, const char **bad)
{
    tree_check c;
    memset(&c, 0, sizeof c);
    c.t = t;
    *bad = NULL;
    const uint64_t ni = t->inner.count, nc = t->chunks.count, nh = 2 * (uint64_t)t->halves.count;
    c.inner_seen = calloc((ni + 63) / 64, sizeof *c.inner_seen);
    c.chunk_seen = calloc((nc + 63) / 64, sizeof *c.chunk_seen);
    c.half_seen = calloc((nh + 63) / 64 + 1, sizeof *c.half_seen);
    if (!c.inner_seen || !c.chunk_seen || !c.half_seen) {
        free(c.inner_seen);
        free(c.chunk_seen);
        free(c.half_seen);
        return TREE_VERIFY_ENOMEM;
    }
    const tree_root root = tree_root_get(t);
    int64_t lo[3];
    for (int a = 0; a < 3; a++) lo[a] = -tree_root_half(root.level);
    check_node(&c, root.node, root.level, lo);
    uint64_t unseen = 0;
    for (uint64_t i = TREE_CHUNK_CAP + 1; !c.bad && i < nc; i++)
        if (!(c.chunk_seen[i >> 6] >> (i & 63) & 1)) unseen++;
    for (uint64_t h = 0; !c.bad && h < nh; h++)
        if (!(c.half_seen[h >> 6] >> (h & 63) & 1) && !half_is_clear(t, TREE_HALF_BIT | (uint32_t)h))
            c.bad = "a free half chunk that is not empty";
    free(c.inner_seen);
    free(c.chunk_seen);
    free(c.half_seen);
    if (!c.bad && unseen) c.bad = "chunks that no leaf holds";
    *bad = c.bad;
    *sums = c.sums;
    return 0;
}

/* ---- compaction: records renumbered in depth-first order ----------------- */

/* The new index of every old record (UINT32_MAX: none yet), and the next
 * new index to hand out, for the inner nodes, the chunks and the halves
 * (by id, without TREE_HALF_BIT). */
typedef struct tree_perm {
    uint32_t *inner, *chunk, *half;
    uint32_t next_inner, next_chunk, next_half;
} tree_perm;

/* Chunk c's new index. */
static uint32_t perm_chunk(const tree_perm *m, uint32_t c)
{
    return (c & TREE_HALF_BIT) ? TREE_HALF_BIT | m->half[c & ~TREE_HALF_BIT] : m->chunk[c];
}

/* Number the records below `node` (a node at `level`) in visiting order:
 * the node, then its children in index order, each leaf's chunks in list
 * order. Recursion depth <= TREE_MAX_LEVEL. */
static void perm_number(const tree *t, tree_perm *m, uint32_t node, int level)
{
    m->inner[node] = m->next_inner++;
    for (int k = 0; k < t->nchild; k++) {
        const uint32_t child = tree_child(tree_children(t, node), (uint32_t)k);
        if (!child) continue;
        if (level > 1) {
            perm_number(t, m, child, level - 1);
            continue;
        }
        for (uint32_t c = child;;) {
            if (c & TREE_HALF_BIT) m->half[c & ~TREE_HALF_BIT] = m->next_half++;
            else m->chunk[c] = m->next_chunk++;
            const uint32_t link = tree_chunk_link(t, c, tree_chunk_at(t, c));
            if (link <= TREE_CHUNK_CAP) break;
            c = link;
        }
    }
}

/* Rewrite every index held below `node` (child indices, chunk links) to
 * its new value; the records themselves have not moved yet. */
static void perm_relink(tree *t, const tree_perm *m, uint32_t node, int level)
{
    _Atomic uint32_t *ch = children_mut(t, node);
    for (int k = 0; k < t->nchild; k++) {
        const uint32_t child = atomic_load_explicit(&ch[k], memory_order_relaxed);
        if (!child) continue;
        if (level > 1) {
            perm_relink(t, m, child, level - 1);
            atomic_store_explicit(&ch[k], m->inner[child], memory_order_relaxed);
            continue;
        }
        for (uint32_t c = child;;) {
            const uint32_t link = tree_chunk_link(t, c, tree_chunk_at(t, c));
            if (link <= TREE_CHUNK_CAP) break;
            chunk_set_link(t, c, perm_chunk(m, link));
            c = link;
        }
        atomic_store_explicit(&ch[k], perm_chunk(m, child), memory_order_relaxed);
    }
}

/* Move record i of the pool to perm[i] for every i >= first, following
 * the permutation's cycles (each record is copied once or twice); perm
 * ends as the identity. */
static void pool_permute(tree_pool *p, uint32_t *perm, uint32_t first)
{
    uint8_t tmp[64];
    for (uint32_t i = first; i < p->count; i++)
        while (perm[i] != i) {
            const uint32_t j = perm[i];
            uint8_t *a = pool_at(p, i), *b = pool_at(p, j);
            memcpy(tmp, b, p->elem);
            memcpy(b, a, p->elem);
            memcpy(a, tmp, p->elem);
            perm[i] = perm[j];
            perm[j] = j;
        }
}

/* Swap the contents (slots and link) of halves i and j (ids). */
static void half_swap(tree *t, uint32_t i, uint32_t j)
{
    uint8_t *a = chunk_mut(t, TREE_HALF_BIT | i), *b = chunk_mut(t, TREE_HALF_BIT | j);
    uint8_t tmp[TREE_HALF_CAP];
    for (int d = 0; d < t->dim; d++) {
        memcpy(tmp, a + d * TREE_CHUNK_CAP, TREE_HALF_CAP);
        memcpy(a + d * TREE_CHUNK_CAP, b + d * TREE_CHUNK_CAP, TREE_HALF_CAP);
        memcpy(b + d * TREE_CHUNK_CAP, tmp, TREE_HALF_CAP);
    }
    const uint32_t la = tree_chunk_link(t, TREE_HALF_BIT | i, a);
    chunk_set_link(t, TREE_HALF_BIT | i, tree_chunk_link(t, TREE_HALF_BIT | j, b));
    chunk_set_link(t, TREE_HALF_BIT | j, la);
}

/* pool_permute for the halves, by id. */
static void halves_permute(tree *t, uint32_t *perm, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        while (perm[i] != i) {
            const uint32_t j = perm[i];
            half_swap(t, i, j);
            perm[i] = perm[j];
            perm[j] = j;
        }
}

void *tree_mmap(size_t bytes)
{
    void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    return p == MAP_FAILED ? NULL : p;
}

static void index_free(uint32_t *p, size_t n)
{
    if (p) munmap(p, n * sizeof(uint32_t));
}

int tree_compact(tree *t)
{
    _Static_assert(TREE_INNER_BYTES3 <= 64 && TREE_CHUNK_BYTES3 <= 64, "pool_permute's buffer");
    const size_t ni = t->inner.count, nc = t->chunks.count, nh = 2 * (size_t)t->halves.count;
    tree_perm m = {tree_mmap(ni * sizeof(uint32_t)), tree_mmap(nc * sizeof(uint32_t)),
                   tree_mmap((nh + 1) * sizeof(uint32_t)), 1, TREE_CHUNK_CAP + 1, 0};
    if (!m.inner || !m.chunk || !m.half) {
        index_free(m.inner, ni);
        index_free(m.chunk, nc);
        index_free(m.half, nh + 1);
        return -1;
    }
    memset(m.inner, 0xff, ni * sizeof *m.inner);
    memset(m.half, 0xff, nh * sizeof *m.half);
    const tree_root root = tree_root_get(t);
    perm_number(t, &m, root.node, root.level);
    /* Every chunk is reached; the inner records no path reaches (the roots
     * that growth replaced) go last, cleared so they name nothing. */
    for (uint32_t i = 1; i < t->inner.count; i++)
        if (m.inner[i] == UINT32_MAX) {
            memset(pool_at(&t->inner, i), 0, t->inner.elem);
            m.inner[i] = m.next_inner++;
        }
    /* The free halves (clear) go last, after the leaves' halves. */
    for (uint32_t h = 0; h < nh; h++)
        if (m.half[h] == UINT32_MAX) m.half[h] = m.next_half++;
    perm_relink(t, &m, root.node, root.level);
    pool_permute(&t->chunks, m.chunk, TREE_CHUNK_CAP + 1);
    pool_permute(&t->inner, m.inner, 1);
    halves_permute(t, m.half, (uint32_t)nh);
    atomic_store_explicit(&t->root_word, (uint64_t)root.level << 32 | 1u, memory_order_release);
    index_free(m.inner, ni);
    index_free(m.chunk, nc);
    index_free(m.half, nh + 1);
    /* The heads moved too (search_state_forget_indices); the free list is
     * rebuilt from the clear halves, which needs no more room than it had. */
    t->head_moves++;
    return tree_free_rebuild(t);
}
