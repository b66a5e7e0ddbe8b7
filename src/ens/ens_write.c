/*
 * ens_write.c - pdla_ens_write(): a complete journal into DIR/ensemble.h5.
 *
 * Layout (HDF5 1.10 format, attributes as in cluster.h5):
 *   /                     format = "pdla-ensemble", format_version = 1, units
 *   /parameters           cluster 0's growth parameters (seed = the first seed)
 *   /ensemble             attrs clusters, first_seed, seed_rule, keep_positions,
 *                         particles (per cluster), total_cpu_seconds, builds
 *                         (the revisions of pdla that grew the clusters,
 *                         space-separated, in the order they joined)
 *   /gyration/N           u64 [K], the shared log grid of R_g samples
 *   /clusters/rg_diam     f64 [M][K], R_g(N) of each cluster, diameters
 *   /clusters/index, seed, particles, walkers, jumps (u64 [M]),
 *            rg_final_diam, r_ext_diam, D_f, D_f_err, prefactor_diam (f64 [M]),
 *            fit_n_lo, fit_n_hi (u64 [M]), fit_points (i32 [M]),
 *            cpu_seconds, wall_seconds (f64 [M]; timings, not reproducible)
 *   /clusters/positions   i32 [M*N][dim] with --keep-positions: rows
 *                         i*N .. i*N+N-1 are cluster i (attr rows_per_cluster);
 *                         chunks of min(N, 65536) rows, so reading cluster i
 *                         touches only its own chunks (one when N <= 65536,
 *                         at most ceil(N / 65536) + 1 else), shuffle + deflate
 *                         at the level asked (attr deflate_level; 0: none)
 *                         and Fletcher32 like every dataset
 *   DIR/ensemble.xdmf2    with positions: the ParaView sidecar (xdmf.h), one
 *                         block per cluster
 *   /statistics           ensemble statistics (pdla_ens_stats_compute, ens_stats.c)
 *   /Code                 provenance, as in cluster.h5
 * Every per-cluster dataset is in cluster index order, so two runs of the
 * same ensemble agree dataset by dataset whatever threads grew them (the
 * timings excepted).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <hdf5.h>

#include "pdla/ensemble.h"
#include "pdla/xdmf.h"
#include "h5util.h"
#include "provenance.h"

static int write_ds(const h5u_writer *w, hid_t loc, const char *name, hid_t ftype, hid_t mtype, int rank,
                    hsize_t rows, hsize_t cols, const void *data, const char *units)
{
    hid_t space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    int rc = -1;
    const hsize_t chunk = rank == 2 && cols > 0 ? (65536 / cols > 0 ? 65536 / cols : 1) : 65536;
    if ((d = h5u_dataset(w, loc, name, ftype, rank, rows, cols, chunk, &space)) < 0) goto fail;
    if (rows > 0 && cols > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
        h5u_fail(w, "write %s", name);
        goto fail;
    }
    if (units && h5u_attr_str(w, d, "units", units) < 0) goto fail;
    rc = 0;
fail:
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

static int ens_write_u64(const h5u_writer *w, hid_t g, const char *name, const uint64_t *v, size_t n, const char *units)
{
    return write_ds(w, g, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, 1, n, 1, v, units);
}

static int ens_write_f64(const h5u_writer *w, hid_t g, const char *name, const double *v, size_t n, const char *units)
{
    return write_ds(w, g, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, n, 1, v, units);
}

/* /statistics from the R_g matrix (m x k) and the clusters' own D_f. */

