/*
 * dlca.c - diffusion-limited cluster-cluster aggregation on a periodic
 * hypercubic lattice (see include/pdla/dlca.h for the model, dlca_sim.h
 * for the state and its memory).
 *
 * Clusters are rigid: each keeps an anchor (the wrapped coordinates of its
 * first monomer) and, per monomer, the site k and the unwrapped offset from
 * the anchor. A move changes the anchor and every k (the floor: a move
 * touches every site of the mover) but no offset; a join appends the smaller
 * cluster to the larger with its offsets shifted into the larger's frame.
 * Because a cluster's extent stays below L on every axis (reaching L is the
 * spanning stop), a wrapped coordinate maps to exactly one offset inside the
 * cluster's bounding box ("window"), which is how a contact site gives the
 * displacement between two frames.
 *
 * The three searches differ only in how the clusters touching (or
 * overlapped by) the mover are found; the set they find is the same, the
 * first contact of each is chosen canonically (lowest mover monomer, then
 * lowest direction), and joins run in cluster-id order: hence the same
 * history, bit for bit, whichever search runs.
 */
#define _GNU_SOURCE /* mremap (Linux) */
#include <math.h>
#ifdef __linux__
#include <sys/mman.h>
#endif
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dlca_internal.h"
#include "dlca_sim.h"

/* ---- small helpers ------------------------------------------------------ */

const int32_t dlca_zero[DLCA_MAX_DIM] = {0};
const dlca_off dlca_zero_off[DLCA_MAX_DIM] = {0};

#define wrap dlca_wrap
#define coords dlca_coords

static inline uint64_t rng_below(pdla_rng *r, uint64_t n)
{
    return (uint64_t)(((unsigned __int128)rng_next(r) * n) >> 64);
}

uint32_t dlca_site(const dlca_sim *s, const int64_t *x)
{
    uint64_t k = 0;
    for (int a = 0; a < s->d; a++) k += (uint64_t)wrap(x[a], s->L[a]) * (uint64_t)s->stride[a];
    return (uint32_t)k;
}

/* The offset inside cluster v's window of wrapped coordinate x on axis a.
 * x and the anchor lie in [0, L) and lo <= 0 (the anchor's own offset is
 * 0), so x - anc - lo > -L: a division only past 2L (a spanning cluster). */
static inline int64_t window(const dlca_sim *s, const dlca_view *v, int a, int64_t x)
{
    const int64_t lo = v->lo[a], L = s->L[a];
    int64_t r = x - v->anc[a] - lo;
    if (r < 0) r += L;
    else if (r >= L) r = r - L < L ? r - L : r % L;
    return lo + r;
}

static inline void digest_add(dlca_sim *s, uint64_t v)
{
    s->digest = (s->digest ^ v) * UINT64_C(0x100000001b3);
    s->digest ^= s->digest >> 29;
}

/* s^gamma: cached for the small sizes (nearly every pick), pow() above;
 * the same double either way. */
static inline double mob_of(const dlca_sim *s, uint64_t size)
{
    return size < s->nmob ? s->mob[size] : pow((double)size, s->p.mobility);
}

/* A fresh mark for the per-slot stamps; at wrap-around (after 2^32
 * searches) every mark is cleared so that none matches by accident. */
static inline uint32_t next_stamp(dlca_sim *s)
{
    if (++s->stamp_now == 0) {
        memset(s->stamp, 0, (s->nslot + 1) * sizeof *s->stamp);
        s->stamp_now = 1;
    }
    return s->stamp_now;
}

/* ---- the block arena ------------------------------------------------------ */

/* Every cluster of 2 or more has its block in one arena, carved at the top
 * and freed by marking (owner 0). When the top reaches the capacity, the
 * live blocks are slid down in place if an eighth of the top is freed
 * blocks, else the arena grows; either way its capacity is then set to the
 * top plus an eighth, so that the pages above the top go back to the
 * system. Resident: at most ~9/8 of the live blocks (one malloc per block
 * kept ~20 B a monomer of freed and outgrown blocks in glibc's heap, and
 * 16 B of malloc header a block: runs/dlca/memory.txt). Offsets are 32-bit
 * words below the tag bit of `ref`: an arena of at most 2^31 words (8 GiB). On Linux the arena is
 * its own mapping (mremap moves it without copying and gives back the
 * tail); elsewhere realloc. */
#define AR_MAX (DLCA_EMPTY - 1) /* offsets below the tag bit of `ref` */

static void ar_release(dlca_sim *s)
{
#ifdef __linux__
    if (s->ar) munmap(s->ar, s->ar_cap * sizeof *s->ar);
#else
    free(s->ar);
#endif
    s->ar = NULL;
    s->ar_top = s->ar_cap = s->ar_free = 0;
}

/* Capacity of cap words (a whole number of pages); 0 or -1 (arena kept). */
static int ar_resize(dlca_sim *s, uint64_t cap)
{
    const uint64_t page = 4096 / sizeof *s->ar;
    cap = (cap + page - 1) / page * page;
    if (cap == s->ar_cap) return 0;
    if (cap > (uint64_t)AR_MAX + 1) return -1;
    const size_t nb = (size_t)cap * sizeof *s->ar;
#ifdef __linux__
    void *p = s->ar ? mremap(s->ar, s->ar_cap * sizeof *s->ar, nb, MREMAP_MAYMOVE)
                    : mmap(NULL, nb, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) return -1;
#else
    void *p = realloc(s->ar, nb);
    if (!p) return -1;
#endif
    s->ar = p;
    s->ar_cap = cap;
    return 0;
}

/* The live blocks slid down to the bottom, in their order; each owner's
 * ref follows its block. O(top). */
static void ar_slide(dlca_sim *s)
{
    uint64_t src = 0, dst = 0;
    while (src < s->ar_top) {
        const uint32_t owner = s->ar[src];
        const uint64_t w = DLCA_BLK_WORDS(s->d, s->ar[src + 1]);
        if (owner) {
            if (dst != src) memmove(s->ar + dst, s->ar + src, (size_t)w * sizeof *s->ar);
            s->ref[owner] = (uint32_t)(dst + 1) | DLCA_EMPTY;
            dst += w;
        }
        src += w;
    }
    s->ar_top = dst;
    s->ar_free = 0;
}

/* Room for w more words at the top (a slide or a resize: the arena may
 * move). 0 or -1. */
static int ar_reserve(dlca_sim *s, uint64_t w)
{
    if (s->ar_top + w <= s->ar_cap) return 0;
    if (s->ar_free > s->ar_top / 8) ar_slide(s);
    const uint64_t need = s->ar_top + w;
    if (need > AR_MAX) return -1;
    return ar_resize(s, need + need / 8 + 1024) && ar_resize(s, need) ? -1 : 0;
}

/* A block of cap for slot c at the top (room reserved); its cap word. */
static uint32_t ar_carve(dlca_sim *s, uint32_t c, uint32_t cap)
{
    uint32_t *b = s->ar + s->ar_top;
    b[0] = c;
    b[1] = cap;
    s->ar_top += DLCA_BLK_WORDS(s->d, cap);
    return (uint32_t)(b + 1 - s->ar) | DLCA_EMPTY;
}

int dlca_blk_new(dlca_sim *s, uint32_t c, uint32_t cap)
{
    if (ar_reserve(s, DLCA_BLK_WORDS(s->d, cap))) return -1;
    s->ref[c] = ar_carve(s, c, cap);
    return 0;
}

/* Slot c's block freed (ref[c] left as it was). */
static void blk_free(dlca_sim *s, uint32_t c)
{
    uint32_t *b = dlca_blk(s, c);
    b[-1] = 0;
    s->ar_free += DLCA_BLK_WORDS(s->d, b[0]);
}

/* Slot c (n >= 2 monomers) moves to a new block of cap >= n, its head and
 * monomers copied over. 0 or -1 (the old block kept). */
