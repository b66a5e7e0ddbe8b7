/*
 * pdla.h - public API of libpdla, an engine for huge off-lattice
 * diffusion-limited aggregation (DLA) clusters in 2D and 3D.
 *
 * Usage: fill a pdla_params with pdla_params_default(), change what you need,
 * pdla_engine_create(), pdla_engine_grow() to the target, read the results
 * (pdla_engine_stats, pdla_engine_visit, pdla_engine_rg_series) or write them
 * with pdla_output_write(), then pdla_engine_destroy().
 *
 * Units. Positions are integers in "units"; one particle diameter is
 * params.resolution units (a power of two). The seed particle sits at the
 * origin. Every public length is in units unless its name ends in _diam.
 *
 * Errors. Functions that can fail return 0 on success or a negative
 * PDLA_E* code, and write a one-line reason into err[errlen] when err is not
 * NULL. The library never prints and never exits.
 */
#ifndef PDLA_PDLA_H
#define PDLA_PDLA_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__)
#define PDLA_API __attribute__((visibility("default")))
#else
#define PDLA_API
#endif

/* Error codes (negative return values). */
enum {
    PDLA_OK = 0,
    PDLA_EINVAL = -1,  /* a parameter is out of its documented range      */
    PDLA_ENOMEM = -2,  /* an allocation failed                            */
    PDLA_ERANGE = -3,  /* the cluster reached the coordinate limit        */
    PDLA_EIO = -4,     /* a file could not be written or read             */
    PDLA_EEXIST = -5,  /* the output exists and overwriting was not asked */
    PDLA_ESTOPPED = -6 /* growth stopped by the caller's stop flag        */
};

/* What happens to a walker that leaves the birth circle (sphere). */
typedef enum {
    /* Exact: put it straight back on the birth circle with the exterior
     * harmonic measure (2D: wrapped Cauchy; 3D: return with probability
     * R/r, else a fresh walker). No walker is ever killed. */
    PDLA_RETURN_EXACT = 0,
    /* The seed paper's scheme: outside the birth radius jump by
     * |p| - R_ext, kill and restart the walker past R_death. */
    PDLA_RETURN_KILL = 1
} pdla_return_mode;

/* What a PDLA worker does when the exact re-check under the lock finds that
 * another walker stuck where it was about to (closer than one diameter). */
typedef enum {
    /* Continue: the walker touches the particle that took its place; it is
     * moved onto contact with it (as in snap_contact) and inserted there if
     * that spot is free, else it restarts on the birth circle. */
    PDLA_RECHECK_CONTINUE = 0,
    /* The seed paper's choice: discard the walker, launch a new one. */
    PDLA_RECHECK_DISCARD = 1
} pdla_recheck_mode;

/* Placement of worker threads (hwloc). */
typedef enum {
    PDLA_BIND_NONE = 0, /* let the OS schedule */
    PDLA_BIND_CORE = 1  /* one worker per physical core, round robin */
} pdla_bind_mode;

/* Largest |coordinate| (units) a particle may have: squared distances of
 * walkers within 3 birth radii then stay below 2^63 in 64-bit integers. */
#define PDLA_MAX_CLUSTER_RADIUS_UNITS (INT64_C(1) << 28)
/* Allowed resolutions (units per diameter); powers of two only. */
#define PDLA_MIN_RESOLUTION 4
#define PDLA_MAX_RESOLUTION 128

/* Run parameters. Every field is documented with its default, which
 * pdla_params_default() sets. Each field is a row of the parameter table
 * (pdla/params.h, src/core/params.c), which holds its default, range, help
 * text, option name and resume rule, and drives every place that handles it. */
