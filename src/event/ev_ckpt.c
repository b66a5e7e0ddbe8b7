/*
 * ev_ckpt.c - checkpoints of the event model (see pdla/event.h).
 *
 * DIR/checkpoint.h5:
 *   /            format = "pdla-event-checkpoint", format_version, model,
 *                dim, particles, ntot, schedule_every_seconds (the
 *                --checkpoint-every a bare --resume keeps; since session
 *                27, optional on load)
 *   parameters   the parameter table as "name=value" lines (values as
 *                pdla_param_format writes them exact: doubles in %.17g)
 *   /state       ps (x, v, t_i, r per particle, as stored: lazy local
 *                times included), species, stuck, count, parent, cell,
 *                the pending events (t_pair, t_cell, partner, pcount,
 *                kind, cell_what), stuck_idx, stuck_t, counters (u64),
 *                reals (f64), rng
 *   /series      the rows so far
 * Which kinds stick (STICKY in --species, default 1) is part of the
 * species parameter, so a checkpoint written before bath kinds existed
 * (no STICKY fields) loads as all sticky, as it ran (tests/event: resume).
 * Everything that decides the next event is stored as it is in memory, and
 * the queue is rebuilt from the pending events: its order is the strict
 * (time, index) order, so the rebuilt queue pops the same events. The cell
 * lists are rebuilt from `cell` (not from the positions: a particle on a
 * cell face by round-off must stay in the cell its crossing events put it
 * in); their order within a cell does not matter (ties between candidate
 * partners are broken by index, see scan_pairs).
 * Crash safety as in src/dla/checkpoint.c: a temporary file in DIR, synced,
 * then the old checkpoint is kept as checkpoint.prev.h5 and the temporary
 * renamed over checkpoint.h5, then the directory synced.
 */
#include <errno.h>
#include <inttypes.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ev_internal.h"
#include "h5util.h"
#include "pdla/h5check.h"
#include "provenance.h"

#define CK_FORMAT "pdla-event-checkpoint"
/* 2: the cell grid changed (finer cells, event4); a version 1 state names
 * cells of another grid, so it is refused. 3: cells no larger than the
 * largest contact distance when a seed is larger than the particles
 * (ev_sim.c size_box); a version 2 state is read when its grid is the same
 * (always without such a seed), else refused. 4: a seed larger than the
 * particles leaves the cell lists (ev_big.c), the cells are sized by the
 * particles alone; a version 2 or 3 state is read when its grid is the
 * same (always without such a seed), else refused. */
#define CK_VERSION 4
enum { CK_NCOUNT = 13, CK_NREAL = 8 };

