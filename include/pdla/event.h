/*
 * event.h - the `event` model of pdla: event-driven hard disks (2D) or
 * spheres (3D) in a box, around an immobile seed of infinite mass (seed 001,
 * Nassib and Dashiell). A free particle that touches the seed or a stuck
 * particle sticks with probability p and stops; every other contact is an
 * elastic collision. Allocates none of the DLA tree or walkers.
 *
 * Units: lengths as given (radii), masses = density * volume of the particle
 * (pi r^2 in 2D, 4/3 pi r^3 in 3D), energies in k_B T as given, time derived.
 *
 * Parameters are rows of the shared parameter table (ev_param_table,
 * pdla/params.h): the CLI's parsing, --help, validation, the output's
 * /parameters attributes and the resume rule are all generated from it.
 */
#ifndef PDLA_EVENT_H
#define PDLA_EVENT_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/params.h"

#define EV_MAX_SPECIES 8

enum ev_walls { EV_WALLS_ELASTIC = 0, EV_WALLS_PERIODIC = 1 };
enum ev_velocities { EV_VEL_MAXWELL = 0, EV_VEL_FIXED = 1 };
enum ev_start { EV_START_RANDOM = 0, EV_START_LATTICE = 1 };

typedef struct ev_species {
    uint64_t count;
    double radius, density;
    int sticky; /* 1: sticks on contact with the cluster (with --stick-p); 0: a bath
                 * particle, every contact elastic, the cluster an infinite mass */
} ev_species;

/* Every parameter of the model; the fields are named in ev_param_table. */
typedef struct ev_params {
    int dim;                 /* 2 or 3 */
    uint64_t particles;      /* when species is empty: one species of this many */
    double radius, density;  /* ... with this radius and density */
    char species[256];       /* "COUNT:RADIUS:DENSITY[:STICKY][,...]" or "" */
    char seeds[512];         /* file of immobile seeds (replace the central one), or "" */
    double packing;          /* volume fraction of the free particles in the box */
    int walls;               /* enum ev_walls */
    uint64_t seed;           /* random seed */
    double kT;               /* k_B T */
    int velocities;          /* enum ev_velocities */
    int start;               /* enum ev_start */
    double seed_radius;      /* radius of the central seed; 0: no seed (a plain gas) */
    double stick_p;          /* sticking probability in [0, 1] */
    double t_max;            /* stop at this time (0: no limit) */
    uint64_t max_stuck;      /* stop at this many stuck particles (0: no limit) */
    uint64_t max_events;     /* stop after this many events (0: no limit) */
    double series_dt;        /* time between rows of the series */
} ev_params;

/* The model's rows of the parameter table (pdla/params.h, models =
 * PDLA_MODEL_EVENT) over ev_params; *n gets its length. Validation, the
 * /parameters attributes, the checkpoint's resume rule and the CLI options
 * are generated from it by the shared code (pdla_param_*). */
const pdla_param_desc *ev_param_table(size_t *n);

/* Defaults from the table. */
void ev_params_default(ev_params *p);
/* Set one parameter (its option or scene key, '_' = '-') from text, checked
 * against its row: 0, or -1 with one line in err naming the option. */
int ev_param_set(ev_params *p, const char *name, const char *value, char *err, size_t errlen);
/* Cross-field validation (species, packing, box vs cell size): 0 or -1. */
int ev_params_check(const ev_params *p, char *err, size_t errlen);
/* The --help text (allocated; caller frees). */
char *ev_help_text(void);

/* The simulation. */
typedef struct ev_sim ev_sim;

enum ev_event_kind { EV_EV_PAIR = 0, EV_EV_WALL = 1, EV_EV_STICK = 2, EV_EV_CELL = 3 };

/* One processed event as the optional trace callback sees it. */
typedef struct ev_trace_event {
    double t;
    uint32_t i, j; /* j: partner, or UINT32_MAX for a wall */
    int kind;      /* enum ev_event_kind */
} ev_trace_event;
typedef void (*ev_trace_fn)(const ev_trace_event *e, void *user);

