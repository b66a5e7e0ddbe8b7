/*
 * export_src.h - what `pdla export` reads: the particles or sites of any
 * pdla output, streamed in slabs through the checked read layer
 * (include/pdla/h5check.h).
 *
 *   DLA cluster.h5      /cluster/positions, int, D units per diameter
 *                       (h5read.c's checks); lengths in diameters
 *   ensemble.h5         /clusters/positions, int, N rows per cluster; one
 *                       cluster (--cluster I) or all with a cluster column
 *   DLCA cluster.h5     /monomers/position, int lattice sites, with
 *                       /monomers/cluster (model = "dlca"); checked when
 *                       opened: each row in the /parameters box, no two
 *                       on one site
 *   event cluster.h5    /cluster/positions, real, model lengths, with
 *                       /cluster/radii, rows in arrival order
 *                       (model = "event")
 * The DLCA and event files are read through their documented layout only
 * (include/pdla/dlca.h, src/event/ev_out.c's header), never the models'
 * code. Only 2D and 3D positions are exported.
 */
#ifndef PDLA_CLI_EXPORT_SRC_H
#define PDLA_CLI_EXPORT_SRC_H

#include <stddef.h>
#include <stdint.h>

#include <hdf5.h>

#include "h5read.h"
#include "pdla/h5check.h"

enum { EXP_DLA, EXP_ENSEMBLE, EXP_DLCA, EXP_EVENT };

typedef struct exp_src {
    int kind;
    const char *path;
    h5r_file dla;          /* EXP_DLA: the file as h5read.c opens it */
    hid_t file;            /* the others */
    pdla_h5_dset pos;      /* positions [rows][dim], int or real */
    pdla_h5_dset radius;   /* EXP_EVENT: radii (id < 0: none) */
    pdla_h5_dset cid;      /* EXP_DLCA: cluster of each monomer (id < 0: none) */
    int dim;               /* 2 or 3 */
    int real;              /* positions are real (read as double), else int32 */
    int units;             /* file units per output length unit (D, or 1) */
    const char *unit_name; /* "diameters", "lattice sites", "model lengths" */
    uint64_t row0, n;      /* rows exported: [row0, row0 + n) of the dataset */
    uint64_t per_cluster;  /* EXP_ENSEMBLE: rows per cluster */
    uint64_t clusters;     /* EXP_ENSEMBLE: M */
    int64_t cluster;       /* EXP_ENSEMBLE: the cluster chosen, or -1: all */
    int arrival;           /* rows (of a cluster) in arrival order: an index column */
    int distance;          /* a distance-from-the-seed column (the seed at the origin) */
    int cluster_col;       /* a cluster id column: ensemble (all) or DLCA */
} exp_src;

/* One slab: rows [first, first + rows) of those exported (0 = row0). */
typedef struct exp_slab {
    size_t rows;
    uint64_t first;
    const int32_t *q;        /* int positions (rows * dim), or NULL */
    const double *f;         /* real positions, or NULL */
    const double *radius;    /* per row, or NULL: 0.5 */
    const uint64_t *cluster; /* per row, or NULL (no cluster column) */
    const uint64_t *index;   /* per row: the arrival index within its cluster */
} exp_slab;
typedef int (*exp_fn)(const exp_slab *s, void *user);

/* Opens path as one of the kinds above. cluster >= 0 picks one cluster of
 * an ensemble file (refused for other kinds). 0, or -1 with err. */
int exp_src_open(exp_src *s, const char *path, int64_t cluster, char *err, size_t errlen);
/* Calls fn on the rows in order, slab_rows (1..H5R_MAX_SLAB_ROWS) at a
 * time from buffers of that size. fn's non-zero return stops and is
 * returned; a read failure returns -1 with err. */
int exp_src_stream(exp_src *s, size_t slab_rows, exp_fn fn, void *user, char *err, size_t errlen);
/* 0, or -1 when HDF5 failed to close something of s. */
int exp_src_close(exp_src *s);

#endif
