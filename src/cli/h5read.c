/*
 * h5read.c - read side of the cluster file for the tools (see h5read.h),
 * and the tools' safe output files.
 */
#include "h5read.h"

#include "pdla/pdla.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int fail(char *err, size_t errlen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    pdla_verrorf(-1, err, errlen, fmt, ap);
    va_end(ap);
    return -1;
}

/* A scalar string attribute into buf; 0, or -1 if missing or not a string. */
/* Whether attribute a holds exactly one element (scalar or 1-element
 * array): H5Aread writes every element, and our buffers hold one. */
static int attr_is_single(hid_t a)
{
    const hid_t sp = H5Aget_space(a);
    if (sp < 0) return 0;
    const hssize_t n = H5Sget_simple_extent_npoints(sp);
    H5Sclose(sp);
    return n == 1;
}

static int read_str_attr(hid_t obj, const char *name, char *buf, size_t len)
{
    if (H5Aexists(obj, name) <= 0) return -1;
    const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    if (a < 0) return -1;
    int rc = -1;
    const hid_t t = H5Aget_type(a);
    if (t >= 0 && H5Tget_class(t) == H5T_STRING && attr_is_single(a)) {
        if (H5Tis_variable_str(t) > 0) {
            char *s = NULL;
            /* The file's own string type (ASCII or UTF-8, as h5py writes):
             * HDF5 will not convert between character sets. */
            const hid_t mt = H5Tcopy(t);
            if (H5Aread(a, mt, &s) >= 0 && s) {
                snprintf(buf, len, "%s", s);
                H5free_memory(s);
                rc = 0;
            }
            H5Tclose(mt);
        } else {
            const size_t sz = H5Tget_size(t);
            char *s = calloc(sz + 1, 1);
            if (s && H5Aread(a, t, s) >= 0) {
                snprintf(buf, len, "%s", s);
                rc = 0;
            }
            free(s);
        }
    }
    if (t >= 0) H5Tclose(t);
    H5Aclose(a);
    return rc;
}

static int read_int_attr(hid_t obj, const char *name, int64_t *v)
{
    if (H5Aexists(obj, name) <= 0) return -1;
    const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    if (a < 0) return -1;
    const hid_t t = H5Aget_type(a);
    int rc = -1;
    if (t >= 0 && H5Tget_class(t) == H5T_INTEGER && attr_is_single(a) &&
        H5Aread(a, H5T_NATIVE_INT64, v) >= 0)
        rc = 0;
    if (t >= 0) H5Tclose(t);
    H5Aclose(a);
    return rc;
}

/* Whether dataset d really stores elems elements (each esize bytes in memory)
 * rather than merely declaring them: a file of a few KB can declare 2^61
 * rows (chunked, nothing written), and readers must neither allocate nor
 * loop for what is not there. Compressed data may expand; deflate's limit
 * is about 1032:1, so filtered datasets get that much room. 0, or -1 with
 * a one-line reason. */
static int h5r_stored(hid_t d, uint64_t elems, size_t esize, const char *path, const char *name,
                      char *err, size_t errlen)
{
    if (elems == 0) return 0;
    if (elems > (uint64_t)(SIZE_MAX / 2) / esize || elems > (uint64_t)1 << 52)
        return fail(err, errlen, "%s: %s declares %llu elements, more than this machine can address",
                    path, name, (unsigned long long)elems);
    const hid_t t = H5Dget_type(d);
    const size_t fsize = t >= 0 ? H5Tget_size(t) : 0;
    if (t >= 0) H5Tclose(t);
    const hid_t dcpl = H5Dget_create_plist(d);
    const int nfilters = dcpl >= 0 ? H5Pget_nfilters(dcpl) : -1;
    if (dcpl >= 0) H5Pclose(dcpl);
    if (fsize == 0 || nfilters < 0)
        return fail(err, errlen, "%s: cannot read the layout of %s (damaged?)", path, name);
    const uint64_t stored = H5Dget_storage_size(d);
    const uint64_t room = nfilters > 0 ? 1100 : 1;
    const double need = (double)elems * (double)fsize;
    if (need > (double)stored * (double)room)
        return fail(err, errlen,
                    "%s: %s declares %llu elements (%.0f bytes) but the file stores only %llu bytes "
                    "of it (damaged or not written by pdla)",
                    path, name, (unsigned long long)elems, need, (unsigned long long)stored);
    return 0;
}

