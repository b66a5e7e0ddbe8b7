/* runs/dlca/scaletrace.c - a long DLCA run (gamma 0, lattice search, to 100
 * clusters) with its CPU time per stage: a line each time N_c falls by a
 * tenth (N_c, attempts, monomer moves, CPU seconds of the stage, ns an
 * attempt, ns a monomer-move), then D_f of the final clusters
 * (dlca_fractal_dim, sizes >= 8, as cluster.h5's /results/D_f) and peak RSS.
 * Build and run (the release libpdla.a):
 *   gcc -O2 -std=gnu11 -I include runs/dlca/scaletrace.c build/libpdla.a \
 *       -lhdf5_serial -lhwloc -lm -lpthread -o /tmp/scaletrace
 *   nice -n 10 /tmp/scaletrace D L FILL SEED */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "pdla/dlca.h"
static double cpu(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}
int main(int argc, char **argv)
{
    if (argc != 5) return 2;
    dlca_params p;
    dlca_params_default(&p);
    p.dim = atoi(argv[1]);
    for (int a = 0; a < DLCA_MAX_DIM; a++) p.box[a] = a < p.dim ? (uint32_t)atoi(argv[2]) : 0;
    p.fill = atof(argv[3]);
    p.until_clusters = 100;
    p.seed = (uint64_t)atoll(argv[4]);
    char err[256];
    dlca_sim *s;
    const double c0 = cpu();
    if (dlca_create(&s, &p, err, sizeof err)) { fprintf(stderr, "%s\n", err); return 1; }
    dlca_stats st, last;
    dlca_get_stats(s, &last);
    double cl = cpu();
    printf("N %llu, setup %.2f s CPU\n", (unsigned long long)last.n_monomers, cl - c0);
    printf("%10s %12s %14s %9s %11s %13s\n", "N_c", "attempts", "monomer_moves", "cpu_s", "ns/attempt", "ns/mono-move");
    int stop = 0;
    while (!stop) {
        stop = dlca_run(s, 100000);
        dlca_get_stats(s, &st);
        if (!stop && st.n_clusters > 0.9 * last.n_clusters) continue;
        const double c = cpu(), da = (double)(st.attempts - last.attempts), dm = (double)(st.monomer_moves - last.monomer_moves);
        printf("%10llu %12llu %14llu %9.2f %11.1f %13.2f\n", (unsigned long long)st.n_clusters,
               (unsigned long long)st.attempts, (unsigned long long)st.monomer_moves, c - cl, 1e9 * (c - cl) / da,
               1e9 * (c - cl) / dm);
        fflush(stdout);
        last = st, cl = c;
    }
    const size_t nc = st.n_clusters;
    uint64_t *size = malloc(nc * sizeof *size);
    double *rg = malloc(nc * sizeof *rg), df, dfe;
    dlca_cluster_table(s, size, rg);
    dlca_fractal_dim(size, rg, nc, 8, &df, &dfe);
    printf("stop %s, t %.1f, attempts %llu, monomer moves %llu, largest %llu, CPU %.1f s, D_f %.3f +/- %.3f\n",
           dlca_stop_name(st.stop), st.t, (unsigned long long)st.attempts, (unsigned long long)st.monomer_moves,
           (unsigned long long)st.largest, cpu() - c0, df, dfe);
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    while (f && fgets(line, sizeof line, f))
        if (line[0] == 'V' && line[2] == 'H' && line[3] == 'W') fputs(line, stdout);
    if (f) fclose(f);
    dlca_destroy(s);
    free(size), free(rg);
    return 0;
}
