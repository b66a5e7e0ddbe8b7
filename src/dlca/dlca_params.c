/*
 * dlca_params.c - the DLCA model's parameters as ONE descriptor table (name,
 * C type, unit, default, range, help, scene key = name) from which the CLI
 * options, the --help lines, validation and the /parameters attributes are
 * all generated. Self-contained so that it can join the engine-wide
 * parameter table.
 */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pdla/dlca.h"

#define OFF(f) offsetof(dlca_params, f)
#define NONE NAN

static const dlca_param_desc table[] = {
    {"dim", DLCA_T_INT, "int", "", "2", 2, 5, 0, 0, "D", "lattice dimension d", OFF(dim)},
    {"box", DLCA_T_BOX, "uint32_t[5]", "sites", "256x256", 2, 65536, 0, 0, "L1xL2[x..]",
     "box lengths, one per axis (one number: the same on every axis)", OFF(box)},
    {"fill", DLCA_T_F64, "double", "", "0.01", 0, 1, 1, 1, "PHI",
     "fill fraction: N = round(PHI V) monomers (unless --count)", OFF(fill)},
    {"count", DLCA_T_U64, "uint64_t", "monomers", "0", 0, 4294967295.0, 0, 0, "N",
     "number of monomers (0: from --fill)", OFF(count)},
    {"mobility", DLCA_T_F64, "double", "", "0", -10, 10, 0, 0, "GAMMA",
     "a cluster of s monomers moves at rate s^GAMMA (0: all equal, as in the seed)", OFF(mobility)},
    {"sticking", DLCA_T_F64, "double", "", "1", 0, 1, 1, 0, "P",
     "probability that face-adjacent clusters join after a move", OFF(sticking)},
    {"drift", DLCA_T_F64, "double", "", "0", 0, 1, 0, 1, "G",
     "probability that a move is one step down the last axis (gravity)", OFF(drift)},
    {"until-clusters", DLCA_T_U64, "uint64_t", "clusters", "1", 1, 4294967295.0, 0, 0, "K",
     "stop when K clusters are left", OFF(until_clusters)},
    {"until-time", DLCA_T_F64, "double", "monomer moves", "0", 0, 1e300, 0, 0, "T",
     "stop at time T (0: never)", OFF(until_time)},
    {"max-attempts", DLCA_T_U64, "uint64_t", "attempts", "0", 0, 1.8e19, 0, 0, "M",
     "stop after M attempted moves (0: never)", OFF(max_attempts)},
    {"seed", DLCA_T_U64, "uint64_t", "", "1", 0, 1.8e19, 0, 0, "S", "random seed", OFF(seed)},
    {"search", DLCA_T_SEARCH, "int", "", "lattice", 0, 2, 0, 0, "lattice|boxes|allpairs",
     "collision search: id lattice (fastest), the seed's grid-boxing, or all pairs", OFF(search)},
    {"grid-box", DLCA_T_INT, "int", "sites", "4", 1, 65536, 0, 0, "A",
     "first grid-box side of --search boxes (a power of two; doubles as clusters grow)",
     OFF(grid_box)},
};

const dlca_param_desc *dlca_param_table(size_t *n)
{
    *n = sizeof table / sizeof table[0];
    return table;
}

static int fail(char *err, size_t errlen, const char *fmt, const char *a, const char *b)
{
    if (err && errlen) snprintf(err, errlen, fmt, a, b);
    return PDLA_EINVAL;
}

static const char *search_names[] = {"lattice", "boxes", "allpairs"};

const char *dlca_search_name(int search)
{
    return search >= 0 && search <= 2 ? search_names[search] : "unknown";
}

/* A number with an optional k/M/G suffix (10M = 1e7), whole text used. */
static int parse_num(const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || errno == ERANGE) return -1;
    if (*end == 'k' || *end == 'K') v *= 1e3, end++;
    else if (*end == 'M') v *= 1e6, end++;
    else if (*end == 'G') v *= 1e9, end++;
    if (*end || !isfinite(v)) return -1;
    *out = v;
    return 0;
}

