/*
 * dlca_sim.h - the DLCA simulation's state, shared by the model (dlca.c)
 * and its consistency check and checkpoints (dlca_state.c). Internal to
 * libpdla.
 *
 * Memory (runs/dlca/memory.txt). A cluster lives in a slot 1..nslot (slot
 * j starts as the j-th monomer placed). Per slot there are two 32-bit
 * words (place in the active list, and `ref`: a site, empty, or a block,
 * see DLCA_EMPTY) plus the active list's word: 12 bytes (a size per slot
 * went into the block's head: 4 B a slot for 4 B a cluster of 2 or more);
 * once a quarter of the slots is empty (at a row) they are
 * renumbered in order and the arrays shrink, each slot keeping its name
 * (id, 4 more bytes), so that the history is the same. A monomer alone
 * (size 1) needs nothing more: `ref` is its site
 * and its geometry is implied (anchor = its coordinates, offset and bounding
 * box 0). A cluster of 2 or more owns a block in one arena for all blocks
 * (`ref` is its offset): its capacity, anchor and bounding box, cap sites
 * and cap x d 16-bit offsets from the anchor (a box axis is at most
 * DLCA_MAX_AXIS sites, so that even the offsets of a join that spans the
 * box, |o| <= 2L - 2, fit). Blocks are made with little slack and freed
 * blocks are reclaimed by sliding the live ones down (dlca.c): one malloc'd
 * block per cluster left ~20 bytes a monomer of glibc's heap between live
 * blocks (runs/dlca/memory.txt). The collision
 * structure of --search lattice is an occupancy bit lattice (1 bit a site;
 * a 4-byte cluster-id lattice before session 7: 268 MB at 8192^2, and
 * cache and TLB misses on every site a move touched): a move clears and
 * sets its sites' bits and tests its new neighbours' bits; only a contact
 * (rare) asks which cluster holds a site, through grid boxes that list the
 * clusters whose bounding box covers them (lookup boxes: no halo search,
 * never all pairs). The "seen" stamps and the box ranges exist only for
 * the seed's searches.
 */
#ifndef PDLA_DLCA_SIM_H
#define PDLA_DLCA_SIM_H

#include <stdint.h>

#include "pdla/dlca.h"
#include "rng.h"

/* An offset from a cluster's anchor along one axis. */
typedef int16_t dlca_off;

/* A cluster of 2 or more monomers owns a block in the arena (s->ar, one
 * array of 32-bit words for all clusters; `ref` is the offset of the
 * block's cap word): [owner slot] then [cap][n], 16-bit [anchor d][lo d][hi d]
 * (padded to a word; the anchor is below L <= DLCA_MAX_AXIS, lo and hi are
 * offsets), [sites cap], then 16-bit [offsets cap x d]. A freed block keeps its cap
 * and gets owner 0, so that the arena can be walked block by block and
 * slid down (dlca.c, ar_slide). */
/* Words of a block (from its cap word) before its sites: cap, anchor, lo, hi. */
#define DLCA_REC_HEAD(d) (2 + (3 * (size_t)(d) + 1) / 2)
/* 32-bit words of a block of cap monomers, from its cap word. */
#define DLCA_REC_WORDS(d, cap) (DLCA_REC_HEAD(d) + (size_t)(cap) + ((size_t)(cap) * (size_t)(d) + 1) / 2)
/* ... and with its owner word: the block's whole length in the arena. */
#define DLCA_BLK_WORDS(d, cap) (1 + DLCA_REC_WORDS(d, cap))

/* A cluster as the moves see it: for a lone monomer the anchor is in the
 * view itself (g), the sites are its `ref` word and offset and bounding box
 * are dlca_zero, so that the same code serves both. Fill with view_of();
 * never copy one. */
typedef struct dlca_view {
    uint32_t n;
    uint32_t *k;
    dlca_off *off;
    int32_t *anc, *lo, *hi;
    int32_t g[DLCA_MAX_DIM];    /* the anchor: a lone monomer's, or a block's copied */
    int32_t glo[DLCA_MAX_DIM], ghi[DLCA_MAX_DIM]; /* a block's bounding box, copied */
    uint32_t *b;                /* the block (NULL: a lone monomer) */
} dlca_view;

/* A lone monomer's offset and bounding box (never written through). */
extern const int32_t dlca_zero[DLCA_MAX_DIM];
extern const dlca_off dlca_zero_off[DLCA_MAX_DIM];

typedef struct dlca_contact {
    uint32_t b;                  /* the other cluster */
    uint32_t i;                  /* first mover monomer touching it */
    int dir;                     /* 2 axis + (sign < 0) */
    int32_t xw[DLCA_MAX_DIM];    /* wrapped coordinates of mover monomer i */
} dlca_contact;

