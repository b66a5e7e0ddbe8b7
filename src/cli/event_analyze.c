/*
 * event_analyze.c - `pdla analyze FILE [--json]` for a cluster.h5 of the
 * event model: the stuck cluster's size, R_g (about its centre of mass)
 * and largest distance from the (nearest) seed, its fractal dimension from the R_g(k)
 * fit (ev_df_fit, the same fit as /results D_f_rg), and a summary of the
 * series (rows, time span, stuck count, kinetic energy first and last,
 * collisions, mean pressure over the second half of the rows).
 * Exit: 0, 1 when the file cannot be read as an event cluster.h5, 2 usage or
 * a file whose values are malformed (not finite, a box side not above 0).
 */
#include <hdf5.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "event_cmd.h"
#include "tools.h"
#include "pdla/event.h"
#include "pdla/h5check.h"
#include "pdla/pdla.h"

/* Dataset PATH of f as doubles (rows x cols; cols 1 for a vector): the
 * array (caller frees), or NULL. An empty dataset gives a 1-element array
 * and *rows = 0. Through the checked reader (pdla/h5check.h): a numeric
 * dataset of rank 1 or 2 whose declared size the file really stores, so a
 * forged size cannot size the allocation. */
static double *read_doubles(hid_t f, const char *path, size_t *rows, size_t *cols)
{
    *rows = 0;
    if (cols) *cols = 1;
    pdla_h5_dset d;
    if (pdla_h5_dset_open(f, path, &d) < 0) return NULL;
    double *buf = NULL;
    if (d.rank >= 1 && d.rank <= 2 && (d.kind == 'f' || d.kind == 'i' || d.kind == 'u') &&
        pdla_h5_dset_stored(&d, sizeof *buf) == PDLA_H5_STORED) {
        const size_t n = (size_t)d.elems;
        buf = malloc((n ? n : 1) * sizeof *buf);
        if (buf && n && pdla_h5_dset_read(&d, PDLA_H5_F64, 0, d.dims[0], buf) < 0) {
            free(buf);
            buf = NULL;
        }
        *rows = (size_t)d.dims[0];
        if (cols) *cols = d.rank == 2 ? (size_t)d.dims[1] : 1;
    }
    if (pdla_h5_dset_close(&d) < 0) { /* a failed read, as any HDF5 error */
        free(buf);
        buf = NULL;
    }
    return buf;
}

/* Attribute NAME of object OBJ as a double (one number), or NaN. */
static double attr_num(hid_t f, const char *obj, const char *name)
{
    double v = NAN;
    if (H5Oexists_by_name(f, obj, H5P_DEFAULT) <= 0) return v;
    const hid_t o = H5Oopen(f, obj, H5P_DEFAULT);
    if (o < 0) return v;
    if (pdla_h5_attr_number(o, name, PDLA_H5_F64, &v) < 0) v = NAN;
    return H5Oclose(o) < 0 ? NAN : v; /* a failed read, as any HDF5 error */
}

typedef struct ev_summary {
    int dim;
    double box;
    size_t stuck, free_n;
    double rg, rmax_seed, df;
    uint64_t k_lo, k_hi;
    size_t rows;
    double t0, t1, stuck0, stuck1, ke0, ke1, coll1, p_mean;
} ev_summary;

/* ---- nearest seed: a k-d tree over the seeds ----------------------------
 * The stuck particles' largest distance from their nearest seed, in
 * O((stuck + seeds) log seeds) instead of stuck x seeds: a forged 74 KB file
 * (3e5 of each, deflated) ran for minutes, and a real --seeds run may have
 * 1e5 seeds. The tree is implicit: each range's median along the axis of
 * its depth sits at the range's middle, smaller or equal values before it,
 * larger or equal after. */
typedef struct kd_tree {
    const double *x; /* seed coordinates, dim per seed */
    int dim;
    size_t *idx;
} kd_tree;

static double kd_at(const kd_tree *t, size_t i, int a) { return t->x[t->idx[i] * (size_t)t->dim + (size_t)a]; }

static void kd_swap(size_t *v, size_t i, size_t j)
{
    const size_t x = v[i];
    v[i] = v[j];
    v[j] = x;
}

/* Put the k-th smallest along axis a of [lo, hi) at k (quickselect with a
 * random pivot and a three-way split, so equal values cannot make it
 * quadratic; NaN compares equal to everything here and ends a range). */
static void kd_select(kd_tree *t, size_t lo, size_t hi, size_t k, int a, uint64_t *rng)
{
    while (hi - lo > 1) {
        *rng = *rng * 6364136223846793005ULL + 1442695040888963407ULL;
        const double pv = kd_at(t, lo + (size_t)((*rng >> 33) % (hi - lo)), a);
        size_t lt = lo, i = lo, gt = hi;
        while (i < gt) {
            const double c = kd_at(t, i, a);
            if (c < pv) kd_swap(t->idx, lt++, i++);
            else if (c > pv) kd_swap(t->idx, i, --gt);
            else i++;
        }
        if (k < lt) hi = lt;
        else if (k >= gt) lo = gt;
        else return;
    }
}

