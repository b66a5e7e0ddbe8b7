/*
 * test_event.c - the event model's engine checks (fast suite `event`):
 *   brute     the engine against an independent all-pairs event loop: the
 *             same events, in the same order, at the same times
 *   conserve  sticking off: energy (walls) and momentum (periodic) to
 *             round-off, no overlap beyond 1e-10 diameters
 *   stick     sticking on: free energy falls by exactly what stuck ones
 *             carried, every stuck particle touches its parent, no overlap
 *   edge      round-off overlaps, grazing, simultaneous events, wall and
 *             particle at once, sticking onto two at once, Newton's cradle
 *   bath      kinds with STICKY 0: never stick, bounce off the cluster
 *             keeping their energy; the all-sticky history unchanged;
 *             bath-brute: against the brute force, resume with a bath;
 *             old checkpoints load as all sticky (bath-oldckpt FILE)
 *   thin      /series beyond 65536 rows: merged rows against a reference
 *             that keeps every interval; resumed across a thinning
 *   graze     grazes whose reflection is lost to round-off: no zero-time
 *             loop, no overlap, the brute force's events
 *   tiny      radii of 1e-80 (2D) and 1e-65 (3D): the collision's products
 *             of lengths and masses must not underflow
 *   determinism, params
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ev_internal.h"
#include "check.h"
#include "bpca.h"

#define TOL 1e-10 /* the stated overlap tolerance, in units of r_i + r_j */

/* ---- recorded traces ----------------------------------------------------- */
typedef struct trace {
    ev_trace_event *e;
    size_t n, cap;
} trace;

static void rec(const ev_trace_event *e, void *u)
{
    trace *t = u;
    if (t->n == t->cap) {
        t->cap = t->cap ? 2 * t->cap : 1024;
        t->e = realloc(t->e, t->cap * sizeof *t->e);
        if (!t->e) abort();
    }
    ev_trace_event x = *e;
    if (x.kind == EV_EV_PAIR && x.j != UINT32_MAX && x.j < x.i) {
        const uint32_t a = x.i;
        x.i = x.j;
        x.j = a;
    }
    t->e[t->n++] = x;
}

/* ---- brute force: all pairs, no cells, no heap ---------------------------- */
/* Independent of the engine's data structures; the same arithmetic for a
 * prediction (both states moved to max(t_i, t_j)), so with elastic walls
 * the two produce bit-identical event times. */
typedef struct bf {
    int D, periodic;
    uint32_t n, ntot;
    double L, half, p;
    double *x, *v, *t, *r, *m;
    uint8_t *stuck, *bath; /* bath: a kind with STICKY 0, never sticks */
    double *bt;
    int *bk; /* 0 none, 1 pair, 2 wall */
    uint32_t *bp;
    double now;
    pdla_rng rng;
} bf;

static double bf_pair(const bf *b, uint32_t i, uint32_t j)
{
    const int D = b->D;
    const double tr = b->t[i] > b->t[j] ? b->t[i] : b->t[j];
    const double di = tr - b->t[i], dj = tr - b->t[j];
    double rv = 0, rr = 0, vv = 0;
    for (int k = 0; k < D; k++) {
        double r = (b->x[j * 3 + k] + b->v[j * 3 + k] * dj) - (b->x[i * 3 + k] + b->v[i * 3 + k] * di);
        const double v = b->v[j * 3 + k] - b->v[i * 3 + k];
        if (b->periodic) { /* the image nearest now, as the engine takes it */
            const double rn = r + v * (b->now - tr);
            if (rn > b->half) r -= b->L;
            else if (rn < -b->half) r += b->L;
        }
        rv += r * v;
        rr += r * r;
        vv += v * v;
    }
    if (rv >= 0) return INFINITY;
    const double sig = b->r[i] + b->r[j], c = rr - sig * sig;
    if (c <= 0) return tr > b->now ? tr : b->now;
    const double disc = rv * rv - vv * c;
    if (disc <= 0) return INFINITY;
    const double t = tr + c / (-rv + sqrt(disc));
    return t > b->now ? t : b->now;
}

static void bf_best(bf *b, uint32_t i)
{
    b->bt[i] = INFINITY;
    b->bk[i] = 0;
    if (b->stuck[i]) return;
    if (!b->periodic)
        for (int k = 0; k < b->D; k++) {
            const double v = b->v[i * 3 + k];
            double t;
            if (v > 0) t = (b->L - b->r[i] - b->x[i * 3 + k]) / v;
            else if (v < 0) t = (b->x[i * 3 + k] - b->r[i]) / -v;
            else continue;
            t = t > 0 ? b->t[i] + t : b->t[i];
            if (t < b->now) t = b->now;
            if (t < b->bt[i]) {
                b->bt[i] = t;
                b->bk[i] = 2;
                b->bp[i] = (uint32_t)(2 * k + (v > 0));
            }
        }
    for (uint32_t j = 0; j < b->ntot; j++) {
        if (j == i) continue;
        const double t = bf_pair(b, i, j);
        if (t < b->bt[i] || (t == b->bt[i] && b->bk[i] == 1 && j < b->bp[i])) {
            b->bt[i] = t;
            b->bk[i] = 1;
            b->bp[i] = j;
        }
    }
}

static bf *bf_from(const ev_sim *s)
{
    bf *b = calloc(1, sizeof *b);
    const int D = s->dim;
    b->D = D;
    b->periodic = s->periodic;
    b->n = s->n;
    b->ntot = s->ntot;
    b->L = s->L;
    b->half = s->half;
    b->p = s->stick_p;
    b->rng = s->rng;
    b->x = calloc(3 * s->ntot, sizeof *b->x);
    b->v = calloc(3 * s->ntot, sizeof *b->v);
    b->t = calloc(s->ntot, sizeof *b->t);
    b->r = calloc(s->ntot, sizeof *b->r);
    b->m = calloc(s->ntot, sizeof *b->m);
    b->stuck = calloc(s->ntot, 1);
    b->bath = calloc(s->ntot, 1);
    b->bt = calloc(s->ntot, sizeof *b->bt);
    b->bk = calloc(s->ntot, sizeof *b->bk);
    b->bp = calloc(s->ntot, sizeof *b->bp);
    for (uint32_t i = 0; i < s->ntot; i++) {
        const double *p = EV_P_ANY(s, i);
        for (int k = 0; k < D; k++) {
            b->x[i * 3 + k] = p[k];
            b->v[i * 3 + k] = p[D + k];
        }
        b->t[i] = p[2 * D];
        b->r[i] = p[2 * D + 1];
        b->m[i] = ev_mass(s, i);
        b->stuck[i] = s->stuck[i];
        b->bath[i] = i < s->n && !ev_species_sticky(s, ev_species_of(s, i));
    }
    for (uint32_t i = 0; i < b->n; i++) bf_best(b, i);
    return b;
}

static void bf_free(bf *b)
{
    free(b->x), free(b->v), free(b->t), free(b->r), free(b->m), free(b->stuck), free(b->bath);
    free(b->bt), free(b->bk), free(b->bp), free(b);
}

static void bf_adv(bf *b, uint32_t i)
{
    for (int k = 0; k < b->D; k++) b->x[i * 3 + k] += b->v[i * 3 + k] * (b->now - b->t[i]);
    b->t[i] = b->now;
}

/* After particles in ch[0..nch) changed: re-predict them, and every other
 * particle whose best involved them or that may now meet them sooner. */
static void bf_update(bf *b, const uint32_t *ch, int nch)
{
    for (int q = 0; q < nch; q++) bf_best(b, ch[q]);
    for (uint32_t k = 0; k < b->n; k++) {
        if (b->stuck[k]) continue;
        int mine = 0, hit = 0;
        for (int q = 0; q < nch; q++) mine |= k == ch[q], hit |= b->bk[k] == 1 && b->bp[k] == ch[q];
        if (mine) continue;
        if (hit) {
            bf_best(b, k);
            continue;
        }
        for (int q = 0; q < nch; q++) {
            const double t = bf_pair(b, k, ch[q]);
            if (t < b->bt[k]) {
                b->bt[k] = t;
                b->bk[k] = 1;
                b->bp[k] = ch[q];
            }
        }
    }
}

/* The engine's rule for a graze whose reflection was lost to round-off
 * (ev_core.c, recede): the pair (r from a to b; a stuck: va NULL, wb = 1)
 * still approaching as bf_pair computes r.v gets the least push along r
 * that makes it recede; the same arithmetic, so the same bits. */
static double bf_approach(int D, const double *r, const double *va, const double *vb)
{
    double rv = 0;
    for (int k = 0; k < D; k++) rv += r[k] * (va ? vb[k] - va[k] : vb[k]);
    return rv;
}

static void bf_recede(int D, const double *r, double rr, double *va, double *vb, double wa, double wb)
{
    double sc = 0;
    for (int k = 0; k < D; k++) sc += fabs(r[k]) * (fabs(vb[k]) + (va ? fabs(va[k]) : 0));
    double d = 4 * DBL_EPSILON * sc + DBL_MIN;
    for (int it = 0; it < 64 && rr > 0; it++) {
        const double rv = bf_approach(D, r, va, vb);
        if (!(rv < 0)) break;
        const double dg = (d - rv) / rr;
        for (int k = 0; k < D; k++) {
            if (va) va[k] -= wa * dg * r[k];
            vb[k] += wb * dg * r[k];
        }
        d *= 2;
    }
}

/* One event; appends it to tr. 0, or -1 when none is left. */
static int bf_step(bf *b, trace *tr)
{
    uint32_t i = UINT32_MAX;
    for (uint32_t k = 0; k < b->n; k++)
        if (!b->stuck[k] && b->bk[k] && (i == UINT32_MAX || b->bt[k] < b->bt[i])) i = k;
    if (i == UINT32_MAX || b->bt[i] == INFINITY) return -1;
    b->now = b->bt[i];
    const int D = b->D;
    if (b->bk[i] == 2) {
        bf_adv(b, i);
        const int k = (int)b->bp[i] >> 1, up = (int)b->bp[i] & 1;
        b->v[i * 3 + k] = up ? -fabs(b->v[i * 3 + k]) : fabs(b->v[i * 3 + k]);
        rec(&(ev_trace_event){b->now, i, UINT32_MAX, EV_EV_WALL}, tr);
        bf_update(b, &i, 1);
        return 0;
    }
    const uint32_t j = b->bp[i];
    bf_adv(b, i);
    double r[3], rr = 0, rv = 0;
    if (b->stuck[j]) {
        for (int k = 0; k < D; k++) {
            r[k] = b->x[i * 3 + k] - b->x[j * 3 + k];
            if (b->periodic) r[k] += r[k] > b->half ? -b->L : r[k] < -b->half ? b->L : 0;
            rr += r[k] * r[k];
            rv += r[k] * b->v[i * 3 + k];
        }
        const int sticks = !b->bath[i] && (b->p >= 1 || (b->p > 0 && rng_uniform(&b->rng) < b->p));
        if (sticks) {
            for (int k = 0; k < D; k++) b->v[i * 3 + k] = 0;
            b->stuck[i] = 1;
            b->bk[i] = 0;
            rec(&(ev_trace_event){b->now, i, j, EV_EV_STICK}, tr);
        } else {
            const double f = 2 * rv / rr;
            for (int k = 0; k < D; k++) b->v[i * 3 + k] -= f * r[k];
            if (bf_approach(D, r, NULL, &b->v[i * 3]) < 0) bf_recede(D, r, rr, NULL, &b->v[i * 3], 0, 1);
            rec(&(ev_trace_event){b->now, i, j, EV_EV_PAIR}, tr);
        }
        bf_update(b, &i, 1);
        return 0;
    }
    bf_adv(b, j);
    for (int k = 0; k < D; k++) {
        r[k] = b->x[j * 3 + k] - b->x[i * 3 + k];
        if (b->periodic) r[k] += r[k] > b->half ? -b->L : r[k] < -b->half ? b->L : 0;
        rr += r[k] * r[k];
        rv += r[k] * (b->v[j * 3 + k] - b->v[i * 3 + k]);
    }
    const double mi = b->m[i], mj = b->m[j], f = 2 * rv / (rr * (mi + mj));
    for (int k = 0; k < D; k++) {
        b->v[i * 3 + k] += mj * f * r[k];
        b->v[j * 3 + k] -= mi * f * r[k];
    }
    if (bf_approach(D, r, &b->v[i * 3], &b->v[j * 3]) < 0)
        bf_recede(D, r, rr, &b->v[i * 3], &b->v[j * 3], mj / (mi + mj), mi / (mi + mj));
    rec(&(ev_trace_event){b->now, i, j, EV_EV_PAIR}, tr);
    const uint32_t ch[2] = {i, j};
    bf_update(b, ch, 2);
    return 0;
}

static ev_params base(int dim, uint64_t n, double packing, int periodic, double seed_r, double p)
{
    ev_params q;
    ev_params_default(&q);
    q.dim = dim;
    q.particles = n;
    q.packing = packing;
    q.walls = periodic;
    q.seed_radius = seed_r;
    q.stick_p = p;
    q.t_max = 1e300;
    return q;
}

/* Engine and brute force from the same start: compare the first nev events.
 * exact: times bit-identical; else within rel. tolerance 1e-9 until the
 * first divergence of the pair sequence, which must come late. The
 * engine's stuck count. */
/* Largest overlap/(r_i + r_j) of a particle with a seed now, by the
 * minimum image, over all pairs (independent of the cells and lists). */
static double seed_overlap_all(const ev_sim *s)
{
    const int D = s->dim;
    double worst = -INFINITY;
    for (uint32_t i = 0; i < s->n; i++) {
        const double *pi = EV_P_ANY(s, i);
        double xi[3] = {0, 0, 0};
        for (int k = 0; k < D; k++) xi[k] = pi[k] + pi[D + k] * (s->now - pi[2 * D]);
        for (uint32_t j = s->n; j < s->ntot; j++) {
            const double *pj = EV_P_ANY(s, j), sig = pi[2 * D + 1] + pj[2 * D + 1];
            const double ov = (sig - sqrt(ev_dist2(s, xi, pj))) / sig;
            if (ov > worst) worst = ov;
        }
    }
    return worst;
}

static uint32_t cmp_brute(const char *what, ev_params q, size_t nev, int exact, size_t min_same)
{
    char err[256];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "%s: %s", what, err);
    if (!s) return 0;
    bf *b = bf_from(s);
    trace te = {0}, tb = {0};
    ev_set_trace(s, rec, &te);
    ev_loop(s, INFINITY, NULL); /* bounded by q.max_events */
    while (tb.n < te.n && bf_step(b, &tb) == 0) {
    }
    size_t same = 0;
    double worst = 0;
    for (; same < te.n && same < tb.n; same++) {
        const ev_trace_event *a = &te.e[same], *c = &tb.e[same];
        if (a->i != c->i || a->j != c->j || a->kind != c->kind) break;
        const double d = fabs(a->t - c->t) / (fabs(c->t) + 1e-300);
        if (d > worst) worst = d;
        if (exact ? a->t != c->t : d > 1e-9) break;
    }
    const uint32_t nstuck = s->nstuck;
    const double sov = seed_overlap_all(s);
    fprintf(stderr, "%s: %zu engine events, %zu brute, %zu identical, worst rel dt %.3g, %u stuck, "
            "seed overlap %.3g\n", what, te.n, tb.n, same, worst, nstuck, sov);
    CHECK(te.n >= nev, "%s: engine stopped early", what);
    /* periodic: chaos amplifies the wrap's round-off; demand the first
     * min_same (after them, no particle may be inside a seed) */
    CHECK(exact ? same == te.n : same >= min_same, "%s: sequences differ at event %zu of %zu", what,
          same, te.n);
    CHECK(sov < TOL && ev_max_overlap_now(s) < TOL, "%s: a particle overlaps a seed by %g", what, sov);
    free(te.e);
    free(tb.e);
    bf_free(b);
    ev_free(s);
    return nstuck;
}

/* Cell lists of s: the most particles in one cell, how many are listed,
 * and how many sit in a list other than their own cell's. */
static void cell_census(const ev_sim *s, uint32_t *most, uint32_t *listed, uint32_t *bad)
{
    const size_t ncell = (size_t)s->nc * (size_t)s->nc * (s->dim == 3 ? (size_t)s->nc : 1);
    *most = *listed = *bad = 0;
    for (size_t c = 0; c < ncell; c++) {
        uint32_t m = 0;
        for (uint32_t j = s->chead[c]; j != UINT32_MAX && m <= s->ntot; j = s->cnext[j], m++)
            if (s->lk[j].cell != c) (*bad)++;
        *listed += m;
        if (m > *most) *most = m;
    }
}

/* The start of q has crowded cells (so the cell lists are long, the case
 * cmp_brute then tests): a few large particles of radius rbig size the
 * cells, no larger than they must be, and every cell's list agrees with
 * the particles' `cell` (each particle listed once, in its own cell). */
