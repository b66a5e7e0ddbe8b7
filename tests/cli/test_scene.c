/*
 * test_scene.c - scene files (src/cli/scene.c) through cli_parse and
 * scene_apply_text: good scenes give the same options as the equivalent
 * command line, command-line options override scene keys, and every bad
 * scene (unknown or duplicate key, missing '=', empty or bad value, a value
 * out of range, a key that is not allowed) is refused with one line
 * "FILE:LINE: reason" naming the right line. The model a scene names
 * (scene_model, which picks the command that reads it). Also the worked
 * examples in runs/scenes/ (path given as argv[1]) parse.
 */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../check.h"
#include "parse.h"
#include "scene.h"

static char tmpdir[] = "/tmp/pdla-scene.XXXXXX";

static const char *write_scene(const char *name, const char *text)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    FILE *f = fopen(path, "w");
    if (!f) return NULL;
    fputs(text, f);
    fclose(f);
    return path;
}

static int parse_with(const char *scene_path, const char *const *extra, cli_options *o, char *err,
                      size_t errlen)
{
    char *argv[32];
    int argc = 0;
    argv[argc++] = (char *)"pdla";
    if (scene_path) {
        argv[argc++] = (char *)"--scene";
        argv[argc++] = (char *)scene_path;
    }
    for (; extra && *extra; extra++) argv[argc++] = (char *)*extra;
    argv[argc] = NULL;
    return cli_parse(argc, argv, o, err, errlen);
}

typedef struct bad_case {
    const char *text;
    const char *want; /* expected message after "FILE" */
} bad_case;

static const bad_case bad[] = {
    {"dim = 2\nfoo = 1\n", ":2: unknown key 'foo'"},
    {"dim = 2\n\n# c\ndim = 3\n", ":4: duplicate key 'dim' (first set on line 1)"},
    {"target = 5\nserial_until = 9\nserial-until = 9\n", ":3: duplicate key 'serial-until'"},
    {"target 1000\n", ":1: missing '='"},
    {"target =\n", ":1: missing value for 'target'"},
    {"target = # nothing\n", ":1: missing value for 'target'"},
    {" = 5\n", ":1: missing key before '='"},
    {"target = 10x\n", ":1: invalid value '10x' for --target: trailing characters"},
    {"dim = 2\ntarget = -5\n", ":2: invalid value '-5' for --target: negative"},
    {"birth-margin = abc\n", ":1: invalid value 'abc' for --birth-margin: not a number"},
    {"return = maybe\n", ":1: invalid value 'maybe' for --return: should be exact|kill"},
    {"exact-search = perhaps\n", ":1: invalid value 'perhaps' for exact-search: should be yes or no"},
    {"dim = 4\n", ":1: dim must be 2 or 3, got 4"},
    {"resolution = 8\ntarget = 10\neps = 6\n", ":3: eps must be in [2, resolution/2 = 4] units"},
    {"eps = 1\n", ":1: eps must be in [2, resolution/2 = 16] units, got 1"},
    {"return = kill\nkill-ratio = 1\n", ":2: kill ratio must be in (1, 1e6]"},
    {"threads = 1025\n", ":1: threads must be in [0, 1024]"},
    {"target = 2e12\n", ":1: target 2000000000000 exceeds the limit 2^40"},
    {"scene = other.scene\n", ":1: unknown key 'scene'"},
    {"help = yes\n", ":1: unknown key 'help'"},
    /* keys are spelled as the options are (the event model has kT): a key
     * that differs from one in letter case only is unknown, and named */
    {"Target = 5\n", ":1: unknown key 'Target' (keys are case-sensitive: 'target')"},
    {"SERIAL_UNTIL = 5\n", ":1: unknown key 'SERIAL-UNTIL' (keys are case-sensitive: 'serial-until')"},
    {"Help = yes\n", ":1: unknown key 'Help' (keys are the long options"},
    {"t\x01rget = 5\n", ":1: bad key 't?rget'"},
    {"tar get = 5\n", ":1: bad key 'tar get'"},
    {"out = -x\n", ":1: invalid value '-x' for --out"},
};

