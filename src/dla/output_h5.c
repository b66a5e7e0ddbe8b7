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
 * before starting (check_space) and before the close (h5u_reserve_space),
 * because HDF5 1.10 cannot recover from a failed close (h5u_divert_writes).
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
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <hdf5.h>

#include "pdla/pdla.h"
#include "h5util.h"
#include "provenance.h"

/* Rows per chunk of /cluster/positions: 768 KiB in 3D, which fits HDF5's
 * default 1 MiB chunk cache, and the positions are buffered to whole chunks
 * so each chunk is checksummed and written once. */
#define POS_CHUNK_ROWS 65536u
/* Rows per chunk of the gyration series (at most ~1000 rows in practice). */
#define SERIES_CHUNK_ROWS 65536u

/* ---- /cluster/positions, streamed from pdla_engine_visit ---------------- */

typedef struct pos_sink {
    const h5u_writer *w;
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
        h5u_fail(s->w, "select rows %llu.. of /cluster/positions", (unsigned long long)s->written);
        goto fail;
    }
    if (H5Dwrite(s->dset, H5T_NATIVE_INT32, mspace, s->fspace, H5P_DEFAULT, s->buf) < 0) {
        h5u_fail(s->w, "write rows %llu..%llu of /cluster/positions",
                (unsigned long long)s->written, (unsigned long long)(s->written + s->fill - 1));
        goto fail;
    }
    s->written += s->fill;
    s->fill = 0;
    rc = 0;
fail:
    return h5u_close(s->w, rc, mspace, H5Sclose, "a memory dataspace");
}

