/*
 * export_src.c - the particles of any pdla output for `pdla export` (see
 * export_src.h): every dataset is opened and checked through h5check.h
 * (type, shape, and that the rows it declares are stored) before a row is
 * read, and rows stream in slabs of bounded size.
 */
#include "export_src.h"

#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dlca_cmd.h"
#include "pdla/dlca.h"
#include "pdla/pdla.h"
#include "tools.h"

int exp_src_close(exp_src *s)
{
    if (s->kind == EXP_DLA) return h5r_close(&s->dla);
    int rc = pdla_h5_dset_close(&s->pos);
    if (pdla_h5_dset_close(&s->radius) < 0) rc = -1;
    if (pdla_h5_dset_close(&s->cid) < 0) rc = -1;
    if (s->file >= 0 && H5Fclose(s->file) < 0) rc = -1;
    s->file = H5I_INVALID_HID;
    return rc;
}

/* name: a dataset of `rank` with rows rows (0: any) whose declared
 * elements (esize bytes each in memory) are stored; kind 'i' (integer) or
 * 'f' (real). */
static int open_checked(exp_src *s, const char *name, pdla_h5_dset *d, int rank, uint64_t rows, char kind,
                        size_t esize, char *err, size_t errlen)
{
    if (H5Lexists(s->file, name, H5P_DEFAULT) <= 0 || pdla_h5_dset_open(s->file, name, d) < 0)
        return pdla_errorf(-1, err, errlen, "%s has no %s dataset", s->path, name);
    const int is_int = d->kind == 'i' || d->kind == 'u';
    if ((kind == 'i' && !is_int) || (kind == 'f' && d->kind != 'f'))
        return pdla_errorf(-1, err, errlen, "%s: %s is not %s dataset", s->path, name, kind == 'i' ? "an integer" : "a real");
    if (d->rank != rank)
        return pdla_errorf(-1, err, errlen, "%s: %s has rank %d, want %d", s->path, name, d->rank, rank);
    if (rows && d->dims[0] != rows)
        return pdla_errorf(-1, err, errlen, "%s: %s has %llu rows, want %llu", s->path, name,
                    (unsigned long long)d->dims[0], (unsigned long long)rows);
    if (rank == 2 && d->dims[1] != 2 && d->dims[1] != 3)
        return pdla_errorf(-1, err, errlen, "%s: %s has %llu columns; export writes 2D and 3D positions", s->path, name,
                    (unsigned long long)d->dims[1]);
    switch (pdla_h5_dset_stored(d, esize)) {
    case PDLA_H5_STORED: return 0;
    case PDLA_H5_TOO_LARGE:
        return pdla_errorf(-1, err, errlen, "%s: %s declares %llu elements, more than this machine can address", s->path,
                    name, (unsigned long long)d->elems);
    default:
        return pdla_errorf(-1, err, errlen,
                    "%s: %s declares %llu elements but the file stores only %llu bytes of it "
                    "(damaged or not written by pdla)",
                    s->path, name, (unsigned long long)d->elems, (unsigned long long)d->stored);
    }
}

