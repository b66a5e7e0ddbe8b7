/*
 * walker.c - one Brownian walker from the birth circle (sphere) to contact,
 * by walk-on-spheres: from a point whose distance to every particle centre is
 * at least d, Brownian motion first leaves the ball of radius d - D (D = one
 * diameter) at a uniform point of its surface, and no particle can be touched
 * on the way. The walker sticks once the exact distance is below D + eps.
 *
 * Positions are integers: a jump is rounded to the unit grid, which moves the
 * walker by at most sqrt(dim)/2 < 1 unit, so jumps are shortened by one unit
 * and the walker never comes closer than D to a centre.
 *
 * Leaving the birth circle R_b: by default the walker is put straight back on
 * it with the exterior harmonic measure (sample.h), which is exact; with
 * PDLA_RETURN_KILL it jumps by |p| - R_ext outside R_b and dies past
 * kill_ratio * R_b (the seed paper's scheme). The code is one always-inlined
 * body instantiated for dim 2 and 3.
 */
#include <math.h>
#if defined(__SSE2__) && defined(__x86_64__)
#include <emmintrin.h>
#endif

#include "engine.h"
#include "claims.h"
#include "recent.h"
#include "sample.h"

static inline __attribute__((always_inline)) void random_dir(pdla_rng *rng, double *v,
                                                             const int dim)
{
    if (dim == 2)
        sample_dir2(rng, v);
    else
        sample_dir3(rng, v);
}

/* Uniform point on the birth circle/sphere, rounded to the grid. */
static inline __attribute__((always_inline)) void launch(walker_ctx *w, double Rb, int64_t *p,
                                                         const int dim)
{
    double v[3];
    random_dir(&w->rng, v, dim);
    for (int a = 0; a < dim; a++) p[a] = (int64_t)lrint(Rb * v[a]);
    w->walkers++;
}

/* Put a walker at radius r > Rb back on the birth circle/sphere (exact
 * harmonic measure). Returns 0 when the walker escaped to infinity (3D) and
 * a fresh one must start. */
static inline __attribute__((always_inline)) int return_to_birth(walker_ctx *w, int64_t *p,
                                                                 double r, double Rb,
                                                                 const int dim)
{
    double out[3];
    if (dim == 2) {
        double cs[2];
        sample_return_cs2(&w->rng, r, Rb, cs);
        sample_rotate_cs2((double)p[0], (double)p[1], r, cs, Rb, out);
    } else {
        double cos_theta;
        if (!sample_return3(&w->rng, r, Rb, &cos_theta)) return 0;
        const double u[3] = {(double)p[0] / r, (double)p[1] / r, (double)p[2] / r};
        sample_cone_point3(&w->rng, u, Rb, cos_theta, out);
    }
    for (int a = 0; a < dim; a++) p[a] = (int64_t)lrint(out[a]);
    w->returns++;
    return 1;
}

/* lrint without the libm call (it is one per jump unless math errno is
 * off): cvtsd2si rounds by the current mode exactly as lrint does. */
static inline __attribute__((always_inline)) int64_t round_i64(double x)
{
#if defined(__SSE2__) && defined(__x86_64__)
    return _mm_cvtsd_si64(_mm_set_sd(x));
#else
    return (int64_t)lrint(x);
#endif
}

static inline __attribute__((always_inline)) void jump(walker_ctx *w, int64_t *p, double s,
                                                       const int dim)
{
    double v[3];
    if (dim == 2) {
        sample_step2(&w->rng, s, v);
        for (int a = 0; a < 2; a++) p[a] += round_i64(v[a]);
    } else {
        sample_step3(&w->rng, s, v);
        for (int a = 0; a < 3; a++) p[a] += round_i64(v[a]);
    }
    w->jumps++;
}

/* Up to this many particles near a 2D contact are read in one scan (circles
 * of diameter D packed within D + eps + 2 of p: far fewer). */
enum { SNAP_NEAR_CAP = 32 };

/* The particles near a 2D contact, read once (search_ball_points2): those
 * within reach of p, in the order the nearest search takes them, and every
 * other one within `far` units of p. n < 0: not read. */
typedef struct snap_near {
    search_point pt[SNAP_NEAR_CAP];
    int n;
    int64_t far;
} snap_near;

