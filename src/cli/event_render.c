/*
 * event_render.c - `pdla render FILE -o PNG [--size N] [--force]` for a
 * cluster.h5 of the event model: the box seen along z, stuck particles as
 * discs coloured by arrival (dark blue first, yellow last), the seeds white,
 * free particles grey. 3D files are projected (the nearest particle wins).
 */
#include <errno.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "h5read.h"
#include "parse.h"
#include "event_cmd.h"
#include "pdla/h5check.h"

/* A whole rank 1 or 2 dataset as doubles (malloc'ed), or NULL when it is
 * missing, of another shape, or declares more than the file stores. */
static double *read_all(hid_t f, const char *name, size_t *rows, size_t *cols)
{
    *rows = 0;
    *cols = 1;
    pdla_h5_dset d;
    if (pdla_h5_dset_open(f, name, &d) < 0) return NULL;
    double *buf = NULL;
    if ((d.rank == 1 || d.rank == 2) && pdla_h5_dset_stored(&d, sizeof *buf) == PDLA_H5_STORED) {
        *rows = (size_t)d.dims[0];
        *cols = d.rank == 2 ? (size_t)d.dims[1] : 1;
        buf = malloc(d.elems ? (size_t)d.elems * sizeof *buf : sizeof *buf);
        if (buf && pdla_h5_dset_read(&d, PDLA_H5_F64, 0, d.dims[0], buf) < 0) {
            free(buf);
            buf = NULL;
        }
    }
    if (pdla_h5_dset_close(&d) < 0) { /* a failed read: "malformed", as any HDF5 error */
        free(buf);
        buf = NULL;
    }
    return buf;
}

typedef struct img {
    int n;
    double scale;
    unsigned char *rgb;
    float *depth;
} img;

/* The pixels [lo, hi] of the image that a span [a, b] covers (empty when
 * lo > hi): clamped to the image before any conversion to int, so a disc
 * far larger than the image (a forged radius of 1e5 box sides took 1e12
 * steps) costs no more than the image. */
static void span(const img *im, double a, double b, int *lo, int *hi)
{
    if (!(a <= b)) { /* NaN from inf - inf (a tiny box side scales far positions to inf) */
        *lo = 0;
        *hi = -1;
        return;
    }
    *lo = a < 0 ? 0 : a >= im->n ? im->n : (int)floor(a);
    *hi = b < 0 ? -1 : b >= im->n ? im->n - 1 : (int)ceil(b);
}

static void disc(img *im, const double *x, int dim, double r, const unsigned char *col)
{
    const double cx = x[0] * im->scale, cy = x[1] * im->scale, rr = fmax(r * im->scale, 0.7);
    const double z = dim == 3 ? x[2] : 0;
    int ylo, yhi, xlo, xhi;
    span(im, cy - rr, cy + rr, &ylo, &yhi);
    span(im, cx - rr, cx + rr, &xlo, &xhi);
    for (int py = ylo; py <= yhi; py++)
        for (int px = xlo; px <= xhi; px++) {
            const double dx = px + 0.5 - cx, dy = py + 0.5 - cy;
            if (dx * dx + dy * dy > rr * rr) continue;
            const size_t k = (size_t)(im->n - 1 - py) * (size_t)im->n + (size_t)px;
            if (dim == 3 && z < im->depth[k]) continue;
            im->depth[k] = (float)z;
            const double shade = dim == 3 ? 0.6 + 0.4 * sqrt(fmax(0, 1 - (dx * dx + dy * dy) / (rr * rr))) : 1;
            for (int c = 0; c < 3; c++) im->rgb[3 * k + c] = (unsigned char)(col[c] * shade);
        }
}

static void arrival_colour(double u, unsigned char *c)
{
    /* dark blue -> magenta -> orange -> yellow */
    static const double k[4][3] = {{20, 20, 120}, {160, 40, 140}, {240, 120, 40}, {250, 240, 80}};
    const double s = u * 3;
    const int i = s >= 3 ? 2 : (int)s;
    const double f = s - i;
    for (int q = 0; q < 3; q++) c[q] = (unsigned char)(k[i][q] + f * (k[i + 1][q] - k[i][q]));
}

/* The four arrays agree (a radius per position, the free positions of the
 * cluster's dimension: a shorter /cluster/radii or 1-column /free/positions
 * was read past its end) and every number is finite (NaN made the disc
 * bounds undefined), radii not negative; L a finite box side > 0. */
static int consistent(const double *cp, size_t ns, size_t dim, const double *cr, size_t nr, const double *fp,
                      size_t nf, size_t fdim, const double *fr, size_t nfr, double L)
{
    if (!(L > 0 && L < INFINITY) || nr != ns || nfr != nf || (dim != 2 && dim != 3) || (nf && fdim != dim))
        return 0;
    for (size_t k = 0; k < ns * dim; k++)
        if (!isfinite(cp[k])) return 0;
    for (size_t k = 0; k < nf * dim; k++)
        if (!isfinite(fp[k])) return 0;
    for (size_t k = 0; k < ns; k++)
        if (!(cr[k] >= 0 && cr[k] < INFINITY)) return 0;
    for (size_t k = 0; k < nf; k++)
        if (!(fr[k] >= 0 && fr[k] < INFINITY)) return 0;
    return 1;
}

