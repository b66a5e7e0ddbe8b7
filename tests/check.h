/*
 * check.h - a minimal assertion harness for pdla's C tests.
 * CHECK() records a failure with file:line and goes on; a test's main ends
 * with `return check_finish();`, which prints a summary and gives the exit
 * status meson reads (0 pass, 1 fail).
 */
#ifndef PDLA_TESTS_CHECK_H
#define PDLA_TESTS_CHECK_H
#include <stdio.h>

static int check_failures_;
static int check_count_;

#define CHECK(cond, ...)                                                   \
    do {                                                                   \
        check_count_++;                                                    \
        if (!(cond)) {                                                     \
            check_failures_++;                                             \
            fprintf(stderr, "%s:%d: check failed: %s: ", __FILE__, __LINE__, \
                    #cond);                                                \
            fprintf(stderr, __VA_ARGS__);                                  \
            fputc('\n', stderr);                                           \
        }                                                                  \
    } while (0)

static inline int check_finish(void)
{
    fprintf(stderr, "%d checks, %d failed\n", check_count_, check_failures_);
    return check_failures_ ? 1 : 0;
}
#endif
