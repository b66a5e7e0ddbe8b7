/*
 * ev_seeds.c - immobile seeds from a file (--seeds FILE) instead of the
 * central one. A line per seed: x y [z] radius (dim coordinates, then the
 * radius), in box coordinates; blank lines and # comments are skipped.
 * Refused with one line naming the file and line: a line that is not
 * dim + 1 finite numbers, a radius <= 0, more than EV_MAX_SEEDS seeds, no
 * seed at all; once the box is known (ev_seeds_check): a seed not inside
 * the box (elastic walls: the whole disk/sphere; periodic: its centre in
 * [0, side)) or two seeds that overlap (distance < sum of radii; periodic:
 * nearest image).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "ev_internal.h"

/* One seed line into xr[0 .. D]: 0, 1 (blank or comment), -1 (bad). The
 * numbers are decimal, as everywhere on the command line (cli_parse_real):
 * strtod's hexadecimal (0x5) is refused. */
static int parse_line(char *line, int D, double *xr)
{
    char *hash = strchr(line, '#');
    if (hash) *hash = '\0';
    char *c = line;
    while (*c == ' ' || *c == '\t' || *c == '\r' || *c == '\n') c++;
    if (!*c) return 1;
    for (int k = 0; k <= D; k++) {
        while (*c == ' ' || *c == '\t') c++;
        char *end;
        errno = 0;
        xr[k] = strtod(c, &end);
        if (end == c || errno == ERANGE || !isfinite(xr[k])) return -1;
        if (strspn(c, "0123456789.eE+-") < (size_t)(end - c)) return -1;
        c = end;
    }
    while (*c == ' ' || *c == '\t' || *c == '\r' || *c == '\n') c++;
    return *c ? -1 : 0;
}

/* The next line of f into buf (without its newline): its length, -1 at the
 * end of the file, -2 for a NUL byte (it would end the line silently),
 * -3 for a line that does not fit (fgets split it in two). */
static long next_line(FILE *f, char *buf, size_t size)
{
    size_t n = 0;
    int ch, bad = 0;
    while ((ch = getc(f)) != EOF && ch != '\n') {
        if (ch == '\0') bad = bad ? bad : -2;
        else if (n + 1 == size) bad = bad ? bad : -3;
        else buf[n++] = (char)ch;
    }
    buf[n] = '\0';
    if (bad) return bad;
    return ch == EOF && n == 0 ? -1 : (long)n;
}

static int read_lines(ev_sim *s, FILE *f, const char *path, char *err, size_t errlen)
{
    const int D = s->dim;
    char buf[1024];
    size_t cap = 0;
    int line = 0;
    long len;
    while ((len = next_line(f, buf, sizeof buf)) != -1) {
        line++;
        if (len == -2) return pdla_errorf(-1, err, errlen, "--seeds %s:%d: a NUL byte in the line", path, line);
        if (len == -3)
            return pdla_errorf(-1, err, errlen, "--seeds %s:%d: line longer than %zu bytes", path, line,
                               sizeof buf - 1);
        double xr[4];
        const int r = parse_line(buf, D, xr);
        if (r == 1) continue;
        if (r < 0)
            return pdla_errorf(-1, err, errlen, "--seeds %s:%d: want %d decimal numbers (x y%s radius)", path,
                               line, D + 1, D == 3 ? " z" : "");
        if (!(xr[D] >= EV_RADIUS_MIN))
            return pdla_errorf(-1, err, errlen, "--seeds %s:%d: radius must be >= %g", path, line, EV_RADIUS_MIN);
        if (s->nseeds == EV_MAX_SEEDS)
            return pdla_errorf(-1, err, errlen, "--seeds %s: more than %d seeds", path, EV_MAX_SEEDS);
        if (s->nseeds == cap) {
            cap = cap ? 2 * cap : 64;
            double *t = realloc(s->seed_xr, cap * (size_t)(D + 1) * sizeof *t);
            if (!t) return pdla_errorf(-1, err, errlen, "--seeds %s: out of memory", path);
            s->seed_xr = t;
        }
        memcpy(s->seed_xr + (size_t)s->nseeds * (size_t)(D + 1), xr, (size_t)(D + 1) * sizeof *xr);
        s->nseeds++;
    }
    if (ferror(f)) return pdla_errorf(-1, err, errlen, "--seeds %s: read error", path);
    if (!s->nseeds) return pdla_errorf(-1, err, errlen, "--seeds %s: no seed in the file", path);
    return 0;
}

