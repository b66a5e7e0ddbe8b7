/*
 * test_sample.c - goodness of fit of every sampler in src/dla/sample.c against
 * its exact law, each with a fixed seed and a p = 0.001 critical value
 * (stats.h), and each with a negative control: the same statistic on a
 * slightly wrong law must exceed the critical value, so the test can fail.
 *
 * Binning: 50 equiprobable bins under the tested law (the sample's CDF value
 * F picks bin floor(50 F)), 49 dof, critical chi-square 85.351. The expected
 * bin probabilities are not taken from the closed-form CDF but integrated
 * numerically from the harmonic-measure density (the Poisson kernel), so the
 * CDF formulas are checked too.
 */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "sample.h"
#include "stats.h"

enum { BINS = 50 };

/* ---- 2D return angle: wrapped Cauchy with concentration R/r ------------ */

/* CDF on (-pi, pi] for k = (r - R)/(r + R): 1/2 + atan(tan(theta/2) / k) / pi. */
static double cdf_return2_k(double theta, double k)
{
    return 0.5 + atan(tan(0.5 * theta) / k) / M_PI;
}

static double cdf_return2(double theta, double r, double R)
{
    return cdf_return2_k(theta, (r - R) / (r + R));
}

static double quantile_return2(double p, double r, double R)
{
    if (p <= 0.0) return -M_PI;
    if (p >= 1.0) return M_PI;
    return 2.0 * atan((r - R) / (r + R) * tan(M_PI * (p - 0.5)));
}

typedef struct {
    double r, R;
} radii;

/* The exterior Poisson kernel of the circle, (1/2pi)(1 - q^2)/(1 + q^2 - 2q cos),
 * q = R/r, with the denominator as (1 - q)^2 + 4q sin^2(theta/2): no
 * cancellation when q -> 1. */
static double poisson_kernel2(double theta, const void *param)
{
    const radii *g = param;
    const double q = g->R / g->r, one_minus_q = (g->r - g->R) / g->r;
    const double s = sin(0.5 * theta);
    return (1.0 / (2.0 * M_PI)) * one_minus_q * (1.0 + q) /
           (one_minus_q * one_minus_q + 4.0 * q * s * s);
}

/* The walker's 2D return (sample_return_cs2, no trig; sample_return_angle2
 * is its angle) against the wrapped Cauchy law, 1e6 draws per ratio: binned
 * chi-square (power 0.9 against a relative error of 0.77% in every bin:
 * noncentrality 1e6 x 0.0077^2 = 59) and one-sample KS on the CDF values
 * (critical 1.95e-3; the statistic's noise at a fixed point has sd <= 5e-4,
 * so a CDF error of 0.26% anywhere is rejected with power > 0.9). KS control:
 * the same draws scored against concentration k x 1.02 (a CDF error of up
 * to ~0.32%) must be rejected. */
