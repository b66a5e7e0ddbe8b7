/*
 * engine.h - the engine struct shared by engine.c (lifecycle, gyration,
 * sampling, results), walker.c (one walker's walk from birth to contact),
 * grow.c (the serial loop) and parallel.c (the workers).
 * Not installed: the public face is include/pdla/pdla.h.
 */
#ifndef PDLA_SRC_ENGINE_H
#define PDLA_SRC_ENGINE_H
#include <pthread.h>
#include <stdatomic.h>

#include "pdla/pdla.h"
#include "distmap.h"
#include "rng.h"
#include "search.h"
#include "tree.h"

/* Exact running sums for the radius of gyration: with |x| < 2^28 units,
 * 128-bit sums hold any N below 2^70. */
typedef struct gyration_sums {
    __extension__ __int128 s1[3];          /* sum of x_a */
    __extension__ unsigned __int128 s2;    /* sum of |x|^2 */
    uint64_t n;
} gyration_sums;

/* What one walker needs besides the tree: its random stream, its search
 * cache and counters. One per thread; the serial phase uses the engine's. */
typedef struct walker_ctx {
    pdla_rng rng;
    search_state ss;
    uint64_t walkers, jumps, returns, lost, killed, restarts;
    uint64_t recheck_overlaps, recheck_continued, recheck_discarded;
    /* Stale reads caught before a jump (PDLA): a particle appended since the
     * walker's distance query lay inside the jump's ball (stale_jumps), or
     * beyond the R_ext the birth circle was drawn from (stale_births); the
     * walker queried again instead. */
    uint64_t stale_jumps, stale_births;
    /* Moves held up by another worker's chosen spot (claims.h) until it was
     * appended; counted apart from the stale reads. */
    uint64_t claim_waits;
    /* Lag of the PDLA phase (issue 11): for each particle a worker or
     * reference walker inserts, the particles appended between its walker's
     * launch and its own append (by the others). Its mean is about P - 1 in
     * both modes (P walkers always in flight); its spread tells how the
     * walkers were interleaved (walker_note_lag). launched_at: the count at
     * the launch of the walk that last stopped. */
    uint64_t launched_at;
    uint64_t lag_n, lag_sum;
    double lag_sum2;
    uint64_t lag_hist[PDLA_LAG_BINS];
    /* The straggler bound (workers only, parallel.c): a walker that finds
     * more than relaunch_after particles appended since its own last step
     * (0: no bound) is relaunched from the birth circle; counted in
     * relaunches. step_seen: the count its last step read (set when a walk
     * stops, for the check at the append). */
    uint64_t relaunch_after, relaunches, step_seen;
    /* Acquisitions of the node, bucket and gyration mutexes (PDLA_MUTEX_*),
     * and how many found the mutex held (this process only; not saved in
     * checkpoints): the measure of lock contention as threads are added. */
    uint64_t mutex_taken[3], mutex_contended[3];
    /* Time (timestamp-counter ticks, engine tick_ns each) spent holding each
     * mutex and waiting for it, and the worker thread's CPU time: the
     * inputs of the contention model (runs/contention-model). */
    uint64_t mutex_hold_ticks[3], mutex_wait_ticks[3];
    /* Holds longer than LONG_HOLD_TICKS (a preempted holder, or a distance
     * map grid rebuilt under the node mutex): counted apart, not in the sum. */
    uint64_t mutex_long_holds[3];
    double cpu_seconds;
    int id;                   /* worker index (the turn hooks) */
    PDLA_CACHE_PAD(pad_); /* workers' contexts sit side by side in one array */
} walker_ctx;

/* Test hooks (tests/threads only; the engine's pointer is NULL otherwise):
 * what a test needs to force the races of the PDLA phase and check every
 * jump against the cluster as it was when the jump was taken. */
