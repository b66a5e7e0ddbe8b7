/*
 * ballistic.c - the reference for runs/event/ballistic.md: ballistic
 * particle-cluster aggregation (Vold 1963, Sutherland; the limit of an
 * infinite mean free path) and the same two fractal-dimension estimates
 * applied to any cluster that `pdla export --format csv` wrote.
 *
 *   ballistic bpca DIM N SEED     grow N particles of radius 0.5 onto a seed
 *                                 of radius 0.5, one at a time, each on a
 *                                 straight line of random direction and a
 *                                 random offset uniform over a disk (3D) or
 *                                 segment (2D) of radius R_max + 1 across it;
 *                                 it sticks at its first contact
 *   ballistic csv FILE [C...]     a cluster from `pdla export --format csv`
 *                                 (x,y[,z] first, rows in arrival order);
 *                                 C: the seed's coordinates when the file
 *                                 does not start with the seed (the event
 *                                 model's box centre: then the box side
 *                                 L = 2 C, the R_g(k) fit stops at L / 8
 *                                 as the model's does, and the mass-radius
 *                                 range at L / 4)
 *
 * Both print one line: N, R_max (the farthest particle from the seed), D_f
 * from R_g(k) in arrival order (ev_df_fit, the model's own fit; rg_max L / 8,
 * infinite without a box), its k range, and D_f from the mass-radius count
 * M(r) of the final cluster around the seed (row 0, or C), least squares of
 * log M against log r on 30 log-spaced r in [max(R / 20, 2), R / 2],
 * R = R_max (at most L / 2; NaN when that is less than a factor 3): the
 * inner part is the seed's neighbourhood, the outer the still growing rim.
 *
 * Build and run: runs/event/ballistic.sh (the link line is there).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pdla/event.h"

static uint64_t rng_s;
static double urand(void) /* splitmix64 */
{
    uint64_t z = (rng_s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}
static double gauss(void)
{
    const double u = urand() + 1e-300, v = urand();
    return sqrt(-2 * log(u)) * cos(2 * M_PI * v);
}

/* A unit vector u and two unit vectors e1, e2 across it (e2 unused in 2D). */
static void frame(int D, double *u, double *e1, double *e2)
{
    if (D == 2) {
        const double a = 2 * M_PI * urand();
        u[0] = cos(a), u[1] = sin(a);
        e1[0] = -u[1], e1[1] = u[0];
        return;
    }
    double n = 0;
    for (int q = 0; q < 3; q++) u[q] = gauss(), n += u[q] * u[q];
    n = sqrt(n);
    for (int q = 0; q < 3; q++) u[q] /= n;
    const double a[3] = {fabs(u[0]) < 0.9 ? 1 : 0, fabs(u[0]) < 0.9 ? 0 : 1, 0};
    e1[0] = a[1] * u[2] - a[2] * u[1], e1[1] = a[2] * u[0] - a[0] * u[2], e1[2] = a[0] * u[1] - a[1] * u[0];
    n = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (int q = 0; q < 3; q++) e1[q] /= n;
    e2[0] = u[1] * e1[2] - u[2] * e1[1], e2[1] = u[2] * e1[0] - u[0] * e1[2], e2[2] = u[0] * e1[1] - u[1] * e1[0];
}

/* BPCA: pos gets n rows (row 0 the seed at the origin). Every particle and
 * the seed have diameter 1: contact at centre distance 1. The line is
 * x(s) = b + s u, b the offset across u; the first contact is the smallest
 * s with |x(s) - c| = 1 over all c in the cluster (an O(k) scan: fine for
 * n up to a few 1e4). */
static void bpca(int D, size_t n, double *pos)
{
    memset(pos, 0, (size_t)D * sizeof *pos);
    double rmax = 0;
    for (size_t k = 1; k < n; k++) {
        for (;;) {
            double u[3], e1[3], e2[3] = {0, 0, 0}, b[3] = {0, 0, 0};
            frame(D, u, e1, e2);
            const double R = rmax + 1;
            double o1, o2 = 0;
            if (D == 2) {
                o1 = R * (2 * urand() - 1);
            } else {
                const double rr = R * sqrt(urand()), a = 2 * M_PI * urand();
                o1 = rr * cos(a), o2 = rr * sin(a);
            }
            for (int q = 0; q < D; q++) b[q] = o1 * e1[q] + o2 * e2[q];
            double best = INFINITY;
            for (size_t c = 0; c < k; c++) {
                const double *p = pos + c * (size_t)D;
                double w[3], wu = 0, ww = 0;
                for (int q = 0; q < D; q++) w[q] = b[q] - p[q], wu += w[q] * u[q], ww += w[q] * w[q];
                const double disc = wu * wu - (ww - 1);
                if (disc < 0) continue;
                const double s = -wu - sqrt(disc); /* entering the contact sphere */
                if (s < best) best = s;
            }
            if (best == INFINITY) continue; /* missed the cluster: a new line */
            double *p = pos + k * (size_t)D, r2 = 0;
            for (int q = 0; q < D; q++) p[q] = b[q] + best * u[q], r2 += p[q] * p[q];
            if (sqrt(r2) > rmax) rmax = sqrt(r2);
            break;
        }
    }
}

static double mass_radius(const double *pos, size_t n, int D, const double *c, double rcap, double *rmax_out)
{
    double *r = malloc(n * sizeof *r), rmax = 0;
    *rmax_out = 0;
    if (!r) return NAN;
    for (size_t k = 0; k < n; k++) {
        double s = 0;
        for (int q = 0; q < D; q++) s += (pos[k * D + q] - c[q]) * (pos[k * D + q] - c[q]);
        r[k] = sqrt(s);
        if (r[k] > rmax) rmax = r[k];
    }
    *rmax_out = rmax;
    if (rmax > 2 * rcap) rmax = 2 * rcap;
    const double r0 = fmax(rmax / 20, 2), r1 = rmax / 2; /* r0: a few diameters out at least */
    if (r1 < 3 * r0) return free(r), NAN;
    const int m = 30;
    double sl = 0, sll = 0, sy = 0, sly = 0;
    for (int j = 0; j < m; j++) {
        const double rr = r0 * pow(r1 / r0, (double)j / (m - 1));
        size_t c = 0;
        for (size_t k = 0; k < n; k++) c += r[k] <= rr;
        const double l = log(rr), y = log((double)c);
        sl += l, sll += l * l, sy += y, sly += l * y;
    }
    free(r);
    return (m * sly - sl * sy) / (m * sll - sl * sl);
}

/* L: the event model's box side, or infinity. */
static void report(const char *what, const double *pos, size_t n, int D, const double *c, double L)
{
    uint64_t lo, hi;
    const double df = ev_df_fit(pos, n, D, L / 8, NULL, &lo, &hi);
    double rmax;
    const double dm = mass_radius(pos, n, D, c, L / 4, &rmax);
    printf("%-36s dim %d N %zu R_max %.1f D_f_rg %.4f (k %llu-%llu) D_f_mass %.4f\n", what, D, n, rmax,
           df, (unsigned long long)lo, (unsigned long long)hi, dm);
}

static double *read_csv(const char *path, size_t *n, int *D)
{
    FILE *f = fopen(path, "r");
    if (!f) return NULL;
    char line[4096];
    if (!fgets(line, sizeof line, f)) return fclose(f), NULL;
    *D = strncmp(line, "x,y,z", 5) == 0 ? 3 : 2;
    size_t cap = 1 << 16;
    double *pos = malloc(cap * 3 * sizeof *pos);
    *n = 0;
    while (pos && fgets(line, sizeof line, f)) {
        if (*n == cap) {
            double *q = realloc(pos, (cap *= 2) * 3 * sizeof *pos);
            if (!q) return free(pos), fclose(f), NULL;
            pos = q;
        }
        char *e = line;
        for (int q = 0; q < *D; q++) {
            pos[*n * *D + q] = strtod(e, &e);
            if (*e == ',') e++;
        }
        (*n)++;
    }
    fclose(f);
    return pos;
}

int main(int argc, char **argv)
{
    if (argc == 5 && !strcmp(argv[1], "bpca")) {
        const int D = atoi(argv[2]);
        const size_t n = (size_t)atof(argv[3]);
        rng_s = strtoull(argv[4], NULL, 10);
        if ((D != 2 && D != 3) || n < 100) return fprintf(stderr, "ballistic: bad DIM or N\n"), 2;
        double *pos = malloc(n * (size_t)D * sizeof *pos);
        if (!pos) return 1;
        bpca(D, n, pos);
        char what[64];
        snprintf(what, sizeof what, "bpca seed %s", argv[4]);
        report(what, pos, n, D, pos, INFINITY);
        free(pos);
        return 0;
    }
    if ((argc == 3 || argc == 5 || argc == 6) && !strcmp(argv[1], "csv")) {
        size_t n;
        int D;
        double *pos = read_csv(argv[2], &n, &D);
        if (!pos || n < 100) return fprintf(stderr, "ballistic: cannot read %s\n", argv[2]), 1;
        double c[3] = {0, 0, 0};
        if (argc > 3 && argc != 3 + D) return fprintf(stderr, "ballistic: %d seed coordinates\n", D), 2;
        for (int q = 0; q < D; q++) c[q] = argc > 3 ? atof(argv[3 + q]) : pos[q];
        report(argv[2], pos, n, D, c, argc > 3 ? 2 * c[0] : INFINITY);
        free(pos);
        return 0;
    }
    fprintf(stderr, "usage: ballistic bpca DIM N SEED | ballistic csv FILE [SEED_X SEED_Y [SEED_Z]]\n");
    return 2;
}
