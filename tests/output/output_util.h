/*
 * output_util.h - helpers shared by the output tests: grow a small cluster,
 * make and remove a scratch directory, read a whole file, and read scalar
 * HDF5 attributes back with the plain C API.
 */
#ifndef PDLA_TESTS_OUTPUT_UTIL_H
#define PDLA_TESTS_OUTPUT_UTIL_H

#include <dirent.h>
#include <hdf5.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "pdla/h5check.h"
#include "pdla/pdla.h"

/* Creates and grows an engine; NULL (after printing why) on failure. */
static inline pdla_engine *grow_engine(int dim, uint64_t target, uint64_t seed,
                                       pdla_return_mode mode, int rg_per_decade)
{
    pdla_params p;
    pdla_params_default(&p);
    p.dim = dim;
    p.target = target;
    p.seed = seed;
    p.return_mode = mode;
    p.rg_per_decade = rg_per_decade;
    pdla_engine *e = NULL;
    char err[256];
    if (pdla_engine_create(&e, &p, err, sizeof err) != 0) {
        fprintf(stderr, "engine_create: %s\n", err);
        return NULL;
    }
    if (pdla_engine_grow(e, target, NULL, 0, NULL, err, sizeof err) != 0) {
        fprintf(stderr, "engine_grow: %s\n", err);
        pdla_engine_destroy(e);
        return NULL;
    }
    return e;
}

/* dir/name into buf. Scratch paths are short; a path that does not fit
 * ends the test (status 1) rather than run on a cut name. */
static inline const char *join(char *buf, size_t cap, const char *dir, const char *name)
{
    if (snprintf(buf, cap, "%s/%s", dir, name) >= (int)cap) {
        fprintf(stderr, "path too long: %s/%s\n", dir, name);
        exit(1);
    }
    return buf;
}

/* A fresh directory under $TMPDIR (or /tmp); path into buf. */
static inline int make_scratch(char *buf, size_t cap)
{
    const char *t = getenv("TMPDIR");
    snprintf(buf, cap, "%s/pdla-output-XXXXXX", t && *t ? t : "/tmp");
    return mkdtemp(buf) ? 0 : -1;
}

/* Removes a scratch directory: its files and subdirectories one level deep
 * (all the tests make). */
static inline void remove_scratch(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    const struct dirent *de;
    char p[4096];
    while ((de = readdir(d)) != NULL) {
        if (!strcmp(de->d_name, ".") || !strcmp(de->d_name, "..")) continue;
        if (snprintf(p, sizeof p, "%s/%s", dir, de->d_name) >= (int)sizeof p) continue;
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode)) {
            chmod(p, 0700);
            remove_scratch(p);
        } else {
            unlink(p);
        }
    }
    closedir(d);
    rmdir(dir);
}

/* Whole file into a malloc'ed buffer; NULL on failure. */
static inline unsigned char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    unsigned char *buf = NULL;
    long n = -1;
    if (fseek(f, 0, SEEK_END) == 0) n = ftell(f);
    if (n >= 0 && fseek(f, 0, SEEK_SET) == 0 && (buf = malloc((size_t)n + 1)) != NULL &&
        fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    if (buf) *len = (size_t)n;
    return buf;
}

/* Entries of dir whose name contains `part`. */
static inline int count_entries_with(const char *dir, const char *part)
{
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    const struct dirent *de;
    while ((de = readdir(d)) != NULL)
        if (strstr(de->d_name, part)) n++;
    closedir(d);
    return n;
}

/* The attribute readers below go through the library's checked readers
 * (pdla/h5check.h), the one HDF5 reading layer (issue 9): an attribute is
 * read only when it holds exactly the one element asked for. */
static inline pdla_h5_type h5check_type_of(hid_t mtype)
{
    if (H5Tequal(mtype, H5T_NATIVE_DOUBLE) > 0) return PDLA_H5_F64;
    if (H5Tequal(mtype, H5T_NATIVE_UINT64) > 0) return PDLA_H5_U64;
    if (H5Tequal(mtype, H5T_NATIVE_INT64) > 0) return PDLA_H5_I64;
    if (H5Tequal(mtype, H5T_NATIVE_UINT32) > 0) return PDLA_H5_U32;
    if (H5Tequal(mtype, H5T_NATIVE_UINT8) > 0) return PDLA_H5_U8;
    if (H5Tequal(mtype, H5T_NATIVE_INT8) > 0) return PDLA_H5_I8;
    return PDLA_H5_I32; /* H5T_NATIVE_INT */
}

/* One-element numeric attribute of the object at `obj` (a path in file),
 * read as mtype; 0 on success. */
static inline int read_attr(hid_t file, const char *obj, const char *name, hid_t mtype, void *out)
{
    const hid_t o = H5Oopen(file, obj, H5P_DEFAULT);
    if (o < 0) return -1;
    const int rc = pdla_h5_attr_number(o, name, h5check_type_of(mtype), out) == 0 ? 0 : -1;
    H5Oclose(o);
    return rc;
}

/* One string attribute into buf (terminated, cut to cap). */
static inline int read_attr_str(hid_t file, const char *obj, const char *name, char *buf,
                                size_t cap)
{
    buf[0] = '\0';
    const hid_t o = H5Oopen(file, obj, H5P_DEFAULT);
    if (o < 0) return -1;
    const int rc = pdla_h5_attr_str(o, name, buf, cap) >= 0 ? 0 : -1;
    H5Oclose(o);
    return rc;
}

#endif
