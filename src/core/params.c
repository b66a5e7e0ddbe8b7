/*
 * params.c - the DLA engine's parameter table (see include/pdla/params.h)
 * and the table-driven functions every parameter user shares: defaults,
 * validation, typed access, formatting. A row here is the only place a
 * parameter's default, range, help text, option name and resume rule are
 * written down.
 */
#include "pdla/params.h"

#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Enums are stored and read as int (CHOICE rows). */
_Static_assert(sizeof(pdla_return_mode) == sizeof(int), "enum size");
_Static_assert(sizeof(pdla_recheck_mode) == sizeof(int), "enum size");
_Static_assert(sizeof(pdla_bind_mode) == sizeof(int), "enum size");

/* ---- rules that a range cannot say ------------------------------------- */

static int check_target(const void *s, char *err, size_t errlen)
{
    const pdla_params *p = s;
    if (p->target < 1) return pdla_errorf(PDLA_EINVAL, err, errlen, "target must be at least 1 particle");
    if (p->target > UINT64_C(1) << 40)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "target %" PRIu64 " exceeds the limit 2^40", p->target);
    return 0;
}

static int check_resolution(const void *s, char *err, size_t errlen)
{
    const int D = ((const pdla_params *)s)->resolution;
    if (D < PDLA_MIN_RESOLUTION || D > PDLA_MAX_RESOLUTION || (D & (D - 1)))
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                          "resolution must be a power of two in [%d, %d] units per diameter, got %d",
                          PDLA_MIN_RESOLUTION, PDLA_MAX_RESOLUTION, D);
    return 0;
}

/* The sticking shell is at most half a diameter (resolution checked before). */
static int check_eps(const void *s, char *err, size_t errlen)
{
    const pdla_params *p = s;
    if (p->eps < 2 || p->eps > p->resolution / 2)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "eps must be in [2, resolution/2 = %d] units, got %d",
                          p->resolution / 2, p->eps);
    return 0;
}

/* Reference mode is one thread: P walkers in turn, not next to workers. */
static int check_reference_walkers(const void *s, char *err, size_t errlen)
{
    const pdla_params *p = s;
    if (p->reference_walkers > 0 && p->threads != 1)
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "reference walkers (one thread) and %d worker threads exclude each other",
                           p->threads);
    return 0;
}

/* ---- the table ---------------------------------------------------------- */

static const char *const return_words[] = {"exact", "kill", NULL};
static const char *const recheck_words[] = {"continue", "discard", NULL};
static const char *const bind_words[] = {"none", "core", NULL};

#define AT(field) offsetof(pdla_params, field)
#define DLA PDLA_MODEL_DLA

/* Order: the --help order within each group; validation also runs in this
 * order, so a row whose rule reads another field comes after it (eps after
 * resolution). */
