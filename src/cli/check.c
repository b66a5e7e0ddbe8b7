/*
 * check.c - `pdla check FILE [--json]`: checks a DLA cluster file against
 * what a grown cluster must be, from its positions alone (pdla_check_* in
 * the library): no overlap, every particle in contact (with an earlier one
 * when the file is in arrival order), the seed at the origin, and R_g, R_ext
 * and the R_g series recomputed exactly and compared with what the file
 * stores. Exit 0 when everything holds, 1 when something does not (the
 * report says what, and one line on stderr), 2 for bad usage or a file that
 * is not a DLA cluster file. A DLCA file goes to check_dlca.c.
 */
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check_event.h"
#include "dlca_cmd.h"
#include "h5read.h"
#include "pdla/dlca.h"
#include "pdla/h5check.h"
#include "pdla/pdla.h"
#include "tools.h"

static const char check_help[] =
    "Usage: pdla check FILE [--json]\n"
    "Check a DLA cluster file (cluster.h5) or checkpoint (checkpoint.h5, loaded\n"
    "and verified as --resume does) from its positions alone, exactly:\n"
    "no two particles closer than one diameter D; every particle within D + eps\n"
    "of an earlier one when the file is in arrival order (--arrival), of another\n"
    "one otherwise; the seed at the origin; and R_g, R_ext and (arrival order)\n"
    "every R_g(N) sample recomputed from the positions, bit for bit as stored.\n"
    "Time and memory are about those of inserting the particles into pdla's\n"
    "tree (4-5 bytes a particle). It stops reading after 10000 failures.\n"
    "\n"
    "A DLCA cluster.h5 or checkpoint (--model dlca) is checked against what the\n"
    "model writes, exactly: every monomer inside the box, on its own site;\n"
    "clusters numbered in monomer order, each one face-connected piece on the\n"
    "torus, none touching another with sticking 1; a spanning stop proved by a\n"
    "walk over a cluster's contacts, and no cluster spanning under another stop;\n"
    "/clusters size and R_g (bit for bit, from the walk's offsets), /results,\n"
    "the stop, /series and /snapshots recomputed from the monomers.\n"
    "\n"
    "  --json     one JSON object on stdout instead of text\n"
    "  -h, --help print this help and exit\n"
    "\n"
    "Exit status: 0 the file passes; 1 it fails a check (the report says\n"
    "which), a read failed, the checkpoint loader refused it as damaged, or it\n"
    "is an HDF5 file that HDF5 cannot open (truncated);\n"
    "2 bad usage or a file that is not a DLA, DLCA or event cluster file or\n"
    "checkpoint (or a DLCA file pdla cannot have written: a dataset missing or\n"
    "declaring more than the file stores, /parameters out of range).\n"
    "\n";

/* Reading stops after this many failures: a forged file of 10^12 rows at
 * one point would otherwise cost quadratic time. */
#define CHECK_MAX_FAILURES 10000u

typedef struct check_feed {
    pdla_check *c;
    char *err;
    size_t errlen;
    int dim;
    int stopped;
} check_feed;

/* h5r_stream's callback: the rows in pieces of 1024, stopping (1) once the
 * failures pass the cap. */
static int feed_rows(const int32_t *xyz, size_t rows, uint64_t first, void *user)
{
    (void)first;
    check_feed *f = user;
    const size_t dim = (size_t)f->dim;
    for (size_t i = 0; i < rows; i += 1024) {
        const size_t m = rows - i < 1024 ? rows - i : 1024;
        if (pdla_check_add(f->c, xyz + i * dim, m, f->err, f->errlen)) return -1;
        if (pdla_check_failures(f->c) >= CHECK_MAX_FAILURES) {
            f->stopped = 1;
            return 1;
        }
    }
    return 0;
}

/* What the file stores beside the positions. */
typedef struct check_stored {
    int eps;
    double rg_diam;        /* NaN: not stored */
    double r_ext_units;    /* NaN: not stored */
    double particles;      /* /results particles, NaN: not stored */
    uint64_t *sn;          /* the stored series (malloc'ed from a file) */
    double *srg;
    size_t sk;
    int series_bad;        /* the stored series' counts do not increase */
    int series_wanted;     /* rg_per_decade > 0 and N >= 1: a series must exist */
    int arrival_wanted;    /* /parameters record_arrival = 1: the rows must be in arrival order */
    uint64_t tree_missing; /* checkpoint: tree particles not in the arrival record */
} check_stored;

