/* chase.c - dependent random loads (pointer chasing) over an array of SIZE
 * bytes, one 64-byte line a hop, in one random cycle: the latency of a
 * cache or DRAM miss on this machine, for issue 15's floor. The array can
 * be advised into transparent huge pages (MADV_HUGEPAGE), as the event
 * engine's big arrays are (ev_sim.c big_zalloc).
 * Build: gcc -O2 -o /tmp/chase runs/event/session35/chase.c
 * Use:   /tmp/chase MIB HUGE(0|1) [HOPS]   -> ns per hop */
#define _GNU_SOURCE
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

static uint64_t rng_state = 88172645463325252ull;
static uint64_t xs(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return rng_state;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: chase MIB HUGE [HOPS]\n");
        return 2;
    }
    const size_t bytes = (size_t)atol(argv[1]) << 20, lines = bytes / 64;
    const int huge = atoi(argv[2]);
    const long hops = argc > 3 ? atol(argv[3]) : 20000000L;
    char *a = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (a == MAP_FAILED) return 1;
    if (huge) madvise(a, bytes, MADV_HUGEPAGE);
    else madvise(a, bytes, MADV_NOHUGEPAGE);
    uint32_t *perm = malloc(lines * sizeof *perm);
    if (!perm) return 1;
    for (size_t i = 0; i < lines; i++) perm[i] = (uint32_t)i;
    for (size_t i = lines - 1; i > 0; i--) { /* Fisher-Yates */
        const size_t j = xs() % (i + 1);
        const uint32_t t = perm[i];
        perm[i] = perm[j];
        perm[j] = t;
    }
    for (size_t i = 0; i < lines; i++) /* one cycle through every line */
        *(char **)(a + (size_t)perm[i] * 64) = a + (size_t)perm[(i + 1) % lines] * 64;
    free(perm);
    char *p = a;
    for (long i = 0; i < hops / 10; i++) p = *(char **)p; /* warm */
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (long i = 0; i < hops; i++) p = *(char **)p;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    const double ns = ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / (double)hops;
    printf("%s MiB %zu huge %d ns/hop %.1f\n", p == NULL ? "?" : "size", bytes >> 20, huge, ns);
    return 0;
}
