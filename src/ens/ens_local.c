/*
 * ens_local.c - the in-process scheduler (pdla_ens_run_local): the clusters
 * the journal lacks, handed out in index order from one atomic counter, and
 * each finished record appended to the journal.
 */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "pdla/ensemble.h"

/* ---- the in-process scheduler -------------------------------------------- */

typedef struct local_sched {
    uint64_t *todo; /* the indices the journal lacks, ascending */
    uint64_t count;
    _Atomic uint64_t next;
    pdla_ens_journal *j;
} local_sched;

static int local_next(void *user, uint64_t *index)
{
    local_sched *q = user;
    const uint64_t k = atomic_fetch_add(&q->next, 1);
    if (k >= q->count) return 0;
    *index = q->todo[k];
    return 1;
}

static int local_done(void *user, const pdla_ens_record *rec, char *err, size_t errlen)
{
    local_sched *q = user;
    return pdla_ens_journal_append(q->j, rec, err, errlen);
}

int pdla_ens_run_local(pdla_ens_journal *j, int threads, pdla_ens_progress_fn progress, void *user,
                       char *err, size_t errlen)
{
    const pdla_ens_config *c = pdla_ens_journal_config(j);
    local_sched q;
    memset(&q, 0, sizeof q);
    q.j = j;
    const uint64_t missing = c->clusters - pdla_ens_journal_count(j);
    if (missing == 0) return PDLA_OK;
    if (missing > SIZE_MAX / sizeof *q.todo || !(q.todo = malloc((size_t)missing * sizeof *q.todo)))
        return pdla_errorf(PDLA_ENOMEM, err, errlen, "out of memory for the list of clusters");
    for (uint64_t i = 0; i < c->clusters && q.count < missing; i++)
        if (!pdla_ens_journal_has(j, i)) q.todo[q.count++] = i;
    atomic_init(&q.next, 0);
    const pdla_ens_scheduler s = {local_next, local_done, &q};
    const int rc = pdla_ens_run(c, threads, &s, progress, user, err, errlen);
    free(q.todo);
    return rc;
}
