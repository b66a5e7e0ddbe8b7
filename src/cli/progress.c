/*
 * progress.c - rate-limited progress lines for the pdla CLI (see progress.h).
 */
#include "progress.h"

#include <inttypes.h>
#include <math.h>
#include <string.h>
#include <time.h>

/* A terminal redraws cheaply: 5 lines a second. A log gets a line every 5 s. */
#define TTY_INTERVAL 0.2
#define LOG_INTERVAL 5.0
/* Time constant (s) of the rate's exponential smoothing: long enough to calm
 * the jitter of 0.2 s samples, short enough to follow the slow-down as the
 * cluster grows. */
#define RATE_TAU 10.0

double progress_now(void) { return pdla_clock_seconds(); }

void progress_init(progress *p, FILE *out, int enabled, int tty, uint64_t particles)
{
    memset(p, 0, sizeof *p);
    p->out = out;
    p->enabled = enabled;
    p->tty = tty;
    p->interval = tty ? TTY_INTERVAL : LOG_INTERVAL;
    p->t_start = p->t_last = progress_now();
    p->n_start = p->n_last = particles;
}

/* Counts in 3 significant digits with an SI suffix once they stop being
 * short: 999999, 1.23M, 45.6G. */
static void fmt_count(char *buf, size_t n, double v)
{
    static const char sfx[] = " kMGTPE";
    if (v < 1e6) {
        snprintf(buf, n, "%.0f", v);
        return;
    }
    int k = 0;
    while (v >= 999.5 && k < 6) {
        v /= 1000;
        k++;
    }
    snprintf(buf, n, "%.*f%c", v < 9.995 ? 2 : v < 99.95 ? 1 : 0, v, sfx[k]);
}