static int blk_grow(dlca_sim *s, uint32_t c, uint32_t n, uint32_t cap)
{
    const int d = s->d;
    const size_t head = DLCA_REC_HEAD(d);
    if (ar_reserve(s, DLCA_BLK_WORDS(d, cap))) return -1;
    const uint32_t nb = ar_carve(s, c, cap);
    const uint32_t *o = dlca_blk(s, c);
    uint32_t *b = s->ar + (nb & ~DLCA_EMPTY);
    memcpy(b + 1, o + 1, (head - 1) * sizeof *b);
    memcpy(b + head, o + head, (size_t)n * sizeof *b);
    memcpy(b + head + cap, o + head + o[0], (size_t)n * d * sizeof(dlca_off));
    blk_free(s, c);
    s->ref[c] = nb;
    return 0;
}

/* ---- the series ---------------------------------------------------------- */

static void add_row(dlca_sim *s)
{
    if (s->nrows == s->caprows) {
        const size_t cap = s->caprows ? 2 * s->caprows : 256;
        dlca_row *r = realloc(s->rows, cap * sizeof *r);
        if (!r) return; /* a row lost to memory is not worth stopping the run */
        s->rows = r;
        s->caprows = cap;
    }
    dlca_row *r = &s->rows[s->nrows++];
    r->t = s->t;
    r->attempts = s->attempts;
    r->n_clusters = s->nc;
    r->largest = s->largest;
    r->mean_size = (double)s->N / (double)s->nc;
    r->weight_size = s->sum_s2 / (double)s->N;
    s->row_nc = s->nc;
}

/* A row per 1% fewer clusters. At each, the slots are compacted once a
 * quarter of them is empty, and the heap's free pages go back to the
 * system: the blocks of absorbed clusters and the outgrown blocks are
 * freed in the middle of glibc's heap and would stay resident (14 of 68
 * bytes a monomer at the end of a 2D run, runs/dlca/memory.txt). */
static void maybe_row(dlca_sim *s)
{
    const uint64_t next = (uint64_t)floor((double)s->row_nc * 0.99);
    if (s->nc <= (next < s->row_nc - 1 ? next : s->row_nc - 1)) {
        add_row(s);
        s->compact_due = s->nc <= s->nslot - s->nslot / 4; /* after this attempt (its digest names the slot) */
#ifdef __GLIBC__
        (void)malloc_trim(0);
#endif
    }
}

/* ---- grid boxes -------------------------------------------------------- */

/* Range of boxes along axis a covered by the interval [start, start + w). */
static void box_span(const dlca_sim *s, int a, int64_t start, int64_t w, int32_t *b0, int32_t *cnt)
{
    const int64_t L = s->L[a], nb = s->nb[a];
    if (w >= L - s->A) {
        *b0 = 0;
        *cnt = (int32_t)nb;
        return;
    }
    const int64_t x0 = wrap(start, L), x1 = wrap(start + w - 1, L);
    *b0 = (int32_t)(x0 / s->A);
    *cnt = (int32_t)(wrap(x1 / s->A - x0 / s->A, nb) + 1);
}

/* Cluster v's own box range (margin 0) or its halo (margin 1) at anchor. */
void dlca_cluster_span(const dlca_sim *s, const dlca_view *v, const int32_t *anchor, int margin, int32_t *b0,
                       int32_t *cnt)
{
    for (int a = 0; a < s->d; a++)
        box_span(s, a, (int64_t)anchor[a] + v->lo[a] - margin, (int64_t)v->hi[a] - v->lo[a] + 1 + 2 * margin,
                 &b0[a], &cnt[a]);
}

/* Call fn for every box of the range (odometer over the axes). */
static int for_boxes(dlca_sim *s, const int32_t *b0, const int32_t *cnt,
                     int (*fn)(dlca_sim *, uint64_t box, uint32_t c), uint32_t c)
{
    int32_t i[DLCA_MAX_DIM] = {0};
    for (;;) {
        uint64_t box = 0;
        for (int a = 0; a < s->d; a++) box += (uint64_t)wrap(b0[a] + i[a], s->nb[a]) * (uint64_t)s->bstride[a];
        if (fn(s, box, c)) return -1;
        int a = 0;
        while (a < s->d && ++i[a] == cnt[a]) i[a++] = 0;
        if (a == s->d) return 0;
    }
}

static int box_add(dlca_sim *s, uint64_t box, uint32_t c)
{
    if (s->box_n[box] == s->box_cap[box]) {
        const uint32_t cap = s->box_cap[box] ? 2 * s->box_cap[box] : 4;
        uint32_t *b = realloc(s->box[box], cap * sizeof *b);
        if (!b) return -1;
        s->box[box] = b;
        s->box_cap[box] = cap;
    }
    s->box[box][s->box_n[box]++] = c;
    return 0;
}

static int box_remove(dlca_sim *s, uint64_t box, uint32_t c)
{
    uint32_t *b = s->box[box];
    for (uint32_t j = 0; j < s->box_n[box]; j++)
        if (b[j] == c) {
            b[j] = b[--s->box_n[box]];
            return 0;
        }
    return -1;
}

/* Register cluster c in the boxes its bounding box covers at its anchor
 * (the range kept in brange for the seed's boxes; the lookup boxes of
 * --search lattice recompute it from the view when it goes: the geometry
 * does not change in between without an unregister first). */
static int box_register(dlca_sim *s, uint32_t c)
{
    int32_t tmp[2 * DLCA_MAX_DIM];
    int32_t *r = s->brange ? dlca_brange(s, c) : tmp;
    dlca_view v;
    view_of(s, c, &v);
    dlca_cluster_span(s, &v, v.anc, 0, r, r + s->d);
    return for_boxes(s, r, r + s->d, box_add, c);
}

static void box_unregister(dlca_sim *s, uint32_t c)
{
    int32_t tmp[2 * DLCA_MAX_DIM];
    int32_t *r = tmp;
    if (s->brange) r = dlca_brange(s, c);
    else {
        dlca_view v;
        view_of(s, c, &v);
        dlca_cluster_span(s, &v, v.anc, 0, r, r + s->d);
    }
    (void)for_boxes(s, r, r + s->d, box_remove, c);
}

static void boxes_free(dlca_sim *s)
{
    if (s->box)
        for (uint64_t b = 0; b < s->nboxes; b++) free(s->box[b]);
    free(s->box);
    free(s->box_n);
    free(s->box_cap);
    s->box = NULL;
    s->box_n = s->box_cap = NULL;
    s->nboxes = 0;
}

/* The grid of boxes of side A (the seed's boxes and the lattice search's
 * lookup boxes alike), with every active cluster registered. */
static int boxes_grid(dlca_sim *s)
{
    uint64_t nb = 1;
    for (int a = 0; a < s->d; a++) {
        s->nb[a] = (s->L[a] + s->A - 1) / s->A;
        s->bstride[a] = (int64_t)nb;
        nb *= (uint64_t)s->nb[a];
    }
    s->nboxes = nb;
    s->box = calloc(nb, sizeof *s->box);
    s->box_n = calloc(nb, sizeof *s->box_n);
    s->box_cap = calloc(nb, sizeof *s->box_cap);
    if (!s->box || !s->box_n || !s->box_cap) return -1;
    for (uint64_t j = 0; j < s->nc; j++)
        if (box_register(s, s->act[j])) return -1;
    return 0;
}

/* (Re)build the boxes for side s->A; falls back to all pairs when 3A >= L
 * on some axis, as the seed does. */
int dlca_boxes_build(dlca_sim *s)
{
    boxes_free(s);
    for (int a = 0; a < s->d; a++)
        if (3 * (int64_t)s->A >= s->L[a]) {
            s->search_now = DLCA_SEARCH_ALLPAIRS;
            return 0;
        }
    if (!s->cand && !(s->cand = malloc(s->nslot * sizeof *s->cand))) return -1; /* the halo's candidates */
    return boxes_grid(s);
}

static int lookup_build(dlca_sim *s);