static const pdla_param_desc dla_params[] = {
    {.name = "dim", .option = "dim", .label = "dim", .unit = "", .metavar = "2|3",
     .help = "dimension", .group = "Cluster:", .example = "3",
     .type = PDLA_PT_INT, .offset = AT(dim), .bit = PDLA_PARAM_DIM, .models = DLA,
     .show_default = 1, .def_u = 2, .lo_u = 2, .hi_u = 3},
    {.name = "target", .option = "target", .label = "target", .unit = "particles", .metavar = "N",
     .help = "particles in the final cluster, 1 to 2^40", .group = "Cluster:", .example = "500",
     .type = PDLA_PT_U64, .offset = AT(target), .bit = PDLA_PARAM_TARGET, .models = DLA,
     .resumable = 1, .show_default = 1, .def_u = 1000000, .lo_u = 1, .hi_u = UINT64_C(1) << 40,
     .check = check_target},
    {.name = "seed", .option = "seed", .label = "seed", .unit = "", .metavar = "S",
     .help = "random seed, 0 to 2^64-1", .group = "Cluster:", .example = "12345",
     .type = PDLA_PT_U64, .offset = AT(seed), .bit = PDLA_PARAM_SEED, .models = DLA,
     .show_default = 1, .def_u = 1, .lo_u = 0, .hi_u = UINT64_MAX},
    {.name = "resolution", .option = "resolution", .label = "resolution",
     .unit = "units per diameter", .metavar = "D",
     .help = "units per particle diameter, a power of two from 4 to 128", .group = "Cluster:",
     .example = "16", .type = PDLA_PT_INT, .offset = AT(resolution),
     .bit = PDLA_PARAM_RESOLUTION, .models = DLA, .show_default = 1, .def_u = 32,
     .lo_u = PDLA_MIN_RESOLUTION, .hi_u = PDLA_MAX_RESOLUTION, .check = check_resolution},
    {.name = "eps", .option = "eps", .label = "eps", .unit = "units", .metavar = "E",
     .help = "sticking shell in units, 2 to D/2: a walker sticks closer than D + E "
             "to a particle centre",
     .group = "Cluster:", .example = "3", .type = PDLA_PT_INT, .offset = AT(eps),
     .bit = PDLA_PARAM_EPS, .models = DLA, .show_default = 1, .def_u = 2, .lo_u = 2,
     .hi_u = PDLA_MAX_RESOLUTION / 2, .check = check_eps},
    {.name = "snap_contact", .option = "no-snap-contact", .label = "snap_contact", .unit = "",
     .help = "stick where the walker stops instead of moving it onto contact "
             "(stretches the cluster by about E/(2D))",
     .group = "Cluster:", .example = "yes", .type = PDLA_PT_FLAG, .offset = AT(snap_contact),
     .bit = PDLA_PARAM_SNAP_CONTACT, .models = DLA, .flag_value = 0, .def_u = 1, .lo_u = 0,
     .hi_u = 1},
    {.name = "birth_margin", .option = "birth-margin", .label = "birth margin",
     .unit = "diameters", .metavar = "M",
     .help = "walkers start on the circle (sphere) of radius R_ext + M diameters, M >= 1",
     .group = "Walkers:", .example = "3.5", .type = PDLA_PT_REAL, .offset = AT(birth_margin),
     .bit = PDLA_PARAM_BIRTH_MARGIN, .models = DLA, .show_default = 1, .def_r = 2.0,
     .lo_r = 1.0, .hi_r = 1e6},
    {.name = "return_mode", .option = "return", .label = "return mode", .unit = "",
     .metavar = "exact|kill",
     .help = "a walker that leaves the birth circle: exact return by the harmonic "
             "measure, or the kill scheme",
     .group = "Walkers:", .example = "kill", .type = PDLA_PT_CHOICE, .offset = AT(return_mode),
     .bit = PDLA_PARAM_RETURN_MODE, .models = DLA, .show_default = 1,
     .def_u = PDLA_RETURN_EXACT, .lo_u = 0, .hi_u = 1, .choices = return_words},
    {.name = "kill_ratio", .option = "kill-ratio", .label = "kill ratio", .unit = "",
     .metavar = "R", .help = "with --return kill: kill radius / birth radius, above 1",
     .group = "Walkers:", .example = "50", .type = PDLA_PT_REAL, .offset = AT(kill_ratio),
     .bit = PDLA_PARAM_KILL_RATIO, .models = DLA, .show_default = 1, .def_r = 100.0,
     .lo_r = 1.0, .hi_r = 1e6, .lo_open = 1},
    {.name = "max_jumps", .option = "max-jumps", .label = "max jumps", .unit = "jumps",
     .metavar = "N", .help = "restart a walk on the birth circle after N jumps",
     .group = "Walkers:", .example = "1e6", .type = PDLA_PT_U64, .offset = AT(max_jumps),
     .bit = PDLA_PARAM_MAX_JUMPS, .models = DLA, .show_default = 1, .def_u = 100000000,
     .lo_u = 1, .hi_u = UINT64_MAX},
    {.name = "exact_search", .option = "exact-search", .label = "exact_search", .unit = "",
     .help = "every jump by the exact nearest distance from the tree: no distance map, no "
             "far-node bound, no 2D leaf-block cut (the reference setting; about 2x slower)",
     .group = "Walkers:", .example = "yes", .type = PDLA_PT_FLAG, .offset = AT(exact_search),
     .bit = PDLA_PARAM_EXACT_SEARCH, .models = DLA, .flag_value = 1, .def_u = 0, .lo_u = 0,
     .hi_u = 1},
    {.name = "far_factor", .option = "far-factor", .label = "far factor", .unit = "",
     .metavar = "F",
     .help = "tree search: a node farther than F x its side is not opened; 0.5 to 64 (matters "
             "in 3D; 2D walkers use the distance map and the leaf block instead)",
     .group = "Walkers:", .example = "4", .type = PDLA_PT_REAL, .offset = AT(far_factor),
     .bit = PDLA_PARAM_FAR_FACTOR, .models = DLA, .show_default = 1, .def_r = 2.0,
     .lo_r = 0.5, .hi_r = 64},
    {.name = "threads", .option = "threads", .label = "threads", .unit = "", .metavar = "N",
     .help = "worker threads after the serial phase: 1 = serial DLA throughout, "
             "0 = one per physical core",
     .group = "Threads (PDLA):", .example = "2", .type = PDLA_PT_INT, .offset = AT(threads),
     .bit = PDLA_PARAM_THREADS, .models = DLA, .resumable = 1, .show_default = 1, .def_u = 1,
     .lo_u = 0, .hi_u = 1024},
    {.name = "reference_walkers", .option = "reference-walkers", .label = "reference walkers",
     .unit = "", .metavar = "P",
     .help = "instead of worker threads: after the serial phase, P walkers advanced in turn "
             "(one jump each) in one thread, each jump seeing the cluster as it is, with the "
             "workers' --recheck rules; deterministic (the race-free reference of P "
             "concurrent walkers; P = 1 is serial DLA); 0 = off",
     .group = "Threads (PDLA):", .example = "2", .type = PDLA_PT_INT,
     .offset = AT(reference_walkers), .bit = PDLA_PARAM_REFERENCE_WALKERS, .models = DLA,
     .resumable = 1, .show_default = 1, .absent_default = 1, .def_u = 0, .lo_u = 0,
     .hi_u = 1u << 20, .check = check_reference_walkers},
    {.name = "serial_until", .option = "serial-until", .label = "serial until",
     .unit = "particles", .metavar = "N",
     .help = "grow with one walker (deterministic) up to N particles, then start the workers",
     .group = "Threads (PDLA):", .example = "100", .type = PDLA_PT_U64,
     .offset = AT(serial_until), .bit = PDLA_PARAM_SERIAL_UNTIL, .models = DLA, .resumable = 1,
     .show_default = 1, .def_u = 10000000, .lo_u = 0, .hi_u = UINT64_MAX},
    {.name = "recheck", .option = "recheck", .label = "re-check mode", .unit = "",
     .metavar = "continue|discard",
     .help = "a worker's walker whose spot another one took: continue in contact with "
             "the newcomer, or discard it",
     .group = "Threads (PDLA):", .example = "discard", .type = PDLA_PT_CHOICE,
     .offset = AT(recheck), .bit = PDLA_PARAM_RECHECK, .models = DLA, .show_default = 1,
     .def_u = PDLA_RECHECK_CONTINUE, .lo_u = 0, .hi_u = 1, .choices = recheck_words},
    {.name = "bind", .option = "bind", .label = "binding", .unit = "", .metavar = "none|core",
     .help = "worker placement: none (the OS decides) or one per physical core",
     .group = "Threads (PDLA):", .example = "core", .type = PDLA_PT_CHOICE, .offset = AT(bind),
     .bit = PDLA_PARAM_BIND, .models = DLA, .resumable = 1, .show_default = 1,
     .def_u = PDLA_BIND_NONE, .lo_u = 0, .hi_u = 1, .choices = bind_words},
    {.name = "rg_per_decade", .option = "rg-per-decade", .label = "rg samples per decade",
     .unit = "", .metavar = "K", .help = "R_g(N) samples per decade of N, 0 = none",
     .group = "Output:", .example = "20", .type = PDLA_PT_INT, .offset = AT(rg_per_decade),
     .bit = PDLA_PARAM_RG_PER_DECADE, .models = DLA, .show_default = 1, .def_u = 100,
     .lo_u = 0, .hi_u = 10000},
    {.name = "record_arrival", .option = "arrival", .label = "record_arrival", .unit = "",
     .help = "store positions in arrival order (costs 4 bytes per coordinate while growing; "
             "lets `pdla render --color arrival` colour by it)",
     .group = "Output:", .example = "yes", .type = PDLA_PT_FLAG, .offset = AT(record_arrival),
     .bit = PDLA_PARAM_RECORD_ARRIVAL, .models = DLA, .flag_value = 1, .def_u = 0, .lo_u = 0,
     .hi_u = 1},
};
#undef AT
#undef DLA

