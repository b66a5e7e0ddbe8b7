/*
 * ens_mpi.c - the MPI scheduler of `pdla ensemble`
 * (include/pdla/ensemble_mpi.h, which explains the design: rank 0 the only
 * writer, one cluster index at a time, records shipped as bytes, only each
 * rank's main thread in MPI).
 *
 * Protocol on a private duplicate of MPI_COMM_WORLD (errors returned, not
 * fatal, so each one is checked and reported):
 *   rank r > 0 -> 0: TAG_NEXT (no data)      0 -> r: TAG_INDEX {has, index}
 *   rank r > 0 -> 0: TAG_RECORD (bytes)      0 -> r: TAG_ACK {rc, text}
 *   rank r > 0 -> 0: TAG_BYE {rc, text}, once, when its workers have ended.
 * A rank has at most one request outstanding, so a reply needs no id.
 */
#include <mpi.h>
#include <limits.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "pdla/ensemble_mpi.h"
#include "must.h"

enum { TAG_NEXT = 101, TAG_INDEX, TAG_RECORD, TAG_ACK, TAG_BYE };

/* An acknowledgement or a goodbye: a PDLA_* code and its line. */
typedef struct msg_status {
    int32_t rc;
    char text[484];
} msg_status;

static MPI_Comm ens_comm = MPI_COMM_NULL;
static int ens_initialized;
/* An MPI call failed on this rank: the protocol is broken and other ranks
 * may wait for this one forever, so pdla_ens_mpi_finalize aborts the job. */
static _Atomic int ens_broken;

static int mpi_error(int mrc, const char *what, char *err, size_t errlen)
{
    char s[MPI_MAX_ERROR_STRING];
    int n = 0;
    atomic_store(&ens_broken, 1);
    if (MPI_Error_string(mrc, s, &n) != MPI_SUCCESS) snprintf(s, sizeof s, "MPI error %d", mrc);
    return pdla_errorf(PDLA_EIO, err, errlen, "MPI: %s failed: %s", what, s);
}

#define MPI_TRY(call, what)                                                                        \
    do {                                                                                           \
        const int mrc_ = (call);                                                                   \
        if (mrc_ != MPI_SUCCESS) return mpi_error(mrc_, what, err, errlen);                        \
    } while (0)

/* Sleep between polls: short at first (a reply is usually near), then up
 * to 1 ms, so an idle wait costs no core. */
static void nap(long *ns)
{
    const struct timespec ts = {0, *ns};
    nanosleep(&ts, NULL);
    if (*ns < 1000000) *ns *= 2;
}

static int wait_all(int n, MPI_Request *rq, const char *what, char *err, size_t errlen)
{
    long ns = 20000;
    for (;;) {
        int flag = 0;
        MPI_TRY(MPI_Testall(n, rq, &flag, MPI_STATUSES_IGNORE), what);
        if (flag) return PDLA_OK;
        nap(&ns);
    }
}

int pdla_ens_mpi_init(int *rank, int *size, char *err, size_t errlen)
{
    int provided = MPI_THREAD_SINGLE;
    /* MPI_Init's own failure aborts the process (no handler is set yet). */
    MPI_TRY(MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    ens_initialized = 1;
    if (provided < MPI_THREAD_FUNNELED)
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "MPI grants thread level %d, pdla ensemble needs MPI_THREAD_FUNNELED (%d)",
                           provided, MPI_THREAD_FUNNELED);
    MPI_TRY(MPI_Comm_dup(MPI_COMM_WORLD, &ens_comm), "MPI_Comm_dup");
    MPI_TRY(MPI_Comm_set_errhandler(ens_comm, MPI_ERRORS_RETURN), "MPI_Comm_set_errhandler");
    MPI_TRY(MPI_Comm_rank(ens_comm, rank), "MPI_Comm_rank");
    MPI_TRY(MPI_Comm_size(ens_comm, size), "MPI_Comm_size");
    return PDLA_OK;
}

