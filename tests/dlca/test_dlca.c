/*
 * test_dlca.c - exactness of the DLCA model: the three collision searches
 * (id lattice, the seed's grid-boxing, all pairs) give the same history bit
 * for bit; every invariant (no overlap, every monomer in one cluster, sizes
 * sum to N, no untouched contact, boxes and lattice consistent) holds after
 * every chunk of attempts; periodic wrap at the box edges and corners in
 * every d = 2..5; tiny boxes; determinism by seed; refused parameters.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "dlca/dlca_internal.h"
#include "pdla/dlca.h"

static void set_box(dlca_params *p, int d, const uint32_t *L)
{
    p->dim = d;
    memset(p->box, 0, sizeof p->box);
    for (int a = 0; a < d; a++) p->box[a] = L[a];
}

/* With sticking 1, face-adjacent monomers of two clusters in the exported
 * state (owner: cluster + 1 a site, 0 empty); also at a spanning stop,
 * whose step's last joins were once left undone. */
static int touching(const dlca_params *p, const uint32_t *owner, uint64_t V)
{
    if (p->sticking < 1) return 0;
    int bad = 0;
    for (uint64_t k = 0; k < V; k++) {
        if (!owner[k]) continue;
        uint64_t stride = 1, rest = k;
        for (int a = 0; a < p->dim; a++) {
            const uint64_t L = p->box[a], x = rest % L, up = x + 1 == L ? k - x * stride : k + stride;
            rest /= L;
            if (owner[up] && owner[up] != owner[k]) bad++;
            stride *= L;
        }
    }
    return bad;
}

/* Independent check of the exported state: distinct sites inside the box,
 * cluster numbers 0..N_c-1 each used, sizes agreeing with the table, no
 * two clusters touching (sticking 1). */
static void check_export(const dlca_sim *s, const char *what)
{
    dlca_stats st;
    dlca_get_stats(s, &st);
    const size_t N = st.n_monomers, nc = st.n_clusters;
    uint32_t *site = malloc(N * sizeof *site), *cid = malloc(N * sizeof *cid);
    uint64_t *size = malloc(nc * sizeof *size), *count = calloc(nc, sizeof *count);
    double *rg = malloc(nc * sizeof *rg);
    const dlca_params *p = dlca_get_params(s);
    uint64_t V = 1;
    for (int a = 0; a < p->dim; a++) V *= p->box[a];
    uint32_t *seen = calloc(V, sizeof *seen);
    dlca_export_sites(s, site, cid);
    dlca_cluster_table(s, size, rg);
    int bad = 0;
    uint64_t sum = 0;
    for (size_t i = 0; i < N; i++) {
        if (site[i] >= V || seen[site[i]] || cid[i] >= nc) bad++;
        else {
            seen[site[i]] = cid[i] + 1;
            count[cid[i]]++;
        }
    }
    const int touch = bad ? 0 : touching(p, seen, V);
    CHECK(touch == 0, "%s: %d face contacts between clusters left unjoined (stop %s)", what, touch,
          dlca_stop_name(st.stop));
    for (size_t c = 0; c < nc; c++) {
        if (count[c] != size[c] || size[c] == 0) bad++;
        sum += size[c];
    }
    CHECK(bad == 0 && sum == N, "%s: %d faults in the exported state, sizes sum %llu of %zu", what, bad,
          (unsigned long long)sum, N);
    free(site), free(cid), free(size), free(count), free(rg), free(seen);
}

/* Run the same seed with all three searches side by side, checking every
 * invariant after each chunk and comparing the histories. */
