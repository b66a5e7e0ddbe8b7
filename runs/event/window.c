/*
 * window.c - mass-radius profile and windowed D_f of clusters exported by
 * `pdla export --format csv` (runs/event/window.sh; README "D_f in the
 * DLA window").
 *
 *   window DIM R_LO R_HI CX CY [CZ] FILE...
 *
 * Every FILE is one cluster (x,y[,z] first; the other columns are ignored),
 * centred on (CX, CY[, CZ]) (the seed: the event model's box centre, 0 for
 * pdla's DLA). For each file it prints N, R_max (farthest particle) and the
 * mass-radius D_f: the least-squares slope of log M(r) against log r on 16
 * log-spaced r in [R_LO, R_HI], M(r) the number of particle centres within
 * r of the seed. Then the mean of those slopes with its standard error
 * (sd / sqrt(files)), and the profile over the files: at r = 2^(j/4) the
 * mean M(r), the cluster's packing fraction inside r (M(r) v / V(r), v the
 * volume of a particle of radius 0.5, V(r) the d-ball of radius r) and the
 * local slope d ln <M> / d ln r from the two points r / sqrt2 and r sqrt2
 * (a factor 2 in r), with its standard error from the per-file local
 * slopes (sd / sqrt(files); nan with one file). Only r with every file's
 * R_max > r are printed: the outer rim of a cluster that is still growing
 * undercounts M.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_d(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The sorted distances from c of the rows of a csv file; NULL on error. */
static double *read_dist(const char *path, int D, const double *c, size_t *n)
{
    FILE *f = fopen(path, "r");
    if (!f) return NULL;
    char line[4096];
    size_t cap = 1 << 16;
    double *r = malloc(cap * sizeof *r);
    *n = 0;
    if (!fgets(line, sizeof line, f)) r = (free(r), NULL); /* the header */
    while (r && fgets(line, sizeof line, f)) {
        if (*n == cap) {
            double *q = realloc(r, (cap *= 2) * sizeof *r);
            if (!q) r = (free(r), NULL);
            else r = q;
            if (!r) break;
        }
        char *e = line;
        double s2 = 0;
        for (int q = 0; q < D; q++) {
            const double x = strtod(e, &e) - c[q];
            s2 += x * x;
            if (*e == ',') e++;
        }
        r[(*n)++] = sqrt(s2);
    }
    fclose(f);
    if (r) qsort(r, *n, sizeof *r, cmp_d);
    return r;
}

/* M(rr): centres within rr (r sorted). */
static double mass(const double *r, size_t n, double rr)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (r[mid] <= rr) lo = mid + 1;
        else hi = mid;
    }
    return (double)lo;
}

static double fit(const double *r, size_t n, double r0, double r1)
{
    const int m = 16;
    double sl = 0, sll = 0, sy = 0, sly = 0;
    for (int j = 0; j < m; j++) {
        const double rr = r0 * pow(r1 / r0, (double)j / (m - 1));
        const double l = log(rr), y = log(fmax(mass(r, n, rr), 1));
        sl += l, sll += l * l, sy += y, sly += l * y;
    }
    return (m * sly - sl * sy) / (m * sll - sl * sl);
}

int main(int argc, char **argv)
{
    const int D = argc > 1 ? atoi(argv[1]) : 0;
    if ((D != 2 && D != 3) || argc < 5 + D) {
        fprintf(stderr, "usage: window DIM R_LO R_HI CX CY [CZ] FILE...\n");
        return 2;
    }
    const double r0 = atof(argv[2]), r1 = atof(argv[3]);
    if (!(r0 > 0 && r1 > r0)) return fprintf(stderr, "window: need 0 < R_LO < R_HI\n"), 2;
    double c[3] = {0, 0, 0};
    for (int q = 0; q < D; q++) c[q] = atof(argv[4 + q]);
    const int nf = argc - 4 - D;
    double **r = calloc((size_t)nf, sizeof *r);
    size_t *n = calloc((size_t)nf, sizeof *n);
    if (!r || !n) return 1;
    double sum = 0, sum2 = 0, rmin = INFINITY;
    for (int i = 0; i < nf; i++) {
        const char *path = argv[4 + D + i];
        r[i] = read_dist(path, D, c, &n[i]);
        if (!r[i] || n[i] < 10) return fprintf(stderr, "window: cannot read %s\n", path), 1;
        const double rmax = r[i][n[i] - 1], df = fit(r[i], n[i], r0, r1);
        if (rmax < rmin) rmin = rmax;
        sum += df, sum2 += df * df;
        printf("file %s N %zu R_max %.1f D_f[%g,%g] %.4f\n", path, n[i], rmax, r0, r1, df);
    }
    const double mean = sum / nf, sd = nf > 1 ? sqrt(fmax(sum2 - nf * mean * mean, 0) / (nf - 1)) : NAN;
    printf("D_f[%g,%g] mean %.4f sd %.4f se %.4f files %d\n", r0, r1, mean, sd, sd / sqrt(nf), nf);
    const double v = D == 2 ? M_PI * 0.25 : M_PI / 6;
    printf("%10s %12s %10s %10s %10s\n", "r", "<M(r)>", "phi_c(r)", "slope", "slope_se");
    for (int j = 0;; j++) {
        const double rr = pow(2, j / 4.0), a = rr / sqrt(2), b = rr * sqrt(2);
        if (b > rmin) break;
        double m = 0, ma = 0, mb = 0, s1 = 0, s2 = 0;
        int ns = 0;
        for (int i = 0; i < nf; i++) {
            const double mai = mass(r[i], n[i], a), mbi = mass(r[i], n[i], b);
            m += mass(r[i], n[i], rr) / nf;
            ma += mai / nf;
            mb += mbi / nf;
            if (mai > 0) {
                const double si = log(mbi / mai) / log(2);
                s1 += si, s2 += si * si, ns++;
            }
        }
        const double sm = ns ? s1 / ns : NAN;
        const double se = ns > 1 ? sqrt(fmax(s2 - ns * sm * sm, 0) / (ns - 1) / ns) : NAN;
        const double V = D == 2 ? M_PI * rr * rr : 4 * M_PI / 3 * rr * rr * rr;
        const double s = ma > 0 ? log(mb / ma) / log(2) : NAN;
        printf("%10.2f %12.1f %10.4f %10.3f %10.3f\n", rr, m, m * v / V, s, se);
    }
    for (int i = 0; i < nf; i++) free(r[i]);
    free(r), free(n);
    return 0;
}
