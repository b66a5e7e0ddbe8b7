/*
 * must.h - PDLA_MUST(call): for the pthread calls that cannot fail in a
 * correct program. Internal to libpdla.
 *
 * The project rule is that every pthread return is checked and that library
 * code returns errors with a message. A call that can fail at run time
 * (pthread_create, pthread_mutex_init, trylock) returns its error to the
 * caller. The calls below fail only when the program is already wrong: per
 * POSIX, locking or unlocking a default (or adaptive) mutex that was
 * initialised and that this thread holds, waiting on or signalling a valid
 * condition variable, destroying an unlocked mutex, joining a thread that
 * was started and not yet joined fail only with EINVAL, EPERM, EBUSY,
 * EDEADLK or ESRCH: a corrupted object or a locking bug. No caller could do
 * anything with such an error but stop (a critical section that could not
 * be entered has no safe way on), and the error paths it would add to every
 * critical section could never be tested. So PDLA_MUST checks the return
 * like an assertion that stays in release builds: on a non-zero code it
 * prints "pdla: FILE:LINE: CALL: strerror(code)" on stderr and aborts.
 * scripts/check-returns allows only the calls of PDLA_MUST_CALLS inside it.
 */
#ifndef PDLA_MUST_H
#define PDLA_MUST_H

/* Prints the failed call and aborts; never returns. */
__attribute__((noreturn, cold)) void pdla_must_fail(int code, const char *call, const char *file,
                                                    int line);

static inline void pdla_must(int code, const char *call, const char *file, int line)
{
    if (__builtin_expect(code != 0, 0)) pdla_must_fail(code, call, file, line);
}

#define PDLA_MUST(call) pdla_must((call), #call, __FILE__, __LINE__)

#endif