static int write_statistics(const h5u_writer *w, hid_t file, const uint64_t *grid, size_t k, const double *rg,
                         size_t m, const double *df_cluster, uint64_t n_final)
{
    pdla_ens_stats s;
    if (pdla_ens_stats_compute(grid, k, rg, m, df_cluster, n_final, PDLA_ENS_BOOT_SAMPLES, PDLA_ENS_CORR_SAMPLES,
                               PDLA_ENS_BOOT_SEED, &s, w->err, w->errlen))
        return -1;
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = h5u_group(w, file, "statistics")) < 0) goto fail;
    if (ens_write_f64(w, g, "mean_rg_diam", s.mean_rg, k, "diameters") < 0 ||
        ens_write_f64(w, g, "se_rg_diam", s.se_rg, k, "diameters") < 0 ||
        ens_write_f64(w, g, "slope_N", s.slope_n, s.nslope, "particles") < 0 ||
        ens_write_f64(w, g, "slope_D_f", s.slope_df, s.nslope, NULL) < 0 ||
        ens_write_f64(w, g, "slope_D_f_lo", s.slope_lo, s.nslope, NULL) < 0 ||
        ens_write_f64(w, g, "slope_D_f_hi", s.slope_hi, s.nslope, NULL) < 0 ||
        h5u_attr_u64(w, g, "fit_n_lo", s.n_lo) < 0 || h5u_attr_u64(w, g, "fit_n_hi", s.n_hi) < 0 ||
        h5u_attr_f64(w, g, "D_f", s.df) < 0 || h5u_attr_f64(w, g, "D_f_lo", s.df_lo) < 0 ||
        h5u_attr_f64(w, g, "D_f_hi", s.df_hi) < 0 || h5u_attr_f64(w, g, "D_f_boot_sd", s.df_boot_sd) < 0 ||
        h5u_attr_f64(w, g, "prefactor_diam", s.prefactor_diam) < 0 ||
        h5u_attr_int(w, g, "bootstrap_samples", s.boot_samples) < 0 ||
        h5u_attr_u64(w, g, "bootstrap_seed", s.boot_seed) < 0 ||
        h5u_attr_str(w, g, "interval", "95% percentile bootstrap over clusters") < 0 ||
        h5u_attr_f64(w, g, "slope_window_decades", s.slope_window) < 0 ||
        h5u_attr_str(w, g, "correction_model",
                     "R_g = A N^(1/D) (1 + B N^-nu), least squares on ln R_g, |B N^-nu| <= 0.9") < 0 ||
        h5u_attr_f64(w, g, "corr_correction_max", s.corr_max) < 0 ||
        h5u_attr_int(w, g, "corr_ok", s.corr_ok) < 0 || h5u_attr_int(w, g, "corr_samples", s.corr_samples) < 0 ||
        h5u_attr_u64(w, g, "corr_n_lo", s.corr_n_lo) < 0 ||
        h5u_attr_f64(w, g, "corr_A_diam", s.corr_A) < 0 || h5u_attr_f64(w, g, "corr_A_lo", s.corr_A_lo) < 0 ||
        h5u_attr_f64(w, g, "corr_A_hi", s.corr_A_hi) < 0 || h5u_attr_f64(w, g, "corr_D", s.corr_D) < 0 ||
        h5u_attr_f64(w, g, "corr_D_lo", s.corr_D_lo) < 0 || h5u_attr_f64(w, g, "corr_D_hi", s.corr_D_hi) < 0 ||
        h5u_attr_f64(w, g, "corr_B", s.corr_B) < 0 || h5u_attr_f64(w, g, "corr_nu", s.corr_nu) < 0 ||
        h5u_attr_f64(w, g, "corr_rms", s.corr_rms) < 0 ||
        h5u_attr_f64(w, g, "D_f_cluster_mean", s.df_cluster_mean) < 0 ||
        h5u_attr_f64(w, g, "D_f_cluster_sd", s.df_cluster_sd) < 0)
        goto fail;
    rc = 0;
fail:
    pdla_ens_stats_free(&s);
    return h5u_close(w, rc, g, H5Gclose, "/statistics");
}

/* Per-cluster columns, filled from the records in index order. */
typedef struct columns {
    size_t m, k;
    uint64_t *index, *seed, *particles, *walkers, *jumps, *n_lo, *n_hi;
    double *rg_final, *r_ext, *df, *df_err, *pref, *cpu, *wall;
    int32_t *points;
    double *rg;      /* m x k */
    uint64_t *grid;  /* k */
} columns;

