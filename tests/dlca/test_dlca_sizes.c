/*
 * test_dlca_sizes.c - the SHAPE of the DLCA cluster-size distribution
 * against Smoluchowski scaling (issue 14; test_dlca_kinetics.c checks the
 * growth exponent and the polydispersity, not the shape).
 *
 * In 2D with mobility exponent gamma = 0 the kernel homogeneity is
 * lambda = gamma + (d - 2) / D_f = 0: the constant kernel, whose exact
 * solution from a monodisperse start is n_k(t) = N0 (1 - q)^2 q^(k-1) with
 * q = 1 - 1 / s_n (s_n = N / N_c). The fraction of clusters of size <= x s_n
 * is then exactly F(x) = 1 - q^floor(x s_n) (-> 1 - exp(-x), the scaling
 * exponential; the exact form also carries the small-s_n corrections).
 * For lambda < 0 (gamma = -1/2 in 2D) the scaling distribution is
 * bell-shaped: small clusters are depleted against the exponential.
 *
 * usage: test_dlca_sizes D L FILL GAMMA RUNS S1 S2 MODE TOL
 * Runs seeds 1..RUNS, stops each at N_c = N / S1 and then N / S2, and at
 * each stop takes F(x) for x in X[] (the fraction of that run's clusters of
 * size <= x s_n, s_n = N / N_c at the stop); per x and stop the ensemble
 * mean +/- standard error over runs. Checks:
 *   MODE exp:   |mean F(x) - (1 - q^floor(x s_n))| <= TOL at both stops,
 *               and the collapse |F_S1(x) - F_S2(x)| <= TOL, for every x
 *   MODE below: the small clusters depleted: F(X[0]) + TOL <= 1 - q^floor
 *               at both stops (the exponential's fraction less TOL)
 *   MODE print: no check (exploration)
 * TOL is set in meson.build from the measured spread.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pdla/dlca.h"

static const double X[] = {0.25, 0.5, 1, 2};
enum { NX = sizeof X / sizeof X[0] };

/* F(x) of this sim's clusters for every x; returns s_n. */
static double cum_fractions(const dlca_sim *s, double N, double *F)
{
    dlca_stats st;
    dlca_get_stats(s, &st);
    const size_t nc = (size_t)st.n_clusters;
    uint64_t *size = malloc(nc * sizeof *size);
    double *rg = malloc(nc * sizeof *rg);
    if (!size || !rg) {
        free(size), free(rg);
        return -1;
    }
    dlca_cluster_table(s, size, rg);
    const double sn = N / (double)nc;
    for (int j = 0; j < NX; j++) {
        const double lim = floor(X[j] * sn);
        size_t c = 0;
        for (size_t i = 0; i < nc; i++) c += (double)size[i] <= lim;
        F[j] = (double)c / (double)nc;
    }
    free(size), free(rg);
    return sn;
}

/* The constant kernel's exact F(x) at s_n. */
static double f_exact(double x, double sn) { return 1 - pow(1 - 1 / sn, floor(x * sn)); }

