/*
 * parse.c - the `pdla` option table, strict number parsing and the --help
 * text. Nothing here prints or exits: errors come back as one-line strings
 * so that main.c decides how to report them and tests can compare them.
 */
#include "parse.h"
#include "scene.h"
#include "optcheck.h"

#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- numbers ----------------------------------------------------------- */

static int is_digit(char c) { return c >= '0' && c <= '9'; }

/* Counts are parsed exactly as decimal significand x 10^exponent, never via
 * floating point, so 18446744073709551615 is accepted and ...616 is not, and
 * "1.5e6" is known to be whole without rounding doubts. */
const char *cli_parse_count(const char *s, uint64_t *out)
{
    if (!s || !*s) return "empty value";
    if (*s == '-') return "negative values are not allowed";
    if (!is_digit(*s)) return "not a number";

    /* Significant digits (leading zeros dropped). Only the first 21 are kept:
     * more than 20 up to the last non-zero one already exceed UINT64_MAX. */
    char sig[21];
    int64_t nsig = 0;   /* significant digits seen */
    int64_t lastnz = 0; /* 1-based index of the last non-zero one, 0: none */
    int64_t nfrac = 0;  /* digits after the point */
    const char *p = s;
    for (int frac = 0;; frac = 1) {
        for (; is_digit(*p); p++) {
            if (nsig == 0 && *p == '0') {
                if (frac) nfrac++;
                continue;
            }
            if (nsig < (int64_t)sizeof sig) sig[nsig] = *p;
            nsig++;
            if (*p != '0') lastnz = nsig;
            if (frac) nfrac++;
        }
        if (frac || *p != '.') break;
        p++;
        if (!is_digit(*p)) return "expected digits after '.'";
    }

    int64_t exp10 = 0;
    int has_exp = 0;
    if (*p == 'e' || *p == 'E') {
        has_exp = 1;
        p++;
        int neg = 0;
        if (*p == '+' || *p == '-') neg = *p++ == '-';
        if (!is_digit(*p)) return "expected digits in the exponent";
        for (; is_digit(*p); p++)
            if (exp10 < INT64_C(100000000000000)) /* beyond that the outcome is decided */
                exp10 = exp10 * 10 + (*p - '0');
        if (neg) exp10 = -exp10;
    }
    if (!has_exp && *p && !p[1]) {
        static const char suffixes[] = "kMGT";
        const char *k = strchr(suffixes, *p);
        if (k) {
            exp10 += 3 * (k - suffixes + 1);
            p++;
        } else if (strchr("KmgtBb", *p)) {
            return "unknown suffix (the suffixes are k, M, G, T, case-sensitive)";
        }
    }
    if (*p) return "trailing characters after the number";

    if (lastnz == 0) { /* every digit is zero */
        *out = 0;
        return NULL;
    }
    /* value = digits[0..lastnz) x 10^e, the last digit non-zero */
    const int64_t e = exp10 - nfrac + (nsig - lastnz);
    if (e < 0) return "not a whole number";
    if (lastnz + e > 20) return "too large (the maximum is 18446744073709551615)";
    uint64_t v = 0;
    for (int64_t i = 0; i < lastnz; i++) {
        const unsigned d = (unsigned)(sig[i] - '0');
        if (v > (UINT64_MAX - d) / 10) return "too large (the maximum is 18446744073709551615)";
        v = v * 10 + d;
    }
    for (int64_t i = 0; i < e; i++) {
        if (v > UINT64_MAX / 10) return "too large (the maximum is 18446744073709551615)";
        v *= 10;
    }
    *out = v;
    return NULL;
}

const char *cli_parse_real(const char *s, double *out)
{
    if (!s || !*s) return "empty value";
    /* strtod would skip leading blanks: refuse them first. */
    if (!is_digit(*s) && *s != '.' && *s != '+' && *s != '-') return "not a number";
    errno = 0;
    char *end;
    const double v = strtod(s, &end);
    if (end == s) return "not a number";
    if (*end) return "trailing characters after the number";
    /* ... and it accepts inf, nan and hexadecimal, which are not for us. */
    if (s[strspn(s, "0123456789.eE+-")]) return "not a finite decimal number";
    if (errno == ERANGE || !isfinite(v)) return "out of range";
    *out = v;
    return NULL;
}

