/*
 * export.c - `pdla export FILE --format ply|csv|xyz -o OUT`: a cluster file
 * for tools that do not read HDF5.
 *
 *   ply  binary little-endian PLY (Blender, MeshLab, ParaView): one vertex
 *        per particle, float x y z and radius in diameters (z = 0 in 2D),
 *        uchar red green blue from the inferno map of the arrival index / N
 *        (files grown with --arrival) or of the distance from the seed / the
 *        largest such distance. Floats hold x / D exactly while |x| < 2^24
 *        units (D is a power of two): 5e5 diameters at D = 32.
 *   csv  a header line, then x,y[,z],distance[,arrival] per particle
 *        (pandas, numpy): lengths in diameters in fixed point with as many
 *        decimals as make x / D exact (5 at D = 32).
 *   xyz  extended XYZ (OVITO, VMD, ASE): the count, a comment line with
 *        Properties=species:S:1:pos:R:3:radius:R:1, then "X x y z 0.5".
 *
 * Memory: positions stream in slabs (h5r_stream) and each slab is formatted
 * in batches of EXP_BATCH rows into one buffer, so memory does not grow with
 * N; PLY colours by distance read the file twice (the largest distance
 * first). OUT is written beside itself and renamed into place on success
 * only (tools_out_*), so a failed export leaves no partial OUT.
 */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "h5read.h"
#include "optcheck.h"
#include "parse.h"
#include "tools.h"

static const char export_help[] =
    "Usage: pdla export FILE --format ply|csv|xyz -o OUT [OPTION]...\n"
    "Write the particles of a pdla cluster file for other programs; lengths in\n"
    "diameters, the seed at the origin, rows in the file's order.\n"
    "\n"
    "  --format ply          binary PLY: float x y z radius, uchar red green blue\n"
    "                        (inferno map of the arrival index, or of the\n"
    "                        distance from the seed) for Blender, MeshLab\n"
    "  --format csv          header x,y[,z],distance[,arrival], one row a particle\n"
    "  --format xyz          extended XYZ for OVITO, VMD, ASE (z = 0 in 2D)\n"
    "                        (without --format: taken from OUT's .ply/.csv/.xyz)\n"
    "  -o, --output OUT      the file to write (required; refused if it exists)\n"
    "  --force               replace an existing OUT\n"
    "  --slab-rows N         rows read at once, 1..65536 (default 65536)\n"
    "  -h, --help            print this help and exit\n"
    "\n"
    "Memory stays under a few MiB for any N: positions are read in slabs.\n"
    "Exit status: 0 done; 1 a read or write failed (OUT is not left behind);\n"
    "2 bad usage or input.\n";

enum { FMT_NONE, FMT_PLY, FMT_CSV, FMT_XYZ };

/* Rows formatted at once: the text buffer is EXP_BATCH * EXP_LINE bytes. */
#define EXP_BATCH 4096u
#define EXP_LINE 160u

/* Same map as `pdla render` (inferno, 33 entries, linear in between). */
static const unsigned char inferno[33][3] = {
    {0, 0, 4},       {4, 3, 18},      {11, 7, 36},     {21, 11, 55},   {33, 12, 74},
    {47, 10, 91},    {61, 9, 101},    {74, 12, 107},   {87, 16, 110},  {100, 21, 110},
    {113, 25, 110},  {125, 30, 109},  {138, 34, 106},  {151, 39, 102}, {163, 44, 97},
    {176, 49, 91},   {188, 55, 84},   {199, 62, 76},   {210, 70, 68},  {219, 80, 59},
    {228, 90, 49},   {235, 102, 40},  {241, 115, 29},  {246, 128, 19}, {249, 142, 9},
    {251, 157, 7},   {252, 172, 17},  {251, 188, 33},  {249, 203, 53}, {245, 219, 76},
    {242, 234, 105}, {243, 246, 138}, {252, 255, 164}};

static void colormap(double t, unsigned char rgb[3])
{
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    const double x = t * 32;
    int i = (int)x;
    if (i > 31) i = 31;
    const double f = x - i;
    for (int c = 0; c < 3; c++) rgb[c] = (unsigned char)lround((1 - f) * inferno[i][c] + f * inferno[i + 1][c]);
}

typedef struct exporter {
    int fmt, dim, arrival;
    uint64_t n;
    double d;           /* units per diameter */
    double rmax;        /* largest distance from the seed, units (PLY colours) */
    int decimals;       /* CSV/XYZ fixed-point decimals */
    int64_t pow10;      /* 10^decimals */
    FILE *fp;
    const char *out;
    char *buf;          /* EXP_BATCH * EXP_LINE bytes */
    char *err;
    size_t errlen;
} exporter;

static int max_pass(const int32_t *xyz, size_t rows, uint64_t first, void *user)
{
    (void)first;
    exporter *const x = user;
    for (size_t i = 0; i < rows; i++) {
        double r2 = 0;
        for (int a = 0; a < x->dim; a++) r2 += (double)xyz[i * (size_t)x->dim + (size_t)a] * xyz[i * (size_t)x->dim + (size_t)a];
        if (r2 > x->rmax * x->rmax) x->rmax = sqrt(r2);
    }
    return 0;
}