int ev_seeds_read(ev_sim *s, const char *path, char *err, size_t errlen)
{
    /* Regular files only: opening a FIFO would block. */
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return pdla_errorf(-1, err, errlen, "--seeds %s: not a readable regular file", path);
    FILE *f = fopen(path, "r");
    if (!f) return pdla_errorf(-1, err, errlen, "--seeds %s: %s", path, strerror(errno));
    s->nseeds = 0;
    const int rc = read_lines(s, f, path, err, errlen);
    fclose(f);
    return rc;
}

/* Can a free particle of a sticky kind touch the seed of radius R at c?
 * Between walls a particle of radius rp keeps its centre in
 * [rp, L - rp]^D, so it can touch the seed when that box comes within
 * rp + R of c; a small seed in a corner lies beyond every particle's reach.
 * A periodic box has no such corner. */
static int seed_reachable(const ev_sim *s, const double *c, double R)
{
    if (s->periodic) return 1;
    const int D = s->dim;
    for (int k = 0; k < s->nspecies; k++) {
        if (!s->sp[k].sticky) continue;
        const double rp = s->sp[k].radius, sig = rp + R;
        double d2 = 0;
        for (int a = 0; a < D; a++) {
            const double lo = rp, hi = s->L - rp;
            const double g = c[a] < lo ? lo - c[a] : c[a] > hi ? c[a] - hi : 0;
            d2 += g * g;
        }
        if (d2 <= sig * sig) return 1;
    }
    return 0;
}

/* A run that stops only when every particle has stuck never ends when no
 * seed can be touched (the particles bounced forever; found by an
 * adversarial test): refused then, as a run where nothing sticks is
 * (ev_params_check). With --t-max or --max-events it is a plain gas.
 * `reachable`: whether some seed can be touched. */
static int reach_line(const ev_sim *s, int reachable, char *err, size_t errlen)
{
    if (reachable || s->par.t_max > 0 || s->par.max_events > 0) return 0;
    return pdla_errorf(-1, err, errlen, "--seeds %s: no particle of a sticky kind can reach any seed between the "
                       "walls (too near a corner): move a seed or give --t-max or --max-events", s->par.seeds);
}

/* The file's seeds (seed_xr, while building). */
static int reach_check(const ev_sim *s, char *err, size_t errlen)
{
    int reachable = 0;
    for (uint32_t a = 0; a < s->nseeds && !reachable; a++) {
        const double *c = s->seed_xr + (size_t)a * (size_t)(s->dim + 1);
        reachable = seed_reachable(s, c, c[s->dim]);
    }
    return reach_line(s, reachable, err, errlen);
}

/* The seeds as placed (particles n .. ntot - 1), for a resume whose stop
 * conditions changed after the load: the load checked the checkpoint's own
 * (a --t-max 5 run resumed with --t-max 0 ran for ever). */
int ev_stop_possible(const ev_sim *s, char *err, size_t errlen)
{
    if (!s->par.seeds[0]) return 0; /* the central seed: the box is sized to reach it */
    int reachable = 0;
    for (uint32_t a = s->n; a < s->ntot && !reachable; a++) {
        const double *p = EV_P_ANY(s, a);
        reachable = seed_reachable(s, p, p[2 * s->dim + 1]);
    }
    return reach_line(s, reachable, err, errlen);
}

