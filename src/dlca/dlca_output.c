/*
 * dlca_output.c - a DLCA run's cluster.h5 (root attribute model = "dlca"),
 * with /parameters written from the model's descriptor table (dlca_params_h5.c), and the
 * fractal-dimension fit of R_g against cluster size.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "dlca_h5.h"
#include "dlca_sim.h"
#include "h5util.h"
#include "pdla/dlca.h"
#include "pdla/h5check.h"
#include "pdla/xdmf.h"
#include "provenance.h"

int dlca_fractal_dim(const uint64_t *size, const double *rg, size_t n, uint64_t s_min, double *df,
                     double *df_err)
{
    enum { NB = 128 };
    double cnt[NB] = {0}, sx[NB] = {0}, sy[NB] = {0};
    if (s_min < 2) s_min = 2; /* a monomer has R_g = 0 */
    for (size_t i = 0; i < n; i++) {
        if (size[i] < s_min || !(rg[i] > 0)) continue;
        const int b = (int)floor(2.0 * log2((double)size[i]));
        if (b < 0 || b >= NB) continue;
        cnt[b]++;
        sx[b] += log(rg[i]);
        sy[b] += log((double)size[i]);
    }
    double W = 0, X = 0, Y = 0;
    int nb = 0;
    for (int b = 0; b < NB; b++)
        if (cnt[b] >= 2) {
            nb++;
            W += cnt[b];
            X += sx[b];
            Y += sy[b];
        }
    *df = *df_err = NAN;
    if (nb < 2) return nb;
    X /= W;
    Y /= W;
    double sxx = 0, sxy = 0;
    for (int b = 0; b < NB; b++)
        if (cnt[b] >= 2) {
            const double x = sx[b] / cnt[b] - X, y = sy[b] / cnt[b] - Y;
            sxx += cnt[b] * x * x;
            sxy += cnt[b] * x * y;
        }
    if (!(sxx > 0)) return nb;
    *df = sxy / sxx;
    if (nb > 2) {
        double rss = 0;
        for (int b = 0; b < NB; b++)
            if (cnt[b] >= 2) {
                const double x = sx[b] / cnt[b] - X, y = sy[b] / cnt[b] - Y;
                rss += cnt[b] * (y - *df * x) * (y - *df * x);
            }
        *df_err = sqrt(rss / (nb - 2) / sxx);
    }
    return nb;
}