/* Fixed point: v / 10^decimals written with exactly `decimals` decimals. */
static char *put_fixed(char *p, int64_t v, int decimals)
{
    if (v < 0) {
        *p++ = '-';
        v = -v;
    }
    char tmp[32];
    int k = 0;
    do {
        tmp[k++] = (char)('0' + v % 10);
        v /= 10;
    } while (v > 0 || k <= decimals);
    while (k > 0) {
        *p++ = tmp[--k];
        if (k == decimals && decimals > 0) *p++ = '.';
    }
    return p;
}

/* x units in diameters, rounded to the nearest 1/10^decimals (exact when
 * D divides 10^decimals, as for every power of two up to 2^9). */
static int64_t units_fixed(const exporter *x, int64_t u)
{
    const int64_t d = (int64_t)x->d;
    const int64_t q = u / d, r = u % d; /* r has u's sign */
    const int64_t s = r * x->pow10, f = s >= 0 ? (s + d / 2) / d : -((-s + d / 2) / d);
    return q * x->pow10 + f;
}

static void put_le32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

static void put_lef(unsigned char *p, float f)
{
    uint32_t v;
    memcpy(&v, &f, sizeof v);
    put_le32(p, v);
}

/* One row into p; returns the end. */
static char *format_row(const exporter *x, const int32_t *q, uint64_t index, char *p)
{
    double r2 = 0;
    for (int a = 0; a < x->dim; a++) r2 += (double)q[a] * q[a];
    const double r = sqrt(r2);
    if (x->fmt == FMT_PLY) {
        unsigned char *const b = (unsigned char *)p;
        for (int a = 0; a < 3; a++) put_lef(b + 4 * a, a < x->dim ? (float)(q[a] / x->d) : 0.0f);
        put_lef(b + 12, 0.5f);
        const double t = x->arrival ? (x->n > 1 ? (double)index / (double)(x->n - 1) : 0)
                                    : (x->rmax > 0 ? r / x->rmax : 0);
        colormap(t, b + 16);
        return p + 19;
    }
    if (x->fmt == FMT_XYZ) {
        *p++ = 'X';
        for (int a = 0; a < 3; a++) {
            *p++ = ' ';
            p = put_fixed(p, a < x->dim ? units_fixed(x, q[a]) : 0, x->decimals);
        }
        memcpy(p, " 0.5\n", 5);
        return p + 5;
    }
    for (int a = 0; a < x->dim; a++) {
        p = put_fixed(p, units_fixed(x, q[a]), x->decimals);
        *p++ = ',';
    }
    p = put_fixed(p, llround(r / x->d * (double)x->pow10), x->decimals);
    if (x->arrival) p += sprintf(p, ",%" PRIu64, index);
    *p++ = '\n';
    return p;
}

static int write_pass(const int32_t *xyz, size_t rows, uint64_t first, void *user)
{
    exporter *const x = user;
    for (size_t i0 = 0; i0 < rows; i0 += EXP_BATCH) {
        const size_t m = rows - i0 < EXP_BATCH ? rows - i0 : EXP_BATCH;
        char *p = x->buf;
        for (size_t i = i0; i < i0 + m; i++) p = format_row(x, xyz + i * (size_t)x->dim, first + i, p);
        const size_t len = (size_t)(p - x->buf);
        if (fwrite(x->buf, 1, len, x->fp) != len) {
            snprintf(x->err, x->errlen, "cannot write %s: %s", x->out, strerror(errno));
            return -1;
        }
    }
    return 0;
}

static int write_header(exporter *x, const char *src)
{
    const char *const slash = strrchr(src, '/');
    const char *const base = slash ? slash + 1 : src;
    int w = 0;
    if (x->fmt == FMT_PLY) {
        /* A PLY comment ends at the line's end: keep the name to one line. */
        char name[256];
        snprintf(name, sizeof name, "%s", base);
        for (char *c = name; *c; c++)
            if (*c == '\n' || *c == '\r') *c = '?';
        w = fprintf(x->fp,
                    "ply\nformat binary_little_endian 1.0\n"
                    "comment pdla export of %s: x y z radius in diameters, colour = inferno(%s)\n"
                    "element vertex %" PRIu64 "\n"
                    "property float x\nproperty float y\nproperty float z\nproperty float radius\n"
                    "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
                    name, x->arrival ? "arrival index / N" : "distance from the seed / largest", x->n);
    } else if (x->fmt == FMT_XYZ) {
        w = fprintf(x->fp, "%" PRIu64 "\nProperties=species:S:1:pos:R:3:radius:R:1 units=diameters dim=%d\n",
                    x->n, x->dim);
    } else {
        w = fprintf(x->fp, "%s,distance%s\n", x->dim == 3 ? "x,y,z" : "x,y", x->arrival ? ",arrival" : "");
    }
    if (w < 0) {
        snprintf(x->err, x->errlen, "cannot write %s: %s", x->out, strerror(errno));
        return -1;
    }
    return 0;
}

