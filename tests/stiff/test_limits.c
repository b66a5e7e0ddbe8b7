/*
 * test_limits.c - the largest magnitudes the integer format allows.
 *  - engine_check_range: |x| = 2^28 - 1 passes on every axis, 2^28 is refused
 *    with PDLA_ERANGE and a message naming the limit (before the tree or any
 *    square sees it);
 *  - the tree holds particles at the corners of the allowed range
 *    (|x| = 2^28 - 1) and beyond, up to its own root limit (|x| < 2^30), and
 *    refuses 2^30 with -2 rather than wrapping;
 *  - the distance search at those particles, for query points up to the
 *    farthest a walker is ever searched from: the largest birth radius,
 *    sqrt(dim) 2^28 (R_ext) + 1e6 diameters of 128 units (the largest birth
 *    margin) + 1, and every coordinate at 2^28 + 1.28e8: exact search equals
 *    a 128-bit brute force, VPDIST is never above it and exact near particles;
 *  - gyration sums of particles at |x| = 2^28 - 1: R_g and R_ext exact;
 *  - a real growth that reaches the limit (2D): a particle placed 2
 *    diameters inside it; walkers stick to it until the next one would cross,
 *    and growth stops with PDLA_ERANGE and "coordinate limit", every stored
 *    particle inside the limit. (Not in 3D: there a walker launched on a
 *    sphere of radius 2^28 almost surely escapes, so a lone particle at the
 *    limit is practically never hit);
 *  - the return samplers on the birth circle at R = sqrt(3) 2^28 + 1.28e8
 *    units (the largest birth radius) and at R = 66, for r/R from 1 + 1e-12 to
 *    1e12: finite output, on the circle/sphere to 1e-12 relative (so the
 *    rounded grid point is within one unit of it), theta in range.
 *    (test_extreme.c checks the laws themselves at those ratios.)
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "engine.h"
#include "search.h"
#include "sample.h"
#include "tree.h"

#define LIM PDLA_MAX_CLUSTER_RADIUS_UNITS

typedef __int128 i128;

static i128 brute128(const int64_t (*s)[3], size_t n, int dim, const int64_t *p)
{
    i128 best = -1;
    for (size_t i = 0; i < n; i++) {
        i128 d2 = 0;
        for (int a = 0; a < dim; a++) {
            const i128 d = (i128)s[i][a] - p[a];
            d2 += d * d;
        }
        if (best < 0 || d2 < best) best = d2;
    }
    return best;
}

static void test_check_range(int dim)
{
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    pdla_engine *e;
    char err[256];
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    for (int a = 0; a < dim; a++)
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            int64_t p[3] = {0, 0, 0};
            p[a] = sgn * (LIM - 1);
            CHECK(engine_check_range(e, p, err, sizeof err) == PDLA_OK, "dim %d axis %d: 2^28-1 refused", dim, a);
            p[a] = sgn * LIM;
            err[0] = 0;
            CHECK(engine_check_range(e, p, err, sizeof err) == PDLA_ERANGE && strstr(err, "coordinate limit"),
                  "dim %d axis %d sign %d: 2^28 not refused clearly: '%s'", dim, a, sgn, err);
            p[a] = sgn > 0 ? INT64_MAX / 2 : -(INT64_MAX / 2);
            CHECK(engine_check_range(e, p, err, sizeof err) == PDLA_ERANGE, "huge not refused");
        }
    /* the corner: every axis at the limit - 1 */
    const int64_t c[3] = {LIM - 1, -(LIM - 1), LIM - 1};
    CHECK(engine_check_range(e, c, err, sizeof err) == PDLA_OK, "corner refused");

    /* gyration at the limit: +-L alternately on axis 0, L on the others */
    const int64_t L = LIM - 1;
    for (int i = 0; i < 1000; i++) {
        int64_t p[3] = {i % 2 ? L : -L, L, -L};
        CHECK(engine_gyration_add(e, p, err, sizeof err) == PDLA_OK, "gyration add");
    }
    /* R_g^2 = L^2 (axis 0 spread) + 0 on the others */
    const double rg = sqrt(gyration_rg2_units(&e->gyr, dim));
    CHECK(fabs(rg / (double)L - 1.0) < 1e-12, "dim %d: R_g %.17g, want %lld", dim, rg, (long long)L);
    const int64_t rext = atomic_load(&e->r_ext);
    const double want = (double)L * sqrt((double)dim);
    CHECK(rext >= want && rext < want + 1.0, "dim %d: R_ext %lld, want ceil(%.3f)", dim, (long long)rext, want);
    pdla_engine_destroy(e);
}

