/*
 * dlca_check.h - the core of `pdla check` for DLCA files (dlca_check.c):
 * monomers fed one by one (site, cluster number, and for a cluster.h5 the
 * position), then the checks over all of them, the totals, the series and
 * the stop, into a dlca_check_report (pdla/dlca.h). dlca_check_h5.c feeds
 * it from a cluster.h5 and dlca_check.c itself from a loaded checkpoint.
 * Internal to libpdla.
 */
#ifndef PDLA_DLCA_CHECK_H
#define PDLA_DLCA_CHECK_H

#include <stdint.h>

#include "dlca_sim.h"
#include "h5util.h"
#include "pdla/dlca.h"
#include "pdla/h5check.h"

/* The state of one check: a bit a site, and per monomer its entry in the
 * sorted sites, its cluster number and a union-find word. */
typedef struct dck {
    dlca_check_report *r;
    int d;
    int64_t L[DLCA_MAX_DIM], stride[DLCA_MAX_DIM];
    uint64_t V, N;
    int apart;        /* sticking 1: no two clusters may touch */
    long snap;        /* -1: the final state; else the snapshot checked (its failures count as snapshots) */
    uint64_t *occ;    /* a bit a site: the monomers placed */
    uint64_t *ks;     /* (site << 32 | row) of the placed monomers, sorted by dck_finish */
    uint64_t m;       /* placed */
    uint32_t *cid;    /* per row: its cluster number */
    uint32_t *ent;    /* per row: its entry in ks (UINT32_MAX: not placed) */
    uint32_t *uf;     /* per entry: union-find over face contacts */
    uint32_t *q;      /* the walk's queue: monomers of one cluster */
    uint32_t *first;  /* per cluster: its first row, first[nc] = rows */
    int32_t *u;       /* the walk: unwrapped coordinates, d per monomer of one cluster */
    dlca_off *off;    /* the walk: offsets from the cluster's first monomer */
    uint64_t rows, nc, largest;
    uint64_t sum_s2;  /* the sum of the squared cluster sizes, exact (below N^2 < 2^62) */
    int numbered;     /* 1 while the cluster numbers are as the writer's */
    uint64_t spanning;
} dck;

/* What /results holds (or a checkpoint's state would write there); has_*
 * 0 where the file lacks the value. */
typedef struct dck_totals {
    double t, mean_size, weight_size, D_f, D_f_err;
    uint64_t attempts, moves, monomer_moves, merges, n_monomers, n_clusters, largest;
    char stop[16], search_used[16];
    int has_t, has_mean, has_weight, has_df, has_dferr, has_attempts, has_moves, has_mmoves, has_merges,
        has_n, has_nc, has_largest, has_stop, has_search;
} dck_totals;

/* The tables the final state is compared with: /clusters (or the
 * checkpoint's dlca_cluster_table); n rows. */
typedef struct dck_table {
    const uint64_t *size;
    const double *rg;
    uint64_t nsize, nrg;
} dck_table;

/* Allocate for N monomers of a box of p (after the caller checked that
 * they fit: dck_fits). 0 or PDLA_ENOMEM. */
int dck_init(dck *c, dlca_check_report *r, const dlca_params *p, uint64_t N);
void dck_free(dck *c);
/* Would a check of N monomers in a box of V sites, d axes, fit in half of
 * this machine's memory? */
int dck_fits(uint64_t V, uint64_t N, int d);
/* Start over for the final state (snap -1) or snapshot snap. */
void dck_reset(dck *c, long snap);
/* Record a failure of kind (DLCA_CK_*): counted, and the first of its kind
 * kept in words (printf format). */
