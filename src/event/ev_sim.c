/*
 * ev_sim.c - the event model's start state (box, cells, placement,
 * velocities), its run loop with the series, and read-out.
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "ev_internal.h"

static double gauss(pdla_rng *r)
{
    /* Box-Muller, one value per call: simple and deterministic. */
    const double u = rng_uniform_open(r), v = rng_uniform(r);
    return sqrt(-2 * log(u)) * cos(2 * M_PI * v);
}

void ev_free(ev_sim *s)
{
    if (!s) return;
    free(s->seed_xr);
    free(s->ps);
    free(s->species);
    free(s->stuck);
    free(s->parent);
    free(s->lk);
    free(s->cnext);
    free(s->chead);
    free(s->heap);
    free(s->qhead);
    free(s->stuck_idx);
    free(s->stuck_t);
    ev_big_free(s);
    free(s);
}

/* Cell of x in a grid of nc cells of side w per dimension. */
static uint32_t cell_in(const ev_sim *s, const double *x, int nc, double w)
{
    uint32_t c = 0;
    for (int k = s->dim - 1; k >= 0; k--) {
        double y = x[k];
        if (s->periodic) y -= s->L * floor(y / s->L);
        int q = (int)(y / w);
        if (q < 0) q = 0;
        if (q >= nc) q = nc - 1;
        c = c * (uint32_t)nc + (uint32_t)q;
    }
    return c;
}

static uint32_t cell_of(const ev_sim *s, const double *x) { return cell_in(s, x, s->nc, s->w); }

/* The integer coordinates of cell c (cc[k] for k < D, the rest 0). */
static inline __attribute__((always_inline)) void cell_coords(const ev_sim *s, uint32_t c, int *cc)
{
    cc[0] = cc[1] = cc[2] = 0;
    for (int k = 0; k < s->dim; k++) {
        cc[k] = (int)(c % (uint32_t)s->nc);
        c /= (uint32_t)s->nc;
    }
}

/* The cell at offset (ox, oy, oz) from the cell at cc into *cn: 1, or 0
 * where the offset leaves an elastic box (periodic boxes wrap). */
static inline __attribute__((always_inline)) int offset_cell(const ev_sim *s, const int *cc, int ox,
                                                             int oy, int oz, uint32_t *cn)
{
    const int D = s->dim;
    int q[3] = {cc[0] + ox, cc[1] + oy, cc[2] + oz};
    for (int k = 0; k < D; k++) {
        if (q[k] < 0 || q[k] >= s->nc) {
            if (!s->periodic) return 0;
            q[k] = (q[k] + s->nc) % s->nc;
        }
    }
    *cn = (uint32_t)q[0] + (uint32_t)s->nc * ((uint32_t)q[1] + (uint32_t)s->nc * (uint32_t)(D == 3 ? q[2] : 0));
    return 1;
}

/* The cells within one cell of the cell of x (3^D of them, fewer at
 * elastic walls) into cn: their count. The same order as overlaps(). */
static int near_cells(const ev_sim *s, const double *x, uint32_t *cn)
{
    const int D = s->dim;
    int cc[3], n = 0;
    cell_coords(s, cell_of(s, x), cc);
    for (int oz = D == 3 ? -1 : 0; oz <= (D == 3 ? 1 : 0); oz++)
        for (int oy = -1; oy <= 1; oy++)
            for (int ox = -1; ox <= 1; ox++) n += offset_cell(s, cc, ox, oy, oz, cn + n);
    return n;
}

/* Does a particle of radius r at x overlap a particle of cell c? */
static inline int overlaps_cell(const ev_sim *s, const double *x, double r, uint32_t c)
{
    const int D = s->dim;
    for (uint32_t j = s->chead[c]; j != UINT32_MAX; j = s->cnext[j]) {
        const double *pj = EV_P(s, j);
        const double sig = r + pj[2 * D + 1];
        if (ev_dist2(s, x, pj) < sig * sig) return 1;
    }
    return 0;
}

/* Does a particle of radius r at x overlap anything placed in the cells
 * cn[0 .. ncn - 1]? */
static int overlaps_in(const ev_sim *s, const double *x, double r, const uint32_t *cn, int ncn)
{
    for (int a = 0; a < ncn; a++)
        if (overlaps_cell(s, x, r, cn[a])) return 1;
    return s->nbig && ev_big_overlaps(s, cell_of(s, x), x, r);
}

/* Does a particle of radius r at x overlap anything placed (cells)? The
 * cells of near_cells walked as they come, without the list: this is
 * the test of every position while few are refused (place_random), and
 * near_cells + overlaps_in there, even inlined, cost 10% more
 * instructions for the whole start (2D 1e5 packing 0.3, callgrind: 449 M
 * against 408 M). */
static inline __attribute__((always_inline)) int overlaps(const ev_sim *s, const double *x, double r)
{
    const int D = s->dim;
    int cc[3];
    const uint32_t c = cell_of(s, x);
    cell_coords(s, c, cc);
    for (int oz = D == 3 ? -1 : 0; oz <= (D == 3 ? 1 : 0); oz++)
        for (int oy = -1; oy <= 1; oy++)
            for (int ox = -1; ox <= 1; ox++) {
                uint32_t cn;
                if (offset_cell(s, cc, ox, oy, oz, &cn) && overlaps_cell(s, x, r, cn)) return 1;
            }
    return s->nbig && ev_big_overlaps(s, c, x, r);
}

static void put(ev_sim *s, uint32_t i, const double *x)
{
    const int D = s->dim;
    double *p = EV_P(s, i);
    for (int k = 0; k < D; k++) p[k] = x[k];
    if (ev_in_cells(s, i)) ev_cell_insert(s, i, cell_of(s, x));
    else s->lk[i].cell = cell_of(s, x);
}

/* Random sequential addition: particle i goes to the first of uniformly
 * random positions that overlaps nothing placed. Near the end of a dense
 * start almost every position is refused (3D 1e6 packing 0.3: 35.5 M
 * positions for 1e6 particles, 426 per particle at the end, and 96% of
 * the run in the overlap test, on the loads of the records near it), so
 * two things make a refusal cheap without changing which position is
 * taken, bit for bit:
 *
 * - A bit map of small cubes (side h <= rmin / 2) with a bit set where the
 *   whole cube lies, with a margin, within rmin + r_j of a placed particle
 *   j (rmin the smallest radius): a position in such a cube overlaps j
 *   whatever its radius, so it is refused on one bit, as the exact test
 *   would refuse it. Positions in clear cubes get the exact test. The
 *   map is made when the tries to come are many (below).
 * - The positions are drawn in batches, and the bits and then the cell
 *   heads of the exact tests are prefetched for the whole batch, so the
 *   cache misses of a batch are in flight together.
 *
 * The candidates are the same draws in the same order, each tested against
 * the same placed set (nothing is placed before the first that fits, and
 * the rest of the batch is dropped), and the generator is left just after
 * the draws of the one taken: the placement of the one-at-a-time loop. */
