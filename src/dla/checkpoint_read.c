/*
 * checkpoint_read.c - pdla_checkpoint_load(): opens a checkpoint written by
 * checkpoint_write.c (layout in checkpoint_fmt.h), checks everything it can
 * (format, version, checksums, shapes against what is stored, the tree's
 * structure and its sums against the stored state, the parameters against
 * what the caller asks) and rebuilds the engine; given a run directory, it
 * takes the newest generation that passes every check.
 */
#define _GNU_SOURCE

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "checkpoint_fmt.h"
#include "engine.h"
#include "fit.h"
#include "h5util.h"
#include "params_h5.h"
#include "pdla/h5check.h"

typedef struct reader {
    const char *path;
    char *err;
    size_t errlen;
} reader;

/* "PATH: what"; returns PDLA_EIO. */
static int rfail(const reader *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int rfail(const reader *r, const char *fmt, ...)
{
    if (r->err && r->errlen) {
        char what[768];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(what, sizeof what, fmt, ap);
        va_end(ap);
        snprintf(r->err, r->errlen, "%s: %s", r->path, what);
        h5u_one_line(r->err);
    }
    return PDLA_EIO;
}

static int damaged(const reader *r, const char *what)
{
    return rfail(r, "damaged checkpoint (%s)", what);
}

/* Closes id (close_fn: H5Gclose, H5Pclose) keeping the first failure: a
 * close that fails fails the load when nothing else has. */
static int close_id(const reader *r, int rc, hid_t id, herr_t (*close_fn)(hid_t), const char *what)
{
    if (id >= 0 && close_fn(id) < 0 && rc == PDLA_OK) return rfail(r, "cannot close %s", what);
    return rc;
}

static int close_dset(const reader *r, int rc, pdla_h5_dset *d, const char *name)
{
    if (pdla_h5_dset_close(d) < 0 && rc == PDLA_OK) return rfail(r, "cannot close dataset %s", name);
    return rc;
}

/* Opens dataset name of element type mtype (class and size) and exact
 * shape; when it has rows, it must carry the Fletcher32 checksum and store
 * what it declares: a forged file may declare 2^40 rows in a few KB, and
 * the loader sizes its memory by the declaration. */
static int open_dset(const reader *r, hid_t loc, const char *name, pdla_h5_type mtype, int rank,
                     hsize_t rows, hsize_t cols, pdla_h5_dset *d)
{
    if (pdla_h5_dset_open(loc, name, d) == 0 && pdla_h5_dset_is(d, mtype) && d->rank == rank &&
        d->dims[0] == rows && (rank == 1 || d->dims[1] == cols) &&
        (rows == 0 || (d->fletcher32 && pdla_h5_dset_stored(d, d->size) == PDLA_H5_STORED)))
        return PDLA_OK;
    (void)pdla_h5_dset_close(d); /* the failure to report is the one below */
    char what[128];
    snprintf(what, sizeof what, "dataset %s missing or of the wrong type or shape", name);
    return damaged(r, what);
}

static int read_rows(const reader *r, const pdla_h5_dset *d, const char *name, pdla_h5_type mtype,
                     hsize_t row0, hsize_t nrows, void *buf)
{
    if (pdla_h5_dset_read(d, mtype, row0, nrows, buf) == 0) return PDLA_OK;
    char what[160];
    snprintf(what, sizeof what, "cannot read %s: checksum or I/O error", name);
    return damaged(r, what);
}

static int read_array(const reader *r, hid_t loc, const char *name, pdla_h5_type mtype, int rank,
                      hsize_t rows, hsize_t cols, void *buf)
{
    pdla_h5_dset d;
    int rc = open_dset(r, loc, name, mtype, rank, rows, cols, &d);
    if (rc) return rc;
    rc = read_rows(r, &d, name, mtype, 0, rows, buf);
    return close_dset(r, rc, &d, name);
}

static int read_params(const reader *r, hid_t file, pdla_params *p)
{
    if (H5Lexists(file, "parameters", H5P_DEFAULT) <= 0) return damaged(r, "no /parameters");
    const hid_t g = H5Gopen2(file, "parameters", H5P_DEFAULT);
    if (g < 0) return damaged(r, "cannot open /parameters");
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    int rc = PDLA_OK;
    for (size_t i = 0; i < n && rc == PDLA_OK; i++) {
        if (pdla_param_read_h5(g, &t[i], p) < 0) {
            char what[96];
            snprintf(what, sizeof what, "parameter %s", t[i].name);
            rc = damaged(r, what);
        }
    }
    rc = close_id(r, rc, g, H5Gclose, "/parameters");
    if (rc) return rc;
    char why[256];
    if (pdla_params_validate(p, why, sizeof why) != PDLA_OK) {
        char what[300];
        snprintf(what, sizeof what, "parameters out of range: %s", why);
        return damaged(r, what);
    }
    return PDLA_OK;
}

/* Applies the caller's parameters (those named by f): a resumable row takes
 * the asked value, any other must equal the checkpoint's; PDLA_EINVAL when
 * one may not change. The target may not drop below the particles held. */
static int apply_asked(const reader *r, pdla_params *p, const pdla_params *a, uint32_t f,
                       uint64_t particles)
{
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    char why[256];
    if (pdla_param_check_asked(t, n, f, p, a, why, sizeof why) != PDLA_OK) {
        if (r->err && r->errlen) snprintf(r->err, r->errlen, "%s: %s", r->path, why);
        return PDLA_EINVAL;
    }
    if ((f & PDLA_PARAM_TARGET) && a->target < particles) {
        if (r->err && r->errlen)
            snprintf(r->err, r->errlen, "%s: target %llu is below the %llu particles it holds",
                     r->path, (unsigned long long)a->target, (unsigned long long)particles);
        return PDLA_EINVAL;
    }
    pdla_param_apply_resumable(t, n, f, p, a);
    if (pdla_params_validate(p, why, sizeof why) != PDLA_OK) {
        if (r->err && r->errlen) snprintf(r->err, r->errlen, "%s: %s", r->path, why);
        return PDLA_EINVAL;
    }
    return PDLA_OK;
}

/* Reads a pool of `records` rows into freshly allocated segments. */
static int read_pool(const reader *r, hid_t g, const char *name, tree_pool *p, uint64_t records,
                     pdla_h5_type mtype, hsize_t cols)
{
    pdla_h5_dset d;
    int rc = open_dset(r, g, name, mtype, 2, records, cols, &d);
    if (rc) return rc;
    const uint32_t nseg = (uint32_t)((records + POOL_SEG_SIZE - 1) / POOL_SEG_SIZE);
    for (uint32_t s = p->nseg; s < nseg; s++) {
        if (!(p->seg[s] = calloc(POOL_SEG_SIZE, p->elem))) {
            (void)pdla_h5_dset_close(&d); /* out of memory is the failure to report */
            if (r->err && r->errlen) snprintf(r->err, r->errlen, "%s: out of memory for the tree", r->path);
            return PDLA_ENOMEM;
        }
        p->nseg = s + 1;
    }
    rc = PDLA_OK;
    for (uint32_t s = 0; rc == PDLA_OK && s < nseg; s++) {
        const uint64_t row0 = (uint64_t)s * POOL_SEG_SIZE;
        const uint64_t n = records - row0 < POOL_SEG_SIZE ? records - row0 : POOL_SEG_SIZE;
        char full[64];
        snprintf(full, sizeof full, "/tree/%s", name);
        rc = read_rows(r, &d, full, mtype, row0, n, p->seg[s]);
    }
    rc = close_dset(r, rc, &d, name);
    if (rc == PDLA_OK) p->count = (uint32_t)records;
    return rc;
}

/* One packed stream (checkpoint_write.c's pack_kind): records first..end-1
 * of `pool`, index bit | i, in the dataset `dset` of `attr` bytes. */
typedef struct unpack_kind {
    const char *dset, *attr;
    uint32_t first, end, bit;
    tree_pool *pool;
    uint32_t records; /* of the pool when done */
} unpack_kind;

/* Allocates the pool's segments for k->records records. */
static int unpack_alloc(const unpack_kind *k)
{
    tree_pool *p = k->pool;
    const uint32_t nseg = (uint32_t)(((uint64_t)k->records + POOL_SEG_SIZE - 1) / POOL_SEG_SIZE);
    for (uint32_t s = p->nseg; s < nseg; s++) {
        if (!(p->seg[s] = calloc(POOL_SEG_SIZE, p->elem))) return PDLA_ENOMEM;
        p->nseg = s + 1;
    }
    p->count = k->records; /* tree_chunk_at needs nothing more */
    return PDLA_OK;
}

/* Unpacks one record from buf at *at (have bytes): 0, or why not. */
static const char *unpack_one(tree *t, const unpack_kind *k, uint32_t i, const uint8_t *buf,
                              size_t have, size_t *at)
{
    const uint32_t link = (uint32_t)buf[*at] | (uint32_t)buf[*at + 1] << 8 |
                          (uint32_t)buf[*at + 2] << 16 | (uint32_t)buf[*at + 3] << 24;
    const uint32_t c = k->bit | i;
    /* Halves: link 0 is a free half, which holds nothing. */
    if (link == 0 && !k->bit) return "an empty chunk";
    if (link != 0 && link <= TREE_CHUNK_CAP && link > tree_cap(c)) return "a chunk filled beyond its slots";
    const size_t m = link ? tree_fill(c, link) : 0;
    if (have - *at < 4 + m * (size_t)t->dim) return "the packed chunks end early";
    *at += 4;
    uint8_t *rec = (uint8_t *)(uintptr_t)tree_chunk_at(t, c);
    for (int a = 0; a < t->dim; a++) {
        memcpy(rec + a * TREE_CHUNK_CAP, buf + *at, m);
        *at += m;
    }
    memcpy(rec + tree_link_offset(t, c), &link, 4);
    return NULL;
}

/* Unpacks a packed stream (see packed_bytes in checkpoint_write.c), reading
 * it a block at a time. */
static int read_chunks(const reader *r, hid_t g, tree *t, const unpack_kind *k)
{
    uint64_t total = 0;
    char what[96];
    if (pdla_h5_attr_exact(g, k->attr, PDLA_H5_U64, &total) < 0) {
        snprintf(what, sizeof what, "/tree %s", k->attr);
        return damaged(r, what);
    }
    const uint64_t n = k->end - k->first, slots = k->bit ? TREE_HALF_CAP : TREE_CHUNK_CAP;
    if (total < n * (k->bit ? 4 : 5) || total > n * (4 + 3 * slots)) {
        snprintf(what, sizeof what, "/tree %s out of range", k->attr);
        return damaged(r, what);
    }
    char full[64];
    snprintf(full, sizeof full, "/tree/%s", k->dset);
    pdla_h5_dset d;
    int rc = open_dset(r, g, k->dset, PDLA_H5_U8, 1, total, 1, &d);
    if (rc) return rc;
    uint8_t *buf = malloc(PACK_BUF_BYTES);
    rc = buf ? unpack_alloc(k) : PDLA_ENOMEM;
    uint64_t pos = 0; /* stream bytes read */
    size_t have = 0, at = 0;
    for (uint32_t i = k->first; rc == PDLA_OK && i < k->end; i++) {
        if (have - at < 4 + 3 * TREE_CHUNK_CAP && pos < total) {
            memmove(buf, buf + at, have - at);
            have -= at;
            at = 0;
            const uint64_t want = total - pos < PACK_BUF_BYTES - have ? total - pos : PACK_BUF_BYTES - have;
            rc = read_rows(r, &d, full, PDLA_H5_U8, pos, want, buf + have);
            if (rc) break;
            pos += want;
            have += (size_t)want;
        }
        const char *bad = have - at < 4 ? "the packed chunks end early" : unpack_one(t, k, i, buf, have, &at);
        if (bad) rc = damaged(r, bad);
    }
    if (rc == PDLA_OK && (at != have || pos != total)) rc = damaged(r, "bytes after the last packed chunk");
    free(buf);
    rc = close_dset(r, rc, &d, full);
    if (rc == PDLA_ENOMEM && r->err && r->errlen)
        snprintf(r->err, r->errlen, "%s: out of memory for the tree", r->path);
    return rc;
}

static int all_zero(const void *p, size_t n)
{
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++)
        if (b[i]) return 0;
    return 1;
}

