/*
 * dlca_tools.c - `pdla render` and `pdla analyze` for a DLCA cluster.h5
 * (root attribute model = "dlca"; render.c and analyze.c hand such a file
 * over here).
 *
 * render: the box seen along its third axis (2D: the plane), one lattice
 * site a square of pixels, coloured by cluster (a golden-ratio hue per
 * cluster number); from 3D on, the monomer with the highest third
 * coordinate in a pixel wins and is shaded darker the deeper it lies
 * (4D and 5D: also a projection onto the first two axes).
 *
 * analyze: the largest cluster's size, radius of gyration and fractal
 * dimension from its mass-radius relation (averaged over monomers as
 * centres, r from 2 to R_g), and D_f from R_g against size
 * over all the file's clusters. The file's positions are wrapped into the
 * box: the largest cluster is unwrapped by walking its face contacts
 * (every cluster is face-connected), so its R_g matches the run's own
 * /clusters/rg (computed from unwrapped offsets); a cluster that spans the
 * box has no unwrapped shape and is refused with one line.
 */
#include <getopt.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "dlca_cmd.h"
#include "h5read.h"
#include "parse.h"
#include "pdla/dlca.h"
#include "pdla/h5check.h"
#include "tools.h"

enum { MAXD = DLCA_MAX_DIM };

typedef struct dfile {
    int dim;
    uint64_t L[MAXD];
    size_t n, nc;
    int32_t *pos;   /* n x dim */
    uint32_t *cid;  /* n */
    uint32_t *site; /* n */
    uint64_t *size; /* nc */
    double *rg;     /* nc */
    char stop[32];
} dfile;

static void dfile_free(dfile *f)
{
    free(f->pos), free(f->cid), free(f->site), free(f->size), free(f->rg);
}

/* The whole dataset `name` of element type t (esize bytes in memory), rank 1
 * or 2, through the checked reader (pdla/h5check.h): what it declares is
 * checked against what the file stores before anything is allocated, so a
 * forged declaration of 2^61 rows is refused, not allocated. *rows, *cols
 * its shape. NULL with one line in err, naming the dataset, when it is
 * missing, of another type or rank, not stored or unreadable. */
static void *read_ds(hid_t f, const char *path, const char *name, pdla_h5_type t, size_t esize, size_t *rows,
                     size_t *cols, char *err, size_t errlen)
{
    pdla_h5_dset d;
    if (pdla_h5_dset_open(f, name, &d) < 0) {
        pdla_errorf(-1, err, errlen, "%s: no dataset %s (not a DLCA cluster.h5, or from before it was written)",
                    path, name);
        return NULL;
    }
    void *buf = NULL;
    const int stored = pdla_h5_dset_stored(&d, esize);
    if (!pdla_h5_dset_is(&d, t) || d.rank < 1 || d.rank > 2)
        pdla_errorf(-1, err, errlen, "%s: %s is not a rank 1 or 2 dataset of the element type pdla writes", path,
                    name);
    else if (stored != PDLA_H5_STORED)
        pdla_errorf(-1, err, errlen, "%s: %s declares %llu elements, %s", path, name, (unsigned long long)d.elems,
                    stored == PDLA_H5_TOO_LARGE ? "more than this machine can address"
                                                : "more than the file stores (damaged or forged)");
    else {
        *rows = (size_t)d.dims[0];
        *cols = d.rank == 2 ? (size_t)d.dims[1] : 1;
        buf = malloc((*rows ? *rows : 1) * *cols * esize);
        if (!buf) pdla_errorf(-1, err, errlen, "%s: out of memory for %s", path, name);
        else if (*rows && pdla_h5_dset_read(&d, t, 0, *rows, buf) < 0) {
            pdla_errorf(-1, err, errlen, "%s: cannot read %s (damaged?)", path, name);
            free(buf);
            buf = NULL;
        }
    }
    if (pdla_h5_dset_close(&d) < 0 && buf) {
        pdla_errorf(-1, err, errlen, "%s: cannot close %s", path, name);
        free(buf);
        buf = NULL;
    }
    return buf;
}