typedef struct check_result {
    pdla_check_report r;
    int rg_ok, rext_ok, count_ok, series_ok, stopped;
} check_result;

static void print_where(FILE *o, const pdla_check_where *w, int dim)
{
    if (w->row != UINT64_MAX) fprintf(o, "row %" PRIu64 " ", w->row);
    fprintf(o, "at (%" PRId64 ", %" PRId64, w->x[0], w->x[1]);
    if (dim == 3) fprintf(o, ", %" PRId64, w->x[2]);
    fprintf(o, ") units");
}

static const char *ok_word(int ok) { return ok ? "as stored" : "DIFFERS from the stored value"; }

static const char *stored_word(double stored, int ok) { return isnan(stored) ? "NOT stored" : ok_word(ok); }

static void print_text(FILE *o, const h5r_file *f, const check_stored *s, const check_result *res)
{
    const pdla_check_report *r = &res->r;
    fprintf(o, "file         %s\n", f->path);
    fprintf(o, "particles    %" PRIu64 " in %dD, D = %d units, eps = %d units, rows in %s order%s\n",
            r->particles, f->dim, f->diameter_units, s->eps, r->arrival ? "arrival" : "tree",
            res->stopped ? " (reading stopped: too many failures)" : "");
    if (!r->overlaps)
        fprintf(o, "overlaps     none (closest centres %.6f diameters apart)\n", r->closest_diam);
    else {
        fprintf(o, "overlaps     %" PRIu64 " pairs closer than D; first: ", r->overlaps);
        print_where(o, &r->first_overlap, f->dim);
        fputc('\n', o);
    }
    if (!r->detached && r->arrival)
        fprintf(o, "contacts     every particle within D + eps of an earlier one (widest %.6f diameters)\n",
                r->widest_contact_diam);
    else if (!r->detached)
        fprintf(o, "contacts     every particle joined to the seed through contacts closer than D + eps "
                   "(widest %.6f diameters)\n", r->widest_contact_diam);
    else {
        fprintf(o, "contacts     %" PRIu64 " particles %s; first: ", r->detached,
                r->arrival ? "touch no earlier particle" : "not joined to the seed through contacts");
        print_where(o, &r->first_detached, f->dim);
        fputc('\n', o);
    }
    if (r->out_of_range) {
        fprintf(o, "range        %" PRIu64 " rows beyond the coordinate limit; first: ", r->out_of_range);
        print_where(o, &r->first_out_of_range, f->dim);
        fputc('\n', o);
    }
    fprintf(o, "seed         %s\n", r->seed_at_origin ? "at the origin" : r->arrival ? "NOT at the origin (row 0)" : "NO particle at the origin");
    fprintf(o, "count        /results particles: %s\n", stored_word(s->particles, res->count_ok));
    fprintf(o, "R_g          %.9g diameters: %s\n", r->rg_diam, stored_word(s->rg_diam, res->rg_ok));
    fprintf(o, "R_ext        %" PRId64 " units: %s\n", r->r_ext_units, stored_word(s->r_ext_units, res->rext_ok));
    if (s->tree_missing)
        fprintf(o, "tree         %" PRIu64 " particles of the tree are NOT in the arrival record\n", s->tree_missing);
    if (!r->arrival && s->arrival_wanted)
        fprintf(o, "order        NOT arrival, although /parameters record_arrival = 1\n");
    if (!r->arrival)
        fprintf(o, "R_g series   not checked (rows not in arrival order)\n");
    else if (!s->sk && s->series_wanted)
        fprintf(o, "R_g series   MISSING (rg_per_decade > 0)\n");
    else if (s->series_bad)
        fprintf(o, "R_g series   BAD: its counts do not increase\n");
    else if (r->series_mismatches)
        fprintf(o, "R_g series   %" PRIu64 " of %zu samples DIFFER; first: sample %" PRIu64 "\n",
                r->series_mismatches, s->sk, r->first_series_mismatch);
    else
        fprintf(o, "R_g series   %" PRIu64 " samples, every one as stored\n", r->series_checked);
}

static void json_where(FILE *o, const char *name, uint64_t count, const pdla_check_where *w, int dim)
{
    fprintf(o, "  \"%s\": ", name);
    if (!count) {
        fputs("null,\n", o);
        return;
    }
    fprintf(o, "{\"row\": ");
    if (w->row == UINT64_MAX) fputs("null", o);
    else fprintf(o, "%" PRIu64, w->row);
    fprintf(o, ", \"x\": [%" PRId64 ", %" PRId64, w->x[0], w->x[1]);
    if (dim == 3) fprintf(o, ", %" PRId64, w->x[2]);
    fputs("]},\n", o);
}

