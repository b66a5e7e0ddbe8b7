/*
 * ev_check.c - the checks of `pdla check` on an event-model file (see
 * pdla/event.h ev_check_file): what a run of the engine leaves must hold,
 * recomputed from the rows alone. The stuck rows: arrival times in order
 * within [0, clock], each parent a seed or an earlier stuck particle at
 * contact, indices distinct; every body (seeds, stuck,
 * free) inside the box and overlapping none (ev_check_geom.c); the counts
 * of rows, /results and /species equal; the free kinetic energy summed
 * again and the total conserved since the series' first row; the series in
 * order and ending at /results. The data come from cluster.h5
 * (ev_check_read.c) or from a loaded checkpoint, so both get the same
 * checks.
 */
#include <float.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ev_check.h"
#include "ev_internal.h"
#include "pdla/pdla.h"

#define NONE UINT32_MAX

/* The round-off of a position (see evc_tol), as ev_ckpt.c round_off_any:
 * the fastest speed, a stuck particle's when it stuck bounded by
 * sqrt(2 ke_stuck / lightest mass), times twice the clock. */
static double round_off(const evc_data *d)
{
    const int D = d->dim;
    double v2 = 0, mmin = INFINITY;
    for (size_t f = 0; f < d->nf; f++) {
        double w = 0;
        for (int k = 0; k < D; k++) w += d->fv[f * D + k] * d->fv[f * D + k];
        if (w > v2) v2 = w;
    }
    for (int k = 0; k < d->nsp; k++)
        if (d->kmass[k] > 0) mmin = fmin(mmin, d->kmass[k]);
    double v = sqrt(v2);
    if (d->res_ke_stuck > 0 && mmin < INFINITY) v = fmax(v, sqrt(2 * d->res_ke_stuck / mmin));
    return 64 * DBL_EPSILON * (fabs(d->L) + v * 2 * fabs(d->t));
}

/* /species: each kind's radius and density positive, its mass density x
 * volume as the engine computes it (bit for bit), sticky 0 or 1, and the
 * counts adding up to the particles. */
static void check_kinds(const evc_data *d, ev_check_report *r)
{
    uint64_t total = 0;
    int wrapped = 0;
    for (int k = 0; k < d->nsp; k++) {
        if (!(d->krad[k] > 0 && d->krad[k] < INFINITY))
            evc_fail(r, EV_CHECK_SPECIES, k, -1, d->krad[k], NAN, "kind %d: radius %.17g is not a positive number", k,
                     d->krad[k]);
        if (!(d->kdens[k] > 0 && d->kdens[k] < INFINITY))
            evc_fail(r, EV_CHECK_SPECIES, k, -1, d->kdens[k], NAN, "kind %d: density %.17g is not a positive number",
                     k, d->kdens[k]);
        const double m = d->kdens[k] * ev_particle_volume(d->dim, d->krad[k]);
        if (!(d->kmass[k] == m))
            evc_fail(r, EV_CHECK_SPECIES, k, -1, d->kmass[k], m, "kind %d: mass %.17g, not density x volume %.17g", k,
                     d->kmass[k], m);
        if (d->ksticky[k] > 1)
            evc_fail(r, EV_CHECK_SPECIES, k, -1, d->ksticky[k], 1, "kind %d: sticky %u is not 0 or 1", k,
                     (unsigned)d->ksticky[k]);
        total += d->kcount[k];
        wrapped |= total < d->kcount[k];
    }
    if (wrapped || total != d->particles)
        evc_fail(r, EV_CHECK_COUNTS, -1, -1, (double)total, (double)d->particles,
                 "the kinds' counts add up to %" PRIu64 "%s, not the %" PRIu64 " particles", total,
                 wrapped ? " (wrapped)" : "", d->particles);
}