int pdla_ens_mpi_finalize(int code)
{
    if (!ens_initialized) return PDLA_OK;
    /* MPI_Abort ends every rank of the job and does not return. */
    if (atomic_load(&ens_broken)) (void)MPI_Abort(MPI_COMM_WORLD, code ? code : 1);
    ens_initialized = 0;
    /* MPI_Finalize even after a failed free; either failure is PDLA_EIO. */
    const int frc = ens_comm != MPI_COMM_NULL ? MPI_Comm_free(&ens_comm) : MPI_SUCCESS;
    return MPI_Finalize() == MPI_SUCCESS && frc == MPI_SUCCESS ? PDLA_OK : PDLA_EIO;
}

/* What rank 0 broadcasts before the growth. */
typedef struct share_msg {
    uint32_t magic, config_size;
    int32_t verdict;
    pdla_ens_config config;
} share_msg;
#define SHARE_MAGIC 0x70646c61u /* "pdla" */

int pdla_ens_mpi_share(int *verdict, pdla_ens_config *c, char *err, size_t errlen)
{
    int rank = 0;
    MPI_TRY(MPI_Comm_rank(ens_comm, &rank), "MPI_Comm_rank");
    share_msg m;
    memset(&m, 0, sizeof m);
    if (rank == 0) {
        m.magic = SHARE_MAGIC;
        m.config_size = (uint32_t)sizeof m.config;
        m.verdict = *verdict;
        if (*verdict == 0) m.config = *c;
    }
    MPI_TRY(MPI_Bcast(&m, (int)sizeof m, MPI_BYTE, 0, ens_comm), "MPI_Bcast of the ensemble");
    if (rank == 0) return PDLA_OK;
    if (m.magic != SHARE_MAGIC || m.config_size != sizeof m.config)
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "rank 0 runs another build of pdla (config of %u bytes, this one %zu)",
                           (unsigned)m.config_size, sizeof m.config);
    *verdict = m.verdict;
    if (m.verdict == 0) *c = m.config;
    return PDLA_OK;
}

/* ---- rank 0 ------------------------------------------------------------- */

typedef struct root_ctx {
    pdla_ens_journal *j;
    const pdla_ens_config *c;
    uint64_t *todo; /* the indices the journal lacks, ascending */
    uint64_t count;
    _Atomic uint64_t next;
    _Atomic int no_more;       /* hand out nothing more (stop or an error) */
    _Atomic int run_finished;  /* rank 0's pdla_ens_run has returned */
    _Atomic uint64_t remote_done;
    int threads;
    pdla_ens_progress_fn progress;
    void *user;
    int run_rc; /* rank 0's own run, written by its thread before run_finished */
    char run_err[1024];
    int remote_rc, stopped_rank; /* the first failed rank's code; a rank stopped */
    char remote_err[1024];
} root_ctx;

static int root_take(root_ctx *x, uint64_t *index)
{
    if (atomic_load(&x->no_more)) return 0;
    const uint64_t k = atomic_fetch_add(&x->next, 1);
    if (k >= x->count) return 0;
    *index = x->todo[k];
    return 1;
}

static int root_next(void *user, uint64_t *index) { return root_take(user, index); }

static int root_done(void *user, const pdla_ens_record *rec, char *err, size_t errlen)
{
    const root_ctx *x = user;
    return pdla_ens_journal_append(x->j, rec, err, errlen);
}

static int root_progress(void *user, uint64_t done, uint64_t particles)
{
    const root_ctx *x = user;
    if (!x->progress) return 0;
    const uint64_t remote = atomic_load(&x->remote_done);
    return x->progress(x->user, done + remote, particles + remote * x->c->params.target);
}

static void *root_run(void *arg)
{
    root_ctx *x = arg;
    const pdla_ens_scheduler s = {root_next, root_done, x};
    x->run_rc = pdla_ens_run(x->c, x->threads, &s, root_progress, x, x->run_err, sizeof x->run_err);
    /* Stopped or failed here: the other ranks get no more work either. */
    if (x->run_rc) atomic_store(&x->no_more, 1);
    atomic_store(&x->run_finished, 1);
    return NULL;
}

