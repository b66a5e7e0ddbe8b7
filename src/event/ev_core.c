/*
 * ev_core.c - event-driven hard disks/spheres that stick (see pdla/event.h).
 *
 * Scheme (after Rapaport; Bannerman et al. 2014 for the stability rules):
 *  - each free particle keeps ONE pending event: its earliest pair or wall
 *    event (t_pair) and its next cell crossing (t_cell); an indexed binary
 *    heap orders particles by min(t_pair, t_cell), ties by particle index;
 *  - lazy update: a particle's stored state is (x, v) at its local time t_i
 *    and only changes at its own events;
 *  - a pair event stores the partner's collision counter; if the counter
 *    moved, the event is stale and the particle is simply re-predicted;
 *  - invariant that keeps every collision: whenever a trajectory changes,
 *    that particle re-predicts against all its neighbours, so of any pair
 *    that will touch at time t at least one has an event <= t pending. A
 *    particle that sticks has no events of its own, so it instead offers
 *    its (new, resting) pair event to every free neighbour;
 *  - a pair prediction depends only on the two stored states: both are
 *    moved to max(t_i, t_j) first, so predicting again later (after a cell
 *    crossing) gives the same bits, and the brute-force reference in the
 *    tests produces the same event sequence. In a periodic box the image
 *    is the one nearest at the time of the prediction (`now`), not at
 *    max(t_i, t_j): a particle keeps its stored state through cell
 *    crossings, so in a dilute gas it may have flown more than half the
 *    box since, and the image nearest then was the wrong one (3D, 1e4
 *    particles at packing 0.001: particles passed through each other, 0.83
 *    diameters deep, until session 14; test event-periodic-few). Now the
 *    two are in neighbouring cells, which with >= 4 cells a side is at most
 *    half the box apart, so the nearest image is the one that meets; when
 *    it is also the nearest at max(t_i, t_j), as nearly always, the bits
 *    are those of before. At exactly half the box (4 to 7 cells a side)
 *    the two images tie and the approached one is taken, and after a
 *    flight of many sides as many are taken off (ev_image, EV_PER_NEAR);
 *    a pair solved from far apart is solved from its closest approach
 *    (solve_far). Both found by `pdla check` (session 30).
 * Stability rules (Bannerman 2014), each tested in tests/event:
 *  - overlapping by round-off and approaching (r.v < 0): collide now;
 *    overlapping and receding: no event (they separate, no pass-through);
 *  - grazing (discriminant <= 0): no event; receding (r.v >= 0): no event;
 *  - event times are never earlier than now (no time going back);
 *  - a wall or cell crossing already passed by round-off happens now; a wall
 *    reflection sets the sign of v explicitly, so it cannot fire twice;
 *  - simultaneous events run in (time, particle index) order; a pair event
 *    made stale by an earlier one at the same instant is re-predicted and
 *    (if the pair still approaches while touching) happens at once;
 *  - sticking onto two at once: the first event in that order decides
 *    the parent; the second contact is then between two stuck particles,
 *    which have no events;
 *  - no pair collides twice at one instant: a collision (or a reflection
 *    off a stuck particle) leaves its pair receding, r.v >= 0 as the pair's
 *    next prediction computes it (approach(), the same bits), so that
 *    prediction is "no event" until one of the two has another event. The
 *    reflection alone does not ensure it: in a graze (touching by
 *    round-off, |r.v| below the round-off of the velocities) its change is
 *    below half an ulp and is lost, and until session 31 such a pair
 *    collided at the same instant until max_events. Such a pair gets the
 *    least push along r that makes it recede (recede(): a normal speed of
 *    a few epsilon of the particles' own speeds; energy and momentum kept
 *    to round-off; the brute force in the tests has the same rule); test
 *    event-graze. A chain of zero-time events through several particles
 *    (Newton's cradle; a particle between a wall and a receding one) is
 *    the exact dynamics' finite one: each of its collisions either
 *    reverses a normal speed above round-off or pushes as above, and a
 *    wall reflection sets the sign of v, so it cannot fire twice. (Not
 *    covered: a particle that fits a gap between two stuck particles on
 *    opposite sides to round-off, touching both at once, rattles between
 *    them at one instant without end, as the exact dynamics would; with
 *    p > 0 it sticks within a few draws, with p = 0 it loops.)
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "ev_internal.h"

#define EV_INF INFINITY

/* ---- event queue: a calendar of time buckets over a small heap ------------
 *
 * One entry per free particle, key min(t_pair, t_cell), ordered by (key,
 * index). A plain binary heap over all N particles costs ~log2 N levels of
 * random memory per update: at N = 1e6 that is ~20 cache misses per event
 * and was the main reason the cost per event grew with N. Here (after Paul
 * 2007, Smallenburg 2022) time from qbase is cut into qnb buckets of width
 * 1/qinv: keys in buckets after the current one cq sit in unsorted
 * doubly-linked lists (O(1), ~3 cache lines per update), keys past the last
 * bucket in an overflow list, and only bucket <= cq is in the binary heap
 * (a few dozen entries, in cache). bucket_of() is monotone in the key, so
 * every heap key is below every list key: the heap's top is the global
 * (key, index) minimum and the event order is exactly that of one heap.
 * When the buckets are used up (or empty), the overflow is re-bucketed with
 * a width fitted to its keys (qnb ~ its size, horizon 2x the mean time to
 * the next event), so the scheme adapts as particles stick or slow down. */

#define QNONE UINT32_MAX

static inline double ev_key(const ev_sim *s, uint32_t i)
{
    const ev_evt *e = &s->lk[i].ev;
    return e->t_pair < e->t_cell ? e->t_pair : e->t_cell;
}

/* Heap entries carry their key, so sifting touches only the heap array. */
static inline int hless(ev_hent a, ev_hent b) { return a.t < b.t || (a.t == b.t && a.id < b.id); }

static void heap_up(ev_sim *s, uint32_t pos, ev_hent x)
{
    while (pos > 0) {
        const uint32_t parent = (pos - 1) / 2;
        const ev_hent p = s->heap[parent];
        if (!hless(x, p)) break;
        s->heap[pos] = p;
        s->lk[p.id].hpos = pos;
        pos = parent;
    }
    s->heap[pos] = x;
    s->lk[x.id].hpos = pos;
}

static void heap_down(ev_sim *s, uint32_t pos, ev_hent x)
{
    const uint32_t n = s->hn;
    for (;;) {
        uint32_t c = 2 * pos + 1;
        if (c >= n) break;
        if (c + 1 < n && hless(s->heap[c + 1], s->heap[c])) c++;
        const ev_hent ch = s->heap[c];
        if (!hless(ch, x)) break;
        s->heap[pos] = ch;
        s->lk[ch.id].hpos = pos;
        pos = c;
    }
    s->heap[pos] = x;
    s->lk[x.id].hpos = pos;
}

static inline void heap_push(ev_sim *s, uint32_t i, double t)
{
    s->lk[i].qslot = QNONE;
    s->hn++;
    heap_up(s, s->hn - 1, (ev_hent){t, i});
}

static void heap_remove(ev_sim *s, uint32_t i)
{
    const uint32_t pos = s->lk[i].hpos;
    s->hn--;
    s->lk[i].hpos = QNONE;
    if (pos == s->hn) return;
    const ev_hent last = s->heap[s->hn];
    if (pos > 0 && hless(last, s->heap[(pos - 1) / 2])) heap_up(s, pos, last);
    else heap_down(s, pos, last);
}

/* Bucket of key t: 0..qnb-1, or qnb (overflow: past the horizon, INF). */
static inline uint32_t bucket_of(const ev_sim *s, double t)
{
    const double x = (t - s->qbase) * s->qinv;
    if (!(x < (double)s->qnb)) return s->qnb;
    return x > 0 ? (uint32_t)x : 0;
}

static inline void list_add(ev_sim *s, uint32_t i, uint32_t slot)
{
    const uint32_t h = s->qhead[slot];
    s->lk[i].qslot = slot;
    s->lk[i].qprev = QNONE;
    s->lk[i].qnext = h;
    if (h != QNONE) s->lk[h].qprev = i;
    s->qhead[slot] = i;
}

static inline void list_del(ev_sim *s, uint32_t i)
{
    const uint32_t slot = s->lk[i].qslot, nx = s->lk[i].qnext, pv = s->lk[i].qprev;
    if (pv != QNONE) s->lk[pv].qnext = nx;
    else s->qhead[slot] = nx;
    if (nx != QNONE) s->lk[nx].qprev = pv;
    s->lk[i].qslot = QNONE;
    if (slot != s->qover) s->qnlist--;
}