#define N_DLA_PARAMS (sizeof dla_params / sizeof dla_params[0])

const pdla_param_desc *pdla_param_table(size_t *n)
{
    *n = N_DLA_PARAMS;
    return dla_params;
}

void pdla_params_default(pdla_params *p)
{
    memset(p, 0, sizeof *p);
    pdla_param_defaults(dla_params, N_DLA_PARAMS, p);
}

int pdla_params_validate(const pdla_params *p, char *err, size_t errlen)
{
    return pdla_param_validate(dla_params, N_DLA_PARAMS, p, NULL, err, errlen);
}

/* ---- table-driven functions -------------------------------------------- */

static int same_key(const char *a, const char *b)
{
    for (; *a && *b; a++, b++) {
        const char x = *a == '_' ? '-' : *a, y = *b == '_' ? '-' : *b;
        if (x != y) return 0;
    }
    return *a == *b;
}

const pdla_param_desc *pdla_param_find(const pdla_param_desc *t, size_t n, const char *key)
{
    for (size_t i = 0; i < n; i++)
        if (same_key(t[i].option, key)) return &t[i];
    for (size_t i = 0; i < n; i++)
        if (same_key(t[i].name, key)) return &t[i];
    return NULL;
}

static void *field(const pdla_param_desc *d, void *s) { return (char *)s + d->offset; }
static const void *cfield(const pdla_param_desc *d, const void *s)
{
    return (const char *)s + d->offset;
}