static int pos_visit(const int32_t *xyz, size_t n, void *user)
{
    pos_sink *const s = user;
    const size_t dim = (size_t)s->dim;
    if (s->written + s->fill + n > s->total) {
        h5u_fail_msg(s->w, "the engine visited more than the %llu particles it counts",
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

static int write_positions(const h5u_writer *w, hid_t file, const pdla_engine *e, uint64_t n)
{
    const pdla_params *const p = pdla_engine_params(e);
    pos_sink s = {w, H5I_INVALID_HID, H5I_INVALID_HID, p->dim, n, 0, NULL, 0, 0, 0};
    uint64_t n_arrival = 0;
    const int32_t *const arrival = pdla_engine_arrival(e, &n_arrival);
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = h5u_group(w, file, "cluster")) < 0) goto fail;
    s.dset = h5u_dataset(w, g, "positions", H5T_STD_I32LE, 2, n, (hsize_t)p->dim, POS_CHUNK_ROWS,
                          &s.fspace);
    if (s.dset < 0) goto fail;
    if (h5u_attr_str(w, s.dset, "units", "lattice units") < 0 ||
        h5u_attr_int(w, s.dset, "diameter_units", p->resolution) < 0 ||
        h5u_attr_str(w, s.dset, "order", arrival ? "arrival" : "tree (not arrival)") < 0)
        goto fail;
    if (arrival && n_arrival != n) {
        h5u_fail_msg(w, "the engine recorded %llu arrivals but counts %llu particles",
                 (unsigned long long)n_arrival, (unsigned long long)n);
        goto fail;
    }
    if (n > 0) {
        s.cap_rows = n < POS_CHUNK_ROWS ? (size_t)n : POS_CHUNK_ROWS;
        if (!(s.buf = malloc(s.cap_rows * (size_t)p->dim * sizeof *s.buf))) {
            h5u_fail_msg(w, "out of memory for a chunk of positions");
            goto fail;
        }
        /* Arrival order: the same chunked writer, fed from the record. */
        const int vrc = arrival ? pos_visit(arrival, (size_t)n, &s)
                                : pdla_engine_visit(e, pos_visit, &s);
        if (s.failed) goto fail;
        if (vrc != 0) {
            h5u_fail_msg(w, "the engine could not list the particles (code %d)", vrc);
            goto fail;
        }
        if (pos_flush(&s) < 0) goto fail;
        if (s.written != n) {
            h5u_fail_msg(w, "the engine visited %llu particles but counts %llu",
                     (unsigned long long)s.written, (unsigned long long)n);
            goto fail;
        }
    }
    rc = 0;
fail:
    free(s.buf);
    rc = h5u_close(w, rc, s.fspace, H5Sclose, "the positions dataspace");
    rc = h5u_close(w, rc, s.dset, H5Dclose, "/cluster/positions");
    return h5u_close(w, rc, g, H5Gclose, "/cluster");
}

/* ---- /gyration ---------------------------------------------------------- */

static int write_series(const h5u_writer *w, hid_t g, const char *name, hid_t ftype, hid_t mtype,
                        const void *data, size_t k, const char *units)
{
    char full[64];
    hid_t space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    int rc = -1;
    snprintf(full, sizeof full, "/gyration/%s", name);
    if ((d = h5u_dataset(w, g, name, ftype, 1, k, 1, SERIES_CHUNK_ROWS, &space)) < 0) goto fail;
    if (k > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
        h5u_fail(w, "write %s", full);
        goto fail;
    }
    if (h5u_attr_str(w, d, "units", units) < 0) goto fail;
    rc = 0;
fail:
    rc = h5u_close(w, rc, space, H5Sclose, "a series dataspace");
    return h5u_close(w, rc, d, H5Dclose, full);
}

static int write_gyration(const h5u_writer *w, hid_t file, const pdla_engine *e)
{
    const uint64_t *n = NULL;
    const double *rg = NULL;
    size_t k = 0;
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    pdla_engine_rg_series(e, &n, &rg, &k);
    if ((g = h5u_group(w, file, "gyration")) < 0) goto fail;
    if (write_series(w, g, "N", H5T_STD_U64LE, H5T_NATIVE_UINT64, n, k, "particles") < 0 ||
        write_series(w, g, "rg_diam", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, rg, k, "diameters") < 0)
        goto fail;
    rc = 0;
fail:
    return h5u_close(w, rc, g, H5Gclose, "/gyration");
}


static int write_results(const h5u_writer *w, hid_t file, const pdla_engine *e, const pdla_stats *s,
                         const pdla_run_info *info)
{
    const pdla_fit f = pdla_engine_fit(e);
    const int res = pdla_engine_params(e)->resolution;
    /* NaN marks a ratio without a denominator (no particles, no jumps). */
    const double jpp = s->particles ? (double)s->jumps / (double)s->particles : NAN;
    const double nspj = s->jumps ? s->grow_seconds * 1e9 / (double)s->jumps : NAN;
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = h5u_group(w, file, "results")) < 0) goto fail;
    if (h5u_attr_u64(w, g, "particles", s->particles) < 0 || h5u_attr_f64(w, g, "D_f", f.df) < 0 ||
        h5u_attr_f64(w, g, "D_f_err", f.df_err) < 0 || h5u_attr_u64(w, g, "fit_n_lo", f.n_lo) < 0 ||
        h5u_attr_u64(w, g, "fit_n_hi", f.n_hi) < 0 || h5u_attr_int(w, g, "fit_points", f.points) < 0 ||
        h5u_attr_f64(w, g, "prefactor_diam", f.prefactor_diam) < 0 ||
        h5u_attr_f64(w, g, "rg_diam", s->rg_diam) < 0 ||
        h5u_attr_i64(w, g, "r_ext_units", s->r_ext) < 0 ||
        h5u_attr_f64(w, g, "r_ext_diam", (double)s->r_ext / res) < 0 ||
        h5u_attr_u64(w, g, "walkers", s->walkers) < 0 || h5u_attr_u64(w, g, "jumps", s->jumps) < 0 ||
        h5u_attr_u64(w, g, "returns", s->returns) < 0 || h5u_attr_u64(w, g, "lost", s->lost) < 0 ||
        h5u_attr_u64(w, g, "killed", s->killed) < 0 || h5u_attr_u64(w, g, "restarts", s->restarts) < 0 ||
        h5u_attr_u64(w, g, "node_visits", s->node_visits) < 0 ||
        h5u_attr_u64(w, g, "particle_checks", s->particle_checks) < 0 ||
        h5u_attr_u64(w, g, "tree_bytes", (uint64_t)s->tree_bytes) < 0 ||
        h5u_attr_u64(w, g, "inner_nodes", s->inner_nodes) < 0 ||
        h5u_attr_u64(w, g, "leaves", s->leaves) < 0 || h5u_attr_u64(w, g, "chunks", s->chunks) < 0 ||
        h5u_attr_int(w, g, "root_level", s->root_level) < 0 ||
        h5u_attr_f64(w, g, "grow_seconds", s->grow_seconds) < 0 ||
        h5u_attr_f64(w, g, "parallel_seconds", s->parallel_seconds) < 0 ||
        h5u_attr_int(w, g, "threads", s->threads) < 0 ||
        h5u_attr_u64(w, g, "recheck_overlaps", s->recheck_overlaps) < 0 ||
        h5u_attr_u64(w, g, "recheck_continued", s->recheck_continued) < 0 ||
        h5u_attr_u64(w, g, "recheck_discarded", s->recheck_discarded) < 0 ||
        h5u_attr_u64(w, g, "stale_jumps", s->stale_jumps) < 0 ||
        h5u_attr_u64(w, g, "stale_births", s->stale_births) < 0 ||
        h5u_attr_u64(w, g, "claim_waits", s->claim_waits) < 0 ||
        h5u_attr_u64_array(w, g, "mutex_taken", s->mutex_taken, 3) < 0 ||
        h5u_attr_u64_array(w, g, "mutex_contended", s->mutex_contended, 3) < 0 ||
        h5u_attr_f64(w, g, "worker_cpu_seconds", s->worker_cpu_seconds) < 0 ||
        h5u_attr_str(w, g, "binding", s->binding) < 0 ||
        h5u_attr_f64(w, g, "wall_seconds", info->wall_seconds) < 0 ||
        h5u_attr_u64(w, g, "peak_rss_bytes", info->peak_rss_bytes) < 0 ||
        h5u_attr_f64(w, g, "jumps_per_particle", jpp) < 0 || h5u_attr_f64(w, g, "ns_per_jump", nspj) < 0)
        goto fail;
    rc = 0;
