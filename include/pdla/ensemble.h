/*
 * ensemble.h - many independent DLA clusters (`pdla ensemble`): growth on
 * worker threads, a crash-safe journal of finished clusters, the ensemble
 * file DIR/ensemble.h5 and its statistics.
 *
 * Reproducibility. Cluster i of an ensemble with first seed S is the serial
 * DLA cluster of seed S + i (pdla_ens_cluster_params): its stream depends on
 * (S, i) only, never on which thread, rank or order grew it, and it is the
 * same cluster `pdla --seed S+i` grows with the other parameters equal.
 *
 * Scheduling. pdla_ens_run grows clusters on T threads and asks a
 * pdla_ens_scheduler for work: next() hands out cluster indices one at a
 * time (dynamic load balancing: clusters differ in time) and done() takes
 * each finished cluster's record. The in-process scheduler
 * (pdla_ens_run_local) serves the indices the journal lacks and appends each
 * record to the journal. A distributed scheduler (MPI) replaces it without
 * touching growth or output: on a worker rank next() asks the root for an
 * index and done() ships pdla_ens_record_encode's bytes to the root, which
 * decodes them and calls pdla_ens_journal_append.
 *
 * Errors follow pdla.h: 0 or a negative PDLA_E* code with one line in err.
 */
#ifndef PDLA_ENSEMBLE_H
#define PDLA_ENSEMBLE_H

#include <stddef.h>
#include <stdint.h>

#include "pdla/pdla.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Files in an ensemble directory. */
#define PDLA_ENS_JOURNAL_NAME "clusters.journal"
#define PDLA_ENS_FILE_NAME "ensemble.h5"
#define PDLA_ENS_SIDECAR_NAME "ensemble.xdmf2" /* with kept positions: for ParaView */

/* What defines an ensemble: the same config grows the same clusters. */
typedef struct pdla_ens_config {
    pdla_params params;  /* every cluster's growth parameters; params.seed is the
                            first cluster's seed. threads must be 1 and bind
                            none (one cluster grows serially on one worker). */
    uint64_t clusters;   /* M >= 1; cluster i has seed params.seed + i */
    int keep_positions;  /* 1: records carry the particle positions */
    int deflate_level;   /* the kept positions' deflate level 0..9 in ensemble.h5
                            (output only: a resume writes with it unless given
                            another; not compared). Journals from before it
                            was recorded read as PDLA_ENS_GZIP_DEFAULT. */
} pdla_ens_config;

/* The most clusters one ensemble may have. The journal's index (16 bytes a
 * cluster) is allocated at start and ensemble.h5 is written from memory
 * (about 124 bytes + 8 per R_g sample a cluster, pdla_ens_memory_bytes):
 * 10^8 clusters need 1.6 GB before the first one grows and 14+ GB at the
 * end, so a larger M (or a journal header claiming one) is refused up
 * front instead of failing after days of growth. */
#define PDLA_ENS_MAX_CLUSTERS UINT64_C(100000000)

/* 0, or PDLA_EINVAL with the first problem: M = 0 or above
 * PDLA_ENS_MAX_CLUSTERS, a seed range params.seed + M - 1 beyond 2^64 - 1,
 * invalid params, threads != 1. */
PDLA_API int pdla_ens_config_check(const pdla_ens_config *c, char *err, size_t errlen);

/* An upper estimate of the bytes of memory writing c's ensemble.h5 takes
 * (the journal's index, the per-cluster columns and the M x K R_g matrix,
 * K the R_g samples of one cluster); saturates at UINT64_MAX. */
PDLA_API uint64_t pdla_ens_memory_bytes(const pdla_ens_config *c);

/* At most how many R_g samples one cluster of c records (the log grid:
 * rg_per_decade a decade, strictly increasing integers, so never more than
 * N, plus N = 1 and the last point), and so the largest cluster record c's
 * clusters make, in bytes (the journal refuses a longer one as damaged
 * before reading it). Saturate at 2^60. */