static int format_from_name(const char *s)
{
    if (strcmp(s, "ply") == 0) return FMT_PLY;
    if (strcmp(s, "csv") == 0) return FMT_CSV;
    if (strcmp(s, "xyz") == 0) return FMT_XYZ;
    return FMT_NONE;
}

typedef struct export_opts {
    const char *out;
    long slab;
    int fmt, force;
} export_opts;

/* Parses the options into o (the format from --format or the output's
 * ending); GO_ON, or the exit status. */
#define GO_ON (-1)
static int parse_options(int argc, char **argv, export_opts *o)
{
    enum { O_FORMAT = 256, O_FORCE, O_SLAB };
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'}, {"format", required_argument, NULL, O_FORMAT},
        {"force", no_argument, NULL, O_FORCE}, {"slab-rows", required_argument, NULL, O_SLAB},
        {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    int c;
    opterr = 0;
    optind = 1;
    char oerr[160];
    if (optcheck_exact(argc, argv, longopts, "ho:", oerr, sizeof oerr)) {
        fprintf(stderr, "pdla export: %s\n", oerr);
        return TOOL_USAGE;
    }
    while ((c = getopt_long(argc, argv, "ho:", longopts, NULL)) != -1) {
        const char *bad = NULL;
        switch (c) {
        case 'o': o->out = optarg; break;
        case O_FORMAT:
            if ((o->fmt = format_from_name(optarg)) == FMT_NONE) bad = "--format: want ply, csv or xyz";
            break;
        case O_FORCE: o->force = 1; break;
        case O_SLAB:
            if (cli_parse_long_in(optarg, 1, H5R_MAX_SLAB_ROWS, &o->slab))
                bad = "--slab-rows: want a whole number in [1, 65536]";
            break;
        case 'h': fputs(export_help, stdout); return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        default:
            return tools_option_error("export", argv, optind, optopt);
        }
        if (bad) return tools_value_error("export", optarg, bad);
    }
    if (tools_one_file("export", optind, argc)) return TOOL_USAGE;
    if (!o->out) {
        fprintf(stderr, "pdla export: no output given (-o OUT)\n");
        return TOOL_USAGE;
    }
    if (o->fmt == FMT_NONE) {
        const char *const dot = strrchr(o->out, '.');
        if (!dot || (o->fmt = format_from_name(dot + 1)) == FMT_NONE) {
            fprintf(stderr, "pdla export: no --format given and %s does not end in .ply, .csv or .xyz\n", o->out);
            return TOOL_USAGE;
        }
    }
    return GO_ON;
}

int tool_export(int argc, char **argv)
{
    export_opts o = {NULL, H5R_MAX_SLAB_ROWS, FMT_NONE, 0};
    const int prc = parse_options(argc, argv, &o);
    if (prc != GO_ON) return prc;
    const char *const out = o.out;
    const long slab = o.slab;
    const int fmt = o.fmt, force = o.force;
    char err[1024];
    if (tools_out_check(out, force, err, sizeof err)) {
        fprintf(stderr, "pdla export: %s\n", err);
        return TOOL_USAGE;
    }
    h5r_file f;
    if (h5r_open(&f, argv[optind], err, sizeof err)) {
        fprintf(stderr, "pdla export: %s\n", err);
        return TOOL_USAGE;
    }
    exporter x;
    memset(&x, 0, sizeof x);
    x.fmt = fmt;
    x.dim = f.dim;
    x.arrival = f.arrival;
    x.n = f.n;
    x.d = f.diameter_units;
    x.out = out;
    x.err = err;
    x.errlen = sizeof err;
    /* Fewest decimals that make x / D exact, else 6 (rounded). */
    x.decimals = 6;
    x.pow10 = 1000000;
    for (int64_t k = 0, p = 1; k <= 9; k++, p *= 10)
        if (p % f.diameter_units == 0) {
            x.decimals = (int)k;
            x.pow10 = p;
            break;
        }
    int rc = TOOL_RUNTIME;
    char tmp[4300];
    if (!(x.buf = malloc((size_t)EXP_BATCH * EXP_LINE))) {
        snprintf(err, sizeof err, "out of memory for the text buffer");
        goto out;
    }
    if (fmt == FMT_PLY && !x.arrival && h5r_stream(&f, (size_t)slab, max_pass, &x, err, sizeof err))
        goto out;
    if (!(x.fp = tools_out_open(out, tmp, sizeof tmp, err, sizeof err))) goto out;
    if (write_header(&x, f.path) || h5r_stream(&f, (size_t)slab, write_pass, &x, err, sizeof err))
        goto out;
    const int crc = tools_out_commit(x.fp, tmp, out, force, err, sizeof err);
    x.fp = NULL;
    if (crc) goto out;
    rc = TOOL_OK;
out:
    if (x.fp) tools_out_abort(x.fp, tmp);
    if (rc != TOOL_OK) fprintf(stderr, "pdla export: %s\n", err);
    free(x.buf);
    h5r_close(&f);
    return rc;
}
