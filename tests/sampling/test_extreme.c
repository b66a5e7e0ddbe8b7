/*
 * test_extreme.c - the return samplers at extreme r/R: a walker a hair outside
 * the birth circle (r/R = 1 + 1e-12) up to absurdly far (1e300, and a pair
 * whose ratio is 1e600). Every output must be finite and in range, and the
 * laws must reach their limits: 2D theta -> 0 as r -> R+ and theta uniform as
 * r -> inf; 3D returns with probability R/r, cos(theta) -> 1 as r -> R+.
 * 10^5 draws per case, fixed seeds; tolerances are stated at each check.
 */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "sample.h"
#include "stats.h"

enum { DRAWS = 100000, BINS = 50 };

static double median(double *v, size_t n)
{
    qsort(v, n, sizeof *v, cmp_double_);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* x = 1 - cos(theta) at the CDF value p of cos(theta) given return (see
 * test_sample.c): rho = ab/(a + 2Rp), x = (rho - a)(rho + a) / (2 r R). */
static double quantile_x3(double p, double r, double R)
{
    const double a = r - R, b = r + R;
    const double rho = a * b / (a + 2.0 * R * p);
    return (rho - a) * (rho + a) / (2.0 * r * R);
}

static void check_case(pdla_rng *rng, double r, double R, double *buf)
{
    const double a = r - R; /* exact here: the cases are built so */
    const double ratio = r / R;
    const int near = a / R < 1e-3, far = ratio > 1e5;

    /* ---- 2D ---- */
    int bad = 0;
    uint64_t counts[BINS] = {0};
    size_t tiny = 0;
    for (int n = 0; n < DRAWS; n++) {
        const double theta = sample_return_angle2(rng, r, R);
        if (!(theta > -M_PI && theta <= M_PI)) bad++;
        double out[2];
        sample_rotate_to2(r, 0.0, theta, R, out);
        if (!(isfinite(out[0]) && isfinite(out[1]))) bad++;
        counts[pit_bin((theta + M_PI) / (2.0 * M_PI), BINS)]++;
        tiny += fabs(theta) < 1e-9 * fmax(1.0, 1e12 * a / R);
        buf[n] = fabs(theta);
    }
    CHECK(bad == 0, "r/R = %.17g, R = %g: %d bad 2D outputs", ratio, R, bad);
    /* |theta| = 2 atan(k |tan psi|) with psi uniform, so its median is
     * exactly 2 atan(k), k = (r - R)/(r + R). Tolerance 3%: the median's
     * relative standard error is about 0.5% here. */
    const double k = a / (r + R);
    const double med = median(buf, DRAWS), med_exact = 2.0 * atan(k);
    fprintf(stderr, "r = %-22.17g R = %-6g 2D: median |theta| = %.4e (exact %.4e)", r, R, med,
            med_exact);
    CHECK(fabs(med / med_exact - 1.0) < 0.03, "r/R = %.17g: median |theta| %.4e vs %.4e", ratio,
          med, med_exact);
    if (near) {
        /* theta -> 0: |theta| < 1e-9 (scaled up for the 1e-6 case) except in
         * the Cauchy tail, P(tail) ~ 2(r-R)/(pi R 1e-9) ~ 6e-4 for 1 + 1e-12. */
        const double frac = (double)tiny / DRAWS;
        fprintf(stderr, ", P(|theta| < %.0e) = %.5f", 1e-9 * fmax(1.0, 1e12 * a / R), frac);
        CHECK(frac > 0.99, "r/R = %.17g: only %.4f of angles near 0", ratio, frac);
    }
    if (far) {
        const double chi2 = chi_square_flat(counts, BINS, DRAWS);
        fprintf(stderr, ", uniformity chi2 = %.2f (49 dof, crit 85.35)", chi2);
        CHECK(chi2 < CHI2_CRIT_49, "r/R = %.17g: theta not uniform, chi2 %.2f", ratio, chi2);
    }
    fputc('\n', stderr);

    /* ---- 3D ---- */
    bad = 0;
    uint64_t back = 0;
    size_t at_pole = 0;
    const double u[3] = {0.0, 0.6, -0.8};
    for (int n = 0; n < DRAWS; n++) {
        double c = NAN;
        if (!sample_return3(rng, r, R, &c)) continue;
        if (!(c >= -1.0 && c <= 1.0)) bad++;
        double out[3];
        sample_cone_point3(rng, u, R, c, out);
        const double radius = sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
        if (!(fabs(radius / R - 1.0) < 1e-12)) bad++;
        at_pole += 1.0 - c <= 1e-20;
        buf[back++] = 1.0 - c;
    }
    CHECK(bad == 0, "r/R = %.17g, R = %g: %d bad 3D outputs", ratio, R, bad);
    /* Return count: |k - N q| <= 4 sd + 3 (the +3 covers q (1 - q) N << 1). */
    const double q = R / r;
    const double sd = sqrt(DRAWS * q * (1.0 - q));
    fprintf(stderr, "%46s 3D: returns %llu of %d (expected %.6g)", "", (unsigned long long)back,
            DRAWS, DRAWS * q);
    CHECK(fabs((double)back - DRAWS * q) <= 4.0 * sd + 3.0, "r/R = %.17g: %llu returns, expected %.6g",
          ratio, (unsigned long long)back, DRAWS * q);
    if (near && a / R > 1e-9) {
        /* 1 - cos is resolved in double here (~1e-12 against an ulp of 1e-16):
         * the sample median within 5% of the exact one (its relative standard
         * error is ~1%: 1 - cos ~ (1 - u)/u^2 has log-slope 6 at u = 1/2). */
        const double med3 = median(buf, back), med3_exact = quantile_x3(0.5, r, R);
        fprintf(stderr, ", median 1 - cos = %.4e (exact %.4e)", med3, med3_exact);
        CHECK(fabs(med3 / med3_exact - 1.0) < 0.05, "r/R = %.17g: median 1-cos %.4e vs %.4e",
              ratio, med3, med3_exact);
    } else if (near) {
        /* cos -> 1: for r/R = 1 + 1e-12 the exact CDF puts 1 - cos <= 1e-20
         * in a fraction 0.993 of returns; more read so, as a cos within an
         * ulp of 1 rounds to 1 (an angle below 1.5e-8 is lost that way). */
        const double frac = (double)at_pole / (double)back;
        fprintf(stderr, ", P(1 - cos <= 1e-20) = %.5f", frac);
        CHECK(frac > 0.99, "r/R = %.17g: only %.4f of returns at the pole", ratio, frac);
    }
    fputc('\n', stderr);
}

int main(void)
{
    const double ratios[] = {1.0 + 1e-12, 1.0 + 1e-6, 1e6, 1e12, 1e300};
    const double scales[] = {1e-3, 1.0, 1e3};
    pdla_rng rng;
    rng_seed(&rng, 6001);
    double *buf = malloc(DRAWS * sizeof *buf);
    for (size_t i = 0; i < sizeof ratios / sizeof ratios[0]; i++)
        for (size_t j = 0; j < sizeof scales / sizeof scales[0]; j++)
            check_case(&rng, ratios[i] * scales[j], scales[j], buf);
    /* Beyond: r near the top of the doubles, and R/r underflowing to 0. */
    check_case(&rng, 1e308, 1.0, buf);
    check_case(&rng, 1e300, 1e-300, buf);

    /* r == R (a caller should not send it, but it must be harmless): the
     * walker returns where it is. */
    double c = 0.0;
    CHECK(sample_return_angle2(&rng, 5.0, 5.0) == 0.0, "r == R: theta not 0");
    CHECK(sample_return3(&rng, 5.0, 5.0, &c) == 1 && c == 1.0, "r == R: not returned at the pole");
    free(buf);
    return check_finish();
}
