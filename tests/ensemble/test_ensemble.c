/*
 * test_ensemble.c - the ensemble library (include/pdla/ensemble.h):
 *   stats    statistics on synthetic series with known answers
 *   journal  records round-trip; the journal survives a torn or damaged
 *            tail (what kill -9 during an append leaves) and refuses foreign
 *            records; config checks (M = 0, seed overflow)
 *   seeds    cluster i is the serial cluster of seed S + i, and pdla_ens_run
 *            gives the same records on 1 and 3 threads
 *   physics2d  a 2D ensemble's D_f against 1.71 within its bootstrap interval
 * Usage: test_ensemble MODE [DIR]
 */
#define _GNU_SOURCE /* memmem */
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "pdla/ensemble.h"
#include "pdla/params.h"

/* ---- synthetic statistics ----------------------------------------------- */

static uint64_t lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005u + 1442695040888963407u;
    return *s >> 11;
}
static double unif(uint64_t *s) { return (double)lcg(s) * 0x1p-53; }
static double gauss(uint64_t *s)
{
    const double u = unif(s) + 1e-300, v = unif(s);
    return sqrt(-2 * log(u)) * cos(2 * M_PI * v);
}

/* N_k = round(10^(k/pd)) for N up to nmax (the engine's grid, distinct). */
static size_t grid(uint64_t *n, size_t cap, int pd, uint64_t nmax)
{
    size_t k = 0;
    uint64_t prev = 0;
    for (int i = 0; k < cap; i++) {
        uint64_t v = (uint64_t)llround(pow(10.0, (double)i / pd));
        if (v <= prev) v = prev + 1;
        if (v > nmax) break;
        n[k++] = prev = v;
    }
    return k;
}

/* SSR of the correction model at (nu, B) with a and s by least squares:
 * the brute-force reference for test_corr_global. */
static double ref_ssr(const double *x, const double *ly, size_t k, double nu, double B)
{
    double sx = 0, sxx = 0, sr = 0, sxr = 0, r[1000];
    for (size_t i = 0; i < k; i++) {
        r[i] = ly[i] - log1p(B * exp(-nu * x[i]));
        sx += x[i], sxx += x[i] * x[i], sr += r[i], sxr += x[i] * r[i];
    }
    const double s = (k * sxr - sx * sr) / (k * sxx - sx * sx), a = (sr - s * sx) / k;
    double ssr = 0;
    for (size_t i = 0; i < k; i++) ssr += (r[i] - a - s * x[i]) * (r[i] - a - s * x[i]);
    return ssr;
}

/* The correction fit is the least squares over nu in [0.2, 2] and B with
 * |B N^-nu| <= 0.9 at every N fitted (ens_stats.c): on noisy series like a
 * small ensemble's (a random walk in ln R_g along ln N), its SSR is at most
 * a brute-force grid's over that region, and its B within it. Before, the
 * profile's Gauss-Newton stopped at local minima and B ran free (to ~90,
 * where the "correction" replaces the power law: D = 1.19 on 12 clusters
 * of 3000). */
static void test_corr_global(void)
{
    enum { CAP = 400 };
    static uint64_t n[CAP];
    const size_t k = grid(n, CAP, 100, 3000);
    uint64_t seed = 77;
    double y[CAP], x[CAP], ly[CAP];
    int worse = 0, out = 0;
    for (int t = 0; t < 12; t++) {
        double w = 0;
        for (size_t j = 0; j < k; j++) {
            w += 0.004 * gauss(&seed);
            y[j] = 0.5 * pow((double)n[j], 1 / 1.71) * (1 + 0.3 * pow((double)n[j], -0.5)) * exp(w);
        }
        double a, d, b, v, rms;
        CHECK(pdla_ens_corr_fit(n, y, k, 30, 3000, &a, &d, &b, &v, &rms) == 0, "corr fit failed");
        size_t m = 0;
        for (size_t j = 0; j < k; j++)
            if (n[j] >= 30) x[m] = log((double)n[j]), ly[m++] = log(y[j]);
        const double zmax = exp(-v * x[0]);
        if (fabs(b) * zmax > 0.9 + 1e-9) out++;
        const double mine = rms * rms * (double)m;
        double best = INFINITY;
        for (int i = 0; i <= 180; i++) {
            const double nu = 0.2 + 0.01 * i, bmax = 0.9 / exp(-nu * x[0]);
            for (int q = -200; q <= 200; q++) {
                const double r = ref_ssr(x, ly, m, nu, bmax * q / 200.0);
                if (r < best) best = r;
            }
        }
        if (mine > best * (1 + 1e-6) + 1e-15) {
            worse++;
            fprintf(stderr, "series %d: fit SSR %.9g above the grid's %.9g (D %.4f B %.4f nu %.3f)\n", t, mine,
                    best, d, b, v);
        }
    }
    CHECK(out == 0, "the correction fit's B left |B N^-nu| <= 0.9 in %d of 12 series", out);
    CHECK(worse == 0, "the correction fit's SSR was above a brute-force grid's in %d of 12 series", worse);
}