static void test_return_angle2(void)
{
    const double ratios[] = {1.0 + 1e-6, 1.01, 1.5, 4.0, 100.0, 1e6};
    const int samples = 1000000;
    const double R = 1.0;
    pdla_rng rng;
    rng_seed(&rng, 2001);
    double *theta = malloc(samples * sizeof *theta);
    double *pit = malloc(samples * sizeof *pit);
    for (size_t i = 0; i < sizeof ratios / sizeof ratios[0]; i++) {
        const double r = ratios[i] * R;
        const radii g = {r, R};
        double prob[BINS], worst_cdf_err = 0.0;
        for (int k = 0; k < BINS; k++) {
            const double lo = quantile_return2((double)k / BINS, r, R);
            const double hi = quantile_return2((double)(k + 1) / BINS, r, R);
            prob[k] = integrate(poisson_kernel2, &g, lo, hi, 1e-12);
            worst_cdf_err = fmax(worst_cdf_err, fabs(prob[k] * BINS - 1.0));
        }
        CHECK(worst_cdf_err < 1e-6, "r/R = %g: closed-form CDF off the kernel by %.2e",
              ratios[i], worst_cdf_err);

        uint64_t counts[BINS] = {0};
        int bad = 0;
        for (int n = 0; n < samples; n++) {
            theta[n] = sample_return_angle2(&rng, r, R);
            if (!(theta[n] > -M_PI && theta[n] <= M_PI)) bad++;
            pit[n] = cdf_return2(theta[n], r, R);
            counts[pit_bin(pit[n], BINS)]++;
        }
        const double chi2 = chi_square(counts, prob, BINS, samples);
        const double ks = ks_one_sample(pit, samples), ks_crit = KS_C_001 / sqrt(samples);
        fprintf(stderr, "2D return angle, r/R = %-11.10g chi2 = %6.2f (49 dof, crit 85.35), "
                        "KS D = %.2e (crit %.2e)", ratios[i], chi2, ks, ks_crit);
        CHECK(bad == 0, "r/R = %g: %d angles outside (-pi, pi]", ratios[i], bad);
        CHECK(chi2 < CHI2_CRIT_49, "r/R = %g: chi2 %.2f", ratios[i], chi2);
        CHECK(ks < ks_crit, "r/R = %g: KS D %.2e", ratios[i], ks);

        /* Negative control: the same angles scored against the law for a walker
         * 20% farther from the circle. Too weak to see far out, where the law
         * is nearly uniform, so only near ratios carry it. */
        if (ratios[i] > 1.001 && ratios[i] < 10.0) {
            const double wrong_r = R + 1.2 * (r - R);
            uint64_t wrong[BINS] = {0};
            for (int n = 0; n < samples; n++)
                wrong[pit_bin(cdf_return2(theta[n], wrong_r, R), BINS)]++;
            const double chi2_wrong = chi_square_flat(wrong, BINS, samples);
            fprintf(stderr, "; control (r - R) x 1.2: chi2 = %.1f", chi2_wrong);
            CHECK(chi2_wrong > CHI2_CRIT_49, "r/R = %g: control not rejected (%.2f)",
                  ratios[i], chi2_wrong);
            const double k_wrong = 1.02 * (r - R) / (r + R);
            for (int n = 0; n < samples; n++) pit[n] = cdf_return2_k(theta[n], k_wrong);
            const double ks_wrong = ks_one_sample(pit, samples);
            fprintf(stderr, "; KS control k x 1.02: D = %.2e", ks_wrong);
            CHECK(ks_wrong > ks_crit, "r/R = %g: KS control not rejected (%.2e)", ratios[i],
                  ks_wrong);
        }
        fputc('\n', stderr);
    }
    free(pit);
    free(theta);
}

/* ---- 3D: return probability R/r and cos(theta) given return ------------- */

/* Given return, 1/rho is uniform on [1/(r+R), 1/(r-R)] and rho^2 = r^2 + R^2 -
 * 2 r R cos(theta) = (r-R)^2 + 2 r R (1 - cos), so with x = 1 - cos(theta):
 *   P(cos <= c) = (1/rho - 1/(r+R)) / (1/(r-R) - 1/(r+R)) = (r-R)(r+R-rho) / (2 R rho).
 * Everything is written in x to keep precision near cos = 1. */
static double cdf_cos3(double x, double r, double R)
{
    const double a = r - R, b = r + R;
    const double rho = sqrt(a * a + 2.0 * r * R * x);
    return a * (b - rho) / (2.0 * R * rho);
}

/* x = 1 - cos at CDF value p: rho = ab / (a + 2Rp), x = (rho - a)(rho + a)/(2rR). */
static double quantile_x3(double p, double r, double R)
{
    const double a = r - R, b = r + R;
    const double rho = a * b / (a + 2.0 * R * p);
    return fmin(2.0, (rho - a) * (rho + a) / (2.0 * r * R));
}

/* Density of x = 1 - cos(theta) given return, from the exterior Poisson
 * kernel of the sphere (r^2 - R^2) / (4 pi R rho^3) over the area 2 pi R^2 dx,
 * divided by the return probability R/r. */
static double kernel_x3(double x, const void *param)
{
    const radii *g = param;
    const double a = g->r - g->R, b = g->r + g->R;
    const double rho = sqrt(a * a + 2.0 * g->r * g->R * x);
    return g->r * a * b / (2.0 * rho * rho * rho);
}

