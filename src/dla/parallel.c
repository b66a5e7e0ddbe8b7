/*
 * parallel.c - the PDLA phase: N worker threads, each with its own walker
 * and random stream, grow the one shared, live tree, following the flow
 * diagram of Sosa-Herrera & Rodriguez-Romo (Fig. 6):
 *
 *   walk (lock-free reads of the tree)
 *   -> exact check of the spot against the live tree, lock-free
 *   -> [bucket mutex]   target check, straggler bound, re-check against the
 *                       particles appended since, then
 *      [node mutex]     (inside it, for the frontier only) create the tree
 *                       nodes down to the particle's leaf and mark its cells
 *                       in the distance map (skipped when both exist, as for
 *                       about 92% of particles), then append
 *   -> [gyration mutex] R_g sums, R_ext, R_g samples
 *
 * Why the node work is done inside the bucket mutex (issue 11): it used to
 * come before it, under the node mutex alone. A walker whose particle needed
 * new nodes (the frontier, where the cluster grows outward) then waited for
 * the node mutex, while walkers that needed none went on to append past it
 * (or it was relaunched by the straggler bound after its node work): a slow
 * node-mutex holder (descheduled, a page fault in a new tree block, a big
 * map update) delayed or dropped the frontier's particles selectively.
 * Inside the bucket mutex nobody appends while a frontier particle's node
 * work runs, and the checks that can turn a particle down come first (test
 * frontier-order). Made slow on purpose (a test hook sleeping 500 us in the
 * node work, 8 workers, 2D 1e4 -> 3e4, runs/pdla-bias/node9) the clusters
 * come out 1.0% more compact than serial DLA with the old order, 0.3% with
 * this one: what is left is not the frontier's but that of any slow holder
 * of the bucket mutex (walks that end meanwhile wait and stick where the
 * cluster was, or are relaunched; a first-come order measured worse, -1.8%).
 * Unamplified, the node work takes about 0.5 us (2D) to 2 us (3D).
 *
 * The lock order is bucket -> node (pdla_engine_stats too); the gyration
 * mutex is taken alone. The node mutex stays, though every worker now takes
 * it inside the bucket mutex: the coordinating thread frees retired map
 * grids under it alone (reclaim_grids), so that reclaiming holds up only
 * frontier appends, not all of them. Tree nodes are still published with
 * release semantics (tree.c), so walkers read the tree without a lock.
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
#include "must.h"
#include "parallel.h"
#include "claims.h"
#include "recent.h"

/* Particles appended between a worker's lock-free check and its bucket
 * mutex: about the number of workers, rarely more. */
#define RECENT_CAP 4096u

/* The straggler bound (issue 11): with n workers, a walker that finds more
 * than STRAGGLER_FACTOR * n particles appended since its own last step
 * (checked at every step, walker.c, and at the append, append_locked) is
 * relaunched from the birth circle instead of going on.
 *
 * Why the bound: in the race-free reference of n walkers (reference.c) the
 * others append at most n - 1 particles between two steps of a walker, and
 * none between its last step and its append; so do the workers taking turns
 * (test lockstep), so the bound never triggers there, and the reference is
 * not touched at all (it runs no worker). With free cores a step takes far
 * less time than a walk, so the others append about (n - 1) / (jumps per
 * walk) << 1 particles per step. More than 8n means the walker was
 * descheduled (an oversubscribed or shared machine) while the others grew
 * the cluster by many particles: a walker frozen at a point its walk chose
 * in a cluster that no longer exists ("straggler"; about 110 per 1e5
 * particles at 4 and 16 workers on the shared 2-core VM, with lags of 2000
 * to 9000) would stick too deep in the new growth, a thing neither serial
 * DLA nor P walkers in flight do.
 *
 * Why relaunching does not bias: the relaunched walker is a fresh walker on
 * a circle enclosing the cluster as of the count it read (R_ext covers it),
 * launched uniformly, which is the exact harmonic measure from infinity for
 * that circle; so it hits the current cluster with the exact harmonic
 * measure, as serial DLA's next walker would. Whether a walker is relaunched
 * depends on the others' appends (the OS schedule), not on its own path;
 * the one selection left is that a longer walk has more chances to be
 * caught by a deschedule, which reweights only the relaunched walks (counted
 * in stats.relaunches: 0.1-0.4% of the walks with 8 workers on 2 CPUs, most
 * of them walkers frozen on the contended bucket mutex before their append,
 * 1.5% under ThreadSanitizer; measured in runs/pdla-bias/README.md) and only by their duration, not by where they
 * were heading. Without the bound those same walks stick with the hit
 * distribution of a cluster thousands of particles younger. */