static int write_2d(const h5u_writer *w, hid_t g, const char *name, hid_t ftype, hid_t mtype, const void *data,
                    size_t n, int cols)
{
    hid_t space = H5I_INVALID_HID, d;
    int rc = 0;
    if ((d = h5u_dataset(w, g, name, ftype, cols > 1 ? 2 : 1, n, (hsize_t)cols, n > 65536 ? 65536 : (n ? n : 1),
                         &space)) < 0)
        return -1;
    if (n > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) rc = h5u_fail(w, "write %s", name);
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

static int write_1d(const h5u_writer *w, hid_t g, const char *name, hid_t ftype, hid_t mtype, const void *data,
                    size_t n)
{
    return write_2d(w, g, name, ftype, mtype, data, n, 1);
}

/* The columns of the series, one dataset each. */
static int write_series(const h5u_writer *w, hid_t file, const dlca_sim *s)
{
    size_t n;
    const dlca_row *r = dlca_series(s, &n);
    double *t = malloc((n ? n : 1) * sizeof *t), *ms = malloc((n ? n : 1) * sizeof *ms),
           *ws = malloc((n ? n : 1) * sizeof *ws);
    uint64_t *at = malloc((n ? n : 1) * sizeof *at), *nc = malloc((n ? n : 1) * sizeof *nc),
             *lg = malloc((n ? n : 1) * sizeof *lg);
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if (!t || !ms || !ws || !at || !nc || !lg) {
        h5u_fail_msg(w, "cannot write %s: out of memory", w->path);
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        t[i] = r[i].t;
        ms[i] = r[i].mean_size;
        ws[i] = r[i].weight_size;
        at[i] = r[i].attempts;
        nc[i] = r[i].n_clusters;
        lg[i] = r[i].largest;
    }
    if ((g = h5u_group(w, file, "series")) < 0) goto done;
    if (write_1d(w, g, "t", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, t, n) < 0 ||
        write_1d(w, g, "attempts", H5T_STD_U64LE, H5T_NATIVE_UINT64, at, n) < 0 ||
        write_1d(w, g, "n_clusters", H5T_STD_U64LE, H5T_NATIVE_UINT64, nc, n) < 0 ||
        write_1d(w, g, "mean_size", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, ms, n) < 0 ||
        write_1d(w, g, "weight_average_size", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, ws, n) < 0 ||
        write_1d(w, g, "largest", H5T_STD_U64LE, H5T_NATIVE_UINT64, lg, n) < 0)
        goto done;
    rc = 0;
done:
    free(t), free(ms), free(ws), free(at), free(nc), free(lg);
    return g < 0 ? rc : h5u_close(w, rc, g, H5Gclose, "/series");
}

/* The /results group of dlca_write_h5: the run's totals as attributes, in a
 * step of its own so the writer reads group by group. -1 on failure (err set
 * by the h5u call that failed), the group closed either way. */
static int write_results(const h5u_writer *w, hid_t file, const dlca_stats *st, double df, double dferr,
                         double wall_s)
{
    const size_t N = st->n_monomers, nc = st->n_clusters;
    const hid_t g = h5u_group(w, file, "results");
    if (g < 0) return -1;
    if (h5u_attr_f64(w, g, "t", st->t) < 0 || h5u_attr_u64(w, g, "attempts", st->attempts) < 0 ||
        h5u_attr_u64(w, g, "moves", st->moves) < 0 || h5u_attr_u64(w, g, "monomer_moves", st->monomer_moves) < 0 ||
        h5u_attr_u64(w, g, "merges", st->merges) < 0 || h5u_attr_u64(w, g, "n_monomers", st->n_monomers) < 0 ||
        h5u_attr_u64(w, g, "n_clusters", st->n_clusters) < 0 || h5u_attr_u64(w, g, "largest", st->largest) < 0 ||
        h5u_attr_f64(w, g, "mean_size", (double)N / (double)nc) < 0 ||
        h5u_attr_f64(w, g, "weight_average_size", st->sum_s2 / (double)N) < 0 ||
        h5u_attr_str(w, g, "stop", dlca_stop_name(st->stop)) < 0 ||
        h5u_attr_str(w, g, "search_used", dlca_search_name(st->search_now)) < 0 ||
        h5u_attr_f64(w, g, "D_f", df) < 0 || h5u_attr_f64(w, g, "D_f_err", dferr) < 0 ||
        h5u_attr_u64(w, g, "history_digest", st->digest) < 0 || h5u_attr_u64(w, g, "model_bytes", st->bytes) < 0 ||
        h5u_attr_f64(w, g, "wall_s", wall_s) < 0)
        return h5u_close(w, -1, g, H5Gclose, "a group");
    return h5u_close(w, 0, g, H5Gclose, "/results");
}

/* /monomers/{site,cluster,position}, MCHUNK monomers at a time from the
 * model's own arrays: copies of all N (16 B a monomer in 2D, 20 in 3D)
 * were a third of the peak RSS beyond the lattice in a 3D run
 * (runs/dlca/memory.txt). The values are those of one whole write. */
enum { MCHUNK = 1 << 16 }; /* the datasets' chunk: 1.3 MB of buffers in 3D */
static int write_monomers(const h5u_writer *w, hid_t g, const dlca_sim *s, size_t N, const dlca_params *p)
{
    static const char *names[3] = {"site", "cluster", "position"};
    const hid_t ft[3] = {H5T_STD_U32LE, H5T_STD_U32LE, H5T_STD_I32LE};
    const hid_t mt[3] = {H5T_NATIVE_UINT32, H5T_NATIVE_UINT32, H5T_NATIVE_INT32};
    const int dim = p->dim;
    const size_t B = N < MCHUNK ? (N ? N : 1) : MCHUNK;
    uint32_t *site = malloc(B * sizeof *site), *cid = malloc(B * sizeof *cid);
    int32_t *pos = malloc(B * (size_t)dim * sizeof *pos);
    hid_t ds[3] = {H5I_INVALID_HID, H5I_INVALID_HID, H5I_INVALID_HID};
    hid_t fsp[3] = {H5I_INVALID_HID, H5I_INVALID_HID, H5I_INVALID_HID};
    int rc = 0;
    if (!site || !cid || !pos) rc = h5u_fail_msg(w, "out of memory");
    for (int j = 0; j < 3 && rc == 0; j++) {
        const hsize_t cols = j == 2 ? (hsize_t)dim : 1;
        if ((ds[j] = h5u_dataset(w, g, names[j], ft[j], cols > 1 ? 2 : 1, N, cols, N > 65536 ? 65536 : (N ? N : 1),
                                 &fsp[j])) < 0)
            rc = -1;
    }
    dlca_cursor cur = {0};
    for (size_t m0 = 0; rc == 0 && m0 < N;) {
        const size_t m = dlca_export_chunk(s, &cur, N - m0 < B ? N - m0 : B, site, cid);
        if (m == 0) {
            rc = h5u_fail_msg(w, "the clusters hold fewer than N monomers");
            break;
        }
        for (size_t i = 0; i < m; i++) { /* the k-index undone: x_a = (k / stride_a) mod L_a */
            uint64_t k = site[i];
            for (int a = 0; a < dim; a++) {
                pos[i * dim + a] = (int32_t)(k % p->box[a]);
                k /= p->box[a];
            }
        }
        const void *buf[3] = {site, cid, pos};
        for (int j = 0; j < 3 && rc == 0; j++) {
            const hsize_t start[2] = {m0, 0}, count[2] = {m, j == 2 ? (hsize_t)dim : 1};
            const hid_t msp = H5Screate_simple(j == 2 && dim > 1 ? 2 : 1, count, NULL);
            if (msp < 0 || H5Sselect_hyperslab(fsp[j], H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
                H5Dwrite(ds[j], mt[j], msp, fsp[j], H5P_DEFAULT, buf[j]) < 0)
                rc = h5u_fail(w, "write %s", names[j]);
            rc = h5u_close(w, rc, msp, H5Sclose, "a dataspace");
        }
        m0 += m;
    }
    for (int j = 0; j < 3; j++) {
        rc = h5u_close(w, rc, fsp[j], H5Sclose, "a dataspace");
        rc = h5u_close(w, rc, ds[j], H5Dclose, names[j]);
    }
    free(site), free(cid), free(pos);
    return rc;
}

int dlca_write_h5(const dlca_sim *s, const char *path, const char *command_line, double wall_s, char *err,
                  size_t errlen)
{
    h5u_writer w = {path, err, errlen};
    h5u_quiet q;
    if (h5u_silence(&q)) {
        if (err && errlen) snprintf(err, errlen, "cannot write %s: cannot silence HDF5", path);
        return PDLA_EIO;
    }
    dlca_stats st;
    dlca_get_stats(s, &st);
    const dlca_params *p = dlca_get_params(s);
    const size_t N = st.n_monomers, nc = st.n_clusters;
    uint64_t *size = malloc(nc * sizeof *size);
    double *rg = malloc(nc * sizeof *rg);
    hid_t file = H5I_INVALID_HID, g = H5I_INVALID_HID;
    int rc = -1;
    if (!size || !rg) {
        h5u_fail_msg(&w, "cannot write %s: out of memory", path);
        goto done;
    }
    dlca_cluster_table(s, size, rg);
    double df, dferr;
    dlca_fractal_dim(size, rg, nc, 8, &df, &dferr);
    pdla_provenance pv;
    (void)prov_collect(&pv);
    if ((file = h5u_create_file(&w, path)) < 0) goto done;
    if (h5u_attr_str(&w, file, "model", "dlca") < 0 || h5u_attr_int(&w, file, "format_version", 1) < 0 ||
        dlca_write_parameters_h5(&w, file, p) < 0 || write_series(&w, file, s) < 0)
        goto done;
    if (write_results(&w, file, &st, df, dferr, wall_s) < 0) goto done;
    if ((g = h5u_group(&w, file, "clusters")) < 0 ||
        write_1d(&w, g, "size", H5T_STD_U64LE, H5T_NATIVE_UINT64, size, nc) < 0 ||
        write_1d(&w, g, "rg", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, rg, nc) < 0)
        goto done;
    rc = h5u_close(&w, 0, g, H5Gclose, "/clusters");
    g = H5I_INVALID_HID;
    if (rc < 0) goto done;
    rc = -1;
    if ((g = h5u_group(&w, file, "monomers")) < 0 || write_monomers(&w, g, s, N, p) < 0) goto done;
    rc = h5u_close(&w, 0, g, H5Gclose, "/monomers");
    g = H5I_INVALID_HID;
    if (rc < 0) goto done;
    rc = h5u_write_code(&w, file, &pv, command_line);
done:
    if (g >= 0) rc = h5u_close(&w, rc, g, H5Gclose, "a group");
    if (file >= 0) rc = h5u_close(&w, rc, file, H5Fclose, path);
    free(size), free(rg);
    if (h5u_restore(&q) < 0 && rc == 0) rc = h5u_fail_msg(&w, "cannot restore the HDF5 error handler");
    return rc < 0 ? PDLA_EIO : 0;
}

/* One time step of the temporal collection: the monomers under group
 * (e.g. "/snapshots/0" or "/monomers") of base, at time t. The items are
 * those of xdmf.c's points (positions read as reals through a Function:
 * ParaView's XDMF 2 reader takes them so). */
static void xdmf_step(xdmf_out *f, const char *base, const char *group, double t, uint64_t n, int dim)
{
    xdmf_printf(f, "   <Grid Name=\"t = %.6g\" GridType=\"Uniform\">\n    <Time Value=\"%.17g\"/>\n"
                   "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%llu\" NodesPerElement=\"1\"/>\n"
                   "    <Geometry GeometryType=\"%s\">\n"
                   "     <DataItem ItemType=\"Function\" Function=\"$0 / 1\" Dimensions=\"%llu %d\">\n"
                   "      <DataItem Dimensions=\"%llu %d\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">",
                t, t, (unsigned long long)n, dim == 3 ? "XYZ" : "XY", (unsigned long long)n, dim,
                (unsigned long long)n, dim);
    xdmf_escaped(f, base);
    xdmf_printf(f, ":%s/position</DataItem>\n     </DataItem>\n    </Geometry>\n", group);
    const char *arrays[2] = {"cluster", "site"};
    for (int i = 0; i < 2; i++) {
        xdmf_printf(f, "    <Attribute Name=\"%s\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                       "     <DataItem Dimensions=\"%llu\" NumberType=\"UInt\" Precision=\"4\" Format=\"HDF\">",
                    arrays[i], (unsigned long long)n);
        xdmf_escaped(f, base);
        xdmf_printf(f, ":%s/%s</DataItem>\n    </Attribute>\n", group, arrays[i]);
    }
    xdmf_printf(f, "   </Grid>\n");
}

/* What the series sidecar shows (xdmf_series). */
typedef struct series_text {
    const char *base; /* the HDF5 file's name, relative to the sidecar */
    int dim;
    uint64_t n;
    const dlca_snapshot *snaps;
    size_t nsnaps;
    double t_end;
} series_text;

static void series_body(xdmf_out *f, const void *arg)
{
    const series_text *const x = arg;
    xdmf_printf(f, "<?xml version=\"1.0\" ?>\n<!-- pdla: DLCA monomers of ");
    xdmf_escaped(f, x->base);
    xdmf_printf(f, " at its snapshot times and the end, for ParaView's \"XDMF Reader\" (XDMF 2); lattice units -->\n"
                   "<Xdmf Version=\"2.0\">\n <Domain>\n"
                   "  <Grid Name=\"monomers\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    char group[64];
    for (size_t i = 0; i < x->nsnaps; i++) {
        snprintf(group, sizeof group, "/snapshots/%zu", i);
        xdmf_step(f, x->base, group, x->snaps[i].t, x->n, x->dim);
    }
    if (!(x->t_end <= x->snaps[x->nsnaps - 1].t)) xdmf_step(f, x->base, "/monomers", x->t_end, x->n, x->dim);
    xdmf_printf(f, "  </Grid>\n </Domain>\n</Xdmf>\n");
}

/* The sidecar of a run with snapshots: a temporal collection, one step per
 * snapshot and the end's /monomers (unless the last snapshot is the end).
 * Written as every sidecar is (xdmf_write_text: a temporary of this
 * process's own, fsync'ed, renamed, the folder fsync'ed; an older one
 * removed on a failure). */
static int xdmf_series(const char *xmf, const char *h5_path, int dim, uint64_t n, const dlca_snapshot *snaps,
                       size_t nsnaps, double t_end, char *err, size_t errlen)
{
    const char *sl = strrchr(h5_path, '/');
    const series_text x = {sl ? sl + 1 : h5_path, dim, n, snaps, nsnaps, t_end};
    return xdmf_write_text(xmf, series_body, &x, err, errlen) ? PDLA_EIO : 0;
}

int dlca_write_xdmf(const char *h5_path, int dim, uint64_t n, const dlca_snapshot *snaps, size_t nsnaps,
                    double t_end, char *err, size_t errlen)
{
    char xmf[4200];
    if (xdmf_sidecar_path(h5_path, xmf, sizeof xmf)) {
        if (err && errlen) snprintf(err, errlen, "xdmf: the path %.200s is too long", h5_path);
        return PDLA_EINVAL;
    }
    /* ParaView shows 2D and 3D points: in 4D and 5D none is written, and
     * every sidecar an older cluster.h5 had goes (of a 2D run, or an event
     * run's two), as do the other kinds beside the one written. */
    const int shown = dim == 2 || dim == 3;
    int rc = 0;
    if (shown && nsnaps && n) rc = xdmf_series(xmf, h5_path, dim, n, snaps, nsnaps, t_end, err, errlen);
    else if (shown) {
        const xdmf_array arrays[] = {{"cluster", "/monomers/cluster", "UInt", 4},
                                     {"site", "/monomers/site", "UInt", 4}};
        const xdmf_points pts = {h5_path, "/monomers/position", n, dim, 1, 0, NULL, arrays, 2};
        rc = xdmf_write_points(xmf, &pts, err, errlen) ? PDLA_EIO : 0;
    }
    char rerr[512];
    if (xdmf_remove_sidecars(h5_path, shown ? XDMF_SIDECAR_BIT(XDMF_SIDECAR_MAIN) : 0, rerr, sizeof rerr) && !rc)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "%s", rerr);
    return rc;
}

/* One snapshot as group name under g: site, cluster and the sites'
 * coordinates (position [N][d], for the sidecar). */
static int write_snapshot(const h5u_writer *w, hid_t g, const char *name, const dlca_snapshot *sn,
                          const dlca_params *p, uint64_t N)
{
    hid_t sg = h5u_group(w, g, name), sp = H5I_INVALID_HID, d;
    if (sg < 0) return -1;
    int rc = h5u_attr_f64(w, sg, "t", sn->t) < 0 || h5u_attr_u64(w, sg, "attempts", sn->attempts) < 0 ||
                     h5u_attr_u64(w, sg, "n_clusters", sn->n_clusters) < 0
                 ? -1
                 : 0;
    const char *names[2] = {"site", "cluster"};
    const uint32_t *data[2] = {sn->site, sn->cluster};
    const hsize_t chunk = N > 65536 ? 65536 : (N ? N : 1);
    for (int i = 0; i < 2 && rc == 0; i++) {
        if ((d = h5u_dataset(w, sg, names[i], H5T_STD_U32LE, 1, N, 1, chunk, &sp)) < 0) {
            rc = -1;
            break;
        }
        if (N && H5Dwrite(d, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, data[i]) < 0)
            rc = h5u_fail(w, "write snapshot %s/%s", name, names[i]);
        rc = h5u_close(w, rc, sp, H5Sclose, "a dataspace");
        rc = h5u_close(w, rc, d, H5Dclose, names[i]);
    }
    int32_t *pos = rc == 0 ? malloc((N ? N : 1) * (size_t)p->dim * sizeof *pos) : NULL;
    if (rc == 0 && !pos) rc = h5u_fail_msg(w, "cannot write %s: out of memory", w->path);
    for (uint64_t m = 0; pos && m < N; m++) {
        uint64_t k = sn->site[m];
        for (int a = 0; a < p->dim; a++) {
            pos[m * p->dim + a] = (int32_t)(k % p->box[a]);
            k /= p->box[a];
        }
    }
    if (rc == 0 && (d = h5u_dataset(w, sg, "position", H5T_STD_I32LE, 2, N, (hsize_t)p->dim, chunk, &sp)) < 0) rc = -1;
    else if (rc == 0) {
        if (N && H5Dwrite(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, pos) < 0)
            rc = h5u_fail(w, "write snapshot %s/position", name);
        rc = h5u_close(w, rc, sp, H5Sclose, "a dataspace");
        rc = h5u_close(w, rc, d, H5Dclose, "position");
    }
    free(pos);
    return h5u_close(w, rc, sg, H5Gclose, name);
}

int dlca_write_snapshots_h5(const char *path, const dlca_params *p, const dlca_snapshot *snaps, size_t n,
                            uint64_t n_monomers, double every, int stopped, char *err, size_t errlen)
{
    h5u_writer w = {path, err, errlen};
    h5u_quiet q;
    if (h5u_silence(&q)) return pdla_errorf(PDLA_EIO, err, errlen, "cannot write %s: cannot silence HDF5", path);
    int rc = -1;
    const hid_t f = H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT);
    hid_t g = H5I_INVALID_HID;
    if (f < 0) h5u_fail_msg(&w, "cannot open %s to add snapshots", path);
    else if ((g = h5u_group(&w, f, "snapshots")) >= 0) {
        rc = h5u_attr_u64(&w, g, "count", n) < 0 || h5u_attr_f64(&w, g, "every", every) < 0 ? -1 : 0;
        /* only when it happened, so other files keep their bytes */
        if (rc == 0 && stopped && h5u_attr_u64(&w, g, "stopped", 1) < 0) rc = -1;
        for (size_t i = 0; i < n && rc == 0; i++) {
            char name[32];
            snprintf(name, sizeof name, "%zu", i);
            rc = write_snapshot(&w, g, name, &snaps[i], p, n_monomers);
        }
        rc = h5u_close(&w, rc, g, H5Gclose, "/snapshots");
    }
    if (f >= 0) rc = h5u_close(&w, rc, f, H5Fclose, path);
    if (h5u_restore(&q) < 0 && rc == 0) rc = h5u_fail_msg(&w, "cannot restore the HDF5 error handler");
    return rc < 0 ? PDLA_EIO : 0;
}

/* The optional attribute stopped of /snapshots (0 when absent): 0 or 1
 * into *stopped, else -1. */
static int read_stopped(hid_t g, int *stopped)
{
    const htri_t has = H5Aexists(g, "stopped");
    if (has <= 0) return has < 0 ? -1 : 0;
    uint64_t v = 0;
    if (pdla_h5_attr_number(g, "stopped", PDLA_H5_U64, &v) < 0 || v > 1) return -1;
    *stopped = (int)v;
    return 0;
}

/* Snapshot i of group g into sn (arrays of N allocated here). 0 or -1. */
static int read_snapshot(hid_t g, size_t i, uint64_t N, dlca_snapshot *sn)
{
    char name[32];
    snprintf(name, sizeof name, "%zu", i);
    const hid_t sg = H5Gopen2(g, name, H5P_DEFAULT);
    if (sg < 0) return -1;
    int rc = 0;
    const char *an[3] = {"t", "attempts", "n_clusters"};
    void *av[3] = {&sn->t, &sn->attempts, &sn->n_clusters};
    for (int a = 0; a < 3 && rc == 0; a++) /* the checked readers (pdla/h5check.h): one value each */
        if (pdla_h5_attr_number(sg, an[a], a ? PDLA_H5_U64 : PDLA_H5_F64, av[a]) < 0) rc = -1;
    sn->site = malloc((N ? N : 1) * sizeof *sn->site);
    sn->cluster = malloc((N ? N : 1) * sizeof *sn->cluster);
    const char *dn[2] = {"site", "cluster"};
    uint32_t *dv[2] = {sn->site, sn->cluster};
    for (int a = 0; a < 2 && rc == 0; a++) { /* rank 1, N u32 that the file stores, then read */
        pdla_h5_dset d;
        if (!dv[a] || pdla_h5_dset_open(sg, dn[a], &d) < 0) {
            rc = -1;
            break;
        }
        if (d.rank != 1 || !pdla_h5_dset_is(&d, PDLA_H5_U32) || d.elems != N ||
            pdla_h5_dset_stored(&d, sizeof *dv[a]) != PDLA_H5_STORED || pdla_h5_dset_read(&d, PDLA_H5_U32, 0, N, dv[a]) < 0)
            rc = -1;
        if (pdla_h5_dset_close(&d) < 0) rc = -1;
    }
    return H5Gclose(sg) < 0 ? -1 : rc;
}

int dlca_snapshots_fit(size_t n, uint64_t n_monomers)
{
    const long pages = sysconf(_SC_PHYS_PAGES), psz = sysconf(_SC_PAGESIZE);
    return !(pages > 0 && psz > 0 && (double)n * 8.0 * (double)n_monomers > 0.25 * (double)pages * (double)psz);
}

/* Before any snapshot is read: their number against the period and the
 * checkpoint's time (one due at each multiple of every up to t_end; a
 * forged count of 2000 hard links to one snapshot read 8N bytes each,
 * 3.3 GB, before the checks), and their memory against the run's budget.
 * 0, or -1 with why set. */
static int snapshots_sane(uint64_t count, double every, double t_end, uint64_t N, char *why, size_t whylen)
{
    if (!count) return 0;
    if (!(isfinite(every) && every > 0)) {
        snprintf(why, whylen, "its snapshot period %g is not a time above 0", every);
        return -1;
    }
    const double due = floor(t_end / every) + 1;
    if ((double)count > due) {
        snprintf(why, whylen, "its /snapshots count %llu is more than the %.0f due by its time %.17g (every %.17g)",
                 (unsigned long long)count, due, t_end, every);
        return -1;
    }
    if (!dlca_snapshots_fit((size_t)count, N)) {
        snprintf(why, whylen, "its %llu snapshots of %llu monomers need more than a quarter of this machine's memory",
                 (unsigned long long)count, (unsigned long long)N);
        return -1;
    }
    return 0;
}

/* Snapshot i's time as read: finite, in order, not past the checkpoint's
 * (dlca_snapshots_check checks the rest once all are read). */
static int snapshot_time_ok(const dlca_snapshot *sn, size_t i, double t_end, char *why, size_t whylen)
{
    if (isfinite(sn[i].t) && sn[i].t >= (i ? sn[i - 1].t : 0) && sn[i].t <= t_end) return 0;
    snprintf(why, whylen, "its snapshot %zu has t out of range (or out of order)", i);
    return -1;
}

int dlca_read_snapshots_h5(const char *path, uint64_t n_monomers, double t_end, dlca_snapshot **snaps, size_t *n,
                           double *every, int *stopped, char *err, size_t errlen)
{
    char why[256] = "";
    *snaps = NULL;
    *n = 0;
    *every = 0;
    *stopped = 0;
    h5u_quiet q;
    if (h5u_silence(&q)) return pdla_errorf(PDLA_EIO, err, errlen, "cannot read %s: cannot silence HDF5", path);
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    int rc = f < 0 ? -1 : 0;
    /* A link that exists but does not open as a group (or an H5Lexists
     * error) is damage: it was read as "no snapshots", and the resumed run
     * wrote none, old or new (found by an adversarial test, one bit). */
    const htri_t has = f >= 0 ? H5Lexists(f, "snapshots", H5P_DEFAULT) : 0;
    const hid_t g = has > 0 ? H5Gopen2(f, "snapshots", H5P_DEFAULT) : H5I_INVALID_HID;
    if (has < 0 || (has > 0 && g < 0)) rc = -1;
    uint64_t count = 0;
    H5G_info_t gi = {0};
    int miscount = 0;
    if (g >= 0) {
        /* count must be the group's members, as the writer makes them: a
         * forged count must not size the array, and one below them dropped
         * the snapshots past it without a word (count 0 resumed with none) */
        if (pdla_h5_attr_number(g, "count", PDLA_H5_U64, &count) < 0 ||
            pdla_h5_attr_number(g, "every", PDLA_H5_F64, every) < 0 || H5Gget_info(g, &gi) < 0)
            rc = -1;
        else if (count != gi.nlinks)
            rc = -1, miscount = 1;
        else if (read_stopped(g, stopped) < 0 || snapshots_sane(count, *every, t_end, n_monomers, why, sizeof why))
            rc = -1;
        if (rc == 0 && count && !(*snaps = calloc(count, sizeof **snaps))) rc = -1;
        for (size_t i = 0; rc == 0 && i < count; i++) {
            rc = read_snapshot(g, i, n_monomers, &(*snaps)[i]);
            *n = i + 1;
            if (rc == 0) rc = snapshot_time_ok(*snaps, i, t_end, why, sizeof why);
        }
        if (H5Gclose(g) < 0) rc = -1;
    }
    if (f >= 0 && H5Fclose(f) < 0) rc = -1;
    if (h5u_restore(&q) < 0) rc = -1;
    if (rc == 0) return 0;
    for (size_t i = 0; i < *n; i++) free((*snaps)[i].site), free((*snaps)[i].cluster);
    free(*snaps);
    *snaps = NULL;
    *n = 0;
    if (why[0]) return pdla_errorf(PDLA_EINVAL, err, errlen, "cannot resume from %s: %s", path, why);
    if (miscount)
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot read the snapshots of %s: /snapshots count %llu, but it holds "
                           "%llu", path, (unsigned long long)count, (unsigned long long)gi.nlinks);
    return pdla_errorf(PDLA_EIO, err, errlen, "cannot read the snapshots of %s", path);
}

