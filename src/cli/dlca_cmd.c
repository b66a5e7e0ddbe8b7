/*
 * dlca_cmd.c - `pdla --model dlca ...`: the DLCA model's command line. Its
 * model options, --help lines, scene keys, checks and the resume rule come
 * from the model's rows of the shared parameter table (dlca_param_table,
 * pdla/params.h); a scene file with `model = dlca` takes the same keys. Writes RUN_DIR/cluster.h5 (beside, then renamed) and
 * prints a summary on stdout.
 *
 * Exit status: 0 done; 1 runtime failure; 2 bad usage or input (one line on
 * stderr, before any work). SIGINT/SIGTERM (or a file RUN_DIR/STOP) stop the
 * run; what was reached is written. With checkpoints on (as in the DLA
 * command: --checkpoint, --checkpoint-every T, --checkpoint-attempts N) a
 * checkpoint is written too and pdla exits 0; without, a signal ends pdla by
 * that signal once the output is written. A signal that arrives after the
 * run reached its own stop (while cluster.h5 is written) stopped nothing:
 * the summary says why the run stopped and the exit status is the writes'.
 */
#include <errno.h>
#include <inttypes.h>
#include <fcntl.h>
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "cmdline.h"
#include "dlca_cmd.h"
#include "fail_note.h"
#include "optcheck.h"
#include "parse.h"
#include "rundir.h"
#include "pdla/dlca.h"
#include "pdla/h5check.h"
#include "pdla/params.h"
#include "pdla/pdla.h"
#include "scene.h"

enum { EXIT_RUNTIME = 1, EXIT_USAGE = 2 };
enum { OPT_MODEL = 1000, OPT_SCENE, OPT_OUT, OPT_FORCE, OPT_NO_OUTPUT, OPT_QUIET, OPT_HELP, OPT_CHECK, OPT_CKPT,
       OPT_RESUME, OPT_CKPT_EVERY, OPT_CKPT_ATTEMPTS, OPT_START, OPT_SNAPSHOT_EVERY, OPT_TABLE = 2000 };

typedef struct dlca_cli {
    dlca_params p;
    const char *out;
    int force, no_output, quiet, check, checkpoint;
    double checkpoint_every;      /* seconds of wall time; 0: none */
    uint64_t checkpoint_attempts; /* 0: none */
    int schedule_given;           /* one of the two above given (a resume then drops the recorded schedule) */
    uint32_t given;               /* DLCA_PARAM_* bits of the rows set by options or the scene */
    int box_lengths;              /* --resume: --box's length count, held against the checkpoint's dim */
    const char *resume;
    const char *start;            /* --start FILE: the monomers' sites */
    double snapshot_every;        /* --snapshot-every T (model time); 0: none */
    dlca_snapshot *snaps;         /* taken so far */
    size_t nsnaps;
    int snaps_stopped;            /* out of memory for snapshots: none after the last (kept in checkpoints) */
    uint64_t n_monomers;          /* of the run (set when it starts) */
    int lock, lock_out;           /* flocks (pdla_rundir_lock) of the checkpoint's and the run directory, -1: none */
    int ahead_bad;                /* --resume FILE: its folder's checkpoint.h5 is damaged (named_ahead) */
    char ahead_why[1024];         /* why, for the note when it goes aside */
    cli_fail fail;                /* the write failures: one line on stderr at the end (fail_note.h) */
} dlca_cli;

static volatile sig_atomic_t stop_signal;
static void on_signal(int sig) { stop_signal = sig; }

/* Does the scene name model dlca? (scene.c reads it, as every scene.) */
static int scene_is_dlca(const char *path)
{
    char model[16];
    scene_model(path, model, sizeof model);
    return !strcmp(model, "dlca");
}

int dlca_cmd_wanted(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--") == 0) break;
        if (strcmp(argv[i], "--model=dlca") == 0) return 1;
        if (strcmp(argv[i], "--model") == 0 && i + 1 < argc && strcmp(argv[i + 1], "dlca") == 0) return 1;
        if (strcmp(argv[i], "--scene") == 0 && i + 1 < argc && scene_is_dlca(argv[i + 1])) return 1;
        if (strncmp(argv[i], "--scene=", 8) == 0 && scene_is_dlca(argv[i] + 8)) return 1;
    }
    return 0;
}

static void print_help(FILE *o)
{
    dlca_params d;
    dlca_params_default(&d);
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    fprintf(o, "usage: pdla --model dlca [OPTIONS]\n"
               "Diffusion-limited cluster-cluster aggregation on a periodic lattice (d = 2..5).\n\n"
               "%s\n", t[0].group);
    for (size_t i = 0; i < n; i++) {
        char def[64] = "", opt[96];
        if (t[i].show_default) pdla_param_format(&t[i], &d, 0, def, sizeof def);
        snprintf(opt, sizeof opt, "--%s %s", t[i].option, t[i].metavar ? t[i].metavar : "");
        fprintf(o, "  %-34s %s%s%s%s%s%s\n", opt, t[i].help, t[i].unit[0] ? ", in " : "", t[i].unit,
                def[0] ? " [default " : "", def, def[0] ? "]" : "");
    }
    fprintf(o, "\nRun options:\n"
               "  --scene FILE                       read KEY = VALUE lines (model = dlca, the keys above and the run\n"
               "                                     options' long names with '_' or '-')\n"
               "  --start FILE                       start from the monomers in FILE instead of at random: a text file\n"
               "                                     of one monomer a line, D integer coordinates 0 <= x < L separated\n"
               "                                     by spaces or tabs ('#' comments), or an HDF5 file with\n"
               "                                     /monomers/position (a DLCA cluster.h5); --fill and --count are\n"
               "                                     then not used\n"
               "  --snapshot-every T                 also store the sites and cluster ids at times T, 2T, ... in\n"
               "                                     cluster.h5 (/snapshots/0, 1, ...; kept in memory until written,\n"
               "                                     8 bytes per monomer each; checkpoints keep them for --resume, and\n"
               "                                     cluster.xdmf2 shows them as ParaView time steps)\n"
               "  --out DIR                          run directory (default runs/dlca-YYYYmmdd-HHMMSS-<d>d)\n"
               "  --force                            write into an existing run directory\n"
               "  --no-output                        write no files\n"
               "  --check                            check every invariant at the end (O(N log N))\n"
               "  --checkpoint                       write RUN_DIR/checkpoint.h5 at the end, on SIGINT/SIGTERM and\n"
               "                                     when a file RUN_DIR/STOP appears (then stop and exit 0)\n"
               "  --checkpoint-every T               also every T of wall time: seconds, or with s, m, h (30m)\n"
               "  --checkpoint-attempts N            also every N attempts\n"
               "  --resume PATH                      go on from a checkpoint file or a run directory's\n"
               "                                     checkpoint.h5 (in its run directory unless --out); only\n"
               "                                     --until-* and --max-attempts may change (the others kept);\n"
               "                                     the checkpoint schedule is kept unless --checkpoint-every or\n"
               "                                     --checkpoint-attempts is given\n"
               "  -q, --quiet                        no summary on stdout\n"
               "  --help                             this text\n");
}