static void test_stats(void)
{
    test_corr_global();
    enum { CAP = 2000 };
    static uint64_t n[CAP];
    const size_t k = grid(n, CAP, 50, 1000000);
    char err[512];

    /* Mean and standard error: clusters alternate +1/-1 about j + 1, so the
     * mean is j + 1 and sd = sqrt(M / (M - 1)) exactly. */
    {
        const size_t m = 10;
        double *rg = malloc(m * k * sizeof *rg);
        for (size_t i = 0; i < m; i++)
            for (size_t j = 0; j < k; j++) rg[i * k + j] = (double)(j + 1) + (i % 2 ? 1.0 : -1.0);
        pdla_ens_stats s;
        CHECK(pdla_ens_stats_compute(n, k, rg, m, NULL, n[k - 1], 10, 0, 1, &s, err, sizeof err) == 0, "%s", err);
        double worst = 0;
        for (size_t j = 0; j < k; j++) {
            worst = fmax(worst, fabs(s.mean_rg[j] - (double)(j + 1)));
            worst = fmax(worst, fabs(s.se_rg[j] - sqrt(10.0 / 9.0) / sqrt(10.0)));
        }
        CHECK(worst < 1e-12, "mean/se off by %g", worst);
        pdla_ens_stats_free(&s);
        free(rg);
    }

    /* An exact power law with a random amplitude per cluster: the mean is
     * an exact power law, so D_f, every local slope and the whole bootstrap
     * band are 1/0.6 to rounding. */
    {
        const size_t m = 20;
        const double D = 1.0 / 0.6;
        double *rg = malloc(m * k * sizeof *rg);
        uint64_t seed = 3;
        for (size_t i = 0; i < m; i++) {
            const double c = 0.5 + unif(&seed);
            for (size_t j = 0; j < k; j++) rg[i * k + j] = c * pow((double)n[j], 1.0 / D);
        }
        pdla_ens_stats s;
        CHECK(pdla_ens_stats_compute(n, k, rg, m, NULL, n[k - 1], 200, 0, 5, &s, err, sizeof err) == 0, "%s", err);
        CHECK(fabs(s.df - D) < 1e-9 && fabs(s.df_lo - D) < 1e-9 && fabs(s.df_hi - D) < 1e-9,
              "D_f %.12f [%.12f, %.12f], want %.12f", s.df, s.df_lo, s.df_hi, D);
        CHECK(s.nslope >= 10, "%zu local slopes over 3 decades", s.nslope);
        for (size_t w = 0; w < s.nslope; w++)
            CHECK(fabs(s.slope_df[w] - D) < 1e-9 && fabs(s.slope_lo[w] - D) < 1e-9, "slope %zu: %.12f", w,
                  s.slope_df[w]);
        pdla_ens_stats_free(&s);
        free(rg);
    }

    /* Noisy clusters: ln R_i(N) = ln N / D + a_i + e_ij with a_i ~ 0.1 g and
     * independent e_ij ~ 0.02 g. The fit of the mean is unbiased for D; the
     * 95% interval must hold D in about 95% of independent ensembles
     * (checked over 200 of them: at least 180, which a correct interval
     * misses with probability < 1e-3, and at most 199, since an interval
     * that always holds is too wide), and be reproducible from its seed. */
    {
        const size_t m = 30;
        const double D = 1.71;
        static uint64_t nc[200];
        const size_t kc = grid(nc, 200, 20, 100000);
        double *rg = malloc(m * kc * sizeof *rg);
        int hit = 0;
        uint64_t seed = 11;
        double width = 0;
        for (int e = 0; e < 200; e++) {
            for (size_t i = 0; i < m; i++) {
                const double a = 0.1 * gauss(&seed);
                for (size_t j = 0; j < kc; j++)
                    rg[i * kc + j] = exp(log((double)nc[j]) / D + a + 0.02 * gauss(&seed));
            }
            pdla_ens_stats s, t;
            CHECK(pdla_ens_stats_compute(nc, kc, rg, m, NULL, 100000, 400, 0, 99, &s, err, sizeof err) == 0, "%s", err);
            hit += s.df_lo <= D && D <= s.df_hi;
            width += s.df_hi - s.df_lo;
            if (e == 0) {
                CHECK(pdla_ens_stats_compute(nc, kc, rg, m, NULL, 100000, 400, 0, 99, &t, err, sizeof err) == 0, "%s", err);
                CHECK(t.df_lo == s.df_lo && t.df_hi == s.df_hi, "bootstrap not reproducible");
                pdla_ens_stats_free(&t);
                CHECK(pdla_ens_stats_compute(nc, kc, rg, m, NULL, 100000, 400, 0, 100, &t, err, sizeof err) == 0, "%s", err);
                CHECK(t.df_lo != s.df_lo, "another bootstrap seed gave the same interval");
                pdla_ens_stats_free(&t);
            }
            pdla_ens_stats_free(&s);
        }
        CHECK(hit >= 180 && hit <= 199, "the 95%% interval held D in %d of 200 ensembles", hit);
        fprintf(stderr, "bootstrap coverage %d/200, mean width %.4f\n", hit, width / 200);
        free(rg);
    }

    /* Correction to scaling, exact: R = A N^(1/D) (1 + B N^-nu). */
    {
        const double A = 0.55, D = 1.71, B = -0.6, nu = 0.47;
        static uint64_t nn[CAP];
        const size_t kk = grid(nn, CAP, 50, 10000000);
        double *y = malloc(kk * sizeof *y);
        for (size_t j = 0; j < kk; j++)
            y[j] = A * pow((double)nn[j], 1.0 / D) * (1.0 + B * pow((double)nn[j], -nu));
        double a, d, b, v, rms;
        CHECK(pdla_ens_corr_fit(nn, y, kk, 10, 10000000, &a, &d, &b, &v, &rms) == 0, "corr fit failed");
        CHECK(fabs(d - D) < 1e-4 && fabs(a - A) < 1e-4 * A && fabs(b - B) < 1e-3 && fabs(v - nu) < 1e-3,
              "corr fit A %.6f D %.6f B %.6f nu %.6f", a, d, b, v);
        CHECK(rms < 1e-6, "corr fit rms %g", rms);
        /* The plain power law over the same range is biased: the local slope
         * approaches D from one side as N grows. */
        pdla_ens_stats s;
        CHECK(pdla_ens_stats_compute(nn, kk, y, 1, NULL, 10000000, 0, 0, 1, &s, err, sizeof err) == 0, "%s", err);
        CHECK(s.nslope > 5 && fabs(s.slope_df[s.nslope - 1] - D) < fabs(s.slope_df[0] - D),
              "local slope does not approach D");
        CHECK(s.corr_ok && fabs(s.corr_D - D) < 1e-3, "stats corr D %.6f", s.corr_D);
        pdla_ens_stats_free(&s);
        CHECK(pdla_ens_corr_fit(nn, y, 4, 1, 10000000, &a, &d, &b, &v, &rms) == -1, "4 points fitted");
        free(y);
    }
}

