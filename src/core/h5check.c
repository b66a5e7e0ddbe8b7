/*
 * h5check.c - the checked HDF5 readers of include/pdla/h5check.h, one set
 * for the checkpoint loader and the tools. The size checks here are the
 * ones the reliability work put into each reader separately: one element
 * per attribute buffer, strings that fit, and no dataset larger than what
 * the file stores.
 */
#include "pdla/h5check.h"

#include <hdf5.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

_Static_assert(sizeof(hid_t) == sizeof(pdla_h5_id), "pdla_h5_id must hold an HDF5 hid_t");

static hid_t native(pdla_h5_type t)
{
    switch (t) {
    case PDLA_H5_U8: return H5T_NATIVE_UINT8;
    case PDLA_H5_I32: return H5T_NATIVE_INT32;
    case PDLA_H5_U32: return H5T_NATIVE_UINT32;
    case PDLA_H5_I64: return H5T_NATIVE_INT64;
    case PDLA_H5_U64: return H5T_NATIVE_UINT64;
    case PDLA_H5_I8: return H5T_NATIVE_INT8;
    default: return H5T_NATIVE_DOUBLE;
    }
}

/* 'i', 'u', 'f', 's' or 0 for an HDF5 type. */
static char kind_of(hid_t t)
{
    switch (H5Tget_class(t)) {
    case H5T_INTEGER: return H5Tget_sign(t) == H5T_SGN_NONE ? 'u' : 'i';
    case H5T_FLOAT: return 'f';
    case H5T_STRING: return 's';
    default: return 0;
    }
}

/* 1 when id is closed (or was never open), 0 when closing it failed: a
 * reader whose close fails reports a failed read, as for any HDF5 error. */
static int close_ok(hid_t id, herr_t (*close_fn)(hid_t))
{
    return id < 0 || close_fn(id) >= 0;
}

/* Opens attribute name of obj with its type and element count; -1 when it
 * is missing or they do not read back. */
static hid_t attr_open(hid_t obj, const char *name, hid_t *type, hssize_t *n)
{
    *type = H5I_INVALID_HID;
    if (H5Aexists(obj, name) <= 0) return H5I_INVALID_HID;
    const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    if (a < 0) return H5I_INVALID_HID;
    const hid_t s = H5Aget_space(a);
    *n = s >= 0 ? H5Sget_simple_extent_npoints(s) : -1;
    if (s >= 0 && H5Sclose(s) < 0) *n = -1;
    if (*n >= 0) *type = H5Aget_type(a);
    if (*type >= 0) return a;
    (void)close_ok(a, H5Aclose); /* the failure already being returned is the one to report */
    return H5I_INVALID_HID;
}

/* Closes a and t; 1, or 0 when a close failed. */
static int attr_close(hid_t a, hid_t t)
{
    const int ok = close_ok(t, H5Tclose);
    return close_ok(a, H5Aclose) && ok;
}

int pdla_h5_attr_exact(pdla_h5_id obj, const char *name, pdla_h5_type t, void *val)
{
    hid_t ft;
    hssize_t n;
    const hid_t a = attr_open(obj, name, &ft, &n);
    if (a < 0) return -1;
    const hid_t mt = native(t);
    int ok = n == 1 && H5Tget_class(ft) == H5Tget_class(mt) && H5Tget_size(ft) == H5Tget_size(mt);
    if (ok && H5Tget_class(ft) == H5T_INTEGER) ok = H5Tget_sign(ft) == H5Tget_sign(mt);
    if (ok) ok = H5Aread(a, mt, val) >= 0;
    ok = attr_close(a, ft) && ok;
    return ok ? 0 : -1;
}

int pdla_h5_attr_number(pdla_h5_id obj, const char *name, pdla_h5_type t, void *val)
{
    hid_t ft;
    hssize_t n;
    const hid_t a = attr_open(obj, name, &ft, &n);
    if (a < 0) return -1;
    const H5T_class_t c = H5Tget_class(ft);
    int ok = n == 1 && (c == H5T_INTEGER || (t == PDLA_H5_F64 && c == H5T_FLOAT));
    if (ok) ok = H5Aread(a, native(t), val) >= 0;
    ok = attr_close(a, ft) && ok;
    return ok ? 0 : -1;
}

