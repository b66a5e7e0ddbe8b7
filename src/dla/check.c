/*
 * check.c - pdla_check_*: an independent check of a DLA cluster from its
 * particle centres (include/pdla/pdla.h). It shares nothing with the growth
 * but the tree and the R_g formula (engine.c gyration_sums_add and
 * gyration_rg_diam, so R_g compares bit for bit): the rows go into a fresh tree, and each is compared with the
 * particles already stored by scanning the leaves its contact ball meets
 * (D + eps <= 192 units < one leaf, so at most 2 leaves per axis), not by the
 * walkers' bounded searches. Everything is integer and exact.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine.h"
#include "tree.h"

/* One bit per tree slot (chunk x 10 + slot; half id x 5 + slot), for the
 * walk's reached set and the arrival match's used set. */
typedef struct slot_bits {
    uint64_t *chunk, *half;
} slot_bits;

struct pdla_check {
    tree t;
    int dim, arrival, finished;
    int64_t D, reach;       /* D and D + eps, units */
    uint64_t D2, contact2;  /* D^2 and (D + eps)^2 */
    uint64_t rows;
    gyration_sums g;
    uint64_t r2max;
    uint64_t least2;        /* least squared distance of two centres */
    uint64_t widest2;       /* largest squared nearest-(earlier-)neighbour distance in contact */
    slot_bits matched;      /* pdla_check_missing's matched slots */
    uint64_t *sn;           /* the R_g series to recompute (arrival order) */
    double *srg;
    size_t sk, si;
    pdla_check_report rep;
};

/* A stored particle met by an enumeration: its chunk and slot (its
 * identity in the tree) and its squared distance from the query point. */
typedef void (*near_fn)(void *user, uint32_t chunk, uint32_t slot, uint64_t d2, const int64_t *q);

static void leaf_each(const tree *t, uint32_t head, const int64_t *lo, const int64_t *p, int dim, near_fn fn,
                      void *user)
{
    for (uint32_t c = head; c;) {
        const uint8_t *ch = tree_chunk_at(t, c);
        const uint32_t link = tree_chunk_link(t, c, ch);
        const uint32_t m = tree_fill(c, link);
        for (uint32_t j = 0; j < m; j++) {
            int64_t q[3] = {0, 0, 0};
            uint64_t d2 = 0;
            for (int a = 0; a < dim; a++) {
                q[a] = lo[a] + (int64_t)ch[a * TREE_CHUNK_CAP + (int)j];
                const int64_t d = q[a] - p[a];
                d2 += (uint64_t)(d * d);
            }
            fn(user, c, j, d2, q);
        }
        c = link > TREE_CHUNK_CAP ? link : 0;
    }
}

/* Every particle of every leaf that holds a point within r (< TREE_LEAF_SIDE)
 * of p on every axis: 1 or 2 leaves per axis. Leaves are aligned to their
 * side, so a leaf's low corner is a coordinate with its low bits cleared. */
static void near_each(const tree *t, const int64_t *p, int64_t r, int dim, near_fn fn, void *user)
{
    const int64_t mask = ~(int64_t)(TREE_LEAF_SIDE - 1);
    int64_t first[3] = {0, 0, 0}, count[3] = {1, 1, 1};
    for (int a = 0; a < dim; a++) {
        first[a] = (p[a] - r) & mask;
        count[a] = (((p[a] + r) & mask) - first[a]) / TREE_LEAF_SIDE + 1;
    }
    for (int64_t i = 0; i < count[0]; i++)
        for (int64_t j = 0; j < count[1]; j++)
            for (int64_t k = 0; k < count[2]; k++) {
                const int64_t corner[3] = {first[0] + i * TREE_LEAF_SIDE, first[1] + j * TREE_LEAF_SIDE,
                                           first[2] + k * TREE_LEAF_SIDE};
                int64_t lo[3];
                const uint32_t head = tree_find_leaf(t, corner, lo);
                if (head) leaf_each(t, head, lo, p, dim, fn, user);
            }
}

/* What the leaves around p hold, relative to p: the least squared distance
 * to a centre other than p itself, and how many centres sit exactly at p. */
typedef struct check_near {
    uint64_t least2;
    uint64_t at_p;
} check_near;

static void near_least(void *user, uint32_t chunk, uint32_t slot, uint64_t d2, const int64_t *q)
{
    (void)chunk, (void)slot, (void)q;
    check_near *n = user;
    if (d2 == 0) n->at_p++;
    else if (d2 < n->least2) n->least2 = d2;
}

static check_near scan_around(const tree *t, const int64_t *p, int64_t r, int dim)
{
    check_near n = {UINT64_MAX, 0};
    near_each(t, p, r, dim, near_least, &n);
    return n;
}