int dlca_file_box(hid_t f, const char *path, int *dim, uint64_t *L, char *err, size_t errlen)
{
    const hid_t g = H5Gopen2(f, "parameters", H5P_DEFAULT);
    pdla_h5_value box;
    int ok = g >= 0 && pdla_h5_attr_number(g, "dim", PDLA_H5_I32, dim) == 0 && *dim >= 2 && *dim <= MAXD &&
             pdla_h5_attr_value(g, "box", &box) == 0 && box.read && box.kind == 'u' && box.n == *dim;
    /* The model's own limits (a length up to DLCA_MAX_AXIS, fewer than 2^31
     * sites): a forged box of 10^5 x 10^5 overflowed analyze's int strides
     * (UBSan) and was then called a cluster spanning the box. */
    uint64_t V = 1;
    for (int a = 0; ok && a < *dim; a++) {
        L[a] = box.u[a];
        ok = L[a] >= 1 && L[a] <= DLCA_MAX_AXIS && (V *= L[a]) < (UINT64_C(1) << 31);
    }
    if (g >= 0 && H5Gclose(g) < 0) ok = 0;
    if (ok) return 0;
    return pdla_errorf(-1, err, errlen, "%s: /parameters dim (2 to %d) or box (dim lengths of 1 to %d, fewer than "
                       "2^31 sites) missing or bad", path, MAXD, DLCA_MAX_AXIS);
}

/* Positions in the box, cluster ids in range, and every /clusters/size the
 * number of monomers with that id (a forged size of 0 sent analyze's
 * unwrap into an empty cluster: a read of an unset index, a write past a
 * zero-length buffer). 1 if so, 0 if not, -1 out of memory. */
static int counts_agree(const dfile *o)
{
    uint64_t *count = calloc(o->nc, sizeof *count);
    if (!count) return -1;
    int ok = 1;
    for (size_t i = 0; i < o->n && ok; i++) {
        if (o->cid[i] >= o->nc) ok = 0;
        else count[o->cid[i]]++;
        for (int a = 0; a < o->dim; a++)
            if (o->pos[i * o->dim + a] < 0 || (uint64_t)o->pos[i * o->dim + a] >= o->L[a]) ok = 0;
    }
    for (size_t c = 0; c < o->nc && ok; c++)
        if (count[c] != o->size[c] || count[c] == 0) ok = 0;
    free(count);
    return ok;
}

/* Each /monomers/site the k-index of its position (x_1 + x_2 L_1 + ...,
 * as the writer makes it), and no two monomers on one site: a monomer
 * copied onto another's site was drawn, analyzed and exported twice.
 * Positions are in the box (counts_agree). 0, or -1 with one line. */
static int sites_agree(const dfile *o, const char *path, char *err, size_t errlen)
{
    for (size_t i = 0; i < o->n; i++) {
        uint64_t k = 0, stride = 1;
        for (int a = 0; a < o->dim; a++) {
            k += (uint64_t)o->pos[i * o->dim + a] * stride;
            stride *= o->L[a];
        }
        if (k != o->site[i])
            return pdla_errorf(-1, err, errlen, "%s: monomer %zu: /monomers/site %u is not the site of its position "
                               "(%llu)", path, i, o->site[i], (unsigned long long)k);
    }
    uint64_t a = 0, b = 0, V = 1;
    for (int d = 0; d < o->dim; d++) V *= o->L[d]; /* < 2^31 (dlca_file_box): 256 MiB of bits at most */
    const int shared = dlca_shared_site(o->site, o->n, V, NULL, &a, &b);
    if (shared < 0) return pdla_errorf(-1, err, errlen, "%s: out of memory checking %zu monomers", path, o->n);
    if (shared)
        return pdla_errorf(-1, err, errlen, "%s: monomers %llu and %llu lie on one site", path, (unsigned long long)a,
                           (unsigned long long)b);
    return 0;
}