static void test_return3_cos(void)
{
    const double ratios[] = {1.0 + 1e-6, 1.01, 1.5, 4.0, 100.0};
    const int returns = 100000;
    const double R = 1.0;
    pdla_rng rng;
    rng_seed(&rng, 3001);
    double *cosv = malloc(returns * sizeof *cosv);
    for (size_t i = 0; i < sizeof ratios / sizeof ratios[0]; i++) {
        const double r = ratios[i] * R;
        const radii g = {r, R};
        double prob[BINS], worst_cdf_err = 0.0;
        for (int k = 0; k < BINS; k++) {
            /* Bin k holds CDF values [k, k+1)/BINS, i.e. x from x(k+1) to x(k). */
            const double x_hi = quantile_x3((double)k / BINS, r, R);
            const double x_lo = quantile_x3((double)(k + 1) / BINS, r, R);
            prob[k] = integrate(kernel_x3, &g, x_lo, x_hi, 1e-12);
            worst_cdf_err = fmax(worst_cdf_err, fabs(prob[k] * BINS - 1.0));
        }
        CHECK(worst_cdf_err < 1e-6, "r/R = %g: closed-form CDF off the kernel by %.2e",
              ratios[i], worst_cdf_err);

        uint64_t counts[BINS] = {0};
        int bad = 0;
        for (int n = 0; n < returns;) {
            double c;
            if (!sample_return3(&rng, r, R, &c)) continue;
            if (!(c >= -1.0 && c <= 1.0)) bad++;
            cosv[n++] = c;
            counts[pit_bin(cdf_cos3(1.0 - c, r, R), BINS)]++;
        }
        const double chi2 = chi_square(counts, prob, BINS, returns);
        fprintf(stderr, "3D cos(theta) | return, r/R = %-11.10g chi2 = %6.2f (49 dof, crit 85.35)",
                ratios[i], chi2);
        CHECK(bad == 0, "r/R = %g: %d cosines outside [-1, 1]", ratios[i], bad);
        CHECK(chi2 < CHI2_CRIT_49, "r/R = %g: chi2 %.2f", ratios[i], chi2);
        if (ratios[i] > 1.001 && ratios[i] < 10.0) {
            const double wrong_r = R + 1.2 * (r - R);
            uint64_t wrong[BINS] = {0};
            for (int n = 0; n < returns; n++)
                wrong[pit_bin(cdf_cos3(1.0 - cosv[n], wrong_r, R), BINS)]++;
            const double chi2_wrong = chi_square_flat(wrong, BINS, returns);
            fprintf(stderr, "; control (r - R) x 1.2: chi2 = %.1f", chi2_wrong);
            CHECK(chi2_wrong > CHI2_CRIT_49, "r/R = %g: control not rejected (%.2f)",
                  ratios[i], chi2_wrong);
        }
        fputc('\n', stderr);
    }
    free(cosv);
}

static void test_return3_fraction(void)
{
    /* 10^6 trials per ratio; binomial |z| < 4 against R/r. */
    const double ratios[] = {1.0 + 1e-6, 1.01, 1.5, 4.0, 100.0, 1e4};
    const uint64_t trials = 1000000;
    pdla_rng rng;
    rng_seed(&rng, 3002);
    for (size_t i = 0; i < sizeof ratios / sizeof ratios[0]; i++) {
        const double R = 3.0, r = ratios[i] * R;
        uint64_t back = 0;
        for (uint64_t t = 0; t < trials; t++) {
            double c;
            back += (uint64_t)sample_return3(&rng, r, R, &c);
        }
        const double z = binomial_z(back, trials, R / r);
        fprintf(stderr, "3D return fraction, r/R = %-11.10g %.6f vs R/r = %.6f, z = %+.2f",
                ratios[i], (double)back / trials, R / r, z);
        CHECK(fabs(z) < 4.0, "r/R = %g: z = %.2f", ratios[i], z);
        if (ratios[i] == 1.5) {
            const double z_wrong = binomial_z(back, trials, R / (1.01 * r));
            fprintf(stderr, "; control R/(1.01 r): z = %+.1f", z_wrong);
            CHECK(fabs(z_wrong) > 4.0, "control not rejected (z = %.2f)", z_wrong);
        }
        fputc('\n', stderr);
    }
}

/* ---- uniform directions ------------------------------------------------ */

static size_t angle_bin(double phi, size_t bins)
{
    return pit_bin((phi + M_PI) / (2.0 * M_PI), bins);
}

