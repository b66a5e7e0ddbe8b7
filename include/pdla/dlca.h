/*
 * dlca.h - public API of pdla's diffusion-limited cluster-cluster aggregation
 * (DLCA) model on a periodic hypercubic lattice in 2 to 5 dimensions (seed
 * 002, Hawick, James and Scogings 2006). A DLCA run allocates none of the
 * DLA engine's tree or walkers.
 *
 * The model. Sites of an L_1 x ... x L_d box with periodic boundaries are
 * numbered k = x_1 + x_2 L_1 + x_3 L_1 L_2 + ... (the seed's k-index). N
 * monomers start on distinct random sites; face-adjacent monomers start
 * joined. Each attempt picks a cluster uniformly, accepts it with
 * probability m(s) / m_bound where m(s) = s^mobility (kinetic Monte Carlo by
 * thinning: m_bound is the largest mobility present), and moves it rigidly
 * one site along a random axis and sign (with probability `drift` the move
 * is instead one site down the last axis: gravity). Time advances by
 * 1 / (N_c m_bound) per attempt, so t counts monomer-move units: a monomer
 * moves once per unit of time on average. A move onto an occupied site is
 * refused; after a move every other cluster face-adjacent to the mover
 * joins it with probability `sticking` (one draw per cluster, in cluster-id
 * order). The run stops at `until_clusters` clusters, at time
 * `until_time`, after `max_attempts` attempts, or when a cluster spans the
 * box (its extent along an axis reaches L: it touches its own image).
 *
 * Collision search (dlca_params.search): DLCA_SEARCH_LATTICE keeps a bit
 * per site (occupied or not: a move costs O(cluster size)) and names the
 * cluster at a contact through boxes listing the clusters; BOXES is the
 * seed's grid-boxing (boxes of side A doubling to hold the largest
 * cluster, halo search, all-pairs once 3A >= L on an axis); ALLPAIRS tests
 * every cluster. All three give the same history, bit for bit, for a seed.
 *
 * Errors follow pdla.h: 0 or a negative PDLA_E* code with a one-line reason.
 */
#ifndef PDLA_DLCA_H
#define PDLA_DLCA_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/params.h"
#include "pdla/pdla.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DLCA_MAX_DIM 5
/* The longest box axis, in sites: a cluster stores its monomers' offsets
 * from its anchor in 16 bits (runs/dlca/memory.txt). */
#define DLCA_MAX_AXIS 16384

typedef enum { DLCA_SEARCH_LATTICE = 0, DLCA_SEARCH_BOXES = 1, DLCA_SEARCH_ALLPAIRS = 2 } dlca_search;

/* Each parameter's bit in "given" masks (pdla_param_desc.bit). */
enum {
    DLCA_PARAM_DIM = 1u << 0,
    DLCA_PARAM_BOX = 1u << 1,
    DLCA_PARAM_FILL = 1u << 2,
    DLCA_PARAM_COUNT = 1u << 3,
    DLCA_PARAM_MOBILITY = 1u << 4,
    DLCA_PARAM_STICKING = 1u << 5,
    DLCA_PARAM_DRIFT = 1u << 6,
    DLCA_PARAM_UNTIL_CLUSTERS = 1u << 7,
    DLCA_PARAM_UNTIL_TIME = 1u << 8,
    DLCA_PARAM_MAX_ATTEMPTS = 1u << 9,
    DLCA_PARAM_SEED = 1u << 10,
    DLCA_PARAM_SEARCH = 1u << 11,
    DLCA_PARAM_GRID_BOX = 1u << 12
};

/* Every field's unit, default and range live in one row of the parameter
 * table (dlca_params.c, dlca_param_table); dlca_params_default() fills them. */
