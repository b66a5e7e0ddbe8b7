/*
 * parse.h - the `pdla` command line: strict number parsing and the option
 * table. No I/O and no state of its own (getopt's globals are reset on each
 * call), so unit tests and a fuzzer can call it directly; main.c prints.
 *
 * Counts (--target, --seed, --max-jumps, ...) are unsigned 64-bit integers
 * written as 1000000, 1e6, 1.5e6 or with a suffix k, M, G, T (10^3, 10^6,
 * 10^9, 10^12; case-sensitive, so "10m" is refused rather than guessed at).
 * Whatever the spelling, the value must be a whole number: "1.5k" is 1500,
 * "2.5" and "1e-3" are errors. Signs, blanks, hexadecimal, inf and nan are
 * refused. Reals (--birth-margin, --kill-ratio, --far-factor) are decimal
 * numbers read with strtod; the whole string must be used and the value
 * finite. Ranges are checked by pdla_params_validate, the library's single
 * source of truth, except that a value must fit the field's C type.
 */
#ifndef PDLA_CLI_PARSE_H
#define PDLA_CLI_PARSE_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/pdla.h"
#include "pdla/params.h"

typedef enum cli_action {
    CLI_RUN = 0,  /* grow a cluster */
    CLI_HELP,     /* -h/--help: print cli_help_text() on stdout, exit 0 */
    CLI_VERSION   /* -V/--version: print the version on stdout, exit 0 */
} cli_action;

typedef struct cli_options {
    pdla_params params;      /* pdla_params_default() plus what was given */
    cli_action action;
    const char *out_dir;     /* --out DIR (points into argv), NULL: default name */
    const char *stats_json;  /* --stats-json FILE (into argv), NULL: none */
    int force;               /* --force: the run directory may exist */
    int no_output;           /* --no-output: no run directory, no files */
    int quiet;               /* -q: no progress, no summary; errors only */
    int progress;            /* 1 --progress, 0 --no-progress, -1 not given */
    const char *scene;       /* --scene FILE (into argv), NULL: none */
    char scene_out[4096];    /* a scene's `out` and `stats-json` values live */
    char scene_stats[4096];  /* here (out_dir/stats_json point to them) */
    char scene_resume[4096]; /* a scene's `resume` value (resume points to it) */
    /* Checkpoints (README "Checkpoints and resume"). */
    int checkpoint;          /* 1: write checkpoints (any --checkpoint* option or --resume) */
    double checkpoint_every; /* --checkpoint-every, seconds; 0: no time trigger */
    uint64_t checkpoint_particles; /* --checkpoint-particles; 0: no particle trigger */
    int checkpoint_compress; /* --checkpoint-compress */
    int schedule_given;      /* one of the three above given (a resume then drops the recorded schedule) */
    const char *resume;      /* --resume DIR|FILE (into argv), NULL: a new run */
    uint32_t given;          /* PDLA_PARAM_* bits of the parameters given explicitly */
    /* cli_parse_threads_apart: --threads and a scene's `threads` mean
     * something else to the caller (pdla ensemble: clusters grown at once),
     * so they land here and params.threads keeps its default. */
    int threads_apart;
    int apart_threads_given;
    uint64_t apart_threads;
} cli_options;

/* The longest run directory or checkpoint path the commands take, in
 * bytes: room for "/checkpoint.h5.tmp.PID" and the like in their 4096-byte
 * buffers. Longer is refused before anything is created (a path cut to
 * fit would name another directory). */
#define CLI_RUN_DIR_MAX 4000
/* 0 if path fits CLI_RUN_DIR_MAX; else the one-line reason in err
 * ("WHAT is too long (N bytes; at most 4000)") and -1. */
int cli_path_fits(const char *what, const char *path, char *err, size_t errlen);

/* Return values of cli_parse. */
enum { CLI_PARSE_OK = 0, CLI_PARSE_EXIT = 1, CLI_PARSE_ERROR = 2 };

/* Parse argv into *out (filled with the defaults first, then the scene of
 * --scene FILE if one is given, then the other options, which override the
 * scene's keys). Returns
 * CLI_PARSE_OK to run, CLI_PARSE_EXIT when --help or --version was asked
 * (out->action says which; the caller prints), or CLI_PARSE_ERROR with a
 * one-line reason in err (no "pdla: " prefix, no newline). On success the
 * parameters have passed pdla_params_validate. getopt_long may permute argv. */
int cli_parse(int argc, char **argv, cli_options *out, char *err, size_t errlen);
/* The same, with --threads (and a scene's `threads` key) stored in
 * out->apart_threads (apart_threads_given set) instead of the parameters:
 * their range is the caller's to check. */
int cli_parse_threads_apart(int argc, char **argv, cli_options *out, char *err, size_t errlen);

/* Set one option by its long name (no "--"; as in a scene file) to a value,
 * exactly as if "--NAME VALUE" had been given; a flag (an option without a
 * value) takes yes|no|true|false|1|0, "no" leaving it as it is. `scene`,
 * `help` and `version` are refused. CLI_PARSE_OK or CLI_PARSE_ERROR with the
 * reason in err. Used by parse.c's scene_apply. */
int cli_set_option(cli_options *o, const char *name, const char *value, char *err, size_t errlen);

/* Apply the scene file `path` (scene.h) to *o, which already holds the
 * defaults: each key as cli_set_option, then the scene alone must be a valid
 * run. CLI_PARSE_OK or CLI_PARSE_ERROR with "FILE:LINE: reason" in err. */
int scene_apply(const char *path, cli_options *o, char *err, size_t errlen);
/* The same for a scene held in memory (`name` is used in messages only). */
int scene_apply_text(const char *name, const char *text, size_t len, cli_options *o, char *err,
                     size_t errlen);

/* Strict parsers for one value. Return NULL on success, else a short static
 * reason such as "trailing characters after the number" (*out untouched). */
const char *cli_parse_count(const char *s, uint64_t *out);
const char *cli_parse_real(const char *s, double *out);

/* A count (as cli_parse_count) within [lo, hi]: 0, else -1 (subcommands'
 * whole-number options). */
int cli_parse_long_in(const char *s, long lo, long hi, long *out);
/* A positive duration: a decimal number of seconds with an optional suffix
 * s, m or h ("90", "30m", "1.5h"). */
const char *cli_parse_duration(const char *s, double *out);

/* pdla_params_validate with the option to change appended to the reason,
 * e.g. "far factor must be in [0.5, 64], got 65 (--far-factor)". */
int cli_check_params(const pdla_params *p, char *err, size_t errlen);

/* The --help text for the given defaults, like snprintf: writes at most len
 * bytes (NUL-terminated when len > 0) and returns the full length. */
size_t cli_help_text(char *buf, size_t len, const pdla_params *defaults);

#endif /* PDLA_CLI_PARSE_H */