/* The nearest particle centre within reach (squared reach2) of p, into q and
 * d2: from the scan when there is one (the first of least d2, as the search
 * would take it), else from the tree. */
static int snap_nearest(const tree *t, const int64_t *p, uint64_t reach2, int64_t *q, uint64_t *d2,
                        search_state *k, const snap_near *nb)
{
    if (nb->n < 0) return search_nearest_point_cached(t, p, reach2, q, d2, k);
    int best = -1;
    for (int i = 0; i < nb->n; i++)
        if (nb->pt[i].d2 < reach2 && (best < 0 || nb->pt[i].d2 < nb->pt[best].d2)) best = i;
    if (best < 0) return 0;
    q[0] = nb->pt[best].x[0];
    q[1] = nb->pt[best].x[1];
    *d2 = nb->pt[best].d2;
    return 1;
}

/* 1 if a particle centre lies within D (squared D2) of the spot c. The scan
 * holds every particle within `far` of p, so it decides whenever c is within
 * far - D of p (a particle within D of c is then within far of p); else
 * the tree does. */
static int snap_blocked(const tree *t, const int64_t *p, const int64_t *c, int64_t D, uint64_t D2,
                        search_state *k, const snap_near *nb)
{
    const int dim = t->dim;
    uint64_t cp2 = 0;
    for (int a = 0; a < dim; a++) cp2 += (uint64_t)((c[a] - p[a]) * (c[a] - p[a]));
    const int64_t slack = nb->far - D;
    if (nb->n < 0 || slack < 0 || cp2 > (uint64_t)(slack * slack)) {
        int64_t other[3];
        uint64_t od2;
        return search_nearest_point_cached(t, c, D2, other, &od2, k);
    }
    for (int i = 0; i < nb->n; i++) {
        const int64_t dx = nb->pt[i].x[0] - c[0], dy = nb->pt[i].x[1] - c[1];
        if ((uint64_t)(dx * dx) + (uint64_t)(dy * dy) < D2) return 1;
    }
    return 0;
}

/* Move a walker that stopped inside the sticking shell onto contact with its
 * nearest particle q, along the line from q (the usual off-lattice closure:
 * without it the mean contact distance is D + eps/2, a systematic
 * stretch of the cluster by eps/(2D)). Of the grid points around the exact
 * contact point, take the one nearest to contact that keeps every particle
 * at least D away; if none does, stay put. In 2D the nearest particle and
 * the candidates' overlap checks come from one scan of the particles within
 * reach + 2 units of p (a candidate lies within reach - D + sqrt(2) of p
 * when p is at least D from q), with the same answers as a search each. */
int walker_snap_to_contact(const tree *t, int64_t *p, int64_t D, uint64_t reach2, search_state *k)
{
    const int dim = t->dim;
    snap_near nb;
    nb.n = -1;
    nb.far = 0;
    if (dim == 2 && k) {
        nb.far = tree_ceil_sqrt(reach2) + 2;
        nb.n = search_ball_points2(t, p, reach2, (uint64_t)(nb.far * nb.far), nb.pt, SNAP_NEAR_CAP, k);
    }
    int64_t q[3];
    uint64_t d2;
    if (!snap_nearest(t, p, reach2, q, &d2, k, &nb) || d2 == 0) return 0;
    const double scale = (double)D / sqrt((double)d2);
    double x[3];
    int64_t base[3];
    for (int a = 0; a < dim; a++) {
        x[a] = (double)q[a] + (double)(p[a] - q[a]) * scale;
        base[a] = (int64_t)floor(x[a]);
    }
    const uint64_t D2 = (uint64_t)(D * D);
    int64_t cand[8][3];
    uint64_t cand_d2[8];
    int n = 0;
    for (int c = 0; c < (1 << dim); c++) {
        uint64_t e2 = 0;
        for (int a = 0; a < dim; a++) {
            cand[n][a] = base[a] + ((c >> a) & 1);
            const int64_t d = cand[n][a] - q[a];
            e2 += (uint64_t)(d * d);
        }
        if (e2 < D2) continue;
        cand_d2[n++] = e2;
    }
    for (int tries = 0; tries < n; tries++) {
        int best = 0;
        for (int i = 1; i < n; i++)
            if (cand_d2[i] < cand_d2[best]) best = i;
        if (!snap_blocked(t, p, cand[best], D, D2, k, &nb)) {
            for (int a = 0; a < dim; a++) p[a] = cand[best][a];
            return 1;
        }
        cand_d2[best] = UINT64_MAX;
    }
    return 0;
}

