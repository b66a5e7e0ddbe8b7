/*
 * ens_analyze.c - `pdla analyze DIR/ensemble.h5`: the ensemble statistics
 * that `pdla ensemble` stored in /statistics (include/pdla/ensemble.h,
 * pdla_ens_stats), as text or JSON. Reads only; nothing is recomputed, so
 * what is printed is what the file holds.
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <hdf5.h>

#include "h5read.h"
#include "tools.h"

/* 1 if path is a regular HDF5 file whose root attribute format is
 * "pdla-ensemble" (read through h5check.h). */
int ens_analyze_is_ensemble(const char *path)
{
    struct stat st;
    if (stat(path, &st) || !S_ISREG(st.st_mode)) return 0;
    if (pdla_hdf5_quiet()) return 0; /* cannot tell; the readers tried next say why */
    int yes = 0;
    const hid_t f = H5Fis_hdf5(path) > 0 ? H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT) : H5I_INVALID_HID;
    if (f >= 0) {
        char fmt[64];
        yes = pdla_h5_attr_str(f, "format", fmt, sizeof fmt) == 0 && strcmp(fmt, "pdla-ensemble") == 0;
        if (H5Fclose(f) < 0) yes = 0; /* a failed close is a failed read */
    }
    return yes;
}

/* A 1-D real dataset through the checked read layer (h5check.h): it must
 * store the rows it declares (a forged file may declare 2^40 rows in a
 * few kB). malloc'ed, *n rows; NULL with err naming it on failure. */
static double *read_f64(hid_t f, const char *path, const char *name, size_t *n, char *err, size_t errlen)
{
    *n = 0;
    pdla_h5_dset d;
    if (H5Lexists(f, name, H5P_DEFAULT) <= 0 || pdla_h5_dset_open(f, name, &d) < 0) {
        snprintf(err, errlen, "%s: no dataset %s", path, name);
        return NULL;
    }
    double *v = NULL;
    if (d.rank != 1 || d.kind != 'f') {
        snprintf(err, errlen, "%s: %s is not a 1-D real dataset", path, name);
    } else if (pdla_h5_dset_stored(&d, sizeof(double)) != PDLA_H5_STORED) {
        snprintf(err, errlen, "%s: %s declares %llu rows but the file stores only %llu bytes of it", path, name,
                 (unsigned long long)d.dims[0], (unsigned long long)d.stored);
    } else if (!(v = malloc((d.dims[0] ? d.dims[0] : 1) * sizeof *v))) {
        snprintf(err, errlen, "%s: out of memory for %s", path, name);
    } else if (d.dims[0] && pdla_h5_dset_read(&d, PDLA_H5_F64, 0, d.dims[0], v) < 0) {
        snprintf(err, errlen, "%s: cannot read %s (damaged?)", path, name);
        free(v);
        v = NULL;
    } else {
        *n = (size_t)d.dims[0];
    }
    /* A failed close is a failed read; after an earlier error, that one is kept. */
    if (pdla_h5_dset_close(&d) < 0 && v) {
        snprintf(err, errlen, "%s: cannot close %s (damaged?)", path, name);
        free(v);
        v = NULL;
        *n = 0;
    }
    return v;
}

static void jnum(FILE *o, const char *name, double v, int comma)
{
    fprintf(o, "  \"%s\": ", name);
    tool_json_num(o, v, 17); /* null for NaN and inf: JSON has neither */
    fprintf(o, "%s\n", comma ? "," : "");
}

/* What `pdla analyze` prints of an ensemble file. */
typedef struct ens_view {
    h5r_attrs st, en, par;   /* /statistics, /ensemble, /parameters */
    size_t ns, ndf;
    double *sn, *sd, *sl, *sh, *dfc; /* local slopes: N, D_f, band; per-cluster D_f */
} ens_view;

static void view_free(ens_view *v)
{
    free(v->sn), free(v->sd), free(v->sl), free(v->sh), free(v->dfc);
    h5r_attrs_free(&v->st), h5r_attrs_free(&v->en), h5r_attrs_free(&v->par);
}

