/*
 * event_cmd.c - `pdla --model event ...`: the event model's command line.
 * Options, --help and validation all come from the model's rows of the
 * parameter table (ev_param_table, pdla/params.h);
 * a scene file (`--scene FILE` holding `model = event`) uses the same keys.
 * Makes the run directory (new, or existing with --force), runs, writes
 * DIR/cluster.h5 (beside as .tmp, then renamed) and prints a summary.
 * Exit: 0 done, 1 runtime failure, 2 bad usage or input.
 */
#include "event_cmd.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include <unistd.h>

#include "cmdline.h"
#include "fail_note.h"
#include "parse.h"
#include "rundir.h"
#include "scene.h"
#include "pdla/event.h"
#include "pdla/pdla.h"

/* Set by SIGINT/SIGTERM: the engine stops at its next check; the signal's
 * number is kept so that a run stopped without checkpoints ends by it. */
static volatile int ev_stop_flag;
static volatile sig_atomic_t ev_stop_signal;
static void on_signal(int sig)
{
    ev_stop_signal = sig;
    ev_stop_flag = 1;
}

/* Value of --model / --scene in argv (or NULL). */
static const char *opt_value(int argc, char **argv, const char *name, int *at)
{
    const size_t n = strlen(name);
    for (int k = 1; k < argc; k++) {
        if (strncmp(argv[k], name, n) != 0) continue;
        if (argv[k][n] == '=') {
            if (at) *at = k;
            return argv[k] + n + 1;
        }
        if (argv[k][n] == '\0' && k + 1 < argc) {
            if (at) *at = k;
            return argv[k + 1];
        }
    }
    return NULL;
}

int event_cmd_wanted(int argc, char **argv)
{
    const char *m = opt_value(argc, argv, "--model", NULL);
    if (m) return !strcmp(m, "event");
    const char *sc = opt_value(argc, argv, "--scene", NULL);
    char model[16] = "";
    if (sc) scene_model(sc, model, sizeof model);
    return !strcmp(model, "event");
}

typedef struct ev_cli {
    ev_params p;
    const char *out;
    int force, quiet;
    char err[512];
    const char *scene;
    int checkpoint;          /* --checkpoint (implied by the two below) */
    double checkpoint_every; /* wall seconds, 0: only at the end / on a signal */
    int schedule_given;      /* --checkpoint-every given (a resume then drops the recorded one) */
    const char *resume;      /* run directory to continue */
    int progress;            /* -1: when stderr is a terminal */
    uint32_t given;          /* bits of the table rows given on the command line */
    int lock;                /* the run directory's flock (pdla_rundir_lock), -1: none */
} ev_cli;

/* One scene entry: `model`, `out` or a row of the parameter table. 0, or
 * -1 with "FILE:LINE: reason" in c->err. */
static int apply_scene_entry(ev_cli *c, const scene_entry *en)
{
    const char *key = en->key, *val = en->value;
    char e[400];
    size_t np;
    const pdla_param_desc *t = ev_param_table(&np);
    if (!strcmp(key, "out")) {
        static char outbuf[4096]; /* the scene's buffer is freed after reading */
        snprintf(outbuf, sizeof outbuf, "%s", val);
        c->out = outbuf;
        return 0;
    }
    if (!strcmp(key, "model")) {
        if (!strcmp(val, "event")) return 0;
        snprintf(e, sizeof e, "model must be event here");
    } else if (!pdla_param_find(t, np, key)) {
        const char *near = NULL; /* the row it differs from in letter case only */
        for (size_t i = 0; i < np && !near; i++)
            if (scene_same_but_case(key, t[i].option)) near = t[i].option;
        scene_unknown_key(key, near, " for model event", e, sizeof e);
    } else if (ev_param_set(&c->p, key, val, e, sizeof e) == 0) {
        return 0;
    }
    return pdla_errorf(-1, c->err, sizeof c->err, "%s:%d: %s", c->scene, en->line, e);
}

/* The scene's entries in order, read by scene.c as every model's scene. */
static int read_scene(ev_cli *c)
{
    scene sc;
    if (scene_read_file(c->scene, &sc, c->err, sizeof c->err)) return -1;
    int rc = 0;
    for (int i = 0; i < sc.n && !rc; i++) rc = apply_scene_entry(c, &sc.entries[i]);
    scene_free(&sc);
    return rc;
}

/* A flag without value: 1 when `a` is one (and taken into c), else 0. */
static int parse_flag(const char *a, ev_cli *c)
{
    if (!strcmp(a, "--force")) c->force = 1;
    else if (!strcmp(a, "--quiet")) c->quiet = 1;
    else if (!strcmp(a, "--checkpoint")) c->checkpoint = 1;
    else if (!strcmp(a, "--progress") || !strcmp(a, "--no-progress")) c->progress = a[2] == 'p';
    else return 0;
    return 1;
}

/* --NAME VALUE: the CLI's own options, else a row of the parameter table
 * (its bit into c->given). 0, or -1 with the line in c->err. */
