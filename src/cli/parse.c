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
    if (!(v > 0) || v > 1e9) return "must be above 0 and at most 1e9 seconds";
    *out = v;
    return NULL;
}

/* ---- the option table -------------------------------------------------- */

enum opt_id {
    OPT_DIM = 256,
    OPT_TARGET,
    OPT_SEED,
    OPT_RESOLUTION,
    OPT_EPS,
    OPT_NO_SNAP,
    OPT_BIRTH_MARGIN,
    OPT_RETURN,
    OPT_KILL_RATIO,
    OPT_MAX_JUMPS,
    OPT_EXACT_SEARCH,
    OPT_FAR_FACTOR,
    OPT_THREADS,
    OPT_SERIAL_UNTIL,
    OPT_RECHECK,
    OPT_BIND,
    OPT_RG_PER_DECADE,
    OPT_OUT,
    OPT_FORCE,
    OPT_NO_OUTPUT,
    OPT_STATS_JSON,
    OPT_PROGRESS,
    OPT_NO_PROGRESS,
    OPT_ARRIVAL,
    OPT_SCENE,
    OPT_CHECKPOINT,
    OPT_CHECKPOINT_EVERY,
    OPT_CHECKPOINT_PARTICLES,
    OPT_CHECKPOINT_COMPRESS,
    OPT_RESUME
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

static const opt_desc options[] = {
    {NULL, 0, 0, ARG_NONE, NULL, "Cluster:"},
    {"dim", 0, OPT_DIM, ARG_INT, "2|3", "dimension"},
    {"target", 0, OPT_TARGET, ARG_COUNT, "N", "particles in the final cluster, 1 to 2^40"},
    {"seed", 0, OPT_SEED, ARG_COUNT, "S", "random seed, 0 to 2^64-1"},
    {"resolution", 0, OPT_RESOLUTION, ARG_INT, "D",
     "units per particle diameter, a power of two from 4 to 128"},
    {"eps", 0, OPT_EPS, ARG_INT, "E",
     "sticking shell in units, 2 to D/2: a walker sticks closer than D + E "
     "to a particle centre"},
    {"no-snap-contact", 0, OPT_NO_SNAP, ARG_NONE, NULL,
     "stick where the walker stops instead of moving it onto contact "
     "(stretches the cluster by about E/(2D))"},
    {NULL, 0, 0, ARG_NONE, NULL, "Walkers:"},
    {"birth-margin", 0, OPT_BIRTH_MARGIN, ARG_REAL, "M",
     "walkers start on the circle (sphere) of radius R_ext + M diameters, M >= 1"},
    {"return", 0, OPT_RETURN, ARG_CHOICE, "exact|kill",
     "a walker that leaves the birth circle: exact return by the harmonic "
     "measure, or the kill scheme"},
    {"kill-ratio", 0, OPT_KILL_RATIO, ARG_REAL, "R",
     "with --return kill: kill radius / birth radius, above 1"},
    {"max-jumps", 0, OPT_MAX_JUMPS, ARG_COUNT, "N",
     "restart a walk on the birth circle after N jumps"},
    {"exact-search", 0, OPT_EXACT_SEARCH, ARG_NONE, NULL,
     "every jump by the exact nearest distance from the tree: no distance map, no "
     "far-node bound, no 2D leaf-block cut (the reference setting; about 2x slower)"},
    {"far-factor", 0, OPT_FAR_FACTOR, ARG_REAL, "F",
     "tree search: a node farther than F x its side is not opened; 0.5 to 64 (matters "
     "in 3D; 2D walkers use the distance map and the leaf block instead)"},
    {NULL, 0, 0, ARG_NONE, NULL, "Threads (PDLA):"},
    {"threads", 0, OPT_THREADS, ARG_INT, "N",
     "worker threads after the serial phase: 1 = serial DLA throughout, "
     "0 = one per physical core"},
    {"serial-until", 0, OPT_SERIAL_UNTIL, ARG_COUNT, "N",
     "grow with one walker (deterministic) up to N particles, then start the workers"},
    {"recheck", 0, OPT_RECHECK, ARG_CHOICE, "continue|discard",
     "a worker's walker whose spot another one took: continue in contact with "
     "the newcomer, or discard it"},
    {"bind", 0, OPT_BIND, ARG_CHOICE, "none|core",
     "worker placement: none (the OS decides) or one per physical core"},
    {NULL, 0, 0, ARG_NONE, NULL, "Output:"},
    {"rg-per-decade", 0, OPT_RG_PER_DECADE, ARG_INT, "K",
     "R_g(N) samples per decade of N, 0 = none"},
    {"arrival", 0, OPT_ARRIVAL, ARG_NONE, NULL,
     "store positions in arrival order (costs 4 bytes per coordinate while growing; "
     "lets `pdla render --color arrival` colour by it)"},
    {"out", 0, OPT_OUT, ARG_STRING, "DIR",
     "run directory; it must not exist, its parents are made "
     "(default runs/run-YYYYmmdd-HHMMSS-<dim>d-<target>)"},
    {"force", 0, OPT_FORCE, ARG_NONE, NULL,
     "allow an existing run directory; its cluster.h5 and summary.txt are replaced"},
    {"no-output", 0, OPT_NO_OUTPUT, ARG_NONE, NULL,
     "no run directory and no files: grow and print the summary (for benchmarks)"},
    {"stats-json", 0, OPT_STATS_JSON, ARG_STRING, "FILE",
     "also write counters, timings and fit as JSON to FILE"},
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
     "checkpoint file; --target may be raised, --threads, --serial-until and --bind "
     "changed, other parameters must match"},
    {"help", 'h', 'h', ARG_NONE, NULL, "print this help and exit"},
    {"version", 'V', 'V', ARG_NONE, NULL, "print the version and exit"},
};
#define N_OPTIONS (sizeof options / sizeof options[0])

