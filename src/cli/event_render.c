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

/* Do n particles (positions pos, dim each; radii rad) lie in the box of
 * side L as the model keeps them, and what volume do they fill (added to
 * *vol)? Between elastic walls a particle lies wholly inside; in a
 * periodic box its centre lies in [0, L] (free positions are wrapped
 * there, stuck ones and seeds are where they were placed, inside) and no
 * radius exceeds half the box (the box is at least 3 of the largest radius,
 * ev_sim.c size_box). 1e-6 of the side covers any round-off. Bounded this
 * way, with the volume at most the box's, the discs cost what a legit file
 * costs: a forged file of 2e4 discs each covering the whole image ran for
 * minutes (N x image size). */
static int in_box(const double *pos, const double *rad, size_t n, size_t dim, double L, int periodic,
                  double *vol)
{
    const double tol = 1e-6 * L;
    for (size_t i = 0; i < n; i++) {
        const double r = rad[i];
        if (!(r <= 0.5 * L)) return 0;
        const double lo = periodic ? 0 : r, hi = periodic ? L : L - r;
        for (size_t k = 0; k < dim; k++)
            if (!(pos[i * dim + k] >= lo - tol && pos[i * dim + k] <= hi + tol)) return 0;
        *vol += dim == 3 ? 4.0 / 3.0 * M_PI * r * r * r : M_PI * r * r;
    }
    return 1;
}

/* What a render reads of an event cluster.h5. */
typedef struct ev_scene {
    size_t ns, dim, nr, nf, fdim, nfr, nsd, sdim, nsr;
    double *cp, *cr, *fp, *fr, *sp, *spr; /* cluster, free, --seeds seeds */
    double L, seed[3], sr;                /* box side, the one seed (sr 0: none) */
    int periodic, has_sd;
} ev_scene;

static void scene_free(ev_scene *e)
{
    free(e->cp), free(e->cr), free(e->fp), free(e->fr), free(e->sp), free(e->spr);
}

/* Why the scene cannot be drawn, or NULL: arrays that disagree or are not
 * finite (consistent), a seed not finite, anything outside the box or
 * larger than half of it, or more volume than the box holds (packing > 1;
 * 1e-6 for round-off: hard particles never overlap beyond 1e-10). */
static const char *scene_fault(const ev_scene *e)
{
    const double L = e->L;
    if (!consistent(e->cp, e->ns, e->dim, e->cr, e->nr, e->fp, e->nf, e->fdim, e->fr, e->nfr, L) ||
        (e->has_sd && (!consistent(e->sp, e->nsd, e->sdim, e->spr, e->nsr, NULL, 0, 0, NULL, 0, L) ||
                       e->sdim != e->dim)))
        return "arrays of different lengths, numbers not finite, or a box side not above 0";
    if (!(isfinite(e->sr) && e->sr >= 0 && isfinite(e->seed[0]) && isfinite(e->seed[1]) && isfinite(e->seed[2])))
        return "a seed position or radius not finite";
    double vol = 0;
    if (!in_box(e->cp, e->cr, e->ns, e->dim, L, e->periodic, &vol) ||
        !in_box(e->fp, e->fr, e->nf, e->dim, L, e->periodic, &vol) ||
        (e->has_sd && !in_box(e->sp, e->spr, e->nsd, e->dim, L, e->periodic, &vol)) ||
        (e->sr > 0 && !in_box(e->seed, &e->sr, 1, e->dim, L, e->periodic, &vol)))
        return "a particle or seed outside the box or larger than half of it";
    if (!(vol <= pow(L, (double)e->dim) * (1 + 1e-6))) return "particles filling more than the box";
    return NULL;
}

/* The box side, the walls (root box_walls) and the one seed's attributes:
 * 0, or -1 on any HDF5 failure or a value of the wrong kind. */
static int read_box(hid_t f, ev_scene *e)
{
    char walls[32];
    if (pdla_h5_attr_str(f, "box_walls", walls, sizeof walls) < 0) return -1;
    if (strcmp(walls, "periodic") && strcmp(walls, "elastic")) return -1;
    e->periodic = !strcmp(walls, "periodic");
    const hid_t g = H5Gopen2(f, "/results", H5P_DEFAULT), gc = H5Gopen2(f, "/cluster", H5P_DEFAULT);
    int ok = g >= 0 && gc >= 0 && pdla_h5_attr_number(g, "box_side", PDLA_H5_F64, &e->L) == 0;
    const htri_t has_seed = ok ? H5Aexists(gc, "seed_radius") : -1;
    ok = ok && has_seed >= 0;
    if (ok && has_seed) {
        static const char *nm[] = {"seed_x", "seed_y", "seed_z", "seed_radius"};
        for (int q = 0; q < 4 && ok; q++) {
            if (q < 3 && (size_t)q >= e->dim) continue;
            ok = pdla_h5_attr_number(gc, nm[q], PDLA_H5_F64, q < 3 ? &e->seed[q] : &e->sr) == 0;
        }
    }
    /* A failed close is a failed read, as any HDF5 error. */
    if (g >= 0 && H5Gclose(g) < 0) ok = 0;
    if (gc >= 0 && H5Gclose(gc) < 0) ok = 0;
    return ok ? 0 : -1;
}

