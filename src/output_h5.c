/*
 * output_h5.c - pdla_output_write(): one run (cluster, R_g series, parameters,
 * results, provenance) into one self-describing HDF5 file.
 *
 * Layout (HDF5 1.10 file format; every string attribute is a fixed-length,
 * NUL-terminated UTF-8 scalar; integers are little-endian, reals IEEE f64):
 *
 *   /                    format = "pdla-cluster", format_version = 1 (i32),
 *                        units (text)
 *   /cluster/positions   i32 [N][dim], particle centres in lattice units, in
 *                        tree order, or in arrival order when the run had
 *                        record_arrival; attrs units, diameter_units (i32),
 *                        order ("tree (not arrival)" or "arrival")
 *   /gyration/N          u64 [k], particle counts of the R_g samples
 *   /gyration/rg_diam    f64 [k], R_g at those counts, in diameters
 *   /parameters          one attribute per pdla_params field
 *   /results             counters, the D_f fit and timings (attributes)
 *   /Code                provenance strings (attributes)
 *
 * A dataset with rows is chunked and Fletcher32-checksummed. A dataset with
 * no rows (k = 0 when sampling is off, N = 0 before the first grow) is still
 * written, with shape [0] or [0][dim] and contiguous layout, because HDF5
 * cannot chunk a zero-sized fixed dimension; readers thus never need to test
 * for a missing dataset.
 *
 * Object modification times are not recorded, so the same engine written
 * twice gives byte-identical files when /Code created_utc is the same (set
 * SOURCE_DATE_EPOCH to fix it); a repeated run also differs in its timing
 * results. Masking created_utc alone is not enough to compare files: HDF5
 * 1.10 metadata carries checksums over it.
 *
 * Safety: the file is made under path.tmp.<pid>, closed, fsync'ed and only
 * then renamed to path without replacing anything, and the directory is
 * fsync'ed; a failure removes the temporary file. A full disk is looked for
 * before starting (check_space) and before the close (reserve_space),
 * because HDF5 1.10 cannot recover from a failed close (divert_writes).
 */
#define _GNU_SOURCE /* renameat2 and RENAME_NOREPLACE */

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h> /* memfd_create */
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <hdf5.h>

#include "pdla/pdla.h"
#include "provenance.h"

/* Rows per chunk of /cluster/positions: 768 KiB in 3D, which fits HDF5's
 * default 1 MiB chunk cache, and the positions are buffered to whole chunks
 * so each chunk is checksummed and written once. */
#define POS_CHUNK_ROWS 65536u
/* Rows per chunk of the gyration series (at most ~1000 rows in practice). */
#define SERIES_CHUNK_ROWS 65536u

/* Where messages go and which file they name. */
typedef struct writer {
    const char *path; /* the final path: what the user asked for */
    char *err;
    size_t errlen;
} writer;

static void make_one_line(char *s)
{
    for (; s && *s; s++)
        if (*s == '\n' || *s == '\r') *s = ' ';
}

/* Records a non-HDF5 failure; returns -1 for `return fail_msg(...)`. */
static int fail_msg(const writer *w, const char *fmt, ...)
{
    if (w->err && w->errlen) {
        char what[1024];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(what, sizeof what, fmt, ap);
        va_end(ap);
        snprintf(w->err, w->errlen, "cannot write %s: %s", w->path, what);
        make_one_line(w->err);
    }
    return -1;
}

#define DETAIL_LEN 256

/* The most specific entry of HDF5's error stack, shortened: the low-level
 * ones read "file write failed: time = ..., filename = ..., errno = 27,
 * error message = 'File too large', buf = 0x..."; keep the part before the
 * first ':' and the system's message. */
static herr_t first_desc(unsigned n, const H5E_error2_t *e, void *data)
{
    char *const buf = data;
    if (n != 0 || !e || !e->desc) return 1;
    const char *const d = e->desc;
    const char *const colon = strchr(d, ':');
    const char *const msg = strstr(d, "error message = '");
    if (colon && msg) {
        const char *const m = msg + strlen("error message = '");
        const char *const q = strchr(m, '\'');
        snprintf(buf, DETAIL_LEN, "%.*s: %.*s", (int)(colon - d), d,
                 (int)(q ? (size_t)(q - m) : strlen(m)), m);
    } else {
        snprintf(buf, DETAIL_LEN, "%s", d);
    }
    return 1; /* only the most specific entry: stop the walk */
}

/* Records an HDF5 failure with the most specific entry of HDF5's error stack,
 * which must be read now: the next HDF5 call clears it. Returns -1. */
