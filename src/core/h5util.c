/*
 * h5util.c - the HDF5 writing helpers shared by output_h5.c (cluster.h5)
 * and checkpoint_write.c: one-line error messages with the most specific entry of
 * HDF5's error stack, attributes, groups and checksummed datasets without
 * time stamps, and the crash-safety steps around a file (reserve space
 * before the close, divert a failed close, sync, publish, sync the
 * directory). See h5util.h.
 */
#define _GNU_SOURCE /* renameat2 and RENAME_NOREPLACE, memfd_create, fallocate */

#include "h5util.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

/* Where messages go and which file they name. */


void h5u_one_line(char *s)
{
    for (; s && *s; s++)
        if (*s == '\n' || *s == '\r') *s = ' ';
}

/* Records a non-HDF5 failure; returns -1 for `return h5u_fail_msg(...)`. */
int h5u_fail_msg(const h5u_writer *w, const char *fmt, ...)
{
    if (w->err && w->errlen) { /* the library's one formatter (util.c): one line */
        char what[1024];
        va_list ap;
        va_start(ap, fmt);
        pdla_verrorf(-1, what, sizeof what, fmt, ap);
        va_end(ap);
        pdla_errorf(-1, w->err, w->errlen, "cannot write %s: %s", w->path, what);
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
int h5u_fail(const h5u_writer *w, const char *fmt, ...)
{
    char what[256], detail[DETAIL_LEN] = "";
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    /* No H5Eclear2: the next HDF5 API call starts from a clear stack. */
    if (H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, first_desc, detail) < 0) detail[0] = '\0';
    if (detail[0]) return h5u_fail_msg(w, "HDF5 could not %s (%s)", what, detail);
    return h5u_fail_msg(w, "HDF5 could not %s", what);
}

/* What kind of object a close names, for callers that pass a bare name: a
 * close can flush HDF5's cache and fail on a full disk, and "could not
 * close t" said nothing ("could not close dataset t" does). */
static const char *close_kind(herr_t (*close_fn)(hid_t), const char *what)
{
    if (!what[0] || !strncmp(what, "a ", 2) || !strncmp(what, "an ", 3)) return "";
    if (close_fn == H5Dclose) return "dataset ";
    if (close_fn == H5Aclose) return "attribute ";
    if (close_fn == H5Gclose) return "group ";
    if (close_fn == H5Fclose) return "file ";
    return "";
}

/* Closes an HDF5 id in an unwind: keeps the first failure, and reports a
 * failed close (which can be a failed write-back) only when all else went well. */
int h5u_close(const h5u_writer *w, int rc, hid_t id, herr_t (*close_fn)(hid_t), const char *what)
{
    if (id < 0) return rc;
    if (close_fn(id) < 0 && rc == 0) return h5u_fail(w, "close %s%s", close_kind(close_fn, what), what);
    return rc;
}

/* ---- attributes --------------------------------------------------------- */

/* n = 0: a scalar attribute; else a one-dimensional one of n values. */
static int attr_write_n(const h5u_writer *w, hid_t obj, const char *name, hid_t ftype, hid_t mtype,
                        const void *val, hsize_t n)
{
    int rc = -1;
    hid_t space = H5I_INVALID_HID, attr = H5I_INVALID_HID;
    if ((space = n ? H5Screate_simple(1, &n, NULL) : H5Screate(H5S_SCALAR)) < 0) {
        h5u_fail(w, "create a dataspace for attribute %s", name);
        goto fail;
    }
    if ((attr = H5Acreate2(obj, name, ftype, space, H5P_DEFAULT, H5P_DEFAULT)) < 0) {
        h5u_fail(w, "create attribute %s", name);
        goto fail;
    }
    if (H5Awrite(attr, mtype, val) < 0) {
        h5u_fail(w, "write attribute %s", name);
        goto fail;
    }
    rc = 0;
fail:
    rc = h5u_close(w, rc, attr, H5Aclose, name);
    return h5u_close(w, rc, space, H5Sclose, "an attribute dataspace");
}

int h5u_attr_write(const h5u_writer *w, hid_t obj, const char *name, hid_t ftype, hid_t mtype,
                   const void *val)
{
    return attr_write_n(w, obj, name, ftype, mtype, val, 0);
}

int h5u_attr_u64_array(const h5u_writer *w, hid_t obj, const char *name, const uint64_t *v,
                       size_t n)
{
    return attr_write_n(w, obj, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, v, (hsize_t)n);
}

int h5u_attr_int(const h5u_writer *w, hid_t obj, const char *name, int v)
{
    const int32_t x = (int32_t)v;
    return h5u_attr_write(w, obj, name, H5T_STD_I32LE, H5T_NATIVE_INT32, &x);
}

int h5u_attr_i64(const h5u_writer *w, hid_t obj, const char *name, int64_t v)
{
    return h5u_attr_write(w, obj, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &v);
}

int h5u_attr_u64(const h5u_writer *w, hid_t obj, const char *name, uint64_t v)
{
    return h5u_attr_write(w, obj, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &v);
}

int h5u_attr_f64(const h5u_writer *w, hid_t obj, const char *name, double v)
{
    return h5u_attr_write(w, obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &v);
}

int h5u_attr_str(const h5u_writer *w, hid_t obj, const char *name, const char *s)
{
    int rc = -1;
    hid_t type = H5I_INVALID_HID;
    if (s == NULL) s = "";
    /* Fixed length with the terminator stored: a C reader gets a terminated
     * string back by reading H5Tget_size() bytes. */
    if ((type = H5Tcopy(H5T_C_S1)) < 0 || H5Tset_size(type, strlen(s) + 1) < 0 ||
        H5Tset_strpad(type, H5T_STR_NULLTERM) < 0 || H5Tset_cset(type, H5T_CSET_UTF8) < 0) {
        h5u_fail(w, "make the string type of attribute %s", name);
        goto fail;
    }
    rc = h5u_attr_write(w, obj, name, type, type, s);
fail:
    return h5u_close(w, rc, type, H5Tclose, "a string type");
}

/* ---- groups and datasets ------------------------------------------------ */

hid_t h5u_create_file(const h5u_writer *w, const char *path)
{
    hid_t fapl = H5I_INVALID_HID, fcpl = H5I_INVALID_HID, file = H5I_INVALID_HID;
    /* The file creation properties carry the root group's, hence no time
     * stamps on / either. */
    if ((fapl = H5Pcreate(H5P_FILE_ACCESS)) < 0 || H5Pset_fapl_sec2(fapl) < 0 ||
        H5Pset_libver_bounds(fapl, H5F_LIBVER_V110, H5F_LIBVER_V110) < 0 ||
        H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG) < 0 ||
        (fcpl = H5Pcreate(H5P_FILE_CREATE)) < 0 || H5Pset_obj_track_times(fcpl, 0) < 0)
        h5u_fail(w, "make the file properties");
    else if ((file = H5Fcreate(path, H5F_ACC_TRUNC, fcpl, fapl)) < 0)
        h5u_fail(w, "create %s", path);
    int rc = file < 0 ? -1 : 0;
    rc = h5u_close(w, rc, fcpl, H5Pclose, "file creation properties");
    rc = h5u_close(w, rc, fapl, H5Pclose, "file access properties");
    if (rc < 0 && file >= 0) {
        h5u_close(w, rc, file, H5Fclose, path); /* keeps the first failure, already in w */
        return H5I_INVALID_HID;
    }
    return file;
}

