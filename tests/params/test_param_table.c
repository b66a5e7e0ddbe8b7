/*
 * test_param_table.c - walks the parameter table (include/pdla/params.h) and
 * checks every row end to end, so that a parameter added to the table is
 * tested without writing a test for it:
 *   - the row itself: a unique bit, applies to DLA, a valid default, an
 *     example value that differs from the default and is valid, the union of
 *     resumable bits equal to PDLA_PARAM_RESUMABLE;
 *   - --help lists its option (with its default when the row says so);
 *   - a scene key sets it to the same value as the option does;
 *   - CLI -> params -> cluster.h5 /parameters: the attribute holds the value;
 *   - -> checkpoint -> resume: the loaded parameters equal the written ones;
 *     asking another value is accepted (and applied) exactly for the
 *     resumable rows, and refused naming the parameter for the others;
 *   - an out-of-range value (derived from the row's range) on the command
 *     line of the real binary (argv[1]) exits 2 with one stderr line that
 *     names the option; a flag gets a bad scene value instead.
 */
#include "../check.h"
#include "../output/output_util.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "parse.h"
#include "pdla/params.h"
#include "scene.h"

static const char *pdla_exe;
static char tmpdir[64];

/* argv for cli_parse: "pdla --target 300 [--OPTION [VALUE]]". */
static int parse_with(const pdla_param_desc *d, const char *value, cli_options *o, char *err,
                      size_t errlen)
{
    char opt[80];
    snprintf(opt, sizeof opt, "--%s", d->option);
    char a0[] = "pdla", a1[] = "--target", a2[] = "300";
    char v[80];
    snprintf(v, sizeof v, "%s", value);
    char *argv[6] = {a0, a1, a2, opt, v, NULL};
    const int argc = d->type == PDLA_PT_FLAG ? 4 : 5;
    if (d->type == PDLA_PT_FLAG) argv[4] = NULL;
    return cli_parse(argc, argv, o, err, errlen);
}

static void check_row(const pdla_param_desc *d, uint32_t *seen)
{
    CHECK(d->bit && !(*seen & d->bit), "%s: bit %#x zero or shared", d->name, d->bit);
    *seen |= d->bit;
    CHECK(d->models & PDLA_MODEL_DLA, "%s: not a DLA parameter", d->name);
    CHECK(d->label && d->unit && d->help && d->group && d->example, "%s: a text is missing", d->name);
    CHECK((d->type == PDLA_PT_FLAG) == (d->metavar == NULL), "%s: metavar iff valued", d->name);
    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    CHECK(pdla_param_find(t, n, d->option) == d && pdla_param_find(t, n, d->name) == d,
          "%s: not found by its option or name", d->name);
}

static void check_help(const pdla_param_desc *d, const char *help)
{
    char want[96];
    snprintf(want, sizeof want, "  --%s%s", d->option, d->metavar ? " " : "");
    const char *at = strstr(help, want);
    CHECK(at != NULL, "%s: --help has no '%s'", d->name, want);
    if (at && d->show_default) {
        pdla_params def;
        pdla_params_default(&def);
        char v[64], dflt[96];
        pdla_param_format(d, &def, 0, v, sizeof v);
        snprintf(dflt, sizeof dflt, "(default %s)", v);
        const char *next = strstr(at + 3, "\n  -");
        const char *found = strstr(at, dflt);
        CHECK(found && (!next || found < next), "%s: --help does not show '%s'", d->name, dflt);
    }
}

/* The scene key sets the same value as the option; '_' spelling too. */
static void check_scene(const pdla_param_desc *d, const cli_options *by_cli)
{
    char text[160], key[64], err[512];
    snprintf(key, sizeof key, "%s", d->option);
    for (char *c = key; *c; c++)
        if (*c == '-') *c = '_';
    snprintf(text, sizeof text, "%s%s = %s\n", d->bit == PDLA_PARAM_TARGET ? "" : "target = 300\n",
             key, d->example);
    cli_options o;
    memset(&o, 0, sizeof o);
    pdla_params_default(&o.params);
    const int rc = scene_apply_text("t.scene", text, strlen(text), &o, err, sizeof err);
    CHECK(rc == CLI_PARSE_OK, "%s: scene '%s = %s' refused: %s", d->name, key, d->example, err);
    CHECK(pdla_param_equal(d, &o.params, &by_cli->params), "%s: scene and option differ", d->name);
}

