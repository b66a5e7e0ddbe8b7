/*
 * faultshim.c - an LD_PRELOAD library for the write-fault suite (issue 10):
 * makes the k-th write-like call on a regular file fail, as a full or
 * broken disk would.
 *
 *   FAULT_AT=k      the k-th counted call fails (1-based); 0 or unset: none
 *   FAULT_OP=write|fsync|fallocate|stdio|any|pread|rename|dirsync   which
 *                   calls are counted (default any). stdio: fflush and fclose of a stream
 *                   writing a regular file - glibc's stdio writes through
 *                   internal calls no preload can see, so a failure there is
 *                   made by dropping the stream's buffer (__fpurge) and
 *                   returning EOF with the error, as a failed flush does;
 *                   pread (only when asked, never in any): pread and
 *                   pread64 fail with the error, as a bad sector does;
 *                   rename (only when asked): rename, renameat, renameat2, link and
 *                   linkat fail with the error (FAULT_PATH is matched
 *                   against either name); dirsync (only when asked): fsync
 *                   and fdatasync of a directory
 *   FAULT_ERR=ENOSPC|EIO|EDQUOT|SHORT    the error; SHORT writes half the
 *                   bytes and reports that, which a correct caller retries
 *   FAULT_STICKY=1  every counted call after the k-th fails too (a full disk)
 *   FAULT_COUNT=F   at exit, write the number of counted calls to file F
 *   FAULT_FLOCK=1   flock(LOCK_NB) answers EWOULDBLOCK: another process won
 *                   the run directory's lock (a deterministic lost race)
 *   FAULT_FLOCK=2   flock(LOCK_NB) on a directory answers ENOLCK: the run
 *                   directory's lock cannot be taken (an NFS mount without
 *                   a lock daemon). Files are left alone: HDF5 flocks what
 *                   it opens, and failing those too would refuse every read
 *                   (users there set HDF5_USE_FILE_LOCKING=FALSE), hiding
 *                   whether pdla refused for its own lock
 *   FAULT_AFFINITY=1  sched_setaffinity and pthread_setaffinity_np fail
 *                   with EPERM: the system refuses --bind core's pinning
 *                   (a cgroup cpuset, a container)
 *   FAULT_PATH=S    count only calls on files whose path contains S (e.g.
 *                   "ensemble.h5.tmp.": the final write of an ensemble)
 *   FAULT_SIGNAL=N  the k-th counted call does not fail: it raises signal N
 *                   in the calling thread, then goes through - a signal
 *                   delivered exactly during that write (a SIGTERM from a
 *                   batch system at the worst moment), without sleeps;
 *                   FAULT_SIGNAL=9 is kill -9 just before that call (no
 *                   handler needed: the process ends there)
 *   FAULT_PHYS_PAGES=n  sysconf(_SC_PHYS_PAGES) answers n: a machine of n
 *                   pages, so the memory budgets that scale with it bite
 *                   (DLCA's snapshots: a quarter of the memory)
 *
 * Counted: write, pwrite, pwrite64, writev, fsync, fdatasync, fallocate,
 * posix_fallocate - only on regular files, so stderr and pipes are left alone;
 * rename, renameat, renameat2, link, linkat and a directory's fsync only when asked.
 */
#undef _FILE_OFFSET_BITS /* define pwrite and pwrite64 both, as libc does */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#include <sched.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdio_ext.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

enum { OP_WRITE = 1, OP_FSYNC = 2, OP_FALLOC = 4, OP_STDIO = 8, OP_PREAD = 16, OP_RENAME = 32, OP_DIRSYNC = 64 };

static atomic_long calls;
static long fault_at = -1;
static int ops = OP_WRITE | OP_FSYNC | OP_FALLOC | OP_STDIO, err_no = ENOSPC, shortw, sticky, inited, sig_no;
static const char *count_file, *path_part;

static void init(void)
{
    if (inited) return;
    inited = 1;
    const char *s = getenv("FAULT_AT");
    fault_at = s ? atol(s) : 0;
    if ((s = getenv("FAULT_OP"))) {
        if (!strcmp(s, "write")) ops = OP_WRITE;
        else if (!strcmp(s, "fsync")) ops = OP_FSYNC;
        else if (!strcmp(s, "fallocate")) ops = OP_FALLOC;
        else if (!strcmp(s, "stdio")) ops = OP_STDIO;
        else if (!strcmp(s, "pread")) ops = OP_PREAD;
        else if (!strcmp(s, "rename")) ops = OP_RENAME;
        else if (!strcmp(s, "dirsync")) ops = OP_DIRSYNC;
    }
    if ((s = getenv("FAULT_ERR"))) {
        if (!strcmp(s, "EIO")) err_no = EIO;
        else if (!strcmp(s, "EDQUOT")) err_no = EDQUOT;
        else if (!strcmp(s, "SHORT")) shortw = 1;
    }
    sticky = (s = getenv("FAULT_STICKY")) && *s == '1';
    count_file = getenv("FAULT_COUNT");
    path_part = getenv("FAULT_PATH");
    sig_no = (s = getenv("FAULT_SIGNAL")) ? atoi(s) : 0;
}