typedef struct engine_hooks {
    /* A worker's walker, between its distance query and the stale check. */
    void (*stall)(void *user);
    /* A worker's walker jumps from p; every particle below index `now` must
     * keep a squared distance of at least R2 from p for the jump to be exact. */
    void (*jump)(void *user, const int64_t *p, uint64_t R2, uint64_t now);
    /* Particle `index` is being appended at p (bucket mutex held, before
     * the count publishes it). */
    void (*append)(void *user, uint64_t index, const int64_t *p);
    /* A worker appended particle `index` at p; its walker flew while `lag`
     * others were appended (tests/physics/lag_probe.c). */
    void (*inserted)(void *user, uint64_t index, const int64_t *p, uint64_t lag);
    /* Turns (tests/physics/test_lockstep.c): worker `id` calls turn_begin
     * before it launches a walker and before each further step, and
     * turn_end after a step that moved and after each insertion, so a test
     * can make the workers take one step each in turn, as the reference
     * mode does (reference.c). */
    void (*turn_begin)(void *user, int id);
    void (*turn_end)(void *user, int id);
    /* A worker does the node work of a frontier particle (new tree nodes or
     * distance-map cells; node mutex held, and the bucket mutex unless
     * node_before_bucket): a test can make it slow (tests/physics/
     * test_frontier.c). */
    void (*node_work)(void *user);
    /* Worker `id`'s walker has chosen its spot p (published as a claim,
     * claims.h) and is about to be inserted, before the snap, the lock-free
     * checks and the bucket mutex: a test can make the insertion slow
     * (tests/physics/test_claims.c). */
    void (*decided)(void *user, int id, const int64_t *p);
    int take_stale; /* count stale jumps but take them (the behaviour before the check) */
    /* Node work before and outside the bucket mutex, so others may append
     * meanwhile (the behaviour before issue 11's fix, parallel.c). */
    int node_before_bucket;
    /* node_work after the frontier particle is appended, bucket mutex still
     * held: the particle is visible to walkers while appends wait (the
     * probe that tells the two effects of a slow node work apart,
     * runs/pdla-bias/node9). */
    int node_work_published;
    int no_relaunch; /* no straggler bound (the behaviour before it, parallel.c) */
    int no_claims;   /* walkers ignore the others' claimed spots (the behaviour before them) */
    void *user;
} engine_hooks;

struct recent_ring;
struct claim_board;

/* Tree compaction in the serial phase (tree_compact, grow.c): first at this
 * count, then each time the count has grown by an eighth, while it is at
 * most 4/5 of the target, so that the borrowed index arrays (4 bytes a
 * record) never raise the peak memory, which the final tree sets. 3D only:
 * 3D 1e6 took 6-10% less user CPU, while 2D (whose near queries keep the
 * block's chunk heads per walker) gained nothing at 1e6, 1e7 or 1e8; steps
 * of a tenth beat steps of a half at 3D 1e6 in 2 of 2 pairs (-5%, -1%),
 * the eighth itself was not compared with either
 * (runs/bench-serial/issue12-compact17-2026-11-29.md). It starts small so
 * that tests/unit/test_pinned (3D: 15000 particles, with a checkpoint
 * half-way) runs through it. */
#define ENGINE_COMPACT_FIRST ((uint64_t)1 << 12)

/* A walker in flight, for walking several in turn in one thread (the
 * race-free reference of PDLA, reference.c). */
typedef struct walk_state {
    int64_t p[3];
    uint64_t jumps;           /* since launch (for max_jumps) */
    uint32_t restarts;        /* launches cut off by max_jumps since walk_begin */
    uint64_t launched_at;     /* particle count at launch (the lag's origin) */
    uint64_t step_seen;       /* workers: the count read by the last step */
    int64_t r_ext_units;      /* the R_ext the radii below were drawn from */
    double r_ext, Rb, Rout2, Rdeath;
    int near;                 /* 2D, one thread: the map's bound here is 0 (walker.c) */
} walk_state;

/* Reference walkers in flight (reference.c), kept in the engine across a
 * stop: walkers 1 .. n - 1 (walker 0 is the engine's), their walks, and
 * the stream walker n - 1 began with (the serial stream resumes past it). */
typedef struct reference_state {
    int n;
    walker_ctx *ws;
    walk_state *st;
    unsigned char *active;
    int next;              /* whose turn comes next (round robin) */
    pdla_rng stream;
} reference_state;

/* Drop the reference walkers kept in flight (e->ref may be NULL). */
void engine_reference_free(pdla_engine *e);

