/*
 * h5check.h - checked reading of HDF5 attributes and datasets: the one
 * reading layer of pdla, used by the checkpoint loader and by the tools
 * (`pdla info`, `render`, `analyze`, `export`, and the DLCA and event
 * models' info and render).
 *
 * Every reader checks what the file declares before it reads: an attribute
 * must hold exactly the one element the caller's buffer has room for (a
 * string must fit), and a dataset's rank, shape and element type are
 * reported so the caller can check them, together with whether the bytes
 * it declares are really stored (pdla_h5_dset_stored): a forged file of a
 * few KB can declare 2^61 rows, and no reader may allocate or loop for data
 * that is not there. The readers print nothing and return -1 (or a code);
 * the caller words the message, naming its file. HDF5's own error printing
 * must be off (pdla_hdf5_quiet).
 *
 * Ids are HDF5 hid_t values, passed as int64_t (hid_t is int64_t since
 * HDF5 1.10; h5check.c checks it), so this header needs no hdf5.h.
 */
#ifndef PDLA_H5CHECK_H
#define PDLA_H5CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/pdla.h"

typedef int64_t pdla_h5_id;

/* The memory types the readers convert to. */
typedef enum pdla_h5_type {
    PDLA_H5_U8,
    PDLA_H5_I32,
    PDLA_H5_U32,
    PDLA_H5_I64,
    PDLA_H5_U64,
    PDLA_H5_F64,
    PDLA_H5_I8 /* last: the values above keep their numbers */
} pdla_h5_type;

/* ---- attributes: 0 when read, -1 when missing or not as wanted ---------- */

/* One element whose class, size and sign are exactly t's (no conversion):
 * what pdla wrote, and nothing else. */
PDLA_API int pdla_h5_attr_exact(pdla_h5_id obj, const char *name, pdla_h5_type t, void *val);
/* One element converted to t by HDF5: an integer attribute for an integer
 * t, an integer or real one for PDLA_H5_F64. */
PDLA_API int pdla_h5_attr_number(pdla_h5_id obj, const char *name, pdla_h5_type t, void *val);
/* One string (fixed or variable length) into buf, always terminated:
 * 0 whole, 1 cut to len - 1 bytes, -1 missing, not one string or unreadable. */
PDLA_API int pdla_h5_attr_str(pdla_h5_id obj, const char *name, char *buf, size_t len);

/* Any attribute, for listing them: numbers of up to PDLA_H5_MAX_ELEMS
 * elements and single strings are read, other shapes only described. */
#define PDLA_H5_MAX_ELEMS 8
typedef struct pdla_h5_value {
    char kind; /* 'i' signed, 'u' unsigned integer, 'f' real, 's' string, 0 another class */
    int64_t n; /* elements it holds */
    int read;  /* 1: the fields below hold its value(s) */
    int64_t i[PDLA_H5_MAX_ELEMS];
    uint64_t u[PDLA_H5_MAX_ELEMS];
    double f[PDLA_H5_MAX_ELEMS]; /* also set for integers */
    char s[4096];                /* 's': the string */
    int cut;                     /* 's': cut to fit s */
} pdla_h5_value;
/* 0 (v->read says whether the value was read), or -1 when the attribute
 * cannot be opened or its type or shape read. */
PDLA_API int pdla_h5_attr_value(pdla_h5_id obj, const char *name, pdla_h5_value *v);

/* The root attribute `model` of the HDF5 file at path (the DLCA and event
 * models write one), quietly: 0 with the string, or -1 (not a regular
 * file, not HDF5, no such string). Never opens a FIFO or device. */
PDLA_API int pdla_h5_file_model(const char *path, char *model, size_t len);
/* The same for any string attribute of the root group (`format`, ...). */
PDLA_API int pdla_h5_file_attr(const char *path, const char *name, char *value, size_t len);

/* ---- datasets ------------------------------------------------------------ */

#define PDLA_H5_MAX_RANK 4
typedef struct pdla_h5_dset {
    pdla_h5_id id;
    char kind;   /* as pdla_h5_value.kind */
    size_t size; /* bytes per element in the file */
    int rank;    /* 0 (scalar) .. PDLA_H5_MAX_RANK */
    uint64_t dims[PDLA_H5_MAX_RANK];
    uint64_t elems;   /* the product of dims (UINT64_MAX when it overflows) */
    uint64_t stored;  /* bytes the file stores for it */
    int fletcher32;   /* carries the Fletcher32 checksum filter */
    int compressing;  /* carries a filter other than Fletcher32 (may shrink it) */
} pdla_h5_dset;

/* Opens loc/name when the link exists and resolves to a dataset of rank at
 * most PDLA_H5_MAX_RANK whose type, space and filters read back. 0, or -1
 * with d->id < 0. */
PDLA_API int pdla_h5_dset_open(pdla_h5_id loc, const char *name, pdla_h5_dset *d);
/* Closes d (if open): 0, or -1 when HDF5 failed to close it. A reader that
 * has read all it wanted treats -1 as a failed read; in an unwind after
 * another error the first error is the one to report. */
PDLA_API int pdla_h5_dset_close(pdla_h5_dset *d);
/* Whether d's elements have t's class (integer or real) and size. */
PDLA_API int pdla_h5_dset_is(const pdla_h5_dset *d, pdla_h5_type t);

/* Whether what d declares is there: PDLA_H5_STORED; PDLA_H5_TOO_LARGE when
 * its elements, esize bytes each in memory, could not be addressed;
 * PDLA_H5_NOT_STORED when it declares more bytes than the file holds for it
 * (times 1100 when a filter may have compressed them: deflate's limit is
 * about 1032:1; a checksum adds bytes, never removes them). */
enum { PDLA_H5_STORED = 0, PDLA_H5_TOO_LARGE = 1, PDLA_H5_NOT_STORED = 2 };
PDLA_API int pdla_h5_dset_stored(const pdla_h5_dset *d, size_t esize);

/* d's chunk dimensions into cd[0 .. rank): its rank when it is chunked, 0
 * when it is not (contiguous or compact), -1 when HDF5 failed. */
PDLA_API int pdla_h5_dset_chunk(const pdla_h5_dset *d, uint64_t *cd);
/* Reopens d, opened from loc/name, with a chunk cache that holds one whole
 * chunk, when it is chunked and a chunk is larger than HDF5's default
 * cache (1 MiB) but at most twice the dataset's bytes plus 1 MiB; else
 * leaves it as it is. For a reader that reads in slabs: a chunk the cache
 * cannot hold is decompressed again for every slab. Call it once the
 * dataset's size is checked (pdla_h5_dset_stored, the caller's memory
 * check), with nothing else holding the dataset open. 0, or -1 when HDF5
 * failed (d->id then invalid, or an id the caller still closes). */
PDLA_API int pdla_h5_dset_cache_chunk(pdla_h5_id loc, const char *name, pdla_h5_dset *d);

/* Reads rows [row0, row0 + nrows) of a rank 1 or 2 dataset, all columns,
 * converted to t, into buf. 0, or -1 (rows out of range, a value that does
 * not fit t, which HDF5 would clamp, a checksum or I/O error). */
PDLA_API int pdla_h5_dset_read(const pdla_h5_dset *d, pdla_h5_type t, uint64_t row0,
                               uint64_t nrows, void *buf);

#endif
