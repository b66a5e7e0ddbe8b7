/*
 * test_h5check.c - the checked HDF5 readers (include/pdla/h5check.h) on a
 * file built here: exact and converting scalar attributes, attributes with
 * more elements than the caller's buffer (refused), strings fixed and
 * variable that fit or are cut, a chunked dataset that declares 2^40 rows
 * but stores none (refused as not stored), one that stores what it declares
 * (read back by rows), and the root `model` attribute.
 */
#include <hdf5.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "pdla/h5check.h"

static void attr(hid_t obj, const char *name, hid_t type, hsize_t n, const void *val)
{
    const hid_t s = n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, NULL);
    const hid_t a = H5Acreate2(obj, name, type, s, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(a >= 0 && H5Awrite(a, type, val) >= 0, "cannot write attribute %s", name);
    H5Aclose(a);
    H5Sclose(s);
}

static void str_attr(hid_t obj, const char *name, const char *v, int variable)
{
    const hid_t t = H5Tcopy(H5T_C_S1);
    H5Tset_size(t, variable ? H5T_VARIABLE : strlen(v) + 1);
    attr(obj, name, t, 1, variable ? (const void *)&v : (const void *)v);
    H5Tclose(t);
}

/* A chunked u32 dataset [rows][2]; the first `written` rows hold 0,1,2,... */
static void dataset(hid_t f, const char *name, hsize_t rows, hsize_t written)
{
    const hsize_t dims[2] = {rows, 2}, chunk[2] = {64, 2};
    const hid_t s = H5Screate_simple(2, dims, NULL), pl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(pl, 2, chunk);
    H5Pset_fletcher32(pl);
    const hid_t d = H5Dcreate2(f, name, H5T_STD_U32LE, s, H5P_DEFAULT, pl, H5P_DEFAULT);
    CHECK(d >= 0, "cannot create %s", name);
    if (written) {
        uint32_t *v = malloc(written * 2 * sizeof *v);
        for (hsize_t i = 0; i < written * 2; i++) v[i] = (uint32_t)i;
        const hsize_t start[2] = {0, 0}, count[2] = {written, 2};
        const hid_t ms = H5Screate_simple(2, count, NULL);
        H5Sselect_hyperslab(s, H5S_SELECT_SET, start, NULL, count, NULL);
        CHECK(H5Dwrite(d, H5T_NATIVE_UINT32, ms, s, H5P_DEFAULT, v) >= 0, "cannot write %s", name);
        H5Sclose(ms);
        free(v);
    }
    H5Dclose(d);
    H5Pclose(pl);
    H5Sclose(s);
}

static void build(const char *path)
{
    const hid_t f = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(f >= 0, "cannot create %s", path);
    const int32_t i32 = -7;
    const uint64_t u64 = UINT64_C(1) << 60;
    const double two[2] = {1.5, 2.5};
    attr(f, "i32", H5T_STD_I32LE, 1, &i32);
    attr(f, "u64", H5T_STD_U64LE, 1, &u64);
    attr(f, "pair", H5T_IEEE_F64LE, 2, two);
    str_attr(f, "model", "dlca", 0);
    str_attr(f, "long", "a string longer than sixteen bytes", 0);
    str_attr(f, "var", "variable", 1);
    dataset(f, "forged", (hsize_t)1 << 40, 0);
    dataset(f, "real", 1000, 1000);
    H5Fclose(f);
}

int main(void)
{
    char path[64];
    snprintf(path, sizeof path, "/tmp/pdla-h5check-%ld.h5", (long)getpid());
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    build(path);
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    CHECK(f >= 0, "cannot open %s", path);

    int32_t i32 = 0;
    int64_t i64 = 0;
    double x = 0;
    CHECK(pdla_h5_attr_exact(f, "i32", PDLA_H5_I32, &i32) == 0 && i32 == -7, "i32 = %d", (int)i32);
    CHECK(pdla_h5_attr_exact(f, "i32", PDLA_H5_I64, &i64) < 0, "exact read converted i32 to i64");
    CHECK(pdla_h5_attr_exact(f, "u64", PDLA_H5_I64, &i64) < 0, "exact read took u64 as i64");
    CHECK(pdla_h5_attr_number(f, "i32", PDLA_H5_I64, &i64) == 0 && i64 == -7, "i64 = %lld", (long long)i64);
    CHECK(pdla_h5_attr_number(f, "i32", PDLA_H5_F64, &x) == 0 && x == -7.0, "f64 = %g", x);
    CHECK(pdla_h5_attr_number(f, "pair", PDLA_H5_F64, &x) < 0, "a two-element attribute read as one");
    CHECK(pdla_h5_attr_number(f, "model", PDLA_H5_F64, &x) < 0, "a string read as a number");
    CHECK(pdla_h5_attr_number(f, "missing", PDLA_H5_F64, &x) < 0, "a missing attribute read");

    char s[16];
    CHECK(pdla_h5_attr_str(f, "model", s, sizeof s) == 0 && !strcmp(s, "dlca"), "model '%s'", s);
    CHECK(pdla_h5_attr_str(f, "var", s, sizeof s) == 0 && !strcmp(s, "variable"), "var '%s'", s);
    CHECK(pdla_h5_attr_str(f, "long", s, sizeof s) == 1 && strlen(s) == sizeof s - 1, "long '%s'", s);
    CHECK(pdla_h5_attr_str(f, "i32", s, sizeof s) < 0, "a number read as a string");

    pdla_h5_value v;
    CHECK(pdla_h5_attr_value(f, "pair", &v) == 0 && v.kind == 'f' && v.n == 2 && v.read &&
              v.f[0] == 1.5 && v.f[1] == 2.5,
          "pair: kind %c n %lld", v.kind, (long long)v.n);
    CHECK(pdla_h5_attr_value(f, "u64", &v) == 0 && v.kind == 'u' && v.u[0] == UINT64_C(1) << 60,
          "u64 value");

    pdla_h5_dset d;
    CHECK(pdla_h5_dset_open(f, "forged", &d) == 0 && d.rank == 2 && d.dims[0] == (uint64_t)1 << 40,
          "forged dataset shape");
    CHECK(pdla_h5_dset_stored(&d, 4) != PDLA_H5_STORED, "2^40 declared rows in a small file accepted");
    pdla_h5_dset_close(&d);
    CHECK(pdla_h5_dset_open(f, "real", &d) == 0 && d.fletcher32 && !d.compressing &&
              pdla_h5_dset_is(&d, PDLA_H5_U32) && !pdla_h5_dset_is(&d, PDLA_H5_U64),
          "real dataset type");
    CHECK(pdla_h5_dset_stored(&d, 4) == PDLA_H5_STORED, "a fully written dataset refused");
    uint32_t rows[10][2];
    CHECK(pdla_h5_dset_read(&d, PDLA_H5_U32, 500, 10, rows) == 0 && rows[0][0] == 1000 &&
              rows[9][1] == 1019,
          "rows 500..509");
    CHECK(pdla_h5_dset_read(&d, PDLA_H5_U32, 995, 10, rows) < 0, "a read past the end accepted");
    pdla_h5_dset_close(&d);
    CHECK(pdla_h5_dset_open(f, "missing", &d) < 0 && d.id < 0, "a missing dataset opened");
    H5Fclose(f);

    char model[8];
    CHECK(pdla_h5_file_model(path, model, sizeof model) == 0 && !strcmp(model, "dlca"), "file model");
    CHECK(pdla_h5_file_model("/dev/null", model, sizeof model) < 0, "a device read as a file");
    unlink(path);
    return check_finish();
}