/* Reads v from the open file f; 0, or -1 with err. */
static int view_read(ens_view *v, hid_t f, const char *path, char *err, size_t errlen)
{
    h5r_file hf;
    memset(&hf, 0, sizeof hf);
    hf.file = f;
    hf.path = path;
    if (h5r_read_attrs(&hf, "/statistics", &v->st, err, errlen) || h5r_read_attrs(&hf, "/ensemble", &v->en, err, errlen) ||
        h5r_read_attrs(&hf, "/parameters", &v->par, err, errlen) || !h5r_attr_find(&v->st, "D_f") ||
        !h5r_attr_find(&v->en, "clusters")) {
        snprintf(err, errlen, "%s: not a complete pdla ensemble file (no /statistics or /ensemble)", path);
        return -1;
    }
    size_t nd = 0, nl = 0, nh = 0;
    if (!(v->sn = read_f64(f, path, "/statistics/slope_N", &v->ns, err, errlen)) ||
        !(v->sd = read_f64(f, path, "/statistics/slope_D_f", &nd, err, errlen)) ||
        !(v->sl = read_f64(f, path, "/statistics/slope_D_f_lo", &nl, err, errlen)) ||
        !(v->sh = read_f64(f, path, "/statistics/slope_D_f_hi", &nh, err, errlen)) ||
        !(v->dfc = read_f64(f, path, "/clusters/D_f", &v->ndf, err, errlen)))
        return -1;
    if (nd != v->ns || nl != v->ns || nh != v->ns) {
        snprintf(err, errlen, "%s: the local slope datasets differ in length", path);
        return -1;
    }
    return 0;
}

/* An attribute of /statistics (NaN when missing). */
#define A(name) h5r_attr_num(&v->st, name)

static void print_json(const ens_view *v, const char *path)
{
    fputs("{\n  \"file\": ", stdout);
    tool_json_str(stdout, path); /* a path may hold quotes or bytes that are not UTF-8 */
    fputs(",\n", stdout);
    jnum(stdout, "clusters", h5r_attr_num(&v->en, "clusters"), 1);
    jnum(stdout, "particles", h5r_attr_num(&v->en, "particles"), 1);
    jnum(stdout, "dim", h5r_attr_num(&v->par, "dim"), 1);
    jnum(stdout, "first_seed", h5r_attr_num(&v->en, "first_seed"), 1), jnum(stdout, "fit_n_lo", A("fit_n_lo"), 1);
    jnum(stdout, "fit_n_hi", A("fit_n_hi"), 1), jnum(stdout, "D_f", A("D_f"), 1);
    jnum(stdout, "D_f_lo", A("D_f_lo"), 1), jnum(stdout, "D_f_hi", A("D_f_hi"), 1);
    jnum(stdout, "D_f_boot_sd", A("D_f_boot_sd"), 1), jnum(stdout, "prefactor_diam", A("prefactor_diam"), 1);
    jnum(stdout, "bootstrap_samples", A("bootstrap_samples"), 1);
    jnum(stdout, "bootstrap_seed", A("bootstrap_seed"), 1);
    jnum(stdout, "D_f_cluster_mean", A("D_f_cluster_mean"), 1);
    jnum(stdout, "D_f_cluster_sd", A("D_f_cluster_sd"), 1);
    jnum(stdout, "corr_D", A("corr_D"), 1), jnum(stdout, "corr_D_lo", A("corr_D_lo"), 1);
    jnum(stdout, "corr_D_hi", A("corr_D_hi"), 1), jnum(stdout, "corr_A_diam", A("corr_A_diam"), 1);
    jnum(stdout, "corr_A_lo", A("corr_A_lo"), 1), jnum(stdout, "corr_A_hi", A("corr_A_hi"), 1);
    jnum(stdout, "corr_B", A("corr_B"), 1), jnum(stdout, "corr_nu", A("corr_nu"), 1);
    jnum(stdout, "corr_n_lo", A("corr_n_lo"), 1);
    jnum(stdout, "corr_correction_max", A("corr_correction_max"), 1);
    /* A window's slope or band can be NaN (too few clusters, a window
     * without two points): null, as jnum, since JSON has no NaN. */
    printf("  \"local_slope\": [");
    for (size_t i = 0; i < v->ns; i++) {
        const double row[4] = {v->sn[i], v->sd[i], v->sl[i], v->sh[i]};
        fputs(i ? ", [" : "[", stdout);
        for (int k = 0; k < 4; k++) {
            if (k) fputs(", ", stdout);
            tool_json_num(stdout, row[k], 6);
        }
        fputc(']', stdout);
    }
    printf("]\n}\n");
}

/* "[lo, hi]" to 4 decimals, or "[n/a]" when the file has no interval (NaN:
 * an ensemble of one cluster, whose resamples are all that cluster). */
static const char *band(char *buf, size_t len, double lo, double hi)
{
    if (!isfinite(lo) || !isfinite(hi)) return "[n/a]";
    snprintf(buf, len, "[%.4f, %.4f]", lo, hi);
    return buf;
}

/* v to 4 decimals, or "n/a" (NaN: the sd of one cluster). */
static const char *num4(char *buf, size_t len, double v)
{
    if (!isfinite(v)) return "n/a";
    snprintf(buf, len, "%.4f", v);
    return buf;
}

