/*
 * ev_check_read.c - what `pdla check` reads of an event-model file (see
 * pdla/event.h ev_check_file): a cluster.h5 through the checked readers
 * (pdla/h5check.h), or a checkpoint.h5 through ev_checkpoint_load and the
 * simulation's public accessors; both into one evc_data for ev_check.c.
 *
 * Nothing is sized by what a file declares before the file is shown to
 * store it: each dataset must have the type pdla writes, its shape, and
 * the bytes it declares (pdla_h5_dset_stored); the datasets of one group
 * must have the rows of its first before they are allocated; /series no
 * more rows than a run keeps, /species no more kinds than the model has,
 * the seeds no more than a --seeds file may hold.
 */
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "ev_check.h"
#include "ev_internal.h"
#include "h5util.h"
#include "pdla/h5check.h"
#include "pdla/pdla.h"

/* ev_ckpt.c's CK_FORMAT: the root attribute `format` of a checkpoint */
#define CKPT_FORMAT "pdla-event-checkpoint"

typedef struct rd {
    hid_t f;
    const char *path;
    char *err;
    size_t errlen;
} rd;

static int bad(const rd *r, const char *name, const char *what)
{
    return pdla_errorf(EV_CHECK_DAMAGED, r->err, r->errlen, "%s: %s %s", r->path, name, what);
}

void evc_data_free(evc_data *d)
{
    void *const p[] = {d->seed_x, d->seed_r, d->sx, d->sr, d->st, d->spar, d->ssp, d->sidx,
                       d->fx, d->fv, d->fr, d->fsp, d->ser_t, d->ser_ke, d->ser_stuck, d->ser_coll};
    for (size_t k = 0; k < sizeof p / sizeof p[0]; k++) free(p[k]);
    memset(d, 0, sizeof *d);
}

/* The shape a dataset must have and where it goes. */
typedef struct want {
    const char *name;
    pdla_h5_type t;
    size_t esize; /* bytes of an element in memory */
    int cols;     /* 0: rank 1; else rank 2 of this many columns */
    size_t max;   /* the most rows allowed */
} want;

/* Is d what w asks, and its rows *rows (SIZE_MAX: any, then set)? */
static int shape_ok(const rd *r, const want *w, const pdla_h5_dset *d, size_t *rows)
{
    if (!pdla_h5_dset_is(d, w->t)) return bad(r, w->name, "is not of the type pdla writes");
    if (d->rank != (w->cols ? 2 : 1) || (w->cols && d->dims[1] != (uint64_t)w->cols))
        return bad(r, w->name, "has another shape than pdla writes");
    if (pdla_h5_dset_stored(d, w->esize) != PDLA_H5_STORED) return bad(r, w->name, "declares more than the file stores");
    if (d->dims[0] > w->max)
        return pdla_errorf(EV_CHECK_DAMAGED, r->err, r->errlen, "%s: %s has %llu rows, more than %zu", r->path,
                           w->name, (unsigned long long)d->dims[0], w->max);
    if (*rows != SIZE_MAX && d->dims[0] != *rows)
        return pdla_errorf(EV_CHECK_DAMAGED, r->err, r->errlen, "%s: %s has %llu rows, its group %zu", r->path,
                           w->name, (unsigned long long)d->dims[0], *rows);
    *rows = (size_t)d->dims[0];
    return 0;
}

/* Dataset w, shape checked, read whole into *dst (malloc'ed). */
static int dset(const rd *r, const want *w, size_t *rows, void **dst)
{
    pdla_h5_dset d;
    *dst = NULL;
    if (pdla_h5_dset_open(r->f, w->name, &d) < 0) return bad(r, w->name, "is missing or not a dataset");
    int rc = shape_ok(r, w, &d, rows);
    if (!rc) {
        const size_t n = *rows * (size_t)(w->cols ? w->cols : 1);
        *dst = malloc((n ? n : 1) * w->esize);
        if (!*dst) rc = bad(r, w->name, "does not fit in memory");
        else if (pdla_h5_dset_read(&d, w->t, 0, *rows, *dst) < 0)
            rc = bad(r, w->name, "cannot be read (a checksum or I/O error, or a value out of range)");
    }
    if (pdla_h5_dset_close(&d) < 0 && !rc) rc = bad(r, w->name, "cannot be closed");
    if (rc) {
        free(*dst);
        *dst = NULL;
    }
    return rc;
}

/* One attribute of object obj ("/" or a group): a number (converted to t)
 * or, for buf, a string. */