static void kd_build(kd_tree *t, size_t lo, size_t hi, int depth, uint64_t *rng)
{
    while (hi - lo > 1) {
        const size_t mid = lo + (hi - lo) / 2;
        kd_select(t, lo, hi, mid, depth % t->dim, rng);
        kd_build(t, lo, mid, depth + 1, rng);
        lo = mid + 1;
        depth++;
    }
}

/* *best: the smallest squared distance from p to a seed of [lo, hi), if
 * below what it holds. */
static void kd_nearest(const kd_tree *t, size_t lo, size_t hi, int depth, const double *p, double *best)
{
    while (hi > lo) {
        const int a = depth % t->dim;
        const size_t mid = lo + (hi - lo) / 2;
        double d2 = 0;
        for (int q = 0; q < t->dim; q++) {
            const double d = p[q] - kd_at(t, mid, q);
            d2 += d * d;
        }
        if (d2 < *best) *best = d2;
        const double diff = p[a] - kd_at(t, mid, a);
        if (diff < 0) {
            kd_nearest(t, lo, mid, depth + 1, p, best);
            lo = mid + 1;
        } else {
            kd_nearest(t, mid + 1, hi, depth + 1, p, best);
            hi = mid;
        }
        if (!(diff * diff < *best)) return; /* the other side lies beyond the plane */
        depth++;
    }
}

/* The largest distance of a stuck particle (rows x dim) from its nearest of
 * ns seeds; -1 when out of memory. */
static double farthest_from_seeds(const double *pos, size_t rows, const double *sd, size_t ns, int dim)
{
    kd_tree t = {sd, dim, malloc(ns * sizeof(size_t))};
    if (!t.idx) return -1;
    for (size_t b = 0; b < ns; b++) t.idx[b] = b;
    uint64_t rng = 0x9e3779b97f4a7c15ULL;
    kd_build(&t, 0, ns, 0, &rng);
    double far = 0;
    for (size_t a = 0; a < rows; a++) {
        double best = INFINITY;
        kd_nearest(&t, 0, ns, 0, pos + a * (size_t)dim, &best);
        far = fmax(far, sqrt(best));
    }
    free(t.idx);
    return far;
}

/* Attribute NAME of group G ("/cluster") as a double: 1 when read, 0 when
 * the group or the attribute is absent, -1 on an HDF5 failure or a value
 * that is not one number. */
static int group_attr(hid_t f, const char *grp, const char *name, double *v)
{
    const htri_t has_g = H5Lexists(f, grp, H5P_DEFAULT);
    if (has_g <= 0) return has_g < 0 ? -1 : 0;
    const hid_t g = H5Gopen2(f, grp, H5P_DEFAULT);
    if (g < 0) return -1;
    const htri_t has = H5Aexists(g, name);
    int rc = has < 0 ? -1 : !has ? 0 : pdla_h5_attr_number(g, name, PDLA_H5_F64, v) == 0 ? 1 : -1;
    if (H5Gclose(g) < 0) rc = -1; /* a failed read, as any HDF5 error */
    return rc;
}

static int cluster_attr(hid_t f, const char *name, double *v) { return group_attr(f, "/cluster", name, v); }

/* The one seed's attributes on /cluster (seed_x, seed_y[, seed_z],
 * seed_radius) into xr (dim coordinates, then the radius): 1, 0 when there
 * is no seed_radius (no seed), -1 with err when one cannot be read. */
static int one_seed(hid_t f, int dim, double *xr, char *err, size_t errlen)
{
    static const char *const sn[3] = {"seed_x", "seed_y", "seed_z"};
    const int has = cluster_attr(f, "seed_radius", &xr[dim]);
    if (has < 0) return snprintf(err, errlen, "no readable seed_radius on /cluster"), -1;
    for (int q = 0; q < dim && has; q++)
        if (cluster_attr(f, sn[q], &xr[q]) != 1)
            return snprintf(err, errlen, "a seed_radius without a readable %s on /cluster", sn[q]), -1;
    return has;
}

/* The seeds of f, dim coordinates each (malloc'ed; NULL and *ns 0 when
 * there are none): a --seeds run's /cluster/seed_positions and seed_radii,
 * or the one seed's attributes. Every coordinate and radius must be finite,
 * radii not negative: a NaN seed gave "farthest from a seed inf", exit 0.
 * 0, or -1 (unreadable: exit 1) or -2 (malformed: exit 2) with err. */
