/*
 * dlca_state.c - the DLCA simulation's state as a whole: the full
 * consistency check (dlca_check) and checkpoints (write, load). Split from
 * dlca.c, which holds the dynamics; both see the state through dlca_sim.h.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "dlca_h5.h"
#include "dlca_internal.h"
#include "dlca_sim.h"
#include "pdla/h5check.h"

/* ---- the consistency check ----------------------------------------------- */

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

#define BAD(...) return pdla_errorf(PDLA_EINVAL, err, errlen, __VA_ARGS__)

/* One cluster: active-list entry, sites against offsets and anchor, the id
 * lattice, the bounding box. Appends (site << 32 | slot) to ks. */
static int check_cluster(const dlca_sim *s, uint32_t c, uint64_t *ks, uint64_t *m, char *err, size_t errlen)
{
    const int d = s->d;
    if (s->pos[c] >= s->nc || s->act[s->pos[c]] != c) BAD("cluster %u is not in the active list", c);
    const uint64_t r = s->ref[c] & ~DLCA_EMPTY; /* its block: the arena holds it whole, it is c's, n fits */
    if (s->ref[c] > DLCA_EMPTY && (r + DLCA_REC_HEAD(d) > s->ar_top || s->ar[r - 1] != c || s->ar[r + 1] < 2 ||
                                   s->ar[r] < s->ar[r + 1] || r + DLCA_REC_WORDS(d, s->ar[r]) > s->ar_top))
        BAD("cluster %u has no block of its monomers", c);
    if (s->ref[c] < DLCA_EMPTY && s->ref[c] >= s->V) BAD("monomer %u lies outside the box", c);
    if (*m + dlca_n(s, c) > s->N) BAD("cluster sizes add up to more than N = %llu", (unsigned long long)s->N);
    dlca_view v;
    view_of(s, c, &v);
    /* The moves find the face that wraps by window() (dlca.c), which needs
     * the anchor inside the box and its own offset (0) in the bounding box:
     * sites alone wrap, so an anchor shifted by L matched them and a
     * resumed run stepped monomers off the lattice (heap overflow). */
    for (int a = 0; a < d; a++)
        if (v.anc[a] < 0 || v.anc[a] >= s->L[a] || v.lo[a] > 0 || v.hi[a] < 0)
            BAD("cluster %u: anchor or bounding box outside the box", c);
    int32_t tlo[DLCA_MAX_DIM], thi[DLCA_MAX_DIM];
    for (int a = 0; a < d; a++) tlo[a] = thi[a] = v.off[a];
    for (uint32_t i = 0; i < v.n; i++) {
        int64_t x[DLCA_MAX_DIM];
        for (int a = 0; a < d; a++) {
            const int32_t o = v.off[(size_t)i * d + a];
            x[a] = (int64_t)v.anc[a] + o;
            if (o < tlo[a]) tlo[a] = o;
            if (o > thi[a]) thi[a] = o;
        }
        if (dlca_site(s, x) != v.k[i]) BAD("cluster %u monomer %u: site %u does not match its offset", c, i, v.k[i]);
        if (s->occ && !dlca_occ(s, v.k[i])) BAD("site %u of cluster %u is not set in the bit lattice", v.k[i], c);
        ks[(*m)++] = (uint64_t)v.k[i] << 32 | c;
    }
    for (int a = 0; a < d; a++) {
        if (tlo[a] != v.lo[a] || thi[a] != v.hi[a]) BAD("cluster %u: bounding box is stale", c);
        if (!s->spanning && (int64_t)v.hi[a] - v.lo[a] + 1 >= s->L[a])
            BAD("cluster %u spans axis %d but the run did not stop", c, a);
    }
    return 0;
}

/* The counters against the clusters: N_c, largest, sum of s^2, smallest. */
static int check_counts(const dlca_sim *s, uint64_t m, char *err, size_t errlen)
{
    uint64_t active = 0, largest = 0, smin = s->N;
    double s2 = 0;
    for (uint64_t c = 1; c <= s->nslot; c++) {
        if (!dlca_n(s, c)) continue;
        if (dlca_slot_id(s, c) > s->N || (c > 1 && dlca_slot_id(s, c) <= dlca_slot_id(s, c - 1)))
            BAD("slot %llu is named out of order", (unsigned long long)c);
        active++;
        if (dlca_n(s, c) > largest) largest = dlca_n(s, c);
        if (dlca_n(s, c) < smin) smin = dlca_n(s, c);
        s2 += (double)dlca_n(s, c) * dlca_n(s, c);
    }
    if (m != s->N) BAD("cluster sizes add up to %llu, not N = %llu", (unsigned long long)m, (unsigned long long)s->N);
    if (active != s->nc)
        BAD("%llu clusters hold monomers, N_c says %llu", (unsigned long long)active, (unsigned long long)s->nc);
    if (largest != s->largest)
        BAD("largest cluster %llu, recorded %llu", (unsigned long long)largest, (unsigned long long)s->largest);
    if (s2 != s->sum_s2) BAD("sum of s^2 %.0f, recorded %.0f", s2, s->sum_s2);
    if (s->size_count && smin != s->smin)
        BAD("smallest cluster %llu, recorded %llu", (unsigned long long)smin, (unsigned long long)s->smin);
    return 0;
}

/* Sorted (site << 32 | slot): no site twice; the lattice holds N sites. */
static int check_sites(const dlca_sim *s, const uint64_t *ks, uint64_t m, char *err, size_t errlen)
{
    for (uint64_t j = 1; j < m; j++)
        if (ks[j] >> 32 == ks[j - 1] >> 32) BAD("two monomers on site %llu", (unsigned long long)(ks[j] >> 32));
    if (s->occ) {
        uint64_t filled = 0;
        for (uint64_t w = 0; w < (s->V + 63) / 64; w++) filled += (uint64_t)__builtin_popcountll(s->occ[w]);
        if (filled != s->N)
            BAD("the bit lattice holds %llu sites, N = %llu", (unsigned long long)filled, (unsigned long long)s->N);
    }
    return 0;
}

