/*
 * checkpoint.c - pdla_checkpoint_write() and pdla_checkpoint_load(): the
 * whole state of an engine between two grow calls, in one HDF5 file, so a
 * run can stop and continue exactly.
 *
 * Layout (HDF5 1.10 format, no time stamps, Fletcher32 on every dataset
 * that has rows; attributes live in object headers, which the 1.10 format
 * checksums):
 *
 *   /               format = "pdla-checkpoint", format_version = 1,
 *                   generation, particles, pause_seconds (time taken to stop
 *                   the workers before this write), previous_write_seconds,
 *                   compressed, record_byte_order = "little"
 *   /parameters     every pdla_params field (as in cluster.h5)
 *   /tree           dim, chunk_bytes, root_level, root_node, count, leaves,
 *                   inner_records, chunk_records (attributes)
 *   /tree/inner     u32 [inner_records][2^dim]: the inner node pool, raw
 *   /tree/chunks_packed  u8 [chunks_packed_bytes]: the chunk pool, packed:
 *                   per record from 11 on (0..10 are the unused null/count
 *                   indices) its link, u32 little-endian, then axis by axis
 *                   the `fill` relative coordinates it holds (fill = link
 *                   when link <= 10, else 10)
 *   /state          counters, R_ext, R_g grid position, timings (attributes)
 *   /state/gyration u64 [4][2]: the exact 128-bit sums of x, y, z (two's
 *                   complement) and |x|^2, as (low, high) words
 *   /state/rng      u64 [1 + W][4]: the engine walker's xoshiro256** state,
 *                   then the W workers' of the last parallel phase (for the
 *                   record only: see below)
 *   /gyration/N, /gyration/rg_diam   the R_g samples so far
 *   /Code           provenance
 *
 * Dumping the pools keeps the tree's record order, so a resumed serial run
 * is byte-identical to one never stopped. Random streams: every start of a
 * parallel phase (the first one, and each restart after a checkpoint pause
 * or a resume) cuts worker i's stream as the i-th rng_jump of the engine
 * stream (worker 0: the engine stream itself), which then moves past them
 * all, n jumps on (parallel.c). So the engine stream
 * is the whole random state, and a resume with any --threads is as
 * deterministic as a pause with it; the workers' last states are kept only
 * as a record.
 */
#define _GNU_SOURCE

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <time.h>
#include <unistd.h>

#include "engine.h"
#include "h5util.h"
#include "provenance.h"

#define FORMAT_NAME "pdla-checkpoint"
#define FORMAT_VERSION 1
#define TMP_PREFIX ".checkpoint.h5.tmp."
#define SERIES_ROWS 65536u
/* Rows per HDF5 chunk of /tree/inner (HDF5 stores the last, partial chunk
 * at full size, so this bounds the waste), and bytes per HDF5 chunk and per
 * write of the packed chunk stream. */
#define POOL_CHUNK_ROWS 4096u
#define PACK_CHUNK_BYTES (UINT64_C(1) << 18)
#define PACK_BUF_BYTES ((size_t)1 << 22)

static void gen_name(char *buf, size_t n, const char *dir, int k)
{
    if (k == 0) snprintf(buf, n, "%s/%s", dir, PDLA_CHECKPOINT_NAME);
    else snprintf(buf, n, "%s/checkpoint.%d.h5", dir, k);
}

/* ---- writing ------------------------------------------------------------ */

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
        H5Sclose(ms);
        ms = H5I_INVALID_HID;
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

/* Bytes of the packed chunk stream: per chunk record from index 11 on, its
 * link (u32 little-endian: the next chunk, or for a leaf's last chunk its
 * fill 1..10) and then, axis by axis, the relative coordinates of the
 * particles it holds (fill bytes each). The unused slots of partly filled
 * chunks are not stored (they are zero in memory), which makes a 2D
 * particle cost ~2 bytes instead of the pool's ~3. */
static uint64_t packed_bytes(const tree *t)
{
    uint64_t n = 0;
    for (uint32_t i = TREE_CHUNK_CAP + 1; i < t->chunks.count; i++) {
        const uint32_t link = tree_chunk_link(t, tree_chunk_at(t, i));
        n += 4 + (uint64_t)(link <= TREE_CHUNK_CAP ? link : TREE_CHUNK_CAP) * (uint64_t)t->dim;
    }
    return n;
}

static int flush_packed(const h5u_writer *w, hid_t d, hid_t space, const uint8_t *buf, size_t fill,
                        uint64_t *written)
{
    if (fill == 0) return 0;
    const hsize_t start = *written, count = fill;
    const hid_t ms = H5Screate_simple(1, &count, NULL);
    const int ok = ms >= 0 && H5Sselect_hyperslab(space, H5S_SELECT_SET, &start, NULL, &count, NULL) >= 0 &&
                   H5Dwrite(d, H5T_NATIVE_UINT8, ms, space, H5P_DEFAULT, buf) >= 0;
    if (ms >= 0) H5Sclose(ms);
    if (!ok) return h5u_fail(w, "write /tree/chunks_packed");
    *written += fill;
    return 0;
}

