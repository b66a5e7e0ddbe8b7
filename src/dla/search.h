/*
 * search.h - the distance search (search.c): per-walker search state, the
 * far-threshold configuration, the variable-precision lower bound on the
 * tree, the map-assisted block search, the exact nearest point near contact
 * and the brute-force reference. Above tree.h and distmap.h (it reads both);
 * below the walker, the workers and the engine. Internal to libpdla.
 */
#ifndef PDLA_SRC_SEARCH_H
#define PDLA_SRC_SEARCH_H
#include <stdint.h>

#include "distmap.h"
#include "tree.h"

/* Per-walker state of the search: counters, and the path of the previous
 * query (successive queries of one walker are close, so the next descent
 * starts from the lowest cached node that still contains the point instead
 * of the root). Reset it with search_state_reset before first use; it stays
 * valid while the tree only grows, and is dropped when the root changes. */
/* Capacity of a walker's neighbour list (particles), its largest radius
 * (units: the ball then spans at most three leaves per axis) and the
 * number of distance buckets it is sorted into. */
#define SEARCH_NB_MAX 1024
#define SEARCH_NB_RADIUS 256
#define SEARCH_NB_BUCKETS 64
/* The leaf-bit rows: words within LB_RING of the walker's (the largest
 * square they hold around its leaf reaches DISTMAP_LEAF_REACH leaves). */
#define LB_RING (DISTMAP_LEAF_REACH / 8)
#define LB_WORDS (2 * LB_RING + 1)

typedef struct search_state {
    uint64_t node_visits;
    uint64_t particle_checks;
    uint32_t root;               /* root the cache was made under; 0 = empty */
    int root_level;
    int depth;                   /* lowest cached level */
    uint32_t node[TREE_MAX_LEVEL + 1];
    uint32_t own[TREE_MAX_LEVEL + 1];
    int64_t lo[TREE_MAX_LEVEL + 1][3];
    /* The leaves around the walker's own leaf (search_block2): their first
     * chunks (or not seen yet, or empty), for the block centred on the leaf
     * whose low corner is blk_c. */
    int blk_valid;
    uint64_t blk_moves;          /* the tree's head_moves they are valid for */
    uint64_t blk_leaves;         /* the map's leaf count when they were cached */
    int64_t blk_c[3];
    uint32_t blk_head[27];
    /* 2D with the map's leaf bits (coarsened fine cells): the bits of the
     * 8 LB_WORDS x 8 LB_WORDS leaves around the walker (the words of 8 x 8
     * leaves within LB_RING words of the word with absolute coordinates
     * lb_w), one row of bits per leaf row, as of the cache key lb_leaves
     * (search.c: block_bits2). */
    int lb_valid;
    int lb_unknown;              /* some of the words were dropped (distmap.h) */
    uint64_t lb_leaves;
    int64_t lb_w[2];
    uint64_t lb_row[8 * LB_WORDS];
    uint64_t lb_nz;              /* bit r: lb_row[r] is not 0 */
    /* The walker's neighbour list (search_near2, serial): every particle
     * centre within nb_r units of nb_c while the tree holds nb_count
     * particles, as offsets from nb_c sorted by distance from it (in
     * buckets); nb_rlo[j] is a lower bound on that distance for particles
     * 8j.. (blocks of eight, the last one padded far away). */
    int nb_valid;
    int32_t nb_r;
    uint32_t nb_n;               /* particles, padded to a multiple of 8 */
    uint64_t nb_count;
    uint64_t nb_last2;           /* the walker's last near answer (its next jump) */
    int64_t nb_c[3];
    uint64_t nb_made, nb_hits, nb_misses; /* lists made; queries answered; deferred */
    int16_t nb_x[SEARCH_NB_MAX], nb_y[SEARCH_NB_MAX], nb_z[SEARCH_NB_MAX];
    int32_t nb_rlo[SEARCH_NB_MAX / 8];
    /* The last exact answer (squared distance ub_d2 from ub_p to a particle
     * of the tree, UINT64_MAX: none). Particles are never removed, so for
     * any later p, 2 (ub_d2 + |p - ub_p|^2) bounds the squared distance to
     * the nearest particle from above; the tree and block searches start
     * from it (search.c: the answer stays the same, the pruning starts
     * earlier). */
    uint64_t ub_d2;
    int64_t ub_p[3];
    /* 3D: the particle at the walker's last exact answer (nq_valid), so
     * |p - nq|^2, a distance the answer never exceeds, seeds the next
     * search (a much tighter seed than ub_d2's); and, during a search, the
     * chunk of the particle at its best bound so far with p less the
     * leaf's corner (arg_q), from which nq is read at the end. */
    int nq_valid;
    int64_t nq[3];
    const uint8_t *arg_chunk;
    uint32_t arg_ci;             /* arg_chunk's index */
    int64_t arg_q[3];
} search_state;

static inline void search_state_reset(search_state *s)
{
    s->node_visits = 0;
    s->particle_checks = 0;
    s->root = 0;
    s->blk_valid = 0;
    s->blk_moves = 0;
    s->lb_valid = 0;
    s->nb_valid = 0;
    s->nb_last2 = 0;
    s->ub_d2 = UINT64_MAX;
    s->nq_valid = 0;
}