/* The entry of ks (sorted, m of them) on site k, or m. */
static uint64_t entry_at(const uint64_t *ks, uint64_t m, uint64_t k)
{
    uint64_t lo = 0, hi = m;
    while (lo < hi) {
        const uint64_t mid = (lo + hi) / 2;
        if (ks[mid] >> 32 < k) lo = mid + 1;
        else hi = mid;
    }
    return lo < m && ks[lo] >> 32 == k ? lo : m;
}

static uint32_t uf_root(uint32_t *uf, uint32_t j)
{
    while (uf[j] != j) j = uf[j] = uf[uf[j]];
    return j;
}

/* The cluster (slot) with two pieces, after the unions: the first slot
 * seen with a second root. */
static uint32_t split_slot(const dlca_sim *s, const uint64_t *ks, uint64_t m, uint32_t *uf)
{
    uint32_t *root = calloc(s->nslot + 1, sizeof *root); /* root + 1 per slot */
    uint32_t bad = 0;
    for (uint64_t j = 0; root && j < m && !bad; j++) {
        const uint32_t c = (uint32_t)ks[j], r = uf_root(uf, (uint32_t)j) + 1;
        if (root[c] && root[c] != r) bad = c;
        root[c] = r;
    }
    free(root);
    return bad;
}

/* Face contacts over ks (sorted): each cluster one face-connected piece
 * on the torus (a forged slot of two far-apart monomers resumed and passed
 * --check); with sticking 1 no two clusters touch, save at a spanning stop
 * (checkpoints of such stops written before session 29 left the step's
 * last contacts unjoined). Through the torus, not the offsets: they are
 * the same for a cluster narrower than L (two pieces whose offsets differ
 * by L on an axis would need L + 1 sites), and a spanning cluster's
 * offsets are any images of its sites (dlca.c, append). */
static int check_contacts(const dlca_sim *s, const uint64_t *ks, uint64_t m, char *err, size_t errlen)
{
    uint32_t *uf = malloc((m ? m : 1) * sizeof *uf);
    if (!uf) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory");
    for (uint64_t j = 0; j < m; j++) uf[j] = (uint32_t)j;
    const int apart = s->p.sticking >= 1 && !s->spanning;
    uint64_t pieces = m;
    for (uint64_t j = 0; j < m; j++) {
        int64_t x[DLCA_MAX_DIM];
        dlca_coords(s, ks[j] >> 32, x);
        for (int dir = 0; dir < 2 * s->d; dir += 2) { /* +1 on each axis: each contact once */
            x[dir >> 1]++;
            const uint64_t o = entry_at(ks, m, dlca_site(s, x));
            x[dir >> 1]--;
            if (o == m) continue;
            if ((uint32_t)ks[o] != (uint32_t)ks[j]) {
                if (!apart) continue;
                free(uf);
                BAD("clusters %llu and %llu touch but did not join", (unsigned long long)(uint32_t)ks[j],
                    (unsigned long long)(uint32_t)ks[o]);
            }
            const uint32_t a = uf_root(uf, (uint32_t)j), b = uf_root(uf, (uint32_t)o);
            if (a != b) uf[a > b ? a : b] = a > b ? b : a, pieces--;
        }
    }
    const uint32_t split = pieces == s->nc ? 0 : split_slot(s, ks, m, uf);
    free(uf);
    if (pieces != s->nc) BAD("cluster %u is not face-connected (its monomers are in pieces)", split);
    return 0;
}

/* An entry span_walk has not reached (img of its first axis). */
#define SPAN_UNSEEN INT8_MIN

/* Does the cluster of entry j0 of ks (sorted) span? A walk over its face
 * contacts on the torus (breadth first) gives each monomer unwrapped
 * coordinates u = x + img * L (x on the torus); it spans if they reach an
 * extent >= L on an axis, or if a monomer is reached again at other
 * coordinates (a loop that winds round the torus). Each is walked to at
 * most once, so img stays in {-1, 0, 1} (the extent so far is below L and
 * holds the start, in [0, L)). */
static int span_walk(const dlca_sim *s, const uint64_t *ks, uint64_t m, uint64_t j0, int8_t *img, uint32_t *queue)
{
    const int d = s->d;
    const uint32_t c = (uint32_t)ks[j0];
    int64_t lo[DLCA_MAX_DIM], hi[DLCA_MAX_DIM], x[DLCA_MAX_DIM], y[DLCA_MAX_DIM], u[DLCA_MAX_DIM];
    dlca_coords(s, ks[j0] >> 32, x);
    for (int a = 0; a < d; a++) lo[a] = hi[a] = x[a], img[j0 * d + a] = 0;
    uint64_t head = 0, tail = 0;
    queue[tail++] = (uint32_t)j0;
    while (head < tail) {
        const uint64_t j = queue[head++];
        dlca_coords(s, ks[j] >> 32, x);
        for (int dir = 0; dir < 2 * d; dir++) {
            for (int a = 0; a < d; a++) u[a] = x[a] + img[j * d + a] * s->L[a];
            u[dir >> 1] += dir & 1 ? -1 : 1;
            const uint64_t o = entry_at(ks, m, dlca_site(s, u));
            if (o == m || (uint32_t)ks[o] != c) continue;
            dlca_coords(s, ks[o] >> 32, y);
            if (img[o * d] != SPAN_UNSEEN) {
                for (int a = 0; a < d; a++)
                    if (y[a] + img[o * d + a] * s->L[a] != u[a]) return 1; /* differs by a multiple of L */
                continue;
            }
            for (int a = 0; a < d; a++) {
                img[o * d + a] = (int8_t)((u[a] - y[a]) / s->L[a]);
                if (u[a] < lo[a]) lo[a] = u[a];
                if (u[a] > hi[a]) hi[a] = u[a];
                if (hi[a] - lo[a] + 1 >= s->L[a]) return 1;
            }
            queue[tail++] = (uint32_t)o;
        }
    }
    return 0;
}