static unsigned __int128 join128(const uint64_t *w) { return (unsigned __int128)w[1] << 64 | w[0]; }

/* /state relaunches (the straggler bound's count, parallel.c), written
 * since it was added: a checkpoint written before has none and resumes
 * counting from 0, as every resume did then. */
static int load_relaunches(const reader *r, hid_t s, walker_ctx *w)
{
    const htri_t has = H5Aexists(s, "relaunches");
    if (has < 0) return damaged(r, "/state attributes");
    w->relaunches = 0;
    if (has > 0 && pdla_h5_attr_exact(s, "relaunches", PDLA_H5_U64, &w->relaunches) < 0)
        return damaged(r, "/state relaunches");
    return PDLA_OK;
}

/* /state, checked against what the tree's particles give (c): the exact
 * gyration sums, R_ext, the R_g grid position; the random states. */
static int load_state(const reader *r, hid_t file, pdla_engine *e, const tree_verify_sums *cs,
                      uint64_t count)
{
    const tree_verify_sums c = *cs;
    int rc;
    if (H5Lexists(file, "state", H5P_DEFAULT) <= 0) return damaged(r, "no /state");
    const hid_t s = H5Gopen2(file, "state", H5P_DEFAULT);
    if (s < 0) return damaged(r, "cannot open /state");
    rc = PDLA_OK;
    uint64_t gy[4][2], gn = 0, r2 = 0, k = 0, nn = 0;
    int64_t rext = 0;
    int32_t nw = 0;
    walker_ctx *w = &e->walker;
    if (pdla_h5_attr_exact(s, "gyration_n", PDLA_H5_U64, &gn) < 0 ||
        pdla_h5_attr_exact(s, "r_ext2", PDLA_H5_U64, &r2) < 0 ||
        pdla_h5_attr_exact(s, "r_ext", PDLA_H5_I64, &rext) < 0 ||
        pdla_h5_attr_exact(s, "rg_next_k", PDLA_H5_U64, &k) < 0 ||
        pdla_h5_attr_exact(s, "rg_next_n", PDLA_H5_U64, &nn) < 0 ||
        pdla_h5_attr_exact(s, "grow_seconds", PDLA_H5_F64, &e->grow_seconds) < 0 ||
        pdla_h5_attr_exact(s, "parallel_seconds", PDLA_H5_F64, &e->parallel_seconds) < 0 ||
        pdla_h5_attr_exact(s, "walkers", PDLA_H5_U64, &w->walkers) < 0 ||
        pdla_h5_attr_exact(s, "jumps", PDLA_H5_U64, &w->jumps) < 0 ||
        pdla_h5_attr_exact(s, "returns", PDLA_H5_U64, &w->returns) < 0 ||
        pdla_h5_attr_exact(s, "lost", PDLA_H5_U64, &w->lost) < 0 ||
        pdla_h5_attr_exact(s, "killed", PDLA_H5_U64, &w->killed) < 0 ||
        pdla_h5_attr_exact(s, "restarts", PDLA_H5_U64, &w->restarts) < 0 ||
        pdla_h5_attr_exact(s, "node_visits", PDLA_H5_U64, &w->ss.node_visits) < 0 ||
        pdla_h5_attr_exact(s, "particle_checks", PDLA_H5_U64, &w->ss.particle_checks) < 0 ||
        pdla_h5_attr_exact(s, "recheck_overlaps", PDLA_H5_U64, &w->recheck_overlaps) < 0 ||
        pdla_h5_attr_exact(s, "recheck_continued", PDLA_H5_U64, &w->recheck_continued) < 0 ||
        pdla_h5_attr_exact(s, "recheck_discarded", PDLA_H5_U64, &w->recheck_discarded) < 0 ||
        pdla_h5_attr_exact(s, "last_workers", PDLA_H5_I32, &nw) < 0 ||
        pdla_h5_attr_str(s, "binding", e->binding, sizeof e->binding) != 0)
        rc = damaged(r, "/state attributes");
    else if (nw < 0 || nw > 1024)
        rc = damaged(r, "/state last_workers out of range");
    if (rc == PDLA_OK) rc = load_relaunches(r, s, w);
    if (rc == PDLA_OK) rc = read_array(r, s, "gyration", PDLA_H5_U64, 2, 4, 2, gy);
    uint64_t(*rng)[4] = NULL;
    if (rc == PDLA_OK && !(rng = malloc((size_t)(1 + nw) * sizeof *rng))) rc = PDLA_ENOMEM;
    if (rc == PDLA_OK) rc = read_array(r, s, "rng", PDLA_H5_U64, 2, (hsize_t)(1 + nw), 4, rng);
    rc = close_id(r, rc, s, H5Gclose, "/state");
    if (rc == PDLA_OK) {
        memcpy(e->walker.rng.s, rng[0], sizeof rng[0]);
        for (int i = 0; i <= nw && rc == PDLA_OK; i++)
            if (all_zero(rng[i], sizeof rng[i])) rc = damaged(r, "an all-zero random state");
    }
    free(rng);
    if (rc == PDLA_ENOMEM && r->err && r->errlen) snprintf(r->err, r->errlen, "%s: out of memory", r->path);
    if (rc) return rc;
    for (int a = 0; a < 3; a++)
        if ((__int128)join128(gy[a]) != c.s1[a]) return damaged(r, "the gyration sums differ from the particles");
    if (join128(gy[3]) != c.s2 || gn != count) return damaged(r, "the gyration sums differ from the particles");
    if (r2 != c.r2max) return damaged(r, "R_ext differs from the particles");
    if (tree_ceil_sqrt(r2) != rext) return damaged(r, "R_ext differs from the particles");
    for (int a = 0; a < 3; a++) e->gyr.s1[a] = c.s1[a];
    e->gyr.s2 = c.s2;
    e->gyr.n = count;
    e->r_ext2 = r2;
    atomic_store(&e->r_ext, rext);
    if (e->params.rg_per_decade > 0 && count > 0 && nn <= count)
        return damaged(r, "the next R_g sample lies behind the particle count");
    /* The grid position must be the engine's: the first grid point above
     * the count (a forged k of 2^63 stopped the sampling for good; a small
     * one put samples off the shared grid; a later one skipped some). */
    const int pd = e->params.rg_per_decade;
    if (pd > 0 ? nn != fit_rg_grid_at(k, pd) || (k > 0 && fit_rg_grid_at(k - 1, pd) > count) : k != 0 || nn != 1)
        return damaged(r, "the next R_g sample is not the grid's next point");
    if (!(isfinite(e->grow_seconds) && e->grow_seconds >= 0 && e->grow_seconds < 1e12 &&
          isfinite(e->parallel_seconds) && e->parallel_seconds >= 0 && e->parallel_seconds <= e->grow_seconds * (1 + 1e-9) + 1e-6))
        return damaged(r, "/state grow_seconds or parallel_seconds out of range");
    e->rg_next_k = k;
    e->rg_next_n = nn;
    return PDLA_OK;
}

