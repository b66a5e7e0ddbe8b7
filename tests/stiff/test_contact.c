/*
 * test_contact.c - contact geometry with hand-placed particles, through the
 * internal tree API (tree.h, engine.h), against brute force:
 *  - every integer offset v whose |v|^2 is D^2 - 1, D^2, D^2 + 1,
 *    (D+eps)^2 - 1, (D+eps)^2 or (D+eps)^2 + 1 (exactly tangent, just
 *    inside, just outside the contact and the sticking shell: along the
 *    axes, the diagonals and every lattice direction that hits those radii
 *    exactly), from particles sitting on leaf corners, node corners
 *    (levels 1 to 3) and the seed's origin, so the query crosses leaf and node
 *    boundaries: exact search and VPDIST must both return the exact squared
 *    distance (all of these are below the far threshold), and the sticking
 *    rule d2 < (D + eps)^2 must hold exactly at the boundary;
 *  - walker_snap_to_contact from every such point inside the sticking shell:
 *    the result lies at distance in [D, D + sqrt(dim)) from the particle it
 *    snapped to, on the line through it (within sqrt(dim) units), overlaps
 *    nothing, and a point already at exactly D stays put; walkers tangent to
 *    two particles at once; a contact point covered by a second particle.
 *    (This found search_nearest_point missing a third leaf per axis when
 *    2 (D + eps) >= 256, i.e. at D = 128: the snap then failed or snapped
 *    onto the wrong particle.)
 * D at 4, 32 and 128 (the smallest, default and largest allowed), eps at 2
 * and D/2, 2D and 3D.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine.h"
#include "search.h"
#include "tree.h"

typedef struct pt {
    int64_t x[3];
} pt;


/* walker_snap_to_contact with a fresh search cache, as a walker just born. */
static int snap(const tree *t, int64_t *p, int64_t D, uint64_t reach2)
{
    search_state k;
    search_state_reset(&k);
    return walker_snap_to_contact(t, p, D, reach2, &k);
}

static uint64_t brute(const pt *s, size_t n, int dim, const int64_t *p)
{
    uint64_t best = UINT64_MAX;
    for (size_t i = 0; i < n; i++) {
        uint64_t d2 = 0;
        for (int a = 0; a < dim; a++) {
            const int64_t d = s[i].x[a] - p[a];
            d2 += (uint64_t)(d * d);
        }
        if (d2 < best) best = d2;
    }
    return best;
}

/* Integer offsets with |v|^2 == r2 (dim 2 or 3), appended to out. */
static size_t shell(int dim, int64_t r2, pt *out, size_t n, size_t cap)
{
    const int64_t r = (int64_t)ceil(sqrt((double)r2));
    for (int64_t x = -r; x <= r; x++)
        for (int64_t y = -r; y <= r; y++) {
            if (dim == 2) {
                if (x * x + y * y == r2 && n < cap) out[n++] = (pt){{x, y, 0}};
                continue;
            }
            const int64_t rest = r2 - x * x - y * y;
            if (rest < 0) continue;
            const int64_t z = (int64_t)llround(sqrt((double)rest));
            if (z * z != rest) continue;
            if (n < cap) out[n++] = (pt){{x, y, z}};
            if (z && n < cap) out[n++] = (pt){{x, y, -z}};
        }
    return n;
}

/* Corners of leaves and nodes: the last and first unit on each side of a
 * boundary at 0, 256 (leaf), 512 (level-1 node), 1024 (level 2), 2048. */
static const int64_t corner_coord[] = {0, -1, 255, 256, 511, 512, -512, -513, 1023, 2048};
#define NCORNER (sizeof corner_coord / sizeof corner_coord[0])

