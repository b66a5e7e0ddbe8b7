/*
 * ens_cmd.c - `pdla ensemble`: M independent clusters on T threads into
 * DIR/ensemble.h5 (include/pdla/ensemble.h does the work).
 *
 * Options: --clusters M and --keep-positions are this command's own; every
 * other option is read by the growth command's parser (parse.c: the
 * parameter table's options, --out, --force, --resume, --scene, -q,
 * --progress), so the growth options, their checks and messages are the same
 * as for `pdla`. --threads T is the number of clusters grown at once (0: one
 * per physical core); each cluster grows serially.
 *
 * Exit status: 0 done; 1 runtime failure; 2 bad usage or input, before
 * anything is written. SIGINT/SIGTERM stop the ensemble: the clusters
 * finished stay in DIR/clusters.journal (resume with --resume DIR), those in
 * flight are lost, and pdla ends by the same signal. A signal that arrives
 * once every cluster is recorded (the last record's sync, the write of
 * ensemble.h5) stops nothing: ensemble.h5 is written, success is reported
 * and the exit status is 0 (1 if the write failed), as for `pdla` itself -
 * ending by the signal after printing success told a batch script to
 * resubmit a finished job.
 *
 * MPI (built with PDLA_WITH_MPI; include/pdla/ensemble_mpi.h has the
 * design): started by an MPI launcher with more than one rank (mpirun,
 * srun --mpi=pmix: its environment says so before MPI_Init), rank 0 does
 * everything a single process does (checks, journal, ensemble.h5, output)
 * and the other ranks only grow clusters. Every rank parses the same argv,
 * so a usage error is found by all and printed by rank 0 alone; after
 * that the other ranks wait for rank 0's verdict (pdla_ens_mpi_share).
 * With one rank, or no launcher, MPI is not initialized at all.
 */
#include <dirent.h>
#include <errno.h>
#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cmdline.h"
#include "ens_cmd.h"
#include "parse.h"
#include "pdla/ensemble.h"
#include "pdla/pdla.h"
#include "progress.h"
#include "rundir.h"
#ifdef PDLA_WITH_MPI
#include "pdla/ensemble_mpi.h"
#endif

enum { EXIT_RUNTIME = 1, EXIT_USAGE = 2 };

static volatile sig_atomic_t stop_signal;
static void on_signal(int sig) { stop_signal = sig; }
/* The journal scan's stop flag (pdla_ens_journal_open_stoppable). */
static int scan_stopped(void *user)
{
    (void)user;
    return stop_signal != 0;
}

static int install_signals(void)
{
    static const int sigs[] = {SIGINT, SIGTERM};
    for (size_t i = 0; i < 2; i++) {
        struct sigaction old, sa;
        if (sigaction(sigs[i], NULL, &old)) return -1;
        if (old.sa_handler == SIG_IGN) continue;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_signal;
        sigemptyset(&sa.sa_mask);
        sa.sa_flags = SA_RESETHAND | SA_RESTART;
        if (sigaction(sigs[i], &sa, NULL)) return -1;
    }
    return 0;
}

static void print_help(void)
{
    printf("Usage: pdla ensemble --clusters M --target N --out DIR [OPTION]...\n"
           "       pdla ensemble --resume DIR [--threads T] [--clusters M2]\n"
           "Grow M independent DLA clusters of N particles, T at a time, into DIR/ensemble.h5:\n"
           "per cluster its R_g(N) series on a shared log grid, final R_g, R_ext, D_f fit,\n"
           "seed and timings; the ensemble statistics (`pdla analyze DIR/ensemble.h5`).\n"
           "Cluster i is the serial cluster of seed S + i (--seed S): the same whatever\n"
           "the threads or the order. Finished clusters are journaled in\n"
           "DIR/clusters.journal as they finish; after a crash or a signal\n"
           "`pdla ensemble --resume DIR` grows only the missing ones.\n\n"
           "  --clusters M        number of clusters (>= 1)\n"
           "  --threads T         clusters grown at once (default 1; 0: one per physical core)\n"
           "  --keep-positions    also store every cluster's positions (/clusters/positions,\n"
           "                      cluster i in rows i*N..i*N+N-1, chunked by cluster) and\n"
           "                      DIR/ensemble.xdmf2 for ParaView (one block per cluster)\n"
           "  --compress L        deflate level 0..9 of the kept positions, with shuffle\n"
           "                      (default 4; 0: uncompressed); h5py and h5dump read both;\n"
           "                      a resume keeps the level the ensemble started with\n"
           "  --out DIR           ensemble directory (must not exist unless --force)\n"
           "  --force             write into an existing DIR (its old ensemble is removed)\n"
           "  --resume DIR        go on with DIR's ensemble; growth options given must match;\n"
           "                      --clusters M2 larger than its M extends it to M2 clusters\n"
           "  -q, --progress, --no-progress, --scene FILE: as for pdla\n"
           "Every growth option of `pdla --help` (--dim, --target, --seed, --resolution, ...)\n"
           "applies to each cluster; --bind, checkpoints, --stats-json and --no-output do not.\n"
#ifdef PDLA_WITH_MPI
           "Across machines: `mpirun -n R pdla ensemble ...` (this build has MPI): rank 0\n"
           "writes DIR, every rank grows clusters on its T threads; give each rank T cores\n"
           "(e.g. --map-by ppr:1:node:PE=T) or --bind-to none.\n"
#else
           "This build has no MPI (meson option -Dmpi); under mpirun it refuses to start.\n"
#endif
           );
}