static void print_text(const ens_view *v, const char *path)
{
    const double M = h5r_attr_num(&v->en, "clusters"), N = h5r_attr_num(&v->en, "particles");
    const double S = h5r_attr_num(&v->en, "first_seed"), dim = h5r_attr_num(&v->par, "dim");
    char b1[64], b2[64];
    printf("ensemble         %s: %.0f clusters of %.0f particles, %.0fD, seeds %.0f..%.0f\n", path, M, N, dim, S,
           S + M - 1);
    printf("fit range        N in [%.0f, %.0f]\n", A("fit_n_lo"), A("fit_n_hi"));
    char how[160];
    if (M == 1) snprintf(how, sizeof how, "one cluster: a bootstrap over clusters needs more");
    else
        snprintf(how, sizeof how, "bootstrap over clusters: %.0f resamples, seed %.0f; sd %s", A("bootstrap_samples"),
                 A("bootstrap_seed"), num4(b2, sizeof b2, A("D_f_boot_sd")));
    printf("D_f              %.4f, 95%% interval %s (%s)\n", A("D_f"), band(b1, sizeof b1, A("D_f_lo"), A("D_f_hi")),
           how);
    printf("prefactor        R_g = %.4f N^(1/D_f) diameters\n", A("prefactor_diam"));
    printf("per-cluster D_f  mean %.4f, sd %s over %zu clusters\n", A("D_f_cluster_mean"),
           num4(b1, sizeof b1, A("D_f_cluster_sd")), v->ndf);
    if (isfinite(A("corr_D_lo"))) snprintf(how, sizeof how, "interval: %.0f resamples", A("corr_samples"));
    else snprintf(how, sizeof how, "no interval%s", M == 1 ? ": one cluster" : "");
    if (A("corr_ok") == 1) {
        /* The fit keeps |B N^-nu| <= 0.9 over its range (ens_stats.c): B at
         * that cap, like nu at an end of its range, says the data do not
         * determine the correction. */
        const int nu_end = A("corr_nu") <= 0.2 * (1 + 1e-6) || A("corr_nu") >= 2.0 * (1 - 1e-6);
        /* corr_correction_max: files of session 28 on; before, there was no
         * cap (the note's test at N = 30 then errs on the safe side). */
        const double cmax = h5r_attr_find(&v->st, "corr_correction_max")
                                ? A("corr_correction_max")
                                : fabs(A("corr_B")) * pow(A("corr_n_lo"), -A("corr_nu"));
        const int b_cap = cmax >= 0.9 * (1 - 1e-6);
        printf("correction fit   R_g = A N^(1/D) (1 + B N^-nu), N in [%.0f, %.0f]: D = %.4f %s, "
               "A = %.4f %s diameters, B = %.4f, nu = %.3f%s%s (%s)\n",
               A("corr_n_lo"), A("fit_n_hi"), A("corr_D"), band(b1, sizeof b1, A("corr_D_lo"), A("corr_D_hi")),
               A("corr_A_diam"), band(b2, sizeof b2, A("corr_A_lo"), A("corr_A_hi")), A("corr_B"), A("corr_nu"),
               nu_end ? " (at the end of its range [0.2, 2]: poorly determined)" : "",
               b_cap ? " (B at its cap, |B N^-nu| = 0.9 at the smallest N: poorly determined)" : "", how);
    } else
        printf("correction fit   n/a (too few points)\n");
    printf("local slope      D_f over windows of %.2g decades of N, 95%% band:\n", A("slope_window_decades"));
    for (size_t i = 0; i < v->ns; i++)
        printf("  N %-10.0f  %.4f  %s\n", v->sn[i], v->sd[i], band(b1, sizeof b1, v->sl[i], v->sh[i]));
#undef A
}

int ens_analyze_main(const char *path, int json)
{
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla analyze: cannot open %s\n", path);
        return TOOL_USAGE;
    }
    ens_view v;
    memset(&v, 0, sizeof v);
    char err[1024];
    int code = TOOL_OK;
    int bad = view_read(&v, f, path, err, sizeof err);
    /* A failed close of the file read to the end is a failed read; after a
     * failed read, that error is the one to report. */
    if (H5Fclose(f) < 0 && !bad) {
        snprintf(err, sizeof err, "%s: cannot close it (damaged?)", path);
        bad = 1;
    }
    if (bad) {
        fprintf(stderr, "pdla analyze: %s\n", err);
        code = TOOL_USAGE;
    } else {
        if (json) print_json(&v, path);
        else print_text(&v, path);
        if (fflush(stdout) || ferror(stdout)) code = TOOL_RUNTIME;
    }
    view_free(&v);
    return code;
}