hid_t h5u_group(const h5u_writer *w, hid_t loc, const char *name)
{
    hid_t gcpl = H5I_INVALID_HID, g = H5I_INVALID_HID;
    int rc = -1;
    if ((gcpl = H5Pcreate(H5P_GROUP_CREATE)) < 0 || H5Pset_obj_track_times(gcpl, 0) < 0) {
        h5u_fail(w, "make the creation properties of group %s", name);
        goto fail;
    }
    if ((g = H5Gcreate2(loc, name, H5P_DEFAULT, gcpl, H5P_DEFAULT)) < 0) {
        h5u_fail(w, "create group %s", name);
        goto fail;
    }
    rc = 0;
fail:
    rc = h5u_close(w, rc, gcpl, H5Pclose, "group creation properties");
    if (rc < 0) {
        h5u_close(w, rc, g, H5Gclose, name);
        return H5I_INVALID_HID;
    }
    return g;
}

/* A dataset of rank 1 or 2 whose first dimension is `rows`: chunked by
 * chunk_rows with Fletcher32 when it has rows, contiguous and empty if not. */
hid_t h5u_dataset(const h5u_writer *w, hid_t loc, const char *name, hid_t ftype, int rank,
                  hsize_t rows, hsize_t cols, hsize_t chunk_rows, hid_t *space_out)
{
    return h5u_dataset_z(w, loc, name, ftype, rank, rows, cols, chunk_rows, 0, space_out);
}