static int h5_fail(const writer *w, const char *fmt, ...)
{
    char what[256], detail[DETAIL_LEN] = "";
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    /* No H5Eclear2: the next HDF5 API call starts from a clear stack. */
    if (H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, first_desc, detail) < 0) detail[0] = '\0';
    if (detail[0]) return fail_msg(w, "HDF5 could not %s (%s)", what, detail);
    return fail_msg(w, "HDF5 could not %s", what);
}

/* Closes an HDF5 id in an unwind: keeps the first failure, and reports a
 * failed close (which can be a failed write-back) only when all else went well. */
static int close_h5(const writer *w, int rc, hid_t id, herr_t (*close_fn)(hid_t), const char *what)
{
    if (id < 0) return rc;
    if (close_fn(id) < 0 && rc == 0) return h5_fail(w, "close %s", what);
    return rc;
}

/* ---- attributes --------------------------------------------------------- */

static int attr_write(const writer *w, hid_t obj, const char *name, hid_t ftype, hid_t mtype,
                      const void *val)
{
    int rc = -1;
    hid_t space = H5I_INVALID_HID, attr = H5I_INVALID_HID;
    if ((space = H5Screate(H5S_SCALAR)) < 0) {
        h5_fail(w, "create a dataspace for attribute %s", name);
        goto fail;
    }
    if ((attr = H5Acreate2(obj, name, ftype, space, H5P_DEFAULT, H5P_DEFAULT)) < 0) {
        h5_fail(w, "create attribute %s", name);
        goto fail;
    }
    if (H5Awrite(attr, mtype, val) < 0) {
        h5_fail(w, "write attribute %s", name);
        goto fail;
    }
    rc = 0;
fail:
    rc = close_h5(w, rc, attr, H5Aclose, name);
    return close_h5(w, rc, space, H5Sclose, "an attribute dataspace");
}

static int attr_int(const writer *w, hid_t obj, const char *name, int v)
{
    const int32_t x = (int32_t)v;
    return attr_write(w, obj, name, H5T_STD_I32LE, H5T_NATIVE_INT32, &x);
}

static int attr_i64(const writer *w, hid_t obj, const char *name, int64_t v)
{
    return attr_write(w, obj, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &v);
}

static int attr_u64(const writer *w, hid_t obj, const char *name, uint64_t v)
{
    return attr_write(w, obj, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &v);
}

static int attr_f64(const writer *w, hid_t obj, const char *name, double v)
{
    return attr_write(w, obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &v);
}

static int attr_str(const writer *w, hid_t obj, const char *name, const char *s)
{
    int rc = -1;
    hid_t type = H5I_INVALID_HID;
    if (s == NULL) s = "";
    /* Fixed length with the terminator stored: a C reader gets a terminated
     * string back by reading H5Tget_size() bytes. */
    if ((type = H5Tcopy(H5T_C_S1)) < 0 || H5Tset_size(type, strlen(s) + 1) < 0 ||
        H5Tset_strpad(type, H5T_STR_NULLTERM) < 0 || H5Tset_cset(type, H5T_CSET_UTF8) < 0) {
        h5_fail(w, "make the string type of attribute %s", name);
        goto fail;
    }
    rc = attr_write(w, obj, name, type, type, s);
fail:
    return close_h5(w, rc, type, H5Tclose, "a string type");
}

/* ---- groups and datasets ------------------------------------------------ */

static hid_t make_group(const writer *w, hid_t loc, const char *name)
{
    hid_t gcpl = H5I_INVALID_HID, g = H5I_INVALID_HID;
    int rc = -1;
    if ((gcpl = H5Pcreate(H5P_GROUP_CREATE)) < 0 || H5Pset_obj_track_times(gcpl, 0) < 0) {
        h5_fail(w, "make the creation properties of group %s", name);
        goto fail;
    }
    if ((g = H5Gcreate2(loc, name, H5P_DEFAULT, gcpl, H5P_DEFAULT)) < 0) {
        h5_fail(w, "create group %s", name);
        goto fail;
    }
    rc = 0;
fail:
    rc = close_h5(w, rc, gcpl, H5Pclose, "group creation properties");
    if (rc < 0) {
        close_h5(w, rc, g, H5Gclose, name);
        return H5I_INVALID_HID;
    }
    return g;
}

/* A dataset of rank 1 or 2 whose first dimension is `rows`: chunked by
 * chunk_rows with Fletcher32 when it has rows, contiguous and empty if not. */
