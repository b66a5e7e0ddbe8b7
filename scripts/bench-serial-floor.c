/*
 * bench-serial-floor.c - issue 12's measured floor (runs/bench-serial/
 * issue12-floor-session7.md). Not part of the library or the default
 * build: scripts/bench-serial-floor compiles it against build/libpdla.a.
 *
 *   trace DIM N SEED   grow the engine's own cluster (same draws as
 *                      `pdla --dim DIM --target N --seed SEED`, bit for bit:
 *                      walker_step is walker_run's body) and, before each
 *                      jump, compute the exact distance to the nearest
 *                      particle (exact tree search) next to the bound the
 *                      engine used (recomputed on a shadow search state,
 *                      checked against the jump actually taken). Prints,
 *                      per source of the bound (map, 2D leaf block, tree)
 *                      and per band of the exact distance, the jumps, the
 *                      mean ratio of the engine's jump radius to the oracle
 *                      radius, and the estimated oracle jumps on the same
 *                      path: sum of (s_engine / s_oracle)^2, the Brownian
 *                      time of each jump (s^2 / dim) in units of the time
 *                      an oracle jump from the same point would take.
 *   count DIM N SEED   the same without the exact search (cheaper): the
 *                      jumps per source of the bound and band of the bound
 *                      itself (the ratios then read 1).
 *   oracle DIM N SEED  grow with --exact-search (every jump by the exact
 *                      distance: the oracle's walk, same law, other
 *                      clusters) and tally its jumps the same way: by the
 *                      source the engine's bound would have had there (map:
 *                      a cheap jump; block2/tree: a near query) and the band
 *                      of the exact distance; <sb/so> is then how loose the
 *                      engine's bound would be on the oracle's path.
 *   jump DIM NJUMPS    the cost of a jump with its radius already known:
 *                      the walker step without the query (direction, rounding,
 *                      move, the birth-circle test, counters), in a loop.
 *                      Time it with callgrind (Ir/jump) or CPU time.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#if defined(__SSE2__) && defined(__x86_64__)
#include <emmintrin.h>
#endif

#include "engine.h"
#include "sample.h"
#include "search.h"

enum { SRC_MAP, SRC_BLOCK, SRC_TREE, NSRC };
static const char *src_name[NSRC] = {"map", "block2", "tree"};
/* Bands of the exact distance d, in diameters: contact shell .. far. */
#define NBAND 7
static const double band_hi[NBAND] = {1.5, 2, 4, 8, 16, 64, INFINITY};

typedef struct tally {
    uint64_t n;
    double sum_ratio, sum_ratio2, sum_sb, sum_so;
} tally;

static int band_of(double d_diam)
{
    int b = 0;
    while (b < NBAND - 1 && d_diam >= band_hi[b]) b++;
    return b;
}

static void tally_add(tally *t, double sb, double so)
{
    const double r = sb / so;
    t->n++;
    t->sum_ratio += r;
    t->sum_ratio2 += r * r;
    t->sum_sb += sb;
    t->sum_so += so;
}

/* The bound the engine's walk_step_dim takes at p (serial, no --exact-search),
 * in units, and where it came from. */
static double engine_bound(const pdla_engine *e, const int64_t *p, search_state *shadow, int *src)
{
    const int dim = e->params.dim;
    const int64_t far = distmap_bound(&e->dmap, p, dim);
    if (far > 0) {
        *src = SRC_MAP;
        return (double)far;
    }
    uint64_t d2 = UINT64_MAX;
    *src = SRC_TREE;
    if (dim == 2) {
        d2 = search_block2(&e->tree, &e->search, &e->dmap, p, shadow);
        if (d2 != UINT64_MAX) *src = SRC_BLOCK;
    }
    if (d2 == UINT64_MAX) d2 = search_lower_bound2(&e->tree, &e->search, p, UINT64_MAX, shadow);
    shadow->nb_last2 = d2;
    return sqrt((double)d2);
}

enum { MODE_COUNT, MODE_TRACE, MODE_ORACLE };

