/*
 * test_fit.c - the D_f fit (src/core/fit.c): exact power laws recovered to 1e-9,
 * a noisy power law recovered within its own error bar, and that error bar
 * checked by its coverage over 1000 noisy replicates; too few points, range
 * filtering and the default range.
 */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "fit.h"
#include "rng.h"

enum { MAX_POINTS = 200 };

/* N = round(10^(k / per_decade)) from 10^lo_decade to 10^hi_decade. */
static size_t log_grid(uint64_t *n, int lo_decade, int hi_decade, int per_decade)
{
    size_t count = 0;
    for (int k = lo_decade * per_decade; k <= hi_decade * per_decade; k++)
        n[count++] = (uint64_t)llround(pow(10.0, (double)k / per_decade));
    return count;
}

static double gaussian(pdla_rng *rng)
{
    /* Box-Muller; the test does not care for speed. */
    const double u = rng_uniform_open(rng), v = rng_uniform(rng);
    return sqrt(-2.0 * log(u)) * cos(2.0 * M_PI * v);
}

static void test_exact(void)
{
    const double dfs[] = {1.71, 2.5};
    const double C = 0.53;
    uint64_t n[MAX_POINTS];
    double rg[MAX_POINTS];
    for (int i = 0; i < 2; i++) {
        const size_t count = log_grid(n, 1, 7, 10);
        for (size_t k = 0; k < count; k++) rg[k] = C * pow((double)n[k], 1.0 / dfs[i]);
        const pdla_fit f = fit_powerlaw(n, rg, count, 10, 10000000);
        fprintf(stderr, "exact D_f = %.2f: fit %.12f +- %.1e, C = %.12f, %d points\n", dfs[i],
                f.df, f.df_err, f.prefactor_diam, f.points);
        CHECK(fabs(f.df - dfs[i]) < 1e-9, "D_f %.12f vs %.2f", f.df, dfs[i]);
        CHECK(f.df_err >= 0.0 && f.df_err < 1e-9, "df_err %.3e of an exact law", f.df_err);
        CHECK(fabs(f.prefactor_diam / C - 1.0) < 1e-9, "C %.12f vs %.2f", f.prefactor_diam, C);
        CHECK(f.points == (int)count, "points %d, expected %zu", f.points, count);
        CHECK(f.n_lo == 10 && f.n_hi == 10000000, "range not echoed");
    }
    /* A narrow range far from N = 1: ln N in [20.7, 23.0]. Naive sums of
     * squares lose ~6 digits here; centred ones do not. */
    const size_t count = log_grid(n, 9, 10, 40);
    for (size_t k = 0; k < count; k++) rg[k] = 0.5 * pow((double)n[k], 1.0 / 1.71);
    const pdla_fit f = fit_powerlaw(n, rg, count, 0, UINT64_MAX);
    CHECK(fabs(f.df - 1.71) < 1e-9 && f.points == (int)count,
          "N in [1e9, 1e10]: D_f %.12f, %d points", f.df, f.points);
}

static void test_noisy(void)
{
    /* ln R_g = ln C + ln N / D_f + sigma xi, xi standard normal. */
    const double df = 1.71, C = 0.5, sigma = 0.02;
    uint64_t n[MAX_POINTS];
    double rg[MAX_POINTS];
    const size_t count = log_grid(n, 2, 8, 10);
    double mean_x = 0.0, sxx = 0.0;
    for (size_t k = 0; k < count; k++) mean_x += log((double)n[k]) / count;
    for (size_t k = 0; k < count; k++) sxx += pow(log((double)n[k]) - mean_x, 2);
    /* The error D_f should report: se(slope) = sigma / sqrt(Sxx), times D_f^2. */
    const double df_err_true = sigma / sqrt(sxx) * df * df;

    pdla_rng rng;
    rng_seed(&rng, 8001);
    const int replicates = 1000;
    int covered = 0;
    double err_sum = 0.0, df_sum = 0.0;
    for (int rep = 0; rep < replicates; rep++) {
        for (size_t k = 0; k < count; k++)
            rg[k] = C * pow((double)n[k], 1.0 / df) * exp(sigma * gaussian(&rng));
        const pdla_fit f = fit_powerlaw(n, rg, count, 100, 100000000);
        if (rep == 0) {
            /* One fit: within 4 of its own error bars, and the bar itself
             * within 30% of the truth (its relative sd is 1/sqrt(2 (n - 2))
             * = 9% for 61 points). */
            fprintf(stderr, "noisy (sigma %.2f, %zu points): D_f = %.5f +- %.5f (true %.2f, "
                            "true error %.5f)\n",
                    sigma, count, f.df, f.df_err, df, df_err_true);
            CHECK(fabs(f.df - df) < 4.0 * f.df_err, "D_f %.5f +- %.5f vs %.2f", f.df, f.df_err, df);
            CHECK(fabs(f.df_err / df_err_true - 1.0) < 0.3, "df_err %.5f vs %.5f", f.df_err,
                  df_err_true);
            CHECK(f.points == (int)count, "points %d", f.points);
        }
        covered += fabs(f.df - df) < f.df_err;
        err_sum += f.df_err;
        df_sum += f.df;
    }
    /* Coverage of the 1-sigma bar: P(|t| < 1) = 0.679 for Student's t with 59
     * dof; binomial sd 0.015 over 1000 replicates, so accept [0.62, 0.74]. */
    const double coverage = (double)covered / replicates;
    const double df_mean = df_sum / replicates;
    fprintf(stderr, "noisy, %d replicates: 1-sigma coverage %.3f (expect 0.679), mean D_f %.5f, "
                    "mean df_err %.5f\n",
            replicates, coverage, df_mean, err_sum / replicates);
    CHECK(coverage > 0.62 && coverage < 0.74, "coverage %.3f", coverage);
    CHECK(fabs(df_mean - df) < 4.0 * df_err_true / sqrt(replicates), "mean D_f %.5f biased",
          df_mean);
}

