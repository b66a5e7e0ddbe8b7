/*
 * test_distmap.c - the coarse distance map against brute-force references,
 * 2D and 3D, on random clusters that make the grid grow several times:
 *  - its bound is never above the true distance to the nearest particle,
 *    and a non-zero bound is at least one fine cell (above D + eps);
 *  - every cell of both levels holds exactly the capped chessboard distance
 *    to the nearest occupied cell (brute force over the occupied cells);
 *  - search_block2 (the leaves around a walker, cached from query to query
 *    while the cluster grows) is never above the true distance and exact
 *    below one leaf;
 *  - search_nearest_point_cached (leaves from the walker's cached path)
 *    gives what search_nearest_point gives, and finds the true nearest
 *    within the reach; in 2D, search_ball_points2 returns exactly the
 *    particles within its radius (brute force), and the first nearest of
 *    them within the reach is the search's;
 *  - a walker's cached block stays right while the grid grows under it;
 *  - the same with a small memory budget, where the fine cells coarsen
 *    while the grid grows; in 2D the block search then reads the leaf bits
 *    (one per leaf), each set exactly where a particle lies (brute
 *    force), and answers beyond the block from them: a bound, checked
 *    like every other, and equal to the brute-force Euclidean distance
 *    to the nearest particle's leaf box within the walker's 24 x 24
 *    leaves (or to their edge; the square follows DISTMAP_LEAF_REACH), never below the chessboard ring bound;
 *  - distmap_rebuild from the tree gives the same cells as the map built one
 *    particle at a time, and the same bounds.
 * Fixed seeds; a failure prints the seed, point and both values.
 */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "distmap.h"
#include "rng.h"
#include "search.h"
#include "tree.h"

static int64_t rand_range(pdla_rng *r, int64_t lo, int64_t hi)
{
    return lo + (int64_t)(rng_next(r) % (uint64_t)(hi - lo + 1));
}

static uint64_t brute(const int64_t (*pts)[3], size_t n, int dim, const int64_t *q)
{
    uint64_t best = UINT64_MAX;
    for (size_t i = 0; i < n; i++) {
        uint64_t d2 = 0;
        for (int a = 0; a < dim; a++) {
            const int64_t d = q[a] - pts[i][a];
            d2 += (uint64_t)(d * d);
        }
        if (d2 < best) best = d2;
    }
    return best;
}

/* The gap in units from offset o (0..255) in a leaf to the leaf d leaves on
 * (d != 0); written apart from search.c's. */
static int64_t gap_ref(int64_t d, int64_t o)
{
    return d > 0 ? d * 256 - o : (-d - 1) * 256 + o + 1;
}

/* What block_bits2's leaf bound must answer at p (2D, coarsened, no tile
 * dropped), by brute force over the particles: UINT64_MAX when a particle
 * lies in the 3 x 3 leaves around p's (the block scan answers then); else
 * the squared Euclidean distance from p to the nearest box of a leaf that
 * holds a particle within the square of 8 LB_WORDS leaves (24 by default)
 * around p's word of 8 x 8 leaves, or to the outside of the square if
 * nearer. *chess2: the
 * chessboard ring bound the code gave before (distmap_block_bound with the
 * ring of the nearest such leaf, at most 9). */
static uint64_t leaf_bound_ref(const int64_t (*pts)[3], size_t n, const int64_t *p, uint64_t *chess2)
{
    const int64_t lx = p[0] >> 8, ly = p[1] >> 8, ox = p[0] & 255, oy = p[1] & 255;
    /* The window: words within LB_RING of p's, nw leaves a side. */
    const int64_t nw = 8 * LB_WORDS, x0 = ((lx >> 3) - LB_RING) * 8, y0 = ((ly >> 3) - LB_RING) * 8;
    int64_t cap = gap_ref(x0 - 1 - lx, ox);
    const int64_t c[3] = {gap_ref(x0 + nw - lx, ox), gap_ref(y0 - 1 - ly, oy), gap_ref(y0 + nw - ly, oy)};
    for (int i = 0; i < 3; i++)
        if (c[i] < cap) cap = c[i];
    uint64_t best = (uint64_t)(cap * cap);
    int64_t ring = 9;
    for (size_t i = 0; i < n; i++) {
        const int64_t dx = (pts[i][0] >> 8) - lx, dy = (pts[i][1] >> 8) - ly;
        const int64_t adx = dx < 0 ? -dx : dx, ady = dy < 0 ? -dy : dy;
        if (adx <= 1 && ady <= 1) return UINT64_MAX;
        const int64_t v = adx > ady ? adx : ady;
        if (v < ring) ring = v;
        if (lx + dx < x0 || lx + dx >= x0 + nw || ly + dy < y0 || ly + dy >= y0 + nw) continue;
        const int64_t gx = dx ? gap_ref(dx, ox) : 0, gy = dy ? gap_ref(dy, oy) : 0;
        const uint64_t d2 = (uint64_t)(gx * gx + gy * gy);
        if (d2 < best) best = d2;
    }
    const int64_t b = distmap_block_bound(p, 8, ring, 2);
    *chess2 = (uint64_t)(b * b);
    return best;
}

/* The leaf bits of a coarsened 2D grid against brute force: set exactly on
 * the leaves that hold a particle, over the whole grid, except in tiles
 * dropped as interior (counted in *unknown). Returns the number of wrong
 * leaves. */
