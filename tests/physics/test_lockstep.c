/*
 * test_lockstep.c - the threaded PDLA engine and the race-free reference of
 * P walkers (reference.c) differ only in how the walkers are interleaved
 * (issue 11).
 *
 * Test hooks (src/engine.h) make the P worker threads take turns: worker i
 * launches a walker or takes one step only when the turn is its own, and
 * passes the turn on after a step that moved or after its insertion, which
 * is the reference mode's round robin. The threads must then grow the
 * reference's cluster bit for bit: the same positions, R_g samples and lags
 * (particles appended by the others while a walker was in flight). Any
 * other difference between the two modes (the launch circle, R_ext read by
 * a walker in flight, the re-check of a taken spot, the random streams, the
 * target) would make the clusters differ. Without the turns the same run
 * gives another cluster (the OS interleaves the workers otherwise).
 *
 * Also: after a phase of P walkers (either mode) the engine's random stream
 * resumes 2^128 P draws after its state at the phase's start, past every
 * walker's stream, so a later phase never draws the same numbers again.
 * Runs under ThreadSanitizer (suite threads).
 */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine.h"

#define MAXW 8

typedef struct turns {
    pthread_mutex_t mu;
    pthread_cond_t cv[MAXW];
    int turn, n;
    const pdla_engine *e;
    uint64_t target;
    uint64_t waits; /* turns handed over (under mu) */
    /* Particles appended between two turns of one worker (under mu): at
     * most P (the P - 1 others' and its own), far below the straggler
     * bound of 8 P, which must then never trigger. */
    uint64_t last[MAXW], max_gap;
    int started[MAXW];
} turns;

static int done(const turns *t) { return pdla_engine_count(t->e) >= t->target; }

static void turn_begin(void *user, int id)
{
    turns *t = user;
    /* Not CHECK: its counters are not for worker threads (a race TSan sees). */
    if (pthread_mutex_lock(&t->mu)) abort();
    /* Once the target is reached the order no longer matters: the workers
     * finish their walks and find the target taken. */
    while (t->turn != id && !done(t)) pthread_cond_wait(&t->cv[id], &t->mu);
    const uint64_t now = pdla_engine_count(t->e);
    if (t->started[id] && !done(t) && now - t->last[id] > t->max_gap) t->max_gap = now - t->last[id];
    t->last[id] = now;
    t->started[id] = 1;
    pthread_mutex_unlock(&t->mu);
}

static void turn_end(void *user, int id)
{
    turns *t = user;
    /* Not CHECK: its counters are not for worker threads (a race TSan sees). */
    if (pthread_mutex_lock(&t->mu)) abort();
    if (t->turn == id) {
        t->turn = (id + 1) % t->n;
        t->waits++;
    }
    if (done(t))
        for (int i = 0; i < t->n; i++) pthread_cond_broadcast(&t->cv[i]);
    else
        pthread_cond_signal(&t->cv[t->turn]);
    pthread_mutex_unlock(&t->mu);
}

#include "positions.h"

typedef struct result {
    positions pos;
    double *rg;
    size_t rg_count;
    pdla_stats s;
    pdla_rng start, end; /* the engine stream at the phase's start and end */
} result;