static int in_range(const dlca_param_desc *d, double v)
{
    if (!isnan(d->min) && (d->min_open ? v <= d->min : v < d->min)) return 0;
    if (!isnan(d->max) && (d->max_open ? v >= d->max : v > d->max)) return 0;
    return 1;
}

static void range_text(const dlca_param_desc *d, char *buf, size_t len)
{
    snprintf(buf, len, "%c%g, %g%c", d->min_open ? '(' : '[', d->min, d->max, d->max_open ? ')' : ']');
}

int dlca_param_set(dlca_params *p, const dlca_param_desc *d, const char *text, char *err,
                   size_t errlen)
{
    char *field = (char *)p + d->offset;
    char rng[96];
    range_text(d, rng, sizeof rng);
    if (d->type == DLCA_T_SEARCH) {
        for (int i = 0; i < 3; i++)
            if (strcmp(text, search_names[i]) == 0) {
                *(int *)field = i;
                return 0;
            }
        return fail(err, errlen, "invalid --search '%s' (lattice, boxes or allpairs)%s", text, "");
    }
    if (d->type == DLCA_T_BOX) {
        uint32_t L[DLCA_MAX_DIM] = {0};
        int n = 0;
        const char *s = text;
        while (1) {
            char *end;
            errno = 0;
            const unsigned long long v = strtoull(s, &end, 10);
            if (end == s || errno || v < 2 || v > 65536 || *s == '-' || *s == '+')
                return fail(err, errlen, "invalid --box '%s' (each length an integer in [2, 65536], "
                            "written L1xL2[x...])%s", text, "");
            if (n == DLCA_MAX_DIM)
                return fail(err, errlen, "invalid --box '%s' (at most 5 lengths)%s", text, "");
            L[n++] = (uint32_t)v;
            if (*end == '\0') break;
            if (*end != 'x') return fail(err, errlen, "invalid --box '%s' (lengths are joined by 'x')%s", text, "");
            s = end + 1;
        }
        /* One length: the same on every axis. */
        for (int i = n; i < DLCA_MAX_DIM; i++) L[i] = n == 1 ? L[0] : 0;
        memcpy(field, L, sizeof L);
        return 0;
    }
    double v;
    if (parse_num(text, &v) || !in_range(d, v) ||
        ((d->type == DLCA_T_INT || d->type == DLCA_T_U64) && v != floor(v))) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s%s", d->type == DLCA_T_F64 ? "a number in " : "an integer in ", rng);
        if (err && errlen) snprintf(err, errlen, "invalid --%s '%s' (%s)", d->name, text, msg);
        return PDLA_EINVAL;
    }
    if (d->type == DLCA_T_INT) *(int *)field = (int)v;
    else if (d->type == DLCA_T_U64) {
        /* Exact for integers written out in full (seeds above 2^53). */
        char *end;
        errno = 0;
        const unsigned long long u = strtoull(text, &end, 10);
        *(uint64_t *)field = (*end == '\0' && !errno) ? (uint64_t)u : (uint64_t)v;
    } else *(double *)field = v;
    return 0;
}

void dlca_param_format(const dlca_params *p, const dlca_param_desc *d, char *buf, size_t len)
{
    const char *field = (const char *)p + d->offset;
    switch (d->type) {
    case DLCA_T_INT: snprintf(buf, len, "%d", *(const int *)field); break;
    case DLCA_T_U64: snprintf(buf, len, "%llu", (unsigned long long)*(const uint64_t *)field); break;
    case DLCA_T_F64: snprintf(buf, len, "%.17g", *(const double *)field); break;
    case DLCA_T_SEARCH: snprintf(buf, len, "%s", dlca_search_name(*(const int *)field)); break;
    case DLCA_T_BOX: {
        const uint32_t *L = (const uint32_t *)field;
        size_t o = 0;
        buf[0] = '\0';
        for (int i = 0; i < p->dim && i < DLCA_MAX_DIM && o < len; i++)
            o += (size_t)snprintf(buf + o, len - o, i ? "x%u" : "%u", L[i]);
        break;
    }
    }
}

