/*
 * h5mut.h - a structure-aware mutator of HDF5 files for the fuzz targets.
 *
 * Byte-level fuzzing of an HDF5 file mostly breaks its metadata (checksums,
 * B-trees), so the loaders' own checks are rarely reached. Here the fuzzer's
 * input is a script of edits applied through the HDF5 library to a copy of
 * a real file (one of the seed files named in $FUZZ_H5_SEEDS, a directory):
 * write one element of a dataset or attribute, fill a whole dataset with one
 * value, give a dataset another length (down to 0, up to a lazily allocated
 * 2^36 rows that the file does not store), or delete a dataset or
 * attribute. Values are either raw bytes or, by class, the usual suspects
 * (0, -1, NaN, +-inf, 1e308, the integer limits). So every field a loader
 * reads gets forged values that are well-formed HDF5. Header-only: each
 * target includes it. Built by scripts/fuzz.
 */
#ifndef PDLA_TESTS_H5MUT_H
#define PDLA_TESTS_H5MUT_H

#include <dirent.h>
#include <hdf5.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_util.h"

#define H5MUT_MAX_SEEDS 16
#define H5MUT_MAX_OBJ 256
#define H5MUT_MAX_BYTES ((size_t)1 << 26) /* a dataset read whole for a resize */

typedef struct {
    unsigned char *data;
    size_t size;
} h5mut_file;

static h5mut_file h5mut_seeds[H5MUT_MAX_SEEDS];
static int h5mut_nseeds = -1;

static int h5mut_name_cmp(const struct dirent **a, const struct dirent **b)
{
    return strcmp((*a)->d_name, (*b)->d_name);
}

/* The seed files, read once: every regular file of $FUZZ_H5_SEEDS, in name
 * order (so an input picks the same seed on any file system and a crash
 * replays anywhere). */
static void h5mut_load_seeds(void)
{
    h5mut_nseeds = 0;
    const char *dir = getenv("FUZZ_H5_SEEDS");
    struct dirent **names = NULL;
    const int nn = dir ? scandir(dir, &names, NULL, h5mut_name_cmp) : -1;
    if (nn < 0) {
        fprintf(stderr, "h5mut: set FUZZ_H5_SEEDS to a directory of seed files\n");
        abort();
    }
    for (int k = 0; k < nn; k++) {
        const char *name = names[k]->d_name;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, name);
        FILE *f = name[0] != '.' && h5mut_nseeds < H5MUT_MAX_SEEDS ? fopen(path, "rb") : NULL;
        free(names[k]);
        if (!f) continue;
        h5mut_file *s = &h5mut_seeds[h5mut_nseeds];
        s->data = malloc(H5MUT_MAX_BYTES);
        s->size = s->data ? fread(s->data, 1, H5MUT_MAX_BYTES, f) : 0;
        fclose(f);
        unsigned char *fit = s->size ? realloc(s->data, s->size) : NULL; /* give back the rest */
        if (fit) s->data = fit;
        if (s->size) h5mut_nseeds++;
    }
    free(names);
    if (h5mut_nseeds == 0) {
        fprintf(stderr, "h5mut: no seed files in %s\n", dir);
        abort();
    }
}

/* The objects a script can name: datasets, and attributes of any object. */
typedef struct {
    char name[H5MUT_MAX_OBJ][256];
    char attr[H5MUT_MAX_OBJ][64]; /* "" for a dataset */
    int n;
} h5mut_list;

typedef struct {
    h5mut_list *l;
    const char *obj;
} h5mut_actx;

static herr_t h5mut_attr_cb(hid_t loc, const char *name, const H5A_info_t *info, void *u)
{
    (void)loc;
    (void)info;
    const h5mut_actx *c = u;
    h5mut_list *l = c->l;
    if (l->n >= H5MUT_MAX_OBJ || strlen(name) >= sizeof l->attr[0]) return 0;
    snprintf(l->name[l->n], sizeof l->name[0], "%s", c->obj);
    snprintf(l->attr[l->n], sizeof l->attr[0], "%s", name);
    l->n++;
    return 0;
}

static void h5mut_list_attrs(hid_t file, const char *obj, h5mut_list *l)
{
    h5mut_actx c = {l, obj};
    hsize_t idx = 0;
    H5Aiterate_by_name(file, obj, H5_INDEX_NAME, H5_ITER_INC, &idx, h5mut_attr_cb, &c, H5P_DEFAULT);
}

static herr_t h5mut_link_cb(hid_t g, const char *name, const H5L_info_t *info, void *u)
{
    h5mut_list *l = u;
    if (info->type != H5L_TYPE_HARD || l->n >= H5MUT_MAX_OBJ || strlen(name) + 2 >= sizeof l->name[0])
        return 0;
    char path[256];
    snprintf(path, sizeof path, "/%s", name);
    /* H5Oopen + H5Iget_type: the same on HDF5 1.10 and later (H5Oget_info's
     * struct changed in 1.12) */
    const hid_t o = H5Oopen(g, path, H5P_DEFAULT);
    const int is_dset = o >= 0 && H5Iget_type(o) == H5I_DATASET;
    if (o >= 0) H5Oclose(o);
    if (is_dset) {
        snprintf(l->name[l->n], sizeof l->name[0], "%s", path);
        l->attr[l->n][0] = '\0';
        l->n++;
    }
    h5mut_list_attrs(g, path, l);
    return 0;
}