static void note_where(pdla_check_where *w, uint64_t *count, uint64_t row, const int64_t *p, int dim)
{
    if ((*count)++ == 0) {
        w->row = row;
        for (int a = 0; a < dim; a++) w->x[a] = p[a];
    }
}

int pdla_check_create(pdla_check **out, int dim, int resolution, int eps, int arrival, char *err,
                      size_t errlen)
{
    *out = NULL;
    if (dim != 2 && dim != 3) return pdla_errorf(PDLA_EINVAL, err, errlen, "dimension %d: want 2 or 3", dim);
    if (resolution < PDLA_MIN_RESOLUTION || resolution > PDLA_MAX_RESOLUTION || (resolution & (resolution - 1)))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "resolution %d: want a power of two from %d to %d",
                           resolution, PDLA_MIN_RESOLUTION, PDLA_MAX_RESOLUTION);
    if (eps < 2 || eps > resolution / 2)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "eps %d: want 2 to %d (resolution / 2)", eps,
                           resolution / 2);
    pdla_check *c = calloc(1, sizeof *c);
    if (!c || tree_init(&c->t, dim)) {
        free(c);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the check's tree");
    }
    c->dim = dim;
    c->arrival = arrival != 0;
    c->D = resolution;
    c->reach = resolution + eps;
    c->D2 = (uint64_t)resolution * (uint64_t)resolution;
    c->contact2 = (uint64_t)(resolution + eps) * (uint64_t)(resolution + eps);
    c->least2 = UINT64_MAX;
    const pdla_check_where none = {UINT64_MAX, {0, 0, 0}};
    c->rep.first_overlap = c->rep.first_detached = c->rep.first_out_of_range = none;
    c->rep.first_series_mismatch = UINT64_MAX;
    c->rep.arrival = c->arrival;
    *out = c;
    return PDLA_OK;
}

int pdla_check_series(pdla_check *c, const uint64_t *n, const double *rg_diam, size_t k, char *err,
                      size_t errlen)
{
    if (!c->arrival || c->rows)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "an R_g series is checked only in arrival order, before any row");
    for (size_t i = 1; i < k; i++)
        if (n[i] <= n[i - 1])
            return pdla_errorf(PDLA_EINVAL, err, errlen, "the R_g series' counts do not increase (sample %zu)", i);
    free(c->sn);
    free(c->srg);
    c->sn = k ? malloc(k * sizeof *c->sn) : NULL;
    c->srg = k ? malloc(k * sizeof *c->srg) : NULL;
    if (k && (!c->sn || !c->srg)) {
        free(c->sn), free(c->srg);
        c->sn = NULL, c->srg = NULL;
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for %zu R_g samples", k);
    }
    if (k) memcpy(c->sn, n, k * sizeof *n), memcpy(c->srg, rg_diam, k * sizeof *rg_diam);
    c->sk = k;
    c->si = 0;
    return PDLA_OK;
}

/* The gyration sums, R_ext and the series sample due at this count. */
static void add_gyration(pdla_check *c, const int64_t *p)
{
    const uint64_t r2 = gyration_sums_add(&c->g, p, c->dim);
    if (r2 > c->r2max) c->r2max = r2;
    while (c->si < c->sk && c->sn[c->si] <= c->g.n) {
        if (c->sn[c->si] == c->g.n) {
            const double rg = gyration_rg_diam(&c->g, c->dim, (int)c->D); /* the engine's own */
            c->rep.series_checked++;
            if (rg != c->srg[c->si] && c->rep.series_mismatches++ == 0)
                c->rep.first_series_mismatch = c->si;
        } else if (c->rep.series_mismatches++ == 0) {
            c->rep.first_series_mismatch = c->si; /* a count this cluster never had */
        }
        c->si++;
    }
}

/* One row against the particles before it: overlaps always, contact in
 * arrival order (the row must have stuck to the cluster as it was). */
static void check_row(pdla_check *c, const int64_t *p)
{
    const uint64_t row = c->rows;
    const check_near n = scan_around(&c->t, p, c->reach, c->dim);
    const uint64_t least2 = n.at_p ? 0 : n.least2;
    if (least2 < c->least2) c->least2 = least2;
    if (least2 < c->D2) note_where(&c->rep.first_overlap, &c->rep.overlaps, row, p, c->dim);
    if (c->arrival && row == 0) {
        c->rep.seed_at_origin = 1;
        for (int a = 0; a < c->dim; a++) c->rep.seed_at_origin &= p[a] == 0;
    } else if (c->arrival) {
        if (least2 >= c->contact2)
            note_where(&c->rep.first_detached, &c->rep.detached, row, p, c->dim);
        else if (least2 >= c->D2 && least2 > c->widest2)
            c->widest2 = least2;
    } else {
        int origin = 1;
        for (int a = 0; a < c->dim; a++) origin &= p[a] == 0;
        if (origin) c->rep.seed_at_origin = 1;
    }
}

