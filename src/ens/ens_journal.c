/*
 * ens_journal.c - DIR/clusters.journal, the crash-safe record of the
 * clusters an ensemble has finished (include/pdla/ensemble.h).
 *
 * Why an append-only journal rather than one HDF5 file per cluster: the
 * workers append from many threads, and Debian's HDF5 is not built
 * thread-safe, so per-cluster HDF5 files would need a global HDF5 lock
 * around every write; a journal needs one pwrite + fdatasync per cluster
 * under a mutex, keeps one file instead of M (1000s) in the directory, and
 * the same bytes (pdla_ens_record_encode) are what a distributed scheduler
 * ships between ranks. A crash can only tear the last record: each record
 * carries its length and a checksum, so a torn or damaged tail is detected
 * on open and cut before appending, losing only clusters in flight.
 *
 * Layout (native byte order, marked in the header):
 *   "PDLAENS1", u32 0x01020304, u32 L, L bytes of text, u64 FNV-1a(text)
 *   then records: "PDLAREC2", u64 P, u64 F, P bytes (a record), u64 FNV-1a(P, F, bytes)
 *   and build records: "PDLABLD1", u64 P, P bytes (a revision), u64 FNV-1a(P, bytes),
 *   appended when another build resumes the ensemble (pdla_ens_journal_join)
 * The text is "key=value" lines: format, the builds of pdla that grew
 * records ("build=REVISION", one line each, in the order they joined; none
 * in journals from before builds were recorded), every row of the
 * parameter table (exact values), clusters, keep_positions, deflate_level
 * (absent in journals from before session 25: read as the default level).
 *
 * F is the fingerprint of the growth parameters the record was grown with
 * (pdla_ens_fingerprint): a record of an ensemble that differs only in,
 * say, --eps has this ensemble's index, seed, dimension and size, and only
 * F tells it apart. It sits before the payload so that the scan refuses a
 * foreign candidate after its 24-byte head. Format 1 (journals written
 * before session 27) has "PDLAREC1", u64 P, P bytes, u64 FNV-1a(P, bytes)
 * records, without F: this build still reads them, in a format-1 journal
 * only and only before its first record with F (it appends records with
 * F to an old journal and keeps its header, format 1, when it extends it;
 * nothing else writes an old record after a new one, except an older
 * build resuming the journal again, whose records then grow again).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "pdla/ensemble.h"
#include "pdla/params.h"
#include "fit.h"
#include "must.h"

#define HEAD_MAGIC "PDLAENS1"
#define REC_MAGIC "PDLAREC2"  /* with the fingerprint F */
#define REC1_MAGIC "PDLAREC1" /* format 1: without */
#define BLD_MAGIC "PDLABLD1"
_Static_assert(sizeof REC_MAGIC == sizeof BLD_MAGIC && sizeof REC1_MAGIC == sizeof BLD_MAGIC,
               "next_record finds the magics by their common prefix PDLA");
#define BOM UINT32_C(0x01020304)
#define FORMAT_PREFIX "format=pdla-ensemble-journal "
#define FORMAT_NOW 2 /* new journals; 1: before session 27 (records without F) */
#define NONE UINT64_MAX
#define JOURNAL_BUILDS_MAX 2048

struct pdla_ens_journal {
    char path[4200];
    pdla_ens_config cfg;
    int fd;
    int appendable, broken;
    pthread_mutex_t mu;     /* appends */
    uint64_t *offset;       /* per cluster: its record's payload offset, or NONE */
    uint64_t *length;       /* ... and payload length */
    uint64_t count;         /* clusters recorded */
    uint64_t head_end;      /* bytes of the header: the records start here */
    uint64_t end;           /* bytes of valid journal */
    uint64_t torn;          /* bytes after end (a torn or damaged tail) */
    uint64_t damaged;       /* bytes of damaged records skipped before end */
    char builds[JOURNAL_BUILDS_MAX]; /* the builds that grew records, space-separated */
    uint64_t max_record;    /* the longest record this ensemble makes (a longer length is damage) */
    uint64_t *grid;         /* open: the N of the R_g samples every cluster of it records */
    uint64_t grid_k;
    char refused[160];      /* open: why the first record with a valid checksum was refused, or "" */
    unsigned unknown_checked; /* candidates not of this ensemble read whole (record_at) */
    int format;             /* the header's: FORMAT_NOW, or 1 (records without F) */
    uint64_t fp;            /* pdla_ens_fingerprint of cfg: every record appended carries it */
    int fp_seen;            /* open: a record with F was taken (a format-1 record after it is not) */
    pdla_ens_stop_fn stop;  /* open: polled during the scan (NULL: never stops) */
    void *stop_user;
};

static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const uint8_t *p = data;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= UINT64_C(0x100000001b3);
    }
    return h;
}
#define FNV_START UINT64_C(0xcbf29ce484222325)

static int write_all(int fd, const void *buf, size_t n, uint64_t off)
{
    const uint8_t *p = buf;
    while (n > 0) {
        const ssize_t w = pwrite(fd, p, n, (off_t)off);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return -1;
        p += w;
        n -= (size_t)w;
        off += (uint64_t)w;
    }
    return 0;
}

/* 1 read completely, 0 short (end of file), -1 error. */
static int read_all(int fd, void *buf, size_t n, uint64_t off)
{
    uint8_t *p = buf;
    while (n > 0) {
        const ssize_t r = pread(fd, p, n, (off_t)off);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) return -1;
        if (r == 0) return 0;
        p += r;
        n -= (size_t)r;
        off += (uint64_t)r;
    }
    return 1;
}

/* ---- the header text ---------------------------------------------------- */