hid_t h5u_dataset_z(const h5u_writer *w, hid_t loc, const char *name, hid_t ftype, int rank,
                    hsize_t rows, hsize_t cols, hsize_t chunk_rows, int gzip, hid_t *space_out)
{
    const hsize_t dims[2] = {rows, cols};
    const hsize_t chunk[2] = {rows < chunk_rows ? rows : chunk_rows, cols};
    hid_t dcpl = H5I_INVALID_HID, space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    int rc = -1;
    if ((dcpl = H5Pcreate(H5P_DATASET_CREATE)) < 0 || H5Pset_obj_track_times(dcpl, 0) < 0) {
        h5u_fail(w, "make the creation properties of dataset %s", name);
        goto fail;
    }
    if (rows > 0 && H5Pset_chunk(dcpl, rank, chunk) < 0) {
        h5u_fail(w, "set chunking on dataset %s", name);
        goto fail;
    }
    /* Shuffle and deflate before the checksum, so Fletcher32 covers what is stored. */
    if (rows > 0 && gzip &&
        (H5Pset_shuffle(dcpl) < 0 || H5Pset_deflate(dcpl, (unsigned)gzip) < 0)) {
        h5u_fail(w, "set compression on dataset %s", name);
        goto fail;
    }
    if (rows > 0 && H5Pset_fletcher32(dcpl) < 0) {
        h5u_fail(w, "set Fletcher32 on dataset %s", name);
        goto fail;
    }
    if ((space = H5Screate_simple(rank, dims, NULL)) < 0) {
        h5u_fail(w, "create the dataspace of dataset %s", name);
        goto fail;
    }
    if ((d = H5Dcreate2(loc, name, ftype, space, H5P_DEFAULT, dcpl, H5P_DEFAULT)) < 0) {
        h5u_fail(w, "create dataset %s", name);
        goto fail;
    }
    rc = 0;
fail:
    rc = h5u_close(w, rc, dcpl, H5Pclose, "dataset creation properties");
    if (rc < 0) {
        h5u_close(w, rc, d, H5Dclose, name);
        h5u_close(w, rc, space, H5Sclose, "a dataspace");
        return H5I_INVALID_HID;
    }
    *space_out = space;
    return d;
}


/* ---- attribute groups --------------------------------------------------- */

/* One attribute per row of the table, typed by the row. */
static int write_param(const h5u_writer *w, hid_t g, const pdla_param_desc *d, const void *s)
{
    switch (d->type) {
    case PDLA_PT_U64: return h5u_attr_u64(w, g, d->name, pdla_param_get_u(d, s));
    case PDLA_PT_REAL: return h5u_attr_f64(w, g, d->name, pdla_param_get_real(d, s));
    case PDLA_PT_CHOICE: {
        char word[64];
        pdla_param_format(d, s, 0, word, sizeof word);
        return h5u_attr_str(w, g, d->name, word);
    }
    case PDLA_PT_STRING: {
        /* "(none)" for empty: what the event model's files have always held */
        const char *v = (const char *)s + d->offset;
        return h5u_attr_str(w, g, d->name, v[0] ? v : "(none)");
    }
    case PDLA_PT_BOX: { /* the lengths in use: as many as the row's count field says */
        const int n = *(const int *)((const char *)s + d->count_offset);
        uint64_t L[PDLA_PARAM_BOX_MAX];
        if (n < 1 || n > PDLA_PARAM_BOX_MAX) return h5u_fail(w, "parameter %s: %d lengths", d->name, n);
        for (int i = 0; i < n; i++) L[i] = ((const uint32_t *)((const char *)s + d->offset))[i];
        return h5u_attr_u64_array(w, g, d->name, L, (size_t)n);
    }
    default: return h5u_attr_int(w, g, d->name, (int)pdla_param_get_i(d, s));
    }
}

int h5u_write_param_table(const h5u_writer *w, hid_t file, const pdla_param_desc *t, size_t n,
                          const void *s)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = h5u_group(w, file, "parameters")) < 0) goto fail;
    for (size_t i = 0; i < n; i++)
        if (write_param(w, g, &t[i], s) < 0) goto fail;
    rc = 0;
fail:
    return h5u_close(w, rc, g, H5Gclose, "/parameters");
}

int h5u_write_parameters(const h5u_writer *w, hid_t file, const pdla_params *p)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    return h5u_write_param_table(w, file, t, n, p);
}