/* Enter i (in no structure now) with its current key. */
static inline void q_insert(ev_sim *s, uint32_t i)
{
    const double t = ev_key(s, i);
    const uint32_t b = bucket_of(s, t);
    if (b >= s->qnb) {
        list_add(s, i, s->qover);
    } else if (b <= s->cq) {
        heap_push(s, i, t);
    } else {
        list_add(s, i, b);
        s->qnlist++;
    }
}

void ev_heap_push(ev_sim *s, uint32_t i)
{
    s->qn++;
    q_insert(s, i);
}

/* The bucket list head that q_insert of i's current key will read. */
static inline void q_prefetch(const ev_sim *s, uint32_t i)
{
    const uint32_t b = bucket_of(s, ev_key(s, i));
    if (b > s->cq && b < s->qnb) __builtin_prefetch(&s->qhead[b]);
}

/* Key of i changed: move it to its place. */
static void heap_fix(ev_sim *s, uint32_t i)
{
    if (s->lk[i].qslot == QNONE) {
        const double t = ev_key(s, i);
        const uint32_t b = bucket_of(s, t);
        if (b <= s->cq && b < s->qnb) {
            const uint32_t pos = s->lk[i].hpos;
            const ev_hent x = {t, i};
            if (pos > 0 && hless(x, s->heap[(pos - 1) / 2])) heap_up(s, pos, x);
            else heap_down(s, pos, x);
            return;
        }
        heap_remove(s, i);
    } else {
        list_del(s, i);
    }
    q_insert(s, i);
}

static void q_remove(ev_sim *s, uint32_t i)
{
    if (s->lk[i].qslot == QNONE) heap_remove(s, i);
    else list_del(s, i);
    s->qn--;
}

/* Re-bucket the overflow list (heap and buckets are empty). */
static void q_rebucket(ev_sim *s)
{
    uint32_t nf = 0;
    double tmin = INFINITY, sum = 0;
    for (uint32_t i = s->qhead[s->qover]; i != QNONE; i = s->lk[i].qnext) {
        const double t = ev_key(s, i);
        if (t == INFINITY) continue;
        nf++;
        sum += t - s->now;
        if (t < tmin) tmin = t;
    }
    if (nf == 0) return; /* everything left is at rest */
    uint32_t nb = nf < 16 ? 16 : nf;
    if (nb > s->qover) nb = s->qover;
    const double horizon = 2 * sum / nf;
    s->qnb = nb;
    s->qbase = tmin;
    /* horizon 0 (all keys at `now`): every finite key into bucket 0 */
    s->qinv = horizon > 0 ? nb / horizon : 0;
    s->cq = 0;
    uint32_t i = s->qhead[s->qover];
    s->qhead[s->qover] = QNONE;
    while (i != QNONE) {
        const uint32_t nx = s->lk[i].qnext;
        q_insert(s, i);
        i = nx;
    }
}

/* Make the heap's top the earliest event. 0, or -1 when no event is left
 * (queue empty, or every queued key infinite). */
static inline int q_ready(ev_sim *s)
{
    while (s->hn == 0) {
        if (s->qn == 0) return -1;
        if (s->qnlist == 0 || s->cq + 1 >= s->qnb) {
            q_rebucket(s);
            return s->hn ? 0 : -1;
        }
        s->cq++;
        uint32_t i = s->qhead[s->cq];
        s->qhead[s->cq] = QNONE;
        while (i != QNONE) {
            const uint32_t nx = s->lk[i].qnext;
            s->lk[i].qslot = QNONE;
            s->qnlist--;
            heap_push(s, i, ev_key(s, i));
            i = nx;
        }
    }
    return 0;
}

/* Empty queue, ready for ev_heap_push. */
void ev_queue_reset(ev_sim *s)
{
    s->hn = 0;
    s->qn = 0;
    s->qnlist = 0;
    s->qnb = 0; /* first q_ready re-buckets everything from the overflow */
    s->cq = 0;
    s->qbase = 0;
    s->qinv = 0;
    for (uint32_t i = 0; i < s->ntot; i++) s->lk[i].hpos = s->lk[i].qslot = QNONE;
    for (uint32_t b = 0; b <= s->qover; b++) s->qhead[b] = QNONE;
}

/* ---- cells --------------------------------------------------------------- */

/* Cell lists are singly linked: a cell holds 0.3-1 particles on average,
 * so removal finds i within a step or two from the head, and no particle
 * carries a back link (one array less, and no write into a neighbour's
 * back link at every crossing). The order of a list is the same as with
 * back links (insert at the head, unlink in place). */
void ev_cell_insert(ev_sim *s, uint32_t i, uint32_t c)
{
    s->lk[i].cell = c;
    s->cnext[i] = s->chead[c];
    s->chead[c] = i;
}

static void cell_remove(ev_sim *s, uint32_t i)
{
    uint32_t *p = &s->chead[s->lk[i].cell];
    while (*p != i) p = &s->cnext[*p];
    *p = s->cnext[i];
}

/* ---- predictions (D is a compile-time constant at every call) ------------ */

/* pred_pp's `per`: 0 walls; EV_PER_NEAR periodic, the pair in neighbouring
 * cells of a box of >= 8 cells a side, so its true separation is at most
 * 2 cells, L/4: the separation now from the stored states is then within
 * L/4 of a multiple m of L, one side off (m = +-1) when a particle crossed
 * the face since its stored state, and |rn| > 1.5 L only after a flight of
 * more than a side (then ev_image); EV_PER_ANY periodic with no such bound
 * (4 to 7 cells a side, where a neighbour cell reaches L/2 and the images
 * may tie; big seeds, met from a shell of cells): every pair by ev_image. */
enum { EV_PER_NEAR = 1, EV_PER_ANY = 2 };

static inline int ev_per(const ev_sim *s)
{
    return !s->periodic ? 0 : s->nc >= 8 ? EV_PER_NEAR : EV_PER_ANY;
}

/* Where the image of a periodic pair must be chosen with care: |rn| above
 * this. Below it (every pair of neighbouring cells but those of 4-cell
 * boxes and long flights) the image is the one at hand. The margin is the
 * round-off of rn, 64 epsilon of |rn| + L and of ro, the size of what rn
 * was computed from (rare_images: the stored positions, and the speeds
 * times the clock). Without ro, at a late clock the round-off of a time,
 * |v| epsilon t (1e-9 at t = 1e7), outgrew the margin (5e-12 in a box of
 * 219): a tie was not seen, the receding image was taken and the particle
 * passed through the seed (3D, `--particles 20 --packing 1e-6 --box-walls
 * periodic --seed 4`: 0.425 of a contact distance deep at t = 1.3e6; test
 * event-periodic-tie-late). */
static inline __attribute__((always_inline)) double ev_half_near(double half, double rn, double ro)
{
    return half - 64 * DBL_EPSILON * (fabs(rn) + 2 * half + ro);
}

/* How many box sides k to take off the separation rn (now, along one axis)
 * so that r - k L is the image that meets: the nearest one now, k =
 * round(rn / L). A particle that flew many sides since its stored state
 * (a dilute gas: 1741 time units, ~95 sides) needs more than one; one, as
 * before, took an image still ~94 sides away. And at a tie, the two images
 * L/2 away each way (4 cells a side, where a neighbour cell reaches half
 * the box: a particle crossing the periodic face at L/2 from the central
 * seed), the one the pair approaches (rn v < 0): round-off picked the
 * receding one, no event followed, the next crossing scans only the new
 * slab, and the particle passed 0.19 diameters into the seed (3D, 20
 * particles at packing 1e-4, seeds 2, 3, 6; test event-periodic-few).
 * k = +-1 away from a tie gives r -+ L, the bits of before. */
static inline double ev_image(double rn, double v, double half, double L, double ro)
{
    double k = nearbyint(rn / L);
    const double rk = rn - k * L;
    if (fabs(rk) > ev_half_near(half, rn, ro) && rk * v > 0) k += rk > 0 ? 1 : -1;
    return k;
}

/* A pair more than 100 contact distances apart (this, squared) at the time
 * it is solved from is solved from its closest approach (solve_far); nearer,
 * the quadratic's round-off, about epsilon 1e4 of a contact distance, is
 * far below the stated 1e-10, and the bits are those of before. */
#define EV_SOLVE_FAR2 1e4

