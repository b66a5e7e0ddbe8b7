/*
 * main.c - `pdla`, the command-line client of libpdla: parse the options
 * (parse.c), make the run directory, grow the cluster with progress on
 * stderr (progress.c), write RUN_DIR/cluster.h5 and RUN_DIR/summary.txt and
 * print the summary on stdout.
 *
 * Exit status: 0 done; 1 runtime failure (growth or a write failed; what was
 * grown is still written when it can be); 2 bad usage or input, including a
 * run directory that exists or cannot be made, detected before any growth.
 * SIGINT/SIGTERM stop the growth at the next progress callback; the partial
 * cluster is written, then pdla ends by the same signal so that shells and
 * loops see an interrupted command (status 130/143). A signal that arrives
 * after the growth had finished (while cluster.h5 is written) interrupted
 * nothing: the run reports success (with a note on stderr) and the exit
 * status is that of the writes, 0 or 1 - never success on stdout and 143.
 */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <hdf5.h>

#include "cmdline.h"
#include "dlca_cmd.h"
#include "ens_cmd.h"
#include "parse.h"
#include "pdla/pdla.h"
#include "progress.h"
#include "rundir.h"
#include "h5read.h"
#include "tools.h"
#include "event_cmd.h"
#include "pdla/xdmf.h"

enum { EXIT_RUNTIME = 1, EXIT_USAGE = 2 };

/* The one piece of global state: the signal that asked us to stop. */
static volatile sig_atomic_t stop_signal;

static void on_signal(int sig) { stop_signal = sig; }

/* Catch SIGINT/SIGTERM once (SA_RESETHAND: a second one ends pdla at once).
 * A signal that was ignored when we started (nohup, a background job of a
 * non-interactive shell) stays ignored, as callers of such jobs expect. */
static int install_signals(void)
{
    static const int sigs[] = {SIGINT, SIGTERM};
    for (size_t i = 0; i < sizeof sigs / sizeof sigs[0]; i++) {
        struct sigaction old;
        if (sigaction(sigs[i], NULL, &old)) return -1;
        if (old.sa_handler == SIG_IGN) continue;
        struct sigaction sa;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_signal;
        sigemptyset(&sa.sa_mask);
        /* SA_RESTART: the HDF5 writer need not cope with EINTR. */
        sa.sa_flags = SA_RESETHAND | SA_RESTART;
        if (sigaction(sigs[i], &sa, NULL)) return -1;
    }
    return 0;
}

/* Peak resident memory of this process image. VmHWM first: getrusage's
 * ru_maxrss keeps the high-water mark of the process that forked us (a
 * Python benchmark driver, say) across exec, so small runs would all read
 * as the parent's size. */
static uint64_t peak_rss_bytes(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (f) {
        char line[256];
        unsigned long long kib = 0;
        int found = 0;
        while (!found && fgets(line, sizeof line, f))
            found = sscanf(line, "VmHWM: %llu kB", &kib) == 1;
        fclose(f);
        if (found) return (uint64_t)kib * 1024;
    }
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru)) return 0;
    return (uint64_t)ru.ru_maxrss * 1024; /* Linux reports KiB */
}

/* ---- the run directory ------------------------------------------------- */

/* The longest run directory name: the checkpoint writer and loader take
 * names of at most 4000 bytes, and the longest name pdla makes in the
 * directory, ".cluster.h5.new.tmp.<pid>" or ".checkpoint.h5.tmp.<pid>", must
 * still fit the 4096 bytes of PATH_MAX. Checked at the start, so that no
 * write fails late, after growth, for a name known from the start. */

/* Removes what an earlier pdla in dir left behind when it was killed while
 * writing cluster.h5, its sidecar or summary.txt (kill -9, a second
 * SIGINT): only names pdla makes (the sidecars' as xdmf.c names them, the
 * event model's too, as a --force run may follow one), and only while we
 * hold the directory's lock, so no live writer can own them. */
static void remove_stale_outputs(const char *dir)
{
    cli_remove_temp(dir); /* the names every model's command writes under (rundir.c) */
}

/* Make the run directory (path filled in dir) before any work, so that a bad
 * or taken name fails at once. *created says whether we made it (and may
 * remove it again while it is empty). 0, or EXIT_USAGE with a message. */
/* No --out: a fresh runs/run-YYYYmmdd-HHMMSS-<dim>d-<target>; a run
 * started in the same second with the same size gets -2, -3, ... */
static int make_default_run_dir(const cli_options *o, char *dir, size_t dirlen, int *created)
{
    int e = cli_mkdir_p("runs");
    if (e) {
        fprintf(stderr, "pdla: cannot create directory 'runs': %s\n", strerror(e));
        return EXIT_USAGE;
    }
    const time_t t = time(NULL);
    struct tm tm;
    char stamp[32];
    if (!localtime_r(&t, &tm) || !strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &tm))
        snprintf(stamp, sizeof stamp, "%lld", (long long)t);
    for (int k = 1; k <= 100; k++) {
        const int n = k == 1 ? snprintf(dir, dirlen, "runs/run-%s-%dd-%" PRIu64, stamp,
                                         o->params.dim, o->params.target)
                             : snprintf(dir, dirlen, "runs/run-%s-%dd-%" PRIu64 "-%d", stamp,
                                        o->params.dim, o->params.target, k);
        if (n < 0 || (size_t)n >= dirlen) break;
        if (mkdir(dir, 0777) == 0) {
            *created = 1;
            return 0;
        }
        if (errno != EEXIST) {
            fprintf(stderr, "pdla: cannot create run directory '%s': %s\n", dir, strerror(errno));
            return EXIT_USAGE;
        }
    }
    fprintf(stderr, "pdla: cannot find a free run directory name under runs/\n");
    return EXIT_USAGE;
}

static int make_run_dir(const cli_options *o, char *dir, size_t dirlen, int *created)
{
    *created = 0;
    if (!o->out_dir) return make_default_run_dir(o, dir, dirlen, created);

    const int n = snprintf(dir, dirlen, "%s", o->out_dir);
    if (n < 0 || (size_t)n >= dirlen || n > CLI_RUN_DIR_MAX) {
        fprintf(stderr, "pdla: run directory name is too long (%zu bytes; at most %d)\n",
                strlen(o->out_dir), CLI_RUN_DIR_MAX);
        return EXIT_USAGE;
    }
    /* "DIR/" names DIR: drop trailing slashes so file paths read DIR/x. */
    for (size_t len = (size_t)n; len > 1 && dir[len - 1] == '/';) dir[--len] = '\0';
    /* The parents: everything before the last component. */
    const int pe = cli_mkdir_parents(dir);
    if (pe) {
        fprintf(stderr, "pdla: cannot create run directory '%s': %s (making its parents)\n", dir, strerror(pe));
        return EXIT_USAGE;
    }
    if (mkdir(dir, 0777) == 0) {
        *created = 1;
        return 0;
    }
    const int e = errno;
    if (e != EEXIST) {
        fprintf(stderr, "pdla: cannot create run directory '%s': %s\n", dir, strerror(e));
        return EXIT_USAGE;
    }
    if (!o->force) {
        fprintf(stderr, "pdla: run directory '%s' already exists (use --force to write into it)\n",
                dir);
        return EXIT_USAGE;
    }
    struct stat st;
    if (stat(dir, &st) || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "pdla: '%s' exists and is not a directory\n", dir);
        return EXIT_USAGE;
    }
    const int we = pdla_rundir_probe(dir);
    if (we) {
        fprintf(stderr, "pdla: run directory '%s' is not writable: %s\n", dir, strerror(we));
        return EXIT_USAGE;
    }
    return 0;
}