static void compare_searches(int d, const uint32_t *L, double fill, double gamma, double p_stick, double drift,
                             uint64_t seed, int chunk, int chunks)
{
    dlca_sim *s[3] = {NULL, NULL, NULL};
    char err[512], what[160];
    snprintf(what, sizeof what, "d=%d L0=%u fill=%g gamma=%g p=%g drift=%g seed=%llu", d, L[0], fill, gamma,
             p_stick, drift, (unsigned long long)seed);
    for (int m = 0; m < 3; m++) {
        dlca_params p;
        dlca_params_default(&p);
        set_box(&p, d, L);
        p.fill = fill;
        p.mobility = gamma;
        p.sticking = p_stick;
        p.drift = drift;
        p.seed = seed;
        p.search = m;
        p.grid_box = 1;
        p.until_clusters = 1;
        const int rc = dlca_create(&s[m], &p, err, sizeof err);
        CHECK(rc == 0, "%s: create (%s): %s", what, dlca_search_name(m), err);
        if (rc) goto done;
    }
    dlca_stats st0;
    dlca_get_stats(s[1], &st0);
    int boxes_seen = st0.search_now == DLCA_SEARCH_BOXES;
    for (int k = 0; k < chunks; k++) {
        int stop[3];
        dlca_stats st[3];
        for (int m = 0; m < 3; m++) {
            stop[m] = dlca_run(s[m], (uint64_t)chunk);
            dlca_get_stats(s[m], &st[m]);
            const int rc = dlca_check(s[m], err, sizeof err);
            CHECK(rc == 0, "%s: %s after chunk %d: %s", what, dlca_search_name(m), k, err);
            if (rc) goto done;
        }
        boxes_seen |= st[1].search_now == DLCA_SEARCH_BOXES;
        for (int m = 1; m < 3; m++) {
            const int same = st[m].digest == st[0].digest && st[m].t == st[0].t &&
                             st[m].n_clusters == st[0].n_clusters && st[m].moves == st[0].moves &&
                             st[m].sum_s2 == st[0].sum_s2 && stop[m] == stop[0];
            CHECK(same, "%s: %s differs from lattice after chunk %d (N_c %llu vs %llu)", what,
                  dlca_search_name(m), k, (unsigned long long)st[m].n_clusters,
                  (unsigned long long)st[0].n_clusters);
            if (!same) goto done;
        }
        if (stop[0]) break;
    }
    /* The final configurations, site by site. */
    dlca_stats st;
    dlca_get_stats(s[0], &st);
    uint32_t *a = malloc(st.n_monomers * 2 * sizeof *a), *b = malloc(st.n_monomers * 2 * sizeof *b);
    dlca_export_sites(s[0], a, a + st.n_monomers);
    for (int m = 1; m < 3; m++) {
        dlca_export_sites(s[m], b, b + st.n_monomers);
        CHECK(memcmp(a, b, st.n_monomers * 2 * sizeof *a) == 0, "%s: %s final sites differ", what,
              dlca_search_name(m));
    }
    free(a), free(b);
    for (int m = 0; m < 3; m++) check_export(s[m], what);
    if (getenv("DLCA_TEST_VERBOSE"))
        fprintf(stderr, "%s: %llu attempts, N_c %llu, stop %s, boxes used %d\n", what,
                (unsigned long long)st.attempts, (unsigned long long)st.n_clusters, dlca_stop_name(st.stop),
                boxes_seen);
    if ((fill <= 0.02 && d < 5) || fill <= 0.01) CHECK(boxes_seen, "%s: the grid boxes were never used", what);
done:
    for (int m = 0; m < 3; m++) dlca_destroy(s[m]);
}

/* Two monomers on one line along axis a, at x_a = L-1 and x_a = 1, all
 * other coordinates at the far corner (L-1): a + step wraps the first to 0,
 * next to the second, and they join across the edge. */
