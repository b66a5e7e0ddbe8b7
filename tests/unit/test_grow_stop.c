/*
 * test_grow_stop.c - a stop asked through the progress callback only ever
 * cuts growth short: the callback is not called once the cluster holds
 * n_until particles, so a callback that always asks to stop at the end
 * (a signal in the last `every` particles) leaves growth complete and
 * PDLA_OK; one that asks earlier stops there with PDLA_ESTOPPED. Serial
 * growth and the reference walkers after a serial phase of 500 (the two
 * loops that call it per particle count; the threaded phase calls it on a
 * timer, not tested here).
 */
#include <stdint.h>
#include "check.h"
#include "pdla/pdla.h"

typedef struct {
    uint64_t stop_from; /* ask to stop at counts >= this */
    uint64_t calls, last;
} probe;

static int on_progress(const pdla_engine *e, void *user)
{
    probe *pr = user;
    pr->calls++;
    pr->last = pdla_engine_count(e);
    return pr->last >= pr->stop_from;
}

static void grow_case(int dim, int reference_walkers, uint64_t stop_from, int want_rc, uint64_t want_count)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.target = 3000;
    p.seed = 7;
    p.reference_walkers = reference_walkers;
    /* With reference walkers, the serial phase ends early so that the
     * reference loop (reference_grow) reaches the target. */
    if (reference_walkers) p.serial_until = 500;
    char err[256];
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &p, err, sizeof err) == PDLA_OK, "%s", err);
    if (!e) return;
    probe pr = {stop_from, 0, 0};
    const int rc = pdla_engine_grow(e, p.target, on_progress, 1000, &pr, err, sizeof err);
    const unsigned long long n = pdla_engine_count(e);
    CHECK(rc == want_rc && n == want_count, "dim %d, reference walkers %d, stop from %llu: rc %d (%s), %llu particles",
          dim, reference_walkers, (unsigned long long)stop_from, rc, rc ? err : "ok", n);
    CHECK(pr.last < p.target, "called with the cluster complete (%llu), dim %d", (unsigned long long)pr.last, dim);
    pdla_engine_destroy(e);
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        for (int ref = 0; ref <= 2; ref += 2) {
            grow_case(dim, ref, 3000, PDLA_OK, 3000);       /* a stop at the end: nothing to stop */
            grow_case(dim, ref, 2000, PDLA_ESTOPPED, 2000); /* earlier: it stops there */
        }
    }
    return check_finish();
}
