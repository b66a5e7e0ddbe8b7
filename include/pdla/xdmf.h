/*
 * xdmf.h - XDMF sidecars: a small XML file beside an HDF5 output that tells
 * ParaView (and other XDMF readers) where the particles are, so the HDF5
 * file opens without pdla.
 *
 * Tested with ParaView 5.11 (Debian 12): the sidecar is named *.xdmf2 so
 * that ParaView opens it with its "XDMF Reader" (XDMF 2) without asking.
 * That reader evaluates the Function data items used here: positions are
 * read from the HDF5 file as reals and divided by the units per diameter,
 * so ParaView shows diameters. The newer Xdmf3 readers (which ParaView
 * picks for *.xmf) cannot evaluate Function items and show no points.
 *
 * That reader puts a Function argument of one element into the expression
 * as a number, and a Function of numbers only fails (the array comes out
 * empty): a one-point grid's computed arrays are written without such a
 * Function (src/core/xdmf.c, put_column2).
 *
 * Every particle is one Polyvertex cell (N cells of one node), so ParaView
 * draws them with any representation. The HDF5 data are never copied: the
 * sidecar only points at datasets, by the HDF5 file's name relative to the
 * sidecar (both must stay in one folder).
 */
#ifndef PDLA_XDMF_H
#define PDLA_XDMF_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/pdla.h"

/* One more per-particle array: a 1-D dataset of n rows in the same file. */
typedef struct xdmf_array {
    const char *name;        /* the name ParaView shows */
    const char *dataset;     /* path inside the HDF5 file, e.g. "/cluster/id" */
    const char *number_type; /* XDMF NumberType: "Int", "UInt", "Float" */
    int precision;           /* bytes per value: 1, 2, 4 or 8 */
} xdmf_array;

typedef struct xdmf_points {
    const char *h5_path;       /* the HDF5 file; the sidecar names its last component */
    const char *positions;     /* integer dataset [n][dim] of particle centres */
    uint64_t n;                /* rows */
    int dim;                   /* 2 or 3 */
    int units_per_diameter;    /* positions / this = diameters */
    int distance;              /* add "distance": |position| in diameters */
    const char *row_index;     /* add this array holding 0..n-1 (e.g. "arrival" when the
                                * rows are in arrival order); NULL: none */
    const xdmf_array *arrays;  /* more per-particle arrays; may be NULL */
    size_t narrays;
} xdmf_points;

/* The sidecars pdla writes for an HDF5 file STEM.h5, by kind: STEM.xdmf2
 * (DLA, DLCA, ensembles; the event model's stuck particles) and
 * STEM-free.xdmf2 (the event model's free particles). One list for every
 * model, so that a run can remove the kinds another model left. */
enum xdmf_sidecar_kind { XDMF_SIDECAR_MAIN, XDMF_SIDECAR_FREE, XDMF_SIDECAR_KINDS };
#define XDMF_SIDECAR_BIT(kind) (1u << (kind))

/* The path of h5_path's sidecar of that kind: a trailing ".h5" replaced by
 * the kind's suffix, else the suffix appended. 0, or -1 if it does not fit
 * in len or kind is unknown. */
PDLA_API int xdmf_sidecar_name(const char *h5_path, int kind, char *out, size_t len);

/* xdmf_sidecar_name of XDMF_SIDECAR_MAIN. */
PDLA_API int xdmf_sidecar_path(const char *h5_path, char *out, size_t len);

/* After h5_path was written: removes every sidecar kind of it whose
 * XDMF_SIDECAR_BIT is not in `written` (one left by an earlier run, of this
 * or another model, would describe datasets the new file may not have),
 * then syncs the folder if one was removed. A missing one is fine. 0, or
 * -1 with one line in err. */
PDLA_API int xdmf_remove_sidecars(const char *h5_path, unsigned written, char *err, size_t errlen);

/* Writes the sidecar of p to xmf_path: into xmf_path.tmp.<pid>, fsync'ed,
 * renamed over xmf_path (a sidecar describes the HDF5 file just written, so
 * an older one is stale), then the folder is fsync'ed. Nothing is written
 * for n == 0 (no points to show; XDMF readers refuse empty arrays) and an
 * older xmf_path is removed. 0, or -1 with one line in err; a failure
 * before the rename also removes an older xmf_path, which would describe
 * another file. */
PDLA_API int xdmf_write_points(const char *xmf_path, const xdmf_points *p, char *err, size_t errlen);

/* The sidecar of a cluster file written by pdla_output_write (positions in
 * /cluster/positions; "arrival" when arrival is set); the other kinds of
 * sidecar of h5_path are removed (xdmf_remove_sidecars). 0 or -1 with err. */
PDLA_API int xdmf_write_cluster(const char *h5_path, uint64_t n, int dim, int units_per_diameter,
                                int arrival, char *err, size_t errlen);

/* A sidecar's text on its way to the file (xdmf_write_text). */
typedef struct xdmf_out xdmf_out;

/* Appends printf-style text to o; after a failure (kept in o) nothing more
 * is written. */
PDLA_API void xdmf_printf(xdmf_out *o, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Appends s with XML's special characters escaped (for a file name). */
PDLA_API void xdmf_escaped(xdmf_out *o, const char *s);

/* The one way every sidecar is written, also by the models' own writers:
 * the text body(o, arg) appends, streamed through a 64 KiB buffer into
 * xmf_path.tmp.<pid>, fsync'ed, renamed over xmf_path, the folder fsync'ed;
 * a failure before the rename also removes an older xmf_path (it would
 * describe another file). 0, or -1 with one line in err. */
PDLA_API int xdmf_write_text(const char *xmf_path, void (*body)(xdmf_out *o, const void *arg), const void *arg,
                             char *err, size_t errlen);

/* An ensemble file (`pdla ensemble --keep-positions`): positions [M * n][dim]
 * with cluster i in rows i n .. i n + n - 1. The sidecar is a spatial
 * Collection of M Polyvertex grids ("cluster I", one ParaView block each),
 * each a HyperSlab of those rows, with the attributes "cluster" (I on every
 * point), "distance" (from the seed, diameters) and, when the rows are in
 * arrival order, "arrival" (0..n-1 within the cluster). */
typedef struct xdmf_ensemble {
    const char *h5_path;    /* the HDF5 file; the sidecar names its last component */
    const char *positions;  /* integer dataset [clusters * n][dim] */
    uint64_t clusters, n;   /* M >= 1 clusters of n >= 1 points */
    int dim;                /* 2 or 3 */
    int units_per_diameter; /* positions / this = diameters */
    int arrival;            /* rows of a cluster are in arrival order */
} xdmf_ensemble;

/* Writes e's sidecar to xmf_path as xdmf_write_points does (temporary,
 * fsync, rename; a failure removes an older xmf_path). 0 or -1 with err. */
PDLA_API int xdmf_write_ensemble(const char *xmf_path, const xdmf_ensemble *e, char *err, size_t errlen);

#endif