fail:
    return h5u_close(w, rc, g, H5Gclose, "/results");
}

/* ---- the file ----------------------------------------------------------- */

static const char units_text[] =
    "Positions are integers in lattice units; one particle diameter is "
    "/parameters resolution units (also /cluster/positions diameter_units). "
    "Names ending in _diam are in diameters, in _units in lattice units.";

/* Bytes the file will take, from above: positions in whole chunks (HDF5
 * stores the last, partial chunk at full size) with their checksums, the
 * series, and the reserve of h5u_reserve_space() for the metadata. */
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
static int check_space(const h5u_writer *w, const pdla_engine *e, const char *dir)
{
    struct statvfs fs;
    if (statvfs(dir, &fs) != 0 || fs.f_blocks == 0) return 0; /* open() will say what is wrong */
    const uint64_t need = size_estimate(e);
    /* A file size limit (ulimit -f) would also stop HDF5 half-way. */
    struct rlimit fl;
    if (getrlimit(RLIMIT_FSIZE, &fl) == 0 && fl.rlim_cur != RLIM_INFINITY && fl.rlim_cur < need)
        return h5u_fail_msg(w, "the file size limit (ulimit -f) is %llu bytes, about %llu needed",
                            (unsigned long long)fl.rlim_cur, (unsigned long long)need);
    const uint64_t avail = (uint64_t)fs.f_bavail * (uint64_t)fs.f_frsize;
    if (avail >= need) return 0;
    return h5u_fail_msg(w, "%s: about %llu bytes needed, %llu free in %s", strerror(ENOSPC),
                    (unsigned long long)need, (unsigned long long)avail, dir);
}

/* Writes everything into `tmp`, which exists and is empty, and closes it. */
static int write_file(const h5u_writer *w, const char *tmp, const pdla_engine *e,
                      const pdla_run_info *info, const pdla_provenance *pv)
{
    hid_t file = H5I_INVALID_HID;
    pdla_stats s;
    int rc = -1;
    pdla_engine_stats(e, &s);
    if ((file = h5u_create_file(w, tmp)) < 0) goto fail;
    if (h5u_attr_str(w, file, "format", "pdla-cluster") < 0 ||
        h5u_attr_int(w, file, "format_version", 1) < 0 || h5u_attr_str(w, file, "units", units_text) < 0 ||
        h5u_write_parameters(w, file, pdla_engine_params(e)) < 0 ||
        write_positions(w, file, e, s.particles) < 0 || write_gyration(w, file, e) < 0 ||
        write_results(w, file, e, &s, info) < 0 || h5u_write_code(w, file, pv, info->command_line) < 0)
        goto fail;
    if (h5u_reserve_space(w, file, tmp) < 0) goto fail;
    rc = 0;
fail:
    if (rc < 0 && file >= 0) h5u_divert_writes(file);
    return h5u_close(w, rc, file, H5Fclose, tmp);
}

/* The temporary name beside path and the directory to sync after the
 * rename (path up to its last '/'), malloc'ed; -1: out of memory. */
static int file_names(const char *path, char **tmp, char **dir)
{
    const size_t len = strlen(path);
    if (!(*tmp = malloc(len + 32)) || !(*dir = malloc(len + 2))) return -1;
    snprintf(*tmp, len + 32, "%s.tmp.%ld", path, (long)getpid());
    const char *const slash = strrchr(path, '/');
    if (!slash) {
        strcpy(*dir, ".");
    } else {
        const size_t dlen = slash == path ? 1 : (size_t)(slash - path);
        memcpy(*dir, path, dlen);
        (*dir)[dlen] = '\0';
    }
    return 0;
}

