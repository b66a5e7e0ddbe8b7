/*
 * h5read.c - read side of the cluster file for the tools (see h5read.h),
 * and the tools' safe output files.
 */
#include "h5read.h"
#include "tools.h"
#include "optcheck.h"

#include "pdla/pdla.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Whether dataset d really stores its elements (each esize bytes in
 * memory) rather than merely declaring them (pdla_h5_dset_stored). 0, or
 * -1 with a one-line reason. */
static int h5r_stored(const pdla_h5_dset *d, size_t esize, const char *path, const char *name,
                      char *err, size_t errlen)
{
    switch (pdla_h5_dset_stored(d, esize)) {
    case PDLA_H5_STORED: return 0;
    case PDLA_H5_TOO_LARGE:
        return pdla_errorf(-1, err, errlen, "%s: %s declares %llu elements, more than this machine can address",
                    path, name, (unsigned long long)d->elems);
    default:
        return pdla_errorf(-1, err, errlen,
                    "%s: %s declares %llu elements (%.0f bytes) but the file stores only %llu bytes "
                    "of it (damaged or not written by pdla)",
                    path, name, (unsigned long long)d->elems, (double)d->elems * (double)d->size,
                    (unsigned long long)d->stored);
    }
}

int h5r_close(h5r_file *f)
{
    int rc = pdla_h5_dset_close(&f->pos);
    if (f->file >= 0 && H5Fclose(f->file) < 0) rc = -1;
    f->file = H5I_INVALID_HID;
    return rc;
}

int h5r_close_tool(h5r_file *f, const char *tool, int code)
{
    if (h5r_close(f) == 0 || code != 0) return code;
    fprintf(stderr, "pdla %s: %s: cannot close it\n", tool, f->path);
    return 1;
}

/* A regular file that HDF5 opens; -1 with err. */
static int open_file(h5r_file *f, char *err, size_t errlen)
{
    const char *const path = f->path;
    struct stat st;
    if (stat(path, &st) != 0) return pdla_errorf(-1, err, errlen, "cannot open %s: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode)) return pdla_errorf(-1, err, errlen, "%s is a directory, not a cluster file", path);
    /* A FIFO or device would block or never end. */
    if (!S_ISREG(st.st_mode)) return pdla_errorf(-1, err, errlen, "%s is not a regular file, not a cluster file", path);
    const int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return pdla_errorf(-1, err, errlen, "cannot open %s: %s", path, strerror(errno));
    close(fd);
    if (H5Fis_hdf5(path) <= 0) return pdla_errorf(-1, err, errlen, "%s is not an HDF5 file", path);
    if ((f->file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT)) < 0) {
        f->damaged = 1; /* the HDF5 signature is there: a damaged file, not a foreign one */
        return pdla_errorf(-1, err, errlen, "%s: HDF5 cannot open it (damaged?)", path);
    }
    return 0;
}

/* format = "pdla-cluster", format_version = 1. */
static int check_format(h5r_file *f, char *err, size_t errlen)
{
    char fmt[64];
    if (pdla_h5_attr_str(f->file, "format", fmt, sizeof fmt) < 0)
        return pdla_errorf(-1, err, errlen, "%s is not a pdla cluster file (no format = \"pdla-cluster\" attribute)",
                    f->path);
    if (strcmp(fmt, "pdla-cluster") != 0)
        return pdla_errorf(-1, err, errlen, "%s is not a pdla cluster file (format = \"%s\")", f->path, fmt);
    int64_t v = 0;
    if (pdla_h5_attr_number(f->file, "format_version", PDLA_H5_I64, &v) != 0 || v != 1)
        return pdla_errorf(-1, err, errlen, "%s: unsupported format_version (this pdla reads version 1)", f->path);
    f->format_version = (int)v;
    return 0;
}