static char *header_text(const pdla_ens_config *c, int format, const char *builds, size_t *len)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    /* Each build line adds 7 bytes to its name and separator: at most
     * 1024 names in JOURNAL_BUILDS_MAX, so 4 x that holds every line. */
    size_t cap = 4096 + JOURNAL_BUILDS_MAX * 4, used = 0;
    char *s = malloc(cap);
    if (!s) return NULL;
    used += (size_t)snprintf(s, cap, "%s%d\n", FORMAT_PREFIX, format);
    for (const char *b = builds; *b; b += strcspn(b, " "), b += *b == ' ') /* one line a build */
        used += (size_t)snprintf(s + used, cap - used, "build=%.*s\n", (int)strcspn(b, " "), b);
    for (size_t i = 0; i < n; i++) {
        char v[80];
        pdla_param_format(&t[i], &c->params, 1, v, sizeof v);
        used += (size_t)snprintf(s + used, cap - used, "%s=%s\n", t[i].name, v);
        if (used + 200 >= cap) { /* never with today's ~20 rows; kept safe */
            char *g = realloc(s, cap *= 2);
            if (!g) {
                free(s);
                return NULL;
            }
            s = g;
        }
    }
    used += (size_t)snprintf(s + used, cap - used, "clusters=%" PRIu64 "\nkeep_positions=%d\ndeflate_level=%d\n",
                             c->clusters, c->keep_positions, c->deflate_level);
    *len = used;
    return s;
}

/* The fingerprint's rows: every growth parameter but threads and bind,
 * which an ensemble fixes for each of its clusters (1 and none). A row
 * that a journal may lack (absent_default: added since) is left out at its
 * default, so that a row added later with a default that keeps the old
 * law leaves the fingerprints of older records as they were. */
static int fingerprint_row(const pdla_param_desc *d, const pdla_params *p, const pdla_params *def)
{
    if (d->bit & (PDLA_PARAM_THREADS | PDLA_PARAM_BIND)) return 0;
    return !(d->absent_default && pdla_param_equal(d, p, def));
}

uint64_t pdla_ens_fingerprint(const pdla_ens_config *c)
{
    static const char version[] = "pdla-ensemble-fingerprint 1\n";
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    pdla_params def;
    pdla_params_default(&def);
    uint64_t h = fnv1a(FNV_START, version, sizeof version - 1);
    for (size_t i = 0; i < n; i++) {
        if (!fingerprint_row(&t[i], &c->params, &def)) continue;
        char v[80];
        pdla_param_format(&t[i], &c->params, 1, v, sizeof v); /* exact: reals in 17 digits */
        h = fnv1a(h, t[i].name, strlen(t[i].name));
        h = fnv1a(h, "=", 1);
        h = fnv1a(h, v, strlen(v));
        h = fnv1a(h, "\n", 1);
    }
    return h;
}

static int parse_u64(const char *v, uint64_t *out)
{
    if (!*v || *v == '-') return -1;
    char *end;
    errno = 0;
    const unsigned long long x = strtoull(v, &end, 10);
    if (errno || *end) return -1;
    *out = x;
    return 0;
}

/* Append revision v to builds (space-separated): -1 when it is not
 * printable without blanks or the list is full. */
static int builds_add(char *builds, const char *v)
{
    const size_t n = strlen(v);
    size_t used = strlen(builds);
    if (!n || n > 200 || used + n + 2 > JOURNAL_BUILDS_MAX) return -1;
    for (size_t i = 0; i < n; i++)
        if (v[i] < 0x21 || v[i] > 0x7e) return -1;
    if (used) builds[used++] = ' ';
    memcpy(builds + used, v, n + 1);
    return 0;
}

/* Is revision `name` (n bytes) in the list? */
static int builds_has(const char *builds, const char *name, size_t n)
{
    for (const char *b = builds; *b; b += strcspn(b, " "), b += *b == ' ')
        if (strcspn(b, " ") == n && !memcmp(b, name, n)) return 1;
    return 0;
}

static int builds_has_this(const pdla_ens_journal *j)
{
    return builds_has(j->builds, pdla_build_revision(), strlen(pdla_build_revision()));
}

/* The format line that begins the text: 1 or FORMAT_NOW into *format and
 * the text after it, or NULL. */
static char *header_format(char *text, int *format)
{
    const size_t k = strlen(FORMAT_PREFIX);
    if (strncmp(text, FORMAT_PREFIX, k) || !text[k] || text[k + 1] != '\n') return NULL;
    *format = text[k] - '0';
    return *format == 1 || *format == FORMAT_NOW ? text + k + 2 : NULL;
}

static int header_parse(char *text, pdla_ens_config *c, int *format, char *builds, char *why, size_t whylen)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    memset(c, 0, sizeof *c);
    pdla_params_default(&c->params);
    c->deflate_level = PDLA_ENS_GZIP_DEFAULT;
    char *const body = header_format(text, format);
    if (!body) return snprintf(why, whylen, "not a pdla ensemble journal of format 1 or %d", FORMAT_NOW), -1;
    uint64_t seen = 0;
    int have_m = 0, have_k = 0;
    for (char *line = body, *next; *line; line = next) {
        next = strchr(line, '\n');
        if (!next) return snprintf(why, whylen, "an unterminated header line"), -1;
        *next++ = '\0';
        char *eq = strchr(line, '=');
        if (!eq) return snprintf(why, whylen, "a header line without '='"), -1;
        *eq = '\0';
        const char *v = eq + 1;
        uint64_t u;
        if (!strcmp(line, "clusters")) {
            if (parse_u64(v, &c->clusters)) return snprintf(why, whylen, "a bad cluster count"), -1;
            have_m = 1;
            continue;
        }
        if (!strcmp(line, "build")) {
            if (builds_add(builds, v)) return snprintf(why, whylen, "a bad build line"), -1;
            continue;
        }
        if (!strcmp(line, "deflate_level")) {
            if (parse_u64(v, &u) || u > 9) return snprintf(why, whylen, "a bad deflate_level"), -1;
            c->deflate_level = (int)u;
            continue;
        }
        if (!strcmp(line, "keep_positions")) {
            if (parse_u64(v, &u) || u > 1) return snprintf(why, whylen, "a bad keep_positions"), -1;
            c->keep_positions = (int)u;
            have_k = 1;
            continue;
        }
        const pdla_param_desc *d = pdla_param_find(t, n, line);
        if (!d || strcmp(d->name, line)) return snprintf(why, whylen, "an unknown parameter '%.40s'", line), -1;
        if (d->type == PDLA_PT_REAL) {
            char *end;
            const double x = strtod(v, &end);
            if (!*v || *end) return snprintf(why, whylen, "a bad value of %s", d->name), -1;
            pdla_param_set_real(d, &c->params, x);
        } else if (d->type == PDLA_PT_CHOICE) {
            const int k = pdla_param_choice(d, v);
            if (k < 0) return snprintf(why, whylen, "a bad value of %s", d->name), -1;
            pdla_param_set_u(d, &c->params, (uint64_t)k);
        } else {
            if (parse_u64(v, &u)) return snprintf(why, whylen, "a bad value of %s", d->name), -1;
            pdla_param_set_u(d, &c->params, u);
        }
        seen |= (uint64_t)1 << (d - t);
    }
    for (size_t i = 0; i < n; i++)
        if (!(seen & ((uint64_t)1 << i)) && !t[i].absent_default)
            return snprintf(why, whylen, "parameter %s is missing", t[i].name), -1;
    if (!have_m || !have_k) return snprintf(why, whylen, "the cluster count is missing"), -1;
    char e[512];
    if (pdla_ens_config_check(c, e, sizeof e)) return snprintf(why, whylen, "%s", e), -1;
    return 0;
}