static hid_t make_dataset(const writer *w, hid_t loc, const char *name, hid_t ftype, int rank,
                          hsize_t rows, hsize_t cols, hsize_t chunk_rows, hid_t *space_out)
{
    const hsize_t dims[2] = {rows, cols};
    const hsize_t chunk[2] = {rows < chunk_rows ? rows : chunk_rows, cols};
    hid_t dcpl = H5I_INVALID_HID, space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    int rc = -1;
    if ((dcpl = H5Pcreate(H5P_DATASET_CREATE)) < 0 || H5Pset_obj_track_times(dcpl, 0) < 0) {
        h5_fail(w, "make the creation properties of dataset %s", name);
        goto fail;
    }
    if (rows > 0 && (H5Pset_chunk(dcpl, rank, chunk) < 0 || H5Pset_fletcher32(dcpl) < 0)) {
        h5_fail(w, "set chunking and Fletcher32 on dataset %s", name);
        goto fail;
    }
    if ((space = H5Screate_simple(rank, dims, NULL)) < 0) {
        h5_fail(w, "create the dataspace of dataset %s", name);
        goto fail;
    }
    if ((d = H5Dcreate2(loc, name, ftype, space, H5P_DEFAULT, dcpl, H5P_DEFAULT)) < 0) {
        h5_fail(w, "create dataset %s", name);
        goto fail;
    }
    rc = 0;
fail:
    rc = close_h5(w, rc, dcpl, H5Pclose, "dataset creation properties");
    if (rc < 0) {
        close_h5(w, rc, d, H5Dclose, name);
        close_h5(w, rc, space, H5Sclose, "a dataspace");
        return H5I_INVALID_HID;
    }
    *space_out = space;
    return d;
}

/* ---- /cluster/positions, streamed from pdla_engine_visit ---------------- */

typedef struct pos_sink {
    const writer *w;
    hid_t dset, fspace;
    int dim;
    uint64_t total;   /* rows the dataset holds */
    uint64_t written; /* rows already in the file */
    int32_t *buf;     /* one chunk of rows: memory stays bounded for any N */
    size_t fill, cap_rows;
    int failed;       /* a message is in w->err */
} pos_sink;

static int pos_flush(pos_sink *s)
{
    if (s->fill == 0) return 0;
    const hsize_t start[2] = {s->written, 0};
    const hsize_t count[2] = {s->fill, (hsize_t)s->dim};
    hid_t mspace = H5I_INVALID_HID;
    int rc = -1;
    if (H5Sselect_hyperslab(s->fspace, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
        (mspace = H5Screate_simple(2, count, NULL)) < 0) {
        h5_fail(s->w, "select rows %llu.. of /cluster/positions", (unsigned long long)s->written);
        goto fail;
    }
    if (H5Dwrite(s->dset, H5T_NATIVE_INT32, mspace, s->fspace, H5P_DEFAULT, s->buf) < 0) {
        h5_fail(s->w, "write rows %llu..%llu of /cluster/positions",
                (unsigned long long)s->written, (unsigned long long)(s->written + s->fill - 1));
        goto fail;
    }
    s->written += s->fill;
    s->fill = 0;
    rc = 0;
fail:
    return close_h5(s->w, rc, mspace, H5Sclose, "a memory dataspace");
}

static int pos_visit(const int32_t *xyz, size_t n, void *user)
{
    pos_sink *const s = user;
    const size_t dim = (size_t)s->dim;
    if (s->written + s->fill + n > s->total) {
        fail_msg(s->w, "the engine visited more than the %llu particles it counts",
                 (unsigned long long)s->total);
        goto fail;
    }
    while (n > 0) {
        const size_t take = n < s->cap_rows - s->fill ? n : s->cap_rows - s->fill;
        memcpy(s->buf + s->fill * dim, xyz, take * dim * sizeof *xyz);
        s->fill += take;
        xyz += take * dim;
        n -= take;
        if (s->fill == s->cap_rows && pos_flush(s) < 0) goto fail;
    }
    return 0;
fail:
    s->failed = 1;
    return 1; /* stops the visit; pdla_engine_visit hands this back */
}

static int write_positions(const writer *w, hid_t file, const pdla_engine *e, uint64_t n)
{
    const pdla_params *const p = pdla_engine_params(e);
    pos_sink s = {w, H5I_INVALID_HID, H5I_INVALID_HID, p->dim, n, 0, NULL, 0, 0, 0};
    uint64_t n_arrival = 0;
    const int32_t *const arrival = pdla_engine_arrival(e, &n_arrival);
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = make_group(w, file, "cluster")) < 0) goto fail;
    s.dset = make_dataset(w, g, "positions", H5T_STD_I32LE, 2, n, (hsize_t)p->dim, POS_CHUNK_ROWS,
                          &s.fspace);
    if (s.dset < 0) goto fail;
    if (attr_str(w, s.dset, "units", "lattice units") < 0 ||
        attr_int(w, s.dset, "diameter_units", p->resolution) < 0 ||
        attr_str(w, s.dset, "order", arrival ? "arrival" : "tree (not arrival)") < 0)
        goto fail;
    if (arrival && n_arrival != n) {
        fail_msg(w, "the engine recorded %llu arrivals but counts %llu particles",
                 (unsigned long long)n_arrival, (unsigned long long)n);
        goto fail;
    }
    if (n > 0) {
        s.cap_rows = n < POS_CHUNK_ROWS ? (size_t)n : POS_CHUNK_ROWS;
        if (!(s.buf = malloc(s.cap_rows * (size_t)p->dim * sizeof *s.buf))) {
            fail_msg(w, "out of memory for a chunk of positions");
            goto fail;
        }
        /* Arrival order: the same chunked writer, fed from the record. */
        const int vrc = arrival ? pos_visit(arrival, (size_t)n, &s)
                                : pdla_engine_visit(e, pos_visit, &s);
        if (s.failed) goto fail;
        if (vrc != 0) {
            fail_msg(w, "the engine could not list the particles (code %d)", vrc);
            goto fail;
        }
        if (pos_flush(&s) < 0) goto fail;
        if (s.written != n) {
            fail_msg(w, "the engine visited %llu particles but counts %llu",
                     (unsigned long long)s.written, (unsigned long long)n);
            goto fail;
        }
    }
    rc = 0;
