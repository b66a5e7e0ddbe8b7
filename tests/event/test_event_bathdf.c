/*
 * test_event_bathdf.c - issue 15's physics record as a test: a dilute
 * sticky kind in a dense bath that never sticks (STICKY 0) grows a more
 * open, DLA-like cluster than the same sticky particles without the bath
 * (runs/event/README.md, "A bath that never sticks"; records
 * runs/event/bath-2d.txt, bath-trend-2d.txt, bath-test.txt).
 *
 *   test_event_bathdf DIM NSTICKY NBATH PACKING STUCK SEEDS R_LO R_HI MARGIN RATIO [BATH_STICKY]
 *
 * For seeds 1..SEEDS: the bath run (NSTICKY sticky + NBATH bath particles,
 * radius 0.5, density 1, total packing PACKING, elastic walls, p = 1,
 * Maxwell-Boltzmann kT = 1, stopped at STUCK stuck) and its control (the
 * NSTICKY sticky ones alone in the same box: packing PACKING * NSTICKY /
 * (NSTICKY + NBATH), same seed, same stop). D_f of each cluster is the
 * mass-radius slope around the seed over the fixed window [R_LO, R_HI]
 * (least squares of log M(r) on 16 log-spaced r, M the stuck centres and
 * the seed within r: runs/event/window.c's estimate). Passes when
 *   - every cluster reaches beyond R_HI (else the window is not inside it),
 *   - mean D_f(control) - mean D_f(bath) > MARGIN,
 *   - mean R_max(bath) / mean R_max(control) > RATIO, R_max the farthest
 *     stuck centre from the seed: the same mass spread wider, a less noisy
 *     sign of an open cluster than a slope over a short window.
 * MARGIN and RATIO come from the measured spread (meson.build states it). With
 * NBATH 0 the two runs are the same, and with BATH_STICKY 1 (the "bath"
 * kind sticks too: a dense sticky gas) the cluster is compact: the test
 * must fail both ways (the checks that it can: runs/event/bath-test.txt).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pdla/event.h"
#include "check.h"

static int cmp_d(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Centres within rr of the seed (r sorted). */
static double mass_within(const double *r, size_t n, double rr)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (r[mid] <= rr) lo = mid + 1;
        else hi = mid;
    }
    return (double)lo;
}

/* Grow one cluster; its windowed D_f, *rmax the farthest stuck centre. NaN
 * when the run fails. */
static double grow_df(int dim, const char *species, double packing, uint64_t stuck, uint64_t seed,
                      double r0, double r1, double *rmax)
{
    ev_params q;
    ev_params_default(&q);
    q.dim = dim;
    snprintf(q.species, sizeof q.species, "%s", species);
    q.packing = packing;
    q.walls = EV_WALLS_ELASTIC;
    q.seed = seed;
    q.seed_radius = 0.5;
    q.stick_p = 1;
    q.t_max = 0;
    q.max_stuck = stuck;
    char err[256];
    ev_sim *s = ev_create(&q, err, sizeof err);
    CHECK(s != NULL, "%s packing %g: %s", species, packing, err);
    *rmax = 0;
    if (!s) return NAN;
    const int why = ev_run(s, NULL);
    CHECK(why == EV_STOP_STUCK, "%s seed %llu: stopped by %s, not at %llu stuck", species,
          (unsigned long long)seed, ev_stop_name(why), (unsigned long long)stuck);
    const uint32_t *idx;
    const double *ts;
    const size_t n = ev_stuck_list(s, &idx, &ts);
    double *r = malloc((n + 1) * sizeof *r);
    if (!r) abort();
    const double *c = ev_pos(s, ev_count(s)); /* the seed */
    r[0] = 0;
    for (size_t k = 0; k < n; k++) {
        const double *p = ev_pos(s, idx[k]);
        double s2 = 0;
        for (int d = 0; d < dim; d++) s2 += (p[d] - c[d]) * (p[d] - c[d]);
        r[k + 1] = sqrt(s2);
    }
    ev_free(s);
    qsort(r, n + 1, sizeof *r, cmp_d);
    *rmax = r[n];
    const int m = 16;
    double sl = 0, sll = 0, sy = 0, sly = 0;
    for (int j = 0; j < m; j++) {
        const double rr = r0 * pow(r1 / r0, (double)j / (m - 1));
        const double l = log(rr), y = log(fmax(mass_within(r, n + 1, rr), 1));
        sl += l, sll += l * l, sy += y, sly += l * y;
    }
    free(r);
    return (m * sly - sl * sy) / (m * sll - sl * sl);
}