static int write_chunks(const h5u_writer *w, hid_t g, const tree *t, int gzip)
{
    const uint64_t total = packed_bytes(t);
    hid_t space = H5I_INVALID_HID, d = H5I_INVALID_HID;
    uint8_t *buf = NULL;
    int rc = -1;
    if (h5u_attr_u64(w, g, "chunks_packed_bytes", total) < 0) return -1;
    if ((d = h5u_dataset_z(w, g, "chunks_packed", H5T_STD_U8LE, 1, total, 1, PACK_CHUNK_BYTES, gzip,
                           &space)) < 0)
        goto fail;
    if (!(buf = malloc(PACK_BUF_BYTES))) {
        h5u_fail_msg(w, "out of memory");
        goto fail;
    }
    size_t fill = 0;
    uint64_t written = 0;
    for (uint32_t i = TREE_CHUNK_CAP + 1; i < t->chunks.count; i++) {
        const uint8_t *rec = tree_chunk_at(t, i);
        const uint32_t link = tree_chunk_link(t, rec);
        const size_t m = link <= TREE_CHUNK_CAP ? link : TREE_CHUNK_CAP;
        if (fill + 4 + TREE_CHUNK_CAP * 3 > PACK_BUF_BYTES) {
            if (flush_packed(w, d, space, buf, fill, &written) < 0) goto fail;
            fill = 0;
        }
        for (int b = 0; b < 4; b++) buf[fill++] = (uint8_t)(link >> (8 * b));
        for (int a = 0; a < t->dim; a++) {
            memcpy(buf + fill, rec + a * TREE_CHUNK_CAP, m);
            fill += m;
        }
    }
    if (flush_packed(w, d, space, buf, fill, &written) < 0) goto fail;
    if (written != total) {
        h5u_fail_msg(w, "internal error: packed %llu of %llu chunk bytes", (unsigned long long)written,
                     (unsigned long long)total);
        goto fail;
    }
    rc = 0;
fail:
    free(buf);
    rc = h5u_close(w, rc, space, H5Sclose, "the packed chunks' dataspace");
    return h5u_close(w, rc, d, H5Dclose, "/tree/chunks_packed");
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
        write_pool(w, g, "inner", &t->inner, H5T_STD_U32LE, H5T_NATIVE_UINT32,
                   (hsize_t)t->nchild, gzip) < 0 ||
        write_chunks(w, g, t, gzip) < 0)
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
        h5u_attr_int(w, g, "last_workers", e->nworkers) < 0 ||
        h5u_attr_str(w, g, "binding", e->binding) < 0 ||
        write_array(w, g, "gyration", H5T_STD_U64LE, H5T_NATIVE_UINT64, 2, 4, 2, gy) < 0 ||
        write_array(w, g, "rng", H5T_STD_U64LE, H5T_NATIVE_UINT64, 2, nr, 4, rng) < 0)
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
    gen_name(path, sizeof path, dir, 0);
    gen_name(g1, sizeof g1, dir, 1);
    gen_name(g2, sizeof g2, dir, 2);
    snprintf(tmp, sizeof tmp, "%s/" TMP_PREFIX "%ld", dir, (long)getpid());
    const h5u_writer w = {path, err, errlen};

    /* A write that fails half-way leaves HDF5 1.10 in a state it may crash
     * on at exit (see h5util.c h5u_divert_writes), so what can be known
     * beforehand is checked beforehand: the free space, the file size limit
     * (ulimit -f), and then disk blocks are reserved for the whole file
     * (reserve_early) before HDF5 writes any data. */
    const uint64_t need = size_bound(e);
    struct statvfs fs;
    if (statvfs(dir, &fs) == 0 && fs.f_blocks != 0 &&
        (uint64_t)fs.f_bavail * (uint64_t)fs.f_frsize < need) {
        h5u_fail_msg(&w, "%s: about %llu bytes needed in %s", strerror(ENOSPC),
                     (unsigned long long)need, dir);
        return PDLA_EIO;
    }
    struct rlimit fl;
    if (getrlimit(RLIMIT_FSIZE, &fl) == 0 && fl.rlim_cur != RLIM_INFINITY && fl.rlim_cur < need) {
        h5u_fail_msg(&w, "the file size limit (ulimit -f) is %llu bytes, about %llu needed",
                     (unsigned long long)fl.rlim_cur, (unsigned long long)need);
        return PDLA_EIO;
    }
    if (unlink(tmp) != 0 && errno != ENOENT) {
        h5u_fail_msg(&w, "cannot remove the stale %s: %s", tmp, strerror(errno));
        return PDLA_EIO;
    }
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        h5u_fail_msg(&w, "cannot create %s: %s", tmp, strerror(errno));
        return PDLA_EIO;
    }
    close(fd);
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
    /* Shift the generations; each name always holds a complete file. */
    if (rename(g1, g2) != 0 && errno != ENOENT) {
        h5u_fail_msg(&w, "cannot rename %s to %s: %s", g1, g2, strerror(errno));
        goto fail;
    }
    if (link(path, g1) != 0 && errno != ENOENT) {
        /* No hard links here: a copy by rename, leaving a moment with no
         * checkpoint.h5 (the loader then takes checkpoint.1.h5). */
        if (rename(path, g1) != 0 && errno != ENOENT) {
            h5u_fail_msg(&w, "cannot keep %s as %s: %s", path, g1, strerror(errno));
            goto fail;
        }
    }
    if (rename(tmp, path) != 0) {
        h5u_fail_msg(&w, "cannot rename %s to it: %s", tmp, strerror(errno));
        goto fail;
    }
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

