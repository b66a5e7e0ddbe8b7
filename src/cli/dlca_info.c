/*
 * dlca_info.c - `pdla info` for a DLCA cluster.h5 (root attribute
 * model = "dlca"): the parameters, results and series length, as text or
 * JSON.
 */
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "dlca_cmd.h"

int dlca_info_is_dlca(const char *path)
{
    struct stat st; /* never open a FIFO or device: HDF5 would block on it */
    if (stat(path, &st) || !S_ISREG(st.st_mode)) return 0;
    H5E_auto2_t fn;
    void *data;
    H5Eget_auto2(H5E_DEFAULT, &fn, &data);
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    int yes = 0;
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f >= 0) {
        if (H5Aexists(f, "model") > 0) {
            const hid_t a = H5Aopen(f, "model", H5P_DEFAULT);
            const hid_t t = a >= 0 ? H5Aget_type(a) : -1;
            const hid_t sp = a >= 0 ? H5Aget_space(a) : -1;
            const int one = sp >= 0 && H5Sget_simple_extent_npoints(sp) == 1; /* buf holds one string */
            if (sp >= 0) H5Sclose(sp);
            char buf[16] = "";
            if (t >= 0 && one && H5Tget_class(t) == H5T_STRING && !H5Tis_variable_str(t) && H5Tget_size(t) < sizeof buf) {
                const hid_t mt = H5Tcopy(t);
                if (mt >= 0 && H5Aread(a, mt, buf) >= 0) yes = strncmp(buf, "dlca", 4) == 0;
                if (mt >= 0) H5Tclose(mt);
            }
            if (t >= 0) H5Tclose(t);
            if (a >= 0) H5Aclose(a);
        }
        H5Fclose(f);
    }
    H5Eset_auto2(H5E_DEFAULT, fn, data);
    return yes;
}

typedef struct it_ctx {
    FILE *o;
    int json, first;
} it_ctx;

/* Print one attribute (number, string or number array). */
static herr_t print_attr(hid_t loc, const char *name, const H5A_info_t *info, void *op)
{
    (void)info;
    it_ctx *c = op;
    const hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
    if (a < 0) return -1;
    const hid_t t = H5Aget_type(a), sp = H5Aget_space(a);
    const H5T_class_t cls = H5Tget_class(t);
    const hssize_t n = H5Sget_simple_extent_npoints(sp);
    herr_t rc = 0;
    if (c->json) fprintf(c->o, "%s\n    \"%s\": ", c->first ? "" : ",", name);
    else fprintf(c->o, "  %-22s ", name);
    c->first = 0;
    if (cls == H5T_STRING) {
        char buf[4096] = "";
        const hid_t mt = H5Tcopy(t);
        if (n == 1 && !H5Tis_variable_str(t) && H5Tget_size(t) < sizeof buf && H5Aread(a, mt, buf) >= 0) {
            if (c->json) { /* escaped: a file's strings are not trusted */
                fputc('"', c->o);
                for (const unsigned char *q = (const unsigned char *)buf; *q; q++)
                    if (*q == '"' || *q == '\\') fprintf(c->o, "\\%c", *q);
                    else if (*q < 0x20) fprintf(c->o, "\\u%04x", *q);
                    else fputc(*q, c->o);
                fputc('"', c->o);
            } else fputs(buf, c->o);
        } else if (c->json) fputs("null", c->o);
        H5Tclose(mt);
    } else if (cls == H5T_INTEGER && n >= 1 && n <= 8) {
        /* Integers exactly (a u64 digest does not survive a double). */
        const int sgn = H5Tget_sign(t) == H5T_SGN_2;
        unsigned long long v[8];
        if (H5Aread(a, sgn ? H5T_NATIVE_LLONG : H5T_NATIVE_ULLONG, v) < 0) rc = -1;
        if (n > 1) fputs(c->json ? "[" : "", c->o);
        for (hssize_t i = 0; i < n && rc == 0; i++) {
            if (i) fputs(c->json ? ", " : "x", c->o);
            if (sgn) fprintf(c->o, "%lld", (long long)v[i]);
            else fprintf(c->o, "%llu", v[i]);
        }
        if (n > 1) fputs(c->json ? "]" : "", c->o);
    } else if (n >= 1 && n <= 8) {
        double v[8];
        if (H5Aread(a, H5T_NATIVE_DOUBLE, v) < 0) rc = -1;
        if (n > 1) fputs(c->json ? "[" : "", c->o);
        for (hssize_t i = 0; i < n && rc == 0; i++) {
            if (i) fputs(c->json ? ", " : "x", c->o);
            if (isfinite(v[i])) fprintf(c->o, "%.10g", v[i]);
            else fputs(c->json ? "null" : "nan", c->o);
        }
        if (n > 1) fputs(c->json ? "]" : "", c->o);
    }
    else if (cls != H5T_STRING && !(n >= 1 && n <= 8) && c->json) fputs("null", c->o);
    if (!c->json) fputc('\n', c->o);
    H5Sclose(sp);
    H5Tclose(t);
    H5Aclose(a);
    return rc;
}

static int print_group(FILE *o, hid_t f, const char *g, int json, int last)
{
    const hid_t gid = H5Gopen2(f, g, H5P_DEFAULT);
    if (gid < 0) return -1;
    it_ctx c = {o, json, 1};
    fprintf(o, json ? "  \"%s\": {" : "%s:\n", g);
    hsize_t idx = 0;
    const herr_t rc = H5Aiterate2(gid, H5_INDEX_NAME, H5_ITER_INC, &idx, print_attr, &c);
    if (json) fprintf(o, "\n  }%s\n", last ? "" : ",");
    H5Gclose(gid);
    return rc < 0 ? -1 : 0;
}

int dlca_info_main(const char *path, int json)
{
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla info: cannot open %s\n", path);
        return 2;
    }
    long long rows = -1;
    const hid_t d = H5Dopen2(f, "/series/t", H5P_DEFAULT);
    if (d >= 0) {
        const hid_t sp = H5Dget_space(d);
        rows = (long long)H5Sget_simple_extent_npoints(sp);
        H5Sclose(sp);
        H5Dclose(d);
    }
    FILE *o = stdout;
    int rc = 0;
    if (json) fprintf(o, "{\n  \"model\": \"dlca\",\n  \"series_rows\": %lld,\n", rows);
    else fprintf(o, "%s: model dlca, %lld series rows\n", path, rows);
    if (print_group(o, f, "parameters", json, 0) || print_group(o, f, "results", json, 0) ||
        print_group(o, f, "Code", json, 1)) {
        fprintf(stderr, "pdla info: %s: cannot read its attributes\n", path);
        rc = 1;
    }
    if (json) fprintf(o, "}\n");
    H5Fclose(f);
    if (fflush(o) || ferror(o)) rc = 1;
    return rc;
}