/* After a join: grow A (doubling) until the largest extent fits. */
static int boxes_fit(dlca_sim *s, uint32_t c)
{
    if (!s->box) return 0;
    dlca_view v;
    view_of(s, c, &v);
    int64_t ext = 0;
    for (int a = 0; a < s->d; a++) {
        const int64_t e = (int64_t)v.hi[a] - v.lo[a] + 1;
        if (e > ext) ext = e;
    }
    if (ext <= s->A) return 0;
    while (s->A < ext) s->A *= 2;
    return s->search_now == DLCA_SEARCH_BOXES ? dlca_boxes_build(s) : lookup_build(s);
}

/* ---- lookup boxes (--search lattice) ------------------------------------ */

/* The boxes of side A listing every cluster where its bounding box lies,
 * as the seed's, but only to name the cluster at a contact site: no halo,
 * and no fall-back to all pairs (a box range covering a whole axis is
 * fine). Unlike the seed's they keep no per-slot range (the memory). */
static int lookup_build(dlca_sim *s)
{
    boxes_free(s);
    return boxes_grid(s);
}

/* Side A: a power of two holding the widest cluster, and about 32 monomers
 * a box on average (fewer boxes: less memory and fewer re-registrations;
 * a lookup scans one box's list, and lookups are rare). */
int dlca_lookup_init(dlca_sim *s)
{
    int64_t ext = 1;
    for (uint64_t j = 0; j < s->nc; j++) {
        dlca_view v;
        view_of(s, s->act[j], &v);
        for (int a = 0; a < s->d; a++) {
            const int64_t e = (int64_t)v.hi[a] - v.lo[a] + 1;
            if (e > ext) ext = e;
        }
    }
    const double per_site = (double)s->N / (double)s->V;
    s->A = 1;
    while (s->A < ext || pow((double)s->A, s->d) * per_site < 32) s->A *= 2;
    return lookup_build(s);
}

/* Does cluster c hold site k (coordinates x)? Its bounding box first. */
static int holds(const dlca_sim *s, uint32_t c, uint64_t k, const int64_t *x)
{
    if (s->ref[c] < DLCA_EMPTY) return s->ref[c] == k;
    dlca_view v;
    view_blk(s, dlca_blk(s, c), &v);
    for (int a = 0; a < s->d; a++)
        if (window(s, &v, a, x[a]) > v.hi[a]) return 0;
    for (uint32_t i = 0; i < v.n; i++)
        if (v.k[i] == k) return 1;
    return 0;
}

uint32_t dlca_slot_of(const dlca_sim *s, uint64_t k)
{
    int64_t x[DLCA_MAX_DIM];
    coords(s, k, x);
    if (!s->box || s->search_now != DLCA_SEARCH_LATTICE || s->spanning) { /* a spanning join left them stale */
        for (uint64_t j = 0; j < s->nc; j++)
            if (holds(s, s->act[j], k, x)) return s->act[j];
        return 0;
    }
    uint64_t box = 0;
    for (int a = 0; a < s->d; a++) box += (uint64_t)(x[a] / s->A) * (uint64_t)s->bstride[a];
    for (uint32_t j = 0; j < s->box_n[box]; j++)
        if (holds(s, s->box[box][j], k, x)) return s->box[box][j];
    return 0;
}

/* The search structures from the current state: --search lattice keeps
 * the bit lattice and gets its lookup boxes; for the seed's modes the bit
 * lattice goes, stamps and box ranges come, and the boxes are built with
 * side A (grown to hold the widest cluster). */
int dlca_search_init(dlca_sim *s, int search, int A)
{
    if (search == DLCA_SEARCH_LATTICE) {
        s->search_now = DLCA_SEARCH_LATTICE;
        return s->box ? 0 : dlca_lookup_init(s);
    }
    free(s->occ);
    s->occ = NULL;
    boxes_free(s);
    s->brange = malloc((s->nslot + 1) * 2 * (size_t)s->d * sizeof *s->brange);
    s->stamp = calloc(s->nslot + 1, sizeof *s->stamp);
    if (!s->brange || !s->stamp) return -1;
    s->search_now = search;
    if (search != DLCA_SEARCH_BOXES) return 0;
    s->A = A;
    int64_t ext = 1;
    for (uint64_t j = 0; j < s->nc; j++) {
        dlca_view v;
        view_of(s, s->act[j], &v);
        for (int a = 0; a < s->d; a++) {
            const int64_t e = (int64_t)v.hi[a] - v.lo[a] + 1;
            if (e > ext) ext = e;
        }
    }
    while (s->A < ext) s->A *= 2;
    return dlca_boxes_build(s);
}

/* ---- compaction ------------------------------------------------------ */

/* p shrunk to bytes (a failed shrink keeps p: it is still valid). */
static void *shrink(void *p, size_t bytes)
{
    void *q = realloc(p, bytes ? bytes : 1);
    return q ? q : p;
}

/* Slots renumbered 1..N_c in their order, each keeping its name (id), so
 * that every comparison of slots (joins in slot order, the larger id
 * absorbed on a tie) and the digest stay as they were: the history does
 * not change. The per-slot arrays shrink to N_c; the box lists are
 * relabelled (O(N), and at most log_{4/3}(N) times in a run).
 * Nothing else remembers a slot number across a row. Optional: on no
 * memory it does nothing. */
static __attribute__((noinline)) void compact(dlca_sim *s)
{
    s->compact_due = 0;
    const uint64_t old = s->nslot;
    const size_t w = 2 * (size_t)s->d;
    uint32_t *map = NULL, *id = s->id; /* map: old slot -> new, for the box lists */
    if (!id) id = malloc((s->nc + 1) * sizeof *id);
    if (s->box) map = malloc((old + 1) * sizeof *map);
    if (!id || (s->box && !map)) {
        free(map);
        if (id != s->id) free(id);
        return;
    }
    uint32_t j = 0;
    for (uint64_t c = 1; c <= old; c++) {
        if (s->ref[c] == DLCA_EMPTY) continue;
        id[++j] = s->id ? s->id[c] : (uint32_t)c; /* j <= c: in place */
        if (map) map[c] = j;
        if (j == c) continue;
        s->ref[j] = s->ref[c];
        s->pos[j] = s->pos[c];
        s->act[s->pos[j]] = j;
        if (s->brange) memmove(s->brange + j * w, s->brange + c * w, w * sizeof *s->brange);
        if (s->ref[j] > DLCA_EMPTY) dlca_blk(s, j)[-1] = j; /* its owner, for ar_slide */
    }
    for (uint64_t b = 0; map && b < s->nboxes; b++)
        for (uint32_t e = 0; e < s->box_n[b]; e++) s->box[b][e] = map[s->box[b][e]];
    free(map);
    s->id = id;
    s->nslot = j;
    s->pos = shrink(s->pos, (j + 1) * sizeof *s->pos);
    s->ref = shrink(s->ref, (j + 1) * sizeof *s->ref);
    s->id = shrink(s->id, (j + 1) * sizeof *s->id);
    s->act = shrink(s->act, j * sizeof *s->act);
    if (s->brange) s->brange = shrink(s->brange, (j + 1) * w * sizeof *s->brange);
    if (s->cand) s->cand = shrink(s->cand, j * sizeof *s->cand);
    if (s->stamp) {
        s->stamp = shrink(s->stamp, (j + 1) * sizeof *s->stamp);
        memset(s->stamp, 0, (j + 1) * sizeof *s->stamp); /* stamp_now is never 0 */
    }
}

/* ---- creation -------------------------------------------------------- */

void dlca_sim_free(dlca_sim *s)
{
    if (!s) return;
    ar_release(s);
    boxes_free(s);
    free(s->pos);
    free(s->ref);
    free(s->act);
    free(s->id);
    free(s->occ);
    free(s->lead);
    free(s->uf);
    free(s->mob);
    free(s->size_count);
    free(s->brange);
    free(s->stamp);
    free(s->cand);
    free(s->con);
    free(s->rows);
    free(s);
}