/* The distance map: remade to the shape the run had (/state map_*,
 * checkpoint_write.c), or, for a checkpoint written before they were
 * kept, rebuilt to the size the particles ask for. */
static int load_map(const reader *r, hid_t file, pdla_engine *e)
{
    const hid_t s = H5Gopen2(file, "state", H5P_DEFAULT);
    if (s < 0) return damaged(r, "cannot open /state");
    const htri_t has = H5Aexists(s, "map_half");
    distmap_shape m = {0, 0, 0, 0, NULL};
    int32_t bits = 0;
    uint64_t tw = 0;
    int rc = has < 0 ? damaged(r, "/state attributes") : PDLA_OK;
    if (rc == PDLA_OK && has > 0 &&
        (pdla_h5_attr_exact(s, "map_half", PDLA_H5_I64, &m.half) < 0 ||
         pdla_h5_attr_exact(s, "map_bits", PDLA_H5_I32, &bits) < 0 ||
         pdla_h5_attr_exact(s, "map_particles", PDLA_H5_U64, &m.particles) < 0 ||
         pdla_h5_attr_exact(s, "map_tile_width", PDLA_H5_U64, &tw) < 0))
        rc = damaged(r, "/state map attributes");
    /* The tile flags are read only for a width a run of this size can have
     * (its tile ids took 4 bytes a slot). */
    const uint64_t n = tree_count(&e->tree);
    if (rc == PDLA_OK && (tw > 65536 || tw * tw > 64 * n + (UINT64_C(1) << 20)))
        rc = damaged(r, "/state map_tile_width out of range");
    m.bits = bits;
    m.tw = (uint32_t)tw;
    if (rc == PDLA_OK && tw && !(m.unknown = malloc((size_t)(tw * tw)))) {
        rfail(r, "out of memory for the distance map");
        rc = PDLA_ENOMEM;
    }
    if (rc == PDLA_OK && tw) rc = read_array(r, s, "map_unknown_tiles", PDLA_H5_U8, 1, tw * tw, 1, m.unknown);
    rc = close_id(r, rc, s, H5Gclose, "/state");
    if (rc == PDLA_OK) {
        const int b = has > 0 ? distmap_rebuild_as(&e->dmap, &e->tree, &m) : distmap_rebuild(&e->dmap, &e->tree);
        if (b == 1) rc = damaged(r, "the distance map's shape does not fit the particles");
        else if (b) {
            rfail(r, "out of memory for the distance map");
            rc = PDLA_ENOMEM;
        }
    }
    free(m.unknown);
    return rc;
}