/* Called between two events every 65536 events and at each series row
 * (progress, checkpoints); non-zero stops the run as if interrupted. */
typedef int (*ev_tick_fn)(ev_sim *s, void *user);
void ev_set_tick(ev_sim *s, ev_tick_fn fn, void *user);

/* Build the start state (placement, velocities). Returns NULL with one line
 * in err: bad parameters (exit 2) or a packing that cannot be reached. */
ev_sim *ev_create(const ev_params *p, char *err, size_t errlen);
void ev_free(ev_sim *s);
/* Trace every physical event (pairs, walls, sticks), for tests. */
void ev_set_trace(ev_sim *s, ev_trace_fn fn, void *user);

/* Why ev_run stopped. */
enum ev_stop { EV_STOP_ALL_STUCK = 1, EV_STOP_TIME, EV_STOP_STUCK, EV_STOP_EVENTS,
               EV_STOP_NO_EVENTS, EV_STOP_INTERRUPT };
/* Run until a stop condition of p; `interrupt`, if not NULL, is polled. */
int ev_run(ev_sim *s, volatile const int *interrupt);
/* Process events up to time t (all particles then advanced to t). */
int ev_run_until(ev_sim *s, double t);
/* Advance every particle's stored position to the current time. */
void ev_sync(ev_sim *s);

/* Read-out. */
typedef struct ev_stats {
    double t;
    uint64_t events, collisions, wall_hits, sticks, cell_crossings, invalid;
    uint64_t stuck;          /* stuck particles (without the seed) */
    double ke_free;          /* kinetic energy of the free particles */
    double ke_stuck;         /* kinetic energy carried away by the stuck ones */
    double virial;           /* sum over pair collisions of r_ij . dp_i */
    double box;              /* box side */
    double max_overlap;      /* largest overlap / (r_i + r_j) ever seen in a collision */
} ev_stats;
void ev_get_stats(const ev_sim *s, ev_stats *st);
int ev_dim(const ev_sim *s);
size_t ev_count(const ev_sim *s);          /* particles without the seed */
/* Position (current time, ev_sync first) and velocity of particle i; the
 * seed is index ev_count(s) when there is one. */
const double *ev_pos(const ev_sim *s, size_t i);
const double *ev_vel(const ev_sim *s, size_t i);
double ev_radius(const ev_sim *s, size_t i);
double ev_mass(const ev_sim *s, size_t i);
int ev_species_of(const ev_sim *s, size_t i);
/* Particles of sticky kinds (ev_count(s) when no kind is a bath), and
 * whether kind k sticks (STICKY in --species; 0 for k out of range). The
 * run's "all stuck" means every particle of a sticky kind stuck. */
size_t ev_sticky_count(const ev_sim *s);
int ev_species_sticky(const ev_sim *s, int k);
int ev_has_seed(const ev_sim *s);
/* The seeds: the central one (0 or 1) or a --seeds file's, indices
 * ev_count(s) .. ev_count(s) + ev_seed_count(s) - 1. */
size_t ev_seed_count(const ev_sim *s);
/* Stuck particles in arrival order: index and the time they stuck. */
size_t ev_stuck_list(const ev_sim *s, const uint32_t **idx, const double **t);
/* What particle i < ev_count(s) stuck to, as cluster.h5's /cluster/parent
 * stores it: the particle's index, -1 - k for seed k (the central seed:
 * -1), or INT64_MIN when i is not stuck. */
int64_t ev_parent(const ev_sim *s, size_t i);
/* The kinds of particles: their number, and kind k's count, radius,
 * density and stickiness (NULL for k out of range). */
int ev_species_count(const ev_sim *s);
const ev_species *ev_species_get(const ev_sim *s, int k);
/* Pressure P from the collision virial over the time [t0, t] with
 * virial sum difference dvir: (2 KE/d + dvir/(d (t - t0))) / V. */
