/*
 * scene.h - scene files: one run described by `key = value` lines whose keys
 * are pdla's long options without "--" (`dim = 2`, `target = 1e6`,
 * `exact-search = yes`), read with `pdla --scene FILE`.
 *
 * Syntax, strictly: '#' starts a comment (to the end of the line); blank
 * lines are skipped; every other line is KEY = VALUE with blanks allowed
 * around both. Keys are option names ('_' may be written for '-'); each key
 * at most once; flags (options without a value) take yes|no|true|false|1|0,
 * and "no" leaves the default. `scene`, `help` and `version` are not keys.
 * Values are parsed by parse.c's own value parsers, so a scene accepts
 * exactly what the command line accepts (1e6, 10M, ...). Paths (`out`,
 * `stats-json`) are relative to the working directory, as on the command
 * line. A scene must be valid on its own (pdla_params_validate); options on
 * the command line are applied after it and override its keys.
 *
 * Every error is one line "FILE:LINE: reason" (or "FILE: reason" when no
 * single line is to blame); no I/O other than reading the file.
 */
#ifndef PDLA_CLI_SCENE_H
#define PDLA_CLI_SCENE_H
#include <stddef.h>

#include "parse.h"

/* Largest scene file and line, in bytes. */
#define SCENE_MAX_BYTES (64 * 1024)
#define SCENE_MAX_LINE 1024

/* Apply the scene in `path` to *o (already holding the defaults). Returns
 * CLI_PARSE_OK or CLI_PARSE_ERROR with the reason in err. */
int scene_apply(const char *path, cli_options *o, char *err, size_t errlen);

/* The same for a scene held in memory (`name` is used in messages only). */
int scene_apply_text(const char *name, const char *text, size_t len, cli_options *o, char *err,
                     size_t errlen);
#endif /* PDLA_CLI_SCENE_H */
