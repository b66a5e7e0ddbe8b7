/*
 * test_dlca_params.c PDLA - walks the DLCA rows of the parameter table
 * (dlca_param_table, pdla/params.h) and checks every row end to end through
 * the real binary, so that a row added later is tested without a new test:
 *   - the row: applies to DLCA, a unique bit, texts present, its example
 *     parses, differs from the default and is valid;
 *   - `pdla --model dlca --help` lists --OPTION with its default;
 *   - CLI -> cluster.h5 /parameters: the attribute read back through the
 *     table holds the example; a scene key gives the same file value;
 *   - -> checkpoint -> resume: the checkpoint holds the example; resuming
 *     with another value is accepted exactly for the resumable rows and
 *     refused (exit 2, one line naming the row's label) for the others;
 *   - an out-of-range value derived from the row's range exits 2 with one
 *     stderr line naming --OPTION, and makes no run directory.
 */
#include "../check.h"

#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "params_h5.h"
#include "pdla/dlca.h"
#include "pdla/params.h"

static const char *pdla_exe;
static char tmp[64];

/* A small, quick run every row's example fits: 3D-ready cubic box. */
static const char *base = "--box 24 --fill 0.05 --until-clusters 5 --max-attempts 300000 --seed 9";

/* Run `pdla --model dlca ARGS` quietly; the exit status; stderr in tmp/err. */
static int run(const char *args)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "'%s' --model dlca %s -q >/dev/null 2>'%s/err'", pdla_exe, args, tmp);
    const int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

static int err_lines(char *text, size_t len)
{
    char path[128];
    snprintf(path, sizeof path, "%s/err", tmp);
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    const size_t n = fread(text, 1, len - 1, f);
    fclose(f);
    text[n] = '\0';
    int lines = 0;
    for (size_t i = 0; i < n; i++) lines += text[i] == '\n';
    return lines;
}

/* Row d of the /parameters group of file path into s; 0 or -1. */
static int read_row(const char *path, const pdla_param_desc *d, dlca_params *s)
{
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return -1;
    const hid_t g = H5Gopen2(f, "parameters", H5P_DEFAULT);
    int rc = -1;
    if (g >= 0) {
        int32_t dim = 0; /* a box row reads as many lengths as dim says */
        const hid_t a = H5Aopen(g, "dim", H5P_DEFAULT);
        if (a >= 0 && H5Aread(a, H5T_NATIVE_INT32, &dim) >= 0) s->dim = dim;
        if (a >= 0) H5Aclose(a);
        rc = pdla_param_read_h5(g, d, s);
        H5Gclose(g);
    }
    H5Fclose(f);
    return rc;
}

/* A value the row's range refuses, as text. */
static void out_of_range(const pdla_param_desc *d, char *buf, size_t len)
{
    switch (d->type) {
    case PDLA_PT_REAL:
        if (d->hi_r < 1e300) snprintf(buf, len, "%.17g", d->hi_open ? d->hi_r : d->hi_r + fabs(d->hi_r) + 1);
        else snprintf(buf, len, "%.17g", d->lo_r - 1);
        break;
    case PDLA_PT_CHOICE: snprintf(buf, len, "nosuch"); break;
    case PDLA_PT_BOX: snprintf(buf, len, "%llu", (unsigned long long)d->lo_u - 1); break;
    default:
        if (d->hi_u < UINT32_MAX) snprintf(buf, len, "%llu", (unsigned long long)d->hi_u + 1);
        else if (d->lo_u > 0) snprintf(buf, len, "%llu", (unsigned long long)d->lo_u - 1);
        else snprintf(buf, len, "-1");
    }
}

static void check_row(const pdla_param_desc *d, uint32_t *seen, const char *help)
{
    CHECK(d->models & PDLA_MODEL_DLCA, "%s: not a DLCA row", d->name);
    CHECK(d->bit && !(*seen & d->bit), "%s: bit zero or shared", d->name);
    *seen |= d->bit;
    CHECK(d->label && d->unit && d->help && d->group && d->example && d->metavar, "%s: a text is missing", d->name);
    dlca_params def, ex;
    dlca_params_default(&def);
    ex = def;
    char err[512], want[128], v[64];
    if (d->type == PDLA_PT_BOX) ex.dim = 2; /* the example box has two lengths */
    CHECK(dlca_param_set(&ex, d, d->example, err, sizeof err) == 0, "%s: example '%s': %s", d->name, d->example, err);
    CHECK(!pdla_param_equal(d, &ex, &def), "%s: example equals the default", d->name);
    pdla_param_format(d, &def, 0, v, sizeof v);
    snprintf(want, sizeof want, "  --%s %s", d->option, d->metavar);
    const char *at = strstr(help, want), *end = at ? strchr(at, '\n') : NULL;
    char dflt[96];
    snprintf(dflt, sizeof dflt, "[default %s]", v);
    const char *found = at ? strstr(at, dflt) : NULL;
    CHECK(at && found && found < end, "%s: --help lacks '%s' with '%s'", d->name, want, dflt);
}