typedef struct ens_args {
    uint64_t clusters;
    int clusters_given, keep, keep_given, help;
    int gzip, gzip_given; /* deflate level of the kept positions; given on the command line */
} ens_args;

/* Take this command's own options out of argv (into a, rest into *rest with
 * rest[0] = "pdla ensemble"); 0, or -1 with err. */
static int split_args(int argc, char **argv, ens_args *a, char **rest, int *nrest, char *err, size_t errlen)
{
    memset(a, 0, sizeof *a);
    a->gzip = PDLA_ENS_GZIP_DEFAULT;
    int n = 0;
    rest[n++] = "pdla ensemble";
    for (int i = 1; i < argc; i++) {
        const char *s = argv[i];
        if (!strcmp(s, "--")) {
            while (i < argc) rest[n++] = argv[i++];
            break;
        }
        const char *v = NULL;
        if (!strcmp(s, "--clusters")) {
            if (i + 1 >= argc) return snprintf(err, errlen, "option --clusters needs a value (M)"), -1;
            v = argv[++i];
        } else if (!strncmp(s, "--clusters=", 11)) {
            v = s + 11;
        } else if (!strcmp(s, "--compress") || !strncmp(s, "--compress=", 11)) {
            const char *l = s[10] == '=' ? s + 11 : i + 1 < argc ? argv[++i] : NULL;
            if (!l) return snprintf(err, errlen, "option --compress needs a value (L)"), -1;
            if (l[0] < '0' || l[0] > '9' || l[1])
                return snprintf(err, errlen, "invalid value '%.48s' for --compress: want a level 0..9", l), -1;
            a->gzip = l[0] - '0';
            a->gzip_given = 1;
            continue;
        } else if (!strcmp(s, "--keep-positions")) {
            a->keep = a->keep_given = 1;
            continue;
        } else if (!strcmp(s, "--help") || !strcmp(s, "-h")) {
            a->help = 1;
            continue;
        } else {
            rest[n++] = argv[i];
            continue;
        }
        const char *why = cli_parse_count(v, &a->clusters);
        if (why) return snprintf(err, errlen, "invalid value '%.48s' for --clusters: %s", v, why), -1;
        if (a->clusters == 0) return snprintf(err, errlen, "invalid value '%.48s' for --clusters: must be at least 1", v), -1;
        a->clusters_given = 1;
    }
    rest[n] = NULL;
    *nrest = n;
    return 0;
}

/* Leftovers of an interrupted writer, only names this command makes (hold
 * the directory's lock): the temporaries of clusters.journal,
 * ensemble.h5 and ensemble.xdmf2, and with old_outputs (a new ensemble with --force) the old
 * journal and file. */
static const char *const ens_temp_prefixes[] = {PDLA_ENS_JOURNAL_NAME ".tmp.", PDLA_ENS_FILE_NAME ".tmp.",
                                                 PDLA_ENS_SIDECAR_NAME ".tmp."};

/* Is name one that remove_named sweeps as a leftover? */
static int ens_temp_name(const char *name)
{
    for (size_t i = 0; i < sizeof ens_temp_prefixes / sizeof ens_temp_prefixes[0]; i++)
        if (!strncmp(name, ens_temp_prefixes[i], strlen(ens_temp_prefixes[i]))) return 1;
    return 0;
}

/* What remove_named sweeps for a new ensemble (--force): the leftovers
 * and the older ensemble's journal, file and sidecar. */
