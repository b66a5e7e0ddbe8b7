/*
 * checkpoint_write.c - pdla_checkpoint_write(): the whole state of an engine
 * between two grow calls, in one HDF5 file (layout in checkpoint_fmt.h),
 * written to a temporary name, synced, and moved into place while the older
 * generations shift; and pdla_checkpoint_remove_stale() for the temporary
 * files a killed writer leaves. Reading is in checkpoint_read.c.
 */
#define _GNU_SOURCE

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "checkpoint_fmt.h"
#include "engine.h"
#include "h5util.h"
#include "provenance.h"

#define SERIES_ROWS 65536u
/* Rows per HDF5 chunk of /tree/inner (HDF5 stores the last, partial chunk
 * at full size, so this bounds the waste), and bytes per HDF5 chunk of the
 * packed chunk stream. */
#define POOL_CHUNK_ROWS 4096u
#define PACK_CHUNK_BYTES (UINT64_C(1) << 18)

/* Writes pool records [0, count) as rows of `cols` elements of type ftype,
 * segment by segment straight from the pool's memory. */
static int write_pool(const h5u_writer *w, hid_t g, const char *name, const tree_pool *p,
                      hid_t ftype, hid_t mtype, hsize_t cols, int gzip)
{
    hid_t space = H5I_INVALID_HID, d = H5I_INVALID_HID, ms = H5I_INVALID_HID;
    int rc = -1;
    if ((d = h5u_dataset_z(w, g, name, ftype, 2, p->count, cols, POOL_CHUNK_ROWS, gzip, &space)) < 0)
        goto fail;
    for (uint32_t s = 0; (uint64_t)s * POOL_SEG_SIZE < p->count; s++) {
        const hsize_t start[2] = {(hsize_t)s * POOL_SEG_SIZE, 0};
        const hsize_t left = p->count - start[0];
        const hsize_t count[2] = {left < POOL_SEG_SIZE ? left : POOL_SEG_SIZE, cols};
        if (H5Sselect_hyperslab(space, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
            (ms = H5Screate_simple(2, count, NULL)) < 0 ||
            H5Dwrite(d, mtype, ms, space, H5P_DEFAULT, p->seg[s]) < 0) {
            h5u_fail(w, "write /tree/%s", name);
            goto fail;
        }
        const herr_t closed = H5Sclose(ms);
        ms = H5I_INVALID_HID;
        if (closed < 0) {
            h5u_fail(w, "close a memory dataspace of /tree/%s", name);
            goto fail;
        }
    }
    rc = 0;
fail:
    rc = h5u_close(w, rc, ms, H5Sclose, "a memory dataspace");
    rc = h5u_close(w, rc, space, H5Sclose, "a pool dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

static int write_array(const h5u_writer *w, hid_t g, const char *name, hid_t ftype, hid_t mtype,
                       int rank, hsize_t rows, hsize_t cols, const void *data)
{
    hid_t space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    int rc = -1;
    if ((d = h5u_dataset(w, g, name, ftype, rank, rows, cols, SERIES_ROWS, &space)) < 0) goto fail;
    if (rows > 0 && H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
        h5u_fail(w, "write %s", name);
        goto fail;
    }
    rc = 0;
fail:
    rc = h5u_close(w, rc, space, H5Sclose, "a dataspace");
    return h5u_close(w, rc, d, H5Dclose, name);
}

/* The packed streams: per chunk record from index 11 on (halves: per half
 * id from 0 on), its link (u32 little-endian: the next chunk, or for a
 * leaf's last chunk its fill 1..10; 0 for a free half) and then, axis by
 * axis, the relative coordinates of the particles it holds (fill bytes
 * each). The unused slots of partly filled chunks are not stored (they are
 * zero in memory), which makes a 2D particle cost ~2 bytes instead of the
 * pool's ~3. */
typedef struct pack_kind {
    const char *dset, *attr;
    uint32_t first, end, bit; /* records first..end-1, index = bit | i */
} pack_kind;

static pack_kind pack_chunks(const tree *t)
{
    return (pack_kind){"chunks_packed", "chunks_packed_bytes", TREE_CHUNK_CAP + 1, t->chunks.count, 0};
}

static pack_kind pack_halves(const tree *t)
{
    return (pack_kind){"halves_packed", "halves_packed_bytes", 0, 2 * t->halves.count, TREE_HALF_BIT};
}

static uint64_t packed_bytes(const tree *t, const pack_kind *k)
{
    uint64_t n = 0;
    for (uint32_t i = k->first; i < k->end; i++) {
        const uint32_t c = k->bit | i;
        const uint32_t link = tree_chunk_link(t, c, tree_chunk_at(t, c));
        n += 4 + (uint64_t)(link ? tree_fill(c, link) : 0) * (uint64_t)t->dim;
    }
    return n;
}

static int flush_packed(const h5u_writer *w, hid_t d, hid_t space, const uint8_t *buf, size_t fill,
                        uint64_t *written, const char *name)
{
    if (fill == 0) return 0;
    const hsize_t start = *written, count = fill;
    const hid_t ms = H5Screate_simple(1, &count, NULL);
    const int ok = ms >= 0 && H5Sselect_hyperslab(space, H5S_SELECT_SET, &start, NULL, &count, NULL) >= 0 &&
                   H5Dwrite(d, H5T_NATIVE_UINT8, ms, space, H5P_DEFAULT, buf) >= 0;
    if (!ok) return h5u_close(w, h5u_fail(w, "write /tree/%s", name), ms, H5Sclose, "");
    if (H5Sclose(ms) < 0) return h5u_fail(w, "close a memory dataspace of /tree/%s", name);
    *written += fill;
    return 0;
}

static int write_chunks(const h5u_writer *w, hid_t g, const tree *t, int gzip, const pack_kind *k)
{
    const uint64_t total = packed_bytes(t, k);
    hid_t space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    uint8_t *buf = NULL;
    int rc = -1;
    if (h5u_attr_u64(w, g, k->attr, total) < 0) return -1;
    if ((d = h5u_dataset_z(w, g, k->dset, H5T_STD_U8LE, 1, total, 1, PACK_CHUNK_BYTES, gzip, &space)) < 0)
        goto fail;
    if (!(buf = malloc(PACK_BUF_BYTES))) {
        h5u_fail_msg(w, "out of memory");
        goto fail;
    }
    size_t fill = 0;
    uint64_t written = 0;
    for (uint32_t i = k->first; i < k->end; i++) {
        const uint32_t c = k->bit | i;
        const uint8_t *rec = tree_chunk_at(t, c);
        const uint32_t link = tree_chunk_link(t, c, rec);
        const size_t m = link ? tree_fill(c, link) : 0;
        if (fill + 4 + TREE_CHUNK_CAP * 3 > PACK_BUF_BYTES) {
            if (flush_packed(w, d, space, buf, fill, &written, k->dset) < 0) goto fail;
            fill = 0;
        }
        for (int b = 0; b < 4; b++) buf[fill++] = (uint8_t)(link >> (8 * b));
        for (int a = 0; a < t->dim; a++) {
            memcpy(buf + fill, rec + a * TREE_CHUNK_CAP, m);
            fill += m;
        }
    }
    if (flush_packed(w, d, space, buf, fill, &written, k->dset) < 0) goto fail;
    if (written != total) {
        h5u_fail_msg(w, "internal error: packed %llu of %llu bytes of /tree/%s", (unsigned long long)written,
                     (unsigned long long)total, k->dset);
        goto fail;
    }
    rc = 0;
fail:
    free(buf);
    rc = h5u_close(w, rc, space, H5Sclose, "a packed stream's dataspace");
    return h5u_close(w, rc, d, H5Dclose, k->dset);
}

static int write_tree(const h5u_writer *w, hid_t file, const tree *t, int gzip)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    const tree_root r = tree_root_get(t);
    if ((g = h5u_group(w, file, "tree")) < 0) goto fail;
    if (h5u_attr_int(w, g, "dim", t->dim) < 0 ||
        h5u_attr_int(w, g, "chunk_bytes", (int)t->chunk_bytes) < 0 ||
        h5u_attr_int(w, g, "root_level", r.level) < 0 ||
        h5u_attr_u64(w, g, "root_node", r.node) < 0 || h5u_attr_u64(w, g, "count", tree_count(t)) < 0 ||
        h5u_attr_u64(w, g, "leaves", t->leaves) < 0 ||
        h5u_attr_u64(w, g, "inner_records", t->inner.count) < 0 ||
        h5u_attr_u64(w, g, "chunk_records", t->chunks.count) < 0 ||
        h5u_attr_u64(w, g, "half_records", t->halves.count) < 0 ||
        write_pool(w, g, "inner", &t->inner, H5T_STD_U32LE, H5T_NATIVE_UINT32,
                   (hsize_t)t->nchild, gzip) < 0)
        goto fail;
    const pack_kind kc = pack_chunks(t), kh = pack_halves(t);
    if (write_chunks(w, g, t, gzip, &kc) < 0 || write_chunks(w, g, t, gzip, &kh) < 0)
        goto fail;
    rc = 0;
fail:
    return h5u_close(w, rc, g, H5Gclose, "/tree");
}

/* The counters of the engine walker and the last workers, summed. */
static void sum_counters(const pdla_engine *e, walker_ctx *s)
{
    *s = e->walker;
    for (int i = 0; i < e->nworkers; i++) walker_ctx_add_counts(s, &e->workers[i]);
}

static void split128(unsigned __int128 v, uint64_t *out)
{
    out[0] = (uint64_t)v;
    out[1] = (uint64_t)(v >> 64);
}

/* The distance map's shape (distmap_shape), so that a resumed run remakes
 * the grid the run had: map_half (0: no map), map_bits, map_particles,
 * map_tile_width and, when that is not 0, map_unknown_tiles (u8, one flag
 * per tile slot: dropped as interior). */
static int write_map(const h5u_writer *w, hid_t g, const pdla_engine *e)
{
    distmap_shape s;
    if (distmap_shape_get(&e->dmap, &s)) return h5u_fail_msg(w, "out of memory");
    int rc = h5u_attr_i64(w, g, "map_half", s.half) < 0 || h5u_attr_int(w, g, "map_bits", s.bits) < 0 ||
                     h5u_attr_u64(w, g, "map_particles", s.particles) < 0 ||
                     h5u_attr_u64(w, g, "map_tile_width", s.tw) < 0
                 ? -1
                 : 0;
    if (rc == 0 && s.tw)
        rc = write_array(w, g, "map_unknown_tiles", H5T_STD_U8LE, H5T_NATIVE_UINT8, 1,
                         (hsize_t)s.tw * s.tw, 1, s.unknown);
    free(s.unknown);
    return rc;
}

static int write_state(const h5u_writer *w, hid_t file, const pdla_engine *e)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    walker_ctx c;
    sum_counters(e, &c);
    uint64_t gy[4][2];
    for (int a = 0; a < 3; a++) split128((unsigned __int128)e->gyr.s1[a], gy[a]);
    split128(e->gyr.s2, gy[3]);
    const size_t nr = 1 + (size_t)e->nworkers;
    uint64_t(*rng)[4] = malloc(nr * sizeof *rng);
    if (!rng) return h5u_fail_msg(w, "out of memory");
    memcpy(rng[0], e->walker.rng.s, sizeof rng[0]);
    for (int i = 0; i < e->nworkers; i++) memcpy(rng[1 + i], e->workers[i].rng.s, sizeof rng[0]);
    if ((g = h5u_group(w, file, "state")) < 0) goto fail;
    if (h5u_attr_u64(w, g, "gyration_n", e->gyr.n) < 0 || h5u_attr_u64(w, g, "r_ext2", e->r_ext2) < 0 ||
        h5u_attr_i64(w, g, "r_ext", atomic_load(&e->r_ext)) < 0 ||
        h5u_attr_u64(w, g, "rg_next_k", e->rg_next_k) < 0 ||
        h5u_attr_u64(w, g, "rg_next_n", e->rg_next_n) < 0 ||
        h5u_attr_f64(w, g, "grow_seconds", e->grow_seconds) < 0 ||
        h5u_attr_f64(w, g, "parallel_seconds", e->parallel_seconds) < 0 ||
        h5u_attr_u64(w, g, "walkers", c.walkers) < 0 || h5u_attr_u64(w, g, "jumps", c.jumps) < 0 ||
        h5u_attr_u64(w, g, "returns", c.returns) < 0 || h5u_attr_u64(w, g, "lost", c.lost) < 0 ||
        h5u_attr_u64(w, g, "killed", c.killed) < 0 || h5u_attr_u64(w, g, "restarts", c.restarts) < 0 ||
        h5u_attr_u64(w, g, "node_visits", c.ss.node_visits) < 0 ||
        h5u_attr_u64(w, g, "particle_checks", c.ss.particle_checks) < 0 ||
        h5u_attr_u64(w, g, "recheck_overlaps", c.recheck_overlaps) < 0 ||
        h5u_attr_u64(w, g, "recheck_continued", c.recheck_continued) < 0 ||
        h5u_attr_u64(w, g, "recheck_discarded", c.recheck_discarded) < 0 ||
        h5u_attr_u64(w, g, "relaunches", c.relaunches) < 0 ||
        h5u_attr_int(w, g, "last_workers", e->nworkers) < 0 ||
        h5u_attr_str(w, g, "binding", e->binding) < 0 ||
        write_array(w, g, "gyration", H5T_STD_U64LE, H5T_NATIVE_UINT64, 2, 4, 2, gy) < 0 ||
        write_array(w, g, "rng", H5T_STD_U64LE, H5T_NATIVE_UINT64, 2, nr, 4, rng) < 0 ||
        write_map(w, g, e) < 0)
        goto fail;
    rc = 0;
fail:
    free(rng);
    return h5u_close(w, rc, g, H5Gclose, "/state");
}

static int write_series(const h5u_writer *w, hid_t file, const pdla_engine *e)
{
    hid_t g = H5I_INVALID_HID;
    int rc = -1;
    if ((g = h5u_group(w, file, "gyration")) < 0) goto fail;
    if (write_array(w, g, "N", H5T_STD_U64LE, H5T_NATIVE_UINT64, 1, e->rg_count, 1, e->rg_n) < 0 ||
        write_array(w, g, "rg_diam", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, e->rg_count, 1,
                    e->rg_diam) < 0)
        goto fail;
    rc = 0;
fail:
    return h5u_close(w, rc, g, H5Gclose, "/gyration");
}

/* --arrival: the positions in arrival order, which the tree cannot give back. */
static int write_arrival(const h5u_writer *w, hid_t file, const pdla_engine *e)
{
    uint64_t n = 0;
    const int32_t *a = pdla_engine_arrival(e, &n);
    if (!a) return 0;
    return write_array(w, file, "arrival", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, n,
                       (hsize_t)e->params.dim, a);
}

/* Bytes the file will take, from above: the pools, the series, the
 * states, plus 1 MiB and 1/512 for HDF5's metadata and chunk index. */
static uint64_t size_bound(const pdla_engine *e)
{
    const uint64_t arrival = e->params.record_arrival
                                 ? tree_count(&e->tree) * (uint64_t)e->params.dim * 4
                                 : 0;
    const uint64_t data = (uint64_t)tree_bytes(&e->tree) + arrival + (uint64_t)e->rg_count * 16 +
                          (uint64_t)(1 + e->nworkers) * 32 + 4096;
    return data + (UINT64_C(1) << 20) + data / 512;
}

/* Reserve disk blocks for the whole file now, while a refusal is still
 * harmless (FALLOC_FL_KEEP_SIZE: HDF5 keeps deciding the size; the close's
 * h5u_reserve_space and h5u_trim_and_sync give back the rest). */
static int reserve_early(const h5u_writer *w, hid_t file, uint64_t bytes)
{
    void *handle = NULL;
    if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || handle == NULL)
        return h5u_fail(w, "get the descriptor of the temporary file");
    const int fd = *(const int *)handle;
    if (fallocate(fd, FALLOC_FL_KEEP_SIZE, 0, (off_t)bytes) == 0) return 0;
    if (errno == EOPNOTSUPP || errno == ENOSYS || errno == EINVAL) return 0;
    return h5u_fail_msg(w, "cannot reserve %llu bytes: %s", (unsigned long long)bytes,
                        strerror(errno));
}