static void columns_free(columns *c)
{
    free(c->index), free(c->seed), free(c->particles), free(c->walkers), free(c->jumps);
    free(c->n_lo), free(c->n_hi), free(c->rg_final), free(c->r_ext), free(c->df), free(c->df_err);
    free(c->pref), free(c->cpu), free(c->wall), free(c->points), free(c->rg), free(c->grid);
}

static int columns_alloc(columns *c, size_t m)
{
    memset(c, 0, sizeof *c);
    c->m = m;
    uint64_t **u[] = {&c->index, &c->seed, &c->particles, &c->walkers, &c->jumps, &c->n_lo, &c->n_hi};
    double **d[] = {&c->rg_final, &c->r_ext, &c->df, &c->df_err, &c->pref, &c->cpu, &c->wall};
    int bad = 0;
    for (size_t i = 0; i < sizeof u / sizeof u[0]; i++) bad |= !(*u[i] = malloc(m * 8));
    for (size_t i = 0; i < sizeof d / sizeof d[0]; i++) bad |= !(*d[i] = malloc(m * 8));
    bad |= !(c->points = malloc(m * 4));
    return bad ? -1 : 0;
}

/* Read every record into the columns (and the R_g matrix). */
static int gather(const pdla_ens_journal *j, columns *c, char *err, size_t errlen)
{
    const pdla_ens_config *cfg = pdla_ens_journal_config(j);
    if (cfg->clusters > SIZE_MAX / 64 || columns_alloc(c, (size_t)cfg->clusters))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the ensemble's columns");
    for (size_t i = 0; i < c->m; i++) {
        pdla_ens_record r;
        int rc = pdla_ens_journal_read(j, i, &r, err, errlen);
        if (rc) return rc;
        if (i == 0) {
            c->k = (size_t)r.rg_count;
            c->grid = malloc((c->k ? c->k : 1) * 8);
            c->rg = c->k && c->m > SIZE_MAX / 8 / c->k ? NULL : malloc((c->m * c->k > 0 ? c->m * c->k : 1) * 8);
            if (!c->grid || !c->rg) {
                pdla_ens_record_free(&r);
                return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the R_g matrix");
            }
            if (c->k) memcpy(c->grid, r.rg_n, c->k * 8);
        }
        if (r.rg_count != c->k || (c->k && memcmp(c->grid, r.rg_n, c->k * 8))) {
            pdla_ens_record_free(&r);
            return pdla_errorf(PDLA_EIO, err, errlen, "cluster %zu's R_g samples are not on the shared grid", i);
        }
        if (c->k) memcpy(c->rg + i * c->k, r.rg, c->k * 8);
        c->index[i] = r.index, c->seed[i] = r.seed, c->particles[i] = r.particles;
        c->walkers[i] = r.walkers, c->jumps[i] = r.jumps, c->n_lo[i] = r.fit.n_lo, c->n_hi[i] = r.fit.n_hi;
        c->rg_final[i] = r.rg_diam, c->r_ext[i] = r.r_ext_diam, c->df[i] = r.fit.df;
        c->df_err[i] = r.fit.df_err, c->pref[i] = r.fit.prefactor_diam, c->cpu[i] = r.cpu_seconds;
        c->wall[i] = r.wall_seconds, c->points[i] = r.fit.points;
        pdla_ens_record_free(&r);
    }
    return PDLA_OK;
}

