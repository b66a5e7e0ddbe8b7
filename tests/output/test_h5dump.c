/*
 * test_h5dump.c - a file from pdla_output_write() is readable by HDF5's own
 * h5dump tool: the header (-H), the format attribute's value, and the whole
 * positions dataset (which makes h5dump verify every chunk's Fletcher32).
 * Exits 77 (meson: skipped) when h5dump is not on PATH.
 */
#include <sys/wait.h>

#include "check.h"
#include "output_util.h"

/* 1 if an executable named `name` is on PATH. */
static int on_path(const char *name)
{
    const char *const path = getenv("PATH");
    if (!path) return 0;
    char dir[4096];
    for (const char *p = path; *p;) {
        const char *const end = strchr(p, ':');
        const size_t n = end ? (size_t)(end - p) : strlen(p);
        if (n > 0 && n < 3000) {
            snprintf(dir, sizeof dir, "%.*s/%s", (int)n, p, name);
            if (access(dir, X_OK) == 0) return 1;
        }
        if (!end) break;
        p = end + 1;
    }
    return 0;
}

/* Runs a shell command; its exit status, and its stdout into out if given. */
static int run(const char *cmd, char *out, size_t cap)
{
    FILE *const f = popen(cmd, "r");
    if (!f) return -1;
    size_t used = 0;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        if (out && used + 1 < cap) {
            const size_t take = n < cap - 1 - used ? n : cap - 1 - used;
            memcpy(out + used, buf, take);
            used += take;
        }
    if (out) out[used] = '\0';
    const int st = pclose(f);
    return st >= 0 && WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

int main(void)
{
    if (!on_path("h5dump")) {
        fprintf(stderr, "h5dump not on PATH: skipped\n");
        return 77;
    }
    char dir[4096], path[4200], cmd[8600], err[256];
    if (make_scratch(dir, sizeof dir) != 0) {
        fprintf(stderr, "cannot make a scratch directory\n");
        return 1;
    }
    join(path, sizeof path, dir, "h.h5");
    if (strchr(path, '\'')) { /* the commands below quote it with '' */
        fprintf(stderr, "scratch path %s holds a quote: skipped\n", path);
        remove_scratch(dir);
        return 77;
    }
    pdla_engine *const e = grow_engine(3, 500, 5, PDLA_RETURN_EXACT, 100);
    CHECK(e != NULL, "cannot grow");
    if (e) {
        const pdla_run_info info = {"pdla test", 0.5, 0};
        CHECK(pdla_output_write(e, &info, path, err, sizeof err) == 0, "write: %s", err);
        pdla_engine_destroy(e);

        static char out[1 << 20];
        CHECK(snprintf(cmd, sizeof cmd, "h5dump -H '%s' 2>&1", path) < (int)sizeof cmd,
              "command too long");
        CHECK(run(cmd, out, sizeof out) == 0, "h5dump -H failed:\n%s", out);
        CHECK(strstr(out, "DATASET \"positions\"") && strstr(out, "GROUP \"gyration\"") &&
                  strstr(out, "GROUP \"parameters\"") && strstr(out, "GROUP \"results\"") &&
                  strstr(out, "GROUP \"Code\""),
              "h5dump -H does not show the layout:\n%s", out);
        CHECK(snprintf(cmd, sizeof cmd, "h5dump -a /format '%s' 2>&1", path) < (int)sizeof cmd,
              "command too long");
        CHECK(run(cmd, out, sizeof out) == 0 && strstr(out, "\"pdla-cluster\""),
              "h5dump -a /format:\n%s", out);
        CHECK(snprintf(cmd, sizeof cmd, "h5dump -d /cluster/positions '%s' 2>&1", path) <
                  (int)sizeof cmd,
              "command too long");
        CHECK(run(cmd, out, sizeof out) == 0 && strstr(out, "( 500, 3 )"),
              "h5dump -d /cluster/positions failed:\n%.2000s", out);
    }
    remove_scratch(dir);
    return check_finish();
}
