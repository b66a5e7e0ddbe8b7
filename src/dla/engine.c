/*
 * engine.c - the DLA engine's state below both growth loops: lifecycle,
 * inserting a particle into the cluster state (range check, exact radius of
 * gyration sums, R_ext, log-spaced R_g samples, arrival order) and read
 * access to the cluster for output and tests. The serial loop (grow.c) and
 * the workers (parallel.c) call down into it; it calls neither.
 */
#define _GNU_SOURCE /* PTHREAD_MUTEX_ADAPTIVE_NP (glibc), where it exists */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "fit.h"
#include "must.h"
#include "pdla_config.h"

const char *pdla_version(void) { return PDLA_VERSION; }

/* pdla_params_default and pdla_params_validate: params.c, from the table. */

static void rg_advance(pdla_engine *e)
{
    e->rg_next_k++;
    e->rg_next_n = fit_rg_grid_n(e->rg_next_k, e->params.rg_per_decade, e->rg_next_n);
}

/* The engine's three mutexes, adaptive where glibc has them: the critical
 * sections are a few hundred nanoseconds, and a waiter that spins briefly
 * before sleeping avoids a futex sleep and wake-up per contended insertion.
 * PDLA_OK, or PDLA_ENOMEM with pthread's reason (none is left initialised). */
static int engine_mutexes_init(pdla_engine *e, char *err, size_t errlen)
{
    pthread_mutexattr_t attr;
    int rc = pthread_mutexattr_init(&attr);
    if (rc) return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot create a mutex attribute: %s",
                               strerror(rc));
#ifdef PTHREAD_ADAPTIVE_MUTEX_INITIALIZER_NP
    rc = pthread_mutexattr_settype(&attr, PTHREAD_MUTEX_ADAPTIVE_NP);
#endif
    pthread_mutex_t *const mu[3] = {&e->node_mu, &e->bucket_mu, &e->gyration_mu};
    int made = 0;
    while (!rc && made < 3 && !(rc = pthread_mutex_init(mu[made], &attr))) made++;
    PDLA_MUST(pthread_mutexattr_destroy(&attr));
    if (!rc) return PDLA_OK;
    while (made > 0) PDLA_MUST(pthread_mutex_destroy(mu[--made]));
    return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot create the engine's mutexes: %s",
                       strerror(rc));
}

int pdla_engine_create(pdla_engine **out, const pdla_params *p, char *err, size_t errlen)
{
    *out = NULL;
    const int rc = pdla_params_validate(p, err, errlen);
    if (rc) return rc;
    pdla_engine *e = calloc(1, sizeof *e);
    if (!e) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory creating the engine");
    e->params = *p;
    if (tree_init(&e->tree, p->dim)) {
        free(e);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory creating the tree");
    }
    search_config_init(&e->search, p->exact_search ? 0.0 : p->far_factor, p->resolution, p->eps);
    {
        /* The map covers the birth circle: its margin beyond the farthest
         * particle is the birth margin plus two coarse cells (capped;
         * queries beyond the grid use the tree). */
        const int bits = DISTMAP_BITS;
        double margin = p->birth_margin * p->resolution + 2.0 * (double)(8 << bits);
        if (margin > (double)(256 << bits)) margin = (double)(256 << bits);
        distmap_init(&e->dmap, p->dim, bits, (int64_t)margin);
        if (p->dim == 3) e->dmap.near_min = (int64_t)DISTMAP_NEAR_MIN_DIAMETERS * p->resolution;
    }
    rng_seed(&e->walker.rng, p->seed);
    search_state_reset(&e->walker.ss);
    e->compact_first = p->dim == 3 ? ENGINE_COMPACT_FIRST : 0; /* 2D gains nothing (engine.h) */
    atomic_init(&e->r_ext, 0);
    atomic_init(&e->stop, 0);
    const int mu_rc = engine_mutexes_init(e, err, errlen);
    if (mu_rc) {
        tree_free(&e->tree);
        free(e);
        return mu_rc;
    }
    snprintf(e->binding, sizeof e->binding, "none");
    e->rg_next_k = 0;
    e->rg_next_n = 1;
    *out = e;
    return PDLA_OK;
}

