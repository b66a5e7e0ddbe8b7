/*
 * test_physics.c - statistical physics of grown clusters, with fixed seeds
 * and stated tolerances.
 *
 *   test_physics 2 M N   2D ensemble of M clusters of N particles:
 *       D_f fitted on the ensemble-mean R_g(N) over [1e3, N] in [1.66, 1.76];
 *       R_g(n) / n^(1/1.71) within 5% of 0.50 diameters at every sampled
 *       n in [1e4, N] (reference: R_g ~ 0.50 N^0.585 measured on a public
 *       off-lattice code, see the README).
 *   test_physics 3 M N   3D ensemble: D_f in [2.40, 2.60] over [1e3, N].
 *
 *   test_physics 2 M N THREADS SERIAL_UNTIL   PDLA against DLA, M pairs:
 *       each seed grown serially and with THREADS workers after the same
 *       SERIAL_UNTIL serial particles; the mean over the pairs of
 *       ln(R_g PDLA / R_g DLA) is within max(2%, 4.5 standard errors) at the
 *       first sample past 10 SERIAL_UNTIL and at N, and the D_f of the PDLA
 *       ensemble-mean R_g is in [1.66, 1.76]. (A live shared tree with P
 *       walkers is DLA while P/N is small; a frozen snapshot per batch would
 *       drift by percents.)
 *
 *   test_physics pair DIM M N SERIAL_UNTIL THREADS_A REFS_A THREADS_B REFS_B TOL [SEED0]
 *       Paired ensembles (issue 11): M seeds, each grown to SERIAL_UNTIL
 *       serially (the same prefix for both arms), then on to N by arm A and
 *       by arm B, each given as worker threads and reference walkers
 *       (1 0 = serial DLA, P 0 = P workers, 1 P = the race-free reference of
 *       P walkers). The mean over seeds of R_g(A)/R_g(B) - 1 at N must be
 *       within TOL (a fraction), and its standard error at most TOL / 3, so
 *       that a difference of 2 TOL is at least 3 standard errors out: the
 *       ensemble is then large enough that a bias of 2 TOL fails.
 *       An optional last argument SEED0 (default 1001) numbers the seeds
 *       SEED0 .. SEED0 + M - 1, so that an ensemble can be extended with
 *       fresh seeds (the reference arms are deterministic) and pooled from
 *       the sums it prints.
 *
 * The ensemble mean is over clusters at identical sample points (the R_g
 * grid is fixed per decade), seeds 1000 + i.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "fit.h"
#include "pdla/pdla.h"
#include "paired.h"

typedef struct ensemble {
    size_t count;
    uint64_t *grid_n;
    double *mean_rg;
    double df_mean, df_sd;
} ensemble;

static ensemble grow_ensemble(int dim, int clusters, uint64_t n, int threads, uint64_t serial_until)
{
    ensemble out = {0, NULL, NULL, 0, 0};
    size_t count = 0;
    uint64_t *grid_n = NULL;
    double *sum_log_rg = NULL;
    double df_sum = 0, df_sum2 = 0;
    for (int i = 0; i < clusters; i++) {
        pdla_params p;
        pdla_params_default(&p);
        p.dim = dim;
        p.target = n;
        p.threads = threads;
        p.serial_until = serial_until;
        p.seed = 1000 + (uint64_t)i;
        pdla_engine *e;
        char err[256];
        if (pdla_engine_create(&e, &p, err, sizeof err) ||
            pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err)) {
            CHECK(0, "growth failed: %s", err);
            return out;
        }
        const uint64_t *sn;
        const double *srg;
        size_t sc;
        pdla_engine_rg_series(e, &sn, &srg, &sc);
        if (i == 0) {
            count = sc;
            grid_n = malloc(sc * sizeof *grid_n);
            sum_log_rg = calloc(sc, sizeof *sum_log_rg);
            memcpy(grid_n, sn, sc * sizeof *grid_n);
        }
        CHECK(sc == count, "cluster %d has %zu samples, cluster 0 has %zu", i, sc, count);
        for (size_t k = 0; k < count && k < sc; k++) {
            CHECK(sn[k] == grid_n[k], "sample grids differ");
            sum_log_rg[k] += log(srg[k]);
        }
        const pdla_fit f = pdla_engine_fit(e);
        df_sum += f.df;
        df_sum2 += f.df * f.df;
        pdla_engine_destroy(e);
    }
    double *mean_rg = malloc(count * sizeof *mean_rg);
    for (size_t k = 0; k < count; k++) {
        mean_rg[k] = exp(sum_log_rg[k] / clusters);
    }
    free(sum_log_rg);
    out.count = count;
    out.grid_n = grid_n;
    out.mean_rg = mean_rg;
    out.df_mean = df_sum / clusters;
    out.df_sd = sqrt(fmax(0, df_sum2 / clusters - out.df_mean * out.df_mean));
    return out;
}

/* One growth of the PDLA-against-DLA comparison: its R_g series (ln R_g
 * at the fixed sample points, in ln_rg[0..count)), and its stats. */