static int ens_new_swept(const char *name)
{
    return ens_temp_name(name) || !strcmp(name, PDLA_ENS_JOURNAL_NAME) || !strcmp(name, PDLA_ENS_FILE_NAME) ||
           !strcmp(name, PDLA_ENS_SIDECAR_NAME);
}

static void remove_named(const char *dir, int old_outputs)
{
    char p[4400];
    if (old_outputs) {
        snprintf(p, sizeof p, "%s/%s", dir, PDLA_ENS_JOURNAL_NAME);
        unlink(p);
        snprintf(p, sizeof p, "%s/%s", dir, PDLA_ENS_FILE_NAME);
        unlink(p);
        snprintf(p, sizeof p, "%s/%s", dir, PDLA_ENS_SIDECAR_NAME);
        unlink(p);
    }
    DIR *d = opendir(dir);
    if (!d) return;
    const struct dirent *de;
    while ((de = readdir(d)))
        if (ens_temp_name(de->d_name)) {
            snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
            unlink(p);
        }
    closedir(d);
}

typedef struct prog_ctx {
    progress prog;
    uint64_t base, total, particles_total;
} prog_ctx;

static int on_progress(void *user, uint64_t done, uint64_t particles)
{
    prog_ctx *c = user;
    if (stop_signal) return 1;
    progress_ensemble(&c->prog, c->base + done, c->total, particles, c->particles_total, 0);
    return 0;
}

/* The ranks and this process's rank an MPI launcher started, from the
 * environment it sets (OpenMPI's mpirun, MPICH/Slurm PMI, PMIx); 1 and 0
 * when there is none. */
static void launcher_ranks(long *size, long *rank)
{
    static const char *const sizes[] = {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_NTASKS"};
    static const char *const ranks[] = {"OMPI_COMM_WORLD_RANK", "PMI_RANK", "SLURM_PROCID"};
    *size = 1;
    *rank = 0;
    /* Slurm's variables count only under a PMI/PMIx launch (srun --mpi=...):
     * a plain srun of a serial program sets them too. */
    const int pmi = getenv("PMI_RANK") || getenv("PMIX_RANK") || getenv("OMPI_COMM_WORLD_RANK");
    for (size_t i = 0; i < 3; i++) {
        const char *v = getenv(sizes[i]);
        if (!v || (i == 2 && !pmi)) continue;
        const long n = strtol(v, NULL, 10);
        if (n > 1) {
            *size = n;
            const char *r = getenv(ranks[i]);
            *rank = r ? strtol(r, NULL, 10) : 0;
            return;
        }
    }
}

/* Writing ensemble.h5 holds the per-cluster columns and the R_g matrix in
 * memory: refuse before the growth (days, perhaps) an ensemble this
 * machine could never write. 0, or -1 with err. */
static int check_memory(const pdla_ens_config *c, char *err, size_t errlen)
{
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0) return 0; /* unknown: let the allocations decide */
    const double have = (double)pages * (double)page, need = (double)pdla_ens_memory_bytes(c);
    if (need <= have) return 0;
    snprintf(err, errlen, "%" PRIu64 " clusters of %" PRIu64 " particles need about %.3g GB of memory to write "
             "ensemble.h5, more than this machine's %.3g GB (fewer clusters or --rg-per-decade)",
             c->clusters, c->params.target, need / 1e9, have / 1e9);
    return -1;
}

static int refuse_options(const cli_options *o, char *err, size_t errlen)
{
    if (o->no_output) return snprintf(err, errlen, "--no-output does not apply to an ensemble"), -1;
    if (o->stats_json) return snprintf(err, errlen, "--stats-json does not apply to an ensemble"), -1;
    if (o->schedule_given || (o->checkpoint && !o->resume))
        return snprintf(err, errlen, "checkpoints do not apply to an ensemble (its journal records finished clusters)"), -1;
    if (o->given & PDLA_PARAM_BIND) return snprintf(err, errlen, "--bind does not apply to an ensemble"), -1;
    return 0;
}

#ifdef PDLA_WITH_MPI
/* A rank > 0: wait for rank 0's verdict, then grow what it hands out. Its
 * errors are its own (rank 0 reports the ensemble's). *grown: the ensemble
 * was grown to the end (a signal then stopped nothing on this rank either:
 * a batch system's SIGTERM to every rank while rank 0 writes ensemble.h5
 * must not end the workers by the signal and fail a finished job). */
