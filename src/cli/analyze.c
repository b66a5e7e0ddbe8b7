/*
 * analyze.c - `pdla analyze FILE`: the fractal dimension two ways.
 *
 * (a) From the R_g(N) series stored while growing: least squares of
 *     ln R_g on ln N over the engine's default range (src/core/fit.c).
 * (b) From the mass-radius relation of the final cluster: M(r) = particles
 *     whose centre lies closer than r to the centre (the seed, or the centre
 *     of mass), at log-spaced r = 10^(i/K) diameters; least squares of ln r
 *     on ln M over r in [r_lo, f_hi R_ext] (defaults 5 diameters and 0.3),
 *     D_f = 1 / slope, by the same fit code.
 *
 * Why that range: below a few diameters M(r) counts a handful of discs and
 * steps with the packing around the centre; beyond ~0.3-0.5 R_ext the
 * density falls off towards the tips, where the cluster is still growing
 * and M(r) bends over to the total mass. Between, DLA is statistically
 * self-similar. Points of M(r) are cumulative, so they are correlated and
 * the least-squares error understates the real uncertainty, as for R_g(N).
 *
 * The positions are streamed twice in hyperslabs (centre and extent, then
 * the histogram), so memory is the slab plus one counter per radius bin.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "pdla/pdla.h"
#include "dlca_cmd.h"
#include "h5read.h"
#include "parse.h"
#include "tools.h"

static const char analyze_help[] =
    "Usage: pdla analyze FILE [OPTION]...\n"
    "Fractal dimension of a pdla cluster file, (a) from its R_g(N) series and\n"
    "(b) from the mass-radius relation M(r) of the final cluster, each with the\n"
    "least-squares standard error and the fit range.\n"
    "\n"
    "  --centre seed|mass  where r is measured from: the seed particle (origin)\n"
    "                      or the centre of mass (default seed)\n"
    "  --fit-min R         smallest r of the M(r) fit, diameters (default 5)\n"
    "  --fit-max F         largest r of the M(r) fit as a fraction of R_ext,\n"
    "                      the largest particle distance from the centre\n"
    "                      (default 0.3)\n"
    "  --per-decade K      radii per decade of r, 2..1000 (default 20)\n"
    "  --csv DIR           also write DIR/rg.csv and DIR/mass_radius.csv (DIR is\n"
    "                      made if missing; existing files need --force)\n"
    "  --force             replace existing CSV files\n"
    "  --json              print the results as one JSON object\n"
    "  --slab-rows N       rows read at once, 1..65536 (default 65536)\n"
    "  -h, --help          print this help and exit\n"
    "\n"
    "An ensemble file (pdla ensemble DIR/ensemble.h5) prints its statistics:\n"
    "D_f with its bootstrap interval, the correction-to-scaling fit, the local\n"
    "slope with its band (only --json applies).\n"
    "\n"
    "Exit status: 0 done; 1 a read or write failed; 2 bad usage or input.\n";

typedef struct mr_pass {
    int dim;
    double centre[3]; /* units */
    /* pass 1 */
    __extension__ __int128 s1[3];
    __extension__ unsigned __int128 s2;
    double rmax_seed2;
    /* pass 2 */
    const double *edges; /* units, increasing */
    size_t nedges;
    uint64_t *hist; /* hist[i]: particles with edges[i-1] <= r < edges[i]; hist[nedges]: beyond */
    double rmax; /* from the centre, units */
} mr_pass;

static int pass1(const int32_t *xyz, size_t rows, uint64_t first, void *user)
{
    (void)first;
    mr_pass *const m = user;
    for (size_t i = 0; i < rows; i++) {
        const int32_t *const p = xyz + i * (size_t)m->dim;
        double r2 = 0;
        for (int a = 0; a < m->dim; a++) {
            m->s1[a] += p[a];
            m->s2 += (unsigned __int128)((int64_t)p[a] * p[a]);
            r2 += (double)p[a] * p[a];
        }
        if (r2 > m->rmax_seed2) m->rmax_seed2 = r2;
    }
    return 0;
}

