/*
 * render.c - `pdla render FILE -o PNG`: a picture of a cluster.
 *
 * 2D: the plane; 3D: a projection along --axis, shaded by depth (the
 * particle nearest the viewer in a pixel sets its brightness). Colour is
 * the inferno map (a 33-entry table, linearly interpolated) of
 *   density  log(1 + particles per pixel), normalised to the densest pixel;
 *   radius   distance from the seed / (R_ext / zoom), averaged over the
 *            pixel in 2D, of the particle nearest the viewer in 3D;
 *   arrival  arrival index / N (files written with `pdla --arrival`);
 *   depth    (3D) distance towards the viewer.
 * Particles smaller than a pixel are deposited bilinearly (anti-aliased
 * points); once a particle spans a pixel or more (large --size or --zoom),
 * each is an anti-aliased disc of its diameter.
 *
 * Memory: positions stream in hyperslabs of --slab-rows (<= 65536) rows, in
 * two passes (extent, then splats); the only image-sized state is one to
 * three float buffers (4..12 bytes a pixel). The PNG (8-bit RGB, no time
 * stamp) is written row by row and is byte-identical for the same input
 * and options.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dlca_cmd.h"
#include "h5read.h"
#include "parse.h"
#include "png_out.h"
#include "tools.h"

static const char render_help[] =
    "Usage: pdla render FILE -o PNG [OPTION]...\n"
    "Draw a pdla cluster file as a PNG picture: 2D clusters as they are, 3D\n"
    "clusters projected along an axis with depth shading. Positions are read in\n"
    "slabs, so any size of cluster renders in memory set by the image size.\n"
    "\n"
    "  -o, --output PNG      the picture to write (required; refused if it exists)\n"
    "  --size N              width = height in pixels, 16..8192 (default 1024)\n"
    "  --color MODE          density: log of particles per pixel (default);\n"
    "                        radius: distance from the seed (up to R_ext, or the\n"
    "                        picture's corner when zoomed); arrival: arrival\n"
    "                        order (files grown with --arrival); depth: 3D,\n"
    "                        distance towards the viewer\n"
    "  --axis x|y|z          3D: the axis looked along (default z)\n"
    "  --zoom F              F > 1: magnify F times around the seed (default 1:\n"
    "                        the whole cluster)\n"
    "  --force               replace an existing PNG\n"
    "  --slab-rows N         rows read at once, 1..65536 (default 65536)\n"
    "  -h, --help            print this help and exit\n"
    "\n"
    "Memory: 4 bytes per pixel for density, 8 for radius and arrival, 4 more in\n"
    "3D (size 2048: 16 to 48 MiB), plus one slab of positions.\n"
    "Exit status: 0 done; 1 a read or write failed; 2 bad usage or input.\n";

static const unsigned char inferno[33][3] = {
    {0, 0, 4},       {4, 3, 18},      {11, 7, 36},     {21, 11, 55},   {33, 12, 74},
    {47, 10, 91},    {61, 9, 101},    {74, 12, 107},   {87, 16, 110},  {100, 21, 110},
    {113, 25, 110},  {125, 30, 109},  {138, 34, 106},  {151, 39, 102}, {163, 44, 97},
    {176, 49, 91},   {188, 55, 84},   {199, 62, 76},   {210, 70, 68},  {219, 80, 59},
    {228, 90, 49},   {235, 102, 40},  {241, 115, 29},  {246, 128, 19}, {249, 142, 9},
    {251, 157, 7},   {252, 172, 17},  {251, 188, 33},  {249, 203, 53}, {245, 219, 76},
    {242, 234, 105}, {243, 246, 138}, {252, 255, 164}};

static void colormap(double t, double rgb[3])
{
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    const double x = t * 32;
    int i = (int)x;
    if (i > 31) i = 31;
    const double f = x - i;
    for (int c = 0; c < 3; c++) rgb[c] = (1 - f) * inferno[i][c] + f * inferno[i + 1][c];
}

enum { COL_DENSITY, COL_RADIUS, COL_ARRIVAL, COL_DEPTH };

typedef struct canvas {
    int dim, size, mode;
    int iu, iv, id;         /* coordinate indices of image x, image y, depth */
    uint64_t n;
    /* pass 1 */
    double lo[3], hi[3], rmax2;
    /* mapping */
    double cu, cv, scale;   /* image centre (units), pixels per unit */
    double rnorm;           /* radius that maps to the top of the colour map */
    double rp;              /* particle radius in pixels */
    double dlo, dspan;      /* depth range, units */
    float *w, *v, *z;       /* coverage, coverage x value, front depth (3D) */
} canvas;