fail:
    free(s.buf);
    rc = close_h5(w, rc, s.fspace, H5Sclose, "the positions dataspace");
    rc = close_h5(w, rc, s.dset, H5Dclose, "/cluster/positions");
    return close_h5(w, rc, g, H5Gclose, "/cluster");
}

/* ---- /gyration ---------------------------------------------------------- */

static int write_series(const writer *w, hid_t g, const char *name, hid_t ftype, hid_t mtype,
                        const void *data, size_t k, const char *units)
{
    char full[64];
    hid_t space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    int rc = -1;
    snprintf(full, sizeof full, "/gyration/%s", name);
    if ((d = make_dataset(w, g, name, ftype, 1, k, 1, SERIES_CHUNK_ROWS, &space)) < 0) goto fail;
    if (k > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
        h5_fail(w, "write %s", full);
        goto fail;
    }
    if (attr_str(w, d, "units", units) < 0) goto fail;
    rc = 0;
fail:
    rc = close_h5(w, rc, space, H5Sclose, "a series dataspace");
    return close_h5(w, rc, d, H5Dclose, full);
}

static int write_gyration(const writer *w, hid_t file, const pdla_engine *e)
{
    const uint64_t *n = NULL;
    const double *rg = NULL;
    size_t k = 0;
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    pdla_engine_rg_series(e, &n, &rg, &k);
    if ((g = make_group(w, file, "gyration")) < 0) goto fail;
    if (write_series(w, g, "N", H5T_STD_U64LE, H5T_NATIVE_UINT64, n, k, "particles") < 0 ||
        write_series(w, g, "rg_diam", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, rg, k, "diameters") < 0)
        goto fail;
    rc = 0;
fail:
    return close_h5(w, rc, g, H5Gclose, "/gyration");
}

/* ---- attribute groups --------------------------------------------------- */

static const char *return_mode_name(pdla_return_mode m)
{
    return m == PDLA_RETURN_EXACT ? "exact" : m == PDLA_RETURN_KILL ? "kill" : "invalid";
}

static const char *recheck_name(pdla_recheck_mode m)
{
    return m == PDLA_RECHECK_CONTINUE  ? "continue"
           : m == PDLA_RECHECK_DISCARD ? "discard"
                                       : "invalid";
}

static const char *bind_name(pdla_bind_mode m)
{
    return m == PDLA_BIND_NONE ? "none" : m == PDLA_BIND_CORE ? "core" : "invalid";
}

static int write_parameters(const writer *w, hid_t file, const pdla_params *p)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = make_group(w, file, "parameters")) < 0) goto fail;
    if (attr_int(w, g, "dim", p->dim) < 0 || attr_u64(w, g, "target", p->target) < 0 ||
        attr_u64(w, g, "seed", p->seed) < 0 || attr_int(w, g, "resolution", p->resolution) < 0 ||
        attr_int(w, g, "eps", p->eps) < 0 || attr_f64(w, g, "birth_margin", p->birth_margin) < 0 ||
        attr_str(w, g, "return_mode", return_mode_name(p->return_mode)) < 0 ||
        attr_f64(w, g, "kill_ratio", p->kill_ratio) < 0 ||
        attr_int(w, g, "exact_search", p->exact_search) < 0 ||
        attr_f64(w, g, "far_factor", p->far_factor) < 0 ||
        attr_u64(w, g, "max_jumps", p->max_jumps) < 0 ||
        attr_int(w, g, "snap_contact", p->snap_contact) < 0 ||
        attr_int(w, g, "rg_per_decade", p->rg_per_decade) < 0 ||
        attr_int(w, g, "threads", p->threads) < 0 ||
        attr_u64(w, g, "serial_until", p->serial_until) < 0 ||
        attr_str(w, g, "recheck", recheck_name(p->recheck)) < 0 ||
        attr_str(w, g, "bind", bind_name(p->bind)) < 0 ||
        attr_int(w, g, "record_arrival", p->record_arrival) < 0)
        goto fail;
    rc = 0;
