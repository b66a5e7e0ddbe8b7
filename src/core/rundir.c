/*
 * rundir.c - the run directory's lock: one writer per run directory, by
 * flock on the directory itself (nothing is created, so a crash leaves no
 * stale lock). pdla_rundir_lock / pdla_rundir_unlock in pdla.h.
 */
#include "pdla/pdla.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
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