static void print_json(FILE *o, const h5r_file *f, const check_stored *s, const check_result *res, int pass)
{
    const pdla_check_report *r = &res->r;
    fputs("{\n  \"file\": ", o);
    tool_json_str(o, f->path);
    fprintf(o, ",\n  \"pass\": %s,\n  \"particles\": %" PRIu64 ",\n  \"dim\": %d,\n", pass ? "true" : "false",
            r->particles, f->dim);
    fprintf(o, "  \"arrival\": %s,\n  \"stopped\": %s,\n", r->arrival ? "true" : "false", res->stopped ? "true" : "false");
    fprintf(o, "  \"overlaps\": %" PRIu64 ",\n", r->overlaps);
    json_where(o, "first_overlap", r->overlaps, &r->first_overlap, f->dim);
    fprintf(o, "  \"detached\": %" PRIu64 ",\n", r->detached);
    json_where(o, "first_detached", r->detached, &r->first_detached, f->dim);
    fprintf(o, "  \"out_of_range\": %" PRIu64 ",\n  \"seed_at_origin\": %s,\n", r->out_of_range,
            r->seed_at_origin ? "true" : "false");
    fputs("  \"closest_diam\": ", o);
    tool_json_num(o, r->closest_diam, 17);
    fputs(",\n  \"widest_contact_diam\": ", o);
    tool_json_num(o, r->widest_contact_diam, 17);
    fputs(",\n  \"rg_diam\": ", o);
    tool_json_num(o, r->rg_diam, 17);
    fprintf(o, ",\n  \"r_ext_units\": %" PRId64 ",\n", r->r_ext_units);
    fprintf(o, "  \"count_as_stored\": %s,\n", res->count_ok ? "true" : "false");
    fprintf(o, "  \"rg_as_stored\": %s,\n", res->rg_ok ? "true" : "false");
    fprintf(o, "  \"r_ext_as_stored\": %s,\n", res->rext_ok ? "true" : "false");
    fprintf(o, "  \"tree_not_in_arrival\": %" PRIu64 ",\n", s->tree_missing);
    fprintf(o, "  \"series_checked\": %" PRIu64 ",\n  \"series_mismatches\": %" PRIu64 "\n}\n",
            r->series_checked, r->series_mismatches + (uint64_t)s->series_bad);
}

/* Reads eps and the stored results; -1 with err when the file lacks eps. */
static int read_stored(h5r_file *f, check_stored *s, char *err, size_t errlen)
{
    h5r_attrs par = {0}, res = {0};
    int rc = -1;
    if (h5r_read_attrs(f, "/parameters", &par, err, errlen) || h5r_read_attrs(f, "/results", &res, err, errlen))
        goto out;
    const double eps = h5r_attr_num(&par, "eps");
    if (!(eps >= 2 && eps <= f->diameter_units / 2 && eps == floor(eps))) {
        snprintf(err, errlen, "%s: /parameters eps is missing or not in [2, D/2]", f->path);
        goto out;
    }
    const double res_units = h5r_attr_num(&par, "resolution");
    if (!isnan(res_units) && res_units != f->diameter_units) {
        snprintf(err, errlen, "%s: diameter_units %d and /parameters resolution %.17g disagree", f->path,
                 f->diameter_units, res_units);
        goto out;
    }
    s->eps = (int)eps;
    s->rg_diam = h5r_attr_num(&res, "rg_diam");
    s->r_ext_units = h5r_attr_num(&res, "r_ext_units");
    s->particles = h5r_attr_num(&res, "particles");
    s->arrival_wanted = h5r_attr_num(&par, "record_arrival") == 1;
    /* The series is read only where it is checked (arrival order), and no
     * longer than the log grid makes it: rg_per_decade samples a decade. */
    const double rpd = h5r_attr_num(&par, "rg_per_decade");
    const double n = (double)f->n;
    s->series_wanted = rpd > 0 && f->n > 0;
    double most = rpd >= 0 && rpd <= 1e6 ? rpd * (log10(n > 1 ? n : 1) + 1) + 2 : n;
    if (most > n) most = n;
    rc = f->arrival && h5r_read_series_max(f, (uint64_t)most, &s->sn, &s->srg, &s->sk, err, errlen) ? -1 : 0;
out:
    h5r_attrs_free(&par);
    h5r_attrs_free(&res);
    return rc;
}

