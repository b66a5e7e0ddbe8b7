/*
 * exact_probe.c - checks every PDLA worker's jump and every append against
 * the whole cluster (a measuring tool for issue 8's 16-core bias).
 *
 *   exact_probe DIM N SERIAL_UNTIL THREADS FIRST_SEED SEEDS
 *
 * Test hooks log every particle as it is appended (index, position) and
 * every jump a worker takes (start p, the squared radius R2 it needs clear,
 * the count `now` it is valid for). After each run, by a grid search over
 * the final cluster filtered by index:
 *  - a bad jump: some particle below `now` lies within sqrt(R2) of p;
 *  - a bad append: particle i overlaps (d < D) an earlier particle, or
 *    touches none (no earlier particle within D + eps).
 * Also the lag distribution (particles appended while a walker flew).
 */
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine.h"

typedef struct jump_rec {
    int64_t p[3];
    uint64_t R2, now;
} jump_rec;

typedef struct probe {
    int64_t (*pos)[3];
    uint64_t *lag;
    uint64_t n, first;
    int dim;
    jump_rec *jumps;
    uint64_t jcap;
    _Atomic uint64_t nj;
} probe;

static void on_append(void *user, uint64_t index, const int64_t *p)
{
    probe *c = user;
    if (index < c->n)
        for (int a = 0; a < 3; a++) c->pos[index][a] = a < c->dim ? p[a] : 0;
}

static void on_inserted(void *user, uint64_t index, const int64_t *p, uint64_t lag)
{
    probe *c = user;
    (void)p;
    if (index < c->n) c->lag[index] = lag;
}

static void on_jump(void *user, const int64_t *p, uint64_t R2, uint64_t now)
{
    probe *c = user;
    const uint64_t j = atomic_fetch_add_explicit(&c->nj, 1, memory_order_relaxed);
    if (j >= c->jcap) return;
    jump_rec *r = &c->jumps[j];
    for (int a = 0; a < 3; a++) r->p[a] = a < c->dim ? p[a] : 0;
    r->R2 = R2;
    r->now = now;
}

/* A dense grid of cells CELL units wide over the final cluster: per cell,
 * the particle indices (CSR). */
#define CELL 256
typedef struct grid {
    int64_t lo[3];
    int64_t w[3];
    uint64_t *start, *idx;
} grid;

static int64_t cell_of(const grid *g, const int64_t *x, int a)
{
    return (x[a] - g->lo[a]) / CELL;
}

static void grid_build(grid *g, const probe *c)
{
    int64_t hi[3];
    for (int a = 0; a < 3; a++) g->lo[a] = hi[a] = 0;
    for (uint64_t i = 0; i < c->n; i++)
        for (int a = 0; a < c->dim; a++) {
            if (c->pos[i][a] < g->lo[a]) g->lo[a] = c->pos[i][a];
            if (c->pos[i][a] > hi[a]) hi[a] = c->pos[i][a];
        }
    uint64_t cells = 1;
    for (int a = 0; a < 3; a++) {
        g->w[a] = a < c->dim ? (hi[a] - g->lo[a]) / CELL + 1 : 1;
        cells *= (uint64_t)g->w[a];
    }
    g->start = calloc(cells + 1, sizeof *g->start);
    g->idx = malloc(c->n * sizeof *g->idx);
    uint64_t *cell = malloc(c->n * sizeof *cell);
    for (uint64_t i = 0; i < c->n; i++) {
        uint64_t k = 0;
        for (int a = c->dim - 1; a >= 0; a--) k = k * (uint64_t)g->w[a] + (uint64_t)cell_of(g, c->pos[i], a);
        cell[i] = k;
        g->start[k + 1]++;
    }
    for (uint64_t k = 0; k < cells; k++) g->start[k + 1] += g->start[k];
    uint64_t *fill = malloc(cells * sizeof *fill);
    memcpy(fill, g->start, cells * sizeof *fill);
    for (uint64_t i = 0; i < c->n; i++) g->idx[fill[cell[i]]++] = i;
    free(fill);
    free(cell);
}

/* The smallest squared distance from p to a particle of index < below
 * (excluding `skip`), looking only within sqrt(R2) (returns R2 if none). */
static uint64_t nearest_below(const grid *g, const probe *c, const int64_t *p, uint64_t R2,
                              uint64_t below, uint64_t skip)
{
    const int64_t r = (int64_t)ceil(sqrt((double)R2)) + 1;
    int64_t a0[3], a1[3];
    for (int a = 0; a < 3; a++) {
        if (a >= c->dim) { a0[a] = a1[a] = 0; continue; }
        int64_t lo = p[a] - r - g->lo[a], hi = p[a] + r - g->lo[a];
        lo = lo < 0 ? 0 : lo / CELL;
        hi = hi < 0 ? -1 : hi / CELL;
        if (hi >= g->w[a]) hi = g->w[a] - 1;
        a0[a] = lo;
        a1[a] = hi;
    }
    uint64_t best = R2;
    for (int64_t z = a0[2]; z <= a1[2]; z++)
        for (int64_t y = a0[1]; y <= a1[1]; y++)
            for (int64_t x = a0[0]; x <= a1[0]; x++) {
                const uint64_t k = ((uint64_t)z * (uint64_t)g->w[1] + (uint64_t)y) * (uint64_t)g->w[0] + (uint64_t)x;
                for (uint64_t s = g->start[k]; s < g->start[k + 1]; s++) {
                    const uint64_t i = g->idx[s];
                    if (i >= below || i == skip) continue;
                    uint64_t d2 = 0;
                    for (int a = 0; a < c->dim; a++) {
                        const int64_t d = p[a] - c->pos[i][a];
                        d2 += (uint64_t)(d * d);
                    }
                    if (d2 < best) best = d2;
                }
            }
    return best;
}