/* ---- growth ------------------------------------------------------------ */

/* Why the progress callback asked growth to stop. */
enum { STOP_NONE = 0, STOP_SIGNAL, STOP_FILE, STOP_CHECKPOINT };

/* The state of the growth loop: progress and the checkpoint triggers. */
typedef struct grow_ctx {
    progress *prog;
    const cli_options *o;
    const char *dir;          /* run directory */
    const char *command;
    char stop_path[4200];     /* RUN_DIR/STOP */
    int reason;               /* STOP_* of the last stop request */
    double t_stop;            /* when it was made */
    double next_time;         /* monotonic time of the next time trigger; 0: none */
    uint64_t next_particles;  /* count of the next particle trigger; 0: none */
    double last_stop_check;   /* when RUN_DIR/STOP was last looked for */
    /* For the summary. */
    int written, failures;
    uint64_t generation, bytes;
    double write_seconds, pause_seconds, max_pause;
    char last_path[4200];
    const pdla_checkpoint_info *resumed; /* NULL: a new run */
} grow_ctx;

static int on_progress(const pdla_engine *e, void *user)
{
    grow_ctx *c = user;
    if (stop_signal) {
        c->reason = STOP_SIGNAL;
        c->t_stop = pdla_clock_seconds();
        return 1;
    }
    if (c->o->checkpoint) {
        const double t = pdla_clock_seconds();
        const uint64_t n = pdla_engine_count(e);
        if (n < pdla_engine_params(e)->target &&
            ((c->next_time > 0 && t >= c->next_time) ||
             (c->next_particles > 0 && n >= c->next_particles))) {
            c->reason = STOP_CHECKPOINT;
            c->t_stop = t;
            return 1;
        }
        if (t - c->last_stop_check >= 1.0) { /* a stat() a second, not per particle */
            c->last_stop_check = t;
            struct stat st;
            if (stat(c->stop_path, &st) == 0 && !S_ISDIR(st.st_mode)) { /* a directory cannot be removed once honoured */
                c->reason = STOP_FILE;
                c->t_stop = t;
                return 1;
            }
        }
    }
    progress_tick(c->prog, e);
    return 0;
}

static void schedule_checkpoints(grow_ctx *c, const pdla_engine *e)
{
    if (c->o->checkpoint_every > 0) c->next_time = pdla_clock_seconds() + c->o->checkpoint_every;
    const uint64_t P = c->o->checkpoint_particles;
    if (P) c->next_particles = (pdla_engine_count(e) / P + 1) * P;
}

/* Write a checkpoint (growth is stopped); pause = time the stop took. */
static int do_checkpoint(pdla_engine *e, grow_ctx *c, double pause, char *why, size_t whylen)
{
    const pdla_checkpoint_opts co = {c->o->checkpoint_compress, c->command, pause, c->o->checkpoint_every,
                                     c->o->checkpoint_particles};
    pdla_checkpoint_info info;
    char err[4600];
    const int rc = pdla_checkpoint_write(e, c->dir, &co, &info, err, sizeof err);
    schedule_checkpoints(c, e);
    if (rc != PDLA_OK) {
        snprintf(why, whylen, "checkpoint failed: %s", err);
        c->failures++;
        return -1;
    }
    c->written++;
    c->generation = info.generation;
    c->bytes = info.bytes;
    c->write_seconds += info.seconds;
    c->pause_seconds += pause;
    if (pause > c->max_pause) c->max_pause = pause;
    snprintf(c->last_path, sizeof c->last_path, "%s", info.path);
    if (c->prog->enabled)
        fprintf(c->prog->out, "%scheckpoint %" PRIu64 ": %" PRIu64 " particles, %.1f MB in %.3f s (pause %.3f s)\n",
                c->prog->tty ? "\r\033[K" : "", info.generation, info.particles, info.bytes / 1e6,
                info.seconds, pause);
    return 0;
}

/* Everything the reports need, gathered once after growth. */
typedef struct report {
    const char *command;
    pdla_stats st;
    pdla_fit fit;
    const pdla_params *P;
    double wall_seconds;
    uint64_t peak_rss;
    const char *h5_path; /* NULL: no file written */
    const grow_ctx *ck;  /* checkpoints, or NULL */
} report;

static const char *return_word(pdla_return_mode m) { return m == PDLA_RETURN_KILL ? "kill" : "exact"; }

/* Every row of the parameter table, one per line with its unit. */
static void print_parameters(FILE *f, const pdla_params *P)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    fprintf(f, "parameters\n");
    for (size_t i = 0; i < n; i++) {
        char v[64];
        pdla_param_format(&t[i], P, 0, v, sizeof v);
        fprintf(f, "  %-14s %s%s%s\n", t[i].name, v, t[i].unit[0] ? " " : "", t[i].unit); /* a space after a long name too */
    }
}

/* The summary's lines on the workers or reference walkers: how the spots
 * were re-checked, how the walkers were interleaved, the mutexes. */