void dlca_destroy(dlca_sim *s) { dlca_sim_free(s); }

int dlca_sim_alloc(dlca_sim **out, const dlca_params *p, uint64_t N)
{
    dlca_sim *s = *out = calloc(1, sizeof *s);
    if (!s) return -1;
    s->p = *p;
    s->d = p->dim;
    s->V = 1;
    for (int a = 0; a < s->d; a++) {
        s->L[a] = p->box[a];
        s->stride[a] = (int64_t)s->V;
        s->V *= p->box[a];
    }
    s->N = N;
    s->nslot = N;
    rng_seed(&s->rng, p->seed);
    s->pos = calloc(N + 1, sizeof *s->pos);
    s->ref = malloc((N + 1) * sizeof *s->ref);
    s->act = malloc(N * sizeof *s->act);
    s->occ = calloc((s->V + 63) / 64, sizeof *s->occ);
    if (!s->pos || !s->ref || !s->act || !s->occ) return -1;
    for (uint64_t j = 0; j <= N; j++) s->ref[j] = DLCA_EMPTY;
    if (p->mobility != 0) {
        s->nmob = N + 1 < 65536 ? N + 1 : 65536;
        if (!(s->mob = malloc(s->nmob * sizeof *s->mob))) return -1;
        s->mob[0] = 0;
        for (uint64_t j = 1; j < s->nmob; j++) s->mob[j] = pow((double)j, p->mobility);
        if (p->mobility < 0 && !(s->size_count = calloc(N + 1, sizeof *s->size_count))) return -1;
    }
    return 0;
}

static void remove_active(dlca_sim *s, uint32_t c)
{
    const uint32_t j = s->pos[c];
    const uint32_t last = s->act[--s->nc];
    s->act[j] = last;
    s->pos[last] = j;
}

/* Sizes a and b joined: the count per size, and the smallest size present
 * (the mobility bound for gamma < 0). The new size is counted before the
 * smallest is searched, so the search stops at it at the latest. */
static void sizes_joined(dlca_sim *s, uint64_t a, uint64_t b)
{
    if (!s->size_count) return;
    s->size_count[a + b]++;
    s->size_count[a]--;
    s->size_count[b]--;
    while (s->smin < s->N && s->size_count[s->smin] == 0) s->smin++;
}

/* Room for n monomers in the keeper: a lone monomer gets a block (its
 * geometry made explicit), a block too small is replaced by one of n and
 * an eighth (the old one is garbage until a slide: with little slack the
 * copies stay O(n) a join and the slack small). 0 or -1. Moves the arena. */
static int keep_room(dlca_sim *s, uint32_t keep, uint32_t n)
{
    if (s->ref[keep] < DLCA_EMPTY) {
        int64_t x[DLCA_MAX_DIM];
        const uint32_t k = s->ref[keep];
        if (dlca_blk_new(s, keep, n)) { /* exact: most clusters stay small */
            s->ref[keep] = k;
            return -1;
        }
        uint32_t *b = dlca_blk(s, keep);
        b[1] = 1;
        coords(s, k, x);
        dlca_off *g = dlca_bgeom(b);
        for (int a = 0; a < s->d; a++) g[a] = (dlca_off)x[a], g[s->d + a] = g[2 * s->d + a] = 0;
        dlca_bsites(s, b)[0] = k;
        memset(dlca_bsites(s, b) + n, 0, (size_t)s->d * sizeof(dlca_off)); /* its offset */
        return 0;
    }
    if (n <= dlca_blk(s, keep)[0]) return 0;
    return blk_grow(s, keep, dlca_n(s, keep), n + (n / 8 < UINT32_MAX - n ? n / 8 : UINT32_MAX - n));
}

/* Does cluster v reach across the box (extent >= L on some axis)? Only
 * after the spanning join: it sets s->spanning. */
static int wide(const dlca_sim *s, const dlca_view *v)
{
    for (int a = 0; a < s->d; a++)
        if ((int64_t)v->hi[a] - v->lo[a] + 1 >= s->L[a]) return 1;
    return 0;
}

/* Append gone's monomers to keep (room made: keep has a record, even if
 * it was a lone monomer), offsets shifted by disp. Into a keeper that
 * already spans, the joins that finish the spanning step place each
 * monomer by window() (any offset that matches its site): disp came from
 * a window that is ambiguous there, and offsets shifted by it could grow
 * by L a join until they overflowed dlca_off; window's stay in
 * [lo, lo + L). The unwrapping of a spanning cluster means nothing. */
static void append(dlca_sim *s, uint32_t keep, uint32_t gone, const int64_t *disp)
{
    const int d = s->d;
    dlca_view K, G;
    view_blk(s, dlca_blk(s, keep), &K);
    view_of(s, gone, &G);
    const int by_site = wide(s, &K);
    for (uint32_t j = 0; j < G.n; j++) {
        K.k[K.n + j] = G.k[j];
        int64_t x[DLCA_MAX_DIM];
        if (by_site) coords(s, G.k[j], x);
        for (int a = 0; a < d; a++) {
            const int32_t o = (int32_t)(by_site ? window(s, &K, a, x[a]) : G.off[(size_t)j * d + a] + disp[a]);
            K.off[(size_t)(K.n + j) * d + a] = (dlca_off)o; /* |o| <= 2L - 2 fits (DLCA_MAX_AXIS) */
            if (o < K.lo[a]) K.lo[a] = o;
            if (o > K.hi[a]) K.hi[a] = o;
        }
    }
    view_put(s, &K);
    for (int a = 0; a < d; a++)
        if ((int64_t)K.hi[a] - K.lo[a] + 1 >= s->L[a]) s->spanning = 1;
}

/* After spanning: does keep span, or gone not (so keep may absorb it)? A
 * spanning cluster must survive its joins, as the proof of the stop
 * (dlca_check asks for one), and append places into its frame. */
static int keeps_span(const dlca_sim *s, uint32_t keep, uint32_t gone)
{
    dlca_view K, G;
    view_of(s, keep, &K);
    view_of(s, gone, &G);
    return wide(s, &K) || !wide(s, &G);
}

/* Join b into c or c into b (the larger survives; on a tie the lower id;
 * after spanning a spanning one),
 * disp = b's anchor in c's frame. Returns the survivor, 0 on no memory. */
static uint32_t join(dlca_sim *s, uint32_t c, uint32_t b, const int64_t *disp_in)
{
    int64_t disp[DLCA_MAX_DIM];
    const int d = s->d;
    uint32_t keep = c, gone = b;
    for (int a = 0; a < d; a++) disp[a] = disp_in[a];
    if (dlca_n(s, b) > dlca_n(s, c) || (dlca_n(s, b) == dlca_n(s, c) && b < c)) {
        keep = b;
        gone = c;
        for (int a = 0; a < d; a++) disp[a] = -disp[a];
    }
    if (s->spanning && !keeps_span(s, keep, gone)) { /* the spanning cluster keeps its frame (append) */
        const uint32_t t = keep;
        keep = gone;
        gone = t;
    }
    const uint32_t nk = dlca_n(s, keep), ng = dlca_n(s, gone), n = nk + ng;
    if (keep_room(s, keep, n)) return 0;
    if (s->uf) s->uf[gone] = keep;
    if (s->box) {
        box_unregister(s, gone);
        box_unregister(s, keep);
    }
    append(s, keep, gone, disp);
    s->sum_s2 += 2.0 * (double)nk * (double)ng;
    sizes_joined(s, nk, ng);
    dlca_blk(s, keep)[1] = n;
    if (ng >= 2) blk_free(s, gone);
    s->ref[gone] = DLCA_EMPTY;
    remove_active(s, gone);
    if (n > s->largest) s->largest = n;
    s->merges++;
    if (s->box && !s->spanning) {
        if (box_register(s, keep)) return 0;
        if (boxes_fit(s, keep)) return 0;
    }
    return keep;
}

