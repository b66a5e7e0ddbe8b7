/* runs/dlca/hwm.c - peak RSS of a DLCA run (lattice search, seed 1, to 100
 * clusters or spanning) beyond what the process held before dlca_create and
 * beyond the lattice (HWM_SITE_BITS bits a site: 32, the default, for the
 * id lattice before session 7; 1 for the bit lattice since), in bytes a
 * monomer. Public API
 * only, so that one source builds against any version of libpdla.a:
 *   gcc -O2 -std=gnu11 -I include runs/dlca/hwm.c build/libpdla.a -lhdf5_serial -lhwloc -lm -lpthread -o /tmp/hwm
 *   /tmp/hwm D L FILL [GAMMA [MAX_ATTEMPTS]] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "pdla/dlca.h"
static long status_kb(const char *key)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long v = -1;
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, key, strlen(key))) v = atol(line + strlen(key) + 1);
    if (f) fclose(f);
    return v;
}
int main(int argc, char **argv)
{
    if (argc < 4) return 2;
    dlca_params p;
    dlca_params_default(&p);
    p.dim = atoi(argv[1]);
    double V = 1;
    for (int a = 0; a < DLCA_MAX_DIM; a++) p.box[a] = a < p.dim ? (uint32_t)atoi(argv[2]) : 0;
    for (int a = 0; a < p.dim; a++) V *= p.box[a];
    p.fill = atof(argv[3]);
    if (argc > 4) p.mobility = atof(argv[4]);
    if (argc > 5) p.max_attempts = (uint64_t)atoll(argv[5]);
    p.until_clusters = 100;
    p.seed = 1;
    char err[256];
    dlca_sim *s;
    const double bits = getenv("HWM_SITE_BITS") ? atof(getenv("HWM_SITE_BITS")) : 32;
    const long rss0 = status_kb("VmRSS:");
    if (dlca_create(&s, &p, err, sizeof err)) { fprintf(stderr, "%s\n", err); return 1; }
    while (!dlca_run(s, 1000000)) {}
    dlca_stats st;
    dlca_get_stats(s, &st);
    const long hwm = status_kb("VmHWM:");
    printf("d %d L %s fill %s: N %llu stop %s N_c %llu | rss before %ld kB, VmHWM %ld kB | beyond the lattice %.1f B/monomer\n",
           p.dim, argv[2], argv[3], (unsigned long long)st.n_monomers, dlca_stop_name(st.stop),
           (unsigned long long)st.n_clusters, rss0, hwm, ((hwm - rss0) * 1024.0 - bits / 8 * V) / (double)st.n_monomers);
    dlca_destroy(s);
    return 0;
}
