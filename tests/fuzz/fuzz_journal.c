/*
 * fuzz_journal.c - libFuzzer target for the ensemble journal's reader with
 * forged records whose checksums are right: real records of a small
 * ensemble (grown once), with fields set from the input (counts, seeds,
 * R_g, the fit, times, the R_g grid, positions), appended through the
 * library's own writer, then the journal is opened and, when it holds
 * every cluster, ensemble.h5 written. Any outcome is fine except a crash,
 * a sanitizer report, a message that is empty or spans lines, or a journal
 * that opens with every cluster and then cannot be written (a record the
 * reader takes must be one the writer can use: a forged R_g grid in
 * cluster 0 once blocked every later write). The writer itself refuses a
 * record whose index, seed or positions count are not the ensemble's; so
 * that the reader's own checks of those are reached too, a record may
 * instead be framed here (magic, length, payload, FNV-1a: the journal's
 * format, written out again on purpose) and appended to the closed
 * journal's file. Built by scripts/fuzz.
 */
#include <fcntl.h>
#include <unistd.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pdla/ensemble.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define M 3

static pdla_ens_config cfg[2];          /* without and with kept positions */
static pdla_ens_record tmpl[2][M];

static void setup(void)
{
    for (int k = 0; k < 2; k++) {
        pdla_params_default(&cfg[k].params);
        cfg[k].params.target = 300;
        cfg[k].params.rg_per_decade = 10;
        cfg[k].clusters = M;
        cfg[k].keep_positions = k;
        char err[512];
        for (uint64_t i = 0; i < M; i++)
            if (pdla_ens_grow_one(&cfg[k], i, &tmpl[k][i], err, sizeof err) != PDLA_OK) {
                fprintf(stderr, "grow: %s\n", err);
                abort();
            }
    }
}

/* A deep copy of a template record. */
static void copy_record(pdla_ens_record *r, const pdla_ens_record *t)
{
    *r = *t;
    r->rg_n = malloc((t->rg_count ? t->rg_count : 1) * sizeof *r->rg_n);
    r->rg = malloc((t->rg_count ? t->rg_count : 1) * sizeof *r->rg);
    r->positions = malloc((t->npos ? t->npos * (uint64_t)t->dim : 1) * sizeof *r->positions);
    if (!r->rg_n || !r->rg || !r->positions) abort();
    if (t->rg_count) {
        memcpy(r->rg_n, t->rg_n, t->rg_count * sizeof *r->rg_n);
        memcpy(r->rg, t->rg, t->rg_count * sizeof *r->rg);
    }
    if (t->npos) memcpy(r->positions, t->positions, t->npos * (uint64_t)t->dim * sizeof *r->positions);
}

static uint64_t u64(fuzz_in *in)
{
    const unsigned sel = fuzz_byte(in) % 12;
    static const uint64_t pick[8] = {0, 1, 2, UINT64_MAX, (uint64_t)1 << 63, 299, 300, 301};
    if (sel < 8) return pick[sel];
    return fuzz_bytes(in, 8);
}

static double real(fuzz_in *in, double was)
{
    static const double pick[10] = {0, -0.0, 1, -1, NAN, INFINITY, -INFINITY, 1e308, 5e-324, 1.7};
    const unsigned sel = fuzz_byte(in) % 14;
    if (sel < 10) return pick[sel];
    if (sel < 13) return was * (1 + 1e-9 * (double)(int)(sel - 11)); /* nearly right */
    const uint64_t v = fuzz_bytes(in, 8);
    double d;
    memcpy(&d, &v, sizeof d);
    return d;
}

/* One field of r from the input. Array lengths only shrink, so the
 * record's arrays stay within what was allocated. */
static void forge(fuzz_in *in, pdla_ens_record *r)
{
    const unsigned f = fuzz_byte(in) % 19;
    const uint64_t k = r->rg_count ? u64(in) % r->rg_count : 0;
    switch (f) {
    case 0: r->index = u64(in); break;
    case 1: r->seed = u64(in); break;
    case 2: r->particles = u64(in); break;
    case 3: r->walkers = u64(in); break;
    case 4: r->jumps = u64(in); break;
    case 5: r->rg_diam = real(in, r->rg_diam); break;
    case 6: r->r_ext_diam = real(in, r->r_ext_diam); break;
    case 7: r->fit.df = real(in, r->fit.df); break;
    case 8: r->fit.df_err = real(in, r->fit.df_err); break;
    case 9: r->fit.prefactor_diam = real(in, r->fit.prefactor_diam); break;
    case 10: r->fit.n_lo = u64(in); break;
    case 11: r->fit.n_hi = u64(in); break;
    case 12: r->fit.points = (int)(u64(in) & 0xffff); break;
    case 13: r->cpu_seconds = real(in, r->cpu_seconds); break;
    case 14: r->wall_seconds = real(in, r->wall_seconds); break;
    case 15: if (r->rg_count) r->rg_n[k] = u64(in); break;
    case 16: if (r->rg_count) r->rg[k] = real(in, r->rg[k]); break;
    case 17: r->rg_count = r->rg_count ? u64(in) % (r->rg_count + 1) : 0; break;
    default:
        if (r->npos && fuzz_byte(in) & 1) r->npos = u64(in) % (r->npos + 1);
        else if (r->npos) r->positions[u64(in) % (r->npos * (uint64_t)r->dim)] = (int32_t)u64(in);
        break;
    }
}