static int read_seeds(hid_t f, int dim, double **out, size_t *ns, char *err, size_t errlen)
{
    *out = NULL;
    *ns = 0;
    const htri_t has_c = H5Lexists(f, "/cluster", H5P_DEFAULT);
    const htri_t has_sd = has_c > 0 ? H5Lexists(f, "/cluster/seed_positions", H5P_DEFAULT) : has_c;
    if (has_sd < 0) return snprintf(err, errlen, "cannot read /cluster"), -1;
    size_t n = 0, nc = 0, nr = 0, rc1 = 0;
    double *sd, *rad;
    if (has_sd) {
        sd = read_doubles(f, "/cluster/seed_positions", &n, &nc);
        rad = read_doubles(f, "/cluster/seed_radii", &nr, &rc1);
        if (!sd || !rad || (int)nc != dim || nr != n || rc1 != 1)
            return free(sd), free(rad),
                   snprintf(err, errlen, "no readable /cluster/seed_positions (%d columns) and seed_radii", dim), -1;
    } else {
        double xr[4];
        const int has = one_seed(f, dim, xr, err, errlen);
        if (has <= 0) return has;
        sd = malloc(4 * sizeof *sd);
        rad = malloc(sizeof *rad);
        if (!sd || !rad) return free(sd), free(rad), snprintf(err, errlen, "out of memory"), -1;
        memcpy(sd, xr, (size_t)dim * sizeof *sd);
        rad[0] = xr[dim];
        n = 1;
    }
    int bad = 0;
    for (size_t k = 0; k < n * (size_t)dim; k++) bad |= !isfinite(sd[k]);
    for (size_t k = 0; k < n; k++) bad |= !(rad[k] >= 0 && rad[k] < INFINITY);
    free(rad);
    if (bad)
        return free(sd), snprintf(err, errlen, "a seed position or radius is not finite (or a radius negative)"), -2;
    *out = sd;
    *ns = n;
    return 0;
}

/* The cluster part: size, R_g, extent from the seed, the D_f fit. 0, or
 * -1 (unreadable) or -2 (malformed) with err. */
static int cluster_summary(hid_t f, ev_summary *m, char *err, size_t errlen)
{
    size_t rows, cols;
    double *pos = read_doubles(f, "/cluster/positions", &rows, &cols);
    if (!pos || (int)cols != m->dim)
        return free(pos), snprintf(err, errlen, "no readable /cluster/positions"), -1;
    m->stuck = rows;
    for (size_t k = 0; k < rows * cols; k++) /* NaN gave R_g 0 and a distance inf, exit 0 */
        if (!isfinite(pos[k]))
            return free(pos), snprintf(err, errlen, "a /cluster/positions value is not finite"), -2;
    size_t ns;
    double *seeds;
    const int src = read_seeds(f, m->dim, &seeds, &ns, err, errlen);
    if (src) return free(pos), src;
    double *rg = malloc((rows ? rows : 1) * sizeof *rg);
    if (!rg) return free(pos), free(seeds), snprintf(err, errlen, "out of memory"), -1;
    m->df = ev_df_fit(pos, rows, m->dim, m->box / 8, rg, &m->k_lo, &m->k_hi);
    m->rg = rows ? rg[rows - 1] : 0;
    /* the largest distance of a stuck particle from its nearest seed */
    m->rmax_seed = ns ? farthest_from_seeds(pos, rows, seeds, ns, m->dim) : 0;
    free(seeds);
    if (m->rmax_seed < 0) return free(rg), free(pos), snprintf(err, errlen, "out of memory"), -1;
    free(rg);
    free(pos);
    return 0;
}

/* The series part: first and last rows, the pressure of the second half. */
static int series_summary(hid_t f, ev_summary *m, char *err, size_t errlen)
{
    size_t n[5];
    double *t = read_doubles(f, "/series/time", &n[0], NULL);
    double *st = read_doubles(f, "/series/stuck", &n[1], NULL);
    double *ke = read_doubles(f, "/series/kinetic_energy", &n[2], NULL);
    double *co = read_doubles(f, "/series/collisions", &n[3], NULL);
    double *pr = read_doubles(f, "/series/pressure", &n[4], NULL);
    int rc = 0;
    if (!t || !st || !ke || !co || !pr || n[1] != n[0] || n[2] != n[0] || n[3] != n[0] || n[4] != n[0]) {
        snprintf(err, errlen, "no readable /series (time, stuck, kinetic_energy, collisions, pressure)");
        rc = -1;
    } else if ((m->rows = n[0]) > 0) {
        const size_t L = n[0] - 1;
        m->t0 = t[0], m->t1 = t[L], m->stuck0 = st[0], m->stuck1 = st[L];
        m->ke0 = ke[0], m->ke1 = ke[L], m->coll1 = co[L];
        double sum = 0;
        size_t k = 0;
        for (size_t a = n[0] / 2; a < n[0]; a++)
            if (isfinite(pr[a])) sum += pr[a], k++;
        m->p_mean = k ? sum / (double)k : NAN;
    }
    free(t), free(st), free(ke), free(co), free(pr);
    return rc;
}