static int extent_pass(const int32_t *xyz, size_t rows, uint64_t first, void *user)
{
    (void)first;
    canvas *const c = user;
    for (size_t i = 0; i < rows; i++) {
        const int32_t *const p = xyz + i * (size_t)c->dim;
        double r2 = 0;
        for (int a = 0; a < c->dim; a++) {
            if (p[a] < c->lo[a]) c->lo[a] = p[a];
            if (p[a] > c->hi[a]) c->hi[a] = p[a];
            r2 += (double)p[a] * p[a];
        }
        if (r2 > c->rmax2) c->rmax2 = r2;
    }
    return 0;
}

static inline void deposit(canvas *c, int x, int y, float cov, float val, float depth)
{
    if (x < 0 || y < 0 || x >= c->size || y >= c->size || cov <= 0) return;
    const size_t k = (size_t)y * (size_t)c->size + (size_t)x;
    c->w[k] += cov;
    if (c->z) {
        /* 3D: the particle nearest the viewer gives the pixel its value. */
        if (depth > c->z[k]) {
            c->z[k] = depth;
            if (c->v) c->v[k] = val;
        }
    } else if (c->v) {
        c->v[k] += cov * val;
    }
}

static int splat_pass(const int32_t *xyz, size_t rows, uint64_t first, void *user)
{
    canvas *const c = user;
    const double half = 0.5 * c->size;
    const double rmax = c->rnorm > 0 ? c->rnorm : 1;
    for (size_t i = 0; i < rows; i++) {
        const int32_t *const p = xyz + i * (size_t)c->dim;
        const double px = (p[c->iu] - c->cu) * c->scale + half;
        const double py = half - (p[c->iv] - c->cv) * c->scale;
        if (px < -c->rp - 2 || py < -c->rp - 2 || px > c->size + c->rp + 2 ||
            py > c->size + c->rp + 2)
            continue;
        float depth = 1.0f;
        if (c->dim == 3) depth = (float)(c->dspan > 0 ? (p[c->id] - c->dlo) / c->dspan : 1.0);
        float val = 0;
        switch (c->mode) {
        case COL_RADIUS: {
            double r2 = 0;
            for (int a = 0; a < c->dim; a++) r2 += (double)p[a] * p[a];
            val = (float)fmin(1.0, sqrt(r2) / rmax);
            break;
        }
        case COL_ARRIVAL: val = c->n > 1 ? (float)((double)(first + i) / (double)(c->n - 1)) : 0; break;
        case COL_DEPTH: val = depth; break;
        default: break;
        }
        if (c->rp < 0.75) {
            /* A point: bilinear weights over the four nearest pixel centres. */
            const double fx = px - 0.5, fy = py - 0.5;
            const int x0 = (int)floor(fx), y0 = (int)floor(fy);
            const float ax = (float)(fx - x0), ay = (float)(fy - y0);
            deposit(c, x0, y0, (1 - ax) * (1 - ay), val, depth);
            deposit(c, x0 + 1, y0, ax * (1 - ay), val, depth);
            deposit(c, x0, y0 + 1, (1 - ax) * ay, val, depth);
            deposit(c, x0 + 1, y0 + 1, ax * ay, val, depth);
        } else {
            /* A disc: coverage ~ how far a pixel centre lies inside the rim. */
            /* Clipped to the picture, in double before narrowing: zoomed in,
             * a disc may be far wider than the image (or lie far outside). */
            const double last = c->size - 1;
            const int x0 = (int)fmax(0, floor(px - c->rp - 1)), x1 = (int)fmin(last, ceil(px + c->rp + 1));
            const int y0 = (int)fmax(0, floor(py - c->rp - 1)), y1 = (int)fmin(last, ceil(py + c->rp + 1));
            for (int y = y0; y <= y1; y++)
                for (int x = x0; x <= x1; x++) {
                    const double dx = x + 0.5 - px, dy = y + 0.5 - py;
                    double cov = c->rp + 0.5 - sqrt(dx * dx + dy * dy);
                    if (cov <= 0) continue;
                    if (cov > 1) cov = 1;
                    deposit(c, x, y, (float)cov, val, depth);
                }
        }
    }
    return 0;
}

