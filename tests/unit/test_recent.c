/*
 * test_recent.c - the PDLA insertion check's ring of recent particles
 * (src/dla/recent.c) against brute force on random clusters, 2D and 3D: for a
 * random spot p and a random `seen`, recent_overlap must say whether one of
 * particles seen..N-1 lies closer than D to p; when the ring (capacities 1,
 * 7, 64, 4096) no longer holds them all, whether any particle does (the
 * fallback searches the whole tree). Fixed seeds.
 */
#include <stdlib.h>

#include "check.h"
#include "recent.h"
#include "rng.h"

static int64_t rand_range(pdla_rng *r, int64_t lo, int64_t hi)
{
    return lo + (int64_t)(rng_next(r) % (uint64_t)(hi - lo + 1));
}

/* Any of pts[from..to) closer than sqrt(D2) to p. */
static int brute_overlap(int64_t (*pts)[3], uint64_t from, uint64_t to, int dim, const int64_t *p,
                         uint64_t D2)
{
    for (uint64_t i = from; i < to; i++) {
        uint64_t d2 = 0;
        for (int a = 0; a < dim; a++) {
            const int64_t d = p[a] - pts[i][a];
            d2 += (uint64_t)(d * d);
        }
        if (d2 < D2) return 1;
    }
    return 0;
}

static void test_ring(int dim, uint32_t cap, uint64_t seed)
{
    enum { N = 600 };
    const int64_t D = 32;
    const uint64_t D2 = (uint64_t)(D * D);
    pdla_rng r;
    rng_seed(&r, seed);
    tree t;
    recent_ring ring;
    CHECK(tree_init(&t, dim) == 0 && recent_init(&ring, cap) == 0, "init");
    int64_t(*pts)[3] = calloc(N, sizeof *pts);
    int hits = 0, misses = 0;
    for (uint64_t n = 0; n < N; n++) {
        /* A few hundred units across: most spots touch something. */
        for (int a = 0; a < dim; a++) pts[n][a] = rand_range(&r, -400, 400);
        CHECK(tree_insert(&t, pts[n]) == 0, "insert");
        recent_put(&ring, n, pts[n], dim);
        for (int q = 0; q < 8; q++) {
            const uint64_t now = n + 1;
            const uint64_t seen = (uint64_t)rand_range(&r, 0, (int64_t)now);
            const uint64_t near = (uint64_t)rand_range(&r, 0, (int64_t)n);
            int64_t p[3] = {0, 0, 0};
            for (int a = 0; a < dim; a++) p[a] = pts[near][a] + rand_range(&r, -2 * D, 2 * D);
            const uint64_t from = now - seen > cap ? 0 : seen;
            const int want = brute_overlap(pts, from, now, dim, p, D2);
            const int got = recent_overlap(&ring, &t, seen, p, D2);
            CHECK(got == want, "dim %d cap %u seed %llu: n %llu seen %llu: ring %d, brute force %d",
                  dim, cap, (unsigned long long)seed, (unsigned long long)now,
                  (unsigned long long)seen, got, want);
            if (want) hits++;
            else misses++;
        }
    }
    CHECK(hits > 100 && misses > 100, "dim %d cap %u: both answers occur (%d, %d)", dim, cap, hits,
          misses);
    free(pts);
    recent_free(&ring);
    tree_free(&t);
}

int main(void)
{
    const uint32_t caps[] = {1, 7, 64, 4096};
    for (int dim = 2; dim <= 3; dim++)
        for (int c = 0; c < 4; c++) test_ring(dim, caps[c], 100 + (uint64_t)(dim * 10 + c));
    return check_finish();
}