static void crowded_cells(ev_params q, double rbig)
{
    char err[256];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "crowded cells: %s", err);
    if (!s) return;
    uint32_t most, listed, bad;
    cell_census(s, &most, &listed, &bad);
    fprintf(stderr, "crowded cells (dim %d): cell side %g, up to %u particles in one, %u listed of %u, "
            "%u in a wrong cell\n", s->dim, s->w, most, listed, s->ntot, bad);
    CHECK(most >= 10, "crowded cells: at most %u particles in a cell (the test needs >= 10)", most);
    CHECK(s->w >= 2 * rbig * (1 + 1e-9) && s->w < 3 * rbig, "crowded cells: cell side %g for particles of "
          "radius up to %g", s->w, rbig);
    CHECK(bad == 0 && listed == s->ntot, "crowded cells: cell lists inconsistent");
    ev_free(s);
}

/* Contact points of big seed j (a spiral on the sphere of radius rs + rp
 * around it, and a hair inside) in no near list that names j; *npts counts
 * the points inside the box. */
static uint32_t contact_misses(const ev_sim *s, uint32_t j, double rp, uint32_t *npts)
{
    const int D = s->dim;
    const double *x = EV_P(s, j), rs = x[2 * D + 1];
    uint32_t miss = 0;
    for (int a = 0; a < 2000; a++) {
        const double z = D == 3 ? 1 - 2 * (a + 0.5) / 2000 : 0, ph = a * 2.399963229728653;
        const double rho = sqrt(1 - z * z), u[3] = {rho * cos(ph), rho * sin(ph), z};
        for (int h = 0; h < 2; h++) {
            const double d = (rs + rp) * (h ? 1 - 1e-12 : 1);
            double y[3] = {0, 0, 0};
            int in = 1;
            for (int k = 0; k < D; k++) {
                y[k] = x[k] + d * u[k];
                if (s->periodic) y[k] -= s->L * floor(y[k] / s->L);
                else if (y[k] < 0 || y[k] >= s->L) in = 0;
            }
            if (!in) continue;
            (*npts)++;
            uint64_t c = 0;
            for (int k = D - 1; k >= 0; k--) c = c * (uint64_t)s->nc + (uint64_t)fmin(s->nc - 1, floor(y[k] / s->w));
            uint32_t lo, hi, found = 0;
            ev_big_list(s, c, &lo, &hi);
            for (uint32_t m = lo; m < hi; m++) found |= s->bg_idx[m] == j;
            miss += !found;
        }
    }
    return miss;
}

/* Seeds larger than the particles (radius rp): nbig of them, in no cell
 * list, and they do not widen the cells; every other particle is listed
 * once, in its own cell; every point at the contact distance from a big
 * seed lies in a cell whose near list names it (ev_big.c: a particle there
 * would otherwise pass through the seed; periodic: through the box's edge
 * too). */
static void big_seed_cells(ev_params q, uint32_t nbig, double rp)
{
    char err[256];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "big seed cells: %s", err);
    if (!s) return;
    const int D = s->dim;
    uint32_t most, listed, bad, miss = 0, npts = 0;
    double rsmin = INFINITY;
    cell_census(s, &most, &listed, &bad);
    for (uint32_t j = s->n; j < s->ntot; j++)
        if (ev_is_big(s, j)) {
            miss += contact_misses(s, j, rp, &npts);
            rsmin = fmin(rsmin, EV_P(s, j)[2 * D + 1]);
        }
    fprintf(stderr, "big seed cells (dim %d): cell side %g, %u big seeds (radius from %g), particles %g, %u "
            "listed of %u, %u of %u contact points in no near list\n", D, s->w, s->nbig, rsmin, rp, listed,
            s->ntot, miss, npts);
    /* the grid of the particles alone: cells of at least 2 rp, at most 4
     * (3D) or 2 (2D) per particle and seed (ev_sim.c size_cells) */
    const double ncp = fmin(floor(s->L / (2 * rp * (1 + 1e-9))),
                            floor(pow((D == 3 ? 4.0 : 2.0) * s->ntot + 27, 1.0 / D)));
    CHECK(s->nbig == nbig && s->nc == (int)ncp,
          "big seed cells: %u big seeds, %d cells a side (side %g) for seeds of radius from %g and particles "
          "of %g", s->nbig, s->nc, s->w, rsmin, rp);
    CHECK(bad == 0 && listed == s->ntot - nbig, "big seed cells: cell lists inconsistent (%u listed)", listed);
    CHECK(miss == 0 && npts > 0, "big seed cells: %u contact points in no near list", miss);
    /* a particle put deep inside the first big seed (a cell wholly inside
     * it has no near list) is seen by ev_max_overlap_now */
    for (uint32_t j = s->n; j < s->ntot; j++) {
        if (!ev_is_big(s, j)) continue;
        double *p0 = EV_P(s, 0);
        for (int k = 0; k < D; k++) p0[k] = EV_P(s, j)[k] + (k ? 0 : 0.2 * EV_P(s, j)[2 * D + 1]);
        if (s->periodic) p0[0] -= s->L * floor(p0[0] / s->L);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        const double ov = ev_max_overlap_now(s);
        CHECK(ov > 0.5, "big seed cells: a particle deep inside a seed seen as overlap %g", ov);
        break;
    }
    ev_free(s);
}

/* The cases of test_brute. seeds: a --seeds file's text (NULL: the
 * central seed of radius seed_r). min_same: 0 with walls (every event bit
 * for bit), else the events that must agree to round-off (periodic).
 * check: 1, crowded cells (rbig = the large particles' radius); 2, nbig
 * seeds out of the cell lists. sticks: some particle must stick (else the
 * case tests no sticking). */
typedef struct {
    const char *what;
    int dim;
    uint64_t n;
    double packing;
    int periodic;
    double seed_r, p;
    const char *species, *seeds;
    uint64_t max_events;
    size_t nev, min_same;
    int check;
    double rbig;
    uint32_t nbig;
    int sticks;
} brute_case;

#define GAS(w, d, n, pk, per, ev, nv, ms) {w, d, n, pk, per, 0, 1, NULL, NULL, ev, nv, ms, 0, 0, 0, 0}
static const brute_case brute_cases[] = {
    GAS("2d walls gas", 2, 300, 0.2, 0, 150000, 40000, 0),
    GAS("3d walls gas", 3, 250, 0.25, 0, 150000, 40000, 0),
    {"2d walls sticking p=1", 2, 300, 0.1, 0, 1.0, 1, NULL, NULL, 200000, 1000, 0, 2, 0, 1, 1},
    {"3d walls sticking p=0.3", 3, 200, 0.1, 0, 1.0, 0.3, NULL, NULL, 200000, 2000, 0, 2, 0, 1, 1},
    {"2d walls two species", 2, 300, 0.2, 0, 0, 1, "150:0.5:1,150:0.8:3", NULL, 100000, 30000, 0, 0, 0, 0, 0},
    /* Crowded cells: a few large particles size the cells (side >= their
     * diameter), so a cell holds ~10-40 small ones: long cell lists (and in
     * 3D, scans of more candidates than one batch), bit for bit. */
    {"2d walls crowded cells", 2, 300, 0.3, 0, 0, 1, "10:5:1,290:0.5:1", NULL, 20000, 8000, 0, 1, 5.0, 0, 0},
    {"3d walls crowded cells", 3, 250, 0.2, 0, 0, 1, "6:2.5:1,244:0.5:1", NULL, 20000, 8000, 0, 1, 2.5, 0, 0},
    /* A seed of 4-10 particle radii: in no cell list, the cells sized by the
     * particles, its contacts found from the near lists (ev_big.c). It
     * reflects (p = 0), so the gas keeps hitting it, or it collects. */
    {"2d walls big seed reflecting", 2, 300, 0.3, 0, 5.0, 0, NULL, NULL, 20000, 8000, 0, 2, 0, 1, 0},
    {"3d walls big seed reflecting", 3, 250, 0.2, 0, 2.5, 0, NULL, NULL, 20000, 8000, 0, 2, 0, 1, 0},
    {"2d walls big seed sticking", 2, 300, 0.1, 0, 4.0, 1, NULL, NULL, 200000, 1000, 0, 2, 0, 1, 1},
    {"3d walls big seed sticking p=0.5", 3, 250, 0.1, 0, 2.0, 0.5, NULL, NULL, 200000, 1000, 0, 2, 0, 1, 1},
    /* periodic: wrapping at the box edge changes the stored position by L,
     * so times agree to round-off only (chaos ends the agreement later). */
    GAS("2d periodic gas", 2, 300, 0.2, 1, 20000, 5000, 1000),
    GAS("3d periodic gas", 3, 250, 0.2, 1, 20000, 5000, 1000),
    {"2d periodic big seed sticking p=0.3", 2, 300, 0.1, 1, 3.0, 0.3, NULL, NULL, 20000, 2000, 500, 2, 0, 1, 1},
    {"3d periodic big seed reflecting", 3, 250, 0.2, 1, 2.0, 0, NULL, NULL, 20000, 3000, 500, 2, 0, 1, 0},
    /* Seeds across the periodic box's edges and corner (box side 48.5 in
     * 2D, 10.9 in 3D), big ones (their near lists wrap) and one of the
     * particles' size (listed in the cells). */
    {"2d periodic edge seeds p=0.3", 2, 300, 0.1, 1, 0, 0.3, NULL, "0 0 2.5\n48.3 24 2\n24 48.5 1.5\n20 20 0.5\n",
     20000, 2000, 500, 2, 0, 3, 1},
    {"3d periodic edge seeds reflecting", 3, 250, 0.1, 1, 0, 0, NULL,
     "0 0 0 1.5\n10.8 5.5 5.5 1.2\n5.5 0.1 10.9 1\n", 20000, 3000, 500, 2, 0, 3, 0},
};
#undef GAS

/* ev_loop runs until the heap is empty or t_end: bound it by events. */
static void test_brute(void)
{
    char dir[] = "/tmp/pdla-ev-brute-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    for (size_t k = 0; k < sizeof brute_cases / sizeof brute_cases[0]; k++) {
        const brute_case *c = &brute_cases[k];
        ev_params q = base(c->dim, c->n, c->packing, c->periodic, c->seed_r, c->p);
        if (c->species) snprintf(q.species, sizeof q.species, "%s", c->species);
        if (c->seeds) {
            snprintf(q.seeds, sizeof q.seeds, "%s/seeds%zu.txt", dir, k);
            FILE *f = fopen(q.seeds, "w");
            if (!f || fputs(c->seeds, f) < 0 || fclose(f)) abort();
        }
        q.max_events = c->max_events;
        if (c->check == 1) crowded_cells(q, c->rbig);
        if (c->check == 2) big_seed_cells(q, c->nbig, q.radius);
        const uint32_t stuck = cmp_brute(c->what, q, c->nev, !c->min_same, c->min_same);
        CHECK(!c->sticks || stuck > 0, "%s: nothing stuck", c->what);
    }
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    CHECK(system(cmd) == 0, "cleanup");
}

static void momentum(const ev_sim *s, double *p, double *scale)
{
    const int D = s->dim;
    p[0] = p[1] = p[2] = 0;
    *scale = 0;
    for (uint32_t i = 0; i < s->n; i++)
        for (int k = 0; k < D; k++) {
            p[k] += ev_mass(s, i) * EV_P_ANY(s, i)[D + k];
            *scale += fabs(ev_mass(s, i) * EV_P_ANY(s, i)[D + k]);
        }
}

static void test_conserve(int dim, int periodic, double packing, double tend)
{
    ev_params q = base(dim, 1000, packing, periodic, 0, 1);
    strcpy(q.species, "600:0.5:1,400:0.7:2.5");
    q.start = EV_START_LATTICE;
    ev_sim *s = ev_create(&q, NULL, 0);
    CHECK(s != NULL, "create");
    if (!s) return;
    ev_stats a, b;
    ev_get_stats(s, &a);
    double p0[3], p1[3], sc;
    momentum(s, p0, &sc);
    double worst = ev_max_overlap_now(s);
    for (int k = 1; k <= 20; k++) {
        ev_run_until(s, tend * k / 20);
        const double ov = ev_max_overlap_now(s);
        if (ov > worst) worst = ov;
    }
    ev_get_stats(s, &b);
    momentum(s, p1, &sc);
    const double de = fabs(b.ke_free - a.ke_free) / a.ke_free;
    double dp = 0;
    for (int k = 0; k < dim; k++) dp = fmax(dp, fabs(p1[k] - p0[k]) / sc);
    fprintf(stderr, "conserve %dd %s eta %.2f: %llu collisions, dE/E %.3g, dp/sum|p| %.3g, "
            "overlap now %.3g, at collisions %.3g, stale %llu\n",
            dim, periodic ? "periodic" : "walls", packing, (unsigned long long)b.collisions, de, dp,
            worst, b.max_overlap, (unsigned long long)b.invalid);
    CHECK(b.collisions > 100000, "too few collisions");
    /* round-off: ~1e-16 per collision, summed as a random walk */
    CHECK(de < 1e-11, "energy drift %g", de);
    if (periodic) CHECK(dp < 1e-11, "momentum drift %g", dp);
    CHECK(worst < TOL && b.max_overlap < TOL, "overlap %g / %g", worst, b.max_overlap);
    ev_free(s);
}

/* Sticking on: energy bookkeeping, contacts, overlaps. */
/* A --seeds file for test_stick (NULL: the central seed). */
static const char *stick_seeds;

/* |distance - sum of radii| / sum of radii of particles i and j (a stuck
 * particle and its parent): 0 when they touch exactly. */
static double contact_gap(const ev_sim *s, uint32_t i, uint32_t j, int dim)
{
    double rr = 0;
    for (int c = 0; c < dim; c++) {
        const double d = EV_P_ANY(s, i)[c] - EV_P_ANY(s, j)[c];
        rr += d * d;
    }
    const double sig = EV_P_ANY(s, i)[2 * dim + 1] + EV_P_ANY(s, j)[2 * dim + 1];
    return fabs(sqrt(rr) - sig) / sig;
}

static void test_stick(int dim, double packing, double p)
{
    ev_params q = base(dim, dim == 2 ? 2000 : 1500, packing, 0, 0.5, p);
    strcpy(q.species, dim == 2 ? "1500:0.5:1,500:0.3:2" : "1000:0.5:1,500:0.35:2");
    if (stick_seeds) snprintf(q.seeds, sizeof q.seeds, "%s", stick_seeds);
    q.t_max = 0;
    q.velocities = EV_VEL_FIXED;
    ev_sim *s = ev_create(&q, NULL, 0);
    CHECK(s != NULL, "create");
    if (!s) return;
    ev_stats a, b;
    ev_get_stats(s, &a);
    double worst = 0;
    int why = 0;
    for (int k = 1; k <= 40 && why != EV_STOP_ALL_STUCK; k++) {
        q.max_stuck = s->n * (uint64_t)k / 40;
        s->par.max_stuck = q.max_stuck;
        why = ev_run(s, NULL);
        const double ov = ev_max_overlap_now(s);
        if (ov > worst) worst = ov;
    }
    ev_get_stats(s, &b);
    const double de = fabs(b.ke_free + b.ke_stuck - a.ke_free) / a.ke_free;
    /* every stuck particle touches its parent */
    const int D = dim;
    double worst_touch = 0;
    for (uint32_t k = 0; k < s->nstuck; k++) {
        const uint32_t i = s->stuck_idx[k], j = s->parent[i];
        worst_touch = fmax(worst_touch, contact_gap(s, i, j, D));
        CHECK(j >= s->n || (s->stuck[j] && j != i), "parent of %u not stuck", i);
        CHECK(j < s->ntot, "parent of %u is %u, no particle or seed", i, j);
    }
    fprintf(stderr, "stick %dd eta %.3f p %.1f: stuck %llu of %u (%s), dE/E %.3g, contact gap %.3g, "
            "overlap %.3g\n", dim, packing, p, (unsigned long long)b.stuck, s->n,
            ev_stop_name(why), de, worst_touch, worst);
    CHECK(b.stuck == s->n && why == EV_STOP_ALL_STUCK, "not all stuck: %s", ev_stop_name(why));
    CHECK(b.ke_free == 0, "free energy left %g", b.ke_free);
    CHECK(de < 1e-12, "energy bookkeeping %g", de);
    CHECK(worst_touch < TOL, "stuck particle off its parent by %g", worst_touch);
    CHECK(worst < TOL && b.max_overlap < TOL, "overlap %g", worst);
    ev_free(s);
}

/* ---- hand-made edge cases ------------------------------------------------- */
/* A sim of n unit-diameter disks (2D, walls, box side about 40), states then
 * set by hand; the seed (if any) is index n. */
static ev_sim *blank(int n, int seed)
{
    ev_params q = base(2, (uint64_t)n, n * M_PI * 0.25 / 1600.0, 0, seed ? 0.5 : 0, 1);
    q.start = EV_START_LATTICE;
    ev_sim *s = ev_create(&q, NULL, 0);
    if (!s) abort();
    for (uint32_t i = 0; i < s->ntot; i++) {
        double *p = EV_P_ANY(s, i);
        p[0] = p[1] = 20;
        p[2] = p[3] = 0;
        p[4] = 0;
    }
    return s;
}