/* Creates the temporary file ourselves, exclusively, so we only ever
 * remove a file this call made (*made_tmp); HDF5 then truncates it. */
static int create_tmp(const h5u_writer *w, const char *tmp, int *made_tmp)
{
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) return h5u_fail_msg(w, "cannot create %s: %s", tmp, strerror(errno));
    *made_tmp = 1;
    if (close(fd) != 0) return h5u_fail_msg(w, "cannot close %s: %s", tmp, strerror(errno));
    return 0;
}

/* Moves the complete tmp to path (never over an existing file) and syncs
 * the directory. PDLA_OK, PDLA_EEXIST or PDLA_EIO with the reason in w;
 * *made_tmp drops to 0 once tmp is no longer ours to remove. */
static int publish(const h5u_writer *w, const char *tmp, const char *path, const char *dir,
                   int *made_tmp)
{
    const int prc = h5u_publish(tmp, path);
    if (prc == PDLA_EEXIST) {
        if (w->err && w->errlen) snprintf(w->err, w->errlen, "%s exists; not overwriting it", path);
        return PDLA_EEXIST;
    }
    if (prc < 0) {
        h5u_fail_msg(w, "cannot rename %s to it: %s", tmp, strerror(errno));
        return PDLA_EIO;
    }
    *made_tmp = 0; /* it is path now (or, prc == 1, a second name of it) */
    if (prc == 1) {
        /* Complete and in place; only a second name of it is left over. */
        h5u_fail_msg(w, "written, but cannot remove the link %s: %s", tmp, strerror(errno));
        return PDLA_EIO;
    }
    if (h5u_fsync_dir(dir) != 0) {
        /* The file is complete and in place, only its durability is unsure:
         * report it, but leave the file. */
        h5u_fail_msg(w, "written, but cannot sync directory %s: %s", dir, strerror(errno));
        return PDLA_EIO;
    }
    return PDLA_OK;
}

int pdla_output_write(const pdla_engine *e, const pdla_run_info *info, const char *path,
                      char *err, size_t errlen)
{
    static const pdla_run_info no_info = {NULL, 0.0, 0};
    const h5u_writer w = {path ? path : "(null)", err, errlen};
    H5E_auto2_t old_fn = NULL;
    void *old_data = NULL;
    int silenced = 0, made_tmp = 0, rc = PDLA_EIO;
    char *tmp = NULL, *dir = NULL;
    pdla_provenance pv;
    struct stat st;

    if (err && errlen) err[0] = '\0';
    if (!e || !path || !path[0]) {
        h5u_fail_msg(&w, "no engine or no path given");
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
        h5u_fail_msg(&w, "cannot check whether it exists: %s", strerror(errno));
        goto fail;
    }

    if (file_names(path, &tmp, &dir) < 0) {
        h5u_fail_msg(&w, "out of memory for file names");
        rc = PDLA_ENOMEM;
        goto fail;
    }

    if (check_space(&w, e, dir) < 0) goto fail;

    if (create_tmp(&w, tmp, &made_tmp) < 0) goto fail;

    /* HDF5 prints its error stack by default; the library never prints.
     * The setting is per thread in thread-safe HDF5 builds, process-wide
     * otherwise; it is restored below on every path. */
    if (H5Eget_auto2(H5E_DEFAULT, &old_fn, &old_data) < 0 ||
        H5Eset_auto2(H5E_DEFAULT, NULL, NULL) < 0) {
        h5u_fail_msg(&w, "cannot silence the HDF5 error stack");
        goto fail;
    }
    silenced = 1;

    (void)prov_collect(&pv); /* missing facts read "unknown": no reason to fail */
    if (write_file(&w, tmp, e, info, &pv) < 0) goto fail;
    if (h5u_trim_and_sync(tmp) != 0) {
        h5u_fail_msg(&w, "cannot sync %s: %s", tmp, strerror(errno));
        goto fail;
    }
    rc = publish(&w, tmp, path, dir, &made_tmp);

fail:
    if (made_tmp && unlink(tmp) != 0 && errno != ENOENT && err && errlen) {
        /* Keep the first failure and add the leftover to the same line. */
        const size_t used = strlen(err);
        snprintf(err + used, errlen - used, "; %s is left over (%s)", tmp, strerror(errno));
    }
    if (silenced && H5Eset_auto2(H5E_DEFAULT, old_fn, old_data) < 0 && rc == PDLA_OK) {
        h5u_fail_msg(&w, "cannot restore the HDF5 error handler");
        rc = PDLA_EIO;
    }
    if (err && errlen) h5u_one_line(err); /* paths may hold newlines */
    free(dir);
    free(tmp);
    return rc;
}
