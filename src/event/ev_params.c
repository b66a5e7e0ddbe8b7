/*
 * ev_params.c - the event model's rows of the parameter table (pdla/params.h,
 * models = PDLA_MODEL_EVENT) and what the model adds to the shared machinery:
 * the --help text, the species list and the checks across fields. Defaults,
 * text -> value, ranges, /parameters and the resume rule are the shared
 * code's (src/core/params.c, h5util.c).
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ev_internal.h"

#define OFF(f) offsetof(ev_params, f)
#define EVT PDLA_MODEL_EVENT
#define BIT(k) (1u << (k))

static const char *const walls_words[] = {"elastic", "periodic", NULL};
static const char *const vel_words[] = {"maxwell", "fixed", NULL};
static const char *const start_words[] = {"random", "lattice", NULL};

static int species_same(const void *a, const void *b);
static int seeds_same(const void *a, const void *b);

/* The event model's rows of the parameter table (pdla/params.h). `name` is
 * the /parameters attribute and the checkpoint's key as the files have
 * always had them (the option's spelling); `label` names a row in messages.
 * Only the stop conditions may change on --resume. Order: the --help order. */
static const pdla_param_desc ev_rows[] = {
    {.name = "dim", .option = "dim", .label = "dim", .unit = "", .metavar = "X",
     .help = "2: hard disks, 3: hard spheres", .group = "Event:", .example = "3",
     .type = PDLA_PT_INT, .offset = OFF(dim), .bit = BIT(0), .models = EVT, .show_default = 1,
     .def_u = 2, .lo_u = 2, .hi_u = 3},
    {.name = "particles", .option = "particles", .label = "particles", .unit = "", .metavar = "X",
     .help = "number of particles (one species; see --species)", .group = "Event:",
     .example = "500", .type = PDLA_PT_U64, .offset = OFF(particles), .bit = BIT(1),
     .models = EVT, .show_default = 1, .def_u = 1000, .lo_u = 1, .hi_u = 4000000000u},
    {.name = "radius", .option = "radius", .label = "radius", .unit = "length", .metavar = "X",
     .help = "particle radius (one species)", .group = "Event:", .example = "0.4",
     .type = PDLA_PT_REAL, .offset = OFF(radius), .bit = BIT(2), .models = EVT,
     .show_default = 1, .def_r = 0.5, .lo_r = EV_RADIUS_MIN, .hi_r = 1e6},
    {.name = "density", .option = "density", .label = "density", .unit = "mass/length^dim",
     .metavar = "X", .help = "mass density: mass = density * (pi r^2 | 4/3 pi r^3)",
     .group = "Event:", .example = "2", .type = PDLA_PT_REAL, .offset = OFF(density),
     .bit = BIT(3), .models = EVT, .show_default = 1, .def_r = 1, .lo_r = 0, .hi_r = 1e12,
     .lo_open = 1},
    {.name = "species", .option = "species", .label = "species", .unit = "", .metavar = "LIST",
     .help = "COUNT:RADIUS:DENSITY[:STICKY][,...] up to 8 kinds (replaces --particles/--radius/"
             "--density); STICKY 1 (default): sticks, 0: a bath kind that never sticks",
     .group = "Event:", .example = "100:0.5:1,50:0.3:2", .type = PDLA_PT_STRING,
     .offset = OFF(species), .bit = BIT(4), .models = EVT, .show_default = 1, .lo_u = 0,
     .hi_u = sizeof(((ev_params *)0)->species) - 1, .def_s = "", .same = species_same},
    {.name = "seeds", .option = "seeds", .label = "seeds", .unit = "", .metavar = "FILE",
     .help = "immobile seeds instead of the central one: a line per seed, x y [z] radius, in "
             "box coordinates [0, side) (the side follows from --packing; the summary prints it); "
             "# comments. --resume takes the seeds from the checkpoint, not the file",
     .group = "Event:", .example = "seeds.txt", .type = PDLA_PT_STRING, .offset = OFF(seeds),
     .bit = BIT(17), .models = EVT, .show_default = 1, .lo_u = 0,
     .hi_u = sizeof(((ev_params *)0)->seeds) - 1, .def_s = "", .same = seeds_same},
    {.name = "packing", .option = "packing", .label = "packing", .unit = "", .metavar = "X",
     .help = "volume fraction of the particles in the box (sets the box side)", .group = "Event:",
     .example = "0.1", .type = PDLA_PT_REAL, .offset = OFF(packing), .bit = BIT(5),
     .models = EVT, .show_default = 1, .def_r = 0.05, .lo_r = 0, .hi_r = 0.7, .lo_open = 1},
    {.name = "box-walls", .option = "box-walls", .label = "box-walls", .unit = "",
     .metavar = "elastic|periodic", .help = "box boundaries", .group = "Event:",
     .example = "periodic", .type = PDLA_PT_CHOICE, .offset = OFF(walls), .bit = BIT(6),
     .models = EVT, .show_default = 1, .def_u = EV_WALLS_ELASTIC, .lo_u = 0, .hi_u = 1,
     .choices = walls_words},
    {.name = "seed", .option = "seed", .label = "seed", .unit = "", .metavar = "X",
     .help = "random seed", .group = "Event:", .example = "12345", .type = PDLA_PT_U64,
     .offset = OFF(seed), .bit = BIT(7), .models = EVT, .show_default = 1, .def_u = 1,
     .lo_u = 0, .hi_u = UINT64_MAX},
    {.name = "kT", .option = "kT", .label = "kT", .unit = "energy", .metavar = "X",
     .help = "k_B T of the start velocities", .group = "Event:", .example = "2",
     .type = PDLA_PT_REAL, .offset = OFF(kT), .bit = BIT(8), .models = EVT, .show_default = 1,
     .def_r = 1, .lo_r = 0, .hi_r = 1e12, .lo_open = 1},
    {.name = "velocities", .option = "velocities", .label = "velocities", .unit = "",
     .metavar = "maxwell|fixed",
     .help = "maxwell: Maxwell-Boltzmann at kT; fixed: speed sqrt(2 kT/m), random direction "
             "(seed 001)",
     .group = "Event:", .example = "fixed", .type = PDLA_PT_CHOICE, .offset = OFF(velocities),
     .bit = BIT(9), .models = EVT, .show_default = 1, .def_u = EV_VEL_MAXWELL, .lo_u = 0,
     .hi_u = 1, .choices = vel_words},
    {.name = "start", .option = "start", .label = "start", .unit = "", .metavar = "random|lattice",
     .help = "random: random sequential placement; lattice: shuffled grid sites",
     .group = "Event:", .example = "lattice", .type = PDLA_PT_CHOICE, .offset = OFF(start),
     .bit = BIT(10), .models = EVT, .show_default = 1, .def_u = EV_START_RANDOM, .lo_u = 0,
     .hi_u = 1, .choices = start_words},
    {.name = "seed-radius", .option = "seed-radius", .label = "seed-radius", .unit = "length",
     .metavar = "X",
     .help = "radius of the immobile central seed; 0: no seed (a plain hard-sphere gas)",
     .group = "Event:", .example = "1", .type = PDLA_PT_REAL, .offset = OFF(seed_radius),
     .bit = BIT(11), .models = EVT, .show_default = 1, .def_r = 0.5, .lo_r = 0, .hi_r = 1e6},
    {.name = "stick-p", .option = "stick-p", .label = "stick-p", .unit = "", .metavar = "X",
     .help = "probability that a contact with the seed or a stuck particle sticks",
     .group = "Event:", .example = "0.5", .type = PDLA_PT_REAL, .offset = OFF(stick_p),
     .bit = BIT(12), .models = EVT, .show_default = 1, .def_r = 1, .lo_r = 0, .hi_r = 1},
    {.name = "t-max", .option = "t-max", .label = "t-max", .unit = "time", .metavar = "X",
     .help = "stop at this time (0: none)", .group = "Event:", .example = "10",
     .type = PDLA_PT_REAL, .offset = OFF(t_max), .bit = BIT(13), .models = EVT, .resumable = 1,
     .show_default = 1, .def_r = 0, .lo_r = 0, .hi_r = 1e300},
    {.name = "max-stuck", .option = "max-stuck", .label = "max-stuck", .unit = "", .metavar = "X",
     .help = "stop at this many stuck particles (0: none)", .group = "Event:", .example = "10",
     .type = PDLA_PT_U64, .offset = OFF(max_stuck), .bit = BIT(14), .models = EVT,
     .resumable = 1, .show_default = 1, .def_u = 0, .lo_u = 0, .hi_u = 4000000000u},
    {.name = "max-events", .option = "max-events", .label = "max-events", .unit = "",
     .metavar = "X", .help = "stop after this many events (0: none)", .group = "Event:",
     .example = "1000", .type = PDLA_PT_U64, .offset = OFF(max_events), .bit = BIT(15),
     .models = EVT, .resumable = 1, .show_default = 1, .def_u = 0, .lo_u = 0,
     .hi_u = UINT64_MAX},
    {.name = "series-dt", .option = "series-dt", .label = "series-dt", .unit = "time",
     .metavar = "X",
     .help = "time between rows of the series (time, stuck, energy, collisions, pressure)",
     .group = "Event:", .example = "0.5", .type = PDLA_PT_REAL, .offset = OFF(series_dt),
     .bit = BIT(16), .models = EVT, .show_default = 1, .def_r = 1, .lo_r = 0, .hi_r = 1e300,
     .lo_open = 1},
};
#undef BIT
#undef EVT
#undef OFF