const char *cli_parse_duration(const char *s, double *out)
{
    if (!s || !*s) return "empty value";
    char buf[64];
    const size_t n = strlen(s);
    if (n >= sizeof buf) return "too long";
    memcpy(buf, s, n + 1);
    double unit = 1;
    const char last = buf[n - 1];
    if (last == 's' || last == 'm' || last == 'h') {
        unit = last == 'h' ? 3600 : last == 'm' ? 60 : 1;
        buf[n - 1] = '\0';
    } else if (!is_digit(last) && last != '.') {
        return "unknown unit (use s, m or h)";
    }
    if (!buf[0] || buf[strspn(buf, "0123456789.")]) return "not a duration (e.g. 90s, 30m, 1.5h)";
    double v;
    const char *why = cli_parse_real(buf, &v);
    if (why) return why;
    v *= unit;
    /* 0: no time trigger (on --resume it drops the recorded schedule) */
    if (!(v >= 0) || v > 1e9) return "must be 0 (none) to 1e9 seconds";
    *out = v;
    return NULL;
}

/* ---- the option table -------------------------------------------------- */

/* Ids of the CLI's own options; the parameters' options are generated from
 * the library's table (params.h) and get OPT_PARAM + their row. */
enum opt_id {
    OPT_OUT = 256,
    OPT_FORCE,
    OPT_NO_OUTPUT,
    OPT_STATS_JSON,
    OPT_PROGRESS,
    OPT_NO_PROGRESS,
    OPT_SCENE,
    OPT_CHECKPOINT,
    OPT_CHECKPOINT_EVERY,
    OPT_CHECKPOINT_PARTICLES,
    OPT_CHECKPOINT_COMPRESS,
    OPT_RESUME,
    OPT_PARAM = 1024
};

typedef enum arg_kind {
    ARG_NONE,   /* a flag */
    ARG_INT,    /* a count that must fit an int */
    ARG_COUNT,  /* an unsigned 64-bit count */
    ARG_REAL,   /* a finite double */
    ARG_CHOICE, /* one word of a fixed list */
    ARG_STRING, /* a path */
    ARG_DURATION /* seconds, with s/m/h */
} arg_kind;

typedef struct opt_desc {
    const char *name;    /* long name without "--"; NULL: a heading (help only) */
    char short_name;     /* 0 if none */
    int id;
    arg_kind kind;
    const char *metavar; /* shown in --help */
    const char *help;
} opt_desc;

/* The CLI's own options, and the --help headings under which the table's
 * parameters of that group are listed first (see cli_help_text). */
static const opt_desc options[] = {
    {NULL, 0, 0, ARG_NONE, NULL, "Cluster:"},
    {NULL, 0, 0, ARG_NONE, NULL, "Walkers:"},
    {NULL, 0, 0, ARG_NONE, NULL, "Threads (PDLA):"},
    {NULL, 0, 0, ARG_NONE, NULL, "Output:"},
    {"out", 0, OPT_OUT, ARG_STRING, "DIR",
     "run directory; it must not exist, its parents are made "
     "(default runs/run-YYYYmmdd-HHMMSS-<dim>d-<target>)"},
    {"force", 0, OPT_FORCE, ARG_NONE, NULL,
     "allow an existing run directory; its cluster.h5 and summary.txt are replaced"},
    {"no-output", 0, OPT_NO_OUTPUT, ARG_NONE, NULL,
     "no run directory and no files: grow and print the summary (for benchmarks)"},
    {"stats-json", 0, OPT_STATS_JSON, ARG_STRING, "FILE",
     "also write counters, timings and fit as JSON to FILE (at the end; an existing FILE only with --force, or on --resume when it holds the statistics pdla wrote)"},
    {"quiet", 'q', 'q', ARG_NONE, NULL, "no summary and no progress (unless --progress); errors only"},
    {"progress", 0, OPT_PROGRESS, ARG_NONE, NULL,
     "progress on stderr (default: only when stderr is a terminal)"},
    {"no-progress", 0, OPT_NO_PROGRESS, ARG_NONE, NULL, "no progress"},
    {"scene", 0, OPT_SCENE, ARG_STRING, "FILE",
     "read settings from a scene file: KEY = VALUE lines, the keys being these "
     "options' long names; options given here override the scene's keys"},
    {NULL, 0, 0, ARG_NONE, NULL, "Checkpoints and resume:"},
    {"checkpoint", 0, OPT_CHECKPOINT, ARG_NONE, NULL,
     "write RUN_DIR/checkpoint.h5 at the end, on SIGINT/SIGTERM and when a file "
     "RUN_DIR/STOP appears (then stop and exit 0); implied by the options below"},
    {"checkpoint-every", 0, OPT_CHECKPOINT_EVERY, ARG_DURATION, "T",
     "also every T of wall time: seconds, or with s, m, h (30m)"},
    {"checkpoint-particles", 0, OPT_CHECKPOINT_PARTICLES, ARG_COUNT, "N",
     "also every N particles"},
    {"checkpoint-compress", 0, OPT_CHECKPOINT_COMPRESS, ARG_NONE, NULL,
     "shuffle + deflate the checkpoint (about 20% smaller, several times slower to write)"},
    {"resume", 0, OPT_RESUME, ARG_STRING, "PATH",
     "continue the run in a run directory (its newest valid checkpoint) or from a "
     "checkpoint file; --target may be raised, --threads, --serial-until, --bind and "
     "--reference-walkers changed, other parameters must match"},
    {"help", 'h', 'h', ARG_NONE, NULL, "print this help and exit"},
    {"version", 'V', 'V', ARG_NONE, NULL, "print the version and exit"},
};
#define N_OPTIONS (sizeof options / sizeof options[0])
/* Room for the parameter table's options in getopt's array. */
#define MAX_PARAMS 128