typedef struct dlca_params {
    int dim;                  /* d, 2..5 */
    uint32_t box[DLCA_MAX_DIM]; /* L_1..L_d, each 2..DLCA_MAX_AXIS; product < 2^31 (PDLA_PT_BOX) */
    double fill;              /* phi in (0, 1): N = round(phi V) when count is 0 */
    uint64_t count;           /* N (monomers); 0: from fill */
    double mobility;          /* gamma: a cluster of s monomers moves at rate s^gamma */
    double sticking;          /* p in (0, 1] */
    double drift;             /* probability in [0, 1) that a move is a step down the last axis */
    uint64_t until_clusters;  /* stop at this many clusters (>= 1) */
    double until_time;        /* stop at this time (0: never) */
    uint64_t max_attempts;    /* stop after this many attempts (0: never) */
    uint64_t seed;
    int search;               /* dlca_search */
    int grid_box;             /* first box side A of BOXES (a power of two) */
    /* How many lengths the --box text gave (dlca_param_set): 1 is one for
     * every axis, any other count must be dim. Kept because box[] cannot
     * tell "64" from "64x64x64" (both fill every axis with 64), and
     * --box 64x64x64 --dim 2 ran a 64x64 box without a word. 0: box[] was
     * filled otherwise (the default, a file, the caller): no rule. */
    int box_lengths;
} dlca_params;

PDLA_API void dlca_params_default(dlca_params *p);
/* 0, or PDLA_EINVAL naming the first bad field. Also refuses a lattice and
 * monomers that would not fit in half the machine's memory. */
PDLA_API int dlca_params_validate(const dlca_params *p, char *err, size_t errlen);
/* The same for a run whose monomers come from a --start file: --fill and
 * --count are not checked (the file's count is, when it is read). */
PDLA_API int dlca_params_validate_start(const dlca_params *p, char *err, size_t errlen);
/* N for these parameters (count, or round(fill V)). */
PDLA_API uint64_t dlca_params_monomers(const dlca_params *p);

typedef enum {
    DLCA_RUNNING = 0,
    DLCA_STOP_CLUSTERS = 1,
    DLCA_STOP_TIME = 2,
    DLCA_STOP_SPANNING = 3,
    DLCA_STOP_ATTEMPTS = 4,
    DLCA_STOP_CALLER = 5
} dlca_stop;

PDLA_API const char *dlca_stop_name(int stop);
PDLA_API const char *dlca_search_name(int search);

typedef struct dlca_sim dlca_sim;

/* Random start (seeded by p->seed). */
PDLA_API int dlca_create(dlca_sim **out, const dlca_params *p, char *err, size_t errlen);
/* Start from the given distinct sites (k-indices); p->count/fill are ignored. */
PDLA_API int dlca_create_sites(dlca_sim **out, const dlca_params *p, const uint32_t *sites,
                               uint64_t n, char *err, size_t errlen);
PDLA_API void dlca_destroy(dlca_sim *s);

/* Run up to `attempts` more attempts (0: no limit) or until a stop
 * condition; returns the stop reason (DLCA_RUNNING if only `attempts` ran). */
PDLA_API int dlca_run(dlca_sim *s, uint64_t attempts);
/* The same, pausing (DLCA_RUNNING) before the first attempt at which the
 * time is t_pause or later (t_pause <= 0: no pause). Pausing does not
 * change the history. */
PDLA_API int dlca_run_to(dlca_sim *s, uint64_t attempts, double t_pause);
/* The time and the attempts so far (cheap, unlike dlca_get_stats). */
PDLA_API double dlca_time(const dlca_sim *s);
PDLA_API uint64_t dlca_attempts(const dlca_sim *s);

/* The monomers of a start file (`--start`): a text file of one monomer a
 * line, d integer coordinates (0 <= x_a < L_a) separated by blanks ('#'
 * comments), or an HDF5 file with /monomers/position [N][d] (a DLCA
 * cluster.h5). *sites (malloc'd, the caller frees) gets their k-indices in
 * file order. 0, or PDLA_EINVAL with one line naming the file and the line
 * or monomer: a coordinate outside the box, two monomers on one site, a
 * wrong count of coordinates, no monomers. Start a run from them with
 * dlca_create_sites. */
PDLA_API int dlca_read_start(const char *path, const dlca_params *p, uint32_t **sites, uint64_t *n, char *err,
                             size_t errlen);
