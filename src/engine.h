/*
 * engine.h - the engine struct shared by engine.c (lifecycle, gyration,
 * sampling, results) and walker.c (one walker's walk from birth to contact).
 * Not installed: the public face is include/pdla/pdla.h.
 */
#ifndef PDLA_SRC_ENGINE_H
#define PDLA_SRC_ENGINE_H
#include "pdla/pdla.h"
#include "rng.h"
#include "tree.h"

/* Exact running sums for the radius of gyration: with |x| < 2^28 units,
 * 128-bit sums hold any N below 2^70. */
typedef struct gyration_sums {
    __extension__ __int128 s1[3];          /* sum of x_a */
    __extension__ unsigned __int128 s2;    /* sum of |x|^2 */
    uint64_t n;
} gyration_sums;

/* What one walker needs besides the tree: its random stream and counters. */
typedef struct walker_ctx {
    pdla_rng rng;
    search_state ss;
    uint64_t walkers, jumps, returns, lost, killed, restarts;
} walker_ctx;

struct pdla_engine {
    pdla_params params;
    tree tree;
    search_config search;
    walker_ctx walker;
    gyration_sums gyr;
    uint64_t r_ext2;          /* max |x|^2 of particle centres, units^2 */
    int64_t r_ext;            /* ceil(sqrt(r_ext2)) */
    /* R_g(N) samples on a fixed log grid: N_k = round(10^(k / rg_per_decade)). */
    uint64_t *rg_n;
    double *rg_diam;
    size_t rg_count, rg_cap;
    uint64_t rg_next_k;       /* index k of the next grid point */
    uint64_t rg_next_n;       /* its N */
    double grow_seconds;
};

/* Walk one walker from birth until it sticks; writes the contact position.
 * Returns 0, or a PDLA_E* code. */
int walker_run(pdla_engine *e, int64_t *stuck_at);

double gyration_rg2_units(const gyration_sums *g, int dim);
#endif