__attribute__((destructor)) static void report(void)
{
    if (!count_file) return;
    FILE *f = fopen(count_file, "w");
    if (f) {
        fprintf(f, "%ld\n", (long)atomic_load(&calls));
        fclose(f);
    }
}

/* The k-th counted call: 1 when it fails (or, SHORT, is cut); 0 when it
 * goes through (after raising FAULT_SIGNAL, when that is set). */
static int count_hit(void)
{
    const long k = atomic_fetch_add(&calls, 1) + 1;
    if (fault_at <= 0) return 0;
    const int now = k == fault_at || (sticky && k > fault_at);
    if (now && sig_no == SIGKILL) raise(SIGKILL); /* kill -9 right before this call */
    if (now && sig_no > 0) {
        const int saved = errno;
        /* A signal ignored or left at its default (SIGINT is ignored in a
         * background job started without job control) would test nothing:
         * say so and exit 99, which no test accepts. */
        struct sigaction sa;
        if (sigaction(sig_no, NULL, &sa) || (!(sa.sa_flags & SA_SIGINFO) &&
                                              (sa.sa_handler == SIG_IGN || sa.sa_handler == SIG_DFL))) {
            static const char msg[] = "faultshim: FAULT_SIGNAL is not caught by the program\n";
            (void)!write(2, msg, sizeof msg - 1);
            _exit(99);
        }
        raise(sig_no); /* the handler runs before raise returns */
        errno = saved;
        return 0;
    }
    return now;
}

/* 1: this call on fd fails (or, SHORT, is cut); 0: it goes through.
 * Counted: regular files (directories for OP_DIRSYNC) not in memory. */
static int hit(int fd, int op)
{
    init();
    if (!(ops & op)) return 0;
    struct stat st;
    if (fstat(fd, &st) != 0 || !(op == OP_DIRSYNC ? S_ISDIR(st.st_mode) : S_ISREG(st.st_mode))) return 0;
    /* Memory files (memfd_create) are not on the disk that fails. */
    char link[64], target[4200];
    snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    const ssize_t n = readlink(link, target, sizeof target - 1);
    if (n > 0) {
        target[n] = '\0';
        if (!strncmp(target, "/memfd:", 7)) return 0;
    }
    if (path_part && (n <= 0 || !strstr(target, path_part))) return 0;
    return count_hit();
}

/* The same for a call on names (rename, link): counted when either name
 * holds FAULT_PATH (or without it). */
static int hit_names(const char *a, const char *b)
{
    init();
    if (!(ops & OP_RENAME)) return 0;
    if (path_part && !strstr(a, path_part) && !strstr(b, path_part)) return 0;
    return count_hit();
}