/* Do two of the n sites, each below V (the box's site count), hold the same
 * value? One bit a site, O(n): seen is (V + 63) / 64 words, all clear, and
 * left clear (a caller checking many arrays of one box keeps one), or NULL
 * for bits of the call's own (V / 8 bytes: at most 256 MiB for the model's
 * fewer than 2^31 sites). 1 with *a < *b the first repeat's indices (*b
 * the lowest index whose site an earlier one holds, *a that one), 0 if all
 * differ, PDLA_ENOMEM, or PDLA_EINVAL (a site >= V, or V > 2^32). The
 * start files, the snapshots a resume reads back and the DLCA tools all
 * check their monomers with it. */
PDLA_API int dlca_shared_site(const uint32_t *site, uint64_t n, uint64_t V, uint64_t *seen, uint64_t *a,
                              uint64_t *b);

typedef struct dlca_stats {
    double t;              /* physical time, monomer-move units */
    uint64_t attempts;     /* cluster picks */
    uint64_t moves;        /* accepted and performed moves */
    uint64_t monomer_moves; /* sum of the sizes of the moved clusters */
    uint64_t merges;
    uint64_t n_monomers, n_clusters, largest;
    double sum_s2;         /* sum of s^2 over clusters (weight-average size = sum_s2 / N) */
    int stop;              /* dlca_stop */
    int search_now;        /* the search in use (BOXES falls back to ALLPAIRS) */
    int box_side;          /* A of BOXES (0 otherwise) */
    uint64_t candidates;   /* clusters pair-tested (BOXES, ALLPAIRS) */
    uint64_t digest;       /* hash of the whole history of attempts */
    uint64_t bytes;        /* memory held by the model */
} dlca_stats;
PDLA_API void dlca_get_stats(const dlca_sim *s, dlca_stats *out);
PDLA_API const dlca_params *dlca_get_params(const dlca_sim *s);

/* Full consistency check (sizes sum to N, every site once, no overlap,
 * the bit lattice and boxes agree, no two clusters face-adjacent when
 * sticking = 1): 0 or PDLA_EINVAL with the first fault. O(N log N). */
PDLA_API int dlca_check(const dlca_sim *s, char *err, size_t errlen);

/* Monomer sites and their cluster numbers (0..N_c-1, in cluster-id order);
 * both arrays hold N. */
PDLA_API void dlca_export_sites(const dlca_sim *s, uint32_t *site, uint32_t *cluster);
/* Per cluster (same numbering): size and radius of gyration (lattice units). */
PDLA_API void dlca_cluster_table(const dlca_sim *s, uint64_t *size, double *rg);

/* Fractal dimension from R_g against size over the clusters of size >=
 * s_min: the clusters are binned by size in factors of sqrt 2, and
 * log s = D_f log R_g + c is fitted to the bins' mean logs (bins with at
 * least 2 clusters; each bin weighted by its count). Returns the number of
 * bins used (< 2: no fit; *df and *df_err NaN). */
PDLA_API int dlca_fractal_dim(const uint64_t *size, const double *rg, size_t n, uint64_t s_min,
                              double *df, double *df_err);

/* One row of the time series, added each time N_c fell by 1% (and at the
 * start and the end). */
typedef struct dlca_row {
    double t;
    uint64_t attempts, n_clusters, largest;
    double mean_size, weight_size;
} dlca_row;
PDLA_API const dlca_row *dlca_series(const dlca_sim *s, size_t *n);

/* Write path (which must not exist) as a DLCA cluster.h5: root attribute
 * model = "dlca", /parameters (from the descriptor table), /results,
 * /series, /clusters, /monomers (site, cluster, position [N][d]), /Code. */
PDLA_API int dlca_write_h5(const dlca_sim *s, const char *path, const char *command_line,
                           double wall_s, char *err, size_t errlen);

/* Snapshots (`--snapshot-every T`): the sites and cluster numbers (as
 * dlca_export_sites) at a time. Added to an existing DLCA cluster.h5 or
 * checkpoint as /snapshots (attributes count and every = T) with groups
 * <i> (i = 0, 1, ...), each with datasets site [N], cluster [N] and
 * position [N][d] (the sites' coordinates) and attributes t, attempts,
 * n_clusters; `stopped` 1 adds the attribute stopped = 1: the run ran out
 * of memory for snapshots and takes none after the last one. 0 or PDLA_EIO. */