static int open_ensemble(exp_src *s, int64_t cluster, char *err, size_t errlen)
{
    const char *const name = "/clusters/positions";
    int64_t v = 0;
    if (pdla_h5_attr_number(s->file, "format_version", PDLA_H5_I64, &v) != 0 || v != 1)
        return pdla_errorf(-1, err, errlen, "%s: unsupported format_version (this pdla reads version 1)", s->path);
    if (H5Lexists(s->file, "/ensemble", H5P_DEFAULT) <= 0)
        return pdla_errorf(-1, err, errlen, "%s: no /ensemble group", s->path);
    const hid_t g = H5Oopen(s->file, "/ensemble", H5P_DEFAULT);
    int ok = g >= 0 && pdla_h5_attr_number(g, "clusters", PDLA_H5_U64, &s->clusters) == 0;
    if (g >= 0 && H5Oclose(g) < 0) ok = 0;
    if (!ok || s->clusters == 0) return pdla_errorf(-1, err, errlen, "%s: no valid /ensemble clusters attribute", s->path);
    if (H5Lexists(s->file, "/clusters", H5P_DEFAULT) <= 0 || H5Lexists(s->file, name, H5P_DEFAULT) <= 0)
        return pdla_errorf(-1, err, errlen, "%s holds no positions (grown without --keep-positions)", s->path);
    if (open_checked(s, name, &s->pos, 2, 0, 'i', sizeof(int32_t), err, errlen)) return -1;
    if (pdla_h5_attr_number(s->pos.id, "rows_per_cluster", PDLA_H5_U64, &s->per_cluster) != 0 ||
        s->per_cluster == 0 || s->per_cluster > UINT64_MAX / s->clusters ||
        s->per_cluster * s->clusters != s->pos.dims[0])
        return pdla_errorf(-1, err, errlen, "%s: %s has %llu rows, not /ensemble clusters x rows_per_cluster", s->path, name,
                    (unsigned long long)s->pos.dims[0]);
    if (pdla_h5_attr_number(s->pos.id, "diameter_units", PDLA_H5_I64, &v) != 0 || v < 1 || v > 1 << 20)
        return pdla_errorf(-1, err, errlen, "%s: no valid diameter_units attribute on %s", s->path, name);
    s->units = (int)v;
    char order[64];
    s->arrival = pdla_h5_attr_str(s->pos.id, "order", order, sizeof order) == 0 && !strcmp(order, "arrival");
    if (cluster >= 0 && (uint64_t)cluster >= s->clusters)
        return pdla_errorf(-1, err, errlen, "--cluster %lld: %s has clusters 0..%llu", (long long)cluster, s->path,
                    (unsigned long long)(s->clusters - 1));
    s->cluster = cluster;
    s->row0 = cluster >= 0 ? (uint64_t)cluster * s->per_cluster : 0;
    s->n = cluster >= 0 ? s->per_cluster : s->pos.dims[0];
    s->cluster_col = cluster < 0;
    s->distance = 1;
    s->unit_name = "diameters";
    return 0;
}

/* Rows [row, row + rows) of a DLCA file's positions pos (dim columns) in
 * the box L and each on a site no earlier row took (a bit a site in taken).
 * 0, or -1 with one line naming the row. */
static int dlca_rows_ok(const exp_src *s, const int32_t *pos, size_t rows, uint64_t row, int dim, const uint64_t *L,
                        uint64_t *taken, char *err, size_t errlen)
{
    for (size_t i = 0; i < rows; i++) {
        uint64_t k = 0, stride = 1;
        for (int a = 0; a < dim; a++) {
            const int32_t x = pos[i * (size_t)dim + (size_t)a];
            if (x < 0 || (uint64_t)x >= L[a])
                return pdla_errorf(-1, err, errlen, "%s: row %llu: coordinate %d on axis %d is outside the box [0, "
                                   "%llu)", s->path, (unsigned long long)(row + i), (int)x, a + 1,
                                   (unsigned long long)L[a]);
            k += (uint64_t)x * stride;
            stride *= L[a];
        }
        if (taken[k >> 6] >> (k & 63) & 1)
            return pdla_errorf(-1, err, errlen, "%s: row %llu: a second monomer on the site of an earlier row", s->path,
                               (unsigned long long)(row + i));
        taken[k >> 6] |= UINT64_C(1) << (k & 63);
    }
    return 0;
}

/* A DLCA file's positions, read once in slabs before anything is written:
 * each in the /parameters box and no two on one site (a monomer copied
 * onto another's site was exported twice, exit 0). A bit a lattice site
 * (at most 256 MiB: the model's sites are fewer than 2^31) and one slab,
 * both freed here. 0, or -1 with one line. */
static int dlca_sites_ok(const exp_src *s, char *err, size_t errlen)
{
    int dim = 0;
    uint64_t L[DLCA_MAX_DIM], V = 1;
    if (dlca_file_box(s->file, s->path, &dim, L, err, errlen)) return -1;
    if ((uint64_t)dim != s->pos.dims[1])
        return pdla_errorf(-1, err, errlen, "%s: /monomers/position has %llu columns, /parameters dim is %d", s->path,
                           (unsigned long long)s->pos.dims[1], dim);
    for (int a = 0; a < dim; a++) V *= L[a];
    const size_t slab = H5R_MAX_SLAB_ROWS;
    uint64_t *taken = calloc((size_t)((V + 63) / 64), sizeof *taken);
    int32_t *pos = malloc(slab * (size_t)dim * sizeof *pos);
    int rc = taken && pos ? 0 : pdla_errorf(-1, err, errlen, "%s: out of memory for a bit a site (%llu sites)",
                                              s->path, (unsigned long long)V);
    for (uint64_t row = 0; rc == 0 && row < s->pos.dims[0]; row += slab) {
        const size_t rows = s->pos.dims[0] - row < slab ? (size_t)(s->pos.dims[0] - row) : slab;
        if (pdla_h5_dset_read(&s->pos, PDLA_H5_I32, row, rows, pos) < 0)
            rc = pdla_errorf(-1, err, errlen, "%s: cannot read rows %llu..%llu of /monomers/position (damaged?)",
                             s->path, (unsigned long long)row, (unsigned long long)(row + rows - 1));
        else
            rc = dlca_rows_ok(s, pos, rows, row, dim, L, taken, err, errlen);
    }
    free(taken), free(pos);
    return rc;
}

