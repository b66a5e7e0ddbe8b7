/*
 * event_info.c - `pdla info FILE` for a cluster.h5 of the event model: the
 * root, /parameters and /results attributes, the cluster and free counts and
 * the last series row, as text or (--json) JSON.
 */
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "event_cmd.h"
#include "pdla/event.h"
#include "pdla/h5check.h"
#include "tools.h"

static const char *file_arg(int argc, char **argv, int *json)
{
    const char *f = NULL;
    *json = 0;
    static const char *valued[] = {"-o", "--output", "--size", "--color", "--axis", "--zoom",
                                    "--slab-rows", "--csv", "--bins", NULL};
    for (int k = 1; k < argc; k++) {
        if (!strcmp(argv[k], "--json")) *json = 1;
        int v = 0;
        for (int q = 0; valued[q]; q++) v |= !strcmp(argv[k], valued[q]);
        if (v) k++;
        else if (argv[k][0] != '-' && !f) f = argv[k];
    }
    return f;
}

/* Root attribute model == "event"? Quiet on any failure. */
int event_info_wanted(int argc, char **argv)
{
    int json;
    const char *path = file_arg(argc, argv, &json);
    if (!path) return 0;
    /* Only a regular file can be ours: never open a FIFO or device here
     * (opening a FIFO blocks); the general tools report those. */
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode)) return 0;
    char model[64];
    return pdla_h5_file_model(path, model, sizeof model) == 0 && strcmp(model, "event") == 0;
}

/* An event file that is not a cluster file (a checkpoint: the only event
 * file with a root "format") is bad input to every reader: one line, 1
 * (exit 2). Before, analyze took it for a damaged cluster file (exit 1)
 * while info and render refused it (exit 2). */
int event_checkpoint_refused(const char *tool, int argc, char **argv)
{
    int json;
    const char *path = file_arg(argc, argv, &json);
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return 0; /* the reader says why */
    pdla_h5_value v;
    const int has = H5Aexists(f, "format") > 0 && pdla_h5_attr_value(f, "format", &v) == 0;
    /* A close that fails leaves the file to the reader, which opens it again and reports. */
    if (H5Fclose(f) < 0 || !has) return 0;
    fprintf(stderr, "pdla %s: %s is not a pdla cluster file (format = \"%.200s\"; an event checkpoint "
                    "continues with pdla --model event --resume)\n",
            tool, path, v.read && v.kind == 's' ? v.s : "?");
    return 1;
}

typedef struct pr {
    FILE *o;
    int json, first;
} pr;

static herr_t print_attr(hid_t loc, const char *name, const H5A_info_t *info, void *u)
{
    (void)info;
    pr *p = u;
    pdla_h5_value v;
    if (pdla_h5_attr_value(loc, name, &v) < 0) return -1;
    char val[1100] = "?";
    int isstr = 0;
    if (v.n == 1 && v.kind == 's') {
        if (v.read) snprintf(val, sizeof val, "%.1023s", v.s);
        isstr = 1;
    } else if (v.n == 1 && v.kind == 'u') {
        if (v.read) snprintf(val, sizeof val, "%llu", (unsigned long long)v.u[0]);
    } else if (v.n == 1 && v.kind == 'i') {
        if (v.read) snprintf(val, sizeof val, "%lld", (long long)v.i[0]);
    } else if (v.n == 1 && v.kind == 'f') {
        const double x = v.f[0];
        if (v.read && isfinite(x)) {
            snprintf(val, sizeof val, "%.10g", x);
        } else if (v.read) {
            snprintf(val, sizeof val, "%s", x != x ? "NaN" : x > 0 ? "Infinity" : "-Infinity");
            isstr = p->json;
        }
    } else {
        isstr = 1;
        snprintf(val, sizeof val, "(array of %lld)", (long long)v.n);
    }
    if (p->json) {
        fprintf(p->o, "%s\n    ", p->first ? "" : ",");
        tool_json_str(p->o, name); /* a forged file's attribute names too */
        fputs(": ", p->o);
        if (isstr) {
            tool_json_str(p->o, val);
        } else {
            fputs(val, p->o);
        }
    } else {
        fprintf(p->o, "  %-22s %s\n", name, val);
    }
    p->first = 0;
    return 0;
}

static int group(FILE *o, hid_t f, const char *g, int json, int last)
{
    const hid_t id = H5Oopen(f, g, H5P_DEFAULT);
    if (id < 0) return -1;
    pr p = {o, json, 1};
    if (json) fprintf(o, "  \"%s\": {", g[1] ? g + 1 : "root");
    else fprintf(o, "%s\n", g);
    hsize_t idx = 0;
    const herr_t rc = H5Aiterate2(id, H5_INDEX_NAME, H5_ITER_INC, &idx, print_attr, &p);
    if (json) fprintf(o, "\n  }%s\n", last ? "" : ",");
    const herr_t closed = H5Oclose(id);
    return rc < 0 || closed < 0 ? -1 : 0;
}

static long long rows(hid_t f, const char *ds)
{
    pdla_h5_dset d;
    if (pdla_h5_dset_open(f, ds, &d) < 0) return -1;
    return pdla_h5_dset_close(&d) < 0 ? -1 : (long long)d.dims[0];
}

/* One column of /species as doubles (at most EV_MAX_SPECIES rows, the
 * kinds a run may have): its length, 0 when absent (an older file has no
 * `sticky`), -1 when /species or the column cannot be read, is not rank 1
 * or has more rows. */