static int check_leafbits(const distmap *m, const int64_t (*pts)[3], size_t n, int *unknown)
{
    const distmap_grid *g = atomic_load(&m->grid);
    if (!g || !g->tix) return 0;
    const int64_t q0 = -g->half >> DISTMAP_LEAFBIT_SHIFT, nq = (2 * g->half) >> DISTMAP_LEAFBIT_SHIFT;
    unsigned char *want = calloc((size_t)(nq * nq), 1);
    for (size_t i = 0; i < n; i++)
        want[((pts[i][1] >> DISTMAP_LEAFBIT_SHIFT) - q0) * nq + (pts[i][0] >> DISTMAP_LEAFBIT_SHIFT) - q0] = 1;
    int bad = 0;
    for (int64_t y = 0; y < nq; y++)
        for (int64_t x = 0; x < nq; x++) {
            const int64_t ax = x + q0, ay = y + q0;
            int unk = 0;
            const uint64_t word = distmap_leaf_word(m, g, ax >> 3, ay >> 3, &unk);
            const int got = (int)((word >> ((ay & 7) * 8 + (ax & 7))) & 1);
            if (unk) {
                ++*unknown;
                continue;
            }
            if (got != want[y * nq + x] && bad++ < 5)
                fprintf(stderr, "leaf %lld %lld: bit %d, want %d\n", (long long)ax, (long long)ay, got,
                        want[y * nq + x]);
        }
    free(want);
    return bad;
}

static unsigned level_at(const distmap_level *L, int dim, const int64_t *c)
{
    return distmap_level_value(L, c, dim);
}

/* Every cell of level l against the brute-force capped chessboard distance. */
static int check_cells(const distmap_grid *g, int l, int dim, const int64_t (*pts)[3], size_t n)
{
    const distmap_level *L = &g->lv[l];
    const int64_t w = L->width;
    int64_t *occ = malloc(n * 3 * sizeof *occ);
    size_t nocc = 0;
    for (size_t i = 0; i < n; i++) {
        int64_t c[3] = {0, 0, 0};
        for (int a = 0; a < dim; a++) c[a] = (pts[i][a] + g->half) >> L->bits;
        size_t j = 0; /* the walks revisit cells: keep each once */
        while (j < nocc && (occ[j * 3] != c[0] || occ[j * 3 + 1] != c[1] || occ[j * 3 + 2] != c[2]))
            j++;
        if (j < nocc) continue;
        for (int a = 0; a < 3; a++) occ[nocc * 3 + a] = c[a];
        nocc++;
    }
    n = nocc;
    int bad = 0;
    for (int64_t z = 0; z < (dim == 3 ? w : 1); z++)
        for (int64_t y = 0; y < w; y++)
            for (int64_t x = 0; x < w; x++) {
                const int64_t c[3] = {x, y, z};
                int64_t best = L->cap;
                for (size_t i = 0; i < n; i++) {
                    int64_t d = 0;
                    for (int a = 0; a < dim; a++) {
                        const int64_t e = llabs(c[a] - occ[i * 3 + a]);
                        if (e > d) d = e;
                    }
                    if (d < best) best = d;
                }
                if ((int64_t)level_at(L, dim, c) != best && bad++ < 5)
                    fprintf(stderr, "level %d cell %lld %lld %lld: %u, want %lld\n", l,
                            (long long)x, (long long)y, (long long)z, level_at(L, dim, c),
                            (long long)best);
            }
    free(occ);
    return bad;
}

/* A random cluster: a few random walks with steps of about one diameter
 * (D = 32), reaching out several hundred diameters so the grid grows. */