static int wds(const h5u_writer *w, hid_t g, const char *name, hid_t ftype, hid_t mtype,
               size_t n, const void *data)
{
    hid_t space = H5I_INVALID_HID;
    const hid_t d = h5u_dataset(w, g, name, ftype, 1, n, 1, 1 << 16, &space);
    if (d < 0) return -1;
    int rc = 0;
    if (n > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
        rc = h5u_fail(w, "write dataset %s", name);
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

static char *params_text(const ev_params *p)
{
    size_t cap = 4096, len = 0;
    char *t = malloc(cap);
    if (!t) return NULL;
    t[0] = '\0';
    size_t np;
    const pdla_param_desc *pt = ev_param_table(&np);
    for (size_t k = 0; k < np; k++) {
        char v[300];
        pdla_param_format(&pt[k], p, 1, v, sizeof v);
        const size_t need = strlen(pt[k].name) + strlen(v) + 3;
        if (len + need >= cap) {
            cap = 2 * cap + need;
            char *u = realloc(t, cap);
            if (!u) {
                free(t);
                return NULL;
            }
            t = u;
        }
        len += (size_t)snprintf(t + len, cap - len, "%s=%s\n", pt[k].name, v);
    }
    return t;
}

static int write_state(const h5u_writer *w, hid_t file, const ev_sim *s)
{
    const uint32_t N = s->ntot;
    const hid_t g = h5u_group(w, file, "state");
    if (g < 0) return -1;
    double *tp = malloc((N ? N : 1) * sizeof *tp), *tc = malloc((N ? N : 1) * sizeof *tc);
    uint32_t *pa = malloc((N ? N : 1) * sizeof *pa), *pc = malloc((N ? N : 1) * sizeof *pc);
    uint32_t *co = malloc((N ? N : 1) * sizeof *co), *ce = malloc((N ? N : 1) * sizeof *ce);
    int8_t *kd = malloc(N ? N : 1), *cw = malloc(N ? N : 1);
    int rc = 0;
    if (!tp || !tc || !pa || !pc || !co || !ce || !kd || !cw) rc = h5u_fail_msg(w, "out of memory writing /state");
    for (uint32_t i = 0; !rc && i < N; i++) {
        co[i] = s->lk[i].count;
        ce[i] = s->lk[i].cell;
        tp[i] = s->lk[i].ev.t_pair;
        tc[i] = s->lk[i].ev.t_cell;
        pa[i] = s->lk[i].ev.partner;
        pc[i] = s->lk[i].ev.pcount;
        kd[i] = s->lk[i].ev.kind;
        cw[i] = s->lk[i].ev.cell_what;
    }
    const uint64_t cnt[CK_NCOUNT] = {s->events, s->collisions, s->wall_hits, s->sticks,
                                     s->cell_crossings, s->invalid, s->nstuck,
                                     (uint64_t)s->started, (uint64_t)s->iv_open,
                                     s->rng.s[0], s->rng.s[1], s->rng.s[2], s->rng.s[3]};
    const double re[CK_NREAL] = {s->now, s->series_dt, s->ke_stuck, s->virial,
                                 s->wall_impulse, s->max_overlap, s->iv_t0, s->iv_v0};
    const hid_t F = H5T_IEEE_F64LE, U = H5T_STD_U32LE;
    if (!rc) rc = wds(w, g, "ps", F, H5T_NATIVE_DOUBLE, (size_t)N * (size_t)(2 * s->dim + 2), s->ps);
    if (!rc) rc = wds(w, g, "species", H5T_STD_U8LE, H5T_NATIVE_UINT8, N, s->species);
    if (!rc) rc = wds(w, g, "stuck", H5T_STD_U8LE, H5T_NATIVE_UINT8, N, s->stuck);
    if (!rc) rc = wds(w, g, "count", U, H5T_NATIVE_UINT32, N, co);
    if (!rc) rc = wds(w, g, "parent", U, H5T_NATIVE_UINT32, N, s->parent);
    if (!rc) rc = wds(w, g, "cell", U, H5T_NATIVE_UINT32, N, ce);
    if (!rc) rc = wds(w, g, "t_pair", F, H5T_NATIVE_DOUBLE, N, tp);
    if (!rc) rc = wds(w, g, "t_cell", F, H5T_NATIVE_DOUBLE, N, tc);
    if (!rc) rc = wds(w, g, "partner", U, H5T_NATIVE_UINT32, N, pa);
    if (!rc) rc = wds(w, g, "pcount", U, H5T_NATIVE_UINT32, N, pc);
    if (!rc) rc = wds(w, g, "kind", H5T_STD_I8LE, H5T_NATIVE_INT8, N, kd);
    if (!rc) rc = wds(w, g, "cell_what", H5T_STD_I8LE, H5T_NATIVE_INT8, N, cw);
    if (!rc) rc = wds(w, g, "stuck_idx", U, H5T_NATIVE_UINT32, s->nstuck, s->stuck_idx);
    if (!rc) rc = wds(w, g, "stuck_t", F, H5T_NATIVE_DOUBLE, s->nstuck, s->stuck_t);
    if (!rc) rc = wds(w, g, "counters", H5T_STD_U64LE, H5T_NATIVE_UINT64, CK_NCOUNT, cnt);
    if (!rc) rc = wds(w, g, "reals", F, H5T_NATIVE_DOUBLE, CK_NREAL, re);
    free(tp), free(tc), free(pa), free(pc), free(co), free(ce), free(kd), free(cw);
    return h5u_close(w, rc, g, H5Gclose, "/state");
}

static int write_series(const h5u_writer *w, hid_t file, const ev_series *ser)
{
    const hid_t g = h5u_group(w, file, "series");
    if (g < 0) return -1;
    const size_t n = ser->n;
    int rc = wds(w, g, "time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, n, ser->t);
    if (!rc) rc = wds(w, g, "kinetic_energy", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, n, ser->ke);
    if (!rc) rc = wds(w, g, "pressure", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, n, ser->pressure);
    if (!rc) rc = wds(w, g, "stuck", H5T_STD_U64LE, H5T_NATIVE_UINT64, n, ser->stuck);
    if (!rc) rc = wds(w, g, "collisions", H5T_STD_U64LE, H5T_NATIVE_UINT64, n, ser->collisions);
    return h5u_close(w, rc, g, H5Gclose, "/series");
}

static int write_ckpt(const h5u_writer *w, const char *tmp, const ev_sim *s,
                      const ev_series *ser, const char *cmdline)
{
    const hid_t file = h5u_create_file(w, tmp);
    if (file < 0) return -1;
    pdla_provenance pv;
    (void)prov_collect(&pv);
    char *pt = params_text(&s->par);
    int rc = pt ? 0 : h5u_fail_msg(w, "out of memory");
    if (!rc) rc = h5u_attr_str(w, file, "format", CK_FORMAT);
    if (!rc) rc = h5u_attr_int(w, file, "format_version", CK_VERSION);
    if (!rc) rc = h5u_attr_str(w, file, "model", "event");
    if (!rc) rc = h5u_attr_int(w, file, "dim", s->dim);
    if (!rc) rc = h5u_attr_u64(w, file, "particles", s->n);
    if (!rc) rc = h5u_attr_u64(w, file, "ntot", s->ntot);
    if (!rc) rc = h5u_attr_f64(w, file, "schedule_every_seconds", s->ck_every);
    if (!rc) rc = wds(w, file, "parameters", H5T_STD_U8LE, H5T_NATIVE_UINT8, strlen(pt), pt);
    if (!rc) rc = write_state(w, file, s);
    if (!rc) rc = write_series(w, file, ser);
    if (!rc) rc = h5u_write_code(w, file, &pv, cmdline);
    free(pt);
    if (rc) h5u_divert_writes(file);
    return h5u_close(w, rc, file, H5Fclose, tmp);
}

int ev_checkpoint_write(const ev_sim *s, const ev_series *ser, const char *dir,
                        const char *cmdline, char *err, size_t errlen)
{
    char path[4200], prev[4200], tmp[4200];
    if (strlen(dir) > 4000) {
        snprintf(err, errlen, "checkpoint: directory name too long");
        return -1;
    }
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    snprintf(prev, sizeof prev, "%s/checkpoint.prev.h5", dir);
    snprintf(tmp, sizeof tmp, "%s/.checkpoint.h5.tmp.%ld", dir, (long)getpid());
    const h5u_writer w = {path, err, errlen};
    h5u_quiet q;
    if (h5u_silence(&q)) {
        snprintf(err, errlen, "checkpoint: cannot silence HDF5");
        return -1;
    }
    int rc = write_ckpt(&w, tmp, s, ser, cmdline);
    if (!rc && h5u_trim_and_sync(tmp) != 0)
        rc = h5u_fail_msg(&w, "cannot sync %s: %s", tmp, strerror(errno));
    /* Keep the previous generation: every name always holds a whole file
     * (without hard links, a moment with only checkpoint.prev.h5). */
    if (!rc && unlink(prev) != 0 && errno != ENOENT)
        rc = h5u_fail_msg(&w, "cannot remove %s: %s", prev, strerror(errno));
    if (!rc && link(path, prev) != 0 && errno != ENOENT && rename(path, prev) != 0 &&
        errno != ENOENT)
        rc = h5u_fail_msg(&w, "cannot keep %s as %s: %s", path, prev, strerror(errno));
    if (!rc && rename(tmp, path) != 0)
        rc = h5u_fail_msg(&w, "cannot rename %s to %s: %s", tmp, path, strerror(errno));
    if (!rc && h5u_fsync_dir(dir) != 0)
        rc = h5u_fail_msg(&w, "written, but cannot sync directory %s: %s", dir, strerror(errno));
    if (rc) unlink(tmp);
    if (h5u_restore(&q) < 0 && !rc) rc = h5u_fail_msg(&w, "written, but %s", "cannot restore the HDF5 error handler");
    if (rc) h5u_one_line(err);
    return rc ? -1 : 0;
}

/* ---- loading ------------------------------------------------------------- */

typedef struct rd {
    hid_t file;
    const char *path;
    char *err;
    size_t errlen;
} rd;

static int rfail(const rd *r, const char *fmt, const char *a)
{
    char m[512];
    snprintf(m, sizeof m, fmt, a);
    snprintf(r->err, r->errlen, "checkpoint %s: %s", r->path, m);
    return -1;
}

/* Read dataset `name` of exactly n elements of type t into buf (n == 0: must
 * be empty), through the checked reader (pdla/h5check.h): its type and size
 * are checked, and whether the file stores what it declares, before it is
 * read. */
static int rds(const rd *r, const char *name, pdla_h5_type t, size_t n, void *buf)
{
    pdla_h5_dset d;
    if (pdla_h5_dset_open(r->file, name, &d) < 0)
        return rfail(r, "no dataset %s (not an event checkpoint, or damaged)", name);
    int rc = 0;
    if (d.rank != 1 || !pdla_h5_dset_is(&d, t) || d.elems != n)
        rc = rfail(r, "dataset %s has the wrong type or size", name);
    else if (pdla_h5_dset_stored(&d, d.size) != PDLA_H5_STORED)
        rc = rfail(r, "dataset %s declares more than the file stores (damaged)", name);
    else if (pdla_h5_dset_read(&d, t, 0, n, buf) < 0)
        rc = rfail(r, "cannot read %s (damaged: checksum or I/O error)", name);
    if (pdla_h5_dset_close(&d) < 0 && !rc) rc = rfail(r, "cannot close dataset %s", name);
    return rc;
}

/* Elements of dataset name; -1 when it is missing, not rank 1 or declares
 * more than the file stores (a forged length must not size an allocation). */
static hssize_t rlen(const rd *r, const char *name)
{
    pdla_h5_dset d;
    if (pdla_h5_dset_open(r->file, name, &d) < 0) return -1;
    const hssize_t np = d.rank == 1 && pdla_h5_dset_stored(&d, d.size) == PDLA_H5_STORED ? (hssize_t)d.elems : -1;
    return pdla_h5_dset_close(&d) < 0 ? -1 : np;
}

/* A string attribute of the file, whole (checked reader). */
static int rattr_str(const rd *r, const char *name, char *buf, size_t len)
{
    return pdla_h5_attr_str(r->file, name, buf, len) == 0 ? 0 : -1;
}

/* A one-element integer attribute of the file (checked reader). */
static int rattr_int(const rd *r, const char *name, long long *v)
{
    int64_t x;
    if (pdla_h5_attr_number(r->file, name, PDLA_H5_I64, &x) < 0) return -1;
    *v = x;
    return 0;
}

/* The checkpoint schedule (optional: none before session 27): what a bare
 * --resume keeps, so a forged one must not set the resumed run's trigger
 * (a NaN or negative period). */
static int read_schedule(const rd *r, ev_sim *s)
{
    static const char *const S = "schedule_every_seconds";
    const htri_t has = H5Aexists(r->file, S);
    if (has < 0) return rfail(r, "%s", "its root attributes cannot be read (damaged)");
    if (!has) return 0;
    double every;
    if (pdla_h5_attr_exact(r->file, S, PDLA_H5_F64, &every) < 0)
        return rfail(r, "%s is not one 64-bit float (damaged)", S);
    if (!(every >= 0 && every <= 1e9)) { /* the range of --checkpoint-every; NaN fails */
        char m[160];
        snprintf(m, sizeof m, "%s %g is not 0 (none) to 1e9 seconds (damaged)", S, every);
        return rfail(r, "%s", m);
    }
    ev_set_checkpoint_every(s, every);
    return 0;
}

/* The parameters from their "name=value" lines. */
static int read_params(const rd *r, ev_params *p)
{
    const hssize_t n = rlen(r, "parameters");
    if (n <= 0 || n > (1 << 20)) return rfail(r, "%s", "no parameters");
    char *t = calloc((size_t)n + 1, 1);
    if (!t) return rfail(r, "%s", "out of memory");
    int rc = rds(r, "parameters", PDLA_H5_U8, (size_t)n, t);
    /* whole lines, as written: a NUL byte or a last line without its newline
     * ended the reading there, and what followed took its default */
    if (!rc && (strlen(t) != (size_t)n || t[n - 1] != '\n'))
        rc = rfail(r, "%s", "parameters with a NUL byte or a cut last line (damaged)");
    ev_params_default(p);
    size_t np;
    const pdla_param_desc *pt = ev_param_table(&np);
    uint32_t seen = 0; /* a key twice: the later won */
    for (char *line = t, *nl; !rc && *line; line = nl + 1) {
        nl = strchr(line, '\n');
        *nl = '\0';
        char *eq = strchr(line, '=');
        char e[400];
        if (!eq) {
            rc = rfail(r, "bad parameter line '%s'", line);
            break;
        }
        *eq = '\0';
        const char *v = eq + 1;
        const pdla_param_desc *d = pdla_param_find(pt, np, line);
        if (d && (seen & d->bit)) rc = rfail(r, "parameter %s given twice (damaged)", line);
        else if (d) seen |= d->bit;
        /* an empty string parameter is written as "" */
        if (!rc && ev_param_set(p, line, v, e, sizeof e)) rc = rfail(r, "%s", e);
    }
    free(t);
    return rc;
}

static int check_state(const rd *r, const ev_sim *s)
{
    const uint64_t ncell = (uint64_t)s->nc * (uint64_t)s->nc * (s->dim == 3 ? (uint64_t)s->nc : 1);
    for (uint32_t i = 0; i < s->ntot; i++) {
        if (s->lk[i].cell >= ncell) return rfail(r, "%s", "a cell index out of range (damaged)");
        if (s->lk[i].ev.kind == EV_K_PAIR && s->lk[i].ev.partner >= s->ntot)
            return rfail(r, "%s", "a partner index out of range (damaged)");
        if (i < s->n && s->species[i] >= s->nspecies)
            return rfail(r, "%s", "a species index out of range (damaged)");
    }
    if (s->nstuck > s->n) return rfail(r, "%s", "more stuck particles than particles (damaged)");
    for (uint32_t a = 0; a < s->nstuck; a++)
        if (s->stuck_idx[a] >= s->n || !s->stuck[s->stuck_idx[a]])
            return rfail(r, "%s", "the stuck list names a free particle (damaged)");
        else if (!s->sp[s->species[s->stuck_idx[a]]].sticky)
            return rfail(r, "%s", "a particle of a bath kind (STICKY 0) is stuck (damaged)");
    return 0;
}

/* Every pending event of a free particle is at or after `now` and names a
 * real partner, wall or face: the loop pops the earliest event and indexes
 * by these fields (a cell face outside [0, 2D) reads out of bounds; an
 * event time before `now` or NaN would send the queue's buckets astray). */
static int check_events(const rd *r, const ev_sim *s, uint32_t i)
{
    const ev_evt *e = &s->lk[i].ev;
    const int D = s->dim;
    if (!(e->t_pair >= s->now) || !(e->t_cell >= s->now))
        return rfail(r, "%s", "a pending event before the checkpoint's time or not a number (damaged)");
    if (e->kind != EV_K_NONE && e->kind != EV_K_PAIR && e->kind != EV_K_WALL)
        return rfail(r, "%s", "an unknown event kind (damaged)");
    if (e->kind == EV_K_WALL && (e->partner >= (uint32_t)(2 * D) || s->periodic))
        return rfail(r, "%s", "a wall event names no wall (damaged)");
    if (e->cell_what < -1 || e->cell_what >= 2 * D || (e->cell_what < 0 && e->t_cell < INFINITY))
        return rfail(r, "%s", "a cell crossing names no cell face (damaged)");
    return 0;
}

/* How far from touching a live pending event may find its particles at
 * its time (and how fast receding, as that distance times the relative
 * speed) and still be one the loop made. Its predictions hit the contact
 * to round-off, which has two parts: one relative to the contact distance
 * (overlaps of 1e-10 are the engine's stated bound, tests/event TOL; the
 * slack above it covers states moved since the prediction without a new
 * one, see pending_fault), and one absolute, of the doubles that make a
 * position at time t: the box side, and |v| times the clock (a time of
 * 1e10 carries 1e-6 of round-off by itself: a walled gas of packing 1e-12
 * at t = 1e10 met its walls 3e-5 radii off and was refused, though valid). */
#define CK_TOUCH 1e-6
#define CK_ROUND (64 * DBL_EPSILON)

/* The most the round-off allowance may reach, relative to the length it is
 * compared with (a contact distance, a radius at a wall, a cell side): a
 * forged speed, clock or ke_stuck must not widen the contact, wall, cell
 * and overlap checks without bound (a particle made 1e200 times faster
 * passed every one). Valid runs stay far below it: the largest round-off
 * in the tests, the dilute gases of event-forged-pending at t = 1e10
 * (walls met 3e-5 radii off), is 300 times smaller. */
#define CK_ROUND_CAP 1e-2

/* The absolute part for particle p at time t (see CK_TOUCH), capped at
 * CK_ROUND_CAP of `scale`. */
static double round_off(const ev_sim *s, const double *p, double t, double scale)
{
    const int D = s->dim;
    double v2 = 0;
    for (int k = 0; k < D; k++) v2 += p[D + k] * p[D + k];
    return fmin(CK_ROUND * (s->L + sqrt(v2) * (fabs(t) + fabs(p[2 * D]))), CK_ROUND_CAP * scale);
}

/* Do free i and j (j any, i != j) touch at time t, approaching? Positions
 * at t from the stored states, the image nearest then (as collide takes
 * it). */
static int pair_touches(const ev_sim *s, uint32_t i, uint32_t j, double t)
{
    const int D = s->dim;
    const double *pi = EV_P_ANY(s, i), *pj = EV_P_ANY(s, j);
    double rr = 0, rv = 0, vv = 0;
    for (int k = 0; k < D; k++) {
        double r = (pj[k] + pj[D + k] * (t - pj[2 * D])) - (pi[k] + pi[D + k] * (t - pi[2 * D]));
        if (s->periodic) {
            if (r > s->half) r -= s->L;
            else if (r < -s->half) r += s->L;
        }
        const double v = pj[D + k] - pi[D + k];
        rr += r * r;
        rv += r * v;
        vv += v * v;
    }
    const double sig = pi[2 * D + 1] + pj[2 * D + 1];
    const double tol = CK_TOUCH * sig + round_off(s, pi, t, 0.5 * sig) + round_off(s, pj, t, 0.5 * sig);
    return fabs(sqrt(rr) - sig) <= tol && rv <= tol * sqrt(vv);
}

/* Is free i at wall `what` (2k + side) at time t, moving into it? */
static int wall_touches(const ev_sim *s, uint32_t i, uint32_t what, double t)
{
    const int D = s->dim, k = (int)(what >> 1), up = (int)(what & 1);
    const double *p = EV_P_ANY(s, i);
    const double v = p[D + k], r = p[2 * D + 1], x = p[k] + v * (t - p[2 * D]);
    const double gap = up ? s->L - r - x : x - r;
    return (up ? v > 0 : v < 0) && fabs(gap) <= CK_TOUCH * r + round_off(s, p, t, r);
}

/* Does i meet a wall some time (ev_core.c pred_wall finds a finite time)? */
static int meets_wall(const ev_sim *s, uint32_t i)
{
    const int D = s->dim;
    const double *p = EV_P_ANY(s, i);
    for (int k = 0; k < D; k++) {
        const double v = p[D + k], r = p[2 * D + 1];
        const double t = v > 0 ? (s->L - r - p[k]) / v : v < 0 ? (p[k] - r) / -v : INFINITY;
        if ((t > 0 ? p[2 * D] + t : p[2 * D]) < INFINITY) return 1;
    }
    return 0;
}

/* What is wrong with free i's pending pair or wall event, or NULL. The loop
 * acts on a live event (a wall, or a partner whose collision counter is
 * still the one recorded) without looking again: a partner that is i
 * itself divides by a zero distance (NaN velocities), one that is not at
 * contact is hit, or stuck to, from afar. So a live event must find its
 * pair touching and approaching (or its wall) at its time. This is checked
 * within CK_TOUCH and CK_ROUND, not by predicting it again bit for bit: a stored state can
 * move without a new prediction (a periodic wrap by L at a cell crossing,
 * ev_sync), and predicting every event again on loading changes the
 * events (stale ones are counted) of a resumed run. A stale event (the
 * partner's counter moved on) is only predicted again when it comes up. In a
 * box with walls every particle that would meet a wall has an event: that
 * wall, or an earlier pair (a prediction starts from the wall). */
static const char *pending_fault(const ev_sim *s, uint32_t i)
{
    const ev_evt *e = &s->lk[i].ev;
    if (e->kind == EV_K_NONE)
        return !s->periodic && meets_wall(s, i)
                   ? "a moving particle without a pending event in a box with walls (damaged)"
                   : NULL;
    if (e->kind == EV_K_WALL)
        return wall_touches(s, i, e->partner, e->t_pair) ? NULL
               : "a pending wall event whose particle does not meet that wall then (damaged)";
    const uint32_t j = e->partner;
    if (j == i) return "a pending event names its own particle as the partner (damaged)";
    /* Any other count is a stale event, which the loop predicts again
     * (counters are 32 bits and wrap, so "ahead" is no fault: after a
     * partner's 2^32-th event a valid checkpoint held one). */
    if (e->pcount != s->lk[j].count || e->t_pair == INFINITY) return NULL; /* stale, or never */
    return pair_touches(s, i, j, e->t_pair) ? NULL
           : "a pending pair event whose particles do not meet then (apart, or receding) (damaged)";
}

/* What is wrong with free i's pending cell crossing, or NULL. The loop
 * moves i to the next cell only at that event, so it must come when i
 * reaches that face of its cell, moving out, and i must not leave the
 * cell through another face before (a forged t_cell of 1e159 left every
 * particle in its first cell: the run went on without meeting its
 * neighbours, and wrote a checkpoint its own loader refused; fuzz_mut_event).
 * A particle with no crossing (walls) must be unable to leave. The line is
 * straight and i is in its cell now (check_particle), so being in the cell
 * at t_cell on every axis it can cross, within the same round-off, is never
 * leaving (an axis where it flies into a wall is met by the wall event). */
static const char *cell_fault(const ev_sim *s, uint32_t i)
{
    const ev_evt *e = &s->lk[i].ev;
    const int D = s->dim, face = e->cell_what;
    const double *p = EV_P_ANY(s, i);
    const double tol = CK_TOUCH * s->w + (face >= 0 ? round_off(s, p, e->t_cell, s->w) : 0);
    uint32_t c = s->lk[i].cell;
    for (int k = 0; k < D; k++, c /= (uint32_t)s->nc) {
        const int cc = (int)(c % (uint32_t)s->nc);
        const double lo = (double)cc * s->w, v = p[D + k];
        if (face < 0) {
            const int out = v > 0 ? s->periodic || cc < s->nc - 1 : v < 0 ? s->periodic || cc > 0 : 0;
            if (out) return "a moving particle without its next cell crossing (damaged)";
            continue;
        }
        /* an axis whose wall comes first is not crossed (pred_cell); a
         * crossing through that wall would wrap i by L (the step wraps) */
        if (!s->periodic && ((v > 0 && cc == s->nc - 1) || (v < 0 && cc == 0))) {
            if (k == face >> 1) return "a cell crossing through a wall of the box (damaged)";
            continue;
        }
        const double x = p[k] + v * (e->t_cell - p[2 * D]);
        if (!(x >= lo - tol && x <= lo + s->w + tol))
            return "a cell crossing after the particle has left its cell (damaged)";
        if (k == face >> 1 && ((face & 1) ? !(v > 0 && x >= lo + s->w - tol) : !(v < 0 && x <= lo + tol)))
            return "a cell crossing whose particle is not at that face then, moving out (damaged)";
    }
    return NULL;
}

/* Is free i still between the walls at its pending event's time? Its
 * wall event is predicted with every pair event, which may only come
 * earlier (ev_core.c), so it can be no later than the wall: a later one let
 * i fly through the wall. Straight in a box, so its end is enough. */
static const char *wall_fault(const ev_sim *s, uint32_t i)
{
    if (s->periodic) return NULL;
    const int D = s->dim;
    const double *p = EV_P_ANY(s, i), T = s->lk[i].ev.t_pair, r = p[2 * D + 1];
    if (T == INFINITY)
        return meets_wall(s, i) ? "a moving particle without a pending event in a box with walls (damaged)" : NULL;
    const double tol = CK_TOUCH * r + round_off(s, p, T, r);
    for (int k = 0; k < D; k++) {
        const double x = p[k] + p[D + k] * (T - p[2 * D]);
        if (!(x >= r - tol && x <= s->L - r + tol))
            return "a pending event after its particle has passed a wall (damaged)";
    }
    return NULL;
}

/* Every free particle's pending event (pending_fault, wall_fault) and cell
 * crossing (cell_fault), after check_values (every particle's numbers
 * finite, every partner in range). */
static int check_pending(const rd *r, const ev_sim *s)
{
    for (uint32_t i = 0; i < s->n; i++) {
        const char *bad = s->stuck[i] ? NULL : pending_fault(s, i);
        if (!bad && !s->stuck[i]) bad = wall_fault(s, i);
        if (!bad && !s->stuck[i]) bad = cell_fault(s, i);
        if (bad) return rfail(r, "%s", bad);
    }
    return 0;
}

/* Particle i's stored numbers: finite, its radius its kind's, its local
 * time in [0, now], and its position at `now` inside its cell up to
 * round-off (the cell lists are rebuilt from `cell`, so a particle far from
 * its cell would never meet its neighbours; NaN or infinite positions or
 * velocities make every later event time NaN and the loop never ends). */
static int check_particle(const rd *r, const ev_sim *s, uint32_t i)
{
    const int D = s->dim;
    const double *p = EV_P_ANY(s, i);
    for (int k = 0; k < 2 * D + 2; k++)
        if (!isfinite(p[k])) return rfail(r, "%s", "a position, velocity or time not finite (damaged)");
    if (!(p[2 * D] >= 0 && p[2 * D] <= s->now))
        return rfail(r, "%s", "a particle's time outside [0, now] (damaged)");
    if (i < s->n ? p[2 * D + 1] != s->sp[s->species[i]].radius : !(p[2 * D + 1] > 0))
        return rfail(r, "%s", "a particle's radius is not its kind's (damaged)");
    /* the box checks (and, periodic, the nearest-image condition of
     * size_cells) hold for the parameters' largest seed, not a larger one */
    if (i >= s->n && !(p[2 * D + 1] <= s->rmax))
        return rfail(r, "%s", "a seed larger than its parameters' seeds (damaged)");
    uint32_t c = s->lk[i].cell;
    const double tol = 1e-6 * s->w;
    for (int k = 0; k < D; k++, c /= (uint32_t)s->nc) {
        const double lo = (double)(c % (uint32_t)s->nc) * s->w;
        const double x = p[k] + p[D + k] * (s->now - p[2 * D]);
        if (!(x >= lo - tol && x <= lo + s->w + tol))
            return rfail(r, "%s", "a particle outside its cell (damaged)");
    }
    return 0;
}

/* The values check_state does not cover: what the event loop trusts. */
static int check_values(const rd *r, const ev_sim *s)
{
    if (!isfinite(s->now) || s->now < 0 || !(s->series_dt > 0) || !isfinite(s->series_dt) ||
        !isfinite(s->iv_t0) || !isfinite(s->iv_v0) || !isfinite(s->ke_stuck) || !isfinite(s->virial) ||
        !isfinite(s->wall_impulse) || !isfinite(s->max_overlap))
        return rfail(r, "%s", "a time or sum not finite, or a negative time (damaged)");
    if ((s->started != 0 && s->started != 1) || (s->iv_open != 0 && s->iv_open != 1))
        return rfail(r, "%s", "a run flag other than 0 or 1 (damaged)");
    /* Sums of non-negative terms, and counters that add up: every event is
     * one collision, wall hit, stick, cell crossing or stale prediction, and
     * every stuck particle stuck by one event (a forged counter wrapped the
     * resumed run's collision count, a negative ke_stuck went to /results) */
    if (!(s->ke_stuck >= 0) || !(s->wall_impulse >= 0) || !(s->max_overlap >= 0))
        return rfail(r, "%s", "a negative energy, impulse or overlap sum (damaged)");
    /* an overlap / (r_i + r_j) is at most 1 (centres at one point); a forged
     * 7 went to /results max_overlap_seen */
    if (!(s->max_overlap <= 1))
        return rfail(r, "%s", "a largest overlap above 1 of the contact distance (damaged)");
    uint64_t sum = 0;
    const uint64_t parts[5] = {s->collisions, s->wall_hits, s->sticks, s->cell_crossings, s->invalid};
    int wrapped = 0;
    for (int k = 0; k < 5; k++) wrapped |= __builtin_add_overflow(sum, parts[k], &sum);
    if (wrapped || sum != s->events || s->sticks != s->nstuck)
        return rfail(r, "%s", "event counters that do not add up (damaged)");
    /* the interval is the parameter's, doubled at each thinning (exact):
     * a forged 1e-300 made a run of 1e6 empty rows a row at a time */
    int e2;
    if (s->started && !(s->series_dt >= s->par.series_dt && frexp(s->series_dt / s->par.series_dt, &e2) == 0.5))
        return rfail(r, "%s", "a series interval that is not the parameter's times a power of 2 (damaged)");
    if (!(s->rng.s[0] | s->rng.s[1] | s->rng.s[2] | s->rng.s[3]))
        return rfail(r, "%s", "an all-zero random state (damaged)");
    uint8_t *seen = calloc(s->n ? s->n : 1, 1);
    if (!seen) return rfail(r, "%s", "out of memory");
    int rc = 0;
    uint32_t flagged = 0;
    for (uint32_t i = 0; !rc && i < s->ntot; i++) {
        if (s->stuck[i] > 1 || (i >= s->n && !s->stuck[i]))
            rc = rfail(r, "%s", "a stuck flag other than 0 or 1, or a free seed (damaged)");
        else if (!(rc = check_particle(r, s, i)) && i < s->n) {
            if (!s->stuck[i]) rc = check_events(r, s, i);
            else if (s->parent[i] >= s->ntot || s->parent[i] == i)
                rc = rfail(r, "%s", "a stuck particle's parent out of range (damaged)");
            flagged += s->stuck[i];
        }
    }
    double t_prev = 0;
    for (uint32_t a = 0; !rc && a < s->nstuck; a++) {
        const uint32_t i = s->stuck_idx[a]; /* < n: check_state */
        if (seen[i]++) rc = rfail(r, "%s", "a particle twice in the stuck list (damaged)");
        else if (!(s->stuck_t[a] >= t_prev && s->stuck_t[a] <= s->now))
            rc = rfail(r, "%s", "sticking times out of order or after now (damaged)");
        else if (s->parent[i] < s->n && !seen[s->parent[i]]) /* a cycle was written to /cluster/parent */
            rc = rfail(r, "%s", "a stuck particle's parent is no seed and stuck after it (damaged)");
        else t_prev = s->stuck_t[a];
    }
    if (!rc && flagged != s->nstuck) rc = rfail(r, "%s", "the stuck flags do not match the stuck list (damaged)");
    free(seen);
    return rc;
}

/* The kinetic energy, free and stuck, is what the start velocities gave
 * (elastic collisions and walls keep it, sticking moves it to ke_stuck):
 * at most 36.8 d N kT (Box-Muller's |g| <= sqrt(2 ln 2^53) per component;
 * fixed speeds give N kT). A particle made 1e200 times faster loaded (the
 * run wrote kinetic_energy_free Infinity, or without a stop never ended:
 * each cell crossing below one ulp of now). 100 d N kT leaves the drift of
 * round-off room. After check_values (finite numbers). */
#define CK_KE_MAX 100.0

static int check_energy(const rd *r, const ev_sim *s)
{
    const int D = s->dim;
    double ke = s->ke_stuck;
    for (uint32_t i = 0; i < s->n; i++) {
        const double *p = EV_P_ANY(s, i);
        double v2 = 0;
        for (int k = 0; k < D; k++) v2 += p[D + k] * p[D + k];
        ke += 0.5 * ev_pmass(s, i) * v2;
    }
    const double most = CK_KE_MAX * D * (double)s->n * s->par.kT;
    if (ke <= most) return 0;
    char m[200];
    snprintf(m, sizeof m, "kinetic energy %.3g, over %.3g (100 d N kT, beyond what the start velocities give) "
             "(damaged)", ke, most);
    return rfail(r, "%s", m);
}

/* Every kind holds the particles its species parameter gives it: /species
 * count, the masses and energies are the parameter's, so a checkpoint that
 * relabels particles (50 of kind 0 as kind 1) resumed with [50, 150] in a
 * run that reports [100, 100]. After check_state (kinds in range). */
static int check_kinds(const rd *r, const ev_sim *s)
{
    uint64_t cnt[EV_MAX_SPECIES] = {0};
    for (uint32_t i = 0; i < s->n; i++) cnt[s->species[i]]++;
    for (int k = 0; k < s->nspecies; k++)
        if (cnt[k] != s->sp[k].count) {
            char m[200];
            snprintf(m, sizeof m, "kind %d has %llu particles, its species parameter %llu (damaged)", k + 1,
                     (unsigned long long)cnt[k], (unsigned long long)s->sp[k].count);
            return rfail(r, "%s", m);
        }
    return 0;
}

/* round_off (see CK_TOUCH) for any particle at any time up to now: 64
 * epsilon of the box side and of the fastest speed times the clock. A
 * stuck particle's position carries the round-off of its speed when it
 * stuck, which is gone from the state; its kinetic energy then is part of
 * ke_stuck, so sqrt(2 ke_stuck / lightest mass) bounds that speed. */
static double round_off_any(const ev_sim *s)
{
    const int D = s->dim;
    double v2 = 0, mmin = INFINITY;
    for (uint32_t i = 0; i < s->n; i++) {
        const double *p = EV_P_ANY(s, i);
        double w = 0;
        for (int k = 0; k < D; k++) w += p[D + k] * p[D + k];
        v2 = fmax(v2, w);
    }
    for (int k = 0; k < s->nspecies; k++) mmin = fmin(mmin, s->spmass[k]);
    const double v = fmax(sqrt(v2), sqrt(2 * s->ke_stuck / mmin));
    return CK_ROUND * (s->L + v * 2 * s->now);
}

/* Every stuck particle and seed at rest, and every stuck particle at
 * contact with its parent: hit_stuck zeroes its velocity and leaves it
 * where it touched (the parent's distance r_i + r_parent, nearest image
 * when periodic, to round-off). A stuck particle moved away from its
 * parent, or given a velocity, resumed and went to /cluster as it was
 * (a cluster that does not hold together, or moving stuck particles).
 * Tolerance: the pending events' (CK_TOUCH of the contact distance and the
 * round-off of two positions, capped). After check_values (finite
 * numbers, parents in range). */
static int check_stuck(const rd *r, const ev_sim *s)
{
    const int D = s->dim;
    const double ro = 2 * round_off_any(s);
    for (uint32_t i = 0; i < s->ntot; i++) {
        if (!s->stuck[i]) continue; /* every seed is stuck (check_values) */
        const double *p = EV_P_ANY(s, i);
        for (int k = 0; k < D; k++)
            if (p[D + k] != 0) return rfail(r, "%s", "a stuck particle or seed with a velocity (damaged)");
        if (i >= s->n) continue;
        const double *q = EV_P_ANY(s, s->parent[i]);
        const double sig = p[2 * D + 1] + q[2 * D + 1], d = sqrt(ev_dist2(s, p, q));
        if (!(fabs(d - sig) <= CK_TOUCH * sig + fmin(ro, CK_ROUND_CAP * sig))) {
            char m[200];
            snprintf(m, sizeof m, "stuck particle %u is %.6g from its parent, not at contact %.6g (damaged)", i, d,
                     sig);
            return rfail(r, "%s", m);
        }
    }
    return 0;
}

/* No two particles (free, stuck, seeds) overlap: the engine keeps every
 * overlap below 1e-10 of the contact distance (tests/event TOL), a forged
 * copy of a particle onto another resumed, and the overlap went to
 * cluster.h5 while /results max_overlap_seen stayed ~1e-14. Measured by
 * ev_max_overlap_now (cell lists, O(N)), so after rebuild_derived; the
 * tolerance is the pending events' (CK_TOUCH plus the round-off of two
 * positions, relative to the smallest contact distance, capped). */
static double overlap_tol(const ev_sim *s)
{
    const int D = s->dim;
    double rmin = INFINITY;
    for (uint32_t i = 0; i < s->ntot; i++) rmin = fmin(rmin, EV_P_ANY(s, i)[2 * D + 1]);
    return CK_TOUCH + fmin(2 * round_off_any(s) / (2 * rmin), CK_ROUND_CAP);
}

static int check_overlap(const rd *r, ev_sim *s)
{
    const double tol = overlap_tol(s);
    const double worst = ev_max_overlap_now(s);
    if (worst <= tol) return 0; /* -INFINITY: no pair of neighbours */
    char m[200];
    snprintf(m, sizeof m, "particles overlap by %.3g of their contact distance, over %.3g (damaged)", worst, tol);
    return rfail(r, "%s", m);
}

/* No pending pair event missing or late: no two neighbours would pass into
 * each other, moving straight, before either's pending event
 * (ev_max_overlap_ahead; a checkpoint with its pair events deleted resumed
 * in a periodic box and particles went 0.64 of a diameter into each
 * other). pending_fault checks the events present; this one what each
 * pair's next contact asks of them, with check_overlap's tolerance. Not by
 * predicting the events again (a particle's own event may be later than
 * a fresh prediction: the pair's other particle holds the earlier one),
 * nor changing any: the resumed run's events stay the same. After the
 * cell lists are rebuilt. */
static int check_ahead(const rd *r, ev_sim *s)
{
    const double tol = overlap_tol(s);
    const double worst = ev_max_overlap_ahead(s);
    if (worst <= tol) return 0;
    char m[240];
    snprintf(m, sizeof m, "two particles would pass %.3g of their contact distance into each other before "
             "either's pending event (a pair event missing or late) (damaged)", worst);
    return rfail(r, "%s", m);
}

/* The series' times: finite, in order, none after now. */
static int check_series(const rd *r, const ev_series *ser, double now)
{
    for (size_t k = 0; k < ser->n; k++)
        if (!(ser->t[k] >= (k ? ser->t[k - 1] : 0) && ser->t[k] <= now))
            return rfail(r, "%s", "series times out of order, not finite or after now (damaged)");
    return 0;
}

/* The rows so far: no more than a run keeps (EV_SERIES_MAX; a gzip-forged
 * length of 5e7 rows in a 2 MB file took 2.3 GB before). */
static int read_series(const rd *r, ev_series *ser, double now)
{
    const hssize_t n = rlen(r, "series/time");
    if (n < 0) return rfail(r, "%s", "no /series");
    if (n > EV_SERIES_MAX) return rfail(r, "%s", "a series longer than a run keeps (damaged)");
    const size_t cap = n > 256 ? (size_t)n : 256;
    ser->t = malloc(cap * sizeof *ser->t);
    ser->ke = malloc(cap * sizeof *ser->ke);
    ser->pressure = malloc(cap * sizeof *ser->pressure);
    ser->stuck = malloc(cap * sizeof *ser->stuck);
    ser->collisions = malloc(cap * sizeof *ser->collisions);
    ser->cap = cap;
    ser->n = (size_t)n;
    if (!ser->t || !ser->ke || !ser->pressure || !ser->stuck || !ser->collisions)
        return rfail(r, "%s", "out of memory");
    const size_t m = (size_t)n;
    if (rds(r, "series/time", PDLA_H5_F64, m, ser->t) ||
        rds(r, "series/kinetic_energy", PDLA_H5_F64, m, ser->ke) ||
        rds(r, "series/pressure", PDLA_H5_F64, m, ser->pressure) ||
        rds(r, "series/stuck", PDLA_H5_U64, m, ser->stuck) ||
        rds(r, "series/collisions", PDLA_H5_U64, m, ser->collisions))
        return -1;
    return check_series(r, ser, now);
}

static int read_state(const rd *r, ev_sim *s)
{
    const uint32_t N = s->ntot;
    double *tp = malloc((N ? N : 1) * sizeof *tp), *tc = malloc((N ? N : 1) * sizeof *tc);
    uint32_t *pa = malloc((N ? N : 1) * sizeof *pa), *pc = malloc((N ? N : 1) * sizeof *pc);
    uint32_t *co = malloc((N ? N : 1) * sizeof *co), *ce = malloc((N ? N : 1) * sizeof *ce);
    int8_t *kd = malloc(N ? N : 1), *cw = malloc(N ? N : 1);
    uint64_t cnt[CK_NCOUNT];
    double re[CK_NREAL];
    int rc = (!tp || !tc || !pa || !pc || !co || !ce || !kd || !cw) ? rfail(r, "%s", "out of memory") : 0;
    if (!rc &&
        (rds(r, "state/ps", PDLA_H5_F64, (size_t)N * (size_t)(2 * s->dim + 2), s->ps) ||
         rds(r, "state/species", PDLA_H5_U8, N, s->species) ||
         rds(r, "state/stuck", PDLA_H5_U8, N, s->stuck) ||
         rds(r, "state/count", PDLA_H5_U32, N, co) ||
         rds(r, "state/parent", PDLA_H5_U32, N, s->parent) ||
         rds(r, "state/cell", PDLA_H5_U32, N, ce) ||
         rds(r, "state/t_pair", PDLA_H5_F64, N, tp) ||
         rds(r, "state/t_cell", PDLA_H5_F64, N, tc) ||
         rds(r, "state/partner", PDLA_H5_U32, N, pa) ||
         rds(r, "state/pcount", PDLA_H5_U32, N, pc) ||
         rds(r, "state/kind", PDLA_H5_I8, N, kd) ||
         rds(r, "state/cell_what", PDLA_H5_I8, N, cw) ||
         rds(r, "state/counters", PDLA_H5_U64, CK_NCOUNT, cnt) ||
         rds(r, "state/reals", PDLA_H5_F64, CK_NREAL, re)))
        rc = -1;
    if (!rc && cnt[6] > s->n) rc = rfail(r, "%s", "more stuck particles than particles (damaged)");
    if (!rc) {
        s->nstuck = (uint32_t)cnt[6];
        rc = rds(r, "state/stuck_idx", PDLA_H5_U32, s->nstuck, s->stuck_idx);
        if (!rc) rc = rds(r, "state/stuck_t", PDLA_H5_F64, s->nstuck, s->stuck_t);
    }
    if (!rc) {
        for (uint32_t i = 0; i < N; i++) {
            s->lk[i].ev = (ev_evt){tp[i], tc[i], pa[i], pc[i], kd[i], cw[i]};
            s->lk[i].count = co[i];
            s->lk[i].cell = ce[i];
        }
        s->events = cnt[0], s->collisions = cnt[1], s->wall_hits = cnt[2], s->sticks = cnt[3];
        s->cell_crossings = cnt[4], s->invalid = cnt[5];
        s->started = (int)cnt[7], s->iv_open = (int)cnt[8];
        for (int k = 0; k < 4; k++) s->rng.s[k] = cnt[9 + k];
        s->now = re[0], s->series_dt = re[1], s->ke_stuck = re[2], s->virial = re[3];
        s->wall_impulse = re[4], s->max_overlap = re[5], s->iv_t0 = re[6], s->iv_v0 = re[7];
    }
    free(tp), free(tc), free(pa), free(pc), free(co), free(ce), free(kd), free(cw);
    return rc;
}

/* Cells from `cell`, the queue from the pending events. */
static void rebuild_derived(ev_sim *s)
{
    const int D = s->dim;
    const uint64_t ncell = (uint64_t)s->nc * (uint64_t)s->nc * (D == 3 ? (uint64_t)s->nc : 1);
    for (uint64_t c = 0; c < ncell; c++) s->chead[c] = UINT32_MAX;
    for (uint32_t i = s->ntot; i-- > 0;)
        if (ev_in_cells(s, i)) ev_cell_insert(s, i, s->lk[i].cell);
    ev_queue_reset(s);
    for (uint32_t i = 0; i < s->n; i++)
        if (!s->stuck[i]) ev_heap_push(s, i);
}

/* Before ev_alloc sizes memory by the parameters: they must give the
 * particle count of the root attributes, and the file must store the state
 * of that many (a forged `particles=4000000000` in a small file must not
 * allocate for it). */
static int check_sizes(const rd *r, const ev_params *p, long long dim, long long n, long long ntot)
{
    ev_species sp[EV_MAX_SPECIES];
    int nsp = 0;
    char e[400];
    if (ev_parse_species(p, sp, &nsp, e, sizeof e)) return rfail(r, "%s", e);
    uint64_t total = 0;
    for (int k = 0; k < nsp; k++) total += sp[k].count;
    if (dim != p->dim || n < 1 || (uint64_t)n != total || ntot < n || ntot > UINT32_MAX)
        return rfail(r, "%s", "its parameters do not give its particle count (damaged)");
    const hssize_t len = rlen(r, "state/ps");
    if (len < 0 || (uint64_t)len != (uint64_t)ntot * (uint64_t)(2 * dim + 2))
        return rfail(r, "%s", "dataset state/ps is not the state of its particles (damaged)");
    return 0;
}

/* A --seeds run's seeds as the checkpoint stores them (particles n ..
 * ntot - 1 of state/ps), D + 1 numbers each (position, radius), for
 * ev_alloc_seeded: a resume uses these, not the file, which was read again
 * before (a file since moved, named relative to another directory or
 * edited made the checkpoint look "damaged", or was silently ignored).
 * Sizes as checked by check_sizes; NULL with the line in r. */
static double *read_seeds(const rd *r, int D, long long n, long long ntot)
{
    const size_t S = (size_t)(2 * D + 2), ns = (size_t)(ntot - n);
    if (ns < 1 || ns > EV_MAX_SEEDS) {
        rfail(r, "%s", "a --seeds run without its seeds, or more than the most a file may hold (damaged)");
        return NULL;
    }
    double *row = malloc(ns * S * sizeof *row), *xr = malloc(ns * (size_t)(D + 1) * sizeof *xr);
    pdla_h5_dset d;
    int rc = !row || !xr ? rfail(r, "%s", "out of memory") : 0;
    if (!rc && pdla_h5_dset_open(r->file, "state/ps", &d) < 0) rc = rfail(r, "%s", "no dataset state/ps (damaged)");
    else if (!rc) {
        if (pdla_h5_dset_read(&d, PDLA_H5_F64, (uint64_t)n * S, ns * S, row) < 0)
            rc = rfail(r, "%s", "cannot read state/ps (damaged: checksum or I/O error)");
        if (pdla_h5_dset_close(&d) < 0 && !rc) rc = rfail(r, "%s", "cannot close dataset state/ps");
    }
    for (size_t a = 0; !rc && a < ns; a++) {
        for (int k = 0; k < D; k++) xr[a * (size_t)(D + 1) + (size_t)k] = row[a * S + (size_t)k];
        const double rad = row[a * S + (size_t)(2 * D + 1)];
        xr[a * (size_t)(D + 1) + (size_t)D] = rad;
        if (!(rad > 0 && rad < INFINITY)) rc = rfail(r, "%s", "a seed's radius is not a positive number (damaged)");
    }
    free(row);
    if (rc) {
        free(xr);
        return NULL;
    }
    return xr;
}

ev_sim *ev_checkpoint_load(const char *path, ev_series *ser, char *err, size_t errlen)
{
    memset(ser, 0, sizeof *ser);
    rd r = {H5I_INVALID_HID, path, err, errlen};
    h5u_quiet q;
    if (h5u_silence(&q)) {
        snprintf(err, errlen, "checkpoint: cannot silence HDF5");
        return NULL;
    }
    ev_sim *s = NULL;
    int rc = 0;
    /* a regular file only: H5Fopen of a FIFO blocked for ever, past SIGTERM */
    struct stat st;
    if (stat(path, &st) != 0 || access(path, R_OK) != 0) {
        snprintf(err, errlen, "checkpoint %s: %s", path, strerror(errno));
        rc = -1;
    } else if (!S_ISREG(st.st_mode)) {
        snprintf(err, errlen, "checkpoint %s: not a regular file", path);
        rc = -1;
    }
    if (!rc && (r.file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT)) < 0)
        rc = rfail(&r, "%s", "not an HDF5 file (or damaged)");
    char fmt[64];
    long long ver = 0, dim = 0, n = 0, ntot = 0;
    if (!rc && (rattr_str(&r, "format", fmt, sizeof fmt) || strcmp(fmt, CK_FORMAT) != 0))
        rc = rfail(&r, "%s", "not an event-model checkpoint");
    if (!rc && (rattr_int(&r, "format_version", &ver) || ver < 2 || ver > CK_VERSION)) {
        char vm[96];
        snprintf(vm, sizeof vm, "format version %lld, not 2 to %d", ver, CK_VERSION);
        rc = rfail(&r, "%s (made by another pdla)", vm);
    }
    if (!rc && (rattr_int(&r, "dim", &dim) || rattr_int(&r, "particles", &n) ||
                rattr_int(&r, "ntot", &ntot)))
        rc = rfail(&r, "%s", "no dim/particles attributes");
    ev_params p;
    if (!rc) rc = read_params(&r, &p);
    char e2[400];
    if (!rc) rc = check_sizes(&r, &p, dim, n, ntot);
    double *seeds = NULL;
    if (!rc && p.seeds[0] && !(seeds = read_seeds(&r, (int)dim, n, ntot))) rc = -1;
    if (!rc && !(s = ev_alloc_seeded(&p, seeds, seeds ? (uint32_t)(ntot - n) : 0, e2, sizeof e2))) rc = rfail(&r, "%s", e2);
    if (!rc && ((long long)s->dim != dim || (long long)s->n != n || (long long)s->ntot != ntot))
        rc = rfail(&r, "%s", "its parameters do not give its particle count (damaged)");
    const int nc_then = !s ? 0 : ver == 2 ? s->nc_v2 : ver == 3 ? s->nc_v3 : s->nc;
    if (!rc && nc_then != s->nc) {
        char vm[160];
        snprintf(vm, sizeof vm, "format version %lld names cells of an older grid (%d a side, now %d)", ver,
                 nc_then, s->nc);
        rc = rfail(&r, "%s: resume it with the pdla that wrote it", vm);
    }
    if (!rc) rc = read_state(&r, s);
    if (!rc) rc = check_state(&r, s);
    if (!rc) rc = check_kinds(&r, s);
    if (!rc) rc = check_values(&r, s);
    if (!rc) rc = check_energy(&r, s);
    if (!rc) rc = check_stuck(&r, s);
    if (!rc) rc = check_pending(&r, s);
    /* the seeds' near lists from the seeds as stored */
    if (!rc && ev_big_build(s)) rc = rfail(&r, "%s", "out of memory for the cells near the seeds");
    if (!rc) rc = read_series(&r, ser, s->now);
    if (!rc) rc = read_schedule(&r, s);
    if (r.file >= 0 && H5Fclose(r.file) < 0 && !rc) rc = rfail(&r, "%s", "cannot close it");
    if (h5u_restore(&q) < 0 && !rc) rc = rfail(&r, "%s", "cannot restore the HDF5 error handler");
    if (!rc) {
        rebuild_derived(s);
        rc = check_overlap(&r, s); /* needs the cell lists */
        if (!rc) rc = check_ahead(&r, s);
    }
    if (rc) {
        ev_free(s);
        ev_series_free(ser);
        return NULL;
    }
    return s;
}

ev_params *ev_params_of(ev_sim *s) { return &s->par; }

void ev_set_checkpoint_every(ev_sim *s, double seconds)
{
    s->ck_every = seconds;
    s->has_ck_every = 1;
}

int ev_checkpoint_every(const ev_sim *s, double *seconds)
{
    *seconds = s->ck_every;
    return s->has_ck_every;
}