static void setp(ev_sim *s, uint32_t i, double x, double y, double vx, double vy)
{
    double *p = EV_P_ANY(s, i);
    p[0] = x, p[1] = y, p[2] = vx, p[3] = vy, p[4] = s->now;
}

static double energy(const ev_sim *s)
{
    ev_stats st;
    ev_get_stats(s, &st);
    return st.ke_free + st.ke_stuck;
}

static void test_edge(void)
{
    trace t = {0};
    /* 1. round-off overlap, approaching: collide at once; receding: never. */
    {
        ev_sim *s = blank(2, 0);
        setp(s, 0, 10, 10, 1, 0);
        setp(s, 1, 11 - 1e-14, 10, -1, 0);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        ev_set_trace(s, rec, &t);
        t.n = 0;
        ev_run_until(s, 1e-12);
        CHECK(t.n == 1 && t.e[0].kind == EV_EV_PAIR && t.e[0].t == 0, "overlap approach: %zu", t.n);
        CHECK(EV_P_ANY(s, 0)[2] < 0 && EV_P_ANY(s, 1)[2] > 0, "did not bounce");
        ev_free(s);
        s = blank(2, 0);
        setp(s, 0, 10, 10, -1, 0);
        setp(s, 1, 11 - 1e-14, 10, 1, 0);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        ev_set_trace(s, rec, &t);
        t.n = 0;
        ev_run_until(s, 5);
        CHECK(t.n == 0, "overlap receding: %zu events", t.n);
        ev_free(s);
    }
    /* 2. grazing: impact parameter exactly sigma (passes), and a hair less
     *    (collides, no overlap). */
    {
        ev_sim *s = blank(2, 0);
        setp(s, 0, 10, 10, 1, 0);
        setp(s, 1, 15, 11, 0, 0);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        ev_set_trace(s, rec, &t);
        t.n = 0;
        ev_run_until(s, 8);
        CHECK(t.n == 0, "exact graze: %zu events", t.n);
        CHECK(ev_max_overlap_now(s) < TOL, "graze overlap");
        ev_free(s);
        s = blank(2, 0);
        setp(s, 0, 10, 10, 1, 0);
        setp(s, 1, 15, 11 - 1e-12, 0, 0);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        const double e0 = energy(s);
        double worst = 0;
        for (int k = 1; k <= 100; k++) {
            ev_run_until(s, 0.1 * k);
            worst = fmax(worst, ev_max_overlap_now(s));
        }
        CHECK(s->collisions == 1, "near graze: %llu collisions", (unsigned long long)s->collisions);
        CHECK(worst < TOL, "near graze overlap %g", worst);
        CHECK(fabs(energy(s) - e0) < 1e-14 * e0, "near graze energy");
        ev_free(s);
    }
    /* 3. simultaneous: two disks hit a third from both sides at once. */
    {
        ev_sim *s = blank(3, 0);
        setp(s, 0, 10, 20, 1, 0);
        setp(s, 1, 13, 20, 0, 0);
        setp(s, 2, 16, 20, -1, 0);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        const double e0 = energy(s);
        ev_run_until(s, 3);
        CHECK(ev_max_overlap_now(s) < TOL, "simultaneous overlap");
        CHECK(fabs(energy(s) - e0) < 1e-14, "simultaneous energy");
        CHECK(EV_P_ANY(s, 0)[2] < 0 && EV_P_ANY(s, 2)[2] > 0, "outer ones must leave");
        CHECK(s->collisions < 10, "zero-time loop: %llu", (unsigned long long)s->collisions);
        ev_free(s);
    }
    /* 4. a wall and a particle at the same instant: 0 reaches the wall
     *    (x = r) at t = 1 while 1 hits it from the right. */
    {
        ev_sim *s = blank(2, 0);
        setp(s, 0, 1.5, 20, -1, 0);
        setp(s, 1, 3.5, 20, -2, 0);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        const double e0 = energy(s);
        double worst = 0;
        for (int k = 1; k <= 40; k++) {
            ev_run_until(s, 0.1 * k);
            worst = fmax(worst, ev_max_overlap_now(s));
            const double *p = EV_P_ANY(s, 0);
            CHECK(p[0] + p[2] * (s->now - p[4]) >= 0.5 - 1e-12, "through the wall");
        }
        CHECK(worst < TOL, "wall+pair overlap %g", worst);
        CHECK(fabs(energy(s) - e0) < 1e-13 * e0, "wall+pair energy");
        CHECK(EV_P_ANY(s, 0)[2] > 0 && EV_P_ANY(s, 1)[2] > 0, "both move away from the wall");
        ev_free(s);
    }
    /* 5. sticking onto two at once: the seed (index 1) at (20,20), stuck 0
     *    touching it at (21,20); free 2 falls onto both. */
    {
        ev_sim *s = blank(3, 1);
        s->stuck[0] = 1;
        setp(s, 0, 21, 20, 0, 0);
        setp(s, 3, 20, 20, 0, 0);
        setp(s, 1, 30, 30, 0, 0);
        s->stuck[1] = 1; /* a far resting spectator */
        setp(s, 2, 20.5, 20 + sqrt(0.75) + 2, 0, -1);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        ev_set_trace(s, rec, &t);
        t.n = 0;
        ev_run_until(s, 5);
        CHECK(s->stuck[2], "did not stick");
        CHECK(t.n == 1 && t.e[0].kind == EV_EV_STICK, "%zu events", t.n);
        CHECK(s->parent[2] == 0 || s->parent[2] == 3, "parent %u", s->parent[2]);
        CHECK(ev_max_overlap_now(s) < TOL, "overlap after double stick %g", ev_max_overlap_now(s));
        ev_free(s);
    }
    /* 6. Newton's cradle: 5 touching disks, one hits the row: a chain of
     *    zero-time collisions that must end with the last one leaving. */
    {
        ev_sim *s = blank(6, 0);
        setp(s, 0, 5, 20, 1, 0);
        for (int k = 1; k < 6; k++) setp(s, (uint32_t)k, 10 + k, 20, 0, 0);
        CHECK(ev_rebuild(s) == 0, "rebuild");
        ev_run_until(s, 6);
        CHECK(s->collisions == 5, "cradle: %llu collisions", (unsigned long long)s->collisions);
        CHECK(fabs(EV_P_ANY(s, 5)[2] - 1) < 1e-15 && fabs(EV_P_ANY(s, 0)[2]) < 1e-15, "cradle velocities");
        CHECK(ev_max_overlap_now(s) < TOL, "cradle overlap");
        ev_free(s);
    }
    free(t.e);
}

static void test_determinism(void)
{
    uint64_t h[3];
    for (int r = 0; r < 3; r++) {
        ev_params q = base(3, 800, 0.1, 0, 0.5, 0.5);
        q.t_max = 0;
        q.seed = r == 2 ? 7 : 3;
        ev_sim *s = ev_create(&q, NULL, 0);
        CHECK(s != NULL, "create");
        if (!s) return;
        ev_run(s, NULL);
        uint64_t x = 1469598103934665603ull;
        for (uint32_t k = 0; k < s->nstuck; k++) {
            double pos[3];
            memcpy(pos, EV_P_ANY(s, s->stuck_idx[k]), sizeof pos);
            const unsigned char *c = (const unsigned char *)pos;
            for (size_t b = 0; b < sizeof pos; b++) x = (x ^ c[b]) * 1099511628211ull;
        }
        h[r] = x;
        ev_free(s);
    }
    CHECK(h[0] == h[1], "same seed, different clusters");
    CHECK(h[0] != h[2], "different seeds, same cluster");
}

/* ev_df_fit (the D_f of /results and `pdla analyze`) on clusters of known
 * dimension, in arrival order: a line (R_g ~ k, D_f = 1) and a disk filled
 * shell by shell (R_g ~ k^(1/2), D_f = 2). Tolerance 0.03: the lattice
 * disk's R_g(k) wobbles by a few % at small k (whole shells), the line's
 * R_g = sqrt((k^2 - 1) / 12) is k / sqrt(12) to 0.1% from k = 20. */
typedef struct dpt {
    double x, y, d;
} dpt;
static int dpt_cmp(const void *a, const void *b)
{
    const double u = ((const dpt *)a)->d, v = ((const dpt *)b)->d;
    return u < v ? -1 : u > v;
}
static void test_dffit(void)
{
    enum { N = 4000 };
    static double pos[2 * N];
    uint64_t lo, hi;
    for (int k = 0; k < N; k++) pos[2 * k] = k, pos[2 * k + 1] = 0;
    double df = ev_df_fit(pos, N, 2, 1e9, NULL, &lo, &hi);
    CHECK(fabs(df - 1) < 0.03 && hi == N, "line: D_f %g over %llu..%llu", df,
          (unsigned long long)lo, (unsigned long long)hi);
    static dpt pt[81 * 81];
    int m = 0;
    for (int i = -40; i <= 40; i++)
        for (int j = -40; j <= 40; j++) pt[m++] = (dpt){i, j, hypot(i, j) + 1e-6 * (i + 41 * j)};
    qsort(pt, (size_t)m, sizeof *pt, dpt_cmp);
    for (int k = 0; k < N; k++) pos[2 * k] = pt[k].x, pos[2 * k + 1] = pt[k].y;
    df = ev_df_fit(pos, N, 2, 1e9, NULL, &lo, &hi);
    CHECK(fabs(df - 2) < 0.03, "disk: D_f %g", df);
    /* rg_max cuts the range; too few left: NaN */
    df = ev_df_fit(pos, N, 2, 3.0, NULL, &lo, &hi);
    CHECK(isnan(df) && lo == 0 && hi == 0, "small rg_max: D_f %g", df);
}

static void test_params(void)
{
    char err[256];
    ev_params p;
    ev_params_default(&p);
    CHECK(ev_params_check(&p, err, sizeof err) == 0, "defaults invalid: %s", err);
    CHECK(ev_param_set(&p, "stick-p", "1.5", err, sizeof err) < 0, "p > 1 accepted");
    CHECK(ev_param_set(&p, "density", "-1", err, sizeof err) < 0, "negative density accepted");
    CHECK(ev_param_set(&p, "box_walls", "periodic", err, sizeof err) == 0 && p.walls == 1, "scene key");
    CHECK(ev_param_set(&p, "particles", "1e5", err, sizeof err) == 0 && p.particles == 100000, "1e5");
    ev_params_default(&p);
    strcpy(p.species, "10:0.5:-1");
    CHECK(ev_params_check(&p, err, sizeof err) < 0, "negative species density accepted");
    ev_params_default(&p);
    p.dim = 3;
    p.packing = 0.45;
    p.particles = 3000;
    CHECK(ev_create(&p, err, sizeof err) == NULL && strstr(err, "cannot place"),
          "unreachable packing not refused: %s", err);
    p.particles = 4;
    p.packing = 0.5;
    CHECK(ev_create(&p, err, sizeof err) == NULL && strstr(err, "box too small"), "small box: %s", err);
}

/* Pressure from the collision virial against Henderson (2D) or
 * Carnahan-Starling (3D), and the collision rate against Enskog with g(sigma)
 * from the same equation of state. Periodic box, one species, lattice start
 * melted for t_eq, measured over 10 blocks of t_meas / 10. The tolerance is
 * 1% on Z (the equations of state are good to a few 0.1% at eta <= 0.4 and
 * N >= 1000 adds ~0.1%); the block scatter is printed and must itself be
 * well under the tolerance, so a pass is not luck. Collision rate: 2.5%
 * (Enskog neglects velocity correlations, a ~1-2% effect at eta 0.4). */
static void test_eos(int dim, double eta, uint64_t n, double t_meas)
{
    ev_params q = base(dim, n, eta, 1, 0, 1);
    q.start = EV_START_LATTICE;
    q.seed = 11;
    ev_sim *s = ev_create(&q, NULL, 0);
    CHECK(s != NULL, "create");
    if (!s) return;
    const double t_eq = 20;
    ev_run_until(s, t_eq);
    enum { B = 10 };
    double z[B], zsum = 0, rate = 0;
    ev_stats a, b;
    ev_get_stats(s, &a);
    const uint64_t c0 = a.collisions;
    for (int k = 0; k < B; k++) {
        ev_get_stats(s, &a);
        ev_run_until(s, t_eq + t_meas * (k + 1) / B);
        ev_get_stats(s, &b);
        z[k] = 1 + (b.virial - a.virial) / (2 * b.ke_free * (b.t - a.t));
        zsum += z[k];
    }
    const double zm = zsum / B;
    double var = 0;
    for (int k = 0; k < B; k++) var += (z[k] - zm) * (z[k] - zm);
    const double se = sqrt(var / (B * (B - 1.0)));
    const double zth = dim == 2 ? (1 + eta * eta / 8) / ((1 - eta) * (1 - eta))
                                : (1 + eta + eta * eta - eta * eta * eta) / pow(1 - eta, 3);
    const double kT = 2 * b.ke_free / (dim * (double)n), m = ev_mass(s, 0), sig = 2 * q.radius;
    const double rho = (double)n / s->V;
    const double g = (zth - 1) / (dim == 2 ? 2 * eta : 4 * eta);
    const double omega = (dim == 2 ? 2 * rho * sig : 4 * rho * sig * sig) * g * sqrt(M_PI * kT / m);
    rate = (double)(b.collisions - c0) / t_meas;
    const double rate_th = 0.5 * (double)n * omega;
    fprintf(stderr, "eos %dd eta %.2f N %llu: Z %.5f +- %.5f (theory %.5f, %+.3f%%), collision rate "
            "%.5g (Enskog %.5g, %+.3f%%), %llu collisions\n", dim, eta, (unsigned long long)n, zm, se,
            zth, 100 * (zm / zth - 1), rate, rate_th, 100 * (rate / rate_th - 1),
            (unsigned long long)(b.collisions - c0));
    CHECK(fabs(zm / zth - 1) < 0.01, "Z off by %g", zm / zth - 1);
    CHECK(se / zth < 0.004, "too noisy to test: se %g", se);
    CHECK(fabs(rate / rate_th - 1) < 0.025, "collision rate off by %g", rate / rate_th - 1);
    CHECK(ev_max_overlap_now(s) < TOL, "overlap");
    ev_free(s);
}

/* From the seed's fixed speed to Maxwell-Boltzmann: <v^4>/<v^2>^2 goes from
 * 1 to 2 (2D) or 5/3 (3D). Averaged over 20 snapshots a few collision times
 * apart (N = 3000: the statistical error is ~1%): tolerance 3%. */
static void test_mb(int dim)
{
    ev_params q = base(dim, 3000, 0.2, 1, 0, 1);
    q.velocities = EV_VEL_FIXED;
    q.start = EV_START_LATTICE;
    ev_sim *s = ev_create(&q, NULL, 0);
    CHECK(s != NULL, "create");
    if (!s) return;
    ev_run_until(s, 15);
    double r = 0;
    const int S = 20;
    for (int k = 0; k < S; k++) {
        ev_run_until(s, 15 + 3.0 * (k + 1));
        double v2 = 0, v4 = 0;
        for (uint32_t i = 0; i < s->n; i++) {
            double w = 0;
            for (int c = 0; c < dim; c++) w += EV_P_ANY(s, i)[dim + c] * EV_P_ANY(s, i)[dim + c];
            v2 += w;
            v4 += w * w;
        }
        v2 /= s->n;
        v4 /= s->n;
        r += v4 / (v2 * v2) / S;
    }
    const double th = dim == 2 ? 2.0 : 5.0 / 3.0;
    fprintf(stderr, "mb %dd: <v^4>/<v^2>^2 = %.4f (Maxwell-Boltzmann %.4f, start 1)\n", dim, r, th);
    CHECK(fabs(r / th - 1) < 0.03, "not Maxwell-Boltzmann: %g", r);
    ev_free(s);
}

/* Sticking off, periodic, N = 1e4 (two species) until `ncoll` collisions
 * (the issue asks 1e8: suite slow): energy and momentum to round-off and no
 * overlap, checked at ~20 points. Bounds: 1e-10 relative (round-off of
 * ~1e-16 per collision adds up to ~1e-12 as a random walk over 1e8, or to
 * 1e-8 if it were systematic: the bound sits between and catches a bias). */
