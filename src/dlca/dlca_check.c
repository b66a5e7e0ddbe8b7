/*
 * dlca_check.c - `pdla check` of DLCA files, the core (dlca_check.h): the
 * monomers are fed one by one and checked as they come (inside the box,
 * the site their position's, no site held twice, the writer's cluster
 * numbers), then over all of them: face contacts by a binary search of the
 * sorted sites (union-find: each cluster one piece; with sticking 1 no
 * contact between two clusters), a walk over each cluster's contacts on
 * the torus (it spans, or it gives the offsets from which the engine's own
 * dlca_rg_offsets recomputes R_g bit for bit), the totals, the series and
 * the stop. Shares with the growth only the R_g function, the series rule
 * (dlca_row_fault), the snapshot rule (dlca_snapshots_check_end) and the
 * fractal fit (dlca_fractal_dim), so that a file is held to the rules the
 * writer and the loader keep; the contacts and the spanning walk are
 * found afresh from the sites, and each snapshot's position dataset is
 * compared with the coordinates of its sites (read through
 * dlca_check_pos.c). Also the check of a checkpoint
 * (dck_checkpoint): loaded, then its state as the cluster.h5 it would
 * write.
 */
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "dlca_check.h"

static const char *const kind_names[DLCA_CK_KINDS] = {"box",  "site",     "shared",  "numbering", "pieces",
                                                      "touch", "spanning", "size",    "rg",        "results",
                                                      "stop", "series",   "snapshots"};

const char *dlca_check_kind_name(int kind) { return kind >= 0 && kind < DLCA_CK_KINDS ? kind_names[kind] : NULL; }

/* A bit a site; per monomer ks 8 bytes, cid, ent, uf, q and first 4 each,
 * the walk's u 4d and off 2d; the tables 16 bytes a cluster (at most one a
 * monomer). */
int dck_fits(uint64_t V, uint64_t N, int d)
{
    const long pages = sysconf(_SC_PHYS_PAGES), psz = sysconf(_SC_PAGESIZE);
    const double need = (double)V / 8 + (double)N * (44.0 + 6.0 * d);
    return !(pages > 0 && psz > 0 && need > 0.5 * (double)pages * (double)psz);
}

void dck_free(dck *c)
{
    free(c->occ), free(c->ks), free(c->cid), free(c->ent), free(c->uf), free(c->q), free(c->first);
    free(c->u), free(c->off);
    memset(c, 0, sizeof *c);
}

int dck_init(dck *c, dlca_check_report *r, const dlca_params *p, uint64_t N)
{
    memset(c, 0, sizeof *c);
    c->r = r;
    c->d = p->dim;
    c->V = 1;
    for (int a = 0; a < c->d; a++) {
        c->L[a] = p->box[a];
        c->stride[a] = (int64_t)c->V;
        c->V *= p->box[a];
    }
    c->N = N;
    c->apart = p->sticking >= 1;
    const size_t n = N ? (size_t)N : 1, d = (size_t)c->d;
    c->occ = calloc((size_t)((c->V + 63) / 64), sizeof *c->occ);
    c->ks = malloc(n * sizeof *c->ks);
    c->cid = malloc(n * sizeof *c->cid);
    c->ent = malloc(n * sizeof *c->ent);
    c->uf = malloc(n * sizeof *c->uf);
    c->q = malloc(n * sizeof *c->q);
    c->first = malloc((n + 1) * sizeof *c->first);
    c->u = malloc(n * d * sizeof *c->u);
    c->off = malloc(n * d * sizeof *c->off);
    if (!c->occ || !c->ks || !c->cid || !c->ent || !c->uf || !c->q || !c->first || !c->u || !c->off) {
        dck_free(c);
        return PDLA_ENOMEM;
    }
    dck_reset(c, -1);
    return 0;
}

/* The bits set by the last state are cleared one by one: a snapshot costs
 * O(N), not the whole box. */
void dck_reset(dck *c, long snap)
{
    for (uint64_t j = 0; j < c->m; j++) {
        const uint64_t k = c->ks[j] >> 32;
        c->occ[k >> 6] &= ~(UINT64_C(1) << (k & 63));
    }
    c->m = c->rows = c->nc = c->largest = c->sum_s2 = c->spanning = 0;
    c->numbered = 1;
    c->snap = snap;
}

void dck_fail(dck *c, int kind, const char *fmt, ...)
{
    dlca_check_report *r = c->r;
    if (c->snap >= 0) kind = DLCA_CK_SNAPSHOTS;
    if (r->fail[kind]++) return;
    char *at = r->first[kind];
    const size_t len = sizeof r->first[kind];
    int k = c->snap >= 0 ? snprintf(at, len, "snapshot %ld: ", c->snap) : 0;
    if (k < 0 || (size_t)k >= len) k = 0;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(at + k, len - (size_t)k, fmt, ap);
    va_end(ap);
}

uint64_t dck_failures(const dck *c)
{
    uint64_t n = 0;
    for (int k = 0; k < DLCA_CK_KINDS; k++) n += c->r->fail[k];
    return n;
}