/* ---- journal ------------------------------------------------------------- */

static void fake_record(pdla_ens_record *r, const pdla_ens_config *c, uint64_t i, int with_pos)
{
    memset(r, 0, sizeof *r);
    r->index = i;
    r->seed = c->params.seed + i;
    r->particles = c->params.target;
    r->dim = c->params.dim;
    r->rg_diam = 1.5 + (double)i;
    /* No fit (too few samples) over the default range, and a walker a
     * particle: what the journal takes as a cluster's. */
    r->fit = (pdla_fit){.df = NAN, .df_err = NAN, .prefactor_diam = NAN, .n_lo = 10, .n_hi = c->params.target};
    r->walkers = c->params.target - 1;
    /* The ensemble's R_g grid (test_journal: one sample a decade, target
     * 50): the journal refuses a record off it. */
    r->rg_count = 2;
    r->rg_n = malloc(2 * 8);
    r->rg = malloc(2 * 8);
    for (int k = 0; k < 2; k++) r->rg_n[k] = k ? 10 : 1, r->rg[k] = 0.1 * (double)(k + i);
    if (with_pos) {
        r->npos = r->particles;
        r->positions = malloc((size_t)r->npos * (size_t)r->dim * 4);
        for (uint64_t q = 0; q < r->npos * (uint64_t)r->dim; q++) r->positions[q] = (int32_t)(q * 7 + i);
    }
}