/* A spanning stop needs a cluster that spans (extent >= L on an axis):
 * a forged flag ended a resumed run at once, "stop: spanning" with an
 * 11-monomer largest cluster, and turned off the contact and box checks.
 * Walked over the contacts on the torus, not read from the offsets: with
 * the flag set a cluster's offsets may be any images of its sites (dlca.c,
 * append), so two neighbours stored L - 1 apart made a forged checkpoint
 * of 2-monomer clusters "span" (and stop at once). A cluster of fewer
 * monomers than the shortest side cannot span and is not walked. */
static int check_spanning(const dlca_sim *s, const uint64_t *ks, uint64_t m, char *err, size_t errlen)
{
    if (!s->spanning) return 0;
    int64_t lmin = s->L[0];
    for (int a = 1; a < s->d; a++)
        if (s->L[a] < lmin) lmin = s->L[a];
    int8_t *img = malloc((m ? m : 1) * (size_t)s->d);
    uint32_t *queue = malloc((m ? m : 1) * sizeof *queue);
    int spans = 0, nomem = !img || !queue;
    if (!nomem) memset(img, (unsigned char)SPAN_UNSEEN, m * (size_t)s->d);
    for (uint64_t j = 0; !nomem && !spans && j < m; j++)
        if (img[j * s->d] == SPAN_UNSEEN && dlca_n(s, (uint32_t)ks[j]) >= (uint64_t)lmin)
            spans = span_walk(s, ks, m, j, img, queue);
    free(img), free(queue);
    if (nomem) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory");
    if (!spans) BAD("it records a spanning cluster, but no cluster spans the box (none winds round or reaches L)");
    return 0;
}
#undef SPAN_UNSEEN

/* Is c listed in every box of the range b0, cnt? */
static int listed_in(const dlca_sim *s, uint32_t c, const int32_t *b0, const int32_t *cnt)
{
    int32_t i[DLCA_MAX_DIM] = {0};
    for (;;) {
        uint64_t box = 0;
        for (int a = 0; a < s->d; a++) box += (uint64_t)dlca_wrap(b0[a] + i[a], s->nb[a]) * (uint64_t)s->bstride[a];
        uint32_t j = 0;
        while (j < s->box_n[box] && s->box[box][j] != c) j++;
        if (j == s->box_n[box]) return 0;
        int a = 0;
        while (a < s->d && ++i[a] == cnt[a]) i[a++] = 0;
        if (a == s->d) return 1;
    }
}

/* The grid boxes (the seed's, or the lookup boxes of --search lattice)
 * list every cluster where its bounding box lies, and nothing else. */
static int check_boxes(const dlca_sim *s, char *err, size_t errlen)
{
    if (!s->box || s->spanning) return 0; /* a spanning join stops the bookkeeping */
    const int d = s->d;
    uint64_t listed = 0, expect = 0;
    for (uint64_t b = 0; b < s->nboxes; b++) listed += s->box_n[b];
    for (uint64_t j = 0; j < s->nc; j++) {
        const uint32_t c = s->act[j];
        dlca_view v;
        view_of(s, c, &v);
        int32_t b0[DLCA_MAX_DIM], cnt[DLCA_MAX_DIM];
        dlca_cluster_span(s, &v, v.anc, 0, b0, cnt);
        if (s->brange) {
            const int32_t *r = dlca_brange(s, c);
            if (memcmp(b0, r, (size_t)d * sizeof *b0) || memcmp(cnt, r + d, (size_t)d * sizeof *cnt))
                BAD("cluster %u is registered in stale boxes", c);
        }
        if (!listed_in(s, c, b0, cnt)) BAD("cluster %u is missing from a box its bounding box covers", c);
        uint64_t e = 1;
        for (int a = 0; a < d; a++) {
            e *= (uint64_t)cnt[a];
            if ((int64_t)v.hi[a] - v.lo[a] + 1 > s->A) BAD("cluster %u is wider than A = %d", c, s->A);
        }
        expect += e;
    }
    if (listed != expect)
        BAD("boxes list %llu entries, expected %llu", (unsigned long long)listed, (unsigned long long)expect);
    return 0;
}
/* The arena walks block by block to its top; a live block is its owner's,
 * the freed words add up. */
static int check_arena(const dlca_sim *s, char *err, size_t errlen)
{
    uint64_t p = 0, freed = 0;
    while (p < s->ar_top) {
        if (p + 2 > s->ar_top) BAD("the block arena ends inside a block head");
        const uint32_t owner = s->ar[p];
        const uint64_t w = DLCA_BLK_WORDS(s->d, s->ar[p + 1]);
        if (!owner) freed += w;
        else if (owner > s->nslot || s->ref[owner] != ((uint32_t)(p + 1) | DLCA_EMPTY))
            BAD("an arena block at %llu names slot %u, which is not its owner", (unsigned long long)p, owner);
        p += w;
    }
    if (p != s->ar_top) BAD("the block arena overruns its top");
    if (freed != s->ar_free) BAD("the block arena has %llu freed words, counted %llu", (unsigned long long)freed,
                                 (unsigned long long)s->ar_free);
    return 0;
}
#undef BAD