void dck_fail(dck *c, int kind, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* Failures so far, over every kind. */
uint64_t dck_failures(const dck *c);
/* The next monomer: x its position (d coordinates) or NULL (a checkpoint
 * or snapshot, which store the site alone), site, cluster number. 1 once
 * the failures reach DLCA_CHECK_MAX_FAILURES (stop feeding), else 0. */
int dck_row(dck *c, const int64_t *x, uint32_t site, uint32_t cluster);
/* After the last row: contacts, pieces, spanning and, with a table, its
 * sizes and R_g. */
void dck_finish(dck *c, const dck_table *tab);
/* The totals against the state just finished (its table tab, p the
 * parameters), and the stop against the state and p's stops. */
void dck_results(dck *c, const dck_totals *tot, const dck_table *tab, const dlca_params *p);
/* The series' rows one by one (i from 0, prev NULL for the first), then
 * dck_series_end with the last row (NULL: none) and the row count. end
 * holds the final state's t, attempts, n_clusters, largest, mean_size,
 * weight_size. */
void dck_series_row(dck *c, uint64_t i, const dlca_row *w, const dlca_row *prev, const dlca_row *end);
void dck_series_end(dck *c, const dlca_row *last, uint64_t rows, const dlca_row *end, const dck_totals *tot);
/* The final state's row for dck_series_row from the totals (values the
 * file lacks: ones no row can pass). */
dlca_row dck_end_row(const dck *c, const dck_totals *tot);
/* The snapshots (read by dlca_read_snapshots_h5): as a resume checks them
 * (dlca_snapshots_check_end against e), then each one's clusters. The
 * final state's check is over: c is reused. 0 or PDLA_ENOMEM. */
int dck_snapshots(dck *c, const dlca_snap_end *e, const dlca_snapshot *sn, size_t n, double every, int stopped,
                  const dck_totals *tot);
/* The snapshots of the file at path (none: nothing to check), read as a
 * resume reads them (dlca_read_snapshots_h5), then dck_snapshots, then
 * each one's /snapshots/<i>/position against its sites (dck_pos_*); a
 * refusal is a failure. 0 or PDLA_ENOMEM. */
int dck_snapshots_file(dck *c, const char *path, const dlca_snap_end *e, const dck_totals *tot);
/* The snapshots' position datasets of a file, read for dck_snapshots_file
 * (dlca_check_pos.c, which uses nothing of the core): the file, the
 * dataset open (open 1) and HDF5's printing, off until dck_pos_close. */
typedef struct dck_pos {
    pdla_h5_id f;
    pdla_h5_dset d;
    int open;
    h5u_quiet q;
} dck_pos;
/* Open path read-only. 0, or -1 with why (nothing to close). */
int dck_pos_open(dck_pos *p, const char *path, char *why, size_t len);
/* Open /snapshots/<i>/position (closing the one before), held to what pdla
 * writes before a row is read: int32, N rows of d, storing what it
 * declares, in chunks of at most 65536 rows of d. 0, or -1 with why, a
 * line that names the dataset. */
int dck_pos_snapshot(dck_pos *p, size_t i, uint64_t N, int d, char *why, size_t len);
/* Rows [r0, r0 + n) of the dataset open, d int32 each, into buf. 0 or -1
 * (a checksum or I/O error). */
int dck_pos_read(const dck_pos *p, uint64_t r0, uint64_t n, int32_t *buf);
/* Close the dataset and the file, HDF5's printing as it was. 0 or -1. */
int dck_pos_close(dck_pos *p);
/* The report's header (the box, N), the final state's counts after
 * dck_finish, and the verdict once every check has run. */
void dck_report_params(dlca_check_report *r, const dlca_params *p, uint64_t N);
void dck_report_state(const dck *c, const dck_totals *tot);
void dck_verdict(const dck *c);
/* The whole check of a DLCA checkpoint (dlca_check_file's, for model
 * "dlca-checkpoint"): loaded by dlca_checkpoint_load, a refusal
 * PDLA_EIO with its line; then its state as a cluster.h5 of it would be. */
int dck_checkpoint(const char *path, dlca_check_report *r, char *err, size_t errlen);
#endif