/* BOX: how many lengths the row uses (its dimension field, clamped). */
static int box_count(const pdla_param_desc *d, const void *s)
{
    const int n = *(const int *)((const char *)s + d->count_offset);
    return n < 1 ? 1 : n > PDLA_PARAM_BOX_MAX ? PDLA_PARAM_BOX_MAX : n;
}

int64_t pdla_param_get_i(const pdla_param_desc *d, const void *s)
{
    switch (d->type) {
    case PDLA_PT_BOX: return *(const uint32_t *)cfield(d, s); /* the first length */
    case PDLA_PT_U64: return (int64_t) * (const uint64_t *)cfield(d, s);
    case PDLA_PT_REAL: return (int64_t) * (const double *)cfield(d, s);
    default: return *(const int *)cfield(d, s);
    }
}

uint64_t pdla_param_get_u(const pdla_param_desc *d, const void *s)
{
    if (d->type == PDLA_PT_U64) return *(const uint64_t *)cfield(d, s);
    return (uint64_t)pdla_param_get_i(d, s);
}

double pdla_param_get_real(const pdla_param_desc *d, const void *s)
{
    if (d->type == PDLA_PT_REAL) return *(const double *)cfield(d, s);
    if (d->type == PDLA_PT_U64) return (double)*(const uint64_t *)cfield(d, s);
    if (d->type == PDLA_PT_BOX) return (double)*(const uint32_t *)cfield(d, s);
    return (double)*(const int *)cfield(d, s);
}