/* Reads the one string of attribute a (type ft) into buf. */
static int read_string(hid_t a, hid_t ft, char *buf, size_t len)
{
    buf[0] = '\0';
    int rc = -1;
    if (H5Tis_variable_str(ft) > 0) {
        char *s = NULL;
        /* The file's own string type (ASCII or UTF-8, as h5py writes): HDF5
         * will not convert between character sets. */
        const hid_t mt = H5Tcopy(ft);
        if (mt >= 0 && H5Aread(a, mt, &s) >= 0 && s) {
            rc = strlen(s) >= len ? 1 : 0;
            snprintf(buf, len, "%s", s);
            if (H5free_memory(s) < 0) rc = -1;
        }
        return close_ok(mt, H5Tclose) ? rc : -1;
    }
    const size_t sz = H5Tget_size(ft);
    char *s = sz > 0 ? calloc(sz + 1, 1) : NULL; /* H5Aread writes all sz bytes */
    if (s && H5Aread(a, ft, s) >= 0) {
        rc = strlen(s) >= len ? 1 : 0;
        snprintf(buf, len, "%s", s);
    }
    free(s);
    return rc;
}

int pdla_h5_attr_str(pdla_h5_id obj, const char *name, char *buf, size_t len)
{
    if (len == 0) return -1;
    buf[0] = '\0';
    hid_t ft;
    hssize_t n;
    const hid_t a = attr_open(obj, name, &ft, &n);
    if (a < 0) return -1;
    const int rc = n == 1 && H5Tget_class(ft) == H5T_STRING ? read_string(a, ft, buf, len) : -1;
    return attr_close(a, ft) ? rc : -1;
}

int pdla_h5_attr_value(pdla_h5_id obj, const char *name, pdla_h5_value *v)
{
    memset(v, 0, sizeof *v);
    hid_t ft;
    hssize_t n;
    const hid_t a = attr_open(obj, name, &ft, &n);
    if (a < 0) return -1;
    v->kind = kind_of(ft);
    v->n = n;
    if (v->kind == 's' && n == 1) {
        const int r = read_string(a, ft, v->s, sizeof v->s);
        v->read = r >= 0;
        v->cut = r == 1;
    } else if (v->kind && v->kind != 's' && n >= 1 && n <= PDLA_H5_MAX_ELEMS) {
        if (v->kind == 'u') v->read = H5Aread(a, H5T_NATIVE_UINT64, v->u) >= 0;
        else if (v->kind == 'i') v->read = H5Aread(a, H5T_NATIVE_INT64, v->i) >= 0;
        else v->read = H5Aread(a, H5T_NATIVE_DOUBLE, v->f) >= 0;
        for (int k = 0; k < n && v->kind != 'f'; k++)
            v->f[k] = v->kind == 'u' ? (double)v->u[k] : (double)v->i[k];
    }
    return attr_close(a, ft) ? 0 : -1;
}

int pdla_h5_file_model(const char *path, char *model, size_t len)
{
    return pdla_h5_file_attr(path, "model", model, len);
}

int pdla_h5_file_attr(const char *path, const char *name, char *model, size_t len)
{
    struct stat st; /* never open a FIFO or device: HDF5 would block on it */
    if (len) model[0] = '\0';
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode)) return -1;
    H5E_auto2_t fn;
    void *data;
    if (H5Eget_auto2(H5E_DEFAULT, &fn, &data) < 0 || H5Eset_auto2(H5E_DEFAULT, NULL, NULL) < 0)
        return -1;
    int rc = -1;
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f >= 0) {
        rc = pdla_h5_attr_str(f, name, model, len) == 0 ? 0 : -1;
        if (H5Fclose(f) < 0) rc = -1;
    }
    return H5Eset_auto2(H5E_DEFAULT, fn, data) < 0 ? -1 : rc;
}

/* ---- datasets ------------------------------------------------------------ */