/* yes/no into *f: 0, or -1 with the message. */
static int set_flag(int *f, const char *k, const char *val, char *err, size_t errlen)
{
    if (!strcmp(val, "yes") || !strcmp(val, "true") || !strcmp(val, "1")) *f = 1;
    else if (!strcmp(val, "no") || !strcmp(val, "false") || !strcmp(val, "0")) *f = 0;
    else {
        snprintf(err, errlen, "invalid %s '%s' (yes or no)", k, val);
        return -1;
    }
    return 0;
}

/* A run option with a value: 0, 1 (not one of them) or -1 with the message. */
static int set_run_value(dlca_cli *c, const char *k, const char *val, char *err, size_t errlen)
{
    const char *bad = NULL;
    if (!strcmp(k, "out")) c->out = val;
    else if (!strcmp(k, "resume")) c->resume = val;
    else if (!strcmp(k, "start")) c->start = val;
    else if (!strcmp(k, "checkpoint-every")) {
        bad = cli_parse_duration(val, &c->checkpoint_every);
        c->checkpoint = c->schedule_given = 1;
    } else if (!strcmp(k, "checkpoint-attempts")) {
        bad = cli_parse_count(val, &c->checkpoint_attempts);
        if (!bad && c->checkpoint_attempts == 0) bad = "must be at least 1";
        c->checkpoint = c->schedule_given = 1;
    } else if (!strcmp(k, "snapshot-every")) {
        bad = cli_parse_real(val, &c->snapshot_every);
        if (!bad && !(c->snapshot_every > 0)) bad = "must be above 0 (a time in monomer moves)";
    } else return 1;
    if (!bad) return 0;
    snprintf(err, errlen, "invalid value '%s' for %s: %s", val, k, bad);
    return -1;
}

static int set_key(dlca_cli *c, const char *key, const char *val, char *err, size_t errlen)
{
    char k[64];
    snprintf(k, sizeof k, "%s", key);
    for (char *q = k; *q; q++)
        if (*q == '_') *q = '-';
    if (strcmp(k, "model") == 0) {
        if (strcmp(val, "dlca")) {
            snprintf(err, errlen, "--model %s: this command runs model dlca", val);
            return -1;
        }
        return 0;
    }
    const int rv = set_run_value(c, k, val, err, errlen);
    if (rv <= 0) return rv;
    int *flag = !strcmp(k, "force") ? &c->force : !strcmp(k, "check") ? &c->check
              : !strcmp(k, "checkpoint") ? &c->checkpoint : !strcmp(k, "no-output") ? &c->no_output
              : !strcmp(k, "quiet") ? &c->quiet : NULL;
    if (flag) return set_flag(flag, k, val, err, errlen);
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    const pdla_param_desc *d = pdla_param_find(t, n, k);
    if (!d) {
        const char *near = NULL; /* the row it differs from in letter case only */
        for (size_t i = 0; i < n && !near; i++)
            if (scene_same_but_case(k, t[i].option)) near = t[i].option;
        return scene_unknown_key(key, near, " for model dlca", err, errlen);
    }
    c->given |= d->bit;
    return dlca_param_set(&c->p, d, val, err, errlen) ? -1 : 0;
}

/* The scene's keys in its order, read by scene.c (as the other models'
 * scenes); *sc keeps the strings (out, start, resume) until the end. */
static int read_scene(dlca_cli *c, const char *path, scene *sc, char *err, size_t errlen)
{
    if (sc->buf) {
        snprintf(err, errlen, "--scene given twice");
        return -1;
    }
    if (scene_read_file(path, sc, err, errlen)) return -1;
    for (int i = 0; i < sc->n; i++) {
        char why[512];
        if (set_key(c, sc->entries[i].key, sc->entries[i].value, why, sizeof why))
            return pdla_errorf(-1, err, errlen, "%s:%d: %s", path, sc->entries[i].line, why);
    }
    return 0;
}

static int parse(int argc, char **argv, dlca_cli *c, scene *sc, char *err, size_t errlen)
{
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    struct option *lo = calloc(n + 16, sizeof *lo); /* the table, then extra[] */
    if (!lo) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    for (size_t i = 0; i < n; i++) lo[i] = (struct option){t[i].option, required_argument, NULL, OPT_TABLE + (int)i};
    const struct option extra[] = {
        {"model", required_argument, NULL, OPT_MODEL}, {"scene", required_argument, NULL, OPT_SCENE},
        {"out", required_argument, NULL, OPT_OUT},     {"force", no_argument, NULL, OPT_FORCE},
        {"no-output", no_argument, NULL, OPT_NO_OUTPUT}, {"quiet", no_argument, NULL, OPT_QUIET},
        {"help", no_argument, NULL, OPT_HELP},         {"check", no_argument, NULL, OPT_CHECK},
        {"checkpoint", no_argument, NULL, OPT_CKPT},   {"resume", required_argument, NULL, OPT_RESUME},
        {"checkpoint-every", required_argument, NULL, OPT_CKPT_EVERY},
        {"checkpoint-attempts", required_argument, NULL, OPT_CKPT_ATTEMPTS},
        {"start", required_argument, NULL, OPT_START},
        {"snapshot-every", required_argument, NULL, OPT_SNAPSHOT_EVERY},
        {NULL, 0, NULL, 0}};
    _Static_assert(sizeof extra / sizeof extra[0] <= 16, "extra[] outgrew lo");
    memcpy(lo + n, extra, sizeof extra);
    /* Pass 1: the scene (and --help), so that options override its keys. */
    int rc = 0, opt;
    opterr = 0;
    optind = 1;
    /* Long options are never abbreviated (as in the DLA command and the tools). */
    if (optcheck_exact(argc, argv, lo, ":q", err, errlen)) rc = -1;
    while (rc == 0 && (opt = getopt_long(argc, argv, ":q", lo, NULL)) != -1) {
        if (opt == OPT_HELP) rc = 1;
        else if (opt == OPT_SCENE) rc = read_scene(c, optarg, sc, err, errlen);
        else if (opt == '?') {
            snprintf(err, errlen, "unknown option '%s' for --model dlca (see pdla --model dlca --help)", argv[optind - 1]);
            rc = -1;
        } else if (opt == ':') {
            snprintf(err, errlen, "option '%s' needs a value", argv[optind - 1]);
            rc = -1;
        }
    }
    if (rc == 0 && optind < argc) {
        snprintf(err, errlen, "unexpected argument '%s'", argv[optind]);
        rc = -1;
    }
    /* Pass 2: the options in order, each through the scene's keys. */
    optind = 1;
    int li = 0;
    while (rc == 0 && (opt = getopt_long(argc, argv, ":q", lo, &li)) != -1) {
        if (opt == 'q') c->quiet = 1;
        else if (opt != OPT_HELP && opt != OPT_SCENE)
            rc = set_key(c, lo[li].name, lo[li].has_arg ? optarg : "yes", err, errlen);
    }
    free(lo);
    return rc;
}

