/*
 * test_reference.c - the race-free reference of PDLA (reference_walkers,
 * src/reference.c), 2D and 3D:
 *  - P = 1 after a serial prefix is serial DLA bit for bit: the same
 *    positions, R_g samples and jump count as a serial run;
 *  - P = 8 is deterministic: the same seed gives the same cluster twice,
 *    and it differs from the serial one;
 *  - P = 8 clusters obey the invariants: exactly `target` particles, no two
 *    closer than D, walkers whose spot was taken were counted (re-checks),
 *    and with --recheck discard some were discarded.
 */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pdla/pdla.h"

#include "positions.h"

typedef struct result {
    positions pos;
    double *rg;
    size_t rg_count;
    pdla_stats s;
} result;

static result grow(int dim, uint64_t target, int refs, pdla_recheck_mode recheck, uint64_t seed)
{
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = target;
    P.seed = seed;
    P.serial_until = target / 10;
    P.reference_walkers = refs;
    P.recheck = recheck;
    result r;
    memset(&r, 0, sizeof r);
    r.pos.dim = dim;
    pdla_engine *e;
    char err[256];
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    CHECK(pdla_engine_grow(e, target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "grow: %s", err);
    CHECK(pdla_engine_visit(e, grab, &r.pos) == 0, "out of memory gathering the positions");
    const uint64_t *n;
    const double *rg;
    pdla_engine_rg_series(e, &n, &rg, &r.rg_count);
    r.rg = malloc(r.rg_count * sizeof *r.rg + 1);
    memcpy(r.rg, rg, r.rg_count * sizeof *r.rg);
    pdla_engine_stats(e, &r.s);
    pdla_engine_destroy(e);
    return r;
}

static int same(const result *a, const result *b)
{
    return a->pos.n == b->pos.n && !memcmp(a->pos.x, b->pos.x, a->pos.n * (size_t)a->pos.dim * 4) &&
           a->rg_count == b->rg_count && !memcmp(a->rg, b->rg, a->rg_count * sizeof *a->rg) &&
           a->s.jumps == b->s.jumps;
}

static void drop(result *r)
{
    free(r->pos.x);
    free(r->rg);
}

/* Smallest squared centre distance (brute force; a few thousand particles). */
static uint64_t min_d2(const positions *p)
{
    uint64_t best = UINT64_MAX;
    for (size_t i = 0; i < p->n; i++)
        for (size_t j = i + 1; j < p->n; j++) {
            uint64_t d2 = 0;
            for (int a = 0; a < p->dim; a++) {
                const int64_t d = (int64_t)p->x[i * (size_t)p->dim + (size_t)a] -
                                  p->x[j * (size_t)p->dim + (size_t)a];
                d2 += (uint64_t)(d * d);
            }
            if (d2 < best) best = d2;
        }
    return best;
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        const uint64_t N = dim == 2 ? 4000 : 2500;
        result serial = grow(dim, N, 0, PDLA_RECHECK_CONTINUE, 21);
        result one = grow(dim, N, 1, PDLA_RECHECK_CONTINUE, 21);
        CHECK(same(&serial, &one), "%dD: reference with 1 walker equals serial DLA bit for bit", dim);
        result a = grow(dim, N, 8, PDLA_RECHECK_CONTINUE, 21);
        result b = grow(dim, N, 8, PDLA_RECHECK_CONTINUE, 21);
        CHECK(same(&a, &b), "%dD: reference with 8 walkers is deterministic", dim);
        CHECK(!same(&a, &serial), "%dD: 8 walkers grow another cluster than 1", dim);
        CHECK(a.s.particles == N && a.pos.n == N, "%dD: exactly %llu particles", dim,
              (unsigned long long)N);
        CHECK(min_d2(&a.pos) >= 32 * 32, "%dD: no two centres closer than D", dim);
        CHECK(a.s.recheck_overlaps > 0 && a.s.recheck_continued > 0,
              "%dD: spots taken by another walker happen (%llu) and continue (%llu)", dim,
              (unsigned long long)a.s.recheck_overlaps, (unsigned long long)a.s.recheck_continued);
        CHECK(a.s.threads == 0 && a.s.stale_jumps == 0, "%dD: one thread, no stale reads", dim);
        result d = grow(dim, N, 8, PDLA_RECHECK_DISCARD, 21);
        CHECK(d.s.particles == N && min_d2(&d.pos) >= 32 * 32, "%dD: discard mode: count, overlaps",
              dim);
        CHECK(d.s.recheck_discarded == d.s.recheck_overlaps && d.s.recheck_discarded > 0,
              "%dD: discard mode discards every taken spot (%llu of %llu)", dim,
              (unsigned long long)d.s.recheck_discarded, (unsigned long long)d.s.recheck_overlaps);
        drop(&serial);
        drop(&one);
        drop(&a);
        drop(&b);
        drop(&d);
    }
    return check_finish();
}
