/*
 * bench_dlca.c - timing of the DLCA searches (not a test): runs one system
 * in chunks of attempts and prints, per chunk, the clusters at its start,
 * the time t, and the CPU time per attempt and per monomer-move (CPU time
 * of this process, so that other jobs on the machine count less), and the
 * clusters pair-tested per attempt.
 *
 * usage: bench_dlca D BOX FILL UNTIL_CLUSTERS SEED SEARCH CHUNK [MAX_ATTEMPTS]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "pdla/dlca.h"

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    if (argc < 8) {
        fprintf(stderr, "usage: %s D BOX FILL UNTIL_CLUSTERS SEED SEARCH CHUNK [MAX_ATTEMPTS]\n", argv[0]);
        return 2;
    }
    dlca_params p;
    dlca_params_default(&p);
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    const char *keys[] = {"dim", "box", "fill", "until-clusters", "seed", "search"};
    char err[512];
    for (int i = 0; i < 6; i++)
        for (size_t j = 0; j < n; j++)
            if (!strcmp(t[j].option, keys[i]) && dlca_param_set(&p, &t[j], argv[1 + i], err, sizeof err)) {
                fprintf(stderr, "%s\n", err);
                return 2;
            }
    const uint64_t chunk = strtoull(argv[7], NULL, 10);
    if (argc > 8) p.max_attempts = strtoull(argv[8], NULL, 10);
    dlca_sim *s;
    const double c0 = cpu_now();
    if (dlca_create(&s, &p, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 2;
    }
    const double c1 = cpu_now();
    printf("# d=%d box=%s fill=%g seed=%llu search=%s setup_cpu_s=%.4f\n", p.dim, argv[2], p.fill,
           (unsigned long long)p.seed, dlca_search_name(p.search), c1 - c0);
    printf("# attempts t n_clusters ns_per_attempt ns_per_monomer_move candidates_per_attempt search_now box_side\n");
    dlca_stats a, b;
    dlca_get_stats(s, &a);
    double total = 0;
    int stop = 0;
    while (!stop) {
        const double t0 = cpu_now();
        stop = dlca_run(s, chunk);
        const double dt = cpu_now() - t0;
        total += dt;
        dlca_get_stats(s, &b);
        const double na = (double)(b.attempts - a.attempts), nm = (double)(b.monomer_moves - a.monomer_moves);
        if (na > 0)
            printf("%llu %.6g %llu %.2f %.3f %.2f %s %d\n", (unsigned long long)a.attempts, a.t,
                   (unsigned long long)a.n_clusters, 1e9 * dt / na, nm > 0 ? 1e9 * dt / nm : 0,
                   (double)(b.candidates - a.candidates) / na, dlca_search_name(a.search_now), a.box_side);
        a = b;
    }
    printf("# total: attempts %llu moves %llu monomer_moves %llu cpu_s %.4f ns_per_attempt %.2f "
           "ns_per_monomer_move %.3f n_clusters %llu t %.6g stop %s bytes_per_monomer %.1f\n",
           (unsigned long long)b.attempts, (unsigned long long)b.moves, (unsigned long long)b.monomer_moves, total,
           1e9 * total / (double)b.attempts, 1e9 * total / (double)b.monomer_moves,
           (unsigned long long)b.n_clusters, b.t, dlca_stop_name(b.stop), (double)b.bytes / (double)b.n_monomers);
    dlca_destroy(s);
    return 0;
}