struct dlca_sim {
    dlca_params p;
    int d;
    int64_t L[DLCA_MAX_DIM];
    int64_t stride[DLCA_MAX_DIM];
    uint64_t V, N;
    uint64_t nslot; /* slots 1..nslot (N at the start; compacted as N_c falls) */
    uint32_t *pos;  /* per slot: index in act */
    uint32_t *ref;  /* per slot: a lone monomer's site, DLCA_EMPTY, or DLCA_EMPTY | its block's offset in ar */
    uint32_t *act;  /* active slots */
    uint32_t *id;   /* per slot: the cluster's name (its first slot); NULL: the slot itself */
    uint64_t nc;
    uint32_t *ar;   /* the arena: blocks of clusters of 2 or more */
    uint64_t ar_top, ar_cap, ar_free; /* words: in use (live or freed), allocated, freed */
    uint64_t *occ;  /* occupancy, a bit per site (LATTICE, and every search while starting) */
    uint64_t *lead; /* LATTICE, sticking 1: per mover monomer, "its site ahead was free" */
    size_t caplead; /* words of lead */
    uint32_t *uf;   /* while starting: per slot, the slot it joined (union-find) */
    pdla_rng rng;
    double t;
    uint64_t attempts, moves, monomer_moves, merges, largest;
    double sum_s2;
    int stop, spanning, search_now, oom;
    int compact_due; /* a row found a quarter of the slots empty: compact after the attempt */
    /* mobility thinning: s^gamma cached for s < nmob */
    double *mob;
    uint64_t nmob;
    uint32_t *size_count;
    uint64_t smin;
    /* grid boxes (BOXES) */
    int A;
    int64_t nb[DLCA_MAX_DIM], bstride[DLCA_MAX_DIM];
    uint64_t nboxes;
    uint32_t **box;
    uint32_t *box_n, *box_cap;
    int32_t *brange; /* BOXES: per slot, start[d], count[d] of its registered boxes (NULL: from the view) */
    uint64_t candidates;
    uint32_t *stamp, stamp_now; /* BOXES, ALLPAIRS: "seen in this search" marks, per slot */
    uint32_t *cand;
    dlca_contact *con;
    size_t ncon, capcon;
    uint64_t digest;
    dlca_row *rows;
    size_t nrows, caprows;
    uint64_t row_nc;
    dlca_ckpt_schedule sched; /* the CLI's checkpoint schedule, kept in checkpoints */
    int has_sched;            /* 1: set, or read from the checkpoint loaded */
};


static inline int64_t dlca_wrap(int64_t v, int64_t L)
{
    int64_t r = v % L;
    return r < 0 ? r + L : r;
}

static inline void dlca_coords(const dlca_sim *s, uint64_t k, int64_t *x)
{
    /* one division per axis but the last (quotient and remainder together) */
    for (int a = 0; a < s->d - 1; a++) {
        const uint64_t L = (uint64_t)s->L[a];
        x[a] = (int64_t)(k % L);
        k /= L;
    }
    x[s->d - 1] = (int64_t)k;
}

/* A slot's `ref`: below DLCA_EMPTY a lone monomer's site (sites are below
 * 2^31), DLCA_EMPTY an absorbed slot, above it DLCA_EMPTY | the offset of
 * its block in the arena, whose head holds the size: no per-slot size. */
#define DLCA_EMPTY UINT32_C(0x80000000)
/* Slot c's block (size >= 2): its cap word. */
static inline uint32_t *dlca_blk(const dlca_sim *s, uint64_t c) { return s->ar + (s->ref[c] & ~DLCA_EMPTY); }
/* Slot c's monomers (0: absorbed). */
static inline uint32_t dlca_n(const dlca_sim *s, uint64_t c)
{
    const uint32_t r = s->ref[c];
    return r < DLCA_EMPTY ? 1 : r == DLCA_EMPTY ? 0 : s->ar[(r & ~DLCA_EMPTY) + 1];
}
/* Block b's 16-bit anchor[d], lo[d], hi[d]; its sites. */
static inline dlca_off *dlca_bgeom(uint32_t *b) { return (dlca_off *)(b + 2); }
static inline uint32_t *dlca_bsites(const dlca_sim *s, uint32_t *b) { return b + DLCA_REC_HEAD(s->d); }

/* Fill v for block b holding n monomers. The view points into the arena:
 * valid until the next block is made (dlca_blk_new may move the arena).
 * Its anchor and bounding box are 32-bit copies of the block's 16-bit ones:
 * a change to them goes back with view_put. */
static inline void view_blk(const dlca_sim *s, uint32_t *b, dlca_view *v)
{
    const int d = s->d;
    const dlca_off *geo = dlca_bgeom(b);
    v->n = b[1];
    v->b = b;
    for (int a = 0; a < d; a++) v->g[a] = geo[a], v->glo[a] = geo[d + a], v->ghi[a] = geo[2 * d + a];
    v->anc = v->g;
    v->lo = v->glo;
    v->hi = v->ghi;
    v->k = b + DLCA_REC_HEAD(d);
    v->off = (dlca_off *)(v->k + b[0]);
}

/* v's anchor and bounding box back into its block (none for a lone
 * monomer: its are implied). */
static inline void view_put(const dlca_sim *s, const dlca_view *v)
{
    if (!v->b) return;
    const int d = s->d;
    dlca_off *geo = dlca_bgeom(v->b);
    for (int a = 0; a < d; a++)
        geo[a] = (dlca_off)v->anc[a], geo[d + a] = (dlca_off)v->lo[a], geo[2 * d + a] = (dlca_off)v->hi[a];
}