static off_t file_size(const char *p)
{
    struct stat st;
    return stat(p, &st) ? -1 : st.st_size;
}

/* The scan's stop flag: stop_after calls of it answer 0, then 1. */
typedef struct stop_count {
    int calls, stop_after;
} stop_count;

static int stop_when(void *user)
{
    stop_count *s = user;
    return ++s->calls > s->stop_after;
}

/* pdla_ens_journal_open_stoppable on dir's journal (path): polled at every
 * candidate record, and stopped it reports PDLA_ESTOPPED with one line and
 * leaves the file as it was (the scan of a torn or damaged journal must not
 * cut it: that is begin_append's, after a scan that ended). */
static void test_journal_stop(const char *dir, const char *path)
{
    char err[1024];
    pdla_ens_journal *j = NULL;
    stop_count never = {0, 1 << 30};
    CHECK(pdla_ens_journal_open_stoppable(dir, stop_when, &never, &j, err, sizeof err) == 0, "%s", err);
    const uint64_t have = j ? pdla_ens_journal_count(j) : 0;
    CHECK(never.calls >= 3 && (uint64_t)never.calls >= have, "the stop flag was polled %d times for %llu records",
          never.calls, (unsigned long long)have);
    pdla_ens_journal_close(j);
    const off_t size = file_size(path);
    for (int k = 0; k < never.calls; k++) {
        stop_count s = {0, k};
        j = NULL;
        err[0] = '\0';
        const int rc = pdla_ens_journal_open_stoppable(dir, stop_when, &s, &j, err, sizeof err);
        CHECK(rc == PDLA_ESTOPPED && j == NULL && strstr(err, "stopped while reading") && !strchr(err, '\n'),
              "stopped at poll %d: rc %d, %s", k + 1, rc, err);
        CHECK(file_size(path) == size, "a stopped scan changed the journal");
        pdla_ens_journal_close(j);
    }
}

/* pdla_ens_fingerprint: every growth parameter that changes a cluster or
 * its record is in it; the count, positions, deflate level, threads and
 * bind (fixed for an ensemble's clusters) are not. */
static void test_fingerprint(const pdla_ens_config *c)
{
    const uint64_t f = pdla_ens_fingerprint(c);
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    for (size_t i = 0; i < n; i++) {
        if (t[i].bit & (PDLA_PARAM_THREADS | PDLA_PARAM_BIND)) continue;
        pdla_ens_config o = *c;
        char e[256] = "";
        if (t[i].type == PDLA_PT_FLAG) /* its example may be the default ("yes" of --no-snap-contact) */
            pdla_param_set_u(&t[i], &o.params, !pdla_param_get_u(&t[i], &c->params));
        else
            CHECK(pdla_param_parse(&t[i], &o.params, t[i].example, e, sizeof e) == 0, "%s: %s", t[i].name, e);
        CHECK(!pdla_param_equal(&t[i], &o.params, &c->params), "%s: its example is the default", t[i].name);
        CHECK(pdla_ens_fingerprint(&o) != f, "the fingerprint does not change with %s", t[i].name);
    }
    pdla_ens_config o = *c;
    o.clusters = c->clusters + 7;
    o.keep_positions = !c->keep_positions;
    o.deflate_level = 9 - c->deflate_level;
    o.params.threads = 5;
    o.params.bind = PDLA_BIND_CORE;
    CHECK(pdla_ens_fingerprint(&o) == f, "the fingerprint changes with the count, positions, level or threads");
    /* A row added later (absent_default) at its default leaves it as it was. */
    o = *c;
    o.params.reference_walkers = 0;
    CHECK(pdla_ens_fingerprint(&o) == f, "reference_walkers at its default changed the fingerprint");
    o.params.eps = 3;
    pdla_ens_config o2 = o;
    CHECK(pdla_ens_fingerprint(&o) == pdla_ens_fingerprint(&o2) && pdla_ens_fingerprint(&o) != f,
          "the fingerprint is not a function of the parameters");
}

