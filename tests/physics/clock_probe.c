/*
 * clock_probe.c - P walkers in flight in one thread, scheduled either in
 * turn (the reference mode, reference.c) or as P threads on P free cores
 * would run them: each walker has a clock that its steps advance by their
 * own CPU time (time-stamp counter), and the walker whose clock is lowest
 * steps next. A measuring tool for issue 8's 16-core bias (not a test):
 * the workers on free cores grow a cluster 2-3% more compact than the
 * reference of as many walkers while every jump is exact (exact_probe);
 * this tells whether the schedule alone does that.
 *
 *   clock_probe DIM N SERIAL_UNTIL P FIRST_SEED SEEDS MODE
 *
 * MODE: rr (in turn: the reference mode's cluster, as a check of this tool),
 * clock, or delayK: in turn, but a walker that stops is appended only K
 * steps (of the others) later, as a walker waiting for the bucket mutex is
 * (its spot re-checked for overlap then, as the workers do). One line per seed: seed, R_g (diameters), mean lag.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if defined(__x86_64__)
#include <x86intrin.h>
#endif
#include <time.h>

#include "engine.h"

static uint64_t ticks(void)
{
#if defined(__x86_64__)
    return __rdtsc();
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
#endif
}

/* reference.c's reference_insert. */
static int insert(pdla_engine *e, walker_ctx *w, int64_t *p, int status, char *err, size_t errlen)
{
    const pdla_params *P = &e->params;
    const int64_t D = P->resolution;
    const uint64_t stick2 = (uint64_t)(D + P->eps) * (uint64_t)(D + P->eps);
    if (status == WALK_OVERLAP) {
        if (P->recheck == PDLA_RECHECK_DISCARD || !walker_snap_to_contact(&e->tree, p, D, stick2, &w->ss))
            return PDLA_OK;
    } else if (P->snap_contact) {
        walker_snap_to_contact(&e->tree, p, D, stick2, &w->ss);
    }
    const uint64_t index = tree_count(&e->tree);
    const int rc = engine_add_particle(e, p, err, errlen);
    if (rc == PDLA_OK) walker_note_lag(w, index);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc != 8) {
        fprintf(stderr, "usage: clock_probe DIM N SERIAL_UNTIL P FIRST_SEED SEEDS rr|clock\n");
        return 2;
    }
    const int dim = atoi(argv[1]), np = atoi(argv[4]), seeds = atoi(argv[6]);
    const uint64_t n = (uint64_t)atof(argv[2]), serial = (uint64_t)atof(argv[3]);
    const uint64_t seed0 = (uint64_t)atof(argv[5]);
    const int clock_mode = strcmp(argv[7], "clock") == 0;
    const int delay = strncmp(argv[7], "delay", 5) == 0 ? atoi(argv[7] + 5) : 0;
    if (np < 2 || (!clock_mode && !delay && strcmp(argv[7], "rr"))) {
        fprintf(stderr, "clock_probe: bad arguments\n");
        return 2;
    }
    for (int sd = 0; sd < seeds; sd++) {
        pdla_params P;
        pdla_params_default(&P);
        P.dim = dim;
        P.target = n;
        P.serial_until = serial;
        P.threads = 1;
        P.seed = seed0 + (uint64_t)sd;
        P.rg_per_decade = 0;
        pdla_engine *e;
        char err[256];
        if (pdla_engine_create(&e, &P, err, sizeof err) != PDLA_OK ||
            pdla_engine_grow(e, serial, NULL, 0, NULL, err, sizeof err) != PDLA_OK) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        walker_ctx *ws = aligned_alloc(64, sizeof(walker_ctx) * (size_t)np);
        walk_state *st = calloc((size_t)np, sizeof *st);
        uint64_t *clk = calloc((size_t)np, sizeof *clk);
        unsigned char *active = calloc((size_t)np, 1);
        int *wait = calloc((size_t)np, sizeof *wait);
        int64_t (*held)[3] = calloc((size_t)np, sizeof *held);
        const uint64_t D2 = (uint64_t)P.resolution * (uint64_t)P.resolution;
        memset(ws, 0, sizeof(walker_ctx) * (size_t)np);
        /* Walker 0 is the serial walker; walker i draws from the serial
         * stream jumped 2^128 i ahead (reference.c, reference_make). */
        walker_ctx *w0 = &e->walker;
        pdla_rng stream = w0->rng;
        for (int i = 1; i < np; i++) {
            rng_jump(&stream);
            ws[i].rng = stream;
            search_state_reset(&ws[i].ss);
        }
        int rc = PDLA_OK;
        for (int i = 0; rc == PDLA_OK && tree_count(&e->tree) < n;) {
            if (clock_mode) {
                i = 0;
                for (int j = 1; j < np; j++)
                    if (clk[j] < clk[i]) i = j;
            }
            walker_ctx *w = i == 0 ? w0 : &ws[i];
            if (delay) {
                /* Waiting walkers count down on every step of the others. */
                for (int j = 0; j < np; j++)
                    if (j != i && wait[j] > 0 && --wait[j] == 0) {
                        int64_t q[3];
                        uint64_t d2;
                        const int over = search_nearest_point(&e->tree, held[j], D2, q, &d2);
                        rc = insert(e, j == 0 ? w0 : &ws[j], held[j], over ? WALK_OVERLAP : WALK_CONTACT,
                                    err, sizeof err);
                        wait[j] = -1;
                    }
                if (wait[i] > 0 || rc != PDLA_OK || tree_count(&e->tree) >= n) {
                    i = i + 1 < np ? i + 1 : 0;
                    continue;
                }
                wait[i] = 0;
            }
            const uint64_t t0 = ticks();
            if (!active[i]) {
                walker_begin(e, w, &st[i]);
                active[i] = 1;
            }
            int64_t p[3];
            const int status = walker_step(e, w, &st[i], p);
            if (status != WALK_MOVED) {
                active[i] = 0;
                if (delay) {
                    /* The spot as found (an overlap is snapped at once,
                     * as insert_concurrent does before the mutex). */
                    if (status == WALK_OVERLAP &&
                        !walker_snap_to_contact(&e->tree, p, P.resolution,
                                                (uint64_t)(P.resolution + P.eps) * (uint64_t)(P.resolution + P.eps),
                                                &w->ss)) {
                        /* discarded */
                    } else {
                        for (int a = 0; a < 3; a++) held[i][a] = p[a];
                        wait[i] = delay;
                    }
                } else {
                    rc = insert(e, w, p, status, err, sizeof err);
                }
            }
            clk[i] += ticks() - t0;
            if (!clock_mode) i = i + 1 < np ? i + 1 : 0;
        }
        if (rc != PDLA_OK) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        uint64_t lag_n = w0->lag_n, lag_sum = w0->lag_sum, h[PDLA_LAG_BINS];
        memcpy(h, w0->lag_hist, sizeof h);
        for (int i = 1; i < np; i++) {
            lag_n += ws[i].lag_n;
            lag_sum += ws[i].lag_sum;
            for (int b = 0; b < PDLA_LAG_BINS; b++) h[b] += ws[i].lag_hist[b];
        }
        /* The bins of exact_probe: 0, 1-7, 8-15, 16-31, 32-127, >= 128. */
        uint64_t c[6] = {h[0], h[1] + h[2] + h[3], h[4], h[5], h[6] + h[7], 0};
        for (int b = 8; b < PDLA_LAG_BINS; b++) c[5] += h[b];
        pdla_stats s;
        pdla_engine_stats(e, &s);
        printf("%llu\t%.9g\t%.3f", (unsigned long long)P.seed, s.rg_diam,
               lag_n ? (double)lag_sum / (double)lag_n : 0.0);
        for (int b = 0; b < 6; b++) printf("\t%llu", (unsigned long long)c[b]);
        printf("\n");
        fflush(stdout);
        free(ws);
        free(st);
        free(clk);
        free(active);
        free(wait);
        free(held);
        pdla_engine_destroy(e);
    }
    return 0;
}