static int load_tree(const reader *r, hid_t file, pdla_engine *e, int version)
{
    tree *t = &e->tree;
    if (H5Lexists(file, "tree", H5P_DEFAULT) <= 0) return damaged(r, "no /tree");
    const hid_t g = H5Gopen2(file, "tree", H5P_DEFAULT);
    if (g < 0) return damaged(r, "cannot open /tree");
    int32_t dim = 0, cb = 0, level = 0;
    uint64_t root = 0, count = 0, leaves = 0, ni = 0, nc = 0, nh = 0;
    int rc = PDLA_OK;
    if (pdla_h5_attr_exact(g, "dim", PDLA_H5_I32, &dim) < 0 ||
        pdla_h5_attr_exact(g, "chunk_bytes", PDLA_H5_I32, &cb) < 0 ||
        pdla_h5_attr_exact(g, "root_level", PDLA_H5_I32, &level) < 0 ||
        pdla_h5_attr_exact(g, "root_node", PDLA_H5_U64, &root) < 0 ||
        pdla_h5_attr_exact(g, "count", PDLA_H5_U64, &count) < 0 ||
        pdla_h5_attr_exact(g, "leaves", PDLA_H5_U64, &leaves) < 0 ||
        pdla_h5_attr_exact(g, "inner_records", PDLA_H5_U64, &ni) < 0 ||
        pdla_h5_attr_exact(g, "chunk_records", PDLA_H5_U64, &nc) < 0 ||
        (version >= 2 && pdla_h5_attr_exact(g, "half_records", PDLA_H5_U64, &nh) < 0))
        rc = damaged(r, "/tree attributes");
    else if (dim != t->dim || (uint32_t)cb != t->chunk_bytes)
        rc = damaged(r, "/tree dim or record size differs from the parameters");
    else if (level < 1 || level > TREE_MAX_LEVEL || ni < 2 || ni > UINT32_MAX || nc < TREE_CHUNK_CAP + 1 ||
             nc > TREE_HALF_BIT || nh > TREE_HALF_BIT / 2 || (dim == 3 && nh) || root == 0 || root >= ni ||
             count > nc * TREE_CHUNK_CAP + 2 * nh * TREE_HALF_CAP || leaves > nc + 2 * nh)
        rc = damaged(r, "/tree sizes out of range");
    if (rc == PDLA_OK)
        rc = read_pool(r, g, "inner", &t->inner, ni, PDLA_H5_U32, (hsize_t)t->nchild);
    const unpack_kind kc = {"chunks_packed", "chunks_packed_bytes", TREE_CHUNK_CAP + 1, (uint32_t)nc, 0,
                            &t->chunks, (uint32_t)nc};
    const unpack_kind kh = {"halves_packed", "halves_packed_bytes", 0, (uint32_t)(2 * nh), TREE_HALF_BIT,
                            &t->halves, (uint32_t)nh};
    if (rc == PDLA_OK) rc = read_chunks(r, g, t, &kc);
    if (rc == PDLA_OK && version >= 2) rc = read_chunks(r, g, t, &kh);
    rc = close_id(r, rc, g, H5Gclose, "/tree");
    if (rc) return rc;
    if (!all_zero(pool_at(&t->inner, 0), t->inner.elem) ||
        !all_zero(pool_at(&t->chunks, 0), (size_t)t->chunks.elem * (TREE_CHUNK_CAP + 1)))
        return damaged(r, "the null records are not empty");
    atomic_store(&t->root_word, (uint64_t)level << 32 | root);
    atomic_store(&t->count, count);
    t->leaves = leaves;

    /* Walk it: structure, and the particles against the stored sums. */
    tree_verify_sums c;
    const char *bad = NULL;
    rc = tree_verify(t, &c, &bad);
    if (rc == PDLA_ENOMEM) {
        if (r->err && r->errlen) snprintf(r->err, r->errlen, "%s: out of memory", r->path);
        return PDLA_ENOMEM;
    }
    if (bad) return damaged(r, bad);
    if (c.count != count) return damaged(r, "the particle count differs from the chunks' fills");
    if (c.leaves != leaves) return damaged(r, "the leaf count differs from the tree");
    if (tree_free_rebuild(t)) {
        if (r->err && r->errlen) snprintf(r->err, r->errlen, "%s: out of memory", r->path);
        return PDLA_ENOMEM;
    }

    return load_state(r, file, e, &c, count);
}