/* The radii drawn from R_ext = r units. */
static inline __attribute__((always_inline)) void walk_set_radii(const pdla_engine *e,
                                                                 walk_state *s, int64_t r)
{
    const pdla_params *P = &e->params;
    const double D = (double)P->resolution;
    s->r_ext_units = r;
    s->r_ext = (double)r;
    /* A walker starts on the circle rounded to the grid, up to sqrt(dim)/2
     * units inside it: with the least margin, one diameter, it could start
     * inside the farthest particle, and the serial loop stopped with
     * "internal error" (found by an adversarial test, 6 of 8 seeds at 2D
     * 1000). So R_birth is at least one diameter and one unit beyond R_ext;
     * margins of 1 + 1/D diameters and more are as given. */
    const double off = P->birth_margin * D;
    s->Rb = s->r_ext + (off < D + 1.0 ? D + 1.0 : off);
    /* One unit of hysteresis: a walker just put on the circle (rounded to the
     * grid) is not sent straight back. */
    s->Rout2 = (s->Rb + 1.0) * (s->Rb + 1.0);
    s->Rdeath = P->kill_ratio * s->Rb;
}

/* Re-read R_ext: it only grows, as particles are added (by this walker
 * between two walks, or by other walkers at any time). */
static inline __attribute__((always_inline)) void walk_refresh(const pdla_engine *e, walk_state *s)
{
    const int64_t now = atomic_load_explicit(&e->r_ext, memory_order_relaxed);
    if (now != s->r_ext_units) walk_set_radii(e, s, now);
}

static inline __attribute__((always_inline)) void walk_begin_dim(const pdla_engine *e,
                                                                 walker_ctx *w, walk_state *s,
                                                                 const int dim)
{
    walk_set_radii(e, s, atomic_load_explicit(&e->r_ext, memory_order_relaxed));
    launch(w, s->Rb, s->p, dim);
    s->jumps = 0;
    s->restarts = 0;
    s->launched_at = tree_count(&e->tree);
    s->step_seen = s->launched_at;
    s->near = 0;
}

/* With worker threads: 1 if more than w->relaunch_after particles were
 * appended since this walker's last step (count `seen` now): it was frozen
 * (descheduled) while the cluster grew, and is relaunched (the straggler
 * bound; why this is unbiased: parallel.c, STRAGGLER_FACTOR). */
static inline __attribute__((always_inline)) int walk_straggler(walker_ctx *w, walk_state *s,
                                                                uint64_t seen)
{
    const uint64_t since = seen - s->step_seen;
    s->step_seen = seen;
    if (!w->relaunch_after || since <= w->relaunch_after) return 0;
    w->relaunches++;
    return 1;
}

/* With worker threads (conc): 1 if a particle appended since the query
 * (count `seen`) makes the move just computed wrong (what: RECENT_NEAR, one
 * inside the ball of squared radius R2 around p; RECENT_FAR, one beyond
 * R_ext); then the walker queries again instead of moving. */
static inline __attribute__((always_inline)) int walk_stale(const pdla_engine *e, walker_ctx *w,
                                                            uint64_t seen, const int64_t *p,
                                                            uint64_t R2, int what)
{
    const engine_hooks *h = e->hooks;
    if (__builtin_expect(h != NULL, 0) && h->stall) h->stall(h->user);
    /* The spots other workers have chosen but not yet appended, before the
     * ring (claims.h: a withdrawal seen here is covered by the count read
     * next). One inside the ball: wait until it is appended, then query
     * again. */
    const claim_board *cb = e->claims;
    int owner;
    uint32_t seq;
    if (cb && claims_any(cb, w->id) && claims_block(cb, w->id, p, R2, what, e->tree.dim, &owner, &seq) &&
        !(__builtin_expect(h != NULL, 0) && h->no_claims)) {
        w->claim_waits++;
        claims_wait(cb, owner, seq);
        return 1;
    }
    uint64_t now;
    if (!recent_stale(e->recent, &e->tree, seen, p, R2, what, &now)) {
        if (__builtin_expect(h != NULL, 0) && h->jump && what == RECENT_NEAR) h->jump(h->user, p, R2, now);
        return 0;
    }
    if (what == RECENT_NEAR)
        w->stale_jumps++;
    else
        w->stale_births++;
    if (__builtin_expect(h != NULL, 0) && h->take_stale) {
        if (h->jump && what == RECENT_NEAR) h->jump(h->user, p, R2, now);
        return 0;
    }
    return 1;
}