static void test_dir2(void)
{
    /* Angle atan2(y, x) in 64 equal bins over (-pi, pi]: 63 dof, crit 103.442. */
    enum { bins = 64 };
    const int samples = 1000000;
    pdla_rng rng;
    rng_seed(&rng, 4001);
    uint64_t counts[bins] = {0}, naive[bins] = {0};
    double worst_norm = 0.0;
    for (int n = 0; n < samples; n++) {
        double v[2];
        sample_dir2(&rng, v);
        worst_norm = fmax(worst_norm, fabs(hypot(v[0], v[1]) - 1.0));
        counts[angle_bin(atan2(v[1], v[0]), bins)]++;
        /* Control: the square normalised without rejection (corners overweighted). */
        const double x = 2.0 * rng_uniform(&rng) - 1.0, y = 2.0 * rng_uniform(&rng) - 1.0;
        naive[angle_bin(atan2(y, x), bins)]++;
    }
    const double chi2 = chi_square_flat(counts, bins, samples);
    const double chi2_naive = chi_square_flat(naive, bins, samples);
    fprintf(stderr, "sample_dir2 angle: chi2 = %.2f (63 dof, crit 103.44); max ||v|-1| = %.1e; "
                    "control (no rejection): chi2 = %.0f\n",
            chi2, worst_norm, chi2_naive);
    CHECK(chi2 < CHI2_CRIT_63, "chi2 %.2f", chi2);
    CHECK(worst_norm < 1e-15, "|v| off 1 by %.2e", worst_norm);
    CHECK(chi2_naive > CHI2_CRIT_63, "control not rejected (%.2f)", chi2_naive);
}

/* The 2D walker's jump (sample_step2): the length is len, and the angle is
 * uniform: 64-bin chi-square (power 0.9 against a relative error of 0.81%
 * in every bin) and one-sample KS on 1e6 angles (critical 1.95e-3; a CDF
 * error of 0.26% is rejected with power > 0.9). The lattice's own error,
 * ~5e-10 (sample.h), is far below what any test can see. Controls: the same
 * angles distorted by phi + 0.02 sin(phi) (a CDF error of 0.32%) must fail
 * KS, and the point of the square without the disk rejection (the angle
 * doubled, corners overweighted) must fail the chi-square. */
static void test_step2(void)
{
    enum { bins = 64 };
    const int samples = 1000000;
    const double len = 1234.5;
    pdla_rng rng;
    rng_seed(&rng, 4003);
    double *pit = malloc(samples * sizeof *pit), *bent = malloc(samples * sizeof *bent);
    uint64_t counts[bins] = {0}, naive[bins] = {0};
    double worst_len = 0.0;
    for (int n = 0; n < samples; n++) {
        double d[2];
        sample_step2(&rng, len, d);
        worst_len = fmax(worst_len, fabs(hypot(d[0], d[1]) / len - 1.0));
        const double phi = atan2(d[1], d[0]);
        pit[n] = (phi + M_PI) / (2.0 * M_PI);
        counts[angle_bin(phi, bins)]++;
        const double wphi = remainder(phi + 0.02 * sin(phi), 2.0 * M_PI);
        bent[n] = (wphi + M_PI) / (2.0 * M_PI);
        const uint64_t z = rng_next(&rng);
        const double x = (double)(int32_t)(uint32_t)(z >> 32), y = (double)(int32_t)(uint32_t)z;
        naive[angle_bin(atan2(2.0 * x * y, x * x - y * y), bins)]++;
    }
    const double chi2 = chi_square_flat(counts, bins, samples);
    const double chi2_naive = chi_square_flat(naive, bins, samples);
    const double ks = ks_one_sample(pit, samples), ks_bent = ks_one_sample(bent, samples);
    const double ks_crit = KS_C_001 / sqrt(samples);
    fprintf(stderr, "sample_step2 angle: chi2 = %.2f (63 dof, crit 103.44), KS D = %.2e (crit %.2e); "
                    "max ||d|/len - 1| = %.1e; controls: bent KS D = %.2e, no rejection chi2 = %.0f\n",
            chi2, ks, ks_crit, worst_len, ks_bent, chi2_naive);
    CHECK(chi2 < CHI2_CRIT_63, "chi2 %.2f", chi2);
    CHECK(ks < ks_crit, "KS D %.2e", ks);
    CHECK(worst_len < 1e-14, "|d| off len by %.2e", worst_len);
    CHECK(ks_bent > ks_crit, "bent control not rejected (%.2e)", ks_bent);
    CHECK(chi2_naive > CHI2_CRIT_63, "no-rejection control not rejected (%.2f)", chi2_naive);
    free(pit);
    free(bent);
}