static void check_bad(void)
{
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const char *path = write_scene("bad.scene", bad[i].text);
        cli_options o;
        char err[1024], want[1024];
        const int rc = parse_with(path, NULL, &o, err, sizeof err);
        snprintf(want, sizeof want, "%s%s", path, bad[i].want);
        CHECK(rc == CLI_PARSE_ERROR, "case %zu: rc %d, want error", i, rc);
        CHECK(!strncmp(err, want, strlen(want)), "case %zu: got '%s', want prefix '%s'", i, err, want);
        CHECK(!strchr(err, '\n'), "case %zu: message has a newline: '%s'", i, err);
    }
    /* the same through the in-memory entry point, and binary junk */
    cli_options o;
    char err[512];
    memset(&o, 0, sizeof o);
    pdla_params_default(&o.params);
    CHECK(scene_apply_text("mem", "dim = 2\0x", 9, &o, err, sizeof err) == CLI_PARSE_ERROR &&
              strstr(err, "mem:1: contains a NUL byte"),
          "NUL byte: '%s'", err);
    char *big = malloc(SCENE_MAX_BYTES + 2);
    memset(big, '#', SCENE_MAX_BYTES + 1);
    big[SCENE_MAX_BYTES + 1] = '\0';
    CHECK(scene_apply_text("big", big, SCENE_MAX_BYTES + 1, &o, err, sizeof err) == CLI_PARSE_ERROR &&
              strstr(err, "big: too large"),
          "too large: '%s'", err);
    memset(big, 'x', 2000);
    memcpy(big, "seed = ", 7);
    big[2000] = '\0';
    CHECK(scene_apply_text("long", big, 2000, &o, err, sizeof err) == CLI_PARSE_ERROR &&
              strstr(err, "long:1: line too long"),
          "long line: '%s'", err);
    free(big);
    const char *none[] = {NULL};
    CHECK(parse_with("/nonexistent/x.scene", none, &o, err, sizeof err) == CLI_PARSE_ERROR &&
              strstr(err, "cannot open scene /nonexistent/x.scene"),
          "missing file: '%s'", err);
    CHECK(parse_with(tmpdir, none, &o, err, sizeof err) == CLI_PARSE_ERROR, "a directory: '%s'", err);
    const char *twice[] = {"--scene", "y.scene", NULL};
    const char *path = write_scene("ok.scene", "dim = 2\n");
    CHECK(parse_with(path, twice, &o, err, sizeof err) == CLI_PARSE_ERROR && strstr(err, "--scene given twice"),
          "twice: '%s'", err);
}

/* The model a scene names, for the command that is to read it: the lines
 * before a bad one count; an unreadable file names none. */
static void check_model(void)
{
    static const struct {
        const char *text, *want;
    } cases[] = {{"# c\nmodel = event\n", "event"},
                 {"model = dlca\nseed = 1\nseed = 2\n", "dlca"},
                 {"seed = 1\nmodel = dlca\nx\n", "dlca"},
                 {"x\nmodel = dlca\n", ""},
                 {"dim = 2\n", ""}};
    char model[16];
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        scene_model(write_scene("m.scene", cases[i].text), model, sizeof model);
        CHECK(!strcmp(model, cases[i].want), "model case %zu: '%s', want '%s'", i, model, cases[i].want);
    }
    const char *path = write_scene("nul.scene", "model = event\n");
    FILE *f = fopen(path, "a");
    fputs("seed = 1", f);
    fputc('\0', f);
    fputs("\n", f);
    for (int i = 0; i < 700; i++) fprintf(f, "%0100d\n", 0); /* also too large */
    fclose(f);
    scene_model(path, model, sizeof model);
    CHECK(!strcmp(model, "event"), "model before a NUL byte in a large file: '%s'", model);
    scene_model("/nonexistent/x.scene", model, sizeof model);
    CHECK(!strcmp(model, ""), "model of a missing file: '%s'", model);
    scene_model(tmpdir, model, sizeof model);
    CHECK(!strcmp(model, ""), "model of a directory: '%s'", model);
}

