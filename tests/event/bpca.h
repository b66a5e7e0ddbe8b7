/*
 * bpca.h - ballistic particle-cluster aggregation (BPCA: Vold 1963,
 * Sutherland), the infinite-mean-free-path reference of the event model, and
 * a mass-radius fractal dimension. Header-only (static functions), shared by
 * tests/event/test_event.c (test `ballistic`) and runs/event/ballistic.c.
 */
#ifndef PDLA_TESTS_BPCA_H
#define PDLA_TESTS_BPCA_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* splitmix64: a uniform double in [0, 1). */
static double bpca_urand(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

/* A random unit vector u and unit vectors e1, e2 across it (e2: 3D only). */
static void bpca_frame(int D, uint64_t *s, double *u, double *e1, double *e2)
{
    if (D == 2) {
        const double a = 2 * M_PI * bpca_urand(s);
        u[0] = cos(a), u[1] = sin(a);
        e1[0] = -u[1], e1[1] = u[0];
        return;
    }
    double n = 0; /* an isotropic direction: three normal deviates (Box-Muller), normalised */
    for (int q = 0; q < 3; q++) {
        const double g1 = bpca_urand(s) + 1e-300, g2 = bpca_urand(s);
        u[q] = sqrt(-2 * log(g1)) * cos(2 * M_PI * g2);
        n += u[q] * u[q];
    }
    n = sqrt(n);
    for (int q = 0; q < 3; q++) u[q] /= n;
    const double b[3] = {fabs(u[0]) < 0.9 ? 1 : 0, fabs(u[0]) < 0.9 ? 0 : 1, 0};
    e1[0] = b[1] * u[2] - b[2] * u[1], e1[1] = b[2] * u[0] - b[0] * u[2], e1[2] = b[0] * u[1] - b[1] * u[0];
    n = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (int q = 0; q < 3; q++) e1[q] /= n;
    e2[0] = u[1] * e1[2] - u[2] * e1[1], e2[1] = u[2] * e1[0] - u[0] * e1[2], e2[2] = u[0] * e1[1] - u[1] * e1[0];
}

/* Grow n particles of diameter 1 (row 0 the seed, at the origin, also of
 * diameter 1) one at a time, each on a straight line of random direction u
 * and an offset uniform over the disk (3D) or segment (2D) of radius
 * R_max + 1 across u; it sticks at its first contact (centre distance 1).
 * An O(k) scan per particle: fine up to a few 1e5 particles. */
static void bpca_grow(int D, size_t n, uint64_t seed, double *pos)
{
    uint64_t s = seed;
    double rmax = 0;
    memset(pos, 0, (size_t)D * sizeof *pos);
    for (size_t k = 1; k < n; k++) {
        for (;;) {
            double u[3], e1[3], e2[3] = {0, 0, 0}, b[3] = {0, 0, 0}, o1, o2 = 0;
            bpca_frame(D, &s, u, e1, e2);
            const double R = rmax + 1;
            if (D == 2) {
                o1 = R * (2 * bpca_urand(&s) - 1);
            } else {
                const double rr = R * sqrt(bpca_urand(&s)), a = 2 * M_PI * bpca_urand(&s);
                o1 = rr * cos(a), o2 = rr * sin(a);
            }
            for (int q = 0; q < D; q++) b[q] = o1 * e1[q] + o2 * e2[q];
            double best = INFINITY;
            for (size_t c = 0; c < k; c++) {
                const double *p = pos + c * (size_t)D;
                double wu = 0, ww = 0;
                for (int q = 0; q < D; q++) {
                    const double w = b[q] - p[q];
                    wu += w * u[q], ww += w * w;
                }
                const double disc = wu * wu - (ww - 1);
                if (disc >= 0 && -wu - sqrt(disc) < best) best = -wu - sqrt(disc); /* entering */
            }
            if (best == INFINITY) continue; /* missed: a new line */
            double *p = pos + k * (size_t)D, r2 = 0;
            for (int q = 0; q < D; q++) p[q] = b[q] + best * u[q], r2 += p[q] * p[q];
            if (sqrt(r2) > rmax) rmax = sqrt(r2);
            break;
        }
    }
}

/* Mass-radius fractal dimension around c: least squares of log M(r)
 * against log r on 30 log-spaced r in [max(R / 20, 2), R / 2], R the
 * farthest particle from c but at most 2 rcap (the event model: rcap = L / 4,
 * so R <= L / 2). The inner limit skips the seed's neighbourhood, the outer
 * the still growing rim. NaN when the range is under a factor 3. */
static double bpca_mass_radius(const double *pos, size_t n, int D, const double *c, double rcap,
                               double *rmax_out)
{
    double *r = malloc((n ? n : 1) * sizeof *r), rmax = 0;
    *rmax_out = 0;
    if (!r) return NAN;
    for (size_t k = 0; k < n; k++) {
        double s2 = 0;
        for (int q = 0; q < D; q++) s2 += (pos[k * D + q] - c[q]) * (pos[k * D + q] - c[q]);
        r[k] = sqrt(s2);
        if (r[k] > rmax) rmax = r[k];
    }
    *rmax_out = rmax;
    if (rmax > 2 * rcap) rmax = 2 * rcap;
    const double r0 = fmax(rmax / 20, 2), r1 = rmax / 2;
    if (r1 < 3 * r0) return free(r), NAN;
    const int m = 30;
    double sl = 0, sll = 0, sy = 0, sly = 0;
    for (int j = 0; j < m; j++) {
        const double rr = r0 * pow(r1 / r0, (double)j / (m - 1));
        size_t cnt = 0;
        for (size_t k = 0; k < n; k++) cnt += r[k] <= rr;
        const double l = log(rr), y = log((double)cnt);
        sl += l, sll += l * l, sy += y, sly += l * y;
    }
    free(r);
    return (m * sly - sl * sy) / (m * sll - sl * sl);
}

#endif