/* The 3D jump (sample_step3): z = d[2]/len uniform on [-1, 1] (Archimedes),
 * azimuth uniform, independent, |d| = len. Each marginal: 50 equiprobable
 * bins (49 dof, crit 85.35; power 0.9 against a relative error of 0.77% in
 * every bin: noncentrality 1e6 x 0.0077^2 = 59) and a one-sample KS (crit
 * 1.95e-3; the statistic's noise at a fixed point has sd <= 5e-4, so a CDF
 * error of 0.26% anywhere is rejected with power > 0.9); jointly 10 x 10
 * cells (99 dof, crit 148.23). Controls that must fail: z's CDF and the
 * azimuth's bent by 0.0032 sin(2 pi F) (an error of up to 0.32%) under KS,
 * and the square's points without the disk rejection under chi-square. */
static void test_step3(void)
{
    const int samples = 1000000;
    const double len = 1234.5, bend = 0.0032;
    pdla_rng rng;
    rng_seed(&rng, 4004);
    double *fz = malloc(samples * sizeof *fz), *fphi = malloc(samples * sizeof *fphi);
    double *bz = malloc(samples * sizeof *bz), *bphi = malloc(samples * sizeof *bphi);
    uint64_t cz[BINS] = {0}, cphi[BINS] = {0}, joint[100] = {0}, naive[BINS] = {0};
    double worst_len = 0.0;
    for (int n = 0; n < samples; n++) {
        double d[3];
        sample_step3(&rng, len, d);
        worst_len = fmax(worst_len, fabs(sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / len - 1.0));
        const double phi = atan2(d[1], d[0]);
        fz[n] = 0.5 * (d[2] / len + 1.0);
        fphi[n] = (phi + M_PI) / (2.0 * M_PI);
        bz[n] = fz[n] + bend * sin(2.0 * M_PI * fz[n]);
        bphi[n] = fphi[n] + bend * sin(2.0 * M_PI * fphi[n]);
        cz[pit_bin(fz[n], BINS)]++;
        cphi[angle_bin(phi, BINS)]++;
        joint[10 * pit_bin(fz[n], 10) + angle_bin(phi, 10)]++;
        /* Control: Marsaglia's map from the whole square (no rejection;
         * S > 1 clamped to the south pole). */
        const uint64_t w = rng_next(&rng);
        const double x = (double)(int32_t)(uint32_t)(w >> 32) * 0x1.0p-31;
        const double y = (double)(int32_t)(uint32_t)w * 0x1.0p-31;
        naive[pit_bin(0.5 * (fmax(-1.0, 1.0 - 2.0 * (x * x + y * y)) + 1.0), BINS)]++;
    }
    const double chi2_z = chi_square_flat(cz, BINS, samples);
    const double chi2_phi = chi_square_flat(cphi, BINS, samples);
    const double chi2_joint = chi_square_flat(joint, 100, samples);
    const double chi2_naive = chi_square_flat(naive, BINS, samples);
    const double ks_z = ks_one_sample(fz, samples), ks_phi = ks_one_sample(fphi, samples);
    const double ks_bz = ks_one_sample(bz, samples), ks_bphi = ks_one_sample(bphi, samples);
    const double ks_crit = KS_C_001 / sqrt(samples);
    fprintf(stderr, "sample_step3: chi2 z = %.2f, azimuth = %.2f (49 dof, crit 85.35), joint 10x10 = %.2f "
                    "(99 dof, crit 148.23); KS D z = %.2e, azimuth = %.2e (crit %.2e); max ||d|/len - 1| = "
                    "%.1e; controls: bent KS D z = %.2e, azimuth = %.2e, no rejection chi2 z = %.0f\n",
            chi2_z, chi2_phi, chi2_joint, ks_z, ks_phi, ks_crit, worst_len, ks_bz, ks_bphi, chi2_naive);
    CHECK(chi2_z < CHI2_CRIT_49, "z chi2 %.2f", chi2_z);
    CHECK(chi2_phi < CHI2_CRIT_49, "azimuth chi2 %.2f", chi2_phi);
    CHECK(chi2_joint < CHI2_CRIT_99, "joint chi2 %.2f", chi2_joint);
    CHECK(ks_z < ks_crit, "z KS D %.2e", ks_z);
    CHECK(ks_phi < ks_crit, "azimuth KS D %.2e", ks_phi);
    CHECK(worst_len < 1e-14, "|d| off len by %.2e", worst_len);
    CHECK(ks_bz > ks_crit, "bent z control not rejected (%.2e)", ks_bz);
    CHECK(ks_bphi > ks_crit, "bent azimuth control not rejected (%.2e)", ks_bphi);
    CHECK(chi2_naive > CHI2_CRIT_49, "no-rejection control not rejected (%.2f)", chi2_naive);
    free(fz);
    free(fphi);
    free(bz);
    free(bphi);
}