static int write_png(FILE *fp, const canvas *c, char *err, size_t errlen)
{
    /* libpng's own handlers print to stderr; ours keep the message for
     * the one line pdla prints (with errno: a failed write sets it). */
    static char png_msg[160];
    png_msg[0] = '\0';
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, png_msg, tools_png_error, tools_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    unsigned char *row = malloc((size_t)c->size * 3);
    if (!png || !info || !row) {
        png_destroy_write_struct(&png, &info);
        free(row);
        snprintf(err, errlen, "out of memory for the PNG writer");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(row);
        snprintf(err, errlen, "libpng could not write the picture%s%s", png_msg[0] ? ": " : "", png_msg);
        return -1;
    }
    const size_t npix = (size_t)c->size * (size_t)c->size;
    float wmax = 0;
    for (size_t k = 0; k < npix; k++)
        if (c->w[k] > wmax) wmax = c->w[k];
    const double lnorm = wmax > 0 ? 1.0 / log1p(wmax) : 0;
    errno = 0; /* so that a write error names its own cause */
    png_init_io(png, fp);
    png_set_IHDR(png, info, (png_uint_32)c->size, (png_uint_32)c->size, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < c->size; y++) {
        for (int x = 0; x < c->size; x++) {
            const size_t k = (size_t)y * (size_t)c->size + (size_t)x;
            const double w = c->w[k];
            double rgb[3];
            if (c->mode == COL_DENSITY) {
                colormap(log1p(w) * lnorm, rgb);
            } else {
                /* Hue from the mean value; coverage fades it into the background. */
                const double q = c->z ? c->v[k] : w > 0 ? c->v[k] / w : 0;
                const double alpha = w >= 1 ? 1 : w;
                double bg[3];
                colormap(0, bg);
                colormap(0.2 + 0.8 * q, rgb);
                for (int j = 0; j < 3; j++) rgb[j] = bg[j] + alpha * (rgb[j] - bg[j]);
            }
            if (c->z && c->z[k] >= 0) {
                const double shade = 0.3 + 0.7 * c->z[k];
                for (int j = 0; j < 3; j++) rgb[j] *= shade;
            }
            for (int j = 0; j < 3; j++) row[3 * (size_t)x + (size_t)j] = (unsigned char)lround(rgb[j]);
        }
        png_write_row(png, row);
    }
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    free(row);
    return 0;
}

typedef struct render_opts {
    const char *out;
    long size, slab;
    int mode, axis, force;
    double zoom;
} render_opts;

/* Parses the options into o; GO_ON, or the exit status (--help, a bad
 * option or value, not exactly one FILE, no -o). */