/* Fill v for slot c (size >= 1). */
static inline void view_of(const dlca_sim *s, uint32_t c, dlca_view *v)
{
    if (s->ref[c] > DLCA_EMPTY) {
        view_blk(s, dlca_blk(s, c), v);
        return;
    }
    v->n = 1;
    v->b = NULL;
    int64_t x[DLCA_MAX_DIM];
    dlca_coords(s, s->ref[c], x);
    for (int a = 0; a < s->d; a++) v->g[a] = (int32_t)x[a];
    v->k = &s->ref[c];
    v->off = (dlca_off *)dlca_zero_off;
    v->lo = v->hi = (int32_t *)dlca_zero;
    v->anc = v->g;
}

/* Slot c's name: the slot it had before any compaction (the history's
 * digest and the checkpoints use it; the order of slots is the order of
 * names, so that compaction changes nothing of the history). */
static inline uint32_t dlca_slot_id(const dlca_sim *s, uint64_t c) { return s->id ? s->id[c] : (uint32_t)c; }

/* The radius of gyration of n monomers at offsets off[n][d] from their
 * cluster's anchor, in lattice units: what /clusters/rg holds
 * (dlca_cluster_table). One function, so that `pdla check`
 * (dlca_check.c), which rebuilds the offsets by walking the cluster's face
 * contacts, sums them in the same order and compares bit for bit. */
double dlca_rg_offsets(const dlca_off *off, uint32_t n, int d);

/* Is row w of a series, after prev (NULL for the first), one the run
 * could have written before ending at end (its t, attempts, n_clusters
 * and largest) with N monomers? NULL, or the first field that is not
 * (dlca_state.c: the checkpoint loader and `pdla check`). */
const char *dlca_row_fault(const dlca_row *w, const dlca_row *prev, const dlca_row *end, uint64_t N);

/* The end of a run as the snapshot checks see it: the run's state
 * (dlca_snapshots_check), or what a cluster.h5 records of it (`pdla
 * check`, dlca_check_h5.c). mobility: gamma (the longest step of an
 * attempt depends on it). */
typedef struct dlca_snap_end {
    double t;
    uint64_t attempts, n_clusters, N, V;
    double mobility;
} dlca_snap_end;
/* dlca_snapshots_check against e. */
int dlca_snapshots_check_end(const dlca_snap_end *e, const dlca_snapshot *snaps, size_t n, double every,
                             int stopped, char *err, size_t errlen);

/* Shared between dlca.c and dlca_state.c. */
void dlca_sim_free(dlca_sim *s);
/* The arrays of a simulation of p with N monomers, nothing placed. */
int dlca_sim_alloc(dlca_sim **out, const dlca_params *p, uint64_t N);
/* A block for slot c with room for cap monomers (ref[c] set, head and
 * contents left to the caller); 0 or -1 (no memory). Moves the arena:
 * every pointer into it is stale after. */
int dlca_blk_new(dlca_sim *s, uint32_t c, uint32_t cap);
/* The seed's search structures from the state (after a start or a load). */
int dlca_search_init(dlca_sim *s, int search, int A);
int dlca_boxes_build(dlca_sim *s);
void dlca_cluster_span(const dlca_sim *s, const dlca_view *v, const int32_t *anchor, int margin, int32_t *b0,
                       int32_t *cnt);
static inline int32_t *dlca_brange(const dlca_sim *s, uint32_t c) { return s->brange + (size_t)c * 2 * s->d; }
static inline int dlca_occ(const dlca_sim *s, uint64_t k) { return (int)(s->occ[k >> 6] >> (k & 63) & 1); }
static inline void dlca_occ_set(dlca_sim *s, uint64_t k) { s->occ[k >> 6] |= UINT64_C(1) << (k & 63); }
static inline void dlca_occ_clear(dlca_sim *s, uint64_t k) { s->occ[k >> 6] &= ~(UINT64_C(1) << (k & 63)); }
/* The lookup boxes of --search lattice for the current state (after a start
 * or a load); 0 or -1 (no memory). */
int dlca_lookup_init(dlca_sim *s);
/* The slot holding site k (0: none), by the lookup boxes or, without
 * them, a scan of every cluster. */
uint32_t dlca_slot_of(const dlca_sim *s, uint64_t k);
int dlca_check_stop(dlca_sim *s);
/* Where an export of the monomers (dlca_export_sites order) stands; zero
 * it to start. */
typedef struct dlca_cursor {
    uint64_t c;  /* slot */
    uint32_t i;  /* monomer in it */
    uint32_t id; /* its cluster number */
} dlca_cursor;
/* The next (up to) max monomers' sites and cluster numbers; how many. So
 * that cluster.h5 is written in pieces, not from copies of all N. */
size_t dlca_export_chunk(const dlca_sim *s, dlca_cursor *cur, size_t max, uint32_t *site, uint32_t *cluster);
#endif