static void print_concurrency(FILE *f, const report *r)
{
    const pdla_stats *s = &r->st;
    const pdla_params *P = r->P;
    if (s->threads)
        fprintf(f, "threads          %d after %" PRIu64 " serial particles (%.3f s parallel, binding %s)\n",
                s->threads, P->serial_until, s->parallel_seconds, s->binding);
    if (P->reference_walkers)
        fprintf(f, "reference        %d walkers in turn (one thread) after %" PRIu64 " serial particles\n",
                P->reference_walkers, P->serial_until);
    if (s->threads || P->reference_walkers)
        fprintf(f, "re-checks        %" PRIu64 " spots taken: %" PRIu64 " continued, %" PRIu64 " discarded\n",
                s->recheck_overlaps, s->recheck_continued, s->recheck_discarded);
    if (s->threads)
        fprintf(f, "stale reads      %" PRIu64 " jumps and %" PRIu64 " births queried again, %" PRIu64
                   " moves waited for a chosen spot\n",
                s->stale_jumps, s->stale_births, s->claim_waits);
    if (s->threads)
        fprintf(f, "relaunched       %" PRIu64 " walkers left behind by more than %d x %d particles\n",
                s->relaunches, PDLA_STRAGGLER_FACTOR, s->threads);
    if ((s->threads || P->reference_walkers) && s->lag_n)
        /* How the walkers were interleaved (issue 11): about P - 1 when they
         * ran at once; mostly 0 when workers ran one at a time. */
        fprintf(f, "lag              mean %.2f particles stuck while a walker flew, %.1f%% of "
                   "walks saw none\n",
                (double)s->lag_sum / (double)s->lag_n,
                100.0 * (double)s->lag_hist[0] / (double)s->lag_n);
    if (s->threads) {
        static const char *const names[3] = {"node", "bucket", "gyration"};
        fprintf(f, "mutex waits     ");
        for (int i = 0; i < 3; i++)
            fprintf(f, " %s %.2f%% of %" PRIu64 "%s", names[i],
                    s->mutex_taken[i] ? 100.0 * (double)s->mutex_contended[i] / (double)s->mutex_taken[i] : 0.0,
                    s->mutex_taken[i], i < 2 ? "," : "\n");
        fprintf(f, "mutex hold ns   ");
        for (int i = 0; i < 3; i++)
            fprintf(f, " %s %.0f%s", names[i],
                    s->mutex_taken[i] > s->mutex_long_holds[i]
                        ? s->mutex_hold_ns[i] / (double)(s->mutex_taken[i] - s->mutex_long_holds[i])
                        : 0.0,
                    i < 2 ? "," : " (mean per acquisition)\n");
    }
}

/* The summary's lines on the resume and the checkpoints written. */
static void print_checkpoints(FILE *f, const grow_ctx *c)
{
    if (c && c->resumed)
        fprintf(f, "resumed from     %s (generation %" PRIu64 ", %" PRIu64 " particles, loaded in %.3f s)\n",
                c->resumed->path, c->resumed->generation, c->resumed->particles, c->resumed->seconds);
    if (c && c->written)
        fprintf(f, "checkpoints      %d written (%d failed), last %s (generation %" PRIu64 ", %.1f MB); "
                   "write %.3f s, pause %.3f s in total (longest pause %.3f s)\n",
                c->written, c->failures, c->last_path, c->generation, c->bytes / 1e6, c->write_seconds,
                c->pause_seconds, c->max_pause);
    else if (c && c->o->checkpoint)
        fprintf(f, "checkpoints      none written (%d failed)\n", c->failures);
}

/* The human summary; summary.txt adds the command line and the parameters. */
static void print_summary(FILE *f, const report *r, int with_command)
{
    const pdla_stats *s = &r->st;
    const pdla_params *P = r->P;
    const double n = (double)s->particles;
    char b1[32], b2[32];
    fprintf(f, "pdla %s: %dD %s\n", pdla_version(), P->dim, s->threads ? "PDLA" : "DLA");
    if (with_command) fprintf(f, "command          %s\n", r->command ? r->command : "?");
    fprintf(f, "particles        %" PRIu64 " of %" PRIu64 "%s\n", s->particles, P->target,
            s->particles < P->target ? " (stopped early)" : "");
    fprintf(f, "resolution       D = %d units per diameter, eps = %d units, seed %" PRIu64 "\n",
            P->resolution, P->eps, P->seed);
    fprintf(f, "return           %s, birth margin %g diameters\n", return_word(P->return_mode),
            P->birth_margin);
    print_concurrency(f, r);
    fprintf(f, "wall time        %.3f s (growth %.3f s)\n", r->wall_seconds, s->grow_seconds);
    fprintf(f, "rate             %.0f particles/s\n", s->grow_seconds > 0 ? n / s->grow_seconds : 0.0);
    fprintf(f, "jumps/particle   %.2f\n", n > 0 ? (double)s->jumps / n : 0.0);
    fprintf(f, "ns/jump          %.1f\n", s->jumps ? 1e9 * s->grow_seconds / (double)s->jumps : 0.0);
    fprintf(f, "walkers          %" PRIu64 " (%" PRIu64 " restarts, %" PRIu64 " lost, %" PRIu64 " killed)\n",
            s->walkers, s->restarts, s->lost, s->killed);
    fprintf(f, "R_g              %.3f diameters\n", s->rg_diam);
    fprintf(f, "R_ext            %.3f diameters\n", (double)s->r_ext / P->resolution);
    if (r->fit.points > 0)
        fprintf(f, "D_f              %.4f +/- %.4f (N from %" PRIu64 " to %" PRIu64 ", %d samples)\n",
                r->fit.df, r->fit.df_err, r->fit.n_lo, r->fit.n_hi, r->fit.points);
    else if (P->rg_per_decade == 0)
        fprintf(f, "D_f              n/a (R_g sampling off: --rg-per-decade 0)\n");
    else
        fprintf(f, "D_f              n/a (too few R_g samples to fit)\n");
    progress_fmt_bytes(b1, sizeof b1, (double)s->tree_bytes);
    fprintf(f, "tree memory      %.2f bytes/particle (%s)\n", n > 0 ? (double)s->tree_bytes / n : 0.0, b1);
    progress_fmt_bytes(b2, sizeof b2, (double)r->peak_rss);
    fprintf(f, "peak RSS         %s\n", b2);
    fprintf(f, "output           %s\n", r->h5_path ? r->h5_path : "none");
    print_checkpoints(f, r->ck);
    if (with_command) print_parameters(f, P);
}

/* ---- JSON -------------------------------------------------------------- */

/* A string, or null; invalid UTF-8 (a path, the command line) as U+FFFD,
 * as info --json writes it (tools.h). */
static void json_string(FILE *f, const char *s)
{
    if (!s) fputs("null", f);
    else tool_json_str(f, s);
}

static void json_real(FILE *f, double x)
{
    if (isfinite(x)) fprintf(f, "%.17g", x);
    else fputs("null", f);
}

/* ",\n  \"key\": [v0, v1, ...]", each a json_real (JSON has no NaN or inf). */
static void json_reals(FILE *f, const char *key, const double *v, int n)
{
    fprintf(f, ",\n  \"%s\": [", key);
    for (int i = 0; i < n; i++) {
        if (i) fputs(", ", f);
        json_real(f, v[i]);
    }
    fputc(']', f);
}

