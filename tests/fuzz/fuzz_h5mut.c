/*
 * fuzz_h5mut.c - libFuzzer targets that load real files forged field by
 * field (h5mut.h): the input is a script of edits to one of the seed files
 * of $FUZZ_H5_SEEDS. Built by scripts/fuzz once per MUT_TARGET:
 *   1 pdla_checkpoint_load (DLA)   2 ev_checkpoint_load (event)
 *   3 dlca_checkpoint_load (DLCA)  4 the tools (info, info --json, analyze,
 *                                    render) on any model's cluster.h5
 * Any outcome is fine except a crash, a hang, a sanitizer report, memory
 * past -rss_limit_mb, an error message that is empty or spans lines, or a
 * loaded state that does not run a little, write back and load again.
 * H5MUT_KEEP=FILE keeps a copy of the forged file, to replay a failure.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#if MUT_TARGET == 1
#include "pdla/pdla.h"
#elif MUT_TARGET == 2
#include "pdla/event.h"
#elif MUT_TARGET == 3
#include "pdla/dlca.h"
#else
#include "tools.h"
#endif
#include "h5mut.h" /* after pdla.h: fuzz_util.h then has fuzz_dla_check */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#if MUT_TARGET == 1
static void check(const char *path) { fuzz_dla_check(path); }
#elif MUT_TARGET == 2
static void check(const char *path)
{
    ev_series ser = {0};
    char err[1024] = "";
    ev_sim *s = ev_checkpoint_load(path, &ser, err, sizeof err);
    if (!s) {
        fuzz_one_line(err);
        ev_series_free(&ser);
        return;
    }
    ev_stats st;
    ev_get_stats(s, &st);
    ev_params *p = ev_params_of(s);
    p->max_events = st.events + 2000; /* a little more, whatever the stops were */
    p->t_max = 0;
    p->max_stuck = 0;
    ev_run(s, NULL);
    char dir[64];
    fuzz_scratch_dir(dir, sizeof dir, "mut");
    if (ev_checkpoint_write(s, &ser, dir, "fuzz", err, sizeof err) != 0) {
        fprintf(stderr, "write back: %s\n", err);
        abort();
    }
    char again[128];
    snprintf(again, sizeof again, "%s/checkpoint.h5", dir);
    ev_series ser2 = {0};
    ev_sim *r = ev_checkpoint_load(again, &ser2, err, sizeof err);
    if (!r) {
        fprintf(stderr, "reload: %s\n", err);
        abort();
    }
    ev_free(r);
    ev_series_free(&ser2);
    ev_free(s);
    ev_series_free(&ser);
}
#elif MUT_TARGET == 3
static void check(const char *path)
{
    dlca_sim *s = NULL;
    char err[1024] = "";
    if (dlca_checkpoint_load(&s, path, err, sizeof err) != 0) {
        fuzz_one_line(err);
        if (s) abort();
        return;
    }
    dlca_run(s, 2000);
    char dir[64];
    fuzz_scratch_dir(dir, sizeof dir, "mut");
    char again[128];
    snprintf(again, sizeof again, "%s/checkpoint.h5", dir);
    if (dlca_checkpoint_write(s, again, err, sizeof err) != 0) {
        fprintf(stderr, "write back: %s\n", err);
        abort();
    }
    dlca_sim *r = NULL;
    if (dlca_checkpoint_load(&r, again, err, sizeof err) != 0) {
        fprintf(stderr, "reload: %s\n", err);
        abort();
    }
    dlca_destroy(r);
    dlca_destroy(s);
}
#else
static void check(const char *path)
{
    static int quiet;
    if (!quiet) { /* the tools' reports go to stdout: keep the log short */
        if (!freopen("/dev/null", "w", stdout)) abort();
        quiet = 1;
    }
    char png[64];
    snprintf(png, sizeof png, "/tmp/pdla-fuzz-mut-%ld.png", (long)getpid());
    char *info[] = {"info", (char *)path, NULL};
    char *json[] = {"info", "--json", (char *)path, NULL};
    char *analyze[] = {"analyze", (char *)path, NULL};
    char *render[] = {"render", (char *)path, "-o", png, "--force", "--size", "64", NULL};
    const int r[4] = {tool_info(2, info), tool_info(3, json), tool_analyze(2, analyze),
                      tool_render(7, render)};
    for (int i = 0; i < 4; i++)
        if (r[i] < 0 || r[i] > 2) abort(); /* exit statuses are 0, 1 or 2 */
    unlink(png);
}
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[64];
    snprintf(path, sizeof path, "/tmp/pdla-fuzz-mut-%ld.h5", (long)getpid());
    if (h5mut_make(data, size, path) != 0) return 0;
    /* H5MUT_KEEP=FILE: keep a copy of the forged file (to replay a crash) */
    const char *keep = getenv("H5MUT_KEEP");
    if (keep) {
        char cmd[512];
        snprintf(cmd, sizeof cmd, "cp %s %s", path, keep);
        if (system(cmd) != 0) abort();
    }
    check(path);
    unlink(path);
    return 0;
}
