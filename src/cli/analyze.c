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
#include "optcheck.h"
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
    if (isfinite(v)) fprintf(o, "%.17g", v);
    else fputs("null", o);
    fputs(comma ? ",\n" : "\n", o);
}

int tool_analyze(int argc, char **argv)
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
    analyze_opts o = {0, 5.0, 0.3, 20, NULL, 0, 0, H5R_MAX_SLAB_ROWS};
    int c;
    long v;
    opterr = 0;
    optind = 1;
    char oerr[160];
    int cluster_only = 0; /* options that apply to a cluster file only */
    if (optcheck_exact(argc, argv, longopts, "h", oerr, sizeof oerr)) {
        fprintf(stderr, "pdla analyze: %s\n", oerr);
        return TOOL_USAGE;
    }
    while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        const char *bad = NULL;
        switch (c) {
        case O_CENTRE:
            if (strcmp(optarg, "seed") == 0) o.centre_mass = 0;
            else if (strcmp(optarg, "mass") == 0) o.centre_mass = 1;
            else bad = "--centre: want seed or mass";
            break;
        case O_FITMIN:
            if (parse_real(optarg, &o.fit_min_diam) || o.fit_min_diam <= 0) bad = "--fit-min: want a positive number of diameters";
            break;
        case O_FITMAX:
            if (parse_real(optarg, &o.fit_max_frac) || !(o.fit_max_frac > 0 && o.fit_max_frac <= 1)) bad = "--fit-max: want a fraction in (0, 1]";
            break;
        case O_PERDEC:
            if (cli_parse_long_in(optarg, 2, 1000, &v)) bad = "--per-decade: want a whole number in [2, 1000]";
            else o.per_decade = (int)v;
            break;
        case O_CSV: o.csv_dir = optarg; break;
        case O_FORCE: o.force = 1; break;
        case O_JSON: o.json = 1; break;
        case O_SLAB:
            if (cli_parse_long_in(optarg, 1, H5R_MAX_SLAB_ROWS, &v)) bad = "--slab-rows: want a whole number in [1, 65536]";
            else o.slab_rows = (size_t)v;
            break;
        case 'h': fputs(analyze_help, stdout); return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        default:
            return tools_option_error("analyze", argv, optind, optopt);
        }
        if (bad) return tools_value_error("analyze", optarg, bad);
        cluster_only += c != O_JSON;
    }
    if (tools_one_file("analyze", optind, argc)) return TOOL_USAGE;
    /* An ensemble file (pdla ensemble): its stored statistics. */
    if (ens_analyze_is_ensemble(argv[optind])) {
        if (cluster_only) {
            fprintf(stderr, "pdla analyze: %s is an ensemble file: only --json applies\n", argv[optind]);
            return TOOL_USAGE;
        }
        return ens_analyze_main(argv[optind], o.json);
    }
    char err[1024];
    /* A bad --csv fails before any reading. */
    if (o.csv_dir) {
        struct stat st;
        if (stat(o.csv_dir, &st) != 0) {
            if (errno != ENOENT || mkdir(o.csv_dir, 0777) != 0) {
                fprintf(stderr, "pdla analyze: cannot make directory %s: %s\n", o.csv_dir, strerror(errno));
                return TOOL_USAGE;
            }
        } else if (!S_ISDIR(st.st_mode)) {
            fprintf(stderr, "pdla analyze: %s is not a directory\n", o.csv_dir);
            return TOOL_USAGE;
        }
        char p[4200];
        snprintf(p, sizeof p, "%s/rg.csv", o.csv_dir);
        const int b1 = tools_out_check(p, o.force, err, sizeof err);
        snprintf(p, sizeof p, "%s/mass_radius.csv", o.csv_dir);
        if (b1 || tools_out_check(p, o.force, err, sizeof err)) {
            fprintf(stderr, "pdla analyze: %s\n", err);
            return TOOL_USAGE;
        }
    }
    h5r_file f;
    if (h5r_open(&f, argv[optind], err, sizeof err)) {
        fprintf(stderr, "pdla analyze: %s\n", err);
        return TOOL_USAGE;
    }
    const int D = f.diameter_units;
    int rc = TOOL_RUNTIME;
    uint64_t *sn = NULL, *mass = NULL;
    double *srg = NULL, *edges = NULL, *edges_diam = NULL;
    size_t k = 0;
    mr_pass m;
    memset(&m, 0, sizeof m);
    m.dim = f.dim;
    if (h5r_read_series(&f, &sn, &srg, &k, err, sizeof err)) goto out;
    uint64_t n_lo, n_hi;
    pdla_fit_default_range(f.n, &n_lo, &n_hi);
    const pdla_fit frg = pdla_fit_powerlaw(sn, srg, k, n_lo, n_hi);

    if (f.n == 0) {
        snprintf(err, sizeof err, "%s holds no particles", f.path);
        rc = TOOL_USAGE;
        goto out;
    }
    if (h5r_stream(&f, o.slab_rows, pass1, &m, err, sizeof err)) goto out;
    const long double nn = (long double)f.n;
    long double mean2 = 0;
    double com[3] = {0, 0, 0};
    for (int a = 0; a < f.dim; a++) {
        const long double mu = (long double)m.s1[a] / nn;
        com[a] = (double)mu;
        mean2 += mu * mu;
    }
    const long double rg2 = (long double)m.s2 / nn - mean2;
    const double rg_final = sqrt(rg2 > 0 ? (double)rg2 : 0.0) / D;
    double com_abs = 0;
    for (int a = 0; a < f.dim; a++) {
        if (o.centre_mass) m.centre[a] = com[a];
        com_abs += com[a] * com[a];
    }
    /* Radii r_i = D * 10^(i/K), i = 0.. up to past the farthest particle. */
    const double rbound = sqrt(m.rmax_seed2) + (o.centre_mass ? sqrt(com_abs) : 0) + 1;
    const double decades = rbound > D ? log10(rbound / D) : 0;
    m.nedges = (size_t)ceil(decades * o.per_decade) + 2;
    edges = malloc(m.nedges * sizeof *edges);
    edges_diam = malloc(m.nedges * sizeof *edges_diam);
    m.hist = calloc(m.nedges + 1, sizeof *m.hist);
    mass = malloc(m.nedges * sizeof *mass);
    if (!edges || !edges_diam || !m.hist || !mass) {
        snprintf(err, sizeof err, "out of memory");
        goto out;
    }
    for (size_t i = 0; i < m.nedges; i++) {
        edges_diam[i] = pow(10.0, (double)i / o.per_decade);
        edges[i] = edges_diam[i] * D;
    }
    m.edges = edges;
    if (h5r_stream(&f, o.slab_rows, pass2, &m, err, sizeof err)) goto out;
    uint64_t cum = 0;
    for (size_t i = 0; i < m.nedges; i++) {
        cum += m.hist[i];
        mass[i] = cum;
    }
    const double rext_diam = m.rmax / D;
    const double fit_lo = o.fit_min_diam, fit_hi = o.fit_max_frac * rext_diam;
    /* Fit ln r on ln M (fit_powerlaw's form: D_f = 1 / slope) over the
     * radii in range; the mass counts stand in for N. */
    size_t nf = 0;
    for (size_t i = 0; i < m.nedges; i++)
        if (edges_diam[i] >= fit_lo && edges_diam[i] <= fit_hi && mass[i] > 0) nf++;
    uint64_t *fm = malloc((nf ? nf : 1) * sizeof *fm);
    double *fr = malloc((nf ? nf : 1) * sizeof *fr);
    if (!fm || !fr) {
        free(fm);
        free(fr);
        snprintf(err, sizeof err, "out of memory");
        goto out;
    }
    nf = 0;
    for (size_t i = 0; i < m.nedges; i++)
        if (edges_diam[i] >= fit_lo && edges_diam[i] <= fit_hi && mass[i] > 0) {
            fm[nf] = mass[i];
            fr[nf] = edges_diam[i];
            nf++;
        }
    const pdla_fit fmr = pdla_fit_powerlaw(fm, fr, nf, 1, UINT64_MAX);
    free(fm);
    free(fr);

    if (o.csv_dir && write_csvs(&o, sn, srg, k, &frg, edges_diam, mass, m.nedges, fit_lo, fit_hi, D,
                                err, sizeof err))
        goto out;

    FILE *out = stdout;
    const char *centre = o.centre_mass ? "mass" : "seed";
    if (o.json) {
        fprintf(out, "{\n  \"file\": \"");
        for (const char *s = f.path; *s; s++) {
            if (*s == '"' || *s == '\\') fputc('\\', out);
            if ((unsigned char)*s >= 0x20) fputc(*s, out);
        }
        fprintf(out, "\",\n  \"particles\": %llu,\n  \"dim\": %d,\n  \"centre\": \"%s\",\n",
                (unsigned long long)f.n, f.dim, centre);
        json_num(out, "centre_of_mass_x_diam", com[0] / D, 1);
        json_num(out, "centre_of_mass_y_diam", com[1] / D, 1);
        json_num(out, "centre_of_mass_z_diam", f.dim == 3 ? com[2] / D : 0.0, 1);
        json_num(out, "r_ext_diam", rext_diam, 1);
        json_num(out, "rg_final_diam", rg_final, 1);
        json_num(out, "rg_D_f", frg.df, 1);
        json_num(out, "rg_D_f_err", frg.df_err, 1);
        json_num(out, "rg_prefactor_diam", frg.prefactor_diam, 1);
        json_num(out, "rg_fit_n_lo", (double)frg.n_lo, 1);
        json_num(out, "rg_fit_n_hi", (double)frg.n_hi, 1);
        json_num(out, "rg_fit_points", frg.points, 1);
        json_num(out, "mr_D_f", fmr.df, 1);
        json_num(out, "mr_D_f_err", fmr.df_err, 1);
        json_num(out, "mr_prefactor_diam", fmr.prefactor_diam, 1);
        json_num(out, "mr_fit_r_lo_diam", fit_lo, 1);
        json_num(out, "mr_fit_r_hi_diam", fit_hi, 1);
        json_num(out, "mr_fit_points", fmr.points, 0);
        fprintf(out, "}\n");
    } else {
        fprintf(out, "file           %s\n", f.path);
        fprintf(out, "particles      %llu in %dD\n", (unsigned long long)f.n, f.dim);
        fprintf(out, "centre         %s", o.centre_mass ? "centre of mass" : "seed (origin)");
        fprintf(out, "; centre of mass at (%.3f, %.3f", com[0] / D, com[1] / D);
        if (f.dim == 3) fprintf(out, ", %.3f", com[2] / D);
        fprintf(out, ") diameters\n");
        fprintf(out, "R_ext          %.6g diameters from the centre; R_g %.6g diameters\n", rext_diam,
                rg_final);
        if (frg.points > 0)
            fprintf(out, "D_f (R_g)      %.4f +- %.4f  ln R_g on ln N, N in [%llu, %llu], %d points\n",
                    frg.df, frg.df_err, (unsigned long long)frg.n_lo, (unsigned long long)frg.n_hi,
                    frg.points);
        else
            fprintf(out, "D_f (R_g)      not fitted: %zu R_g samples, fewer than 3 with N in [%llu, %llu]\n",
                    k, (unsigned long long)n_lo, (unsigned long long)n_hi);
        if (fmr.points > 0)
            fprintf(out,
                    "D_f (M(r))     %.4f +- %.4f  ln r on ln M, r in [%g, %g] diameters "
                    "(%.2g .. %g R_ext), %d points\n",
                    fmr.df, fmr.df_err, fit_lo, fit_hi, fit_lo / rext_diam, o.fit_max_frac, fmr.points);
        else
            fprintf(out, "D_f (M(r))     not fitted: fewer than 3 radii in [%g, %g] diameters "
                    "(cluster too small for this range)\n", fit_lo, fit_hi);
        fprintf(out, "errors         least-squares standard errors; they understate the\n"
                     "               cluster-to-cluster spread (use ensembles)\n");
    }
    if (fflush(out) || ferror(out)) {
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
    h5r_close(&f);
    return rc;
}