/* ---- create, open --------------------------------------------------------- */

static pdla_ens_journal *journal_new(const char *dir, const pdla_ens_config *c)
{
    pdla_ens_journal *j = calloc(1, sizeof *j);
    if (!j) return NULL;
    j->fd = -1;
    snprintf(j->path, sizeof j->path, "%s/%s", dir, PDLA_ENS_JOURNAL_NAME);
    j->format = FORMAT_NOW;
    if (c) {
        j->cfg = *c;
        j->max_record = pdla_ens_record_max_bytes(c);
        j->fp = pdla_ens_fingerprint(c);
    }
    if (pthread_mutex_init(&j->mu, NULL)) {
        free(j);
        return NULL;
    }
    return j;
}

static int journal_alloc_index(pdla_ens_journal *j)
{
    const uint64_t m = j->cfg.clusters;
    if (m > SIZE_MAX / 16) return -1;
    j->offset = malloc((size_t)m * sizeof *j->offset);
    j->length = malloc((size_t)m * sizeof *j->length);
    if (!j->offset || !j->length) return -1;
    for (uint64_t i = 0; i < m; i++) j->offset[i] = NONE;
    return 0;
}

static uint8_t *header_bytes(const pdla_ens_config *c, int format, const char *builds, size_t *len);

static int sync_dir(const char *dir)
{
    const int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return -1;
    const int rc = fsync(fd);
    close(fd);
    return rc;
}

int pdla_ens_journal_create(const char *dir, const pdla_ens_config *c, pdla_ens_journal **out, char *err,
                            size_t errlen)
{
    *out = NULL;
    int rc = pdla_ens_config_check(c, err, errlen);
    if (rc) return rc;
    if (strlen(dir) > 4000) return pdla_errorf(PDLA_EINVAL, err, errlen, "directory name too long");
    pdla_ens_journal *j = journal_new(dir, c);
    if (!j || journal_alloc_index(j)) {
        pdla_ens_journal_close(j);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the journal");
    }
    (void)builds_add(j->builds, pdla_build_revision()); /* refused only if not printable: then none */
    size_t hl = 0;
    uint8_t *buf = header_bytes(c, FORMAT_NOW, j->builds, &hl);
    char tmp[4300];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", j->path, (long)getpid());
    const int fd = buf ? open(tmp, O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0666) : -1;
    if (fd < 0) {
        rc = buf ? pdla_errorf(PDLA_EIO, err, errlen, "cannot create %s: %s", tmp, strerror(errno))
                 : pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory");
        free(buf);
        pdla_ens_journal_close(j);
        return rc;
    }
    const int bad = write_all(fd, buf, hl, 0) || fsync(fd);
    free(buf);
    if (bad || rename(tmp, j->path)) {
        const int e = errno;
        close(fd);
        unlink(tmp);
        /* The message before the close: it frees j->path. */
        rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot write %s: %s", j->path, strerror(e));
        pdla_ens_journal_close(j);
        return rc;
    }
    sync_dir(dir);
    j->fd = fd;
    j->head_end = j->end = hl;
    j->appendable = 1;
    *out = j;
    return PDLA_OK;
}

/* The N of the R_g samples of every cluster of j's ensemble (each grows
 * one particle at a time to the target: fit_rg_grid_n's points up to it),
 * for record_values_ok. 0 or -1 (no memory). */
static int journal_grid(pdla_ens_journal *j)
{
    const int pd = j->cfg.params.rg_per_decade;
    const uint64_t target = j->cfg.params.target, cap = pdla_ens_rg_samples_max(&j->cfg);
    if (cap > SIZE_MAX / sizeof *j->grid || !(j->grid = malloc((size_t)(cap ? cap : 1) * sizeof *j->grid)))
        return -1;
    j->grid_k = 0;
    for (uint64_t k = 0, n = 1; pd > 0 && n <= target && j->grid_k < cap; n = fit_rg_grid_n(++k, pd, n))
        j->grid[j->grid_k++] = n;
    return 0;
}

/* Its own D_f fit (pdla_engine_fit), the CPU and wall seconds and the
 * walkers as a cluster of n particles gives them (a forged D_f of inf, a
 * negative CPU time were taken: ensemble.h5 got that D_f for the cluster,
 * the mean D_f without it, and a negative total_cpu_seconds): the default
 * fit range for n, and either no fit (points 0, D_f, its error and the
 * prefactor NaN) or one of 3 or more samples with D_f finite, its error
 * finite and >= 0, the prefactor finite and > 0; the seconds finite and
 * >= 0; a walker a particle but the seed, at least. NULL, or the value
 * that is not. */