int main(int argc, char **argv)
{
    if (argc != 10) {
        fprintf(stderr, "usage: %s D L FILL GAMMA RUNS S1 S2 exp|below|print TOL\n", argv[0]);
        return 2;
    }
    const int d = atoi(argv[1]), runs = atoi(argv[5]);
    const uint32_t L = (uint32_t)atoi(argv[2]);
    const double fill = atof(argv[3]), gamma = atof(argv[4]), tol = atof(argv[9]);
    const double S[2] = {atof(argv[6]), atof(argv[7])};
    const char *mode = argv[8];
    if (runs < 2 || !(S[0] > 1 && S[1] > S[0]) ||
        (strcmp(mode, "exp") && strcmp(mode, "below") && strcmp(mode, "print"))) {
        fprintf(stderr, "%s: need RUNS >= 2, 1 < S1 < S2, MODE exp|below|print\n", argv[0]);
        return 2;
    }
    /* ex: the exact F of each run's own s_n, summed (floor(x s_n) jumps when
     * s_n is a hair below a round S, so the theory is taken run by run) */
    double sum[2][NX] = {{0}}, sum2[2][NX] = {{0}}, ex[2][NX] = {{0}}, snsum[2] = {0};
    for (int r = 1; r <= runs; r++) {
        dlca_params p;
        dlca_params_default(&p);
        p.dim = d;
        for (int a = 0; a < DLCA_MAX_DIM; a++) p.box[a] = a < d ? L : 0;
        p.fill = fill;
        p.mobility = gamma;
        p.seed = (uint64_t)r;
        const double N = (double)dlca_params_monomers(&p);
        p.until_clusters = (uint64_t)llround(N / S[0]);
        dlca_sim *s = NULL;
        char err[512];
        if (N / S[1] < 20 || dlca_create(&s, &p, err, sizeof err)) {
            CHECK(0, "%s", N / S[1] < 20 ? "box too small for S2" : err);
            return check_finish();
        }
        for (int k = 0; k < 2; k++) {
            if (k) dlca_set_stops(s, (uint64_t)llround(N / S[k]), 0, 0);
            const int stop = dlca_run(s, 0);
            CHECK(stop == DLCA_STOP_CLUSTERS, "run %d stopped by %s", r, dlca_stop_name(stop));
            double F[NX];
            const double sn = cum_fractions(s, N, F);
            CHECK(sn > 0, "out of memory");
            snsum[k] += sn;
            for (int j = 0; j < NX; j++)
                sum[k][j] += F[j], sum2[k][j] += F[j] * F[j], ex[k][j] += f_exact(X[j], sn);
        }
        dlca_destroy(s);
    }
    double mean[2][NX], se[2][NX], sn[2];
    for (int k = 0; k < 2; k++) {
        sn[k] = snsum[k] / runs;
        fprintf(stderr, "d=%d L=%u fill=%g gamma=%g runs=%d s_n=%.2f: x F(x) +/- se [constant kernel]:", d, L,
                fill, gamma, runs, sn[k]);
        for (int j = 0; j < NX; j++) {
            mean[k][j] = sum[k][j] / runs, ex[k][j] /= runs;
            se[k][j] = sqrt(fmax(0, (sum2[k][j] - runs * mean[k][j] * mean[k][j]) / (runs - 1)) / runs);
            fprintf(stderr, "  %g %.4f +/- %.4f [%.4f]", X[j], mean[k][j], se[k][j], ex[k][j]);
        }
        fprintf(stderr, "\n");
    }
    for (int j = 0; j < NX; j++)
        fprintf(stderr, "collapse x=%g: F(s_n %.1f) - F(s_n %.1f) = %+.4f [constant kernel %+.4f]\n", X[j], sn[1],
                sn[0], mean[1][j] - mean[0][j], ex[1][j] - ex[0][j]);
    if (!strcmp(mode, "exp")) {
        for (int k = 0; k < 2; k++)
            for (int j = 0; j < NX; j++)
                CHECK(fabs(mean[k][j] - ex[k][j]) <= tol,
                      "s_n %.2f, x %g: F = %.4f, the constant kernel gives %.4f (tolerance %g)", sn[k], X[j],
                      mean[k][j], ex[k][j], tol);
        /* collapse: F(x) moves between the stops only by the constant
         * kernel's own small-s_n correction (the floor) */
        for (int j = 0; j < NX; j++)
            CHECK(fabs((mean[1][j] - mean[0][j]) - (ex[1][j] - ex[0][j])) <= tol,
                  "no collapse at x %g: F %.4f at s_n %.2f, %.4f at %.2f (constant kernel: %+.4f)", X[j], mean[0][j],
                  sn[0], mean[1][j], sn[1], ex[1][j] - ex[0][j]);
    } else if (!strcmp(mode, "below")) {
        for (int k = 0; k < 2; k++)
            CHECK(mean[k][0] + tol <= ex[k][0],
                  "s_n %.2f: F(%g) = %.4f not below the exponential's %.4f by %g: no small-cluster depletion",
                  sn[k], X[0], mean[k][0], ex[k][0], tol);
    }
    return check_finish();
}