void pdla_param_set_u(const pdla_param_desc *d, void *s, uint64_t v)
{
    switch (d->type) {
    case PDLA_PT_U64: *(uint64_t *)field(d, s) = v; break;
    case PDLA_PT_REAL: *(double *)field(d, s) = (double)v; break;
    case PDLA_PT_BOX: /* one length: the same on every axis */
        for (int i = 0; i < PDLA_PARAM_BOX_MAX; i++) ((uint32_t *)field(d, s))[i] = (uint32_t)v;
        break;
    default: *(int *)field(d, s) = (int)v; break;
    }
}

void pdla_param_set_real(const pdla_param_desc *d, void *s, double v)
{
    if (d->type == PDLA_PT_REAL) *(double *)field(d, s) = v;
    else pdla_param_set_u(d, s, (uint64_t)v);
}

int pdla_param_equal(const pdla_param_desc *d, const void *a, const void *b)
{
    if (d->same) return d->same(a, b);
    if (d->type == PDLA_PT_STRING) return strcmp(cfield(d, a), cfield(d, b)) == 0;
    const size_t size = d->type == PDLA_PT_U64 ? sizeof(uint64_t)
                        : d->type == PDLA_PT_REAL ? sizeof(double)
                        : d->type == PDLA_PT_BOX  ? (size_t)box_count(d, a) * sizeof(uint32_t)
                                                  : sizeof(int);
    return memcmp(cfield(d, a), cfield(d, b), size) == 0;
}

void pdla_param_defaults(const pdla_param_desc *t, size_t n, void *s)
{
    for (size_t i = 0; i < n; i++) {
        if (t[i].type == PDLA_PT_REAL) pdla_param_set_real(&t[i], s, t[i].def_r);
        else if (t[i].type == PDLA_PT_STRING)
            snprintf(field(&t[i], s), t[i].hi_u + 1, "%s", t[i].def_s ? t[i].def_s : "");
        else pdla_param_set_u(&t[i], s, t[i].def_u);
    }
}

int pdla_param_choice(const pdla_param_desc *d, const char *word)
{
    if (d->type != PDLA_PT_CHOICE || !word) return -1;
    for (int i = 0; d->choices[i]; i++)
        if (!strcmp(d->choices[i], word)) return i;
    return -1;
}

int pdla_param_format(const pdla_param_desc *d, const void *s, int exact, char *buf, size_t len)
{
    switch (d->type) {
    case PDLA_PT_U64: return snprintf(buf, len, "%" PRIu64, pdla_param_get_u(d, s));
    case PDLA_PT_REAL: return snprintf(buf, len, exact ? "%.17g" : "%g", pdla_param_get_real(d, s));
    case PDLA_PT_CHOICE: {
        const int64_t v = pdla_param_get_i(d, s);
        return snprintf(buf, len, "%s", v >= 0 && (uint64_t)v <= d->hi_u ? d->choices[v] : "invalid");
    }
    case PDLA_PT_STRING: return snprintf(buf, len, "%s", (const char *)cfield(d, s));
    case PDLA_PT_BOX: {
        const uint32_t *L = cfield(d, s);
        int o = 0;
        if (len) buf[0] = '\0';
        for (int i = 0; i < box_count(d, s); i++) {
            const int w = snprintf(buf + (size_t)o, (size_t)o < len ? len - (size_t)o : 0, i ? "x%u" : "%u", L[i]);
            o += w;
        }
        return o;
    }
    default: return snprintf(buf, len, "%" PRId64, pdla_param_get_i(d, s));
    }
}