typedef struct pdla_params {
    int dim;                 /* 2 or 3. Default 2. */
    uint64_t target;         /* particles in the final cluster, >= 1. Default 1000000. */
    uint64_t seed;           /* random seed. Default 1. */
    int resolution;          /* D: units per particle diameter, power of two in
                                [4,128]. Default 32 (a leaf is 256/D = 8 diameters). */
    int eps;                 /* sticking shell in units: a walker sticks when its
                                centre is closer than D + eps to a particle centre;
                                2 <= eps <= D/2 (rounding to the unit grid needs one unit of slack). Default 2. */
    double birth_margin;     /* R_birth = R_ext + birth_margin diameters, >= 1. Default 2. */
    pdla_return_mode return_mode; /* Default PDLA_RETURN_EXACT. */
    double kill_ratio;       /* R_death / R_birth in PDLA_RETURN_KILL mode, > 1. Default 100. */
    int exact_search;        /* 1: exact nearest-distance search only (no far
                                approximation), for comparison. Default 0. */
    double far_factor;       /* a non-empty tree node whose box is farther than
                                far_factor x its side from the walker is not opened;
                                its box distance serves as a lower bound.
                                In [0.5, 64]. Default 2. */
    uint64_t max_jumps;      /* jumps after which a walk is restarted on the birth
                                circle (counted in stats.restarts). Default 10^8. */
    int snap_contact;        /* 1: a walker that stops inside the sticking shell is
                                moved along the line to its nearest particle onto
                                contact (distance D, to the grid point nearest it
                                that overlaps nothing); 0: it sticks where it
                                stopped (mean contact distance D + eps/2, which
                                stretches the cluster by ~eps/(2D)). Default 1. */
    int rg_per_decade;       /* R_g(N) samples per decade of N, log-spaced; 0 turns
                                sampling off. Default 100 (1000 samples at 1e10). */
    int threads;             /* worker threads after the serial phase; 1 = serial
                                DLA throughout (no thread is started); 0 = one per
                                physical core (hwloc). In [0, 1024]. Default 1. */
    uint64_t serial_until;   /* grow serially (one walker, deterministic) up to this
                                many particles, then start the workers (PDLA).
                                Default 10^7, the seed paper's value. */
    pdla_recheck_mode recheck; /* Default PDLA_RECHECK_CONTINUE. */
    pdla_bind_mode bind;     /* Default PDLA_BIND_NONE. */
    int reference_walkers;   /* P > 0: after the serial phase, grow with P walkers
                                advanced in turn, one jump each, in one thread
                                (deterministic): the race-free reference of P
                                concurrent walkers, with the workers' insertion
                                rules (recheck). 1 = serial DLA exactly. Needs
                                threads = 1. In [0, 2^20]. Default 0 (off). */
    int record_arrival;      /* 1: also keep every particle's position in arrival
                                order (dim int32 per particle, 8 or 12 bytes), so
                                pdla_output_write stores /cluster/positions in
                                arrival order (attribute order = "arrival");
                                0: nothing is kept, positions are written in tree
                                order. Default 0. */
} pdla_params;

PDLA_API void pdla_params_default(pdla_params *p);
/* 0 if every field is in range, else PDLA_EINVAL and the first bad field in
 * err (pdla_param_validate over the table, in its order). */
PDLA_API int pdla_params_validate(const pdla_params *p, char *err, size_t errlen);

/* The PDLA straggler bound: a worker's walker that finds more than
 * PDLA_STRAGGLER_FACTOR x workers particles appended since its last step is
 * relaunched (pdla_stats.relaunches). */
#define PDLA_STRAGGLER_FACTOR 8

/* Bins of pdla_stats.lag_hist (powers of two). */
#define PDLA_LAG_BINS 20