static int open_dlca(exp_src *s, char *err, size_t errlen)
{
    pdla_h5_dset probe;
    if (pdla_h5_dset_open(s->file, "/monomers/position", &probe) == 0) {
        const int rank = probe.rank;
        const uint64_t cols = rank == 2 ? probe.dims[1] : 1;
        if (pdla_h5_dset_close(&probe) < 0)
            return pdla_errorf(-1, err, errlen, "%s: cannot close /monomers/position", s->path);
        if (rank != 2 || cols < 2 || cols > 3)
            return pdla_errorf(-1, err, errlen, "%s: a %lluD DLCA lattice; export writes 2D and 3D positions", s->path,
                        (unsigned long long)cols);
    }
    if (open_checked(s, "/monomers/position", &s->pos, 2, 0, 'i', sizeof(int32_t), err, errlen) ||
        open_checked(s, "/monomers/cluster", &s->cid, 1, s->pos.dims[0], 'i', sizeof(uint64_t), err, errlen) ||
        dlca_sites_ok(s, err, errlen))
        return -1;
    s->n = s->pos.dims[0];
    s->units = 1;
    s->cluster_col = 1;
    s->unit_name = "lattice sites";
    return 0;
}

static int open_event(exp_src *s, char *err, size_t errlen)
{
    if (open_checked(s, "/cluster/positions", &s->pos, 2, 0, 'f', sizeof(double), err, errlen) ||
        open_checked(s, "/cluster/radii", &s->radius, 1, s->pos.dims[0], 'f', sizeof(double), err, errlen))
        return -1;
    s->n = s->pos.dims[0];
    s->real = 1;
    s->units = 1;
    s->arrival = 1; /* the stuck particles, in arrival order */
    s->unit_name = "model lengths";
    return 0;
}

int exp_src_open(exp_src *s, const char *path, int64_t cluster, char *err, size_t errlen)
{
    memset(s, 0, sizeof *s);
    s->path = path;
    s->file = s->pos.id = s->radius.id = s->cid.id = H5I_INVALID_HID;
    s->dla.file = s->dla.pos.id = H5I_INVALID_HID;
    s->cluster = -1;
    if (pdla_hdf5_quiet()) return pdla_errorf(-1, err, errlen, "%s: cannot silence HDF5", path);
    char model[64];
    const int has_model = pdla_h5_file_model(path, model, sizeof model) == 0;
    const int ens = !has_model && ens_analyze_is_ensemble(path);
    if (!has_model && !ens) {
        /* A DLA cluster file, or h5read.c says what it is not. */
        s->kind = EXP_DLA;
        if (cluster >= 0) {
            if (h5r_open(&s->dla, path, err, errlen)) return -1;
            (void)h5r_close(&s->dla); /* the failure to report is the one below */
            return pdla_errorf(-1, err, errlen, "--cluster applies to ensemble files; %s is one cluster", path);
        }
        if (h5r_open(&s->dla, path, err, errlen)) return -1;
        s->pos = s->dla.pos;
        s->dim = s->dla.dim;
        s->n = s->dla.n;
        s->units = s->dla.diameter_units;
        s->arrival = s->dla.arrival;
        s->distance = 1;
        s->unit_name = "diameters";
        return 0;
    }
    s->kind = ens ? EXP_ENSEMBLE : !strcmp(model, "dlca") ? EXP_DLCA : !strcmp(model, "event") ? EXP_EVENT : -1;
    if (s->kind < 0) return pdla_errorf(-1, err, errlen, "%s: model \"%s\" holds no particles export knows", path, model);
    if (cluster >= 0 && s->kind != EXP_ENSEMBLE)
        return pdla_errorf(-1, err, errlen, "--cluster applies to ensemble files; %s is a %s file", path, model);
    if ((s->file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT)) < 0)
        return pdla_errorf(-1, err, errlen, "%s: HDF5 cannot open it (damaged?)", path);
    const int rc = s->kind == EXP_ENSEMBLE ? open_ensemble(s, cluster, err, errlen)
                   : s->kind == EXP_DLCA   ? open_dlca(s, err, errlen)
                                           : open_event(s, err, errlen);
    if (rc) {
        (void)exp_src_close(s); /* the failure to report is the one in err */
        return -1;
    }
    s->dim = (int)s->pos.dims[1];
    return 0;
}