void progress_fmt_bytes(char *buf, size_t n, double b)
{
    static const char *const unit[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int k = 0;
    while (b >= 1024 && k < 4) {
        b /= 1024;
        k++;
    }
    snprintf(buf, n, k ? "%.1f %s" : "%.0f %s", b, unit[k]);
}

/* h:mm:ss, or days and hours when it is that far off. */
static void fmt_eta(char *buf, size_t n, double s)
{
    if (!(s >= 0) || s > 1e9) {
        snprintf(buf, n, "--");
        return;
    }
    const uint64_t t = (uint64_t)(s + 0.5);
    if (t >= 86400)
        snprintf(buf, n, "%" PRIu64 "d%02uh", t / 86400, (unsigned)(t % 86400 / 3600));
    else
        snprintf(buf, n, "%u:%02u:%02u", (unsigned)(t / 3600), (unsigned)(t % 3600 / 60),
                 (unsigned)(t % 60));
}

static void draw(progress *p, const pdla_engine *e, double now, int final)
{
    pdla_stats s;
    pdla_engine_stats(e, &s);
    const pdla_params *P = pdla_engine_params(e);

    /* Rate over the interval since the last line, smoothed; the final line
     * gives the mean over the whole growth instead. */
    const double dt = now - p->t_last;
    if (final) {
        p->rate = now > p->t_start ? (double)(s.particles - p->n_start) / (now - p->t_start) : 0;
    } else if (dt > 0 && s.particles >= p->n_last) {
        const double r = (double)(s.particles - p->n_last) / dt;
        /* Until RATE_TAU has passed, dt / elapsed makes it the plain mean
         * since the start, so the fast first particles do not linger. */
        const double ema = 1.0 - exp(-dt / RATE_TAU);
        const double mean = dt / (now - p->t_start);
        const double a = mean > ema ? mean : ema;
        p->rate += a * (r - p->rate);
    }
    p->t_last = now;
    p->n_last = s.particles;

    char n[16], tgt[16], rate[16], eta[24], mem[24];
    fmt_count(n, sizeof n, (double)s.particles);
    fmt_count(tgt, sizeof tgt, (double)P->target);
    fmt_count(rate, sizeof rate, p->rate);
    const double left = (double)(P->target - (s.particles < P->target ? s.particles : P->target));
    if (final)
        fmt_eta(eta, sizeof eta, now - p->t_start); /* the final line shows the time taken */
    else
        fmt_eta(eta, sizeof eta, p->rate > 0 ? left / p->rate : -1);
    progress_fmt_bytes(mem, sizeof mem, (double)s.tree_bytes);
    const double pct = P->target ? 100.0 * (double)s.particles / (double)P->target : 0;

    /* Which phase: the serial phase says until when, so a PDLA run's
     * early rate is not mistaken for its parallel one. */
    char phase[48] = "";
    if (P->threads != 1 && P->target > P->serial_until) {
        char until[16];
        fmt_count(until, sizeof until, (double)P->serial_until);
        if (s.threads > 0)
            snprintf(phase, sizeof phase, "  %d threads", s.threads);
        else if (s.particles >= P->serial_until && P->threads > 0)
            snprintf(phase, sizeof phase, "  %d threads", P->threads);
        else if (s.particles >= P->serial_until)
            snprintf(phase, sizeof phase, "  one thread per core");
        else
            snprintf(phase, sizeof phase, "  serial until %s", until);
    }

    char line[200];
    const int len = snprintf(line, sizeof line,
                             "%s/%s (%.1f%%)  %s p/s  %s %s  R_ext %.0f d  tree %s%s", n, tgt, pct,
                             rate, final ? "time" : "ETA", eta, (double)s.r_ext / P->resolution,
                             mem, phase);
    if (p->tty) {
        /* Blank what a longer previous line left behind. */
        const int pad = p->width > len ? p->width - len : 0;
        fprintf(p->out, "\r%s%*s", line, pad, "");
        p->width = len;
    } else {
        fprintf(p->out, "%s\n", line);
    }
    fflush(p->out);
}

void progress_tick(progress *p, const pdla_engine *e)
{
    if (!p->enabled) return;
    const double now = progress_now();
    if (now - p->t_last < p->interval) return;
    draw(p, e, now, 0);
}

void progress_finish(progress *p, const pdla_engine *e)
{
    if (!p->enabled) return;
    /* A log already has enough lines; the summary follows. */
    if (!p->tty) return;
    draw(p, e, progress_now(), 1);
    fputc('\n', p->out);
    fflush(p->out);
}

void progress_ensemble(progress *p, uint64_t done, uint64_t total, uint64_t particles,
                       uint64_t particles_total, int final)
{
    if (!p->enabled) return;
    const double now = progress_now();
    if (!final && now - p->t_last < p->interval) return;
    if (final && !p->tty) return; /* a log already has its lines */
    const double dt = now - p->t_last;
    if (final) {
        p->rate = now > p->t_start ? (double)particles / (now - p->t_start) : 0;
    } else if (dt > 0 && particles >= p->n_last) {
        const double r = (double)(particles - p->n_last) / dt;
        const double ema = 1.0 - exp(-dt / RATE_TAU);
        const double mean = dt / (now - p->t_start);
        p->rate += (mean > ema ? mean : ema) * (r - p->rate);
    }
    p->t_last = now;
    p->n_last = particles;
    char rate[16], eta[24];
    fmt_count(rate, sizeof rate, p->rate);
    const double left = particles < particles_total ? (double)(particles_total - particles) : 0.0;
    fmt_eta(eta, sizeof eta, final ? now - p->t_start : p->rate > 0 ? left / p->rate : -1);
    char line[160];
    const int len = snprintf(line, sizeof line, "clusters %" PRIu64 "/%" PRIu64 " (%.1f%%)  %s p/s  %s %s", done,
                             total, total ? 100.0 * (double)done / (double)total : 0.0, rate,
                             final ? "time" : "ETA", eta);
    if (p->tty) {
        const int pad = p->width > len ? p->width - len : 0;
        fprintf(p->out, "\r%s%*s%s", line, pad, "", final ? "\n" : "");
        p->width = len;
    } else {
        fprintf(p->out, "%s\n", line);
    }
    fflush(p->out);
}