/* Counters of a growth run. */
typedef struct pdla_stats {
    uint64_t particles;      /* particles in the cluster */
    uint64_t walkers;        /* walkers launched (one per particle plus restarts) */
    uint64_t jumps;          /* walk-on-spheres jumps of all walkers */
    uint64_t returns;        /* walkers put back on the birth circle (exact mode) */
    uint64_t lost;           /* 3D walkers that escaped to infinity (exact mode) */
    uint64_t killed;         /* walkers killed beyond R_death (kill mode) */
    uint64_t restarts;       /* walks cut by max_jumps and restarted */
    uint64_t node_visits;    /* tree nodes touched by distance queries */
    uint64_t particle_checks;/* exact particle distances computed */
    int64_t r_ext;           /* max |x| of the particle centres, units (rounded up) */
    double rg_diam;          /* radius of gyration now, diameters */
    size_t tree_bytes;       /* bytes of tree records (nodes and chunks) in use */
    uint64_t inner_nodes, leaves, chunks;
    int root_level;          /* root box side = 256 * 2^root_level units */
    double grow_seconds;     /* wall time spent in pdla_engine_grow */
    double parallel_seconds; /* of which with worker threads */
    int threads;             /* workers used in the parallel phase (0 if none ran) */
    uint64_t recheck_overlaps;  /* PDLA: walkers that found their spot taken */
    uint64_t recheck_continued; /* ... and were inserted in contact with the newcomer */
    uint64_t recheck_discarded; /* ... and were discarded / restarted */
    /* PDLA stale reads caught (this process only, not checkpointed): jumps
     * queried again because a particle appended since the walker's distance
     * query lay inside the jump's ball, and birth-circle moves redone
     * because R_ext had grown since it was read. */
    uint64_t stale_jumps, stale_births;
    /* PDLA (workers, this process only): moves held up until a spot another
     * worker had chosen but not yet appended was appended, then queried
     * again (the claims of issue 8). */
    uint64_t claim_waits;
    /* PDLA straggler bound (workers): walkers relaunched from the birth
     * circle because more than 8 x workers particles were appended between
     * two of their steps (or between their last step and their append):
     * descheduled while the others grew. Saved in checkpoints, so cumulative
     * over resumes (a checkpoint written before the count was saved resumes
     * it from 0). */
    uint64_t relaunches;
    /* PDLA lock contention, indexed by PDLA_MUTEX_NODE/BUCKET/GYRATION:
     * acquisitions by workers, and those that found the mutex held (so had
     * to wait). Counted since this process started (not checkpointed). */
    uint64_t mutex_taken[3];
    uint64_t mutex_contended[3];
    /* ... total time workers held each mutex (holds up to 2^17 ticks) and
     * waited for it (ns), and
     * the workers' CPU time (s); this process only. */
    double mutex_hold_ns[3], mutex_wait_ns[3];
    uint64_t mutex_long_holds[3]; /* holds over 2^17 timestamp ticks (tens of us: a
                                     preempted holder, a map grid rebuilt), not
                                     in mutex_hold_ns */
    double worker_cpu_seconds;
    char binding[256];       /* how workers were placed, e.g. "none" or "core: 0 1 2 3" */
    /* PDLA lag (workers or reference walkers; this process only): for each
     * particle they inserted, the particles appended by the others between
     * its walker's launch and its append. Mean about P - 1 however the
     * walkers are interleaved; the spread and the histogram show the
     * interleaving (oversubscribed threads: most lags small, a few huge).
     * lag_hist[0]: lag 0; lag_hist[k]: 2^(k-1) <= lag < 2^k; the last bin
     * holds everything above. */
    uint64_t lag_n, lag_sum;
    double lag_sum2;
    uint64_t lag_hist[PDLA_LAG_BINS];
} pdla_stats;

enum { PDLA_MUTEX_NODE = 0, PDLA_MUTEX_BUCKET = 1, PDLA_MUTEX_GYRATION = 2 };

/* One fit of ln R_g = ln C + ln N / D_f. */
typedef struct pdla_fit {
    double df;               /* fractal dimension D_f */
    double df_err;           /* standard error of D_f from the least-squares slope */
    double prefactor_diam;   /* C, in diameters */
    uint64_t n_lo, n_hi;     /* the fit range of N, inclusive */
    int points;              /* samples used; 0 when there were too few to fit */
} pdla_fit;

typedef struct pdla_engine pdla_engine;

/* Progress callback: called from inside pdla_engine_grow about every
 * `every` particles while the cluster holds fewer than n_until (never once
 * growth is complete); returning non-zero stops growth (PDLA_ESTOPPED). */
typedef int (*pdla_progress_fn)(const pdla_engine *e, void *user);

PDLA_API int pdla_engine_create(pdla_engine **out, const pdla_params *p,
                                char *err, size_t errlen);
PDLA_API void pdla_engine_destroy(pdla_engine *e);

/* Grow the cluster until it holds min(n_until, target) particles. */
PDLA_API int pdla_engine_grow(pdla_engine *e, uint64_t n_until,
                              pdla_progress_fn progress, uint64_t every,
                              void *user, char *err, size_t errlen);

PDLA_API const pdla_params *pdla_engine_params(const pdla_engine *e);
PDLA_API uint64_t pdla_engine_count(const pdla_engine *e);
PDLA_API void pdla_engine_stats(const pdla_engine *e, pdla_stats *out);

/* Visit every particle centre, in tree order (not arrival order), in
 * batches: xyz holds n * dim int32 coordinates in units. A non-zero return
 * from the visitor stops the walk and is returned. */