/* Rows against /results and the particles. */
static void check_counts(const evc_data *d, ev_check_report *r)
{
    if (d->ns != d->res_stuck)
        evc_fail(r, EV_CHECK_COUNTS, -1, -1, (double)d->ns, (double)d->res_stuck,
                 "%zu stuck rows, /results stuck %" PRIu64, d->ns, d->res_stuck);
    if ((uint64_t)d->ns + d->nf != d->particles)
        evc_fail(r, EV_CHECK_COUNTS, -1, -1, (double)(d->ns + d->nf), (double)d->particles,
                 "%zu stuck and %zu free rows, not the %" PRIu64 " particles", d->ns, d->nf, d->particles);
}

/* The box side: positive, and the one the kinds and the packing give (the
 * engine's expression, ev_sim.c size_box: bit for bit). 1 when the side
 * can be used for the geometry. */
static int check_side(const evc_data *d, ev_check_report *r)
{
    if (!(d->L > 0 && d->L < INFINITY)) {
        evc_fail(r, EV_CHECK_BOX, -1, -1, d->L, NAN, "box side %.17g is not a positive number", d->L);
        return 0;
    }
    double vol = 0;
    for (int k = 0; k < d->nsp; k++) vol += (double)d->kcount[k] * ev_particle_volume(d->dim, d->krad[k]);
    const double L = pow(vol / d->packing, 1.0 / d->dim);
    if (!(L == d->L))
        evc_fail(r, EV_CHECK_BOX, -1, -1, d->L, L, "box side %.17g, not the %.17g the kinds and packing %.17g give",
                 d->L, L, d->packing);
    return 1;
}

/* The seeds as their parameters describe them: a --seeds file's, each of
 * positive radius; else the central seed (none for seed radius 0) of that
 * radius at the box's centre, exactly where the engine puts it. */
static void check_seeds(const evc_data *d, ev_check_report *r)
{
    for (size_t a = 0; a < d->nseeds; a++)
        if (!(d->seed_r[a] > 0))
            evc_fail(r, EV_CHECK_SEEDS, (int64_t)a, -1, d->seed_r[a], NAN, "seed %zu: radius %.17g is not positive", a,
                     d->seed_r[a]);
    if (d->seeds_param) return;
    const size_t want = d->seed_radius > 0;
    if (d->nseeds != want) {
        evc_fail(r, EV_CHECK_SEEDS, -1, -1, (double)d->nseeds, (double)want,
                 "%zu seeds, where seed radius %.17g gives %zu", d->nseeds, d->seed_radius, want);
        return;
    }
    if (!want) return;
    if (!(d->seed_r[0] == d->seed_radius))
        evc_fail(r, EV_CHECK_SEEDS, 0, -1, d->seed_r[0], d->seed_radius, "the seed's radius %.17g, not its parameter's %.17g",
                 d->seed_r[0], d->seed_radius);
    for (int k = 0; k < d->dim; k++)
        if (!(d->seed_x[k] == 0.5 * d->L))
            evc_fail(r, EV_CHECK_SEEDS, 0, k, d->seed_x[k], 0.5 * d->L,
                     "the seed's coordinate %d is %.17g, not the box's centre %.17g", k, d->seed_x[k], 0.5 * d->L);
}

/* Every centre and radius finite, and the free velocities. */
static void check_finite(const evc_data *d, const evc_bodies *b, ev_check_report *r)
{
    const int D = d->dim;
    char nm[80];
    for (size_t i = 0; i < b->n && !r->stopped; i++) {
        int ok = isfinite(b->r[i]);
        for (int k = 0; k < D; k++) ok &= isfinite(b->x[i * D + k]);
        if (ok) continue;
        evc_body_name(d, i, nm, sizeof nm);
        evc_fail(r, EV_CHECK_FINITE, (int64_t)i, -1, NAN, NAN, "%s: centre (%g, %g%s) or radius %g not finite", nm,
                 b->x[i * D], b->x[i * D + 1], D == 3 ? ", ..." : "", b->r[i]);
    }
    for (size_t f = 0; f < d->nf && !r->stopped; f++)
        for (int k = 0; k < D; k++)
            if (!isfinite(d->fv[f * D + k])) {
                evc_fail(r, EV_CHECK_FINITE, (int64_t)f, -1, d->fv[f * D + k], NAN,
                         "free row %zu: velocity component %d is %g", f, k, d->fv[f * D + k]);
                break;
            }
}