void engine_reference_free(pdla_engine *e)
{
    reference_state *r = e->ref;
    if (!r) return;
    free(r->ws);
    free(r->st);
    free(r->active);
    free(r);
    e->ref = NULL;
}

void pdla_engine_destroy(pdla_engine *e)
{
    if (!e) return;
    PDLA_MUST(pthread_mutex_destroy(&e->node_mu));
    PDLA_MUST(pthread_mutex_destroy(&e->bucket_mu));
    PDLA_MUST(pthread_mutex_destroy(&e->gyration_mu));
    free(e->workers);
    distmap_free(&e->dmap);
    tree_free(&e->tree);
    free(e->rg_n);
    free(e->rg_diam);
    free(e->arrival);
    free(e->gyr_wait_idx);
    free(e->gyr_wait_p);
    engine_reference_free(e);
    free(e);
}

double gyration_rg2_units(const gyration_sums *g, int dim)
{
    if (g->n == 0) return 0.0;
    const long double n = (long double)g->n;
    long double mean2 = 0;
    for (int a = 0; a < dim; a++) {
        const long double m = (long double)g->s1[a] / n;
        mean2 += m * m;
    }
    const long double rg2 = (long double)g->s2 / n - mean2;
    return rg2 > 0 ? (double)rg2 : 0.0;
}

double gyration_rg_diam(const gyration_sums *g, int dim, int resolution)
{
    return sqrt(gyration_rg2_units(g, dim)) / resolution;
}

uint64_t gyration_sums_add(gyration_sums *g, const int64_t *p, int dim)
{
    uint64_t r2 = 0;
    for (int a = 0; a < dim; a++) {
        r2 += (uint64_t)(p[a] * p[a]);
        g->s1[a] += p[a];
    }
    g->s2 += r2;
    g->n++;
    return r2;
}

static int record_rg_sample(pdla_engine *e)
{
    if (e->rg_count == e->rg_cap) {
        const size_t cap = e->rg_cap ? 2 * e->rg_cap : 256;
        uint64_t *n = realloc(e->rg_n, cap * sizeof *n);
        if (!n) return PDLA_ENOMEM;
        e->rg_n = n;
        double *r = realloc(e->rg_diam, cap * sizeof *r);
        if (!r) return PDLA_ENOMEM;
        e->rg_diam = r;
        e->rg_cap = cap;
    }
    e->rg_n[e->rg_count] = e->gyr.n;
    e->rg_diam[e->rg_count] = gyration_rg_diam(&e->gyr, e->params.dim, e->params.resolution);
    e->rg_count++;
    return PDLA_OK;
}

int engine_check_range(const pdla_engine *e, const int64_t *p, char *err, size_t errlen)
{
    for (int a = 0; a < e->params.dim; a++)
        if (p[a] <= -PDLA_MAX_CLUSTER_RADIUS_UNITS || p[a] >= PDLA_MAX_CLUSTER_RADIUS_UNITS)
            return pdla_errorf(PDLA_ERANGE, err, errlen,
                        "cluster reached the coordinate limit |x| < 2^28 units at %llu particles",
                        (unsigned long long)tree_count(&e->tree));
    return PDLA_OK;
}

/* record_arrival: p as row `index`, the particle's index in the tree (its
 * append order); called where the gyration sums grow, so in the parallel
 * phase under gyration_mu. Not the order of those calls: a worker
 * descheduled between its append and the sums was overtaken by others, and
 * a particle was listed up to ~250 rows before the one it stuck to (found
 * by an adversarial test). */