static int worker_rank(int threads, int rank, int *grown)
{
    char err[1024];
    int verdict = 0;
    pdla_ens_config c;
    if (pdla_ens_mpi_share(&verdict, &c, err, sizeof err)) {
        fprintf(stderr, "pdla ensemble: rank %d: %s\n", rank, err);
        return EXIT_RUNTIME;
    }
    if (verdict) return verdict;
    prog_ctx pc;
    memset(&pc, 0, sizeof pc);
    progress_init(&pc.prog, stderr, 0, 0, 0);
    const int rc = pdla_ens_mpi_run_worker(&c, threads, on_progress, &pc, err, sizeof err);
    *grown = rc == PDLA_OK;
    if (rc == PDLA_OK || rc == PDLA_ESTOPPED) return rc ? EXIT_RUNTIME : 0;
    /* An MPI failure: pdla_ens_mpi_finalize ends the job. */
    fprintf(stderr, "pdla ensemble: rank %d: %s\n", rank, err);
    return EXIT_RUNTIME;
}
#endif

/* One `pdla ensemble` invocation: what the steps below share. */
typedef struct ens_cmd {
    ens_args a;
    cli_options o;
    pdla_ens_config asked;  /* the config the options describe */
    char dir[4096];
    int lock, mpi_rank, mpi_size;
    int verdict_pending;    /* MPI: rank 0 owes the other ranks its verdict */
    int grown;              /* every cluster recorded: a signal now stops nothing */
    pdla_ens_journal *j;
    char err[4600];
} ens_cmd;

#define GO_ON (-1)

/* Under an MPI launcher with more than one rank: MPI_Init (or, in a build
 * without MPI, a refusal). GO_ON or the exit status. */