/* /parameters/NAME of the file holds the value of p. */
static void check_h5(const pdla_param_desc *d, const char *path, const pdla_params *p)
{
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    CHECK(f >= 0, "%s: cannot open %s", d->name, path);
    if (f < 0) return;
    char want[64], got[64] = "";
    pdla_param_format(d, p, 1, want, sizeof want);
    if (d->type == PDLA_PT_CHOICE) {
        read_attr_str(f, "/parameters", d->name, got, sizeof got);
    } else if (d->type == PDLA_PT_REAL) {
        double x = 0;
        if (read_attr(f, "/parameters", d->name, H5T_NATIVE_DOUBLE, &x) == 0) snprintf(got, sizeof got, "%.17g", x);
    } else if (d->type == PDLA_PT_U64) {
        uint64_t u = 0;
        if (read_attr(f, "/parameters", d->name, H5T_NATIVE_UINT64, &u) == 0) snprintf(got, sizeof got, "%" PRIu64, u);
    } else {
        int i = 0;
        if (read_attr(f, "/parameters", d->name, H5T_NATIVE_INT, &i) == 0) snprintf(got, sizeof got, "%d", i);
    }
    CHECK(!strcmp(got, want), "%s: /parameters holds '%s', want '%s'", d->name, got, want);
    H5Fclose(f);
}

/* Checkpoint of e, then resumes: same parameters back; another value of d
 * applied if resumable, else refused naming it. */
static void check_checkpoint(const pdla_param_desc *d, pdla_engine *e, const pdla_params *p)
{
    char err[1024], dir[128], path[200];
    snprintf(dir, sizeof dir, "%s/ck-%s", tmpdir, d->name);
    CHECK(mkdir(dir, 0777) == 0, "%s: mkdir", d->name);
    CHECK(pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) == 0, "%s: %s", d->name, err);
    snprintf(path, sizeof path, "%s/%s", dir, PDLA_CHECKPOINT_NAME);

    pdla_engine *r = NULL;
    CHECK(pdla_checkpoint_load(&r, path, p, UINT32_MAX, NULL, err, sizeof err) == 0, "%s: same "
          "parameters refused: %s", d->name, err);
    if (r) {
        size_t n;
        const pdla_param_desc *t = pdla_param_table(&n);
        for (size_t i = 0; i < n; i++)
            CHECK(pdla_param_equal(&t[i], pdla_engine_params(r), p), "%s: resumed %s differs",
                  d->name, t[i].name);
        pdla_engine_destroy(r);
    }
    pdla_params other = *p; /* the default value of d: differs from the example */
    pdla_params def;
    pdla_params_default(&def);
    if (d->type == PDLA_PT_REAL) pdla_param_set_real(d, &other, pdla_param_get_real(d, &def));
    else pdla_param_set_u(d, &other, pdla_param_get_u(d, &def));
    r = NULL;
    err[0] = '\0';
    const int rc = pdla_checkpoint_load(&r, path, &other, d->bit, NULL, err, sizeof err);
    if (d->resumable) {
        CHECK(rc == 0, "%s: resumable, but a change was refused: %s", d->name, err);
        CHECK(r && pdla_param_equal(d, pdla_engine_params(r), &other), "%s: change not applied", d->name);
    } else {
        char want[96];
        snprintf(want, sizeof want, "%s is ", d->label);
        CHECK(rc == PDLA_EINVAL && strstr(err, want), "%s: not resumable, but rc %d '%s'", d->name,
              rc, err);
    }
    pdla_engine_destroy(r);
}

/* A value outside the row's range, as the command line would read it. */
static void bad_value(const pdla_param_desc *d, char *buf, size_t len)
{
    switch (d->type) {
    case PDLA_PT_CHOICE: snprintf(buf, len, "bogus"); break;
    case PDLA_PT_REAL:
        snprintf(buf, len, "%.17g", d->lo_open ? d->lo_r : d->lo_r > 0 ? d->lo_r / 2 : d->lo_r - 1);
        break;
    default:
        if (d->hi_u < (d->type == PDLA_PT_U64 ? UINT64_MAX : (uint64_t)INT32_MAX))
            snprintf(buf, len, "%" PRIu64, d->hi_u + 1);
        else if (d->lo_u > 0) snprintf(buf, len, "%" PRIu64, d->lo_u - 1);
        else snprintf(buf, len, "-1");
    }
}