static int record_arrival(pdla_engine *e, const int64_t *p, uint64_t index)
{
    const size_t dim = (size_t)e->params.dim;
    while (index >= e->arrival_cap) {
        const uint64_t cap = e->arrival_cap ? 2 * e->arrival_cap : 4096;
        if (cap > SIZE_MAX / (dim * sizeof *e->arrival)) return PDLA_ENOMEM;
        int32_t *a = realloc(e->arrival, (size_t)cap * dim * sizeof *a);
        if (!a) return PDLA_ENOMEM;
        e->arrival = a;
        e->arrival_cap = cap;
    }
    for (size_t a = 0; a < dim; a++) e->arrival[(size_t)index * dim + a] = (int32_t)p[a];
    return PDLA_OK;
}

void engine_raise_r_ext(pdla_engine *e, const int64_t *p)
{
    uint64_t r2 = 0;
    for (int a = 0; a < e->params.dim; a++) r2 += (uint64_t)(p[a] * p[a]);
    const int64_t r = tree_ceil_sqrt(r2);
    int64_t cur = atomic_load_explicit(&e->r_ext, memory_order_relaxed);
    while (r > cur && !atomic_compare_exchange_weak_explicit(&e->r_ext, &cur, r, memory_order_relaxed,
                                                             memory_order_relaxed)) {
    }
}

int engine_gyration_add(pdla_engine *e, const int64_t *p, char *err, size_t errlen)
{
    return engine_gyration_add_at(e, p, e->gyr.n, err, errlen);
}

/* Adds the particle whose turn it is (index gyr.n) to the sums, R_ext and
 * the samples. */
static int gyration_add_next(pdla_engine *e, const int64_t *p, char *err, size_t errlen)
{
    const uint64_t r2 = gyration_sums_add(&e->gyr, p, e->params.dim);
    if (r2 > e->r_ext2) {
        e->r_ext2 = r2;
        engine_raise_r_ext(e, p);
    }
    if (e->params.rg_per_decade > 0 && e->gyr.n >= e->rg_next_n) {
        if (record_rg_sample(e)) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for R_g samples");
        while (e->rg_next_n <= e->gyr.n) rg_advance(e);
    }
    return PDLA_OK;
}

/* Room for index in the waiting slots (index - gyr.n below the capacity,
 * which doubles as needed; every waiting index lies in [gyr.n, gyr.n + cap)). */
static int gyration_wait_room(pdla_engine *e, uint64_t index)
{
    size_t cap = e->gyr_wait_cap ? e->gyr_wait_cap : 64;
    while (index - e->gyr.n >= cap) {
        if (cap > SIZE_MAX / 2 / sizeof(int64_t[3])) return PDLA_ENOMEM;
        cap *= 2;
    }
    if (cap == e->gyr_wait_cap) return PDLA_OK;
    uint64_t *idx = calloc(cap, sizeof *idx);
    int64_t(*pp)[3] = malloc(cap * sizeof *pp);
    if (!idx || !pp) {
        free(idx), free(pp);
        return PDLA_ENOMEM;
    }
    for (size_t i = 0; i < e->gyr_wait_cap; i++) {
        if (!e->gyr_wait_idx[i]) continue;
        const size_t j = (size_t)(e->gyr_wait_idx[i] - 1) & (cap - 1);
        idx[j] = e->gyr_wait_idx[i];
        memcpy(pp[j], e->gyr_wait_p[i], sizeof pp[j]);
    }
    free(e->gyr_wait_idx);
    free(e->gyr_wait_p);
    e->gyr_wait_idx = idx;
    e->gyr_wait_p = pp;
    e->gyr_wait_cap = cap;
    return PDLA_OK;
}