static int write_clusters(const h5u_writer *w, hid_t file, const columns *c)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    const size_t m = c->m;
    if ((g = h5u_group(w, file, "clusters")) < 0) goto fail;
    if (write_ds(w, g, "rg_diam", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, m, c->k, c->rg, "diameters") < 0 ||
        ens_write_u64(w, g, "index", c->index, m, NULL) < 0 || ens_write_u64(w, g, "seed", c->seed, m, NULL) < 0 ||
        ens_write_u64(w, g, "particles", c->particles, m, "particles") < 0 ||
        ens_write_u64(w, g, "walkers", c->walkers, m, NULL) < 0 ||
        ens_write_u64(w, g, "jumps", c->jumps, m, NULL) < 0 ||
        ens_write_f64(w, g, "rg_final_diam", c->rg_final, m, "diameters") < 0 ||
        ens_write_f64(w, g, "r_ext_diam", c->r_ext, m, "diameters") < 0 ||
        ens_write_f64(w, g, "D_f", c->df, m, NULL) < 0 || ens_write_f64(w, g, "D_f_err", c->df_err, m, NULL) < 0 ||
        ens_write_f64(w, g, "prefactor_diam", c->pref, m, "diameters") < 0 ||
        ens_write_u64(w, g, "fit_n_lo", c->n_lo, m, "particles") < 0 ||
        ens_write_u64(w, g, "fit_n_hi", c->n_hi, m, "particles") < 0 ||
        write_ds(w, g, "fit_points", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, m, 1, c->points, NULL) < 0 ||
        ens_write_f64(w, g, "cpu_seconds", c->cpu, m, "seconds") < 0 ||
        ens_write_f64(w, g, "wall_seconds", c->wall, m, "seconds") < 0)
        goto fail;
    rc = 0;
fail:
    return h5u_close(w, rc, g, H5Gclose, "/clusters");
}