int pdla_check_add(pdla_check *c, const int32_t *xyz, size_t rows, char *err, size_t errlen)
{
    if (c->finished) return pdla_errorf(PDLA_EINVAL, err, errlen, "rows after pdla_check_finish");
    for (size_t i = 0; i < rows; i++, c->rows++) {
        int64_t p[3] = {0, 0, 0};
        int in = 1;
        for (int a = 0; a < c->dim; a++) {
            p[a] = xyz[i * (size_t)c->dim + (size_t)a];
            /* As engine_check_range: |x| < 2^28. */
            in &= p[a] > -PDLA_MAX_CLUSTER_RADIUS_UNITS && p[a] < PDLA_MAX_CLUSTER_RADIUS_UNITS;
        }
        if (!in) {
            note_where(&c->rep.first_out_of_range, &c->rep.out_of_range, c->rows, p, c->dim);
            continue;
        }
        check_row(c, p);
        /* |x| < 2^28 lies well inside the largest root (2^31): a failure
         * here is memory. */
        if (tree_insert(&c->t, p))
            return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the check's tree at row %llu",
                               (unsigned long long)c->rows);
        add_gyration(c, p);
    }
    return PDLA_OK;
}

/* Not in arrival order: the contact graph (centres closer than D + eps)
 * must be one piece holding the seed, as a cluster grown by sticking is. A
 * breadth-first walk from the particle at the origin (else from any one)
 * marks the slots it reaches, one bit each; a particle never reached is
 * detached. The queue holds positions (int32: |x| < 2^28). */
static int slot_bits_alloc(slot_bits *b, const tree *t)
{
    b->chunk = calloc(((uint64_t)t->chunks.count * TREE_CHUNK_CAP + 63) / 64 + 1, sizeof(uint64_t));
    b->half = calloc(((uint64_t)t->halves.count * 2 * TREE_HALF_CAP + 63) / 64 + 1, sizeof(uint64_t));
    return b->chunk && b->half ? PDLA_OK : PDLA_ENOMEM;
}

static void slot_bits_free(slot_bits *b)
{
    free(b->chunk);
    free(b->half);
    b->chunk = b->half = NULL;
}

/* Sets the slot's bit; returns whether it was set already. */
static int slot_bits_test_set(slot_bits *b, uint32_t chunk, uint32_t slot)
{
    uint64_t *bits = b->chunk;
    uint64_t i = (uint64_t)chunk * TREE_CHUNK_CAP + slot;
    if (chunk & TREE_HALF_BIT) bits = b->half, i = (uint64_t)(chunk & ~TREE_HALF_BIT) * TREE_HALF_CAP + slot;
    const uint64_t m = UINT64_C(1) << (i & 63);
    const int was = (bits[i >> 6] & m) != 0;
    bits[i >> 6] |= m;
    return was;
}

typedef struct bfs {
    pdla_check *c;
    slot_bits seen;                   /* reached */
    int32_t *queue;                   /* dim ints a particle */
    size_t head, tail, cap;           /* in particles */
    uint64_t reached, least2;
    int oom, found;
} bfs;

static void bfs_push(bfs *b, const int64_t *q)
{
    const int dim = b->c->dim;
    if (b->tail == b->cap) {
        const size_t cap = b->cap ? 2 * b->cap : 4096;
        int32_t *nq = realloc(b->queue, cap * (size_t)dim * sizeof *nq);
        if (!nq) {
            b->oom = 1;
            return;
        }
        b->queue = nq;
        b->cap = cap;
    }
    for (int a = 0; a < dim; a++) b->queue[b->tail * (size_t)dim + (size_t)a] = (int32_t)q[a];
    b->tail++;
    b->reached++;
}

static void bfs_neighbour(void *user, uint32_t chunk, uint32_t slot, uint64_t d2, const int64_t *q)
{
    bfs *b = user;
    if (d2 > 0 && d2 < b->least2) b->least2 = d2;
    if (d2 < b->c->contact2 && !slot_bits_test_set(&b->seen, chunk, slot)) bfs_push(b, q);
}

/* The start: the particle at the origin (its slot marked), else none yet. */
static void bfs_origin(void *user, uint32_t chunk, uint32_t slot, uint64_t d2, const int64_t *q)
{
    bfs *b = user;
    if (d2 == 0 && !b->found) {
        b->found = 1;
        slot_bits_test_set(&b->seen, chunk, slot);
        bfs_push(b, q);
    }
}

static int bfs_any(const int64_t *p, void *user)
{
    bfs *b = user;
    near_each(&b->c->t, p, 0, b->c->dim, bfs_origin, b);
    return 1; /* the first particle visited is enough */
}