static int parse_value(ev_cli *c, const char *name, const char *val)
{
    if (!strcmp(name, "model") && strcmp(val, "event")) { /* a second, other --model */
        snprintf(c->err, sizeof c->err, "--model %s: this command runs model event", val);
        return -1;
    }
    if (!strcmp(name, "model") || !strcmp(name, "scene")) return 0;
    if (!strcmp(name, "out")) {
        c->out = val;
        return 0;
    }
    if (!strcmp(name, "resume")) {
        c->resume = val;
        return 0;
    }
    if (!strcmp(name, "checkpoint-every")) {
        const char *why = cli_parse_duration(val, &c->checkpoint_every);
        if (why) {
            snprintf(c->err, sizeof c->err, "--checkpoint-every '%s': %s", val, why);
            return -1;
        }
        c->checkpoint = c->schedule_given = 1;
        return 0;
    }
    char e[400];
    if (ev_param_set(&c->p, name, val, e, sizeof e)) {
        snprintf(c->err, sizeof c->err, "%s", e);
        return -1;
    }
    size_t np;
    const pdla_param_desc *t = ev_param_table(&np);
    c->given |= pdla_param_find(t, np, name)->bit; /* found: ev_param_set took it */
    return 0;
}

/* 0 run, 1 help printed, -1 error in c->err. */
static int parse(int argc, char **argv, ev_cli *c)
{
    ev_params_default(&c->p);
    int at = -1;
    c->scene = opt_value(argc, argv, "--scene", &at);
    for (int k = at + 1; c->scene && k < argc; k++) {
        /* As the DLA and DLCA commands: a second scene is refused, not ignored. */
        if (!strcmp(argv[k], "--scene") || !strncmp(argv[k], "--scene=", 8)) {
            snprintf(c->err, sizeof c->err, "--scene given twice");
            return -1;
        }
    }
    if (c->scene && read_scene(c)) return -1;
    for (int k = 1; k < argc; k++) {
        const char *a = argv[k];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) return 1;
        if (parse_flag(a, c)) continue;
        if (strncmp(a, "--", 2) != 0) {
            snprintf(c->err, sizeof c->err, "unexpected argument '%s' (see pdla --model event --help)", a);
            return -1;
        }
        char name[64];
        const char *eq = strchr(a, '=');
        const char *val;
        if (eq) {
            snprintf(name, sizeof name, "%.*s", (int)(eq - a - 2), a + 2);
            val = eq + 1;
        } else {
            snprintf(name, sizeof name, "%s", a + 2);
            if (k + 1 >= argc) {
                snprintf(c->err, sizeof c->err, "--%s needs a value", name);
                return -1;
            }
            val = argv[++k];
        }
        if (parse_value(c, name, val)) return -1;
    }
    /* A path cut to fit the 4096-byte buffers would name another directory. */
    if ((c->out && cli_path_fits("the run directory name", c->out, c->err, sizeof c->err)) ||
        (c->resume && cli_path_fits("the checkpoint path", c->resume, c->err, sizeof c->err)))
        return -1;
    if (c->resume) {
        if (c->scene || c->out) {
            snprintf(c->err, sizeof c->err, "--resume continues the checkpoint's run in its own "
                                            "directory: --scene and --out may not be given with it");
            return -1;
        }
        return 0; /* the parameters come from the checkpoint */
    }
    char e[400];
    if (ev_params_check(&c->p, e, sizeof e)) {
        snprintf(c->err, sizeof c->err, "%s", e);
        return -1;
    }
    return 0;
}

static int make_dir(ev_cli *c, char *dir, size_t len)
{
    if (c->out) {
        snprintf(dir, len, "%s", c->out);
        /* "DIR/" names DIR, as for DLA and DLCA: with the slash, DIR was made
         * as its parent, then found existing */
        for (size_t l = strlen(dir); l > 1 && dir[l - 1] == '/';) dir[--l] = '\0';
    } else {
        if (mkdir("runs", 0777) && errno != EEXIST) {
            fprintf(stderr, "pdla: cannot create directory 'runs': %s\n", strerror(errno));
            return 2;
        }
        char stamp[32];
        const time_t t = time(NULL);
        struct tm tm;
        if (!localtime_r(&t, &tm) || !strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &tm))
            snprintf(stamp, sizeof stamp, "%lld", (long long)t);
        snprintf(dir, len, "runs/event-%s-%dd-%" PRIu64, stamp, c->p.dim, c->p.particles);
    }
    const int pe = cli_mkdir_parents(dir); /* as the DLA and DLCA commands */
    if (pe) {
        fprintf(stderr, "pdla: cannot create run directory '%s': %s (making its parents)\n", dir, strerror(pe));
        return 2;
    }
    if (mkdir(dir, 0777) == 0) return 0;
    if (errno != EEXIST) {
        fprintf(stderr, "pdla: cannot create run directory '%s': %s\n", dir, strerror(errno));
        return 2;
    }
    struct stat st;
    if (!c->force) {
        fprintf(stderr, "pdla: run directory '%s' already exists (use --force to write into it)\n", dir);
        return 2;
    }
    if (stat(dir, &st) || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "pdla: '%s' exists and is not a directory\n", dir);
        return 2;
    }
    return 0;
}