#define N_EV_ROWS (sizeof ev_rows / sizeof ev_rows[0])

const pdla_param_desc *ev_param_table(size_t *n)
{
    *n = N_EV_ROWS;
    return ev_rows;
}

int ev_param_set(ev_params *p, const char *name, const char *value, char *err, size_t errlen)
{
    const pdla_param_desc *d = pdla_param_find(ev_rows, N_EV_ROWS, name);
    if (!d) return pdla_errorf(-1, err, errlen, "unknown parameter '%s' for model event", name);
    char e[300];
    ev_params q = *p;
    /* a value that is no value of its type: "--OPT: 'x' is not ..."; out of
     * range: the row's own line, which names it */
    if (pdla_param_parse(d, &q, value, e, sizeof e)) return pdla_errorf(-1, err, errlen, "--%s: %s", d->option, e);
    if (pdla_param_validate(d, 1, &q, NULL, err, errlen)) return -1;
    *p = q;
    return 0;
}

void ev_params_default(ev_params *p)
{
    memset(p, 0, sizeof *p);
    pdla_param_defaults(ev_rows, N_EV_ROWS, p);
}

char *ev_help_text(void)
{
    size_t cap = 8192, n = 0;
    char *t = malloc(cap);
    if (!t) return NULL;
    ev_params def;
    ev_params_default(&def);
    n += (size_t)snprintf(t + n, cap - n,
                          "usage: pdla --model event [OPTIONS] [--out DIR] [--force]\n"
                          "Event-driven hard disks (2D) or spheres (3D) in a box around an "
                          "immobile seed;\nparticles touching the seed or a stuck particle stick "
                          "with probability --stick-p.\nWrites DIR/cluster.h5 (default DIR: "
                          "runs/event-YYYYmmdd-HHMMSS-<dim>d-<particles>). Options (scene key: name with _):\n");
    for (size_t k = 0; k < N_EV_ROWS; k++) {
        const pdla_param_desc *d = &ev_rows[k];
        char opt[64], dv[300];
        snprintf(opt, sizeof opt, "--%s %s", d->option, d->metavar);
        pdla_param_format(d, &def, 0, dv, sizeof dv);
        const int w = snprintf(t + n, cap - n, "  %-28s %s%s%s%s (default %s)\n", opt, d->help,
                               *d->unit ? " [" : "", d->unit, *d->unit ? "]" : "",
                               *dv ? dv : "none");
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
             "  --resume PATH                continue a run directory's checkpoint (or one\n"
             "                               checkpoint file, in its folder) bit for bit; --t-max,\n"
             "                               --max-stuck, --max-events may change, any other\n"
             "                               parameter given must equal the checkpoint's; its\n"
             "                               --checkpoint-every is kept unless given again\n"
             "  --help                       this text\n");
    return t;
}