/* --arrival: the arrival order, checked against the tree by the exact
 * gyration sums it must reproduce (Fletcher32 guards the bytes; this guards
 * against a record that belongs to another cluster) and the seed in row 0. */
static int load_arrival(const reader *r, hid_t file, pdla_engine *e)
{
    if (!e->params.record_arrival) return PDLA_OK;
    const uint64_t n = tree_count(&e->tree);
    const size_t dim = (size_t)e->params.dim;
    if (n > SIZE_MAX / (dim * sizeof *e->arrival)) return damaged(r, "too many arrivals");
    int32_t *a = malloc(n ? (size_t)n * dim * sizeof *a : 1);
    if (!a) {
        rfail(r, "out of memory for the arrival order");
        return PDLA_ENOMEM;
    }
    int rc = read_array(r, file, "arrival", PDLA_H5_I32, 2, n, (hsize_t)dim, a);
    if (rc) {
        free(a);
        return rc;
    }
    __extension__ __int128 s1[3] = {0, 0, 0};
    __extension__ unsigned __int128 s2 = 0;
    for (uint64_t i = 0; i < n; i++)
        for (size_t c = 0; c < dim; c++) {
            const int64_t x = a[i * dim + c];
            s1[c] += x;
            s2 += (unsigned __int128)(x * x);
        }
    int seed_ok = 1;
    for (size_t c = 0; c < dim && n > 0; c++) seed_ok &= a[c] == 0;
    if (!seed_ok || s2 != e->gyr.s2 || s1[0] != e->gyr.s1[0] || s1[1] != e->gyr.s1[1] ||
        s1[2] != e->gyr.s1[2]) {
        free(a);
        return damaged(r, "the arrival order does not match the particles");
    }
    free(e->arrival);
    e->arrival = a;
    e->arrival_cap = n;
    return PDLA_OK;
}