int engine_gyration_add_at(pdla_engine *e, const int64_t *p, uint64_t index, char *err, size_t errlen)
{
    if (e->params.record_arrival && record_arrival(e, p, index))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the arrival order at %llu particles",
                    (unsigned long long)e->gyr.n);
    if (index != e->gyr.n) {
        /* A later particle than the next: it waits for those before it. */
        if (index < e->gyr.n)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "particle %llu counted twice in the R_g sums",
                               (unsigned long long)index);
        if (gyration_wait_room(e, index))
            return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory ordering the R_g sums at %llu particles",
                               (unsigned long long)e->gyr.n);
        const size_t j = (size_t)index & (e->gyr_wait_cap - 1);
        e->gyr_wait_idx[j] = index + 1;
        memcpy(e->gyr_wait_p[j], p, sizeof e->gyr_wait_p[j]);
        return PDLA_OK;
    }
    int rc = gyration_add_next(e, p, err, errlen);
    while (rc == PDLA_OK && e->gyr_wait_cap) {
        const size_t j = (size_t)e->gyr.n & (e->gyr_wait_cap - 1);
        if (e->gyr_wait_idx[j] != e->gyr.n + 1) break;
        e->gyr_wait_idx[j] = 0;
        rc = gyration_add_next(e, e->gyr_wait_p[j], err, errlen);
    }
    return rc;
}

/* Serial insertion (one thread: the serial loop, the reference mode): the
 * tree, the distance map, the gyration sums, R_ext and the samples. */
static int add_particle_from(pdla_engine *e, const int64_t *p, const tree_start *from, char *err,
                             size_t errlen)
{
    int rc = engine_check_range(e, p, err, errlen);
    if (rc) return rc;
    distmap_add(&e->dmap, p, tree_count(&e->tree) + 1, 0);
    rc = tree_insert_from(&e->tree, p, from);
    if (rc) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory (or the tree's record limit) at %llu particles",
                        (unsigned long long)tree_count(&e->tree));
    return engine_gyration_add(e, p, err, errlen);
}

int engine_add_particle(pdla_engine *e, const int64_t *p, char *err, size_t errlen)
{
    return add_particle_from(e, p, NULL, err, errlen);
}

int engine_add_walker_particle(pdla_engine *e, const int64_t *p, const search_state *k, char *err,
                               size_t errlen)
{
    tree_start from;
    search_path_start(k, &e->tree, p, &from);
    return add_particle_from(e, p, &from, err, errlen);
}

const pdla_params *pdla_engine_params(const pdla_engine *e) { return &e->params; }
uint64_t pdla_engine_count(const pdla_engine *e) { return tree_count(&e->tree); }

/* Copy a walker's (summed) counters into the stats. */
static void stats_set_counts(pdla_stats *s, const walker_ctx *w)
{
    s->walkers = w->walkers;
    s->jumps = w->jumps;
    s->returns = w->returns;
    s->lost = w->lost;
    s->killed = w->killed;
    s->restarts = w->restarts;
    s->node_visits = w->ss.node_visits;
    s->particle_checks = w->ss.particle_checks;
    s->recheck_overlaps = w->recheck_overlaps;
    s->recheck_continued = w->recheck_continued;
    s->recheck_discarded = w->recheck_discarded;
    s->stale_jumps = w->stale_jumps;
    s->stale_births = w->stale_births;
    s->claim_waits = w->claim_waits;
    s->relaunches = w->relaunches;
    s->lag_n = w->lag_n;
    s->lag_sum = w->lag_sum;
    s->lag_sum2 = w->lag_sum2;
    memcpy(s->lag_hist, w->lag_hist, sizeof s->lag_hist);
    memcpy(s->mutex_taken, w->mutex_taken, sizeof s->mutex_taken);
    memcpy(s->mutex_contended, w->mutex_contended, sizeof s->mutex_contended);
}

/* Safe while workers run (the progress callback calls it): worker counters
 * are folded in only after they have stopped, and the pools and sums are
 * read under the mutexes that guard them. */
