/*
 * recent.h - the positions of the particles appended most recently, by
 * insertion index, for the PDLA insertion check (parallel.c).
 *
 * A worker checks its spot against the live tree without a lock, having
 * first read the particle count `seen` (every particle below it is then
 * visible to that search), and under the bucket mutex only against the
 * particles appended since: a handful of entries instead of a tree search
 * inside the one critical section every insertion passes through. The
 * positions are written and read under the bucket mutex only.
 */
#ifndef PDLA_SRC_RECENT_H
#define PDLA_SRC_RECENT_H
#include <stdint.h>

#include "tree.h"

typedef struct recent_ring {
    uint32_t cap;     /* positions kept: particle i in slot i mod cap */
    int32_t (*pos)[3];
} recent_ring;

/* 0, or -1 when out of memory. */
int recent_init(recent_ring *r, uint32_t cap);
void recent_free(recent_ring *r);

/* Record particle number `index` (0-based insertion order) at p. */
static inline void recent_put(recent_ring *r, uint64_t index, const int64_t *p, int dim)
{
    int32_t *x = r->pos[index % r->cap];
    for (int a = 0; a < 3; a++) x[a] = a < dim ? (int32_t)p[a] : 0;
}

/* 1 if one of the particles seen..tree_count(t) - 1 lies closer than
 * sqrt(D2) to p. When the ring no longer holds them all, the answer comes
 * from an exact search of the whole tree (which also covers the older ones,
 * already known to be clear of p). */
int recent_overlap(const recent_ring *r, const tree *t, uint64_t seen, const int64_t *p,
                   uint64_t D2);
#endif
