/*
 * util.c - the two helpers every layer shares: the one-line error message
 * (library, models and CLI all report errors this way) and the monotonic
 * clock that every timing in pdla reads; and PDLA_MUST's abort (must.h).
 */
#include "pdla/pdla.h"

#include "must.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

int pdla_verrorf(int code, char *err, size_t errlen, const char *fmt, va_list ap)
{
    if (err && errlen) {
        vsnprintf(err, errlen, fmt, ap);
        for (char *c = err; *c; c++) /* a path may hold a newline: keep one line */
            if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
    }
    return code;
}

int pdla_errorf(int code, char *err, size_t errlen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    pdla_verrorf(code, err, errlen, fmt, ap);
    va_end(ap);
    return code;
}

double pdla_clock_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void pdla_must_fail(int code, const char *call, const char *file, int line)
{
    /* A broken invariant (must.h): no caller to return to. */
    fprintf(stderr, "pdla: %s:%d: %s: %s (a pthread call that cannot fail did: aborting)\n", file,
            line, call, strerror(code));
    fflush(stderr);
    abort();
}