/* Forget the tree indices a state caches (its path from the root and the
 * block's first chunks), as after tree_compact moved the records. Nothing
 * else is needed: the other caches hold coordinates and distances, and no
 * answer depends on what is cached, only the work to find it. */
static inline void search_state_forget_indices(search_state *s)
{
    s->root = 0;
    s->blk_valid = 0;
}

/* The lowest node of the walker's cached path that contains p, as a
 * start for tree_insert_from (none when the cache is empty or was made
 * under another root). The serial insertion of a walker's particle, right
 * after its last search near that spot, so descends a level or two. */
void search_path_start(const search_state *k, const tree *t, const int64_t *p, tree_start *out);

/* Per-level squared far thresholds: a non-empty node at level L whose box is
 * at squared distance > far2[L] from the query is not opened; its box
 * distance is used as the lower bound. UINT64_MAX disables it (exact). */
typedef struct search_config {
    uint64_t far2[TREE_MAX_LEVEL + 2];
    int concurrent; /* 1 while other threads may append: scalar leaf scans only */
} search_config;

/* far_factor <= 0 gives exact search. The thresholds never fall below
 * (2 (D + eps))^2, so any result below (D + eps)^2 is an exact distance. */
void search_config_init(search_config *c, double far_factor, int resolution, int eps);

/* Squared lower bound on the distance from p to the nearest particle centre
 * (UINT64_MAX if the tree is empty). Exact whenever it is below the
 * smallest far threshold; never above the true squared distance.
 * `cap2`: the caller needs no answer larger than this (pass UINT64_MAX for
 * none); the search may return any value >= cap2 once it knows the true
 * distance is at least that large. */
uint64_t search_lower_bound2(const tree *t, const search_config *c, const int64_t *p,
                             uint64_t cap2, search_state *k);

/* Exact squared distance from p to the nearest particle centre from the
 * walker's neighbour list, or UINT64_MAX when the list cannot prove it
 * (then search_lower_bound2 answers; an answer given here is always the
 * one it would give, as it is below the smallest far threshold). The list
 * is remade around p, with a radius of a few times the walker's last
 * answer (k->nb_last2, which the caller sets after each query), when the
 * tree has grown since or p has left its inner half; when that answer is
 * too large for a list to pay, the tree answers. Only while the tree is
 * not appended to concurrently. */
uint64_t search_near2(const tree *t, const search_config *c, const int64_t *p, search_state *k);

/* Exact squared distance by brute force over every particle: the reference
 * the optimised search is tested against. */
uint64_t search_brute2(const tree *t, const int64_t *p);

/* Exact nearest particle centre within sqrt(radius2) of p, radius2 < 256^2
 * (so up to three leaves per axis: D + eps reaches 192 units at D = 128):
 * returns 1 and writes it to q (and its squared distance), or 0 if none. */
int search_nearest_point(const tree *t, const int64_t *p, uint64_t radius2, int64_t *q,
                         uint64_t *d2);
/* The same, finding the leaves from (and updating) a walker's cached path. */
int search_nearest_point_cached(const tree *t, const int64_t *p, uint64_t radius2, int64_t *q,
                                uint64_t *d2, search_state *k);

/* A particle centre and its squared distance from a query point. */
typedef struct search_point {
    int64_t x[2];
    uint64_t d2;
} search_point;

/* 2D, from a walker's caches (k): every particle centre whose squared
 * distance from p is below far2 (near2 <= far2 < 256^2), in pts, at most
 * cap; returns their number, or -1 when there are more (or far2 is out of
 * range). The leaves of the ball of near2 come first, in
 * search_nearest_point's order, so the first point of least d2 below near2
 * is the one search_nearest_point_cached(p, near2) returns. Contact
 * snapping reads its nearest particle and the overlap checks of its
 * candidate spots from one such scan (walker.c). */
int search_ball_points2(const tree *t, const int64_t *p, uint64_t near2, uint64_t far2,
                        search_point *pts, int cap, search_state *k);

/* Squared lower bound on the distance from p to the cluster from the leaves
 * of the 3^dim block around p's leaf that the map's fine level marks
 * occupied (the fine cells are the leaves), scanned exactly: exact whenever
 * the nearest particle is nearer than the outside of the block (so always
 * near contact), else the distance to the outside of the block. In 2D once
 * the fine cells coarsen, the map's leaf bits say which leaves are
 * occupied instead; and when none of the 3 x 3 leaves is, the answer is
 * the leaf bound: the distance to the outside of the largest empty square
 * of leaves around p's leaf, up to DISTMAP_LEAF_REACH leaves (at least one
 * leaf). Returns UINT64_MAX when the map cannot answer (none, coarsened
 * cells without leaf bits, or p near the grid's edge): then
 * search_lower_bound2 does. The leaves' first chunks are cached in k (a
 * leaf once seen keeps its head until the tree's head_moves changes; one
 * not seen yet is looked up again when the map marks its cell). */
uint64_t search_block2(const tree *t, const search_config *c, const distmap *m, const int64_t *p,
                       search_state *k);
#endif /* PDLA_SRC_SEARCH_H */
