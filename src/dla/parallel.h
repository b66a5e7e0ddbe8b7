/*
 * parallel.h - the PDLA phase (parallel.c), called by grow.c after the
 * serial phase. Internal to libpdla.
 */
#ifndef PDLA_SRC_PARALLEL_H
#define PDLA_SRC_PARALLEL_H
#include "engine.h"

/* Workers grow the cluster to n_until (see parallel.c). */
int parallel_grow(pdla_engine *e, uint64_t n_until, pdla_progress_fn progress, void *user,
                  char *err, size_t errlen);
#endif