/* ---- the overlap check ----------------------------------------------------
 * Every pair is checked, but not by all pairs (1e5 seeds made 5e9 distance
 * checks, 7 s): the seeds with the EV_SEEDS_BIG largest radii ("big") are
 * checked against every seed, the others against the others in their own
 * and the neighbouring cells of a grid whose cells are at least two of
 * their radii wide. The answer is all pairs' answer, the lexicographically
 * first overlapping pair (a, b), so the message is the same. */
#define EV_SEEDS_BIG 64

static const double *seed_at(const ev_sim *s, uint32_t i)
{
    return s->seed_xr + (size_t)i * (size_t)(s->dim + 1);
}

static int seeds_overlap(const ev_sim *s, uint32_t a, uint32_t b)
{
    const double *p = seed_at(s, a), *q = seed_at(s, b);
    const double sig = p[s->dim] + q[s->dim];
    return ev_dist2(s, p, q) < sig * sig;
}

static int cmp_desc(const void *x, const void *y)
{
    const double a = *(const double *)x, b = *(const double *)y;
    return (a < b) - (a > b);
}

typedef struct seed_grid {
    int m;            /* cells per axis; 1: one cell, every small pair checked */
    double rcut;      /* seeds with a larger radius are big */
    uint32_t *start;  /* m^D + 1 offsets into order */
    uint32_t *order;  /* the small seeds, by cell, in index order in a cell */
    uint32_t *big;    /* the big seeds, in index order */
    uint32_t nbig;
} seed_grid;

/* x's cell along axis k, clamped into the grid (a periodic coordinate may
 * round up to L). */
static int grid_coord(const ev_sim *s, const seed_grid *g, const double *x, int k)
{
    const long i = (long)floor(x[k] / s->L * g->m);
    return (int)(i < 0 ? 0 : i >= g->m ? g->m - 1 : i);
}

static size_t grid_cell(const ev_sim *s, const seed_grid *g, const double *x)
{
    size_t c = 0;
    for (int k = s->dim - 1; k >= 0; k--) c = c * (size_t)g->m + (size_t)grid_coord(s, g, x, k);
    return c;
}

/* rcut: the radius of the (EV_SEEDS_BIG + 1)-th largest seed, so at most
 * EV_SEEDS_BIG seeds are bigger; cells at least 2 rcut wide, at most about
 * 2 n of them, and 3 per axis or one in all (with fewer a neighbour would
 * be counted twice). -1: out of memory. */
static int grid_build(const ev_sim *s, seed_grid *g)
{
    const uint32_t n = s->nseeds;
    const int D = s->dim;
    double *r = malloc((size_t)n * sizeof *r);
    if (!r) return -1;
    for (uint32_t i = 0; i < n; i++) r[i] = seed_at(s, i)[D];
    qsort(r, n, sizeof *r, cmp_desc);
    g->rcut = r[n > EV_SEEDS_BIG ? EV_SEEDS_BIG : n - 1];
    free(r);
    /* a cell a hair wider than 2 rcut: rounding in grid_cell cannot then
     * put two overlapping seeds two cells apart */
    double m = floor(s->L / (2.0 * g->rcut * (1.0 + 1e-9)));
    const double mmax = floor(pow(2.0 * n, 1.0 / D));
    m = m > mmax ? mmax : m;
    g->m = m >= 3 ? (int)m : 1;
    size_t cells = 1;
    for (int k = 0; k < D; k++) cells *= (size_t)g->m;
    g->start = calloc(cells + 1, sizeof *g->start);
    g->order = malloc((size_t)n * sizeof *g->order);
    g->big = malloc((n < EV_SEEDS_BIG ? n : EV_SEEDS_BIG) * sizeof *g->big);
    if (!g->start || !g->order || !g->big) return -1;
    g->nbig = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (seed_at(s, i)[D] > g->rcut) g->big[g->nbig++] = i;
        else g->start[grid_cell(s, g, seed_at(s, i)) + 1]++;
    }
    for (size_t c = 0; c < cells; c++) g->start[c + 1] += g->start[c];
    uint32_t *fill = malloc(cells * sizeof *fill);
    if (!fill) return -1;
    memcpy(fill, g->start, cells * sizeof *fill);
    for (uint32_t i = 0; i < n; i++)
        if (seed_at(s, i)[D] <= g->rcut) g->order[fill[grid_cell(s, g, seed_at(s, i))]++] = i;
    free(fill);
    return 0;
}