static int attr(const rd *r, const char *obj, const char *name, pdla_h5_type t, void *v, size_t len)
{
    const hid_t o = H5Oopen(r->f, obj, H5P_DEFAULT);
    if (o < 0) return bad(r, obj, "is missing");
    const int got = len ? pdla_h5_attr_str(o, name, v, len) : pdla_h5_attr_number(o, name, t, v);
    int rc = 0;
    if (got != 0)
        rc = pdla_errorf(EV_CHECK_DAMAGED, r->err, r->errlen, "%s: %s attribute %s is missing or not as pdla writes it",
                         r->path, obj, name);
    if (H5Oclose(o) < 0 && !rc) rc = bad(r, obj, "cannot be closed");
    return rc;
}

/* Whether object obj has attribute name (quietly: 0 when it cannot say). */
static int has_attr(const rd *r, const char *obj, const char *name)
{
    return H5Aexists_by_name(r->f, obj, name, H5P_DEFAULT) > 0;
}

static int read_root(const rd *r, evc_data *d)
{
    int64_t dim = 0;
    char walls[32];
    int rc = attr(r, "/", "dim", PDLA_H5_I64, &dim, 0);
    if (!rc) rc = attr(r, "/", "particles", PDLA_H5_U64, &d->particles, 0);
    if (!rc) rc = attr(r, "/", "box_walls", PDLA_H5_U8, walls, sizeof walls);
    if (!rc && dim != 2 && dim != 3) rc = bad(r, "/", "attribute dim is not 2 or 3");
    if (!rc && strcmp(walls, "elastic") != 0 && strcmp(walls, "periodic") != 0)
        rc = bad(r, "/", "attribute box_walls is not elastic or periodic");
    d->dim = (int)dim;
    d->periodic = !rc && strcmp(walls, "periodic") == 0;
    return rc;
}

static int read_results(const rd *r, evc_data *d)
{
    char why[64];
    int rc = attr(r, "/results", "time", PDLA_H5_F64, &d->t, 0);
    if (!rc) rc = attr(r, "/results", "stuck", PDLA_H5_U64, &d->res_stuck, 0);
    if (!rc) rc = attr(r, "/results", "collisions", PDLA_H5_U64, &d->res_collisions, 0);
    if (!rc) rc = attr(r, "/results", "kinetic_energy_free", PDLA_H5_F64, &d->res_ke_free, 0);
    if (!rc) rc = attr(r, "/results", "kinetic_energy_stuck", PDLA_H5_F64, &d->res_ke_stuck, 0);
    if (!rc) rc = attr(r, "/results", "box_side", PDLA_H5_F64, &d->L, 0);
    if (!rc) rc = attr(r, "/results", "stop_reason", PDLA_H5_U8, why, sizeof why);
    /* an interrupted run leaves its last series interval open */
    d->ended = !rc && strcmp(why, ev_stop_name(EV_STOP_INTERRUPT)) != 0;
    return rc;
}

/* /parameters: the seeds file (its name), the central seed's radius and
 * the packing. */
static int read_params(const rd *r, evc_data *d)
{
    char seeds[sizeof ((ev_params *)0)->seeds];
    int rc = attr(r, "/parameters", "seeds", PDLA_H5_U8, seeds, sizeof seeds);
    if (!rc) rc = attr(r, "/parameters", "seed-radius", PDLA_H5_F64, &d->seed_radius, 0);
    if (!rc) rc = attr(r, "/parameters", "packing", PDLA_H5_F64, &d->packing, 0);
    /* an empty text parameter is written "(none)" (h5util.c h5u_write_param_table) */
    d->seeds_param = !rc && seeds[0] != '\0' && strcmp(seeds, "(none)") != 0;
    return rc;
}

static int read_species(const rd *r, evc_data *d)
{
    const want w[] = {{"species/count", PDLA_H5_U64, 8, 0, EV_MAX_SPECIES},
                      {"species/radius", PDLA_H5_F64, 8, 0, EV_MAX_SPECIES},
                      {"species/density", PDLA_H5_F64, 8, 0, EV_MAX_SPECIES},
                      {"species/mass", PDLA_H5_F64, 8, 0, EV_MAX_SPECIES},
                      {"species/stuck", PDLA_H5_U64, 8, 0, EV_MAX_SPECIES},
                      {"species/sticky", PDLA_H5_U8, 1, 0, EV_MAX_SPECIES}};
    void *const to[] = {d->kcount, d->krad, d->kdens, d->kmass, d->kstuck, d->ksticky};
    size_t rows = SIZE_MAX;
    int rc = 0;
    for (size_t k = 0; k < sizeof w / sizeof w[0] && !rc; k++) {
        void *buf = NULL;
        rc = dset(r, &w[k], &rows, &buf);
        if (!rc) memcpy(to[k], buf, rows * w[k].esize);
        free(buf);
    }
    if (!rc && rows == 0) rc = bad(r, "/species", "has no kinds");
    d->nsp = (int)rows;
    return rc;
}

