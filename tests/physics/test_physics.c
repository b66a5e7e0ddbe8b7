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
 * The ensemble mean is over clusters at identical sample points (the R_g
 * grid is fixed per decade), seeds 1000 + i.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "fit.h"
#include "pdla/pdla.h"

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: test_physics DIM CLUSTERS N\n");
        return 2;
    }
    const int dim = atoi(argv[1]);
    const int clusters = atoi(argv[2]);
    const uint64_t n = (uint64_t)atof(argv[3]);
    size_t count = 0;
    uint64_t *grid_n = NULL;
    double *sum_log_rg = NULL;
    double df_sum = 0, df_sum2 = 0;
    for (int i = 0; i < clusters; i++) {
        pdla_params p;
        pdla_params_default(&p);
        p.dim = dim;
        p.target = n;
        p.seed = 1000 + (uint64_t)i;
        pdla_engine *e;
        char err[256];
        if (pdla_engine_create(&e, &p, err, sizeof err) ||
            pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err)) {
            CHECK(0, "growth failed: %s", err);
            return check_finish();
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
    for (size_t k = 0; k < count; k++) mean_rg[k] = exp(sum_log_rg[k] / clusters);
    const pdla_fit f = fit_powerlaw(grid_n, mean_rg, count, 1000, n);
    const double df_mean = df_sum / clusters;
    const double df_sd = sqrt(fmax(0, df_sum2 / clusters - df_mean * df_mean));
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
    free(grid_n);
    free(sum_log_rg);
    free(mean_rg);
    return check_finish();
}