#define GO_ON (-1)
static int parse_options(int argc, char **argv, render_opts *o)
{
    if (dlca_tool_file(argc, argv)) return dlca_render_main(argc, argv); /* model dlca: dlca_tools.c */
    enum { O_SIZE = 256, O_COLOR, O_AXIS, O_ZOOM, O_FORCE, O_SLAB };
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'}, {"size", required_argument, NULL, O_SIZE},
        {"color", required_argument, NULL, O_COLOR}, {"colour", required_argument, NULL, O_COLOR},
        {"axis", required_argument, NULL, O_AXIS}, {"zoom", required_argument, NULL, O_ZOOM},
        {"force", no_argument, NULL, O_FORCE}, {"slab-rows", required_argument, NULL, O_SLAB},
        {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    int c;
    if (tools_options_begin("render", argc, argv, longopts, "ho:")) return TOOL_USAGE;
    while ((c = getopt_long(argc, argv, "ho:", longopts, NULL)) != -1) {
        const char *bad = NULL;
        switch (c) {
        case 'o': o->out = optarg; break;
        case O_SIZE:
            if (cli_parse_long_in(optarg, 16, 8192, &o->size)) bad = "--size: want a whole number in [16, 8192]";
            break;
        case O_COLOR:
            if (strcmp(optarg, "density") == 0) o->mode = COL_DENSITY;
            else if (strcmp(optarg, "radius") == 0) o->mode = COL_RADIUS;
            else if (strcmp(optarg, "arrival") == 0) o->mode = COL_ARRIVAL;
            else if (strcmp(optarg, "depth") == 0) o->mode = COL_DEPTH;
            else bad = "--color: want density, radius, arrival or depth";
            break;
        case O_AXIS:
            if (strlen(optarg) == 1 && optarg[0] >= 'x' && optarg[0] <= 'z') o->axis = optarg[0] - 'x';
            else bad = "--axis: want x, y or z";
            break;
        case O_ZOOM:
            if (cli_parse_real(optarg, &o->zoom) || !(o->zoom >= 1 && o->zoom <= 1e6))
                bad = "--zoom: want a number in [1, 1e6]";
            break;
        case O_FORCE: o->force = 1; break;
        case O_SLAB:
            if (cli_parse_long_in(optarg, 1, H5R_MAX_SLAB_ROWS, &o->slab)) bad = "--slab-rows: want a whole number in [1, 65536]";
            break;
        case 'h': fputs(render_help, stdout); return fflush(stdout) ? TOOL_RUNTIME : TOOL_OK;
        default:
            return tools_option_error("render", argv, optind, optopt);
        }
        if (bad) return tools_value_error("render", optarg, bad);
    }
    if (tools_one_file("render", optind, argc)) return TOOL_USAGE;
    if (!o->out) {
        fprintf(stderr, "pdla render: no output given (-o PNG)\n");
        return TOOL_USAGE;
    }
    return GO_ON;
}

/* After the extent pass: the image axes (2D x right, y up; 3D looking down
 * the chosen axis), the centre and the scale. The whole cluster, centred
 * on its bounding box; zoomed, centred on the seed, and radius colours
 * then span what the picture shows. */
static void frame(canvas *cv, const h5r_file *f, const render_opts *o)
{
    if (f->n == 0)
        for (int a = 0; a < 3; a++) cv->lo[a] = cv->hi[a] = 0;
    static const int uv[3][3] = {{1, 2, 0}, {0, 2, 1}, {0, 1, 2}};
    if (f->dim == 2) {
        cv->iu = 0;
        cv->iv = 1;
        cv->id = 0;
    } else {
        cv->iu = uv[o->axis][0];
        cv->iv = uv[o->axis][1];
        cv->id = uv[o->axis][2];
        cv->dlo = cv->lo[cv->id];
        cv->dspan = cv->hi[cv->id] - cv->lo[cv->id];
    }
    const double D = f->diameter_units;
    double halfw = 0.5 * fmax(cv->hi[cv->iu] - cv->lo[cv->iu], cv->hi[cv->iv] - cv->lo[cv->iv]) + D;
    cv->rnorm = sqrt(cv->rmax2);
    if (o->zoom > 1) {
        halfw /= o->zoom;
        cv->cu = cv->cv = 0;
        cv->rnorm = fmin(cv->rnorm, halfw * sqrt(2.0));
    } else {
        cv->cu = 0.5 * (cv->lo[cv->iu] + cv->hi[cv->iu]);
        cv->cv = 0.5 * (cv->lo[cv->iv] + cv->hi[cv->iv]);
    }
    cv->scale = 0.5 * cv->size / halfw;
    cv->rp = 0.5 * D * cv->scale;
}

/* Whether n balls of diameter D (units) fit the positions' bounding box
 * widened by D without overlapping (volume at most the box's): a cluster
 * pdla grew always does, and this bounds the drawing's work, which grows
 * with the pixels each disc covers (2e5 forged rows at one spot, or a
 * forged diameter of 2^20 units, drew for minutes to days). */
static int fits_box(const canvas *cv, double D)
{
    double box = 1, ball = cv->dim == 2 ? M_PI / 4 * D * D : M_PI / 6 * D * D * D;
    for (int a = 0; a < cv->dim; a++) box *= cv->hi[a] - cv->lo[a] + D;
    return (double)cv->n * ball <= box * (1 + 1e-9);
}

/* The pixel arrays the colour mode needs; -1: out of memory. */
static int alloc_image(canvas *cv)
{
    const size_t npix = (size_t)cv->size * (size_t)cv->size;
    cv->w = calloc(npix, sizeof *cv->w);
    if (cv->mode != COL_DENSITY) cv->v = calloc(npix, sizeof *cv->v);
    if (cv->dim == 3 && (cv->z = malloc(npix * sizeof *cv->z)))
        for (size_t k = 0; k < npix; k++) cv->z[k] = -1; /* below every depth */
    return !cv->w || (cv->mode != COL_DENSITY && !cv->v) || (cv->dim == 3 && !cv->z) ? -1 : 0;
}

int tool_render(int argc, char **argv)
{
    render_opts o = {NULL, 1024, H5R_MAX_SLAB_ROWS, COL_DENSITY, 2, 0, 1};
    int rc = parse_options(argc, argv, &o);
    if (rc != GO_ON) return rc;
    char err[1024];
    if (tools_out_check(o.out, argv[optind], o.force, err, sizeof err)) {
        fprintf(stderr, "pdla render: %s\n", err);
        return TOOL_USAGE;
    }
    h5r_file f;
    if (h5r_open(&f, argv[optind], err, sizeof err)) {
        fprintf(stderr, "pdla render: %s\n", err);
        return TOOL_USAGE;
    }
    rc = TOOL_USAGE;
    FILE *fp = NULL;
    char tmp[4300];
    canvas cv;
    memset(&cv, 0, sizeof cv);
    cv.dim = f.dim;
    cv.size = (int)o.size;
    cv.mode = o.mode;
    cv.n = f.n;
    if (o.mode == COL_ARRIVAL && !f.arrival) {
        snprintf(err, sizeof err, "%s has positions in %s order, not arrival order (grow it with --arrival)",
                 f.path, f.order);
        goto out;
    }
    if (o.mode == COL_DEPTH && f.dim != 3) {
        snprintf(err, sizeof err, "--color depth needs a 3D cluster; %s is 2D", f.path);
        goto out;
    }
    rc = TOOL_RUNTIME;
    for (int a = 0; a < 3; a++) {
        cv.lo[a] = INFINITY;
        cv.hi[a] = -INFINITY;
    }
    if (f.n > 0 && h5r_stream(&f, (size_t)o.slab, extent_pass, &cv, err, sizeof err)) goto out;
    if (f.n > 1 && !fits_box(&cv, f.diameter_units)) {
        snprintf(err, sizeof err, "%s: %llu particles of diameter %d units overlap (more volume than "
                 "their bounding box holds); not a cluster pdla grew", f.path, (unsigned long long)f.n,
                 f.diameter_units);
        rc = TOOL_USAGE; /* bad input, as a malformed file at opening */
        goto out;
    }
    frame(&cv, &f, &o);
    if (alloc_image(&cv)) {
        snprintf(err, sizeof err, "out of memory for a %dx%d image", cv.size, cv.size);
        goto out;
    }
    if (f.n > 0 && h5r_stream(&f, (size_t)o.slab, splat_pass, &cv, err, sizeof err)) goto out;
    if (!(fp = tools_out_open(o.out, tmp, sizeof tmp, err, sizeof err))) goto out;
    if (write_png(fp, &cv, err, sizeof err)) goto out;
    const int crc = tools_out_commit(fp, tmp, o.out, o.force, err, sizeof err);
    fp = NULL;
    if (crc) goto out;
    rc = TOOL_OK;
out:
    if (fp) tools_out_abort(fp, tmp);
    if (rc != TOOL_OK) fprintf(stderr, "pdla render: %s\n", err);
    free(cv.w);
    free(cv.v);
    free(cv.z);
    return h5r_close_tool(&f, "render", rc);
}
