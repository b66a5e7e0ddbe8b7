/*
 * lag_probe.c - where the walkers that were frozen mid-flight stick (issue 11;
 * a measuring tool, not a test: runs/pdla-bias/README.md).
 *
 *   lag_probe DIM N SERIAL_UNTIL THREADS FIRST_SEED SEEDS [MIN_LAG]
 *
 * Grows each seed serially to SERIAL_UNTIL, then with THREADS workers to N,
 * and logs for every particle of the parallel phase its lag (particles the
 * others appended while its walker flew; test hook `inserted`) and |x|^2.
 * A worker descheduled mid-walk (more workers than free cores) leaves its
 * walker frozen while the others grow the cluster; such "stragglers" (lag >=
 * MIN_LAG, default 256) stick where the cluster was when they froze. For each
 * straggler: |x|^2 against the mean |x|^2 of the other particles appended
 * within 1000 indices of it; the sum of the excesses over N R_g^2, halved,
 * is their first-order share of the relative change of R_g at N (negative:
 * more compact). One line per seed, then the mean over seeds.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine.h"

typedef struct probe {
    uint64_t *lag;
    double *r2;
    uint64_t first, n;
    int dim;
} probe;

static void on_inserted(void *user, uint64_t index, const int64_t *p, uint64_t lag)
{
    probe *c = user;
    if (index < c->first || index >= c->n) return;
    double r2 = 0;
    for (int a = 0; a < c->dim; a++) r2 += (double)p[a] * (double)p[a];
    c->lag[index - c->first] = lag;
    c->r2[index - c->first] = r2;
}

int main(int argc, char **argv)
{
    if (argc != 7 && argc != 8) {
        fprintf(stderr, "usage: lag_probe DIM N SERIAL_UNTIL THREADS FIRST_SEED SEEDS [MIN_LAG]\n");
        return 2;
    }
    const int dim = atoi(argv[1]), threads = atoi(argv[4]), seeds = atoi(argv[6]);
    const uint64_t n = (uint64_t)atof(argv[2]), serial = (uint64_t)atof(argv[3]);
    const uint64_t seed0 = (uint64_t)atof(argv[5]);
    const uint64_t min_lag = argc == 8 ? (uint64_t)atof(argv[7]) : 256;
    if (dim < 2 || dim > 3 || threads < 2 || serial < 1 || n <= serial || seeds < 1) {
        fprintf(stderr, "lag_probe: bad arguments\n");
        return 2;
    }
    const uint64_t m = n - serial;
    probe c = {calloc(m, sizeof *c.lag), calloc(m, sizeof *c.r2), serial, n, dim};
    double *prefix = calloc(m + 1, sizeof *prefix);
    uint64_t *cnt = calloc(m + 1, sizeof *cnt);
    if (!c.lag || !c.r2 || !prefix || !cnt) {
        fprintf(stderr, "lag_probe: out of memory\n");
        return 1;
    }
    double sum_effect = 0, sum_ratio = 0;
    uint64_t sum_stragglers = 0;
    printf("seed\tR_g\tstragglers\tmean_lag_of_stragglers\tmean_r/r_local\tdRg/Rg_first_order\n");
    for (int k = 0; k < seeds; k++) {
        pdla_params P;
        pdla_params_default(&P);
        P.dim = dim;
        P.target = n;
        P.serial_until = serial;
        P.threads = threads;
        P.seed = seed0 + (uint64_t)k;
        P.rg_per_decade = 0;
        pdla_engine *e;
        char err[256];
        if (pdla_engine_create(&e, &P, err, sizeof err)) {
            fprintf(stderr, "lag_probe: %s\n", err);
            return 1;
        }
        memset(c.lag, 0, m * sizeof *c.lag);
        engine_hooks h = {.inserted = on_inserted, .user = &c};
        e->hooks = &h;
        if (pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err)) {
            fprintf(stderr, "lag_probe: %s\n", err);
            return 1;
        }
        e->hooks = NULL;
        pdla_stats s;
        pdla_engine_stats(e, &s);
        const double rg_units = s.rg_diam * P.resolution;
        pdla_engine_destroy(e);
        /* prefix sums of |x|^2 over the particles that are not stragglers */
        for (uint64_t i = 0; i < m; i++) {
            const int normal = c.lag[i] < min_lag;
            prefix[i + 1] = prefix[i] + (normal ? c.r2[i] : 0);
            cnt[i + 1] = cnt[i] + (uint64_t)normal;
        }
        double excess = 0, ratio = 0, lags = 0;
        uint64_t stragglers = 0;
        for (uint64_t i = 0; i < m; i++) {
            if (c.lag[i] < min_lag) continue;
            const uint64_t lo = i > 1000 ? i - 1000 : 0, hi = i + 1000 < m ? i + 1000 : m;
            const uint64_t nn = cnt[hi] - cnt[lo];
            if (!nn) continue;
            const double local = (prefix[hi] - prefix[lo]) / (double)nn;
            excess += c.r2[i] - local;
            ratio += sqrt(c.r2[i] / local);
            lags += (double)c.lag[i];
            stragglers++;
        }
        const double effect = 0.5 * excess / ((double)n * rg_units * rg_units);
        printf("%llu\t%.4f\t%llu\t%.0f\t%.3f\t%+.4f%%\n", (unsigned long long)P.seed, s.rg_diam,
               (unsigned long long)stragglers, stragglers ? lags / (double)stragglers : 0.0,
               stragglers ? ratio / (double)stragglers : 0.0, 100 * effect);
        sum_effect += effect;
        sum_ratio += stragglers ? ratio / (double)stragglers : 0.0;
        sum_stragglers += stragglers;
    }
    printf("mean over %d seeds: %.1f stragglers (lag >= %llu) per run, mean r/r_local %.3f, "
           "first-order R_g change %+.4f%%\n",
           seeds, (double)sum_stragglers / seeds, (unsigned long long)min_lag, sum_ratio / seeds,
           100 * sum_effect / seeds);
    free(c.lag);
    free(c.r2);
    free(prefix);
    free(cnt);
    return 0;
}