/* A new run directory, or an existing one with --force. */
static int make_dir(const dlca_cli *c, char *dir, size_t len)
{
    if (c->out) {
        if (c->out != dir) snprintf(dir, len, "%s", c->out);
        for (size_t l = strlen(dir); l > 1 && dir[l - 1] == '/';) dir[--l] = '\0';
    } else {
        char stamp[32];
        const time_t now = time(NULL);
        struct tm tm;
        localtime_r(&now, &tm);
        strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &tm);
        snprintf(dir, len, "runs/dlca-%s-%dd", stamp, c->p.dim);
    }
    const int pe = cli_mkdir_parents(dir);
    if (pe) {
        fprintf(stderr, "pdla: cannot create run directory '%s': %s (making its parents)\n", dir, strerror(pe));
        return EXIT_USAGE;
    }
    if (mkdir(dir, 0777) == 0) return 0;
    if (errno != EEXIST) {
        fprintf(stderr, "pdla: cannot create run directory '%s': %s\n", dir, strerror(errno));
        return EXIT_USAGE;
    }
    struct stat st;
    if (!c->force) {
        fprintf(stderr, "pdla: run directory '%s' already exists (use --force to write into it)\n", dir);
        return EXIT_USAGE;
    }
    if (stat(dir, &st) || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "pdla: '%s' exists and is not a directory\n", dir);
        return EXIT_USAGE;
    }
    return 0;
}

/* fsync of a file or a directory: 0, or -1 with errno (a directory that
 * cannot be synced, EINVAL on some file systems, counts as synced). */
static int sync_path(const char *p, int is_dir)
{
    const int fd = open(p, (is_dir ? O_RDONLY | O_DIRECTORY : O_WRONLY) | O_CLOEXEC);
    if (fd < 0) return -1;
    int r = fsync(fd) == 0 || (is_dir && errno == EINVAL) ? 0 : -1;
    const int saved = errno;
    if (close(fd) != 0 && r == 0) r = -1;
    else errno = saved;
    return r;
}

/* Write what = "cluster" or "checkpoint" as DIR/what.h5 (beside, then
 * renamed, so that a reader never sees half a file). 0; -1 with err when
 * the file is not in place; 1 with err when it is, but its directory did
 * not sync or its sidecar failed (the summary must not say "wrote" for -1). */
static int write_file(const dlca_sim *s, const dlca_cli *c, const char *dir, const char *what, const char *cmd,
                      double wall, char *err, size_t errlen)
{
    char path[4200], tmp[4200];
    snprintf(path, sizeof path, "%s/%s.h5", dir, what);
    snprintf(tmp, sizeof tmp, "%s/.%s.h5.new", dir, what);
    unlink(tmp);
    err[0] = '\0';
    int rc = what[1] == 'l' ? dlca_write_h5(s, tmp, cmd, wall, err, errlen)
                            : dlca_checkpoint_write(s, tmp, err, errlen);
    if (rc == 0 && c->snapshot_every > 0) /* the checkpoint too: a resumed run keeps them */
        rc = dlca_write_snapshots_h5(tmp, dlca_get_params(s), c->snaps, c->nsnaps, c->n_monomers, c->snapshot_every, c->snaps_stopped,
                                     err, errlen);
    /* Synced before the rename and the directory after it: without, a
     * machine crash could leave checkpoint.h5 empty with the previous one
     * already replaced (the file was never fsync'ed before session 11). */
    if (rc == 0 && sync_path(tmp, 0) != 0) {
        snprintf(err, errlen, "cannot sync %.900s: %s", tmp, strerror(errno));
        rc = -1;
    }
    if (rc || rename(tmp, path)) {
        if (!err[0]) snprintf(err, errlen, "cannot rename %.900s: %s", tmp, strerror(errno));
        unlink(tmp);
        return -1;
    }
    const int unsynced = sync_path(dir, 1) != 0;
    if (unsynced) snprintf(err, errlen, "wrote %.900s, but cannot sync its directory: %s", path, strerror(errno));
    /* ParaView's sidecar, for the file under its final name; also when the
     * directory did not sync: before, the older run's stayed beside the new
     * cluster.h5, describing another number of monomers */
    if (what[1] == 'l') {
        dlca_stats st;
        dlca_get_stats(s, &st);
        char xerr[1024];
        if (dlca_write_xdmf(path, dlca_get_params(s)->dim, st.n_monomers, c->snaps, c->nsnaps, st.t, xerr,
                            sizeof xerr) &&
            !unsynced) {
            snprintf(err, errlen, "%s", xerr);
            return 1;
        }
    }
    return unsynced ? 1 : 0;
}

enum { ASKED_NONE = 0, ASKED_SIGNAL, ASKED_FILE, ASKED_CKFAIL };

/* The run loop: chunks of attempts between which the signal flag, the
 * checkpoint triggers and RUN_DIR/STOP are looked at. Returns the stop
 * reason; *asked says whether a signal or the STOP file ended it. */
/* A snapshot of the state now (sites and cluster numbers); -1 on no memory. */
static int take_snapshot(const dlca_sim *s, dlca_cli *c)
{
    /* Held until the file is written: a budget of a quarter of the
     * machine's memory (the run itself may take half, dlca_params_validate) */
    if (!dlca_snapshots_fit(c->nsnaps + 1, c->n_monomers)) return -1;
    dlca_snapshot *sn = realloc(c->snaps, (c->nsnaps + 1) * sizeof *sn);
    if (!sn) return -1;
    c->snaps = sn;
    sn += c->nsnaps;
    sn->site = malloc(c->n_monomers * sizeof *sn->site);
    sn->cluster = malloc(c->n_monomers * sizeof *sn->cluster);
    if (!sn->site || !sn->cluster) {
        free(sn->site), free(sn->cluster);
        return -1;
    }
    dlca_export_sites(s, sn->site, sn->cluster);
    sn->t = dlca_time(s);
    sn->attempts = dlca_attempts(s);
    sn->n_clusters = 0;
    for (uint64_t i = 0; i < c->n_monomers; i++)
        if (sn->cluster[i] + 1 > sn->n_clusters) sn->n_clusters = sn->cluster[i] + 1;
    c->nsnaps++;
    return 0;
}

static void free_snapshots(dlca_cli *c)
{
    for (size_t i = 0; i < c->nsnaps; i++) free(c->snaps[i].site), free(c->snaps[i].cluster);
    free(c->snaps);
    c->snaps = NULL;
    c->nsnaps = 0;
}