/* Where the rows come from: a cluster file (streamed) or a loaded
 * checkpoint's engine (its arrival record, else its tree). */
typedef struct check_source {
    h5r_file *f;
    const pdla_engine *e;
    uint64_t *tree_missing; /* checkpoint with an arrival record: tree particles not in it */
} check_source;

static int feed_visit(const int32_t *xyz, size_t n, void *user) { return feed_rows(xyz, n, 0, user); }

/* A checkpoint's tree against the arrival record just checked: the tree is
 * what --resume grows from, so its particles must be the record's. */
typedef struct tree_vs_arrival {
    pdla_check *c;
    uint64_t missing;
} tree_vs_arrival;

static int tree_missing_visit(const int32_t *xyz, size_t n, void *user)
{
    tree_vs_arrival *v = user;
    const int64_t m = pdla_check_missing(v->c, xyz, n);
    if (m < 0) return -1;
    v->missing += (uint64_t)m;
    return 0;
}

static int feed_source(const check_source *src, check_feed *feed, char *err, size_t errlen)
{
    if (src->f) return h5r_stream(src->f, H5R_MAX_SLAB_ROWS, feed_rows, feed, err, errlen) < 0 ? -1 : 0;
    uint64_t n = 0;
    const int32_t *rows = pdla_engine_arrival(src->e, &n);
    if (!rows || n != pdla_engine_count(src->e)) return pdla_engine_visit(src->e, feed_visit, feed) < 0 ? -1 : 0;
    const int rc = feed_rows(rows, (size_t)n, 0, feed);
    if (rc) return rc < 0 ? -1 : 0;
    tree_vs_arrival v = {feed->c, 0};
    if (pdla_engine_visit(src->e, tree_missing_visit, &v))
        return pdla_errorf(-1, err, errlen, "out of memory matching the tree against the arrival record");
    *src->tree_missing = v.missing;
    return 0;
}

/* Runs the check; TOOL_OK with res filled, or an exit code after the one
 * line on stderr. f describes the rows (path, dim, D, arrival). */
static int run_check(const h5r_file *f, const check_source *src, check_stored *s, check_result *res)
{
    char err[1024];
    pdla_check *c = NULL;
    if (pdla_check_create(&c, f->dim, f->diameter_units, s->eps, f->arrival, err, sizeof err)) {
        fprintf(stderr, "pdla check: %s: %s\n", f->path, err);
        return TOOL_USAGE;
    }
    if (f->arrival && s->sk && pdla_check_series(c, s->sn, s->srg, s->sk, err, sizeof err)) s->series_bad = 1;
    check_feed feed = {c, err, sizeof err, f->dim, 0};
    int rc = TOOL_OK;
    if (feed_source(src, &feed, err, sizeof err)) {
        fprintf(stderr, "pdla check: %s\n", err);
        rc = TOOL_RUNTIME;
    }
    if (rc == TOOL_OK && pdla_check_finish(c, !feed.stopped, &res->r, err, sizeof err)) {
        fprintf(stderr, "pdla check: %s\n", err);
        rc = TOOL_RUNTIME;
    }
    res->stopped = feed.stopped;
    pdla_check_destroy(c);
    return rc;
}

/* The verdict, printed; TOOL_OK when the file passes, else TOOL_RUNTIME
 * after one line on stderr. */
static int report(const h5r_file *f, const check_stored *s, check_result *res, int json)
{
    const pdla_check_report *r = &res->r;
    res->count_ok = s->particles == (double)r->particles && r->particles == f->n;
    res->rg_ok = s->rg_diam == r->rg_diam;
    res->rext_ok = s->r_ext_units == (double)r->r_ext_units;
    const int series_ok = !r->arrival || (!s->series_bad && !r->series_mismatches && (s->sk || !s->series_wanted));
    /* Every stored value is required: pdla writes them all. */
    const int pass = !res->stopped && !r->overlaps && !r->detached && !r->out_of_range && r->seed_at_origin &&
                     res->count_ok && res->rg_ok && res->rext_ok && series_ok && !s->tree_missing &&
                     (r->arrival || !s->arrival_wanted);
    if (json) print_json(stdout, f, s, res, pass);
    else {
        print_text(stdout, f, s, res);
        fprintf(stdout, "result       %s\n", pass ? "pass" : "FAIL");
    }
    if (tools_stdout_done("check")) return TOOL_RUNTIME;
    if (pass) return TOOL_OK;
    fprintf(stderr, "pdla check: %s fails the check (%" PRIu64 " overlaps, %" PRIu64 " detached particles%s)\n",
            f->path, r->overlaps, r->detached, res->stopped ? ", reading stopped" : "");
    return TOOL_RUNTIME;
}