/* Type, shape and filters of the open dataset d->id; 0 or -1. */
static int describe(pdla_h5_dset *d)
{
    const hid_t t = H5Dget_type(d->id), s = H5Dget_space(d->id), pl = H5Dget_create_plist(d->id);
    int ok = t >= 0 && s >= 0 && pl >= 0;
    if (ok) {
        d->kind = kind_of(t);
        d->size = H5Tget_size(t);
        d->rank = H5Sget_simple_extent_ndims(s);
        ok = d->size > 0 && d->rank >= 0 && d->rank <= PDLA_H5_MAX_RANK;
    }
    hsize_t dims[PDLA_H5_MAX_RANK] = {0};
    if (ok) ok = H5Sget_simple_extent_dims(s, dims, NULL) == d->rank;
    d->elems = 1;
    for (int k = 0; ok && k < d->rank; k++) {
        d->dims[k] = dims[k];
        d->elems = dims[k] && d->elems > UINT64_MAX / dims[k] ? UINT64_MAX : d->elems * dims[k];
    }
    const int nf = ok ? H5Pget_nfilters(pl) : -1;
    ok = ok && nf >= 0;
    for (int k = 0; ok && k < nf; k++) {
        unsigned flags;
        size_t ne = 0;
        char fname[32];
        if (H5Pget_filter2(pl, (unsigned)k, &flags, &ne, NULL, sizeof fname, fname, NULL) ==
            H5Z_FILTER_FLETCHER32)
            d->fletcher32 = 1;
        else
            d->compressing = 1;
    }
    if (ok) d->stored = H5Dget_storage_size(d->id);
    ok = close_ok(pl, H5Pclose) && ok;
    ok = close_ok(s, H5Sclose) && ok;
    ok = close_ok(t, H5Tclose) && ok;
    return ok ? 0 : -1;
}

int pdla_h5_dset_open(pdla_h5_id loc, const char *name, pdla_h5_dset *d)
{
    memset(d, 0, sizeof *d);
    d->id = H5I_INVALID_HID;
    /* A link that does not resolve (dangling soft link) is missing too. */
    if (H5Lexists(loc, name, H5P_DEFAULT) <= 0 || H5Oexists_by_name(loc, name, H5P_DEFAULT) <= 0)
        return -1;
    if ((d->id = H5Dopen2(loc, name, H5P_DEFAULT)) < 0) return -1;
    if (describe(d) == 0) return 0;
    (void)pdla_h5_dset_close(d); /* the failure already being returned is the one to report */
    return -1;
}

int pdla_h5_dset_close(pdla_h5_dset *d)
{
    const int ok = close_ok(d->id, H5Dclose);
    d->id = H5I_INVALID_HID;
    return ok ? 0 : -1;
}

int pdla_h5_dset_is(const pdla_h5_dset *d, pdla_h5_type t)
{
    const hid_t mt = native(t);
    const int want_real = H5Tget_class(mt) == H5T_FLOAT;
    const int is_int = d->kind == 'i' || d->kind == 'u';
    return (want_real ? d->kind == 'f' : is_int) && d->size == H5Tget_size(mt);
}

int pdla_h5_dset_stored(const pdla_h5_dset *d, size_t esize)
{
    if (d->elems == 0) return PDLA_H5_STORED;
    if (esize == 0 || d->elems > (uint64_t)(SIZE_MAX / 2) / esize || d->elems > (uint64_t)1 << 52)
        return PDLA_H5_TOO_LARGE;
    const double need = (double)d->elems * (double)d->size;
    const double room = d->compressing ? 1100.0 : 1.0;
    return need > (double)d->stored * room ? PDLA_H5_NOT_STORED : PDLA_H5_STORED;
}

/* HDF5 clamps a value that does not fit the memory type (an int64 of
 * 2^40 read as int32 became 2^31 - 1, silently): a read fails instead. */
static H5T_conv_ret_t conv_refuse_range(H5T_conv_except_t e, hid_t src, hid_t dst, void *sbuf, void *dbuf,
                                        void *user)
{
    (void)src, (void)dst, (void)sbuf, (void)dbuf, (void)user;
    return e == H5T_CONV_EXCEPT_RANGE_HI || e == H5T_CONV_EXCEPT_RANGE_LOW ? H5T_CONV_ABORT : H5T_CONV_UNHANDLED;
}