static const char *record_fit_bad(const pdla_ens_record *r)
{
    const pdla_fit *f = &r->fit;
    uint64_t lo, hi;
    fit_default_range(r->particles, &lo, &hi);
    if (f->n_lo != lo || f->n_hi != hi) return "its D_f fit range is not the default one for its N";
    if (f->points == 0 ? !(isnan(f->df) && isnan(f->df_err) && isnan(f->prefactor_diam))
                       : f->points < 3 || (uint64_t)f->points > r->rg_count || !isfinite(f->df) ||
                             !(isfinite(f->df_err) && f->df_err >= 0) ||
                             !(isfinite(f->prefactor_diam) && f->prefactor_diam > 0))
        return "its D_f fit (D_f, error, prefactor or points) is not finite or out of range";
    if (!(isfinite(r->cpu_seconds) && r->cpu_seconds >= 0)) return "its CPU seconds are negative or not finite";
    if (!(isfinite(r->wall_seconds) && r->wall_seconds >= 0)) return "its wall seconds are negative or not finite";
    if (r->particles && r->walkers < r->particles - 1) return "it has fewer walkers than particles after the seed";
    return NULL;
}

/* Are a decoded record's values ones a cluster of j's ensemble makes? Its
 * R_g samples at the ensemble's grid points (ensemble.h5 is written on
 * the grid of cluster 0's record, so a forged one there, increasing and in
 * [1, N], refused every other cluster as off the grid: the ensemble could
 * no longer be written), and every R_g, R_ext finite and >= 0 (a record
 * forged with NaN R_g and its checksum recomputed was taken, and
 * ensemble.h5 got D_f nan). NULL, or the value that is not. */
static const char *record_values_bad(const pdla_ens_journal *j, const pdla_ens_record *r)
{
    if (r->rg_count != j->grid_k || (r->rg_count && memcmp(r->rg_n, j->grid, (size_t)r->rg_count * 8)))
        return "its R_g samples are not at the ensemble's grid of N";
    if (!isfinite(r->rg_diam) || r->rg_diam < 0) return "its final R_g is negative or not finite";
    if (!isfinite(r->r_ext_diam) || r->r_ext_diam < 0) return "its R_ext is negative or not finite";
    for (uint64_t k = 0; k < r->rg_count; k++)
        if (!isfinite(r->rg[k]) || r->rg[k] < 0) return "an R_g sample is negative or not finite";
    return record_fit_bad(r);
}

/* Whether r (its fixed fields suffice) is one of c's clusters. */
static int record_is_ours(const pdla_ens_config *c, const pdla_ens_record *r)
{
    return r->index < c->clusters && r->seed == c->params.seed + r->index && r->dim == c->params.dim &&
           r->particles == c->params.target && r->npos == (c->keep_positions ? r->particles : 0);
}

/* Candidates not of this ensemble checked whole, for the note (record_at). */
#define JOURNAL_UNKNOWN_CHECKED 8

/* Whether the caller asked the scan to stop (pdla_ens_journal_open_stoppable). */
static int journal_stopped(const pdla_ens_journal *j)
{
    return j->stop && j->stop(j->stop_user);
}

/* A cluster record's head: "PDLAREC2", u64 P, u64 F, or format 1's
 * "PDLAREC1", u64 P. */
typedef struct rec_head {
    uint64_t len;        /* P */
    uint64_t skip;       /* bytes before the payload: 24, or 16 without F */
    uint8_t summed[16];  /* what the checksum covers before the payload: P, and F */
    const char *foreign; /* why its F says it is not this ensemble's record, or NULL */
} rec_head;

/* The head of a cluster record at off: 1 and *h when there is one whose
 * length fits in the file and in this ensemble's records, 0 when there is
 * none, or PDLA_EIO. */
static int record_head(const pdla_ens_journal *j, uint64_t off, uint64_t size, rec_head *h)
{
    uint8_t b[24]; /* without F, its last 8 bytes are the payload's */
    if (off + 24 > size) return 0;
    const int hr = read_all(j->fd, b, 24, off);
    if (hr < 0) return PDLA_EIO;
    const int with_fp = hr == 1 && !memcmp(b, REC_MAGIC, 8);
    if (hr == 0 || (!with_fp && memcmp(b, REC1_MAGIC, 8))) return 0;
    h->skip = with_fp ? 24 : 16;
    memcpy(&h->len, b + 8, 8);
    memcpy(h->summed, b + 8, (size_t)h->skip - 8);
    const uint64_t room = size - off;
    if (room < h->skip + 8 || h->len > room - h->skip - 8 || h->len < PDLA_ENS_RECORD_FIXED ||
        h->len > j->max_record)
        return 0;
    uint64_t fp = 0;
    if (with_fp) memcpy(&fp, b + 16, 8);
    /* Without F a record is taken only where this build's own would have
     * none: in a format-1 journal, before its first record with F. */
    if (with_fp)
        h->foreign = fp == j->fp ? NULL
                                 : "it was grown with other growth parameters (its parameter fingerprint "
                                   "is not this ensemble's)";
    else
        h->foreign = j->format == 1 && !j->fp_seen ? NULL
                                                   : "it has no parameter fingerprint (an older build's "
                                                     "record) where this journal's records carry one";
    return 1;
}

/* The record at off, if it is one of this ensemble's: magic, a length that
 * fits in the file, the fingerprint of this ensemble's growth parameters
 * (or none, where an old journal's records may have none), its checksum,
 * and (decoded) its index, seed, dimension, particles, positions and
 * values. 1 (with the bytes before its payload in *skip, its payload
 * length in *len and its index in *idx), 0 when it is not, PDLA_ENOMEM,
 * PDLA_EIO, or PDLA_ESTOPPED when the caller's stop flag is set: checked
 * at every candidate, because the time of a scan goes into candidates (up
 * to max_record bytes read and hashed each). *buf, *cap: a scratch buffer
 * kept between calls. */