static void test_cluster(int dim, size_t n, uint64_t seed, int exact_cells, size_t budget,
                         double interior)
{
    pdla_rng r;
    rng_seed(&r, seed);
    tree t;
    CHECK(tree_init(&t, dim) == 0, "tree_init");
    distmap m;
    distmap_init(&m, dim, 8, 2 * 32 + 8 * 256);
    if (budget) { /* a small budget: the fine cells coarsen as the grid grows */
        m.budget_min = budget;
        m.budget_per_particle = 0.0;
        m.leaf_interior = interior; /* 2D: interior tiles dropped */
    } else { /* leaf cells throughout, whatever the random cluster's extent */
        m.budget_min = (size_t)1 << 30;
    }
    if (dim == 3) m.near_min = 4 * 32; /* the engine's, at resolution 32 */
    int near_answers = 0;
    int64_t(*pts)[3] = calloc(n, sizeof *pts);
    int64_t cur[3] = {0, 0, 0};
    int bad_bound = 0, bad_min = 0, useful = 0, bad_block = 0, block_used = 0, ball_scans = 0;
    int far_bits = 0, leaf_bounds = 0;
    search_config cfg;
    search_config_init(&cfg, 2.0, 32, 2);
    search_config exact;
    search_config_init(&exact, 0.0, 32, 2);
    search_state ss;
    search_state_reset(&ss);
    int64_t walker[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        if (i % 97 == 0) /* jump to an earlier particle: branches */
            for (int a = 0; a < dim; a++) cur[a] = pts[rng_next(&r) % (i ? i : 1)][a];
        const int64_t step = (i % 500 < 20) ? 3000 : 40;
        for (int a = 0; a < dim; a++) cur[a] += rand_range(&r, -step, step);
        for (int a = 0; a < dim; a++) pts[i][a] = cur[a];
        distmap_add(&m, cur, i + 1, 0);
        CHECK(tree_insert(&t, cur) == 0, "insert");
        /* The block search from a walker-like cursor: never above the true
         * distance, exact whenever that is below one leaf (so always where
         * sticking is decided). */
        for (int q = 0; q < 4; q++) {
            for (int a = 0; a < dim; a++) walker[a] += rand_range(&r, -150, 150);
            if (q == 0)
                for (int a = 0; a < dim; a++) walker[a] = cur[a] + rand_range(&r, -700, 700);
            const uint64_t b2 = search_block2(&t, &cfg, &m, walker, &ss);
            const uint64_t truth = brute(pts, i + 1, dim, walker);
            /* The tree search shares the walker's path cache. */
            if (search_lower_bound2(&t, &exact, walker, UINT64_MAX, &ss) != truth && bad_block++ < 5)
                fprintf(stderr, "dim %d seed %llu n %zu: exact tree search wrong after block\n",
                        dim, (unsigned long long)seed, i + 1);
            /* The nearest point within a contact reach, from the cached path
             * and from the root: the same answer. */
            {
                int64_t q1[3] = {0, 0, 0}, q2[3] = {0, 0, 0};
                uint64_t e1 = 0, e2 = 0;
                const uint64_t reach2 = (uint64_t)(rand_range(&r, 1, 255) * rand_range(&r, 1, 255));
                const int f1 = search_nearest_point_cached(&t, walker, reach2, q1, &e1, &ss);
                const int f2 = search_nearest_point(&t, walker, reach2, q2, &e2);
                int same = f1 == f2 && (!f1 || e1 == e2);
                for (int a = 0; f1 && a < dim; a++) same &= q1[a] == q2[a];
                if (!same && bad_block++ < 5)
                    fprintf(stderr, "dim %d: cached nearest point differs\n", dim);
                if (f2 && (e2 > truth || e2 >= reach2) && bad_block++ < 5)
                    fprintf(stderr, "dim %d: nearest point %llu vs true %llu\n", dim,
                            (unsigned long long)e2, (unsigned long long)truth);
                if (!f2 && truth < reach2 && bad_block++ < 5)
                    fprintf(stderr, "dim %d: nearest point missed\n", dim);
                /* 2D: one scan of the particles within far of the walker
                 * (contact snapping): exactly the brute-force set, and its
                 * first nearest within the reach is the search's. */
                if (dim == 2) {
                    const int64_t rr = (int64_t)ceil(sqrt((double)reach2)), far = rr + rand_range(&r, 0, 255 - rr);
                    search_point sp[64];
                    const int got = search_ball_points2(&t, walker, reach2, (uint64_t)(far * far), sp, 64, &ss);
                    int within = 0, first = -1, wrong = 0;
                    for (size_t j = 0; j <= i; j++) {
                        const int64_t dx = pts[j][0] - walker[0], dy = pts[j][1] - walker[1];
                        within += (uint64_t)(dx * dx + dy * dy) < (uint64_t)(far * far);
                    }
                    for (int j = 0; j < got; j++) {
                        const int64_t dx = sp[j].x[0] - walker[0], dy = sp[j].x[1] - walker[1];
                        wrong += sp[j].d2 != (uint64_t)(dx * dx + dy * dy) || sp[j].d2 >= (uint64_t)(far * far);
                        if (sp[j].d2 < reach2 && (first < 0 || sp[j].d2 < sp[first].d2)) first = j;
                    }
                    if (got >= 0) {
                        ball_scans++;
                        if (got != within || wrong) {
                            if (bad_block++ < 5)
                                fprintf(stderr, "ball scan: %d points, brute force %d, %d wrong\n",
                                        got, within, wrong);
                        } else if ((first >= 0) != f2 ||
                                   (f2 && (sp[first].x[0] != q2[0] || sp[first].x[1] != q2[1]))) {
                            if (bad_block++ < 5) fprintf(stderr, "ball scan: nearest differs\n");
                        }
                    } else if (within <= 64 && bad_block++ < 5) {
                        fprintf(stderr, "ball scan refused %d points (cap 64)\n", within);
                    }
                }
            }
            if (b2 == UINT64_MAX) continue;
            block_used++;
            far_bits += b2 > 512 * 512; /* >= 2 empty leaves all round: from the leaf bits */
            if (dim == 2 && budget) {
                const distmap_grid *gq = atomic_load(&m.grid);
                uint64_t chess2 = 0;
                const uint64_t want = gq && gq->lv[0].bits > 8 ? leaf_bound_ref(pts, i + 1, walker, &chess2)
                                                               : UINT64_MAX;
                if (want != UINT64_MAX) {
                    leaf_bounds++;
                    if ((b2 != want || b2 < chess2) && bad_block++ < 5)
                        fprintf(stderr, "seed %llu n %zu: leaf bound %.1f, brute force %.1f, chessboard %.1f\n",
                                (unsigned long long)seed, i + 1, sqrt((double)b2), sqrt((double)want),
                                sqrt((double)chess2));
                }
            }
            if ((b2 > truth || (truth < 256 * 256 && b2 != truth)) && bad_block++ < 5)
                fprintf(stderr, "dim %d seed %llu n %zu: block %.1f, true %.1f\n", dim,
                        (unsigned long long)seed, i + 1, sqrt((double)b2), sqrt((double)truth));
        }
        if (i % 50 != 49) continue;
        /* Leaf bounds from points up to ~20 leaves off the cluster (a
         * walker of its own each), where the square's edge can decide. */
        if (dim == 2 && budget) {
            const distmap_grid *gq = atomic_load(&m.grid);
            for (int q = 0; gq && gq->lv[0].bits > 8 && q < 40; q++) {
                int64_t p[3] = {0, 0, 0};
                const int64_t *s = pts[rng_next(&r) % (i + 1)];
                for (int a = 0; a < 2; a++) p[a] = s[a] + rand_range(&r, -5000, 5000);
                search_state s2;
                search_state_reset(&s2);
                const uint64_t b2 = search_block2(&t, &cfg, &m, p, &s2);
                uint64_t chess2 = 0;
                const uint64_t want = leaf_bound_ref(pts, i + 1, p, &chess2);
                if (b2 == UINT64_MAX || want == UINT64_MAX) continue;
                leaf_bounds++;
                if ((b2 != want || b2 < chess2 || b2 > brute(pts, i + 1, 2, p)) && bad_block++ < 5)
                    fprintf(stderr, "seed %llu n %zu: far leaf bound %.1f, brute force %.1f, chessboard %.1f\n",
                            (unsigned long long)seed, i + 1, sqrt((double)b2), sqrt((double)want),
                            sqrt((double)chess2));
            }
        }
        for (int q = 0; q < 40; q++) {
            int64_t p[3];
            const int64_t *s = pts[rng_next(&r) % (i + 1)];
            const int64_t spread = q % 2 ? 2000 : 40000;
            for (int a = 0; a < dim; a++) p[a] = s[a] + rand_range(&r, -spread, spread);
            const int64_t b = distmap_bound(&m, p, dim);
            if (b == 0) continue;
            useful++;
            const uint64_t truth = brute(pts, i + 1, dim, p);
            if ((uint64_t)b * (uint64_t)b > truth && bad_bound++ < 5)
                fprintf(stderr, "dim %d seed %llu n %zu: bound %lld above true %.1f\n", dim,
                        (unsigned long long)seed, i + 1, (long long)b, sqrt((double)truth));
            if (b <= 256 && (dim == 2 || b < m.near_min)) bad_min++;
            near_answers += b < 256;
        }
    }
    CHECK(m.disabled == 0, "map disabled");
    CHECK(bad_block == 0, "dim %d seed %llu: %d block searches wrong", dim,
          (unsigned long long)seed, bad_block);
    if (!budget || dim == 2) CHECK(block_used > 1000, "dim %d: only %d block searches", dim, block_used);
    if (budget && dim == 2) {
        CHECK(far_bits > 50, "only %d block answers from the leaf bits", far_bits);
        CHECK(leaf_bounds > 200, "only %d leaf bounds checked", leaf_bounds);
        int unknown = 0;
        CHECK(check_leafbits(&m, (const int64_t(*)[3])pts, n, &unknown) == 0,
              "seed %llu: leaf bits wrong", (unsigned long long)seed);
        if (interior >= 0.5)
            CHECK(unknown > 0, "seed %llu: no tile dropped at interior %.2f", (unsigned long long)seed,
                  interior);
    }
    if (dim == 2) CHECK(ball_scans > 1000, "only %d ball scans answered", ball_scans);
    const distmap_grid *gf = atomic_load(&m.grid);
    if (budget) CHECK(gf && gf->lv[0].bits > 8, "dim %d: the fine cells did not coarsen", dim);
    CHECK(bad_bound == 0, "dim %d seed %llu: %d bounds above the true distance", dim,
          (unsigned long long)seed, bad_bound);
    CHECK(bad_min == 0, "dim %d: %d non-zero bounds not above one fine cell", dim, bad_min);
    CHECK(useful > 100, "dim %d: only %d queries answered by the map", dim, useful);
    if (dim == 3 && !budget)
        CHECK(near_answers > 0, "dim 3 seed %llu: no near answer", (unsigned long long)seed);

    const distmap_grid *g = atomic_load(&m.grid);
    CHECK(g != NULL, "no grid");
    if (g && exact_cells)
        for (int l = 0; l < 2; l++)
            CHECK(check_cells(g, l, dim, (const int64_t(*)[3])pts, n) == 0,
                  "dim %d seed %llu: level %d cells differ from brute force", dim,
                  (unsigned long long)seed, l);

    /* Rebuild from the tree: same cells where both grids reach. */
    distmap m2;
    distmap_init(&m2, dim, 8, 2 * 32 + 8 * 256);
    m2.budget_min = m.budget_min;
    m2.budget_per_particle = m.budget_per_particle;
    m2.near_min = m.near_min;
    distmap_rebuild(&m2, &t);
    const distmap_grid *g2 = atomic_load(&m2.grid);
    CHECK(g2 != NULL, "rebuild made no grid");
    int differ = 0;
    if (g && g2)
        for (int l = 0; l < 2; l++) {
            if (g->lv[l].bits != g2->lv[l].bits) continue; /* budgets chose differently */
            const int64_t h = g->half < g2->half ? g->half : g2->half;
            const int64_t cells = (2 * h) >> g->lv[l].bits;
            for (int64_t z = 0; z < (dim == 3 ? cells : 1); z++)
                for (int64_t y = 0; y < cells; y++)
                    for (int64_t x = 0; x < cells; x++) {
                        int64_t c1[3] = {x, y, z}, c2[3] = {x, y, z};
                        for (int a = 0; a < dim; a++) {
                            c1[a] += (g->half - h) >> g->lv[l].bits;
                            c2[a] += (g2->half - h) >> g->lv[l].bits;
                        }
                        if (level_at(&g->lv[l], dim, c1) != level_at(&g2->lv[l], dim, c2)) differ++;
                    }
        }
    CHECK(differ == 0, "dim %d seed %llu: rebuilt map differs in %d cells", dim,
          (unsigned long long)seed, differ);
    if (budget && dim == 2) {
        CHECK(g2 && g2->tix != NULL, "the rebuilt coarsened map has no leaf bits");
        int unknown = 0;
        CHECK(check_leafbits(&m2, (const int64_t(*)[3])pts, n, &unknown) == 0 && unknown == 0,
              "rebuilt leaf bits wrong (%d leaves unknown)", unknown);
    }
    for (int q = 0; q < 2000; q++) {
        int64_t p[3];
        const int64_t *s = pts[rng_next(&r) % n];
        for (int a = 0; a < dim; a++) p[a] = s[a] + rand_range(&r, -30000, 30000);
        const int64_t b2 = distmap_bound(&m2, p, dim);
        if (b2 && (uint64_t)b2 * (uint64_t)b2 > brute(pts, n, dim, p)) bad_bound++;
    }
    CHECK(bad_bound == 0, "dim %d: rebuilt map bound above the true distance", dim);
    distmap_free(&m2);
    distmap_free(&m);
    tree_free(&t);
    free(pts);
}