typedef struct choice {
    const char *word;
    int value;
} choice;

static const choice return_choices[] = {{"exact", PDLA_RETURN_EXACT}, {"kill", PDLA_RETURN_KILL}, {NULL, 0}};
static const choice recheck_choices[] = {
    {"continue", PDLA_RECHECK_CONTINUE}, {"discard", PDLA_RECHECK_DISCARD}, {NULL, 0}};
static const choice bind_choices[] = {{"none", PDLA_BIND_NONE}, {"core", PDLA_BIND_CORE}, {NULL, 0}};

static const choice *choices_of(int id)
{
    switch (id) {
    case OPT_RETURN: return return_choices;
    case OPT_RECHECK: return recheck_choices;
    case OPT_BIND: return bind_choices;
    default: return NULL;
    }
}

static const char *choice_word(const choice *c, int value)
{
    for (; c->word; c++)
        if (c->value == value) return c->word;
    return "?";
}

static const opt_desc *find_opt(int id)
{
    for (size_t i = 0; i < N_OPTIONS; i++)
        if (options[i].name && options[i].id == id) return &options[i];
    return NULL;
}

/* ---- error messages ---------------------------------------------------- */

static int fail(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return CLI_PARSE_ERROR;
}

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
        const choice *c = choices_of(d->id);
        for (; c->word; c++)
            if (!strcmp(arg, c->word)) break;
        if (!c->word)
            return fail(err, errlen, "invalid value '%s' for %s: should be %s", shown(v, arg),
                        opt_label(l, d), d->metavar);
        n = (uint64_t)c->value;
        break;
    }
    case ARG_NONE: break;
    }
    if (why) return fail(err, errlen, "invalid value '%s' for %s: %s", shown(v, arg), opt_label(l, d), why);

    pdla_params *p = &o->params;
    static const uint32_t field_of[] = {
        [OPT_DIM - OPT_DIM] = PDLA_PARAM_DIM, [OPT_TARGET - OPT_DIM] = PDLA_PARAM_TARGET,
        [OPT_SEED - OPT_DIM] = PDLA_PARAM_SEED, [OPT_RESOLUTION - OPT_DIM] = PDLA_PARAM_RESOLUTION,
        [OPT_EPS - OPT_DIM] = PDLA_PARAM_EPS, [OPT_NO_SNAP - OPT_DIM] = PDLA_PARAM_SNAP_CONTACT,
        [OPT_BIRTH_MARGIN - OPT_DIM] = PDLA_PARAM_BIRTH_MARGIN,
        [OPT_RETURN - OPT_DIM] = PDLA_PARAM_RETURN_MODE,
        [OPT_KILL_RATIO - OPT_DIM] = PDLA_PARAM_KILL_RATIO,
        [OPT_MAX_JUMPS - OPT_DIM] = PDLA_PARAM_MAX_JUMPS,
        [OPT_EXACT_SEARCH - OPT_DIM] = PDLA_PARAM_EXACT_SEARCH,
        [OPT_FAR_FACTOR - OPT_DIM] = PDLA_PARAM_FAR_FACTOR,
        [OPT_THREADS - OPT_DIM] = PDLA_PARAM_THREADS,
        [OPT_SERIAL_UNTIL - OPT_DIM] = PDLA_PARAM_SERIAL_UNTIL,
        [OPT_RECHECK - OPT_DIM] = PDLA_PARAM_RECHECK, [OPT_BIND - OPT_DIM] = PDLA_PARAM_BIND,
        [OPT_RG_PER_DECADE - OPT_DIM] = PDLA_PARAM_RG_PER_DECADE};
    if (d->id >= OPT_DIM && d->id <= OPT_RG_PER_DECADE) o->given |= field_of[d->id - OPT_DIM];
    switch (d->id) {
    case OPT_DIM: p->dim = (int)n; break;
    case OPT_TARGET: p->target = n; break;
    case OPT_SEED: p->seed = n; break;
    case OPT_RESOLUTION: p->resolution = (int)n; break;
    case OPT_EPS: p->eps = (int)n; break;
    case OPT_NO_SNAP: p->snap_contact = 0; break;
    case OPT_BIRTH_MARGIN: p->birth_margin = x; break;
    case OPT_RETURN: p->return_mode = (pdla_return_mode)n; break;
    case OPT_KILL_RATIO: p->kill_ratio = x; break;
    case OPT_MAX_JUMPS: p->max_jumps = n; break;
    case OPT_EXACT_SEARCH: p->exact_search = 1; break;
    case OPT_FAR_FACTOR: p->far_factor = x; break;
    case OPT_THREADS: p->threads = (int)n; break;
    case OPT_SERIAL_UNTIL: p->serial_until = n; break;
    case OPT_RECHECK: p->recheck = (pdla_recheck_mode)n; break;
    case OPT_BIND: p->bind = (pdla_bind_mode)n; break;
    case OPT_RG_PER_DECADE: p->rg_per_decade = (int)n; break;
    case OPT_ARRIVAL:
        p->record_arrival = 1;
        o->given |= PDLA_PARAM_RECORD_ARRIVAL;
        break;
    case OPT_OUT: o->out_dir = arg; break;
    case OPT_FORCE: o->force = 1; break;
    case OPT_NO_OUTPUT: o->no_output = 1; break;
    case OPT_STATS_JSON: o->stats_json = arg; break;
    case OPT_SCENE:
        if (o->scene) return fail(err, errlen, "--scene given twice");
        o->scene = arg;
        break;
    case 'q': o->quiet = 1; break;
    case OPT_PROGRESS: o->progress = 1; break;
    case OPT_NO_PROGRESS: o->progress = 0; break;
    case OPT_CHECKPOINT: o->checkpoint = 1; break;
    case OPT_CHECKPOINT_EVERY: o->checkpoint = 1; o->checkpoint_every = x; break;
    case OPT_CHECKPOINT_PARTICLES:
        if (n == 0) return fail(err, errlen, "invalid value '%s' for --checkpoint-particles: must be at least 1",
                                shown(v, arg));
        o->checkpoint = 1;
        o->checkpoint_particles = n;
        break;
    case OPT_CHECKPOINT_COMPRESS: o->checkpoint = 1; o->checkpoint_compress = 1; break;
    case OPT_RESUME: o->checkpoint = 1; o->resume = arg; break;
    case 'h': o->action = CLI_HELP; break;
    case 'V': o->action = CLI_VERSION; break;
    default: return fail(err, errlen, "internal error: option %d has no handler", d->id);
    }
    return CLI_PARSE_OK;
}