double ev_particle_volume(int dim, double r)
{
    return dim == 2 ? M_PI * r * r : 4.0 / 3.0 * M_PI * r * r * r;
}

/* One number of --species, read as the command line reads numbers: digits,
 * '.', exponent and signs only (no blanks, hexadecimal, inf or nan), a digit
 * or '.' first, and neither under- nor overflow. 0, or -1. */
static int species_num(const char *c, double *out, char **end)
{
    const size_t n = strspn(c, "0123456789.eE+-");
    if (n == 0 || !strchr("0123456789.", *c)) return -1;
    errno = 0;
    *out = strtod(c, end);
    return *end == c + n && errno != ERANGE && isfinite(*out) ? 0 : -1;
}

int ev_parse_species(const ev_params *p, ev_species *sp, int *nsp, char *err, size_t errlen)
{
    if (!p->species[0]) {
        sp[0] = (ev_species){p->particles, p->radius, p->density, 1};
        *nsp = 1;
        return 0;
    }
    int n = 0;
    const char *c = p->species;
    const double rlo = pdla_param_find(ev_rows, N_EV_ROWS, "radius")->lo_r;
    const double rhi = pdla_param_find(ev_rows, N_EV_ROWS, "radius")->hi_r;
    const double dhi = pdla_param_find(ev_rows, N_EV_ROWS, "density")->hi_r;
    while (*c) {
        if (n == EV_MAX_SPECIES) return pdla_errorf(-1, err, errlen, "--species: more than %d kinds", EV_MAX_SPECIES);
        char *end;
        double cnt, r, rho;
        if (species_num(c, &cnt, &end) || *end != ':' || cnt < 1 || cnt != floor(cnt) || cnt > 4e9)
            return pdla_errorf(-1, err, errlen, "--species: kind %d: bad COUNT (want COUNT:RADIUS:DENSITY)", n + 1);
        c = end + 1;
        /* the ranges of --radius and --density: a kind of radius 1e300 made
         * a box of infinite side, one of density 1e300 a gas that never
         * reached the seed; both ran */
        if (species_num(c, &r, &end) || *end != ':')
            return pdla_errorf(-1, err, errlen, "--species: kind %d: RADIUS is not a number (want "
                               "COUNT:RADIUS:DENSITY)", n + 1);
        if (!(r >= rlo) || !(r <= rhi))
            return pdla_errorf(-1, err, errlen, "--species: kind %d: RADIUS must be in [%g, %g], got %.17g", n + 1,
                               rlo, rhi, r);
        c = end + 1;
        if (species_num(c, &rho, &end) || (*end != ',' && *end != ':' && *end))
            return pdla_errorf(-1, err, errlen, "--species: kind %d: DENSITY is not a number (want "
                               "COUNT:RADIUS:DENSITY)", n + 1);
        if (!(rho > 0) || !(rho <= dhi))
            return pdla_errorf(-1, err, errlen, "--species: kind %d: DENSITY must be in (0, %g], got %.17g", n + 1,
                               dhi, rho);
        int sticky = 1;
        if (*end == ':') {
            /* STICKY: exactly "0" or "1" */
            c = end + 1;
            if ((*c != '0' && *c != '1') || (c[1] != ',' && c[1]))
                return pdla_errorf(-1, err, errlen, "--species: kind %d: STICKY must be 0 or 1", n + 1);
            sticky = *c == '1';
            end = (char *)c + 1;
        }
        sp[n++] = (ev_species){(uint64_t)cnt, r, rho, sticky};
        c = *end ? end + 1 : end;
        if (*end == ',' && !*c) return pdla_errorf(-1, err, errlen, "--species: nothing after the last comma");
    }
    if (!n) return pdla_errorf(-1, err, errlen, "--species: empty list");
    *nsp = n;
    return 0;
}

