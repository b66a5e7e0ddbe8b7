/*
 * test_pool_huge.c - the tree pools' slabs and huge pages (tree.c).
 *
 * A checkpoint load gives a pool segments from calloc (checkpoint_read.c)
 * between the first slab segment and the ones pool_new adds later. The
 * slab places of those segments are never written, so they must stay
 * non-resident: a huge page collapsed over them would add up to 2 MiB of
 * resident memory each. The test builds that layout, grows the pool past
 * several 2 MiB pages and checks with mincore that
 *   - the unused slab places stay non-resident (fails if pool_huge_done
 *     ignored huge_from: the page at 4..6 MiB straddles it);
 *   - the records written read back (contents survive the collapse);
 *   - where the kernel has MADV_COLLAPSE (Linux >= 6.1, probed first), the
 *     fully written pages became huge pages (AnonHugePages in smaps).
 * Under ASan the tree_free at the end checks that calloc'd segments are
 * freed and slab segments are not (an invalid free or a leak fails).
 */
#include "check.h"
#include "tree.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#ifndef MADV_COLLAPSE
#define MADV_COLLAPSE 25
#endif

/* Resident 4 KiB pages in [p, p + bytes). */
static size_t resident_pages(const uint8_t *p, size_t bytes)
{
    const size_t pg = (size_t)sysconf(_SC_PAGESIZE);
    const size_t n = (bytes + pg - 1) / pg;
    unsigned char *v = malloc(n);
    size_t r = 0;
    if (v && mincore((void *)p, bytes, v) == 0)
        for (size_t i = 0; i < n; i++) r += v[i] & 1;
    free(v);
    return r;
}

/* AnonHugePages (kB) of the mapping that holds address a. */
static long huge_kb_at(const void *a)
{
    FILE *f = fopen("/proc/self/smaps", "r");
    if (!f) return -1;
    char line[256];
    int in = 0;
    long kb = -1;
    while (fgets(line, sizeof line, f)) {
        unsigned long lo, hi;
        if (sscanf(line, "%lx-%lx ", &lo, &hi) == 2 && strchr(line, '-') < strchr(line, ' ')) {
            in = (uintptr_t)a >= lo && (uintptr_t)a < hi;
            continue;
        }
        if (in && sscanf(line, "AnonHugePages: %ld kB", &kb) == 1) break;
    }
    fclose(f);
    return kb;
}

/* Whether this kernel collapses a resident 2 MiB page on request. */
static int collapse_works(void)
{
    uint8_t *m = pool_map(POOL_HUGE_PAGE);
    if (!m) return 0;
    memset(m, 1, POOL_HUGE_PAGE);
    const int ok = madvise(m, POOL_HUGE_PAGE, MADV_COLLAPSE) == 0 && huge_kb_at(m) >= 2048;
    pool_unmap(m, POOL_HUGE_PAGE);
    return ok;
}

static void test_checkpoint_layout(void)
{
    tree t;
    CHECK(tree_init(&t, 2) == 0, "tree_init");
    tree_pool *p = &t.chunks;
    const size_t seg = (size_t)POOL_SEG_SIZE * p->elem; /* 1.5 MiB in 2D */
    /* What read_pool does: segments 1 and 2 from calloc, filled. */
    for (uint32_t s = 1; s <= 2; s++) {
        p->seg[s] = calloc(POOL_SEG_SIZE, p->elem);
        CHECK(p->seg[s] != NULL, "calloc");
        if (!p->seg[s]) return;
        memset(p->seg[s], 0x5a, seg);
        p->nseg = s + 1;
    }
    p->count = 3 * POOL_SEG_SIZE - 100; /* the load ends in segment 2 */
    /* New leaves, one chunk each: 4 more segments' worth of chunks. */
    const uint32_t first = p->count;
    int bad = 0;
    for (int64_t i = 0; i < 520 && !bad; i++)
        for (int64_t j = 0; j < 520; j++) {
            const int64_t q[2] = {(i - 260) * TREE_LEAF_SIDE + i % 7, (j - 260) * TREE_LEAF_SIDE};
            if (tree_insert(&t, q)) {
                bad = 1;
                break;
            }
        }
    CHECK(!bad, "insert");
    CHECK(p->nseg >= 6, "only %u segments", p->nseg);
    const uint8_t *slab = p->slab[0];
    CHECK(slab && p->seg[0] == slab && p->seg[3] == slab + 3 * seg, "segments 0 and 3 in slab 0");
    /* Slab 0 at 1.5..4.5 MiB: the places of the calloc'd segments. Segment
     * 3, written throughout, makes the page at 4..6 MiB complete above
     * huge_from (4.5 MiB) only, so it must not be collapsed. */
    CHECK(resident_pages(slab + seg, 2 * seg) == 0, "%zu pages resident where no segment lives",
          resident_pages(slab + seg, 2 * seg));
    /* Each new leaf's first chunk holds its particle: x relative to the leaf. */
    int wrong = 0;
    for (uint32_t c = first; c < p->count; c++) {
        const uint8_t *rec = tree_chunk_at(&t, c);
        if (tree_chunk_link(&t, rec) != 1 || rec[0] >= 7) wrong++;
    }
    CHECK(wrong == 0, "%d chunks read back wrong", wrong);
    if (collapse_works()) {
        /* 6..8 MiB of slab 0 lies in segments 4 and 5, written throughout. */
        CHECK(huge_kb_at(slab + 6 * ((size_t)1 << 20)) >= 2048, "no huge page in a written 2 MiB page");
    } else {
        fprintf(stderr, "note: MADV_COLLAPSE unavailable (errno %d); huge page check not run\n", errno);
    }
    tree_free(&t);
}

int main(void)
{
    test_checkpoint_layout();
    return check_finish();
}
