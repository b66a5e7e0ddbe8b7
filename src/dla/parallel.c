/*
 * parallel.c - the PDLA phase: N worker threads, each with its own walker
 * and random stream, grow the one shared, live tree, following the flow
 * diagram of Sosa-Herrera & Rodriguez-Romo (Fig. 6):
 *
 *   walk (lock-free reads of the tree)
 *   -> exact check of the spot against the live tree, lock-free
 *   -> [node mutex]     create the tree nodes down to the particle's leaf
 *                       and mark its cells in the distance map (skipped
 *                       when both exist, as for most particles)
 *   -> [bucket mutex]   re-check against the particles appended since,
 *                       target check, append
 *   -> [gyration mutex] R_g sums, R_ext, R_g samples
 *
 * Walkers read the tree while others append. Each jump is checked, just
 * before it is taken, against the particles appended since the distance
 * query that sized it (the ring of recent particles, walker.c): a walker
 * descheduled between the two would otherwise jump through a newcomer (the
 * bias of issue 11: clusters 0.5% too compact with 16 workers on 2 cores).
 * So every jump is exact for the cluster as it is when it is taken.
 *
 * The re-check matters because another walker may have stuck in the spot
 * after this walker's last distance query. The seed discards such a walker;
 * by default we let it touch the particle that took its place (it is moved
 * onto contact with it and re-checked), which wastes no walk. Both events are
 * counted. The target is exact: the count is checked and raised under the
 * bucket mutex.
 *
 * hwloc finds the physical cores (for threads = 0) and, when asked, binds
 * worker i to core i mod cores.
 */
#include <hwloc.h>
#if defined(__x86_64__)
#include <x86intrin.h>
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "parallel.h"
#include "recent.h"

/* Particles appended between a worker's lock-free check and its bucket
 * mutex: about the number of workers, rarely more. */
#define RECENT_CAP 4096u

typedef struct worker {
    /* The map epoch this worker saw between two walks, when it held no map
     * grid (UINT64_MAX once it has returned); written by the worker once a
     * walk, read by the coordinating thread to free retired grids. */
    _Atomic uint64_t seen_epoch;
    PDLA_CACHE_PAD(pad_epoch_);
    pdla_engine *e;
    walker_ctx *w;
    recent_ring *recent;     /* shared by all workers */
    uint64_t n_until;
    hwloc_topology_t topo;   /* NULL unless binding */
    hwloc_obj_t core;        /* core to bind to, or NULL */
    pthread_t thread;
    int rc;
    char err[256];
} worker;

enum { INSERTED = 0, TARGET_REACHED = 1, DISCARDED = 2 };

static int worker_fail(worker *k, int rc, const char *what)
{
    snprintf(k->err, sizeof k->err, "%s", what);
    k->rc = rc;
    atomic_store_explicit(&k->e->stop, 1, memory_order_relaxed);
    return rc;
}

/* A timestamp for the mutex timings: the time-stamp counter where there is
 * one (a few ns to read), else the monotonic clock in ns. */
static inline uint64_t ticks(void)
{
#if defined(__x86_64__)
    return __rdtsc();
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
#endif
}

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e9 * (double)ts.tv_sec + (double)ts.tv_nsec;
}

/* Lock mu, counting the acquisition, whether it had to wait and how long.
 * Returns the time it was acquired (for unlock_counted). */
static inline uint64_t lock_counted(pthread_mutex_t *mu, walker_ctx *w, int which)
{
    w->mutex_taken[which]++;
    if (pthread_mutex_trylock(mu)) {
        w->mutex_contended[which]++;
        const uint64_t t0 = ticks();
        pthread_mutex_lock(mu);
        const uint64_t t1 = ticks();
        w->mutex_wait_ticks[which] += t1 - t0;
        return t1;
    }
    return ticks();
}

#define LONG_HOLD_TICKS (UINT64_C(1) << 17)

static inline void unlock_counted(pthread_mutex_t *mu, walker_ctx *w, int which, uint64_t since)
{
    const uint64_t held = ticks() - since;
    if (held < LONG_HOLD_TICKS)
        w->mutex_hold_ticks[which] += held;
    else
        w->mutex_long_holds[which]++;
    pthread_mutex_unlock(mu);
}