typedef struct dlca_snapshot {
    double t;
    uint64_t attempts, n_clusters;
    uint32_t *site, *cluster;
} dlca_snapshot;
PDLA_API int dlca_write_snapshots_h5(const char *path, const dlca_params *p, const dlca_snapshot *snaps, size_t n,
                                     uint64_t n_monomers, double every, int stopped, char *err, size_t errlen);
/* The time of the snapshot after one at t (or after the start, t = 0):
 * the first attempt at or after the returned time takes it. The first
 * multiple of T after t, and always after t (where T is below t's rounding
 * step, the multiple rounds back to t). The run loop and
 * dlca_snapshots_check both use it, so the check is the writer's rule. */
PDLA_API double dlca_next_snapshot(double t, double T);
/* The snapshots of a file so written (a checkpoint: a resumed run keeps
 * them): *snaps (malloc'ed, *n of them, each with its arrays, for the
 * caller to free), *every and *stopped (the optional attribute: 0 or 1);
 * none (0) if the file has no /snapshots. The count attribute must be the
 * number of groups under /snapshots, at most the snapshots due by the
 * checkpoint's time t_end (floor(t_end / every) + 1) and within
 * dlca_snapshots_fit, checked before any is read; each one's time finite,
 * in order and not past t_end as read.
 * 0, or PDLA_EIO (PDLA_EINVAL for those checks) with nothing left
 * allocated. */
PDLA_API int dlca_read_snapshots_h5(const char *path, uint64_t n_monomers, double t_end, dlca_snapshot **snaps,
                                    size_t *n, double *every, int *stopped, char *err, size_t errlen);
/* Do n snapshots of n_monomers fit in the snapshot budget, a quarter of
 * this machine's memory (8 bytes a monomer each; the run may take half)? */
PDLA_API int dlca_snapshots_fit(size_t n, uint64_t n_monomers);
/* Could the run s have taken these snapshots (as read from its checkpoint
 * with their period `every`)? every finite and above 0 (0 only with no
 * snapshots); in time order, none later than s (time, attempts) nor with
 * fewer clusters than s now; n_clusters in [1, N] and falling; every site
 * in the box and no two monomers on one site; the cluster numbers as
 * dlca_export_sites gives them (0, 1, ..., n_clusters - 1, each cluster's
 * monomers together, in that order); each snapshot at the first attempt at
 * or after its dlca_next_snapshot time (not before it, nor later than one
 * attempt's time step), and none missing: s's time is before the next
 * one's, unless `stopped` (the run took no more, for want of memory). 0,
 * or PDLA_EINVAL (PDLA_ENOMEM) with one line naming the snapshot and the
 * value. */
PDLA_API int dlca_snapshots_check(const dlca_sim *s, const dlca_snapshot *snaps, size_t n, double every, int stopped,
                                  char *err, size_t errlen);

/* ParaView's XDMF 2 sidecar (xdmf.h) of a DLCA cluster.h5 just written
 * with n monomers: points at /monomers/position (site coordinates, lattice
 * units, wrapped into the box) with the arrays "cluster" and "site"; beside
 * it as cluster.xdmf2. With snapshots (nsnaps > 0) it is a temporal
 * collection: one time step per snapshot (/snapshots/<i>, at its t) and the
 * end (/monomers at t_end, unless the last snapshot is at t_end). d = 4, 5:
 * nothing written (0). Every other sidecar of h5_path (xdmf.h kinds), and
 * in 4D and 5D cluster.xdmf2 itself, is removed: an older run's would
 * describe another file. 0 or PDLA_EIO. */
PDLA_API int dlca_write_xdmf(const char *h5_path, int dim, uint64_t n, const dlca_snapshot *snaps, size_t nsnaps,
                             double t_end, char *err, size_t errlen);

