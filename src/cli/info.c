/*
 * info.c - `pdla info FILE [--json]`: what a cluster file holds. A summary
 * (particles, dimension, order, D_f with its error and fit range, extent,
 * timing, provenance), then every attribute of /parameters, /results and
 * /Code as stored, so parameters added later show without changes here.
 * --json prints the same as one JSON object (NaN and infinities as null).
 */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "h5read.h"
#include "dlca_cmd.h"
#include "tools.h"

static const char info_help[] =
    "Usage: pdla info FILE [--json]\n"
    "Show what a pdla cluster file (cluster.h5) holds: particles, dimension,\n"
    "parameters, the fractal dimension D_f from the R_g(N) fit with its error,\n"
    "timing and provenance, then every stored attribute.\n"
    "\n"
    "  --json     one JSON object on stdout instead of text\n"
    "  -h, --help print this help and exit\n"
    "\n"
    "Exit status: 0 done; 2 bad usage or a file that is not a pdla cluster file.\n";

static void json_num(FILE *o, double v)
{
    if (isfinite(v)) fprintf(o, "%.17g", v);
    else fputs("null", o);
}

static void json_attr(FILE *o, const h5r_attr *a)
{
    if (a->n > 1) { /* an array of numbers */
        for (int k = 0; k < a->n; k++) {
            fputs(k ? ", " : "[", o);
            if (a->kind == 'i') fprintf(o, "%lld", (long long)a->iv[k]);
            else if (a->kind == 'u') fprintf(o, "%llu", (unsigned long long)a->uv[k]);
            else json_num(o, a->fv[k]);
        }
        fputc(']', o);
        return;
    }
    switch (a->kind) {
    case 'i': fprintf(o, "%lld", (long long)a->i); break;
    case 'u': fprintf(o, "%llu", (unsigned long long)a->u); break;
    case 'f': json_num(o, a->f); break;
    default: tool_json_str(o, a->s ? a->s : ""); break;
    }
}

static void json_group(FILE *o, const char *name, const h5r_attrs *g, int last)
{
    fprintf(o, "  ");
    tool_json_str(o, name);
    fprintf(o, ": {");
    for (size_t i = 0; i < g->n; i++) {
        fprintf(o, "%s\n    ", i ? "," : "");
        tool_json_str(o, g->a[i].name);
        fprintf(o, ": ");
        json_attr(o, &g->a[i]);
    }
    fprintf(o, "%s}%s\n", g->n ? "\n  " : "", last ? "" : ",");
}

static void text_attr(FILE *o, const h5r_attr *a)
{
    if (a->n > 1) { /* an array of numbers, blank-separated */
        for (int k = 0; k < a->n; k++) {
            if (k) fputc(' ', o);
            if (a->kind == 'i') fprintf(o, "%lld", (long long)a->iv[k]);
            else if (a->kind == 'u') fprintf(o, "%llu", (unsigned long long)a->uv[k]);
            else fprintf(o, "%.10g", a->fv[k]);
        }
        return;
    }
    switch (a->kind) {
    case 'i': fprintf(o, "%lld", (long long)a->i); break;
    case 'u': fprintf(o, "%llu", (unsigned long long)a->u); break;
    case 'f': fprintf(o, "%.10g", a->f); break;
    default: fprintf(o, "%s", a->s ? a->s : ""); break;
    }
}

static void text_group(FILE *o, const char *name, const h5r_attrs *g)
{
    fprintf(o, "\n[%s]\n", name);
    for (size_t i = 0; i < g->n; i++) {
        fprintf(o, "  %-20s ", g->a[i].name);
        text_attr(o, &g->a[i]);
        fputc('\n', o);
    }
}

static const char *str_or(const h5r_attrs *g, const char *name, const char *dflt)
{
    const h5r_attr *const a = h5r_attr_find(g, name);
    return a && a->kind == 's' && a->s ? a->s : dflt;
}