/* The stuck particles' rows (/cluster), then the free ones' (/free); at
 * most the engine's 32-bit particle indices. */
static int read_rows(const rd *r, evc_data *d)
{
    const size_t most = UINT32_MAX - EV_MAX_SEEDS, D = (size_t)d->dim;
    const want w[] = {{"cluster/positions", PDLA_H5_F64, 8, (int)D, most},
                      {"cluster/radii", PDLA_H5_F64, 8, 0, most},
                      {"cluster/arrival_time", PDLA_H5_F64, 8, 0, most},
                      {"cluster/parent", PDLA_H5_I64, 8, 0, most},
                      {"cluster/species", PDLA_H5_I32, 4, 0, most},
                      {"cluster/index", PDLA_H5_U32, 4, 0, most},
                      {"free/positions", PDLA_H5_F64, 8, (int)D, most},
                      {"free/velocities", PDLA_H5_F64, 8, (int)D, most},
                      {"free/radii", PDLA_H5_F64, 8, 0, most},
                      {"free/species", PDLA_H5_I32, 4, 0, most}};
    void **const to[] = {(void **)&d->sx, (void **)&d->sr, (void **)&d->st, (void **)&d->spar, (void **)&d->ssp,
                         (void **)&d->sidx, (void **)&d->fx, (void **)&d->fv, (void **)&d->fr, (void **)&d->fsp};
    size_t ns = SIZE_MAX, nf = SIZE_MAX;
    int rc = 0;
    for (size_t k = 0; k < sizeof w / sizeof w[0] && !rc; k++) rc = dset(r, &w[k], k < 6 ? &ns : &nf, to[k]);
    if (!rc && ns + nf > most) rc = bad(r, "/cluster and /free", "hold more particles than the engine indexes");
    d->ns = rc ? 0 : ns;
    d->nf = rc ? 0 : nf;
    return rc;
}

/* The seeds: a --seeds file's datasets, or the one seed's attributes of
 * /cluster (none: no seed). */
static int read_seeds(const rd *r, evc_data *d)
{
    const size_t D = (size_t)d->dim;
    if (d->seeds_param) {
        const want w[] = {{"cluster/seed_positions", PDLA_H5_F64, 8, (int)D, EV_MAX_SEEDS},
                          {"cluster/seed_radii", PDLA_H5_F64, 8, 0, EV_MAX_SEEDS}};
        size_t n = SIZE_MAX;
        int rc = dset(r, &w[0], &n, (void **)&d->seed_x);
        if (!rc) rc = dset(r, &w[1], &n, (void **)&d->seed_r);
        d->nseeds = rc ? 0 : n;
        return rc;
    }
    if (!has_attr(r, "/cluster", "seed_radius")) return 0;
    d->seed_x = malloc(3 * sizeof *d->seed_x);
    d->seed_r = malloc(sizeof *d->seed_r);
    if (!d->seed_x || !d->seed_r) return bad(r, "/cluster", "seed: out of memory");
    static const char *const nm[] = {"seed_x", "seed_y", "seed_z"};
    int rc = attr(r, "/cluster", "seed_radius", PDLA_H5_F64, d->seed_r, 0);
    for (size_t k = 0; k < D && !rc; k++) rc = attr(r, "/cluster", nm[k], PDLA_H5_F64, &d->seed_x[k], 0);
    d->nseeds = rc ? 0 : 1;
    return rc;
}

static int read_series(const rd *r, evc_data *d)
{
    const want w[] = {{"series/time", PDLA_H5_F64, 8, 0, EV_SERIES_MAX},
                      {"series/kinetic_energy", PDLA_H5_F64, 8, 0, EV_SERIES_MAX},
                      {"series/stuck", PDLA_H5_U64, 8, 0, EV_SERIES_MAX},
                      {"series/collisions", PDLA_H5_U64, 8, 0, EV_SERIES_MAX}};
    void **const to[] = {(void **)&d->ser_t, (void **)&d->ser_ke, (void **)&d->ser_stuck, (void **)&d->ser_coll};
    size_t n = SIZE_MAX;
    int rc = 0;
    for (size_t k = 0; k < 4 && !rc; k++) rc = dset(r, &w[k], &n, to[k]);
    d->nser = rc ? 0 : n;
    return rc;
}

