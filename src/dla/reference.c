/*
 * reference.c - the race-free reference of PDLA (issue 11): P walkers in
 * flight, advanced in turn in one thread, one step (a jump, a return to the
 * birth circle) each, round robin. Every step sees the cluster exactly as it
 * is then; a walker that stops is inserted at once with the workers' rules
 * (parallel.c): in contact, it is moved onto contact (snap) and added; closer
 * than one diameter (a particle another walker added since its last step
 * took its spot), it is moved onto contact with the newcomer (--recheck
 * continue) or discarded (discard). Then a new walker is launched in its
 * place.
 *
 * Deterministic for a seed: it separates the physics of P concurrent
 * walkers (serial vs reference-P) from the implementation with threads
 * (reference-P vs --threads P). Walker 0 is the serial walker (its stream and
 * counters), so P = 1 repeats serial DLA draw for draw; walker i > 0 draws
 * from the serial stream jumped 2^128 i ahead, as worker i does; with the
 * workers made to take one step each in turn (test hooks), --threads P grows
 * this mode's cluster bit for bit (tests/physics/test_lockstep.c).
 */
#include <stdlib.h>

#include "reference.h"

/* Insert where walker w stopped (status WALK_CONTACT or WALK_OVERLAP). Returns
 * PDLA_OK (inserted or discarded), or an error. */
static int reference_insert(pdla_engine *e, walker_ctx *w, int64_t *p, int status, char *err,
                            size_t errlen)
{
    const pdla_params *P = &e->params;
    const int64_t D = P->resolution;
    const uint64_t stick2 = (uint64_t)(D + P->eps) * (uint64_t)(D + P->eps);
    int continued = 0;
    if (status == WALK_OVERLAP) {
        w->recheck_overlaps++;
        /* The snap moves p onto contact with the newcomer at a grid point
         * that overlaps nothing, or fails. One thread: nothing can take the
         * spot before the insertion below, so no second re-check. */
        if (P->recheck == PDLA_RECHECK_DISCARD || !walker_snap_to_contact(&e->tree, p, D, stick2, &w->ss)) {
            w->recheck_discarded++;
            return PDLA_OK;
        }
        continued = 1;
    } else if (P->snap_contact) {
        walker_snap_to_contact(&e->tree, p, D, stick2, &w->ss);
    }
    const uint64_t index = tree_count(&e->tree);
    const int rc = engine_add_walker_particle(e, p, &w->ss, err, errlen);
    if (rc == PDLA_OK && continued) w->recheck_continued++;
    if (rc == PDLA_OK) walker_note_lag(w, index);
    return rc;
}

/* The walkers in flight, kept in the engine across a stop (a checkpoint
 * pauses growth by stopping it): they were dropped there and new ones
 * launched from new streams, so a run with periodic checkpoints grew
 * another cluster than one without, and timed ones made it differ from
 * run to run (found by an adversarial test). A resume from the checkpoint
 * file still starts new walkers (the file holds no walkers in flight).
 * The state itself: engine.h, reference_state. */
static reference_state *reference_make(pdla_engine *e)
{
    const int n = e->params.reference_walkers;
    reference_state *r = calloc(1, sizeof *r);
    if (!r) return NULL;
    r->n = n;
    r->ws = n > 1 ? calloc((size_t)n - 1, sizeof *r->ws) : NULL;
    r->st = calloc((size_t)n, sizeof *r->st);
    r->active = calloc((size_t)n, 1);
    if ((n > 1 && !r->ws) || !r->st || !r->active) {
        e->ref = r;
        engine_reference_free(e);
        return NULL;
    }
    r->stream = e->walker.rng;
    for (int i = 1; i < n; i++) {
        rng_jump(&r->stream);
        r->ws[i - 1].rng = r->stream;
        search_state_reset(&r->ws[i - 1].ss);
    }
    return r;
}

/* Steps between two looks at the clock, and the seconds between two calls
 * of progress when no particle is added (a signal must not wait for one). */
#define REF_POLL_STEPS 4096
#define REF_POLL_SECONDS 0.25

int reference_grow(pdla_engine *e, uint64_t n_until, pdla_progress_fn progress, uint64_t every,
                   void *user, char *err, size_t errlen)
{
    if (e->ref && e->ref->n != e->params.reference_walkers) engine_reference_free(e);
    if (!e->ref && !(e->ref = reference_make(e)))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for %d reference walkers",
                           e->params.reference_walkers);
    reference_state *const r = e->ref;
    const int n = r->n;
    walker_ctx *const ws = r->ws;
    walk_state *const st = r->st;
    unsigned char *const active = r->active;
    int rc = PDLA_OK;
    double polled = pdla_clock_seconds();
    uint64_t steps = 0;
    /* round robin from the walker whose turn it was when a stop came */
    for (int i = r->next; rc == PDLA_OK && tree_count(&e->tree) < n_until; i = i + 1 < n ? i + 1 : 0) {
        r->next = i + 1 < n ? i + 1 : 0;
        {
            walker_ctx *w = i == 0 ? &e->walker : &ws[i - 1];
            /* Launched when its turn comes: P = 1 then draws exactly as the
             * serial loop does, and no walker is launched past the target. */
            if (!active[i]) {
                walker_begin(e, w, &st[i]);
                active[i] = 1;
            }
            int64_t p[3];
            const int status = walker_step(e, w, &st[i], p);
            if (status == WALK_MOVED) {
                if (progress && ++steps % REF_POLL_STEPS == 0 && pdla_clock_seconds() - polled >= REF_POLL_SECONDS) {
                    polled = pdla_clock_seconds();
                    if (progress(e, user))
                        rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped at %llu particles",
                                         (unsigned long long)tree_count(&e->tree));
                }
                continue;
            }
            active[i] = 0;
            if (status == WALK_ENDLESS) {
                rc = pdla_errorf(PDLA_EINVAL, err, errlen, WALK_ENDLESS_FMT, WALK_ENDLESS_RESTARTS,
                                 (unsigned long long)e->params.max_jumps);
                break;
            }
            const uint64_t before = tree_count(&e->tree);
            rc = reference_insert(e, w, p, status, err, errlen);
            if (rc == PDLA_OK && progress && tree_count(&e->tree) != before &&
                tree_count(&e->tree) % every == 0 && tree_count(&e->tree) < n_until && progress(e, user)) {
                rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped at %llu particles",
                                 (unsigned long long)tree_count(&e->tree));
            }
        }
    }
    /* Stopped: the walkers stay in flight for the next call. */
    if (rc == PDLA_ESTOPPED) return rc;
    /* Counters stay cumulative in the serial walker's. */
    for (int i = 1; i < n; i++) walker_ctx_add_counts(&e->walker, &ws[i - 1]);
    /* The serial stream resumes past every walker's (as after workers):
     * 2^128 n draws after where walker 0 began, not at walker n - 1's start
     * (the next phase's walker 0 would draw that walker's numbers again). */
    if (n > 1) {
        pdla_rng stream = r->stream;
        rng_jump(&stream);
        e->walker.rng = stream;
    }
    engine_reference_free(e);
    return rc;
}