static void test_tangent(int dim, int D, int eps)
{
    tree t;
    CHECK(tree_init(&t, dim) == 0, "tree_init");
    /* Particles on corners, spaced so that they never overlap: the corner
     * coordinates are at least 1 apart, so use them on the diagonal only
     * where they are >= D apart, plus the origin seed. */
    pt s[64];
    size_t n = 0;
    for (size_t i = 0; i < NCORNER; i++) {
        pt c = {{corner_coord[i], corner_coord[(i * 3) % NCORNER], dim == 3 ? corner_coord[(i * 7) % NCORNER] : 0}};
        int ok = 1;
        for (size_t j = 0; j < n && ok; j++) {
            uint64_t d2 = 0;
            for (int a = 0; a < dim; a++) d2 += (uint64_t)((c.x[a] - s[j].x[a]) * (c.x[a] - s[j].x[a]));
            ok = d2 >= (uint64_t)(4 * (D + eps) * (D + eps)); /* well separated */
        }
        if (!ok) continue;
        s[n++] = c;
        CHECK(tree_insert(&t, c.x) == 0, "insert");
    }
    search_config exact, vp;
    search_config_init(&exact, 0.0, D, eps);
    search_config_init(&vp, 2.0, D, eps);
    search_state k1, k2;
    search_state_reset(&k1);
    search_state_reset(&k2);

    const int64_t radii[6] = {(int64_t)D * D - 1, (int64_t)D * D, (int64_t)D * D + 1,
                              (int64_t)(D + eps) * (D + eps) - 1, (int64_t)(D + eps) * (D + eps),
                              (int64_t)(D + eps) * (D + eps) + 1};
    const uint64_t stick2 = (uint64_t)(D + eps) * (uint64_t)(D + eps), D2 = (uint64_t)D * (uint64_t)D;
    size_t cap = 200000;
    pt *off = malloc(cap * sizeof *off);
    int bad_ex = 0, bad_vp = 0, bad_stick = 0, queries = 0, snaps = 0, bad_snap = 0, stayed = 0;
    for (int ri = 0; ri < 6; ri++) {
        const size_t m = shell(dim, radii[ri], off, 0, cap);
        for (size_t i = 0; i < n; i++)
            for (size_t j = 0; j < m; j++) {
                int64_t p[3] = {0, 0, 0};
                for (int a = 0; a < dim; a++) p[a] = s[i].x[a] + off[j].x[a];
                const uint64_t truth = brute(s, n, dim, p);
                const uint64_t ex = search_lower_bound2(&t, &exact, p, UINT64_MAX, &k1);
                const uint64_t lb = search_lower_bound2(&t, &vp, p, UINT64_MAX, &k2);
                queries++;
                if (ex != truth) bad_ex++;
                if (lb != truth) bad_vp++;
                /* the sticking rule at the boundary: strictly inside (D + eps) */
                if ((lb < stick2) != ((uint64_t)radii[ri] < stick2 || truth < (uint64_t)radii[ri]))
                    bad_stick++;
                if (truth < D2 || truth >= stick2) continue;
                /* inside the shell: snap onto contact */
                int64_t q[3];
                memcpy(q, p, sizeof q);
                const int moved = snap(&t, q, D, stick2);
                snaps++;
                const uint64_t after = brute(s, n, dim, q);
                /* distance to the particle it snapped to (the nearest one) */
                uint64_t dq = 0;
                double along = 0;
                for (int a = 0; a < dim; a++) {
                    const int64_t d = q[a] - s[i].x[a];
                    dq += (uint64_t)(d * d);
                    along += (double)d * (double)(p[a] - s[i].x[a]);
                }
                const double dqs = sqrt((double)dq), dps = sqrt((double)truth);
                /* distance of q from the line through s_i and p */
                const double perp = sqrt(fmax(0.0, (double)dq - (along / dps) * (along / dps)));
                int ok = moved && after >= D2 && dqs < D + sqrt((double)dim) && perp <= sqrt((double)dim);
                if (truth == D2) {
                    ok = ok && !memcmp(q, p, sizeof q); /* already in contact: stays */
                    stayed += ok;
                }
                if (!ok) {
                    if (bad_snap < 5)
                        fprintf(stderr, "snap D %d eps %d dim %d: p (%lld %lld %lld) -> (%lld %lld %lld) moved %d d %.3f perp %.3f\n",
                                D, eps, dim, (long long)p[0], (long long)p[1], (long long)p[2], (long long)q[0],
                                (long long)q[1], (long long)q[2], moved, dqs, perp);
                    bad_snap++;
                }
            }
    }
    CHECK(bad_ex == 0, "dim %d D %d eps %d: exact search wrong at %d of %d tangent points", dim, D, eps, bad_ex, queries);
    CHECK(bad_vp == 0, "dim %d D %d eps %d: VPDIST not exact at %d of %d contact points", dim, D, eps, bad_vp, queries);
    CHECK(bad_stick == 0, "dim %d D %d eps %d: sticking rule wrong at %d points", dim, D, eps, bad_stick);
    CHECK(bad_snap == 0, "dim %d D %d eps %d: %d of %d snaps wrong", dim, D, eps, bad_snap, snaps);
    CHECK(stayed > 0, "dim %d D %d: no exact contact point tested", dim, D);
    fprintf(stderr, "dim %d D %3d eps %2d: %zu corner particles, %d tangent queries, %d snaps (%d exact contacts)\n",
            dim, D, eps, n, queries, snaps, stayed);
    free(off);
    tree_free(&t);
}

