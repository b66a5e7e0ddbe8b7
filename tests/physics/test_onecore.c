/*
 * test_onecore.c - the threaded engine's law on any machine (issue 11):
 * PDLA workers all confined to one CPU, paired against serial DLA.
 *
 *   test_onecore M N SERIAL_UNTIL THREADS TOL [bound-off | node-before-bucket]
 *
 * The test process is pinned to one CPU of its allowed set before the
 * engine starts its workers, which inherit the mask: the THREADS workers
 * then only time-slice, never run at once, and their growth is DLA (no two
 * walkers are in flight together, except that one descheduled mid-walk
 * waits while the others grow; the straggler bound relaunches it). Each of
 * M seeds (1001 ...) grows the same serial prefix of SERIAL_UNTIL particles
 * in both arms, then on to N serially and with THREADS workers (2D). The
 * mean over seeds of R_g(workers) / R_g(serial) - 1 must be within TOL (a
 * fraction) and its standard error at most TOL / 3, so that both 0 and a
 * bias of 2 TOL are at least 3 standard errors from the tolerance. Every
 * worker insertion checks (test hook) that it ran on the chosen CPU.
 *
 * The scheduler decides the interleaving, so the workers' clusters differ
 * between runs; only the statistic decides pass or fail.
 *
 * The optional last argument removes a protection for the workers' arm
 * (test hooks, engine.h), to show what the statistic sees without it:
 * bound-off (no straggler bound: a walker descheduled mid-walk sticks
 * after the others appended a time slice's worth of particles) or
 * node-before-bucket (node work outside the bucket mutex, the order before
 * issue 11's fix).
 */
#define _GNU_SOURCE
#include <math.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine.h"
#include "paired.h"

typedef struct onecore {
    int cpu;                  /* the CPU every worker must run on */
    _Atomic uint64_t elsewhere; /* insertions seen on another CPU */
} onecore;

static void on_inserted(void *user, uint64_t index, const int64_t *p, uint64_t lag)
{
    (void)index, (void)p, (void)lag;
    onecore *o = user;
    if (sched_getcpu() != o->cpu) atomic_fetch_add_explicit(&o->elsewhere, 1, memory_order_relaxed);
}

/* Pin this thread (and so the workers it starts) to one allowed CPU: the
 * one it runs on now if allowed. Returns the CPU, or -1 with a message. */
static int pin_one_cpu(void)
{
    cpu_set_t allowed;
    if (sched_getaffinity(0, sizeof allowed, &allowed)) {
        perror("sched_getaffinity");
        return -1;
    }
    int cpu = sched_getcpu();
    if (cpu < 0 || cpu >= CPU_SETSIZE || !CPU_ISSET(cpu, &allowed)) {
        cpu = -1;
        for (int c = 0; c < CPU_SETSIZE && cpu < 0; c++)
            if (CPU_ISSET(c, &allowed)) cpu = c;
    }
    if (cpu < 0) return -1;
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    if (sched_setaffinity(0, sizeof one, &one)) {
        perror("sched_setaffinity");
        return -1;
    }
    return cpu;
}

typedef struct arm_stats {
    uint64_t relaunches, lag_n, lag_far; /* lags of lag_edge() or more */
} arm_stats;

/* The smallest lag histogram edge (lag_hist[k]: 2^(k-1) <= lag < 2^k) above
 * the straggler bound: lags this large mean a walker descheduled mid-walk. */
static uint64_t lag_edge(int threads)
{
    uint64_t edge = 1;
    while (edge <= (uint64_t)PDLA_STRAGGLER_FACTOR * (uint64_t)threads) edge *= 2;
    return edge;
}

static double grow_rg(uint64_t n, uint64_t serial_until, int threads, uint64_t seed,
                      const engine_hooks *h, arm_stats *acc)
{
    pdla_params p;
    grow_params(&p, 2, n, threads, serial_until, seed);
    pdla_engine *e;
    char err[256];
    if (pdla_engine_create(&e, &p, err, sizeof err)) {
        CHECK(0, "create failed: %s", err);
        return NAN;
    }
    e->hooks = h;
    if (pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err)) {
        CHECK(0, "growth failed: %s", err);
        pdla_engine_destroy(e);
        return NAN;
    }
    pdla_stats s;
    pdla_engine_stats(e, &s);
    pdla_engine_destroy(e);
    acc->relaunches += s.relaunches;
    acc->lag_n += s.lag_n;
    for (int k = 1; k < PDLA_LAG_BINS; k++)
        if ((1ull << (k - 1)) >= lag_edge(threads)) acc->lag_far += s.lag_hist[k];
    return s.rg_diam;
}

int main(int argc, char **argv)
{
    if (argc != 6 && argc != 7) {
        fprintf(stderr, "usage: test_onecore M N SERIAL_UNTIL THREADS TOL [bound-off | node-before-bucket]\n");
        return 2;
    }
    const int m = atoi(argv[1]), threads = atoi(argv[4]);
    const uint64_t n = (uint64_t)atof(argv[2]), serial_until = (uint64_t)atof(argv[3]);
    const double tol = atof(argv[5]);
    const char *knob = argc == 7 ? argv[6] : "";
    if (m < 2 || threads < 2 || n <= serial_until || !(tol > 0) ||
        (*knob && strcmp(knob, "bound-off") && strcmp(knob, "node-before-bucket"))) {
        fprintf(stderr, "test_onecore: bad arguments\n");
        return 2;
    }
    onecore o = {.cpu = pin_one_cpu()};
    CHECK(o.cpu >= 0, "could not pin the test to one CPU");
    if (o.cpu < 0) return check_finish();
    const engine_hooks h = {.inserted = on_inserted,
                            .no_relaunch = !strcmp(knob, "bound-off"),
                            .node_before_bucket = !strcmp(knob, "node-before-bucket"),
                            .user = &o};
    double sum = 0, sum2 = 0;
    arm_stats acc = {0, 0, 0}, serial = {0, 0, 0};
    for (int i = 0; i < m; i++) {
        const uint64_t seed = 1001 + (uint64_t)i;
        const double d = grow_rg(n, serial_until, threads, seed, &h, &acc) /
                             grow_rg(n, serial_until, 1, seed, NULL, &serial) -
                         1;
        sum += d;
        sum2 += d * d;
    }
    const pair_stat st = pair_stat_of(sum, sum2, m);
    const double mean = st.mean, sd = st.sd, se = st.se;
    fprintf(stderr,
            "2D, %d pairs of %llu after %llu serial, %d workers on CPU %d%s%s: R_g(workers) / "
            "R_g(serial) - 1 = %+.3f%% +- %.3f%% (pair sd %.2f%%; tolerance %.3f%%)\n",
            m, (unsigned long long)n, (unsigned long long)serial_until, threads, o.cpu,
            *knob ? ", " : "", knob, 100 * mean, 100 * se, 100 * sd, 100 * tol);
    fprintf(stderr,
            "workers: %llu relaunches, %llu of %llu insertions with lag %llu or more (descheduled "
            "mid-walk), %llu on another CPU\n",
            (unsigned long long)acc.relaunches, (unsigned long long)acc.lag_far,
            (unsigned long long)acc.lag_n, (unsigned long long)lag_edge(threads),
            (unsigned long long)atomic_load(&o.elsewhere));
    CHECK(acc.lag_n > 0, "the workers inserted nothing");
    CHECK(atomic_load(&o.elsewhere) == 0, "workers ran off the pinned CPU");
    pair_check(st, tol);
    return check_finish();
}