static void test_conserve_long(int dim, double ncoll)
{
    ev_params q = base(dim, 10000, 0.3, 1, 0, 1);
    strcpy(q.species, "6000:0.5:1,4000:0.7:2.5");
    q.start = EV_START_LATTICE;
    ev_sim *s = ev_create(&q, NULL, 0);
    CHECK(s != NULL, "create");
    if (!s) return;
    ev_stats a, b;
    ev_get_stats(s, &a);
    double p0[3], p1[3], sc;
    momentum(s, p0, &sc);
    double worst = ev_max_overlap_now(s), t = 0, dt = 1;
    for (int k = 0;; k++) {
        t += dt;
        ev_run_until(s, t);
        ev_get_stats(s, &b);
        const double ov = ev_max_overlap_now(s);
        if (ov > worst) worst = ov;
        if ((double)b.collisions >= ncoll) break;
        if (k == 0) dt = t * (ncoll / (double)(b.collisions + 1)) / 20; /* ~20 checks */
    }
    momentum(s, p1, &sc);
    const double de = fabs(b.ke_free - a.ke_free) / a.ke_free;
    double dp = 0;
    for (int k = 0; k < dim; k++) dp = fmax(dp, fabs(p1[k] - p0[k]) / sc);
    fprintf(stderr, "conserve-long %dd: %llu collisions to t %.4g, dE/E %.3g, dp/sum|p| %.3g, "
            "overlap %.3g / %.3g\n", dim, (unsigned long long)b.collisions, b.t, de, dp, worst,
            b.max_overlap);
    CHECK(de < 1e-10, "energy drift %g", de);
    CHECK(dp < 1e-10, "momentum drift %g", dp);
    CHECK(worst < TOL && b.max_overlap < TOL, "overlap %g / %g", worst, b.max_overlap);
    ev_free(s);
}

/* The limit of a long mean free path (issue 15's physics record,
 * runs/event/README.md): the event model's cluster against ballistic
 * particle-cluster aggregation (bpca.h) of the same N, by the mass-radius
 * D_f (bpca_mass_radius). The event model at packing 1e-3 (mean free path
 * 278 diameters in 2D, 118 in 3D, against a cluster 20-50 across), nev runs;
 * BPCA nb runs. Passes when the event mean is within tol of BPCA's and
 * beyond pdla's DLA value (dla) by more than gap: ballistic-like, not
 * diffusion-limited. Tolerances from the measured spread (see the caller). */
static double ev_mass_df(int dim, uint64_t n, double packing, uint64_t seed)
{
    ev_params q = base(dim, n, packing, 0, 0.5, 1);
    q.t_max = 0;
    q.seed = seed;
    ev_sim *s = ev_create(&q, NULL, 0);
    CHECK(s != NULL, "create");
    if (!s) return NAN;
    CHECK(ev_run(s, NULL) == EV_STOP_ALL_STUCK, "not all stuck");
    double *pos = malloc((size_t)s->nstuck * dim * sizeof *pos), c[3], rmax;
    if (!pos) abort();
    for (uint32_t k = 0; k < s->nstuck; k++) memcpy(pos + (size_t)k * dim, EV_P_ANY(s, s->stuck_idx[k]), dim * sizeof *pos);
    memcpy(c, ev_pos(s, ev_count(s)), dim * sizeof *c);
    const double df = bpca_mass_radius(pos, s->nstuck, dim, c, s->L / 4, &rmax);
    free(pos);
    ev_free(s);
    return df;
}
static void test_ballistic(int dim, uint64_t n, int nev, int nb, double tol, double dla, double gap)
{
    double be = 0, bb = 0, bb2 = 0, e[16], b[64];
    double *pos = malloc(n * dim * sizeof *pos), rmax;
    if (!pos || nev > 16 || nb > 64) abort();
    const double zero[3] = {0, 0, 0};
    for (int k = 0; k < nb; k++) {
        bpca_grow(dim, n, 1000 + k, pos);
        b[k] = bpca_mass_radius(pos, n, dim, zero, INFINITY, &rmax);
        bb += b[k] / nb, bb2 += b[k] * b[k] / nb;
    }
    free(pos);
    for (int k = 0; k < nev; k++) be += (e[k] = ev_mass_df(dim, n, 1e-3, 1 + k)) / nev;
    fprintf(stderr, "ballistic %dd N %llu: event (packing 1e-3) mass-radius D_f", dim, (unsigned long long)n);
    for (int k = 0; k < nev; k++) fprintf(stderr, " %.4f", e[k]);
    fprintf(stderr, ", mean %.4f; BPCA mean %.4f sd %.4f (%d runs); DLA %.2f\n", be, bb,
            sqrt(fmax(0, bb2 - bb * bb)), nb, dla);
    CHECK(fabs(be - bb) < tol, "event %.4f vs BPCA %.4f: not ballistic", be, bb);
    CHECK(be - dla > gap, "event %.4f within %.2f of DLA %.2f", be, gap, dla);
}

/* ---- checkpoint and resume ---------------------------------------------- */
/* Stop at the k-th tick (as a signal would), mid-way through a series row. */
typedef struct tick_stop { int calls, at; } tick_stop;
static int tick_at(ev_sim *s, void *u)
{
    (void)s;
    tick_stop *t = u;
    return ++t->calls == t->at;
}

/* A series row without events still polls the interrupt and calls the tick
 * (pdla/event.h: "at each series row"): before, ev_loop returned at such a
 * row's end before its poll, so a run whose rows held no event (series-dt
 * far below the time between events: here 1e-9 against ~0.1) went on deaf
 * to SIGINT/SIGTERM, progress and --checkpoint-every until the next event
 * (about 1e6 rows later here, minutes with more particles). */
static void test_quiet_rows(void)
{
    ev_params q = base(2, 20, 0.001, 0, 0.5, 1);
    q.series_dt = 1e-9;
    char err[512];
    for (int by_flag = 0; by_flag < 2; by_flag++) {
        ev_sim *s = ev_create(&q, err, sizeof err);
        CHECK(s != NULL, "quiet rows: %s", err);
        if (!s) return;
        ev_series ser = {0};
        tick_stop tk = {0, 1};
        volatile int stop = by_flag;
        if (!by_flag) ev_set_tick(s, tick_at, &tk);
        const int why = ev_run_series(s, &ser, &stop);
        CHECK(why == EV_STOP_INTERRUPT && s->events == 0 && ser.n <= 2,
              "quiet rows (%s): stop %s after %llu events and %zu rows, want interrupted at the first row",
              by_flag ? "flag" : "tick", ev_stop_name(why), (unsigned long long)s->events, ser.n);
        ev_series_free(&ser);
        ev_free(s);
    }
}

/* A series row sums the free kinetic energy over all N only when a
 * velocity changed since the last row (a collision, a reflection off the
 * cluster, a stick); its value is the same bits as ev_get_stats's. Before,
 * every row summed all N, twice (its pressure too), and --series-dt far
 * below the time between events made every interval a row until the
 * thinning had doubled it enough: --series-dt 1e-9 to t = 1 took 15 s for
 * 1e4 disks and 12000 events. Each tick at a new row (the start of the
 * next interval, nothing changed since) compares the row's energy with a
 * fresh sum; three runs: walls and sticking (2D), a bath reflecting off
 * the cluster in a periodic box (3D), and 2000 disks at series-dt 1e-9
 * (about 4e5 rows, ~30 collisions: the sums must follow the collisions,
 * not the rows). */
typedef struct ke_watch { const ev_series *ser; double last_t; size_t rows, bad; } ke_watch;
static int ke_tick(ev_sim *s, void *u)
{
    ke_watch *w = u;
    const ev_series *ser = w->ser;
    if (!ser->n || ser->t[ser->n - 1] == w->last_t) return 0;
    w->last_t = ser->t[ser->n - 1];
    w->rows++;
    ev_stats st;
    ev_get_stats(s, &st);
    if (ser->t[ser->n - 1] == s->now && memcmp(&ser->ke[ser->n - 1], &st.ke_free, sizeof st.ke_free)) w->bad++;
    return 0;
}

static void row_cost_case(const char *what, ev_params q, int check_each, size_t min_rows)
{
    char err[512];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "row cost %s: %s", what, err);
    if (!s) return;
    ev_series ser = {0};
    ke_watch w = {&ser, -1, 0, 0};
    if (check_each) ev_set_tick(s, ke_tick, &w);
    const int why = ev_run_series(s, &ser, NULL);
    ev_stats st;
    ev_get_stats(s, &st);
    fprintf(stderr, "row cost %s: %s at t %g, %zu rows checked, %llu collisions, %llu sticks, %llu sums\n", what,
            ev_stop_name(why), s->now, w.rows, (unsigned long long)s->collisions, (unsigned long long)s->sticks,
            (unsigned long long)s->ke_sums);
    CHECK(why == EV_STOP_TIME && ser.n > 1, "row cost %s: stop %s, %zu rows", what, ev_stop_name(why), ser.n);
    CHECK(!memcmp(&ser.ke[ser.n - 1], &st.ke_free, sizeof st.ke_free), "row cost %s: the last row's energy %.17g is "
          "not the sum %.17g", what, ser.ke[ser.n - 1], st.ke_free);
    CHECK(w.bad == 0 && w.rows >= min_rows, "row cost %s: %zu of %zu rows not the fresh sum", what, w.bad, w.rows);
    CHECK(s->ke_sums <= s->collisions + s->sticks + 1, "row cost %s: %llu sums of all N for %llu collisions and "
          "%llu sticks", what, (unsigned long long)s->ke_sums, (unsigned long long)s->collisions,
          (unsigned long long)s->sticks);
    ev_series_free(&ser);
    ev_free(s);
}

static void test_row_cost(void)
{
    ev_params q = base(2, 400, 0.1, 0, 1, 0.3);
    q.series_dt = 0.01;
    q.t_max = 40;
    row_cost_case("2d walls", q, 1, 3000);
    q = base(3, 1, 0.15, 1, 1, 0.5);
    strcpy(q.species, "100:0.5:1,500:0.5:1:0");
    q.series_dt = 0.002;
    q.t_max = 10;
    row_cost_case("3d bath", q, 1, 4000);
    q = base(2, 2000, 0.1, 0, 0.5, 1);
    q.series_dt = 1e-9;
    q.t_max = 0.05;
    row_cost_case("series-dt 1e-9", q, 0, 0);
}

/* A stop time already passed (a resume's --t-max below the checkpoint's
 * time) ends the run where it is: before, the clock was set back to it
 * ("time reached at time 5" for a state at 12, particles' local times after
 * `now`: a checkpoint its own loader refused). */
static void test_past_stop(void)
{
    ev_params q = base(2, 100, 0.1, 0, 0.5, 1);
    char err[512];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "past stop: %s", err);
    if (!s) return;
    ev_series ser = {0};
    s->par.t_max = 4;
    CHECK(ev_run_series(s, &ser, NULL) == EV_STOP_TIME && s->now == 4, "past stop: first leg to %g", s->now);
    s->par.t_max = 2;
    const int why = ev_run_series(s, &ser, NULL);
    CHECK(why == EV_STOP_TIME && s->now == 4 && ser.n && ser.t[ser.n - 1] == 4,
          "past stop: stop %s at %g, last row %g (want time reached at 4)", ev_stop_name(why), s->now,
          ser.n ? ser.t[ser.n - 1] : -1.0);
    ev_series_free(&ser);
    ev_free(s);
}

/* The collision counters of a and b's first N particles are the same. */
static int same_counts(const ev_sim *a, const ev_sim *b, size_t N)
{
    for (size_t i = 0; i < N; i++)
        if (a->lk[i].count != b->lk[i].count) return 0;
    return 1;
}

static int same_state(const char *what, const ev_sim *a, const ev_sim *b, const ev_series *sa,
                      const ev_series *sb)
{
    const size_t N = a->ntot;
    int ok = a->ntot == b->ntot && a->nstuck == b->nstuck && sa->n == sb->n;
    CHECK(ok, "%s: sizes differ (stuck %u/%u, rows %zu/%zu)", what, a->nstuck, b->nstuck, sa->n, sb->n);
    if (!ok) return 0;
    ok = !memcmp(a->ps, b->ps, N * (size_t)(2 * a->dim + 2) * sizeof(double)) &&
         same_counts(a, b, N) &&
         !memcmp(a->stuck, b->stuck, N) && !memcmp(a->parent, b->parent, N * sizeof *a->parent) &&
         !memcmp(a->stuck_idx, b->stuck_idx, a->nstuck * sizeof *a->stuck_idx) &&
         !memcmp(a->stuck_t, b->stuck_t, a->nstuck * sizeof *a->stuck_t) &&
         !memcmp(&a->now, &b->now, sizeof a->now) && !memcmp(&a->virial, &b->virial, sizeof a->virial) &&
         !memcmp(&a->ke_stuck, &b->ke_stuck, sizeof a->ke_stuck) && a->events == b->events &&
         a->collisions == b->collisions && a->invalid == b->invalid &&
         !memcmp(&a->rng, &b->rng, sizeof a->rng);
    CHECK(ok, "%s: the resumed state is not bit-identical (events %llu/%llu, t %.17g/%.17g)", what,
          (unsigned long long)a->events, (unsigned long long)b->events, a->now, b->now);
    const int ser = !memcmp(sa->t, sb->t, sa->n * sizeof *sa->t) &&
                    !memcmp(sa->ke, sb->ke, sa->n * sizeof *sa->ke) &&
                    !memcmp(sa->pressure, sb->pressure, sa->n * sizeof *sa->pressure) &&
                    !memcmp(sa->stuck, sb->stuck, sa->n * sizeof *sa->stuck) &&
                    !memcmp(sa->collisions, sb->collisions, sa->n * sizeof *sa->collisions);
    CHECK(ser, "%s: the resumed series differs", what);
    return ok && ser;
}

/* A run stopped at tick `at` (mid-row), checkpointed, freed, loaded and run
 * on must equal, bit for bit, the run never stopped; a second stop and
 * resume of the resumed run too (the checkpoint's own round trip). */
static void resume_case(const char *what, ev_params q, int at)
{
    char err[512], dir[] = "/tmp/pdla-ev-ckpt-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    ev_series sa = {0}, sb = {0};
    ev_sim *a = ev_create(&q, err, sizeof err);
    CHECK(a != NULL, "%s: %s", what, err);
    if (!a) return;
    const int wa = ev_run_series(a, &sa, NULL);
    ev_sim *b = ev_create(&q, err, sizeof err);
    tick_stop ts = {0, at};
    ev_set_tick(b, tick_at, &ts);
    int wb = ev_run_series(b, &sb, NULL);
    CHECK(wb == EV_STOP_INTERRUPT, "%s: the tick did not stop the run (%d)", what, wb);
    CHECK(b->events < a->events && b->iv_open, "%s: stopped too late or between rows", what);
    for (int round = 0; round < 2; round++) {
        CHECK(ev_checkpoint_write(b, &sb, dir, "test", err, sizeof err) == 0, "%s: write: %s", what, err);
        ev_free(b);
        ev_series_free(&sb);
        char path[300];
        snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
        b = ev_checkpoint_load(path, &sb, err, sizeof err);
        CHECK(b != NULL, "%s: load: %s", what, err);
        if (!b) break;
        ts.calls = 0;
        ts.at = round == 0 ? at : 0; /* round 0: stop again later; 1: run to the end */
        ev_set_tick(b, tick_at, &ts);
        wb = ev_run_series(b, &sb, NULL);
        if (round == 0) CHECK(wb == EV_STOP_INTERRUPT, "%s: second stop missed", what);
    }
    if (b) {
        CHECK(wa == wb, "%s: stop reasons %d and %d", what, wa, wb);
        same_state(what, a, b, &sa, &sb);
    }
    /* a damaged file is refused with one line */
    char path[300];
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    FILE *f = fopen(path, "r+b");
    if (f) {
        fseek(f, 0, SEEK_END);
        const long len = ftell(f);
        fseek(f, len / 2, SEEK_SET);
        for (int k = 0; k < 64; k++) fputc(0x5a, f);
        fclose(f);
        ev_series sc = {0};
        ev_sim *c = ev_checkpoint_load(path, &sc, err, sizeof err);
        CHECK(c == NULL && strchr(err, '\n') == NULL && strstr(err, "checkpoint"),
              "%s: a damaged checkpoint was loaded (%s)", what, c ? "" : err);
        ev_free(c);
    }
    snprintf(path, sizeof path, "rm -rf '%s'", dir);
    CHECK(system(path) == 0, "cleanup");
    ev_free(a);
    ev_free(b);
    ev_series_free(&sa);
    ev_series_free(&sb);
}

/* Seeds from a file (2D and 3D, three seeds each, one touching a wall):
 * the sticking checks of test_stick (every stuck particle touches its
 * parent, a seed or a stuck particle; energy bookkeeping; no overlap),
 * every seed of the file got particles, and a checkpoint resumes bit for bit. */
