/*
 * test_must.c - PDLA_MUST (src/core/must.h): a pthread call that returns 0
 * goes on; one that fails aborts the process with one line on stderr naming
 * the call, its file:line and the error's text. The failure is provoked
 * honestly: unlocking an error-checking mutex this thread does not hold is
 * EPERM. The abort is watched from a forked child.
 */
#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "must.h"

/* Runs the failing call in a child; its status and stderr. */
static int child_fails(char *out, size_t len)
{
    int fd[2];
    if (pipe(fd)) return -1;
    const pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        dup2(fd[1], 2);
        close(fd[0]);
        pthread_mutexattr_t a;
        pthread_mutex_t m;
        if (pthread_mutexattr_init(&a) || pthread_mutexattr_settype(&a, PTHREAD_MUTEX_ERRORCHECK) ||
            pthread_mutex_init(&m, &a))
            _exit(3);
        PDLA_MUST(pthread_mutex_unlock(&m)); /* not held: EPERM */
        _exit(0);
    }
    close(fd[1]);
    size_t n = 0;
    ssize_t r;
    while (n + 1 < len && (r = read(fd[0], out + n, len - 1 - n)) > 0) n += (size_t)r;
    out[n] = '\0';
    close(fd[0]);
    int st = 0;
    if (waitpid(pid, &st, 0) != pid) return -1;
    return st;
}

int main(void)
{
    pthread_mutex_t m = PTHREAD_MUTEX_INITIALIZER;
    PDLA_MUST(pthread_mutex_lock(&m));
    PDLA_MUST(pthread_mutex_unlock(&m));
    PDLA_MUST(pthread_mutex_destroy(&m));
    CHECK(1, "calls that return 0 go on");

    char out[1024];
    const int st = child_fails(out, sizeof out);
    CHECK(st != -1 && WIFSIGNALED(st) && WTERMSIG(st) == SIGABRT, "status %d: want SIGABRT", st);
    CHECK(strstr(out, "test_must.c:") != NULL, "no file:line in: %s", out);
    CHECK(strstr(out, "pthread_mutex_unlock(&m): ") != NULL, "no call in: %s", out);
    CHECK(strstr(out, strerror(EPERM)) != NULL, "no '%s' in: %s", strerror(EPERM), out);
    CHECK(strchr(out, '\n') == out + strlen(out) - 1, "not one line: %s", out);
    return check_finish();
}
