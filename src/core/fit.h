/*
 * fit.h - fractal dimension from the radius-of-gyration series:
 * least squares of ln R_g on ln N over a range of N, D_f = 1 / slope,
 * with the standard error of D_f propagated from the slope's.
 */
#ifndef PDLA_SRC_FIT_H
#define PDLA_SRC_FIT_H
#include <stddef.h>
#include <stdint.h>
#include "pdla/pdla.h"

/* Fit over samples with n_lo <= N <= n_hi and rg > 0. Fewer than 3 points
 * give points = 0 and df = df_err = NAN. */
pdla_fit fit_powerlaw(const uint64_t *n, const double *rg, size_t count, uint64_t n_lo,
                      uint64_t n_hi);

/* The default fit range for a cluster of n_final particles:
 * [max(10, min(1000, n_final / 10)), n_final]. Corrections to scaling are
 * small above ~1e3 particles in off-lattice DLA. */
void fit_default_range(uint64_t n_final, uint64_t *n_lo, uint64_t *n_hi);

/* N of R_g grid point k (k = 0 is N = 1): round(10^(k / per_decade)),
 * forced above prev (the point before) so that the grid strictly
 * increases. The engine samples R_g at every point, so a cluster grown one
 * particle at a time to n holds exactly the points <= n: one grid, which
 * the ensemble journal holds each record's against (ens_journal.c). */
uint64_t fit_rg_grid_n(uint64_t k, int per_decade, uint64_t prev);

/* N of grid point k replayed from point 0 (each point depends on the one
 * before), for checking a stored grid position; 0 when k lies past 20
 * decades (no uint64 N reaches it) or per_decade < 1. */
uint64_t fit_rg_grid_at(uint64_t k, int per_decade);
#endif