static void test_dir3(void)
{
    /* cos(theta) = z in 50 bins on [-1, 1] and azimuth in 50 bins (49 dof,
     * crit 85.351 each); jointly in 10 x 10 cells (99 dof, crit 148.23). */
    const int samples = 1000000;
    pdla_rng rng;
    rng_seed(&rng, 4002);
    uint64_t cz[BINS] = {0}, cphi[BINS] = {0}, joint[100] = {0}, naive[BINS] = {0};
    double worst_norm = 0.0;
    for (int n = 0; n < samples; n++) {
        double v[3];
        sample_dir3(&rng, v);
        worst_norm = fmax(worst_norm, fabs(sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) - 1.0));
        const double phi = atan2(v[1], v[0]);
        cz[pit_bin(0.5 * (v[2] + 1.0), BINS)]++;
        cphi[angle_bin(phi, BINS)]++;
        joint[10 * pit_bin(0.5 * (v[2] + 1.0), 10) + angle_bin(phi, 10)]++;
        /* Control: the cube normalised without rejection. */
        double w[3], s = 0.0;
        for (int k = 0; k < 3; k++) {
            w[k] = 2.0 * rng_uniform(&rng) - 1.0;
            s += w[k] * w[k];
        }
        naive[pit_bin(0.5 * (w[2] / sqrt(s) + 1.0), BINS)]++;
    }
    const double chi2_z = chi_square_flat(cz, BINS, samples);
    const double chi2_phi = chi_square_flat(cphi, BINS, samples);
    const double chi2_joint = chi_square_flat(joint, 100, samples);
    const double chi2_naive = chi_square_flat(naive, BINS, samples);
    fprintf(stderr, "sample_dir3: chi2 cos = %.2f, azimuth = %.2f (49 dof, crit 85.35), "
                    "joint 10x10 = %.2f (99 dof, crit 148.23); max ||v|-1| = %.1e; "
                    "control (no rejection) cos: chi2 = %.0f\n",
            chi2_z, chi2_phi, chi2_joint, worst_norm, chi2_naive);
    CHECK(chi2_z < CHI2_CRIT_49, "cos chi2 %.2f", chi2_z);
    CHECK(chi2_phi < CHI2_CRIT_49, "azimuth chi2 %.2f", chi2_phi);
    CHECK(chi2_joint < CHI2_CRIT_99, "joint chi2 %.2f", chi2_joint);
    CHECK(worst_norm < 1e-15, "|v| off 1 by %.2e", worst_norm);
    CHECK(chi2_naive > CHI2_CRIT_49, "control not rejected (%.2f)", chi2_naive);
}