fail:
    return close_h5(w, rc, g, H5Gclose, "/parameters");
}

static int write_results(const writer *w, hid_t file, const pdla_engine *e, const pdla_stats *s,
                         const pdla_run_info *info)
{
    const pdla_fit f = pdla_engine_fit(e);
    const int res = pdla_engine_params(e)->resolution;
    /* NaN marks a ratio without a denominator (no particles, no jumps). */
    const double jpp = s->particles ? (double)s->jumps / (double)s->particles : NAN;
    const double nspj = s->jumps ? s->grow_seconds * 1e9 / (double)s->jumps : NAN;
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = make_group(w, file, "results")) < 0) goto fail;
    if (attr_u64(w, g, "particles", s->particles) < 0 || attr_f64(w, g, "D_f", f.df) < 0 ||
        attr_f64(w, g, "D_f_err", f.df_err) < 0 || attr_u64(w, g, "fit_n_lo", f.n_lo) < 0 ||
        attr_u64(w, g, "fit_n_hi", f.n_hi) < 0 || attr_int(w, g, "fit_points", f.points) < 0 ||
        attr_f64(w, g, "prefactor_diam", f.prefactor_diam) < 0 ||
        attr_f64(w, g, "rg_diam", s->rg_diam) < 0 ||
        attr_i64(w, g, "r_ext_units", s->r_ext) < 0 ||
        attr_f64(w, g, "r_ext_diam", (double)s->r_ext / res) < 0 ||
        attr_u64(w, g, "walkers", s->walkers) < 0 || attr_u64(w, g, "jumps", s->jumps) < 0 ||
        attr_u64(w, g, "returns", s->returns) < 0 || attr_u64(w, g, "lost", s->lost) < 0 ||
        attr_u64(w, g, "killed", s->killed) < 0 || attr_u64(w, g, "restarts", s->restarts) < 0 ||
        attr_u64(w, g, "node_visits", s->node_visits) < 0 ||
        attr_u64(w, g, "particle_checks", s->particle_checks) < 0 ||
        attr_u64(w, g, "tree_bytes", (uint64_t)s->tree_bytes) < 0 ||
        attr_u64(w, g, "inner_nodes", s->inner_nodes) < 0 ||
        attr_u64(w, g, "leaves", s->leaves) < 0 || attr_u64(w, g, "chunks", s->chunks) < 0 ||
        attr_int(w, g, "root_level", s->root_level) < 0 ||
        attr_f64(w, g, "grow_seconds", s->grow_seconds) < 0 ||
        attr_f64(w, g, "parallel_seconds", s->parallel_seconds) < 0 ||
        attr_int(w, g, "threads", s->threads) < 0 ||
        attr_u64(w, g, "recheck_overlaps", s->recheck_overlaps) < 0 ||
        attr_u64(w, g, "recheck_continued", s->recheck_continued) < 0 ||
        attr_u64(w, g, "recheck_discarded", s->recheck_discarded) < 0 ||
        attr_str(w, g, "binding", s->binding) < 0 ||
        attr_f64(w, g, "wall_seconds", info->wall_seconds) < 0 ||
        attr_u64(w, g, "peak_rss_bytes", info->peak_rss_bytes) < 0 ||
        attr_f64(w, g, "jumps_per_particle", jpp) < 0 || attr_f64(w, g, "ns_per_jump", nspj) < 0)
        goto fail;
    rc = 0;
fail:
    return close_h5(w, rc, g, H5Gclose, "/results");
}

static int write_code(const writer *w, hid_t file, const pdla_provenance *pv,
                      const pdla_run_info *info)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = make_group(w, file, "Code")) < 0) goto fail;
    if (attr_str(w, g, "version", pv->version) < 0 ||
        attr_str(w, g, "git_revision", pv->git_revision) < 0 ||
        attr_str(w, g, "compiler", pv->compiler) < 0 ||
        attr_str(w, g, "build_flags", pv->build_flags) < 0 ||
        attr_str(w, g, "hdf5_version", pv->hdf5_version) < 0 ||
        attr_str(w, g, "hwloc_version", pv->hwloc_version) < 0 ||
        attr_str(w, g, "topology", pv->topology) < 0 || attr_str(w, g, "host", pv->host) < 0 ||
        attr_str(w, g, "created_utc", pv->created_utc) < 0 ||
        attr_str(w, g, "command_line", info->command_line ? info->command_line : "unknown") < 0)
        goto fail;
    rc = 0;
