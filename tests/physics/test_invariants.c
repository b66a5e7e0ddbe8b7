/*
 * test_invariants.c - invariants of grown clusters, checked independently of
 * the tree (positions are read out once and checked with a uniform grid):
 *  - no two centres closer than one diameter D;
 *  - every particle but a lone seed touches another: it has a neighbour at
 *    distance in [D, D + eps), and the contact graph is connected (a cluster
 *    grown by sticking is one connected piece);
 *  - the count is exactly the target; R_g from the engine matches R_g
 *    recomputed from the positions;
 *  - the same seed and parameters give the identical cluster, a different
 *    seed a different one.
 * Both return modes, 2D and 3D, a few resolutions, tiny targets (1, 2, 3),
 * and PDLA with worker threads: 2, 8 and 32 workers (more than cores), more
 * workers than particles left to add, both re-check modes; the cluster must
 * end with exactly `target` particles. Run under ThreadSanitizer too.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pdla/pdla.h"

typedef struct positions {
    int64_t *x;
    size_t n, cap;
    int dim;
} positions;

static int grab(const int32_t *xyz, size_t n, void *user)
{
    positions *p = user;
    if (p->n + n > p->cap) {
        p->cap = 2 * (p->n + n);
        p->x = realloc(p->x, p->cap * 3 * sizeof *p->x);
    }
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < p->dim; a++) p->x[(p->n + i) * 3 + (size_t)a] = xyz[i * (size_t)p->dim + (size_t)a];
    p->n += n;
    return 0;
}

static positions read_positions(const pdla_engine *e)
{
    positions p = {NULL, 0, 0, pdla_engine_params(e)->dim};
    pdla_engine_visit(e, grab, &p);
    return p;
}

static size_t uf_find(size_t *parent, size_t i)
{
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
}

/* Hash grid with cell side D + eps: every neighbour within D + eps lies in
 * the 3^dim cells around a particle. */
typedef struct grid {
    size_t *head, *next;
    size_t nbuckets;
} grid;

static size_t cell_hash(const int64_t *c, int dim, size_t nb)
{
    uint64_t h = 1469598103934665603u;
    for (int a = 0; a < dim; a++) h = (h ^ (uint64_t)c[a]) * 1099511628211u;
    return (size_t)(h % nb);
}