static int record_at(pdla_ens_journal *j, uint64_t off, uint64_t size, uint8_t **buf, size_t *cap,
                     uint64_t *skip, uint64_t *len, uint64_t *idx)
{
    if (journal_stopped(j)) return PDLA_ESTOPPED;
    rec_head hd;
    const int hr = record_head(j, off, size, &hd);
    if (hr != 1) return hr;
    const uint64_t n = hd.len, at = off + hd.skip;
    /* The fingerprint and the fixed fields first (24 + 136 bytes): a
     * candidate that is not one of this ensemble's records is dropped
     * before it is read whole and hashed (a forged megabyte of record
     * heads, each declaring the longest length, made a resume read and
     * hash ~50 GB), one of other growth parameters after its head alone.
     * The first few such candidates are still checked whole, so that a
     * spliced record of another ensemble is named in the note. */
    if (hd.foreign && j->unknown_checked >= JOURNAL_UNKNOWN_CHECKED) return 0;
    uint8_t fx[PDLA_ENS_RECORD_FIXED];
    const int fr = read_all(j->fd, fx, sizeof fx, at);
    if (fr < 0) return PDLA_EIO;
    pdla_ens_record h;
    if (fr == 0 || pdla_ens_record_peek(fx, n, &h)) return 0;
    const pdla_ens_config *c = &j->cfg;
    if ((hd.foreign || !record_is_ours(c, &h)) && j->unknown_checked++ >= JOURNAL_UNKNOWN_CHECKED) return 0;
    if (n > *cap) {
        uint8_t *g = realloc(*buf, (size_t)n);
        if (!g) return PDLA_ENOMEM;
        *buf = g;
        *cap = (size_t)n;
    }
    uint64_t sum;
    const int pr = read_all(j->fd, *buf, (size_t)n, at), sr = pr == 1 ? read_all(j->fd, &sum, 8, at + n) : 0;
    if (pr < 0 || sr < 0) return PDLA_EIO;
    if (pr == 0 || sr == 0 || fnv1a(fnv1a(FNV_START, hd.summed, (size_t)hd.skip - 8), *buf, (size_t)n) != sum)
        return 0;
    /* A checksum only says the bytes are as written: the record must also
     * be one this ensemble's clusters would make (a record of another
     * ensemble spliced in, or a forged one, would reach ensemble.h5). */
    pdla_ens_record r;
    char why[160];
    const int rc = pdla_ens_record_decode(*buf, (size_t)n, &r, why, sizeof why);
    if (rc == PDLA_ENOMEM) return rc;
    const char *bad = rc != PDLA_OK            ? NULL
                      : hd.foreign             ? hd.foreign
                      : !record_is_ours(c, &r) ? "it is not one of this ensemble's (index, seed, dimension, "
                                                 "particles or positions)"
                                               : record_values_bad(j, &r);
    const int ok = rc == PDLA_OK && !bad;
    if (bad && !j->refused[0]) /* the first, for the note (pdla_ens_journal_refused) */
        snprintf(j->refused, sizeof j->refused, "cluster %llu: %s", (unsigned long long)r.index, bad);
    if (ok && hd.skip == 24) j->fp_seen = 1;
    *idx = r.index;
    pdla_ens_record_free(&r);
    *skip = hd.skip;
    *len = n;
    return ok;
}

/* The offset of the first record of this ensemble after `from`, or NONE:
 * where the scan goes on after a damaged record. A build record counts too
 * (an extension's or resume's build record after the damage would else be
 * cut as torn tail when no cluster record follows it). Reads the file in 1 MB
 * windows looking for the record magic, skipping holes: a sparse region
 * reads as zeros and holds no record, and reading one costs as much as
 * reading data (about 2.5 s of system time a GB on this project's machines:
 * a forged length over gigabytes of hole made every resume that slow).
 * PDLA_ESTOPPED when the caller's stop flag is set (checked at every
 * window and every candidate). */
static int build_at(pdla_ens_journal *j, uint64_t off, uint64_t size, uint64_t *len);

static int next_record(pdla_ens_journal *j, uint64_t from, uint64_t size, uint8_t **buf, size_t *cap,
                       uint64_t *found)
{
    enum { WIN = 1 << 20, M = sizeof REC_MAGIC - 1 };
    *found = NONE;
    uint8_t *w = malloc(WIN);
    if (!w) return PDLA_ENOMEM;
    int rc = PDLA_OK;
    for (uint64_t at = from; at + 24 <= size && *found == NONE && rc == PDLA_OK;) {
        if (journal_stopped(j)) {
            rc = PDLA_ESTOPPED;
            break;
        }
        const off_t data = lseek(j->fd, (off_t)at, SEEK_DATA); /* fails (EINVAL) where unsupported: read on */
        if (data < 0 && errno == ENXIO) break;                   /* a hole to the end */
        if (data > (off_t)at) at = (uint64_t)data;
        if (at + 24 > size) break;
        const size_t n = size - at < WIN ? (size_t)(size - at) : WIN;
        const int got = read_all(j->fd, w, n, at);
        if (got < 0) rc = PDLA_EIO;
        if (got != 1) break;
        for (const uint8_t *p = w; p && p + M <= w + n;) {
            p = memmem(p, (size_t)(w + n - p), "PDLA", 4); /* every magic begins so */
            if (!p || p + M > w + n) break;
            const uint64_t pos = at + (uint64_t)(p - w);
            uint64_t skip, len, idx;
            const int r = !memcmp(p, BLD_MAGIC, M)                                ? build_at(j, pos, size, &len)
                          : !memcmp(p, REC_MAGIC, M) || !memcmp(p, REC1_MAGIC, M) ? record_at(j, pos, size, buf, cap,
                                                                                              &skip, &len, &idx)
                                                                                  : 0;
            if (r < 0) {
                rc = r;
                break;
            }
            if (r == 1) {
                *found = at + (uint64_t)(p - w);
                break;
            }
            p++;
        }
        if (n < WIN) break;
        at += n - (M - 1); /* a magic across the window's end is found in the next */
    }
    free(w);
    return rc;
}

/* A build record at off ("PDLABLD1", u64 n, n bytes of revision, u64
 * FNV-1a): 1 (its revision added to j->builds unless listed, *len = n),
 * 0 when there is none, PDLA_EIO when the file cannot be read. */