/* 2D: a block answer below 128 units is exact (its cut is at least one
 * leaf, 256 units), so a particle q lies at d < 128 from p. The jump of
 * d - D - 1 (plus < 1 unit of rounding) ends less than 2d - D < 256 from q,
 * so within one fine cell (>= 256 units) of q's occupied cell on each axis:
 * the map's fine value there is at most 1 and distmap_bound is 0, which the
 * next step then need not look up (the answer is the same). Particles are
 * only added and map values only fall, so it holds for walkers stepped in
 * turn (reference.c) too; with worker threads it is not used. */
#define NEAR_SKIP2 ((uint64_t)128 * 128)

/* The parameters a step reads, converted once per walk (walk_dim) rather
 * than reloaded from the engine on every jump: the step's calls into
 * search.c force those reloads otherwise. */
typedef struct walk_consts {
    double D;           /* one diameter, units */
    uint64_t stick2;    /* (D + eps)^2: contact below it */
    uint64_t D2;        /* D^2: overlap below it */
    uint64_t max_jumps;
    uint32_t endless;   /* restarts in a row that end a walk (WALK_ENDLESS) */
    int exact;          /* --exact-search */
    int kill;           /* PDLA_RETURN_KILL */
    int64_t claim_margin; /* how far the snap may move a stopped walker (claims.h) */
} walk_consts;

static inline __attribute__((always_inline)) walk_consts walk_consts_of(const pdla_params *P,
                                                                     uint32_t test_endless)
{
    const uint64_t De = (uint64_t)(P->resolution + P->eps);
    return (walk_consts){.D = (double)P->resolution,
                         .stick2 = De * De,
                         .D2 = (uint64_t)P->resolution * (uint64_t)P->resolution,
                         .max_jumps = P->max_jumps,
                         .endless = test_endless ? test_endless : WALK_ENDLESS_RESTARTS,
                         .exact = P->exact_search,
                         .kill = P->return_mode == PDLA_RETURN_KILL,
                         .claim_margin = claims_margin(P->resolution, P->eps)};
}

/* One step of a walk: one jump (or return to the birth circle, restart,
 * kill). Returns WALK_MOVED, or WALK_CONTACT / WALK_OVERLAP with the spot in
 * stuck_at, or WALK_ENDLESS (engine.h) at the last restart allowed. conc: worker threads append meanwhile; every move is then
 * checked against the particles appended since its query (walk_stale), so
 * each jump is exact for the cluster as it is when the jump is taken, as in
 * the race-free reference. Longer than the 80-line rule on purpose: the
 * hot loop of every walk, kept in one always_inline piece so the compiler
 * keeps its state in registers (scripts/long-functions.allow). */