/* A walker's cached block must survive the grid growing under it (its
 * origin moves): query, grow the grid by far particles, query again in the
 * same and nearby leaves. */
static void test_growth_cache(int dim, uint64_t seed, size_t budget)
{
    pdla_rng r;
    rng_seed(&r, seed);
    tree t;
    CHECK(tree_init(&t, dim) == 0, "tree_init");
    distmap m;
    distmap_init(&m, dim, 8, 2 * 32 + 8 * 256);
    if (budget) { /* coarsened cells: 2D reads the leaf bits */
        m.budget_min = budget;
        m.budget_per_particle = 0.0;
    }
    search_config cfg;
    search_config_init(&cfg, 2.0, 32, 2);
    search_state ss;
    search_state_reset(&ss);
    enum { NMAX = 4000 };
    int64_t(*pts)[3] = calloc(NMAX, sizeof *pts);
    size_t n = 0;
    int bad = 0, used = 0;
    for (int round = 0; round < 12; round++) {
        /* a blob near the origin, then one particle ever farther out */
        for (int i = 0; i < 100 && n < NMAX - 1; i++, n++) {
            for (int a = 0; a < dim; a++) pts[n][a] = rand_range(&r, -3000, 3000);
            distmap_add(&m, pts[n], n + 1, 0);
            tree_insert(&t, pts[n]);
        }
        for (int q = 0; q < 300; q++) {
            int64_t p[3];
            for (int a = 0; a < dim; a++) p[a] = rand_range(&r, -3200, 3200);
            const uint64_t b2 = search_block2(&t, &cfg, &m, p, &ss);
            if (b2 == UINT64_MAX) continue;
            used++;
            const uint64_t truth = brute(pts, n, dim, p);
            if ((b2 > truth || (truth < 256 * 256 && b2 != truth)) && bad++ < 5)
                fprintf(stderr, "dim %d round %d: block %.1f, true %.1f\n", dim, round,
                        sqrt((double)b2), sqrt((double)truth));
        }
        /* Fill the cache at p, grow the grid, then query where the old grid
         * cell of p now lies (the same cell index in the new grid). */
        int64_t p[3];
        for (int a = 0; a < dim; a++) p[a] = rand_range(&r, -1500, 1500);
        search_block2(&t, &cfg, &m, p, &ss);
        const int64_t half0 = atomic_load(&m.grid)->half;
        for (int a = 0; a < dim; a++) pts[n][a] = (a == 0 ? 1 : -1) * (int64_t)(6000 + 1200 * round);
        distmap_add(&m, pts[n], n + 1, 0);
        tree_insert(&t, pts[n]);
        n++;
        const int64_t shift = atomic_load(&m.grid)->half - half0;
        for (int a = 0; a < dim; a++) p[a] -= shift;
        const uint64_t b2 = search_block2(&t, &cfg, &m, p, &ss);
        const uint64_t truth = brute(pts, n, dim, p);
        if (b2 != UINT64_MAX && (b2 > truth || (truth < 256 * 256 && b2 != truth)) && bad++ < 5)
            fprintf(stderr, "dim %d round %d (grid shift %lld): block %.1f, true %.1f\n", dim,
                    round, (long long)shift, sqrt((double)b2), sqrt((double)truth));
    }
    CHECK(bad == 0, "dim %d: %d block searches wrong after the grid grew", dim, bad);
    CHECK(used > 500, "dim %d: only %d block searches", dim, used);
    distmap_free(&m);
    tree_free(&t);
    free(pts);
}