/* Is it time for a snapshot (the first attempt at or after the next
 * multiple of T)? Then take it; *next becomes the multiple after now. */
static int snapshot_due(const dlca_sim *s, dlca_cli *c, double *next)
{
    if (!(*next > 0) || dlca_time(s) < *next) return 0;
    *next = dlca_next_snapshot(dlca_time(s), c->snapshot_every);
    if (take_snapshot(s, c) == 0) return 0;
    /* Once, and no more snapshots: before, the line was printed on every
     * pass of the loop (13 million lines in a minute). The run goes on; its
     * exit status and its line at the end say so. */
    char msg[200];
    snprintf(msg, sizeof msg, "no memory for more snapshots at t = %g (%zu taken, %.3g GiB); none taken after it",
             dlca_time(s), c->nsnaps, (double)c->nsnaps * 8.0 * (double)c->n_monomers / 1073741824.0);
    cli_fail_note(&c->fail, "snapshots", "%s", msg);
    c->snaps_stopped = 1;
    *next = 0;
    return -1;
}

/* The run loop: chunks of attempts between which the signal flag, the
 * checkpoint triggers, snapshots and RUN_DIR/STOP are looked at. Returns
 * the stop reason; *asked says whether a signal or the STOP file ended it. */
static int run_loop(dlca_sim *s, dlca_cli *c, const char *dir, const char *cmd, int *asked, int *ck_failed)
{
    uint64_t att = dlca_attempts(s), next_att = 0;
    const uint64_t every = c->checkpoint_attempts;
    if (every) next_att = (att / every + 1) * every;
    double last_look = pdla_clock_seconds();
    double next_time = c->checkpoint_every > 0 ? last_look + c->checkpoint_every : 0;
    double next_snap = c->snapshot_every > 0 && !c->snaps_stopped ? dlca_next_snapshot(dlca_time(s), c->snapshot_every) : 0;
    char stop_path[4200], err[1024];
    snprintf(stop_path, sizeof stop_path, "%s/STOP", dir);
    *asked = ASKED_NONE;
    for (;;) {
        uint64_t chunk = 1u << 16; /* a signal waits at most a chunk: milliseconds */
        if (next_att && next_att - att < chunk) chunk = next_att - att;
        const int stop = dlca_run_to(s, chunk, next_snap);
        if (snapshot_due(s, c, &next_snap)) (*ck_failed)++;
        if (stop != DLCA_RUNNING) return stop;
        att = dlca_attempts(s);
        if (stop_signal) {
            *asked = ASKED_SIGNAL;
            return stop;
        }
        if (!c->checkpoint) continue;
        const double now = pdla_clock_seconds();
        if ((next_att && att >= next_att) || (next_time > 0 && now >= next_time)) {
            if (write_file(s, c, dir, "checkpoint", cmd, 0, err, sizeof err)) {
                /* The run stops, as the event model's: it would go on
                 * without its safety net (a full disk: for days). cluster.h5
                 * and a checkpoint of here are still tried. */
                char msg[1100];
                snprintf(msg, sizeof msg, "checkpoint failed after %llu attempts, the run stopped there: %s",
                         (unsigned long long)att, err);
                cli_fail_note(&c->fail, "a checkpoint", "%s", msg);
                (*ck_failed)++;
                *asked = ASKED_CKFAIL;
                return stop;
            }
            if (every) next_att = (att / every + 1) * every;
            if (next_time > 0) next_time = pdla_clock_seconds() + c->checkpoint_every;
        }
        if (now - last_look >= 0.1) { /* a stat() at most ten times a second */
            last_look = now;
            struct stat sb;
            if (stat(stop_path, &sb) == 0 && !S_ISDIR(sb.st_mode)) {
                *asked = ASKED_FILE;
                return stop;
            }
        }
    }
}

/* Parse and check the command line: -1 to go on, else the exit status
 * (0 after --help, EXIT_USAGE with the one line printed). */
static int read_command(int argc, char **argv, dlca_cli *c, scene *sc)
{
    char err[1024];
    memset(c, 0, sizeof *c);
    c->lock = c->lock_out = -1;
    dlca_params_default(&c->p);
    int prc = parse(argc, argv, c, sc, err, sizeof err);
    if (prc == 1) {
        print_help(stdout);
        return fflush(stdout) ? EXIT_RUNTIME : 0;
    }
    if (prc == 0 && c->resume && c->start) {
        snprintf(err, sizeof err, "--start and --resume exclude each other (a resumed run starts from its checkpoint)");
        prc = -1;
    }
    /* before anything is made: make_dir created the parents of an --out
     * too long for its buffer, then failed on the cut name */
    if (prc == 0 && ((c->out && cli_path_fits("the run directory name", c->out, err, sizeof err)) ||
                     (c->resume && cli_path_fits("the checkpoint path", c->resume, err, sizeof err))))
        prc = -1;
    if (prc == 0 && c->resume) c->checkpoint = 1; /* as in the DLA command: a resumed run goes on checkpointing */
    /* Resumed, the run's parameters are the checkpoint's, not the
     * defaults: the options given are held against them, and the result
     * checked, after the load (resume_sim). Checked here, --box 16x16x16
     * was held against the default dimension 2, and --until-clusters 40
     * against the default fill's 31 monomers of that box. */
    if (prc == 0 && c->resume) c->box_lengths = c->p.box_lengths;
    if (prc == 0 && c->no_output && c->checkpoint) {
        snprintf(err, sizeof err, "checkpoints need a run directory: --no-output excludes them");
        prc = -1;
    }
    /* With --start the file gives the monomers: --fill and --count are not
     * used, and a box under 50 sites was refused for the default fill's 0
     * monomers (the file's own count is checked when it is read). */
    if (prc || (!c->resume && (c->start ? dlca_params_validate_start(&c->p, err, sizeof err)
                                           : dlca_params_validate(&c->p, err, sizeof err)))) {
        fprintf(stderr, "pdla: %s\n", err);
        return EXIT_USAGE;
    }
    return -1;
}

/* From here a signal is caught: one during set-up stops the run after its
 * first chunk, with the output written. */
static void catch_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND | SA_RESTART; /* a second signal ends pdla at once */
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

/* A checkpoint written before session 27 (no schedule attributes) did not
 * record that its run had run out of memory for snapshots: its snapshots
 * may end early. When that alone fails the check, take it as stopped, as
 * such a run had taken none after (the resume says so): else a week-long
 * run could not go on after an upgrade. 1 when they pass so. */
static int old_stopped_pass(const dlca_sim *s, const dlca_snapshot *snaps, size_t n, double every, int stopped)
{
    dlca_ckpt_schedule sc;
    char why[512];
    return !stopped && !dlca_checkpoint_schedule(s, &sc) &&
           !dlca_snapshots_check(s, snaps, n, every, 1, why, sizeof why);
}