static int body_finite(const evc_bodies *b, size_t i, int D)
{
    int ok = isfinite(b->r[i]);
    for (int k = 0; k < D; k++) ok &= isfinite(b->x[i * (size_t)D + k]);
    return ok;
}

/* Between elastic walls every body lies wholly inside, its centre in
 * [r, L - r]; in a periodic box every centre in [0, L) (the free ones are
 * wrapped there when written, the stuck ones and seeds lie where they were
 * placed). Both to the tolerance of the radius (evc_tol): the round-off of
 * a position, which is also what puts a wrapped centre at L itself. */
static void check_box(const evc_data *d, const evc_bodies *b, double ro, ev_check_report *r)
{
    const int D = d->dim;
    char nm[80];
    for (size_t i = 0; i < b->n && !r->stopped; i++) {
        if (!body_finite(b, i, D)) continue;
        const double rad = b->r[i], tol = evc_tol(fabs(rad), ro);
        const double lo = d->periodic ? 0 : rad, hi = d->periodic ? d->L : d->L - rad;
        for (int k = 0; k < D; k++) {
            const double x = b->x[i * D + k];
            if (x >= lo - tol && x <= hi + tol) continue;
            evc_body_name(d, i, nm, sizeof nm);
            evc_fail(r, EV_CHECK_BOX, (int64_t)i, k, x, x < lo ? lo : hi,
                     "%s: coordinate %d is %.17g, outside [%.17g, %.17g] (%s, tolerance %.3g)", nm, k, x, lo, hi,
                     d->periodic ? "periodic" : "elastic walls", tol);
            break;
        }
    }
}

/* Stuck rows' indices: below the particles, each once; row_of[i] gets the
 * row of index i. (Which kind owns an index is not fixed: the start
 * renumbers the particles in the order of a grid of cells, ev_sim.c.) */
static void check_index(const evc_data *d, uint32_t *row_of, size_t nidx, ev_check_report *r)
{
    for (size_t a = 0; a < d->ns && !r->stopped; a++) {
        const uint32_t i = d->sidx[a];
        if (i >= nidx) {
            evc_fail(r, EV_CHECK_INDEX, (int64_t)a, i, i, (double)nidx,
                     "stuck row %zu: index %" PRIu32 " is not below the %zu particles", a, i, nidx);
            continue;
        }
        if (row_of[i] != NONE) {
            evc_fail(r, EV_CHECK_INDEX, (int64_t)a, row_of[i], i, NAN,
                     "stuck row %zu: index %" PRIu32 " is also stuck row %" PRIu32, a, i, row_of[i]);
            continue;
        }
        row_of[i] = (uint32_t)a;
    }
}

/* A row's kind in range and its radius the kind's, exactly (the engine
 * copies it); counted into per[] when in range. 0 when out of range. */
static int row_kind(const evc_data *d, const char *what, size_t a, int32_t k, double rad, uint64_t *per,
                    ev_check_report *r)
{
    if (k < 0 || k >= d->nsp) {
        evc_fail(r, EV_CHECK_SPECIES, (int64_t)a, k, k, d->nsp, "%s row %zu: kind %" PRId32 " is not one of the %d",
                 what, a, k, d->nsp);
        return 0;
    }
    if (!(rad == d->krad[k]))
        evc_fail(r, EV_CHECK_SPECIES, (int64_t)a, k, rad, d->krad[k],
                 "%s row %zu: radius %.17g, not its kind %" PRId32 "'s %.17g", what, a, rad, k, d->krad[k]);
    per[k]++;
    return 1;
}

/* Kinds of the stuck and free rows; a bath kind never sticks; the stuck
 * rows of each kind are /species stuck, and with the free ones its count. */
