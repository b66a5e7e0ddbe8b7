/*
 * test_gyration_order.c - the R_g sums count particles in arrival order
 * whatever order the workers bring them in (engine.c
 * engine_gyration_add_at): one engine is fed indices in order, another the
 * same particles with indices shuffled in windows of up to 300 and one
 * particle held back while 3000 later ones arrive (a worker descheduled
 * between its append and its turn at the gyration mutex). The R_g series
 * (counts and values), the sums, R_ext and the arrival record must be equal
 * bit for bit. An index counted twice is an error. Without the reordering
 * (engine.c before it) the shuffled series differs in most samples.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine.h"

#define N_ADD 20000u

static pdla_engine *make(void)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = 3;
    p.target = 1000000;
    p.record_arrival = 1;
    p.rg_per_decade = 100;
    char err[256];
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &p, err, sizeof err) == PDLA_OK, "create: %s", err);
    return e;
}

/* A deterministic spread of points (not a DLA cluster: the sums do not
 * care), distinct so every sample moves. */
static void point(uint64_t i, int64_t *x)
{
    uint64_t h = i * 0x9E3779B97F4A7C15ull;
    for (int a = 0; a < 3; a++) {
        h ^= h >> 29;
        h *= 0xBF58476D1CE4E5B9ull;
        x[a] = (int64_t)(h % 200001) - 100000;
    }
}

int main(void)
{
    pdla_engine *a = make(), *b = make();
    if (!a || !b) return check_finish();
    const uint64_t base = a->gyr.n;
    uint64_t *order = malloc(N_ADD * sizeof *order);
    for (uint64_t i = 0; i < N_ADD; i++) order[i] = base + i;
    /* Shuffle within windows of 300 (a fixed LCG). */
    uint64_t s = 12345;
    for (uint64_t w = 0; w + 300 <= N_ADD; w += 300)
        for (uint64_t i = 299; i > 0; i--) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            const uint64_t j = (s >> 33) % (i + 1);
            const uint64_t t = order[w + i];
            order[w + i] = order[w + j], order[w + j] = t;
        }
    /* One particle held back past 3000 later ones. */
    const uint64_t held = order[5000];
    memmove(order + 5000, order + 5001, 3000 * sizeof *order);
    order[8000] = held;
    char err[256];
    int64_t x[3];
    for (uint64_t i = 0; i < N_ADD; i++) {
        point(base + i, x);
        CHECK(engine_gyration_add_at(a, x, base + i, err, sizeof err) == PDLA_OK, "in order: %s", err);
        point(order[i], x);
        CHECK(engine_gyration_add_at(b, x, order[i], err, sizeof err) == PDLA_OK, "shuffled: %s", err);
    }
    CHECK(a->gyr.n == b->gyr.n && a->gyr.n == base + N_ADD, "counts %llu %llu",
          (unsigned long long)a->gyr.n, (unsigned long long)b->gyr.n);
    CHECK(memcmp(&a->gyr, &b->gyr, sizeof a->gyr) == 0 && a->r_ext2 == b->r_ext2, "sums differ");
    CHECK(a->rg_count == b->rg_count && a->rg_count > 300, "samples %zu %zu", a->rg_count, b->rg_count);
    size_t differ = 0;
    for (size_t k = 0; k < a->rg_count && k < b->rg_count; k++)
        differ += a->rg_n[k] != b->rg_n[k] || a->rg_diam[k] != b->rg_diam[k];
    CHECK(differ == 0, "%zu of %zu R_g samples differ", differ, a->rg_count);
    uint64_t na = 0, nb = 0;
    const int32_t *ra = pdla_engine_arrival(a, &na), *rb = pdla_engine_arrival(b, &nb);
    CHECK(na == nb && ra && rb && memcmp(ra, rb, (size_t)na * 3 * sizeof *ra) == 0, "arrival records differ");
    /* An index already counted. */
    point(0, x);
    CHECK(engine_gyration_add_at(b, x, base, err, sizeof err) != PDLA_OK, "a repeated index was taken");
    free(order);
    pdla_engine_destroy(a);
    pdla_engine_destroy(b);
    return check_finish();
}