enum { PLACE_TRIES = 10000, PLACE_BATCH = 64 };

typedef struct place_map {
    uint64_t *bits; /* NULL: no map (every position gets the exact test) */
    int m;          /* cubes per side, h = L / m */
    int lg, mt;     /* a word is a tile of 2^lg cubes per side (4^3, 8^2); mt tiles per side */
    uint64_t nwords;
    double h, inv_h, rmin;
} place_map;

typedef struct place_cand {
    double x[3];
    pdla_rng after; /* the generator just after this candidate's draws */
    uint64_t bit;   /* its cube */
    int refused;    /* by the map */
    int ncn;        /* otherwise the cells of its exact test */
    uint32_t cn[27];
} place_cand;

/* The map's cube side: rmin / 2, coarser to keep the map at 256 bits per
 * particle or less, none (m = 0) when that would be coarser than rmin (a
 * cube must fit well inside a sphere of radius 2 rmin to be covered by
 * one). Not allocated yet (place_map_start). */
static void place_map_init(const ev_sim *s, place_map *pm)
{
    const int D = s->dim;
    memset(pm, 0, sizeof *pm);
    pm->rmin = INFINITY;
    for (int k = 0; k < s->nspecies; k++)
        if (s->sp[k].count && s->sp[k].radius < pm->rmin) pm->rmin = s->sp[k].radius;
    if (!(pm->rmin > 0) || !isfinite(pm->rmin)) return;
    double m = ceil(s->L / (0.5 * pm->rmin));
    const double mmax = floor(pow(256.0 * (double)s->n + 4096, 1.0 / D));
    if (m > mmax) m = mmax;
    if (m < 1 || s->L / m > pm->rmin) return;
    pm->m = (int)m;
    pm->h = s->L / m;
    pm->inv_h = m / s->L;
    /* tiles, so that the cubes a particle covers (up to 9 per side) share
     * few cache lines */
    pm->lg = D == 3 ? 2 : 3;
    pm->mt = (pm->m + (1 << pm->lg) - 1) >> pm->lg;
    pm->nwords = (uint64_t)pm->mt * (uint64_t)pm->mt * (D == 3 ? (uint64_t)pm->mt : 1);
}

static int place_cube(const place_map *pm, double y)
{
    int q = (int)(y * pm->inv_h);
    return q < 0 ? 0 : q >= pm->m ? pm->m - 1 : q;
}

/* The bit of cube q[0..D-1]: 64 times its tile's word, plus its place in
 * the tile. */
static uint64_t place_tiled(const ev_sim *s, const place_map *pm, const int *q)
{
    const int lg = pm->lg, mask = (1 << lg) - 1;
    uint64_t w = 0, b = 0;
    for (int k = s->dim - 1; k >= 0; k--) {
        w = w * (uint64_t)pm->mt + (uint64_t)(q[k] >> lg);
        b = (b << lg) | (uint64_t)(q[k] & mask);
    }
    return w * 64 + b;
}

static uint64_t place_bit(const ev_sim *s, const place_map *pm, const double *x)
{
    int q[3];
    for (int k = 0; k < s->dim; k++) q[k] = place_cube(pm, x[k]);
    return place_tiled(s, pm, q);
}

/* Cube index q along one axis, wrapped (periodic) or -1 outside the box. */
static int place_wrap(const ev_sim *s, const place_map *pm, int q)
{
    if (q >= 0 && q < pm->m) return q;
    return s->periodic ? ((q % pm->m) + pm->m) % pm->m : -1;
}

/* The largest distance from c to a point of [q h, (q + 1) h]. */
static double place_far(const place_map *pm, int q, double c)
{
    return fmax(fabs(c - q * pm->h), fabs((q + 1) * pm->h - c));
}

/* Set the bits of the cubes that lie wholly within rmin + r of x (shrunk
 * by 1e-7 relative: round-off in the exact test and in the cube of a
 * position is ~1e-14 of the box). Row by row along x, where the covered
 * cubes are one run. */
static void place_mark(const ev_sim *s, const place_map *pm, const double *x, double r)
{
    if (!pm->bits) return;
    const int D = s->dim;
    const double R = (pm->rmin + r) * (1 - 1e-7), R2 = R * R;
    const int z0 = D == 3 ? (int)floor((x[2] - R) * pm->inv_h) : 0, z1 = D == 3 ? (int)floor((x[2] + R) * pm->inv_h) : 0;
    const int y0 = (int)floor((x[1] - R) * pm->inv_h), y1 = (int)floor((x[1] + R) * pm->inv_h);
    for (int qz = z0; qz <= z1; qz++) {
        const int wz = D == 3 ? place_wrap(s, pm, qz) : 0;
        if (wz < 0) continue;
        const double dz = D == 3 ? place_far(pm, qz, x[2]) : 0;
        for (int qy = y0; qy <= y1; qy++) {
            const int wy = place_wrap(s, pm, qy);
            if (wy < 0) continue;
            const double dy = place_far(pm, qy, x[1]), rest = R2 - dz * dz - dy * dy;
            if (rest <= 0) continue;
            /* cubes [q h, (q + 1) h] inside [x0 - a, x0 + a] */
            const double a = sqrt(rest);
            const int q0 = (int)ceil((x[0] - a) * pm->inv_h), q1 = (int)floor((x[0] + a) * pm->inv_h) - 1;
            /* the run, a piece per tile: its cubes are consecutive bits */
            for (int q = q0; q <= q1;) {
                const int wq[3] = {place_wrap(s, pm, q), wy, wz};
                if (wq[0] < 0) {
                    q++;
                    continue;
                }
                int len = q1 - q + 1;
                const int in_tile = (wq[0] | ((1 << pm->lg) - 1)) - wq[0] + 1, in_box = pm->m - wq[0];
                if (len > in_tile) len = in_tile;
                if (len > in_box) len = in_box;
                const uint64_t bit = place_tiled(s, pm, wq);
                pm->bits[bit >> 6] |= ((1ull << len) - 1) << (bit & 63);
                q += len;
            }
        }
    }
}