static void check_row_kinds(const evc_data *d, ev_check_report *r)
{
    uint64_t ps[EV_MAX_SPECIES] = {0}, pf[EV_MAX_SPECIES] = {0};
    for (size_t a = 0; a < d->ns && !r->stopped; a++)
        if (row_kind(d, "stuck", a, d->ssp[a], d->sr[a], ps, r) && !d->ksticky[d->ssp[a]])
            evc_fail(r, EV_CHECK_SPECIES, (int64_t)a, d->ssp[a], d->ssp[a], NAN,
                     "stuck row %zu: of kind %" PRId32 ", a bath kind, which never sticks", a, d->ssp[a]);
    for (size_t f = 0; f < d->nf && !r->stopped; f++) row_kind(d, "free", f, d->fsp[f], d->fr[f], pf, r);
    for (int k = 0; k < d->nsp && !r->stopped; k++) {
        if (ps[k] != d->kstuck[k])
            evc_fail(r, EV_CHECK_COUNTS, k, -1, (double)ps[k], (double)d->kstuck[k],
                     "kind %d: %" PRIu64 " stuck rows, /species stuck %" PRIu64, k, ps[k], d->kstuck[k]);
        if (ps[k] + pf[k] != d->kcount[k])
            evc_fail(r, EV_CHECK_COUNTS, k, -1, (double)(ps[k] + pf[k]), (double)d->kcount[k],
                     "kind %d: %" PRIu64 " stuck and %" PRIu64 " free rows, /species count %" PRIu64, k, ps[k], pf[k],
                     d->kcount[k]);
    }
}

/* Arrival times: finite, in [0, clock], never before the previous row's. */
static void check_arrival(const evc_data *d, ev_check_report *r)
{
    for (size_t a = 0; a < d->ns && !r->stopped; a++) {
        const double t = d->st[a], prev = a ? d->st[a - 1] : 0;
        if (!(t >= 0 && t <= d->t))
            evc_fail(r, EV_CHECK_ARRIVAL, (int64_t)a, -1, t, d->t, "stuck row %zu: arrival time %.17g is not in [0, %.17g]",
                     a, t, d->t);
        else if (a && !(t >= prev))
            evc_fail(r, EV_CHECK_ARRIVAL, (int64_t)a, (int64_t)a - 1, t, prev,
                     "stuck row %zu: arrival time %.17g is before row %zu's %.17g", a, t, a - 1, prev);
    }
}

/* Each parent: seed k (-1 - k) of the seeds there are, or a particle that
 * stuck in an earlier row. pbody[a] gets the parent's body number (seeds
 * first, then the stuck rows), or NONE. */
static void check_parents(const evc_data *d, const uint32_t *row_of, size_t nidx, uint32_t *pbody,
                          ev_check_report *r)
{
    for (size_t a = 0; a < d->ns && !r->stopped; a++) {
        const int64_t p = d->spar[a];
        pbody[a] = NONE;
        if (p < 0) {
            const uint64_t k = (uint64_t)(-1 - p); /* no overflow: -1 - INT64_MIN = INT64_MAX */
            if (k < d->nseeds) pbody[a] = (uint32_t)k;
            else
                evc_fail(r, EV_CHECK_PARENT, (int64_t)a, p, (double)p, NAN,
                         "stuck row %zu: parent %" PRId64 " names seed %" PRIu64 " of %zu", a, p, k, d->nseeds);
            continue;
        }
        const uint32_t row = (uint64_t)p < nidx ? row_of[p] : NONE;
        if (row == NONE)
            evc_fail(r, EV_CHECK_PARENT, (int64_t)a, p, (double)p, NAN,
                     "stuck row %zu: parent %" PRId64 " is no stuck particle", a, p);
        else if (row >= a)
            evc_fail(r, EV_CHECK_PARENT, (int64_t)a, row, (double)p, NAN,
                     "stuck row %zu: parent %" PRId64 " stuck %s (row %" PRIu32 ")", a, p,
                     row == a ? "as the row itself" : "later", row);
        else pbody[a] = (uint32_t)(d->nseeds + row);
    }
}

/* Each stuck particle at contact with its parent: the distance (nearest
 * image when periodic) r_i + r_parent to evc_tol of it, the round-off of
 * two positions. */