static int write_ckpt_file(const h5u_writer *w, const char *tmp, const pdla_engine *e,
                           const pdla_checkpoint_opts *o, uint64_t generation)
{
    hid_t file = H5I_INVALID_HID;
    int rc = -1;
    pdla_provenance pv;
    (void)prov_collect(&pv);
    const int gzip = o && o->compress ? 1 : 0;
    if ((file = h5u_create_file(w, tmp)) < 0) goto fail;
    if (reserve_early(w, file, size_bound(e)) < 0) goto fail;
    if (h5u_attr_str(w, file, "format", FORMAT_NAME) < 0 ||
        h5u_attr_int(w, file, "format_version", FORMAT_VERSION) < 0 ||
        h5u_attr_u64(w, file, "generation", generation) < 0 ||
        h5u_attr_u64(w, file, "particles", tree_count(&e->tree)) < 0 ||
        h5u_attr_f64(w, file, "pause_seconds", o ? o->pause_seconds : 0.0) < 0 ||
        h5u_attr_f64(w, file, "previous_write_seconds", e->ckpt_write_seconds) < 0 ||
        h5u_attr_int(w, file, "compressed", gzip) < 0 ||
        h5u_attr_f64(w, file, "schedule_every_seconds", o ? o->every_seconds : 0.0) < 0 ||
        h5u_attr_u64(w, file, "schedule_every_particles", o ? o->every_particles : 0) < 0 ||
        h5u_attr_str(w, file, "record_byte_order", "little") < 0 ||
        h5u_write_parameters(w, file, &e->params) < 0 || write_tree(w, file, &e->tree, gzip) < 0 ||
        write_state(w, file, e) < 0 || write_series(w, file, e) < 0 ||
        write_arrival(w, file, e) < 0 || h5u_write_code(w, file, &pv, o ? o->command_line : NULL) < 0)
        goto fail;
    if (h5u_reserve_space(w, file, tmp) < 0) goto fail;
    rc = 0;
fail:
    if (rc < 0 && file >= 0) h5u_divert_writes(file);
    return h5u_close(w, rc, file, H5Fclose, tmp);
}

