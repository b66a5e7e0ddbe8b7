/*
 * ev_params.c - the event model's parameter table and everything generated
 * from it: defaults, text -> value with bounds, value -> text, --help. Kept
 * self-contained so it can be folded into the engine-wide table.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ev_internal.h"

#define OFF(f) offsetof(ev_params, f)

const ev_param_desc ev_param_table[] = {
    {"dim", EV_P_INT, OFF(dim), "", "2", 2, 3, 0, NULL, "2: hard disks, 3: hard spheres"},
    {"particles", EV_P_U64, OFF(particles), "", "1000", 1, 4e9, 0, NULL,
     "number of particles (one species; see --species)"},
    {"radius", EV_P_F64, OFF(radius), "length", "0.5", 0, 1e6, 1, NULL,
     "particle radius (one species)"},
    {"density", EV_P_F64, OFF(density), "mass/length^dim", "1", 0, 1e12, 1, NULL,
     "mass density: mass = density * (pi r^2 | 4/3 pi r^3)"},
    {"species", EV_P_STR, OFF(species), "", "", 0, 0, 0, NULL,
     "COUNT:RADIUS:DENSITY[,...] up to 8 kinds (replaces --particles/--radius/--density)"},
    {"packing", EV_P_F64, OFF(packing), "", "0.05", 0, 0.7, 1, NULL,
     "volume fraction of the particles in the box (sets the box side)"},
    {"box-walls", EV_P_ENUM, OFF(walls), "", "elastic", 0, 1, 0, "elastic|periodic",
     "box boundaries"},
    {"seed", EV_P_U64, OFF(seed), "", "1", 0, 1.8446744073709552e19, 0, NULL, "random seed"},
    {"kT", EV_P_F64, OFF(kT), "energy", "1", 0, 1e12, 1, NULL, "k_B T of the start velocities"},
    {"velocities", EV_P_ENUM, OFF(velocities), "", "maxwell", 0, 1, 0, "maxwell|fixed",
     "maxwell: Maxwell-Boltzmann at kT; fixed: speed sqrt(2 kT/m), random direction (seed 001)"},
    {"start", EV_P_ENUM, OFF(start), "", "random", 0, 1, 0, "random|lattice",
     "random: random sequential placement; lattice: shuffled grid sites"},
    {"seed-radius", EV_P_F64, OFF(seed_radius), "length", "0.5", 0, 1e6, 0, NULL,
     "radius of the immobile central seed; 0: no seed (a plain hard-sphere gas)"},
    {"stick-p", EV_P_F64, OFF(stick_p), "", "1", 0, 1, 0, NULL,
     "probability that a contact with the seed or a stuck particle sticks"},
    {"t-max", EV_P_F64, OFF(t_max), "time", "0", 0, 1e300, 0, NULL, "stop at this time (0: none)"},
    {"max-stuck", EV_P_U64, OFF(max_stuck), "", "0", 0, 4e9, 0, NULL,
     "stop at this many stuck particles (0: none)"},
    {"max-events", EV_P_U64, OFF(max_events), "", "0", 0, 1.8446744073709552e19, 0, NULL,
     "stop after this many events (0: none)"},
    {"series-dt", EV_P_F64, OFF(series_dt), "time", "1", 0, 1e300, 1, NULL,
     "time between rows of the series (time, stuck, energy, collisions, pressure)"},
};
const size_t ev_param_count = sizeof ev_param_table / sizeof ev_param_table[0];

static int fail(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -1;
}

static const ev_param_desc *find(const char *name)
{
    for (size_t k = 0; k < ev_param_count; k++) {
        const char *a = ev_param_table[k].name, *b = name;
        /* scene keys write '_' for '-' */
        while (*a && (*a == *b || (*a == '-' && *b == '_'))) a++, b++;
        if (!*a && !*b) return &ev_param_table[k];
    }
    return NULL;
}

/* The k-th choice of "a|b|c" equal to v, or -1. */
static int choice_index(const char *choices, const char *v)
{
    int k = 0;
    for (const char *c = choices;; k++) {
        const char *bar = strchr(c, '|');
        const size_t len = bar ? (size_t)(bar - c) : strlen(c);
        if (strlen(v) == len && strncmp(c, v, len) == 0) return k;
        if (!bar) return -1;
        c = bar + 1;
    }
}