fail:
    return close_h5(w, rc, g, H5Gclose, "/Code");
}

/* ---- the file ----------------------------------------------------------- */

static const char units_text[] =
    "Positions are integers in lattice units; one particle diameter is "
    "/parameters resolution units (also /cluster/positions diameter_units). "
    "Names ending in _diam are in diameters, in _units in lattice units.";

/* HDF5 1.10 frees a file whose close failed yet keeps its id, and then
 * crashes at exit closing it again (HDFFV-11052, CVE-2020-10812; fixed in
 * 1.14.1). A close fails when its write-back fails (disk full, quota, I/O
 * error), so after a failure the file's descriptor is pointed at an
 * anonymous memory file: the close then completes (only what the caches
 * hold lands there, by default at most a few tens of MiB; the rest is
 * sparse), HDF5 lets go of everything, and the
 * unfinished temporary file is removed by name. Best effort: if this cannot
 * be set up, the close is tried as it is. */
static void divert_writes(hid_t file)
{
    void *handle = NULL;
    if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || handle == NULL) return;
    const int fd = *(const int *)handle; /* the sec2 driver's handle is its fd */
    const int sink = memfd_create("pdla-discard", MFD_CLOEXEC);
    if (sink < 0) return;
    /* Should dup2 fail, fd still names the file and the close is tried as is. */
    (void)dup2(sink, fd);
    close(sink);
}

/* Bytes the file will take, from above: positions in whole chunks (HDF5
 * stores the last, partial chunk at full size) with their checksums, the
 * series, and the reserve of reserve_space() for the metadata. */
static uint64_t size_estimate(const pdla_engine *e)
{
    const uint64_t n = pdla_engine_count(e);
    const uint64_t dim = (uint64_t)pdla_engine_params(e)->dim;
    const uint64_t rows = n < POS_CHUNK_ROWS ? n : POS_CHUNK_ROWS;
    const uint64_t chunks = rows ? (n + rows - 1) / rows : 0;
    const uint64_t *sn;
    const double *srg;
    size_t k;
    pdla_engine_rg_series(e, &sn, &srg, &k);
    const uint64_t data = chunks * (rows * dim * 4 + 4) + (uint64_t)k * 16 + 16;
    return data + (UINT64_C(1) << 20) + data / 512 + (UINT64_C(64) << 10);
}

/* A disk that is already too full is the common way for a write to fail,
 * and the cheapest to catch: before HDF5 starts, when nothing needs undoing.
 * (A failed H5Fcreate leaves HDF5 1.10 with leaked internals that it
 * complains about at exit.) Quotas are not seen here; file systems that
 * report no size (f_blocks == 0) are not checked. */
static int check_space(const writer *w, const pdla_engine *e, const char *dir)
{
    struct statvfs fs;
    if (statvfs(dir, &fs) != 0 || fs.f_blocks == 0) return 0; /* open() will say what is wrong */
    const uint64_t need = size_estimate(e);
    const uint64_t avail = (uint64_t)fs.f_bavail * (uint64_t)fs.f_frsize;
    if (avail >= need) return 0;
    return fail_msg(w, "%s: about %llu bytes needed, %llu free in %s", strerror(ENOSPC),
                    (unsigned long long)need, (unsigned long long)avail, dir);
}

/* HDF5 writes most metadata back only when the file closes, and a failed
 * close cannot be recovered from in 1.10 (see divert_writes); an explicit
 * H5Fflush does not help: once it fails, every later flush, and so the
 * close, fails too. So before the close, disk blocks are reserved for the
 * whole file plus what the close may add (measured: ~4 KiB for the groups'
 * metadata, plus the chunk index, ~20 bytes a chunk; reserved: 1 MiB plus
 * 1/512 of the file): a full disk or quota shows here, while the failure
 * can still be handled. FALLOC_FL_KEEP_SIZE leaves the file's size to HDF5;
 * trim_reserve() gives back the blocks past the end after the close. Where
 * the file system has no fallocate this is skipped, and a disk that fills
 * up exactly during the close is not caught. */
static int reserve_space(const writer *w, hid_t file, const char *tmp)
{
    hsize_t size = 0;
    void *handle = NULL;
    if (H5Fget_filesize(file, &size) < 0 || H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 ||
        handle == NULL)
        return h5_fail(w, "get the size and descriptor of %s", tmp);
    const int fd = *(const int *)handle;
    const off_t want = (off_t)(size + (UINT64_C(1) << 20) + size / 512);
    if (fallocate(fd, FALLOC_FL_KEEP_SIZE, 0, want) == 0) return 0;
    if (errno == EOPNOTSUPP || errno == ENOSYS || errno == EINVAL) return 0;
    return fail_msg(w, "cannot reserve %lld bytes for %s: %s", (long long)want, tmp,
                    strerror(errno));
}