/* Grids outgrown while readers may run are kept, then freed by epoch:
 * distmap_reclaim(E) frees exactly those retired before epoch E. */
static size_t retired_count(const distmap *m, size_t *bytes)
{
    size_t n = 0;
    *bytes = 0;
    for (const distmap_grid *g = m->old; g; g = g->retired, n++) *bytes += g->bytes;
    return n;
}

static void test_reclaim(int dim)
{
    distmap m;
    distmap_init(&m, dim, 8, 2 * 32 + 8 * 256);
    int64_t p[3] = {0, 0, 0};
    uint64_t n = 0;
    distmap_add(&m, p, ++n, 1);
    for (int k = 0; k < 6; k++) { /* each point beyond the grid: a new one */
        for (int a = 0; a < dim; a++) p[a] = (int64_t)(4000 << k);
        distmap_add(&m, p, ++n, 1);
    }
    size_t bytes;
    const size_t kept = retired_count(&m, &bytes);
    const uint64_t epoch = distmap_epoch(&m);
    CHECK(kept >= 4 && epoch == kept, "dim %d: %zu grids retired, epoch %llu", dim, kept,
          (unsigned long long)epoch);
    CHECK(bytes == m.retired_bytes && bytes > 0, "dim %d: retired bytes %zu, counted %zu", dim,
          m.retired_bytes, bytes);
    distmap_reclaim(&m, 0); /* a reader has seen nothing yet: keep all */
    CHECK(retired_count(&m, &bytes) == kept, "dim %d: reclaim(0) freed a grid", dim);
    distmap_reclaim(&m, 2); /* the two oldest (retired at epochs 0 and 1) go */
    CHECK(retired_count(&m, &bytes) == kept - 2 && bytes == m.retired_bytes,
          "dim %d: reclaim(2) left %zu of %zu", dim, retired_count(&m, &bytes), kept);
    for (const distmap_grid *g = m.old; g; g = g->retired)
        CHECK(g->retired_at >= 2, "dim %d: a grid retired at %llu survived", dim,
              (unsigned long long)g->retired_at);
    distmap_reclaim(&m, epoch);
    CHECK(m.old == NULL && m.retired_bytes == 0, "dim %d: reclaim(epoch) kept grids", dim);
    CHECK(atomic_load(&m.grid) != NULL, "dim %d: the current grid was freed", dim);
    distmap_free(&m);
}

