/*
 * ev_check.h - what `pdla check` knows of an event-model file, read from a
 * cluster.h5 (ev_check_read.c) or taken from a loaded checkpoint, and the
 * checks run on it (ev_check.c, ev_check_geom.c). Private to src/event.
 */
#ifndef PDLA_EV_CHECK_H
#define PDLA_EV_CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/event.h"

/* Every array is malloc'ed (NULL when it has no rows) and freed by
 * evc_data_free. Rows as cluster.h5 stores them: the stuck particles in
 * arrival order, the free ones in index order, the seeds in file order. */
typedef struct evc_data {
    int dim, periodic;
    int ended;           /* the run reached a stop of its own: the series' last row is the end state */
    double L, t;         /* box side, clock */
    double packing;      /* the packing parameter (with the kinds it gives L) */
    uint64_t particles;  /* declared (root attribute, or the simulation's count) */
    /* seeds */
    size_t nseeds;
    double *seed_x, *seed_r;
    int seeds_param;     /* 1: a --seeds file (seed_positions), 0: the central seed or none */
    double seed_radius;  /* the central seed's radius parameter */
    /* stuck rows */
    size_t ns;
    double *sx, *sr, *st;
    int64_t *spar;
    int32_t *ssp;
    uint32_t *sidx;
    /* free rows */
    size_t nf;
    double *fx, *fv, *fr;
    int32_t *fsp;
    /* the kinds (/species) */
    int nsp;
    uint64_t kcount[EV_MAX_SPECIES], kstuck[EV_MAX_SPECIES];
    double krad[EV_MAX_SPECIES], kdens[EV_MAX_SPECIES], kmass[EV_MAX_SPECIES];
    uint8_t ksticky[EV_MAX_SPECIES];
    /* /results */
    uint64_t res_stuck, res_collisions;
    double res_ke_free, res_ke_stuck;
    /* /series */
    size_t nser;
    double *ser_t, *ser_ke;
    uint64_t *ser_stuck, *ser_coll;
} evc_data;

void evc_data_free(evc_data *d);
/* cluster.h5 at path into d: 0, or EV_CHECK_DAMAGED with one line in err
 * (a dataset or attribute missing, of another type or shape, or declaring
 * more than the file stores; a read that failed). */
int evc_read_file(const char *path, evc_data *d, char *err, size_t errlen);
/* Every check on d into r (r's geometry fields and items): 0, or
 * EV_CHECK_DAMAGED when out of memory. */
int evc_run(const evc_data *d, ev_check_report *r, char *err, size_t errlen);

/* ---- shared by ev_check.c and ev_check_geom.c ---- */

/* Count a failure of `kind`, describing it when it is the first; checking
 * stops (r->stopped) at EV_CHECK_MAX_FAILURES. */
void evc_fail(ev_check_report *r, int kind, int64_t a, int64_t b, double value, double limit, const char *fmt,
              ...) __attribute__((format(printf, 7, 8)));
/* The tolerance on a length `len` (a contact distance, a radius at a
 * wall): EV_CHECK_TOL of it plus the round-off ro, capped at 1e-2 of it. */
double evc_tol(double len, double ro);
/* The squared distance of a and b (dim coordinates), by the minimum image
 * in a periodic box of side L. */
double evc_dist2(const double *a, const double *b, int dim, int periodic, double L);
/* The bodies (seeds, stuck rows, free rows) in one array each of centres
 * and radii, for the geometric checks. */
typedef struct evc_bodies {
    size_t n;
    double *x, *r;
} evc_bodies;
/* No two bodies closer than their contact distance beyond evc_tol (a grid
 * of cells, O(N)): failures into r, r->pairs and r->worst_overlap. 0, or
 * -1 when out of memory. */
int evc_overlaps(const evc_data *d, const evc_bodies *b, double ro, ev_check_report *r);
/* "seed 2", "stuck row 7 (particle 31)", "free row 3" for body b. */
void evc_body_name(const evc_data *d, size_t b, char *buf, size_t len);

#endif