static void wrap_join(int d, const uint32_t *L, int a, int search)
{
    dlca_params p;
    dlca_params_default(&p);
    set_box(&p, d, L);
    p.search = search;
    p.grid_box = 1;
    dlca_sim *s = NULL;
    char err[512];
    int64_t x[DLCA_MAX_DIM], y[DLCA_MAX_DIM];
    for (int b = 0; b < d; b++) x[b] = y[b] = L[b] - 1;
    y[a] = 1;
    /* Built through a throwaway sim for the site arithmetic. */
    uint32_t sites[2] = {0, 0};
    {
        const uint32_t tmp[1] = {0};
        dlca_sim *t = NULL;
        if (dlca_create_sites(&t, &p, tmp, 1, err, sizeof err)) {
            CHECK(0, "create: %s", err);
            return;
        }
        sites[0] = dlca_site(t, x);
        sites[1] = dlca_site(t, y);
        dlca_destroy(t);
    }
    CHECK(dlca_create_sites(&s, &p, sites, 2, err, sizeof err) == 0, "create: %s", err);
    if (!s) return;
    CHECK(dlca_size_at(s, sites[0]) == 1 && dlca_size_at(s, sites[1]) == 1, "d=%d a=%d: started joined", d, a);
    const int r = dlca_move_site(s, sites[0], a, +1);
    x[a] = 0;
    const uint32_t moved = dlca_site(s, x);
    CHECK(r == 0 && dlca_size_at(s, moved) == 2 && dlca_size_at(s, sites[1]) == 2,
          "d=%d axis %d (%s): no join across the edge (r=%d, size %llu)", d, a, dlca_search_name(search), r,
          (unsigned long long)dlca_size_at(s, moved));
    CHECK(dlca_extent_at(s, moved, a) == 2, "d=%d axis %d: extent %lld, not 2", d, a,
          (long long)dlca_extent_at(s, moved, a));
    CHECK(dlca_check(s, err, sizeof err) == 0, "d=%d axis %d: %s", d, a, err);
    /* Move the pair round the box along every axis and back: it wraps at
     * both edges of every axis and stays whole. */
    for (int b = 0; b < d && s; b++)
        for (int sg = -1; sg <= 1; sg += 2)
            for (uint32_t k = 0; k < L[b] + 1; k++) {
                const int mr = dlca_move_site(s, dlca_site(s, x), b, sg);
                x[b] += sg;
                if (mr != 0 || dlca_size_at(s, dlca_site(s, x)) != 2) {
                    CHECK(0, "d=%d: pair lost moving along axis %d sign %d (r=%d)", d, b, sg, mr);
                    b = d;
                    break;
                }
            }
    CHECK(dlca_check(s, err, sizeof err) == 0, "d=%d after the tour: %s", d, err);
    dlca_destroy(s);
}

/* With a sticking probability of ~0 a touching pair stays apart, and a move
 * onto the other monomer (across the edge) is refused. */
static void refused_overlap(int d, const uint32_t *L, int search)
{
    dlca_params p;
    dlca_params_default(&p);
    set_box(&p, d, L);
    p.search = search;
    p.grid_box = 1;
    p.sticking = 1e-12;
    int64_t x[DLCA_MAX_DIM] = {0}, y[DLCA_MAX_DIM] = {0};
    x[0] = L[0] - 1;
    y[0] = 1;
    char err[512];
    dlca_sim *s = NULL;
    const uint32_t tmp[1] = {0};
    if (dlca_create_sites(&s, &p, tmp, 1, err, sizeof err)) return;
    uint32_t sites[2] = {dlca_site(s, x), dlca_site(s, y)};
    dlca_destroy(s);
    s = NULL;
    CHECK(dlca_create_sites(&s, &p, sites, 2, err, sizeof err) == 0, "create: %s", err);
    if (!s) return;
    CHECK(dlca_move_site(s, sites[0], 0, +1) == 0, "d=%d: first move refused", d);
    x[0] = 0;
    CHECK(dlca_size_at(s, dlca_site(s, x)) == 1, "d=%d: joined with p = 1e-12", d);
    CHECK(dlca_move_site(s, dlca_site(s, x), 0, +1) == 1, "d=%d (%s): a move onto a monomer was not refused", d,
          dlca_search_name(search));
    CHECK(dlca_check(s, err, sizeof err) == 0, "d=%d: %s", d, err);
    dlca_destroy(s);
}

