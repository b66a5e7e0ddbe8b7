/*
 * ev_check_util.c - what the checks of an event-model file share
 * (ev_check.h): counting a failure, the tolerance, the distance by the
 * nearest image, the names of bodies and of the kinds of check.
 */
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#include "ev_check.h"

static const char *const kind_names[EV_CHECK_NKINDS] = {
    "finite", "box", "overlap", "contact", "parent", "arrival",
    "index", "species", "counts", "energy", "series", "seeds"};

const char *ev_check_kind_name(int kind) { return kind >= 0 && kind < EV_CHECK_NKINDS ? kind_names[kind] : "?"; }

void evc_fail(ev_check_report *r, int kind, int64_t a, int64_t b, double value, double limit, const char *fmt, ...)
{
    if (r->stopped) return;
    ev_check_item *it = &r->item[kind];
    if (!it->count++) {
        it->a = a;
        it->b = b;
        it->value = value;
        it->limit = limit;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(it->first, sizeof it->first, fmt, ap);
        va_end(ap);
    }
    if (++r->failures >= EV_CHECK_MAX_FAILURES) r->stopped = 1;
}

/* EV_CHECK_TOL: the engine keeps every overlap at a collision and every
 * stuck particle's gap to its parent under 1e-10 of the contact distance
 * for particles of similar size (README "Checked in the fast suite",
 * tests/event TOL). Beyond that a position x0 + v (t - t0), and a contact
 * found at a time t, carry the round-off of their doubles, about epsilon
 * of the box side and of |v| t: a light, fast kind showed 7e-9 of its small
 * contact distance at t = 230 (README), which that part covers. ro is that
 * round-off as the checkpoint loader reckons it (ev_ckpt.c round_off_any:
 * 64 epsilon of the side and of the fastest speed times twice the clock),
 * capped as there at 1e-2 of the length, so that a forged speed or clock
 * cannot widen a check without bound. The loader's base, 1e-6, is slack
 * for pending events predicted from states that have moved since; the
 * positions of one instant need none. A stuck particle's speed when it
 * stuck is gone from the file and bounded by sqrt(2 ke_stuck / lightest
 * mass): after long runs with many stuck particles ro is loose (1e-7 of a
 * diameter at t = 2e4 for 2000 stuck disks, where the worst contact seen
 * is 2e-12); the report prints it. Not covered, and so failed: in a
 * periodic box the engine solves a contact time from the older stored
 * state, whose position is many box sides of flight back after a long free
 * flight, and loses about epsilon x flight^2 / contact distance (3.3e-7 of
 * it in a dilute 2D run, test tools-check-event engine_faults): beyond the
 * 1e-10 the engine states, so a fault of the engine, not of this check. */
double evc_tol(double len, double ro) { return EV_CHECK_TOL * len + fmin(ro, 1e-2 * len); }

double evc_dist2(const double *a, const double *b, int dim, int periodic, double L)
{
    double rr = 0;
    for (int k = 0; k < dim; k++) {
        double e = b[k] - a[k];
        if (periodic) {
            /* the engine's one correction (ev_dist2) for centres in the box;
             * any other distance is wrapped whole */
            if (e > 0.5 * L) e -= L;
            else if (e < -0.5 * L) e += L;
            if (fabs(e) > 0.5 * L) e -= L * nearbyint(e / L);
        }
        rr += e * e;
    }
    return rr;
}

void evc_body_name(const evc_data *d, size_t b, char *buf, size_t len)
{
    if (b < d->nseeds) snprintf(buf, len, "seed %zu", b);
    else if (b < d->nseeds + d->ns)
        snprintf(buf, len, "stuck row %zu (particle %" PRIu32 ")", b - d->nseeds, d->sidx[b - d->nseeds]);
    else snprintf(buf, len, "free row %zu", b - d->nseeds - d->ns);
}