int dlca_check(const dlca_sim *s, char *err, size_t errlen)
{
    uint64_t *ks = malloc(s->N * sizeof *ks); /* (site << 32) | slot */
    if (!ks) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory");
    uint64_t m = 0;
    int rc = 0;
    for (uint64_t c = 1; c <= s->nslot && rc == 0; c++)
        if (dlca_n(s, c)) rc = check_cluster(s, (uint32_t)c, ks, &m, err, errlen);
    if (rc == 0) rc = check_counts(s, m, err, errlen);
    if (rc == 0) {
        qsort(ks, m, sizeof *ks, cmp_u64);
        rc = check_sites(s, ks, m, err, errlen);
        if (rc == 0) rc = check_contacts(s, ks, m, err, errlen);
        if (rc == 0) rc = check_spanning(s, ks, m, err, errlen);
    }
    if (rc == 0) rc = check_boxes(s, err, errlen);
    if (rc == 0) rc = check_arena(s, err, errlen);
    free(ks);
    return rc;
}

/* ---- checkpoints ---------------------------------------------------------- */

/* The scalars of the state, in one array of doubles and one of u64. */
enum { CK_U_ATT, CK_U_MOV, CK_U_MMOV, CK_U_MRG, CK_U_LARGE, CK_U_CAND, CK_U_DIG, CK_U_NC, CK_U_ROWNC, CK_U_SMIN,
       CK_U_A, CK_U_SEARCH, CK_U_SPAN, CK_U_STOP, CK_U_N, CK_NU };
enum { CK_D_T, CK_D_S2, CK_ND };