/* Insert the particle where walker w stopped; see the file comment. The exact
 * re-check is split in two: against the live tree as of `seen` particles
 * without a lock, then against those appended since under the bucket mutex.
 * Together they cover every particle present when the particle is appended,
 * exactly as one check under the lock would. */
static int insert_concurrent(worker *k, int64_t *p, int status)
{
    pdla_engine *e = k->e;
    walker_ctx *w = k->w;
    tree *t = &e->tree;
    const pdla_params *P = &e->params;
    const int64_t D = P->resolution;
    const uint64_t D2 = (uint64_t)(D * D);
    const uint64_t stick2 = (uint64_t)(D + P->eps) * (uint64_t)(D + P->eps);
    int retried = 0;
    for (;;) {
        /* Every particle below `seen` is visible to the searches that follow
         * (acquire on the count the bucket mutex's holder released). */
        const uint64_t seen = tree_count(t);
        /* A snap that moved p has just checked its new spot against every
         * particle within D: the lock-free half of the re-check. */
        int checked = 0;
        if (status == WALK_OVERLAP) {
            w->recheck_overlaps++;
            if (P->recheck == PDLA_RECHECK_DISCARD || retried ||
                !walker_snap_to_contact(t, p, D, stick2, &w->ss)) {
                w->recheck_discarded++;
                return DISCARDED;
            }
            retried = 1;
            checked = 1;
        } else if (P->snap_contact) {
            checked = walker_snap_to_contact(t, p, D, stick2, &w->ss);
        }
        char err[256];
        if (engine_check_range(e, p, err, sizeof err)) return worker_fail(k, PDLA_ERANGE, err);

        int64_t q[3];
        uint64_t d2;
        if (!checked && search_nearest_point_cached(t, p, D2, q, &d2, &w->ss)) {
            status = WALK_OVERLAP; /* someone stuck here since the last query */
            continue;
        }
        /* Structure: the tree's nodes down to p's leaf and p's cells in the
         * distance map, under the node mutex and only when missing (for about
         * one particle in ten: a new leaf). The map is updated before the
         * particle is published in the tree, so a walker that sees the
         * particle also sees its cells; if the re-check below then turns the
         * spot down, the cells stay marked, which only makes the map's
         * bounds more conservative there. */
        tree_slot slot;
        const int have_path = tree_find_slot(t, p, &slot);
        if (!have_path || distmap_needs_add(&e->dmap, p)) {
            const uint64_t held = lock_counted(&e->node_mu, w, PDLA_MUTEX_NODE);
            const int rc = have_path ? 0 : tree_make_path(t, p, &slot);
            if (rc == 0) distmap_add(&e->dmap, p, seen + 1, 1);
            unlock_counted(&e->node_mu, w, PDLA_MUTEX_NODE, held);
            if (rc) return worker_fail(k, PDLA_ENOMEM, "out of memory (or tree index space) creating nodes");
        }

        const uint64_t held = lock_counted(&e->bucket_mu, w, PDLA_MUTEX_BUCKET);
        const uint64_t count = atomic_load_explicit(&t->count, memory_order_relaxed);
        if (count >= k->n_until) {
            unlock_counted(&e->bucket_mu, w, PDLA_MUTEX_BUCKET, held);
            return TARGET_REACHED;
        }
        if (recent_overlap(k->recent, t, seen, p, D2)) {
            unlock_counted(&e->bucket_mu, w, PDLA_MUTEX_BUCKET, held);
            status = WALK_OVERLAP;
            continue;
        }
        /* Before the count publishes p: the ring slot and R_ext, which
         * walkers read without a lock once they have acquired the count
         * (their stale-read check, walker.c). A failed append leaves a slot
         * for an index not yet published; the next append rewrites it. */
        recent_put(k->recent, count, p, t->dim);
        engine_raise_r_ext(e, p);
        if (__builtin_expect(e->hooks != NULL, 0) && e->hooks->append)
            e->hooks->append(e->hooks->user, count, p);
        const int rc = tree_append(t, &slot, p);
        unlock_counted(&e->bucket_mu, w, PDLA_MUTEX_BUCKET, held);
        if (rc) return worker_fail(k, PDLA_ENOMEM, "out of memory appending a particle");
        if (retried) w->recheck_continued++;
        walker_note_lag(w, count);
        if (__builtin_expect(e->hooks != NULL, 0) && e->hooks->inserted)
            e->hooks->inserted(e->hooks->user, count, p, count - w->launched_at);

        const uint64_t gheld = lock_counted(&e->gyration_mu, w, PDLA_MUTEX_GYRATION);
        const int grc = engine_gyration_add(e, p, err, sizeof err);
        unlock_counted(&e->gyration_mu, w, PDLA_MUTEX_GYRATION, gheld);
        if (grc) return worker_fail(k, grc, err);
        return INSERTED;
    }
}