PDLA_API uint64_t pdla_ens_rg_samples_max(const pdla_ens_config *c);
PDLA_API uint64_t pdla_ens_record_max_bytes(const pdla_ens_config *c);

/* The growth parameters of cluster i (seed = params.seed + i). */
PDLA_API void pdla_ens_cluster_params(const pdla_ens_config *c, uint64_t i, pdla_params *out);

/* The fingerprint of c's growth parameters, which every journal record
 * carries: a 64-bit FNV-1a of "name=value" lines (exact values) of every
 * row of the parameter table (params.h) but threads and bind (fixed for an
 * ensemble's clusters), a row added since journals existed
 * (absent_default) left out at its default. Two ensembles that differ in
 * any growth parameter (--eps, --resolution, --far-factor, --max-jumps,
 * --rg-per-decade, --arrival, ... and seed, dimension, size) differ in it;
 * the cluster count, keep_positions and deflate_level are not in it. */
PDLA_API uint64_t pdla_ens_fingerprint(const pdla_ens_config *c);

/* One finished cluster. Arrays are malloc'ed (pdla_ens_record_free). */
typedef struct pdla_ens_record {
    uint64_t index;        /* i in [0, M) */
    uint64_t seed;         /* its engine seed, params.seed + i */
    uint64_t particles;
    uint64_t walkers, jumps;
    double rg_diam;        /* final radius of gyration, diameters */
    double r_ext_diam;     /* final max |x| of the centres, diameters */
    pdla_fit fit;          /* its own D_f fit (pdla_engine_fit) */
    double cpu_seconds;    /* CPU time of the thread that grew it */
    double wall_seconds;
    int dim;
    uint64_t rg_count;     /* R_g samples: the shared log grid up to particles */
    uint64_t *rg_n;        /* N of each sample */
    double *rg;            /* R_g at N, diameters */
    uint64_t npos;         /* positions kept (particles with keep_positions, else 0) */
    int32_t *positions;    /* npos * dim, units; arrival order with
                              params.record_arrival, else tree order */
} pdla_ens_record;

PDLA_API void pdla_ens_record_free(pdla_ens_record *r);

/* Grow cluster i of c on the calling thread. */
PDLA_API int pdla_ens_grow_one(const pdla_ens_config *c, uint64_t i, pdla_ens_record *out,
                               char *err, size_t errlen);

/* A record as bytes (the journal's payload, also for sending between
 * processes of one architecture) and back. encode: *buf is malloc'ed. */
PDLA_API int pdla_ens_record_encode(const pdla_ens_record *r, uint8_t **buf, size_t *len);
PDLA_API int pdla_ens_record_decode(const uint8_t *buf, size_t len, pdla_ens_record *out,
                                    char *err, size_t errlen);
/* A record's fixed fields come first, in PDLA_ENS_RECORD_FIXED bytes. peek
 * reads them alone (no allocation; rg_n, rg and positions stay NULL), for
 * a record of `len` bytes in all: 0, or -1 when the lengths they declare do
 * not add up to len. The journal's scan past damage checks candidates so
 * before it reads and hashes them whole. */
#define PDLA_ENS_RECORD_FIXED 136
PDLA_API int pdla_ens_record_peek(const uint8_t *fixed, uint64_t len, pdla_ens_record *out);

/* Where work comes from and where finished clusters go. Both functions are
 * called from the worker threads, concurrently: they must be thread-safe. */
typedef struct pdla_ens_scheduler {
    /* 1 and the next cluster to grow in *index, or 0: no work left. */
    int (*next)(void *user, uint64_t *index);
    /* Cluster rec->index is finished; rec stays the caller's. Non-zero
     * (with err) stops the run with that error. */
    int (*done)(void *user, const pdla_ens_record *rec, char *err, size_t errlen);
    void *user;
} pdla_ens_scheduler;