static int ck_write(const h5u_writer *w, hid_t loc, const char *name, hid_t ftype, hid_t mtype, const void *data,
                    size_t n)
{
    hid_t space = H5I_INVALID_HID, d;
    int rc = 0;
    if ((d = h5u_dataset(w, loc, name, ftype, 1, n, 1, n > 65536 ? 65536 : (n ? n : 1), &space)) < 0) return -1;
    if (n > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) rc = h5u_fail(w, "write %s", name);
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

/* The state as the checkpoint format (version 1) lays it out: per slot
 * (by its name: the slots as they were before any compaction) its size and
 * anchor + bounding box, per monomer (slot order) site and offset, the
 * active list (names), the series as two arrays. */
typedef struct ck_arrays {
    uint32_t *slot_n, *k, *act;
    int32_t *off, *geom;
    double *rt;
    uint64_t *ru;
} ck_arrays;

static void ck_free(ck_arrays *a)
{
    free(a->slot_n), free(a->k), free(a->act), free(a->off), free(a->geom), free(a->rt), free(a->ru);
}

static int ck_alloc(ck_arrays *a, uint64_t N, int d, size_t nrows)
{
    a->slot_n = calloc(N + 1, sizeof *a->slot_n);
    a->k = malloc(N * sizeof *a->k);
    a->act = malloc((N ? N : 1) * sizeof *a->act);
    a->off = malloc(N * (size_t)d * sizeof *a->off);
    a->geom = calloc((N + 1) * 3 * (size_t)d, sizeof *a->geom);
    a->rt = malloc((nrows + 1) * 3 * sizeof *a->rt);
    a->ru = malloc((nrows + 1) * 3 * sizeof *a->ru);
    return a->slot_n && a->k && a->act && a->off && a->geom && a->rt && a->ru ? 0 : -1;
}

static void ck_gather(const dlca_sim *s, ck_arrays *a)
{
    const int d = s->d;
    uint64_t m = 0;
    for (uint64_t c = 1; c <= s->nslot; c++) {
        if (!dlca_n(s, c)) continue;
        const uint32_t name = dlca_slot_id(s, c);
        a->slot_n[name] = dlca_n(s, c);
        dlca_view v;
        view_of(s, (uint32_t)c, &v);
        int32_t *g = a->geom + name * 3 * (size_t)d;
        memcpy(g, v.anc, (size_t)d * sizeof *g);
        memcpy(g + d, v.lo, (size_t)d * sizeof *g);
        memcpy(g + 2 * d, v.hi, (size_t)d * sizeof *g);
        memcpy(a->k + m, v.k, v.n * sizeof *a->k);
        for (size_t j = 0; j < (size_t)v.n * d; j++) a->off[m * d + j] = v.off[j];
        m += v.n;
    }
    for (uint64_t j = 0; j < s->nc; j++) a->act[j] = dlca_slot_id(s, s->act[j]);
    for (size_t r = 0; r < s->nrows; r++) {
        const dlca_row *w = &s->rows[r];
        a->rt[3 * r] = w->t, a->rt[3 * r + 1] = w->mean_size, a->rt[3 * r + 2] = w->weight_size;
        a->ru[3 * r] = w->attempts, a->ru[3 * r + 1] = w->n_clusters, a->ru[3 * r + 2] = w->largest;
    }
}

int dlca_checkpoint_write(const dlca_sim *s, const char *path, char *err, size_t errlen)
{
    h5u_writer w = {path, err, errlen};
    h5u_quiet q;
    if (h5u_silence(&q)) return pdla_errorf(PDLA_EIO, err, errlen, "cannot silence HDF5");
    const int d = s->d;
    const uint64_t u[CK_NU] = {s->attempts, s->moves, s->monomer_moves, s->merges, s->largest, s->candidates,
                               s->digest, s->nc, s->row_nc, s->smin, (uint64_t)s->A, (uint64_t)s->search_now,
                               (uint64_t)s->spanning, (uint64_t)s->stop, s->N};
    const double dv[CK_ND] = {s->t, s->sum_s2};
    ck_arrays a = {0};
    hid_t file = H5I_INVALID_HID;
    int rc = -1;
    if (ck_alloc(&a, s->N, d, s->nrows)) {
        h5u_fail_msg(&w, "cannot write %s: out of memory", path);
        goto done;
    }
    ck_gather(s, &a);
    if ((file = h5u_create_file(&w, path)) < 0) goto done;
    if (h5u_attr_str(&w, file, "model", "dlca-checkpoint") < 0 || h5u_attr_int(&w, file, "format_version", 1) < 0 ||
        h5u_attr_f64(&w, file, "schedule_every_seconds", s->sched.every_seconds) < 0 ||
        h5u_attr_u64(&w, file, "schedule_every_attempts", s->sched.every_attempts) < 0 ||
        dlca_write_parameters_h5(&w, file, &s->p) < 0 ||
        ck_write(&w, file, "rng", H5T_STD_U64LE, H5T_NATIVE_UINT64, s->rng.s, 4) < 0 ||
        ck_write(&w, file, "u64", H5T_STD_U64LE, H5T_NATIVE_UINT64, u, CK_NU) < 0 ||
        ck_write(&w, file, "f64", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, dv, CK_ND) < 0 ||
        ck_write(&w, file, "slot_n", H5T_STD_U32LE, H5T_NATIVE_UINT32, a.slot_n, s->N + 1) < 0 ||
        ck_write(&w, file, "geom", H5T_STD_I32LE, H5T_NATIVE_INT32, a.geom, (s->N + 1) * 3 * (size_t)d) < 0 ||
        ck_write(&w, file, "active", H5T_STD_U32LE, H5T_NATIVE_UINT32, a.act, s->nc) < 0 ||
        ck_write(&w, file, "site", H5T_STD_U32LE, H5T_NATIVE_UINT32, a.k, s->N) < 0 ||
        ck_write(&w, file, "offset", H5T_STD_I32LE, H5T_NATIVE_INT32, a.off, s->N * (size_t)d) < 0 ||
        ck_write(&w, file, "rows_f64", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, a.rt, 3 * s->nrows) < 0 ||
        ck_write(&w, file, "rows_u64", H5T_STD_U64LE, H5T_NATIVE_UINT64, a.ru, 3 * s->nrows) < 0)
        goto done;
    rc = 0;
done:
    if (file >= 0) rc = h5u_close(&w, rc, file, H5Fclose, path);
    ck_free(&a);
    if (h5u_restore(&q) < 0 && rc == 0) rc = h5u_fail_msg(&w, "cannot restore the HDF5 error handler");
    return rc < 0 ? PDLA_EIO : 0;
}

/* Opens dataset name through the checked reader (pdla/h5check.h): rank 1,
 * elements of t's class and size, and the bytes it declares stored in the
 * file, so a forged checkpoint declaring 2^61 rows in a few KB is refused
 * before anything is sized by it. 0, or -1 (d closed). */
static int ck_open(hid_t f, const char *name, pdla_h5_type t, pdla_h5_dset *d)
{
    const size_t esize = t == PDLA_H5_U64 || t == PDLA_H5_I64 || t == PDLA_H5_F64 ? 8 : t == PDLA_H5_U8 ? 1 : 4;
    if (pdla_h5_dset_open(f, name, d) == 0 && d->rank == 1 && pdla_h5_dset_is(d, t) &&
        pdla_h5_dset_stored(d, esize) == PDLA_H5_STORED)
        return 0;
    (void)pdla_h5_dset_close(d); /* -1 either way */
    return -1;
}

/* Read dataset name of exactly n elements of type t. */
static int ck_read(hid_t f, const char *name, pdla_h5_type t, void *buf, size_t n)
{
    pdla_h5_dset d;
    if (ck_open(f, name, t, &d)) return -1;
    const int rc = d.elems == n && pdla_h5_dset_read(&d, t, 0, n, buf) == 0 ? 0 : -1;
    return pdla_h5_dset_close(&d) < 0 ? -1 : rc;
}

/* Elements in dataset name (of type t) / per (0 if it is missing or not
 * stored). */
static size_t ck_rows(hid_t f, const char *name, pdla_h5_type t, size_t per)
{
    pdla_h5_dset d;
    if (ck_open(f, name, t, &d)) return 0;
    const size_t n = (size_t)(d.elems / per);
    return pdla_h5_dset_close(&d) < 0 ? 0 : n; /* unreadable: as missing */
}

/* What a load failed on: the return code and the reason. */
#define LOAD_FAIL(code, ...)                         \
    do {                                             \
        snprintf(why, whylen, __VA_ARGS__);          \
        return (code);                               \
    } while (0)

/* The clusters from the arrays: sizes, records, sites, offsets, lattice. */
static int load_clusters(dlca_sim *s, const ck_arrays *a, char *why, size_t whylen)
{
    const int d = s->d;
    uint64_t m = 0;
    for (uint64_t c = 1; c <= s->N; c++) {
        const uint32_t n = a->slot_n[c];
        if (!n) continue;
        if (m + n > s->N) LOAD_FAIL(PDLA_EIO, "its cluster sizes add up to more than N");
        const int32_t *g = a->geom + c * 3 * (size_t)d;
        if (n == 1) s->ref[c] = a->k[m];
        else {
            if (dlca_blk_new(s, (uint32_t)c, n)) LOAD_FAIL(PDLA_ENOMEM, "out of memory");
            uint32_t *b = dlca_blk(s, (uint32_t)c);
            b[1] = n;
            memcpy(dlca_bsites(s, b), a->k + m, n * sizeof *a->k); /* cap n: offsets follow */
            dlca_off *off = (dlca_off *)(dlca_bsites(s, b) + n);
            for (size_t j = 0; j < (size_t)n * d; j++) {
                const int32_t o = a->off[m * d + j];
                if (o < INT16_MIN || o > INT16_MAX) LOAD_FAIL(PDLA_EIO, "an offset is out of range");
                off[j] = (dlca_off)o;
            }
            dlca_off *geo = dlca_bgeom(b);
            for (int j = 0; j < 3 * d; j++) {
                if (g[j] < INT16_MIN || g[j] > INT16_MAX) LOAD_FAIL(PDLA_EIO, "an anchor or bounding box is out of range");
                geo[j] = (dlca_off)g[j];
            }
        }
        for (uint32_t i = 0; i < n; i++) {
            if (a->k[m + i] >= s->V || dlca_occ(s, a->k[m + i])) LOAD_FAIL(PDLA_EIO, "a site is outside the box or taken twice");
            dlca_occ_set(s, a->k[m + i]);
        }
        m += n;
    }
    return 0;
}

/* The counters the dynamics never read but cluster.h5 and the summary
 * print, against what the run could have counted (a forged checkpoint
 * resumed with 10^9 joins of 115 monomers and wrote them): a join is one
 * cluster fewer, a move moves 1 to `largest` monomers, an attempt moves at
 * most once and pair-tests at most N clusters; row_nc is N_c at the last
 * row (the dynamics read it: 0 stopped the series, 10^12 added a row each
 * attempt) and smin the smallest size (1 when no mobility needs it). */
static int check_counters(const dlca_sim *s, char *why, size_t whylen)
{
    const double att = (double)s->attempts, mov = (double)s->moves;
    if (s->merges != s->N - s->nc)
        LOAD_FAIL(PDLA_EIO, "its merges counter %llu is not N - N_c = %llu", (unsigned long long)s->merges,
                  (unsigned long long)(s->N - s->nc));
    if (s->moves > s->attempts)
        LOAD_FAIL(PDLA_EIO, "its moves counter %llu is more than its %llu attempts", (unsigned long long)s->moves,
                  (unsigned long long)s->attempts);
    if (s->monomer_moves < s->moves || (double)s->monomer_moves > mov * (double)s->largest)
        LOAD_FAIL(PDLA_EIO, "its monomer moves counter %llu is not in [moves, moves x largest]",
                  (unsigned long long)s->monomer_moves);
    if ((double)s->candidates > att * (double)s->N)
        LOAD_FAIL(PDLA_EIO, "its candidates counter %llu is more than attempts x N", (unsigned long long)s->candidates);
    if (s->row_nc < s->nc || s->row_nc > s->N)
        LOAD_FAIL(PDLA_EIO, "its series counter row_nc %llu is not in [N_c, N]", (unsigned long long)s->row_nc);
    if (s->smin < 1 || s->smin > s->largest)
        LOAD_FAIL(PDLA_EIO, "its smallest cluster size %llu is not in [1, largest]", (unsigned long long)s->smin);
    return 0;
}

/* Row w of a series after prev (NULL for the first), against the state at
 * the series' end (end: its t, attempts, n_clusters and largest; N its
 * monomers): times and attempts in order and not past the end's, N_c not
 * rising and not below the end's, each row later than the one before
 * (fewer clusters: N_c fell by 1%; or more attempts: the row of a stop),
 * the largest size growing and not above the end's, the two average sizes
 * finite in [1, N] (the series is written to cluster.h5 as it is: a forged
 * NaN or 10^9 clusters went there without a word). NULL, or the first
 * field out of range. The loader and `pdla check` (dlca_check_h5.c) share
 * it, so a file and a checkpoint are held to one rule. */
const char *dlca_row_fault(const dlca_row *w, const dlca_row *prev, const dlca_row *end, uint64_t N)
{
    if (!isfinite(w->t) || w->t < (prev ? prev->t : 0) || w->t > end->t) return "t";
    if (w->attempts > end->attempts || (prev && w->attempts < prev->attempts)) return "attempts";
    if (w->n_clusters < end->n_clusters || w->n_clusters > (prev ? prev->n_clusters : N) ||
        (prev && w->n_clusters == prev->n_clusters && w->attempts == prev->attempts))
        return "n_clusters";
    if (w->largest < 1 || w->largest > end->largest || (prev && w->largest < prev->largest)) return "largest";
    if (!(w->mean_size >= 1 && w->mean_size <= (double)N)) return "mean_size";
    if (!(w->weight_size >= 1 && w->weight_size <= (double)N)) return "weight_size";
    return NULL;
}

/* Row r of the series against the state (dlca_row_fault). */
static int check_row(const dlca_sim *s, size_t r, const dlca_row *w, const dlca_row *prev, char *why, size_t whylen)
{
    const dlca_row end = {.t = s->t, .attempts = s->attempts, .n_clusters = s->nc, .largest = s->largest};
    const char *bad = dlca_row_fault(w, prev, &end, s->N);
    if (bad) LOAD_FAIL(PDLA_EIO, "its series row %zu has %s out of range (or out of order)", r, bad);
    return 0;
}

/* The counters, the active list and the series. */
static int load_counters(dlca_sim *s, hid_t f, const uint64_t *u, const double *dv, char *why, size_t whylen)
{
    if (ck_read(f, "rng", PDLA_H5_U64, s->rng.s, 4) || u[CK_U_NC] > s->N ||
        ck_read(f, "active", PDLA_H5_U32, s->act, u[CK_U_NC]))
        LOAD_FAIL(PDLA_EIO, "its state arrays are missing or have the wrong length");
    s->nc = u[CK_U_NC];
    for (uint64_t j = 0; j < s->nc; j++) {
        if (s->act[j] < 1 || s->act[j] > s->N || !dlca_n(s, s->act[j])) LOAD_FAIL(PDLA_EIO, "its active list names an empty cluster");
        s->pos[s->act[j]] = (uint32_t)j;
    }
    s->attempts = u[CK_U_ATT], s->moves = u[CK_U_MOV], s->monomer_moves = u[CK_U_MMOV];
    s->merges = u[CK_U_MRG], s->largest = u[CK_U_LARGE], s->candidates = u[CK_U_CAND];
    s->digest = u[CK_U_DIG], s->row_nc = u[CK_U_ROWNC], s->smin = u[CK_U_SMIN];
    s->spanning = (int)u[CK_U_SPAN], s->stop = (int)u[CK_U_STOP];
    s->t = dv[CK_D_T], s->sum_s2 = dv[CK_D_S2];
    /* What the dynamics trust (session 11: each of these resumed without a
     * word; a zero RNG state moves every cluster the same way forever) */
    if (!isfinite(s->t) || s->t < 0) LOAD_FAIL(PDLA_EIO, "its time is negative or not finite");
    /* Stopped by spanning with no cluster spanning: the resumed run ended at
     * once, "stop: spanning" (a spanning cluster without the flag fails
     * dlca_check). */
    if (u[CK_U_SPAN] > 1 || u[CK_U_STOP] > DLCA_STOP_CALLER || (u[CK_U_STOP] == DLCA_STOP_SPANNING && !u[CK_U_SPAN]))
        LOAD_FAIL(PDLA_EIO, "its stop state is out of range");
    if (!(s->rng.s[0] | s->rng.s[1] | s->rng.s[2] | s->rng.s[3])) LOAD_FAIL(PDLA_EIO, "its random state is all zero");
    const int crc = check_counters(s, why, whylen);
    if (crc) return crc;
    if (s->size_count)
        for (uint64_t j = 0; j < s->nc; j++) s->size_count[dlca_n(s, s->act[j])]++;
    const size_t nr = ck_rows(f, "rows_u64", PDLA_H5_U64, 3);
    double *rt = malloc((nr + 1) * 3 * sizeof *rt);
    uint64_t *ru = malloc((nr + 1) * 3 * sizeof *ru);
    s->rows = malloc((nr + 1) * sizeof *s->rows);
    int rc = 0;
    if (!rt || !ru || !s->rows) rc = PDLA_ENOMEM, snprintf(why, whylen, "out of memory");
    else if (ck_read(f, "rows_f64", PDLA_H5_F64, rt, 3 * nr) || ck_read(f, "rows_u64", PDLA_H5_U64, ru, 3 * nr))
        rc = PDLA_EIO, snprintf(why, whylen, "its series is damaged");
    for (size_t r = 0; rc == 0 && r < nr; r++) {
        s->rows[r] = (dlca_row){rt[3 * r], ru[3 * r], ru[3 * r + 1], ru[3 * r + 2], rt[3 * r + 1], rt[3 * r + 2]};
        rc = check_row(s, r, &s->rows[r], r ? &s->rows[r - 1] : NULL, why, whylen);
    }
    s->nrows = rc ? 0 : nr;
    s->caprows = s->rows ? nr + 1 : 0;
    free(rt), free(ru);
    return rc;
}

/* The whole state from an open checkpoint file. */
static int load_state(dlca_sim **out, hid_t f, char *why, size_t whylen)
{
    dlca_params p; /* the parameters, through the table: every field the writer wrote */
    dlca_params_default(&p);
    if (dlca_read_parameters_h5(f, &p, 1)) LOAD_FAIL(PDLA_EIO, "not a DLCA checkpoint (no readable /parameters)");
    uint64_t u[CK_NU];
    double dv[CK_ND];
    if (ck_read(f, "u64", PDLA_H5_U64, u, CK_NU) || ck_read(f, "f64", PDLA_H5_F64, dv, CK_ND))
        LOAD_FAIL(PDLA_EIO, "not a DLCA checkpoint (no state)");
    /* count as the run was given it (0: from fill), kept so that a resumed
     * run's cluster.h5 records the same /parameters as an uninterrupted one
     * (before: count = N); it must give the N the state holds. */
    const uint64_t given = p.count;
    if (dlca_params_monomers(&p) != u[CK_U_N])
        LOAD_FAIL(PDLA_EIO, "its %llu monomers are not the %llu its parameters give (count %llu, fill %.17g)",
                  (unsigned long long)u[CK_U_N], (unsigned long long)dlca_params_monomers(&p),
                  (unsigned long long)given, p.fill);
    p.count = u[CK_U_N];
    if (dlca_params_validate(&p, why, whylen)) return PDLA_EIO;
    const int d = p.dim;
    /* Before N sizes memory: the file must store N monomers (a forged N of
     * 2e8 in a few KB allocated and touched 795 MB), and a box side the
     * boxes search can double from (0 or one not a power of two >= the
     * first side looped for ever in dlca_search_init). */
    if (ck_rows(f, "site", PDLA_H5_U32, 1) != p.count || ck_rows(f, "slot_n", PDLA_H5_U32, 1) != p.count + 1)
        LOAD_FAIL(PDLA_EIO, "its monomer arrays are missing or have the wrong length");
    /* A starts at grid_box and doubles until it holds the widest cluster,
     * so it never passes the first power of two >= the longest box side. */
    uint64_t a_max = (uint64_t)p.grid_box;
    for (int k = 0; k < d; k++)
        while (a_max < p.box[k]) a_max *= 2;
    if (p.search == DLCA_SEARCH_BOXES &&
        (u[CK_U_A] < (uint64_t)p.grid_box || u[CK_U_A] > a_max || (u[CK_U_A] & (u[CK_U_A] - 1))))
        LOAD_FAIL(PDLA_EIO, "its grid-box side %llu is not a power of two in [grid_box, %llu]",
                  (unsigned long long)u[CK_U_A], (unsigned long long)a_max);
    ck_arrays a = {0};
    int rc = PDLA_EIO;
    if (dlca_sim_alloc(out, &p, p.count) || ck_alloc(&a, p.count, d, 0)) rc = PDLA_ENOMEM, snprintf(why, whylen, "out of memory");
    else if (ck_read(f, "slot_n", PDLA_H5_U32, a.slot_n, p.count + 1) ||
             ck_read(f, "site", PDLA_H5_U32, a.k, p.count) ||
             ck_read(f, "offset", PDLA_H5_I32, a.off, p.count * (size_t)d) ||
             ck_read(f, "geom", PDLA_H5_I32, a.geom, (p.count + 1) * 3 * (size_t)d))
        snprintf(why, whylen, "its monomer arrays are missing or have the wrong length");
    else if (!(rc = load_clusters(*out, &a, why, whylen)) && !(rc = load_counters(*out, f, u, dv, why, whylen))) {
        /* The search structures from the state, boxes of the saved side. */
        rc = dlca_search_init(*out, p.search, (int)u[CK_U_A]) ? PDLA_ENOMEM : 0;
        if (rc) snprintf(why, whylen, "out of memory");
        if (!rc && (*out)->search_now != (int)u[CK_U_SEARCH]) rc = PDLA_EIO, snprintf(why, whylen, "its search state is inconsistent");
        (*out)->p.count = given;
    }
    ck_free(&a);
    return rc;
}

/* The checkpoint schedule: optional (none before session 27), both
 * attributes or neither. What a bare --resume keeps, so a forged one must
 * not set the resumed run's triggers (a NaN period, a negative one). */
static int load_schedule(dlca_sim *s, hid_t f, char *why, size_t whylen)
{
    static const char *const S = "schedule_every_seconds", *const A = "schedule_every_attempts";
    const htri_t hs = H5Aexists(f, S), ha = H5Aexists(f, A);
    if (hs < 0 || ha < 0) LOAD_FAIL(PDLA_EIO, "its root attributes cannot be read");
    if (!hs && !ha) return 0;
    if (!hs || !ha) LOAD_FAIL(PDLA_EIO, "it records %s without %s", hs ? S : A, hs ? A : S);
    dlca_ckpt_schedule sc;
    if (pdla_h5_attr_exact(f, S, PDLA_H5_F64, &sc.every_seconds) < 0)
        LOAD_FAIL(PDLA_EIO, "its %s is not one 64-bit float", S);
    if (!(sc.every_seconds >= 0 && sc.every_seconds <= 1e9)) /* the range of --checkpoint-every; NaN fails */
        LOAD_FAIL(PDLA_EIO, "its %s %g is not 0 (none) to 1e9 seconds", S, sc.every_seconds);
    if (pdla_h5_attr_exact(f, A, PDLA_H5_U64, &sc.every_attempts) < 0)
        LOAD_FAIL(PDLA_EIO, "its %s is not one unsigned 64-bit integer", A);
    dlca_set_checkpoint_schedule(s, &sc);
    return 0;
}
#undef LOAD_FAIL

int dlca_checkpoint_load(dlca_sim **out, const char *path, char *err, size_t errlen)
{
    *out = NULL;
    h5u_quiet q;
    if (h5u_silence(&q)) return pdla_errorf(PDLA_EIO, err, errlen, "cannot silence HDF5");
    dlca_sim *s = NULL;
    char why[256] = "";
    int rc = PDLA_EIO;
    /* a regular file only: H5Fopen of a FIFO blocked for ever */
    struct stat st;
    const int found = stat(path, &st) == 0, stat_errno = errno;
    const int reg = found && S_ISREG(st.st_mode);
    const hid_t f = reg ? H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT) : H5I_INVALID_HID;
    if (!reg)
        snprintf(why, sizeof why, "%s",
                 !found ? strerror(stat_errno) : S_ISDIR(st.st_mode) ? "a directory, not a checkpoint" : "not a regular file");
    else if (f < 0) snprintf(why, sizeof why, "cannot open it as HDF5");
    else if ((rc = load_state(&s, f, why, sizeof why)) == 0 && (rc = load_schedule(s, f, why, sizeof why)) == 0) {
        char cerr[160];
        if (dlca_check(s, cerr, sizeof cerr)) {
            snprintf(why, sizeof why, "its state is inconsistent: %s", cerr);
            rc = PDLA_EIO;
        }
    }
    if (f >= 0 && H5Fclose(f) < 0 && rc == 0) {
        snprintf(why, sizeof why, "cannot close it");
        rc = PDLA_EIO;
    }
    if (h5u_restore(&q) < 0 && rc == 0) {
        snprintf(why, sizeof why, "cannot restore the HDF5 error handler");
        rc = PDLA_EIO;
    }
    if (rc) {
        dlca_sim_free(s);
        return pdla_errorf(rc, err, errlen, "cannot resume from %s: %s", path, why);
    }
    *out = s;
    return 0;
}

void dlca_set_checkpoint_schedule(dlca_sim *s, const dlca_ckpt_schedule *sc)
{
    s->sched = *sc;
    s->has_sched = 1;
}

int dlca_checkpoint_schedule(const dlca_sim *s, dlca_ckpt_schedule *sc)
{
    *sc = s->sched;
    return s->has_sched;
}