/* The contact time of a pair far apart at t0 (separation r, relative
 * velocity v, b = r.v < 0, vv = v.v): solved from the time of closest
 * approach t0 + s, s = -b / vv, where the separation r + v s is short. A
 * stored state may be a long flight old (a dilute periodic gas: 1741 time
 * units, ~95 box sides), and the quadratic solved across it from t0 lost
 * about epsilon |r|^2 / contact in c = r.r - sigma^2: a stuck particle
 * 3.3e-7 of a contact distance off its parent, 3000 times the stated
 * bound (2D, 20 particles at packing 1e-4, periodic, seed 4). Here the
 * round-off is epsilon |r| in the separation, not its square. Depends only
 * on the stored states, as every prediction (see the top). */
static __attribute__((noinline, cold)) double solve_far(const int D, const double *r, const double *v, double b, double vv,
                               double sig, double t0, double now)
{
    const double s = -b / vv;
    double rc2 = 0;
    for (int k = 0; k < D; k++) {
        const double rc = r[k] + v[k] * s;
        rc2 += rc * rc;
    }
    const double h = sig * sig - rc2;
    if (h <= 0) return EV_INF; /* passes at or beyond contact: miss or graze */
    const double t = t0 + (s - sqrt(h / vv));
    return t > now ? t : now;
}

/* The separation at t0 and relative velocity of the pair (pi, pj) with
 * every periodic image chosen by ev_image (pred_pp's rare case). */
static void rare_images(const int D, const double *pi, const double *pj, double now, double half, double L,
                        double *r, double *v)
{
    const double ti = pi[2 * D], tj = pj[2 * D];
    const double t0 = ti > tj ? ti : tj;
    const double di = t0 - ti, dj = t0 - tj, dn = now - t0;
    for (int k = 0; k < D; k++) {
        const double r0 = (pj[k] + pj[D + k] * dj) - (pi[k] + pi[D + k] * di);
        v[k] = pj[D + k] - pi[D + k];
        const double rn = r0 + v[k] * dn;
        const double ro = fabs(pi[k]) + fabs(pj[k]) + (fabs(pi[D + k]) + fabs(pj[D + k])) * fabs(now);
        r[k] = fabs(rn) > ev_half_near(half, rn, ro) ? r0 - L * ev_image(rn, v[k], half, L, ro) : r0;
    }
}

/* The contact time from separation r at t0 and relative velocity v (b =
 * r.v, vv = v.v), as pred_pp solves it. */
static inline __attribute__((always_inline)) double solve(const int D, const double *r, const double *v, double b,
                                                          double rr, double vv, double sig, double t0, double now)
{
    if (b >= 0) return EV_INF; /* receding or at rest: no event */
    const double c = rr - sig * sig;
    if (c <= 0) return t0 > now ? t0 : now; /* round-off overlap, approaching: now */
    if (__builtin_expect(rr > EV_SOLVE_FAR2 * sig * sig, 0)) return solve_far(D, r, v, b, vv, sig, t0, now);
    const double disc = b * b - vv * c;
    if (disc <= 0) return EV_INF; /* miss or exact graze */
    const double t = t0 + c / (-b + sqrt(disc)); /* stable root (no cancellation) */
    return t > now ? t : now;
}

/* pred_pp's rare case, out of line: every image by ev_image. */
static __attribute__((noinline, cold)) double pred_rare(const int D, const double *pi, const double *pj, double now,
                                                       double half, double L)
{
    double r[3], v[3], b = 0, rr = 0, vv = 0;
    rare_images(D, pi, pj, now, half, L, r, v);
    for (int k = 0; k < D; k++) {
        b += r[k] * v[k];
        rr += r[k] * r[k];
        vv += v[k] * v[k];
    }
    const double ti = pi[2 * D], tj = pj[2 * D];
    return solve(D, r, v, b, rr, vv, pi[2 * D + 1] + pj[2 * D + 1], ti > tj ? ti : tj, now);
}

/* Time at which the particles at pi and pj touch, or INF; never before
 * `now`. Depends only on the two stored states (see the top comment).
 * per/half/L: the box, passed in so a scan keeps them in registers (per:
 * 0 walls, or EV_PER_NEAR / EV_PER_ANY). The wrap `|r| > half: r -=
 * sign(r) L` is the minimum image r > half ? r - L : r < -half ? r + L :
 * r, bit for bit, with one test in the usual case; a separation beyond
 * 1.5 L (a long flight) or a box without the neighbour bound goes to
 * pred_rare (ev_image). */
static inline __attribute__((always_inline)) double
pred_pp(const int D, const double *pi, const double *pj, double now, int per, double half,
        double L)
{
    if (per == EV_PER_ANY) return pred_rare(D, pi, pj, now, half, L);
    const double ti = pi[2 * D], tj = pj[2 * D];
    const double t0 = ti > tj ? ti : tj; /* the time the pair is solved from */
    const double di = t0 - ti, dj = t0 - tj, dn = now - t0;
    double r[3], v[3], b = 0, rr = 0, vv = 0;
    int rare = 0;
    for (int k = 0; k < D; k++) {
        r[k] = (pj[k] + pj[D + k] * dj) - (pi[k] + pi[D + k] * di);
        v[k] = pj[D + k] - pi[D + k];
        if (per) {
            /* the image is the nearest one now, not at t0 (see the top) */
            const double rn = r[k] + v[k] * dn;
            if (fabs(rn) > half) {
                r[k] = rn > 0 ? r[k] - L : r[k] + L;
                rare |= fabs(rn) > 1.5 * L;
            }
        }
        b += r[k] * v[k];
        rr += r[k] * r[k];
        vv += v[k] * v[k];
    }
    if (__builtin_expect(rare, 0)) return pred_rare(D, pi, pj, now, half, L);
    return solve(D, r, v, b, rr, vv, pi[2 * D + 1] + pj[2 * D + 1], t0, now);
}

static inline __attribute__((always_inline)) double
pred_pair(const ev_sim *s, const int D, uint32_t i, uint32_t j, double now)
{
    return pred_pp(D, EV_P(s, i), EV_P(s, j), now, s->periodic ? EV_PER_ANY : 0, s->half, s->L);
}

/* Earliest wall event of i (elastic walls only): time, *what = 2k+side. */
static inline __attribute__((always_inline)) double
pred_wall(const ev_sim *s, const int D, uint32_t i, double now, int *what)
{
    const double *p = EV_P(s, i);
    const double r = p[2 * D + 1];
    double best = EV_INF;
    for (int k = 0; k < D; k++) {
        const double v = p[D + k];
        double t;
        if (v > 0) t = (s->L - r - p[k]) / v;
        else if (v < 0) t = (p[k] - r) / -v;
        else continue;
        t = t > 0 ? p[2 * D] + t : p[2 * D];
        if (t < best) {
            best = t;
            *what = 2 * k + (v > 0);
        }
    }
    return best > now ? best : now;
}

/* Cell coordinates of cell c. */
static inline __attribute__((always_inline)) void cell_coords(const ev_sim *s, const int D,
                                                              uint32_t c, int32_t *cc)
{
    for (int k = 0; k < D; k++) {
        cc[k] = (int32_t)(c % (uint32_t)s->nc);
        c /= (uint32_t)s->nc;
    }
}

/* Next cell crossing of i: time, *what = 2k + (direction > 0). In a box with
 * walls the outer faces are never crossed (the wall comes first). */
static inline __attribute__((always_inline)) double
pred_cell(const ev_sim *s, const int D, uint32_t i, double now, int *what)
{
    const double *p = EV_P(s, i);
    int32_t cc[3];
    cell_coords(s, D, s->lk[i].cell, cc);
    double best = EV_INF;
    *what = -1;
    for (int k = 0; k < D; k++) {
        const double v = p[D + k];
        double t;
        if (v > 0) {
            if (!s->periodic && cc[k] == s->nc - 1) continue;
            t = ((double)(cc[k] + 1) * s->w - p[k]) / v;
        } else if (v < 0) {
            if (!s->periodic && cc[k] == 0) continue;
            t = ((double)cc[k] * s->w - p[k]) / v;
        } else {
            continue;
        }
        t = t > 0 ? p[2 * D] + t : p[2 * D];
        if (t < best) {
            best = t;
            *what = 2 * k + (v > 0);
        }
    }
    return best > now ? best : now;
}

/* Visit the cells around cc (3^D, or the 3^(D-1) slab at offset `slab` in
 * dimension `sk` when sk >= 0), running BODY for each particle j there.
 * The cells are listed first and the first particle of each is prefetched,
 * so their cache misses overlap instead of following one another down the
 * linked lists (at N >= 1e5 these misses are most of the time per event).
 * The wrapped (or, with walls, dropped) coordinates are worked out once per
 * dimension, 3 per axis, not once per cell. The visiting order is the same
 * as always: cells in z, y, x order, each list from its head (the scans'
 * results do not depend on it anyway: ties go to the lower index). */