static int load_series(const reader *r, hid_t file, pdla_engine *e)
{
    if (H5Lexists(file, "gyration", H5P_DEFAULT) <= 0 ||
        H5Lexists(file, "gyration/N", H5P_DEFAULT) <= 0)
        return damaged(r, "no /gyration/N");
    pdla_h5_dset d;
    if (pdla_h5_dset_open(file, "gyration/N", &d) < 0) return damaged(r, "cannot open /gyration/N");
    const int ok = d.rank == 1;
    const hsize_t k = d.dims[0];
    if (close_dset(r, PDLA_OK, &d, "/gyration/N")) return PDLA_EIO;
    const uint64_t n = tree_count(&e->tree);
    if (!ok || k > 64 * 10000 || k > n) return damaged(r, "/gyration/N of a wrong shape");
    if (k > 0) {
        e->rg_n = malloc(k * sizeof *e->rg_n);
        e->rg_diam = malloc(k * sizeof *e->rg_diam);
        if (!e->rg_n || !e->rg_diam) {
            if (r->err && r->errlen) snprintf(r->err, r->errlen, "%s: out of memory", r->path);
            return PDLA_ENOMEM;
        }
        e->rg_cap = k;
    }
    int rc = read_array(r, file, "gyration/N", PDLA_H5_U64, 1, k, 1, e->rg_n);
    if (rc == PDLA_OK) rc = read_array(r, file, "gyration/rg_diam", PDLA_H5_F64, 1, k, 1, e->rg_diam);
    if (rc) return rc;
    e->rg_count = k;
    if (e->params.rg_per_decade == 0 && k) return damaged(r, "R_g samples with sampling off");
    for (size_t i = 0; i < k; i++)
        if (e->rg_n[i] == 0 || e->rg_n[i] > n || (i && e->rg_n[i] <= e->rg_n[i - 1]) ||
            !(e->rg_diam[i] >= 0 && e->rg_diam[i] < 1e12))
            return damaged(r, "the R_g samples are out of order or range");
    if (k && e->rg_n[k - 1] >= e->rg_next_n) return damaged(r, "the R_g samples pass the next grid point");
    return PDLA_OK;
}

/* Before HDF5 sees it: a regular file (not a directory, FIFO or device)
 * that starts with the HDF5 signature and whose superblock fits in it. */
static int check_file(const reader *r, struct stat *st)
{
    /* O_NONBLOCK: opening a FIFO for reading would wait for a writer. */
    const int fd = open(r->path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) return rfail(r, "cannot open: %s", strerror(errno));
    unsigned char sb[48];
    const int fst = fstat(fd, st);
    /* A directory or a device under a checkpoint name is something put
     * there, not a write a crash damaged: refused (PDLA_EINVAL), so that a
     * run directory's recovery does not fall back past it and rename it
     * aside as checkpoint.damaged.h5 (it did, a directory with its files). */
    if (fst == 0 && S_ISDIR(st->st_mode)) {
        close(fd);
        rfail(r, "is a directory, not a checkpoint (move it away to resume)");
        return PDLA_EINVAL;
    }
    if (fst != 0 || !S_ISREG(st->st_mode)) {
        close(fd);
        if (fst != 0) return rfail(r, "cannot stat: %s", strerror(errno));
        rfail(r, "not a regular file, so not a pdla checkpoint (move it away to resume)");
        return PDLA_EINVAL;
    }
    const ssize_t got = read(fd, sb, sizeof sb);
    close(fd);
    if (got < 8 || memcmp(sb, "\211HDF\r\n\032\n", 8) != 0)
        return rfail(r, "not an HDF5 file, so not a pdla checkpoint");
    /* HDF5 1.10 leaks its internals when it fails to open a truncated file
     * (and then complains on stderr at exit), so the superblock's end-of-file
     * address is checked first. Checkpoints have a version 2/3 superblock
     * with 8-byte addresses: signature, version, sizes, flags, then base,
     * extension, end-of-file and root addresses. Other HDF5 files go on to
     * HDF5, which tells why they are not checkpoints. */
    if (got == (ssize_t)sizeof sb && (sb[8] == 2 || sb[8] == 3) && sb[9] == 8 && sb[10] == 8) {
        uint64_t base = 0, eof = 0;
        for (int i = 7; i >= 0; i--) {
            base = base << 8 | sb[12 + i];
            eof = eof << 8 | sb[28 + i];
        }
        if (base != 0 || eof > (uint64_t)st->st_size || eof < 48)
            return damaged(r, eof > (uint64_t)st->st_size ? "truncated" : "superblock");
    } else if (got < (ssize_t)sizeof sb) {
        return damaged(r, "truncated");
    }
    return PDLA_OK;
}

/* The root attributes: a pdla checkpoint, of this format version, in a
 * byte order this machine reads. */
static int check_root(const reader *r, hid_t file, uint64_t *generation, uint64_t *particles,
                      int *version)
{
    char fmt[64];
    int32_t ver = 0;
    const htri_t has_format = H5Aexists(file, "format");
    if (has_format < 0) /* the root group's header does not read back */
        return damaged(r, "the root group cannot be read");
    if (has_format == 0) return rfail(r, "an HDF5 file but not a pdla checkpoint (no format attribute)");
    if (pdla_h5_attr_str(file, "format", fmt, sizeof fmt) != 0)
        return damaged(r, "the format attribute cannot be read");
    if (strcmp(fmt, FORMAT_NAME) != 0)
        return rfail(r, "an HDF5 file but not a pdla checkpoint (format '%s')", fmt);
    if (pdla_h5_attr_exact(file, "format_version", PDLA_H5_I32, &ver) < 0)
        return damaged(r, "no format_version");
    if (ver < 1 || ver > FORMAT_VERSION)
        return rfail(r, "checkpoint format version %d; this pdla reads versions 1 to %d", (int)ver,
                     FORMAT_VERSION);
    *version = (int)ver;
    char order[16];
    if (pdla_h5_attr_str(file, "record_byte_order", order, sizeof order) != 0 ||
        pdla_h5_attr_exact(file, "generation", PDLA_H5_U64, generation) < 0 ||
        pdla_h5_attr_exact(file, "particles", PDLA_H5_U64, particles) < 0)
        return damaged(r, "root attributes");
    /* A run writes one generation per checkpoint, never near 2^62; a forged
     * 2^64 - 1 loaded, and the next write's generation wrapped to 0, so the
     * next resume took the old file as the newest and went back in time. */
    if (*generation >= CKPT_GENERATION_MAX)
        return rfail(r, "damaged checkpoint (root generation %" PRIu64 " out of range: at most 2^62 - 1)",
                     *generation);
    const uint16_t probe = 1;
    if (strcmp(order, "little") != 0 || *(const uint8_t *)&probe != 1)
        return rfail(r, "records in byte order '%s' cannot be read on this machine", order);
    return PDLA_OK;
}