/* A DLA checkpoint: loaded (and so verified) by the library, then its
 * particles checked as a cluster file's, against the engine's own R_g,
 * R_ext, count and series. */
static int check_checkpoint(const char *path, int json)
{
    char err[1024];
    pdla_engine *e = NULL;
    pdla_checkpoint_info info;
    if (pdla_checkpoint_load(&e, path, NULL, 0, &info, err, sizeof err)) {
        /* A DLA checkpoint the loader refuses (damaged, forged) fails. */
        fprintf(stderr, "pdla check: %s\n", err);
        return TOOL_RUNTIME;
    }
    const pdla_params *P = pdla_engine_params(e);
    pdla_stats st;
    pdla_engine_stats(e, &st);
    uint64_t na = 0;
    const int32_t *arr = pdla_engine_arrival(e, &na);
    h5r_file f = {0};
    f.path = path;
    f.dim = P->dim;
    f.diameter_units = P->resolution;
    f.n = st.particles;
    f.arrival = arr && na == st.particles;
    check_stored s = {.eps = P->eps, .rg_diam = st.rg_diam, .r_ext_units = (double)st.r_ext,
                      .particles = (double)st.particles, .series_wanted = P->rg_per_decade > 0 && st.particles > 0,
                      .arrival_wanted = P->record_arrival};
    const uint64_t *sn = NULL;
    const double *srg = NULL;
    pdla_engine_rg_series(e, &sn, &srg, &s.sk);
    s.sn = (uint64_t *)(uintptr_t)sn; /* read only: run_check copies them */
    s.srg = (double *)(uintptr_t)srg;
    check_result res = {0};
    const check_source src = {NULL, e, &s.tree_missing};
    int rc = run_check(&f, &src, &s, &res);
    if (rc == TOOL_OK) rc = report(&f, &s, &res, json);
    pdla_engine_destroy(e);
    return rc;
}

static int is_dla_checkpoint(const char *path)
{
    char format[32];
    return pdla_h5_file_attr(path, "format", format, sizeof format) == 0 &&
           strcmp(format, "pdla-checkpoint") == 0;
}

int tool_check(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"json", no_argument, NULL, 'j'}, {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    int json = 0, c;
    if (tools_options_begin("check", argc, argv, longopts, "h")) return TOOL_USAGE;
    while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        switch (c) {
        case 'j': json = 1; break;
        case 'h':
            fputs(check_help, stdout);
            fputs(check_event_help, stdout);
            return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        default: return tools_option_error("check", argv, optind, 0); /* no option takes a value */
        }
    }
    if (tools_one_file("check", optind, argc)) return TOOL_USAGE;
    if (dlca_check_wanted(argv[optind])) return dlca_check_main(argv[optind], json); /* model dlca: check_dlca.c */
    const int ev = check_event(argv[optind], json); /* check_event.c: -1 when not an event file */
    if (ev >= 0) return ev;
    if (is_dla_checkpoint(argv[optind])) return check_checkpoint(argv[optind], json);
    char err[1024];
    h5r_file f;
    if (h5r_open(&f, argv[optind], err, sizeof err)) {
        fprintf(stderr, "pdla check: %s\n", err);
        /* A file HDF5 calls its own but cannot open (a truncated cluster.h5
         * or checkpoint) fails the check, as a damaged checkpoint the
         * loader refuses does; any other file is not one to check. */
        return f.damaged ? TOOL_RUNTIME : TOOL_USAGE;
    }
    check_stored s = {0};
    check_result res = {0};
    int rc = read_stored(&f, &s, err, sizeof err) ? TOOL_USAGE : TOOL_OK;
    if (rc) fprintf(stderr, "pdla check: %s\n", err);
    const check_source src = {&f, NULL, NULL};
    if (rc == TOOL_OK) rc = run_check(&f, &src, &s, &res);
    if (rc == TOOL_OK) rc = report(&f, &s, &res, json);
    free(s.sn);
    free(s.srg);
    return h5r_close_tool(&f, "check", rc);
}
