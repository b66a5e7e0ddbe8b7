/*
 * scene.h - scene files: one run described by `key = value` lines whose keys
 * are pdla's long options without "--" (`dim = 2`, `target = 1e6`,
 * `exact-search = yes`), read with `pdla --scene FILE`.
 *
 * Syntax, strictly: '#' starts a comment (to the end of the line); blank
 * lines are skipped; every other line is KEY = VALUE with blanks allowed
 * around both. Keys are option names ('_' may be written for '-'), spelled
 * as the option is: letters keep their case (the event model's `kT`), and
 * the command that applies the scene matches them case-sensitively, so
 * `Target` is an unknown key (scene_unknown_key says which key differs only
 * in case). Each key at most once; flags (options without a value) take
 * yes|no|true|false|1|0, and "no" leaves the default. `scene`, `help` and
 * `version` are not keys.
 * This file only reads and splits; parse.c's scene_apply applies the
 * entries with the command line's own value parsers, so a scene accepts
 * exactly what the command line accepts (1e6, 10M, ...). Paths (`out`,
 * `stats-json`) are relative to the working directory, as on the command
 * line. A scene must be valid on its own (pdla_params_validate); options on
 * the command line are applied after it and override its keys.
 *
 * Every error is one line "FILE:LINE: reason" (or "FILE: reason" when no
 * single line is to blame); no I/O other than reading the file. Nothing
 * here knows the options: the scene reader sits below the option table.
 * All three models' commands (DLA: parse.c; DLCA: dlca_cmd.c; event:
 * event_cmd.c) read their scenes here, so a scene is refused for the same
 * reasons with the same words whatever its model.
 */
#ifndef PDLA_CLI_SCENE_H
#define PDLA_CLI_SCENE_H
#include <stddef.h>

/* Largest scene file and line, in bytes. */
#define SCENE_MAX_BYTES (64 * 1024)
#define SCENE_MAX_LINE 1024

typedef struct scene_entry {
    char key[64];      /* as written but '_' -> '-' (case kept) */
    const char *value; /* into the scene's buffer */
    int line;
} scene_entry;

/* A scene split into entries; the values point into buf ([0, len)). */
typedef struct scene {
    char *buf;
    size_t len;
    scene_entry *entries;
    int n;
} scene;

/* Read and split a scene held in memory (`name` is used in messages only)
 * or in the file `path`: 0, or -1 with the reason in err (and *sc empty).
 * Syntax errors, over-long lines and duplicate keys are found here. */
int scene_read_text(const char *name, const char *text, size_t len, scene *sc, char *err,
                    size_t errlen);
int scene_read_file(const char *path, scene *sc, char *err, size_t errlen);
void scene_free(scene *sc);

/* The entry whose key is `key` (exact), or NULL. */
const scene_entry *scene_find(const scene *sc, const char *key);

/* The value of the `model` key of the scene file `path` into model[len]
 * ("" when it has none, or the file cannot be read): which command is to
 * read the scene. The lines before a line the reader refuses count, so a
 * scene that names its model and then has a bad line goes to that model's
 * command, which reports the line; one too large is read for this up to
 * SCENE_MAX_BYTES. */
void scene_model(const char *path, char *model, size_t len);

/* "unknown key 'KEY'" and then `tail`, into err: the commands' one message
 * for a key they do not take. `near` is the key the command does take that
 * differs from KEY in letter case only (NULL: none); then the tail is
 * "(keys are case-sensitive: 'NEAR')". Returns -1. */
int scene_unknown_key(const char *key, const char *near, const char *tail, char *err, size_t errlen);
/* Does a differ from b in letter case only ('_' and '-' the same)? */
int scene_same_but_case(const char *a, const char *b);
#endif /* PDLA_CLI_SCENE_H */