/* mode: 'r' reference of P walkers, 't' P workers in turns, 'f' P free workers. */
static result grow(int dim, uint64_t target, uint64_t serial, int P, int mode, uint64_t seed)
{
    pdla_params par;
    pdla_params_default(&par);
    par.dim = dim;
    par.target = target;
    par.seed = seed;
    par.serial_until = serial;
    if (mode == 'r')
        par.reference_walkers = P;
    else
        par.threads = P;
    result r;
    memset(&r, 0, sizeof r);
    r.pos.dim = dim;
    pdla_engine *e;
    char err[256];
    CHECK(pdla_engine_create(&e, &par, err, sizeof err) == PDLA_OK, "create: %s", err);
    turns t = {.turn = 0, .n = P, .e = e, .target = target};
    CHECK(pthread_mutex_init(&t.mu, NULL) == 0, "mutex");
    for (int i = 0; i < P; i++) CHECK(pthread_cond_init(&t.cv[i], NULL) == 0, "cond");
    engine_hooks h = {.turn_begin = turn_begin, .turn_end = turn_end, .user = &t};
    CHECK(pdla_engine_grow(e, serial, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "serial: %s", err);
    r.start = e->walker.rng;
    if (mode == 't') e->hooks = &h;
    CHECK(pdla_engine_grow(e, target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "grow: %s", err);
    e->hooks = NULL;
    r.end = e->walker.rng;
    CHECK(pdla_engine_visit(e, grab, &r.pos) == 0, "out of memory gathering the positions");
    const uint64_t *n;
    const double *rg;
    pdla_engine_rg_series(e, &n, &rg, &r.rg_count);
    r.rg = malloc(r.rg_count * sizeof *r.rg + 1);
    memcpy(r.rg, rg, r.rg_count * sizeof *r.rg);
    pdla_engine_stats(e, &r.s);
    pdla_engine_destroy(e);
    for (int i = 0; i < P; i++) pthread_cond_destroy(&t.cv[i]);
    pthread_mutex_destroy(&t.mu);
    if (mode == 't') {
        CHECK(t.waits > target - serial, "%dD: the workers took turns (%llu handovers)", dim,
              (unsigned long long)t.waits);
        CHECK(t.max_gap > 0 && t.max_gap <= (uint64_t)P,
              "%dD: at most %d particles appended between two turns of a worker (%llu)", dim, P,
              (unsigned long long)t.max_gap);
        CHECK(r.s.relaunches == 0, "%dD: the straggler bound never triggers in turns (%llu)", dim,
              (unsigned long long)r.s.relaunches);
    }
    return r;
}

static int same_cluster(const result *a, const result *b)
{
    return a->pos.n == b->pos.n && !memcmp(a->pos.x, b->pos.x, a->pos.n * (size_t)a->pos.dim * 4) &&
           a->rg_count == b->rg_count && !memcmp(a->rg, b->rg, a->rg_count * sizeof *a->rg);
}

static int same_lags(const pdla_stats *a, const pdla_stats *b)
{
    return a->lag_n == b->lag_n && a->lag_sum == b->lag_sum &&
           !memcmp(a->lag_hist, b->lag_hist, sizeof a->lag_hist);
}

/* The stream 2^128 k draws after s. */
static pdla_rng jumped(pdla_rng s, int k)
{
    for (int i = 0; i < k; i++) rng_jump(&s);
    return s;
}

static void drop(result *r)
{
    free(r->pos.x);
    free(r->rg);
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        const uint64_t N = dim == 2 ? 1500 : 800, S = N / 10;
        const int P = dim == 2 ? 4 : 3;
        result ref = grow(dim, N, S, P, 'r', 7);
        result turn = grow(dim, N, S, P, 't', 7);
        result freew = grow(dim, N, S, P, 'f', 7);
        CHECK(ref.pos.n == N && turn.pos.n == N && freew.pos.n == N, "%dD: %llu particles each", dim,
              (unsigned long long)N);
        CHECK(same_cluster(&ref, &turn),
              "%dD: %d workers taking turns grow the reference's cluster bit for bit", dim, P);
        CHECK(same_lags(&ref.s, &turn.s), "%dD: ... with the same lags (mean %.3f and %.3f)", dim,
              ref.s.lag_n ? (double)ref.s.lag_sum / (double)ref.s.lag_n : 0.0,
              turn.s.lag_n ? (double)turn.s.lag_sum / (double)turn.s.lag_n : 0.0);
        CHECK(ref.s.lag_n == N - S, "%dD: a lag for every particle of the phase (%llu)", dim,
              (unsigned long long)ref.s.lag_n);
        /* Little's law: P walkers always in flight, so about P - 1 others
         * stick during a walker's flight (a little less: a walker is
         * relaunched only at its next turn). In 3D walkers also escape and
         * are replaced by fresh ones, whose lag starts again: less. */
        const double mean = (double)ref.s.lag_sum / (double)ref.s.lag_n;
        CHECK(mean > (dim == 2 ? P - 1.5 : 0.0) && mean <= P - 1,
              "%dD: mean lag %.3f of %d reference walkers", dim, mean, P);
        CHECK(!same_cluster(&ref, &freew) || !same_lags(&ref.s, &freew.s),
              "%dD: free workers (no turns) grow another cluster", dim);
        /* Streams: walker i from the start jumped i times; the engine
         * resumes P jumps on. */
        const pdla_rng want = jumped(ref.start, P);
        CHECK(!memcmp(&ref.end, &want, sizeof want), "%dD: reference: the stream resumes %d jumps on",
              dim, P);
        CHECK(!memcmp(&turn.end, &want, sizeof want) && !memcmp(&freew.end, &want, sizeof want),
              "%dD: workers: the stream resumes %d jumps on", dim, P);
        drop(&ref);
        drop(&turn);
        drop(&freew);
    }
    return check_finish();
}