/* The same kinds, however written: a resume compared the texts, so
 * 100:0.50:1.0 was "a different physics parameter" beside 100:0.5:1. Two
 * lists are the same when they parse to the same counts, radii, densities
 * (bit for bit) and STICKY; a list and none (--particles, --radius,
 * --density) by their text. */
static int species_same(const void *a, const void *b)
{
    const ev_params *p = a, *q = b;
    if (!strcmp(p->species, q->species)) return 1;
    if (!p->species[0] || !q->species[0]) return 0;
    ev_species x[EV_MAX_SPECIES], y[EV_MAX_SPECIES];
    int nx, ny;
    char e[400];
    if (ev_parse_species(p, x, &nx, e, sizeof e) || ev_parse_species(q, y, &ny, e, sizeof e) || nx != ny) return 0;
    for (int k = 0; k < nx; k++)
        if (x[k].count != y[k].count || x[k].radius != y[k].radius || x[k].density != y[k].density ||
            x[k].sticky != y[k].sticky)
            return 0;
    return 1;
}

/* The same seeds file: the same text, or two names of one file (./s.txt
 * and s.txt, from the working directory). A resume takes the seeds from
 * the checkpoint and does not read the file (which may have moved since),
 * so only its name is compared; a name of another file is refused. */
static int seeds_same(const void *a, const void *b)
{
    const ev_params *p = a, *q = b;
    if (!strcmp(p->seeds, q->seeds)) return 1;
    struct stat x, y;
    return p->seeds[0] && q->seeds[0] && stat(p->seeds, &x) == 0 && stat(q->seeds, &y) == 0 &&
           x.st_dev == y.st_dev && x.st_ino == y.st_ino;
}