/* Allocate the map and mark the seeds and the particles 0 .. nplaced - 1:
 * 0, or -1 when out of memory. */
static int place_map_start(const ev_sim *s, place_map *pm, uint32_t nplaced)
{
    const int D = s->dim;
    pm->bits = calloc((size_t)pm->nwords, sizeof *pm->bits);
    if (!pm->bits) return -1;
    for (uint32_t a = s->n; a < s->ntot; a++) place_mark(s, pm, EV_P(s, a), EV_P(s, a)[2 * D + 1]);
    for (uint32_t a = 0; a < nplaced; a++) place_mark(s, pm, EV_P(s, a), EV_P(s, a)[2 * D + 1]);
    return 0;
}

static int place_marked(const place_map *pm, uint64_t b) { return (int)(pm->bits[b >> 6] >> (b & 63)) & 1; }

/* Draw n candidates from s->rng's state (not advancing it), refuse those
 * in marked cubes, and prefetch what the exact tests of the others load. */
static void place_batch(ev_sim *s, const place_map *pm, double r, place_cand *c, int n)
{
    pdla_rng g = s->rng;
    for (int b = 0; b < n; b++) {
        for (int k = 0; k < s->dim; k++)
            c[b].x[k] = s->periodic ? rng_uniform(&g) * s->L : r + rng_uniform(&g) * (s->L - 2 * r);
        c[b].after = g;
        c[b].refused = 0;
        if (pm->bits) {
            c[b].bit = place_bit(s, pm, c[b].x);
            __builtin_prefetch(&pm->bits[c[b].bit >> 6]);
        }
    }
    for (int b = 0; b < n; b++) {
        if (pm->bits && place_marked(pm, c[b].bit)) {
            c[b].refused = 1;
            continue;
        }
        c[b].ncn = near_cells(s, c[b].x, c[b].cn);
        for (int a = 0; a < c[b].ncn; a++) __builtin_prefetch(&s->chead[c[b].cn[a]]);
    }
    for (int b = 0; b < n; b++)
        for (int a = 0; a < (c[b].refused ? 0 : c[b].ncn); a++) {
            const uint32_t j = s->chead[c[b].cn[a]];
            if (j == UINT32_MAX) continue;
            __builtin_prefetch(EV_P_ANY(s, j));
            __builtin_prefetch(&s->cnext[j]);
        }
}

static int place_random(ev_sim *s, char *err, size_t errlen)
{
    const int D = s->dim;
    place_map pm;
    place_map_init(s, &pm);
    place_cand c[PLACE_BATCH];
    double mean_tries = 1; /* running mean: sets the batch size, starts the map */
    for (uint32_t i = 0; i < s->n; i++) {
        const double r = EV_P(s, i)[2 * D + 1];
        int tries = 0, placed = 0;
        /* the map once the tries still to come (at least mean_tries per
         * particle left) outnumber 4 per particle to mark (all of them in
         * the end): marking one costs about as much as 3-4 exact tests in
         * 2D (callgrind, 2D 1e5 packing 0.3), and a map that comes too
         * early costs more than the refusals it speeds up (3D 1e6 packing
         * 0.05: +60% with a map from the start; 2D 1e6 packing 0.3: +6-10%
         * with one from 8 tries per particle on) */
        if (!pm.bits && pm.m && mean_tries * (double)(s->n - i) > 4.0 * s->n && place_map_start(s, &pm, i))
            return pdla_errorf(-1, err, errlen, "out of memory for the placement map");
        while (!pm.bits && tries < PLACE_TRIES && !placed) {
            /* no map yet: one position at a time, as it comes (batches cost
             * more than they save while few positions are refused: 2D 1e5
             * packing 0.3 +25% instructions) */
            double x[3];
            for (int k = 0; k < D; k++)
                x[k] = s->periodic ? rng_uniform(&s->rng) * s->L : r + rng_uniform(&s->rng) * (s->L - 2 * r);
            tries++;
            if (!overlaps(s, x, r)) {
                put(s, i, x);
                placed = 1;
            }
        }
        while (tries < PLACE_TRIES && !placed) {
            /* about 1.5 times the tries a particle takes now: one batch
             * usually suffices and few draws are wasted */
            int n = (int)(1.5 * mean_tries);
            if (n < 1) n = 1;
            if (n > PLACE_BATCH) n = PLACE_BATCH;
            if (n > PLACE_TRIES - tries) n = PLACE_TRIES - tries;
            place_batch(s, &pm, r, c, n);
            for (int b = 0; b < n && !placed; b++) {
                tries++;
                s->rng = c[b].after;
                if (!c[b].refused && !overlaps_in(s, c[b].x, r, c[b].cn, c[b].ncn)) {
                    put(s, i, c[b].x);
                    place_mark(s, &pm, c[b].x, r);
                    placed = 1;
                }
            }
        }
        if (!placed) {
            free(pm.bits);
            return pdla_errorf(-1, err, errlen,
                        "cannot place particle %" PRIu32 " of %" PRIu32 " without overlap at packing "
                        "%g after %d tries (random placement jams near 0.55 in 2D, 0.38 in 3D): "
                        "lower --packing or use --start lattice",
                        i + 1, s->n, s->par.packing, PLACE_TRIES);
        }
        mean_tries += 0.05 * (tries - mean_tries);
    }
    free(pm.bits);
    return 0;
}

/* Grid sites (k + 1/2) a, a = L / m, in random order; sites touching the
 * seed are skipped; m grows until there are enough. */
static int place_lattice(ev_sim *s, double rmax, char *err, size_t errlen)
{
    const int D = s->dim;
    int m = (int)ceil(pow((double)s->n, 1.0 / D) - 1e-9);
    for (;; m++) {
        const double a = s->L / m;
        if (a < 2 * rmax * (1 + 1e-9))
            return pdla_errorf(-1, err, errlen, "cannot place %" PRIu32 " particles on a grid at packing %g "
                                     "(sites closer than a diameter): lower --packing",
                        s->n, s->par.packing);
        const uint64_t nsites = (uint64_t)m * (uint64_t)m * (D == 3 ? (uint64_t)m : 1);
        if (nsites > 4ull * s->n + 64) continue;
        uint32_t *ok = malloc(nsites * sizeof *ok);
        if (!ok) return pdla_errorf(-1, err, errlen, "out of memory");
        uint64_t nok = 0;
        for (uint64_t q = 0; q < nsites; q++) {
            double x[3];
            uint64_t t = q;
            for (int k = 0; k < D; k++) {
                x[k] = ((double)(t % (uint64_t)m) + 0.5) * a;
                t /= (uint64_t)m;
            }
            if (!overlaps(s, x, rmax)) ok[nok++] = (uint32_t)q;
        }
        if (nok < s->n) {
            free(ok);
            continue;
        }
        for (uint32_t i = 0; i < s->n; i++) {
            /* partial Fisher-Yates: a random unused site */
            const uint64_t pick = i + (uint64_t)(rng_uniform(&s->rng) * (double)(nok - i));
            const uint32_t q = ok[pick];
            ok[pick] = ok[i];
            double x[3];
            uint64_t t = q;
            for (int k = 0; k < D; k++) {
                x[k] = ((double)(t % (uint64_t)m) + 0.5) * a;
                t /= (uint64_t)m;
            }
            put(s, i, x);
        }
        free(ok);
        return 0;
    }
}

