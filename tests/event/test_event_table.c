/*
 * test_event_table.c - walks the event model's rows of the parameter table
 * (ev_param_table, pdla/params.h) and checks every row end to end:
 *   walk  its scene key sets it (to the row's example, which must differ
 *         from the default); cluster.h5 /parameters holds the value; a
 *         checkpoint written and loaded gives it back bit for bit; the
 *         resume rule refuses a changed value unless the row is resumable
 *         (then takes it); a value out of its range is refused with one
 *         line naming the option.
 *   rows  prints "OPTION EXAMPLE BAD" per row for test_event_cli.sh, which
 *         checks --help and the CLI's exit 2 on each.
 */
#include <hdf5.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "pdla/event.h"

/* A text the row must refuse: past its range, or not of its type. */
static void bad_text(const pdla_param_desc *d, char *buf, size_t len)
{
    switch (d->type) {
    case PDLA_PT_REAL:
        if (d->lo_open) snprintf(buf, len, "%.17g", d->lo_r);
        else snprintf(buf, len, "%.17g", d->hi_r < 1e300 ? d->hi_r * 2 + 1 : -1.0);
        break;
    case PDLA_PT_CHOICE: snprintf(buf, len, "bogus"); break;
    case PDLA_PT_STRING: snprintf(buf, len, "x:y"); break; /* species: no COUNT */
    default:
        if (d->hi_u < UINT32_MAX) snprintf(buf, len, "%" PRIu64, d->hi_u + 1);
        else if (d->lo_u > 0) snprintf(buf, len, "%" PRIu64, d->lo_u - 1);
        else snprintf(buf, len, "-1");
        break;
    }
}

static void print_rows(void)
{
    size_t n;
    const pdla_param_desc *t = ev_param_table(&n);
    for (size_t i = 0; i < n; i++) {
        char bad[64];
        bad_text(&t[i], bad, sizeof bad);
        printf("%s %s %s\n", t[i].option, t[i].example, bad);
    }
}

/* The run every row's example goes into: small, short, with a seed. */
static void base(ev_params *p)
{
    ev_params_default(p);
    p->particles = 200;
    p->packing = 0.05;
    p->max_events = 2000;
    p->series_dt = 0.25;
}

/* /parameters/NAME of PATH equals row d's value in p (reals bitwise). */
static int h5_param_equal(const char *path, const pdla_param_desc *d, const ev_params *p)
{
    const hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return 0;
    const hid_t a = H5Aopen_by_name(f, "parameters", d->name, H5P_DEFAULT, H5P_DEFAULT);
    int ok = 0;
    if (a >= 0) {
        char want[300];
        pdla_param_format(d, p, 1, want, sizeof want);
        if (d->type == PDLA_PT_REAL) {
            double v;
            ok = H5Aread(a, H5T_NATIVE_DOUBLE, &v) >= 0 && v == pdla_param_get_real(d, p);
        } else if (d->type == PDLA_PT_U64) {
            uint64_t v;
            ok = H5Aread(a, H5T_NATIVE_UINT64, &v) >= 0 && v == pdla_param_get_u(d, p);
        } else if (d->type == PDLA_PT_INT || d->type == PDLA_PT_FLAG) {
            int v;
            ok = H5Aread(a, H5T_NATIVE_INT, &v) >= 0 && v == (int)pdla_param_get_i(d, p);
        } else {
            const hid_t ty = H5Aget_type(a);
            const size_t sz = H5Tget_size(ty);
            char *v = calloc(sz + 1, 1);
            ok = v && H5Aread(a, ty, v) >= 0 && !strcmp(v, want[0] ? want : "(none)");
            free(v);
            H5Tclose(ty);
        }
        H5Aclose(a);
    }
    H5Fclose(f);
    return ok;
}