/* Peak resident memory (VmHWM) in bytes, 0 if unknown. */
static unsigned long long peak_rss(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f) return 0;
    char line[256];
    unsigned long long kib = 0;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmHWM: %llu kB", &kib) == 1) break;
    fclose(f);
    return kib * 1024;
}

/* ---- progress lines and interval checkpoints (called between events) --- */
typedef struct ev_ticker {
    ev_cli *c;
    ev_series *ser;
    cli_fail *fail;
    const char *dir, *cmd;
    int enabled, tty, width, failed;
    double interval, t_start, t_last, t_ckpt, rate;
    uint64_t ev_start, ev_last;
} ev_ticker;

static void fmt_hms(char *buf, size_t n, double sec)
{
    if (!(sec >= 0) || sec > 1e9) {
        snprintf(buf, n, "--");
        return;
    }
    const unsigned long t = (unsigned long)(sec + 0.5);
    snprintf(buf, n, "%lu:%02lu:%02lu", t / 3600, t % 3600 / 60, t % 60);
}

/* Fraction of the run done: the furthest of the stop conditions that apply
 * (time, stuck count or all stuck, event count); -1 when none says. The ETA
 * is a straight-line extrapolation of it over the wall time so far. */
static double done_fraction(const ev_sim *s, const ev_stats *st)
{
    const ev_params *p = ev_params_of((ev_sim *)s);
    double f = -1;
    if (p->t_max > 0) f = fmax(f, st->t / p->t_max);
    const uint64_t tgt = p->max_stuck ? p->max_stuck : (ev_has_seed(s) && p->stick_p > 0 ? ev_sticky_count(s) : 0);
    if (tgt) f = fmax(f, (double)st->stuck / (double)tgt);
    if (p->max_events) f = fmax(f, (double)st->events / (double)p->max_events);
    return f > 1 ? 1 : f;
}

static void progress_line(ev_ticker *k, ev_sim *s, double now, int final)
{
    ev_stats st;
    ev_get_stats(s, &st);
    const double dt = now - k->t_last;
    if (final || k->rate == 0) k->rate = now > k->t_start ? (double)(st.events - k->ev_start) / (now - k->t_start) : 0;
    else if (dt > 0) k->rate += 0.3 * ((double)(st.events - k->ev_last) / dt - k->rate);
    k->t_last = now;
    k->ev_last = st.events;
    const double f = done_fraction(s, &st);
    char eta[32];
    fmt_hms(eta, sizeof eta, final ? now - k->t_start : f > 0 ? (now - k->t_start) * (1 - f) / f : -1);
    char line[240];
    const int len = snprintf(line, sizeof line,
                             "t %.4g  events %.3g (%.3g/s)  collisions %.3g  stuck %.1f%% (%" PRIu64
                             "/%zu)  %s %s",
                             st.t, (double)st.events, k->rate, (double)st.collisions,
                             ev_sticky_count(s) ? 100.0 * (double)st.stuck / (double)ev_sticky_count(s) : 0.0,
                             st.stuck, ev_sticky_count(s), final ? "time" : "ETA", eta);
    if (k->tty) {
        fprintf(stderr, "\r%s%*s%s", line, k->width > len ? k->width - len : 0, "", final ? "\n" : "");
        k->width = len;
    } else {
        fprintf(stderr, "%s\n", line);
    }
    fflush(stderr);
}

static int ticker(ev_sim *s, void *u)
{
    ev_ticker *k = u;
    const double now = pdla_clock_seconds();
    if (k->enabled && now - k->t_last >= k->interval) progress_line(k, s, now, 0);
    if (k->c->checkpoint_every > 0 && now - k->t_ckpt >= k->c->checkpoint_every) {
        char err[512], msg[600];
        if (ev_checkpoint_write(s, k->ser, k->dir, k->cmd, err, sizeof err)) {
            ev_stats st;
            ev_get_stats(s, &st);
            snprintf(msg, sizeof msg, "checkpoint failed at t = %.6g, the run stopped there: %s", st.t, err);
            cli_fail_note(k->fail, "a checkpoint", "%s", msg);
            k->failed = 1;
            return 1; /* stop: the run would go on without its safety net */
        }
        k->t_ckpt = pdla_clock_seconds();
    }
    return 0;
}

/* Under the directory's lock (no live writer can own them): the temporary
 * files a killed pdla left (kill -9 while writing: each as large as a
 * checkpoint, one per kill), and with old_checkpoints also an older run's
 * checkpoints (every model's names), which a new --force run replaces: a
 * later --resume would otherwise grow the old run and write it over the new
 * cluster.h5. 0, or 1 (an I/O failure) with the line printed. */