static void test_seeds(void)
{
    char dir[] = "/tmp/pdla-ev-seeds-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[300];
    for (int dim = 2; dim <= 3; dim++) {
        snprintf(path, sizeof path, "%s/seeds%d.txt", dir, dim);
        FILE *f = fopen(path, "w");
        if (!f) abort();
        if (dim == 2) fputs("# x y r\n40 40 1\n80 80 2\n0.5 80 0.5\n", f);
        else fputs("6 6 6 1\n13 13 13 1.5\n6 13 0.5 0.5  # on the z = 0 wall\n", f);
        fclose(f);
        stick_seeds = path;
        test_stick(dim, 0.05, 1);
        stick_seeds = NULL;
        ev_params q = base(dim, 600, 0.05, 0, 0.5, 1);
        snprintf(q.seeds, sizeof q.seeds, "%s", path);
        q.t_max = 0;
        char err[300];
        ev_sim *s = ev_create(&q, err, sizeof err);
        CHECK(s && s->nseeds == 3 && s->ntot == s->n + 3, "%dd: seeds: %s", dim, s ? "count" : err);
        if (!s) continue;
        CHECK(ev_run(s, NULL) == EV_STOP_ALL_STUCK, "%dd seeds: not all stuck", dim);
        int used[3] = {0, 0, 0};
        for (uint32_t k = 0; k < s->nstuck; k++) {
            uint32_t j = s->stuck_idx[k];
            for (uint32_t hop = 0; j < s->n && hop <= s->n; hop++) j = s->parent[j];
            if (j >= s->n && j < s->ntot) used[j - s->n] = 1;
        }
        CHECK(used[0] && used[1] && used[2], "%dd: a seed got no particle (%d %d %d)", dim, used[0],
              used[1], used[2]);
        ev_free(s);
        if (dim == 2) {
            q.series_dt = 3;
            q.stick_p = 0.5;
            resume_case("2d seeds", q, 5);
        }
    }
    snprintf(path, sizeof path, "rm -rf '%s'", dir);
    CHECK(system(path) == 0, "cleanup");
}

/* The seed overlap check (ev_seeds_check: a grid with the 64 biggest seeds
 * apart) against all pairs, the old check: the same first overlapping pair
 * (the message names it) or none, over 2400 random sets in 2D and 3D,
 * periodic and between walls, of 2-700 seeds: equal radii, radii spread
 * over two decades, and a few seeds far bigger than the rest, at densities
 * from none to many overlaps; seeds on the box's faces and at the periodic
 * seam included. Then 1e5 touching seeds on a lattice (every neighbour at
 * exactly the sum of the radii: no overlap) are accepted. */
static int brute_first(const ev_sim *s, uint32_t *pa, uint32_t *pb)
{
    const int D = s->dim;
    for (uint32_t a = 0; a < s->nseeds; a++)
        for (uint32_t b = a + 1; b < s->nseeds; b++) {
            const double *p = s->seed_xr + (size_t)a * (D + 1), *q = s->seed_xr + (size_t)b * (D + 1);
            const double sig = p[D] + q[D];
            if (ev_dist2(s, p, q) < sig * sig) {
                *pa = a;
                *pb = b;
                return 1;
            }
        }
    return 0;
}

static void test_seeds_overlap(void)
{
    ev_sim *s = calloc(1, sizeof *s);
    CHECK(s != NULL, "calloc");
    if (!s) return;
    snprintf(s->par.seeds, sizeof s->par.seeds, "forged");
    s->par.t_max = 1; /* no reach check: a plain gas may have any seeds */
    pdla_rng st = {{0x9e3779b97f4a7c15u, 12345, 0xdeadbeef, 7}};
    int found = 0, runs = 0;
    for (int it = 0; it < 2400; it++) {
        const int D = 2 + it % 2, kind = it / 2 % 3;
        s->dim = D;
        s->periodic = it / 6 % 2;
        s->L = 100.0;
        s->half = s->L / 2;
        const uint32_t n = 2 + (uint32_t)(rng_uniform(&st) * (it % 5 == 4 ? 700 : 120));
        const double r0 = (0.2 + 3.0 * rng_uniform(&st)) * (D == 2 ? 1.0 : 2.0);
        s->nseeds = n;
        s->seed_xr = malloc((size_t)n * (D + 1) * sizeof(double));
        if (!s->seed_xr) abort();
        for (uint32_t i = 0; i < n; i++) {
            double *x = s->seed_xr + (size_t)i * (D + 1);
            double r = kind == 0 ? r0 : kind == 1 ? r0 * pow(10.0, -2.0 * rng_uniform(&st)) : r0;
            if (kind == 2 && rng_uniform(&st) < 0.05) r = r0 * (5 + 20 * rng_uniform(&st));
            if (r > 0.45 * s->L) r = 0.45 * s->L;
            x[D] = r;
            const double lo = s->periodic ? 0 : r, hi = s->periodic ? s->L : s->L - r;
            for (int k = 0; k < D; k++) {
                const double u = rng_uniform(&st);
                /* one coordinate in 8 on a face (walls) or the seam (periodic) */
                x[k] = u < 0.0625 ? lo : u < 0.125 && !s->periodic ? hi
                       : u < 0.125 ? s->L * (1 - 1e-15) : lo + (hi - lo) * rng_uniform(&st);
            }
        }
        char err[600];
        uint32_t a = 0, b = 0;
        const int want = brute_first(s, &a, &b);
        char msg[128];
        snprintf(msg, sizeof msg, "--seeds forged: seeds %u and %u overlap", a + 1, b + 1);
        const int rc = ev_seeds_check(s, err, sizeof err);
        CHECK(want ? rc != 0 && !strcmp(err, msg) : rc == 0,
              "seeds-overlap %d (%dd, %s, kind %d, %u seeds): all pairs say %s, the check says %s", it, D,
              s->periodic ? "periodic" : "walls", kind, n, want ? msg : "none", rc ? err : "none");
        found += want;
        runs++;
        free(s->seed_xr);
        s->seed_xr = NULL;
    }
    CHECK(found > runs / 5 && found < runs * 4 / 5, "seeds-overlap: %d of %d sets overlap (want both kinds)",
          found, runs);
    /* 1e5 seeds of radius 0.5 touching on a 2D lattice of spacing 1 */
    s->dim = 2;
    s->periodic = 1;
    s->L = 317;
    s->half = s->L / 2;
    s->nseeds = 100000;
    s->seed_xr = malloc((size_t)s->nseeds * 3 * sizeof(double));
    if (!s->seed_xr) abort();
    for (uint32_t i = 0; i < s->nseeds; i++) {
        s->seed_xr[3 * i] = i % 316 + 0.5;
        s->seed_xr[3 * i + 1] = i / 316 + 0.5;
        s->seed_xr[3 * i + 2] = 0.5;
    }
    char err[600];
    CHECK(ev_seeds_check(s, err, sizeof err) == 0, "1e5 touching seeds refused: %s", err);
    free(s->seed_xr);
    free(s);
}

static void test_resume(void)
{
    /* 2D sticking with p = 0.5 (the RNG is part of the state), elastic walls */
    ev_params q = base(2, 3000, 0.1, 0, 1, 0.5);
    q.t_max = 0;
    q.series_dt = 3;
    resume_case("2d stick", q, 5);
    /* 3D periodic gas, series rows longer than a tick */
    q = base(3, 4000, 0.3, 1, 0, 1);
    q.t_max = 6;
    q.series_dt = 1;
    resume_case("3d gas", q, 3);
}

/* ---- series thinning ------------------------------------------------------ */
/* README, cluster.h5: beyond 65536 rows neighbouring rows of /series are
 * merged in pairs and the interval doubles. One 2D run to t = 14000.03
 * (280000 intervals of the first series_dt 0.05, three thinnings; 133305
 * intervals run as the interval doubles, 5-6 collisions each at first): 60
 * bath disks and 40 sticky ones (stick_p 0.0005, so the stuck count and the
 * free kinetic energy change all through the run) around a seed, periodic.
 * The run must reach t_max, so not every sticky disk may stick: with seeds
 * 1-12 of these parameters 3-18 of the 40 stuck (with 20 sticky ones at
 * stick_p 0.003, as until session 15, all 20 stuck for one seed of 6);
 * t_max is off the grid (the last row is short). The row count, seen by the
 * tick (at the start of each interval with an event), reaches 65536 and
 * never more; times go from 0 to
 * t_max, strictly increasing, spaced by the final interval (8 x 0.05). A
 * reference run from the same start, stepped by the same intervals and
 * keeping every row (never thinned), gives each row: its time is one of the
 * reference's interval ends; stuck, kinetic energy and the cumulative
 * collision count are the reference's at that end (snapshots, bit for
 * bit); its pressure is the mean over its span of the reference's rows
 * (weighted by their intervals, rel. 1e-9). Until this test the unpaired
 * row of a full series was dropped, and the next row's pressure covered
 * half its span (15% off here). Then a run stopped mid-interval before the
 * first thinning and after it, checkpointed and resumed each time, ends
 * bit-identical (state and series) to the run never stopped. 3 s release,
 * 9 s under ASan + UBSan. */
enum { THIN_MAX = 65536 };
typedef struct thin_watch { const ev_series *ser; size_t max_rows; } thin_watch;
static int thin_tick(ev_sim *s, void *u)
{
    (void)s;
    thin_watch *w = u;
    if (w->ser->n > w->max_rows) w->max_rows = w->ser->n;
    return 0;
}

static void test_thin(void)
{
    ev_params q = base(2, 1, 0.3, 1, 0.5, 0.003);
    strcpy(q.species, "60:0.5:1:0,40:0.5:1");
    q.stick_p = 0.0005;
    q.series_dt = 0.05;
    q.t_max = 14000.03; /* thinnings near t = 3277, 6554, 13107 */
    const double dt0 = q.series_dt;
    char err[512];
    ev_series sa = {0};
    ev_sim *a = ev_create(&q, err, sizeof err);
    CHECK(a != NULL, "thin: %s", err);
    if (!a) return;
    thin_watch tw = {&sa, 0};
    ev_set_tick(a, thin_tick, &tw); /* sees the row count after (nearly) every push */
    const int wa = ev_run_series(a, &sa, NULL);
    CHECK(wa == EV_STOP_TIME, "thin: stop %s", ev_stop_name(wa));
    const size_t n = sa.n;
    CHECK(a->series_dt == 8 * dt0, "thin: the interval is %.17g, not 8 x %g (three thinnings)", a->series_dt,
          dt0);
    CHECK(tw.max_rows == THIN_MAX && n <= THIN_MAX && n > THIN_MAX / 2,
          "thin: rows at most %zu during the run, %zu at the end (limit %d)", tw.max_rows, n, THIN_MAX);
    CHECK(a->nstuck >= 2 && a->nstuck < 40, "thin: %u stuck (sticking should go on all run)", a->nstuck);
    /* times: from 0, strictly increasing, spaced by the final (8x) interval,
     * the last row short and at t_max */
    size_t bad_t = 0, first_bad = 0;
    for (size_t j = 1; j < n; j++) {
        const double d = sa.t[j] - sa.t[j - 1];
        const int ok = d > 0 && (j + 1 == n ? d <= a->series_dt * (1 + 1e-9)
                                            : fabs(d - a->series_dt) <= 1e-9 * a->series_dt);
        if (!ok && !bad_t++) first_bad = j;
    }
    CHECK(n > 1 && sa.t[0] == 0 && sa.t[n - 1] == q.t_max && sa.t[n - 1] - sa.t[n - 2] < a->series_dt,
          "thin: rows span %.17g..%.17g", sa.t[0], n ? sa.t[n - 1] : 0);
    CHECK(!bad_t, "thin: %zu rows not spaced by %g, first row %zu (%.17g after %.17g)", bad_t, a->series_dt,
          first_bad, sa.t[first_bad], sa.t[first_bad ? first_bad - 1 : 0]);
    CHECK(n && sa.collisions[n - 1] == a->collisions && sa.stuck[n - 1] == a->nstuck,
          "thin: last row collisions %llu stuck %llu, run %llu %u", (unsigned long long)sa.collisions[n - 1],
          (unsigned long long)sa.stuck[n - 1], (unsigned long long)a->collisions, a->nstuck);

    /* the reference: ev_run_series's intervals (t1 = t0 + dt, cut at t_max)
     * with every row kept; its interval doubles where the series' row count
     * reaches THIN_MAX (then half of it is left, plus the new row). */
    ev_sim *r = ev_create(&q, err, sizeof err);
    CHECK(r != NULL, "thin: reference: %s", err);
    if (!r) return;
    size_t cap = 1 << 19, m = 0, rows = 1;
    double *rt = malloc(cap * sizeof *rt), *rke = malloc(cap * sizeof *rke), *rp = malloc(cap * sizeof *rp);
    uint64_t *rst = malloc(cap * sizeof *rst), *rco = malloc(cap * sizeof *rco);
    if (!rt || !rke || !rp || !rst || !rco) abort();
    double d = dt0;
    ev_stats st;
    ev_get_stats(r, &st);
    rt[0] = st.t, rke[0] = st.ke_free, rp[0] = NAN, rst[0] = st.stuck, rco[0] = st.collisions, m = 1;
    for (;;) {
        const double t0 = r->now, v0 = r->virial;
        double t1 = t0 + d;
        if (t1 > q.t_max) t1 = q.t_max;
        const int why = ev_loop(r, t1, NULL);
        if (!why) r->now = t1;
        if (m == cap) abort();
        ev_get_stats(r, &st);
        rt[m] = st.t, rke[m] = st.ke_free, rst[m] = st.stuck, rco[m] = st.collisions;
        rp[m] = ev_pressure(r, r->virial - v0, r->now - t0);
        m++;
        if (rows == THIN_MAX) rows = THIN_MAX / 2, d *= 2;
        rows++;
        if (why || r->now >= q.t_max) break;
    }
    CHECK(m > 130000 && rows == n, "thin: reference %zu intervals, %zu rows (series %zu)", m - 1, rows, n);
    /* each row against the reference intervals it covers */
    size_t k = 1, bad_grid = 0, bad_snap = 0, bad_p = 0, fg = 0, fs = 0, fe = 0, fp = 0;
    double worst = 0;
    CHECK(n && rke[0] == sa.ke[0] && rco[0] == sa.collisions[0] && rst[0] == sa.stuck[0] &&
              isnan(sa.pressure[0]),
          "thin: the first row is not the start");
    for (size_t j = 1; j < n && k < m; j++) {
        double pt = 0, tt = 0;
        for (; k < m && rt[k] <= sa.t[j]; k++) {
            pt += rp[k] * (rt[k] - rt[k - 1]);
            tt += rt[k] - rt[k - 1];
        }
        const size_t e = k - 1; /* the reference row at the series row's end */
        if (rt[e] != sa.t[j] || !tt) {
            if (!bad_grid++) fg = j;
            continue;
        }
        if (rke[e] != sa.ke[j] || rst[e] != sa.stuck[j] || rco[e] != sa.collisions[j])
            if (!bad_snap++) fs = j, fe = e;
        const double want = pt / tt, rel = fabs(sa.pressure[j] - want) / fabs(want);
        if (!(rel <= 1e-9) && !bad_p++) fp = j;
        if (rel > worst) worst = rel;
    }
    CHECK(!bad_grid && k == m, "thin: %zu rows not at a reference interval end (first %zu, t %.17g)",
          bad_grid, fg, sa.t[fg]);
    CHECK(!bad_snap, "thin: %zu rows' kinetic energy, stuck or collisions not the reference's at their end "
          "(first %zu, t %.17g: ke %.17g/%.17g)", bad_snap, fs, sa.t[fs], sa.ke[fs], rke[fe]);
    CHECK(!bad_p, "thin: %zu rows' pressure not the mean over their span (first %zu, t %.17g; worst rel. "
          "error %.3g)", bad_p, fp, sa.t[fp], worst);
    fprintf(stderr, "thin: %zu rows (%zu intervals run), interval %g, %u stuck, %llu collisions; pressure "
            "within %.3g of the reference\n", n, m - 1, a->series_dt, a->nstuck,
            (unsigned long long)a->collisions, worst);
    CHECK(r->collisions == a->collisions && r->nstuck == a->nstuck && r->events == a->events,
          "thin: the reference ran other events");
    free(rt), free(rke), free(rp), free(rst), free(rco);
    ev_free(r);

    /* stopped before the first thinning and after it, resumed each time */
    char dir[] = "/tmp/pdla-ev-thin-XXXXXX", path[300];
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    ev_series sb = {0};
    ev_sim *b = ev_create(&q, err, sizeof err);
    tick_stop ts = {0, 40000}; /* about one tick an interval: t ~ 2000 */
    for (int round = 0; b && round < 3; round++) {
        ev_set_tick(b, tick_at, &ts);
        const int wb = ev_run_series(b, &sb, NULL);
        if (round == 2) {
            CHECK(wb == wa, "thin: resumed run stops %s", ev_stop_name(wb));
            break;
        }
        CHECK(wb == EV_STOP_INTERRUPT && b->iv_open, "thin: stop %d missed (%s)", round, ev_stop_name(wb));
        CHECK(round ? b->series_dt == 2 * dt0 : b->series_dt == dt0 && sb.n < THIN_MAX,
              "thin: stop %d at t %g with %zu rows, interval %g: not %s the first thinning", round, b->now,
              sb.n, b->series_dt, round ? "after" : "before");
        CHECK(ev_checkpoint_write(b, &sb, dir, "test", err, sizeof err) == 0, "thin: write: %s", err);
        ev_free(b);
        ev_series_free(&sb);
        b = ev_checkpoint_load(path, &sb, err, sizeof err);
        CHECK(b != NULL, "thin: load: %s", err);
        ts.calls = 0;
        ts.at = round == 0 ? 40000 : 0; /* then t ~ 4000; then to the end */
    }
    if (b) same_state("thin resume", a, b, &sa, &sb);
    snprintf(path, sizeof path, "rm -rf '%s'", dir);
    CHECK(system(path) == 0, "cleanup");
    ev_free(a);
    ev_free(b);
    ev_series_free(&sa);
    ev_series_free(&sb);
}