/* Join cur with cluster b, which touches wrapped site xw + e_dir (xw a site
 * of cur). Returns the survivor, 0 on no memory. */
static uint32_t join_contact(dlca_sim *s, uint32_t cur, uint32_t b, const int32_t *xw, int dir)
{
    int64_t disp[DLCA_MAX_DIM];
    const int ax = dir >> 1, sg = (dir & 1) ? -1 : 1;
    dlca_view C, B;
    view_of(s, cur, &C);
    view_of(s, b, &B);
    for (int a = 0; a < s->d; a++) {
        const int64_t f = a == ax ? sg : 0;
        const int64_t ox = window(s, &C, a, xw[a]);
        const int64_t oy = window(s, &B, a, wrap((int64_t)xw[a] + f, s->L[a]));
        disp[a] = ox + f - oy;
    }
    return join(s, cur, b, disp);
}

/* Place the monomers: slot j holds the j-th one placed, at sites[j-1] or
 * at random; placed[] gets the sites in order. */
static int place(dlca_sim *s, const uint32_t *sites, uint32_t *placed, char *err, size_t errlen)
{
    for (uint64_t j = 1; j <= s->N; j++) {
        uint64_t k;
        if (sites) {
            k = sites[j - 1];
            if (k >= s->V || dlca_occ(s, k))
                return pdla_errorf(PDLA_EINVAL, err, errlen, k >= s->V ? "a site is outside the box" : "two monomers on one site");
        } else {
            do k = rng_below(&s->rng, s->V);
            while (dlca_occ(s, k));
        }
        dlca_occ_set(s, k);
        placed[j - 1] = (uint32_t)k;
        s->ref[j] = (uint32_t)k;
        s->pos[j] = (uint32_t)(j - 1);
        s->act[j - 1] = (uint32_t)j;
    }
    s->nc = s->N;
    s->largest = 1;
    s->sum_s2 = (double)s->N;
    s->smin = 1;
    if (s->size_count) s->size_count[1] = (uint32_t)s->N;
    return 0;
}

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* The slot now holding monomer j (placed as slot j): union-find. */
static uint32_t uf_find(uint32_t *uf, uint32_t j)
{
    while (uf[j] != j) j = uf[j] = uf[uf[j]];
    return j;
}

/* Face-adjacent monomers start joined: every placed site in placement
 * order, its directions in order (the same in every search mode). The
 * monomer on a site is found in the placed sites sorted by site, its
 * cluster by union-find over the joins (12 bytes a monomer while starting,
 * freed after: no id lattice). */
static int join_adjacent(dlca_sim *s, const uint32_t *placed)
{
    uint64_t *bysite = malloc(s->N * sizeof *bysite);
    s->uf = malloc((s->N + 1) * sizeof *s->uf);
    if (!bysite || !s->uf) {
        free(bysite);
        return -1;
    }
    for (uint64_t j = 0; j <= s->N; j++) s->uf[j] = (uint32_t)j;
    for (uint64_t j = 1; j <= s->N; j++) bysite[j - 1] = (uint64_t)placed[j - 1] << 32 | j;
    qsort(bysite, s->N, sizeof *bysite, cmp_u64);
    int rc = 0;
    /* on after spanning: every contact joined, as the step's joins
     * (join_contacts), so N_c and largest are those of the stop */
    for (uint64_t j = 1; j <= s->N && !rc; j++) {
        const uint32_t k = placed[j - 1];
        int64_t x[DLCA_MAX_DIM];
        int32_t xw[DLCA_MAX_DIM];
        coords(s, k, x);
        for (int a = 0; a < s->d; a++) xw[a] = (int32_t)x[a];
        for (int dir = 0; dir < 2 * s->d; dir++) {
            int64_t y[DLCA_MAX_DIM];
            memcpy(y, x, sizeof y);
            y[dir >> 1] += (dir & 1) ? -1 : 1;
            const uint64_t ky = dlca_site(s, y);
            if (!dlca_occ(s, ky)) continue;
            uint64_t lo = 0, hi = s->N; /* the monomer on ky */
            while (lo < hi) {
                const uint64_t mid = (lo + hi) / 2;
                if (bysite[mid] >> 32 < ky) lo = mid + 1;
                else hi = mid;
            }
            const uint32_t other = uf_find(s->uf, (uint32_t)bysite[lo]), self = uf_find(s->uf, (uint32_t)j);
            if (other != self && !join_contact(s, self, other, xw, dir)) {
                rc = -1;
                break;
            }
        }
    }
    free(bysite);
    free(s->uf);
    s->uf = NULL;
    return rc;
}

static int setup(dlca_sim **out, const dlca_params *p, const uint32_t *sites, uint64_t n, char *err,
                 size_t errlen)
{
    *out = NULL;
    int rc = dlca_params_validate(p, err, errlen);
    if (rc) return rc;
    const uint64_t N = sites ? n : dlca_params_monomers(p);
    dlca_sim *s = NULL;
    uint32_t *placed = NULL;
    if (dlca_sim_alloc(&s, p, N) || !(placed = malloc(N * sizeof *placed))) goto nomem;
    s->search_now = DLCA_SEARCH_LATTICE; /* the seed's boxes are built after the first joins */
    if ((rc = place(s, sites, placed, err, errlen))) {
        free(placed);
        dlca_sim_free(s);
        return rc;
    }
    if (join_adjacent(s, placed)) goto nomem;
    free(placed);
    placed = NULL;
    if (dlca_search_init(s, p->search, p->grid_box)) goto nomem;
    add_row(s);
    if (s->spanning) s->stop = DLCA_STOP_SPANNING;
    else if (s->nc <= p->until_clusters) s->stop = DLCA_STOP_CLUSTERS;
    *out = s;
    return 0;
nomem:
    free(placed);
    dlca_sim_free(s);
    return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the DLCA lattice and clusters");
}

int dlca_create(dlca_sim **out, const dlca_params *p, char *err, size_t errlen)
{
    return setup(out, p, NULL, 0, err, errlen);
}

int dlca_create_sites(dlca_sim **out, const dlca_params *p, const uint32_t *sites, uint64_t n,
                      char *err, size_t errlen)
{
    if (!sites || n == 0) return pdla_errorf(PDLA_EINVAL, err, errlen, "no sites given");
    dlca_params q = *p;
    q.count = n; /* so that validation counts these monomers */
    return setup(out, &q, sites, n, err, errlen);
}

/* ---- moves ------------------------------------------------------------ */

static void add_contact(dlca_sim *s, uint32_t b, uint32_t i, int dir)
{
    if (s->ncon == s->capcon) {
        const size_t cap = s->capcon ? 2 * s->capcon : 16;
        dlca_contact *c = realloc(s->con, cap * sizeof *c);
        if (!c) {
            s->oom = 1; /* do_move reports it */
            return;
        }
        s->con = c;
        s->capcon = cap;
    }
    dlca_contact *x = &s->con[s->ncon++];
    x->b = b;
    x->i = i;
    x->dir = dir;
}

/* A contact with cluster id unless one was found before in this move: a
 * scan of the few found so far (contacts are rare) instead of a stamp per
 * slot. */
static inline void lattice_contact(dlca_sim *s, uint32_t id, uint32_t i, int dir)
{
    for (size_t j = 0; j < s->ncon; j++)
        if (s->con[j].b == id) return;
    add_contact(s, id, i, dir);
}

/* Can the box range along a of a span [start, start + w) change when it
 * shifts by sg? Only if its first or last site crosses a box edge (A is a
 * power of two: no division; a range over the whole axis never changes).
 * start is above -L. */
static inline int span_moved(const dlca_sim *s, int a, int sg, int64_t start, int64_t w)
{
    const int64_t L = s->L[a];
    if (w >= L - s->A) return 0;
    const int sh = __builtin_ctz((unsigned)s->A);
    int64_t xs = start < 0 ? start + L : start, xe = xs + w - 1;
    if (xe >= L) xe -= L;
    int64_t ns = xs + sg, ne = xe + sg;
    if (ns < 0) ns += L; else if (ns >= L) ns -= L;
    if (ne < 0) ne += L; else if (ne >= L) ne -= L;
    return (xs >> sh) != (ns >> sh) || (xe >> sh) != (ne >> sh);
}