/* Every /clusters/rg a radius, finite and >= 0: a NaN or negative one was
 * printed by analyze as the file's R_g and fitted into D_f as nan. */
static int rg_ok(const dfile *o, const char *path, char *err, size_t errlen)
{
    for (size_t c = 0; c < o->nc; c++)
        if (!isfinite(o->rg[c]) || o->rg[c] < 0)
            return pdla_errorf(-1, err, errlen, "%s: /clusters/rg %zu is %g, not a radius (finite, >= 0)", path, c,
                               o->rg[c]);
    return 0;
}

/* The contents' checks, after the shapes: 0, or -1 with one line naming
 * the first fault. */
static int dfile_consistent(const dfile *o, const char *path, char *err, size_t errlen)
{
    const int agree = counts_agree(o);
    if (agree < 0) return pdla_errorf(-1, err, errlen, "%s: out of memory checking %zu clusters", path, o->nc);
    if (!agree)
        return pdla_errorf(-1, err, errlen, "%s: malformed DLCA file (a position or cluster id is out of range, or a "
                           "cluster's size is not its monomer count)", path);
    return sites_agree(o, path, err, errlen) || rg_ok(o, path, err, errlen) ? -1 : 0;
}

/* Read what both tools need; 0, or -1 with one line in err. */
static int dfile_read(const char *path, dfile *o, char *err, size_t errlen)
{
    memset(o, 0, sizeof *o);
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return pdla_errorf(-1, err, errlen, "cannot open %s", path);
    size_t cols = 0, n2 = 0, n3 = 0, nc2 = 0, one;
    int ok = dlca_file_box(f, path, &o->dim, o->L, err, errlen) == 0 &&
             (o->pos = read_ds(f, path, "/monomers/position", PDLA_H5_I32, 4, &o->n, &cols, err, errlen)) &&
             (o->cid = read_ds(f, path, "/monomers/cluster", PDLA_H5_U32, 4, &n2, &one, err, errlen)) &&
             (o->site = read_ds(f, path, "/monomers/site", PDLA_H5_U32, 4, &n3, &one, err, errlen)) &&
             (o->size = read_ds(f, path, "/clusters/size", PDLA_H5_U64, 8, &o->nc, &one, err, errlen)) &&
             (o->rg = read_ds(f, path, "/clusters/rg", PDLA_H5_F64, 8, &nc2, &one, err, errlen));
    const int shaped = ok && cols == (size_t)o->dim && n2 == o->n && n3 == o->n && nc2 == o->nc && o->nc > 0 &&
                       o->n > 0;
    if (ok && !shaped) {
        pdla_errorf(-1, err, errlen, "%s: malformed DLCA file (/monomers and /clusters do not agree in shape)", path);
        ok = 0;
    } else if (ok && dfile_consistent(o, path, err, errlen)) {
        ok = 0;
    }
    if (ok) { /* the stop reason is for the record only: absent or odd, it stays empty */
        const hid_t r = H5Gopen2(f, "results", H5P_DEFAULT);
        if (r < 0 || pdla_h5_attr_str(r, "stop", o->stop, sizeof o->stop) < 0) o->stop[0] = '\0';
        if (r >= 0 && H5Gclose(r) < 0) {
            pdla_errorf(-1, err, errlen, "%s: cannot close /results", path);
            ok = 0;
        }
    }
    if (H5Fclose(f) < 0 && ok) {
        pdla_errorf(-1, err, errlen, "%s: cannot close it", path);
        ok = 0;
    }
    if (!ok) {
        dfile_free(o);
        return -1;
    }
    return 0;
}

/* ---- render -------------------------------------------------------------- */

