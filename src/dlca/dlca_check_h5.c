/*
 * dlca_check_h5.c - `pdla check` of a DLCA cluster.h5 (dlca_check_file in
 * pdla/dlca.h; a checkpoint goes to dck_checkpoint): /parameters through
 * the model's table, then /monomers streamed in slabs into the core
 * (dlca_check.c), /clusters, /results, /series (streamed) and /snapshots.
 * Every dataset is opened through the checked readers (pdla/h5check.h):
 * its type and shape are pdla's and it stores what it declares before
 * anything is sized by it, and the monomers and the box must fit in half
 * of this machine's memory (dck_fits) before the core allocates.
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "dlca_check.h"
#include "dlca_h5.h"
#include "h5util.h"
#include "pdla/h5check.h"

/* Rows read at a time: the slab buffers stay under 3 MB in 5D. */
enum { SLAB = 1 << 16 };

int dlca_check_wanted(const char *path)
{
    char model[32];
    return pdla_h5_file_model(path, model, sizeof model) == 0 &&
           (!strcmp(model, "dlca") || !strcmp(model, "dlca-checkpoint"));
}

/* loc/name as pdla writes it: rank (1, or 2 with cols columns) of type t,
 * storing what it declares; chunks cached whole for slab reads. 0, or
 * PDLA_EINVAL with the line (d closed). */
/* The rows of d's chunks (0 when it is not chunked), or -1. */
static int64_t chunk_rows(const pdla_h5_dset *d)
{
    uint64_t cd[PDLA_H5_MAX_RANK] = {0};
    const int rank = pdla_h5_dset_chunk(d, cd);
    return rank < 0 ? -1 : rank > 0 ? (int64_t)cd[0] : 0;
}

/* The /series columns are read side by side, six open at once, so each is
 * held to the chunks pdla writes (at most 65536 rows, 512 KB, which HDF5's
 * default cache holds): a forged column in one gzip'ed chunk of 2^26 rows
 * made each keep a 512 MB decompressed chunk (3.2 GB for a 3 MB file) or,
 * uncached, decompress it again for every slab. */
#define SERIES_CHUNK_MAX 65536

static int open_ds_as(hid_t loc, const char *name, pdla_h5_type t, int rank, uint64_t cols, int series,
                      pdla_h5_dset *d, const char *path, char *err, size_t errlen)
{
    const size_t esize = t == PDLA_H5_U64 || t == PDLA_H5_F64 ? 8 : 4;
    if (pdla_h5_dset_open(loc, name, d) < 0)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: no dataset %s (pdla writes it in every DLCA cluster.h5)",
                           path, name);
    const int stored = pdla_h5_dset_stored(d, esize);
    int rc = 0;
    int64_t cr = 0;
    if (!pdla_h5_dset_is(d, t) || d->rank != rank || (rank == 2 && d->dims[1] != cols))
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %s is not of the type and shape pdla writes", path, name);
    else if (stored != PDLA_H5_STORED)
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %s declares %" PRIu64 " elements, %s", path, name, d->elems,
                         stored == PDLA_H5_TOO_LARGE ? "more than this machine can address"
                                                     : "more than the file stores (damaged or forged)");
    else if (series && (cr = chunk_rows(d)) < 0)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot read how %s is stored", path, name);
    else if (series && cr > SERIES_CHUNK_MAX)
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %s is stored in chunks of %" PRId64 " rows, more than the %d "
                         "pdla writes", path, name, cr, SERIES_CHUNK_MAX);
    else if (!series && pdla_h5_dset_cache_chunk(loc, name, d) < 0)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot open %s", path, name);
    if (rc) (void)pdla_h5_dset_close(d); /* the first error is the one to report */
    return rc;
}

static int open_ds(hid_t loc, const char *name, pdla_h5_type t, int rank, uint64_t cols, pdla_h5_dset *d,
                   const char *path, char *err, size_t errlen)
{
    return open_ds_as(loc, name, t, rank, cols, 0, d, path, err, errlen);
}

