/*
 * test_straggler.c - the straggler bound (issue 11, parallel.c): a worker's
 * walker that finds more than PDLA_STRAGGLER_FACTOR x workers particles
 * appended since its own last step is relaunched from the birth circle, so
 * no walker frozen in flight sticks long after its walk was drawn.
 *
 * Test hooks freeze worker 1 now and then at the start of a turn (before a
 * step or a launch) until the other worker has appended FREEZE particles,
 * the straggler an oversubscribed machine makes (a worker descheduled while
 * another runs). Two runs with the same freezes:
 *  - without the bound (hooks.no_relaunch): walkers frozen in flight stick
 *    with a lag (particles appended while they flew) of at least FREEZE, or
 *    the freezes reproduce nothing and the second run proves nothing;
 *  - with it: walkers were relaunched, at least one per freeze that caught a
 *    walk in flight, and lags of FREEZE or more all but vanish (a lag that
 *    large then needs FREEZE / 16 consecutive steps each just under the
 *    bound of 16).
 * 2D and 3D. Runs under ThreadSanitizer (suite threads): the hooks read the
 * count with the engine's own acquire load.
 */
#include <stdatomic.h>
#include <stdlib.h>
#include <time.h>

#include "check.h"
#include "engine.h"

#define FREEZE 64   /* particles the other worker appends during a freeze */
#define EVERY 1500  /* worker 1 freezes at one turn in EVERY */

typedef struct freezer {
    const pdla_engine *e;
    uint64_t target;
    uint64_t turns;  /* worker 1's turns (only worker 1 touches it) */
    _Atomic uint64_t freezes;
} freezer;

static void turn_begin(void *user, int id)
{
    freezer *f = user;
    if (id != 1 || ++f->turns % EVERY) return;
    const uint64_t c0 = pdla_engine_count(f->e);
    /* Near the target worker 0 stops: do not wait for it then. */
    if (c0 + FREEZE + 1 >= f->target) return;
    atomic_fetch_add_explicit(&f->freezes, 1, memory_order_relaxed);
    const struct timespec ts = {0, 20000};
    for (int i = 0; i < 100000 && pdla_engine_count(f->e) < c0 + FREEZE; i++) nanosleep(&ts, NULL);
}

static void turn_end(void *user, int id)
{
    (void)user;
    (void)id;
}

typedef struct outcome {
    uint64_t particles, relaunches, freezes, far; /* far: particles with lag >= FREEZE */
} outcome;

static outcome run(int dim, int bound, uint64_t seed)
{
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = dim == 2 ? 20000 : 8000;
    P.serial_until = dim == 2 ? 2000 : 1000;
    P.threads = 2;
    P.seed = seed;
    P.rg_per_decade = 0;
    pdla_engine *e;
    char err[256];
    outcome o = {0, 0, 0, 0};
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    freezer f = {.e = e, .target = P.target, .turns = 0};
    atomic_init(&f.freezes, 0);
    engine_hooks h = {.turn_begin = turn_begin, .turn_end = turn_end, .no_relaunch = !bound,
                      .user = &f};
    e->hooks = &h;
    CHECK(pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "grow: %s", err);
    pdla_stats s;
    pdla_engine_stats(e, &s);
    o.particles = s.particles;
    o.relaunches = s.relaunches;
    o.freezes = atomic_load(&f.freezes);
    /* lag_hist[k]: 2^(k-1) <= lag < 2^k; FREEZE = 2^6 starts bin 7 */
    for (int k = 7; k < PDLA_LAG_BINS; k++) o.far += s.lag_hist[k];
    pdla_engine_destroy(e);
    return o;
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        const outcome off = run(dim, 0, 21);
        const outcome on = run(dim, 1, 21);
        fprintf(stderr,
                "%dD: without the bound %llu freezes, %llu particles with lag >= %d, %llu relaunches;"
                " with it %llu freezes, %llu with lag >= %d, %llu relaunches\n",
                dim, (unsigned long long)off.freezes, (unsigned long long)off.far, FREEZE,
                (unsigned long long)off.relaunches, (unsigned long long)on.freezes,
                (unsigned long long)on.far, FREEZE, (unsigned long long)on.relaunches);
        CHECK(off.particles == on.particles && on.particles == (dim == 2 ? 20000u : 8000u),
              "%dD: both runs reach the target", dim);
        CHECK(off.freezes >= 5 && on.freezes >= 5, "%dD: worker 1 was frozen", dim);
        CHECK(off.relaunches == 0, "%dD: no relaunch without the bound", dim);
        CHECK(off.far >= off.freezes / 2, "%dD: the freezes make stragglers (%llu of %llu)", dim,
              (unsigned long long)off.far, (unsigned long long)off.freezes);
        /* Most freezes catch a walk in flight (a walk is dozens of turns);
         * the OS may add relaunches of its own on a busy machine. */
        CHECK(on.relaunches >= on.freezes / 2, "%dD: walkers frozen in flight were relaunched", dim);
        CHECK(on.far * 10 <= off.far, "%dD: the bound removes the stragglers", dim);
    }
    return check_finish();
}