static int remove_stale(const char *dir, int old_checkpoints)
{
    cli_remove_temp(dir);
    if (!old_checkpoints) return 0;
    char err[4600]; /* every model's checkpoint names: pdla.h */
    if (pdla_rundir_remove_old_run(dir, 0, err, sizeof err) == PDLA_OK) return 0;
    fprintf(stderr, "pdla: %s\n", err);
    return 1;
}

/* Can a file be made in dir? Seen before the run (chattr +i, a read-only
 * mount: access() says yes to root): before, the whole run went by and
 * then cluster.h5 and the checkpoint could not be written. 0, or 2 with
 * the line printed. */
static int dir_takes_files(const char *dir)
{
    const int e = pdla_rundir_probe(dir);
    if (!e) return 0;
    fprintf(stderr, "pdla: run directory '%s' takes no files: %s\n", dir, strerror(e));
    return 2;
}

/* checkpoint.h5 is damaged and the run resumes from checkpoint.prev.h5:
 * the damaged file goes aside, kept, under the first free name of
 * checkpoint.damaged.h5, checkpoint.damaged.2.h5, ... (pdla_rundir_set_aside,
 * as the DLA recovery: until session 31 a second fallback renamed its
 * damaged file over the first one's checkpoint.damaged.h5), the directory
 * is synced, and the previous one becomes checkpoint.h5 too (a hard link,
 * else renamed). The next write moves checkpoint.h5 to checkpoint.prev.h5
 * before it puts the new one in place; without this it moved the damaged
 * file over the good previous one, and a crash before the new file was in
 * place left no whole checkpoint under either name. 0, or 1 with the line
 * printed. */
static int promote_previous(const char *dir)
{
    char cur[4200], prev[4200], kept[4200], err[4600];
    snprintf(cur, sizeof cur, "%s/checkpoint.h5", dir);
    snprintf(prev, sizeof prev, "%s/checkpoint.prev.h5", dir);
    if (pdla_rundir_set_aside(dir, cur, kept, sizeof kept, err, sizeof err) != PDLA_OK) {
        fprintf(stderr, "pdla: cannot resume: %s\n", err);
        return 1;
    }
    /* synced before checkpoint.h5 is taken again: on a power loss the new
     * name must not land without the set-aside (the DLA recovery's order) */
    if (kept[0] && pdla_rundir_fsync(dir) != 0) {
        fprintf(stderr, "pdla: cannot sync directory %s: %s\n", dir, strerror(errno));
        return 1;
    }
    if (link(prev, cur) != 0 && rename(prev, cur) != 0) {
        fprintf(stderr, "pdla: cannot make %s the current checkpoint: %s\n", prev, strerror(errno));
        return 1;
    }
    if (pdla_rundir_fsync(dir) != 0) {
        fprintf(stderr, "pdla: cannot sync directory %s: %s\n", dir, strerror(errno));
        return 1;
    }
    if (kept[0]) fprintf(stderr, "pdla: note: %s set aside as %s\n", cur, kept);
    return 0;
}

/* The given-mask bit of the table row for option `name`. */
static uint32_t row_bit(const char *name)
{
    size_t n;
    const pdla_param_desc *t = ev_param_table(&n);
    for (size_t i = 0; i < n; i++)
        if (!strcmp(t[i].option, name)) return t[i].bit;
    return 0;
}

/* A stop given with --resume that the checkpoint has already passed is
 * refused, as the DLA command refuses a --target below the particles held:
 * before, the run stopped at once with exit 0 and its cluster.h5 recorded
 * t-max 1 beside a time of 7.8. 0, or -1 with the line in err, naming the
 * checkpoint read (path), as the DLCA command's does. */
static int stop_passed(const ev_cli *c, const ev_sim *s, const char *path, char *err, size_t errlen)
{
    const ev_params *p = &c->p;
    ev_stats st;
    ev_get_stats(s, &st);
    if ((c->given & row_bit("t-max")) && p->t_max > 0 && p->t_max < st.t)
        return snprintf(err, errlen, "cannot resume: %s: --t-max %.17g is below the time %.17g the checkpoint "
                                     "has reached", path, p->t_max, st.t), -1;
    if ((c->given & row_bit("max-events")) && p->max_events > 0 && p->max_events < st.events)
        return snprintf(err, errlen, "cannot resume: %s: --max-events %" PRIu64 " is below the %" PRIu64
                                     " events the checkpoint has run", path, p->max_events, st.events), -1;
    if ((c->given & row_bit("max-stuck")) && p->max_stuck > 0 && p->max_stuck < st.stuck)
        return snprintf(err, errlen, "cannot resume: %s: --max-stuck %" PRIu64 " is below the %" PRIu64
                                     " particles stuck in the checkpoint", path, (uint64_t)p->max_stuck, st.stuck), -1;
    return 0;
}

/* The event model's checkpoint names in dir, newest first. */
static const char *const ckpt_names[2] = {"checkpoint.h5", "checkpoint.prev.h5"};