/* Every row of the parameter table: {"name": value, ...}; a choice as its word. */
static void json_params(FILE *f, const pdla_params *P)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    fputc('{', f);
    for (size_t i = 0; i < n; i++) {
        char v[64];
        pdla_param_format(&t[i], P, 1, v, sizeof v);
        fprintf(f, "%s\"%s\": ", i ? ", " : "", t[i].name);
        if (t[i].type == PDLA_PT_CHOICE) json_string(f, v);
        else if (t[i].type == PDLA_PT_REAL) json_real(f, pdla_param_get_real(&t[i], P));
        else fputs(v, f);
    }
    fputc('}', f);
}

static void write_json(FILE *f, const report *r, const char *status)
{
    const pdla_stats *s = &r->st;
    const pdla_params *P = r->P;
    fprintf(f, "{\n  \"version\": ");
    json_string(f, pdla_version());
    fprintf(f, ",\n  \"command\": ");
    json_string(f, r->command);
    fprintf(f, ",\n  \"status\": ");
    json_string(f, status);
    fprintf(f, ",\n  \"params\": ");
    json_params(f, P);
    fprintf(f, ",\n");
    fprintf(f, "  \"particles\": %" PRIu64 ",\n  \"walkers\": %" PRIu64 ",\n  \"jumps\": %" PRIu64
               ",\n  \"returns\": %" PRIu64 ",\n  \"lost\": %" PRIu64 ",\n  \"killed\": %" PRIu64
               ",\n  \"restarts\": %" PRIu64 ",\n  \"node_visits\": %" PRIu64
               ",\n  \"particle_checks\": %" PRIu64 ",\n  \"r_ext_units\": %" PRId64 ",\n",
            s->particles, s->walkers, s->jumps, s->returns, s->lost, s->killed, s->restarts,
            s->node_visits, s->particle_checks, s->r_ext);
    fprintf(f, "  \"r_ext_diam\": ");
    json_real(f, (double)s->r_ext / P->resolution);
    fprintf(f, ",\n  \"rg_diam\": ");
    json_real(f, s->rg_diam);
    fprintf(f, ",\n  \"tree_bytes\": %zu,\n  \"inner_nodes\": %" PRIu64 ",\n  \"leaves\": %" PRIu64
               ",\n  \"chunks\": %" PRIu64 ",\n  \"root_level\": %d,\n  \"grow_seconds\": ",
            s->tree_bytes, s->inner_nodes, s->leaves, s->chunks, s->root_level);
    json_real(f, s->grow_seconds);
    fprintf(f, ",\n  \"parallel_seconds\": ");
    json_real(f, s->parallel_seconds);
    fprintf(f, ",\n  \"threads\": %d,\n  \"recheck_overlaps\": %" PRIu64
               ",\n  \"recheck_continued\": %" PRIu64 ",\n  \"recheck_discarded\": %" PRIu64
               ",\n  \"stale_jumps\": %" PRIu64 ",\n  \"stale_births\": %" PRIu64
               ",\n  \"claim_waits\": %" PRIu64 ",\n  \"relaunches\": %" PRIu64
               ",\n  \"mutex_taken\": [%" PRIu64 ", %" PRIu64 ", %" PRIu64 "]"
               ",\n  \"mutex_contended\": [%" PRIu64 ", %" PRIu64 ", %" PRIu64 "]",
            s->threads, s->recheck_overlaps, s->recheck_continued, s->recheck_discarded,
            s->stale_jumps, s->stale_births, s->claim_waits, s->relaunches, s->mutex_taken[0], s->mutex_taken[1], s->mutex_taken[2], s->mutex_contended[0],
            s->mutex_contended[1], s->mutex_contended[2]);
    json_reals(f, "mutex_hold_ns", s->mutex_hold_ns, 3);
    json_reals(f, "mutex_wait_ns", s->mutex_wait_ns, 3);
    fprintf(f, ",\n  \"mutex_long_holds\": [%" PRIu64 ", %" PRIu64 ", %" PRIu64 "],\n  \"worker_cpu_seconds\": ",
            s->mutex_long_holds[0], s->mutex_long_holds[1], s->mutex_long_holds[2]);
    json_real(f, s->worker_cpu_seconds);
    fprintf(f, ",\n  \"binding\": ");
    json_string(f, s->binding);
    /* PDLA lag (issue 11): particles appended by the others while a walker
     * was in flight, over the particles the workers / reference walkers
     * inserted. */
    const double lag_mean = s->lag_n ? (double)s->lag_sum / (double)s->lag_n : 0.0;
    const double lag_var = s->lag_n ? s->lag_sum2 / (double)s->lag_n - lag_mean * lag_mean : 0.0;
    fprintf(f, ",\n  \"lag_n\": %" PRIu64 ",\n  \"lag_mean\": ", s->lag_n);
    json_real(f, lag_mean);
    fprintf(f, ",\n  \"lag_sd\": ");
    json_real(f, lag_var > 0 ? sqrt(lag_var) : 0.0);
    fprintf(f, ",\n  \"lag_hist\": [");
    for (int i = 0; i < PDLA_LAG_BINS; i++) fprintf(f, "%s%" PRIu64, i ? ", " : "", s->lag_hist[i]);
    fprintf(f, "]");
    fprintf(f, ",\n  \"fit\": {\"df\": ");
    json_real(f, r->fit.points ? r->fit.df : NAN);
    fprintf(f, ", \"df_err\": ");
    json_real(f, r->fit.points ? r->fit.df_err : NAN);
    fprintf(f, ", \"prefactor_diam\": ");
    json_real(f, r->fit.points ? r->fit.prefactor_diam : NAN);
    fprintf(f, ", \"n_lo\": %" PRIu64 ", \"n_hi\": %" PRIu64 ", \"points\": %d},\n", r->fit.n_lo,
            r->fit.n_hi, r->fit.points);
    fprintf(f, "  \"wall_seconds\": ");
    json_real(f, r->wall_seconds);
    fprintf(f, ",\n  \"peak_rss_bytes\": %" PRIu64 ",\n  \"output\": ", r->peak_rss);
    json_string(f, r->h5_path);
    fprintf(f, "\n}\n");
}

/* Write cluster.h5 into dir. With --force an existing one is replaced by
 * writing beside it and renaming, so a failed write keeps the old file.
 * 0; -1 with why when cluster.h5 is not written; 1 with why when it is in
 * place but its directory sync or its sidecar failed. */
