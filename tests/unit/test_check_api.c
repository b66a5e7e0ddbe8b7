/*
 * test_check_api.c - pdla_check_* (include/pdla/pdla.h) through the public
 * API on hand-made rows: a clean chain passes in both orders; an overlap,
 * a detached row, a coordinate at 2^28 and a missing seed are counted;
 * pdla_check_missing matches each added row once (a multiset: a tree row
 * repeated in place of another is missing), which `pdla check` relies on to
 * hold a checkpoint's tree against its arrival record.
 */
#include <stdint.h>

#include "check.h"
#include "pdla/pdla.h"

static pdla_check_report run(const int32_t *xy, size_t n, int arrival)
{
    pdla_check *c = NULL;
    pdla_check_report r = {0};
    char err[256];
    CHECK(pdla_check_create(&c, 2, 32, 2, arrival, err, sizeof err) == PDLA_OK, "create: %s", err);
    if (!c) return r;
    CHECK(pdla_check_add(c, xy, n, err, sizeof err) == PDLA_OK, "add: %s", err);
    CHECK(pdla_check_finish(c, 1, &r, err, sizeof err) == PDLA_OK, "finish: %s", err);
    pdla_check_destroy(c);
    return r;
}

int main(void)
{
    const int32_t chain[] = {0, 0, 32, 0, 64, 0, 64, 33};
    pdla_check_report r = run(chain, 4, 1);
    CHECK(r.overlaps == 0 && r.detached == 0 && r.seed_at_origin && r.particles == 4, "chain, arrival");
    r = run(chain, 4, 0);
    CHECK(r.overlaps == 0 && r.detached == 0 && r.seed_at_origin, "chain, tree order");
    const int32_t overlap[] = {0, 0, 32, 0, 63, 0};
    r = run(overlap, 3, 1);
    CHECK(r.overlaps == 1 && r.first_overlap.row == 2, "overlap: %llu", (unsigned long long)r.overlaps);
    const int32_t far[] = {0, 0, 32, 0, 99, 0};
    r = run(far, 3, 1);
    CHECK(r.detached == 1 && r.first_detached.row == 2, "detached: %llu", (unsigned long long)r.detached);
    const int32_t limit[] = {0, 0, 32, 0, 1 << 28, 0};
    r = run(limit, 3, 1);
    CHECK(r.out_of_range == 1, "x = 2^28 taken");
    const int32_t noseed[] = {32, 0, 64, 0};
    r = run(noseed, 2, 0);
    CHECK(!r.seed_at_origin, "no seed: taken");
    /* Multiset matching. */
    pdla_check *c = NULL;
    char err[256];
    CHECK(pdla_check_create(&c, 2, 32, 2, 0, err, sizeof err) == PDLA_OK, "create");
    if (c) {
        CHECK(pdla_check_add(c, chain, 4, err, sizeof err) == PDLA_OK, "add");
        const int32_t twice[] = {0, 0, 0, 0, 64, 0, 64, 33};
        CHECK(pdla_check_missing(c, twice, 4) == 1, "a repeated row matched twice");
        pdla_check_destroy(c);
    }
    CHECK(pdla_check_create(&c, 2, 32, 2, 0, err, sizeof err) == PDLA_OK, "create");
    if (c) {
        CHECK(pdla_check_add(c, chain, 4, err, sizeof err) == PDLA_OK, "add");
        const int32_t same[] = {64, 33, 0, 0, 64, 0, 32, 0};
        CHECK(pdla_check_missing(c, same, 2) == 0 && pdla_check_missing(c, same + 4, 2) == 0,
              "the same rows in another order, over two calls");
        CHECK(pdla_check_missing(c, same, 1) == 1, "a row matched a second time");
        pdla_check_destroy(c);
    }
    return check_finish();
}