static int start_mpi(ens_cmd *c)
{
    long launched, launched_rank;
    launcher_ranks(&launched, &launched_rank);
    (void)launched_rank;
    if (launched <= 1) return GO_ON;
#ifdef PDLA_WITH_MPI
    if (pdla_ens_mpi_init(&c->mpi_rank, &c->mpi_size, c->err, sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_RUNTIME;
    }
    return GO_ON;
#else
    (void)c;
    if (launched_rank == 0)
        fprintf(stderr, "pdla ensemble: started as %ld MPI ranks, but this pdla was built without MPI "
                        "(meson setup -Dmpi=enabled with libopenmpi-dev)\n", launched);
    return EXIT_USAGE;
#endif
}

/* The clusters-at-once count, checked against the growth parameters' range
 * for threads (the same words as pdla's --threads). 0, or -1 with err. */
static int check_threads(const cli_options *o, char *err, size_t errlen)
{
    if (!o->apart_threads_given) return 0;
    pdla_params p;
    pdla_params_default(&p);
    p.threads = (int)o->apart_threads; /* an int: set_value refused more than INT_MAX */
    return cli_check_params(&p, err, errlen) == CLI_PARSE_OK ? 0 : -1;
}

/* argv into c->a, c->o and c->asked (every rank parses; rank 0 prints).
 * GO_ON or the exit status (--help, a usage error). */
static int parse_all(ens_cmd *c, int argc, char **argv, char **rest)
{
    int nrest = 0;
    if (split_args(argc, argv, &c->a, rest, &nrest, c->err, sizeof c->err)) {
        if (c->mpi_rank == 0) fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_USAGE;
    }
    if (c->a.help) {
        if (c->mpi_rank == 0) print_help();
        return fflush(stdout) ? EXIT_RUNTIME : 0;
    }
    /* --threads (or a scene's `threads`) counts the clusters grown at once,
     * not a cluster's worker threads, so it stays out of the growth options
     * (there it would be refused beside --reference-walkers). */
    if (cli_parse_threads_apart(nrest, rest, &c->o, c->err, sizeof c->err) != CLI_PARSE_OK ||
        refuse_options(&c->o, c->err, sizeof c->err) || check_threads(&c->o, c->err, sizeof c->err)) {
        if (c->mpi_rank == 0)
            fprintf(stderr, "pdla ensemble: %s\n",
                    c->o.action == CLI_VERSION ? "--version: see pdla --version" : c->err);
        return EXIT_USAGE;
    }
    if (c->o.apart_threads_given) c->o.params.threads = (int)c->o.apart_threads;
    c->asked.params = c->o.params;
    c->asked.params.threads = 1;
    c->asked.params.bind = PDLA_BIND_NONE;
    c->asked.clusters = c->a.clusters;
    c->asked.keep_positions = c->a.keep;
    c->asked.deflate_level = c->a.gzip;
    return GO_ON;
}

/* A resume by a build that did not grow the journal's records, with
 * clusters to grow (missing, or more asked: `grow`): one note, and the
 * journal lists this build too (join_build: ensemble.h5 /ensemble builds),
 * so a mixed ensemble says so. The note comes first, before an extension
 * rewrites the journal (which keeps its list as it was). */
static void note_build(const ens_cmd *c, int grow)
{
    if (pdla_ens_journal_built_here(c->j) || !grow) return;
    const char *was = *pdla_ens_journal_builds(c->j) ? pdla_ens_journal_builds(c->j) : "unknown (not recorded)";
    fprintf(stderr, "pdla ensemble: note: %s/%s was grown by build %s; this build (%s) grows the rest: the same "
                    "law, not the same bits as an uninterrupted run (ensemble.h5 /ensemble builds lists them)\n",
            c->dir, PDLA_ENS_JOURNAL_NAME, was, pdla_build_revision());
}

/* Before appending: 0, or -1 with the line printed. */
static int join_build(ens_cmd *c)
{
    if (pdla_ens_journal_count(c->j) >= pdla_ens_journal_config(c->j)->clusters) return 0;
    const int rc = pdla_ens_journal_join(c->j, c->err, sizeof c->err);
    if (rc) fprintf(stderr, "pdla ensemble: %s\n", c->err);
    return rc ? -1 : 0;
}

/* What the journal scan of a resume skipped, cut or refused: notes. */
static void print_scan_notes(const ens_cmd *c)
{
    if (pdla_ens_journal_damaged_bytes(c->j))
        fprintf(stderr, "pdla ensemble: note: skipping %" PRIu64 " damaged bytes inside %s/%s (the clusters "
                        "they held grow again; the records after them count)\n",
                pdla_ens_journal_damaged_bytes(c->j), c->dir, PDLA_ENS_JOURNAL_NAME);
    if (pdla_ens_journal_torn_bytes(c->j))
        fprintf(stderr, "pdla ensemble: note: cutting a torn record of %" PRIu64 " bytes (a cluster in flight)\n",
                pdla_ens_journal_torn_bytes(c->j));
    if (pdla_ens_journal_refused(c->j)[0]) /* the record the bytes above held, when it was readable */
        fprintf(stderr, "pdla ensemble: note: a record was refused (%s); a cluster with no valid record grows again\n",
                pdla_ens_journal_refused(c->j));
}

/* --clusters M2 above the journal's: rewrite it for M2 clusters and reopen
 * it (c->j). GO_ON or the exit status with the line printed. */
static int extend_journal(ens_cmd *c)
{
    pdla_ens_journal *wide = NULL;
    const int rc2 = pdla_ens_journal_extend(c->j, c->a.clusters, &wide, c->err, sizeof c->err);
    c->j = wide; /* the old one is closed either way */
    if (rc2 == PDLA_ESTOPPED) { /* in the reopen's scan, after the rewrite */
        fprintf(stderr, "pdla ensemble: stopped by signal after extending %s/%s to %" PRIu64 " clusters; resume "
                        "with pdla ensemble --resume %s\n", c->dir, PDLA_ENS_JOURNAL_NAME, c->a.clusters, c->dir);
        return EXIT_RUNTIME;
    }
    if (rc2) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_RUNTIME;
    }
    return GO_ON;
}

/* --resume DIR: lock, open and check the journal, make it appendable.
 * GO_ON or the exit status. */
