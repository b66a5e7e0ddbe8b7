/*
 * dlca.c - diffusion-limited cluster-cluster aggregation on a periodic
 * hypercubic lattice (see include/pdla/dlca.h for the model).
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
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dlca_internal.h"
#include "rng.h"

/* A cluster's sites and offsets live in one block of cap x (1 + d) words
 * (off right after k). A monomer not yet joined (cap 0) borrows its two
 * from the shared start pool instead: one malloc per monomer cost 64 bytes
 * of allocator chunks (runs/dlca/memory.txt). */
typedef struct dlca_cl {
    uint32_t n, cap; /* monomers (0: slot absorbed); cap 0: k, off in the pool */
    uint32_t act;    /* index in the active list */
    uint32_t *k;     /* sites */
    int32_t *off;    /* n x d offsets from the anchor */
} dlca_cl;

typedef struct contact {
    uint32_t b;   /* the other cluster */
    uint32_t i;   /* first mover monomer touching it */
    int dir;      /* 2 axis + (sign < 0) */
    int32_t xw[DLCA_MAX_DIM]; /* wrapped coordinates of mover monomer i */
} contact;

struct dlca_sim {
    dlca_params p;
    int d;
    int64_t L[DLCA_MAX_DIM];
    int64_t stride[DLCA_MAX_DIM];
    uint64_t V, N;
    dlca_cl *cl;     /* slots 1..N */
    int32_t *geom;   /* per slot: anchor[d], lo[d], hi[d] */
    uint32_t *act;   /* active slots */
    uint64_t nc;
    uint32_t *grid;  /* LATTICE: slot id per site, 0 empty */
    pdla_rng rng;
    double t;
    uint64_t attempts, moves, monomer_moves, merges, largest;
    double sum_s2;
    int stop, spanning, search_now, oom;
    /* mobility thinning */
    double *mob;
    uint32_t *size_count;
    uint64_t smin;
    /* grid boxes */
    int A;
    int64_t nb[DLCA_MAX_DIM], bstride[DLCA_MAX_DIM];
    uint64_t nboxes;
    uint32_t **box;
    uint32_t *box_n, *box_cap;
    int32_t *brange; /* per slot: start[d], count[d] of its registered boxes */
    uint64_t candidates;
    uint32_t *stamp, stamp_now; /* "seen in this search" marks, per slot */
    uint32_t *pool;             /* the start's k[N] then off[N d] */
    uint32_t *cand;
    contact *con;
    size_t ncon, capcon;
    uint64_t digest;
    dlca_row *rows;
    size_t nrows, caprows;
    uint64_t row_nc;
};

/* ---- small helpers ------------------------------------------------------ */

static inline int64_t wrap(int64_t v, int64_t L)
{
    int64_t r = v % L;
    return r < 0 ? r + L : r;
}

static inline int32_t *anchor_of(const dlca_sim *s, uint32_t c) { return s->geom + (size_t)c * 3 * s->d; }
static inline int32_t *lo_of(const dlca_sim *s, uint32_t c) { return anchor_of(s, c) + s->d; }
static inline int32_t *hi_of(const dlca_sim *s, uint32_t c) { return anchor_of(s, c) + 2 * s->d; }

static inline uint64_t rng_below(pdla_rng *r, uint64_t n)
{
    return (uint64_t)(((unsigned __int128)rng_next(r) * n) >> 64);
}

static void coords(const dlca_sim *s, uint64_t k, int64_t *x)
{
    for (int a = 0; a < s->d; a++) x[a] = (int64_t)((k / (uint64_t)s->stride[a]) % (uint64_t)s->L[a]);
}

uint32_t dlca_site(const dlca_sim *s, const int64_t *x)
{
    uint64_t k = 0;
    for (int a = 0; a < s->d; a++) k += (uint64_t)wrap(x[a], s->L[a]) * (uint64_t)s->stride[a];
    return (uint32_t)k;
}

/* The offset inside cluster c's window of wrapped coordinate x on axis a. */
static inline int64_t window(const dlca_sim *s, uint32_t c, int a, int64_t x)
{
    const int64_t lo = lo_of(s, c)[a];
    return lo + wrap(x - anchor_of(s, c)[a] - lo, s->L[a]);
}

static inline void digest_add(dlca_sim *s, uint64_t v)
{
    s->digest = (s->digest ^ v) * UINT64_C(0x100000001b3);
    s->digest ^= s->digest >> 29;
}

static int fail(char *err, size_t errlen, int code, const char *msg)
{
    if (err && errlen) snprintf(err, errlen, "%s", msg);
    return code;
}

/* A fresh mark for the per-slot stamps; at wrap-around (after 2^32
 * searches) every mark is cleared so that none matches by accident. */
static inline uint32_t next_stamp(dlca_sim *s)
{
    if (++s->stamp_now == 0) {
        memset(s->stamp, 0, (s->N + 1) * sizeof *s->stamp);
        s->stamp_now = 1;
    }
    return s->stamp_now;
}

/* Give cluster C a block of cap entries (cap >= C->n), its n copied over. */
static int cl_alloc(dlca_cl *C, uint32_t cap, int d)
{
    uint32_t *k = malloc((size_t)cap * (1 + (size_t)d) * sizeof *k);
    if (!k) return -1;
    int32_t *off = (int32_t *)(k + cap);
    if (C->n) {
        memcpy(k, C->k, (size_t)C->n * sizeof *k);
        memcpy(off, C->off, (size_t)C->n * d * sizeof *off);
    }
    if (C->cap) free(C->k);
    C->k = k;
    C->off = off;
    C->cap = cap;
    return 0;
}