void h5r_close(h5r_file *f)
{
    if (f->fspace >= 0) H5Sclose(f->fspace);
    if (f->dset >= 0) H5Dclose(f->dset);
    if (f->file >= 0) H5Fclose(f->file);
    f->fspace = f->dset = f->file = H5I_INVALID_HID;
}

int h5r_open(h5r_file *f, const char *path, char *err, size_t errlen)
{
    memset(f, 0, sizeof *f);
    f->file = f->dset = f->fspace = H5I_INVALID_HID;
    f->path = path;
    /* The tools print their own one-line messages. */
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);

    struct stat st;
    if (stat(path, &st) != 0) return fail(err, errlen, "cannot open %s: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode)) return fail(err, errlen, "%s is a directory, not a cluster file", path);
    /* A FIFO or device would block or never end. */
    if (!S_ISREG(st.st_mode)) return fail(err, errlen, "%s is not a regular file, not a cluster file", path);
    const int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return fail(err, errlen, "cannot open %s: %s", path, strerror(errno));
    close(fd);
    if (H5Fis_hdf5(path) <= 0) return fail(err, errlen, "%s is not an HDF5 file", path);
    if ((f->file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT)) < 0)
        return fail(err, errlen, "%s: HDF5 cannot open it (damaged?)", path);

    char fmt[64];
    if (read_str_attr(f->file, "format", fmt, sizeof fmt) != 0) {
        h5r_close(f);
        return fail(err, errlen, "%s is not a pdla cluster file (no format = \"pdla-cluster\" attribute)",
                    path);
    }
    if (strcmp(fmt, "pdla-cluster") != 0) {
        h5r_close(f);
        return fail(err, errlen, "%s is not a pdla cluster file (format = \"%s\")", path, fmt);
    }
    int64_t v = 0;
    if (read_int_attr(f->file, "format_version", &v) != 0 || v != 1) {
        h5r_close(f);
        return fail(err, errlen, "%s: unsupported format_version (this pdla reads version 1)", path);
    }
    f->format_version = (int)v;

    if (H5Lexists(f->file, "/cluster", H5P_DEFAULT) <= 0 ||
        H5Lexists(f->file, "/cluster/positions", H5P_DEFAULT) <= 0 ||
        (f->dset = H5Dopen2(f->file, "/cluster/positions", H5P_DEFAULT)) < 0) {
        h5r_close(f);
        return fail(err, errlen, "%s has no /cluster/positions dataset", path);
    }
    const hid_t t = H5Dget_type(f->dset);
    const int is_int = t >= 0 && H5Tget_class(t) == H5T_INTEGER;
    if (t >= 0) H5Tclose(t);
    hsize_t dims[2] = {0, 0};
    f->fspace = H5Dget_space(f->dset);
    const int rank = f->fspace >= 0 ? H5Sget_simple_extent_ndims(f->fspace) : -1;
    if (!is_int || rank != 2 || H5Sget_simple_extent_dims(f->fspace, dims, NULL) != 2 ||
        (dims[1] != 2 && dims[1] != 3)) {
        h5r_close(f);
        if (!is_int) return fail(err, errlen, "%s: /cluster/positions is not an integer dataset", path);
        if (rank != 2)
            return fail(err, errlen, "%s: /cluster/positions has rank %d; want [N][2] or [N][3]", path,
                        rank);
        return fail(err, errlen, "%s: /cluster/positions has %llu columns; want 2 or 3", path,
                    (unsigned long long)dims[1]);
    }
    f->n = dims[0];
    f->dim = (int)dims[1];
    if (h5r_stored(f->dset, f->n * (uint64_t)f->dim, sizeof(int32_t), path, "/cluster/positions", err,
                   errlen)) {
        h5r_close(f);
        return -1;
    }

    /* Cross-check the declared dimension when /parameters has one. */
    if (H5Lexists(f->file, "/parameters", H5P_DEFAULT) > 0) {
        const hid_t g = H5Oopen(f->file, "/parameters", H5P_DEFAULT);
        if (g >= 0) {
            int64_t pd = 0;
            const int have = read_int_attr(g, "dim", &pd) == 0;
            int64_t res = 0;
            if (read_int_attr(g, "resolution", &res) == 0)
                f->diameter_units = res >= 1 && res <= 1 << 20 ? (int)res : -1;
            H5Oclose(g);
            if (have && pd != f->dim) {
                h5r_close(f);
                return fail(err, errlen,
                            "%s: /cluster/positions has %d columns but /parameters dim = %lld", path,
                            f->dim, (long long)pd);
            }
        }
    }
    /* Range-check the 64-bit value before narrowing: 2^32 + 32 is not 32. */
    if (read_int_attr(f->dset, "diameter_units", &v) == 0)
        f->diameter_units = v >= 1 && v <= 1 << 20 ? (int)v : -1;
    if (f->diameter_units < 1 || f->diameter_units > 1 << 20) {
        h5r_close(f);
        return fail(err, errlen, "%s: no valid diameter_units attribute on /cluster/positions", path);
    }
    if (read_str_attr(f->dset, "order", f->order, sizeof f->order) != 0)
        snprintf(f->order, sizeof f->order, "unknown");
    f->arrival = strcmp(f->order, "arrival") == 0;
    return 0;
}

