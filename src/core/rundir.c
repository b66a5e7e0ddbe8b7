/*
 * rundir.c - the run directory's lock: one writer per run directory, by
 * flock on the directory itself (nothing is created, so a crash leaves no
 * stale lock). pdla_rundir_lock / pdla_rundir_unlock in pdla.h.
 */
#include "pdla/pdla.h"
#include "h5util.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <unistd.h>

int pdla_rundir_lock(const char *dir, int *fd, char *err, size_t errlen)
{
    *fd = -1;
    const int d = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (d < 0) {
        if (err && errlen) snprintf(err, errlen, "cannot open run directory '%s': %s", dir, strerror(errno));
        return PDLA_EIO;
    }
    if (flock(d, LOCK_EX | LOCK_NB) != 0) {
        const int e = errno;
        close(d);
        if (e == EWOULDBLOCK) {
            if (err && errlen)
                snprintf(err, errlen, "run directory '%s' is in use by another pdla process", dir);
            return PDLA_EEXIST;
        }
        if (err && errlen) snprintf(err, errlen, "cannot lock run directory '%s': %s", dir, strerror(e));
        return PDLA_EIO;
    }
    *fd = d;
    return PDLA_OK;
}

void pdla_rundir_unlock(int fd)
{
    if (fd >= 0) close(fd); /* closing the last descriptor releases the flock */
}

/* The probes of pdla processes that no longer exist (killed between the
 * probe's create and unlink: models-faults' kill -9 chains found one left).
 * A live process's probe is left alone: some commands probe before they
 * take the directory's lock. */
static void remove_dead_probes(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    static const char pre[] = ".pdla-probe.";
    const struct dirent *de;
    while ((de = readdir(d))) {
        if (strncmp(de->d_name, pre, sizeof pre - 1)) continue;
        char *end;
        errno = 0;
        const long pid = strtol(de->d_name + sizeof pre - 1, &end, 10);
        if (errno || *end || pid <= 0 || pid > INT_MAX || pid == (long)getpid()) continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue; /* alive (EPERM too) */
        char p[4400];
        snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
        unlink(p);
    }
    closedir(d);
}

int pdla_rundir_probe(const char *dir)
{
    char p[4300];
    snprintf(p, sizeof p, "%s/.pdla-probe.%ld", dir, (long)getpid());
    int fd = open(p, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    /* Our own name already there: a killed pdla of the same pid left it (a
     * container's pdla is often pid 1 every time); no live process has it. */
    if (fd < 0 && errno == EEXIST && unlink(p) == 0)
        fd = open(p, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) return errno;
    if (close(fd) != 0) {
        const int e = errno;
        unlink(p);
        return e;
    }
    /* ENOENT: removed by another host's pdla that took our pid for a dead
     * one of its own (a shared file system); the create proved the point */
    if (unlink(p) != 0 && errno != ENOENT) return errno;
    remove_dead_probes(dir);
    return 0;
}

/* Every name under which a model keeps a checkpoint (DLA: the
 * generations checkpoint.h5, checkpoint.1.h5, ...; event: .prev; DLCA:
 * checkpoint.h5; the damaged ones set aside: remove_aside), and the DLA
 * run summary. One list for
 * every model: a --force run of one model over another's directory left
 * the other's checkpoints, and a later --resume brought the older run
 * back over the new cluster.h5. The summary last (see writes_summary). */
static const char *const old_run_names[] = {PDLA_CHECKPOINT_NAME, "checkpoint.1.h5", "checkpoint.2.h5",
                                            "checkpoint.prev.h5", "summary.txt"};

/* The damaged checkpoints a DLA fallback resume set aside
 * (PDLA_CHECKPOINT_ASIDE_PREFIX: checkpoint.damaged.h5, .damaged.2.h5, ...):
 * they belong to the run being replaced. 0 (*removed set when one went),
 * or -1 with err. */
static int remove_aside(const char *dir, int *removed, char *err, size_t errlen)
{
    DIR *d = opendir(dir);
    if (!d) return pdla_errorf(-1, err, errlen, "cannot read run directory '%s': %s", dir, strerror(errno));
    const size_t plen = strlen(PDLA_CHECKPOINT_ASIDE_PREFIX);
    char p[4400];
    int rc = 0;
    const struct dirent *de;
    while (rc == 0 && (de = readdir(d))) {
        if (strncmp(de->d_name, PDLA_CHECKPOINT_ASIDE_PREFIX, plen)) continue;
        snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
        if (unlink(p) == 0) *removed = 1;
        else if (errno != ENOENT)
            rc = pdla_errorf(-1, err, errlen, "cannot remove the older run's '%s': %s", p, strerror(errno));
    }
    closedir(d);
    return rc;
}
_Static_assert(PDLA_CHECKPOINT_GENERATIONS == 3, "old_run_names lists the DLA generations .1 and .2");

int pdla_rundir_remove_old_run(const char *dir, int writes_summary, char *err, size_t errlen)
{
    char p[4400];
    const size_t n = sizeof old_run_names / sizeof old_run_names[0] - (writes_summary ? 1 : 0);
    int removed = 0;
    for (size_t i = 0; i < n; i++) {
        snprintf(p, sizeof p, "%s/%s", dir, old_run_names[i]);
        if (unlink(p) == 0) removed = 1;
        else if (errno != ENOENT)
            return pdla_errorf(PDLA_EIO, err, errlen, "cannot remove the older run's '%s': %s", p, strerror(errno));
    }
    if (remove_aside(dir, &removed, err, errlen)) return PDLA_EIO;
    /* Only when something went: a run over a directory without an older
     * run's files syncs nothing more (and fails at no new point). */
    if (removed && h5u_fsync_dir(dir) != 0)
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot sync run directory '%s': %s", dir, strerror(errno));
    return PDLA_OK;
}

int pdla_rundir_fsync(const char *dir)
{
    return h5u_fsync_dir(dir);
}

void pdla_rundir_remove_prefixed(const char *dir, const char *const *prefixes, size_t n)
{
    DIR *d = opendir(dir);
    if (!d) return;
    char p[4400];
    const struct dirent *de;
    while ((de = readdir(d)))
        for (size_t i = 0; i < n; i++)
            if (!strncmp(de->d_name, prefixes[i], strlen(prefixes[i]))) {
                snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
                unlink(p);
                break;
            }
    closedir(d);
}