static void refusals(void)
{
    dlca_params p;
    char err[512];
    const struct {
        int dim;
        uint32_t L0;
        double fill;
        uint64_t count;
    } bad[] = {{1, 64, 0.01, 0}, {6, 8, 0.01, 0}, {2, 64, 0, 0}, {2, 64, 1, 0}, {2, 64, 1.5, 0},
               {2, 1, 0.5, 0},   {2, 4, 0.01, 0}, {2, 4, 0.5, 16}, {3, 2000, 0.01, 0}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        dlca_params_default(&p);
        p.dim = bad[i].dim;
        for (int a = 0; a < DLCA_MAX_DIM; a++) p.box[a] = bad[i].L0;
        p.fill = bad[i].fill;
        p.count = bad[i].count;
        err[0] = '\0';
        CHECK(dlca_params_validate(&p, err, sizeof err) == PDLA_EINVAL && err[0] && !strchr(err, '\n'),
              "case %zu (dim %d, L %u, fill %g, count %llu) not refused in one line: '%s'", i, bad[i].dim,
              bad[i].L0, bad[i].fill, (unsigned long long)bad[i].count, err);
    }
    /* The table's own text round-trips through the parser. */
    dlca_params_default(&p);
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    CHECK(dlca_param_set(&p, &t[1], "1024x512", err, sizeof err) == 0 && p.box[0] == 1024 && p.box[1] == 512,
          "--box 1024x512: %s", err);
    CHECK(dlca_param_set(&p, &t[1], "10x0", err, sizeof err) == PDLA_EINVAL, "--box 10x0 accepted");
    CHECK(dlca_params_validate(&p, err, sizeof err) == 0, "defaults after --box 1024x512: %s", err);
}

/* dlca_shared_site, the one duplicate-site check (start files, resumed
 * snapshots, the tools): the first repeat named, a caller's bits left
 * clear for the next array, a site outside the box refused. */
static void shared_site(void)
{
    static const uint32_t all[] = {5, 0, 63, 64, 129}, rep[] = {7, 3, 9, 3, 7}, out[] = {1, 2, 130};
    uint64_t seen[3] = {0}, a = 99, b = 99; /* 130 sites */
    CHECK(dlca_shared_site(all, 5, 130, NULL, &a, &b) == 0, "distinct sites called shared");
    CHECK(dlca_shared_site(all, 5, 130, seen, &a, &b) == 0, "distinct sites called shared (bits given)");
    CHECK(!seen[0] && !seen[1] && !seen[2], "bits left set: %llx %llx %llx", (unsigned long long)seen[0],
          (unsigned long long)seen[1], (unsigned long long)seen[2]);
    CHECK(dlca_shared_site(rep, 5, 130, seen, &a, &b) == 1 && a == 1 && b == 3, "repeat: %llu %llu",
          (unsigned long long)a, (unsigned long long)b);
    CHECK(!seen[0] && !seen[1] && !seen[2], "bits left set after a repeat");
    CHECK(dlca_shared_site(out, 3, 130, seen, &a, &b) == PDLA_EINVAL, "site 130 of 130 taken");
    CHECK(!seen[0] && !seen[1] && !seen[2], "bits left set after a site outside the box");
    CHECK(dlca_shared_site(rep, 0, 130, NULL, &a, &b) == 0, "no sites called shared");
}

/* L = 2: two monomers side by side along a 2-site axis touch their own
 * image: the run stops at once as spanning. */
static void two_site_axis(void)
{
    dlca_params p;
    dlca_params_default(&p);
    const uint32_t L[2] = {2, 8};
    set_box(&p, 2, L);
    const uint32_t sites[2] = {0, 1};
    char err[512];
    for (int m = 0; m < 3; m++) {
        p.search = m;
        dlca_sim *s = NULL;
        CHECK(dlca_create_sites(&s, &p, sites, 2, err, sizeof err) == 0, "create: %s", err);
        if (!s) continue;
        dlca_stats st;
        dlca_get_stats(s, &st);
        CHECK(st.stop == DLCA_STOP_SPANNING && st.n_clusters == 1, "L = 2 pair: stop %d, N_c %llu", st.stop,
              (unsigned long long)st.n_clusters);
        CHECK(dlca_run(s, 10) == DLCA_STOP_SPANNING, "a stopped run ran on");
        dlca_destroy(s);
    }
}

/* The longest axis (offsets are 16 bits): row A (x 0..L-2, anchored at
 * x 0) and row B two rows up (L - 4 monomers from x L-4 on, wrapping,
 * anchored at x L-4). B moves down onto A and joins it whole: its offsets
 * in A's frame reach 2L - 9 (an axis of 2^15 would overflow them; extent 2L - 8) and the
 * cluster spans the axis; every invariant holds (check_cluster: offsets
 * against sites and bounding box), in every search. One more site on the
 * axis is refused. */