double ev_pressure(const ev_sim *s, double dvir, double dt);
/* Largest overlap / (r_i + r_j) over all pairs now (O(N) with the cells). */
double ev_max_overlap_now(ev_sim *s);

/* Fractal dimension of a cluster from R_g(k) of its first k particles in
 * arrival order (pos: n rows of dim coordinates): 1 / slope of log R_g
 * against log k over k in [k_lo, k_hi], k_hi the last k with R_g < rg_max
 * (the model uses box side / 8: farther the box shapes the cluster) and
 * k_lo = max(20, k_hi / 30). NaN with k_lo = k_hi = 0 when k_hi < 5 k_lo.
 * rg, when not NULL, gets R_g(k) for k = 1..n. Used for /results D_f_rg and
 * by `pdla analyze`. */
double ev_df_fit(const double *pos, size_t n, int dim, double rg_max, double *rg,
                 uint64_t *k_lo, uint64_t *k_hi);

/* Run with series recording and write DIR's cluster.h5 (see event_out.c). */
typedef struct ev_series {
    size_t n, cap;
    double *t, *ke, *pressure;
    uint64_t *stuck, *collisions;
} ev_series;
int ev_run_series(ev_sim *s, ev_series *ser, volatile const int *interrupt);
void ev_series_free(ev_series *ser);
/* 0; -1 with one line in err (the file at path, if any, untouched); or 1
 * when the new file is in place but its directory could not be synced
 * (err says so; its sidecars should still be written). */
int ev_write_h5(const ev_sim *s, const ev_series *ser, const char *path, const char *cmdline,
                int stop_reason, char *err, size_t errlen);
const char *ev_stop_name(int why);
/* ParaView sidecars of the cluster.h5 at h5_path (see ev_out.c): 0 or -1. */
int ev_write_xdmf(const ev_sim *s, const char *h5_path, char *err, size_t errlen);

/* Checkpoints: DIR/checkpoint.h5 holds the whole state (particles with
 * their local times, pending events, cells, counters, RNG, stuck list,
 * series and its open interval). Written to a temporary file, synced and
 * renamed over the old one, which is kept as checkpoint.prev.h5. A run
 * resumed from it takes the same events at the same times, bit for bit, as
 * one never stopped (tests/event: resume). */
int ev_checkpoint_write(const ev_sim *s, const ev_series *ser, const char *dir,
                        const char *cmdline, char *err, size_t errlen);
/* Load PATH: the simulation (NULL with one line in err) and its series.
 * The stop conditions t_max, max_stuck, max_events may then be changed. */
ev_sim *ev_checkpoint_load(const char *path, ev_series *ser, char *err, size_t errlen);
/* Can s's stop conditions, as they are now, end its run? After a resume
 * changed them (the load checked the checkpoint's): 0, or -1 with the line
 * a new run gets (a --seeds run whose seeds no particle can touch, with no
 * --t-max or --max-events). */
int ev_stop_possible(const ev_sim *s, char *err, size_t errlen);
/* The command line's --checkpoint-every (wall seconds, 0: none), recorded in
 * each checkpoint (root attribute schedule_every_seconds; absent before
 * session 27) so that a bare --resume keeps it: before, it wrote only its
 * final checkpoint. The load refuses a recorded value that is not 0 to 1e9
 * seconds (one line). */
void ev_set_checkpoint_every(ev_sim *s, double seconds);
/* *seconds: the value s records; 1 when s was loaded from a checkpoint that
 * recorded one (or one was set), else 0 (and *seconds 0). */
int ev_checkpoint_every(const ev_sim *s, double *seconds);
ev_params *ev_params_of(ev_sim *s);

/* `pdla check` of an event-model file (ev_check.c): a cluster.h5, or a
 * checkpoint.h5 loaded by ev_checkpoint_load (which verifies its own
 * invariants, with a looser tolerance) and then checked as one. Each kind
 * of check counts its failures and describes the first one. Geometry is
 * compared with a tolerance relative to each pair's contact distance:
 * EV_CHECK_TOL (the engine's stated bound, tests/event TOL) plus the
 * round-off of two positions (64 epsilon of the box side and of the fastest
 * speed times twice the clock, as the checkpoint loader reckons it), the
 * round-off capped at 1e-2 of the contact distance. Overlaps are found on
 * a grid of cells, O(N); checking stops after EV_CHECK_MAX_FAILURES. */
