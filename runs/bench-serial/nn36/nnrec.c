/*
 * nnrec.c - issue 12's near-query floor against a public exact k-d tree
 * (session 36; record: README.md beside this file).
 *
 *   nnrec DIM N SEED KEEP OUTPREFIX
 *
 * Grows the engine's own cluster (serial, same draws as `pdla --dim DIM
 * --target N --seed SEED`: walker_step is walker_run's body) and records
 * every point where the walker's step asks the tree (the map's bound is 0
 * and the walker is inside R_out) during the last KEEP particles' walks.
 * Then it writes the final cluster (OUTPREFIX.pos: int64 x DIM each) and the
 * query points (OUTPREFIX.q: int64 x DIM each, in walk order), and replays
 * the queries on the final tree with one persistent search state, as the
 * serial walker keeps one: (a) the engine's near path (3D: neighbour list,
 * then tree; 2D: the leaf block, then tree) and (b) the tree alone (2D: a
 * bound, not always the block's answer, where the block answers beyond its
 * cut); it prints ns a query (CPU time, best of 3)
 * and a checksum of the squared answers (OUTPREFIX.d2: uint64 each, the
 * exact answers, for nn.cpp to check against).
 * Build: see README.md beside this file.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "search.h"

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct vec {
    int64_t *v;
    size_t n, cap;
} vec;

static void vec_push(vec *a, int64_t x)
{
    if (a->n == a->cap) {
        a->cap = a->cap ? 2 * a->cap : 1 << 20;
        a->v = realloc(a->v, a->cap * sizeof *a->v);
        if (!a->v) { fprintf(stderr, "nnrec: out of memory\n"); exit(1); }
    }
    a->v[a->n++] = x;
}

static vec pos;
static int pos_dim;
static int visit(const int64_t *p, void *user)
{
    (void)user;
    for (int a = 0; a < pos_dim; a++) vec_push(&pos, p[a]);
    return 0;
}

static void dump(const char *prefix, const char *ext, const void *data, size_t bytes)
{
    char path[4096];
    snprintf(path, sizeof path, "%s.%s", prefix, ext);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, bytes, f) != bytes || fclose(f)) {
        fprintf(stderr, "nnrec: cannot write %s\n", path);
        exit(1);
    }
}

int main(int argc, char **argv)
{
    if (argc != 6) {
        fprintf(stderr, "usage: nnrec DIM N SEED KEEP OUTPREFIX\n");
        return 2;
    }
    const int dim = atoi(argv[1]);
    const uint64_t n = strtoull(argv[2], NULL, 10), keep = strtoull(argv[4], NULL, 10);
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = n;
    P.seed = strtoull(argv[3], NULL, 10);
    char err[256];
    pdla_engine *e;
    if (pdla_engine_create(&e, &P, err, sizeof err)) {
        fprintf(stderr, "nnrec: %s\n", err);
        return 1;
    }
    const uint64_t stick2 = (uint64_t)(P.resolution + P.eps) * (uint64_t)(P.resolution + P.eps);
    const int64_t origin[3] = {0, 0, 0};
    if (engine_add_particle(e, origin, err, sizeof err)) return 1;
    walker_ctx *w = &e->walker;
    vec q = {0};
    const double t0 = cpu_now();
    while (tree_count(&e->tree) < n) {
        const int rec = tree_count(&e->tree) + keep >= n;
        walk_state s;
        walker_begin(e, w, &s);
        int64_t stuck[3];
        for (;;) {
            if (rec) {
                double r2 = 0;
                for (int a = 0; a < dim; a++) r2 += (double)s.p[a] * (double)s.p[a];
                /* walker_step refreshes Rout2 first; a point just past it
                 * is rare and only adds a query both sides answer. */
                if (r2 <= s.Rout2 && distmap_bound(&e->dmap, s.p, dim) == 0)
                    for (int a = 0; a < dim; a++) vec_push(&q, s.p[a]);
            }
            const int r = walker_step(e, w, &s, stuck);
            if (r != WALK_MOVED) break;
        }
        if (P.snap_contact) walker_snap_to_contact(&e->tree, stuck, P.resolution, stick2, &w->ss);
        if (engine_add_particle(e, stuck, err, sizeof err)) {
            fprintf(stderr, "nnrec: %s\n", err);
            return 1;
        }
    }
    const double tgrow = cpu_now() - t0;
    pos_dim = dim;
    tree_visit(&e->tree, visit, NULL);
    const size_t nq = q.n / (size_t)dim;
    printf("dim %d N %llu seed %llu: grown in %.2f CPU s; %zu particles, %zu near queries in the "
           "last %llu walks (%.2f a particle)\n",
           dim, (unsigned long long)n, (unsigned long long)P.seed, tgrow, pos.n / (size_t)dim, nq,
           (unsigned long long)keep, (double)nq / (double)keep);
    dump(argv[5], "pos", pos.v, pos.n * sizeof(int64_t));
    dump(argv[5], "q", q.v, q.n * sizeof(int64_t));
    uint64_t *ans = malloc(nq * sizeof *ans);
    if (!ans) return 1;
    for (int mode = 0; mode < 2; mode++) {
        double best = INFINITY;
        uint64_t sum = 0, visits = 0, checks = 0;
        for (int rep = 0; rep < 3; rep++) {
            search_state ss;
            search_state_reset(&ss);
            sum = 0;
            const double t1 = cpu_now();
            for (size_t i = 0; i < nq; i++) {
                const int64_t *p = q.v + i * (size_t)dim;
                uint64_t d2 = UINT64_MAX;
                if (mode == 0 && dim == 3) d2 = search_near2(&e->tree, &e->search, p, &ss);
                if (mode == 0 && dim == 2)
                    d2 = search_block2(&e->tree, &e->search, &e->dmap, p, &ss);
                if (d2 == UINT64_MAX)
                    d2 = search_lower_bound2(&e->tree, &e->search, p, UINT64_MAX, &ss);
                ss.nb_last2 = d2;
                ans[i] = d2;
                sum += d2;
            }
            const double t = cpu_now() - t1;
            if (t < best) best = t;
            visits = ss.node_visits;
            checks = ss.particle_checks;
        }
        printf("engine %-10s %.1f ns/query (best of 3, CPU), node visits/query %.1f, particle "
               "checks/query %.1f, checksum %llu\n",
               mode == 0 ? (dim == 3 ? "list+tree" : "block+tree") : "tree", 1e9 * best / (double)nq,
               (double)visits / (double)nq, (double)checks / (double)nq, (unsigned long long)sum);
    }
    dump(argv[5], "d2", ans, nq * sizeof *ans);
    pdla_engine_destroy(e);
    return 0;
}