#define EV_FOR_NEIGHBOURS(s, D, cc, sk, slab, BODY)                                          \
    do {                                                                                     \
        const int nc_ = (s)->nc, per_ = (s)->periodic;                                       \
        const uint32_t *const cnext_ = (s)->cnext, *const chead_ = (s)->chead;              \
        uint32_t off_[3][3] = {{0}, {0}, {0}}, stride_ = 1;                                 \
        int no_[3] = {1, 1, 1};                                                              \
        for (int k_ = 0; k_ < (D); k_++) {                                                   \
            const int lo_ = k_ == (sk) ? (slab) : -1, hi_ = k_ == (sk) ? (slab) : 1;         \
            int m_ = 0;                                                                      \
            for (int o_ = lo_; o_ <= hi_; o_++) {                                            \
                int q_ = (cc)[k_] + o_;                                                      \
                if (q_ < 0 || q_ >= nc_) {                                                   \
                    if (!per_) continue;                                                     \
                    q_ = q_ < 0 ? q_ + nc_ : q_ - nc_;                                       \
                }                                                                            \
                off_[k_][m_++] = (uint32_t)q_ * stride_;                                     \
            }                                                                                \
            no_[k_] = m_;                                                                    \
            stride_ *= (uint32_t)nc_;                                                        \
        }                                                                                    \
        uint32_t heads_[27];                                                                 \
        int nh_ = 0;                                                                         \
        for (int a_ = 0; a_ < no_[2]; a_++)                                                  \
            for (int b_ = 0; b_ < no_[1]; b_++) {                                            \
                const uint32_t row_ = off_[2][a_] + off_[1][b_];                             \
                for (int c_ = 0; c_ < no_[0]; c_++) {                                        \
                    const uint32_t h_ = chead_[row_ + off_[0][c_]];                          \
                    if (h_ == UINT32_MAX) continue;                                          \
                    __builtin_prefetch(EV_P_ANY((s), h_));                                   \
                    __builtin_prefetch(&cnext_[h_]);                                         \
                    heads_[nh_++] = h_;                                                      \
                }                                                                            \
            }                                                                                \
        for (int q_ = 0; q_ < nh_; q_++) {                                                   \
            for (uint32_t j = heads_[q_]; j != UINT32_MAX; j = cnext_[j]) {                  \
                {                                                                            \
                    const uint32_t nx_ = cnext_[j];                                          \
                    if (nx_ != UINT32_MAX) __builtin_prefetch(EV_P_ANY((s), nx_));           \
                }                                                                            \
                BODY                                                                         \
            }                                                                            \
        }                                                                                    \
    } while (0)

/* Pair prediction of pi against two candidates at once, one per SSE2 lane:
 * the same IEEE operations as pred_pp in each lane, in the same order, so
 * the times are the same bits; the case analysis of pred_pp is done with
 * masks instead of branches (a scan's outcomes - receding, missing,
 * hitting - are near random, and each mispredicted branch cost about as
 * much as the arithmetic). A lane whose case is decided by a mask may
 * divide by zero on the way (inf or NaN, no trap; the mask drops it).
 * out[0] for pa, out[1] for pb. */
#if defined(__SSE2__)
/* pred_pp2's rare lanes (ev_image, solve_far), out of line so the scan's
 * loop keeps its registers. D is 2 or 3. */
static __attribute__((noinline, cold)) void pred_pp2_slow(const int D, const double *pi, const double *pa,
                                                          const double *pb, double now, int per, double half,
                                                          double L, double *out)
{
    if (D == 2) {
        out[0] = pred_pp(2, pi, pa, now, per, half, L);
        out[1] = pred_pp(2, pi, pb, now, per, half, L);
    } else {
        out[0] = pred_pp(3, pi, pa, now, per, half, L);
        out[1] = pred_pp(3, pi, pb, now, per, half, L);
    }
}

static inline __attribute__((always_inline)) void
pred_pp2(const int D, const double *pi, const double *pa, const double *pb, double now, int per,
         double half, double L, double *out)
{
    if (per == EV_PER_ANY) {
        pred_pp2_slow(D, pi, pa, pb, now, per, half, L, out);
        return;
    }
    const __m128d sgn = _mm_set1_pd(-0.0), inf = _mm_set1_pd(EV_INF), zero = _mm_setzero_pd();
    const __m128d ti = _mm_set1_pd(pi[2 * D]), tj = _mm_set_pd(pb[2 * D], pa[2 * D]);
    const __m128d tr = _mm_max_pd(ti, tj); /* ti > tj ? ti : tj */
    const __m128d di = _mm_sub_pd(tr, ti), dj = _mm_sub_pd(tr, tj);
    const __m128d dn = _mm_sub_pd(_mm_set1_pd(now), tr);
    __m128d b = zero, rr = zero, vv = zero, slow = zero;
#pragma GCC unroll 3
    for (int k = 0; k < D; k++) {
        const __m128d xj = _mm_set_pd(pb[k], pa[k]), vj = _mm_set_pd(pb[D + k], pa[D + k]);
        const __m128d xi = _mm_set1_pd(pi[k]), vi = _mm_set1_pd(pi[D + k]);
        __m128d r = _mm_sub_pd(_mm_add_pd(xj, _mm_mul_pd(vj, dj)), _mm_add_pd(xi, _mm_mul_pd(vi, di)));
        const __m128d v = _mm_sub_pd(vj, vi);
        if (per) {
            /* |rn| > half (rn = r + v dn, the separation now): r -
             * copysign(L, rn), i.e. r - L or r + L exactly, as pred_pp's
             * usual case. A lane beyond 1.5 L (a long flight: ev_image,
             * see EV_PER_NEAR) is rare, so both lanes go to pred_pp
             * (pred_pp2_slow), whose arithmetic is this one's, bit for
             * bit; EV_PER_ANY goes there at once. */
            const __m128d rn = _mm_add_pd(r, _mm_mul_pd(v, dn));
            const __m128d arn = _mm_andnot_pd(sgn, rn);
            const __m128d far = _mm_cmpgt_pd(arn, _mm_set1_pd(half));
            const __m128d sl = _mm_or_pd(_mm_and_pd(sgn, rn), _mm_set1_pd(L));
            r = _mm_sub_pd(r, _mm_and_pd(far, sl));
            slow = _mm_or_pd(slow, _mm_cmpgt_pd(arn, _mm_set1_pd(1.5 * L)));
        }
        b = _mm_add_pd(b, _mm_mul_pd(r, v));
        rr = _mm_add_pd(rr, _mm_mul_pd(r, r));
        vv = _mm_add_pd(vv, _mm_mul_pd(v, v));
    }
    const __m128d sig = _mm_add_pd(_mm_set1_pd(pi[2 * D + 1]), _mm_set_pd(pb[2 * D + 1], pa[2 * D + 1]));
    /* and a pair far apart at tr: solve_far */
    slow = _mm_or_pd(slow, _mm_cmpgt_pd(rr, _mm_mul_pd(_mm_set1_pd(EV_SOLVE_FAR2), _mm_mul_pd(sig, sig))));
    if (__builtin_expect(_mm_movemask_pd(slow), 0)) {
        pred_pp2_slow(D, pi, pa, pb, now, per, half, L, out);
        return;
    }
    const __m128d c = _mm_sub_pd(rr, _mm_mul_pd(sig, sig));
    const __m128d disc = _mm_sub_pd(_mm_mul_pd(b, b), _mm_mul_pd(vv, c));
    /* sqrt of disc where disc > 0 (the only lanes that use it) */
    const __m128d sq = _mm_sqrt_pd(_mm_and_pd(_mm_cmpgt_pd(disc, zero), disc));
    const __m128d nb = _mm_xor_pd(b, sgn); /* -b */
    const __m128d t = _mm_max_pd(_mm_add_pd(tr, _mm_div_pd(c, _mm_add_pd(nb, sq))), _mm_set1_pd(now));
    const __m128d tnow = _mm_max_pd(tr, _mm_set1_pd(now));
    const __m128d over = _mm_cmple_pd(c, zero), miss = _mm_cmple_pd(disc, zero);
    const __m128d rec = _mm_cmpge_pd(b, zero);
    /* c <= 0: tnow; else disc <= 0: INF; else t; and b >= 0: INF */
    __m128d res = _mm_or_pd(_mm_and_pd(miss, inf), _mm_andnot_pd(miss, t));
    res = _mm_or_pd(_mm_and_pd(over, tnow), _mm_andnot_pd(over, res));
    res = _mm_or_pd(_mm_and_pd(rec, inf), _mm_andnot_pd(rec, res));
    _mm_storeu_pd(out, res);
}
#endif