/* Index of the first edge above r: M(edges[i]) counts r < edges[i]. */
static size_t edge_index(const mr_pass *m, double r)
{
    if (m->nedges == 0 || r < m->edges[0]) return 0;
    /* Start from the log estimate, then settle on the exact comparison. */
    const double k = (double)(m->nedges - 1) / log(m->edges[m->nedges - 1] / m->edges[0]);
    double g = floor(log(r / m->edges[0]) * k) + 1;
    size_t i = g < 1 ? 1 : g > (double)m->nedges ? m->nedges : (size_t)g;
    while (i > 0 && r < m->edges[i - 1]) i--;
    while (i < m->nedges && r >= m->edges[i]) i++;
    return i;
}

static int pass2(const int32_t *xyz, size_t rows, uint64_t first, void *user)
{
    (void)first;
    mr_pass *const m = user;
    for (size_t i = 0; i < rows; i++) {
        const int32_t *const p = xyz + i * (size_t)m->dim;
        double r2 = 0;
        for (int a = 0; a < m->dim; a++) {
            const double d = (double)p[a] - m->centre[a];
            r2 += d * d;
        }
        const double r = sqrt(r2);
        if (r > m->rmax) m->rmax = r;
        m->hist[edge_index(m, r)]++;
    }
    return 0;
}

typedef struct analyze_opts {
    int centre_mass;
    double fit_min_diam, fit_max_frac;
    int per_decade;
    const char *csv_dir;
    int force, json;
    size_t slab_rows;
    int cluster_only; /* options given that apply to a cluster file only */
} analyze_opts;

/* The option values use the main command line's strict parsers. */
static int parse_real(const char *s, double *out) { return cli_parse_real(s, out) ? -1 : 0; }

static int write_csvs(const analyze_opts *o, const uint64_t *sn, const double *srg, size_t k,
                      const pdla_fit *frg, const double *edges_diam, const uint64_t *mass,
                      size_t nedges, double fit_lo, double fit_hi, int D, char *err, size_t errlen)
{
    char path[2][4200], tmp[4300];
    snprintf(path[0], sizeof path[0], "%s/rg.csv", o->csv_dir);
    snprintf(path[1], sizeof path[1], "%s/mass_radius.csv", o->csv_dir);
    for (int which = 0; which < 2; which++) {
        FILE *fp = tools_out_open(path[which], tmp, sizeof tmp, err, errlen);
        if (!fp) return -1;
        if (which == 0) {
            fprintf(fp, "N,rg_diam,in_fit\n");
            for (size_t i = 0; i < k; i++)
                fprintf(fp, "%llu,%.17g,%d\n", (unsigned long long)sn[i], srg[i],
                        frg->points > 0 && sn[i] >= frg->n_lo && sn[i] <= frg->n_hi && srg[i] > 0);
        } else {
            fprintf(fp, "r_diam,r_units,M,in_fit\n");
            for (size_t i = 0; i < nedges; i++)
                fprintf(fp, "%.17g,%.17g,%llu,%d\n", edges_diam[i], edges_diam[i] * D,
                        (unsigned long long)mass[i],
                        edges_diam[i] >= fit_lo && edges_diam[i] <= fit_hi && mass[i] > 0);
        }
        if (tools_out_commit(fp, tmp, path[which], o->force, err, errlen)) return -1;
    }
    return 0;
}

static void json_num(FILE *o, const char *name, double v, int comma)
{
    fprintf(o, "  \"%s\": ", name);
    tool_json_num(o, v, 17);
    fputs(comma ? ",\n" : "\n", o);
}

/* Parses the options into o; GO_ON, or the exit status (--help, a bad
 * option or value, not exactly one FILE). */