#define EV_CHECK_TOL 1e-10
#define EV_CHECK_MAX_FAILURES 10000u
enum ev_check_kind {
    EV_CHECK_FINITE,   /* a position, radius, velocity or time not finite */
    EV_CHECK_BOX,      /* a centre outside the box */
    EV_CHECK_OVERLAP,  /* two bodies (seeds, stuck, free) overlapping */
    EV_CHECK_CONTACT,  /* a stuck particle not at contact with its parent */
    EV_CHECK_PARENT,   /* a parent that is no seed and no earlier stuck particle */
    EV_CHECK_ARRIVAL,  /* arrival times out of order or outside [0, time] */
    EV_CHECK_INDEX,    /* a stuck particle's index repeated or out of range */
    EV_CHECK_SPECIES,  /* a kind id out of range, a radius not its kind's, a bath kind stuck */
    EV_CHECK_COUNTS,   /* counts that disagree (rows, /results, /species, particles) */
    EV_CHECK_ENERGY,   /* kinetic energies not as recomputed or not conserved */
    EV_CHECK_SERIES,   /* /series out of order or not ending at /results */
    EV_CHECK_SEEDS,    /* the seeds not as their parameters describe them */
    EV_CHECK_NKINDS
};
/* The kind's name in reports ("overlap", ...). */
const char *ev_check_kind_name(int kind);
typedef struct ev_check_item {
    uint64_t count;      /* failures of this kind */
    int64_t a, b;        /* the first: its row, and the other one's (-1: none); for finite, box
                          * and overlap a body number: the seeds, then the stuck rows, then
                          * the free rows */
    double value, limit; /* the first: what was found and what was allowed (NaN: not a number) */
    char first[320];     /* the first, in words */
} ev_check_item;
typedef struct ev_check_report {
    int checkpoint;          /* 1: a checkpoint.h5, loaded */
    int dim, periodic;
    uint64_t particles;      /* stuck + free as declared */
    uint64_t seeds, stuck, free_rows;
    double box, time;        /* box side, the clock */
    double round_off;        /* the tolerance's absolute part (before its cap) */
    double worst_overlap;    /* largest (contact - distance) / contact over compared pairs (-inf: none) */
    double worst_contact;    /* largest |distance - contact| / contact of a stuck particle and its parent */
    double ke_free;          /* recomputed from the free velocities and the kinds' masses */
    double ke_balance;       /* (ke_free + ke_stuck) / series' first energy - 1 (NaN: not checked) */
    uint64_t pairs;          /* pairs of bodies compared */
    uint64_t series_rows;
    int series_at_end;       /* 1: the last row was compared with the end state (a run that ended) */
    int stopped;             /* checking stopped after EV_CHECK_MAX_FAILURES */
    uint64_t failures;
    int pass;                /* no failure of any kind */
    ev_check_item item[EV_CHECK_NKINDS];
} ev_check_report;
/* ev_check_file's returns besides 0 (checked, r filled). */
enum { EV_CHECK_NOT_EVENT = 1, /* not an event cluster file or checkpoint (err says why) */
       EV_CHECK_DAMAGED = 2    /* unreadable, a dataset missing or malformed, or the
                                * checkpoint loader refused it (err has its line) */ };
int ev_check_file(const char *path, ev_check_report *r, char *err, size_t errlen);
/* The same checks on a loaded simulation and its series (ev_sync is called:
 * the free particles are advanced to the clock). 0, or EV_CHECK_DAMAGED
 * when out of memory. */
int ev_check_sim(ev_sim *s, const ev_series *ser, ev_check_report *r, char *err, size_t errlen);

#endif