/* Checkpoints: everything needed to go on (parameters, random state,
 * clusters, counters, series) in one HDF5 file (model = "dlca-checkpoint").
 * A run resumed from one continues with the same history, bit for bit, as
 * the run that was never stopped. Load refuses a damaged or foreign file
 * with one line (PDLA_EIO). */
PDLA_API int dlca_checkpoint_write(const dlca_sim *s, const char *path, char *err, size_t errlen);
PDLA_API int dlca_checkpoint_load(dlca_sim **out, const char *path, char *err, size_t errlen);
/* The command line's checkpoint schedule, recorded in each checkpoint (root
 * attributes schedule_every_seconds, schedule_every_attempts; absent in
 * checkpoints before session 27) so that a bare --resume keeps it: before,
 * it wrote only its final checkpoint. Load refuses a schedule that is not
 * a period of 0 to 1e9 seconds and an unsigned attempt count, or one of the
 * two attributes without the other (PDLA_EIO, one line). */
typedef struct dlca_ckpt_schedule {
    double every_seconds;    /* wall time; 0: no time trigger */
    uint64_t every_attempts; /* 0: no attempt trigger */
} dlca_ckpt_schedule;
/* The schedule the next checkpoint of s records (a new run: none, 0 and 0). */
PDLA_API void dlca_set_checkpoint_schedule(dlca_sim *s, const dlca_ckpt_schedule *sc);
/* *sc: the schedule of s; 1 when s was loaded from a checkpoint that
 * recorded one (or one was set), else 0 (and *sc all 0). */
PDLA_API int dlca_checkpoint_schedule(const dlca_sim *s, dlca_ckpt_schedule *sc);
/* New stop conditions for a resumed run; returns the stop they give now. */
PDLA_API int dlca_set_stops(dlca_sim *s, uint64_t until_clusters, double until_time, uint64_t max_attempts);

/* ---- `pdla check` of a DLCA file ----------------------------------------
 * dlca_check_file reads a DLCA cluster.h5 (root attribute model = "dlca")
 * or checkpoint ("dlca-checkpoint") and checks it against what a run
 * writes, exactly, in integers where the values are integers:
 *  - every monomer's position inside the box and its /monomers/site the
 *    k-index of that position; no two monomers on one site;
 *  - the cluster numbers 0, 1, ..., N_c - 1 in monomer order, each
 *    cluster's monomers together (as the writer numbers them);
 *  - each cluster one face-connected piece on the periodic lattice, and,
 *    with sticking 1, no two clusters face-adjacent (a move joins every
 *    contact, a start every adjacent pair, and the step that spans the box
 *    joins all of its contacts too);
 *  - a spanning stop proved by a cluster that spans (a walk over its face
 *    contacts reaches an extent of L on an axis or winds round the torus),
 *    and no cluster spanning under any other stop;
 *  - /clusters/size the clusters' monomer counts, and /clusters/rg
 *    recomputed by the engine's own function (dlca_rg_offsets) from the
 *    offsets the walk gives, bit for bit; a spanning cluster's offsets
 *    depend on its history (dlca.c, append), so its R_g is only bounded;
 *  - /results: n_monomers, n_clusters, largest, mean and weight-average
 *    size (bit for bit), merges = N - N_c, the move counters, the search
 *    used, D_f and D_f_err (dlca_fractal_dim of the stored table, bit for
 *    bit), and the stop against the state and the stops asked;
 *  - /series: every row in range and order (the loader's rule), its mean
 *    size bit for bit, the first row at the start and, after a stop, the
 *    last row the final state;
 *  - /snapshots: as a resume checks them, and each snapshot's clusters as
 *    the final ones (one piece each, apart with sticking 1).
 * A checkpoint is loaded by dlca_checkpoint_load (so verified as --resume
 * does) and its state checked the same way, its own cluster table, totals
 * and series taking the place of the stored ones.
 * Memory: a bit a site of the box and 44 + 6d bytes a monomer (the file
 * must store what it declares, and both must fit in half of this machine's
 * memory, before anything is allocated: else PDLA_ENOMEM), plus the
 * snapshots as a resume holds them. Reading stops once
 * DLCA_CHECK_MAX_FAILURES failures are counted (r->stopped). */