/* "  "KEY": V" and `end`, V with `digits` digits, null when not finite
 * (JSON has no NaN or inf: a forged series value printed "inf", which no
 * JSON reader takes). */
static void json_num(const char *key, double v, int digits, const char *end)
{
    printf("  \"%s\": ", key);
    tool_json_num(stdout, v, digits);
    fputs(end, stdout);
}

static void print_summary(const ev_summary *m, int json)
{
    if (json) {
        printf("{\n  \"model\": \"event\",\n  \"dim\": %d,\n  \"stuck\": %zu,\n  \"free\": %zu,\n", m->dim,
               m->stuck, m->free_n);
        json_num("rg", m->rg, 10, ",\n");
        json_num("max_distance_from_seed", m->rmax_seed, 10, ",\n");
        json_num("D_f", m->df, 10, ",\n");
        printf("  \"D_f_k_lo\": %llu,\n  \"D_f_k_hi\": %llu,\n  \"series_rows\": %zu,\n",
               (unsigned long long)m->k_lo, (unsigned long long)m->k_hi, m->rows);
        json_num("time", m->t1, 10, ",\n");
        json_num("kinetic_energy_first", m->ke0, 10, ",\n");
        json_num("kinetic_energy_last", m->ke1, 10, ",\n");
        json_num("collisions", m->coll1, 17, ",\n");
        json_num("pressure_mean_second_half", m->p_mean, 10, "\n}\n");
        return;
    }
    printf("model event, %dd, box %.6g\n", m->dim, m->box);
    printf("cluster: %zu stuck, %zu free; R_g %.6g; farthest from a seed %.6g\n", m->stuck,
           m->free_n, m->rg, m->rmax_seed);
    if (isfinite(m->df))
        printf("D_f %.4f (R_g(k) fit over k = %llu..%llu)\n", m->df, (unsigned long long)m->k_lo,
               (unsigned long long)m->k_hi);
    else
        printf("D_f -- (too few stuck particles inside box/8 for the R_g(k) fit)\n");
    if (m->rows)
        printf("series: %zu rows, t %.6g..%.6g, stuck %.0f..%.0f, kinetic energy %.6g..%.6g, "
               "collisions %.0f, mean pressure (second half) %.6g\n",
               m->rows, m->t0, m->t1, m->stuck0, m->stuck1, m->ke0, m->ke1, m->coll1, m->p_mean);
    else
        printf("series: no rows\n");
}

int event_analyze_main(int argc, char **argv)
{
    const char *path = NULL;
    int json = 0;
    for (int k = 1; k < argc; k++) {
        if (!strcmp(argv[k], "--json")) json = 1;
        else if (argv[k][0] == '-' || path) {
            fprintf(stderr, "pdla analyze: an event cluster.h5 takes only FILE [--json], not '%s'\n",
                    argv[k]);
            return 2;
        } else path = argv[k];
    }
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla analyze: cannot open %s as HDF5\n", path);
        return 2; /* as info: bad input */
    }
    ev_summary m;
    memset(&m, 0, sizeof m);
    const double dim = attr_num(f, "/", "dim");
    m.dim = dim == 2 || dim == 3 ? (int)dim : 0; /* NaN or 1e300 cast to int is undefined; 0 is refused below */
    const int has_box = group_attr(f, "/results", "box_side", &m.box);
    size_t fr, fc;
    free(read_doubles(f, "/free/positions", &fr, &fc));
    m.free_n = fr;
    char err[256];
    int rc = (m.dim == 2 || m.dim == 3) && has_box == 1 ? 0 : -1;
    if (rc) snprintf(err, sizeof err, "no dim (2 or 3) or /results box_side");
    /* a box side of 0 or less fed the D_f fit's range (box/8), exit 0 */
    if (!rc && !(m.box > 0 && m.box < INFINITY)) {
        snprintf(err, sizeof err, "/results box_side %g is not a length above 0", m.box);
        rc = -2;
    }
    if (!rc) rc = cluster_summary(f, &m, err, sizeof err);
    if (!rc) rc = series_summary(f, &m, err, sizeof err);
    if (H5Fclose(f) < 0 && !rc) {
        snprintf(err, sizeof err, "cannot close it");
        rc = -1;
    }
    if (rc) {
        fprintf(stderr, "pdla analyze: %s: %s\n", path, err);
        return rc == -2 ? 2 : 1; /* malformed values: bad input, as info and render */
    }
    print_summary(&m, json);
    return fflush(stdout) ? 1 : 0;
}