/* The whole rank-1 dataset name (type t, 8-byte elements) of at most max
 * rows into *buf (malloc'ed) and *n. 0 or a code with the line. */
static int read_table(hid_t g, const char *name, pdla_h5_type t, uint64_t max, void **buf, uint64_t *n,
                      const char *path, char *err, size_t errlen)
{
    pdla_h5_dset d;
    int rc = open_ds(g, name, t, 1, 1, &d, path, err, errlen);
    if (rc) return rc;
    *n = d.dims[0];
    if (*n > max)
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: /clusters/%s has %" PRIu64 " rows, more than its %" PRIu64
                         " monomers", path, name, *n, max);
    else if (!(*buf = malloc((size_t)(*n ? *n : 1) * 8)))
        rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", path);
    else if (*n && pdla_h5_dset_read(&d, t, 0, *n, *buf) < 0)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot read /clusters/%s (damaged?)", path, name);
    if (pdla_h5_dset_close(&d) < 0 && !rc) rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close %s", path, name);
    return rc;
}

/* /clusters/size and /clusters/rg (at most N rows each). */
static int read_clusters(hid_t f, uint64_t N, dck_table *tab, uint64_t **size, double **rg, const char *path,
                         char *err, size_t errlen)
{
    const hid_t g = H5Lexists(f, "clusters", H5P_DEFAULT) > 0 ? H5Gopen2(f, "clusters", H5P_DEFAULT) : H5I_INVALID_HID;
    if (g < 0) return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: no group /clusters (pdla writes one)", path);
    int rc = read_table(g, "size", PDLA_H5_U64, N, (void **)size, &tab->nsize, path, err, errlen);
    if (!rc) rc = read_table(g, "rg", PDLA_H5_F64, N, (void **)rg, &tab->nrg, path, err, errlen);
    if (H5Gclose(g) < 0 && !rc) rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close /clusters", path);
    tab->size = *size;
    tab->rg = *rg;
    return rc;
}

/* /monomers' three datasets, of N rows each: position, site, cluster. */
typedef struct mono {
    pdla_h5_dset ds[3];
    int open; /* how many of them */
} mono;

static int mono_close(mono *m)
{
    int rc = 0;
    for (int j = 0; j < m->open; j++)
        if (pdla_h5_dset_close(&m->ds[j]) < 0) rc = -1;
    m->open = 0;
    return rc;
}

static int mono_open(hid_t f, int d, mono *m, uint64_t *N, const char *path, char *err, size_t errlen)
{
    static const char *const names[3] = {"monomers/position", "monomers/site", "monomers/cluster"};
    const pdla_h5_type types[3] = {PDLA_H5_I32, PDLA_H5_U32, PDLA_H5_U32};
    int rc = 0;
    for (m->open = 0; m->open < 3 && !rc; m->open++)
        if ((rc = open_ds(f, names[m->open], types[m->open], m->open ? 1 : 2, m->open ? 1 : (uint64_t)d,
                          &m->ds[m->open], path, err, errlen)))
            break; /* open_ds closed it */
    *N = rc ? 0 : m->ds[0].dims[0];
    if (!rc && (m->ds[1].dims[0] != *N || m->ds[2].dims[0] != *N))
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: /monomers/position, site and cluster have different lengths",
                         path);
    if (rc) (void)mono_close(m); /* the first error is the one to report */
    return rc;
}

