/*
 * ev_check_geom.c - `pdla check`'s overlap check of an event-model file: no
 * two bodies (seeds, stuck and free particles) closer than their contact
 * distance beyond evc_tol, in O(N) on grids of cells.
 *
 * The particles and the seeds no larger than them go into one grid of
 * cells no smaller than the largest particle diameter (the engine's cells,
 * ev_sim.c size_cells), so every pair that can touch lies in neighbouring
 * cells. A seed larger than every particle (a --seeds file may hold seeds
 * of any size) is in no cell list, as in the engine (ev_big.c): it scans
 * the cells its contact distance reaches. The large seeds among themselves
 * go the same way by halves: the smaller half in a grid of its own, which
 * the larger half scans, then the larger half again; about log2 of their
 * number levels (at most EV_MAX_SEEDS seeds). Cells are no more than about
 * 2 per body, so a tiny radius in a big box costs no memory. A forged file
 * can still crowd many bodies into a cell: the comparisons are counted,
 * and past a budget far above what a valid file takes the check stops
 * as a failure.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "ev_check.h"

typedef struct grid {
    int D, periodic;
    double L, w, rmax; /* box side, cell side, largest radius in the grid */
    int64_t nc;        /* cells a side */
    uint32_t *start;   /* the bodies of cell c: item[start[c] .. start[c + 1]) */
    uint32_t *item;
} grid;

typedef struct scan_ctx {
    const evc_data *d;
    const evc_bodies *b;
    ev_check_report *r;
    double ro;
    uint64_t work, budget; /* cells visited and pairs compared; the most allowed */
} scan_ctx;

/* A coordinate in the box: wrapped when periodic, else clamped (moving
 * points no farther apart, so neighbours stay neighbouring cells). */
static double in_box(const grid *g, double x)
{
    if (g->periodic) x -= g->L * floor(x / g->L);
    return x < 0 ? 0 : x > g->L ? g->L : x;
}

static int64_t axis_cell(const grid *g, double y)
{
    const double c = floor(y / g->w);
    return c < 0 ? 0 : c >= (double)g->nc ? g->nc - 1 : (int64_t)c;
}

static uint64_t cell_of(const grid *g, const double *x)
{
    uint64_t c = 0;
    for (int k = g->D - 1; k >= 0; k--) c = c * (uint64_t)g->nc + (uint64_t)axis_cell(g, in_box(g, x[k]));
    return c;
}

static void grid_free(grid *g)
{
    free(g->start);
    free(g->item);
    g->start = g->item = NULL;
}

/* The grid of bodies ids[0 .. n): cells no smaller than twice the largest
 * radius (times 1 + 1e-9, so a contact rounded across a face still falls
 * in a neighbour), and at most about 2 n + 27 of them. 0, or -1 when out
 * of memory. */
static int grid_build(grid *g, const evc_data *d, const evc_bodies *b, const uint32_t *ids, size_t n)
{
    const int D = d->dim;
    g->D = D;
    g->periodic = d->periodic;
    g->L = d->L;
    g->rmax = 0;
    for (size_t q = 0; q < n; q++) g->rmax = fmax(g->rmax, b->r[ids[q]]);
    const double most = floor(pow(fmin(2.0 * (double)n + 27, 2147483648.0), 1.0 / D));
    double nc = g->rmax > 0 ? floor(d->L / (2 * g->rmax * (1 + 1e-9))) : most;
    nc = nc < 1 ? 1 : nc > most ? most : nc;
    g->nc = (int64_t)nc;
    g->w = d->L / nc;
    const uint64_t ncell = (uint64_t)g->nc * (uint64_t)g->nc * (D == 3 ? (uint64_t)g->nc : 1);
    g->start = calloc(ncell + 2, sizeof *g->start);
    g->item = malloc((n ? n : 1) * sizeof *g->item);
    uint32_t *cell = malloc((n ? n : 1) * sizeof *cell);
    if (!g->start || !g->item || !cell) {
        free(cell);
        grid_free(g);
        return -1;
    }
    for (size_t q = 0; q < n; q++) {
        cell[q] = (uint32_t)cell_of(g, b->x + (size_t)ids[q] * D);
        g->start[cell[q] + 2]++;
    }
    for (uint64_t c = 0; c < ncell; c++) g->start[c + 2] += g->start[c + 1];
    for (size_t q = 0; q < n; q++) g->item[g->start[cell[q] + 1]++] = ids[q];
    free(cell);
    return 0;
}