void pdla_param_format_two(const pdla_param_desc *d, const void *a, const void *b, char *abuf, char *bbuf,
                           size_t len)
{
    pdla_param_format(d, a, 0, abuf, len);
    pdla_param_format(d, b, 0, bbuf, len);
    if (len && !strcmp(abuf, bbuf)) {
        pdla_param_format(d, a, 1, abuf, len);
        pdla_param_format(d, b, 1, bbuf, len);
    }
    if (len && !abuf[0]) snprintf(abuf, len, "(none)");
    if (len && !bbuf[0]) snprintf(bbuf, len, "(none)");
}

/* x with the fewest digits (6 to 17) that read back as x: the value a
 * range message names ("got 1" for 1.0000001 said nothing). */
static const char *real_text(char buf[32], double x)
{
    for (int p = 6; p <= 17; p++) {
        snprintf(buf, 32, "%.*g", p, x);
        if (strtod(buf, NULL) == x) break;
    }
    return buf;
}

/* A bound as people write it: %g, with "1e+06" shortened to "1e6". */
static const char *bound_text(char buf[32], double x)
{
    char t[32];
    snprintf(t, sizeof t, "%g", x);
    size_t j = 0;
    for (size_t i = 0; t[i] && j < 31; i++) {
        if (t[i] == 'e') {
            buf[j++] = 'e';
            if (t[i + 1] == '+') i++;
            else if (t[i + 1] == '-') buf[j++] = t[++i];
            while (t[i + 1] == '0' && t[i + 2]) i++;
            continue;
        }
        buf[j++] = t[i];
    }
    buf[j] = '\0';
    return buf;
}

/* The generic range rule of one row; 0 or PDLA_EINVAL with the message. */
static int check_range(const pdla_param_desc *d, const void *s, char *err, size_t errlen)
{
    const char *sp = d->unit[0] ? " " : "";
    switch (d->type) {
    case PDLA_PT_REAL: {
        const double v = pdla_param_get_real(d, s);
        const int low = d->lo_open ? !(v > d->lo_r) : !(v >= d->lo_r);
        const int high = d->hi_open ? !(v < d->hi_r) : !(v <= d->hi_r);
        char lo[32], hi[32], got[32];
        if (low || high)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s must be in %c%s, %s%c%s%s, got %s", d->label,
                              d->lo_open ? '(' : '[', bound_text(lo, d->lo_r),
                              bound_text(hi, d->hi_r), d->hi_open ? ')' : ']', sp, d->unit, real_text(got, v));
        return 0;
    }
    case PDLA_PT_BOX: {
        const uint32_t *L = cfield(d, s);
        const int n = box_count(d, s);
        for (int i = 0; i < PDLA_PARAM_BOX_MAX; i++) {
            if (i < n && L[i] == 0)
                return pdla_errorf(PDLA_EINVAL, err, errlen, "%s gives %d lengths for %d axes", d->label, i, n);
            if (i < n && (L[i] < d->lo_u || L[i] > d->hi_u))
                return pdla_errorf(PDLA_EINVAL, err, errlen,
                                   "%s needs %d lengths in [%" PRIu64 ", %" PRIu64 "]%s%s, length %d is %u",
                                   d->label, n, d->lo_u, d->hi_u, sp, d->unit, i + 1, L[i]);
            /* Beyond the dimension: unset, or the one length given for all axes. */
            if (i >= n && L[i] && L[i] != L[0])
                return pdla_errorf(PDLA_EINVAL, err, errlen, "%s has more lengths than the %d axes", d->label, n);
        }
        return 0;
    }
    case PDLA_PT_FLAG:
        if (pdla_param_get_i(d, s) != 0 && pdla_param_get_i(d, s) != 1)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s must be 0 or 1", d->label);
        return 0;
    case PDLA_PT_CHOICE: {
        const int64_t v = pdla_param_get_i(d, s);
        if (v < 0 || (uint64_t)v > d->hi_u)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "unknown %s %" PRId64, d->label, v);
        return 0;
    }
    case PDLA_PT_U64: {
        const uint64_t v = pdla_param_get_u(d, s);
        if (v >= d->lo_u && v <= d->hi_u) return 0;
        if (d->hi_u == UINT64_MAX)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s must be at least %" PRIu64, d->label, d->lo_u);
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s must be in [%" PRIu64 ", %" PRIu64 "]%s%s, got %" PRIu64,
                          d->label, d->lo_u, d->hi_u, sp, d->unit, v);
    }
    case PDLA_PT_STRING: {
        const size_t v = strnlen(cfield(d, s), d->hi_u + 1);
        if (v >= d->lo_u && v <= d->hi_u) return 0;
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s must be %" PRIu64 " to %" PRIu64
                           " characters long", d->label, d->lo_u, d->hi_u);
    }
    case PDLA_PT_INT: {
        const int64_t v = pdla_param_get_i(d, s);
        if (v >= (int64_t)d->lo_u && v <= (int64_t)d->hi_u) return 0;
        if (d->hi_u == d->lo_u + 1)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "%s must be %" PRIu64 " or %" PRIu64 ", got %" PRId64,
                              d->label, d->lo_u, d->hi_u, v);
        return pdla_errorf(PDLA_EINVAL, err, errlen, "%s must be in [%" PRIu64 ", %" PRIu64 "]%s%s, got %" PRId64,
                          d->label, d->lo_u, d->hi_u, sp, d->unit, v);
    }
    }
    return 0;
}