static void choice_name(const char *choices, int k, char *buf, size_t len)
{
    const char *c = choices;
    for (int q = 0; q < k && c; q++) {
        c = strchr(c, '|');
        if (c) c++;
    }
    if (!c) c = "?";
    const char *bar = strchr(c, '|');
    const size_t n = bar ? (size_t)(bar - c) : strlen(c);
    snprintf(buf, len, "%.*s", (int)n, c);
}

static int set_desc(ev_params *p, const ev_param_desc *d, const char *v, char *err, size_t errlen)
{
    char *base = (char *)p + d->offset;
    if (d->type == EV_P_STR) {
        if (strlen(v) >= sizeof p->species) return fail(err, errlen, "--%s: value too long", d->name);
        snprintf(base, sizeof p->species, "%s", v);
        return 0;
    }
    if (d->type == EV_P_ENUM) {
        const int k = choice_index(d->choices, v);
        if (k < 0) return fail(err, errlen, "--%s: '%s' is not one of %s", d->name, v, d->choices);
        *(int *)base = k;
        return 0;
    }
    errno = 0;
    char *end;
    const double x = strtod(v, &end);
    if (end == v || *end || errno == ERANGE || !isfinite(x))
        return fail(err, errlen, "--%s: '%s' is not a number", d->name, v);
    if (x < d->min || (d->min_open && x == d->min) || x > d->max)
        return fail(err, errlen, "--%s: %s is outside %s%g, %g]", d->name, v,
                    d->min_open ? "(" : "[", d->min, d->max);
    if (d->type == EV_P_F64) {
        *(double *)base = x;
        return 0;
    }
    if (x != floor(x)) return fail(err, errlen, "--%s: '%s' is not a whole number", d->name, v);
    if (d->type == EV_P_INT) *(int *)base = (int)x;
    else {
        /* exact for integers written out in full, 1e5-style otherwise */
        const int plain = strspn(v, "0123456789") == strlen(v);
        *(uint64_t *)base = plain ? strtoull(v, NULL, 10) : (uint64_t)x;
    }
    return 0;
}

int ev_param_set(ev_params *p, const char *name, const char *value, char *err, size_t errlen)
{
    const ev_param_desc *d = find(name);
    if (!d) return fail(err, errlen, "unknown parameter '%s' for model event", name);
    return set_desc(p, d, value, err, errlen);
}

void ev_params_default(ev_params *p)
{
    memset(p, 0, sizeof *p);
    for (size_t k = 0; k < ev_param_count; k++) {
        const int rc = set_desc(p, &ev_param_table[k], ev_param_table[k].defval, NULL, 0);
        (void)rc; /* the table's own defaults are valid (tested) */
    }
}

void ev_param_format(const ev_params *p, size_t k, char *buf, size_t len)
{
    const ev_param_desc *d = &ev_param_table[k];
    const char *base = (const char *)p + d->offset;
    switch (d->type) {
    case EV_P_INT: snprintf(buf, len, "%d", *(const int *)base); break;
    case EV_P_U64: snprintf(buf, len, "%" PRIu64, *(const uint64_t *)base); break;
    case EV_P_F64: snprintf(buf, len, "%.17g", *(const double *)base); break;
    case EV_P_STR: snprintf(buf, len, "%s", base); break;
    case EV_P_ENUM: choice_name(d->choices, *(const int *)base, buf, len); break;
    }
}