/* Renumber the particles (not the seed) in cell order, so that neighbours
 * sit close in memory: a collision then touches few cache lines. Called
 * after placement, before anything else refers to particle indices. The
 * order is that of the numbering grid (nc_order cells per side, the event
 * grid of before event4: about one particle per cell), cell by cell, the
 * higher index first within a cell, so the numbering, and with it every
 * run's realisation, does not depend on the event grid's cell size. */
static int sort_by_cell(ev_sim *s)
{
    const int D = s->dim, S = 2 * D + 2, nco = s->nc_order;
    const double wo = s->L / nco;
    const uint64_t ncell = (uint64_t)nco * (uint64_t)nco * (D == 3 ? (uint64_t)nco : 1);
    const size_t n1 = s->n ? s->n : 1;
    uint32_t *order = malloc(n1 * sizeof *order), *key = malloc(n1 * sizeof *key);
    uint32_t *start = calloc((size_t)ncell + 1, sizeof *start);
    double *ps = malloc(n1 * (size_t)S * sizeof *ps);
    uint8_t *sp = malloc(n1);
    if (!order || !key || !start || !ps || !sp) {
        free(order), free(key), free(start), free(ps), free(sp);
        return -1;
    }
    /* counting sort by cell; filling from the highest index down gives the
     * higher index first within a cell */
    for (uint32_t j = 0; j < s->n; j++) {
        key[j] = cell_in(s, EV_P(s, j), nco, wo);
        start[key[j] + 1]++;
    }
    for (uint64_t c = 0; c < ncell; c++) start[c + 1] += start[c];
    for (uint32_t j = s->n; j-- > 0;) order[start[key[j]]++] = j;
    for (uint32_t a = 0; a < s->n; a++) {
        memcpy(ps + (size_t)a * S, EV_P(s, order[a]), (size_t)S * sizeof *ps);
        sp[a] = s->species[order[a]];
    }
    memcpy(s->ps, ps, (size_t)s->n * (size_t)S * sizeof *ps);
    memcpy(s->species, sp, s->n);
    free(order), free(key), free(start), free(ps), free(sp);
    const uint64_t nce = (uint64_t)s->nc * (uint64_t)s->nc * (D == 3 ? (uint64_t)s->nc : 1);
    for (uint64_t c = 0; c < nce; c++) s->chead[c] = UINT32_MAX;
    for (uint32_t i = 0; i < s->ntot; i++)
        if (ev_in_cells(s, i)) ev_cell_insert(s, i, cell_of(s, EV_P(s, i)));
    return 0;
}

/* Cells per particle at most (see size_box). */
#define EV_CELLS_PER_PARTICLE(D) ((D) == 3 ? 4.0 : 2.0)

/* n zeroed elements of `size` bytes, aligned to `align` (16, or a larger
 * power of two), for free(); NULL when out of memory. Arrays of 4 MB and
 * more are asked to live in transparent huge pages (madvise, the kernel's
 * THP "madvise" mode): the event loop reads them at random (a candidate's
 * record, its cell's head, the queue links), and from N ~ 1e6 a TLB miss
 * per random line was measured as a few % of the loop's CPU
 * (runs/event/speed-session11.md). With align 16 the array comes from
 * calloc (its untouched pages, e.g. the unused end of the heap array, stay
 * unmapped) and its whole 2 MB pages inside are advised; larger alignments
 * (the particle records) are aligned to 2 MB and written whole. The advice
 * is a hint: where it is refused the array is the same, in small pages. */
static void *big_zalloc(size_t n, size_t size, size_t align)
{
    if (n == 0) n = 1;
    if (n > SIZE_MAX / size) return NULL;
    size_t bytes = n * size;
    const size_t huge = (size_t)2 << 20;
    const int big = bytes >= 2 * huge;
    if (align <= 16) {
        char *p = calloc(n, size);
#ifdef MADV_HUGEPAGE
        if (p && big) {
            char *lo = (char *)(((uintptr_t)p + huge - 1) & ~(uintptr_t)(huge - 1));
            char *hi = (char *)(((uintptr_t)p + bytes) & ~(uintptr_t)(huge - 1));
            if (hi > lo) (void)madvise(lo, (size_t)(hi - lo), MADV_HUGEPAGE);
        }
#endif
        return p;
    }
    if (big) align = huge;
    bytes = (bytes + align - 1) / align * align;
    void *p = aligned_alloc(align, bytes);
    if (!p) return NULL;
#ifdef MADV_HUGEPAGE
    if (big) (void)madvise(p, bytes, MADV_HUGEPAGE);
#endif
    memset(p, 0, bytes);
    return p;
}

#define ALLOC(ptr, n)                                                      \
    do {                                                                   \
        (ptr) = big_zalloc((size_t)(n), sizeof *(ptr), 16);                 \
        if (!(ptr)) goto oom;                                              \
    } while (0)

static int size_cells(ev_sim *s, double rmax, double rpmax, char *err, size_t errlen);

/* The largest box side, in radii of the smallest particle. */
#define EV_BOX_MAX_RADII 1e9

/* The particle count, the box (side from the packing) and the cells of p:
 * 0, or -1 with one line in err when the box is too small. */