static arg_kind kind_of(const pdla_param_desc *pd)
{
    switch (pd->type) {
    case PDLA_PT_INT: return ARG_INT;
    case PDLA_PT_U64: return ARG_COUNT;
    case PDLA_PT_REAL: return ARG_REAL;
    case PDLA_PT_CHOICE: return ARG_CHOICE;
    default: return ARG_NONE;
    }
}

/* The parameter of an option id, or NULL for the CLI's own options. */
static const pdla_param_desc *param_of(int id)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    return id >= OPT_PARAM && (size_t)(id - OPT_PARAM) < n ? &t[id - OPT_PARAM] : NULL;
}

/* The option row of table row i, made from its descriptor. */
static opt_desc param_opt(const pdla_param_desc *t, size_t i)
{
    return (opt_desc){t[i].option, 0, OPT_PARAM + (int)i, kind_of(&t[i]), t[i].metavar, t[i].help};
}

/* The row of option id: a CLI row, or *tmp filled from the table. */
static const opt_desc *find_opt(int id, opt_desc *tmp)
{
    const pdla_param_desc *pd = param_of(id);
    if (pd) {
        size_t n;
        const pdla_param_desc *t = pdla_param_table(&n);
        *tmp = param_opt(t, (size_t)(pd - t));
        return tmp;
    }
    for (size_t i = 0; i < N_OPTIONS; i++)
        if (options[i].name && options[i].id == id) return &options[i];
    return NULL;
}

/* ---- error messages ---------------------------------------------------- */

/* A user's string made fit for a one-line message: control characters
 * become '?', and it is cut to 48 bytes with "...". */
static const char *shown(char dst[64], const char *s)
{
    size_t i = 0;
    for (; s[i] && i < 48; i++) {
        const unsigned char c = (unsigned char)s[i];
        dst[i] = (c < 0x20 || c == 0x7f) ? '?' : (char)c;
    }
    if (s[i]) {
        memcpy(dst + i, "...", 3);
        i += 3;
    }
    dst[i] = '\0';
    return dst;
}

/* The option as the user wrote it: "--target", or "-q" for short ones. */
static const char *opt_label(char dst[64], const opt_desc *o)
{
    snprintf(dst, 64, "--%s", o->name);
    return dst;
}

/* ---- the parser -------------------------------------------------------- */

/* A parameter's value into o->params, and its bit into o->given. */
static void set_param(cli_options *o, const pdla_param_desc *pd, uint64_t n, double x)
{
    if (pd->type == PDLA_PT_REAL) pdla_param_set_real(pd, &o->params, x);
    else if (pd->type == PDLA_PT_FLAG) pdla_param_set_u(pd, &o->params, (uint64_t)pd->flag_value);
    else pdla_param_set_u(pd, &o->params, n);
    o->given |= pd->bit;
}

