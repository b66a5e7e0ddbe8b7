/*
 * dlca_params.c - the DLCA model's parameters as rows of the shared
 * parameter table machinery (include/pdla/params.h, models = PDLA_MODEL_DLCA):
 * defaults, range checks and their one-line errors, the CLI options, --help
 * lines and scene keys (src/cli/dlca_cmd.c), the /parameters attributes
 * (h5u_write_param_table) and their reading back (pdla_param_read_h5), and
 * the resume rule (pdla_param_check_asked) all come from these rows, through
 * the same code as the DLA engine's. What a row cannot say (the box's volume,
 * N against V, the machine's memory) is in dlca_params_validate.
 */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pdla/dlca.h"
#include "dlca_internal.h"

/* ---- rules that a range cannot say ------------------------------------- */

static int check_grid_box(const void *s, char *err, size_t errlen)
{
    const int A = ((const dlca_params *)s)->grid_box;
    if (A > 0 && (A & (A - 1)))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "grid box must be a power of two, got %d", A);
    return 0;
}

/* A box written out axis by axis must have dim lengths (box_lengths, set
 * by parse_box; the lengths alone cannot say how many were written). Run
 * before the range check, which words this case less well. */
static int check_box_lengths(const void *s, char *err, size_t errlen)
{
    const dlca_params *p = s;
    if (p->box_lengths > 1 && p->box_lengths != p->dim)
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "box gives %d lengths but dim is %d (one length per axis, or one for every axis)",
                           p->box_lengths, p->dim);
    return 0;
}

/* ---- the table ---------------------------------------------------------- */

static const char *const search_words[] = {"lattice", "boxes", "allpairs", NULL};

#define AT(f) offsetof(dlca_params, f)
#define M PDLA_MODEL_DLCA
#define G "Model (also scene keys, with model = dlca):"

/* Order: the --help order; validation runs in it too, so box (which reads
 * dim) comes after dim. The names are the /parameters attributes of every
 * DLCA file written so far. */