/* /cluster/positions: integer [N][2] or [N][3], all of it stored. */
static int open_positions(h5r_file *f, char *err, size_t errlen)
{
    const char *const path = f->path;
    if (H5Lexists(f->file, "/cluster", H5P_DEFAULT) <= 0 ||
        H5Lexists(f->file, "/cluster/positions", H5P_DEFAULT) <= 0 ||
        pdla_h5_dset_open(f->file, "/cluster/positions", &f->pos) < 0)
        return pdla_errorf(-1, err, errlen, "%s has no /cluster/positions dataset", path);
    const pdla_h5_dset *d = &f->pos;
    if (d->kind != 'i' && d->kind != 'u')
        return pdla_errorf(-1, err, errlen, "%s: /cluster/positions is not an integer dataset", path);
    if (d->rank != 2)
        return pdla_errorf(-1, err, errlen, "%s: /cluster/positions has rank %d; want [N][2] or [N][3]", path,
                    d->rank);
    if (d->dims[1] != 2 && d->dims[1] != 3)
        return pdla_errorf(-1, err, errlen, "%s: /cluster/positions has %llu columns; want 2 or 3", path,
                    (unsigned long long)d->dims[1]);
    f->n = d->dims[0];
    f->dim = (int)d->dims[1];
    if (h5r_stored(d, sizeof(int32_t), path, "/cluster/positions", err, errlen)) return -1;
    /* h5r_stream reads slabs of H5R_MAX_SLAB_ROWS rows: a foreign file's
     * one gzip'ed chunk larger than HDF5's 1 MiB cache was decompressed
     * again for each (analyze, two passes over 2e6 rows: 62 times). */
    if (pdla_h5_dset_cache_chunk(f->file, "/cluster/positions", &f->pos) < 0)
        return pdla_errorf(-1, err, errlen, "%s: cannot reopen /cluster/positions with a chunk cache", path);
    return 0;
}

/* The units per diameter (/cluster/positions diameter_units, else
 * /parameters resolution), and /parameters dim against the columns. */
static int read_units(h5r_file *f, char *err, size_t errlen)
{
    if (H5Lexists(f->file, "/parameters", H5P_DEFAULT) > 0) {
        const hid_t g = H5Oopen(f->file, "/parameters", H5P_DEFAULT);
        if (g >= 0) {
            int64_t pd = 0;
            const int have = pdla_h5_attr_number(g, "dim", PDLA_H5_I64, &pd) == 0;
            int64_t res = 0;
            if (pdla_h5_attr_number(g, "resolution", PDLA_H5_I64, &res) == 0)
                f->diameter_units = res >= 1 && res <= 1 << 20 ? (int)res : -1;
            if (H5Oclose(g) < 0)
                return pdla_errorf(-1, err, errlen, "%s: cannot close /parameters", f->path);
            if (have && pd != f->dim)
                return pdla_errorf(-1, err, errlen,
                            "%s: /cluster/positions has %d columns but /parameters dim = %lld", f->path,
                            f->dim, (long long)pd);
        }
    }
    /* Range-check the 64-bit value before narrowing: 2^32 + 32 is not 32. */
    int64_t v = 0;
    if (pdla_h5_attr_number(f->pos.id, "diameter_units", PDLA_H5_I64, &v) == 0)
        f->diameter_units = v >= 1 && v <= 1 << 20 ? (int)v : -1;
    if (f->diameter_units < 1 || f->diameter_units > 1 << 20)
        return pdla_errorf(-1, err, errlen, "%s: no valid diameter_units attribute on /cluster/positions", f->path);
    return 0;
}

int h5r_open(h5r_file *f, const char *path, char *err, size_t errlen)
{
    memset(f, 0, sizeof *f);
    f->file = f->pos.id = H5I_INVALID_HID;
    f->path = path;
    /* The tools print their own one-line messages. */
    if (pdla_hdf5_quiet()) return pdla_errorf(-1, err, errlen, "%s: cannot silence HDF5", path);
    if (open_file(f, err, errlen) || check_format(f, err, errlen) || open_positions(f, err, errlen) ||
        read_units(f, err, errlen)) {
        (void)h5r_close(f); /* the failure to report is the one in err */
        return -1;
    }
    if (pdla_h5_attr_str(f->pos.id, "order", f->order, sizeof f->order) < 0)
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
    if (!buf) return pdla_errorf(-1, err, errlen, "out of memory for %zu rows", slab_rows);
    int rc = 0;
    for (uint64_t first = 0; first < f->n && rc == 0; first += slab_rows) {
        const uint64_t left = f->n - first;
        const size_t rows = left < slab_rows ? (size_t)left : slab_rows;
        if (pdla_h5_dset_read(&f->pos, PDLA_H5_I32, first, rows, buf) < 0) {
            rc = pdla_errorf(-1, err, errlen, "%s: cannot read rows %llu..%llu of /cluster/positions (damaged, or a value "
                                             "beyond 32-bit integers?)",
                      f->path, (unsigned long long)first, (unsigned long long)(first + rows - 1));
        } else {
            rc = fn(buf, rows, first, user);
        }
    }
    free(buf);
    return rc;
}