int main(int argc, char **argv)
{
    if (argc != 11 && argc != 12) {
        fprintf(stderr, "usage: test_event_bathdf DIM NSTICKY NBATH PACKING STUCK SEEDS R_LO R_HI MARGIN "
                        "RATIO [BATH_STICKY]\n");
        return 2;
    }
    const int dim = atoi(argv[1]), seeds = atoi(argv[6]);
    const unsigned long long ns = strtoull(argv[2], NULL, 10), nb = strtoull(argv[3], NULL, 10);
    const double eta = atof(argv[4]), r0 = atof(argv[7]), r1 = atof(argv[8]), margin = atof(argv[9]);
    const uint64_t stuck = strtoull(argv[5], NULL, 10);
    const double ratio = atof(argv[10]);
    const int bsticky = argc == 12 ? atoi(argv[11]) : 0;
    if ((dim != 2 && dim != 3) || ns == 0 || seeds < 2 || !(eta > 0) || !(r0 > 0 && r1 > r0) ||
        (bsticky != 0 && bsticky != 1)) {
        fprintf(stderr, "test_event_bathdf: bad arguments\n");
        return 2;
    }
    char sb[128], sc[64];
    if (nb) snprintf(sb, sizeof sb, "%llu:0.5:1,%llu:0.5:1:%d", ns, nb, bsticky);
    else snprintf(sb, sizeof sb, "%llu:0.5:1", ns);
    snprintf(sc, sizeof sc, "%llu:0.5:1", ns);
    const double eta_c = eta * (double)ns / (double)(ns + nb);
    double mb = 0, mc = 0, mb2 = 0, mc2 = 0, rbm = 0, rcm = 0;
    for (int k = 1; k <= seeds; k++) {
        double rb, rc;
        const double db = grow_df(dim, sb, eta, stuck, (uint64_t)k, r0, r1, &rb);
        const double dc = grow_df(dim, sc, eta_c, stuck, (uint64_t)k, r0, r1, &rc);
        fprintf(stderr, "seed %d: bath D_f[%g,%g] %.4f (R_max %.1f), control %.4f (R_max %.1f)\n", k, r0, r1,
                db, rb, dc, rc);
        CHECK(rb > r1 && rc > r1, "seed %d: R_max %.1f / %.1f inside the window's end %g", k, rb, rc, r1);
        mb += db / seeds, mc += dc / seeds, mb2 += db * db / seeds, mc2 += dc * dc / seeds;
        rbm += rb / seeds, rcm += rc / seeds;
    }
    const double sdb = sqrt(fmax(mb2 - mb * mb, 0) * seeds / (seeds - 1));
    const double sdc = sqrt(fmax(mc2 - mc * mc, 0) * seeds / (seeds - 1));
    fprintf(stderr, "%dD %llu sticky + %llu bath, packing %g, %llu stuck, %d seeds: D_f bath %.4f (sd %.4f), "
            "control %.4f (sd %.4f), difference %.4f (margin %g); R_max bath %.2f, control %.2f, ratio %.3f "
            "(bound %g)\n", dim, ns, nb, eta, (unsigned long long)stuck, seeds, mb, sdb, mc, sdc, mc - mb, margin,
            rbm, rcm, rbm / rcm, ratio);
    CHECK(mc - mb > margin, "control - bath D_f %.4f, not above %g: the bath did not open the cluster", mc - mb,
          margin);
    CHECK(rbm / rcm > ratio, "R_max bath / control %.3f, not above %g: the bath did not spread the cluster",
          rbm / rcm, ratio);
    return check_finish();
}
