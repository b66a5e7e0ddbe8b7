/*
 * claims.c - spots that PDLA workers have chosen but not yet appended
 * (see claims.h).
 */
#include "claims.h"
#include "recent.h"

#include <math.h>
#include <sched.h>
#include <stdlib.h>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

int claims_init(claim_board *b, int n)
{
    b->n = n;
    /* The flags on cache lines of their own: every worker writes its flag
     * twice a walk and reads all before every jump. */
    b->flag = aligned_alloc(64, ((size_t)n + 63) / 64 * 64);
    b->slot = aligned_alloc(64, sizeof *b->slot * (size_t)n);
    if (!b->flag || !b->slot) {
        claims_free(b);
        return -1;
    }
    for (int i = 0; i < n; i++) atomic_init(&b->flag[i], 0);
    for (int i = 0; i < n; i++) {
        atomic_init(&b->slot[i].seq, 0);
        for (int a = 0; a < 3; a++) atomic_init(&b->slot[i].x[a], 0);
        atomic_init(&b->slot[i].margin, 0);
    }
    return 0;
}

void claims_free(claim_board *b)
{
    free(b->flag);
    free(b->slot);
    b->flag = NULL;
    b->slot = NULL;
}

void claims_publish(claim_board *b, int i, const int64_t *p, int dim, int64_t margin)
{
    claim_slot *s = &b->slot[i];
    const uint32_t q = atomic_load_explicit(&s->seq, memory_order_relaxed);
    /* Seqlock write: odd while the position changes. The fence keeps the
     * stores below after the odd sequence for a reader that sees them. */
    atomic_store_explicit(&s->seq, q + 1, memory_order_relaxed);
    atomic_thread_fence(memory_order_release);
    for (int a = 0; a < 3; a++)
        atomic_store_explicit(&s->x[a], a < dim ? (int32_t)p[a] : 0, memory_order_relaxed);
    atomic_store_explicit(&s->margin, (int32_t)margin, memory_order_relaxed);
    atomic_store_explicit(&s->seq, q + 2, memory_order_release);
    if (!atomic_load_explicit(&b->flag[i], memory_order_relaxed))
        atomic_store_explicit(&b->flag[i], 1, memory_order_release);
}

void claims_withdraw(claim_board *b, int i)
{
    claim_slot *s = &b->slot[i];
    /* Only the owner writes its flag and slot. */
    if (!atomic_load_explicit(&b->flag[i], memory_order_relaxed)) return;
    /* The sequence moves on too, so a reader waiting on this slot wakes
     * even if the worker publishes again before it looks at the flag. */
    atomic_store_explicit(&s->seq, atomic_load_explicit(&s->seq, memory_order_relaxed) + 2,
                          memory_order_release);
    atomic_store_explicit(&b->flag[i], 0, memory_order_release);
}

/* Whether slot j's spot blocks the move; 1 also when the slot is being
 * written (the reader cannot tell where it is). *seq: the sequence read. */
static int slot_blocks(const claim_slot *s, const int64_t *p, double R, int what, int dim,
                       uint32_t *seq)
{
    const uint32_t q = atomic_load_explicit(&s->seq, memory_order_acquire);
    *seq = q;
    if (q & 1) return 1;
    int64_t x[3];
    for (int a = 0; a < 3; a++) x[a] = atomic_load_explicit(&s->x[a], memory_order_relaxed);
    const double m = (double)atomic_load_explicit(&s->margin, memory_order_relaxed) + 1.0;
    atomic_thread_fence(memory_order_acquire);
    if (atomic_load_explicit(&s->seq, memory_order_relaxed) != q) return 1;
    double d2 = 0;
    for (int a = 0; a < dim; a++) {
        const double d = (double)(what == RECENT_NEAR ? p[a] - x[a] : x[a]);
        d2 += d * d;
    }
    const double d = sqrt(d2);
    return what == RECENT_NEAR ? d < R + m : d + m > R;
}

int claims_block(const claim_board *b, int self, const int64_t *p, uint64_t R2, int what, int dim,
                 int *owner, uint32_t *seq)
{
    double R = -1.0; /* computed at the first spot to look at */
    for (int j = 0; j < b->n; j++) {
        if (j == self || !atomic_load_explicit(&b->flag[j], memory_order_acquire)) continue;
        if (R < 0) R = sqrt((double)R2);
        if (slot_blocks(&b->slot[j], p, R, what, dim, seq)) {
            *owner = j;
            return 1;
        }
    }
    return 0;
}

void claims_wait(const claim_board *b, int owner, uint32_t seq)
{
    for (unsigned spin = 0;; spin++) {
        if (!atomic_load_explicit(&b->flag[owner], memory_order_acquire)) return;
        if (atomic_load_explicit(&b->slot[owner].seq, memory_order_acquire) != seq) return;
        /* The owner is inserting (a few hundred ns to a few us); on an
         * oversubscribed machine it may not be running at all. */
        if (spin < 256) {
#if defined(__x86_64__)
            _mm_pause();
#endif
        } else {
            sched_yield();
        }
    }
}