static int size_box(ev_sim *s, const ev_params *p, char *err, size_t errlen)
{
    const int D = s->dim;
    uint64_t n = 0;
    double vol = 0, rmax = p->seeds[0] ? 0 : p->seed_radius, rpmax = 0;
    for (uint32_t a = 0; a < s->nseeds && p->seeds[0]; a++)
        rmax = fmax(rmax, s->seed_xr[(size_t)a * (size_t)(D + 1) + (size_t)D]);
    uint64_t nsticky = 0;
    double rpmin = INFINITY;
    for (int k = 0; k < s->nspecies; k++) {
        rpmin = fmin(rpmin, s->sp[k].radius);
        n += s->sp[k].count;
        if (s->sp[k].sticky) nsticky += s->sp[k].count;
        vol += (double)s->sp[k].count * ev_particle_volume(D, s->sp[k].radius);
        if (s->sp[k].radius > rmax) rmax = s->sp[k].radius;
        if (s->sp[k].radius > rpmax) rpmax = s->sp[k].radius;
    }
    s->n = (uint32_t)n;
    s->rpmax = rpmax;
    s->nsticky = (uint32_t)nsticky;
    s->has_bath = nsticky < n;
    if (!p->seeds[0]) s->nseeds = p->seed_radius > 0;
    s->has_seed = s->nseeds > 0;
    s->ntot = s->n + s->nseeds;
    s->lookahead = s->ntot >= EV_LOOKAHEAD_MIN;
    s->nfree_total = s->has_seed && s->stick_p > 0 && s->nsticky > 0;
    s->V = vol / p->packing;
    s->L = pow(s->V, 1.0 / D);
    s->half = 0.5 * s->L;
    /* A box of 1e9 radii of the smallest particle resolves its positions to
     * 2e-7 radii (doubles); a lower packing (1e-300: side infinite, or 1e151
     * radii) ran without end and wrote box_side Infinity. */
    if (!(s->L <= EV_BOX_MAX_RADII * rpmin))
        return pdla_errorf(-1, err, errlen, "box too large: side %g is over %g radii of the smallest particle (%g), "
                           "beyond what positions resolve: raise --packing", s->L, EV_BOX_MAX_RADII, rpmin);
    if (s->L < 2 * rmax * 1.5 || (s->has_seed && !p->seeds[0] && s->L < 2 * p->seed_radius + 4 * rpmax))
        return pdla_errorf(-1, err, errlen, "box too small: side %g for %s of radius %g", s->L,
                    rmax > rpmax ? "a seed" : "particles", rmax);
    if (p->seeds[0] && ev_seeds_check(s, err, errlen)) return -1;
    return size_cells(s, rmax, rpmax, err, errlen);
}

/* Cells per side for cells no smaller than cmin (times 1 + 1e-9, so a
 * particle assigned by round-off to the next cell is still found), and at
 * low packing no more than EV_CELLS_PER_PARTICLE(D) cells per particle. */
static double cells_for(const ev_sim *s, double cmin)
{
    const double cap = floor(pow(EV_CELLS_PER_PARTICLE(s->dim) * (double)s->ntot + 27, 1.0 / s->dim));
    const double nc = fmin(floor(s->L / (cmin * (1 + 1e-9))), cap);
    return nc < 1 ? 1 : nc;
}

/* cells_for, and in a periodic box at least 4 a side where cells of cmin
 * allow it (few particles; see size_cells) */
static int grid_cells(const ev_sim *s, double cmin)
{
    const double nc = cells_for(s, cmin);
    if (s->periodic && nc < 4 && floor(s->L / (cmin * (1 + 1e-9))) >= 4) return 4;
    return (int)nc;
}

/* The cell grid for particles of radius up to rpmax and seeds of radius
 * up to rmax: 0, or -1 with one line in err. */
static int size_cells(ev_sim *s, double rmax, double rpmax, char *err, size_t errlen)
{
    /* Cells no smaller than the largest contact distance of what is in the
     * cell lists, and at low packing no more than EV_CELLS_PER_PARTICLE(D)
     * per particle (bigger cells there mean fewer crossing events). The
     * smaller the cells, the fewer candidates a scan tests (a full scan
     * covers 3^D cells) but the more crossing events: callgrind of the event
     * loop (N = 1e4, periodic, runs/event/speed.md, 2026-11-24 event4) has
     * 3D cheapest with the smallest cells at every packing tried (0.05 ..
     * 0.3: 4 cells per particle -44% instructions at 0.05, -30% at 0.3
     * against 1) and 2D cheapest at about 2 per particle (0.05, 0.15; at
     * 0.3 the smallest). The largest contact distance in the lists is 2
     * rpmax: a seed no larger than the particles is listed (contact <= 2
     * rpmax), a larger one is not (ev_big.c). Earlier rules, kept so that an
     * old checkpoint is refused only when its grid differs (ev_ckpt.c):
     * version 2, twice the largest radius of anything (nc_v2); version 3,
     * max(2 rpmax, seed radius + rpmax) (nc_v3), big seeds listed. A
     * periodic box needs 4 cells a side: particles in neighbouring cells
     * are then at most half the box apart on each axis, so the minimum
     * image that pred_pp takes is the one that meets (with 3, two particles
     * two cells apart approaching across the cell between them are taken
     * by their nearer image through the wrap, as receding, and pass through
     * each other). */
    const double cmin = 2 * rpmax;
    /* the numbering grid keeps version 2's rule: particles are numbered as
     * before (the events of the runs compared in runs/event/speed-session14.md
     * are the same) */
    s->nc_order = (int)fmax(1, fmin(floor(s->L / (2 * rmax * (1 + 1e-9))),
                                    floor(pow((double)s->ntot + 27, 1.0 / s->dim))));
    s->nc = grid_cells(s, cmin);
    s->nc_v2 = (int)cells_for(s, 2 * rmax); /* version 2 had no periodic minimum */
    s->nc_v3 = grid_cells(s, fmax(2 * rpmax, rmax + rpmax));
    s->rmax = rmax;
    s->w = s->L / s->nc;
    if (s->periodic && s->nc < 4)
        return pdla_errorf(-1, err, errlen, "box too small for periodic walls: side %g is under 4 cells of %g",
                    s->L, cmin);
    /* A big seed in a periodic box: a particle that meets it is within
     * R + rpmax + w of it on each axis when it predicts the contact (from
     * its cell), which must be under half the box for pred_pp's nearest
     * image to be the one that meets. */
    if (s->periodic && rmax > rpmax && s->L <= 2 * (rmax + rpmax + s->w) * (1 + 1e-9))
        return pdla_errorf(-1, err, errlen, "box too small for periodic walls: side %g is under 2 (seed radius "
                                            "%g + particle radius %g + cell %g)", s->L, rmax, rpmax, s->w);
    return 0;
}

/* Every per-particle and per-cell array, zeroed (cell heads empty): 0 or
 * -1 when out of memory. */