/* The monomers in slabs into the core; r->stopped at the failure cap. */
static int feed_monomers(dck *c, const mono *m, const char *path, char *err, size_t errlen)
{
    const int d = c->d;
    int32_t *pos = malloc((size_t)SLAB * (size_t)d * sizeof *pos);
    uint32_t *site = malloc((size_t)SLAB * sizeof *site), *cl = malloc((size_t)SLAB * sizeof *cl);
    int rc = !pos || !site || !cl ? pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", path) : 0;
    for (uint64_t r0 = 0; !rc && r0 < c->N; r0 += SLAB) {
        const uint64_t n = c->N - r0 < SLAB ? c->N - r0 : SLAB;
        if (pdla_h5_dset_read(&m->ds[0], PDLA_H5_I32, r0, n, pos) < 0 ||
            pdla_h5_dset_read(&m->ds[1], PDLA_H5_U32, r0, n, site) < 0 ||
            pdla_h5_dset_read(&m->ds[2], PDLA_H5_U32, r0, n, cl) < 0) {
            rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot read /monomers rows %" PRIu64 "..%" PRIu64 " (damaged?)",
                             path, r0, r0 + n - 1);
            break;
        }
        for (uint64_t i = 0; i < n; i++) {
            int64_t x[DLCA_MAX_DIM];
            for (int a = 0; a < d; a++) x[a] = pos[i * (uint64_t)d + (uint64_t)a];
            if (dck_row(c, x, site[i], cl[i])) {
                c->r->stopped = 1;
                r0 = c->N; /* ends the slab loop */
                break;
            }
        }
    }
    free(pos), free(site), free(cl);
    return rc;
}

/* /results as stored; a value missing or not of pdla's type is left
 * has_* 0 (a failure of its own). 0, or -1 when the group cannot be
 * closed. */
static int read_totals(hid_t f, dck_totals *t)
{
    memset(t, 0, sizeof *t);
    const hid_t g = H5Lexists(f, "results", H5P_DEFAULT) > 0 ? H5Gopen2(f, "results", H5P_DEFAULT) : H5I_INVALID_HID;
    if (g < 0) return 0;
    const char *un[7] = {"attempts", "moves", "monomer_moves", "merges", "n_monomers", "n_clusters", "largest"};
    uint64_t *uv[7] = {&t->attempts, &t->moves, &t->monomer_moves, &t->merges, &t->n_monomers, &t->n_clusters, &t->largest};
    int *uh[7] = {&t->has_attempts, &t->has_moves, &t->has_mmoves, &t->has_merges, &t->has_n, &t->has_nc, &t->has_largest};
    for (int i = 0; i < 7; i++) *uh[i] = pdla_h5_attr_exact(g, un[i], PDLA_H5_U64, uv[i]) == 0;
    const char *fn[5] = {"t", "mean_size", "weight_average_size", "D_f", "D_f_err"};
    double *fv[5] = {&t->t, &t->mean_size, &t->weight_size, &t->D_f, &t->D_f_err};
    int *fh[5] = {&t->has_t, &t->has_mean, &t->has_weight, &t->has_df, &t->has_dferr};
    for (int i = 0; i < 5; i++) *fh[i] = pdla_h5_attr_exact(g, fn[i], PDLA_H5_F64, fv[i]) == 0;
    t->has_stop = pdla_h5_attr_str(g, "stop", t->stop, sizeof t->stop) == 0;
    t->has_search = pdla_h5_attr_str(g, "search_used", t->search_used, sizeof t->search_used) == 0;
    return H5Gclose(g) < 0 ? -1 : 0;
}

/* /series' six columns, as pdla writes them (equal lengths). */
static const char *const series_names[6] = {"series/t", "series/attempts", "series/n_clusters", "series/largest",
                                            "series/mean_size", "series/weight_average_size"};
static const pdla_h5_type series_types[6] = {PDLA_H5_F64, PDLA_H5_U64, PDLA_H5_U64,
                                             PDLA_H5_U64, PDLA_H5_F64, PDLA_H5_F64};

static int series_open(hid_t f, pdla_h5_dset *d, int *open, const char *path, char *err, size_t errlen)
{
    for (*open = 0; *open < 6; ++*open) {
        const int rc =
            open_ds_as(f, series_names[*open], series_types[*open], 1, 1, 1, &d[*open], path, err, errlen);
        if (rc) return rc;
        if (d[*open].dims[0] != d[0].dims[0]) {
            ++*open;
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: the /series columns have different lengths", path);
        }
    }
    return 0;
}

