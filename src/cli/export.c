/*
 * export.c - `pdla export FILE --format ply|csv|xyz -o OUT`: the particles
 * of any pdla output for tools that do not read HDF5. FILE is a DLA
 * cluster.h5, an ensemble.h5 with kept positions (all clusters with a
 * cluster column, or one with --cluster I), or a DLCA or event-driven
 * cluster.h5 (export_src.h says what is read from each).
 *
 *   ply  binary little-endian PLY (Blender, MeshLab, ParaView): one vertex
 *        per particle, float x y z and radius (z = 0 in 2D), uchar red green
 *        blue from the inferno map of the arrival index / (N - 1) (rows in
 *        arrival order), of the cluster id / the largest (DLCA), else of the
 *        distance from the seed / the largest such distance; `uint cluster`
 *        when the file has clusters. Floats hold x / D exactly while
 *        |x| < 2^24 units (D is a power of two): 5e5 diameters at D = 32.
 *   csv  a header line, then x,y[,z][,distance][,radius][,arrival][,cluster]
 *        per particle (pandas, numpy): integer lengths in fixed point with as
 *        many decimals as make x / D exact (5 at D = 32), real ones (event)
 *        with 17 significant digits (exact as doubles).
 *   xyz  extended XYZ (OVITO, VMD, ASE): the count, a comment line with
 *        Properties=species:S:1:pos:R:3:radius:R:1[:cluster:I:1], then
 *        "X x y z radius[ cluster]".
 * Lengths: diameters (DLA, ensemble), lattice sites (DLCA), the model's
 * length (event); the header or comment says which.
 *
 * Memory: rows stream in slabs (exp_src_stream) and each slab is formatted
 * in batches of EXP_BATCH rows into one buffer, so memory does not grow with
 * N; PLY colours by distance or cluster read the file twice (the largest
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

#include "export_src.h"
#include "h5read.h"
#include "parse.h"
#include "tools.h"

static const char export_help[] =
    "Usage: pdla export FILE --format ply|csv|xyz -o OUT [OPTION]...\n"
    "Write the particles of a pdla file for other programs, rows in the file's\n"
    "order: a DLA cluster.h5 (lengths in diameters, the seed at the origin), an\n"
    "ensemble.h5 grown with --keep-positions (every cluster, with a cluster\n"
    "column, or one with --cluster I), a DLCA cluster.h5 (lattice sites, with\n"
    "the cluster of each monomer) or an event-model cluster.h5 (the stuck\n"
    "particles in the model's length, with their radii).\n"
    "\n"
    "  --format ply          binary PLY: float x y z radius, uchar red green blue\n"
    "                        (inferno map of the arrival index, or of the\n"
    "                        distance from the seed) for Blender, MeshLab\n"
    "  --format csv          header x,y[,z][,distance][,radius][,arrival][,cluster],\n"
    "                        one row a particle\n"
    "  --format xyz          extended XYZ for OVITO, VMD, ASE (z = 0 in 2D)\n"
    "                        (without --format: taken from OUT's .ply/.csv/.xyz)\n"
    "  -o, --output OUT      the file to write (required; refused if it exists)\n"
    "  --force               replace an existing OUT\n"
    "  --cluster I           ensemble files: only cluster I (0..M-1)\n"
    "  --slab-rows N         rows read at once, 1..65536 (default 65536)\n"
    "  -h, --help            print this help and exit\n"
    "\n"
    "Memory stays under a few MiB for any N: positions are read in slabs.\n"
    "Exit status: 0 done; 1 a read or write failed (OUT is not left behind);\n"
    "2 bad usage or input.\n";

enum { FMT_NONE, FMT_PLY, FMT_CSV, FMT_XYZ };

/* Rows formatted at once: the text buffer is EXP_BATCH * EXP_LINE bytes. */
#define EXP_BATCH 4096u
#define EXP_LINE 256u

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
    int fmt, dim;
    const exp_src *src;
    uint64_t n;         /* rows exported */
    uint64_t span;      /* arrival indices run 0..span-1 (rows per cluster) */
    double d;           /* file units per output length unit */
    double rmax;        /* largest distance from the seed, file units (PLY colours) */
    uint64_t cmax;      /* largest cluster id (PLY colours of DLCA) */
    int colour;         /* COL_* */
    int decimals;       /* CSV/XYZ fixed-point decimals */
    int64_t pow10;      /* 10^decimals */
    FILE *fp;
    const char *out;
    char *buf;          /* EXP_BATCH * EXP_LINE bytes */
    char *err;
    size_t errlen;
} exporter;

enum { COL_ARRIVAL, COL_CLUSTER, COL_DISTANCE };

