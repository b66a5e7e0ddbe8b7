/*
 * rundir.c - the run directory's lock: one writer per run directory, by
 * flock on the directory itself (nothing is created, so a crash leaves no
 * stale lock). pdla_rundir_lock / pdla_rundir_unlock in pdla.h. Also what
 * every model does to the directory's names: the writability probe, the
 * set-aside of a damaged checkpoint after a fallback resume (one numbering,
 * checkpoint.damaged[.N].h5, for DLA and the event model) and the removal
 * of an older run's files.
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
#include <sys/stat.h>
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
 * checkpoint.h5; the damaged ones set aside: is_aside_name), and the DLA
 * run summary. One list for every model: a --force run of one model over another's directory left
 * the other's checkpoints, and a later --resume brought the older run
 * back over the new cluster.h5. The summary last (writes_summary drops it). */
static const char *const old_run_names[] = {PDLA_CHECKPOINT_NAME, "checkpoint.1.h5", "checkpoint.2.h5",
                                            "checkpoint.prev.h5", "summary.txt"};

/* Kept files are numbered up to this (three digits: is_aside_name); past
 * it a set-aside is refused rather than a kept file replaced (a directory
 * that needed so many fallbacks has a disk to look at, and each kept file
 * may be gigabytes). */
#define ASIDE_MAX 999

/* The k-th name a fallback resume sets a damaged checkpoint aside under
 * (pdla_rundir_set_aside): k = 1 is checkpoint.damaged.h5, then
 * checkpoint.damaged.2.h5, ... */
static void aside_name(char *buf, size_t n, const char *dir, int k)
{
    if (k == 1) snprintf(buf, n, "%s/" PDLA_CHECKPOINT_ASIDE_PREFIX "h5", dir);
    else snprintf(buf, n, "%s/" PDLA_CHECKPOINT_ASIDE_PREFIX "%d.h5", dir, k);
}

int pdla_rundir_set_aside(const char *dir, const char *src, char *kept, size_t keptlen, char *err, size_t errlen)
{
    struct stat s0, sk;
    kept[0] = '\0';
    if (lstat(src, &s0) != 0)
        return errno == ENOENT ? PDLA_OK : pdla_errorf(PDLA_EIO, err, errlen, "cannot set %s aside: %s", src,
                                                       strerror(errno));
    for (int k = 1; k <= ASIDE_MAX; k++) {
        aside_name(kept, keptlen, dir, k);
        if (lstat(kept, &sk) == 0) {
            if (sk.st_dev != s0.st_dev || sk.st_ino != s0.st_ino) continue;
            if (unlink(src) == 0) return PDLA_OK;
            return pdla_errorf(PDLA_EIO, err, errlen, "%s is kept as %s, but cannot remove it: %s", src, kept,
                               strerror(errno));
        }
        if (errno != ENOENT)
            return pdla_errorf(PDLA_EIO, err, errlen, "cannot look at %s: %s", kept, strerror(errno));
        const int rc = h5u_publish(src, kept);
        if (rc == 0) return PDLA_OK;
        if (rc == PDLA_EEXIST) continue; /* made since the lstat: take the next name */
        if (rc == 1)
            return pdla_errorf(PDLA_EIO, err, errlen, "%s is kept as %s, but cannot remove it: %s", src, kept,
                               strerror(errno));
        return pdla_errorf(PDLA_EIO, err, errlen, "cannot set %s aside as %s: %s", src, kept, strerror(errno));
    }
    kept[0] = '\0';
    return pdla_errorf(PDLA_EIO, err, errlen,
                       "cannot set %s aside: %d files are kept as %s/" PDLA_CHECKPOINT_ASIDE_PREFIX
                       "*h5 already; remove those no longer needed",
                       src, ASIDE_MAX, dir);
}

/* Whether name is one a fallback resume sets aside (pdla_rundir_set_aside:
 * PDLA_CHECKPOINT_ASIDE_PREFIX "h5", or the prefix, a number and ".h5"):
 * only those, not a user's checkpoint.damaged.notes.txt. */