static void longest_axis(void)
{
    enum { L = DLCA_MAX_AXIS };
    dlca_params p;
    dlca_params_default(&p);
    const uint32_t box[2] = {L, 4};
    set_box(&p, 2, box);
    uint32_t *sites = malloc(2 * L * sizeof *sites);
    if (!sites) return;
    uint32_t n = 0;
    for (uint32_t x = 0; x < L - 1; x++) sites[n++] = x;
    for (uint32_t j = 0; j < L - 4; j++) sites[n++] = 2 * L + (L - 4 + j) % L;
    char err[512];
    for (int m = 0; m < 3; m++) {
        p.search = m;
        dlca_sim *s = NULL;
        CHECK(dlca_create_sites(&s, &p, sites, n, err, sizeof err) == 0, "longest axis: %s", err);
        if (!s) continue;
        dlca_stats st;
        dlca_get_stats(s, &st);
        CHECK(st.n_clusters == 2 && st.stop == 0, "longest axis: the rows did not form (N_c %llu)",
              (unsigned long long)st.n_clusters);
        CHECK(dlca_move_site(s, 2 * L + L - 4, 1, -1) == DLCA_MOVED, "longest axis: row B did not move");
        dlca_get_stats(s, &st);
        CHECK(st.stop == DLCA_STOP_SPANNING && st.n_clusters == 1 && dlca_extent_at(s, 0, 0) == 2 * L - 8,
              "longest axis, search %d: stop %d, N_c %llu, extent %lld", m, st.stop,
              (unsigned long long)st.n_clusters, (long long)dlca_extent_at(s, 0, 0));
        CHECK(dlca_check(s, err, sizeof err) == 0, "longest axis, search %d: %s", m, err);
        check_export(s, "longest axis");
        dlca_destroy(s);
    }
    free(sites);
    p.box[0] = L + 1;
    CHECK(dlca_params_validate(&p, err, sizeof err) == PDLA_EINVAL, "an axis of %d sites accepted", L + 1);
}

static void determinism(void)
{
    dlca_params p;
    dlca_params_default(&p);
    const uint32_t L[3] = {16, 12, 10};
    set_box(&p, 3, L);
    p.fill = 0.05;
    p.mobility = -0.5;
    uint64_t dg[3];
    for (int i = 0; i < 3; i++) {
        p.seed = i < 2 ? 7 : 8;
        dlca_sim *s = NULL;
        char err[256];
        if (dlca_create(&s, &p, err, sizeof err)) {
            CHECK(0, "%s", err);
            return;
        }
        dlca_run(s, 20000);
        dlca_stats st;
        dlca_get_stats(s, &st);
        dg[i] = st.digest ^ (uint64_t)(st.t * 1e6);
        dlca_destroy(s);
    }
    CHECK(dg[0] == dg[1], "same seed, different history");
    CHECK(dg[0] != dg[2], "different seeds, same history");
}

/* A run stopped half way, written, loaded and run on ends exactly where the
 * straight run ends (every search, size-dependent mobility, p < 1). */