/* /clusters/positions, one cluster's rows at a time from the journal. */
static int write_positions(const h5u_writer *w, hid_t file, const pdla_ens_journal *j, const columns *c,
                           int gzip)
{
    const pdla_ens_config *cfg = pdla_ens_journal_config(j);
    const hsize_t n = cfg->params.target, dim = (hsize_t)cfg->params.dim;
    hid_t g = H5I_INVALID_HID, d = H5I_INVALID_HID, space = H5I_INVALID_HID, ms = H5I_INVALID_HID;
    int rc = -1;
    for (size_t i = 0; i < c->m; i++)
        if (c->particles[i] != n) {
            h5u_fail_msg(w, "cluster %zu has %llu particles, not %llu", i, (unsigned long long)c->particles[i],
                         (unsigned long long)n);
            return -1;
        }
    if ((g = H5Gopen2(file, "clusters", H5P_DEFAULT)) < 0) {
        h5u_fail(w, "open /clusters");
        goto fail;
    }
    const hsize_t chunk = n < 65536 ? n : 65536;
    if ((d = h5u_dataset_z(w, g, "positions", H5T_STD_I32LE, 2, (hsize_t)c->m * n, dim, chunk, gzip, &space)) <
        0)
        goto fail;
    if (h5u_attr_str(w, d, "units", "lattice units") < 0 || h5u_attr_int(w, d, "deflate_level", gzip) < 0 ||
        h5u_attr_int(w, d, "diameter_units", cfg->params.resolution) < 0 ||
        h5u_attr_u64(w, d, "rows_per_cluster", n) < 0 ||
        h5u_attr_str(w, d, "order", cfg->params.record_arrival ? "arrival" : "tree (not arrival)") < 0)
        goto fail;
    const hsize_t count[2] = {n, dim};
    if (n > 0 && (ms = H5Screate_simple(2, count, NULL)) < 0) {
        h5u_fail(w, "create a memory dataspace");
        goto fail;
    }
    for (size_t i = 0; i < c->m && n > 0; i++) {
        pdla_ens_record r;
        if (pdla_ens_journal_read(j, i, &r, w->err, w->errlen)) goto fail;
        const hsize_t start[2] = {(hsize_t)i * n, 0};
        const int bad = r.npos != n || H5Sselect_hyperslab(space, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
                        H5Dwrite(d, H5T_NATIVE_INT32, ms, space, H5P_DEFAULT, r.positions) < 0;
        pdla_ens_record_free(&r);
        if (bad) {
            h5u_fail(w, "write cluster %zu's positions", i);
            goto fail;
        }
    }
    rc = 0;
fail:
    rc = h5u_close(w, rc, ms, H5Sclose, "a dataspace");
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    rc = h5u_close(w, rc, d, H5Dclose, "/clusters/positions");
    return h5u_close(w, rc, g, H5Gclose, "/clusters");
}

static int write_ensemble(const h5u_writer *w, hid_t file, const pdla_ens_journal *j, const columns *c)
{
    const pdla_ens_config *cfg = pdla_ens_journal_config(j);
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    double cpu = 0;
    for (size_t i = 0; i < c->m; i++) cpu += c->cpu[i];
    const char *builds = *pdla_ens_journal_builds(j) ? pdla_ens_journal_builds(j)
                                                      : "unknown (a journal from before builds were recorded)";
    if ((g = h5u_group(w, file, "ensemble")) < 0) goto fail;
    if (h5u_attr_u64(w, g, "clusters", cfg->clusters) < 0 || h5u_attr_u64(w, g, "first_seed", cfg->params.seed) < 0 ||
        h5u_attr_str(w, g, "seed_rule", "cluster i is the serial DLA cluster of seed first_seed + i") < 0 ||
        h5u_attr_int(w, g, "keep_positions", cfg->keep_positions) < 0 ||
        h5u_attr_u64(w, g, "particles", cfg->params.target) < 0 ||
        h5u_attr_f64(w, g, "total_cpu_seconds", cpu) < 0 || h5u_attr_str(w, g, "builds", builds) < 0)
        goto fail;
    rc = 0;
fail:
    rc = h5u_close(w, rc, g, H5Gclose, "/ensemble");
    if (rc < 0) return rc;
    if ((g = h5u_group(w, file, "gyration")) < 0) return -1;
    rc = ens_write_u64(w, g, "N", c->grid, c->k, "particles");
    return h5u_close(w, rc, g, H5Gclose, "/gyration");
}

static const char units_text[] =
    "Positions are integers in lattice units; one particle diameter is "
    "/parameters resolution units. Names ending in _diam are in diameters.";

static int write_file(const h5u_writer *w, const char *tmp, const pdla_ens_journal *j, const columns *c,
                      const pdla_run_info *info, const pdla_provenance *pv, int gzip)
{
    const pdla_ens_config *cfg = pdla_ens_journal_config(j);
    hid_t file = H5I_INVALID_HID;
    int rc = -1;
    if ((file = h5u_create_file(w, tmp)) < 0) goto fail;
    if (h5u_attr_str(w, file, "format", "pdla-ensemble") < 0 || h5u_attr_int(w, file, "format_version", 1) < 0 ||
        h5u_attr_str(w, file, "units", units_text) < 0 || h5u_write_parameters(w, file, &cfg->params) < 0 ||
        write_ensemble(w, file, j, c) < 0 || write_clusters(w, file, c) < 0 ||
        (cfg->keep_positions && write_positions(w, file, j, c, gzip) < 0) ||
        write_statistics(w, file, c->grid, c->k, c->rg, c->m, c->df, cfg->params.target) < 0 ||
        h5u_write_code(w, file, pv, info ? info->command_line : NULL) < 0)
        goto fail;
    if (h5u_reserve_space(w, file, tmp) < 0) goto fail;
    rc = 0;
fail:
    if (rc < 0 && file >= 0) h5u_divert_writes(file);
    return h5u_close(w, rc, file, H5Fclose, tmp);
}

/* The sidecar beside path when positions are kept; without positions an
 * older one (of a replaced ensemble) is removed: it would point at rows
 * that are no longer there. Other kinds of sidecar (xdmf.h) are removed
 * too. */
static int write_sidecar(const pdla_ens_config *cfg, const char *path, char *err, size_t errlen)
{
    char xmf[4400];
    if (xdmf_sidecar_path(path, xmf, sizeof xmf))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "the path %.200s is too long for its sidecar", path);
    const int shown = cfg->keep_positions && cfg->params.target > 0;
    if (shown) {
        const xdmf_ensemble e = {path, "/clusters/positions", cfg->clusters, cfg->params.target, cfg->params.dim,
                                 cfg->params.resolution, cfg->params.record_arrival};
        if (xdmf_write_ensemble(xmf, &e, err, errlen)) return PDLA_EIO;
    }
    if (xdmf_remove_sidecars(path, shown ? XDMF_SIDECAR_BIT(XDMF_SIDECAR_MAIN) : 0, err, errlen)) return PDLA_EIO;
    return PDLA_OK;
}

