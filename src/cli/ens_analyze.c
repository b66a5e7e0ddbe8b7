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

/* 1 if path is an HDF5 file whose root attribute format is "pdla-ensemble". */
int ens_analyze_is_ensemble(const char *path)
{
    struct stat st;
    if (stat(path, &st) || !S_ISREG(st.st_mode)) return 0;
    H5E_auto2_t fn;
    void *data;
    H5Eget_auto2(H5E_DEFAULT, &fn, &data);
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    int yes = 0;
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f >= 0) {
        h5r_file hf;
        memset(&hf, 0, sizeof hf);
        hf.file = f;
        hf.path = path;
        h5r_attrs a;
        char err[256];
        if (h5r_read_attrs(&hf, "/", &a, err, sizeof err) == 0) {
            const h5r_attr *x = h5r_attr_find(&a, "format");
            yes = x && x->kind == 's' && x->s && strcmp(x->s, "pdla-ensemble") == 0;
            h5r_attrs_free(&a);
        }
        H5Fclose(f);
    }
    H5Eset_auto2(H5E_DEFAULT, fn, data);
    return yes;
}

/* A 1-D float64 dataset: malloc'ed, *n rows; NULL on failure. */
static double *read_f64(hid_t f, const char *name, size_t *n)
{
    *n = 0;
    const hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
    if (d < 0) return NULL;
    const hid_t s = H5Dget_space(d);
    hsize_t dims[1] = {0};
    double *v = NULL;
    if (s >= 0 && H5Sget_simple_extent_ndims(s) == 1 && H5Sget_simple_extent_dims(s, dims, NULL) == 1) {
        v = malloc((dims[0] ? dims[0] : 1) * sizeof *v);
        if (v && dims[0] && H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) < 0) {
            free(v);
            v = NULL;
        }
        if (v) *n = (size_t)dims[0];
    }
    if (s >= 0) H5Sclose(s);
    H5Dclose(d);
    return v;
}

static void jnum(FILE *o, const char *name, double v, int comma)
{
    if (isfinite(v)) fprintf(o, "  \"%s\": %.17g%s\n", name, v, comma ? "," : "");
    else fprintf(o, "  \"%s\": null%s\n", name, comma ? "," : "");
}

int ens_analyze_main(const char *path, int json)
{
    H5E_auto2_t efn;
    void *edata;
    H5Eget_auto2(H5E_DEFAULT, &efn, &edata);
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla analyze: cannot open %s\n", path);
        return TOOL_USAGE;
    }
    h5r_file hf;
    memset(&hf, 0, sizeof hf);
    hf.file = f;
    hf.path = path;
    h5r_attrs st, en, par;
    char err[1024];
    int code = TOOL_OK;
    size_t ns = 0, nd = 0, nl = 0, nh = 0, ndf = 0;
    double *sn = NULL, *sd = NULL, *sl = NULL, *sh = NULL, *dfc = NULL;
    memset(&st, 0, sizeof st), memset(&en, 0, sizeof en), memset(&par, 0, sizeof par);
    if (h5r_read_attrs(&hf, "/statistics", &st, err, sizeof err) || h5r_read_attrs(&hf, "/ensemble", &en, err, sizeof err) ||
        h5r_read_attrs(&hf, "/parameters", &par, err, sizeof err) || !h5r_attr_find(&st, "D_f") ||
        !h5r_attr_find(&en, "clusters")) {
        fprintf(stderr, "pdla analyze: %s: not a complete pdla ensemble file (no /statistics or /ensemble)\n", path);
        code = TOOL_USAGE;
        goto out;
    }
    sn = read_f64(f, "/statistics/slope_N", &ns);
    sd = read_f64(f, "/statistics/slope_D_f", &nd);
    sl = read_f64(f, "/statistics/slope_D_f_lo", &nl);
    sh = read_f64(f, "/statistics/slope_D_f_hi", &nh);
    dfc = read_f64(f, "/clusters/D_f", &ndf);
    if (!sn || !sd || !sl || !sh || !dfc || nd != ns || nl != ns || nh != ns) {
        fprintf(stderr, "pdla analyze: %s: cannot read the local slopes or per-cluster D_f\n", path);
        code = TOOL_USAGE;
        goto out;
    }
    const double M = h5r_attr_num(&en, "clusters"), N = h5r_attr_num(&en, "particles");
    const double S = h5r_attr_num(&en, "first_seed"), dim = h5r_attr_num(&par, "dim");
#define A(name) h5r_attr_num(&st, name)
    if (json) {
        printf("{\n  \"file\": \"%s\",\n", path); /* paths with quotes are rare; kept simple */
        jnum(stdout, "clusters", M, 1), jnum(stdout, "particles", N, 1), jnum(stdout, "dim", dim, 1);
        jnum(stdout, "first_seed", S, 1), jnum(stdout, "fit_n_lo", A("fit_n_lo"), 1);
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
        printf("  \"local_slope\": [");
        for (size_t i = 0; i < ns; i++)
            printf("%s[%.6g, %.6g, %.6g, %.6g]", i ? ", " : "", sn[i], sd[i], sl[i], sh[i]);
        printf("]\n}\n");
    } else {
        printf("ensemble         %s: %.0f clusters of %.0f particles, %.0fD, seeds %.0f..%.0f\n", path, M, N, dim, S,
               S + M - 1);
        printf("fit range        N in [%.0f, %.0f]\n", A("fit_n_lo"), A("fit_n_hi"));
        printf("D_f              %.4f, 95%% interval [%.4f, %.4f] (bootstrap over clusters: %.0f resamples, "
               "seed %.0f; sd %.4f)\n",
               A("D_f"), A("D_f_lo"), A("D_f_hi"), A("bootstrap_samples"), A("bootstrap_seed"), A("D_f_boot_sd"));
        printf("prefactor        R_g = %.4f N^(1/D_f) diameters\n", A("prefactor_diam"));
        printf("per-cluster D_f  mean %.4f, sd %.4f over %zu clusters\n", A("D_f_cluster_mean"), A("D_f_cluster_sd"),
               ndf);
        if (A("corr_ok") == 1)
            printf("correction fit   R_g = A N^(1/D) (1 + B N^-nu), N in [%.0f, %.0f]: D = %.4f [%.4f, %.4f], "
                   "A = %.4f [%.4f, %.4f] diameters, B = %.4f, nu = %.3f%s (interval: %.0f resamples)\n",
                   A("corr_n_lo"), A("fit_n_hi"), A("corr_D"), A("corr_D_lo"), A("corr_D_hi"), A("corr_A_diam"),
                   A("corr_A_lo"), A("corr_A_hi"), A("corr_B"), A("corr_nu"),
                   A("corr_nu") <= 0.2 || A("corr_nu") >= 2.0 ? " (at the end of its range [0.2, 2]: poorly determined)" : "",
                   A("corr_samples"));
        else
            printf("correction fit   n/a (too few points)\n");
        printf("local slope      D_f over windows of %.2g decades of N, 95%% band:\n", A("slope_window_decades"));
        for (size_t i = 0; i < ns; i++)
            printf("  N %-10.0f  %.4f  [%.4f, %.4f]\n", sn[i], sd[i], sl[i], sh[i]);
    }
#undef A
    if (fflush(stdout) || ferror(stdout)) code = TOOL_RUNTIME;
out:
    free(sn), free(sd), free(sl), free(sh), free(dfc);
    h5r_attrs_free(&st), h5r_attrs_free(&en), h5r_attrs_free(&par);
    H5Fclose(f);
    H5Eset_auto2(H5E_DEFAULT, efn, edata);
    return code;
}