/* --resume FILE: the names of its folder dir that the resume's writes move
 * on ahead of it (checkpoint.h5 ahead of checkpoint.prev.h5, both ahead of
 * a file under another name, none ahead of checkpoint.h5 itself), each
 * loaded with every check, one at a time, before the file named. A valid
 * one refuses the resume (its writes would push it out: the first moves
 * checkpoint.h5 to checkpoint.prev.h5, the second drops it); a damaged one
 * gets its bit in *bad (1 checkpoint.h5, 2 checkpoint.prev.h5) and why in
 * why, to go aside once the file named has loaded (set_aside_ahead). Until
 * session 31 a file named was resumed with its folder as it was: named
 * checkpoint.prev.h5 past a damaged checkpoint.h5, the first write removed
 * it and kept the damaged file as checkpoint.prev.h5. *is_prev: the file is
 * checkpoint.prev.h5. 0, or 2 with the line printed. */
static int named_ahead(const char *file, const char *dir, int *bad, int *is_prev, char *why, size_t whylen)
{
    struct stat sf, sn;
    char p[2][4200];
    int ahead = 2;
    *bad = *is_prev = 0;
    if (stat(file, &sf) != 0 || !S_ISREG(sf.st_mode)) return 0; /* the load says why */
    for (int k = 0; k < 2; k++) {
        snprintf(p[k], sizeof p[k], "%s/%s", dir, ckpt_names[k]);
        if (ahead == 2 && lstat(p[k], &sn) == 0 && sn.st_dev == sf.st_dev && sn.st_ino == sf.st_ino) ahead = k;
    }
    *is_prev = ahead == 1;
    for (int k = 0; k < ahead; k++) {
        if (lstat(p[k], &sn) != 0 && errno == ENOENT) continue;
        ev_series ser = {0};
        char err[600];
        ev_sim *s = ev_checkpoint_load(p[k], &ser, err, sizeof err);
        ev_series_free(&ser);
        char what[1200];
        if (!s && cli_foreign_checkpoint(p[k], "event", what, sizeof what)) {
            fprintf(stderr, "pdla: cannot resume: %s: %s is %s that the checkpoints of this resume would push "
                    "out; move %s out of %s to go on from %s\n", file, p[k], what, p[k], dir, file);
            return 2;
        }
        if (!s) {
            if (!*bad) snprintf(why, whylen, "%s", err);
            *bad |= 1 << k;
            continue;
        }
        ev_free(s);
        fprintf(stderr, "pdla: cannot resume: %s: %s is a %svalid checkpoint that the checkpoints of this resume "
                "would push out; resume the newest with --resume %s, or move %s out of %s to go on from %s\n",
                file, p[k], ahead < 2 ? "newer " : "", dir, p[k], dir, file);
        return 2;
    }
    return 0;
}

/* The damaged names named_ahead found (bits of bad) go aside, kept
 * (pdla_rundir_set_aside), the directory synced. 0, or 1 with the line
 * printed. */
static int set_aside_ahead(const char *dir, int bad)
{
    char name[4200], kept[4200], err[4600];
    for (int k = 0; k < 2; k++) {
        if (!(bad & 1 << k)) continue;
        snprintf(name, sizeof name, "%s/%s", dir, ckpt_names[k]);
        if (pdla_rundir_set_aside(dir, name, kept, sizeof kept, err, sizeof err) != PDLA_OK) {
            fprintf(stderr, "pdla: cannot resume: %s\n", err);
            return 1;
        }
        if (kept[0]) fprintf(stderr, "pdla: note: %s set aside as %s\n", name, kept);
    }
    if (bad && pdla_rundir_fsync(dir) != 0) {
        fprintf(stderr, "pdla: cannot sync directory %s: %s\n", dir, strerror(errno));
        return 1;
    }
    return 0;
}

/* What a resume leaves to do to its folder once it is accepted
 * (order_folder): a resume refused for what it asks (a changed parameter, a
 * stop passed) is one line and leaves the folder as it was, as the DLA
 * command's; until session 31 the set-aside and the promotion came first,
 * with their notes. */
typedef struct ev_order {
    int promote;     /* checkpoint.prev.h5 becomes checkpoint.h5 (promote_previous) */
    int bad;         /* named_ahead's damaged names, to go aside (set_aside_ahead) */
    char note[5000]; /* what was skipped and why (names of 4000 bytes) */
} ev_order;

/* The checkpoint --resume names, loaded (its path into path): a run
 * directory's checkpoint.h5, or past a damaged one its checkpoint.prev.h5
 * (then promoted); or the file named, whose folder is then put in order
 * as after that fallback: checkpoint.prev.h5 named becomes checkpoint.h5
 * too, damaged names ahead of another file go aside (named_ahead). What to
 * do to the folder goes into *o. NULL with the line printed. */