static void resume(int search)
{
    dlca_params p;
    dlca_params_default(&p);
    const uint32_t L[2] = {64, 48};
    set_box(&p, 2, L);
    p.fill = 0.04;
    p.mobility = -0.5;
    p.sticking = 0.7;
    p.search = search;
    p.seed = 11;
    p.until_clusters = 5;
    char err[512], path[] = "/tmp/pdla-dlca-ckpt-XXXXXX";
    const int fd = mkstemp(path);
    if (fd < 0) return;
    close(fd);
    unlink(path);
    dlca_sim *a = NULL, *b = NULL, *c = NULL;
    if (dlca_create(&a, &p, err, sizeof err) || dlca_create(&b, &p, err, sizeof err)) {
        CHECK(0, "%s", err);
        goto done;
    }
    dlca_run(a, 0);
    dlca_stats s0;
    dlca_get_stats(a, &s0);
    CHECK(dlca_run(b, s0.attempts / 2) == DLCA_RUNNING && s0.attempts > 1000, "%s: no half-way point (%llu attempts)",
          dlca_search_name(search), (unsigned long long)s0.attempts);
    CHECK(dlca_checkpoint_write(b, path, err, sizeof err) == 0, "write: %s", err);
    CHECK(dlca_checkpoint_load(&c, path, err, sizeof err) == 0, "load: %s", err);
    if (!c) goto done;
    dlca_run(c, 0);
    dlca_stats sa, sc;
    dlca_get_stats(a, &sa);
    dlca_get_stats(c, &sc);
    CHECK(sa.digest == sc.digest && sa.t == sc.t && sa.attempts == sc.attempts && sa.n_clusters == sc.n_clusters,
          "%s: resumed run differs (attempts %llu vs %llu)", dlca_search_name(search),
          (unsigned long long)sa.attempts, (unsigned long long)sc.attempts);
    size_t na, nc;
    const dlca_row *ra = dlca_series(a, &na), *rc = dlca_series(c, &nc);
    CHECK(na == nc && memcmp(ra, rc, na * sizeof *ra) == 0, "%s: series differ (%zu vs %zu rows)",
          dlca_search_name(search), na, nc);
    uint32_t *ea = malloc(sa.n_monomers * 2 * sizeof *ea), *ec = malloc(sa.n_monomers * 2 * sizeof *ec);
    dlca_export_sites(a, ea, ea + sa.n_monomers);
    dlca_export_sites(c, ec, ec + sa.n_monomers);
    CHECK(memcmp(ea, ec, sa.n_monomers * 2 * sizeof *ea) == 0, "%s: final sites differ", dlca_search_name(search));
    free(ea), free(ec);
    /* A file that is not a checkpoint is refused in one line. */
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("not hdf5\n", f);
        fclose(f);
        dlca_sim *x = NULL;
        err[0] = '\0';
        CHECK(dlca_checkpoint_load(&x, path, err, sizeof err) == PDLA_EIO && !x && err[0] && !strchr(err, '\n'),
              "a text file loaded as a checkpoint: '%s'", err);
    }
done:
    unlink(path);
    dlca_destroy(a);
    dlca_destroy(b);
    dlca_destroy(c);
}

/* The slots compact as N_c falls: at 100 clusters of N = 13107 the model
 * holds at most 16 bytes a monomer beyond its bit lattice (about 10: the
 * clusters' blocks; before compaction the slots alone were 16 and the
 * whole 29), and the state still checks. */
static void compacted(void)
{
    dlca_params p;
    dlca_params_default(&p);
    static const uint32_t L[] = {512, 512};
    set_box(&p, 2, L);
    p.fill = 0.05;
    p.until_clusters = 100;
    p.seed = 1;
    char err[256];
    dlca_sim *s = NULL;
    CHECK(dlca_create(&s, &p, err, sizeof err) == 0, "compacted: %s", err);
    if (!s) return;
    (void)dlca_run(s, 0);
    dlca_stats st;
    dlca_get_stats(s, &st);
    const double beyond = ((double)st.bytes - 512.0 * 512 / 8) / (double)st.n_monomers;
    if (getenv("DLCA_TEST_VERBOSE")) fprintf(stderr, "compacted: %.2f bytes a monomer beyond the lattice\n", beyond);
    CHECK(st.n_clusters == 100 && beyond < 16, "compacted: %.1f bytes a monomer beyond the lattice at N_c %llu",
          beyond, (unsigned long long)st.n_clusters);
    CHECK(dlca_check(s, err, sizeof err) == 0, "compacted: %s", err);
    check_export(s, "compacted");
    dlca_destroy(s);
}

/* The drift option does what it says: with probability G a move is one
 * site down the last axis. Two lone monomers far apart (they never meet in
 * the run) are moved 4000 times; their summed displacement, unwrapped by
 * the minimal image every 50 attempts (a monomer moves at most 50 sites in
 * between, the box is 512), has mean -4000 G along y and 0 along x. Per
 * attempt the y step has variance G + (1 - G)/2 - G^2 (0.56 at G = 0.3:
 * sd 47 over 4000), x (1 - G)/2 (sd 37): tolerances of 5 sd. Ignoring the
 * drift (0), reversing it (+1200) or putting it on axis 0 (x -1200) fails.
 * Every search gives the same displacement (same history). */