static void root_remote_failed(root_ctx *x, int src, int rc, const char *text)
{
    if (rc == PDLA_ESTOPPED) {
        if (!x->stopped_rank) x->stopped_rank = src;
    } else if (x->remote_rc == PDLA_OK) {
        x->remote_rc = rc < 0 ? rc : PDLA_EIO;
        snprintf(x->remote_err, sizeof x->remote_err, "rank %d: %s", src, text);
    }
    atomic_store(&x->no_more, 1);
}

/* A record from rank src: decode, journal, acknowledge. */
static int root_take_record(root_ctx *x, const MPI_Status *st, char *err, size_t errlen)
{
    int n = 0;
    MPI_TRY(MPI_Get_count(st, MPI_BYTE, &n), "MPI_Get_count");
    uint8_t *buf = malloc(n > 0 ? (size_t)n : 1);
    if (!buf) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for a record of %d bytes", n);
    const int mrc = MPI_Recv(buf, n, MPI_BYTE, st->MPI_SOURCE, TAG_RECORD, ens_comm, MPI_STATUS_IGNORE);
    if (mrc != MPI_SUCCESS) {
        free(buf);
        return mpi_error(mrc, "MPI_Recv of a record", err, errlen);
    }
    msg_status ack;
    memset(&ack, 0, sizeof ack);
    pdla_ens_record r;
    ack.rc = pdla_ens_record_decode(buf, (size_t)n, &r, ack.text, sizeof ack.text);
    free(buf);
    if (ack.rc == PDLA_OK) {
        const int had = pdla_ens_journal_has(x->j, r.index);
        ack.rc = pdla_ens_journal_append(x->j, &r, ack.text, sizeof ack.text);
        if (ack.rc == PDLA_OK && !had) atomic_fetch_add(&x->remote_done, 1);
        pdla_ens_record_free(&r);
    }
    /* The sender learns of the failure from the ack and stops. */
    if (ack.rc) root_remote_failed(x, st->MPI_SOURCE, ack.rc, ack.text);
    MPI_TRY(MPI_Send(&ack, (int)sizeof ack, MPI_BYTE, st->MPI_SOURCE, TAG_ACK, ens_comm), "MPI_Send of an ack");
    return PDLA_OK;
}

/* Serve the other ranks until rank 0's run has ended and every rank has
 * said goodbye. */
static int root_serve(root_ctx *x, int size, char *err, size_t errlen)
{
    int byes = 0;
    long ns = 20000;
    while (!(atomic_load(&x->run_finished) && byes == size - 1)) {
        int flag = 0;
        MPI_Status st;
        MPI_TRY(MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, ens_comm, &flag, &st), "MPI_Iprobe");
        if (!flag) {
            nap(&ns);
            continue;
        }
        ns = 20000;
        if (st.MPI_TAG == TAG_NEXT) {
            MPI_TRY(MPI_Recv(NULL, 0, MPI_BYTE, st.MPI_SOURCE, TAG_NEXT, ens_comm, MPI_STATUS_IGNORE),
                    "MPI_Recv of a request");
            uint64_t reply[2] = {0, 0};
            reply[0] = (uint64_t)root_take(x, &reply[1]);
            MPI_TRY(MPI_Send(reply, 2, MPI_UINT64_T, st.MPI_SOURCE, TAG_INDEX, ens_comm), "MPI_Send of an index");
        } else if (st.MPI_TAG == TAG_RECORD) {
            const int rc = root_take_record(x, &st, err, errlen);
            if (rc) return rc;
        } else if (st.MPI_TAG == TAG_BYE) {
            msg_status bye;
            MPI_TRY(MPI_Recv(&bye, (int)sizeof bye, MPI_BYTE, st.MPI_SOURCE, TAG_BYE, ens_comm, MPI_STATUS_IGNORE),
                    "MPI_Recv of a goodbye");
            bye.text[sizeof bye.text - 1] = '\0';
            byes++;
            if (bye.rc) root_remote_failed(x, st.MPI_SOURCE, bye.rc, bye.text);
        } else {
            return pdla_errorf(PDLA_EIO, err, errlen, "MPI: unexpected message tag %d from rank %d", st.MPI_TAG,
                               st.MPI_SOURCE);
        }
    }
    return PDLA_OK;
}

