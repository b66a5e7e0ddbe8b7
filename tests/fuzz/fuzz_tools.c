/*
 * fuzz_tools.c - libFuzzer target for the tools' reader (src/cli/h5read.c):
 * the input is written to a file and given to pdla info, info --json,
 * analyze and render (a 64-pixel picture). Any outcome is fine except a
 * crash, a hang, a sanitizer report or memory past libFuzzer's -rss_limit_mb
 * (a file that declares more than it stores). Built by scripts/fuzz.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "tools.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int quiet;
    if (!quiet) { /* the tools' reports go to stdout: keep the log short */
        if (!freopen("/dev/null", "w", stdout)) abort();
        quiet = 1;
    }
    char path[64], png[64];
    snprintf(path, sizeof path, "/tmp/pdla-fuzz-tools-%ld.h5", (long)getpid());
    snprintf(png, sizeof png, "/tmp/pdla-fuzz-tools-%ld.png", (long)getpid());
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    if (fclose(f)) abort();
    char *info[] = {"info", path, NULL};
    char *json[] = {"info", "--json", path, NULL};
    char *analyze[] = {"analyze", path, NULL};
    char *render[] = {"render", path, "-o", png, "--force", "--size", "64", NULL};
    const int r[4] = {tool_info(2, info), tool_info(3, json), tool_analyze(2, analyze),
                      tool_render(7, render)};
    for (int i = 0; i < 4; i++)
        if (r[i] < 0 || r[i] > 2) abort(); /* exit statuses are 0, 1 or 2 */
    unlink(path);
    unlink(png);
    return 0;
}