static const pdla_param_desc table[] = {
    {.name = "dim", .option = "dim", .label = "dim", .unit = "", .metavar = "D",
     .help = "lattice dimension d", .group = G, .example = "3", .type = PDLA_PT_INT,
     .offset = AT(dim), .bit = DLCA_PARAM_DIM, .models = M, .show_default = 1, .def_u = 2,
     .lo_u = 2, .hi_u = DLCA_MAX_DIM},
    {.name = "box", .option = "box", .label = "box", .unit = "sites", .metavar = "L1xL2[x..]",
     .help = "box lengths, one per axis (one number: the same on every axis)", .group = G,
     .example = "64x48", .type = PDLA_PT_BOX, .offset = AT(box), .count_offset = AT(dim),
     .bit = DLCA_PARAM_BOX, .models = M, .show_default = 1, .def_u = 256, .lo_u = 2,
     .hi_u = DLCA_MAX_AXIS, .check = check_box_lengths},
    {.name = "fill", .option = "fill", .label = "fill fraction", .unit = "", .metavar = "PHI",
     .help = "fill fraction: N = round(PHI V) monomers (unless --count)", .group = G,
     .example = "0.05", .type = PDLA_PT_REAL, .offset = AT(fill), .bit = DLCA_PARAM_FILL,
     .models = M, .show_default = 1, .def_r = 0.01, .lo_r = 0, .hi_r = 1, .lo_open = 1,
     .hi_open = 1},
    {.name = "count", .option = "count", .label = "count", .unit = "monomers", .metavar = "N",
     .help = "number of monomers (0: from --fill)", .group = G, .example = "100",
     .type = PDLA_PT_U64, .offset = AT(count), .bit = DLCA_PARAM_COUNT, .models = M,
     .show_default = 1, .def_u = 0, .lo_u = 0, .hi_u = UINT32_MAX},
    {.name = "mobility", .option = "mobility", .label = "mobility", .unit = "", .metavar = "GAMMA",
     .help = "a cluster of s monomers moves at rate s^GAMMA (0: all equal, as in the seed)",
     .group = G, .example = "-0.5", .type = PDLA_PT_REAL, .offset = AT(mobility),
     .bit = DLCA_PARAM_MOBILITY, .models = M, .show_default = 1, .def_r = 0, .lo_r = -10,
     .hi_r = 10},
    {.name = "sticking", .option = "sticking", .label = "sticking probability", .unit = "",
     .metavar = "P", .help = "probability that face-adjacent clusters join after a move",
     .group = G, .example = "0.5", .type = PDLA_PT_REAL, .offset = AT(sticking),
     .bit = DLCA_PARAM_STICKING, .models = M, .show_default = 1, .def_r = 1, .lo_r = 0,
     .hi_r = 1, .lo_open = 1},
    {.name = "drift", .option = "drift", .label = "drift", .unit = "", .metavar = "G",
     .help = "probability that a move is one step down the last axis (gravity)", .group = G,
     .example = "0.1", .type = PDLA_PT_REAL, .offset = AT(drift), .bit = DLCA_PARAM_DRIFT,
     .models = M, .show_default = 1, .def_r = 0, .lo_r = 0, .hi_r = 1, .hi_open = 1},
    {.name = "until_clusters", .option = "until-clusters", .label = "until-clusters",
     .unit = "clusters", .metavar = "K", .help = "stop when K clusters are left", .group = G,
     .example = "10", .type = PDLA_PT_U64, .offset = AT(until_clusters),
     .bit = DLCA_PARAM_UNTIL_CLUSTERS, .models = M, .resumable = 1, .show_default = 1,
     .def_u = 1, .lo_u = 1, .hi_u = UINT32_MAX},
    {.name = "until_time", .option = "until-time", .label = "until-time", .unit = "monomer moves",
     .metavar = "T", .help = "stop at time T (0: never)", .group = G, .example = "100",
     .type = PDLA_PT_REAL, .offset = AT(until_time), .bit = DLCA_PARAM_UNTIL_TIME, .models = M,
     .resumable = 1, .show_default = 1, .def_r = 0, .lo_r = 0, .hi_r = 1e300},
    {.name = "max_attempts", .option = "max-attempts", .label = "max-attempts", .unit = "attempts",
     .metavar = "M", .help = "stop after M attempted moves (0: never)", .group = G,
     .example = "100000", .type = PDLA_PT_U64, .offset = AT(max_attempts),
     .bit = DLCA_PARAM_MAX_ATTEMPTS, .models = M, .resumable = 1, .show_default = 1, .def_u = 0,
     .lo_u = 0, .hi_u = UINT64_MAX},
    {.name = "seed", .option = "seed", .label = "seed", .unit = "", .metavar = "S",
     .help = "random seed", .group = G, .example = "12345", .type = PDLA_PT_U64,
     .offset = AT(seed), .bit = DLCA_PARAM_SEED, .models = M, .show_default = 1, .def_u = 1,
     .lo_u = 0, .hi_u = UINT64_MAX},
    {.name = "search", .option = "search", .label = "search", .unit = "",
     .metavar = "lattice|boxes|allpairs",
     .help = "collision search: bit lattice (fastest), the seed's grid-boxing, or all pairs",
     .group = G, .example = "boxes", .type = PDLA_PT_CHOICE, .offset = AT(search),
     .bit = DLCA_PARAM_SEARCH, .models = M, .show_default = 1, .def_u = DLCA_SEARCH_LATTICE,
     .lo_u = 0, .hi_u = 2, .choices = search_words},
    {.name = "grid_box", .option = "grid-box", .label = "grid box", .unit = "sites", .metavar = "A",
     .help = "first grid-box side of --search boxes (a power of two; doubles as clusters grow)",
     .group = G, .example = "8", .type = PDLA_PT_INT, .offset = AT(grid_box),
     .bit = DLCA_PARAM_GRID_BOX, .models = M, .show_default = 1, .def_u = 4, .lo_u = 1,
     .hi_u = 65536, .check = check_grid_box},
};
#undef AT
#undef M
#undef G

