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
    const int rc = engine_add_particle(e, p, err, errlen);
    if (rc == PDLA_OK && continued) w->recheck_continued++;
    if (rc == PDLA_OK) walker_note_lag(w, index);
    return rc;
}

int reference_grow(pdla_engine *e, uint64_t n_until, pdla_progress_fn progress, uint64_t every,
                   void *user, char *err, size_t errlen)
{
    const int n = e->params.reference_walkers;
    walker_ctx *ws = n > 1 ? calloc((size_t)n - 1, sizeof *ws) : NULL;
    walk_state *st = calloc((size_t)n, sizeof *st);
    unsigned char *active = calloc((size_t)n, 1);
    if ((n > 1 && !ws) || !st || !active) {
        free(ws);
        free(st);
        free(active);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for %d reference walkers", n);
    }
    pdla_rng stream = e->walker.rng;
    for (int i = 1; i < n; i++) {
        rng_jump(&stream);
        ws[i - 1].rng = stream;
        search_state_reset(&ws[i - 1].ss);
    }
    int rc = PDLA_OK;
    while (rc == PDLA_OK && tree_count(&e->tree) < n_until) {
        for (int i = 0; i < n && rc == PDLA_OK && tree_count(&e->tree) < n_until; i++) {
            walker_ctx *w = i == 0 ? &e->walker : &ws[i - 1];
            /* Launched when its turn comes: P = 1 then draws exactly as the
             * serial loop does, and no walker is launched past the target. */
            if (!active[i]) {
                walker_begin(e, w, &st[i]);
                active[i] = 1;
            }
            int64_t p[3];
            const int status = walker_step(e, w, &st[i], p);
            if (status == WALK_MOVED) continue;
            active[i] = 0;
            const uint64_t before = tree_count(&e->tree);
            rc = reference_insert(e, w, p, status, err, errlen);
            if (rc == PDLA_OK && progress && tree_count(&e->tree) != before &&
                tree_count(&e->tree) % every == 0 && tree_count(&e->tree) < n_until && progress(e, user)) {
                rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped at %llu particles",
                                 (unsigned long long)tree_count(&e->tree));
            }
        }
    }
    /* Counters stay cumulative in the serial walker's; walkers still in
     * flight are dropped, as workers' are. */
    for (int i = 1; i < n; i++) walker_ctx_add_counts(&e->walker, &ws[i - 1]);
    /* The serial stream resumes past every walker's (as after workers):
     * 2^128 n draws after where walker 0 began, not at walker n - 1's start
     * (the next phase's walker 0 would draw that walker's numbers again). */
    if (n > 1) {
        rng_jump(&stream);
        e->walker.rng = stream;
    }
    free(ws);
    free(st);
    free(active);
    return rc;
}