static ev_sim *load_checkpoint(const ev_cli *c, ev_series *ser, const char *dir, int is_dir, char *path,
                               size_t plen, ev_order *o)
{
    /* each a path (a run directory of up to 4000 bytes) and its reason,
     * whole: at 600 bytes a run directory of ~580 bytes lost both */
    char err[4800], err2[4800] = "";
    int is_prev = 0;
    memset(o, 0, sizeof *o);
    /* A directory or a device as checkpoint.prev.h5 is the user's: each
     * write of the resume failed to remove it, after the whole run (exit
     * 1). Refused before anything, as one under checkpoint.h5. */
    struct stat sp;
    snprintf(path, plen, "%s/%s", dir, ckpt_names[1]);
    if (stat(path, &sp) == 0 && !S_ISREG(sp.st_mode)) {
        fprintf(stderr, "pdla: cannot resume: %s is %s, not a checkpoint; the checkpoints of this resume would "
                "replace it (move it away to resume)\n", path,
                S_ISDIR(sp.st_mode) ? "a directory" : "not a regular file");
        return NULL;
    }
    if (!is_dir && named_ahead(c->resume, dir, &o->bad, &is_prev, err2, sizeof err2)) return NULL;
    if (is_dir) snprintf(path, plen, "%s/checkpoint.h5", dir);
    else snprintf(path, plen, "%s", c->resume);
    ev_sim *s = ev_checkpoint_load(path, ser, err, sizeof err);
    if (!s && !is_dir) { /* the file named: no other to fall back on */
        fprintf(stderr, "pdla: cannot resume: %s\n", err);
        return NULL;
    }
    const int fell_back = !s; /* a directory's checkpoint.h5 unusable */
    char what[1200];
    const int foreign = fell_back ? cli_foreign_checkpoint(path, "event", what, sizeof what) : 0;
    if (foreign) { /* not damaged: kept, not fallen back past */
        fprintf(stderr, "pdla: cannot resume: %s is %s, not an event checkpoint (%s)\n", path, what,
                foreign == 1 ? "resume it with --model" : "move it away to resume from checkpoint.prev.h5");
        return NULL;
    }
    if (fell_back) {
        snprintf(path, plen, "%s/checkpoint.prev.h5", dir);
        s = ev_checkpoint_load(path, ser, err2, sizeof err2);
        if (!s) { /* both reasons: the first alone hid why the fallback failed */
            fprintf(stderr, "pdla: cannot resume: %s; %s\n", err, err2);
            return NULL;
        }
        snprintf(o->note, sizeof o->note, "pdla: %s; resuming from the previous checkpoint", err);
    } else if (o->bad) {
        snprintf(o->note, sizeof o->note, "pdla: note: %s; resuming from %s", err2, path);
    }
    /* checkpoint.prev.h5 named: checkpoint.h5 is damaged or missing (a
     * valid one refused the resume), and the first write would remove the
     * file named before its own is in place */
    o->promote = fell_back || is_prev;
    return s;
}

/* The folder put in order for the accepted resume (load_checkpoint's *o),
 * its notes said. 0, or 1 with the line printed. */
static int order_folder(const char *dir, const ev_order *o)
{
    if (o->note[0]) fprintf(stderr, "%s\n", o->note);
    return o->promote ? promote_previous(dir) : set_aside_ahead(dir, o->bad);
}

/* --resume PATH: a run directory (its checkpoint.h5, or the previous one if
 * that is unusable) or one checkpoint file, as the DLA and DLCA commands
 * take; the run directory, locked, is then the file's folder. */
static ev_sim *load_resume(ev_cli *c, ev_series *ser, char *dir, size_t len, int *rc)
{
    struct stat st;
    if (stat(c->resume, &st) != 0) {
        fprintf(stderr, "pdla: cannot resume from '%s': %s\n", c->resume, strerror(errno));
        return NULL;
    }
    const int is_dir = S_ISDIR(st.st_mode);
    /* A killed run's temporary file named (or a user's copy so named): the
     * stale-file sweep below removed it before it was read, so a resume
     * from it lost the file. Refused untouched, as the DLA command does. */
    if (!is_dir && cli_refuse_temp_resume(c->resume)) return NULL;
    snprintf(dir, len, "%s", c->resume);
    char *slash = is_dir ? NULL : strrchr(dir, '/');
    if (!is_dir && !slash) snprintf(dir, len, ".");
    else if (slash) slash[slash == dir ? 1 : 0] = '\0';
    /* Locked before the checkpoint is read: the run writing it may still be
     * going. Refused on any failure, not only a lock held elsewhere: on
     * ENOLCK (a file system without locks) the resume ran and wrote its
     * checkpoints and cluster.h5 there unlocked, as the DLA command never did. */
    char lerr[600];
    if (pdla_rundir_lock(dir, &c->lock, lerr, sizeof lerr) != PDLA_OK) {
        fprintf(stderr, "pdla: cannot resume: %s\n", lerr);
        return NULL;
    }
    /* a link to a temporary name: the sweep below left it dangling, and
     * the resume fell back to checkpoint.prev.h5 (rundir.h) */
    if (cli_refuse_temp_links(dir)) return NULL;
    (void)remove_stale(dir, 0);
    if (dir_takes_files(dir)) return NULL;
    char path[4200];
    ev_order order;
    ev_sim *s = load_checkpoint(c, ser, dir, is_dir, path, sizeof path, &order);
    if (!s) return NULL;
    /* the table's resume rule: stop conditions may change, the rest must match */
    ev_params *p = ev_params_of(s);
    size_t np;
    const pdla_param_desc *t = ev_param_table(&np);
    char e[4600]; /* a stop passed names the checkpoint's path */
    int bad = pdla_param_check_asked(t, np, c->given, p, &c->p, e, sizeof e);
    if (!bad) pdla_param_apply_resumable(t, np, c->given, p, &c->p);
    if (bad || ev_params_check(p, e, sizeof e) || ev_stop_possible(s, e, sizeof e) ||
        stop_passed(c, s, path, e, sizeof e)) {
        fprintf(stderr, "pdla: %s\n", e);
        ev_free(s);
        ev_series_free(ser);
        return NULL;
    }
    if (order_folder(dir, &order)) {
        *rc = 1; /* the disk's failure, not bad use (until session 31 exit 2) */
        ev_free(s);
        ev_series_free(ser);
        return NULL;
    }
    c->checkpoint = 1; /* a resumed run keeps checkpointing */
    /* and on the interrupted run's schedule unless --checkpoint-every is
     * given (0: none), as the DLA command (session 26): a bare --resume
     * after --checkpoint-every 30m wrote only its final checkpoint, so a
     * crash after the resume lost all it had run */
    double every;
    if (!c->schedule_given && ev_checkpoint_every(s, &every)) c->checkpoint_every = every;
    return s;
}