#define GO_ON (-1)
static int parse_options(int argc, char **argv, analyze_opts *o)
{
    if (dlca_tool_file(argc, argv)) return dlca_analyze_main(argc, argv); /* model dlca: dlca_tools.c */
    enum { O_CENTRE = 256, O_FITMIN, O_FITMAX, O_PERDEC, O_CSV, O_FORCE, O_JSON, O_SLAB };
    static const struct option longopts[] = {
        {"centre", required_argument, NULL, O_CENTRE}, {"center", required_argument, NULL, O_CENTRE},
        {"fit-min", required_argument, NULL, O_FITMIN}, {"fit-max", required_argument, NULL, O_FITMAX},
        {"per-decade", required_argument, NULL, O_PERDEC}, {"csv", required_argument, NULL, O_CSV},
        {"force", no_argument, NULL, O_FORCE}, {"json", no_argument, NULL, O_JSON},
        {"slab-rows", required_argument, NULL, O_SLAB}, {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    int c;
    long v;
    if (tools_options_begin("analyze", argc, argv, longopts, "h")) return TOOL_USAGE;
    while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        const char *bad = NULL;
        switch (c) {
        case O_CENTRE:
            if (strcmp(optarg, "seed") == 0) o->centre_mass = 0;
            else if (strcmp(optarg, "mass") == 0) o->centre_mass = 1;
            else bad = "--centre: want seed or mass";
            break;
        case O_FITMIN:
            if (parse_real(optarg, &o->fit_min_diam) || o->fit_min_diam <= 0) bad = "--fit-min: want a positive number of diameters";
            break;
        case O_FITMAX:
            if (parse_real(optarg, &o->fit_max_frac) || !(o->fit_max_frac > 0 && o->fit_max_frac <= 1)) bad = "--fit-max: want a fraction in (0, 1]";
            break;
        case O_PERDEC:
            if (cli_parse_long_in(optarg, 2, 1000, &v)) bad = "--per-decade: want a whole number in [2, 1000]";
            else o->per_decade = (int)v;
            break;
        case O_CSV: o->csv_dir = optarg; break;
        case O_FORCE: o->force = 1; break;
        case O_JSON: o->json = 1; break;
        case O_SLAB:
            if (cli_parse_long_in(optarg, 1, H5R_MAX_SLAB_ROWS, &v)) bad = "--slab-rows: want a whole number in [1, 65536]";
            else o->slab_rows = (size_t)v;
            break;
        case 'h': fputs(analyze_help, stdout); return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        default:
            return tools_option_error("analyze", argv, optind, optopt);
        }
        if (bad) return tools_value_error("analyze", optarg, bad);
        o->cluster_only += c != O_JSON;
    }
    if (tools_one_file("analyze", optind, argc)) return TOOL_USAGE;
    return GO_ON;
}

/* A bad --csv fails before any reading: the directory is made, and the two
 * files must be writable (or replaceable with --force). */
static int check_csv_dir(const analyze_opts *o, const char *input)
{
    if (!o->csv_dir) return 0;
    /* the name as shown in a one-line message: control bytes as '?' */
    char shown[4200];
    snprintf(shown, sizeof shown, "%s", o->csv_dir);
    for (char *c = shown; *c; c++)
        if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
    struct stat st;
    if (stat(o->csv_dir, &st) != 0) {
        if (errno != ENOENT || mkdir(o->csv_dir, 0777) != 0) {
            fprintf(stderr, "pdla analyze: cannot make directory %s: %s\n", shown, strerror(errno));
            return TOOL_USAGE;
        }
    } else if (!S_ISDIR(st.st_mode)) {
        fprintf(stderr, "pdla analyze: %s is not a directory\n", shown);
        return TOOL_USAGE;
    }
    char p[4200], err[1024];
    snprintf(p, sizeof p, "%s/rg.csv", o->csv_dir);
    const int b1 = tools_out_check(p, input, o->force, err, sizeof err);
    snprintf(p, sizeof p, "%s/mass_radius.csv", o->csv_dir);
    if (b1 || tools_out_check(p, input, o->force, err, sizeof err)) {
        fprintf(stderr, "pdla analyze: %s\n", err);
        return TOOL_USAGE;
    }
    return 0;
}

/* What the analysis found, for the reports. */
typedef struct analysis {
    double com[3];            /* centre of mass, units */
    double rg_final, rext_diam;
    pdla_fit frg, fmr;        /* D_f from R_g(N) and from M(r) */
    uint64_t n_lo, n_hi;      /* the R_g fit's N range */
    size_t k;                 /* R_g samples */
    double fit_lo, fit_hi;    /* the M(r) fit's radii, diameters */
} analysis;

/* After pass 1: the centre of mass and R_g of the whole cluster; with
 * --centre mass, pass 2 measures from the centre of mass. */
static void centre_and_rg(mr_pass *m, const h5r_file *f, const analyze_opts *o, analysis *an)
{
    const int D = f->diameter_units;
    const long double nn = (long double)f->n;
    long double mean2 = 0;
    for (int a = 0; a < f->dim; a++) {
        const long double mu = (long double)m->s1[a] / nn;
        an->com[a] = (double)mu;
        mean2 += mu * mu;
    }
    const long double rg2 = (long double)m->s2 / nn - mean2;
    an->rg_final = sqrt(rg2 > 0 ? (double)rg2 : 0.0) / D;
    for (int a = 0; a < f->dim; a++)
        if (o->centre_mass) m->centre[a] = an->com[a];
}

/* The radii of pass 2: r_i = D * 10^(i/K), i = 0.. up to past the farthest
 * particle, in units (edges, m->edges) and diameters (edges_diam); the
 * histogram and the cumulative masses. -1: out of memory. */
static int make_bins(mr_pass *m, const analyze_opts *o, const analysis *an, int D, double **edges,
                     double **edges_diam, uint64_t **mass)
{
    double com_abs = 0;
    for (int a = 0; a < m->dim; a++) com_abs += an->com[a] * an->com[a];
    const double rbound = sqrt(m->rmax_seed2) + (o->centre_mass ? sqrt(com_abs) : 0) + 1;
    const double decades = rbound > D ? log10(rbound / D) : 0;
    m->nedges = (size_t)ceil(decades * o->per_decade) + 2;
    *edges = malloc(m->nedges * sizeof **edges);
    *edges_diam = malloc(m->nedges * sizeof **edges_diam);
    m->hist = calloc(m->nedges + 1, sizeof *m->hist);
    *mass = malloc(m->nedges * sizeof **mass);
    if (!*edges || !*edges_diam || !m->hist || !*mass) return -1;
    for (size_t i = 0; i < m->nedges; i++) {
        (*edges_diam)[i] = pow(10.0, (double)i / o->per_decade);
        (*edges)[i] = (*edges_diam)[i] * D;
    }
    m->edges = *edges;
    return 0;
}

/* Fit ln r on ln M (fit_powerlaw's form: D_f = 1 / slope) over the radii
 * in [fit_lo, fit_hi]; the mass counts stand in for N. -1: out of memory. */
static int fit_mass_radius(const double *edges_diam, const uint64_t *mass, size_t nedges,
                           analysis *an)
{
    size_t nf = 0;
    for (size_t i = 0; i < nedges; i++)
        if (edges_diam[i] >= an->fit_lo && edges_diam[i] <= an->fit_hi && mass[i] > 0) nf++;
    uint64_t *fm = malloc((nf ? nf : 1) * sizeof *fm);
    double *fr = malloc((nf ? nf : 1) * sizeof *fr);
    if (!fm || !fr) {
        free(fm);
        free(fr);
        return -1;
    }
    nf = 0;
    for (size_t i = 0; i < nedges; i++)
        if (edges_diam[i] >= an->fit_lo && edges_diam[i] <= an->fit_hi && mass[i] > 0) {
            fm[nf] = mass[i];
            fr[nf] = edges_diam[i];
            nf++;
        }
    an->fmr = pdla_fit_powerlaw(fm, fr, nf, 1, UINT64_MAX);
    free(fm);
    free(fr);
    return 0;
}

static void print_json(FILE *out, const h5r_file *f, const analyze_opts *o, const analysis *an)
{
    const int D = f->diameter_units;
    fprintf(out, "{\n  \"file\": ");
    tool_json_str(out, f->path); /* invalid UTF-8 as U+FFFD, control bytes escaped */
    fprintf(out, ",\n  \"particles\": %llu,\n  \"dim\": %d,\n  \"centre\": \"%s\",\n",
            (unsigned long long)f->n, f->dim, o->centre_mass ? "mass" : "seed");
    json_num(out, "centre_of_mass_x_diam", an->com[0] / D, 1);
    json_num(out, "centre_of_mass_y_diam", an->com[1] / D, 1);
    json_num(out, "centre_of_mass_z_diam", f->dim == 3 ? an->com[2] / D : 0.0, 1);
    json_num(out, "r_ext_diam", an->rext_diam, 1);
    json_num(out, "rg_final_diam", an->rg_final, 1);
    json_num(out, "rg_D_f", an->frg.df, 1);
    json_num(out, "rg_D_f_err", an->frg.df_err, 1);
    json_num(out, "rg_prefactor_diam", an->frg.prefactor_diam, 1);
    json_num(out, "rg_fit_n_lo", (double)an->frg.n_lo, 1);
    json_num(out, "rg_fit_n_hi", (double)an->frg.n_hi, 1);
    json_num(out, "rg_fit_points", an->frg.points, 1);
    json_num(out, "mr_D_f", an->fmr.df, 1);
    json_num(out, "mr_D_f_err", an->fmr.df_err, 1);
    json_num(out, "mr_prefactor_diam", an->fmr.prefactor_diam, 1);
    json_num(out, "mr_fit_r_lo_diam", an->fit_lo, 1);
    json_num(out, "mr_fit_r_hi_diam", an->fit_hi, 1);
    json_num(out, "mr_fit_points", an->fmr.points, 0);
    fprintf(out, "}\n");
}

static void print_text(FILE *out, const h5r_file *f, const analyze_opts *o, const analysis *an)
{
    const int D = f->diameter_units;
    const pdla_fit *frg = &an->frg, *fmr = &an->fmr;
    fprintf(out, "file           %s\n", f->path);
    fprintf(out, "particles      %llu in %dD\n", (unsigned long long)f->n, f->dim);
    fprintf(out, "centre         %s", o->centre_mass ? "centre of mass" : "seed (origin)");
    fprintf(out, "; centre of mass at (%.3f, %.3f", an->com[0] / D, an->com[1] / D);
    if (f->dim == 3) fprintf(out, ", %.3f", an->com[2] / D);
    fprintf(out, ") diameters\n");
    fprintf(out, "R_ext          %.6g diameters from the centre; R_g %.6g diameters\n", an->rext_diam,
            an->rg_final);
    if (frg->points > 0)
        fprintf(out, "D_f (R_g)      %.4f +- %.4f  ln R_g on ln N, N in [%llu, %llu], %d points\n",
                frg->df, frg->df_err, (unsigned long long)frg->n_lo, (unsigned long long)frg->n_hi,
                frg->points);
    else
        fprintf(out, "D_f (R_g)      not fitted: %zu R_g samples, fewer than 3 with N in [%llu, %llu]\n",
                an->k, (unsigned long long)an->n_lo, (unsigned long long)an->n_hi);
    if (fmr->points > 0)
        fprintf(out,
                "D_f (M(r))     %.4f +- %.4f  ln r on ln M, r in [%g, %g] diameters "
                "(%.2g .. %g R_ext), %d points\n",
                fmr->df, fmr->df_err, an->fit_lo, an->fit_hi, an->fit_lo / an->rext_diam,
                o->fit_max_frac, fmr->points);
    else
        fprintf(out, "D_f (M(r))     not fitted: fewer than 3 radii in [%g, %g] diameters "
                "(cluster too small for this range)\n", an->fit_lo, an->fit_hi);
    fprintf(out, "errors         least-squares standard errors; they understate the\n"
                 "               cluster-to-cluster spread (use ensembles)\n");
}

int tool_analyze(int argc, char **argv)
{
    analyze_opts o = {0, 5.0, 0.3, 20, NULL, 0, 0, H5R_MAX_SLAB_ROWS, 0};
    int rc = parse_options(argc, argv, &o);
    if (rc != GO_ON) return rc;
    /* An ensemble file (pdla ensemble): its stored statistics. */
    if (ens_analyze_is_ensemble(argv[optind])) {
        if (o.cluster_only) {
            fprintf(stderr, "pdla analyze: %s is an ensemble file: only --json applies\n", argv[optind]);
            return TOOL_USAGE;
        }
        return ens_analyze_main(argv[optind], o.json);
    }
    if ((rc = check_csv_dir(&o, argv[optind]))) return rc;
    char err[1024];
    h5r_file f;
    if (h5r_open(&f, argv[optind], err, sizeof err)) {
        fprintf(stderr, "pdla analyze: %s\n", err);
        return TOOL_USAGE;
    }
    const int D = f.diameter_units;
    rc = TOOL_RUNTIME;
    uint64_t *sn = NULL, *mass = NULL;
    double *srg = NULL, *edges = NULL, *edges_diam = NULL;
    analysis an;
    memset(&an, 0, sizeof an);
    mr_pass m;
    memset(&m, 0, sizeof m);
    m.dim = f.dim;
    if (h5r_read_series(&f, &sn, &srg, &an.k, err, sizeof err)) goto out;
    pdla_fit_default_range(f.n, &an.n_lo, &an.n_hi);
    an.frg = pdla_fit_powerlaw(sn, srg, an.k, an.n_lo, an.n_hi);

    if (f.n == 0) {
        snprintf(err, sizeof err, "%s holds no particles", f.path);
        rc = TOOL_USAGE;
        goto out;
    }
    if (h5r_stream(&f, o.slab_rows, pass1, &m, err, sizeof err)) goto out;
    centre_and_rg(&m, &f, &o, &an);
    if (make_bins(&m, &o, &an, D, &edges, &edges_diam, &mass)) {
        snprintf(err, sizeof err, "out of memory");
        goto out;
    }
    if (h5r_stream(&f, o.slab_rows, pass2, &m, err, sizeof err)) goto out;
    uint64_t cum = 0;
    for (size_t i = 0; i < m.nedges; i++) {
        cum += m.hist[i];
        mass[i] = cum;
    }
    an.rext_diam = m.rmax / D;
    an.fit_lo = o.fit_min_diam;
    an.fit_hi = o.fit_max_frac * an.rext_diam;
    if (fit_mass_radius(edges_diam, mass, m.nedges, &an)) {
        snprintf(err, sizeof err, "out of memory");
        goto out;
    }
    if (o.csv_dir && write_csvs(&o, sn, srg, an.k, &an.frg, edges_diam, mass, m.nedges, an.fit_lo,
                                an.fit_hi, D, err, sizeof err))
        goto out;
    if (o.json) print_json(stdout, &f, &o, &an);
    else print_text(stdout, &f, &o, &an);
    if (fflush(stdout) || ferror(stdout)) {
        snprintf(err, sizeof err, "cannot write to stdout");
        goto out;
    }
    rc = TOOL_OK;
out:
    if (rc != TOOL_OK) fprintf(stderr, "pdla analyze: %s\n", err);
    free(sn);
    free(srg);
    free(edges);
    free(edges_diam);
    free(m.hist);
    free(mass);
    return h5r_close_tool(&f, "analyze", rc);
}
