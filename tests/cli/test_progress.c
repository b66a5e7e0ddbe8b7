/*
 * test_progress.c - the CLI's progress lines (src/cli/progress.c) on real
 * engines: the final line's rate counts only the particles this process
 * grew (a resumed run starts from its checkpoint's count, not from zero),
 * and the phase label says "serial until N" before the workers start and
 * "N threads" once they run. Fixed seeds; the rate is checked against the
 * interval the test itself timed around the growth.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pdla/pdla.h"
#include "progress.h"

static pdla_engine *make(int threads, uint64_t serial_until, uint64_t target)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = 2;
    p.seed = 5;
    p.threads = threads;
    p.serial_until = serial_until;
    p.target = target;
    pdla_engine *e = NULL;
    char err[256];
    CHECK(pdla_engine_create(&e, &p, err, sizeof err) == PDLA_OK, "create: %s", err);
    return e;
}

static int grow(pdla_engine *e, uint64_t n)
{
    char err[256];
    const int rc = pdla_engine_grow(e, n, NULL, 0, NULL, err, sizeof err);
    CHECK(rc == PDLA_OK, "grow to %llu: %s", (unsigned long long)n, err);
    return rc;
}

/* The last line written to f (lines end in '\r' or '\n'). */
static void last_line(FILE *f, char *line, size_t cap)
{
    fflush(f);
    const long size = ftell(f);
    char *all = calloc((size_t)size + 1, 1);
    rewind(f);
    const size_t got = all ? fread(all, 1, (size_t)size, f) : 0;
    line[0] = '\0';
    size_t end = got;
    while (end > 0 && (all[end - 1] == '\n' || all[end - 1] == '\r' || all[end - 1] == ' ')) end--;
    size_t start = end;
    while (start > 0 && all[start - 1] != '\n' && all[start - 1] != '\r') start--;
    snprintf(line, cap, "%.*s", (int)(end - start), all + start);
    fseek(f, 0, SEEK_END);
    free(all);
}

/* A run that starts at 20000 particles (as a resumed one does) and grows to
 * 40000: the final rate is 20000 / time, not 40000 / time. */
static void test_resumed_rate(void)
{
    pdla_engine *e = make(1, 0, 40000);
    if (!e || grow(e, 20000)) return;
    FILE *f = tmpfile();
    progress p;
    progress_init(&p, f, 1, 1, 20000);
    if (grow(e, 40000)) return;
    const double t1 = progress_now();
    progress_finish(&p, e);
    const double t2 = progress_now();
    char line[256];
    last_line(f, line, sizeof line);
    double rate = -1;
    CHECK(sscanf(line, "%*s %*s %lf p/s", &rate) == 1, "final line '%s'", line);
    const double lo = 20000 / (t2 - p.t_start), hi = 20000 / (t1 - p.t_start);
    CHECK(rate >= 0.995 * lo && rate <= 1.005 * hi, "rate %.0f p/s outside [%.0f, %.0f] ('%s')",
          rate, lo, hi, line);
    fclose(f);
    pdla_engine_destroy(e);
}

/* The phase label before and after the workers start. */
static void test_phase_label(void)
{
    pdla_engine *e = make(2, 1000, 3000);
    if (!e || grow(e, 500)) return;
    FILE *f = tmpfile();
    progress p;
    progress_init(&p, f, 1, 0, 500);
    p.interval = 0;
    progress_tick(&p, e);
    char line[256];
    last_line(f, line, sizeof line);
    CHECK(strstr(line, "serial until 1000") != NULL, "serial phase label: '%s'", line);
    if (grow(e, 3000)) return;
    progress_tick(&p, e);
    last_line(f, line, sizeof line);
    CHECK(strstr(line, "  2 threads") != NULL, "parallel phase label: '%s'", line);
    CHECK(strncmp(line, "3000/3000 (100.0%)", 18) == 0, "count and share: '%s'", line);
    fclose(f);
    pdla_engine_destroy(e);
}

int main(void)
{
    test_resumed_rate();
    test_phase_label();
    return check_finish();
}
