/*
 * ens_run.c - growing an ensemble: the config and its per-cluster seeds, one
 * cluster grown into a record, records as bytes, and pdla_ens_run, the
 * worker threads that take cluster indices from a scheduler and hand the
 * records back to it (include/pdla/ensemble.h).
 *
 * Each cluster grows serially (threads = 1) on one worker: the engine's
 * serial path is deterministic, so a cluster depends only on its seed, and
 * M clusters keep T cores busy without any lock shared between them.
 */
#define _GNU_SOURCE /* CLOCK_THREAD_CPUTIME_ID */
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <hwloc.h>

#include "pdla/ensemble.h"

int pdla_ens_config_check(const pdla_ens_config *c, char *err, size_t errlen)
{
    if (c->clusters < 1) return pdla_errorf(PDLA_EINVAL, err, errlen, "the number of clusters must be at least 1, got 0");
    if (c->params.seed > UINT64_MAX - (c->clusters - 1))
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "seed range overflows: seeds %llu + 0..%llu pass 2^64 - 1 (lower --seed or --clusters)",
                           (unsigned long long)c->params.seed, (unsigned long long)(c->clusters - 1));
    if (c->keep_positions != 0 && c->keep_positions != 1)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "keep_positions must be 0 or 1, got %d", c->keep_positions);
    if (c->params.threads != 1 || c->params.bind != PDLA_BIND_NONE)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "each cluster of an ensemble grows serially: threads must be 1 "
                                                     "and bind none in its parameters");
    return pdla_params_validate(&c->params, err, errlen);
}

void pdla_ens_cluster_params(const pdla_ens_config *c, uint64_t i, pdla_params *out)
{
    *out = c->params;
    out->seed = c->params.seed + i;
    out->threads = 1;
    out->bind = PDLA_BIND_NONE;
}

void pdla_ens_record_free(pdla_ens_record *r)
{
    if (!r) return;
    free(r->rg_n);
    free(r->rg);
    free(r->positions);
    r->rg_n = NULL;
    r->rg = NULL;
    r->positions = NULL;
}

static double thread_cpu_seconds(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts)) return 0.0;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- one cluster -------------------------------------------------------- */

/* Shared by the workers of one pdla_ens_run: the stop flag and the count of
 * particles grown, for the progress line. */
typedef struct run_flags {
    _Atomic int stop;
    _Atomic uint64_t particles;
} run_flags;

typedef struct grow_cb {
    run_flags *flags;
    uint64_t last; /* particles of this cluster already counted */
} grow_cb;

static int on_grow(const pdla_engine *e, void *user)
{
    grow_cb *g = user;
    if (!g->flags) return 0;
    const uint64_t n = pdla_engine_count(e);
    atomic_fetch_add_explicit(&g->flags->particles, n - g->last, memory_order_relaxed);
    g->last = n;
    return atomic_load_explicit(&g->flags->stop, memory_order_relaxed);
}

typedef struct pos_copy {
    int32_t *dst;
    uint64_t filled, cap;
    int dim;
} pos_copy;

static int copy_positions(const int32_t *xyz, size_t n, void *user)
{
    pos_copy *p = user;
    if (p->filled + n > p->cap) return 1;
    memcpy(p->dst + p->filled * (uint64_t)p->dim, xyz, n * (size_t)p->dim * sizeof *xyz);
    p->filled += n;
    return 0;
}

static int record_fill(const pdla_ens_config *c, const pdla_engine *e, pdla_ens_record *r, char *err,
                       size_t errlen)
{
    pdla_stats st;
    pdla_engine_stats(e, &st);
    const pdla_params *P = pdla_engine_params(e);
    r->particles = st.particles;
    r->walkers = st.walkers;
    r->jumps = st.jumps;
    r->rg_diam = st.rg_diam;
    r->r_ext_diam = (double)st.r_ext / P->resolution;
    r->fit = pdla_engine_fit(e);
    r->dim = P->dim;
    const uint64_t *n;
    const double *rg;
    size_t k;
    pdla_engine_rg_series(e, &n, &rg, &k);
    r->rg_count = k;
    r->rg_n = malloc((k ? k : 1) * sizeof *r->rg_n);
    r->rg = malloc((k ? k : 1) * sizeof *r->rg);
    if (!r->rg_n || !r->rg) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for a cluster's R_g series");
    if (k) {
        memcpy(r->rg_n, n, k * sizeof *n);
        memcpy(r->rg, rg, k * sizeof *rg);
    }
    if (!c->keep_positions) return PDLA_OK;
    const size_t dim = (size_t)P->dim;
    if (st.particles > SIZE_MAX / (dim * sizeof(int32_t)))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "too many positions to keep");
    r->positions = malloc((size_t)(st.particles ? st.particles : 1) * dim * sizeof(int32_t));
    if (!r->positions) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for a cluster's positions");
    uint64_t na = 0;
    const int32_t *arr = pdla_engine_arrival(e, &na);
    if (arr && na == st.particles) {
        memcpy(r->positions, arr, (size_t)na * dim * sizeof *arr);
    } else {
        pos_copy pc = {r->positions, 0, st.particles, P->dim};
        if (pdla_engine_visit(e, copy_positions, &pc) || pc.filled != st.particles)
            return pdla_errorf(PDLA_EIO, err, errlen, "the engine listed %llu of %llu particles",
                               (unsigned long long)pc.filled, (unsigned long long)st.particles);
    }
    r->npos = st.particles;
    return PDLA_OK;
}