int cli_set_option(cli_options *o, const char *name, const char *value, char *err, size_t errlen)
{
    const opt_desc *d = NULL;
    for (size_t i = 0; i < N_OPTIONS && !d; i++)
        if (options[i].name && !strcmp(options[i].name, name)) d = &options[i];
    char v[64];
    if (!d || d->id == 'h' || d->id == 'V' || d->id == OPT_SCENE)
        return fail(err, errlen, "unknown key '%s' (keys are the long options of pdla --help "
                    "without '--', except scene, help and version)", shown(v, name));
    if (d->kind != ARG_NONE) return set_value(o, d, value, err, errlen);
    static const char *const yes[] = {"yes", "true", "1"}, *const no[] = {"no", "false", "0"};
    for (int i = 0; i < 3; i++) {
        if (!strcmp(value, yes[i])) return set_value(o, d, NULL, err, errlen);
        if (!strcmp(value, no[i])) return CLI_PARSE_OK;
    }
    return fail(err, errlen, "invalid value '%s' for %s: should be yes or no", shown(v, value), name);
}

/* One pass of getopt over argv into *out (not reset). */
static int parse_args(int argc, char **argv, cli_options *out, char *err, size_t errlen)
{
    struct option longopts[N_OPTIONS + 1];
    char shortopts[2 * N_OPTIONS + 2];
    size_t nl = 0, ns = 0;
    shortopts[ns++] = ':'; /* report a missing value as ':' rather than '?' */
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
            const opt_desc *d = find_opt(optopt);
            char l[64];
            return fail(err, errlen, "option %s needs a value (%s)",
                        d ? opt_label(l, d) : shown(v, cur), d ? d->metavar : "see --help");
        }
        if (c == '?') {
            const opt_desc *d = optopt ? find_opt(optopt) : NULL;
            if (d) { /* a known flag given "=value" */
                char l[64];
                return fail(err, errlen, "option %s does not take a value", opt_label(l, d));
            }
            if (optopt > 0x20 && optopt < 0x7f) /* printable: control bytes would break the line */
                return fail(err, errlen, "unknown option '-%c' (see --help)", optopt);
            return fail(err, errlen, "unknown or ambiguous option '%s' (see --help)", shown(v, cur));
        }
        const opt_desc *d = find_opt(c);
        if (!d) return fail(err, errlen, "internal error: getopt returned %d", c);
        const int rc = set_value(out, d, optarg, err, errlen);
        if (rc) return rc;
    }
    if (optind < argc)
        return fail(err, errlen, "unexpected argument '%s' (options only; see --help)",
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

static int parse_all(int argc, char **argv, cli_options *out, char *err, size_t errlen);

/* Errors are one line: a file name or argument quoted in the message may
 * hold a newline or another control byte, so those are shown as '?'. */
int cli_parse(int argc, char **argv, cli_options *out, char *err, size_t errlen)
{
    const int rc = parse_all(argc, argv, out, err, errlen);
    if (rc == CLI_PARSE_ERROR && err)
        for (char *c = err; *c; c++)
            if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
    return rc;
}

static int parse_all(int argc, char **argv, cli_options *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    pdla_params_default(&out->params);
    out->action = CLI_RUN;
    out->progress = -1;
    if (err && errlen) err[0] = '\0';

    /* Pass 1 finds --help, --version and --scene (and any syntax error);
     * with a scene, pass 2 applies the command line over it. */
    cli_options *first = malloc(sizeof *first);
    if (!first) return fail(err, errlen, "out of memory");
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

    if (out->no_output && out->out_dir)
        return fail(err, errlen, "--no-output and --out exclude each other");
    if (out->no_output && out->force)
        return fail(err, errlen, "--no-output and --force exclude each other");
    if (out->no_output && out->checkpoint)
        return fail(err, errlen, "checkpoints need a run directory: --no-output excludes them");
    if (out->resume && (out->out_dir || out->force))
        return fail(err, errlen, "--resume continues in the checkpoint's run directory: "
                                 "--out and --force do not apply");
    if (pdla_params_validate(&out->params, err, errlen) != PDLA_OK) return CLI_PARSE_ERROR;
    return CLI_PARSE_OK;
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

/* The default of an option as text, from the library's defaults; 0 if the
 * option has none worth showing. */
static int default_text(int id, const pdla_params *d, char *buf, size_t n)
{
    switch (id) {
    case OPT_DIM: snprintf(buf, n, "%d", d->dim); return 1;
    case OPT_TARGET: snprintf(buf, n, "%" PRIu64, d->target); return 1;
    case OPT_SEED: snprintf(buf, n, "%" PRIu64, d->seed); return 1;
    case OPT_RESOLUTION: snprintf(buf, n, "%d", d->resolution); return 1;
    case OPT_EPS: snprintf(buf, n, "%d", d->eps); return 1;
    case OPT_BIRTH_MARGIN: snprintf(buf, n, "%g", d->birth_margin); return 1;
    case OPT_RETURN: snprintf(buf, n, "%s", choice_word(return_choices, d->return_mode)); return 1;
    case OPT_KILL_RATIO: snprintf(buf, n, "%g", d->kill_ratio); return 1;
    case OPT_MAX_JUMPS: snprintf(buf, n, "%" PRIu64, d->max_jumps); return 1;
    case OPT_FAR_FACTOR: snprintf(buf, n, "%g", d->far_factor); return 1;
    case OPT_THREADS: snprintf(buf, n, "%d", d->threads); return 1;
    case OPT_SERIAL_UNTIL: snprintf(buf, n, "%" PRIu64, d->serial_until); return 1;
    case OPT_RECHECK: snprintf(buf, n, "%s", choice_word(recheck_choices, d->recheck)); return 1;
    case OPT_BIND: snprintf(buf, n, "%s", choice_word(bind_choices, d->bind)); return 1;
    case OPT_RG_PER_DECADE: snprintf(buf, n, "%d", d->rg_per_decade); return 1;
    /* Flags that turn a default off or on say so only when it matters. */
    case OPT_NO_SNAP: return 0;
    case OPT_EXACT_SEARCH: return 0;
    default: return 0;
    }
}

size_t cli_help_text(char *buf, size_t len, const pdla_params *defaults)
{
    text t = {buf, len, 0};
    if (buf && len) buf[0] = '\0';
    put(&t,
        "Usage: pdla [OPTION]...\n"
        "       pdla info|render|analyze FILE [OPTION]...   (pdla COMMAND --help)\n"
        "Grow an off-lattice diffusion-limited aggregation (DLA) cluster and write it\n"
        "to RUN_DIR/cluster.h5 (HDF5), with a summary in RUN_DIR/summary.txt.\n"
        "Look at a cluster file: `info` (what it holds), `render` (a PNG picture),\n"
        "`analyze` (fractal dimension from R_g(N) and from the mass-radius relation).\n"
        "Lengths are in units (D units = one particle diameter) or in diameters.\n");
    for (size_t i = 0; i < N_OPTIONS; i++) {
        const opt_desc *d = &options[i];
        if (!d->name) {
            put(&t, "\n%s\n", d->help);
            continue;
        }
        char head[64];
        int col;
        if (d->short_name)
            col = snprintf(head, sizeof head, "  -%c, --%s", d->short_name, d->name);
        else
            col = snprintf(head, sizeof head, "  --%s", d->name);
        if (d->metavar && col > 0 && (size_t)col < sizeof head)
            col += snprintf(head + col, sizeof head - (size_t)col, " %s", d->metavar);
        put(&t, "%s", head);
        if (col + 2 > HELP_COL) {
            put(&t, "\n");
            col = 0;
        }
        put(&t, "%*s", HELP_COL - col, "");
        char dflt[48], help[512];
        if (default_text(d->id, defaults, dflt, sizeof dflt))
            snprintf(help, sizeof help, "%s (default%c%s)", d->help, NBSP, dflt);
        else
            snprintf(help, sizeof help, "%s", d->help);
        put_wrapped(&t, HELP_COL, help);
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
