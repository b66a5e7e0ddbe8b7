/*
 * ballistic.c - the reference for runs/event/README.md (ballistic.sh): ballistic
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
 *   ballistic bpca DIM N SEED OUT the same cluster written to OUT as csv
 *                                 (x,y[,z], the seed first; for window.c)
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
#include "bpca.h" /* tests/event: the BPCA growth and the mass-radius fit */

/* L: the event model's box side, or infinity. */
static void report(const char *what, const double *pos, size_t n, int D, const double *c, double L)
{
    uint64_t lo, hi;
    const double df = ev_df_fit(pos, n, D, L / 8, NULL, &lo, &hi);
    double rmax;
    const double dm = bpca_mass_radius(pos, n, D, c, L / 4, &rmax);
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
    if ((argc == 5 || argc == 6) && !strcmp(argv[1], "bpca")) {
        const int D = atoi(argv[2]);
        const size_t n = (size_t)atof(argv[3]);
        if ((D != 2 && D != 3) || n < 100) return fprintf(stderr, "ballistic: bad DIM or N\n"), 2;
        double *pos = malloc(n * (size_t)D * sizeof *pos);
        if (!pos) return 1;
        bpca_grow(D, n, strtoull(argv[4], NULL, 10), pos);
        char what[64];
        snprintf(what, sizeof what, "bpca seed %s", argv[4]);
        report(what, pos, n, D, pos, INFINITY);
        FILE *f = argc == 6 ? fopen(argv[5], "w") : NULL;
        if (argc == 6 && !f) return free(pos), fprintf(stderr, "ballistic: cannot write %s\n", argv[5]), 1;
        if (f) {
            fputs(D == 3 ? "x,y,z\n" : "x,y\n", f);
            for (size_t k = 0; k < n; k++)
                for (int q = 0; q < D; q++) fprintf(f, "%.10g%c", pos[k * D + q], q == D - 1 ? '\n' : ',');
            if (fclose(f)) return free(pos), fprintf(stderr, "ballistic: cannot write %s\n", argv[5]), 1;
        }
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
    fprintf(stderr, "usage: ballistic bpca DIM N SEED [OUT.csv] | ballistic csv FILE [SEED_X SEED_Y [SEED_Z]]\n");
    return 2;
}