void pdla_engine_stats(const pdla_engine *e, pdla_stats *s)
{
    pdla_engine *m = (pdla_engine *)e; /* the mutexes are the only thing touched */
    memset(s, 0, sizeof *s);
    s->particles = tree_count(&e->tree);
    walker_ctx sum;
    memset(&sum, 0, sizeof sum);
    walker_ctx_add_counts(&sum, &e->walker);
    for (int i = 0; i < e->nworkers; i++) walker_ctx_add_counts(&sum, &e->workers[i]);
    stats_set_counts(s, &sum);
    s->threads = e->nworkers;
    for (int i = 0; i < 3; i++) {
        s->mutex_hold_ns[i] = (double)sum.mutex_hold_ticks[i] * e->tick_ns;
        s->mutex_wait_ns[i] = (double)sum.mutex_wait_ticks[i] * e->tick_ns;
        s->mutex_long_holds[i] = sum.mutex_long_holds[i];
    }
    s->worker_cpu_seconds = sum.cpu_seconds;
    s->parallel_seconds = e->parallel_seconds;
    snprintf(s->binding, sizeof s->binding, "%s", e->binding);
    s->r_ext = atomic_load_explicit(&e->r_ext, memory_order_relaxed);
    PDLA_MUST(pthread_mutex_lock(&m->gyration_mu));
    s->rg_diam = gyration_rg_diam(&e->gyr, e->params.dim, e->params.resolution);
    PDLA_MUST(pthread_mutex_unlock(&m->gyration_mu));
    PDLA_MUST(pthread_mutex_lock(&m->bucket_mu)); /* the workers' order: bucket, then node */
    PDLA_MUST(pthread_mutex_lock(&m->node_mu));
    s->tree_bytes = tree_bytes(&e->tree);
    s->inner_nodes = e->tree.inner.count - 1;
    s->leaves = e->tree.leaves;
    s->chunks = e->tree.chunks.count - (TREE_CHUNK_CAP + 1);
    PDLA_MUST(pthread_mutex_unlock(&m->node_mu));
    PDLA_MUST(pthread_mutex_unlock(&m->bucket_mu));
    s->root_level = tree_root_get(&e->tree).level;
    s->grow_seconds = e->grow_seconds;
}

/* Batches positions as int32 for the visitor. */
typedef struct visit_batch {
    int32_t xyz[4096 * 3];
    size_t n;
    int dim;
    pdla_visit_fn fn;
    void *user;
} visit_batch;

static int batch_add(const int64_t *p, void *user)
{
    visit_batch *b = user;
    for (int a = 0; a < b->dim; a++) b->xyz[b->n * (size_t)b->dim + (size_t)a] = (int32_t)p[a];
    if (++b->n == 4096) {
        b->n = 0;
        return b->fn(b->xyz, 4096, b->user);
    }
    return 0;
}

int pdla_engine_visit(const pdla_engine *e, pdla_visit_fn fn, void *user)
{
    visit_batch *b = malloc(sizeof *b);
    if (!b) return PDLA_ENOMEM;
    b->n = 0;
    b->dim = e->params.dim;
    b->fn = fn;
    b->user = user;
    int rc = tree_visit(&e->tree, batch_add, b);
    if (rc == 0 && b->n) rc = fn(b->xyz, b->n, user);
    free(b);
    return rc;
}

void pdla_engine_rg_series(const pdla_engine *e, const uint64_t **n, const double **rg_diam,
                           size_t *count)
{
    *n = e->rg_n;
    *rg_diam = e->rg_diam;
    *count = e->rg_count;
}

const int32_t *pdla_engine_arrival(const pdla_engine *e, uint64_t *n)
{
    *n = e->params.record_arrival ? e->gyr.n : 0;
    return e->params.record_arrival ? e->arrival : NULL;
}

pdla_fit pdla_engine_fit(const pdla_engine *e)
{
    uint64_t lo, hi;
    fit_default_range(tree_count(&e->tree), &lo, &hi);
    return fit_powerlaw(e->rg_n, e->rg_diam, e->rg_count, lo, hi);
}

double pdla_engine_nearest(const pdla_engine *e, const int64_t *p)
{
    search_config exact;
    search_state k;
    search_state_reset(&k);
    search_config_init(&exact, 0.0, e->params.resolution, e->params.eps);
    const uint64_t d2 = search_lower_bound2(&e->tree, &exact, p, UINT64_MAX, &k);
    return d2 == UINT64_MAX ? INFINITY : sqrt((double)d2);
}