/* Marks the first unmarked slot holding a centre exactly at p: 1 when
 * there was one (a centre at p not yet reached or matched), else 0. */
typedef struct slot_claim {
    slot_bits *bits;
    int hit;
} slot_claim;

static void claim_slot(void *user, uint32_t chunk, uint32_t slot, uint64_t d2, const int64_t *q)
{
    (void)q;
    slot_claim *k = user;
    if (d2 == 0 && !k->hit && !slot_bits_test_set(k->bits, chunk, slot)) k->hit = 1;
}

static int claim_at(const tree *t, const int64_t *p, int dim, slot_bits *bits)
{
    slot_claim k = {bits, 0};
    near_each(t, p, 0, dim, claim_slot, &k);
    return k.hit;
}

/* After the walk: the first particle not reached (tree order). */
static int unreached_visit(const int64_t *p, void *user)
{
    bfs *b = user;
    if (!claim_at(&b->c->t, p, b->c->dim, &b->seen)) return 0;
    note_where(&b->c->rep.first_detached, &b->c->rep.detached, UINT64_MAX, p, b->c->dim);
    return 1;
}

static int check_connected(pdla_check *c)
{
    const tree *t = &c->t;
    const uint64_t n = tree_count(t);
    if (n == 0) return PDLA_OK;
    bfs b = {.c = c, .least2 = UINT64_MAX};
    int rc = slot_bits_alloc(&b.seen, t);
    const int64_t origin[3] = {0, 0, 0};
    if (rc == PDLA_OK) near_each(t, origin, 0, c->dim, bfs_origin, &b);
    if (rc == PDLA_OK && !b.found) tree_visit(t, bfs_any, &b);
    for (; rc == PDLA_OK && b.head < b.tail && !b.oom; b.head++) {
        int64_t p[3] = {0, 0, 0};
        for (int a = 0; a < c->dim; a++) p[a] = b.queue[b.head * (size_t)c->dim + (size_t)a];
        b.least2 = UINT64_MAX;
        near_each(t, p, c->reach, c->dim, bfs_neighbour, &b);
        if (b.least2 < c->contact2 && b.least2 >= c->D2 && b.least2 > c->widest2) c->widest2 = b.least2;
    }
    if (b.oom) rc = PDLA_ENOMEM;
    if (rc == PDLA_OK && b.reached < n) {
        tree_visit(t, unreached_visit, &b);
        c->rep.detached = n - b.reached; /* note_where counted the first one */
    }
    slot_bits_free(&b.seen);
    free(b.queue);
    return rc;
}

/* Rows of xyz that match no stored centre not matched before: each stored
 * slot answers one row at most (a bit a slot, made on the first call), so
 * equal counts and no missing row mean the same multiset of centres. */
int64_t pdla_check_missing(pdla_check *c, const int32_t *xyz, size_t rows)
{
    if (!c->matched.chunk && slot_bits_alloc(&c->matched, &c->t)) {
        slot_bits_free(&c->matched);
        return PDLA_ENOMEM;
    }
    int64_t missing = 0;
    for (size_t i = 0; i < rows; i++) {
        int64_t p[3] = {0, 0, 0};
        for (int a = 0; a < c->dim; a++) p[a] = xyz[i * (size_t)c->dim + (size_t)a];
        missing += !claim_at(&c->t, p, c->dim, &c->matched);
    }
    return missing;
}

uint64_t pdla_check_failures(const pdla_check *c)
{
    return c->rep.overlaps + c->rep.detached + c->rep.out_of_range;
}

int pdla_check_finish(pdla_check *c, int all_rows, pdla_check_report *r, char *err, size_t errlen)
{
    if (!c->finished && all_rows && !c->arrival && check_connected(c))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory walking the contacts of %llu particles",
                           (unsigned long long)c->rows);
    if (!c->finished && all_rows) {
        /* Samples at counts beyond the rows are samples of another cluster. */
        for (; c->si < c->sk; c->si++)
            if (c->rep.series_mismatches++ == 0) c->rep.first_series_mismatch = c->si;
    }
    c->finished = 1;
    c->rep.particles = c->rows;
    c->rep.closest_diam = c->least2 == UINT64_MAX ? NAN : sqrt((double)c->least2) / (double)c->D;
    c->rep.widest_contact_diam = c->widest2 == 0 ? NAN : sqrt((double)c->widest2) / (double)c->D;
    c->rep.rg_diam = gyration_rg_diam(&c->g, c->dim, (int)c->D);
    c->rep.r_ext_units = c->g.n ? tree_ceil_sqrt(c->r2max) : 0;
    *r = c->rep;
    return PDLA_OK;
}

void pdla_check_destroy(pdla_check *c)
{
    if (!c) return;
    tree_free(&c->t);
    slot_bits_free(&c->matched);
    free(c->sn);
    free(c->srg);
    free(c);
}