static int set_value(cli_options *o, const opt_desc *d, const char *arg, char *err, size_t errlen)
{
    char v[64], l[64];
    const char *why = NULL;
    uint64_t n = 0;
    double x = 0;
    switch (d->kind) {
    case ARG_INT:
        why = cli_parse_count(arg, &n);
        if (!why && n > INT_MAX) why = "too large (the maximum is 2147483647)";
        break;
    case ARG_COUNT: why = cli_parse_count(arg, &n); break;
    case ARG_REAL: why = cli_parse_real(arg, &x); break;
    case ARG_DURATION: why = cli_parse_duration(arg, &x); break;
    case ARG_STRING:
        if (!*arg) why = "empty name";
        else if (*arg == '-') why = "a name starting with '-' looks like an option (write ./NAME)";
        break;
    case ARG_CHOICE: {
        const int c = pdla_param_choice(param_of(d->id), arg);
        if (c < 0)
            return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "invalid value '%s' for %s: should be %s", shown(v, arg),
                        opt_label(l, d), d->metavar);
        n = (uint64_t)c;
        break;
    }
    case ARG_NONE: break;
    }
    if (why) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "invalid value '%s' for %s: %s", shown(v, arg), opt_label(l, d), why);

    const pdla_param_desc *pd = param_of(d->id);
    if (pd && o->threads_apart && !strcmp(pd->option, "threads")) {
        o->apart_threads = n;
        o->apart_threads_given = 1;
        return CLI_PARSE_OK;
    }
    if (pd) {
        set_param(o, pd, n, x);
        return CLI_PARSE_OK;
    }
    switch (d->id) {
    case OPT_OUT: o->out_dir = arg; break;
    case OPT_FORCE: o->force = 1; break;
    case OPT_NO_OUTPUT: o->no_output = 1; break;
    case OPT_STATS_JSON: o->stats_json = arg; break;
    case OPT_SCENE:
        if (o->scene) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "--scene given twice");
        o->scene = arg;
        break;
    case 'q': o->quiet = 1; break;
    case OPT_PROGRESS: o->progress = 1; break;
    case OPT_NO_PROGRESS: o->progress = 0; break;
    case OPT_CHECKPOINT: o->checkpoint = 1; break;
    case OPT_CHECKPOINT_EVERY: o->checkpoint = o->schedule_given = 1; o->checkpoint_every = x; break;
    case OPT_CHECKPOINT_PARTICLES:
        if (n == 0) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "invalid value '%s' for --checkpoint-particles: must be at least 1",
                                shown(v, arg));
        o->checkpoint = o->schedule_given = 1;
        o->checkpoint_particles = n;
        break;
    case OPT_CHECKPOINT_COMPRESS: o->checkpoint = o->schedule_given = 1; o->checkpoint_compress = 1; break;
    case OPT_RESUME: o->checkpoint = 1; o->resume = arg; break;
    case 'h': o->action = CLI_HELP; break;
    case 'V': o->action = CLI_VERSION; break;
    default: return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "internal error: option %d has no handler", d->id);
    }
    return CLI_PARSE_OK;
}

/* Options that are no scene keys. */
static int not_a_key(const opt_desc *d) { return d->id == 'h' || d->id == 'V' || d->id == OPT_SCENE; }

int cli_set_option(cli_options *o, const char *name, const char *value, char *err, size_t errlen)
{
    const opt_desc *d = NULL;
    opt_desc tmp;
    size_t np;
    const pdla_param_desc *t = pdla_param_table(&np);
    for (size_t i = 0; i < np && !d; i++)
        if (!strcmp(t[i].option, name)) d = find_opt(OPT_PARAM + (int)i, &tmp);
    for (size_t i = 0; i < N_OPTIONS && !d; i++)
        if (options[i].name && !strcmp(options[i].name, name)) d = &options[i];
    char v[64];
    if (!d || not_a_key(d)) {
        /* a key that differs from an option in letter case only is named */
        const char *near = NULL;
        for (size_t i = 0; i < np && !near; i++)
            if (scene_same_but_case(name, t[i].option)) near = t[i].option;
        for (size_t i = 0; i < N_OPTIONS && !near; i++)
            if (options[i].name && !not_a_key(&options[i]) && scene_same_but_case(name, options[i].name))
                near = options[i].name;
        scene_unknown_key(shown(v, name), near, " (keys are the long options of pdla --help without '--', "
                          "except scene, help and version)", err, errlen);
        return CLI_PARSE_ERROR;
    }
    if (d->kind != ARG_NONE) return set_value(o, d, value, err, errlen);
    static const char *const yes[] = {"yes", "true", "1"}, *const no[] = {"no", "false", "0"};
    for (int i = 0; i < 3; i++) {
        if (!strcmp(value, yes[i])) return set_value(o, d, NULL, err, errlen);
        if (!strcmp(value, no[i])) return CLI_PARSE_OK;
    }
    return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "invalid value '%s' for %s: should be yes or no", shown(v, value), name);
}