static int grow_one(const pdla_ens_config *c, uint64_t i, run_flags *flags, pdla_ens_record *out,
                    char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (i >= c->clusters)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cluster %llu is outside the ensemble's %llu",
                           (unsigned long long)i, (unsigned long long)c->clusters);
    pdla_params p;
    pdla_ens_cluster_params(c, i, &p);
    out->index = i;
    out->seed = p.seed;
    const double cpu0 = thread_cpu_seconds(), wall0 = pdla_clock_seconds();
    pdla_engine *e = NULL;
    char why[512];
    int rc = pdla_engine_create(&e, &p, why, sizeof why);
    if (rc) return pdla_errorf(rc, err, errlen, "cluster %llu: %s", (unsigned long long)i, why);
    grow_cb g = {flags, 0};
    rc = pdla_engine_grow(e, p.target, on_grow, 1000, &g, why, sizeof why);
    if (rc == PDLA_ESTOPPED) {
        pdla_engine_destroy(e);
        return rc;
    }
    if (rc) {
        pdla_engine_destroy(e);
        return pdla_errorf(rc, err, errlen, "cluster %llu (seed %llu): %s", (unsigned long long)i,
                           (unsigned long long)p.seed, why);
    }
    on_grow(e, &g); /* the last particles since the final callback */
    rc = record_fill(c, e, out, err, errlen);
    pdla_engine_destroy(e);
    out->cpu_seconds = thread_cpu_seconds() - cpu0;
    out->wall_seconds = pdla_clock_seconds() - wall0;
    if (rc) pdla_ens_record_free(out);
    return rc;
}

int pdla_ens_grow_one(const pdla_ens_config *c, uint64_t i, pdla_ens_record *out, char *err,
                      size_t errlen)
{
    const int rc = pdla_ens_config_check(c, err, errlen);
    if (rc) return rc;
    return grow_one(c, i, NULL, out, err, errlen);
}

/* ---- records as bytes ----------------------------------------------------
 * Native byte order (the journal's header records it), fixed fields first:
 * u64 index seed particles walkers jumps; f64 rg_diam r_ext_diam df df_err
 * prefactor; u64 n_lo n_hi; i32 points dim; f64 cpu wall; u64 rg_count npos;
 * then u64 rg_n[rg_count], f64 rg[rg_count], i32 positions[npos * dim]. */

#define REC_FIXED (5 * 8 + 5 * 8 + 2 * 8 + 2 * 4 + 2 * 8 + 2 * 8)

static uint8_t *put(uint8_t *p, const void *v, size_t n)
{
    memcpy(p, v, n);
    return p + n;
}

static const uint8_t *get(const uint8_t *p, void *v, size_t n)
{
    memcpy(v, p, n);
    return p + n;
}

int pdla_ens_record_encode(const pdla_ens_record *r, uint8_t **buf, size_t *len)
{
    *buf = NULL;
    *len = 0;
    if (r->dim < 2 || r->dim > 3 || r->rg_count > (SIZE_MAX / 32) || r->npos > SIZE_MAX / 32)
        return PDLA_EINVAL;
    const size_t n = REC_FIXED + (size_t)r->rg_count * 16 + (size_t)r->npos * (size_t)r->dim * 4;
    uint8_t *b = malloc(n), *p = b;
    if (!b) return PDLA_ENOMEM;
    const uint64_t u[5] = {r->index, r->seed, r->particles, r->walkers, r->jumps};
    const double d[5] = {r->rg_diam, r->r_ext_diam, r->fit.df, r->fit.df_err, r->fit.prefactor_diam};
    const uint64_t nr[2] = {r->fit.n_lo, r->fit.n_hi};
    const int32_t ii[2] = {r->fit.points, r->dim};
    const double t[2] = {r->cpu_seconds, r->wall_seconds};
    const uint64_t cnt[2] = {r->rg_count, r->npos};
    p = put(p, u, sizeof u);
    p = put(p, d, sizeof d);
    p = put(p, nr, sizeof nr);
    p = put(p, ii, sizeof ii);
    p = put(p, t, sizeof t);
    p = put(p, cnt, sizeof cnt);
    if (r->rg_count) {
        p = put(p, r->rg_n, (size_t)r->rg_count * 8);
        p = put(p, r->rg, (size_t)r->rg_count * 8);
    }
    if (r->npos) p = put(p, r->positions, (size_t)r->npos * (size_t)r->dim * 4);
    *buf = b;
    *len = (size_t)(p - b);
    return PDLA_OK;
}