static int is_aside_name(const char *name)
{
    const size_t plen = strlen(PDLA_CHECKPOINT_ASIDE_PREFIX);
    if (strncmp(name, PDLA_CHECKPOINT_ASIDE_PREFIX, plen)) return 0;
    const char *q = name + plen;
    if (!strcmp(q, "h5")) return 1;
    size_t digits = 0;
    while (q[digits] >= '0' && q[digits] <= '9') digits++;
    return digits > 0 && digits <= 3 && q[0] != '0' && !strcmp(q + digits, ".h5");
}

/* Every old-run name present in dir (the first n of old_run_names and the
 * set-aside checkpoints) goes into *list (malloc'ed, *count of them).
 * Checked before anything is removed: a name that is a directory refuses
 * the whole removal, so a refused run leaves the older run as it was
 * (its checkpoints resumable). 0, or -1 with err. */
static int old_run_list(const char *dir, size_t n, char ***list, size_t *count, char *err, size_t errlen)
{
    *list = NULL;
    *count = 0;
    DIR *d = opendir(dir);
    if (!d) return pdla_errorf(-1, err, errlen, "cannot read run directory '%s': %s", dir, strerror(errno));
    int rc = 0;
    const struct dirent *de;
    while (rc == 0 && (de = readdir(d))) {
        int take = is_aside_name(de->d_name);
        for (size_t i = 0; i < n && !take; i++) take = !strcmp(de->d_name, old_run_names[i]);
        if (!take) continue;
        char p[4400];
        snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
        struct stat st;
        if (lstat(p, &st) != 0) {
            if (errno == ENOENT) continue; /* gone meanwhile */
            rc = pdla_errorf(-1, err, errlen, "cannot look at the older run's '%s': %s", p, strerror(errno));
            break;
        }
        if (S_ISDIR(st.st_mode)) {
            rc = pdla_errorf(-1, err, errlen, "cannot remove the older run's '%s': %s", p, strerror(EISDIR));
            break;
        }
        char **grown = realloc(*list, (*count + 1) * sizeof *grown);
        if (grown) *list = grown;
        if (!grown || !(grown[*count] = strdup(p))) {
            rc = pdla_errorf(-1, err, errlen, "out of memory listing run directory '%s'", dir);
            break;
        }
        (*count)++;
    }
    if (closedir(d) != 0 && rc == 0)
        rc = pdla_errorf(-1, err, errlen, "cannot read run directory '%s': %s", dir, strerror(errno));
    return rc;
}

_Static_assert(PDLA_CHECKPOINT_GENERATIONS == 3, "old_run_names lists the DLA generations .1 and .2");

static void free_list(char **list, size_t count)
{
    for (size_t i = 0; i < count; i++) free(list[i]);
    free(list);
}

int pdla_rundir_old_run_name(const char *name)
{
    if (is_aside_name(name)) return 1;
    for (size_t i = 0; i < sizeof old_run_names / sizeof old_run_names[0]; i++)
        if (!strcmp(name, old_run_names[i])) return 1;
    return 0;
}

int pdla_rundir_remove_old_run(const char *dir, int writes_summary, char *err, size_t errlen)
{
    char **list;
    size_t count;
    const size_t n = sizeof old_run_names / sizeof old_run_names[0] - (writes_summary ? 1 : 0);
    if (old_run_list(dir, n, &list, &count, err, errlen)) {
        free_list(list, count);
        return PDLA_EIO;
    }
    int rc = PDLA_OK;
    /* The checkpoints, then the summary: a removal that fails midway
     * leaves the older run's description with what is left of it. */
    for (int pass = 0; pass < 2; pass++)
        for (size_t i = 0; i < count && rc == PDLA_OK; i++) {
            if ((strstr(list[i], "/summary.txt") != NULL) != pass) continue;
            if (unlink(list[i]) != 0 && errno != ENOENT)
                rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot remove the older run's '%s': %s", list[i],
                                 strerror(errno));
        }
    /* Synced when something went: a crash must not bring them back. */
    if (rc == PDLA_OK && count > 0 && h5u_fsync_dir(dir) != 0)
        rc = pdla_errorf(PDLA_EIO, err, errlen, "cannot sync run directory '%s': %s", dir, strerror(errno));
    free_list(list, count);
    return rc;
}

int pdla_rundir_fsync(const char *dir)
{
    return h5u_fsync_dir(dir);
}
