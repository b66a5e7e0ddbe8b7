/*
 * test_exact_search.c - `exact_search` changes the walk, in 2D and 3D.
 * With it every jump is by the exact nearest distance from the tree (no
 * distance map, no VPDIST far bound, no 2D leaf-block cut), so 2D walkers
 * need markedly fewer jumps than with the fast search, whose bounds are
 * lower.
 * The distance map once made the flag a silent no-op in 2D (identical
 * clusters for both settings); this fails if that happens again.
 * The same seed still gives a valid cluster of the same size either way.
 */
#include "check.h"
#include "pdla/pdla.h"

static pdla_stats grow(int dim, int exact, uint64_t n)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.target = n;
    p.seed = 11;
    p.exact_search = exact;
    pdla_engine *e = NULL;
    char err[256];
    pdla_stats s = {0};
    if (pdla_engine_create(&e, &p, err, sizeof err) != PDLA_OK) {
        CHECK(0, "create: %s", err);
        return s;
    }
    CHECK(pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "grow: %s", err);
    pdla_engine_stats(e, &s);
    pdla_engine_destroy(e);
    return s;
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        const uint64_t n = dim == 2 ? 20000 : 5000;
        const pdla_stats fast = grow(dim, 0, n), exact = grow(dim, 1, n);
        const double jf = (double)fast.jumps / (double)n, je = (double)exact.jumps / (double)n;
        fprintf(stderr, "%dD %llu: jumps/particle fast %.2f, exact %.2f\n", dim,
                (unsigned long long)n, jf, je);
        CHECK(fast.particles == n && exact.particles == n, "%dD: both reach the target", dim);
        /* 2D: measured 29.1 vs 16.6 jumps/particle, a wide margin. 3D walks
         * spend their jumps near the cluster, where both searches are exact
         * below the sticking shell, so the counts are close (31.3 vs 31.6):
         * there the check is only that the flag changes the walk. */
        if (dim == 2)
            CHECK(je < 0.85 * jf, "2D: exact search takes fewer jumps (%.2f vs %.2f)", je, jf);
        else
            CHECK(exact.jumps != fast.jumps, "3D: exact search changes the walk");
    }
    return check_finish();
}