int pdla_h5_dset_read(const pdla_h5_dset *d, pdla_h5_type t, uint64_t row0, uint64_t nrows,
                      void *buf)
{
    if (d->rank < 1 || d->rank > 2 || row0 > d->dims[0] || nrows > d->dims[0] - row0) return -1;
    if (nrows == 0) return 0;
    const hsize_t start[2] = {row0, 0}, count[2] = {nrows, d->rank == 2 ? d->dims[1] : 1};
    const hid_t fs = H5Dget_space(d->id);
    const hid_t ms = H5Screate_simple(d->rank, count, NULL);
    const hid_t xf = H5Pcreate(H5P_DATASET_XFER);
    const int ok = fs >= 0 && ms >= 0 && xf >= 0 && H5Pset_type_conv_cb(xf, conv_refuse_range, NULL) >= 0 &&
                   H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) >= 0 &&
                   H5Dread(d->id, native(t), ms, fs, xf, buf) >= 0;
    const int closed = close_ok(fs, H5Sclose) & close_ok(ms, H5Sclose) & close_ok(xf, H5Pclose);
    return ok && closed ? 0 : -1;
}

/* A chunk HDF5's default cache (1 MiB per dataset) cannot hold is read and
 * decompressed again for every read that touches it, so reading one
 * gzip'ed chunk of n rows in slabs of 65536 cost n / 65536 decompressions
 * of the whole chunk: quadratic in n (a DLCA start of 1.2e7 monomers took
 * 157 s, not 16 s; `pdla analyze` read a 2.2 MB single-chunk file as 136 MB).
 * HDF5 decompresses a whole chunk to read any of it, so caching it costs no
 * more memory than the read already took; a chunk more than twice the
 * data's bytes (an extendible dataset, mostly beyond its rows) is left to
 * the default cache. */
int pdla_h5_dset_chunk(const pdla_h5_dset *d, uint64_t *cd)
{
    const hid_t dcpl = H5Dget_create_plist(d->id);
    if (dcpl < 0) return -1;
    hsize_t c[PDLA_H5_MAX_RANK] = {0};
    const H5D_layout_t layout = H5Pget_layout(dcpl);
    const int rank = layout == H5D_CHUNKED ? H5Pget_chunk(dcpl, PDLA_H5_MAX_RANK, c) : 0;
    if (H5Pclose(dcpl) < 0 || layout < 0 || rank < 0 || rank > PDLA_H5_MAX_RANK) return -1;
    for (int a = 0; a < rank; a++) cd[a] = c[a];
    return rank;
}

int pdla_h5_dset_cache_chunk(pdla_h5_id loc, const char *name, pdla_h5_dset *d)
{
    if (d->rank < 1) return 0;
    uint64_t cd[PDLA_H5_MAX_RANK] = {0};
    const int rank = pdla_h5_dset_chunk(d, cd);
    if (rank < 0) return -1;
    if (rank != d->rank) return 0; /* contiguous or compact: no chunk cache */
    const double mib = 1048576.0;
    double chunk = (double)d->size, data = (double)d->size;
    for (int a = 0; a < rank; a++) {
        chunk *= (double)cd[a];
        data *= (double)d->dims[a];
    }
    if (chunk <= mib || chunk > 2 * data + mib) return 0;
    /* Closed first: HDF5 shares an open dataset's cache between its ids,
     * so a second open while d is open kept the default cache. */
    const int closed = close_ok(d->id, H5Dclose);
    d->id = H5I_INVALID_HID;
    if (!closed) return -1;
    const hid_t dapl = H5Pcreate(H5P_DATASET_ACCESS);
    if (dapl < 0) return -1;
    const herr_t set =
        H5Pset_chunk_cache(dapl, H5D_CHUNK_CACHE_NSLOTS_DEFAULT, (size_t)chunk, H5D_CHUNK_CACHE_W0_DEFAULT);
    const hid_t id = set < 0 ? H5I_INVALID_HID : H5Dopen2(loc, name, dapl);
    /* The same dataset of a file opened read-only: d's description holds.
     * Kept in d even when the list fails to close, so that the caller
     * closes it. */
    d->id = id;
    return close_ok(dapl, H5Pclose) && id >= 0 ? 0 : -1;
}