static void h5mut_list_make(hid_t file, h5mut_list *l)
{
    l->n = 0;
    h5mut_list_attrs(file, "/", l);
    H5Lvisit(file, H5_INDEX_NAME, H5_ITER_INC, h5mut_link_cb, l);
}

/* One element's bytes for type t: a class-wise special value or raw bytes. */
static void h5mut_value(fuzz_in *in, hid_t t, unsigned char *buf, size_t sz)
{
    const unsigned sel = fuzz_byte(in) % 16;
    memset(buf, 0, sz);
    if (sel >= 11) {
        for (size_t i = 0; i < sz; i++) buf[i] = (unsigned char)fuzz_byte(in);
        return;
    }
    const H5T_class_t c = H5Tget_class(t);
    if (c == H5T_FLOAT && (sz == 8 || sz == 4)) {
        static const double fv[11] = {0, -0.0, 1, -1, NAN, INFINITY, -INFINITY, 1e308, -1e308, 5e-324, 0.5};
        if (sz == 8) memcpy(buf, &fv[sel], 8);
        else {
            const float f = (float)fv[sel];
            memcpy(buf, &f, 4);
        }
        return;
    }
    /* integers (and anything else): little-endian patterns, cut to size */
    static const uint64_t iv[11] = {0, 1, UINT64_MAX, INT64_MAX, (uint64_t)INT64_MIN, 2, 255,
                                    65536, (uint64_t)1 << 32, INT32_MAX, (uint64_t)INT32_MAX + 1};
    for (size_t i = 0; i < sz && i < 8; i++) buf[i] = (unsigned char)(iv[sel] >> (8 * i));
    if (sz > 8 && sel == 2) memset(buf, 0xff, sz);
    if (H5Tget_order(t) == H5T_ORDER_BE) /* the same number in the file's order */
        for (size_t i = 0; i < sz / 2; i++) {
            const unsigned char x = buf[i];
            buf[i] = buf[sz - 1 - i];
            buf[sz - 1 - i] = x;
        }
}

static int h5mut_plain(hid_t t) { return t >= 0 && H5Tdetect_class(t, H5T_VLEN) <= 0 && !H5Tis_variable_str(t); }

/* Write element (or, fill: every element) of dataset d. */
static void h5mut_dset_write(fuzz_in *in, hid_t d, uint32_t elem, int fill)
{
    const hid_t t = H5Dget_type(d), fs = H5Dget_space(d);
    const hssize_t np = fs >= 0 ? H5Sget_simple_extent_npoints(fs) : -1;
    if (h5mut_plain(t) && np > 0 && np <= (hssize_t)(H5MUT_MAX_BYTES / 64)) {
        const size_t sz = H5Tget_size(t);
        unsigned char one[256];
        if (sz <= sizeof one) {
            h5mut_value(in, t, one, sz);
            unsigned char *all = malloc((size_t)np * sz);
            if (all && H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, all) >= 0) {
                for (hssize_t i = 0; i < np; i++)
                    if (fill || (hssize_t)(elem % (uint32_t)np) == i) memcpy(all + (size_t)i * sz, one, sz);
                H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, all);
            }
            free(all);
        }
    }
    H5Sclose(fs);
    H5Tclose(t);
}

static void h5mut_attr_write(fuzz_in *in, hid_t file, const char *obj, const char *name, uint32_t elem)
{
    const hid_t a = H5Aopen_by_name(file, obj, name, H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0) return;
    const hid_t t = H5Aget_type(a), s = H5Aget_space(a);
    const hssize_t np = s >= 0 ? H5Sget_simple_extent_npoints(s) : -1;
    const size_t sz = t >= 0 ? H5Tget_size(t) : 0;
    if (h5mut_plain(t) && np > 0 && np < 65536 && sz && sz <= 256) {
        unsigned char *all = malloc((size_t)np * sz);
        if (all && H5Aread(a, t, all) >= 0) {
            h5mut_value(in, t, all + (size_t)(elem % (uint32_t)np) * sz, sz);
            H5Awrite(a, t, all);
        }
        free(all);
    }
    H5Sclose(s);
    H5Tclose(t);
    H5Aclose(a);
}

/* Replace dataset `name` by one of the same type whose first axis has a
 * new length (copying what fits); a huge length is chunked and never
 * written beyond the copy, so the file stays small. */