/* Called on pdla_ens_run's thread about every 0.1 s and once at the end
 * with the clusters finished in this call and the particles grown in it
 * (clusters in flight included). Non-zero stops the run: the clusters in
 * flight are dropped, pdla_ens_run returns PDLA_ESTOPPED. */
typedef int (*pdla_ens_progress_fn)(void *user, uint64_t clusters_done, uint64_t particles);

/* Threads for `asked`: itself when > 0, else the physical cores (hwloc);
 * 0 when the topology cannot be read. */
PDLA_API int pdla_ens_threads(int asked);

/* Grow clusters on `threads` worker threads (0: physical cores) until
 * s->next says there are none left. progress may be NULL. */
PDLA_API int pdla_ens_run(const pdla_ens_config *c, int threads, const pdla_ens_scheduler *s,
                          pdla_ens_progress_fn progress, void *user, char *err, size_t errlen);

/* ---- the journal: finished clusters, crash-safe ------------------------- */

typedef struct pdla_ens_journal pdla_ens_journal;

/* A new ensemble in directory dir (which must exist): DIR/clusters.journal
 * is created (replacing an old one) with c in its header, fsync'ed. */
PDLA_API int pdla_ens_journal_create(const char *dir, const pdla_ens_config *c,
                                     pdla_ens_journal **out, char *err, size_t errlen);
/* Open dir's journal read-only: its config and every complete record
 * (checksums verified, and each record must belong to the ensemble: its
 * parameter fingerprint (pdla_ens_fingerprint), index, seed, dimension,
 * particles, positions; a torn or damaged tail, from a crash during an
 * append, is noted and ignored; a damaged record between valid ones is
 * skipped and the scan goes on at the next valid record). A journal of
 * format 1 (before session 27) has records without a fingerprint: they are
 * taken before its first record with one, as that format was read.
 * PDLA_EIO when there is none or its header is damaged. Writes nothing. */
PDLA_API int pdla_ens_journal_open(const char *dir, pdla_ens_journal **out, char *err,
                                   size_t errlen);
/* Asked by a long scan whether to stop (a signal arrived); non-zero: stop.
 * Called from the thread that opens the journal. */
typedef int (*pdla_ens_stop_fn)(void *user);
/* pdla_ens_journal_open with stop(user) polled at every record candidate
 * and every megabyte searched past damage (stop may be NULL): when it
 * returns non-zero the open ends with PDLA_ESTOPPED and one line, having
 * written nothing. pdla_ens_journal_extend's reopen polls it too. */
PDLA_API int pdla_ens_journal_open_stoppable(const char *dir, pdla_ens_stop_fn stop, void *user,
                                             pdla_ens_journal **out, char *err, size_t errlen);
/* Make an opened journal appendable: cut the torn tail, if any. */
PDLA_API int pdla_ens_journal_begin_append(pdla_ens_journal *j, char *err, size_t errlen);
/* Extend the ensemble of opened journal j to `clusters` (> its M): the
 * journal is rewritten with the new count in its header and its complete
 * records (a torn tail is dropped) into a temporary file, fsync'ed and
 * renamed over it, so a crash leaves the old or the new journal whole. The
 * recorded clusters stay valid because cluster i is seed S + i whatever M.
 * j is closed in every case; the reopened journal (read-only, as after
 * pdla_ens_journal_open) is returned in *out on success. PDLA_EINVAL:
 * clusters <= M or a seed range past 2^64 - 1 (nothing written). */
PDLA_API int pdla_ens_journal_extend(pdla_ens_journal *j, uint64_t clusters, pdla_ens_journal **out,
                                     char *err, size_t errlen);
/* Before this build grows clusters of a journal another build grew (after
 * pdla_ens_journal_begin_append): append a build record naming this build
 * (pdla_build_revision; "unrecorded" first for the records of a journal
 * from before builds were recorded), made durable like a cluster record:
 * the journal is not rewritten, whatever its size. Nothing is written when
 * the journal lists this build already, or its list is full (2 KB of
 * names). A build's clusters are the same law as another's, not the same
 * bits: the list says which builds grew the ensemble (ensemble.h5
 * /ensemble builds). */