static int open_resume(ens_cmd *c)
{
    snprintf(c->dir, sizeof c->dir, "%s", c->o.resume);
    for (size_t len = strlen(c->dir); len > 1 && c->dir[len - 1] == '/';) c->dir[--len] = '\0';
    if (pdla_rundir_lock(c->dir, &c->lock, c->err, sizeof c->err) != PDLA_OK) {
        fprintf(stderr, "pdla ensemble: cannot resume: %s\n", c->err);
        return EXIT_USAGE;
    }
    /* A link to a leftover name (clusters.journal -> clusters.journal.tmp.5),
     * or through one: the sweep below removed the file, and the journal
     * with every cluster recorded was lost (rundir.h). */
    if (cli_refuse_links_through(c->dir, ens_temp_name, "pdla ensemble")) return EXIT_USAGE;
    /* The scan of a large (or forged) journal may take long: a signal
     * stops it, and it has written nothing. A signal after its last poll
     * stops here, before the journal is touched (a torn tail cut, an
     * extension). */
    const int rc = pdla_ens_journal_open_stoppable(c->dir, scan_stopped, NULL, &c->j, c->err, sizeof c->err);
    if (rc == PDLA_ESTOPPED || (rc == PDLA_OK && stop_signal)) {
        fprintf(stderr, "pdla ensemble: stopped by signal while reading %s/%s (nothing in it was changed); resume "
                        "with pdla ensemble --resume %s\n", c->dir, PDLA_ENS_JOURNAL_NAME, c->dir);
        return EXIT_RUNTIME;
    }
    if (rc) {
        fprintf(stderr, "pdla ensemble: cannot resume: %s\n", c->err);
        return rc == PDLA_ENOMEM ? EXIT_RUNTIME : EXIT_USAGE;
    }
    /* --clusters M2 > M extends the ensemble (cluster i is seed S + i
     * whatever M, so the recorded clusters stay valid); fewer would drop
     * finished clusters. */
    const uint64_t had = pdla_ens_journal_config(c->j)->clusters;
    const int extend = c->a.clusters_given && c->a.clusters > had;
    if (c->a.clusters_given && c->a.clusters < had) {
        fprintf(stderr, "pdla ensemble: cannot resume: the ensemble has --clusters %" PRIu64 ", asked %" PRIu64
                        " (an ensemble can be extended, not shrunk)\n", had, c->a.clusters);
        return EXIT_USAGE;
    }
    if (pdla_ens_config_compare(pdla_ens_journal_config(c->j), &c->asked, c->o.given, 0, c->a.keep_given, c->err,
                                sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_USAGE;
    }
    pdla_ens_config wider = *pdla_ens_journal_config(c->j);
    wider.clusters = c->a.clusters;
    if (extend && pdla_ens_config_check(&wider, c->err, sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: cannot extend to --clusters %" PRIu64 ": %s\n", c->a.clusters, c->err);
        return EXIT_USAGE;
    }
    if (check_memory(extend ? &wider : pdla_ens_journal_config(c->j), c->err, sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: cannot %s: %s\n", extend ? "extend" : "resume", c->err);
        return EXIT_USAGE;
    }
    if (access(c->dir, W_OK)) {
        fprintf(stderr, "pdla ensemble: cannot resume: '%s' is not writable: %s\n", c->dir, strerror(errno));
        return EXIT_USAGE;
    }
    print_scan_notes(c);
    note_build(c, extend || pdla_ens_journal_count(c->j) < pdla_ens_journal_config(c->j)->clusters);
    remove_named(c->dir, 0);
    if (extend) {
        const int xr = extend_journal(c);
        if (xr != GO_ON) return xr;
    }
    if (pdla_ens_journal_begin_append(c->j, c->err, sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_RUNTIME;
    }
    if (join_build(c)) return EXIT_RUNTIME;
    if (!c->o.quiet)
        fprintf(stderr, "pdla ensemble: resuming %s: %" PRIu64 " of %" PRIu64 " clusters recorded%s\n", c->dir,
                pdla_ens_journal_count(c->j), pdla_ens_journal_config(c->j)->clusters,
                extend ? " (extended)" : "");
    return GO_ON;
}

/* A new ensemble: check, make DIR, lock it, create the journal. GO_ON or
 * the exit status. */
static int open_new(ens_cmd *c, int threads)
{
    const cli_options *const o = &c->o;
    if (!c->a.clusters_given) {
        fprintf(stderr, "pdla ensemble: --clusters M is required (see pdla ensemble --help)\n");
        return EXIT_USAGE;
    }
    if (!o->out_dir) {
        fprintf(stderr, "pdla ensemble: --out DIR is required\n");
        return EXIT_USAGE;
    }
    if (pdla_ens_config_check(&c->asked, c->err, sizeof c->err) || check_memory(&c->asked, c->err, sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_USAGE;
    }
    if (threads == 0 && pdla_ens_threads(0) <= 0) {
        fprintf(stderr, "pdla ensemble: --threads 0: hwloc could not read the machine topology\n");
        return EXIT_USAGE;
    }
    if (cli_path_fits("the run directory name", o->out_dir, c->err, sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_USAGE;
    }
    snprintf(c->dir, sizeof c->dir, "%s", o->out_dir);
    for (size_t len = strlen(c->dir); len > 1 && c->dir[len - 1] == '/';) c->dir[--len] = '\0';
    struct stat st;
    if (!o->force && lstat(c->dir, &st) == 0) {
        fprintf(stderr, "pdla ensemble: '%s' already exists (use --force to write into it)\n", c->dir);
        return EXIT_USAGE;
    }
    int e = cli_mkdir_parents(c->dir); /* as the model commands */
    if (!e && mkdir(c->dir, 0777)) e = errno;
    if (e && !(e == EEXIST && o->force && stat(c->dir, &st) == 0 && S_ISDIR(st.st_mode))) {
        fprintf(stderr, "pdla ensemble: cannot create '%s': %s\n", c->dir, strerror(e));
        return EXIT_USAGE;
    }
    if (pdla_rundir_lock(c->dir, &c->lock, c->err, sizeof c->err) != PDLA_OK) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_USAGE;
    }
    /* --force --out E/ensemble.h5.tmp.7 (or E/ensemble.h5) with that a
     * link to E: the sweep below removed the link, and the journal's
     * creation failed */
    if (cli_refuse_out_through(c->dir, ens_new_swept, ens_temp_name, "pdla ensemble")) return EXIT_USAGE;
    remove_named(c->dir, 1);
    if (pdla_ens_journal_create(c->dir, &c->asked, &c->j, c->err, sizeof c->err)) {
        fprintf(stderr, "pdla ensemble: %s\n", c->err);
        return EXIT_RUNTIME;
    }
    return GO_ON;
}

/* Grow the clusters the journal lacks (on this process, or over the MPI
 * ranks), then write ensemble.h5. The exit status. */
static int grow_and_write(ens_cmd *c, int threads, const char *cmd, double t0)
{
    const pdla_ens_config *cfg = pdla_ens_journal_config(c->j);
    char *const err = c->err;
    const size_t errlen = sizeof c->err;
    prog_ctx pc;
    const int tty = isatty(STDERR_FILENO);
    progress_init(&pc.prog, stderr, c->o.progress == 1 || (c->o.progress == -1 && !c->o.quiet && tty), tty, 0);
    pc.base = pdla_ens_journal_count(c->j);
    pc.total = cfg->clusters;
    pc.particles_total = (cfg->clusters - pc.base) * cfg->params.target;
#ifdef PDLA_WITH_MPI
    if (c->verdict_pending) {
        int go = 0;
        c->verdict_pending = 0;
        if (pdla_ens_mpi_share(&go, (pdla_ens_config *)cfg, err, errlen)) {
            fprintf(stderr, "pdla ensemble: %s\n", err);
            return EXIT_RUNTIME;
        }
    }
    const int rc = c->mpi_size > 1 ? pdla_ens_mpi_run_root(c->j, threads, on_progress, &pc, err, errlen)
                                   : pdla_ens_run_local(c->j, threads, on_progress, &pc, err, errlen);
#else
    const int rc = pdla_ens_run_local(c->j, threads, on_progress, &pc, err, errlen);
#endif
    const uint64_t have = pdla_ens_journal_count(c->j);
    /* A stop asked after the last record was synced (the workers saw the
     * signal on their way out) lost nothing: write the file. */
    c->grown = (rc == PDLA_OK || rc == PDLA_ESTOPPED) && have == cfg->clusters;
    if (c->grown) progress_ensemble(&pc.prog, have, cfg->clusters, pc.particles_total, pc.particles_total, 1);
    else if (pc.prog.enabled && tty) fputc('\n', stderr);
    if (!c->grown && (rc == PDLA_ESTOPPED || (rc == PDLA_OK && stop_signal))) {
        fprintf(stderr, "pdla ensemble: stopped by signal: %" PRIu64 " of %" PRIu64 " clusters recorded in %s/%s; "
                        "resume with pdla ensemble --resume %s\n",
                have, cfg->clusters, c->dir, PDLA_ENS_JOURNAL_NAME, c->dir);
        return EXIT_RUNTIME;
    }
    if (rc && !c->grown) {
        fprintf(stderr, "pdla ensemble: %s (%" PRIu64 " of %" PRIu64 " clusters recorded; resume with "
                        "pdla ensemble --resume %s)\n",
                err, have, cfg->clusters, c->dir);
        return EXIT_RUNTIME;
    }
    char h5[4300];
    snprintf(h5, sizeof h5, "%s/%s", c->dir, PDLA_ENS_FILE_NAME);
    const pdla_run_info info = {cmd, pdla_clock_seconds() - t0, 0};
    /* A resume writes at the level the ensemble was started with (its
     * journal's), unless --compress gives another for this file. */
    const int gzip = c->a.gzip_given ? c->a.gzip : cfg->deflate_level;
    if (pdla_ens_write_gz(c->j, &info, h5, gzip, err, errlen)) {
        fprintf(stderr, "pdla ensemble: %s\n", err);
        return EXIT_RUNTIME;
    }
    if (!c->o.quiet) {
        printf("ensemble: %" PRIu64 " clusters of %" PRIu64 " particles (%dD, seeds %" PRIu64 "..%" PRIu64
               ") in %s\n",
               cfg->clusters, cfg->params.target, cfg->params.dim, cfg->params.seed,
               cfg->params.seed + cfg->clusters - 1, h5);
        printf("wall time %.3f s; statistics: pdla analyze %s\n", pdla_clock_seconds() - t0, h5);
    }
    if (stop_signal)
        fprintf(stderr, "pdla ensemble: signal received after every cluster was recorded; %s complete\n", h5);
    return fflush(stdout) ? EXIT_RUNTIME : 0;
}

/* Everything the steps above may leave open; MPI's end. The exit status. */
static int finish(ens_cmd *c, int code)
{
    pdla_ens_journal_close(c->j);
    if (c->lock >= 0) pdla_rundir_unlock(c->lock);
#ifdef PDLA_WITH_MPI
    if (c->verdict_pending) { /* rank 0 failed before the growth: tell the others */
        int v = code ? code : EXIT_RUNTIME;
        if (pdla_ens_mpi_share(&v, NULL, c->err, sizeof c->err)) fprintf(stderr, "pdla ensemble: %s\n", c->err);
    }
    /* After an MPI failure this aborts the job (others may wait for us). */
    if (c->mpi_size > 1 && pdla_ens_mpi_finalize(code) && code == 0) {
        fprintf(stderr, "pdla ensemble: MPI_Finalize failed\n");
        code = EXIT_RUNTIME;
    }
#endif
    return code;
}

/* The steps in order; the exit status. */
static int run_steps(ens_cmd *c, int argc, char **argv, char **rest, const char *cmd, double t0)
{
    /* First: a signal from now on stops the ensemble in an orderly way. */
    if (install_signals()) {
        fprintf(stderr, "pdla ensemble: cannot install signal handlers: %s\n", strerror(errno));
        return EXIT_RUNTIME;
    }
    int code = start_mpi(c);
    if (code == GO_ON) code = parse_all(c, argc, argv, rest);
    if (code != GO_ON) return code;
    const int threads = c->o.params.threads;
    /* Checked once rank 0 owes its verdict (so the others hear of it); the
     * other ranks read and write no HDF5 file. */
    const int loud = pdla_hdf5_quiet();
#ifdef PDLA_WITH_MPI
    /* From here on only rank 0 decides; the others wait for its verdict. */
    if (c->mpi_size > 1 && c->mpi_rank > 0) return worker_rank(threads, c->mpi_rank, &c->grown);
    c->verdict_pending = c->mpi_size > 1;
#endif
    if (loud) {
        fprintf(stderr, "pdla ensemble: cannot turn HDF5's error printing off\n");
        return EXIT_RUNTIME;
    }
    code = c->o.resume ? open_resume(c) : open_new(c, threads);
    if (code != GO_ON) return code;
    return grow_and_write(c, threads, cmd, t0);
}

int ens_cmd_main(int argc, char **argv)
{
    const double t0 = pdla_clock_seconds();
    ens_cmd *const c = calloc(1, sizeof *c);
    char **rest = calloc((size_t)argc + 2, sizeof *rest);
    char *cmd = cli_command_line("pdla", argc, argv);
    int code = EXIT_RUNTIME;
    if (!c || !rest || !cmd) {
        fprintf(stderr, "pdla ensemble: out of memory\n");
    } else {
        c->lock = -1;
        c->mpi_size = 1;
        code = finish(c, run_steps(c, argc, argv, rest, cmd, t0));
    }
    free(rest);
    free(cmd);
    /* End by the signal only when it stopped something (the growth, or the
     * steps before it); once every cluster is recorded the exit status
     * says how the write went. */
    const int sig = c && c->grown ? 0 : stop_signal;
    free(c);
    if (sig) {
        fflush(NULL);
        signal(sig, SIG_DFL);
        raise(sig);
    }
    return code;
}