/* ---- sites --------------------------------------------------------------- */

static uint64_t site_of(const dck *c, const int64_t *x)
{
    uint64_t k = 0;
    for (int a = 0; a < c->d; a++) k += (uint64_t)dlca_wrap(x[a], c->L[a]) * (uint64_t)c->stride[a];
    return k;
}

static void coords_of(const dck *c, uint64_t k, int64_t *x)
{
    for (int a = 0; a < c->d; a++) {
        x[a] = (int64_t)(k % (uint64_t)c->L[a]);
        k /= (uint64_t)c->L[a];
    }
}

static int occ_at(const dck *c, uint64_t k) { return (int)(c->occ[k >> 6] >> (k & 63) & 1); }

/* The entry of ks (sorted) on site k, which a placed monomer holds. */
static uint64_t entry_at(const dck *c, uint64_t k)
{
    uint64_t lo = 0, hi = c->m;
    while (lo < hi) {
        const uint64_t mid = (lo + hi) / 2;
        if (c->ks[mid] >> 32 < k) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* "(x, y, ...)" of d coordinates into buf. */
static const char *point(const dck *c, const int64_t *x, char *buf, size_t len)
{
    size_t k = 0;
    for (int a = 0; a < c->d && k < len; a++)
        k += (size_t)snprintf(buf + k, len - k, "%s%" PRId64, a ? ", " : "(", x[a]);
    if (k < len) snprintf(buf + k, len - k, ")");
    return buf;
}

/* ---- the monomers one by one ---------------------------------------------- */

/* The writer numbers the clusters 0, 1, ... in monomer order, each one's
 * monomers together (dlca_export_chunk): first[] gets each one's first
 * row. Once broken, the clusters are not checked as clusters. */
static void number_row(dck *c, uint64_t i, uint32_t cl)
{
    if (!c->numbered) return;
    const uint32_t prev = i ? c->cid[i - 1] : 0;
    if (i == 0 ? cl == 0 : cl == prev || cl == prev + 1) {
        if (i == 0 || cl != prev) c->first[c->nc++] = (uint32_t)i;
        return;
    }
    c->numbered = 0;
    if (i == 0) dck_fail(c, DLCA_CK_NUMBERING, "monomer 0 is in cluster %" PRIu32 ", not 0", cl);
    else
        dck_fail(c, DLCA_CK_NUMBERING, "monomer %" PRIu64 " is in cluster %" PRIu32 " after one in cluster %" PRIu32
                 " (the clusters are numbered 0, 1, ... in monomer order, each one's monomers together)", i, cl, prev);
}

int dck_row(dck *c, const int64_t *x, uint32_t site, uint32_t cluster)
{
    const uint64_t i = c->rows++;
    c->cid[i] = cluster;
    c->ent[i] = UINT32_MAX;
    number_row(c, i, cluster);
    uint64_t k = site;
    char b[128];
    int inside = 1;
    for (int a = 0; x && a < c->d; a++)
        if (x[a] < 0 || x[a] >= c->L[a]) inside = 0;
    if (!inside)
        dck_fail(c, DLCA_CK_BOX, "monomer %" PRIu64 " at %s lies outside the box", i, point(c, x, b, sizeof b));
    else if (!x && site >= c->V)
        dck_fail(c, DLCA_CK_BOX, "monomer %" PRIu64 " is on site %" PRIu32 ", outside the box of %" PRIu64 " sites", i,
                 site, c->V);
    else {
        if (x && (k = site_of(c, x)) != site)
            dck_fail(c, DLCA_CK_SITE, "monomer %" PRIu64 " at %s: /monomers/site %" PRIu32 ", not that position's %" PRIu64,
                     i, point(c, x, b, sizeof b), site, k);
        if (occ_at(c, k))
            dck_fail(c, DLCA_CK_SHARED, "monomer %" PRIu64 " is on site %" PRIu64 ", which an earlier monomer holds", i, k);
        else {
            c->occ[k >> 6] |= UINT64_C(1) << (k & 63);
            c->ks[c->m++] = k << 32 | i;
        }
    }
    return dck_failures(c) >= DLCA_CHECK_MAX_FAILURES;
}

/* ---- over all of them ------------------------------------------------------ */

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static uint32_t uf_root(uint32_t *uf, uint32_t j)
{
    while (uf[j] != j) j = uf[j] = uf[uf[j]];
    return j;
}

/* Every face contact once (+1 on each axis, on the torus): the same
 * cluster's are joined in uf, two clusters' fail with sticking 1. */
static void contacts(dck *c)
{
    for (uint64_t j = 0; j < c->m; j++) c->uf[j] = (uint32_t)j;
    for (uint64_t j = 0; j < c->m; j++) {
        int64_t x[DLCA_MAX_DIM];
        coords_of(c, c->ks[j] >> 32, x);
        const uint32_t row = (uint32_t)c->ks[j];
        for (int a = 0; a < c->d; a++) {
            x[a]++;
            const uint64_t k = site_of(c, x);
            x[a]--;
            if (!occ_at(c, k)) continue;
            const uint64_t o = entry_at(c, k);
            const uint32_t orow = (uint32_t)c->ks[o];
            if (c->cid[orow] == c->cid[row]) {
                const uint32_t ra = uf_root(c->uf, (uint32_t)j), rb = uf_root(c->uf, (uint32_t)o);
                if (ra != rb) c->uf[ra > rb ? ra : rb] = ra > rb ? rb : ra;
            } else if (c->apart)
                dck_fail(c, DLCA_CK_TOUCH, "clusters %" PRIu32 " and %" PRIu32 " touch (monomers %" PRIu32 " and %" PRIu32
                         " are face-adjacent), although sticking is 1: a move joins every contact", c->cid[row],
                         c->cid[orow], row, orow);
        }
    }
}

/* Cluster cl's monomers (rows f..f+n) all placed and joined into one
 * piece? 1, or 0 (a piece apart fails; a monomer not placed has failed). */
static int one_piece(dck *c, uint64_t cl, uint32_t f, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        if (c->ent[f + i] == UINT32_MAX) return 0;
    const uint32_t r0 = uf_root(c->uf, c->ent[f]);
    for (uint32_t i = 1; i < n; i++)
        if (uf_root(c->uf, c->ent[f + i]) != r0) {
            dck_fail(c, DLCA_CK_PIECES, "cluster %" PRIu64 " is not one face-connected piece: monomer %" PRIu32
                     " is not joined to monomer %" PRIu32 " by face contacts", cl, f + i, f);
            return 0;
        }
    return 1;
}

/* A breadth-first walk over cluster cl's face contacts on the torus from
 * its first monomer (row f), each monomer given unwrapped coordinates u
 * (the walk's step from a neighbour's). 1 if it spans: u reaches an extent
 * of L on an axis, or a monomer is reached again at other coordinates
 * (the cluster winds round the torus, so any unwrapping reaches L). Else
 * 0 and off holds u minus the first monomer's: the engine's offsets, which
 * are one unwrapping of a cluster narrower than L (so every contact is a
 * unit step in them; two unwrappings of a connected cluster differ by a
 * constant) with the cluster's first monomer at offset 0 (a block keeps
 * its first monomer first, at the anchor: dlca.c, keep_room, append). */
static int walk(dck *c, uint32_t cl, uint32_t f, uint32_t n)
{
    const int d = c->d;
    int32_t *u = c->u;
    int64_t x[DLCA_MAX_DIM], lo[DLCA_MAX_DIM], hi[DLCA_MAX_DIM], y[DLCA_MAX_DIM];
    for (uint32_t i = 0; i < n; i++) u[(size_t)i * d] = INT32_MIN; /* not reached */
    coords_of(c, c->ks[c->ent[f]] >> 32, x);
    for (int a = 0; a < d; a++) u[a] = (int32_t)x[a], lo[a] = hi[a] = x[a];
    uint32_t head = 0, tail = 0;
    c->q[tail++] = 0;
    while (head < tail) {
        const uint32_t j = c->q[head++];
        for (int dir = 0; dir < 2 * d; dir++) {
            for (int a = 0; a < d; a++) y[a] = u[(size_t)j * d + a];
            y[dir >> 1] += dir & 1 ? -1 : 1;
            const uint64_t k = site_of(c, y);
            if (!occ_at(c, k)) continue;
            const uint32_t row = (uint32_t)c->ks[entry_at(c, k)];
            if (c->cid[row] != cl) continue;
            int32_t *ur = u + (size_t)(row - f) * d;
            if (ur[0] != INT32_MIN) {
                for (int a = 0; a < d; a++)
                    if (ur[a] != y[a]) return 1; /* the same monomer, an image L away */
                continue;
            }
            for (int a = 0; a < d; a++) {
                ur[a] = (int32_t)y[a]; /* within (-L, 2L): the extent so far is below L */
                if (y[a] < lo[a]) lo[a] = y[a];
                if (y[a] > hi[a]) hi[a] = y[a];
                if (hi[a] - lo[a] + 1 >= c->L[a]) return 1;
            }
            c->q[tail++] = row - f;
        }
    }
    for (size_t i = 0; i < (size_t)n * d; i++) c->off[i] = (dlca_off)(u[i] - u[i % d]);
    return 0;
}

/* A spanning cluster's offsets are any images of its sites (dlca.c,
 * append places them by window()), so its R_g is not a function of its
 * sites: it must be finite and within what offsets of |o| <= 2L - 2 on
 * each axis allow (a variance of values in an interval of width 4L - 4 is
 * at most (2L - 2)^2). */
static double rg_bound(const dck *c)
{
    double b = 0;
    for (int a = 0; a < c->d; a++) b += (2.0 * (double)c->L[a] - 2) * (2.0 * (double)c->L[a] - 2);
    return sqrt(b);
}

/* Cluster cl (rows f..f+n): its size against the table, one piece, and
 * spanning or its R_g recomputed. */
static void one_cluster(dck *c, uint32_t cl, const dck_table *tab)
{
    const uint32_t f = c->first[cl], n = c->first[cl + 1] - f;
    if (n > c->largest) c->largest = n;
    c->sum_s2 += (uint64_t)n * n;
    if (tab && cl < tab->nsize && tab->size[cl] != n)
        dck_fail(c, DLCA_CK_SIZE, "cluster %" PRIu32 " holds %" PRIu32 " monomers, /clusters/size says %" PRIu64, cl, n,
                 tab->size[cl]);
    if (!one_piece(c, cl, f, n)) return;
    const int spans = walk(c, cl, f, n);
    c->spanning += (uint64_t)spans;
    if (!tab || cl >= tab->nrg) return;
    const double rg = tab->rg[cl];
    if (spans) {
        c->r->rg_bounded++;
        if (!(rg >= 0 && rg <= rg_bound(c)))
            dck_fail(c, DLCA_CK_RG, "cluster %" PRIu32 " spans the box, and its /clusters/rg %.17g is not in [0, %.17g]",
                     cl, rg, rg_bound(c));
        return;
    }
    c->r->rg_exact++;
    const double want = dlca_rg_offsets(c->off, n, c->d);
    if (memcmp(&want, &rg, sizeof rg))
        dck_fail(c, DLCA_CK_RG, "cluster %" PRIu32 ": /clusters/rg %.17g, recomputed %.17g", cl, rg, want);
}

void dck_finish(dck *c, const dck_table *tab)
{
    qsort(c->ks, (size_t)c->m, sizeof *c->ks, cmp_u64);
    for (uint64_t j = 0; j < c->m; j++) c->ent[(uint32_t)c->ks[j]] = (uint32_t)j;
    contacts(c);
    if (!c->numbered) return; /* the clusters are not as written: nothing more is said of them */
    c->first[c->nc] = (uint32_t)c->rows;
    if (tab && (tab->nsize != c->nc || tab->nrg != c->nc))
        dck_fail(c, tab->nsize != c->nc ? DLCA_CK_SIZE : DLCA_CK_RG, "/clusters/%s has %" PRIu64 " rows for %" PRIu64
                 " clusters", tab->nsize != c->nc ? "size" : "rg", tab->nsize != c->nc ? tab->nsize : tab->nrg, c->nc);
    for (uint64_t cl = 0; cl < c->nc; cl++) one_cluster(c, (uint32_t)cl, tab);
}

/* ---- the totals ------------------------------------------------------------ */

static int same_f64(double a, double b) { return memcmp(&a, &b, sizeof a) == 0 || (isnan(a) && isnan(b)); }

static void want_u(dck *c, const char *name, int has, uint64_t got, uint64_t want, const char *from)
{
    if (!has) dck_fail(c, DLCA_CK_RESULTS, "/results %s is missing (or not the unsigned 64-bit integer pdla writes)", name);
    else if (got != want) dck_fail(c, DLCA_CK_RESULTS, "/results %s is %" PRIu64 ", %s give %" PRIu64, name, got, from, want);
}

static void want_f(dck *c, const char *name, int has, double got, double want, const char *from)
{
    if (!has) dck_fail(c, DLCA_CK_RESULTS, "/results %s is missing (or not the 64-bit float pdla writes)", name);
    else if (!same_f64(got, want)) dck_fail(c, DLCA_CK_RESULTS, "/results %s is %.17g, %s give %.17g", name, got, from, want);
}

/* The weight-average size sum(s^2) / N. The engine keeps the sum as a
 * double (N at the start, then 2 s_a s_b a join): exact up to 2^53, so
 * compared bit for bit there; above, each of its N - N_c additions may
 * round by half an ulp of the sum. */
static void want_weight(dck *c, const dck_totals *t)
{
    const double want = (double)c->sum_s2 / (double)c->N;
    if (c->sum_s2 <= UINT64_C(1) << 53) {
        want_f(c, "weight_average_size", t->has_weight, t->weight_size, want, "the cluster sizes");
        return;
    }
    const double tol = ((double)(c->N - c->nc) + 2) * ldexp(want, -52);
    if (!t->has_weight) want_f(c, "weight_average_size", 0, 0, want, "");
    else if (!(fabs(t->weight_size - want) <= tol))
        dck_fail(c, DLCA_CK_RESULTS, "/results weight_average_size is %.17g, the cluster sizes give %.17g (to %.3g)",
                 t->weight_size, want, tol);
}

/* The move counters as the run counts them: an attempt moves at most once,
 * a move moves 1 to `largest` monomers (the checkpoint loader's rule). */
static void counters(dck *c, const dck_totals *t)
{
    const uint64_t largest = c->numbered ? c->largest : t->largest;
    if (!t->has_attempts || !t->has_moves || !t->has_mmoves)
        dck_fail(c, DLCA_CK_RESULTS, "/results attempts, moves or monomer_moves is missing (or not a u64)");
    else if (t->moves > t->attempts)
        dck_fail(c, DLCA_CK_RESULTS, "/results moves %" PRIu64 " is more than its %" PRIu64 " attempts", t->moves,
                 t->attempts);
    else if (t->monomer_moves < t->moves || (unsigned __int128)t->monomer_moves > (unsigned __int128)t->moves * largest)
        dck_fail(c, DLCA_CK_RESULTS, "/results monomer_moves %" PRIu64 " is not in [moves, moves x largest] = [%" PRIu64
                 ", %" PRIu64 " x %" PRIu64 "]", t->monomer_moves, t->moves, t->moves, largest);
}

/* t against the attempts: each adds 1 / (N_c m_max), m_max the mobility
 * bound (1 at gamma 0; s^gamma of the largest size for gamma > 0, of the
 * smallest for gamma < 0), so between 1 / (N max(1, N^gamma)) and
 * max(1, N^-gamma); slack for the rounding of the sum of as many terms. */
static void time_bounds(dck *c, const dck_totals *t, double gamma)
{
    if (!t->has_t || !t->has_attempts) {
        dck_fail(c, DLCA_CK_RESULTS, "/results t or attempts is missing (or not as pdla writes it)");
        return;
    }
    const double N = (double)c->N, a = (double)t->attempts, slack = a * 0x1p-50 + 1e-12;
    const double hi = gamma < 0 ? pow(N, -gamma) : 1, lo = 1 / (N * (gamma > 0 ? pow(N, gamma) : 1));
    if (!(isfinite(t->t) && t->t >= a * lo * (1 - slack) && t->t <= a * hi * (1 + slack)))
        dck_fail(c, DLCA_CK_RESULTS, "/results t %.17g is not what %" PRIu64 " attempts add up to (each adds %.3g to %.3g)",
                 t->t, t->attempts, lo, hi);
}

static void search_used(dck *c, const dck_totals *t, int search)
{
    if (!t->has_search)
        dck_fail(c, DLCA_CK_RESULTS, "/results search_used is missing");
    else if (strcmp(t->search_used, dlca_search_name(search)) &&
             !(search == DLCA_SEARCH_BOXES && !strcmp(t->search_used, dlca_search_name(DLCA_SEARCH_ALLPAIRS))))
        dck_fail(c, DLCA_CK_RESULTS, "/results search_used '%s' is not --search %s (nor allpairs, which boxes fall "
                 "back to)", t->search_used, dlca_search_name(search));
}

/* D_f as the writer fits it, from the stored table (whose values are
 * checked against the monomers on their own). */
static void fractal(dck *c, const dck_totals *t, const dck_table *tab)
{
    if (!tab || tab->nsize != tab->nrg) return; /* failed as the table's length */
    double df, dferr;
    dlca_fractal_dim(tab->size, tab->rg, (size_t)tab->nsize, 8, &df, &dferr);
    want_f(c, "D_f", t->has_df, t->D_f, df, "the stored /clusters");
    want_f(c, "D_f_err", t->has_dferr, t->D_f_err, dferr, "the stored /clusters");
}

/* The stop against the state and the stops asked, in dlca_check_stop's
 * order (spanning, clusters, time, attempts): what stopped the run held,
 * and what comes before it did not; "running" (a run stopped by a signal
 * between attempts) none; "stopped" (out of memory in a join) may be any
 * state. A spanning stop needs a spanning cluster, and any other none. */
static void stop_check(dck *c, const dck_totals *t, const dlca_params *p)
{
    if (!t->has_stop) {
        dck_fail(c, DLCA_CK_STOP, "/results stop is missing");
        return;
    }
    const int span = !strcmp(t->stop, "spanning");
    if (span && !c->spanning)
        dck_fail(c, DLCA_CK_SPANNING, "it records a spanning stop, but no cluster spans the box (none reaches an "
                 "extent of L on an axis nor winds round it)");
    if (!span && c->spanning)
        dck_fail(c, DLCA_CK_SPANNING, "%" PRIu64 " clusters span the box, but the run stopped for '%s' (spanning always "
                 "stops it)", c->spanning, t->stop);
    const uint64_t nc = c->numbered ? c->nc : t->n_clusters;
    const int cl = nc <= p->until_clusters, tm = p->until_time > 0 && t->t >= p->until_time,
              at = p->max_attempts && t->attempts >= p->max_attempts;
    int ok = 1;
    if (!strcmp(t->stop, "clusters")) ok = cl;
    else if (!strcmp(t->stop, "time")) ok = !cl && tm;
    else if (!strcmp(t->stop, "attempts")) ok = !cl && !tm && at;
    else if (!strcmp(t->stop, "running")) ok = !cl && !tm && !at;
    else if (strcmp(t->stop, "stopped") && !span) {
        dck_fail(c, DLCA_CK_STOP, "/results stop '%s' is no stop of the model", t->stop);
        return;
    }
    if (!ok)
        dck_fail(c, DLCA_CK_STOP, "stop '%s' with %" PRIu64 " clusters, t = %.17g and %" PRIu64 " attempts does not "
                 "follow the stops asked (until_clusters %" PRIu64 ", until_time %.17g, max_attempts %" PRIu64 ")",
                 t->stop, nc, t->t, t->attempts, p->until_clusters, p->until_time, p->max_attempts);
}

void dck_results(dck *c, const dck_totals *t, const dck_table *tab, const dlca_params *p)
{
    want_u(c, "n_monomers", t->has_n, t->n_monomers, c->N, "the monomers");
    if (c->numbered) {
        want_u(c, "n_clusters", t->has_nc, t->n_clusters, c->nc, "the monomers' clusters");
        want_u(c, "largest", t->has_largest, t->largest, c->largest, "the monomers' clusters");
        want_u(c, "merges", t->has_merges, t->merges, c->N - c->nc, "N - N_c (a join is one cluster fewer)");
        want_f(c, "mean_size", t->has_mean, t->mean_size, (double)c->N / (double)c->nc, "the monomers' clusters");
        want_weight(c, t);
    }
    counters(c, t);
    time_bounds(c, t, p->mobility);
    search_used(c, t, p->search);
    fractal(c, t, tab);
    stop_check(c, t, p);
}

/* ---- the series -------------------------------------------------------------- */

dlca_row dck_end_row(const dck *c, const dck_totals *t)
{
    const uint64_t nc = c->numbered ? c->nc : t->n_clusters, largest = c->numbered ? c->largest : t->largest;
    return (dlca_row){.t = t->has_t ? t->t : INFINITY, .attempts = t->has_attempts ? t->attempts : UINT64_MAX,
                      .n_clusters = nc, .largest = largest, .mean_size = (double)c->N / (double)nc,
                      .weight_size = t->weight_size};
}

void dck_series_row(dck *c, uint64_t i, const dlca_row *w, const dlca_row *prev, const dlca_row *end)
{
    const char *bad = dlca_row_fault(w, prev, end, c->N);
    if (bad) dck_fail(c, DLCA_CK_SERIES, "row %" PRIu64 " has %s out of range (or out of order)", i, bad);
    else if (w->mean_size != (double)c->N / (double)w->n_clusters)
        dck_fail(c, DLCA_CK_SERIES, "row %" PRIu64 ": mean_size %.17g is not N / n_clusters = %.17g", i, w->mean_size,
                 (double)c->N / (double)w->n_clusters);
    else if (i == 0 && (w->t != 0 || w->attempts != 0))
        dck_fail(c, DLCA_CK_SERIES, "row 0 is not the start (t = 0, 0 attempts)");
}

/* A stopped run adds a row of its final state (dlca_run_to), unless its
 * last row was taken at that attempt: then that one is it. */
void dck_series_end(dck *c, const dlca_row *last, uint64_t rows, const dlca_row *end, const dck_totals *t)
{
    c->r->series_rows = rows;
    if (!rows) {
        dck_fail(c, DLCA_CK_SERIES, "it has no rows (a run writes one at its start)");
        return;
    }
    if (!t->has_stop || !strcmp(t->stop, "running")) return;
    const char *f = last->t != end->t                         ? "t"
                    : last->attempts != end->attempts           ? "attempts"
                    : last->n_clusters != end->n_clusters       ? "n_clusters"
                    : last->largest != end->largest             ? "largest"
                    : !same_f64(last->mean_size, end->mean_size) ? "mean_size"
                    : !same_f64(last->weight_size, end->weight_size) ? "weight_average_size"
                                                                 : NULL;
    if (f)
        dck_fail(c, DLCA_CK_SERIES, "its last row (%" PRIu64 ") is not the final state (its %s differs), which a "
                 "stopped run writes last", rows - 1, f);
}

/* ---- snapshots ----------------------------------------------------------------- */

int dck_snapshots(dck *c, const dlca_snap_end *e, const dlca_snapshot *sn, size_t n, double every, int stopped,
                  const dck_totals *t)
{
    char why[512];
    c->r->snapshots = n;
    const int rc = dlca_snapshots_check_end(e, sn, n, every, stopped, why, sizeof why);
    if (rc == PDLA_ENOMEM) return rc;
    if (rc) {
        dck_fail(c, DLCA_CK_SNAPSHOTS, "%s", why);
        return 0;
    }
    /* Each snapshot is a state of the run after an attempt: its clusters
     * hold the final state's rules, and one spans only at the spanning
     * stop (the run stops at the attempt that spans). */
    const int span_stop = !strcmp(t->stop, "spanning");
    for (size_t i = 0; i < n; i++) {
        dck_reset(c, (long)i);
        for (uint64_t m = 0; m < c->N; m++)
            if (dck_row(c, NULL, sn[i].site[m], sn[i].cluster[m])) {
                c->r->stopped = 1;
                return 0;
            }
        dck_finish(c, NULL);
        if (c->spanning && !(span_stop && sn[i].attempts == e->attempts))
            dck_fail(c, DLCA_CK_SPANNING, "%" PRIu64 " clusters span the box at %" PRIu64 " attempts, before the run's "
                     "end (spanning stops it)", c->spanning, sn[i].attempts);
    }
    return 0;
}

/* Rows of a snapshot's position read at a time: 1.3 MB of buffer in 5D. */
enum { POS_SLAB = 1 << 16 };

/* Rows r0..r0+n of snapshot i's position (pos, d a row) against the
 * coordinates the writer derives from its sites (dlca_output.c,
 * write_snapshot: x_a = (k / stride_a) mod L_a, coords_of's rule), exactly:
 * each row that differs a failure. 1 at the failure cap, else 0. */
static int position_rows(dck *c, size_t i, const uint32_t *site, uint64_t r0, uint64_t n, const int32_t *pos)
{
    const int d = c->d;
    for (uint64_t j = 0; j < n; j++) {
        int64_t want[DLCA_MAX_DIM], got[DLCA_MAX_DIM];
        coords_of(c, site[r0 + j], want);
        int same = 1;
        for (int a = 0; a < d; a++) {
            got[a] = pos[j * (uint64_t)d + (uint64_t)a];
            if (got[a] != want[a]) same = 0;
        }
        if (same) continue;
        char b1[96], b2[96];
        dck_fail(c, DLCA_CK_SNAPSHOTS, "/snapshots/%zu/position row %" PRIu64 " is %s, but its site %" PRIu32
                 " is at %s", i, r0 + j, point(c, got, b1, sizeof b1), site[r0 + j], point(c, want, b2, sizeof b2));
        if (dck_failures(c) >= DLCA_CHECK_MAX_FAILURES) return 1;
    }
    return 0;
}

/* Each snapshot's /snapshots/<i>/position (what ParaView shows of it;
 * the resume reads only its sites), read in slabs through dck_pos_*, its
 * failures those of snapshot i. 0 or PDLA_ENOMEM. */
static int snapshot_positions(dck *c, const char *path, const dlca_snapshot *sn, size_t n)
{
    char why[256];
    dck_pos p;
    if (dck_pos_open(&p, path, why, sizeof why)) {
        dck_fail(c, DLCA_CK_SNAPSHOTS, "%s", why);
        return 0;
    }
    int32_t *pos = malloc((size_t)POS_SLAB * (size_t)c->d * sizeof *pos);
    int rc = pos ? 0 : PDLA_ENOMEM;
    for (size_t i = 0; !rc && i < n && !c->r->stopped; i++) {
        c->snap = (long)i; /* dck_fail names the snapshot */
        if (dck_pos_snapshot(&p, i, c->N, c->d, why, sizeof why)) {
            dck_fail(c, DLCA_CK_SNAPSHOTS, "%s", why);
            continue;
        }
        for (uint64_t r0 = 0; r0 < c->N && !c->r->stopped; r0 += POS_SLAB) {
            const uint64_t k = c->N - r0 < POS_SLAB ? c->N - r0 : POS_SLAB;
            if (dck_pos_read(&p, r0, k, pos) < 0) {
                dck_fail(c, DLCA_CK_SNAPSHOTS, "cannot read /snapshots/%zu/position rows %" PRIu64 "..%" PRIu64
                         " (damaged?)", i, r0, r0 + k - 1);
                break;
            }
            if (position_rows(c, i, sn[i].site, r0, k, pos)) c->r->stopped = 1;
        }
        if (dck_failures(c) >= DLCA_CHECK_MAX_FAILURES) c->r->stopped = 1;
    }
    if (dck_pos_close(&p) < 0) dck_fail(c, DLCA_CK_SNAPSHOTS, "cannot close the snapshots' position datasets");
    free(pos);
    return rc;
}

int dck_snapshots_file(dck *c, const char *path, const dlca_snap_end *e, const dck_totals *t)
{
    dlca_snapshot *sn = NULL;
    size_t n = 0;
    double every = 0;
    int stopped = 0;
    char why[1024];
    if (dlca_read_snapshots_h5(path, e->N, e->t, &sn, &n, &every, &stopped, why, sizeof why)) {
        /* its line names the file: the report names it once */
        char prefix[64];
        const char *at = why;
        snprintf(prefix, sizeof prefix, "cannot resume from ");
        if (!strncmp(at, prefix, strlen(prefix)) && !strncmp(at + strlen(prefix), path, strlen(path)) &&
            !strncmp(at + strlen(prefix) + strlen(path), ": ", 2))
            at += strlen(prefix) + strlen(path) + 2;
        dck_fail(c, DLCA_CK_SNAPSHOTS, "%s", at);
        return 0;
    }
    int rc = dck_snapshots(c, e, sn, n, every, stopped, t);
    if (!rc && !c->r->stopped) rc = snapshot_positions(c, path, sn, n);
    for (size_t i = 0; i < n; i++) free(sn[i].site), free(sn[i].cluster);
    free(sn);
    return rc;
}

/* ---- the report ---------------------------------------------------------------- */

void dck_report_params(dlca_check_report *r, const dlca_params *p, uint64_t N)
{
    r->dim = p->dim;
    for (int a = 0; a < p->dim; a++) r->box[a] = p->box[a];
    r->sticking = p->sticking;
    r->monomers = N;
}

void dck_report_state(const dck *c, const dck_totals *t)
{
    dlca_check_report *r = c->r;
    r->clusters = c->numbered ? c->nc : 0;
    r->largest = c->numbered ? c->largest : 0;
    r->spanning = c->spanning;
    snprintf(r->stop, sizeof r->stop, "%s", t->has_stop ? t->stop : "");
}

void dck_verdict(const dck *c) { c->r->pass = !c->r->stopped && dck_failures(c) == 0; }

/* ---- a checkpoint ----------------------------------------------------------------- */

/* What a cluster.h5 of s would hold in /results (dlca_output.c,
 * write_results), its table tab. */
static void totals_of(const dlca_sim *s, const dck_table *tab, dck_totals *t)
{
    dlca_stats st;
    dlca_get_stats(s, &st);
    memset(t, 0, sizeof *t);
    t->t = st.t;
    t->attempts = st.attempts, t->moves = st.moves, t->monomer_moves = st.monomer_moves, t->merges = st.merges;
    t->n_monomers = st.n_monomers, t->n_clusters = st.n_clusters, t->largest = st.largest;
    t->mean_size = (double)st.n_monomers / (double)st.n_clusters;
    t->weight_size = st.sum_s2 / (double)st.n_monomers;
    dlca_fractal_dim(tab->size, tab->rg, (size_t)tab->nsize, 8, &t->D_f, &t->D_f_err);
    snprintf(t->stop, sizeof t->stop, "%s", dlca_stop_name(st.stop));
    snprintf(t->search_used, sizeof t->search_used, "%s", dlca_search_name(st.search_now));
    t->has_t = t->has_mean = t->has_weight = t->has_df = t->has_dferr = t->has_attempts = t->has_moves = 1;
    t->has_mmoves = t->has_merges = t->has_n = t->has_nc = t->has_largest = t->has_stop = t->has_search = 1;
}

/* The loaded state s through the checks: its monomers as dlca_export_sites
 * numbers them (site, cl), its cluster table, totals, series, snapshots. */
static int check_state(dck *c, const dlca_sim *s, const char *path, const uint32_t *site, const uint32_t *cl,
                       const dck_table *tab)
{
    for (uint64_t m = 0; m < c->N; m++)
        if (dck_row(c, NULL, site[m], cl[m])) {
            c->r->stopped = 1;
            return 0;
        }
    dck_finish(c, tab);
    dck_totals t;
    totals_of(s, tab, &t);
    const dlca_params *p = dlca_get_params(s);
    dck_results(c, &t, tab, p);
    size_t nr;
    const dlca_row *rows = dlca_series(s, &nr);
    const dlca_row end = dck_end_row(c, &t);
    for (size_t i = 0; i < nr; i++) dck_series_row(c, i, &rows[i], i ? &rows[i - 1] : NULL, &end);
    dck_series_end(c, nr ? &rows[nr - 1] : NULL, nr, &end, &t);
    dck_report_state(c, &t);
    const dlca_snap_end e = {t.t, t.attempts, t.n_clusters, c->N, c->V, p->mobility};
    return dck_snapshots_file(c, path, &e, &t);
}

int dck_checkpoint(const char *path, dlca_check_report *r, char *err, size_t errlen)
{
    dlca_sim *s = NULL;
    const int lrc = dlca_checkpoint_load(&s, path, err, errlen);
    if (lrc) return lrc == PDLA_ENOMEM ? lrc : PDLA_EIO; /* a refusal: the file fails */
    r->checkpoint = 1;
    const dlca_params *p = dlca_get_params(s);
    dlca_stats st;
    dlca_get_stats(s, &st);
    dck_report_params(r, p, st.n_monomers);
    const size_t N = (size_t)st.n_monomers, nc = (size_t)st.n_clusters;
    uint32_t *site = malloc((N ? N : 1) * sizeof *site), *cl = malloc((N ? N : 1) * sizeof *cl);
    uint64_t *size = malloc((nc ? nc : 1) * sizeof *size);
    double *rg = malloc((nc ? nc : 1) * sizeof *rg);
    dck c;
    int rc = 0;
    if (!dck_fits(s->V, N, p->dim))
        rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: %zu monomers in a box of %" PRIu64 " sites need more than half "
                         "of this machine's memory to check", path, N, s->V);
    else if (!site || !cl || !size || !rg || dck_init(&c, r, p, N))
        rc = pdla_errorf(PDLA_ENOMEM, err, errlen, "%s: out of memory", path);
    else {
        dlca_export_sites(s, site, cl);
        dlca_cluster_table(s, size, rg);
        const dck_table tab = {size, rg, nc, nc};
        rc = check_state(&c, s, path, site, cl, &tab);
        if (rc) pdla_errorf(rc, err, errlen, "%s: out of memory", path);
        dck_verdict(&c);
        dck_free(&c);
    }
    free(site), free(cl), free(size), free(rg);
    dlca_destroy(s);
    return rc;
}
