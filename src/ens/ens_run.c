/*
 * ens_run.c - growing an ensemble: one cluster grown into a record, and
 * pdla_ens_run, the worker threads that take cluster indices from a
 * scheduler and hand the records back to it (include/pdla/ensemble.h).
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
#include "must.h"

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
    PDLA_MUST(pthread_mutex_lock(&x->mu));
    if (x->rc == PDLA_OK) {
        x->rc = rc;
        snprintf(x->err, sizeof x->err, "%s", why);
    }
    PDLA_MUST(pthread_mutex_unlock(&x->mu));
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
    const int mrc = pthread_mutex_init(&x->mu, NULL);
    if (mrc) {
        free(x);
        free(tid);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot create a mutex: %s", strerror(mrc));
    }
    int started = 0, crc = 0;
    atomic_store(&x->running, T);
    for (; started < T; started++)
        if ((crc = pthread_create(&tid[started], NULL, worker, x))) break;
    if (started < T) {
        atomic_fetch_sub(&x->running, T - started);
        char why[160];
        snprintf(why, sizeof why, "cannot start worker thread %d of %d: %s", started + 1, T, strerror(crc));
        fail(x, PDLA_ENOMEM, why);
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
    for (int k = 0; k < started; k++) PDLA_MUST(pthread_join(tid[k], NULL));
    if (progress && !stopped) progress(user, atomic_load(&x->done), atomic_load(&x->flags.particles));
    rc = x->rc;
    if (rc) pdla_errorf(rc, err, errlen, "%s", x->err);
    else if (stopped) rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped after %llu clusters",
                                       (unsigned long long)atomic_load(&x->done));
    PDLA_MUST(pthread_mutex_destroy(&x->mu));
    free(x);
    free(tid);
    return rc;
}