static int alloc_arrays(ev_sim *s)
{
    const int D = s->dim;
    const uint64_t ncell = (uint64_t)s->nc * (uint64_t)s->nc * (D == 3 ? (uint64_t)s->nc : 1);
    const uint32_t N = s->ntot;
    {
        /* one particle = 64 bytes in 3D: align so it is one cache line */
        s->ps = big_zalloc((size_t)N * (size_t)(2 * D + 2), sizeof(double), 64);
        if (!s->ps) goto oom;
    }
    ALLOC(s->species, N);
    ALLOC(s->stuck, N);
    ALLOC(s->parent, N);
    s->lk = big_zalloc(N, sizeof *s->lk, 64); /* one line each */
    if (!s->lk) goto oom;
    ALLOC(s->cnext, N);
    ALLOC(s->chead, ncell);
    ALLOC(s->heap, N);
    s->qover = N < 16 ? 16 : N;
    ALLOC(s->qhead, (size_t)s->qover + 1);
    ALLOC(s->stuck_idx, N);
    ALLOC(s->stuck_t, N);
    for (uint64_t c = 0; c < ncell; c++) s->chead[c] = UINT32_MAX;
    return 0;
oom:
    return -1;
}

/* Radii, masses and species of the particles, species by species, and the
 * seed (infinite mass, stuck) placed at the centre. */
static void fill_particles(ev_sim *s, const ev_params *p)
{
    const int D = s->dim;
    uint32_t i = 0;
    for (int k = 0; k < s->nspecies; k++)
        for (uint64_t q = 0; q < s->sp[k].count; q++, i++) {
            EV_P(s, i)[2 * D + 1] = s->sp[k].radius;
            s->species[i] = (uint8_t)k;
            s->parent[i] = UINT32_MAX;
        }
    for (uint32_t a = 0; a < s->nseeds; a++) {
        /* the central seed, or the file's seed a (ev_seeds.c) */
        const uint32_t sd = s->n + a;
        double x[3] = {s->half, s->half, s->half}, r = p->seed_radius;
        if (p->seeds[0]) {
            const double *q = s->seed_xr + (size_t)a * (size_t)(D + 1);
            for (int k = 0; k < D; k++) x[k] = q[k];
            r = q[D];
        }
        EV_P(s, sd)[2 * D + 1] = r;
        s->stuck[sd] = 1;
        s->species[sd] = UINT8_MAX;
        s->parent[sd] = UINT32_MAX;
        put(s, sd, x);
    }
    free(s->seed_xr);
    s->seed_xr = NULL;
}

/* The box, cells, arrays and species tables of p, with the seed placed and
 * no particle yet (ev_create places them; a checkpoint fills them in). */
ev_sim *ev_alloc(const ev_params *p, char *err, size_t errlen) { return ev_alloc_seeded(p, NULL, 0, err, errlen); }

ev_sim *ev_alloc_seeded(const ev_params *p, double *seed_xr, uint32_t nseeds, char *err, size_t errlen)
{
    if (ev_params_check(p, err, errlen)) {
        free(seed_xr);
        return NULL;
    }
    ev_sim *s = calloc(1, sizeof *s);
    if (!s) {
        free(seed_xr);
        pdla_errorf(-1, err, errlen, "out of memory");
        return NULL;
    }
    s->seed_xr = seed_xr;
    s->nseeds = nseeds;
    s->par = *p;
    s->dim = p->dim;
    s->periodic = p->walls == EV_WALLS_PERIODIC;
    s->stick_p = p->stick_p;
    rng_seed(&s->rng, p->seed);
    ev_parse_species(p, s->sp, &s->nspecies, NULL, 0);
    for (int k = 0; k < s->nspecies; k++)
        s->spmass[k] = s->sp[k].density * ev_particle_volume(s->dim, s->sp[k].radius);
    if (p->seeds[0] && !s->seed_xr && ev_seeds_read(s, p->seeds, err, errlen)) goto bad;
    if (size_box(s, p, err, errlen)) goto bad;
    if (alloc_arrays(s)) {
        pdla_errorf(-1, err, errlen, "out of memory for %" PRIu64 " particles", (uint64_t)s->n);
        goto bad;
    }
    fill_particles(s, p);
    if (ev_big_build(s)) {
        pdla_errorf(-1, err, errlen, "out of memory for the cells near the seeds");
        goto bad;
    }
    return s;
bad:
    ev_free(s);
    return NULL;
}

ev_sim *ev_create(const ev_params *p, char *err, size_t errlen)
{
    ev_sim *s = ev_alloc(p, err, errlen);
    if (!s) return NULL;
    const int D = s->dim;
    double rpmax = 0;
    for (int k = 0; k < s->nspecies; k++)
        if (s->sp[k].radius > rpmax) rpmax = s->sp[k].radius;
    if (p->start == EV_START_LATTICE ? place_lattice(s, rpmax, err, errlen)
                                     : place_random(s, err, errlen))
        goto bad;
    if (sort_by_cell(s)) goto oom;
    for (uint32_t i = 0; i < s->n; i++) {
        double *q = EV_P(s, i);
        const double m = ev_pmass(s, i);
        if (p->velocities == EV_VEL_MAXWELL) {
            const double sd = sqrt(p->kT / m);
            for (int k = 0; k < D; k++) q[D + k] = sd * gauss(&s->rng);
        } else {
            /* seed 001: speed sqrt(2 kT / m) in a uniformly random direction */
            double u[3], uu;
            do {
                uu = 0;
                for (int k = 0; k < D; k++) {
                    u[k] = 2 * rng_uniform(&s->rng) - 1;
                    uu += u[k] * u[k];
                }
            } while (uu > 1 || uu < 1e-12);
            const double f = sqrt(2 * p->kT / m) / sqrt(uu);
            for (int k = 0; k < D; k++) q[D + k] = f * u[k];
        }
    }
    for (uint32_t i = 0; i < s->n; i++) ev_predict(s, i, 0);
    ev_queue_reset(s);
    for (uint32_t i = 0; i < s->n; i++) ev_heap_push(s, i);
    return s;
oom:
    pdla_errorf(-1, err, errlen, "out of memory for %" PRIu64 " particles", (uint64_t)s->n);
bad:
    ev_free(s);
    return NULL;
}

void ev_set_trace(ev_sim *s, ev_trace_fn fn, void *user)
{
    s->trace = fn;
    s->trace_user = user;
}

static double stop_time(const ev_sim *s) { return s->par.t_max > 0 ? s->par.t_max : INFINITY; }

int ev_run(ev_sim *s, volatile const int *interrupt)
{
    const int why = ev_loop(s, stop_time(s), interrupt);
    if (why) return why;
    s->now = stop_time(s);
    return EV_STOP_TIME;
}