static int trace(int dim, uint64_t n, uint64_t seed, int mode)
{
    const int with_exact = mode != MODE_COUNT;
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = n;
    P.seed = seed;
    P.exact_search = mode == MODE_ORACLE; /* the walker jumps by the exact distance */
    char err[256];
    pdla_engine *e;
    if (pdla_engine_create(&e, &P, err, sizeof err)) {
        fprintf(stderr, "bench-serial-floor: %s\n", err);
        return 1;
    }
    search_config exact;
    search_config_init(&exact, 0.0, P.resolution, P.eps);
    search_state ks, shadow;
    search_state_reset(&ks);
    search_state_reset(&shadow);
    const double D = P.resolution;
    const int64_t Di = P.resolution;
    const uint64_t stick2 = (uint64_t)(P.resolution + P.eps) * (uint64_t)(P.resolution + P.eps);
    const int64_t origin[3] = {0, 0, 0};
    if (engine_add_particle(e, origin, err, sizeof err)) return 1;
    walker_ctx *w = &e->walker;
    tally by[NSRC][NBAND];
    memset(by, 0, sizeof by);
    uint64_t mismatch = 0, jumps = 0;
    double max_dev = 0;
    while (tree_count(&e->tree) < n) {
        walk_state s;
        walker_begin(e, w, &s);
        int64_t stuck[3];
        for (;;) {
            int64_t before[3] = {s.p[0], s.p[1], s.p[2]};
            const uint64_t j0 = w->jumps;
            /* The exact distance and the engine's bound, before the step. */
            int src;
            const double db = engine_bound(e, before, &shadow, &src);
            /* count mode: the engine's bound stands in for the exact one. */
            const uint64_t ex2 = with_exact ? search_lower_bound2(&e->tree, &exact, before,
                                                                  UINT64_MAX, &ks)
                                            : (uint64_t)(db * db);
            const int r = walker_step(e, w, &s, stuck);
            if (r != WALK_MOVED) break;
            if (w->jumps == j0) continue; /* a return, launch or restart */
            jumps++;
            const double dex = sqrt((double)ex2);
            const double sb = db - D - 1.0, so = dex - D - 1.0;
            double moved2 = 0;
            for (int a = 0; a < dim; a++) {
                const double d = (double)(s.p[a] - before[a]);
                moved2 += d * d;
            }
            /* Rounding moves the walker by at most sqrt(dim)/2. */
            const double dev = fabs(sqrt(moved2) - (mode == MODE_ORACLE ? so : sb));
            if (dev > max_dev) max_dev = dev;
            if (dev > 0.5 * sqrt((double)dim) + 1e-9) mismatch++;
            tally_add(&by[src][band_of(dex / D)], sb, so);
        }
        if (P.snap_contact) walker_snap_to_contact(&e->tree, stuck, Di, stick2, &w->ss);
        if (engine_add_particle(e, stuck, err, sizeof err)) {
            fprintf(stderr, "bench-serial-floor: %s\n", err);
            return 1;
        }
    }
    pdla_stats st;
    pdla_engine_stats(e, &st);
    printf("dim %d N %llu seed %llu: jumps %llu (engine counter %llu), jumps/particle %.3f, "
           "returns %llu, R_g %.6f diameters\n",
           dim, (unsigned long long)n, (unsigned long long)seed, (unsigned long long)jumps,
           (unsigned long long)st.jumps, (double)st.jumps / (double)n,
           (unsigned long long)st.returns, st.rg_diam);
    printf("jump radius vs recomputed bound: max |moved - s_engine| %.3f units, %llu beyond "
           "sqrt(dim)/2\n", max_dev, (unsigned long long)mismatch);
    printf("%-7s %-10s %10s %8s %9s %9s %12s %9s\n", "source", "d (diam)", "jumps", "per part",
           "<sb/so>", "sum sb/sum so", "oracle est", "per part");
    double tot_est = 0;
    uint64_t tot_n = 0;
    for (int sidx = 0; sidx < NSRC; sidx++) {
        tally sum = {0};
        for (int b = 0; b < NBAND; b++) {
            const tally *t = &by[sidx][b];
            if (!t->n) continue;
            char band[32];
            snprintf(band, sizeof band, "%g-%g", b ? band_hi[b - 1] : 0.0, band_hi[b]);
            printf("%-7s %-10s %10llu %8.3f %9.3f %13.3f %12.0f %9.3f\n", src_name[sidx], band,
                   (unsigned long long)t->n, (double)t->n / (double)n, t->sum_ratio / (double)t->n,
                   t->sum_sb / t->sum_so, t->sum_ratio2, t->sum_ratio2 / (double)n);
            sum.n += t->n;
            sum.sum_ratio += t->sum_ratio;
            sum.sum_ratio2 += t->sum_ratio2;
            sum.sum_sb += t->sum_sb;
            sum.sum_so += t->sum_so;
        }
        if (!sum.n) continue;
        printf("%-7s %-10s %10llu %8.3f %9.3f %13.3f %12.0f %9.3f\n", src_name[sidx], "all",
               (unsigned long long)sum.n, (double)sum.n / (double)n, sum.sum_ratio / (double)sum.n,
               sum.sum_sb / sum.sum_so, sum.sum_ratio2, sum.sum_ratio2 / (double)n);
        tot_est += sum.sum_ratio2;
        tot_n += sum.n;
    }
    printf("total: engine jumps/particle %.3f, estimated oracle jumps/particle on the same "
           "path %.3f (ratio %.3f)\n",
           (double)tot_n / (double)n, tot_est / (double)n, (double)tot_n / tot_est);
    pdla_engine_destroy(e);
    return 0;
}