/* Best (time, partner) of i over the candidates cand[0 .. n): the least
 * (time, index); a wall event (*bj = none) wins a tie, and nothing replaces
 * "no event" (INF) by an INF pair. cand may name i itself (skipped). */
static inline __attribute__((always_inline)) void
scan_batch_per(const ev_sim *s, const int D, const int per, uint32_t i, const double *pi,
               const uint32_t *cand, int n, double now, double *bt, uint32_t *bj)
{
    const double *const ps = s->ps;
    const double half = s->half, L = s->L;
    double t2[2];
    for (int q = 0; q < n; q += 2) {
        const uint32_t ja = cand[q], jb = q + 1 < n ? cand[q + 1] : i;
        const double *pa = ps + (size_t)ja * (size_t)(2 * D + 2);
        const double *pb = ps + (size_t)jb * (size_t)(2 * D + 2);
#if defined(__SSE2__)
        pred_pp2(D, pi, pa, pb, now, per, half, L, t2);
#else
        t2[0] = pred_pp(D, pi, pa, now, per, half, L);
        t2[1] = pred_pp(D, pi, pb, now, per, half, L);
#endif
        for (int h = 0; h < 2; h++) {
            const uint32_t j = h ? jb : ja;
            const double t = t2[h];
            if ((t < *bt || (t == *bt && *bj != UINT32_MAX && j < *bj)) && j != i) {
                *bt = t;
                *bj = j;
                __builtin_prefetch(&s->lk[j].count); /* read when the scan ends */
            }
        }
    }
}

/* scan_batch with the box's wrap decided once per batch, not per pair */
static inline __attribute__((always_inline)) void
scan_batch(const ev_sim *s, const int D, uint32_t i, const double *pi, const uint32_t *cand,
           int n, double now, double *bt, uint32_t *bj)
{
    const int per = ev_per(s); /* a constant in each copy */
    if (per == EV_PER_NEAR) scan_batch_per(s, D, EV_PER_NEAR, i, pi, cand, n, now, bt, bj);
    else if (per == EV_PER_ANY) scan_batch_per(s, D, EV_PER_ANY, i, pi, cand, n, now, bt, bj);
    else scan_batch_per(s, D, 0, i, pi, cand, n, now, bt, bj);
}

/* Scan the cells around i (all, or one slab) for an earlier pair event:
 * the best (time, partner) is kept in registers and written back once.
 * batch = 1 (3D): the cells' particles are listed first (the lists walked
 * with the next record prefetched), then predicted two at a time by
 * scan_batch, without branches on the outcome; batch = 0 (2D, ~5
 * candidates per scan, too few to pay for the list): one at a time by
 * pred_pp, as they come. */
static inline __attribute__((always_inline)) void
scan_pairs_body(ev_sim *s, const int D, const int batch, const int per, uint32_t i, double now, int sk,
                int slab)
{
    ev_evt *e = &s->lk[i].ev;
    int32_t cc[3] = {0, 0, 0};
    cell_coords(s, D, s->lk[i].cell, cc);
    const double *const ps = s->ps, *const pi = EV_P(s, i);
    const double half = s->half, L = s->L;
    double bt = e->t_pair;
    const uint32_t bj0 = e->kind == EV_K_PAIR ? e->partner : UINT32_MAX;
    uint32_t bj = bj0;
    enum { CAP = 64 };
    uint32_t cand[CAP];
    int n = 0;
    EV_FOR_NEIGHBOURS(s, D, cc, sk, slab, {
        if (batch) {
            cand[n++] = j;
            if (n == CAP) {
                scan_batch(s, D, i, pi, cand, n, now, &bt, &bj);
                n = 0;
            }
        } else {
            if (j == i) continue;
            const double t = pred_pp(D, pi, ps + (size_t)j * (size_t)(2 * D + 2), now, per, half, L);
            if (t < bt || (t == bt && bj != UINT32_MAX && j < bj)) {
                bt = t;
                bj = j;
                __builtin_prefetch(&s->lk[j].count); /* read when the scan ends */
            }
        }
    });
    if (batch) scan_batch(s, D, i, pi, cand, n, now, &bt, &bj);
    if (bj != bj0 || bt != e->t_pair) {
        e->t_pair = bt;
        e->kind = EV_K_PAIR;
        e->partner = bj;
        e->pcount = s->lk[bj].count;
    }
}

/* 3D: out of line, so the batch's state stays in registers (inlined into
 * step(), the scan's counters went to the stack). */
static __attribute__((noinline)) void scan_pairs3(ev_sim *s, uint32_t i, double now, int sk, int slab)
{
    scan_pairs_body(s, 3, 1, ev_per(s), i, now, sk, slab); /* per: used by pred_pp only in 2D */
}

static inline __attribute__((always_inline)) void
scan_pairs(ev_sim *s, const int D, uint32_t i, double now, int sk, int slab)
{
    /* 2D predicts pair by pair: the box's kind a constant of each copy */
    const int per = ev_per(s);
    if (D == 2 && per == 0) scan_pairs_body(s, 2, 0, 0, i, now, sk, slab);
    else if (D == 2 && per == EV_PER_NEAR) scan_pairs_body(s, 2, 0, EV_PER_NEAR, i, now, sk, slab);
    else if (D == 2) scan_pairs_body(s, 2, 0, EV_PER_ANY, i, now, sk, slab);
    else scan_pairs3(s, i, now, sk, slab);
}

/* The big seeds i may meet from its cell (out of the cell lists, ev_big.c)
 * into its pair event, with the scans' rule: the least (time, index), a
 * wall event winning a tie. */
static __attribute__((noinline)) void scan_big(ev_sim *s, const int D, uint32_t i, double now)
{
    uint32_t lo, hi;
    ev_big_list(s, s->lk[i].cell, &lo, &hi);
    if (lo == hi) return;
    ev_evt *e = &s->lk[i].ev;
    const double *pi = EV_P(s, i);
    double bt = e->t_pair;
    const uint32_t bj0 = e->kind == EV_K_PAIR ? e->partner : UINT32_MAX;
    uint32_t bj = bj0;
    for (uint32_t a = lo; a < hi; a++) {
        const uint32_t j = s->bg_idx[a];
        const double t = pred_pp(D, pi, EV_P(s, j), now, s->periodic ? EV_PER_ANY : 0, s->half, s->L);
        if (t < bt || (t == bt && bj != UINT32_MAX && j < bj)) {
            bt = t;
            bj = j;
        }
    }
    if (bj != bj0 || bt != e->t_pair) {
        e->t_pair = bt;
        e->kind = EV_K_PAIR;
        e->partner = bj;
        e->pcount = s->lk[bj].count;
    }
}

/* Full prediction of i's events. */
static inline __attribute__((always_inline)) void predict_all(ev_sim *s, const int D, uint32_t i,
                                                              double now)
{
    ev_evt *e = &s->lk[i].ev;
    e->t_pair = EV_INF;
    e->kind = EV_K_NONE;
    if (!s->periodic) {
        int what = 0;
        const double t = pred_wall(s, D, i, now, &what);
        if (t < EV_INF) {
            e->t_pair = t;
            e->kind = EV_K_WALL;
            e->partner = (uint32_t)what;
        }
    }
    scan_pairs(s, D, i, now, -1, 0);
    if (__builtin_expect(s->nbig != 0, 0)) scan_big(s, D, i, now);
    int what = -1;
    e->t_cell = pred_cell(s, D, i, now, &what);
    e->cell_what = (int8_t)what;
}

/* Move i's stored state to time t. */
static inline __attribute__((always_inline)) void advance(ev_sim *s, const int D, uint32_t i,
                                                          double t)
{
    double *p = EV_P(s, i);
    const double dt = t - p[2 * D];
    for (int k = 0; k < D; k++) p[k] += p[D + k] * dt;
    p[2 * D] = t;
}

static inline __attribute__((always_inline)) double kinetic(const ev_sim *s, const int D,
                                                            uint32_t i)
{
    const double *p = EV_P(s, i);
    double v2 = 0;
    for (int k = 0; k < D; k++) v2 += p[D + k] * p[D + k];
    return 0.5 * ev_pmass(s, i) * v2;
}

/* i (just stuck, at rest) offers itself as a partner to every free
 * neighbour whose pending event is later (see the invariant above). */