/* The writer's checkpoint schedule (optional: files before session 26 have
 * none) and the compression flag, into info. */
static int read_schedule(const reader *r, hid_t file, pdla_checkpoint_info *info)
{
    const htri_t hs = H5Aexists(file, "schedule_every_seconds"), hp = H5Aexists(file, "schedule_every_particles");
    const htri_t hc = H5Aexists(file, "compressed");
    if (hs < 0 || hp < 0 || hc < 0) return damaged(r, "the root group cannot be read");
    double every = 0;
    uint64_t parts = 0;
    int32_t comp = 0;
    if ((hs > 0 && (pdla_h5_attr_exact(file, "schedule_every_seconds", PDLA_H5_F64, &every) < 0 ||
                    !(every >= 0 && every <= 1e9))) ||
        (hp > 0 && pdla_h5_attr_exact(file, "schedule_every_particles", PDLA_H5_U64, &parts) < 0) ||
        (hc > 0 && (pdla_h5_attr_exact(file, "compressed", PDLA_H5_I32, &comp) < 0 || (comp != 0 && comp != 1))))
        return damaged(r, "its checkpoint schedule (schedule_every_seconds, schedule_every_particles, compressed)");
    if (info) {
        info->has_schedule = hs > 0 && hp > 0;
        info->every_seconds = every;
        info->every_particles = parts;
        info->compressed = comp;
    }
    return PDLA_OK;
}

/* The root's generation of the checkpoint at path, without loading the
 * rest: a damaged file the loader skipped may still name its generation
 * (a checksum error in a dataset leaves the root readable), and
 * pdla_checkpoint_recover numbers the next write past it. 0, or -1 when the
 * file is not a checkpoint whose root reads (truncated, foreign, missing).
 * The caller silences HDF5's error stack. */
static int ckpt_peek_root(const char *path, uint64_t *generation, uint64_t *particles);

int ckpt_peek_generation(const char *path, uint64_t *generation)
{
    uint64_t particles;
    return ckpt_peek_root(path, generation, &particles);
}

int pdla_checkpoint_peek(const char *path, uint64_t *generation, uint64_t *particles)
{
    /* no place for the numbers: refused, not a write through NULL */
    if (!path || !generation || !particles) return PDLA_EINVAL;
    h5u_quiet q;
    if (h5u_silence(&q) < 0) return PDLA_EIO;
    const int rc = ckpt_peek_root(path, generation, particles);
    return h5u_restore(&q) < 0 || rc ? PDLA_EIO : PDLA_OK;
}

/* ckpt_peek_generation with the root's particle count too. */
static int ckpt_peek_root(const char *path, uint64_t *generation, uint64_t *particles)
{
    char scratch[1024];
    const reader rr = {path, scratch, sizeof scratch}, *r = &rr;
    struct stat st;
    if (check_file(r, &st)) return -1;
    const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    if (fapl < 0 || H5Pset_fapl_sec2(fapl) < 0) {
        close_id(r, PDLA_EIO, fapl, H5Pclose, "the file access properties"); /* -1 either way */
        return -1;
    }
    const hid_t file = H5Fopen(path, H5F_ACC_RDONLY, fapl);
    int rc = close_id(r, PDLA_OK, fapl, H5Pclose, "the file access properties");
    if (file < 0) return -1;
    int version = 0;
    if (rc == PDLA_OK) rc = check_root(r, file, generation, particles, &version);
    if (H5Fclose(file) < 0) rc = PDLA_EIO;
    return rc == PDLA_OK ? 0 : -1;
}

/* One file: every check; *out on success. */
static int load_file(const char *path, const pdla_params *asked, uint32_t fields,
                     pdla_engine **out, pdla_checkpoint_info *info, char *err, size_t errlen)
{
    const reader rr = {path, err, errlen}, *r = &rr;
    *out = NULL;
    if (ckpt_is_tmp_name(path)) return rfail(r, "an unfinished temporary checkpoint; not loaded");
    struct stat st;
    const int crc = check_file(r, &st);
    if (crc) return crc;

    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    /* Not H5F_CLOSE_STRONG here: with it, HDF5 1.10.8 keeps some internals
     * of a read-only file alive past the close (and reports an "infinite
     * loop closing library" at exit); the loader closes every id itself. */
    if (fapl < 0 || H5Pset_fapl_sec2(fapl) < 0)
        return close_id(r, rfail(r, "cannot set up HDF5"), fapl, H5Pclose, "");
    const hid_t file = H5Fopen(path, H5F_ACC_RDONLY, fapl);
    int rc = close_id(r, PDLA_OK, fapl, H5Pclose, "the file access properties");
    if (file < 0) return rc ? rc : damaged(r, "HDF5 cannot open it: truncated or corrupt");
    pdla_engine *e = NULL;
    uint64_t generation = 0, particles = 0;
    int version = 0;
    if (rc || (rc = check_root(r, file, &generation, &particles, &version))) goto out;
    if ((rc = read_schedule(r, file, info))) goto out;
    pdla_params p;
    if ((rc = read_params(r, file, &p))) goto out;
    if (asked && (rc = apply_asked(r, &p, asked, fields, particles))) goto out;
    char why[256];
    if ((rc = pdla_engine_create(&e, &p, why, sizeof why))) {
        rfail(r, "%s", why);
        goto out;
    }
    if ((rc = load_tree(r, file, e, version))) goto out;
    if (tree_count(&e->tree) != particles) {
        rc = damaged(r, "the particle count differs from the tree");
        goto out;
    }
    if ((rc = load_series(r, file, e))) goto out;
    if ((rc = load_arrival(r, file, e))) goto out;
    if ((rc = load_map(r, file, e))) goto out;
    e->ckpt_generation = generation;
    if (info) {
        info->slot = -1; /* a file named; the directory walk sets its name's */
        snprintf(info->path, sizeof info->path, "%s", path);
        info->generation = generation;
        info->particles = particles;
        info->bytes = (uint64_t)st.st_size;
    }
out:
    if (H5Fclose(file) < 0 && rc == PDLA_OK) rc = damaged(r, "cannot close it");
    if (rc) {
        pdla_engine_destroy(e);
        return rc;
    }
    *out = e;
    return PDLA_OK;
}