/* old_stopped_pass for the snapshots read into c; 1 when taken so. */
static int old_snapshots_stopped(dlca_cli *c, const dlca_sim *s, double every)
{
    if (!old_stopped_pass(s, c->snaps, c->nsnaps, every, c->snaps_stopped)) return 0;
    c->snaps_stopped = 1;
    return 1;
}

/* The snapshots taken before the checkpoint and its period, which
 * --snapshot-every given again must equal. 0, or -1 with the line printed. */
static int resume_snapshots(dlca_cli *c, const dlca_sim *s, const char *ckpath, uint64_t n_monomers)
{
    char err[1024];
    double every = 0;
    if (dlca_read_snapshots_h5(ckpath, n_monomers, dlca_time(s), &c->snaps, &c->nsnaps, &every, &c->snaps_stopped,
                               err, sizeof err)) {
        fprintf(stderr, "pdla: %s\n", err);
        return -1;
    }
    if (dlca_snapshots_check(s, c->snaps, c->nsnaps, every, c->snaps_stopped, err, sizeof err) &&
        !old_snapshots_stopped(c, s, every)) {
        fprintf(stderr, "pdla: cannot resume from %s: %s\n", ckpath, err);
        return -1;
    }
    if (c->snaps_stopped) { /* the line at the end says so again */
        char msg[200];
        snprintf(msg, sizeof msg, "the run before this resume ran out of memory for snapshots after t = %g (%zu "
                 "taken); none taken after it", c->nsnaps ? c->snaps[c->nsnaps - 1].t : 0.0, c->nsnaps);
        cli_fail_note(&c->fail, "snapshots", "%s", msg);
    }
    if (!(c->snapshot_every > 0)) {
        c->snapshot_every = every;
    } else if (c->snapshot_every != every) {
        /* the period is the checkpoint's, as every option but the stops:
         * a new one was taken without a word, and /snapshots said `every`
         * of snapshots taken at the old one */
        fprintf(stderr, "pdla: cannot resume with a different --snapshot-every: %.17g in the checkpoint, %.17g asked\n",
                every, c->snapshot_every);
        return -1;
    }
    return 0;
}

/* Is dir the directory open as fd (the lock a resume took)? A second flock
 * on it from this process would conflict with the first. */
