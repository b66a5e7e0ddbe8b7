/*
 * grow.c - pdla_engine_grow: the serial DLA loop (one walker, deterministic)
 * up to serial_until particles, then the parallel phase (parallel.c). This is
 * the top of the engine: it calls the walker, the cluster state (engine.c)
 * and the workers; nothing below calls back into it.
 */
#include <string.h>

#include "engine.h"
#include "parallel.h"
#include "reference.h"

/* The compaction count after `at` (engine.h). */
static uint64_t compact_next(uint64_t at)
{
    return at + (at >> 3 ? at >> 3 : 1);
}

/* Compact the tree at the serial phase's compaction counts (engine.h);
 * out of memory it stays as it is (the layout is only for speed). */
static void compact_serial(pdla_engine *e, uint64_t *at)
{
    const uint64_t n = tree_count(&e->tree);
    if (!*at || n < *at) return;
    while (*at <= n) *at = compact_next(*at);
    if (n / 4 * 5 <= e->params.target && tree_compact(&e->tree) == 0)
        search_state_forget_indices(&e->walker.ss);
}

/* Steps of a serial walk between two looks at the clock (~5-20 ms), and
 * the seconds between two calls of progress within one walk. */
#define SERIAL_SLICE_STEPS (1u << 16)
#define SERIAL_POLL_SECONDS 0.25

/* One serial walk, with progress called every SERIAL_POLL_SECONDS while it
 * lasts: progress was called only between particles (every 1000), so a
 * walk that did not end (--max-jumps 1 before WALK_ENDLESS, or a birth
 * circle 1e6 diameters out) held off SIGTERM, the STOP file and timed checkpoints for ever
 * (found by an adversarial test). During the call the walker's stream is
 * the one the walk began with, so a checkpoint written then redoes the
 * whole walk when resumed (the same cluster as a straight run; the tree
 * does not change during a serial walk); a stop leaves it there, and the
 * next grow in this process goes on with the walk (e->walk_paused).
 * WALK_CONTACT, WALK_OVERLAP, WALK_ENDLESS, or WALK_STOPPED with the line
 * in err. */
static int serial_walk(pdla_engine *e, pdla_progress_fn progress, void *user, double t0, double *polled,
                       int64_t *p, char *err, size_t errlen)
{
    const pdla_rng r0 = e->walker.rng;
    const uint64_t slice = e->test_slice_steps ? e->test_slice_steps : SERIAL_SLICE_STEPS;
    const double every_s = e->test_poll_every_slice ? 0 : SERIAL_POLL_SECONDS;
    walk_state ws;
    int st;
    if (e->walk_paused && !memcmp(&e->walker.rng, &e->paused_r0, sizeof r0)) {
        /* a stop (a checkpoint, most often) within a walk: go on with it;
         * walks longer than the checkpoint interval then still end */
        ws = e->paused_ws;
        e->walker.rng = e->paused_rng;
        st = WALK_MOVED;
    } else {
        st = walker_run_slice(e, &e->walker, &ws, 0, slice, p);
    }
    e->walk_paused = 0;
    while (st == WALK_MOVED) {
        const double now = pdla_clock_seconds();
        if (progress && now - *polled >= every_s) {
            *polled = now;
            const pdla_rng cur = e->walker.rng;
            e->walker.rng = r0;
            e->grow_seconds += now - t0;
            const int stop = progress(e, user);
            e->grow_seconds -= pdla_clock_seconds() - t0;
            if (stop) {
                e->walk_paused = 1;
                e->paused_ws = ws;
                e->paused_rng = cur;
                e->paused_r0 = r0;
                pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped at %llu particles",
                            (unsigned long long)tree_count(&e->tree));
                return WALK_STOPPED;
            }
            e->walker.rng = cur;
        }
        st = walker_run_slice(e, &e->walker, &ws, 1, slice, p);
    }
    return st;
}

int pdla_engine_grow(pdla_engine *e, uint64_t n_until, pdla_progress_fn progress, uint64_t every,
                     void *user, char *err, size_t errlen)
{
    if (n_until > e->params.target) n_until = e->params.target;
    const double t0 = pdla_clock_seconds();
    int rc = PDLA_OK;
    if (tree_count(&e->tree) == 0 && n_until > 0) {
        const int64_t origin[3] = {0, 0, 0};
        rc = engine_add_particle(e, origin, err, errlen);
    }
    if (every == 0) every = 1000;
    const int phase2 = e->params.threads != 1 || e->params.reference_walkers > 0;
    const uint64_t serial_end = !phase2 || n_until < e->params.serial_until
                                    ? n_until
                                    : e->params.serial_until;
    const int64_t D = e->params.resolution;
    const uint64_t stick2 = (uint64_t)(D + e->params.eps) * (uint64_t)(D + e->params.eps);
    uint64_t compact_at = e->compact_first;
    while (compact_at && compact_at <= tree_count(&e->tree)) compact_at = compact_next(compact_at);
    double polled = t0;
    while (rc == PDLA_OK && tree_count(&e->tree) < serial_end) {
        int64_t p[3];
        compact_serial(e, &compact_at);
        const int st = serial_walk(e, progress, user, t0, &polled, p, err, errlen);
        if (st == WALK_STOPPED) {
            rc = PDLA_ESTOPPED;
            break;
        }
        if (st == WALK_ENDLESS) {
            rc = pdla_errorf(PDLA_EINVAL, err, errlen, WALK_ENDLESS_FMT, WALK_ENDLESS_RESTARTS,
                             (unsigned long long)e->params.max_jumps);
            break;
        }
        if (st != WALK_CONTACT) {
            rc = pdla_errorf(PDLA_EINVAL, err, errlen,
                      "internal error: a serial walker stopped closer than one diameter");
            break;
        }
        if (e->params.snap_contact) walker_snap_to_contact(&e->tree, p, D, stick2, &e->walker.ss);
        rc = engine_add_walker_particle(e, p, &e->walker.ss, err, errlen);
        /* Not at n_until: a stop asked there would cut nothing short, yet
         * report the complete cluster as stopped (the CLI would then end by
         * the signal after writing it whole). */
        if (rc == PDLA_OK && progress && tree_count(&e->tree) % every == 0 && tree_count(&e->tree) < n_until) {
            e->grow_seconds += pdla_clock_seconds() - t0;
            const int stop = progress(e, user);
            e->grow_seconds -= pdla_clock_seconds() - t0;
            if (stop) rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped at %llu particles",
                                (unsigned long long)tree_count(&e->tree));
        }
    }
    if (rc == PDLA_OK && tree_count(&e->tree) < n_until && e->params.reference_walkers > 0) {
        rc = reference_grow(e, n_until, progress, every, user, err, errlen);
    } else if (rc == PDLA_OK && tree_count(&e->tree) < n_until) {
        const double tp = pdla_clock_seconds();
        rc = parallel_grow(e, n_until, progress, user, err, errlen);
        e->parallel_seconds += pdla_clock_seconds() - tp;
    }
    e->grow_seconds += pdla_clock_seconds() - t0;
    return rc;
}