/* The walker's jump as walker.c makes it (random_dir, cvtsd2si rounding). */
static inline __attribute__((always_inline)) int64_t round_i64(double x)
{
#if defined(__SSE2__) && defined(__x86_64__)
    return _mm_cvtsd_si64(_mm_set_sd(x));
#else
    return (int64_t)lrint(x);
#endif
}

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* NJUMPS jumps of radius s from a radius table (the bound "already known"),
 * with the step's bookkeeping: |p|^2 against the birth radius, the jump
 * counters. The walker drifts freely (|p| stays far below 2^28 units). */
static inline __attribute__((always_inline)) uint64_t jump_loop(uint64_t njumps, const double *radius,
                                                                int64_t *p, const int dim)
{
    pdla_rng rng;
    rng_seed(&rng, 1);
    uint64_t jumps = 0, outside = 0;
    const double Rout2 = 1e30;
    for (uint64_t i = 0; i < njumps; i++) {
        double r2 = 0;
        for (int a = 0; a < dim; a++) r2 += (double)p[a] * (double)p[a];
        if (r2 > Rout2) {
            outside++;
            continue;
        }
        double v[3];
        const double s = radius[i & 1023];
        if (dim == 2) {
            sample_step2(&rng, s, v); /* the walker's 2D jump (walker.c) */
            for (int a = 0; a < 2; a++) p[a] += round_i64(v[a]);
        } else {
            sample_step3(&rng, s, v); /* the walker's 3D jump */
            for (int a = 0; a < 3; a++) p[a] += round_i64(v[a]);
        }
        jumps++;
    }
    return jumps + outside;
}

static int jump_bench(int dim, uint64_t njumps)
{
    double radius[1024];
    pdla_rng r;
    rng_seed(&r, 7);
    /* Radii as near the cluster: 1 to 300 units. */
    for (int i = 0; i < 1024; i++) radius[i] = 1.0 + 299.0 * rng_uniform(&r);
    int64_t p[3] = {0, 0, 0};
    const double t0 = cpu_now();
    const uint64_t k = dim == 2 ? jump_loop(njumps, radius, p, 2) : jump_loop(njumps, radius, p, 3);
    const double t = cpu_now() - t0;
    printf("dim %d: %llu jumps, %.3f CPU s, %.2f ns/jump (end %lld %lld %lld)\n", dim,
           (unsigned long long)k, t, 1e9 * t / (double)njumps, (long long)p[0], (long long)p[1],
           (long long)p[2]);
    return 0;
}

int main(int argc, char **argv)
{
    static const char *modes[] = {"count", "trace", "oracle"};
    for (int m = 0; m < 3; m++)
        if (argc == 5 && !strcmp(argv[1], modes[m]))
            return trace(atoi(argv[2]), strtoull(argv[3], NULL, 10), strtoull(argv[4], NULL, 10), m);
    if (argc == 4 && !strcmp(argv[1], "jump"))
        return jump_bench(atoi(argv[2]), strtoull(argv[3], NULL, 10));
    fprintf(stderr, "usage: bench-serial-floor trace|count|oracle DIM N SEED | jump DIM NJUMPS\n");
    return 2;
}