/* ---- placing the return point ------------------------------------------ */

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void test_cone_point3(void)
{
    /* For axes including the poles (the seam of naive bases) and random ones:
     * |out| = R and out.u = R cos(theta) to 1e-14 relative, and the azimuth
     * about u, measured in a basis built here by cross products, is uniform
     * (50 bins, crit 85.351). */
    const double s = 1.0 / sqrt(3.0);
    const double axes[][3] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, -1, 0},
                              {s, -s, s}, {0.6, 0.0, -0.8}, {0, 1e-20, -1}};
    const int samples = 100000;
    const double R = 1234.5;
    pdla_rng rng;
    rng_seed(&rng, 5001);
    for (size_t i = 0; i < sizeof axes / sizeof axes[0]; i++) {
        const double *u = axes[i];
        /* e1 = unit(u x a) with a the coordinate axis least aligned with u. */
        const int least = fabs(u[0]) <= fabs(u[1]) && fabs(u[0]) <= fabs(u[2]) ? 0
                          : fabs(u[1]) <= fabs(u[2])                        ? 1
                                                                             : 2;
        const double ax[3] = {least == 0, least == 1, least == 2};
        double e1[3] = {u[1] * ax[2] - u[2] * ax[1], u[2] * ax[0] - u[0] * ax[2],
                        u[0] * ax[1] - u[1] * ax[0]};
        const double n1 = sqrt(dot3(e1, e1));
        for (int k = 0; k < 3; k++) e1[k] /= n1;
        const double e2[3] = {u[1] * e1[2] - u[2] * e1[1], u[2] * e1[0] - u[0] * e1[2],
                              u[0] * e1[1] - u[1] * e1[0]};
        uint64_t counts[BINS] = {0};
        double worst_radius = 0.0, worst_cos = 0.0;
        for (int n = 0; n < samples; n++) {
            const double c = 2.0 * rng_uniform(&rng) - 1.0;
            double out[3];
            sample_cone_point3(&rng, u, R, c, out);
            worst_radius = fmax(worst_radius, fabs(sqrt(dot3(out, out)) / R - 1.0));
            worst_cos = fmax(worst_cos, fabs(dot3(out, u) / R - c));
            counts[angle_bin(atan2(dot3(out, e2), dot3(out, e1)), BINS)]++;
        }
        const double chi2 = chi_square_flat(counts, BINS, samples);
        fprintf(stderr, "cone point, u = (%.3g, %.3g, %.3g): azimuth chi2 = %.2f, "
                        "max radius err %.1e, max cos err %.1e\n",
                u[0], u[1], u[2], chi2, worst_radius, worst_cos);
        CHECK(chi2 < CHI2_CRIT_49, "axis %zu: azimuth chi2 %.2f", i, chi2);
        CHECK(worst_radius < 1e-14, "axis %zu: radius off by %.2e", i, worst_radius);
        CHECK(worst_cos < 1e-14, "axis %zu: cos off by %.2e", i, worst_cos);
    }
    /* cos_theta = +-1 puts the point on the axis exactly. */
    const double u[3] = {0.0, 0.6, 0.8};
    double out[3];
    sample_cone_point3(&rng, u, 2.0, 1.0, out);
    CHECK(fabs(out[0]) < 1e-15 && fabs(out[1] - 1.2) < 1e-15 && fabs(out[2] - 1.6) < 1e-15,
          "cos = 1 gives (%g, %g, %g)", out[0], out[1], out[2]);
    sample_cone_point3(&rng, u, 2.0, -1.0, out);
    CHECK(fabs(out[0]) < 1e-15 && fabs(out[1] + 1.2) < 1e-15 && fabs(out[2] + 1.6) < 1e-15,
          "cos = -1 gives (%g, %g, %g)", out[0], out[1], out[2]);
}

static void test_rotate_to2(void)
{
    double out[2];
    sample_rotate_to2(3.0, 4.0, M_PI / 2, 10.0, out);
    CHECK(fabs(out[0] + 8.0) < 1e-14 && fabs(out[1] - 6.0) < 1e-14, "(3,4) by pi/2 to 10: (%g, %g)",
          out[0], out[1]);
    sample_rotate_to2(-5.0, 0.0, 0.0, 2.0, out);
    CHECK(out[0] == -2.0 && out[1] == 0.0, "(-5,0) by 0 to 2: (%g, %g)", out[0], out[1]);
    /* Far-out points do not overflow in the norm. */
    sample_rotate_to2(1e300, -1e300, M_PI, 1.0, out);
    CHECK(fabs(out[0] + M_SQRT1_2) < 1e-15 && fabs(out[1] - M_SQRT1_2) < 1e-15,
          "huge point: (%g, %g)", out[0], out[1]);
    /* Random points and angles: the radius is R and the turn is theta. */
    pdla_rng rng;
    rng_seed(&rng, 5002);
    double worst = 0.0;
    for (int n = 0; n < 100000; n++) {
        const double x = 1e6 * (2.0 * rng_uniform(&rng) - 1.0);
        const double y = 1e6 * (2.0 * rng_uniform(&rng) - 1.0);
        const double theta = M_PI * (2.0 * rng_uniform(&rng) - 1.0), R = 777.0;
        sample_rotate_to2(x, y, theta, R, out);
        const double turn = remainder(atan2(out[1], out[0]) - atan2(y, x) - theta, 2.0 * M_PI);
        worst = fmax(worst, fmax(fabs(turn), fabs(hypot(out[0], out[1]) / R - 1.0)));
    }
    CHECK(worst < 1e-12, "rotate: worst angle/radius error %.2e", worst);
}

int main(void)
{
    test_return_angle2();
    test_return3_cos();
    test_return3_fraction();
    test_dir2();
    test_step2();
    test_step3();
    test_dir3();
    test_cone_point3();
    test_rotate_to2();
    return check_finish();
}
