/*
 * test_endless.c - walks that cannot end (session 26).
 *
 * A --max-jumps too small for any walk to reach the cluster (1: a jump
 * from the birth circle never ends in contact) used to be accepted, and
 * growth went on for ever: serially until a signal, with worker threads
 * even past one (a worker looked at the stop flag only between walks).
 * Now:
 *  - WALK_ENDLESS_RESTARTS launches in a row cut off by --max-jumps end
 *    growth with PDLA_EINVAL and a line naming --max-jumps, in the serial
 *    walk, the reference walkers and the workers (2D and 3D), the cluster
 *    as it was (1 particle here);
 *  - a small limit that walks can meet still grows (2D, --max-jumps 10:
 *    over 10000 restarts, no error);
 *  - a worker polls the stop flag within a walk: with the limit lifted
 *    (test_endless_restarts) its walk never ends, and a stop asked by the
 *    progress callback must still end growth (PDLA_ESTOPPED) within
 *    seconds. Without the poll this case runs until the meson timeout.
 * Each case is bounded by the clock as well, so a hang fails.
 */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "engine.h"
#include "pdla/pdla.h"

static pdla_params params_of(int dim, int threads, int refs, uint64_t max_jumps, uint64_t target)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.target = target;
    p.seed = 3;
    p.max_jumps = max_jumps;
    p.threads = threads;
    p.reference_walkers = refs;
    if (threads != 1 || refs > 0) p.serial_until = 1;
    return p;
}

static int stop_at_once(const pdla_engine *e, void *user)
{
    (void)e;
    (*(int *)user)++;
    return 1;
}

static void endless_case(int dim, int threads, int refs)
{
    const pdla_params P = params_of(dim, threads, refs, 1, 100);
    char err[512] = "";
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    if (!e) return;
    const double t0 = pdla_clock_seconds();
    const int rc = pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err);
    const double dt = pdla_clock_seconds() - t0;
    CHECK(rc == PDLA_EINVAL && strstr(err, "--max-jumps 1 jumps") && strstr(err, "raise --max-jumps"),
          "%dD threads %d refs %d, --max-jumps 1: rc %d, \"%s\" (want PDLA_EINVAL naming --max-jumps)", dim,
          threads, refs, rc, err);
    CHECK(pdla_engine_count(e) == 1, "%dD threads %d refs %d: %llu particles (want the seed alone)", dim, threads,
          refs, (unsigned long long)pdla_engine_count(e));
    CHECK(dt < 20, "%dD threads %d refs %d: %.1f s to give up", dim, threads, refs, dt);
    pdla_engine_destroy(e);
}

/* A limit walks can meet: growth completes, with restarts. */
static void small_limit_grows(void)
{
    const pdla_params P = params_of(2, 1, 0, 10, 2000);
    char err[512] = "";
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    if (!e) return;
    const int rc = pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err);
    pdla_stats s;
    pdla_engine_stats(e, &s);
    CHECK(rc == PDLA_OK && pdla_engine_count(e) == P.target, "--max-jumps 10: rc %d, %llu particles: %s", rc,
          (unsigned long long)pdla_engine_count(e), err);
    CHECK(s.restarts > 10000, "--max-jumps 10: only %llu restarts (the case should exercise them)",
          (unsigned long long)s.restarts);
    pdla_engine_destroy(e);
}

/* Workers in walks that never end: a stop must still end growth. */
static void stop_inside_endless(int dim)
{
    const pdla_params P = params_of(dim, 2, 0, 1, 100);
    char err[512] = "";
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    if (!e) return;
    e->test_endless_restarts = UINT32_MAX;
    int calls = 0;
    const double t0 = pdla_clock_seconds();
    const int rc = pdla_engine_grow(e, P.target, stop_at_once, 1000, &calls, err, sizeof err);
    const double dt = pdla_clock_seconds() - t0;
    CHECK(rc == PDLA_ESTOPPED && calls >= 1, "%dD workers in endless walks, stop asked: rc %d after %d calls (%s)",
          dim, rc, calls, err);
    CHECK(dt < 5, "%dD workers in endless walks: %.2f s to stop (want well under a second)", dim, dt);
    pdla_engine_destroy(e);
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        endless_case(dim, 1, 0);
        endless_case(dim, 1, 3);
        endless_case(dim, 2, 0);
        stop_inside_endless(dim);
    }
    small_limit_grows();
    return check_finish();
}