int ckpt_load_name(const char *name, const pdla_params *asked, uint32_t fields, pdla_engine **out,
                   pdla_checkpoint_info *info, char *err, size_t errlen)
{
    char model[32];
    *out = NULL;
    /* Another model's checkpoint (a DLCA or event run's, whole) is not a
     * damaged generation to fall back past (the recovery would then set it
     * aside as damaged): refused. */
    if (pdla_h5_file_model(name, model, sizeof model) == 0)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: another model's file (model '%s'), not a DLA checkpoint "
                           "(resume it with --model)", name, model);
    return load_file(name, asked, fields, out, info, err, errlen);
}

int ckpt_foreign_names(const char *dir, char *err, size_t errlen)
{
    char name[4200];
    for (int k = 0; k < PDLA_CHECKPOINT_GENERATIONS; k++) {
        ckpt_gen_name(name, sizeof name, dir, k);
        struct stat st; /* through a link: a dangling one is a name the writes replace */
        if (stat(name, &st) != 0 || S_ISREG(st.st_mode)) continue;
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s: %s, not a checkpoint (move it away to resume)", name,
                           S_ISDIR(st.st_mode) ? "is a directory" : "not a regular file");
    }
    return PDLA_OK;
}

/* One generation's reason: its name (a run directory of up to 4000 bytes,
 * pdla_checkpoint_load) and rfail's what, whole: at 1024 bytes a long run
 * directory's reasons were cut inside the name. */
#define CKPT_REASON_MAX 4800

int pdla_checkpoint_load(pdla_engine **out, const char *path, const pdla_params *asked,
                         uint32_t asked_fields, pdla_checkpoint_info *info, char *err,
                         size_t errlen)
{
    const double t0 = pdla_clock_seconds();
    *out = NULL;
    if (err && errlen) err[0] = '\0';
    if (info) memset(info, 0, sizeof *info);
    if (!path || !path[0] || strlen(path) > 4000) {
        if (err && errlen) snprintf(err, errlen, "no (or too long a) checkpoint path");
        return PDLA_EINVAL;
    }
    h5u_quiet q;
    if (h5u_silence(&q) < 0) {
        if (err && errlen) snprintf(err, errlen, "cannot silence the HDF5 error stack");
        return PDLA_EIO;
    }
    struct stat st;
    int rc;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
        /* A run directory: the newest generation that passes every check. */
        /* every failed generation's reason, oldest last: a resume that
         * finds none usable names them all, not only the newest */
        char name[4200], all_err[PDLA_CHECKPOINT_GENERATIONS * CKPT_REASON_MAX] = "", note[1024] = "";
        size_t used = 0;
        int found = 0;
        /* every name, not only those up to the one that loads: the writes
         * rotate them all */
        const int foreign = ckpt_foreign_names(path, err, errlen);
        rc = foreign ? foreign : PDLA_EIO;
        for (int k = 0; !foreign && k < PDLA_CHECKPOINT_GENERATIONS; k++) {
            ckpt_gen_name(name, sizeof name, path, k);
            if (access(name, F_OK) != 0) continue;
            found++;
            char e1[CKPT_REASON_MAX] = "";
            rc = ckpt_load_name(name, asked, asked_fields, out, info, e1, sizeof e1);
            if (rc == PDLA_OK && info) info->slot = k;
            if (rc == PDLA_OK || rc == PDLA_EINVAL || rc == PDLA_ENOMEM) {
                if (rc != PDLA_OK && err && errlen) snprintf(err, errlen, "%s", e1);
                break;
            }
            if (used < sizeof all_err) {
                const int n = snprintf(all_err + used, sizeof all_err - used, "%s%s", used ? "; " : "", e1);
                if (n > 0) used += (size_t)n;
            }
            if (!note[0]) snprintf(note, sizeof note, "skipped %s", e1);
        }
        if (foreign) {
            /* err says which name */
        } else if (!found) {
            if (err && errlen) snprintf(err, errlen, "%s: no checkpoint in this directory", path);
            rc = PDLA_EIO;
        } else if (rc == PDLA_EIO) {
            if (err && errlen) snprintf(err, errlen, "%s", all_err);
        } else if (rc == PDLA_OK && info && note[0]) {
            snprintf(info->note, sizeof info->note, "%s", note);
        }
    } else {
        rc = load_file(path, asked, asked_fields, out, info, err, errlen);
    }
    if (h5u_restore(&q) < 0 && rc == PDLA_OK) {
        pdla_engine_destroy(*out);
        *out = NULL;
        rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot restore the HDF5 error handler");
    }
    if (rc == PDLA_OK && info) info->seconds = pdla_clock_seconds() - t0;
    if (err && errlen) h5u_one_line(err);
    return rc;
}