/* Where T is below t's rounding step, (floor(t/T) + 1) T rounds back to t,
 * and the run loop stopped at t for ever taking a snapshot each pass
 * (--snapshot-every 1e-300 filled the memory at once): then the next double. */
double dlca_next_snapshot(double t, double T)
{
    const double next = (floor(t / T) + 1) * T;
    return next > t ? next : nextafter(t, INFINITY);
}

/* Snapshot i's numbers against s and the snapshot before: 0, or
 * PDLA_EINVAL naming the first out of range. */
static int check_numbers(const dlca_snap_end *s, const dlca_snapshot *snaps, size_t i, char *err, size_t errlen)
{
    const dlca_snapshot *sn = &snaps[i], *prev = i ? &snaps[i - 1] : NULL;
    const char *bad = NULL;
    if (!isfinite(sn->t) || sn->t < (prev ? prev->t : 0) || sn->t > s->t) bad = "t";
    else if (sn->attempts > s->attempts || (prev && sn->attempts < prev->attempts)) bad = "attempts";
    else if (sn->n_clusters < s->n_clusters || sn->n_clusters > (prev ? prev->n_clusters : s->N)) bad = "n_clusters";
    for (uint64_t m = 0; !bad && m < s->N; m++) {
        if (sn->site[m] >= s->V) bad = "a site";
        else if (sn->cluster[m] >= sn->n_clusters) bad = "a cluster number";
    }
    if (bad) return pdla_errorf(PDLA_EINVAL, err, errlen, "its snapshot %zu has %s out of range (or out of order)", i, bad);
    return 0;
}