PDLA_API int pdla_ens_journal_join(pdla_ens_journal *j, char *err, size_t errlen);
/* The builds that grew j's records, space-separated revisions in the order
 * they joined; "" for a journal from before builds were recorded. Whether this
 * build is among them. */
PDLA_API const char *pdla_ens_journal_builds(const pdla_ens_journal *j);
PDLA_API int pdla_ens_journal_built_here(const pdla_ens_journal *j);
PDLA_API const pdla_ens_config *pdla_ens_journal_config(const pdla_ens_journal *j);
/* Clusters recorded, and whether cluster i is. */
PDLA_API uint64_t pdla_ens_journal_count(const pdla_ens_journal *j);
PDLA_API int pdla_ens_journal_has(const pdla_ens_journal *j, uint64_t i);
/* Bytes of a torn or damaged tail found by open (0: none). */
PDLA_API uint64_t pdla_ens_journal_torn_bytes(const pdla_ens_journal *j);
/* Bytes of damaged records found by open between valid ones (a bad sector,
 * a stray write): skipped, not cut, so the records after them still count;
 * the clusters they held are missing and grow again. 0: none. */
PDLA_API uint64_t pdla_ens_journal_damaged_bytes(const pdla_ens_journal *j);
/* Why open refused the first record whose checksum held, as damage (inside
 * or at the tail): "cluster I: " and the value no cluster of the ensemble
 * makes (R_g samples off the ensemble's grid of N, a NaN R_g, ...); "" when
 * none was (a failed checksum names no cluster). */
PDLA_API const char *pdla_ens_journal_refused(const pdla_ens_journal *j);
/* Append rec (one write, then fdatasync) unless cluster rec->index is
 * already recorded. Thread-safe. */
PDLA_API int pdla_ens_journal_append(pdla_ens_journal *j, const pdla_ens_record *rec,
                                     char *err, size_t errlen);
/* Read cluster i's record back. */
PDLA_API int pdla_ens_journal_read(const pdla_ens_journal *j, uint64_t i, pdla_ens_record *out,
                                   char *err, size_t errlen);
PDLA_API void pdla_ens_journal_close(pdla_ens_journal *j);

/* asked vs the journal's config for a resume: every parameter named in
 * asked_fields (PDLA_PARAM_* bits; threads and bind are not growth
 * parameters here and are skipped), the cluster count when clusters_given
 * and keep_positions when keep_given must be equal. 0, or PDLA_EINVAL and
 * one line naming the first difference. */
PDLA_API int pdla_ens_config_compare(const pdla_ens_config *stored, const pdla_ens_config *asked,
                                     uint32_t asked_fields, int clusters_given, int keep_given,
                                     char *err, size_t errlen);

/* The in-process scheduler: grow every cluster the journal lacks on
 * `threads` threads, each record appended to the journal as it finishes. */
PDLA_API int pdla_ens_run_local(pdla_ens_journal *j, int threads, pdla_ens_progress_fn progress,
                                void *user, char *err, size_t errlen);

/* Write the ensemble file from a complete journal: path.tmp.<pid>, fsync'ed,
 * renamed onto path (replacing it). PDLA_EINVAL when clusters are missing. */
PDLA_API int pdla_ens_write(const pdla_ens_journal *j, const pdla_run_info *info,
                            const char *path, char *err, size_t errlen);
/* The same with kept positions compressed at deflate level gzip (0..9, with
 * shuffle; 0: stored as they are); pdla_ens_write uses
 * PDLA_ENS_GZIP_DEFAULT. With kept positions the ParaView sidecar
 * path-without-.h5 + ".xdmf2" (xdmf.h) is written after the rename, also
 * crash-safely; without, an older sidecar there is removed. */
