/*
 * dlca_info.c - `pdla info` for a DLCA cluster.h5 (root attribute
 * model = "dlca"): the parameters, results and series length, as text or
 * JSON.
 */
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "dlca_cmd.h"
#include "pdla/h5check.h"
#include "tools.h"

int dlca_info_is_dlca(const char *path)
{
    char model[16];
    return pdla_h5_file_model(path, model, sizeof model) == 0 && strcmp(model, "dlca") == 0;
}

typedef struct it_ctx {
    FILE *o;
    int json, first;
} it_ctx;

/* Print one attribute (number, string or number array of up to 8). */
static herr_t print_attr(hid_t loc, const char *name, const H5A_info_t *info, void *op)
{
    (void)info;
    it_ctx *c = op;
    pdla_h5_value v;
    if (pdla_h5_attr_value(loc, name, &v) < 0) return -1;
    herr_t rc = 0;
    if (c->json) {
        fprintf(c->o, "%s\n    ", c->first ? "" : ",");
        tool_json_str(c->o, name); /* a forged file's attribute names too */
        fputs(": ", c->o);
    }
    else fprintf(c->o, "  %-22s ", name);
    c->first = 0;
    if (v.kind == 's' && v.read && !v.cut) {
        if (c->json) tool_json_str(c->o, v.s);
        else fputs(v.s, c->o);
    } else if (v.kind && v.kind != 's' && v.read) {
        if (v.n > 1) fputs(c->json ? "[" : "", c->o);
        for (int64_t i = 0; i < v.n; i++) {
            if (i) fputs(c->json ? ", " : "x", c->o);
            /* Integers exactly (a u64 digest does not survive a double). */
            if (v.kind == 'i') fprintf(c->o, "%lld", (long long)v.i[i]);
            else if (v.kind == 'u') fprintf(c->o, "%llu", (unsigned long long)v.u[i]);
            else if (isfinite(v.f[i])) fprintf(c->o, "%.10g", v.f[i]);
            else fputs(c->json ? "null" : "nan", c->o);
        }
        if (v.n > 1) fputs(c->json ? "]" : "", c->o);
    } else if (v.kind && v.kind != 's' && v.n >= 1 && v.n <= PDLA_H5_MAX_ELEMS) {
        rc = -1; /* a number HDF5 could not read: the file is damaged */
    } else if (c->json) {
        fputs("null", c->o);
    }
    if (!c->json) fputc('\n', c->o);
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
    const herr_t closed = H5Gclose(gid);
    return rc < 0 || closed < 0 ? -1 : 0;
}

int dlca_info_main(const char *path, int json)
{
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla info: cannot open %s\n", path);
        return 2;
    }
    long long rows = -1;
    pdla_h5_dset d;
    if (pdla_h5_dset_open(f, "/series/t", &d) == 0) {
        rows = pdla_h5_dset_close(&d) == 0 ? (long long)d.elems : -1;
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
    if (H5Fclose(f) < 0) {
        fprintf(stderr, "pdla info: %s: cannot close it\n", path);
        rc = 1;
    }
    if (fflush(o) || ferror(o)) rc = 1;
    return rc;
}
