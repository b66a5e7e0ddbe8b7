/*
 * test_parse.c - the CLI's number parsing and option table (src/cli/parse.c)
 * against tables of inputs with their expected values or errors, without
 * running anything: counts (exact to UINT64_MAX, suffixes, exponents,
 * whole-number rule, junk), reals (finite, full-string), whole command lines
 * (values, errors as one line naming the option, --help/--version, the
 * library's validation) and the --help text (defaults from the library,
 * lines within 79 columns).
 */
#include <stdint.h>
#include <string.h>

#include "../check.h"
#include "parse.h"

typedef struct count_case {
    const char *in;
    int ok;
    uint64_t want;
    const char *why; /* a substring of the expected reason, when !ok */
} count_case;

static const count_case counts[] = {
    {"0", 1, 0, NULL},
    {"1", 1, 1, NULL},
    {"1000000", 1, 1000000, NULL},
    {"007", 1, 7, NULL},
    {"1e6", 1, 1000000, NULL},
    {"1E6", 1, 1000000, NULL},
    {"1e+6", 1, 1000000, NULL},
    {"1.5e6", 1, 1500000, NULL},
    {"2.50e1", 1, 25, NULL},
    {"1000e-3", 1, 1, NULL},
    {"0.0", 1, 0, NULL},
    {"0e99999", 1, 0, NULL},
    {"10M", 1, 10000000, NULL},
    {"2k", 1, 2000, NULL},
    {"1G", 1, 1000000000, NULL},
    {"1T", 1, 1000000000000, NULL},
    {"1M", 1, 1000000, NULL},
    {"1.5k", 1, 1500, NULL},
    {"0.001k", 1, 1, NULL},
    {"18446744073709551615", 1, UINT64_MAX, NULL},
    {"0018446744073709551615", 1, UINT64_MAX, NULL},
    {"18446744073709551615.000", 1, UINT64_MAX, NULL},
    {"1e19", 1, UINT64_C(10000000000000000000), NULL},
    {"18.446744073709551615e18", 1, UINT64_MAX, NULL},
    {"18446744073709551616", 0, 0, "too large"},
    {"18446744073709551620", 0, 0, "too large"},
    {"99999999999999999999", 0, 0, "too large"},
    {"99999999999999999999999", 0, 0, "too large"},
    {"1e20", 0, 0, "too large"},
    {"1e999999999999999999999999", 0, 0, "too large"},
    {"20000000T", 0, 0, "too large"},
    {"100000000000000000000000e-5", 1, UINT64_C(1000000000000000000), NULL},
    {"", 0, 0, "empty"},
    {" 5", 0, 0, "not a number"},
    {"5 ", 0, 0, "trailing"},
    {"+5", 0, 0, "not a number"},
    {"-5", 0, 0, "negative"},
    {"-0", 0, 0, "negative"},
    {"0x10", 0, 0, "trailing"},
    {"1e-3", 0, 0, "not a whole number"},
    {"2.5", 0, 0, "not a whole number"},
    {"1.5", 0, 0, "not a whole number"},
    {"0.5", 0, 0, "not a whole number"},
    {"1.0000000000000000000000001", 0, 0, "not a whole number"},
    {"1.5e-999999999999999", 0, 0, "not a whole number"},
    {"inf", 0, 0, "not a number"},
    {"nan", 0, 0, "not a number"},
    {"infinity", 0, 0, "not a number"},
    {".5", 0, 0, "not a number"},
    {"1.", 0, 0, "digits after"},
    {"1e", 0, 0, "exponent"},
    {"1e+", 0, 0, "exponent"},
    {"12x", 0, 0, "trailing"},
    {"10m", 0, 0, "suffix"},
    {"10K", 0, 0, "suffix"},
    {"1e6k", 0, 0, "trailing"},
    {"1kk", 0, 0, "trailing"},
    {"1_000", 0, 0, "trailing"},
    {"1,000", 0, 0, "trailing"},
    {"5\n", 0, 0, "trailing"},
};

typedef struct real_case {
    const char *in;
    int ok;
    double want;
} real_case;

static const real_case reals[] = {
    {"2", 1, 2.0},     {"2.5", 1, 2.5},  {"1e2", 1, 100.0}, {".5", 1, 0.5},
    {"-1", 1, -1.0},   {"+3", 1, 3.0},   {"0", 1, 0.0},     {"", 0, 0},
    {" 2", 0, 0},      {"2 ", 0, 0},     {"nan", 0, 0},     {"NaN", 0, 0},
    {"-nan", 0, 0},    {"inf", 0, 0},    {"-inf", 0, 0},    {"infinity", 0, 0},
    {"1e999", 0, 0},   {"0x10", 0, 0},   {"0x1p3", 0, 0},   {"2x", 0, 0},
    {"1,5", 0, 0},     {"e5", 0, 0},     {"-", 0, 0},
};

