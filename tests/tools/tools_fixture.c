/*
 * tools_fixture.c - helpers for test_tools.sh:
 *   tools_fixture synth KIND OUT.h5   write a file in the pdla-cluster layout
 *       with known geometry: disc (2D, filled, D_f = 2), line (2D, D_f = 1),
 *       ball (3D, filled, D_f = 3), big (2D, 150000 rows: more than the
 *       largest slab), huge (2D, 10^7 rows, 80 MB), or a broken one:
 *       foreign (HDF5 without the format attribute), otherformat, wrongdims
 *       ([N][4]), mismatch ([N][2] with /parameters dim = 3), rank1
 *       (positions of rank 1).
 *   tools_fixture png FILE W H        read FILE back with libpng: 8-bit RGB of
 *       W x H with at least one pixel unlike the corner's; prints
 *       the number of such pixels.
 *   tools_fixture mr FILE.h5 CSV      brute force: every position in memory,
 *       M(r) = #{|x| < r} at each r_units of analyze's mass_radius.csv, which
 *       must agree exactly.
 *   tools_fixture same ARRIVAL.h5 TREE.h5   the first row of ARRIVAL.h5 is
 *       the seed (origin) and both files hold the same set of positions.
 */
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <hdf5.h>

#define DU 32 /* units per diameter */

static int attr_str(hid_t obj, const char *name, const char *s)
{
    hid_t t = H5Tcopy(H5T_C_S1);
    H5Tset_size(t, strlen(s) + 1);
    hid_t sp = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(obj, name, t, sp, H5P_DEFAULT, H5P_DEFAULT);
    const int rc = a >= 0 && H5Awrite(a, t, s) >= 0 ? 0 : -1;
    H5Aclose(a);
    H5Sclose(sp);
    H5Tclose(t);
    return rc;
}

static int attr_int(hid_t obj, const char *name, int v)
{
    hid_t sp = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(obj, name, H5T_STD_I32LE, sp, H5P_DEFAULT, H5P_DEFAULT);
    const int rc = a >= 0 && H5Awrite(a, H5T_NATIVE_INT, &v) >= 0 ? 0 : -1;
    H5Aclose(a);
    H5Sclose(sp);
    return rc;
}

typedef struct pts {
    int32_t *p;
    size_t n, cap;
    int dim;
} pts;

static void add(pts *s, int64_t x, int64_t y, int64_t z)
{
    if (s->n == s->cap) {
        s->cap = s->cap ? 2 * s->cap : 1024;
        s->p = realloc(s->p, s->cap * 3 * sizeof *s->p);
        if (!s->p) exit(99);
    }
    const int64_t c[3] = {x, y, z};
    for (int a = 0; a < s->dim; a++) s->p[s->n * (size_t)s->dim + (size_t)a] = (int32_t)c[a];
    s->n++;
}