static int write_cluster(const pdla_engine *e, const pdla_run_info *info, const char *h5,
                         const char *dir, char *why, size_t whylen)
{
    char err[4600];
    char tmp[4200];
    const int exists = access(h5, F_OK) == 0;
    const char *target = h5;
    if (exists) {
        snprintf(tmp, sizeof tmp, "%s/.cluster.h5.new", dir);
        if (unlink(tmp) && errno != ENOENT) {
            snprintf(why, whylen, "cannot remove %s: %s", tmp, strerror(errno));
            return -1;
        }
        target = tmp;
    }
    if (pdla_output_write(e, info, target, err, sizeof err) != PDLA_OK) {
        snprintf(why, whylen, "%s", err); /* already names the file */
        /* a failed --force write keeps the old cluster.h5 and leaves no
         * .cluster.h5.new (one written whose directory sync failed stayed) */
        if (exists) unlink(tmp);
        return -1;
    }
    if (exists && rename(tmp, h5)) {
        snprintf(why, whylen, "cannot replace %s: %s", h5, strerror(errno));
        unlink(tmp);
        return -1;
    }
    /* The replacing rename made durable, as the library's own rename is (a
     * crash just after a --force run that said "wrote" could leave the older
     * cluster.h5); a failed sync is one line with the new file in place. */
    const int unsynced = exists && pdla_rundir_fsync(dir) != 0 ? (errno ? errno : EIO) : 0;
    /* ParaView's sidecar (include/pdla/xdmf.h), for the file under its final name. */
    const int xrc = xdmf_write_cluster(h5, pdla_engine_count(e), pdla_engine_params(e)->dim,
                                       pdla_engine_params(e)->resolution,
                                       pdla_engine_params(e)->record_arrival, why, whylen);
    if (unsynced)
        snprintf(why, whylen, "replaced %s, but cannot sync its directory: %s", h5, strerror(unsynced));
    return unsynced || xrc ? 1 : 0; /* cluster.h5 is in place either way */
}

/* ---- main: one run as a sequence of steps ------------------------------- */

/* Steps return GO_ON to go on, or the exit status to end with. */
#define GO_ON (-1)

/* Everything one run of the main command holds between its steps; run_close
 * is the one unwind. */
typedef struct run {
    double t0;
    char *cmd; /* the command line, for provenance */
    cli_options o;
    pdla_engine *eng;
    char dir[4096];              /* the run directory ("" with --no-output) */
    int created, lock;           /* we made dir; its lock (-1: none) */
    pdla_checkpoint_info loaded; /* --resume: what was loaded */
    int json_on, json_force;     /* --stats-json: write it; it may replace a file */
    progress prog;
    grow_ctx gc;
    int grew;                    /* growth ran: the exit follows a signal */
    int grc;                     /* the last pdla_engine_grow return */
    char gerr[512];
    char ckwhy[4700];            /* why the last checkpoint failed */
    int asked_stop, ckpt_failed; /* stopped by signal/STOP; final checkpoint failed */
    report r;
    char h5[4200], txt[4200], why[5000];
    int write_failed;
} run;

/* The subcommands and the other models, each with its own command line.
 * Returns 1 with *code set when argv was one of them. */
static int run_subcommand(int argc, char **argv, int *code)
{
    const char *sub = argc > 1 ? argv[1] : "";
    /* The event model has its own command line and info (event_cmd.h). */
    const int ev_tool = (!strcmp(sub, "info") || !strcmp(sub, "render") || !strcmp(sub, "analyze")) &&
                        event_info_wanted(argc - 1, argv + 1);
    if (ev_tool && event_checkpoint_refused(sub, argc - 1, argv + 1))
        *code = EXIT_USAGE;
    else if (ev_tool && strcmp(sub, "info") == 0)
        *code = event_info_main(argc - 1, argv + 1);
    else if (ev_tool && strcmp(sub, "render") == 0)
        *code = event_render_main(argc - 1, argv + 1);
    else if (ev_tool)
        *code = event_analyze_main(argc - 1, argv + 1);
    else if (event_cmd_wanted(argc, argv))
        *code = event_cmd_main(argc, argv);
    /* Subcommands that read a cluster file (tools.h). */
    else if (strcmp(sub, "info") == 0)
        *code = tool_info(argc - 1, argv + 1);
    else if (strcmp(sub, "render") == 0)
        *code = tool_render(argc - 1, argv + 1);
    else if (strcmp(sub, "analyze") == 0)
        *code = tool_analyze(argc - 1, argv + 1);
    else if (strcmp(sub, "ensemble") == 0)
        *code = ens_cmd_main(argc - 1, argv + 1);
    else if (dlca_cmd_wanted(argc, argv)) /* --model dlca */
        *code = dlca_cmd_main(argc, argv);
    else if (strcmp(sub, "export") == 0)
        *code = tool_export(argc - 1, argv + 1);
    else if (strcmp(sub, "check") == 0)
        *code = tool_check(argc - 1, argv + 1);
    else
        return 0;
    return 1;
}

/* --help or --version on stdout. */
static int print_help_or_version(const cli_options *o)
{
    if (o->action == CLI_HELP) {
        pdla_params d;
        pdla_params_default(&d);
        const size_t n = cli_help_text(NULL, 0, &d) + 1;
        char *help = malloc(n);
        if (!help) {
            fprintf(stderr, "pdla: out of memory\n");
            return EXIT_RUNTIME;
        }
        cli_help_text(help, n, &d);
        fputs(help, stdout);
        free(help);
    } else {
        printf("pdla %s\nrevision %s\ncompiler %s\nbuild %s\n", pdla_version(), pdla_build_revision(), pdla_build_compiler(),
               pdla_build_flags());
    }
    if (fflush(stdout) || ferror(stdout)) {
        fprintf(stderr, "pdla: cannot write to stdout: %s\n", strerror(errno));
        return EXIT_RUNTIME;
    }
    return 0;
}

/* Step 1, parse: the options (parse.c), then the signal handlers and a
 * silent HDF5 for what follows. */
static int parse_step(run *R, int argc, char **argv)
{
    R->cmd = cli_command_line(NULL, argc, argv); /* before getopt reorders argv */
    if (!R->cmd) {
        fprintf(stderr, "pdla: out of memory\n");
        return EXIT_RUNTIME;
    }
    char err[1024];
    const int prc = cli_parse(argc, argv, &R->o, err, sizeof err);
    if (prc == CLI_PARSE_ERROR) {
        fprintf(stderr, "pdla: %s\n", err);
        return EXIT_USAGE;
    }
    if (prc == CLI_PARSE_EXIT) return print_help_or_version(&R->o);
    if (install_signals()) {
        fprintf(stderr, "pdla: cannot install signal handlers: %s\n", strerror(errno));
        return EXIT_RUNTIME;
    }
    if (pdla_hdf5_quiet()) { /* HDF5 never prints; our messages say what failed */
        fprintf(stderr, "pdla: cannot silence HDF5\n");
        return EXIT_RUNTIME;
    }
    return GO_ON;
}

/* The run directory of --resume PATH: PATH itself, or the checkpoint file's
 * folder, without trailing slashes. */