#define REAL(name, ret, ...)                                                       \
    static ret (*real_##name)(__VA_ARGS__);                                        \
    if (!real_##name) real_##name = (ret(*)(__VA_ARGS__))dlsym(RTLD_NEXT, #name)

ssize_t write(int fd, const void *buf, size_t n)
{
    REAL(write, ssize_t, int, const void *, size_t);
    if (n > 0 && hit(fd, OP_WRITE)) {
        if (shortw && n > 1) return real_write(fd, buf, n / 2);
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_write(fd, buf, n);
}

ssize_t pread(int fd, void *buf, size_t n, off_t off)
{
    REAL(pread, ssize_t, int, void *, size_t, off_t);
    if (n > 0 && hit(fd, OP_PREAD)) {
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_pread(fd, buf, n, off);
}

ssize_t pread64(int fd, void *buf, size_t n, off_t off)
{
    REAL(pread64, ssize_t, int, void *, size_t, off_t);
    if (n > 0 && hit(fd, OP_PREAD)) {
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_pread64(fd, buf, n, off);
}

ssize_t pwrite(int fd, const void *buf, size_t n, off_t off)
{
    REAL(pwrite, ssize_t, int, const void *, size_t, off_t);
    if (n > 0 && hit(fd, OP_WRITE)) {
        if (shortw && n > 1) return real_pwrite(fd, buf, n / 2, off);
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_pwrite(fd, buf, n, off);
}

ssize_t pwrite64(int fd, const void *buf, size_t n, off_t off)
{
    REAL(pwrite64, ssize_t, int, const void *, size_t, off_t);
    if (n > 0 && hit(fd, OP_WRITE)) {
        if (shortw && n > 1) return real_pwrite64(fd, buf, n / 2, off);
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_pwrite64(fd, buf, n, off);
}

ssize_t writev(int fd, const struct iovec *iov, int cnt)
{
    REAL(writev, ssize_t, int, const struct iovec *, int);
    if (cnt > 0 && hit(fd, OP_WRITE)) {
        /* SHORT: half of the first buffer, as a partial writev may. */
        if (shortw && iov[0].iov_len > 1) return real_writev(fd, &(struct iovec){iov[0].iov_base, iov[0].iov_len / 2}, 1);
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_writev(fd, iov, cnt);
}

int fsync(int fd)
{
    REAL(fsync, int, int);
    if (hit(fd, OP_FSYNC) || hit(fd, OP_DIRSYNC)) {
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_fsync(fd);
}

int fdatasync(int fd)
{
    REAL(fdatasync, int, int);
    if (hit(fd, OP_FSYNC) || hit(fd, OP_DIRSYNC)) {
        errno = shortw ? EIO : err_no;
        return -1;
    }
    return real_fdatasync(fd);
}

int fallocate(int fd, int mode, off_t off, off_t len)
{
    REAL(fallocate, int, int, int, off_t, off_t);
    if (hit(fd, OP_FALLOC)) {
        errno = shortw ? ENOSPC : err_no;
        return -1;
    }
    return real_fallocate(fd, mode, off, len);
}

int fallocate64(int fd, int mode, off_t off, off_t len)
{
    REAL(fallocate64, int, int, int, off_t, off_t);
    if (hit(fd, OP_FALLOC)) {
        errno = shortw ? ENOSPC : err_no;
        return -1;
    }
    return real_fallocate64(fd, mode, off, len);
}

int posix_fallocate(int fd, off_t off, off_t len)
{
    REAL(posix_fallocate, int, int, off_t, off_t);
    if (hit(fd, OP_FALLOC)) return shortw ? ENOSPC : err_no;
    return real_posix_fallocate(fd, off, len);
}

int posix_fallocate64(int fd, off_t off, off_t len)
{
    REAL(posix_fallocate64, int, int, off_t, off_t);
    if (hit(fd, OP_FALLOC)) return shortw ? ENOSPC : err_no;
    return real_posix_fallocate64(fd, off, len);
}

/* A failed rename or link: -1 with the error (SHORT means nothing to a
 * name: EIO). */
static int name_fail(void)
{
    errno = shortw ? EIO : err_no;
    return -1;
}

int rename(const char *from, const char *to)
{
    REAL(rename, int, const char *, const char *);
    if (hit_names(from, to)) return name_fail();
    return real_rename(from, to);
}

int renameat(int fd1, const char *from, int fd2, const char *to)
{
    REAL(renameat, int, int, const char *, int, const char *);
    if (hit_names(from, to)) return name_fail();
    return real_renameat(fd1, from, fd2, to);
}

/* h5u_publish moves a finished file in place with renameat2
 * (RENAME_NOREPLACE): without this a rename fault never reached it. */
int renameat2(int fd1, const char *from, int fd2, const char *to, unsigned int flags)
{
    REAL(renameat2, int, int, const char *, int, const char *, unsigned int);
    if (hit_names(from, to)) return name_fail();
    return real_renameat2(fd1, from, fd2, to, flags);
}

int link(const char *from, const char *to)
{
    REAL(link, int, const char *, const char *);
    if (hit_names(from, to)) return name_fail();
    return real_link(from, to);
}

int linkat(int fd1, const char *from, int fd2, const char *to, int flags)
{
    REAL(linkat, int, int, const char *, int, const char *, int);
    if (hit_names(from, to)) return name_fail();
    return real_linkat(fd1, from, fd2, to, flags);
}

long sysconf(int name)
{
    REAL(sysconf, long, int);
    const char *s = getenv("FAULT_PHYS_PAGES");
    if (name == _SC_PHYS_PAGES && s && *s) return atol(s);
    return real_sysconf(name);
}

int flock(int fd, int op)
{
    REAL(flock, int, int, int);
    const char *s = getenv("FAULT_FLOCK");
    struct stat st;
    if (s && *s == '1' && (op & LOCK_NB)) {
        errno = EWOULDBLOCK;
        return -1;
    }
    if (s && *s == '2' && (op & LOCK_NB) && fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) {
        errno = ENOLCK;
        return -1;
    }
    return real_flock(fd, op);
}

static int affinity_refused(void)
{
    const char *s = getenv("FAULT_AFFINITY");
    return s && *s == '1';
}

int sched_setaffinity(pid_t pid, size_t n, const cpu_set_t *mask)
{
    REAL(sched_setaffinity, int, pid_t, size_t, const cpu_set_t *);
    if (!affinity_refused()) return real_sched_setaffinity(pid, n, mask);
    errno = EPERM;
    return -1;
}

int pthread_setaffinity_np(pthread_t t, size_t n, const cpu_set_t *mask)
{
    REAL(pthread_setaffinity_np, int, pthread_t, size_t, const cpu_set_t *);
    return affinity_refused() ? EPERM : real_pthread_setaffinity_np(t, n, mask);
}

int fflush(FILE *fp)
{
    REAL(fflush, int, FILE *);
    if (fp && __fwritable(fp) && __fpending(fp) > 0 && hit(fileno(fp), OP_STDIO)) {
        __fpurge(fp);
        errno = shortw ? EIO : err_no;
        return EOF;
    }
    return real_fflush(fp);
}

int fclose(FILE *fp)
{
    REAL(fclose, int, FILE *);
    if (fp && __fwritable(fp) && __fpending(fp) > 0 && hit(fileno(fp), OP_STDIO)) {
        __fpurge(fp);
        real_fclose(fp);
        errno = shortw ? EIO : err_no;
        return EOF;
    }
    return real_fclose(fp);
}
