/* runs/dlca/memparts.c - memory breakdown of a DLCA run (to 100 clusters,
 * seed 1): the model's parts and glibc's heap, sampled every 20000 attempts,
 * at the sample of the largest heap and at the end; "rss" from
 * /proc/self/statm (TRIM=1: malloc_trim first; MMT=bytes: mallopt's mmap
 * threshold). Since the block arena (dlca6): "arena_live" = its live blocks,
 * "arena_top" = up to its top with the freed blocks not yet slid out; slots:
 * pos, ref, act (+ id after a compaction), no size array since dlca6.
 * TRACE=1: a line each time N_c falls by a fifth. Build and run (internal headers, the release libpdla.a):
 *   gcc -O2 -std=gnu11 -I include -I src -I src/core -I src/dlca runs/dlca/memparts.c build/libpdla.a \
 *       -lhdf5_serial -lhwloc -lm -lpthread -o /tmp/memparts
 *   /tmp/memparts D L FILL GAMMA */
#include <malloc.h>
#include <stdio.h>
#include <stdlib.h>
#include "dlca_sim.h"
typedef struct { double slots, grid, rectab, blocks_cap, blocks_used, extra, heap; } parts;
static parts measure(const dlca_sim *s)
{
    parts p = {0};
    const int d = s->d;
    p.slots = (double)(s->nslot + 1) * (8 + 4 * (s->id != NULL)) + (double)s->nslot * 4;
    p.grid = s->grid ? (double)s->V * 4 : 0;
    p.rectab = (double)(s->ar_top - s->ar_free) * 4; /* the arena's live blocks (no record table now) */
    p.blocks_cap = (double)s->ar_top * 4;             /* the arena up to its top, freed blocks too */
    for (uint64_t c = 1; c <= s->nslot; c++)
        if (dlca_n(s, c) >= 2) p.blocks_used += (double)dlca_n(s, c) * (4 + 2 * d);
    if (s->size_count) p.extra += (s->N + 1) * 4.0;
    if (s->mob) p.extra += s->nmob * 8.0;
    if (s->stamp) p.extra += (s->nslot + 1) * 4.0;
    if (s->cand) p.extra += s->nslot * 4.0;
    if (s->brange) p.extra += (s->nslot + 1) * 8.0 * d;
    struct mallinfo2 mi = mallinfo2(); if (getenv("TRIM")) malloc_trim(0);
    { FILE *f = fopen("/proc/self/statm", "r"); long a, b; if (fscanf(f, "%ld %ld", &a, &b) == 2) p.extra = b * 4096.0; fclose(f); }
    p.heap = (double)mi.arena + (double)mi.hblkhd; /* bytes obtained from the system */
    return p;
}
int main(int argc, char **argv)
{
    if (getenv("MMT")) mallopt(M_MMAP_THRESHOLD, atoi(getenv("MMT")));
    dlca_params p;
    dlca_params_default(&p);
    p.dim = atoi(argv[1]);
    for (int a = 0; a < DLCA_MAX_DIM; a++) p.box[a] = a < p.dim ? (uint32_t)atoi(argv[2]) : 0;
    p.fill = atof(argv[3]);
    p.mobility = atof(argv[4]);
    p.until_clusters = 100;
    p.seed = 1;
    char err[256];
    dlca_sim *s;
    if (dlca_create(&s, &p, err, sizeof err)) { fprintf(stderr, "%s\n", err); return 1; }
    parts pk = {0};
    double lastnc = 1e30;
    double nc_pk = 0;
    while (!dlca_run(s, 20000)) {
        parts q = measure(s);
        if (q.heap > pk.heap) pk = q, nc_pk = s->nc;
        if (getenv("TRACE") && s->nc < 0.8 * lastnc) {
            lastnc = (double)s->nc;
            printf("nc %llu slots %.1f arena_live %.1f arena_top %.1f used %.1f rss %.1f heap %.1f\n",
                   (unsigned long long)s->nc, q.slots / s->N, q.rectab / s->N, q.blocks_cap / s->N,
                   q.blocks_used / s->N, q.extra / s->N, q.heap / s->N);
        }
    }
    parts e = measure(s);
    const double N = s->N;
    printf("N %.0f\n", N);
    const char *names[] = {"slots", "grid", "arena_live", "arena_top", "blocks_used", "rss", "heap(system)"};
    for (int i = 0; i < 7; i++)
        printf("%-13s peak(N_c %.0f) %7.1f B/monomer   end(N_c %llu) %7.1f\n", names[i], nc_pk, ((double *)&pk)[i] / N,
               (unsigned long long)s->nc, ((double *)&e)[i] / N);
    dlca_destroy(s);
    return 0;
}