/* distmap_needs_add, the workers' lock-free test, says 0 exactly when
 * distmap_add would change nothing (no new grid, no newly marked leaf), and
 * 0 for every point once it has been added. */
static void test_needs_add(int dim, uint64_t seed, size_t budget)
{
    pdla_rng r;
    rng_seed(&r, seed);
    distmap m;
    distmap_init(&m, dim, 8, 2 * 32 + 8 * 256);
    if (budget) { /* coarsened cells (2D: with leaf bits) */
        m.budget_min = budget;
        m.budget_per_particle = 0.0;
    }
    int zeros = 0, ones = 0;
    for (uint64_t n = 1; n <= 3000; n++) {
        int64_t p[3] = {0, 0, 0};
        const int64_t span = 200 + (int64_t)n * 3; /* the box grows: new grids too */
        for (int a = 0; a < dim; a++) p[a] = rand_range(&r, -span, span);
        const int needs = distmap_needs_add(&m, p);
        const distmap_grid *g0 = atomic_load(&m.grid);
        const uint64_t leaves0 = atomic_load(&m.leaves);
        distmap_add(&m, p, n, 0);
        const int changed = atomic_load(&m.grid) != g0 || atomic_load(&m.leaves) != leaves0;
        if (!needs) {
            zeros++;
            CHECK(!changed, "dim %d n %llu: needs_add said 0 but the map changed", dim,
                  (unsigned long long)n);
        } else {
            ones++;
        }
        CHECK(distmap_needs_add(&m, p) == 0, "dim %d n %llu: an added point still needs adding", dim,
              (unsigned long long)n);
    }
    CHECK(zeros > 100 && ones > 100, "dim %d: both answers occur (%d, %d)", dim, zeros, ones);
    if (budget) CHECK(atomic_load(&m.grid)->lv[0].bits > 8, "dim %d: no coarsening", dim);
    distmap_free(&m);
}

/* A walker outside the grid (the birth circle reaches beyond the square
 * when the farthest particles lie off the axes) gets the gap from it to the
 * box that holds every particle, [-half + margin, half - margin): never
 * above the true distance, equal to it straight out from a particle on the
 * box's face, and at least the margin. Particles are put on every face of
 * the box of the grid the first one made (they are covered, so it stays). */
