/*
 * ens_stats.c - the statistics physicists quote for an ensemble
 * (include/pdla/ensemble.h, pdla_ens_stats): mean R_g(N) with standard
 * errors, D_f of the mean with a bootstrap interval over clusters, the local
 * slope with its band, and the correction-to-scaling fit
 * R_g = A N^(1/D) (1 + B N^-nu) with its interval; /statistics in
 * ensemble.h5 is written from them by ens_write.c.
 *
 * Why bootstrap over clusters: the R_g(N) of one cluster at neighbouring N
 * are strongly correlated (the same particles), so the least-squares error
 * of a fit to the mean series is far too small; the clusters themselves are
 * independent, and resampling them carries every correlation along.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pdla/ensemble.h"
#include "fit.h"
#include "rng.h"

#define SLOPE_HALF 0.25 /* half width of a local-slope window, decades */
#define SLOPE_STEP 0.1  /* spacing of the windows' centres, decades */
#define CORR_N_LO 30    /* smallest N of the correction-to-scaling fit */

void pdla_ens_stats_free(pdla_ens_stats *s)
{
    if (!s) return;
    free(s->mean_rg), free(s->se_rg), free(s->slope_n), free(s->slope_df), free(s->slope_lo), free(s->slope_hi);
    memset(s, 0, sizeof *s);
}

/* ---- correction to scaling -------------------------------------------------- */

/* Solve the 3x3 system a x = b (Gaussian elimination, partial pivoting). */
static int solve3(double a[3][3], double b[3], double x[3])
{
    for (int c = 0; c < 3; c++) {
        int p = c;
        for (int r = c + 1; r < 3; r++)
            if (fabs(a[r][c]) > fabs(a[p][c])) p = r;
        if (!(fabs(a[p][c]) > 0)) return -1;
        if (p != c) {
            for (int q = 0; q < 3; q++) {
                const double t = a[c][q];
                a[c][q] = a[p][q];
                a[p][q] = t;
            }
            const double t = b[c];
            b[c] = b[p];
            b[p] = t;
        }
        for (int r = c + 1; r < 3; r++) {
            const double f = a[r][c] / a[c][c];
            for (int q = c; q < 3; q++) a[r][q] -= f * a[c][q];
            b[r] -= f * b[c];
        }
    }
    for (int c = 2; c >= 0; c--) {
        double s = b[c];
        for (int q = c + 1; q < 3; q++) s -= a[c][q] * x[q];
        x[c] = s / a[c][c];
    }
    return 0;
}

/* Sum of squared residuals of ln y = a + s x + ln(1 + B z), z = N^-nu
 * (precomputed), at parameters p = {a, s, B}; INFINITY where 1 + B z <= 0. */
static double corr_ssr(const double *x, const double *ly, const double *z, size_t k, const double p[3])
{
    double ssr = 0;
    for (size_t i = 0; i < k; i++) {
        const double g = 1.0 + p[2] * z[i];
        if (!(g > 0)) return INFINITY;
        const double r = ly[i] - p[0] - p[1] * x[i] - log(g);
        ssr += r * r;
    }
    return ssr;
}

/* Least squares over (a, s, B) at fixed nu: the linearised model
 * (ln(1 + B z) ~ B z) gives the start, Gauss-Newton with step halving
 * finishes. z: scratch of k. Returns the SSR, p filled. */
static double corr_fixed_nu(const double *x, const double *ly, double *z, size_t k, double nu, double p[3])
{
    double A[3][3] = {{0}}, b[3] = {0};
    for (size_t i = 0; i < k; i++) {
        z[i] = exp(-nu * x[i]);
        const double f[3] = {1.0, x[i], z[i]};
        for (int r = 0; r < 3; r++) {
            b[r] += f[r] * ly[i];
            for (int c = 0; c < 3; c++) A[r][c] += f[r] * f[c];
        }
    }
    if (solve3(A, b, p)) return INFINITY;
    double ssr = corr_ssr(x, ly, z, k, p);
    if (!isfinite(ssr)) {
        p[2] = 0; /* start from the pure power law instead */
        ssr = corr_ssr(x, ly, z, k, p);
    }
    for (int it = 0; it < 20 && isfinite(ssr); it++) {
        double J[3][3] = {{0}}, g[3] = {0};
        for (size_t i = 0; i < k; i++) {
            const double h = 1.0 + p[2] * z[i];
            const double r = ly[i] - p[0] - p[1] * x[i] - log(h);
            const double d[3] = {1.0, x[i], z[i] / h};
            for (int a = 0; a < 3; a++) {
                g[a] += d[a] * r;
                for (int c = 0; c < 3; c++) J[a][c] += d[a] * d[c];
            }
        }
        double step[3];
        if (solve3(J, g, step)) break;
        double lambda = 1.0, q[3], s2 = INFINITY;
        for (int h = 0; h < 20; h++, lambda *= 0.5) {
            for (int a = 0; a < 3; a++) q[a] = p[a] + lambda * step[a];
            s2 = corr_ssr(x, ly, z, k, q);
            if (s2 <= ssr) break;
        }
        if (!(s2 <= ssr)) break;
        const double gain = ssr - s2;
        memcpy(p, q, sizeof q);
        ssr = s2;
        if (gain <= 1e-12 * ssr + 1e-300) break;
    }
    return ssr;
}

