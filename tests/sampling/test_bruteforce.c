/*
 * test_bruteforce.c - the return laws of src/dla/sample.c against Brownian motion
 * itself, with none of their formulas: walkers started at radius r are moved
 * by walk-on-spheres in free space (from a point at distance d from the
 * circle/sphere of radius R, Brownian motion first leaves the ball of radius d
 * around it at a uniform point; trig and libm here, not sample_dir*), until
 * they come within EPS R of the target or pass KILL R.
 *
 * Approximations and the allowance they get:
 *  - a walker stopped within EPS R is read as hitting at its own direction:
 *    its true hitting point is a Cauchy-like spread of scale ~EPS around it,
 *    which moves E[cos] by at most ~EPS, and in 3D it might still escape
 *    (probability <= EPS);
 *  - past KILL R, a 2D walker's return point is drawn uniformly (the exterior
 *    harmonic measure seen from distance rho is uniform to within a density
 *    factor 1 +- 2R/rho), and a 3D walker is counted lost (it would return
 *    with probability R/rho <= 1/KILL).
 * With EPS = 1e-6 and KILL = 1e6 both are below 3e-6 in any mean or
 * probability, far below the statistical errors (~1e-3).
 *
 * Comparisons, two-sample, brute force against sampler (same count each):
 *   two-sample Kolmogorov-Smirnov on theta (2D) or on cos(theta) given
 *   return (3D), at p = 0.001; mean cos(theta) and the 3D return fraction
 *   within 4 combined standard errors + 3e-6 (4, not 3: some 20 such checks
 *   run, and at 3 one of them would fail by chance once in 20 seeds).
 *   The brute force is also held to the exact means, which follow from the
 *   exterior harmonic extension of cos(theta) alone: 2D E[cos] = R/r,
 *   3D P(return) = R/r and E[cos | return] = R/r (the extension of cos is
 *   (R/rho)^2 cos in 3D, giving E[cos; return] = (R/r)^2).
 *   Negative control: the sampler at a walker 20% farther from the target
 *   (r - R scaled by 1.2) must be rejected by the KS test at r/R = 1.5.
 *
 * Usage: test_bruteforce [walkers per ratio] (default 50000; the 'slow'
 * suite runs 10^6).
 */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "sample.h"
#include "stats.h"

#define EPS 1e-6
#define KILL 1e6
#define ALLOWANCE 3e-6
#define Z_MAX 4.0

/* Brute-force 2D: the signed angle, seen from the origin, between the start
 * (r, 0) and the hitting point on the circle of radius R. */
static double brute_return2(pdla_rng *rng, double r, double R, uint64_t *steps)
{
    double x = r, y = 0.0;
    for (;;) {
        const double rho = hypot(x, y);
        const double d = rho - R;
        if (d < EPS * R) return atan2(y, x);
        if (rho > KILL * R) return M_PI * (2.0 * rng_uniform_open(rng) - 1.0);
        const double phi = 2.0 * M_PI * rng_uniform(rng);
        x += d * cos(phi);
        y += d * sin(phi);
        (*steps)++;
    }
}

/* Brute-force 3D from (0, 0, r): 1 and *cos_theta on hitting the sphere of
 * radius R, 0 when the walker escapes past KILL R. */
static int brute_return3(pdla_rng *rng, double r, double R, double *cos_theta, uint64_t *steps)
{
    double p[3] = {0.0, 0.0, r};
    for (;;) {
        const double rho = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        const double d = rho - R;
        if (d < EPS * R) {
            *cos_theta = p[2] / rho;
            return 1;
        }
        if (rho > KILL * R) return 0;
        /* Uniform on the sphere: z uniform on [-1, 1] (Archimedes), azimuth uniform. */
        const double z = 2.0 * rng_uniform(rng) - 1.0;
        const double phi = 2.0 * M_PI * rng_uniform(rng);
        const double s = sqrt(1.0 - z * z);
        p[0] += d * s * cos(phi);
        p[1] += d * s * sin(phi);
        p[2] += d * z;
        (*steps)++;
    }
}

typedef struct {
    double mean, se;
} mean_se;

static mean_se mean_cos(const double *v, size_t n, int values_are_angles)
{
    double s = 0.0, s2 = 0.0;
    for (size_t i = 0; i < n; i++) {
        const double c = values_are_angles ? cos(v[i]) : v[i];
        s += c;
        s2 += c * c;
    }
    const double m = s / (double)n;
    const mean_se out = {m, sqrt(fmax(0.0, s2 / (double)n - m * m) / (double)n)};
    return out;
}