int pdla_ens_mpi_run_root(pdla_ens_journal *j, int threads, pdla_ens_progress_fn progress, void *user, char *err,
                          size_t errlen)
{
    int size = 1;
    MPI_TRY(MPI_Comm_size(ens_comm, &size), "MPI_Comm_size");
    const pdla_ens_config *c = pdla_ens_journal_config(j);
    root_ctx *x = calloc(1, sizeof *x);
    if (!x) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the MPI scheduler");
    x->j = j;
    x->c = c;
    x->threads = threads;
    x->progress = progress;
    x->user = user;
    const uint64_t missing = c->clusters - pdla_ens_journal_count(j);
    if (missing > SIZE_MAX / sizeof *x->todo || !(x->todo = malloc((size_t)(missing ? missing : 1) * sizeof *x->todo))) {
        free(x);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the list of clusters");
    }
    for (uint64_t i = 0; i < c->clusters && x->count < missing; i++)
        if (!pdla_ens_journal_has(j, i)) x->todo[x->count++] = i;
    atomic_init(&x->next, 0);
    atomic_init(&x->no_more, 0);
    atomic_init(&x->run_finished, 0);
    atomic_init(&x->remote_done, 0);
    pthread_t tid;
    const int crc = pthread_create(&tid, NULL, root_run, x);
    if (crc) {
        free(x->todo);
        free(x);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot start rank 0's growth thread: %s", strerror(crc));
    }
    /* An MPI failure here leaves the others waiting: pdla_ens_mpi_finalize aborts the
     * job. Rank 0's own workers end first (no more work for them). */
    int rc = root_serve(x, size, err, errlen);
    if (rc) atomic_store(&x->no_more, 1);
    if (pthread_join(tid, NULL) && rc == PDLA_OK) rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot join rank 0's growth thread");
    if (rc == PDLA_OK) {
        const uint64_t have = pdla_ens_journal_count(j);
        if (x->run_rc) rc = pdla_errorf(x->run_rc, err, errlen, "%s", x->run_err);
        else if (x->remote_rc) rc = pdla_errorf(x->remote_rc, err, errlen, "%s", x->remote_err);
        else if (x->stopped_rank) rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "rank %d was stopped", x->stopped_rank);
        else if (have < c->clusters)
            rc = pdla_errorf(PDLA_EIO, err, errlen, "%llu clusters were not grown",
                             (unsigned long long)(c->clusters - have));
    }
    free(x->todo);
    free(x);
    return rc;
}

/* ---- ranks > 0 ---------------------------------------------------------- */

enum { REQ_NONE, REQ_NEXT, REQ_DONE };

/* One request at a time from this rank's worker threads to its main thread. */
typedef struct mailbox {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int busy;      /* a worker owns the slot */
    int kind;      /* REQ_*: posted, not yet answered */
    int answered;
    int finished;  /* this rank's pdla_ens_run has returned */
    uint8_t *buf;  /* REQ_DONE: the encoded record */
    size_t len;
    uint64_t has, index;  /* REQ_NEXT's answer */
    msg_status ack;       /* REQ_DONE's answer */
    const pdla_ens_config *c;
    int threads;
    pdla_ens_progress_fn progress;
    void *user;
    int run_rc;
    char run_err[1024];
} mailbox;

/* Take the slot, post a request (buf: REQ_DONE's record) and wait for its
 * answer; mu is held on entry and exit. */