int h5u_write_code(const h5u_writer *w, hid_t file, const pdla_provenance *pv,
                   const char *command_line)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = h5u_group(w, file, "Code")) < 0) goto fail;
    if (h5u_attr_str(w, g, "version", pv->version) < 0 ||
        h5u_attr_str(w, g, "git_revision", pv->git_revision) < 0 ||
        h5u_attr_str(w, g, "compiler", pv->compiler) < 0 ||
        h5u_attr_str(w, g, "build_flags", pv->build_flags) < 0 ||
        h5u_attr_str(w, g, "hdf5_version", pv->hdf5_version) < 0 ||
        h5u_attr_str(w, g, "hwloc_version", pv->hwloc_version) < 0 ||
        h5u_attr_str(w, g, "topology", pv->topology) < 0 || h5u_attr_str(w, g, "host", pv->host) < 0 ||
        h5u_attr_str(w, g, "created_utc", pv->created_utc) < 0 ||
        h5u_attr_str(w, g, "command_line", command_line ? command_line : "unknown") < 0)
        goto fail;
    rc = 0;
fail:
    return h5u_close(w, rc, g, H5Gclose, "/Code");
}




/* HDF5 1.10 frees a file whose close failed yet keeps its id, and then
 * crashes at exit closing it again (HDFFV-11052, CVE-2020-10812; fixed in
 * 1.14.1). A close fails when its write-back fails (disk full, quota, I/O
 * error), so after a failure the file's descriptor is pointed at an
 * anonymous memory file: the close then completes (only what the caches
 * hold lands there, by default at most a few tens of MiB; the rest is
 * sparse), HDF5 lets go of everything, and the
 * unfinished temporary file is removed by name. Best effort: if this cannot
 * be set up, the close is tried as it is. */
void h5u_divert_writes(hid_t file)
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

/* HDF5 writes most metadata back only when the file closes, and a failed
 * close cannot be recovered from in 1.10 (see h5u_divert_writes); an explicit
 * H5Fflush does not help: once it fails, every later flush, and so the
 * close, fails too. So before the close, disk blocks are reserved for the
 * whole file plus what the close may add (measured: ~4 KiB for the groups'
 * metadata, plus the chunk index, ~20 bytes a chunk; reserved: 1 MiB plus
 * 1/512 of the file): a full disk or quota shows here, while the failure
 * can still be handled. FALLOC_FL_KEEP_SIZE leaves the file's size to HDF5;
 * trim_reserve() gives back the blocks past the end after the close. Where
 * the file system has no fallocate this is skipped, and a disk that fills
 * up exactly during the close is not caught. */
int h5u_reserve_space(const h5u_writer *w, hid_t file, const char *tmp)
{
    hsize_t size = 0;
    void *handle = NULL;
    if (H5Fget_filesize(file, &size) < 0 || H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 ||
        handle == NULL)
        return h5u_fail(w, "get the size and descriptor of %s", tmp);
    const int fd = *(const int *)handle;
    const off_t want = (off_t)(size + (UINT64_C(1) << 20) + size / 512);
    if (fallocate(fd, FALLOC_FL_KEEP_SIZE, 0, want) == 0) return 0;
    if (errno == EOPNOTSUPP || errno == ENOSYS || errno == EINVAL) return 0;
    return h5u_fail_msg(w, "cannot reserve %lld bytes for %s: %s", (long long)want, tmp,
                    strerror(errno));
}

/* Gives back the blocks h5u_reserve_space() kept past the end of the file
 * (truncating to the same size frees them on ext4 and XFS), then syncs it. */
int h5u_trim_and_sync(const char *tmp)
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

int h5u_fsync_dir(const char *p)
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
int h5u_publish(const char *tmp, const char *path)
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
     * another h5u_writer creating path in between. */
    struct stat st;
    if (lstat(path, &st) == 0) return PDLA_EEXIST;
    if (errno != ENOENT) return PDLA_EIO;
    return rename(tmp, path) == 0 ? 0 : PDLA_EIO;
}

int h5u_silence(h5u_quiet *q)
{
    q->on = 0;
    if (H5Eget_auto2(H5E_DEFAULT, &q->fn, &q->data) < 0 || H5Eset_auto2(H5E_DEFAULT, NULL, NULL) < 0)
        return -1;
    q->on = 1;
    return 0;
}

int h5u_restore(h5u_quiet *q)
{
    if (!q->on) return 0;
    q->on = 0;
    return H5Eset_auto2(H5E_DEFAULT, q->fn, q->data) < 0 ? -1 : 0;
}

/* pdla.h: HDF5 printing off for the calling thread, for good. */
int pdla_hdf5_quiet(void)
{
    return H5Eset_auto2(H5E_DEFAULT, NULL, NULL) < 0 ? PDLA_EIO : PDLA_OK;
}
