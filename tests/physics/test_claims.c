/*
 * test_claims.c - no PDLA worker's jump passes through a spot another
 * worker has already chosen but not yet appended (issue 8: the bias of 16
 * workers on 16 free cores; src/dla/claims.h).
 *
 * On a 16-core machine 16 workers grew 2D clusters 2-3% more compact than
 * the race-free reference of 16 walkers while every jump was exact for the
 * cluster as published (tests/physics/exact_probe.c): between a walker's
 * decision to stick and its append (the snap, the checks, the contended
 * bucket mutex) the others moved through the spot, which in the reference
 * is taken at once (tests/physics/clock_probe.c, delayK, reproduces the
 * compaction with delayed appends alone).
 *
 * Here worker 0's insertions are made slow on purpose (after its walker has
 * chosen its spot, a hook waits until worker 1 has jumped WINDOW_JUMPS
 * times; the straggler bound is off, so the slow walkers are not
 * relaunched), 2 workers, and hooks log, with one
 * shared sequence number, every decision (worker, then the particle's
 * index at its append) and every jump (start, squared radius, count it was
 * checked against). A jump is bad if a particle not yet appended when it
 * was checked (index >= its count), whose spot had been chosen before the
 * jump's check began (sequence), lies within the jump's radius. The jump's
 * sequence number is taken when its check begins (the stall hook, before
 * the claims are read), not when it is logged: a worker descheduled
 * between its check and its log (TSan on a loaded 2-core CI machine, once
 * in session 26) was counted as jumping through a spot published while it
 * was away. The decision's number is taken after the spot is published
 * (and CLAIM_SETTLE_US later), both with acq_rel, so a check that begins
 * after it sees the spot.
 *
 *  - with the claims off (hook no_claims, the engine before the fix): bad
 *    jumps must occur, or the slow insertions do not open the window;
 *  - with the claims: none.
 * 2D and 3D; also under ThreadSanitizer (suite threads).
 */
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "engine.h"

#define WINDOW_JUMPS 1000
#define WINDOW_MAX_US 5000
#define CLAIM_SETTLE_US 5

typedef struct jump_rec {
    int64_t p[3];
    uint64_t R2, now, seq;
} jump_rec;

typedef struct log_ctx {
    int dim;
    uint64_t n;
    int64_t (*pos)[3];       /* by particle index (append hook) */
    uint64_t *decided_seq;   /* by particle index: when its spot was chosen */
    jump_rec *jumps;
    uint64_t jcap;
    _Atomic uint64_t nj, seq;
} log_ctx;

static _Thread_local uint64_t my_decided_seq = UINT64_MAX;
static _Thread_local uint64_t my_check_seq = UINT64_MAX; /* when this thread's last check began */

static double now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec / 1e3;
}

static void spin_us(double us)
{
    const double until = now_us() + us;
    while (now_us() < until) {
    }
}

static void on_decided(void *user, int id, const int64_t *p)
{
    log_ctx *c = user;
    (void)p;
    spin_us(CLAIM_SETTLE_US);
    my_decided_seq = atomic_fetch_add_explicit(&c->seq, 1, memory_order_acq_rel);
    if (id != 0) return;
    /* Worker 0 waits until worker 1 has jumped WINDOW_JUMPS times (or
     * WINDOW_MAX_US have passed: with the claims, worker 1 may be waiting
     * for this very spot), yielding the CPU, so that the window opens on
     * a loaded machine too. */
    const uint64_t from = atomic_load_explicit(&c->nj, memory_order_relaxed);
    const double t0 = now_us();
    while (atomic_load_explicit(&c->nj, memory_order_relaxed) - from < WINDOW_JUMPS &&
           now_us() - t0 < WINDOW_MAX_US)
        sched_yield();
}

static void on_append(void *user, uint64_t index, const int64_t *p)
{
    log_ctx *c = user;
    if (index >= c->n) return;
    for (int a = 0; a < 3; a++) c->pos[index][a] = a < c->dim ? p[a] : 0;
    c->decided_seq[index] = my_decided_seq;
}