static void test_journal(const char *dir)
{
    char err[1024], path[4200];
    pdla_ens_config c;
    memset(&c, 0, sizeof c);
    pdla_params_default(&c.params);
    c.params.target = 50;
    c.params.seed = 100;
    c.params.rg_per_decade = 1; /* samples at N = 1 and 10 (fake_record) */
    c.clusters = 5;
    c.keep_positions = 1;

    /* Config checks. */
    pdla_ens_config bad = c;
    bad.clusters = 0;
    CHECK(pdla_ens_config_check(&bad, err, sizeof err) == PDLA_EINVAL, "M = 0 accepted");
    bad = c;
    bad.params.seed = UINT64_MAX - 3;
    CHECK(pdla_ens_config_check(&bad, err, sizeof err) == PDLA_EINVAL && strstr(err, "overflow"),
          "seed overflow accepted: %s", err);
    bad.params.seed = UINT64_MAX - 4; /* seeds ...-4 .. UINT64_MAX: fits */
    CHECK(pdla_ens_config_check(&bad, err, sizeof err) == 0, "%s", err);
    bad = c;
    bad.params.threads = 2;
    CHECK(pdla_ens_config_check(&bad, err, sizeof err) == PDLA_EINVAL, "threads 2 accepted");
    test_fingerprint(&c);

    /* Round trip of a record. */
    pdla_ens_record r, back;
    fake_record(&r, &c, 2, 1);
    uint8_t *buf;
    size_t len;
    CHECK(pdla_ens_record_encode(&r, &buf, &len) == 0, "encode");
    CHECK(pdla_ens_record_decode(buf, len, &back, err, sizeof err) == 0, "%s", err);
    CHECK(back.index == 2 && back.rg_count == 2 && back.rg[1] == r.rg[1] && back.npos == 50 &&
              !memcmp(back.positions, r.positions, 50 * 2 * 4),
          "record round trip");
    pdla_ens_record_free(&back);
    CHECK(pdla_ens_record_decode(buf, len - 1, &back, err, sizeof err) != 0, "short record decoded");
    free(buf);
    pdla_ens_record_free(&r);

    pdla_ens_journal *j;
    CHECK(pdla_ens_journal_create(dir, &c, &j, err, sizeof err) == 0, "%s", err);
    for (uint64_t i = 0; i < 3; i++) {
        fake_record(&r, &c, i, 1);
        CHECK(pdla_ens_journal_append(j, &r, err, sizeof err) == 0, "%s", err);
        CHECK(pdla_ens_journal_append(j, &r, err, sizeof err) == 0, "a repeat is skipped");
        pdla_ens_record_free(&r);
    }
    fake_record(&r, &c, 3, 0); /* no positions in a keep_positions ensemble */
    CHECK(pdla_ens_journal_append(j, &r, err, sizeof err) == PDLA_EINVAL, "a foreign record was appended");
    pdla_ens_record_free(&r);
    fake_record(&r, &c, 3, 1);
    r.seed++;
    CHECK(pdla_ens_journal_append(j, &r, err, sizeof err) == PDLA_EINVAL, "a record with a wrong seed");
    pdla_ens_record_free(&r);
    CHECK(pdla_ens_journal_count(j) == 3, "count %llu", (unsigned long long)pdla_ens_journal_count(j));
    pdla_ens_journal_close(j);

    snprintf(path, sizeof path, "%s/%s", dir, PDLA_ENS_JOURNAL_NAME);
    const off_t whole = file_size(path);
    /* A torn append: half of a fourth record. */
    {
        fake_record(&r, &c, 3, 1);
        CHECK(pdla_ens_record_encode(&r, &buf, &len) == 0, "encode");
        const int fd = open(path, O_WRONLY | O_APPEND);
        const uint64_t l64 = len, fp = pdla_ens_fingerprint(&c);
        CHECK(write(fd, "PDLAREC2", 8) == 8 && write(fd, &l64, 8) == 8 && write(fd, &fp, 8) == 8 &&
                  write(fd, buf, len / 2) == (ssize_t)(len / 2),
              "tear");
        close(fd);
        free(buf);
        pdla_ens_record_free(&r);
    }
    CHECK(pdla_ens_journal_open(dir, &j, err, sizeof err) == 0, "%s", err);
    CHECK(pdla_ens_journal_count(j) == 3 && pdla_ens_journal_torn_bytes(j) > 0, "torn tail: count %llu torn %llu",
          (unsigned long long)pdla_ens_journal_count(j), (unsigned long long)pdla_ens_journal_torn_bytes(j));
    CHECK(file_size(path) > whole, "open cut the file (it must only read)");
    CHECK(pdla_ens_journal_has(j, 2) && !pdla_ens_journal_has(j, 3), "has");
    CHECK(pdla_ens_journal_read(j, 1, &back, err, sizeof err) == 0 && back.rg_diam == 2.5 && back.npos == 50,
          "read back: %s", err);
    pdla_ens_record_free(&back);
    CHECK(pdla_ens_journal_begin_append(j, err, sizeof err) == 0, "%s", err);
    CHECK(file_size(path) == whole, "the torn tail was not cut");
    fake_record(&r, &c, 4, 1);
    CHECK(pdla_ens_journal_append(j, &r, err, sizeof err) == 0, "%s", err);
    pdla_ens_record_free(&r);
    pdla_ens_journal_close(j);

    /* A flipped byte in the last record's payload: it is dropped, the
     * earlier ones stay. */
    {
        const off_t sz = file_size(path);
        const int fd = open(path, O_RDWR);
        uint8_t b;
        CHECK(pread(fd, &b, 1, sz - 20) == 1, "read");
        b ^= 0x40;
        CHECK(pwrite(fd, &b, 1, sz - 20) == 1, "write");
        close(fd);
    }
    CHECK(pdla_ens_journal_open(dir, &j, err, sizeof err) == 0, "%s", err);
    CHECK(pdla_ens_journal_count(j) == 3 && !pdla_ens_journal_has(j, 4), "damaged record counted");
    CHECK(pdla_ens_journal_damaged_bytes(j) == 0, "a damaged tail counted as damage inside");
    pdla_ens_journal_close(j);

    /* A flipped byte in the first record: it is skipped, and the records
     * after it still count (cutting there would drop them all). */
    {
        const off_t sz = file_size(path);
        uint8_t *all = malloc((size_t)sz);
        const int fd = open(path, O_RDWR);
        CHECK(all && pread(fd, all, (size_t)sz, 0) == sz, "read");
        const uint8_t *rec = all ? memmem(all, (size_t)sz, "PDLAREC2", 8) : NULL;
        CHECK(rec != NULL, "no record in the journal");
        if (rec) {
            const off_t at = (off_t)(rec - all) + 24 + 20;
            uint8_t b = all[at] ^ 0x40;
            CHECK(pwrite(fd, &b, 1, at) == 1, "write");
        }
        close(fd);
        free(all);
    }
    CHECK(pdla_ens_journal_open(dir, &j, err, sizeof err) == 0, "%s", err);
    CHECK(pdla_ens_journal_count(j) == 2 && !pdla_ens_journal_has(j, 0) && pdla_ens_journal_has(j, 1) &&
              pdla_ens_journal_has(j, 2) && pdla_ens_journal_damaged_bytes(j) > 0,
          "a damaged first record: count %llu, damaged %llu", (unsigned long long)pdla_ens_journal_count(j),
          (unsigned long long)pdla_ens_journal_damaged_bytes(j));
    pdla_ens_journal_close(j);
    test_journal_stop(dir, path);

    /* Counts no machine could write are refused; the memory estimate
     * saturates instead of wrapping. */
    {
        pdla_ens_config big = c;
        big.clusters = PDLA_ENS_MAX_CLUSTERS + 1;
        CHECK(pdla_ens_config_check(&big, err, sizeof err) == PDLA_EINVAL, "10^8 + 1 clusters accepted");
        big.clusters = PDLA_ENS_MAX_CLUSTERS;
        big.params.seed = 0;
        CHECK(pdla_ens_config_check(&big, err, sizeof err) == 0, "10^8 clusters refused: %s", err);
        big.clusters = UINT64_MAX;
        big.params.target = UINT64_MAX;
        CHECK(pdla_ens_memory_bytes(&big) == UINT64_MAX, "the estimate wrapped");
        big.clusters = 1000;
        big.params.target = 1000000;
        big.params.rg_per_decade = 100;
        const uint64_t m = pdla_ens_memory_bytes(&big);
        /* 100 samples a decade to 10^6: 602 samples, 8 bytes each a cluster. */
        CHECK(m > 1000 * 602 * 8 && m < 1000 * 602 * 8 + 1000 * 200 + (UINT64_C(2) << 20),
              "estimate %llu for 1000 clusters of 10^6", (unsigned long long)m);
    }

    /* A damaged header is refused. */
    {
        const int fd = open(path, O_RDWR);
        CHECK(pwrite(fd, "X", 1, 30) == 1, "write");
        close(fd);
    }
    CHECK(pdla_ens_journal_open(dir, &j, err, sizeof err) == PDLA_EIO, "damaged header accepted");
    fprintf(stderr, "damaged header: %s\n", err);
    unlink(path);
    CHECK(pdla_ens_journal_open(dir, &j, err, sizeof err) == PDLA_EIO, "no journal accepted");

    /* Comparing configs for a resume. */
    pdla_ens_config a = c;
    a.params.target = 60;
    a.params.threads = 7;
    CHECK(pdla_ens_config_compare(&c, &a, PDLA_PARAM_TARGET, 0, 0, err, sizeof err) == PDLA_EINVAL &&
              strstr(err, "--target"),
          "target change accepted: %s", err);
    CHECK(pdla_ens_config_compare(&c, &a, PDLA_PARAM_THREADS, 0, 0, err, sizeof err) == 0, "threads refused");
    CHECK(pdla_ens_config_compare(&c, &a, 0, 0, 0, err, sizeof err) == 0, "fields not asked compared");
    a = c;
    a.clusters = 9;
    CHECK(pdla_ens_config_compare(&c, &a, 0, 1, 0, err, sizeof err) == PDLA_EINVAL, "cluster count change accepted");
}