/* Flags of v's monomers whose site ahead (new site: k + dn, or k + dw on
 * the face T that wraps) is clear before the move: the leading face.
 * NULL (s->oom) on no memory. */
static uint64_t *mark_lead(dlca_sim *s, const dlca_view *v, int a, int32_t T, int64_t dn, int64_t dw)
{
    const uint32_t n = v->n;
    const size_t w = (n + 63) / 64;
    if (w > s->caplead) {
        uint64_t *l = realloc(s->lead, (w + w / 8) * sizeof *l);
        if (!l) {
            s->oom = 1;
            return NULL;
        }
        s->lead = l;
        s->caplead = w + w / 8;
    }
    uint64_t *lead = s->lead;
    const dlca_off *offa = v->off + a;
    const uint32_t *k = v->k;
    const int d = s->d;
    memset(lead, 0, w * sizeof *lead);
    for (uint32_t i = 0; i < n; i++)
        if (!dlca_occ(s, (uint64_t)((int64_t)k[i] + (offa[(size_t)i * d] == T ? dw : dn))))
            lead[i >> 6] |= UINT64_C(1) << (i & 63);
    return lead;
}

/* Cluster c (view v, moved along a from anchor old_anc) re-registered in
 * the lookup boxes if its range along a changed. */
static void lookup_follow(dlca_sim *s, uint32_t c, const dlca_view *v, int a, int32_t old_anc)
{
    int32_t b0[DLCA_MAX_DIM], cnt[DLCA_MAX_DIM], ob0, ocnt;
    const int64_t w = (int64_t)v->hi[a] - v->lo[a] + 1;
    box_span(s, a, (int64_t)old_anc + v->lo[a], w, &ob0, &ocnt);
    box_span(s, a, (int64_t)v->anc[a] + v->lo[a], w, &b0[a], &cnt[a]);
    if (ob0 == b0[a] && ocnt == cnt[a]) return;
    dlca_cluster_span(s, v, v->anc, 0, b0, cnt);
    const int32_t nb0 = b0[a], ncnt = cnt[a];
    b0[a] = ob0, cnt[a] = ocnt;
    (void)for_boxes(s, b0, cnt, box_remove, c);
    b0[a] = nb0, cnt[a] = ncnt;
    if (for_boxes(s, b0, cnt, box_add, c)) s->oom = 1;
}

/* The bit-lattice move of cluster v (slot c) one step along a (sg = +-1).
 * With sticking 1 no cluster touches the mover before it moves, so a
 * monomer whose site ahead is set (in the lattice before the move) has its
 * own monomer there: its new site was the cluster's, every neighbour of it
 * free of other clusters, and only the other monomers (the leading face)
 * are scanned; those are marked first (s->lead). Then the mover's bits are
 * cleared, so that a set bit next to a new site is another cluster's: its
 * id is looked up (rare: a contact), the same clusters and first contacts
 * as an id lattice gives. A move onto a set bit (only possible with
 * sticking < 1) is refused and the bits put back. */
static int move_lattice(dlca_sim *s, uint32_t c, int a, int sg)
{
    dlca_view v;
    view_of(s, c, &v);
    const int d = s->d;
    const uint32_t n = v.n;
    uint32_t *k = v.k;
    const int64_t L = s->L[a], st = s->stride[a];
    const int32_t T = (int32_t)window(s, &v, a, sg > 0 ? L - 1 : 0); /* offsets on the face that wraps */
    const int64_t dn = sg * st, dw = -sg * (L - 1) * st;
    const dlca_off *offa = v.off + a;
    const int lead_only = s->p.sticking >= 1;
    uint64_t *lead = NULL;
    if (lead_only && n > 1 && !(lead = mark_lead(s, &v, a, T, dn, dw))) return DLCA_REFUSED; /* s->oom */
    if (lead_only) /* nothing to refuse: clear and step in one pass */
        for (uint32_t i = 0; i < n; i++) {
            dlca_occ_clear(s, k[i]);
            k[i] = (uint32_t)((int64_t)k[i] + (offa[(size_t)i * d] == T ? dw : dn));
        }
    else {
        for (uint32_t i = 0; i < n; i++) dlca_occ_clear(s, k[i]);
        for (uint32_t i = 0; i < n; i++)
            if (dlca_occ(s, (uint64_t)((int64_t)k[i] + (offa[(size_t)i * d] == T ? dw : dn)))) {
                for (uint32_t j = 0; j < n; j++) dlca_occ_set(s, k[j]);
                return DLCA_REFUSED;
            }
        for (uint32_t i = 0; i < n; i++) k[i] = (uint32_t)((int64_t)k[i] + (offa[(size_t)i * d] == T ? dw : dn));
    }
    const int32_t old_anc = v.anc[a];
    v.anc[a] = old_anc + sg < 0 ? (int32_t)(L - 1) : old_anc + sg == L ? 0 : old_anc + sg;
    if (v.b) dlca_bgeom(v.b)[a] = (dlca_off)v.anc[a];
    int32_t T0[DLCA_MAX_DIM], T1[DLCA_MAX_DIM];
    for (int b = 0; b < d; b++) {
        T0[b] = (int32_t)window(s, &v, b, 0);
        T1[b] = (int32_t)window(s, &v, b, s->L[b] - 1);
    }
    s->ncon = 0;
    const int skip = 2 * a + (sg > 0); /* the way back: own old site */
    for (uint32_t i = 0; i < n; i++) {
        if (lead && !(lead[i >> 6] >> (i & 63) & 1)) continue;
        const dlca_off *o = v.off + (size_t)i * d;
        const int64_t ki = k[i];
        for (int b = 0; b < d; b++) {
            const int64_t sb = s->stride[b], wb = (s->L[b] - 1) * sb;
            const uint64_t kp = (uint64_t)(o[b] == T1[b] ? ki - wb : ki + sb);
            const uint64_t km = (uint64_t)(o[b] == T0[b] ? ki + wb : ki - sb);
            if (2 * b != skip && dlca_occ(s, kp)) lattice_contact(s, dlca_slot_of(s, kp), i, 2 * b);
            if (2 * b + 1 != skip && dlca_occ(s, km)) lattice_contact(s, dlca_slot_of(s, km), i, 2 * b + 1);
        }
    }
    for (uint32_t i = 0; i < n; i++) dlca_occ_set(s, k[i]);
    if (s->box && span_moved(s, a, sg, old_anc + v.lo[a], (int64_t)v.hi[a] - v.lo[a] + 1))
        lookup_follow(s, c, &v, a, old_anc);
    return DLCA_MOVED;
}

enum { PAIR_NONE, PAIR_CONTACT, PAIR_OVERLAP };

/* Do the bounding boxes of C (at anchor na, grown by one site) and B miss
 * each other? Then so do the clusters; D gets B's anchor minus na. */
static int boxes_apart(const dlca_sim *s, const dlca_view *C, const int32_t *na, const dlca_view *B, int64_t *D)
{
    for (int a = 0; a < s->d; a++) {
        const int64_t L = s->L[a], wc = (int64_t)C->hi[a] - C->lo[a] + 3, wb = (int64_t)B->hi[a] - B->lo[a] + 1;
        if (wc < L && wb < L) {
            const int64_t sc = wrap((int64_t)na[a] + C->lo[a] - 1, L), sb = wrap((int64_t)B->anc[a] + B->lo[a], L);
            if (!(wrap(sb - sc, L) < wc || wrap(sc - sb, L) < wb)) return 1;
        }
        D[a] = (int64_t)B->anc[a] - na[a];
    }
    return 0;
}

/* Does cluster b touch (or overlap) cluster c placed at anchor na? The
 * first contact is the lowest monomer of c, then the lowest direction. */
