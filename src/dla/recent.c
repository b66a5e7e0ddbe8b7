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
    return r->pos ? 0 : -1;
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
    for (uint64_t i = seen; i < now; i++) {
        const int32_t *x = r->pos[i % r->cap];
        uint64_t d2 = 0;
        for (int a = 0; a < t->dim; a++) {
            const int64_t d = p[a] - x[a];
            d2 += (uint64_t)(d * d);
        }
        if (d2 < D2) return 1;
    }
    return 0;
}
