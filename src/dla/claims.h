/*
 * claims.h - spots that PDLA workers have chosen but not yet appended
 * (issue 8: the bias of 16 workers on 16 free cores).
 *
 * Why: a worker's walker decides to stick when its query finds contact, but
 * its particle becomes visible to the others only at the append, after the
 * snap, the lock-free checks and the bucket mutex (which 16 workers contend
 * for: half the acquisitions wait, microseconds each). Meanwhile the other
 * walkers take hundreds of steps in a cluster without that particle: they
 * pass through a spot that is already taken and stick deeper. On a 16-core
 * machine that made 2D clusters 2-3% more compact than the race-free
 * reference of 16 walkers (where deciding and appending are one step),
 * with every jump exact for the cluster as published
 * (runs/bench-threads-16core/session24/README.md).
 *
 * So a worker publishes its spot here as soon as it has decided, and every
 * other worker's jump (and return to the birth circle) is checked against
 * the published spots as it is against the ring of recent particles: a
 * spot inside the jump's ball (widened by the spot's margin, which covers
 * the snap still to come) makes the walker wait until the spot is appended
 * or given up, and then query again, now seeing it. Deciding and appending
 * then look like one step to the others, as in the reference.
 *
 * One slot per worker (a seqlock: seq odd while the slot is written) and a
 * flag byte per worker, packed, so that the common check (no spot
 * published) reads one cache line for up to 64 workers. Only the owner
 * writes its slot and flag; readers never write.
 *
 * Cost: 2D 2 workers from 1e5 to 1e6 on the 2-core VM, the parallel phase
 * takes 1.07-1.28x as long (five alternated pairs; serial runs unchanged;
 * runs/bench-threads-16core/session24/claims-cost-2core.txt): the others'
 * flags and slots are read before every jump and change twice a walk, so
 * they miss the cache. Not yet measured on 16 cores. claims_any reads n
 * bytes (n / 64 cache lines) per jump: one line up to 64 workers, 16 at
 * 1024 (the --threads limit; not measured beyond 16 workers).
 */
#ifndef PDLA_SRC_CLAIMS_H
#define PDLA_SRC_CLAIMS_H
#include <stdatomic.h>
#include <stdint.h>

#include "tree.h"

typedef struct claim_slot {
    _Atomic uint32_t seq;    /* even: stable; odd: being written */
    _Atomic int32_t x[3];    /* the spot, units */
    _Atomic int32_t margin;  /* how far (units) the particle may still move */
    uint32_t pad_[11];       /* one slot per cache line: owners write apart */
} claim_slot;

typedef struct claim_board {
    int n;                   /* workers (slots) */
    /* flag[i]: worker i has a spot published. One byte per worker, packed
     * (64 workers a cache line), each stored by its owner alone: plain
     * stores, which the owner does not wait for, where a shared mask's
     * read-modify-writes cost 2D 2 workers about 10% of their CPU time
     * (runs/bench-threads-16core/session24). */
    _Atomic uint8_t *flag;
    claim_slot *slot;
} claim_board;

/* How far a spot may still move once published: the snap onto contact
 * moves it by at most D + eps, and its rounding by a unit on each side.
 * The one definition for the walker (at the decision) and the insertion
 * (at a republish after an overlap). */
static inline int64_t claims_margin(int64_t resolution, int64_t eps)
{
    return resolution + eps + 2;
}

/* 0, or -1 when out of memory. */
int claims_init(claim_board *b, int n);
void claims_free(claim_board *b);

/* Worker `i` publishes (or moves) its spot p, which may still move by up to
 * `margin` units before it is appended. */
void claims_publish(claim_board *b, int i, const int64_t *p, int dim, int64_t margin);

/* Worker `i` has appended its particle (after the count that publishes it)
 * or given the spot up. */
void claims_withdraw(claim_board *b, int i);

/* Lock-free, by worker `self` (excluded) before a move: 1 if another
 * worker's spot lies within sqrt(R2) (plus the spot's margin and one unit)
 * of p (what = RECENT_NEAR: a jump's ball), or beyond sqrt(R2) from the
 * origin less its margin (RECENT_FAR: outside the R_ext a return was drawn
 * from); then *owner is that worker and *seq the slot's sequence seen, for
 * claims_wait. Call it before reading the count for the ring check: a
 * withdrawal seen here is then followed by the count that covers the
 * appended particle. */
int claims_block(const claim_board *b, int self, const int64_t *p, uint64_t R2, int what, int dim,
                 int *owner, uint32_t *seq);

/* Lock-free: whether any worker but `self` has a spot published (n byte
 * loads from n / 64 cache lines), so that claims_block is called only then. The
 * acquire pairs with claims_withdraw's release, as claims_block's does. */
static inline int claims_any(const claim_board *b, int self)
{
    for (int i = 0; i < b->n; i++)
        if (i != self && atomic_load_explicit(&b->flag[i], memory_order_acquire)) return 1;
    return 0;
}

/* Wait (spinning, then yielding the CPU) until worker `owner`'s slot has
 * changed from sequence `seq` or its spot is withdrawn. */
void claims_wait(const claim_board *b, int owner, uint32_t seq);
#endif
