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
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[64];
    snprintf(path, sizeof path, "/tmp/pdla-fuzz-%ld.h5", (long)getpid());
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    if (fclose(f)) abort();
    fuzz_dla_check(path);
    unlink(path);
    return 0;
}
