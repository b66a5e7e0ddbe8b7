/*
 * fuzz_checkpoint.c - libFuzzer target for pdla_checkpoint_load: the input
 * is written to a file and loaded. Any outcome is fine except a crash, a
 * hang, a sanitizer report, a load that succeeds on a state that does not
 * write back (the loaded engine is re-checked by writing and loading it),
 * or a message that is empty or spans lines. Built by scripts/fuzz.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pdla/pdla.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[64];
    snprintf(path, sizeof path, "/tmp/pdla-fuzz-%ld.h5", (long)getpid());
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    if (fclose(f)) abort();
    pdla_engine *e = NULL;
    char err[1024] = "";
    const int rc = pdla_checkpoint_load(&e, path, NULL, 0, NULL, err, sizeof err);
    if (rc != PDLA_OK && (!err[0] || strchr(err, '\n') || e)) abort();
    if (rc == PDLA_OK) {
        /* What loads must also grow a little and survive a round trip. */
        char dir[64];
        snprintf(dir, sizeof dir, "/tmp/pdla-fuzz-%ld.d", (long)getpid());
        char cmd[128];
        snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
        if (system(cmd) != 0) abort();
        const pdla_params *p = pdla_engine_params(e);
        if (pdla_engine_count(e) < p->target && pdla_engine_count(e) < 5000)
            pdla_engine_grow(e, pdla_engine_count(e) + 10, NULL, 1000, NULL, err, sizeof err);
        if (pdla_checkpoint_write(e, dir, NULL, NULL, err, sizeof err) != PDLA_OK) abort();
        pdla_engine *r = NULL;
        if (pdla_checkpoint_load(&r, dir, NULL, 0, NULL, err, sizeof err) != PDLA_OK) abort();
        if (pdla_engine_count(r) != pdla_engine_count(e)) abort();
        pdla_engine_destroy(r);
    }
    pdla_engine_destroy(e);
    unlink(path);
    return 0;
}