/* About the bytes a particle takes at the peak (the engine's arrays, cells,
 * writing cluster.h5): 199 and 239 MB measured at N = 1e6 (2D, 3D). */
#define EV_BYTES_2D 210.0
#define EV_BYTES_3D 250.0

/* A run that cannot fit in this machine's memory is refused before it
 * starts, as the DLCA model does: each array alone fits the kernel's
 * overcommit, so N = 1e8 on a 23 GB machine allocated, then its pages were
 * written and the kernel killed pdla. 0, or -1 with the line. */
static int ev_too_big(int dim, uint64_t n, char *err, size_t errlen)
{
    const long pages = sysconf(_SC_PHYS_PAGES), psz = sysconf(_SC_PAGESIZE);
    const double need = (double)n * (dim == 3 ? EV_BYTES_3D : EV_BYTES_2D);
    if (pages > 0 && psz > 0 && need > 0.8 * (double)pages * (double)psz)
        return pdla_errorf(-1, err, errlen, "%" PRIu64 " particles need about %.3g GiB, more than 80%% of this "
                           "machine's memory (%.3g GiB)", n, need / 1073741824.0,
                           (double)pages * (double)psz / 1073741824.0);
    return 0;
}

/* Each range alone is not enough: --radius 1e-6 with --density 1e-300 is a
 * mass of 3e-312, whose start speed sqrt(2 kT / m) overflows; every event
 * time was then NaN and the run never ended (or wrote NaN positions with
 * --max-events). The thermal speed sqrt(kT / m) must lie in [1e-100, 1e100],
 * so that squared relative speeds (pred_pp) stay normal doubles. */
#define EV_SPEED_MIN 1e-100
#define EV_SPEED_MAX 1e100

static int ev_speed_check(const ev_params *p, const ev_species *sp, int k, int nsp, char *err, size_t errlen)
{
    const double m = sp->density * ev_particle_volume(p->dim, sp->radius);
    const double v = sqrt(p->kT / m);
    if (m > 0 && v >= EV_SPEED_MIN && v <= EV_SPEED_MAX) return 0;
    char who[48] = "particles";
    if (nsp > 1 || p->species[0]) snprintf(who, sizeof who, "--species kind %d", k + 1);
    return pdla_errorf(-1, err, errlen, "%s: mass %.3g (density %.3g x volume of radius %.3g) gives a thermal "
                       "speed sqrt(kT/m) = %.3g at kT %.3g, outside [%g, %g]", who, m, sp->density,
                       sp->radius, v, p->kT, EV_SPEED_MIN, EV_SPEED_MAX);
}

int ev_params_check(const ev_params *p, char *err, size_t errlen)
{
    const pdla_param_desc *bad;
    if (pdla_param_validate(ev_rows, N_EV_ROWS, p, &bad, err, errlen)) return -1;
    ev_species sp[EV_MAX_SPECIES];
    int nsp;
    if (ev_parse_species(p, sp, &nsp, err, errlen)) return -1;
    uint64_t total = 0, nsticky = 0;
    for (int k = 0; k < nsp; k++) {
        total += sp[k].count;
        if (sp[k].sticky) nsticky += sp[k].count;
    }
    if (total >= UINT32_MAX - 1) return pdla_errorf(-1, err, errlen, "too many particles (%" PRIu64 ")", total);
    for (int k = 0; k < nsp; k++)
        if (ev_speed_check(p, &sp[k], k, nsp, err, errlen)) return -1;
    if (ev_too_big(p->dim, total, err, errlen)) return -1;
    const int seeded = p->seeds[0] || p->seed_radius > 0;
    /* Without a sticky kind nothing can end the run but time or events (a
     * bath alone is a plain gas around the cluster), and --max-stuck could
     * never be reached: both refused, as with no seed. */
    const int endless = p->t_max == 0 && p->max_events == 0;
    if (endless && (!seeded || p->stick_p == 0))
        return pdla_errorf(-1, err, errlen, "nothing sticks (--seed-radius 0 or --stick-p 0): give --t-max or "
                                 "--max-events");
    if (endless && !nsticky)
        return pdla_errorf(-1, err, errlen, "nothing sticks (--species: every kind has STICKY 0): give --t-max or "
                                 "--max-events");
    if (p->max_stuck && !seeded)
        return pdla_errorf(-1, err, errlen, "--max-stuck needs a seed (--seed-radius > 0)");
    if (p->max_stuck && !nsticky)
        return pdla_errorf(-1, err, errlen, "--max-stuck needs a sticky kind (--species: every kind has STICKY 0)");
    return 0;
}