static void resume_dir(const char *path, int is_dir, char *dir, size_t dirlen)
{
    snprintf(dir, dirlen, "%s", path);
    if (!is_dir) {
        char *slash = strrchr(dir, '/');
        if (!slash) snprintf(dir, dirlen, ".");
        else slash[slash == dir ? 1 : 0] = '\0';
    }
    for (size_t len = strlen(dir); len > 1 && dir[len - 1] == '/';) dir[--len] = '\0';
}

/* Steps 2 and 3 for --resume: lock the run directory, then load the
 * checkpoint, which validates it and the options against it. */
/* A resume without checkpoint options keeps the interrupted run's schedule
 * (a bare `pdla --resume DIR` after --checkpoint-every 30m wrote only the
 * final checkpoint, so a kill after it lost everything since the resume);
 * any of --checkpoint-every, --checkpoint-particles, --checkpoint-compress
 * given replaces it (--checkpoint-every 0: no time trigger). */
static void keep_schedule(run *R)
{
    cli_options *o = &R->o;
    const pdla_checkpoint_info *in = &R->loaded;
    if (!in->has_schedule || o->schedule_given) return;
    o->checkpoint_every = in->every_seconds;
    o->checkpoint_particles = in->every_particles;
    o->checkpoint_compress = in->compressed;
}

/* The checkpoint --resume names, loaded: a run directory's newest valid
 * generation, or the file named, placed first among its folder's
 * generation names (pdla_checkpoint_place: a valid checkpoint ahead of it,
 * which this resume's writes would rotate out, refuses the resume; damaged
 * ones there go aside in resume_step, as after a directory's fallback).
 * GO_ON, or the exit status with the line printed. */
static int load_resume(run *R, int is_dir)
{
    const cli_options *o = &R->o;
    /* a run directory's every generation with its reason (up to 4800
     * bytes each, checkpoint_read.c): at 1024 a directory of ~330 bytes
     * lost the oldest generation's name */
    char err[16384], note[1024] = "";
    int slot = -1;
    if (!is_dir) {
        const int prc = pdla_checkpoint_place(o->resume, R->dir, &slot, note, sizeof note, err, sizeof err);
        if (prc != PDLA_OK) {
            fprintf(stderr, "pdla: cannot resume: %s\n", err);
            return prc == PDLA_EEXIST || prc == PDLA_EINVAL ? EXIT_USAGE : EXIT_RUNTIME;
        }
    }
    const int lrc = pdla_checkpoint_load(&R->eng, o->resume, &o->params, o->given, &R->loaded, err,
                                         sizeof err);
    if (lrc != PDLA_OK) {
        fprintf(stderr, "pdla: cannot resume: %s\n", err);
        return lrc == PDLA_ENOMEM ? EXIT_RUNTIME : EXIT_USAGE;
    }
    if (!is_dir) {
        R->loaded.slot = slot;
        snprintf(R->loaded.note, sizeof R->loaded.note, "%s", note);
    }
    return GO_ON;
}

static int resume_step(run *R)
{
    const cli_options *o = &R->o;
    struct stat st;
    if (stat(o->resume, &st) != 0) {
        fprintf(stderr, "pdla: cannot resume from '%s': %s\n", o->resume, strerror(errno));
        return EXIT_USAGE;
    }
    /* A checkpoint under a name the sweep of leftovers below removes (a copy
     * named .cluster.h5.new): it loaded, and the sweep then removed the file
     * named, so a kill before the first checkpoint lost it. Refused, kept,
     * as the event and DLCA commands refuse their temporary names. */
    if (!S_ISDIR(st.st_mode) && cli_refuse_temp_resume(o->resume)) return EXIT_USAGE;
    resume_dir(o->resume, S_ISDIR(st.st_mode), R->dir, sizeof R->dir);
    if (strlen(o->resume) > CLI_RUN_DIR_MAX) {
        fprintf(stderr, "pdla: cannot resume: the checkpoint path is too long (%zu bytes; at most %d)\n",
                strlen(o->resume), CLI_RUN_DIR_MAX);
        return EXIT_USAGE;
    }
    /* Lock first, so no other pdla writes while we read; the lock creates
     * nothing, so a refused resume leaves the disk as it was. */
    char err[1024];
    if (pdla_rundir_lock(R->dir, &R->lock, err, sizeof err) != PDLA_OK) {
        fprintf(stderr, "pdla: %s\n", err);
        return EXIT_USAGE;
    }
    /* a link to a temporary name: loaded through, then the sweep below
     * removed the file it names (rundir.h) */
    if (cli_refuse_temp_links(R->dir)) return EXIT_USAGE;
    const int lrc = load_resume(R, S_ISDIR(st.st_mode));
    if (lrc != GO_ON) return lrc;
    /* Writability now, not after growth: a resume writes checkpoints,
     * cluster.h5 and summary.txt there. (After the load, so that a resume
     * refused for its checkpoint or parameters touches nothing, not even the
     * directory's mtime.) */
    const int we = pdla_rundir_probe(R->dir);
    if (we) {
        fprintf(stderr, "pdla: cannot resume: run directory '%s' is not writable: %s\n", R->dir,
                strerror(we));
        return EXIT_USAGE;
    }
    if (R->loaded.note[0])
        fprintf(stderr, "pdla: note: %s; resuming from %s (generation %" PRIu64 ")\n", R->loaded.note,
                R->loaded.path, R->loaded.generation);
    /* Loaded from an older name (a directory's fallback, or a file named
     * behind damaged newer names): the skipped files go aside and the good
     * generations to the front before any write, else the next write's
     * rotation kept the damaged checkpoint.h5 as a generation and pushed out
     * the one loaded; and the next generation comes after every one there. */
    char done[2048];
    if (pdla_checkpoint_recover(R->eng, R->dir, &R->loaded, done, sizeof done, err, sizeof err) != PDLA_OK) {
        fprintf(stderr, "pdla: cannot resume: %s\n", err);
        return EXIT_RUNTIME;
    }
    if (done[0]) fprintf(stderr, "pdla: note: %s\n", done);
    keep_schedule(R);
    pdla_checkpoint_remove_stale(R->dir);
    remove_stale_outputs(R->dir);
    return GO_ON;
}

/* Steps 2 and 3 for a new run: the engine (which validates the parameters),
 * then the run directory, made and locked. Everything that can fail on a
 * bad name fails here, before growth. */
