/*
 * recent.c - the ring of recently appended particles (see recent.h).
 */
#include "recent.h"
#include "search.h"

#include <stdlib.h>

int recent_init(recent_ring *r, uint32_t cap)
{
    r->cap = cap ? cap : 1;
    r->pos = calloc(r->cap, sizeof *r->pos);
    if (!r->pos) return -1;
    for (uint32_t i = 0; i < r->cap; i++) atomic_init(&r->pos[i].tag, RECENT_WRITING);
    return 0;
}

void recent_free(recent_ring *r)
{
    free(r->pos);
    r->pos = NULL;
}

int recent_overlap(const recent_ring *r, const tree *t, uint64_t seen, const int64_t *p,
                   uint64_t D2)
{
    const uint64_t now = atomic_load_explicit(&t->count, memory_order_relaxed);
    if (now - seen > r->cap) {
        int64_t q[3];
        uint64_t d2;
        return search_nearest_point(t, p, D2, q, &d2);
    }
    /* Under the bucket mutex: no slot is being written. */
    for (uint64_t i = seen; i < now; i++) {
        const recent_slot *s = &r->pos[i % r->cap];
        uint64_t d2 = 0;
        for (int a = 0; a < t->dim; a++) {
            const int64_t d = p[a] - atomic_load_explicit(&s->x[a], memory_order_relaxed);
            d2 += (uint64_t)(d * d);
        }
        if (d2 < D2) return 1;
    }
    return 0;
}

int recent_stale(const recent_ring *r, const tree *t, uint64_t seen, const int64_t *p,
                 uint64_t R2, int what, uint64_t *now_out)
{
    const uint64_t now = tree_count(t);
    *now_out = now;
    if (now == seen) return 0;
    /* Half the ring: room for the appends that go on while we read. */
    if (now - seen > r->cap / 2) return 1;
    for (uint64_t i = seen; i < now; i++) {
        recent_slot *s = &r->pos[i % r->cap];
        if (atomic_load_explicit(&s->tag, memory_order_acquire) != i) return 1;
        int64_t x[3];
        for (int a = 0; a < t->dim; a++) x[a] = atomic_load_explicit(&s->x[a], memory_order_acquire);
        /* A position store we read happened after the tag was cleared: if
         * the slot was reused, this load sees it. */
        if (atomic_load_explicit(&s->tag, memory_order_relaxed) != i) return 1;
        uint64_t d2 = 0;
        for (int a = 0; a < t->dim; a++) {
            const int64_t d = p[a] - x[a];
            d2 += (uint64_t)(d * d);
        }
        if (what == RECENT_NEAR ? d2 < R2 : d2 > R2) return 1;
    }
    return 0;
}