/* ---- bath kinds (STICKY 0 in --species) ----------------------------------- */
/* A bath particle never sticks: it bounces off the seed and the stuck ones
 * as off an infinite mass (v -= 2 (v.r) r / r.r), which keeps its energy.
 * Counts the bounces off the cluster, by bath and by sticky particles. */
typedef struct bath_count {
    const ev_sim *s;
    uint64_t bath_bounce, bath_stick;
} bath_count;

static void bath_rec(const ev_trace_event *e, void *u)
{
    bath_count *c = u;
    const ev_sim *s = c->s;
    if (e->kind == EV_EV_WALL || e->i >= s->n) return;
    const int bath_i = !ev_species_sticky(s, ev_species_of(s, e->i));
    if (e->kind == EV_EV_STICK && bath_i) c->bath_stick++;
    /* a pair event with a seed or a stuck particle: i is the free one */
    if (e->kind == EV_EV_PAIR && bath_i && (e->j >= s->n || s->stuck[e->j])) c->bath_bounce++;
}

/* A bath alone around a big seed (a small box, so that many collisions are
 * with the seed): nothing sticks, the energy stays to round-off over >= 1e5
 * collisions of which >= 5000 off the infinite-mass seed (same tolerance
 * as `conserve`: ~1e-16 per collision as a random walk), no overlap beyond
 * TOL. Two bath kinds of different mass, elastic walls. */
static void test_bath_alone(int dim)
{
    ev_params q = base(dim, 1, dim == 2 ? 0.3 : 0.2, 0, dim == 2 ? 5 : 2.5, 1);
    strcpy(q.species, dim == 2 ? "150:0.5:1:0,50:0.6:3:0" : "300:0.5:1:0,100:0.45:3:0");
    q.start = EV_START_LATTICE;
    q.t_max = dim == 2 ? 400 : 75;
    char err[256];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "bath alone %dd: %s", dim, err);
    if (!s) return;
    CHECK(s->has_bath && s->nsticky == 0 && !s->nfree_total, "bath alone %dd: flags", dim);
    bath_count c = {s, 0, 0};
    ev_set_trace(s, bath_rec, &c);
    ev_stats a, b;
    ev_get_stats(s, &a);
    double worst = ev_max_overlap_now(s);
    int why = 0;
    for (int k = 1; k <= 10; k++) {
        s->par.t_max = q.t_max * k / 10;
        why = ev_run(s, NULL);
        const double ov = ev_max_overlap_now(s);
        if (ov > worst) worst = ov;
    }
    ev_get_stats(s, &b);
    const double de = fabs(b.ke_free - a.ke_free) / a.ke_free;
    fprintf(stderr, "bath alone %dd: %llu collisions, %llu off the seed, dE/E %.3g, overlap %.3g/%.3g, %s\n",
            dim, (unsigned long long)b.collisions, (unsigned long long)c.bath_bounce, de, worst,
            b.max_overlap, ev_stop_name(why));
    CHECK(why == EV_STOP_TIME && b.stuck == 0 && c.bath_stick == 0, "bath alone %dd: something stuck", dim);
    CHECK(b.collisions > 100000 && c.bath_bounce > 5000, "bath alone %dd: too few collisions", dim);
    CHECK(de < 1e-11, "bath alone %dd: energy drift %g", dim, de);
    CHECK(worst < TOL && b.max_overlap < TOL, "bath alone %dd: overlap %g / %g", dim, worst, b.max_overlap);
    ev_free(s);
}

/* Sticky kinds in a bath, run to the end: every sticky particle stuck and
 * no bath one ("all stuck"), the bath bounced off the cluster, the energy
 * bookkeeping of `stick` (free + carried away = start, to round-off: the
 * bath's bounces keep energy), contacts, no overlap with the cluster. */
static void test_bath_stick(int dim, double p)
{
    ev_params q = base(dim, 1, 0.2, 0, 0.5, p);
    strcpy(q.species, dim == 2 ? "150:0.5:1,500:0.5:1:0,150:0.35:4:0" : "120:0.5:1,500:0.5:1:0");
    q.t_max = 0;
    char err[256];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "bath stick %dd: %s", dim, err);
    if (!s) return;
    bath_count c = {s, 0, 0};
    ev_set_trace(s, bath_rec, &c);
    ev_stats a, b;
    ev_get_stats(s, &a);
    double worst = ev_max_overlap_now(s);
    int why = 0;
    for (int k = 1; k <= 20 && why != EV_STOP_ALL_STUCK; k++) {
        s->par.max_stuck = s->nsticky * (uint64_t)k / 20;
        why = ev_run(s, NULL);
        const double ov = ev_max_overlap_now(s);
        if (ov > worst) worst = ov;
    }
    ev_get_stats(s, &b);
    uint32_t bath_stuck = 0, sticky_free = 0;
    double worst_touch = 0;
    for (uint32_t i = 0; i < s->n; i++) {
        const int sticky = ev_species_sticky(s, ev_species_of(s, i));
        bath_stuck += !sticky && s->stuck[i];
        sticky_free += sticky && !s->stuck[i];
    }
    for (uint32_t k = 0; k < s->nstuck; k++) {
        const uint32_t i = s->stuck_idx[k], j = s->parent[i];
        worst_touch = fmax(worst_touch, contact_gap(s, i, j, dim));
    }
    const double de = fabs(b.ke_free + b.ke_stuck - a.ke_free) / a.ke_free;
    fprintf(stderr, "bath stick %dd p %.1f: stuck %llu of %u sticky (%s), bath bounces off the cluster "
            "%llu, dE/E %.3g, contact gap %.3g, overlap %.3g\n", dim, p, (unsigned long long)b.stuck,
            s->nsticky, ev_stop_name(why), (unsigned long long)c.bath_bounce, de, worst_touch, worst);
    CHECK(why == EV_STOP_ALL_STUCK && b.stuck == s->nsticky && sticky_free == 0,
          "bath stick %dd: not all sticky ones stuck (%s)", dim, ev_stop_name(why));
    CHECK(bath_stuck == 0 && c.bath_stick == 0, "bath stick %dd: %u bath particles stuck", dim, bath_stuck);
    CHECK(c.bath_bounce > 1000, "bath stick %dd: only %llu bath bounces off the cluster", dim,
          (unsigned long long)c.bath_bounce);
    CHECK(b.ke_free > 0.5 * a.ke_free, "bath stick %dd: the bath lost its energy", dim);
    CHECK(de < 1e-11, "bath stick %dd: energy bookkeeping %g", dim, de);
    CHECK(worst_touch < TOL, "bath stick %dd: stuck particle off its parent by %g", dim, worst_touch);
    CHECK(worst < TOL && b.max_overlap < TOL, "bath stick %dd: overlap %g / %g", dim, worst, b.max_overlap);
    ev_free(s);
}

/* STICKY given as 1 everywhere is the list without it, bit for bit. */
static void test_bath_same(void)
{
    ev_sim *s[2];
    for (int r = 0; r < 2; r++) {
        ev_params q = base(2, 1, 0.1, 0, 1, 0.5);
        strcpy(q.species, r ? "300:0.5:1:1,200:0.4:2:1" : "300:0.5:1,200:0.4:2");
        q.t_max = 0;
        s[r] = ev_create(&q, NULL, 0);
        CHECK(s[r] != NULL, "create");
        if (!s[r]) return;
        CHECK(ev_run(s[r], NULL) == EV_STOP_ALL_STUCK, "not all stuck");
    }
    const ev_sim *a = s[0], *b = s[1];
    CHECK(!a->has_bath && !b->has_bath && a->nsticky == a->n, "STICKY 1 made a bath");
    CHECK(a->events == b->events && a->nstuck == b->nstuck &&
              !memcmp(a->ps, b->ps, a->ntot * (size_t)(2 * a->dim + 2) * sizeof(double)) &&
              !memcmp(a->stuck_t, b->stuck_t, a->nstuck * sizeof *a->stuck_t),
          "STICKY 1 changed the history (events %llu/%llu)", (unsigned long long)a->events,
          (unsigned long long)b->events);
    ev_free(s[0]);
    ev_free(s[1]);
}

static void test_bath_params(void)
{
    char err[256];
    ev_params p;
    static const char *const bad[] = {"10:0.5:1:2", "10:0.5:1:", "10:0.5:1:01", "10:0.5:1:1x",
                                      "10:0.5:1:-1", "10:0.5:1:0:1", NULL};
    for (int k = 0; bad[k]; k++) {
        ev_params_default(&p);
        strcpy(p.species, bad[k]);
        err[0] = 0;
        CHECK(ev_params_check(&p, err, sizeof err) < 0 && strstr(err, "--species") && !strchr(err, '\n'),
              "--species %s accepted (%s)", bad[k], err);
    }
    ev_params_default(&p);
    strcpy(p.species, "10:0.5:1,20:0.5:1:0,5:0.4:2:1");
    ev_species sp[EV_MAX_SPECIES];
    int n = 0;
    CHECK(ev_parse_species(&p, sp, &n, err, sizeof err) == 0 && n == 3 && sp[0].sticky == 1 &&
              sp[1].sticky == 0 && sp[2].sticky == 1 && sp[2].density == 2,
          "--species with STICKY: %s", err);
    /* nothing sticky: a stop by time or events is needed, --max-stuck refused */
    ev_params_default(&p);
    strcpy(p.species, "100:0.5:1:0");
    CHECK(ev_params_check(&p, err, sizeof err) < 0 && strstr(err, "STICKY 0"), "all bath, no end: %s", err);
    p.t_max = 5;
    CHECK(ev_params_check(&p, err, sizeof err) == 0, "all bath with --t-max refused: %s", err);
    p.max_stuck = 3;
    CHECK(ev_params_check(&p, err, sizeof err) < 0 && strstr(err, "max-stuck"), "all bath --max-stuck: %s", err);
    /* --max-stuck below the sticky count stops there; above it, all stuck */
    ev_params q = base(2, 1, 0.1, 0, 1, 1);
    strcpy(q.species, "40:0.5:1,200:0.5:1:0");
    q.t_max = 0;
    q.max_stuck = 10;
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s && ev_run(s, NULL) == EV_STOP_STUCK && s->nstuck == 10, "--max-stuck 10 in a bath");
    if (s) s->par.max_stuck = 1000;
    CHECK(s && ev_run(s, NULL) == EV_STOP_ALL_STUCK && s->nstuck == 40, "--max-stuck 1000 in a bath");
    ev_free(s);
}

/* A checkpoint written by main 999a772 (before STICKY existed: 40 + 30
 * particles, p = 0.5, stopped at event 2000, tests/event/data) loads as
 * all sticky and runs on to the same end, bit for bit, as a fresh run of
 * its parameters by this code. */
static void test_bath_oldckpt(const char *path)
{
    char err[512];
    ev_series sa = {0}, sb = {0};
    ev_sim *b = ev_checkpoint_load(path, &sb, err, sizeof err);
    CHECK(b != NULL, "old checkpoint %s: %s", path, err);
    if (!b) return;
    CHECK(b->events == 2000 && !b->has_bath && b->nsticky == b->n && b->n == 70 &&
              ev_species_sticky(b, 0) && ev_species_sticky(b, 1),
          "old checkpoint: not all sticky (events %llu, sticky %u of %u)", (unsigned long long)b->events,
          b->nsticky, b->n);
    ev_params q = *ev_params_of(b);
    q.max_events = 0;
    b->par.max_events = 0;
    ev_sim *a = ev_create(&q, err, sizeof err);
    CHECK(a != NULL, "fresh run: %s", err);
    if (a) {
        const int wa = ev_run_series(a, &sa, NULL), wb = ev_run_series(b, &sb, NULL);
        fprintf(stderr, "old checkpoint: resumed %s at %llu events, fresh %s at %llu, stuck %u/%u\n",
                ev_stop_name(wb), (unsigned long long)b->events, ev_stop_name(wa),
                (unsigned long long)a->events, b->nstuck, a->nstuck);
        CHECK(wa == EV_STOP_ALL_STUCK && wb == wa && a->nstuck == a->n && b->nstuck == a->nstuck &&
                  a->events == b->events && a->collisions == b->collisions &&
                  !memcmp(a->ps, b->ps, a->ntot * (size_t)(2 * a->dim + 2) * sizeof(double)) &&
                  !memcmp(a->stuck_idx, b->stuck_idx, a->nstuck * sizeof *a->stuck_idx) &&
                  !memcmp(a->stuck_t, b->stuck_t, a->nstuck * sizeof *a->stuck_t) &&
                  !memcmp(&a->rng, &b->rng, sizeof a->rng),
              "old checkpoint: the resumed run is not the fresh one");
    }
    ev_free(a);
    ev_free(b);
    ev_series_free(&sa);
    ev_series_free(&sb);
}

static void test_bath(void)
{
    test_bath_params();
    test_bath_same();
    test_bath_alone(2);
    test_bath_alone(3);
    test_bath_stick(2, 1);
    test_bath_stick(2, 0.3);
    test_bath_stick(3, 1);
}

/* The engine against the brute force with a bath (p = 0.5: the RNG is
 * drawn for sticky contacts only), and a checkpoint mid-run with a bath. */
static void test_bath_brute(void)
{
    ev_params q = base(2, 1, 0.2, 0, 1.0, 0.5);
    strcpy(q.species, "60:0.5:1,240:0.5:1:0");
    q.max_events = 60000; /* cell crossings included: ~27000 traced events */
    cmp_brute("2d bath + sticky p=0.5", q, 20000, 1, 0);
    q = base(3, 1, 0.15, 0, 1.0, 1);
    strcpy(q.species, "50:0.5:1,200:0.45:2:0");
    q.max_events = 100000;
    cmp_brute("3d bath + sticky p=1", q, 20000, 1, 0);
    /* a checkpoint mid-run resumes bit for bit with a bath */
    q = base(2, 1, 0.2, 0, 1, 0.5);
    strcpy(q.species, "400:0.5:1,2000:0.5:1:0");
    q.t_max = 300;
    q.series_dt = 3;
    resume_case("2d bath", q, 5);
}

/* Random placement against its definition: a reference that draws one
 * position at a time from the same generator and tests it against every
 * particle placed so far (no cells, no map, no batches), with the engine's
 * arithmetic. ev_create (cells, the bit map of covered cubes, batched
 * draws) must place the same particles at the same positions, bit for bit,
 * and leave the generator at the same state; the cases run near jamming
 * (most positions refused by the map), with walls, a seed and two radii.
 * The engine renumbers the particles by cell afterwards, so the two sets
 * are compared sorted. */
static int place_row_cmp(const void *a, const void *b)
{
    const double *x = a, *y = b;
    for (int k = 0; k < 4; k++)
        if (x[k] != y[k]) return x[k] < y[k] ? -1 : 1;
    return 0;
}

static int place_ref_overlaps(const ev_sim *s, uint32_t n_placed, const double *x, double r)
{
    const int D = s->dim;
    for (uint32_t a = 0; a < s->ntot; a++) {
        if (a >= n_placed && a < s->n) continue;
        const double *pj = EV_P(s, a);
        double rr = 0;
        for (int k = 0; k < D; k++) {
            double d = pj[k] - x[k];
            if (s->periodic) {
                if (d > s->half) d -= s->L;
                else if (d < -s->half) d += s->L;
            }
            rr += d * d;
        }
        const double sig = r + pj[2 * D + 1];
        if (rr < sig * sig) return 1;
    }
    return 0;
}