static void test_2d(size_t walkers)
{
    const double ratios[] = {1.01, 1.5, 4.0, 100.0};
    const double R = 1.0;
    pdla_rng rng;
    rng_seed(&rng, 7001);
    double *brute = malloc(walkers * sizeof *brute);
    double *fast = malloc(walkers * sizeof *fast);
    for (size_t i = 0; i < sizeof ratios / sizeof ratios[0]; i++) {
        const double r = ratios[i] * R;
        uint64_t steps = 0;
        for (size_t n = 0; n < walkers; n++) brute[n] = brute_return2(&rng, r, R, &steps);
        for (size_t n = 0; n < walkers; n++) fast[n] = sample_return_angle2(&rng, r, R);
        const mean_se mb = mean_cos(brute, walkers, 1), mf = mean_cos(fast, walkers, 1);
        const double se = hypot(mb.se, mf.se);
        const double ks = ks_two_sample(brute, walkers, fast, walkers);
        const double ks_crit = ks_critical_001(walkers, walkers);
        fprintf(stderr, "2D r/R = %-5g (%.1f steps/walker): <cos> brute %.5f, sampler %.5f "
                        "(exact %.5f), diff/se = %+.2f; KS D = %.4f (crit %.4f)",
                ratios[i], (double)steps / walkers, mb.mean, mf.mean, R / r,
                (mb.mean - mf.mean) / se, ks, ks_crit);
        CHECK(fabs(mb.mean - mf.mean) < Z_MAX * se + ALLOWANCE, "2D r/R = %g: <cos> %.5f vs %.5f",
              ratios[i], mb.mean, mf.mean);
        CHECK(fabs(mb.mean - R / r) < Z_MAX * mb.se + ALLOWANCE,
              "2D r/R = %g: brute-force <cos> %.5f vs exact %.5f", ratios[i], mb.mean, R / r);
        CHECK(ks < ks_crit, "2D r/R = %g: KS D = %.4f >= %.4f", ratios[i], ks, ks_crit);
        if (ratios[i] == 1.5) {
            const double wrong_r = R + 1.2 * (r - R);
            for (size_t n = 0; n < walkers; n++) fast[n] = sample_return_angle2(&rng, wrong_r, R);
            const double ks_wrong = ks_two_sample(brute, walkers, fast, walkers);
            fprintf(stderr, "; control: KS D = %.4f", ks_wrong);
            CHECK(ks_wrong > ks_crit, "2D control not rejected: KS D = %.4f", ks_wrong);
        }
        fputc('\n', stderr);
    }
    free(brute);
    free(fast);
}

/* Run `trials` walkers of one kind; fills cosines of the returns, gives their count. */
static size_t run3(pdla_rng *rng, int use_brute, double r, double R, size_t trials,
                   double *cos_out, uint64_t *steps)
{
    size_t back = 0;
    for (size_t n = 0; n < trials; n++) {
        double c;
        const int returned = use_brute ? brute_return3(rng, r, R, &c, steps)
                                       : sample_return3(rng, r, R, &c);
        if (returned) cos_out[back++] = c;
    }
    return back;
}

static void test_3d(size_t walkers)
{
    const double ratios[] = {1.01, 1.5, 4.0, 20.0};
    const double R = 1.0;
    pdla_rng rng;
    rng_seed(&rng, 7002);
    double *brute = malloc(walkers * sizeof *brute);
    double *fast = malloc(walkers * sizeof *fast);
    for (size_t i = 0; i < sizeof ratios / sizeof ratios[0]; i++) {
        const double r = ratios[i] * R;
        uint64_t steps = 0;
        const size_t nb = run3(&rng, 1, r, R, walkers, brute, &steps);
        const size_t nf = run3(&rng, 0, r, R, walkers, fast, &steps);
        const double pb = (double)nb / walkers, pf = (double)nf / walkers;
        const double pooled = 0.5 * (pb + pf);
        const double se_p = sqrt(pooled * (1.0 - pooled) * 2.0 / walkers);
        const mean_se mb = mean_cos(brute, nb, 0), mf = mean_cos(fast, nf, 0);
        const double se = hypot(mb.se, mf.se);
        const double ks = ks_two_sample(brute, nb, fast, nf);
        const double ks_crit = ks_critical_001(nb, nf);
        fprintf(stderr, "3D r/R = %-5g (%.1f steps/walker): return brute %.5f, sampler %.5f "
                        "(exact %.5f), diff/se = %+.2f; <cos|ret> brute %.5f, sampler %.5f, "
                        "exact %.5f, diff/se = %+.2f; KS D = %.4f (crit %.4f)",
                ratios[i], (double)steps / walkers, pb, pf, R / r, (pb - pf) / se_p, mb.mean,
                mf.mean, R / r, (mb.mean - mf.mean) / se, ks, ks_crit);
        CHECK(fabs(pb - pf) < Z_MAX * se_p + ALLOWANCE,
              "3D r/R = %g: return fraction %.5f vs %.5f", ratios[i], pb, pf);
        CHECK(fabs(mb.mean - mf.mean) < Z_MAX * se + ALLOWANCE, "3D r/R = %g: <cos> %.5f vs %.5f",
              ratios[i], mb.mean, mf.mean);
        CHECK(fabs(pb - R / r) < Z_MAX * sqrt(R / r * (1.0 - R / r) / walkers) + ALLOWANCE,
              "3D r/R = %g: brute-force return fraction %.5f vs exact %.5f", ratios[i], pb, R / r);
        CHECK(fabs(mb.mean - R / r) < Z_MAX * mb.se + ALLOWANCE,
              "3D r/R = %g: brute-force <cos|ret> %.5f vs exact %.5f", ratios[i], mb.mean, R / r);
        CHECK(ks < ks_crit, "3D r/R = %g: KS D = %.4f >= %.4f", ratios[i], ks, ks_crit);
        if (ratios[i] == 1.5) {
            const size_t nw = run3(&rng, 0, R + 1.2 * (r - R), R, walkers, fast, &steps);
            const double ks_wrong = ks_two_sample(brute, nb, fast, nw);
            fprintf(stderr, "; control: KS D = %.4f", ks_wrong);
            CHECK(ks_wrong > ks_critical_001(nb, nw), "3D control not rejected: KS D = %.4f",
                  ks_wrong);
        }
        fputc('\n', stderr);
    }
    free(brute);
    free(fast);
}

int main(int argc, char **argv)
{
    const long walkers = argc > 1 ? strtol(argv[1], NULL, 10) : 50000;
    if (walkers < 1000) {
        fprintf(stderr, "usage: %s [walkers per ratio, >= 1000]\n", argv[0]);
        return 2;
    }
    test_2d((size_t)walkers);
    test_3d((size_t)walkers);
    return check_finish();
}