static void check_cluster(const pdla_engine *e, const char *label)
{
    const pdla_params *P = pdla_engine_params(e);
    positions ps = read_positions(e);
    const int dim = P->dim;
    const int64_t D = P->resolution, reach = P->resolution + P->eps;
    CHECK(ps.n == P->target, "%s: %zu particles, target %llu", label, ps.n,
          (unsigned long long)P->target);

    grid g;
    g.nbuckets = 2 * ps.n + 1;
    g.head = malloc(g.nbuckets * sizeof *g.head);
    g.next = malloc(ps.n * sizeof *g.next);
    for (size_t b = 0; b < g.nbuckets; b++) g.head[b] = SIZE_MAX;
    for (size_t i = 0; i < ps.n; i++) {
        int64_t c[3];
        for (int a = 0; a < dim; a++) {
            const int64_t v = ps.x[i * 3 + (size_t)a];
            c[a] = v >= 0 ? v / reach : -((-v + reach - 1) / reach);
        }
        const size_t b = cell_hash(c, dim, g.nbuckets);
        g.next[i] = g.head[b];
        g.head[b] = i;
    }
    size_t *parent = malloc(ps.n * sizeof *parent);
    for (size_t i = 0; i < ps.n; i++) parent[i] = i;
    size_t overlaps = 0, lonely = 0;
    for (size_t i = 0; i < ps.n; i++) {
        const int64_t *xi = &ps.x[i * 3];
        int64_t c[3];
        for (int a = 0; a < dim; a++) c[a] = xi[a] >= 0 ? xi[a] / reach : -((-xi[a] + reach - 1) / reach);
        int touches = 0;
        const int ncell = dim == 2 ? 9 : 27;
        for (int k = 0; k < ncell; k++) {
            int64_t cc[3] = {c[0] + k % 3 - 1, c[1] + (k / 3) % 3 - 1, dim == 3 ? c[2] + k / 9 - 1 : 0};
            for (size_t j = g.head[cell_hash(cc, dim, g.nbuckets)]; j != SIZE_MAX; j = g.next[j]) {
                if (j == i) continue;
                uint64_t d2 = 0;
                for (int a = 0; a < dim; a++) {
                    const int64_t d = xi[a] - ps.x[j * 3 + (size_t)a];
                    d2 += (uint64_t)(d * d);
                }
                if (d2 < (uint64_t)(D * D)) overlaps++;
                if (d2 < (uint64_t)(reach * reach)) {
                    touches = 1;
                    parent[uf_find(parent, i)] = uf_find(parent, j);
                }
            }
        }
        if (!touches && ps.n > 1) lonely++;
    }
    size_t roots = 0;
    for (size_t i = 0; i < ps.n; i++) roots += uf_find(parent, i) == i;
    CHECK(overlaps == 0, "%s: %zu overlapping pairs (closer than one diameter)", label, overlaps / 2);
    CHECK(lonely == 0, "%s: %zu particles touch nothing", label, lonely);
    CHECK(ps.n == 0 || roots == 1, "%s: contact graph has %zu pieces", label, roots);

    /* R_g recomputed from the positions. */
    double mean[3] = {0, 0, 0}, m2 = 0;
    for (size_t i = 0; i < ps.n; i++)
        for (int a = 0; a < dim; a++) {
            mean[a] += (double)ps.x[i * 3 + (size_t)a];
            m2 += (double)ps.x[i * 3 + (size_t)a] * (double)ps.x[i * 3 + (size_t)a];
        }
    double rg2 = m2 / (double)ps.n;
    for (int a = 0; a < dim; a++) rg2 -= (mean[a] / (double)ps.n) * (mean[a] / (double)ps.n);
    pdla_stats st;
    pdla_engine_stats(e, &st);
    const double rg = rg2 > 0 ? sqrt(rg2) / (double)D : 0;
    CHECK(fabs(rg - st.rg_diam) <= 1e-9 * (1 + rg), "%s: R_g %.12g from positions, engine %.12g", label,
          rg, st.rg_diam);
    free(g.head);
    free(g.next);
    free(parent);
    free(ps.x);
}

static pdla_engine *grown(pdla_params p)
{
    pdla_engine *e = NULL;
    char err[256];
    const int rc = pdla_engine_create(&e, &p, err, sizeof err);
    CHECK(rc == 0, "create: %s", err);
    if (rc) return NULL;
    const int g = pdla_engine_grow(e, p.target, NULL, 0, NULL, err, sizeof err);
    CHECK(g == 0, "grow: %s", err);
    return e;
}

static void test_invariants(int dim, int resolution, pdla_return_mode mode, uint64_t target)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.resolution = resolution;
    p.return_mode = mode;
    p.target = target;
    p.seed = 12345 + (uint64_t)resolution;
    pdla_engine *e = grown(p);
    if (!e) return;
    char label[128];
    snprintf(label, sizeof label, "dim %d D %d %s N %llu", dim, resolution,
             mode == PDLA_RETURN_KILL ? "kill" : "exact", (unsigned long long)target);
    check_cluster(e, label);
    pdla_engine_destroy(e);
}

typedef struct hash_ctx {
    uint64_t h;
    int dim;
} hash_ctx;

static int hash_visit(const int32_t *xyz, size_t n, void *user)
{
    hash_ctx *c = user;
    for (size_t i = 0; i < n * (size_t)c->dim; i++) c->h = (c->h ^ (uint32_t)xyz[i]) * 1099511628211u;
    return 0;
}

static void test_determinism(int dim)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.target = dim == 2 ? 5000 : 2000;
    p.seed = 99;
    uint64_t h[3];
    for (int run = 0; run < 3; run++) {
        if (run == 2) p.seed = 100;
        pdla_engine *e = grown(p);
        if (!e) return;
        hash_ctx c = {1469598103934665603u, dim};
        pdla_engine_visit(e, hash_visit, &c);
        pdla_stats st;
        pdla_engine_stats(e, &st);
        h[run] = c.h ^ st.jumps ^ (st.walkers << 20);
        pdla_engine_destroy(e);
    }
    CHECK(h[0] == h[1], "dim %d: same seed gave different clusters", dim);
    CHECK(h[0] != h[2], "dim %d: different seeds gave the same cluster", dim);
}