static int same_dir(int fd, const char *dir)
{
    struct stat a, b;
    return fd >= 0 && fstat(fd, &a) == 0 && stat(dir, &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

/* A resume without --checkpoint-every and --checkpoint-attempts keeps the
 * interrupted run's schedule, as the DLA command (session 26): a bare
 * `--resume DIR` after --checkpoint-every 30m wrote only its final
 * checkpoint, so a crash after the resume lost all it had grown. Either
 * option given replaces both (--checkpoint-every 0: no time trigger). */
static void keep_schedule(dlca_cli *c, const dlca_sim *s)
{
    dlca_ckpt_schedule sc;
    if (c->schedule_given || !dlca_checkpoint_schedule(s, &sc)) return;
    c->checkpoint_every = sc.every_seconds;
    c->checkpoint_attempts = sc.every_attempts;
}

/* A stop given with --resume that the checkpoint has already passed is
 * refused, as the DLA command refuses a --target below the particles held:
 * before, the run stopped at once with exit 0 and its cluster.h5 recorded
 * max-attempts 100 beside 20000 attempts. A stop at or beyond the one the
 * checkpoint recorded (rec) is taken even where the state went past it:
 * the time and the cluster count overshoot their stops (the stopping
 * attempt adds a whole step; one attempt may join several clusters), and
 * the attempt before lay short of rec, so also short of the value given;
 * the state is then where a run to that value stops. A finished run resumed
 * with its own --until-time stops at once, as before. 0, or -1 with the
 * reason. */
static int stop_passed(const dlca_cli *c, const dlca_params *p, const dlca_params *rec, const dlca_stats *st,
                       char *err, size_t errlen)
{
    if ((c->given & DLCA_PARAM_UNTIL_TIME) && p->until_time > 0 && p->until_time < st->t &&
        !(rec->until_time > 0 && p->until_time >= rec->until_time))
        return snprintf(err, errlen, "--until-time %.17g is below the time %.17g it has reached", p->until_time,
                        st->t), -1;
    if ((c->given & DLCA_PARAM_MAX_ATTEMPTS) && p->max_attempts > 0 && p->max_attempts < st->attempts &&
        !(rec->max_attempts > 0 && p->max_attempts >= rec->max_attempts))
        return snprintf(err, errlen, "--max-attempts %" PRIu64 " is below the %" PRIu64 " attempts it has made",
                        p->max_attempts, st->attempts), -1;
    if ((c->given & DLCA_PARAM_UNTIL_CLUSTERS) && p->until_clusters > st->n_clusters &&
        p->until_clusters > rec->until_clusters)
        return snprintf(err, errlen, "--until-clusters %" PRIu64 " is above the %" PRIu64 " clusters it has left",
                        (uint64_t)p->until_clusters, st->n_clusters), -1;
    return 0;
}

/* ---- --resume FILE: the checkpoint.h5 its writes would replace ---- */

/* Checkpoint path loaded as a resume of its directory loads it (the state
 * with every check, then its snapshots), and freed: 0 with *st, or the
 * error (PDLA_ENOMEM: could not tell) with why, one line without the
 * "cannot resume from PATH: " of the loaders. */
static int ahead_loads(const char *path, dlca_stats *st, char *why, size_t whylen)
{
    dlca_sim *s = NULL;
    char err[1024], head[4400];
    int rc = dlca_checkpoint_load(&s, path, err, sizeof err);
    if (!rc) {
        dlca_get_stats(s, st);
        dlca_snapshot *snaps = NULL;
        size_t n = 0;
        double every = 0;
        int stopped = 0;
        rc = dlca_read_snapshots_h5(path, st->n_monomers, dlca_time(s), &snaps, &n, &every, &stopped, err,
                                    sizeof err);
        if (!rc) rc = dlca_snapshots_check(s, snaps, n, every, stopped, err, sizeof err);
        if (rc && rc != PDLA_ENOMEM && snaps && old_stopped_pass(s, snaps, n, every, stopped)) rc = 0;
        for (size_t i = 0; i < n && snaps; i++) free(snaps[i].site), free(snaps[i].cluster);
        free(snaps);
        dlca_destroy(s);
    }
    snprintf(head, sizeof head, "cannot resume from %s: ", path);
    if (rc) snprintf(why, whylen, "%s", strncmp(err, head, strlen(head)) ? err : err + strlen(head));
    return rc;
}

/* --resume FILE whose checkpoints go to FILE's folder dir (no --out
 * elsewhere): before FILE is loaded, dir/checkpoint.h5, which the first
 * write replaces, unless it is FILE (the normal resume), is loaded as
 * `--resume dir` would load it, and freed. Absent is fine; damaged sets
 * c->ahead_bad (why in c->ahead_why), to go aside once nothing can refuse
 * the resume (set_aside_ahead); a valid one, or another model's file,
 * refuses the resume, exit 2, one line, nothing touched (the DLA and event
 * rule). Until session 31 the first write replaced it silently: a
 * 5000-attempt checkpoint.h5 by the 3000 attempts of a copy D/save.h5
 * resumed in D. 0, or the exit status with the line printed. */
static int named_ahead(dlca_cli *c, const char *file, const char *dir)
{
    char name[4300], what[1200];
    struct stat sf, sn;
    c->ahead_bad = 0;
    snprintf(name, sizeof name, "%s/checkpoint.h5", dir);
    if (stat(file, &sf) != 0 || !S_ISREG(sf.st_mode)) return 0; /* the load says why */
    if (lstat(name, &sn) != 0) {
        if (errno == ENOENT) return 0;
        fprintf(stderr, "pdla: cannot resume: cannot look at %s: %s\n", name, strerror(errno));
        return EXIT_RUNTIME;
    }
    if (stat(name, &sn) == 0 && sn.st_dev == sf.st_dev && sn.st_ino == sf.st_ino) return 0; /* FILE itself */
    dlca_stats st;
    const int rc = ahead_loads(name, &st, c->ahead_why, sizeof c->ahead_why);
    if (rc == PDLA_ENOMEM) {
        fprintf(stderr, "pdla: cannot resume: %s: %s\n", name, c->ahead_why);
        return EXIT_RUNTIME;
    }
    char way[4400] = "";
    if (rc == 0) {
        snprintf(what, sizeof what, "a valid checkpoint (%" PRIu64 " attempts, t = %.6g, %" PRIu64 " clusters)",
                 st.attempts, st.t, st.n_clusters);
        snprintf(way, sizeof way, "resume it with --resume %s, or ", dir);
    } else if (!cli_foreign_checkpoint(name, "dlca-checkpoint", what, sizeof what)) {
        c->ahead_bad = 1;
        return 0;
    }
    fprintf(stderr, "pdla: cannot resume: %s: %s is %s that the checkpoints of this resume would replace; "
            "%smove %s out of %s to go on from %s\n", file, name, what, way, name, dir, file);
    return EXIT_USAGE;
}

/* The damaged checkpoint.h5 named_ahead found goes aside, kept
 * (pdla_rundir_set_aside, as the DLA and event fallbacks), the directory
 * synced, before the first write could replace it. 0, or 1 with the line
 * printed. */
static int set_aside_ahead(const dlca_cli *c, const char *dir)
{
    char name[4200], kept[4200], err[4600];
    snprintf(name, sizeof name, "%s/checkpoint.h5", dir);
    fprintf(stderr, "pdla: note: skipped %s: damaged checkpoint (%s); resuming from %s\n", name, c->ahead_why,
            c->resume);
    if (pdla_rundir_set_aside(dir, name, kept, sizeof kept, err, sizeof err) != PDLA_OK) {
        fprintf(stderr, "pdla: cannot resume: %s\n", err);
        return EXIT_RUNTIME;
    }
    if (kept[0]) fprintf(stderr, "pdla: note: %s set aside as %s\n", name, kept);
    if (pdla_rundir_fsync(dir) != 0) {
        fprintf(stderr, "pdla: cannot resume: cannot sync directory %s: %s\n", dir, strerror(errno));
        return EXIT_RUNTIME;
    }
    return 0;
}

/* The checkpoint --resume names (a run directory stands for its
 * checkpoint.h5) into ckpath, its directory locked, then loaded into *s;
 * a file resumed in its own folder after that folder's checkpoint.h5 is
 * looked at (named_ahead). 0, or the exit status with the line printed. */
static int lock_and_load(dlca_cli *c, char *ckpath, size_t cklen, dlca_sim **s)
{
    char err[1024];
    struct stat sb;
    if (stat(c->resume, &sb) != 0) { /* as the DLA command; before: "cannot open it as HDF5" */
        fprintf(stderr, "pdla: cannot resume from '%s': %s\n", c->resume, strerror(errno));
        return EXIT_USAGE;
    }
    /* a killed run's temporary file: the sweep under the lock removed it
     * once it was loaded (as the event command, which lost it unread) */
    if (!S_ISDIR(sb.st_mode) && cli_refuse_temp_resume(c->resume)) return EXIT_USAGE;
    if (S_ISDIR(sb.st_mode)) snprintf(ckpath, cklen, "%s/checkpoint.h5", c->resume);
    else snprintf(ckpath, cklen, "%s", c->resume);
    /* The checkpoint's directory is locked before it is read: the run
     * writing it may still be going (then this one is refused). Any other
     * failure (ENOLCK, a directory that cannot be opened) is refused too:
     * before, the checkpoint was read unlocked and the run refused later
     * with "already exists (use --force ...)", which named no lock. */
    char ckdir[4200];
    snprintf(ckdir, sizeof ckdir, "%s", ckpath);
    char *slash = strrchr(ckdir, '/');
    if (slash) *slash = '\0';
    const char *folder = slash ? (ckdir[0] ? ckdir : "/") : ".";
    if (pdla_rundir_lock(folder, &c->lock, err, sizeof err) != PDLA_OK) {
        fprintf(stderr, "pdla: cannot resume: %s\n", err);
        return EXIT_USAGE;
    }
    /* a link to a temporary name: loaded through, then the sweep of the
     * run directory removed the file it names (rundir.h). Only when the
     * folder is the run directory swept: with --out elsewhere (--force)
     * the sweep is that directory's, and the folder is left as it is */
    if ((!c->out || same_dir(c->lock, c->out)) && cli_refuse_temp_links(c->out ? c->out : folder)) return EXIT_USAGE;
    /* a file resumed in its own folder (--out elsewhere needs --force,
     * which replaces that directory's run): the checkpoint.h5 there first */
    if (!S_ISDIR(sb.st_mode) && (!c->out || same_dir(c->lock, c->out))) {
        const int arc = named_ahead(c, ckpath, folder);
        if (arc) return arc;
    }
    const int lrc = dlca_checkpoint_load(s, ckpath, err, sizeof err);
    if (lrc) {
        fprintf(stderr, "pdla: %s\n", err);
        return lrc == PDLA_ENOMEM ? EXIT_RUNTIME : EXIT_USAGE;
    }
    return 0;
}

/* --resume: load the checkpoint, hold the options given against it (the
 * table's resume rule: only the resumable rows, the stops, may change) and
 * apply the stops given. 0, or the exit status with the line printed. */
static int resume_sim(dlca_cli *c, char *dir, size_t dirlen, dlca_sim **s)
{
    char ckpath[4200], err[1024];
    const int lrc = lock_and_load(c, ckpath, sizeof ckpath, s);
    if (lrc) return lrc;
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    dlca_params p = *dlca_get_params(*s);
    dlca_stats st;
    dlca_get_stats(*s, &st);
    /* --count N with the run's own N is not a change, nor is --count 0 when
     * the run took its N from --fill (the checkpoint stores 0 then). */
    if (!p.count && c->p.count) p.count = st.n_monomers;
    const int box_bad = c->box_lengths > 1 && c->box_lengths != p.dim;
    if (box_bad)
        snprintf(err, sizeof err, "--box gives %d lengths but the checkpoint is %dD", c->box_lengths, p.dim);
    if (box_bad || pdla_param_check_asked(t, n, c->given, &p, &c->p, err, sizeof err)) {
        fprintf(stderr, "pdla: %s: %s\n", ckpath, err);
        dlca_destroy(*s);
        *s = NULL;
        return EXIT_USAGE;
    }
    if (resume_snapshots(c, *s, ckpath, st.n_monomers)) {
        dlca_destroy(*s);
        *s = NULL;
        return EXIT_USAGE; /* the snapshots are freed at the end, as after a failed read */
    }
    /* The stops not given stay the checkpoint's: a resumed run ends where
     * the interrupted one would have. */
    pdla_param_apply_resumable(t, n, c->given, &p, &c->p);
    if (dlca_params_validate(&p, err, sizeof err)) { /* the stops given, on the checkpoint's run */
        fprintf(stderr, "pdla: %s\n", err);
        dlca_destroy(*s);
        *s = NULL;
        return EXIT_USAGE;
    }
    if (stop_passed(c, &p, dlca_get_params(*s), &st, err, sizeof err)) {
        fprintf(stderr, "pdla: cannot resume: %s: %s\n", ckpath, err);
        dlca_destroy(*s);
        *s = NULL;
        return EXIT_USAGE;
    }
    (void)dlca_set_stops(*s, p.until_clusters, p.until_time, p.max_attempts);
    c->p = p;
    keep_schedule(c, *s);
    if (!c->out) {
        /* Whole, then cut at its last '/': a copy cut to 4000 bytes first
         * named the parent of a long run directory (its checkpoint path is
         * up to CLI_RUN_DIR_MAX + 14 bytes, which dir holds). */
        const int w = snprintf(dir, dirlen, "%s", ckpath);
        if (w < 0 || (size_t)w >= dirlen) { /* not with --resume of at most CLI_RUN_DIR_MAX bytes */
            fprintf(stderr, "pdla: the checkpoint path is too long (%zu bytes)\n", strlen(ckpath));
            dlca_destroy(*s);
            *s = NULL;
            return EXIT_USAGE;
        }
        char *sl = strrchr(dir, '/');
        if (sl) *sl = '\0';
        else snprintf(dir, dirlen, ".");
        c->out = dir;
    }
    /* Its own run directory is written over; another one given by --out
     * only with --force, as for a new run (it was written over silently,
     * another run's checkpoint with it). */
    if (same_dir(c->lock, c->out)) c->force = 1;
    return 0;
}

/* A new simulation: at random, or from the --start file. */
static int new_sim(const dlca_cli *c, dlca_sim **s, char *err, size_t errlen)
{
    if (!c->start) return dlca_create(s, &c->p, err, errlen);
    uint32_t *sites;
    uint64_t n;
    const int rc = dlca_read_start(c->start, &c->p, &sites, &n, err, errlen);
    if (rc) return rc;
    const int crc = dlca_create_sites(s, &c->p, sites, n, err, errlen);
    free(sites);
    return crc;
}

/* The simulation to run (resumed or new) and its run directory: 0, or the
 * exit status with the line printed. */
static int open_sim(dlca_cli *c, char *dir, size_t dirlen, dlca_sim **s)
{
    *s = NULL;
    char err[1024];
    if (c->resume) {
        const int rrc = resume_sim(c, dir, dirlen, s);
        if (rrc) return rrc;
    } else {
        const int rc = new_sim(c, s, err, sizeof err); /* before the directory: a bad start file makes none */
        if (rc) {
            fprintf(stderr, "pdla: %s\n", err);
            return rc == PDLA_EINVAL ? EXIT_USAGE : EXIT_RUNTIME;
        }
    }
    if (!c->no_output) {
        /* One writer per run directory (as the DLA command): two runs on
         * one directory wrote over each other's temporary files and left a
         * 179-byte checkpoint.h5 that the survivor named for --resume. */
        int drc = make_dir(c, dir, dirlen);
        if (!drc && !same_dir(c->lock, dir) && pdla_rundir_lock(dir, &c->lock_out, err, sizeof err) != PDLA_OK) {
            fprintf(stderr, "pdla: %s\n", err);
            drc = EXIT_USAGE;
        }
        /* --out X/.checkpoint.h5.new (or X/checkpoint.h5) with that a link
         * to X, a new run with --force or a resume into --out elsewhere:
         * the sweep or the older run's removal below took the link under
         * the run (rundir.h). A resume in its own folder removes no older
         * run, and its temporary names were checked before the load. */
        if (!drc && (!c->resume || !same_dir(c->lock, dir)) && cli_refuse_temp_out(dir)) drc = EXIT_USAGE;
        /* seen before the run (chattr +i, a read-only mount): before, the
         * whole run went by and then cluster.h5 and the checkpoint failed */
        const int pe = drc ? 0 : pdla_rundir_probe(dir);
        if (pe) {
            fprintf(stderr, "pdla: run directory '%s' takes no files: %s\n", dir, strerror(pe));
            drc = EXIT_USAGE;
        }
        if (!drc) {
            /* Under the lock, what a pdla killed while it wrote here left:
             * cluster.xdmf2.tmp.PID stayed for good (kill -9 during the
             * sidecar); the .new names are taken again, but not at once. */
            cli_remove_temp(dir);
        }
        if (!drc && c->resume && c->ahead_bad && same_dir(c->lock, dir)) drc = set_aside_ahead(c, dir);
        if (!drc && (!c->resume || !same_dir(c->lock, dir))) {
            /* A new run (--force) replaces an older run's checkpoint: a
             * later --resume would otherwise grow the old run and write it
             * over this run's cluster.h5. So does a resume written into
             * another directory (--resume CK --out DIR --force): a DLA
             * run's checkpoints there outlived it, and a DLA --resume of
             * DIR then grew that run over the DLCA cluster.h5. */
            if (pdla_rundir_remove_old_run(dir, 0, err, sizeof err) != PDLA_OK) {
                fprintf(stderr, "pdla: %s\n", err);
                drc = EXIT_RUNTIME;
            }
        }
        if (drc) {
            dlca_destroy(*s);
            *s = NULL;
            return drc;
        }
    }
    dlca_stats st;
    dlca_get_stats(*s, &st);
    c->n_monomers = st.n_monomers;
    /* recorded in each checkpoint, for a later bare --resume */
    const dlca_ckpt_schedule sched = {c->checkpoint_every, c->checkpoint_attempts};
    dlca_set_checkpoint_schedule(*s, &sched);
    if (c->checkpoint) {
        char stop_path[4200]; /* honoured before: a resume must not stop at once */
        snprintf(stop_path, sizeof stop_path, "%s/STOP", dir);
        unlink(stop_path);
    }
    return 0;
}

/* After the run: the check, cluster.h5 and the final checkpoint. Returns
 * the exit status so far; *final_ck says whether a checkpoint was written,
 * *wrote whether cluster.h5 is in place. */
static int finish_files(const dlca_sim *s, dlca_cli *c, const char *dir, const char *cmd, double wall,
                        int status, int *final_ck, int *wrote)
{
    char err[1024];
    *final_ck = 0;
    *wrote = 0;
    if (c->check && dlca_check(s, err, sizeof err)) {
        cli_fail_note(&c->fail, "the check", "check failed: %s", err);
        status = EXIT_RUNTIME;
    }
    if (c->no_output) return status;
    const int wrc = write_file(s, c, dir, "cluster", cmd, wall, err, sizeof err);
    *wrote = wrc >= 0;
    if (wrc) {
        cli_fail_note(&c->fail, "cluster.h5", "%s", err);
        status = EXIT_RUNTIME;
    }
    if (c->checkpoint) {
        if (write_file(s, c, dir, "checkpoint", cmd, 0, err, sizeof err)) {
            cli_fail_note(&c->fail, "the final checkpoint", "checkpoint failed: %s", err);
            status = EXIT_RUNTIME;
        } else *final_ck = 1;
    }
    return status;
}

static void print_summary(const dlca_sim *s, const dlca_params *p, const char *dir, int stop, int asked,
                          double wall, int wrote)
{
    dlca_stats st;
    dlca_get_stats(s, &st);
    char box[64];
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    pdla_param_format(pdla_param_find(t, n, "box"), p, 0, box, sizeof box);
    printf("model dlca, d = %d, box %s, N = %llu, search %s\n", p->dim, box, (unsigned long long)st.n_monomers,
           dlca_search_name(p->search));
    printf("stop: %s; t = %.6g; clusters %llu; largest %llu; weight-average size %.4g\n",
           asked == ASKED_SIGNAL   ? "signal"
           : asked == ASKED_FILE   ? "STOP file"
           : asked == ASKED_CKFAIL ? "a checkpoint failed"
                                   : dlca_stop_name(stop),
           st.t,
           (unsigned long long)st.n_clusters, (unsigned long long)st.largest, st.sum_s2 / (double)st.n_monomers);
    printf("attempts %llu, moves %llu, monomer moves %llu, joins %llu\n", (unsigned long long)st.attempts,
           (unsigned long long)st.moves, (unsigned long long)st.monomer_moves, (unsigned long long)st.merges);
    printf("time %.3f s: %.1f ns/attempt, %.2f ns/monomer-move; model memory %.1f bytes/monomer\n", wall,
           st.attempts ? 1e9 * wall / (double)st.attempts : 0.0,
           st.monomer_moves ? 1e9 * wall / (double)st.monomer_moves : 0.0, (double)st.bytes / (double)st.n_monomers);
    if (dir[0] && wrote) printf("wrote %s/cluster.h5\n", dir);
    fflush(stdout);
}

/* The exit, with the run's one line on stderr (a failure, a stop asked
 * for, or both): a stop asked for with checkpoints on is a clean exit (as
 * the DLA command); a signal without ends pdla by that signal, but only one
 * that stopped the run (asked): one caught during the final writes
 * interrupted nothing, and the summary already said the run finished. */
static int exit_status(const dlca_cli *c, int status, int asked, int final_ck, uint64_t attempts, const char *dir)
{
    char also[128] = "";
    if (c->fail.also[0]) snprintf(also, sizeof also, "; also failed: %s", c->fail.also);
    if ((asked == ASKED_SIGNAL || asked == ASKED_FILE) && final_ck) {
        fprintf(stderr, "pdla: stopped by %s after %llu attempts; checkpoint %s/checkpoint.h5 (resume with "
                        "pdla --model dlca --resume %s)%s%s%s\n",
                asked == ASKED_SIGNAL ? "signal" : "RUN_DIR/STOP", (unsigned long long)attempts, dir, dir,
                c->fail.why[0] ? "; " : "", c->fail.why, also);
        if (asked == ASKED_FILE) {
            char stop_path[4200];
            snprintf(stop_path, sizeof stop_path, "%s/STOP", dir);
            unlink(stop_path); /* honoured */
        }
        return status;
    }
    if (c->fail.why[0]) fprintf(stderr, "pdla: %s%s\n", c->fail.why, also);
    else if (stop_signal && asked != ASKED_SIGNAL) /* during the final writes: said, as the DLA command does */
        fprintf(stderr, "pdla: signal received after the run had finished; output complete\n");
    if (stop_signal && asked == ASKED_SIGNAL) {
        signal((int)stop_signal, SIG_DFL);
        raise((int)stop_signal);
    }
    return status;
}

/* The command after parsing; cmd, the command line as typed (taken before
 * getopt permutes argv), for the files' provenance. */
static int dlca_command(int argc, char **argv, const char *cmd)
{
    dlca_cli c;
    scene sc = {0};
    char dir[4096] = "";
    const int rc = read_command(argc, argv, &c, &sc);
    dlca_sim *s = NULL;
    if (rc >= 0) {
        scene_free(&sc);
        return rc;
    }
    catch_signals();
    const int orc = open_sim(&c, dir, sizeof dir, &s);
    if (orc) {
        scene_free(&sc);
        free_snapshots(&c); /* a resume reads them before its last checks */
        return orc;
    }
    const double t0 = pdla_clock_seconds();
    int asked = ASKED_NONE, ck_failed = 0, final_ck = 0, wrote = 0;
    const int stop = run_loop(s, &c, dir, cmd, &asked, &ck_failed);
    const double wall = pdla_clock_seconds() - t0;
    const int status = finish_files(s, &c, dir, cmd, wall, ck_failed ? EXIT_RUNTIME : 0, &final_ck, &wrote);
    if (!c.quiet) print_summary(s, &c.p, dir, stop, asked, wall, wrote);
    dlca_stats st;
    dlca_get_stats(s, &st);
    dlca_destroy(s);
    scene_free(&sc);
    free_snapshots(&c);
    pdla_rundir_unlock(c.lock_out);
    pdla_rundir_unlock(c.lock);
    return exit_status(&c, status, asked, final_ck, st.attempts, dir);
}

int dlca_cmd_main(int argc, char **argv)
{
    char *const cmd = cli_command_line(NULL, argc, argv);
    if (!cmd) {
        fprintf(stderr, "pdla: out of memory\n");
        return EXIT_RUNTIME;
    }
    const int rc = dlca_command(argc, argv, cmd);
    free(cmd);
    return rc;
}