static void walk_row(const pdla_param_desc *t, size_t n, size_t i, const char *dir)
{
    const pdla_param_desc *d = &t[i];
    char key[64], err[400];
    snprintf(key, sizeof key, "%s", d->option);
    for (char *c = key; *c; c++)
        if (*c == '-') *c = '_';
    ev_params p, def;
    base(&p);
    def = p;
    CHECK(ev_param_set(&p, key, d->example, err, sizeof err) == 0, "%s: scene key: %s", key, err);
    CHECK(!pdla_param_equal(d, &p, &def), "%s: example %s is the default", d->option, d->example);
    ev_sim *s = ev_create(&p, err, sizeof err);
    CHECK(s != NULL, "%s = %s: %s", d->option, d->example, err);
    if (!s) return;
    ev_series ser = {0};
    CHECK(ev_run_series(s, &ser, NULL) >= 0, "%s: run", d->option);
    char path[512];
    snprintf(path, sizeof path, "%s/cluster.h5", dir);
    CHECK(ev_write_h5(s, &ser, path, "test", 0, err, sizeof err) == 0, "%s: h5: %s", d->option, err);
    for (size_t k = 0; k < n; k++)
        CHECK(h5_param_equal(path, &t[k], &p), "%s: /parameters/%s differs", d->option, t[k].name);
    CHECK(ev_checkpoint_write(s, &ser, dir, "test", err, sizeof err) == 0, "%s: ckpt: %s",
          d->option, err);
    ev_series_free(&ser);
    ev_free(s);
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    ev_series ser2 = {0};
    ev_sim *r = ev_checkpoint_load(path, &ser2, err, sizeof err);
    CHECK(r != NULL, "%s: load: %s", d->option, err);
    if (!r) return;
    ev_params *got = ev_params_of(r);
    for (size_t k = 0; k < n; k++)
        CHECK(pdla_param_equal(&t[k], got, &p), "%s: checkpoint's %s differs", d->option, t[k].name);
    /* asking the checkpoint's run for the default of this row */
    const int rc = pdla_param_check_asked(t, n, d->bit, got, &def, err, sizeof err);
    if (!rc) pdla_param_apply_resumable(t, n, d->bit, got, &def);
    if (d->resumable)
        CHECK(rc == 0 && pdla_param_equal(d, got, &def), "%s: resumable, not taken", d->option);
    else
        CHECK(rc != 0 && strstr(err, d->label) && !strchr(err, '\n'),
              "%s: change on resume not refused: %s", d->option, err);
    ev_series_free(&ser2);
    ev_free(r);
    /* out of range or not of the type: refused, naming the option */
    char bad[64];
    bad_text(d, bad, sizeof bad);
    ev_params q = def;
    const int set = ev_param_set(&q, d->option, bad, err, sizeof err);
    int chk = set ? set : ev_params_check(&q, err, sizeof err);
    if (!chk) {
        /* a file named by the row (--seeds) is read when the run is built */
        ev_sim *b = ev_create(&q, err, sizeof err);
        chk = b == NULL;
        ev_free(b);
    }
    CHECK(chk != 0 && strstr(err, d->option) && !strchr(err, '\n'), "%s %s: not refused: %s",
          d->option, bad, chk ? err : "accepted");
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "rows")) {
        print_rows();
        return 0;
    }
    char dir[] = "/tmp/pdla-evtable-XXXXXX";
    if (!mkdtemp(dir) || chdir(dir)) return 1;
    /* the seeds row's example file: one seed inside the base run's box */
    FILE *sf = fopen("seeds.txt", "w");
    if (!sf || fputs("20 20 1\n", sf) < 0 || fclose(sf)) return 1;
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    size_t n;
    const pdla_param_desc *t = ev_param_table(&n);
    for (size_t i = 0; i < n; i++) {
        CHECK(t[i].models == PDLA_MODEL_EVENT && t[i].bit && !(t[i].bit & (t[i].bit - 1)),
              "%s: models or bit", t[i].name);
        for (size_t k = 0; k < i; k++)
            CHECK(t[k].bit != t[i].bit && strcmp(t[k].option, t[i].option), "%s: bit or option twice",
                  t[i].name);
        walk_row(t, n, i, dir);
    }
    char cmd[600];
    if (chdir("/")) return 1;
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
    return check_finish();
}