static inline __attribute__((always_inline)) int walk_step_dim(const pdla_engine *e,
                                                               walker_ctx *w, walk_state *s,
                                                               int64_t *stuck_at, const walk_consts kc,
                                                               const int dim, const int conc)
{
    const tree *t = &e->tree;
    const double D = kc.D;
    int64_t *p = s->p;
    /* The count first: R_ext is raised before a particle is published, so
     * the R_ext read next covers every particle below `seen`, and so do
     * the map and the tree searches. */
    const uint64_t seen = conc ? tree_count(t) : 0;
    walk_refresh(e, s);
    if (conc && walk_straggler(w, s, seen)) {
        launch(w, s->Rb, p, dim);
        s->jumps = 0;
        s->launched_at = seen;
    }
    if (s->jumps >= kc.max_jumps) {
        if (++s->restarts >= kc.endless) return WALK_ENDLESS;
        w->restarts++;
        launch(w, s->Rb, p, dim);
        s->jumps = 0;
        s->launched_at = tree_count(t);
        s->near = 0;
    }
    /* Set by the last step's jump: then the map's bound here is 0. */
    const int near = s->near;
    s->near = 0;
    double r2 = 0;
    for (int a = 0; a < dim; a++) r2 += (double)p[a] * (double)p[a];
    if (r2 > s->Rout2) {
        static const int64_t origin[3] = {0, 0, 0};
        if (conc && walk_stale(e, w, seen, origin,
                               (uint64_t)s->r_ext_units * (uint64_t)s->r_ext_units, RECENT_FAR))
            return WALK_MOVED;
        const double r = sqrt(r2);
        if (kc.kill) {
            if (r > s->Rdeath) {
                w->killed++;
                launch(w, s->Rb, p, dim);
                s->launched_at = tree_count(t);
                return WALK_MOVED;
            }
            jump(w, p, r - s->r_ext - D - 1.0, dim);
            s->jumps++;
        } else if (!return_to_birth(w, p, r, s->Rb, dim)) {
            w->lost++;
            launch(w, s->Rb, p, dim);
            s->launched_at = tree_count(t);
        }
        return WALK_MOVED;
    }
    /* Far from the cluster one look-up in the distance map bounds the
     * distance (at least one map cell; in 3D also within a cell of the
     * cluster, then at least 4 diameters: distmap_bound; either way far
     * above the sticking shell).
     * --exact-search (the reference setting) skips the map and the
     * block cut: every jump is by the exact distance from the tree. */
    const int64_t far = kc.exact || near ? 0 : distmap_bound(&e->dmap, p, dim);
    if (far > 0) {
        if (conc && walk_stale(e, w, seen, p, (uint64_t)far * (uint64_t)far, RECENT_NEAR))
            return WALK_MOVED;
        jump(w, p, (double)far - D - 1.0, dim);
        s->jumps++;
        return WALK_MOVED;
    }
    /* Near the cluster in 2D: the 3 x 3 leaves around the walker, whose
     * chunks stay cached while it moves among them. (In 3D the cut at
     * the block's edge costs more jumps than it saves: the tree, after
     * the walker's neighbour list, which gives the tree's own answer
     * whenever it gives one, so the walk is the same; serial only, as the
     * list is remade whenever the tree grows.) */
    uint64_t d2 = UINT64_MAX;
    int exact_near = 0;
    if (dim == 2 && !kc.exact) {
        d2 = search_block2(t, &e->search, &e->dmap, p, &w->ss);
        exact_near = d2 < NEAR_SKIP2;
    }
    else if (dim == 3 && !conc && !kc.exact)
        d2 = search_near2(t, &e->search, p, &w->ss);
    if (d2 == UINT64_MAX) d2 = search_lower_bound2(t, &e->search, p, UINT64_MAX, &w->ss);
    w->ss.nb_last2 = d2;
    if (d2 < kc.stick2) {
        /* A particle appended since the query only makes the walker closer:
         * the insertion's exact re-check (parallel.c) sees it. The spot is
         * published at once (claims.h), with room for the snap still to
         * come (claims_margin). */
        if (conc && e->claims)
            claims_publish(e->claims, w->id, p, dim, kc.claim_margin);
        for (int a = 0; a < dim; a++) stuck_at[a] = p[a];
        w->launched_at = s->launched_at;
        w->step_seen = seen;
        /* Closer than one diameter can only mean another walker's particle
         * appeared next to this one since its last jump. */
        return d2 < kc.D2 ? WALK_OVERLAP : WALK_CONTACT;
    }
    if (conc && walk_stale(e, w, seen, p, d2, RECENT_NEAR)) return WALK_MOVED;
    jump(w, p, sqrt((double)d2) - D - 1.0, dim);
    s->jumps++;
    s->near = !conc && exact_near;
    return WALK_MOVED;
}

