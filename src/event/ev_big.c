/*
 * ev_big.c - seeds larger than the particles, kept out of the cell lists.
 *
 * The cells must be no smaller than the largest contact distance. A seed
 * of radius R > rpmax (the largest particle radius) would set it to R +
 * rpmax: every cell, all over the box, would hold (R + rpmax)^D / (2
 * rpmax)^D times the particles, and every scan would test that many more
 * candidates, though only the few particles near the seed can meet it
 * (session 14: 3D, seed radius 5, 20.7 us a collision against 1.7 with a
 * seed of the particles' size). So such a seed ("big") is in no cell list:
 * the cells are sized by the particles alone, and each cell that a big
 * seed can be met from carries the list of those seeds:
 *
 *  - near: the cells whose box comes within R + rpmax of the seed's centre
 *    and is not wholly inside the seed (a particle can only be in a cell
 *    that is not, so the list of a big seed is a shell, ~ its surface);
 *  - inside: the cells wholly within R of a centre (no particle's centre
 *    can be there; placement refuses positions there at once).
 *
 * A particle in cell c can meet a big seed before it leaves c only if c's
 * box holds a point at the contact distance R + r_i <= R + rpmax from the
 * seed's centre, so c is then "near". Each prediction (ev_core.c: a full
 * one, and the one at a cell crossing, for the new cell) tests the near
 * list of the particle's cell; a contact after the particle has left c is
 * found again from the cell it is in then. The results do not depend on
 * which candidates are tested twice: ties go to the lower index, as in
 * the cell scans, so the event sequence is that of the all-pairs loop
 * (test event-brute).
 *
 * Layout: a bit per cell for "near" and one for "inside"; the near cells'
 * lists in one array, found by the rank of the cell's bit (a count of the
 * near bits before each 64-bit word, plus a popcount in the word). Only a
 * run with a big seed allocates anything here: ncell / 4 bytes of bits and
 * ranks, and 4 bytes per (near cell, seed).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ev_internal.h"

void ev_big_free(ev_sim *s)
{
    free(s->bg_near);
    free(s->bg_inside);
    free(s->bg_rank);
    free(s->bg_start);
    free(s->bg_idx);
    s->bg_near = s->bg_inside = NULL;
    s->bg_rank = s->bg_start = s->bg_idx = NULL;
    s->nbig = 0;
}

/* Per axis, the cells a seed at x (radius R) reaches: their index and the
 * least and largest distance from x to the cell's slab (periodic: by the
 * image nearest the slab; each index once). Their count. */
typedef struct {
    int *q;
    double *dlo, *dhi;
} big_axis;

static double slab_dist(double x, double lo, double hi) { return x < lo ? lo - x : x > hi ? x - hi : 0; }

static int axis_cells(const ev_sim *s, double x, double ext, big_axis *ax)
{
    const int nc = s->nc;
    const double w = s->w;
    long a = (long)floor((x - ext) / w), b = (long)floor((x + ext) / w);
    if (!s->periodic) {
        if (a < 0) a = 0;
        if (b > nc - 1) b = nc - 1;
    } else if (b - a + 1 > nc) {
        a = 0;
        b = nc - 1;
    }
    int m = 0;
    for (long q = a; q <= b; q++) {
        const int qw = (int)(s->periodic ? ((q % nc) + nc) % nc : q);
        const double lo = qw * w, hi = lo + w;
        double dl = slab_dist(x, lo, hi), dh = fmax(fabs(x - lo), fabs(x - hi));
        if (s->periodic) {
            /* the image of x nearest this slab */
            for (int im = -1; im <= 1; im += 2) {
                const double y = x + im * s->L, d = slab_dist(y, lo, hi);
                if (d < dl) {
                    dl = d;
                    dh = fmax(fabs(y - lo), fabs(y - hi));
                }
            }
        }
        ax->q[m] = qw;
        ax->dlo[m] = dl;
        ax->dhi[m] = dh;
        m++;
    }
    return m;
}

enum { BIG_MARK, BIG_COUNT, BIG_FILL };

static inline void bit_set(uint64_t *b, uint64_t c) { b[c >> 6] |= (uint64_t)1 << (c & 63); }

/* The rank of near cell c (its index among the near cells). */
static inline uint32_t near_rank(const ev_sim *s, uint64_t c)
{
    const uint64_t w = s->bg_near[c >> 6], below = w & (((uint64_t)1 << (c & 63)) - 1);
    return s->bg_rank[c >> 6] + (uint32_t)__builtin_popcountll(below);
}

/* One pass over the cells seed j reaches: mark the bits, count the near
 * cells' entries into bg_start[rank + 1], or fill bg_idx (bg_start as
 * cursors). The margins keep a cell whose box is within round-off. */