/* CLI and scene -> cluster.h5 -> checkpoint -> resume. */
static void check_files(const pdla_param_desc *d)
{
    char args[1024], dir[128], path[256], err[1024];
    const char *extra = d->type == PDLA_PT_BOX ? "--dim 2" : "";
    snprintf(dir, sizeof dir, "%s/%s", tmp, d->name);
    snprintf(args, sizeof args, "%s %s --%s %s --out %s --checkpoint", base, extra, d->option, d->example, dir);
    int rc = run(args);
    CHECK(rc == 0, "%s: run exit %d", d->name, rc);
    dlca_params ex, got, ck;
    dlca_params_default(&ex);
    if (d->type == PDLA_PT_BOX) ex.dim = 2;
    (void)dlca_param_set(&ex, d, d->example, err, sizeof err);
    got = ck = ex;
    snprintf(path, sizeof path, "%s/cluster.h5", dir);
    CHECK(read_row(path, d, &got) == 0 && pdla_param_equal(d, &got, &ex), "%s: cluster.h5 /parameters", d->name);
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    CHECK(read_row(path, d, &ck) == 0 && pdla_param_equal(d, &ck, &ex), "%s: checkpoint /parameters", d->name);
    /* The scene key names the same row (written with '_' for '-'). */
    char scene[128], key[64], sdir[128];
    snprintf(scene, sizeof scene, "%s/scene", tmp);
    snprintf(sdir, sizeof sdir, "%s/%s-scene", tmp, d->name);
    snprintf(key, sizeof key, "%s", d->option);
    for (char *c = key; *c; c++)
        if (*c == '-') *c = '_';
    FILE *f = fopen(scene, "w");
    if (f) {
        /* the base run's keys, but the row's own: a scene may not give a
         * key twice (scene.h, as the DLA command's scenes) */
        static const char *const base_keys[][2] = {{"box", "24"}, {"fill", "0.05"}, {"until_clusters", "5"},
                                                   {"max_attempts", "300000"}, {"seed", "9"}};
        fprintf(f, "model = dlca\n");
        for (size_t b = 0; b < sizeof base_keys / sizeof base_keys[0]; b++)
            if (strcmp(base_keys[b][0], key)) fprintf(f, "%s = %s\n", base_keys[b][0], base_keys[b][1]);
        fprintf(f, "%s%s = %s\nout = %s\n", d->type == PDLA_PT_BOX ? "dim = 2\n" : "", key, d->example, sdir);
        fclose(f);
    }
    snprintf(args, sizeof args, "--scene %s", scene);
    rc = run(args);
    got = ex;
    snprintf(path, sizeof path, "%s/cluster.h5", sdir);
    CHECK(rc == 0 && read_row(path, d, &got) == 0 && pdla_param_equal(d, &got, &ex), "%s: scene key %s (exit %d)",
          d->name, key, rc);
    /* Resume asking the default: the resumable rows take it, the others
     * are refused naming the row. */
    dlca_params def;
    dlca_params_default(&def);
    if (d->type == PDLA_PT_BOX) def.dim = 2;
    char v[64];
    pdla_param_format(d, &def, 1, v, sizeof v);
    snprintf(args, sizeof args, "--resume %s --%s %s", dir, d->option, v);
    rc = run(args);
    char text[2048];
    const int lines = err_lines(text, sizeof text);
    if (d->resumable) CHECK(rc == 0, "%s: resumable, but --resume with %s: exit %d %s", d->name, v, rc, text);
    else
        CHECK(rc == 2 && lines == 1 && strstr(text, d->label), "%s: --resume with another value: exit %d, %s",
              d->name, rc, text);
}

static void check_refused(const pdla_param_desc *d)
{
    char bad[64], args[1024], dir[128], text[2048];
    out_of_range(d, bad, sizeof bad);
    snprintf(dir, sizeof dir, "%s/refused", tmp);
    snprintf(args, sizeof args, "%s --%s %s --out %s", base, d->option, bad, dir);
    const int rc = run(args);
    const int lines = err_lines(text, sizeof text);
    char opt[80];
    snprintf(opt, sizeof opt, "--%s", d->option);
    struct stat st;
    CHECK(rc == 2 && lines == 1 && strstr(text, opt) && stat(dir, &st) != 0,
          "%s: out-of-range %s: exit %d, %d lines: %s", d->name, bad, rc, lines, text);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s PDLA\n", argv[0]);
        return 2;
    }
    pdla_exe = argv[1];
    snprintf(tmp, sizeof tmp, "/tmp/dlca-params-XXXXXX");
    if (!mkdtemp(tmp)) return 1;
    char cmd[512], help[16384] = "";
    snprintf(cmd, sizeof cmd, "'%s' --model dlca --help", pdla_exe);
    FILE *p = popen(cmd, "r");
    if (p) {
        const size_t n = fread(help, 1, sizeof help - 1, p);
        help[n] = '\0';
        pclose(p);
    }
    size_t n;
    const pdla_param_desc *t = dlca_param_table(&n);
    uint32_t seen = 0;
    for (size_t i = 0; i < n; i++) {
        check_row(&t[i], &seen, help);
        check_files(&t[i]);
        check_refused(&t[i]);
    }
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmp);
    if (system(cmd)) fprintf(stderr, "cannot remove %s\n", tmp);
    return check_finish();
}