static inline __attribute__((always_inline)) int walk_dim(const pdla_engine *e, walker_ctx *w,
                                                          int64_t *stuck_at, const int dim,
                                                          const int conc)
{
    walk_state s;
    const walk_consts kc = walk_consts_of(&e->params, e->test_endless_restarts);
    walk_begin_dim(e, w, &s, dim);
    for (uint32_t steps = 1;; steps++) {
        const int r = walk_step_dim(e, w, &s, stuck_at, kc, dim, conc);
        if (r != WALK_MOVED) return r;
        /* Every 4096 steps (a few hundred microseconds): a walk that does
         * not end must not keep a worker from a stop. */
        if (!(steps & 4095u) && atomic_load_explicit(&e->stop, memory_order_relaxed))
            return WALK_ABANDONED;
        if (conc && __builtin_expect(e->hooks != NULL, 0) && e->hooks->turn_end) {
            e->hooks->turn_end(e->hooks->user, w->id);
            e->hooks->turn_begin(e->hooks->user, w->id);
        }
    }
}

int walker_run(const pdla_engine *e, walker_ctx *w, int64_t *stuck_at)
{
    if (e->recent)
        return e->params.dim == 2 ? walk_dim(e, w, stuck_at, 2, 1) : walk_dim(e, w, stuck_at, 3, 1);
    return e->params.dim == 2 ? walk_dim(e, w, stuck_at, 2, 0) : walk_dim(e, w, stuck_at, 3, 0);
}

static inline __attribute__((always_inline)) int walk_slice_dim(const pdla_engine *e, walker_ctx *w,
                                                                walk_state *s, int resume, uint64_t steps,
                                                                int64_t *stuck_at, const int dim)
{
    const walk_consts kc = walk_consts_of(&e->params, e->test_endless_restarts);
    if (!resume) walk_begin_dim(e, w, s, dim);
    for (uint64_t k = 0; k < steps; k++) {
        const int r = walk_step_dim(e, w, s, stuck_at, kc, dim, 0);
        if (r != WALK_MOVED) return r;
    }
    return WALK_MOVED;
}

int walker_run_slice(const pdla_engine *e, walker_ctx *w, walk_state *s, int resume, uint64_t steps,
                     int64_t *stuck_at)
{
    return e->params.dim == 2 ? walk_slice_dim(e, w, s, resume, steps, stuck_at, 2)
                              : walk_slice_dim(e, w, s, resume, steps, stuck_at, 3);
}

void walker_begin(const pdla_engine *e, walker_ctx *w, walk_state *s)
{
    if (e->params.dim == 2)
        walk_begin_dim(e, w, s, 2);
    else
        walk_begin_dim(e, w, s, 3);
}

int walker_step(const pdla_engine *e, walker_ctx *w, walk_state *s, int64_t *stuck_at)
{
    const walk_consts kc = walk_consts_of(&e->params, e->test_endless_restarts);
    return e->params.dim == 2 ? walk_step_dim(e, w, s, stuck_at, kc, 2, 0)
                              : walk_step_dim(e, w, s, stuck_at, kc, 3, 0);
}

void walker_ctx_add_counts(walker_ctx *s, const walker_ctx *o)
{
    s->walkers += o->walkers;
    s->jumps += o->jumps;
    s->returns += o->returns;
    s->lost += o->lost;
    s->killed += o->killed;
    s->restarts += o->restarts;
    s->ss.node_visits += o->ss.node_visits;
    s->ss.particle_checks += o->ss.particle_checks;
    s->recheck_overlaps += o->recheck_overlaps;
    s->recheck_continued += o->recheck_continued;
    s->recheck_discarded += o->recheck_discarded;
    s->stale_jumps += o->stale_jumps;
    s->stale_births += o->stale_births;
    s->claim_waits += o->claim_waits;
    s->relaunches += o->relaunches;
    s->lag_n += o->lag_n;
    s->lag_sum += o->lag_sum;
    s->lag_sum2 += o->lag_sum2;
    for (int i = 0; i < PDLA_LAG_BINS; i++) s->lag_hist[i] += o->lag_hist[i];
    s->cpu_seconds += o->cpu_seconds;
    for (int i = 0; i < 3; i++) {
        s->mutex_taken[i] += o->mutex_taken[i];
        s->mutex_contended[i] += o->mutex_contended[i];
        s->mutex_hold_ticks[i] += o->mutex_hold_ticks[i];
        s->mutex_wait_ticks[i] += o->mutex_wait_ticks[i];
        s->mutex_long_holds[i] += o->mutex_long_holds[i];
    }
}