static void cl_release(dlca_cl *C)
{
    if (C->cap) free(C->k);
    C->k = NULL;
    C->off = NULL;
    C->cap = 0;
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

static void maybe_row(dlca_sim *s)
{
    const uint64_t next = (uint64_t)floor((double)s->row_nc * 0.99);
    if (s->nc <= (next < s->row_nc - 1 ? next : s->row_nc - 1)) add_row(s);
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

/* Cluster c's own box range (margin 0) or its halo (margin 1). */
static void cluster_span(const dlca_sim *s, uint32_t c, const int32_t *anchor, int margin, int32_t *b0,
                         int32_t *cnt)
{
    const int32_t *lo = lo_of(s, c), *hi = hi_of(s, c);
    for (int a = 0; a < s->d; a++)
        box_span(s, a, (int64_t)anchor[a] + lo[a] - margin, (int64_t)hi[a] - lo[a] + 1 + 2 * margin, &b0[a],
                 &cnt[a]);
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

static int32_t *brange_of(const dlca_sim *s, uint32_t c) { return s->brange + (size_t)c * 2 * s->d; }

static int box_register(dlca_sim *s, uint32_t c)
{
    int32_t *r = brange_of(s, c);
    cluster_span(s, c, anchor_of(s, c), 0, r, r + s->d);
    return for_boxes(s, r, r + s->d, box_add, c);
}

static void box_unregister(dlca_sim *s, uint32_t c)
{
    int32_t *r = brange_of(s, c);
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

/* (Re)build the boxes for side s->A; falls back to all pairs when 3A >= L
 * on some axis, as the seed does. */
static int boxes_build(dlca_sim *s)
{
    boxes_free(s);
    for (int a = 0; a < s->d; a++)
        if (3 * (int64_t)s->A >= s->L[a]) {
            s->search_now = DLCA_SEARCH_ALLPAIRS;
            return 0;
        }
    uint64_t nb = 1;
    for (int a = 0; a < s->d; a++) {
        s->nb[a] = (s->L[a] + s->A - 1) / s->A;
        s->bstride[a] = (int64_t)nb;
        nb *= (uint64_t)s->nb[a];
    }
    s->nboxes = nb;
    if (!s->cand && !(s->cand = malloc(s->N * sizeof *s->cand))) return -1; /* the halo's candidates */
    s->box = calloc(nb, sizeof *s->box);
    s->box_n = calloc(nb, sizeof *s->box_n);
    s->box_cap = calloc(nb, sizeof *s->box_cap);
    if (!s->box || !s->box_n || !s->box_cap) return -1;
    for (uint64_t j = 0; j < s->nc; j++)
        if (box_register(s, s->act[j])) return -1;
    return 0;
}

/* After a join: grow A (doubling) until the largest extent fits. */
static int boxes_fit(dlca_sim *s, uint32_t c)
{
    if (s->search_now != DLCA_SEARCH_BOXES) return 0;
    int64_t ext = 0;
    for (int a = 0; a < s->d; a++) {
        const int64_t e = (int64_t)hi_of(s, c)[a] - lo_of(s, c)[a] + 1;
        if (e > ext) ext = e;
    }
    if (ext <= s->A) return 0;
    while (s->A < ext) s->A *= 2;
    return boxes_build(s);
}

/* ---- creation -------------------------------------------------------- */

static void sim_free(dlca_sim *s)
{
    if (!s) return;
    if (s->cl)
        for (uint64_t c = 1; c <= s->N; c++) cl_release(&s->cl[c]);
    boxes_free(s);
    free(s->pool);
    free(s->cl);
    free(s->geom);
    free(s->act);
    free(s->grid);
    free(s->mob);
    free(s->size_count);
    free(s->brange);
    free(s->stamp);
    free(s->cand);
    free(s->con);
    free(s->rows);
    free(s);
}

void dlca_destroy(dlca_sim *s) { sim_free(s); }

static void remove_active(dlca_sim *s, uint32_t c)
{
    const uint32_t j = s->cl[c].act;
    const uint32_t last = s->act[--s->nc];
    s->act[j] = last;
    s->cl[last].act = j;
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

/* Join b into c or c into b (the larger survives; on a tie the lower id),
 * disp = b's anchor in c's frame. Returns the survivor, 0 on no memory. */
static uint32_t join(dlca_sim *s, uint32_t c, uint32_t b, const int64_t *disp_in)
{
    int64_t disp[DLCA_MAX_DIM];
    const int d = s->d;
    uint32_t keep = c, gone = b;
    for (int a = 0; a < d; a++) disp[a] = disp_in[a];
    if (s->cl[b].n > s->cl[c].n || (s->cl[b].n == s->cl[c].n && b < c)) {
        keep = b;
        gone = c;
        for (int a = 0; a < d; a++) disp[a] = -disp[a];
    }
    dlca_cl *K = &s->cl[keep], *G = &s->cl[gone];
    const uint32_t n = K->n + G->n;
    if (n > K->cap) {
        uint32_t cap = K->cap ? K->cap : 1;
        while (cap < n) cap *= 2;
        if (cl_alloc(K, cap, d)) return 0;
    }
    if (s->search_now == DLCA_SEARCH_BOXES) {
        box_unregister(s, gone);
        box_unregister(s, keep);
    }
    int32_t *lo = lo_of(s, keep), *hi = hi_of(s, keep);
    for (uint32_t j = 0; j < G->n; j++) {
        K->k[K->n + j] = G->k[j];
        for (int a = 0; a < d; a++) {
            const int32_t o = (int32_t)(G->off[(size_t)j * d + a] + disp[a]);
            K->off[(size_t)(K->n + j) * d + a] = o;
            if (o < lo[a]) lo[a] = o;
            if (o > hi[a]) hi[a] = o;
        }
        if (s->grid) s->grid[G->k[j]] = keep;
    }
    s->sum_s2 += 2.0 * (double)K->n * (double)G->n;
    sizes_joined(s, K->n, G->n);
    K->n = n;
    G->n = 0;
    cl_release(G);
    remove_active(s, gone);
    if (n > s->largest) s->largest = n;
    s->merges++;
    for (int a = 0; a < d; a++)
        if ((int64_t)hi[a] - lo[a] + 1 >= s->L[a]) s->spanning = 1;
    if (s->search_now == DLCA_SEARCH_BOXES && !s->spanning) {
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
    for (int a = 0; a < s->d; a++) {
        const int64_t f = a == ax ? sg : 0;
        const int64_t ox = window(s, cur, a, xw[a]);
        const int64_t oy = window(s, b, a, wrap((int64_t)xw[a] + f, s->L[a]));
        disp[a] = ox + f - oy;
    }
    return join(s, cur, b, disp);
}

static int setup(dlca_sim **out, const dlca_params *p, const uint32_t *sites, uint64_t n, char *err,
                 size_t errlen)
{
    *out = NULL;
    int rc = dlca_params_validate(p, err, errlen);
    if (rc) return rc;
    uint32_t *placed = NULL;
    dlca_sim *s = calloc(1, sizeof *s);
    if (!s) return fail(err, errlen, PDLA_ENOMEM, "out of memory");
    s->p = *p;
    s->d = p->dim;
    s->V = 1;
    for (int a = 0; a < s->d; a++) {
        s->L[a] = p->box[a];
        s->stride[a] = (int64_t)s->V;
        s->V *= p->box[a];
    }
    s->N = sites ? n : dlca_params_monomers(p);
    if (s->N < 1 || s->N >= s->V) {
        sim_free(s);
        return fail(err, errlen, PDLA_EINVAL, "the box cannot hold that many monomers");
    }
    rng_seed(&s->rng, p->seed);
    s->cl = calloc(s->N + 1, sizeof *s->cl);
    s->geom = calloc((s->N + 1) * 3 * (size_t)s->d, sizeof *s->geom);
    s->act = malloc(s->N * sizeof *s->act);
    s->grid = calloc(s->V, sizeof *s->grid);
    s->stamp = calloc(s->N + 1, sizeof *s->stamp);
    s->pool = calloc(s->N * (1 + (size_t)s->d), sizeof *s->pool);
    if (!s->cl || !s->geom || !s->act || !s->grid || !s->stamp || !s->pool) goto nomem;
    if (p->mobility != 0) {
        s->mob = malloc((s->N + 1) * sizeof *s->mob);
        if (!s->mob) goto nomem;
        s->mob[0] = 0;
        for (uint64_t j = 1; j <= s->N; j++) s->mob[j] = pow((double)j, p->mobility);
        if (p->mobility < 0) {
            s->size_count = calloc(s->N + 1, sizeof *s->size_count);
            if (!s->size_count) goto nomem;
        }
    }
    /* Place the monomers: slot j holds the j-th one placed. */
    placed = malloc(s->N * sizeof *placed);
    if (!placed) goto nomem;
    for (uint64_t j = 1; j <= s->N; j++) {
        uint64_t k;
        if (sites) {
            k = sites[j - 1];
            if (k >= s->V || s->grid[k]) {
                free(placed);
                sim_free(s);
                return fail(err, errlen, PDLA_EINVAL, k >= s->V ? "a site is outside the box" : "two monomers on one site");
            }
        } else {
            do k = rng_below(&s->rng, s->V);
            while (s->grid[k]);
        }
        s->grid[k] = (uint32_t)j;
        placed[j - 1] = (uint32_t)k;
        dlca_cl *c = &s->cl[j];
        c->n = 1;
        c->cap = 0; /* borrowed from the pool */
        c->k = s->pool + (j - 1);
        c->off = (int32_t *)(s->pool + s->N + (j - 1) * (uint64_t)s->d);
        c->k[0] = (uint32_t)k;
        int64_t x[DLCA_MAX_DIM];
        coords(s, k, x);
        for (int a = 0; a < s->d; a++) anchor_of(s, (uint32_t)j)[a] = (int32_t)x[a];
        c->act = (uint32_t)(j - 1);
        s->act[j - 1] = (uint32_t)j;
    }
    s->nc = s->N;
    s->largest = 1;
    s->sum_s2 = (double)s->N;
    s->smin = 1;
    if (s->size_count) s->size_count[1] = (uint32_t)s->N;
    s->search_now = DLCA_SEARCH_LATTICE; /* boxes are built after the first joins */
    /* Face-adjacent monomers start joined: every placed site in placement
     * order, its directions in order (the same in every search mode). */
    for (uint64_t j = 1; j <= s->N && !s->spanning; j++) {
        const uint32_t k = placed[j - 1];
        int64_t x[DLCA_MAX_DIM];
        int32_t xw[DLCA_MAX_DIM];
        coords(s, k, x);
        for (int a = 0; a < s->d; a++) xw[a] = (int32_t)x[a];
        for (int dir = 0; dir < 2 * s->d && !s->spanning; dir++) {
            int64_t y[DLCA_MAX_DIM];
            memcpy(y, x, sizeof y);
            y[dir >> 1] += (dir & 1) ? -1 : 1;
            const uint32_t other = s->grid[dlca_site(s, y)], self = s->grid[k];
            if (other && other != self && !join_contact(s, self, other, xw, dir)) goto nomem;
        }
    }
    free(placed);
    placed = NULL;
    if (p->search != DLCA_SEARCH_LATTICE) {
        free(s->grid);
        s->grid = NULL;
        s->brange = malloc((s->N + 1) * 2 * (size_t)s->d * sizeof *s->brange);
        if (!s->brange) goto nomem;
        s->search_now = p->search;
        if (p->search == DLCA_SEARCH_BOXES) {
            s->A = p->grid_box;
            int64_t ext = 1;
            for (uint64_t j = 0; j < s->nc; j++)
                for (int a = 0; a < s->d; a++) {
                    const uint32_t c = s->act[j];
                    const int64_t e = (int64_t)hi_of(s, c)[a] - lo_of(s, c)[a] + 1;
                    if (e > ext) ext = e;
                }
            while (s->A < ext) s->A *= 2;
            if (boxes_build(s)) goto nomem;
        }
    }
    add_row(s);
    if (s->spanning) s->stop = DLCA_STOP_SPANNING;
    else if (s->nc <= p->until_clusters) s->stop = DLCA_STOP_CLUSTERS;
    *out = s;
    return 0;
nomem:
    free(placed);
    sim_free(s);
    return fail(err, errlen, PDLA_ENOMEM, "out of memory for the DLCA lattice and clusters");
}

int dlca_create(dlca_sim **out, const dlca_params *p, char *err, size_t errlen)
{
    return setup(out, p, NULL, 0, err, errlen);
}

int dlca_create_sites(dlca_sim **out, const dlca_params *p, const uint32_t *sites, uint64_t n,
                      char *err, size_t errlen)
{
    if (!sites || n == 0) return fail(err, errlen, PDLA_EINVAL, "no sites given");
    dlca_params q = *p;
    q.count = n; /* so that validation counts these monomers */
    return setup(out, &q, sites, n, err, errlen);
}

/* ---- moves ------------------------------------------------------------ */

static void add_contact(dlca_sim *s, uint32_t b, uint32_t i, int dir)
{
    if (s->ncon == s->capcon) {
        const size_t cap = s->capcon ? 2 * s->capcon : 16;
        contact *c = realloc(s->con, cap * sizeof *c);
        if (!c) {
            s->oom = 1; /* do_move reports it */
            return;
        }
        s->con = c;
        s->capcon = cap;
    }
    contact *x = &s->con[s->ncon++];
    x->b = b;
    x->i = i;
    x->dir = dir;
}

/* The id-lattice move: overlap test (only needed when sticking < 1: with
 * p = 1 no two clusters are ever adjacent, so a unit step cannot overlap),
 * the move, then the neighbours of every new site. */
static int move_lattice(dlca_sim *s, uint32_t c, int a, int sg)
{
    dlca_cl *C = &s->cl[c];
    const int d = s->d;
    const int64_t L = s->L[a], st = s->stride[a];
    int32_t *anc = anchor_of(s, c);
    const int32_t T = (int32_t)window(s, c, a, sg > 0 ? L - 1 : 0);
    const int64_t dn = sg * st, dw = -sg * (L - 1) * st;
    uint32_t *k = C->k;
    const int32_t *offa = C->off + a;
    const uint32_t n = C->n;
    uint32_t *grid = s->grid;
    if (s->p.sticking < 1)
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t id = grid[(int64_t)k[i] + (offa[(size_t)i * d] == T ? dw : dn)];
            if (id && id != c) return DLCA_REFUSED;
        }
    for (uint32_t i = 0; i < n; i++) {
        grid[k[i]] = 0;
        k[i] = (uint32_t)((int64_t)k[i] + (offa[(size_t)i * d] == T ? dw : dn));
    }
    for (uint32_t i = 0; i < n; i++) grid[k[i]] = c;
    anc[a] = (int32_t)wrap((int64_t)anc[a] + sg, L);

    int32_t T0[DLCA_MAX_DIM], T1[DLCA_MAX_DIM];
    for (int b = 0; b < d; b++) {
        T0[b] = (int32_t)window(s, c, b, 0);
        T1[b] = (int32_t)window(s, c, b, s->L[b] - 1);
    }
    s->ncon = 0;
    const uint32_t stamp = next_stamp(s);
    const int skip = 2 * a + (sg > 0); /* the way back: own old site */
    /* With sticking 1 no cluster touched the mover before, so a monomer
     * whose site ahead is its own (x + e was in the cluster) cannot touch
     * anything now: every neighbour of x + e was free of other clusters.
     * Only the leading face is scanned. */
    const int lead_only = s->p.sticking >= 1;
    const int64_t fw_n = sg * st, fw_w = -sg * (L - 1) * st;
    const int32_t Tf = sg > 0 ? T1[a] : T0[a];
    for (uint32_t i = 0; i < n; i++) {
        const int32_t *o = C->off + (size_t)i * d;
        const int64_t ki = k[i];
        if (lead_only && grid[ki + (o[a] == Tf ? fw_w : fw_n)] == c) continue;
        for (int b = 0; b < d; b++) {
            const int64_t sb = s->stride[b], wb = (s->L[b] - 1) * sb;
            const int64_t kp = o[b] == T1[b] ? ki - wb : ki + sb;
            const int64_t km = o[b] == T0[b] ? ki + wb : ki - sb;
            uint32_t id;
            if (2 * b != skip && (id = grid[kp]) && id != c && s->stamp[id] != stamp) {
                s->stamp[id] = stamp;
                add_contact(s, id, i, 2 * b);
            }
            if (2 * b + 1 != skip && (id = grid[km]) && id != c && s->stamp[id] != stamp) {
                s->stamp[id] = stamp;
                add_contact(s, id, i, 2 * b + 1);
            }
        }
    }
    return DLCA_MOVED;
}

enum { PAIR_NONE, PAIR_CONTACT, PAIR_OVERLAP };

/* Does cluster b touch (or overlap) cluster c placed at anchor na? The
 * first contact is the lowest monomer of c, then the lowest direction. */
static int pair_test(const dlca_sim *s, uint32_t c, const int32_t *na, uint32_t b, int full, uint32_t *ci,
                     int *cdir)
{
    const int d = s->d;
    const int32_t *lc = lo_of(s, c), *hc = hi_of(s, c), *lb = lo_of(s, b), *hb = hi_of(s, b);
    const int32_t *ab = anchor_of(s, b);
    int64_t D[DLCA_MAX_DIM];
    /* Bounding boxes first (c's grown by one site): most pairs stop here. */
    for (int a = 0; a < d; a++) {
        const int64_t L = s->L[a], wc = (int64_t)hc[a] - lc[a] + 3, wb = (int64_t)hb[a] - lb[a] + 1;
        if (wc < L && wb < L) {
            const int64_t sc = wrap((int64_t)na[a] + lc[a] - 1, L), sb = wrap((int64_t)ab[a] + lb[a], L);
            if (!(wrap(sb - sc, L) < wc || wrap(sc - sb, L) < wb)) return PAIR_NONE;
        }
        D[a] = (int64_t)ab[a] - na[a];
    }
    const dlca_cl *C = &s->cl[c], *B = &s->cl[b];
    int found = 0;
    for (uint32_t i = 0; i < C->n; i++) {
        const int32_t *oc = C->off + (size_t)i * d;
        int best = 2 * DLCA_MAX_DIM;
        for (uint32_t j = 0; j < B->n; j++) {
            const int32_t *ob = B->off + (size_t)j * d;
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

/* The seed's searches: all pairs, or the clusters registered in the boxes
 * that c's grown bounding box covers at its new place. */
static int move_ref(dlca_sim *s, uint32_t c, int a, int sg)
{
    dlca_cl *C = &s->cl[c];
    const int d = s->d;
    int32_t *anc = anchor_of(s, c);
    int32_t na[DLCA_MAX_DIM];
    memcpy(na, anc, (size_t)d * sizeof *na);
    na[a] = (int32_t)wrap((int64_t)na[a] + sg, s->L[a]);
    size_t ncand;
    const uint32_t *cand;
    (void)next_stamp(s);
    if (s->search_now == DLCA_SEARCH_BOXES) {
        int32_t b0[DLCA_MAX_DIM], cnt[DLCA_MAX_DIM];
        cluster_span(s, c, na, 1, b0, cnt);
        s->ncon = 0;
        (void)for_boxes(s, b0, cnt, halo_collect, c);
        ncand = s->ncon;
        cand = s->cand;
    } else {
        ncand = s->nc;
        cand = s->act;
    }
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
    const int32_t T = (int32_t)window(s, c, a, sg > 0 ? L - 1 : 0);
    const int64_t dn = sg * st, dw = -sg * (L - 1) * st;
    for (uint32_t i = 0; i < C->n; i++)
        C->k[i] = (uint32_t)((int64_t)C->k[i] + (C->off[(size_t)i * d + a] == T ? dw : dn));
    if (s->search_now == DLCA_SEARCH_BOXES) {
        int32_t b0[DLCA_MAX_DIM], cnt[DLCA_MAX_DIM];
        cluster_span(s, c, na, 0, b0, cnt);
        const int32_t *r = brange_of(s, c);
        if (memcmp(b0, r, (size_t)d * sizeof *b0) || memcmp(cnt, r + d, (size_t)d * sizeof *cnt)) {
            box_unregister(s, c);
            memcpy(anc, na, (size_t)d * sizeof *na);
            if (box_register(s, c)) return PDLA_ENOMEM;
        }
    }
    memcpy(anc, na, (size_t)d * sizeof *na);
    return DLCA_MOVED;
}

/* Join the mover with what it touches, in cluster-id order. */
static int join_contacts(dlca_sim *s, uint32_t c)
{
    const int d = s->d;
    const int32_t *anc = anchor_of(s, c);
    for (size_t j = 0; j < s->ncon; j++) {
        contact *x = &s->con[j];
        for (int a = 0; a < d; a++)
            x->xw[a] = (int32_t)wrap((int64_t)anc[a] + s->cl[c].off[(size_t)x->i * d + a], s->L[a]);
    }
    for (size_t j = 1; j < s->ncon; j++) /* insertion sort: a handful */
        for (size_t m = j; m > 0 && s->con[m - 1].b > s->con[m].b; m--) {
            const contact t = s->con[m];
            s->con[m] = s->con[m - 1];
            s->con[m - 1] = t;
        }
    uint32_t cur = c;
    for (size_t j = 0; j < s->ncon && !s->spanning; j++) {
        if (s->p.sticking < 1 && rng_uniform(&s->rng) >= s->p.sticking) continue;
        cur = join_contact(s, cur, s->con[j].b, s->con[j].xw, s->con[j].dir);
        if (!cur) return PDLA_ENOMEM;
    }
    if (s->ncon) maybe_row(s);
    return 0;
}

static int do_move(dlca_sim *s, uint32_t c, int a, int sg)
{
    const uint32_t n = s->cl[c].n;
    const int r = s->search_now == DLCA_SEARCH_LATTICE ? move_lattice(s, c, a, sg) : move_ref(s, c, a, sg);
    if (s->oom) return PDLA_ENOMEM;
    if (r != DLCA_MOVED) return r;
    s->moves++;
    s->monomer_moves += n;
    const int jr = join_contacts(s, c);
    return jr ? jr : DLCA_MOVED;
}

static int check_stop(dlca_sim *s)
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
    double mb = 1;
    if (s->mob) mb = s->p.mobility < 0 ? s->mob[s->smin] : s->mob[s->largest];
    s->t += 1.0 / ((double)s->nc * mb);
    if (s->mob && rng_uniform(&s->rng) * mb >= s->mob[s->cl[c].n]) {
        digest_add(s, c | (uint64_t)DLCA_NOT_PICKED << 40);
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
    digest_add(s, c | (uint64_t)(2 * a + (sg < 0)) << 32 | (uint64_t)(r < 0 ? 7 : r) << 40);
    return r < 0 ? r : 0;
}

int dlca_run(dlca_sim *s, uint64_t attempts)
{
    if (s->stop) return s->stop;
    for (uint64_t j = 0; attempts == 0 || j < attempts; j++) {
        if (step(s) < 0) {
            s->stop = DLCA_STOP_CALLER; /* out of memory in a join */
            break;
        }
        if (check_stop(s)) break;
    }
    if (s->stop && (!s->nrows || s->rows[s->nrows - 1].attempts != s->attempts)) add_row(s);
    return s->stop;
}

/* ---- test hooks ---------------------------------------------------------- */

static uint32_t slot_at(const dlca_sim *s, uint32_t k)
{
    if (s->grid) return s->grid[k];
    for (uint64_t j = 0; j < s->nc; j++) {
        const dlca_cl *C = &s->cl[s->act[j]];
        for (uint32_t i = 0; i < C->n; i++)
            if (C->k[i] == k) return s->act[j];
    }
    return 0;
}

int dlca_move_site(dlca_sim *s, uint32_t k, int axis, int sign)
{
    const uint32_t c = k < s->V ? slot_at(s, k) : 0;
    if (!c || axis < 0 || axis >= s->d || (sign != 1 && sign != -1)) return PDLA_EINVAL;
    s->attempts++;
    const int r = do_move(s, c, axis, sign);
    digest_add(s, c | (uint64_t)(2 * axis + (sign < 0)) << 32 | (uint64_t)(r < 0 ? 7 : r) << 40);
    (void)check_stop(s);
    return r;
}

uint64_t dlca_size_at(const dlca_sim *s, uint32_t k)
{
    const uint32_t c = k < s->V ? slot_at(s, k) : 0;
    return c ? s->cl[c].n : 0;
}

int64_t dlca_extent_at(const dlca_sim *s, uint32_t k, int axis)
{
    const uint32_t c = k < s->V ? slot_at(s, k) : 0;
    return c ? (int64_t)hi_of(s, c)[axis] - lo_of(s, c)[axis] + 1 : 0;
}

/* ---- results -------------------------------------------------------------- */

const char *dlca_stop_name(int stop)
{
    static const char *names[] = {"running", "clusters", "time", "spanning", "attempts", "stopped"};
    return stop >= 0 && stop <= 5 ? names[stop] : "unknown";
}

const dlca_params *dlca_get_params(const dlca_sim *s) { return &s->p; }

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
    uint64_t b = sizeof *s + (s->N + 1) * (sizeof *s->cl + 3 * (size_t)s->d * sizeof *s->geom + sizeof *s->stamp) +
                 s->N * (sizeof *s->act + (1 + (size_t)s->d) * sizeof *s->pool);
    if (s->cand) b += s->N * sizeof *s->cand;
    if (s->grid) b += s->V * sizeof *s->grid;
    if (s->mob) b += (s->N + 1) * sizeof *s->mob;
    if (s->size_count) b += (s->N + 1) * sizeof *s->size_count;
    if (s->brange) b += (s->N + 1) * 2 * (size_t)s->d * sizeof *s->brange;
    for (uint64_t j = 0; j < s->nc; j++)
        b += (uint64_t)s->cl[s->act[j]].cap * (sizeof(uint32_t) + (size_t)s->d * sizeof(int32_t));
    for (uint64_t j = 0; j < s->nboxes; j++) b += sizeof(uint32_t *) + 8 + s->box_cap[j] * sizeof(uint32_t);
    o->bytes = b;
}

const dlca_row *dlca_series(const dlca_sim *s, size_t *n)
{
    *n = s->nrows;
    return s->rows;
}

void dlca_export_sites(const dlca_sim *s, uint32_t *site, uint32_t *cluster)
{
    uint64_t m = 0;
    uint32_t id = 0;
    for (uint64_t c = 1; c <= s->N; c++) {
        const dlca_cl *C = &s->cl[c];
        if (!C->n) continue;
        for (uint32_t i = 0; i < C->n; i++, m++) {
            site[m] = C->k[i];
            cluster[m] = id;
        }
        id++;
    }
}

void dlca_cluster_table(const dlca_sim *s, uint64_t *size, double *rg)
{
    uint64_t id = 0;
    const int d = s->d;
    for (uint64_t c = 1; c <= s->N; c++) {
        const dlca_cl *C = &s->cl[c];
        if (!C->n) continue;
        double var = 0;
        for (int a = 0; a < d; a++) {
            double m1 = 0, m2 = 0;
            for (uint32_t i = 0; i < C->n; i++) {
                const double o = C->off[(size_t)i * d + a];
                m1 += o;
                m2 += o * o;
            }
            m1 /= C->n;
            var += m2 / C->n - m1 * m1;
        }
        size[id] = C->n;
        rg[id] = sqrt(var > 0 ? var : 0);
        id++;
    }
}

/* ---- the consistency check ----------------------------------------------- */

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

#define BAD(...)                                             \
    do {                                                     \
        if (err && errlen) snprintf(err, errlen, __VA_ARGS__); \
        rc = PDLA_EINVAL;                                     \
        goto done;                                           \
    } while (0)

int dlca_check(const dlca_sim *s, char *err, size_t errlen)
{
    const int d = s->d;
    int rc = 0;
    uint64_t *ks = malloc(s->N * sizeof *ks); /* (site << 32) | slot */
    if (!ks) return fail(err, errlen, PDLA_ENOMEM, "out of memory");
    uint64_t m = 0, active = 0, largest = 0;
    double s2 = 0;
    for (uint64_t c = 1; c <= s->N; c++) {
        const dlca_cl *C = &s->cl[c];
        if (!C->n) continue;
        active++;
        if (C->act >= s->nc || s->act[C->act] != c) BAD("cluster %llu is not in the active list", (unsigned long long)c);
        if (m + C->n > s->N) BAD("cluster sizes add up to more than N = %llu", (unsigned long long)s->N);
        if (C->n > largest) largest = C->n;
        s2 += (double)C->n * C->n;
        const int32_t *anc = anchor_of(s, c), *lo = lo_of(s, c), *hi = hi_of(s, c);
        int32_t tlo[DLCA_MAX_DIM], thi[DLCA_MAX_DIM];
        for (int a = 0; a < d; a++) tlo[a] = thi[a] = C->off[a];
        for (uint32_t i = 0; i < C->n; i++) {
            int64_t x[DLCA_MAX_DIM];
            for (int a = 0; a < d; a++) {
                const int32_t o = C->off[(size_t)i * d + a];
                x[a] = (int64_t)anc[a] + o;
                if (o < tlo[a]) tlo[a] = o;
                if (o > thi[a]) thi[a] = o;
            }
            if (dlca_site(s, x) != C->k[i])
                BAD("cluster %llu monomer %u: site %u does not match its offset", (unsigned long long)c, i, C->k[i]);
            if (s->grid && s->grid[C->k[i]] != c)
                BAD("site %u holds id %u, not its cluster %llu", C->k[i], s->grid[C->k[i]], (unsigned long long)c);
            ks[m++] = (uint64_t)C->k[i] << 32 | c;
        }
        for (int a = 0; a < d; a++) {
            if (tlo[a] != lo[a] || thi[a] != hi[a]) BAD("cluster %llu: bounding box is stale", (unsigned long long)c);
            if (!s->spanning && (int64_t)hi[a] - lo[a] + 1 >= s->L[a])
                BAD("cluster %llu spans axis %d but the run did not stop", (unsigned long long)c, a);
        }
    }
    if (m != s->N) BAD("cluster sizes add up to %llu, not N = %llu", (unsigned long long)m, (unsigned long long)s->N);
    if (active != s->nc) BAD("%llu clusters hold monomers, N_c says %llu", (unsigned long long)active, (unsigned long long)s->nc);
    if (largest != s->largest) BAD("largest cluster %llu, recorded %llu", (unsigned long long)largest, (unsigned long long)s->largest);
    if (s2 != s->sum_s2) BAD("sum of s^2 %.0f, recorded %.0f", s2, s->sum_s2);
    if (s->size_count) {
        uint64_t smin = s->N;
        for (uint64_t j = 0; j < s->nc; j++)
            if (s->cl[s->act[j]].n < smin) smin = s->cl[s->act[j]].n;
        if (smin != s->smin) BAD("smallest cluster %llu, recorded %llu", (unsigned long long)smin, (unsigned long long)s->smin);
    }
    qsort(ks, m, sizeof *ks, cmp_u64);
    for (uint64_t j = 1; j < m; j++)
        if (ks[j] >> 32 == ks[j - 1] >> 32) BAD("two monomers on site %llu", (unsigned long long)(ks[j] >> 32));
    if (s->grid) {
        uint64_t filled = 0;
        for (uint64_t k = 0; k < s->V; k++) filled += s->grid[k] != 0;
        if (filled != s->N) BAD("the id lattice holds %llu sites, N = %llu", (unsigned long long)filled, (unsigned long long)s->N);
    }
    if (s->p.sticking >= 1 && !s->spanning)
        for (uint64_t j = 0; j < m; j++) {
            int64_t x[DLCA_MAX_DIM];
            coords(s, ks[j] >> 32, x);
            for (int dir = 0; dir < 2 * d; dir++) {
                int64_t y[DLCA_MAX_DIM];
                memcpy(y, x, sizeof y);
                y[dir >> 1] += (dir & 1) ? -1 : 1;
                const uint64_t key = (uint64_t)dlca_site(s, y) << 32;
                /* binary search for the site */
                uint64_t lo = 0, hi = m;
                while (lo < hi) {
                    const uint64_t mid = (lo + hi) / 2;
                    if (ks[mid] < key) lo = mid + 1;
                    else hi = mid;
                }
                if (lo < m && ks[lo] >> 32 == key >> 32 && (ks[lo] & 0xffffffffu) != (ks[j] & 0xffffffffu))
                    BAD("clusters %llu and %llu touch but did not join", (unsigned long long)(ks[j] & 0xffffffffu),
                        (unsigned long long)(ks[lo] & 0xffffffffu));
            }
        }
    if (s->search_now == DLCA_SEARCH_BOXES && !s->spanning) { /* a spanning join stops the bookkeeping */
        uint64_t listed = 0, expect = 0;
        for (uint64_t b = 0; b < s->nboxes; b++) listed += s->box_n[b];
        for (uint64_t j = 0; j < s->nc; j++) {
            const uint32_t c = s->act[j];
            int32_t b0[DLCA_MAX_DIM], cnt[DLCA_MAX_DIM];
            cluster_span(s, c, anchor_of(s, c), 0, b0, cnt);
            const int32_t *r = brange_of(s, c);
            if (memcmp(b0, r, (size_t)d * sizeof *b0) || memcmp(cnt, r + d, (size_t)d * sizeof *cnt))
                BAD("cluster %u is registered in stale boxes", c);
            uint64_t e = 1;
            for (int a = 0; a < d; a++) {
                e *= (uint64_t)cnt[a];
                if ((int64_t)hi_of(s, c)[a] - lo_of(s, c)[a] + 1 > s->A) BAD("cluster %u is wider than A = %d", c, s->A);
            }
            expect += e;
        }
        if (listed != expect) BAD("boxes list %llu entries, expected %llu", (unsigned long long)listed, (unsigned long long)expect);
    }
done:
    free(ks);
    return rc;
}

/* ---- checkpoints ---------------------------------------------------------- */

#include "dlca_h5.h"

/* The scalars of the state, in one array of doubles and one of u64. */
enum { CK_U_ATT, CK_U_MOV, CK_U_MMOV, CK_U_MRG, CK_U_LARGE, CK_U_CAND, CK_U_DIG, CK_U_NC, CK_U_ROWNC, CK_U_SMIN,
       CK_U_A, CK_U_SEARCH, CK_U_SPAN, CK_U_STOP, CK_U_N, CK_NU };
enum { CK_D_T, CK_D_S2, CK_ND };

static int ck_write(const h5u_writer *w, hid_t loc, const char *name, hid_t ftype, hid_t mtype, const void *data,
                    size_t n)
{
    hid_t space = H5I_INVALID_HID, d;
    int rc = 0;
    if ((d = h5u_dataset(w, loc, name, ftype, 1, n, 1, n > 65536 ? 65536 : (n ? n : 1), &space)) < 0) return -1;
    if (n > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) rc = h5u_fail(w, "write %s", name);
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

int dlca_checkpoint_write(const dlca_sim *s, const char *path, char *err, size_t errlen)
{
    h5u_writer w = {path, err, errlen};
    h5u_quiet q;
    if (h5u_silence(&q)) return fail(err, errlen, PDLA_EIO, "cannot silence HDF5");
    const int d = s->d;
    uint64_t u[CK_NU] = {s->attempts, s->moves, s->monomer_moves, s->merges, s->largest, s->candidates,
                         s->digest, s->nc, s->row_nc, s->smin, (uint64_t)s->A, (uint64_t)s->search_now,
                         (uint64_t)s->spanning, (uint64_t)s->stop, s->N};
    double dv[CK_ND] = {s->t, s->sum_s2};
    uint32_t *slot_n = malloc((s->N + 1) * sizeof *slot_n), *k = malloc(s->N * sizeof *k);
    int32_t *off = malloc(s->N * (size_t)d * sizeof *off);
    double *rt = malloc((s->nrows + 1) * sizeof(double) * 3);
    uint64_t *ru = malloc((s->nrows + 1) * sizeof(uint64_t) * 3);
    hid_t file = H5I_INVALID_HID;
    int rc = -1;
    if (!slot_n || !k || !off || !rt || !ru) {
        h5u_fail_msg(&w, "cannot write %s: out of memory", path);
        goto done;
    }
    uint64_t m = 0;
    for (uint64_t c = 0; c <= s->N; c++) {
        slot_n[c] = c ? s->cl[c].n : 0;
        for (uint32_t i = 0; c && i < s->cl[c].n; i++, m++) {
            k[m] = s->cl[c].k[i];
            memcpy(off + m * d, s->cl[c].off + (size_t)i * d, (size_t)d * sizeof *off);
        }
    }
    for (size_t r = 0; r < s->nrows; r++) {
        rt[3 * r] = s->rows[r].t;
        rt[3 * r + 1] = s->rows[r].mean_size;
        rt[3 * r + 2] = s->rows[r].weight_size;
        ru[3 * r] = s->rows[r].attempts;
        ru[3 * r + 1] = s->rows[r].n_clusters;
        ru[3 * r + 2] = s->rows[r].largest;
    }
    if ((file = h5u_create_file(&w, path)) < 0) goto done;
    if (h5u_attr_str(&w, file, "model", "dlca-checkpoint") < 0 || h5u_attr_int(&w, file, "format_version", 1) < 0 ||
        dlca_write_parameters_h5(&w, file, &s->p) < 0 ||
        ck_write(&w, file, "rng", H5T_STD_U64LE, H5T_NATIVE_UINT64, s->rng.s, 4) < 0 ||
        ck_write(&w, file, "u64", H5T_STD_U64LE, H5T_NATIVE_UINT64, u, CK_NU) < 0 ||
        ck_write(&w, file, "f64", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, dv, CK_ND) < 0 ||
        ck_write(&w, file, "slot_n", H5T_STD_U32LE, H5T_NATIVE_UINT32, slot_n, s->N + 1) < 0 ||
        ck_write(&w, file, "geom", H5T_STD_I32LE, H5T_NATIVE_INT32, s->geom, (s->N + 1) * 3 * (size_t)d) < 0 ||
        ck_write(&w, file, "active", H5T_STD_U32LE, H5T_NATIVE_UINT32, s->act, s->nc) < 0 ||
        ck_write(&w, file, "site", H5T_STD_U32LE, H5T_NATIVE_UINT32, k, s->N) < 0 ||
        ck_write(&w, file, "offset", H5T_STD_I32LE, H5T_NATIVE_INT32, off, s->N * (size_t)d) < 0 ||
        ck_write(&w, file, "rows_f64", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, rt, 3 * s->nrows) < 0 ||
        ck_write(&w, file, "rows_u64", H5T_STD_U64LE, H5T_NATIVE_UINT64, ru, 3 * s->nrows) < 0)
        goto done;
    rc = 0;
done:
    if (file >= 0) rc = h5u_close(&w, rc, file, H5Fclose, path);
    free(slot_n), free(k), free(off), free(rt), free(ru);
    h5u_restore(&q);
    return rc < 0 ? PDLA_EIO : 0;
}

/* Read dataset name of exactly n elements. */
static int ck_read(hid_t f, const char *name, hid_t mtype, void *buf, size_t n)
{
    const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
    if (d < 0) return -1;
    const hid_t sp = H5Dget_space(d);
    const hssize_t have = sp >= 0 ? H5Sget_simple_extent_npoints(sp) : -1;
    int rc = have == (hssize_t)n ? 0 : -1;
    if (rc == 0 && n && H5Dread(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) rc = -1;
    if (sp >= 0) H5Sclose(sp);
    H5Dclose(d);
    return rc;
}

int dlca_checkpoint_load(dlca_sim **out, const char *path, char *err, size_t errlen)
{
    *out = NULL;
    h5u_quiet q;
    if (h5u_silence(&q)) return fail(err, errlen, PDLA_EIO, "cannot silence HDF5");
    dlca_sim *s = NULL;
    uint32_t *slot_n = NULL, *k = NULL, *one = NULL;
    int32_t *off = NULL;
    double *rt = NULL;
    uint64_t *ru = NULL;
    int rc = PDLA_EIO;
    char why[256] = "";
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        snprintf(why, sizeof why, "cannot open it as HDF5");
        goto done;
    }
    /* The parameters, through the table: every field the writer wrote. */
    dlca_params p;
    dlca_params_default(&p);
    if (dlca_read_parameters_h5(f, &p)) {
        snprintf(why, sizeof why, "not a DLCA checkpoint (no readable /parameters)");
        goto done;
    }
    uint64_t u[CK_NU];
    double dv[CK_ND];
    if (ck_read(f, "u64", H5T_NATIVE_UINT64, u, CK_NU) || ck_read(f, "f64", H5T_NATIVE_DOUBLE, dv, CK_ND)) {
        snprintf(why, sizeof why, "not a DLCA checkpoint (no state)");
        goto done;
    }
    const uint64_t N = u[CK_U_N];
    if (N != dlca_params_monomers(&p) && p.count == 0) p.count = N;
    p.count = N;
    const int d = p.dim;
    slot_n = malloc((N + 1) * sizeof *slot_n);
    k = malloc(N * sizeof *k);
    off = malloc(N * (size_t)d * sizeof *off);
    one = malloc(sizeof *one);
    if (!slot_n || !k || !off || !one) {
        rc = PDLA_ENOMEM;
        snprintf(why, sizeof why, "out of memory");
        goto done;
    }
    if (ck_read(f, "slot_n", H5T_NATIVE_UINT32, slot_n, N + 1) || ck_read(f, "site", H5T_NATIVE_UINT32, k, N) ||
        ck_read(f, "offset", H5T_NATIVE_INT32, off, N * (size_t)d)) {
        snprintf(why, sizeof why, "its monomer arrays are missing or have the wrong length");
        goto done;
    }
    /* A fresh sim of these parameters from the saved sites, then the state
     * laid over it. */
    dlca_params q0 = p;
    q0.search = DLCA_SEARCH_LATTICE;
    if ((rc = dlca_create_sites(&s, &q0, k, N, why, sizeof why))) goto done;
    rc = PDLA_EIO;
    s->p = p;
    for (uint64_t c = 1; c <= N; c++) {
        cl_release(&s->cl[c]);
        s->cl[c].n = 0;
    }
    memset(s->grid, 0, s->V * sizeof *s->grid);
    if (ck_read(f, "rng", H5T_NATIVE_UINT64, s->rng.s, 4) ||
        ck_read(f, "geom", H5T_NATIVE_INT32, s->geom, (N + 1) * 3 * (size_t)d) ||
        ck_read(f, "active", H5T_NATIVE_UINT32, s->act, u[CK_U_NC])) {
        snprintf(why, sizeof why, "its state arrays are missing or have the wrong length");
        goto done;
    }
    uint64_t m = 0;
    for (uint64_t c = 1; c <= N; c++) {
        const uint32_t n = slot_n[c];
        if (!n) continue;
        if (m + n > N) {
            snprintf(why, sizeof why, "its cluster sizes add up to more than N");
            goto done;
        }
        dlca_cl *C = &s->cl[c];
        if (cl_alloc(C, n, d)) {
            rc = PDLA_ENOMEM;
            snprintf(why, sizeof why, "out of memory");
            goto done;
        }
        C->n = n;
        memcpy(C->k, k + m, n * sizeof *C->k);
        memcpy(C->off, off + m * d, (size_t)n * d * sizeof *C->off);
        for (uint32_t i = 0; i < n; i++) s->grid[C->k[i]] = (uint32_t)c;
        m += n;
    }
    s->nc = u[CK_U_NC];
    for (uint64_t j = 0; j < s->nc; j++) {
        if (s->act[j] < 1 || s->act[j] > N || !s->cl[s->act[j]].n) {
            snprintf(why, sizeof why, "its active list names an empty cluster");
            goto done;
        }
        s->cl[s->act[j]].act = (uint32_t)j;
    }
    s->attempts = u[CK_U_ATT];
    s->moves = u[CK_U_MOV];
    s->monomer_moves = u[CK_U_MMOV];
    s->merges = u[CK_U_MRG];
    s->largest = u[CK_U_LARGE];
    s->candidates = u[CK_U_CAND];
    s->digest = u[CK_U_DIG];
    s->row_nc = u[CK_U_ROWNC];
    s->smin = u[CK_U_SMIN];
    s->spanning = (int)u[CK_U_SPAN];
    s->stop = (int)u[CK_U_STOP];
    s->t = dv[CK_D_T];
    s->sum_s2 = dv[CK_D_S2];
    if (s->size_count) {
        memset(s->size_count, 0, (N + 1) * sizeof *s->size_count);
        for (uint64_t j = 0; j < s->nc; j++) s->size_count[s->cl[s->act[j]].n]++;
    }
    /* The series. */
    const hid_t dr = H5Dopen2(f, "rows_u64", H5P_DEFAULT);
    size_t nr = 0;
    if (dr >= 0) {
        const hid_t sp = H5Dget_space(dr);
        nr = (size_t)H5Sget_simple_extent_npoints(sp) / 3;
        H5Sclose(sp);
        H5Dclose(dr);
    }
    rt = malloc((nr + 1) * 3 * sizeof *rt);
    ru = malloc((nr + 1) * 3 * sizeof *ru);
    dlca_row *rows = realloc(s->rows, (nr + 1) * sizeof *rows);
    if (!rt || !ru || !rows) {
        rc = PDLA_ENOMEM;
        snprintf(why, sizeof why, "out of memory");
        goto done;
    }
    s->rows = rows;
    s->caprows = nr + 1;
    if (ck_read(f, "rows_f64", H5T_NATIVE_DOUBLE, rt, 3 * nr) || ck_read(f, "rows_u64", H5T_NATIVE_UINT64, ru, 3 * nr)) {
        snprintf(why, sizeof why, "its series is damaged");
        goto done;
    }
    for (size_t r = 0; r < nr; r++)
        s->rows[r] = (dlca_row){rt[3 * r], ru[3 * r], ru[3 * r + 1], ru[3 * r + 2], rt[3 * r + 1], rt[3 * r + 2]};
    s->nrows = nr;
    /* The search structures from the state. */
    if (p.search != DLCA_SEARCH_LATTICE) {
        free(s->grid);
        s->grid = NULL;
        s->brange = malloc((N + 1) * 2 * (size_t)d * sizeof *s->brange);
        if (!s->brange) {
            rc = PDLA_ENOMEM;
            snprintf(why, sizeof why, "out of memory");
            goto done;
        }
        s->search_now = (int)u[CK_U_SEARCH];
        s->A = (int)u[CK_U_A];
        if (s->search_now == DLCA_SEARCH_BOXES && boxes_build(s)) {
            rc = PDLA_ENOMEM;
            snprintf(why, sizeof why, "out of memory");
            goto done;
        }
    } else s->search_now = DLCA_SEARCH_LATTICE;
    char cerr[160];
    if (dlca_check(s, cerr, sizeof cerr)) {
        snprintf(why, sizeof why, "its state is inconsistent: %s", cerr);
        goto done;
    }
    rc = 0;
done:
    if (f >= 0) H5Fclose(f);
    h5u_restore(&q);
    free(slot_n), free(k), free(off), free(one), free(rt), free(ru);
    if (rc) {
        dlca_destroy(s);
        if (err && errlen) snprintf(err, errlen, "cannot resume from %s: %s", path, why);
        return rc;
    }
    *out = s;
    return 0;
}

int dlca_set_stops(dlca_sim *s, uint64_t until_clusters, double until_time, uint64_t max_attempts)
{
    s->p.until_clusters = until_clusters;
    s->p.until_time = until_time;
    s->p.max_attempts = max_attempts;
    if (s->stop != DLCA_STOP_SPANNING) s->stop = 0;
    return check_stop(s);
}