/* a * b + c, saturating at UINT64_MAX. */
static uint64_t sat_muladd(uint64_t a, uint64_t b, uint64_t c)
{
    if (b && a > (UINT64_MAX - c) / b) return UINT64_MAX;
    return a * b + c;
}

uint64_t pdla_ens_memory_bytes(const pdla_ens_config *c)
{
    const uint64_t k = pdla_ens_rg_samples_max(c);
    /* Per cluster: the journal's offset and length (16), the columns
     * (14 x 8 + 4), the bootstrap's pick (8), and the R_g row (8 K). The
     * sidecar (about 2.6 kB of text a cluster) is streamed to its file
     * through 64 KiB (xdmf.c), inside the fixed MiB. */
    const uint64_t per = sat_muladd(k, 8, 16 + 116 + 8);
    return sat_muladd(c->clusters, per, sat_muladd(k, 64, 1 << 20));
}

int pdla_ens_write(const pdla_ens_journal *j, const pdla_run_info *info, const char *path, char *err,
                   size_t errlen)
{
    return pdla_ens_write_gz(j, info, path, PDLA_ENS_GZIP_DEFAULT, err, errlen);
}

int pdla_ens_write_gz(const pdla_ens_journal *j, const pdla_run_info *info, const char *path, int gzip,
                      char *err, size_t errlen)
{
    const pdla_ens_config *cfg = pdla_ens_journal_config(j);
    if (gzip < 0 || gzip > 9)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "deflate level %d, want 0..9", gzip);
    if (pdla_ens_journal_count(j) != cfg->clusters)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "the ensemble is incomplete: %llu of %llu clusters",
                           (unsigned long long)pdla_ens_journal_count(j), (unsigned long long)cfg->clusters);
    const h5u_writer w = {path, err, errlen};
    columns c;
    int rc = gather(j, &c, err, errlen);
    if (rc) {
        columns_free(&c);
        return rc;
    }
    char tmp[4400];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) {
        columns_free(&c);
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot create %s: %s", tmp, strerror(errno));
    }
    close(fd);
    h5u_quiet q;
    pdla_provenance pv;
    (void)prov_collect(&pv);
    rc = PDLA_EIO;
    if (h5u_silence(&q) == 0) {
        if (write_file(&w, tmp, j, &c, info, &pv, gzip) == 0) rc = PDLA_OK;
        if (h5u_restore(&q) < 0 && rc == PDLA_OK) {
            h5u_fail_msg(&w, "cannot restore the HDF5 error handler");
            rc = PDLA_EIO;
        }
    } else {
        h5u_fail_msg(&w, "cannot silence the HDF5 error stack");
    }
    columns_free(&c);
    if (rc == PDLA_OK && h5u_trim_and_sync(tmp)) rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot sync %s: %s", tmp, strerror(errno));
    if (rc == PDLA_OK && rename(tmp, path)) rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot rename %s to %s: %s", tmp, path, strerror(errno));
    if (rc != PDLA_OK) {
        unlink(tmp);
        if (err && errlen) h5u_one_line(err);
        return rc;
    }
    char dir[4400];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash) slash[slash == dir ? 1 : 0] = '\0';
    else snprintf(dir, sizeof dir, ".");
    h5u_fsync_dir(dir);
    return write_sidecar(cfg, path, err, errlen);
}
