/*
 * stats.h - the statistics the sampling tests judge by: Pearson's chi-square,
 * the two-sample Kolmogorov-Smirnov distance, adaptive Simpson quadrature
 * (for bin probabilities computed from a density, independently of any
 * closed-form CDF) and a binomial z-score. Header-only, test use only.
 *
 * Critical values at p = 0.001, computed from the regularised incomplete
 * gamma function (they agree with published tables):
 *   chi-square, 9 dof: 27.877   24 dof: 51.179   49 dof: 85.351
 *               63 dof: 103.442  99 dof: 148.230
 *   two-sample KS: D > 1.9495 sqrt((n + m) / (n m)); one-sample: D > 1.9495 / sqrt(n).
 */
#ifndef PDLA_TESTS_SAMPLING_STATS_H
#define PDLA_TESTS_SAMPLING_STATS_H
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#define CHI2_CRIT_9 27.877
#define CHI2_CRIT_24 51.179
#define CHI2_CRIT_49 85.351
#define CHI2_CRIT_63 103.442
#define CHI2_CRIT_99 148.230
#define KS_C_001 1.9494746

/* Pearson's statistic for counts against expected probabilities. */
static inline double chi_square(const uint64_t *counts, const double *prob, size_t bins,
                                uint64_t total)
{
    double chi2 = 0.0;
    for (size_t k = 0; k < bins; k++) {
        const double expected = prob[k] * (double)total;
        const double d = (double)counts[k] - expected;
        chi2 += d * d / expected;
    }
    return chi2;
}

/* Pearson's statistic for counts in equiprobable bins. */
static inline double chi_square_flat(const uint64_t *counts, size_t bins, uint64_t total)
{
    const double expected = (double)total / (double)bins;
    double chi2 = 0.0;
    for (size_t k = 0; k < bins; k++) {
        const double d = (double)counts[k] - expected;
        chi2 += d * d / expected;
    }
    return chi2;
}

/* Bin of a probability-integral-transformed value F in [0, 1]. */
static inline size_t pit_bin(double F, size_t bins)
{
    if (!(F > 0.0)) return 0;
    const size_t k = (size_t)(F * (double)bins);
    return k < bins ? k : bins - 1;
}

static inline int cmp_double_(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Two-sample Kolmogorov-Smirnov distance sup |F_a - F_b|; sorts a and b. */
static inline double ks_two_sample(double *a, size_t n, double *b, size_t m)
{
    qsort(a, n, sizeof *a, cmp_double_);
    qsort(b, m, sizeof *b, cmp_double_);
    size_t i = 0, j = 0;
    double d = 0.0;
    while (i < n && j < m) {
        const double x = a[i] <= b[j] ? a[i] : b[j];
        while (i < n && a[i] <= x) i++;
        while (j < m && b[j] <= x) j++;
        const double diff = fabs((double)i / (double)n - (double)j / (double)m);
        if (diff > d) d = diff;
    }
    return d;
}

/* One-sample Kolmogorov-Smirnov distance of probability-integral-transformed
 * values F (uniform on [0, 1] under the tested law) from the uniform law;
 * sorts F. Critical value at p = 0.001: KS_C_001 / sqrt(n) (asymptotic;
 * the tests use n >= 1e5). */
static inline double ks_one_sample(double *F, size_t n)
{
    qsort(F, n, sizeof *F, cmp_double_);
    double d = 0.0;
    for (size_t i = 0; i < n; i++) {
        const double above = (double)(i + 1) / (double)n - F[i], below = F[i] - (double)i / (double)n;
        if (above > d) d = above;
        if (below > d) d = below;
    }
    return d;
}

static inline double ks_critical_001(size_t n, size_t m)
{
    return KS_C_001 * sqrt((double)(n + m) / ((double)n * (double)m));
}

/* z-score of k successes in n trials against success probability p. */
static inline double binomial_z(uint64_t k, uint64_t n, double p)
{
    const double mean = (double)n * p;
    const double sd = sqrt((double)n * p * (1.0 - p));
    return ((double)k - mean) / sd;
}

/* Adaptive Simpson of f over [a, b] to absolute tolerance tol. */
typedef double (*density_fn)(double x, const void *param);

static inline double simpson_step_(density_fn f, const void *param, double a, double b, double fa,
                            double fm, double fb, double whole, double tol, int depth)
{
    const double m = 0.5 * (a + b);
    const double lm = 0.5 * (a + m), rm = 0.5 * (m + b);
    const double flm = f(lm, param), frm = f(rm, param);
    const double left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    const double right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    const double delta = left + right - whole;
    if (depth <= 0 || fabs(delta) <= 15.0 * tol) return left + right + delta / 15.0;
    return simpson_step_(f, param, a, m, fa, flm, fm, left, 0.5 * tol, depth - 1) +
           simpson_step_(f, param, m, b, fm, frm, fb, right, 0.5 * tol, depth - 1);
}

static inline double integrate(density_fn f, const void *param, double a, double b, double tol)
{
    const double fa = f(a, param), fb = f(b, param), fm = f(0.5 * (a + b), param);
    const double whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    return simpson_step_(f, param, a, b, fa, fm, fb, whole, tol, 50);
}
#endif