int pdla_param_validate(const pdla_param_desc *t, size_t n, const void *s,
                        const pdla_param_desc **bad, char *err, size_t errlen)
{
    for (size_t i = 0; i < n; i++) {
        /* The row's own rule first: it words the common mistakes best. */
        if ((t[i].check && t[i].check(s, err, errlen)) || check_range(&t[i], s, err, errlen)) {
            if (bad) *bad = &t[i];
            return PDLA_EINVAL;
        }
    }
    if (bad) *bad = NULL;
    return PDLA_OK;
}

/* ---- text in, and the resume rule --------------------------------------- */

/* A whole number >= 0: digits, or a decimal/exponent form that is whole
 * ("1e5", "2.5e3"); NULL or why not. */
static const char *parse_whole(const char *t, uint64_t *out)
{
    if (!*t || !strchr("0123456789.", *t)) return "is not a number";
    if (t[strspn(t, "0123456789")] == '\0') {
        errno = 0;
        const unsigned long long v = strtoull(t, NULL, 10);
        if (errno == ERANGE) return "is too large";
        *out = v;
        return NULL;
    }
    if (t[strspn(t, "0123456789.eE+-")]) return "is not a number";
    errno = 0;
    char *end;
    const double x = strtod(t, &end);
    if (*end || errno == ERANGE || !isfinite(x)) return "is not a number";
    if (x != floor(x)) return "is not a whole number";
    if (x >= 18446744073709551616.0) return "is too large";
    *out = (uint64_t)x;
    return NULL;
}

static const char *parse_real(const char *t, double *out)
{
    /* strtod also reads blanks, inf, nan and hexadecimal: not for us */
    if (!*t || t[strspn(t, "0123456789.eE+-")]) return "is not a number";
    errno = 0;
    char *end;
    const double x = strtod(t, &end);
    if (end == t || *end || errno == ERANGE || !isfinite(x)) return "is not a number";
    *out = x;
    return NULL;
}

