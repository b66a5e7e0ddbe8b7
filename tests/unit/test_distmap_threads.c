/*
 * test_distmap_threads.c - the 2D map with coarsened cells (leaf bits) read
 * lock-free while a writer grows the cluster, as PDLA's workers do: one
 * writer adds particles (distmap_add with `concurrent`, then the tree),
 * two readers query search_block2 and distmap_bound at random points near
 * the cluster. Every answer must be a lower bound on the distance to each
 * particle published before the query began (the tree's count, read first):
 * a particle that a reader may miss is only one appended meanwhile. Run
 * under ThreadSanitizer (suite `threads`), it also checks the map's memory
 * ordering (tile ids, bits, grids replaced while readers run).
 */
#include <pthread.h>
#include <sched.h>
#include <stdlib.h>

#include "check.h"
#include "distmap.h"
#include "rng.h"
#include "search.h"
#include "tree.h"

enum { NPTS = 6000, NREADERS = 2 };

typedef struct shared {
    tree t;
    distmap m;
    int64_t (*pts)[3]; /* written before the particle is published in the tree */
    _Atomic int done;
    _Atomic long nq;   /* queries so far, all readers: the writer keeps pace */
} shared;

typedef struct reader {
    shared *sh;
    uint64_t seed;
    long queries, answered, bits_answers, bad;
} reader;

static int64_t rand_range(pdla_rng *r, int64_t lo, int64_t hi)
{
    return lo + (int64_t)(rng_next(r) % (uint64_t)(hi - lo + 1));
}

static uint64_t brute(const int64_t (*pts)[3], uint64_t n, const int64_t *q)
{
    uint64_t best = UINT64_MAX;
    for (uint64_t i = 0; i < n; i++) {
        const int64_t dx = q[0] - pts[i][0], dy = q[1] - pts[i][1];
        const uint64_t d2 = (uint64_t)(dx * dx + dy * dy);
        if (d2 < best) best = d2;
    }
    return best;
}

static void *read_loop(void *arg)
{
    reader *rd = arg;
    shared *sh = rd->sh;
    pdla_rng r;
    rng_seed(&r, rd->seed);
    search_config cfg;
    search_config_init(&cfg, 2.0, 32, 2);
    cfg.concurrent = 1;
    search_state ss;
    search_state_reset(&ss);
    int64_t q[3] = {0, 0, 0};
    while (!atomic_load(&sh->done)) {
        const uint64_t n = tree_count(&sh->t);
        if (n < 2) continue;
        /* A walker-like cursor: near a published particle, moving a little. */
        if (rd->queries % 8 == 0) {
            const int64_t *s = sh->pts[rng_next(&r) % n];
            for (int a = 0; a < 2; a++) q[a] = s[a] + rand_range(&r, -2000, 2000);
        } else {
            for (int a = 0; a < 2; a++) q[a] += rand_range(&r, -200, 200);
        }
        rd->queries++;
        atomic_fetch_add(&sh->nq, 1);
        const uint64_t b2 = search_block2(&sh->t, &cfg, &sh->m, q, &ss);
        const int64_t fb = distmap_bound(&sh->m, q, 2);
        const uint64_t truth = brute((const int64_t(*)[3])sh->pts, n, q);
        if (b2 != UINT64_MAX) {
            rd->answered++;
            rd->bits_answers += b2 > 512 * 512;
            if (b2 > truth) rd->bad++;
        }
        if (fb > 0 && (uint64_t)fb * (uint64_t)fb > truth) rd->bad++;
    }
    return NULL;
}

int main(void)
{
    shared *sh = calloc(1, sizeof *sh);
    CHECK(sh && tree_init(&sh->t, 2) == 0, "tree_init");
    distmap_init(&sh->m, 2, 8, 2 * 32 + 8 * 256);
    sh->m.budget_min = 1024; /* coarsened cells with leaf bits from a few hundred particles */
    sh->m.budget_per_particle = 0.0;
    sh->pts = calloc(NPTS, sizeof *sh->pts);
    atomic_init(&sh->done, 0);
    atomic_init(&sh->nq, 0);
    /* The first particle before the readers start. */
    distmap_add(&sh->m, sh->pts[0], 1, 1);
    CHECK(tree_insert(&sh->t, sh->pts[0]) == 0, "insert");
    reader rd[NREADERS];
    pthread_t th[NREADERS];
    for (int i = 0; i < NREADERS; i++) {
        rd[i] = (reader){.sh = sh, .seed = 100 + (uint64_t)i};
        CHECK(pthread_create(&th[i], NULL, read_loop, &rd[i]) == 0, "pthread_create");
    }
    pdla_rng r;
    rng_seed(&r, 11);
    int64_t cur[3] = {0, 0, 0};
    for (uint64_t i = 1; i < NPTS; i++) {
        if (i % 97 == 0)
            for (int a = 0; a < 2; a++) cur[a] = sh->pts[rng_next(&r) % i][a];
        const int64_t step = (i % 500 < 20) ? 3000 : 40;
        for (int a = 0; a < 2; a++) cur[a] += rand_range(&r, -step, step);
        for (int a = 0; a < 2; a++) sh->pts[i][a] = cur[a];
        distmap_add(&sh->m, cur, i + 1, 1);
        /* As the engine's workers append while others read: nothing moves. */
        tree_slot sl;
        CHECK(tree_make_path(&sh->t, cur, &sl) == 0 && tree_append(&sh->t, &sl, cur, 1) == 0, "insert");
        /* About one query per particle, so the readers run while the map
         * grows (and its grids are replaced). */
        while (atomic_load(&sh->nq) < (long)i) sched_yield();
    }
    atomic_store(&sh->done, 1);
    long answered = 0, bits = 0, bad = 0, queries = 0;
    for (int i = 0; i < NREADERS; i++) {
        CHECK(pthread_join(th[i], NULL) == 0, "pthread_join");
        queries += rd[i].queries;
        answered += rd[i].answered;
        bits += rd[i].bits_answers;
        bad += rd[i].bad;
    }
    const distmap_grid *g = atomic_load(&sh->m.grid);
    CHECK(g && g->tix != NULL, "the map did not coarsen to leaf bits");
    CHECK(bad == 0, "%ld of %ld answers above the distance to the published particles", bad, queries);
    CHECK(answered > 1000 && bits > 50, "%ld block answers (%ld from the bits) in %ld queries", answered,
          bits, queries);
    fprintf(stderr, "%ld queries, %ld block answers (%ld from the leaf bits beyond 2 leaves)\n", queries,
            answered, bits);
    distmap_free(&sh->m);
    tree_free(&sh->t);
    free(sh->pts);
    free(sh);
    return check_finish();
}