int h5r_stream(h5r_file *f, size_t slab_rows, h5r_rows_fn fn, void *user, char *err, size_t errlen)
{
    if (slab_rows < 1 || slab_rows > H5R_MAX_SLAB_ROWS) slab_rows = H5R_MAX_SLAB_ROWS;
    if (f->n == 0) return 0;
    if (f->n < slab_rows) slab_rows = (size_t)f->n;
    const size_t dim = (size_t)f->dim;
    int32_t *buf = malloc(slab_rows * dim * sizeof *buf);
    if (!buf) return fail(err, errlen, "out of memory for %zu rows", slab_rows);
    int rc = 0;
    for (uint64_t first = 0; first < f->n && rc == 0; first += slab_rows) {
        const uint64_t left = f->n - first;
        const size_t rows = left < slab_rows ? (size_t)left : slab_rows;
        const hsize_t start[2] = {first, 0}, count[2] = {rows, dim};
        const hid_t ms = H5Screate_simple(2, count, NULL);
        if (ms < 0 || H5Sselect_hyperslab(f->fspace, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
            H5Dread(f->dset, H5T_NATIVE_INT32, ms, f->fspace, H5P_DEFAULT, buf) < 0) {
            rc = fail(err, errlen, "%s: cannot read rows %llu..%llu of /cluster/positions (damaged?)",
                      f->path, (unsigned long long)first, (unsigned long long)(first + rows - 1));
        } else {
            rc = fn(buf, rows, first, user);
        }
        if (ms >= 0) H5Sclose(ms);
    }
    free(buf);
    return rc;
}

/* A whole 1-D dataset of k rows in native type mt; *out malloc'ed. */
static int read_1d(h5r_file *f, const char *name, hid_t mt, size_t esize, void **out, size_t *k,
                   char *err, size_t errlen)
{
    *out = NULL;
    *k = 0;
    /* Absent: no series. A link that cannot be followed is damage, not absence. */
    const htri_t hg = H5Lexists(f->file, "/gyration", H5P_DEFAULT);
    const htri_t hn = hg > 0 ? H5Lexists(f->file, name, H5P_DEFAULT) : 0;
    if (hg < 0 || hn < 0 || (hg > 0 && H5Oexists_by_name(f->file, "/gyration", H5P_DEFAULT) <= 0) ||
        (hn > 0 && H5Oexists_by_name(f->file, name, H5P_DEFAULT) <= 0))
        return fail(err, errlen, "%s: cannot follow the link to %s (damaged?)", f->path, name);
    if (hn <= 0) return 0;
    const hid_t d = H5Dopen2(f->file, name, H5P_DEFAULT);
    if (d < 0) return fail(err, errlen, "%s: cannot open %s", f->path, name);
    const hid_t s = H5Dget_space(d);
    hsize_t dims[1] = {0};
    int rc = 0;
    if (s < 0 || H5Sget_simple_extent_ndims(s) != 1 || H5Sget_simple_extent_dims(s, dims, NULL) != 1) {
        rc = fail(err, errlen, "%s: %s is not one-dimensional", f->path, name);
    } else if (dims[0] > 0 && h5r_stored(d, dims[0], esize, f->path, name, err, errlen)) {
        rc = -1;
    } else if (dims[0] > 0) {
        void *buf = malloc((size_t)dims[0] * esize);
        if (!buf) rc = fail(err, errlen, "out of memory reading %s", name);
        else if (H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0) {
            free(buf);
            rc = fail(err, errlen, "%s: cannot read %s (damaged?)", f->path, name);
        } else {
            *out = buf;
            *k = (size_t)dims[0];
        }
    }
    if (s >= 0) H5Sclose(s);
    H5Dclose(d);
    return rc;
}

int h5r_read_series(h5r_file *f, uint64_t **n, double **rg_diam, size_t *k, char *err, size_t errlen)
{
    size_t kn = 0, kr = 0;
    void *pn = NULL, *pr = NULL;
    *n = NULL;
    *rg_diam = NULL;
    *k = 0;
    if (read_1d(f, "/gyration/N", H5T_NATIVE_UINT64, sizeof(uint64_t), &pn, &kn, err, errlen) ||
        read_1d(f, "/gyration/rg_diam", H5T_NATIVE_DOUBLE, sizeof(double), &pr, &kr, err, errlen)) {
        free(pn);
        free(pr);
        return -1;
    }
    if (kn != kr) {
        free(pn);
        free(pr);
        return fail(err, errlen, "%s: /gyration/N has %zu rows but /gyration/rg_diam %zu", f->path,
                    kn, kr);
    }
    *n = pn;
    *rg_diam = pr;
    *k = kn;
    return 0;
}

/* ---- attributes --------------------------------------------------------- */

static herr_t attr_cb(hid_t obj, const char *name, const H5A_info_t *info, void *data)
{
    (void)info;
    h5r_attrs *const out = data;
    const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    if (a < 0) return 0;
    const hid_t t = H5Aget_type(a), s = H5Aget_space(a);
    h5r_attr at;
    memset(&at, 0, sizeof at);
    snprintf(at.name, sizeof at.name, "%s", name);
    int ok = 0;
    if (t >= 0 && s >= 0 && H5Sget_simple_extent_npoints(s) == 1) {
        switch (H5Tget_class(t)) {
        case H5T_INTEGER:
            if (H5Tget_sign(t) == H5T_SGN_NONE) {
                at.kind = 'u';
                ok = H5Aread(a, H5T_NATIVE_UINT64, &at.u) >= 0;
                at.f = (double)at.u;
            } else {
                at.kind = 'i';
                ok = H5Aread(a, H5T_NATIVE_INT64, &at.i) >= 0;
                at.f = (double)at.i;
            }
            break;
        case H5T_FLOAT:
            at.kind = 'f';
            ok = H5Aread(a, H5T_NATIVE_DOUBLE, &at.f) >= 0;
            break;
        case H5T_STRING: {
            char tmp[4096];
            at.kind = 's';
            H5Aclose(a);
            ok = read_str_attr(obj, name, tmp, sizeof tmp) == 0 && (at.s = strdup(tmp)) != NULL;
            if (t >= 0) H5Tclose(t);
            if (s >= 0) H5Sclose(s);
            goto add;
        }
        default: break;
        }
    }
    H5Aclose(a);
    if (t >= 0) H5Tclose(t);
    if (s >= 0) H5Sclose(s);
add:
    if (!ok) {
        free(at.s);
        return 0; /* not a scalar we can show: skipped */
    }
    if (out->n == out->cap) {
        const size_t cap = out->cap ? 2 * out->cap : 32;
        h5r_attr *p = realloc(out->a, cap * sizeof *p);
        if (!p) {
            free(at.s);
            return -1;
        }
        out->a = p;
        out->cap = cap;
    }
    out->a[out->n++] = at;
    return 0;
}

int h5r_read_attrs(h5r_file *f, const char *where, h5r_attrs *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (strcmp(where, "/") != 0 && H5Lexists(f->file, where, H5P_DEFAULT) <= 0) return 0;
    const hid_t o = H5Oopen(f->file, where, H5P_DEFAULT);
    if (o < 0) return fail(err, errlen, "%s: cannot open %s", f->path, where);
    hsize_t idx = 0;
    const herr_t r = H5Aiterate2(o, H5_INDEX_NAME, H5_ITER_INC, &idx, attr_cb, out);
    H5Oclose(o);
    if (r < 0) {
        h5r_attrs_free(out);
        return fail(err, errlen, "%s: cannot read the attributes of %s", f->path, where);
    }
    return 0;
}

void h5r_attrs_free(h5r_attrs *a)
{
    for (size_t i = 0; i < a->n; i++) free(a->a[i].s);
    free(a->a);
    memset(a, 0, sizeof *a);
}

const h5r_attr *h5r_attr_find(const h5r_attrs *a, const char *name)
{
    for (size_t i = 0; i < a->n; i++)
        if (strcmp(a->a[i].name, name) == 0) return &a->a[i];
    return NULL;
}

double h5r_attr_num(const h5r_attrs *a, const char *name)
{
    const h5r_attr *const at = h5r_attr_find(a, name);
    return at && at->kind != 's' ? at->f : NAN;
}

/* ---- output files ------------------------------------------------------- */

int tools_out_check(const char *path, int force, char *err, size_t errlen)
{
    struct stat st;
    if (!path || !path[0]) return fail(err, errlen, "no output path given");
    if (lstat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode)) return fail(err, errlen, "%s is a directory", path);
        if (!force) return fail(err, errlen, "%s exists; not overwriting it (use --force)", path);
    } else if (errno != ENOENT) {
        return fail(err, errlen, "cannot check %s: %s", path, strerror(errno));
    }
    /* The directory it goes into must exist and take new files. */
    char *dir = strdup(path);
    if (!dir) return fail(err, errlen, "out of memory");
    char *const slash = strrchr(dir, '/');
    const char *d = ".";
    if (slash == dir) d = "/";
    else if (slash) {
        *slash = '\0';
        d = dir;
    }
    const int ok = access(d, W_OK | X_OK) == 0;
    const int e = errno;
    free(dir);
    if (!ok) return fail(err, errlen, "cannot write %s: %s", path, strerror(e));
    return 0;
}