/* The binary refuses an out-of-range value: exit 2, one line naming it. */
static void check_refused(const pdla_param_desc *d)
{
    char cmd[1024], v[64], errf[128];
    snprintf(errf, sizeof errf, "%s/err", tmpdir);
    if (d->type == PDLA_PT_FLAG) { /* no value on the command line: a bad scene value */
        char scene_path[128];
        snprintf(scene_path, sizeof scene_path, "%s/bad.scene", tmpdir);
        FILE *f = fopen(scene_path, "w");
        if (f) {
            fprintf(f, "%s = maybe\n", d->option);
            fclose(f);
        }
        snprintf(cmd, sizeof cmd, "'%s' --no-output -q --target 10 --scene '%s' 2>'%s'", pdla_exe,
                 scene_path, errf);
    } else {
        bad_value(d, v, sizeof v);
        snprintf(cmd, sizeof cmd, "'%s' --no-output -q --target 10 --%s '%s' 2>'%s'", pdla_exe,
                 d->option, v, errf);
        if (d->bit == PDLA_PARAM_TARGET)
            snprintf(cmd, sizeof cmd, "'%s' --no-output -q --target '%s' 2>'%s'", pdla_exe, v, errf);
    }
    const int st = system(cmd);
    CHECK(st != -1 && WIFEXITED(st) && WEXITSTATUS(st) == 2, "%s: '%s' exit status %d, want 2",
          d->name, cmd, WIFEXITED(st) ? WEXITSTATUS(st) : -1);
    char msg[2048] = "";
    size_t len = 0;
    FILE *f = fopen(errf, "r");
    if (f) {
        len = fread(msg, 1, sizeof msg - 1, f);
        msg[len] = '\0';
        fclose(f);
    }
    char want[80];
    snprintf(want, sizeof want, "%s", d->option);
    const char *nl = memchr(msg, '\n', len);
    CHECK(strstr(msg, want) && nl && nl == msg + len - 1,
          "%s: stderr '%s' is not one line naming %s", d->name, msg, want);
}

static void check_param(const pdla_param_desc *d, const char *help, uint32_t *seen)
{
    char err[1024];
    check_row(d, seen);
    check_help(d, help);

    cli_options o;
    const int rc = parse_with(d, d->example, &o, err, sizeof err);
    CHECK(rc == CLI_PARSE_OK, "%s: --%s %s refused: %s", d->name, d->option, d->example, err);
    if (rc != CLI_PARSE_OK) return;
    pdla_params def;
    pdla_params_default(&def);
    CHECK(!pdla_param_equal(d, &o.params, &def), "%s: example equals the default", d->name);
    CHECK(o.given & d->bit, "%s: option does not mark it given", d->name);
    check_scene(d, &o);

    pdla_engine *e = NULL;
    CHECK(pdla_engine_create(&e, &o.params, err, sizeof err) == 0, "%s: %s", d->name, err);
    if (!e) return;
    CHECK(pdla_engine_grow(e, 200, NULL, 0, NULL, err, sizeof err) == 0, "%s: %s", d->name, err);
    char h5[160];
    snprintf(h5, sizeof h5, "%s/%s.h5", tmpdir, d->name);
    const pdla_run_info info = {"test_param_table", 0, 0};
    CHECK(pdla_output_write(e, &info, h5, err, sizeof err) == 0, "%s: %s", d->name, err);
    check_h5(d, h5, &o.params);
    check_checkpoint(d, e, &o.params);
    pdla_engine_destroy(e);
    check_refused(d);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: test_param_table PDLA_EXE\n");
        return 2;
    }
    pdla_exe = argv[1];
    pdla_hdf5_quiet();
    snprintf(tmpdir, sizeof tmpdir, "/tmp/pdla-params-XXXXXX");
    CHECK(mkdtemp(tmpdir) != NULL, "mkdtemp");

    pdla_params def;
    pdla_params_default(&def);
    char err[512];
    CHECK(pdla_params_validate(&def, err, sizeof err) == 0, "defaults invalid: %s", err);
    const size_t hl = cli_help_text(NULL, 0, &def) + 1;
    char *help = malloc(hl);
    cli_help_text(help, hl, &def);

    size_t n;
    const pdla_param_desc *t = pdla_param_table(&n);
    CHECK(n >= 18, "table has %zu rows", n);
    uint32_t seen = 0, resumable = 0;
    for (size_t i = 0; i < n; i++) {
        check_param(&t[i], help, &seen);
        if (t[i].resumable) resumable |= t[i].bit;
    }
    CHECK(resumable == PDLA_PARAM_RESUMABLE, "resumable rows %#x, PDLA_PARAM_RESUMABLE %#x",
          resumable, (unsigned)PDLA_PARAM_RESUMABLE);
    free(help);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    CHECK(system(cmd) == 0, "cleanup");
    return check_finish();
}