/* Rows r0..r0+n of the series into w. 0 or -1. */
static int series_slab(const pdla_h5_dset *d, uint64_t r0, uint64_t n, double *f[3], uint64_t *u[3], dlca_row *w)
{
    void *const col[6] = {f[0], u[0], u[1], u[2], f[1], f[2]}; /* in series_names' order */
    for (int j = 0; j < 6; j++)
        if (pdla_h5_dset_read(&d[j], series_types[j], r0, n, col[j]) < 0) return -1;
    for (uint64_t i = 0; i < n; i++)
        w[i] = (dlca_row){.t = f[0][i], .attempts = u[0][i], .n_clusters = u[1][i], .largest = u[2][i],
                          .mean_size = f[1][i], .weight_size = f[2][i]};
    return 0;
}

/* The series streamed in slabs, each row against the one before and the
 * final state (end), reading stopped at the failure cap. */
static int check_series(dck *c, hid_t f, const dlca_row *end, const dck_totals *t, const char *path, char *err,
                        size_t errlen)
{
    pdla_h5_dset d[6];
    int open = 0;
    int rc = series_open(f, d, &open, path, err, errlen);
    double *fb[3] = {malloc(SLAB * sizeof(double)), malloc(SLAB * sizeof(double)), malloc(SLAB * sizeof(double))};
    uint64_t *ub[3] = {malloc(SLAB * sizeof(uint64_t)), malloc(SLAB * sizeof(uint64_t)), malloc(SLAB * sizeof(uint64_t))};
    dlca_row *w = malloc(SLAB * sizeof *w), prev = {0}, last = {0};
    if (!rc && (!fb[0] || !fb[1] || !fb[2] || !ub[0] || !ub[1] || !ub[2] || !w))
        rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", path);
    const uint64_t n = rc ? 0 : d[0].dims[0];
    for (uint64_t r0 = 0; !rc && r0 < n && !c->r->stopped; r0 += SLAB) {
        const uint64_t k = n - r0 < SLAB ? n - r0 : SLAB;
        if (series_slab(d, r0, k, fb, ub, w) < 0) {
            rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot read /series rows %" PRIu64 "..%" PRIu64 " (damaged?)",
                             path, r0, r0 + k - 1);
            break;
        }
        for (uint64_t i = 0; i < k && !c->r->stopped; i++) {
            dck_series_row(c, r0 + i, &w[i], r0 + i ? &prev : NULL, end);
            prev = last = w[i];
            if (dck_failures(c) >= DLCA_CHECK_MAX_FAILURES) c->r->stopped = 1;
        }
    }
    if (!rc && !c->r->stopped) dck_series_end(c, &last, n, end, t);
    for (int j = 0; j < open; j++)
        if (pdla_h5_dset_close(&d[j]) < 0 && !rc) rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close /series", path);
    for (int j = 0; j < 3; j++) free(fb[j]), free(ub[j]);
    free(w);
    return rc;
}

/* After the monomers: the table, the totals, the series, the snapshots. */
static int check_rest(dck *c, hid_t f, const dck_table *tab, const dlca_params *p, const char *path, char *err,
                      size_t errlen)
{
    dck_finish(c, tab);
    dck_totals t;
    if (read_totals(f, &t) < 0) return pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close /results", path);
    dck_results(c, &t, tab, p);
    const dlca_row end = dck_end_row(c, &t);
    int rc = check_series(c, f, &end, &t, path, err, errlen);
    dck_report_state(c, &t);
    if (rc || c->r->stopped) return rc;
    if (!t.has_t || !t.has_attempts || !t.has_nc) return 0; /* failed; the snapshots need them */
    const dlca_snap_end e = {t.t, t.attempts, t.n_clusters, c->N, c->V, p->mobility};
    rc = dck_snapshots_file(c, path, &e, &t);
    return rc ? pdla_errorf(rc, err, errlen, "%s: out of memory", path) : 0;
}