int evc_read_file(const char *path, evc_data *d, char *err, size_t errlen)
{
    memset(d, 0, sizeof *d);
    h5u_quiet q;
    if (h5u_silence(&q)) return pdla_errorf(EV_CHECK_DAMAGED, err, errlen, "%s: cannot silence HDF5", path);
    rd r = {H5I_INVALID_HID, path, err, errlen};
    struct stat st;
    /* a regular file only: opening a FIFO blocks */
    int rc = stat(path, &st) != 0 || !S_ISREG(st.st_mode) ? bad(&r, "the path", "is not a regular file") : 0;
    if (!rc && (r.f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT)) < 0) rc = bad(&r, "the file", "cannot be opened");
    if (!rc) rc = read_root(&r, d);
    if (!rc) rc = read_results(&r, d);
    if (!rc) rc = read_params(&r, d);
    if (!rc) rc = read_species(&r, d);
    if (!rc) rc = read_rows(&r, d);
    if (!rc) rc = read_seeds(&r, d);
    if (!rc) rc = read_series(&r, d);
    if (r.f >= 0 && H5Fclose(r.f) < 0 && !rc) rc = bad(&r, "the file", "cannot be closed");
    if (h5u_restore(&q) < 0 && !rc) rc = bad(&r, "HDF5's error handler", "cannot be restored");
    if (rc) evc_data_free(d);
    return rc;
}

/* ---- a loaded checkpoint, through the public accessors ---- */

static int sim_alloc(evc_data *d, size_t nser)
{
    const size_t D = (size_t)d->dim, ns = d->ns ? d->ns : 1, nf = d->nf ? d->nf : 1, m = d->nseeds ? d->nseeds : 1;
    const size_t k = nser ? nser : 1;
    d->seed_x = malloc(m * D * sizeof(double));
    d->seed_r = malloc(m * sizeof(double));
    d->sx = malloc(ns * D * sizeof(double));
    d->sr = malloc(ns * sizeof(double));
    d->st = malloc(ns * sizeof(double));
    d->spar = malloc(ns * sizeof(int64_t));
    d->ssp = malloc(ns * sizeof(int32_t));
    d->sidx = malloc(ns * sizeof(uint32_t));
    d->fx = malloc(nf * D * sizeof(double));
    d->fv = malloc(nf * D * sizeof(double));
    d->fr = malloc(nf * sizeof(double));
    d->fsp = malloc(nf * sizeof(int32_t));
    d->ser_t = malloc(k * sizeof(double));
    d->ser_ke = malloc(k * sizeof(double));
    d->ser_stuck = malloc(k * sizeof(uint64_t));
    d->ser_coll = malloc(k * sizeof(uint64_t));
    return d->seed_x && d->seed_r && d->sx && d->sr && d->st && d->spar && d->ssp && d->sidx && d->fx && d->fv &&
                   d->fr && d->fsp && d->ser_t && d->ser_ke && d->ser_stuck && d->ser_coll
               ? 0
               : -1;
}

/* The kinds, and what the checkpoint holds in place of /results. */
static void sim_header(ev_sim *s, evc_data *d)
{
    const ev_params *p = ev_params_of(s);
    ev_stats st;
    ev_get_stats(s, &st);
    d->dim = ev_dim(s);
    d->periodic = p->walls == EV_WALLS_PERIODIC;
    d->ended = 0; /* a checkpoint may hold an open series interval */
    d->L = st.box;
    d->t = st.t;
    d->packing = p->packing;
    d->particles = ev_count(s);
    d->seeds_param = p->seeds[0] != '\0';
    d->seed_radius = p->seed_radius;
    d->res_stuck = st.stuck;
    d->res_collisions = st.collisions;
    d->res_ke_free = st.ke_free;
    d->res_ke_stuck = st.ke_stuck;
    d->nsp = ev_species_count(s);
    for (int k = 0; k < d->nsp && k < EV_MAX_SPECIES; k++) {
        const ev_species *sp = ev_species_get(s, k);
        d->kcount[k] = sp->count;
        d->krad[k] = sp->radius;
        d->kdens[k] = sp->density;
        /* the masses are derived, not stored: the engine's expression */
        d->kmass[k] = sp->density * ev_particle_volume(d->dim, sp->radius);
        d->ksticky[k] = (uint8_t)sp->sticky;
    }
    d->nseeds = ev_seed_count(s);
    d->nf = ev_count(s) - d->ns;
}