struct pdla_engine {
    /* Read by every walker step; written once (or, r_ext and stop, rarely).
     * The groups below are kept a cache line apart (PDLA_CACHE_PAD) so that
     * what inserting threads write does not evict what walkers read. */
    pdla_params params;
    search_config search;
    _Atomic int64_t r_ext;    /* ceil(sqrt(r_ext2)); read by walkers without a lock */
    _Atomic int stop;         /* set to make the workers return */
    const struct recent_ring *recent; /* the PDLA phase's ring of appended particles, else NULL */
    struct claim_board *claims; /* the PDLA phase's chosen, not yet appended spots, else NULL */
    const engine_hooks *hooks; /* tests only */
    PDLA_CACHE_PAD(pad_read_);
    tree tree;                /* padded inside: query fields / insertion counts */
    distmap dmap;             /* far-query accelerator, derived from the tree */
    /* PDLA: the three mutexes of the seed's flow diagram, each on its own
     * line. node: creating tree nodes (inner pool, root growth) and the
     * distance map's writes (cells, grids); bucket: appending to a leaf's
     * chunks (chunk pool, count, the exact re-check, the target and the
     * recent-insertion ring); gyration:
     * the R_g sums, R_ext and the samples. Workers take the node mutex
     * inside the bucket mutex (lock order bucket -> node, parallel.c), the
     * gyration mutex alone. */
    pthread_mutex_t node_mu;
    PDLA_CACHE_PAD(pad_node_);
    pthread_mutex_t bucket_mu;
    PDLA_CACHE_PAD(pad_bucket_);
    pthread_mutex_t gyration_mu;
    PDLA_CACHE_PAD(pad_gyration_);
    /* Written under the gyration mutex (or by the one serial thread). */
    gyration_sums gyr;
    uint64_t r_ext2;          /* max |x|^2 of particle centres, units^2 */
    /* R_g(N) samples on a fixed log grid: N_k = round(10^(k / rg_per_decade)). */
    uint64_t *rg_n;
    double *rg_diam;
    size_t rg_count, rg_cap;
    uint64_t rg_next_k;       /* index k of the next grid point */
    uint64_t rg_next_n;       /* its N */
    int32_t *arrival;         /* record_arrival: positions in arrival order */
    uint64_t arrival_cap;     /* particles it has room for */
    /* Workers take the gyration mutex in another order than they took their
     * indices (the bucket mutex): particles that come before their turn
     * wait here, slot index & (cap - 1), so the sums and the R_g samples
     * always cover exactly the first gyr.n particles in arrival order. */
    uint64_t *gyr_wait_idx;   /* index + 1 of the particle in a slot, 0: empty */
    int64_t (*gyr_wait_p)[3];
    size_t gyr_wait_cap;      /* a power of two, 0 until needed */
    /* The caller's thread only. */
    walker_ctx walker;        /* the serial phase's walker */
    uint64_t compact_first;   /* serial phase: first tree compaction at this count (0: none; grow.c) */
    double grow_seconds;
    double parallel_seconds;
    double tick_ns;            /* ns per timestamp tick, measured in the parallel phase */
    walker_ctx *workers;       /* per-thread walkers of the last parallel phase */
    int nworkers;
    char binding[256];
    /* A serial walk stopped between two slices (grow.c serial_walk): the
     * stream stands at the walk's start meanwhile (a checkpoint then redoes
     * the walk), and the next grow continues it where it was. */
    reference_state *ref;      /* reference walkers in flight across a stop (reference.c) */
    int walk_paused;
    walk_state paused_ws;
    pdla_rng paused_rng; /* the stream where the walk stood */
    pdla_rng paused_r0;  /* the stream the walk began with */
    /* Tests only (tests/unit/test_midwalk.c), 0 otherwise: steps per slice
     * of a serial walk instead of grow.c's, and progress at every slice
     * instead of every SERIAL_POLL_SECONDS, so that stops fall inside walks. */
    uint32_t test_slice_steps;
    int test_poll_every_slice;
    /* Tests: WALK_ENDLESS after this many restarts in a row instead of
     * WALK_ENDLESS_RESTARTS (0), so that a walk can be made endless. */
    uint32_t test_endless_restarts;
    uint64_t ckpt_generation;  /* checkpoints written (or loaded) so far */
    double ckpt_write_seconds; /* time of the last checkpoint write */
};

/* Outcomes of a walk (and of one step of it). */
enum {
    WALK_MOVED = -1,  /* walker_step: still walking */
    WALK_CONTACT = 0, /* inside the sticking shell: D <= distance < D + eps */
    WALK_OVERLAP = 1, /* closer than D: a particle appeared during the last jump */
    /* WALK_ENDLESS_RESTARTS launches in a row were cut off by --max-jumps
     * with no contact: with a limit that small no walk reaches the cluster,
     * and growth would go on for ever (an error, not a hang). */
    WALK_ENDLESS = 2,
    /* workers only: the engine's stop flag was seen within a walk (a walk
     * that does not end must not hold off a signal or an error) */
    WALK_ABANDONED = 3,
    /* grow.c's serial walk only: stopped by the progress callback */
    WALK_STOPPED = 4
};

/* A million restarts in a row: a walker that reaches the cluster within
 * --max-jumps once in a million tries would need 1e6 x max_jumps jumps a
 * particle, far beyond any useful run, so no useful run is cut short. */
#define WALK_ENDLESS_RESTARTS 1000000u