/* The journal's framing of a record (ens_journal.c's append_raw): the
 * record magic, u64 length, u64 fingerprint of the growth parameters, the
 * payload, u64 FNV-1a of length, fingerprint and payload. */
static uint64_t fnv1a(uint64_t h, const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= UINT64_C(0x100000001b3);
    }
    return h;
}

/* Appends r, framed with the fingerprint of c, to the closed journal in
 * dir: past the writer's own refusal of a foreign index, seed or positions
 * count. */
static void append_framed(const char *dir, const pdla_ens_config *c, const pdla_ens_record *r)
{
    uint8_t *payload = NULL;
    size_t len = 0;
    if (pdla_ens_record_encode(r, &payload, &len)) abort();
    char path[600];
    snprintf(path, sizeof path, "%s/%s", dir, PDLA_ENS_JOURNAL_NAME);
    const int fd = open(path, O_WRONLY | O_APPEND);
    if (fd < 0) abort();
    const uint64_t n = len, fp = pdla_ens_fingerprint(c);
    uint8_t head[24];
    memcpy(head, "PDLAREC2", 8);
    memcpy(head + 8, &n, 8);
    memcpy(head + 16, &fp, 8);
    const uint64_t sum = fnv1a(fnv1a(UINT64_C(0xcbf29ce484222325), head + 8, 16), payload, len);
    if (write(fd, head, 24) != 24 || write(fd, payload, len) != (ssize_t)len || write(fd, &sum, 8) != 8) abort();
    if (close(fd)) abort();
    free(payload);
}

/* Open the journal written; with every cluster in it, ensemble.h5 must be
 * written from it. */
static void read_back(const char *dir, int keep)
{
    pdla_ens_journal *j = NULL;
    char err[1024] = "";
    if (pdla_ens_journal_open(dir, &j, err, sizeof err) != PDLA_OK) {
        fuzz_one_line(err);
        return;
    }
    const char *why = pdla_ens_journal_refused(j);
    if (why && strchr(why, '\n')) abort();
    for (uint64_t i = 0; i < M; i++) {
        if (!pdla_ens_journal_has(j, i)) continue;
        pdla_ens_record r;
        if (pdla_ens_journal_read(j, i, &r, err, sizeof err) != PDLA_OK) {
            fprintf(stderr, "read of a recorded cluster: %s\n", err);
            abort();
        }
        if (r.index != i || r.particles != cfg[keep].params.target) abort();
        pdla_ens_record_free(&r);
    }
    if (pdla_ens_journal_count(j) == M) {
        char path[600];
        snprintf(path, sizeof path, "%s/%s", dir, PDLA_ENS_FILE_NAME);
        const pdla_run_info info = {"fuzz", 0, 0};
        if (pdla_ens_write(j, &info, path, err, sizeof err) != PDLA_OK) {
            fprintf(stderr, "a journal of every cluster that cannot be written: %s\n", err);
            abort();
        }
    }
    pdla_ens_journal_close(j);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready;
    if (!ready) {
        setup();
        ready = 1;
    }
    fuzz_in in = {data, size};
    const int keep = (int)(fuzz_byte(&in) & 1);
    char dir[128], err[1024] = "";
    fuzz_scratch_dir(dir, sizeof dir, "journal");
    pdla_ens_journal *j = NULL;
    if (pdla_ens_journal_create(dir, &cfg[keep], &j, err, sizeof err) != PDLA_OK) {
        fprintf(stderr, "create: %s\n", err);
        abort();
    }
    pdla_ens_record framed[M];
    int nframed = 0;
    for (int i = 0; i < M; i++) {
        pdla_ens_record r;
        copy_record(&r, &tmpl[keep][i]);
        const unsigned b = fuzz_byte(&in), edits = b % 4;
        for (unsigned e = 0; e < edits; e++) forge(&in, &r);
        if (b & 4) { /* past the writer: appended framed after the close */
            framed[nframed++] = r;
            continue;
        }
        if (pdla_ens_journal_append(j, &r, err, sizeof err) != PDLA_OK) fuzz_one_line(err);
        pdla_ens_record_free(&r);
    }
    pdla_ens_journal_close(j);
    for (int i = 0; i < nframed; i++) {
        append_framed(dir, &cfg[keep], &framed[i]);
        pdla_ens_record_free(&framed[i]);
    }
    read_back(dir, keep);
    return 0;
}