/* The particles' rows, in cluster.h5's order and encoding (ev_out.c). */
static void sim_rows(const ev_sim *s, evc_data *d)
{
    const size_t D = (size_t)d->dim, n = ev_count(s);
    const uint32_t *idx;
    const double *t;
    (void)ev_stuck_list(s, &idx, &t);
    for (size_t a = 0; a < d->nseeds; a++) {
        memcpy(d->seed_x + a * D, ev_pos(s, n + a), D * sizeof(double));
        d->seed_r[a] = ev_radius(s, n + a);
    }
    for (size_t a = 0; a < d->ns; a++) {
        const uint32_t i = idx[a];
        memcpy(d->sx + a * D, ev_pos(s, i), D * sizeof(double));
        d->sr[a] = ev_radius(s, i);
        d->st[a] = t[a];
        d->spar[a] = ev_parent(s, i);
        d->ssp[a] = ev_species_of(s, i);
        d->sidx[a] = i;
        if (d->ssp[a] >= 0 && d->ssp[a] < EV_MAX_SPECIES) d->kstuck[d->ssp[a]]++;
    }
    size_t f = 0;
    for (size_t i = 0; i < n && f < d->nf; i++) {
        if (ev_parent(s, i) != INT64_MIN) continue; /* stuck */
        memcpy(d->fx + f * D, ev_pos(s, i), D * sizeof(double));
        memcpy(d->fv + f * D, ev_vel(s, i), D * sizeof(double));
        d->fr[f] = ev_radius(s, i);
        d->fsp[f] = ev_species_of(s, i);
        f++;
    }
}

int ev_check_sim(ev_sim *s, const ev_series *ser, ev_check_report *r, char *err, size_t errlen)
{
    memset(r, 0, sizeof *r);
    /* positions at the clock: free particles are stored at their own times */
    ev_sync(s);
    evc_data d = {0};
    const uint32_t *idx;
    const double *t;
    d.ns = ev_stuck_list(s, &idx, &t);
    sim_header(s, &d);
    if (sim_alloc(&d, ser->n)) {
        evc_data_free(&d);
        return pdla_errorf(EV_CHECK_DAMAGED, err, errlen, "out of memory copying %zu particles", ev_count(s));
    }
    sim_rows(s, &d);
    d.nser = ser->n;
    if (ser->n) {
        memcpy(d.ser_t, ser->t, ser->n * sizeof *d.ser_t);
        memcpy(d.ser_ke, ser->ke, ser->n * sizeof *d.ser_ke);
        memcpy(d.ser_stuck, ser->stuck, ser->n * sizeof *d.ser_stuck);
        memcpy(d.ser_coll, ser->collisions, ser->n * sizeof *d.ser_coll);
    }
    const int rc = evc_run(&d, r, err, errlen);
    evc_data_free(&d);
    return rc;
}

/* A checkpoint: the loader's own checks first (a refusal is its line),
 * then this check's on what it loaded. */
static int check_checkpoint(const char *path, ev_check_report *r, char *err, size_t errlen)
{
    ev_series ser;
    char e2[1024];
    ev_sim *s = ev_checkpoint_load(path, &ser, e2, sizeof e2);
    if (!s) return pdla_errorf(EV_CHECK_DAMAGED, err, errlen, "%s", e2);
    const int rc = ev_check_sim(s, &ser, r, err, errlen);
    r->checkpoint = 1;
    ev_free(s);
    ev_series_free(&ser);
    return rc;
}

int ev_check_file(const char *path, ev_check_report *r, char *err, size_t errlen)
{
    memset(r, 0, sizeof *r);
    char fmt[64], model[64];
    if (pdla_h5_file_attr(path, "format", fmt, sizeof fmt) == 0 && strcmp(fmt, CKPT_FORMAT) == 0)
        return check_checkpoint(path, r, err, errlen);
    if (pdla_h5_file_model(path, model, sizeof model) != 0 || strcmp(model, "event") != 0)
        return pdla_errorf(EV_CHECK_NOT_EVENT, err, errlen, "%s: not an event-model cluster file or checkpoint", path);
    evc_data d;
    int rc = evc_read_file(path, &d, err, errlen);
    if (!rc) rc = evc_run(&d, r, err, errlen);
    evc_data_free(&d);
    return rc;
}
