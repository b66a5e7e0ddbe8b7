/*
 * fuzz_textfiles.c - libFuzzer target for the models' text input files:
 * DLCA start files (dlca_read_start, then dlca_create_sites) and event seed
 * files (ev_create with --seeds), in 2D and 3D. The input's first byte
 * picks the reader and dimension, the rest is the file. Every outcome must
 * be a success or one non-empty line; a start file that reads must make a
 * simulation. Built by scripts/fuzz.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pdla/dlca.h"
#include "pdla/event.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void dlca_start(const char *path, int dim)
{
    dlca_params p;
    dlca_params_default(&p);
    p.dim = dim;
    for (int a = 0; a < dim; a++) p.box[a] = dim == 2 ? 32 : 12;
    uint32_t *sites = NULL;
    uint64_t n = 0;
    char err[1024] = "";
    if (dlca_read_start(path, &p, &sites, &n, err, sizeof err) != 0) {
        fuzz_one_line(err);
        free(sites);
        return;
    }
    dlca_sim *s = NULL;
    if (dlca_create_sites(&s, &p, sites, n, err, sizeof err) != 0) fuzz_one_line(err);
    else dlca_run(s, 200);
    dlca_destroy(s);
    free(sites);
}

static void event_seeds(const char *path, int dim)
{
    ev_params p;
    ev_params_default(&p);
    p.dim = dim;
    p.particles = 40;
    p.packing = 0.02;
    p.max_events = 500;
    snprintf(p.seeds, sizeof p.seeds, "%s", path);
    char err[1024] = "";
    ev_sim *s = ev_create(&p, err, sizeof err);
    if (!s) {
        fuzz_one_line(err);
        return;
    }
    ev_run(s, NULL);
    ev_free(s);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > 8192) return 0;
    char path[64];
    snprintf(path, sizeof path, "/tmp/pdla-fuzz-text-%ld.txt", (long)getpid());
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size > 1 && fwrite(data + 1, 1, size - 1, f) != size - 1) abort();
    if (fclose(f)) abort();
    const int dim = data[0] & 1 ? 3 : 2;
    if (data[0] & 2) event_seeds(path, dim);
    else dlca_start(path, dim);
    unlink(path);
    return 0;
}