typedef int (*pdla_visit_fn)(const int32_t *xyz, size_t n, void *user);
PDLA_API int pdla_engine_visit(const pdla_engine *e, pdla_visit_fn fn, void *user);

/* R_g(N) samples so far: *n gets their number; the arrays stay valid until
 * the next grow call. N is the particle count, rg_diam the radius of gyration
 * in diameters. */
PDLA_API void pdla_engine_rg_series(const pdla_engine *e, const uint64_t **n,
                                    const double **rg_diam, size_t *count);
/* Positions in arrival order (n * dim int32, units) when the engine was
 * created with record_arrival = 1, else NULL (and *n = 0). Valid until the
 * next grow call. */
PDLA_API const int32_t *pdla_engine_arrival(const pdla_engine *e, uint64_t *n);

/* Fit D_f on the R_g series over the default range (see README). */
PDLA_API pdla_fit pdla_engine_fit(const pdla_engine *e);

/* Exact lower-bound-free distance (units) from a point to the nearest particle
 * centre, by the engine's own tree search in exact mode; for tests and tools. */
PDLA_API double pdla_engine_nearest(const pdla_engine *e, const int64_t *p);

/* Write a one-line message (printf format; control characters such as a
 * newline in a file name become '?') into
 * err[errlen] when err is not NULL, and return code: the error convention of
 * the library, shared with its tools (`return pdla_errorf(PDLA_EINVAL, err,
 * errlen, "dim must be 2 or 3, got %d", dim);`). */