/* A whole 1-D dataset of k rows in native type mt; *out malloc'ed. */
static int read_1d(h5r_file *f, const char *name, pdla_h5_type mt, size_t esize, uint64_t max_rows, void **out,
                   size_t *k, char *err, size_t errlen)
{
    *out = NULL;
    *k = 0;
    /* Absent: no series. A link that cannot be followed is damage, not absence. */
    const htri_t hg = H5Lexists(f->file, "/gyration", H5P_DEFAULT);
    const htri_t hn = hg > 0 ? H5Lexists(f->file, name, H5P_DEFAULT) : 0;
    if (hg < 0 || hn < 0 || (hg > 0 && H5Oexists_by_name(f->file, "/gyration", H5P_DEFAULT) <= 0) ||
        (hn > 0 && H5Oexists_by_name(f->file, name, H5P_DEFAULT) <= 0))
        return pdla_errorf(-1, err, errlen, "%s: cannot follow the link to %s (damaged?)", f->path, name);
    if (hn <= 0) return 0;
    pdla_h5_dset d;
    if (pdla_h5_dset_open(f->file, name, &d) < 0) return pdla_errorf(-1, err, errlen, "%s: cannot open %s", f->path, name);
    const uint64_t rows = d.dims[0];
    int rc = 0;
    if (d.rank != 1) {
        rc = pdla_errorf(-1, err, errlen, "%s: %s is not one-dimensional", f->path, name);
    } else if (rows > max_rows) {
        rc = pdla_errorf(-1, err, errlen, "%s: %s has %llu rows, more than the %llu a cluster of this size samples",
                         f->path, name, (unsigned long long)rows, (unsigned long long)max_rows);
    } else if (rows > 0 && h5r_stored(&d, esize, f->path, name, err, errlen)) {
        rc = -1;
    } else if (rows > 0) {
        void *buf = malloc((size_t)rows * esize);
        if (!buf) rc = pdla_errorf(-1, err, errlen, "out of memory reading %s", name);
        else if (pdla_h5_dset_read(&d, mt, 0, rows, buf) < 0) {
            free(buf);
            rc = pdla_errorf(-1, err, errlen, "%s: cannot read %s (damaged?)", f->path, name);
        } else {
            *out = buf;
            *k = (size_t)rows;
        }
    }
    if (pdla_h5_dset_close(&d) < 0 && rc == 0) {
        free(*out);
        *out = NULL;
        *k = 0;
        rc = pdla_errorf(-1, err, errlen, "%s: cannot close %s", f->path, name);
    }
    return rc;
}

int h5r_read_series(h5r_file *f, uint64_t **n, double **rg_diam, size_t *k, char *err, size_t errlen)
{
    return h5r_read_series_max(f, UINT64_MAX, n, rg_diam, k, err, errlen);
}