/* One pass of getopt over argv into *out (not reset). */
static int parse_args(int argc, char **argv, cli_options *out, char *err, size_t errlen)
{
    size_t np;
    const pdla_param_desc *t = pdla_param_table(&np);
    if (np > MAX_PARAMS) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "internal error: %zu parameters", np);
    struct option longopts[N_OPTIONS + MAX_PARAMS + 1];
    char shortopts[2 * N_OPTIONS + 2];
    size_t nl = 0, ns = 0;
    shortopts[ns++] = ':'; /* report a missing value as ':' rather than '?' */
    for (size_t i = 0; i < np; i++)
        longopts[nl++] = (struct option){t[i].option,
                                         t[i].type == PDLA_PT_FLAG ? no_argument : required_argument,
                                         NULL, OPT_PARAM + (int)i};
    for (size_t i = 0; i < N_OPTIONS; i++) {
        const opt_desc *d = &options[i];
        if (!d->name) continue;
        longopts[nl++] = (struct option){d->name, d->kind == ARG_NONE ? no_argument : required_argument,
                                         NULL, d->id};
        if (d->short_name) {
            shortopts[ns++] = d->short_name;
            if (d->kind != ARG_NONE) shortopts[ns++] = ':';
        }
    }
    longopts[nl] = (struct option){NULL, 0, NULL, 0};
    shortopts[ns] = '\0';

    /* getopt keeps its state in globals: optind = 0 makes glibc start afresh
     * (so repeated calls from a test or fuzzer work), opterr = 0 keeps it
     * from printing. */
    optind = 0;
    opterr = 0;
    if (optcheck_exact(argc, argv, longopts, shortopts, err, errlen)) return CLI_PARSE_ERROR;
    char v[64];
    int c;
    while ((c = getopt_long(argc, argv, shortopts, longopts, NULL)) != -1) {
        const char *cur = optind > 0 && optind <= argc ? argv[optind - 1] : "?";
        if (c == ':') {
            opt_desc tmp;
            const opt_desc *d = find_opt(optopt, &tmp);
            char l[64];
            return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "option %s needs a value (%s)",
                        d ? opt_label(l, d) : shown(v, cur), d ? d->metavar : "see --help");
        }
        if (c == '?') {
            opt_desc tmp;
            const opt_desc *d = optopt ? find_opt(optopt, &tmp) : NULL;
            if (d) { /* a known flag given "=value" */
                char l[64];
                return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "option %s does not take a value", opt_label(l, d));
            }
            if (optopt > 0x20 && optopt < 0x7f) /* printable: control bytes would break the line */
                return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "unknown option '-%c' (see --help)", optopt);
            return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "unknown or ambiguous option '%s' (see --help)", shown(v, cur));
        }
        opt_desc tmp;
        const opt_desc *d = find_opt(c, &tmp);
        if (!d) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "internal error: getopt returned %d", c);
        const int rc = set_value(out, d, optarg, err, errlen);
        if (rc) return rc;
    }
    if (optind < argc)
        return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "unexpected argument '%s' (options only; see --help)",
                    shown(v, argv[optind]));
    return CLI_PARSE_OK;
}

int cli_parse_long_in(const char *s, long lo, long hi, long *out)
{
    uint64_t v;
    if (lo < 0 || cli_parse_count(s, &v) || v < (uint64_t)lo || v > (uint64_t)hi) return -1;
    *out = (long)v;
    return 0;
}

static int parse_all(int argc, char **argv, cli_options *out, int apart, char *err, size_t errlen);

/* ---- scenes ------------------------------------------------------------ */

/* Apply sc's entries except `skip` (-1: none) to a copy of base. */
static int apply_entries(const cli_options *base, const scene *sc, int skip, cli_options *out,
                         int *bad_line, char *err, size_t errlen)
{
    *out = *base;
    for (int i = 0; i < sc->n; i++) {
        if (i == skip) continue;
        const int rc = cli_set_option(out, sc->entries[i].key, sc->entries[i].value, err, errlen);
        if (rc != CLI_PARSE_OK) {
            *bad_line = sc->entries[i].line;
            return rc;
        }
    }
    return CLI_PARSE_OK;
}

