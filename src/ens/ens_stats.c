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

/* The correction term must stay a correction: |B N^-nu| <= CORR_B_CAP at
 * every N fitted. Without it the least squares wandered to B ~ 90, where
 * ln(1 + B N^-nu) ~ ln B - nu ln N takes over the power law (12 clusters of
 * 3000: D = 1.19 with 13% less SSR than D = 1.70 at the profile's local
 * minimum, which the fit then reported as if it were the global one). */
#define CORR_B_CAP 0.9
#define CORR_B_GRID 12   /* intervals of the grid over B before refining */
#define CORR_NU_GRID 36  /* intervals of the grid over nu in [0.2, 2] */
#define CORR_REFINE 32   /* golden-section steps: brackets shrink by 0.618^32 = 2e-7 */

typedef struct corr_data {
    const double *x, *ly; /* ln N, ln R_g */
    double *z, *r;        /* N^-nu at the current nu; scratch residuals */
    size_t k;
} corr_data;

/* SSR of ln y = a + s x + ln(1 + B z) at fixed nu (z) and B, with a and s
 * by linear least squares (exact); p = {a, s, B}. */
static double corr_at_b(const corr_data *c, double B, double p[3])
{
    double sx = 0, sxx = 0, sr = 0, sxr = 0;
    const double n = (double)c->k;
    for (size_t i = 0; i < c->k; i++) {
        const double r = c->ly[i] - log1p(B * c->z[i]);
        c->r[i] = r;
        sx += c->x[i], sxx += c->x[i] * c->x[i], sr += r, sxr += c->x[i] * r;
    }
    const double det = n * sxx - sx * sx;
    if (!(det > 0)) return INFINITY;
    p[1] = (n * sxr - sx * sr) / det;
    p[0] = (sr - p[1] * sx) / n;
    p[2] = B;
    double ssr = 0; /* a second pass: no cancellation at rms 1e-9 */
    for (size_t i = 0; i < c->k; i++) {
        const double e = c->r[i] - p[0] - p[1] * c->x[i];
        ssr += e * e;
    }
    return ssr;
}

/* Minimise f over [lo, hi]: a grid of `grid` intervals, then golden
 * section between the best point's neighbours. f(t, p) fills p. */
typedef double (*corr_fn)(const corr_data *c, double t, double p[3]);

static double corr_min1(const corr_data *c, corr_fn f, double lo, double hi, int grid, double *tb,
                        double bp[3])
{
    double best = INFINITY, p[3];
    *tb = lo;
    for (int j = 0; j <= grid; j++) {
        const double t = lo + (hi - lo) * j / grid, v = f(c, t, p);
        if (v < best) best = v, *tb = t, memcpy(bp, p, sizeof p);
    }
    if (!isfinite(best)) return best;
    /* Golden section: one new point a step, the other kept from the step
     * before (half the evaluations of two fresh points). */
    const double h = (hi - lo) / grid, gr = 0.5 * (sqrt(5.0) - 1.0);
    double a = *tb - h > lo ? *tb - h : lo, b = *tb + h < hi ? *tb + h : hi;
    double u = b - gr * (b - a), w = a + gr * (b - a), pu[3], pw[3];
    double fu = f(c, u, pu), fw = f(c, w, pw);
    for (int it = 0; it < CORR_REFINE; it++) {
        if (fu < best) best = fu, *tb = u, memcpy(bp, pu, sizeof pu);
        if (fw < best) best = fw, *tb = w, memcpy(bp, pw, sizeof pw);
        if (fu < fw) { /* the minimum lies in [a, w]: w <- u, a new u */
            b = w, w = u, fw = fu, memcpy(pw, pu, sizeof pu);
            u = b - gr * (b - a);
            fu = f(c, u, pu);
        } else {       /* in [u, b]: u <- w, a new w */
            a = u, u = w, fu = fw, memcpy(pu, pw, sizeof pw);
            w = a + gr * (b - a);
            fw = f(c, w, pw);
        }
    }
    if (fu < best) best = fu, *tb = u, memcpy(bp, pu, sizeof pu);
    if (fw < best) best = fw, *tb = w, memcpy(bp, pw, sizeof pw);
    return best;
}

/* The best (a, s, B) at fixed nu, B within the cap. */
static double corr_at_nu(const corr_data *c, double nu, double p[3])
{
    double zmax = 0; /* the largest z (the smallest N): it bounds B */
    for (size_t i = 0; i < c->k; i++) {
        c->z[i] = exp(-nu * c->x[i]);
        if (c->z[i] > zmax) zmax = c->z[i];
    }
    const double bmax = CORR_B_CAP / zmax;
    double B;
    return corr_min1(c, corr_at_b, -bmax, bmax, CORR_B_GRID, &B, p);
}

int pdla_ens_corr_fit(const uint64_t *n, const double *y, size_t k, uint64_t n_lo, uint64_t n_hi, double *A,
                      double *D, double *B, double *nu, double *rms)
{
    const size_t sz = (k ? k : 1) * sizeof(double);
    double *x = malloc(sz), *ly = malloc(sz), *z = malloc(sz), *r = malloc(sz);
    size_t used = 0;
    for (size_t i = 0; x && ly && z && r && i < k; i++)
        if (n[i] >= n_lo && n[i] <= n_hi && n[i] > 0 && y[i] > 0 && isfinite(y[i])) {
            x[used] = log((double)n[i]);
            ly[used++] = log(y[i]);
        }
    int rc = -1;
    if (used >= 5) {
        /* nu profiled on a grid, then refined; B likewise at each nu. */
        const corr_data c = {x, ly, z, r, used};
        double bp[3] = {0, 0, 0}, bnu;
        const double best = corr_min1(&c, corr_at_nu, 0.2, 2.0, CORR_NU_GRID, &bnu, bp);
        if (isfinite(best)) {
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
    free(r);
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
    /* The correction's largest size is at the smallest N fitted (the first
     * grid point at or above corr_n_lo, which need not be 30). */
    s->corr_max = NAN;
    for (size_t i = 0; s->corr_ok && i < k; i++)
        if (n[i] >= s->corr_n_lo && n[i] <= s->n_hi && s->mean_rg[i] > 0 && isfinite(s->mean_rg[i])) {
            s->corr_max = fabs(s->corr_B) * pow((double)n[i], -s->corr_nu);
            break;
        }
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

/* One cluster: every resample of it is that cluster, so a bootstrap over
 * clusters says nothing about the scatter between clusters and its
 * intervals would have zero width. None is given: NaN, like se_rg and the
 * per-cluster sd. */
static void no_intervals(pdla_ens_stats *s, const boot_work *w)
{
    s->df_lo = s->df_hi = s->df_boot_sd = NAN;
    for (size_t v = 0; v < w->nw; v++) s->slope_lo[v] = s->slope_hi[v] = NAN;
    s->corr_A_lo = s->corr_A_hi = s->corr_D_lo = s->corr_D_hi = NAN;
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
        if (m > 1) {
            bootstrap(s, &w, n, k, rg, m, boot_seed);
            intervals(s, &w);
        } else {
            no_intervals(s, &w);
        }
        s->df_cluster_mean = s->df_cluster_sd = NAN;
        if (df_cluster) mean_sd(df_cluster, m, &s->df_cluster_mean, &s->df_cluster_sd);
    }
    boot_free(&w);
    if (rc) pdla_ens_stats_free(s);
    return rc;
}