static void check_contacts(const evc_data *d, const evc_bodies *b, const uint32_t *pbody, double ro,
                           ev_check_report *r)
{
    const int D = d->dim;
    char nm[80];
    for (size_t a = 0; a < d->ns && !r->stopped; a++) {
        const size_t i = d->nseeds + a, p = pbody[a];
        if (p == NONE || !body_finite(b, i, D) || !body_finite(b, p, D)) continue;
        const double sig = b->r[i] + b->r[p];
        const double dist = sqrt(evc_dist2(b->x + i * D, b->x + p * D, D, d->periodic, d->L));
        const double off = fabs(dist - sig);
        if (off / sig > r->worst_contact) r->worst_contact = off / sig;
        if (off <= evc_tol(sig, 2 * ro)) continue;
        evc_body_name(d, p, nm, sizeof nm);
        evc_fail(r, EV_CHECK_CONTACT, (int64_t)a, (int64_t)p, dist, sig,
                 "stuck row %zu (particle %" PRIu32 ") is %.17g from its parent, %s, not at contact %.17g "
                 "(off by %.3g of it, tolerance %.3g)", a, d->sidx[a], dist, nm, sig, off / sig,
                 evc_tol(sig, 2 * ro) / sig);
    }
}

/* The free kinetic energy summed again, in the engine's order (free rows
 * follow the indices, ev_sim.c ke_free_sum: 0.5 m v^2 added row by row),
 * so it is the stored value bit for bit; a fused multiply-add may round
 * each term otherwise, and two sums of n positive terms each within
 * (n + d + 2) epsilon of the exact one differ by at most twice that. */
static void check_ke_free(const evc_data *d, ev_check_report *r)
{
    const int D = d->dim;
    double ke = 0;
    for (size_t f = 0; f < d->nf; f++) {
        const int32_t k = d->fsp[f];
        if (k < 0 || k >= d->nsp) continue; /* reported as a species failure */
        double v2 = 0;
        for (int q = 0; q < D; q++) v2 += d->fv[f * D + q] * d->fv[f * D + q];
        ke += 0.5 * d->kmass[k] * v2;
    }
    r->ke_free = ke;
    const double tol = 2.0 * ((double)d->nf + D + 2) * DBL_EPSILON * fabs(ke);
    if (!(fabs(ke - d->res_ke_free) <= tol))
        evc_fail(r, EV_CHECK_ENERGY, -1, -1, d->res_ke_free, ke,
                 "/results kinetic_energy_free %.17g, the free velocities give %.17g (relative %.3g, tolerance %.3g)",
                 d->res_ke_free, ke, (d->res_ke_free - ke) / ke, tol / fabs(ke));
}

/* The energy the stuck particles carried (kinetic_energy_stuck: each one's
 * kinetic energy when it stuck; their velocities are then zeroed, so it
 * cannot be summed again) is not negative, 0 without stuck particles, and
 * with the free energy makes the series' first (all-free) energy: every
 * collision and wall is elastic and the cluster an infinite mass. The
 * engine conserves it to 4e-14 over 4.5e5 collisions and 2e-12 over 1e8
 * (README), round-off that grows as the root of the collisions: tolerance
 * 1e-9 plus 64 epsilon times that root. */
static void check_ke_stuck(const evc_data *d, ev_check_report *r)
{
    r->ke_balance = NAN;
    if (!(d->res_ke_stuck >= 0 && d->res_ke_stuck < INFINITY) || (d->ns == 0 && d->res_ke_stuck != 0))
        evc_fail(r, EV_CHECK_ENERGY, -1, -1, d->res_ke_stuck, NAN,
                 "/results kinetic_energy_stuck %.17g with %zu stuck particles", d->res_ke_stuck, d->ns);
    if (!d->nser || d->ser_stuck[0] != 0 || !(d->ser_ke[0] > 0)) return;
    const double e0 = d->ser_ke[0];
    r->ke_balance = (d->res_ke_free + d->res_ke_stuck) / e0 - 1;
    const double tol = 1e-9 + 64 * DBL_EPSILON * sqrt((double)d->res_collisions + (double)d->ns);
    if (!(fabs(r->ke_balance) <= tol))
        evc_fail(r, EV_CHECK_ENERGY, -1, -1, d->res_ke_free + d->res_ke_stuck, e0,
                 "kinetic energy free + stuck %.17g, the series' first row %.17g (relative %.3g, tolerance %.3g)",
                 d->res_ke_free + d->res_ke_stuck, e0, r->ke_balance, tol);
}