static void h5mut_resize(fuzz_in *in, hid_t file, const char *name)
{
    const hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
    if (d < 0) return;
    const hid_t t = H5Dget_type(d), fs = H5Dget_space(d);
    int rank = fs >= 0 ? H5Sget_simple_extent_ndims(fs) : -1;
    hsize_t dims[8] = {0};
    const size_t sz = t >= 0 ? H5Tget_size(t) : 0;
    const hssize_t np = fs >= 0 ? H5Sget_simple_extent_npoints(fs) : -1;
    if (rank < 1 || rank > 8 || !h5mut_plain(t) || np < 0 || !sz || (size_t)np * sz > H5MUT_MAX_BYTES) {
        H5Sclose(fs);
        H5Tclose(t);
        H5Dclose(d);
        return;
    }
    H5Sget_simple_extent_dims(fs, dims, NULL);
    unsigned char *old = malloc((size_t)np * sz + 1);
    const int ok = old && H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, old) >= 0;
    H5Dclose(d);
    const hsize_t n0 = dims[0];
    const unsigned how = fuzz_byte(in) % 7;
    const hsize_t n1 = how == 0 ? 0 : how == 1 ? 1 : how == 2 ? (n0 ? n0 - 1 : 0) : how == 3 ? n0 + 1
                     : how == 4 ? 2 * n0 + 3 : how == 5 ? ((hsize_t)1 << 36) : (uint32_t)fuzz_bytes(in, 4) % 100000;
    if (ok && H5Ldelete(file, name, H5P_DEFAULT) >= 0) {
        hsize_t nd[8];
        memcpy(nd, dims, sizeof nd);
        nd[0] = n1;
        const hid_t ns = H5Screate_simple(rank, nd, NULL);
        const hid_t pl = H5Pcreate(H5P_DATASET_CREATE);
        hsize_t ch[8];
        /* chunks of up to 2^20 rows: HDF5's index of a chunked dataset
         * has an entry per chunk, so 2^36 rows take 512 KiB of it (sparse
         * on disk), which every reader walks; smaller chunks would make
         * the file's own size, not its declared one, the slow part */
        for (int a = 0; a < rank; a++)
            ch[a] = nd[a] ? (nd[a] < ((hsize_t)1 << 20) ? nd[a] : ((hsize_t)1 << 20)) : 1;
        if (n1 > 4096) H5Pset_chunk(pl, rank, ch);
        const hid_t nd_id = H5Dcreate2(file, name, t, ns, H5P_DEFAULT, pl, H5P_DEFAULT);
        const hsize_t keep = n0 < n1 ? n0 : n1;
        if (nd_id >= 0 && keep > 0) {
            hsize_t start[8] = {0}, cnt[8];
            memcpy(cnt, nd, sizeof cnt);
            cnt[0] = keep;
            const hid_t ms = H5Screate_simple(rank, cnt, NULL);
            H5Sselect_hyperslab(ns, H5S_SELECT_SET, start, NULL, cnt, NULL);
            H5Dwrite(nd_id, t, ms, ns, H5P_DEFAULT, old);
            H5Sclose(ms);
        }
        if (nd_id >= 0) H5Dclose(nd_id);
        H5Pclose(pl);
        H5Sclose(ns);
    }
    free(old);
    H5Sclose(fs);
    H5Tclose(t);
}

static void h5mut_op(fuzz_in *in, hid_t file, const h5mut_list *l)
{
    const unsigned kind = fuzz_byte(in) % 5;
    const int k = (int)(fuzz_byte(in) % (unsigned)l->n);
    const uint32_t elem = (uint32_t)fuzz_bytes(in, 4);
    const int is_attr = l->attr[k][0] != '\0';
    if (kind == 3) { /* delete */
        if (is_attr) H5Adelete_by_name(file, l->name[k], l->attr[k], H5P_DEFAULT);
        else H5Ldelete(file, l->name[k], H5P_DEFAULT);
        return;
    }
    if (is_attr) {
        h5mut_attr_write(in, file, l->name[k], l->attr[k], elem);
        return;
    }
    if (kind == 2) {
        h5mut_resize(in, file, l->name[k]);
        return;
    }
    const hid_t d = H5Dopen2(file, l->name[k], H5P_DEFAULT);
    if (d < 0) return;
    h5mut_dset_write(in, d, elem, kind == 4);
    H5Dclose(d);
}

/* Write the seed file chosen by the input to path and apply the input's
 * edits. 0, or -1 when the copy could not be made (the target skips). */
static int h5mut_make(const uint8_t *data, size_t size, const char *path)
{
    if (h5mut_nseeds < 0) {
        h5mut_load_seeds();
        H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    }
    fuzz_in in = {data, size};
    const h5mut_file *s = &h5mut_seeds[fuzz_byte(&in) % (unsigned)h5mut_nseeds];
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (fwrite(s->data, 1, s->size, f) != s->size) abort();
    if (fclose(f)) abort();
    const hid_t file = H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT);
    if (file < 0) return 0; /* a seed that is not HDF5: the loader gets it as is */
    static h5mut_list l;
    h5mut_list_make(file, &l);
    for (int ops = 0; in.n > 0 && ops < 8 && l.n > 0; ops++) h5mut_op(&in, file, &l);
    H5Fclose(file);
    return 0;
}

#endif