PDLA_API int pdla_errorf(int code, char *err, size_t errlen, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
PDLA_API int pdla_verrorf(int code, char *err, size_t errlen, const char *fmt, va_list ap);
/* Seconds on the monotonic clock (CLOCK_MONOTONIC): the clock behind every
 * timing the library reports (stats.grow_seconds, checkpoint times). */
PDLA_API double pdla_clock_seconds(void);

/* Library version string, e.g. "0.1.0". */
PDLA_API const char *pdla_version(void);
/* The source revision libpdla was built from (`git describe --always
 * --dirty` at build time, as /Code git_revision), "unknown" outside git. */
PDLA_API const char *pdla_build_revision(void);
/* The compiler and the build flags libpdla was built with (as in /Code). */
PDLA_API const char *pdla_build_compiler(void);
PDLA_API const char *pdla_build_flags(void);

/* Least squares of ln R_g = ln C + ln N / D_f over the samples with
 * n_lo <= N <= n_hi and rg > 0 (rg in any length unit; prefactor_diam is in
 * that unit). Fewer than 3 usable points give points = 0 and df = NAN. The
 * same fit serves a mass-radius relation: pass M as n and r as rg. */
PDLA_API pdla_fit pdla_fit_powerlaw(const uint64_t *n, const double *rg, size_t count,
                                    uint64_t n_lo, uint64_t n_hi);
/* The default fit range for a cluster of n_final particles (the one
 * pdla_engine_fit uses): [max(10, min(1000, n_final / 10)), n_final]. */
PDLA_API void pdla_fit_default_range(uint64_t n_final, uint64_t *n_lo, uint64_t *n_hi);

/* ---- output ---------------------------------------------------------- */

/* Facts about the run that the engine does not know, for provenance. */
typedef struct pdla_run_info {
    const char *command_line;  /* the command as typed, or NULL */
    double wall_seconds;       /* wall time of the whole run */
    uint64_t peak_rss_bytes;   /* peak resident memory, 0 if unknown */
} pdla_run_info;

/* Write the run into one HDF5 file at `path` (see README for the layout).
 * Refuses (PDLA_EEXIST) if the file exists. Writes to a temporary name and
 * renames, so a failed write leaves nothing half-made. */
PDLA_API int pdla_output_write(const pdla_engine *e, const pdla_run_info *info,
                               const char *path, char *err, size_t errlen);

/* ---- checkpoints and resume (checkpoint_write.c, checkpoint_read.c; README "Checkpoints and resume") */

/* Bits naming pdla_params fields, for pdla_checkpoint_load's `asked`
 * (pdla_param_desc.bit of each row). */
enum {
    PDLA_PARAM_DIM = 1u << 0,
    PDLA_PARAM_TARGET = 1u << 1,
    PDLA_PARAM_SEED = 1u << 2,
    PDLA_PARAM_RESOLUTION = 1u << 3,
    PDLA_PARAM_EPS = 1u << 4,
    PDLA_PARAM_BIRTH_MARGIN = 1u << 5,
    PDLA_PARAM_RETURN_MODE = 1u << 6,
    PDLA_PARAM_KILL_RATIO = 1u << 7,
    PDLA_PARAM_EXACT_SEARCH = 1u << 8,
    PDLA_PARAM_FAR_FACTOR = 1u << 9,
    PDLA_PARAM_MAX_JUMPS = 1u << 10,
    PDLA_PARAM_SNAP_CONTACT = 1u << 11,
    PDLA_PARAM_RG_PER_DECADE = 1u << 12,
    PDLA_PARAM_THREADS = 1u << 13,
    PDLA_PARAM_SERIAL_UNTIL = 1u << 14,
    PDLA_PARAM_RECHECK = 1u << 15,
    PDLA_PARAM_BIND = 1u << 16,
    PDLA_PARAM_RECORD_ARRIVAL = 1u << 17,
    PDLA_PARAM_REFERENCE_WALKERS = 1u << 18
};
/* The fields a resume may change (the rows with resumable = 1; tests/params
 * checks they agree); any other asked field must equal the checkpoint's value.
 * The target may be raised (not below the particles held). */
#define PDLA_PARAM_RESUMABLE \
    (PDLA_PARAM_TARGET | PDLA_PARAM_THREADS | PDLA_PARAM_SERIAL_UNTIL | PDLA_PARAM_BIND | \
     PDLA_PARAM_REFERENCE_WALKERS)

/* File names inside a run directory: the newest checkpoint, then the two
 * generations before it. */
#define PDLA_CHECKPOINT_NAME "checkpoint.h5"
#define PDLA_CHECKPOINT_GENERATIONS 3
/* Names a fallback resume sets the skipped (damaged) checkpoints aside
 * under (pdla_rundir_set_aside, for pdla_checkpoint_recover and the event
 * command): checkpoint.damaged.h5, checkpoint.damaged.2.h5, ...; never read
 * by a directory resume. */
#define PDLA_CHECKPOINT_ASIDE_PREFIX "checkpoint.damaged."

typedef struct pdla_checkpoint_opts {
    int compress;             /* 1: shuffle + deflate 1 on the pools (slower). Default 0. */
    const char *command_line; /* for provenance, or NULL */
    double pause_seconds;     /* time the caller took to stop the workers; recorded */
    /* The caller's schedule, recorded so that a resume can keep it
     * (pdla_checkpoint_info): wall seconds and particles between
     * checkpoints, 0 for none. */
    double every_seconds;
    uint64_t every_particles;
} pdla_checkpoint_opts;

typedef struct pdla_checkpoint_info {
    char path[4200];          /* the file written or loaded */
    uint64_t generation;      /* 1 for a run's first checkpoint */
    uint64_t particles;
    uint64_t bytes;           /* size of the file */
    double seconds;           /* write or load time */
    char note[1024];          /* on load: why newer generations were skipped, or "" */
    /* On load from a run directory: which generation name was loaded (0
     * checkpoint.h5, 1 checkpoint.1.h5, ...; above 0 after a fallback, see
     * pdla_checkpoint_recover); -1 when a file was named (the caller of a
     * resume puts the file's place here, from pdla_checkpoint_place). */
    int slot;
    /* On load: the schedule the writer recorded (pdla_checkpoint_opts) and
     * whether the pools were compressed; has_schedule 0 for files written
     * before session 26, which did not record it. */
    int has_schedule;
    double every_seconds;
    uint64_t every_particles;
    int compressed;
} pdla_checkpoint_info;

/* Write a checkpoint of e into directory dir: DIR/.checkpoint.h5.tmp.<pid>
 * is written, closed, fsync'ed, the older generations shift
 * (checkpoint.1.h5 -> checkpoint.2.h5, checkpoint.h5 -> checkpoint.1.h5),
 * the new file is renamed to DIR/checkpoint.h5 and dir is fsync'ed. At every
 * moment each of those names is a complete checkpoint. Growth must not be
 * running (call it between pdla_engine_grow calls). info may be NULL. */
PDLA_API int pdla_checkpoint_write(pdla_engine *e, const char *dir,
                                   const pdla_checkpoint_opts *opts,
                                   pdla_checkpoint_info *info, char *err, size_t errlen);

/* Make an engine from a checkpoint file, or from the newest valid generation
 * in a run directory (a damaged newer one is skipped; info->note says so).
 * Everything is verified first: signature, format and version, parameters,
 * record counts, checksums, the tree's structure and that its particles
 * reproduce the stored exact gyration sums, R_ext and count, the R_g series
 * and the RNG state. `asked` (may be NULL when asked_fields is 0) holds the
 * caller's parameters, of which those named by asked_fields are applied:
 * PDLA_PARAM_RESUMABLE ones replace the checkpoint's, any other must be
 * equal. Returns PDLA_EIO (unreadable, foreign or damaged: err names the
 * file and the reason), PDLA_EINVAL (a parameter may not change; a
 * directory or a device as the file, or under any generation name of the
 * run directory), PDLA_ENOMEM. Reads only. */
PDLA_API int pdla_checkpoint_load(pdla_engine **out, const char *path, const pdla_params *asked,
                                  uint32_t asked_fields, pdla_checkpoint_info *info,
                                  char *err, size_t errlen);

/* The root of the DLA checkpoint at path, without loading the rest (a
 * quick look, whatever the file's size): its generation and particle
 * count. PDLA_OK when the root reads as a DLA checkpoint's (its data may
 * still be damaged), else PDLA_EIO (not a regular file, not HDF5, another
 * model's file, a root that does not read), or PDLA_EINVAL when path,
 * generation or particles is NULL. Reads only. */
PDLA_API int pdla_checkpoint_peek(const char *path, uint64_t *generation, uint64_t *particles);

/* Before pdla_checkpoint_load of a checkpoint FILE named for a resume (not
 * a run directory), whose checkpoints then go to its folder dir (hold its
 * lock): the file's place among dir's generation names, which those writes
 * rotate. *slot gets k when path is generation name k of dir (the same
 * file: a hard link or the name itself), PDLA_CHECKPOINT_GENERATIONS when
 * it is none (every generation name of dir is then ahead of it), or -1
 * when path is no regular file whose checkpoint root reads (the load then
 * says what is wrong). Every generation name ahead of the file (before
 * *slot) is loaded and verified as a directory resume would, one at a time
 * (never beside the named file's engine): absent or damaged is fine, and
 * pdla_checkpoint_recover, given *slot in info->slot after the load, sets
 * those aside and moves the file and the older names to the front, as after
 * a directory resume's fallback; note (may be NULL) then gets "skipped
 * NAME: damaged checkpoint (why)" for the first, as pdla_checkpoint_info's
 * note, or "". A valid checkpoint there is PDLA_EEXIST, with err naming it
 * (its generation and particles) and the two ways on: --resume dir, or
 * move it out of dir to go on from path (the writes would rotate it out,
 * and the directory would mix two histories). Another model's checkpoint
 * there is PDLA_EINVAL, as is a directory or a device under any generation
 * name of dir; PDLA_EIO when a name cannot be looked at,
 * PDLA_ENOMEM. Reads only. */
PDLA_API int pdla_checkpoint_place(const char *path, const char *dir, int *slot, char *note, size_t notelen,
                                   char *err, size_t errlen);

/* After pdla_checkpoint_load of run directory dir (info->slot >= 0; for a
 * file named, the place pdla_checkpoint_place found, else -1: left alone),
 * before the first write. When the load took an older name (slot > 0: the
 * newer ones damaged, unreadable or missing; PDLA_CHECKPOINT_GENERATIONS:
 * a file named under another name, every generation name damaged or
 * missing), the directory is put back in the shape the rotation of
 * pdla_checkpoint_write expects, so that its hard link of checkpoint.h5
 * never keeps a damaged file as a generation: each skipped file is moved
 * aside (PDLA_CHECKPOINT_ASIDE_PREFIX, the first free name; a kept file is
 * never replaced), then the loaded and older generations are renamed to the
 * front (checkpoint.1.h5 -> checkpoint.h5, checkpoint.2.h5 ->
 * checkpoint.1.h5), with the directory fsync'ed after each step, so that a
 * crash at any point leaves every generation name a complete file or
 * absent. Always, e's generation is raised past every generation seen in
 * dir (each checkpoint file's, kept ones included, whose root reads; a
 * skipped one whose root does not read counts as the generation its place
 * gave it), so that no write reuses a damaged file's number. Hold the lock.
 * done (may be NULL) gets one line saying what moved, or "" when nothing
 * did. PDLA_OK, or PDLA_EIO with err naming the file and the reason (what
 * moved before it stays moved: every name is still a complete checkpoint or
 * absent, and the next resume takes it from there). */
PDLA_API int pdla_checkpoint_recover(pdla_engine *e, const char *dir, const pdla_checkpoint_info *info,
                                     char *done, size_t donelen, char *err, size_t errlen);

/* Lock a run directory against a second writer (flock on the directory
 * itself, so nothing is created). *fd gets the lock to pass to
 * pdla_rundir_unlock. PDLA_EEXIST when another process holds it, PDLA_EIO
 * when the directory cannot be opened or flock fails otherwise (ENOLCK on a
 * file system without locks); err names the directory and the reason. The
 * commands refuse on either: no lock, no writes. */
PDLA_API int pdla_rundir_lock(const char *dir, int *fd, char *err, size_t errlen);
PDLA_API void pdla_rundir_unlock(int fd);
/* Whether dir takes new files: one is made and removed again, since access()
 * cannot see an immutable directory or a read-only mount for root. 0, or an
 * errno. */
PDLA_API int pdla_rundir_probe(const char *dir);
/* A new run written with --force into dir (hold the lock): remove what
 * would let the older run come back or describe it. Every model's
 * checkpoint names (a --resume of any model would otherwise grow the older
 * run, perhaps of another model, and write it over this run's cluster.h5),
 * and, unless the new run writes its own (the DLA command, which replaces
 * it whole at its end, beside its cluster.h5), the DLA summary.txt: it
 * would describe the older run beside another model's cluster.h5. Then
 * the directory is synced (when something was removed), so that a crash
 * cannot bring them back. PDLA_OK, or PDLA_EIO with err naming the file
 * when one cannot be removed (a missing one is fine) or the directory when
 * it cannot be synced: the commands stop before the run then, exit 1 (an
 * I/O failure, as a failed write). */
PDLA_API int pdla_rundir_remove_old_run(const char *dir, int writes_summary, char *err, size_t errlen);

/* Is name (a name in a directory, no '/') one that
 * pdla_rundir_remove_old_run removes with writes_summary 0: a checkpoint
 * name of any model, a set-aside checkpoint, summary.txt? 1 or 0. (A new
 * run's --out named through such a link of its own folder lost the link
 * to that removal.) */
PDLA_API int pdla_rundir_old_run_name(const char *name);
/* A damaged checkpoint src of run directory dir that a fallback resume
 * skipped goes aside, kept byte for byte, under the first free name of
 * PDLA_CHECKPOINT_ASIDE_PREFIX: checkpoint.damaged.h5, then
 * checkpoint.damaged.2.h5, ... up to .999 (every model: DLA's
 * pdla_checkpoint_recover, the event command's fallback). The name is
 * claimed without replacing anything (renameat2 RENAME_NOREPLACE, else a
 * hard link and an unlink), so an earlier kept file is never overwritten;
 * when an aside name already is this file (a crash between that link and
 * unlink), src is only unlinked, so a file is never kept twice. kept (may
 * not be NULL) gets the name, or "" when src is not there. The caller
 * syncs the directory. Hold the lock. PDLA_OK, or PDLA_EIO with err naming
 * the file and the reason. */
PDLA_API int pdla_rundir_set_aside(const char *dir, const char *src, char *kept, size_t keptlen, char *err,
                                   size_t errlen);
/* fsync the directory itself, so that renames and links in it are on disk
 * (a file system that cannot sync a directory counts as synced). 0, or -1
 * with errno. */
PDLA_API int pdla_rundir_fsync(const char *dir);
/* Remove the temporary files an interrupted checkpoint write left in dir
 * (hold the lock). Returns how many were removed, or -1. */
PDLA_API int pdla_checkpoint_remove_stale(const char *dir);
/* Turn HDF5's automatic error printing off in the calling thread for good.
 * The library silences HDF5 around each call and restores the caller's
 * setting; but HDF5 1.10 keeps internals of some corrupt files it failed to
 * read and then prints a complaint at exit unless printing is off. A program
 * that must print nothing but its own messages (the CLI) calls this first. */
PDLA_API int pdla_hdf5_quiet(void);

/* An independent check of a grown cluster from its particle centres alone
 * (`pdla check`): the rows go into a fresh tree one by one, and each is
 * compared with the particles already there, exactly, in integers:
 *  - no two centres closer than one diameter D (every pair is seen once,
 *    when its later row arrives);
 *  - contact: in arrival order, every row after the first lies within
 *    D + eps of an earlier one (it stuck to the cluster as it was, so the
 *    cluster is one piece); in any other order, the contact graph (centres
 *    closer than D + eps) of the finished tree is one piece holding the
 *    seed (a breadth-first walk from it, one bit a particle plus its queue);
 *  - the seed: the first row in arrival order, some row otherwise, at the
 *    origin;
 *  - the R_g and R_ext of the centres from exact integer sums, as the engine
 *    computes them, so a caller can compare a file's stored values bit for
 *    bit; in arrival order also R_g at given counts (the stored series).
 * Memory: about the tree's, 4-5 bytes a particle. */
typedef struct pdla_check pdla_check;

/* Where a failed check was first seen: its row (file order) and centre. */
typedef struct pdla_check_where {
    uint64_t row;     /* UINT64_MAX when no failure, or found over the tree */
    int64_t x[3];
} pdla_check_where;

typedef struct pdla_check_report {
    uint64_t particles;
    uint64_t overlaps;          /* pairs closer than D */
    pdla_check_where first_overlap;
    uint64_t detached;          /* particles without the contact above (tree order:
                                   not connected to the seed's piece) */
    pdla_check_where first_detached;
    uint64_t out_of_range;      /* rows beyond PDLA_MAX_CLUSTER_RADIUS_UNITS (not stored) */
    pdla_check_where first_out_of_range;
    int seed_at_origin;         /* 1 when the seed is at the origin */
    int arrival;                /* 1: rows in arrival order (the stronger checks) */
    double closest_diam;        /* least distance between two centres (NaN: < 2 rows) */
    double widest_contact_diam; /* largest distance from a particle to its nearest
                                   (earlier) neighbour, below D + eps (NaN: none) */
    double rg_diam;             /* R_g of the centres, diameters (engine's formula) */
    int64_t r_ext_units;        /* ceil of the largest |x| of a centre, units */
    uint64_t series_checked;    /* R_g samples compared (arrival order) */
    uint64_t series_mismatches; /* samples whose value differs from the recomputed one */
    uint64_t first_series_mismatch; /* its index, UINT64_MAX when none */
} pdla_check_report;

/* dim 2 or 3, resolution D a power of two in [PDLA_MIN_RESOLUTION,
 * PDLA_MAX_RESOLUTION], eps in [2, D/2] (pdla_params' ranges); arrival: the
 * rows will come in arrival order. */
PDLA_API int pdla_check_create(pdla_check **out, int dim, int resolution, int eps, int arrival,
                               char *err, size_t errlen);
/* Arrival order only, before any row: the stored R_g series (k samples of
 * R_g in diameters at counts n[], increasing) to recompute and compare. The
 * arrays are copied. */
PDLA_API int pdla_check_series(pdla_check *c, const uint64_t *n, const double *rg_diam, size_t k,
                               char *err, size_t errlen);
/* The next `rows` centres (dim int32 each, in units), in file order. */
PDLA_API int pdla_check_add(pdla_check *c, const int32_t *xyz, size_t rows, char *err,
                            size_t errlen);
/* After the last row: of these rows (dim int32 each), how many match no
 * added row that no earlier call matched (each added row answers one row
 * at most). Over calls covering as many rows as were added, 0 means the
 * same multiset of centres (a checkpoint's tree against its arrival
 * record). PDLA_ENOMEM (negative) when out of memory. */
PDLA_API int64_t pdla_check_missing(pdla_check *c, const int32_t *xyz, size_t rows);
/* Failures found so far (overlaps, detached and out-of-range rows): a caller
 * may stop feeding rows once it has seen enough. */
PDLA_API uint64_t pdla_check_failures(const pdla_check *c);
/* After the last row: the remaining checks and the report. all_rows 0: the
 * caller stopped early, so the checks that need every row (contacts over
 * the finished tree when not in arrival order, series samples beyond the
 * rows) are left out. */
PDLA_API int pdla_check_finish(pdla_check *c, int all_rows, pdla_check_report *r, char *err,
                               size_t errlen);
PDLA_API void pdla_check_destroy(pdla_check *c);

#ifdef __cplusplus
}
#endif
#endif /* PDLA_PDLA_H */
