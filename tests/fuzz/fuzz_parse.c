/*
 * fuzz_parse.c - libFuzzer target for the `pdla` command line (cli_parse in
 * src/cli/parse.c): the input, split at NUL bytes, is the argument vector.
 * Every outcome must be one of the three documented ones, an error must be
 * one non-empty line, and a successful parse must hold valid parameters.
 * The single-value parsers get the first argument too. Built by scripts/fuzz.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "parse.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > 4096) return 0;
    char *buf = malloc(size + 1);
    if (!buf) return 0;
    memcpy(buf, data, size);
    buf[size] = '\0';
    char *argv[66];
    int argc = 0;
    argv[argc++] = (char *)"pdla";
    for (size_t i = 0; i <= size && argc < 64;) {
        argv[argc++] = buf + i;
        i += strlen(buf + i) + 1;
    }
    argv[argc] = NULL;

    uint64_t n;
    double x;
    (void)cli_parse_count(argv[1], &n);
    (void)cli_parse_real(argv[1], &x);
    (void)cli_parse_duration(argv[1], &x);

    cli_options o;
    char err[512];
    const int rc = cli_parse(argc, argv, &o, err, sizeof err);
    if (rc == CLI_PARSE_ERROR && (!err[0] || strchr(err, '\n'))) abort();
    if (rc == CLI_PARSE_OK && pdla_params_validate(&o.params, NULL, 0) != PDLA_OK) abort();
    if (rc == CLI_PARSE_OK && o.checkpoint_every < 0) abort();
    if (rc != CLI_PARSE_OK && rc != CLI_PARSE_EXIT && rc != CLI_PARSE_ERROR) abort();
    free(buf);
    return 0;
}