int ev_run_until(ev_sim *s, double t)
{
    const int why = ev_loop(s, t, NULL);
    if (!why && t > s->now) s->now = t;
    return why;
}

void ev_sync(ev_sim *s)
{
    const int D = s->dim;
    for (uint32_t i = 0; i < s->n; i++) {
        if (s->stuck[i]) continue;
        double *p = EV_P(s, i);
        const double dt = s->now - p[2 * D];
        for (int k = 0; k < D; k++) p[k] += p[D + k] * dt;
        p[2 * D] = s->now;
    }
}

/* The free particles' kinetic energy, summed in index order. */
static double ke_free_sum(const ev_sim *s)
{
    const int D = s->dim;
    double ke = 0;
    for (uint32_t i = 0; i < s->n; i++) {
        if (s->stuck[i]) continue;
        const double *p = EV_P(s, i);
        double v2 = 0;
        for (int k = 0; k < D; k++) v2 += p[D + k] * p[D + k];
        ke += 0.5 * ev_pmass(s, i) * v2;
    }
    return ke;
}

void ev_get_stats(const ev_sim *s, ev_stats *st)
{
    memset(st, 0, sizeof *st);
    st->t = s->now;
    st->events = s->events;
    st->collisions = s->collisions;
    st->wall_hits = s->wall_hits;
    st->sticks = s->sticks;
    st->cell_crossings = s->cell_crossings;
    st->invalid = s->invalid;
    st->stuck = s->nstuck;
    st->ke_free = ke_free_sum(s);
    st->ke_stuck = s->ke_stuck;
    st->virial = s->virial;
    st->box = s->L;
    st->max_overlap = s->max_overlap;
}

int ev_dim(const ev_sim *s) { return s->dim; }
size_t ev_count(const ev_sim *s) { return s->n; }
int ev_has_seed(const ev_sim *s) { return s->has_seed; }
size_t ev_seed_count(const ev_sim *s) { return s->nseeds; }
const double *ev_pos(const ev_sim *s, size_t i)
{
    const int D = s->dim;
    return EV_P(s, i);
}
const double *ev_vel(const ev_sim *s, size_t i)
{
    const int D = s->dim;
    return EV_P(s, i) + D;
}
double ev_radius(const ev_sim *s, size_t i)
{
    const int D = s->dim;
    return EV_P(s, i)[2 * D + 1];
}
double ev_mass(const ev_sim *s, size_t i) { return i < s->n ? ev_pmass(s, (uint32_t)i) : INFINITY; }
int ev_species_of(const ev_sim *s, size_t i) { return s->species[i] == UINT8_MAX ? -1 : s->species[i]; }
size_t ev_sticky_count(const ev_sim *s) { return s->nsticky; }
int ev_species_sticky(const ev_sim *s, int k) { return k >= 0 && k < s->nspecies && s->sp[k].sticky; }
size_t ev_stuck_list(const ev_sim *s, const uint32_t **idx, const double **t)
{
    *idx = s->stuck_idx;
    *t = s->stuck_t;
    return s->nstuck;
}
/* cluster.h5's encoding of a parent (ev_out.c write_cluster) */
int64_t ev_parent(const ev_sim *s, size_t i)
{
    if (i >= s->n || !s->stuck[i] || s->parent[i] == UINT32_MAX) return INT64_MIN;
    const uint32_t p = s->parent[i];
    return p >= s->n ? -1 - (int64_t)(p - s->n) : (int64_t)p;
}
int ev_species_count(const ev_sim *s) { return s->nspecies; }
const ev_species *ev_species_get(const ev_sim *s, int k) { return k >= 0 && k < s->nspecies ? &s->sp[k] : NULL; }

/* The virial pressure from the free kinetic energy ke and the collision
 * virial dvir over dt (one expression for ev_pressure and the series). */
static double pressure_of(const ev_sim *s, double ke, double dvir, double dt)
{
    return (2 * ke / s->dim + dvir / (s->dim * dt)) / s->V;
}

double ev_pressure(const ev_sim *s, double dvir, double dt)
{
    return pressure_of(s, ke_free_sum(s), dvir, dt);
}

/* The free kinetic energy of a series row, the same bits as
 * ev_get_stats's: summed again (O(N)) only when a velocity may have changed
 * since the last sum. Only a collision (pair, or a reflection off the
 * cluster) or a stick changes one; a wall flips a sign (v^2 the same bits),
 * a cell crossing or a stale event none. Before, every row summed all N
 * (twice, with its pressure): --series-dt 1e-9 against ~1e-4 between
 * events made ~5e5 rows (the thinning doubles the interval every 32768)
 * and 1e4 disks took 15 s for 12000 events; such a row now costs O(1)
 * (test event-row-cost). */
static double series_ke(ev_sim *s)
{
    if (!s->ke_valid || s->ke_collisions != s->collisions || s->ke_sticks != s->sticks) {
        s->ke_free = ke_free_sum(s);
        s->ke_collisions = s->collisions;
        s->ke_sticks = s->sticks;
        s->ke_valid = 1;
        s->ke_sums++;
    }
    return s->ke_free;
}

/* ev_pressure with the row's energy (series_ke): the same expression. */
static double series_pressure(ev_sim *s, double dvir, double dt)
{
    return pressure_of(s, series_ke(s), dvir, dt);
}

/* At most EV_SERIES_MAX rows: when full, neighbouring rows are merged in
 * pairs (the later row's values; the pressures' mean weighted by the two
 * intervals' lengths: a row's virial part is its interval's mean, its
 * kinetic part the free energy at the row's end, which changes only when a
 * particle sticks) and the interval doubles. Row 0 (the start) is kept, so
 * a full series leaves one row without a partner: it stays last and the row
 * being pushed merges into it (until test event-thin it was dropped, and
 * the next row's pressure covered only half its span). A run that goes on
 * for ever (one particle that never finds the cluster) thus keeps bounded
 * memory. */