#define PDLA_ENS_GZIP_DEFAULT 4
PDLA_API int pdla_ens_write_gz(const pdla_ens_journal *j, const pdla_run_info *info,
                               const char *path, int gzip, char *err, size_t errlen);

/* ---- statistics (ens_stats.c) -------------------------------------------- */

/* The ensemble statistics of M R_g(N) series on a shared grid. */
typedef struct pdla_ens_stats {
    size_t k;                  /* grid points */
    double *mean_rg, *se_rg;   /* [k] mean R_g over clusters and its standard
                                  error sd / sqrt(M) (NaN when M = 1), diameters */
    uint64_t n_lo, n_hi;       /* fit range of N (pdla_fit_default_range) */
    /* D_f of the mean R_g (least squares of ln <R_g> on ln N over the fit
     * range) with a 95% interval: the 2.5 and 97.5 percentiles over
     * boot_samples resamples of the M clusters with replacement, drawn from
     * a fixed seed (reproducible); df_boot_sd their standard deviation.
     * With M = 1 every resample is that one cluster: no interval, df_lo,
     * df_hi, df_boot_sd (and the slope bands and the correction fit's
     * intervals below) are NaN. */
    double df, df_lo, df_hi, df_boot_sd, prefactor_diam;
    int boot_samples;
    uint64_t boot_seed;
    /* Local slope: D_f fitted over windows of half a decade of N, centred
     * every 0.1 decade from min(30, n_lo) to the end, with the same
     * bootstrap band. */
    size_t nslope;
    double slope_window;       /* its width in decades (0.5) */
    double *slope_n, *slope_df, *slope_lo, *slope_hi;
    /* Correction to scaling R_g = A N^(1/D) (1 + B N^-nu) over N in
     * [corr_n_lo = 30, n_hi] (nonlinear least squares on ln R_g over nu in
     * [0.2, 2] and B with |B N^-nu| <= 0.9 at every N fitted); the
     * interval of D and A by bootstrap (the first corr_samples resamples). corr_ok = 0
     * when it could not be fitted (too few points). A in diameters.
     * corr_max: the largest |B N^-nu| over the N fitted (0.9: B at its cap). */
    int corr_ok, corr_samples;
    uint64_t corr_n_lo;
    double corr_A, corr_A_lo, corr_A_hi, corr_D, corr_D_lo, corr_D_hi, corr_B, corr_nu, corr_rms, corr_max;
    /* The per-cluster D_f: mean and standard deviation over clusters. */
    double df_cluster_mean, df_cluster_sd;
} pdla_ens_stats;

#define PDLA_ENS_BOOT_SAMPLES 1000
#define PDLA_ENS_CORR_SAMPLES 200 /* the correction fit profiles nu: 200 refits */
#define PDLA_ENS_BOOT_SEED 20260101u

/* rg: m x k, row-major (cluster i's series at rg + i * k); df_cluster: the
 * clusters' own D_f (may be NULL); n_final: the clusters' size; the
 * correction fit's interval uses the first min(corr_samples, boot_samples)
 * resamples (0: no interval). */
PDLA_API int pdla_ens_stats_compute(const uint64_t *n, size_t k, const double *rg, size_t m,
                                    const double *df_cluster, uint64_t n_final, int boot_samples,
                                    int corr_samples, uint64_t boot_seed, pdla_ens_stats *out,
                                    char *err, size_t errlen);
PDLA_API void pdla_ens_stats_free(pdla_ens_stats *s);

/* The correction-to-scaling fit alone, of one series y(N) over [n_lo, n_hi]:
 * 0 with A, D, B, nu and the rms of the ln residuals, or -1 (too few points). */
PDLA_API int pdla_ens_corr_fit(const uint64_t *n, const double *y, size_t k, uint64_t n_lo,
                               uint64_t n_hi, double *A, double *D, double *B, double *nu,
                               double *rms);

#ifdef __cplusplus
}
#endif
#endif /* PDLA_ENSEMBLE_H */