static void cluster_colour(uint32_t id, double shade, unsigned char *rgb)
{
    const double h = fmod(id * 0.6180339887498949, 1.0) * 6, s = 0.7, v = 0.95 * shade;
    const int i = (int)h;
    const double f = h - i, p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    const double c[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
    for (int k = 0; k < 3; k++) rgb[k] = (unsigned char)lround(255 * c[i % 6][k]);
}

/* The parsed command line of `pdla render`. */
typedef struct render_args {
    const char *out;
    long size;
    int force;
} render_args;

/* Step 1 of render: the options, kept apart from the drawing so each reads
 * on its own. -1 to go on (a->out and argv[optind] set), else the exit code. */
static int render_parse(int argc, char **argv, render_args *a)
{
    enum { O_SIZE = 256, O_FORCE };
    static const struct option lo[] = {{"output", required_argument, NULL, 'o'},
                                       {"size", required_argument, NULL, O_SIZE},
                                       {"force", no_argument, NULL, O_FORCE},
                                       {"help", no_argument, NULL, 'h'},
                                       {NULL, 0, NULL, 0}};
    int c;
    a->out = NULL, a->size = 1024, a->force = 0;
    if (tools_options_begin("render", argc, argv, lo, "ho:")) return TOOL_USAGE;
    while ((c = getopt_long(argc, argv, "ho:", lo, NULL)) != -1) {
        if (c == 'o') a->out = optarg;
        else if (c == O_SIZE) {
            if (cli_parse_long_in(optarg, 16, 8192, &a->size)) {
                fprintf(stderr, "pdla render: --size: want a whole number in [16, 8192]\n");
                return TOOL_USAGE;
            }
        } else if (c == O_FORCE) a->force = 1;
        else if (c == 'h') {
            printf("Usage: pdla render DLCA_FILE -o PNG [--size N] [--force]\n"
                   "A DLCA cluster.h5: the box along its first two axes (deeper axes projected,\n"
                   "nearer monomers on top and brighter), each cluster its own colour.\n");
            return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        } else {
            fprintf(stderr, "pdla render: option '%s' is not known for DLCA files (use -o PNG, --size N, --force)\n",
                    argv[optind - 1]);
            return TOOL_USAGE;
        }
    }
    if (optind != argc - 1 || !a->out) {
        fprintf(stderr, "pdla render: need one DLCA_FILE and -o PNG\n");
        return TOOL_USAGE;
    }
    return -1;
}

/* Step 2 of render: paint every monomer's site into rgb (w x h, y up), the
 * one highest along the third axis winning a pixel (depth), so the drawing
 * can be read apart from the file and PNG handling around it. */
static void render_paint(const dfile *f, double scale, int w, int h, unsigned char *rgb, float *depth)
{
    for (size_t k = 0; k < (size_t)w * h; k++) {
        depth[k] = -1;
        rgb[3 * k] = 16, rgb[3 * k + 1] = 16, rgb[3 * k + 2] = 24;
    }
    for (size_t i = 0; i < f->n; i++) {
        const int32_t *x = f->pos + i * f->dim;
        const float z = f->dim > 2 ? (float)x[2] : 0;
        const double shade = f->dim > 2 ? 0.4 + 0.6 * (f->L[2] > 1 ? z / (double)(f->L[2] - 1) : 1) : 1;
        unsigned char col[3];
        cluster_colour(f->cid[i], shade, col);
        const int x0 = (int)floor(x[0] * scale), y0 = (int)floor(x[1] * scale);
        int x1 = (int)floor((x[0] + 1) * scale), y1 = (int)floor((x[1] + 1) * scale);
        if (x1 <= x0) x1 = x0 + 1;
        if (y1 <= y0) y1 = y0 + 1;
        for (int py = y0; py < y1 && py < h; py++)
            for (int px = x0; px < x1 && px < w; px++) {
                const size_t k = (size_t)(h - 1 - py) * w + px; /* y up */
                if (z < depth[k]) continue;
                depth[k] = z;
                memcpy(rgb + 3 * k, col, 3);
            }
    }
}

int dlca_render_main(int argc, char **argv)
{
    render_args a;
    char err[600];
    const int prc = render_parse(argc, argv, &a);
    if (prc >= 0) return prc;
    const char *out = a.out;
    if (tools_out_check(out, argv[optind], a.force, err, sizeof err)) {
        fprintf(stderr, "pdla render: %s\n", err);
        return TOOL_USAGE;
    }
    dfile f;
    if (dfile_read(argv[optind], &f, err, sizeof err)) {
        fprintf(stderr, "pdla render: %s\n", err);
        return TOOL_USAGE;
    }
    /* Keep the box's aspect: the longer of the first two sides is `size`. */
    const double scale = (double)a.size / (double)(f.L[0] > f.L[1] ? f.L[0] : f.L[1]);
    const int w = (int)fmax(1, lround(f.L[0] * scale)), h = (int)fmax(1, lround(f.L[1] * scale));
    unsigned char *rgb = malloc((size_t)w * h * 3);
    float *depth = malloc((size_t)w * h * sizeof *depth);
    int rc = TOOL_OK;
    if (!rgb || !depth) {
        fprintf(stderr, "pdla render: out of memory for a %dx%d picture\n", w, h);
        rc = TOOL_RUNTIME;
        goto done;
    }
    render_paint(&f, scale, w, h, rgb, depth);
    char werr[600];
    if (tools_png_write(out, w, h, rgb, a.force, werr, sizeof werr)) {
        fprintf(stderr, "pdla render: %s\n", werr);
        rc = TOOL_RUNTIME;
    }
done:
    free(rgb), free(depth);
    dfile_free(&f);
    return rc;
}

/* ---- analyze ------------------------------------------------------------- */

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Unwrapped coordinates u (m x dim) of the m monomers idx[] of one cluster,
 * by a walk over face contacts from the first. -1 if the cluster is not
 * face-connected or meets itself across the box (spans it). */
static int unwrap(const dfile *f, const size_t *idx, size_t m, int64_t *u)
{
    const int d = f->dim;
    uint64_t *key = malloc(m * sizeof *key); /* site << 32 | j */
    size_t *queue = malloc(m * sizeof *queue);
    unsigned char *seen = calloc(m, 1);
    int rc = -1;
    if (!key || !queue || !seen) goto done;
    for (size_t j = 0; j < m; j++) key[j] = (uint64_t)f->site[idx[j]] << 32 | j;
    qsort(key, m, sizeof *key, cmp_u64);
    uint64_t stride[MAXD];
    for (uint64_t a = 0, s = 1; a < (uint64_t)d; a++) stride[a] = s, s *= f->L[a];
    for (int a = 0; a < d; a++) u[a] = f->pos[idx[0] * d + a];
    seen[0] = 1;
    size_t head = 0, tail = 0, reached = 1;
    queue[tail++] = 0;
    while (head < tail) {
        const size_t j = queue[head++];
        const int32_t *x = f->pos + idx[j] * d;
        for (int dir = 0; dir < 2 * d; dir++) {
            const int ax = dir >> 1, sg = (dir & 1) ? -1 : 1;
            uint64_t k = 0;
            for (int a = 0; a < d; a++) {
                int64_t y = x[a] + (a == ax ? sg : 0);
                y = (y + (int64_t)f->L[a]) % (int64_t)f->L[a];
                k += (uint64_t)y * stride[a];
            }
            size_t lo = 0, hi = m; /* the neighbour site among the cluster's */
            while (lo < hi) {
                const size_t mid = (lo + hi) / 2;
                if ((key[mid] >> 32) < k) lo = mid + 1;
                else hi = mid;
            }
            if (lo == m || (key[lo] >> 32) != k) continue;
            const size_t q = (size_t)(key[lo] & 0xffffffffu);
            int64_t v[MAXD];
            for (int a = 0; a < d; a++) v[a] = u[j * d + a] + (a == ax ? sg : 0);
            if (seen[q]) {
                for (int a = 0; a < d; a++)
                    if (u[q * d + a] != v[a]) goto done; /* met itself across the box */
                continue;
            }
            seen[q] = 1;
            reached++;
            memcpy(u + q * d, v, (size_t)d * sizeof *v);
            queue[tail++] = q;
        }
    }
    rc = reached == m ? 0 : -1;
done:
    free(key), free(queue), free(seen);
    return rc;
}

/* D_f from the mass-radius relation averaged over centres (the cluster's
 * correlation integral): M(r) = mean over up to 64 monomers (evenly spaced
 * in file order) of the monomers within r of it, at 10 radii spaced evenly
 * in log r over [r_lo, r_hi]; least squares of log M on log r, *err its
 * standard error. (The centre of mass itself often lies in a hole of a
 * tenuous cluster.) -1 if the range is empty. */
static int mass_radius(const int64_t *u, size_t m, int d, double r_lo, double r_hi, double *df, double *err)
{
    enum { K = 10, C = 64 };
    if (!(r_hi > r_lo * 1.5) || m < 2) return -1;
    double x[K], y[K] = {0}, r2[K], sx = 0, sy = 0;
    for (int i = 0; i < K; i++) {
        const double r = r_lo * pow(r_hi / r_lo, (double)i / (K - 1));
        x[i] = log(r);
        r2[i] = r * r;
    }
    const size_t nc = m < C ? m : C;
    for (size_t c = 0; c < nc; c++) {
        const int64_t *uc = u + (c * m / nc) * d;
        for (size_t j = 0; j < m; j++) {
            double q = 0;
            for (int a = 0; a < d; a++) q += (double)((u[j * d + a] - uc[a]) * (u[j * d + a] - uc[a]));
            for (int i = 0; i < K; i++) y[i] += q <= r2[i];
        }
    }
    for (int i = 0; i < K; i++) {
        y[i] = log(y[i] / (double)nc);
        sx += x[i], sy += y[i];
    }
    sx /= K, sy /= K;
    double sxx = 0, sxy = 0;
    for (int i = 0; i < K; i++) sxx += (x[i] - sx) * (x[i] - sx), sxy += (x[i] - sx) * (y[i] - sy);
    *df = sxy / sxx;
    double rss = 0;
    for (int i = 0; i < K; i++) rss += pow(y[i] - sy - *df * (x[i] - sx), 2);
    *err = sqrt(rss / (K - 2) / sxx);
    return 0;
}

/* Step 1 of analyze: the options, kept apart from the analysis so each reads
 * on its own. -1 to go on (*json and argv[optind] set), else the exit code. */
static int analyze_parse(int argc, char **argv, int *json)
{
    static const struct option lo[] = {{"json", no_argument, NULL, 'j'}, {"help", no_argument, NULL, 'h'},
                                       {NULL, 0, NULL, 0}};
    int c;
    *json = 0;
    if (tools_options_begin("analyze", argc, argv, lo, "h")) return TOOL_USAGE;
    while ((c = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        if (c == 'j') *json = 1;
        else if (c == 'h') {
            printf("Usage: pdla analyze DLCA_FILE [--json]\n"
                   "A DLCA cluster.h5: the largest cluster's size, R_g and D_f (mass-radius:\n"
                   "monomers within r of a monomer, averaged over up to 64 of them, r from 2 to\n"
                   "R_g, lattice units), and\n"
                   "D_f from R_g against size over all the clusters (sizes >= 8).\n");
            return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        } else {
            fprintf(stderr, "pdla analyze: option '%s' is not known for DLCA files (use --json)\n", argv[optind - 1]);
            return TOOL_USAGE;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "pdla analyze: need one DLCA_FILE\n");
        return TOOL_USAGE;
    }
    return -1;
}

/* Step 2 of analyze: R_g of the unwrapped cluster u (m x d) about its centre
 * of mass (r2, m entries, is scratch); the same sums in the same order as
 * before the split, so the printed digits do not move. */
static double analyze_rg(const int64_t *u, size_t m, int d, double *r2)
{
    double cm[MAXD] = {0}, rg2 = 0;
    for (size_t j = 0; j < m; j++)
        for (int a = 0; a < d; a++) cm[a] += (double)u[j * d + a] / (double)m;
    for (size_t j = 0; j < m; j++) {
        r2[j] = 0;
        for (int a = 0; a < d; a++) r2[j] += pow((double)u[j * d + a] - cm[a], 2);
        rg2 += r2[j] / (double)m;
    }
    return sqrt(rg2);
}

int dlca_analyze_main(int argc, char **argv)
{
    int json;
    char err[600];
    const int prc = analyze_parse(argc, argv, &json);
    if (prc >= 0) return prc;
    dfile f;
    if (dfile_read(argv[optind], &f, err, sizeof err)) {
        fprintf(stderr, "pdla analyze: %s\n", err);
        return TOOL_USAGE;
    }
    const int d = f.dim;
    size_t big = 0;
    for (size_t j = 1; j < f.nc; j++)
        if (f.size[j] > f.size[big]) big = j;
    size_t m = 0;
    for (size_t i = 0; i < f.n; i++) m += f.cid[i] == big;
    size_t *idx = malloc((m ? m : 1) * sizeof *idx);
    int64_t *u = malloc((m ? m : 1) * (size_t)d * sizeof *u);
    double *r2 = malloc((m ? m : 1) * sizeof *r2);
    int rc = TOOL_OK;
    if (!idx || !u || !r2) {
        fprintf(stderr, "pdla analyze: out of memory\n");
        rc = TOOL_RUNTIME;
        goto done;
    }
    m = 0;
    for (size_t i = 0; i < f.n; i++)
        if (f.cid[i] == big) idx[m++] = i;
    if (m != f.size[big] || unwrap(&f, idx, m, u)) {
        fprintf(stderr, "pdla analyze: %s: the largest cluster %s\n", argv[optind],
                m != f.size[big] ? "has another size than /clusters/size says"
                                 : "spans the box or is not face-connected: no unwrapped shape");
        rc = TOOL_USAGE;
        goto done;
    }
    const double rg = analyze_rg(u, m, d, r2);
    double dfm = NAN, dfm_err = NAN, dfe, dfe_err;
    (void)mass_radius(u, m, d, 2, rg, &dfm, &dfm_err);
    const int bins = dlca_fractal_dim(f.size, f.rg, f.nc, 8, &dfe, &dfe_err);
    if (json) {
        /* not-a-number fits (a small largest cluster, too few size bins)
         * print null: JSON has no NaN */
        printf("{\"model\": \"dlca\", \"dim\": %d, \"monomers\": %zu, \"clusters\": %zu, \"largest\": {\"size\": %zu, "
               "\"rg\": ", d, f.n, f.nc, m);
        const double v[6] = {rg, f.rg[big], dfm, dfm_err, dfe, dfe_err};
        const char *const sep[6] = {", \"rg_file\": ", ", \"D_f\": ", ", \"D_f_err\": ", "}, \"clusters_D_f\": ",
                                    ", \"clusters_D_f_err\": ", ", \"clusters_D_f_bins\": "};
        for (int i = 0; i < 6; i++) {
            tool_json_num(stdout, v[i], i < 2 ? 10 : 6);
            fputs(sep[i], stdout);
        }
        printf("%d}\n", bins);
    } else {
        printf("%s: model dlca, d = %d, %zu monomers in %zu clusters (stop: %s)\n", argv[optind], d, f.n, f.nc,
               f.stop[0] ? f.stop : "?");
        printf("largest cluster: %zu monomers, R_g %.6g (file: %.6g), D_f %.4f +/- %.4f (mass-radius, r in [2, R_g])\n",
               m, rg, f.rg[big], dfm, dfm_err);
        printf("all clusters: D_f %.4f +/- %.4f (R_g against size, sizes >= 8, %d bins)\n", dfe, dfe_err, bins);
    }
    if (fflush(stdout)) rc = TOOL_RUNTIME;
done:
    free(idx), free(u), free(r2);
    dfile_free(&f);
    return rc;
}

int dlca_tool_file(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (argv[i][0] == '-') {
            if (!strcmp(argv[i], "-o") || !strcmp(argv[i], "--output")) i++; /* its value */
            continue;
        }
        if (dlca_info_is_dlca(argv[i])) return 1;
    }
    return 0;
}