int pdla_ens_corr_fit(const uint64_t *n, const double *y, size_t k, uint64_t n_lo, uint64_t n_hi, double *A,
                      double *D, double *B, double *nu, double *rms)
{
    double *x = malloc((k ? k : 1) * sizeof *x), *ly = malloc((k ? k : 1) * sizeof *ly);
    double *z = malloc((k ? k : 1) * sizeof *z);
    size_t used = 0;
    for (size_t i = 0; x && ly && z && i < k; i++)
        if (n[i] >= n_lo && n[i] <= n_hi && n[i] > 0 && y[i] > 0 && isfinite(y[i])) {
            x[used] = log((double)n[i]);
            ly[used++] = log(y[i]);
        }
    int rc = -1;
    if (used >= 5) {
        /* Profile nu on a grid, then golden-section between the best
         * point's neighbours. */
        double best = INFINITY, bnu = 0, p[3], bp[3] = {0, 0, 0};
        for (int j = 0; j <= 36; j++) {
            const double v = 0.2 + 0.05 * j;
            const double s = corr_fixed_nu(x, ly, z, used, v, p);
            if (s < best) best = s, bnu = v, memcpy(bp, p, sizeof p);
        }
        if (isfinite(best)) {
            double lo = bnu - 0.05 > 0.2 ? bnu - 0.05 : 0.2, hi = bnu + 0.05 < 2.0 ? bnu + 0.05 : 2.0;
            const double gr = 0.5 * (sqrt(5.0) - 1.0);
            for (int it = 0; it < 30; it++) { /* the bracket shrinks to 1e-7 */
                const double c = hi - gr * (hi - lo), d = lo + gr * (hi - lo);
                double pc[3], pd[3];
                const double sc = corr_fixed_nu(x, ly, z, used, c, pc), sd = corr_fixed_nu(x, ly, z, used, d, pd);
                if (sc < sd) hi = d;
                else lo = c;
                if (sc < best) best = sc, bnu = c, memcpy(bp, pc, sizeof pc);
                if (sd < best) best = sd, bnu = d, memcpy(bp, pd, sizeof pd);
            }
            *A = exp(bp[0]);
            *D = 1.0 / bp[1];
            *B = bp[2];
            *nu = bnu;
            *rms = sqrt(best / (double)used);
            rc = 0;
        }
    }
    free(x);
    free(ly);
    free(z);
    return rc;
}

/* ---- the ensemble ------------------------------------------------------------- */

/* The q-quantile of the finite values in v[0..n) (sorted in place; linear
 * interpolation), NaN when none is finite. */
static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double quantile(double *v, size_t n, double q)
{
    size_t f = 0;
    for (size_t i = 0; i < n; i++)
        if (isfinite(v[i])) v[f++] = v[i];
    if (f == 0) return NAN;
    qsort(v, f, sizeof *v, cmp_double);
    const double pos = q * (double)(f - 1);
    const size_t i = (size_t)pos;
    return i + 1 < f ? v[i] + (pos - (double)i) * (v[i + 1] - v[i]) : v[f - 1];
}

static void mean_sd(const double *v, size_t n, double *mean, double *sd)
{
    double s = 0, s2 = 0;
    size_t f = 0;
    for (size_t i = 0; i < n; i++)
        if (isfinite(v[i])) s += v[i], f++;
    *mean = f ? s / (double)f : NAN;
    for (size_t i = 0; i < n; i++)
        if (isfinite(v[i])) s2 += (v[i] - *mean) * (v[i] - *mean);
    *sd = f > 1 ? sqrt(s2 / (double)(f - 1)) : NAN;
}