static void *worker_main(void *arg)
{
    worker *k = arg;
    pdla_engine *e = k->e;
    if (k->topo && k->core) {
        /* Binding is a placement hint: a refusal (containers, cgroups) is
         * reported in the binding string by the caller, not fatal. */
        hwloc_set_cpubind(k->topo, k->core->cpuset, HWLOC_CPUBIND_THREAD);
    }
    while (!atomic_load_explicit(&e->stop, memory_order_relaxed) &&
           tree_count(&e->tree) < k->n_until) {
        atomic_store_explicit(&k->seen_epoch, distmap_epoch(&e->dmap), memory_order_release);
        const engine_hooks *h = e->hooks;
        if (__builtin_expect(h != NULL, 0) && h->turn_begin) h->turn_begin(h->user, k->w->id);
        int64_t p[3];
        const int status = walker_run(e, k->w, p);
        const int r = insert_concurrent(k, p, status);
        if (__builtin_expect(h != NULL, 0) && h->turn_end) h->turn_end(h->user, k->w->id);
        if (r == TARGET_REACHED || r < 0) break;
    }
    atomic_store_explicit(&k->seen_epoch, UINT64_MAX, memory_order_release);
    struct timespec cpu;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cpu) == 0)
        k->w->cpu_seconds = (double)cpu.tv_sec + 1e-9 * (double)cpu.tv_nsec;
    return NULL;
}

/* Free the map grids that no worker can still hold: those retired before
 * the oldest epoch any worker has seen between two of its walks. */
static void reclaim_grids(pdla_engine *e, worker *ks, int n)
{
    uint64_t oldest = UINT64_MAX;
    for (int i = 0; i < n; i++) {
        const uint64_t s = atomic_load_explicit(&ks[i].seen_epoch, memory_order_acquire);
        if (s < oldest) oldest = s;
    }
    pthread_mutex_lock(&e->node_mu);
    distmap_reclaim(&e->dmap, oldest);
    pthread_mutex_unlock(&e->node_mu);
}

static void sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

/* Load the topology when it is needed (threads = 0 or binding); returns the
 * number of physical cores, or 0 on failure. */
static int load_topology(hwloc_topology_t *topo)
{
    if (hwloc_topology_init(topo)) return 0;
    if (hwloc_topology_load(*topo)) {
        hwloc_topology_destroy(*topo);
        *topo = NULL;
        return 0;
    }
    const int cores = hwloc_get_nbobjs_by_type(*topo, HWLOC_OBJ_CORE);
    return cores > 0 ? cores : hwloc_get_nbobjs_by_type(*topo, HWLOC_OBJ_PU);
}