static inline __attribute__((always_inline)) void offer_stuck(ev_sim *s, const int D, uint32_t i,
                                                              double now)
{
    int32_t cc[3] = {0, 0, 0};
    cell_coords(s, D, s->lk[i].cell, cc);
    EV_FOR_NEIGHBOURS(s, D, cc, -1, 0, {
        if (j == i || s->stuck[j]) continue;
        const double t = pred_pair(s, D, j, i, now);
        ev_evt *e = &s->lk[j].ev;
        if (t < e->t_pair || (t == e->t_pair && e->kind == EV_K_PAIR && i < e->partner)) {
            e->t_pair = t;
            e->kind = EV_K_PAIR;
            e->partner = i;
            e->pcount = s->lk[i].count;
            heap_fix(s, j);
        }
    });
}

/* r.(vb - va): the pair's b as pred_pp computes it when the pair is next
 * predicted at this instant (r from a to b as the collision took it, va
 * NULL for a stuck a, at rest): the same products summed in the same
 * order, so the same bits (a stuck partner's -vb and -r cancel exactly). */
static inline __attribute__((always_inline)) double approach(const int D, const double *r,
                                                             const double *va, const double *vb)
{
    double b = 0;
    for (int k = 0; k < D; k++) b += r[k] * (va ? vb[k] - va[k] : vb[k]);
    return b;
}

/* The pair of a collision still approaches (approach() < 0): a graze, whose
 * normal speed |r.v| / |r| was below the round-off of the velocities (r.v =
 * -6.9e-18 at speeds 0.3, touching by round-off; a co-moving pair sooner),
 * so the reflection's change, -2 (r.v) r / r.r, was below half an ulp of
 * every component and was lost. The next prediction found the pair touching
 * and approaching, "collide now", and the same collision repeated at the
 * same instant until max_events (99,998 of them at t = 0; --t-max could not
 * end it). Here the pair gets the least push along r that makes it recede
 * as that prediction computes r.v: r.v is set to 4 epsilon of its round-off
 * scale sum |r_k| (|va_k| + |vb_k|) (the particles' own speeds, not the
 * relative one: a co-moving pair rounds its change away sooner), the push
 * doubled until r.v >= 0 (the first push did it in every case tried). wa,
 * wb: the shares mb / (ma + mb), ma / (ma + mb) of the push (a stuck a: va
 * NULL, wb = 1), so momentum is kept to round-off; the push itself changes
 * the energy by ~epsilon^2 of it, the rounding of the new velocities by
 * what any collision's does. Returns the push g (relative velocity change
 * g r) for the virial. */
static __attribute__((noinline, cold)) double recede(const int D, const double *r, double rr, double *va,
                                                    double *vb, double wa, double wb)
{
    double sc = 0, g = 0;
    for (int k = 0; k < D; k++) sc += fabs(r[k]) * (fabs(vb[k]) + (va ? fabs(va[k]) : 0));
    double d = 4 * DBL_EPSILON * sc + DBL_MIN;
    for (int it = 0; it < 64 && rr > 0; it++) {
        const double b = approach(D, r, va, vb);
        if (!(b < 0)) break;
        const double dg = (d - b) / rr;
        for (int k = 0; k < D; k++) {
            if (va) va[k] -= wa * dg * r[k];
            vb[k] += wb * dg * r[k];
        }
        g += dg;
        d *= 2;
    }
    return g;
}

/* Free i meets stuck j: stick with probability p (never for a bath
 * particle), else reflect off the infinite mass: v -= 2 (v.r) r / r.r, which
 * keeps |v| (the bath particle's energy) to round-off. */
static inline __attribute__((always_inline)) void hit_stuck(ev_sim *s, const int D, uint32_t i,
                                                            uint32_t j, double now)
{
    double *pi = EV_P(s, i);
    const double *pj = EV_P(s, j);
    double r[3], rr = 0, rv = 0;
    for (int k = 0; k < D; k++) {
        r[k] = pi[k] - pj[k];
        if (s->periodic) {
            if (r[k] > s->half) r[k] -= s->L;
            else if (r[k] < -s->half) r[k] += s->L;
        }
        rr += r[k] * r[k];
        rv += r[k] * pi[D + k];
    }
    const double sig = pi[2 * D + 1] + pj[2 * D + 1];
    const double ov = (sig - sqrt(rr)) / sig;
    if (ov > s->max_overlap) s->max_overlap = ov;
    /* A bath particle (a kind with STICKY 0) never sticks and draws no
     * random number; has_bath first, so an all-sticky run pays one
     * predictable branch here and nothing in the loop. */
    const int sticks = (!s->has_bath || s->sp[s->species[i]].sticky) &&
                       (s->stick_p >= 1 || (s->stick_p > 0 && rng_uniform(&s->rng) < s->stick_p));
    if (sticks) {
        s->ke_stuck += kinetic(s, D, i);
        for (int k = 0; k < D; k++) pi[D + k] = 0;
        s->stuck[i] = 1;
        s->parent[i] = j;
        s->stuck_idx[s->nstuck] = i;
        s->stuck_t[s->nstuck] = now;
        s->nstuck++;
        s->sticks++;
        s->lk[i].count++;
        q_remove(s, i);
        if (s->trace) s->trace(&(ev_trace_event){now, i, j, EV_EV_STICK}, s->trace_user);
        offer_stuck(s, D, i, now);
        return;
    }
    /* Reflect: dp_i = -2 m (v.r) r / rr; virial r_ij . dp_i. */
    const double f = 2 * rv / rr;
    double rv1 = 0; /* r.v after: approach(D, r, NULL, pi + D) */
    for (int k = 0; k < D; k++) {
        const double u = pi[D + k] - f * r[k];
        pi[D + k] = u;
        rv1 += r[k] * u;
    }
    s->virial += -ev_pmass(s, i) * f * rr;
    /* a graze whose change was lost: pushed off, as it is predicted */
    if (__builtin_expect(rv1 < 0, 0)) s->virial += ev_pmass(s, i) * recede(D, r, rr, NULL, pi + D, 0, 1) * rr;
    s->collisions++;
    s->lk[i].count++;
    if (s->trace) s->trace(&(ev_trace_event){now, i, j, EV_EV_PAIR}, s->trace_user);
    predict_all(s, D, i, now);
    heap_fix(s, i);
}

/* Elastic collision of free i and free j at time now (both advanced). */
static inline __attribute__((always_inline)) void collide(ev_sim *s, const int D, uint32_t i,
                                                          uint32_t j, double now)
{
    double *pi = EV_P(s, i), *pj = EV_P(s, j);
    double r[3], rr = 0, rv = 0;
    for (int k = 0; k < D; k++) {
        r[k] = pj[k] - pi[k];
        if (s->periodic) {
            if (r[k] > s->half) r[k] -= s->L;
            else if (r[k] < -s->half) r[k] += s->L;
        }
        rr += r[k] * r[k];
        rv += r[k] * (pj[D + k] - pi[D + k]);
    }
    const double sig = pi[2 * D + 1] + pj[2 * D + 1];
    const double ov = (sig - sqrt(rr)) / sig;
    if (ov > s->max_overlap) s->max_overlap = ov;
    const double mi = ev_pmass(s, i), mj = ev_pmass(s, j);
    /* Reflection along r with r.r in the denominator: exact for any |r|. */
    const double den = rr * (mi + mj);
    const double f = 2 * rv / den;
    /* r_ij = -r, dp_i = mi mj f r: r_ij . dp_i = -mi mj f rr (> 0, f < 0). */
    double fi = mj * f, fj = mi * f, vir = -mi * mj * f * rr;
    if (__builtin_expect(!(den >= DBL_MIN) || !(fabs(f) <= DBL_MAX) || !(mi * mj >= DBL_MIN), 0)) {
        /* Tiny particles: r.r (m_i + m_j) or m_i m_j under DBL_MIN (2D
         * radius 1e-80 at density 1, r^4 ~ 1e-320; 3D 1e-65), where the
         * product underflowed: f was infinite, the velocities NaN, and the
         * wall events of a NaN position repeated at one instant until
         * --max-events; 3D radius 1e-55: m_i m_j = 0, the collisions added
         * nothing to the virial. The
         * same reflection by the velocity change 2 r.v / r.r (~ |v| / |r|)
         * and the mass shares, which do not underflow; ordinary scales keep
         * the bits above. Test event-tiny. */
        const double g = 2 * rv / rr, wi = mj / (mi + mj), wj = mi / (mi + mj);
        fi = wi * g;
        fj = wj * g;
        vir = -(mi * wj) * g * rr;
    }
    double rv1 = 0; /* r.v after: approach(D, r, pi + D, pj + D) */
    for (int k = 0; k < D; k++) {
        const double ui = pi[D + k] + fi * r[k], uj = pj[D + k] - fj * r[k];
        pi[D + k] = ui;
        pj[D + k] = uj;
        rv1 += r[k] * (uj - ui);
    }
    s->virial += vir;
    /* a graze whose change was lost: pushed apart, as it is predicted */
    if (__builtin_expect(rv1 < 0, 0))
        s->virial += mi * mj / (mi + mj) * recede(D, r, rr, pi + D, pj + D, mj / (mi + mj), mi / (mi + mj)) * rr;
    s->collisions++;
    s->lk[i].count++;
    s->lk[j].count++;
    if (s->trace) s->trace(&(ev_trace_event){now, i, j, EV_EV_PAIR}, s->trace_user);
    /* Both predictions first, then both queue updates (in the same order as
     * ever: the queue ends the same). A queue update's first load, the
     * head of the bucket list of the new key, is a random line at large N;
     * prefetched after i's prediction, it arrives while j's runs. */
    predict_all(s, D, i, now);
    if (s->lookahead) q_prefetch(s, i);
    predict_all(s, D, j, now);
    if (s->lookahead) q_prefetch(s, j);
    heap_fix(s, i);
    heap_fix(s, j);
}