static int pair_test(const dlca_sim *s, uint32_t c, const int32_t *na, uint32_t b, int full, uint32_t *ci,
                     int *cdir)
{
    const int d = s->d;
    dlca_view C, B;
    view_of(s, c, &C);
    view_of(s, b, &B);
    int64_t D[DLCA_MAX_DIM];
    if (boxes_apart(s, &C, na, &B, D)) return PAIR_NONE;
    int found = 0;
    for (uint32_t i = 0; i < C.n; i++) {
        const dlca_off *oc = C.off + (size_t)i * d;
        int best = 2 * DLCA_MAX_DIM;
        for (uint32_t j = 0; j < B.n; j++) {
            const dlca_off *ob = B.off + (size_t)j * d;
            int nz = 0, dir = -1, ok = 1;
            for (int a = 0; a < d; a++) {
                const int64_t r = wrap(D[a] + ob[a] - oc[a], s->L[a]);
                if (r == 0) continue;
                if (nz || (r != 1 && r != s->L[a] - 1)) {
                    ok = 0;
                    break;
                }
                nz = 1;
                dir = r == 1 ? 2 * a : 2 * a + 1;
            }
            if (!ok) continue;
            if (!nz) return PAIR_OVERLAP;
            if (dir < best) best = dir;
        }
        if (best < 2 * DLCA_MAX_DIM && !found) {
            found = 1;
            *ci = i;
            *cdir = best;
            if (!full) return PAIR_CONTACT;
        }
    }
    return found ? PAIR_CONTACT : PAIR_NONE;
}

static int halo_collect(dlca_sim *s, uint64_t box, uint32_t c)
{
    for (uint32_t j = 0; j < s->box_n[box]; j++) {
        const uint32_t b = s->box[box][j];
        if (b != c && s->stamp[b] != s->stamp_now) {
            s->stamp[b] = s->stamp_now;
            s->cand[s->ncon++] = b; /* ncon counts candidates here */
        }
    }
    return 0;
}

/* The candidates of the seed's searches: all clusters, or those registered
 * in the boxes that c's grown bounding box covers at anchor na. */
static size_t ref_candidates(dlca_sim *s, uint32_t c, const int32_t *na, const uint32_t **cand)
{
    (void)next_stamp(s);
    if (s->search_now != DLCA_SEARCH_BOXES) {
        *cand = s->act;
        return s->nc;
    }
    dlca_view v;
    view_of(s, c, &v);
    int32_t b0[DLCA_MAX_DIM], cnt[DLCA_MAX_DIM];
    dlca_cluster_span(s, &v, na, 1, b0, cnt);
    s->ncon = 0;
    (void)for_boxes(s, b0, cnt, halo_collect, c);
    *cand = s->cand;
    return s->ncon;
}

/* The seed's searches: test the candidates at c's new place, then move. */
static int move_ref(dlca_sim *s, uint32_t c, int a, int sg)
{
    const int d = s->d;
    dlca_view v;
    view_of(s, c, &v);
    int32_t na[DLCA_MAX_DIM];
    memcpy(na, v.anc, (size_t)d * sizeof *na);
    na[a] = (int32_t)wrap((int64_t)na[a] + sg, s->L[a]);
    const uint32_t *cand;
    const size_t ncand = ref_candidates(s, c, na, &cand);
    s->ncon = 0;
    const int full = s->p.sticking < 1;
    for (size_t j = 0; j < ncand; j++) {
        const uint32_t b = cand[j];
        if (b == c) continue;
        s->candidates++;
        uint32_t i;
        int dir;
        const int r = pair_test(s, c, na, b, full, &i, &dir);
        if (r == PAIR_OVERLAP) {
            s->ncon = 0;
            return DLCA_REFUSED;
        }
        if (r == PAIR_CONTACT) add_contact(s, b, i, dir);
    }
    const int64_t L = s->L[a], st = s->stride[a];
    const int32_t T = (int32_t)window(s, &v, a, sg > 0 ? L - 1 : 0);
    const int64_t dn = sg * st, dw = -sg * (L - 1) * st;
    for (uint32_t i = 0; i < v.n; i++) v.k[i] = (uint32_t)((int64_t)v.k[i] + (v.off[(size_t)i * d + a] == T ? dw : dn));
    if (s->search_now == DLCA_SEARCH_BOXES) {
        int32_t b0[DLCA_MAX_DIM], cnt[DLCA_MAX_DIM];
        dlca_cluster_span(s, &v, na, 0, b0, cnt);
        const int32_t *r = dlca_brange(s, c);
        if (memcmp(b0, r, (size_t)d * sizeof *b0) || memcmp(cnt, r + d, (size_t)d * sizeof *cnt)) {
            box_unregister(s, c);
            memcpy(v.anc, na, (size_t)d * sizeof *na);
            view_put(s, &v); /* box_register reads it from the block */
            if (box_register(s, c)) return PDLA_ENOMEM;
        }
    }
    memcpy(v.anc, na, (size_t)d * sizeof *na);
    view_put(s, &v);
    return DLCA_MOVED;
}

/* Join the mover with what it touches, in cluster-id order. */
static int join_contacts(dlca_sim *s, uint32_t c)
{
    if (!s->ncon) return 0; /* nearly every move */
    const int d = s->d;
    dlca_view v;
    view_of(s, c, &v);
    for (size_t j = 0; j < s->ncon; j++) {
        dlca_contact *x = &s->con[j];
        for (int a = 0; a < d; a++)
            x->xw[a] = (int32_t)wrap((int64_t)v.anc[a] + v.off[(size_t)x->i * d + a], s->L[a]);
    }
    for (size_t j = 1; j < s->ncon; j++) /* insertion sort: a handful */
        for (size_t m = j; m > 0 && s->con[m - 1].b > s->con[m].b; m--) {
            const dlca_contact t = s->con[m];
            s->con[m] = s->con[m - 1];
            s->con[m - 1] = t;
        }
    uint32_t cur = c;
    /* All of them, also after a join that spans: the stop comes after the
     * step, with its contacts joined (they were left touching, and N_c and
     * the largest size at the percolation point were wrong). */
    for (size_t j = 0; j < s->ncon; j++) {
        if (s->p.sticking < 1 && rng_uniform(&s->rng) >= s->p.sticking) continue;
        cur = join_contact(s, cur, s->con[j].b, s->con[j].xw, s->con[j].dir);
        if (!cur) return PDLA_ENOMEM;
    }
    maybe_row(s);
    return 0;
}

static int do_move(dlca_sim *s, uint32_t c, int a, int sg)
{
    const uint32_t n = dlca_n(s, c);
    const int r = s->search_now == DLCA_SEARCH_LATTICE ? move_lattice(s, c, a, sg) : move_ref(s, c, a, sg);
    if (s->oom) return PDLA_ENOMEM;
    if (r != DLCA_MOVED) return r;
    s->moves++;
    s->monomer_moves += n;
    const int jr = join_contacts(s, c);
    return jr ? jr : DLCA_MOVED;
}

int dlca_check_stop(dlca_sim *s)
{
    if (s->spanning) s->stop = DLCA_STOP_SPANNING;
    else if (s->nc <= s->p.until_clusters) s->stop = DLCA_STOP_CLUSTERS;
    else if (s->p.until_time > 0 && s->t >= s->p.until_time) s->stop = DLCA_STOP_TIME;
    else if (s->p.max_attempts && s->attempts >= s->p.max_attempts) s->stop = DLCA_STOP_ATTEMPTS;
    return s->stop;
}