/* Durations (cli_parse_duration: --checkpoint-every of the DLA, DLCA and
 * event commands): README's `90`, `30m`, `1.5h`, seconds without a
 * suffix; 0 is no time trigger; at most 1e9 s. */
static const real_case durations[] = {
    {"90", 1, 90.0},      {"90s", 1, 90.0},   {"30m", 1, 1800.0}, {"1.5h", 1, 5400.0},
    {"0", 1, 0.0},        {"0.05", 1, 0.05},  {".5m", 1, 30.0},   {"1000000000", 1, 1e9},
    {"1000000001", 0, 0}, {"277778h", 0, 0},  {"", 0, 0},         {"h", 0, 0},
    {"10x", 0, 0},        {"1e3", 0, 0},      {"-5", 0, 0},       {"1.5 h", 0, 0},
    {"1.5hh", 0, 0},      {"nan", 0, 0},      {"inf", 0, 0},      {"90S", 0, 0},
};

/* Run cli_parse on a NULL-terminated word list (argv[0] added). */
static int parse(cli_options *o, char *err, size_t errlen, const char *const *words)
{
    char *argv[32];
    int argc = 0;
    static char name[] = "pdla";
    argv[argc++] = name;
    /* getopt may permute argv, so give it private copies. */
    static char store[32][256];
    for (; words[argc - 1]; argc++) {
        snprintf(store[argc], sizeof store[argc], "%s", words[argc - 1]);
        argv[argc] = store[argc];
    }
    argv[argc] = NULL;
    return cli_parse(argc, argv, o, err, errlen);
}

typedef struct bad_case {
    const char *words[6];
    const char *msg; /* substring of the error */
} bad_case;

static const bad_case bad[] = {
    {{"--bogus", NULL}, "unknown"},
    /* A newline in a quoted name must not split the one-line error (the
     * fuzzer's find: --sc "//\xce\nF"); the test also rejects '\n'. */
    {{"--scene", "//\xce\nF", NULL}, "scene //\xce?F"},
    {{"-x", NULL}, "unknown option '-x'"},
    {{"--target", NULL}, "needs a value"},
    {{"--target", "12x", NULL}, "invalid value '12x' for --target: trailing characters"},
    {{"--target", "-5", NULL}, "negative"},
    {{"--target", "1.5", NULL}, "not a whole number"},
    {{"--target", "99999999999999999999999", NULL}, "too large"},
    {{"--target", "0", NULL}, "target"},
    {{"--target", "1e13", NULL}, "2^40"},
    {{"--dim", "4", NULL}, "dim"},
    {{"--dim", "4294967298", NULL}, "too large"},
    {{"--resolution", "48", NULL}, "power of two"},
    {{"--eps", "0", NULL}, "eps"},
    {{"--return", "bogus", NULL}, "should be exact|kill"},
    {{"--recheck", "maybe", NULL}, "continue|discard"},
    {{"--bind", "socket", NULL}, "none|core"},
    {{"--far-factor", "nan", NULL}, "--far-factor"},
    {{"--far-factor", "100", NULL}, "far factor"},
    {{"--kill-ratio", "1", NULL}, "kill ratio"},
    {{"--birth-margin", "0.5", NULL}, "birth margin"},
    {{"--force=yes", NULL}, "does not take a value"},
    {{"stray", NULL}, "unexpected argument 'stray'"},
    {{"--out", "", NULL}, "empty"},
    {{"--out", "--force", NULL}, "starting with '-'"},
    {{"--no-output", "--out", "x", NULL}, "exclude"},
    {{"--t", "5", NULL}, "unknown option '--t'"},
    /* Long options are exact: a unique prefix is refused too (issue 10). */
    {{"--targ", "5", NULL}, "long options are not abbreviated"},
    {{"--no-out", NULL}, "unknown option '--no-out'"},
    {{"--target", "1\n2", NULL}, "'1?2'"},
};