/* Run options that exclude each other (not parameters, which the table
 * checks): the one-line reason, or NULL. */
static const char *run_option_clash(const cli_options *o)
{
    if (o->no_output && o->out_dir) return "--no-output and --out exclude each other";
    if (o->no_output && o->force) return "--no-output and --force exclude each other";
    if (o->no_output && o->checkpoint) return "checkpoints need a run directory: --no-output excludes them";
    if (o->resume && (o->out_dir || o->force))
        return "--resume continues in the checkpoint's run directory: --out and --force do not apply";
    return NULL;
}

/* The line to blame for an invalid scene: the one that sets the parameter
 * the validation named, else one whose removal makes the scene valid (its
 * parameters, and with `clash` its run options too), else 0. */
static int blame_line(const cli_options *base, const scene *sc, const pdla_param_desc *bad, int clash)
{
    for (int i = 0; bad && i < sc->n; i++)
        if (!strcmp(sc->entries[i].key, bad->option)) return sc->entries[i].line;
    cli_options *t2 = malloc(sizeof *t2);
    int blamed = 0, unused;
    char ignore[512];
    for (int i = sc->n - 1; t2 && i >= 0 && !blamed; i--)
        if (apply_entries(base, sc, i, t2, &unused, ignore, sizeof ignore) == CLI_PARSE_OK &&
            pdla_params_validate(&t2->params, ignore, sizeof ignore) == PDLA_OK && !(clash && run_option_clash(t2)))
            blamed = sc->entries[i].line;
    free(t2);
    return blamed;
}

/* The scene's strings live in its buffer, which is freed: keep the paths
 * in the options themselves. */
static void keep_strings(cli_options *o, const scene *sc)
{
    if (o->out_dir && o->out_dir >= sc->buf && o->out_dir < sc->buf + sc->len) {
        snprintf(o->scene_out, sizeof o->scene_out, "%s", o->out_dir);
        o->out_dir = o->scene_out;
    }
    if (o->stats_json && o->stats_json >= sc->buf && o->stats_json < sc->buf + sc->len) {
        snprintf(o->scene_stats, sizeof o->scene_stats, "%s", o->stats_json);
        o->stats_json = o->scene_stats;
    }
    if (o->resume && o->resume >= sc->buf && o->resume < sc->buf + sc->len) {
        snprintf(o->scene_resume, sizeof o->scene_resume, "%s", o->resume);
        o->resume = o->scene_resume;
    }
}

static int apply_scene(const char *name, const scene *sc, cli_options *o, char *err, size_t errlen)
{
    cli_options *tmp = malloc(sizeof *tmp);
    if (!tmp) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "%s: out of memory", name);
    char why[512];
    int bad_line = 0;
    int rc = apply_entries(o, sc, -1, tmp, &bad_line, why, sizeof why);
    if (rc != CLI_PARSE_OK) {
        pdla_errorf(CLI_PARSE_ERROR, err, errlen, "%s:%d: %s", name, bad_line, why);
    } else {
        size_t np;
        const pdla_param_desc *t = pdla_param_table(&np);
        const pdla_param_desc *bad = NULL;
        const char *clash = NULL;
        const int params_bad = pdla_param_validate(t, np, &tmp->params, &bad, why, sizeof why) != PDLA_OK;
        if (!params_bad && (clash = run_option_clash(tmp)) != NULL) snprintf(why, sizeof why, "%s", clash);
        if (params_bad || clash) {
            /* A scene that is not a valid run on its own: its parameters, or
             * run options it sets that exclude each other (no-output with
             * out, force or a checkpoint; resume with out or force). */
            const int line = blame_line(o, sc, bad, clash != NULL);
            rc = line ? pdla_errorf(CLI_PARSE_ERROR, err, errlen, "%s:%d: %s", name, line, why)
                      : pdla_errorf(CLI_PARSE_ERROR, err, errlen, "%s: %s", name, why);
        } else {
            keep_strings(tmp, sc);
            *o = *tmp;
            /* *o was copied from tmp: repoint what pointed into tmp's own arrays. */
            if (tmp->out_dir == tmp->scene_out) o->out_dir = o->scene_out;
            if (tmp->stats_json == tmp->scene_stats) o->stats_json = o->scene_stats;
            if (tmp->resume == tmp->scene_resume) o->resume = o->scene_resume;
        }
    }
    free(tmp);
    return rc;
}