/* ---- reading ------------------------------------------------------------ */

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

/* A scalar numeric attribute whose stored class and size match mtype. */
static int read_attr(hid_t obj, const char *name, hid_t mtype, void *val)
{
    if (H5Aexists(obj, name) <= 0) return -1;
    const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    if (a < 0) return -1;
    const hid_t t = H5Aget_type(a), s = H5Aget_space(a);
    int ok = t >= 0 && s >= 0 && H5Tget_class(t) == H5Tget_class(mtype) &&
             H5Tget_size(t) == H5Tget_size(mtype) && H5Sget_simple_extent_npoints(s) == 1;
    if (ok && H5Tget_class(t) == H5T_INTEGER) ok = H5Tget_sign(t) == H5Tget_sign(mtype);
    if (ok) ok = H5Aread(a, mtype, val) >= 0;
    if (t >= 0) H5Tclose(t);
    if (s >= 0) H5Sclose(s);
    H5Aclose(a);
    return ok ? 0 : -1;
}

/* A fixed-length string attribute into buf (always terminated). */
static int read_attr_str(hid_t obj, const char *name, char *buf, size_t len)
{
    buf[0] = '\0';
    if (H5Aexists(obj, name) <= 0) return -1;
    const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    if (a < 0) return -1;
    const hid_t t = H5Aget_type(a), s = H5Aget_space(a);
    int ok = t >= 0 && s >= 0 && H5Tget_class(t) == H5T_STRING && H5Tis_variable_str(t) == 0 &&
             H5Tget_size(t) > 0 && H5Tget_size(t) < len && H5Sget_simple_extent_npoints(s) == 1;
    if (ok) {
        memset(buf, 0, len);
        ok = H5Aread(a, t, buf) >= 0;
        buf[len - 1] = '\0';
    }
    if (t >= 0) H5Tclose(t);
    if (s >= 0) H5Sclose(s);
    H5Aclose(a);
    return ok ? 0 : -1;
}


/* Opens dataset name with the given element class/size and exact shape;
 * checks the Fletcher32 filter when it has rows. */
static hid_t open_dset(const reader *r, hid_t loc, const char *name, hid_t mtype, int rank,
                       hsize_t rows, hsize_t cols, int *rc)
{
    char what[128];
    *rc = PDLA_OK;
    hid_t d = H5I_INVALID_HID, t = H5I_INVALID_HID, s = H5I_INVALID_HID, pl = H5I_INVALID_HID;
    int ok = 0;
    if (H5Lexists(loc, name, H5P_DEFAULT) <= 0) goto out;
    if ((d = H5Dopen2(loc, name, H5P_DEFAULT)) < 0) goto out;
    t = H5Dget_type(d);
    s = H5Dget_space(d);
    if (t < 0 || s < 0 || H5Tget_class(t) != H5Tget_class(mtype) ||
        H5Tget_size(t) != H5Tget_size(mtype) || H5Sget_simple_extent_ndims(s) != rank)
        goto out;
    hsize_t dims[2] = {0, 0};
    H5Sget_simple_extent_dims(s, dims, NULL);
    if (dims[0] != rows || (rank == 2 && dims[1] != cols)) goto out;
    if (rows > 0) {
        pl = H5Dget_create_plist(d);
        if (pl < 0) goto out;
        const int nf = H5Pget_nfilters(pl);
        int fl = 0;
        for (int i = 0; i < nf; i++) {
            unsigned flags;
            size_t ne = 0;
            char fname[32];
            if (H5Pget_filter2(pl, (unsigned)i, &flags, &ne, NULL, sizeof fname, fname, NULL) ==
                H5Z_FILTER_FLETCHER32)
                fl = 1;
        }
        if (!fl) goto out;
        /* What is declared must be stored: a forged file may declare 2^40
         * rows in a few KB (unwritten chunks read as fill values), and the
         * loader sizes its memory by the declaration. Deflate expands at most
         * about 1032:1; the checksum adds bytes, never removes them. */
        const double need = (double)rows * (double)(rank == 2 ? cols : 1) * (double)H5Tget_size(t);
        if (need > (double)H5Dget_storage_size(d) * (nf > 1 ? 1100.0 : 1.0)) goto out;
    }
    ok = 1;
out:
    if (pl >= 0) H5Pclose(pl);
    if (t >= 0) H5Tclose(t);
    if (s >= 0) H5Sclose(s);
    if (ok) return d;
    if (d >= 0) H5Dclose(d);
    snprintf(what, sizeof what, "dataset %s missing or of the wrong type or shape", name);
    *rc = damaged(r, what);
    return H5I_INVALID_HID;
}