#define STRAGGLER_FACTOR ((uint64_t)PDLA_STRAGGLER_FACTOR)

/* Room at the end of e->binding for mark_refused_bindings' note. */
#define BINDING_NOTE_ROOM 64

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
    int bind_refused;        /* hwloc_set_cpubind failed (written by the worker, read after the join) */
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

/* Lock mu, counting the acquisition, whether it had to wait and how long.
 * Returns the time it was acquired (for unlock_counted). */
static inline uint64_t lock_counted(pthread_mutex_t *mu, walker_ctx *w, int which)
{
    w->mutex_taken[which]++;
    if (pthread_mutex_trylock(mu)) {
        w->mutex_contended[which]++;
        const uint64_t t0 = ticks();
        PDLA_MUST(pthread_mutex_lock(mu));
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
    PDLA_MUST(pthread_mutex_unlock(mu));
}

/* insert_concurrent's steps below return these (errors are negative
 * PDLA_E* codes, already recorded by worker_fail). RETRY: another walker took
 * the spot since this one's last check; re-check as an overlap. */
enum { RETRY = 3, RELAUNCH = 4, ABANDON = 5 /* worker_main: a stop came within the walk */ };

/* Step 1, for an overlap: snap p onto contact with the particle that took
 * its spot, once, unless --recheck discard. Otherwise the snap of
 * --snap-contact. Returns 1 when the snap has just checked p's new spot
 * against every particle within D (the lock-free half of the re-check is
 * then done), 0 when that check is still to do, DISCARDED when the walker
 * is given up. */
static int snap_spot(worker *k, int64_t *p, int status, int *retried)
{
    walker_ctx *w = k->w;
    const tree *t = &k->e->tree;
    const pdla_params *P = &k->e->params;
    const int64_t D = P->resolution;
    const uint64_t stick2 = (uint64_t)(D + P->eps) * (uint64_t)(D + P->eps);
    if (status == WALK_OVERLAP) {
        w->recheck_overlaps++;
        if (P->recheck == PDLA_RECHECK_DISCARD || *retried ||
            !walker_snap_to_contact(t, p, D, stick2, &w->ss)) {
            w->recheck_discarded++;
            return DISCARDED;
        }
        *retried = 1;
        return 1;
    }
    return P->snap_contact && walker_snap_to_contact(t, p, D, stick2, &w->ss);
}

/* Step 2, lock-free: whether p needs node work (a new tree path down to
 * its leaf, or new cells in the distance map: the frontier, about one
 * particle in 13 in 2D, one in 23 in 3D); fills *slot when the path exists. */
static int needs_nodes(const pdla_engine *e, const int64_t *p, tree_slot *slot, int *have_path)
{
    *have_path = tree_find_slot(&e->tree, p, slot);
    return !*have_path || distmap_needs_add(&e->dmap, p);
}

/* The node work under the node mutex: the tree's nodes down to p's leaf
 * (unless have_path) and p's cells in the distance map. The map is updated
 * before the particle is published in the tree, so a walker that sees the
 * particle also sees its cells. The caller holds the bucket mutex, except
 * with the test hook node_before_bucket (the order before the fix). Fills
 * *slot; 0 or PDLA_ENOMEM. */
static int make_path(worker *k, const int64_t *p, uint64_t seen, int have_path, tree_slot *slot)
{
    pdla_engine *e = k->e;
    const uint64_t held = lock_counted(&e->node_mu, k->w, PDLA_MUTEX_NODE);
    const int rc = have_path ? 0 : tree_make_path(&e->tree, p, slot);
    if (rc == 0) distmap_add(&e->dmap, p, seen + 1, 1);
    if (__builtin_expect(e->hooks != NULL, 0) && e->hooks->node_work && !e->hooks->node_work_published)
        e->hooks->node_work(e->hooks->user);
    unlock_counted(&e->node_mu, k->w, PDLA_MUTEX_NODE, held);
    if (rc) return worker_fail(k, PDLA_ENOMEM, "out of memory (or tree index space) creating nodes");
    return 0;
}

/* Step 3, under the bucket mutex: the exact target check, the straggler
 * bound (more than relaunch_after particles appended since the walk's last
 * step: RELAUNCH), the re-check against the particles appended since `seen`
 * (the ring), the node work when `need` (make_path, node mutex taken inside
 * the bucket mutex: a slow insertion at the frontier holds every append up,
 * see the file comment), and the append. INSERTED with p's index in *index,
 * TARGET_REACHED, RELAUNCH, RETRY, or PDLA_ENOMEM. */
static int append_locked(worker *k, const int64_t *p, uint64_t seen, int need, int have_path,
                         tree_slot *slot, uint64_t *index)
{
    pdla_engine *e = k->e;
    tree *t = &e->tree;
    const uint64_t D = (uint64_t)e->params.resolution;
    const uint64_t held = lock_counted(&e->bucket_mu, k->w, PDLA_MUTEX_BUCKET);
    const uint64_t count = atomic_load_explicit(&t->count, memory_order_relaxed);
    if (count >= k->n_until) {
        unlock_counted(&e->bucket_mu, k->w, PDLA_MUTEX_BUCKET, held);
        return TARGET_REACHED;
    }
    const walker_ctx *w = k->w;
    if (w->relaunch_after && count - w->step_seen > w->relaunch_after) {
        unlock_counted(&e->bucket_mu, k->w, PDLA_MUTEX_BUCKET, held);
        return RELAUNCH;
    }
    if (recent_overlap(k->recent, t, seen, p, D * D)) {
        unlock_counted(&e->bucket_mu, k->w, PDLA_MUTEX_BUCKET, held);
        return RETRY;
    }
    if (need && make_path(k, p, seen, have_path, slot)) {
        unlock_counted(&e->bucket_mu, k->w, PDLA_MUTEX_BUCKET, held);
        return PDLA_ENOMEM;
    }
    /* Before the count publishes p: the ring slot and R_ext, which
     * walkers read without a lock once they have acquired the count
     * (their stale-read check, walker.c). A failed append leaves a slot
     * for an index not yet published; the next append rewrites it. */
    recent_put(k->recent, count, p, t->dim);
    engine_raise_r_ext(e, p);
    if (__builtin_expect(e->hooks != NULL, 0) && e->hooks->append)
        e->hooks->append(e->hooks->user, count, p);
    const int rc = tree_append(t, slot, p, 1);
    if (__builtin_expect(e->hooks != NULL, 0) && need && e->hooks->node_work && e->hooks->node_work_published)
        e->hooks->node_work(e->hooks->user);
    unlock_counted(&e->bucket_mu, k->w, PDLA_MUTEX_BUCKET, held);
    if (rc) return worker_fail(k, PDLA_ENOMEM, "out of memory appending a particle");
    *index = count;
    return INSERTED;
}

/* Step 4, after the append: counters, the inserted hook, and the R_g sums
 * and samples under the gyration mutex (kept apart from the bucket mutex so
 * appends do not wait for the sums). INSERTED or the sums' error. */
static int account_insert(worker *k, const int64_t *p, uint64_t count, int retried)
{
    pdla_engine *e = k->e;
    walker_ctx *w = k->w;
    if (retried) w->recheck_continued++;
    walker_note_lag(w, count);
    if (__builtin_expect(e->hooks != NULL, 0) && e->hooks->inserted)
        e->hooks->inserted(e->hooks->user, count, p, count - w->launched_at);
    char err[256];
    const uint64_t held = lock_counted(&e->gyration_mu, w, PDLA_MUTEX_GYRATION);
    const int rc = engine_gyration_add_at(e, p, count, err, sizeof err);
    unlock_counted(&e->gyration_mu, w, PDLA_MUTEX_GYRATION, held);
    if (rc) return worker_fail(k, rc, err);
    return INSERTED;
}

/* Insert the particle where walker w stopped; see the file comment. The exact
 * re-check is split in two: against the live tree as of `seen` particles
 * without a lock (the snap, or the nearest-point query), then against those
 * appended since under the bucket mutex (append_locked). Together they cover
 * every particle present when the particle is appended, exactly as one check
 * under the lock would. An overlap found by either restarts the steps with
 * the spot treated as taken. */
static int insert_spot(worker *k, int64_t *p, int status)
{
    pdla_engine *e = k->e;
    const uint64_t D2 = (uint64_t)e->params.resolution * (uint64_t)e->params.resolution;
    int retried = 0;
    if (__builtin_expect(e->hooks != NULL, 0) && e->hooks->decided)
        e->hooks->decided(e->hooks->user, k->w->id, p);
    for (;;) {
        /* Every particle below `seen` is visible to the searches that follow
         * (acquire on the count the bucket mutex's holder released). */
        const uint64_t seen = tree_count(&e->tree);
        /* After an overlap the snap moves p onto the newcomer: the spot is
         * published again where the walker stopped, with the snap's margin
         * (the decision published it first, walker.c). */
        if (status == WALK_OVERLAP)
            claims_publish(e->claims, k->w->id, p, e->tree.dim,
                           claims_margin(e->params.resolution, e->params.eps));
        const int checked = snap_spot(k, p, status, &retried);
        if (checked == DISCARDED) return DISCARDED;
        char err[256];
        if (engine_check_range(e, p, err, sizeof err)) return worker_fail(k, PDLA_ERANGE, err);
        int64_t q[3];
        uint64_t d2;
        status = WALK_OVERLAP; /* for the next turn, if there is one */
        if (!checked && search_nearest_point_cached(&e->tree, p, D2, q, &d2, &k->w->ss))
            continue; /* someone stuck here since the last query */
        tree_slot slot;
        int have_path;
        int need = needs_nodes(e, p, &slot, &have_path);
        if (need && __builtin_expect(e->hooks != NULL, 0) && e->hooks->node_before_bucket) {
            const int rc = make_path(k, p, seen, have_path, &slot); /* the order before the fix */
            if (rc) return rc;
            need = 0;
        }
        uint64_t index = 0;
        const int rc = append_locked(k, p, seen, need, have_path, &slot, &index);
        if (rc == RETRY) continue;
        if (rc != INSERTED) return rc;
        /* Appended (the count published it): the others see it now. */
        claims_withdraw(e->claims, k->w->id);
        return account_insert(k, p, index, retried);
    }
}

/* The spot the walker stopped at was published when it was chosen
 * (claims.h); whatever becomes of it, it is withdrawn here. */
static int insert_concurrent(worker *k, int64_t *p, int status)
{
    const int r = insert_spot(k, p, status);
    if (r != INSERTED) claims_withdraw(k->e->claims, k->w->id);
    return r;
}

static void *worker_main(void *arg)
{
    worker *k = arg;
    pdla_engine *e = k->e;
    if (k->topo && k->core) {
        /* Binding is a placement hint: a refusal (containers, cgroups) is
         * not fatal; the coordinating thread adds it to the binding string
         * after the join (mark_refused_bindings). */
        k->bind_refused = hwloc_set_cpubind(k->topo, k->core->cpuset, HWLOC_CPUBIND_THREAD) != 0;
    }
    while (!atomic_load_explicit(&e->stop, memory_order_relaxed) &&
           tree_count(&e->tree) < k->n_until) {
        atomic_store_explicit(&k->seen_epoch, distmap_epoch(&e->dmap), memory_order_release);
        const engine_hooks *h = e->hooks;
        if (__builtin_expect(h != NULL, 0) && h->turn_begin) h->turn_begin(h->user, k->w->id);
        int64_t p[3];
        const int status = walker_run(e, k->w, p);
        int r = ABANDON;
        if (status == WALK_ENDLESS) {
            char msg[256];
            snprintf(msg, sizeof msg, WALK_ENDLESS_FMT, WALK_ENDLESS_RESTARTS,
                     (unsigned long long)e->params.max_jumps);
            r = worker_fail(k, PDLA_EINVAL, msg);
        } else if (status != WALK_ABANDONED) {
            r = insert_concurrent(k, p, status);
        }
        if (r == RELAUNCH) k->w->relaunches++; /* the next walk is a fresh walker */
        if (__builtin_expect(h != NULL, 0) && h->turn_end) h->turn_end(h->user, k->w->id);
        if (r == TARGET_REACHED || r == ABANDON || r < 0) break;
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
    PDLA_MUST(pthread_mutex_lock(&e->node_mu));
    distmap_reclaim(&e->dmap, oldest);
    PDLA_MUST(pthread_mutex_unlock(&e->node_mu));
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

/* One PDLA phase: its workers and what they share. */
typedef struct phase {
    hwloc_topology_t topo; /* NULL unless threads = 0 or binding */
    int cores;             /* physical cores (with topo) */
    int n;                 /* workers */
    int started;           /* threads created */
    walker_ctx *ws;        /* the workers' walkers: kept by the engine after */
    worker *ks;
    recent_ring recent;
    claim_board claims;
} phase;

static void phase_free(phase *ph)
{
    free(ph->ws);
    free(ph->ks);
    recent_free(&ph->recent);
    claims_free(&ph->claims);
    if (ph->topo) hwloc_topology_destroy(ph->topo);
}

/* Step 1: how many workers (reading the topology when threads = 0 or when
 * binding), and their memory. PDLA_OK, or an error with err (nothing held). */
static int phase_alloc(pdla_engine *e, phase *ph, char *err, size_t errlen)
{
    const pdla_params *P = &e->params;
    if (P->threads == 0 || P->bind == PDLA_BIND_CORE) {
        ph->cores = load_topology(&ph->topo);
        if (ph->cores <= 0)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "hwloc could not read the machine topology");
    }
    ph->n = P->threads > 0 ? P->threads : ph->cores;
    ph->ws = calloc((size_t)ph->n, sizeof *ph->ws);
    ph->ks = calloc((size_t)ph->n, sizeof *ph->ks);
    const int ring_rc = recent_init(&ph->recent, RECENT_CAP);
    const int claims_rc = claims_init(&ph->claims, ph->n);
    if (!ph->ws || !ph->ks || ring_rc || claims_rc) {
        phase_free(ph);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for %d workers", ph->n);
    }
    return PDLA_OK;
}

/* Step 2: each worker's random stream, target and core, and e->binding.
 * Independent streams, as the reference mode's walkers (reference.c):
 * worker 0 continues the serial stream, worker i starts 2^128 i draws
 * after it, and the serial stream resumes 2^128 n draws after it, past
 * every worker's. (It used to resume at the start of worker n - 1's,
 * which a serial phase after a resume would have drawn again.) */
static void phase_setup_workers(pdla_engine *e, phase *ph, uint64_t n_until)
{
    const pdla_params *P = &e->params;
    pdla_rng stream = e->walker.rng;
    const int bound = ph->n > 1 && !(e->hooks && e->hooks->no_relaunch);
    size_t used = (size_t)snprintf(e->binding, sizeof e->binding, "%s",
                                   P->bind == PDLA_BIND_CORE ? "core:" : "none");
    for (int i = 0; i < ph->n; i++) {
        worker *k = &ph->ks[i];
        if (i > 0) rng_jump(&stream);
        ph->ws[i].rng = stream;
        ph->ws[i].id = i;
        ph->ws[i].relaunch_after = bound ? STRAGGLER_FACTOR * (uint64_t)ph->n : 0;
        search_state_reset(&ph->ws[i].ss);
        k->e = e;
        k->w = &ph->ws[i];
        k->n_until = n_until;
        atomic_init(&k->seen_epoch, 0); /* not started: holds anything */
        k->recent = &ph->recent;
        if (P->bind == PDLA_BIND_CORE) {
            k->topo = ph->topo;
            k->core = hwloc_get_obj_by_type(ph->topo, HWLOC_OBJ_CORE, (unsigned)(i % ph->cores));
            if (!k->core) k->core = hwloc_get_obj_by_type(ph->topo, HWLOC_OBJ_PU, (unsigned)(i % ph->cores));
            /* room kept for mark_refused_bindings' note: the list ends
             * with "..." past it (126 workers filled the string) */
            if (used + BINDING_NOTE_ROOM < sizeof e->binding)
                used += (size_t)snprintf(e->binding + used, sizeof e->binding - used, " %u",
                                         k->core ? k->core->logical_index : 0u);
            else if (used + 4 < sizeof e->binding && strcmp(e->binding + used - 4, " ..."))
                used += (size_t)snprintf(e->binding + used, sizeof e->binding - used, " ...");
        }
    }
    rng_jump(&stream);
    e->walker.rng = stream; /* the serial stream resumes past every worker's */
}

/* Step 3: the engine enters the concurrent phase. Counters of an earlier
 * parallel phase are folded into the serial walker so stats stay
 * cumulative; the walkers check their jumps against the shared ring. */
static void phase_begin(pdla_engine *e, phase *ph)
{
    for (int i = 0; i < e->nworkers; i++) walker_ctx_add_counts(&e->walker, &e->workers[i]);
    free(e->workers);
    e->workers = NULL;
    e->nworkers = 0;
    atomic_store_explicit(&e->stop, 0, memory_order_relaxed);
    e->search.concurrent = 1;
    e->recent = &ph->recent;
    e->claims = &ph->claims;
}


/* After the join: how many workers' binding the system refused (a
 * cgroup's cpuset, a container), added to e->binding, which the file's
 * /results binding records, so that "core: 0 1" is never claimed for
 * threads that ran where the scheduler put them. A count, in the room
 * phase_setup_workers keeps: a list of refused workers overflowed the
 * string at 60 workers and was lost at 126. */
static void mark_refused_bindings(pdla_engine *e, const phase *ph)
{
    int refused = 0;
    for (int i = 0; i < ph->started; i++) refused += ph->ks[i].bind_refused;
    const size_t used = strlen(e->binding);
    if (refused && used < sizeof e->binding)
        snprintf(e->binding + used, sizeof e->binding - used, " (refused by the system for %d of %d workers)",
                 refused, ph->started);
}
/* Step 4: start the threads, then report progress, relay a stop request and
 * free retired map grids from this thread until the target or a stop; join.
 * PDLA_OK, or the first failure of this thread (the workers' own come in
 * step 5). */
static int phase_run(pdla_engine *e, phase *ph, uint64_t n_until, pdla_progress_fn progress,
                     void *user, char *err, size_t errlen)
{
    int rc = PDLA_OK;
    for (; ph->started < ph->n; ph->started++) {
        worker *const k = &ph->ks[ph->started];
        const int t = pthread_create(&k->thread, NULL, worker_main, k);
        if (t) {
            atomic_store_explicit(&e->stop, 1, memory_order_relaxed);
            rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot start worker thread %d of %d: %s",
                             ph->started + 1, ph->n, strerror(t));
            break;
        }
    }
    while (rc == PDLA_OK && !atomic_load_explicit(&e->stop, memory_order_relaxed) &&
           tree_count(&e->tree) < n_until) {
        sleep_ms(20);
        reclaim_grids(e, ph->ks, ph->started);
        if (progress && tree_count(&e->tree) < n_until && progress(e, user)) {
            atomic_store_explicit(&e->stop, 1, memory_order_relaxed);
            rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped at %llu particles",
                             (unsigned long long)tree_count(&e->tree));
        }
    }
    for (int i = 0; i < ph->started; i++) {
        const int j = pthread_join(ph->ks[i].thread, NULL);
        if (j && rc == PDLA_OK)
            rc = pdla_errorf(PDLA_EINVAL, err, errlen, "cannot join worker thread %d: %s", i, strerror(j));
    }
    mark_refused_bindings(e, ph);
    return rc;
}