static void test_too_few(void)
{
    const uint64_t n[] = {10, 100, 1000, 10000, 100000};
    const double rg[] = {1.0, 2.0, 4.0, 8.0, 16.0};
    const double rg_bad[] = {1.0, 0.0, -4.0, NAN, 16.0};
    const uint64_t n_same[] = {500, 500, 500, 500, 500};
    const uint64_t n_zero[] = {0, 0, 0, 10, 100};

    const pdla_fit none = fit_powerlaw(NULL, NULL, 0, 1, 1000);
    CHECK(none.points == 0 && isnan(none.df) && isnan(none.df_err), "empty series");
    const pdla_fit two = fit_powerlaw(n, rg, 2, 1, 1000000);
    CHECK(two.points == 0 && isnan(two.df) && isnan(two.df_err), "two points fitted");
    const pdla_fit three = fit_powerlaw(n, rg, 3, 1, 1000000);
    CHECK(three.points == 3 && isfinite(three.df), "three points not fitted");
    const pdla_fit ranged = fit_powerlaw(n, rg, 5, 50, 5000);
    CHECK(ranged.points == 0 && isnan(ranged.df), "range leaving 2 points fitted");
    const pdla_fit bad = fit_powerlaw(n, rg_bad, 5, 1, 1000000);
    CHECK(bad.points == 0 && isnan(bad.df), "rg <= 0 or NaN used (%d points)", bad.points);
    const pdla_fit same = fit_powerlaw(n_same, rg, 5, 1, 1000000);
    CHECK(same.points == 0 && isnan(same.df), "one N only fitted");
    const pdla_fit zero = fit_powerlaw(n_zero, rg, 5, 0, 1000000);
    CHECK(zero.points == 0 && isnan(zero.df), "N = 0 used (%d points)", zero.points);
}

static void test_range(void)
{
    /* Three regimes, continuous at N = 100 and N = 1e5: D_f = 1.0 below,
     * 1.71 inside, 3.0 above. Only the inside may enter the fit. */
    uint64_t n[MAX_POINTS];
    double rg[MAX_POINTS];
    const size_t count = log_grid(n, 1, 7, 10);
    const double at100 = pow(100.0, 1.0 / 1.71), at1e5 = pow(1e5, 1.0 / 1.71);
    size_t inside = 0;
    for (size_t k = 0; k < count; k++) {
        const double x = (double)n[k];
        if (n[k] < 100)
            rg[k] = at100 * pow(x / 100.0, 1.0 / 1.0);
        else if (n[k] <= 100000)
            rg[k] = pow(x, 1.0 / 1.71);
        else
            rg[k] = at1e5 * pow(x / 1e5, 1.0 / 3.0);
        inside += n[k] >= 100 && n[k] <= 100000;
    }
    const pdla_fit f = fit_powerlaw(n, rg, count, 100, 100000);
    CHECK(fabs(f.df - 1.71) < 1e-9, "range [100, 1e5]: D_f %.12f", f.df);
    CHECK(f.points == (int)inside && inside == 31, "range [100, 1e5]: %d points of %zu", f.points,
          inside);
    CHECK(f.n_lo == 100 && f.n_hi == 100000, "range not echoed");
    /* Both ends are inclusive: moving each in by one drops exactly two. */
    const pdla_fit g = fit_powerlaw(n, rg, count, 101, 99999);
    CHECK(g.points == (int)inside - 2, "range [101, 99999]: %d points", g.points);
    /* The whole series is not a power law: the fit must differ. */
    const pdla_fit all = fit_powerlaw(n, rg, count, 0, UINT64_MAX);
    CHECK(fabs(all.df - 1.71) > 0.01, "unfiltered fit %.4f should differ from 1.71", all.df);
}

static void test_default_range(void)
{
    const struct {
        uint64_t n_final, lo, hi;
    } cases[] = {
        {0, 10, 0},           {50, 10, 50},           {100, 10, 100},
        {150, 15, 150},       {5000, 500, 5000},      {10000, 1000, 10000},
        {1000000, 1000, 1000000}, {UINT64_C(10000000000), 1000, UINT64_C(10000000000)},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        uint64_t lo, hi;
        fit_default_range(cases[i].n_final, &lo, &hi);
        CHECK(lo == cases[i].lo && hi == cases[i].hi,
              "n_final %llu: range [%llu, %llu], expected [%llu, %llu]",
              (unsigned long long)cases[i].n_final, (unsigned long long)lo,
              (unsigned long long)hi, (unsigned long long)cases[i].lo,
              (unsigned long long)cases[i].hi);
    }
}

int main(void)
{
    test_exact();
    test_noisy();
    test_too_few();
    test_range();
    test_default_range();
    return check_finish();
}