void dlca_params_default(dlca_params *p)
{
    memset(p, 0, sizeof *p);
    size_t n;
    const dlca_param_desc *t = dlca_param_table(&n);
    for (size_t i = 0; i < n; i++) (void)dlca_param_set(p, &t[i], t[i].def, NULL, 0);
}

uint64_t dlca_params_monomers(const dlca_params *p)
{
    if (p->count) return p->count;
    double V = 1;
    for (int i = 0; i < p->dim && i < DLCA_MAX_DIM; i++) V *= p->box[i];
    return (uint64_t)floor(p->fill * V + 0.5);
}

int dlca_params_validate(const dlca_params *p, char *err, size_t errlen)
{
    size_t n;
    const dlca_param_desc *t = dlca_param_table(&n);
    char buf[64];
    for (size_t i = 0; i < n; i++) {
        const char *f = (const char *)p + t[i].offset;
        double v;
        if (t[i].type == DLCA_T_INT) v = *(const int *)f;
        else if (t[i].type == DLCA_T_U64) v = (double)*(const uint64_t *)f;
        else if (t[i].type == DLCA_T_F64) v = *(const double *)f;
        else if (t[i].type == DLCA_T_SEARCH) v = *(const int *)f;
        else continue;
        if (!in_range(&t[i], v) || isnan(v)) {
            char rng[96];
            range_text(&t[i], rng, sizeof rng);
            dlca_param_format(p, &t[i], buf, sizeof buf);
            if (err && errlen) snprintf(err, errlen, "--%s %s is outside %s", t[i].name, buf, rng);
            return PDLA_EINVAL;
        }
    }
    if (p->grid_box & (p->grid_box - 1)) {
        if (err && errlen) snprintf(err, errlen, "--grid-box %d is not a power of two", p->grid_box);
        return PDLA_EINVAL;
    }
    double V = 1;
    for (int i = 0; i < p->dim; i++) {
        if (p->box[i] < 2 || p->box[i] > 65536) {
            if (err && errlen)
                snprintf(err, errlen, "--box gives %d lengths in [2, 65536] for --dim %d", i, p->dim);
            return PDLA_EINVAL;
        }
        V *= p->box[i];
    }
    for (int i = p->dim; i < DLCA_MAX_DIM; i++)
        if (p->box[i] && p->box[i] != p->box[0]) {
            if (err && errlen) snprintf(err, errlen, "--box has more lengths than --dim %d", p->dim);
            return PDLA_EINVAL;
        }
    if (V >= 4294967295.0) {
        if (err && errlen) snprintf(err, errlen, "--box has %.3g sites (at most 2^32 - 1)", V);
        return PDLA_EINVAL;
    }
    /* The id lattice: 4 bytes a site; refuse what cannot fit in memory. */
    const long pages = sysconf(_SC_PHYS_PAGES), psz = sysconf(_SC_PAGESIZE);
    if (pages > 0 && psz > 0 && 4.0 * V > 0.5 * (double)pages * (double)psz) {
        if (err && errlen)
            snprintf(err, errlen, "--box needs %.3g GiB for its lattice, more than half of this machine's memory",
                     4.0 * V / 1073741824.0);
        return PDLA_EINVAL;
    }
    const uint64_t N = dlca_params_monomers(p);
    if (N < 1 || (double)N >= V) {
        if (err && errlen)
            snprintf(err, errlen, "the box of %.0f sites cannot hold %llu monomers (need 1 <= N < V)", V,
                     (unsigned long long)N);
        return PDLA_EINVAL;
    }
    if (p->until_clusters > N && p->until_clusters != 1) {
        if (err && errlen)
            snprintf(err, errlen, "--until-clusters %llu is more than the %llu monomers",
                     (unsigned long long)p->until_clusters, (unsigned long long)N);
        return PDLA_EINVAL;
    }
    return 0;
}