static void print_text(FILE *o, const h5r_file *f, size_t k, const h5r_attrs *par,
                       const h5r_attrs *res, const h5r_attrs *code)
{
    const double D = f->diameter_units;
    fprintf(o, "file         %s\n", f->path);
    fprintf(o, "format       pdla-cluster version %d\n", f->format_version);
    fprintf(o, "particles    %llu in %dD, positions in %s order, D = %d units\n",
            (unsigned long long)f->n, f->dim, f->arrival ? "arrival" : "tree", f->diameter_units);
    const double rext = h5r_attr_num(res, "r_ext_units") / D, rg = h5r_attr_num(res, "rg_diam");
    if (isfinite(rext) || isfinite(rg))
        fprintf(o, "extent       R_ext = %.6g diameters, R_g = %.6g diameters\n", rext, rg);
    const double df = h5r_attr_num(res, "D_f"), dfe = h5r_attr_num(res, "D_f_err");
    if (isfinite(df))
        fprintf(o, "D_f          %.4f +- %.4f (R_g(N) fit, N in [%.0f, %.0f], %.0f of %zu samples)\n",
                df, dfe, h5r_attr_num(res, "fit_n_lo"), h5r_attr_num(res, "fit_n_hi"),
                h5r_attr_num(res, "fit_points"), k);
    else
        fprintf(o, "D_f          not fitted (%zu R_g samples)\n", k);
    const double gs = h5r_attr_num(res, "grow_seconds"), ws = h5r_attr_num(res, "wall_seconds");
    if (isfinite(gs))
        fprintf(o,
                "timing       grow %.3g s (parallel %.3g s, %.0f threads), wall %.3g s, "
                "%.4g jumps/particle, %.3g ns/jump, peak RSS %.1f MiB\n",
                gs, h5r_attr_num(res, "parallel_seconds"), h5r_attr_num(res, "threads"), ws,
                h5r_attr_num(res, "jumps_per_particle"), h5r_attr_num(res, "ns_per_jump"),
                h5r_attr_num(res, "peak_rss_bytes") / 1048576.0);
    const h5r_attr *const seed = h5r_attr_find(par, "seed");
    const h5r_attr *const target = h5r_attr_find(par, "target");
    if (seed && target) {
        fprintf(o, "seed         ");
        text_attr(o, seed); /* exact: a 64-bit seed does not fit a double */
        fprintf(o, ", target ");
        text_attr(o, target);
        fprintf(o, ", threads %.0f\n", h5r_attr_num(par, "threads"));
    }
    fprintf(o, "provenance   pdla %s (git %s), %s, HDF5 %s, hwloc %s\n",
            str_or(code, "version", "?"), str_or(code, "git_revision", "?"),
            str_or(code, "compiler", "?"), str_or(code, "hdf5_version", "?"),
            str_or(code, "hwloc_version", "?"));
    fprintf(o, "made         %s on %s\n", str_or(code, "created_utc", "?"), str_or(code, "host", "?"));
    fprintf(o, "command      %s\n", str_or(code, "command_line", "?"));
    text_group(o, "parameters", par);
    text_group(o, "results", res);
    text_group(o, "Code", code);
}

static void print_json(FILE *o, const h5r_file *f, size_t k, const h5r_attrs *par,
                       const h5r_attrs *res, const h5r_attrs *code)
{
    fprintf(o, "{\n  \"file\": ");
    tool_json_str(o, f->path);
    fprintf(o, ",\n  \"format\": \"pdla-cluster\",\n  \"format_version\": %d,\n", f->format_version);
    fprintf(o, "  \"particles\": %llu,\n  \"dim\": %d,\n  \"diameter_units\": %d,\n  \"order\": ",
            (unsigned long long)f->n, f->dim, f->diameter_units);
    tool_json_str(o, f->order);
    fprintf(o, ",\n  \"rg_samples\": %zu,\n  \"D_f\": ", k);
    json_num(o, h5r_attr_num(res, "D_f"));
    fprintf(o, ",\n  \"D_f_err\": ");
    json_num(o, h5r_attr_num(res, "D_f_err"));
    fprintf(o, ",\n");
    json_group(o, "parameters", par, 0);
    json_group(o, "results", res, 0);
    json_group(o, "Code", code, 1);
    fprintf(o, "}\n");
}

int tool_info(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"json", no_argument, NULL, 'j'}, {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    int json = 0, c;
    if (tools_options_begin("info", argc, argv, longopts, "h")) return TOOL_USAGE;
    while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        switch (c) {
        case 'j': json = 1; break;
        case 'h': fputs(info_help, stdout); return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        default:
            return tools_option_error("info", argv, optind, 0); /* no option of info takes a value */
        }
    }
    if (tools_one_file("info", optind, argc)) return TOOL_USAGE;
    if (dlca_info_is_dlca(argv[optind])) return dlca_info_main(argv[optind], json); /* model dlca */
    char err[1024];
    h5r_file f;
    if (h5r_open(&f, argv[optind], err, sizeof err)) {
        fprintf(stderr, "pdla info: %s\n", err);
        return TOOL_USAGE;
    }
    h5r_attrs par = {0}, res = {0}, code = {0};
    uint64_t *sn = NULL;
    double *srg = NULL;
    size_t k = 0;
    int rc = TOOL_OK;
    if (h5r_read_attrs(&f, "/parameters", &par, err, sizeof err) ||
        h5r_read_attrs(&f, "/results", &res, err, sizeof err) ||
        h5r_read_attrs(&f, "/Code", &code, err, sizeof err) ||
        h5r_read_series(&f, &sn, &srg, &k, err, sizeof err)) {
        fprintf(stderr, "pdla info: %s\n", err);
        rc = TOOL_RUNTIME;
    } else {
        if (json) print_json(stdout, &f, k, &par, &res, &code);
        else print_text(stdout, &f, k, &par, &res, &code);
        if (fflush(stdout) || ferror(stdout)) {
            fprintf(stderr, "pdla info: cannot write to stdout\n");
            rc = TOOL_RUNTIME;
        }
    }
    free(sn);
    free(srg);
    h5r_attrs_free(&par);
    h5r_attrs_free(&res);
    h5r_attrs_free(&code);
    return h5r_close_tool(&f, "info", rc);
}