static int new_run_step(run *R)
{
    char err[1024];
    const int rc = pdla_engine_create(&R->eng, &R->o.params, err, sizeof err);
    if (rc != PDLA_OK) {
        fprintf(stderr, "pdla: %s\n", err);
        return rc == PDLA_EINVAL ? EXIT_USAGE : EXIT_RUNTIME;
    }
    if (R->o.no_output) return GO_ON;
    const int drc = make_run_dir(&R->o, R->dir, sizeof R->dir, &R->created);
    if (drc) return drc;
    if (pdla_rundir_lock(R->dir, &R->lock, err, sizeof err) != PDLA_OK) {
        /* Not removed even if we made it: the pdla that holds the lock (a
         * --force run that found it there) writes into it. */
        fprintf(stderr, "pdla: %s\n", err);
        return EXIT_USAGE;
    }
    /* --force --out X/.checkpoint.h5.new with that a link to X: the sweep
     * below removed the link, and every write after it failed (rundir.h) */
    if (cli_refuse_temp_out(R->dir)) return EXIT_USAGE;
    pdla_checkpoint_remove_stale(R->dir);
    remove_stale_outputs(R->dir);
    return GO_ON;
}

/* The last step before growth, once nothing can refuse the run: a --force
 * run's directory loses the older run's checkpoints (they were removed in
 * new_run_step, before the --stats-json check, so a run refused for its
 * path left the older run unable to resume). */
static int clear_old_run_step(const run *R)
{
    if (R->o.resume || R->o.no_output || R->created) return GO_ON;
    char err[4600];
    if (pdla_rundir_remove_old_run(R->dir, 1, err, sizeof err) == PDLA_OK) return GO_ON;
    fprintf(stderr, "pdla: %s\n", err);
    return EXIT_RUNTIME;
}

/* Whether the file begins as write_json begins its output: a file
 * whose first byte alone was '{' (any JSON document: a notebook, a
 * config) was replaced on --resume without --force. */
static int json_file_is_stats(const char *path)
{
    static const char head[] = "{\n  \"version\": \"";
    char got[sizeof head - 1];
    /* Never block on a FIFO or device (fopen waited for a writer for ever,
     * SIGTERM included): a regular file only, opened without waiting. */
    const int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return 0;
    struct stat st;
    size_t n = 0;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode))
        while (n < sizeof got) {
            const ssize_t r = read(fd, got + n, sizeof got - n);
            if (r <= 0 && !(r < 0 && errno == EINTR)) break;
            if (r > 0) n += (size_t)r;
        }
    close(fd);
    return n == sizeof got && memcmp(got, head, sizeof got) == 0;
}

/* --stats-json FILE is checked before growth, so a bad path costs nothing,
 * and written at the end under a temporary name, then moved into place: it
 * was opened with "w" here, so any file of that name (a checkpoint
 * included, found by an adversarial test) was emptied at once, without
 * --force, and a killed run left it empty. An existing file is replaced
 * only with --force, or on --resume when it holds pdla's statistics
 * (json_file_is_stats: the run's own). */
static int open_json_step(run *R)
{
    if (!R->o.stats_json) return GO_ON;
    const int force = R->o.force || (R->o.resume && json_file_is_stats(R->o.stats_json));
    char why[4400];
    if (tools_out_check(R->o.stats_json, NULL, force, why, sizeof why) == 0) {
        R->json_on = 1;
        R->json_force = force;
        return GO_ON;
    }
    struct stat st;
    if (R->o.resume && !force && lstat(R->o.stats_json, &st) == 0 && !S_ISDIR(st.st_mode))
        /* --force is refused with --resume: name the way out that remains
         * (a directory keeps tools_out_check's "is a directory") */
        fprintf(stderr, "pdla: --stats-json: %s exists and does not hold pdla's statistics; not overwriting it "
                "(remove it or name another file)\n", R->o.stats_json);
    else
        fprintf(stderr, "pdla: --stats-json: %s\n", why);
    if (R->created) rmdir(R->dir); /* still empty: leave no trace */
    return EXIT_USAGE;
}

/* Step 4, grow: to the target, writing a checkpoint at each trigger and a
 * final one at the end or when asked to stop. */
static void grow_step(run *R)
{
    const cli_options *o = &R->o;
    const int tty = isatty(STDERR_FILENO);
    pdla_stats at_start;
    pdla_engine_stats(R->eng, &at_start);
    progress_init(&R->prog, stderr, o->progress == 1 || (o->progress == -1 && !o->quiet && tty), tty,
                  at_start.particles);
    grow_ctx *gc = &R->gc;
    gc->prog = &R->prog;
    gc->o = o;
    gc->dir = R->dir;
    gc->command = R->cmd;
    gc->resumed = o->resume ? &R->loaded : NULL;
    snprintf(gc->stop_path, sizeof gc->stop_path, "%s/STOP", R->dir);
    gc->last_stop_check = pdla_clock_seconds();
    schedule_checkpoints(gc, R->eng);
    R->grew = 1;
    for (;;) {
        gc->reason = STOP_NONE;
        R->grc = pdla_engine_grow(R->eng, pdla_engine_params(R->eng)->target, on_progress, 1000, gc,
                                  R->gerr, sizeof R->gerr);
        if (R->grc != PDLA_ESTOPPED || gc->reason != STOP_CHECKPOINT) break;
        /* A trigger: the workers have stopped (joined); write, go on. */
        if (do_checkpoint(R->eng, gc, pdla_clock_seconds() - gc->t_stop, R->ckwhy, sizeof R->ckwhy) &&
            gc->failures == 1)
            fprintf(stderr, "pdla: warning: %s; growth goes on\n", R->ckwhy);
    }
    progress_finish(&R->prog, R->eng);
    /* The final checkpoint: at the end, on a signal or RUN_DIR/STOP. */
    R->asked_stop = R->grc == PDLA_ESTOPPED && (gc->reason == STOP_SIGNAL || gc->reason == STOP_FILE);
    if (o->checkpoint && (R->grc == PDLA_OK || R->asked_stop)) {
        if (do_checkpoint(R->eng, gc, R->asked_stop ? pdla_clock_seconds() - gc->t_stop : 0.0, R->ckwhy,
                          sizeof R->ckwhy))
            R->ckpt_failed = 1;
        else if (gc->reason == STOP_FILE)
            unlink(gc->stop_path); /* honoured: a resume must not stop at once */
    }
}

/* Step 5, write outputs: what was grown, whether growth finished or not:
 * cluster.h5 (+ its XDMF sidecar), then summary.txt. */