/* Step 5: back to one thread: no concurrent readers, the map's retired
 * grids freed, the first worker error (if this thread had none) in err; the
 * engine keeps the workers' walkers for the stats. */
static int phase_end(pdla_engine *e, phase *ph, int rc, char *err, size_t errlen)
{
    distmap_quiesce(&e->dmap);
    e->search.concurrent = 0;
    e->recent = NULL;
    e->claims = NULL;
    for (int i = 0; i < ph->started && rc == PDLA_OK; i++)
        if (ph->ks[i].rc) rc = pdla_errorf(ph->ks[i].rc, err, errlen, "worker %d: %s", i, ph->ks[i].err);
    /* Every appended particle was counted in its turn (engine.c
     * engine_gyration_add_at): none may still wait. */
    if (rc == PDLA_OK && e->gyr.n != tree_count(&e->tree))
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "the R_g sums hold %llu of %llu particles",
                         (unsigned long long)e->gyr.n, (unsigned long long)tree_count(&e->tree));
    e->workers = ph->ws;
    e->nworkers = ph->n;
    ph->ws = NULL;
    phase_free(ph);
    return rc;
}

int parallel_grow(pdla_engine *e, uint64_t n_until, pdla_progress_fn progress, void *user,
                  char *err, size_t errlen)
{
    phase ph = {0};
    int rc = phase_alloc(e, &ph, err, errlen);
    if (rc) return rc;
    phase_setup_workers(e, &ph, n_until);
    phase_begin(e, &ph);
    /* Calibrate the timestamp ticks against the clock over the phase. */
    const uint64_t tick0 = ticks();
    const double s0 = pdla_clock_seconds();
    rc = phase_run(e, &ph, n_until, progress, user, err, errlen);
    const uint64_t dt = ticks() - tick0;
    if (dt > 0) e->tick_ns = 1e9 * (pdla_clock_seconds() - s0) / (double)dt;
    return phase_end(e, &ph, rc, err, errlen);
}