int scene_apply_text(const char *name, const char *text, size_t len, cli_options *o, char *err,
                     size_t errlen)
{
    scene sc;
    if (scene_read_text(name, text, len, &sc, err, errlen)) return CLI_PARSE_ERROR;
    const int rc = apply_scene(name, &sc, o, err, errlen);
    scene_free(&sc);
    return rc;
}

int scene_apply(const char *path, cli_options *o, char *err, size_t errlen)
{
    scene sc;
    if (scene_read_file(path, &sc, err, errlen)) return CLI_PARSE_ERROR;
    const int rc = apply_scene(path, &sc, o, err, errlen);
    scene_free(&sc);
    return rc;
}

int cli_check_params(const pdla_params *p, char *err, size_t errlen)
{
    size_t np;
    const pdla_param_desc *t = pdla_param_table(&np);
    const pdla_param_desc *bad = NULL;
    if (pdla_param_validate(t, np, p, &bad, err, errlen) == PDLA_OK) return CLI_PARSE_OK;
    /* The library names the value; the user also wants the option to change. */
    const size_t used = err ? strlen(err) : 0;
    if (bad && err && used < errlen) snprintf(err + used, errlen - used, " (--%s)", bad->option);
    return CLI_PARSE_ERROR;
}

int cli_path_fits(const char *what, const char *path, char *err, size_t errlen)
{
    const size_t n = strlen(path);
    if (n <= CLI_RUN_DIR_MAX) return 0;
    snprintf(err, errlen, "%s is too long (%zu bytes; at most %d)", what, n, CLI_RUN_DIR_MAX);
    return -1;
}

/* Errors are one line: a file name or argument quoted in the message may
 * hold a newline or another control byte, so those are shown as '?'. */
static int parse_one_line(int argc, char **argv, cli_options *out, int apart, char *err, size_t errlen)
{
    const int rc = parse_all(argc, argv, out, apart, err, errlen);
    if (rc == CLI_PARSE_ERROR && err)
        for (char *c = err; *c; c++)
            if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
    return rc;
}

int cli_parse(int argc, char **argv, cli_options *out, char *err, size_t errlen)
{
    return parse_one_line(argc, argv, out, 0, err, errlen);
}

int cli_parse_threads_apart(int argc, char **argv, cli_options *out, char *err, size_t errlen)
{
    return parse_one_line(argc, argv, out, 1, err, errlen);
}

static int parse_all(int argc, char **argv, cli_options *out, int apart, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    out->threads_apart = apart;
    pdla_params_default(&out->params);
    out->action = CLI_RUN;
    out->progress = -1;
    if (err && errlen) err[0] = '\0';

    /* Pass 1 finds --help, --version and --scene (and any syntax error);
     * with a scene, pass 2 applies the command line over it. */
    cli_options *first = malloc(sizeof *first);
    if (!first) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "out of memory");
    *first = *out;
    int rc = parse_args(argc, argv, first, err, errlen);
    if (rc == CLI_PARSE_OK && first->scene && first->action == CLI_RUN) {
        rc = scene_apply(first->scene, out, err, errlen);
        if (rc == CLI_PARSE_OK) rc = parse_args(argc, argv, out, err, errlen);
    } else {
        *out = *first;
    }
    free(first);
    if (rc != CLI_PARSE_OK) return rc;
    if (out->action != CLI_RUN) return CLI_PARSE_EXIT;

    const char *clash = run_option_clash(out);
    if (clash) return pdla_errorf(CLI_PARSE_ERROR, err, errlen, "%s", clash);
    return cli_check_params(&out->params, err, errlen);
}

/* ---- --help ------------------------------------------------------------ */

typedef struct text {
    char *buf;
    size_t len, pos; /* pos counts what would have been written */
} text;

static void put(text *t, const char *fmt, ...)
{
    char *dst = t->pos < t->len ? t->buf + t->pos : NULL;
    const size_t room = t->pos < t->len ? t->len - t->pos : 0;
    va_list ap;
    va_start(ap, fmt);
    const int n = vsnprintf(dst, room, fmt, ap);
    va_end(ap);
    if (n > 0) t->pos += (size_t)n;
}

enum { HELP_COL = 25, HELP_WIDTH = 79 };

/* Word-wrap s from column col, continuation lines indented to HELP_COL.
 * NBSP (a byte no help text uses) glues words and prints as a space. */