int main(int argc, char **argv)
{
    if (argc != 7) {
        fprintf(stderr, "usage: exact_probe DIM N SERIAL_UNTIL THREADS FIRST_SEED SEEDS\n");
        return 2;
    }
    const int dim = atoi(argv[1]), threads = atoi(argv[4]), seeds = atoi(argv[6]);
    const uint64_t n = (uint64_t)atof(argv[2]), serial = (uint64_t)atof(argv[3]);
    const uint64_t seed0 = (uint64_t)atof(argv[5]);
    for (int sd = 0; sd < seeds; sd++) {
        pdla_params P;
        pdla_params_default(&P);
        P.dim = dim;
        P.target = n;
        P.serial_until = serial;
        P.threads = threads;
        P.seed = seed0 + (uint64_t)sd;
        P.rg_per_decade = 0;
        P.record_arrival = 1;
        probe c = {.n = n, .first = serial, .dim = dim};
        c.pos = calloc(n, sizeof *c.pos);
        c.lag = calloc(n, sizeof *c.lag);
        c.jcap = 200 * n;
        c.jumps = malloc(c.jcap * sizeof *c.jumps);
        atomic_init(&c.nj, 0);
        engine_hooks h = {.jump = on_jump, .append = on_append, .inserted = on_inserted, .user = &c};
        pdla_engine *e;
        char err[256];
        if (pdla_engine_create(&e, &P, err, sizeof err) != PDLA_OK) { fprintf(stderr, "%s\n", err); return 1; }
        /* The serial prefix first (no hooks: its positions come from the tree
         * walk below), then the workers with the hooks. */
        if (pdla_engine_grow(e, serial, NULL, 0, NULL, err, sizeof err) != PDLA_OK) { fprintf(stderr, "%s\n", err); return 1; }
        uint64_t na;
        const int32_t *arr = pdla_engine_arrival(e, &na);
        for (uint64_t i = 0; i < serial && i < na; i++)
            for (int a = 0; a < dim; a++) c.pos[i][a] = arr[i * (uint64_t)dim + (uint64_t)a];
        e->hooks = &h;
        if (pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err) != PDLA_OK) { fprintf(stderr, "%s\n", err); return 1; }
        pdla_stats st;
        pdla_engine_stats(e, &st);
        grid g;
        grid_build(&g, &c);
        const uint64_t D = (uint64_t)P.resolution, De = D + (uint64_t)P.eps;
        uint64_t nj = atomic_load(&c.nj), bad_jumps = 0, overlap = 0, loose = 0;
        if (nj > c.jcap) nj = c.jcap;
        for (uint64_t j = 0; j < nj; j++) {
            const jump_rec *r = &c.jumps[j];
            if (nearest_below(&g, &c, r->p, r->R2, r->now, UINT64_MAX) < r->R2) bad_jumps++;
        }
        double lag_sum = 0;
        uint64_t lag_hist[6] = {0};
        for (uint64_t i = serial; i < n; i++) {
            const uint64_t d2 = nearest_below(&g, &c, c.pos[i], De * De, i, i);
            if (d2 < D * D) overlap++;
            if (d2 >= De * De) loose++;
            lag_sum += (double)c.lag[i];
            const uint64_t l = c.lag[i];
            lag_hist[l == 0 ? 0 : l < 8 ? 1 : l < 16 ? 2 : l < 32 ? 3 : l < 128 ? 4 : 5]++;
        }
        printf("seed %llu threads %d: rg %.6f jumps %llu bad_jumps %llu appends %llu overlap %llu "
               "no_contact %llu relaunch %llu stale %llu lag_mean %.2f lag[0,<8,<16,<32,<128,>=128] "
               "%llu %llu %llu %llu %llu %llu\n",
               (unsigned long long)P.seed, threads, st.rg_diam, (unsigned long long)nj,
               (unsigned long long)bad_jumps, (unsigned long long)(n - serial),
               (unsigned long long)overlap, (unsigned long long)loose,
               (unsigned long long)st.relaunches, (unsigned long long)st.stale_jumps,
               lag_sum / (double)(n - serial), (unsigned long long)lag_hist[0],
               (unsigned long long)lag_hist[1], (unsigned long long)lag_hist[2],
               (unsigned long long)lag_hist[3], (unsigned long long)lag_hist[4],
               (unsigned long long)lag_hist[5]);
        fflush(stdout);
        pdla_engine_destroy(e);
        free(g.start);
        free(g.idx);
        free(c.pos);
        free(c.lag);
        free(c.jumps);
    }
    return 0;
}