enum {
    DLCA_CK_BOX,       /* a monomer outside the box */
    DLCA_CK_SITE,      /* /monomers/site is not the k-index of the position */
    DLCA_CK_SHARED,    /* two monomers on one site */
    DLCA_CK_NUMBERING, /* cluster numbers not as the writer gives them */
    DLCA_CK_PIECES,    /* a cluster that is not one face-connected piece */
    DLCA_CK_TOUCH,     /* two clusters face-adjacent with sticking 1 */
    DLCA_CK_SPANNING,  /* the stop and the clusters disagree about spanning */
    DLCA_CK_SIZE,      /* /clusters/size, or its length */
    DLCA_CK_RG,        /* /clusters/rg, or its length */
    DLCA_CK_RESULTS,   /* a /results value */
    DLCA_CK_STOP,      /* /results stop against the state and the stops asked */
    DLCA_CK_SERIES,    /* /series */
    DLCA_CK_SNAPSHOTS, /* /snapshots */
    DLCA_CK_KINDS
};
#define DLCA_CHECK_MAX_FAILURES 10000u

typedef struct dlca_check_report {
    int checkpoint;             /* 1: a checkpoint, 0: a cluster.h5 */
    int dim;
    uint64_t box[DLCA_MAX_DIM];
    double sticking;
    uint64_t monomers;          /* rows of /monomers (N) */
    uint64_t clusters;          /* clusters numbered in /monomers (0: the numbers are not the writer's) */
    uint64_t largest;           /* the largest of them */
    char stop[16];              /* /results stop */
    uint64_t spanning;          /* clusters that span the box */
    uint64_t rg_exact;          /* R_g values recomputed and compared bit for bit */
    uint64_t rg_bounded;        /* R_g values of spanning clusters, only bounded */
    uint64_t series_rows;
    uint64_t snapshots;
    int stopped;                /* reading stopped at DLCA_CHECK_MAX_FAILURES */
    uint64_t fail[DLCA_CK_KINDS];
    char first[DLCA_CK_KINDS][256]; /* the first failure of each kind, in words */
    int pass;                   /* 1: no failure and every check ran */
} dlca_check_report;

/* The kind's name: "box", "site", "shared", "numbering", "pieces",
 * "touch", "spanning", "size", "rg", "results", "stop", "series",
 * "snapshots" (JSON keys of `pdla check --json`); NULL past the last. */
PDLA_API const char *dlca_check_kind_name(int kind);
/* 1 if path is a regular HDF5 file whose root attribute model is "dlca" or
 * "dlca-checkpoint" (quietly, never opening a FIFO), else 0. */
PDLA_API int dlca_check_wanted(const char *path);
/* Check path as above into *r. 0: checked (r->pass says whether it
 * passes); PDLA_EINVAL: not a DLCA file, or one pdla cannot have written
 * (a dataset missing, of another type or shape, declaring more than the
 * file stores, /parameters out of the model's ranges: err says which);
 * PDLA_EIO: the checkpoint loader refused it as damaged, or a read failed
 * midway; PDLA_ENOMEM. */
PDLA_API int dlca_check_file(const char *path, dlca_check_report *r, char *err, size_t errlen);

/* ---- the parameter table ----------------------------------------------
 * Rows of the shared machinery (pdla/params.h, models = PDLA_MODEL_DLCA): the
 * options and scene keys are the rows' `option`, the /parameters attributes
 * their `name`; pdla_param_format, pdla_param_validate and the rest apply. */
PDLA_API const pdla_param_desc *dlca_param_table(size_t *n);
/* Parse text into the field of row d in *p (numbers may end in k, M or G;
 * a box is L1xL2[x...]), checked against the row's range: 0 or PDLA_EINVAL
 * with a one-line reason naming the option. */
PDLA_API int dlca_param_set(dlca_params *p, const pdla_param_desc *d, const char *text, char *err,
                            size_t errlen);

#ifdef __cplusplus
}
#endif
#endif /* PDLA_DLCA_H */