/* Help printed: 0, or 1 when stdout failed. */
static int print_help(void)
{
    char *h = ev_help_text();
    if (!h) return 1;
    fputs(h, stdout);
    free(h);
    return fflush(stdout) ? 1 : 0;
}

/* The simulation to run: resumed from c->resume, or new with its run
 * directory made. NULL with *rc the exit code (the message printed). */
static ev_sim *start_sim(ev_cli *c, ev_series *ser, char *dir, size_t len, int *rc)
{
    *rc = 2;
    if (c->resume) return load_resume(c, ser, dir, len, rc);
    char err[512];
    ev_sim *s = ev_create(&c->p, err, sizeof err);
    if (!s) {
        fprintf(stderr, "pdla: %s\n", err);
        return NULL;
    }
    /* One writer per run directory (as the DLA command): two runs on one
     * directory wrote over each other's cluster.h5.tmp and both lost it. */
    int drc = make_dir(c, dir, len);
    if (!drc && pdla_rundir_lock(dir, &c->lock, err, sizeof err) != PDLA_OK) {
        fprintf(stderr, "pdla: %s\n", err);
        drc = 2;
    }
    /* --force --out X/.checkpoint.h5.new, a link to X: the sweep below
     * removed the link under the run (rundir.h) */
    if (!drc && cli_refuse_temp_out(dir)) drc = 2;
    if (!drc) drc = dir_takes_files(dir);
    if (!drc) drc = remove_stale(dir, 1);
    if (drc) {
        ev_free(s);
        *rc = drc;
        return NULL;
    }
    return s;
}

/* The checkpoint (when asked), cluster.h5 and its sidecars: 0 or 1 with
 * the failures noted in f. */
static int write_outputs(const ev_cli *c, ev_sim *s, const ev_series *ser, const char *dir,
                         const char *cmd, int why, cli_fail *f)
{
    char path[4200], err[512];
    snprintf(path, sizeof path, "%s/cluster.h5", dir);
    int rc = 0;
    if (c->checkpoint && ev_checkpoint_write(s, ser, dir, cmd, err, sizeof err)) {
        cli_fail_note(f, "the final checkpoint", "%s", err);
        rc = 1;
    }
    const int wrc = ev_write_h5(s, ser, path, cmd, why, err, sizeof err);
    if (wrc) { /* 1: in place but its directory not synced: the sidecars still follow it */
        cli_fail_note(f, "cluster.h5", "%s", err);
        rc = 1;
    }
    if (wrc >= 0 && ev_write_xdmf(s, path, err, sizeof err)) {
        cli_fail_note(f, "its sidecars", "%s", err);
        rc = 1;
    }
    return rc;
}

/* The rates use this session's events and collisions (before: the run's
 * since its start, so a resumed run's read 2.7e9 collisions/s): `at0` is
 * the stats when this session began. */
