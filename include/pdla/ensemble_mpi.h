/*
 * ensemble_mpi.h - `pdla ensemble` over MPI ranks (issue 13 part 3): the
 * distributed pdla_ens_scheduler. Built only when meson finds MPI
 * (option -Dmpi, default auto) into its own library, pdla_mpi: libpdla
 * does not link MPI and this header does not include mpi.h.
 *
 * Design. Rank 0 is the only writer: it owns DIR/clusters.journal and
 * DIR/ensemble.h5, exactly as a single-process run (one journal, no per-rank
 * files to merge; crash safety is the journal's). Every rank, rank 0
 * included, grows clusters on its own T worker threads (pdla_ens_run).
 * Work is handed out one cluster at a time (dynamic load balancing):
 * rank 0's workers take the next missing index from a shared counter; a
 * worker thread on rank r > 0 asks rank 0 for one, and ships each finished
 * record (pdla_ens_record_encode's bytes) to rank 0, which decodes it,
 * appends it to the journal (fdatasync) and only then acknowledges: a
 * cluster acknowledged is on disk.
 *
 * Threads and MPI. Only each rank's main thread (the one that called
 * pdla_ens_mpi_init) calls MPI: MPI_THREAD_FUNNELED is all this asks for,
 * and init fails when the library grants less. On ranks > 0 the worker
 * threads hand their requests to the main thread through a mailbox
 * (mutex + condition variable); on rank 0 the main thread serves the other
 * ranks while its workers use the journal directly. Waits poll MPI_Test /
 * MPI_Iprobe with sleeps of 20 us to 1 ms instead of blocking calls, which
 * in OpenMPI spin a core that the workers need.
 *
 * Messages are raw bytes between processes of one architecture and one
 * build (the config is broadcast as its C struct; pdla_ens_mpi_share checks
 * its size). Cluster i is still the serial cluster of seed S + i, so the
 * per-cluster data equal a single-process ensemble's, whatever the ranks.
 *
 * Ending. Rank 0 stops handing out work when it is stopped (signal) or a
 * rank reports an error; the others finish the clusters in flight, ship
 * them and say goodbye; rank 0 returns once every rank has. Ranks beyond
 * the clusters to grow get no work and end at once. A rank that dies (kill
 * -9, a lost node) never says goodbye: mpirun then aborts the whole job
 * (OpenMPI's default); the journal holds every acknowledged cluster and
 * `pdla ensemble --resume DIR` (with or without mpirun) grows the rest.
 *
 * Errors follow pdla.h: 0 or a negative PDLA_E* code with one line in err
 * (an MPI failure: PDLA_EIO with MPI_Error_string's text).
 */
#ifndef PDLA_ENSEMBLE_MPI_H
#define PDLA_ENSEMBLE_MPI_H

#include <stddef.h>

#include "pdla/ensemble.h"

#ifdef __cplusplus
extern "C" {
#endif

/* MPI_Init_thread (asking MPI_THREAD_FUNNELED) on the calling thread, which
 * must be the one that later calls every other function here; this
 * process's rank and the number of ranks. */
PDLA_API int pdla_ens_mpi_init(int *rank, int *size, char *err, size_t errlen);

/* MPI_Finalize (after pdla_ens_mpi_init; else nothing). When an MPI call
 * of this rank failed, the others may be waiting for it: MPI_Abort of the
 * whole job with exit status code (1 if 0) instead, which does not return. */
PDLA_API int pdla_ens_mpi_finalize(int code);

/* Rank 0 tells the others whether to grow: *verdict 0 and the ensemble's
 * config c (rank 0's, which read or created the journal), or an exit code
 * (c ignored, may be NULL). Collective: every rank calls it once; on the
 * others *verdict and *c are filled in. */
PDLA_API int pdla_ens_mpi_share(int *verdict, pdla_ens_config *c, char *err, size_t errlen);

/* Rank 0: grow the clusters j lacks on `threads` threads of this rank and
 * on the other ranks, appending every record to j; returns when every rank
 * has ended. progress (may be NULL) sees the clusters finished on all
 * ranks in this call, and the particles of rank 0's clusters plus target
 * per cluster finished elsewhere. PDLA_ESTOPPED when progress stopped it or
 * a rank was stopped; an error of any rank comes back as its line. */
PDLA_API int pdla_ens_mpi_run_root(pdla_ens_journal *j, int threads, pdla_ens_progress_fn progress,
                                   void *user, char *err, size_t errlen);

/* Ranks > 0: grow the clusters rank 0 hands out on `threads` threads until
 * it has none left, shipping each record to it. progress as for
 * pdla_ens_run (its non-zero return stops this rank: PDLA_ESTOPPED). An
 * error of this rank's growth goes to rank 0 in its goodbye and rank 0
 * reports it; what comes back here is only what rank 0 could not be told
 * (an MPI failure; pdla_ens_mpi_finalize then aborts the job). */
PDLA_API int pdla_ens_mpi_run_worker(const pdla_ens_config *c, int threads,
                                     pdla_ens_progress_fn progress, void *user, char *err,
                                     size_t errlen);

#ifdef __cplusplus
}
#endif
#endif /* PDLA_ENSEMBLE_MPI_H */