/* One attempt: pick a cluster, thin by mobility, pick a direction, move. */
static int step(dlca_sim *s)
{
    s->attempts++;
    const uint32_t c = s->act[rng_below(&s->rng, s->nc)];
    const uint64_t cid = dlca_slot_id(s, c);
    double mb = 1;
    if (s->mob) mb = s->p.mobility < 0 ? mob_of(s, s->smin) : mob_of(s, s->largest);
    s->t += 1.0 / ((double)s->nc * mb);
    if (s->mob && rng_uniform(&s->rng) * mb >= mob_of(s, dlca_n(s, c))) {
        digest_add(s, cid | (uint64_t)DLCA_NOT_PICKED << 40);
        return 0;
    }
    int a, sg;
    if (s->p.drift > 0 && rng_uniform(&s->rng) < s->p.drift) {
        a = s->d - 1;
        sg = -1;
    } else {
        const uint64_t dir = rng_below(&s->rng, 2 * (uint64_t)s->d);
        a = (int)(dir >> 1);
        sg = (dir & 1) ? -1 : 1;
    }
    const int r = do_move(s, c, a, sg);
    digest_add(s, cid | (uint64_t)(2 * a + (sg < 0)) << 32 | (uint64_t)(r < 0 ? 7 : r) << 40);
    return r < 0 ? r : 0;
}

int dlca_run(dlca_sim *s, uint64_t attempts) { return dlca_run_to(s, attempts, 0); }

double dlca_time(const dlca_sim *s) { return s->t; }
uint64_t dlca_attempts(const dlca_sim *s) { return s->attempts; }

int dlca_run_to(dlca_sim *s, uint64_t attempts, double t_pause)
{
    if (s->stop) return s->stop;
    for (uint64_t j = 0; attempts == 0 || j < attempts; j++) {
        if (t_pause > 0 && s->t >= t_pause) break;
        if (step(s) < 0) {
            s->stop = DLCA_STOP_CALLER; /* out of memory in a join */
            break;
        }
        if (s->compact_due) compact(s);
        if (dlca_check_stop(s)) break;
    }
    if (s->stop && (!s->nrows || s->rows[s->nrows - 1].attempts != s->attempts)) {
        /* The stop row is not a 1% row: row_nc stays at the last of those,
         * else a run resumed past this stop took its next rows 1% below the
         * stop's N_c and its series parted from the uninterrupted run's. */
        const uint64_t row_nc = s->row_nc;
        add_row(s);
        s->row_nc = row_nc;
    }
    return s->stop;
}

/* ---- test hooks ---------------------------------------------------------- */

static uint32_t slot_at(const dlca_sim *s, uint32_t k) { return dlca_slot_of(s, k); }

int dlca_move_site(dlca_sim *s, uint32_t k, int axis, int sign)
{
    const uint32_t c = k < s->V ? slot_at(s, k) : 0;
    if (!c || axis < 0 || axis >= s->d || (sign != 1 && sign != -1)) return PDLA_EINVAL;
    s->attempts++;
    const uint64_t cid = dlca_slot_id(s, c);
    const int r = do_move(s, c, axis, sign);
    digest_add(s, cid | (uint64_t)(2 * axis + (sign < 0)) << 32 | (uint64_t)(r < 0 ? 7 : r) << 40);
    if (s->compact_due) compact(s);
    (void)dlca_check_stop(s);
    return r;
}

uint64_t dlca_size_at(const dlca_sim *s, uint32_t k)
{
    const uint32_t c = k < s->V ? slot_at(s, k) : 0;
    return c ? dlca_n(s, c) : 0;
}

int64_t dlca_extent_at(const dlca_sim *s, uint32_t k, int axis)
{
    const uint32_t c = k < s->V ? slot_at(s, k) : 0;
    if (!c) return 0;
    dlca_view v;
    view_of(s, c, &v);
    return (int64_t)v.hi[axis] - v.lo[axis] + 1;
}

/* ---- results -------------------------------------------------------------- */

const char *dlca_stop_name(int stop)
{
    static const char *names[] = {"running", "clusters", "time", "spanning", "attempts", "stopped"};
    return stop >= 0 && stop <= 5 ? names[stop] : "unknown";
}

const dlca_params *dlca_get_params(const dlca_sim *s) { return &s->p; }

/* Bytes held by the model (the arrays and blocks it allocated). */
static uint64_t model_bytes(const dlca_sim *s)
{
    uint64_t b = sizeof *s + (s->nslot + 1) * (2 + (s->id != NULL)) * sizeof(uint32_t) +
                 s->nslot * sizeof *s->act + s->ar_top * sizeof *s->ar; /* with its freed blocks */
    if (s->cand) b += s->nslot * sizeof *s->cand;
    if (s->stamp) b += (s->nslot + 1) * sizeof *s->stamp;
    if (s->occ) b += (s->V + 63) / 64 * sizeof *s->occ;
    b += s->caplead * sizeof *s->lead;
    if (s->mob) b += s->nmob * sizeof *s->mob;
    if (s->size_count) b += (s->N + 1) * sizeof *s->size_count;
    if (s->brange) b += (s->nslot + 1) * 2 * (size_t)s->d * sizeof *s->brange;
    for (uint64_t j = 0; j < s->nboxes; j++) b += sizeof(uint32_t *) + 8 + s->box_cap[j] * sizeof(uint32_t);
    return b;
}

void dlca_get_stats(const dlca_sim *s, dlca_stats *o)
{
    memset(o, 0, sizeof *o);
    o->t = s->t;
    o->attempts = s->attempts;
    o->moves = s->moves;
    o->monomer_moves = s->monomer_moves;
    o->merges = s->merges;
    o->n_monomers = s->N;
    o->n_clusters = s->nc;
    o->largest = s->largest;
    o->sum_s2 = s->sum_s2;
    o->stop = s->stop;
    o->search_now = s->search_now;
    o->box_side = s->search_now == DLCA_SEARCH_BOXES ? s->A : 0;
    o->candidates = s->candidates;
    o->digest = s->digest;
    o->bytes = model_bytes(s);
}

const dlca_row *dlca_series(const dlca_sim *s, size_t *n)
{
    *n = s->nrows;
    return s->rows;
}

size_t dlca_export_chunk(const dlca_sim *s, dlca_cursor *cur, size_t max, uint32_t *site, uint32_t *cluster)
{
    size_t m = 0;
    if (cur->c == 0) cur->c = 1, cur->i = 0, cur->id = 0;
    for (; m < max && cur->c <= s->nslot; cur->c++, cur->i = 0) {
        if (!dlca_n(s, cur->c)) continue;
        dlca_view v;
        view_of(s, (uint32_t)cur->c, &v);
        while (cur->i < v.n && m < max) {
            site[m] = v.k[cur->i++];
            cluster[m++] = cur->id;
        }
        if (cur->i < v.n) break; /* full: go on in this cluster next time */
        cur->id++;
    }
    return m;
}

void dlca_export_sites(const dlca_sim *s, uint32_t *site, uint32_t *cluster)
{
    dlca_cursor cur = {0};
    (void)dlca_export_chunk(s, &cur, s->N, site, cluster);
}

double dlca_rg_offsets(const dlca_off *off, uint32_t n, int d)
{
    double var = 0;
    for (int a = 0; a < d; a++) {
        double m1 = 0, m2 = 0;
        for (uint32_t i = 0; i < n; i++) {
            const double o = off[(size_t)i * d + a];
            m1 += o;
            m2 += o * o;
        }
        m1 /= n;
        var += m2 / n - m1 * m1;
    }
    return sqrt(var > 0 ? var : 0);
}

void dlca_cluster_table(const dlca_sim *s, uint64_t *size, double *rg)
{
    uint64_t id = 0;
    for (uint64_t c = 1; c <= s->nslot; c++) {
        if (!dlca_n(s, c)) continue;
        dlca_view v;
        view_of(s, (uint32_t)c, &v);
        size[id] = v.n;
        rg[id] = dlca_rg_offsets(v.off, v.n, s->d);
        id++;
    }
}

int dlca_set_stops(dlca_sim *s, uint64_t until_clusters, double until_time, uint64_t max_attempts)
{
    s->p.until_clusters = until_clusters;
    s->p.until_time = until_time;
    s->p.max_attempts = max_attempts;
    if (s->stop != DLCA_STOP_SPANNING) s->stop = 0;
    return dlca_check_stop(s);
}
