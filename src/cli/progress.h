/*
 * progress.h - rate-limited progress of a growth run on a stream (stderr).
 *
 * On a terminal one line is redrawn in place with '\r' at most 5 times a
 * second; anywhere else (a log file, a pipe) a full line is appended at most
 * every 5 seconds, so logs of long runs stay readable. A line holds the
 * particle count, percent of the target, the recent rate, the ETA, R_ext in
 * diameters and the tree's memory.
 *
 * progress_tick is meant to be called from the engine's progress callback,
 * which runs about every thousand particles: it reads the clock and returns
 * at once unless a line is due, so it costs nothing measurable.
 */
#ifndef PDLA_CLI_PROGRESS_H
#define PDLA_CLI_PROGRESS_H

#include <stdint.h>
#include <stdio.h>

#include "pdla/pdla.h"

typedef struct progress {
    FILE *out;
    int enabled;
    int tty;             /* redraw in place with '\r' */
    double interval;     /* seconds between lines */
    double t_start;      /* when growth began */
    double t_last;       /* last line (or the start) */
    uint64_t n_start;    /* particles when growth began (a resumed run's count) */
    uint64_t n_last;     /* particles at t_last */
    double rate;         /* smoothed particles per second, 0 before the first line */
    int width;           /* length of the line on screen, to blank leftovers */
} progress;

/* Monotonic seconds. */
double progress_now(void);

/* A byte count for people: "812 B", "3.4 MiB". */
void progress_fmt_bytes(char *buf, size_t n, double b);

/* Start timing a growth that begins at `particles` (0, or where a resumed
 * run stood: rates count only what this process grows); enabled = 0 makes
 * every other call a no-op. */
void progress_init(progress *p, FILE *out, int enabled, int tty, uint64_t particles);

/* Print a line if one is due. */
void progress_tick(progress *p, const pdla_engine *e);

/* Draw the final state and end the terminal line, so what follows starts
 * on a fresh line. */
void progress_finish(progress *p, const pdla_engine *e);

/* An ensemble (`pdla ensemble`): a line with clusters done of total, the
 * rate in particles/s and the ETA, from `particles` grown so far of
 * `particles_total` (both counted from this process's start); rate-limited
 * like progress_tick unless final, which draws the last line and ends it. */
void progress_ensemble(progress *p, uint64_t done, uint64_t total, uint64_t particles,
                       uint64_t particles_total, int final);

#endif /* PDLA_CLI_PROGRESS_H */