/* The render's options: 0, or 2 with the line printed. */
static int render_args(int argc, char **argv, const char **in, const char **out, long *size, int *force)
{
    for (int k = 1; k < argc; k++) {
        if ((!strcmp(argv[k], "-o") || !strcmp(argv[k], "--output")) && k + 1 < argc) *out = argv[++k];
        else if (!strcmp(argv[k], "--size") && k + 1 < argc) {
            /* the whole word a number (atoi took "100abc" as 100) */
            if (cli_parse_long_in(argv[++k], 16, 8192, size)) {
                fprintf(stderr, "pdla render: --size: want a whole number in [16, 8192]\n");
                return 2;
            }
        } else if (!strcmp(argv[k], "--force")) *force = 1;
        else if (argv[k][0] != '-') *in = argv[k];
        else {
            fprintf(stderr, "pdla render: option '%s' is not known for event files "
                            "(use -o PNG, --size N, --force)\n", argv[k]);
            return 2;
        }
    }
    if (!*in || !*out) {
        fprintf(stderr, "pdla render: need FILE and -o PNG (--size 16..8192)\n");
        return 2;
    }
    return 0;
}

int event_render_main(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    long size = 1024;
    int force = 0;
    if (render_args(argc, argv, &in, &out, &size, &force)) return 2;
    struct stat st;
    if (!force && stat(out, &st) == 0) {
        fprintf(stderr, "pdla render: %s exists; not overwriting it (use --force)\n", out);
        return 2;
    }
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(in, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla render: cannot open %s\n", in);
        return 2;
    }
    size_t ns, dim, nr, one, nf, fdim, nfr;
    double *cp = read_all(f, "/cluster/positions", &ns, &dim);
    double *cr = read_all(f, "/cluster/radii", &nr, &one);
    double *fp = read_all(f, "/free/positions", &nf, &fdim);
    double *fr = read_all(f, "/free/radii", &nfr, &one);
    /* the seeds of a --seeds run: datasets, not the one seed's attributes */
    size_t nsd = 0, sdim = 0, nsr = 0;
    const int has_sd = H5Lexists(f, "/cluster", H5P_DEFAULT) > 0 &&
                       H5Lexists(f, "/cluster/seed_positions", H5P_DEFAULT) > 0;
    double *sp = has_sd ? read_all(f, "/cluster/seed_positions", &nsd, &sdim) : NULL;
    double *spr = has_sd ? read_all(f, "/cluster/seed_radii", &nsr, &one) : NULL;
    double L = 0, seed[3] = {0, 0, 0}, sr = 0;
    const hid_t g = H5Gopen2(f, "/results", H5P_DEFAULT), gc = H5Gopen2(f, "/cluster", H5P_DEFAULT);
    int ok = cp && cr && fp && fr && g >= 0 && gc >= 0 && (!has_sd || (sp && spr));
    if (ok) {
        ok = pdla_h5_attr_number(g, "box_side", PDLA_H5_F64, &L) == 0;
        if (H5Aexists(gc, "seed_radius") > 0) {
            static const char *nm[] = {"seed_x", "seed_y", "seed_z", "seed_radius"};
            for (int q = 0; q < 4 && ok; q++) {
                if (q < 3 && (size_t)q >= dim) continue;
                ok = pdla_h5_attr_number(gc, nm[q], PDLA_H5_F64, q < 3 ? &seed[q] : &sr) == 0;
            }
        }
    }
    /* A failed close is a failed read: "malformed" below, as any HDF5 error. */
    if (g >= 0 && H5Gclose(g) < 0) ok = 0;
    if (gc >= 0 && H5Gclose(gc) < 0) ok = 0;
    if (H5Fclose(f) < 0) ok = 0;
    int rc = 0;
    img im = {size, size / (L > 0 ? L : 1), calloc((size_t)size * size * 3, 1),
              malloc((size_t)size * size * sizeof(float))};
    if (!ok || !im.rgb || !im.depth || !consistent(cp, ns, dim, cr, nr, fp, nf, fdim, fr, nfr, L) ||
        !(isfinite(sr) && sr >= 0 && isfinite(seed[0]) && isfinite(seed[1]) && isfinite(seed[2])) ||
        (has_sd && !consistent(sp, nsd, sdim, spr, nsr, NULL, 0, 0, NULL, 0, L)) || (has_sd && sdim != dim)) {
        fprintf(stderr, "pdla render: %s: malformed event file\n", in);
        rc = 2;
        goto done;
    }
    for (size_t k = 0; k < (size_t)size * size; k++) im.depth[k] = -INFINITY;
    memset(im.rgb, 24, (size_t)size * size * 3);
    static const unsigned char grey[3] = {110, 110, 110}, white[3] = {255, 255, 255};
    for (size_t i = 0; i < nf; i++) disc(&im, fp + i * dim, (int)dim, fr[i], grey);
    for (size_t i = 0; i < ns; i++) {
        unsigned char c[3];
        arrival_colour(ns > 1 ? (double)i / (double)(ns - 1) : 0, c);
        disc(&im, cp + i * dim, (int)dim, cr[i], c);
    }
    if (sr > 0) disc(&im, seed, (int)dim, sr, white);
    for (size_t i = 0; i < nsd; i++) disc(&im, sp + i * dim, (int)dim, spr[i], white);
    char werr[600];
    rc = tools_png_write(out, (int)size, (int)size, im.rgb, force, werr, sizeof werr) ? 1 : 0;
    if (rc) fprintf(stderr, "pdla render: %s\n", werr);
done:
    free(cp), free(cr), free(fp), free(fr), free(sp), free(spr), free(im.rgb), free(im.depth);
    return rc;
}