static void test_outside(int dim, uint64_t seed)
{
    pdla_rng r;
    rng_seed(&r, seed);
    distmap m;
    distmap_init(&m, dim, 8, 2 * 32 + 8 * 256);
    int64_t pts[7][3] = {{0, 0, 0}};
    size_t n = 0;
    CHECK(distmap_add(&m, pts[n++], 1, 0) == 0, "dim %d: add", dim);
    const distmap_grid *g = atomic_load(&m.grid);
    CHECK(g != NULL, "dim %d: no grid", dim);
    const int64_t half = g->half, hi = half - m.margin - 1, lo = m.margin - half;
    for (int a = 0; a < dim; a++)
        for (int s = 0; s < 2; s++) {
            for (int b = 0; b < 3; b++) pts[n][b] = 0;
            pts[n][a] = s ? hi : lo;
            CHECK(distmap_add(&m, pts[n], n + 1, 0) == 0, "dim %d: add", dim);
            n++;
        }
    CHECK(atomic_load(&m.grid) == g, "dim %d: the face particles grew the grid", dim);
    int bad = 0, tight = 0;
    static const int64_t out[] = {0, 1, 7, 1000, 20000};
    for (int a = 0; a < dim; a++)
        for (int s = 0; s < 2; s++)
            for (int k = 0; k < 5; k++)
                for (int off = 0; off < 4; off++) {
                    int64_t q[3] = {0, 0, 0};
                    q[a] = s ? half + out[k] : -half - 1 - out[k];
                    /* off 0: straight out from the face particle; else
                     * anywhere along the other axes (also outside). */
                    for (int b = 0; b < dim; b++)
                        if (b != a && off) q[b] = rand_range(&r, -2 * half, 2 * half);
                    const int64_t bound = distmap_bound(&m, q, dim);
                    const uint64_t truth = brute((const int64_t(*)[3])pts, n, dim, q);
                    if (((uint64_t)bound * (uint64_t)bound > truth || bound < m.margin) && bad++ < 5)
                        fprintf(stderr, "dim %d: outside bound %lld, true %.1f, margin %lld\n", dim,
                                (long long)bound, sqrt((double)truth), (long long)m.margin);
                    if (!off) tight += (uint64_t)bound * (uint64_t)bound == truth;
                }
    CHECK(bad == 0, "dim %d: %d outside bounds wrong", dim, bad);
    CHECK(tight == 2 * dim * 5, "dim %d: %d of %d straight-out bounds tight", dim, tight, 2 * dim * 5);
    distmap_free(&m);
}

/* 3D bounds from the face neighbours (distmap_faces3), adversarially: a
 * small cluster of tight clumps and lone particles, the map's near answer
 * taken from 1 unit (the engine takes it from 4 diameters), and query
 * points on cell faces and corners (offsets 0, 1, 254, 255 in a cell) as
 * well as random ones, each bound against the brute-force distance. The
 * faces must also say more than p's own cell alone at some points (the
 * plain bound, (v - 1) cells + p's distance to its cell's edge, is worked
 * out here from the cell values), and the near answer must occur. */
static void test_faces3(uint64_t seed)
{
    pdla_rng r;
    rng_seed(&r, seed);
    distmap m;
    distmap_init(&m, 3, 8, 2 * 32 + 8 * 256);
    m.budget_min = (size_t)1 << 30;
    m.near_min = 1;
    enum { N = 400 };
    int64_t pts[N][3];
    int64_t cur[3] = {0, 0, 0};
    for (int i = 0; i < N; i++) {
        const int64_t step = i % 40 == 0 ? 1500 : 40; /* clumps, then a jump */
        for (int a = 0; a < 3; a++) cur[a] += rand_range(&r, -step, step);
        for (int a = 0; a < 3; a++) pts[i][a] = cur[a];
        distmap_add(&m, cur, (uint64_t)i + 1, 0);
    }
    const distmap_grid *g = atomic_load(&m.grid);
    CHECK(g != NULL, "no grid");
    if (!g) return;
    static const int64_t edge_off[4] = {0, 1, 254, 255};
    int bad = 0, near = 0, better = 0, checked = 0;
    for (int q = 0; q < 60000; q++) {
        int64_t p[3];
        const int64_t *s = pts[rng_next(&r) % N];
        const int64_t spread = q % 3 == 0 ? 600 : q % 3 == 1 ? 2500 : 9000;
        for (int a = 0; a < 3; a++) p[a] = s[a] + rand_range(&r, -spread, spread);
        if (q % 2) /* onto a face, edge or corner of its cell */
            for (int a = 0; a < 3; a++)
                if (rng_next(&r) % 2) {
                    const int64_t u = p[a] + g->half;
                    p[a] = (u & ~(int64_t)255) + edge_off[rng_next(&r) % 4] - g->half;
                }
        const int64_t b = distmap_bound(&m, p, 3);
        if (b == 0) continue;
        checked++;
        const uint64_t truth = brute((const int64_t(*)[3])pts, N, 3, p);
        if ((uint64_t)b * (uint64_t)b > truth && bad++ < 5)
            fprintf(stderr, "faces3 seed %llu: bound %lld above true %.2f at %lld %lld %lld\n",
                    (unsigned long long)seed, (long long)b, sqrt((double)truth), (long long)p[0],
                    (long long)p[1], (long long)p[2]);
        int64_t u[3], c[3];
        int inside = 1;
        for (int a = 0; a < 3; a++) {
            u[a] = p[a] + g->half;
            c[a] = u[a] >> 8;
            inside &= u[a] >= 0 && u[a] < 2 * g->half;
        }
        if (!inside) continue; /* the outside bound: test_outside */
        const int64_t v = distmap_level_value(&g->lv[0], c, 3);
        if (v < 2) {
            near++;
            continue;
        }
        int64_t e = 256;
        for (int a = 0; a < 3; a++) {
            const int64_t o = u[a] & 255;
            if (o + 1 < e) e = o + 1;
            if (256 - o < e) e = 256 - o;
        }
        better += b > (v - 1) * 256 + e;
    }
    CHECK(bad == 0, "faces3 seed %llu: %d bounds above the true distance", (unsigned long long)seed, bad);
    CHECK(checked > 10000, "faces3: only %d bounds checked", checked);
    CHECK(near > 500, "faces3: only %d near answers", near);
    CHECK(better > 1000, "faces3: the faces beat the own cell only %d times", better);
    fprintf(stderr, "faces3 seed %llu: %d bounds checked, %d near, %d above the own cell's\n",
            (unsigned long long)seed, checked, near, better);
    distmap_free(&m);
}