const pdla_param_desc *dlca_param_table(size_t *n)
{
    *n = sizeof table / sizeof table[0];
    return table;
}

const char *dlca_search_name(int search)
{
    return search >= 0 && search <= 2 ? search_words[search] : "unknown";
}

/* ---- text -> value ------------------------------------------------------ */

/* A number with an optional k/M/G suffix (10M = 1e7), whole text used. */
static int parse_num(const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || s[strspn(s, "0123456789.eE+-kMG")]) return -1;
    if (errno == ERANGE) return -2; /* beyond a double, or below its smallest normal */
    if (*end == 'k' || *end == 'K') v *= 1e3, end++;
    else if (*end == 'M') v *= 1e6, end++;
    else if (*end == 'G') v *= 1e9, end++;
    if (*end || !isfinite(v)) return -1;
    *out = v;
    return 0;
}

/* "L1xL2x...": each an integer in the row's range, at most 5; one length
 * stands for every axis. */
static int parse_box(const pdla_param_desc *d, dlca_params *p, const char *text, char *err, size_t errlen)
{
    uint32_t L[PDLA_PARAM_BOX_MAX] = {0};
    int n = 0;
    for (const char *s = text;;) {
        char *end;
        errno = 0;
        const unsigned long long v = strtoull(s, &end, 10);
        /* A digit first: strtoull would skip blanks and take a sign. */
        if (end == s || errno || v < d->lo_u || v > d->hi_u || *s < '0' || *s > '9')
            return pdla_errorf(PDLA_EINVAL, err, errlen,
                               "invalid --box '%s' (each length an integer in [2, %llu], written L1xL2[x...])",
                               text, (unsigned long long)d->hi_u);
        if (n == PDLA_PARAM_BOX_MAX)
            return pdla_errorf(PDLA_EINVAL, err, errlen, "invalid --box '%s' (at most 5 lengths)", text);
        L[n++] = (uint32_t)v;
        if (*end == '\0') break;
        if (*end != 'x')
            return pdla_errorf(PDLA_EINVAL, err, errlen, "invalid --box '%s' (lengths are joined by 'x')", text);
        s = end + 1;
    }
    for (int i = n; i < PDLA_PARAM_BOX_MAX; i++) L[i] = n == 1 ? L[0] : 0;
    memcpy((char *)p + d->offset, L, sizeof L);
    p->box_lengths = n; /* held against dim once every option is read (check_box_lengths) */
    return 0;
}

int dlca_param_set(dlca_params *p, const pdla_param_desc *d, const char *text, char *err, size_t errlen)
{
    if (d->type == PDLA_PT_BOX) return parse_box(d, p, text, err, errlen);
    if (d->type == PDLA_PT_CHOICE) {
        const int c = pdla_param_choice(d, text);
        if (c < 0) return pdla_errorf(PDLA_EINVAL, err, errlen, "invalid --%s '%s' (%s)", d->option, text, d->metavar);
        pdla_param_set_u(d, p, (uint64_t)c);
        return 0;
    }
    double v;
    const int integer = d->type != PDLA_PT_REAL;
    const int prc = parse_num(text, &v);
    if (prc == -2)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "invalid --%s '%s' (out of range)", d->option, text);
    if (prc || (integer && (v != floor(v) || v < 0)))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "invalid --%s '%s' (%s)", d->option, text,
                           integer ? "not a whole number of at least 0" : "not a number");
    if (d->type == PDLA_PT_REAL) pdla_param_set_real(d, p, v);
    else {
        /* Exact for integers written out in full (seeds above 2^53). */
        char *end;
        errno = 0;
        const unsigned long long u = strtoull(text, &end, 10);
        const int exact = *end == '\0' && !errno;
        /* The range of an exact integer by the integer: 2^64 - 1 rounds to
         * 2^64 as a double and was refused as above "at most 2^64 - 1". */
        if (exact ? d->type == PDLA_PT_INT && u > d->hi_u
                  : v >= 18446744073709551616.0 || (d->type == PDLA_PT_INT && v > (double)d->hi_u))
            return pdla_errorf(PDLA_EINVAL, err, errlen, "invalid --%s '%s' (at most %llu)", d->option, text,
                               (unsigned long long)d->hi_u);
        pdla_param_set_u(d, p, exact ? (uint64_t)u : (uint64_t)v);
    }
    /* The row's own range and rule, now, so that a scene names its line. */
    char why[256];
    if (pdla_param_validate(d, 1, p, NULL, why, sizeof why))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "invalid --%s '%s': %s", d->option, text, why);
    return 0;
}

