/*
 * test_arrival_order.c - with worker threads, --arrival lists a particle
 * after the particle it stuck to. The row used to be written where the
 * gyration sums grow, after the bucket mutex was released, so a worker
 * descheduled between its append and the sums was overtaken by others (an
 * adversarial test saw a particle listed ~250 rows before its contact). Here
 * the `inserted` hook, called in that gap, makes every 5th insertion wait
 * 2 ms, so others overtake it for sure; every row past the seed must have an
 * earlier row within D + eps, and the rows must be the tree's particles.
 * 2D and 3D, 3 workers. Also under TSan (suite threads).
 */
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "engine.h"
#include "pdla/pdla.h"

static void slow_every_5th(void *user, uint64_t index, const int64_t *p, uint64_t lag)
{
    (void)user, (void)p, (void)lag;
    if (index % 5 == 0) nanosleep(&(struct timespec){0, 2000000}, NULL);
}

typedef struct {
    int64_t sum[3];
    uint64_t n;
    int dim;
} tally;

static int add_up(const int32_t *xyz, size_t n, void *user)
{
    tally *t = user;
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < t->dim; a++) t->sum[a] += xyz[(size_t)t->dim * i + (size_t)a];
    t->n += n;
    return 0;
}

static void order_case(int dim)
{
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = dim == 2 ? 1500 : 800;
    P.seed = 9;
    P.threads = 3;
    P.serial_until = 10;
    P.record_arrival = 1;
    char err[256];
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    if (!e) return;
    engine_hooks h;
    memset(&h, 0, sizeof h);
    h.inserted = slow_every_5th;
    e->hooks = &h;
    CHECK(pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "grow: %s", err);
    e->hooks = NULL;
    uint64_t n = 0;
    const int32_t *a = pdla_engine_arrival(e, &n);
    const int64_t reach = P.resolution + P.eps;
    uint64_t bad = 0;
    tally rows = {{0, 0, 0}, 0, dim}, visited = {{0, 0, 0}, 0, dim};
    for (uint64_t i = 0; a && i < n; i++) {
        for (int k = 0; k < dim; k++) rows.sum[k] += a[i * (uint64_t)dim + (uint64_t)k];
        rows.n++;
        if (i == 0) continue;
        int64_t best = INT64_MAX;
        for (uint64_t j = 0; j < i; j++) {
            int64_t d2 = 0;
            for (int k = 0; k < dim; k++) {
                const int64_t d = (int64_t)a[i * (uint64_t)dim + (uint64_t)k] - a[j * (uint64_t)dim + (uint64_t)k];
                d2 += d * d;
            }
            if (d2 < best) best = d2;
        }
        bad += best >= reach * reach;
    }
    pdla_engine_visit(e, add_up, &visited);
    CHECK(n == P.target && bad == 0, "%dD: %llu rows, %llu without an earlier row within D + eps", dim,
          (unsigned long long)n, (unsigned long long)bad);
    CHECK(rows.n == visited.n && !memcmp(rows.sum, visited.sum, sizeof rows.sum),
          "%dD: the rows are not the tree's particles (%llu against %llu)", dim, (unsigned long long)rows.n,
          (unsigned long long)visited.n);
    pdla_engine_destroy(e);
}

int main(void)
{
    order_case(2);
    order_case(3);
    return check_finish();
}
