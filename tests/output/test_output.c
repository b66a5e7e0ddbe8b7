/*
 * test_output.c - pdla_output_write() against an independent reader (the
 * HDF5 C API): layout and format attributes, positions equal to what
 * pdla_engine_visit gives (as a multiset), the R_g series, every parameter,
 * the results, non-empty provenance, checksums that catch a flipped byte,
 * and the safety rules: no temporary file left, an existing path refused and
 * left byte-identical, unwritable places fail with one line and print
 * nothing, the caller's HDF5 error handler restored.
 *
 * Reproducibility is checked in two ways, because a file holds two kinds of
 * facts that legitimately differ between runs:
 *  - the same engine written twice (a second apart) with SOURCE_DATE_EPOCH
 *    set gives byte-identical files: the writer adds nothing variable but
 *    /Code created_utc, which that variable fixes. (Masking created_utc in
 *    the bytes would not do: HDF5 1.10 metadata checksums cover it.)
 *    Without the variable, the files differ in only a few bytes;
 *  - two engines grown from the same seed give identical positions (same
 *    bytes, same tree order), R_g series, parameters and results except the
 *    timings (grow_seconds, parallel_seconds, ns_per_jump), which measure
 *    the machine, not the cluster.
 */
#define _GNU_SOURCE /* RTLD_NEXT, fallocate */
#include <errno.h>
#include <fcntl.h>
#include <dlfcn.h>
#include <math.h>
#include <sys/statvfs.h>

#include "check.h"
#include "output_util.h"

/* ---- failure injection --------------------------------------------------
 * A full disk, simulated: this executable's pwrite() and fallocate() take
 * the place of libc's for every library in the process (HDF5's sec2 driver
 * writes with pwrite), and once armed they fail with ENOSPC on files whose
 * name contains ".tmp." after `write_budget` bytes (until space is
 * reserved with fallocate, as on a real file system). Test-only global state:
 * an interposed libc function has nowhere else to keep it. */
static long long write_budget = -1; /* bytes still allowed; -1: not armed */
static int fail_fallocate;          /* 1: fallocate() on a .tmp. file fails */

static int is_tmp_file(int fd)
{
    char link[64], target[4096];
    snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    const ssize_t n = readlink(link, target, sizeof target - 1);
    if (n <= 0) return 0;
    target[n] = '\0';
    return strstr(target, ".tmp.") != NULL;
}

/* Both names: meson builds with _FILE_OFFSET_BITS=64, so this file's pwrite
 * would otherwise be named pwrite64, while HDF5 may call either. */
static ssize_t injected_pwrite(const char *name, int fd, const void *buf, size_t n, off_t off)
{
    ssize_t (*real)(int, const void *, size_t, off_t);
    *(void **)&real = dlsym(RTLD_NEXT, name);
    if (!real) {
        errno = ENOSYS;
        return -1;
    }
    if (write_budget >= 0 && is_tmp_file(fd)) {
        if ((long long)n > write_budget) {
            write_budget = 0;
            errno = ENOSPC;
            return -1;
        }
        write_budget -= (long long)n;
    }
    return real(fd, buf, n, off);
}

_Static_assert(sizeof(off_t) == 8, "the interposers assume a 64-bit off_t");
ssize_t test_pwrite(int fd, const void *buf, size_t n, off_t off) __asm__("pwrite");
ssize_t test_pwrite64(int fd, const void *buf, size_t n, off_t off) __asm__("pwrite64");
int test_fallocate(int fd, int mode, off_t off, off_t len) __asm__("fallocate");
int test_fallocate64(int fd, int mode, off_t off, off_t len) __asm__("fallocate64");

ssize_t test_pwrite(int fd, const void *buf, size_t n, off_t off)
{
    return injected_pwrite("pwrite", fd, buf, n, off);
}

ssize_t test_pwrite64(int fd, const void *buf, size_t n, off_t off)
{
    return injected_pwrite("pwrite64", fd, buf, n, off);
}

static int injected_fallocate(const char *name, int fd, int mode, off_t off, off_t len)
{
    int (*real)(int, int, off_t, off_t);
    *(void **)&real = dlsym(RTLD_NEXT, name);
    if (!real) {
        errno = ENOSYS;
        return -1;
    }
    if (!is_tmp_file(fd)) return real(fd, mode, off, len);
    if (fail_fallocate) {
        errno = ENOSPC;
        return -1;
    }
    const int r = real(fd, mode, off, len);
    /* Reserved blocks are what make later writes fit on a real file system
     * (the library relies on it for the writes of the close), so a
     * successful reservation ends the simulated shortage. */
    if (r == 0) write_budget = -1;
    return r;
}

int test_fallocate(int fd, int mode, off_t off, off_t len)
{
    return injected_fallocate("fallocate", fd, mode, off, len);
}

int test_fallocate64(int fd, int mode, off_t off, off_t len)
{
    return injected_fallocate("fallocate64", fd, mode, off, len);
}

/* statvfs: reports a nearly full file system when `tiny_disk` is set, for
 * the check the library makes before it starts. */