/* A write that fails half-way leaves HDF5 1.10 in a state it may crash on
 * at exit (see h5util.c h5u_divert_writes), so what can be known beforehand
 * is checked beforehand: the free space, the file size limit (ulimit -f);
 * then the temporary file is made, and disk blocks are reserved for the
 * whole file (reserve_early) before HDF5 writes any data. */
static int prepare(const h5u_writer *w, const pdla_engine *e, const char *dir, const char *tmp)
{
    const uint64_t need = size_bound(e);
    struct statvfs fs;
    if (statvfs(dir, &fs) == 0 && fs.f_blocks != 0 &&
        (uint64_t)fs.f_bavail * (uint64_t)fs.f_frsize < need) {
        h5u_fail_msg(w, "%s: about %llu bytes needed in %s", strerror(ENOSPC),
                     (unsigned long long)need, dir);
        return PDLA_EIO;
    }
    struct rlimit fl;
    if (getrlimit(RLIMIT_FSIZE, &fl) == 0 && fl.rlim_cur != RLIM_INFINITY && fl.rlim_cur < need) {
        h5u_fail_msg(w, "the file size limit (ulimit -f) is %llu bytes, about %llu needed",
                     (unsigned long long)fl.rlim_cur, (unsigned long long)need);
        return PDLA_EIO;
    }
    if (unlink(tmp) != 0 && errno != ENOENT) {
        h5u_fail_msg(w, "cannot remove the stale %s: %s", tmp, strerror(errno));
        return PDLA_EIO;
    }
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        h5u_fail_msg(w, "cannot create %s: %s", tmp, strerror(errno));
        return PDLA_EIO;
    }
    close(fd);
    return PDLA_OK;
}