/* Snapshot i's monomers as dlca_export_sites gives them: on distinct sites
 * (a forged copy of one site onto another was resumed and written back),
 * and the cluster numbers 0, 1, ..., n_clusters - 1 with each cluster's
 * monomers together, in that order (all set to 0 under n_clusters 34 was
 * written back as one cluster). 0, PDLA_EINVAL or PDLA_ENOMEM. */
static int check_monomers(const dlca_snap_end *s, const dlca_snapshot *sn, size_t i, uint64_t *seen, char *err,
                          size_t errlen)
{
    for (uint64_t m = 0; m < s->N; m++) {
        const uint32_t c = sn->cluster[m], before = m ? sn->cluster[m - 1] : 0;
        if (c != before && (m == 0 || c != before + 1))
            return pdla_errorf(PDLA_EINVAL, err, errlen, "its snapshot %zu gives monomer %llu cluster %u: the clusters "
                               "are numbered 0, 1, ... in monomer order, each one's monomers together", i,
                               (unsigned long long)m, c);
    }
    if (s->N && sn->cluster[s->N - 1] + (uint64_t)1 != sn->n_clusters)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "its snapshot %zu numbers its clusters 0 to %u, but says "
                           "n_clusters %llu", i, sn->cluster[s->N - 1], (unsigned long long)sn->n_clusters);
    uint64_t a = 0, b = 0; /* the sites are in the box (check_numbers), seen one bit each */
    const int shared = dlca_shared_site(sn->site, s->N, s->V, seen, &a, &b);
    if (shared < 0) return pdla_errorf(shared, err, errlen, "its snapshot %zu has a site outside the box", i);
    if (shared)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "its snapshot %zu puts monomers %llu and %llu on one site", i,
                           (unsigned long long)a, (unsigned long long)b);
    return 0;
}