/* ---- look-ahead: the next events' lines, fetched while this one runs ------
 *
 * Once the arrays leave the L2 (N >~ 3e4), an event's time is mostly load
 * latency: the particle's record and event, its cell, the heads of the 9 or
 * 27 cells around it, then their particles' records. Each event's own loads
 * overlap only among themselves; but the queue already names the particles
 * of the next few events: the heap's entries after its top, then the heads
 * of the next bucket lists. So every event first prefetches, in two stages,
 * for particles that come one to three events later:
 *  - stage 1 (the heads of buckets cq+2, cq+3, the second of cq+1): the
 *    particle's record, event, cell, counter and queue links;
 *  - stage 2 (heap[1], heap[2], the head of bucket cq+1), whose lines stage
 *    1 often fetched an event ago: the cell heads its next event will scan (the
 *    3^D block; for a cell crossing, the new slab) and, for a pair event,
 *    the partner's lines.
 * A guess that turns out wrong (a new event jumps the queue) only wastes a
 * few prefetches: nothing here changes the state or the event order. Cell
 * rows are taken without wrapping, clamped to the grid: at the box's faces
 * a few prefetches miss, nothing more. */

static inline __attribute__((always_inline)) void la_particle(const ev_sim *s, const int D,
                                                              uint32_t id)
{
    const double *p = EV_P(s, id);
    __builtin_prefetch(p);
    if (D == 2) __builtin_prefetch(p + 5); /* 48-byte records straddle lines */
    __builtin_prefetch(&s->lk[id]); /* events, counter, cell, queue place: one line */
}

/* Prefetch the cell heads of the block around cell c: offsets -1..1 in
 * every dimension, or only `off` in dimension sk (sk >= 0). */
static inline __attribute__((always_inline)) void la_block(const ev_sim *s, const int D,
                                                           uint32_t c, int sk, int off)
{
    const int64_t nc = s->nc, ncell = D == 2 ? nc * nc : nc * nc * nc;
    const int64_t st1 = nc, st2 = nc * nc;
    const int lo0 = sk == 0 ? off : -1, hi0 = sk == 0 ? off : 1;
    const int lo1 = sk == 1 ? off : -1, hi1 = sk == 1 ? off : 1;
    const int lo2 = D == 3 ? (sk == 2 ? off : -1) : 0, hi2 = D == 3 ? (sk == 2 ? off : 1) : 0;
    for (int a = lo2; a <= hi2; a++)
        for (int b = lo1; b <= hi1; b++) {
            const int64_t row = (int64_t)c + a * st2 + b * st1;
            int64_t x0 = row + lo0, x1 = row + hi0;
            x0 = x0 < 0 ? 0 : x0 >= ncell ? ncell - 1 : x0;
            x1 = x1 < 0 ? 0 : x1 >= ncell ? ncell - 1 : x1;
            __builtin_prefetch(&s->chead[x0]);
            __builtin_prefetch(&s->chead[x1]);
        }
}

static inline __attribute__((always_inline)) void la_cells(const ev_sim *s, const int D,
                                                           uint32_t id)
{
    const ev_evt *e = &s->lk[id].ev;
    const uint32_t c = s->lk[id].cell;
    if (e->t_cell <= e->t_pair) {
        if (e->cell_what < 0) return;
        const int k = e->cell_what >> 1, up = e->cell_what & 1;
        la_block(s, D, c, k, up ? 2 : -2);
        return;
    }
    la_block(s, D, c, -1, 0);
    if (e->kind == EV_K_PAIR && e->partner < s->ntot) la_particle(s, D, e->partner);
}

static inline __attribute__((always_inline)) void lookahead(const ev_sim *s, const int D)
{
    if (s->hn > 1) la_cells(s, D, s->heap[1].id);
    if (s->hn > 2) la_cells(s, D, s->heap[2].id);
    const uint32_t cq = s->cq, nb = s->qnb;
    if (cq + 1 < nb) {
        const uint32_t h = s->qhead[cq + 1];
        if (h != QNONE) {
            la_cells(s, D, h);
            const uint32_t h2 = s->lk[h].qnext;
            if (h2 != QNONE) la_particle(s, D, h2);
        }
    }
    for (uint32_t k = 2; k <= 3 && cq + k < nb; k++) {
        const uint32_t h = s->qhead[cq + k];
        if (h != QNONE) la_particle(s, D, h);
    }
}

/* Process the earliest event. 0, or -1 when none is left. */
static inline __attribute__((always_inline)) int step(ev_sim *s, const int D)
{
    if (q_ready(s)) return -1;
    const uint32_t i = s->heap[0].id;
    ev_evt *e = &s->lk[i].ev;
    s->events++;
    if (s->lookahead) lookahead(s, D);
    if (e->t_cell <= e->t_pair) {
        /* Cell crossing: the stored state does not change (periodic: the
         * position moves by one box side). Scan only the new slab. */
        const double now = e->t_cell;
        s->now = now;
        s->cell_crossings++;
        const int k = e->cell_what >> 1, up = e->cell_what & 1;
        int32_t cc[3] = {0, 0, 0};
        cell_coords(s, D, s->lk[i].cell, cc);
        cc[k] += up ? 1 : -1;
        if (cc[k] == s->nc) {
            cc[k] = 0;
            EV_P(s, i)[k] -= s->L;
        } else if (cc[k] < 0) {
            cc[k] = s->nc - 1;
            EV_P(s, i)[k] += s->L;
        }
        uint32_t c = 0;
        for (int q = D - 1; q >= 0; q--) c = c * (uint32_t)s->nc + (uint32_t)cc[q];
        cell_remove(s, i);
        ev_cell_insert(s, i, c);
        scan_pairs(s, D, i, now, k, up ? 1 : -1);
        if (__builtin_expect(s->nbig != 0, 0)) scan_big(s, D, i, now); /* the new cell's big seeds */
        int what = -1;
        e->t_cell = pred_cell(s, D, i, now, &what);
        e->cell_what = (int8_t)what;
        heap_fix(s, i);
        return 0;
    }
    const double now = e->t_pair;
    s->now = now;
    if (e->kind == EV_K_WALL) {
        advance(s, D, i, now);
        double *p = EV_P(s, i);
        const int k = (int)e->partner >> 1, up = (int)e->partner & 1;
        /* Hitting the upper wall leaves with v < 0, the lower with v > 0. */
        s->wall_impulse += 2 * ev_pmass(s, i) * fabs(p[D + k]);
        p[D + k] = up ? -fabs(p[D + k]) : fabs(p[D + k]);
        s->wall_hits++;
        s->lk[i].count++;
        if (s->trace) s->trace(&(ev_trace_event){now, i, UINT32_MAX, EV_EV_WALL}, s->trace_user);
        predict_all(s, D, i, now);
        heap_fix(s, i);
        return 0;
    }
    const uint32_t j = e->partner;
    if (e->kind != EV_K_PAIR || s->lk[j].count != e->pcount) {
        /* Stale: the partner moved on. Predict again from the stored state. */
        s->invalid++;
        predict_all(s, D, i, now);
        heap_fix(s, i);
        return 0;
    }
    advance(s, D, i, now);
    if (s->stuck[j]) {
        hit_stuck(s, D, i, j, now);
        return 0;
    }
    /* j's cell heads load while i's neighbours are scanned */
    if (s->lookahead) la_block(s, D, s->lk[j].cell, -1, 0);
    advance(s, D, j, now);
    collide(s, D, i, j, now);
    return 0;
}

