/*
 * h5read.h - reading a pdla cluster file (the layout of src/dla/output_h5.c)
 * for the tools: checks that it is one, streams /cluster/positions in
 * hyperslabs of bounded size, reads the R_g series and the attributes of
 * /parameters, /results and /Code. HDF5's own error printing is turned off
 * by h5r_open; every failure comes back as one line in err.
 */
#ifndef PDLA_CLI_H5READ_H
#define PDLA_CLI_H5READ_H

#include <stddef.h>
#include <stdint.h>

#include <hdf5.h>

#include "pdla/h5check.h"

/* Largest rows read at once; also the chunk size the writer uses. */
#define H5R_MAX_SLAB_ROWS 65536u

typedef struct h5r_file {
    hid_t file;
    pdla_h5_dset pos; /* /cluster/positions */
    const char *path;
    int format_version;
    int dim;            /* 2 or 3 */
    uint64_t n;         /* particles (rows of /cluster/positions) */
    int diameter_units; /* D: units per particle diameter */
    int arrival;        /* 1 when the rows are in arrival order */
    char order[64];     /* the order attribute as written */
    int damaged;        /* h5r_open failed on a file HDF5 calls its own but cannot open (truncated) */
} h5r_file;

/* One attribute: a scalar, or a short array of numbers (n of 2 to
 * PDLA_H5_MAX_ELEMS, as the /results mutex counters). kind: 'i' signed
 * integer, 'u' unsigned, 'f' real, 's' string (s is malloc'ed, scalars
 * only); i, u, f the first element, iv, uv, fv all n. */
typedef struct h5r_attr {
    char name[64];
    char kind;
    int n;
    int64_t i;
    uint64_t u;
    double f;
    char *s;
    int64_t iv[PDLA_H5_MAX_ELEMS];
    uint64_t uv[PDLA_H5_MAX_ELEMS];
    double fv[PDLA_H5_MAX_ELEMS];
} h5r_attr;

typedef struct h5r_attrs {
    h5r_attr *a;
    size_t n, cap;
} h5r_attrs;

/* Opens and checks path. 0, or -1 with err: missing or unreadable file, not
 * HDF5, no format = "pdla-cluster", positions of the wrong type or shape. */
int h5r_open(h5r_file *f, const char *path, char *err, size_t errlen);
/* 0, or -1 when HDF5 failed to close the file (a tool that read it all
 * reports that as a failed run). */
int h5r_close(h5r_file *f);
/* The end of a tool that read f: closes it, and when that fails after a
 * run that went well (code 0) prints "pdla TOOL: PATH: cannot close it" and
 * returns 1; else returns code. */
int h5r_close_tool(h5r_file *f, const char *tool, int code);

/* Calls fn on rows [0, n) in order, slab_rows (1..H5R_MAX_SLAB_ROWS) at a
 * time from one buffer of slab_rows * dim int32; `first` is the index of the
 * slab's first row. A non-zero return of fn stops and is returned; a read
 * failure returns -1 with err. */
typedef int (*h5r_rows_fn)(const int32_t *xyz, size_t rows, uint64_t first, void *user);
int h5r_stream(h5r_file *f, size_t slab_rows, h5r_rows_fn fn, void *user, char *err,
               size_t errlen);

/* The R_g series (/gyration/N, /gyration/rg_diam): malloc'ed arrays, k rows
 * (0 and NULLs when the file has none). 0 or -1 with err. */
int h5r_read_series(h5r_file *f, uint64_t **n, double **rg_diam, size_t *k, char *err,
                    size_t errlen);
/* The same, refusing (-1 with err, before any allocation) a series of more
 * than max_rows rows. */
int h5r_read_series_max(h5r_file *f, uint64_t max_rows, uint64_t **n, double **rg_diam, size_t *k, char *err,
                        size_t errlen);

/* Attributes of the object at `where` ("/", "/parameters", ...), in name
 * order: the scalars and the arrays of up to PDLA_H5_MAX_ELEMS numbers. A
 * missing object gives an empty list. 0 or -1 with err. */
int h5r_read_attrs(h5r_file *f, const char *where, h5r_attrs *out, char *err, size_t errlen);
void h5r_attrs_free(h5r_attrs *a);
const h5r_attr *h5r_attr_find(const h5r_attrs *a, const char *name);
/* An attribute as a number (NaN when missing or a string). */
double h5r_attr_num(const h5r_attrs *a, const char *name);

/* Tools' output files: refuse an existing path unless force; write to a
 * temporary name beside it and move it into place (replacing only with
 * force). tools_out_check runs before any work, so a bad -o fails early.
 * input (the file the tool reads; NULL: none) is refused as path even with
 * force when path names the same file (st_dev and st_ino; path not
 * followed if it is a link, which the rename would replace, not its
 * target): the output would replace what is being read. */
int tools_out_check(const char *path, const char *input, int force, char *err, size_t errlen);

/* The option errors every tool gives the same way (one line on stderr, the
 * tool named; each returns 2 = TOOL_USAGE so a caller can `return` it):
 * getopt's '?' (unknown option, or one whose value is missing: optopt != 0),
 * a value its parser refused (what = "--opt: want ..."), and FILE counts other
 * than one (returns 0 when exactly one FILE follows the options). */
int tools_option_error(const char *tool, char *const *argv, int optind_now, int optopt_now);
int tools_value_error(const char *tool, const char *value, const char *what);
/* Before a tool's getopt_long loop: resets getopt (opterr = 0, optind = 1)
 * and refuses an abbreviated long option (optcheck_exact), naming the tool.
 * 0, or 2 = TOOL_USAGE after the one line on stderr. */
struct option;
int tools_options_begin(const char *tool, int argc, char *const *argv,
                        const struct option *longopts, const char *shortopts);
int tools_one_file(const char *tool, int optind_now, int argc);
/* Returns a FILE* on path.tmp.<pid>; tools_out_commit closes, syncs and
 * renames it (removing it on failure). */
#include <stdio.h>
FILE *tools_out_open(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen);
int tools_out_commit(FILE *fp, const char *tmp, const char *path, int force, char *err,
                     size_t errlen);
void tools_out_abort(FILE *fp, const char *tmp);
/* An 8-bit RGB picture (w x h x 3, top row first) as the PNG at path,
 * through tools_out_* (png_out.c); force: it may replace a file. 0, or -1
 * with the one line in err. */
int tools_png_write(const char *path, int w, int h, const unsigned char *rgb, int force, char *err,
                    size_t errlen);

#endif