/* ---- seeds and threads ------------------------------------------------------ */

typedef struct collect {
    pthread_mutex_t mu;
    uint64_t next, m;
    pdla_ens_record *recs;
} collect;

static int c_next(void *u, uint64_t *i)
{
    collect *c = u;
    pthread_mutex_lock(&c->mu);
    const int ok = c->next < c->m;
    if (ok) *i = c->m - 1 - c->next++; /* backwards: order must not matter */
    pthread_mutex_unlock(&c->mu);
    return ok;
}

static int c_done(void *u, const pdla_ens_record *r, char *err, size_t errlen)
{
    collect *c = u;
    uint8_t *b;
    size_t len;
    if (pdla_ens_record_encode(r, &b, &len)) return pdla_errorf(PDLA_ENOMEM, err, errlen, "encode");
    const int rc = pdla_ens_record_decode(b, len, &c->recs[r->index], err, errlen);
    free(b);
    return rc;
}

static void run_collect(const pdla_ens_config *cfg, int threads, pdla_ens_record *recs)
{
    collect c = {PTHREAD_MUTEX_INITIALIZER, 0, cfg->clusters, recs};
    const pdla_ens_scheduler s = {c_next, c_done, &c};
    char err[512];
    CHECK(pdla_ens_run(cfg, threads, &s, NULL, NULL, err, sizeof err) == 0, "%s", err);
}

