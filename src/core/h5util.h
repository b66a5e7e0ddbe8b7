/*
 * h5util.h - HDF5 writing helpers shared by output_h5.c and checkpoint_write.c.
 * Internal to libpdla.
 *
 * Every helper that can fail records one line "cannot write PATH: ..." in
 * the writer's err (with the most specific entry of HDF5's error stack when
 * HDF5 failed) and returns -1 (or H5I_INVALID_HID). HDF5 must have been
 * silenced by the caller (h5u_silence) so its error stack never prints.
 */
#ifndef PDLA_H5UTIL_H
#define PDLA_H5UTIL_H

#include <hdf5.h>
#include <stddef.h>
#include <stdint.h>

#include "pdla/pdla.h"
#include "pdla/params.h"
#include "provenance.h"

/* Where messages go and which file they name. */
typedef struct h5u_writer {
    const char *path; /* the final path: what the user asked for */
    char *err;
    size_t errlen;
} h5u_writer;

/* Newlines and carriage returns become blanks. */
void h5u_one_line(char *s);
int h5u_fail_msg(const h5u_writer *w, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
int h5u_fail(const h5u_writer *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Close an id in an unwind, keeping the first failure. */
int h5u_close(const h5u_writer *w, int rc, hid_t id, herr_t (*close_fn)(hid_t), const char *what);

int h5u_attr_write(const h5u_writer *w, hid_t obj, const char *name, hid_t ftype, hid_t mtype,
                   const void *val);
int h5u_attr_int(const h5u_writer *w, hid_t obj, const char *name, int v);
int h5u_attr_i64(const h5u_writer *w, hid_t obj, const char *name, int64_t v);
int h5u_attr_u64(const h5u_writer *w, hid_t obj, const char *name, uint64_t v);
int h5u_attr_f64(const h5u_writer *w, hid_t obj, const char *name, double v);
/* A one-dimensional attribute of n (> 0) unsigned 64-bit values. */
int h5u_attr_u64_array(const h5u_writer *w, hid_t obj, const char *name, const uint64_t *v,
                       size_t n);
int h5u_attr_str(const h5u_writer *w, hid_t obj, const char *name, const char *s);

/* A group without time stamps. */
/* Create (truncate) path in the 1.10 format, without object time stamps
 * and with H5F_CLOSE_STRONG (H5Fclose also closes anything an unwind left
 * open, so a failed write never keeps the file half-open). Returns the file
 * or a negative id with the reason in w. */
hid_t h5u_create_file(const h5u_writer *w, const char *path);

hid_t h5u_group(const h5u_writer *w, hid_t loc, const char *name);
/* A dataset of rank 1 or 2 whose first dimension is `rows`: chunked by
 * chunk_rows with Fletcher32 when it has rows, contiguous and empty if not.
 * h5u_dataset_z adds shuffle + deflate level gzip (0: none) before the checksum. */
hid_t h5u_dataset(const h5u_writer *w, hid_t loc, const char *name, hid_t ftype, int rank,
                  hsize_t rows, hsize_t cols, hsize_t chunk_rows, hid_t *space_out);
hid_t h5u_dataset_z(const h5u_writer *w, hid_t loc, const char *name, hid_t ftype, int rank,
                    hsize_t rows, hsize_t cols, hsize_t chunk_rows, int gzip, hid_t *space_out);

/* /parameters: one attribute per row of a parameter table (params.h), typed
 * by the row (a choice as its word); h5u_write_parameters for the DLA table. */
int h5u_write_param_table(const h5u_writer *w, hid_t file, const pdla_param_desc *t, size_t n,
                          const void *s);
int h5u_write_parameters(const h5u_writer *w, hid_t file, const pdla_params *p);
/* /Code: provenance strings. */
int h5u_write_code(const h5u_writer *w, hid_t file, const pdla_provenance *pv,
                   const char *command_line);

/* Crash safety (see the comments in h5util.c). */
void h5u_divert_writes(hid_t file);
int h5u_reserve_space(const h5u_writer *w, hid_t file, const char *tmp);
int h5u_trim_and_sync(const char *tmp);
int h5u_fsync_dir(const char *dir);
/* Moves tmp to path unless path exists: 0, PDLA_EEXIST, PDLA_EIO (errno
 * set), or 1 when path is in place but tmp could not be removed. */
int h5u_publish(const char *tmp, const char *path);

/* Turn HDF5's automatic error printing off for the calling thread (the
 * setting is per thread in thread-safe builds) and back on. */
typedef struct h5u_quiet {
    H5E_auto2_t fn;
    void *data;
    int on;
} h5u_quiet;
int h5u_silence(h5u_quiet *q);
int h5u_restore(h5u_quiet *q);
#endif