int parallel_grow(pdla_engine *e, uint64_t n_until, pdla_progress_fn progress, void *user,
                  char *err, size_t errlen)
{
    const pdla_params *P = &e->params;
    hwloc_topology_t topo = NULL;
    int cores = 0;
    if (P->threads == 0 || P->bind == PDLA_BIND_CORE) {
        cores = load_topology(&topo);
        if (cores <= 0) {
            snprintf(err, errlen, "hwloc could not read the machine topology");
            return PDLA_EINVAL;
        }
    }
    const int n = P->threads > 0 ? P->threads : cores;

    walker_ctx *ws = calloc((size_t)n, sizeof *ws);
    worker *ks = calloc((size_t)n, sizeof *ks);
    recent_ring recent;
    const int ring_rc = recent_init(&recent, RECENT_CAP);
    if (!ws || !ks || ring_rc) {
        free(ws);
        free(ks);
        recent_free(&recent);
        if (topo) hwloc_topology_destroy(topo);
        snprintf(err, errlen, "out of memory for %d workers", n);
        return PDLA_ENOMEM;
    }
    /* Independent streams, as the reference mode's walkers (reference.c):
     * worker 0 continues the serial stream, worker i starts 2^128 i draws
     * after it, and the serial stream resumes 2^128 n draws after it, past
     * every worker's. (It used to resume at the start of worker n - 1's,
     * which a serial phase after a resume would have drawn again.) */
    pdla_rng stream = e->walker.rng;
    size_t used = (size_t)snprintf(e->binding, sizeof e->binding, "%s",
                                   P->bind == PDLA_BIND_CORE ? "core:" : "none");
    for (int i = 0; i < n; i++) {
        if (i > 0) rng_jump(&stream);
        ws[i].rng = stream;
        ws[i].id = i;
        search_state_reset(&ws[i].ss);
        ks[i].e = e;
        ks[i].w = &ws[i];
        ks[i].n_until = n_until;
        atomic_init(&ks[i].seen_epoch, 0); /* not started: holds anything */
        ks[i].recent = &recent;
        if (P->bind == PDLA_BIND_CORE) {
            ks[i].topo = topo;
            ks[i].core = hwloc_get_obj_by_type(topo, HWLOC_OBJ_CORE, (unsigned)(i % cores));
            if (!ks[i].core) ks[i].core = hwloc_get_obj_by_type(topo, HWLOC_OBJ_PU, (unsigned)(i % cores));
            if (used < sizeof e->binding)
                used += (size_t)snprintf(e->binding + used, sizeof e->binding - used, " %u",
                                         ks[i].core ? ks[i].core->logical_index : 0u);
        }
    }
    /* Counters of an earlier parallel phase are folded into the serial
     * walker so stats stay cumulative. */
    for (int i = 0; i < e->nworkers; i++) walker_ctx_add_counts(&e->walker, &e->workers[i]);
    free(e->workers);
    e->workers = NULL;
    e->nworkers = 0;
    rng_jump(&stream);
    e->walker.rng = stream; /* the serial stream resumes past every worker's */
    atomic_store_explicit(&e->stop, 0, memory_order_relaxed);
    e->search.concurrent = 1;
    e->recent = &recent; /* walkers check their jumps against it */

    /* Calibrate the timestamp ticks against the clock over the phase. */
    const uint64_t tick0 = ticks();
    const double ns0 = now_ns();
    int started = 0, rc = PDLA_OK;
    for (; started < n; started++)
        if (pthread_create(&ks[started].thread, NULL, worker_main, &ks[started])) {
            atomic_store_explicit(&e->stop, 1, memory_order_relaxed);
            snprintf(err, errlen, "cannot start worker thread %d of %d", started + 1, n);
            rc = PDLA_ENOMEM;
            break;
        }
    /* The calling thread reports progress and relays a stop request. */
    while (rc == PDLA_OK && !atomic_load_explicit(&e->stop, memory_order_relaxed) &&
           tree_count(&e->tree) < n_until) {
        sleep_ms(20);
        reclaim_grids(e, ks, started);
        if (progress && progress(e, user)) {
            atomic_store_explicit(&e->stop, 1, memory_order_relaxed);
            snprintf(err, errlen, "stopped at %llu particles",
                     (unsigned long long)tree_count(&e->tree));
            rc = PDLA_ESTOPPED;
        }
    }
    for (int i = 0; i < started; i++) pthread_join(ks[i].thread, NULL);
    const uint64_t dt = ticks() - tick0;
    if (dt > 0) e->tick_ns = (now_ns() - ns0) / (double)dt;
    distmap_quiesce(&e->dmap);
    e->search.concurrent = 0;
    e->recent = NULL;
    for (int i = 0; i < started; i++)
        if (ks[i].rc && rc == PDLA_OK) {
            snprintf(err, errlen, "worker %d: %s", i, ks[i].err);
            rc = ks[i].rc;
        }
    e->workers = ws;
    e->nworkers = n;
    free(ks);
    recent_free(&recent);
    if (topo) hwloc_topology_destroy(topo);
    return rc;
}