/* Mean series of the clusters pick[0..m) (with repeats). */
static void mean_of(const double *rg, size_t k, const size_t *pick, size_t m, double *out)
{
    for (size_t j = 0; j < k; j++) out[j] = 0;
    for (size_t i = 0; i < m; i++) {
        const double *row = rg + pick[i] * k;
        for (size_t j = 0; j < k; j++) out[j] += row[j];
    }
    for (size_t j = 0; j < k; j++) out[j] /= (double)m;
}

/* Local slope windows: centres every SLOPE_STEP decade from n_lo on while a
 * whole window fits below n_max. */
static size_t slope_windows(uint64_t n_lo, uint64_t n_max, double *centre, size_t cap)
{
    size_t c = 0;
    const double top = log10((double)n_max);
    for (double x = log10((double)n_lo) + SLOPE_HALF; x + SLOPE_HALF <= top + 1e-9 && c < cap; x += SLOPE_STEP)
        centre[c++] = x;
    return c;
}

static void slope_range(double centre, uint64_t *lo, uint64_t *hi)
{
    *lo = (uint64_t)ceil(pow(10.0, centre - SLOPE_HALF) - 1e-9);
    *hi = (uint64_t)floor(pow(10.0, centre + SLOPE_HALF) + 1e-9);
}

/* The bootstrap's scratch arrays: B resamples, BC of them also refit
 * with the correction term, nw slope windows centred at centre[]. */
typedef struct boot_work {
    size_t B, BC, nw;
    const double *centre;
    size_t *pick;
    double *mean, *df, *sl, *A, *D;
} boot_work;

static void boot_free(boot_work *w)
{
    free(w->pick), free(w->mean), free(w->df), free(w->sl), free(w->A), free(w->D);
}

/* s's arrays and w's; 0, or -1 (out of memory). */
static int stats_alloc(pdla_ens_stats *s, boot_work *w, size_t m, size_t k)
{
    const size_t nw = w->nw, B = w->B, BC = w->BC;
    s->mean_rg = malloc((k ? k : 1) * 8);
    s->se_rg = malloc((k ? k : 1) * 8);
    s->slope_n = malloc((nw ? nw : 1) * 8), s->slope_df = malloc((nw ? nw : 1) * 8);
    s->slope_lo = malloc((nw ? nw : 1) * 8), s->slope_hi = malloc((nw ? nw : 1) * 8);
    w->pick = malloc(m * sizeof *w->pick);
    w->mean = malloc((k ? k : 1) * 8), w->df = malloc((B ? B : 1) * 8);
    w->sl = malloc((B * nw > 0 ? B * nw : 1) * 8), w->A = malloc((BC ? BC : 1) * 8);
    w->D = malloc((BC ? BC : 1) * 8);
    return !s->mean_rg || !s->se_rg || !s->slope_n || !s->slope_df || !s->slope_lo || !s->slope_hi || !w->pick ||
                   !w->mean || !w->df || !w->sl || !w->A || !w->D
               ? -1
               : 0;
}

/* The estimates from all m clusters: mean R_g and its standard error, the
 * D_f fit, the local slopes and the correction-to-scaling fit. */
static void point_estimates(pdla_ens_stats *s, const boot_work *w, const uint64_t *n, size_t k, const double *rg,
                            size_t m)
{
    for (size_t j = 0; j < k; j++) {
        double sum = 0, sq = 0;
        for (size_t i = 0; i < m; i++) sum += rg[i * k + j];
        const double mu = sum / (double)m;
        for (size_t i = 0; i < m; i++) sq += (rg[i * k + j] - mu) * (rg[i * k + j] - mu);
        s->mean_rg[j] = mu;
        s->se_rg[j] = m > 1 ? sqrt(sq / (double)(m - 1) / (double)m) : NAN;
    }
    const pdla_fit f = fit_powerlaw(n, s->mean_rg, k, s->n_lo, s->n_hi);
    s->df = f.df;
    s->prefactor_diam = f.prefactor_diam;
    s->nslope = w->nw;
    for (size_t v = 0; v < w->nw; v++) {
        uint64_t lo, hi;
        slope_range(w->centre[v], &lo, &hi);
        s->slope_n[v] = pow(10.0, w->centre[v]);
        s->slope_df[v] = fit_powerlaw(n, s->mean_rg, k, lo, hi).df;
    }
    s->corr_samples = (int)w->BC;
    /* The correction term describes the approach to scaling: it needs the
     * small clusters the power-law fit leaves out. */
    s->corr_n_lo = CORR_N_LO;
    s->corr_ok = pdla_ens_corr_fit(n, s->mean_rg, k, s->corr_n_lo, s->n_hi, &s->corr_A, &s->corr_D, &s->corr_B,
                                   &s->corr_nu, &s->corr_rms) == 0;
    if (!s->corr_ok) s->corr_A = s->corr_D = s->corr_B = s->corr_nu = s->corr_rms = NAN;
}

