/*
 * test_stale.c - every jump a PDLA worker takes is exact for the cluster as
 * it is when the jump is taken (issue 11), checked independently of the
 * engine's own stale-read check.
 *
 * Test hooks (src/engine.h) make a walker sleep now and then between its
 * distance query and its jump, the race an oversubscribed machine makes
 * (16 workers on 2 cores), log every particle as it is appended (index and
 * position, before the count publishes it), and report every jump with the
 * count `now` it is valid for and the squared radius R2 it needs clear. The
 * test then checks by brute force that none of the last WINDOW particles
 * below `now` lies within sqrt(R2) of the jump's start: such a jump would
 * pass through (or land inside) a particle. Older particles are the searches'
 * business (tests/unit); a stale read concerns the particles appended while
 * the walker waited, a few dozen at most here.
 *
 * Two runs with the same stalls:
 *  - take_stale = 1 (the engine before the fix: stale jumps are counted but
 *    taken): bad jumps must occur, or the stalls do not reproduce the race
 *    and the second run would prove nothing;
 *  - the engine as shipped: no bad jump, and stale reads were caught.
 * 2D and 3D. Runs under ThreadSanitizer (suite threads): the log is written
 * before the count's release store and read after an acquire load of it.
 */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "engine.h"

#define WINDOW 512

typedef struct log_ctx {
    int64_t (*pos)[3];       /* by particle index; written in the append hook */
    uint64_t cap;
    uint64_t first;          /* first index appended by workers */
    int dim;
    _Atomic uint64_t calls;  /* stall hook calls */
    _Atomic uint64_t jumps, bad;
} log_ctx;

static void on_stall(void *user)
{
    log_ctx *c = user;
    /* One query in 16 waits 0.2 ms: dozens of particles are appended meanwhile. */
    if (atomic_fetch_add_explicit(&c->calls, 1, memory_order_relaxed) % 16 == 0) {
        struct timespec ts = {0, 200000};
        nanosleep(&ts, NULL);
    }
}

static void on_append(void *user, uint64_t index, const int64_t *p)
{
    log_ctx *c = user;
    if (index < c->cap)
        for (int a = 0; a < 3; a++) c->pos[index][a] = a < c->dim ? p[a] : 0;
}

static void on_jump(void *user, const int64_t *p, uint64_t R2, uint64_t now)
{
    log_ctx *c = user;
    atomic_fetch_add_explicit(&c->jumps, 1, memory_order_relaxed);
    uint64_t from = now > WINDOW ? now - WINDOW : 0;
    if (from < c->first) from = c->first;
    for (uint64_t i = from; i < now && i < c->cap; i++) {
        uint64_t d2 = 0;
        for (int a = 0; a < c->dim; a++) {
            const int64_t d = p[a] - c->pos[i][a];
            d2 += (uint64_t)(d * d);
        }
        if (d2 < R2) {
            atomic_fetch_add_explicit(&c->bad, 1, memory_order_relaxed);
            return;
        }
    }
}

typedef struct outcome {
    uint64_t jumps, bad, stale_jumps, particles;
} outcome;

static outcome run(int dim, int take_stale, uint64_t seed)
{
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = dim == 2 ? 3000 : 2000;
    P.serial_until = 300;
    P.threads = 8;
    P.seed = seed;
    P.rg_per_decade = 0;
    log_ctx c = {.cap = P.target, .first = P.serial_until, .dim = dim};
    c.pos = calloc(c.cap, sizeof *c.pos);
    atomic_init(&c.calls, 0);
    atomic_init(&c.jumps, 0);
    atomic_init(&c.bad, 0);
    engine_hooks h = {.stall = on_stall, .jump = on_jump, .append = on_append,
                      .take_stale = take_stale, .user = &c};
    pdla_engine *e;
    char err[256];
    outcome o = {0, 0, 0, 0};
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    e->hooks = &h;
    const int rc = pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err);
    CHECK(rc == PDLA_OK, "grow: %s", err);
    pdla_stats s;
    pdla_engine_stats(e, &s);
    o.jumps = atomic_load(&c.jumps);
    o.bad = atomic_load(&c.bad);
    o.stale_jumps = s.stale_jumps;
    o.particles = s.particles;
    pdla_engine_destroy(e);
    free(c.pos);
    return o;
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        const outcome before = run(dim, 1, 11);
        const outcome after = run(dim, 0, 11);
        fprintf(stderr,
                "%dD: stale jumps taken: %llu of %llu checked jumps through a particle "
                "(%llu stale reads); with the check: %llu of %llu (%llu stale reads caught)\n",
                dim, (unsigned long long)before.bad, (unsigned long long)before.jumps,
                (unsigned long long)before.stale_jumps, (unsigned long long)after.bad,
                (unsigned long long)after.jumps, (unsigned long long)after.stale_jumps);
        CHECK(before.particles == after.particles, "both runs reach the target");
        CHECK(before.jumps > 10000 && after.jumps > 10000, "%dD: enough jumps checked", dim);
        CHECK(before.bad > 0, "%dD: the stalls reproduce jumps through new particles", dim);
        CHECK(before.stale_jumps >= before.bad, "%dD: the engine's count of stale jumps covers them",
              dim);
        CHECK(after.bad == 0, "%dD: %llu jumps through a particle with the check on", dim,
              (unsigned long long)after.bad);
        CHECK(after.stale_jumps > 0, "%dD: stale reads happened and were caught", dim);
    }
    return check_finish();
}