/* Dimension-specialised entry points: D is a constant in each. */
static int step2(ev_sim *s) { return step(s, 2); }
static int step3(ev_sim *s) { return step(s, 3); }
static void predict2(ev_sim *s, uint32_t i, double now) { predict_all(s, 2, i, now); }
static void predict3(ev_sim *s, uint32_t i, double now) { predict_all(s, 3, i, now); }

void ev_predict(ev_sim *s, uint32_t i, double now)
{
    if (s->dim == 2) predict2(s, i, now);
    else predict3(s, i, now);
}

/* The stuck-count stop of a run. With a bath the queue never empties: the
 * run ends when every sticky particle is stuck, folded into the stuck-count
 * stop so that a run without a bath makes the same test per event as
 * before. */
static uint64_t stuck_stop_of(const ev_sim *s)
{
    const uint64_t stuck_stop = s->par.max_stuck;
    if (s->has_bath && s->nfree_total && (!stuck_stop || stuck_stop > s->nsticky)) return s->nsticky;
    return stuck_stop;
}

/* The stop condition that holds before the next event, or 0. */
static inline int stop_before(ev_sim *s, uint64_t stuck_stop)
{
    if (s->qn == 0) return s->nfree_total && s->nstuck == s->n ? EV_STOP_ALL_STUCK : EV_STOP_NO_EVENTS;
    if (stuck_stop && s->nstuck >= stuck_stop)
        return s->has_bath && s->nfree_total && s->nstuck >= s->nsticky ? EV_STOP_ALL_STUCK : EV_STOP_STUCK;
    if (s->par.max_events && s->events >= s->par.max_events) return EV_STOP_EVENTS;
    if (q_ready(s)) return EV_STOP_NO_EVENTS; /* everything free is at rest */
    if (s->heap[0].t == EV_INF) return EV_STOP_NO_EVENTS; /* everything free is at rest */
    return 0;
}

int ev_stop_now(ev_sim *s) { return stop_before(s, stuck_stop_of(s)); }

/* Process events while the next is at or before t_end and no stop
 * condition holds; returns the stop reason or 0 when t_end was reached. */
int ev_loop(ev_sim *s, double t_end, volatile const int *interrupt)
{
    int (*const stepf)(ev_sim *) = s->dim == 2 ? step2 : step3;
    const uint64_t stuck_stop = stuck_stop_of(s);
    for (uint64_t n = 0;; n++) {
        const int why = stop_before(s, stuck_stop);
        if (why) return why;
        /* Polled before a row without events returns (until session 17 after:
         * with series rows far shorter than the time between events a run
         * went on for minutes deaf to SIGINT/SIGTERM, with no progress line
         * and no --checkpoint-every) */
        if ((n & 0xffff) == 0) {
            if (interrupt && *interrupt) return EV_STOP_INTERRUPT;
            /* between two events: the state is whole (progress, checkpoints) */
            if (s->tick && s->tick(s, s->tick_user)) return EV_STOP_INTERRUPT;
        }
        if (s->heap[0].t > t_end) return 0;
        stepf(s);
    }
}

static double seed_overlap(const ev_sim *s, const int D, uint32_t i, const double *xi, uint32_t j)
{
    const double *pj = EV_P(s, j);
    const double sig = EV_P(s, i)[2 * D + 1] + pj[2 * D + 1];
    return (sig - sqrt(ev_dist2(s, xi, pj))) / sig;
}

/* Largest overlap/(r_i + r_j) of particle i, at xi, with a big seed of
 * its cell's list (-INF when none); in a cell wholly inside a big seed,
 * where no particle can be, with every big seed. */
static double big_overlap(const ev_sim *s, const int D, uint32_t i, const double *xi)
{
    const uint64_t c = s->lk[i].cell;
    double worst = -INFINITY;
    if ((s->bg_inside[c >> 6] >> (c & 63)) & 1) {
        for (uint32_t j = s->n; j < s->ntot; j++)
            if (ev_is_big(s, j)) worst = fmax(worst, seed_overlap(s, D, i, xi, j));
        return worst;
    }
    uint32_t lo, hi;
    ev_big_list(s, c, &lo, &hi);
    for (uint32_t a = lo; a < hi; a++) worst = fmax(worst, seed_overlap(s, D, i, xi, s->bg_idx[a]));
    return worst;
}

/* Largest overlap/(r_i + r_j) over all pairs at the current time, each
 * particle's position taken at s->now without changing the state. */
double ev_max_overlap_now(ev_sim *s)
{
    const int D = s->dim;
    double worst = -INFINITY;
    const uint32_t ntot = s->ntot;
    for (uint32_t i = 0; i < ntot; i++) {
        const double *pi = EV_P(s, i);
        double xi[3];
        for (int k = 0; k < D; k++) xi[k] = pi[k] + pi[D + k] * (s->now - pi[2 * D]);
        int32_t cc[3] = {0, 0, 0};
        cell_coords(s, D, s->lk[i].cell, cc);
        EV_FOR_NEIGHBOURS(s, D, cc, -1, 0, {
            if (j <= i) continue;
            const double *pj = EV_P(s, j);
            double rr = 0;
            for (int k = 0; k < D; k++) {
                double r = pj[k] + pj[D + k] * (s->now - pj[2 * D]) - xi[k];
                if (s->periodic) {
                    if (r > s->half) r -= s->L;
                    else if (r < -s->half) r += s->L;
                }
                rr += r * r;
            }
            const double sig = pi[2 * D + 1] + pj[2 * D + 1];
            const double ov = (sig - sqrt(rr)) / sig;
            if (ov > worst) worst = ov;
        });
        if (s->nbig && i < s->n) {
            const double ov = big_overlap(s, D, i, xi);
            if (ov > worst) worst = ov;
        }
    }
    return worst;
}

/* Deepest overlap / (r_i + r_j) of free i at xi (now) and j, moving
 * straight from now to T (INF: for ever): at the closest approach within. */
static double ahead_overlap(const ev_sim *s, const int D, const double *pi, const double *xi, uint32_t j,
                            double T)
{
    const double *pj = EV_P(s, j);
    double r[3], rv = 0, vv = 0;
    for (int k = 0; k < D; k++) {
        r[k] = pj[k] + pj[D + k] * (s->now - pj[2 * D]) - xi[k];
        if (s->periodic) {
            if (r[k] > s->half) r[k] -= s->L;
            else if (r[k] < -s->half) r[k] += s->L;
        }
        const double v = pj[D + k] - pi[D + k];
        rv += r[k] * v;
        vv += v * v;
    }
    double u = rv < 0 ? -rv / vv : 0; /* the closest approach, if ahead */
    if (u > T - s->now) u = T - s->now;
    double rr = 0;
    for (int k = 0; k < D; k++) {
        const double d = r[k] + (pj[D + k] - pi[D + k]) * u;
        rr += d * d;
    }
    const double sig = pi[2 * D + 1] + pj[2 * D + 1];
    return (sig - sqrt(rr)) / sig;
}

/* Largest overlap / (r_i + r_j) that a pair with a free particle would
 * reach, both moving straight from their stored states, before either has
 * its pending pair or wall event (t_pair; a stuck particle or seed has
 * none). The invariant of the top (of any pair that will touch at t, one
 * has a pair event <= t pending; cell crossings never raise t_pair) keeps
 * it at round-off; a checkpoint whose pending events were deleted let
 * neighbours pass through each other (0.64 of a diameter). Pairs of
 * neighbouring cells and i's cell's big seeds, as ev_max_overlap_now;
 * -INF when there is no such pair. */
double ev_max_overlap_ahead(ev_sim *s)
{
    const int D = s->dim;
    double worst = -INFINITY;
    for (uint32_t i = 0; i < s->n; i++) {
        if (s->stuck[i]) continue;
        const double *pi = EV_P(s, i), ti = s->lk[i].ev.t_pair;
        double xi[3];
        for (int k = 0; k < D; k++) xi[k] = pi[k] + pi[D + k] * (s->now - pi[2 * D]);
        int32_t cc[3] = {0, 0, 0};
        cell_coords(s, D, s->lk[i].cell, cc);
        EV_FOR_NEIGHBOURS(s, D, cc, -1, 0, {
            if (j == i || (j < i && !s->stuck[j])) continue; /* a free pair once */
            const double T = s->stuck[j] ? ti : fmin(ti, s->lk[j].ev.t_pair);
            worst = fmax(worst, ahead_overlap(s, D, pi, xi, j, T));
        });
        uint32_t lo = 0, hi = 0;
        if (s->nbig) ev_big_list(s, s->lk[i].cell, &lo, &hi);
        for (uint32_t a = lo; a < hi; a++) worst = fmax(worst, ahead_overlap(s, D, pi, xi, s->bg_idx[a], ti));
    }
    return worst;
}