/* The error growth reports on WALK_ENDLESS (one wording, three callers). */
#define WALK_ENDLESS_FMT                                                                   \
    "no walker reached the cluster in %u launches in a row, each cut off after "          \
    "--max-jumps %llu jumps: raise --max-jumps (default 1e8)"


/* Walk one walker from birth until it sticks; writes where it stopped.
 * Returns WALK_CONTACT or WALK_OVERLAP; WALK_ENDLESS, or WALK_ABANDONED
 * once the engine's stop flag is set. Reads the tree only (any number of
 * threads at once). */
int walker_run(const pdla_engine *e, walker_ctx *w, int64_t *stuck_at);


/* Launch a walker on the birth circle (sphere). */
void walker_begin(const pdla_engine *e, walker_ctx *w, walk_state *s);

/* The serial walk in slices: at most `steps` steps (launching it first
 * unless resume), then WALK_MOVED if it still walks (call again with resume
 * = 1 and the same s), else WALK_CONTACT / WALK_OVERLAP with the spot in
 * stuck_at. The same draws as walker_run (grow.c polls between slices, so a
 * walk that never ends cannot hold off a signal). */
int walker_run_slice(const pdla_engine *e, walker_ctx *w, walk_state *s, int resume, uint64_t steps,
                     int64_t *stuck_at);

/* One step (a jump, a return, a restart): WALK_MOVED, or WALK_CONTACT /
 * WALK_OVERLAP with the spot in stuck_at. One thread only: each step sees
 * the cluster as it is. walker_run is walker_begin, then steps until one
 * stops, with the same random draws. */
int walker_step(const pdla_engine *e, walker_ctx *w, walk_state *s, int64_t *stuck_at);

/* Move p onto contact (distance D) with its nearest particle within `reach2`,
 * at the grid point nearest to contact that overlaps nothing. Returns 1 if
 * it moved p (then no particle the search saw lies closer than D to p), 0
 * if no such point exists (p unchanged). k: the walker's
 * search state (its cached tree path finds the leaves). */
int walker_snap_to_contact(const tree *t, int64_t *p, int64_t D, uint64_t reach2, search_state *k);

/* Count the lag of the particle with insertion index `index` appended by
 * walker w (its walk began at w->launched_at). */
static inline void walker_note_lag(walker_ctx *w, uint64_t index)
{
    const uint64_t lag = index > w->launched_at ? index - w->launched_at : 0;
    w->lag_n++;
    w->lag_sum += lag;
    w->lag_sum2 += (double)lag * (double)lag;
    const int bin = lag ? 64 - __builtin_clzll(lag) : 0; /* 2^(bin-1) <= lag < 2^bin */
    w->lag_hist[bin < PDLA_LAG_BINS ? bin : PDLA_LAG_BINS - 1]++;
}

/* Add o's counters (walkers, jumps, ..., re-checks) to into's. */
void walker_ctx_add_counts(walker_ctx *into, const walker_ctx *o);

double gyration_rg2_units(const gyration_sums *g, int dim);
/* R_g in diameters, as every R_g the engine reports or samples (and as
 * pdla_check recomputes it, bit for bit). */
double gyration_rg_diam(const gyration_sums *g, int dim, int resolution);
/* Add p to the sums; returns |p|^2 (for R_ext). */
uint64_t gyration_sums_add(gyration_sums *g, const int64_t *p, int dim);

/* PDLA_ERANGE if p lies beyond the coordinate limit. */
int engine_check_range(const pdla_engine *e, const int64_t *p, char *err, size_t errlen);

/* Raise R_ext to cover |p| (atomic max: the worker that appends p raises
 * it before publishing p, so a walker that has acquired the count sees an
 * R_ext that covers every particle below it). */
void engine_raise_r_ext(pdla_engine *e, const int64_t *p);

/* Add p to the gyration sums, R_ext and the R_g samples (caller holds
 * gyration_mu when workers run). */
int engine_gyration_add(pdla_engine *e, const int64_t *p, char *err, size_t errlen);
/* The same, with --arrival's row for p at `index`, its index in the tree
 * (workers: the append order, not the order they reach the sums). */
int engine_gyration_add_at(pdla_engine *e, const int64_t *p, uint64_t index, char *err, size_t errlen);

/* Serial insertion (one thread): tree, map, gyration, R_ext. */
int engine_add_particle(pdla_engine *e, const int64_t *p, char *err, size_t errlen);
/* The same, descending the tree from the lowest node of walker state k's
 * cached path that contains p (search_path_start) instead of the root. */
int engine_add_walker_particle(pdla_engine *e, const int64_t *p, const search_state *k, char *err,
                               size_t errlen);
#endif