int pdla_param_parse(const pdla_param_desc *d, void *s, const char *text, char *err,
                     size_t errlen)
{
    const char *why = NULL;
    uint64_t u = 0;
    double x = 0;
    switch (d->type) {
    case PDLA_PT_REAL:
        if (!(why = parse_real(text, &x))) pdla_param_set_real(d, s, x);
        break;
    case PDLA_PT_CHOICE: {
        const int k = pdla_param_choice(d, text);
        if (k < 0) {
            char list[128] = "";
            for (int i = 0; d->choices[i]; i++)
                snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? "|" : "",
                         d->choices[i]);
            return pdla_errorf(PDLA_EINVAL, err, errlen, "'%s' is not one of %s", text, list);
        }
        pdla_param_set_u(d, s, (uint64_t)k);
        break;
    }
    case PDLA_PT_FLAG: {
        static const char *const yes[] = {"yes", "true", "1"}, *const no[] = {"no", "false", "0"};
        int v = -1;
        for (int i = 0; i < 3; i++) {
            if (!strcmp(text, yes[i])) v = 1;
            if (!strcmp(text, no[i])) v = 0;
        }
        if (v < 0) why = "is not yes or no";
        else pdla_param_set_u(d, s, (uint64_t)v);
        break;
    }
    case PDLA_PT_BOX: {
        /* "L" (every axis) or "L1xL2x...": as many as the row's count field */
        const int n = *(const int *)((const char *)s + d->count_offset);
        uint32_t L[PDLA_PARAM_BOX_MAX];
        int k = 0;
        char buf[128];
        snprintf(buf, sizeof buf, "%s", text);
        for (char *c = buf, *xp; !why && c; c = xp ? xp + 1 : NULL, k++) {
            xp = strchr(c, 'x');
            if (xp) *xp = '\0';
            if (k == PDLA_PARAM_BOX_MAX) why = "has too many lengths";
            else if (!(why = parse_whole(c, &u)) && u > UINT32_MAX) why = "is too large";
            else if (!why) L[k] = (uint32_t)u;
        }
        if (!why && k != 1 && k != n) why = "has not one length per axis";
        if (!why && k == 1) pdla_param_set_u(d, s, L[0]);
        else if (!why) memcpy(field(d, s), L, (size_t)k * sizeof *L);
        break;
    }
    case PDLA_PT_STRING:
        if (strlen(text) > d->hi_u) why = "is too long";
        else snprintf(field(d, s), d->hi_u + 1, "%s", text);
        break;
    case PDLA_PT_INT:
        if (!(why = parse_whole(text, &u)) && u > INT_MAX) why = "is too large";
        if (!why) pdla_param_set_u(d, s, u);
        break;
    case PDLA_PT_U64:
        if (!(why = parse_whole(text, &u))) pdla_param_set_u(d, s, u);
        break;
    }
    if (why) return pdla_errorf(PDLA_EINVAL, err, errlen, "'%s' %s", text, why);
    return PDLA_OK;
}

int pdla_param_check_asked(const pdla_param_desc *t, size_t n, uint32_t given, const void *have,
                           const void *asked, char *err, size_t errlen)
{
    for (size_t i = 0; i < n; i++) {
        const pdla_param_desc *d = &t[i];
        if (!(given & d->bit) || d->resumable || pdla_param_equal(d, asked, have)) continue;
        char h[64], a[64];
        pdla_param_format_two(d, have, asked, h, a, sizeof h);
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "cannot resume with a different physics parameter: %s is %s in the checkpoint, %s asked",
                           d->label, h, a);
    }
    return PDLA_OK;
}

void pdla_param_apply_resumable(const pdla_param_desc *t, size_t n, uint32_t given, void *dst,
                                const void *src)
{
    for (size_t i = 0; i < n; i++) {
        const pdla_param_desc *d = &t[i];
        if (!(given & d->bit) || !d->resumable) continue;
        if (d->type == PDLA_PT_REAL) pdla_param_set_real(d, dst, pdla_param_get_real(d, src));
        else if (d->type == PDLA_PT_BOX) memcpy(field(d, dst), cfield(d, src), PDLA_PARAM_BOX_MAX * sizeof(uint32_t));
        else if (d->type == PDLA_PT_STRING) memcpy(field(d, dst), cfield(d, src), d->hi_u + 1);
        else pdla_param_set_u(d, dst, pdla_param_get_u(d, src));
    }
}