static void test_threads(int dim, int threads, uint64_t serial_until, uint64_t target,
                         pdla_recheck_mode recheck)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.threads = threads;
    p.serial_until = serial_until;
    p.target = target;
    p.recheck = recheck;
    p.seed = 777 + (uint64_t)threads;
    pdla_engine *e = grown(p);
    if (!e) return;
    pdla_stats st;
    pdla_engine_stats(e, &st);
    char label[160];
    snprintf(label, sizeof label, "dim %d threads %d serial %llu target %llu %s", dim, threads,
             (unsigned long long)serial_until, (unsigned long long)target,
             recheck == PDLA_RECHECK_DISCARD ? "discard" : "continue");
    CHECK(st.threads == threads, "%s: %d workers ran", label, st.threads);
    CHECK(st.recheck_continued + st.recheck_discarded <= st.recheck_overlaps,
          "%s: re-check counts inconsistent", label);
    if (recheck == PDLA_RECHECK_DISCARD)
        CHECK(st.recheck_continued == 0, "%s: continued in discard mode", label);
    /* Lock accounting: each worker particle passes the gyration mutex once,
     * the bucket mutex at least once (more after a re-check, at the target,
     * or when the straggler bound relaunches a walker there), the node mutex at most as often as the bucket mutex. */
    const uint64_t added = target - serial_until;
    CHECK(st.mutex_taken[PDLA_MUTEX_GYRATION] == added, "%s: gyration mutex taken %llu times for %llu particles",
          label, (unsigned long long)st.mutex_taken[PDLA_MUTEX_GYRATION], (unsigned long long)added);
    CHECK(st.mutex_taken[PDLA_MUTEX_BUCKET] >= added &&
              st.mutex_taken[PDLA_MUTEX_BUCKET] <=
                  added + st.recheck_overlaps + st.relaunches + (uint64_t)threads,
          "%s: bucket mutex taken %llu times for %llu particles", label,
          (unsigned long long)st.mutex_taken[PDLA_MUTEX_BUCKET], (unsigned long long)added);
    CHECK(st.mutex_taken[PDLA_MUTEX_NODE] <= st.mutex_taken[PDLA_MUTEX_BUCKET] + st.recheck_overlaps,
          "%s: node mutex taken more often than the bucket mutex", label);
    for (int i = 0; i < 3; i++)
        CHECK(st.mutex_contended[i] <= st.mutex_taken[i], "%s: mutex %d waits exceed acquisitions", label, i);
    fprintf(stderr, "%s: overlaps %llu continued %llu discarded %llu, relaunched %llu\n", label,
            (unsigned long long)st.recheck_overlaps, (unsigned long long)st.recheck_continued,
            (unsigned long long)st.recheck_discarded, (unsigned long long)st.relaunches);
    check_cluster(e, label);
    pdla_engine_destroy(e);
}

int main(void)
{
    test_threads(2, 2, 2000, 20000, PDLA_RECHECK_CONTINUE);
    test_threads(2, 8, 2000, 20000, PDLA_RECHECK_CONTINUE);
    test_threads(2, 8, 500, 8000, PDLA_RECHECK_DISCARD);
    test_threads(2, 32, 300, 5000, PDLA_RECHECK_CONTINUE);
    test_threads(2, 16, 100, 105, PDLA_RECHECK_CONTINUE);
    test_threads(3, 4, 500, 5000, PDLA_RECHECK_CONTINUE);
    test_threads(3, 8, 3, 40, PDLA_RECHECK_CONTINUE);
    for (int dim = 2; dim <= 3; dim++) {
        for (uint64_t n = 1; n <= 3; n++) test_invariants(dim, 32, PDLA_RETURN_EXACT, n);
        test_invariants(dim, 4, PDLA_RETURN_EXACT, 2000);
        test_invariants(dim, 32, PDLA_RETURN_EXACT, dim == 2 ? 20000 : 5000);
        test_invariants(dim, 128, PDLA_RETURN_EXACT, 2000);
        test_invariants(dim, 32, PDLA_RETURN_KILL, 2000);
        test_determinism(dim);
    }
    return check_finish();
}