/* ---- defaults and the model's own rules ----------------------------------- */

void dlca_params_default(dlca_params *p)
{
    memset(p, 0, sizeof *p);
    pdla_param_defaults(table, sizeof table / sizeof table[0], p);
}

uint64_t dlca_params_monomers(const dlca_params *p)
{
    if (p->count) return p->count;
    double V = 1;
    for (int i = 0; i < p->dim && i < DLCA_MAX_DIM; i++) V *= p->box[i];
    return (uint64_t)floor(p->fill * V + 0.5);
}

/* The bit lattice (1 bit a site) and about 32 bytes a monomer at the
 * mid-run peak (runs/dlca/memory.txt): refuse what cannot fit in memory. */
int dlca_memory_fits(double V, uint64_t N, double *gib)
{
    const long pages = sysconf(_SC_PHYS_PAGES), psz = sysconf(_SC_PAGESIZE);
    const double need = V / 8 + 32.0 * (double)N;
    *gib = need / 1073741824.0;
    return !(pages > 0 && psz > 0 && need > 0.5 * (double)pages * (double)psz);
}

/* monomers: check N from --fill/--count (0: a --start file gives them) */
static int validate(const dlca_params *p, int monomers, char *err, size_t errlen)
{
    const pdla_param_desc *bad = NULL;
    char why[256];
    if (pdla_param_validate(table, sizeof table / sizeof table[0], p, &bad, why, sizeof why))
        return pdla_errorf(PDLA_EINVAL, err, errlen, "--%s: %s", bad ? bad->option : "?", why);
    double V = 1;
    for (int i = 0; i < p->dim; i++) V *= p->box[i];
    if (V >= 2147483648.0) /* a site and a tag bit in one word (dlca_sim.h, DLCA_EMPTY) */
        return pdla_errorf(PDLA_EINVAL, err, errlen, "--box has %.3g sites (at most 2^31 - 1)", V);
    const uint64_t N = monomers ? dlca_params_monomers(p) : 0;
    double gib = 0;
    if (!dlca_memory_fits(V, N, &gib))
        return pdla_errorf(PDLA_EINVAL, err, errlen,
                           "--box and --fill need about %.3g GiB (lattice and monomers), more than half of this "
                           "machine's memory", gib);
    if (!monomers) return 0;
    if (N < 1 || (double)N >= V)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "the box of %.0f sites cannot hold %llu monomers (need 1 <= N < V)",
                           V, (unsigned long long)N);
    if (p->until_clusters > N && p->until_clusters != 1)
        return pdla_errorf(PDLA_EINVAL, err, errlen, "--until-clusters %llu is more than the %llu monomers",
                           (unsigned long long)p->until_clusters, (unsigned long long)N);
    return 0;
}

int dlca_params_validate(const dlca_params *p, char *err, size_t errlen) { return validate(p, 1, err, errlen); }

int dlca_params_validate_start(const dlca_params *p, char *err, size_t errlen)
{
    return validate(p, 0, err, errlen);
}

_Static_assert(DLCA_MAX_DIM == PDLA_PARAM_BOX_MAX, "the box row holds DLCA_MAX_DIM lengths");
_Static_assert(sizeof(((dlca_params *)0)->box) == PDLA_PARAM_BOX_MAX * sizeof(uint32_t), "box field");
