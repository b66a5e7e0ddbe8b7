/*
 * reference.h - the reference mode of PDLA (reference.c, issue 11), called
 * by grow.c after the serial phase. Internal to libpdla.
 */
#ifndef PDLA_SRC_REFERENCE_H
#define PDLA_SRC_REFERENCE_H
#include "engine.h"

/* reference_walkers walkers in turn, in this thread, to n_until. Stopped
 * (PDLA_ESTOPPED), the walkers in flight stay in e->ref for the next call. */
int reference_grow(pdla_engine *e, uint64_t n_until, pdla_progress_fn progress, uint64_t every,
                   void *user, char *err, size_t errlen);
#endif