static int write_file(const char *out, const pts *s, int cols, int rank, const char *format,
                      int pdim)
{
    hid_t f = H5Fcreate(out, H5F_ACC_EXCL, H5P_DEFAULT, H5P_DEFAULT);
    if (f < 0) return 1;
    if (format) attr_str(f, "format", format);
    attr_int(f, "format_version", 1);
    hid_t g = H5Gcreate2(f, "cluster", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t dims[2] = {rank == 1 ? s->n * (size_t)s->dim : s->n, (hsize_t)cols};
    const hsize_t chunk[2] = {dims[0] < 65536 ? dims[0] : 65536, (hsize_t)cols};
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, rank, chunk);
    H5Pset_fletcher32(dcpl);
    hid_t sp = H5Screate_simple(rank, dims, NULL);
    hid_t d = H5Dcreate2(g, "positions", H5T_STD_I32LE, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    int32_t *buf = s->p;
    int32_t *wide = NULL;
    if (cols != s->dim && rank == 2) { /* pad to the wrong width */
        wide = calloc(s->n * (size_t)cols, sizeof *wide);
        for (size_t i = 0; i < s->n; i++)
            for (int a = 0; a < s->dim && a < cols; a++) wide[i * (size_t)cols + (size_t)a] = s->p[i * (size_t)s->dim + (size_t)a];
        buf = wide;
    }
    int rc = H5Dwrite(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0;
    free(wide);
    attr_int(d, "diameter_units", DU);
    attr_str(d, "order", "tree (not arrival)");
    attr_str(d, "units", "lattice units");
    hid_t p = H5Gcreate2(f, "parameters", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    attr_int(p, "dim", pdim);
    attr_int(p, "resolution", DU);
    H5Gclose(p);
    H5Dclose(d);
    H5Sclose(sp);
    H5Pclose(dcpl);
    H5Gclose(g);
    if (H5Fclose(f) < 0) rc = 1;
    return rc;
}

/* 10^7 rows (80 MB) written slab by slab, so neither this program nor a
 * reader that streams needs memory for the whole dataset. A spiral at
 * r = 32 sqrt(k) units: a diameter's disc per 1024 pi units^2, packing
 * 0.25, as render requires of a cluster (its balls must fit their box). */
static int synth_huge(const char *out)
{
    const hsize_t n = 10000000, slab = 65536;
    hid_t f = H5Fcreate(out, H5F_ACC_EXCL, H5P_DEFAULT, H5P_DEFAULT);
    if (f < 0) return 1;
    attr_str(f, "format", "pdla-cluster");
    attr_int(f, "format_version", 1);
    hid_t g = H5Gcreate2(f, "cluster", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t dims[2] = {n, 2}, chunk[2] = {slab, 2};
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 2, chunk);
    H5Pset_fletcher32(dcpl);
    hid_t sp = H5Screate_simple(2, dims, NULL);
    hid_t d = H5Dcreate2(g, "positions", H5T_STD_I32LE, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    int32_t *buf = malloc(slab * 2 * sizeof *buf);
    int rc = d < 0 || !buf;
    for (hsize_t first = 0; first < n && !rc; first += slab) {
        const hsize_t rows = n - first < slab ? n - first : slab;
        for (hsize_t i = 0; i < rows; i++) {
            const double k = (double)(first + i), t = 0.01 * k;
            buf[2 * i] = (int32_t)(sqrt(k) * 32 * cos(t));
            buf[2 * i + 1] = (int32_t)(sqrt(k) * 32 * sin(t));
        }
        const hsize_t start[2] = {first, 0}, count[2] = {rows, 2};
        hid_t ms = H5Screate_simple(2, count, NULL);
        rc = H5Sselect_hyperslab(sp, H5S_SELECT_SET, start, NULL, count, NULL) < 0 ||
             H5Dwrite(d, H5T_NATIVE_INT32, ms, sp, H5P_DEFAULT, buf) < 0;
        H5Sclose(ms);
    }
    free(buf);
    attr_int(d, "diameter_units", DU);
    attr_str(d, "order", "tree (not arrival)");
    H5Dclose(d);
    H5Sclose(sp);
    H5Pclose(dcpl);
    H5Gclose(g);
    if (H5Fclose(f) < 0) rc = 1;
    return rc;
}

static int synth(const char *kind, const char *out)
{
    if (!strcmp(kind, "huge")) return synth_huge(out);
    pts s = {NULL, 0, 0, 2};
    int cols = 2, rank = 2, pdim = 2;
    const char *format = "pdla-cluster";
    if (!strcmp(kind, "disc")) {
        /* Lattice of spacing D/2 inside radius 200 D: ~5e5 points. */
        const int64_t h = DU / 2, R = 200 * DU;
        for (int64_t y = -R; y <= R; y += h)
            for (int64_t x = -R; x <= R; x += h)
                if (x * x + y * y <= R * R) add(&s, x, y, 0);
    } else if (!strcmp(kind, "line")) {
        const int64_t h = DU / 4, L = 1000 * DU;
        for (int64_t x = -L; x <= L; x += h) add(&s, x, 0, 0);
    } else if (!strcmp(kind, "ball")) {
        s.dim = cols = pdim = 3;
        const int64_t h = DU, R = 50 * DU;
        for (int64_t z = -R; z <= R; z += h)
            for (int64_t y = -R; y <= R; y += h)
                for (int64_t x = -R; x <= R; x += h)
                    if (x * x + y * y + z * z <= R * R) add(&s, x, y, z);
    } else if (!strcmp(kind, "big")) {
        /* A square spiral-ish pattern, 150000 rows, deterministic. */
        for (int64_t i = 0; i < 150000; i++) {
            const double t = 0.05 * (double)i;
            add(&s, (int64_t)(sqrt((double)i) * DU * cos(t)), (int64_t)(sqrt((double)i) * DU * sin(t)), 0);
        }
    } else {
        for (int64_t i = 0; i < 100; i++) add(&s, i * DU, 0, 0);
        if (!strcmp(kind, "foreign")) format = NULL;
        else if (!strcmp(kind, "otherformat")) format = "something-else";
        else if (!strcmp(kind, "wrongdims")) cols = 4;
        else if (!strcmp(kind, "mismatch")) pdim = 3;
        else if (!strcmp(kind, "rank1")) rank = 1, cols = 1;
        else {
            fprintf(stderr, "unknown kind %s\n", kind);
            return 2;
        }
    }
    const int rc = write_file(out, &s, cols, rank, format, pdim);
    free(s.p);
    return rc;
}

static int png_check(const char *path, unsigned w, unsigned h)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) return 1;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    unsigned char *row = NULL;
    if (setjmp(png_jmpbuf(png))) {
        fprintf(stderr, "%s: not a valid PNG\n", path);
        png_destroy_read_struct(&png, &info, NULL);
        free(row);
        fclose(fp);
        return 1;
    }
    png_init_io(png, fp);
    png_read_info(png, info);
    const unsigned W = png_get_image_width(png, info), H = png_get_image_height(png, info);
    if (W != w || H != h || png_get_bit_depth(png, info) != 8 ||
        png_get_color_type(png, info) != PNG_COLOR_TYPE_RGB) {
        fprintf(stderr, "%s: %ux%u depth %d type %d, want %ux%u 8-bit RGB\n", path, W, H,
                png_get_bit_depth(png, info), png_get_color_type(png, info), w, h);
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return 1;
    }
    row = malloc((size_t)W * 3);
    unsigned char bg[3] = {0, 0, 0};
    unsigned long lit = 0;
    for (unsigned y = 0; y < H; y++) {
        png_read_row(png, row, NULL);
        if (y == 0) memcpy(bg, row, 3);
        for (unsigned x = 0; x < W; x++)
            if (memcmp(row + 3 * x, bg, 3)) lit++;
    }
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    free(row);
    fclose(fp);
    printf("%lu\n", lit);
    return lit > 0 ? 0 : 1;
}

/* All of /cluster/positions in memory; NULL on failure. */
static int32_t *read_all(const char *h5, hsize_t dims[2])
{
    hid_t f = H5Fopen(h5, H5F_ACC_RDONLY, H5P_DEFAULT);
    hid_t d = H5Dopen2(f, "/cluster/positions", H5P_DEFAULT);
    hid_t sp = H5Dget_space(d);
    H5Sget_simple_extent_dims(sp, dims, NULL);
    int32_t *p = malloc(dims[0] * dims[1] * sizeof *p + 1);
    if (p && H5Dread(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, p) < 0) {
        free(p);
        p = NULL;
    }
    H5Sclose(sp);
    H5Dclose(d);
    H5Fclose(f);
    return p;
}

static int cmp_dim;
static int cmp_rows(const void *a, const void *b)
{
    return memcmp(a, b, (size_t)cmp_dim * sizeof(int32_t)) < 0 ? -1 : memcmp(a, b, (size_t)cmp_dim * sizeof(int32_t)) > 0;
}

static int same_check(const char *arr, const char *tree)
{
    hsize_t da[2], dt[2];
    int32_t *a = read_all(arr, da), *t = read_all(tree, dt);
    int rc = 1;
    if (!a || !t || da[0] != dt[0] || da[1] != dt[1] || da[0] == 0) {
        fprintf(stderr, "shapes differ or unreadable\n");
    } else if (a[0] != 0 || a[1] != 0 || (da[1] == 3 && a[2] != 0)) {
        fprintf(stderr, "the first arrival is not the seed\n");
    } else {
        cmp_dim = (int)da[1];
        qsort(a, da[0], da[1] * sizeof *a, cmp_rows);
        qsort(t, dt[0], dt[1] * sizeof *t, cmp_rows);
        rc = memcmp(a, t, da[0] * da[1] * sizeof *a) != 0;
        if (rc) fprintf(stderr, "the positions differ\n");
    }
    free(a);
    free(t);
    return rc;
}

static int mr_check(const char *h5, const char *csv)
{
    hsize_t dims[2];
    int32_t *p = read_all(h5, dims);
    if (!p) return 1;
    double *r = malloc(dims[0] * sizeof *r);
    for (hsize_t i = 0; i < dims[0]; i++) {
        double r2 = 0;
        for (hsize_t a = 0; a < dims[1]; a++) r2 += (double)p[i * dims[1] + a] * p[i * dims[1] + a];
        r[i] = sqrt(r2);
    }
    FILE *fp = fopen(csv, "r");
    if (!fp) return 1;
    char line[512];
    int rows = 0, bad = 0;
    if (!fgets(line, sizeof line, fp)) return 1;
    while (fgets(line, sizeof line, fp)) {
        double rd, ru;
        unsigned long long m;
        int in;
        if (sscanf(line, "%lf,%lf,%llu,%d", &rd, &ru, &m, &in) != 4) return 1;
        unsigned long long brute = 0;
        for (hsize_t i = 0; i < dims[0]; i++) brute += r[i] < ru;
        if (brute != m) {
            fprintf(stderr, "M(%g units): streamed %llu, brute force %llu\n", ru, m, brute);
            bad++;
        }
        rows++;
    }
    fclose(fp);
    free(p);
    free(r);
    printf("%d radii compared, %d differ\n", rows, bad);
    return rows > 0 && bad == 0 ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "synth")) return synth(argv[2], argv[3]);
    if (argc == 5 && !strcmp(argv[1], "png")) return png_check(argv[2], (unsigned)atoi(argv[3]), (unsigned)atoi(argv[4]));
    if (argc == 4 && !strcmp(argv[1], "mr")) return mr_check(argv[2], argv[3]);
    if (argc == 4 && !strcmp(argv[1], "same")) return same_check(argv[2], argv[3]);
    fprintf(stderr, "usage: tools_fixture synth KIND OUT | png FILE W H | mr H5 CSV\n");
    return 2;
}