static void test_tree_at_limits(int dim)
{
    tree t;
    CHECK(tree_init(&t, dim) == 0, "tree_init");
    int64_t s[64][3];
    size_t n = 0;
    /* every corner of the allowed box, and a few particles next to one */
    for (int c = 0; c < (1 << dim); c++) {
        for (int a = 0; a < 3; a++) s[n][a] = a < dim ? (((c >> a) & 1) ? LIM - 1 : -(LIM - 1)) : 0;
        n++;
    }
    for (int i = 1; i <= 5; i++) {
        for (int a = 0; a < 3; a++) s[n][a] = a < dim ? LIM - 1 - 32 * i * (a + 1) : 0;
        n++;
    }
    s[n][0] = 0, s[n][1] = 0, s[n][2] = 0;
    n++;
    /* the tree's own limit: just inside 2^30 */
    const int64_t TL = (int64_t)1 << 30;
    for (int a = 0; a < 3; a++) s[n][a] = a < dim ? TL - 1 : 0;
    n++;
    for (int a = 0; a < 3; a++) s[n][a] = a < dim ? -TL : 0;
    n++;
    for (size_t i = 0; i < n; i++) CHECK(tree_insert(&t, s[i]) == 0, "dim %d: insert %zu", dim, i);
    CHECK(tree_root_get(&t).level <= TREE_MAX_LEVEL, "root level %d", tree_root_get(&t).level);
    int64_t beyond[3] = {TL, 0, 0};
    CHECK(tree_insert(&t, beyond) == -2, "dim %d: 2^30 not refused", dim);
    beyond[0] = 0;
    beyond[dim - 1] = -TL - 1;
    CHECK(tree_insert(&t, beyond) == -2, "dim %d: -2^30-1 not refused", dim);
    CHECK(tree_count(&t) == n, "count");

    search_config exact, vp;
    search_config_init(&exact, 0.0, 32, 2);
    search_config_init(&vp, 2.0, 32, 2);
    search_state k1, k2;
    search_state_reset(&k1);
    search_state_reset(&k2);
    pdla_rng r;
    rng_seed(&r, 42);
    /* The farthest point a walker is searched from: |p| <= R_birth + 1 with
     * R_birth <= R_ext + 1e6 * 128; take every coordinate that large. */
    const int64_t QMAX = LIM + 128000000 + 1;
    /* R_ext is a Euclidean norm, up to sqrt(dim) 2^28 with every coordinate
     * inside the limit: the largest birth radius (+ 1 unit of hysteresis). */
    const double RBMAX = sqrt((double)dim) * (double)LIM + 128000000.0 + 1.0;
    int bad_ex = 0, bad_vp = 0, bad_near = 0, bad_brute = 0;
    for (int q = 0; q < 5000; q++) {
        int64_t p[3] = {0, 0, 0};
        const int kind = q % 5;
        if (kind == 4) { /* on the largest birth circle/sphere */
            double v[3], n2 = 0;
            for (int a = 0; a < dim; a++) {
                v[a] = (double)(int64_t)(rng_next(&r) % 2000001) - 1000000.0;
                n2 += v[a] * v[a];
            }
            for (int a = 0; a < dim; a++) p[a] = (int64_t)(RBMAX * v[a] / sqrt(n2));
        }
        for (int a = 0; a < dim && kind < 4; a++) {
            const int64_t u = (int64_t)(rng_next(&r) % 2001) - 1000;
            if (kind == 0) p[a] = s[q % n][a] + u; /* near a particle */
            else if (kind == 1) p[a] = (rng_next(&r) & 1 ? QMAX : -QMAX) - u / 10; /* far corners */
            else if (kind == 2) p[a] = (int64_t)(rng_next(&r) % (uint64_t)(2 * QMAX + 1)) - QMAX;
            else p[a] = s[q % n][a] + (int64_t)(rng_next(&r) % 20001) - 10000;
        }
        const i128 truth = brute128((const int64_t(*)[3])s, n, dim, p);
        CHECK(truth < ((i128)1 << 64), "the test's own range: truth above 2^64");
        const uint64_t ex = search_lower_bound2(&t, &exact, p, UINT64_MAX, &k1);
        const uint64_t lb = search_lower_bound2(&t, &vp, p, UINT64_MAX, &k2);
        if ((i128)ex != truth) bad_ex++;
        if ((i128)lb > truth) bad_vp++;
        if (lb < vp.far2[0] && (i128)lb != truth) bad_near++;
        if ((i128)search_brute2(&t, p) != truth) bad_brute++;
    }
    CHECK(bad_ex == 0, "dim %d: exact search wrong at %d of 5000 far points", dim, bad_ex);
    CHECK(bad_vp == 0, "dim %d: VPDIST above the truth at %d", dim, bad_vp);
    CHECK(bad_near == 0, "dim %d: VPDIST not exact near particles at %d", dim, bad_near);
    CHECK(bad_brute == 0, "dim %d: search_brute2 differs from 128-bit brute force at %d", dim, bad_brute);
    tree_free(&t);
}