/* The scene from the open file f: 0, or -1 on any HDF5 failure or a
 * dataset of the wrong shape (arrays left to scene_free). */
static int read_scene(hid_t f, ev_scene *e)
{
    size_t one;
    e->cp = read_all(f, "/cluster/positions", &e->ns, &e->dim);
    e->cr = read_all(f, "/cluster/radii", &e->nr, &one);
    e->fp = read_all(f, "/free/positions", &e->nf, &e->fdim);
    e->fr = read_all(f, "/free/radii", &e->nfr, &one);
    if (!e->cp || !e->cr || !e->fp || !e->fr) return -1;
    /* the seeds of a --seeds run: datasets, not the one seed's attributes */
    const htri_t has_c = H5Lexists(f, "/cluster", H5P_DEFAULT);
    const htri_t has_sd = has_c > 0 ? H5Lexists(f, "/cluster/seed_positions", H5P_DEFAULT) : has_c;
    if (has_sd < 0) return -1;
    e->has_sd = has_sd > 0;
    if (e->has_sd) {
        e->sp = read_all(f, "/cluster/seed_positions", &e->nsd, &e->sdim);
        e->spr = read_all(f, "/cluster/seed_radii", &e->nsr, &one);
        if (!e->sp || !e->spr) return -1;
    }
    return read_box(f, e);
}

static void draw_scene(img *im, const ev_scene *e)
{
    static const unsigned char grey[3] = {110, 110, 110}, white[3] = {255, 255, 255};
    const size_t dim = e->dim, ns = e->ns;
    for (size_t i = 0; i < e->nf; i++) disc(im, e->fp + i * dim, (int)dim, e->fr[i], grey);
    for (size_t i = 0; i < ns; i++) {
        unsigned char c[3];
        arrival_colour(ns > 1 ? (double)i / (double)(ns - 1) : 0, c);
        disc(im, e->cp + i * dim, (int)dim, e->cr[i], c);
    }
    if (e->sr > 0) disc(im, e->seed, (int)dim, e->sr, white);
    for (size_t i = 0; i < e->nsd; i++) disc(im, e->sp + i * dim, (int)dim, e->spr[i], white);
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
    char cerr[1024];
    if (tools_out_check(out, in, force, cerr, sizeof cerr)) {
        fprintf(stderr, "pdla render: %s\n", cerr);
        return 2;
    }
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(in, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla render: cannot open %s\n", in);
        return 2;
    }
    ev_scene e;
    memset(&e, 0, sizeof e);
    int ok = read_scene(f, &e) == 0;
    if (H5Fclose(f) < 0) ok = 0; /* a failed close is a failed read */
    const char *bad = ok ? scene_fault(&e) : "missing or unreadable datasets or attributes";
    int rc = 0;
    img im = {size, size / (e.L > 0 ? e.L : 1), NULL, NULL};
    if (bad) {
        fprintf(stderr, "pdla render: %s: malformed event file (%s)\n", in, bad);
        rc = 2;
        goto done;
    }
    im.rgb = malloc((size_t)size * size * 3);
    im.depth = malloc((size_t)size * size * sizeof(float));
    if (!im.rgb || !im.depth) {
        fprintf(stderr, "pdla render: out of memory for a %ld-pixel image\n", size);
        rc = 1;
        goto done;
    }
    for (size_t k = 0; k < (size_t)size * size; k++) im.depth[k] = -INFINITY;
    memset(im.rgb, 24, (size_t)size * size * 3);
    draw_scene(&im, &e);
    char werr[600];
    rc = tools_png_write(out, (int)size, (int)size, im.rgb, force, werr, sizeof werr) ? 1 : 0;
    if (rc) fprintf(stderr, "pdla render: %s\n", werr);
done:
    scene_free(&e);
    free(im.rgb), free(im.depth);
    return rc;
}
