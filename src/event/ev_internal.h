/*
 * ev_internal.h - the event model's state, shared by its source files.
 */
#ifndef PDLA_EV_INTERNAL_H
#define PDLA_EV_INTERNAL_H

#include <stdint.h>

#include "pdla/event.h"
#include "rng.h"

enum { EV_K_NONE = 0, EV_K_PAIR = 1, EV_K_WALL = 2 };

/* From this many particles on, each event prefetches the lines of the next
 * few (ev_core.c, "look-ahead"). Below it the arrays sit in the caches and
 * the prefetches only cost instructions (always on: 2D +5-11% and 3D +4%
 * at 3e3-1e4, 3D even at 1e4 and 3e4); at 1e5 they are even, at 1e6 they
 * save 9% (3D) and 20% (2D) of the engine's CPU in quiet rounds (AMD EPYC
 * VM, runs/event/speed-session14.md). */
#define EV_LOOKAHEAD_MIN 50000u

/* A particle's pending events: its earliest pair or wall event and its
 * next cell crossing (see ev_core.c). 32 bytes. */
typedef struct ev_evt {
    double t_pair, t_cell;
    uint32_t partner; /* pair: particle; wall: 2k + side */
    uint32_t pcount;  /* partner's collision counter when predicted */
    int8_t kind;      /* EV_K_* */
    int8_t cell_what; /* 2k + (direction > 0), -1: none */
} ev_evt;

/* What the event loop reads and writes of a particle, besides its
 * kinematics (ps): its pending events, collision counter, cell and queue
 * place, in one 64-byte record, one cache line. At N ~ 1e6 every event
 * touches the particle and its partner at random; with the events in one
 * array and each 4-byte field in an array of its own (until session 15),
 * that cost up to six lines a particle, none of them in the caches. The
 * cell lists' links (cnext) stay a dense array of their own: a scan walks
 * them for every neighbour, and 4 bytes a particle mostly sit in the
 * last-level cache where 64 would not (simulated: runs/event/speed-session15.md). */
typedef struct ev_link {
    ev_evt ev;             /* its pending events */
    uint32_t count;        /* collision counter (stale events) */
    uint32_t cell;         /* its cell */
    uint32_t hpos;         /* place in the heap, or none */
    uint32_t qslot;        /* its bucket list, or none (in the heap) */
    uint32_t qnext, qprev; /* bucket list links */
    uint32_t pad[2];
} ev_link;
_Static_assert(sizeof(ev_link) == 64, "ev_link is one cache line");

typedef struct ev_hent {
    double t;
    uint32_t id;
} ev_hent;

struct ev_sim {
    ev_params par;
    int dim, periodic;
    uint32_t n;           /* particles without the seed */
    uint32_t ntot;        /* n + (seed ? 1 : 0) */
    int has_seed;         /* 1 when there are seeds (indices n .. ntot - 1) */
    uint32_t nseeds;      /* ntot - n: 1 for the central seed, or the file's count */
    double *seed_xr;      /* while building: the file's seeds, D + 1 per seed (ev_seeds.c) */
    int nfree_total;      /* 1 when there are particles that can stick */
    uint32_t nsticky;     /* particles of sticky kinds (n when there is no bath) */
    int has_bath;         /* 1 when a kind never sticks (STICKY 0 in --species) */
    double L, half, V;    /* box side, L/2, volume */
    int lookahead;        /* prefetch the next events' lines (ev_core.c) */
    int nc;               /* cells per dimension */
    int nc_v2;            /* cells per dimension by checkpoint version 2's rule */
    int nc_v3;            /* cells per dimension by checkpoint version 3's rule */
    double rmax;          /* largest radius, particles and seeds */
    double rpmax;         /* largest particle radius: the cells are sized by it */
    int nc_order;         /* cells per dimension of the numbering grid (ev_sim.c) */
    double w;             /* cell side */
    /* Particle i: ps[i*S ..]: x[D], v[D], t_i, radius (S = 2D + 2). */
    double *ps;
    int S;
    double spmass[EV_MAX_SPECIES]; /* mass of each kind (density x volume) */
    uint8_t *species, *stuck;
    uint32_t *parent;
    ev_link *lk;      /* per particle: events, counter, cell, queue place */
    uint32_t *cnext, *chead;
    /* event queue (ev_core.c): heap of the current bucket, bucket lists */
    ev_hent *heap;
    uint32_t hn;
    uint32_t *qhead;
    uint32_t qn, qnlist; /* queued particles; those in bucket lists */
    uint32_t qnb, cq;    /* buckets now, current bucket */
    uint32_t qover;      /* slot of the overflow list (>= any qnb) */
    double qbase, qinv;  /* bucket b covers [qbase + b / qinv, qbase + (b + 1) / qinv) */
    /* seeds larger than the particles, out of the cell lists (ev_big.c) */
    uint32_t nbig;
    uint64_t *bg_near, *bg_inside; /* a bit per cell */
    uint32_t *bg_rank;             /* near bits before each 64-bit word */
    uint32_t *bg_start, *bg_idx;   /* near cell of rank r: bg_idx[bg_start[r] .. bg_start[r + 1]) */
    /* stuck particles in arrival order */
    uint32_t *stuck_idx, nstuck;
    double *stuck_t;
    double now;
    double series_dt; /* the series' interval now (doubles when thinned) */
    double stick_p;
    pdla_rng rng;
    uint64_t events, collisions, wall_hits, sticks, cell_crossings, invalid;
    double ke_stuck, virial, wall_impulse, max_overlap;
    ev_trace_fn trace;
    void *trace_user;
    ev_tick_fn tick;
    void *tick_user;
    /* run state kept in checkpoints: series started, the open interval */
    int started, iv_open;
    double iv_t0, iv_v0;
    /* the CLI's --checkpoint-every, kept in checkpoints; has_ck_every 1:
     * set, or read from the checkpoint loaded */
    double ck_every;
    int has_ck_every;
    /* the series' free kinetic energy (ev_sim.c series_ke): the last full
     * sum, the collision and stick counts it was made at (ke_valid 0: none
     * yet, or states set by hand since), and how many full sums were made */
    int ke_valid;
    uint64_t ke_collisions, ke_sticks, ke_sums;
    double ke_free;
    /* species table actually used */
    int nspecies;
    ev_species sp[EV_MAX_SPECIES];
};

