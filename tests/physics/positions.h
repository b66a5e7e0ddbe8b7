/*
 * positions.h - the particle positions of a run, gathered through the
 * engine's visitor (pdla_engine_visit with `grab`), for the tests
 * that compare two runs particle by particle (test_reference, test_lockstep).
 */
#ifndef PDLA_TESTS_POSITIONS_H
#define PDLA_TESTS_POSITIONS_H
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct positions {
    int32_t *x; /* n * dim coordinates, units */
    size_t n, cap;
    int dim;
} positions;

/* Appends n particles; non-zero (the callback's "stop") when out of memory. */
static int grab(const int32_t *xyz, size_t n, void *user)
{
    positions *p = user;
    if (p->n + n > p->cap) {
        const size_t cap = 2 * (p->n + n);
        int32_t *x = realloc(p->x, cap * (size_t)p->dim * sizeof *x);
        if (!x) return -1;
        p->x = x;
        p->cap = cap;
    }
    memcpy(p->x + p->n * (size_t)p->dim, xyz, n * (size_t)p->dim * sizeof *xyz);
    p->n += n;
    return 0;
}
#endif