static int build_at(pdla_ens_journal *j, uint64_t off, uint64_t size, uint64_t *len)
{
    uint8_t head[16];
    char name[208];
    uint64_t n, sum;
    if (off + 24 > size) return 0;
    const int hr = read_all(j->fd, head, 16, off);
    if (hr < 0) return PDLA_EIO;
    if (hr == 0 || memcmp(head, BLD_MAGIC, 8)) return 0;
    memcpy(&n, head + 8, 8);
    if (n < 1 || n > 200 || n > size - off - 24) return 0;
    const int nr = read_all(j->fd, name, (size_t)n, off + 16), sr = nr == 1 ? read_all(j->fd, &sum, 8, off + 16 + n) : 0;
    if (nr < 0 || sr < 0) return PDLA_EIO;
    if (nr == 0 || sr == 0 || fnv1a(fnv1a(FNV_START, head + 8, 8), name, (size_t)n) != sum) return 0;
    name[n] = '\0';
    if (strlen(name) != n) return 0;
    if (!builds_has(j->builds, name, (size_t)n)) (void)builds_add(j->builds, name); /* full: not listed */
    *len = n;
    return 1;
}

/* Scan the records after the header. A damaged record followed by a valid
 * one (a bad sector, a stray write) is skipped and counted in j->damaged:
 * cutting there would throw away every record after it. What follows the
 * last valid record is the torn tail a crash left (j->torn), cut by
 * pdla_ens_journal_begin_append. Reads only: stopped by the caller's flag
 * (PDLA_ESTOPPED), it leaves the file as it was. */
static int scan_records(pdla_ens_journal *j, uint64_t size, char *err, size_t errlen)
{
    uint64_t off = j->end;
    uint8_t *buf = NULL;
    size_t cap = 0;
    int rc = PDLA_OK;
    while (off + 24 <= size) {
        uint64_t skip = 16, len = 0, idx = 0;
        int r = build_at(j, off, size, &len);
        if (r == 1) {
            off += 24 + len;
            continue;
        }
        if (r == 0) r = record_at(j, off, size, &buf, &cap, &skip, &len, &idx);
        if (r == 0) {
            uint64_t next;
            r = next_record(j, off + 1, size, &buf, &cap, &next);
            if (r == PDLA_OK && next == NONE) break;
            if (r == PDLA_OK) {
                j->damaged += next - off;
                off = next;
                continue;
            }
        }
        if (r < 0) {
            /* Never a torn tail: cutting there would lose the records after. */
            rc = r == PDLA_ENOMEM    ? pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory reading the journal")
                 : r == PDLA_ESTOPPED ? pdla_errorf(PDLA_ESTOPPED, err, errlen, "stopped while reading %s near byte "
                                                   "%llu", j->path, (unsigned long long)off)
                                      : pdla_errorf(PDLA_EIO, err, errlen, "cannot read %s near byte %llu: %s", j->path,
                                                    (unsigned long long)off, strerror(errno));
            break;
        }
        if (j->offset[idx] == NONE) {
            j->offset[idx] = off + skip;
            j->length[idx] = len;
            j->count++;
        }
        off += skip + len + 8;
    }
    free(buf);
    j->torn = size - off;
    j->end = off;
    return rc;
}

int pdla_ens_journal_open(const char *dir, pdla_ens_journal **out, char *err, size_t errlen)
{
    return pdla_ens_journal_open_stoppable(dir, NULL, NULL, out, err, errlen);
}