static int max_pass(const exp_slab *sl, void *user)
{
    exporter *const x = user;
    const size_t dim = (size_t)x->dim;
    for (size_t i = 0; i < sl->rows; i++) {
        double r2 = 0;
        for (size_t a = 0; a < dim; a++) {
            const double v = sl->q ? (double)sl->q[i * dim + a] : sl->f[i * dim + a];
            r2 += v * v;
        }
        if (r2 > x->rmax * x->rmax) x->rmax = sqrt(r2);
        if (sl->cluster && sl->cluster[i] > x->cmax) x->cmax = sl->cluster[i];
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

/* Coordinate a of row i: fixed point of the units (int positions) or
 * %.17g of the real ones. */
static char *put_coord(const exporter *x, const exp_slab *sl, size_t i, int a, char *p)
{
    if (a >= x->dim) return sl->q ? put_fixed(p, 0, x->decimals) : p + sprintf(p, "0");
    if (sl->q) return put_fixed(p, units_fixed(x, sl->q[i * (size_t)x->dim + (size_t)a]), x->decimals);
    return p + sprintf(p, "%.17g", sl->f[i * (size_t)x->dim + (size_t)a]);
}

static double coord(const exporter *x, const exp_slab *sl, size_t i, int a)
{
    return sl->q ? (double)sl->q[i * (size_t)x->dim + (size_t)a] : sl->f[i * (size_t)x->dim + (size_t)a];
}

/* Row i of the slab into p; returns the end. */
static char *format_row(const exporter *x, const exp_slab *sl, size_t i, char *p)
{
    const exp_src *const s = x->src;
    double r2 = 0;
    for (int a = 0; a < x->dim; a++) r2 += coord(x, sl, i, a) * coord(x, sl, i, a);
    const double r = sqrt(r2);
    if (x->fmt == FMT_PLY) {
        unsigned char *const b = (unsigned char *)p;
        for (int a = 0; a < 3; a++) put_lef(b + 4 * a, a < x->dim ? (float)(coord(x, sl, i, a) / x->d) : 0.0f);
        put_lef(b + 12, sl->radius ? (float)sl->radius[i] : 0.5f);
        const double t = x->colour == COL_ARRIVAL ? (x->span > 1 ? (double)sl->index[i] / (double)(x->span - 1) : 0)
                         : x->colour == COL_CLUSTER ? (x->cmax > 0 ? (double)sl->cluster[i] / (double)x->cmax : 0)
                                                    : (x->rmax > 0 ? r / x->rmax : 0);
        colormap(t, b + 16);
        if (!s->cluster_col) return p + 19;
        put_le32(b + 19, (uint32_t)sl->cluster[i]);
        return p + 23;
    }
    if (x->fmt == FMT_XYZ) {
        *p++ = 'X';
        for (int a = 0; a < 3; a++) {
            *p++ = ' ';
            p = put_coord(x, sl, i, a, p);
        }
        if (sl->radius) p += sprintf(p, " %.17g", sl->radius[i]);
        else p += sprintf(p, " 0.5");
        if (s->cluster_col) p += sprintf(p, " %" PRIu64, sl->cluster[i]);
        *p++ = '\n';
        return p;
    }
    for (int a = 0; a < x->dim; a++) {
        if (a) *p++ = ',';
        p = put_coord(x, sl, i, a, p);
    }
    if (s->distance) {
        *p++ = ',';
        p = put_fixed(p, llround(r / x->d * (double)x->pow10), x->decimals);
    }
    if (sl->radius) p += sprintf(p, ",%.17g", sl->radius[i]);
    if (s->arrival) p += sprintf(p, ",%" PRIu64, sl->index[i]);
    if (s->cluster_col) p += sprintf(p, ",%" PRIu64, sl->cluster[i]);
    *p++ = '\n';
    return p;
}

static int write_pass(const exp_slab *sl, void *user)
{
    exporter *const x = user;
    for (size_t i0 = 0; i0 < sl->rows; i0 += EXP_BATCH) {
        const size_t m = sl->rows - i0 < EXP_BATCH ? sl->rows - i0 : EXP_BATCH;
        char *p = x->buf;
        for (size_t i = i0; i < i0 + m; i++) p = format_row(x, sl, i, p);
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
    const exp_src *const s = x->src;
    const char *const slash = strrchr(src, '/');
    const char *const base = slash ? slash + 1 : src;
    int w = 0;
    if (x->fmt == FMT_PLY) {
        /* A PLY comment ends at the line's end: keep the name to one line. */
        char name[256];
        snprintf(name, sizeof name, "%s", base);
        for (char *c = name; *c; c++)
            if (*c == '\n' || *c == '\r') *c = '?';
        const char *const by = x->colour == COL_ARRIVAL   ? "arrival index / N"
                               : x->colour == COL_CLUSTER ? "cluster id / largest"
                                                          : "distance from the seed / largest";
        w = fprintf(x->fp,
                    "ply\nformat binary_little_endian 1.0\n"
                    "comment pdla export of %s: x y z radius in %s, colour = inferno(%s)\n"
                    "element vertex %" PRIu64 "\n"
                    "property float x\nproperty float y\nproperty float z\nproperty float radius\n"
                    "property uchar red\nproperty uchar green\nproperty uchar blue\n%send_header\n",
                    name, s->unit_name, by, x->n, s->cluster_col ? "property uint cluster\n" : "");
    } else if (x->fmt == FMT_XYZ) {
        const int q = strchr(s->unit_name, ' ') != NULL;
        w = fprintf(x->fp, "%" PRIu64 "\nProperties=species:S:1:pos:R:3:radius:R:1%s units=%s%s%s dim=%d\n", x->n,
                    s->cluster_col ? ":cluster:I:1" : "", q ? "\"" : "", s->unit_name, q ? "\"" : "", x->dim);
    } else {
        w = fprintf(x->fp, "%s%s%s%s%s\n", x->dim == 3 ? "x,y,z" : "x,y", s->distance ? ",distance" : "",
                    s->radius.id >= 0 ? ",radius" : "", s->arrival ? ",arrival" : "",
                    s->cluster_col ? ",cluster" : "");
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
    long cluster; /* --cluster I, or -1 */
} export_opts;

/* Parses the options into o (the format from --format or the output's
 * ending); GO_ON, or the exit status. */
#define GO_ON (-1)
static int parse_options(int argc, char **argv, export_opts *o)
{
    enum { O_FORMAT = 256, O_FORCE, O_SLAB, O_CLUSTER };
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'}, {"format", required_argument, NULL, O_FORMAT},
        {"force", no_argument, NULL, O_FORCE}, {"slab-rows", required_argument, NULL, O_SLAB},
        {"cluster", required_argument, NULL, O_CLUSTER}, {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    int c;
    if (tools_options_begin("export", argc, argv, longopts, "ho:")) return TOOL_USAGE;
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
        case O_CLUSTER:
            if (cli_parse_long_in(optarg, 0, INT32_MAX, &o->cluster))
                bad = "--cluster: want a cluster index 0..M-1";
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

/* The fewest decimals that make x / d exact, else 6 (rounded). */
static void set_decimals(exporter *x, int64_t d)
{
    x->decimals = 6;
    x->pow10 = 1000000;
    for (int64_t k = 0, p = 1; k <= 9; k++, p *= 10)
        if (p % d == 0) {
            x->decimals = (int)k;
            x->pow10 = p;
            return;
        }
}

/* The rows of src into out (opened here, committed on success). */
static int export_rows(exporter *x, exp_src *src, long slab, int force)
{
    char tmp[4300];
    if (!(x->buf = malloc((size_t)EXP_BATCH * EXP_LINE))) {
        snprintf(x->err, x->errlen, "out of memory for the text buffer");
        return -1;
    }
    if (x->fmt == FMT_PLY && x->colour != COL_ARRIVAL &&
        exp_src_stream(src, (size_t)slab, max_pass, x, x->err, x->errlen))
        return -1;
    if (!(x->fp = tools_out_open(x->out, tmp, sizeof tmp, x->err, x->errlen))) return -1;
    if (write_header(x, src->path) || exp_src_stream(src, (size_t)slab, write_pass, x, x->err, x->errlen)) {
        tools_out_abort(x->fp, tmp);
        x->fp = NULL;
        return -1;
    }
    const int crc = tools_out_commit(x->fp, tmp, x->out, force, x->err, x->errlen);
    x->fp = NULL;
    return crc ? -1 : 0;
}

int tool_export(int argc, char **argv)
{
    export_opts o = {NULL, H5R_MAX_SLAB_ROWS, FMT_NONE, 0, -1};
    const int prc = parse_options(argc, argv, &o);
    if (prc != GO_ON) return prc;
    char err[1024];
    if (tools_out_check(o.out, argv[optind], o.force, err, sizeof err)) {
        fprintf(stderr, "pdla export: %s\n", err);
        return TOOL_USAGE;
    }
    exp_src src;
    if (exp_src_open(&src, argv[optind], o.cluster, err, sizeof err)) {
        fprintf(stderr, "pdla export: %s\n", err);
        return TOOL_USAGE;
    }
    exporter x;
    memset(&x, 0, sizeof x);
    x.fmt = o.fmt;
    x.src = &src;
    x.dim = src.dim;
    x.n = src.n;
    x.span = src.per_cluster ? src.per_cluster : src.n;
    x.d = src.units;
    x.colour = src.arrival ? COL_ARRIVAL : src.kind == EXP_DLCA ? COL_CLUSTER : COL_DISTANCE;
    x.out = o.out;
    x.err = err;
    x.errlen = sizeof err;
    set_decimals(&x, src.units);
    int rc = export_rows(&x, &src, o.slab, o.force) ? TOOL_RUNTIME : TOOL_OK;
    if (rc != TOOL_OK) fprintf(stderr, "pdla export: %s\n", err);
    free(x.buf);
    if (exp_src_close(&src) && rc == TOOL_OK) {
        fprintf(stderr, "pdla export: %s: cannot close it\n", src.path);
        rc = TOOL_RUNTIME;
    }
    return rc;
}