static void mb_ask(mailbox *m, int kind, uint8_t *buf, size_t len)
{
    while (m->busy) PDLA_MUST(pthread_cond_wait(&m->cv, &m->mu));
    m->busy = 1;
    m->buf = buf;
    m->len = len;
    m->kind = kind;
    m->answered = 0;
    PDLA_MUST(pthread_cond_broadcast(&m->cv));
    while (!m->answered) PDLA_MUST(pthread_cond_wait(&m->cv, &m->mu));
}

static void mb_release(mailbox *m)
{
    m->busy = 0;
    m->buf = NULL;
    m->kind = REQ_NONE;
    m->answered = 0;
    PDLA_MUST(pthread_cond_broadcast(&m->cv));
}

static int worker_next(void *user, uint64_t *index)
{
    mailbox *m = user;
    PDLA_MUST(pthread_mutex_lock(&m->mu));
    mb_ask(m, REQ_NEXT, NULL, 0);
    const int has = m->has != 0;
    *index = m->index;
    mb_release(m);
    PDLA_MUST(pthread_mutex_unlock(&m->mu));
    return has;
}

static int worker_done(void *user, const pdla_ens_record *rec, char *err, size_t errlen)
{
    mailbox *m = user;
    uint8_t *buf = NULL;
    size_t len = 0;
    if (pdla_ens_record_encode(rec, &buf, &len))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory encoding cluster %llu",
                           (unsigned long long)rec->index);
    if (len > INT_MAX) {
        free(buf);
        return pdla_errorf(PDLA_EINVAL, err, errlen, "cluster %llu's record (%zu bytes) is too large for one MPI message",
                           (unsigned long long)rec->index, len);
    }
    PDLA_MUST(pthread_mutex_lock(&m->mu));
    mb_ask(m, REQ_DONE, buf, len);
    const int rc = m->ack.rc;
    if (rc) pdla_errorf(rc < 0 ? rc : PDLA_EIO, err, errlen, "%s", m->ack.text);
    mb_release(m);
    PDLA_MUST(pthread_mutex_unlock(&m->mu));
    free(buf);
    return rc;
}

static void *worker_run(void *arg)
{
    mailbox *m = arg;
    const pdla_ens_scheduler s = {worker_next, worker_done, m};
    const int rc = pdla_ens_run(m->c, m->threads, &s, m->progress, m->user, m->run_err, sizeof m->run_err);
    PDLA_MUST(pthread_mutex_lock(&m->mu));
    m->run_rc = rc;
    m->finished = 1;
    PDLA_MUST(pthread_cond_broadcast(&m->cv));
    PDLA_MUST(pthread_mutex_unlock(&m->mu));
    return NULL;
}

/* Carry one request to rank 0 and its answer back (main thread, mu not held). */
static int worker_exchange(mailbox *m, int kind, char *err, size_t errlen)
{
    MPI_Request rq[2];
    if (kind == REQ_NEXT) {
        uint64_t reply[2] = {0, 0};
        MPI_TRY(MPI_Irecv(reply, 2, MPI_UINT64_T, 0, TAG_INDEX, ens_comm, &rq[0]), "MPI_Irecv of an index");
        MPI_TRY(MPI_Isend(NULL, 0, MPI_BYTE, 0, TAG_NEXT, ens_comm, &rq[1]), "MPI_Isend of a request");
        const int rc = wait_all(2, rq, "waiting for an index", err, errlen);
        if (rc) return rc;
        m->has = reply[0];
        m->index = reply[1];
        return PDLA_OK;
    }
    msg_status ack;
    MPI_TRY(MPI_Irecv(&ack, (int)sizeof ack, MPI_BYTE, 0, TAG_ACK, ens_comm, &rq[0]), "MPI_Irecv of an ack");
    MPI_TRY(MPI_Isend(m->buf, (int)m->len, MPI_BYTE, 0, TAG_RECORD, ens_comm, &rq[1]), "MPI_Isend of a record");
    const int rc = wait_all(2, rq, "shipping a record", err, errlen);
    if (rc) return rc;
    ack.text[sizeof ack.text - 1] = '\0';
    m->ack = ack;
    return PDLA_OK;
}

