/*
 * test_dlca_physics.c - fractal dimension of DLCA clusters: R_g against size
 * over the clusters of an ensemble of runs (pooled, binned by size in
 * factors of sqrt 2, dlca_fractal_dim), checked against a range that holds
 * the published values (2D 1.44-1.45, 3D 1.75-1.80).
 *
 * usage: test_dlca_physics D L FILL RUNS UNTIL_CLUSTERS S_MIN LO HI
 * (box L^D, seeds 1..RUNS, gamma = 0 as in the seed). The range [LO, HI] is
 * the issue's; the run prints the fit and its standard error so that a
 * failure says by how much.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pdla/dlca.h"

int main(int argc, char **argv)
{
    if (argc != 9) {
        fprintf(stderr, "usage: %s D L FILL RUNS UNTIL_CLUSTERS S_MIN LO HI\n", argv[0]);
        return 2;
    }
    const int d = atoi(argv[1]), runs = atoi(argv[4]);
    const uint32_t L = (uint32_t)atoi(argv[2]);
    const double fill = atof(argv[3]), lo = atof(argv[7]), hi = atof(argv[8]);
    const uint64_t K = strtoull(argv[5], NULL, 10), smin = strtoull(argv[6], NULL, 10);
    uint64_t *size = NULL;
    double *rg = NULL;
    size_t n = 0;
    for (int r = 1; r <= runs; r++) {
        dlca_params p;
        dlca_params_default(&p);
        p.dim = d;
        for (int a = 0; a < DLCA_MAX_DIM; a++) p.box[a] = a < d ? L : 0;
        p.fill = fill;
        p.until_clusters = K;
        p.seed = (uint64_t)r;
        dlca_sim *s = NULL;
        char err[512];
        if (dlca_create(&s, &p, err, sizeof err)) {
            CHECK(0, "%s", err);
            return check_finish();
        }
        const int stop = dlca_run(s, 0);
        dlca_stats st;
        dlca_get_stats(s, &st);
        CHECK(stop == DLCA_STOP_CLUSTERS, "run %d stopped by %s at %llu clusters", r, dlca_stop_name(stop),
              (unsigned long long)st.n_clusters);
        size = realloc(size, (n + st.n_clusters) * sizeof *size);
        rg = realloc(rg, (n + st.n_clusters) * sizeof *rg);
        dlca_cluster_table(s, size + n, rg + n);
        n += st.n_clusters;
        dlca_destroy(s);
    }
    double df, err;
    const int bins = dlca_fractal_dim(size, rg, n, smin, &df, &err);
    uint64_t big = 0;
    for (size_t i = 0; i < n; i++) big = size[i] > big ? size[i] : big;
    fprintf(stderr, "d=%d L=%u fill=%g: %zu clusters (largest %llu), %d bins from s >= %llu: D_f = %.4f +/- %.4f\n", d,
            L, fill, n, (unsigned long long)big, bins, (unsigned long long)smin, df, err);
    CHECK(bins >= 4, "only %d size bins", bins);
    CHECK(df >= lo && df <= hi, "D_f %.4f outside [%g, %g]", df, lo, hi);
    free(size);
    free(rg);
    return check_finish();
}