/* Gives back the blocks reserve_space() kept past the end of the file
 * (truncating to the same size frees them on ext4 and XFS), then syncs it. */
static int trim_and_sync(const char *tmp)
{
    const int fd = open(tmp, O_WRONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    struct stat st;
    int r = fstat(fd, &st) == 0 && ftruncate(fd, st.st_size) == 0 && fsync(fd) == 0 ? 0 : -1;
    const int saved = errno;
    if (close(fd) != 0 && r == 0) r = -1;
    else errno = saved;
    return r;
}

/* Writes everything into `tmp`, which exists and is empty, and closes it. */
static int write_file(const writer *w, const char *tmp, const pdla_engine *e,
                      const pdla_run_info *info, const pdla_provenance *pv)
{
    hid_t fapl = H5I_INVALID_HID, fcpl = H5I_INVALID_HID, file = H5I_INVALID_HID;
    pdla_stats s;
    int rc = -1;
    pdla_engine_stats(e, &s);
    /* STRONG: H5Fclose also closes anything an unwind left open, so a failed
     * write never keeps the file half-open. The file creation properties
     * carry the root group's, hence no time stamps on / either. */
    if ((fapl = H5Pcreate(H5P_FILE_ACCESS)) < 0 || H5Pset_fapl_sec2(fapl) < 0 ||
        H5Pset_libver_bounds(fapl, H5F_LIBVER_V110, H5F_LIBVER_V110) < 0 ||
        H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG) < 0 ||
        (fcpl = H5Pcreate(H5P_FILE_CREATE)) < 0 || H5Pset_obj_track_times(fcpl, 0) < 0) {
        h5_fail(w, "make the file properties");
        goto fail;
    }
    if ((file = H5Fcreate(tmp, H5F_ACC_TRUNC, fcpl, fapl)) < 0) {
        h5_fail(w, "create %s", tmp);
        goto fail;
    }
    if (attr_str(w, file, "format", "pdla-cluster") < 0 ||
        attr_int(w, file, "format_version", 1) < 0 || attr_str(w, file, "units", units_text) < 0 ||
        write_parameters(w, file, pdla_engine_params(e)) < 0 ||
        write_positions(w, file, e, s.particles) < 0 || write_gyration(w, file, e) < 0 ||
        write_results(w, file, e, &s, info) < 0 || write_code(w, file, pv, info) < 0)
        goto fail;
    if (reserve_space(w, file, tmp) < 0) goto fail;
    rc = 0;
fail:
    if (rc < 0 && file >= 0) divert_writes(file);
    rc = close_h5(w, rc, file, H5Fclose, tmp);
    rc = close_h5(w, rc, fcpl, H5Pclose, "file creation properties");
    return close_h5(w, rc, fapl, H5Pclose, "file access properties");
}

static int fsync_dir(const char *p)
{
    const int fd = open(p, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return -1;
    /* Some file systems cannot sync a directory (EINVAL): nothing to do then. */
    const int r = fsync(fd) == 0 || errno == EINVAL ? 0 : -1;
    const int saved = errno;
    close(fd);
    errno = saved;
    return r;
}

/* Moves tmp to path unless path exists. Returns 0, PDLA_EEXIST, PDLA_EIO
 * (with errno set), or 1 when path is in place but the temporary hard link
 * could not be removed (errno set). */
static int publish(const char *tmp, const char *path)
{
#ifdef RENAME_NOREPLACE
    if (renameat2(AT_FDCWD, tmp, AT_FDCWD, path, RENAME_NOREPLACE) == 0) return 0;
    if (errno == EEXIST) return PDLA_EEXIST;
    /* Kernels or file systems without RENAME_NOREPLACE: try a hard link. */
    if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP && errno != EOPNOTSUPP)
        return PDLA_EIO;
#endif
    if (link(tmp, path) == 0) return unlink(tmp) == 0 ? 0 : 1;
    if (errno == EEXIST) return PDLA_EEXIST;
    if (errno != EPERM && errno != ENOTSUP && errno != EOPNOTSUPP && errno != ENOSYS &&
        errno != EMLINK)
        return PDLA_EIO;
    /* No hard links either (e.g. FAT): a checked rename, racy only against
     * another writer creating path in between. */
    struct stat st;
    if (lstat(path, &st) == 0) return PDLA_EEXIST;
    if (errno != ENOENT) return PDLA_EIO;
    return rename(tmp, path) == 0 ? 0 : PDLA_EIO;
}