/* The face bounds are exact where they should be: one particle on the
 * face of its cell that looks towards p, p straight out along that axis,
 * v cells on (v = 1 .. 6) at offsets r in its cell: the true distance is
 * then the face neighbour's bound (v - 1 cells + r + 1 units, or v cells
 * - r the other way), so distmap_bound must equal it to the unit, never
 * exceed it. Random points rarely sit where a bound is tight: an error of
 * a unit or two passes test_faces3, not this. */
static void test_faces3_tight(void)
{
    static const int64_t offs[] = {0, 1, 2, 100, 127, 128, 253, 254, 255};
    int bad = 0, n = 0;
    for (int a = 0; a < 3; a++)
        for (int dir = -1; dir <= 1; dir += 2) {
            distmap m;
            distmap_init(&m, 3, 8, 2 * 32 + 8 * 256);
            m.budget_min = (size_t)1 << 30;
            m.near_min = 1;
            /* p above the particle (dir 1): the particle on its cell's top
             * face; below (dir -1): on the bottom face. */
            int64_t x[3] = {5 * 256 + 17, -3 * 256 + 200, 2 * 256 + 99};
            x[a] = dir > 0 ? 4 * 256 + 255 : 4 * 256;
            distmap_add(&m, x, 1, 0);
            const distmap_grid *g = atomic_load(&m.grid);
            for (int64_t v = 1; v <= 6; v++)
                for (size_t k = 0; k < sizeof offs / sizeof *offs; k++) {
                    int64_t p[3] = {x[0], x[1], x[2]};
                    const int64_t cell = 4 + dir * v; /* p's cell on axis a */
                    p[a] = cell * 256 + offs[k];
                    const int64_t truth = p[a] > x[a] ? p[a] - x[a] : x[a] - p[a];
                    const int64_t b = distmap_bound(&m, p, 3);
                    n++;
                    if (b != truth && bad++ < 5)
                        fprintf(stderr, "faces3 tight: axis %d dir %d v %lld r %lld: bound %lld, true %lld "
                                        "(half %lld)\n",
                                a, dir, (long long)v, (long long)offs[k], (long long)b, (long long)truth,
                                (long long)(g ? g->half : 0));
                }
            distmap_free(&m);
        }
    CHECK(bad == 0, "faces3 tight: %d of %d bounds not the true distance", bad, n);
}

/* A particle at the grid's low edge as covers() has it, x = -(half -
 * margin), does not make a new grid; a checkpoint's shape must then load
 * (distmap_rebuild_as). It was refused ("the distance map's shape does not
 * fit the particles"): the load asked |x| + margin < half, one unit
 * stricter than the growth on the negative side, and such a run's
 * checkpoints could not be resumed until the map grew again. */
static void test_edge_shape(int dim)
{
    tree t;
    distmap m, m2;
    const int64_t margin = 2 * 32 + 8 * 256;
    CHECK(tree_init(&t, dim) == 0, "tree_init");
    distmap_init(&m, dim, 8, margin);
    int64_t p[3] = {0, 0, 0};
    CHECK(distmap_add(&m, p, 1, 0) == 0 && tree_insert(&t, p) == 0, "dim %d: origin", dim);
    distmap_shape s0, s;
    CHECK(distmap_shape_get(&m, &s0) == 0 && s0.half > margin, "dim %d: shape", dim);
    p[dim - 1] = -(s0.half - margin);
    CHECK(distmap_add(&m, p, 2, 0) == 0 && tree_insert(&t, p) == 0, "dim %d: edge particle", dim);
    CHECK(distmap_shape_get(&m, &s) == 0 && s.half == s0.half, "dim %d: the edge made a new grid", dim);
    distmap_init(&m2, dim, 8, margin);
    CHECK(distmap_rebuild_as(&m2, &t, &s) == 0, "dim %d: a shape with a particle at -(half - margin) refused",
          dim);
    free(s0.unknown);
    free(s.unknown);
    distmap_free(&m2);
    distmap_free(&m);
    tree_free(&t);
}

int main(void)
{
    test_edge_shape(2);
    test_edge_shape(3);
    test_faces3_tight();
    test_faces3(51);
    test_faces3(52);
    test_outside(2, 41);
    test_outside(3, 42);
    test_needs_add(2, 31, 0);
    test_needs_add(3, 32, 0);
    test_needs_add(2, 33, 1024);
    test_reclaim(2);
    test_reclaim(3);
    test_growth_cache(2, 7, 0);
    test_growth_cache(3, 8, 0);
    test_growth_cache(2, 9, 512);
    test_cluster(2, 2000, 1, 1, 0, 0);
    test_cluster(2, 10000, 2, 0, 0, 0);
    test_cluster(3, 1000, 3, 1, 0, 0);
    test_cluster(3, 5000, 4, 0, 0, 0);
    test_cluster(2, 4000, 5, 1, 2048, DISTMAP_LEAF_INTERIOR);
    test_cluster(2, 10000, 7, 0, 4096, 0.6);
    test_cluster(3, 2000, 6, 1, 4096, DISTMAP_LEAF_INTERIOR);
    return check_finish();
}