static void write_outputs_step(run *R)
{
    report *r = &R->r;
    r->command = R->cmd;
    r->P = pdla_engine_params(R->eng);
    r->ck = &R->gc;
    if (!R->o.no_output) {
        snprintf(R->h5, sizeof R->h5, "%s/cluster.h5", R->dir);
        snprintf(R->txt, sizeof R->txt, "%s/summary.txt", R->dir);
        const pdla_run_info info = {R->cmd, pdla_clock_seconds() - R->t0, peak_rss_bytes()};
        const int wc = write_cluster(R->eng, &info, R->h5, R->dir, R->why, sizeof R->why);
        if (wc) R->write_failed = 1;
        if (wc >= 0) r->h5_path = R->h5; /* in place, also when its directory did not sync */
    }
    pdla_engine_stats(R->eng, &r->st);
    r->fit = pdla_engine_fit(R->eng);
    r->wall_seconds = pdla_clock_seconds() - R->t0;
    r->peak_rss = peak_rss_bytes();
    if (R->o.no_output || !r->h5_path) return;
    /* Beside it and renamed, as cluster.h5: a failed write (disk full)
     * leaves the old summary.txt, or none, never a truncated one. It is
     * written for a cluster.h5 in place even when that one's directory
     * sync failed: the older run's must not stay beside it. The first
     * failure is the one reported. */
    char stmp[4300], why2[sizeof R->why];
    char *const why = R->write_failed ? why2 : R->why;
    FILE *f = tools_out_open(R->txt, stmp, sizeof stmp, why, sizeof why2);
    if (!f) {
        R->write_failed = 1;
    } else {
        print_summary(f, r, 1);
        if (tools_out_commit(f, stmp, R->txt, 1, why, sizeof why2)) R->write_failed = 1;
    }
}

/* Step 6, report: the JSON statistics and the summary on stdout. */
static void report_step(run *R)
{
    const char *status = R->grc == PDLA_OK                                          ? "done"
                         : stop_signal                                              ? "stopped by signal"
                         : R->grc == PDLA_ESTOPPED && R->gc.reason == STOP_FILE ? "stopped by STOP file"
                                                                                    : "failed";
    if (R->json_on) {
        char tmp[4400], jwhy[5000];
        FILE *const f = tools_out_open(R->o.stats_json, tmp, sizeof tmp, jwhy, sizeof jwhy);
        int bad = !f;
        if (f) {
            write_json(f, &R->r, status);
            bad = tools_out_commit(f, tmp, R->o.stats_json, R->json_force, jwhy, sizeof jwhy) != 0;
        }
        if (bad && !R->write_failed) {
            memcpy(R->why, jwhy, sizeof R->why);
            R->write_failed = 1;
        }
    }
    if (!R->o.quiet) {
        print_summary(stdout, &R->r, 0);
        if (fflush(stdout) || ferror(stdout)) {
            if (!R->write_failed)
                snprintf(R->why, sizeof R->why, "cannot write the summary to stdout: %s", strerror(errno));
            R->write_failed = 1;
        }
    }
}

/* The end of a grown run: one line on stderr for whatever went wrong, and
 * the exit status. */
static int outcome(run *R)
{
    const uint64_t n = R->r.st.particles;
    const grow_ctx *gc = &R->gc;
    char where[5200];
    if (R->o.no_output) snprintf(where, sizeof where, "nothing written (--no-output)");
    else if (R->write_failed) snprintf(where, sizeof where, "%s", R->why);
    else snprintf(where, sizeof where, "partial cluster written to %s", R->h5);
    int code = 0;
    if (R->o.checkpoint && R->asked_stop) {
        const char *by = gc->reason == STOP_FILE ? gc->stop_path : "signal";
        if (R->ckpt_failed) {
            fprintf(stderr, "pdla: stopped by %s after %" PRIu64 " particles; %s; %s\n", by, n, R->ckwhy,
                    where);
            code = EXIT_RUNTIME;
        } else {
            fprintf(stderr, "pdla: stopped by %s after %" PRIu64 " particles; checkpoint %s (resume with "
                            "pdla --resume %s); %s\n",
                    by, n, gc->last_path, R->dir, where);
            code = R->write_failed ? EXIT_RUNTIME : 0;
        }
        stop_signal = 0; /* handled: exit normally */
    } else if (R->ckpt_failed) {
        fprintf(stderr, "pdla: %s\n", R->ckwhy);
        code = EXIT_RUNTIME;
    } else if (R->grc == PDLA_ESTOPPED && stop_signal) {
        fprintf(stderr, "pdla: stopped by signal after %" PRIu64 " particles; %s\n", n, where);
        code = EXIT_RUNTIME;
    } else if (R->grc != PDLA_OK) {
        fprintf(stderr, "pdla: growth failed after %" PRIu64 " particles: %s; %s\n", n, R->gerr, where);
        code = EXIT_RUNTIME;
    } else if (R->write_failed) {
        fprintf(stderr, "pdla: %s\n", R->why);
        code = EXIT_RUNTIME;
    } else if (stop_signal) {
        fprintf(stderr, "pdla: signal received after growth had finished; output complete\n");
    }
    return code;
}

/* The one unwind. */
static void run_close(run *R)
{
    pdla_engine_destroy(R->eng);
    pdla_rundir_unlock(R->lock);
    free(R->cmd);
}

int main(int argc, char **argv)
{
    /* HDF5 1.10 frees a file whose close failed (a write-back hit a full
     * disk or an I/O error) but keeps its id, and its own exit handler then
     * closes that id again and crashes (H5F__close_cb; HDFFV-11052). Every
     * file pdla opens is closed explicitly before it exits, so HDF5's exit
     * handler has nothing else to do: without it a failed close ends with
     * our one-line message and exit 1 instead of a segfault. Must come
     * before the first HDF5 call (else it fails, and a failed close could
     * end in that segfault: refuse to run). */
    if (H5dont_atexit() < 0) {
        fprintf(stderr, "pdla: cannot turn off HDF5's exit handler\n");
        return EXIT_RUNTIME;
    }
    int code;
    if (run_subcommand(argc, argv, &code)) return code;

    /* parse -> validate + open the run directory (new or --resume) -> grow
     * -> write outputs -> report. */
    static run R; /* ~40 KB of paths and messages: not on the stack */
    memset(&R, 0, sizeof R);
    R.t0 = pdla_clock_seconds();
    R.lock = -1;
    code = parse_step(&R, argc, argv);
    if (code == GO_ON) code = R.o.resume ? resume_step(&R) : new_run_step(&R);
    if (code == GO_ON) code = open_json_step(&R);
    if (code == GO_ON) code = clear_old_run_step(&R);
    if (code == GO_ON) {
        grow_step(&R);
        write_outputs_step(&R);
        report_step(&R);
        code = outcome(&R);
    }
    run_close(&R);

    /* Interrupted while growing: end by the same signal (the handler was
     * reset on delivery), so a calling shell sees it and stops its loop too.
     * Growth that finished (PDLA_OK) was not interrupted: the signal came
     * during the final writes, which completed; outcome() noted it. */
    const int sig = R.grew && R.grc != PDLA_OK ? stop_signal : 0;
    if (sig) {
        fflush(NULL);
        signal(sig, SIG_DFL);
        raise(sig);
    }
    return code;
}