static void print_summary(const ev_cli *c, ev_sim *s, const char *dir, int why, double cpu, const ev_stats *at0)
{
    ev_stats st;
    ev_get_stats(s, &st);
    const double coll = (double)(st.collisions - at0->collisions), events = (double)(st.events - at0->events);
    char bath[64] = "";
    if (ev_sticky_count(s) < ev_count(s))
        snprintf(bath, sizeof bath, " (%zu of a bath kind)", ev_count(s) - ev_sticky_count(s));
    printf("model event, %dd, %zu particles%s, box %.6g (%s walls)\n"
           "stopped: %s at time %.6g\n"
           "stuck %" PRIu64 ", events %" PRIu64 ", collisions %" PRIu64 ", wall hits %" PRIu64
           "\ncpu %.3f s, %.3g collisions/s, %.3g us/event, peak RSS %.1f MB\nwrote %s/cluster.h5\n",
           ev_dim(s), ev_count(s), bath, st.box,
           ev_params_of(s)->walls == EV_WALLS_PERIODIC ? "periodic" : "elastic",
           ev_stop_name(why), st.t, st.stuck, st.events, st.collisions, st.wall_hits, cpu,
           cpu > 0 ? coll / cpu : 0.0, events > 0 ? 1e6 * cpu / events : 0.0, peak_rss() / 1e6, dir);
    if (c->checkpoint)
        printf("checkpoint %s/checkpoint.h5%s\n", dir,
               why == EV_STOP_INTERRUPT ? " (continue with: pdla --model event --resume DIR)" : "");
}

/* The ticker of the run: progress lines and interval checkpoints. */
static void ticker_init(ev_ticker *tk, ev_cli *c, ev_series *ser, cli_fail *fail, ev_sim *s, const char *dir,
                        const char *cmd)
{
    memset(tk, 0, sizeof *tk);
    tk->c = c;
    tk->ser = ser;
    tk->fail = fail;
    tk->dir = dir;
    tk->cmd = cmd;
    tk->enabled = c->progress == 1 || (c->progress == -1 && !c->quiet && isatty(2));
    tk->tty = isatty(2);
    tk->interval = tk->tty ? 0.2 : 5.0;
    tk->t_start = tk->t_last = tk->t_ckpt = pdla_clock_seconds();
    ev_stats st0;
    ev_get_stats(s, &st0);
    tk->ev_start = tk->ev_last = st0.events;
    ev_set_tick(s, ticker, tk);
}

/* The command after parsing; cmd, the command line as typed (taken before
 * getopt permutes argv), for the files' provenance. */
static int event_run(int argc, char **argv, const char *cmd)
{
    ev_cli c;
    memset(&c, 0, sizeof c);
    c.progress = -1;
    c.lock = -1;
    const int prc = parse(argc, argv, &c);
    if (prc < 0) {
        fprintf(stderr, "pdla: %s\n", c.err);
        return 2;
    }
    if (prc == 1) return print_help();
    if (pdla_hdf5_quiet()) {
        fprintf(stderr, "pdla: cannot silence HDF5\n");
        return 1;
    }
    ev_series ser = {0};
    char dir[4096];
    int rc;
    /* Before the start: a signal while the run directory is made (a slow
     * disk) is then seen at the first event, not lost or fatal. */
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    ev_sim *s = start_sim(&c, &ser, dir, sizeof dir, &rc);
    if (!s) return rc;
    ev_set_checkpoint_every(s, c.checkpoint_every); /* recorded in each checkpoint, for a later bare --resume */
    ev_ticker tk;
    cli_fail fail = {"", ""};
    ticker_init(&tk, &c, &ser, &fail, s, dir, cmd);
    ev_stats at0;
    ev_get_stats(s, &at0);
    const clock_t c0 = clock();
    const int why = ev_run_series(s, &ser, &ev_stop_flag);
    const double cpu = (double)(clock() - c0) / CLOCKS_PER_SEC;
    if (tk.enabled) progress_line(&tk, s, pdla_clock_seconds(), 1);
    rc = tk.failed;
    if (why < 0) {
        cli_fail_note(&fail, NULL, "%s", "out of memory for the series");
        rc = 1;
    } else if (write_outputs(&c, s, &ser, dir, cmd, why, &fail)) {
        rc = 1;
    }
    if (fail.why[0]) fprintf(stderr, "pdla: %s%s%s\n", fail.why, fail.also[0] ? "; also failed: " : "", fail.also);
    else if (ev_stop_signal && why != EV_STOP_INTERRUPT) /* during the final writes: said, as the DLA command does */
        fprintf(stderr, "pdla: signal received after the run had finished; output complete\n");
    if (!rc && !c.quiet) print_summary(&c, s, dir, why, cpu, &at0);
    ev_series_free(&ser);
    ev_free(s);
    pdla_rundir_unlock(c.lock);
    /* Interrupted with checkpoints on: the run is saved, exit 0 (as the
     * DLA CLI); without: the state is lost but cluster.h5 written, and pdla
     * ends by the same signal (130/143), so a calling shell sees it. A
     * signal after the run's own stop interrupted nothing (why says so). */
    if (why == EV_STOP_INTERRUPT && !rc && !c.checkpoint) {
        const int sig = ev_stop_signal ? (int)ev_stop_signal : SIGINT;
        fflush(NULL);
        signal(sig, SIG_DFL);
        raise(sig);
        return 128 + sig;
    }
    return rc;
}

int event_cmd_main(int argc, char **argv)
{
    char *const cmd = cli_command_line(NULL, argc, argv);
    if (!cmd) {
        fprintf(stderr, "pdla: out of memory\n");
        return 1;
    }
    const int rc = event_run(argc, argv, cmd);
    free(cmd);
    return rc;
}
