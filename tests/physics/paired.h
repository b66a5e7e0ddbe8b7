/* paired.h - shared by the paired PDLA tests (test_physics, test_onecore,
 * test_frontier): the parameters they grow with, and the statistic and
 * checks of the pairs' R_g ratios. */
#ifndef PDLA_TESTS_PAIRED_H
#define PDLA_TESTS_PAIRED_H
#include <math.h>
#include <pdla/pdla.h>

#include "check.h"

/* One seed to n particles, serial to serial_until, then `threads` workers
 * (1: serial DLA throughout), no R_g samples. */
static inline void grow_params(pdla_params *p, int dim, uint64_t n, int threads,
                               uint64_t serial_until, uint64_t seed)
{
    pdla_params_default(p);
    p->dim = dim;
    p->target = n;
    p->threads = threads;
    p->serial_until = serial_until;
    p->seed = seed;
    p->rg_per_decade = 0;
}

/* Mean, sample sd and standard error of m differences from their sum and
 * sum of squares. */
typedef struct pair_stat {
    double mean, sd, se;
} pair_stat;

static inline pair_stat pair_stat_of(double sum, double sum2, int m)
{
    pair_stat r;
    r.mean = sum / m;
    r.sd = sqrt(fmax(0, (sum2 - m * r.mean * r.mean) / (m - 1)));
    r.se = r.sd / sqrt(m);
    return r;
}

/* The arms agree within tol, and the pairs are enough for that to mean
 * something: se <= tol / 3, so a bias of twice the tolerance would fail. */
static inline void pair_check(pair_stat r, double tol)
{
    CHECK(fabs(r.mean) <= tol, "the arms differ by %+.3f%% +- %.3f%%, tolerance %.3f%%", 100 * r.mean,
          100 * r.se, 100 * tol);
    CHECK(r.se <= tol / 3, "standard error %.3f%% above tolerance / 3 = %.3f%%: too few pairs to fail a "
                           "bias of twice the tolerance",
          100 * r.se, 100 * tol / 3);
}
#endif