static void drift_statistics(void)
{
    const double G = 0.3;
    const uint32_t L[2] = {512, 512};
    long long sum[3][2] = {{0}};
    for (int m = 0; m < 3; m++) {
        dlca_params p;
        dlca_params_default(&p);
        set_box(&p, 2, L);
        p.drift = G;
        p.search = m;
        p.seed = 42;
        const uint32_t sites[2] = {0, 256 + 256 * 512};
        dlca_sim *s = NULL;
        char err[256];
        if (dlca_create_sites(&s, &p, sites, 2, err, sizeof err)) {
            CHECK(0, "drift: %s", err);
            return;
        }
        uint32_t prev[2] = {sites[0], sites[1]}, cur[2], cid[2];
        for (int chunk = 0; chunk < 80; chunk++) {
            (void)dlca_run(s, 50);
            dlca_export_sites(s, cur, cid);
            for (int i = 0; i < 2; i++) {
                const long long dx = (long long)(cur[i] % 512) - (long long)(prev[i] % 512);
                const long long dy = (long long)(cur[i] / 512) - (long long)(prev[i] / 512);
                sum[m][0] += dx > 256 ? dx - 512 : dx < -256 ? dx + 512 : dx;
                sum[m][1] += dy > 256 ? dy - 512 : dy < -256 ? dy + 512 : dy;
                prev[i] = cur[i];
            }
        }
        dlca_stats st;
        dlca_get_stats(s, &st);
        CHECK(st.attempts == 4000 && st.n_clusters == 2, "drift: %llu attempts, %llu clusters",
              (unsigned long long)st.attempts, (unsigned long long)st.n_clusters);
        dlca_destroy(s);
    }
    if (getenv("DLCA_TEST_VERBOSE")) fprintf(stderr, "drift: displacement (%lld, %lld)\n", sum[0][0], sum[0][1]);
    CHECK(llabs(sum[0][1] + 1200) <= 5 * 47 && llabs(sum[0][0]) <= 5 * 37,
          "drift %g: displacement (%lld, %lld) over 4000 attempts, want (0, -1200) within 5 sd", G, sum[0][0],
          sum[0][1]);
    CHECK(memcmp(sum[0], sum[1], sizeof sum[0]) == 0 && memcmp(sum[0], sum[2], sizeof sum[0]) == 0,
          "drift: the searches moved the monomers differently");
}

/* The sticking probability: a monomer stepped next to another joins it
 * with probability p. 600 fresh pairs (seeds 1..600) at p = 0.3: the
 * joins are binomial, mean 180, sd 11.2; tolerance 4 sd (45). p ignored
 * (600 joins) or 1 - p (420) fails. The searches agree pair by pair. */
static void sticking_statistics(void)
{
    const uint32_t L[2] = {16, 12};
    int joins[3] = {0, 0, 0};
    for (int m = 0; m < 3; m++)
        for (uint64_t seed = 1; seed <= 600; seed++) {
            dlca_params p;
            dlca_params_default(&p);
            set_box(&p, 2, L);
            p.sticking = 0.3;
            p.search = m;
            p.seed = seed;
            const uint32_t sites[2] = {5 + 16 * 6, 7 + 16 * 6};
            dlca_sim *s = NULL;
            char err[256];
            if (dlca_create_sites(&s, &p, sites, 2, err, sizeof err)) {
                CHECK(0, "sticking: %s", err);
                return;
            }
            const int r = dlca_move_site(s, sites[0], 0, +1);
            CHECK(r == DLCA_MOVED, "sticking: the step next to the other monomer was refused (%d)", r);
            joins[m] += dlca_size_at(s, sites[1]) == 2;
            CHECK(dlca_check(s, err, sizeof err) == 0, "sticking: %s", err);
            dlca_destroy(s);
        }
    if (getenv("DLCA_TEST_VERBOSE")) fprintf(stderr, "sticking: %d joins of 600\n", joins[0]);
    CHECK(abs(joins[0] - 180) <= 45, "sticking 0.3: %d joins of 600 contacts, want 180 +/- 45", joins[0]);
    CHECK(joins[0] == joins[1] && joins[0] == joins[2], "sticking: searches differ (%d, %d, %d joins)", joins[0],
          joins[1], joins[2]);
}