/* Each row of the series: time finite, not back, within the clock; the
 * stuck count and collisions not back and within /results; the stuck
 * count between the arrivals before its time and those at or before it. */
static void check_series_rows(const evc_data *d, int arrival_ok, ev_check_report *r)
{
    size_t lo = 0, hi = 0;
    for (size_t k = 0; k < d->nser && !r->stopped; k++) {
        const double t = d->ser_t[k];
        if (!(t >= (k ? d->ser_t[k - 1] : 0) && t <= d->t))
            evc_fail(r, EV_CHECK_SERIES, (int64_t)k, -1, t, d->t,
                     "row %zu: time %.17g not in order or not in [0, %.17g]", k, t, d->t);
        if ((k && (d->ser_stuck[k] < d->ser_stuck[k - 1] || d->ser_coll[k] < d->ser_coll[k - 1])) ||
            d->ser_stuck[k] > d->res_stuck || d->ser_coll[k] > d->res_collisions)
            evc_fail(r, EV_CHECK_SERIES, (int64_t)k, -1, (double)d->ser_stuck[k], (double)d->res_stuck,
                     "row %zu: stuck %" PRIu64 " or collisions %" PRIu64 " back or past /results", k,
                     d->ser_stuck[k], d->ser_coll[k]);
        if (!(d->ser_ke[k] >= 0 && d->ser_ke[k] < INFINITY))
            evc_fail(r, EV_CHECK_SERIES, (int64_t)k, -1, d->ser_ke[k], NAN, "row %zu: kinetic energy %.17g", k,
                     d->ser_ke[k]);
        if (!arrival_ok || !isfinite(t)) continue;
        while (lo < d->ns && d->st[lo] < t) lo++;
        if (hi < lo) hi = lo;
        while (hi < d->ns && d->st[hi] <= t) hi++;
        if (d->ser_stuck[k] < lo || d->ser_stuck[k] > hi)
            evc_fail(r, EV_CHECK_SERIES, (int64_t)k, -1, (double)d->ser_stuck[k], (double)lo,
                     "row %zu: stuck %" PRIu64 " at time %.17g, where %zu particles arrived before and %zu by then", k,
                     d->ser_stuck[k], t, lo, hi);
    }
}

/* A run that reached its own stop pushes its last row at the end state
 * (ev_sim.c ev_run_series): the clock, stuck count, collisions and free
 * energy of /results, exactly (the row's energy is the same sum, test
 * event-row-cost). An interrupted run, or a checkpoint, may have an
 * interval open: its last row comes earlier. */
static void check_series(const evc_data *d, ev_check_report *r)
{
    r->series_rows = d->nser;
    if (!d->nser) {
        evc_fail(r, EV_CHECK_SERIES, -1, -1, 0, 1, "no rows (a run writes its start as row 0)");
        return;
    }
    check_series_rows(d, !r->item[EV_CHECK_ARRIVAL].count, r);
    const size_t k = d->nser - 1;
    r->series_at_end = d->ended;
    if (d->ended && !(d->ser_t[k] == d->t && d->ser_stuck[k] == d->res_stuck &&
                      d->ser_coll[k] == d->res_collisions && d->ser_ke[k] == d->res_ke_free))
        evc_fail(r, EV_CHECK_SERIES, (int64_t)k, -1, d->ser_t[k], d->t,
                 "the last row (time %.17g, stuck %" PRIu64 ", collisions %" PRIu64 ", energy %.17g) is not "
                 "/results (%.17g, %" PRIu64 ", %" PRIu64 ", %.17g) of a run that ended", d->ser_t[k],
                 d->ser_stuck[k], d->ser_coll[k], d->ser_ke[k], d->t, d->res_stuck, d->res_collisions,
                 d->res_ke_free);
}