static size_t grow_series(uint64_t n, int threads, uint64_t serial_until, uint64_t seed,
                          uint64_t *grid_n, double *ln_rg, size_t cap, pdla_stats *st)
{
    pdla_params p, defaults;
    grow_params(&p, 2, n, threads, serial_until, seed);
    pdla_params_default(&defaults);
    p.rg_per_decade = defaults.rg_per_decade; /* the series is what is compared */
    pdla_engine *e;
    char err[256];
    if (pdla_engine_create(&e, &p, err, sizeof err) ||
        pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err)) {
        CHECK(0, "growth failed: %s", err);
        return 0;
    }
    const uint64_t *sn;
    const double *srg;
    size_t sc;
    pdla_engine_rg_series(e, &sn, &srg, &sc);
    CHECK(sc <= cap, "%zu R_g samples, room for %zu", sc, cap);
    const size_t count = sc < cap ? sc : cap;
    for (size_t k = 0; k < count; k++) {
        grid_n[k] = sn[k];
        ln_rg[k] = log(srg[k]);
    }
    pdla_engine_stats(e, st);
    pdla_engine_destroy(e);
    return count;
}

/* PDLA against DLA, paired by seed: seed 1000 + i grows the same serial
 * prefix (SERIAL_UNTIL) and then on to N serially and with THREADS
 * workers; the statistic at a sample point is the mean over seeds of
 * ln(R_g PDLA / R_g DLA), its standard error from the pairs' spread.
 * Checked at the first sample past 10 SERIAL_UNTIL and at N.
 *
 * This is the coarse guard (a PDLA phase that grows another law: a frozen
 * snapshot per batch, lost or doubled particles, a broken re-check would
 * move R_g by percents); the 0.1% questions of issue 11 are the paired
 * tests pdla-one-cpu-2e4 (fast) and the slow suite's. Tolerance: 2%, or
 * 4.5 standard errors where the pairs are too few to resolve 2% (so a
 * correct engine fails with probability ~1e-5 per check: the test runs in
 * every CI, in the release and the TSan build). With 32 pairs of 3e4 after
 * 2e3 (pair sd ~2.7%, se ~0.48%) the tolerance is 2.2%. A failure prints the
 * straggler relaunches and lags, so the regime that made it can be read. */
