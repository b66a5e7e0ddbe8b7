/*
 * test_midwalk.c - stops and checkpoints inside a serial walk (grow.c
 * serial_walk). Progress used to be called only between particles, so a
 * walk that did not end held off a signal for ever; now it is called
 * between slices of a walk as well. That must not change the cluster:
 *  - stopped inside walks hundreds of times (slices of 16 steps, progress
 *    at each, a stop at every 5th call) and grown on in the same engine,
 *    the cluster equals a straight run's, bit for bit;
 *  - a checkpoint written while a walk is stopped (it holds the stream the
 *    walk began with), loaded into a new engine and grown on, equals it too.
 * The same for reference walkers stopped every 37 particles (they were
 * dropped at a stop). 2D and 3D. Mutations this catches: the stream not rewound for the call
 * (the checkpoint case), the walk not continued after a stop (the first).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "engine.h"
#include "pdla/pdla.h"

typedef struct {
    int32_t (*x)[3];
    size_t n, cap;
    int dim;
} pts;

/* xyz: n x dim coordinates */
static int grab(const int32_t *xyz, size_t n, void *user)
{
    pts *p = user;
    if (p->n + n > p->cap) {
        p->cap = (p->n + n) * 2;
        p->x = realloc(p->x, p->cap * sizeof *p->x);
    }
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) p->x[p->n + i][a] = a < p->dim ? xyz[(size_t)p->dim * i + (size_t)a] : 0;
    p->n += n;
    return 0;
}

static pts positions(const pdla_engine *e)
{
    pts p = {NULL, 0, 0, pdla_engine_params(e)->dim};
    pdla_engine_visit(e, grab, &p);
    return p;
}

typedef struct {
    uint64_t calls, stop_every, stop_at, stopped_mid;
    pdla_engine *e;
} probe;

static int on_progress(const pdla_engine *e, void *user)
{
    probe *pr = user;
    (void)e;
    pr->calls++;
    if (pr->stop_at && pr->calls == pr->stop_at) return 1;
    return pr->stop_every && pr->calls % pr->stop_every == 0;
}

static pdla_params params_of(int dim)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.target = dim == 2 ? 3000 : 1500;
    p.seed = 5;
    return p;
}

static int same(const pts *a, const pts *b)
{
    return a->n == b->n && !memcmp(a->x, b->x, a->n * sizeof a->x[0]);
}

static void midwalk_case(int dim, const char *dir)
{
    const pdla_params P = params_of(dim);
    char err[512];
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    CHECK(pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "straight: %s", err);
    pts straight = positions(e);
    pdla_engine_destroy(e);

    /* stops inside walks, grown on in the same engine */
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    e->test_slice_steps = 16;
    e->test_poll_every_slice = 1;
    probe pr = {0, 5, 0, 0, e};
    int rc, stops = 0;
    while ((rc = pdla_engine_grow(e, P.target, on_progress, 1000, &pr, err, sizeof err)) == PDLA_ESTOPPED) {
        stops++;
        pr.stopped_mid += e->walk_paused != 0;
    }
    pts paused = positions(e);
    CHECK(rc == PDLA_OK && pr.stopped_mid > 100, "%dD: rc %d, %d stops, %llu inside a walk", dim, rc, stops,
          (unsigned long long)pr.stopped_mid);
    CHECK(same(&paused, &straight), "%dD: stopped inside walks %llu times: not the straight run's cluster", dim,
          (unsigned long long)pr.stopped_mid);
    pdla_engine_destroy(e);

    /* a checkpoint written while a walk is stopped, loaded and grown on */
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    e->test_slice_steps = 16;
    e->test_poll_every_slice = 1;
    probe one = {0, 0, 0, 0, e};
    int mid = 0;
    for (int k = 0; k < 50 && !mid; k++) { /* stop until a stop falls inside a walk */
        one.stop_at = one.calls + 997;
        rc = pdla_engine_grow(e, P.target, on_progress, 1000, &one, err, sizeof err);
        mid = rc == PDLA_ESTOPPED && e->walk_paused;
    }
    CHECK(mid, "%dD: no stop inside a walk", dim);
    const uint64_t at = pdla_engine_count(e);
    const pdla_checkpoint_opts co = {.command_line = "test_midwalk"};
    CHECK(pdla_checkpoint_write(e, dir, &co, NULL, err, sizeof err) == PDLA_OK, "write: %s", err);
    pdla_engine_destroy(e);
    char path[600];
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    e = NULL;
    CHECK(pdla_checkpoint_load(&e, path, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "load: %s", err);
    if (e) {
        CHECK(pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "grow on: %s", err);
        pts resumed = positions(e);
        CHECK(same(&resumed, &straight), "%dD: checkpoint written inside a walk at %llu particles, resumed: not the "
              "straight run's cluster", dim, (unsigned long long)at);
        free(resumed.x);
        pdla_engine_destroy(e);
    }
    free(paused.x);
    free(straight.x);
}

/* Reference walkers (--reference-walkers): a stop (a checkpoint pauses
 * growth by stopping it) dropped the walkers in flight and launched new
 * ones from new streams, so periodic checkpoints changed the cluster. */
static void reference_case(int dim)
{
    pdla_params P = params_of(dim);
    P.reference_walkers = 3;
    P.serial_until = 500;
    char err[512];
    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    CHECK(pdla_engine_grow(e, P.target, NULL, 0, NULL, err, sizeof err) == PDLA_OK, "straight: %s", err);
    pts straight = positions(e);
    pdla_engine_destroy(e);
    CHECK(pdla_engine_create(&e, &P, err, sizeof err) == PDLA_OK, "create: %s", err);
    probe pr = {0, 1, 0, 0, e}; /* stop at every call: every 37 particles */
    int rc, stops = 0;
    while ((rc = pdla_engine_grow(e, P.target, on_progress, 37, &pr, err, sizeof err)) == PDLA_ESTOPPED) stops++;
    pts paused = positions(e);
    CHECK(rc == PDLA_OK && stops > 30, "%dD reference: rc %d, %d stops", dim, rc, stops);
    CHECK(same(&paused, &straight), "%dD reference walkers stopped %d times: not the straight run's cluster", dim,
          stops);
    pdla_engine_destroy(e);
    free(paused.x);
    free(straight.x);
}

int main(void)
{
    char tmpl[] = "/tmp/pdla-midwalk-XXXXXX";
    const char *dir = mkdtemp(tmpl);
    CHECK(dir != NULL, "mkdtemp");
    if (!dir) return check_finish();
    for (int dim = 2; dim <= 3; dim++) {
        midwalk_case(dim, dir);
        char cmd[700];
        snprintf(cmd, sizeof cmd, "rm -f %s/checkpoint*.h5", dir);
        CHECK(system(cmd) == 0, "%s", cmd);
        reference_case(dim);
    }
    rmdir(dir);
    return check_finish();
}