static double series_pmerge(double pa, double ta, double pb, double tb)
{
    /* an interval of no length (a finished run resumed) has no pressure
     * (NaN): the other's stands */
    if (!(tb > 0)) return pa;
    if (!(ta > 0)) return pb;
    return (pa * ta + pb * tb) / (ta + tb);
}
static int series_thin(ev_series *ser, ev_sim *s)
{
    size_t w = 1, r = 1;
    for (; r + 1 < ser->n; r += 2, w++) {
        ser->pressure[w] = series_pmerge(ser->pressure[r], ser->t[r] - ser->t[r - 1], ser->pressure[r + 1],
                                         ser->t[r + 1] - ser->t[r]);
        ser->t[w] = ser->t[r + 1];
        ser->ke[w] = ser->ke[r + 1];
        ser->stuck[w] = ser->stuck[r + 1];
        ser->collisions[w] = ser->collisions[r + 1];
    }
    const int left = r < ser->n; /* the last row, unpaired */
    if (left) {
        ser->t[w] = ser->t[r];
        ser->ke[w] = ser->ke[r];
        ser->pressure[w] = ser->pressure[r];
        ser->stuck[w] = ser->stuck[r];
        ser->collisions[w] = ser->collisions[r];
        w++;
    }
    ser->n = w;
    s->series_dt *= 2;
    return left;
}

static int series_push(ev_series *ser, ev_sim *s, double pressure)
{
    const int left = ser->n >= EV_SERIES_MAX ? series_thin(ser, s) : 0;
    if (ser->n == ser->cap) {
        const size_t cap = ser->cap ? 2 * ser->cap : 256;
        double *a = realloc(ser->t, cap * sizeof *a);
        if (a) ser->t = a;
        double *b = realloc(ser->ke, cap * sizeof *b);
        if (b) ser->ke = b;
        double *c = realloc(ser->pressure, cap * sizeof *c);
        if (c) ser->pressure = c;
        uint64_t *d = realloc(ser->stuck, cap * sizeof *d);
        if (d) ser->stuck = d;
        uint64_t *e = realloc(ser->collisions, cap * sizeof *e);
        if (e) ser->collisions = e;
        if (!a || !b || !c || !d || !e) return -1;
        ser->cap = cap;
    }
    size_t i = ser->n;
    if (left) { /* the new row covers (t[n - 1], now]: merge it into that unpaired row */
        i--;
        pressure = series_pmerge(ser->pressure[i], ser->t[i] - ser->t[i - 1], pressure, s->now - ser->t[i]);
    }
    ser->t[i] = s->now;
    ser->ke[i] = series_ke(s);
    ser->pressure[i] = pressure;
    ser->stuck[i] = s->nstuck;
    ser->collisions[i] = s->collisions;
    ser->n = i + 1;
    return 0;
}

void ev_series_free(ev_series *ser)
{
    free(ser->t);
    free(ser->ke);
    free(ser->pressure);
    free(ser->stuck);
    free(ser->collisions);
    memset(ser, 0, sizeof *ser);
}

/* The series' interval that is open (iv_t0, iv_v0: its start time and
 * virial) is part of the state: an interrupted run leaves it open, its
 * checkpoint keeps it, and the resumed run closes it at the same time
 * t0 + series_dt with the same sums as a run never stopped. */
int ev_run_series(ev_sim *s, ev_series *ser, volatile const int *interrupt)
{
    const int between = s->started && !s->iv_open; /* resumed from the checkpoint of a run that had ended */
    if (!s->started) {
        s->series_dt = s->par.series_dt;
        if (series_push(ser, s, NAN)) return -1;
        s->started = 1;
    }
    /* never back in time: a stop time already passed (a resume's --t-max)
     * ends the run where it is */
    const double tstop = fmax(stop_time(s), s->now);
    /* A run that had ended and still has: no interval is opened. Before, a
     * resume of its checkpoint (the final one of a run whose cluster.h5
     * failed, or a run killed while it wrote cluster.h5) closed one of no
     * length at once and wrote the last row twice. */
    if (between) {
        const int why = s->now >= tstop ? EV_STOP_TIME : ev_stop_now(s);
        if (why) return why;
    }
    for (;;) {
        if (!s->iv_open) {
            s->iv_t0 = s->now;
            s->iv_v0 = s->virial;
            s->iv_open = 1;
        }
        const double t0 = s->iv_t0;
        double t1 = t0 + s->series_dt;
        if (t1 > tstop) t1 = tstop;
        int why = ev_loop(s, t1, interrupt);
        if (why == EV_STOP_INTERRUPT) return why; /* the interval stays open */
        if (!why) s->now = t1;
        const double dt = s->now - t0;
        s->iv_open = 0;
        if (series_push(ser, s, dt > 0 ? series_pressure(s, s->virial - s->iv_v0, dt) : NAN)) return -1;
        if (why) return why;
        if (s->now >= tstop) return EV_STOP_TIME;
    }
}

void ev_set_tick(ev_sim *s, ev_tick_fn fn, void *user)
{
    s->tick = fn;
    s->tick_user = user;
}

const char *ev_stop_name(int why)
{
    switch (why) {
    case EV_STOP_ALL_STUCK: return "all stuck";
    case EV_STOP_TIME: return "time reached";
    case EV_STOP_STUCK: return "stuck count reached";
    case EV_STOP_EVENTS: return "event count reached";
    case EV_STOP_NO_EVENTS: return "no events left";
    case EV_STOP_INTERRUPT: return "interrupted";
    default: return "unknown";
    }
}

/* Tests set positions, velocities or stuck flags by hand, then call this:
 * cells, the big seeds' lists, events and the heap are rebuilt from the
 * stored states. 0, or -1 when out of memory (the lists). */
int ev_rebuild(ev_sim *s)
{
    const uint64_t ncell = (uint64_t)s->nc * (uint64_t)s->nc * (s->dim == 3 ? (uint64_t)s->nc : 1);
    s->ke_valid = 0; /* velocities or stuck flags set by hand: no counter saw it */
    ev_sync(s);
    for (uint32_t i = 0; i < s->ntot && s->periodic; i++)
        for (int k = 0; k < s->dim; k++) EV_P_ANY(s, i)[k] -= s->L * floor(EV_P_ANY(s, i)[k] / s->L);
    for (uint64_t c = 0; c < ncell; c++) s->chead[c] = UINT32_MAX;
    for (uint32_t i = 0; i < s->ntot; i++)
        if (ev_in_cells(s, i)) ev_cell_insert(s, i, cell_of(s, EV_P_ANY(s, i)));
        else s->lk[i].cell = cell_of(s, EV_P_ANY(s, i));
    if (ev_big_build(s)) return -1; /* a test may have moved a seed */
    ev_queue_reset(s);
    for (uint32_t i = 0; i < s->n; i++)
        if (!s->stuck[i]) ev_predict(s, i, s->now);
    for (uint32_t i = 0; i < s->n; i++)
        if (!s->stuck[i]) ev_heap_push(s, i);
    return 0;
}