/* The longest time one attempt can add while n_clusters or more clusters
 * are left: 1 / (N_c m_max) (dlca.c's step), with m_max, the mobility of
 * the smallest (gamma < 0) or largest (gamma > 0) size present, at least
 * min(1, N^gamma). */
static double longest_step(const dlca_snap_end *s, uint64_t n_clusters)
{
    const double m_max = s->mobility < 0 ? pow((double)s->N, s->mobility) : 1;
    return 1.0 / ((double)n_clusters * m_max);
}

/* The snapshots' times against the run loop's rule: the first is due at
 * dlca_next_snapshot(0, every), each taken at the first attempt at or
 * after its due time (so less than one attempt's step after it: slack for
 * the sum's rounding), the next due at dlca_next_snapshot of its time; and
 * s stopped before the one after the last came due. A count of 0 in a
 * checkpoint at t = 80 with every = 50 resumed with the t = 50 snapshot
 * gone and the later ones renumbered. A run that ran out of memory for
 * snapshots (dlca_cmd.c's snapshot_due) takes none after it and says so
 * (`stopped`): then the last may be followed by none. */
static int check_schedule(const dlca_snap_end *s, const dlca_snapshot *snaps, size_t n, double every, int stopped,
                          char *err, size_t errlen)
{
    if (!(every > 0)) return 0; /* a run without snapshots */
    double due = dlca_next_snapshot(0, every);
    for (size_t i = 0; i < n; i++) {
        const double t = snaps[i].t, late = longest_step(s, snaps[i].n_clusters) * (1 + 1e-9) + 4 * DBL_EPSILON * due;
        if (!(t >= due) || t - due > late)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "its snapshot %zu at t = %.17g is not the first attempt at or "
                               "after t = %.17g (--snapshot-every %.17g)", i, t, due, every);
        due = dlca_next_snapshot(t, every);
    }
    if (!stopped && s->t >= due)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "it holds %zu snapshots, but its time %.17g passed t = %.17g, when "
                           "snapshot %zu was due (--snapshot-every %.17g)", n, s->t, due, n, every);
    return 0;
}