int h5r_read_series_max(h5r_file *f, uint64_t max_rows, uint64_t **n, double **rg_diam, size_t *k, char *err,
                        size_t errlen)
{
    size_t kn = 0, kr = 0;
    void *pn = NULL, *pr = NULL;
    *n = NULL;
    *rg_diam = NULL;
    *k = 0;
    if (read_1d(f, "/gyration/N", PDLA_H5_U64, sizeof(uint64_t), max_rows, &pn, &kn, err, errlen) ||
        read_1d(f, "/gyration/rg_diam", PDLA_H5_F64, sizeof(double), max_rows, &pr, &kr, err, errlen)) {
        free(pn);
        free(pr);
        return -1;
    }
    if (kn != kr) {
        free(pn);
        free(pr);
        return pdla_errorf(-1, err, errlen, "%s: /gyration/N has %zu rows but /gyration/rg_diam %zu", f->path,
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
    pdla_h5_value v;
    /* Scalars are listed, and arrays of a few numbers (pdla's mutex
     * counters); a string cut to 4 KB is still one. */
    if (pdla_h5_attr_value(obj, name, &v) < 0 || !v.read || v.n < 1 || v.n > PDLA_H5_MAX_ELEMS ||
        (v.n > 1 && v.kind == 's'))
        return 0;
    h5r_attr at;
    memset(&at, 0, sizeof at);
    snprintf(at.name, sizeof at.name, "%s", name);
    at.kind = v.kind;
    at.n = (int)v.n;
    at.i = v.i[0];
    at.u = v.u[0];
    at.f = v.f[0];
    memcpy(at.iv, v.i, sizeof at.iv);
    memcpy(at.uv, v.u, sizeof at.uv);
    memcpy(at.fv, v.f, sizeof at.fv);
    if (v.kind == 's' && !(at.s = strdup(v.s))) return -1;
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
    if (o < 0) return pdla_errorf(-1, err, errlen, "%s: cannot open %s", f->path, where);
    hsize_t idx = 0;
    const herr_t r = H5Aiterate2(o, H5_INDEX_NAME, H5_ITER_INC, &idx, attr_cb, out);
    if (H5Oclose(o) < 0 || r < 0) {
        h5r_attrs_free(out);
        return pdla_errorf(-1, err, errlen, "%s: cannot read the attributes of %s", f->path, where);
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
        if (a->a[i].n == 1 && strcmp(a->a[i].name, name) == 0) return &a->a[i]; /* a scalar, as asked for */
    return NULL;
}

double h5r_attr_num(const h5r_attrs *a, const char *name)
{
    const h5r_attr *const at = h5r_attr_find(a, name);
    return at && at->kind != 's' ? at->f : NAN;
}

/* ---- output files ------------------------------------------------------- */

int tools_out_check(const char *path, const char *input, int force, char *err, size_t errlen)
{
    struct stat st, in;
    if (!path || !path[0]) return pdla_errorf(-1, err, errlen, "no output path given");
    if (lstat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode)) return pdla_errorf(-1, err, errlen, "%s is a directory", path);
        if (input && stat(input, &in) == 0 && in.st_dev == st.st_dev && in.st_ino == st.st_ino)
            return pdla_errorf(-1, err, errlen, "%s is the input file; not writing over it (even with --force)", path);
        if (!force) return pdla_errorf(-1, err, errlen, "%s exists; not overwriting it (use --force)", path);
    } else if (errno != ENOENT) {
        return pdla_errorf(-1, err, errlen, "cannot check %s: %s", path, strerror(errno));
    }
    /* The directory it goes into must exist and take new files. */
    char *dir = strdup(path);
    if (!dir) return pdla_errorf(-1, err, errlen, "out of memory");
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
    if (!ok) return pdla_errorf(-1, err, errlen, "cannot write %s: %s", path, strerror(e));
    return 0;
}

FILE *tools_out_open(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen)
{
    snprintf(tmp, tmplen, "%s.tmp.%ld", path, (long)getpid());
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        pdla_errorf(-1, err, errlen, "cannot write %s: %s", path, strerror(errno));
        return NULL;
    }
    FILE *fp = fdopen(fd, "wb");
    if (!fp) {
        pdla_errorf(-1, err, errlen, "cannot write %s: %s", path, strerror(errno));
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
        return pdla_errorf(-1, err, errlen, "cannot write %s: %s", path, strerror(bad ? e : errno));
    }
    if (force) {
        if (rename(tmp, path) != 0) {
            const int re = errno;
            unlink(tmp);
            return pdla_errorf(-1, err, errlen, "cannot rename %s to %s: %s", tmp, path, strerror(re));
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
        return pdla_errorf(-1, err, errlen, "%s exists; not overwriting it (use --force)", path);
    }
    struct stat st;
    if (lstat(path, &st) == 0) {
        unlink(tmp);
        return pdla_errorf(-1, err, errlen, "%s exists; not overwriting it (use --force)", path);
    }
    if (rename(tmp, path) != 0) {
        const int re = errno;
        unlink(tmp);
        return pdla_errorf(-1, err, errlen, "cannot rename %s to %s: %s", tmp, path, strerror(re));
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

int tools_options_begin(const char *tool, int argc, char *const *argv,
                        const struct option *longopts, const char *shortopts)
{
    opterr = 0;
    optind = 1;
    char oerr[160];
    if (!optcheck_exact(argc, argv, longopts, shortopts, oerr, sizeof oerr)) return 0;
    fprintf(stderr, "pdla %s: %s\n", tool, oerr);
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

int tools_stdout_done(const char *tool)
{
    if (!fflush(stdout) && !ferror(stdout)) return 0;
    fprintf(stderr, "pdla %s: cannot write to stdout\n", tool);
    return 1;
}