static int seed_pass(ev_sim *s, uint32_t j, int mode)
{
    const int D = s->dim;
    const double *p = EV_P(s, j);
    const double R = p[2 * D + 1], ext = R + s->rpmax, tol = 1e-9 * (ext + s->w);
    const double near2 = (ext + tol) * (ext + tol), in = R - tol, in2 = in > 0 ? in * in : -1;
    /* at most nc cells, or 2 ext / w + 3, per axis */
    const double span = fmin((double)s->nc, 2 * (ext + tol) / s->w + 3);
    const size_t cap = (size_t)span + 1;
    big_axis ax[3];
    int *qs = malloc(3 * cap * sizeof *qs);
    double *ds = malloc(6 * cap * sizeof *ds);
    if (!qs || !ds) {
        free(qs), free(ds);
        return -1;
    }
    for (int k = 0; k < 3; k++) ax[k] = (big_axis){qs + k * cap, ds + 2 * k * cap, ds + (2 * k + 1) * cap};
    int m[3] = {1, 1, 1};
    for (int k = 0; k < D; k++) m[k] = axis_cells(s, p[k], ext + tol, &ax[k]);
    if (D == 2) {
        ax[2].q[0] = 0;
        ax[2].dlo[0] = ax[2].dhi[0] = 0;
    }
    const uint64_t nc = (uint64_t)s->nc;
    for (int a = 0; a < m[2]; a++)
        for (int b = 0; b < m[1]; b++)
            for (int c = 0; c < m[0]; c++) {
                const double dlo = ax[0].dlo[c] * ax[0].dlo[c] + ax[1].dlo[b] * ax[1].dlo[b] +
                                   ax[2].dlo[a] * ax[2].dlo[a];
                if (dlo > near2) continue;
                const double dhi = ax[0].dhi[c] * ax[0].dhi[c] + ax[1].dhi[b] * ax[1].dhi[b] +
                                   ax[2].dhi[a] * ax[2].dhi[a];
                const uint64_t cell = (uint64_t)ax[0].q[c] + nc * ((uint64_t)ax[1].q[b] + nc * (uint64_t)ax[2].q[a]);
                const int inside = dhi < in2;
                if (mode == BIG_MARK) bit_set(inside ? s->bg_inside : s->bg_near, cell);
                else if (inside) continue;
                else if (mode == BIG_COUNT) s->bg_start[near_rank(s, cell) + 1]++;
                else s->bg_idx[s->bg_start[near_rank(s, cell)]++] = j;
            }
    free(qs), free(ds);
    return 0;
}

/* The structures of the big seeds as they are placed now (ev_alloc, and a
 * checkpoint's restore): 0, or -1 when out of memory. */
int ev_big_build(ev_sim *s)
{
    const int D = s->dim;
    ev_big_free(s);
    uint32_t nbig = 0;
    for (uint32_t j = s->n; j < s->ntot; j++) nbig += ev_is_big(s, j);
    if (!nbig) return 0;
    s->nbig = nbig;
    const uint64_t ncell = (uint64_t)s->nc * (uint64_t)s->nc * (D == 3 ? (uint64_t)s->nc : 1);
    const uint64_t nw = (ncell + 63) / 64;
    s->bg_near = calloc(nw, sizeof *s->bg_near);
    s->bg_inside = calloc(nw, sizeof *s->bg_inside);
    s->bg_rank = calloc(nw + 1, sizeof *s->bg_rank);
    if (!s->bg_near || !s->bg_inside || !s->bg_rank) goto oom;
    for (uint32_t j = s->n; j < s->ntot; j++)
        if (ev_is_big(s, j) && seed_pass(s, j, BIG_MARK)) goto oom;
    uint64_t nnear = 0;
    for (uint64_t a = 0; a < nw; a++) {
        s->bg_rank[a] = (uint32_t)nnear;
        nnear += (uint64_t)__builtin_popcountll(s->bg_near[a]);
    }
    s->bg_rank[nw] = (uint32_t)nnear;
    s->bg_start = calloc(nnear + 1, sizeof *s->bg_start);
    if (!s->bg_start) goto oom;
    for (uint32_t j = s->n; j < s->ntot; j++)
        if (ev_is_big(s, j) && seed_pass(s, j, BIG_COUNT)) goto oom;
    uint64_t total = 0;
    for (uint64_t r = 0; r < nnear; r++) total += s->bg_start[r + 1];
    if (total >= UINT32_MAX) goto oom; /* the lists are indexed by 32 bits */
    for (uint64_t r = 0; r < nnear; r++) s->bg_start[r + 1] += s->bg_start[r];
    s->bg_idx = malloc((size_t)(s->bg_start[nnear] ? s->bg_start[nnear] : 1) * sizeof *s->bg_idx);
    if (!s->bg_idx) goto oom;
    /* fill with bg_start[r] as cursors, then shift the starts back */
    for (uint32_t j = s->n; j < s->ntot; j++)
        if (ev_is_big(s, j) && seed_pass(s, j, BIG_FILL)) goto oom;
    for (uint64_t r = nnear; r > 0; r--) s->bg_start[r] = s->bg_start[r - 1];
    s->bg_start[0] = 0;
    return 0;
oom:
    ev_big_free(s);
    return -1;
}

int ev_big_overlaps(const ev_sim *s, uint64_t c, const double *x, double r)
{
    if (!s->nbig) return 0;
    if ((s->bg_inside[c >> 6] >> (c & 63)) & 1) return 1;
    uint32_t lo, hi;
    ev_big_list(s, c, &lo, &hi);
    const int D = s->dim;
    for (uint32_t a = lo; a < hi; a++) {
        const double *pj = EV_P(s, s->bg_idx[a]);
        const double sig = r + pj[2 * D + 1];
        if (ev_dist2(s, x, pj) < sig * sig) return 1;
    }
    return 0;
}