static void bodies_free(evc_bodies *b)
{
    free(b->x);
    free(b->r);
}

/* The seeds, then the stuck rows, then the free rows. */
static int bodies_make(const evc_data *d, evc_bodies *b)
{
    const size_t D = (size_t)d->dim, n = d->nseeds + d->ns + d->nf;
    b->n = n;
    b->x = malloc((n ? n : 1) * D * sizeof *b->x);
    b->r = malloc((n ? n : 1) * sizeof *b->r);
    if (!b->x || !b->r) return -1;
    if (d->nseeds) memcpy(b->x, d->seed_x, d->nseeds * D * sizeof *b->x);
    if (d->ns) memcpy(b->x + d->nseeds * D, d->sx, d->ns * D * sizeof *b->x);
    if (d->nf) memcpy(b->x + (d->nseeds + d->ns) * D, d->fx, d->nf * D * sizeof *b->x);
    if (d->nseeds) memcpy(b->r, d->seed_r, d->nseeds * sizeof *b->r);
    if (d->ns) memcpy(b->r + d->nseeds, d->sr, d->ns * sizeof *b->r);
    if (d->nf) memcpy(b->r + d->nseeds + d->ns, d->fr, d->nf * sizeof *b->r);
    return 0;
}

static void report_init(const evc_data *d, ev_check_report *r)
{
    r->dim = d->dim;
    r->periodic = d->periodic;
    r->particles = d->particles;
    r->seeds = d->nseeds;
    r->stuck = d->ns;
    r->free_rows = d->nf;
    r->box = d->L;
    r->time = d->t;
    r->worst_overlap = -INFINITY;
    r->worst_contact = 0;
    r->ke_balance = NAN;
    for (int k = 0; k < EV_CHECK_NKINDS; k++) {
        r->item[k].a = r->item[k].b = -1;
        r->item[k].value = r->item[k].limit = NAN;
    }
}

/* The checks on the stuck and free rows' identities and the geometry. */
static int run_rows(const evc_data *d, const evc_bodies *b, uint32_t *row_of, size_t nidx, uint32_t *pbody,
                    ev_check_report *r)
{
    const double ro = r->round_off;
    check_finite(d, b, r);
    const int side_ok = check_side(d, r);
    if (side_ok) check_box(d, b, ro, r);
    check_index(d, row_of, nidx, r);
    check_row_kinds(d, r);
    check_arrival(d, r);
    check_parents(d, row_of, nidx, pbody, r);
    if (side_ok) check_contacts(d, b, pbody, ro, r);
    if (side_ok && !r->stopped && evc_overlaps(d, b, ro, r)) return -1;
    return 0;
}

int evc_run(const evc_data *d, ev_check_report *r, char *err, size_t errlen)
{
    report_init(d, r);
    r->round_off = round_off(d);
    /* indices are below the particles and the rows hold them all: the
     * smaller bounds the map without trusting a forged count */
    const size_t nidx = d->particles < d->ns + d->nf ? (size_t)d->particles : d->ns + d->nf;
    uint32_t *row_of = malloc((nidx ? nidx : 1) * sizeof *row_of);
    uint32_t *pbody = malloc((d->ns ? d->ns : 1) * sizeof *pbody);
    evc_bodies b = {0};
    int rc = !row_of || !pbody || bodies_make(d, &b) ? -1 : 0;
    if (!rc) {
        for (size_t i = 0; i < nidx; i++) row_of[i] = NONE;
        check_kinds(d, r);
        check_counts(d, r);
        check_seeds(d, r);
        rc = run_rows(d, &b, row_of, nidx, pbody, r);
    }
    if (!rc) {
        check_ke_free(d, r);
        check_ke_stuck(d, r);
        check_series(d, r);
        r->pass = !r->failures && !r->stopped;
    }
    free(row_of);
    free(pbody);
    bodies_free(&b);
    if (rc)
        return pdla_errorf(EV_CHECK_DAMAGED, err, errlen, "out of memory checking %zu particles and %zu seeds",
                           d->ns + d->nf, d->nseeds);
    return 0;
}