static int compare_pdla(int pairs, uint64_t n, int threads, uint64_t serial_until)
{
    enum { CAP = 4096 }; /* R_g samples: 100 a decade by default */
    static uint64_t grid_d[CAP], grid_p[CAP];
    static double ln_d[CAP], ln_p[CAP], sum[CAP], sum2[CAP], sum_ln_p[CAP], mean_rg[CAP];
    size_t count = 0;
    uint64_t relaunches = 0, lag_n = 0, lag_sum = 0, lag0 = 0;
    for (int i = 0; i < pairs; i++) {
        const uint64_t seed = 1000 + (uint64_t)i;
        pdla_stats sd, sp;
        const size_t cd = grow_series(n, 1, serial_until, seed, grid_d, ln_d, CAP, &sd);
        const size_t cp = grow_series(n, threads, serial_until, seed, grid_p, ln_p, CAP, &sp);
        CHECK(cd > 0 && cd == cp && !memcmp(grid_d, grid_p, cd * sizeof *grid_d),
              "seed %llu: sample grids differ (%zu and %zu points)", (unsigned long long)seed, cd, cp);
        if (!cd || cd != cp || (count && cd != count)) return check_finish();
        count = cd;
        for (size_t k = 0; k < count; k++) {
            const double d = ln_p[k] - ln_d[k];
            sum[k] += d;
            sum2[k] += d * d;
            sum_ln_p[k] += ln_p[k];
        }
        relaunches += sp.relaunches;
        lag_n += sp.lag_n;
        lag_sum += sp.lag_sum;
        lag0 += sp.lag_hist[0];
    }
    double worst = 0;
    for (size_t k = 0; k < count; k++) {
        const uint64_t at = grid_d[k];
        const int last = k + 1 == count;
        if (!last && !(at >= 10 * serial_until && (k == 0 || grid_d[k - 1] < 10 * serial_until)))
            continue;
        const pair_stat st = pair_stat_of(sum[k], sum2[k], pairs);
        const double tol = fmax(0.02, 4.5 * st.se);
        if (fabs(st.mean) > fabs(worst)) worst = st.mean;
        fprintf(stderr, "N = %llu: ln(R_g PDLA / R_g DLA), mean of %d pairs = %+.3f%% +- %.3f%% "
                        "(pair sd %.2f%%, tolerance %.2f%%)\n",
                (unsigned long long)at, pairs, 100 * st.mean, 100 * st.se, 100 * st.sd, 100 * tol);
        CHECK(fabs(st.mean) <= tol, "PDLA R_g differs from DLA by %+.2f%% at N = %llu (tolerance %.2f%%)",
              100 * st.mean, (unsigned long long)at, 100 * tol);
    }
    for (size_t k = 0; k < count; k++) mean_rg[k] = exp(sum_ln_p[k] / pairs);
    const pdla_fit f = fit_powerlaw(grid_d, mean_rg, count, 1000, n);
    fprintf(stderr, "%d pairs of %llu, %d threads after %llu: largest R_g deviation from DLA "
                    "%+.2f%%; PDLA D_f = %.4f; per PDLA run %.0f straggler relaunches, lag mean %.2f, "
                    "%.1f%% of particles with lag 0\n",
            pairs, (unsigned long long)n, threads, (unsigned long long)serial_until, 100 * worst,
            f.df, (double)relaunches / pairs, lag_n ? (double)lag_sum / (double)lag_n : 0,
            lag_n ? 100.0 * (double)lag0 / (double)lag_n : 100.0);
    CHECK(f.df >= 1.66 && f.df <= 1.76, "PDLA D_f %.4f outside [1.66, 1.76]", f.df);
    return check_finish();
}

/* The lag of a run's PDLA phase (particles appended by the others while a
 * walker was in flight): its mean and the fraction of particles with lag 0. */
typedef struct lag_stat {
    double mean, zero;
} lag_stat;

static double grow_rg(int dim, uint64_t n, uint64_t serial_until, int threads, int refs,
                      uint64_t seed, lag_stat *lag)
{
    pdla_params p;
    grow_params(&p, dim, n, threads, serial_until, seed);
    p.reference_walkers = refs;
    pdla_engine *e;
    char err[256];
    if (pdla_engine_create(&e, &p, err, sizeof err) ||
        pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err)) {
        CHECK(0, "growth failed: %s", err);
        return NAN;
    }
    pdla_stats s;
    pdla_engine_stats(e, &s);
    pdla_engine_destroy(e);
    lag->mean = s.lag_n ? (double)s.lag_sum / (double)s.lag_n : 0;
    lag->zero = s.lag_n ? (double)s.lag_hist[0] / (double)s.lag_n : 1;
    return s.rg_diam;
}