/* Walkers tangent to two particles, and a spot with no free grid point. */
static void test_two_and_crowded(int dim, int D)
{
    const int eps = 2;
    const uint64_t stick2 = (uint64_t)(D + eps) * (uint64_t)(D + eps), D2 = (uint64_t)D * (uint64_t)D;
    tree t;
    CHECK(tree_init(&t, dim) == 0, "tree_init");
    /* Two particles 2D apart along x across the leaf boundary at 256: the
     * midpoint is exactly tangent to both. */
    pt s[3] = {{{256 - D, 5, 0}}, {{256 + D, 5, 0}}, {{0}}};
    for (int i = 0; i < 2; i++) CHECK(tree_insert(&t, s[i].x) == 0, "insert");
    int64_t p[3] = {256, 5, 0};
    CHECK(snap(&t, p, D, stick2) == 1 && p[0] == 256 && p[1] == 5,
          "dim %d D %d: double tangent moved to (%lld %lld)", dim, D, (long long)p[0], (long long)p[1]);
    /* Just off the midpoint: snapping to one must not overlap the other. */
    for (int64_t dy = 1; dy <= eps + 1; dy++) {
        int64_t q[3] = {256, 5 + dy, 0};
        const uint64_t before = brute(s, 2, dim, q);
        const int moved = snap(&t, q, D, stick2);
        CHECK(brute(s, 2, dim, q) >= D2, "dim %d D %d: snap next to two overlaps", dim, D);
        CHECK(moved || before >= stick2 || !memcmp(q, (int64_t[3]){256, 5 + dy, 0}, sizeof q),
              "dim %d D %d: not moved but changed", dim, D);
    }
    /* Near-crowded: a walker at D + 1 from A = (0,0) along x whose exact
     * contact point (D, 0) lies closer than D to B = (D + 1, D - 1): the
     * snap must pick a free grid point or leave the walker where it is. */
    tree u;
    pt c[2] = {{{0, 0, 0}}, {{D + 1, D - 1, 0}}};
    CHECK(tree_init(&u, dim) == 0, "tree_init");
    for (int i = 0; i < 2; i++) CHECK(tree_insert(&u, c[i].x) == 0, "insert");
    int64_t w[3] = {D + 1, 0, 0};
    const uint64_t dA = brute(c, 1, dim, w), dB = brute(c + 1, 1, dim, w);
    int64_t w0[3];
    memcpy(w0, w, sizeof w);
    const int moved = snap(&u, w, D, stick2);
    const uint64_t after = brute(c, 2, dim, w);
    CHECK(after >= D2, "dim %d D %d: crowded snap overlaps (moved %d)", dim, D, moved);
    CHECK(moved || !memcmp(w, w0, sizeof w), "dim %d D %d: crowded: changed without moving", dim, D);
    fprintf(stderr, "dim %d D %3d: crowded walker (d2 to A %llu, to B %llu): moved %d to (%lld %lld)\n", dim, D,
            (unsigned long long)dA, (unsigned long long)dB, moved, (long long)w[0], (long long)w[1]);
    tree_free(&u);
    tree_free(&t);
}

int main(void)
{
    static const int Ds[] = {4, 32, 128};
    for (int dim = 2; dim <= 3; dim++)
        for (size_t i = 0; i < 3; i++) {
            const int D = Ds[i];
            test_tangent(dim, D, 2);
            if (D / 2 != 2 && (dim == 2 || D < 128)) test_tangent(dim, D, D / 2);
            test_two_and_crowded(dim, D);
        }
    return check_finish();
}