int main(void)
{
    for (size_t i = 0; i < sizeof counts / sizeof counts[0]; i++) {
        const count_case *c = &counts[i];
        uint64_t v = 12345;
        const char *why = cli_parse_count(c->in, &v);
        if (c->ok) {
            CHECK(why == NULL, "'%s': unexpected error '%s'", c->in, why ? why : "");
            CHECK(v == c->want, "'%s': got %llu, want %llu", c->in, (unsigned long long)v,
                  (unsigned long long)c->want);
        } else {
            CHECK(why != NULL, "'%s': accepted as %llu", c->in, (unsigned long long)v);
            CHECK(why && strstr(why, c->why), "'%s': reason '%s' lacks '%s'", c->in, why ? why : "",
                  c->why);
            CHECK(v == 12345, "'%s': output touched on error", c->in);
        }
    }
    CHECK(cli_parse_count(NULL, &(uint64_t){0}) != NULL, "NULL accepted");

    for (size_t i = 0; i < sizeof reals / sizeof reals[0]; i++) {
        const real_case *c = &reals[i];
        double v = -7;
        const char *why = cli_parse_real(c->in, &v);
        if (c->ok) {
            CHECK(why == NULL && v == c->want, "'%s': got %g (%s), want %g", c->in, v, why ? why : "ok",
                  c->want);
        } else {
            CHECK(why != NULL, "'%s': accepted as %g", c->in, v);
            CHECK(v == -7, "'%s': output touched on error", c->in);
        }
    }

    for (size_t i = 0; i < sizeof durations / sizeof durations[0]; i++) {
        const real_case *c = &durations[i];
        double v = -7;
        const char *why = cli_parse_duration(c->in, &v);
        if (c->ok) {
            CHECK(why == NULL && v == c->want, "duration '%s': got %g (%s), want %g", c->in, v,
                  why ? why : "ok", c->want);
        } else {
            CHECK(why != NULL, "duration '%s': accepted as %g", c->in, v);
            CHECK(v == -7, "duration '%s': output touched on error", c->in);
        }
    }

    /* Whole command lines. */
    pdla_params d;
    pdla_params_default(&d);
    cli_options o;
    char err[256];

    int rc = parse(&o, err, sizeof err, (const char *const[]){NULL});
    CHECK(rc == CLI_PARSE_OK && o.action == CLI_RUN, "no options: rc %d (%s)", rc, err);
    CHECK(!memcmp(&o.params, &d, sizeof d), "no options: params differ from the defaults");
    CHECK(o.out_dir == NULL && o.stats_json == NULL && !o.force && !o.no_output && !o.quiet &&
              o.progress == -1,
          "no options: CLI defaults");

    rc = parse(&o, err, sizeof err, (const char *const[]){"--target", "10M", NULL});
    CHECK(rc == CLI_PARSE_OK && o.params.target == 10000000, "--target 10M: rc %d target %llu (%s)", rc,
          (unsigned long long)o.params.target, err);
    rc = parse(&o, err, sizeof err, (const char *const[]){"--target=1.5e6", "--seed", "18446744073709551615", NULL});
    CHECK(rc == CLI_PARSE_OK && o.params.target == 1500000 && o.params.seed == UINT64_MAX,
          "--target=1.5e6 --seed max: rc %d (%s)", rc, err);

    rc = parse(&o, err, sizeof err,
               (const char *const[]){"--dim", "3", "--resolution", "64", "--eps", "4", "--birth-margin", "3.5",
                                     NULL});
    CHECK(rc == CLI_PARSE_OK && o.params.dim == 3 && o.params.resolution == 64 && o.params.eps == 4 &&
              o.params.birth_margin == 3.5,
          "cluster options: rc %d (%s)", rc, err);
    rc = parse(&o, err, sizeof err,
               (const char *const[]){"--return", "kill", "--kill-ratio", "50", "--exact-search", "--far-factor",
                                     "4", NULL});
    CHECK(rc == CLI_PARSE_OK && o.params.return_mode == PDLA_RETURN_KILL && o.params.kill_ratio == 50 &&
              o.params.exact_search == 1 && o.params.far_factor == 4,
          "walker options: rc %d (%s)", rc, err);
    rc = parse(&o, err, sizeof err,
               (const char *const[]){"--max-jumps", "1k", "--rg-per-decade", "0", "--no-snap-contact", NULL});
    CHECK(rc == CLI_PARSE_OK && o.params.max_jumps == 1000 && o.params.rg_per_decade == 0 &&
              o.params.snap_contact == 0,
          "more options: rc %d (%s)", rc, err);
    rc = parse(&o, err, sizeof err,
               (const char *const[]){"--threads", "0", "--serial-until", "1M", "--recheck", "discard", "--bind",
                                     "core", NULL});
    CHECK(rc == CLI_PARSE_OK && o.params.threads == 0 && o.params.serial_until == 1000000 &&
              o.params.recheck == PDLA_RECHECK_DISCARD && o.params.bind == PDLA_BIND_CORE,
          "thread options: rc %d (%s)", rc, err);
    rc = parse(&o, err, sizeof err,
               (const char *const[]){"--out", "runs/x", "--force", "-q", "--progress", "--stats-json", "s.json",
                                     NULL});
    CHECK(rc == CLI_PARSE_OK && o.out_dir && !strcmp(o.out_dir, "runs/x") && o.force && o.quiet &&
              o.progress == 1 && o.stats_json && !strcmp(o.stats_json, "s.json"),
          "output options: rc %d (%s)", rc, err);
    rc = parse(&o, err, sizeof err, (const char *const[]){"--progress", "--no-progress", "--no-output", NULL});
    CHECK(rc == CLI_PARSE_OK && o.progress == 0 && o.no_output, "last of --progress/--no-progress wins");
    rc = parse(&o, err, sizeof err, (const char *const[]){"--dim", "3", "--dim", "2", NULL});
    CHECK(rc == CLI_PARSE_OK && o.params.dim == 2, "a repeated option: the last wins");

    rc = parse(&o, err, sizeof err, (const char *const[]){"--help", NULL});
    CHECK(rc == CLI_PARSE_EXIT && o.action == CLI_HELP, "--help: rc %d", rc);
    rc = parse(&o, err, sizeof err, (const char *const[]){"-V", NULL});
    CHECK(rc == CLI_PARSE_EXIT && o.action == CLI_VERSION, "-V: rc %d", rc);
    /* --help wins over a bad parameter value that parses (validation is for runs). */
    rc = parse(&o, err, sizeof err, (const char *const[]){"--dim", "4", "-h", NULL});
    CHECK(rc == CLI_PARSE_EXIT && o.action == CLI_HELP, "--dim 4 -h: rc %d", rc);

    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const bad_case *b = &bad[i];
        err[0] = '\0';
        rc = parse(&o, err, sizeof err, b->words);
        CHECK(rc == CLI_PARSE_ERROR, "%s %s: rc %d, want an error", b->words[0], b->words[1] ? b->words[1] : "",
              rc);
        CHECK(strstr(err, b->msg) != NULL, "%s: message '%s' lacks '%s'", b->words[0], err, b->msg);
        CHECK(!strchr(err, '\n') && err[0], "%s: message is not one line: '%s'", b->words[0], err);
    }
    /* A tiny error buffer truncates without overflowing. */
    char tiny[8];
    rc = parse(&o, tiny, sizeof tiny, (const char *const[]){"--target", "12x", NULL});
    CHECK(rc == CLI_PARSE_ERROR && strlen(tiny) == sizeof tiny - 1, "tiny buffer: '%s'", tiny);
    /* A very long value is cut in the message. */
    char longv[300];
    memset(longv, '7', sizeof longv - 2);
    longv[sizeof longv - 2] = 'x';
    longv[sizeof longv - 1] = '\0';
    rc = parse(&o, err, sizeof err, (const char *const[]){"--target", longv, NULL});
    CHECK(rc == CLI_PARSE_ERROR && strstr(err, "...") && strlen(err) < 150, "long value: '%s'", err);

    /* --help: every line within 79 columns, every default from the library. */
    const size_t n = cli_help_text(NULL, 0, &d);
    char help[8192];
    CHECK(n > 500 && n < sizeof help, "help length %zu", n);
    CHECK(cli_help_text(help, sizeof help, &d) == n && strlen(help) == n, "help written fully");
    for (const char *line = help; *line;) {
        const size_t w = strcspn(line, "\n");
        CHECK(w <= 79, "help line too long (%zu): %.*s", w, (int)w, line);
        line += w + (line[w] == '\n');
    }
    const char *want[] = {"--dim 2|3", "(default 2)", "(default 1000000)", "(default 32)",
                          "(default exact)", "(default 100)", "(default 100000000)", "(default 10000000)",
                          "--force", "--no-output", "-q, --quiet", "-h, --help", "-V, --version",
                          "--progress", "--no-progress", "--exact-search", "--stats-json FILE"};
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
        CHECK(strstr(help, want[i]) != NULL, "help lacks '%s'", want[i]);
    /* Other defaults show up in the text: it is built from the struct. */
    pdla_params d2 = d;
    d2.target = 4242;
    cli_help_text(help, sizeof help, &d2);
    CHECK(strstr(help, "(default 4242)") != NULL, "help ignores the defaults it is given");
    char small[16];
    CHECK(cli_help_text(small, sizeof small, &d) == n && strlen(small) == sizeof small - 1,
          "help into a small buffer");
    return check_finish();
}