int pdla_ens_record_decode(const uint8_t *buf, size_t len, pdla_ens_record *r, char *err, size_t errlen)
{
    memset(r, 0, sizeof *r);
    if (len < REC_FIXED) return pdla_errorf(PDLA_EIO, err, errlen, "a cluster record of %zu bytes is too short", len);
    uint64_t u[5], nr[2], cnt[2];
    double d[5], t[2];
    int32_t ii[2];
    const uint8_t *p = buf;
    p = get(p, u, sizeof u);
    p = get(p, d, sizeof d);
    p = get(p, nr, sizeof nr);
    p = get(p, ii, sizeof ii);
    p = get(p, t, sizeof t);
    p = get(p, cnt, sizeof cnt);
    if (ii[1] < 2 || ii[1] > 3 || cnt[0] > len / 16 || cnt[1] > len / 8 ||
        len != REC_FIXED + cnt[0] * 16 + cnt[1] * (uint64_t)ii[1] * 4)
        return pdla_errorf(PDLA_EIO, err, errlen, "a cluster record's lengths do not add up (%zu bytes)", len);
    r->index = u[0];
    r->seed = u[1];
    r->particles = u[2];
    r->walkers = u[3];
    r->jumps = u[4];
    r->rg_diam = d[0];
    r->r_ext_diam = d[1];
    r->fit.df = d[2];
    r->fit.df_err = d[3];
    r->fit.prefactor_diam = d[4];
    r->fit.n_lo = nr[0];
    r->fit.n_hi = nr[1];
    r->fit.points = ii[0];
    r->dim = ii[1];
    r->cpu_seconds = t[0];
    r->wall_seconds = t[1];
    r->rg_count = cnt[0];
    r->npos = cnt[1];
    const size_t k = (size_t)cnt[0], np = (size_t)cnt[1] * (size_t)ii[1];
    r->rg_n = malloc((k ? k : 1) * 8);
    r->rg = malloc((k ? k : 1) * 8);
    r->positions = np ? malloc(np * 4) : NULL;
    if (!r->rg_n || !r->rg || (np && !r->positions)) {
        pdla_ens_record_free(r);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory reading a cluster record");
    }
    if (k) {
        p = get(p, r->rg_n, k * 8);
        p = get(p, r->rg, k * 8);
    }
    if (np) get(p, r->positions, np * 4);
    return PDLA_OK;
}

/* ---- worker threads ----------------------------------------------------- */

int pdla_ens_threads(int asked)
{
    if (asked > 0) return asked;
    hwloc_topology_t topo;
    if (hwloc_topology_init(&topo)) return 0;
    if (hwloc_topology_load(topo)) {
        hwloc_topology_destroy(topo);
        return 0;
    }
    int cores = hwloc_get_nbobjs_by_type(topo, HWLOC_OBJ_CORE);
    if (cores <= 0) cores = hwloc_get_nbobjs_by_type(topo, HWLOC_OBJ_PU);
    hwloc_topology_destroy(topo);
    return cores > 0 ? cores : 0;
}

typedef struct run_ctx {
    const pdla_ens_config *c;
    const pdla_ens_scheduler *s;
    run_flags flags;
    _Atomic uint64_t done;
    _Atomic int running;
    pthread_mutex_t mu; /* guards rc and err */
    int rc;
    char err[1024];
} run_ctx;

static void fail(run_ctx *x, int rc, const char *why)
{
    pthread_mutex_lock(&x->mu);
    if (x->rc == PDLA_OK) {
        x->rc = rc;
        snprintf(x->err, sizeof x->err, "%s", why);
    }
    pthread_mutex_unlock(&x->mu);
    atomic_store(&x->flags.stop, 1);
}