static int tiny_disk;

static int injected_statvfs(const char *name, const char *path, struct statvfs *buf)
{
    int (*real)(const char *, struct statvfs *);
    *(void **)&real = dlsym(RTLD_NEXT, name);
    if (!real) {
        errno = ENOSYS;
        return -1;
    }
    const int r = real(path, buf);
    if (r == 0 && tiny_disk) buf->f_bavail = 1;
    return r;
}

int test_statvfs(const char *path, struct statvfs *buf) __asm__("statvfs");
int test_statvfs64(const char *path, struct statvfs *buf) __asm__("statvfs64");

int test_statvfs(const char *path, struct statvfs *buf)
{
    return injected_statvfs("statvfs", path, buf);
}

int test_statvfs64(const char *path, struct statvfs *buf)
{
    return injected_statvfs("statvfs64", path, buf);
}

typedef struct row {
    int32_t x[3];
} row;

typedef struct rows {
    row *r;
    size_t n, cap;
    int dim;
} rows;

static int collect(const int32_t *xyz, size_t n, void *user)
{
    rows *const s = user;
    if (s->n + n > s->cap) {
        const size_t cap = 2 * (s->n + n);
        row *const r = realloc(s->r, cap * sizeof *r);
        if (!r) return 1;
        s->r = r;
        s->cap = cap;
    }
    for (size_t i = 0; i < n; i++) {
        row q = {{0, 0, 0}};
        for (int a = 0; a < s->dim; a++) q.x[a] = xyz[i * (size_t)s->dim + (size_t)a];
        s->r[s->n++] = q;
    }
    return 0;
}

static int row_cmp(const void *a, const void *b)
{
    const row *const p = a, *const q = b;
    for (int i = 0; i < 3; i++)
        if (p->x[i] != q->x[i]) return p->x[i] < q->x[i] ? -1 : 1;
    return 0;
}

static int same_double(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0 || (isnan(a) && isnan(b));
}

static int one_line(const char *s) { return s[0] && !strchr(s, '\n'); }

/* Layout (chunked + Fletcher32 when it has rows, contiguous when empty). */
static void check_layout(hid_t d, hsize_t rows_n, const char *name)
{
    const hid_t dcpl = H5Dget_create_plist(d);
    CHECK(dcpl >= 0, "%s: no creation properties", name);
    if (dcpl < 0) return;
    const H5D_layout_t lay = H5Pget_layout(dcpl);
    if (rows_n > 0) {
        CHECK(lay == H5D_CHUNKED, "%s: layout %d, not chunked", name, (int)lay);
        int fletcher = 0;
        const int nf = H5Pget_nfilters(dcpl);
        for (int i = 0; i < nf; i++) {
            unsigned flags = 0, cd[4];
            size_t ncd = 4;
            char fname[64];
            if (H5Pget_filter2(dcpl, (unsigned)i, &flags, &ncd, cd, sizeof fname, fname, NULL) ==
                H5Z_FILTER_FLETCHER32)
                fletcher = 1;
        }
        CHECK(fletcher, "%s: no Fletcher32 filter", name);
    } else {
        CHECK(lay == H5D_CONTIGUOUS, "%s: empty but layout %d", name, (int)lay);
    }
    H5Pclose(dcpl);
}

static void check_positions(hid_t file, const pdla_engine *e)
{
    const pdla_params *const p = pdla_engine_params(e);
    const uint64_t n = pdla_engine_count(e);
    const hid_t d = H5Dopen2(file, "/cluster/positions", H5P_DEFAULT);
    CHECK(d >= 0, "no /cluster/positions");
    if (d < 0) return;
    const hid_t sp = H5Dget_space(d), t = H5Dget_type(d);
    hsize_t dims[2] = {0, 0};
    CHECK(H5Sget_simple_extent_ndims(sp) == 2, "positions rank is not 2");
    H5Sget_simple_extent_dims(sp, dims, NULL);
    CHECK(dims[0] == n && dims[1] == (hsize_t)p->dim,
          "positions shape [%llu][%llu], want [%llu][%d]",
          (unsigned long long)dims[0], (unsigned long long)dims[1], (unsigned long long)n, p->dim);
    CHECK(H5Tequal(t, H5T_STD_I32LE) > 0, "positions are not little-endian int32");
    check_layout(d, dims[0], "positions");

    int res = 0;
    char s[256];
    CHECK(read_attr(file, "/cluster/positions", "diameter_units", H5T_NATIVE_INT, &res) == 0 &&
              res == p->resolution,
          "diameter_units %d, want %d", res, p->resolution);
    CHECK(read_attr_str(file, "/cluster/positions", "units", s, sizeof s) == 0 &&
              !strcmp(s, "lattice units"),
          "positions units '%s'", s);
    CHECK(read_attr_str(file, "/cluster/positions", "order", s, sizeof s) == 0 &&
              !strcmp(s, "tree (not arrival)"),
          "positions order '%s'", s);

    rows want = {NULL, 0, 0, p->dim};
    CHECK(pdla_engine_visit(e, collect, &want) == 0, "visit failed");
    CHECK(want.n == n, "visit gave %zu of %llu", want.n, (unsigned long long)n);
    if (dims[0] == n && dims[1] == (hsize_t)p->dim && want.n == n) {
        int32_t *const raw = malloc((n ? n : 1) * (size_t)p->dim * sizeof *raw);
        rows got = {NULL, 0, 0, p->dim};
        CHECK(raw && (n == 0 ||
                      H5Dread(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw) >= 0),
              "cannot read positions");
        /* Same order too: the file is written in the order the visit gives. */
        size_t first_diff = n;
        for (size_t i = 0; raw && i < n && first_diff == n; i++)
            for (int a = 0; a < p->dim; a++)
                if (raw[i * (size_t)p->dim + (size_t)a] != want.r[i].x[a]) first_diff = i;
        CHECK(first_diff == n, "positions differ from the visit order at row %zu", first_diff);
        if (raw) collect(raw, n, &got);
        if (n) {
            qsort(want.r, want.n, sizeof *want.r, row_cmp);
            qsort(got.r, got.n, sizeof *got.r, row_cmp);
        }
        CHECK(got.n == want.n && (n == 0 || !memcmp(got.r, want.r, n * sizeof *got.r)),
              "positions are not the visited multiset");
        free(got.r);
        free(raw);
    }
    free(want.r);
    H5Tclose(t);
    H5Sclose(sp);
    H5Dclose(d);
}