#define EV_P(s, i) ((s)->ps + (size_t)(i) * (size_t)(2 * D + 2))

/* The squared distance from a to b (the first s->dim coordinates), by the
 * minimum image in a periodic box. Symmetric bit for bit (the wrap of -d is
 * the negative of the wrap of d). */
static inline double ev_dist2(const ev_sim *s, const double *a, const double *b)
{
    double rr = 0;
    for (int k = 0; k < s->dim; k++) {
        double d = b[k] - a[k];
        if (s->periodic) {
            if (d > s->half) d -= s->L;
            else if (d < -s->half) d += s->L;
        }
        rr += d * d;
    }
    return rr;
}
#define EV_P_ANY(s, i) ((s)->ps + (size_t)(i) * (size_t)(2 * (s)->dim + 2))
int ev_rebuild(ev_sim *s);

/* Mass of particle i < n: its kind's (the event loop reads no per-particle
 * mass: at N ~ 1e6 an array of them cost a cache miss per particle of each
 * collision; the kinds' masses sit in one line, the kinds in 1 byte each). */
static inline double ev_pmass(const ev_sim *s, uint32_t i)
{
    return s->spmass[s->nspecies == 1 ? 0 : s->species[i]];
}

/* Is i a seed larger than every particle (in no cell list, ev_big.c)? */
static inline int ev_is_big(const ev_sim *s, uint32_t i)
{
    return i >= s->n && EV_P_ANY(s, i)[2 * s->dim + 1] > s->rpmax;
}
/* Cell lists for every particle and seed but the big seeds. */
static inline int ev_in_cells(const ev_sim *s, uint32_t i) { return !ev_is_big(s, i); }
int ev_big_build(ev_sim *s);
void ev_big_free(ev_sim *s);
/* The big seeds a particle in cell c may meet: bg_idx[*lo .. *hi) (empty
 * unless c's "near" bit is set; its rank indexes the lists). */
static inline void ev_big_list(const ev_sim *s, uint64_t c, uint32_t *lo, uint32_t *hi)
{
    const uint64_t w = s->bg_near[c >> 6], bit = (uint64_t)1 << (c & 63);
    *lo = *hi = 0;
    if (!(w & bit)) return;
    const uint32_t r = s->bg_rank[c >> 6] + (uint32_t)__builtin_popcountll(w & (bit - 1));
    *lo = s->bg_start[r];
    *hi = s->bg_start[r + 1];
}
/* Does a particle of radius r <= rpmax at x, in cell c, overlap a big seed? */
int ev_big_overlaps(const ev_sim *s, uint64_t c, const double *x, double r);
ev_sim *ev_alloc(const ev_params *p, char *err, size_t errlen);
/* ev_alloc with a --seeds run's seeds given (a checkpoint's, D + 1 numbers
 * each: position, radius; malloc'ed, taken over even on failure) instead of
 * read from the file. */
ev_sim *ev_alloc_seeded(const ev_params *p, double *seed_xr, uint32_t nseeds, char *err, size_t errlen);
/* Contact tests square sums of radii: below 1e-150 they fall under the
 * smallest normal double (2e-308) and lose their digits; radius 1e-158 in
 * 2D (density 1e12, kT 1e-300) ran and wrote 173 overlapping pairs. */
#define EV_RADIUS_MIN 1e-150
/* The most seeds a --seeds file (or a checkpoint) may hold. */
#define EV_MAX_SEEDS 100000
double ev_fractal_dimension(const ev_sim *s, uint64_t *k_lo, uint64_t *k_hi);

/* The series keeps at most this many rows (ev_sim.c series_push thins it:
 * a checkpoint never holds more). */
enum { EV_SERIES_MAX = 1 << 16 };

void ev_queue_reset(ev_sim *s);
void ev_heap_push(ev_sim *s, uint32_t i);
void ev_cell_insert(ev_sim *s, uint32_t i, uint32_t c);
void ev_predict(ev_sim *s, uint32_t i, double now);
/* The deepest overlap / (r_i + r_j) pairs would reach before their pending
 * events (ev_core.c; checkpoints' check): the state is not changed. */
double ev_max_overlap_ahead(ev_sim *s);
int ev_loop(ev_sim *s, double t_end, volatile const int *interrupt);
/* The stop reason that holds now, before the next event (ev_loop's), or 0. */
int ev_stop_now(ev_sim *s);
/* Species list from p (the string, or one species): 0 or -1 with err. */
int ev_parse_species(const ev_params *p, ev_species *sp, int *nsp, char *err, size_t errlen);
double ev_particle_volume(int dim, double r);
/* --seeds FILE into s->seed_xr / s->nseeds (box not yet known): 0 or -1. */
int ev_seeds_read(ev_sim *s, const char *path, char *err, size_t errlen);
/* The file's seeds against the box: inside it, no two overlapping. */
int ev_seeds_check(const ev_sim *s, char *err, size_t errlen);

#endif