int pdla_ens_journal_open_stoppable(const char *dir, pdla_ens_stop_fn stop, void *user, pdla_ens_journal **out,
                                    char *err, size_t errlen)
{
    *out = NULL;
    if (strlen(dir) > 4000) return pdla_errorf(PDLA_EINVAL, err, errlen, "directory name too long");
    pdla_ens_journal *j = journal_new(dir, NULL);
    if (!j) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the journal");
    j->stop = stop;
    j->stop_user = user;
    int rc = PDLA_EIO;
    char why[600] = "";
    char *text = NULL;
    struct stat st;
    /* O_NONBLOCK: a FIFO put in the journal's place would block open()
     * for good, and SIGINT/SIGTERM only set a flag (SA_RESTART). */
    j->fd = open(j->path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (j->fd < 0 || fstat(j->fd, &st)) {
        snprintf(why, sizeof why, "%s", strerror(errno));
        goto fail;
    }
    if (!S_ISREG(st.st_mode)) {
        snprintf(why, sizeof why, "not a regular file");
        goto fail;
    }
    uint8_t head[16];
    uint32_t h[2];
    if (read_all(j->fd, head, 16, 0) != 1 || memcmp(head, HEAD_MAGIC, 8)) {
        snprintf(why, sizeof why, "not a pdla ensemble journal");
        goto fail;
    }
    memcpy(h, head + 8, 8);
    if (h[0] != BOM || h[1] > 1u << 20 || (uint64_t)st.st_size < 24 + (uint64_t)h[1]) {
        snprintf(why, sizeof why, "damaged header (or another byte order)");
        goto fail;
    }
    text = malloc((size_t)h[1] + 1);
    uint64_t sum;
    if (!text || read_all(j->fd, text, h[1], 16) != 1 || read_all(j->fd, &sum, 8, 16 + h[1]) != 1 ||
        fnv1a(FNV_START, text, h[1]) != sum) {
        snprintf(why, sizeof why, "damaged header");
        goto fail;
    }
    text[h[1]] = '\0';
    if (header_parse(text, &j->cfg, &j->format, j->builds, why, sizeof why)) goto fail;
    j->max_record = pdla_ens_record_max_bytes(&j->cfg);
    j->fp = pdla_ens_fingerprint(&j->cfg);
    if (journal_alloc_index(j) || journal_grid(j)) {
        rc = PDLA_ENOMEM;
        snprintf(why, sizeof why, "out of memory");
        goto fail;
    }
    j->head_end = j->end = 24 + h[1];
    rc = scan_records(j, (uint64_t)st.st_size, err, errlen);
    free(text);
    if (rc) {
        pdla_ens_journal_close(j);
        return rc;
    }
    *out = j;
    return PDLA_OK;
fail:
    free(text);
    rc = pdla_errorf(rc, err, errlen, "cannot read %s: %s", j->path, why);
    pdla_ens_journal_close(j);
    return rc;
}

int pdla_ens_journal_begin_append(pdla_ens_journal *j, char *err, size_t errlen)
{
    if (j->appendable) return PDLA_OK;
    const int fd = open(j->path, O_RDWR | O_CLOEXEC);
    if (fd < 0) return pdla_errorf(PDLA_EIO, err, errlen, "cannot open %s for writing: %s", j->path, strerror(errno));
    if (j->torn && (ftruncate(fd, (off_t)j->end) || fsync(fd))) {
        const int e = errno;
        close(fd);
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot cut the torn tail of %s: %s", j->path, strerror(e));
    }
    close(j->fd);
    j->fd = fd;
    j->appendable = 1;
    return PDLA_OK;
}

/* The header of c: "PDLAENS1", BOM, length, text, checksum. malloc'ed,
 * *len bytes; NULL when out of memory. */
static uint8_t *header_bytes(const pdla_ens_config *c, int format, const char *builds, size_t *len)
{
    size_t tl = 0;
    char *text = header_text(c, format, builds, &tl);
    uint8_t *buf = text ? malloc(24 + tl) : NULL;
    if (buf) {
        const uint32_t h[2] = {BOM, (uint32_t)tl};
        const uint64_t sum = fnv1a(FNV_START, text, tl);
        memcpy(buf, HEAD_MAGIC, 8);
        memcpy(buf + 8, h, 8);
        memcpy(buf + 16, text, tl);
        memcpy(buf + 16 + tl, &sum, 8);
        *len = 24 + tl;
    }
    free(text);
    return buf;
}

/* The records [from, to) of fd appended to out at offset at. */
static int copy_range(int fd, uint64_t from, uint64_t to, int out, uint64_t at)
{
    enum { CHUNK = 1 << 20 };
    uint8_t *buf = malloc(CHUNK);
    int bad = !buf;
    for (uint64_t off = from; off < to && !bad; off += CHUNK) {
        const size_t n = to - off < CHUNK ? (size_t)(to - off) : CHUNK;
        bad = read_all(fd, buf, n, off) != 1 || write_all(out, buf, n, at + (off - from));
    }
    free(buf);
    return bad ? -1 : 0;
}

/* Rewrite j's file for `clusters` clusters: the new header and the valid
 * records into a temporary file, fsync'ed and renamed over it (a crash
 * leaves the old or the new journal whole). The header keeps j's list of
 * builds (its own line merged with the build records, which are copied
 * too); this build is added, like any resume's, by pdla_ens_journal_join
 * before it grows anything - one place that lists builds. */
static int journal_rewrite_file(pdla_ens_journal *j, uint64_t clusters, char *err, size_t errlen)
{
    pdla_ens_config c = j->cfg;
    c.clusters = clusters;
    int rc = pdla_ens_config_check(&c, err, errlen);
    if (rc) return rc;
    char dir[4200], tmp[4300];
    snprintf(dir, sizeof dir, "%s", j->path);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = '\0';
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", j->path, (long)getpid());
    size_t hl = 0;
    /* The format stays: an old journal's records without F are copied as they are. */
    uint8_t *head = header_bytes(&c, j->format, j->builds, &hl);
    if (!head) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the journal header");
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    /* The valid records only: a torn tail is left behind. */
    const int bad = fd < 0 || write_all(fd, head, hl, 0) || copy_range(j->fd, j->head_end, j->end, fd, hl) ||
                    fsync(fd);
    const int e = errno;
    free(head);
    if (fd >= 0 && close(fd) && !bad) rc = PDLA_EIO;
    if (bad || rc || rename(tmp, j->path)) {
        const int e2 = bad ? e : errno;
        unlink(tmp);
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot rewrite %s for %llu clusters: %s", j->path,
                           (unsigned long long)clusters, strerror(e2));
    }
    sync_dir(dir);
    return PDLA_OK;
}


/* Rewrite j for `clusters`, close it and reopen it into *out. */
static int journal_rewrite(pdla_ens_journal *j, uint64_t clusters, pdla_ens_journal **out, char *err,
                           size_t errlen)
{
    *out = NULL;
    const int rc0 = journal_rewrite_file(j, clusters, err, errlen);
    char dir[4200];
    snprintf(dir, sizeof dir, "%s", j->path);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = '\0';
    const pdla_ens_stop_fn stop = j->stop; /* the reopen's scan stops as the first did */
    void *const user = j->stop_user;
    pdla_ens_journal_close(j);
    return rc0 ? rc0 : pdla_ens_journal_open_stoppable(dir, stop, user, out, err, errlen);
}

int pdla_ens_journal_extend(pdla_ens_journal *j, uint64_t clusters, pdla_ens_journal **out, char *err,
                            size_t errlen)
{
    if (clusters <= j->cfg.clusters) {
        *out = NULL;
        const int rc = pdla_errorf(PDLA_EINVAL, err, errlen, "cannot extend %s from %llu to %llu clusters",
                                   j->path, (unsigned long long)j->cfg.clusters, (unsigned long long)clusters);
        pdla_ens_journal_close(j);
        return rc;
    }
    return journal_rewrite(j, clusters, out, err, errlen);
}

/* Append one record: magic, u64 length, u64 *fp (cluster records; NULL:
 * none, build records), payload, u64 FNV-1a of all after the magic, then
 * fdatasync, under the append mutex; on success *at = its payload offset.
 * A failed write breaks the journal for appends (a torn tail, cut on the
 * next open). */
static int append_raw(pdla_ens_journal *j, const char *magic, const uint64_t *fp, const void *payload, size_t len,
                      uint64_t *at, char *err, size_t errlen)
{
    uint8_t head[24];
    const uint64_t len64 = len;
    const size_t hl = fp ? 24 : 16;
    memcpy(head, magic, 8);
    memcpy(head + 8, &len64, 8);
    if (fp) memcpy(head + 16, fp, 8);
    const uint64_t sum = fnv1a(fnv1a(FNV_START, head + 8, hl - 8), payload, len);
    if (!j->appendable || j->broken) return pdla_errorf(PDLA_EIO, err, errlen, "%s is not open for appending", j->path);
    if (write_all(j->fd, head, hl, j->end) || write_all(j->fd, payload, len, j->end + hl) ||
        write_all(j->fd, &sum, 8, j->end + hl + len) || fdatasync(j->fd)) {
        j->broken = 1;
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot append to %s: %s", j->path, strerror(errno));
    }
    *at = j->end + hl;
    j->end += hl + len + 8;
    return PDLA_OK;
}