static void test_seeds(void)
{
    pdla_ens_config c;
    memset(&c, 0, sizeof c);
    pdla_params_default(&c.params);
    c.params.target = 1500;
    c.params.seed = 42;
    c.clusters = 5;
    c.keep_positions = 1;
    char err[512];
    /* Cluster 3 is `pdla --seed 45`. */
    pdla_ens_record r;
    CHECK(pdla_ens_grow_one(&c, 3, &r, err, sizeof err) == 0, "%s", err);
    pdla_params p = c.params;
    p.seed = 45;
    pdla_engine *e;
    CHECK(pdla_engine_create(&e, &p, err, sizeof err) == 0, "%s", err);
    CHECK(pdla_engine_grow(e, p.target, NULL, 0, NULL, err, sizeof err) == 0, "%s", err);
    const uint64_t *n;
    const double *rg;
    size_t k;
    pdla_engine_rg_series(e, &n, &rg, &k);
    CHECK(r.seed == 45 && r.rg_count == k && !memcmp(r.rg, rg, k * 8) && !memcmp(r.rg_n, n, k * 8),
          "cluster 3 differs from the serial cluster of seed 45");
    pdla_stats st;
    pdla_engine_stats(e, &st);
    CHECK(r.jumps == st.jumps && r.rg_diam == st.rg_diam, "counters differ");
    pdla_engine_destroy(e);
    pdla_ens_record_free(&r);

    /* 1 and 3 threads, clusters handed out backwards: the same records. */
    pdla_ens_record a[5], b[5];
    memset(a, 0, sizeof a);
    memset(b, 0, sizeof b);
    run_collect(&c, 1, a);
    run_collect(&c, 3, b);
    for (int i = 0; i < 5; i++) {
        CHECK(a[i].index == (uint64_t)i && b[i].index == (uint64_t)i, "index");
        CHECK(a[i].rg_count == b[i].rg_count && !memcmp(a[i].rg, b[i].rg, a[i].rg_count * 8) &&
                  a[i].jumps == b[i].jumps && a[i].npos == b[i].npos &&
                  !memcmp(a[i].positions, b[i].positions, a[i].npos * 2 * 4),
              "cluster %d differs between 1 and 3 threads", i);
        pdla_ens_record_free(&a[i]);
        pdla_ens_record_free(&b[i]);
    }
    /* An index outside the ensemble is an error, not a cluster. */
    CHECK(pdla_ens_grow_one(&c, 5, &r, err, sizeof err) == PDLA_EINVAL, "index 5 of 5 grown");
}