/* The smallest b > a among small seed a's grid neighbours that overlaps a;
 * UINT32_MAX if none. */
static uint32_t grid_first(const ev_sim *s, const seed_grid *g, uint32_t a)
{
    const int D = s->dim, m = g->m;
    const double *x = seed_at(s, a);
    int ci[3] = {0, 0, 0};
    for (int k = 0; k < D; k++) ci[k] = grid_coord(s, g, x, k);
    const int span = m == 1 ? 1 : 3, nb = D == 2 ? span * span : span * span * span;
    uint32_t best = UINT32_MAX;
    for (int t = 0; t < nb; t++) {
        size_t c = 0;
        int inside = 1, tt = t;
        for (int k = D - 1; k >= 0; k--) {
            const int off = m == 1 ? 0 : (k == 0 ? tt % 3 : k == 1 ? tt / 3 % 3 : tt / 9) - 1;
            int j = ci[k] + off;
            if (j < 0 || j >= m) {
                if (!s->periodic) inside = 0;
                j = (j + m) % m;
            }
            c = c * (size_t)m + (size_t)j;
        }
        if (!inside) continue;
        for (uint32_t u = g->start[c]; u < g->start[c + 1]; u++) {
            const uint32_t b = g->order[u];
            if (b > a && b < best && seeds_overlap(s, a, b)) best = b;
        }
    }
    return best;
}

/* 1 with the first overlapping pair (*a < *b), 0 if none, -1 out of memory. */
static int overlap_first(const ev_sim *s, uint32_t *pa, uint32_t *pb)
{
    seed_grid g = {0};
    int rc = grid_build(s, &g);
    for (uint32_t a = 0; rc == 0 && a < s->nseeds; a++) {
        uint32_t best = UINT32_MAX;
        if (seed_at(s, a)[s->dim] > g.rcut) {
            for (uint32_t b = a + 1; b < s->nseeds && best == UINT32_MAX; b++)
                if (seeds_overlap(s, a, b)) best = b;
        } else {
            best = grid_first(s, &g, a);
            for (uint32_t k = 0; k < g.nbig; k++)
                if (g.big[k] > a && g.big[k] < best && seeds_overlap(s, a, g.big[k])) best = g.big[k];
        }
        if (best != UINT32_MAX) {
            *pa = a;
            *pb = best;
            rc = 1;
        }
    }
    free(g.start);
    free(g.order);
    free(g.big);
    return rc;
}

int ev_seeds_check(const ev_sim *s, char *err, size_t errlen)
{
    const int D = s->dim;
    const char *path = s->par.seeds;
    for (uint32_t a = 0; a < s->nseeds; a++) {
        const double *p = s->seed_xr + (size_t)a * (size_t)(D + 1);
        for (int k = 0; k < D; k++) {
            const double lo = s->periodic ? 0 : p[D], hi = s->periodic ? s->L : s->L - p[D];
            if (!(p[k] >= lo && (s->periodic ? p[k] < hi : p[k] <= hi)))
                return pdla_errorf(-1, err, errlen, "--seeds %s: seed %u (radius %g) is outside the box of side %g",
                            path, a + 1, p[D], s->L);
        }
    }
    uint32_t a, b;
    const int rc = overlap_first(s, &a, &b);
    if (rc < 0) return pdla_errorf(-1, err, errlen, "--seeds %s: out of memory checking %u seeds", path, s->nseeds);
    if (rc) return pdla_errorf(-1, err, errlen, "--seeds %s: seeds %u and %u overlap", path, a + 1, b + 1);
    return reach_check(s, err, errlen);
}