/* Bodies a and j, compared: the deepest overlap so far, and a failure
 * beyond evc_tol of their contact distance (two positions' round-off). */
static void compare(scan_ctx *s, uint32_t a, uint32_t j)
{
    const evc_bodies *b = s->b;
    const int D = s->d->dim;
    const double sig = b->r[a] + b->r[j];
    const double dist = sqrt(evc_dist2(b->x + (size_t)a * D, b->x + (size_t)j * D, D, s->d->periodic, s->d->L));
    s->r->pairs++;
    const double ov = (sig - dist) / sig;
    if (ov > s->r->worst_overlap) s->r->worst_overlap = ov;
    const double tol = evc_tol(sig, 2 * s->ro);
    if (!(sig - dist > tol)) return;
    char na[80], nb[80];
    evc_body_name(s->d, a < j ? a : j, na, sizeof na);
    evc_body_name(s->d, a < j ? j : a, nb, sizeof nb);
    evc_fail(s->r, EV_CHECK_OVERLAP, a < j ? a : j, a < j ? j : a, dist, sig,
             "%s and %s overlap: centres %.17g apart, contact distance %.17g (%.3g of it, tolerance %.3g)", na, nb,
             dist, sig, ov, tol / sig);
}

/* The cells [lo, lo + span) on one axis that a body at y reaches within
 * `reach`: clamped to the grid, or wrapped when periodic (every cell once
 * when the reach spans the box). */
static void axis_range(const grid *g, double y, double reach, int64_t *lo, int64_t *span)
{
    const double a = floor((y - reach) / g->w), z = floor((y + reach) / g->w);
    const double n = (double)g->nc;
    if (g->periodic) {
        if (!(z - a + 1 < n)) {
            *lo = 0, *span = g->nc;
            return;
        }
        *lo = (int64_t)a, *span = (int64_t)(z - a + 1);
        return;
    }
    const double l = a < 0 ? 0 : a > n - 1 ? n - 1 : a, h = z < 0 ? 0 : z > n - 1 ? n - 1 : z;
    *lo = (int64_t)l, *span = (int64_t)(h - l + 1);
}

/* Body a against the bodies of g its contact distance can reach (same: a
 * is in g, and each pair is compared once, from its lower number). 1 when
 * the budget ran out. */
static int scan(scan_ctx *s, const grid *g, uint32_t a, int same)
{
    const int D = g->D;
    const double *x = s->b->x + (size_t)a * D;
    const double reach = (s->b->r[a] + g->rmax) * (1 + 1e-9) + 1e-9 * g->w;
    int64_t lo[3] = {0, 0, 0}, span[3] = {1, 1, 1}, c[3] = {0, 0, 0};
    for (int k = 0; k < D; k++) axis_range(g, in_box(g, x[k]), reach, &lo[k], &span[k]);
    for (;;) {
        uint64_t cell = 0;
        for (int k = D - 1; k >= 0; k--) {
            int64_t i = lo[k] + c[k];
            i = ((i % g->nc) + g->nc) % g->nc; /* wraps only when periodic: else in range */
            cell = cell * (uint64_t)g->nc + (uint64_t)i;
        }
        s->work++;
        for (uint32_t q = g->start[cell]; q < g->start[cell + 1] && !s->r->stopped; q++) {
            const uint32_t j = g->item[q];
            if (same ? j <= a : j == a) continue;
            s->work++;
            compare(s, a, j);
        }
        if (s->work > s->budget || s->r->stopped) return s->work > s->budget;
        int k = 0;
        while (k < D && ++c[k] == span[k]) c[k++] = 0;
        if (k == D) return 0;
    }
}