/* ---- physics ------------------------------------------------------------------ */

static void test_physics2d(const char *dir)
{
    /* 40 clusters of 10^4 in 2D. Measured (seed 1): D_f = 1.7126 with the
     * 95% bootstrap interval [1.690, 1.733] (half-width 0.021, bootstrap sd
     * 0.011). The references (1.7100(3) Menshutin-Shchur, 1.715(4)
     * Tolman-Meakin) lie 10x closer together than that half-width, and the
     * correction-to-scaling shift of the mean-R_g fit at 10^4 is about 0.01
     * (runs/ensemble-2d), so 1.71 must fall inside the interval; and the
     * interval must be narrower than 0.08 (4x the bootstrap sd on each
     * side), which a broken R_g or a broken resampling would not give. */
    pdla_ens_config c;
    memset(&c, 0, sizeof c);
    pdla_params_default(&c.params);
    c.params.target = 10000;
    c.params.seed = 1;
    c.clusters = 40;
    char err[1024];
    pdla_ens_journal *j;
    CHECK(pdla_ens_journal_create(dir, &c, &j, err, sizeof err) == 0, "%s", err);
    CHECK(pdla_ens_run_local(j, 2, NULL, NULL, err, sizeof err) == 0, "%s", err);
    CHECK(pdla_ens_journal_count(j) == 40, "count");
    const size_t m = 40;
    double *rg = NULL, *df = malloc(m * 8);
    uint64_t *n = NULL;
    size_t k = 0;
    for (size_t i = 0; i < m; i++) {
        pdla_ens_record r;
        CHECK(pdla_ens_journal_read(j, i, &r, err, sizeof err) == 0, "%s", err);
        if (i == 0) {
            k = (size_t)r.rg_count;
            rg = malloc(m * k * 8);
            n = malloc(k * 8);
            memcpy(n, r.rg_n, k * 8);
        }
        memcpy(rg + i * k, r.rg, k * 8);
        df[i] = r.fit.df;
        pdla_ens_record_free(&r);
    }
    pdla_ens_stats s;
    CHECK(pdla_ens_stats_compute(n, k, rg, m, df, 10000, PDLA_ENS_BOOT_SAMPLES, PDLA_ENS_CORR_SAMPLES, PDLA_ENS_BOOT_SEED, &s, err,
                                 sizeof err) == 0,
          "%s", err);
    fprintf(stderr, "2D: D_f %.4f [%.4f, %.4f] (boot sd %.4f), per-cluster %.4f +- %.4f, corr D %.4f [%.4f, %.4f]\n",
            s.df, s.df_lo, s.df_hi, s.df_boot_sd, s.df_cluster_mean, s.df_cluster_sd, s.corr_D, s.corr_D_lo,
            s.corr_D_hi);
    CHECK(s.df_lo <= 1.71 && 1.71 <= s.df_hi, "D_f interval [%.4f, %.4f] misses 1.71", s.df_lo, s.df_hi);
    CHECK(s.df_hi - s.df_lo < 0.08, "D_f interval [%.4f, %.4f] too wide", s.df_lo, s.df_hi);
    char path[4200];
    snprintf(path, sizeof path, "%s/ensemble.h5", dir);
    CHECK(pdla_ens_write(j, NULL, path, err, sizeof err) == 0, "%s", err);
    pdla_ens_stats_free(&s);
    pdla_ens_journal_close(j);
    free(rg), free(df), free(n);
}

int main(int argc, char **argv)
{
    pdla_hdf5_quiet();
    const char *mode = argc > 1 ? argv[1] : "";
    char dir[] = "/tmp/pdla-ens-XXXXXX";
    if (!mkdtemp(dir)) return 1;
    if (!strcmp(mode, "stats")) test_stats();
    else if (!strcmp(mode, "journal")) test_journal(dir);
    else if (!strcmp(mode, "seeds")) test_seeds();
    else if (!strcmp(mode, "physics2d")) test_physics2d(dir);
    else {
        fprintf(stderr, "usage: test_ensemble stats|journal|seeds|physics2d\n");
        return 2;
    }
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd)) fprintf(stderr, "could not remove %s\n", dir);
    return check_finish();
}
