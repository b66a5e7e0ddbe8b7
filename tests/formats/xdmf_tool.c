/*
 * xdmf_tool.c - the sidecar writers of include/pdla/xdmf.h called on their
 * own, for test_xdmf_text.py:
 *   xdmf_tool points XMF H5 DATASET N DIM UPD DISTANCE ROW_INDEX
 *       xdmf_write_points for the [N][DIM] DATASET of H5 (ROW_INDEX "-":
 *       none, else its name).
 *   xdmf_tool ensemble XMF H5 DATASET M N DIM UPD ARRIVAL
 *       xdmf_write_ensemble for M clusters of N rows; prints the peak RSS
 *       in KiB ("peak_rss_kib K", VmHWM) after it.
 * Exit 0, or 1 with the writer's message.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pdla/xdmf.h"

static unsigned long long num(const char *s)
{
    return strtoull(s, NULL, 10);
}

/* This process's peak RSS: VmHWM of /proc/self/status, which starts anew at
 * exec (getrusage's ru_maxrss keeps the parent's peak across fork and
 * exec: a Python parent's 40 MB). -1 when unreadable. */
static long peak_rss_kib(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kib = -1;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "VmHWM: %ld kB", &kib) == 1) break;
    if (f) fclose(f);
    return kib;
}

int main(int argc, char **argv)
{
    char err[512] = "";
    int rc = -1;
    if (argc == 10 && strcmp(argv[1], "points") == 0) {
        const xdmf_points p = {argv[3], argv[4], num(argv[5]), (int)num(argv[6]), (int)num(argv[7]),
                               (int)num(argv[8]), strcmp(argv[9], "-") ? argv[9] : NULL, NULL, 0};
        rc = xdmf_write_points(argv[2], &p, err, sizeof err);
    } else if (argc == 10 && strcmp(argv[1], "ensemble") == 0) {
        const xdmf_ensemble e = {argv[3], argv[4], num(argv[5]), num(argv[6]), (int)num(argv[7]),
                                 (int)num(argv[8]), (int)num(argv[9])};
        rc = xdmf_write_ensemble(argv[2], &e, err, sizeof err);
        if (rc == 0) printf("peak_rss_kib %ld\n", peak_rss_kib());
    } else {
        fprintf(stderr, "usage: xdmf_tool points XMF H5 DATASET N DIM UPD DISTANCE ROW_INDEX\n"
                        "       xdmf_tool ensemble XMF H5 DATASET M N DIM UPD ARRIVAL\n");
        return 2;
    }
    if (rc != 0) {
        fprintf(stderr, "xdmf_tool: %s\n", err);
        return 1;
    }
    return 0;
}