/* The bootstrap: the resamples are drawn in turn from one stream seeded
 * with boot_seed, so the interval is reproducible. Fills w's samples. */
static void bootstrap(const pdla_ens_stats *s, boot_work *w, const uint64_t *n, size_t k, const double *rg,
                      size_t m, uint64_t boot_seed)
{
    pdla_rng r;
    rng_seed(&r, boot_seed);
    for (size_t b = 0; b < w->B; b++) {
        for (size_t i = 0; i < m; i++) {
            const size_t q = (size_t)(rng_uniform(&r) * (double)m);
            w->pick[i] = q < m ? q : m - 1; /* u * m may round up to m */
        }
        mean_of(rg, k, w->pick, m, w->mean);
        w->df[b] = fit_powerlaw(n, w->mean, k, s->n_lo, s->n_hi).df;
        for (size_t v = 0; v < w->nw; v++) {
            uint64_t lo, hi;
            slope_range(w->centre[v], &lo, &hi);
            w->sl[v * w->B + b] = fit_powerlaw(n, w->mean, k, lo, hi).df;
        }
        if (b < w->BC && s->corr_ok) {
            double a, d, bb, nu, rms;
            if (pdla_ens_corr_fit(n, w->mean, k, s->corr_n_lo, s->n_hi, &a, &d, &bb, &nu, &rms)) a = d = NAN;
            w->A[b] = a;
            w->D[b] = d;
        }
    }
}

/* The 95% intervals from the bootstrap samples. */
static void intervals(pdla_ens_stats *s, boot_work *w)
{
    const size_t B = w->B, BC = w->BC;
    double unused;
    mean_sd(w->df, B, &unused, &s->df_boot_sd);
    s->df_lo = quantile(w->df, B, 0.025);
    s->df_hi = quantile(w->df, B, 0.975);
    for (size_t v = 0; v < w->nw; v++) {
        s->slope_lo[v] = quantile(w->sl + v * B, B, 0.025);
        s->slope_hi[v] = quantile(w->sl + v * B, B, 0.975);
    }
    s->corr_A_lo = s->corr_A_hi = s->corr_D_lo = s->corr_D_hi = NAN;
    if (s->corr_ok && BC) {
        s->corr_A_lo = quantile(w->A, BC, 0.025);
        s->corr_A_hi = quantile(w->A, BC, 0.975);
        s->corr_D_lo = quantile(w->D, BC, 0.025);
        s->corr_D_hi = quantile(w->D, BC, 0.975);
    }
}

int pdla_ens_stats_compute(const uint64_t *n, size_t k, const double *rg, size_t m, const double *df_cluster,
                           uint64_t n_final, int boot_samples, int corr_samples, uint64_t boot_seed,
                           pdla_ens_stats *s, char *err, size_t errlen)
{
    memset(s, 0, sizeof *s);
    if (m < 1 || boot_samples < 0 || boot_samples > 1000000 || corr_samples < 0)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "statistics need at least one cluster and 0..1e6 resamples");
    s->k = k;
    s->slope_window = 2 * SLOPE_HALF;
    s->boot_samples = boot_samples;
    s->boot_seed = boot_seed;
    fit_default_range(n_final, &s->n_lo, &s->n_hi);
    double centre[256];
    boot_work w;
    memset(&w, 0, sizeof w);
    w.nw = slope_windows(CORR_N_LO < s->n_lo ? CORR_N_LO : s->n_lo, n_final, centre, 256);
    w.centre = centre;
    w.B = (size_t)boot_samples;
    w.BC = w.B < (size_t)corr_samples ? w.B : (size_t)corr_samples;
    int rc = PDLA_OK;
    if (stats_alloc(s, &w, m, k)) {
        rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the ensemble statistics");
    } else {
        point_estimates(s, &w, n, k, rg, m);
        bootstrap(s, &w, n, k, rg, m, boot_seed);
        intervals(s, &w);
        s->df_cluster_mean = s->df_cluster_sd = NAN;
        if (df_cluster) mean_sd(df_cluster, m, &s->df_cluster_mean, &s->df_cluster_sd);
    }
    boot_free(&w);
    if (rc) pdla_ens_stats_free(s);
    return rc;
}