/* A build record for revision `name` (listed unless the list is full). */
static int append_build(pdla_ens_journal *j, const char *name, char *err, size_t errlen)
{
    char probe[JOURNAL_BUILDS_MAX];
    memcpy(probe, j->builds, sizeof probe);
    if (builds_add(probe, name)) return PDLA_OK; /* full, or not printable: not recorded */
    uint64_t at;
    PDLA_MUST(pthread_mutex_lock(&j->mu));
    const int rc = append_raw(j, BLD_MAGIC, NULL, name, strlen(name), &at, err, errlen);
    if (rc == PDLA_OK) memcpy(j->builds, probe, sizeof probe);
    PDLA_MUST(pthread_mutex_unlock(&j->mu));
    return rc;
}

int pdla_ens_journal_join(pdla_ens_journal *j, char *err, size_t errlen)
{
    if (builds_has_this(j)) return PDLA_OK;
    /* Records of a journal from before builds were recorded. */
    int rc = !*j->builds && j->count ? append_build(j, "unrecorded", err, errlen) : PDLA_OK;
    if (rc == PDLA_OK) rc = append_build(j, pdla_build_revision(), err, errlen);
    return rc;
}

const char *pdla_ens_journal_builds(const pdla_ens_journal *j) { return j->builds; }
int pdla_ens_journal_built_here(const pdla_ens_journal *j) { return builds_has_this(j); }
const pdla_ens_config *pdla_ens_journal_config(const pdla_ens_journal *j) { return &j->cfg; }
uint64_t pdla_ens_journal_count(const pdla_ens_journal *j) { return j->count; }
uint64_t pdla_ens_journal_torn_bytes(const pdla_ens_journal *j) { return j->torn; }
uint64_t pdla_ens_journal_damaged_bytes(const pdla_ens_journal *j) { return j->damaged; }
const char *pdla_ens_journal_refused(const pdla_ens_journal *j) { return j->refused; }

int pdla_ens_journal_has(const pdla_ens_journal *j, uint64_t i)
{
    return i < j->cfg.clusters && j->offset[i] != NONE;
}

int pdla_ens_journal_append(pdla_ens_journal *j, const pdla_ens_record *rec, char *err, size_t errlen)
{
    const pdla_ens_config *c = &j->cfg;
    if (rec->index >= c->clusters || rec->seed != c->params.seed + rec->index || rec->dim != c->params.dim ||
        (c->keep_positions && rec->npos != rec->particles) || (!c->keep_positions && rec->npos))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cluster record %llu does not belong to this ensemble",
                           (unsigned long long)rec->index);
    uint8_t *payload = NULL;
    size_t len = 0;
    if (pdla_ens_record_encode(rec, &payload, &len))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot encode cluster record %llu", (unsigned long long)rec->index);
    int rc = PDLA_OK;
    uint64_t at = 0; /* set by append_raw on success (gcc 12 cannot tell) */
    PDLA_MUST(pthread_mutex_lock(&j->mu));
    /* One record, written in order, then made durable before it counts;
     * it carries this ensemble's fingerprint, also in an old journal. */
    if (j->offset[rec->index] == NONE &&
        (rc = append_raw(j, REC_MAGIC, &j->fp, payload, len, &at, err, errlen)) == PDLA_OK) {
        j->offset[rec->index] = at;
        j->length[rec->index] = len;
        j->count++;
    }
    PDLA_MUST(pthread_mutex_unlock(&j->mu));
    free(payload);
    return rc;
}

int pdla_ens_journal_read(const pdla_ens_journal *j, uint64_t i, pdla_ens_record *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (!pdla_ens_journal_has(j, i))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cluster %llu is not in the journal", (unsigned long long)i);
    uint8_t *buf = malloc((size_t)j->length[i]);
    if (!buf) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory reading cluster %llu", (unsigned long long)i);
    int rc;
    if (read_all(j->fd, buf, (size_t)j->length[i], j->offset[i]) != 1)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot read cluster %llu from %s", (unsigned long long)i, j->path);
    else
        rc = pdla_ens_record_decode(buf, (size_t)j->length[i], out, err, errlen);
    free(buf);
    return rc;
}

void pdla_ens_journal_close(pdla_ens_journal *j)
{
    if (!j) return;
    if (j->fd >= 0) close(j->fd);
    PDLA_MUST(pthread_mutex_destroy(&j->mu));
    free(j->offset);
    free(j->length);
    free(j->grid);
    free(j);
}

int pdla_ens_config_compare(const pdla_ens_config *stored, const pdla_ens_config *asked, uint32_t asked_fields,
                            int clusters_given, int keep_given, char *err, size_t errlen)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    for (size_t i = 0; i < n; i++) {
        if (!(t[i].bit & asked_fields) || (t[i].bit & (PDLA_PARAM_THREADS | PDLA_PARAM_BIND))) continue;
        if (pdla_param_equal(&t[i], &stored->params, &asked->params)) continue;
        char a[80], b[80];
        pdla_param_format_two(&t[i], &stored->params, &asked->params, a, b, sizeof a);
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cannot resume: the ensemble has --%s %s, asked %s "
                                                     "(an ensemble resumes with its own growth parameters)",
                           t[i].option, a, b);
    }
    if (clusters_given && stored->clusters != asked->clusters)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cannot resume: the ensemble has --clusters %llu, asked %llu",
                           (unsigned long long)stored->clusters, (unsigned long long)asked->clusters);
    if (keep_given && stored->keep_positions != asked->keep_positions)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cannot resume: the ensemble was started %s --keep-positions",
                           stored->keep_positions ? "with" : "without");
    return PDLA_OK;
}