/* The main thread: carry requests until the workers have ended. */
static int worker_serve(mailbox *m, char *err, size_t errlen)
{
    int rc = PDLA_OK;
    PDLA_MUST(pthread_mutex_lock(&m->mu));
    for (;;) {
        while (!m->finished && (m->kind == REQ_NONE || m->answered)) PDLA_MUST(pthread_cond_wait(&m->cv, &m->mu));
        if (m->kind != REQ_NONE && !m->answered) {
            const int kind = m->kind;
            if (rc == PDLA_OK) {
                PDLA_MUST(pthread_mutex_unlock(&m->mu));
                rc = worker_exchange(m, kind, err, errlen);
                PDLA_MUST(pthread_mutex_lock(&m->mu));
            }
            if (rc) { /* no answer from rank 0: refuse, the workers end */
                m->has = 0;
                m->ack.rc = PDLA_EIO;
                snprintf(m->ack.text, sizeof m->ack.text, "lost contact with rank 0");
            }
            m->answered = 1;
            PDLA_MUST(pthread_cond_broadcast(&m->cv));
            continue;
        }
        if (m->finished) break;
    }
    PDLA_MUST(pthread_mutex_unlock(&m->mu));
    return rc;
}

int pdla_ens_mpi_run_worker(const pdla_ens_config *c, int threads, pdla_ens_progress_fn progress, void *user,
                            char *err, size_t errlen)
{
    mailbox *m = calloc(1, sizeof *m);
    if (!m) return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the MPI scheduler");
    m->c = c;
    m->threads = threads;
    m->progress = progress;
    m->user = user;
    int prc = pthread_mutex_init(&m->mu, NULL);
    if (prc) {
        free(m);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot create a mutex: %s", strerror(prc));
    }
    if ((prc = pthread_cond_init(&m->cv, NULL))) {
        PDLA_MUST(pthread_mutex_destroy(&m->mu));
        free(m);
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "cannot create a condition variable: %s", strerror(prc));
    }
    pthread_t tid;
    int rc = PDLA_OK;
    if ((prc = pthread_create(&tid, NULL, worker_run, m))) {
        m->run_rc = pdla_errorf(PDLA_ENOMEM, m->run_err, sizeof m->run_err, "cannot start the growth thread: %s",
                                strerror(prc));
    } else {
        rc = worker_serve(m, err, errlen);
        if (pthread_join(tid, NULL) && rc == PDLA_OK)
            rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot join the growth thread");
    }
    if (rc == PDLA_OK) {
        /* Goodbye, with this rank's outcome: rank 0 waits for it. */
        msg_status bye;
        memset(&bye, 0, sizeof bye);
        bye.rc = m->run_rc;
        snprintf(bye.text, sizeof bye.text, "%.480s", m->run_rc ? m->run_err : "");
        MPI_Request rq;
        const int mrc = MPI_Isend(&bye, (int)sizeof bye, MPI_BYTE, 0, TAG_BYE, ens_comm, &rq);
        if (mrc != MPI_SUCCESS) rc = mpi_error(mrc, "MPI_Isend of a goodbye", err, errlen);
        else rc = wait_all(1, &rq, "saying goodbye", err, errlen);
        /* Rank 0 reports this rank's error (it came in the goodbye). */
        if (rc == PDLA_OK && m->run_rc == PDLA_ESTOPPED) rc = pdla_errorf(PDLA_ESTOPPED, err, errlen, "%s", m->run_err);
    }
    PDLA_MUST(pthread_cond_destroy(&m->cv));
    PDLA_MUST(pthread_mutex_destroy(&m->mu));
    free(m);
    return rc;
}