static void check_series(hid_t file, const char *name, hid_t mtype, const void *want, size_t k,
                         size_t elem)
{
    const hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
    CHECK(d >= 0, "no %s", name);
    if (d < 0) return;
    const hid_t sp = H5Dget_space(d);
    hsize_t dim = 99;
    CHECK(H5Sget_simple_extent_ndims(sp) == 1, "%s rank is not 1", name);
    H5Sget_simple_extent_dims(sp, &dim, NULL);
    CHECK(dim == k, "%s has %llu rows, want %zu", name, (unsigned long long)dim, k);
    check_layout(d, dim, name);
    if (dim == k && k > 0) {
        void *const got = malloc(k * elem);
        CHECK(got && H5Dread(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, got) >= 0, "cannot read %s",
              name);
        CHECK(got && !memcmp(got, want, k * elem), "%s differs from pdla_engine_rg_series", name);
        free(got);
    }
    H5Sclose(sp);
    H5Dclose(d);
}

static void check_parameters(hid_t file, const pdla_params *p)
{
    int i = 0;
    uint64_t u = 0;
    double f = 0;
    char s[64];
#define P_INT(field)                                                                           \
    CHECK(read_attr(file, "/parameters", #field, H5T_NATIVE_INT, &i) == 0 && i == p->field,      \
          "parameter " #field " %d, want %d", i, (int)p->field)
#define P_U64(field)                                                                           \
    CHECK(read_attr(file, "/parameters", #field, H5T_NATIVE_UINT64, &u) == 0 && u == p->field,   \
          "parameter " #field " %llu", (unsigned long long)u)
#define P_F64(field)                                                                           \
    CHECK(read_attr(file, "/parameters", #field, H5T_NATIVE_DOUBLE, &f) == 0 &&                  \
              same_double(f, p->field),                                                        \
          "parameter " #field " %g, want %g", f, p->field)
    P_INT(dim);
    P_U64(target);
    P_U64(seed);
    P_INT(resolution);
    P_INT(eps);
    P_F64(birth_margin);
    P_F64(kill_ratio);
    P_INT(exact_search);
    P_F64(far_factor);
    P_U64(max_jumps);
    P_INT(snap_contact);
    P_INT(rg_per_decade);
    P_INT(threads);
    P_U64(serial_until);
#undef P_INT
#undef P_U64
#undef P_F64
    CHECK(read_attr_str(file, "/parameters", "return_mode", s, sizeof s) == 0 &&
              !strcmp(s, p->return_mode == PDLA_RETURN_EXACT ? "exact" : "kill"),
          "return_mode '%s'", s);
    CHECK(read_attr_str(file, "/parameters", "recheck", s, sizeof s) == 0 &&
              !strcmp(s, p->recheck == PDLA_RECHECK_CONTINUE ? "continue" : "discard"),
          "recheck '%s'", s);
    CHECK(read_attr_str(file, "/parameters", "bind", s, sizeof s) == 0 &&
              !strcmp(s, p->bind == PDLA_BIND_NONE ? "none" : "core"),
          "bind '%s'", s);
}

static void check_results(hid_t file, const pdla_engine *e, const pdla_run_info *info)
{
    static const char *const names[] = {
        "particles", "D_f", "D_f_err", "fit_n_lo", "fit_n_hi", "fit_points", "prefactor_diam",
        "rg_diam", "r_ext_units", "r_ext_diam", "walkers", "jumps", "returns", "lost", "killed",
        "restarts", "node_visits", "particle_checks", "tree_bytes", "inner_nodes", "leaves",
        "chunks", "root_level", "grow_seconds", "wall_seconds", "peak_rss_bytes",
        "jumps_per_particle", "ns_per_jump"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        CHECK(H5Aexists_by_name(file, "/results", names[i], H5P_DEFAULT) > 0, "no /results %s",
              names[i]);
    pdla_stats s;
    pdla_engine_stats(e, &s);
    const pdla_fit fit = pdla_engine_fit(e);
    uint64_t u = 0;
    int64_t i64 = 0;
    int i = 0;
    double f = 0;
#define R_U64(name, want)                                                                      \
    CHECK(read_attr(file, "/results", name, H5T_NATIVE_UINT64, &u) == 0 && u == (uint64_t)(want), \
          "results " name " %llu", (unsigned long long)u)
#define R_F64(name, want)                                                                      \
    CHECK(read_attr(file, "/results", name, H5T_NATIVE_DOUBLE, &f) == 0 && same_double(f, want), \
          "results " name " %g, want %g", f, (double)(want))
    R_U64("particles", s.particles);
    R_U64("walkers", s.walkers);
    R_U64("jumps", s.jumps);
    R_U64("returns", s.returns);
    R_U64("killed", s.killed);
    R_U64("node_visits", s.node_visits);
    R_U64("tree_bytes", s.tree_bytes);
    R_U64("fit_n_lo", fit.n_lo);
    R_U64("fit_n_hi", fit.n_hi);
    R_U64("peak_rss_bytes", info->peak_rss_bytes);
    R_F64("D_f", fit.df);
    R_F64("D_f_err", fit.df_err);
    R_F64("prefactor_diam", fit.prefactor_diam);
    R_F64("rg_diam", s.rg_diam);
    R_F64("grow_seconds", s.grow_seconds);
    R_F64("wall_seconds", info->wall_seconds);
    R_F64("r_ext_diam", (double)s.r_ext / pdla_engine_params(e)->resolution);
#undef R_U64
#undef R_F64
    CHECK(read_attr(file, "/results", "fit_points", H5T_NATIVE_INT, &i) == 0 && i == fit.points,
          "fit_points %d", i);
    CHECK(read_attr(file, "/results", "root_level", H5T_NATIVE_INT, &i) == 0 && i == s.root_level,
          "root_level %d", i);
    CHECK(read_attr(file, "/results", "r_ext_units", H5T_NATIVE_INT64, &i64) == 0 && i64 == s.r_ext,
          "r_ext_units %lld", (long long)i64);
    CHECK(read_attr(file, "/results", "jumps_per_particle", H5T_NATIVE_DOUBLE, &f) == 0 &&
              (s.particles ? fabs(f - (double)s.jumps / (double)s.particles) < 1e-12 * (f + 1)
                           : isnan(f)),
          "jumps_per_particle %g", f);
}

static void check_code(hid_t file, const pdla_run_info *info)
{
    static const char *const names[] = {"version", "git_revision", "compiler", "build_flags",
                                        "hdf5_version", "hwloc_version", "topology", "host",
                                        "created_utc", "command_line"};
    char s[2048];
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        CHECK(read_attr_str(file, "/Code", names[i], s, sizeof s) == 0 && s[0],
              "/Code %s missing or empty", names[i]);
    }
    CHECK(read_attr_str(file, "/Code", "version", s, sizeof s) == 0 && !strcmp(s, pdla_version()),
          "/Code version '%s'", s);
    CHECK(read_attr_str(file, "/Code", "created_utc", s, sizeof s) == 0 && strlen(s) == 20 &&
              s[4] == '-' && s[10] == 'T' && s[19] == 'Z',
          "/Code created_utc '%s'", s);
    unsigned maj, min, rel;
    char v[32];
    H5get_libversion(&maj, &min, &rel);
    snprintf(v, sizeof v, "%u.%u.%u", maj, min, rel);
    CHECK(read_attr_str(file, "/Code", "hdf5_version", s, sizeof s) == 0 && !strcmp(s, v),
          "/Code hdf5_version '%s', want %s", s, v);
    CHECK(read_attr_str(file, "/Code", "command_line", s, sizeof s) == 0 &&
              !strcmp(s, info->command_line ? info->command_line : "unknown"),
          "/Code command_line '%s'", s);
}

/* Everything in one written file. */
static void verify_file(const char *path, const pdla_engine *e, const pdla_run_info *info)
{
    const hid_t file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    CHECK(file >= 0, "cannot open %s", path);
    if (file < 0) return;
    H5F_info2_t fi;
    CHECK(H5Fget_info2(file, &fi) >= 0 && fi.super.version == 3,
          "superblock version %u (want 3: HDF5 1.10 format)", fi.super.version);
    char s[512];
    int fv = 0;
    CHECK(read_attr_str(file, "/", "format", s, sizeof s) == 0 && !strcmp(s, "pdla-cluster"),
          "format '%s'", s);
    CHECK(read_attr(file, "/", "format_version", H5T_NATIVE_INT, &fv) == 0 && fv == 1,
          "format_version %d", fv);
    CHECK(read_attr_str(file, "/", "units", s, sizeof s) == 0 && strstr(s, "diameter"),
          "units '%s'", s);

    check_positions(file, e);
    const uint64_t *n;
    const double *rg;
    size_t k;
    pdla_engine_rg_series(e, &n, &rg, &k);
    check_series(file, "/gyration/N", H5T_NATIVE_UINT64, n, k, sizeof *n);
    check_series(file, "/gyration/rg_diam", H5T_NATIVE_DOUBLE, rg, k, sizeof *rg);
    check_parameters(file, pdla_engine_params(e));
    check_results(file, e, info);
    check_code(file, info);
    CHECK(H5Fclose(file) >= 0, "close %s", path);
}

/* Writes e to dir/name and verifies it; returns the write's code. */
static int write_and_verify(const char *dir, const char *name, const pdla_engine *e,
                            const pdla_run_info *info)
{
    char path[4096], err[512] = "x";
    join(path, sizeof path, dir, name);
    const int rc = pdla_output_write(e, info, path, err, sizeof err);
    CHECK(rc == 0, "write %s: %d %s", path, rc, err);
    CHECK(rc != 0 || err[0] == '\0', "success but a message: %s", err);
    CHECK(count_entries_with(dir, ".tmp") == 0, "a temporary file remains in %s", dir);
    if (rc == 0) verify_file(path, e, info);
    return rc;
}

/* Calls pdla_output_write with fd 2 sent to a file; *printed gets the bytes
 * the call wrote to stderr. */
static int write_quietly(const pdla_engine *e, const pdla_run_info *info, const char *path,
                         char *err, size_t errlen, const char *capture, long *printed)
{
    fflush(stderr);
    const int saved = dup(2);
    const int fd = open(capture, O_CREAT | O_TRUNC | O_WRONLY, 0600);
    if (saved < 0 || fd < 0) {
        *printed = -1;
        return pdla_output_write(e, info, path, err, errlen);
    }
    dup2(fd, 2);
    close(fd);
    const int rc = pdla_output_write(e, info, path, err, errlen);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    struct stat st;
    *printed = stat(capture, &st) == 0 ? (long)st.st_size : -1;
    unlink(capture);
    return rc;
}

static void test_safety(const char *dir, const pdla_engine *e, const pdla_run_info *info)
{
    char path[4096], err[512], capture[4096];
    long printed = 0;
    join(path, sizeof path, dir, "a.h5");
    join(capture, sizeof capture, dir, "stderr.txt");

    /* An existing file is refused and left as it was. */
    size_t len0 = 0, len1 = 0;
    unsigned char *const before = read_all(path, &len0);
    CHECK(before != NULL, "cannot read %s", path);
    int rc = write_quietly(e, info, path, err, sizeof err, capture, &printed);
    CHECK(rc == PDLA_EEXIST, "overwrite gave %d, want PDLA_EEXIST", rc);
    CHECK(one_line(err) && strstr(err, path), "EEXIST message '%s'", err);
    CHECK(printed == 0, "%ld bytes printed on stderr", printed);
    unsigned char *const after = read_all(path, &len1);
    CHECK(after && len0 == len1 && !memcmp(before, after, len0), "%s changed", path);
    free(before);
    free(after);
    CHECK(count_entries_with(dir, ".tmp") == 0, "a temporary file remains after EEXIST");

    /* A directory or a dangling link at the path counts as existing too. */
    join(path, sizeof path, dir, "link.h5");
    CHECK(symlink("nowhere", path) == 0, "symlink: %s", strerror(errno));
    rc = pdla_output_write(e, info, path, err, sizeof err);
    CHECK(rc == PDLA_EEXIST, "dangling link gave %d", rc);
    unlink(path);

    /* A directory that does not exist. */
    join(path, sizeof path, dir, "no/such/dir/x.h5");
    rc = write_quietly(e, info, path, err, sizeof err, capture, &printed);
    CHECK(rc == PDLA_EIO, "missing directory gave %d, want PDLA_EIO", rc);
    CHECK(one_line(err) && strstr(err, path), "EIO message '%s'", err);
    CHECK(printed == 0, "%ld bytes printed on stderr (HDF5 error stack?)", printed);

    /* A read-only directory; root ignores permissions, so only as a user. */
    if (geteuid() != 0) {
        char ro[4096];
        join(ro, sizeof ro, dir, "ro");
        CHECK(mkdir(ro, 0555) == 0, "mkdir %s", ro);
        join(path, sizeof path, ro, "x.h5");
        rc = write_quietly(e, info, path, err, sizeof err, capture, &printed);
        CHECK(rc == PDLA_EIO, "read-only directory gave %d, want PDLA_EIO", rc);
        CHECK(one_line(err) && strstr(err, path), "read-only message '%s'", err);
        CHECK(printed == 0, "%ld bytes printed on stderr", printed);
        CHECK(count_entries_with(ro, "x.h5") == 0, "something was left in %s", ro);
    } else {
        fprintf(stderr, "note: running as root, read-only directory check skipped\n");
    }

    /* Bad arguments. */
    CHECK(pdla_output_write(e, info, "", err, sizeof err) == PDLA_EINVAL, "empty path accepted");
    CHECK(pdla_output_write(NULL, info, path, err, sizeof err) == PDLA_EINVAL,
          "NULL engine accepted");
}

/* A disk that fills up: at the first write, part way through the data, at
 * the last data write, and when the space for the close is reserved. Each
 * must fail with one line, print nothing, leave no file, and not leave HDF5
 * with a half-closed file (HDF5 1.10 would crash at exit: the test's exit
 * status checks that). */
static void test_disk_full(const char *dir, const pdla_engine *e, const pdla_run_info *info)
{
    char path[4096], capture[4096], err[512];
    long printed = 0;
    join(path, sizeof path, dir, "full.h5");
    join(capture, sizeof capture, dir, "stderr.txt");
    /* Budgets: 4096, 12000 run out in the positions, 20000 in the R_g
     * series (the file is ~31 KB); -1: the reserve before the close fails;
     * -2: the file system reports too little space before the start. Not
     * simulated: a disk that fills between that check and the superblock
     * write (H5Fcreate fails; HDF5 1.10 then leaks and says so at exit). */
    static const long long budgets[] = {4096, 12000, 20000, -1, -2};
    for (size_t i = 0; i < sizeof budgets / sizeof *budgets; i++) {
        const long long b = budgets[i];
        write_budget = b >= 0 ? b : -1;
        fail_fallocate = b == -1;
        tiny_disk = b == -2;
        const int rc = write_quietly(e, info, path, err, sizeof err, capture, &printed);
        write_budget = -1;
        fail_fallocate = 0;
        tiny_disk = 0;
        CHECK(rc == PDLA_EIO, "disk full (budget %lld) gave %d, want PDLA_EIO", b, rc);
        CHECK(one_line(err) && strstr(err, path) && strstr(err, "No space left"),
              "disk full (budget %lld) message '%s'", b, err);
        CHECK(printed == 0, "disk full (budget %lld): %ld bytes printed on stderr", b, printed);
        CHECK(access(path, F_OK) != 0, "disk full (budget %lld): %s exists", b, path);
        CHECK(count_entries_with(dir, ".tmp") == 0, "disk full (budget %lld): a .tmp file remains",
              b);
        CHECK(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) == 0,
              "disk full (budget %lld): HDF5 still holds %zd objects", b,
              H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL));
        fprintf(stderr, "note: disk full (budget %lld): %s\n", b, err);
    }
    /* And the same process can still write. */
    CHECK(pdla_output_write(e, info, path, err, sizeof err) == 0, "after disk full: %s", err);
}

/* Flipping one byte of the first positions chunk must make the read fail:
 * the checksum is really stored and checked. */
static void test_checksum(const char *dir)
{
    char path[4096], bad[4096];
    join(path, sizeof path, dir, "a.h5");
    join(bad, sizeof bad, dir, "corrupt.h5");
    haddr_t addr = HADDR_UNDEF;
    hsize_t size = 0, rows_n = 0, dims[2];
    hid_t file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    hid_t d = H5Dopen2(file, "/cluster/positions", H5P_DEFAULT);
    hid_t sp = H5Dget_space(d);
    H5Sget_simple_extent_dims(sp, dims, NULL);
    rows_n = dims[0];
    unsigned mask = 0;
    hsize_t off[2];
    CHECK(H5Dget_chunk_info(d, sp, 0, off, &mask, &addr, &size) >= 0 && addr != HADDR_UNDEF,
          "no chunk info");
    H5Sclose(sp);
    H5Dclose(d);
    H5Fclose(file);
    size_t len = 0;
    unsigned char *const buf = read_all(path, &len);
    if (!buf || addr == HADDR_UNDEF || addr + 16 > len) {
        CHECK(0, "cannot set up the corruption test");
        free(buf);
        return;
    }
    buf[addr + 5] ^= 0x40;
    FILE *const f = fopen(bad, "wb");
    CHECK(f && fwrite(buf, 1, len, f) == len && fclose(f) == 0, "cannot write %s", bad);
    free(buf);

    H5E_auto2_t fn;
    void *data;
    H5Eget_auto2(H5E_DEFAULT, &fn, &data);
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    file = H5Fopen(bad, H5F_ACC_RDONLY, H5P_DEFAULT);
    d = H5Dopen2(file, "/cluster/positions", H5P_DEFAULT);
    int32_t *const raw = malloc(rows_n * 3 * sizeof *raw);
    CHECK(raw && H5Dread(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw) < 0,
          "a flipped byte in a chunk was not detected");
    free(raw);
    H5Dclose(d);
    H5Fclose(file);
    H5Eset_auto2(H5E_DEFAULT, fn, data);
    unlink(bad);
}

static void read_created(const char *path, char *s, size_t cap)
{
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0 || read_attr_str(f, "/Code", "created_utc", s, cap) != 0) s[0] = '\0';
    if (f >= 0) H5Fclose(f);
}

/* Raw bytes of every attribute of `obj` equal in both files, except `skip`. */
typedef struct attr_cmp {
    hid_t other;
    const char *obj;
    const char *const *skip;
    int compared;
} attr_cmp;

static herr_t cmp_one(hid_t loc, const char *name, const H5A_info_t *ainfo, void *data)
{
    (void)ainfo;
    attr_cmp *const c = data;
    for (const char *const *s = c->skip; *s; s++)
        if (!strcmp(*s, name)) return 0;
    const hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
    const hid_t b = H5Aopen_by_name(c->other, c->obj, name, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t ta = H5Aget_type(a), tb = b >= 0 ? H5Aget_type(b) : -1;
    const hid_t sa = H5Aget_space(a);
    const hssize_t points = sa >= 0 ? H5Sget_simple_extent_npoints(sa) : 1;
    if (sa >= 0) H5Sclose(sa);
    const size_t n = H5Tget_size(ta) * (size_t)(points > 0 ? points : 1);
    unsigned char *const x = calloc(n, 1), *const y = calloc(n, 1);
    CHECK(b >= 0 && H5Tequal(ta, tb) > 0 && x && y && H5Aread(a, ta, x) >= 0 &&
              H5Aread(b, tb, y) >= 0 && !memcmp(x, y, n),
          "%s %s differs between the two runs", c->obj, name);
    c->compared++;
    free(x);
    free(y);
    if (tb >= 0) H5Tclose(tb);
    H5Tclose(ta);
    if (b >= 0) H5Aclose(b);
    H5Aclose(a);
    return 0;
}

static void compare_attrs(hid_t f1, hid_t f2, const char *obj, const char *const *skip)
{
    attr_cmp c = {f2, obj, skip, 0};
    CHECK(H5Aiterate_by_name(f1, obj, H5_INDEX_NAME, H5_ITER_INC, NULL, cmp_one, &c,
                             H5P_DEFAULT) >= 0,
          "cannot list the attributes of %s", obj);
    CHECK(c.compared > 0, "no attributes compared in %s", obj);
}

static void compare_dataset(hid_t f1, hid_t f2, const char *name)
{
    const hid_t a = H5Dopen2(f1, name, H5P_DEFAULT), b = H5Dopen2(f2, name, H5P_DEFAULT);
    const hid_t ta = H5Dget_type(a);
    const hid_t sa = H5Dget_space(a), sb = H5Dget_space(b);
    const hssize_t na = H5Sget_simple_extent_npoints(sa);
    const hssize_t nb = H5Sget_simple_extent_npoints(sb);
    H5Sclose(sa);
    H5Sclose(sb);
    const size_t bytes = (size_t)(na > 0 ? na : 1) * H5Tget_size(ta);
    unsigned char *const x = malloc(bytes), *const y = malloc(bytes);
    CHECK(na == nb && x && y &&
              (na == 0 || (H5Dread(a, ta, H5S_ALL, H5S_ALL, H5P_DEFAULT, x) >= 0 &&
                           H5Dread(b, ta, H5S_ALL, H5S_ALL, H5P_DEFAULT, y) >= 0 &&
                           !memcmp(x, y, bytes))),
          "%s differs between the two runs", name);
    free(x);
    free(y);
    H5Tclose(ta);
    H5Dclose(a);
    H5Dclose(b);
}

static void test_reproducible(const char *dir, const pdla_engine *e, const pdla_run_info *info)
{
    char p1[4096], p2[4096], p3[4096], c1[64], c2[64], err[512];
    join(p1, sizeof p1, dir, "b1.h5");
    join(p2, sizeof p2, dir, "b2.h5");
    join(p3, sizeof p3, dir, "c.h5");

    /* The same engine twice, a second apart, with SOURCE_DATE_EPOCH fixing
     * created_utc: the whole files must be identical. */
    CHECK(setenv("SOURCE_DATE_EPOCH", "1700000000", 1) == 0, "setenv");
    CHECK(pdla_output_write(e, info, p1, err, sizeof err) == 0, "write b1: %s", err);
    sleep(1);
    CHECK(pdla_output_write(e, info, p2, err, sizeof err) == 0, "write b2: %s", err);
    CHECK(unsetenv("SOURCE_DATE_EPOCH") == 0, "unsetenv");
    read_created(p1, c1, sizeof c1);
    read_created(p2, c2, sizeof c2);
    CHECK(!strcmp(c1, "2023-11-14T22:13:20Z") && !strcmp(c2, c1),
          "created_utc '%s' / '%s' ignores SOURCE_DATE_EPOCH", c1, c2);
    size_t l1 = 0, l2 = 0;
    unsigned char *a = read_all(p1, &l1), *b = read_all(p2, &l2);
    CHECK(a && b && l1 == l2 && !memcmp(a, b, l1), "same engine written twice: files differ");
    free(a);
    free(b);

    /* Without it, the clock: same size, and only created_utc's bytes and
     * the checksums over them may differ (a handful of bytes). */
    join(p2, sizeof p2, dir, "b3.h5");
    CHECK(pdla_output_write(e, info, p2, err, sizeof err) == 0, "write b3: %s", err);
    read_created(p2, c2, sizeof c2);
    CHECK(strlen(c2) == 20 && strcmp(c2, c1) != 0, "created_utc '%s' is not the clock", c2);
    a = read_all(p1, &l1);
    b = read_all(p2, &l2);
    size_t differ = 0;
    for (size_t i = 0; a && b && l1 == l2 && i < l1; i++) differ += a[i] != b[i];
    CHECK(a && b && l1 == l2 && differ > 0 && differ <= 64,
          "b1 vs b3: sizes %zu/%zu, %zu bytes differ (want 1..64)", l1, l2, differ);
    free(a);
    free(b);

    /* A second engine from the same seed. */
    const pdla_params *const p = pdla_engine_params(e);
    pdla_engine *const e2 =
        grow_engine(p->dim, p->target, p->seed, p->return_mode, p->rg_per_decade);
    CHECK(e2 != NULL, "cannot grow the second engine");
    if (!e2) return;
    CHECK(pdla_output_write(e2, info, p3, err, sizeof err) == 0, "write c: %s", err);
    const hid_t f1 = H5Fopen(p1, H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t f2 = H5Fopen(p3, H5F_ACC_RDONLY, H5P_DEFAULT);
    CHECK(f1 >= 0 && f2 >= 0, "cannot open b1/c");
    if (f1 >= 0 && f2 >= 0) {
        static const char *const none[] = {NULL};
        static const char *const timing[] = {"grow_seconds", "parallel_seconds", "ns_per_jump",
                                             NULL};
        static const char *const created[] = {"created_utc", NULL};
        compare_dataset(f1, f2, "/cluster/positions");
        compare_dataset(f1, f2, "/gyration/N");
        compare_dataset(f1, f2, "/gyration/rg_diam");
        compare_attrs(f1, f2, "/", none);
        compare_attrs(f1, f2, "/cluster/positions", none);
        compare_attrs(f1, f2, "/parameters", none);
        compare_attrs(f1, f2, "/results", timing);
        compare_attrs(f1, f2, "/Code", created);
    }
    if (f1 >= 0) H5Fclose(f1);
    if (f2 >= 0) H5Fclose(f2);
    pdla_engine_destroy(e2);
}

int main(void)
{
    char dir[4096];
    if (make_scratch(dir, sizeof dir) != 0) {
        fprintf(stderr, "cannot make a scratch directory\n");
        return 1;
    }
    const pdla_run_info info = {"pdla --dim 2 --target 2000 --seed 7 -o a.h5", 1.25, 123456789};
    H5E_auto2_t fn0, fn1;
    void *data0, *data1;
    H5Eget_auto2(H5E_DEFAULT, &fn0, &data0);

    /* 2D, exact return, sampling on. */
    pdla_engine *const e2d = grow_engine(2, 2000, 7, PDLA_RETURN_EXACT, 100);
    CHECK(e2d != NULL, "cannot grow the 2D engine");
    if (e2d) {
        write_and_verify(dir, "a.h5", e2d, &info);
        test_safety(dir, e2d, &info);
        test_checksum(dir);
        test_disk_full(dir, e2d, &info);
        test_reproducible(dir, e2d, &info);
        pdla_engine_destroy(e2d);
    }

    /* 3D, kill mode, sampling off: empty gyration datasets; no command line. */
    const pdla_run_info bare = {NULL, 0.0, 0};
    pdla_engine *const e3d = grow_engine(3, 500, 3, PDLA_RETURN_KILL, 0);
    CHECK(e3d != NULL, "cannot grow the 3D engine");
    if (e3d) {
        write_and_verify(dir, "d3.h5", e3d, &bare);
        /* info may be NULL */
        char path[4096], err[256];
        join(path, sizeof path, dir, "d3-noinfo.h5");
        CHECK(pdla_output_write(e3d, NULL, path, err, sizeof err) == 0, "NULL info: %s", err);
        pdla_engine_destroy(e3d);
    }

    /* More than one positions chunk (65536 rows): the batching across chunks. */
    pdla_engine *const big = grow_engine(2, 70000, 11, PDLA_RETURN_EXACT, 20);
    CHECK(big != NULL, "cannot grow the 70000-particle engine");
    if (big) {
        write_and_verify(dir, "big.h5", big, &info);
        pdla_engine_destroy(big);
    }

    /* An engine that never grew: zero particles, zero samples. */
    pdla_params p;
    pdla_params_default(&p);
    pdla_engine *empty = NULL;
    char err[256];
    CHECK(pdla_engine_create(&empty, &p, err, sizeof err) == 0, "create: %s", err);
    if (empty) {
        write_and_verify(dir, "empty.h5", empty, &info);
        pdla_engine_destroy(empty);
    }

    H5Eget_auto2(H5E_DEFAULT, &fn1, &data1);
    CHECK(fn0 == fn1 && data0 == data1, "the HDF5 error handler was not restored");
    remove_scratch(dir);
    return check_finish();
}