/* Real positions finite and radii finite and >= 0 (an event file forged
 * with a NaN position was exported as NaN, exit 0): 1 if so. */
static int slab_numbers_ok(const double *pos, size_t npos, const double *radius, size_t rows)
{
    for (size_t i = 0; i < npos; i++)
        if (!isfinite(pos[i])) return 0;
    for (size_t i = 0; radius && i < rows; i++)
        if (!isfinite(radius[i]) || radius[i] < 0) return 0;
    return 1;
}

int exp_src_stream(exp_src *s, size_t slab_rows, exp_fn fn, void *user, char *err, size_t errlen)
{
    if (slab_rows < 1 || slab_rows > H5R_MAX_SLAB_ROWS) slab_rows = H5R_MAX_SLAB_ROWS;
    if (s->n == 0) return 0;
    if (s->n < slab_rows) slab_rows = (size_t)s->n;
    const size_t dim = (size_t)s->dim;
    void *pos = malloc(slab_rows * dim * (s->real ? sizeof(double) : sizeof(int32_t)));
    double *radius = s->radius.id >= 0 ? malloc(slab_rows * sizeof *radius) : NULL;
    uint64_t *cl = s->cluster_col ? malloc(slab_rows * sizeof *cl) : NULL;
    uint64_t *index = malloc(slab_rows * sizeof *index);
    int rc = 0;
    if (!pos || !index || (s->radius.id >= 0 && !radius) || (s->cluster_col && !cl))
        rc = pdla_errorf(-1, err, errlen, "out of memory for %zu rows", slab_rows);
    for (uint64_t first = 0; first < s->n && rc == 0; first += slab_rows) {
        const uint64_t left = s->n - first, row = s->row0 + first;
        const size_t rows = left < slab_rows ? (size_t)left : slab_rows;
        const char *bad = NULL;
        if (pdla_h5_dset_read(&s->pos, s->real ? PDLA_H5_F64 : PDLA_H5_I32, row, rows, pos) < 0) bad = "positions";
        else if (radius && pdla_h5_dset_read(&s->radius, PDLA_H5_F64, row, rows, radius) < 0) bad = "radii";
        else if (cl && s->cid.id >= 0 && pdla_h5_dset_read(&s->cid, PDLA_H5_U64, row, rows, cl) < 0)
            bad = "cluster ids";
        if (bad) {
            rc = pdla_errorf(-1, err, errlen, "%s: cannot read rows %llu..%llu of the %s (damaged, or a value beyond "
                                             "the type read?)", s->path,
                      (unsigned long long)row, (unsigned long long)(row + rows - 1), bad);
            break;
        }
        if (s->real && !slab_numbers_ok(pos, rows * dim, radius, rows)) {
            rc = pdla_errorf(-1, err, errlen, "%s: rows %llu..%llu hold a position or radius that is not a finite "
                             "number (or a negative radius)", s->path, (unsigned long long)row,
                             (unsigned long long)(row + rows - 1));
            break;
        }
        for (size_t i = 0; i < rows; i++) {
            const uint64_t r = row + i;
            index[i] = s->per_cluster ? r % s->per_cluster : r;
            if (cl && s->cid.id < 0) cl[i] = r / s->per_cluster;
        }
        const exp_slab slab = {rows, first, s->real ? NULL : pos, s->real ? pos : NULL, radius, cl, index};
        rc = fn(&slab, user);
    }
    free(pos), free(radius), free(cl), free(index);
    return rc;
}
