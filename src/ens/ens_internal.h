/*
 * ens_internal.h - what the ensemble's files share (src/ens/); not installed.
 */
#ifndef PDLA_SRC_ENS_INTERNAL_H
#define PDLA_SRC_ENS_INTERNAL_H
#include <stddef.h>
#include <stdint.h>

#include "h5util.h"

/* One column dataset under g (units may be NULL). -1 with w->err on failure. */
int ens_write_u64(const h5u_writer *w, hid_t g, const char *name, const uint64_t *v, size_t n,
                  const char *units);
int ens_write_f64(const h5u_writer *w, hid_t g, const char *name, const double *v, size_t n,
                  const char *units);

/* /statistics from the R_g matrix (m x k) and the clusters' own D_f. */
int ens_write_statistics(const h5u_writer *w, hid_t file, const uint64_t *grid, size_t k,
                         const double *rg, size_t m, const double *df_cluster, uint64_t n_final);
#endif