char *ev_help_text(void)
{
    size_t cap = 8192, n = 0;
    char *t = malloc(cap);
    if (!t) return NULL;
    n += (size_t)snprintf(t + n, cap - n,
                          "usage: pdla --model event [OPTIONS] [--out DIR] [--force]\n"
                          "Event-driven hard disks (2D) or spheres (3D) in a box around an "
                          "immobile seed;\nparticles touching the seed or a stuck particle stick "
                          "with probability --stick-p.\nWrites DIR/cluster.h5 (default DIR: "
                          "runs/event-<time>). Options (scene key: name with _):\n");
    for (size_t k = 0; k < ev_param_count; k++) {
        const ev_param_desc *d = &ev_param_table[k];
        char opt[64];
        snprintf(opt, sizeof opt, "--%s %s", d->name,
                 d->type == EV_P_ENUM ? d->choices : d->type == EV_P_STR ? "LIST" : "X");
        const int w = snprintf(t + n, cap - n, "  %-28s %s%s%s%s (default %s)\n", opt, d->help,
                               *d->unit ? " [" : "", d->unit, *d->unit ? "]" : "",
                               *d->defval ? d->defval : "none");
        if (w < 0 || (size_t)w >= cap - n) break;
        n += (size_t)w;
    }
    snprintf(t + n, cap - n,
             "  --out DIR                    run directory\n"
             "  --force                      write into an existing run directory\n"
             "  --quiet                      no summary, no progress lines (unless --progress)\n"
             "  --progress, --no-progress    progress lines on stderr (default: when a terminal)\n"
             "  --checkpoint                 DIR/checkpoint.h5 at the end and on SIGINT/SIGTERM\n"
             "                               (then exit 0)\n"
             "  --checkpoint-every T         also every T of wall time (seconds, or 30s, 5m, 1h)\n"
             "  --resume DIR                 continue DIR's checkpoint bit for bit; only --t-max,\n"
             "                               --max-stuck, --max-events may be given with it\n"
             "  --help                       this text\n");
    return t;
}

double ev_particle_volume(int dim, double r)
{
    return dim == 2 ? M_PI * r * r : 4.0 / 3.0 * M_PI * r * r * r;
}

int ev_parse_species(const ev_params *p, ev_species *sp, int *nsp, char *err, size_t errlen)
{
    if (!p->species[0]) {
        sp[0] = (ev_species){p->particles, p->radius, p->density};
        *nsp = 1;
        return 0;
    }
    int n = 0;
    const char *c = p->species;
    while (*c) {
        if (n == EV_MAX_SPECIES) return fail(err, errlen, "--species: more than %d kinds", EV_MAX_SPECIES);
        char *end;
        errno = 0;
        const double cnt = strtod(c, &end);
        if (end == c || *end != ':' || cnt < 1 || cnt != floor(cnt) || cnt > 4e9)
            return fail(err, errlen, "--species: kind %d: bad COUNT (want COUNT:RADIUS:DENSITY)", n + 1);
        c = end + 1;
        const double r = strtod(c, &end);
        if (end == c || *end != ':' || !(r > 0) || !isfinite(r))
            return fail(err, errlen, "--species: kind %d: RADIUS must be > 0", n + 1);
        c = end + 1;
        const double rho = strtod(c, &end);
        if (end == c || (*end != ',' && *end) || !(rho > 0) || !isfinite(rho))
            return fail(err, errlen, "--species: kind %d: DENSITY must be > 0", n + 1);
        sp[n++] = (ev_species){(uint64_t)cnt, r, rho};
        c = *end ? end + 1 : end;
    }
    if (!n) return fail(err, errlen, "--species: empty list");
    *nsp = n;
    return 0;
}

int ev_params_check(const ev_params *p, char *err, size_t errlen)
{
    for (size_t k = 0; k < ev_param_count; k++) {
        char buf[300];
        ev_param_format(p, k, buf, sizeof buf);
        ev_params q = *p;
        if (set_desc(&q, &ev_param_table[k], buf, err, errlen)) return -1;
    }
    ev_species sp[EV_MAX_SPECIES];
    int nsp;
    if (ev_parse_species(p, sp, &nsp, err, errlen)) return -1;
    uint64_t total = 0;
    double rmax = p->seed_radius;
    for (int k = 0; k < nsp; k++) {
        total += sp[k].count;
        if (sp[k].radius > rmax) rmax = sp[k].radius;
    }
    if (total >= UINT32_MAX - 1) return fail(err, errlen, "too many particles (%" PRIu64 ")", total);
    double rpmax = 0;
    for (int k = 0; k < nsp; k++)
        if (sp[k].radius > rpmax) rpmax = sp[k].radius;
    if (p->seed_radius > 10 * rpmax)
        return fail(err, errlen, "--seed-radius %g is above 10 particle radii (the cell size)",
                    p->seed_radius);
    const int endless = p->t_max == 0 && p->max_events == 0;
    if (endless && (p->seed_radius == 0 || p->stick_p == 0))
        return fail(err, errlen, "nothing sticks (--seed-radius 0 or --stick-p 0): give --t-max or "
                                 "--max-events");
    if (p->max_stuck && p->seed_radius == 0)
        return fail(err, errlen, "--max-stuck needs a seed (--seed-radius > 0)");
    return 0;
}