static int compare_pairs(char **a, uint64_t seed0)
{
    const int dim = atoi(a[0]), m = atoi(a[1]);
    const uint64_t n = (uint64_t)atof(a[2]), serial_until = (uint64_t)atof(a[3]);
    const int ta = atoi(a[4]), ra = atoi(a[5]), tb = atoi(a[6]), rb = atoi(a[7]);
    const double tol = atof(a[8]);
    double sum = 0, sum2 = 0, zero_a = 0, zero_b = 0, lag_a = 0, lag_b = 0;
    for (int i = 0; i < m; i++) {
        const uint64_t seed = seed0 + (uint64_t)i;
        lag_stat la, lb;
        const double d = grow_rg(dim, n, serial_until, ta, ra, seed, &la) /
                             grow_rg(dim, n, serial_until, tb, rb, seed, &lb) -
                         1;
        sum += d;
        sum2 += d * d;
        zero_a += la.zero / m;
        zero_b += lb.zero / m;
        lag_a += la.mean / m;
        lag_b += lb.mean / m;
    }
    const pair_stat st = pair_stat_of(sum, sum2, m);
    const double mean = st.mean, sd = st.sd, se = st.se;
    fprintf(stderr,
            "%dD, %d pairs (seeds %llu..%llu) of %llu after %llu serial: R_g(threads %d, "
            "reference %d) / R_g(threads %d, reference %d) - 1 = %+.3f%% +- %.3f%% (pair sd "
            "%.2f%%; tolerance %.3f%%; sums %.17g %.17g)\n",
            dim, m, (unsigned long long)seed0, (unsigned long long)(seed0 + (uint64_t)m - 1),
            (unsigned long long)n, (unsigned long long)serial_until, ta, ra, tb, rb, 100 * mean,
            100 * se, 100 * sd, 100 * tol, sum, sum2);
    fprintf(stderr, "lag (particles appended while a walker flew): arm A mean %.2f, %.2f%% of "
                    "particles with lag 0; arm B mean %.2f, %.2f%% with lag 0\n",
            lag_a, 100 * zero_a, lag_b, 100 * zero_b);
    /* Workers are P walkers in flight at once only if they run at once: on
     * fewer free cores than workers, most walks run alone (lag 0) and a few
     * are frozen for thousands of particles (tests/physics/test_lockstep.c
     * shows that the interleaving is the only difference from the
     * reference). Comparing them with the reference then measures the
     * machine, not the engine: skip, saying so. */
    if (ta > 1 && rb == ta && zero_a > zero_b + 0.10) {
        fprintf(stderr, "SKIP: the %d workers did not run concurrently (%.1f%% of walks saw no "
                        "other stick, the reference's %.1f%%): this comparison needs %d free cores\n",
                ta, 100 * zero_a, 100 * zero_b, ta);
        return 77;
    }
    pair_check(st, tol);
    return check_finish();
}

int main(int argc, char **argv)
{
    if ((argc == 11 || argc == 12) && !strcmp(argv[1], "pair")) {
        const uint64_t seed0 = argc == 12 ? strtoull(argv[11], NULL, 10) : 1001;
        if (seed0 == 0) {
            fprintf(stderr, "test_physics pair: SEED0 must be a positive integer\n");
            return 2;
        }
        return compare_pairs(argv + 2, seed0);
    }
    if (argc != 4 && argc != 6) {
        fprintf(stderr, "usage: test_physics DIM CLUSTERS N [THREADS SERIAL_UNTIL]\n"
                        "       test_physics pair DIM M N SERIAL_UNTIL THREADS_A REFS_A THREADS_B "
                        "REFS_B TOL [SEED0]\n");
        return 2;
    }
    const int dim = atoi(argv[1]);
    const int clusters = atoi(argv[2]);
    const uint64_t n = (uint64_t)atof(argv[3]);
    if (argc == 6) return compare_pdla(clusters, n, atoi(argv[4]), (uint64_t)atof(argv[5]));
    const ensemble ens = grow_ensemble(dim, clusters, n, 1, UINT64_MAX);
    const size_t count = ens.count;
    const uint64_t *grid_n = ens.grid_n;
    double *mean_rg = ens.mean_rg;
    if (!count) return check_finish();
    const pdla_fit f = fit_powerlaw(grid_n, mean_rg, count, 1000, n);
    const double df_mean = ens.df_mean, df_sd = ens.df_sd;
    fprintf(stderr, "dim %d, %d clusters of %llu: D_f(ensemble R_g) = %.4f +- %.4f, "
                    "mean of per-cluster D_f = %.4f (sd %.4f)\n",
            dim, clusters, (unsigned long long)n, f.df, f.df_err, df_mean, df_sd);
    if (dim == 2) {
        CHECK(f.df >= 1.66 && f.df <= 1.76, "2D D_f %.4f outside [1.66, 1.76]", f.df);
        double worst = 0.50;
        for (size_t k = 0; k < count; k++) {
            if (grid_n[k] < 10000) continue;
            const double c = mean_rg[k] / pow((double)grid_n[k], 1.0 / 1.71);
            if (fabs(c / 0.50 - 1) > fabs(worst / 0.50 - 1)) worst = c;
            CHECK(fabs(c / 0.50 - 1) <= 0.05, "R_g/N^(1/1.71) = %.4f at N = %llu, not within 5%% of 0.50",
                  c, (unsigned long long)grid_n[k]);
        }
        fprintf(stderr, "R_g/N^(1/1.71) furthest from 0.50 over [1e4, N]: %.4f\n", worst);
    } else {
        CHECK(f.df >= 2.40 && f.df <= 2.60, "3D D_f %.4f outside [2.40, 2.60]", f.df);
    }
    free(ens.grid_n);
    free(mean_rg);
    return check_finish();
}