/* tmp becomes checkpoint.h5, the old one checkpoint.1.h5 and that one
 * checkpoint.2.h5; each name always holds a complete file. 0 or -1. */
static int shift_generations(const h5u_writer *w, const char *tmp, const char *path,
                             const char *g1, const char *g2)
{
    if (rename(g1, g2) != 0 && errno != ENOENT) {
        h5u_fail_msg(w, "cannot rename %s to %s: %s", g1, g2, strerror(errno));
        return -1;
    }
    if (link(path, g1) != 0 && errno != ENOENT) {
        /* No hard links here: a copy by rename, leaving a moment with no
         * checkpoint.h5 (the loader then takes checkpoint.1.h5). */
        if (rename(path, g1) != 0 && errno != ENOENT) {
            h5u_fail_msg(w, "cannot keep %s as %s: %s", path, g1, strerror(errno));
            return -1;
        }
    }
    if (rename(tmp, path) != 0) {
        h5u_fail_msg(w, "cannot rename %s to it: %s", tmp, strerror(errno));
        return -1;
    }
    return 0;
}

int pdla_checkpoint_write(pdla_engine *e, const char *dir, const pdla_checkpoint_opts *opts,
                          pdla_checkpoint_info *info, char *err, size_t errlen)
{
    const double t0 = pdla_clock_seconds();
    char path[4200], tmp[4200], g1[4200], g2[4200];
    if (err && errlen) err[0] = '\0';
    if (!e || !dir || !dir[0] || strlen(dir) > 4000) {
        if (err && errlen) snprintf(err, errlen, "checkpoint: no engine or no (or too long a) directory");
        return PDLA_EINVAL;
    }
    /* The loader takes a root generation from CKPT_GENERATION_MAX up as
     * damaged: a run resumed from a (forged) 2^62 - 1 wrote 2^62 and on,
     * and its next resume set those aside and went back to the forged file.
     * Refused before anything is written, the generations as they were. */
    if (e->ckpt_generation >= CKPT_GENERATION_MAX - 1)
        return pdla_errorf(PDLA_EIO, err, errlen, "checkpoint: generation %llu is the last there may be (2^62 - 1); "
                           "no later one is written", (unsigned long long)e->ckpt_generation);
    ckpt_gen_name(path, sizeof path, dir, 0);
    ckpt_gen_name(g1, sizeof g1, dir, 1);
    ckpt_gen_name(g2, sizeof g2, dir, 2);
    snprintf(tmp, sizeof tmp, "%s/" TMP_PREFIX "%ld", dir, (long)getpid());
    const h5u_writer w = {path, err, errlen};

    const int prc = prepare(&w, e, dir, tmp);
    if (prc) return prc;
    h5u_quiet q;
    int rc = PDLA_EIO;
    if (h5u_silence(&q) < 0) {
        h5u_fail_msg(&w, "cannot silence the HDF5 error stack");
        goto fail;
    }
    const uint64_t generation = e->ckpt_generation + 1;
    if (write_ckpt_file(&w, tmp, e, opts, generation) < 0) goto fail;
    if (h5u_trim_and_sync(tmp) != 0) {
        h5u_fail_msg(&w, "cannot sync %s: %s", tmp, strerror(errno));
        goto fail;
    }
    if (shift_generations(&w, tmp, path, g1, g2) < 0) goto fail;
    if (h5u_fsync_dir(dir) != 0) {
        h5u_fail_msg(&w, "written, but cannot sync directory %s: %s", dir, strerror(errno));
        rc = PDLA_EIO;
        goto done;
    }
    rc = PDLA_OK;
    goto done;
fail:
    if (unlink(tmp) != 0 && errno != ENOENT && err && errlen) {
        const size_t used = strlen(err);
        snprintf(err + used, errlen - used, "; %s is left over (%s)", tmp, strerror(errno));
    }
done:
    if (h5u_restore(&q) < 0 && rc == PDLA_OK) {
        h5u_fail_msg(&w, "cannot restore the HDF5 error handler");
        rc = PDLA_EIO;
    }
    if (rc == PDLA_OK) {
        e->ckpt_generation = generation;
        e->ckpt_write_seconds = pdla_clock_seconds() - t0;
        if (info) {
            memset(info, 0, sizeof *info);
            snprintf(info->path, sizeof info->path, "%s", path);
            info->generation = generation;
            info->particles = tree_count(&e->tree);
            struct stat st;
            info->bytes = stat(path, &st) == 0 ? (uint64_t)st.st_size : 0;
            info->seconds = e->ckpt_write_seconds;
        }
    }
    if (err && errlen) h5u_one_line(err);
    return rc;
}

/* ---- stale temporary files (the lock is in rundir.c) ------------------- */

int pdla_checkpoint_remove_stale(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    const struct dirent *de;
    char p[4400];
    while ((de = readdir(d)))
        if (ckpt_is_tmp_name(de->d_name)) {
            snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
            if (unlink(p) == 0) n++;
        }
    closedir(d);
    return n;
}