/* The parameters (through the model's table; N checked against count and
 * fill below), then the monomers and the rest. */
static int check_open(hid_t f, const char *path, dlca_check_report *r, char *err, size_t errlen)
{
    dlca_params p;
    dlca_params_default(&p);
    int version = 0;
    if (pdla_h5_attr_number(f, "format_version", PDLA_H5_I32, &version) < 0 || version != 1)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: its format_version is not 1, the one pdla writes", path);
    if (dlca_read_parameters_h5(f, &p, 0))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: /parameters missing or out of the model's ranges (a box of "
                           "2 to %d sites an axis and fewer than 2^31 in all)", path, DLCA_MAX_AXIS);
    mono m;
    uint64_t N = 0, V = 1;
    for (int a = 0; a < p.dim; a++) V *= p.box[a];
    int rc = mono_open(f, p.dim, &m, &N, path, err, errlen);
    if (rc) return rc;
    dck_report_params(r, &p, N);
    if (N < 1 || N >= V)
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %" PRIu64 " monomers in a box of %" PRIu64 " sites (a run has "
                         "1 to V - 1)", path, N, V);
    /* The writer records count = N for a --start run too, so every file it
     * writes has N = count, or round(fill V) with count 0 (a forged count
     * of 500 over 205 monomers passed). */
    else if (dlca_params_monomers(&p) != N)
        rc = pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %" PRIu64 " monomers, but /parameters count %" PRIu64
                         " and fill %.17g give %" PRIu64, path, N, (uint64_t)p.count, p.fill,
                         dlca_params_monomers(&p));
    else if (!dck_fits(V, N, p.dim))
        rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: %" PRIu64 " monomers in a box of %" PRIu64 " sites need more "
                         "than half of this machine's memory to check", path, N, V);
    uint64_t *size = NULL;
    double *rg = NULL;
    dck_table tab = {0};
    dck c;
    if (!rc) rc = read_clusters(f, N, &tab, &size, &rg, path, err, errlen);
    if (!rc && dck_init(&c, r, &p, N)) rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", path);
    else if (!rc) {
        rc = feed_monomers(&c, &m, path, err, errlen);
        if (!rc && !r->stopped) rc = check_rest(&c, f, &tab, &p, path, err, errlen);
        dck_verdict(&c);
        dck_free(&c);
    }
    free(size), free(rg);
    if (mono_close(&m) < 0 && !rc) rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close /monomers", path);
    return rc;
}

static int check_h5(const char *path, dlca_check_report *r, char *err, size_t errlen)
{
    h5u_quiet q;
    if (h5u_silence(&q)) return pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot silence HDF5", path);
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    int rc = f < 0 ? pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot open it as HDF5", path)
                   : check_open(f, path, r, err, errlen);
    if (f >= 0 && H5Fclose(f) < 0 && !rc) rc = pdla_errorf(PDLA_EIO, err, errlen, "%s: cannot close it", path);
    if (h5u_restore(&q) < 0 && !rc) rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot restore the HDF5 error handler");
    return rc;
}

int dlca_check_file(const char *path, dlca_check_report *r, char *err, size_t errlen)
{
    memset(r, 0, sizeof *r);
    char model[32];
    struct stat st; /* never open a FIFO or device: HDF5 would block on it */
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: not a regular file", path);
    if (pdla_h5_file_model(path, model, sizeof model))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: not an HDF5 file with a root attribute model (not a DLCA "
                           "file)", path);
    if (!strcmp(model, "dlca-checkpoint")) return dck_checkpoint(path, r, err, errlen);
    if (strcmp(model, "dlca"))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: model '%s', not a DLCA cluster.h5 or checkpoint", path, model);
    return check_h5(path, r, err, errlen);
}