static int species_col(hid_t f, const char *name, double *v)
{
    const htri_t has_sp = H5Lexists(f, "/species", H5P_DEFAULT);
    if (has_sp <= 0) return has_sp < 0 ? -1 : 0;
    char path[64];
    snprintf(path, sizeof path, "/species/%s", name);
    const htri_t has = H5Lexists(f, path, H5P_DEFAULT);
    if (has <= 0) return has < 0 ? -1 : 0;
    pdla_h5_dset d;
    if (pdla_h5_dset_open(f, path, &d) < 0) return -1;
    int n = -1;
    if (d.rank == 1 && d.dims[0] <= EV_MAX_SPECIES && pdla_h5_dset_stored(&d, 8) == PDLA_H5_STORED &&
        pdla_h5_dset_read(&d, PDLA_H5_F64, 0, d.dims[0], v) == 0)
        n = (int)d.dims[0];
    return pdla_h5_dset_close(&d) < 0 ? -1 : n;
}

/* The per-kind table of /species: count, radius, density, stuck, sticky. */
typedef struct sp_table {
    int n; /* kinds; 0: no table to show */
    double v[5][EV_MAX_SPECIES];
} sp_table;

/* Reads the table before anything is printed: 0 (t->n 0 when the file has
 * none), or -1 when it is malformed: a column unreadable, of another
 * length than the others, or of more rows than EV_MAX_SPECIES (9 rows gave
 * half a JSON object and "cannot read its attributes", exit 1). A file
 * without `sticky` was written before bath kinds: all stuck on contact. */
static int species_read(hid_t f, sp_table *t)
{
    static const char *const col[] = {"count", "radius", "density", "stuck", "sticky"};
    int n = -2;
    t->n = 0;
    for (int c = 0; c < 5; c++) {
        const int m = species_col(f, col[c], t->v[c]);
        if (m < 0) return -1;
        if (m == 0 && c < 4) return c == 0 ? 0 : -1; /* no table, or half of one */
        if (c == 4 && m == 0)
            for (int k = 0; k < n; k++) t->v[4][k] = 1;
        else if (n == -2) n = m;
        else if (m != n) return -1;
    }
    t->n = n;
    return 0;
}

static void species_print(FILE *o, const sp_table *t, int json)
{
    if (!t->n) return;
    if (json) fprintf(o, "  \"species\": [");
    else fprintf(o, "/species\n");
    for (int k = 0; k < t->n; k++) {
        if (json) {
            /* a forged table's NaN or inf as null: JSON has no such numbers */
            static const char *const key[4] = {"count", "radius", "density", "stuck"};
            fprintf(o, "%s\n    {", k ? "," : "");
            for (int c = 0; c < 4; c++) {
                fprintf(o, "\"%s\": ", key[c]);
                if (isfinite(t->v[c][k])) fprintf(o, "%.17g, ", t->v[c][k]);
                else fputs("null, ", o);
            }
            fprintf(o, "\"sticky\": %d}", t->v[4][k] != 0);
        } else
            fprintf(o, "  kind %d: count %.10g radius %.10g density %.10g stuck %.10g sticky %d%s\n", k + 1,
                    t->v[0][k], t->v[1][k], t->v[2][k], t->v[3][k], t->v[4][k] != 0, t->v[4][k] != 0 ? "" : " (bath)");
    }
    if (json) fprintf(o, "\n  ],\n");
}

int event_info_main(int argc, char **argv)
{
    int json;
    const char *path = file_arg(argc, argv, &json);
    const hid_t f = pdla_hdf5_quiet() ? H5I_INVALID_HID : H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
        fprintf(stderr, "pdla info: cannot open %s\n", path);
        return 2;
    }
    const long long ns = rows(f, "/cluster/positions"), nf = rows(f, "/free/positions"),
                    nr = rows(f, "/series/time");
    int rc = 0;
    sp_table spt;
    /* everything checked before the first line is printed */
    if (ns < 0 || nf < 0 || nr < 0 || species_read(f, &spt)) {
        if (ns < 0 || nf < 0 || nr < 0) fprintf(stderr, "pdla info: %s: malformed event file (missing datasets)\n", path);
        else fprintf(stderr, "pdla info: %s: malformed event file (a /species table unreadable, of columns of "
                             "different lengths or of more than %d kinds)\n", path, EV_MAX_SPECIES);
        (void)H5Fclose(f); /* the error to report is the one above */
        return 2;
    }
    if (json) { /* the path escaped: a name with " or \\ made the whole JSON unreadable */
        fputs("{\n  \"file\": ", stdout);
        tool_json_str(stdout, path);
        fprintf(stdout, ",\n  \"stuck\": %lld,\n  \"free\": %lld,\n  \"series_rows\": %lld,\n", ns, nf, nr);
    }
    else fprintf(stdout, "%s: event model, %lld stuck, %lld free, %lld series rows\n", path, ns, nf, nr);
    if (group(stdout, f, "/", json, 0) || group(stdout, f, "/parameters", json, 0) ||
        group(stdout, f, "/results", json, 0))
        rc = 1;
    if (!rc) species_print(stdout, &spt, json);
    if (!rc && group(stdout, f, "/Code", json, 1)) rc = 1;
    if (json) fprintf(stdout, "}\n");
    if (rc) fprintf(stderr, "pdla info: %s: cannot read its attributes\n", path);
    if (H5Fclose(f) < 0) {
        fprintf(stderr, "pdla info: %s: cannot close it\n", path);
        rc = 1;
    }
    if (fflush(stdout)) rc = 1;
    return rc;
}