/* The values a resumed run writes back into its cluster.h5 as they are (a
 * forged NaN time, 10^9 clusters or a site outside the box went there
 * without a word, and a NaN or negative period was taken as the run's). */
int dlca_snapshots_check_end(const dlca_snap_end *s, const dlca_snapshot *snaps, size_t n, double every,
                             int stopped, char *err, size_t errlen)
{
    if (n ? !(isfinite(every) && every > 0) : !(every == 0 || (isfinite(every) && every > 0)))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "its snapshot period %g is not a time above 0", every);
    /* one bit a site, as the run's own bit lattice */
    uint64_t *seen = n ? calloc((size_t)((s->V + 63) / 64), sizeof *seen) : NULL;
    if (n && !seen) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory checking its snapshots");
    int rc = 0;
    for (size_t i = 0; i < n && !rc; i++) {
        rc = check_numbers(s, snaps, i, err, errlen);
        if (!rc) rc = check_monomers(s, &snaps[i], i, seen, err, errlen);
    }
    free(seen);
    return rc ? rc : check_schedule(s, snaps, n, every, stopped, err, errlen);
}

int dlca_snapshots_check(const dlca_sim *s, const dlca_snapshot *snaps, size_t n, double every, int stopped,
                         char *err, size_t errlen)
{
    const dlca_snap_end e = {s->t, s->attempts, s->nc, s->N, s->V, s->p.mobility};
    return dlca_snapshots_check_end(&e, snaps, n, every, stopped, err, errlen);
}