int pdla_output_write(const pdla_engine *e, const pdla_run_info *info, const char *path,
                      char *err, size_t errlen)
{
    static const pdla_run_info no_info = {NULL, 0.0, 0};
    const writer w = {path ? path : "(null)", err, errlen};
    H5E_auto2_t old_fn = NULL;
    void *old_data = NULL;
    int silenced = 0, made_tmp = 0, rc = PDLA_EIO;
    char *tmp = NULL, *dir = NULL;
    pdla_provenance pv;
    struct stat st;

    if (err && errlen) err[0] = '\0';
    if (!e || !path || !path[0]) {
        fail_msg(&w, "no engine or no path given");
        rc = PDLA_EINVAL;
        goto fail;
    }
    if (!info) info = &no_info;
    /* lstat: a dangling symbolic link counts as existing too. */
    if (lstat(path, &st) == 0) {
        if (err && errlen) snprintf(err, errlen, "%s exists; not overwriting it", path);
        rc = PDLA_EEXIST;
        goto fail;
    }
    if (errno != ENOENT) {
        fail_msg(&w, "cannot check whether it exists: %s", strerror(errno));
        goto fail;
    }

    const size_t len = strlen(path);
    if (!(tmp = malloc(len + 32)) || !(dir = malloc(len + 2))) {
        fail_msg(&w, "out of memory for file names");
        rc = PDLA_ENOMEM;
        goto fail;
    }
    snprintf(tmp, len + 32, "%s.tmp.%ld", path, (long)getpid());
    /* The directory to sync after the rename: path up to its last '/'. */
    const char *const slash = strrchr(path, '/');
    if (!slash) {
        strcpy(dir, ".");
    } else {
        const size_t dlen = slash == path ? 1 : (size_t)(slash - path);
        memcpy(dir, path, dlen);
        dir[dlen] = '\0';
    }

    if (check_space(&w, e, dir) < 0) goto fail;

    /* Create the temporary file ourselves, exclusively, so we only ever
     * remove a file this call made; HDF5 then truncates it. */
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        fail_msg(&w, "cannot create %s: %s", tmp, strerror(errno));
        goto fail;
    }
    made_tmp = 1;
    if (close(fd) != 0) {
        fail_msg(&w, "cannot close %s: %s", tmp, strerror(errno));
        goto fail;
    }

    /* HDF5 prints its error stack by default; the library never prints.
     * The setting is per thread in thread-safe HDF5 builds, process-wide
     * otherwise; it is restored below on every path. */
    if (H5Eget_auto2(H5E_DEFAULT, &old_fn, &old_data) < 0 ||
        H5Eset_auto2(H5E_DEFAULT, NULL, NULL) < 0) {
        fail_msg(&w, "cannot silence the HDF5 error stack");
        goto fail;
    }
    silenced = 1;

    (void)prov_collect(&pv); /* missing facts read "unknown": no reason to fail */
    if (write_file(&w, tmp, e, info, &pv) < 0) goto fail;
    if (trim_and_sync(tmp) != 0) {
        fail_msg(&w, "cannot sync %s: %s", tmp, strerror(errno));
        goto fail;
    }
    const int prc = publish(tmp, path);
    if (prc == PDLA_EEXIST) {
        if (err && errlen) snprintf(err, errlen, "%s exists; not overwriting it", path);
        rc = PDLA_EEXIST;
        goto fail;
    }
    if (prc < 0) {
        fail_msg(&w, "cannot rename %s to it: %s", tmp, strerror(errno));
        goto fail;
    }
    if (prc == 1) {
        /* Complete and in place; only a second name of it is left over. */
        fail_msg(&w, "written, but cannot remove the link %s: %s", tmp, strerror(errno));
        made_tmp = 0;
        goto fail;
    }
    made_tmp = 0; /* it is path now */
    if (fsync_dir(dir) != 0) {
        /* The file is complete and in place, only its durability is unsure:
         * report it, but leave the file. */
        fail_msg(&w, "written, but cannot sync directory %s: %s", dir, strerror(errno));
        goto fail;
    }
    rc = PDLA_OK;

fail:
    if (made_tmp && unlink(tmp) != 0 && errno != ENOENT && err && errlen) {
        /* Keep the first failure and add the leftover to the same line. */
        const size_t used = strlen(err);
        snprintf(err + used, errlen - used, "; %s is left over (%s)", tmp, strerror(errno));
    }
    if (silenced && H5Eset_auto2(H5E_DEFAULT, old_fn, old_data) < 0 && rc == PDLA_OK) {
        fail_msg(&w, "cannot restore the HDF5 error handler");
        rc = PDLA_EIO;
    }
    if (err && errlen) make_one_line(err); /* paths may hold newlines */
    free(dir);
    free(tmp);
    return rc;
}
