/*
 * fit.c - fractal dimension from the R_g(N) series: ordinary least squares of
 * y = ln R_g on x = ln N, D_f = 1/slope, with the slope's standard error
 * propagated to D_f to first order (df_err = se(slope) / slope^2).
 */
#include "fit.h"

#include <math.h>

/* A sample takes part when its N is in the range and both logs exist. */
static int usable(uint64_t n, double rg, uint64_t n_lo, uint64_t n_hi)
{
    return n >= n_lo && n <= n_hi && n > 0 && rg > 0.0 && isfinite(rg);
}

pdla_fit fit_powerlaw(const uint64_t *n, const double *rg, size_t count, uint64_t n_lo,
                      uint64_t n_hi)
{
    pdla_fit fit = {.df = NAN, .df_err = NAN, .prefactor_diam = NAN,
                    .n_lo = n_lo, .n_hi = n_hi, .points = 0};

    /* Two passes, means first: the sums of squares are then of centred
     * values, which keeps their precision when ln N spans a narrow range far
     * from zero (e.g. N in [1e9, 1e10]). */
    size_t used = 0;
    double sum_x = 0.0, sum_y = 0.0;
    for (size_t i = 0; i < count; i++) {
        if (!usable(n[i], rg[i], n_lo, n_hi)) continue;
        sum_x += log((double)n[i]);
        sum_y += log(rg[i]);
        used++;
    }
    if (used < 3) return fit;
    const double mean_x = sum_x / (double)used;
    const double mean_y = sum_y / (double)used;

    double sxx = 0.0, sxy = 0.0;
    for (size_t i = 0; i < count; i++) {
        if (!usable(n[i], rg[i], n_lo, n_hi)) continue;
        const double dx = log((double)n[i]) - mean_x;
        const double dy = log(rg[i]) - mean_y;
        sxx += dx * dx;
        sxy += dx * dy;
    }
    /* All samples at one N: the slope is undefined. */
    if (!(sxx > 0.0)) return fit;
    const double slope = sxy / sxx;
    const double intercept = mean_y - slope * mean_x;

    /* Residuals from the fitted line directly, not syy - slope * sxy, which
     * cancels to noise for an almost exact power law. */
    double ssr = 0.0;
    for (size_t i = 0; i < count; i++) {
        if (!usable(n[i], rg[i], n_lo, n_hi)) continue;
        const double e = log(rg[i]) - (intercept + slope * log((double)n[i]));
        ssr += e * e;
    }
    const double slope_err = sqrt(ssr / (double)(used - 2) / sxx);

    /* A slope <= 0 is no fractal; 1/slope then reports it as it is (negative
     * or infinite) rather than hiding it. */
    fit.df = 1.0 / slope;
    fit.df_err = slope_err / (slope * slope);
    fit.prefactor_diam = exp(intercept);
    fit.points = (int)used;
    return fit;
}

uint64_t fit_rg_grid_n(uint64_t k, int per_decade, uint64_t prev)
{
    const double x = pow(10.0, (double)k / per_decade);
    uint64_t n = x >= 0x1p63 ? UINT64_MAX : (uint64_t)llround(x);
    return n > prev ? n : prev + 1;
}

uint64_t fit_rg_grid_at(uint64_t k, int per_decade)
{
    if (per_decade < 1 || k > 20 * (uint64_t)per_decade) return 0;
    uint64_t n = 1;
    for (uint64_t j = 1; j <= k; j++) n = fit_rg_grid_n(j, per_decade, n);
    return n;
}

void fit_default_range(uint64_t n_final, uint64_t *n_lo, uint64_t *n_hi)
{
    uint64_t lo = n_final / 10;
    if (lo > 1000) lo = 1000;
    if (lo < 10) lo = 10;
    *n_lo = lo;
    *n_hi = n_final;
}

/* The public names (pdla.h) of the two functions above, for the tools. */
pdla_fit pdla_fit_powerlaw(const uint64_t *n, const double *rg, size_t count, uint64_t n_lo,
                           uint64_t n_hi)
{
    return fit_powerlaw(n, rg, count, n_lo, n_hi);
}

void pdla_fit_default_range(uint64_t n_final, uint64_t *n_lo, uint64_t *n_hi)
{
    fit_default_range(n_final, n_lo, n_hi);
}