static void *worker(void *arg)
{
    run_ctx *x = arg;
    char why[1024];
    uint64_t i;
    while (!atomic_load(&x->flags.stop) && x->s->next(x->s->user, &i)) {
        pdla_ens_record r;
        int rc = grow_one(x->c, i, &x->flags, &r, why, sizeof why);
        if (rc == PDLA_ESTOPPED) break;
        if (rc) {
            fail(x, rc, why);
            break;
        }
        rc = x->s->done(x->s->user, &r, why, sizeof why);
        pdla_ens_record_free(&r);
        if (rc) {
            fail(x, rc < 0 ? rc : PDLA_EIO, why);
            break;
        }
        atomic_fetch_add(&x->done, 1);
    }
    atomic_fetch_sub(&x->running, 1);
    return NULL;
}

int pdla_ens_run(const pdla_ens_config *c, int threads, const pdla_ens_scheduler *s,
                 pdla_ens_progress_fn progress, void *user, char *err, size_t errlen)
{
    int rc = pdla_ens_config_check(c, err, errlen);
    if (rc) return rc;
    const int T = pdla_ens_threads(threads);
    if (T <= 0) return pdla_errorf(PDLA_EINVAL, err, errlen, "hwloc could not read the machine topology");
    if (T > 1024) return pdla_errorf(PDLA_EINVAL, err, errlen, "threads must be at most 1024, got %d", T);
    run_ctx *x = calloc(1, sizeof *x);
    pthread_t *tid = calloc((size_t)T, sizeof *tid);
    if (!x || !tid) {
        free(x);
        free(tid);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory starting the workers");
    }
    x->c = c;
    x->s = s;
    if (pthread_mutex_init(&x->mu, NULL)) {
        free(x);
        free(tid);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot create a mutex");
    }
    int started = 0;
    atomic_store(&x->running, T);
    for (; started < T; started++)
        if (pthread_create(&tid[started], NULL, worker, x)) break;
    if (started < T) {
        atomic_fetch_sub(&x->running, T - started);
        fail(x, PDLA_ENOMEM, "cannot start the worker threads");
    }
    /* This thread watches: progress, and the stop it may ask for. */
    int stopped = 0;
    while (atomic_load(&x->running) > 0) {
        const struct timespec ts = {0, 100 * 1000 * 1000};
        nanosleep(&ts, NULL);
        if (progress && !stopped &&
            progress(user, atomic_load(&x->done), atomic_load(&x->flags.particles))) {
            stopped = 1;
            atomic_store(&x->flags.stop, 1);
        }
    }
    for (int k = 0; k < started; k++) pthread_join(tid[k], NULL);
    if (progress && !stopped) progress(user, atomic_load(&x->done), atomic_load(&x->flags.particles));
    rc = x->rc;
    if (rc) pdla_errorf(rc, err, errlen, "%s", x->err);
    else if (stopped) rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped after %llu clusters",
                                       (unsigned long long)atomic_load(&x->done));
    pthread_mutex_destroy(&x->mu);
    free(x);
    free(tid);
    return rc;
}

/* ---- the in-process scheduler -------------------------------------------- */

typedef struct local_sched {
    uint64_t *todo; /* the indices the journal lacks, ascending */
    uint64_t count;
    _Atomic uint64_t next;
    pdla_ens_journal *j;
} local_sched;

static int local_next(void *user, uint64_t *index)
{
    local_sched *q = user;
    const uint64_t k = atomic_fetch_add(&q->next, 1);
    if (k >= q->count) return 0;
    *index = q->todo[k];
    return 1;
}

static int local_done(void *user, const pdla_ens_record *rec, char *err, size_t errlen)
{
    local_sched *q = user;
    return pdla_ens_journal_append(q->j, rec, err, errlen);
}

int pdla_ens_run_local(pdla_ens_journal *j, int threads, pdla_ens_progress_fn progress, void *user,
                       char *err, size_t errlen)
{
    const pdla_ens_config *c = pdla_ens_journal_config(j);
    local_sched q;
    memset(&q, 0, sizeof q);
    q.j = j;
    const uint64_t missing = c->clusters - pdla_ens_journal_count(j);
    if (missing == 0) return PDLA_OK;
    if (missing > SIZE_MAX / sizeof *q.todo || !(q.todo = malloc((size_t)missing * sizeof *q.todo)))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the list of clusters");
    for (uint64_t i = 0; i < c->clusters && q.count < missing; i++)
        if (!pdla_ens_journal_has(j, i)) q.todo[q.count++] = i;
    atomic_init(&q.next, 0);
    const pdla_ens_scheduler s = {local_next, local_done, &q};
    const int rc = pdla_ens_run(c, threads, &s, progress, user, err, errlen);
    free(q.todo);
    return rc;
}