static int read_rows(const reader *r, hid_t d, const char *name, hid_t mtype, hsize_t row0,
                     hsize_t nrows, hsize_t cols, int rank, void *buf)
{
    if (nrows == 0) return 0;
    const hid_t fs = H5Dget_space(d);
    const hsize_t start[2] = {row0, 0}, count[2] = {nrows, cols};
    const hid_t ms = H5Screate_simple(rank, count, NULL);
    const int ok = fs >= 0 && ms >= 0 &&
                   H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) >= 0 &&
                   H5Dread(d, mtype, ms, fs, H5P_DEFAULT, buf) >= 0;
    if (fs >= 0) H5Sclose(fs);
    if (ms >= 0) H5Sclose(ms);
    if (ok) return 0;
    char what[160];
    snprintf(what, sizeof what, "cannot read %s: checksum or I/O error", name);
    return damaged(r, what);
}

static int read_array(const reader *r, hid_t loc, const char *name, hid_t mtype, int rank,
                      hsize_t rows, hsize_t cols, void *buf)
{
    int rc;
    const hid_t d = open_dset(r, loc, name, mtype, rank, rows, cols, &rc);
    if (d < 0) return rc;
    rc = read_rows(r, d, name, mtype, 0, rows, cols, rank, buf);
    H5Dclose(d);
    return rc;
}

/* One row of the parameter table from its /parameters attribute. */
static int read_param(hid_t g, const pdla_param_desc *d, pdla_params *p)
{
    switch (d->type) {
    case PDLA_PT_U64: {
        uint64_t v;
        if (read_attr(g, d->name, H5T_NATIVE_UINT64, &v) < 0) return -1;
        pdla_param_set_u(d, p, v);
        return 0;
    }
    case PDLA_PT_REAL: {
        double v;
        if (read_attr(g, d->name, H5T_NATIVE_DOUBLE, &v) < 0) return -1;
        pdla_param_set_real(d, p, v);
        return 0;
    }
    case PDLA_PT_CHOICE: {
        char word[32];
        const int v = read_attr_str(g, d->name, word, sizeof word) < 0 ? -1 : pdla_param_choice(d, word);
        if (v < 0) return -1;
        pdla_param_set_u(d, p, (uint64_t)v);
        return 0;
    }
    default: {
        int32_t v;
        if (read_attr(g, d->name, H5T_NATIVE_INT32, &v) < 0) return -1;
        pdla_param_set_u(d, p, (uint64_t)(int64_t)v);
        return 0;
    }
    }
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
        if (t[i].absent_default && H5Aexists(g, t[i].name) == 0) {
            if (t[i].type == PDLA_PT_REAL) pdla_param_set_real(&t[i], p, t[i].def_r);
            else pdla_param_set_u(&t[i], p, t[i].def_u);
            continue;
        }
        if (read_param(g, &t[i], p) < 0) {
            char what[96];
            snprintf(what, sizeof what, "parameter %s", t[i].name);
            rc = damaged(r, what);
        }
    }
    H5Gclose(g);
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
    for (size_t i = 0; i < n; i++) {
        const pdla_param_desc *d = &t[i];
        if (!(f & d->bit) || d->resumable || pdla_param_equal(d, a, p)) continue;
        char have[64], asked[64];
        pdla_param_format(d, p, 0, have, sizeof have);
        pdla_param_format(d, a, 0, asked, sizeof asked);
        if (r->err && r->errlen)
            snprintf(r->err, r->errlen, "%s: cannot resume with a different physics parameter: "
                     "%s is %s in the checkpoint, %s asked", r->path, d->label, have, asked);
        return PDLA_EINVAL;
    }
    if ((f & PDLA_PARAM_TARGET) && a->target < particles) {
        if (r->err && r->errlen)
            snprintf(r->err, r->errlen, "%s: target %llu is below the %llu particles it holds",
                     r->path, (unsigned long long)a->target, (unsigned long long)particles);
        return PDLA_EINVAL;
    }
    for (size_t i = 0; i < n; i++) {
        const pdla_param_desc *d = &t[i];
        if ((f & d->bit) && d->resumable) {
            if (d->type == PDLA_PT_REAL) pdla_param_set_real(d, p, pdla_param_get_real(d, a));
            else pdla_param_set_u(d, p, pdla_param_get_u(d, a));
        }
    }
    char why[256];
    if (pdla_params_validate(p, why, sizeof why) != PDLA_OK) {
        if (r->err && r->errlen) snprintf(r->err, r->errlen, "%s: %s", r->path, why);
        return PDLA_EINVAL;
    }
    return PDLA_OK;
}