/* Bodies of ids[lo, hi) in a grid, against each other, and the larger
 * ones big[from, nbig) scanning it. 0, 1 (budget spent) or -1 (memory). */
static int level(scan_ctx *s, const uint32_t *ids, size_t n, const uint32_t *big, size_t nbig)
{
    grid g = {0};
    if (grid_build(&g, s->d, s->b, ids, n)) return -1;
    int rc = 0;
    for (size_t q = 0; q < n && !rc && !s->r->stopped; q++) rc = scan(s, &g, ids[q], 1);
    for (size_t q = 0; q < nbig && !rc && !s->r->stopped; q++) rc = scan(s, &g, big[q], 0);
    grid_free(&g);
    return rc;
}

typedef struct by_r {
    double r;
    uint32_t id;
} by_r;
static int by_radius(const void *pa, const void *pb)
{
    const by_r *a = pa, *b = pb;
    return a->r < b->r ? -1 : a->r > b->r ? 1 : (a->id > b->id) - (a->id < b->id);
}

static int body_ok(const evc_bodies *b, size_t i, int D)
{
    int ok = b->r[i] > 0 && b->r[i] < INFINITY;
    for (int k = 0; k < D; k++) ok &= isfinite(b->x[i * (size_t)D + k]);
    return ok;
}

/* Splits the usable bodies (finite centre, positive finite radius: the
 * others are failures of their own) into those no larger than the largest
 * particle (small[]) and the larger seeds (big[]). */
static void split(const evc_data *d, const evc_bodies *b, uint32_t *small, size_t *ns, uint32_t *big, size_t *nb)
{
    const int D = d->dim;
    double rp = 0;
    for (size_t i = d->nseeds; i < b->n; i++)
        if (body_ok(b, i, D)) rp = fmax(rp, b->r[i]);
    *ns = *nb = 0;
    for (size_t i = 0; i < b->n; i++) {
        if (!body_ok(b, i, D)) continue;
        if (i < d->nseeds && b->r[i] > rp) big[(*nb)++] = (uint32_t)i;
        else small[(*ns)++] = (uint32_t)i;
    }
}

/* big[] in the order of their radii (ties by number): 0, or -1 (memory). */
static int sort_big(const evc_bodies *b, uint32_t *big, size_t nb)
{
    by_r *t = malloc((nb ? nb : 1) * sizeof *t);
    if (!t) return -1;
    for (size_t q = 0; q < nb; q++) t[q] = (by_r){b->r[big[q]], big[q]};
    qsort(t, nb, sizeof *t, by_radius);
    for (size_t q = 0; q < nb; q++) big[q] = t[q].id;
    free(t);
    return 0;
}

int evc_overlaps(const evc_data *d, const evc_bodies *b, double ro, ev_check_report *r)
{
    /* a valid file compares each body with the few in 3^d cells, about 30
     * to 60 steps a body in 3D; the budget is far above that */
    scan_ctx s = {d, b, r, ro, 0, 1000000000u + 1000u * (uint64_t)b->n};
    uint32_t *small = malloc((b->n ? b->n : 1) * sizeof *small), *big = malloc((d->nseeds + 1) * sizeof *big);
    size_t ns = 0, nb = 0;
    int rc = small && big ? 0 : -1;
    if (!rc) split(d, b, small, &ns, big, &nb);
    if (!rc) rc = sort_big(b, big, nb);
    /* the particles and small seeds among themselves, the large seeds against them */
    if (!rc && ns) rc = level(&s, small, ns, big, nb);
    /* the large seeds by halves: the smaller half against itself and the rest */
    for (size_t lo = 0; !rc && lo < nb && !r->stopped;) {
        const size_t hi = lo + (nb - lo + 1) / 2;
        rc = level(&s, big + lo, hi - lo, big + hi, nb - hi);
        lo = hi;
    }
    if (rc == 1)
        evc_fail(r, EV_CHECK_OVERLAP, -1, -1, (double)s.work, (double)s.budget,
                 "stopped after %llu steps: bodies crowded into cells far beyond what a run leaves",
                 (unsigned long long)s.work);
    free(small);
    free(big);
    return rc < 0 ? -1 : 0;
}