#define NBSP '\x01'
static void put_wrapped(text *t, int col, const char *s)
{
    while (*s) {
        while (*s == ' ') s++;
        const size_t w = strcspn(s, " ");
        if (!w) break;
        if (col > HELP_COL && col + 1 + (int)w > HELP_WIDTH) {
            put(t, "\n%*s", HELP_COL, "");
            col = HELP_COL;
        } else if (col > HELP_COL) {
            put(t, " ");
            col++;
        }
        for (size_t i = 0; i < w; i++) put(t, "%c", s[i] == NBSP ? ' ' : s[i]);
        col += (int)w;
        s += w;
    }
    put(t, "\n");
}

/* One option's --help entry: the name column, then the wrapped text. */
static void put_option(text *t, const opt_desc *d, const char *dflt)
{
    char head[64];
    int col;
    if (d->short_name)
        col = snprintf(head, sizeof head, "  -%c, --%s", d->short_name, d->name);
    else
        col = snprintf(head, sizeof head, "  --%s", d->name);
    if (d->metavar && col > 0 && (size_t)col < sizeof head)
        col += snprintf(head + col, sizeof head - (size_t)col, " %s", d->metavar);
    put(t, "%s", head);
    if (col + 2 > HELP_COL) {
        put(t, "\n");
        col = 0;
    }
    put(t, "%*s", HELP_COL - col, "");
    char help[512];
    if (dflt)
        snprintf(help, sizeof help, "%s (default%c%s)", d->help, NBSP, dflt);
    else
        snprintf(help, sizeof help, "%s", d->help);
    put_wrapped(t, HELP_COL, help);
}

/* The parameters listed under a --help heading, with their defaults. */
static void put_param_group(text *t, const char *group, const pdla_params *defaults)
{
    size_t np;
    const pdla_param_desc *pt = pdla_param_table(&np);
    for (size_t i = 0; i < np; i++) {
        if (strcmp(pt[i].group, group)) continue;
        const opt_desc d = param_opt(pt, i);
        char dflt[48];
        if (pt[i].show_default) pdla_param_format(&pt[i], defaults, 0, dflt, sizeof dflt);
        put_option(t, &d, pt[i].show_default ? dflt : NULL);
    }
}

size_t cli_help_text(char *buf, size_t len, const pdla_params *defaults)
{
    text t = {buf, len, 0};
    if (buf && len) buf[0] = '\0';
    put(&t,
        "Usage: pdla [OPTION]...\n"
        "       pdla info|render|analyze|export FILE [OPTION]...   (pdla COMMAND --help)\n"
        "       pdla --model dlca|event [OPTION]...   (pdla --model M --help)\n"
        "       pdla ensemble --clusters M [OPTION]...   (pdla ensemble --help)\n"
        "Grow an off-lattice diffusion-limited aggregation (DLA) cluster and write it\n"
        "to RUN_DIR/cluster.h5 (HDF5), with a summary in RUN_DIR/summary.txt.\n"
        "Look at a cluster file: `info` (what it holds), `render` (a PNG picture),\n"
        "`analyze` (fractal dimension from R_g(N) and from the mass-radius relation),\n"
        "`export` (PLY, CSV or XYZ for other programs).\n"
        "Lengths are in units (D units = one particle diameter) or in diameters.\n");
    for (size_t i = 0; i < N_OPTIONS; i++) {
        const opt_desc *d = &options[i];
        if (!d->name) {
            put(&t, "\n%s\n", d->help);
            put_param_group(&t, d->help, defaults);
        } else {
            put_option(&t, d, NULL);
        }
    }
    put(&t,
        "\n"
        "Counts (N, S, K, D, E) are whole numbers: 1000000, 1e6, 1.5e6, 10M, 2k, 1G;\n"
        "the suffixes k M G T are 10^3 10^6 10^9 10^12 and case-sensitive.\n"
        "Progress goes to stderr, the summary to stdout (and RUN_DIR/summary.txt).\n"
        "\n"
        "Exit status: 0 done; 1 runtime failure (growth or writing failed; what was\n"
        "grown is still written when possible); 2 bad usage, input or run directory.\n"
        "On SIGINT or SIGTERM, pdla writes the partial cluster and then ends by that\n"
        "signal (shell status 130 or 143); a second signal ends it at once. With\n"
        "checkpoints on, it writes a checkpoint too and exits 0: resume it with\n"
        "pdla --resume RUN_DIR.\n");
    return t.pos;
}