static void check_good(void)
{
    const char *path = write_scene("good.scene",
                                   "# a comment line\n"
                                   "   \n"
                                   "dim = 3          # trailing comment\n"
                                   "target=1.5k\n"
                                   "\tseed =  7\t\r\n"
                                   "resolution = 64\n"
                                   "eps = 8\n"
                                   "return = kill\n"
                                   "kill_ratio = 2.5\n"
                                   "exact-search = yes\n"
                                   "no-snap-contact = no\n"
                                   "threads = 3\n"
                                   "serial-until = 1e3\n"
                                   "rg-per-decade = 0\n"
                                   "out = some/dir\n"
                                   "stats-json = s.json\n"
                                   "quiet = true");  /* no final newline */
    cli_options o;
    char err[1024];
    int rc = parse_with(path, NULL, &o, err, sizeof err);
    CHECK(rc == CLI_PARSE_OK, "good scene: %s", err);
    const pdla_params *p = &o.params;
    CHECK(p->dim == 3 && p->target == 1500 && p->seed == 7 && p->resolution == 64 && p->eps == 8,
          "values: dim %d target %llu seed %llu D %d eps %d", p->dim, (unsigned long long)p->target,
          (unsigned long long)p->seed, p->resolution, p->eps);
    CHECK(p->return_mode == PDLA_RETURN_KILL && p->kill_ratio == 2.5 && p->exact_search == 1 &&
              p->snap_contact == 1 && p->threads == 3 && p->serial_until == 1000 && p->rg_per_decade == 0,
          "more values");
    CHECK(o.out_dir && !strcmp(o.out_dir, "some/dir") && o.stats_json && !strcmp(o.stats_json, "s.json") &&
              o.quiet == 1,
          "strings and flags: out '%s' json '%s'", o.out_dir ? o.out_dir : "(null)",
          o.stats_json ? o.stats_json : "(null)");

    /* The same run on the command line gives the same parameters. */
    cli_options c;
    const char *same[] = {"--dim", "3", "--target", "1.5k", "--seed", "7", "--resolution", "64",
                          "--eps", "8", "--return", "kill", "--kill-ratio", "2.5", "--exact-search",
                          "--threads", "3", "--serial-until", "1e3", "--rg-per-decade", "0", "--out",
                          "some/dir", "--stats-json", "s.json", "-q", NULL};
    rc = parse_with(NULL, same, &c, err, sizeof err);
    CHECK(rc == CLI_PARSE_OK && !memcmp(&c.params, &o.params, sizeof c.params),
          "scene and command line differ");

    /* Command-line flags override scene keys, before or after --scene. */
    const char *over[] = {"--target", "99", "--out", "elsewhere", "--eps", "4", NULL};
    rc = parse_with(path, over, &o, err, sizeof err);
    CHECK(rc == CLI_PARSE_OK && o.params.target == 99 && o.params.eps == 4 &&
              !strcmp(o.out_dir, "elsewhere") && o.params.dim == 3 && !strcmp(o.stats_json, "s.json"),
          "override: %s target %llu", err, (unsigned long long)o.params.target);
    char *argv[] = {"pdla", "--seed", "11", "--scene", (char *)path, "--resolution", "32", NULL};
    rc = cli_parse(7, argv, &o, err, sizeof err);
    CHECK(rc == CLI_PARSE_OK && o.params.seed == 11 && o.params.resolution == 32 && o.params.eps == 8,
          "override before --scene: %s seed %llu", err, (unsigned long long)o.params.seed);
    /* ... and the merged result is validated: eps 8 > 4/2. */
    const char *bad_merge[] = {"--resolution", "4", NULL};
    rc = parse_with(path, bad_merge, &o, err, sizeof err);
    CHECK(rc == CLI_PARSE_ERROR && strstr(err, "eps must be"), "merged validation: '%s'", err);
    /* --help wins without reading the scene. */
    const char *help[] = {"--help", NULL};
    rc = parse_with("/nonexistent.scene", help, &o, err, sizeof err);
    CHECK(rc == CLI_PARSE_EXIT && o.action == CLI_HELP, "--help with a scene: %d", rc);

    /* An empty scene (comments only) is the defaults. */
    path = write_scene("empty.scene", "# nothing\n\n");
    rc = parse_with(path, NULL, &o, err, sizeof err);
    pdla_params d;
    pdla_params_default(&d);
    CHECK(rc == CLI_PARSE_OK && !memcmp(&d, &o.params, sizeof d), "empty scene: %s", err);
}

/* Every .scene file in runs/scenes parses. */
static void check_examples(const char *dir)
{
    DIR *dp = opendir(dir);
    CHECK(dp != NULL, "cannot open %s", dir);
    if (!dp) return;
    int n = 0;
    struct dirent *de;
    while ((de = readdir(dp))) {
        const size_t l = strlen(de->d_name);
        if (l < 7 || strcmp(de->d_name + l - 6, ".scene")) continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, de->d_name);
        cli_options o;
        char err[1024];
        CHECK(parse_with(path, NULL, &o, err, sizeof err) == CLI_PARSE_OK, "%s: %s", path, err);
        n++;
    }
    closedir(dp);
    CHECK(n >= 4, "only %d example scenes in %s", n, dir);
}

int main(int argc, char **argv)
{
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    check_bad();
    check_model();
    check_good();
    if (argc > 1) check_examples(argv[1]);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd)) fprintf(stderr, "could not remove %s\n", tmpdir);
    return check_finish();
}