/* walk_stale's first call, before it reads the claims */
static void on_check(void *user)
{
    log_ctx *c = user;
    my_check_seq = atomic_fetch_add_explicit(&c->seq, 1, memory_order_acq_rel);
}

static void on_jump(void *user, const int64_t *p, uint64_t R2, uint64_t now)
{
    log_ctx *c = user;
    const uint64_t s = my_check_seq;
    const uint64_t j = atomic_fetch_add_explicit(&c->nj, 1, memory_order_relaxed);
    if (j >= c->jcap) return;
    jump_rec *r = &c->jumps[j];
    for (int a = 0; a < 3; a++) r->p[a] = a < c->dim ? p[a] : 0;
    r->R2 = R2;
    r->now = now;
    r->seq = s;
}

typedef struct outcome {
    uint64_t jumps, bad, waits, particles;
} outcome;

static outcome run(int dim, int no_claims, uint64_t seed)
{
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = dim == 2 ? 15000 : 8000;
    P.serial_until = dim == 2 ? 2000 : 1000;
    P.threads = 2;
    P.seed = seed;
    P.rg_per_decade = 0;
    log_ctx c = {.dim = dim, .n = P.target};
    c.pos = calloc(c.n, sizeof *c.pos);
    c.decided_seq = malloc(c.n * sizeof *c.decided_seq);
    for (uint64_t i = 0; i < c.n; i++) c.decided_seq[i] = UINT64_MAX;
    c.jcap = 400 * c.n;
    c.jumps = malloc(c.jcap * sizeof *c.jumps);
    atomic_init(&c.nj, 0);
    atomic_init(&c.seq, 0);
    engine_hooks h = {.decided = on_decided, .append = on_append, .jump = on_jump, .stall = on_check,
                      .no_claims = no_claims, .no_relaunch = 1, .user = &c};
    pdla_engine *e;
    char err[256];
    outcome o = {0, 0, 0, 0};
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    e->hooks = &h;
    CHECK(pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "grow: %s", err);
    pdla_stats s;
    pdla_engine_stats(e, &s);
    uint64_t nj = atomic_load(&c.nj);
    if (nj > c.jcap) nj = c.jcap;
    for (uint64_t j = 0; j < nj; j++) {
        const jump_rec *r = &c.jumps[j];
        /* The particles appended after the jump's check: at most a few
         * were chosen before it (2 workers, one spot each). */
        for (uint64_t i = r->now; i < c.n && i < r->now + 64; i++) {
            if (c.decided_seq[i] == UINT64_MAX || c.decided_seq[i] > r->seq) continue;
            uint64_t d2 = 0;
            for (int a = 0; a < dim; a++) {
                const int64_t d = r->p[a] - c.pos[i][a];
                d2 += (uint64_t)(d * d);
            }
            if (d2 < r->R2) {
                o.bad++;
                break;
            }
        }
    }
    o.jumps = nj;
    o.waits = s.claim_waits;
    o.particles = s.particles;
    pdla_engine_destroy(e);
    free(c.pos);
    free(c.decided_seq);
    free(c.jumps);
    return o;
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        const outcome before = run(dim, 1, 21);
        const outcome after = run(dim, 0, 21);
        fprintf(stderr,
                "%dD: claims off: %llu of %llu jumps through a chosen spot; with claims: %llu of "
                "%llu (%llu moves waited for a spot)\n",
                dim, (unsigned long long)before.bad, (unsigned long long)before.jumps,
                (unsigned long long)after.bad, (unsigned long long)after.jumps,
                (unsigned long long)after.waits);
        CHECK(before.particles == after.particles, "both runs reach the target");
        CHECK(before.jumps > 10000 && after.jumps > 10000, "%dD: enough jumps checked", dim);
        CHECK(before.bad >= 5, "%dD: the slow insertions open the window (%llu bad jumps)", dim,
              (unsigned long long)before.bad);
        CHECK(after.bad == 0, "%dD: %llu jumps through a chosen spot with claims", dim,
              (unsigned long long)after.bad);
        CHECK(after.waits > 0, "%dD: walkers waited for chosen spots", dim);
    }
    return check_finish();
}
