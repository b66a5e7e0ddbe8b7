/*
 * fuzz_scene.c - libFuzzer target for scene files (src/cli/scene.c read,
 * parse.c's scene_apply_text apply): the input is the scene's text. Every
 * outcome must be OK or ERROR, an error one non-empty line, and an accepted
 * scene must hold valid parameters. Built by scripts/fuzz.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "parse.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    cli_options o;
    memset(&o, 0, sizeof o);
    pdla_params_default(&o.params);
    char err[512] = "";
    const int rc = scene_apply_text("fuzz.scene", (const char *)data, size, &o, err, sizeof err);
    if (rc == CLI_PARSE_ERROR && (!err[0] || strchr(err, '\n'))) abort();
    if (rc == CLI_PARSE_OK && pdla_params_validate(&o.params, NULL, 0) != PDLA_OK) abort();
    if (rc != CLI_PARSE_OK && rc != CLI_PARSE_ERROR) abort();
    return 0;
}