/* Reads a pool of `records` rows into freshly allocated segments. */
static int read_pool(const reader *r, hid_t g, const char *name, tree_pool *p, uint64_t records,
                     hid_t mtype, hsize_t cols)
{
    int rc;
    const hid_t d = open_dset(r, g, name, mtype, 2, records, cols, &rc);
    if (d < 0) return rc;
    const uint32_t nseg = (uint32_t)((records + POOL_SEG_SIZE - 1) / POOL_SEG_SIZE);
    for (uint32_t s = p->nseg; s < nseg; s++) {
        if (!(p->seg[s] = calloc(POOL_SEG_SIZE, p->elem))) {
            H5Dclose(d);
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
        rc = read_rows(r, d, full, mtype, row0, n, cols, 2, p->seg[s]);
    }
    H5Dclose(d);
    if (rc == PDLA_OK) p->count = (uint32_t)records;
    return rc;
}

/* Unpacks /tree/chunks_packed (see packed_bytes) into chunk records
 * 11..nc-1, reading it a block at a time. */
static int read_chunks(const reader *r, hid_t g, tree *t, uint64_t nc)
{
    uint64_t total = 0;
    if (read_attr(g, "chunks_packed_bytes", H5T_NATIVE_UINT64, &total) < 0)
        return damaged(r, "/tree chunks_packed_bytes");
    if (total < (nc - TREE_CHUNK_CAP - 1) * 5 || total > (nc - TREE_CHUNK_CAP - 1) * (4 + 3 * TREE_CHUNK_CAP))
        return damaged(r, "/tree chunks_packed_bytes out of range");
    int rc;
    const hid_t d = open_dset(r, g, "chunks_packed", H5T_NATIVE_UINT8, 1, total, 1, &rc);
    if (d < 0) return rc;
    tree_pool *p = &t->chunks;
    const uint32_t nseg = (uint32_t)((nc + POOL_SEG_SIZE - 1) / POOL_SEG_SIZE);
    uint8_t *buf = malloc(PACK_BUF_BYTES);
    rc = buf ? PDLA_OK : PDLA_ENOMEM;
    for (uint32_t s = p->nseg; rc == PDLA_OK && s < nseg; s++) {
        if (!(p->seg[s] = calloc(POOL_SEG_SIZE, p->elem))) rc = PDLA_ENOMEM;
        else p->nseg = s + 1;
    }
    uint64_t pos = 0; /* stream bytes read */
    size_t have = 0, at = 0;
    uint32_t i = TREE_CHUNK_CAP + 1;
    while (rc == PDLA_OK && i < nc) {
        if (have - at < 4 + 3 * TREE_CHUNK_CAP && pos < total) {
            memmove(buf, buf + at, have - at);
            have -= at;
            at = 0;
            const uint64_t want = total - pos < PACK_BUF_BYTES - have ? total - pos : PACK_BUF_BYTES - have;
            rc = read_rows(r, d, "/tree/chunks_packed", H5T_NATIVE_UINT8, pos, want, 1, 1, buf + have);
            if (rc) break;
            pos += want;
            have += (size_t)want;
        }
        if (have - at < 4) {
            rc = damaged(r, "the packed chunks end early");
            break;
        }
        const uint32_t link = (uint32_t)buf[at] | (uint32_t)buf[at + 1] << 8 |
                              (uint32_t)buf[at + 2] << 16 | (uint32_t)buf[at + 3] << 24;
        const size_t m = link <= TREE_CHUNK_CAP ? link : TREE_CHUNK_CAP;
        if (link == 0 || have - at < 4 + m * (size_t)t->dim) {
            rc = damaged(r, link == 0 ? "an empty chunk" : "the packed chunks end early");
            break;
        }
        at += 4;
        p->count = i + 1; /* pool_at needs nothing more; count is set for good below */
        uint8_t *rec = pool_at(p, i);
        for (int a = 0; a < t->dim; a++) {
            memcpy(rec + a * TREE_CHUNK_CAP, buf + at, m);
            at += m;
        }
        memcpy(rec + t->chunk_bytes - 4, &link, 4);
        i++;
    }
    if (rc == PDLA_OK && (at != have || pos != total)) rc = damaged(r, "bytes after the last packed chunk");
    free(buf);
    H5Dclose(d);
    if (rc == PDLA_ENOMEM && r->err && r->errlen)
        snprintf(r->err, r->errlen, "%s: out of memory for the tree", r->path);
    if (rc == PDLA_OK) p->count = (uint32_t)nc;
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

static int load_tree(const reader *r, hid_t file, pdla_engine *e)
{
    tree *t = &e->tree;
    if (H5Lexists(file, "tree", H5P_DEFAULT) <= 0) return damaged(r, "no /tree");
    const hid_t g = H5Gopen2(file, "tree", H5P_DEFAULT);
    if (g < 0) return damaged(r, "cannot open /tree");
    int32_t dim = 0, cb = 0, level = 0;
    uint64_t root = 0, count = 0, leaves = 0, ni = 0, nc = 0;
    int rc = PDLA_OK;
    if (read_attr(g, "dim", H5T_NATIVE_INT32, &dim) < 0 ||
        read_attr(g, "chunk_bytes", H5T_NATIVE_INT32, &cb) < 0 ||
        read_attr(g, "root_level", H5T_NATIVE_INT32, &level) < 0 ||
        read_attr(g, "root_node", H5T_NATIVE_UINT64, &root) < 0 ||
        read_attr(g, "count", H5T_NATIVE_UINT64, &count) < 0 ||
        read_attr(g, "leaves", H5T_NATIVE_UINT64, &leaves) < 0 ||
        read_attr(g, "inner_records", H5T_NATIVE_UINT64, &ni) < 0 ||
        read_attr(g, "chunk_records", H5T_NATIVE_UINT64, &nc) < 0)
        rc = damaged(r, "/tree attributes");
    else if (dim != t->dim || (uint32_t)cb != t->chunk_bytes)
        rc = damaged(r, "/tree dim or record size differs from the parameters");
    else if (level < 1 || level > TREE_MAX_LEVEL || ni < 2 || ni > UINT32_MAX || nc < TREE_CHUNK_CAP + 1 ||
             nc > UINT32_MAX || root == 0 || root >= ni || count > nc * TREE_CHUNK_CAP ||
             leaves > nc)
        rc = damaged(r, "/tree sizes out of range");
    if (rc == PDLA_OK)
        rc = read_pool(r, g, "inner", &t->inner, ni, H5T_NATIVE_UINT32, (hsize_t)t->nchild);
    if (rc == PDLA_OK) rc = read_chunks(r, g, t, nc);
    H5Gclose(g);
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

    /* The state, checked against what the particles give. */
    if (H5Lexists(file, "state", H5P_DEFAULT) <= 0) return damaged(r, "no /state");
    const hid_t s = H5Gopen2(file, "state", H5P_DEFAULT);
    if (s < 0) return damaged(r, "cannot open /state");
    rc = PDLA_OK;
    uint64_t gy[4][2], gn = 0, r2 = 0, k = 0, nn = 0;
    int64_t rext = 0;
    int32_t nw = 0;
    walker_ctx *w = &e->walker;
    if (read_attr(s, "gyration_n", H5T_NATIVE_UINT64, &gn) < 0 ||
        read_attr(s, "r_ext2", H5T_NATIVE_UINT64, &r2) < 0 ||
        read_attr(s, "r_ext", H5T_NATIVE_INT64, &rext) < 0 ||
        read_attr(s, "rg_next_k", H5T_NATIVE_UINT64, &k) < 0 ||
        read_attr(s, "rg_next_n", H5T_NATIVE_UINT64, &nn) < 0 ||
        read_attr(s, "grow_seconds", H5T_NATIVE_DOUBLE, &e->grow_seconds) < 0 ||
        read_attr(s, "parallel_seconds", H5T_NATIVE_DOUBLE, &e->parallel_seconds) < 0 ||
        read_attr(s, "walkers", H5T_NATIVE_UINT64, &w->walkers) < 0 ||
        read_attr(s, "jumps", H5T_NATIVE_UINT64, &w->jumps) < 0 ||
        read_attr(s, "returns", H5T_NATIVE_UINT64, &w->returns) < 0 ||
        read_attr(s, "lost", H5T_NATIVE_UINT64, &w->lost) < 0 ||
        read_attr(s, "killed", H5T_NATIVE_UINT64, &w->killed) < 0 ||
        read_attr(s, "restarts", H5T_NATIVE_UINT64, &w->restarts) < 0 ||
        read_attr(s, "node_visits", H5T_NATIVE_UINT64, &w->ss.node_visits) < 0 ||
        read_attr(s, "particle_checks", H5T_NATIVE_UINT64, &w->ss.particle_checks) < 0 ||
        read_attr(s, "recheck_overlaps", H5T_NATIVE_UINT64, &w->recheck_overlaps) < 0 ||
        read_attr(s, "recheck_continued", H5T_NATIVE_UINT64, &w->recheck_continued) < 0 ||
        read_attr(s, "recheck_discarded", H5T_NATIVE_UINT64, &w->recheck_discarded) < 0 ||
        read_attr(s, "last_workers", H5T_NATIVE_INT32, &nw) < 0 ||
        read_attr_str(s, "binding", e->binding, sizeof e->binding) < 0)
        rc = damaged(r, "/state attributes");
    else if (nw < 0 || nw > 1024)
        rc = damaged(r, "/state last_workers out of range");
    if (rc == PDLA_OK) rc = read_array(r, s, "gyration", H5T_NATIVE_UINT64, 2, 4, 2, gy);
    uint64_t(*rng)[4] = NULL;
    if (rc == PDLA_OK && !(rng = malloc((size_t)(1 + nw) * sizeof *rng))) rc = PDLA_ENOMEM;
    if (rc == PDLA_OK) rc = read_array(r, s, "rng", H5T_NATIVE_UINT64, 2, (hsize_t)(1 + nw), 4, rng);
    H5Gclose(s);
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
    int64_t re = (int64_t)sqrt((double)r2);
    while ((uint64_t)(re * re) < r2) re++;
    while (re > 0 && (uint64_t)((re - 1) * (re - 1)) >= r2) re--;
    if (re != rext) return damaged(r, "R_ext differs from the particles");
    for (int a = 0; a < 3; a++) e->gyr.s1[a] = c.s1[a];
    e->gyr.s2 = c.s2;
    e->gyr.n = count;
    e->r_ext2 = r2;
    atomic_store(&e->r_ext, rext);
    if (e->params.rg_per_decade > 0 && count > 0 && nn <= count)
        return damaged(r, "the next R_g sample lies behind the particle count");
    e->rg_next_k = k;
    e->rg_next_n = nn;
    return PDLA_OK;
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
    int rc = read_array(r, file, "arrival", H5T_NATIVE_INT32, 2, n, (hsize_t)dim, a);
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
    const hid_t d = H5Dopen2(file, "gyration/N", H5P_DEFAULT);
    if (d < 0) return damaged(r, "cannot open /gyration/N");
    const hid_t sp = H5Dget_space(d);
    hsize_t k = 0;
    const int ok = sp >= 0 && H5Sget_simple_extent_ndims(sp) == 1 &&
                   H5Sget_simple_extent_dims(sp, &k, NULL) == 1;
    if (sp >= 0) H5Sclose(sp);
    H5Dclose(d);
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
    int rc = read_array(r, file, "gyration/N", H5T_NATIVE_UINT64, 1, k, 1, e->rg_n);
    if (rc == PDLA_OK) rc = read_array(r, file, "gyration/rg_diam", H5T_NATIVE_DOUBLE, 1, k, 1, e->rg_diam);
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

static int is_tmp_name(const char *path)
{
    const char *b = strrchr(path, '/');
    b = b ? b + 1 : path;
    return strncmp(b, TMP_PREFIX, strlen(TMP_PREFIX)) == 0;
}

/* One file: every check; *out on success. */
static int load_file(const char *path, const pdla_params *asked, uint32_t fields,
                     pdla_engine **out, pdla_checkpoint_info *info, char *err, size_t errlen)
{
    const reader rr = {path, err, errlen}, *r = &rr;
    *out = NULL;
    if (is_tmp_name(path)) return rfail(r, "an unfinished temporary checkpoint; not loaded");
    /* O_NONBLOCK: opening a FIFO for reading would wait for a writer. */
    const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) return rfail(r, "cannot open: %s", strerror(errno));
    unsigned char sb[48];
    struct stat st;
    const int fst = fstat(fd, &st);
    if (fst == 0 && S_ISDIR(st.st_mode)) {
        close(fd);
        return rfail(r, "is a directory");
    }
    if (fst != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return rfail(r, "not a regular file, so not a pdla checkpoint");
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
        if (base != 0 || eof > (uint64_t)st.st_size || eof < 48)
            return damaged(r, eof > (uint64_t)st.st_size ? "truncated" : "superblock");
    } else if (got < (ssize_t)sizeof sb) {
        return damaged(r, "truncated");
    }

    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    /* Not H5F_CLOSE_STRONG here: with it, HDF5 1.10.8 keeps some internals
     * of a read-only file alive past the close (and reports an "infinite
     * loop closing library" at exit); the loader closes every id itself. */
    if (fapl < 0 || H5Pset_fapl_sec2(fapl) < 0) {
        if (fapl >= 0) H5Pclose(fapl);
        return rfail(r, "cannot set up HDF5");
    }
    const hid_t file = H5Fopen(path, H5F_ACC_RDONLY, fapl);
    H5Pclose(fapl);
    if (file < 0) return damaged(r, "HDF5 cannot open it: truncated or corrupt");
    pdla_engine *e = NULL;
    int rc = PDLA_OK;
    char fmt[64];
    int32_t ver = 0;
    uint64_t generation = 0, particles = 0;
    const htri_t has_format = H5Aexists(file, "format");
    if (has_format < 0) { /* the root group's header does not read back */
        rc = damaged(r, "the root group cannot be read");
        goto out;
    }
    if (has_format == 0) {
        rc = rfail(r, "an HDF5 file but not a pdla checkpoint (no format attribute)");
        goto out;
    }
    if (read_attr_str(file, "format", fmt, sizeof fmt) < 0) {
        rc = damaged(r, "the format attribute cannot be read");
        goto out;
    }
    if (strcmp(fmt, FORMAT_NAME) != 0) {
        rc = rfail(r, "an HDF5 file but not a pdla checkpoint (format '%s')", fmt);
        goto out;
    }
    if (read_attr(file, "format_version", H5T_NATIVE_INT32, &ver) < 0) {
        rc = damaged(r, "no format_version");
        goto out;
    }
    if (ver != FORMAT_VERSION) {
        rc = rfail(r, "checkpoint format version %d; this pdla reads version %d", (int)ver,
                   FORMAT_VERSION);
        goto out;
    }
    char order[16];
    if (read_attr_str(file, "record_byte_order", order, sizeof order) < 0 ||
        read_attr(file, "generation", H5T_NATIVE_UINT64, &generation) < 0 ||
        read_attr(file, "particles", H5T_NATIVE_UINT64, &particles) < 0) {
        rc = damaged(r, "root attributes");
        goto out;
    }
    const uint16_t probe = 1;
    if (strcmp(order, "little") != 0 || *(const uint8_t *)&probe != 1) {
        rc = rfail(r, "records in byte order '%s' cannot be read on this machine", order);
        goto out;
    }
    pdla_params p;
    if ((rc = read_params(r, file, &p))) goto out;
    if (asked && (rc = apply_asked(r, &p, asked, fields, particles))) goto out;
    char why[256];
    if ((rc = pdla_engine_create(&e, &p, why, sizeof why))) {
        rfail(r, "%s", why);
        goto out;
    }
    if ((rc = load_tree(r, file, e))) goto out;
    if (tree_count(&e->tree) != particles) {
        rc = damaged(r, "the particle count differs from the tree");
        goto out;
    }
    if ((rc = load_series(r, file, e))) goto out;
    if ((rc = load_arrival(r, file, e))) goto out;
    if (distmap_rebuild(&e->dmap, &e->tree)) {
        rc = PDLA_ENOMEM;
        rfail(r, "out of memory for the distance map");
        goto out;
    }
    e->ckpt_generation = generation;
    if (info) {
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
        char name[4200], first_err[1024] = "", note[1024] = "";
        int found = 0;
        rc = PDLA_EIO;
        for (int k = 0; k < PDLA_CHECKPOINT_GENERATIONS; k++) {
            gen_name(name, sizeof name, path, k);
            if (access(name, F_OK) != 0) continue;
            found++;
            char e1[1024] = "";
            rc = load_file(name, asked, asked_fields, out, info, e1, sizeof e1);
            if (rc == PDLA_OK || rc == PDLA_EINVAL || rc == PDLA_ENOMEM) {
                if (rc != PDLA_OK && err && errlen) snprintf(err, errlen, "%s", e1);
                break;
            }
            if (!first_err[0]) snprintf(first_err, sizeof first_err, "%s", e1);
            if (!note[0]) snprintf(note, sizeof note, "skipped %s", e1);
        }
        if (!found) {
            if (err && errlen) snprintf(err, errlen, "%s: no checkpoint in this directory", path);
            rc = PDLA_EIO;
        } else if (rc == PDLA_EIO) {
            if (err && errlen)
                snprintf(err, errlen, "%s%s", first_err,
                         found > 1 ? " (and no older generation is usable)" : "");
        } else if (rc == PDLA_OK && info && note[0]) {
            snprintf(info->note, sizeof info->note, "%s", note);
        }
    } else {
        rc = load_file(path, asked, asked_fields, out, info, err, errlen);
    }
    h5u_restore(&q);
    if (rc == PDLA_OK && info) info->seconds = pdla_clock_seconds() - t0;
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
        if (is_tmp_name(de->d_name)) {
            snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
            if (unlink(p) == 0) n++;
        }
    closedir(d);
    return n;
}