FILE *tools_out_open(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen)
{
    snprintf(tmp, tmplen, "%s.tmp.%ld", path, (long)getpid());
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        fail(err, errlen, "cannot write %s: %s", path, strerror(errno));
        return NULL;
    }
    FILE *fp = fdopen(fd, "wb");
    if (!fp) {
        fail(err, errlen, "cannot write %s: %s", path, strerror(errno));
        close(fd);
        unlink(tmp);
    }
    return fp;
}

void tools_out_abort(FILE *fp, const char *tmp)
{
    if (fp) fclose(fp);
    unlink(tmp);
}

int tools_out_commit(FILE *fp, const char *tmp, const char *path, int force, char *err,
                     size_t errlen)
{
    const int bad = fflush(fp) != 0 || ferror(fp) || fsync(fileno(fp)) != 0;
    const int e = errno;
    if (fclose(fp) != 0 || bad) {
        unlink(tmp);
        return fail(err, errlen, "cannot write %s: %s", path, strerror(bad ? e : errno));
    }
    if (force) {
        if (rename(tmp, path) != 0) {
            const int re = errno;
            unlink(tmp);
            return fail(err, errlen, "cannot rename %s to %s: %s", tmp, path, strerror(re));
        }
        return 0;
    }
    /* No replace: a hard link fails if path appeared meanwhile. */
    if (link(tmp, path) == 0) {
        unlink(tmp);
        return 0;
    }
    const int le = errno;
    if (le == EEXIST) {
        unlink(tmp);
        return fail(err, errlen, "%s exists; not overwriting it (use --force)", path);
    }
    struct stat st;
    if (lstat(path, &st) == 0) {
        unlink(tmp);
        return fail(err, errlen, "%s exists; not overwriting it (use --force)", path);
    }
    if (rename(tmp, path) != 0) {
        const int re = errno;
        unlink(tmp);
        return fail(err, errlen, "cannot rename %s to %s: %s", tmp, path, strerror(re));
    }
    return 0;
}

int tools_option_error(const char *tool, char *const *argv, int optind_now, int optopt_now)
{
    if (optopt_now)
        fprintf(stderr, "pdla %s: option '%s' needs a value (see pdla %s --help)\n", tool,
                argv[optind_now - 1], tool);
    else
        fprintf(stderr, "pdla %s: unknown option '%s' (see pdla %s --help)\n", tool,
                argv[optind_now - 1], tool);
    return 2;
}

int tools_value_error(const char *tool, const char *value, const char *what)
{
    fprintf(stderr, "pdla %s: invalid value '%s' for %s\n", tool, value, what);
    return 2;
}

int tools_one_file(const char *tool, int optind_now, int argc)
{
    if (optind_now == argc - 1) return 0;
    fprintf(stderr, "pdla %s: %s (see pdla %s --help)\n", tool,
            optind_now >= argc ? "no FILE given" : "more than one FILE given", tool);
    return 2;
}
