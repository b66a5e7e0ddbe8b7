/* grow_params.h - the parameters the paired PDLA tests grow with: one seed to
 * n particles, serial to serial_until, then `threads` workers (1: serial DLA
 * throughout), no R_g samples. */
#ifndef PDLA_TESTS_GROW_PARAMS_H
#define PDLA_TESTS_GROW_PARAMS_H
#include <pdla/pdla.h>

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
#endif
