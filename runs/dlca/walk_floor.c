/*
 * runs/dlca/walk_floor.c - the floor the issue names: a plain lattice
 * random walk's cost per site step, beside DLCA's ns per monomer-move.
 * N independent walkers with excluded volume on a periodic 2D id lattice
 * (the DLCA's: 4 bytes a site): pick a walker and a direction at random
 * (pdla's rng, as a DLCA attempt does), step unless the site is taken
 * (clear the old site, mark the new), then look at the new site's four
 * neighbours (the contact scan a DLCA move does). No clusters, no joins.
 * Prints CPU ns per step (CPU time of this process).
 *   gcc -O3 -std=gnu11 -I src/core runs/dlca/walk_floor.c -o /tmp/walk_floor
 *   /tmp/walk_floor LX LY FILL STEPS SEED
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "rng.h"

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static inline uint64_t below(pdla_rng *r, uint64_t n) { return (uint64_t)(((unsigned __int128)rng_next(r) * n) >> 64); }

int main(int argc, char **argv)
{
    if (argc < 6) return 2;
    const uint32_t LX = (uint32_t)atoi(argv[1]), LY = (uint32_t)atoi(argv[2]);
    const double fill = atof(argv[3]);
    const uint64_t steps = strtoull(argv[4], NULL, 10), V = (uint64_t)LX * LY, N = (uint64_t)(fill * V + 0.5);
    pdla_rng rng;
    rng_seed(&rng, strtoull(argv[5], NULL, 10));
    uint32_t *grid = calloc(V, sizeof *grid), *site = malloc(N * sizeof *site);
    if (!grid || !site) return 1;
    for (uint64_t j = 0; j < N; j++) {
        uint64_t k;
        do k = below(&rng, V);
        while (grid[k]);
        grid[k] = (uint32_t)j + 1;
        site[j] = (uint32_t)k;
    }
    uint64_t touched = 0, moved = 0;
    const double t0 = cpu_now();
    for (uint64_t s = 0; s < steps; s++) {
        const uint64_t j = below(&rng, N), dir = below(&rng, 4);
        const uint32_t k = site[j], x = k % LX, y = k / LX;
        const uint32_t nx = dir == 0 ? (x + 1 == LX ? 0 : x + 1) : dir == 1 ? (x ? x - 1 : LX - 1) : x;
        const uint32_t ny = dir == 2 ? (y + 1 == LY ? 0 : y + 1) : dir == 3 ? (y ? y - 1 : LY - 1) : y;
        const uint32_t kn = ny * LX + nx;
        if (grid[kn]) continue;
        grid[k] = 0;
        grid[kn] = (uint32_t)j + 1;
        site[j] = kn;
        moved++;
        const uint32_t xr = nx + 1 == LX ? 0 : nx + 1, xl = nx ? nx - 1 : LX - 1;
        const uint32_t yu = ny + 1 == LY ? 0 : ny + 1, yd = ny ? ny - 1 : LY - 1;
        touched += (grid[ny * LX + xr] != 0) + (grid[ny * LX + xl] != 0) + (grid[yu * LX + nx] != 0) +
                   (grid[yd * LX + nx] != 0);
    }
    const double cpu = cpu_now() - t0;
    printf("N %llu steps %llu moved %llu contacts %llu cpu_s %.3f ns/step %.2f\n", (unsigned long long)N,
           (unsigned long long)steps, (unsigned long long)moved, (unsigned long long)touched, cpu, 1e9 * cpu / steps);
    return 0;
}
