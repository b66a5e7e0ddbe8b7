/*
 * recent.h - the positions of the particles appended most recently, by
 * insertion index, for the PDLA insertion check (parallel.c).
 *
 * A worker checks its spot against the live tree without a lock, having
 * first read the particle count `seen` (every particle below it is then
 * visible to that search), and under the bucket mutex only against the
 * particles appended since: a handful of entries instead of a tree search
 * inside the one critical section every insertion passes through.
 *
 * Walkers also read the ring without a lock, between a distance query and
 * the jump it bounds (recent_stale): a jump is taken only if no particle
 * appended since the query lies inside its ball. Each slot is a small
 * seqlock: its tag is the particle's index, set to RECENT_WRITING while the
 * position is rewritten, so a reader knows when a slot it read was being
 * reused. The writer (under the bucket mutex) fills the slot before it
 * publishes the particle count, so every index below a count a reader
 * acquired is in the ring or has been overwritten by a later one.
 */
#ifndef PDLA_SRC_RECENT_H
#define PDLA_SRC_RECENT_H
#include <stdint.h>

#include "tree.h"

#include <stdatomic.h>

#define RECENT_WRITING UINT64_MAX

typedef struct recent_slot {
    _Atomic uint64_t tag;  /* index of the particle held, or RECENT_WRITING */
    _Atomic int32_t x[3];
} recent_slot;

typedef struct recent_ring {
    uint32_t cap;     /* positions kept: particle i in slot i mod cap */
    recent_slot *pos;
} recent_ring;

/* 0, or -1 when out of memory. */
int recent_init(recent_ring *r, uint32_t cap);
void recent_free(recent_ring *r);

/* Record particle number `index` (0-based insertion order) at p; before the
 * count that publishes it is raised. One writer at a time (bucket mutex).
 * The position stores are release stores: a reader whose load sees one of
 * them then sees the RECENT_WRITING tag (or a later one) too. */
static inline void recent_put(recent_ring *r, uint64_t index, const int64_t *p, int dim)
{
    recent_slot *s = &r->pos[index % r->cap];
    atomic_store_explicit(&s->tag, RECENT_WRITING, memory_order_relaxed);
    for (int a = 0; a < 3; a++)
        atomic_store_explicit(&s->x[a], a < dim ? (int32_t)p[a] : 0, memory_order_release);
    atomic_store_explicit(&s->tag, index, memory_order_release);
}

/* 1 if one of the particles seen..tree_count(t) - 1 lies closer than
 * sqrt(D2) to p. When the ring no longer holds them all, the answer comes
 * from an exact search of the whole tree (which also covers the older ones,
 * already known to be clear of p). */
int recent_overlap(const recent_ring *r, const tree *t, uint64_t seen, const int64_t *p,
                   uint64_t D2);

/* What recent_stale looks for among the particles appended since `seen`. */
enum {
    RECENT_NEAR = 0, /* one closer than sqrt(R2) to p (inside a jump's ball) */
    RECENT_FAR = 1   /* one farther than sqrt(R2) from p (beyond a stale R_ext) */
};

/* Lock-free (any thread, any time): 0 if no particle appended since `seen`
 * (the count acquired before the query) is NEAR / FAR as `what` says; 1 if
 * one is, or if the ring cannot tell (a slot reused meanwhile, or more
 * particles appended than it holds), when the caller queries again, which
 * is always correct. The common case, nothing appended since, is one load.
 * *now: the count it checked up to (the answer 0 holds for particles
 * 0..*now - 1). */
int recent_stale(const recent_ring *r, const tree *t, uint64_t seen, const int64_t *p,
                 uint64_t R2, int what, uint64_t *now);
#endif