static int max_abs_visit(const int64_t *p, void *u)
{
    int64_t *m = u;
    for (int a = 0; a < 3; a++) {
        const int64_t v = p[a] < 0 ? -p[a] : p[a];
        if (v > *m) *m = v;
    }
    return 0;
}

/* Grow against the limit: a particle placed 2 diameters inside +2^28 on x. */
static void test_grow_into_limit(int dim)
{
    pdla_params P;
    pdla_params_default(&P);
    P.dim = dim;
    P.target = 100000;
    P.seed = 3;
    pdla_engine *e;
    char err[256];
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    CHECK(pdla_engine_grow(e, 1, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "seed: %s", err);
    const int64_t far[3] = {LIM - 2 * P.resolution, 0, 0};
    /* As the engine inserts (the map too: a walker outside the map's grid
     * takes the grid's margin as a bound, so every particle must be in it). */
    CHECK(engine_add_particle(e, far, err, sizeof err) == PDLA_OK, "insert far: %s", err);
    err[0] = 0;
    const int rc = pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err);
    const uint64_t n = pdla_engine_count(e);
    CHECK(rc == PDLA_ERANGE && strstr(err, "coordinate limit"), "dim %d: rc %d '%s'", dim, rc, err);
    CHECK(n < P.target && n >= 2, "dim %d: %llu particles", dim, (unsigned long long)n);
    /* every stored particle is inside the limit */
    int64_t maxabs = 0;
    CHECK(tree_visit(&e->tree, max_abs_visit, &maxabs) == 0, "visit");
    CHECK(maxabs < LIM, "dim %d: a particle at |x| = %lld >= 2^28", dim, (long long)maxabs);
    fprintf(stderr, "dim %d: growth stopped at %llu particles: %s (max |x| %lld, limit %lld)\n", dim,
            (unsigned long long)n, err, (long long)maxabs, (long long)LIM);
    pdla_engine_destroy(e);
}

static void test_samplers_on_circle(void)
{
    const double Rs[2] = {66.0, sqrt(3.0) * (double)LIM + 128000000.0}; /* the largest birth radius */
    pdla_rng rng;
    rng_seed(&rng, 9);
    int bad = 0, total = 0;
    for (int ri = 0; ri < 2; ri++) {
        const double R = Rs[ri];
        for (int e = -12; e <= 12; e++) {
            const double ratio = e < 0 ? 1.0 + pow(10.0, e) : pow(10.0, e);
            if (e == 0) continue;
            const double r = R * ratio;
            for (int i = 0; i < 2000; i++) {
                total++;
                /* 2D: from (r cos phi, r sin phi) */
                const double phi = 0.37 * i;
                const double theta = sample_return_angle2(&rng, r, R);
                double out[2];
                sample_rotate_to2(r * cos(phi), r * sin(phi), theta, R, out);
                const double rho2 = hypot(out[0], out[1]);
                if (!(theta > -M_PI && theta <= M_PI) || !isfinite(rho2) || fabs(rho2 / R - 1) > 1e-12)
                    bad++;
                /* 3D */
                double c;
                if (sample_return3(&rng, r, R, &c)) {
                    double u[3] = {sin(phi) * 0.6, cos(phi) * 0.6, 0.8};
                    double o3[3];
                    if (!(c >= -1 && c <= 1)) bad++;
                    sample_cone_point3(&rng, u, R, c, o3);
                    const double rho3 = sqrt(o3[0] * o3[0] + o3[1] * o3[1] + o3[2] * o3[2]);
                    if (!isfinite(rho3) || fabs(rho3 / R - 1) > 1e-12) bad++;
                    /* rounded to the grid, still within one unit of the sphere */
                    double g2 = 0;
                    for (int a = 0; a < 3; a++) g2 += (double)lrint(o3[a]) * (double)lrint(o3[a]);
                    if (fabs(sqrt(g2) - R) > 1.0) bad++;
                }
            }
        }
    }
    CHECK(bad == 0, "%d bad return points of %d (not finite, off the circle, or theta out of range)", bad, total);
    fprintf(stderr, "samplers: %d returns at R = 66 and %.0f, r/R from 1+1e-12 to 1e12, %d bad\n", total,
            Rs[1], bad);
}

int main(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        test_check_range(dim);
        test_tree_at_limits(dim);
    }
    test_grow_into_limit(2);
    test_samplers_on_circle();
    return check_finish();
}