static void place_case(const char *what, ev_params q, double min_tries)
{
    char err[256];
    q.start = EV_START_RANDOM;
    ev_sim *ref = ev_alloc(&q, err, sizeof err);
    CHECK(ref != NULL, "%s: %s", what, err);
    if (!ref) return;
    const int D = ref->dim;
    uint64_t tries = 0;
    uint32_t fail = UINT32_MAX; /* the particle the reference cannot place */
    for (uint32_t i = 0; i < ref->n && fail == UINT32_MAX; i++) {
        const double r = EV_P(ref, i)[2 * D + 1];
        for (int a = 0;; a++) {
            if (a == 10000) {
                fail = i;
                break;
            }
            double x[3];
            for (int k = 0; k < D; k++)
                x[k] = ref->periodic ? rng_uniform(&ref->rng) * ref->L
                                     : r + rng_uniform(&ref->rng) * (ref->L - 2 * r);
            tries++;
            if (!place_ref_overlaps(ref, i, x, r)) {
                memcpy(EV_P(ref, i), x, (size_t)D * sizeof *x);
                break;
            }
        }
    }
    /* the engine's generator after placement = the velocities' first draw */
    q.velocities = EV_VEL_FIXED;
    ev_sim *s = ev_create(&q, err, sizeof err);
    if (fail != UINT32_MAX) {
        /* jammed: the engine must give up on the same particle, in one line */
        char want[64];
        snprintf(want, sizeof want, "cannot place particle %u of %u ", fail + 1, ref->n);
        printf("place %s: reference jams at particle %u; engine: %s\n", what, fail + 1, s ? "placed" : err);
        CHECK(!s && strstr(err, want) && !strchr(err, '\n'), "%s: want \"%s\", got %s", what, want, s ? "placed" : err);
        ev_free(s);
        ev_free(ref);
        return;
    }
    CHECK(s != NULL, "%s: %s", what, err);
    if (!s) return;
    double *ra = calloc((size_t)ref->n * 4, sizeof *ra), *sa = calloc((size_t)ref->n * 4, sizeof *sa);
    for (uint32_t i = 0; i < ref->n; i++)
        for (int k = 0; k < 4; k++) {
            const int f = k < D ? k : k == 3 ? 2 * D + 1 : -1;
            ra[4 * i + k] = f < 0 ? 0 : EV_P(ref, i)[f];
            sa[4 * i + k] = f < 0 ? 0 : EV_P(s, i)[f];
        }
    qsort(ra, ref->n, 4 * sizeof *ra, place_row_cmp);
    qsort(sa, ref->n, 4 * sizeof *sa, place_row_cmp);
    const int same = !memcmp(ra, sa, (size_t)ref->n * 4 * sizeof *ra);
    /* the engine's first velocity draw comes from the state after placement */
    double u[3], uu;
    pdla_rng g = ref->rng;
    do {
        uu = 0;
        for (int k = 0; k < D; k++) {
            u[k] = 2 * rng_uniform(&g) - 1;
            uu += u[k] * u[k];
        }
    } while (uu > 1 || uu < 1e-12);
    uint32_t hits = 0;
    for (uint32_t i = 0; i < s->n; i++) {
        const double *p = EV_P(s, i);
        const double f = sqrt(2 * q.kT / ev_mass(s, i)) / sqrt(uu);
        int eq = 1;
        for (int k = 0; k < D; k++) eq &= p[D + k] == f * u[k];
        hits += eq;
    }
    printf("place %s: %u particles, %.1f tries per particle, positions %s, first velocity found %u times\n",
           what, ref->n, (double)tries / ref->n, same ? "identical" : "DIFFER", hits);
    CHECK(same, "%s: placement differs from the reference", what);
    CHECK(hits == 1, "%s: generator state after placement differs (%u)", what, hits);
    CHECK((double)tries / ref->n >= min_tries, "%s: %.1f tries per particle, the case does not reach jamming",
          what, (double)tries / ref->n);
    free(ra), free(sa);
    ev_free(s);
    ev_free(ref);
}

static void test_place(void)
{
    ev_params q = base(3, 3000, 0.3, 1, 0, 1);
    q.seed = 3;
    place_case("3d periodic 0.3", q, 5);
    q = base(2, 3000, 0.45, 0, 3, 1);
    q.seed = 4;
    place_case("2d walls 0.45 seed", q, 5);
    q = base(3, 1, 0.25, 0, 1, 1);
    strcpy(q.species, "500:0.8:1,1500:0.5:1");
    q.seed = 5;
    place_case("3d walls two radii seed", q, 3);
    q = base(2, 1, 0.4, 1, 0, 1);
    strcpy(q.species, "300:0.9:1,2000:0.3:1");
    q.seed = 6;
    place_case("2d periodic two radii", q, 3);
    /* the big ones last: they no longer fit */
    q = base(3, 1, 0.25, 0, 1, 1);
    strcpy(q.species, "1500:0.5:1,500:0.8:1");
    q.seed = 5;
    place_case("3d walls two radii jammed", q, 0);
    q = base(2, 1, 0.4, 1, 0, 1);
    strcpy(q.species, "2000:0.3:1,300:0.9:1");
    q.seed = 6;
    place_case("2d periodic two radii jammed", q, 0);
}

/* A periodic box of few cells: two spheres approaching along x from 0.1 and
 * 2.6 in a box of side 4.71 (3D, 2 particles, packing 0.01) are 2.5 apart,
 * more than half the box, so their nearest image at the start is through
 * the wrap, receding. Until session 14 they passed through each other: the
 * box had 3 cells a side, and the image was chosen at the pair's older
 * stored time, when they were that far apart. Closing at speed 2 from 2.5
 * to contact at 1, they must collide once (t = 0.75) before t = 1 and
 * never overlap; also in 2D (side 5.6); and a periodic box with under 4
 * cells of the contact distance a side is refused. Fails with the image
 * taken at max(t_i, t_j) (0 collisions in 3D), whatever the cells. */
static void test_periodic_few(void)
{
    for (int dim = 2; dim <= 3; dim++) {
        ev_params q = base(dim, 2, dim == 3 ? 0.01 : 0.05, 1, 0, 1);
        char err[256];
        ev_sim *s = ev_create(&q, err, sizeof err);
        CHECK(s != NULL, "%dd periodic few: %s", dim, err);
        if (!s) continue;
        CHECK(s->nc >= 4, "%dd periodic few: %d cells a side", dim, s->nc);
        for (uint32_t i = 0; i < 2; i++) {
            double *p = EV_P_ANY(s, i);
            for (int k = 0; k < 2 * dim; k++) p[k] = 0.5 * s->L;
            p[0] = i ? 2.6 : 0.1;
            p[dim] = i ? -1 : 1;
            for (int k = 1; k < dim; k++) p[dim + k] = 0;
            p[2 * dim] = 0;
        }
        CHECK(ev_rebuild(s) == 0, "rebuild");
        ev_loop(s, 1.0, NULL);
        const double ov = ev_max_overlap_now(s);
        fprintf(stderr, "%dd periodic few: side %g, %d cells, %llu collisions, overlap %g\n", dim, s->L, s->nc,
                (unsigned long long)s->collisions, ov);
        CHECK(s->collisions == 1 && ov < TOL, "%dd periodic few: %llu collisions, overlap %g", dim,
              (unsigned long long)s->collisions, ov);
        ev_free(s);
    }
    ev_params q = base(2, 3, 0.4, 1, 0, 1); /* side 2.4: under 4 cells of 1 */
    char err[256] = "";
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s == NULL && strstr(err, "under 4 cells"), "periodic box of under 4 cells: %s", s ? "accepted" : err);
    ev_free(s);
}

/* The image tie at a late clock: in a periodic box of 4 cells a side a
 * particle crossing the face x = 0 head-on towards the central seed is
 * exactly L/2 from it, and the approached image must be taken (ev_image).
 * Its separation then carries the round-off of its time, |v| epsilon t: at
 * t = 1e7 about 1e-9, 200 times the margin the tie was first given (64
 * epsilon of the box), so about half such crossings took the receding image,
 * never predicted the seed again and passed through it (3D, `--particles 20
 * --packing 1e-6 --box-walls periodic --seed 4`: 0.425 of a contact distance
 * deep at t = 1.3e6). Each start, at t = 0 and at 1e7, must stick with no
 * overlap by the time it would reach the seed's centre. */
static void test_periodic_tie_late(void)
{
    /* a pass-through is a deep overlap; at 1e7 a contact's round-off,
     * |v| epsilon t, is 1e-9 (README), beyond TOL but not this */
    const double OVER_LATE = 1e-6;
    for (int dim = 2; dim <= 3; dim++) {
        int missed = 0, runs = 0;
        for (int late = 0; late <= 1; late++)
            for (int a = 0; a < 24; a++) {
                ev_params q = base(dim, 1, dim == 3 ? 1e-4 : 0.04, 1, 0.5, 1);
                char err[256];
                ev_sim *s = ev_create(&q, err, sizeof err);
                CHECK(s != NULL, "%dd periodic tie late: %s", dim, err);
                if (!s) return;
                CHECK(s->nc == 4, "%dd periodic tie late: %d cells a side", dim, s->nc);
                const double t0 = late ? 1e7 : 0, v = 0.37 + 0.071 * a;
                double *p = EV_P_ANY(s, 0);
                for (int k = 0; k < dim; k++) p[k] = 0.5 * s->L, p[dim + k] = 0;
                p[0] = 0.013 * (a + 1); /* the face x = 0 crossed at t0 + p[0] / v */
                p[dim] = -v;
                p[2 * dim] = s->now = t0;
                CHECK(ev_rebuild(s) == 0, "rebuild");
                ev_loop(s, t0 + (p[0] + 0.5 * s->L) / v, NULL);
                const double ov = ev_max_overlap_now(s);
                missed += s->nstuck != 1 || !(ov < OVER_LATE);
                runs++;
                ev_free(s);
            }
        fprintf(stderr, "%dd periodic tie late: %d of %d crossings missed the seed\n", dim, missed, runs);
        CHECK(missed == 0, "%dd periodic tie late: %d of %d crossings missed the seed", dim, missed, runs);
    }
}

/* ---- grazes whose reflection is lost to round-off (issue 15) --------------
 * A pair touching by round-off (|r|^2 - sigma^2 <= 0) whose normal speed is
 * below the round-off of its velocities (a tangential relative velocity and
 * a normal part of -1e-17..-1e-20; r.v = -6.9e-18 at speeds 0.3) collides
 * "now", but the reflection -2 (r.v) r / r.r is below half an ulp of the
 * velocities and is lost: until session 31 the same collision fired at the
 * same instant until max_events (99,998 at t = 0; 58 of 2000 such starts of
 * two free spheres; a particle reflecting off the seed at p = 0). Now such a
 * pair is pushed apart (ev_core.c, recede): each start has at most one
 * event at t = 0, none overlaps, energy and momentum hold to round-off,
 * and the brute force, which has the same rule, gives the same events. */