/* A start whose first joins span the box (4x8: a row of 4 on y = 0) and
 * whose last monomer, (3,1), touches that row: the joins go on after the
 * spanning one, so 2 clusters (5 and 1), not 3 with (3,1) left alone. */
static void spanning_start(void)
{
    static const uint32_t L[] = {4, 8}, sites[] = {0, 1, 2, 3, 20, 7};
    dlca_params p;
    dlca_params_default(&p);
    set_box(&p, 2, L);
    dlca_sim *s = NULL;
    char err[512];
    CHECK(dlca_create_sites(&s, &p, sites, 6, err, sizeof err) == 0, "spanning start: %s", err);
    if (!s) return;
    dlca_stats st;
    dlca_get_stats(s, &st);
    CHECK(st.stop == DLCA_STOP_SPANNING && st.n_clusters == 2 && st.largest == 5,
          "spanning start: stop %s, %llu clusters, largest %llu (want spanning, 2, 5)", dlca_stop_name(st.stop),
          (unsigned long long)st.n_clusters, (unsigned long long)st.largest);
    CHECK(dlca_check(s, err, sizeof err) == 0, "spanning start: %s", err);
    check_export(s, "spanning start");
    dlca_destroy(s);
}

int main(void)
{
    static const uint32_t L2[] = {40, 36}, L3[] = {24, 20, 18}, L4[] = {16, 14, 15, 13}, L5[] = {10, 9, 11, 10, 9};
    static const uint32_t E2[] = {7, 5}, E3[] = {5, 4, 6}, E4[] = {4, 5, 4, 4}, E5[] = {4, 5, 4, 4, 5};
    const uint32_t *Ls[] = {L2, L3, L4, L5}, *Es[] = {E2, E3, E4, E5};
    refusals();
    shared_site();
    for (int m = 0; m < 3; m++) resume(m);
    two_site_axis();
    longest_axis();
    determinism();
    compacted();
    drift_statistics();
    sticking_statistics();
    spanning_start();
    /* A 4D run that spans with two more contacts in its last step (left
     * touching before; check_export counts them). */
    static const uint32_t S4[] = {6, 6, 6, 6};
    compare_searches(4, S4, 0.1, 0, 1, 0, 4, 250, 800);
    for (int d = 2; d <= 5; d++) {
        for (int a = 0; a < d; a++)
            for (int m = 0; m < 3; m++) wrap_join(d, Es[d - 2], a, m);
        for (int m = 0; m < 3; m++) refused_overlap(d, Es[d - 2], m);
    }
    /* The searches against each other: dilute and dense, equal and
     * size-dependent mobility, sticking 1 and 1/2, drift; down to one
     * cluster or spanning. */
    for (int d = 2; d <= 5; d++)
        for (uint64_t seed = 1; seed <= (d <= 3 ? 3u : 1u); seed++) {
            const double f = d == 5 ? 0.5 : 1; /* 5D percolates early */
            compare_searches(d, Ls[d - 2], 0.02 * f, 0, 1, 0, seed, 250, 800);
            compare_searches(d, Ls[d - 2], 0.08 * f, -0.5, 1, 0, seed + 10, 250, 800);
            compare_searches(d, Ls[d - 2], 0.04 * f, 0.3, 0.5, 0.2, seed + 20, 250, 800);
        }
    /* A larger 2D box where the boxes double several times before they
     * give way to all pairs. */
    static const uint32_t B2[] = {96, 80};
    compare_searches(2, B2, 0.02, 0, 1, 0, 5, 2000, 400);
    compare_searches(2, B2, 0.02, -1, 0.7, 0.1, 6, 2000, 400);
    return check_finish();
}
