/*
 * checkpoint_fmt.h - what checkpoint_write.c and checkpoint_read.c share:
 * the format's name and version, the file names of the generations and of
 * the temporary file, and the sizes both sides must agree on. Internal to
 * libpdla; the API is pdla_checkpoint_* in pdla.h.
 *
 * Layout (HDF5 1.10 format, no time stamps, Fletcher32 on every dataset
 * that has rows; attributes live in object headers, which the 1.10 format
 * checksums):
 *
 *   /               format = "pdla-checkpoint", format_version = 2,
 *                   generation, particles, pause_seconds (time taken to stop
 *                   the workers before this write), previous_write_seconds,
 *                   compressed, record_byte_order = "little"
 *   /parameters     every pdla_params field (as in cluster.h5)
 *   /tree           dim, chunk_bytes, root_level, root_node, count, leaves,
 *                   inner_records, chunk_records, half_records (attributes)
 *   /tree/inner     u32 [inner_records][2^dim]: the inner node pool, raw
 *   /tree/chunks_packed  u8 [chunks_packed_bytes]: the chunk pool, packed:
 *                   per record from 11 on (0..10 are the unused null/count
 *                   indices) its link, u32 little-endian, then axis by axis
 *                   the `fill` relative coordinates it holds (fill = link
 *                   when link <= 10, else 10)
 *   /tree/halves_packed  u8 [halves_packed_bytes]: the half chunks, packed
 *                   the same way per half id 0 .. 2 half_records - 1 (fill
 *                   5 when the link names a next chunk; a free half is its
 *                   link 0 and nothing more)
 *   /state          counters, R_ext, R_g grid position, timings (attributes);
 *                   the distance map's shape: map_half, map_bits,
 *                   map_particles, map_tile_width (attributes) and, when
 *                   that width is not 0, /state/map_unknown_tiles u8
 *                   [width^2] (distmap_shape; absent in older files, which
 *                   rebuild the map to the particles' size)
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
#ifndef PDLA_CHECKPOINT_FMT_H
#define PDLA_CHECKPOINT_FMT_H

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "pdla/pdla.h"

#define FORMAT_NAME "pdla-checkpoint"
/* 2: half chunks (tree.h), /tree half_records and /tree/halves_packed.
 * Version 1 files (no halves) still load. */
#define FORMAT_VERSION 2
#define TMP_PREFIX ".checkpoint.h5.tmp."
/* Root generations from here up are refused as damaged (checkpoint_read.c). */
#define CKPT_GENERATION_MAX (UINT64_C(1) << 62)
/* Bytes per read and write of the packed chunk stream (/tree/chunks_packed). */
#define PACK_BUF_BYTES ((size_t)1 << 22)

/* Generation k's file in dir: checkpoint.h5, checkpoint.1.h5, ... */
static inline void ckpt_gen_name(char *buf, size_t n, const char *dir, int k)
{
    if (k == 0) snprintf(buf, n, "%s/%s", dir, PDLA_CHECKPOINT_NAME);
    else snprintf(buf, n, "%s/checkpoint.%d.h5", dir, k);
}

/* checkpoint_read.c: the generation in the root of the checkpoint at path,
 * without loading the rest. 0, or -1 when the root does not read. */
int ckpt_peek_generation(const char *path, uint64_t *generation);
/* checkpoint_read.c: PDLA_OK, or PDLA_EINVAL (err names it) when a
 * generation name of dir is a directory or a device: the rotation of the
 * resume's writes renamed a directory checkpoint.1.h5 to checkpoint.2.h5
 * and then failed at every write, after the run. */
int ckpt_foreign_names(const char *dir, char *err, size_t errlen);

/* checkpoint_read.c: generation name `name` of a run directory loaded as
 * the directory walk of pdla_checkpoint_load takes each: another model's
 * checkpoint is refused (PDLA_EINVAL: not a damaged generation to fall back
 * past, which the recovery would set aside), else the file is loaded with
 * every check. PDLA_EIO: damaged, unreadable or foreign (skipped by the
 * walk); PDLA_ENOMEM. The caller silences HDF5's error stack. */
int ckpt_load_name(const char *name, const pdla_params *asked, uint32_t fields, pdla_engine **out,
                   pdla_checkpoint_info *info, char *err, size_t errlen);

/* Whether path's base name is a writer's temporary file. */
static inline int ckpt_is_tmp_name(const char *path)
{
    const char *b = strrchr(path, '/');
    b = b ? b + 1 : path;
    return strncmp(b, TMP_PREFIX, strlen(TMP_PREFIX)) == 0;
}

#endif