static double gz_u(uint64_t *st) /* splitmix64: [0, 1) */
{
    uint64_t z = (*st += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return (double)((z ^ (z >> 31)) >> 11) * 0x1p-53;
}

/* Particle b touching a (|r| = 1 - 0..3 epsilon/2, sigma 1) at a random unit
 * normal n: vb = va + a tangential part (scale tan) + e n, e = -1e-17..-1e-20
 * times escale (approaching by far less than the velocities' round-off). */
static void gz_place(uint64_t *st, int D, const double *a, const double *va, double *b, double *vb,
                     double tan, double escale)
{
    double n[3] = {0, 0, 0}, t[3] = {0, 0, 0}, nn = 0, tn = 0;
    for (int k = 0; k < D; k++) n[k] = gz_u(st) - 0.5, nn += n[k] * n[k];
    if (escale < 0) n[0] = fabs(n[0]), escale = -escale; /* b on the side x > a */
    for (int k = 0; k < D; k++) n[k] /= sqrt(nn);
    for (int k = 0; k < D; k++) t[k] = tan * (gz_u(st) - 0.5), tn += t[k] * n[k];
    const double sh = 1 - 0x1p-53 * floor(4 * gz_u(st)), e = -escale * pow(10, -17 - 3 * gz_u(st));
    for (int k = 0; k < D; k++) {
        b[k] = a[k] + n[k] * sh;
        vb[k] = va[k] + (t[k] - tn * n[k]) + e * n[k];
    }
}

static void gz_count0(const ev_trace_event *e, void *u)
{
    *(int *)u += e->t == 0;
}

/* Run a placed start (t = 0) to t_end, bounded by 2000 events: the number
 * of events at t = 0, or 1000 if it looped until max_events. */
static int gz_run(ev_sim *s, double t_end, int keep_momentum, const char *what)
{
    double p0[3], p1[3], sc, sc1, dp = 0;
    int n0 = 0;
    if (ev_rebuild(s)) abort();
    momentum(s, p0, &sc);
    const double e0 = energy(s);
    ev_set_trace(s, gz_count0, &n0);
    ev_loop(s, t_end, NULL);
    if (s->events >= s->par.max_events) return 1000;
    momentum(s, p1, &sc1);
    for (int k = 0; k < s->dim; k++) dp = fmax(dp, fabs(p1[k] - p0[k]));
    const double ov = ev_max_overlap_now(s), de = fabs(energy(s) - e0);
    CHECK(ov < TOL, "%s: overlap %g", what, ov);
    CHECK(!keep_momentum || dp <= 4 * DBL_EPSILON * sc, "%s: momentum off by %g of %g", what, dp, sc);
    CHECK(de <= 8 * DBL_EPSILON * e0, "%s: energy off by %g of %g", what, de, e0);
    return n0;
}

/* Two free spheres (or disks) in a periodic box, touching and grazing:
 * speeds ~0.3 with a tangential relative velocity, or (co) co-moving at
 * speed ~co with only the normal part (they lose the change sooner). */
static void gz_free(int D, int nstart, double co, uint64_t st)
{
    int worst = 0, at0 = 0, rep = 0;
    for (int a = 0; a < nstart; a++) {
        ev_params q = base(D, 2, D == 3 ? 0.001 : 0.01, 1, 0, 1);
        q.max_events = 2000;
        ev_sim *s = ev_create(&q, NULL, 0);
        if (!s) abort();
        double *A = EV_P_ANY(s, 0), *B = EV_P_ANY(s, 1);
        for (int k = 0; k < D; k++) A[k] = 0.5 * s->L, A[D + k] = (co ? co : 1) * (gz_u(&st) - 0.5);
        gz_place(&st, D, A, A + D, B, B + D, co ? 0 : 1, co ? co : 1);
        A[2 * D] = B[2 * D] = 0;
        const int n0 = gz_run(s, co ? 200 : 1, 1, co ? "co-moving pair" : "free pair");
        worst = n0 > worst ? n0 : worst;
        at0 += n0 > 0;
        rep += n0 > 1;
        ev_free(s);
    }
    fprintf(stderr, "%dd %s grazes: %d of %d collided at t = 0, %d more than once (most: %d)\n", D,
            co ? "co-moving" : "free", at0, nstart, rep, worst);
    CHECK(worst <= 1, "%dd %s grazes: %d events at t = 0", D, co ? "co-moving" : "free", worst);
    CHECK(at0 > 0, "%dd %s grazes: none collided at t = 0 (the test lost its case)", D, co ? "co-moving" : "free");
}

/* One particle touching the seed (sigma 1), grazing, stick_p p: p = 0
 * reflects off the infinite mass, 0.5 reflects or sticks (until session 31
 * the loop drew until it stuck). */
static void gz_seed(int D, double p, int nstart, uint64_t st)
{
    int worst = 0, at0 = 0, rep = 0;
    for (int a = 0; a < nstart; a++) {
        ev_params q = base(D, 1, D == 3 ? 0.001 : 0.01, a & 1, 0.5, p);
        q.max_events = 2000;
        ev_sim *s = ev_create(&q, NULL, 0);
        if (!s) abort();
        double *P = EV_P_ANY(s, 0), *S = EV_P_ANY(s, 1), zero[3] = {0, 0, 0};
        gz_place(&st, D, S, zero, P, P + D, 1, 1);
        P[2 * D] = 0;
        const int n0 = gz_run(s, 1, 0, "seed graze");
        worst = n0 > worst ? n0 : worst;
        at0 += n0 > 0;
        rep += n0 > 1;
        ev_free(s);
    }
    fprintf(stderr, "%dd seed grazes, p = %g: %d of %d hit the seed at t = 0, %d more than once (most: %d)\n",
            D, p, at0, nstart, rep, worst);
    CHECK(worst <= 1, "%dd seed grazes p = %g: %d events at t = 0", D, p, worst);
    CHECK(at0 > 0, "%dd seed grazes p = %g: none at t = 0 (the test lost its case)", D, p);
}

/* The review's case (3D, 1 particle at packing 0.001, seed radius 0.5,
 * periodic, p = 0, start 629 of its sweep): |r|^2 - 1 = -5.6e-16, r.v =
 * -6.9e-18 at speed 0.38; 100,000 collisions at t = 0 until session 31. */
static void gz_review(void)
{
    ev_params q = base(3, 1, 0.001, 1, 0.5, 0);
    q.max_events = 2000;
    ev_sim *s = ev_create(&q, NULL, 0);
    if (!s) abort();
    CHECK(s->L == 8.0599597700823473 && s->nc == 4, "review case: box %.17g, %d cells", s->L, s->nc);
    double *P = EV_P_ANY(s, 0), *S = EV_P_ANY(s, 1);
    const double x[3] = {3.1020802849870095, 3.6955842440192774, 4.1948491892941995};
    const double v[3] = {0.13098384026428578, -0.21912147294792875, 0.29275666447060134};
    for (int k = 0; k < 3; k++) S[k] = 4.0299798850411737, P[k] = x[k], P[3 + k] = v[k];
    P[6] = 0;
    const int n0 = gz_run(s, 50, 0, "review case");
    fprintf(stderr, "review case: %d events at t = 0, %llu collisions by t = 50\n", n0,
            (unsigned long long)s->collisions);
    CHECK(n0 == 1, "review case: %d events at t = 0", n0);
    ev_free(s);
}

/* Two free particles in a walled box, the first in the middle with a random
 * velocity (at_wall: at the wall x = r instead, moving into it at 1e-20),
 * the second grazing it (gz_place; on the box's side of a wall particle). */
static ev_sim *gz_pair(int D, uint64_t *st, int at_wall)
{
    ev_params q = base(D, 2, D == 3 ? 0.01 : 0.05, 0, 0, 1);
    q.max_events = 2000;
    ev_sim *s = ev_create(&q, NULL, 0);
    if (!s) abort();
    double *A = EV_P_ANY(s, 0), *B = EV_P_ANY(s, 1);
    for (int k = 0; k < D; k++) A[k] = 0.5 * s->L, A[D + k] = gz_u(st) - 0.5;
    if (at_wall) A[0] = A[2 * D + 1], A[D] = -1e-20;
    gz_place(st, D, A, A + D, B, B + D, 1, at_wall ? -1 : 1);
    A[2 * D] = B[2 * D] = 0;
    return s;
}

/* A particle at the wall (x = r, its normal velocity -1e-20 into it) and a
 * free one touching it from the box's side, grazing: the wall sets the
 * sign of v (no loop of its own) and the pair is pushed apart; the push
 * sends the first into the wall again and so on, a short chain that ends
 * (at most 5 events at t = 0 in these starts) as the second recedes. */
static void gz_wall(int D, int nstart, uint64_t st)
{
    int worst = 0, at0 = 0;
    for (int a = 0; a < nstart; a++) {
        ev_sim *s = gz_pair(D, &st, 1);
        const double *A = EV_P_ANY(s, 0);
        const int n0 = gz_run(s, 1, 0, "wall graze");
        worst = n0 > worst ? n0 : worst;
        at0 += n0 > 1;
        CHECK(A[D] > 0, "wall graze: did not leave the wall");
        ev_free(s);
    }
    fprintf(stderr, "%dd wall grazes: %d of %d with a pair event at t = 0 (most events at t = 0: %d)\n", D,
            at0, nstart, worst);
    CHECK(worst <= 8, "%dd wall grazes: %d events at t = 0", D, worst);
    CHECK(at0 > 0, "%dd wall grazes: no pair event at t = 0 (the test lost its case)", D);
}

/* Grazing free pairs in a box with walls, engine against brute force: the
 * same events at the same times, bit for bit, up to t = 30. */
static void gz_brute(int D, int nstart, uint64_t st)
{
    size_t events = 0, differ = 0;
    for (int a = 0; a < nstart; a++) {
        ev_sim *s = gz_pair(D, &st, 0);
        if (ev_rebuild(s)) abort();
        bf *b = bf_from(s);
        trace te = {0}, tb = {0};
        ev_set_trace(s, rec, &te);
        ev_loop(s, 30, NULL);
        while (tb.n <= te.n && bf_step(b, &tb) == 0 && b->now <= 30) {
        }
        size_t same = 0;
        while (same < te.n && same < tb.n && te.e[same].t == tb.e[same].t && te.e[same].i == tb.e[same].i &&
               te.e[same].j == tb.e[same].j && te.e[same].kind == tb.e[same].kind)
            same++;
        events += te.n;
        differ += same != te.n || (tb.n > te.n && tb.e[te.n].t <= 30);
        free(te.e), free(tb.e), bf_free(b), ev_free(s);
    }
    fprintf(stderr, "%dd grazes against brute force: %zu events, %zu of %d starts differ\n", D, events, differ,
            nstart);
    CHECK(differ == 0, "%dd grazes against brute force: %zu of %d starts differ", D, differ, nstart);
}

static void test_graze(void)
{
    for (int D = 2; D <= 3; D++) {
        gz_free(D, 400, 0, 1000 + (uint64_t)D);
        gz_free(D, 200, 3, 2000 + (uint64_t)D);
        gz_seed(D, 0, 400, 3000 + (uint64_t)D);
        gz_seed(D, 0.5, 200, 4000 + (uint64_t)D);
        gz_brute(D, 100, 5000 + (uint64_t)D);
        gz_wall(D, 200, 6000 + (uint64_t)D);
    }
    gz_review();
}

/* ---- look-ahead prefetch (ev_core.c): the same events with and without --
 * From EV_LOOKAHEAD_MIN particles on, every event prefetches the lines of
 * the next few. It reads the queue and the particles' cells (under ASan
 * those reads are checked) and must change nothing: the same run with it
 * switched off gives the same trace, bit for bit, and the same end state. */
/* ---- tiny particles ----------------------------------------------------------
 * The dynamics is the same at any length scale, but the collision's
 * r.r (m_i + m_j) and m_i m_j are products of lengths and masses: with a
 * radius of 1e-80 in 2D (density 1, r^4 ~ 1e-320; 1e-65 in 3D) they
 * underflowed, the first collision made the velocities infinite and the
 * positions NaN, and wall events at one instant repeated until
 * --max-events (a run without it never ended); at 1e-55 (3D) m_i m_j
 * alone underflowed and the collisions added nothing to the virial. Runs at radius r0 against
 * the same scene at radius 0.5 (the same placement and velocities, scaled):
 * everything finite, no zero-time loop, no overlap, energy kept, every
 * stuck particle at contact, and the compressibility factor from the
 * collision virial that of the unit scene. */
static double tiny_z(ev_sim *s, double *worst, uint64_t *ncoll, double *de, int *why)
{
    ev_stats a, b;
    ev_get_stats(s, &a);
    *worst = ev_max_overlap_now(s);
    for (int k = 1; k <= 20; k++) {
        s->par.max_events = 2000u * (uint64_t)k;
        *why = ev_run(s, NULL);
        *worst = fmax(*worst, ev_max_overlap_now(s));
        if (*why != EV_STOP_EVENTS) break;
    }
    ev_get_stats(s, &b);
    *ncoll = b.collisions;
    *de = fabs(b.ke_free + b.ke_stuck - a.ke_free) / a.ke_free;
    /* Z = P V / (N kT) = 1 + virial / (t 2 KE) (kT = 2 KE / (d N), walls' impulse aside) */
    return 1 + b.virial / (b.t * 2 * b.ke_free);
}

static void tiny_case(int dim, double r0, double p, double packing)
{
    double z[2] = {0, 0};
    for (int unit = 1; unit >= 0; unit--) {
        const double r = unit ? 0.5 : r0;
        ev_params q = base(dim, 300, packing, 0, p > 0 ? r : 0, p);
        q.radius = r;
        ev_sim *s = ev_create(&q, NULL, 0);
        CHECK(s != NULL, "create");
        if (!s) return;
        double worst, de;
        uint64_t nc;
        int why = 0;
        z[unit] = tiny_z(s, &worst, &nc, &de, &why);
        int finite = 1;
        for (uint32_t i = 0; i < s->n; i++)
            for (int k = 0; k < 2 * dim + 1; k++) finite &= isfinite(EV_P_ANY(s, i)[k]);
        double touch = 0;
        for (uint32_t k = 0; k < s->nstuck; k++) {
            const uint32_t i = s->stuck_idx[k];
            touch = fmax(touch, contact_gap(s, i, s->parent[i], dim));
        }
        fprintf(stderr, "tiny %dd r %g p %g: %s, %llu events, %llu collisions, %llu stuck, dE/E %.3g, overlap %.3g, "
                "contact gap %.3g, Z %.4g\n", dim, r, p, ev_stop_name(why), (unsigned long long)s->events,
                (unsigned long long)nc, (unsigned long long)s->nstuck, de, worst, touch, z[unit]);
        CHECK(finite, "%dd r %g: a position, velocity or time not finite", dim, r);
        CHECK(nc > 1000, "%dd r %g: %llu collisions", dim, r, (unsigned long long)nc);
        CHECK(de < 1e-12, "%dd r %g: energy %g", dim, r, de);
        CHECK(worst < TOL && s->max_overlap < TOL, "%dd r %g: overlap %g / %g", dim, r, worst, s->max_overlap);
        CHECK(touch < TOL, "%dd r %g: stuck particle off its parent by %g", dim, r, touch);
        if (p > 0) CHECK(why == EV_STOP_ALL_STUCK, "%dd r %g: %s, not all stuck", dim, r, ev_stop_name(why));
        ev_free(s);
    }
    /* the same gas statistically: Z within 10% (about 2.1 in 2D at packing
     * 0.3, 1.9 in 3D at 0.25, at these short times; a lost virial gives 1) */
    if (p == 0) CHECK(fabs(z[0] / z[1] - 1) < 0.1, "%dd: Z %g at radius %g, %g at 0.5", dim, z[0], r0, z[1]);
}

static void test_tiny(void)
{
    tiny_case(2, 1e-80, 0, 0.3);
    tiny_case(3, 1e-65, 0, 0.25);
    tiny_case(3, 1e-55, 0, 0.25); /* r.r (m_i + m_j) fine, m_i m_j = 0: the virial lost */
    tiny_case(2, 1e-80, 1, 0.1);
    tiny_case(3, 1e-65, 0.5, 0.1);
}

static void hash_ev(const ev_trace_event *e, void *u)
{
    uint64_t *h = u;
    const unsigned char *c = (const unsigned char *)&e->t;
    for (size_t b = 0; b < sizeof e->t; b++) *h = (*h ^ c[b]) * 1099511628211ull;
    *h = (*h ^ e->i) * 1099511628211ull;
    *h = (*h ^ e->j) * 1099511628211ull;
    *h = (*h ^ (uint64_t)e->kind) * 1099511628211ull;
}

static void lookahead_case(const char *what, ev_params q)
{
    uint64_t h[2], ev[2], coll[2], nstuck[2], walls = 0, cross = 0;
    double *end[2] = {NULL, NULL};
    size_t bytes = 0;
    for (int r = 0; r < 2; r++) {
        char err[256];
        ev_sim *s = ev_create(&q, err, sizeof err);
        CHECK(s != NULL, "%s: %s", what, err);
        if (!s) return;
        CHECK(s->lookahead == 1, "%s: %u particles, look-ahead off", what, s->ntot);
        s->lookahead = r == 0; /* run 1: switched off */
        h[r] = 1469598103934665603ull;
        ev_set_trace(s, hash_ev, &h[r]);
        ev_loop(s, INFINITY, NULL); /* bounded by q.max_events */
        ev[r] = s->events;
        coll[r] = s->collisions;
        nstuck[r] = s->nstuck;
        walls = s->wall_hits;
        cross = s->cell_crossings;
        bytes = (size_t)s->ntot * (size_t)(2 * s->dim + 2) * sizeof(double);
        end[r] = malloc(bytes);
        if (end[r]) memcpy(end[r], s->ps, bytes);
        ev_free(s);
    }
    fprintf(stderr, "%s: %llu events, %llu collisions, %llu stuck\n", what, (unsigned long long)ev[0],
            (unsigned long long)coll[0], (unsigned long long)nstuck[0]);
    CHECK(ev[0] == q.max_events, "%s: stopped after %llu events", what, (unsigned long long)ev[0]);
    /* the paths the look-ahead meets: crossings always, walls and sticking
     * in a box with walls and seeds */
    CHECK(cross > 0 && (q.walls == EV_WALLS_PERIODIC || (walls > 0 && nstuck[0] > 100)),
          "%s: %llu crossings, %llu wall hits, %llu stuck", what, (unsigned long long)cross,
          (unsigned long long)walls, (unsigned long long)nstuck[0]);
    CHECK(h[0] == h[1] && ev[0] == ev[1] && coll[0] == coll[1] && nstuck[0] == nstuck[1],
          "%s: look-ahead changed the events", what);
    CHECK(end[0] && end[1] && !memcmp(end[0], end[1], bytes), "%s: look-ahead changed the end state", what);
    free(end[0]);
    free(end[1]);
}

static void test_lookahead(void)
{
    ev_params q = base(2, EV_LOOKAHEAD_MIN + 10000, 0.3, 1, 0, 1);
    q.max_events = 150000;
    lookahead_case("2D periodic gas", q);
    q = base(3, EV_LOOKAHEAD_MIN + 10000, 0.3, 1, 0, 1);
    q.max_events = 150000;
    lookahead_case("3D periodic gas", q);
    /* walls and sticking with p < 1 (wall events, stuck partners, offers):
     * a grid of seeds through the box, so that thousands stick */
    char dir[] = "/tmp/pdla-ev-la-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    for (int dim = 2; dim <= 3; dim++) {
        q = base(dim, EV_LOOKAHEAD_MIN, dim == 2 ? 0.05 : 0.1, 0, 1, 0.5);
        q.max_events = 150000;
        ev_sim *s = ev_create(&q, NULL, 0); /* for the box side */
        CHECK(s != NULL, "create");
        if (!s) return;
        const double L = s->L, step = dim == 2 ? 20 : 6;
        ev_free(s);
        snprintf(q.seeds, sizeof q.seeds, "%s/seeds%d.txt", dir, dim);
        FILE *f = fopen(q.seeds, "w");
        if (!f) abort();
        for (double x = step; x < 0.9 * L; x += step)
            for (double y = step; y < 0.9 * L; y += step)
                for (double z = step; dim == 2 ? z == step : z < 0.9 * L; z += step)
                    if (dim == 2) fprintf(f, "%g %g 1\n", x, y);
                    else fprintf(f, "%g %g %g 1\n", x, y, z);
        fclose(f);
        lookahead_case(dim == 2 ? "2D walls, seeds, sticking" : "3D walls, seeds, sticking", q);
    }
    snprintf(q.seeds, sizeof q.seeds, "rm -rf '%s'", dir);
    CHECK(system(q.seeds) == 0, "cleanup");
}

int main(int argc, char **argv)
{
    if (argc > 2 && !strcmp(argv[1], "bath-oldckpt")) {
        test_bath_oldckpt(argv[2]);
        return check_finish();
    }
    if (argc > 4 && !strcmp(argv[1], "eos")) {
        test_eos(atoi(argv[2]), atof(argv[3]), strtoull(argv[4], NULL, 10), argc > 5 ? atof(argv[5]) : 200);
        return check_finish();
    }
    if (argc > 3 && !strcmp(argv[1], "conserve-long")) {
        test_conserve_long(atoi(argv[2]), atof(argv[3]));
        return check_finish();
    }
    if (argc > 8 && !strcmp(argv[1], "ballistic")) {
        test_ballistic(atoi(argv[2]), strtoull(argv[3], NULL, 10), atoi(argv[4]), atoi(argv[5]), atof(argv[6]),
                       atof(argv[7]), atof(argv[8]));
        return check_finish();
    }
    if (argc > 2 && !strcmp(argv[1], "mb")) {
        test_mb(atoi(argv[2]));
        return check_finish();
    }
    const char *what = argc > 1 ? argv[1] : "all";
    const int all = !strcmp(what, "all");
    if (all || !strcmp(what, "brute")) test_brute();
    if (all || !strcmp(what, "conserve")) {
        test_conserve(2, 0, 0.3, 150);
        test_conserve(2, 1, 0.4, 120);
        test_conserve(3, 0, 0.3, 100);
        test_conserve(3, 1, 0.3, 100);
    }
    if (all || !strcmp(what, "stick")) {
        test_stick(2, 0.05, 1);
        test_stick(2, 0.2, 0.3);
        test_stick(3, 0.05, 1);
        test_stick(3, 0.2, 0.5);
    }
    if (all || !strcmp(what, "edge")) test_edge();
    if (all || !strcmp(what, "determinism")) test_determinism();
    if (all || !strcmp(what, "params")) test_params();
    if (all || !strcmp(what, "dffit")) test_dffit();
    if (all || !strcmp(what, "seeds")) test_seeds();
    if (all || !strcmp(what, "seeds-overlap")) test_seeds_overlap();
    if (all || !strcmp(what, "resume")) test_resume();
    if (all || !strcmp(what, "quiet-rows")) test_quiet_rows();
    if (all || !strcmp(what, "row-cost")) test_row_cost();
    if (all || !strcmp(what, "past-stop")) test_past_stop();
    if (all || !strcmp(what, "thin")) test_thin();
    if (all || !strcmp(what, "bath")) test_bath();
    if (all || !strcmp(what, "bath-brute")) test_bath_brute();
    if (all || !strcmp(what, "place")) test_place();
    if (all || !strcmp(what, "lookahead")) test_lookahead();
    if (all || !strcmp(what, "periodic-few")) test_periodic_few();
    if (all || !strcmp(what, "periodic-tie-late")) test_periodic_tie_late();
    if (all || !strcmp(what, "graze")) test_graze();
    if (all || !strcmp(what, "tiny")) test_tiny();
    return check_finish();
}
